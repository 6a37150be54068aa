//! The whole report's text against its values: every section rendered from a snapshot of the
//! quick report's summary and again with every value moved ([`prose::perturbed`]); a number
//! that stays put was typed into the text, not filled from a value.
//!
//! The snapshot (`tests/snapshots/report_values.json` of this crate: the section ids of the
//! quick report's page and the summary keys the rendered sections read) is refreshed from a
//! quick report by `UPDATE_SNAPSHOTS=1 SSMCTL_REPORT_DIR=DIR cargo test -p ssmctl --test
//! commands report::pages`, where `DIR` holds `ssmctl reproduce --quick --out DIR`.

use serde_json::{Map, Value};
use ssmctl::report::prose::{perturbed, unmoved};
use ssmctl::report::{
    Report, auto_table, bifurcations, chaos, esc, global, normal_form, own_plant, reproduce, sloshing, verdict,
};
use std::error::Error;
use std::path::{Path, PathBuf};

/// A section written from the summary.
pub(crate) type Render = fn(&mut Report, &Value) -> Result<(), Box<dyn Error>>;

/// The sections written from the summary: id, the summary keys they read, the writer.
const RENDERED: &[(&str, &[&str], Render)] = &[
    ("own-plant", &["own_plant"], |r, s| own_plant::render(r, &s["own_plant"])),
    ("portraits", &["portraits", "page_portraits", "torus_hopf_dt_ms"], bifurcations::portraits_render),
    (
        "fullsystem",
        &["page_fullsystem", "torus_30p8", "fast_cycle", "domain_of_attraction", "transient_3torus"],
        bifurcations::fullsystem_render,
    ),
    (
        "predictions",
        &["predictions", "predictions_spline", "page_predictions", "map_switch_dt_ms"],
        bifurcations::predictions_render,
    ),
    ("basin", &["basin", "page_basin"], global::basin_render),
    ("fit-auto", &["fit_auto"], |r, s| auto_table::render(r, &s["fit_auto"])),
    ("scenes", &["scenes"], reproduce::scenes_render),
    ("stability", &["stability"], reproduce::stability_render),
    ("chart", &["stability_chart", "page_chart"], reproduce::chart_render),
    ("accuracy-time-sim", &["bench_simulate", "page_bench"], reproduce::bench_render),
    ("parametric", &["parametric_setup", "linear_nf", "normal_form_table"], normal_form::render),
    (
        "equation",
        &[
            "page_equation",
            "equation_ssm",
            "heteroclinic_dt_ms",
            "torus_hopf_dt_ms",
            "torus_30p8",
            "map_switch_dt_ms",
            "map_sensitivity",
        ],
        global::equation_render,
    ),
    ("chaos-verdict", &["microchaos_verdict", "page_chaos_verdict"], verdict::render),
    // The sloshing, device and chaos pages (the furuta blob's paragraph ends the sloshing section).
    ("fit-sloshing", &["page_sloshing", "fit_sloshing", "page_furuta_blob"], sloshing::sloshing_page_render),
    ("device", &["device", "pil", "page_device"], sloshing::device_render),
    ("chaos-scale", &["chaos_scale", "page_chaos_scale"], chaos::scale_render),
    ("chaos", &["page_chaos"], chaos::render),
];

/// Sections whose text is not yet written from values, and why.
const NOT_YET: &[(&str, &str)] = &[("timings", "wall-clock times, not results: compare-report drops this section")];

/// String values copied into the text as they are (names, settings, messages): their digits
/// do not move with the numbers. `(summary path, why)`; `[]` stands for every item of a list,
/// `**` for any depth (a key at any depth below), and a list of strings at the end of a path
/// stands for its items. Only strings with a number in them are masked (`traj_1` is left as it
/// is, so that it is not masked inside `traj_12`).
const VERBATIM: &[(&str, &str)] = &[
    ("fit_auto.rows[].set", "a data set's name"),
    ("fit_auto.rows[].auto_describe", "the chosen fit setting, named by ssm::auto::Setting::describe"),
    ("fit_auto.rows[].grid_winner_describe", "the grid winner's setting, named by Setting::describe"),
    ("fit_auto.rows[].grid_missing", "a file path and the command that writes it"),
    ("fit_auto.rows[].ssmlearnpy", "SSMLearnPy's result as read from studies/results/auto/ssmlearnpy.json"),
    ("fit_auto.grid_command", "a command line"),
    ("fit_auto.sloshing_dir", "a folder path"),
    ("page_fullsystem.setup.scene", "a scene's name"),
    ("own_plant.chart.scene", "a scene's name"),
    ("own_plant.ssm.scene", "a scene's name"),
    ("scenes[].name", "a scene's name"),
    ("scenes[].effects[]", "a scene's effects with their settings, named by Scene::effect_names"),
    ("scenes[].stopped", "why a run stopped, a message"),
    ("stability[].scene", "a scene's name"),
    ("bench_simulate[].method", "an integrator with its setting, named by bench::label"),
    ("page_bench.scene", "a scene's name"),
    ("page_bench.baseline", "the baseline integrator with its setting, named by bench::label"),
    ("page_bench.elsewhere", "other programs' speeds quoted from MODEL.md, not measured by this program"),
    ("page_chaos_verdict.setup.quantized", "a scene's name"),
    ("page_chaos_verdict.setup.smooth", "a scene's name"),
    ("page_chaos_verdict.setup.noisy", "a scene's name"),
    ("microchaos_verdict.noisy_source", "where the noisy series comes from: a scene's or a recording's name"),
    ("microchaos_verdict.series[].name", "a series' name: a scene's or a recording's"),
    ("map_sensitivity.variants[].variant", "a training variant's name with its settings"),
    ("heteroclinic_dt_ms.map.linear.error", "why a search failed, a message"),
    ("heteroclinic_dt_ms.map.spline.error", "why a search failed, a message"),
    ("heteroclinic_dt_ms.full_system_connection.error", "why a search failed, a message"),
    ("heteroclinic_dt_ms.equation_map.by_order[].connection.error", "why a search failed, a message"),
    ("torus_hopf_dt_ms.equation_map.by_order[].error", "why a continuation failed, a message"),
    ("map_switch_dt_ms.equation_map.error", "why a search failed, a message"),
    ("page_equation.where.full_error", "why a search failed, a message"),
    ("map_sensitivity.variants[].connection.linear.error", "why a search failed, a message"),
    ("map_sensitivity.variants[].connection.spline.error", "why a search failed, a message"),
    ("map_sensitivity.variants[].torus.linear.error", "why a continuation failed, a message"),
    ("map_sensitivity.variants[].torus.spline.error", "why a continuation failed, a message"),
    ("page_sloshing.setup.folder", "a folder path"),
    ("page_sloshing.setup.train[]", "a run's name"),
    ("page_sloshing.setup.test", "a run's name"),
    ("page_furuta_blob.scene", "a scene's name"),
    ("page_furuta_blob.file", "a file name"),
    ("page_sloshing.export.file", "a file name"),
    ("page_device.machine", "QEMU's machine name"),
    ("page_device.icount", "QEMU's option, a setting of `cargo xtask device-table`"),
    ("page_device.predict_call", "the firmware's call, named with its horizon"),
    ("device.missing", "a file path"),
    ("pil.missing", "a file path"),
    ("chaos_cost.rows[].notes[]", "an estimator's notes"),
    ("flag_pipeline_fit.noisy_state_realizations.models[].model", "a model's name with its settings"),
    ("page_chaos.**.candidate", "a candidate model's name with its settings, as the study names it"),
    ("page_chaos.**.name", "a data set's, series', run's, system's or candidate's name"),
    ("page_chaos.**.train", "a training series' name"),
    ("page_chaos.**.test", "the held-out series' name"),
    ("page_chaos.**.best", "the names of the candidates closest to the data"),
    ("page_chaos.**.system", "a known chaotic system's name with its parameters"),
    ("page_chaos.**.systems", "known chaotic systems' names with their parameters"),
    ("page_chaos.**.what", "what a group of rows varies, as the study names it"),
    ("page_chaos.**.d5", "a diagnosis group's name, as the study names it"),
    ("page_chaos.**.d6", "a diagnosis group's name, as the study names it"),
    ("page_chaos.**.scan_group", "a diagnosis group's name, as the study names it"),
    ("page_chaos.**.seed_model", "a candidate model's name"),
    ("page_chaos.**.failed", "why a candidate failed, a message"),
    ("page_chaos.**.error", "why an analysis failed, a message"),
    ("page_chaos.**.notes", "an estimator's or a fit's notes"),
    ("page_chaos.**.note", "an estimator's note"),
];

/// String values written as whole table cells (names, settings, messages), masked only there:
/// their digits may equal a moved number elsewhere on the page. `(summary path, why)` as in
/// [`VERBATIM`].
const CELLS: &[(&str, &str)] = &[
    ("fit_sloshing.table[].setting", "the fit setting a row varies, named by the bench"),
    ("fit_sloshing.table[].stopped", "why a prediction stopped, a message"),
    ("device.predictor[].sqrt", "a sqrt flavour's name"),
    ("device.predictor_f32_vs_f64[].scalar", "a scalar type's name"),
    ("device.firmware_sizes[].config", "a firmware configuration's name"),
    ("page_device.sizes[].config", "a firmware configuration's name"),
    ("chaos_scale[].name", "a data set's name"),
    ("chaos_scale[].unit_name", "a unit's name"),
    ("chaos_scale[].rows[].note", "an estimator's note"),
    ("chaos_cost.rows[].kind", "a model kind's name"),
];

/// The numbers that may stay put, and why.
const STAYS: &[(&str, &str)] = &[("0", "an integer zero stays zero in `perturbed`, so that a branch on a count stays")];

fn snapshot_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/snapshots/report_values.json")
}

/// The snapshot from a quick report in `dir`: its section ids in page order, and the summary
/// keys [`RENDERED`] reads.
fn snapshot_from(dir: &Path) -> Value {
    let html = std::fs::read_to_string(dir.join("index.html")).expect("the report's index.html");
    let ids: Vec<String> =
        html.split("<h2 id=\"").skip(1).filter_map(|s| s.split('"').next()).map(str::to_string).collect();
    let summary: Map<String, Value> =
        serde_json::from_str(&std::fs::read_to_string(dir.join("summary.json")).expect("summary.json")).unwrap();
    let keys: Map<String, Value> = RENDERED
        .iter()
        .flat_map(|(_, keys, _)| keys.iter())
        .filter_map(|k| summary.get(*k).map(|v| (k.to_string(), v.clone())))
        .collect();
    serde_json::json!({"sections": ids, "summary": keys})
}

/// The strings at `path` (dot-separated keys, `[]` for every item of a list, `**` for any
/// depth; a list of strings at the end stands for its items) in `v`.
fn strings_at<'a>(v: &'a Value, path: &str, out: &mut Vec<&'a str>) {
    let (head, rest) = path.split_once('.').map_or((path, None), |(h, r)| (h, Some(r)));
    if head == "**" {
        let rest = rest.unwrap_or_default();
        strings_at(v, rest, out);
        let children: Vec<&Value> = match v {
            Value::Array(a) => a.iter().collect(),
            Value::Object(o) => o.values().collect(),
            _ => Vec::new(),
        };
        for c in children {
            strings_at(c, path, out);
        }
        return;
    }
    let (key, all) = head.strip_suffix("[]").map_or((head, false), |k| (k, true));
    let Some(x) = v.get(key) else { return };
    let items: Vec<&Value> = if all { x.as_array().map(|a| a.iter().collect()).unwrap_or_default() } else { vec![x] };
    for it in items {
        match (rest, it) {
            (Some(r), _) => strings_at(it, r, out),
            (None, Value::Array(a)) => out.extend(a.iter().filter_map(Value::as_str)),
            (None, _) => out.extend(it.as_str()),
        }
    }
}

/// `html` with the [`VERBATIM`] strings of `summary` masked, and its [`CELLS`] strings where
/// they are a whole table cell.
fn masked(html: &str, summary: &Value) -> String {
    let mut cells = Vec::new();
    for (path, _) in CELLS {
        strings_at(summary, path, &mut cells);
    }
    let html =
        cells.iter().fold(html.to_string(), |h, s| h.replace(&format!("<td>{}</td>", esc(s)), "<td>(verbatim)</td>"));
    let mut strings = Vec::new();
    for (path, _) in VERBATIM {
        strings_at(summary, path, &mut strings);
    }
    // Longest first, so a string inside another is not masked in part.
    strings.sort_by_key(|s| std::cmp::Reverse(s.len()));
    strings
        .iter()
        .filter(|s| !ssmctl::report::prose::numbers_in(s).is_empty())
        .fold(html, |h, s| h.replace(&esc(s), "(verbatim)").replace(*s, "(verbatim)"))
}

fn render(f: Render, summary: &Value) -> String {
    let dir = std::env::temp_dir().join(format!("ssmctl-pages-{}", std::process::id()));
    let mut rep = Report::new(&dir).unwrap();
    f(&mut rep, summary).unwrap();
    let html = rep.into_parts().0;
    masked(&html, summary)
}

/// The summary of the snapshot.
pub(crate) fn snapshot_summary() -> Value {
    let text = std::fs::read_to_string(snapshot_path()).expect("the report values snapshot");
    serde_json::from_str::<Value>(&text).unwrap()["summary"].clone()
}

/// The two checks of a section written by `f` from `summary`: the number at `pointer` (a
/// JSON pointer) changed to `to` puts `expect` on the page (and the old page lacks it), and
/// with every value moved no number of the page stays put. `Err` says which failed.
fn check_section(f: Render, summary: &Value, pointer: &str, to: Value, expect: &str) -> Result<(), String> {
    let a = render(f, summary);
    if a.contains(expect) {
        return Err(format!("`{expect}` already on the page:\n{a}"));
    }
    let mut one = summary.clone();
    *one.pointer_mut(pointer).ok_or_else(|| format!("no {pointer} in the values"))? = to;
    let b = render(f, &one);
    if !b.contains(expect) {
        return Err(format!("`{expect}` not on the page after {pointer} changed:\n{b}"));
    }
    let u: Vec<_> = unmoved(&a, &render(f, &perturbed(summary)))?
        .into_iter()
        .filter(|(_, n)| !STAYS.iter().any(|s| s.0 == n))
        .collect();
    if !u.is_empty() {
        return Err(format!("numbers typed into the text (position, number): {u:?}\n{a}"));
    }
    Ok(())
}

/// One check of [`check_section`]: what it checks, the writer, its values, the number's
/// pointer, its new value and the text that value puts on the page.
struct Check {
    what: &'static str,
    render: Render,
    values: fn() -> Value,
    pointer: &'static str,
    to: Value,
    expect: &'static str,
}

/// The sections' checks: the quick report's values (the snapshot), or made-up values for the
/// sections only the full report or a device run writes.
fn checks() -> Vec<Check> {
    use serde_json::json;
    use ssmctl::report::{bifurcations as bif, global as glob, reproduce as rp};
    let snap: fn() -> Value = snapshot_summary;
    let c = |what, render: Render, values, pointer, to, expect| Check { what, render, values, pointer, to, expect };
    vec![
        c(
            "chaos diagnosis: noisy-state realizations, a count",
            crate::report::chaos::noisy_state_render,
            crate::report::chaos::noisy_state_summary,
            "/flag_pipeline_fit/noisy_state_realizations/models/1/within",
            json!(5),
            "(verbatim) 5/8, Benettin",
        ),
        c(
            "chaos diagnosis: noisy-state realizations, a median",
            crate::report::chaos::noisy_state_render,
            crate::report::chaos::noisy_state_summary,
            "/flag_pipeline_fit/noisy_state_realizations/models/2/corr_dim/median",
            json!(9.876),
            "D2 9.88 (",
        ),
        c("scenes", rp::scenes_render, snap, "/scenes/0/max_abs_theta_late", json!(0.123456), "<td>0.1235</td>"),
        c(
            "stability",
            rp::stability_render,
            snap,
            "/stability/0/dominant/0/abs",
            json!(0.987654321),
            "<td>0.987654</td>",
        ),
        c("chart", rp::chart_render, snap, "/page_chart/gains/0", json!(17.25), "(17.25 V,"),
        c(
            "accuracy-time-sim",
            rp::bench_render,
            snap,
            "/bench_simulate/0/max_err_rad",
            json!(1.234e-5),
            "<td>1.23e-5</td>",
        ),
        c(
            "fit-auto",
            |r, s| auto_table::render(r, &s["fit_auto"]),
            snap,
            "/fit_auto/replicates",
            json!(77),
            "77 bootstrap replicates",
        ),
        c("parametric", normal_form::render, snap, "/linear_nf/0/fast_rate_fit", json!(-1.23456), "<td>-1.2346</td>"),
        c("predictions", bif::predictions_render, snap, "/predictions/0/nmte", json!(0.0123456), "<td>0.0123</td>"),
        c(
            "portraits",
            bif::portraits_render,
            snap,
            "/page_portraits/hopf",
            json!({"dt": 31.98766, "bracket": [31.9, 32.0], "rho": [0.1, 0.02], "eigenvalues": [[0.0, 1.0], [0.0, -1.0]],
                   "complex_pair": true, "frequency_hz": 0.5, "loses_stability": true}),
            "loses stability at dt = 31.9877 ms",
        ),
        c(
            "fullsystem",
            bif::fullsystem_render,
            snap,
            "/page_fullsystem/scan/runs",
            json!(987),
            "Small starts, full system: 987 runs",
        ),
        c(
            "bifurcation sensitivity (full report, made-up values)",
            bif::sensitivity_render,
            crate::report::bifurcations::sensitivity_values,
            "/page_bifsensitivity/max_rate_error",
            json!(0.0042),
            "within 0.42 %",
        ),
        c(
            "equation",
            glob::equation_render,
            snap,
            "/equation_ssm/bifurcations_by_order/0/saddle_connection_dt_ms",
            json!(31.23456),
            "<td>31.235</td>",
        ),
        c(
            "equation, the fitted map's training variants (full report, made-up variants)",
            glob::equation_render,
            crate::report::global::map_variant_values,
            "/map_sensitivity/variants/0/torus/linear/growth_onset",
            json!(31.7777),
            "onset 31.778</td>",
        ),
        c("basin", glob::basin_render, snap, "/basin/per_dt/0/map/disagreement", json!(0.4321), "<td>43.2 % ("),
        c(
            "chaos-verdict",
            verdict::render,
            snap,
            "/microchaos_verdict/period_map/open_loop_rate",
            json!(12.3456),
            "<td>12.3456</td>",
        ),
        c(
            "chaos-verdict, the conclusion",
            verdict::render,
            snap,
            "/microchaos_verdict/conclusion/zero_one_span_s",
            json!(123.4),
            "displacements over 123 s of data",
        ),
        c(
            "fit-sloshing",
            sloshing::sloshing_page_render,
            snap,
            "/fit_sloshing/nmte_test",
            json!(0.0421),
            "test NMTE 0.0421,",
        ),
        c(
            "device (made-up device table and PIL run)",
            sloshing::device_render,
            crate::report::sloshing::device_values,
            "/device/controller_step_instructions_int",
            json!(123.4),
            "integer 123 (",
        ),
        c(
            "chaos-scale",
            chaos::scale_render,
            snap,
            "/chaos_scale/0/rows/0/eps_units",
            json!(12.3456),
            "<td>12.346</td>",
        ),
        c(
            "chaos-cost (full report, made-up rows)",
            chaos::cost_render,
            crate::report::chaos::cost_values,
            "/chaos_cost/lle_data",
            json!(0.9876),
            "0.988 1/s.",
        ),
        c("chaos", chaos::render, snap, "/page_chaos/0/values/centers", json!(321), "(linear kernel, 321 centres)"),
    ]
}

/// Each section's checks ([`checks`]): one value moved shows on its page, and with every
/// value moved no number stays put. A failure names its check.
#[test]
fn each_section_follows_its_values() {
    let failures: Vec<String> = checks()
        .into_iter()
        .filter_map(|c| {
            check_section(c.render, &(c.values)(), c.pointer, c.to, c.expect).err().map(|e| format!("{}: {e}", c.what))
        })
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// Every section of the quick report is written from values or named in a list above with
/// why; with every value moved, no number of a written section stays put.
#[test]
fn every_number_of_the_report_follows_its_values() {
    if std::env::var_os("UPDATE_SNAPSHOTS").is_some() {
        let dir = std::env::var_os("SSMCTL_REPORT_DIR")
            .expect("UPDATE_SNAPSHOTS=1 needs SSMCTL_REPORT_DIR, a folder written by `ssmctl reproduce --quick`");
        let snap = snapshot_from(Path::new(&dir));
        ssmctl::output::write_atomic(&snapshot_path(), serde_json::to_string_pretty(&snap).unwrap().as_bytes())
            .unwrap();
    }
    let text = std::fs::read_to_string(snapshot_path()).expect("the report values snapshot");
    let snap: Value = serde_json::from_str(&text).unwrap();
    let known = |id: &str| RENDERED.iter().any(|r| r.0 == id) || NOT_YET.iter().any(|r| r.0 == id);
    let ids: Vec<&str> = snap["sections"].as_array().unwrap().iter().filter_map(Value::as_str).collect();
    let unknown: Vec<&&str> = ids.iter().filter(|id| !known(id)).collect();
    assert!(unknown.is_empty(), "sections neither written from values nor listed with why: {unknown:?}");
    let summary = &snap["summary"];
    let moved = perturbed(summary);
    let mut failures = Vec::new();
    for (id, _, f) in RENDERED {
        if !ids.contains(id) {
            failures.push(format!("{id}: not in the quick report's page (stale entry?)"));
            continue;
        }
        let (a, b) = (render(*f, summary), render(*f, &moved));
        match unmoved(&a, &b) {
            Err(e) => failures.push(format!("{id}: {e}")),
            Ok(u) => {
                let u: Vec<_> = u.into_iter().filter(|(_, n)| !STAYS.iter().any(|s| s.0 == n)).collect();
                if !u.is_empty() {
                    failures.push(format!("{id}: numbers typed into the text (position, number): {u:?}\n{a}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}
