use chaos_study::chaos_tables::*;
use chaos_study::microchaos::*;
use serde_json::json;
use ssmctl::report::chaos::*;
use ssmctl::report::prose::Prose;
use std::error::Error;

/// The HTML template `tpl` (named `name` in errors) over `values` ([`Prose::html`]).
pub(crate) fn html(name: &str, tpl: &str, values: &serde_json::Value) -> Result<String, Box<dyn Error>> {
    Ok(Prose::new().html(name, tpl, values)?)
}

/// Asserts that `template` over `values` moves every number when every value moves
/// ([`ssmctl::report::prose::perturbed`]), except numbers that are part of a string value (a
/// run, system or candidate name) and a zero count; returns the rendering.
pub(crate) fn assert_numbers_follow(name: &str, template: &str, values: &serde_json::Value) -> String {
    use ssmctl::report::prose::{numbers_in, perturbed, unmoved};
    fn strings(v: &serde_json::Value, out: &mut Vec<String>) {
        match v {
            serde_json::Value::String(s) => out.extend(numbers_in(s)),
            serde_json::Value::Array(a) => a.iter().for_each(|x| strings(x, out)),
            serde_json::Value::Object(o) => o.values().for_each(|x| strings(x, out)),
            _ => {}
        }
    }
    let p = Prose::new();
    let a = p.html(name, template, values).unwrap();
    let b = p.html(name, template, &perturbed(values)).unwrap();
    let mut names = Vec::new();
    strings(values, &mut names);
    // `perturbed` keeps a zero count at zero (so "none of them" keeps its branch): a "0" may stay.
    let typed: Vec<_> = unmoved(&a, &b).unwrap().into_iter().filter(|(_, n)| n != "0" && !names.contains(n)).collect();
    assert!(typed.is_empty(), "{name}: numbers typed into the text, not from values: {typed:?}\n{a}\n{b}");
    a
}

/// `lo to hi` of `v` with `p` decimals (one value when they agree, `-` when there is none).
fn span(v: &[f64], p: usize) -> String {
    // `+ 0.0` prints a negative zero as 0.
    let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x + 0.0), b.max(x + 0.0)));
    if v.is_empty() {
        "-".into()
    } else if format!("{lo:.p$}") == format!("{hi:.p$}") {
        format!("{lo:.p$}")
    } else {
        format!("{lo:.p$} to {hi:.p$}")
    }
}

/// The settings paragraphs: every number comes from the options, the targets or the
/// flag study's files; one value changed shows on the page.
#[test]
fn settings_paragraphs_follow_their_values() {
    let results = chaos_study::study_results::FlagResults::bundled().unwrap();
    let o = ChaosOptions::default();
    let intro = json!({ "scaling_tolerance": chaos::ScalingRule::default().tolerance, "centers": o.centers,
                        "poly_order": o.poly_order });
    let a = assert_numbers_follow("chaos/intro", INTRO, &intro);
    assert!(a.contains("within 10 % of their median") && a.contains("(linear kernel, 500 centres)"), "{a}");
    let mut one = intro.clone();
    one["centers"] = json!(321);
    let b = html("chaos/intro", INTRO, &one).unwrap();
    assert!(b.contains("(linear kernel, 321 centres)") && !b.contains("500"), "{b}");
    let es = chaos_study::model_selection::EvalSettings::default();
    let sel = json!({ "long_runs": es.long_runs, "region_factor": es.region_factor,
                      "targets": chaos::Targets::default(), "rollout_starts": 200 });
    let a = assert_numbers_follow("chaos/selection", SELECTION, &sel);
    assert!(a.contains("within 10 % of the data's exponent, Rosenstein within 5 %"), "{a}");
    let runs = json!({ "train": results.held_out.train_runs, "test": results.held_out.test_run });
    let a = assert_numbers_follow("chaos/search-intro", SEARCH_INTRO, &runs);
    assert!(a.contains("train traj_9 + traj_7, held out traj_8"), "{a}");
    let (ro, lo) = (chaos::reference::Rossler::default(), chaos::reference::Lorenz::default());
    let check = json!({ "embed": 6, "rossler": [ro.a, ro.b, ro.c], "lorenz": [lo.sigma, lo.rho, lo.beta] });
    let a = assert_numbers_follow("chaos/rosenstein-check", ROSENSTEIN_CHECK, &check);
    assert!(a.contains("Rössler (a = 0.2, b = 0.2, c = 5.7) and Lorenz (10, 28, 2.6667)"), "{a}");
    let models = json!({ "range": [0.43, 0.55], "models": 7, "rossler_x": 0.73, "lorenz_z": 1.02 });
    let a = assert_numbers_follow("chaos/rosenstein-models", ROSENSTEIN_MODELS, &models);
    assert!(a.contains("0.73 on Rössler x and 1.02 on Lorenz z"), "{a}");
    assert_numbers_follow("chaos/data-spread", DATA_SPREAD, &json!({ "runs": 10 }));
    let f = chaos_study::calibration::FLAG_SAMPLING;
    let cal = json!({ "flag": f, "flag_per_lag": f.lle * f.lag as f64 * f.dt });
    let a = assert_numbers_follow("chaos/calibration", CALIBRATION, &cal);
    assert!(a.contains("the flag's lag (11 samples)") && a.contains("(0.32 % of the"), "{a}");
    let says = json!({
        "calm_per_lag": 0.22, "models_ratio": [0.43, 0.55], "targets": chaos::Targets::default(),
        "calm": { "systems": ["Rössler", "Mackey-Glass tau = 30"], "corr_dim": [2.1, 2.7] },
        "chaotic": { "systems": ["Lorenz-96 n = 8"], "corr_dim": null },
        "s": { "calm_mean_range": [0.8, 1.1], "calm_segment_range": [0.5, 1.4], "calm_segment_sd_max": 0.2,
               "calm_noise_shift_max": 0.05, "chaotic_mean_range": [0.4, 0.9], "chaotic_segment_range": [0.3, 1.2],
               "chaotic_implied_exponent": [0.37, 0.83], "calm_implied_exponent": [0.3, 0.41] },
    });
    let a = assert_numbers_follow("chaos/calibration-says", CALIBRATION_SAYS, &says);
    assert!(a.contains("(Rössler, Mackey-Glass tau = 30; D2 2.1-2.7)") && a.contains("D2 -)"), "{a}");
    let theory = json!({ "window_ratio": WINDOW_RATIO, "diffusion_power": DIFFUSION_POWER });
    let a = assert_numbers_follow("chaos/separation", SEPARATION, &theory);
    assert!(a.contains("ln(2)") && a.contains("near 0.5 while"), "{a}");
    let scale = json!({ "embed": SCALE_EMBED, "references": KANTZ_REFERENCES, "neighbours": KANTZ_NEIGHBOURS,
                        "scales": SCALES });
    let a = assert_numbers_follow("chaos-scale/intro", SCALE_INTRO, &scale);
    assert!(a.contains("at most 2000 references with 50 neighbours each) at 8 log-spaced"), "{a}");
    assert!(
        assert_numbers_follow("chaos-cost/intro", COST_INTRO, &json!({ "dim": COST_DIM })).contains("dimension 6:")
    );
}

/// The estimator-bias paragraph over made-up values, with and without candidates close to
/// the data: every number follows them.
#[test]
fn bias_paragraph_follows_the_values() {
    let v = json!({
        "rows": 17, "best": ["k=4 d=4 c=250", "k=4 d=4 c=300 /x"], "best_count": 2, "data_corr_dim": 3.36,
        "d2": 0.3, "js": 0.02, "ratio": [0.43, 0.55], "exponent": [0.6, 0.77], "joint": [0.95, 1.05],
        "targets": chaos::Targets::default(), "inside": 3, "inside_close": 1,
    });
    let a = assert_numbers_follow("chaos/bias", BIAS, &v);
    assert!(
        a.contains("(D2 within 0.3 of 3.36, JS <= 0.02: k=4 d=4 c=250; k=4 d=4 c=300 /x) read 0.43 to 0.55"),
        "{a}"
    );
    assert!(a.contains("ratio in [0.950, 1.050]: 3 chaotic rows are in it, 1 of them"), "{a}");
    let mut none = v.clone();
    none["best_count"] = json!(0);
    let a = assert_numbers_follow("chaos/bias", BIAS, &none);
    assert!(a.contains("no chaotic candidate of the search matches the data's D2 (within 0.3) and PDFs (JS <= 0.02)."));
}

/// The pick paragraph over made-up values: a pick with each warning and none, and no pick;
/// every number follows the values, and the text is `model_selection::select`'s.
#[test]
fn pick_paragraph_follows_the_values() {
    let r = json!({ "name": "RBF 500 /1", "benettin": 0.0123, "benettin_err": 0.02, "benettin_2nd": -0.1,
                    "rosenstein": 0.31, "corr_dim": 2.5, "js": 0.0456, "rollout": 0.2, "failed": null,
                    "data": { "lle": 0.332, "corr_dim": 3.36, "corr_dim_err": 0.17 } });
    let pick = |met: &[&str], warning: &str| json!({ "r": r, "met_count": met.len(), "met": met, "targets": 4, "score": 3.21, "warning": warning });
    let v = |p: serde_json::Value| json!({ "set": "measured: flag", "pick": p, "failed": 2, "total": 7, "targets": chaos::Targets::default() });
    let a = assert_numbers_follow("chaos/pick", PICK, &v(pick(&["benettin", "js"], "data_chaotic")));
    let want = "measured: flag: picked RBF 500 /1. RBF 500 /1 meets 2 of 4 targets (Benettin within 10 %, JS within \
         bound) with normalized error 3.21: Benettin 0.012 1/s, Rosenstein 0.310 vs data 0.332 1/s, D2 2.500 vs \
         3.36 +- 0.17, JS 0.046; 2 of 7 candidates failed <b>Warning:</b> the data look chaotic (Rosenstein 0.332 \
         1/s) but the best model is not (Benettin 0.012 +- 0.020 1/s): its irregularity is not reproduced by its \
         own dynamics.";
    assert_eq!(a, want);
    let a = assert_numbers_follow("chaos/pick", PICK, &v(pick(&[], "model_chaotic")));
    assert!(a.contains("targets (none) with") && a.ends_with("but the data do not look so (Rosenstein 0.332 1/s)."));
    let a = assert_numbers_follow("chaos/pick", PICK, &v(pick(&["rosenstein", "corr_dim"], "none")));
    assert!(a.contains("(Rosenstein within 5 %, D2 within the data's error bar)") && a.ends_with("candidates failed"));
    let a = assert_numbers_follow("chaos/pick", PICK, &v(serde_json::Value::Null));
    assert!(a.ends_with(
        "picked none. all 7 candidates failed (escape, left the data's region or fit error) \
         <b>Warning:</b> no model: every candidate failed."
    ));
}

/// The false-nearest-neighbour paragraph over made-up values: every number follows them.
#[test]
fn fnn_paragraph_follows_the_values() {
    let row = |dim: usize, fnn: f64| json!({ "dim": dim, "singular_rel": 0.1, "fnn": fnn });
    let v = json!({
        "embed": 9, "shift": 1, "step": 4, "proj": [row(3, 0.123), row(4, 0.0456)], "dims": [3, 4],
        "ratio": 2.0, "max_fnn": 0.005, "max_dim": 8, "rule_dim": 6, "rows": [row(5, 0.0123), row(6, 0.0031)],
    });
    let a = assert_numbers_follow("chaos/fnn", FNN, &v);
    assert!(a.contains("(9 samples, shift 1, map step 4) has 12.3 %, 4.6 % false nearest neighbours"), "{a}");
    assert!(a.contains("exceeds 2 times the projected one) at d = 3, 4. The dimension rule"), "{a}");
    assert!(
        a.contains("at most 0.5 % false neighbours) gives d = 6: d = 5 (p = 11) 1.2 %, d = 6 (p = 13) 0.3 %."),
        "{a}"
    );
    let mut none = v.clone();
    none["rule_dim"] = json!(null);
    assert!(html("chaos/fnn", FNN, &none).unwrap().contains("gives no d up to 8: d = 5"));
}

/// The centre-set paragraph over the bundled results: every number follows the values.
#[test]
fn centre_set_paragraph_follows_the_results() {
    let results = chaos_study::study_results::FlagResults::bundled().unwrap();
    let fcs = results.held_out.centre_rows();
    let v = centre_set_values(&results.held_out, &fcs);
    let a = assert_numbers_follow("chaos/centre-sets", CENTRE_SETS, &v);
    let n = fcs.len();
    assert!(a.contains(&format!("one-step and multistep): {n} rows, ")), "{a}");
    let mut one = v.clone();
    one["c"]["rows"] = json!(987);
    assert!(html("chaos/centre-sets", CENTRE_SETS, &one).unwrap().contains("multistep): 987 rows"));
}

/// The diagnosis paragraph over the bundled rows: every number follows the values.
#[test]
fn diagnosis_paragraph_follows_the_rows() {
    let results = chaos_study::study_results::FlagResults::bundled().unwrap();
    let diag = results.known.diagnosis_rows();
    let noisy = noisy_state_values(&chaos_study::study_results::default_dir()).unwrap();
    let v = diagnosis_values(&results, &diag, 9, &noisy);
    let a = assert_numbers_follow("chaos/diagnosis", &format!("{SPAN}{NOISY_STATE}{DIAGNOSIS}"), &v);
    let g = &v["groups"]["d5"];
    assert!(a.contains(&format!("rows \"(b) d = 5\": {}/{},", g[0], g[1])), "{a}");
    assert!(a.contains("the whole 9-sample delay vector") && a.contains("keeps d = 4, whose rows"), "{a}");
}

/// The diagnosis paragraph's noisy-state part rendered from the summary, as the paragraph
/// renders it (`flag_pipeline_fit.noisy_state_realizations`).
pub(crate) fn noisy_state_render(
    rep: &mut ssmctl::report::Report,
    s: &serde_json::Value,
) -> Result<(), Box<dyn Error>> {
    let tpl = format!("{SPAN}{NOISY_STATE}{{{{ noisy_state(flag_pipeline_fit.noisy_state_realizations) }}}}");
    rep.para(&html("chaos/noisy-state", &tpl, s)?);
    Ok(())
}

/// The summary the noisy-state checks of `report::pages` move: the committed realizations.
pub(crate) fn noisy_state_summary() -> serde_json::Value {
    let noisy = noisy_state_values(&chaos_study::study_results::default_dir()).unwrap();
    json!({ "flag_pipeline_fit": { "noisy_state_realizations": noisy } })
}

/// The committed realizations are eight per model (the checks in `report::pages` move them).
#[test]
fn noisy_state_realizations_are_eight_per_model() {
    let s = noisy_state_summary();
    let noisy = &s["flag_pipeline_fit"]["noisy_state_realizations"];
    assert_eq!(noisy["realizations"], 8);
    assert!(noisy["models"].as_array().unwrap().iter().all(|m| m["n"] == 8), "{noisy}");
    assert_ne!(noisy["models"][1]["within"], 5, "the check in report::pages moves this count to 5");
}

/// Median and range by model over a made-up file (odd and even counts, a failed row); a
/// missing or empty file is an error naming it.
#[test]
fn noisy_state_values_group_by_model() {
    use chaos_study::study_results::{DiagRow, KnownData, KnownSystemResults, NOISE_REALIZATIONS, to_json};
    let dir = std::env::temp_dir().join(format!("chaos-noisy-state-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let e = noisy_state_values(&dir).unwrap_err().to_string();
    assert!(e.contains(NOISE_REALIZATIONS), "{e}");
    let row = |name: &str, b: f64, d2: Option<f64>| DiagRow {
        group: "g".into(),
        candidate: name.into(),
        scale: 1,
        noise_rel: 0.01,
        benettin: Some(b),
        rosenstein: Some(0.5),
        corr_dim: d2,
        js: Some(0.005),
        failed: d2.is_none().then(|| "escaped".into()),
    };
    let mut r = KnownSystemResults {
        produced_by: "ssmctl study s.toml".into(),
        data: KnownData { rosenstein: 0.9, corr_dim: 2.5, corr_dim_err: 0.1, exact: 1.0 },
        pipeline_check: Vec::new(),
        diagnosis: vec![
            row("state poly 4 noise seed 0", 1.0, Some(3.0)),
            row("state poly 4 noise seed 1", 0.5, Some(1.0)),
            row("state poly 4 noise seed 2", 1.05, Some(2.0)),
            row("state RBF 9 noise seed 0", 1.2, Some(2.0)),
            row("state RBF 9 noise seed 1", 0.98, Some(4.0)),
            row("state RBF 9 noise seed 2", 1.0, None),
        ],
    };
    std::fs::write(dir.join(NOISE_REALIZATIONS), to_json(&r).unwrap()).unwrap();
    let v = noisy_state_values(&dir).unwrap();
    assert_eq!((v["spec"].as_str(), &v["realizations"]), (Some("s.toml"), &json!(3)));
    let m = &v["models"];
    assert_eq!(
        (m[0]["model"].as_str(), &m[0]["n"], &m[0]["within"]),
        (Some("state poly 4 noise"), &json!(3), &json!(2))
    );
    assert_eq!((&m[0]["corr_dim"]["median"], &m[0]["corr_dim"]["range"]), (&json!(2.0), &json!([1.0, 3.0])));
    assert_eq!((&m[1]["failed"], &m[1]["corr_dim"]["median"]), (&json!(1), &json!(3.0)));
    assert_eq!(&m[0]["ratio"]["median"], &json!(1.0));
    r.diagnosis.clear();
    std::fs::write(dir.join(NOISE_REALIZATIONS), to_json(&r).unwrap()).unwrap();
    let e = noisy_state_values(&dir).unwrap_err().to_string();
    assert!(e.contains(NOISE_REALIZATIONS) && e.contains("no diagnosis rows"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The multistep paragraph over the bundled rows: every number follows the values.
#[test]
fn multistep_paragraph_follows_the_rows() {
    let results = chaos_study::study_results::FlagResults::bundled().unwrap();
    let diag = results.known.diagnosis_rows();
    let v = multistep_values(&results, &diag);
    let a = assert_numbers_follow("chaos/multistep", &format!("{SPAN}{MULTISTEP}"), &v);
    let c = &v["scan"][0];
    let text = format!(
        "name them): 1x the data, the flag's noise: multistep {}/{} within 10 %",
        c["multistep"][0], c["multistep"][2]
    );
    assert!(a.contains(&text) && a.contains("the rows \"d = 6 scan\" above"), "{a}");
    assert!(a.contains("on the known system's d = 6 fits") && a.contains("On the flag (d = 4, the flag's rule"), "{a}");
}

/// The validation paragraph over the bundled results: every number follows the values.
#[test]
fn validation_paragraph_follows_the_results() {
    let results = chaos_study::study_results::FlagResults::bundled().unwrap();
    let test_rows = results.held_out.centre_rows();
    let v = validation_values(&results, &test_rows).unwrap();
    let a = assert_numbers_follow("chaos/validation", VALIDATION, &v);
    let text = format!(
        "the {} centre-set rows fitted again on traj_9 + traj_7 and measured on traj_{}",
        v["c"]["rows"], v["run"]
    );
    assert!(a.contains(&text) && a.contains("best-ranked d = 4 models on traj_8"), "{a}");
    let mut one = v.clone();
    one["ensemble"]["js_pooled"] = json!(0.98765);
    assert!(html("chaos/validation", VALIDATION, &one).unwrap().contains("pooled long runs 0.9877 (members"));
}

/// The accuracy-vs-cost page's values (full report only) over made-up rows, for
/// [`crate::report::pages`]'s checks.
pub(crate) fn cost_values() -> serde_json::Value {
    let row = |kind: &str, setting: usize, lle: Option<f64>, notes: &[&str]| {
        json!({"kind": kind, "setting": setting, "lle_rosenstein": lle, "lle_abs_error": lle.map(|l| l - 0.33),
               "lle_benettin": 0.41, "pdf_js": 0.0123, "fit_s": 1.234, "step_us": 5.67, "fit_ratio": 1.0,
               "step_ratio": 2.5, "notes": notes})
    };
    json!({
        "page_chaos_cost": { "dim": COST_DIM, "found": true },
        "chaos_cost": { "name": "inverted flag", "lle_data": 0.332, "ssm_dim": 6,
                        "rows": [row("RBF", 250, Some(0.45), &[]), row("poly", 3, None, &["escaped at step 12"])] },
    })
}

/// The accuracy-vs-cost page notes missing flag data.
#[test]
fn cost_page_notes_missing_data() {
    let dir = std::env::temp_dir().join(format!("chaos-report-cost-{}", std::process::id()));
    let mut rep = ssmctl::report::Report::new(&dir).unwrap();
    cost_render(&mut rep, &json!({ "page_chaos_cost": { "dim": COST_DIM, "found": false } })).unwrap();
    assert!(rep.into_parts().0.contains("Inverted-flag data not found: skipped."));
    std::fs::remove_dir_all(&dir).ok();
}

/// The search narration is computed from the search table: with every value moved every
/// number moves, and a row changed changes the counts on the page.
#[test]
fn search_findings_follow_the_table() {
    let results = chaos_study::study_results::FlagResults::bundled().unwrap();
    let rows = &results.search.rows;
    let v = search_findings(rows, 4, FLAG_DIM);
    let a = assert_numbers_follow("chaos/search-findings", SEARCH_FINDINGS, &v);
    let step4 = v["steps"].as_array().unwrap().iter().find(|s| s["k"] == 4).unwrap().clone();
    let text = format!("k = 4: {} of {} chaotic", step4["chaotic"], step4["rows"]);
    assert!(a.contains(&text) && a.contains("data's Rosenstein 0.332 1/s"), "{a}");
    // One chaotic row at step 4 made to escape: one fewer chaotic, one more escaped.
    let mut search = rows.clone();
    let row = search.iter_mut().find(|r| r.candidate == "k=4 d=4 p=9 s=1 m=3 c=500 r=1e-8").unwrap();
    row.failed = Some("escaped".into());
    let w = search_findings(&search, 4, FLAG_DIM);
    let moved = w["steps"].as_array().unwrap().iter().find(|s| s["k"] == 4).unwrap();
    assert_eq!(moved["chaotic"].as_u64().unwrap() + 1, step4["chaotic"].as_u64().unwrap());
    assert_eq!(moved["failed"].as_u64().unwrap(), step4["failed"].as_u64().unwrap() + 1);
    let b = html("chaos/search-findings", SEARCH_FINDINGS, &w).unwrap();
    assert!(b.contains(&format!("k = 4: {} of {} chaotic", moved["chaotic"], moved["rows"])), "{b}");
}

/// The experiment-as-model paragraph over the bundled results: every number follows the
/// values, and the pieces' shared samples are computed from their starts.
#[test]
fn experiment_paragraph_follows_the_results() {
    let results = chaos_study::study_results::FlagResults::bundled().unwrap();
    let rows = results.held_out.centre_rows();
    let v = experiment_values(&results, &rows).unwrap();
    let a = assert_numbers_follow("chaos/experiment-as-model", EXPERIMENT_AS_MODEL, &v);
    let f = results.experiment.rows.iter().filter(|r| r.run == v["fragile"]["run"]).collect::<Vec<_>>();
    let (p, q) = (f[f.len() - 2], f[f.len() - 1]);
    let share = (p.start + p.len - q.start) as f64 / p.len as f64;
    assert!(a.contains(&format!("share {:.0} % of their samples", 100.0 * share)), "{a}");
    assert!(a.contains("fitted on traj_9 + traj_7") && a.contains("pieces (1973 samples at step 4)"), "{a}");
    let mut one = v.clone();
    one["fragile"]["share"] = json!(0.5);
    let b = html("chaos/experiment-as-model", EXPERIMENT_AS_MODEL, &one).unwrap();
    assert!(b.contains("share 50 % of their samples"), "{b}");
}

/// The pipeline check's introduction over made-up statistics: every number follows.
#[test]
fn pipeline_check_intro_follows_the_values() {
    use chaos_study::flag_pipeline::{FLAG_LAYOUT, KnownStats, SegmentStats};
    let k = KnownStats {
        system: "Lorenz-96 (4 sites, F = 17.7)".into(),
        dt: 0.0333,
        step_dt: 0.1333,
        lag: 11,
        theiler: 40,
        corr_dim: 3.1,
        corr_dim_err: 0.2,
        rosenstein: 0.4,
        exact: 0.5,
        exact_err: 0.01,
        per_lag: 0.7,
        noise_rel: 0.0032,
    };
    let seg = SegmentStats {
        corr_dims: vec![Some(3.0), None, Some(3.2)],
        rosensteins: vec![Some(0.3), Some(0.45), None],
        lags: vec![11, 12, 11],
        corr_dim_mean: Some(3.1),
        corr_dim_sd: Some(0.14),
    };
    let v = json!({
        "system": k, "pieces": seg, "segments": 3, "layout": FLAG_LAYOUT, "scales": [1, 3, 10],
        "ratios": [0.6, 0.9, null],
        "flag": { "lag": 11, "theiler": 38, "per_lag": 0.49 },
        "fit": { "dim": 4, "embed": 9, "shift": 1, "manifold_order": 3 },
    });
    let a = assert_numbers_follow("chaos/pipeline-check", PIPELINE_CHECK, &v);
    assert!(a.contains("or 3 and 10 times longer") && a.contains("(the flag: 11 / 38)"), "{a}");
    assert!(a.contains("D2 reads 3.10 ± 0.14 (3.00, -, 3.20) and Rosenstein / exact 0.60, 0.90, -."), "{a}");
}

#[test]
fn pil_record_theta_loads_and_bad_files_are_named() {
    let dir = std::env::temp_dir().join(format!("chaos-report-pil-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("run1")).unwrap();
    let p = dir.join("run1/record.csv");
    let mut text = String::from("t_s,theta_rad,phi_rad,theta_meas_rad,code,prediction\n");
    for k in 0..50 {
        text.push_str(&format!("{},{},0,0,0,NaN\n", k as f64 * 0.025, 0.01 * (k as f64).sin()));
    }
    std::fs::write(&p, text).unwrap();
    let ts = pil_plant_theta(&p).unwrap();
    assert_eq!(ts.x.len(), 50);
    assert_eq!(ts.x[3], 0.01 * 3f64.sin());
    std::fs::write(&p, "t_s,theta_meas_rad\n0,1\n").unwrap();
    let e = pil_plant_theta(&p).unwrap_err().to_string();
    assert!(e.contains("not a PIL record"), "{e}");
    std::fs::write(&p, "t_s,theta_rad,phi_rad\n0,abc,0\n").unwrap();
    let e = pil_plant_theta(&p).unwrap_err().to_string();
    assert!(e.contains("line 2") && e.contains("theta_rad"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The diagnosis and multistep paragraphs quote the committed rows' ranges: each range
/// printed is the rows' own (no number typed into the text).
#[test]
fn diagnosis_paragraphs_quote_the_rows() {
    use chaos_study::flag_pipeline::{CHOSEN, FLAG_LAYOUT, known_stats};
    let results = chaos_study::study_results::FlagResults::bundled().unwrap();
    let (_, series) = known_stats(&CHOSEN, &FLAG_LAYOUT, 1, 1000.0).unwrap();
    let dir = std::env::temp_dir().join(format!("chaos-report-diag-{}", std::process::id()));
    let mut rep = ssmctl::report::Report::new(&dir).unwrap();
    let mut page = Page::default();
    let o = ChaosOptions::default();
    page.para("chaos/intro", json!({ "scaling_tolerance": 0.1, "centers": o.centers, "poly_order": o.poly_order }));
    flag_pipeline_fit(&mut rep, &mut page, &results, &series).unwrap();
    render(&mut rep, &json!({ "page_chaos": page.blocks })).unwrap();
    let html = rep.into_parts().0;
    eprintln!("{html}");
    let diag = results.known.diagnosis_rows();
    let state: Vec<f64> = diag
        .iter()
        .filter(|(w, n, _)| w == "(c) true state" && *n == 0.0)
        .filter_map(|(_, _, r)| r.benettin_over_exact)
        .collect();
    assert!(html.contains(&format!("noise-free ({} of exact, JS", span(&state, 2))), "{html}");
    let refined_seeds: Vec<f64> = diag
        .iter()
        .filter(|(_, _, r)| {
            r.candidate.contains("RBF 250") && r.candidate.contains(" ms ") && r.candidate.contains(" seed ")
        })
        .filter_map(|(_, _, r)| r.benettin_over_exact)
        .collect();
    assert_eq!(refined_seeds.len(), 2);
    assert!(html.contains(&format!("the refined one gives {} of exact", span(&refined_seeds, 2))), "{html}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The pipeline check's conclusion, built from the bundled rows and the system's
/// statistics, reads as the report prints it; a row moved moves its numbers.
#[test]
fn pipeline_conclusion_follows_the_values() {
    use chaos_study::flag_pipeline::{CHOSEN, FLAG_LAYOUT, known_stats, segment_stats, summarize};
    let results = chaos_study::study_results::FlagResults::bundled().unwrap();
    let (k, _) = known_stats(&CHOSEN, &FLAG_LAYOUT, 1, 4000.0).unwrap();
    let seg = segment_stats(&CHOSEN, k.dt, &FLAG_LAYOUT, 8).unwrap();
    let rows = results.known.check_rows();
    let summaries: Vec<_> = [1, 3, 10].iter().map(|&s| summarize(&rows, s)).collect();
    let fit = chaos_study::flag_pipeline::flag_like_candidates(FLAG_LAYOUT.step, &[])[0].fit;
    let v = pipeline_conclusion(&rows, &summaries, &k, &seg, &fit);
    let text = assert_numbers_follow("chaos/pipeline-does", &format!("{SEP}{PIPELINE_DOES}"), &v);
    let was = "So on data made by a smooth system of exactly 4 dimensions, with the flag's sampling, lengths, \
         noise, D2 (3.0 over pieces) and chaos per lag, the flag's pipeline does not recover the system: most \
         candidates escape or are not chaotic (5 of 6, 4 of 6 and 3 of 4 at 1x, 3x and 10x the flag's \
         training data), the chaotic ones read 0.06 to 1.31 times the exact exponent (a different attractor \
         at every RBF size and data amount), none has its exponent within 10 % together with the data's D2 \
         and PDFs, and none meets the targets. 3 and 10 times more training data do not make it better (the \
         chaotic models' Benettin / exact: 1.31 at 1x; 0.79 and 0.06 at 3x; 0.55 at 10x). The Rosenstein \
         number of one held-out series is no firmer a reference here than on the flag: 1.10 of the exact \
         exponent on the held-out piece, 0.29 to 0.85 on the others. What this measures: the failure on the \
         flag is what this pipeline does on data like the flag's even when a smooth 4-dimensional model of \
         the data exists (the system itself, a 4-D flow, seen in a delay embedding of 9 samples, Takens' \
         bound for that dimension, with SSM dimension 4: the flag settings); it is a limit of the fit \
         (one-step ridge regression on data this sparse and chaotic lands on a fragile, size-dependent \
         attractor), not evidence that no smooth reduced model of the flag exists, and not cured by the \
         amount of data.";
    assert!(text.ends_with(was), "{text}");
    assert!(
        text.starts_with("What the pipeline does on it: with 1x the flag's training data 1 of 6 candidates"),
        "{text}"
    );
    // One value moved, the text follows: the chaotic row at 10x with Benettin 1.5 1/s.
    let mut moved = results.known.clone();
    let r = moved.pipeline_check.iter_mut().find(|r| r.scale == 10 && r.benettin == Some(0.517)).unwrap();
    r.benettin = Some(1.5);
    let rows = moved.check_rows();
    let summaries: Vec<_> = [1, 3, 10].iter().map(|&s| summarize(&rows, s)).collect();
    let v = pipeline_conclusion(&rows, &summaries, &k, &seg, &fit);
    let text = html("chaos/pipeline-does", &format!("{SEP}{PIPELINE_DOES}"), &v).unwrap();
    let q = format!("{:.2}", 1.5 / k.exact);
    assert!(text.contains(&format!("0.06 to {q} times")) && text.contains(&format!("{q} at 10x")), "{text}");
}
