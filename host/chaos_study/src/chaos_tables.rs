//! The chaos study's two tables (paper section 3.2, MODEL.md "Lyapunov exponents of a
//! quantized loop"):
//!
//! - [`scale_dependence`]: Kantz's time-series exponent as a function of the neighbourhood
//!   scale `eps`. For a quantized loop the exponent is scale dependent: below the
//!   quantization step nearby states receive identical control codes and separate at the
//!   open-loop rate; above it the macroscopic (microchaotic) rate shows.
//! - [`accuracy_vs_cost`]: model accuracy (LLE error, PDF divergence) against fit time and
//!   time per model step, over RBF centre counts and polynomial orders. Times are wall-clock
//!   `Instant` measurements, reported also as ratios to the smallest configuration; they are
//!   never asserted.

use crate::Error;
use std::time::Instant;

use chaos::{ChaosError, DivergenceParams, delay_embed, kantz_curves};
use serde::Serialize;

use crate::lyapunov::model_bound;
use crate::microchaos::{ChaosOptions, evaluate_model, fit_options};
use chaos::{Context, fit_lle_curve};
use ssm::dynamics::StepScratch;
use ssm::{Dynamics, SsmModel, TimeSeries, fit};

// ---------------------------------------------------------------------------------------
// Scale dependence of the time-series exponent.

/// Kantz's exponent at one scale.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleRow {
    /// Neighbourhood radius (Euclidean, in the units of the series).
    pub eps: f64,
    /// `eps` in units of the study's reference scale.
    pub eps_units: f64,
    /// Exponent, 1/s (absent when no fit was possible).
    pub exponent: Option<f64>,
    pub fit_stderr: Option<f64>,
    pub window_s: Option<(f64, f64)>,
    /// Rise of the divergence curve, nats.
    pub rise: Option<f64>,
    pub mean_neighbours: f64,
    pub n_reference: usize,
    /// Fit-rule fallback used, or why there is no value.
    pub note: String,
}

/// Kantz's exponent against `eps` for one series.
#[derive(Clone, Debug, Serialize)]
pub struct ScaleStudy {
    pub name: String,
    /// What `eps_units` counts (e.g. "encoder step h = 3.14e-3 rad", "series sd").
    pub unit_name: String,
    pub unit: f64,
    pub samples: usize,
    pub dt: f64,
    pub embed: usize,
    pub lag: usize,
    pub theiler: usize,
    pub max_steps: usize,
    pub rows: Vec<ScaleRow>,
    pub seconds: f64,
}

/// Kantz's exponent of the scalar series `x` (step `dt`) in a delay embedding of dimension
/// `embed` (lag = first zero of the autocorrelation, Theiler window = dominant period,
/// curve length 3 Theiler windows within 30..1000 samples, as in [`crate::microchaos::analyse`]),
/// at radii `eps = eps_units * unit`. At most 2000 reference points and 50 neighbours each.
/// The fit window follows the same rule with the same fallbacks as `analyse`.
pub fn scale_dependence(
    name: &str,
    x: &[f64],
    dt: f64,
    embed: usize,
    unit_name: &str,
    unit: f64,
    eps_units: &[f64],
) -> Result<ScaleStudy, ChaosError> {
    let t0 = Instant::now();
    let ctx = Context::from_series(x, dt, embed)?;
    let pts = delay_embed(x, embed, ctx.lag)?;
    let eps: Vec<f64> = eps_units.iter().map(|e| e * unit).collect();
    let p = DivergenceParams { max_reference: KANTZ_REFERENCES, ..ctx.divergence_params() };
    let curves = kantz_curves(&pts, &eps, &p, KANTZ_NEIGHBOURS)?;
    let rows = curves
        .into_iter()
        .zip(eps_units)
        .map(|((eps, mean_neighbours, curve), &eu)| match curve {
            Err(why) => ScaleRow {
                eps,
                eps_units: eu,
                exponent: None,
                fit_stderr: None,
                window_s: None,
                rise: None,
                mean_neighbours,
                n_reference: 0,
                note: why,
            },
            Ok(c) => {
                let n_reference = c.n_reference;
                match fit_lle_curve(&c) {
                    Ok((f, note)) => ScaleRow {
                        eps,
                        eps_units: eu,
                        exponent: Some(f.exponent),
                        fit_stderr: Some(f.fit_stderr),
                        window_s: Some(f.window_time),
                        rise: Some(f.rise),
                        mean_neighbours,
                        n_reference,
                        note: note.unwrap_or_default(),
                    },
                    Err(e) => ScaleRow {
                        eps,
                        eps_units: eu,
                        exponent: None,
                        fit_stderr: None,
                        window_s: None,
                        rise: None,
                        mean_neighbours,
                        n_reference,
                        note: e.to_string(),
                    },
                }
            }
        })
        .collect();
    Ok(ScaleStudy {
        name: name.into(),
        unit_name: unit_name.into(),
        unit,
        samples: x.len(),
        dt,
        embed,
        lag: ctx.lag,
        theiler: ctx.theiler,
        max_steps: p.max_steps,
        rows,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

// ---------------------------------------------------------------------------------------
// Accuracy against cost.

/// One model configuration of the accuracy-vs-cost study.
#[derive(Clone, Debug, Serialize)]
pub struct CostRow {
    /// "rbf" (setting = centres) or "poly" (setting = map order).
    pub kind: String,
    pub setting: usize,
    /// Rosenstein exponent of the model series (same estimator and settings as the data), 1/s.
    pub lle_rosenstein: Option<f64>,
    /// |lle_rosenstein - data exponent|, 1/s.
    pub lle_abs_error: Option<f64>,
    /// Benettin exponent of the map, 1/s.
    pub lle_benettin: Option<f64>,
    /// Mean Jensen-Shannon divergence of the reduced-coordinate PDFs, bits.
    pub pdf_js: Option<f64>,
    pub fit_s: f64,
    /// Mean wall time per model step (reduced map only), microseconds.
    pub step_us: f64,
    /// Ratios to the smallest configuration of the same kind.
    pub fit_ratio: f64,
    pub step_ratio: f64,
    pub notes: Vec<String>,
}

/// Result of [`accuracy_vs_cost`].
#[derive(Clone, Debug, Serialize)]
pub struct CostStudy {
    pub name: String,
    pub lle_data: f64,
    pub ssm_dim: usize,
    pub rows: Vec<CostRow>,
}

/// Steps timed per configuration for the time per model step.
pub const TIMED_STEPS: usize = 20_000;

/// Fits each RBF centre count in `centres` and each polynomial order in `orders` with the
/// other options of `o` (SSM dimension: `o.ssm_dim`, else the paper's rule), and measures
/// accuracy and cost. Times come from `Instant` around the fit and around [`TIMED_STEPS`]
/// steps of the reduced map; never asserted anywhere.
pub fn accuracy_vs_cost(
    name: &str,
    train: &[TimeSeries],
    o: &ChaosOptions,
    centres: &[usize],
    orders: &[u32],
) -> Result<CostStudy, Error> {
    let data = train
        .iter()
        .max_by_key(|s| s.x.len())
        .ok_or(Error::BadInput { what: "training", why: "no training series".into() })?;
    let dt = data.dt().ok_or(Error::BadInput { what: "data", why: "the series has no sampling step".into() })?;
    let ctx = Context::from_series(&data.x, dt, o.gp_embed)?;
    let ssm_dim = match o.ssm_dim {
        Some(d) => d,
        None => ctx.ssm_dim_from_data(&data.x, o.gp_embed)?,
    };
    let mut notes = Vec::new();
    let (lle_data, _) = ctx.lle(&data.x, &mut notes, "data")?;
    let mut rows: Vec<CostRow> = Vec::new();
    let configs = centres
        .iter()
        .map(|&c| ("rbf", c, Dynamics::Rbf { centers: c }, o.poly_order))
        .chain(orders.iter().map(|&k| ("poly", k as usize, Dynamics::Map, k)));
    for (kind, setting, dynamics, order) in configs {
        let mut opts = fit_options(o, ssm_dim, &ctx);
        opts.dynamics = dynamics;
        opts.dyn_order = order;
        let t0 = Instant::now();
        let fitted = fit(train, &opts);
        let fit_s = t0.elapsed().as_secs_f64();
        let mut row = CostRow {
            kind: kind.into(),
            setting,
            lle_rosenstein: None,
            lle_abs_error: None,
            lle_benettin: None,
            pdf_js: None,
            fit_s,
            step_us: f64::NAN,
            fit_ratio: f64::NAN,
            step_ratio: f64::NAN,
            notes: Vec::new(),
        };
        match fitted {
            Err(e) => row.notes.push(format!("fit failed: {e}")),
            Ok(m) => {
                let s = evaluate_model(&m, data, &ctx, o, kind)?;
                row.lle_rosenstein = s.lle_rosenstein;
                row.lle_abs_error = s.lle_rosenstein.map(|v| (v - lle_data).abs());
                row.lle_benettin = s.benettin.as_ref().map(|b| b.exponent);
                row.pdf_js = s.js;
                row.notes = s.notes;
                row.step_us = time_steps(&m, &s.eta0);
            }
        }
        rows.push(row);
    }
    for kind in ["rbf", "poly"] {
        let base = rows.iter().find(|r| r.kind == kind).map(|r| (r.fit_s, r.step_us));
        if let Some((f0, s0)) = base {
            for r in rows.iter_mut().filter(|r| r.kind == kind) {
                r.fit_ratio = r.fit_s / f0;
                r.step_ratio = r.step_us / s0;
            }
        }
    }
    Ok(CostStudy { name: name.into(), lle_data, ssm_dim, rows })
}

/// Mean microseconds per reduced-map step over [`TIMED_STEPS`] steps from `eta0` (a state
/// that leaves the training range is reset to `eta0`, so the loop times the same work). The
/// step timed is the prepared map's ([`ssm::dynamics::ReducedDynamics::prepare`], outside the
/// timed loop), the step the model runs ([`SsmModel::predict`]) take, with the same bits as
/// the plain `step`.
fn time_steps(m: &SsmModel, eta0: &[f64]) -> f64 {
    let mut eta = eta0.to_vec();
    let mut s = StepScratch::default();
    let bound = model_bound(m);
    let map = m.dynamics.prepare();
    let t0 = Instant::now();
    for _ in 0..TIMED_STEPS {
        map.step(&mut eta, m.dt, &mut s);
        if !eta.iter().all(|v| v.is_finite() && v.abs() <= bound) {
            eta.copy_from_slice(eta0);
        }
    }
    std::hint::black_box(&eta);
    t0.elapsed().as_secs_f64() * 1e6 / TIMED_STEPS as f64
}

/// Encoder step of `furuta-quant-dt25` (2000 counts per revolution), rad.
pub const H_ADC: f64 = std::f64::consts::PI / 1000.0;

/// Kantz's estimator in the scale studies: at most this many reference points, each with
/// this many neighbours.
pub const KANTZ_REFERENCES: usize = 2000;
pub const KANTZ_NEIGHBOURS: usize = 50;
/// Embedding dimension and number of log-spaced radii of the scale studies.
pub const SCALE_EMBED: usize = 6;
pub const SCALES: usize = 8;
/// SSM dimension of the accuracy-vs-cost study's models.
pub const COST_DIM: usize = 6;

/// The two scale studies of the report: the simulated quantized loop (theta, `periods`
/// sampling periods, eps = 0.1..30 encoder steps) and, when present, the inverted flag
/// (traj_9, eps = 0.01..1 series sd); 8 log-spaced scales each, embedding dimension 6.
pub fn scale_studies(data_dir: &std::path::Path, periods: usize) -> Result<Vec<ScaleStudy>, Error> {
    // The two studies are independent: two tasks on the rayon pool, in this order.
    let simulated = || -> Result<ScaleStudy, Error> {
        let sim = crate::microchaos::simulate_quantized(periods, 0.02, "furuta-quant-dt25")?;
        let dt = sim.dt().ok_or(Error::BadInput { what: "simulated series", why: "no sampling step".into() })?;
        let eps = chaos::log_spaced(0.1, 30.0, SCALES)?;
        Ok(scale_dependence(
            "simulated: furuta-quant-dt25 (theta)",
            &sim.x,
            dt,
            SCALE_EMBED,
            "encoder step h = pi/1000 rad",
            H_ADC,
            &eps,
        )?)
    };
    let measured = || -> Result<Option<ScaleStudy>, Error> {
        let f = data_dir.join("inverted_flag_chaotic").join("traj_9.csv");
        if !f.is_file() {
            return Ok(None);
        }
        let ts = ssm::load_csv(&f)?;
        let dt = ts.dt().ok_or(Error::BadInput { what: "inverted-flag series", why: "no sampling step".into() })?;
        let n = ts.x.len() as f64;
        let m = ts.x.iter().sum::<f64>() / n;
        let sd = (ts.x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0)).sqrt();
        let eps = chaos::log_spaced(0.01, 1.0, SCALES)?;
        Ok(Some(scale_dependence("measured: inverted flag traj_9", &ts.x, dt, SCALE_EMBED, "series sd", sd, &eps)?))
    };
    let (a, b) = rayon::join(simulated, measured);
    let mut out = vec![a?];
    out.extend(b?);
    Ok(out)
}

/// The inverted-flag accuracy-vs-cost study of the report: RBF centres 50, 100, 200, 500
/// and polynomial orders 2..5 (6D SSM, default options otherwise), trained on traj_9 + traj_7.
pub fn flag_cost_study(data_dir: &std::path::Path) -> Result<Option<CostStudy>, Error> {
    let d = data_dir.join("inverted_flag_chaotic");
    if !d.join("traj_9.csv").is_file() {
        return Ok(None);
    }
    let train = vec![ssm::load_csv(d.join("traj_9.csv"))?, ssm::load_csv(d.join("traj_7.csv"))?];
    let o = ChaosOptions { ssm_dim: Some(COST_DIM), ..Default::default() };
    Ok(Some(accuracy_vs_cost("inverted flag (traj_9 + traj_7)", &train, &o, &[50, 100, 200, 500], &[2, 3, 4, 5])?))
}
