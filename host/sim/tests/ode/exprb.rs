use nalgebra::SMatrix;
use sim::ode::internals::exprb::*;

// ---- The former nalgebra code, the reference for bit equality. ----
/// All `phi_k(a)`, `k = 0..=4`, of a matrix `a`, plus `phi1(a/2)`. `None` if `a` is not
/// finite or too large to scale.
fn phis_of_old<const N: usize>(a: &M<N>) -> Option<(M<N>, [M<N>; 5])> {
    if a.iter().any(|v| !v.is_finite()) {
        return None;
    }
    // 1-norm: largest absolute column sum.
    let mut norm = 0.0f64;
    for c in a.column_iter() {
        norm = norm.max(c.iter().map(|v| v.abs()).sum());
    }
    if !norm.is_finite() {
        return None;
    }
    // At least one doubling, so that the level before the last is phi(a/2).
    let s = if norm > THETA { (norm / THETA).log2().ceil() as i32 } else { 1 }.max(1);
    if s > MAX_DOUBLINGS {
        return None;
    }
    let x = a * 0.5f64.powi(s);
    let id = M::<N>::identity();
    // phi4(x) = sum_{j=0..DEG} x^j / (j+4)!
    let mut p4 = id * INV_FACT[DEG + 4];
    for j in (0..DEG).rev() {
        p4 = id * INV_FACT[j + 4] + x * p4;
    }
    let p3 = id * INV_FACT[3] + x * p4;
    let p2 = id * INV_FACT[2] + x * p3;
    let p1 = id + x * p2;
    let e = id + x * p1;
    let mut p = [e, p1, p2, p3, p4];
    let mut half = p[1];
    for level in 0..s {
        if level == s - 1 {
            half = p[1];
        }
        p = double_old(&p);
    }
    Some((half, p))
}

/// `phi_k(2X)` from `phi_k(X)`, `k = 0..=4`.
#[inline]
fn double_old<const N: usize>(p: &[M<N>; 5]) -> [M<N>; 5] {
    let [e, p1, p2, p3, p4] = p;
    let e2 = e * e;
    let q1 = (e * p1 + p1) * 0.5;
    let q2 = (e * p2 + p1 + p2) * 0.25;
    let q3 = (e * p3 + p1 * 0.5 + p2 + p3) * 0.125;
    let q4 = (e * p4 + p1 * INV_FACT[3] + p2 * 0.5 + p3 + p4) * 0.0625;
    [e2, q1, q2, q3, q4]
}

/// The matrix functions one `exprb43` step of size `h` needs, at Jacobian `jac`.
#[inline]
fn phis_old<const N: usize>(jac: &[[f64; N]; N], h: f64) -> Option<Phis<N>> {
    let a = M::<N>::from_fn(|i, j| h * jac[i][j]);
    let (p1_half, p) = phis_of_old(&a)?;
    let [_, p1, _, p3, p4] = p;
    Some(Phis { p1_half, p1, p3, p4 })
}

/// xorshift64 draws: entries of random sign over many scales, with `+-0.0` and small
/// integers mixed in (exact products and cancellations to `+-0.0`).
fn draw(seed: &mut u64) -> f64 {
    let mut next = || {
        *seed ^= *seed << 13;
        *seed ^= *seed >> 7;
        *seed ^= *seed << 17;
        *seed
    };
    let r = next();
    let u = (next() >> 11) as f64 / (1u64 << 53) as f64;
    let sign = if r & 1 == 0 { 1.0 } else { -1.0 };
    match (r >> 1) % 16 {
        0 => 0.0,
        1 => -0.0,
        2 => sign * ((r >> 8) % 4) as f64,
        _ => sign * u * 10f64.powi(((r >> 8) % 13) as i32 - 6),
    }
}

fn same<const N: usize>(a: &M<N>, b: &M<N>) -> bool {
    a.iter().zip(b.iter()).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn products_are_nalgebras_bit_for_bit() {
    let mut seed = 0x2545f4914f6cdd1du64;
    for _ in 0..2_000_000 {
        let a = M::<4>::from_fn(|_, _| draw(&mut seed));
        let b = M::<4>::from_fn(|_, _| draw(&mut seed));
        let ca: Cols<4> = core::array::from_fn(|j| core::array::from_fn(|i| a[(i, j)]));
        let cb: Cols<4> = core::array::from_fn(|j| core::array::from_fn(|i| b[(i, j)]));
        let want = a * b;
        assert!(same(&to_m(&mm(&ca, &cb)), &want), "{a} * {b}");
    }
}

/// The array code against the former nalgebra code on random Jacobians and steps over
/// many scales (1 to ~50 doublings, signed zeros in the Jacobian): every output bit for bit,
/// for `phis` (4 x 4) and `phis_of` (2 x 2, 3 x 3, 4 x 4), and the same refusals.
#[test]
fn phis_are_the_former_nalgebra_code_bit_for_bit() {
    fn check<const N: usize>(seed: &mut u64, n: usize) -> (usize, usize) {
        let mut refused = 0;
        for r in 0..n {
            let jac: [[f64; N]; N] = core::array::from_fn(|_| core::array::from_fn(|_| draw(seed)));
            let h = 10f64.powi((r % 11) as i32 - 8) * (1.0 + (r % 7) as f64 / 7.0);
            let (new, old) = (phis(&jac, h), phis_old(&jac, h));
            match (new, old) {
                (Some(x), Some(y)) => {
                    assert!(
                        same(&x.p1_half, &y.p1_half) && same(&x.p1, &y.p1) && same(&x.p3, &y.p3) && same(&x.p4, &y.p4),
                        "{jac:?} h {h}"
                    );
                }
                (None, None) => refused += 1,
                _ => panic!("refusal differs: {jac:?} h {h}"),
            }
            let a = M::<N>::from_fn(|i, j| h * jac[i][j]);
            match (phis_of(&a), phis_of_old(&a)) {
                (Some((h1, p)), Some((h2, q))) => {
                    assert!(same(&h1, &h2) && p.iter().zip(&q).all(|(x, y)| same(x, y)))
                }
                (None, None) => {}
                _ => panic!("refusal differs: {a}"),
            }
        }
        (n, refused)
    }
    let mut seed = 0x9e3779b97f4a7c15u64;
    let n4 = check::<4>(&mut seed, 300_000);
    let n3 = check::<3>(&mut seed, 50_000);
    let n2 = check::<2>(&mut seed, 50_000);
    eprintln!("4x4 {n4:?}, 3x3 {n3:?}, 2x2 {n2:?} (cases, refused)");
    // Non-finite and huge arguments are refused by both.
    let mut jac = [[0.0; 4]; 4];
    jac[1][2] = f64::NAN;
    assert!(phis(&jac, 1.0).is_none() && phis_old(&jac, 1.0).is_none());
    jac[1][2] = 1e30;
    assert!(phis(&jac, 1.0).is_none() && phis_old(&jac, 1.0).is_none());
}

/// Both sides of one case bit for bit (`phis` and `phis_of`); `Some(non-finite output)`
/// if accepted.
fn check_same(jac: &[[f64; 4]; 4], h: f64) -> Option<bool> {
    let r = match (phis(jac, h), phis_old(jac, h)) {
        (Some(x), Some(y)) => {
            assert!(
                same(&x.p1_half, &y.p1_half) && same(&x.p1, &y.p1) && same(&x.p3, &y.p3) && same(&x.p4, &y.p4),
                "{jac:?} h {h:e}"
            );
            Some([x.p1_half, x.p1, x.p3, x.p4].iter().flatten().any(|v| !v.is_finite()))
        }
        (None, None) => None,
        _ => panic!("refusal differs: {jac:?} h {h:e}"),
    };
    let a = M::<4>::from_fn(|i, j| h * jac[i][j]);
    match (phis_of(&a), phis_of_old(&a)) {
        (Some((h1, p)), Some((h2, q))) => {
            assert!(same(&h1, &h2) && p.iter().zip(&q).all(|(x, y)| same(x, y)), "{a}")
        }
        (None, None) => {}
        _ => panic!("refusal differs: {a}"),
    }
    r
}

/// The products for the Furuta layout (`sparse_layout`: rows 0 and 2 of `hJ` the identity
/// block, column 2 zero) against the former nalgebra code, every output bit for bit:
/// the plants' own Jacobians (dual numbers; Furuta's closed form too) at random states and
/// steps from 1e-9 s to 1000 s (up to ~40 doublings, overflow to inf and NaN at the long
/// steps), and random
/// Jacobians in the layout with zeros of both signs, small integers (exact cancellations),
/// entries over 24 decades, identity-block entries other than 1, and steps down to
/// subnormal products (zero products of either sign in every sum).
#[test]
fn sparse_layout_products_are_the_former_nalgebra_code_bit_for_bit() {
    use sim::plant::{Cart, Furuta, Plant, jacobian};
    fn tally(r: Option<bool>, n: &mut [usize; 3]) {
        n[match r {
            Some(false) => 0,
            Some(true) => 1,
            None => 2,
        }] += 1;
    }
    let (furuta, cart) = (Furuta::paper(), Cart::reference());
    let mut seed = 0x853c49e6748fea9bu64;
    let uniform = |lo: f64, hi: f64, seed: &mut u64| {
        *seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        lo + (hi - lo) * ((*seed >> 11) as f64 / (1u64 << 53) as f64)
    };
    // (finite, non-finite, refused)
    let mut plants = [0usize; 3];
    let mut layout = 0usize;
    for r in 0..60_000 {
        let sc = if r % 3 == 0 { 0.05 } else { 1.0 };
        let x = [
            uniform(-3.2, 3.2, &mut seed) * sc,
            uniform(-20.0, 20.0, &mut seed) * sc,
            uniform(-10.0, 10.0, &mut seed),
            uniform(-40.0, 40.0, &mut seed) * sc,
        ];
        let u = uniform(-24.0, 24.0, &mut seed);
        let h = 10f64.powf(uniform(-9.0, 3.0, &mut seed));
        let jac = if r % 2 == 0 { jacobian(&furuta, &x, u).1 } else { jacobian(&cart, &x, u).1 };
        let a: Cols<4> = core::array::from_fn(|j| core::array::from_fn(|i| h * jac[i][j]));
        layout += usize::from(sparse_layout(&a));
        tally(check_same(&jac, h), &mut plants);
        if r % 2 == 0 {
            // The closed-form Jacobian (exact zeros of one sign).
            tally(check_same(&furuta.rhs_and_jacobian(&x, u).1, h), &mut plants);
        }
    }
    let mut seed = 0x9e3779b97f4a7c15u64;
    let mut random = [0usize; 3];
    for r in 0..300_000 {
        let mut jac: [[f64; 4]; 4] = core::array::from_fn(|_| core::array::from_fn(|_| draw(&mut seed)));
        let z = |seed: &mut u64| if draw(seed) < 0.0 { -0.0 } else { 0.0 };
        for (i, row) in jac.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                let block = (i == 0 && j == 1) || (i == 2 && j == 3);
                if (i % 2 == 0 && !block) || j == 2 {
                    *v = z(&mut seed);
                } else if block && r % 4 != 0 {
                    *v = 1.0;
                }
            }
        }
        let h = match r % 5 {
            // Subnormal and underflowing products.
            0 => 10f64.powi(-300 - (r % 23) as i32),
            _ => 10f64.powi((r % 13) as i32 - 9) * (1.0 + (r % 7) as f64 / 7.0),
        };
        tally(check_same(&jac, h), &mut random);
    }
    eprintln!("plants {plants:?} (layout {layout}), random {random:?} (finite, non-finite, refused)");
    // The layout was tested, with finite and non-finite outputs.
    assert!(layout == 60_000 && plants[0] > 50_000 && plants[1] > 1000, "{plants:?} {layout}");
    assert!(random[0] > 100_000 && random[1] > 1000, "{random:?}");
}

/// The scaling's `2^-s` and `ceil(log2 q)` without the library calls, against them: every
/// `s` in range, and `q` over 70 binades, random and at the mantissa margins, powers of two.
#[test]
fn scaling_without_library_calls_is_exact() {
    for s in -70..=70 {
        assert_eq!(pow2(s).to_bits(), 0.5f64.powi(-s).to_bits(), "{s}");
    }
    let mut seed = 0x5851f42d4c957f2du64;
    let want = |q: f64| q.log2().ceil() as i32;
    for e in 0..70 {
        let base = 2f64.powi(e);
        for frac in [
            0u64,
            1,
            2,
            (1 << 32) - 1,
            1 << 32,
            (1 << 32) + 1,
            (1 << 52) - (1 << 32) - 1,
            (1 << 52) - (1 << 32),
            (1 << 52) - (1 << 32) + 1,
            (1 << 52) - 1,
        ] {
            let q = f64::from_bits(base.to_bits() + frac);
            if q > 1.0 {
                assert_eq!(ceil_log2(q), want(q), "{q:e}");
            }
        }
        for _ in 0..20_000 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let q = f64::from_bits(base.to_bits() + (seed >> 12));
            if q > 1.0 {
                assert_eq!(ceil_log2(q), want(q), "{q:e}");
            }
        }
    }
    assert_eq!(ceil_log2(f64::INFINITY), want(f64::INFINITY));
}

/// `phi_k(a)` for diagonalizable `a` with real eigenvalues via `V phi_k(Lambda) V^-1`,
/// the scalar `phi_k` from its series (small |z|) or its closed form.
fn phi_scalar(k: usize, z: f64) -> f64 {
    if z.abs() < 0.1 {
        (0..30).map(|j| z.powi(j as i32) * INV_FACT_LONG(j + k)).sum()
    } else {
        // phi_k(z) = (e^z - sum_{j<k} z^j/j!) / z^k
        let mut s = z.exp();
        for j in 0..k {
            s -= z.powi(j as i32) * INV_FACT_LONG(j);
        }
        s / z.powi(k as i32)
    }
}

#[allow(non_snake_case)]
fn INV_FACT_LONG(k: usize) -> f64 {
    (1..=k).fold(1.0, |a, i| a / i as f64)
}

#[test]
fn phi_functions_of_a_stiff_non_normal_matrix_match_eigendecomposition() {
    // A = V diag(lambda) V^-1 with eigenvalues spread like the Furuta Jacobian times a
    // period (-1.56e4, -11.1, 0, 4.39) * 30.8 ms and an ill-conditioned V (entries up to 1e3).
    let lam = [-1.56e4 * 0.0308, -11.1 * 0.0308, 0.0, 4.39 * 0.0308];
    let vm = M::<4>::new(
        1.0, 0.3, 0.0, 2.0, //
        -4.0e2, 1.0, 0.5, 1.0, //
        0.0, 0.2, 1.0, -0.7, //
        1.0e3, -3.0, 0.1, 1.0,
    );
    let vinv = vm.try_inverse().unwrap();
    let a = vm * M::<4>::from_diagonal(&V::<4>::from_column_slice(&lam)) * vinv;
    assert!(a.abs().max() > 1e3, "not non-normal enough: {}", a.abs().max());
    let (half, p) = phis_of(&a).unwrap();
    for (k, got) in p.iter().enumerate() {
        let d = V::<4>::from_fn(|i, _| phi_scalar(k, lam[i]));
        let want = vm * M::<4>::from_diagonal(&d) * vinv;
        let err = (got - want).abs().max() / want.abs().max();
        // The reference itself carries cond(V) * eps ~ 1e-12.
        assert!(err < 1e-11, "phi_{k}: relative error {err:e}");
    }
    let d = V::<4>::from_fn(|i, _| phi_scalar(1, 0.5 * lam[i]));
    let want = vm * M::<4>::from_diagonal(&d) * vinv;
    let err = (half - want).abs().max() / want.abs().max();
    assert!(err < 1e-11, "phi_1(A/2): relative error {err:e}");
}

#[test]
fn phi_functions_of_a_rotation_match_closed_form() {
    // a = [[0, w], [-w, 0]]: exp = rotation, phi1 = (exp - I) a^-1.
    let w = 7.5;
    let a = SMatrix::<f64, 2, 2>::new(0.0, w, -w, 0.0);
    let (_, p) = phis_of(&a).unwrap();
    let e = SMatrix::<f64, 2, 2>::new(w.cos(), w.sin(), -w.sin(), w.cos());
    assert!((p[0] - e).abs().max() < 1e-13, "{}", p[0]);
    let p1 = (e - SMatrix::<f64, 2, 2>::identity()) * a.try_inverse().unwrap();
    assert!((p[1] - p1).abs().max() < 1e-13, "{}", p[1]);
}

#[test]
fn non_finite_or_huge_argument_is_refused() {
    let mut a = M::<4>::zeros();
    a[(1, 2)] = f64::NAN;
    assert!(phis_of(&a).is_none());
    // Beyond 2^60 * THETA in norm: more doublings than allowed.
    a[(1, 2)] = 1e30;
    assert!(phis_of(&a).is_none());
    a[(1, 2)] = 1e3;
    assert!(phis_of(&a).is_some());
}
