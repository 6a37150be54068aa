use chaos_study::verdict::VerdictOptions;
use serde_json::json;
use ssmctl::report::prose::Prose;
use ssmctl::report::prose::{perturbed, unmoved};
use ssmctl::report::verdict::*;

/// The conclusion over the quick report's values, chaotic below a step or not and at the
/// attractor's scale or not: every number follows the values, the theory's slopes too.
#[test]
fn conclusion_follows_the_values() {
    let s = crate::report::pages::snapshot_summary();
    for chaotic in [true, false] {
        let mut v = s["microchaos_verdict"].clone();
        v["chaotic"] = json!(chaotic);
        v["chaotic_at_attractor_scale"] = json!(!chaotic);
        let values =
            json!({"v": v, "c": v["conclusion"], "fsle_slope": s["page_chaos_verdict"]["setup"]["fsle_slope"]});
        let a = crate::report::chaos::assert_numbers_follow("chaos-verdict/conclusion", CONCLUSION, &values);
        assert!(a.contains("diffusion gives -2, chaos 0):"), "{a}");
        assert_eq!(a.starts_with("The noise-free quantized loop is chaotic in the strict sense"), chaotic, "{a}");
        assert_eq!(a.contains("): exponential separation at the attractor's scale."), !chaotic, "{a}");
    }
}

/// Every number of the introduction comes from the options, the scene or the theory's
/// slopes: with all of them moved, every number of the text moves.
#[test]
fn intro_numbers_follow_the_setup() {
    let setup = json!({
        "options": VerdictOptions::quick(), "dt_ms": 25.0, "quantized": "q", "smooth": "s", "noisy": "n",
        "fsle_slope": {"chaos": FSLE_SLOPE_CHAOS, "diffusion": FSLE_SLOPE_DIFFUSION},
    });
    let p = Prose::new();
    let a = p.html("chaos-verdict/intro", INTRO, &setup).unwrap();
    assert!(a.contains("(q, 25 ms)") && a.contains("started 1e-9..1e-3 rad apart") && a.contains("-2 for diffusion"));
    let b = p.html("chaos-verdict/intro", INTRO, &perturbed(&setup)).unwrap();
    assert_eq!(unmoved(&a, &b).unwrap(), [], "{a}\n{b}");
}
