//! `ssmctl fit` / `inspect`: the fitting request from the command line and its JSON summary.

use ssm::{Dynamics, FitOptions, Ridge, SsmModel, TimeSeries, fit, load_csv_column};
use serde::Serialize;
use serde_json::{Value, json};
use std::path::PathBuf;
use std::time::Instant;

/// What `ssmctl fit` was asked.
pub struct FitRequest {
    pub data: Vec<PathBuf>,
    pub test: Vec<PathBuf>,
    pub dim: usize,
    pub embed: usize,
    pub shift: usize,
    pub order: u32,
    pub dyn_order: u32,
    pub dynamics: String,
    pub centers: usize,
    pub ridge: String,
    /// Observable column of wider CSV files (see [`ssm::load_csv_column`]).
    pub column: Option<String>,
    /// See [`FitOptions::linear_anchor`].
    pub linear_anchor: Option<f64>,
    pub normal_form: bool,
}

#[derive(Debug, Serialize)]
pub struct Eigenvalue {
    pub re: f64,
    pub im: f64,
}

/// The JSON `ssmctl fit --json` prints.
#[derive(Debug, Serialize)]
pub struct FitSummary {
    /// Eigenvalues of the linear part, continuous time (1/s).
    pub eigenvalues: Vec<Eigenvalue>,
    pub normal_form: Option<Value>,
    /// Mean NMTE over the training trajectories (prediction from each one's first point).
    pub nmte_train: f64,
    /// Mean NMTE over the test trajectories (null without --test).
    pub nmte_test: Option<f64>,
    pub nmte_dtw_test: Option<f64>,
    pub fit_seconds: f64,
    pub manifold_condition: Option<f64>,
    pub dynamics_condition: f64,
    /// Predictions that stopped early (blow-up), with the reason.
    pub stopped: Vec<String>,
}

pub struct FitResult {
    pub model: SsmModel,
    pub summary: FitSummary,
}

fn parse_dynamics(s: &str, centers: usize) -> Result<Dynamics, String> {
    match s {
        "flow" => Ok(Dynamics::Flow),
        "map" => Ok(Dynamics::Map),
        "rbf" => Ok(Dynamics::Rbf { centers }),
        _ => Err(format!("--dynamics `{s}`: expected flow, map or rbf")),
    }
}

fn parse_ridge(s: &str) -> Result<Ridge, String> {
    if s == "cv" {
        return Ok(Ridge::CrossValidated);
    }
    match s.parse::<f64>() {
        Ok(a) if a.is_finite() && a >= 0.0 => Ok(Ridge::Fixed(a)),
        _ => Err(format!("--ridge `{s}`: expected a number >= 0 or `cv`")),
    }
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// Loads, fits and scores.
pub fn run_fit(r: &FitRequest) -> Result<FitResult, Box<dyn std::error::Error>> {
    let load = |ps: &[PathBuf]| ps.iter().map(|p| load_csv_column(p, r.column.as_deref())).collect::<Result<Vec<TimeSeries>, _>>();
    let train = load(&r.data)?;
    let test = load(&r.test)?;
    let opts = FitOptions {
        dim: r.dim,
        embed: r.embed,
        shift: r.shift,
        manifold_order: r.order,
        dyn_order: r.dyn_order,
        dynamics: parse_dynamics(&r.dynamics, r.centers)?,
        ridge: parse_ridge(&r.ridge)?,
        linear_anchor: r.linear_anchor,
    };
    let t0 = Instant::now();
    let model = fit(&train, &opts)?;
    let fit_seconds = t0.elapsed().as_secs_f64();
    let mut stopped = Vec::new();
    let mut score = |set: &[TimeSeries], dtw: bool| -> Result<(Vec<f64>, Vec<f64>), Box<dyn std::error::Error>> {
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for ts in set {
            let p = model.predict(ts)?;
            if let Some(s) = &p.stop {
                stopped.push(format!("{}: stopped at t = {} s: {:?}", ts.name, s.t, s.reason));
            }
            // A stopped prediction's NMTE is infinite by convention (reported in `stopped`);
            // any other non-finite metric is a number that cannot be trusted: an error.
            let finite = |what: &str, v: f64| -> Result<f64, Box<dyn std::error::Error>> {
                if v.is_finite() || p.stop.is_some() {
                    Ok(v)
                } else {
                    Err(format!("{}: the {what} of the prediction is not a finite number ({v}); the data or the model cannot be scored", ts.name).into())
                }
            };
            a.push(finite("NMTE", p.nmte(ts))?);
            if dtw {
                b.push(finite("DTW-aligned NMTE", p.nmte_dtw(ts, None))?);
            }
        }
        Ok((a, b))
    };
    let (tr, _) = score(&train, false)?;
    let (te, te_dtw) = score(&test, true)?;
    let summary = FitSummary {
        eigenvalues: model.eigenvalues_ct().iter().map(|&(re, im)| Eigenvalue { re, im }).collect(),
        normal_form: if r.normal_form {
            let nf = ssm::normal_form::model_normal_form(&model, &Default::default())?;
            Some(serde_json::to_value(nf.table())?)
        } else {
            None
        },
        nmte_train: mean(&tr),
        nmte_test: (!te.is_empty()).then(|| mean(&te)),
        nmte_dtw_test: (!te_dtw.is_empty()).then(|| mean(&te_dtw)),
        fit_seconds,
        manifold_condition: model.manifold.conditioning.map(|c| c.cond),
        dynamics_condition: model.dynamics.conditioning().cond,
        stopped,
    };
    Ok(FitResult { model, summary })
}

/// A human-readable summary.
pub fn text_summary(s: &FitSummary) -> String {
    let mut out = String::from("eigenvalues (continuous time, 1/s):\n");
    for e in &s.eigenvalues {
        out.push_str(&format!("  {:+.6} {:+.6}i  ({:.4} Hz)\n", e.re, e.im, e.im.abs() / (2.0 * std::f64::consts::PI)));
    }
    out.push_str(&format!("nmte_train {:.5}\n", s.nmte_train));
    if let Some(t) = s.nmte_test {
        out.push_str(&format!("nmte_test  {t:.5} (after DTW {:.5})\n", s.nmte_dtw_test.unwrap_or(f64::NAN)));
    }
    out.push_str(&format!("fit_seconds {:.4}", s.fit_seconds));
    for st in &s.stopped {
        out.push_str(&format!("\nwarning: {st}"));
    }
    out
}

/// Capacities of the host's blob decoder (`inspect`, and `export`'s round trip):
/// `p`, `d`, RBF centres, lift monomials.
pub type HostModel = shared::model::Model<256, { ssm::limits::MAX_DIM }, 8192, 4096>;

/// Largest blob file `inspect` reads: header plus the largest payload [`HostModel`] holds,
/// with room to spare (the decoder then names what is wrong).
pub const MAX_BLOB_BYTES: u64 = 16 * 1024 * 1024;

/// Why a blob is refused: its format, or its controller configuration.
#[derive(Debug, thiserror::Error)]
pub enum BlobError {
    #[error(transparent)]
    Decode(#[from] shared::model::DecodeError),
    #[error(transparent)]
    Config(#[from] controller::ConfigError),
}

/// Header and shapes of a device blob, after a full decode (so every check runs) and the
/// validation of its controller configuration: the same check a scene's configuration
/// passes ([`controller::validate_config`] for the project's history capacity).
pub fn inspect(bytes: &[u8]) -> Result<Value, BlobError> {
    let (h, _) = shared::model::Header::parse(bytes)?;
    let mut m = Box::new(HostModel::empty());
    m.decode_into(bytes)?;
    controller::validate_config::<{ controller::HISTORY }>(m.config())?;
    let c = m.config();
    Ok(json!({
        "format_version": h.version,
        "bytes": bytes.len(),
        "payload_bytes": h.payload_len,
        "crc32": format!("{:#010x}", h.crc),
        "p": m.p(), "d": m.d(), "shift": m.shift(), "sample_period_s": m.sample_period(),
        "offset": m.offset(), "scale": m.scale(),
        "lift_order": m.lift_order(), "lift_terms": m.lift_terms(), "centres": m.k(),
        "controller": {"kp": c.kp, "kd": c.kd, "kphi_d": c.kphi_d, "ki": c.ki, "dt": c.dt, "delay": c.delay,
                        "u_max": c.u_max, "quantized": c.quant.is_some()},
    }))
}
