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
    for dt in ["30.5", "31", "32", "32.5", "30.8", "31.2", "31.4", "31.41", "31.55", "31.6", "31.68", "31.8", "32.2", "32.3", "25"] {
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
