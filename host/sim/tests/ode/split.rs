use nalgebra::SVector;
use sim::ode::internals::split::*;
use sim::plant::{Furuta, jacobian};

/// `phi_k(z)`, `k = 0..=4`, to full precision: [`phi_scalar_cut`] with the series cut at
/// `1e-18` of its first term.
fn phi_scalar(z: f64) -> [f64; 5] {
    phi_scalar_cut(z, 1e-18)
}

/// `phi_k(z)`, `k = 0..=4`, and `phi_1(z/2)` to full precision ([`phi_scalar_and_half_cut`]).
fn phi_scalar_and_half(z: f64) -> ([f64; 5], f64) {
    phi_scalar_and_half_cut(z, 1e-18)
}

/// Uniform draws in `[lo, hi)` from a 64-bit LCG (Knuth's MMIX constants) seeded with
/// `seed`: the random Jacobians and states of the pair tests.
fn uniform_stream(mut seed: u64) -> impl FnMut(f64, f64) -> f64 {
    move |lo, hi| {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// `phi_k(z)` by the series `sum_j z^j/(j+k)!` (60 terms) for `|z| <= 1`, the closed form
/// `(e^z - sum_{j<k} z^j/j!)/z^k` beyond (no cancellation there for `k <= 4`).
pub(crate) fn phi_ref(k: usize, z: f64) -> f64 {
    let fact = |n: usize| (1..=n).fold(1.0f64, |a, i| a * i as f64);
    if z.abs() <= 1.0 {
        (0..60).map(|j| z.powi(j as i32) / fact(j + k)).sum()
    } else {
        let mut s = z.exp();
        for j in 0..k {
            s -= z.powi(j as i32) / fact(j);
        }
        s / z.powi(k as i32)
    }
}

#[test]
fn scalar_phi_functions_match_series_and_closed_form() {
    for z in [0.0, 1e-8, -1e-3, 0.37, -1.0, -1.99, 1.999, -2.0, 2.5, -3.0, -7.5, -21.0, -480.0, -1e4, 6.0] {
        let p = phi_scalar(z);
        for (k, got) in p.iter().enumerate() {
            let want = phi_ref(k, z);
            let tol = if z.abs() <= 1.0 { 4e-15 } else { 2e-14 };
            assert!((got - want).abs() <= tol * want.abs(), "phi_{k}({z}) = {got:e}, want {want:e}");
        }
    }
}

#[test]
fn lean_scalar_phi_functions_meet_their_cut() {
    for rtol in [1e-6, 1e-8, 1e-10, 1e-12, 1e-15] {
        let cut = Cut::for_rtol(rtol);
        for z in [
            0.0, 1e-9, -1e-4, -0.01, -0.05, 0.07, -0.1, -0.3, -0.99, 1.5, -1.99, -2.0, -3.0, -7.5, -21.0, -480.0, -1e4,
            6.0,
        ] {
            let (p, half) = phi_lean(z, &cut);
            for (k, got) in p.iter().enumerate() {
                let want = phi_ref(k, z);
                let tol = cut.term.max(4e-15) * if k == 0 { want.abs().max(1.0) } else { want.abs() };
                assert!((got - want).abs() <= tol, "rtol {rtol:e}: phi_{k}({z}) = {got:e}, want {want:e}");
            }
            let want = phi_ref(1, 0.5 * z);
            assert!((half - want).abs() <= 4e-15 * want.abs(), "rtol {rtol:e}: phi_1({z}/2) = {half:e}, want {want:e}");
        }
    }
}

#[test]
fn scalar_phi_and_half_agree_with_the_single_evaluations() {
    for z in [0.0, -1.0, -3.9, -4.0, 4.5, -7.5, -21.0, -480.0] {
        let (p, h) = phi_scalar_and_half(z);
        let q = phi_scalar(z);
        for k in 0..5 {
            assert!((p[k] - q[k]).abs() <= 4e-16 * q[k].abs(), "phi_{k}({z}): {} vs {}", p[k], q[k]);
        }
        let want = phi_ref(1, 0.5 * z);
        assert!((h - want).abs() <= 4e-15 * want.abs(), "phi_1({z}/2): {h} vs {want}");
    }
}

/// The split phi-functions against the full matrix functions (scaling and squaring,
/// itself checked against an eigendecomposition in `exprb.rs`), at Furuta states from the
/// upright to a tilted, fast-moving one, for steps from 10 us to a period.
#[test]
fn split_phi_functions_match_the_matrix_functions_on_the_furuta_jacobian() {
    let p = Furuta::paper();
    let mut used = 0;
    for (x, u) in [
        ([0.0, 0.0, 0.0, 0.0], 0.0),
        ([0.05, 1.0, 0.3, 0.5], 0.7),
        ([-0.1, -2.0, 1.0, 3.0], -2.0),
        ([0.15, -3.0, 0.0, 2.0], -2.0),
    ] {
        let (_, jac) = jacobian(&p, &x, u);
        let pair = dominant_pair(&jac, None).expect("the Furuta Jacobian has a dominant eigenvalue near the upright");
        // The back-EMF mode: about -K Jp / Delta(theta).
        let delta = p.delta(x[0]);
        let want_lambda = -p.params().k * p.params().jp / delta;
        assert!((pair.0 / want_lambda - 1.0).abs() < 0.05, "lambda {} vs {want_lambda}", pair.0);
        // A warm start from a nearby Jacobian converges to the same pair.
        let (_, jac0) = jacobian(&p, &[0.0; 4], 0.0);
        let pair0 = dominant_pair(&jac0, None).unwrap();
        let warm = dominant_pair(&jac, Some(&pair0)).unwrap();
        assert!((warm.0 - pair.0).abs() < 1e-12 * pair.0.abs());
        for h in [1e-5, 1e-4, 1e-3, 3e-3, 0.0308] {
            let Some(s) = Split::new(&jac, &pair, h) else {
                // Only large steps at tilted states leave the Taylor range.
                assert!(h >= 1e-3, "no split at h = {h}, x = {x:?}");
                continue;
            };
            used += 1;
            let phis = sim::ode::internals::exprb::phis(&jac, h).unwrap();
            for y in [[0.3, -1.0, 2.0, 5.0], pair.1, [1.0, 0.0, 0.0, 0.0]] {
                let got = s.apply::<true, true, true, true>(&y);
                let yv = SVector::<f64, 4>::from_column_slice(&y);
                let want = [phis.p1_half * yv, phis.p1 * yv, phis.p3 * yv, phis.p4 * yv];
                for k in 0..4 {
                    let scale = want[k].abs().max();
                    for i in 0..4 {
                        let e = (got[k][i] - want[k][i]).abs() / scale;
                        assert!(e < 1e-13, "x {x:?} h {h}: function {k} component {i}: relative error {e:e}");
                    }
                }
            }
        }
    }
    assert!(used >= 12, "split used {used} times");
}

/// exprb-lean's pair: Rayleigh quotient iteration from the pair of a nearby Jacobian gives
/// the power iteration's pair (same eigenvalue, same vectors to rounding), in a residual of
/// `tol`; without a start, power iteration.
#[test]
fn rayleigh_pair_from_a_warm_start_matches_power_iteration() {
    let p = Furuta::paper();
    let states = [
        ([0.0, 0.0, 0.0, 0.0], 0.0),
        ([0.05, 1.0, 0.3, 0.5], 0.7),
        ([0.05, 1.05, 0.3, 0.8], 0.7),
        ([-0.1, -2.0, 1.0, 3.0], -2.0),
    ];
    let mut prev: Option<Pair<4>> = None;
    for (x, u) in states {
        let (_, jac) = jacobian(&p, &x, u);
        let want = dominant_pair(&jac, None).unwrap();
        let got = dominant_pair_lean(&jac, prev.as_ref(), 1e-14).unwrap();
        assert!((got.0 - want.0).abs() <= 1e-13 * want.0.abs(), "lambda {} vs {}", got.0, want.0);
        // Same normalization (inf norm 1 for v, w^T v = 1): the vectors agree up to sign.
        let sign = if dot(&got.1, &want.1) < 0.0 { -1.0 } else { 1.0 };
        for i in 0..4 {
            assert!((sign * got.1[i] - want.1[i]).abs() <= 1e-12, "v: {:?} vs {:?}", got.1, want.1);
            assert!((sign * got.2[i] - want.2[i]).abs() <= 1e-12 * norm_inf(&want.2), "w: {:?} vs {:?}", got.2, want.2);
        }
        prev = Some(got);
    }
    // A start that is no eigenpair at all still ends on a checked pair or on None.
    let (_, jac) = jacobian(&p, &[0.05, 1.0, 0.3, 0.5], 0.7);
    let bad = (1.0, [1.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]);
    if let Some((l, v, w)) = dominant_pair_lean(&jac, Some(&bad), 1e-12) {
        let jv = matvec(&jac, &v);
        let jw = matvec_t(&jac, &w);
        for i in 0..4 {
            assert!((jv[i] - l * v[i]).abs() <= 1e-11 * l.abs());
            assert!((jw[i] - l * w[i]).abs() <= 1e-11 * l.abs() * norm_inf(&w));
        }
    }
    // A shift exactly at an eigenvalue: the zero pivot is floored, the solve stays finite.
    let lu = ShiftedLu::new(&[[2.0, 0.0], [0.0, -3.0]], 2.0);
    let x = lu.solve(&[1.0, 1.0]);
    assert!(x.iter().all(|v| v.is_finite()) && x[0].abs() > 1e10 * x[1].abs(), "{x:?}");
    let x = lu.solve_t(&[1.0, 1.0]);
    assert!(x.iter().all(|v| v.is_finite()) && x[0].abs() > 1e10 * x[1].abs(), "{x:?}");
}

/// The relative residuals `(|J v - lambda v|, |J^T w - lambda w| / |w|)` of a pair (inf
/// norms, over `|lambda|`).
fn residuals(jac: &[[f64; 4]; 4], (l, v, w): &Pair<4>) -> (f64, f64) {
    let (jv, jw) = (matvec(jac, v), matvec_t(jac, w));
    let rv = (0..4).map(|i| (jv[i] - l * v[i]).abs()).fold(0.0, f64::max) / (l.abs() * norm_inf(v));
    let rw = (0..4).map(|i| (jw[i] - l * w[i]).abs()).fold(0.0, f64::max) / (l.abs() * norm_inf(w));
    (rv, rw)
}

/// `(lambda, v, w)` of two pairs with the same normalization (`|v| = 1`, `w^T v = 1`):
/// the largest relative differences of `lambda`, `v` and `w` (`w` relative to its norm),
/// signs aligned.
fn pair_diff(a: &Pair<4>, b: &Pair<4>) -> [f64; 3] {
    let sign = if dot(&a.1, &b.1) < 0.0 { -1.0 } else { 1.0 };
    let dv = (0..4).map(|i| (sign * a.1[i] - b.1[i]).abs()).fold(0.0, f64::max);
    let dw = (0..4).map(|i| (sign * a.2[i] - b.2[i]).abs()).fold(0.0, f64::max) / norm_inf(&b.2);
    [(a.0 - b.0).abs() / b.0.abs(), dv, dw]
}

/// The closed-form pair of a second-order Jacobian (the Furuta plant's closed form, random
/// states from the upright to 0.6 rad, fast arm) from the eigenvalue of a nearby state's
/// pair against power iteration from a cold start (accepted at residuals of 1e-14): the
/// closed form's residuals at rounding (below 1e-15), the same eigenvalue to 1e-15, `v` to
/// 1e-14 and `w` to 3e-14 (power iteration's own error sets these two), and
/// `dominant_pair_lean` takes it. The worst values are printed.
#[test]
fn second_order_pair_matches_power_iteration_on_the_furuta_jacobian() {
    use sim::plant::Plant;
    let plant = Furuta::paper();
    let mut uniform = uniform_stream(0x9e37_79b9_7f4a_7c15);
    let (mut worst, mut worst_res, mut used) = ([0.0f64; 3], [0.0f64; 2], 0);
    for k in 0..400 {
        let r = if k < 200 { 0.1 } else { 0.6 };
        let x = [uniform(-1.0, 1.0) * r, uniform(-10.0, 10.0) * r, uniform(-10.0, 10.0), uniform(-30.0, 30.0) * r];
        let u = uniform(-12.0, 12.0);
        let (_, jac) = plant.rhs_and_jacobian(&x, u);
        assert_eq!(second_order_layout(&jac), Some([(0, 1), (2, 3)]));
        let Some(want) = dominant_pair(&jac, None) else { continue };
        // The start: the pair at a state a step away (1e-3 of the state's scale).
        let near: [f64; 4] = core::array::from_fn(|i| x[i] + 1e-3 * uniform(-1.0, 1.0) * [1.0, 10.0, 1.0, 30.0][i]);
        let start = dominant_pair(&plant.rhs_and_jacobian(&near, u).1, None).unwrap_or(want);
        let got = second_order_pair(&jac, &start, 1e-14, unit_rows(&jac))
            .expect("the closed-form pair passes the residual test");
        let lean = dominant_pair_lean(&jac, Some(&start), 1e-14).unwrap();
        assert_eq!(lean.0.to_bits(), got.0.to_bits(), "dominant_pair_lean takes the closed form");
        let d = pair_diff(&got, &want);
        for i in 0..3 {
            worst[i] = worst[i].max(d[i]);
        }
        let r = residuals(&jac, &got);
        assert!(r.0 <= 1e-15 && r.1 <= 1e-15, "x {x:?} u {u}: residuals {r:?}");
        worst_res = [worst_res[0].max(r.0), worst_res[1].max(r.1)];
        assert!(d[0] <= 1e-15 && d[1] <= 1e-14 && d[2] <= 3e-14, "x {x:?} u {u}: [lambda, v, w] differ by {d:?}");
        used += 1;
    }
    eprintln!(
        "second-order pair vs power iteration, {used} Jacobians: [lambda, v, w] worst {worst:?}, residuals (v, w) {worst_res:?}"
    );
    assert!(used >= 300, "{used} Jacobians with a dominant pair");
}

/// The pairs of the Jacobians met along a closed-loop run (the paper's delayed PD loop
/// from 0.05 rad, 100 periods of 30.8 ms, each advanced by exprb-filtered in 20 pieces, a
/// Jacobian at each piece's end), each from the last one's pair: the closed-form chain
/// against the Rayleigh chain (the old `dominant_pair_lean`) at the tolerances of the
/// report's integrators (`pair_tol` 3e-13) and the tightest (1e-14): every closed-form pair
/// passes with residuals (relative, inf norms) at rounding, below 1e-15, the Rayleigh
/// pairs' up to `tol`; the eigenvalues agree to 1e-15, the vectors to `1.5 tol` (the
/// Rayleigh pair's own error is up to about `tol`). The worst values are printed.
#[test]
fn second_order_pair_along_a_run_matches_the_rayleigh_pair() {
    use sim::ode::{Integrator, Method};
    use sim::plant::Plant;
    let plant = Furuta::paper();
    let (dt, kp, kd, kphi) = (0.0308, 15.5, 5.45, 1.5);
    for tol in [3e-13, 1e-14] {
        let mut integ = Integrator::<4>::new(Method::ExprbFiltered { rtol: 3e-11, atol: 3e-11 }).unwrap();
        let mut x = [0.05, 0.0, 0.0, 0.0];
        let (mut s1, mut s2) = ((x[0], x[2]), (x[0], x[2]));
        let (mut old, mut new): (Option<Pair<4>>, Option<Pair<4>>) = (None, None);
        let (mut worst_res, mut worst_diff, mut n) = ([0.0f64; 4], [0.0f64; 3], 0);
        for _ in 0..100 {
            let u = -kp * s1.0 - kd * (s1.0 - s2.0) / dt + kphi * (s1.1 - s2.1) / dt;
            s2 = s1;
            s1 = (x[0], x[2]);
            for _ in 0..20 {
                integ.advance(&plant, &mut x, u, dt / 20.0).unwrap();
                let (_, jac) = plant.rhs_and_jacobian(&x, u);
                let o = old
                    .as_ref()
                    .and_then(|s| rayleigh_iteration(&jac, s, tol))
                    .or_else(|| power_iteration(&jac, None, 2, tol));
                // Every pair after the first (cold, power iteration) is the closed form's.
                let w = match new.as_ref() {
                    Some(s) => second_order_pair(&jac, s, tol, unit_rows(&jac)),
                    None => power_iteration(&jac, None, 2, tol),
                };
                let (o, w) = (o.expect("a Rayleigh pair"), w.expect("a closed-form pair"));
                let cold = new.is_none();
                (old, new) = (Some(o), Some(w));
                if cold {
                    continue;
                }
                let (ro, rn) = (residuals(&jac, &o), residuals(&jac, &w));
                for (k, r) in [ro.0, ro.1, rn.0, rn.1].into_iter().enumerate() {
                    worst_res[k] = worst_res[k].max(r);
                }
                let d = pair_diff(&w, &o);
                for k in 0..3 {
                    worst_diff[k] = worst_diff[k].max(d[k]);
                }
                assert!(rn.0 <= 1e-15 && rn.1 <= 1e-15, "x {x:?}: closed-form residuals {rn:?}");
                assert!(ro.0 <= tol && ro.1 <= tol, "x {x:?}: Rayleigh residuals {ro:?}");
                assert!(
                    d[0] <= 1e-15 && d[1] <= 1.5 * tol && d[2] <= 1.5 * tol,
                    "x {x:?}: [lambda, v, w] differ by {d:?}"
                );
                n += 1;
            }
        }
        eprintln!(
            "tol {tol:e}, {n} Jacobians along the run: residuals (v, w) rayleigh {:?} closed form {:?}; [lambda, v, w] differ by {worst_diff:?}",
            &worst_res[..2],
            &worst_res[2..]
        );
    }
}

/// Without the second-order layout (a unit row off by one ulp, rows pointing at each
/// other, a 3-state Jacobian) there is no closed-form pair and `dominant_pair_lean` is the
/// Rayleigh quotient iteration's, bit for bit.
#[test]
fn without_the_second_order_layout_the_rayleigh_pair_is_used() {
    use sim::plant::Plant;
    let plant = Furuta::paper();
    let (_, jac) = plant.rhs_and_jacobian(&[0.05, 1.0, 0.3, 0.5], 0.7);
    let start = dominant_pair(&plant.rhs_and_jacobian(&[0.051, 1.0, 0.3, 0.6], 0.7).1, None).unwrap();
    let mut off = jac;
    off[0][1] = 1.0 + f64::EPSILON;
    let mut swapped = jac;
    swapped[0] = [0.0, 0.0, 1.0, 0.0];
    swapped[2] = [1.0, 0.0, 0.0, 0.0];
    for j in [off, swapped] {
        assert_eq!(second_order_layout(&j), None);
        assert!(second_order_pair(&j, &start, 1e-14, unit_rows(&j)).is_none());
        let want = rayleigh_iteration(&j, &start, 1e-14);
        let got = dominant_pair_lean(&j, Some(&start), 1e-14);
        assert_eq!(format!("{got:?}"), format!("{want:?}"));
    }
    // The blocked layout (q, q') is found as well.
    let perm = [0, 2, 1, 3];
    let blocked: [[f64; 4]; 4] = core::array::from_fn(|i| core::array::from_fn(|k| jac[perm[i]][perm[k]]));
    assert_eq!(second_order_layout(&blocked), Some([(0, 2), (1, 3)]));
    let s = (start.0, perm.map(|i| start.1[i]), perm.map(|i| start.2[i]));
    let (a, b) = (
        second_order_pair(&blocked, &s, 1e-14, unit_rows(&blocked)).unwrap(),
        second_order_pair(&jac, &start, 1e-14, unit_rows(&jac)).unwrap(),
    );
    assert!((a.0 - b.0).abs() <= 1e-15 * b.0.abs(), "{a:?} vs {b:?}");
    let j3 = [[1.0, 2.0, 0.5], [-4.0, 0.3, 1.0], [2.0, -1.0, 3.0]];
    assert_eq!(second_order_layout(&j3), None);
    // A start far from every eigenvalue: Newton's root is refused, not taken.
    if let Some(p) = second_order_pair(&jac, &(-3.0, start.1, start.2), 1e-14, unit_rows(&jac)) {
        assert!((p.0 + 3.0).abs() <= 1.5, "{p:?}");
    }
}

/// `checked_pair_furuta` is `checked_pair` bit for bit on Jacobians with the Furuta layout:
/// the closed form's pairs (which pass), the same pairs perturbed (which fail, `Err(Some)`,
/// the Rayleigh quotient compared by its bits), vectors with exact and negative zeros, and
/// nearly orthogonal ones (`Err(None)`); on the plant's closed-form Jacobians at random
/// states and on Jacobians with random entries (and zeros) in rows 1 and 3.
#[test]
fn checked_pair_furuta_equals_checked_pair_bit_for_bit() {
    use sim::plant::Plant;
    let plant = Furuta::paper();
    let mut uniform = uniform_stream(0x1234_5678_9abc_def1);
    let key = |r: Result<Pair<4>, Option<f64>>| -> Vec<u64> {
        match r {
            Ok((l, v, w)) => [l].iter().chain(&v).chain(&w).map(|x| x.to_bits()).collect(),
            Err(Some(l)) => vec![1, l.to_bits()],
            Err(None) => vec![2],
        }
    };
    let (mut ok, mut fail, mut none) = (0, 0, 0);
    for k in 0..3000 {
        let r = if k % 2 == 0 { 0.1 } else { 1.0 };
        let x = [uniform(-1.0, 1.0) * r, uniform(-10.0, 10.0) * r, uniform(-10.0, 10.0), uniform(-30.0, 30.0) * r];
        let u = uniform(-12.0, 12.0);
        let (_, mut jac) = plant.rhs_and_jacobian(&x, u);
        if k % 3 == 2 {
            // Random rows 1 and 3, some entries exactly zero or negative zero.
            for i in [1, 3] {
                for j in 0..4 {
                    jac[i][j] = match (k + i + j) % 7 {
                        0 => 0.0,
                        1 => -0.0,
                        _ => uniform(-1e4, 1e4),
                    };
                }
            }
        }
        assert_eq!(second_order_layout(&jac), Some([(0, 1), (2, 3)]));
        let start = dominant_pair(&jac, None).map_or((-1.5e4, [0.0; 4], [0.0; 4]), |p| p);
        let (mut v, mut w) = match second_order_pair(&jac, &start, 1e-14, unit_rows(&jac)) {
            Some((_, v, w)) => (v, w),
            None => (core::array::from_fn(|_| uniform(-1.0, 1.0)), core::array::from_fn(|_| uniform(-1.0, 1.0))),
        };
        match k % 5 {
            1 => v[(k / 5) % 4] += 1e-9 * uniform(-1.0, 1.0),
            2 => w[(k / 5) % 4] = -0.0,
            3 => (v[0], w[2]) = (0.0, -0.0),
            4 => (v, w) = ([1.0, 0.0, -0.0, 0.0], [0.0, 1.0, 0.0, -0.0]),
            _ => {}
        }
        for tol in [1e-14, 3e-13, 1e-2] {
            let want = key(checked_pair(&jac, &v, &w, tol));
            let got = key(checked_pair_furuta(&jac, &v, &w, tol));
            assert_eq!(got, want, "k {k} tol {tol:e}: jac {jac:?} v {v:?} w {w:?}");
            match want[..] {
                [2] => none += 1,
                [1, _] => fail += 1,
                _ => ok += 1,
            }
        }
    }
    eprintln!("checked_pair_furuta vs checked_pair: {ok} accepted, {fail} refused, {none} orthogonal, all bit for bit");
    assert!(ok >= 1000 && fail >= 1000 && none >= 100, "{ok} {fail} {none}");
}

/// `matvec_unit_rows` is `matvec` bit for bit on Jacobians with [`unit_rows`] and finite
/// vectors (random entries, exact and negative zeros); `unit_rows` finds exactly that layout.
#[test]
fn matvec_unit_rows_equals_matvec_bit_for_bit() {
    use sim::plant::Plant;
    let plant = Furuta::paper();
    let mut uniform = uniform_stream(0x0bad_cafe_f00d_1234);
    for k in 0..5000 {
        let x = [uniform(-1.0, 1.0), uniform(-10.0, 10.0), uniform(-10.0, 10.0), uniform(-30.0, 30.0)];
        let (_, jac) = plant.rhs_and_jacobian(&x, uniform(-12.0, 12.0));
        assert!(unit_rows(&jac));
        let mut y: [f64; 4] = core::array::from_fn(|_| uniform(-1.0, 1.0) * 10f64.powi((k % 13) as i32 - 6));
        match k % 4 {
            1 => y[(k / 4) % 4] = 0.0,
            2 => (y[1], y[3]) = (-0.0, -0.0),
            3 => y = [-0.0, -0.0, 0.0, -0.0],
            _ => {}
        }
        let (a, b) = (matvec_unit_rows(&jac, &y), matvec(&jac, &y));
        assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "y {y:?}: {a:?} vs {b:?}");
    }
    let (_, jac) = plant.rhs_and_jacobian(&[0.1, 0.2, 0.3, 0.4], 1.0);
    for (i, j, x) in [(0, 1, 1.0 + f64::EPSILON), (2, 2, 1e-300), (2, 3, -1.0)] {
        let mut off = jac;
        off[i][j] = x;
        assert!(!unit_rows(&off), "{i} {j} {x}");
    }
    // A negative zero is a zero, as in `second_order_layout` (its products are zeros too).
    let mut neg = jac;
    neg[0][0] = -0.0;
    assert!(unit_rows(&neg) && second_order_layout(&neg) == Some([(0, 1), (2, 3)]));
    assert!(!unit_rows(&[[0.0, 1.0], [2.0, 3.0]]));
}

#[test]
fn shifted_lu_solves_both_ways() {
    let j = [[1.0, 2.0, 0.5], [-4.0, 0.3, 1.0], [2.0, -1.0, 3.0]];
    let lu = ShiftedLu::new(&j, 0.7);
    let b = [0.3, -1.0, 2.0];
    let x = lu.solve(&b);
    let xt = lu.solve_t(&b);
    for i in 0..3 {
        let r: f64 = (0..3).map(|k| (j[i][k] - if i == k { 0.7 } else { 0.0 }) * x[k]).sum();
        let rt: f64 = (0..3).map(|k| (j[k][i] - if i == k { 0.7 } else { 0.0 }) * xt[k]).sum();
        assert!((r - b[i]).abs() < 1e-14 && (rt - b[i]).abs() < 1e-14, "{i}: {r} {rt}");
    }
}

#[test]
fn no_dominant_eigenvalue_means_no_split() {
    // Far from upright and spinning: the back-EMF mode is no longer dominant.
    let (_, jac) = jacobian(&Furuta::paper(), &[1.0, 3.0, 0.0, 20.0], 10.0);
    assert!(dominant_pair(&jac, None).is_none());
    // A rotation: a complex pair dominates; power iteration cannot converge.
    let rot = [[0.0, 5.0], [-5.0, 0.0]];
    assert!(dominant_pair(&rot, None).is_none());
    // Non-finite or zero Jacobians.
    assert!(dominant_pair(&[[f64::NAN, 0.0], [0.0, 1.0]], None).is_none());
    assert!(dominant_pair(&[[0.0; 2]; 2], None).is_none());
    // A clear dominant eigenvalue but a step too long for the Taylor sums of the rest.
    let j = [[-1e4, 0.0], [0.0, -10.0]];
    let pair = dominant_pair(&j, None).unwrap();
    assert!((pair.0 + 1e4).abs() < 1e-9);
    assert!(Split::new(&j, &pair, 0.05).is_some());
    assert!(Split::new(&j, &pair, 0.2).is_none());
}
