#![doc = include_str!("../README.md")]
// Library code returns errors: no unwrap/expect/panic (CI runs clippy); the tests are in
// `tests/`, so the library is never built with `cfg(test)`.
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

pub mod benettin;
pub mod corrdim;
pub mod density;
pub mod embed;
pub mod fsle;
pub mod held_out;
pub mod lyapunov;
pub mod reference;
pub mod rng;
pub mod surrogate;
pub mod zero_one;

/// Not part of the API: kernels and helpers public only for the tests in `tests/`, which
/// check them against plain reference loops bit for bit. They may change without notice.
#[doc(hidden)]
pub mod internals {
    pub use crate::corrdim::{Binner, accumulate, accumulate_any};
    pub use crate::lyapunov::{SortedAxis, check_params, finish_curve};
    pub use crate::strided;
    pub use crate::surrogate::{
        IaaftWork, prediction_sse_scan, prediction_sse_sorted, radix_sort, stable_sort_keyed, total_order_key,
    };
}

pub use benettin::{
    BenettinParams, BenettinResult, Orbit, SpectrumResult, benettin_qr, benettin_tangent, benettin_two_trajectory,
    iterate_map, jacobian_tangent_step, kaplan_yorke,
};
pub use corrdim::{
    CorrSumParams, CorrelationCurve, DimensionEstimate, ScalingRule, correlation_dimension, correlation_sum,
    fit_scaling_range, ssm_dimension,
};
pub use density::{Bins, CoordinatePdf, PdfComparison, compare_pdfs, jensen_shannon_bits};
pub use embed::{autocorrelation, delay_embed, dominant_period, first_zero_crossing, lag_and_period};
pub use fsle::{FsleRow, FsleSeriesParams, fsle_from_separations, fsle_series, scaling_slope, thresholds};
pub use held_out::{
    Context, GrowthWindow, Reference, Statistics, Targets, add_noise, best_of, dimension_rule, fit_lle_curve,
    growth_windows, is_chaotic, moving_average, noise_sd, rollout_error, rollout_horizon,
};
pub use lyapunov::{
    DivergenceCurve, DivergenceFit, DivergenceParams, FitRule, KantzEstimate, LyapunovEstimate, fit_divergence, kantz,
    kantz_curves, log_spaced, rosenstein, rosenstein_curve,
};
pub use surrogate::{Statistic, SurrogateParams, SurrogateResult, surrogate_test, surrogate_tests};
pub use zero_one::{ZeroOneParams, ZeroOneResult, zero_one_test};

/// Everything that can go wrong in this crate. Each variant names the offending input.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ChaosError {
    /// The series (or point set) has fewer samples than the parameters need.
    #[error("series too short for {param}: {have} samples, need at least {need}")]
    TooShort { param: &'static str, have: usize, need: usize },
    /// A NaN or infinite value in the input.
    #[error("non-finite input value {value} at sample {index}, coordinate {coord}")]
    NonFinite { index: usize, coord: usize, value: f64 },
    /// A coordinate that never changes: no attractor to measure.
    #[error("coordinate {coord} has zero variance (constant {value})")]
    ZeroVariance { coord: usize, value: f64 },
    /// A parameter outside its valid range.
    #[error("bad parameter {name} = {value}: {reason}")]
    BadParameter { name: &'static str, value: f64, reason: &'static str },
    /// Inputs whose shapes do not agree (dimension of points, tangent vector, ...).
    #[error("shape mismatch for {what}: expected {expected}, got {got}")]
    Shape { what: &'static str, expected: usize, got: usize },
    /// The correlation curve has no radius range satisfying the scaling rule.
    #[error("no scaling range: {reason}")]
    NoScalingRange { reason: String },
    /// The divergence curve gives no usable fit window.
    #[error("no fit window: {reason}")]
    NoFitWindow { reason: String },
    /// An iterated map or flow left its bound or produced a non-finite state.
    #[error("orbit escaped at step {step}: {reason} (max |x_i| = {norm})")]
    Escape { step: usize, norm: f64, reason: &'static str },
    /// A tangent vector or trajectory separation became exactly zero (e.g. a quantized map
    /// that sends nearby states to the same state): no exponent at that scale.
    #[error("separation collapsed to zero at step {step}")]
    Collapsed { step: usize },
    /// A Jacobian was requested where the map is not differentiable.
    #[error("map not differentiable at step {step}: {reason}")]
    NotDifferentiable { step: usize, reason: &'static str },
}

pub type Result<T> = std::result::Result<T, ChaosError>;

/// Distance used between points (embedding vectors or model states).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Norm {
    /// Euclidean distance.
    #[default]
    Euclidean,
    /// Maximum of the absolute coordinate differences (cheaper; the usual choice of TISEAN).
    Max,
}

impl Norm {
    /// The squared distance (for `Max`, the square of the max-norm), so that comparisons
    /// against squared radii work for both norms.
    #[inline]
    pub fn dist2(self, a: &[f64], b: &[f64]) -> f64 {
        match self {
            Norm::Euclidean => a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum(),
            Norm::Max => {
                let m = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
                m * m
            }
        }
    }
}

/// A time-ordered set of points of equal dimension: delay vectors of a scalar series, or
/// states of a (reduced) model trajectory. Stored row-major. All values are finite.
#[derive(Debug, Clone, PartialEq)]
pub struct Points {
    dim: usize,
    data: Vec<f64>,
}

impl Points {
    /// Points of dimension `dim` from a flat row-major buffer.
    pub fn from_flat(dim: usize, data: Vec<f64>) -> Result<Self> {
        if dim == 0 {
            return Err(ChaosError::BadParameter {
                name: "dim",
                value: 0.0,
                reason: "points need at least one coordinate",
            });
        }
        if data.len() % dim != 0 {
            return Err(ChaosError::Shape {
                what: "flat point buffer length (multiple of dim)",
                expected: data.len() / dim * dim + dim,
                got: data.len(),
            });
        }
        check_finite(&data, dim)?;
        Ok(Self { dim, data })
    }

    /// Points from rows (e.g. model states); every row must have the same length.
    pub fn from_rows<R: AsRef<[f64]>>(rows: &[R]) -> Result<Self> {
        let dim = rows.first().map_or(0, |r| r.as_ref().len());
        let mut data = Vec::with_capacity(dim * rows.len());
        for r in rows {
            let r = r.as_ref();
            if r.len() != dim {
                return Err(ChaosError::Shape { what: "row length", expected: dim, got: r.len() });
            }
            data.extend_from_slice(r);
        }
        Self::from_flat(dim, data)
    }

    /// A scalar series as one-dimensional points.
    pub fn from_series(x: &[f64]) -> Result<Self> {
        Self::from_flat(1, x.to_vec())
    }

    pub fn dim(&self) -> usize {
        self.dim
    }
    pub fn len(&self) -> usize {
        self.data.len() / self.dim
    }
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
    /// Point `i` (panics if out of range, like slice indexing).
    #[inline]
    pub fn point(&self, i: usize) -> &[f64] {
        &self.data[i * self.dim..(i + 1) * self.dim]
    }
    pub fn as_flat(&self) -> &[f64] {
        &self.data
    }
    /// Coordinate `c` of every point.
    pub fn column(&self, c: usize) -> Vec<f64> {
        self.data.iter().skip(c).step_by(self.dim).copied().collect()
    }

    /// Error if any coordinate has zero variance.
    pub(crate) fn check_variance(&self) -> Result<()> {
        for c in 0..self.dim {
            let first = self.data[c];
            if self.data.iter().skip(c).step_by(self.dim).all(|&v| v == first) {
                return Err(ChaosError::ZeroVariance { coord: c, value: first });
            }
        }
        Ok(())
    }

    /// Per-coordinate (min, max).
    pub(crate) fn bounds(&self) -> Vec<(f64, f64)> {
        let mut b = vec![(f64::INFINITY, f64::NEG_INFINITY); self.dim];
        for p in self.data.chunks_exact(self.dim) {
            for (bc, &v) in b.iter_mut().zip(p) {
                bc.0 = bc.0.min(v);
                bc.1 = bc.1.max(v);
            }
        }
        b
    }
}

pub(crate) fn check_finite(data: &[f64], dim: usize) -> Result<()> {
    match data.iter().position(|v| !v.is_finite()) {
        Some(k) => Err(ChaosError::NonFinite { index: k / dim, coord: k % dim, value: data[k] }),
        None => Ok(()),
    }
}

pub(crate) fn positive(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ChaosError::BadParameter { name, value: v, reason: "must be finite and > 0" })
    }
}

pub(crate) fn at_least(name: &'static str, v: usize, min: usize) -> Result<()> {
    if v >= min { Ok(()) } else { Err(ChaosError::BadParameter { name, value: v as f64, reason: "below its minimum" }) }
}

/// Evenly strided subset of `0..n` of at most `max` indices (all of them when `n <= max`).
#[doc(hidden)]
pub fn strided(n: usize, max: usize) -> Vec<usize> {
    if n <= max { (0..n).collect() } else { (0..max).map(|k| k * n / max).collect() }
}

/// Ordinary least-squares line `y = intercept + slope * x`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LineFit {
    pub slope: f64,
    pub intercept: f64,
    /// Standard error of the slope from the residuals (0 for two points).
    pub slope_stderr: f64,
}

/// Least squares over `(x, y)`; needs at least two distinct `x`.
pub fn fit_line(x: &[f64], y: &[f64]) -> Result<LineFit> {
    if x.len() != y.len() {
        return Err(ChaosError::Shape { what: "fit_line y length", expected: x.len(), got: y.len() });
    }
    let n = x.len();
    if n < 2 {
        return Err(ChaosError::TooShort { param: "line fit", have: n, need: 2 });
    }
    let nf = n as f64;
    let mx = x.iter().sum::<f64>() / nf;
    let my = y.iter().sum::<f64>() / nf;
    let sxx: f64 = x.iter().map(|v| (v - mx) * (v - mx)).sum();
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    if sxx <= 0.0 {
        return Err(ChaosError::ZeroVariance { coord: 0, value: mx });
    }
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let slope_stderr = if n > 2 {
        let ss: f64 = x.iter().zip(y).map(|(a, b)| (b - intercept - slope * a).powi(2)).sum();
        (ss / (nf - 2.0) / sxx).sqrt()
    } else {
        0.0
    };
    Ok(LineFit { slope, intercept, slope_stderr })
}

/// Mean and sample standard deviation (over `n - 1`; 0 for one value) of `v`.
pub fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = if v.len() > 1 { v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0) } else { 0.0 };
    (m, var.sqrt())
}

/// The longest run `a..=b` inside `lo..=hi` (at least `min_points` long) of values that all
/// lie within `tol * |median|` of the run's own median; ties go to the smaller standard
/// deviation. Returns `(a, b, std, median)`.
pub(crate) fn longest_consistent_run(
    s: &[f64],
    lo: usize,
    hi: usize,
    tol: f64,
    min_points: usize,
) -> Option<(usize, usize, f64, f64)> {
    let mut best: Option<(usize, usize, f64, f64)> = None;
    let mut sorted: Vec<f64> = Vec::new();
    if hi >= s.len() || lo > hi {
        return None;
    }
    for a in lo..=hi {
        if hi + 1 - a < min_points.max(best.map_or(0, |(ba, bb, _, _)| bb + 1 - ba)) {
            break; // no longer run can start here
        }
        sorted.clear();
        let (mut sum, mut sumsq) = (0.0, 0.0);
        for (b, &v) in s.iter().enumerate().take(hi + 1).skip(a) {
            let pos = sorted.partition_point(|&x| x < v);
            sorted.insert(pos, v);
            sum += v;
            sumsq += v * v;
            let len = b + 1 - a;
            if len < min_points {
                continue;
            }
            let med = if len % 2 == 1 { sorted[len / 2] } else { 0.5 * (sorted[len / 2 - 1] + sorted[len / 2]) };
            let band = tol * med.abs();
            if sorted[len - 1] - med > band || med - sorted[0] > band {
                continue;
            }
            let n = len as f64;
            let sd = ((sumsq - sum * sum / n) / (n - 1.0)).max(0.0).sqrt();
            let better = match best {
                None => true,
                Some((ba, bb, bsd, _)) => len > bb + 1 - ba || (len == bb + 1 - ba && sd < bsd),
            };
            if better {
                best = Some((a, b, sd, med));
            }
        }
    }
    best
}
