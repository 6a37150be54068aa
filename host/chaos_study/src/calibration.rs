//! The Rosenstein estimator calibrated on known answers sampled like the inverted flag
//! (docs/decisions/0002): smooth chaotic systems whose largest exponent is known exactly (Benettin with
//! the exact tangent dynamics of the equations that produce the series), sampled so that the
//! data settings choose the flag's lag (the first zero of the autocorrelation: 11 samples at
//! the model step 4), cut to the flag's held-out length (1,973 samples), observed with white
//! measurement noise at the flag's measured level relative to the series' standard deviation,
//! and passed through exactly the estimator and settings used on the flag
//! ([`crate::estimator_check::rosenstein_as_on_data`]). Each row gives Rosenstein / exact
//! over several segments of one long orbit (mean and spread) and the correlation dimension
//! the data settings read on the noise-free series, so attractors like the flag's (D2 about 3)
//! can be told from the low-dimensional ones.
//!
//! Systems: Rössler (x), Lorenz (z), the hyperchaotic Rössler flow (x; two positive
//! exponents), Lorenz-96 with five sites (x1) and the Mackey-Glass delay equation at tau = 30
//! (Heun's method on a grid of 300 delay steps; the exact exponent is the discretized map's,
//! the map that produces the series).

use chaos::reference::{Flow, HyperRossler, Lorenz, Lorenz96, Rossler, rk4_flow};
use chaos::{
    BenettinParams, CorrSumParams, ScalingRule, benettin_tangent, correlation_dimension, delay_embed,
    first_zero_crossing,
};
use serde::Serialize;

use crate::Error;
use crate::estimator_check::{EMBED, rosenstein_as_on_data};
use chaos::add_noise;

/// How the flag's held-out series at the model step looks to the estimator: its sampling
/// step (s), length, the lag and Theiler window the data settings choose on it, its
/// measurement-noise level (the [`crate::model_selection::DataStats::noise_sd`] rule) over
/// its standard deviation, and its Rosenstein exponent (1/s).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct FlagSampling {
    pub dt: f64,
    pub samples: usize,
    pub lag: usize,
    pub theiler: usize,
    pub noise_rel: f64,
    pub lle: f64,
}

/// traj_8 at step 4 (measured by `model_selection::data_stats`; checked against the data in
/// the tests): 1,973 samples, lag 11, Theiler window 38, noise sd 0.001759 over the series sd
/// 0.5487 (the tip deflection at the full frame rate), Rosenstein exponent 0.3320 1/s.
pub const FLAG_SAMPLING: FlagSampling =
    FlagSampling { dt: 4.0 / 30.0, samples: 1973, lag: 11, theiler: 38, noise_rel: 0.001759 / 0.5487, lle: 0.3320 };

/// A smooth system sampled at a fixed step: `advance` moves state and tangent one sample.
trait Sampled: Sync {
    fn name(&self) -> &'static str;
    fn observable(&self) -> &'static str;
    fn start(&self) -> Vec<f64>;
    /// One sample of time `dt` of the state and a tangent vector together.
    fn advance(&self, x: &mut [f64], v: &mut [f64], dt: f64);
    /// The observed value of a state.
    fn observe(&self, x: &[f64]) -> f64;
    /// A step fine enough to measure the lag (about 50 samples per quarter oscillation).
    fn fine_dt(&self) -> f64;
}

/// A flow as a [`Sampled`] system.
struct FlowSystem<F: Flow> {
    flow: F,
    name: &'static str,
    observable: &'static str,
    obs: usize,
    x0: Vec<f64>,
    max_h: f64,
    fine_dt: f64,
}
impl<F: Flow> Sampled for FlowSystem<F> {
    fn name(&self) -> &'static str {
        self.name
    }
    fn observable(&self) -> &'static str {
        self.observable
    }
    fn start(&self) -> Vec<f64> {
        self.x0.clone()
    }
    fn advance(&self, x: &mut [f64], v: &mut [f64], dt: f64) {
        rk4_flow(&self.flow, x, v, dt, (dt / self.max_h).ceil().max(1.0) as usize);
    }
    fn observe(&self, x: &[f64]) -> f64 {
        x[self.obs]
    }
    fn fine_dt(&self) -> f64 {
        self.fine_dt
    }
}

/// The Mackey-Glass equation `x' = 0.2 x(t - tau) / (1 + x(t - tau)^10) - 0.1 x` by Heun's
/// method with `n` steps per delay: the state is the last `n + 1` grid values (oldest first),
/// the tangent is the exact derivative of that map.
struct MackeyGlass {
    tau: f64,
    n: usize,
}
impl MackeyGlass {
    fn g(u: f64) -> f64 {
        0.2 * u / (1.0 + u.powi(10))
    }
    fn dg(u: f64) -> f64 {
        let p = u.powi(10);
        0.2 * (1.0 + p - 10.0 * p) / ((1.0 + p) * (1.0 + p))
    }
    fn h(&self) -> f64 {
        self.tau / self.n as f64
    }
    /// One Heun step of state and tangent (both `n + 1` values, oldest first).
    fn heun(&self, x: &mut [f64], v: &mut [f64]) {
        let (n, h) = (self.n, self.h());
        let (xn, xd, xd1) = (x[n], x[0], x[1]);
        let k1 = Self::g(xd) - 0.1 * xn;
        let pred = xn + h * k1;
        let k2 = Self::g(xd1) - 0.1 * pred;
        let next = xn + 0.5 * h * (k1 + k2);
        let dk1 = Self::dg(xd) * v[0] - 0.1 * v[n];
        let dpred = v[n] + h * dk1;
        let dk2 = Self::dg(xd1) * v[1] - 0.1 * dpred;
        let dnext = v[n] + 0.5 * h * (dk1 + dk2);
        x.copy_within(1.., 0);
        v.copy_within(1.., 0);
        x[n] = next;
        v[n] = dnext;
    }
}
impl Sampled for MackeyGlass {
    fn name(&self) -> &'static str {
        "Mackey-Glass tau = 30"
    }
    fn observable(&self) -> &'static str {
        "x"
    }
    fn start(&self) -> Vec<f64> {
        (0..=self.n).map(|k| 0.9 + 0.1 * (k as f64 * 0.37).sin()).collect()
    }
    fn advance(&self, x: &mut [f64], v: &mut [f64], dt: f64) {
        let steps = (dt / self.h()).round().max(1.0) as usize;
        for _ in 0..steps {
            self.heun(x, v);
        }
    }
    fn observe(&self, x: &[f64]) -> f64 {
        x[self.n]
    }
    fn fine_dt(&self) -> f64 {
        self.h()
    }
}

fn lorenz96(n: usize, f: f64, name: &'static str) -> Box<dyn Sampled> {
    let mut x0 = vec![f; n];
    x0[0] += 0.01;
    Box::new(FlowSystem { flow: Lorenz96 { n, f }, name, observable: "x1", obs: 0, x0, max_h: 0.005, fine_dt: 0.005 })
}

/// The systems of [`calibration_rows`], in report order: first those whose exponent per lag
/// time is at most 0.21 (D2 2.1-2.7), then Lorenz-96 at growing chaos per lag time (0.25 to
/// 0.81, D2 3.5-4.4), the range of the flag (0.49 at its Rosenstein value).
fn systems() -> Vec<Box<dyn Sampled>> {
    vec![
        Box::new(FlowSystem {
            flow: Rossler::default(),
            name: "Rössler",
            observable: "x",
            obs: 0,
            x0: vec![1.0, 1.0, 1.0],
            max_h: 0.02,
            fine_dt: 0.03,
        }),
        Box::new(FlowSystem {
            flow: Lorenz::default(),
            name: "Lorenz",
            observable: "z",
            obs: 2,
            x0: vec![1.0, 1.0, 1.0],
            max_h: 0.005,
            fine_dt: 0.004,
        }),
        Box::new(FlowSystem {
            flow: HyperRossler,
            name: "hyperchaotic Rössler",
            observable: "x",
            obs: 0,
            x0: vec![-10.0, -6.0, 0.0, 10.0],
            max_h: 0.005,
            fine_dt: 0.03,
        }),
        Box::new(MackeyGlass { tau: 30.0, n: 300 }),
        lorenz96(5, 8.0, "Lorenz-96 N = 5, F = 8"),
        lorenz96(5, 9.0, "Lorenz-96 N = 5, F = 9"),
        lorenz96(5, 10.0, "Lorenz-96 N = 5, F = 10"),
        lorenz96(6, 9.0, "Lorenz-96 N = 6, F = 9"),
        lorenz96(5, 20.0, "Lorenz-96 N = 5, F = 20"),
        lorenz96(6, 10.0, "Lorenz-96 N = 6, F = 10"),
    ]
}

/// Calibration of the estimator on one system at one noise level.
#[derive(Clone, Debug, Serialize)]
pub struct CalibrationRow {
    pub system: String,
    pub observable: String,
    /// Sampling step (chosen so that the data settings' lag is the flag's), lag and Theiler
    /// window the data settings chose on the first segment, samples per segment.
    pub dt: f64,
    pub lag: usize,
    pub theiler: usize,
    pub samples: usize,
    /// Exact largest exponent (Benettin on the equations), 1/s, and its block error.
    pub exact: f64,
    pub exact_err: f64,
    /// `exact x lag x dt`: the exponent per lag time, the attractor's chaos per quarter
    /// oscillation (the flag's Rosenstein value reads 0.49).
    pub per_lag: f64,
    /// Correlation dimension (data settings) of the first noise-free segment and its error bar.
    pub corr_dim: Option<f64>,
    pub corr_dim_err: Option<f64>,
    /// Noise sd over the series sd.
    pub noise_rel: f64,
    /// Segments whose Rosenstein estimate could be fitted, of `segments`.
    pub fitted: usize,
    pub segments: usize,
    /// Mean and sd over the segments of Rosenstein / exact.
    pub ratio_mean: Option<f64>,
    pub ratio_sd: Option<f64>,
    /// Median, smallest and largest Rosenstein / exact over the segments.
    pub ratio_median: Option<f64>,
    pub ratio_min: Option<f64>,
    pub ratio_max: Option<f64>,
    pub ratios: Vec<f64>,
    pub notes: Vec<String>,
}

/// `n` observed samples of `sys` every `dt` after `transient` samples.
fn orbit(sys: &dyn Sampled, dt: f64, transient: usize, n: usize) -> Vec<f64> {
    let mut x = sys.start();
    let mut v = vec![0.0; x.len()];
    for _ in 0..transient {
        sys.advance(&mut x, &mut v, dt);
    }
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        out.push(sys.observe(&x));
        sys.advance(&mut x, &mut v, dt);
    }
    out
}

/// The exact largest exponent of `sys` (Benettin with its exact tangent, renormalized every
/// sample of `dt`, 20 blocks over `steps` samples after `transient`), 1/s, and its block error.
fn exponent(sys: &dyn Sampled, dt: f64, transient: usize, steps: usize) -> Result<(f64, f64), Error> {
    let p = BenettinParams { transient, steps, time_step: dt, renorm_every: 1, bound: 1e6, blocks: 20 };
    let r = benettin_tangent(&sys.start(), |x, v| sys.advance(x, v, dt), &p)?;
    Ok((r.exponent, r.std_error))
}

fn sd(x: &[f64]) -> f64 {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n).sqrt()
}

/// The step at which the data settings' lag on `sys` is `lag` samples: the lag measured on a
/// finely sampled series (5,000 lags' worth), scaled.
fn step_for_lag(sys: &dyn Sampled, lag: usize) -> Result<f64, Error> {
    let h = sys.fine_dt();
    let x = orbit(sys, h, 20_000, 40_000);
    let l0 = first_zero_crossing(&x, x.len() / 4)?.max(1);
    Ok(h * l0 as f64 / lag as f64)
}

/// Rosenstein (data settings) against the exact exponent for every system, sampled like the
/// flag (`f`), at each relative noise level of `noise` (multiples of `f.noise_rel`), over
/// `segments` disjoint segments of `f.samples` samples of one orbit. On the rayon pool, rows
/// in (system, noise) order.
pub fn calibration_rows(f: &FlagSampling, noise: &[f64], segments: usize) -> Result<Vec<CalibrationRow>, Error> {
    if f.samples < 200 || f.lag == 0 || segments == 0 || noise.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
        return Err(Error::BadOption {
            what: "calibration",
            why: format!(
                "need >= 200 samples, lag >= 1, >= 1 segment and finite noise multiples >= 0 (got {f:?}, {segments}, {noise:?})"
            ),
        });
    }
    let sys = systems();
    let per_system = crate::par_map(&sys, |s| {
        let dt = step_for_lag(s.as_ref(), f.lag)?;
        let (exact, err) = exponent(s.as_ref(), dt, 5_000, 20_000)?;
        let x = orbit(s.as_ref(), dt, 5_000, f.samples * segments);
        Ok::<_, Error>((dt, x, exact, err))
    })?;
    let jobs: Vec<(usize, f64)> = (0..sys.len()).flat_map(|i| noise.iter().map(move |&m| (i, m))).collect();
    crate::par_map(&jobs, |&(i, mult)| {
        let (s, (dt, x, exact, err)) = (&sys[i], &per_system[i]);
        let noise_rel = mult * f.noise_rel;
        let mut notes = Vec::new();
        let mut ratios = Vec::new();
        let (mut lag, mut theiler) = (0, 0);
        let (mut corr_dim, mut corr_dim_err) = (None, None);
        for (k, seg) in x.chunks_exact(f.samples).enumerate() {
            let y = if noise_rel > 0.0 { add_noise(seg, noise_rel * sd(seg), 7 + k as u64) } else { seg.to_vec() };
            let (l, lg, th, note) = rosenstein_as_on_data(&y, *dt)?;
            if k == 0 {
                (lag, theiler) = (lg, th);
                let cd = delay_embed(seg, EMBED, lg).and_then(|p| {
                    correlation_dimension(
                        &p,
                        &CorrSumParams { theiler: th, ..Default::default() },
                        &ScalingRule::default(),
                    )
                });
                match cd {
                    Ok(cd) => (corr_dim, corr_dim_err) = (Some(cd.dimension), Some(cd.slope_std)),
                    Err(e) => notes.push(format!("correlation dimension: {e}")),
                }
            }
            if !note.is_empty() {
                notes.push(format!("segment {}: {note}", k + 1));
            }
            if let Some(l) = l {
                ratios.push(l / exact);
            }
        }
        let (ratio_mean, ratio_sd) = match ratios.len() {
            0 => (None, None),
            1 => (Some(ratios[0]), None),
            n => {
                let m = ratios.iter().sum::<f64>() / n as f64;
                (Some(m), Some((ratios.iter().map(|r| (r - m) * (r - m)).sum::<f64>() / (n - 1) as f64).sqrt()))
            }
        };
        let mut sorted = ratios.clone();
        sorted.sort_by(f64::total_cmp);
        let ratio_median = (!sorted.is_empty()).then(|| {
            let m = sorted.len() / 2;
            if sorted.len() % 2 == 1 { sorted[m] } else { 0.5 * (sorted[m - 1] + sorted[m]) }
        });
        Ok(CalibrationRow {
            system: s.name().to_string(),
            observable: s.observable().to_string(),
            dt: *dt,
            lag,
            theiler,
            samples: f.samples,
            exact: *exact,
            exact_err: *err,
            per_lag: exact * f.lag as f64 * dt,
            corr_dim,
            corr_dim_err,
            noise_rel,
            fitted: ratios.len(),
            segments,
            ratio_mean,
            ratio_sd,
            ratio_median,
            ratio_min: sorted.first().copied(),
            ratio_max: sorted.last().copied(),
            ratios,
            notes,
        })
    })
}

/// Rows whose exponent per lag time is at most this are the smooth, weakly chaotic regime
/// (Rössler, Lorenz, hyperchaotic Rössler, Mackey-Glass, Lorenz-96 5/8: 0.10-0.19).
pub const CALM_PER_LAG: f64 = 0.22;

/// What the calibration says about the flag's number.
#[derive(Clone, Debug, Serialize)]
pub struct CalibrationSummary {
    /// The flag's Rosenstein exponent at the model step, 1/s, and its exponent per lag time
    /// (`lle x lag x dt`).
    pub data_lle: f64,
    pub data_per_lag: f64,
    /// Rows at the flag's noise level with exponent per lag time <= [`CALM_PER_LAG`]:
    /// their range of mean ratios, of single-segment ratios, and the largest segment sd.
    pub calm_mean_range: (f64, f64),
    pub calm_segment_range: (f64, f64),
    pub calm_segment_sd_max: f64,
    /// The data's exponent if the estimator read it as on the calm rows (data lle over the
    /// mean-ratio range), 1/s.
    pub calm_implied_exponent: (f64, f64),
    /// Rows at the flag's noise level with more chaos per lag time (the flag's regime):
    /// the range of mean ratios and of single-segment ratios.
    pub chaotic_mean_range: (f64, f64),
    pub chaotic_segment_range: (f64, f64),
    /// The data's exponent if the estimator read it as on one of these rows (data lle over
    /// the mean-ratio range), 1/s.
    pub chaotic_implied_exponent: (f64, f64),
    /// Largest change of a calm row's mean ratio from no noise to the flag's noise level.
    pub calm_noise_shift_max: f64,
}

fn range(v: impl Iterator<Item = f64>) -> (f64, f64) {
    v.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)))
}

/// The summary of `rows` ([`calibration_rows`] with noise multiples 0 and 1 among others) for
/// the flag sampled as `f`; `None` when a regime has no fitted row at the flag's noise level.
pub fn summarize(rows: &[CalibrationRow], f: &FlagSampling) -> Option<CalibrationSummary> {
    let data_lle = f.lle;
    let at_flag: Vec<&CalibrationRow> =
        rows.iter().filter(|r| r.noise_rel == f.noise_rel && r.ratio_mean.is_some()).collect();
    let (calm, chaotic): (Vec<&CalibrationRow>, Vec<&CalibrationRow>) =
        at_flag.iter().partition(|r| r.per_lag <= CALM_PER_LAG);
    if calm.is_empty() || chaotic.is_empty() {
        return None;
    }
    let calm_mean_range = range(calm.iter().filter_map(|r| r.ratio_mean));
    let chaotic_mean_range = range(chaotic.iter().filter_map(|r| r.ratio_mean));
    let shift = calm
        .iter()
        .filter_map(|r| {
            let clean = rows.iter().find(|c| c.noise_rel == 0.0 && c.system == r.system)?;
            Some((r.ratio_mean? - clean.ratio_mean?).abs())
        })
        .fold(0.0, f64::max);
    Some(CalibrationSummary {
        data_lle,
        data_per_lag: data_lle * f.lag as f64 * f.dt,
        calm_mean_range,
        calm_segment_range: range(calm.iter().flat_map(|r| r.ratios.iter().copied())),
        calm_segment_sd_max: calm.iter().filter_map(|r| r.ratio_sd).fold(0.0, f64::max),
        calm_implied_exponent: (data_lle / calm_mean_range.1, data_lle / calm_mean_range.0),
        chaotic_mean_range,
        chaotic_implied_exponent: (data_lle / chaotic_mean_range.1, data_lle / chaotic_mean_range.0),
        chaotic_segment_range: range(chaotic.iter().flat_map(|r| r.ratios.iter().copied())),
        calm_noise_shift_max: shift,
    })
}
