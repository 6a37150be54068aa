//! The flag pipeline on a known chaotic system (docs/decisions/0002): can our pipeline recover a chaotic
//! model from data like the inverted flag's at all?
//!
//! A smooth chaotic system whose largest exponent is known exactly (Benettin with the exact
//! tangent dynamics of its equations) is sampled like the flag: at a full-rate step chosen so
//! that the data settings pick the flag's lag (11 samples at the model step 4), two training
//! series and one held-out series of the flag's lengths (12,922, 12,631 and 7,890 samples; or
//! `scale` times longer training series), white measurement noise at the flag's level relative
//! to each series' sd. The series go through exactly the flag's model search
//! ([`crate::model_selection::evaluate_and_select`] with flag-like candidates: map step 4, SSM
//! dimension 4, embedding 9, RBF and polynomial maps); each model's Benettin exponent is then
//! compared with the system's exact exponent, and its Rosenstein exponent, D2 and PDFs with
//! the held-out data's, measured as on the flag.
//!
//! Systems ([`KnownSystem`]): Lorenz-96 (`x_i' = (x_{i+1} - x_{i-2}) x_{i-1} - x_i + F`, observed
//! `x_1`), two Lorenz systems coupled diffusively in `x` (observed `x_1 + x_2`), and the Lorenz
//! system observed by `x` (the lobe switching makes its autocorrelation slow: much chaos per
//! lag, like the flag).

use chaos::reference::{Flow, Lorenz, Lorenz96, Rossler, rk4_flow};
use chaos::{BenettinParams, benettin_tangent, first_zero_crossing};
use serde::{Deserialize, Serialize};
use ssm::{FitOptions, TimeSeries};

use crate::Error;
use crate::model_selection::{Candidate, CandidateResult, EvalSettings, data_stats, evaluate_and_select};
use chaos::{Reference, Statistics, Targets, add_noise};

/// The flag's sampling as the pipeline sees it: full-rate lengths of the training series
/// (traj_9, traj_7) and of the held-out series (traj_8), the map step, the lag the data
/// settings choose at that step, and the measurement noise over the series sd
/// ([`crate::calibration::FLAG_SAMPLING`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlagLayout {
    pub train: [usize; 2],
    pub test: usize,
    pub step: usize,
    pub lag: usize,
    pub noise_rel: f64,
}

/// The flag's layout (series lengths counted from the data files, lag and noise from
/// [`crate::calibration::FLAG_SAMPLING`]).
pub const FLAG_LAYOUT: FlagLayout = FlagLayout {
    train: [12_922, 12_631],
    test: 7_890,
    step: 4,
    lag: 11,
    noise_rel: crate::calibration::FLAG_SAMPLING.noise_rel,
};

/// A smooth chaotic flow with a known exact exponent.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub enum KnownSystem {
    /// Lorenz-96 with `n` sites and forcing `f`, observed `x_1`.
    Lorenz96 { n: usize, f: f64 },
    /// Two Lorenz systems (10, 28, 8/3) with `x_1' += c (x_2 - x_1)`, `x_2' += c (x_1 - x_2)`,
    /// observed `x_1 + x_2`.
    CoupledLorenz { c: f64 },
    /// The Lorenz system (10, `rho`, 8/3) observed `x`.
    LorenzX { rho: f64 },
    /// Rössler's flow (`x' = -y - z`, `y' = x + a y`, `z' = b + z (x - c)`), observed `x`.
    Rossler { a: f64, b: f64, c: f64 },
}

impl KnownSystem {
    pub fn name(&self) -> String {
        match *self {
            KnownSystem::Lorenz96 { n, f } => format!("Lorenz-96 N = {n}, F = {f} (x1)"),
            KnownSystem::CoupledLorenz { c } => format!("two Lorenz systems coupled c = {c} (x1 + x2)"),
            KnownSystem::LorenzX { rho } => format!("Lorenz rho = {rho} (x)"),
            KnownSystem::Rossler { a, b, c } => format!("Rössler a = {a}, b = {b}, c = {c} (x)"),
        }
    }
    /// The initial state of the system's integration (before its transient).
    pub fn start(&self) -> Vec<f64> {
        match *self {
            KnownSystem::Lorenz96 { n, f } => {
                let mut x = vec![f; n];
                x[0] += 0.01;
                x
            }
            KnownSystem::CoupledLorenz { .. } => vec![1.0, 1.0, 1.0, -3.0, 2.0, 20.0],
            KnownSystem::LorenzX { .. } | KnownSystem::Rossler { .. } => vec![1.0, 1.0, 1.0],
        }
    }
    /// Largest RK4 substep.
    fn max_h(&self) -> f64 {
        0.005
    }
    /// A step fine enough to measure the lag.
    fn fine_dt(&self) -> f64 {
        0.005
    }
    fn observe(&self, x: &[f64]) -> f64 {
        match self {
            KnownSystem::Lorenz96 { .. } | KnownSystem::LorenzX { .. } | KnownSystem::Rossler { .. } => x[0],
            KnownSystem::CoupledLorenz { .. } => x[0] + x[3],
        }
    }
    /// State and tangent over `dt` by [`rk4_flow`] with substeps of at most [`Self::max_h`].
    fn advance(&self, x: &mut [f64], v: &mut [f64], dt: f64) {
        rk4_flow(self, x, v, dt, (dt / self.max_h()).ceil().max(1.0) as usize);
    }

    /// `n` observed samples every `dt` after `transient` samples from the state `x`
    /// (advanced in place).
    fn orbit_from(&self, x: &mut [f64], dt: f64, transient: usize, n: usize) -> Vec<f64> {
        let mut v = vec![0.0; x.len()];
        for _ in 0..transient {
            self.advance(x, &mut v, dt);
        }
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            out.push(self.observe(x));
            self.advance(x, &mut v, dt);
        }
        out
    }

    /// The full-rate step at which the data settings' lag at map step `step` is `lag`: the
    /// first zero of the autocorrelation on a finely sampled series (40,000 samples), scaled.
    pub fn step_for_lag(&self, step: usize, lag: usize) -> Result<f64, Error> {
        if step == 0 || lag == 0 {
            return Err(Error::BadOption {
                what: "step_for_lag",
                why: format!("need step >= 1 and lag >= 1 (got {step}, {lag})"),
            });
        }
        let h = self.fine_dt();
        let x = self.orbit_from(&mut self.start(), h, 20_000, 40_000);
        let l0 = first_zero_crossing(&x, x.len() / 4)?.max(1);
        Ok(h * l0 as f64 / (lag * step) as f64)
    }

    /// The exact largest exponent (Benettin with the exact tangent, renormalized every `dt`,
    /// 20 blocks over `steps` steps after `transient`), 1/s, and its block error.
    pub fn exponent(&self, dt: f64, transient: usize, steps: usize) -> Result<(f64, f64), Error> {
        let p = BenettinParams { transient, steps, time_step: dt, renorm_every: 1, bound: 1e6, blocks: 20 };
        let r = benettin_tangent(&self.start(), |x, v| self.advance(x, v, dt), &p)?;
        Ok((r.exponent, r.std_error))
    }

    /// The states (not observed, no noise) of the orbit pieces of [`Self::flag_like_series`]
    /// with the same `dt` and `lengths`: one row-major `n x dim` vector per piece.
    pub fn flag_like_states(&self, dt: f64, lengths: &[usize]) -> Result<Vec<Vec<f64>>, Error> {
        if !(dt.is_finite() && dt > 0.0) || lengths.iter().any(|&n| n < 2) {
            return Err(Error::BadOption {
                what: "flag-like states",
                why: format!("need dt > 0 and >= 2 samples per piece (got {dt}, {lengths:?})"),
            });
        }
        let mut x = self.start();
        let mut v = vec![0.0; x.len()];
        let mut out = Vec::with_capacity(lengths.len());
        for (i, &n) in lengths.iter().enumerate() {
            for _ in 0..if i == 0 { 5_000 } else { 1_000 } {
                self.advance(&mut x, &mut v, dt);
            }
            let mut piece = Vec::with_capacity(n * x.len());
            for _ in 0..n {
                piece.extend_from_slice(&x);
                self.advance(&mut x, &mut v, dt);
            }
            out.push(piece);
        }
        Ok(out)
    }

    /// Series laid out like the flag's at the full-rate step `dt`: consecutive pieces of one
    /// orbit (after a transient of 5,000 samples; 1,000 samples skipped between pieces) of
    /// the given lengths, each with white noise of `noise_rel` times its own sd (seeded by its
    /// index), named `name #i`.
    pub fn flag_like_series(&self, dt: f64, lengths: &[usize], noise_rel: f64) -> Result<Vec<TimeSeries>, Error> {
        self.flag_like_series_seeded(dt, lengths, noise_rel, 0)
    }

    /// [`Self::flag_like_series`] for realization `seed` (0: that one exactly): the orbit's
    /// transient is `5,000 + 7,919 seed` samples (another piece of the attractor) and the
    /// noise seeds are offset by `1,000 seed`.
    pub fn flag_like_series_seeded(
        &self,
        dt: f64,
        lengths: &[usize],
        noise_rel: f64,
        seed: u64,
    ) -> Result<Vec<TimeSeries>, Error> {
        let extra = usize::try_from(seed).ok().and_then(|s| s.checked_mul(7_919)).filter(|&e| e <= 100_000_000).ok_or(
            Error::BadOption {
                what: "flag-like series seed",
                why: format!("seed {seed} would skip more than 1e8 samples"),
            },
        )?;
        if !(dt.is_finite() && dt > 0.0 && noise_rel.is_finite() && noise_rel >= 0.0) || lengths.iter().any(|&n| n < 2)
        {
            return Err(Error::BadOption {
                what: "flag-like series",
                why: format!(
                    "need dt > 0, noise >= 0 and >= 2 samples per series (got {dt}, {noise_rel}, {lengths:?})"
                ),
            });
        }
        let mut x = self.start();
        let mut out = Vec::with_capacity(lengths.len());
        for (i, &n) in lengths.iter().enumerate() {
            let clean = self.orbit_from(&mut x, dt, if i == 0 { 5_000 + extra } else { 1_000 }, n);
            let y = if noise_rel > 0.0 {
                add_noise(&clean, noise_rel * sd(&clean), 31 + i as u64 + 1_000 * seed)
            } else {
                clean
            };
            out.push(TimeSeries::new(format!("{} #{i}", self.name()), (0..n).map(|k| k as f64 * dt).collect(), y)?);
        }
        Ok(out)
    }
}

/// The Lorenz system (10, `rho`, 8/3) of the known-answer systems.
fn lorenz(rho: f64) -> Lorenz {
    Lorenz { rho, ..Lorenz::default() }
}

impl Flow for KnownSystem {
    fn rhs(&self, x: &[f64], o: &mut [f64]) {
        match *self {
            KnownSystem::Lorenz96 { n, f } => Lorenz96 { n, f }.rhs(x, o),
            KnownSystem::CoupledLorenz { c } => {
                Flow::rhs(&lorenz(28.0), &x[..3], &mut o[..3]);
                Flow::rhs(&lorenz(28.0), &x[3..], &mut o[3..]);
                o[0] += c * (x[3] - x[0]);
                o[3] += c * (x[0] - x[3]);
            }
            KnownSystem::LorenzX { rho } => Flow::rhs(&lorenz(rho), x, o),
            KnownSystem::Rossler { a, b, c } => Rossler { a, b, c }.rhs(x, o),
        }
    }
    fn jvp(&self, x: &[f64], v: &[f64], w: &mut [f64]) {
        match *self {
            KnownSystem::Lorenz96 { n, f } => Lorenz96 { n, f }.jvp(x, v, w),
            KnownSystem::CoupledLorenz { c } => {
                lorenz(28.0).jvp(&x[..3], &v[..3], &mut w[..3]);
                lorenz(28.0).jvp(&x[3..], &v[3..], &mut w[3..]);
                w[0] += c * (v[3] - v[0]);
                w[3] += c * (v[0] - v[3]);
            }
            KnownSystem::LorenzX { rho } => lorenz(rho).jvp(x, v, w),
            KnownSystem::Rossler { a, b, c } => Rossler { a, b, c }.jvp(x, v, w),
        }
    }
}

fn sd(x: &[f64]) -> f64 {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n).sqrt()
}

/// A known system sampled like the flag, as the flag's data settings read it.
#[derive(Clone, Debug, Serialize)]
pub struct KnownStats {
    pub system: String,
    /// Full-rate step (s) and the map step's.
    pub dt: f64,
    pub step_dt: f64,
    /// Lag and Theiler window the data settings chose on the held-out series at the map step.
    pub lag: usize,
    pub theiler: usize,
    /// D2 (data settings) of the held-out series at the map step, and its error bar.
    pub corr_dim: f64,
    pub corr_dim_err: f64,
    /// Rosenstein exponent of the held-out series at the map step, 1/s.
    pub rosenstein: f64,
    /// Exact largest exponent, 1/s, and its block error.
    pub exact: f64,
    pub exact_err: f64,
    /// `exact x lag x step_dt`: exact exponent per lag time (the flag's, at its Rosenstein
    /// value: docs/flag-study.md).
    pub per_lag: f64,
    pub noise_rel: f64,
}

/// `sys` sampled as `layout` (training series `scale` times longer): the statistics of its
/// held-out series and the series (training, then held-out; the held-out series is the
/// orbit's first piece, the same at every scale). `benettin_time` sets the exact
/// exponent's length (s, after 5,000 full-rate steps).
pub fn known_stats(
    sys: &KnownSystem,
    layout: &FlagLayout,
    scale: usize,
    benettin_time: f64,
) -> Result<(KnownStats, Vec<TimeSeries>), Error> {
    known_stats_seeded(sys, layout, scale, benettin_time, 0)
}

/// [`known_stats`] on realization `seed` of the series ([`KnownSystem::flag_like_series_seeded`];
/// 0: [`known_stats`] exactly). The exact exponent is the same for every seed.
pub fn known_stats_seeded(
    sys: &KnownSystem,
    layout: &FlagLayout,
    scale: usize,
    benettin_time: f64,
    seed: u64,
) -> Result<(KnownStats, Vec<TimeSeries>), Error> {
    known_stats_with(sys, layout, scale, benettin_time, seed, &EvalSettings::default())
}

/// [`known_stats_seeded`] with the estimator settings `settings`.
pub fn known_stats_with(
    sys: &KnownSystem,
    layout: &FlagLayout,
    scale: usize,
    benettin_time: f64,
    seed: u64,
    settings: &EvalSettings,
) -> Result<(KnownStats, Vec<TimeSeries>), Error> {
    if scale == 0 {
        return Err(Error::BadOption { what: "scale", why: "the training-data scale must be >= 1".into() });
    }
    let dt = sys.step_for_lag(layout.step, layout.lag)?;
    let steps = (benettin_time / dt).ceil();
    if !(steps.is_finite() && (1.0..=1e9).contains(&steps)) {
        return Err(Error::BadOption {
            what: "benettin_time",
            why: format!("{benettin_time} s at step {dt} s is not 1..1e9 steps"),
        });
    }
    let (exact, exact_err) = sys.exponent(dt, 5_000, steps as usize)?;
    // The held-out piece first, so that it is the same at every scale.
    let lengths = [layout.test, layout.train[0] * scale, layout.train[1] * scale];
    let mut series = sys.flag_like_series_seeded(dt, &lengths, layout.noise_rel, seed)?;
    series.rotate_left(1);
    let (ds, _) = data_stats(&series[2], layout.step, settings)?;
    let stats = KnownStats {
        system: sys.name(),
        dt,
        step_dt: ds.dt,
        lag: ds.lag,
        theiler: ds.theiler,
        corr_dim: ds.corr_dim,
        corr_dim_err: ds.corr_dim_err,
        rosenstein: ds.lle,
        exact,
        exact_err,
        per_lag: exact * ds.lag as f64 * ds.dt,
        noise_rel: layout.noise_rel,
    };
    Ok((stats, series))
}

/// The data settings' readings on `segments` consecutive held-out-length pieces of one orbit
/// of `sys` at the full-rate step `dt` (noise as `layout`), at the map step: D2 and
/// Rosenstein (1/s) per piece (`None` where the estimator found no scaling range or fit).
#[derive(Clone, Debug, Serialize)]
pub struct SegmentStats {
    pub corr_dims: Vec<Option<f64>>,
    pub rosensteins: Vec<Option<f64>>,
    pub lags: Vec<usize>,
    /// Mean and sd of the D2 values found.
    pub corr_dim_mean: Option<f64>,
    pub corr_dim_sd: Option<f64>,
}

/// [`SegmentStats`] of `sys`.
pub fn segment_stats(sys: &KnownSystem, dt: f64, layout: &FlagLayout, segments: usize) -> Result<SegmentStats, Error> {
    if segments == 0 {
        return Err(Error::BadOption { what: "segments", why: "need at least one segment".into() });
    }
    let series = sys.flag_like_series(dt, &vec![layout.test; segments], layout.noise_rel)?;
    let per = crate::par_map(&series, |ts| {
        Ok::<_, Error>(data_stats(ts, layout.step, &EvalSettings::default()).ok().map(|(d, _)| d))
    })?;
    let corr_dims: Vec<Option<f64>> = per.iter().map(|d| d.as_ref().map(|d| d.corr_dim)).collect();
    let found: Vec<f64> = corr_dims.iter().flatten().copied().collect();
    let (corr_dim_mean, corr_dim_sd) = match found.len() {
        0 => (None, None),
        1 => (Some(found[0]), None),
        n => {
            let m = found.iter().sum::<f64>() / n as f64;
            (Some(m), Some((found.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1) as f64).sqrt()))
        }
    };
    Ok(SegmentStats {
        corr_dims,
        rosensteins: per.iter().map(|d| d.as_ref().map(|d| d.lle)).collect(),
        lags: per.iter().map(|d| d.as_ref().map_or(0, |d| d.lag)).collect(),
        corr_dim_mean,
        corr_dim_sd,
    })
}

/// Flag-like candidates at map step `step` (the flag search's: SSM dimension 4, embedding 9,
/// shift 1, manifold order 3, map order 4): RBF maps with (centres, ridge) from `rbf`, and the
/// polynomial map of order 4 (ridge 1e-8).
pub fn flag_like_candidates(step: usize, rbf: &[(usize, f64)]) -> Vec<Candidate> {
    let base = FitOptions {
        dim: 4,
        embed: 9,
        shift: 1,
        manifold_order: 3,
        dyn_order: 4,
        dynamics: ssm::Dynamics::Map,
        ridge: ssm::Ridge::Fixed(1e-8),
        linear_anchor: None,
        anchor_joint: false,
    };
    let mut out: Vec<Candidate> = rbf
        .iter()
        .map(|&(centers, ridge)| Candidate {
            name: format!("RBF {centers} /{step} r={ridge:e}"),
            step,
            fit: FitOptions { dynamics: ssm::Dynamics::Rbf { centers }, ridge: ssm::Ridge::Fixed(ridge), ..base },
            smooth: 0,
            multistep: None,
            denoise_inputs: 0,
            centres: Default::default(),
        })
        .collect();
    out.push(Candidate {
        name: format!("poly 4 /{step}"),
        step,
        fit: base,
        smooth: 0,
        multistep: None,
        denoise_inputs: 0,
        centres: Default::default(),
    });
    out
}

/// The RBF (centres, ridge) of the flag search's one-step rows (`studies/results/flag/search.json`).
pub const FLAG_LIKE_RBF: [(usize, f64); 5] = [(200, 3e-9), (250, 1e-8), (300, 3e-9), (500, 1e-8), (1000, 1e-8)];

/// One candidate of the pipeline check, against the exact exponent and the held-out data.
#[derive(Clone, Debug, Serialize)]
pub struct PipelineRow {
    pub candidate: String,
    /// Training data in multiples of the flag's.
    pub scale: usize,
    /// Benettin of the model, 1/s, and over the exact exponent.
    pub benettin: Option<f64>,
    pub benettin_over_exact: Option<f64>,
    /// Rosenstein of the model series and of the held-out data, 1/s.
    pub rosenstein: Option<f64>,
    pub data_rosenstein: f64,
    /// D2 of the model series, of the held-out data and its error bar.
    pub corr_dim: Option<f64>,
    pub data_corr_dim: f64,
    pub data_corr_dim_err: f64,
    pub js: Option<f64>,
    /// Chaotic (Benettin > 0.01 x exact) with Benettin within 10 % of the exact exponent.
    pub benettin_exact_ok: bool,
    /// The four targets against the data's Rosenstein number (as on the flag).
    pub passes: [bool; 4],
    pub failed: Option<String>,
}

impl PipelineRow {
    pub fn new(r: &CandidateResult, scale: usize, exact: f64) -> Self {
        let m = Measured { benettin: r.benettin, rosenstein: r.rosenstein, corr_dim: r.corr_dim, js: r.js };
        Self::from_values(&r.name, scale, &m, r.failed.clone(), r.data.lle, r.data.corr_dim, r.data.corr_dim_err, exact)
    }

    /// A row from measured values: the model's, whether it failed, the held-out data's
    /// Rosenstein exponent and D2 (with its error bar), and the exact exponent.
    #[allow(clippy::too_many_arguments)]
    pub fn from_values(
        candidate: &str,
        scale: usize,
        m: &Measured,
        failed: Option<String>,
        data_lle: f64,
        data_d2: f64,
        data_d2_err: f64,
        exact: f64,
    ) -> Self {
        let ratio = m.benettin.map(|b| b / exact);
        let ok = failed.is_none();
        let stats = Statistics { benettin: m.benettin, rosenstein: m.rosenstein, corr_dim: m.corr_dim, js: m.js };
        let data = Reference { lle: data_lle, corr_dim: data_d2, corr_dim_err: data_d2_err };
        let passes = Targets::default().passes(&stats, &data).map(|p| ok && p);
        PipelineRow {
            candidate: candidate.to_string(),
            scale,
            benettin: m.benettin,
            benettin_over_exact: ratio,
            rosenstein: m.rosenstein,
            data_rosenstein: data_lle,
            corr_dim: m.corr_dim,
            data_corr_dim: data_d2,
            data_corr_dim_err: data_d2_err,
            js: m.js,
            benettin_exact_ok: ok && ratio.is_some_and(|q| (q - 1.0).abs() <= 0.10),
            passes,
            failed,
        }
    }
}

/// A model's measured statistics: Benettin (1/s), Rosenstein of its series (1/s), D2, JS (bits).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Measured {
    pub benettin: Option<f64>,
    pub rosenstein: Option<f64>,
    pub corr_dim: Option<f64>,
    pub js: Option<f64>,
}

/// The flag's model search on `sys` sampled as `layout`, training data `scale` times the
/// flag's: the system's statistics and one row per candidate. Candidates and settings as in
/// [`evaluate_and_select`] with the default settings (those used on the flag).
pub fn pipeline_check(
    sys: &KnownSystem,
    layout: &FlagLayout,
    scale: usize,
    candidates: &[Candidate],
    benettin_time: f64,
) -> Result<(KnownStats, Vec<PipelineRow>), Error> {
    pipeline_check_seeded(sys, layout, scale, candidates, benettin_time, 0)
}

/// [`pipeline_check`] on realization `seed` of the series ([`known_stats_seeded`]).
pub fn pipeline_check_seeded(
    sys: &KnownSystem,
    layout: &FlagLayout,
    scale: usize,
    candidates: &[Candidate],
    benettin_time: f64,
    seed: u64,
) -> Result<(KnownStats, Vec<PipelineRow>), Error> {
    let (stats, series) = known_stats_seeded(sys, layout, scale, benettin_time, seed)?;
    let (results, _) =
        evaluate_and_select(&series[..2], &series[2], candidates, &EvalSettings::default(), &Targets::default())?;
    let rows = results.iter().map(|r| PipelineRow::new(r, scale, stats.exact)).collect();
    Ok((stats, rows))
}

/// What the pipeline check found at one training-data scale.
#[derive(Clone, Debug, Serialize)]
pub struct PipelineSummary {
    pub scale: usize,
    pub candidates: usize,
    pub failed: usize,
    /// Candidates whose model is chaotic (Benettin above 1 % of the exact exponent).
    pub chaotic: usize,
    /// Smallest and largest Benettin / exact over the chaotic candidates.
    pub benettin_over_exact: Option<(f64, f64)>,
    /// Candidates with Benettin within 10 % of the exact exponent.
    pub benettin_within_10pct_of_exact: usize,
    /// Candidates meeting the targets against the held-out data as on the flag:
    /// each target and all four.
    pub target_counts: [usize; 4],
    pub all_four: usize,
    /// Candidates with Benettin within 10 % of the exact exponent and D2 within the data's
    /// error bar and JS <= 0.01 (the targets with the exact exponent as reference).
    pub exact_d2_js: usize,
}

/// [`PipelineSummary`] of the rows of `scale`.
pub fn summarize(rows: &[PipelineRow], scale: usize) -> PipelineSummary {
    let rows: Vec<&PipelineRow> = rows.iter().filter(|r| r.scale == scale).collect();
    let chaotic: Vec<&&PipelineRow> =
        rows.iter().filter(|r| r.failed.is_none() && r.benettin_over_exact.is_some_and(|q| q > 0.01)).collect();
    let ratios = chaotic.iter().filter_map(|r| r.benettin_over_exact);
    let range = ratios.fold(None, |acc: Option<(f64, f64)>, q| Some(acc.map_or((q, q), |(a, b)| (a.min(q), b.max(q)))));
    let mut target_counts = [0; 4];
    for r in &rows {
        for (c, p) in target_counts.iter_mut().zip(r.passes) {
            *c += p as usize;
        }
    }
    PipelineSummary {
        scale,
        candidates: rows.len(),
        failed: rows.iter().filter(|r| r.failed.is_some()).count(),
        chaotic: chaotic.len(),
        benettin_over_exact: range,
        benettin_within_10pct_of_exact: rows.iter().filter(|r| r.benettin_exact_ok).count(),
        target_counts,
        all_four: rows.iter().filter(|r| r.passes.iter().all(|&p| p)).count(),
        exact_d2_js: rows.iter().filter(|r| r.benettin_exact_ok && r.passes[2] && r.passes[3]).count(),
    }
}

/// The known system of the report's pipeline check, chosen by the `scan` of the example
/// (Lorenz-96 with 4 sites) because sampled like the flag its chaos per lag, D2, lag and
/// Theiler window are the flag's (the numbers: docs/flag-study.md and the report).
pub const CHOSEN: KnownSystem = KnownSystem::Lorenz96 { n: 4, f: 17.7 };

// The study's results files as pipeline rows (the conversions live here so that
// `study_results` depends on no other module of the crate).
use crate::study_results::{HeldOutResults, KnownSystemResults, ModelRow, RunStats, ValidationRun};

impl ModelRow {
    /// The row's measured values.
    pub fn measured(&self) -> Measured {
        Measured { benettin: self.benettin, rosenstein: self.rosenstein, corr_dim: self.corr_dim, js: self.js }
    }

    /// The row against the run statistics `data` (the exponent's reference is the data's
    /// Rosenstein value: the flag has no exact one).
    pub fn against(&self, data: &RunStats) -> PipelineRow {
        PipelineRow::from_values(
            &self.candidate,
            1,
            &self.measured(),
            self.failed.clone(),
            data.rosenstein,
            data.corr_dim,
            data.corr_dim_err,
            data.rosenstein,
        )
    }
}

/// `rows` against `data` ([`ModelRow::against`]).
pub fn rows_against(rows: &[ModelRow], data: &RunStats) -> Vec<PipelineRow> {
    rows.iter().map(|r| r.against(data)).collect()
}

impl KnownSystemResults {
    /// [`Self::pipeline_check`] as rows against [`Self::data`].
    pub fn check_rows(&self) -> Vec<PipelineRow> {
        let k = &self.data;
        self.pipeline_check
            .iter()
            .map(|r| {
                let m = Measured { benettin: r.benettin, rosenstein: r.rosenstein, corr_dim: r.corr_dim, js: r.js };
                PipelineRow::from_values(
                    &r.candidate,
                    r.scale,
                    &m,
                    r.failed.clone(),
                    k.rosenstein,
                    k.corr_dim,
                    k.corr_dim_err,
                    k.exact,
                )
            })
            .collect()
    }

    /// [`Self::diagnosis`] as (group, noise over the sd, row) against [`Self::data`] (the
    /// noise-free rows' own held-out series reads nearly the same Rosenstein and D2).
    pub fn diagnosis_rows(&self) -> Vec<(String, f64, PipelineRow)> {
        let k = &self.data;
        self.diagnosis
            .iter()
            .map(|r| {
                let m = Measured { benettin: r.benettin, rosenstein: r.rosenstein, corr_dim: r.corr_dim, js: r.js };
                let row = PipelineRow::from_values(
                    &r.candidate,
                    r.scale,
                    &m,
                    r.failed.clone(),
                    k.rosenstein,
                    k.corr_dim,
                    k.corr_dim_err,
                    k.exact,
                );
                (r.group.clone(), r.noise_rel, row)
            })
            .collect()
    }
}

impl HeldOutResults {
    /// [`Self::centres`] as rows against [`Self::data`].
    pub fn centre_rows(&self) -> Vec<PipelineRow> {
        rows_against(&self.centres, &self.data)
    }

    /// [`Self::fit`] as rows against [`Self::data`].
    pub fn fit_rows(&self) -> Vec<PipelineRow> {
        rows_against(&self.fit, &self.data)
    }

    /// [`Self::multistep`] as rows against [`Self::data`].
    pub fn multistep_rows(&self) -> Vec<PipelineRow> {
        rows_against(&self.multistep, &self.data)
    }
}

impl ValidationRun {
    /// [`Self::rows`] as rows against [`Self::data`].
    pub fn pipeline_rows(&self) -> Vec<PipelineRow> {
        rows_against(&self.rows, &self.data)
    }
}
