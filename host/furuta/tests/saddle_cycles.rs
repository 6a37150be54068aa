//! The tests of `furuta::saddle_cycles`.

use furuta::Error;
use furuta::saddle_cycles::*;
use nalgebra::Complex;

type C = Complex<f64>;

/// The fast (mode-2) saddle cycle at 31.3 ms: Newton on the exact period map converges
/// to an invariant circle, a fixed point of the collocation system to 1e-10, with a
/// discretization error below 1e-10 between the points; the equation-driven model (order
/// 7, inside its radius of convergence here: rho* ~ 0.07 rad) has it to 1e-4 rad.
#[test]
fn fast_saddle_cycle_is_an_invariant_circle_of_the_exact_map() {
    let rows = saddle_cycles(&[31.3], 2, &[7], &CircleOptions::default()).unwrap();
    let r = &rows[0];
    eprintln!("{r:?}");
    let c = r.full.as_ref().unwrap();
    assert!(c.residual <= 1e-10, "{}", c.residual);
    assert!(c.residual_midpoints <= 1e-10, "{}", c.residual_midpoints);
    // Pinned against regressions (the row is printed above).
    assert!((c.theta_amplitude - 0.06954).abs() < 2e-5, "{}", c.theta_amplitude);
    let e = &r.equation[0];
    assert!((e.theta_amplitude.unwrap() - c.theta_amplitude).abs() < 1e-4, "{e:?}");
    assert!((e.freq_hz.unwrap() - c.freq_hz).abs() < 1e-3, "{e:?} {}", c.freq_hz);
}

/// The slow (mode-1) saddle cycle at 31 ms, beyond the root-test radius (~0.1 rad) of the
/// SSM series on the 0.05 rad sphere: the exact map's circle (a fixed point to 1e-10) and
/// the order-7 model's (rho* = its theta first harmonic, `Amplitude::Observable`) agree
/// within 0.2 % (with `Amplitude::Spectral` they did not). Both are printed and pinned.
#[test]
fn slow_saddle_cycle_of_the_exact_map_and_the_truncated_model() {
    let opts = CircleOptions { n: 65, ..CircleOptions::default() };
    let rows = saddle_cycles(&[31.0], 1, &[7], &opts).unwrap();
    let r = &rows[0];
    let c = r.full.as_ref().unwrap();
    eprintln!(
        "full: theta1 {} f {} Hz res {:e} mid {:e}; {:?}",
        c.theta_amplitude, c.freq_hz, c.residual, c.residual_midpoints, r.equation
    );
    assert!(c.residual <= 1e-10 && c.residual_midpoints <= 1e-8, "{} {}", c.residual, c.residual_midpoints);
    assert!((c.theta_amplitude - 0.17016).abs() < 2e-4, "{}", c.theta_amplitude);
    assert!((c.freq_hz - 0.5362).abs() < 1e-3, "{}", c.freq_hz);
    let e = &r.equation[0];
    assert!((e.rho.unwrap() - 0.17036).abs() < 1e-4, "{e:?}");
    assert!((e.rho.unwrap() - e.theta_amplitude.unwrap()).abs() < 1e-12, "{e:?}");
    let rel = e.theta_amplitude.unwrap() / c.theta_amplitude - 1.0;
    assert!(rel.abs() < 2e-3, "{rel}");
}

/// Known answer: `z -> z e^{i omega} (1 - 0.1 (1 - |z|^2))` (an unstable circle |z| = 1
/// turning by omega) with a slaved coordinate `w -> 0.01 w + x^2`: the circle is
/// `(cos t, sin t, A + 2 Re(c e^{2 i t}))`, `A = 0.5 / 0.99`, `c = 0.25 / (e^{2 i omega} - 0.01)`.
#[test]
fn invariant_circle_of_a_known_map() {
    let omega = 0.7;
    let f = |s: &[f64]| -> Result<Vec<f64>, Error> {
        let z = C::new(s[0], s[1]);
        let z2 = z * C::from_polar(1.0, omega) * (1.0 - 0.1 * (1.0 - z.norm_sqr()));
        Ok(vec![z2.re, z2.im, 0.01 * s[2] + s[0] * s[0]])
    };
    let n = 21;
    // A perturbed start: radius 1.05, w = 0.
    let guess: Vec<Vec<f64>> = (0..n)
        .map(|i| {
            let t = std::f64::consts::TAU * i as f64 / n as f64;
            vec![1.05 * t.cos(), 1.05 * t.sin(), 0.0]
        })
        .collect();
    let opts = CircleOptions { n, ..CircleOptions::default() };
    let c = invariant_circle_of(&f, &|s: &[f64]| s[0], &[1.0, 0.0, 0.0], 0.01, &guess, 0.65, &opts).unwrap();
    let a = 0.5 / 0.99;
    let cc = C::new(0.25, 0.0) / (C::from_polar(1.0, 2.0 * omega) - 0.01);
    for (i, k) in c.points.iter().enumerate() {
        let t = std::f64::consts::TAU * i as f64 / n as f64;
        let want = [t.cos(), t.sin(), a + 2.0 * (cc * C::from_polar(1.0, 2.0 * t)).re];
        for j in 0..3 {
            assert!((k[j] - want[j]).abs() < 1e-9, "point {i} component {j}: {} vs {}", k[j], want[j]);
        }
    }
    assert!((c.omega - omega).abs() < 1e-10, "{}", c.omega);
    assert!((c.theta_amplitude - 1.0).abs() < 1e-9 && c.residual < 1e-10 && c.residual_midpoints < 1e-9, "{c:?}");
    assert!((c.freq_hz - omega / (std::f64::consts::TAU * 0.01)).abs() < 1e-6);
}

#[test]
fn bad_circle_inputs_are_refused() {
    assert!(matches!(
        saddle_cycles(&[31.0], 3, &[7], &CircleOptions::default()),
        Err(Error::BadOption { what: "mode", .. })
    ));
    assert!(matches!(
        saddle_cycles(&[31.0], 1, &[11], &CircleOptions::default()),
        Err(Error::BadOption { what: "orders", .. })
    ));
}
