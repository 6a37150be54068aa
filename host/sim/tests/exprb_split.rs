//! `exprb-split` on the bundled Furuta scenes against the tight RODAS4 reference: the smooth
//! loops, the quantized ones (counts and literal quantizer), saturation, and a longer delay.
//! Quantized loops are chaotic, so the comparison covers the first periods, where a tiny
//! integration error cannot yet have flipped an encoder count: there the codes must agree
//! exactly and the states to far below one count.

use sim::closed_loop::simulate;
use sim::scene::{IntegratorSpec, MethodKind};

use crate::common;
use common::scene;

#[test]
fn exprb_split_matches_the_reference_on_the_furuta_scenes() {
    for (name, periods, delay, bound) in [
        ("furuta-dt30.8", 150, None, 2e-10),
        ("furuta-dt31.2", 150, None, 2e-10),
        ("furuta-dt25", 150, Some(3), 2e-10),
        ("furuta-saturation", 150, None, 2e-10),
        ("furuta-quant-dt25", 60, None, 2e-10),
        ("furuta-microchaos", 60, None, 2e-10),
        ("furuta-literal-dt25", 60, None, 2e-10),
    ] {
        let reference = simulate(&scene(name, periods, MethodKind::Rodas, 1e-13, delay), None).unwrap();
        let got = simulate(&scene(name, periods, MethodKind::ExprbSplit, 1e-10, delay), None).unwrap();
        assert_eq!(got.rows(), reference.rows(), "{name}");
        // theta in rad; every state relative to its size (at least 1).
        let err = got.primary().iter().zip(reference.primary()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        let rel = common::max_relative_state_error(&got, &reference);
        assert!(err < bound && err > 0.0, "{name}: max theta error {err:e}");
        assert!(rel < 50.0 * bound, "{name}: max relative state error {rel:e}");
        assert_eq!(got.codes, reference.codes, "{name}: integer codes differ");
        assert_eq!(got.u.len(), reference.u.len());
        let amp = reference.primary().iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(amp > 1e-3, "{name}: the loop does nothing (max theta {amp})");
        eprintln!(
            "{name}: max theta error {err:.2e}, state {rel:.2e}, {:.1} steps/period",
            (got.ode_stats.steps + got.ode_stats.rejected) as f64 / periods as f64
        );
    }
}

#[test]
fn exprb_split_scene_key_is_validated() {
    common::assert_scene_key_is_validated(MethodKind::ExprbSplit);
    let parsed: IntegratorSpec = toml::from_str("method = \"exprb-split\"\nrtol = 1e-9\natol = 1e-11").unwrap();
    assert_eq!(parsed.method, MethodKind::ExprbSplit);
}
