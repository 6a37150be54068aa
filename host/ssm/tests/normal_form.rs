//! The tests of `ssm::normal_form`.

use ssm::normal_form::*;

use nalgebra::{Complex, DMatrix};
use ssm::internals::{add_into, compose, map_to_flow, mul, mul_btree, normal_form_parts, one, var};
use ssm::poly::{self, Poly};
use std::collections::BTreeMap;

type C = Complex<f64>;
/// A sparse complex polynomial: exponent vector to coefficient.
type SPoly = BTreeMap<Vec<u32>, C>;

/// The packed-key product against the map product: the same entries (keys, and the
/// coefficients bit for bit), on random sparse polynomials in 1..6 variables with
/// repeated, zero and negative-zero coefficients, terms above the truncation degree, and
/// products truncated at 0..9; `NF_MUL_BENCH=packed` / `btree` time one of them.
#[test]
fn packed_product_equals_the_map_product() {
    let mut rng = ssm::testing::XorShift64::new(0x2545_f491_4f6c_dd1d);
    let mut rnd = move || rng.next_u64();
    let poly = |nvar: usize, terms: usize, top: u32, rnd: &mut dyn FnMut() -> u64| {
        let mut p = SPoly::new();
        for _ in 0..terms {
            let e: Vec<u32> = (0..nvar).map(|_| (rnd() % u64::from(top + 1)) as u32).collect();
            let v = |r: u64| match r % 5 {
                0 => 0.0,
                1 => -0.0,
                _ => (r >> 11) as f64 / (1u64 << 53) as f64 - 0.5,
            };
            let c = C::new(v(rnd()), v(rnd()));
            p.insert(e, c);
        }
        p
    };
    let same = |x: &SPoly, y: &SPoly| {
        x.len() == y.len()
            && x.iter().zip(y).all(|((ea, ca), (eb, cb))| {
                ea == eb && ca.re.to_bits() == cb.re.to_bits() && ca.im.to_bits() == cb.im.to_bits()
            })
    };
    for nvar in 1..=6 {
        for maxdeg in 0..=9 {
            for _ in 0..3 {
                let a = poly(nvar, 40, 5, &mut rnd);
                let b = poly(nvar, 60, 4, &mut rnd);
                assert!(same(&mul(&a, &b, maxdeg), &mul_btree(&a, &b, maxdeg)), "nvar {nvar} maxdeg {maxdeg}");
                // Products of products (sums of many terms per key).
                let ab = mul_btree(&a, &b, maxdeg);
                assert!(same(&mul(&ab, &a, maxdeg), &mul_btree(&ab, &a, maxdeg)), "nvar {nvar} maxdeg {maxdeg} (ab a)");
            }
        }
    }
    assert!(mul(&SPoly::new(), &one(3), 4).is_empty());
    // Exponents that do not fit the packing (11 variables of 6 bits) take the map product.
    let a = poly(11, 30, 3, &mut rnd);
    assert!(same(&mul(&a, &a, 40), &mul_btree(&a, &a, 40)));
    if let Ok(kind) = std::env::var("NF_MUL_BENCH") {
        let a = poly(4, 300, 7, &mut rnd);
        let t = std::time::Instant::now();
        let mut n = 0;
        for _ in 0..50 {
            n += if kind == "packed" { mul(&a, &a, 7) } else { mul_btree(&a, &a, 7) }.len();
        }
        eprintln!("50 {kind} products of 300 terms: {n} entries, {:?}", t.elapsed());
    }
}

/// `z_j = x_{2j} + i x_{2j+1}` and its conjugate, `x = M^-1 eta`, as linear polynomials in
/// `eta` (the order `z_1, conj z_1, z_2, ...`).
fn z_of_eta(m: &DMatrix<f64>) -> Vec<SPoly> {
    let d = m.nrows();
    let minv = m.clone().try_inverse().unwrap();
    let mut sub = Vec::new();
    for j in 0..d / 2 {
        for sgn in [1.0, -1.0] {
            let mut p = SPoly::new();
            for l in 0..d {
                let mut e = vec![0; d];
                e[l] = 1;
                p.insert(e, C::new(minv[(2 * j, l)], sgn * minv[(2 * j + 1, l)]));
            }
            sub.push(p);
        }
    }
    sub
}

/// Real polynomial (as a [`Poly`] with the given scales, degrees 1..=order) of the field
/// `eta' = M x'` where `x = (Re z_j, Im z_j)_j = M^-1 eta` and `z_j' = zdot[j](z, conj z)`.
fn real_field(zdot: &[SPoly], m: &DMatrix<f64>, scale: &[f64], order: u32) -> Poly {
    let d = m.nrows();
    let zd = compose(zdot, &z_of_eta(m), d, order);
    // x'_{2j} = Re z_j', x'_{2j+1} = Im z_j' (eta real); eta' = M x'.
    let exps = poly::exponents(d, 1, order);
    let mut coef = vec![0.0; exps.len() * d];
    for (k, e) in exps.iter().enumerate() {
        let sc: f64 = e.iter().zip(scale).map(|(&p, s)| s.powi(p as i32)).product();
        for o in 0..d {
            let mut v = 0.0;
            for j in 0..d / 2 {
                let c = zd[j].get(e).copied().unwrap_or(C::new(0.0, 0.0));
                v += m[(o, 2 * j)] * c.re + m[(o, 2 * j + 1)] * c.im;
            }
            coef[k * d + o] = v * sc;
        }
    }
    Poly { dim_in: d, dim_out: d, scale: scale.to_vec(), exps, coef }
}

fn term(e: &[u32], c: C) -> (Vec<u32>, C) {
    (e.to_vec(), c)
}

/// Hopf normal form plus a non-resonant quadratic term g11 z conj z, mixed by a linear
/// map: the cubic coefficient must be b + |g11|^2 / lambda (hand-derived from one
/// near-identity step), the quintic c exactly when g11 = 0.
#[test]
fn flow_d2_known_coefficients() {
    let lam = C::new(-0.07, 3.1);
    let (b, c) = (C::new(-0.8, 0.4), C::new(0.25, -0.6));
    let m = DMatrix::from_row_slice(2, 2, &[1.3, -0.4, 0.2, 0.9]);
    let obs: Vec<f64> = m.clone().try_inverse().unwrap().row(0).iter().copied().collect();
    for g11 in [C::new(0.0, 0.0), C::new(0.5, -0.3)] {
        let zdot: SPoly =
            [term(&[1, 0], lam), term(&[1, 1], g11), term(&[2, 1], b), term(&[3, 2], c)].into_iter().collect();
        let p = real_field(&[zdot], &m, &[0.6, 1.7], 5);
        let opts = NormalFormOptions { normalization: Normalization::Observable(obs.clone()), ..Default::default() };
        let nf = normal_form_of_poly(&p, None, &opts).unwrap();
        assert_eq!(nf.modes, 1);
        assert_eq!(nf.pexps, vec![vec![0], vec![1], vec![2]]);
        let b3 = b + g11.norm_sqr() / lam;
        assert!((nf.amp[0][0] - lam.re).abs() < 1e-12 && (nf.phase[0][0] - lam.im).abs() < 1e-12, "{nf:?}");
        assert!((nf.amp[0][1] - b3.re).abs() < 1e-11, "{} vs {}", nf.amp[0][1], b3.re);
        assert!((nf.phase[0][1] - b3.im).abs() < 1e-11, "{} vs {}", nf.phase[0][1], b3.im);
        if g11.norm() == 0.0 {
            assert!((nf.amp[0][2] - c.re).abs() < 1e-11 && (nf.phase[0][2] - c.im).abs() < 1e-11, "{nf:?}");
        }
        let t = nf.table();
        assert_eq!(t.rows.iter().map(|r| r.monomial.as_str()).collect::<Vec<_>>(), ["rho_1", "rho_1^3", "rho_1^5"]);
        assert!(nf.extra_resonances.is_empty());
    }
}

/// Two modes in normal form with cross terms, a generic 4x4 mixing and unequal scales. All polar coefficients are recovered, modes ordered by frequency although
/// the fast mode comes first in x.
#[test]
fn flow_d4_cross_terms_recovered() {
    let (l1, l2) = (C::new(-0.11, 2.7), C::new(0.27, 53.0));
    // z1' = z1 (l1 + b1 P1 + c1 P2 + ...), z2' likewise; P = |z|^2.
    let b = [
        [C::new(0.04, 0.1), C::new(11.65, -2.0), C::new(1.2, 0.3), C::new(41.0, 1.0), C::new(110.0, -5.0)],
        [C::new(-2.1, 0.7), C::new(-8.2, 1.1), C::new(-2.2, 0.0), C::new(-27.4, 2.0), C::new(-22.5, 3.0)],
    ];
    // exponents of (P1, P2) in that order: P1, P2, P1^2, P1 P2, P2^2 (for mode 2: P1, P2, P1^2, P1 P2, P2^2)
    let pe = [[1u32, 0], [0, 1], [2, 0], [1, 1], [0, 2]];
    // variable order in x: fast mode first.
    let mut z_fast = SPoly::new();
    let mut z_slow = SPoly::new();
    z_slow.insert(vec![0, 0, 1, 0], l1);
    z_fast.insert(vec![1, 0, 0, 0], l2);
    for (k, e) in pe.iter().enumerate() {
        // variables (z2, conj z2, z1, conj z1)
        z_slow.insert(vec![e[1], e[1], e[0] + 1, e[0]], b[0][k]);
        z_fast.insert(vec![e[1] + 1, e[1], e[0], e[0]], b[1][k]);
    }
    let m = DMatrix::from_row_slice(
        4,
        4,
        &[1.0, 0.2, -0.1, 0.3, 0.1, 0.9, 0.2, -0.2, -0.3, 0.1, 1.1, 0.2, 0.2, -0.3, 0.1, 0.8],
    );
    let minv = m.clone().try_inverse().unwrap();
    let obs: Vec<f64> = (0..4).map(|j| minv[(0, j)] + minv[(2, j)]).collect();
    let p = real_field(&[z_fast, z_slow], &m, &[0.5, 0.8, 1.2, 2.0], 5);
    let opts = NormalFormOptions { normalization: Normalization::Observable(obs), ..Default::default() };
    let nf = normal_form_of_poly(&p, None, &opts).unwrap();
    assert_eq!(nf.pexps, vec![vec![0, 0], vec![1, 0], vec![0, 1], vec![2, 0], vec![1, 1], vec![0, 2]]);
    assert!((nf.eigenvalues[0].1 - l1.im).abs() < 1e-10 && (nf.eigenvalues[1].1 - l2.im).abs() < 1e-10);
    for i in 0..2 {
        let l = if i == 0 { l1 } else { l2 };
        assert!((nf.amp[i][0] - l.re).abs() < 1e-10);
        for k in 0..5 {
            let want = b[i][k];
            // roundoff of the order-5 expansion through a generic 4x4 mixing, with a wide margin
            let tol = 1e-7 * want.norm().max(1.0);
            assert!((nf.amp[i][k + 1] - want.re).abs() < tol, "mode {i} k {k}: {} vs {}", nf.amp[i][k + 1], want.re);
            assert!(
                (nf.phase[i][k + 1] - want.im).abs() < tol,
                "mode {i} k {k}: {} vs {}",
                nf.phase[i][k + 1],
                want.im
            );
        }
    }
    let t = nf.table();
    let names: Vec<_> = t.rows.iter().map(|r| r.monomial.clone()).collect();
    assert_eq!(
        names,
        [
            "rho_1",
            "rho_1^3",
            "rho_1 rho_2^2",
            "rho_1^5",
            "rho_1^3 rho_2^2",
            "rho_1 rho_2^4",
            "rho_2",
            "rho_1^2 rho_2",
            "rho_2^3",
            "rho_1^4 rho_2",
            "rho_1^2 rho_2^3",
            "rho_2^5"
        ]
    );
    assert!((t.get(1, "rho_1 rho_2^2").unwrap() - 11.65).abs() < 1e-8);
    assert!((t.get(2, "rho_2^3").unwrap() + 8.2).abs() < 1e-8);
}

/// Map path: z -> mu z (1 + k1 P + k2 P^2) with real k's chosen so that the polar map is
/// the time-dt map of the Bernoulli flow P' = 2 P (a + A1 P) (exact solution
/// P(t) = P0 E / (1 - (A1/a) (E - 1) P0), E = e^{2 a t}), truncated at P^3.
#[test]
fn map_to_flow_matches_bernoulli() {
    let (a, a1, om, dt): (f64, f64, f64, f64) = (0.27, -8.2, 53.0, 0.0308);
    let e = (2.0 * a * dt).exp();
    let kappa = a1 / a * (e - 1.0);
    let (k1, k2) = (kappa / 2.0, 3.0 * kappa * kappa / 8.0);
    let mu = C::from_polar((a * dt).exp(), om * dt);
    let zmap: SPoly = [term(&[1, 0], mu), term(&[2, 1], mu * k1), term(&[3, 2], mu * k2)].into_iter().collect();
    let m = DMatrix::from_row_slice(2, 2, &[0.7, 0.1, -0.3, 1.2]);
    let mut p = real_field(&[zmap], &m, &[1.0, 1.0], 5);
    // increment = F - identity
    for i in 0..2 {
        p.coef[i * 2 + i] -= 1.0;
    }
    let obs: Vec<f64> = m.clone().try_inverse().unwrap().row(0).iter().copied().collect();
    let opts = NormalFormOptions { normalization: Normalization::Observable(obs), ..Default::default() };
    let nf = normal_form_of_poly(&p, Some(dt), &opts).unwrap();
    assert!((nf.amp[0][0] - a).abs() < 1e-12, "{nf:?}");
    assert!((nf.phase[0][0] - om).abs() < 1e-10, "{nf:?}");
    assert!((nf.amp[0][1] - a1).abs() < 1e-9 * a1.abs(), "{} vs {a1}", nf.amp[0][1]);
    assert!(nf.amp[0][2].abs() < 1e-9, "{}", nf.amp[0][2]);
    assert!(nf.phase[0][1].abs() < 1e-9 && nf.phase[0][2].abs() < 1e-9, "{nf:?}");
}

/// Conjugate partner of a polynomial in `(z_1, conj z_1, z_2, ...)`: coefficients
/// conjugated, exponents of each pair swapped.
fn conj_poly(p: &SPoly) -> SPoly {
    p.iter()
        .map(|(e, c)| {
            let mut f = e.clone();
            for j in 0..e.len() / 2 {
                f.swap(2 * j, 2 * j + 1);
            }
            (f, c.conj())
        })
        .collect()
}

/// A real scalar `x(eta)` (a [`Poly`] with the given scales, degrees 1..=order) of a
/// real-valued polynomial `xq(z, conj z)`, `x = (Re z_j, Im z_j)_j = M^-1 eta`.
fn real_scalar(xq: &SPoly, m: &DMatrix<f64>, scale: &[f64], order: u32) -> Poly {
    let d = m.nrows();
    let x = compose(std::slice::from_ref(xq), &z_of_eta(m), d, order).pop().unwrap();
    let exps = poly::exponents(d, 1, order);
    let coef = exps
        .iter()
        .map(|e| {
            let c = x.get(e).copied().unwrap_or(C::new(0.0, 0.0));
            assert!(c.im.abs() < 1e-12, "observable not real: {e:?} {c}");
            c.re * e.iter().zip(scale).map(|(&p, s)| s.powi(p as i32)).product::<f64>()
        })
        .collect();
    Poly { dim_in: d, dim_out: 1, scale: scale.to_vec(), exps, coef }
}

/// Known answer of the first-harmonic basis: a two-mode map normal form
/// `u_j -> u_j (mu_j + sum beta_j,ab P_1^a P_2^b)` seen through a known near-identity
/// change `q = u + k(u)` with resonant and non-resonant terms, mixed by a real 4x4 `M`,
/// and an observable whose first harmonic in `u` is exactly `Re u_1 + Re u_2` plus
/// non-first-harmonic terms (`|u_1|^2`, `Re u_1^2`, `Re u_1^3`, `Re u_1^2 conj u_2`, `Re u_1^3 conj u_2^2`, ...).
/// `FirstHarmonic` must recover the beta's (as the flow coefficients of `map_to_flow`)
/// to 1e-9; `Observable` (linear row only) must not (the resonant part of `k` moves it).
#[test]
fn first_harmonic_recovers_a_known_map_normal_form() {
    let order = 5;
    let dt = 0.03;
    let mu = [C::from_polar(0.995, 0.15), C::from_polar(1.008, 1.63)];
    let pe = [[1u32, 0], [0, 1], [2, 0], [1, 1], [0, 2]];
    let beta = [
        [C::new(0.8, -0.3), C::new(-1.7, 0.4), C::new(2.5, 1.0), C::new(-3.0, 0.7), C::new(1.1, -2.0)],
        [C::new(-0.6, 0.2), C::new(-1.2, -0.5), C::new(0.9, 0.3), C::new(2.2, -1.4), C::new(-0.7, 0.6)],
    ];
    let d = 4;
    // Normal form N(u), z-equations only (variables u_1, conj u_1, u_2, conj u_2).
    let mut nz = vec![SPoly::new(), SPoly::new()];
    for i in 0..2 {
        let mut e = vec![0u32; d];
        e[2 * i] = 1;
        nz[i].insert(e, mu[i]);
        for (k, p) in pe.iter().enumerate() {
            let mut e = vec![p[0], p[0], p[1], p[1]];
            e[2 * i] += 1;
            nz[i].insert(e, mu[i] * beta[i][k]);
        }
    }
    let full = |z: &[SPoly]| -> Vec<SPoly> { z.iter().flat_map(|p| [p.clone(), conj_poly(p)]).collect() };
    // k(u): non-resonant (u_1^2, |u_1|^2, u_2 conj u_1, u_2^3, u_1 u_2, conj u_1^2) and
    // resonant (u_1 |u_1|^2, u_1 |u_2|^2, u_2 |u_2|^2, u_2 |u_1|^4) terms.
    let kz: Vec<SPoly> = vec![
        [
            term(&[2, 0, 0, 0], C::new(0.4, -0.2)),
            term(&[1, 1, 0, 0], C::new(-0.3, 0.1)),
            term(&[0, 1, 1, 0], C::new(0.25, 0.3)),
            term(&[0, 0, 3, 0], C::new(-0.2, 0.1)),
            term(&[2, 1, 0, 0], C::new(0.7, -0.4)),
            term(&[1, 0, 1, 1], C::new(-0.5, 0.2)),
        ]
        .into_iter()
        .collect(),
        [
            term(&[1, 0, 1, 0], C::new(0.3, 0.2)),
            term(&[0, 2, 0, 0], C::new(-0.1, 0.35)),
            term(&[0, 0, 2, 1], C::new(0.6, 0.3)),
            term(&[2, 2, 1, 0], C::new(-0.8, 0.5)),
        ]
        .into_iter()
        .collect(),
    ];
    let kf = full(&kz);
    // T(u) = u + k(u); T^-1(q) = q - k(T^-1(q)) by fixed point, truncated at `order`.
    let ids: Vec<SPoly> = (0..d).map(|i| var(d, i)).collect();
    let mut inv = ids.clone();
    for _ in 0..order {
        let kv = compose(&kf, &inv, d, order);
        inv = (0..d)
            .map(|i| {
                let mut p = ids[i].clone();
                add_into(&mut p, &kv[i], C::new(-1.0, 0.0));
                p
            })
            .collect();
    }
    // F(q) = T(N(T^-1(q))), z-equations.
    let nf_full = full(&nz);
    let t: Vec<SPoly> = (0..d)
        .map(|i| {
            let mut p = ids[i].clone();
            add_into(&mut p, &kf[i], C::new(1.0, 0.0));
            p
        })
        .collect();
    let tn = compose(&t, &nf_full, d, order);
    let fq = compose(&tn, &inv, d, order);
    let fz = vec![fq[0].clone(), fq[2].clone()];
    // Observable in u: Re u_1 + Re u_2 + terms with no first harmonic.
    let half = C::new(0.5, 0.0);
    let mut xu: SPoly = [
        term(&[1, 0, 0, 0], half),
        term(&[0, 1, 0, 0], half),
        term(&[0, 0, 1, 0], half),
        term(&[0, 0, 0, 1], half),
        term(&[1, 1, 0, 0], C::new(0.7, 0.0)),
        term(&[0, 0, 1, 1], C::new(-0.6, 0.0)),
    ]
    .into_iter()
    .collect();
    for (e, c) in [
        ([2u32, 0, 0, 0], C::new(0.3, 0.2)),
        ([1, 0, 1, 0], C::new(-0.2, 0.4)),
        ([3, 0, 0, 0], C::new(-0.4, 0.1)),
        ([2, 0, 0, 1], C::new(0.5, -0.3)),
        ([3, 0, 0, 2], C::new(0.2, 0.2)),
    ] {
        let p: SPoly = [term(&e, c)].into_iter().collect();
        add_into(&mut xu, &p, C::new(1.0, 0.0));
        add_into(&mut xu, &conj_poly(&p), C::new(1.0, 0.0));
    }
    let xq = compose(std::slice::from_ref(&xu), &inv, d, order).pop().unwrap();
    let m = DMatrix::from_row_slice(
        4,
        4,
        &[1.0, 0.2, -0.1, 0.3, 0.1, 0.9, 0.2, -0.2, -0.3, 0.1, 1.1, 0.2, 0.2, -0.3, 0.1, 0.8],
    );
    let scale = [0.5, 0.8, 1.2, 2.0];
    let mut p = real_field(&fz, &m, &scale, order);
    // increment = F - identity (a degree-1 coefficient multiplies eta_i / scale_i)
    for i in 0..d {
        let mut e = vec![0u32; d];
        e[i] = 1;
        let k = p.exps.iter().position(|x| *x == e).unwrap();
        p.coef[k * d + i] -= scale[i];
    }
    let x = real_scalar(&xq, &m, &[0.7, 1.3, 0.9, 1.1], order);
    let pexps = poly::exponents(2, 0, 2);
    let bfull: Vec<Vec<C>> =
        (0..2).map(|i| std::iter::once(C::new(0.0, 0.0)).chain(beta[i].iter().map(|b| mu[i] * b)).collect()).collect();
    let (want_amp, want_phase) = map_to_flow(&bfull, &mu, &pexps, dt).unwrap();
    let fh = NormalFormOptions {
        order: Some(order),
        normalization: Normalization::FirstHarmonic(x.clone()),
        ..Default::default()
    };
    let nf = normal_form_of_poly(&p, Some(dt), &fh).unwrap();
    assert!(nf.extra_resonances.is_empty());
    for i in 0..2 {
        for k in 0..pexps.len() {
            let sc = want_amp[i][k].abs().max(want_phase[i][k].abs()).max(1.0);
            assert!(
                (nf.amp[i][k] - want_amp[i][k]).abs() < 1e-9 * sc,
                "amp {i} {k}: {} vs {}",
                nf.amp[i][k],
                want_amp[i][k]
            );
            assert!(
                (nf.phase[i][k] - want_phase[i][k]).abs() < 1e-9 * sc,
                "phase {i} {k}: {} vs {}",
                nf.phase[i][k],
                want_phase[i][k]
            );
        }
    }
    // The transform's observable has exactly the first harmonic rho_j on a torus.
    let (_, tr) = normal_form_parts(&p, Some(dt), &fh).unwrap();
    let rho = [0.03, 0.02];
    let n = 16;
    let mut h1 = [C::new(0.0, 0.0); 2];
    for a in 0..n {
        for b in 0..n {
            let th = [std::f64::consts::TAU * a as f64 / n as f64, std::f64::consts::TAU * b as f64 / n as f64];
            let xv = x.eval(&tr.eta(&rho, &th))[0];
            h1[0] += C::from_polar(xv, -th[0]) / (n * n) as f64;
            h1[1] += C::from_polar(xv, -th[1]) / (n * n) as f64;
        }
    }
    for j in 0..2 {
        // O(rho^6) from the truncation of x(W(u + h(u))) at the order.
        assert!(
            (2.0 * h1[j].norm() - rho[j]).abs() < 1e-8 * rho[j],
            "mode {j}: first harmonic {} vs rho {}",
            2.0 * h1[j].norm(),
            rho[j]
        );
    }
    let lin = NormalFormOptions {
        order: Some(order),
        normalization: Normalization::Observable(x.linear_part()),
        ..Default::default()
    };
    let nl = normal_form_of_poly(&p, Some(dt), &lin).unwrap();
    assert!(
        (nl.amp[0][1] - want_amp[0][1]).abs() > 1e-3,
        "{} vs {}: the test needs a resonant k",
        nl.amp[0][1],
        want_amp[0][1]
    );
}

#[test]
fn rejects_real_eigenvalues_and_odd_dimension() {
    let exps = poly::exponents(2, 1, 1);
    let p = Poly { dim_in: 2, dim_out: 2, scale: vec![1.0, 1.0], exps, coef: vec![-1.0, 0.0, 0.0, -2.0] };
    let e = normal_form_of_poly(&p, None, &NormalFormOptions::default()).unwrap_err();
    assert!(matches!(e, NormalFormError::RealEigenvalue { .. }), "{e}");
    let exps = poly::exponents(3, 1, 1);
    let p3 = Poly { dim_in: 3, dim_out: 3, scale: vec![1.0; 3], exps, coef: vec![0.0; 9] };
    assert!(matches!(
        normal_form_of_poly(&p3, None, &NormalFormOptions::default()),
        Err(NormalFormError::OddDimension(3))
    ));
}
