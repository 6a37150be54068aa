//! Largest Lyapunov exponent from a time series: Rosenstein's nearest-neighbour method and
//! Kantz's neighbourhood-average variant at several scales `eps`.
//!
//! Both build a divergence curve `y(k)`, the mean logarithm of the distance between pairs
//! of trajectory segments `k` samples after they were close, and fit a line to it over a
//! window picked by the [`FitRule`]; the exponent is the slope per unit time
//! (`k * dt`). Only reference points whose partners still have `max_steps` samples ahead
//! are used, so every point of the curve averages the same pairs. Distances are between
//! whole points (embedding vectors or states) in the chosen [`Norm`].
//!
//! # Fit-window rule ([`FitRule`])
//! Let `y0 = y(0)`, `ytop = max y`, `rise = ytop - y0`, and `s(k)` the local slope of the
//! curve (centred difference in time; one-sided at the ends).
//! - If `rise < min_rise` (nats) the pairs do not separate measurably (periodic or
//!   quasi-periodic motion, or `max_steps` too short): the line is fitted to the whole
//!   curve and `grew = false` (slope near zero for regular motion).
//! - Otherwise the candidate range runs from the first `k` with
//!   `y(k) >= y0 + lo_fraction * rise` to the last `k` before `y` first reaches
//!   `y0 + hi_fraction * rise` (before saturation at the attractor's size). Inside it, the
//!   window is the longest run of at least `min_points` samples whose local slopes all lie
//!   within `tolerance * |median|` of the run's median (the straightest section; it skips
//!   the initial reorientation of the separation, where the curve is steeper). Ties go to
//!   the run with the smaller spread of slopes. The exponent is the least-squares slope over
//!   the window; `fit_stderr` is its regression standard error and `slope_std` the standard
//!   deviation of the local slopes in the window.
//!
//! The curves bend on real data: report the curve and the window with the number.

use crate::{ChaosError, LineFit, Norm, Points, Result, at_least, fit_line, positive, strided};

/// Runs `$body` with `$f` bound to the squared distance of norm `$norm` for points of
/// dimension `$dim`: [`euclid`] (a loop of known length) for the Euclidean norm in 2..8
/// dimensions, else `Norm::dist2`; `$body` is compiled once per arm, so the distance is
/// inlined. The same values either way.
macro_rules! with_dist2 {
    ($dim:expr, $norm:expr, $f:ident => $body:block) => {
        match ($norm, $dim) {
            (Norm::Euclidean, 2) => {
                let $f = euclid::<2>;
                $body
            }
            (Norm::Euclidean, 3) => {
                let $f = euclid::<3>;
                $body
            }
            (Norm::Euclidean, 4) => {
                let $f = euclid::<4>;
                $body
            }
            (Norm::Euclidean, 5) => {
                let $f = euclid::<5>;
                $body
            }
            (Norm::Euclidean, 6) => {
                let $f = euclid::<6>;
                $body
            }
            (Norm::Euclidean, 7) => {
                let $f = euclid::<7>;
                $body
            }
            (Norm::Euclidean, 8) => {
                let $f = euclid::<8>;
                $body
            }
            (norm, _) => {
                let $f = move |a: &[f64], b: &[f64]| norm.dist2(a, b);
                $body
            }
        }
    };
}

/// Parameters shared by both estimators.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DivergenceParams {
    /// Neighbours must satisfy `|i - j| > theiler` (about one dominant period for flows).
    pub theiler: usize,
    /// Length of the divergence curve in samples.
    pub max_steps: usize,
    /// At most this many reference points, evenly strided in time.
    pub max_reference: usize,
    /// Time per sample (1 for maps; the exponent comes out per unit of `dt`).
    pub dt: f64,
    pub norm: Norm,
}

impl Default for DivergenceParams {
    fn default() -> Self {
        Self { theiler: 1, max_steps: 30, max_reference: 3000, dt: 1.0, norm: Norm::Euclidean }
    }
}

/// The rule that picks the fit window (module docs).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FitRule {
    pub lo_fraction: f64,
    pub hi_fraction: f64,
    pub min_rise: f64,
    /// Relative band around the median local slope.
    pub tolerance: f64,
    pub min_points: usize,
}

impl Default for FitRule {
    fn default() -> Self {
        Self { lo_fraction: 0.0, hi_fraction: 0.7, min_rise: 1.0, tolerance: 0.2, min_points: 5 }
    }
}

/// Mean log distance against time, ready to plot.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DivergenceCurve {
    /// `k * dt`, `k = 0..=max_steps`.
    pub time: Vec<f64>,
    /// Rosenstein: mean of `ln d_i(k)`; Kantz: mean over references of the log of the mean
    /// distance to the neighbourhood.
    pub mean_log_distance: Vec<f64>,
    /// Number of terms averaged at each `k`.
    pub n_terms: Vec<usize>,
    /// Reference points that found a partner.
    pub n_reference: usize,
    /// Terms skipped because the distance was exactly zero (repeated points, e.g. quantized
    /// data).
    pub zero_distances: usize,
}

/// Slope of a divergence curve over the chosen window.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct DivergenceFit {
    /// Largest Lyapunov exponent, per unit of `dt`.
    pub exponent: f64,
    pub fit_stderr: f64,
    /// Standard deviation of the local slopes in the window (per unit time).
    pub slope_std: f64,
    /// Inclusive sample indices of the fit window.
    pub window: (usize, usize),
    pub window_time: (f64, f64),
    /// `max y - y(0)` in nats.
    pub rise: f64,
    /// `false` when the rise was below `min_rise` and the whole curve was fitted.
    pub grew: bool,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct LyapunovEstimate {
    pub fit: DivergenceFit,
    pub curve: DivergenceCurve,
}

/// Kantz's estimate at one scale.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct KantzEstimate {
    pub eps: f64,
    /// Mean neighbourhood size over references that had neighbours (after the cap).
    pub mean_neighbours: f64,
    pub curve: Option<DivergenceCurve>,
    pub fit: Option<DivergenceFit>,
    /// Why `curve` or `fit` is missing (no neighbours within `eps`, no window).
    pub failure: Option<String>,
}

/// `n` values log-spaced from `lo` to `hi` inclusive.
pub fn log_spaced(lo: f64, hi: f64, n: usize) -> Result<Vec<f64>> {
    positive("lo", lo)?;
    positive("hi", hi)?;
    at_least("n", n, 2)?;
    let (a, b) = (lo.ln(), hi.ln());
    Ok((0..n).map(|k| (a + (b - a) * k as f64 / (n - 1) as f64).exp()).collect())
}

#[doc(hidden)]
pub fn check_params(points: &Points, p: &DivergenceParams) -> Result<usize> {
    positive("dt", p.dt)?;
    at_least("max_steps", p.max_steps, 2)?;
    at_least("max_reference", p.max_reference, 1)?;
    let n = points.len();
    let need = p.max_steps + 2 * (p.theiler + 1) + 1;
    if n < need {
        return Err(ChaosError::TooShort { param: "max_steps + 2*(theiler+1)", have: n, need });
    }
    points.check_variance()?;
    Ok(n - p.max_steps)
}

/// Rosenstein's divergence curve: each reference's nearest neighbour (outside the Theiler
/// window, at non-zero distance), then the mean of `ln` of their distance `k` steps later.
pub fn rosenstein_curve(points: &Points, p: &DivergenceParams) -> Result<DivergenceCurve> {
    let nc = check_params(points, p)?;
    let k_len = p.max_steps + 1;
    let mut sum = vec![0.0; k_len];
    let mut n_terms = vec![0usize; k_len];
    let mut zero = 0usize;
    let mut n_ref = 0usize;
    let axis = SortedAxis::new(points, nc);
    with_dist2!(points.dim(), p.norm, dist2 => {
        for i in strided(nc, p.max_reference) {
            let Some(j) = axis.nearest(points, i, p) else { continue };
            n_ref += 1;
            for k in 0..k_len {
                let d2 = dist2(points.point(i + k), points.point(j + k));
                if d2 > 0.0 {
                    sum[k] += 0.5 * d2.ln();
                    n_terms[k] += 1;
                } else {
                    zero += 1;
                }
            }
        }
    });
    finish_curve(sum, n_terms, n_ref, zero, p.dt)
}

/// Euclidean squared distance of `D` coordinates by a loop of known length: the same
/// expression as `Norm::dist2`, so the same operations in the same order.
#[inline(always)]
fn euclid<const D: usize>(a: &[f64], b: &[f64]) -> f64 {
    match (<&[f64; D]>::try_from(a), <&[f64; D]>::try_from(b)) {
        (Ok(a), Ok(b)) => a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum(),
        _ => Norm::Euclidean.dist2(a, b),
    }
}

/// The first `nc` points ordered by their first coordinate (ties by index), for exact
/// neighbour searches that stop once the first coordinate alone is too far: every distance
/// of [`Norm`] is at least the first coordinate's difference (the rounded square of a
/// difference never exceeds the rounded sum of squares, or the square of the largest
/// difference, that contains it), so the points skipped could not have been picked. The
/// results are those of the scan over all points in index order, bit for bit: the same
/// distances, the same tie rule (the smallest index among equal distances).
#[doc(hidden)]
pub struct SortedAxis {
    /// Point indices by increasing first coordinate.
    order: Vec<usize>,
    /// `rank[j]`: the position of point `j` in `order`.
    rank: Vec<usize>,
}

impl SortedAxis {
    pub fn new(points: &Points, nc: usize) -> Self {
        let mut order: Vec<usize> = (0..nc).collect();
        order.sort_unstable_by(|&a, &b| points.point(a)[0].total_cmp(&points.point(b)[0]).then(a.cmp(&b)));
        let mut rank = vec![0; nc];
        for (r, &j) in order.iter().enumerate() {
            rank[j] = r;
        }
        Self { order, rank }
    }

    /// The points `j` of the first `nc` (the reference `i` too) whose first-coordinate gap
    /// `t = x_i0 - x_j0` has `t * t < lim`, found by walking out from `i`'s rank: a run of
    /// `order` (by first coordinate, not by index). Every other point has a squared distance
    /// of at least `t * t >= lim` in any [`Norm`].
    fn within(&self, points: &Points, i: usize, lim: f64) -> &[usize] {
        let x0 = points.point(i)[0];
        let r = self.rank[i];
        let near = |j: usize| {
            let t = x0 - points.point(j)[0];
            t * t < lim
        };
        // At most r + 1 points lie at or below rank r: `lo` from 0 to r + 1, no underflow.
        let lo = r + 1 - self.order[..=r].iter().rev().take_while(|&&j| near(j)).count();
        let hi = r + 1 + self.order[r + 1..].iter().take_while(|&&j| near(j)).count();
        &self.order[lo.min(r + 1)..hi]
    }

    /// Rosenstein's partner of reference `i`: the point `j` outside the Theiler window at the
    /// smallest non-zero distance, the smallest such `j` on ties; `None` when there is none.
    pub fn nearest(&self, points: &Points, i: usize, p: &DivergenceParams) -> Option<usize> {
        // Euclidean distances of 2..8 coordinates by `euclid`, a loop of known length.
        with_dist2!(points.dim(), p.norm, dist2 => { self.nearest_by(points, i, p, dist2) })
    }

    /// [`SortedAxis::nearest`] with the squared distance `dist2` (that of `p.norm`).
    #[inline(always)]
    fn nearest_by(
        &self,
        points: &Points,
        i: usize,
        p: &DivergenceParams,
        dist2: impl Fn(&[f64], &[f64]) -> f64,
    ) -> Option<usize> {
        let pi = points.point(i);
        let x0 = pi[0];
        let r = self.rank[i];
        let mut best: Option<(usize, f64)> = None;
        // A function inlined into the walk (a closure here was compiled as a call per point).
        #[inline(always)]
        fn consider_with(
            j: usize,
            i: usize,
            theiler: usize,
            pi: &[f64],
            points: &Points,
            dist2: &impl Fn(&[f64], &[f64]) -> f64,
            best: &mut Option<(usize, f64)>,
        ) {
            if j.abs_diff(i) > theiler {
                let d2 = dist2(pi, points.point(j));
                if d2 > 0.0 && best.is_none_or(|(bj, b)| d2 < b || (d2 == b && j < bj)) {
                    *best = Some((j, d2));
                }
            }
        }
        // Walk out from the reference's rank on both sides; a side ends at the first point
        // whose first-coordinate gap alone exceeds the best distance (all later ones do).
        let (mut lo, mut hi) = (r, r + 1);
        let mut lo_open = true;
        let mut hi_open = true;
        while lo_open || hi_open {
            if lo_open {
                if lo == 0 {
                    lo_open = false;
                } else {
                    lo -= 1;
                    let j = self.order[lo];
                    let t = x0 - points.point(j)[0];
                    if best.is_some_and(|(_, b)| t * t > b) {
                        lo_open = false;
                    } else {
                        consider_with(j, i, p.theiler, pi, points, &dist2, &mut best);
                    }
                }
            }
            if hi_open {
                if hi >= self.order.len() {
                    hi_open = false;
                } else {
                    let j = self.order[hi];
                    hi += 1;
                    let t = x0 - points.point(j)[0];
                    if best.is_some_and(|(_, b)| t * t > b) {
                        hi_open = false;
                    } else {
                        consider_with(j, i, p.theiler, pi, points, &dist2, &mut best);
                    }
                }
            }
        }
        best.map(|(j, _)| j)
    }
}

#[doc(hidden)]
pub fn finish_curve(
    sum: Vec<f64>,
    n_terms: Vec<usize>,
    n_reference: usize,
    zero_distances: usize,
    dt: f64,
) -> Result<DivergenceCurve> {
    if let Some(k) = n_terms.iter().position(|&c| c == 0) {
        return Err(ChaosError::NoFitWindow {
            reason: format!("no pair at non-zero distance at step {k} ({n_reference} references)"),
        });
    }
    Ok(DivergenceCurve {
        time: (0..sum.len()).map(|k| k as f64 * dt).collect(),
        mean_log_distance: sum.iter().zip(&n_terms).map(|(s, &c)| s / c as f64).collect(),
        n_terms,
        n_reference,
        zero_distances,
    })
}

/// Apply the fit-window rule (module docs) to a curve.
pub fn fit_divergence(curve: &DivergenceCurve, rule: &FitRule) -> Result<DivergenceFit> {
    let ok_frac = |v: f64| v.is_finite() && (0.0..=1.0).contains(&v);
    if !ok_frac(rule.lo_fraction) || !ok_frac(rule.hi_fraction) || rule.lo_fraction >= rule.hi_fraction {
        return Err(ChaosError::BadParameter {
            name: "lo_fraction/hi_fraction",
            value: rule.hi_fraction,
            reason: "need 0 <= lo_fraction < hi_fraction <= 1",
        });
    }
    if !(rule.min_rise.is_finite() && rule.min_rise >= 0.0) {
        return Err(ChaosError::BadParameter {
            name: "min_rise",
            value: rule.min_rise,
            reason: "must be finite and >= 0",
        });
    }
    at_least("min_points", rule.min_points, 2)?;
    let y = &curve.mean_log_distance;
    let t = &curve.time;
    if y.len() < rule.min_points {
        return Err(ChaosError::TooShort {
            param: "divergence curve (min_points)",
            have: y.len(),
            need: rule.min_points,
        });
    }
    let y0 = y[0];
    let ytop = y.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let rise = ytop - y0;
    let n = y.len();
    let slope = |a: usize, b: usize| (y[b] - y[a]) / (t[b] - t[a]);
    let local: Vec<f64> = (0..n)
        .map(|k| {
            if k == 0 {
                slope(0, 1)
            } else if k == n - 1 {
                slope(n - 2, n - 1)
            } else {
                slope(k - 1, k + 1)
            }
        })
        .collect();
    let (a, b, grew) = if rise < rule.min_rise {
        (0, n - 1, false)
    } else {
        positive("tolerance", rule.tolerance)?;
        let lo = y0 + rule.lo_fraction * rise;
        let hi = y0 + rule.hi_fraction * rise;
        let ka = y.iter().position(|&v| v >= lo).unwrap_or(0);
        let kb = y.iter().position(|&v| v >= hi).unwrap_or(n - 1).saturating_sub(1).max(ka);
        let Some((a, b, _, _)) = crate::longest_consistent_run(&local, ka, kb, rule.tolerance, rule.min_points) else {
            return Err(ChaosError::NoFitWindow {
                reason: format!(
                    "no run of {} samples with local slopes within +-{:.0}% of their median in k = {ka}..={kb} \
                     (rise {rise:.3} nats, fractions {}..{})",
                    rule.min_points,
                    100.0 * rule.tolerance,
                    rule.lo_fraction,
                    rule.hi_fraction
                ),
            });
        };
        (a, b, true)
    };
    let LineFit { slope, slope_stderr, .. } = fit_line(&t[a..=b], &y[a..=b])?;
    let (_, slope_std) = crate::mean_std(&local[a..=b]);
    Ok(DivergenceFit {
        exponent: slope,
        fit_stderr: slope_stderr,
        slope_std,
        window: (a, b),
        window_time: (t[a], t[b]),
        rise,
        grew,
    })
}

/// Rosenstein's estimate: curve plus fit.
pub fn rosenstein(points: &Points, p: &DivergenceParams, rule: &FitRule) -> Result<LyapunovEstimate> {
    let curve = rosenstein_curve(points, p)?;
    let fit = fit_divergence(&curve, rule)?;
    Ok(LyapunovEstimate { fit, curve })
}

/// Kantz's divergence curves, one per `eps`: for each reference, the neighbours within
/// `eps` outside the Theiler window (at most `max_neighbours`, evenly strided in time when
/// there are more); `S(k) = mean_i ln( mean_j |x_{i+k} - x_{j+k}| )`.
/// Returns, per `eps`, the curve (or why there is none) and the mean neighbourhood size.
#[allow(clippy::type_complexity)]
pub fn kantz_curves(
    points: &Points,
    eps: &[f64],
    p: &DivergenceParams,
    max_neighbours: usize,
) -> Result<Vec<(f64, f64, std::result::Result<DivergenceCurve, String>)>> {
    let nc = check_params(points, p)?;
    at_least("max_neighbours", max_neighbours, 1)?;
    if eps.is_empty() {
        return Err(ChaosError::BadParameter { name: "eps", value: 0.0, reason: "need at least one scale" });
    }
    for &e in eps {
        positive("eps", e)?;
    }
    let eps_max = eps.iter().copied().fold(0.0, f64::max);
    let k_len = p.max_steps + 1;
    let ne = eps.len();
    let mut sum = vec![vec![0.0; k_len]; ne];
    let mut n_terms = vec![vec![0usize; k_len]; ne];
    let mut zero = vec![0usize; ne];
    let mut n_ref = vec![0usize; ne];
    let mut neigh_total = vec![0usize; ne];
    let mut cand: Vec<(usize, f64)> = Vec::new();
    // Per scale, the chosen neighbours as positions in `cand`; `need[q]`: some scale chose
    // `cand[q]`, `used` those positions in order; `dist[q]` the distance of `cand[q]` at
    // the current step (computed once for all scales that chose it: the same value).
    let mut chosen: Vec<Vec<usize>> = vec![Vec::new(); ne];
    let mut need: Vec<bool> = Vec::new();
    let mut used: Vec<usize> = Vec::new();
    let mut dist: Vec<f64> = Vec::new();
    let axis = SortedAxis::new(points, nc);
    let lim = eps_max * eps_max;
    with_dist2!(points.dim(), p.norm, dist2 => {
        for i in strided(nc, p.max_reference) {
            let pi = points.point(i);
            // The points within `eps_max` outside the Theiler window: those of the scan over
            // all `j` in index order, found by the walk over the first coordinate (a point
            // whose first-coordinate gap alone reaches `eps_max` is farther), then put back
            // in index order.
            cand.clear();
            for &j in axis.within(points, i, lim) {
                if j.abs_diff(i) > p.theiler {
                    let d2 = dist2(pi, points.point(j));
                    if d2 < lim {
                        cand.push((j, d2));
                    }
                }
            }
            cand.sort_unstable_by_key(|c| c.0);
            need.clear();
            need.resize(cand.len(), false);
            for (e, &eps_e) in eps.iter().enumerate() {
                let ch = &mut chosen[e];
                ch.clear();
                ch.extend(cand.iter().enumerate().filter(|(_, (_, d2))| *d2 < eps_e * eps_e).map(|(q, _)| q));
                if ch.is_empty() {
                    continue;
                }
                if ch.len() > max_neighbours {
                    let keep: Vec<usize> = strided(ch.len(), max_neighbours).into_iter().map(|q| ch[q]).collect();
                    ch.clear();
                    ch.extend(keep);
                }
                n_ref[e] += 1;
                neigh_total[e] += ch.len();
                for &q in ch.iter() {
                    need[q] = true;
                }
            }
            used.clear();
            used.extend((0..cand.len()).filter(|&q| need[q]));
            if used.is_empty() {
                continue;
            }
            dist.clear();
            dist.resize(cand.len(), 0.0);
            for k in 0..k_len {
                let a = points.point(i + k);
                for &q in &used {
                    dist[q] = dist2(a, points.point(cand[q].0 + k)).sqrt();
                }
                for (e, ch) in chosen.iter().enumerate() {
                    if ch.is_empty() {
                        continue;
                    }
                    let mean_d = ch.iter().map(|&q| dist[q]).sum::<f64>() / ch.len() as f64;
                    if mean_d > 0.0 {
                        sum[e][k] += mean_d.ln();
                        n_terms[e][k] += 1;
                    } else {
                        zero[e] += 1;
                    }
                }
            }
        }
    });
    let mut out = Vec::with_capacity(ne);
    for e in 0..ne {
        let mean_neigh = if n_ref[e] > 0 { neigh_total[e] as f64 / n_ref[e] as f64 } else { 0.0 };
        let curve = if n_ref[e] == 0 {
            Err(format!("no reference point has a neighbour within eps = {:.4e}", eps[e]))
        } else {
            finish_curve(std::mem::take(&mut sum[e]), std::mem::take(&mut n_terms[e]), n_ref[e], zero[e], p.dt)
                .map_err(|err| err.to_string())
        };
        out.push((eps[e], mean_neigh, curve));
    }
    Ok(out)
}

/// Kantz's exponent as a function of the scale `eps` (scale dependence is the point: on
/// quantized-control data the exponent changes with `eps`).
pub fn kantz(
    points: &Points,
    eps: &[f64],
    p: &DivergenceParams,
    max_neighbours: usize,
    rule: &FitRule,
) -> Result<Vec<KantzEstimate>> {
    Ok(kantz_curves(points, eps, p, max_neighbours)?
        .into_iter()
        .map(|(eps, mean_neighbours, curve)| match curve {
            Err(why) => KantzEstimate { eps, mean_neighbours, curve: None, fit: None, failure: Some(why) },
            Ok(c) => match fit_divergence(&c, rule) {
                Ok(f) => KantzEstimate { eps, mean_neighbours, curve: Some(c), fit: Some(f), failure: None },
                Err(e) => {
                    KantzEstimate { eps, mean_neighbours, curve: Some(c), fit: None, failure: Some(e.to_string()) }
                }
            },
        })
        .collect())
}
