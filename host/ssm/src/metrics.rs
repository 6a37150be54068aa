//! Error metrics and spectra: SSMLearn's NMTE, NMTE after dynamic-time-warping alignment,
//! and FFT amplitude spectra.
//!
//! NMTE (normalized mean trajectory error) follows SSMLearn's
//! `src/utils/computeTrajectoryErrors.m` (haller-group/SSMLearn):
//! `mean(vecnorm(yPred - yTrue)) / max(vecnorm(yTrue))`, i.e. the mean over samples of the
//! Euclidean error norm divided by the largest norm of the true trajectory.

// `%` instead of `is_multiple_of`: the workspace MSRV is 1.85.
#![allow(clippy::manual_is_multiple_of)]

use serde::{Deserialize, Serialize};

/// NMTE of a predicted trajectory against the truth; points are rows of `dim` values
/// stored contiguously (`pred.len() == truth.len()`, a multiple of `dim`). Returns `None`
/// for empty input, mismatched lengths, non-finite values or an all-zero truth. Values so
/// small or large that their squares underflow or overflow (1e-300, 1e200) are handled by
/// rescaling: the NMTE is scale-invariant.
pub fn nmte(pred: &[f64], truth: &[f64], dim: usize) -> Option<f64> {
    if let Some(v) = nmte_plain(pred, truth, dim) {
        return Some(v);
    }
    let s = rescale_factor(pred, truth)?;
    let scaled = |v: &[f64]| v.iter().map(|x| x / s).collect::<Vec<f64>>();
    nmte_plain(&scaled(pred), &scaled(truth), dim)
}

/// The largest magnitude of `a` and `b` when every value is finite and one is non-zero.
fn rescale_factor(a: &[f64], b: &[f64]) -> Option<f64> {
    let mut s = 0.0f64;
    for v in a.iter().chain(b) {
        if !v.is_finite() {
            return None;
        }
        s = s.max(v.abs());
    }
    (s > 0.0).then_some(s)
}

/// [`nmte`] without rescaling: `None` also when the result is not a finite number.
fn nmte_plain(pred: &[f64], truth: &[f64], dim: usize) -> Option<f64> {
    if dim == 0 || pred.len() != truth.len() || truth.is_empty() || truth.len() % dim != 0 {
        return None;
    }
    let n = truth.len() / dim;
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut err = 0.0;
    let mut max_true: f64 = 0.0;
    for (p, t) in pred.chunks_exact(dim).zip(truth.chunks_exact(dim)) {
        let e: f64 = p.iter().zip(t).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
        err += e;
        max_true = max_true.max(norm(t));
    }
    let v = err / n as f64 / max_true;
    (max_true > 0.0 && v.is_finite()).then_some(v)
}

/// Result of a DTW alignment without the path.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DtwCost {
    /// Sum of point distances along the optimal warping path.
    pub total: f64,
    /// Number of aligned pairs on that path (ties broken towards the shorter path).
    pub path_len: usize,
}

/// Classic DTW between point sequences `a` (n points) and `b` (m points) of dimension
/// `dim`, local cost the Euclidean distance, steps (1,0), (0,1), (1,1), both ends pinned.
/// `band`: Sakoe-Chiba half-width in samples around the rescaled diagonal
/// `j ~ i * (m-1)/(n-1)`; `None` = unconstrained. O(n*m) time (O(n*band) with a band),
/// O(m) memory (two rolling rows of cost and path length). Returns `None` on empty input,
/// bad lengths, or when the band admits no path.
pub fn dtw(a: &[f64], b: &[f64], dim: usize, band: Option<usize>) -> Option<DtwCost> {
    if dim == 0 || a.is_empty() || b.is_empty() || a.len() % dim != 0 || b.len() % dim != 0 {
        return None;
    }
    let (n, m) = (a.len() / dim, b.len() / dim);
    let dist = |i: usize, j: usize| {
        a[i * dim..(i + 1) * dim]
            .iter()
            .zip(&b[j * dim..(j + 1) * dim])
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt()
    };
    let window = |i: usize| -> (usize, usize) {
        match band {
            None => (0, m - 1),
            Some(w) => {
                let c = if n > 1 { (i as f64 * (m - 1) as f64 / (n - 1) as f64).round() as usize } else { 0 };
                (c.saturating_sub(w), (c + w).min(m - 1))
            }
        }
    };
    const INF: f64 = f64::INFINITY;
    let mut prev = vec![(INF, 0usize); m];
    let mut cur = vec![(INF, 0usize); m];
    for i in 0..n {
        let (lo, hi) = window(i);
        cur.iter_mut().for_each(|c| *c = (INF, 0));
        for j in lo..=hi {
            let best = if i == 0 && j == 0 {
                (0.0, 0)
            } else {
                let mut best = (INF, 0usize);
                let mut consider = |c: (f64, usize)| {
                    if c.0 < best.0 || (c.0 == best.0 && c.1 < best.1) {
                        best = c;
                    }
                };
                if i > 0 {
                    consider(prev[j]);
                    if j > 0 {
                        consider(prev[j - 1]);
                    }
                }
                if j > 0 {
                    consider(cur[j - 1]);
                }
                best
            };
            if best.0.is_finite() {
                cur[j] = (best.0 + dist(i, j), best.1 + 1);
            }
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    let (total, path_len) = prev[m - 1];
    total.is_finite().then_some(DtwCost { total, path_len })
}

/// NMTE after DTW alignment: mean distance along the optimal warping path divided by the
/// max norm of the truth (`b`); rescaled like [`nmte`] when the squares under- or overflow.
pub fn nmte_dtw(pred: &[f64], truth: &[f64], dim: usize, band: Option<usize>) -> Option<f64> {
    if let Some(v) = nmte_dtw_plain(pred, truth, dim, band) {
        return Some(v);
    }
    let s = rescale_factor(pred, truth)?;
    let scaled = |v: &[f64]| v.iter().map(|x| x / s).collect::<Vec<f64>>();
    nmte_dtw_plain(&scaled(pred), &scaled(truth), dim, band)
}

fn nmte_dtw_plain(pred: &[f64], truth: &[f64], dim: usize, band: Option<usize>) -> Option<f64> {
    let c = dtw(pred, truth, dim, band)?;
    let max_true = truth.chunks_exact(dim).map(|t| t.iter().map(|x| x * x).sum::<f64>().sqrt()).fold(0.0, f64::max);
    let v = c.total / c.path_len as f64 / max_true;
    (max_true > 0.0 && c.path_len > 0 && v.is_finite()).then_some(v)
}

/// Complex number as (re, im) for the FFT.
type C = (f64, f64);

fn cmul(a: C, b: C) -> C {
    (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
}

/// In-place iterative radix-2 FFT (`x.len()` a power of two); `inverse` flips the sign of
/// the exponent (no 1/n scaling).
fn fft_pow2(x: &mut [C], inverse: bool) {
    let n = x.len();
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            x.swap(i, j);
        }
    }
    let sign = if inverse { 1.0 } else { -1.0 };
    let mut len = 2;
    while len <= n {
        let ang = sign * 2.0 * std::f64::consts::PI / len as f64;
        for start in (0..n).step_by(len) {
            for k in 0..len / 2 {
                let w = ((ang * k as f64).cos(), (ang * k as f64).sin());
                let u = x[start + k];
                let v = cmul(x[start + k + len / 2], w);
                x[start + k] = (u.0 + v.0, u.1 + v.1);
                x[start + k + len / 2] = (u.0 - v.0, u.1 - v.1);
            }
        }
        len <<= 1;
    }
}

/// DFT `X_k = sum_n x_n exp(-2 pi i k n / N)` of any length: radix-2 when N is a power of
/// two, Bluestein's chirp-z algorithm otherwise. O(N log N).
pub fn dft(x: &[C]) -> Vec<C> {
    let n = x.len();
    if n <= 1 {
        return x.to_vec();
    }
    if n.is_power_of_two() {
        let mut v = x.to_vec();
        fft_pow2(&mut v, false);
        return v;
    }
    // Bluestein: X_k = conj(w_k) * sum_n (x_n conj(w_n)) w_{k-n}, w_k = exp(i pi k^2 / N).
    let m = (2 * n - 1).next_power_of_two();
    let chirp: Vec<C> = (0..n)
        .map(|k| {
            // k^2 mod 2N keeps the angle small and exact.
            let kk = ((k as u128 * k as u128) % (2 * n as u128)) as f64;
            let a = std::f64::consts::PI * kk / n as f64;
            (a.cos(), a.sin())
        })
        .collect();
    let mut a = vec![(0.0, 0.0); m];
    for k in 0..n {
        a[k] = cmul(x[k], (chirp[k].0, -chirp[k].1));
    }
    let mut b = vec![(0.0, 0.0); m];
    b[0] = chirp[0];
    for k in 1..n {
        b[k] = chirp[k];
        b[m - k] = chirp[k];
    }
    fft_pow2(&mut a, false);
    fft_pow2(&mut b, false);
    for (u, v) in a.iter_mut().zip(&b) {
        *u = cmul(*u, *v);
    }
    fft_pow2(&mut a, true);
    (0..n).map(|k| cmul((a[k].0 / m as f64, a[k].1 / m as f64), (chirp[k].0, -chirp[k].1))).collect()
}

/// Single-sided amplitude spectrum of a real signal sampled at `dt`: frequencies
/// `k / (N dt)` in Hz for `k = 0..=N/2`, amplitudes `|X_k| / N` at DC (and at Nyquist for
/// even N) and `2 |X_k| / N` elsewhere, so a sinusoid `A cos(2 pi f t)` on a bin reads `A`.
pub fn amplitude_spectrum(x: &[f64], dt: f64) -> (Vec<f64>, Vec<f64>) {
    let n = x.len();
    if n == 0 {
        return (Vec::new(), Vec::new());
    }
    let spec = dft(&x.iter().map(|&v| (v, 0.0)).collect::<Vec<_>>());
    let half = n / 2;
    let mut f = Vec::with_capacity(half + 1);
    let mut amp = Vec::with_capacity(half + 1);
    for (k, s) in spec.iter().enumerate().take(half + 1) {
        let mag = s.0.hypot(s.1) / n as f64;
        let edge = k == 0 || (n % 2 == 0 && k == half);
        f.push(k as f64 / (n as f64 * dt));
        amp.push(if edge { mag } else { 2.0 * mag });
    }
    (f, amp)
}
