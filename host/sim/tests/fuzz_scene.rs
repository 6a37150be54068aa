//! Fuzzing the scene boundary (docs/decisions/0004): random `--set` overrides of every kind of
//! value on the bundled scenes, and byte-mutated scene files. Nothing may panic; every
//! accepted scene is valid (safe name, bounded periods, a controller configuration the
//! controller accepts), its exact stability computation and a short simulation of it return
//! `Ok` or `Err`, never panic.
//!
//! Bounded time: `FUZZ_CASES` cases per property (default 300); a longer run for a fuzz
//! campaign is `FUZZ_CASES=100000 cargo test -p sim --test integration --release fuzz_scene::`.

use proptest::prelude::*;
use sim::closed_loop::simulate;
use sim::scene::{BUNDLED, IntegratorSpec, MAX_PERIODS, MethodKind, Scene, check_name};

fn cases() -> u32 {
    std::env::var("FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(300)
}

/// Every key a scene has, and some it has not.
const KEYS: &[&str] = &[
    "name",
    "description",
    "plant.kind",
    "plant.params.jp",
    "plant.params.m",
    "plant.params.l",
    "plant.params.b1",
    "plant.params.nope",
    "controller.kp",
    "controller.kd",
    "controller.kphi_d",
    "controller.dt_ms",
    "controller.delay",
    "initial.state",
    "initial.history",
    "run.periods",
    "run.tasks",
    "run.escape_theta",
    "integrator.method",
    "integrator.rtol",
    "integrator.atol",
    "integrator.steps",
    "effects.quantization.mode",
    "effects.quantization.h_adc",
    "effects.quantization.h_adc_phi",
    "effects.quantization.h_dac",
    "effects.saturation.u_max",
    "effects.noise.seed",
    "effects.noise.sigma_theta",
    "effects.noise.sigma_phi",
    "effects.integral.ki",
    "controller",
    "run",
    "effects.quantization",
];

/// Floats of every class, as TOML literals.
fn float() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("0.0".to_string()),
        Just("-0.0".to_string()),
        Just("5e-324".to_string()),
        Just("1.7976931348623157e308".to_string()),
        Just("-1e300".to_string()),
        Just("1e-300".to_string()),
        Just("1e200".to_string()),
        (-1e3f64..1e3).prop_map(|v| format!("{v:e}")),
        any::<f64>().prop_filter("finite", |v| v.is_finite()).prop_map(|v| format!("{v:e}")),
    ]
}

fn value() -> impl Strategy<Value = String> {
    prop_oneof![
        float(),
        any::<i64>().prop_map(|v| v.to_string()),
        (0i64..20).prop_map(|v| v.to_string()),
        Just("9223372036854775807".to_string()),
        Just("-1".to_string()),
        Just("true".to_string()),
        Just("\"../../x\"".to_string()),
        Just("\"/abs/x\"".to_string()),
        Just("\"counts\"".to_string()),
        Just("\"literal\"".to_string()),
        Just("\"rk4\"".to_string()),
        Just("[\"stability\"]".to_string()),
        Just("[]".to_string()),
        prop::collection::vec(float(), 0..6).prop_map(|v| format!("[{}]", v.join(","))),
        prop::collection::vec((float(), float()), 0..4)
            .prop_map(|v| format!("[{}]", v.iter().map(|(a, b)| format!("[{a},{b}]")).collect::<Vec<_>>().join(","))),
        "[ -~]{0,12}",
    ]
}

/// Accepted scenes (the fraction is printed with `--nocapture`: the properties must reach
/// the computations, not only the parser).
static ACCEPTED: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// An accepted scene is valid, and computing with it never panics.
fn exercise(s: &Scene) {
    let n = ACCEPTED.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
    if n % 500 == 0 {
        println!("{n} accepted scenes exercised");
    }
    assert!(s.validate().is_ok(), "accepted but invalid: {s:?}");
    assert!(check_name(&s.name).is_ok());
    assert!(s.run.periods <= MAX_PERIODS);
    assert!(controller::validate_config::<{ sim::closed_loop::HISTORY }>(&s.controller_config()).is_ok());
    let _ = sim::stability::scene_multipliers(s);
    // A short run with a fixed-step integrator (the adaptive ones with random tolerances
    // are bounded by their own step limits, but slow): Ok or Err, no panic.
    let mut short = s.clone();
    short.run.periods = short.run.periods.min(5);
    short.integrator = IntegratorSpec { method: MethodKind::Rk4, rtol: None, atol: None, steps: Some(4) };
    if short.validate().is_ok() {
        if let Ok(tr) = simulate(&short, None) {
            assert!(tr.rows() <= 6);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_overrides_never_panic(
        scene in 0..BUNDLED.len(),
        sets in prop::collection::vec((prop::sample::select(KEYS), value()), 1..5),
    ) {
        let (name, text) = BUNDLED[scene];
        let overrides: Vec<String> = sets.iter().map(|(k, v)| format!("{k}={v}")).collect();
        if let Ok(s) = Scene::parse(name, text, &overrides) {
            exercise(&s);
        }
    }

    #[test]
    fn mutated_scene_files_never_panic(
        scene in 0..BUNDLED.len(),
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0u8..3), 1..6),
    ) {
        let mut bytes = BUNDLED[scene].1.as_bytes().to_vec();
        for (at, b, kind) in edits {
            let i = at.index(bytes.len() + 1);
            match kind {
                0 if i < bytes.len() => bytes[i] = b,
                1 => bytes.insert(i, b),
                _ if i < bytes.len() => { bytes.remove(i); }
                _ => {}
            }
        }
        let text = String::from_utf8_lossy(&bytes);
        if let Ok(s) = Scene::parse("fuzz", &text, &[]) {
            exercise(&s);
        }
    }
}
