use serde_json::{Value, json};
use ssmctl::report::normal_form::*;
use ssmctl::report::prose::Prose;
use ssmctl::report::prose::{perturbed, unmoved};

/// The introduction's numbers all come from the setup: with every value moved, every
/// number of the text moves, with and without the anchored linear part.
#[test]
fn intro_numbers_follow_the_setup() {
    let p = Prose::new();
    for anchor in [json!(0.01), Value::Null] {
        let setup = json!({
            "embed": 9, "manifold_order": 3, "dyn_order": 7, "linear_normal": true, "linear_anchor": anchor,
            "dts_ms": [30.5, 31.0, 32.0, 32.5], "initial_states": 12, "slow_starts": 3,
            "modes_hz": [0.4412, 8.4513], "targets": RATE_TARGETS,
        });
        let a = p.html("parametric/intro", INTRO, &setup).unwrap();
        let b = p.html("parametric/intro", INTRO, &perturbed(&setup)).unwrap();
        assert!(a.contains("p = 9 of theta") && a.contains("~0.44 Hz") && a.contains("targets 1 % at training"), "{a}");
        assert_eq!(unmoved(&a, &b).unwrap(), [], "{a}\n{b}");
    }
}
