//! Estimators against systems with known answers. Tolerances are stated at each assert.

use chaos::reference::{Henon, Lorenz};
use chaos::{
    BenettinParams, ChaosError, CorrSumParams, DivergenceParams, FitRule, Points, ScalingRule, benettin_qr,
    benettin_tangent, benettin_two_trajectory, correlation_dimension, correlation_sum, delay_embed, iterate_map, kantz,
    rosenstein,
};

/// Published largest exponent of the Hénon map (a = 1.4, b = 0.3), per iteration.
const HENON_LAMBDA: f64 = 0.41922;
/// Published largest exponent of the Lorenz system (10, 28, 8/3), 1/s.
const LORENZ_LAMBDA: f64 = 0.9056;

fn henon_x(n: usize) -> Vec<f64> {
    Henon::default().orbit(n, 1000).iter().map(|s| s[0]).collect()
}

#[test]
fn circle_has_dimension_one_and_exponent_zero() {
    // Period 12 pi = 37.7 samples (irrational, so the orbit never repeats exactly).
    let x: Vec<f64> = (0..6000).map(|i| (i as f64 / 6.0).sin()).collect();
    let p = delay_embed(&x, 2, 10).unwrap();
    let prm = CorrSumParams { theiler: 40, ..Default::default() };
    let d = correlation_dimension(&p, &prm, &ScalingRule::default()).unwrap();
    println!("circle: D2 = {:.4} +- {:.4} over r = {:.3e}..{:.3e}", d.dimension, d.slope_std, d.r_range.0, d.r_range.1);
    assert!((d.dimension - 1.0).abs() < 0.05, "D2 = {}", d.dimension);

    let lp = DivergenceParams { theiler: 40, max_steps: 100, ..Default::default() };
    let l = rosenstein(&p, &lp, &FitRule::default()).unwrap();
    println!("circle: Rosenstein {:.5}/sample, rise {:.3}, grew {}", l.fit.exponent, l.fit.rise, l.fit.grew);
    assert!(!l.fit.grew);
    assert!(l.fit.exponent.abs() < 2e-3, "{}", l.fit.exponent);
}

#[test]
fn two_torus_has_dimension_two() {
    // Both periods irrational in samples (40.2 and 24.9), ratio the golden mean.
    let w1 = 1.0 / 6.4;
    let w2 = w1 * (1.0 + 5f64.sqrt()) / 2.0;
    let x: Vec<f64> = (0..12000).map(|i| (w1 * i as f64).sin() + 0.8 * (w2 * i as f64).sin()).collect();
    let p = delay_embed(&x, 5, 7).unwrap();
    let prm = CorrSumParams { theiler: 40, ..Default::default() };
    let d = correlation_dimension(&p, &prm, &ScalingRule::default()).unwrap();
    println!(
        "torus: D2 = {:.4} +- {:.4} (fit se {:.4}) over r = {:.3e}..{:.3e}",
        d.dimension, d.slope_std, d.fit_stderr, d.r_range.0, d.r_range.1
    );
    assert!((d.dimension - 2.0).abs() < 0.15, "D2 = {}", d.dimension);
    assert_eq!(chaos::ssm_dimension(d.dimension).unwrap(), if d.dimension < 2.0 { 2 } else { 4 });
}

#[test]
fn henon_correlation_dimension() {
    let x = henon_x(20_000);
    let p = delay_embed(&x, 2, 1).unwrap();
    let d = correlation_dimension(&p, &CorrSumParams::default(), &ScalingRule::default()).unwrap();
    println!(
        "henon: D2 = {:.4} +- {:.4} (fit se {:.4}) over r = {:.3e}..{:.3e}, {} radii",
        d.dimension,
        d.slope_std,
        d.fit_stderr,
        d.r_range.0,
        d.r_range.1,
        d.index_range.1 - d.index_range.0 + 1
    );
    // Published 1.21 +- 0.01 (Grassberger & Procaccia 1983); later, larger samples give
    // 1.22. Accept 1.17..1.27.
    assert!((1.17..=1.27).contains(&d.dimension), "D2 = {}", d.dimension);
    // The same from the states (x, y) themselves.
    let states = Points::from_rows(&Henon::default().orbit(20_000, 1000)).unwrap();
    let ds = correlation_dimension(&states, &CorrSumParams::default(), &ScalingRule::default()).unwrap();
    println!("henon states: D2 = {:.4} +- {:.4}", ds.dimension, ds.slope_std);
    assert!((1.17..=1.27).contains(&ds.dimension), "D2 = {}", ds.dimension);
}

#[test]
fn henon_benettin_exact_jacobian_and_two_trajectory() {
    let h = Henon::default();
    let prm = BenettinParams { transient: 1000, steps: 1_000_000, bound: 10.0, ..Default::default() };
    let t0 = std::time::Instant::now();
    let r = benettin_tangent(&[0.1, 0.1], |x, v| h.tangent_step(x, v), &prm).unwrap();
    println!(
        "henon Benettin tangent: {:.5} +- {:.5} ({:.3} s for 1e6 steps)",
        r.exponent,
        r.std_error,
        t0.elapsed().as_secs_f64()
    );
    assert!((r.exponent - HENON_LAMBDA).abs() < 0.005, "{}", r.exponent);
    assert!(r.std_error < 0.005);
    assert_eq!(r.steps, 1_000_000);

    let step = chaos::benettin::jacobian_tangent_step(2, |x, o| h.map(x, o), |x, j| h.jacobian(x, j));
    let rj = benettin_tangent(&[0.1, 0.1], step, &BenettinParams { steps: 200_000, ..prm }).unwrap();
    assert!((rj.exponent - HENON_LAMBDA).abs() < 0.01, "{}", rj.exponent);

    let mut nx = [0.0; 2];
    let r2 = benettin_two_trajectory(
        &[0.1, 0.1],
        |x| {
            h.map(x, &mut nx);
            x.copy_from_slice(&nx);
        },
        1e-9,
        &BenettinParams { steps: 200_000, ..prm },
    )
    .unwrap();
    println!("henon Benettin two-trajectory d0=1e-9: {:.5} +- {:.5}", r2.exponent, r2.std_error);
    assert!((r2.exponent - HENON_LAMBDA).abs() < 0.01, "{}", r2.exponent);
}

#[test]
fn henon_rosenstein_and_kantz() {
    let x = henon_x(10_000);
    let p = delay_embed(&x, 2, 1).unwrap();
    let lp = DivergenceParams { theiler: 1, max_steps: 25, max_reference: 3000, ..Default::default() };
    let l = rosenstein(&p, &lp, &FitRule::default()).unwrap();
    println!(
        "henon Rosenstein: {:.4} window {:?}, rise {:.2}\n  curve {:?}",
        l.fit.exponent,
        l.fit.window,
        l.fit.rise,
        l.curve.mean_log_distance.iter().map(|v| (v * 100.0).round() / 100.0).collect::<Vec<_>>()
    );
    assert!((l.fit.exponent - HENON_LAMBDA).abs() < 0.05, "{}", l.fit.exponent);

    let eps = chaos::log_spaced(0.002, 0.2, 5).unwrap();
    let k = kantz(&p, &eps, &lp, 50, &FitRule::default()).unwrap();
    for e in &k {
        println!(
            "henon Kantz eps {:.4}: {:?} (neighbours {:.1}) {:?}",
            e.eps,
            e.fit.map(|f| (f.exponent, f.window)),
            e.mean_neighbours,
            e.failure
        );
    }
    let small = k[0].fit.expect("smallest eps has a fit");
    assert!((small.exponent - HENON_LAMBDA).abs() < 0.07, "{}", small.exponent);
}

#[test]
fn lorenz_benettin_rk4() {
    let lz = Lorenz::default();
    let h = 0.01;
    let prm = BenettinParams { transient: 10_000, steps: 400_000, time_step: h, bound: 1e3, ..Default::default() };
    let t0 = std::time::Instant::now();
    let r = benettin_tangent(&[1.0, 1.0, 1.0], |x, v| lz.rk4_tangent_step(x, v, h), &prm).unwrap();
    println!(
        "lorenz Benettin: {:.4} +- {:.4} 1/s ({:.3} s for 4e5 RK4 steps)",
        r.exponent,
        r.std_error,
        t0.elapsed().as_secs_f64()
    );
    // Finite time (4000 s): accept +-0.03, a margin of about 3x over the standard error printed above.
    assert!((r.exponent - LORENZ_LAMBDA).abs() < 0.03, "{}", r.exponent);

    let r2 = benettin_two_trajectory(
        &[1.0, 1.0, 1.0],
        |x| lz.rk4_step(x, h),
        1e-8,
        &BenettinParams { renorm_every: 10, ..prm },
    )
    .unwrap();
    println!("lorenz two-trajectory: {:.4} +- {:.4} 1/s", r2.exponent, r2.std_error);
    assert!((r2.exponent - LORENZ_LAMBDA).abs() < 0.03, "{}", r2.exponent);
}

#[test]
fn lorenz_rosenstein_from_x() {
    let lz = Lorenz::default();
    let dt = 0.02;
    let x: Vec<f64> = lz.orbit(12_000, 0.01, 2, 5000).iter().map(|s| s[0]).collect();
    let p = delay_embed(&x, 3, 5).unwrap();
    let lp = DivergenceParams { theiler: 40, max_steps: 200, max_reference: 2000, dt, ..Default::default() };
    let l = rosenstein(&p, &lp, &FitRule::default()).unwrap();
    println!("lorenz Rosenstein: {:.4} 1/s window {:?} s, rise {:.2}", l.fit.exponent, l.fit.window_time, l.fit.rise);
    assert!((l.fit.exponent - LORENZ_LAMBDA).abs() < 0.15, "{}", l.fit.exponent);
}

#[test]
fn long_bounded_iteration_and_escape() {
    let h = Henon::default();
    let o = iterate_map(&[0.1, 0.1], |x, out| h.map(x, out), 1_000_000, 10.0, 1000).unwrap();
    assert_eq!(o.steps, 1_000_000);
    assert_eq!(o.recorded.as_ref().unwrap().len(), 1001);
    assert!(o.final_state.iter().all(|v| v.abs() < 2.0));

    // Outside the basin: x1 = 1 - 1.4*4 = -4.6, then -28.6, -1150, -1.85e6 > bound at step 4.
    let e = iterate_map(&[2.0, 0.0], |x, out| h.map(x, out), 1_000_000, 1e6, 0).unwrap_err();
    assert!(matches!(e, ChaosError::Escape { step: 4, reason: "state left the bound", .. }), "{e}");
    // A map that produces NaN is reported as non-finite, with the step.
    let e = iterate_map(&[0.5], |x, out| out[0] = (x[0] - 0.3).sqrt(), 100, 1e6, 0).unwrap_err();
    assert!(matches!(e, ChaosError::Escape { reason: "non-finite state", .. }), "{e}");
    // Benettin reports escape the same way.
    let bad = Henon { a: 2.0, b: 0.3 };
    let e = benettin_tangent(&[0.1, 0.1], |x, v| bad.tangent_step(x, v), &BenettinParams::default()).unwrap_err();
    assert!(matches!(e, ChaosError::Escape { .. }), "{e}");
}

#[test]
fn estimators_reject_bad_series() {
    let x = henon_x(100);
    let p = delay_embed(&x, 2, 1).unwrap();
    assert!(matches!(
        correlation_sum(&p, &CorrSumParams { theiler: 60, ..Default::default() }),
        Err(ChaosError::TooShort { param: "theiler (pairs outside the window)", .. })
    ));
    assert!(matches!(
        rosenstein(&p, &DivergenceParams { max_steps: 95, ..Default::default() }, &FitRule::default()),
        Err(ChaosError::TooShort { param: "max_steps + 2*(theiler+1)", .. })
    ));
    let mut y = x.clone();
    y[7] = f64::INFINITY;
    assert!(matches!(delay_embed(&y, 2, 1), Err(ChaosError::NonFinite { index: 7, .. })));
    assert!(matches!(Points::from_series(&y), Err(ChaosError::NonFinite { index: 7, .. })));
    let c = Points::from_series(&[3.0; 200]).unwrap();
    assert!(matches!(
        rosenstein(&c, &DivergenceParams::default(), &FitRule::default()),
        Err(ChaosError::ZeroVariance { coord: 0, .. })
    ));
    assert!(matches!(
        kantz(&p, &[-1.0], &DivergenceParams { max_steps: 10, ..Default::default() }, 10, &FitRule::default()),
        Err(ChaosError::BadParameter { name: "eps", .. })
    ));
}

#[test]
fn henon_spectrum_by_qr() {
    // Two exponents: the largest is the published 0.41922 per iteration; det J = -b is
    // constant, so l1 + l2 = ln b exactly (up to rounding) at any run length.
    let h = Henon::default();
    let prm = BenettinParams { transient: 1000, steps: 200_000, bound: 10.0, ..Default::default() };
    let jac = |x: &[f64], j: &mut [f64]| {
        h.jacobian(x, j);
        Ok(())
    };
    let r = benettin_qr(&[0.1, 0.1], |x, o| h.map(x, o), jac, 2, &prm).unwrap();
    println!("henon QR spectrum {:?} +- {:?}, Kaplan-Yorke {:?}", r.exponents, r.std_error, r.kaplan_yorke);
    assert!((r.exponents[0] - HENON_LAMBDA).abs() < 0.005, "{:?}", r.exponents);
    assert!((r.exponents[0] + r.exponents[1] - 0.3f64.ln()).abs() < 1e-9, "{:?}", r.exponents);
    // Kaplan-Yorke dimension 1 + l1 / |l2| = 1.258 for the published exponents.
    let ky = r.kaplan_yorke.unwrap();
    assert!((ky - (1.0 + HENON_LAMBDA / (HENON_LAMBDA - 0.3f64.ln()))).abs() < 0.003, "{ky}");
    // One vector gives the same largest exponent as the single-vector tangent method.
    let r1 = benettin_qr(&[0.1, 0.1], |x, o| h.map(x, o), jac, 1, &prm).unwrap();
    assert!((r1.exponents[0] - r.exponents[0]).abs() < 1e-12);

    // A kink where the Jacobian does not exist is reported with its step, never as NaN.
    let e = benettin_qr(
        &[0.0],
        |x, o| o[0] = 0.5 * x[0].abs(),
        |x, j| {
            if x[0] == 0.0 {
                Err("kink of |x| at 0")
            } else {
                j[0] = 0.5 * x[0].signum();
                Ok(())
            }
        },
        1,
        &BenettinParams { transient: 10, steps: 100, ..Default::default() },
    )
    .unwrap_err();
    assert_eq!(e, ChaosError::NotDifferentiable { step: 0, reason: "kink of |x| at 0" });
    assert!(matches!(
        benettin_qr(&[0.1, 0.1], |x, o| h.map(x, o), jac, 3, &prm),
        Err(ChaosError::BadParameter { name: "k (tangent vectors)", .. })
    ));
}
