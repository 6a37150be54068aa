use sim::ode::internals::exprb54::*;
use sim::ode::internals::split::Cut;

/// The weights and stages of the method in closed form: the order conditions at `Z = 0`
/// (scalar `phi_k(0) = 1/k!`), for both solutions.
#[test]
fn coefficients_meet_the_order_conditions() {
    let (c2, c3, c4): (f64, f64, f64) = (C2, C3, C4);
    // phi_k(0)
    let (p3, p4, p5) = (1.0 / 6.0, 1.0 / 24.0, 1.0 / 120.0);
    // b_i(0) of the order-5 solution (b_2 = 0) and the order-4 one.
    let b5 = [0.0, 18.0 * p3 - 60.0 * p4, -250.0 / 81.0 * p3 + 500.0 / 27.0 * p4];
    let b4 = [64.0 * p3 - 60.0 * p4, -8.0 * p3 - 285.0 / 8.0 * p4, 125.0 / 8.0 * p4];
    let c = [c2, c3, c4];
    let moment = |b: &[f64; 3], k: i32| (0..3).map(|i| b[i] * c[i].powi(k)).sum::<f64>();
    for (name, b) in [("order 5", &b5), ("order 4", &b4)] {
        assert!((moment(b, 2) - 2.0 * p3).abs() < 1e-15, "{name}: sum b c^2");
        assert!((moment(b, 3) - 6.0 * p4).abs() < 1e-15, "{name}: sum b c^3");
    }
    assert!((moment(&b5, 4) - 24.0 * p5).abs() < 1e-15, "sum b c^4 = 24 phi5(0)");
    assert!((moment(&b4, 4) - 24.0 * p5).abs() > 1e-3, "the embedded solution is of order 4 only");
    // As polynomials in phi3, phi4 (Z != 0): sum b c^2 = 2 phi3, sum b c^3 = 6 phi4.
    for (b3c, b4c) in [
        ([0.0, 18.0, -250.0 / 81.0], [0.0, -60.0, 500.0 / 27.0]),
        ([64.0, -8.0, 0.0], [-60.0, -285.0 / 8.0, 125.0 / 8.0]),
    ] {
        let m = |w: &[f64; 3], k: i32| (0..3).map(|i| w[i] * c[i].powi(k)).sum::<f64>();
        assert!((m(&b3c, 2) - 2.0).abs() < 1e-14 && m(&b4c, 2).abs() < 1e-14);
        assert!(m(&b3c, 3).abs() < 1e-14 && (m(&b4c, 3) - 6.0).abs() < 1e-14);
    }
    // psi_3: a_32 c_2^2 / 2 = c_3^3, a_43 c_3^2 / 2 = c_4^3 (in units of phi3(c_i Z)).
    assert!((4.0 * c2 * c2 / 2.0 - c3.powi(3)).abs() < 1e-15);
    assert!((729.0 / 125.0 * c3 * c3 / 2.0 - c4.powi(3)).abs() < 1e-15);
    // The error estimate's weights are the difference of the two solutions'.
    let e3: [f64; 3] = [-64.0, 26.0, -250.0 / 81.0];
    let e4: [f64; 3] = [60.0, -195.0 / 8.0, 625.0 / 216.0];
    let d3 = [0.0 - 64.0, 18.0 + 8.0, -250.0 / 81.0];
    let d4 = [0.0 + 60.0, -60.0 + 285.0 / 8.0, 500.0 / 27.0 - 125.0 / 8.0];
    for i in 0..3 {
        assert!((e3[i] - d3[i]).abs() < 1e-14 && (e4[i] - d4[i]).abs() < 1e-14);
    }
}

/// The split's scalar `phi`-functions (the doubled `expm1` included) against the series
/// and closed forms, to the cut (or 4e-15 relative) at every `c`.
#[test]
fn fast_mode_phi_functions_meet_their_cut() {
    use crate::ode::split::phi_ref;
    let jac = [[-1.0]];
    for rtol in [1e-8, 1e-10, 3e-11, 1e-11, 1e-13] {
        let cut = Cut::for_rtol(rtol);
        for hl in [-1e-6, -0.3, -1.0, -2.0, -2.3, -3.0, -7.5, -21.0, -480.0, -1e4, 3.0] {
            let sp = Split54::<1>::new(&jac, &(-1.0, [1.0], [1.0]), -hl, &cut, false).unwrap();
            let z = hl;
            let got = [
                (sp.f1[0], 1, C2),
                (sp.f1[1], 1, C3),
                (sp.f1[2], 1, C4),
                (sp.f1[3], 1, 1.0),
                (sp.f3[0], 3, C3),
                (sp.f3[1], 3, C4),
                (sp.f3[2], 3, 1.0),
                (sp.f4, 4, 1.0),
            ];
            for (g, k, c) in got {
                let want = phi_ref(k, c * z);
                let tol = cut.term.max(4e-15) * want.abs();
                assert!((g - want).abs() <= tol, "rtol {rtol:e}: phi_{k}({c} * {z}) = {g:e}, want {want:e}");
            }
        }
    }
}

#[test]
fn weight_tables_are_the_taylor_coefficients() {
    let fact = |n: usize| (1..=n).fold(1.0f64, |a, i| a * i as f64);
    for (w, c, k) in [(&W1_C2, C2, 1), (&W1_C4, C4, 1), (&W3_C3, C3, 3), (&W4, 1.0, 4)] {
        for j in 0..MAX_TERMS {
            let want = c.powi(j as i32) / fact(j + k);
            assert!((w[j] - want).abs() <= 1e-14 * want, "c {c} k {k} j {j}: {} vs {want}", w[j]);
        }
    }
    assert!(2f64.powi(MAX_TERMS as i32) / fact(MAX_TERMS + 1) < 1e-18);
}
