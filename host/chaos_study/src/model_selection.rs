//! Reduced models of chaotic data chosen by held-out long-term statistics (docs/decisions/0002): each
//! [`Candidate`] (SSM options and a map step) is fitted on the training trajectories and run
//! on its own from the held-out trajectory's first point; its long-term statistics are
//! compared with the held-out data's, measured by the same estimators with the same settings:
//! the map's own Benettin exponent and the data's Rosenstein exponent, the Rosenstein exponent
//! of the model's observable series, the correlation dimension of that series, the mean
//! Jensen-Shannon divergence of the reduced-coordinate PDFs, and whether the long run stays
//! in the data's region. [`select`] picks the candidate that meets most targets (ties: the
//! smallest normalized errors), says why, and warns when the data look chaotic and the pick
//! is not (or the reverse).
//!
//! Map step: a candidate with `step = k` is a map over `k` samples (Xu et al. 2024 sample
//! the flag data every 4th frame). It is fitted on the `k` phase-shifted subsamplings of each
//! training series (so every pair `(n, n + k)` of the data is a training pair: multi-step-
//! ahead fitting) and evaluated on the held-out series subsampled by `k`; the data statistics
//! it is compared with are those of that subsampled series (lag and Theiler window in its
//! samples, the rest unchanged), so model and data go through the same estimator with the
//! same parameters.

use chaos::{
    Bins, Context, CorrSumParams, Points, Reference, ScalingRule, Statistics, correlation_dimension, delay_embed,
};
use chaos::{Targets, add_noise, best_of, rollout_horizon};
use serde::{Deserialize, Serialize};
use ssm::{FitOptions, SsmModel, TimeSeries, fit};

use crate::Error;
use crate::lyapunov::{iterate_dynamics, model_bound, model_lyapunov};
use crate::microchaos::reduce_series;

/// One candidate model: SSM fit options and the map step in samples.
#[derive(Clone, Debug, Serialize)]
pub struct Candidate {
    pub name: String,
    /// Map step in samples of the data (>= 1).
    pub step: usize,
    pub fit: FitOptions,
    /// Noise-aware training: the training series are smoothed by a centred moving average
    /// of `2 smooth + 1` samples (fewer at the ends) before fitting; 0 = raw data. The
    /// held-out statistics always come from the raw held-out series.
    #[serde(default)]
    pub smooth: usize,
    /// Multi-step (trajectory) refinement of an RBF map after its one-step ridge fit
    /// ([`ssm::multistep::refine_model`], on the same training series); `None`: the ridge
    /// fit as it is.
    #[serde(default)]
    pub multistep: Option<ssm::multistep::MultiStep>,
    /// Errors-in-variables fit: after the ordinary fit on the raw series, the RBF map is
    /// fitted again on pairs whose inputs are the reduced coordinates of the training series
    /// smoothed by a centred moving average of `2 w + 1` samples (at the full rate, before
    /// subsampling) and whose targets are the raw series' ([`ssm::ReducedDynamics::fit_rbf_pairs`]);
    /// 0 = off. The manifold stays the raw fit's.
    #[serde(default)]
    pub denoise_inputs: usize,
    /// How the RBF map's centres are chosen ([`ssm::dynamics::CentreChoice`]; the default,
    /// farthest points, is the ordinary fit). Any other choice refits the map on the same
    /// reduced coordinates with those centres ([`ssm::ReducedDynamics::fit_rbf_centres`]),
    /// before any multistep refinement; not combined with `denoise_inputs`.
    #[serde(default, skip_serializing_if = "is_farthest")]
    pub centres: ssm::dynamics::CentreChoice,
}

fn is_farthest(c: &ssm::dynamics::CentreChoice) -> bool {
    *c == ssm::dynamics::CentreChoice::Farthest
}

/// Settings of the evaluation (the same for every candidate); a selection spec's `statistics`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvalSettings {
    /// Delay-embedding dimension of the dimension and Rosenstein estimates.
    pub gp_embed: usize,
    /// Length of the long run, in held-out series lengths (escape check and PDFs).
    pub long_runs: usize,
    /// Benettin transient and measured map steps.
    pub benettin_transient: usize,
    pub benettin_steps: usize,
    /// A long run whose reduced coordinates exceed this factor times the data's largest
    /// `|eta_i|` has left the data's region (a failed candidate).
    pub region_factor: f64,
}

impl EvalSettings {
    /// A spec's `statistics` table is usable: an embedding within the estimators' limit,
    /// at least one long run and one Benettin step, a finite region factor of at least 1.
    pub fn check(&self) -> Result<(), String> {
        if self.gp_embed == 0 || self.gp_embed > crate::microchaos::MAX_GP_EMBED {
            return Err(format!(
                "statistics.gp_embed = {}: needs 1 ..= {}",
                self.gp_embed,
                crate::microchaos::MAX_GP_EMBED
            ));
        }
        if self.long_runs == 0 || self.benettin_steps == 0 {
            return Err("statistics.long_runs and statistics.benettin_steps must be >= 1".into());
        }
        if !(self.region_factor.is_finite() && self.region_factor >= 1.0) {
            return Err(format!("statistics.region_factor = {}: needs a finite value >= 1", self.region_factor));
        }
        Ok(())
    }
}

impl Default for EvalSettings {
    fn default() -> Self {
        Self { gp_embed: 6, long_runs: 5, benettin_transient: 5_000, benettin_steps: 50_000, region_factor: 1.5 }
    }
}

/// Statistics of the held-out data at one map step.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DataStats {
    pub step: usize,
    pub dt: f64,
    pub lag: usize,
    pub theiler: usize,
    pub corr_dim: f64,
    pub corr_dim_err: f64,
    /// Rosenstein exponent, 1/s.
    pub lle: f64,
    pub len: usize,
    /// Measurement-noise level of the full-rate held-out series: the sd of its difference
    /// from a 5-sample centred moving average over sqrt(4/5) (white noise passes that
    /// filter with this factor; the flapping, ~40 samples per period and slower, barely).
    pub noise_sd: f64,
}

/// What one candidate gave. `failed` names why a candidate is out (fit error, escape, left
/// the data's region, a statistic that could not be measured); its values are then those
/// measured before the failure.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CandidateResult {
    pub name: String,
    pub step: usize,
    pub options: FitOptions,
    pub data: DataStats,
    /// The map's own largest Lyapunov exponent (Benettin), 1/s, and its block error.
    pub benettin: Option<f64>,
    pub benettin_err: Option<f64>,
    /// Second Benettin exponent, 1/s (a torus has two zeros).
    pub benettin_2nd: Option<f64>,
    /// Rosenstein exponent of the model's observable series (data settings), 1/s.
    pub rosenstein: Option<f64>,
    /// Diagnostic (not a target): Rosenstein exponent of the model series with white
    /// Gaussian noise of the data's `noise_sd` added (seeded), 1/s: how much of the data's
    /// exponent measurement noise alone can explain.
    pub rosenstein_noisy: Option<f64>,
    /// Multi-step (rollout) loss on the held-out trajectory: RMS error of the model's
    /// reduced coordinates run [`rollout_horizon`] map steps (a quarter of the dominant
    /// period of the held-out series at this step) from evenly spaced held-out points, over
    /// the RMS of the held-out reduced coordinates ([`rollout_error`]). Reported next to
    /// the long-term statistics; it does not enter the pick.
    #[serde(default)]
    pub rollout: Option<f64>,
    /// Correlation dimension of the model's observable series (data settings).
    pub corr_dim: Option<f64>,
    pub corr_dim_err: Option<f64>,
    /// Mean Jensen-Shannon divergence of the reduced-coordinate PDFs (long run), bits.
    pub js: Option<f64>,
    /// Largest `|eta_i|` of the long run over the data's largest `|eta_i|`.
    pub excursion: Option<f64>,
    /// Map steps of the long run (as many as completed when it escaped).
    pub long_steps: usize,
    pub failed: Option<String>,
    pub notes: Vec<String>,
    /// Fit plus evaluation time, s (informative only, never compared).
    pub seconds: f64,
}

impl CandidateResult {
    /// The measured statistics, as the targets read them.
    pub fn statistics(&self) -> Statistics {
        Statistics { benettin: self.benettin, rosenstein: self.rosenstein, corr_dim: self.corr_dim, js: self.js }
    }

    /// Which targets hold: (Benettin, Rosenstein, D2, JS) ([`Targets::passes`]).
    pub fn passes(&self, t: &Targets) -> [bool; 4] {
        if self.failed.is_some() {
            return [false; 4];
        }
        t.passes(&self.statistics(), &self.data.reference())
    }

    /// [`Targets::score`] of the candidate; infinite for a failed one.
    pub fn score(&self, t: &Targets) -> f64 {
        if self.failed.is_some() {
            return f64::INFINITY;
        }
        t.score(&self.statistics(), &self.data.reference())
    }
}

impl DataStats {
    /// What the targets measure a model against.
    pub fn reference(&self) -> Reference {
        Reference { lle: self.lle, corr_dim: self.corr_dim, corr_dim_err: self.corr_dim_err }
    }
}

/// Every `k`-th sample of `ts` from sample `offset`.
pub fn subsample(ts: &TimeSeries, k: usize, offset: usize) -> Result<TimeSeries, Error> {
    if k == 0 {
        return Err(Error::BadOption { what: "step", why: "the map step must be >= 1 sample".into() });
    }
    let name = if k == 1 { ts.name.clone() } else { format!("{} /{k}+{offset}", ts.name) };
    Ok(TimeSeries::new(
        name,
        ts.t.iter().skip(offset).step_by(k).copied().collect(),
        ts.x.iter().skip(offset).step_by(k).copied().collect(),
    )?)
}

/// [`chaos::moving_average`] of the series' values, named after it; `w = 0` copies.
pub fn moving_average(ts: &TimeSeries, w: usize) -> Result<TimeSeries, Error> {
    if w == 0 {
        return Ok(ts.clone());
    }
    let x = chaos::moving_average(&ts.x, w);
    Ok(TimeSeries::new(format!("{} (moving average {})", ts.name, 2 * w + 1), ts.t.clone(), x)?)
}

/// The `k` phase-shifted subsamplings of every training series (every pair `(n, n + k)` is
/// then a training pair of a map over `k` samples).
pub fn phase_subsamples(train: &[TimeSeries], k: usize) -> Result<Vec<TimeSeries>, Error> {
    let mut out = Vec::with_capacity(train.len() * k);
    for ts in train {
        for off in 0..k {
            out.push(subsample(ts, k, off)?);
        }
    }
    Ok(out)
}

/// Statistics of the held-out series `test` subsampled by `step`.
pub fn data_stats(test: &TimeSeries, step: usize, s: &EvalSettings) -> Result<(DataStats, Context), Error> {
    let ts = subsample(test, step, 0)?;
    let dt =
        ts.dt().ok_or(Error::BadInput { what: "held-out series", why: format!("{}: no sampling step", ts.name) })?;
    let ctx = Context::from_series(&ts.x, dt, s.gp_embed)?;
    let pts = delay_embed(&ts.x, s.gp_embed, ctx.lag)?;
    let cd = correlation_dimension(
        &pts,
        &CorrSumParams { theiler: ctx.theiler, ..Default::default() },
        &ScalingRule::default(),
    )?;
    let mut notes = Vec::new();
    let (lle, _) = ctx.lle(&ts.x, &mut notes, "data")?;
    let noise_sd = chaos::noise_sd(&test.x);
    Ok((
        DataStats {
            step,
            dt,
            lag: ctx.lag,
            theiler: ctx.theiler,
            corr_dim: cd.dimension,
            corr_dim_err: cd.slope_std,
            lle,
            len: ts.x.len(),
            noise_sd,
        },
        ctx,
    ))
}

/// What [`crate::microchaos::analyse_held_out_models`] already computed on the same training
/// and held-out series, for [`evaluate_and_select_known`] to reuse instead of computing it
/// again: the held-out data statistics at map step 1 (the same estimators with the same
/// settings as [`data_stats`]) and the models fitted on the raw training series with their
/// Benettin results from the held-out series' first point. Reuse changes no number: a
/// step-1 candidate without smoothing, refits or refinement whose fit options equal a known
/// model's is that model (the fit is deterministic), and its Benettin run is the known one
/// when start and lengths agree.
#[derive(Default)]
pub struct Known<'a> {
    /// [`data_stats`] of the held-out series at step 1.
    pub step1: Option<(DataStats, Context)>,
    pub models: Vec<KnownModel<'a>>,
}

/// A model of [`Known`].
pub struct KnownModel<'a> {
    pub model: &'a SsmModel,
    /// Benettin from `eta0` with `transient` and `steps` map steps, and its result.
    pub benettin: Option<KnownBenettin>,
}

/// A Benettin run of a [`KnownModel`] and where it started.
pub struct KnownBenettin {
    pub eta0: Vec<f64>,
    pub transient: usize,
    pub steps: usize,
    pub result: crate::lyapunov::ModelLyapunov,
}

impl<'a> Known<'a> {
    /// From an analysis of `train` with held-out `test` ([`crate::microchaos::analyse_held_out_models`]
    /// with `Some(test)` and options `o`): its summary and fitted models. The caller passes
    /// the same `train` and `test` to [`evaluate_and_select_known`].
    pub fn from_analysis(
        test: &TimeSeries,
        o: &crate::microchaos::ChaosOptions,
        summary: &crate::microchaos::ChaosSummary,
        models: &'a [(&'static str, SsmModel)],
    ) -> Result<Self, Error> {
        let dt = test
            .dt()
            .ok_or(Error::BadInput { what: "held-out series", why: format!("{}: no sampling step", test.name) })?;
        let ctx = Context { dt, lag: summary.lag_samples, theiler: summary.theiler_samples, embed: summary.gp_embed };
        let stats = DataStats {
            step: 1,
            dt,
            lag: ctx.lag,
            theiler: ctx.theiler,
            corr_dim: summary.corr_dim,
            corr_dim_err: summary.corr_dim_err,
            lle: summary.lle_data,
            len: test.x.len(),
            noise_sd: chaos::noise_sd(&test.x),
        };
        let mut out = Known { step1: Some((stats, ctx)), models: Vec::new() };
        for (kind, m) in models {
            let b = if *kind == "rbf" { &summary.benettin_rbf } else { &summary.benettin_poly };
            let benettin = match b {
                Some(r) => {
                    let eta = reduce_series(m, test)?;
                    Some(KnownBenettin {
                        eta0: eta[..m.options.dim.min(eta.len())].to_vec(),
                        transient: o.benettin_transient,
                        steps: o.benettin_steps,
                        result: r.clone(),
                    })
                }
                None => None,
            };
            out.models.push(KnownModel { model: m, benettin });
        }
        Ok(out)
    }

    /// The known model that candidate `c` would fit, if any.
    fn model_for(&self, c: &Candidate) -> Option<&KnownModel<'a>> {
        if c.step != 1 || c.smooth != 0 || c.multistep.is_some() || c.denoise_inputs != 0 || !is_farthest(&c.centres) {
            return None;
        }
        self.models.iter().find(|k| k.model.options == c.fit)
    }
}

/// Fits `c` on `train` and measures it against the held-out `test` (see the module docs).
/// `data` must be [`data_stats`] of `test` at `c.step`. Only bad options are errors; a
/// failed fit, an escape or a statistic that cannot be measured is `failed`, said plainly.
pub fn evaluate_candidate(
    train: &[TimeSeries],
    test: &TimeSeries,
    c: &Candidate,
    data: &(DataStats, Context),
    s: &EvalSettings,
) -> Result<CandidateResult, Error> {
    evaluate_candidate_known(train, test, c, data, s, None)
}

/// [`evaluate_candidate`] with the model already fitted: `known` is the model `c` fits on
/// `train` (see [`Known`]), used as it is.
fn evaluate_candidate_known(
    train: &[TimeSeries],
    test: &TimeSeries,
    c: &Candidate,
    data: &(DataStats, Context),
    s: &EvalSettings,
    known: Option<&KnownModel<'_>>,
) -> Result<CandidateResult, Error> {
    evaluate_candidate_model(train, test, c, data, s, known).map(|(r, _)| r)
}

/// [`evaluate_candidate`] that also returns the fitted model (`None` when the fit failed or a
/// known model was used), for diagnostics beyond the result's statistics.
pub fn evaluate_candidate_fitted(
    train: &[TimeSeries],
    test: &TimeSeries,
    c: &Candidate,
    data: &(DataStats, Context),
    s: &EvalSettings,
) -> Result<(CandidateResult, Option<SsmModel>), Error> {
    evaluate_candidate_model(train, test, c, data, s, None)
}

fn evaluate_candidate_model(
    train: &[TimeSeries],
    test: &TimeSeries,
    c: &Candidate,
    data: &(DataStats, Context),
    s: &EvalSettings,
    known: Option<&KnownModel<'_>>,
) -> Result<(CandidateResult, Option<SsmModel>), Error> {
    let t0 = std::time::Instant::now();
    let (ds, ctx) = data;
    if ds.step != c.step {
        return Err(Error::BadInput {
            what: "data statistics",
            why: format!("measured at step {}, candidate {} has step {}", ds.step, c.name, c.step),
        });
    }
    c.fit.validate()?;
    if let Some(ms) = &c.multistep {
        ms.validate()?;
    }
    let seeded = !is_farthest(&c.centres);
    if seeded && (c.fit.dynamics.rbf().is_none() || c.denoise_inputs > 0) {
        return Err(Error::BadOption {
            what: "centres",
            why: format!("candidate {}: a centre choice needs RBF dynamics and no denoised-input refit", c.name),
        });
    }
    let mut r = CandidateResult {
        name: c.name.clone(),
        step: c.step,
        options: c.fit,
        data: ds.clone(),
        benettin: None,
        benettin_err: None,
        benettin_2nd: None,
        rosenstein: None,
        rosenstein_noisy: None,
        rollout: None,
        corr_dim: None,
        corr_dim_err: None,
        js: None,
        excursion: None,
        long_steps: 0,
        failed: None,
        notes: Vec::new(),
        seconds: 0.0,
    };
    let test_k = subsample(test, c.step, 0)?;
    if let Some(k) = known {
        measure(k.model, &test_k, ctx, s, &mut r, k.benettin.as_ref())?;
        r.seconds = t0.elapsed().as_secs_f64();
        return Ok((r, None));
    }
    let smoothed: Vec<TimeSeries> = train.iter().map(|t| moving_average(t, c.smooth)).collect::<Result<_, _>>()?;
    let train_k = phase_subsamples(&smoothed, c.step)?;
    // With a centre choice the RBF map is fitted once, below: the manifold fit does not
    // depend on the dynamics, so the first fit takes the cheap linear map.
    let first = if seeded { FitOptions { dynamics: ssm::Dynamics::Map, dyn_order: 1, ..c.fit } } else { c.fit };
    let mut m = match fit(&train_k, &first) {
        Ok(m) => m,
        Err(e @ ssm::FitError::TooLarge { .. }) => return Err(e.into()),
        Err(e) => {
            r.failed = Some(format!("fit failed: {e}"));
            return Ok((r, None));
        }
    };
    if seeded {
        match refit_centres(&mut m, &train_k, &c.fit, c.centres) {
            Ok(()) => r.notes.push(format!("centres {}", c.centres.name())),
            Err(e @ Error::Ssm(ssm::Error::Fit(ssm::FitError::TooLarge { .. }))) => return Err(e),
            Err(e) => {
                r.failed = Some(format!("fit failed (centres {}): {e}", c.centres.name()));
                return Ok((r, None));
            }
        }
    }
    if c.denoise_inputs > 0 {
        match refit_denoised_inputs(&mut m, &smoothed, c.step, c.denoise_inputs) {
            Ok(()) => {
                r.notes.push(format!("inputs denoised (moving average {}), raw targets", 2 * c.denoise_inputs + 1))
            }
            Err(e @ Error::Ssm(ssm::Error::Fit(ssm::FitError::TooLarge { .. }))) => return Err(e),
            Err(e) => {
                r.failed = Some(format!("denoised-input refit failed: {e}"));
                return Ok((r, None));
            }
        }
    }
    if let Some(ms) = &c.multistep {
        match ssm::multistep::refine_model(&mut m, &train_k, ms) {
            Ok(stages) => r.notes.extend(stages.iter().map(|st| {
                format!(
                    "multistep h={}: rollout RMS {:.4} -> {:.4} ({} of {} steps kept)",
                    st.horizon, st.rms_before, st.rms_after, st.accepted, st.tried
                )
            })),
            Err(e @ ssm::FitError::TooLarge { .. }) => return Err(e.into()),
            Err(e) => {
                r.failed = Some(format!("multistep refinement failed: {e}"));
                return Ok((r, None));
            }
        }
    }
    measure(&m, &test_k, ctx, s, &mut r, None)?;
    r.seconds = t0.elapsed().as_secs_f64();
    Ok((r, Some(m)))
}

/// The RBF map of `m` (fitted on `train_k` with any dynamics) fitted again on the same
/// reduced coordinates as `opts` says, centres chosen by `choice`; `m.options` becomes `opts`.
fn refit_centres(
    m: &mut SsmModel,
    train_k: &[TimeSeries],
    opts: &FitOptions,
    choice: ssm::dynamics::CentreChoice,
) -> Result<(), Error> {
    let (ys, dts) = ssm::fit::embed_training(train_k, opts)?;
    let etas: Vec<faer::Mat<f64>> = ys.iter().map(|y| m.manifold.reduce_points(y.as_ref())).collect();
    let trajs: Vec<_> =
        etas.iter().zip(&dts).map(|(e, &dt)| ssm::dynamics::EtaTrajectory { eta: e.as_ref(), dt }).collect();
    m.dynamics = ssm::ReducedDynamics::fit_rbf_centres(&trajs, opts.dynamics, opts.ridge, choice)?;
    m.eigenvalues_ct = m.dynamics.eigenvalues_ct()?;
    m.options = *opts;
    Ok(())
}

/// The errors-in-variables refit of [`Candidate::denoise_inputs`]: the RBF map of `m` fitted
/// again with the reduced coordinates of `train` smoothed by a moving average of `2 w + 1`
/// samples as inputs and those of `train` itself as targets, at map step `step`.
pub fn refit_denoised_inputs(m: &mut SsmModel, train: &[TimeSeries], step: usize, w: usize) -> Result<(), Error> {
    let smooth: Vec<TimeSeries> = train.iter().map(|t| moving_average(t, w)).collect::<Result<_, _>>()?;
    let reduced = |series: &[TimeSeries]| -> Result<(Vec<faer::Mat<f64>>, Vec<f64>), Error> {
        let (ys, dts) = ssm::fit::embed_training(&phase_subsamples(series, step)?, &m.options)?;
        Ok((ys.iter().map(|y| m.manifold.reduce_points(y.as_ref())).collect(), dts))
    };
    let (raw, dts) = reduced(train)?;
    let (den, _) = reduced(&smooth)?;
    let den_t: Vec<_> =
        den.iter().zip(&dts).map(|(e, &dt)| ssm::dynamics::EtaTrajectory { eta: e.as_ref(), dt }).collect();
    let raw_t: Vec<_> =
        raw.iter().zip(&dts).map(|(e, &dt)| ssm::dynamics::EtaTrajectory { eta: e.as_ref(), dt }).collect();
    m.dynamics = ssm::ReducedDynamics::fit_rbf_pairs(&den_t, &raw_t, m.options.dynamics, m.options.ridge)?;
    m.eigenvalues_ct = m.dynamics.eigenvalues_ct()?;
    Ok(())
}

/// The measurements of [`evaluate_candidate`] on a fitted model `m` (map step = the step of
/// `test_k`).
fn measure(
    m: &SsmModel,
    test_k: &TimeSeries,
    ctx: &Context,
    s: &EvalSettings,
    r: &mut CandidateResult,
    known: Option<&KnownBenettin>,
) -> Result<(), Error> {
    let d = m.options.dim;
    let eta_data = reduce_series(m, test_k)?;
    let n_data = eta_data.len() / d;
    if n_data < 2 {
        r.failed = Some(format!("held-out series too short for the embedding ({n_data} points)"));
        return Ok(());
    }
    let eta0 = eta_data[..d].to_vec();
    r.rollout = rollout_error(&m.dynamics, &eta_data, d, rollout_horizon(ctx.theiler), ROLLOUT_STARTS);
    let data_max = eta_data.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    // A known Benettin run with this start and these lengths is this one.
    let reuse = known.filter(|k| k.eta0 == eta0 && k.transient == s.benettin_transient && k.steps == s.benettin_steps);
    match reuse
        .map_or_else(|| model_lyapunov(m, &eta0, s.benettin_transient, s.benettin_steps), |k| Ok(k.result.clone()))
    {
        Ok(b) => {
            r.benettin = Some(b.exponent);
            r.benettin_err = Some(b.std_error);
            r.benettin_2nd = b.spectrum.get(1).copied();
        }
        Err(e) => r.notes.push(format!("Benettin: {e}")),
    }
    // The long run: the observable series (as long as the data), then the rest for the PDFs.
    let n_long = test_k.x.len().max(n_data) * s.long_runs.max(1);
    let orbit = match iterate_dynamics(&m.dynamics, &eta0, n_long, model_bound(m), 1) {
        Ok(o) => o,
        Err(e) => {
            r.failed = Some(format!("escaped in the long run: {e}"));
            return Ok(());
        }
    };
    let Some(pts) = orbit.recorded else {
        r.failed = Some("long run recorded nothing".into());
        return Ok(());
    };
    r.long_steps = orbit.steps;
    let etas = pts.as_flat();
    let exc = etas.iter().fold(0.0_f64, |a, v| a.max(v.abs())) / data_max;
    r.excursion = Some(exc);
    if !(exc <= s.region_factor) {
        let k =
            (0..pts.len()).find(|&i| pts.point(i).iter().any(|v| v.abs() > s.region_factor * data_max)).unwrap_or(0);
        r.failed = Some(format!(
            "left the data's region: |eta| reached {exc:.2} x the data's largest |eta_i| (limit {}), first at t = {:.1} s",
            s.region_factor,
            k as f64 * m.dt
        ));
        return Ok(());
    }
    let mut lifted = vec![0.0; m.manifold.p];
    let mut ps = ssm::poly::PolyScratch::default();
    let seg = test_k.x.len().min(pts.len());
    let mut x = Vec::with_capacity(seg);
    for i in 0..seg {
        m.manifold.lift_into(pts.point(i), &mut ps, &mut lifted);
        x.push(lifted[0]);
    }
    match ctx.lle(&x, &mut r.notes, "model") {
        Ok((l, _)) => r.rosenstein = Some(l),
        Err(e) => r.notes.push(format!("Rosenstein on the model series: {e}")),
    }
    let noisy = add_noise(&x, r.data.noise_sd, 1);
    match ctx.lle(&noisy, &mut Vec::new(), "model + noise") {
        Ok((l, _)) => r.rosenstein_noisy = Some(l),
        Err(e) => r.notes.push(format!("Rosenstein on the model series with noise: {e}")),
    }
    match delay_embed(&x, ctx.embed, ctx.lag).and_then(|p| {
        correlation_dimension(
            &p,
            &CorrSumParams { theiler: ctx.theiler, ..Default::default() },
            &ScalingRule::default(),
        )
    }) {
        Ok(cd) => (r.corr_dim, r.corr_dim_err) = (Some(cd.dimension), Some(cd.slope_std)),
        Err(e) => r.notes.push(format!("correlation dimension of the model series: {e}")),
    }
    match Points::from_flat(d, eta_data).and_then(|a| chaos::compare_pdfs(&a, &pts, Bins::default())) {
        Ok(cmp) => r.js = Some(cmp.mean_js_bits),
        Err(e) => r.notes.push(format!("PDFs: {e}")),
    }
    Ok(())
}

/// Starts of the rollout loss on the held-out series ([`chaos::rollout_error`]).
pub const ROLLOUT_STARTS: usize = 200;

/// [`chaos::rollout_error`] of a discrete reduced map on a held-out reduced series;
/// `None` for a continuous flow.
pub fn rollout_error(
    dynamics: &ssm::ReducedDynamics,
    eta_data: &[f64],
    d: usize,
    horizon: usize,
    starts: usize,
) -> Option<f64> {
    let dt = dynamics.map_dt()?;
    let mut scratch = ssm::dynamics::StepScratch::default();
    let map = dynamics.prepare();
    chaos::rollout_error(|eta| map.step(eta, dt, &mut scratch), eta_data, d, horizon, starts)
}

/// The pick of [`select`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Selection {
    /// Index into the results, `None` when every candidate failed.
    pub index: Option<usize>,
    pub name: Option<String>,
    pub why: String,
    /// Chaos of data and pick disagree (data chaotic, pick not, or the reverse).
    pub warnings: Vec<String>,
}

/// Picks the candidate meeting most targets, ties broken by the smallest
/// [`CandidateResult::score`]; failed candidates are never picked. The data count as chaotic
/// when their Rosenstein exponent is positive and larger than `chaos_margin` (1/s); a pick
/// counts as chaotic when its Benettin exponent exceeds twice its block error.
pub fn select(results: &[CandidateResult], t: &Targets, chaos_margin: f64) -> Selection {
    let best =
        best_of(results.iter().map(|r| (r.failed.is_some(), r.passes(t).iter().filter(|p| **p).count(), r.score(t))));
    let failed = results.iter().filter(|r| r.failed.is_some()).count();
    let Some((i, n, sc)) = best else {
        return Selection {
            index: None,
            name: None,
            why: format!("all {} candidates failed (escape, left the data's region or fit error)", results.len()),
            warnings: vec!["no model: every candidate failed".into()],
        };
    };
    let r = &results[i];
    let p = r.passes(t);
    let names = ["Benettin within 10 %", "Rosenstein within 5 %", "D2 within the data's error bar", "JS within bound"];
    let met: Vec<&str> = names.iter().zip(p).filter(|(_, ok)| *ok).map(|(n, _)| *n).collect();
    let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
    let why = format!(
        "{} meets {n} of 4 targets ({}) with normalized error {sc:.2}: Benettin {} 1/s, Rosenstein {} vs data {:.3} 1/s, D2 {} vs {:.2} +- {:.2}, JS {}; {} of {} candidates failed",
        r.name,
        if met.is_empty() { "none".to_string() } else { met.join(", ") },
        f(r.benettin),
        f(r.rosenstein),
        r.data.lle,
        f(r.corr_dim),
        r.data.corr_dim,
        r.data.corr_dim_err,
        f(r.js),
        failed,
        results.len()
    );
    let data_chaotic = r.data.lle > chaos_margin;
    let model_chaotic = chaos::is_chaotic(r.benettin, r.benettin_err);
    let mut warnings = Vec::new();
    if data_chaotic && !model_chaotic {
        warnings.push(format!(
            "the data look chaotic (Rosenstein {:.3} 1/s) but the best model is not (Benettin {} +- {} 1/s): its irregularity is not reproduced by its own dynamics",
            r.data.lle,
            f(r.benettin),
            f(r.benettin_err)
        ));
    } else if !data_chaotic && model_chaotic {
        warnings.push(format!(
            "the best model is chaotic (Benettin {} 1/s) but the data do not look so (Rosenstein {:.3} 1/s)",
            f(r.benettin),
            r.data.lle
        ));
    }
    Selection { index: Some(i), name: Some(r.name.clone()), why, warnings }
}

/// One line for a candidate: its statistics against the data's, or why it failed.
pub fn describe(r: &CandidateResult) -> String {
    let f = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |v| format!("{v:.p$}"));
    let head = format!(
        "{}: Benettin {} (2nd {}), Rosenstein {} (data {:.3}), D2 {} (data {:.2} +- {:.2}), JS {}",
        r.name,
        f(r.benettin, 3),
        f(r.benettin_2nd, 3),
        f(r.rosenstein, 3),
        r.data.lle,
        f(r.corr_dim, 2),
        r.data.corr_dim,
        r.data.corr_dim_err,
        f(r.js, 4)
    );
    match &r.failed {
        Some(why) => format!("{head}: FAILED, {why}"),
        None => head,
    }
}

/// The standard candidates at each map step of `steps`: the RBF map (`o.centers`) and the
/// polynomial map (`o.poly_order`) with the study's options ([`crate::microchaos::fit_options`]:
/// embedding `2 d + 1`, the shift rule applied to the held-out series subsampled by the step,
/// unless `o` sets them). Named `"RBF <centres> /<step>"` and `"poly <order> /<step>"`.
pub fn standard_candidates(
    o: &crate::microchaos::ChaosOptions,
    ssm_dim: usize,
    steps: &[usize],
    test: &TimeSeries,
) -> Result<Vec<Candidate>, Error> {
    o.validate()?;
    let mut out = Vec::new();
    for &k in steps {
        let ts = subsample(test, k, 0)?;
        let dt = ts
            .dt()
            .ok_or(Error::BadInput { what: "held-out series", why: format!("{}: no sampling step", ts.name) })?;
        let ctx = Context::from_series(&ts.x, dt, o.gp_embed)?;
        let base = crate::microchaos::fit_options(o, ssm_dim, &ctx);
        out.push(Candidate {
            name: format!("RBF {} /{k}", o.centers),
            step: k,
            fit: FitOptions { dynamics: ssm::Dynamics::Rbf { centers: o.centers }, ..base },
            smooth: 0,
            multistep: None,
            denoise_inputs: 0,
            centres: Default::default(),
        });
        out.push(Candidate {
            name: format!("poly {} /{k}", o.poly_order),
            step: k,
            fit: FitOptions { dynamics: ssm::Dynamics::Map, ..base },
            smooth: 0,
            multistep: None,
            denoise_inputs: 0,
            centres: Default::default(),
        });
    }
    Ok(out)
}

/// The summary's `chosen_model`: the pick's name, options, map step, statistics (with the
/// data's), why, warnings; `{"name": null, "why": ...}` when every candidate failed.
pub fn chosen_json(results: &[CandidateResult], sel: &Selection) -> serde_json::Value {
    match sel.index.and_then(|i| results.get(i)) {
        None => serde_json::json!({ "name": null, "why": sel.why, "warnings": sel.warnings }),
        Some(r) => serde_json::json!({
            "name": r.name,
            "options": r.options,
            "step": r.step,
            "benettin": r.benettin,
            "benettin_err": r.benettin_err,
            "rosenstein": r.rosenstein,
            "corr_dim": r.corr_dim,
            "corr_dim_err": r.corr_dim_err,
            "js": r.js,
            "excursion": r.excursion,
            "data": r.data,
            "why": sel.why,
            "warnings": sel.warnings,
        }),
    }
}

/// The inverted-flag configurations the candidate search picked (see `studies/results/flag/search.json`), as
/// candidates for the report's selection.
pub fn flag_candidates() -> Vec<Candidate> {
    FLAG_CHOSEN
        .iter()
        .map(|&(name, step, dim, embed, shift, manifold_order, centers, ridge)| Candidate {
            name: name.to_string(),
            step,
            fit: FitOptions {
                dim,
                embed,
                shift,
                manifold_order,
                dyn_order: 4,
                dynamics: ssm::Dynamics::Rbf { centers },
                ridge: ssm::Ridge::Fixed(ridge),
                linear_anchor: None,
                anchor_joint: false,
            },
            smooth: 0,
            multistep: None,
            denoise_inputs: 0,
            centres: Default::default(),
        })
        .collect()
}

/// (name, step, d, p, shift, manifold order, centres, ridge) of [`flag_candidates`].
/// The chaotic candidates of the search closest to the targets: Benettin within 10 % (250
/// centres, ridge 1e-8; 300 centres, ridge 3e-9) and D2 within the error bar (200 centres,
/// ridge 3e-9); none brings its Rosenstein exponent within 5 % of the data's.
pub const FLAG_CHOSEN: [(&str, usize, usize, usize, usize, u32, usize, f64); 3] = [
    ("RBF 250 /4 r=1e-8", 4, 4, 9, 1, 3, 250, 1e-8),
    ("RBF 300 /4 r=3e-9", 4, 4, 9, 1, 3, 300, 3e-9),
    ("RBF 200 /4 r=3e-9", 4, 4, 9, 1, 3, 200, 3e-9),
];

/// One chaotic row of the flag's candidate search with its estimator ratio.
#[derive(Clone, Debug, Serialize)]
pub struct RatioRow {
    pub candidate: String,
    /// The map's own exponent and the Rosenstein exponent of its series, 1/s.
    pub benettin: f64,
    pub rosenstein: f64,
    /// `rosenstein / benettin`: the Rosenstein estimator's bias on this model's attractor.
    pub ratio: f64,
    pub corr_dim: f64,
    /// The data's correlation dimension at the row's step (the parenthesized value of the
    /// D2 column).
    pub data_corr_dim: f64,
    pub js: f64,
    /// The data's Rosenstein exponent at the row's step over `ratio`: the data's exponent if
    /// the estimator were biased on the data as on this model, 1/s.
    pub implied_data_exponent: f64,
    /// Fitted with the multi-step refinement (notes column "multistep ...").
    pub multistep: bool,
}

/// The Rosenstein/Benettin ratio of every chaotic row of the flag's candidate search (rows
/// whose outcome is "chaotic" and whose Benettin and Rosenstein values are numbers).
pub fn flag_search_ratios(search: &crate::study_results::SearchResults) -> Vec<RatioRow> {
    search
        .rows
        .iter()
        .filter(|r| r.chaotic && r.failed.is_none())
        .filter_map(|r| {
            let (b, ro, d2, js) = (r.benettin?, r.rosenstein?, r.corr_dim?, r.js?);
            (b > 0.0).then(|| RatioRow {
                candidate: r.candidate.clone(),
                benettin: b,
                rosenstein: ro,
                ratio: ro / b,
                corr_dim: d2,
                data_corr_dim: r.data_corr_dim,
                js,
                implied_data_exponent: r.data_rosenstein * b / ro,
                multistep: r.notes.starts_with("multistep"),
            })
        })
        .collect()
}

/// Largest distance of a best-matching row's D2 from the data's ([`best_matching`]).
pub const BEST_MATCH_D2: f64 = 0.5;
/// Largest JS divergence (bits) of a best-matching row ([`best_matching`]).
pub const BEST_MATCH_JS: f64 = 0.005;

/// The one-step (not multistep) rows of [`flag_search_ratios`] closest to the data: D2
/// within [`BEST_MATCH_D2`] of the data's and JS at most [`BEST_MATCH_JS`].
pub fn best_matching(rows: &[RatioRow]) -> Vec<&RatioRow> {
    rows.iter()
        .filter(|r| !r.multistep && (r.corr_dim - r.data_corr_dim).abs() <= BEST_MATCH_D2 && r.js <= BEST_MATCH_JS)
        .collect()
}

/// Evaluates every candidate (on the rayon pool, results in input order; data statistics
/// once per map step) and selects one.
pub fn evaluate_and_select(
    train: &[TimeSeries],
    test: &TimeSeries,
    candidates: &[Candidate],
    s: &EvalSettings,
    t: &Targets,
) -> Result<(Vec<CandidateResult>, Selection), Error> {
    evaluate_and_select_known(train, test, candidates, s, t, &Known::default())
}

/// [`evaluate_and_select`] reusing what an earlier analysis of the same `train` and `test`
/// computed ([`Known`]): the step-1 data statistics when their settings are `s`'s, and the
/// models the step-1 candidates would fit. The results are those of [`evaluate_and_select`].
pub fn evaluate_and_select_known(
    train: &[TimeSeries],
    test: &TimeSeries,
    candidates: &[Candidate],
    s: &EvalSettings,
    t: &Targets,
    known: &Known<'_>,
) -> Result<(Vec<CandidateResult>, Selection), Error> {
    let mut steps: Vec<usize> = candidates.iter().map(|c| c.step).collect();
    steps.sort_unstable();
    steps.dedup();
    let stats = crate::par_map(&steps, |&k| match &known.step1 {
        Some(st) if k == 1 && st.1.embed == s.gp_embed => Ok(st.clone()),
        _ => data_stats(test, k, s),
    })?;
    let results = crate::par_map(candidates, |c| {
        let i = steps.iter().position(|&k| k == c.step).unwrap_or(0);
        evaluate_candidate_known(train, test, c, &stats[i], s, known.model_for(c))
    })?;
    let sel = select(&results, t, 0.0);
    Ok((results, sel))
}
