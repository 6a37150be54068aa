//! Correlation dimension (Grassberger–Procaccia).
//!
//! `C(r)` is the fraction of point pairs `(i, j)` closer than `r`, over pairs with
//! `|i - j| > theiler` only: self-pairs (`i = j`) are never counted, and temporally close
//! pairs, which lie close because the trajectory is continuous rather than because the
//! attractor is folded onto itself, are excluded by the Theiler window.
//!
//! Cost: O(n_ref * n * dim) with `n_ref <= max_reference` reference points (evenly strided
//! in time) paired with every point. One pass fills a histogram over a log-spaced radius
//! grid, so the whole curve costs one pass.
//!
//! # Scaling-range rule (see [`ScalingRule`])
//! 1. Eligible radii: `count(r) >= min_pairs` (enough pairs for a stable `ln C`) and
//!    `r <= upper_fraction * diameter` (below the saturation of `C` near the attractor's
//!    size); `diameter` is the largest pair distance seen.
//! 2. Local slope at each grid radius: the centred difference of `ln C` against `ln r`
//!    (one-sided at the ends of the curve).
//! 3. The scaling range is the longest run of consecutive eligible radii, with at least
//!    `min_points` of them, whose local slopes all lie within `tolerance * |median|` of the
//!    run's own median; ties go to the run with the smaller standard deviation of slopes.
//! 4. Dimension: least-squares slope of `ln C` against `ln r` over that run. Error bar
//!    (`slope_std`): the sample standard deviation of the local slopes in the run. The
//!    regression's standard error (`fit_stderr`) is reported too; it is usually far smaller
//!    and understates the systematic uncertainty.

use crate::{ChaosError, LineFit, Norm, Points, Result, at_least, fit_line, positive, strided};

/// Parameters of the correlation sum.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CorrSumParams {
    /// Pairs with `|i - j| <= theiler` are excluded (`0` excludes only self-pairs). About
    /// one dominant period for flows sampled finely; 1-few samples for maps.
    pub theiler: usize,
    /// At most this many reference points (evenly strided in time), each paired with all
    /// points. All pairs are used when the set is no larger.
    pub max_reference: usize,
    /// Grid radii per decade (1..=50).
    pub radii_per_decade: usize,
    /// The grid spans this many decades below the bounding-box size of the points.
    pub decades: usize,
    pub norm: Norm,
}

impl Default for CorrSumParams {
    fn default() -> Self {
        Self { theiler: 1, max_reference: 3000, radii_per_decade: 20, decades: 8, norm: Norm::Euclidean }
    }
}

/// The correlation sum on its radius grid (from the first radius with a pair to the
/// first radius above the diameter), ready to plot.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CorrelationCurve {
    pub radius: Vec<f64>,
    /// Number of pairs closer than each radius.
    pub count: Vec<u64>,
    /// `C(r) = count / total_pairs`.
    pub c: Vec<f64>,
    /// `d ln C / d ln r` at each radius.
    pub local_slope: Vec<f64>,
    pub total_pairs: u64,
    /// Largest pair distance seen.
    pub diameter: f64,
    pub n_points: usize,
    pub n_reference: usize,
    pub theiler: usize,
}

/// The rule that picks the scaling range (module docs).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ScalingRule {
    pub min_pairs: u64,
    pub upper_fraction: f64,
    pub tolerance: f64,
    pub min_points: usize,
}

impl Default for ScalingRule {
    fn default() -> Self {
        Self { min_pairs: 100, upper_fraction: 0.25, tolerance: 0.10, min_points: 5 }
    }
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct DimensionEstimate {
    /// Least-squares slope over the scaling range.
    pub dimension: f64,
    /// Error bar: standard deviation of the local slopes in the range.
    pub slope_std: f64,
    /// Standard error of the least-squares slope.
    pub fit_stderr: f64,
    pub median_slope: f64,
    /// Scaling range in radius and as inclusive indices into the curve.
    pub r_range: (f64, f64),
    pub index_range: (usize, usize),
    pub curve: CorrelationCurve,
}

/// Correlation sum `C(r)` on a log-spaced grid.
pub fn correlation_sum(points: &Points, params: &CorrSumParams) -> Result<CorrelationCurve> {
    at_least("max_reference", params.max_reference, 2)?;
    at_least("radii_per_decade", params.radii_per_decade, 1)?;
    if params.radii_per_decade > 50 {
        return Err(ChaosError::BadParameter {
            name: "radii_per_decade",
            value: params.radii_per_decade as f64,
            reason: "at most 50 (finer grids are below the estimator's resolution)",
        });
    }
    at_least("decades", params.decades, 1)?;
    let n = points.len();
    let w = params.theiler;
    let need = 2 * (w + 1) + 1;
    if n < need {
        return Err(ChaosError::TooShort { param: "theiler (pairs outside the window)", have: n, need });
    }
    points.check_variance()?;

    // Top of the grid: an upper bound of every pair distance.
    let b = points.bounds();
    let top = match params.norm {
        Norm::Euclidean => b.iter().map(|(lo, hi)| (hi - lo).powi(2)).sum::<f64>().sqrt(),
        Norm::Max => b.iter().map(|(lo, hi)| hi - lo).fold(0.0, f64::max),
    } * (1.0 + 1e-12);
    let ppd = params.radii_per_decade as f64;
    let k_len = params.decades * params.radii_per_decade + 1;
    // radius_k = top * 10^((k - (k_len-1)) / ppd)
    let ln_r0 = top.ln() - (k_len - 1) as f64 / ppd * std::f64::consts::LN_10;
    let scale = ppd / std::f64::consts::LN_10; // grid steps per unit of ln r
    let binner = Binner::new(ln_r0, scale, k_len);
    let mut hist = vec![0u64; k_len + 1];
    let mut hist2 = vec![0u64; k_len + 1];
    let mut total: u64 = 0;
    let mut max_d2: f64 = 0.0;

    let refs = strided(n, params.max_reference);
    let all = refs.len() == n;
    let dim = points.dim();
    let data = points.as_flat();
    for &i in &refs {
        let pi = points.point(i);
        // Partners: every j outside the window; when all points are references, only j > i
        // (each unordered pair once).
        let hi_start = i + w + 1;
        if hi_start < n {
            let md = accumulate(pi, &data[hi_start * dim..], params.norm, &binner, &mut hist, &mut hist2);
            max_d2 = max_d2.max(md);
            total += (n - hi_start) as u64;
        }
        if !all && i > w {
            let md = accumulate(pi, &data[..(i - w) * dim], params.norm, &binner, &mut hist, &mut hist2);
            max_d2 = max_d2.max(md);
            total += (i - w) as u64;
        }
    }
    if total == 0 {
        return Err(ChaosError::TooShort { param: "theiler (no pairs outside the window)", have: n, need });
    }
    for (h, h2) in hist.iter_mut().zip(&hist2) {
        *h += h2;
    }

    let diameter = max_d2.sqrt();
    let mut radius = Vec::new();
    let mut count = Vec::new();
    let mut cum = 0u64;
    for (k, h) in hist.iter().take(k_len).enumerate() {
        cum += h;
        let r = binner.edges2[k].sqrt();
        if cum > 0 {
            radius.push(r);
            count.push(cum);
        }
        if r > diameter {
            break;
        }
    }
    let c: Vec<f64> = count.iter().map(|&k| k as f64 / total as f64).collect();
    let local_slope = local_slopes(&radius, &c);
    Ok(CorrelationCurve {
        radius,
        count,
        c,
        local_slope,
        total_pairs: total,
        diameter,
        n_points: n,
        n_reference: refs.len(),
        theiler: w,
    })
}

/// Maps a squared distance to the index of the first grid radius strictly above it,
/// without a logarithm per pair: Mitchell's approximation of log2 from the float's bits
/// (error < 0.09 in log2) gives a guess that is corrected against the exact squared edges.
#[doc(hidden)]
pub struct Binner {
    /// Squared grid radii, padded with two `+inf`.
    pub edges2: Vec<f64>,
    k_len: usize,
    a: f64,
    b: f64,
}

impl Binner {
    /// The binner of `k_len` radii `exp(ln_r0 + k / scale)`.
    pub fn new(ln_r0: f64, scale: f64, k_len: usize) -> Self {
        let mut edges2: Vec<f64> = (0..k_len).map(|k| (ln_r0 + k as f64 / scale).exp().powi(2)).collect();
        edges2.extend([f64::INFINITY; 2]);
        // grid coordinate t = (ln d - ln_r0) * scale = log2(d2) * (ln2 / 2) * scale - ln_r0 * scale
        Self { edges2, k_len, a: 0.5 * std::f64::consts::LN_2 * scale, b: -ln_r0 * scale }
    }

    /// `edges2` is padded with two `+inf`. Mitchell's log2 underestimates by at most 0.086
    /// (0.013 decades of d), under 0.65 grid steps at <= 50 radii per decade, so the true
    /// bin lies in `floor(t~) ..= floor(t~) + 2` and two comparisons settle it.
    #[inline]
    pub fn bin(&self, d2: f64) -> usize {
        let approx_log2 = d2.to_bits() as f64 * (1.0 / (1u64 << 52) as f64) - 1023.0;
        let t = approx_log2 * self.a + self.b;
        let lo = (t as usize).min(self.k_len); // saturating cast: negative -> 0
        lo + usize::from(d2 >= self.edges2[lo]) + usize::from(d2 >= self.edges2[lo + 1])
    }
}

/// Histogram the distances from `a` to every point in the flat slice `others`; returns the
/// largest squared distance. The counts go to `hist` and `hist2` (even and odd partners; the
/// caller adds them up: two histograms break the chain of increments of one bin, which
/// consecutive partners, close in time, mostly hit). Each distance is the plain loop's, in
/// its order: embeddings of dimension 2 to 8 take a loop unrolled at compile time.
#[doc(hidden)]
pub fn accumulate(a: &[f64], others: &[f64], norm: Norm, binner: &Binner, hist: &mut [u64], hist2: &mut [u64]) -> f64 {
    match (norm, a.len()) {
        (Norm::Euclidean, 2) => accumulate_fixed::<2, false>(a, others, binner, hist, hist2),
        (Norm::Euclidean, 3) => accumulate_fixed::<3, false>(a, others, binner, hist, hist2),
        (Norm::Euclidean, 4) => accumulate_fixed::<4, false>(a, others, binner, hist, hist2),
        (Norm::Euclidean, 5) => accumulate_fixed::<5, false>(a, others, binner, hist, hist2),
        (Norm::Euclidean, 6) => accumulate_fixed::<6, false>(a, others, binner, hist, hist2),
        (Norm::Euclidean, 7) => accumulate_fixed::<7, false>(a, others, binner, hist, hist2),
        (Norm::Euclidean, 8) => accumulate_fixed::<8, false>(a, others, binner, hist, hist2),
        (Norm::Max, 2) => accumulate_fixed::<2, true>(a, others, binner, hist, hist2),
        (Norm::Max, 3) => accumulate_fixed::<3, true>(a, others, binner, hist, hist2),
        (Norm::Max, 4) => accumulate_fixed::<4, true>(a, others, binner, hist, hist2),
        (Norm::Max, 5) => accumulate_fixed::<5, true>(a, others, binner, hist, hist2),
        (Norm::Max, 6) => accumulate_fixed::<6, true>(a, others, binner, hist, hist2),
        (Norm::Max, 7) => accumulate_fixed::<7, true>(a, others, binner, hist, hist2),
        (Norm::Max, 8) => accumulate_fixed::<8, true>(a, others, binner, hist, hist2),
        _ => accumulate_any(a, others, norm, binner, hist),
    }
}

/// The squared distance of [`accumulate_any`] for `D` coordinates (`MAX`: the max norm's
/// square), the same operations in the same order.
#[inline(always)]
fn dist2_fixed<const D: usize, const MAX: bool>(a: &[f64; D], b: &[f64]) -> f64 {
    if MAX {
        let mut m: f64 = 0.0;
        for c in 0..D {
            m = m.max((a[c] - b[c]).abs());
        }
        m * m
    } else {
        let mut d2 = 0.0;
        for c in 0..D {
            let d = a[c] - b[c];
            d2 += d * d;
        }
        d2
    }
}

/// [`accumulate`] for `D` coordinates: partners two at a time, the first's count in `hist`,
/// the second's in `hist2`.
fn accumulate_fixed<const D: usize, const MAX: bool>(
    a: &[f64],
    others: &[f64],
    binner: &Binner,
    hist: &mut [u64],
    hist2: &mut [u64],
) -> f64 {
    let mut p = [0.0; D];
    p.copy_from_slice(&a[..D]);
    let (mut m1, mut m2): (f64, f64) = (0.0, 0.0);
    let mut pairs = others.chunks_exact(2 * D);
    for b in &mut pairs {
        let (b1, b2) = b.split_at(D);
        let d1 = dist2_fixed::<D, MAX>(&p, b1);
        let d2 = dist2_fixed::<D, MAX>(&p, b2);
        m1 = m1.max(d1);
        m2 = m2.max(d2);
        hist[binner.bin(d1)] += 1;
        hist2[binner.bin(d2)] += 1;
    }
    for b in pairs.remainder().chunks_exact(D) {
        let d1 = dist2_fixed::<D, MAX>(&p, b);
        m1 = m1.max(d1);
        hist[binner.bin(d1)] += 1;
    }
    m1.max(m2)
}

/// [`accumulate`] for any dimension, one histogram.
#[doc(hidden)]
pub fn accumulate_any(a: &[f64], others: &[f64], norm: Norm, binner: &Binner, hist: &mut [u64]) -> f64 {
    let dim = a.len();
    let mut max_d2: f64 = 0.0;
    match norm {
        Norm::Euclidean => {
            for b in others.chunks_exact(dim) {
                let mut d2 = 0.0;
                for c in 0..dim {
                    let d = a[c] - b[c];
                    d2 += d * d;
                }
                max_d2 = max_d2.max(d2);
                hist[binner.bin(d2)] += 1;
            }
        }
        Norm::Max => {
            for b in others.chunks_exact(dim) {
                let mut m: f64 = 0.0;
                for c in 0..dim {
                    m = m.max((a[c] - b[c]).abs());
                }
                let d2 = m * m;
                max_d2 = max_d2.max(d2);
                hist[binner.bin(d2)] += 1;
            }
        }
    }
    max_d2
}

fn local_slopes(r: &[f64], c: &[f64]) -> Vec<f64> {
    let n = r.len();
    (0..n)
        .map(|k| {
            if n < 2 {
                return 0.0;
            }
            let (a, b) = if k == 0 {
                (0, 1)
            } else if k == n - 1 {
                (n - 2, n - 1)
            } else {
                (k - 1, k + 1)
            };
            (c[b].ln() - c[a].ln()) / (r[b].ln() - r[a].ln())
        })
        .collect()
}

/// Apply the scaling-range rule (module docs) to a curve.
pub fn fit_scaling_range(curve: &CorrelationCurve, rule: &ScalingRule) -> Result<DimensionEstimate> {
    positive("tolerance", rule.tolerance)?;
    positive("upper_fraction", rule.upper_fraction)?;
    at_least("min_points", rule.min_points, 2)?;
    let r_upper = rule.upper_fraction * curve.diameter;
    let eligible: Vec<usize> =
        (0..curve.radius.len()).filter(|&k| curve.count[k] >= rule.min_pairs && curve.radius[k] <= r_upper).collect();
    if eligible.len() < rule.min_points {
        return Err(ChaosError::NoScalingRange {
            reason: format!(
                "{} grid radii have >= {} pairs and r <= {} x diameter ({:.4e}); need {}",
                eligible.len(),
                rule.min_pairs,
                rule.upper_fraction,
                curve.diameter,
                rule.min_points
            ),
        });
    }
    // Eligible radii are contiguous (count and r both increase with k).
    let (ka, kb) = (eligible[0], *eligible.last().unwrap_or(&eligible[0]));
    let best = crate::longest_consistent_run(&curve.local_slope, ka, kb, rule.tolerance, rule.min_points);
    let Some((a, b, sd, med)) = best else {
        return Err(ChaosError::NoScalingRange {
            reason: format!(
                "no run of {} consecutive local slopes within +-{:.0}% of their median between r = {:.3e} and {:.3e}",
                rule.min_points,
                100.0 * rule.tolerance,
                curve.radius[ka],
                curve.radius[kb]
            ),
        });
    };
    let x: Vec<f64> = curve.radius[a..=b].iter().map(|r| r.ln()).collect();
    let y: Vec<f64> = curve.c[a..=b].iter().map(|c| c.ln()).collect();
    let LineFit { slope, slope_stderr, .. } = fit_line(&x, &y)?;
    Ok(DimensionEstimate {
        dimension: slope,
        slope_std: sd,
        fit_stderr: slope_stderr,
        median_slope: med,
        r_range: (curve.radius[a], curve.radius[b]),
        index_range: (a, b),
        curve: curve.clone(),
    })
}

/// Correlation sum plus the scaling-range rule. Call [`correlation_sum`] and
/// [`fit_scaling_range`] separately to keep the curve when no range is found.
pub fn correlation_dimension(points: &Points, params: &CorrSumParams, rule: &ScalingRule) -> Result<DimensionEstimate> {
    let curve = correlation_sum(points, params)?;
    fit_scaling_range(&curve, rule)
}

/// The paper's rule (appendix A): the SSM dimension is the smallest even integer strictly
/// above the fractal-dimension estimate (pass `dimension + error bar` for a conservative
/// choice). `4.39 -> 6`, `4.0 -> 6`, `3.9 -> 4`.
pub fn ssm_dimension(dimension: f64) -> Result<usize> {
    if !(0.0..=1e6).contains(&dimension) {
        return Err(ChaosError::BadParameter {
            name: "dimension",
            value: dimension,
            reason: "must be finite, >= 0 and <= 1e6",
        });
    }
    let above = dimension.floor() as usize + 1;
    Ok(if above % 2 == 0 { above } else { above + 1 })
}
