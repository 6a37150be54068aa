//! `exprb-lean` on the bundled Furuta scenes against the tight RODAS4 reference, as
//! `exprb_split.rs` does for `exprb-split`: the smooth loops, a longer delay, saturation and the
//! quantized (chaotic) loops over their first periods, where the integer codes must agree
//! exactly. Also the errors at rtol 4e-9 and 1e-8 (the bench's operating points), printed.

use sim::closed_loop::simulate;
use sim::scene::{IntegratorSpec, MethodKind};

use crate::common;
use common::scene;

#[test]
fn exprb_lean_matches_the_reference_on_the_furuta_scenes() {
    // (scene, periods, delay, bound at rtol 1e-10, bound at rtol 4e-9)
    for (name, periods, delay, bound, bound_4e9) in [
        ("furuta-dt30.8", 150, None, 2e-10, 1e-9),
        ("furuta-dt31.2", 150, None, 2e-10, 1e-9),
        ("furuta-dt25", 150, Some(3), 2e-10, 5e-9),
        ("furuta-saturation", 150, None, 2e-10, 5e-9),
        ("furuta-quant-dt25", 60, None, 2e-10, 5e-9),
        ("furuta-microchaos", 60, None, 2e-10, 5e-9),
        ("furuta-literal-dt25", 60, None, 2e-10, 5e-9),
    ] {
        let reference = simulate(&scene(name, periods, MethodKind::Rodas, 1e-13, delay), None).unwrap();
        let mut errs = Vec::new();
        for (rtol, bound) in [(1e-10, bound), (4e-9, bound_4e9), (1e-8, 10.0 * bound_4e9)] {
            let got = simulate(&scene(name, periods, MethodKind::ExprbLean, rtol, delay), None).unwrap();
            assert_eq!(got.rows(), reference.rows(), "{name}");
            let err = got.primary().iter().zip(reference.primary()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            assert!(err < bound && err > 0.0, "{name} rtol {rtol:e}: max theta error {err:e}");
            if rtol == 1e-10 {
                let rel = common::max_relative_state_error(&got, &reference);
                assert!(rel < 50.0 * bound, "{name}: max relative state error {rel:e}");
                assert_eq!(got.codes, reference.codes, "{name}: integer codes differ");
            }
            let st = got.ode_stats;
            errs.push(format!(
                "rtol {rtol:e}: {err:.2e} rad, {:.1} steps/period",
                (st.steps + st.rejected) as f64 / periods as f64
            ));
        }
        eprintln!("{name} ({periods} periods): {}", errs.join("; "));
    }
}

#[test]
fn exprb_lean_scene_key_is_validated() {
    let parsed: IntegratorSpec = toml::from_str("method = \"exprb-lean\"\nrtol = 4e-9\natol = 4e-11").unwrap();
    assert_eq!(parsed.method, MethodKind::ExprbLean);
    common::assert_scene_key_is_validated(MethodKind::ExprbLean);
}
