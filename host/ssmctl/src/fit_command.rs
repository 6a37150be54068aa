//! `ssmctl fit` / `backbone` / `frc` / `inspect`: the fitting request from the command line
//! (CSV or SSMLearn `.mat` trajectories of one or several observables, time windows, backbone
//! curves), its JSON summary, and forced response curves of a saved model.

use serde::Serialize;
use serde_json::{Value, json};
use ssm::auto::{AutoOptions, BackboneBand, IntervalOptions, Setting};
use ssm::backbone::{Backbone, BackboneOptions, backbone};
use ssm::{
    Dynamics, FitOptions, MultiSeries, Ridge, SsmModel, fit_multi, load_csv_column, load_csv_observables, load_mat,
};
use std::error::Error;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What `ssmctl fit` was asked.
pub struct FitRequest {
    /// Training files: CSV, or `.mat` (all trajectories of `mat_var`).
    pub data: Vec<PathBuf>,
    /// Test files, likewise.
    pub test: Vec<PathBuf>,
    /// A `.mat` file split into training and test trajectories by `test_rows`.
    pub mat: Option<PathBuf>,
    /// The cell-array variable of `.mat` files (SSMLearn's `xData`).
    pub mat_var: String,
    /// 1-based rows of `mat` held out for testing (SSMLearn's `indTest`).
    pub test_rows: Vec<usize>,
    /// Observables: CSV column names or `.mat` rows of X (`1`, `2`, ...); `all` for every
    /// one; `None`: one observable (CSV: two columns or `column`; `.mat`: all rows).
    pub observables: Option<Vec<String>>,
    /// Time windows (`--from`, `--to`): one value for every trajectory or one per
    /// trajectory (training, then test); `None` entries leave that side open.
    pub from: Vec<Option<f64>>,
    pub to: Vec<Option<f64>>,
    /// Backbone curves (polynomial dynamics).
    pub backbone: Option<BackboneRequest>,
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
    /// See [`FitOptions::anchor_joint`].
    pub anchor_joint: bool,
    pub normal_form: bool,
    /// `--auto`: the settings above (but `dynamics`) chosen by cross-validation.
    pub auto: Option<AutoRequest>,
    /// `--intervals`: bootstrap intervals of the eigenvalues and the backbone.
    pub intervals: Option<IntervalRequest>,
}

/// `--auto` and its options.
pub struct AutoRequest {
    /// Most settings scored (`--budget`).
    pub budget: usize,
    /// A fixed SSM dimension (`--dim` with `--auto`); `None`: from the singular values.
    pub dim: Option<usize>,
}

/// `--intervals` and its options.
pub struct IntervalRequest {
    /// Bootstrap replicates (`--replicates`).
    pub replicates: usize,
    /// Resampling seed (`--seed`).
    pub seed: u64,
}

/// `--backbone DIR` and its options.
pub struct BackboneRequest {
    /// Writes DIR/backbone.json and DIR/backbone.png.
    pub out: Option<PathBuf>,
    /// Observable name (default: the first).
    pub observable: Option<String>,
    /// Largest amplitude (default: the largest |observable| of the training data).
    pub amplitude: Option<f64>,
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
    /// Names of the observables (NMTE is over all of them).
    pub observables: Vec<String>,
    /// Numbers of training and test trajectories.
    pub trajectories: [usize; 2],
    /// Backbone curves (with `--backbone`): `[{"mode", "observable", "points": [{"amplitude",
    /// "freq_rad_s", "damping_ratio", "rate", "rho"}, ...]}, ...]`; with `--intervals` each
    /// curve also has `"band": {"amplitude": [...], "freq_rad_s": [{estimate, lo, hi}, ...],
    /// "damping_ratio": [...]}`.
    pub backbone: Option<Value>,
    /// With `--auto`: the chosen settings, the runner-up and why (see [`ssm::auto::AutoChoice`]),
    /// and the seconds the search took.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub auto: Option<Value>,
    /// With `--intervals`: bootstrap intervals (see [`ssm::auto::Intervals`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub intervals: Option<Value>,
}

pub struct FitResult {
    pub model: SsmModel,
    pub summary: FitSummary,
}

/// The `--dynamics` option's value (`flow`, `map`, `rbf`, `rbf:KERNEL`, ...) as the fit's
/// dynamics, an RBF map with `centers` centres; an error names the option and the value.
pub fn parse_dynamics(s: &str, centers: usize) -> Result<Dynamics, String> {
    match s {
        "flow" => Ok(Dynamics::Flow),
        "map" => Ok(Dynamics::Map),
        "rbf" => Ok(Dynamics::Rbf { centers }),
        _ => match s.strip_prefix("rbf:") {
            // `rbf:KERNEL`: linear (the default), cubic, thin-plate, gaussian:EPS.
            Some(k) => ssm::Kernel::parse(k)
                .map(|kernel| Dynamics::RbfWith { centers, kernel })
                .map_err(|e| format!("--dynamics `{s}`: {e}")),
            None => Err(format!(
                "--dynamics `{s}`: expected flow, map or rbf (or rbf:KERNEL, KERNEL: linear, cubic, thin-plate, gaussian:EPS)"
            )),
        },
    }
}

pub(crate) fn parse_ridge(s: &str) -> Result<Ridge, String> {
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

fn is_mat(p: &Path) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case("mat"))
}

/// The trajectories of one file (see [`FitRequest::observables`]).
fn load_file(r: &FitRequest, path: &Path) -> Result<Vec<MultiSeries>, Box<dyn Error>> {
    let all = |o: &[String]| o.len() == 1 && o[0] == "all";
    if is_mat(path) {
        let trajs = load_mat(path, &r.mat_var)?;
        return match &r.observables {
            Some(o) if !all(o) => Ok(trajs.iter().map(|t| t.select(o)).collect::<Result<_, _>>()?),
            _ => Ok(trajs),
        };
    }
    Ok(vec![match &r.observables {
        None => MultiSeries::from(&load_csv_column(path, r.column.as_deref())?),
        Some(o) if all(o) => load_csv_observables(path, None)?,
        Some(o) => load_csv_observables(path, Some(o))?,
    }])
}

/// Training and test trajectories, windows applied.
pub fn load_sets(r: &FitRequest) -> Result<(Vec<MultiSeries>, Vec<MultiSeries>), Box<dyn Error>> {
    let mut train = Vec::new();
    let mut test = Vec::new();
    for p in &r.data {
        train.extend(load_file(r, p)?);
    }
    for p in &r.test {
        test.extend(load_file(r, p)?);
    }
    if let Some(path) = &r.mat {
        let trajs = load_file(r, path)?;
        if let Some(bad) = r.test_rows.iter().find(|&&k| k == 0 || k > trajs.len()) {
            return Err(format!(
                "--test-rows {bad}: {} has {} trajectories (rows 1..={})",
                path.display(),
                trajs.len(),
                trajs.len()
            )
            .into());
        }
        for (i, t) in trajs.into_iter().enumerate() {
            if r.test_rows.contains(&(i + 1)) { test.push(t) } else { train.push(t) }
        }
    } else if !r.test_rows.is_empty() {
        return Err("--test-rows needs --mat".into());
    }
    let n = train.len() + test.len();
    let bounds = |v: &[Option<f64>], flag: &str| -> Result<Vec<Option<f64>>, String> {
        match v.len() {
            0 => Ok(vec![None; n]),
            1 => Ok(vec![v[0]; n]),
            k if k == n => Ok(v.to_vec()),
            k => Err(format!(
                "{flag}: {k} values for {n} trajectories (training, then test); give one for all, or one per trajectory"
            )),
        }
    };
    let (from, to) = (bounds(&r.from, "--from")?, bounds(&r.to, "--to")?);
    for (k, t) in train.iter_mut().chain(test.iter_mut()).enumerate() {
        if from[k].is_some() || to[k].is_some() {
            *t = t.window(from[k], to[k])?;
        }
    }
    Ok((train, test))
}

/// The observable index and the curve options of a backbone request; `train` gives the
/// observable names and the default largest amplitude.
pub fn backbone_options(
    train: &[MultiSeries],
    b: &BackboneRequest,
) -> Result<(String, BackboneOptions), Box<dyn Error>> {
    let names = &train.first().ok_or("no training data")?.observables;
    let index = match &b.observable {
        None => 0,
        Some(o) => names
            .iter()
            .position(|n| n == o)
            .ok_or_else(|| format!("--backbone-observable {o}: observables are {}", names.join(", ")))?,
    };
    let amplitude = match b.amplitude {
        Some(a) => a,
        None => {
            train.iter().flat_map(|t| t.x.iter().skip(index).step_by(t.dim())).fold(0.0, |m: f64, v| m.max(v.abs()))
        }
    };
    Ok((names[index].clone(), BackboneOptions::new(index, amplitude)))
}

/// Backbone curves of `model` as asked, with the bootstrap `bands` (possibly none); `train`
/// gives the observable names and the default largest amplitude.
pub fn run_backbone(
    model: &SsmModel,
    train: &[MultiSeries],
    b: &BackboneRequest,
    bands: &[BackboneBand],
) -> Result<(Vec<Backbone>, Value), Box<dyn Error>> {
    let (name, opts) = backbone_options(train, b)?;
    let curves = backbone(model, &opts)?;
    let json = backbone_json(&curves, &name, bands);
    if let Some(dir) = &b.out {
        write_backbone(dir, &curves, &json, &name, bands)?;
    }
    Ok((curves, json))
}

/// The curves as JSON, the observable named; a curve with a band of the same mode gets it
/// as `"band"`.
pub fn backbone_json(curves: &[Backbone], observable: &str, bands: &[BackboneBand]) -> Value {
    Value::Array(
        curves
            .iter()
            .map(|b| {
                let mut v = json!({"mode": b.mode, "observable": observable, "points": serde_json::to_value(&b.points).unwrap_or(Value::Null)});
                if let Some(band) = bands.iter().find(|x| x.mode == b.mode) {
                    v["band"] = json!({
                        "amplitude": band.amplitude,
                        "freq_rad_s": serde_json::to_value(&band.freq_rad_s).unwrap_or(Value::Null),
                        "damping_ratio": serde_json::to_value(&band.damping_ratio).unwrap_or(Value::Null),
                    });
                }
                v
            })
            .collect(),
    )
}

/// Writes DIR/backbone.json and DIR/backbone.png (with the bands, if any).
pub fn write_backbone(
    dir: &Path,
    curves: &[Backbone],
    json: &Value,
    observable: &str,
    bands: &[BackboneBand],
) -> Result<(), Box<dyn Error>> {
    crate::output::create_dir(dir)?;
    crate::output::write_atomic(&dir.join("backbone.json"), serde_json::to_string_pretty(json)?.as_bytes())?;
    crate::draw::backbone::backbone_figure(
        &dir.join("backbone.png"),
        "backbone",
        curves,
        &format!("amplitude of {observable}"),
        bands,
    )?;
    Ok(())
}

/// `--freq-range A:B[:N]`: forcing frequencies in rad/s, `0 < A < B`, N points (default 400).
pub fn parse_freq_range(s: &str) -> Result<(f64, f64, usize), String> {
    let parts: Vec<&str> = s.split(':').collect();
    let num = |x: &str| {
        x.trim()
            .parse::<f64>()
            .map_err(|_| format!("--freq-range `{s}`: `{x}` is not a number (expected A:B or A:B:N, rad/s)"))
    };
    let (a, b, n) = match parts.as_slice() {
        [a, b] => (num(a)?, num(b)?, 400),
        [a, b, n] => (
            num(a)?,
            num(b)?,
            n.trim().parse::<usize>().map_err(|_| format!("--freq-range `{s}`: N = `{n}` is not a count"))?,
        ),
        _ => return Err(format!("--freq-range `{s}`: expected A:B or A:B:N (forcing frequencies in rad/s)")),
    };
    if !(a > 0.0 && a.is_finite() && b.is_finite()) {
        return Err(format!("--freq-range `{s}`: forcing frequencies must be > 0 rad/s"));
    }
    if b <= a {
        return Err(format!("--freq-range `{s}`: the upper end must exceed the lower end"));
    }
    if !(2..=ssm::frc::MAX_FRC_POINTS).contains(&n) {
        return Err(format!("--freq-range `{s}`: N = {n} points; need 2 ..= {}", ssm::frc::MAX_FRC_POINTS));
    }
    Ok((a, b, n))
}

/// `--calibrate FREQ,AMP`: a measured steady state (rad/s, observable units).
pub fn parse_calibration(s: &str) -> Result<ssm::frc::Calibration, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("--calibrate `{s}`: expected FREQ,AMP (two numbers)"))?;
    match v.as_slice() {
        [f, a] => Ok(ssm::frc::Calibration { freq_rad_s: *f, amplitude: *a }),
        _ => Err(format!("--calibrate `{s}`: expected FREQ,AMP (forcing frequency in rad/s, steady-state amplitude)")),
    }
}

/// The forced response of `model` as JSON (`ssm::frc::Frc` with the observable named):
/// `{"mode", "observable", "calibration": {"freq_rad_s", "amplitude", "rho", "forcing"},
/// "amplitude_max", "rho_max", "branches": [{"stable", "freq_rad_s": [...], "amplitude":
/// [...], "rho": [...]}, ...]}`.
pub fn frc_json(frc: &ssm::frc::Frc, observable: &str) -> Result<Value, serde_json::Error> {
    let mut v = serde_json::to_value(frc)?;
    v["observable"] = json!(observable);
    Ok(v)
}

/// Writes DIR/frc.json and DIR/frc.png (with the forced mode's backbone when it is computable).
pub fn write_frc(dir: &Path, model: &SsmModel, frc: &ssm::frc::Frc, observable: &str) -> Result<(), Box<dyn Error>> {
    crate::output::create_dir(dir)?;
    let json = frc_json(frc, observable)?;
    crate::output::write_atomic(&dir.join("frc.json"), serde_json::to_string_pretty(&json)?.as_bytes())?;
    let bb = backbone(model, &BackboneOptions::new(frc.observable, frc.amplitude_max)).ok();
    let mode_bb = bb.as_ref().and_then(|c| c.iter().find(|b| b.mode == frc.mode));
    crate::draw::frc::frc_figure(
        &dir.join("frc.png"),
        "forced response",
        frc,
        mode_bb,
        &format!("amplitude of {observable}"),
    )?;
    Ok(())
}

/// One line per branch: stability, frequency span, amplitude span.
pub fn frc_text(frc: &ssm::frc::Frc) -> String {
    let c = frc.calibration;
    let mut out = format!(
        "calibration: {:.4} rad/s, amplitude {:.5} -> normal-form forcing {:.5e} (rho {:.5}); model range up to amplitude {:.5}\n",
        c.freq_rad_s, c.amplitude, c.forcing, c.rho, frc.amplitude_max
    );
    for b in &frc.branches {
        let span = |v: &[f64]| {
            (v.iter().copied().fold(f64::INFINITY, f64::min), v.iter().copied().fold(f64::NEG_INFINITY, f64::max))
        };
        let ((f0, f1), (a0, a1)) = (span(&b.freq_rad_s), span(&b.amplitude));
        out.push_str(&format!(
            "{:<8} {:>4} points: frequency {f0:.4} .. {f1:.4} rad/s, amplitude {a0:.5} .. {a1:.5}\n",
            if b.stable { "stable" } else { "unstable" },
            b.freq_rad_s.len()
        ));
    }
    out
}

/// Loads, fits and scores; with `auto`, chooses the settings first; with `intervals`,
/// bootstraps them.
pub fn run_fit(r: &FitRequest) -> Result<FitResult, Box<dyn std::error::Error>> {
    let (raw, test) = load_sets(r)?;
    let dynamics = parse_dynamics(&r.dynamics, r.centers)?;
    let (setting, auto) = match &r.auto {
        Some(a) => {
            let t0 = Instant::now();
            let o = AutoOptions { dynamics, dim: a.dim, budget: a.budget, ..Default::default() };
            let choice = ssm::auto::select(&raw, &o)?;
            let seconds = t0.elapsed().as_secs_f64();
            let setting = choice.best.setting;
            (setting, Some(json!({"seconds": seconds, "choice": serde_json::to_value(&choice)?})))
        }
        None => (
            Setting {
                cut: 0.0,
                options: FitOptions {
                    dim: r.dim,
                    embed: r.embed,
                    shift: r.shift,
                    manifold_order: r.order,
                    dyn_order: r.dyn_order,
                    dynamics,
                    ridge: parse_ridge(&r.ridge)?,
                    linear_anchor: r.linear_anchor,
                    anchor_joint: r.anchor_joint,
                },
            },
            None,
        ),
    };
    let opts = setting.options;
    let train = ssm::auto::cut(&raw, setting.cut);
    let bb_opts = r.backbone.as_ref().map(|b| backbone_options(&train, b)).transpose()?;
    let intervals = match &r.intervals {
        Some(i) => {
            let o = IntervalOptions {
                replicates: i.replicates,
                seed: i.seed,
                backbone: bb_opts.as_ref().map(|(_, o)| (*o, 41)),
                ..Default::default()
            };
            let t0 = Instant::now();
            let iv = ssm::auto::intervals(&raw, &setting, &o)?;
            Some((iv, t0.elapsed().as_secs_f64()))
        }
        None => None,
    };
    let t0 = Instant::now();
    let model = fit_multi(&train, &opts).map_err(|e| -> Box<dyn Error> {
        match e {
            // The decomposition is of all training data at once: name them.
            ssm::FitError::Svd { .. } => {
                let names: Vec<&str> = train.iter().map(|t| t.name.as_str()).collect();
                format!("{}: {e}", names.join(", ")).into()
            }
            e => e.into(),
        }
    })?;
    let fit_seconds = t0.elapsed().as_secs_f64();
    let mut stopped = Vec::new();
    let mut score = |set: &[MultiSeries], dtw: bool| -> Result<(Vec<f64>, Vec<f64>), Box<dyn std::error::Error>> {
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for ts in set {
            let p = model.predict_multi(ts)?;
            if let Some(s) = &p.stop {
                stopped.push(format!("{}: stopped at t = {} s: {}", ts.name, s.t, s.reason));
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
            a.push(finite("NMTE", p.nmte_multi(ts))?);
            if dtw {
                b.push(finite("DTW-aligned NMTE", p.nmte_dtw_multi(ts, None))?);
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
        observables: train[0].observables.clone(),
        trajectories: [train.len(), test.len()],
        backbone: match &r.backbone {
            Some(b) => {
                let bands = intervals.as_ref().map_or(&[][..], |(iv, _)| &iv.backbone[..]);
                Some(run_backbone(&model, &train, b, bands)?.1)
            }
            None => None,
        },
        auto,
        intervals: match &intervals {
            Some((iv, secs)) => {
                let mut v = serde_json::to_value(iv)?;
                v["seconds"] = json!(secs);
                // The bands are in `backbone` (each curve's `band`).
                if let Some(o) = v.as_object_mut() {
                    o.remove("backbone");
                }
                Some(v)
            }
            None => None,
        },
    };
    Ok(FitResult { model, summary })
}

/// A human-readable summary.
pub fn text_summary(s: &FitSummary) -> String {
    let mut out = String::new();
    if let Some(a) = &s.auto {
        let c = &a["choice"];
        let describe = |v: &Value| -> String {
            serde_json::from_value::<Setting>(v["setting"].clone()).map_or_else(|_| "?".into(), |x| x.describe())
        };
        out.push_str(&format!(
            "auto: chose {}\n  ({} settings scored in {:.2} s, {}{})\n",
            describe(&c["best"]),
            c["evaluated"],
            a["seconds"].as_f64().unwrap_or(f64::NAN),
            c["folds"].as_str().unwrap_or("?"),
            if c["budget_exhausted"].as_bool() == Some(true) { "; the budget stopped the search" } else { "" }
        ));
        if !c["runner_up"].is_null() {
            out.push_str(&format!("  runner-up: {}\n", describe(&c["runner_up"])));
        }
        for line in c["reasons"].as_array().map(Vec::as_slice).unwrap_or_default() {
            out.push_str(&format!("  why: {}\n", line.as_str().unwrap_or("?")));
        }
    }
    out.push_str("eigenvalues (continuous time, 1/s):\n");
    let ivs = s.intervals.as_ref().and_then(|v| v["eigenvalues"].as_array());
    for e in &s.eigenvalues {
        out.push_str(&format!("  {:+.6} {:+.6}i  ({:.4} Hz)\n", e.re, e.im, e.im.abs() / (2.0 * std::f64::consts::PI)));
        // The intervals list the eigenvalues sorted by decreasing imaginary part: the nearest.
        let dist = |x: &Value| {
            let g = |k: &str| x[k]["estimate"].as_f64().unwrap_or(f64::INFINITY);
            (g("re") - e.re).hypot(g("im") - e.im)
        };
        let iv = ivs.and_then(|v| v.iter().min_by(|a, b| dist(a).total_cmp(&dist(b))));
        if let Some(iv) = iv {
            let f = |k: &str, b: &str| iv[k][b].as_f64().unwrap_or(f64::NAN);
            out.push_str(&format!(
                "    95 %: re [{:+.6}, {:+.6}], im [{:+.6}, {:+.6}], damping ratio {:.5} [{:.5}, {:.5}]\n",
                f("re", "lo"),
                f("re", "hi"),
                f("im", "lo"),
                f("im", "hi"),
                f("damping_ratio", "estimate"),
                f("damping_ratio", "lo"),
                f("damping_ratio", "hi")
            ));
        }
    }
    if let Some(iv) = &s.intervals {
        out.push_str(&format!(
            "intervals: bootstrap over {}, {} replicates ({} failed, {} backbones failed), {:.2} s\n",
            iv["method"].as_str().unwrap_or("?"),
            iv["replicates"],
            iv["failed"],
            iv["backbone_failed"],
            iv["seconds"].as_f64().unwrap_or(f64::NAN)
        ));
    }
    out.push_str(&format!("nmte_train {:.5}\n", s.nmte_train));
    if let Some(t) = s.nmte_test {
        out.push_str(&format!("nmte_test  {t:.5} (after DTW {:.5})\n", s.nmte_dtw_test.unwrap_or(f64::NAN)));
    }
    if s.observables.len() > 1 {
        out.push_str(&format!("observables {} (NMTE over all)\n", s.observables.join(", ")));
    }
    out.push_str(&format!("trajectories: {} training, {} test\n", s.trajectories[0], s.trajectories[1]));
    if let Some(Value::Array(curves)) = &s.backbone {
        for c in curves {
            let pts = c["points"].as_array().map(Vec::as_slice).unwrap_or_default();
            if let (Some(a), Some(b)) = (pts.first(), pts.last()) {
                let f = |p: &Value, k: &str| p[k].as_f64().unwrap_or(f64::NAN);
                out.push_str(&format!(
                    "backbone mode {} ({}): amplitude {:.4} -> {:.4}: frequency {:.4} -> {:.4} Hz, damping ratio {:.4} -> {:.4}\n",
                    c["mode"],
                    c["observable"].as_str().unwrap_or("?"),
                    f(a, "amplitude"),
                    f(b, "amplitude"),
                    f(a, "freq_rad_s") / std::f64::consts::TAU,
                    f(b, "freq_rad_s") / std::f64::consts::TAU,
                    f(a, "damping_ratio"),
                    f(b, "damping_ratio")
                ));
            }
        }
    }
    out.push_str(&format!("fit_seconds {:.4}", s.fit_seconds));
    for st in &s.stopped {
        out.push_str(&format!("\nwarning: {st}"));
    }
    out
}

pub use ssm::device::HostModel;

/// Largest blob file `inspect` reads: header plus the largest payload [`HostModel`] holds,
/// with room to spare (the decoder then names what is wrong).
pub const MAX_BLOB_BYTES: u64 = infile::MAX_BLOB_BYTES;

/// Why a blob is refused: its format, or its controller configuration.
#[derive(Debug, thiserror::Error)]
pub enum BlobError {
    #[error(transparent)]
    Decode(#[from] shared::model::DecodeError),
    #[error(transparent)]
    Config(#[from] controller::ConfigError),
    /// The host decoder's refusal ([`ssm::device::decode_host`]), or its thread's failure.
    #[error(transparent)]
    Host(#[from] ssm::device::HostDecodeError),
}

/// Header and shapes of a device blob, after a full decode (so every check runs) and the
/// validation of its controller configuration: the same check a scene's configuration
/// passes ([`controller::validate_config`] for the project's history capacity).
pub fn inspect(bytes: &[u8]) -> Result<Value, BlobError> {
    let (h, _) = shared::model::Header::parse(bytes)?;
    let m = ssm::device::decode_host(bytes)?;
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
        "controller": {
            "gains": c.gains.iter().map(|g| serde_json::json!({"index": g.index, "p": g.p, "d": g.d, "h_adc": g.h_adc}))
                .collect::<Vec<_>>(),
            // The shorthand's keys when the gains have its layout (null otherwise).
            "kp": c.as_shorthand().map(|s| s.0), "kd": c.as_shorthand().map(|s| s.1),
            "kphi_d": c.as_shorthand().map(|s| s.2),
            "ki": c.ki, "dt": c.dt, "delay": c.delay, "u_max": c.u_max, "quantized": c.quant.is_some()},
    }))
}
