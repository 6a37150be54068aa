//! Report section: what the parametric Furuta SSM model predicts at sampling periods it was
//! not trained on (paper section 3.1, fig. 4): trajectory predictions with NMTE, DTW-NMTE and
//! spectra, from a parametric model whose manifold and map coefficients are interpolated
//! in dt (linearly, and by a natural cubic spline for comparison).

use crate::draw::portrait::plot_portrait;
use crate::plot::{self, Series};
use crate::report::normal_form::PAPER_DTS;
use crate::report::prose::Prose;
use crate::report::tasks::task;
use crate::report::{Report, par_map};
use furuta::bifurcations::{
    ModelBifurcations, RHO_MAX, SensitivityRow, model_bifurcations, model_default_switch, model_row, row_from,
    sensitivity_variants,
};
use furuta::parametric::{FurutaOptions, ParametricModel, TrainingRuns, furuta_parametric_family};
use furuta::shared_tangent::{
    PredictOptions, PredictionResult, predictions_on, shared_parametric_from, test_series_all,
};
use plotters::style::RGBColor;
use serde_json::{Value, json};
use ssm::interp::Interp;
use ssm::portrait::{Fate, PointKind, PortraitOptions, fixed_points, portrait, trajectory};
use std::error::Error;

/// Start of the transient run near the 3-torus, (rho_1, rho_2) in rad.
const TRANSIENT_RHO: [f64; 2] = [0.02, 0.035];
/// The full system's torus across dt: the start (on the torus), the run's length in periods
/// and the tail (s) its mean and spread are measured over.
pub const TORUS_RHO: [f64; 2] = [0.095, 0.028];
pub const TORUS_PERIODS: u64 = 16_000;
pub const TORUS_TAIL_S: f64 = 125.0;

const BLACK: RGBColor = RGBColor(0, 0, 0);
const RED: RGBColor = RGBColor(200, 30, 30);

/// Trajectory and spectrum figures of one prediction; returns the two relative paths.
fn prediction_figures(rep: &Report, r: &PredictionResult) -> Result<(String, String), Box<dyn Error>> {
    let tag = format!("{}", r.dt_ms).replace('.', "p");
    let traj = format!("fig/prediction_dt{tag}.png");
    let spec = format!("fig/prediction_spectrum_dt{tag}.png");
    let tp: Vec<(f64, f64)> = r.t.iter().copied().zip(r.x_true.iter().copied()).collect();
    let pp: Vec<(f64, f64)> = r.t.iter().copied().zip(r.x_pred.iter().copied()).collect();
    plot::lines(
        &rep.dir().join(&traj),
        &format!("dt = {} ms: full system vs parametric SSM model", r.dt_ms),
        "t [s]",
        "theta [rad]",
        &[
            Series { name: "full system", points: &tp, color: BLACK },
            Series { name: "SSM model (interpolated)", points: &pp, color: RED },
        ],
        (760, 260),
    )?;
    let band = |s: &furuta::shared_tangent::Spectrum| -> Vec<(f64, f64)> {
        s.freq_hz.iter().copied().zip(s.amp.iter().copied()).filter(|p| p.0 <= 12.0).collect()
    };
    let (st, sp) = (band(&r.spectrum_true), band(&r.spectrum_pred));
    plot::lines(
        &rep.dir().join(&spec),
        &format!("dt = {} ms: amplitude spectra", r.dt_ms),
        "f [Hz]",
        "amplitude [rad]",
        &[
            Series { name: "full system", points: &st, color: BLACK },
            Series { name: "SSM model", points: &sp, color: RED },
        ],
        (520, 260),
    )?;
    Ok((traj, spec))
}

/// The predictions section's text over the summary (`predictions`, `predictions_spline`,
/// `page_predictions`).
const PRED_INTRO: &str = "All training periods are fitted in one tangent space (V1 from the pooled embedded data, plus a \
    linear normal part per period), so manifold and map coefficients can be interpolated in dt. Test runs of the full \
    system at dt = {{ page_predictions.setup.dts_ms | plain }} ms start on the slow eigenvector (theta amplitude \
    {{ page_predictions.setup.slow_theta | plain }} rad) plus a theta offset of {{ page_predictions.setup.theta0 | plain }} \
    rad and last {{ page_predictions.setup.horizon_s | plain }} s (cut at |theta| > {{ page_predictions.setup.max_theta \
    | plain }} rad); the model predicts from the first delay vector. NMTE as SSMLearn defines it; DTW-NMTE after dynamic \
    time warping (unconstrained band).";
const PRED_CELLS: [&str; 8] = [
    "{{ lin.dt_ms | plain }}",
    "{{ lin.nmte | num }}",
    "{{ lin.dtw_nmte | num }}",
    "{{ spl.nmte | num }}",
    "{{ spl.dtw_nmte | num }}",
    "{{ row.test_length_s | fixed(1) }}",
    "{% if row.test_cut_s is none %}-{% else %}|theta| > {{ max_theta | plain }} rad at t = {{ row.test_cut_s | fixed(2) }} \
     s{% endif %}",
    "{% if row.model_stop_s is none %}-{% else %}model left range at {{ row.model_stop_s | fixed(1) }} s{% endif %}",
];
const PRED_TRAJ: &str = "dt = {{ dt_ms | plain }} ms: test trajectory and the linearly interpolated model's prediction";
const PRED_SPEC: &str = "dt = {{ dt_ms | plain }} ms: FFT amplitude spectra over the compared samples";

/// Predictions at the paper's unseen sampling periods; `summary.json` key `predictions`
/// (linear interpolation, the paper's choice) and `predictions_spline`, and what the text
/// reads besides (`page_predictions`).
/// `runs`: the training runs of the parametric section (the same series, simulated once).
/// Returns the shared-tangent model it predicted with (the fitted map of the global sections).
pub fn predictions_section(
    rep: &mut Report,
    runs: &TrainingRuns,
) -> Result<furuta::shared_tangent::SharedParametricModel, Box<dyn Error>> {
    let po = PredictOptions::default();
    let model = task("predictions/shared-fit", || shared_parametric_from(&FurutaOptions::default(), runs))?;
    // The test runs once, read by both interpolations.
    let tests = task("predictions/test-runs", || test_series_all(&po))?;
    let (lin, spl) = rayon::join(
        || task("predictions/linear", || predictions_on(&model, &po, &tests, Interp::Linear)),
        || task("predictions/spline", || predictions_on(&model, &po, &tests, Interp::Spline)),
    );
    let (lin, spl) = (lin?, spl?);
    let mut rows = Vec::new();
    for (a, test) in lin.iter().zip(&tests) {
        let (traj, spec) = prediction_figures(rep, a)?;
        rows.push(json!({
            "test_length_s": a.t.last().copied().unwrap_or(0.0),
            "test_cut_s": a.test_cut.as_ref().map(|_| test.t.last().copied().unwrap_or(0.0)),
            "model_stop_s": a.stop.as_ref().map(|s| s.t),
            "figures": {"trajectory": traj, "spectrum": spec},
        }));
    }
    let list = |v: &[PredictionResult]| -> Value {
        Value::Array(v.iter().map(|r| json!({"dt_ms": r.dt_ms, "nmte": r.nmte, "dtw_nmte": r.dtw_nmte})).collect())
    };
    rep.summary.insert("predictions".into(), list(&lin));
    rep.summary.insert("predictions_spline".into(), list(&spl));
    rep.summary.insert(
        "page_predictions".into(),
        json!({"setup": {"dts_ms": po.dts_ms, "slow_theta": po.slow.0, "theta0": po.theta0, "horizon_s": po.horizon_s,
                         "max_theta": po.max_theta},
               "rows": rows}),
    );
    let sw = map_switch_values(rep, &model)?;
    rep.summary.insert("map_switch_dt_ms".into(), sw);
    predictions_render(rep, &Value::Object(rep.summary.clone()))?;
    Ok(model)
}

/// The value at `key` of the summary `s`, or an error naming it.
fn at<'a>(s: &'a Value, key: &str) -> Result<&'a Value, String> {
    s.get(key).filter(|v| !v.is_null()).ok_or_else(|| format!("report: summary lacks `{key}`"))
}

fn list<'a>(s: &'a Value, key: &str) -> Result<&'a Vec<Value>, String> {
    at(s, key)?.as_array().ok_or_else(|| format!("report: summary `{key}` is not a list"))
}

/// Writes the predictions section and the fitted map's switch from the summary `s`.
pub fn predictions_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    rep.section(
        "predictions",
        "Parametric model: trajectory predictions at unseen sampling periods",
        &p.html("predictions/intro", PRED_INTRO, s)?,
    );
    let (lin, spl, page) = (list(s, "predictions")?, list(s, "predictions_spline")?, at(s, "page_predictions")?);
    let prow = page["rows"].as_array().ok_or("report: page_predictions.rows is not a list")?;
    if lin.len() != spl.len() || lin.len() != prow.len() {
        return Err("report: predictions, predictions_spline and page_predictions.rows differ in length".into());
    }
    let items: Vec<Value> = lin
        .iter()
        .zip(spl)
        .zip(prow)
        .map(|((a, b), r)| json!({"lin": a, "spl": b, "row": r, "max_theta": page["setup"]["max_theta"]}))
        .collect();
    rep.table(
        &[
            "dt [ms]",
            "NMTE (linear)",
            "DTW-NMTE (linear)",
            "NMTE (spline)",
            "DTW-NMTE (spline)",
            "test length [s]",
            "test run cut",
            "model stop",
        ],
        &p.rows("predictions/row", &PRED_CELLS, &items)?,
    );
    let mut sorted: Vec<(&Value, &Value)> = lin.iter().zip(prow).collect();
    sorted.sort_by(|a, b| {
        a.0["dt_ms"].as_f64().unwrap_or(f64::NAN).total_cmp(&b.0["dt_ms"].as_f64().unwrap_or(f64::NAN))
    });
    for (r, row) in sorted {
        let fig = |k: &str| {
            row["figures"][k].as_str().map(str::to_string).ok_or(format!("report: page_predictions figure {k}"))
        };
        rep.figure(&fig("trajectory")?, &p.text("predictions/trajectory", PRED_TRAJ, r)?);
        rep.figure(&fig("spectrum")?, &p.text("predictions/spectrum", PRED_SPEC, r)?);
    }
    map_switch_render(rep, s)
}

/// Range and resolution of the fitted map's small-start switch scan [ms].
pub(crate) const MAP_SWITCH_RANGE_MS: (f64, f64, usize, f64) = (31.0, 32.0, 11, 0.005);

/// The fitted map's switch over the summary key `map_switch_dt_ms` (and `portraits`, where
/// the slow saddle cycle is).
const MAP_SWITCH: &str = "The global bifurcation read off the fitted map itself, without a normal form: the model above \
    (its maps interpolated in dt) is iterated from the full system's small mode-shaped starts (the first delay vector \
    from the full system, then the map) for {{ m.periods }} periods, escape when |theta| exceeds {{ m.escape_theta | plain \
    }} rad, on a grid of {{ m.grid_n }} values of dt over [{{ m.range_ms[0] | plain }}, {{ m.range_ms[1] | plain }}] ms, \
    then bisected to {{ m.tol_ms | plain }} ms.{% if m.slow_saddle_rho1 is not none %} The polar normal form is a Taylor \
    series truncated about the origin, while its slow saddle cycle lies at rho_1 = {{ m.slow_saddle_rho1[0] | fixed(2) }}-{{ \
    m.slow_saddle_rho1[1] | fixed(2) }} rad at the paper's periods (portraits above); the map is iterated as it was fitted, \
    with no such expansion.{% endif %}";
const MAP_SWITCH_CELLS: [&str; 5] = [
    "{{ name }}",
    "{% if sw.bracket is none %}none{% else %}[{{ sw.bracket[0] | fixed(4) }}, {{ sw.bracket[1] | fixed(4) }}]{% endif %}",
    "{% for g in sw.grid %}{{ g[1] }}{% if not loop.last %} {% endif %}{% endfor %}",
    "{% if sw.monotone %}yes{% else %}no{% endif %}",
    "{{ sw.evaluations }}",
];

/// The global bifurcation read off the fitted map itself (no normal form): the same small,
/// mode-shaped starts as the full system's scan (`full_system::default_ics`), the same horizon
/// and escape rule, iterated on the shared-tangent model's map at each dt; grid, then
/// bisection. The summary value `map_switch_dt_ms`.
fn map_switch_values(
    rep: &Report,
    model: &furuta::shared_tangent::SharedParametricModel,
) -> Result<Value, Box<dyn Error>> {
    use furuta::full_system::{DEFAULT_SCAN_PERIODS, ESCAPE_THETA, default_ics};
    let (lo, hi, n, tol) = MAP_SWITCH_RANGE_MS;
    let scan = |interp: Interp| {
        furuta::bifurcations::map_small_start_switch(
            |dt| model.model_at(dt, interp),
            default_ics,
            lo,
            hi,
            n,
            DEFAULT_SCAN_PERIODS,
            tol,
        )
    };
    let (ml, ms) = rayon::join(
        || task("predictions/map-switch-linear", || scan(Interp::Linear)),
        || task("predictions/map-switch-spline", || scan(Interp::Spline)),
    );
    let (ml, ms) = (ml?, ms?);
    let full = rep.summary.get("heteroclinic_dt_ms").and_then(|h| h.get("full_system")).cloned().unwrap_or(Value::Null);
    let js = |sw: &furuta::bifurcations::MapSwitch| {
        json!({
            "bracket": sw.bracket.map(|(a, b)| vec![a, b]),
            "grid": sw.grid.iter().map(|g| json!([g.0, g.1])).collect::<Vec<_>>(),
            "monotone": sw.monotone,
            "evaluations": sw.evaluations,
        })
    };
    // The slow-mode saddle cycles of the portraits section: their rho_1 over the periods.
    let slow: Vec<f64> = rep
        .summary
        .get("portraits")
        .and_then(Value::as_array)
        .into_iter()
        .flatten()
        .flat_map(|d| d["fixed_points"].as_array().into_iter().flatten())
        .filter(|f| f["kind"]["LimitCycle"]["mode"] == 1 && f["stability"] == "Saddle")
        .filter_map(|f| f["rho"][0].as_f64())
        .collect();
    let slow_range = (!slow.is_empty()).then(|| {
        [slow.iter().copied().fold(f64::INFINITY, f64::min), slow.iter().copied().fold(f64::NEG_INFINITY, f64::max)]
    });
    Ok(json!({"linear": js(&ml), "spline": js(&ms), "full_system": full, "periods": DEFAULT_SCAN_PERIODS,
              "range_ms": [lo, hi], "tol_ms": tol, "grid_n": n, "escape_theta": ESCAPE_THETA,
              "slow_saddle_rho1": slow_range}))
}

fn map_switch_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    let m = at(s, "map_switch_dt_ms")?;
    rep.para(&p.html("predictions/map-switch", MAP_SWITCH, &json!({ "m": m }))?);
    let items: Vec<Value> = ["linear", "spline"].iter().map(|k| json!({"name": k, "sw": m[k]})).collect();
    rep.table(
        &["interpolation", "switch bracket [ms]", "escaping starts per grid dt", "monotone", "map runs"],
        &p.rows("predictions/map-switch-row", &MAP_SWITCH_CELLS, &items)?,
    );
    Ok(())
}

fn kind_text(k: PointKind) -> String {
    match k {
        PointKind::Equilibrium => "equilibrium".into(),
        PointKind::LimitCycle { mode } => format!("limit cycle (mode {mode})"),
        PointKind::Torus2 => "2-torus".into(),
    }
}

/// A fixed point's kind (a serialized [`PointKind`] named `k`) in words, as [`kind_text`].
const KIND: &str = "{% if k == \"Equilibrium\" %}equilibrium{% elif k == \"Torus2\" %}2-torus{% else %}limit cycle \
    (mode {{ k.LimitCycle.mode }}){% endif %}";

/// A serialized enum value (serde's external tagging) as Rust's `Debug` writes it:
/// `Converges { point: 3 }`, `ConvergesTo(Torus2)`, `TimeLimit`.
pub fn debug_text(v: &Value) -> String {
    let tagged = |o: &serde_json::Map<String, Value>| {
        o.len() == 1 && o.keys().all(|k| k.starts_with(|c: char| c.is_ascii_uppercase()))
    };
    match v {
        Value::String(s) => s.clone(),
        Value::Number(n) => {
            n.as_f64().filter(|_| !n.is_u64() && !n.is_i64()).map_or_else(|| n.to_string(), |x| format!("{x:?}"))
        }
        Value::Array(a) => format!("({})", a.iter().map(debug_text).collect::<Vec<_>>().join(", ")),
        Value::Object(o) => match o.iter().next() {
            Some((tag, inner)) if tagged(o) => match inner {
                Value::Object(fields) if !tagged(fields) => format!(
                    "{tag} {{ {} }}",
                    fields.iter().map(|(k, x)| format!("{k}: {}", debug_text(x))).collect::<Vec<_>>().join(", ")
                ),
                other => format!("{tag}({})", debug_text(other)),
            },
            _ => format!(
                "{{ {} }}",
                o.iter().map(|(k, x)| format!("{k}: {}", debug_text(x))).collect::<Vec<_>>().join(", ")
            ),
        },
        other => other.to_string(),
    }
}

const PORTRAITS_INTRO: &str = "Amplitude equations rho' = f(rho; dt) of the interpolated normal form. Fixed points: the \
    origin is the equilibrium, a point on an axis a limit cycle of that mode, an interior point a 2-torus; a closed orbit \
    of the amplitude equations is a 3-torus. Saddles' stable manifolds in blue, unstable in red, 3-tori in green. The \
    heteroclinic value is where the interior unstable branch of a saddle cycle switches fate (it lands on the other \
    saddle's stable manifold there), refined by bisection; the torus loses stability where the real part of its Jacobian \
    eigenvalues crosses zero.";
const POINT_CELLS: [&str; 6] = [
    "{{ dt_ms | plain }}",
    "KIND",
    "({{ f.rho[0] | fixed(4) }}, {{ f.rho[1] | fixed(4) }})",
    "{{ f.stability }}",
    "{{ f.eigenvalues[0][0] | signed(4) }} {{ f.eigenvalues[0][1] | signed(4) }}i, {{ f.eigenvalues[1][0] | signed(4) }} \
     {{ f.eigenvalues[1][1] | signed(4) }}i",
    "{{ f.freqs_hz[0] | fixed(3) }}, {{ f.freqs_hz[1] | fixed(3) }}",
];
const ORBIT_CELLS: [&str; 6] = [
    "{{ dt_ms | plain }}",
    "3-torus ({% if o.stable %}stable{% else %}unstable{% endif %})",
    "rho_1 {{ o.rho_range[0][0] | fixed(3) }}..{{ o.rho_range[0][1] | fixed(3) }}, rho_2 {{ o.rho_range[1][0] | fixed(3) \
     }}..{{ o.rho_range[1][1] | fixed(3) }}",
    "multiplier {{ o.multiplier | fixed(4) }}",
    "period {{ o.period_s | fixed(2) }} s",
    "",
];
const PORTRAIT_CAPTION: &str = "Phase portrait of the amplitude equations at dt = {{ dt_ms | plain }} ms";
const HETEROCLINIC: &str = "{% if h is none %}No heteroclinic switch found in {{ range_ms[0] | plain }}..{{ range_ms[1] \
    | plain }} ms.{% else %}Heteroclinic bifurcation (model): dt = {{ h.dt | fixed(4) }} ms (bracket {{ h.bracket[0] | \
    fixed(4) }}..{{ h.bracket[1] | fixed(4) }}); the interior unstable branch of the KIND goes from {{ below }} below to {{ \
    above }} above.{% endif %}";
const HOPF: &str = "{% if h is none %}The 2-torus does not change stability in {{ range_ms[0] | plain }}..{{ range_ms[1] \
    | plain }} ms.{% else %}The 2-torus {% if h.loses_stability %}loses stability{% else %}gains stability{% endif %} at \
    dt = {{ h.dt | fixed(4) }} ms ({% if h.complex_pair %}a complex pair crosses: a Hopf bifurcation of the amplitude \
    equations{% else %}a real eigenvalue crosses{% endif %}; the 3-torus frequency there is {{ h.frequency_hz | fixed(4) \
    }} Hz).{% endif %}";

/// Phase portraits in `(rho_1, rho_2)` at the paper's unseen sampling periods: fixed points
/// (equilibrium, limit cycles, 2-torus) and their stability, the saddle cycles' stable and
/// unstable manifolds, unstable 3-tori; then the heteroclinic and torus-Hopf values of dt.
/// Summary keys `portraits`, `torus_hopf_dt_ms` and `page_portraits` (the events as found).
pub fn portraits_section(rep: &mut Report, pm: &ParametricModel) -> Result<ModelBifurcations, Box<dyn Error>> {
    let popts = PortraitOptions { rho_max: RHO_MAX, ..PortraitOptions::default() };
    let mut list = Vec::new();
    let mut figures = Vec::new();
    for &dt in PAPER_DTS.iter() {
        let nf = pm.normal_form_at(dt)?;
        let p = portrait(&nf, &popts)?;
        list.push(json!({"dt_ms": dt, "fixed_points": p.fixed_points, "orbits": p.orbits.iter().map(|o| json!({
            "rho_range": o.rho_range, "period_s": o.period, "multiplier": o.multiplier, "stable": o.stable})).collect::<Vec<_>>()}));
        let tag = format!("{dt}").replace('.', "p");
        let path = format!("fig/portrait_dt{tag}.png");
        plot_portrait(&rep.dir().join(&path), &p, &format!("dt = {dt} ms"), &[])?;
        figures.push(path);
    }
    let (lo, hi) = pm.range();
    let bif = model_bifurcations(pm)?;
    let (heteroclinic, hopf) = (&bif.heteroclinic, &bif.hopf);
    rep.summary.insert("portraits".into(), Value::Array(list));
    rep.summary.insert(
        "torus_hopf_dt_ms".into(),
        json!({"model": hopf.as_ref().map(|h| h.dt), "complex_pair": hopf.as_ref().map(|h| h.complex_pair)}),
    );
    rep.summary.insert(
        "page_portraits".into(),
        json!({"figures": figures, "range_ms": [lo, hi], "heteroclinic": heteroclinic, "hopf": hopf}),
    );
    portraits_render(rep, &Value::Object(rep.summary.clone()))?;
    Ok(bif)
}

/// Writes the portraits section from the summary `s`.
pub fn portraits_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    rep.section(
        "portraits",
        "Parametric model: phase portraits and bifurcations",
        &p.html("portraits/intro", PORTRAITS_INTRO, s)?,
    );
    let (portraits, page) = (list(s, "portraits")?, at(s, "page_portraits")?);
    let figures = page["figures"].as_array().ok_or("report: page_portraits.figures is not a list")?;
    let point_cells =
        POINT_CELLS.map(|c| if c == "KIND" { "{% set k = f.kind %}".to_string() + KIND } else { c.to_string() });
    let point_cells: Vec<&str> = point_cells.iter().map(String::as_str).collect();
    let mut rows = Vec::new();
    for (d, fig) in portraits.iter().zip(figures) {
        let each = |k: &str, v: &str| -> Vec<Value> {
            d[k].as_array().into_iter().flatten().map(|x| json!({"dt_ms": d["dt_ms"], v: x})).collect()
        };
        rows.extend(p.rows("portraits/point", &point_cells, &each("fixed_points", "f"))?);
        rows.extend(p.rows("portraits/orbit", &ORBIT_CELLS, &each("orbits", "o"))?);
        let fig = fig.as_str().ok_or("report: page_portraits.figures holds a non-string")?;
        rep.figure(fig, &p.text("portraits/caption", PORTRAIT_CAPTION, d)?);
    }
    rep.table(&["dt [ms]", "object", "rho (rad)", "stability", "eigenvalues [1/s]", "freqs [Hz]"], &rows);
    let h = &page["heteroclinic"];
    let het = json!({"h": h, "range_ms": page["range_ms"], "k": h["saddle"],
                     "below": debug_text(&h["fate_below"]), "above": debug_text(&h["fate_above"])});
    rep.para(&p.html("portraits/heteroclinic", &HETEROCLINIC.replace("KIND", KIND), &het)?);
    rep.para(&p.html("portraits/hopf", HOPF, &json!({"h": page["hopf"], "range_ms": page["range_ms"]}))?);
    Ok(())
}

// ------------------------------------------------------------------ model vs full system

/// Where the full system's 2-torus is measured (the model's is `ModelBifurcations::torus_30p8`)
/// and the start of that run (theta, rad).
pub const TORUS_DT_MS: f64 = 30.8;
const TORUS_THETA0: f64 = 0.05;
/// The fast-mode cycle: the start's (slow, fast) amplitudes, and the plateau read after this
/// time (s) while rho_1 stays below this (rad).
const FAST_START: [f64; 2] = [1e-7, 0.005];
const FAST_PLATEAU: (f64, f64) = (15.0, 1e-3);

const FULL_INTRO: &str = "The full system is simulated (scene {{ f.setup.scene }}: INTEGRATOR) from small \
    starts built on the exact linear eigenvectors with given slow/fast theta amplitudes (rho_1, rho_2); a run escapes \
    when |theta| > {{ f.setup.escape_theta | plain }} rad. Mode amplitudes of full-system runs are sliding least-squares \
    fits of the slow and fast components ({{ f.setup.amp_window_s | plain }} s windows), drawn in the model's (rho_1, \
    rho_2) plane. The global section's basin map, torus continuation and connection runs use {{ f.setup.verdict_method \
    }} at the same tolerances; the scans from the default starts keep the scene's integrator (the comparison of the two \
    on these runs: host/lab/examples/fullsystem_integrators.rs).";
/// An integrator (`{"name", "method"}`, the method serialized) as `Integrator::describe` writes it.
const INTEGRATOR: &str = "{{ f.setup.integrator.name }} {% if f.setup.integrator.method.steps is defined %}steps={{ \
    f.setup.integrator.method.steps }}/period{% else %}rtol={{ f.setup.integrator.method.rtol | e }} atol={{ \
    f.setup.integrator.method.atol | e }}{% endif %}";
const FULL_SCAN: &str = "Small starts, full system: {{ f.scan.runs }} runs of {{ f.scan.periods }} periods over dt = {{ \
    f.scan.dts_ms | first | fixed(2) }}..{{ f.scan.dts_ms | last | fixed(2) }} ms ({{ f.scan.wall_seconds | fixed(1) }} \
    s wall): all bounded up to {% if f.scan.bracket is none %}-{% else %}{{ f.scan.bracket[0] | plain }} ms{% endif %}, \
    some escape from {% if f.scan.bracket is none %}-{% else %}{{ f.scan.bracket[1] | plain }} ms{% endif %}{% if not \
    f.scan.monotone %} (not monotone in dt){% endif %}; every start escapes from {% if f.scan.all_escape_from is none \
    %}never in the scan{% else %}{{ f.scan.all_escape_from | plain }} ms{% endif %}. Model: a small start follows the \
    fast-mode saddle cycle's interior unstable branch, which reaches the 2-torus (or the 3-torus around it) up to {% if \
    f.model_switch is none %}the end of the range ({{ f.model_range_end_ms | fixed(2) }} ms){% else %}{{ \
    f.model_switch[0] | fixed(3) }}{% endif %} ms. Heteroclinic search on the model's saddle cycles (unstable branch \
    switching fate between converging and leaving): {% if f.saddle_connection is none %}none found{% else %}{{ \
    f.saddle_connection | fixed(4) }} ms{% endif %}.";
const TORUS_CELLS: [&str; 6] = [
    "{{ name }}",
    "{% if amp is none %}-{% else %}{{ amp | fixed(4) }}{% endif %}",
    "{% if rho is none %}-{% else %}{{ rho[0] | fixed(4) }}{% endif %}",
    "{% if rho is none %}-{% else %}{{ rho[1] | fixed(4) }}{% endif %}",
    "{% if hz is none %}-{% else %}{{ hz[0] | fixed(4) }}{% endif %}",
    "{% if hz is none %}-{% else %}{{ hz[1] | fixed(4) }}{% endif %}",
];
const FAST: &str = "The fast-mode cycle (the saddle every small start passes first): the model's limit cycle against \
    the full system started on the fast mode (slow part {{ f.fast.start[0] | plain }} rad), mean rho_2 while rho_1 < {{ \
    f.fast.rho1_below | plain }} after {{ f.fast.after_s | plain }} s.";
const FAST_CELLS: [&str; 4] = [
    "{{ dt_ms | plain }}",
    "{% if rho2_model is none %}-{% else %}{{ rho2_model | fixed(4) }}{% endif %}",
    "{% if rho2_full is none %}-{% else %}{{ rho2_full | fixed(4) }}{% endif %}",
    "{% if rho2_model is none or rho2_full is none %}-{% else %}{{ (100 * (rho2_model - rho2_full) / rho2_full) | \
     signed(1) }} %{% endif %}",
];
const DOA_CELLS: [&str; 3] = [
    "({{ s.rho[0] | plain }}, {{ s.rho[1] | plain }})",
    "{% if m.class == \"leaves\" %}leaves the box (escape){% elif m.class == \"converges\" %}converges to the KIND{% elif \
     m.class == \"time\" %}stays bounded (3-torus){% else %}{{ m.other }}{% endif %}",
    "{% if s.full_bounded %}bounded for {{ bounded_s | fixed(0) }} s{% else %}escapes at {{ s.full_escape_t | fixed(1) \
     }} s{% endif %}",
];
const DOA_CAPTION: &str = "Domain of attraction at {{ dt_ms | plain }} ms: the model's portrait with {{ n }} full-system \
    runs in amplitude coordinates";
const TRANSIENT: &str = "Transient at {{ t.dt_ms | plain }} ms from (rho_1, rho_2) = ({{ p.rho[0] | plain }}, {{ p.rho[1] \
    | plain }}), {{ p.analysed_s | fixed(0) }} s analysed{% if p.escape_t is not none %} (escapes at {{ p.escape_t | \
    fixed(1) }} s){% endif %}: {{ p.peaks }} spectral peaks above {{ p.peak_threshold_pct | num }} % of the \
    largest ({% for x in t.peaks_hz %}{{ x | fixed(4) }}{% if not loop.last %}, {% endif %}{% endfor %}); slow {{ p.slow_hz \
    | fixed(4) }} Hz, fast {{ p.fast_hz | fixed(4) }} Hz; the third frequency as sideband spacing {% if \
    t.sideband_spacing_hz is none %}-{% else %}{{ t.sideband_spacing_hz | fixed(4) }} Hz{% endif %} and as the oscillation \
    of rho_1(t) {% if t.envelope_freq_hz is none %}-{% else %}{{ t.envelope_freq_hz | fixed(4) }} Hz{% endif %}; the \
    model's 3-torus at {{ t.dt_ms | plain }} ms circles at {% if t.model_3torus_freq_hz is none %}- (no 3-torus in the \
    model){% else %}{{ t.model_3torus_freq_hz | fixed(4) }} Hz{% endif %}.";

/// Full-system checks of the model's predictions: where small starts switch from bounded to
/// escape, the 2-torus at `TORUS_DT_MS`, the domain of attraction at 31.55 ms (three starts,
/// paper fig. 5), and the transient spectrum near the 3-torus (paper fig. 6). Returns the
/// model's small-start switch bracket ([`model_default_switch`]), which the sensitivity
/// section's default row reuses. Summary keys `heteroclinic_dt_ms`, `torus_30p8`,
/// `fast_cycle`, `domain_of_attraction`, `transient_3torus` and `page_fullsystem` (what else
/// the text reads).
pub fn fullsystem_section(
    rep: &mut Report,
    pm: &ParametricModel,
    bif: &ModelBifurcations,
    quick: bool,
) -> Result<Option<(f64, f64)>, Box<dyn Error>> {
    use furuta::full_system::{
        AMP_WINDOW_S, DEFAULT_SCAN_PERIODS, ESCAPE_THETA, default_ics, default_switch_scan, fate_from, start_from_rho,
        switch_scan_per_dt, torus_full, transient_analysis,
    };
    // The integrator of the full-system runs here: the scene's (`furuta-dt30.5`); the basin,
    // torus-continuation and connection runs of the global section take the verdict method.
    let scene = furuta::full_system::base_scene()?;
    let method = sim::closed_loop::method_of(scene);
    let described = sim::ode::Integrator::<4>::new(method)?.describe();
    let name = described.split(' ').next().unwrap_or_default();
    let integrator = json!({"name": name, "method": method});
    let verdict = furuta::full_system::verdict_integrator()?;
    // The full-system runs of the four parts below and the model's small-start scan share
    // nothing: they run together on the pool, then the parts are written in order.
    let (lo, hi) = pm.range();
    let fast_dts = [30.8, 31.2, 31.4, 31.6];
    let dt_doa = 31.55;
    let starts: [[f64; 2]; 3] = [[0.08, 0.03], [0.02, 0.03], [0.14, 0.055]];
    let periods = if quick { 2000 } else { 6000 };
    let dt_tr = 31.5;
    let model_switch = || model_default_switch(pm);
    let scan = || {
        if quick {
            let two = |dt: f64| default_ics(dt).map(|v| v.into_iter().take(2).collect());
            switch_scan_per_dt(&[31.2, 31.3, 31.4, 31.5, 31.6], two, 3000)
        } else {
            default_switch_scan(DEFAULT_SCAN_PERIODS)
        }
    };
    let torus = || {
        torus_full(
            TORUS_DT_MS,
            &([TORUS_THETA0, 0.0, 0.0, 0.0], None),
            if quick { 4000 } else { 8000 },
            if quick { 40.0 } else { 80.0 },
        )
    };
    let fast_fates = || par_map(&fast_dts, |&dt| fate_from(dt, FAST_START, [0.0, 0.0], 3000));
    let doa_fates = || par_map(&starts, |&rho| fate_from(dt_doa, rho, [0.0, 0.0], periods));
    let transient = || {
        let start = start_from_rho(dt_tr, TRANSIENT_RHO, [0.0, 0.0])?;
        transient_analysis(dt_tr, &(start.0, Some(start.1)), if quick { 60.0 } else { 150.0 })
    };
    let ((model_switch, scan), ((tf, fast_fates), (doa_fates, ta))) = rayon::join(
        || rayon::join(|| task("fullsystem/model-switch", model_switch), || task("fullsystem/scan", scan)),
        || {
            rayon::join(
                || rayon::join(|| task("fullsystem/torus", torus), || task("fullsystem/fast-fates", fast_fates)),
                || rayon::join(|| task("fullsystem/doa-fates", doa_fates), || task("fullsystem/transient", transient)),
            )
        },
    );
    let (model_switch, scan, tf, fast_fates, doa_fates, ta) = (model_switch?, scan?, tf?, fast_fates?, doa_fates?, ta?);

    // 1. Small-start switch.
    let full_bracket = scan.bracket();
    rep.summary.insert(
        "heteroclinic_dt_ms".into(),
        json!({
            "model": model_switch.map(|b| 0.5 * (b.0 + b.1)),
            "model_rule": "first dt where the fast saddle cycle's interior unstable branch no longer ends on the continued 2-torus or a 3-torus around it",
            "model_saddle_connection": bif.heteroclinic.as_ref().map(|h| h.dt),
            "full_system": full_bracket.map(|b| [b.0, b.1]),
            "full_system_all_escape_from": scan.all_escape_from(),
            "scan_periods": scan.periods,
        }),
    );
    let scan_rows: Vec<Value> = scan
        .dts_ms
        .iter()
        .zip(&scan.outcomes)
        .map(|(dt, row)| {
            json!({"dt_ms": dt, "bounded": row.iter().map(|o| o.bounded()).collect::<Vec<_>>(),
                   "escape_t": row.iter().filter_map(|o| o.escape_t).collect::<Vec<_>>()})
        })
        .collect();

    // 2. The 2-torus.
    let tm = bif.torus_30p8.as_ref();
    rep.summary.insert(
        "torus_30p8".into(),
        json!({
            "amplitude_theta_model": tm.map(|t| t.rho[0] + t.rho[1]),
            "amplitude_theta_full": tf.amplitude_theta,
            "rho_model": tm.map(|t| t.rho),
            "rho_full": tf.rho,
            "freqs_hz_model": tm.map(|t| t.freqs_hz),
            "freqs_hz_full": tf.freqs_hz,
        }),
    );

    // 2b. The fast-mode cycle (the saddle small starts pass first): the full system started
    // on the fast mode with a tiny slow part stays near the cycle for tens of seconds; its
    // plateau (mean rho_2 while rho_1 is small, after a while) against the model's cycle.
    let mut clist = Vec::new();
    let popts = PortraitOptions { rho_max: RHO_MAX, ray_samples: 0, flow_grid: 0, ..PortraitOptions::default() };
    for (dt, f) in fast_dts.into_iter().zip(fast_fates) {
        let plateau: Vec<f64> =
            f.amps.iter().filter(|(t, r)| *t > FAST_PLATEAU.0 && r[0] < FAST_PLATEAU.1).map(|(_, r)| r[1]).collect();
        let full = (!plateau.is_empty()).then(|| plateau.iter().sum::<f64>() / plateau.len() as f64);
        let model = fixed_points(&pm.normal_form_at(dt)?, &popts)?
            .into_iter()
            .filter(|p| p.kind == (PointKind::LimitCycle { mode: 2 }))
            .map(|p| p.rho[1])
            .min_by(f64::total_cmp);
        clist.push(json!({"dt_ms": dt, "rho2_model": model, "rho2_full": full}));
    }
    rep.summary.insert("fast_cycle".into(), Value::Array(clist));

    // 3. Domain of attraction (paper fig. 5): three starts.
    let nf = pm.normal_form_at(dt_doa)?;
    let popts = PortraitOptions { rho_max: RHO_MAX, ..PortraitOptions::default() };
    let p = portrait(&nf, &popts)?;
    let mut curves: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    let mut doa = Vec::new();
    let mut classes = Vec::new();
    for (rho, f) in starts.into_iter().zip(doa_fates) {
        let (_, mfate) = trajectory(&nf, rho, 2000.0, &popts)?;
        let kind = |point: usize| p.fixed_points.get(point).map_or(PointKind::Torus2, |x| x.kind);
        let (model_class, class) = match mfate {
            Fate::LeavesBox { .. } => ("leaves the box (escape)".to_string(), json!({"class": "leaves"})),
            Fate::Converges { point } => (
                format!("converges to the {}", kind_text(kind(point))),
                json!({"class": "converges", "kind": kind(point)}),
            ),
            Fate::TimeLimit => ("stays bounded (3-torus)".to_string(), json!({"class": "time"})),
            other => (format!("{other:?}"), json!({"class": "other", "other": format!("{other:?}")})),
        };
        doa.push(json!({"rho": rho, "model": model_class, "full_bounded": f.bounded, "full_escape_t": f.escape_t}));
        classes.push(class);
        curves.push((format!("full ({}, {})", rho[0], rho[1]), f.amps.iter().map(|(_, r)| (r[0], r[1])).collect()));
    }
    let extra: Vec<(&str, &[(f64, f64)])> = curves.iter().map(|(n, c)| (n.as_str(), c.as_slice())).collect();
    let doa_fig = format!("fig/domain_{}.png", format!("{dt_doa}").replace('.', "p"));
    plot_portrait(
        &rep.dir().join(&doa_fig),
        &p,
        &format!("dt = {dt_doa} ms: model portrait, full-system runs"),
        &extra,
    )?;
    rep.summary.insert("domain_of_attraction".into(), json!({"dt_ms": dt_doa, "starts": doa}));

    // 4. Transient spectrum near the 3-torus (paper fig. 6).
    let model_orbit = portrait(&pm.normal_form_at(dt_tr)?, &popts)?.orbits.first().map(|o| 1.0 / o.period);
    rep.summary.insert(
        "transient_3torus".into(),
        json!({"dt_ms": dt_tr, "peaks_hz": ta.peaks.iter().map(|p| p.freq_hz).collect::<Vec<_>>(),
               "sideband_spacing_hz": ta.sideband_spacing_hz, "envelope_freq_hz": ta.envelope_freq_hz,
               "model_3torus_freq_hz": model_orbit}),
    );
    rep.summary.insert(
        "page_fullsystem".into(),
        json!({
            "setup": {"scene": scene.name, "integrator": integrator, "verdict_method": verdict.method.key(),
                      "escape_theta": ESCAPE_THETA, "amp_window_s": AMP_WINDOW_S},
            "scan": {"runs": scan.runs, "periods": scan.periods, "dts_ms": scan.dts_ms, "wall_seconds": scan.wall_seconds,
                     "monotone": scan.monotone(), "bracket": full_bracket.map(|b| [b.0, b.1]),
                     "all_escape_from": scan.all_escape_from(), "rows": scan_rows},
            "model_switch": model_switch.map(|b| [b.0, b.1]),
            "model_range_end_ms": hi.min(PAPER_DTS.iter().copied().fold(f64::NEG_INFINITY, f64::max)),
            "model_range_ms": [lo, hi],
            "saddle_connection": bif.heteroclinic.as_ref().map(|h| h.dt),
            "torus": {"dt_ms": TORUS_DT_MS, "theta0": TORUS_THETA0, "tail_s": tf.tail_s, "total_s": tf.total_s,
                      "linear_freqs_hz": tf.linear_freqs_hz},
            "fast": {"start": FAST_START, "after_s": FAST_PLATEAU.0, "rho1_below": FAST_PLATEAU.1},
            "doa": {"periods": periods, "starts": starts.len(), "classes": classes, "figure": doa_fig},
            "transient": {"rho": TRANSIENT_RHO, "analysed_s": ta.analysed_s, "escape_t": ta.escape_t,
                          "peaks": ta.peaks.len(), "peak_threshold_pct": 100.0 * ssm::spectrum::PEAK_REL_THRESHOLD,
                          "slow_hz": ta.slow.freq_hz, "fast_hz": ta.fast.freq_hz},
        }),
    );
    fullsystem_render(rep, &Value::Object(rep.summary.clone()))?;
    Ok(model_switch)
}

/// Writes the full-system section from the summary `s`.
pub fn fullsystem_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    let f = at(s, "page_fullsystem")?;
    let v = json!({ "f": f });
    rep.section(
        "fullsystem",
        "Parametric model vs the full system: bifurcations, torus, domain of attraction",
        &p.html("fullsystem/intro", &FULL_INTRO.replace("INTEGRATOR", INTEGRATOR), &v)?,
    );
    rep.para(&p.html("fullsystem/scan", FULL_SCAN, &v)?);
    // One line per dt: `dt  B/E per start  (escape times)`, as `SwitchScan::to_text`.
    let mut pre = String::new();
    for r in f["scan"]["rows"].as_array().ok_or("report: page_fullsystem.scan.rows is not a list")? {
        let dt = r["dt_ms"].as_f64().ok_or("report: page_fullsystem.scan.rows[].dt_ms")?;
        let marks: String = r["bounded"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|b| if b.as_bool() == Some(true) { 'B' } else { 'E' })
            .collect();
        let times: Vec<String> = r["escape_t"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(Value::as_f64)
            .map(|t| format!("{t:.1}"))
            .collect();
        pre.push_str(&format!("{dt:8.3} ms  {marks}  escapes at [{}] s\n", times.join(", ")));
    }
    rep.para(&format!("<pre>{}</pre>", crate::report::esc(&pre)));

    let torus = at(s, "torus_30p8")?;
    let t = &f["torus"];
    let head = p.text("fullsystem/torus-head", "2-torus at {{ dt_ms | plain }} ms", t)?;
    let items = [
        json!({"name": "model (fixed point of the amplitude equations; max |theta| = rho_1 + rho_2)",
               "amp": torus["amplitude_theta_model"], "rho": torus["rho_model"], "hz": torus["freqs_hz_model"]}),
        json!({"name": p.text("fullsystem/torus-full", "full system (last {{ tail_s | fixed(0) }} s of {{ total_s | fixed(0) }} s from theta0 = {{ theta0 | plain }})", t)?,
               "amp": torus["amplitude_theta_full"], "rho": torus["rho_full"], "hz": torus["freqs_hz_full"]}),
    ];
    let mut rows = p.rows("fullsystem/torus", &TORUS_CELLS, &items)?;
    let linear = p.rows("fullsystem/torus-linear", &TORUS_CELLS[4..], &[json!({"hz": t["linear_freqs_hz"]})])?;
    rows.push(
        [vec!["exact linear frequencies".to_string(), String::new(), String::new(), String::new()], linear.concat()]
            .concat(),
    );
    rep.table(
        &[head.as_str(), "max |theta| [rad]", "rho_1 (slow) [rad]", "rho_2 (fast) [rad]", "slow [Hz]", "fast [Hz]"],
        &rows,
    );

    rep.para(&p.html("fullsystem/fast", FAST, &v)?);
    rep.table(
        &["dt [ms]", "model rho_2 [rad]", "full system rho_2 [rad]", "model - full"],
        &p.rows("fullsystem/fast-row", &FAST_CELLS, list(s, "fast_cycle")?)?,
    );

    let doa = at(s, "domain_of_attraction")?;
    let starts = doa["starts"].as_array().ok_or("report: domain_of_attraction.starts is not a list")?;
    let classes = f["doa"]["classes"].as_array().ok_or("report: page_fullsystem.doa.classes is not a list")?;
    let bounded_s = f["doa"]["periods"].as_f64().unwrap_or(f64::NAN) * doa["dt_ms"].as_f64().unwrap_or(f64::NAN) * 1e-3;
    let items: Vec<Value> = starts
        .iter()
        .zip(classes)
        .map(|(st, m)| json!({"s": st, "m": m, "k": m["kind"], "bounded_s": bounded_s}))
        .collect();
    let cells = DOA_CELLS.map(|c| c.replace("KIND", KIND));
    let cells: Vec<&str> = cells.iter().map(String::as_str).collect();
    rep.table(&["start (rho_1, rho_2) [rad]", "model", "full system"], &p.rows("fullsystem/doa", &cells, &items)?);
    let fig = f["doa"]["figure"].as_str().ok_or("report: page_fullsystem.doa.figure")?;
    rep.figure(
        fig,
        &p.text("fullsystem/doa-caption", DOA_CAPTION, &json!({"dt_ms": doa["dt_ms"], "n": f["doa"]["starts"]}))?,
    );
    rep.para(&p.html(
        "fullsystem/transient",
        TRANSIENT,
        &json!({"t": at(s, "transient_3torus")?, "p": f["transient"]}),
    )?);
    Ok(())
}

const SENS_INTRO: &str = "The parametric model's bifurcation values are a property of the fitted normal-form \
    coefficients, and those depend on which amplitudes the training runs cover: each row refits the model (same \
    embedding, orders and starts) with the training runs cut at a different |theta| or with more training periods. \
    {% if page.max_rate_error is not none %}The linear rates stay within {{ page.max_rate_error | pct(2) }} % of the \
    exact ones at the training periods in every variant; the higher-order coefficients, and with them the \
    bifurcations, need not.{% endif %}";
const SENS_CELLS: [&str; 6] = [
    "{{ variant }}",
    "{% if torus_hopf_dt_ms is none %}none{% else %}{{ torus_hopf_dt_ms | fixed(3) }}{% endif %}",
    "{% if heteroclinic_dt_ms is none %}none{% else %}{{ heteroclinic_dt_ms | fixed(3) }}{% endif %}",
    "{% if small_start_switch_dt_ms is none %}none{% else %}{{ small_start_switch_dt_ms | fixed(3) }}{% endif %}",
    "{% if torus_30p8_rho is none %}none{% else %}({{ torus_30p8_rho[0] | fixed(4) }}, {{ torus_30p8_rho[1] | fixed(4) \
     }}){% endif %}",
    "{% if fit_seconds is none %}(above){% else %}{{ fit_seconds | fixed(1) }}{% endif %}",
];
const SENS_TORUS: &str = "The full system's torus for comparison: started at (rho_1, rho_2) = ({{ page.torus_rho[0] | \
    plain }}, {{ page.torus_rho[1] | plain }}), {{ page.torus_periods }} periods, mean and spread (max - min) of the mode \
    amplitudes over the last {{ page.torus_tail_s | plain }} s. A spread near zero is an attracting 2-torus; it grows \
    where the torus loses attraction. The full system's small-start switch is in the section above.";
const SENS_TORUS_CELLS: [&str; 4] = [
    "{{ t.dt_ms | plain }}",
    "{% if t.escaped %}escaped ({{ why }}){% else %}({{ t.rho[0] | fixed(4) }}, {{ t.rho[1] | fixed(4) }}){% endif %}",
    "{% if t.escaped %}-{% else %}{{ t.rho_spread[0] | fixed(4) }}{% endif %}",
    "{% if t.escaped %}-{% else %}{{ t.rho_spread[1] | fixed(4) }}{% endif %}",
];

/// The largest relative error of `pm`'s linear rates against the exact ones over its
/// training periods `dts`.
fn rate_error(pm: &ParametricModel, dts: &[f64]) -> Result<f64, furuta::Error> {
    let mut worst = 0.0f64;
    for &dt in dts {
        let fit = pm.linear_rates_at(dt)?;
        let exact = furuta::parametric::exact_modes(dt)?.rates;
        for k in 0..2 {
            worst = worst.max(((fit[k] - exact[k]) / exact[k]).abs());
        }
    }
    Ok(worst)
}

/// How the model's bifurcation values depend on the training data: the amplitude cut of
/// the training runs and the density of training periods (full report only: four more
/// parametric fits). `default` is the report's model, fitted with `FurutaOptions::default()`;
/// `runs` its training runs, which cover the variants (simulated once); the variants share
/// the fits of their common (period, cut) pairs and reuse `default`'s. `default`'s row is
/// made from `bif` (its [`model_bifurcations`]) and `switch` (its small-start switch, the
/// full-system section's), the values [`model_row`] would compute again. Summary keys
/// `bifurcation_sensitivity`, `torus_full_vs_dt` and `page_bifsensitivity`.
pub fn sensitivity_section(
    rep: &mut Report,
    default: &ParametricModel,
    bif: &ModelBifurcations,
    switch: Option<(f64, f64)>,
    runs: &TrainingRuns,
) -> Result<(), Box<dyn Error>> {
    let base = FurutaOptions::default();
    let variants = sensitivity_variants();
    // The refits per variant and the full system's torus across dt (below) run together on
    // the pool; rows are kept in this order, the default model's first.
    let dts = [30.8, 31.2, 31.4, 31.6, 31.8, 31.9];
    let tori = || {
        par_map(&dts, |&dt| {
            let (x, h) = furuta::full_system::start_from_rho(dt, TORUS_RHO, [0.0, 0.0])?;
            Ok::<_, furuta::Error>(furuta::full_system::torus_full(dt, &(x, Some(h)), TORUS_PERIODS, TORUS_TAIL_S))
        })
    };
    let first = row_from("default (paper's periods, cut 0.2 rad)", &base, bif, switch, None);
    let first_err = rate_error(default, &base.dts_ms)?;
    let (rest, tori) = rayon::join(
        || -> Result<Vec<(SensitivityRow, f64)>, furuta::Error> {
            let sets: Vec<&FurutaOptions> = variants.iter().map(|(_, o)| o).collect();
            let models = task("bifsensitivity/family", || furuta_parametric_family(&base, default, &sets, runs))?;
            let items: Vec<(&(&str, FurutaOptions), (ParametricModel, f64))> = variants.iter().zip(models).collect();
            task("bifsensitivity/rows", || {
                par_map(&items, |((name, o), (pm, secs))| {
                    Ok((model_row(name, o, pm, Some(*secs))?, rate_error(pm, &o.dts_ms)?))
                })
            })
        },
        || task("bifsensitivity/tori", tori),
    );
    let mut list = vec![first];
    let mut worst = first_err;
    for (r, e) in rest? {
        list.push(r);
        worst = worst.max(e);
    }
    let tori = tori?;
    // The full system's torus across dt: started on it, measured over the run's tail.
    let mut tlist = Vec::new();
    let mut why = Vec::new();
    for (dt, torus) in dts.into_iter().zip(tori) {
        match torus {
            Ok(t) => {
                tlist.push(json!({"dt_ms": dt, "rho": t.rho, "rho_spread": t.rho_spread, "escaped": false}));
                why.push(Value::Null);
            }
            Err(furuta::Error::TorusEscaped { why: w, .. }) => {
                tlist.push(json!({"dt_ms": dt, "escaped": true}));
                why.push(json!(w.to_string()));
            }
            Err(e) => return Err(e.into()),
        }
    }
    rep.summary.insert("torus_full_vs_dt".into(), Value::Array(tlist));
    rep.summary.insert("bifurcation_sensitivity".into(), serde_json::to_value(&list)?);
    rep.summary.insert(
        "page_bifsensitivity".into(),
        json!({"max_rate_error": worst, "torus_rho": TORUS_RHO, "torus_periods": TORUS_PERIODS,
               "torus_tail_s": TORUS_TAIL_S, "torus_dt_ms": TORUS_DT_MS, "escaped_why": why}),
    );
    sensitivity_render(rep, &Value::Object(rep.summary.clone()))
}

/// Writes the sensitivity section from the summary `s`.
pub fn sensitivity_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    let page = at(s, "page_bifsensitivity")?;
    rep.section(
        "bifsensitivity",
        "Model bifurcations vs training choices",
        &p.html("bifsensitivity/intro", SENS_INTRO, &json!({ "page": page }))?,
    );
    let head = p.text("bifsensitivity/head", "torus at {{ torus_dt_ms | plain }} ms (rho_1, rho_2)", page)?;
    rep.table(
        &["training", "torus Hopf [ms]", "saddle connection [ms]", "small-start switch [ms]", head.as_str(), "fit [s]"],
        &p.rows("bifsensitivity/row", &SENS_CELLS, list(s, "bifurcation_sensitivity")?)?,
    );
    rep.para(&p.html("bifsensitivity/torus", SENS_TORUS, &json!({ "page": page }))?);
    let why = page["escaped_why"].as_array().ok_or("report: page_bifsensitivity.escaped_why is not a list")?;
    let items: Vec<Value> =
        list(s, "torus_full_vs_dt")?.iter().zip(why).map(|(t, w)| json!({"t": t, "why": w})).collect();
    rep.table(
        &["dt [ms]", "mean (rho_1, rho_2)", "rho_1 spread", "rho_2 spread"],
        &p.rows("bifsensitivity/torus-row", &SENS_TORUS_CELLS, &items)?,
    );
    Ok(())
}
