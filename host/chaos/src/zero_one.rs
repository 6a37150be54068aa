//! The 0-1 test for chaos (Gottwald & Melbourne 2004; the correlation method and the
//! modified mean-square displacement of their 2009 implementation paper).
//!
//! For a scalar series `phi(j)` and a frequency `c`, the translation variables
//! `p_c(n) = sum_{j<=n} phi(j) cos(j c)`, `q_c(n) = sum_{j<=n} phi(j) sin(j c)` are bounded for
//! regular (periodic, quasi-periodic) dynamics and behave like a Brownian motion for chaotic
//! dynamics. Their mean-square displacement `M_c(n)` minus the oscillating term
//! `V_osc(c, n) = (E phi)^2 (1 - cos n c) / (1 - cos c)` is `D_c(n)`; `K_c` is the
//! correlation of `D_c(n)` with `n` for `n = 1..n_cut`; the result is the median of `K_c` over
//! random `c` in `(pi/5, 4 pi/5)` (away from the resonances at 0 and pi). `K ~ 1` means
//! diffusive growth (chaos), `K ~ 0` bounded (regular).
//!
//! Oversampled data (a flow sampled much faster than its correlation time) look regular over
//! the short lags the test reads; Gottwald & Melbourne's remedy, used here, is to coarsen the
//! series first: [`ZeroOneParams::stride`] keeps every `stride`-th sample (choose it near the
//! first zero of the autocorrelation, [`crate::first_zero_crossing`]).
//!
//! What the test cannot do: it measures diffusion of `(p_c, q_c)`, not exponential
//! separation. A regular system driven by noise (a torus whose phases diffuse) also makes
//! `(p_c, q_c)` diffuse and gets `K ~ 1` (see the tests); the test tells regular from
//! irregular, not chaos from noise.

use crate::rng::SplitMix;
use crate::{ChaosError, Result, at_least, check_finite};

/// Settings of [`zero_one_test`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ZeroOneParams {
    /// Number of random frequencies `c` (Gottwald-Melbourne use 100).
    pub n_c: usize,
    /// Seed of the frequency draw.
    pub seed: u64,
    /// Keep every `stride`-th sample (1: all) against oversampling.
    pub stride: usize,
    /// `n_cut` as a fraction of the (coarsened) length (Gottwald-Melbourne: 1/10).
    pub n_cut_fraction: f64,
}

impl Default for ZeroOneParams {
    fn default() -> Self {
        Self { n_c: 100, seed: 1, stride: 1, n_cut_fraction: 0.1 }
    }
}

/// What [`zero_one_test`] found.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ZeroOneResult {
    /// Median of `K_c` over the frequencies.
    pub k: f64,
    /// 25 % and 75 % quantiles of `K_c` (their spread).
    pub k_quartiles: (f64, f64),
    /// Samples used after coarsening.
    pub n_used: usize,
    /// Largest displacement lag `n_cut`.
    pub n_cut: usize,
    pub stride: usize,
}

/// Shortest coarsened series the test accepts (n_cut = 10 at the default fraction).
pub const MIN_SAMPLES: usize = 100;

/// The 0-1 test on series `x` (see the module doc).
///
/// Errors: non-finite samples, a constant series, `n_c` or `stride` zero, `n_cut_fraction`
/// outside `(0, 0.5]`, fewer than [`MIN_SAMPLES`] samples after coarsening.
pub fn zero_one_test(x: &[f64], p: &ZeroOneParams) -> Result<ZeroOneResult> {
    check_finite(x, 1)?;
    at_least("n_c (0-1 test frequencies)", p.n_c, 1)?;
    at_least("stride (0-1 test coarsening)", p.stride, 1)?;
    if !(p.n_cut_fraction > 0.0 && p.n_cut_fraction <= 0.5) {
        return Err(ChaosError::BadParameter {
            name: "n_cut_fraction",
            value: p.n_cut_fraction,
            reason: "must lie in (0, 0.5]",
        });
    }
    let phi: Vec<f64> = x.iter().step_by(p.stride).copied().collect();
    let n = phi.len();
    if n < MIN_SAMPLES {
        return Err(ChaosError::TooShort {
            param: "0-1 test (after coarsening by stride)",
            have: n,
            need: MIN_SAMPLES,
        });
    }
    if phi.iter().all(|&v| v == phi[0]) {
        return Err(ChaosError::ZeroVariance { coord: 0, value: phi[0] });
    }
    let n_cut = ((n as f64 * p.n_cut_fraction) as usize).max(2);
    let mean = phi.iter().sum::<f64>() / n as f64;
    let mut rng = SplitMix::new(p.seed);
    let (lo, hi) = (std::f64::consts::PI / 5.0, 4.0 * std::f64::consts::PI / 5.0);
    let mut ks = Vec::with_capacity(p.n_c);
    let mut pq = vec![(0.0, 0.0); n];
    let xi: Vec<f64> = (1..=n_cut).map(|k| k as f64).collect();
    let mut d = vec![0.0; n_cut];
    for _ in 0..p.n_c {
        let c = lo + (hi - lo) * rng.uniform();
        let (mut ps, mut qs) = (0.0, 0.0);
        for (j, (v, slot)) in phi.iter().zip(pq.iter_mut()).enumerate() {
            let (s, co) = ((j + 1) as f64 * c).sin_cos();
            ps += v * co;
            qs += v * s;
            *slot = (ps, qs);
        }
        // Mean over a common number of origins so every lag averages the same span.
        let origins = n - n_cut;
        for (k, dk) in d.iter_mut().enumerate() {
            let lag = k + 1;
            let m: f64 = (0..origins)
                .map(|j| {
                    let (a, b) = (pq[j + lag].0 - pq[j].0, pq[j + lag].1 - pq[j].1);
                    a * a + b * b
                })
                .sum::<f64>()
                / origins as f64;
            let v_osc = mean * mean * (1.0 - (lag as f64 * c).cos()) / (1.0 - c.cos());
            *dk = m - v_osc;
        }
        ks.push(correlation(&xi, &d));
    }
    ks.sort_by(f64::total_cmp);
    Ok(ZeroOneResult {
        k: quantile(&ks, 0.5),
        k_quartiles: (quantile(&ks, 0.25), quantile(&ks, 0.75)),
        n_used: n,
        n_cut,
        stride: p.stride,
    })
}

/// Pearson correlation; 0 when either side is constant (a bounded, non-growing `D_c`).
fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    if saa > 0.0 && sbb > 0.0 { sab / (saa * sbb).sqrt() } else { 0.0 }
}

/// Linear-interpolated quantile of sorted, non-empty `v`.
pub(crate) fn quantile(v: &[f64], q: f64) -> f64 {
    let pos = q * (v.len() - 1) as f64;
    let i = pos.floor() as usize;
    let f = pos - i as f64;
    match (v.get(i), v.get(i + 1)) {
        (Some(a), Some(b)) => a + f * (b - a),
        (Some(a), None) => *a,
        _ => f64::NAN,
    }
}
