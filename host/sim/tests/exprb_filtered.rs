//! `exprb-filtered` on the bundled Furuta scenes against the tight RODAS4 reference, as
//! `exprb_lean.rs` does for `exprb-lean`, at rtol = atol (the full-system scene's setting):
//! the smooth loops, a longer delay, saturation and the quantized (chaotic) loops over their
//! first periods, where the integer codes must agree exactly at 1e-10. The errors and steps are
//! printed next to exprb-lean's.
//!
//! The filter pays on the smooth loops; on the chaotic ones an error made anywhere grows, and
//! its steps buy less accuracy there.

use sim::closed_loop::simulate;
use sim::scene::{IntegratorSpec, MethodKind};

use crate::common;
use common::scene;

#[test]
fn exprb_filtered_matches_the_reference_on_the_furuta_scenes() {
    // (scene, periods, delay, bound at 1e-10, bound at 4e-9)
    for (name, periods, delay, bound, bound_4e9) in [
        ("furuta-dt30.8", 150, None, 5e-11, 1e-9),
        ("furuta-dt31.2", 150, None, 5e-11, 1e-9),
        ("furuta-dt25", 150, Some(3), 4e-10, 8e-9),
        ("furuta-saturation", 150, None, 6e-11, 1.2e-9),
        ("furuta-quant-dt25", 60, None, 2.5e-9, 6e-8),
        ("furuta-microchaos", 60, None, 2e-9, 4e-8),
        ("furuta-literal-dt25", 60, None, 1.5e-9, 4e-8),
    ] {
        let reference = simulate(&scene(name, periods, MethodKind::Rodas, 1e-13, delay), None).unwrap();
        let mut errs = Vec::new();
        for (tol, bound) in [(1e-10, bound), (4e-9, bound_4e9)] {
            for method in [MethodKind::ExprbFiltered, MethodKind::ExprbLean] {
                let mut s = scene(name, periods, method, tol, delay);
                s.integrator.atol = Some(tol);
                let got = simulate(&s, None).unwrap();
                assert_eq!(got.rows(), reference.rows(), "{name}");
                let err = got.primary().iter().zip(reference.primary()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                let st = got.ode_stats;
                errs.push(format!(
                    "{method:?} {tol:e}: {err:.2e} rad, {:.1} steps/period",
                    (st.steps + st.rejected) as f64 / periods as f64
                ));
                if method == MethodKind::ExprbLean {
                    continue;
                }
                assert!(err < bound && err > 0.0, "{name} tol {tol:e}: max theta error {err:e}");
                if tol == 1e-10 {
                    let rel = common::max_relative_state_error(&got, &reference);
                    assert!(rel < 100.0 * bound, "{name}: max relative state error {rel:e}");
                    assert_eq!(got.codes, reference.codes, "{name}: integer codes differ");
                }
            }
        }
        eprintln!("{name} ({periods} periods): {}", errs.join("; "));
    }
}

#[test]
fn exprb_filtered_scene_key_is_validated() {
    let parsed: IntegratorSpec = toml::from_str("method = \"exprb-filtered\"\nrtol = 4e-9\natol = 4e-9").unwrap();
    assert_eq!(parsed.method, MethodKind::ExprbFiltered);
    common::assert_scene_key_is_validated(MethodKind::ExprbFiltered);
}
