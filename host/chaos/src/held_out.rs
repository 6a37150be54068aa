//! Long-term statistics of a series measured the same way on data and on a model's output,
//! and the choice of a model by them (docs/decisions/0002), for any series and any map:
//!
//! - [`Context`]: the estimator settings of one series (delay lag = first zero of the
//!   autocorrelation, Theiler window = dominant period, embedding dimension), reused
//!   unchanged on every series compared with it; its Rosenstein exponent with the fit-window
//!   fallbacks of [`fit_lle_curve`] and its correlation dimension.
//! - [`moving_average`], [`noise_sd`], [`add_noise`]: the measurement-noise checks.
//! - [`rollout_error`]: the multi-step loss of a map on a held-out series.
//! - [`Targets`], [`Statistics`], [`Reference`], [`best_of`]: which targets a model's
//!   statistics meet against the data's, its normalized error, and the pick among models.

use serde::Serialize;

use crate::{
    ChaosError, CorrSumParams, DimensionEstimate, DivergenceCurve, DivergenceFit, DivergenceParams, FitRule, Result,
    ScalingRule, correlation_dimension, delay_embed, fit_divergence, lag_and_period, rosenstein_curve, ssm_dimension,
};

/// Estimator settings of a series: sampling step (s), delay lag and Theiler window (samples),
/// embedding dimension.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Context {
    pub dt: f64,
    pub lag: usize,
    pub theiler: usize,
    pub embed: usize,
}

impl Context {
    /// Lag and Theiler window from the autocorrelation of `x` (lags up to a quarter of its
    /// length), each at least 1.
    pub fn from_series(x: &[f64], dt: f64, embed: usize) -> Result<Self> {
        let n = x.len();
        let (lag, theiler) = lag_and_period(x, n / 4)?;
        let (lag, theiler) = (lag.max(1), theiler.max(1));
        Ok(Self { dt, lag, theiler, embed })
    }

    /// Rosenstein/Kantz settings: curve length 3 Theiler windows within 30..1000 samples.
    pub fn divergence_params(&self) -> DivergenceParams {
        DivergenceParams {
            theiler: self.theiler,
            max_steps: (3 * self.theiler).clamp(30, 1000),
            dt: self.dt,
            ..Default::default()
        }
    }

    /// Correlation dimension of `x` embedded in `embed` dimensions with this lag and Theiler
    /// window (the default scaling rule).
    pub fn corr_dim_in(&self, x: &[f64], embed: usize) -> Result<DimensionEstimate> {
        let pts = delay_embed(x, embed, self.lag)?;
        correlation_dimension(
            &pts,
            &CorrSumParams { theiler: self.theiler, ..Default::default() },
            &ScalingRule::default(),
        )
    }

    /// Correlation dimension of `x` with these settings.
    pub fn corr_dim(&self, x: &[f64]) -> Result<DimensionEstimate> {
        self.corr_dim_in(x, self.embed)
    }

    /// SSM dimension by the paper's rule ([`dimension_rule`]) from the correlation dimension
    /// of `x` embedded in `embed` dimensions.
    pub fn ssm_dim_from_data(&self, x: &[f64], embed: usize) -> Result<usize> {
        let cd = self.corr_dim_in(x, embed)?;
        dimension_rule(cd.dimension, cd.slope_std)
    }

    /// Rosenstein divergence curve of series `x` with these settings.
    pub fn divergence(&self, x: &[f64]) -> Result<DivergenceCurve> {
        let pts = delay_embed(x, self.embed, self.lag)?;
        rosenstein_curve(&pts, &self.divergence_params())
    }

    /// Rosenstein exponent (1/s) and fit window (s) of series `x`; fallbacks go to `notes`,
    /// prefixed by `who`.
    pub fn lle(&self, x: &[f64], notes: &mut Vec<String>, who: &str) -> Result<(f64, (f64, f64))> {
        let curve = self.divergence(x)?;
        let (f, note) = fit_lle_curve(&curve)?;
        if let Some(n) = note {
            notes.push(format!("{who}: {n}"));
        }
        Ok((f.exponent, f.window_time))
    }
}

/// The fit-window rule with its fallbacks: the straightest-section rule first; a bent curve
/// (quantized data) with no 5-sample run within +-20 % gets a second try at +-50 %, then a
/// fit over the first 70 % of the rise. The second value says which fallback was used.
pub fn fit_lle_curve(curve: &DivergenceCurve) -> Result<(DivergenceFit, Option<String>)> {
    let rule = FitRule::default();
    match fit_divergence(curve, &rule) {
        Err(ChaosError::NoFitWindow { .. }) => match fit_divergence(curve, &FitRule { tolerance: 0.5, ..rule }) {
            Ok(f) => Ok((f, Some("Lyapunov fit window found only at +-50 % slope tolerance".into()))),
            Err(ChaosError::NoFitWindow { .. }) => match fit_divergence(curve, &FitRule { tolerance: 1e6, ..rule }) {
                Ok(f) => Ok((
                    f,
                    Some("divergence curve has no straight section; slope fitted over its first 70 % rise".into()),
                )),
                Err(ChaosError::NoFitWindow { .. }) => after_noise_jump(curve, &rule),
                Err(e) => Err(e),
            },
            Err(e) => Err(e),
        },
        other => other.map(|f| (f, None)),
    }
}

/// Noisy data: neighbours separate by the noise level in one step, so 70 % of the rise can
/// happen at the first step and no window of 5 samples exists. Drop the initial jump (the
/// steps before the first one whose increment is below a tenth of the total rise) and fit the
/// first 70 % of the rest; the note gives the share of the rise the jump took.
fn after_noise_jump(curve: &DivergenceCurve, rule: &FitRule) -> Result<(DivergenceFit, Option<String>)> {
    let y = &curve.mean_log_distance;
    let rise = y.iter().copied().fold(f64::NEG_INFINITY, f64::max) - y.first().copied().unwrap_or(0.0);
    let skip = (1..y.len()).find(|&k| y[k] - y[k - 1] < 0.1 * rise).unwrap_or(y.len()).saturating_sub(1);
    if skip == 0 || y.len() - skip < 2 * rule.min_points {
        return Err(ChaosError::NoFitWindow {
            reason: format!("no straight section and no noise jump to skip (rise {rise:.3} nats)"),
        });
    }
    let cut = |v: &[f64]| v[skip..].to_vec();
    let tail = DivergenceCurve {
        time: curve.time[skip..].iter().map(|t| t - curve.time[skip]).collect(),
        mean_log_distance: cut(y),
        n_terms: curve.n_terms[skip..].to_vec(),
        n_reference: curve.n_reference,
        zero_distances: curve.zero_distances,
    };
    let jump = (y[skip] - y[0]) / rise;
    let t0 = curve.time[skip];
    fit_divergence(&tail, &FitRule { tolerance: 1e6, min_rise: 0.0, ..*rule }).map(|mut f| {
        f.window_time = (f.window_time.0 + t0, f.window_time.1 + t0);
        (f, Some(format!("noise-dominated first {skip} step(s) ({:.0} % of the rise) skipped; slope fitted over the first 70 % of the rest", 100.0 * jump)))
    })
}

/// Secant slope of a divergence curve over one window `[t0, t1 = 2 t0]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct GrowthWindow {
    pub t0: f64,
    pub t1: f64,
    /// `(y(t1) - y(t0)) / (t1 - t0)`, 1/s (y = mean log distance).
    pub slope: f64,
    /// The same rise read as a power law `d ~ t^a`: `a = (y(t1) - y(t0)) / ln(t1 / t0)`.
    pub power: f64,
}

/// Secant slopes of `curve` over doubling windows `[t, 2t]`, `t` from the first positive
/// time on the curve. Exponential separation keeps the slope fixed (the power grows like
/// t); separation by diffusion along a neutral direction keeps the power fixed (about 0.5)
/// while the slope falls like 1/t. A single Rosenstein number cannot tell them apart.
pub fn growth_windows(curve: &DivergenceCurve) -> Vec<GrowthWindow> {
    let time = &curve.time;
    let y = &curve.mean_log_distance;
    let at = |t: f64| time.iter().position(|&s| s >= t * (1.0 - 1e-9));
    let mut out = Vec::new();
    let Some(mut t) = time.iter().copied().find(|&s| s > 0.0) else { return out };
    while let (Some(a), Some(b)) = (at(t), at(2.0 * t)) {
        let (t0, t1) = (time[a], time[b]);
        if t1 <= t0 {
            break;
        }
        out.push(GrowthWindow { t0, t1, slope: (y[b] - y[a]) / (t1 - t0), power: (y[b] - y[a]) / (t1 / t0).ln() });
        t *= 2.0;
    }
    out
}

/// The paper's rule read with the error bar ("an even number larger than 4.39 +- 0.06"): the
/// smallest even integer above `D2 + err`.
pub fn dimension_rule(d2: f64, err: f64) -> Result<usize> {
    ssm_dimension(d2 + err.max(0.0))
}

/// Centred moving average of `2 w + 1` samples (fewer at the ends); `w = 0` copies.
pub fn moving_average(x: &[f64], w: usize) -> Vec<f64> {
    if w == 0 {
        return x.to_vec();
    }
    let n = x.len();
    (0..n)
        .map(|i| {
            let (a, b) = (i.saturating_sub(w), (i + w + 1).min(n));
            x[a..b].iter().sum::<f64>() / (b - a) as f64
        })
        .collect()
}

/// Measurement-noise level of a series: the sd of its difference from a 5-sample centred
/// moving average over sqrt(4/5) (white noise passes that filter with this factor; motion
/// sampled at tens of samples per period and slower, barely).
pub fn noise_sd(x: &[f64]) -> f64 {
    let ma = moving_average(x, 2);
    let n = x.len().max(1) as f64;
    (x.iter().zip(&ma).map(|(a, b)| (a - b) * (a - b)).sum::<f64>() / n / 0.8).sqrt()
}

/// `x` plus white Gaussian noise of standard deviation `sd` (xorshift64 from `seed`,
/// Box-Muller), the same for every run with the same seed.
pub fn add_noise(x: &[f64], sd: f64, seed: u64) -> Vec<f64> {
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    };
    x.iter()
        .map(|v| {
            let (u1, u2) = (uniform(), uniform());
            v + sd * (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
        })
        .collect()
}

/// Horizon of the rollout loss, map steps: a quarter of the dominant period (`theiler`
/// samples), at least one step. Over a whole period a chaotic model's error saturates near
/// the data's RMS and tells models apart no more (docs/flag-study.md).
pub fn rollout_horizon(theiler: usize) -> usize {
    theiler.div_ceil(4).max(1)
}

/// Multi-step loss of a map `step` (the state in place, one map step) on a held-out series
/// of states `data` (`d` values per point): from `starts` evenly spaced points (each with
/// `horizon` points after it) the map is run `horizon` steps; the RMS over all starts and
/// steps of the distance to the data's points, over the RMS norm of the data's points.
/// `None` when the series is shorter than `horizon + 1` points or a run leaves the finite
/// numbers.
pub fn rollout_error(
    mut step: impl FnMut(&mut [f64]),
    data: &[f64],
    d: usize,
    horizon: usize,
    starts: usize,
) -> Option<f64> {
    let n = data.len() / d.max(1);
    if d == 0 || horizon == 0 || n < horizon + 1 || starts == 0 {
        return None;
    }
    let stride = ((n - horizon) / starts).max(1);
    let (mut err2, mut count) = (0.0, 0usize);
    let mut x = vec![0.0; d];
    for s in (0..n - horizon).step_by(stride) {
        x.copy_from_slice(&data[s * d..(s + 1) * d]);
        for k in 1..=horizon {
            step(&mut x);
            let target = &data[(s + k) * d..(s + k + 1) * d];
            err2 += x.iter().zip(target).map(|(a, b)| (a - b) * (a - b)).sum::<f64>();
            count += 1;
        }
    }
    let norm2 = data.iter().map(|v| v * v).sum::<f64>() / n as f64;
    let e = (err2 / count.max(1) as f64 / norm2).sqrt();
    e.is_finite().then_some(e)
}

/// The targets of a model against the data (docs/decisions/0002): its own (Benettin)
/// exponent positive and within `benettin_rel` of the data's exponent, the Rosenstein
/// exponent of its series within `rosenstein_rel`, its D2 within the data's error bar, the
/// divergence of its densities at most `js_max` bits.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Targets {
    pub benettin_rel: f64,
    pub rosenstein_rel: f64,
    pub js_max: f64,
}

impl Default for Targets {
    fn default() -> Self {
        Self { benettin_rel: 0.10, rosenstein_rel: 0.05, js_max: 0.01 }
    }
}

/// The data's statistics the targets are measured against: exponent (1/s; Rosenstein on
/// data), correlation dimension and its error bar.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Reference {
    pub lle: f64,
    pub corr_dim: f64,
    pub corr_dim_err: f64,
}

/// A model's measured statistics, each `None` when it could not be measured: its own
/// exponent (Benettin, 1/s), the Rosenstein exponent of its series (1/s), the correlation
/// dimension of its series, the divergence of its densities from the data's (bits).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Statistics {
    pub benettin: Option<f64>,
    pub rosenstein: Option<f64>,
    pub corr_dim: Option<f64>,
    pub js: Option<f64>,
}

impl Targets {
    /// Which targets `m` meets against `data`: (Benettin, Rosenstein, D2, JS).
    pub fn passes(&self, m: &Statistics, data: &Reference) -> [bool; 4] {
        let l = data.lle;
        let within = |v: Option<f64>, rel: f64| v.is_some_and(|v| (v - l).abs() <= rel * l.abs());
        [
            m.benettin.is_some_and(|b| b > 0.0) && within(m.benettin, self.benettin_rel),
            within(m.rosenstein, self.rosenstein_rel),
            m.corr_dim.is_some_and(|d| (d - data.corr_dim).abs() <= data.corr_dim_err),
            m.js.is_some_and(|j| j <= self.js_max),
        ]
    }

    /// How many targets `m` meets against `data`.
    pub fn met(&self, m: &Statistics, data: &Reference) -> usize {
        self.passes(m, data).iter().filter(|p| **p).count()
    }

    /// Sum of the errors of `m`, each over its tolerance (Benettin and Rosenstein relative
    /// to the data's exponent, D2 over the data's error bar, JS over its bound); infinite
    /// when a value is missing.
    pub fn score(&self, m: &Statistics, data: &Reference) -> f64 {
        let l = data.lle.abs();
        let e = |v: Option<f64>, r: f64, tol: f64| v.map_or(f64::INFINITY, |v| (v - r).abs() / tol);
        e(m.benettin, data.lle, self.benettin_rel * l)
            + e(m.rosenstein, data.lle, self.rosenstein_rel * l)
            + e(m.corr_dim, data.corr_dim, data.corr_dim_err.max(1e-12))
            + m.js.map_or(f64::INFINITY, |j| j / self.js_max)
    }

    /// The Rosenstein/Benettin ratios `rho` between which the Benettin and Rosenstein
    /// targets can hold together: a model with Benettin `B` within `B_rel` of the data's
    /// exponent `L` and Rosenstein `rho B` within `R_rel` of it needs
    /// `(1 - R_rel) / (1 + B_rel) <= rho <= (1 + R_rel) / (1 - B_rel)`.
    pub fn joint_ratio_range(&self) -> (f64, f64) {
        (
            (1.0 - self.rosenstein_rel) / (1.0 + self.benettin_rel),
            (1.0 + self.rosenstein_rel) / (1.0 - self.benettin_rel),
        )
    }
}

/// Whether a model's own exponent says it is chaotic: positive and above twice its error.
pub fn is_chaotic(benettin: Option<f64>, err: Option<f64>) -> bool {
    match (benettin, err) {
        (Some(b), Some(e)) => b > 2.0 * e && b > 0.0,
        _ => false,
    }
}

/// The best of rows given as (failed, targets met, score): most targets met, ties by the
/// smallest score, the first of equals; failed rows are never picked. (index, met, score).
pub fn best_of(rows: impl IntoIterator<Item = (bool, usize, f64)>) -> Option<(usize, usize, f64)> {
    let mut best: Option<(usize, usize, f64)> = None;
    for (i, (failed, n, sc)) in rows.into_iter().enumerate() {
        if !failed && best.is_none_or(|(_, bn, bs)| n > bn || (n == bn && sc < bs)) {
            best = Some((i, n, sc));
        }
    }
    best
}
