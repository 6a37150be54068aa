mod axis;

use sim::scene::*;

/// The bundled scenes' texts by name.
mod bundled {
    pub fn get(name: &str) -> Option<&'static str> {
        sim::scene::BUNDLED.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
    }
}

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
        assert_eq!((s.controller.kp, s.controller.kd), (Some(15.5), Some(5.45)));
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

/// Regression: a scene name of `../../x` or `/abs/x` made `simulate` write outside `--out`.
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

/// Regression: `run.periods` near u64::MAX panicked in `Vec::with_capacity`, 1e12 aborted on
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

/// The controller configuration is validated by the controller's own check (the
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
    use sim::scene::MethodKind::*;
    for m in [Rodas, RodasFixed, Rk4, Exprb, ExprbFixed, ExprbSplit, ExprbLean, ExprbFiltered, Exprb54, Exprb54Filtered]
    {
        let v: MethodKind = toml::Value::String(m.key().into()).try_into().unwrap();
        assert_eq!(v, m);
    }
}

mod equations {
    use super::bundled;
    use sim::closed_loop::{AnyPlant, build_plant, simulate};
    use sim::scene::*;

    fn load(name: &str, o: &[&str]) -> Result<Scene, SceneError> {
        Scene::load(name, &o.iter().map(|s| s.to_string()).collect::<Vec<_>>())
    }

    fn load_err(name: &str, o: &[&str]) -> String {
        match load(name, o) {
            Ok(_) => panic!("{name} {o:?} loaded"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn bundled_equation_scenes_build_their_plants() {
        for (name, coords) in [("furuta-equations", 2), ("cartpole-pd", 2), ("pendulum-pd", 1), ("duffing-chain", 2)] {
            let s = load(name, &[]).unwrap();
            assert_eq!(s.plant.kind, PlantKind::Equations);
            let p = build_plant(&s).unwrap();
            let n = match p {
                AnyPlant::Equations1(_) => 1,
                AnyPlant::Equations2(_) => 2,
                AnyPlant::Equations3(_) => 3,
                AnyPlant::Equations4(_) => 4,
                _ => 0,
            };
            assert_eq!(n, coords, "{name}");
        }
    }

    /// `--set plant.parameters.NAME=...` overrides a parameter like every other key.
    #[test]
    fn parameter_overrides_apply() {
        let a = simulate(&load("pendulum-pd", &["run.periods=50"]).unwrap(), None).unwrap();
        let b = simulate(&load("pendulum-pd", &["run.periods=50", "plant.parameters.m=0.25"]).unwrap(), None).unwrap();
        assert_ne!(a.states, b.states);
        assert_eq!(a.state_names, ["theta", "theta_dot"]);
        // A new name is a new parameter, unknown to the expressions: accepted, unused.
        load("pendulum-pd", &["plant.parameters.unused=1.0"]).unwrap();
        let e = load_err("pendulum-pd", &["plant.parameters.m=\"heavy\""]);
        assert!(e.contains("`plant.parameters.m`") && e.contains("must be a number"), "{e}");
    }

    /// Errors name the scene, the key and the column.
    #[test]
    fn errors_name_scene_key_and_column() {
        let e = load_err("cartpole-pd", &["plant.forces=[\"m*g*l*sin(thetaa)\", \"u\"]"]);
        assert!(e.starts_with("scene cartpole-pd: `plant.forces[0]`: column 11: unknown name `thetaa`"), "{e}");
        let e = load_err("pendulum-pd", &["plant.mass=[[\"m*l^2\", \"0\"]]"]);
        assert!(e.contains("`plant.mass[0]`") && e.contains("square"), "{e}");
        let e = load_err("pendulum-pd", &["plant.parameters.m=-0.3"]);
        assert!(e.contains("`plant.mass`") && e.contains("positive definite"), "{e}");
        let e = load_err("pendulum-pd", &["plant.lagrangian=\"0.5*m*l^2*theta_dot^2\""]);
        assert!(e.contains("not both"), "{e}");
        let e = load_err("furuta-dt25", &["plant.coordinates=[\"theta\"]"]);
        assert!(e.contains("`plant.coordinates`") && e.contains("only a plant of kind = \"equations\""), "{e}");
        let e = load_err("pendulum-pd", &["plant.params.m=1"]);
        assert!(e.contains("`plant.params.m`") && e.contains("plant.parameters"), "{e}");
        let e = load_err("pendulum-pd", &["plant.forces=[\"m*g*l*cos(theta) + u\"]"]);
        assert!(e.contains("`plant.forces[0]`") && e.contains("not zero") && e.contains("plant.equilibrium"), "{e}");
        // A scene file names itself by its path.
        let dir = std::env::temp_dir().join(format!("sim-eq-scene-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("bad.toml");
        let text = bundled::get("pendulum-pd").unwrap().replace("m*g*l*sin(theta)", "m*g*l*sin(theta))");
        std::fs::write(&path, text).unwrap();
        let e = Scene::load(path.to_str().unwrap(), &[]).unwrap_err().to_string();
        assert!(e.contains("bad.toml") && e.contains("`plant.forces[0]`: column 17: unmatched `)`"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The Furuta written as equations runs the bench scene's 200 periods as the built-in
    /// plant does, to 1e-9 rad (a tight integrator on both: the difference is the plants').
    #[test]
    fn furuta_equations_trajectory_equals_the_builtin() {
        let o = ["run.periods=200", "integrator.method=\"rodas\"", "integrator.rtol=1e-12", "integrator.atol=1e-14"];
        let a = simulate(&load("furuta-dt30.8", &o).unwrap(), None).unwrap();
        let b = simulate(&load("furuta-equations", &o).unwrap(), None).unwrap();
        assert_eq!(a.rows(), 201);
        assert_eq!(b.rows(), 201);
        let mut worst = 0.0f64;
        for i in 0..a.rows() {
            for k in [0, 2] {
                worst = worst.max((a.state(i, k) - b.state(i, k)).abs());
            }
        }
        println!("furuta equations vs built-in, 200 periods: max angle difference {worst:e} rad");
        assert!(worst < 1e-9, "{worst:e}");
        let ma = sim::stability::scene_multipliers(&load("furuta-dt30.8", &[]).unwrap()).unwrap();
        let mb = sim::stability::scene_multipliers(&load("furuta-equations", &[]).unwrap()).unwrap();
        crate::plant::equations::assert_same_multipliers(&ma, &mb, 1e-10 * ma[0].abs.max(1.0), "furuta");
    }

    /// The bundled equation scenes are linearly stable where they say so, and their runs stay
    /// bounded (the pendulum and the cart-pole settle, the chain's vibration decays).
    #[test]
    fn bundled_equation_scenes_are_stable_and_settle() {
        for name in ["cartpole-pd", "pendulum-pd", "duffing-chain"] {
            let s = load(name, &[]).unwrap();
            let dom = sim::stability::dominant_pairs(&s).unwrap();
            println!("{name}: dominant {:?}", dom.first());
            let tr = simulate(&s, None).unwrap();
            assert!(tr.stopped.is_none(), "{name}: {:?}", tr.stopped);
            let first = tr.state(0, 0).abs().max(1e-12);
            let last = tr.state(tr.rows() - 1, 0).abs();
            assert!(last < 0.1 * first, "{name}: |q0| {first} -> {last}");
        }
    }
}

#[test]
fn initial_state_by_name() {
    let pend = bundled::get("pendulum-pd").unwrap().replace("state = [0.05, 0.0]", "state = { theta_dot = -0.2 }");
    let s = Scene::parse("t", &pend, &[]).unwrap();
    assert_eq!(s.initial.state, vec![0.0, -0.2]);
    let e = Scene::parse("t", &pend.replace("theta_dot = -0.2", "omega = 1"), &[]).unwrap_err().to_string();
    assert!(e.contains("`initial.state.omega`") && e.contains("theta, theta_dot"), "{e}");
    let s = Scene::parse("t", &MINIMAL.replace("[run]", "[initial]\nstate = { phi = 0.5, theta = 0.1 }\n[run]"), &[])
        .unwrap();
    assert_eq!(s.initial.state, vec![0.1, 0.0, 0.5, 0.0]);
}
