//! Microchaos study tables (paper section 3.2, MODEL.md "Lyapunov exponents of a quantized
//! loop"):
//!
//! - [`rbf_jacobian`], [`poly_map_jacobian`]: analytic Jacobians of the fitted reduced maps;
//!   [`dynamics_lyapunov`] / [`model_lyapunov`]: Benettin's method with these tangent maps and
//!   QR re-orthonormalization on the model's own attractor (after a transient), so the
//!   smooth model's exponent is measured directly, not through a time-series estimator.
//!   [`iterate_dynamics`]: a long bounded iteration of a reduced map that reports escape.
//! - [`scale_dependence`] / [`scale_table`]: Kantz's time-series exponent as a function of
//!   the neighbourhood scale `eps`. For a quantized loop the exponent is scale dependent:
//!   below the quantization step nearby states receive identical control codes and separate
//!   at the open-loop rate; above it the macroscopic (microchaotic) rate shows.
//! - [`accuracy_vs_cost`] / [`cost_table`]: model accuracy (LLE error, PDF divergence)
//!   against fit time and time per model step, over RBF centre counts and polynomial orders.
//!   Times are wall-clock `Instant` measurements, reported also as ratios to the smallest
//!   configuration; they are printed, never asserted.

use std::error::Error;
use std::time::Instant;

use chaos::{BenettinParams, ChaosError, DivergenceParams, Orbit, benettin_qr, delay_embed, iterate_map, kantz_curves};
use serde::Serialize;

use crate::chaoscmd::{ChaosOptions, Context, evaluate_model, fit_options, fit_lle_curve};
use crate::ssm::dynamics::{RbfMap, ReducedDynamics, StepScratch};
use crate::ssm::fit::BLOWUP_FACTOR;
use crate::ssm::poly::Poly;
use crate::ssm::{Dynamics, SsmModel, TimeSeries, fit};

/// Why a model exponent could not be measured.
#[derive(Debug, thiserror::Error)]
pub enum ChaosTableError {
    #[error(transparent)]
    Chaos(#[from] ChaosError),
    #[error("Benettin's method here needs a discrete map; these reduced dynamics are a continuous flow")]
    NotAMap,
    #[error("initial state has {got} coordinates, the reduced dynamics have {expected}")]
    Shape { expected: usize, got: usize },
}

/// Message for the non-differentiable points of the linear kernel.
pub const RBF_KINK: &str = "state exactly at an RBF centre (the linear kernel has a kink there)";

/// Jacobian (row-major `d x d`) of the RBF map `eta -> eta + sum_i C_i ||z - c_i|| + A z + b`,
/// `z = eta / s`: `I + sum_i C_i (z - c_i)^T / (||z - c_i|| s) + A / s`. Fails only exactly
/// at a centre.
pub fn rbf_jacobian(m: &RbfMap, eta: &[f64], jac: &mut [f64]) -> Result<(), &'static str> {
    let d = m.dim;
    let k = m.n_centers();
    jac.iter_mut().for_each(|v| *v = 0.0);
    for i in 0..d {
        jac[i * d + i] = 1.0;
    }
    let mut diff = [0.0; 16];
    let mut diff_v = Vec::new();
    let diff: &mut [f64] = if d <= 16 {
        &mut diff[..d]
    } else {
        diff_v.resize(d, 0.0);
        &mut diff_v
    };
    for c in 0..k {
        let ctr = &m.centers[c * d..(c + 1) * d];
        let mut r2 = 0.0;
        for j in 0..d {
            diff[j] = eta[j] / m.scale[j] - ctr[j];
            r2 += diff[j] * diff[j];
        }
        if r2 == 0.0 {
            return Err(RBF_KINK);
        }
        let r = r2.sqrt();
        for out in 0..d {
            let w = m.coef[c * d + out];
            for j in 0..d {
                jac[out * d + j] += w * diff[j] / (r * m.scale[j]);
            }
        }
    }
    for j in 0..d {
        for out in 0..d {
            jac[out * d + j] += m.coef[(k + j) * d + out] / m.scale[j];
        }
    }
    Ok(())
}

/// Jacobian (row-major `d x d`) of the polynomial map `eta -> eta + P(eta)`, `P` evaluated
/// on `z = eta / s`: `I + dP/dz / s`.
pub fn poly_map_jacobian(p: &Poly, eta: &[f64], jac: &mut [f64]) {
    let d = p.dim_in;
    jac.iter_mut().for_each(|v| *v = 0.0);
    for i in 0..d.min(p.dim_out) {
        jac[i * d + i] = 1.0;
    }
    let maxdeg = crate::ssm::poly::max_degree(&p.exps) as usize;
    let stride = maxdeg + 1;
    let mut pow = vec![1.0; d * stride];
    for i in 0..d {
        let z = eta[i] / p.scale[i];
        for e in 1..stride {
            pow[i * stride + e] = pow[i * stride + e - 1] * z;
        }
    }
    for (k, e) in p.exps.iter().enumerate() {
        for j in 0..d {
            if e[j] == 0 {
                continue;
            }
            let mut g = e[j] as f64 * pow[j * stride + e[j] as usize - 1] / p.scale[j];
            for (i, &ei) in e.iter().enumerate() {
                if i != j {
                    g *= pow[i * stride + ei as usize];
                }
            }
            for out in 0..p.dim_out {
                jac[out * d + j] += p.coef[k * p.dim_out + out] * g;
            }
        }
    }
}

/// Jacobian of a discrete reduced map at `eta`.
pub fn map_jacobian(dynamics: &ReducedDynamics, eta: &[f64], jac: &mut [f64]) -> Result<(), &'static str> {
    match dynamics {
        ReducedDynamics::Rbf(m) => rbf_jacobian(m, eta, jac),
        ReducedDynamics::Map { increment, .. } => {
            poly_map_jacobian(increment, eta, jac);
            Ok(())
        }
        ReducedDynamics::Flow { .. } => Err("continuous flow: no map Jacobian"),
    }
}

/// Benettin result of a reduced map, in 1/s.
#[derive(Clone, Debug, Serialize)]
pub struct ModelLyapunov {
    /// Largest exponent, 1/s.
    pub exponent: f64,
    /// Its block standard error, 1/s.
    pub std_error: f64,
    /// All `d` exponents, 1/s, largest first.
    pub spectrum: Vec<f64>,
    pub kaplan_yorke: Option<f64>,
    pub transient: usize,
    pub steps: usize,
    /// Map step, s.
    pub dt: f64,
}

/// Benettin's method with the analytic tangent map and QR re-orthonormalization every step,
/// from `eta0` after `transient` steps, over `steps` steps (20 blocks). Escape (any
/// `|eta_i| > bound` or a non-finite state) and a hit on an RBF centre are errors with the
/// step number.
pub fn dynamics_lyapunov(
    dynamics: &ReducedDynamics,
    eta0: &[f64],
    bound: f64,
    transient: usize,
    steps: usize,
) -> Result<ModelLyapunov, ChaosTableError> {
    let dt = dynamics.map_dt().ok_or(ChaosTableError::NotAMap)?;
    let d = dim_of(dynamics);
    if eta0.len() != d {
        return Err(ChaosTableError::Shape { expected: d, got: eta0.len() });
    }
    let p = BenettinParams { transient, steps, time_step: dt, renorm_every: 1, bound, blocks: 20 };
    let mut scratch = StepScratch::default();
    let f = |x: &[f64], out: &mut [f64]| {
        out.copy_from_slice(x);
        dynamics.step(out, dt, &mut scratch);
    };
    let r = benettin_qr(eta0, f, |x, j| map_jacobian(dynamics, x, j), d, &p)?;
    Ok(ModelLyapunov {
        exponent: r.exponents[0],
        std_error: r.std_error[0],
        kaplan_yorke: r.kaplan_yorke,
        spectrum: r.exponents,
        transient,
        steps: r.steps,
        dt,
    })
}

/// [`dynamics_lyapunov`] for a fitted model, bounded by [`BLOWUP_FACTOR`] x the largest
/// training range of the reduced coordinates (the prediction's blow-up rule).
pub fn model_lyapunov(model: &SsmModel, eta0: &[f64], transient: usize, steps: usize) -> Result<ModelLyapunov, ChaosTableError> {
    dynamics_lyapunov(&model.dynamics, eta0, model_bound(model), transient, steps)
}

/// The escape bound used for a model: [`BLOWUP_FACTOR`] x max training |eta_i|.
pub fn model_bound(model: &SsmModel) -> f64 {
    BLOWUP_FACTOR * model.eta_range.iter().fold(0.0_f64, |m, v| m.max(*v))
}

/// Iterates a discrete reduced map `steps` times from `eta0` (recording every
/// `record_every`-th state, 0 = none); escape beyond `bound` is an error with the step.
pub fn iterate_dynamics(
    dynamics: &ReducedDynamics,
    eta0: &[f64],
    steps: usize,
    bound: f64,
    record_every: usize,
) -> Result<Orbit, ChaosTableError> {
    let dt = dynamics.map_dt().ok_or(ChaosTableError::NotAMap)?;
    let d = dim_of(dynamics);
    if eta0.len() != d {
        return Err(ChaosTableError::Shape { expected: d, got: eta0.len() });
    }
    let mut scratch = StepScratch::default();
    Ok(iterate_map(
        eta0,
        |x, out| {
            out.copy_from_slice(x);
            dynamics.step(out, dt, &mut scratch);
        },
        steps,
        bound,
        record_every,
    )?)
}

fn dim_of(dynamics: &ReducedDynamics) -> usize {
    match dynamics {
        ReducedDynamics::Rbf(m) => m.dim,
        ReducedDynamics::Map { increment, .. } => increment.dim_in,
        ReducedDynamics::Flow { field, .. } => field.dim_in,
    }
}

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
/// curve length 3 Theiler windows within 30..1000 samples, as in [`crate::chaoscmd::analyse`]),
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
    let p = DivergenceParams { max_reference: 2000, ..ctx.divergence_params() };
    let curves = kantz_curves(&pts, &eps, &p, 50)?;
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

fn fmt_opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("-".into(), |x| format!("{x:.prec$}"))
}

/// Report table of scale studies: header, rows (one per series and scale) and JSON.
pub fn scale_table(studies: &[ScaleStudy]) -> (Vec<String>, Vec<Vec<String>>, serde_json::Value) {
    let header = ["data", "eps", "eps / unit", "unit", "LLE Kantz [1/s]", "fit window [s]", "rise [nats]", "neighbours", "note"]
        .map(String::from)
        .to_vec();
    let mut rows = Vec::new();
    for s in studies {
        for r in &s.rows {
            rows.push(vec![
                s.name.clone(),
                format!("{:.3e}", r.eps),
                format!("{:.3}", r.eps_units),
                s.unit_name.clone(),
                fmt_opt(r.exponent, 3),
                r.window_s.map_or("-".into(), |(a, b)| format!("{a:.2}..{b:.2}")),
                fmt_opt(r.rise, 2),
                format!("{:.1}", r.mean_neighbours),
                r.note.clone(),
            ]);
        }
    }
    let json = serde_json::to_value(studies).unwrap_or(serde_json::Value::Null);
    (header, rows, json)
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
pub fn accuracy_vs_cost(name: &str, train: &[TimeSeries], o: &ChaosOptions, centres: &[usize], orders: &[u32]) -> Result<CostStudy, Box<dyn Error>> {
    let data = train.iter().max_by_key(|s| s.x.len()).ok_or("no training series")?;
    let dt = data.dt().ok_or("data series has no sampling step")?;
    let ctx = Context::from_series(&data.x, dt, o.gp_embed)?;
    let ssm_dim = match o.ssm_dim {
        Some(d) => d,
        None => ctx.ssm_dim_from_data(&data.x, o.gp_embed)?,
    };
    let mut notes = Vec::new();
    let (lle_data, _) = ctx.lle(&data.x, &mut notes, "data")?;
    let mut rows: Vec<CostRow> = Vec::new();
    let configs = centres.iter().map(|&c| ("rbf", c, Dynamics::Rbf { centers: c }, o.poly_order))
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
/// that leaves the training range is reset to `eta0`, so the loop times the same work).
fn time_steps(m: &SsmModel, eta0: &[f64]) -> f64 {
    let mut eta = eta0.to_vec();
    let mut s = StepScratch::default();
    let bound = model_bound(m);
    let t0 = Instant::now();
    for _ in 0..TIMED_STEPS {
        m.dynamics.step(&mut eta, m.dt, &mut s);
        if !eta.iter().all(|v| v.is_finite() && v.abs() <= bound) {
            eta.copy_from_slice(eta0);
        }
    }
    std::hint::black_box(&eta);
    t0.elapsed().as_secs_f64() * 1e6 / TIMED_STEPS as f64
}

/// Report table of an accuracy-vs-cost study: header, rows and JSON.
pub fn cost_table(study: &CostStudy) -> (Vec<String>, Vec<Vec<String>>, serde_json::Value) {
    let header = [
        "model",
        "centres / order",
        "LLE Rosenstein [1/s]",
        "|LLE model - LLE data|",
        "LLE Benettin [1/s]",
        "JS [bits]",
        "fit [s]",
        "step [us]",
        "fit ratio",
        "step ratio",
        "notes",
    ]
    .map(String::from)
    .to_vec();
    let rows = study
        .rows
        .iter()
        .map(|r| {
            vec![
                r.kind.clone(),
                r.setting.to_string(),
                fmt_opt(r.lle_rosenstein, 3),
                fmt_opt(r.lle_abs_error, 3),
                fmt_opt(r.lle_benettin, 3),
                fmt_opt(r.pdf_js, 3),
                format!("{:.3}", r.fit_s),
                format!("{:.2}", r.step_us),
                format!("{:.2}", r.fit_ratio),
                format!("{:.2}", r.step_ratio),
                r.notes.join("; "),
            ]
        })
        .collect();
    (header, rows, serde_json::to_value(study).unwrap_or(serde_json::Value::Null))
}

/// Prints a table as aligned text (the criterion-free bench print).
pub fn print_table(title: &str, header: &[String], rows: &[Vec<String>]) -> String {
    let mut w: Vec<usize> = header.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (i, c) in r.iter().enumerate() {
            if i < w.len() {
                w[i] = w[i].max(c.chars().count());
            }
        }
    }
    let line = |cells: &[String]| {
        cells.iter().enumerate().map(|(i, c)| format!("{c:<width$}", width = w.get(i).copied().unwrap_or(0))).collect::<Vec<_>>().join("  ")
    };
    let mut out = format!("{title}\n{}\n", line(header));
    for r in rows {
        out.push_str(&line(r));
        out.push('\n');
    }
    out
}

/// Encoder step of `furuta-quant-dt25` (2000 counts per revolution), rad.
pub const H_ADC: f64 = std::f64::consts::PI / 1000.0;

/// The two scale studies of the report: the simulated quantized loop (theta, `periods`
/// sampling periods, eps = 0.1..30 encoder steps) and, when present, the inverted flag
/// (traj_9, eps = 0.01..1 series sd); 8 log-spaced scales each, embedding dimension 6.
pub fn scale_studies(data_dir: &std::path::Path, periods: usize) -> Result<Vec<ScaleStudy>, Box<dyn Error>> {
    let mut out = Vec::new();
    let sim = crate::chaoscmd::simulate_quantized(periods, 0.02, "furuta-quant-dt25")?;
    let dt = sim.dt().ok_or("simulated series has no step")?;
    let eps = chaos::log_spaced(0.1, 30.0, 8)?;
    out.push(scale_dependence("simulated: furuta-quant-dt25 (theta)", &sim.x, dt, 6, "encoder step h = pi/1000 rad", H_ADC, &eps)?);
    let f = data_dir.join("inverted_flag_chaotic").join("traj_9.csv");
    if f.is_file() {
        let ts = crate::ssm::load_csv(&f)?;
        let dt = ts.dt().ok_or("flag series has no step")?;
        let n = ts.x.len() as f64;
        let m = ts.x.iter().sum::<f64>() / n;
        let sd = (ts.x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0)).sqrt();
        let eps = chaos::log_spaced(0.01, 1.0, 8)?;
        out.push(scale_dependence("measured: inverted flag traj_9", &ts.x, dt, 6, "series sd", sd, &eps)?);
    }
    Ok(out)
}

/// Report section with the scale table (for the lead to wire into the report).
pub fn scale_section(rep: &mut crate::report::Report, data_dir: &std::path::Path, quick: bool) -> Result<(), Box<dyn Error>> {
    rep.section(
        "chaos-scale",
        "Scale dependence of the time-series Lyapunov exponent",
        "Kantz's estimator (embedding dimension 6, lag = first zero of the autocorrelation, Theiler window = \
         dominant period, at most 2000 references with 50 neighbours each) at 8 log-spaced neighbourhood radii. \
         In a quantized loop, states closer than one quantization step receive the same control codes and \
         separate at the open-loop rate; the microchaotic rate appears only at scales of a few steps and above.",
    );
    let studies = scale_studies(data_dir, if quick { 6000 } else { 30000 })?;
    let (h, rows, json) = scale_table(&studies);
    let hr: Vec<&str> = h.iter().map(String::as_str).collect();
    rep.table(&hr, &rows);
    rep.summary.insert("chaos_scale".into(), json);
    Ok(())
}

/// The inverted-flag accuracy-vs-cost study of the report: RBF centres 50, 100, 200, 500
/// and polynomial orders 2..5 (6D SSM, default options otherwise), trained on traj_9 + traj_7.
pub fn flag_cost_study(data_dir: &std::path::Path) -> Result<Option<CostStudy>, Box<dyn Error>> {
    let d = data_dir.join("inverted_flag_chaotic");
    if !d.join("traj_9.csv").is_file() {
        return Ok(None);
    }
    let train = vec![crate::ssm::load_csv(d.join("traj_9.csv"))?, crate::ssm::load_csv(d.join("traj_7.csv"))?];
    let o = ChaosOptions { ssm_dim: Some(6), ..Default::default() };
    Ok(Some(accuracy_vs_cost("inverted flag (traj_9 + traj_7)", &train, &o, &[50, 100, 200, 500], &[2, 3, 4, 5])?))
}

/// Report section with the accuracy-vs-cost table (for the lead to wire into the report).
pub fn cost_section(rep: &mut crate::report::Report, data_dir: &std::path::Path) -> Result<(), Box<dyn Error>> {
    rep.section(
        "chaos-cost",
        "Model accuracy against cost (inverted flag)",
        "6D SSM models: |LLE model - LLE data| with the same Rosenstein settings on both series, the map's own \
         Benettin exponent, mean Jensen-Shannon divergence of the reduced-coordinate PDFs, wall time of the fit \
         and per reduced-map step (this machine, single run), and the time ratios to the smallest configuration.",
    );
    match flag_cost_study(data_dir)? {
        None => rep.para("Inverted-flag data not found: skipped."),
        Some(st) => {
            let (h, rows, json) = cost_table(&st);
            let hr: Vec<&str> = h.iter().map(String::as_str).collect();
            rep.para(&format!("Data exponent (Rosenstein): {:.3} 1/s.", st.lle_data));
            rep.table(&hr, &rows);
            rep.summary.insert("chaos_cost".into(), json);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
