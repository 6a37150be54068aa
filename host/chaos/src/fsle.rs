//! Finite-size Lyapunov exponents (Aurell, Boffetta, Crisanti, Paladin & Vulpiani 1997):
//! the separation's growth rate as a function of its size.
//!
//! For thresholds `delta_k = delta_0 r^k`, the time `tau_k` a separation takes to grow from
//! `delta_k` to `delta_{k+1}` (first passages) is averaged over pairs, and
//! `lambda(delta_k) = ln r / <tau_k>`. Chaos shows a plateau at the largest exponent for small
//! `delta`, falling to zero as `delta` reaches the attractor's size; diffusion (a
//! noise-driven neutral direction) shows `lambda ~ delta^-2` (the time to diffuse over
//! `delta` grows like `delta^2`); a contracting direction kicked by noise shows no growth
//! below the noise level.
//!
//! Two sources of pairs: [`fsle_from_separations`] takes separation histories of twin runs
//! of a known system (model-based: two runs started `delta_0` apart), [`fsle_series`] finds
//! pairs of close points in a delay embedding of data (each reference point and its nearest
//! neighbour outside the Theiler window, closer than the smallest threshold) and follows
//! them in time.

use crate::{ChaosError, Points, Result, at_least, check_finite, fit_line, positive, strided};

/// One scale of an FSLE table.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FsleRow {
    /// Lower threshold `delta_k`.
    pub delta: f64,
    /// `ln r / <tau_k>` (1/time unit of `dt`); `None` when no pair crossed both thresholds or
    /// every crossing took zero time (the separation jumped over the band within one sample).
    pub lambda: Option<f64>,
    /// Mean first-passage time from `delta_k` to `delta_{k+1}`.
    pub mean_time: Option<f64>,
    /// Pairs that crossed both thresholds.
    pub pairs: usize,
}

/// Geometric thresholds `delta_0 r^k`, `k = 0..n`.
pub fn thresholds(delta_0: f64, ratio: f64, n: usize) -> Result<Vec<f64>> {
    positive("delta_0 (smallest FSLE threshold)", delta_0)?;
    if !(ratio.is_finite() && ratio > 1.0) {
        return Err(ChaosError::BadParameter {
            name: "ratio (FSLE threshold ratio)",
            value: ratio,
            reason: "must be finite and > 1",
        });
    }
    at_least("n (FSLE thresholds)", n, 2)?;
    Ok((0..n).map(|k| delta_0 * ratio.powi(k as i32)).collect())
}

/// FSLE from separation histories sampled every `dt`: for each history, the first sample at
/// which it reaches each threshold (in order; a history that starts above `delta_0` is
/// skipped), and `lambda` per band `[delta_k, delta_{k+1})`. `delta` must be increasing.
pub fn fsle_from_separations<S: AsRef<[f64]>>(separations: &[S], dt: f64, delta: &[f64]) -> Result<Vec<FsleRow>> {
    positive("dt", dt)?;
    at_least("thresholds", delta.len(), 2)?;
    for (k, w) in delta.windows(2).enumerate() {
        if !(w[0] > 0.0 && w[1] > w[0] && w[1].is_finite()) {
            return Err(ChaosError::BadParameter {
                name: "thresholds (positive, increasing)",
                value: w[1],
                reason: if k == 0 { "first pair not increasing" } else { "not increasing" },
            });
        }
    }
    let nb = delta.len() - 1;
    let mut sum = vec![0.0; nb];
    let mut count = vec![0usize; nb];
    let mut first = vec![None; delta.len()];
    for s in separations {
        let s = s.as_ref();
        check_finite(s, 1)?;
        if s.first().is_none_or(|&d0| d0 >= delta[0]) {
            continue;
        }
        first.iter_mut().for_each(|f| *f = None);
        let mut next = 0;
        for (i, &d) in s.iter().enumerate() {
            while next < delta.len() && d >= delta[next] {
                first[next] = Some(i);
                next += 1;
            }
            if next == delta.len() {
                break;
            }
        }
        for k in 0..nb {
            if let (Some(a), Some(b)) = (first[k], first[k + 1]) {
                sum[k] += (b - a) as f64 * dt;
                count[k] += 1;
            }
        }
    }
    Ok((0..nb)
        .map(|k| {
            let mean_time = (count[k] > 0).then(|| sum[k] / count[k] as f64);
            let lambda = mean_time.filter(|&t| t > 0.0).map(|t| (delta[k + 1] / delta[k]).ln() / t);
            FsleRow { delta: delta[k], lambda, mean_time, pairs: count[k] }
        })
        .collect())
}

/// Settings of [`fsle_series`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FsleSeriesParams {
    /// Temporal neighbours excluded from the neighbour search (samples).
    pub theiler: usize,
    /// At most this many reference points (evenly strided).
    pub max_refs: usize,
    /// Pairs are followed for at most this many samples.
    pub horizon: usize,
    /// Sampling step (time unit of the exponents).
    pub dt: f64,
}

/// FSLE of data: pairs of delay vectors closer than `delta[0]` (each reference point with its
/// nearest neighbour outside the Theiler window) followed for up to `horizon` samples
/// (Euclidean distance in the embedding). Also returns the number of pairs found.
pub fn fsle_series(points: &Points, delta: &[f64], p: &FsleSeriesParams) -> Result<(Vec<FsleRow>, usize)> {
    at_least("horizon (FSLE)", p.horizon, 1)?;
    at_least("max_refs (FSLE)", p.max_refs, 1)?;
    let n = points.len();
    let need = p.horizon + 2 * p.theiler + 2;
    if n < need {
        return Err(ChaosError::TooShort { param: "FSLE horizon + 2 Theiler windows", have: n, need });
    }
    let d0 = delta.first().copied().unwrap_or(0.0);
    positive("thresholds[0]", d0)?;
    let last = n - p.horizon; // references and neighbours need `horizon` samples after them
    let mut seps: Vec<Vec<f64>> = Vec::new();
    for i in strided(last, p.max_refs) {
        let pi = points.point(i);
        let mut best: Option<(usize, f64)> = None;
        for j in 0..last {
            if j.abs_diff(i) <= p.theiler {
                continue;
            }
            let d2 = crate::Norm::Euclidean.dist2(pi, points.point(j));
            if d2 > 0.0 && best.is_none_or(|(_, b)| d2 < b) {
                best = Some((j, d2));
            }
        }
        if let Some((j, d2)) = best.filter(|&(_, d2)| d2.sqrt() < d0) {
            let _ = d2;
            seps.push(
                (0..p.horizon)
                    .map(|k| crate::Norm::Euclidean.dist2(points.point(i + k), points.point(j + k)).sqrt())
                    .collect(),
            );
        }
    }
    let pairs = seps.len();
    Ok((fsle_from_separations(&seps, p.dt, delta)?, pairs))
}

/// Slope of `ln lambda` against `ln delta` over the rows with a value and at least
/// `min_pairs` pairs: about 0 on a chaotic plateau, about -2 for diffusion.
pub fn scaling_slope(rows: &[FsleRow], min_pairs: usize) -> Result<f64> {
    let (x, y): (Vec<f64>, Vec<f64>) = rows
        .iter()
        .filter(|r| r.pairs >= min_pairs)
        .filter_map(|r| r.lambda.filter(|&l| l > 0.0).map(|l| (r.delta.ln(), l.ln())))
        .unzip();
    Ok(fit_line(&x, &y)?.slope)
}
