use crate::report::chaos::{assert_numbers_follow, html};
use serde_json::{Value, json};
use ssmctl::report::Report;
use ssmctl::report::sloshing::*;

/// Every number of the section's paragraphs comes from its values: with all of them
/// moved, every number moves (numbers inside names aside), and one value changed shows
/// on the page.
#[test]
fn paragraphs_follow_their_values() {
    let fo = ssmctl::bench::sloshing_fit_options();
    let intro = json!({ "dim": fo.dim, "folder": "../shared/data/sloshing", "train": TRAIN, "test": TEST });
    let a = assert_numbers_follow("fit-sloshing/intro", INTRO, &intro);
    assert!(a.contains("A 2D SSM") && a.contains("trained on decay_0 and decay_1, tested on decay_2"), "{a}");
    let fit = json!({
        "fit": { "embed": fo.embed, "shift": fo.shift, "manifold_order": fo.manifold_order, "dyn_order": fo.dyn_order },
        "fit_ms": 12.345, "reps": 2, "nmte": 0.01234, "dtw": 0.00567,
        "eigenvalues": [{ "re": -0.06, "im": 7.8 }, { "re": -0.06, "im": -7.8 }],
    });
    let t = format!("{SIGNED}{FIT}");
    let a = assert_numbers_follow("fit-sloshing/fit", &t, &fit);
    assert!(a.contains("(p = 5, shift 1, manifold order 3, polynomial map order 5)"), "{a}");
    assert!(a.contains("eigenvalues -0.0600 +7.8000i, -0.0600 -7.8000i."), "{a}");
    let mut one = fit.clone();
    one["nmte"] = json!(0.0421);
    let b = html("fit-sloshing/fit", &t, &one).unwrap();
    assert!(b.contains("test NMTE 0.0421,") && !b.contains("0.0123"), "{b}");
    let bb = json!({
        "first": { "amplitude": 0.0, "freq_hz": 1.2428, "damping_pct": 0.77 },
        "last": { "amplitude": 12.5, "freq_hz": 1.19, "damping_pct": 1.4 },
    });
    let a = assert_numbers_follow("fit-sloshing/backbone", BACKBONE, &bb);
    assert!(a.contains("From amplitude 0 to 12.5 %"), "{a}");
    let frc = json!({
        "amplitude": CAL_AMPLITUDE, "freq_rad_s": 8.05, "ratio": CAL_RATIO, "forcing": 0.0123,
        "peak_amplitude": 3.4, "peak_freq_rad_s": 7.9, "unstable": 1,
    });
    let a = assert_numbers_follow("fit-sloshing/frc", FRC, &frc);
    assert!(a.contains("amplitude 1 % at 8.05 rad/s (1.03 times the linear frequency)"), "{a}");
    let export = json!({ "centres": 50, "bytes": 4321, "file": "sloshing-rbf50.bin" });
    let a = assert_numbers_follow("fit-sloshing/export", EXPORT, &export);
    assert!(a.contains("the 50-centre RBF model as <code>sloshing-rbf50.bin</code> (4321 bytes)"), "{a}");
    let blob = json!({ "dim": 4, "centres": 100, "scene": FURUTA_SCENE, "file": FURUTA_BLOB, "bytes": 9876 });
    let a = assert_numbers_follow("furuta-blob", FURUTA_EXPORT, &blob);
    assert!(a.contains("a 100-centre RBF map") && a.contains("(9876 bytes)"), "{a}");
}

/// A device table and a PIL run as `cargo xtask device-table` and `cargo xtask pil` write
/// them (the quick report has neither), with the page values `device_section` adds.
pub(crate) fn device_values() -> Value {
    json!({
        "device": {
            "controller_step_instructions_int": 90.5, "controller_step_instructions_int_pd": 72.8,
            "controller_step_instructions_float": 80.2, "controller_step_instructions_f64": 912.7,
            "flash_bytes": 30211, "ram_bytes": 4417,
            "controller_step_instructions_int_by_coordinates": {"1": 60.0, "2": 90.5, "4": 150.3},
            "controller_step_instructions_int_runtime_config": {"1": 70.0, "2": 101.0},
            "predictor": [
                {"centers": 50, "sqrt": "libm", "instructions": 5123.5, "per_center": 102.47, "rel_error": 3.1e-7},
                {"centers": 100, "sqrt": "fast", "instructions": 9876.5, "per_center": 98.765, "rel_error": 2.2e-4},
            ],
            "predictor_f32_vs_f64": [
                {"centers": 50, "scalar": "f32", "instructions": 1234.5, "per_center": 24.69, "rel_error": 3e-7, "vs_f32": 1.5},
                {"centers": 50, "scalar": "f64", "instructions": 23456.5, "per_center": 469.13, "rel_error": 2e-16, "vs_f32": 19.0},
            ],
            "firmware_sizes": [
                {"config": "stm32f407: on-target tests", "flash_bytes": 3, "ram_bytes": 7, "flash_capacity": 10, "ram_capacity": 9},
            ],
        },
        "pil": {"periods": 4000, "codes_identical": true, "host_sim_codes_identical": true,
                "noise": {"sigma_theta": 0.0015, "seed": 7}, "max_pred_rel_diff": 2.5e-7, "source": "qemu/target/pil/summary.json"},
        "page_device": {"machine": QEMU_MACHINE, "icount": QEMU_ICOUNT, "predict_call": PREDICT_CALL,
                        "figure": "fig/device_predictor.png",
                        "coordinates": [{"n": 1, "fixed": 60.0, "runtime": 70.0}, {"n": 2, "fixed": 90.5, "runtime": 101.0},
                                        {"n": 4, "fixed": 150.3, "runtime": null}],
                        "sizes": [{"config": "stm32f407: on-target tests", "flash_bytes": 3, "flash_pct": 30.0,
                                   "ram_bytes": 7, "ram_pct": 77.8}],
                        "pil": {"predictions_compared": 3990, "round_trips_per_s": 1534.6, "blob": true}},
    })
}

/// The page of a missing device table and PIL run names the files.
#[test]
fn device_page_names_missing_files() {
    let missing = json!({"device": {"missing": "q/device-table.json"}, "pil": {"missing": "q/pil/summary.json"},
                         "page_device": {"machine": QEMU_MACHINE, "icount": QEMU_ICOUNT, "predict_call": PREDICT_CALL,
                                         "figure": null, "coordinates": [], "pil": null}});
    let dir = std::env::temp_dir().join(format!("ssm-sloshing-report-missing-{}", std::process::id()));
    let mut rep = Report::new(&dir).unwrap();
    device_render(&mut rep, &missing).unwrap();
    let html = rep.into_parts().0;
    assert!(html.contains("No device table at q/device-table.json") && html.contains("run at q/pil/summary.json"));
    assert!(html.contains("(QEMU mps2-an386, <code>-icount shift=7</code>, SysTick"), "{html}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The f32-vs-f64 rows of the device table JSON are rendered as a table.
#[test]
fn device_section_renders_f32_vs_f64_rows() {
    let dir = std::env::temp_dir().join(format!("ssm-sloshing-report-dev-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let table = dir.join("device-table.json");
    let v = json!({
        "controller_step_instructions_int": 90.5,
        "controller_step_instructions_int_pd": 72.8,
        "controller_step_instructions_int_by_coordinates": {"1": 60.0, "2": 90.5, "4": 150.3},
        "controller_step_instructions_int_runtime_config": {"1": 70.0, "2": 101.0},
        "predictor_f32_vs_f64": [
            {"centers": 50, "scalar": "f32", "instructions": 1234.5, "per_center": 24.69, "rel_error": 3e-7, "vs_f32": 1.0},
            {"centers": 50, "scalar": "f64", "instructions": 23456.5, "per_center": 469.13, "rel_error": 2e-16, "vs_f32": 19.0},
        ],
        "firmware_sizes": [
            {"config": "stm32f407: on-target tests", "flash_bytes": 262144, "ram_bytes": 32768, "flash_capacity": 1048576, "ram_capacity": 131072},
        ],
    });
    std::fs::write(&table, v.to_string()).unwrap();
    let mut rep = Report::new(&dir.join("out")).unwrap();
    device_section(&mut rep, &table).unwrap();
    rep.finish("t").unwrap();
    let html = std::fs::read_to_string(dir.join("out/index.html")).unwrap();
    assert!(html.contains("<th>x f32</th>"), "no f32/f64 table");
    assert!(html.contains("<td>2</td><td>90.5</td><td>101.0</td>"), "{html}");
    assert!(html.contains("(73 for PD without integral action)"), "{html}");
    assert!(html.contains("<td>4</td><td>150.3</td><td>-</td>"), "{html}");
    assert!(html.find("<td>1</td><td>60.0</td>") < html.find("<td>2</td><td>90.5</td>"), "{html}");
    assert!(html.contains("<td>f64</td><td>23456.5</td><td>469.13</td><td>19.0</td><td>2e-16</td>"), "{html}");
    assert_eq!(rep.summary["device"]["predictor_f32_vs_f64"][1]["vs_f32"], 19.0);
    assert!(
        html.contains("<td>stm32f407: on-target tests</td><td>262144 (25.0 %)</td><td>32768 (25.0 %)</td>"),
        "{html}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
