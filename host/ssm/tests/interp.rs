//! The tests of `ssm::interp`.

use ssm::dynamics::ReducedDynamics;
use ssm::fit::SsmModel;
use ssm::interp::*;
use ssm::poly::Poly;

/// A hand-built map model whose every coefficient is affine in `a`: mixing models at
/// `a_i` with weights summing to 1 gives the model at `sum w_i a_i` (to rounding).
fn map_model(a: f64) -> SsmModel {
    let mut m = crate::backbone::model(0.3, 1.0 + a);
    let exps = ssm::poly::exponents(2, 1, 3);
    let coef = (0..exps.len() * 2).map(|k| 0.01 * (k as f64 + 1.0) * (1.0 - 0.5 * a) + 0.001 * a).collect();
    m.dynamics = ReducedDynamics::Map {
        increment: Poly { dim_in: 2, dim_out: 2, scale: vec![1.0, 1.0], exps, coef },
        dt: 0.01,
        conditioning: ssm::ridge::Conditioning::NONE,
    };
    m.manifold.v1.iter_mut().for_each(|v| *v *= 1.0 + a);
    m
}

#[test]
fn mix_models_mixes_coefficients() {
    let (m0, m1, m2) = (map_model(0.0), map_model(1.0), map_model(0.25));
    let w = [0.75, 0.25];
    let max_diff = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
    let inc = |m: &SsmModel| match &m.dynamics {
        ReducedDynamics::Map { increment, dt, .. } => (increment.coef.clone(), *dt),
        _ => (Vec::new(), 0.0),
    };
    let nl = |m: &SsmModel| m.manifold.nonlinear.as_ref().map(|p| p.coef.clone()).unwrap_or_default();
    let mixed = mix_models(&[&m0, &m1], &w, 0, V1Mix::Mixed, 0.02).unwrap();
    assert!(max_diff(&inc(&mixed).0, &inc(&m2).0) < 1e-16 && max_diff(&nl(&mixed), &nl(&m2)) < 1e-15);
    assert!(max_diff(&mixed.manifold.v1, &m2.manifold.v1) < 1e-15);
    assert_eq!((inc(&mixed).1, mixed.dt), (0.02, 0.02));
    assert_eq!(mixed.eigenvalues_ct, mixed.dynamics.eigenvalues_ct().unwrap());
    // Shared: the base's V1 bit for bit, everything else mixed as before.
    let shared = mix_models(&[&m0, &m1], &w, 1, V1Mix::Shared, 0.02).unwrap();
    assert_eq!(shared.manifold.v1, m1.manifold.v1);
    assert_eq!(inc(&shared).0, inc(&mixed).0);
    // Refused: counts, other monomials, not a map.
    assert!(matches!(
        mix_models(&[&m0, &m1], &[1.0], 0, V1Mix::Mixed, 0.02),
        Err(ssm::Error::Mix(MixError::Count { .. }))
    ));
    let mut other = map_model(1.0);
    if let ReducedDynamics::Map { increment, .. } = &mut other.dynamics {
        increment.scale[0] = 2.0;
    }
    assert!(matches!(
        mix_models(&[&m0, &other], &w, 0, V1Mix::Mixed, 0.02),
        Err(ssm::Error::Mix(MixError::Mismatch { index: 1, base: 0, part: "map increment" }))
    ));
    let flow = crate::backbone::model(0.3, 1.0);
    assert!(matches!(
        mix_models(&[&m0, &flow], &w, 0, V1Mix::Mixed, 0.02),
        Err(ssm::Error::Mix(MixError::NotAMap { index: 1 }))
    ));
}

#[test]
fn spline_weights() {
    // Node values reproduced exactly, by both interpolants.
    let nodes = [30.5, 31.0, 32.0, 32.5];
    for interp in [Interp::Linear, Interp::Spline] {
        for (i, &x) in nodes.iter().enumerate() {
            let w = interp_weights(&nodes, x, interp).unwrap();
            for (j, wj) in w.iter().enumerate() {
                assert!((wj - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14, "{interp:?} node {i}: {w:?}");
            }
        }
    }
    // Hand-derived natural spline through (0,0), (1,1), (2,0): m_1 = -3, so on [0,1]
    // S(x) = -x^3/2 + 3x/2, and by symmetry S(2-x) = S(x).
    let n3 = [0.0, 1.0, 2.0];
    let y3 = [0.0, 1.0, 0.0];
    let ev = |x: f64| interp_weights(&n3, x, Interp::Spline).unwrap().iter().zip(&y3).map(|(w, y)| w * y).sum::<f64>();
    for x in [0.1, 0.25, 0.5, 0.9] {
        let s = -x * x * x / 2.0 + 1.5 * x;
        assert!((ev(x) - s).abs() < 1e-14 && (ev(2.0 - x) - s).abs() < 1e-14, "x {x}: {} vs {s}", ev(x));
    }
    // A natural spline is exact for straight lines; on the training nodes a cubic
    // y = (x - 31)^3 is NOT reproduced (its ends have nonzero curvature), but the
    // interpolant is C2 with zero end curvature: check by finite differences.
    let f = |x: f64| 2.0 - 0.3 * x;
    let yc: Vec<f64> = nodes.iter().map(|&x| (x - 31.0f64).powi(3)).collect();
    let s = |x: f64, y: &[f64]| {
        interp_weights(&nodes, x, Interp::Spline).unwrap().iter().zip(y).map(|(w, v)| w * v).sum::<f64>()
    };
    let yl: Vec<f64> = nodes.iter().map(|&x| f(x)).collect();
    for x in [30.6, 30.9, 31.3, 31.77, 32.2, 32.45] {
        assert!((s(x, &yl) - f(x)).abs() < 1e-12, "line at {x}");
    }
    let h = 1e-4;
    let d2 = |x: f64| (s(x + h, &yc) - 2.0 * s(x, &yc) + s(x - h, &yc)) / (h * h);
    let d1 = |x: f64, side: f64| (s(x + side * h, &yc) - s(x, &yc)) / (side * h);
    assert!(
        d2(30.5 + h).abs() < 5e-3 && d2(32.5 - h).abs() < 5e-3 && d2(31.5).abs() > 0.5,
        "end curvature {} {}",
        d2(30.5 + h),
        d2(32.5 - h)
    );
    for &xi in &nodes[1..3] {
        // one-sided slopes agree to O(h), second derivatives on both sides too
        assert!((d1(xi, 1.0) - d1(xi, -1.0)).abs() < 1e-2, "C1 at {xi}");
        assert!(
            (d2(xi + 2.0 * h) - d2(xi - 2.0 * h)).abs() < 0.1,
            "C2 at {xi}: {} vs {}",
            d2(xi + 2.0 * h),
            d2(xi - 2.0 * h)
        );
    }
    assert!(matches!(interp_weights(&nodes, 32.6, Interp::Spline), Err(InterpError::OutOfRange { .. })));
    assert!(matches!(interp_weights(&[1.0, 1.0], 1.0, Interp::Linear), Err(InterpError::BadNodes(_))));
}
