//! Every boundary refuses bad input with exit code 1 and a message naming the
//! field and the limit, never a panic (101), an abort (134), a hang or a silent success.

use serde_json::Value;
use shared::model::OwnedModel;
use shared::{ControllerConfig, Quantization};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// Runs `ssmctl --quiet ARGS`: (exit code, stdout, stderr), and checks it took under 60 s.
fn ssmctl(args: &[&str]) -> (Option<i32>, String, String) {
    let t0 = Instant::now();
    let o = Command::new(env!("CARGO_BIN_EXE_ssmctl")).arg("--quiet").args(args).output().expect("run ssmctl");
    assert!(t0.elapsed() < Duration::from_secs(60), "{args:?} took {:?}", t0.elapsed());
    (o.status.code(), String::from_utf8_lossy(&o.stdout).into(), String::from_utf8_lossy(&o.stderr).into())
}

/// Asserts exit code 1 (an error, not a panic) and that stderr contains every `parts`.
fn refused(args: &[&str], parts: &[&str]) -> String {
    let (code, _, err) = ssmctl(args);
    assert_eq!(code, Some(1), "{args:?}: expected exit 1, stderr: {err}");
    for p in parts {
        assert!(err.contains(p), "{args:?}: stderr does not contain {p:?}:\n{err}");
    }
    err
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ssmctl-bad-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A tiny valid device model (p = 3, d = 1, one centre, linear lift) with `config`.
fn blob(config: ControllerConfig) -> Vec<u8> {
    OwnedModel {
        config,
        p: 3,
        shift: 1,
        sample_period: 0.025,
        offset: 0.0,
        scale: 1.0,
        d: 1,
        lift_order: 1,
        k: 1,
        v1: vec![0.5, 0.5, 0.5],
        lift: vec![],
        centres: vec![0.1],
        weights: vec![0.2],
        affine: vec![0.9, 0.0],
    }
    .encode()
    .unwrap()
}

fn counts_config() -> ControllerConfig {
    let h = 2.0 * std::f64::consts::PI / 2000.0;
    ControllerConfig { u_max: Some(10.0), ..ControllerConfig::paper(0.025).with_counts(h, h, 4.8828125e-3) }
}

/// Class 1: the controller configuration is validated by one check wherever it crosses: a
/// blob passes `inspect` only if a scene with the same values would be accepted, and both
/// refuse with the same message.
#[test]
fn controller_configuration_is_refused_alike_in_scenes_and_blobs() {
    let dir = tmp("config");
    let good = dir.join("good.bin");
    std::fs::write(&good, blob(counts_config())).unwrap();
    let (code, out, err) = ssmctl(&["inspect", s(&good), "--json"]);
    assert_eq!(code, Some(0), "{err}");
    let v: Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["controller"]["delay"], 1);
    type Edit = fn(&mut ControllerConfig);
    let cases: [(Edit, &str, &str); 6] = [
        (|c| c.dt = 0.0, "controller.dt_ms=0", "controller config: `dt` must be > 0"),
        (|c| c.dt = -0.025, "controller.dt_ms=-25", "controller config: `dt` must be > 0"),
        (
            |c| c.delay = 7,
            "controller.delay=7",
            "controller config: `delay` = 7 samples exceeds this controller's history (max 6)",
        ),
        (|c| c.u_max = Some(-1.0), "effects.saturation.u_max=-1", "controller config: `u_max` must be > 0"),
        (
            |c| c.quant = c.quant.map(|q| Quantization { h_dac: 0.0, ..q }),
            "effects.quantization.h_dac=0",
            "controller config: `quant.h_dac` must be > 0",
        ),
        (|c| c.gains[0].p = f64::NAN, "controller.kp=nan", "controller config: `gains[0].p` is not finite"),
    ];
    for (edit, set, message) in cases {
        let mut c = counts_config();
        edit(&mut c);
        let path = dir.join("bad.bin");
        std::fs::write(&path, blob(c)).unwrap();
        refused(&["inspect", s(&path)], &["bad.bin", message]);
        refused(&["stability", "--scene", "furuta-quant-dt25", "--set", set], &[message]);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Simulated quantized data (`furuta-quant-dt25`, optionally at another dt) and an RBF
/// model fitted to it and saved: (data CSV, model JSON).
fn data_and_model(dir: &Path, dt_ms: &str) -> (PathBuf, PathBuf) {
    let sim = dir.join(format!("sim{dt_ms}"));
    let (code, _, err) = ssmctl(&[
        "simulate",
        "--scene",
        "furuta-quant-dt25",
        "--out",
        s(&sim),
        "--set",
        "run.periods=600",
        "--set",
        &format!("controller.dt_ms={dt_ms}"),
        "--set",
        "initial.state=[0.05,0,0,0]",
    ]);
    assert_eq!(code, Some(0), "{err}");
    let csv = sim.join("furuta-quant-dt25.csv");
    let model = dir.join(format!("model{dt_ms}.json"));
    let (code, _, err) = ssmctl(&[
        "fit",
        "--data",
        s(&csv),
        "--column",
        "theta",
        "--dim",
        "2",
        "--embed",
        "5",
        "--order",
        "2",
        "--dynamics",
        "rbf",
        "--centers",
        "20",
        "--ridge",
        "1e-8",
        "--save",
        s(&model),
    ]);
    assert_eq!(code, Some(0), "{err}");
    (csv, model)
}

/// Class 1 and 3: `export` validates the saved model before indexing it (shapes, limits),
/// refuses a model sampled at another period than the scene's loop, never writes onto its
/// own input, and writes only blobs `inspect` accepts. `fit --save` never overwrites its data.
#[test]
fn export_refuses_inconsistent_models_other_periods_and_its_own_input() {
    let dir = tmp("export");
    let (csv, model) = data_and_model(&dir, "25");
    let text = std::fs::read_to_string(&model).unwrap();
    let out = dir.join("m.bin");
    // Good: the scene's loop runs at the model's 25 ms; the blob inspects.
    let (code, _, err) = ssmctl(&["export", "--model", s(&model), "--out", s(&out), "--scene", "furuta-quant-dt25"]);
    assert_eq!(code, Some(0), "{err}");
    let (code, out_json, err) = ssmctl(&["inspect", s(&out), "--json"]);
    assert_eq!(code, Some(0), "{err}");
    let v: Value = serde_json::from_str(&out_json).unwrap();
    assert_eq!((v["p"].as_u64(), v["d"].as_u64()), (Some(5), Some(2)));
    // Another loop period: refused, naming both.
    refused(
        &["export", "--model", s(&model), "--out", s(&dir.join("x.bin")), "--scene", "furuta-dt30.8"],
        &["sampling step 0.025", "controller dt 0.0308"],
    );
    let (_, model28) = data_and_model(&dir, "28");
    refused(
        &["export", "--model", s(&model28), "--out", s(&dir.join("x.bin")), "--scene", "furuta-quant-dt25"],
        &["sampling step 0.028", "controller dt 0.025"],
    );
    assert!(!dir.join("x.bin").exists());
    // Writing onto its own input.
    refused(&["export", "--model", s(&model), "--out", s(&model)], &["refusing to write", "--model"]);
    assert_eq!(std::fs::read_to_string(&model).unwrap(), text, "the model was overwritten");
    refused(
        &["fit", "--data", s(&csv), "--column", "theta", "--dim", "2", "--embed", "5", "--save", s(&csv)],
        &["refusing to write", "--data"],
    );
    // Inconsistent saved models: refused with the field named, nothing written.
    let good: Value = serde_json::from_str(&text).unwrap();
    type Edit = fn(&mut Value);
    let cases: [(Edit, &str); 5] = [
        (|m| m["manifold"]["v1"].as_array_mut().unwrap().truncate(4), "`manifold.v1`: length 4, expected 10"),
        (
            |m| {
                m["options"]["dim"] = 0.into();
                m["manifold"]["dim"] = 0.into();
            },
            "`options`",
        ),
        (|m| m["dynamics"]["Rbf"]["scale"] = serde_json::json!([]), "`dynamics.Rbf.scale`: length 0, expected 2"),
        (
            |m| m["manifold"]["nonlinear"]["exps"][0] = serde_json::json!([4000000000u32, 0]),
            "`manifold.nonlinear.exps[0]`: total degree 4000000000",
        ),
        (|m| m["dynamics"]["Rbf"]["centers"] = serde_json::json!([]), "`dynamics.Rbf.centers`"),
    ];
    for (edit, message) in cases {
        let mut v = good.clone();
        edit(&mut v["model"]);
        let bad = dir.join("bad.json");
        std::fs::write(&bad, v.to_string()).unwrap();
        let o = dir.join("bad.bin");
        refused(&["export", "--model", s(&bad), "--out", s(&o)], &["bad.json", message]);
        assert!(!o.exists());
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Class 3: file names derived from scene names stay inside `--out`; a failed run leaves
/// no partial file (nor a temporary one).
#[test]
fn scene_names_cannot_escape_the_output_folder() {
    let dir = tmp("names");
    let base = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/furuta-dt25.toml")).unwrap();
    for name in ["../../escaped", "/tmp/escaped-abs", "sub/x"] {
        let file = dir.join("scene.toml");
        std::fs::write(&file, base.replace("name = \"furuta-dt25\"", &format!("name = \"{name}\""))).unwrap();
        let out = dir.join("out");
        refused(
            &["simulate", "--scene", s(&file), "--out", s(&out), "--set", "run.periods=3"],
            &["`name`", "ASCII letters"],
        );
        assert!(!out.exists());
    }
    assert!(!std::env::temp_dir().join("escaped-abs.csv").exists());
    // A run that fails midway (the sensor leaves the encoder range) writes nothing.
    let out = dir.join("fail");
    refused(
        &[
            "simulate",
            "--scene",
            "furuta-quant-dt25",
            "--out",
            s(&out),
            "--set",
            "initial.state=[1e300,0,0,0]",
            "--set",
            "run.periods=5",
        ],
        &["sensor"],
    );
    let left: Vec<_> = std::fs::read_dir(&out).map(|d| d.count()).into_iter().collect();
    assert!(left.is_empty() || left == [0], "files left: {left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Class 1: sizes are checked against stated limits before anything is allocated, with
/// the limit in the message (these allocated gigabytes, panicked or aborted before).
#[test]
fn sizes_are_refused_before_allocation_with_the_limit() {
    let dir = tmp("sizes");
    refused(
        &["stability", "--scene", "furuta-dt25", "--set", "run.periods=1000000000000"],
        &["`run.periods`", "limit of 10000000"],
    );
    refused(
        &["simulate", "--scene", "furuta-dt25", "--out", s(&dir), "--set", "run.periods=9223372036854775807"],
        &["limit of 10000000"],
    );
    refused(&["inspect", "/dev/zero"], &["/dev/zero", "a character device, not a regular file"]);
    let (csv, _) = {
        let sim = dir.join("sim");
        let (code, _, err) =
            ssmctl(&["simulate", "--scene", "furuta-quant-dt25", "--out", s(&sim), "--set", "run.periods=400"]);
        assert_eq!(code, Some(0), "{err}");
        (sim.join("furuta-quant-dt25.csv"), ())
    };
    let c = s(&csv);
    refused(
        &["fit", "--data", c, "--column", "theta", "--dim", "100", "--embed", "201"],
        &["dim: 100 exceeds the limit of 32"],
    );
    refused(
        &["fit", "--data", c, "--column", "theta", "--dim", "2", "--embed", "5", "--order", "40"],
        &["manifold_order: 40 exceeds the limit of 32"],
    );
    refused(
        &["fit", "--data", c, "--column", "theta", "--dim", "12", "--embed", "25", "--order", "8"],
        &["manifold monomials", "limit of 20000"],
    );
    refused(
        &[
            "fit",
            "--data",
            c,
            "--column",
            "theta",
            "--dim",
            "2",
            "--embed",
            "5",
            "--dynamics",
            "rbf",
            "--centers",
            "1000000",
        ],
        &["rbf centers: 1000000 exceeds the limit of 100000"],
    );
    // chaos: zero and huge options are errors (exit 1), not notes.
    for (opt, val, message) in [
        ("--ssm-dim", "0", "invalid option ssm_dim: must be >= 1"),
        ("--centers", "0", "invalid option centers: must be >= 1"),
        ("--shift", "0", "invalid option shift: must be >= 1"),
        ("--ssm-dim", "50", "ssm_dim: 50 exceeds the limit of 32"),
        ("--poly-order", "30", "dynamics monomials"),
        ("--poly-order", "40", "poly_order: 40 exceeds the limit of 32"),
        ("--gp-embed", "0", "gp_embed: must be >= 1"),
    ] {
        let mut a = vec!["chaos", "--data", c, "--column", "theta", opt, val];
        if opt != "--ssm-dim" {
            a.extend(["--ssm-dim", "4"]);
        }
        refused(&a, &[message]);
    }
    // PIL options are checked before QEMU starts or anything is read.
    let pil = |extra: &[&str]| {
        let mut a = vec![
            "pil",
            "--scene",
            "furuta-quant-dt25",
            "--model",
            "/nonexistent.bin",
            "--out",
            s(&dir),
            "--elf",
            "/nonexistent.elf",
        ];
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    for (extra, message) in [
        (vec!["--periods", "0"], "--periods must be >= 1"),
        (vec!["--periods", "100000000"], "exceeds the limit of 10000000 periods"),
        (
            vec!["--timeout", "1e30"],
            "--timeout must be a number of seconds in (0, 3600], got 1000000000000000000000000000000",
        ),
        (vec!["--timeout", "0"], "--timeout must be a number of seconds in (0, 3600]"),
        (vec!["--timeout", "NaN"], "got NaN"),
    ] {
        let a = pil(&extra);
        refused(&a.iter().map(String::as_str).collect::<Vec<_>>(), &[message]);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Class 2 and 4: numbers that cannot be trusted are errors naming the cause; data files
/// without a header are errors naming the file.
#[test]
fn untrustworthy_numbers_and_headerless_data_are_errors() {
    refused(
        &["stability", "--scene", "furuta-dt25", "--set", "controller.kp=1e200"],
        &["controller gain kp = 1e200", "refusing"],
    );
    // A sampling period too short to move the state on the f64 grid, and one whose rates
    // rounding swamps: both under the key that caused them, for every command computing
    // multipliers (the equation-driven SSM said "multiplier ... is real").
    for args in [&["stability"][..], &["ssm-equations", "--order", "3"]] {
        let mut a = args.to_vec();
        a.extend(["--scene", "furuta-dt25", "--set", "controller.dt_ms=1e-300"]);
        refused(&a, &["`controller.dt_ms`", "underflows", "one period does not move the state"]);
    }
    refused(
        &["stability", "--scene", "furuta-dt25", "--set", "controller.dt_ms=1e-12"],
        &["`controller.dt_ms`", "the rates ln|mu|/dt are only known", "refusing"],
    );
    let dir = tmp("numbers");
    let png = dir.join("chart.png");
    refused(
        &[
            "stability-chart",
            "--scene",
            "furuta-dt25",
            "--out",
            s(&png),
            "--dt-ms",
            "25,1e-300",
            "--kp",
            "0:40:3",
            "--kd",
            "0:8:3",
        ],
        &["--dt-ms 1e-300", "underflows"],
    );
    assert!(!png.exists(), "a chart was written");
    // At 300 ms a dominant multiplier is real: refused before the period map's expansion
    // (which ran a long expansion at order 9 before failing without naming the key).
    refused(
        &["ssm-equations", "--scene", "furuta-dt25", "--set", "controller.dt_ms=300", "--order", "9"],
        &["`controller.dt_ms`", "not a complex pair", "is real", "not started"],
    );
    // A .mat observable beyond the magnitude bound (the SVD did not converge, naming
    // nothing): refused naming the file, the variable's row and the observable.
    let mut mat =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../ssm/tests/data/duffing_plain.mat")).unwrap();
    let at = 14864;
    assert_eq!(f64::from_le_bytes(mat[at..at + 8].try_into().unwrap()), -1.6164652032898954, "bundled file changed");
    mat[at..at + 8].copy_from_slice(&(-4.8e197f64).to_le_bytes());
    let big = dir.join("big.mat");
    std::fs::write(&big, &mat).unwrap();
    refused(
        &["fit", "--mat", s(&big), "--dim", "2", "--embed", "2"],
        &["big.mat xData{", "observable 2", "the largest |x| is 4.8e197", "rescale the data"],
    );
    // Data scaled by 1e-300 (squares subnormal: the fit loses its digits and the NMTE was
    // `inf` with exit 0) are refused, naming the file and the magnitude.
    let t: Vec<f64> = (0..600).map(|i| f64::from(i) * 0.02).collect();
    let x = |s: f64| t.iter().map(|&t| s * (-0.1 * t).exp() * (3.0 * t).cos()).collect::<Vec<f64>>();
    let write = |name: &str, xs: &[f64], header: bool| {
        let p = dir.join(name);
        let mut text = if header { String::from("t,x\n") } else { String::new() };
        for (t, x) in t.iter().zip(xs) {
            text.push_str(&format!("{t},{x:e}\n"));
        }
        std::fs::write(&p, text).unwrap();
        p
    };
    let nmte = |p: &Path| {
        let (code, out, err) = ssmctl(&[
            "fit",
            "--data",
            s(p),
            "--dim",
            "2",
            "--embed",
            "5",
            "--order",
            "1",
            "--dyn-order",
            "1",
            "--json",
        ]);
        assert_eq!(code, Some(0), "{err}");
        serde_json::from_str::<Value>(&out).unwrap()["nmte_train"].as_f64().unwrap()
    };
    let plain = nmte(&write("plain.csv", &x(1.0), true));
    assert!(plain.is_finite() && plain < 1e-6, "{plain}");
    assert!(nmte(&write("small.csv", &x(1e-80), true)) < 1e-6);
    let tiny = write("tiny.csv", &x(1e-300), true);
    refused(
        &["fit", "--data", s(&tiny), "--dim", "2", "--embed", "5"],
        &["tiny", "the largest |x| is 1e-300", "rescale the data"],
    );
    // No header line: an error naming the file, not a lost first row.
    let nohdr = write("nohdr.csv", &x(1.0), false);
    refused(&["fit", "--data", s(&nohdr), "--dim", "2", "--embed", "5"], &["nohdr.csv: line 1", "header line"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Class 1: a model sampled at another period than the loop is refused by `pil` before
/// QEMU starts (it ran with exit 0), like `export --scene` refuses it.
#[test]
fn pil_refuses_a_model_sampled_at_another_period() {
    let dir = tmp("pil-dt");
    let cfg = sim::scene::Scene::load("furuta-quant-dt25", &[]).unwrap().controller_config();
    let mut m = shared::model::Model::<8, 4, 4, 4>::decode(&blob(cfg)).unwrap().to_owned_model();
    m.sample_period = 0.033;
    let path = dir.join("m33.bin");
    std::fs::write(&path, m.encode().unwrap()).unwrap();
    // ssmctl checks first that --elf is ARM firmware: an ELF header (32-bit, little-endian,
    // machine ARM) passes that check, and the model is refused before QEMU starts.
    let elf = dir.join("fake.elf");
    let mut header = vec![0x7f, b'E', b'L', b'F', 1, 1, 1];
    header.resize(18, 0);
    header.extend_from_slice(&40u16.to_le_bytes());
    std::fs::write(&elf, header).unwrap();
    let out = dir.join("out");
    refused(
        &[
            "pil",
            "--scene",
            "furuta-quant-dt25",
            "--model",
            s(&path),
            "--out",
            s(&out),
            "--elf",
            s(&elf),
            "--periods",
            "10",
        ],
        &["m33.bin", "sampling step 0.03299", "controller dt 0.025"],
    );
    assert!(!out.join("theta.csv").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}
