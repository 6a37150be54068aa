//! Chaotic statistics, data vs SSM models (paper section 3.2): correlation dimension
//! (Grassberger-Procaccia) and the SSM dimension rule (the smallest even dimension above the
//! estimate plus its error bar); SSM fits with RBF and polynomial reduced dynamics; the largest
//! Lyapunov exponent by Rosenstein's estimator applied identically to data and to
//! model-generated series, and of the smooth reduced maps themselves by Benettin's method
//! (analytic tangent maps, [`crate::lyapunov`]); PDFs of the reduced coordinates and their
//! Jensen-Shannon divergence.
//!
//! Stated choices: delay lag = first zero of the autocorrelation; Theiler window = dominant
//! period T (both from the training data, reused unchanged for model series); GP embedding
//! dimension `gp_embed` (default 6); Rosenstein in the same embedding, curve length
//! 3 Theiler windows (30..1000 samples), fit window by the chaos crate's straightest-section
//! rule. SSM delay embedding `p = 2 d + 1` with shift `round(T / (4 (p - 1)))` (the window
//! spans a quarter period); defaults 500 RBF centres, polynomial map order 4, relative ridge
//! 1e-8 (measured on the inverted flag: see the report). Model series are as long as the
//! data series and start from the data's first point; Benettin runs 5,000 transient and
//! 50,000 measured steps from the same point.

use crate::Error;
use crate::lyapunov::{ModelLyapunov, model_lyapunov};
use chaos::held_out::{Context, GrowthWindow, dimension_rule, fit_lle_curve, growth_windows};
use chaos::{Bins, CorrSumParams, Points, ScalingRule, correlation_dimension, delay_embed};
use serde::Serialize;
use sim::closed_loop::Trajectory;
use sim::scene::{Scene, SceneBuilder};
use ssm::embed::delay_embed as ssm_embed;
use ssm::{Dynamics, FitOptions, Ridge, SsmModel, TimeSeries, fit};

#[derive(Clone, Debug)]
pub struct ChaosOptions {
    /// Embedding dimension for the correlation dimension and Lyapunov estimates.
    pub gp_embed: usize,
    /// Override the SSM dimension (default: the paper's rule from the dimension estimate).
    pub ssm_dim: Option<usize>,
    /// RBF centres.
    pub centers: usize,
    /// Polynomial map order.
    pub poly_order: u32,
    /// Relative ridge parameter of both SSM regressions.
    pub ridge: f64,
    /// SSM delay-embedding dimension (default `2 d + 1`).
    pub embed: Option<usize>,
    /// SSM delay-embedding shift, samples (default: the embedding window `(p - 1) shift`
    /// spans a quarter of the dominant period, `round(T / (4 (p - 1)))`, at least 1).
    pub shift: Option<usize>,
    /// Polynomial order of the manifold parametrization.
    pub manifold_order: u32,
    /// Benettin: transient and measured map steps on the model's own attractor.
    pub benettin_transient: usize,
    pub benettin_steps: usize,
}

/// Largest delay-embedding dimension of the chaos estimators.
pub const MAX_GP_EMBED: usize = 64;

impl ChaosOptions {
    /// Checks the options before any work: an SSM dimension, centre count, shift or order of
    /// 0 is an error (not a failed fit reported in a note), sizes are bounded by
    /// [`ssm::limits`] (and [`MAX_GP_EMBED`]) with the limit in the message.
    pub fn validate(&self) -> Result<(), Error> {
        use ssm::limits::{MAX_CENTERS, MAX_DIM, MAX_EMBED, MAX_ORDER, MAX_SHIFT};
        let range = |what: &'static str, v: usize, max: usize| {
            if v == 0 {
                Err(Error::BadOption { what, why: "must be >= 1".into() })
            } else if v > max {
                Err(Error::BadOption { what, why: format!("{v} exceeds the limit of {max}") })
            } else {
                Ok(())
            }
        };
        range("gp_embed", self.gp_embed, MAX_GP_EMBED)?;
        if let Some(d) = self.ssm_dim {
            range("ssm_dim", d, MAX_DIM)?;
        }
        range("centers", self.centers, MAX_CENTERS)?;
        range("poly_order", self.poly_order as usize, MAX_ORDER as usize)?;
        range("manifold_order", self.manifold_order as usize, MAX_ORDER as usize)?;
        if let Some(p) = self.embed {
            range("embed", p, MAX_EMBED)?;
        }
        if let Some(s) = self.shift {
            range("shift", s, MAX_SHIFT)?;
        }
        if !(self.ridge.is_finite() && self.ridge >= 0.0) {
            return Err(Error::BadOption {
                what: "ridge",
                why: format!("must be finite and >= 0, got {}", self.ridge),
            });
        }
        if let Some(d) = self.ssm_dim {
            // Everything the SSM options imply (monomial counts, p > 2d) before any estimate.
            let ctx_free = FitOptions {
                dim: d,
                embed: self.embed.unwrap_or(2 * d + 1),
                shift: self.shift.unwrap_or(1),
                manifold_order: self.manifold_order,
                dyn_order: self.poly_order,
                dynamics: Dynamics::Map,
                ridge: Ridge::Fixed(self.ridge),
                linear_anchor: None,
                anchor_joint: false,
            };
            ctx_free.validate()?;
        }
        Ok(())
    }
}

impl Default for ChaosOptions {
    fn default() -> Self {
        Self {
            gp_embed: 6,
            ssm_dim: None,
            centers: 500,
            poly_order: 4,
            ridge: 1e-8,
            embed: None,
            shift: None,
            manifold_order: 2,
            benettin_transient: 5_000,
            benettin_steps: 50_000,
        }
    }
}

/// What `ssmctl chaos --json` prints (and `summary.json` holds per data set).
#[derive(Clone, Debug, Serialize)]
pub struct ChaosSummary {
    pub corr_dim: f64,
    pub corr_dim_err: f64,
    pub ssm_dim: usize,
    /// Largest Lyapunov exponents, 1/s (Rosenstein, identical settings).
    pub lle_data: f64,
    pub lle_model_rbf: Option<f64>,
    pub lle_model_poly: Option<f64>,
    /// Largest Lyapunov exponents of the smooth reduced maps themselves, 1/s: Benettin with
    /// the analytic tangent map and QR re-orthonormalization on the model's own attractor.
    pub lle_model_rbf_benettin: Option<f64>,
    pub lle_model_poly_benettin: Option<f64>,
    /// The full Benettin results (spectrum, Kaplan-Yorke dimension, block error).
    pub benettin_rbf: Option<ModelLyapunov>,
    pub benettin_poly: Option<ModelLyapunov>,
    /// Mean Jensen-Shannon divergence (bits, 0..1) of the reduced-coordinate PDFs.
    pub pdf_divergence_rbf: Option<f64>,
    pub pdf_divergence_poly: Option<f64>,
    /// The residual-kicked models ([`evaluate_kicked`]): Rosenstein exponent (1/s) and PDF
    /// divergence (bits).
    pub lle_model_rbf_kicked: Option<f64>,
    pub lle_model_poly_kicked: Option<f64>,
    pub pdf_divergence_rbf_kicked: Option<f64>,
    pub pdf_divergence_poly_kicked: Option<f64>,
    pub lag_samples: usize,
    pub theiler_samples: usize,
    pub gp_embed: usize,
    pub lle_fit_window_s: (f64, f64),
    /// The data's divergence curve read over doubling windows (see [`growth_windows`]).
    pub growth_windows_data: Vec<GrowthWindow>,
    /// SSM fit settings used.
    pub ssm_embed: usize,
    pub ssm_shift: usize,
    pub ridge: f64,
    pub centers: usize,
    pub poly_order: u32,
    /// Why a model value is missing (blow-up, estimator failure).
    pub notes: Vec<String>,
    pub seconds: f64,
}

/// Estimator settings derived from the reference data series and reused unchanged for model
/// series: delay lag (first zero of the autocorrelation), Theiler window (dominant period),
/// embedding dimension, sampling step.
/// SSM fit options of the study (dynamics set by the caller); `ctx` gives the dominant
/// period for the default shift.
pub fn fit_options(o: &ChaosOptions, ssm_dim: usize, ctx: &Context) -> FitOptions {
    let embed = o.embed.unwrap_or(2 * ssm_dim + 1);
    let auto = ((ctx.theiler as f64 / (4.0 * (embed.max(2) - 1) as f64)).round() as usize).max(1);
    FitOptions {
        dim: ssm_dim,
        embed,
        shift: o.shift.unwrap_or(auto),
        manifold_order: o.manifold_order,
        dyn_order: o.poly_order,
        dynamics: Dynamics::Map,
        ridge: Ridge::Fixed(o.ridge),
        linear_anchor: None,
        anchor_joint: false,
    }
}

/// Statistics of one fitted model against the reference data.
#[derive(Clone, Debug)]
pub struct ModelStats {
    /// Rosenstein exponent of the model's observable series, 1/s.
    pub lle_rosenstein: Option<f64>,
    /// Mean Jensen-Shannon divergence of the reduced-coordinate PDFs, bits.
    pub js: Option<f64>,
    pub benettin: Option<ModelLyapunov>,
    /// Reduced coordinates of the data's first embedded point (the model runs start there).
    pub eta0: Vec<f64>,
    pub notes: Vec<String>,
}

/// Runs model `m` from the data's first embedded point over the data's length, then
/// measures: Rosenstein exponent of the model series (settings of `ctx`), PDF divergence
/// against the data's reduced coordinates, Benettin exponent of the map.
pub fn evaluate_model(
    m: &SsmModel,
    data: &TimeSeries,
    ctx: &Context,
    o: &ChaosOptions,
    name: &str,
) -> Result<ModelStats, Error> {
    evaluate_model_run(m, data, ctx, o, name).map(|(s, _)| s)
}

/// A model's run over held-out data as [`evaluate_model`] made it: the prediction from the
/// data's first embedded point and the data's reduced coordinates under the model
/// ([`reduce_series`]), for callers that draw them (the same values, not computed again).
#[derive(Clone, Debug)]
pub struct HeldOutRun {
    pub prediction: ssm::Prediction,
    pub eta_data: Vec<f64>,
}

/// [`evaluate_model`] that also returns the model's run ([`HeldOutRun`]).
pub fn evaluate_model_run(
    m: &SsmModel,
    data: &TimeSeries,
    ctx: &Context,
    o: &ChaosOptions,
    name: &str,
) -> Result<(ModelStats, HeldOutRun), Error> {
    let d = m.options.dim;
    let eta_data = reduce_series(m, data)?;
    let eta0 = eta_data[..d].to_vec();
    let mut notes = Vec::new();
    let mut out = ModelStats { lle_rosenstein: None, js: None, benettin: None, eta0, notes: Vec::new() };
    match model_lyapunov(m, &out.eta0, o.benettin_transient, o.benettin_steps) {
        Ok(b) => out.benettin = Some(b),
        Err(e) => notes.push(format!("{name} model Benettin: {e}")),
    }
    let p = m.predict(data)?;
    if let Some(s) = &p.stop {
        notes.push(format!("{name} model stopped at t = {:.2} s: {:?}", s.t, s.reason));
    }
    (out.lle_rosenstein, out.js) =
        series_statistics(ctx, d, &p.x, p.eta.clone(), eta_data.clone(), name, &format!("{name} model"), &mut notes);
    out.notes = notes;
    Ok((out, HeldOutRun { prediction: p, eta_data }))
}

/// Rosenstein exponent (settings of `ctx`) of a model's observable series `x`, and the mean
/// PDF divergence of its reduced coordinates `eta` against the data's `eta_data` (both
/// row-major, `d` per point). A value is `None`, with a note naming `who`, when its
/// estimator fails or the series is shorter than 10 Theiler windows; `lle_tag` prefixes the
/// Lyapunov fit-rule notes.
#[allow(clippy::too_many_arguments)]
pub fn series_statistics(
    ctx: &Context,
    d: usize,
    x: &[f64],
    eta: Vec<f64>,
    eta_data: Vec<f64>,
    lle_tag: &str,
    who: &str,
    notes: &mut Vec<String>,
) -> (Option<f64>, Option<f64>) {
    let min_len = 10 * ctx.theiler;
    if x.len() < min_len {
        notes.push(format!("{who} series too short ({} samples < {min_len}) for the estimators", x.len()));
        return (None, None);
    }
    let lle = match ctx.lle(x, notes, lle_tag) {
        Ok(v) => Some(v.0),
        Err(e) => {
            notes.push(format!("{who} Lyapunov: {e}"));
            None
        }
    };
    let js = match Points::from_flat(d, eta_data)
        .and_then(|a| chaos::compare_pdfs(&a, &Points::from_flat(d, eta)?, Bins::default()))
    {
        Ok(c) => Some(c.mean_js_bits),
        Err(e) => {
            notes.push(format!("{who} PDFs: {e}"));
            None
        }
    };
    (lle, js)
}

/// Reduced coordinates of every embedded point of `ts` under model `m`, row-major.
pub fn reduce_series(m: &SsmModel, ts: &TimeSeries) -> Result<Vec<f64>, Error> {
    let y = ssm_embed(ts, m.manifold.p, m.options.shift, 1)?;
    let mut out = Vec::with_capacity(y.ncols() * m.options.dim);
    let mut col = vec![0.0; m.manifold.p];
    for j in 0..y.ncols() {
        for (i, c) in col.iter_mut().enumerate() {
            *c = y[(i, j)];
        }
        out.extend(m.manifold.reduce(&col));
    }
    Ok(out)
}

/// Statistics of the residual-kicked model (see [`evaluate_kicked`]).
#[derive(Clone, Debug, Serialize)]
pub struct KickedStats {
    pub lle_rosenstein: Option<f64>,
    pub js: Option<f64>,
    /// RMS of the one-step residual vectors that drive it.
    pub residual_rms: f64,
    pub notes: Vec<String>,
}

/// The smooth model driven by its own one-step errors: the residuals `eta_{n+1} - F(eta_n)`
/// over the training data are drawn at random (xorshift64, `seed`) and added after every
/// map step, from the data's first point over the data's length. A smooth map fitted to a
/// quantized loop has the loop's mean dynamics but not its kicks; this puts them back as a
/// bootstrap noise, so its statistics show how much of the data's "chaos" the kicks alone
/// explain. Same estimators and settings as [`evaluate_model`].
pub fn evaluate_kicked(
    m: &SsmModel,
    train: &[TimeSeries],
    data: &TimeSeries,
    ctx: &Context,
    seed: u64,
    name: &str,
) -> Result<KickedStats, Error> {
    let res = kick_residuals(m, train)?;
    evaluate_kicked_on(m, res, reduce_series(m, data)?, ctx, seed, name)
}

/// The one-step residuals `eta_{n+1} - F(eta_n)` of `m` over the reduced training series,
/// row-major (the map stepped prepared, [`ssm::dynamics::ReducedDynamics::prepare`]: the
/// same bits as its plain step).
fn kick_residuals(m: &SsmModel, train: &[TimeSeries]) -> Result<Vec<f64>, Error> {
    use ssm::dynamics::StepScratch;
    let d = m.options.dim;
    let mut sc = StepScratch::default();
    let map = m.dynamics.prepare();
    let mut res = Vec::new();
    let mut x = vec![0.0; d];
    for ts in train {
        let e = reduce_series(m, ts)?;
        for k in 0..(e.len() / d).saturating_sub(1) {
            x.copy_from_slice(&e[k * d..(k + 1) * d]);
            map.step(&mut x, m.dt, &mut sc);
            res.extend(e[(k + 1) * d..(k + 2) * d].iter().zip(&x).map(|(a, b)| a - b));
        }
    }
    Ok(res)
}

/// [`evaluate_kicked`] from the residuals ([`kick_residuals`]) and the data's reduced
/// coordinates `eta_data` ([`reduce_series`] of the data) already formed.
fn evaluate_kicked_on(
    m: &SsmModel,
    res: Vec<f64>,
    eta_data: Vec<f64>,
    ctx: &Context,
    seed: u64,
    name: &str,
) -> Result<KickedStats, Error> {
    use ssm::dynamics::StepScratch;
    let d = m.options.dim;
    let mut sc = StepScratch::default();
    let nres = res.len() / d;
    if nres == 0 {
        return Err(Error::BadInput {
            what: "kicked model",
            why: format!("{name}: no training pairs for the residuals"),
        });
    }
    let residual_rms = (res.iter().map(|v| v * v).sum::<f64>() / nres as f64).sqrt();
    let n = eta_data.len() / d;
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let bound = crate::lyapunov::model_bound(m);
    let mut eta = eta_data[..d].to_vec();
    let mut etas = Vec::with_capacity(n * d);
    let mut x = Vec::with_capacity(n);
    let mut lifted = vec![0.0; m.manifold.p];
    let mut ps = ssm::poly::PolyScratch::default();
    let mut notes = Vec::new();
    let (map, manifold) = (m.dynamics.prepare(), m.manifold.prepare());
    for step in 0..n {
        if !eta.iter().all(|v| v.is_finite() && v.abs() <= bound) {
            notes.push(format!("{name} kicked model left the bound {bound:.3e} at step {step}"));
            break;
        }
        etas.extend_from_slice(&eta);
        manifold.lift_into(&eta, &mut ps, &mut lifted);
        x.push(lifted[0]);
        map.step(&mut eta, m.dt, &mut sc);
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let k = (state % nres as u64) as usize;
        for (e, r) in eta.iter_mut().zip(&res[k * d..(k + 1) * d]) {
            *e += r;
        }
    }
    let (lle_rosenstein, js) = series_statistics(
        ctx,
        d,
        &x,
        etas,
        eta_data,
        &format!("{name} kicked"),
        &format!("{name} kicked model"),
        &mut notes,
    );
    Ok(KickedStats { lle_rosenstein, js, residual_rms, notes })
}

/// Runs the whole analysis on training series (the longest is the reference data).
pub fn analyse(train: &[TimeSeries], o: &ChaosOptions) -> Result<ChaosSummary, Error> {
    analyse_held_out(train, None, o)
}

/// [`analyse`] with a held-out trajectory: the models are fitted on `train` only, and the
/// data statistics (dimension, Lyapunov exponent, PDFs) and the model series' starting point
/// come from `test` (the longest training series when `None`).
pub fn analyse_held_out(
    train: &[TimeSeries],
    test: Option<&TimeSeries>,
    o: &ChaosOptions,
) -> Result<ChaosSummary, Error> {
    analyse_held_out_models(train, test, o).map(|(s, _)| s)
}

/// [`analyse_held_out`] that also returns the fitted models, `("rbf" | "poly", model)` in
/// that order (a model whose fit failed, reported in the notes, is left out): callers that
/// draw the models' series reuse them instead of fitting them again.
pub fn analyse_held_out_models(
    train: &[TimeSeries],
    test: Option<&TimeSeries>,
    o: &ChaosOptions,
) -> Result<(ChaosSummary, Vec<(&'static str, SsmModel)>), Error> {
    analyse_held_out_runs(train, test, o).map(|(s, m, _)| (s, m))
}

/// [`analyse_held_out_models`] that also returns each returned model's run over the held-out
/// data ([`HeldOutRun`], in the models' order): callers that draw the model series reuse
/// them instead of predicting again.
#[allow(clippy::type_complexity)]
pub fn analyse_held_out_runs(
    train: &[TimeSeries],
    test: Option<&TimeSeries>,
    o: &ChaosOptions,
) -> Result<(ChaosSummary, Vec<(&'static str, SsmModel)>, Vec<HeldOutRun>), Error> {
    o.validate()?;
    let t0 = std::time::Instant::now();
    let longest = train
        .iter()
        .max_by_key(|s| s.x.len())
        .ok_or(Error::BadInput { what: "training", why: "no training series".into() })?;
    let data = test.unwrap_or(longest);
    let dt = data.dt().ok_or(Error::BadInput { what: "data", why: "the series has no sampling step".into() })?;
    let ctx = Context::from_series(&data.x, dt, o.gp_embed)?;
    let pts = delay_embed(&data.x, o.gp_embed, ctx.lag)?;
    let cd = correlation_dimension(
        &pts,
        &CorrSumParams { theiler: ctx.theiler, ..Default::default() },
        &ScalingRule::default(),
    )?;
    let ssm_dim = match o.ssm_dim {
        Some(d) => d,
        None => dimension_rule(cd.dimension, cd.slope_std)?,
    };
    let mut notes = Vec::new();
    // One divergence curve of the data for the exponent and the growth windows.
    let data_curve = ctx.divergence(&data.x)?;
    let (data_fit, note) = fit_lle_curve(&data_curve)?;
    if let Some(n) = note {
        notes.push(format!("data: {n}"));
    }
    let (lle_data, window) = (data_fit.exponent, data_fit.window_time);
    let growth_windows_data = growth_windows(&data_curve);
    let base = fit_options(o, ssm_dim, &ctx);
    for dynamics in [Dynamics::Rbf { centers: o.centers }, Dynamics::Map] {
        FitOptions { dynamics, ..base }.validate()?;
    }
    let mut out = ChaosSummary {
        corr_dim: cd.dimension,
        corr_dim_err: cd.slope_std,
        ssm_dim,
        lle_data,
        lle_model_rbf: None,
        lle_model_poly: None,
        lle_model_rbf_benettin: None,
        lle_model_poly_benettin: None,
        benettin_rbf: None,
        benettin_poly: None,
        pdf_divergence_rbf: None,
        pdf_divergence_poly: None,
        lle_model_rbf_kicked: None,
        lle_model_poly_kicked: None,
        pdf_divergence_rbf_kicked: None,
        pdf_divergence_poly_kicked: None,
        lag_samples: ctx.lag,
        theiler_samples: ctx.theiler,
        gp_embed: o.gp_embed,
        lle_fit_window_s: window,
        growth_windows_data,
        ssm_embed: base.embed,
        ssm_shift: base.shift,
        ridge: o.ridge,
        centers: o.centers,
        poly_order: o.poly_order,
        notes: Vec::new(),
        seconds: 0.0,
    };
    // The RBF and the polynomial model are fitted and evaluated as two tasks on the rayon
    // pool (the kicked runs draw from seed 1 in each); notes and values are merged in this
    // order. A failed fit is a note, not an error.
    let kinds = [("rbf", Dynamics::Rbf { centers: o.centers }), ("poly", Dynamics::Map)];
    let evals = crate::par_map(
        &kinds,
        |&(name, dynamics)| -> Result<Result<(ModelStats, HeldOutRun, KickedStats, SsmModel), String>, Error> {
            let mut opts = base;
            opts.dynamics = dynamics;
            let m = match fit(train, &opts) {
                Ok(m) => m,
                // A size beyond the stated limits is the caller's to fix, not a finding.
                Err(e @ ssm::FitError::TooLarge { .. }) => return Err(e.into()),
                Err(e) => return Ok(Err(format!("{name} fit failed: {e}"))),
            };
            let (s, run) = evaluate_model_run(&m, data, &ctx, o, name)?;
            // The kicked run from the data's reduced coordinates the model's run just formed.
            let k = evaluate_kicked_on(&m, kick_residuals(&m, train)?, run.eta_data.clone(), &ctx, 1, name)?;
            Ok(Ok((s, run, k, m)))
        },
    )?;
    let mut models = Vec::new();
    let mut runs = Vec::new();
    for (&(name, _), eval) in kinds.iter().zip(evals) {
        let (s, run, k, m) = match eval {
            Ok(sk) => sk,
            Err(note) => {
                notes.push(note);
                continue;
            }
        };
        models.push((name, m));
        runs.push(run);
        notes.extend(s.notes);
        let b = s.benettin.as_ref().map(|b| b.exponent);
        if name == "rbf" {
            (out.lle_model_rbf, out.pdf_divergence_rbf, out.lle_model_rbf_benettin, out.benettin_rbf) =
                (s.lle_rosenstein, s.js, b, s.benettin);
        } else {
            (out.lle_model_poly, out.pdf_divergence_poly, out.lle_model_poly_benettin, out.benettin_poly) =
                (s.lle_rosenstein, s.js, b, s.benettin);
        }
        notes.extend(k.notes);
        if name == "rbf" {
            (out.lle_model_rbf_kicked, out.pdf_divergence_rbf_kicked) = (k.lle_rosenstein, k.js);
        } else {
            (out.lle_model_poly_kicked, out.pdf_divergence_poly_kicked) = (k.lle_rosenstein, k.js);
        }
    }
    out.notes = notes;
    out.seconds = t0.elapsed().as_secs_f64();
    Ok((out, models, runs))
}

/// `periods` sampling periods of the quantized scene `furuta-quant-dt25` from
/// `theta(0) = theta0`, theta only, first 20 s of transient dropped.
pub fn simulate_quantized(periods: usize, theta0: f64, name: &str) -> Result<TimeSeries, Error> {
    simulate_scene(SceneBuilder::load("furuta-quant-dt25")?, periods, theta0, name)
}

/// [`simulate_quantized`] for any scene (e.g. with another `kd` or noise seed set on the
/// builder): the run length and the initial state `[theta0, 0, 0, 0]` are set here.
pub fn simulate_scene(scene: SceneBuilder, periods: usize, theta0: f64, name: &str) -> Result<TimeSeries, Error> {
    let s = scene.periods(periods as u64).initial_state(&[theta0, 0.0, 0.0, 0.0]).build()?;
    let tr = simulate_shared(&s)?;
    let skip = (20.0 / tr.dt) as usize;
    if skip >= tr.t.len() {
        return Err(Error::BadInput {
            what: "periods",
            why: format!("{periods} periods are shorter than the 20 s transient"),
        });
    }
    Ok(TimeSeries::new(name, tr.t[skip..].to_vec(), tr.primary()[skip..].to_vec())?)
}

/// Runs kept by [`simulate_shared`] (at most this many; the oldest is dropped first).
pub const SHARED_RUNS: usize = 8;

/// `sim::closed_loop::simulate(scene)`, shared between callers in one process: the chaos
/// study simulates the same quantized loop (`furuta-quant-dt25` from theta0 = 0.02) in the
/// chaos, chaos-scale and chaos-verdict sections, 20,000 to 30,000 periods each. A run is
/// kept per scene (everything but `run.periods`); a request for fewer periods than a kept
/// run gets that run's first `periods + 1` rows. They are the same numbers bit for bit: the
/// loop advances period by period and nothing in it depends on the run's length. A prefix
/// is served only from a run that did not stop early, so its `stopped` (none) holds for the
/// prefix too; its `saturated_samples` and `saturated_rows` are the kept run's rows below
/// the prefix's end (the verdict's run is a prefix of the chaos section's longer run from the
/// same start, so it is not simulated twice); its `ode_stats` are left zero and its
/// `wall_seconds` is 0 (they are the longer run's, not measured for the prefix). A longer
/// request simulates afresh and replaces the kept run.
pub fn simulate_shared(scene: &Scene) -> Result<Trajectory, Error> {
    type Kept = Vec<(Scene, std::sync::Arc<Trajectory>)>;
    static RUNS: std::sync::OnceLock<std::sync::Mutex<Kept>> = std::sync::OnceLock::new();
    let runs = RUNS.get_or_init(|| std::sync::Mutex::new(Vec::new()));
    let periods = scene.run.periods as usize;
    let mut key = scene.clone();
    key.run.periods = 0;
    let kept = runs.lock().ok().and_then(|v| v.iter().find(|(k, _)| *k == key).map(|(_, t)| t.clone()));
    if let Some(t) = kept {
        if t.rows() == periods + 1 {
            return Ok((*t).clone());
        }
        if t.rows() > periods + 1 && t.stopped.is_none() {
            return Ok(prefix(&t, periods + 1));
        }
    }
    let t = sim::closed_loop::simulate(scene, None)?;
    if let Ok(mut v) = runs.lock() {
        v.retain(|(k, kt)| !(*k == key && kt.rows() <= t.rows()));
        if !v.iter().any(|(k, _)| *k == key) {
            if v.len() >= SHARED_RUNS {
                v.remove(0);
            }
            v.push((key, std::sync::Arc::new(t.clone())));
        }
    }
    Ok(t)
}

/// The first `rows` rows of `t` (see [`simulate_shared`] for the statistics).
fn prefix(t: &Trajectory, rows: usize) -> Trajectory {
    let n = t.n_states();
    Trajectory {
        scene: t.scene.clone(),
        state_names: t.state_names.clone(),
        dt: t.dt,
        t: t.t[..rows].to_vec(),
        states: t.states[..rows * n].to_vec(),
        u: t.u[..rows].to_vec(),
        codes: t.codes.as_ref().map(|c| c[..rows].to_vec()),
        saturated_samples: t.saturated_rows.iter().filter(|&&r| r < rows).count() as u64,
        saturated_rows: t.saturated_rows.iter().copied().filter(|&r| r < rows).collect(),
        stopped: None,
        integrator: t.integrator.clone(),
        ode_stats: Default::default(),
        wall_seconds: 0.0,
    }
}
