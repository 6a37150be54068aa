use super::*;

fn err(text: &str, overrides: &[&str]) -> String {
    let o: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    match Scene::parse("t", text, &o) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

const MINIMAL: &str = r#"
name = "t"
[plant]
kind = "furuta"
[controller]
kp = 15.5
kd = 5.45
dt_ms = 25
[run]
periods = 10
"#;

#[test]
fn every_bundled_scene_parses_and_is_named_after_its_file() {
    for (name, text) in BUNDLED {
        let s = Scene::parse(name, text, &[]).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(&s.name, name);
    }
    assert!(BUNDLED.len() >= 20);
}

#[test]
fn paper_sweep_and_test_values_are_bundled() {
    for dt in [
        "30.5", "31", "32", "32.5", "30.8", "31.2", "31.4", "31.41", "31.55", "31.6", "31.68", "31.8", "32.2", "32.3",
        "25",
    ] {
        let name = format!("furuta-dt{dt}");
        let s = Scene::load(&name, &[]).unwrap();
        assert_eq!(s.controller.dt_ms, dt.parse::<f64>().unwrap());
        assert_eq!((s.controller.kp, s.controller.kd), (15.5, 5.45));
        assert!(s.effects.quantization.is_none() && s.effects.noise.is_none());
    }
}

#[test]
fn minimal_scene_defaults() {
    let s = Scene::parse("t", MINIMAL, &[]).unwrap();
    assert_eq!(s.controller.delay, 1);
    assert_eq!(s.run.tasks, vec![Task::Simulate, Task::Stability]);
    assert_eq!(s.integrator.method, MethodKind::Rodas);
    let c = s.controller_config();
    assert_eq!((c.dt, c.ki, c.u_max, c.quant), (0.025, 0.0, None, None));
    assert_eq!(s.effect_names().len(), 1);
}

#[test]
fn overrides_set_nested_values_and_create_tables() {
    let s = Scene::parse(
        "t",
        MINIMAL,
        &["controller.dt_ms=31.2".into(), "effects.saturation.u_max=24".into(), "run.tasks=[\"stability\"]".into()],
    )
    .unwrap();
    assert_eq!(s.controller.dt_ms, 31.2);
    assert_eq!(s.effects.saturation.as_ref().map(|x| x.u_max), Some(24.0));
    assert!(!s.wants(Task::Simulate));
}

#[test]
fn unknown_keys_are_errors_with_their_path() {
    let e = err(MINIMAL, &["controller.kpp=1"]);
    assert!(e.contains("controller") && e.contains("kpp"), "{e}");
    let e = err(&format!("{MINIMAL}\n[effects.quantization]\nmode = \"counts\"\nh_adc = 0.001\nbogus = 1\n"), &[]);
    assert!(e.contains("effects.quantization") && e.contains("bogus"), "{e}");
}

#[test]
fn bad_values_name_their_key() {
    for (o, key) in [
        ("controller.dt_ms=-1", "controller.dt_ms"),
        ("controller.kp=nan", "controller.kp"),
        ("run.periods=0", "run.periods"),
        ("controller.delay=9", "controller.delay"),
        ("effects.saturation.u_max=0", "effects.saturation.u_max"),
        ("effects.noise.seed=1", "effects.noise"),
        ("integrator.method=\"rk4\"", "integrator.steps"),
        ("integrator.rtol=-1e-9", "integrator.rtol"),
        ("initial.history=[[0.0, 0.0]]", "initial.history"),
        ("plant.kind=\"segway\"", "plant.kind"),
        ("controller.kd=\"fast\"", "controller.kd"),
    ] {
        let e = err(MINIMAL, &[o]);
        assert!(e.contains(key), "override {o}: error `{e}` does not name {key}");
    }
}

#[test]
fn malformed_overrides_and_unknown_scenes_are_rejected() {
    assert!(err(MINIMAL, &["controller.kp"]).contains("PATH=VALUE"));
    assert!(err(MINIMAL, &["controller..kp=1"]).contains("PATH=VALUE"));
    assert!(err(MINIMAL, &["name.x=1"]).contains("not a table"));
    let e = Scene::load("no-such-scene", &[]).unwrap_err().to_string();
    assert!(e.contains("no-such-scene"), "{e}");
}

/// Issue 14: a scene name of `../../x` or `/abs/x` made `simulate` write outside `--out`.
/// Names become file names and are restricted to a safe set.
#[test]
fn scene_names_are_restricted_to_safe_file_names() {
    for bad in ["../../x", "/abs/x", "a/b", "a\\\\b", "..", ".hidden", "", "x y", "na\\u0000me", "é"] {
        let text = MINIMAL.replace("name = \"t\"", &format!("name = \"{bad}\""));
        let e = err(&text, &[]);
        assert!(e.contains("`name`") && e.contains("may hold only ASCII letters, digits"), "{bad:?}: {e}");
    }
    let long = "n".repeat(MAX_NAME_LEN + 1);
    let e = err(&MINIMAL.replace("name = \"t\"", &format!("name = \"{long}\"")), &[]);
    assert!(e.contains(&format!("the limit is {MAX_NAME_LEN}")), "{e}");
    // The bundled names and ordinary ones pass.
    for ok in ["furuta-dt31.41", "my_scene-2", "A.b"] {
        assert!(Scene::parse("t", &MINIMAL.replace("name = \"t\"", &format!("name = \"{ok}\"")), &[]).is_ok(), "{ok}");
    }
    // Overrides and builders are validated too.
    let e = err(MINIMAL, &["name=\"../up\""]);
    assert!(e.contains("`name`"), "{e}");
}

/// Issue 14: `run.periods` near u64::MAX panicked in `Vec::with_capacity`, 1e12 aborted on
/// allocation. The limit is stated and checked before anything is allocated.
#[test]
fn run_periods_are_limited_before_allocation() {
    for p in [u64::MAX, 1_000_000_000_000, MAX_PERIODS + 1] {
        let e = err(MINIMAL, &[&format!("run.periods={}", p.min(i64::MAX as u64))]);
        assert!(e.contains("`run.periods`") && e.contains(&format!("limit of {MAX_PERIODS}")), "{p}: {e}");
    }
    assert!(Scene::parse("t", MINIMAL, &[format!("run.periods={MAX_PERIODS}")]).is_ok());
    let e = Scene::load("furuta-dt25", &[]).unwrap().builder().periods(u64::MAX).build().unwrap_err().to_string();
    assert!(e.contains("run.periods"), "{e}");
}

/// Issue 14: the controller configuration is validated by the controller's own check (the
/// one `inspect` and `export` use), under the scene's key path with the controller's message.
#[test]
fn controller_fields_are_validated_by_the_controller_check() {
    let quant = "\n[effects.quantization]\nmode = \"counts\"\nh_adc = 0.001\n";
    for (text, o, key, msg) in [
        (MINIMAL.to_string(), "controller.kp=inf", "controller.kp", "controller config: `gains[0].p` is not finite"),
        (
            MINIMAL.to_string(),
            "controller.kphi_d=nan",
            "controller.kphi_d",
            "controller config: `gains[1].d` is not finite",
        ),
        (
            MINIMAL.to_string(),
            "controller.delay=7",
            "controller.delay",
            "controller config: `delay` = 7 samples exceeds this controller's history (max 6)",
        ),
        (
            MINIMAL.to_string(),
            "effects.saturation.u_max=-2",
            "effects.saturation.u_max",
            "controller config: `u_max` must be > 0",
        ),
        (
            MINIMAL.to_string(),
            "effects.integral.ki=nan",
            "effects.integral.ki",
            "controller config: `ki` is not finite",
        ),
        (
            format!("{MINIMAL}{quant}"),
            "effects.quantization.h_dac=0",
            "effects.quantization.h_dac",
            "controller config: `quant.h_dac` must be > 0",
        ),
        (
            format!("{MINIMAL}{quant}"),
            "effects.quantization.h_adc=-1",
            "effects.quantization.h_adc",
            "controller config: `gains[0].h_adc` must be > 0",
        ),
        (
            format!("{MINIMAL}{quant}"),
            "effects.quantization.h_adc_phi=0",
            "effects.quantization.h_adc_phi",
            "must be > 0",
        ),
        (format!("{MINIMAL}{quant}"), "controller.kp=1e30", "controller.kp", "not representable"),
    ] {
        let e = err(&text, &[o]);
        assert!(e.contains(&format!("`{key}`")) && e.contains(msg), "{o}: {e}");
    }
    // dt is named by the scene's key (in ms), with the controller's message.
    for o in ["controller.dt_ms=0", "controller.dt_ms=-1", "controller.dt_ms=4e-324"] {
        let e = err(MINIMAL, &[o]);
        assert!(e.contains("`controller.dt_ms`") && e.contains("controller config: `dt` must be > 0"), "{o}: {e}");
    }
    let e = err(MINIMAL, &["controller.dt_ms=nan"]);
    assert!(e.contains("`controller.dt_ms`") && e.contains("controller config: `dt` is not finite"), "{e}");
}

/// Every method's key is its scene-file name: it parses back to the method through `--set`.
#[test]
fn method_keys_parse_back() {
    use super::MethodKind::*;
    for m in [Rodas, RodasFixed, Rk4, Exprb, ExprbFixed, ExprbSplit, ExprbLean, ExprbFiltered, Exprb54, Exprb54Filtered]
    {
        let v: MethodKind = toml::Value::String(m.key().into()).try_into().unwrap();
        assert_eq!(v, m);
    }
}
