//! Report section: SSM fitting on real measured data (sloshing decay), its backbone curve
//! and forced response curve (illustrative calibration), the fit accuracy-vs-time table, and the device blobs exported from fitted RBF models.

use crate::plot::{self, Series};
use crate::report::prose::Prose;
use crate::report::{Report, esc};
use plotters::style::RGBColor;
use serde_json::{Value, json};
use sim::closed_loop::simulate;
use sim::scene::SceneBuilder;
use sim::units::s_to_ms;
use ssm::backbone::{BackboneOptions, backbone};
use ssm::device::{encode, to_device_model};
use ssm::metrics::amplitude_spectrum;
use ssm::{Dynamics, FitOptions, Ridge, TimeSeries, fit, load_csv};
use std::error::Error;
use std::path::Path;

const BLACK: RGBColor = RGBColor(0, 0, 0);
const RED: RGBColor = RGBColor(200, 30, 30);

/// The training and test runs of the sloshing data set (file stems under its folder).
pub const TRAIN: [&str; 2] = ["decay_0", "decay_1"];
pub const TEST: &str = "decay_2";

/// The forced response's illustrative calibration: the amplitude (% of the tank width) at this
/// multiple of the linear frequency, and the frequency range swept (multiples of it).
pub const CAL_AMPLITUDE: f64 = 1.0;
pub const CAL_RATIO: f64 = 1.03;
const SWEEP: (f64, f64) = (0.9, 1.06);

/// The HTML template `tpl` (named `name` in errors) over `values` ([`Prose::html`]).
fn html(name: &str, tpl: &str, values: &Value) -> Result<String, Box<dyn Error>> {
    Ok(Prose::new().html(name, tpl, values)?)
}

/// A number with its sign (`{:+.n}`), for the templates below.
pub const SIGNED: &str = "{% macro signed(x, n) %}{% if x >= 0 %}+{% endif %}{{ x | fixed(n) }}{% endmacro %}";

/// The section's introduction over the data set's runs and the model's dimension.
pub const INTRO: &str = "A {{ dim }}D SSM in a delay embedding of the centre-of-mass signal (SSMLearn's sloshing example \
    data, read from <code>{{ folder }}</code>): trained on {{ train | join(' and ') }}, tested on {{ test }}. NMTE as \
    SSMLearn defines it (mean error norm over the max norm of the truth), on the observable; DTW-NMTE after dynamic \
    time warping.";

/// The fit's settings and accuracy.
pub const FIT: &str = "Recommended settings (p = {{ fit.embed }}, shift {{ fit.shift }}, manifold order \
    {{ fit.manifold_order }}, polynomial map order {{ fit.dyn_order }}): fit {{ fit_ms | fixed(2) }} ms (best of \
    {{ reps }}), test NMTE {{ nmte | fixed(4) }}, DTW-NMTE {{ dtw | fixed(4) }}; eigenvalues {% for e in eigenvalues \
    %}{{ signed(e.re, 4) }} {{ signed(e.im, 4) }}i{% if not loop.last %}, {% endif %}{% endfor %}.";

/// The exported sloshing model.
pub const EXPORT: &str = "Exported the {% if centres is not none %}{{ centres }}-centre {% endif %}RBF model as \
    <code>{{ file }}</code> ({{ bytes }} bytes).";

/// The exported Furuta model.
pub const FURUTA_EXPORT: &str = "Exported a {{ dim }}D SSM with a {{ centres }}-centre RBF map fitted to the theta \
    series of {{ scene }}, together with that scene's quantized controller configuration, as <code>{{ file }}</code> \
    ({{ bytes }} bytes): the blob the firmware runs.";

/// The backbone curve's ends.
pub const BACKBONE: &str = "Backbone curve of this model (normal form of the map, <code>ssm::backbone</code>): \
    instantaneous damping ratio -Re&lambda;/|&lambda;| and frequency against the amplitude of x, the max over a period \
    of x on the manifold above the normal-form amplitude. From amplitude {{ first.amplitude | num }} to \
    {{ last.amplitude | num }} % (the largest |x| of the training data) the frequency goes from \
    {{ first.freq_hz | num }} to {{ last.freq_hz | num }} Hz and the damping ratio from {{ first.damping_pct | num }} to \
    {{ last.damping_pct | num }} %.";

/// The forced response's calibration and peak.
pub const FRC: &str = "Forced response curve of this model (<code>ssm::frc</code>, SSMLearn's calibrateFRC approach): \
    harmonic forcing added to the polar normal form, steady states and their stability in closed form, amplitudes of x \
    through the normal-form transformation and the manifold. The calibration point is illustrative (the data hold no \
    forced measurement): amplitude {{ amplitude | num }} % at {{ freq_rad_s | num }} rad/s ({{ ratio | num }} times the \
    linear frequency), giving the normal-form forcing {{ forcing | num }}. Largest stable amplitude \
    {{ peak_amplitude | num }} % at {{ peak_freq_rad_s | num }} rad/s; {{ unstable }} unstable branch(es) (dashed).";

/// The sloshing section; skipped with a note when the data folder is absent. Computes its
/// values (summary keys `fit_sloshing`, `backbone`, `frc`, and `page_sloshing` for the page's
/// settings and figures), then writes the page from them ([`sloshing_render`]).
pub fn sloshing_section(rep: &mut Report, data_dir: &Path, quick: bool) -> Result<(), Box<dyn Error>> {
    let dir = data_dir.join("sloshing");
    let fo = crate::bench::sloshing_fit_options();
    let setup = json!({ "dim": fo.dim, "folder": dir.display().to_string(), "train": TRAIN, "test": TEST });
    let files = [TRAIN[0], TRAIN[1], TEST].map(|f| dir.join(format!("{f}.csv")));
    if !files.iter().all(|f| f.is_file()) {
        rep.summary.insert("fit_sloshing".into(), json!({"skipped": format!("{} not found", dir.display())}));
        rep.summary.insert("backbone".into(), json!({"skipped": format!("{} not found", dir.display())}));
        rep.summary.insert("frc".into(), json!({"skipped": format!("{} not found", dir.display())}));
        rep.summary.insert("page_sloshing".into(), json!({ "setup": setup, "skipped_dir": dir.display().to_string() }));
        return sloshing_render(rep, &Value::Object(rep.summary.clone()));
    }
    let series: Vec<TimeSeries> = files.iter().map(load_csv).collect::<Result<_, _>>()?;
    let (train, test) = (&series[..2], &series[2]);
    let reps = if quick { 2 } else { 10 };
    let (secs, m) = crate::bench::timed_fit(train, &fo, reps)?;
    let pred = m.predict(test)?;
    let (nmte, dtw) = (pred.nmte(test), pred.nmte_dtw(test, None));
    let eig: Vec<Value> = m.eigenvalues_ct().iter().map(|&(re, im)| json!({"re": re, "im": im})).collect();
    let tp: Vec<(f64, f64)> = test.t.iter().copied().zip(test.x.iter().copied()).collect();
    let pp: Vec<(f64, f64)> = pred.t.iter().copied().zip(pred.x.iter().copied()).collect();
    let (prediction_fig, spectrum_fig) = ("fig/sloshing_prediction.png", "fig/sloshing_spectrum.png");
    plot::lines(
        &rep.dir().join(prediction_fig),
        &format!("sloshing {TEST}: measured vs SSM prediction"),
        "t [s]",
        "x [% tank width]",
        &[
            Series { name: "measured", points: &tp, color: BLACK },
            Series { name: "SSM model", points: &pp, color: RED },
        ],
        (760, 320),
    )?;
    let (f1, a1) = amplitude_spectrum(&test.x[..pred.x.len()], m.dt);
    let (f2, a2) = amplitude_spectrum(&pred.x, m.dt);
    let s1: Vec<(f64, f64)> = f1.into_iter().zip(a1).filter(|p| p.0 <= 3.0).collect();
    let s2: Vec<(f64, f64)> = f2.into_iter().zip(a2).filter(|p| p.0 <= 3.0).collect();
    plot::lines(
        &rep.dir().join(spectrum_fig),
        "amplitude spectra",
        "f [Hz]",
        "amplitude",
        &[
            Series { name: "measured", points: &s1, color: BLACK },
            Series { name: "SSM model", points: &s2, color: RED },
        ],
        (520, 320),
    )?;
    let backbone_page = backbone_values(rep, &m, train)?;
    let frc_page = frc_values(rep, &m, train)?;

    // What accuracy costs in time (second table; also `ssmctl bench fit`).
    let (bench_rows, rbf50) = crate::bench::bench_fit(train, test, quick, |_| {})?;
    let list = serde_json::to_value(&bench_rows)?;
    let mut export = Value::Null;
    if let Some(m) = rbf50 {
        let blob = encode(&to_device_model(&m, shared::ControllerConfig::paper(m.dt))?)?;
        crate::output::write_atomic(&rep.dir().join("sloshing-rbf50.bin"), &blob)?;
        let centres = match m.options.dynamics {
            Dynamics::Rbf { centers } => Some(centers),
            _ => None,
        };
        export = json!({ "centres": centres, "bytes": blob.len(), "file": "sloshing-rbf50.bin" });
    }
    rep.summary.insert(
        "fit_sloshing".into(),
        json!({"fit_ms": s_to_ms(secs), "nmte_test": nmte, "dtw_nmte_test": dtw, "eigenvalues": eig, "table": list}),
    );
    rep.summary.insert(
        "page_sloshing".into(),
        json!({
            "setup": setup,
            "fit": { "embed": fo.embed, "shift": fo.shift, "manifold_order": fo.manifold_order, "dyn_order": fo.dyn_order },
            "reps": reps,
            "figures": { "prediction": prediction_fig, "spectrum": spectrum_fig },
            "backbone": backbone_page,
            "frc": frc_page,
            "export": export,
        }),
    );
    sloshing_render(rep, &Value::Object(rep.summary.clone()))
}

/// The figure captions of the sloshing section, over its setup.
const PREDICTION_CAPTION: &str = "Test trajectory {{ test }} and the model's prediction from its first point";
const SPECTRUM_CAPTION: &str = "FFT amplitude spectra of the test trajectory and the prediction";
const BACKBONE_CAPTION: &str =
    "Backbone curve of the sloshing model: amplitude of x against damping ratio and against frequency";
const FRC_CAPTION: &str = "Forced response of the sloshing model (illustrative calibration point): stable solid, unstable dashed, backbone grey";

/// The fit-vs-time table's introduction.
const BENCH_INTRO: &str = "What accuracy costs in time (fitting): each row varies one setting from the baseline (first \
    row); fit time is the best of repeated fits on one core, and its ratio to the baseline's is measured in the same run \
    (<code>ssmctl bench fit</code> prints the same table).";

/// The fit-vs-time table's cells over one row of `fit_sloshing.table`.
const BENCH_CELLS: [&str; 6] = [
    "{{ r.setting }}",
    "{{ r.fit_ms | fixed(2) }}",
    "{{ r.ratio_vs_baseline | fixed(2) }}",
    "{{ r.nmte_test | num }}",
    "{{ r.dtw_nmte_test | num }}",
    "{% if r.stopped is none %}-{% else %}{{ r.stopped }}{% endif %}",
];

/// The summary value at `key` of `s`, or an error naming it.
fn key<'a>(s: &'a Value, key: &str) -> Result<&'a Value, String> {
    s.get(key).ok_or_else(|| format!("report: summary lacks `{key}`"))
}

/// A figure path at `key` of `v`, or an error naming it.
fn fig<'a>(v: &'a Value, key: &str) -> Result<&'a str, String> {
    v[key].as_str().ok_or_else(|| format!("report: figure `{key}` is not a path"))
}

/// Writes the sloshing section from the summary `s` (`page_sloshing`, `fit_sloshing`).
pub fn sloshing_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    let page = key(s, "page_sloshing")?;
    let setup = &page["setup"];
    rep.section(
        "fit-sloshing",
        "SSM fit of measured data: water sloshing decay",
        &p.html("fit-sloshing/intro", INTRO, setup)?,
    );
    if page.get("skipped_dir").is_some() {
        let dir = page["skipped_dir"].as_str().ok_or("report: page_sloshing.skipped_dir is not a path")?;
        rep.para(&format!("Skipped: data folder {} not found.", esc(dir)));
        return Ok(());
    }
    let fs = key(s, "fit_sloshing")?;
    let v = json!({
        "fit": page["fit"], "fit_ms": fs["fit_ms"], "reps": page["reps"], "nmte": fs["nmte_test"],
        "dtw": fs["dtw_nmte_test"], "eigenvalues": fs["eigenvalues"],
    });
    rep.para(&p.html("fit-sloshing/fit", &format!("{SIGNED}{FIT}"), &v)?);
    let figures = &page["figures"];
    rep.figure(fig(figures, "prediction")?, &p.text("fit-sloshing/prediction", PREDICTION_CAPTION, setup)?);
    rep.figure(fig(figures, "spectrum")?, &p.text("fit-sloshing/spectrum", SPECTRUM_CAPTION, setup)?);
    let bb = &page["backbone"];
    rep.para(&p.html("fit-sloshing/backbone", BACKBONE, bb)?);
    rep.figure(fig(bb, "figure")?, &p.text("fit-sloshing/backbone-caption", BACKBONE_CAPTION, bb)?);
    let frc = &page["frc"];
    rep.para(&p.html("fit-sloshing/frc", FRC, frc)?);
    rep.figure(fig(frc, "figure")?, &p.text("fit-sloshing/frc-caption", FRC_CAPTION, frc)?);
    rep.para(&p.html("fit-sloshing/bench-intro", BENCH_INTRO, page)?);
    let items: Vec<Value> = fs["table"]
        .as_array()
        .ok_or("report: fit_sloshing.table is not a list")?
        .iter()
        .map(|r| json!({ "r": r }))
        .collect();
    rep.table(
        &["setting", "fit [ms]", "x baseline", "test NMTE", "test DTW-NMTE", "stopped"],
        &p.rows("fit-sloshing/bench-row", &BENCH_CELLS, &items)?,
    );
    if !page["export"].is_null() {
        rep.para(&p.html("fit-sloshing/export", EXPORT, &page["export"])?);
    }
    Ok(())
}

/// The backbone curve of the recommended sloshing model: instantaneous damping ratio and
/// frequency against the amplitude of x (through the normal-form transformation and the
/// manifold), up to the largest |x| of the training data; `summary.json` key `backbone`:
/// `{"sloshing": [{"amplitude", "freq_rad_s", "damping_ratio"}, ...]}`. Returns the paragraph's
/// values: the curve's ends and the figure.
fn backbone_values(rep: &mut Report, m: &ssm::SsmModel, train: &[TimeSeries]) -> Result<Value, Box<dyn Error>> {
    let amp_max = train.iter().flat_map(|t| t.x.iter()).fold(0.0_f64, |a, v| a.max(v.abs()));
    let opts = BackboneOptions { points: 51, ..BackboneOptions::new(0, amp_max) };
    let curves = backbone(m, &opts)?;
    let fig = "fig/sloshing_backbone.png";
    crate::draw::backbone::backbone_figure(
        &rep.dir().join(fig),
        "sloshing",
        &curves,
        "amplitude of x [% tank width]",
        &[],
    )?;
    let pts = &curves[0].points;
    let (first, last) = (pts[0], pts[pts.len() - 1]);
    let end = |p: &ssm::backbone::BackbonePoint| {
        json!({ "amplitude": p.amplitude, "freq_hz": p.freq_rad_s / std::f64::consts::TAU,
                "damping_pct": 100.0 * p.damping_ratio })
    };
    let v = json!({ "first": end(&first), "last": end(&last), "figure": fig });
    let list: Vec<Value> = pts
        .iter()
        .map(|p| json!({"amplitude": p.amplitude, "freq_rad_s": p.freq_rad_s, "damping_ratio": p.damping_ratio}))
        .collect();
    rep.summary.insert("backbone".into(), json!({ "sloshing": list }));
    Ok(v)
}

/// The forced response curve of the recommended sloshing model (`ssm::frc`), forcing
/// calibrated at an ILLUSTRATIVE point (no forced measurement is part of the data): amplitude
/// 1 % of the tank width at 1.03 times the linear frequency, above resonance where the
/// softening curve is single-valued. Model range: the largest |x| of the training data.
/// `summary.json` key `frc`: `{"sloshing": {"calibration": {"freq_rad_s", "amplitude",
/// "rho", "forcing"}, "branches": [{"stable", "freq_rad_s", "amplitude", "rho"}, ...], ...}}`.
/// Returns the paragraph's values: the calibration, the peak, the unstable branches, the figure.
fn frc_values(rep: &mut Report, m: &ssm::SsmModel, train: &[TimeSeries]) -> Result<Value, Box<dyn Error>> {
    use ssm::frc::{Calibration, FrcOptions, frc};
    let amp_max = train.iter().flat_map(|t| t.x.iter()).fold(0.0_f64, |a, v| a.max(v.abs()));
    let w0 = m.eigenvalues_ct().first().map_or(0.0, |e| e.1.abs());
    let cal = Calibration { freq_rad_s: CAL_RATIO * w0, amplitude: CAL_AMPLITUDE };
    let opts = FrcOptions { amplitude_max: Some(amp_max), ..FrcOptions::new(0) };
    let curve = frc(m, &opts, cal, SWEEP.0 * w0, SWEEP.1 * w0, 200)?;
    let bb = backbone(m, &BackboneOptions { points: 51, ..BackboneOptions::new(0, amp_max) })?;
    let fig = "fig/sloshing_frc.png";
    crate::draw::frc::frc_figure(
        &rep.dir().join(fig),
        "sloshing: forced response",
        &curve,
        bb.first(),
        "amplitude of x [% tank width]",
    )?;
    let (mut peak_f, mut peak_a) = (0.0, 0.0);
    for b in curve.branches.iter().filter(|b| b.stable) {
        for (f, a) in b.freq_rad_s.iter().zip(&b.amplitude) {
            if *a > peak_a {
                (peak_f, peak_a) = (*f, *a);
            }
        }
    }
    let unstable = curve.branches.iter().filter(|b| !b.stable).count();
    let v = json!({
        "amplitude": cal.amplitude, "freq_rad_s": cal.freq_rad_s, "ratio": CAL_RATIO,
        "forcing": curve.calibration.forcing, "peak_amplitude": peak_a, "peak_freq_rad_s": peak_f, "unstable": unstable,
        "figure": fig,
    });
    let mut frc = crate::fit_command::frc_json(&curve, "x")?;
    frc["calibration_illustrative"] = json!(true);
    rep.summary.insert("frc".into(), json!({ "sloshing": frc }));
    Ok(v)
}

/// The scene of the exported Furuta model and its blob's file name.
pub const FURUTA_SCENE: &str = "furuta-quant-dt25";
pub const FURUTA_BLOB: &str = "furuta-quant-dt25-rbf100.bin";

/// Fits an RBF model to a simulated Furuta theta series and writes its device blob.
pub fn furuta_blob(rep: &mut Report, quick: bool) -> Result<(), Box<dyn Error>> {
    let s = SceneBuilder::load(FURUTA_SCENE)?.periods(if quick { 1500 } else { 4000 }).build()?;
    let tr = simulate(&s, None)?;
    let ts = TimeSeries::new("theta", tr.t.clone(), tr.primary())?;
    let o = FitOptions {
        dim: 4,
        embed: 9,
        shift: 1,
        manifold_order: 2,
        dyn_order: 1,
        dynamics: Dynamics::Rbf { centers: 100 },
        ridge: Ridge::Fixed(1e-10),
        linear_anchor: None,
        anchor_joint: false,
    };
    let m = fit(std::slice::from_ref(&ts), &o)?;
    let blob = encode(&to_device_model(&m, s.controller_config())?)?;
    crate::output::write_atomic(&rep.dir().join(FURUTA_BLOB), &blob)?;
    let centres = match o.dynamics {
        Dynamics::Rbf { centers } => centers,
        _ => 0,
    };
    let v =
        json!({ "dim": o.dim, "centres": centres, "scene": FURUTA_SCENE, "file": FURUTA_BLOB, "bytes": blob.len() });
    rep.summary.insert("exported_blobs".into(), json!(["sloshing-rbf50.bin", FURUTA_BLOB]));
    rep.summary.insert("page_furuta_blob".into(), v);
    furuta_blob_render(rep, &Value::Object(rep.summary.clone()))
}

/// Writes the sloshing section's page from the summary `s`: the sloshing fit
/// ([`sloshing_render`]) and the Furuta blob's paragraph that ends it ([`furuta_blob_render`]).
pub fn sloshing_page_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    sloshing_render(rep, s)?;
    furuta_blob_render(rep, s)
}

/// Writes the Furuta blob's paragraph (the end of the sloshing section) from the summary `s`
/// (`page_furuta_blob`).
pub fn furuta_blob_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    rep.para(&html("furuta-blob", FURUTA_EXPORT, key(s, "page_furuta_blob")?)?);
    Ok(())
}

/// The QEMU machine and option the device table is counted under (`cargo xtask device-table`).
pub const QEMU_MACHINE: &str = "mps2-an386";
pub const QEMU_ICOUNT: &str = "-icount shift=7";
/// The firmware's prediction call whose error the f32-vs-f64 table gives (`data::HORIZON` steps).
pub const PREDICT_CALL: &str = "predict(12)";

/// The device section's introduction over the QEMU machine and option.
const DEVICE_INTRO: &str = "Instructions per call on the Cortex-M4F (QEMU {{ machine }}, <code>{{ icount }}</code>, \
    SysTick: exact and repeatable counts, not cycles), and the prediction error of each sqrt flavour against the host's \
    f64 evaluation of the same model.";

/// Each firmware configuration's flash and static RAM from the device table, with their shares
/// of the linked memory map in per cent (none where a capacity is missing or zero).
fn size_values(v: &Value) -> Vec<Value> {
    let rows = v.get("firmware_sizes").and_then(Value::as_array).map_or(&[][..], Vec::as_slice);
    rows.iter()
        .map(|r| {
            let n = |k: &str| r.get(k).and_then(Value::as_u64);
            let pct = |a: Option<u64>, b: Option<u64>| match (a, b) {
                (Some(a), Some(b)) if b > 0 => Some(100.0 * a as f64 / b as f64),
                _ => None,
            };
            json!({
                "config": r.get("config"),
                "flash_bytes": n("flash_bytes"),
                "flash_pct": pct(n("flash_bytes"), n("flash_capacity")),
                "ram_bytes": n("ram_bytes"),
                "ram_pct": pct(n("ram_bytes"), n("ram_capacity")),
            })
        })
        .collect()
}

/// Report section: the device cost table measured under QEMU (`cargo xtask device-table`
/// writes `qemu/target/device-table.json`; the host cannot count Cortex-M instructions), and
/// the processor-in-the-loop run. Summary keys `device` (the table as read), `pil` and
/// `page_device` (the QEMU settings, the figure and the PIL run's page values); the page is
/// written from them ([`device_render`]).
pub fn device_section(rep: &mut Report, table: &Path) -> Result<(), Box<dyn Error>> {
    let mut page = json!({ "machine": QEMU_MACHINE, "icount": QEMU_ICOUNT, "predict_call": PREDICT_CALL, "figure": null,
                "coordinates": [] });
    match infile::read_text(table, infile::MAX_REPORT_INPUT_BYTES) {
        Err(_) => {
            rep.summary.insert("device".into(), json!({"missing": table.display().to_string()}));
        }
        Ok(text) => {
            let v: Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", table.display()))?;
            page["coordinates"] = Value::Array(coordinate_values(&v));
            page["sizes"] = Value::Array(size_values(&v));
            // Plot: instructions per predictor step against centres, one line per sqrt flavour.
            let mut by: std::collections::BTreeMap<String, Vec<(f64, f64)>> = Default::default();
            for r in v.get("predictor").and_then(Value::as_array).into_iter().flatten() {
                if let (Some(k), Some(sq), Some(n)) = (
                    r.get("centers").and_then(Value::as_f64),
                    r.get("sqrt").and_then(Value::as_str),
                    r.get("instructions").and_then(Value::as_f64),
                ) {
                    by.entry(sq.to_string()).or_default().push((k, n));
                }
            }
            if !by.is_empty() {
                let colors = [RGBColor(20, 60, 160), RED, RGBColor(30, 140, 60), BLACK];
                let series: Vec<Series<'_>> = by
                    .iter()
                    .zip(colors.iter().cycle())
                    .map(|((name, pts), c)| Series { name, points: pts, color: *c })
                    .collect();
                let fig = "fig/device_predictor.png";
                plot::lines(
                    &rep.dir().join(fig),
                    "RBF predictor step on the Cortex-M4F (d = 6)",
                    "centres K",
                    "instructions per step",
                    &series,
                    (620, 340),
                )?;
                page["figure"] = json!(fig);
            }
            rep.summary.insert("device".into(), v);
        }
    }
    page["pil"] = pil_values(rep, &table.with_file_name("pil").join("summary.json"))?;
    rep.summary.insert("page_device".into(), page);
    device_render(rep, &Value::Object(rep.summary.clone()))
}

/// Writes the device section from the summary `s` (`device`, `pil`, `page_device`).
pub fn device_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let page = key(s, "page_device")?;
    rep.section("device", "What accuracy costs in time: on the device", &html("device/intro", DEVICE_INTRO, page)?);
    let v = key(s, "device")?;
    if let Some(missing) = v.get("missing").and_then(Value::as_str) {
        rep.para(&format!(
            "No device table at {}: run <code>cargo xtask device-table</code> (builds the firmware, runs it in QEMU) and \
             rerun the report.",
            esc(missing)
        ));
        return pil_render(rep, s);
    }
    let g = |k: &str| v.get(k).and_then(Value::as_f64).map_or("-".to_string(), |x| format!("{x:.0}"));
    let pd = v
        .get("controller_step_instructions_int_pd")
        .and_then(Value::as_f64)
        .map_or(String::new(), |x| format!(" ({x:.0} for PD without integral action)"));
    rep.para(&format!(
        "Controller step: integer {}{pd} instructions, f32 {} , f64 (software double) {}. Firmware flash {} B, static RAM {} B.",
        g("controller_step_instructions_int"),
        g("controller_step_instructions_float"),
        g("controller_step_instructions_f64"),
        g("flash_bytes"),
        g("ram_bytes")
    ));
    let by_n = page["coordinates"].as_array().ok_or("report: page_device.coordinates is not a list")?;
    if !by_n.is_empty() {
        rep.para(
            "Integer controller step by number of measured coordinates (encoders): with the configuration known when \
             the firmware is built, and decoded at run time from the model blob as the processor-in-the-loop firmware \
             has it.",
        );
        let rows = Prose::new().rows("device/coordinates", &COORDINATE_CELLS, by_n)?;
        rep.table(&["coordinates", "instructions / step", "run-time configuration"], &rows);
    }
    let rows: Vec<Vec<String>> = v
        .get("predictor")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .map(|r| {
                    let f = |k: &str| r.get(k).map_or("-".to_string(), |x| x.to_string().trim_matches('"').to_string());
                    vec![f("centers"), f("sqrt"), f("instructions"), f("per_center"), f("rel_error")]
                })
                .collect()
        })
        .unwrap_or_default();
    rep.table(&["centres", "sqrt", "instructions / step", "per centre", "rel. error vs f64"], &rows);
    if let Some(sizes) = page.get("sizes").and_then(Value::as_array).filter(|s| !s.is_empty()) {
        let rows: Vec<Vec<String>> = sizes
            .iter()
            .map(|r| {
                let cell = |bytes: &str, share: &str| match (r.get(bytes), r.get(share).and_then(Value::as_f64)) {
                    (Some(b), Some(p)) => format!("{b} ({p:.1} %)"),
                    (Some(b), None) => b.to_string(),
                    (None, _) => "-".to_string(),
                };
                vec![
                    r.get("config").and_then(Value::as_str).unwrap_or("?").to_string(),
                    cell("flash_bytes", "flash_pct"),
                    cell("ram_bytes", "ram_pct"),
                ]
            })
            .collect();
        rep.para("Flash and static RAM per firmware configuration (share of the linked memory map):");
        rep.table(&["configuration", "flash [B]", "static RAM [B]"], &rows);
    }
    // f32 against f64 where it matters: the same RBF kernel with a generic scalar.
    let scalar_rows: Vec<Vec<String>> = v
        .get("predictor_f32_vs_f64")
        .and_then(Value::as_array)
        .map(|a| {
            a.iter()
                .map(|r| {
                    let f = |k: &str| {
                        r.get(k)
                            .filter(|x| !x.is_null())
                            .map_or("-".to_string(), |x| x.to_string().trim_matches('"').to_string())
                    };
                    vec![f("centers"), f("scalar"), f("instructions"), f("per_center"), f("vs_f32"), f("rel_error")]
                })
                .collect()
        })
        .unwrap_or_default();
    if !scalar_rows.is_empty() {
        rep.para(&format!(
            "f32 or f64: the Cortex-M4F's FPU is single precision only, so f64 arithmetic runs in software \
             (compiler-builtins' double routines, <code>libm::sqrt</code>). The same RBF step (the library's \
             operation order, generic scalar, the dimension of the figure below) counted both ways; the error is that of <code>{}</code> against \
             the host's f64 evaluation of the same model.",
            esc(page["predict_call"].as_str().ok_or("report: page_device.predict_call is not a string")?)
        ));
        rep.table(
            &["centres", "scalar", "instructions / step", "per centre", "x f32", "rel. error vs f64"],
            &scalar_rows,
        );
    }
    if let Some(fig) = page["figure"].as_str() {
        rep.figure(fig, "Instructions per predictor step against the number of centres, per sqrt flavour");
    }
    pil_render(rep, s)
}

/// The processor-in-the-loop result (`cargo xtask pil` writes `qemu/target/pil/summary.json`):
/// summary key `pil`; returns the page's values (`null` when the run is missing).
fn pil_values(rep: &mut Report, path: &Path) -> Result<Value, Box<dyn Error>> {
    let Ok(text) = infile::read_text(path, infile::MAX_REPORT_INPUT_BYTES) else {
        rep.summary.insert("pil".into(), json!({"missing": path.display().to_string()}));
        return Ok(Value::Null);
    };
    let v: Value = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    // The blob the run flashed is part of the report's exported models.
    let blob = path.with_file_name("model.bin");
    let has_blob = blob.is_file();
    if has_blob {
        let bytes =
            infile::read_bytes(&blob, infile::MAX_BLOB_BYTES).map_err(|e| format!("{}: {e}", blob.display()))?;
        crate::output::write_atomic(&rep.dir().join("pil-model.bin"), &bytes)?;
        if let Some(Value::Array(list)) = rep.summary.get_mut("exported_blobs") {
            list.push(json!("pil-model.bin"));
        }
    }
    rep.summary.insert(
        "pil".into(),
        json!({"periods": v.get("periods"), "codes_identical": v.get("codes_identical"),
               "host_sim_codes_identical": v.get("host_sim_codes_identical"), "noise": v.get("noise"),
               "max_pred_rel_diff": v.get("max_pred_rel_diff"), "source": path.display().to_string()}),
    );
    Ok(json!({
        "predictions_compared": v.get("predictions_compared"), "round_trips_per_s": v.get("round_trips_per_s"),
        "blob": has_blob,
    }))
}

/// Writes the processor-in-the-loop paragraph from the summary `s` (`pil`, `page_device.pil`).
fn pil_render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let v = key(s, "pil")?;
    if let Some(missing) = v.get("missing").and_then(Value::as_str) {
        rep.para(&format!("No processor-in-the-loop run at {}: run <code>cargo xtask pil</code>.", esc(missing)));
        return Ok(());
    }
    let page = &key(s, "page_device")?["pil"];
    // A value as the run's summary.json writes it, `-` when absent.
    let f = |v: &Value, k: &str| v.get(k).filter(|x| !x.is_null()).map_or("-".to_string(), |x| x.to_string());
    rep.para(&format!(
        "Processor in the loop (plant on the host, integer controller and RBF predictor in QEMU over the emulated UART, \
         framed and CRC-checked): {} periods, control codes identical to the host-only controller: {}, predictions \
         compared: {}, max relative prediction difference vs the host's f32 evaluation: {}, {} round trips/s. \
         The whole closed loop (encoder counts, codes, states) equals the host-only simulation of the scene{}: {}.",
        f(v, "periods"),
        f(v, "codes_identical"),
        f(page, "predictions_compared"),
        f(v, "max_pred_rel_diff"),
        page.get("round_trips_per_s").and_then(Value::as_f64).map_or("-".into(), |x| format!("{x:.0}")),
        v.get("noise").filter(|n| !n.is_null()).map_or(String::new(), |n| format!(
            " (sensor noise sigma {} rad, seed {}, the same draws)",
            n.get("sigma_theta").map_or("-".to_string(), |x| x.to_string()),
            n.get("seed").map_or("-".to_string(), |x| x.to_string())
        )),
        f(v, "host_sim_codes_identical")
    ));
    if page["blob"].as_bool() == Some(true) {
        rep.para("The model blob of this run is <code>pil-model.bin</code>.");
    }
    Ok(())
}
/// The integer step's cost per number of measured coordinates, from the device table's
/// `controller_step_instructions_int_by_coordinates` and `..._runtime_config` (empty when the
/// table predates them): `[{"n", "fixed", "runtime"}]` in increasing `n`.
fn coordinate_values(v: &Value) -> Vec<Value> {
    let Some(fixed) = v.get("controller_step_instructions_int_by_coordinates").and_then(Value::as_object) else {
        return Vec::new();
    };
    let runtime = v.get("controller_step_instructions_int_runtime_config");
    let mut keys: Vec<(u32, &String)> = fixed.keys().filter_map(|k| k.parse().ok().map(|n| (n, k))).collect();
    keys.sort();
    keys.into_iter()
        .map(|(n, k)| {
            let at = |x: Option<&Value>| x.and_then(Value::as_f64);
            json!({ "n": n, "fixed": at(fixed.get(k)), "runtime": at(runtime.and_then(|r| r.get(k))) })
        })
        .collect()
}

/// The cells of a [`coordinate_values`] row.
const COORDINATE_CELLS: [&str; 3] = ["{{ n }}", "{{ fixed | fixed_or(1, '-') }}", "{{ runtime | fixed_or(1, '-') }}"];
