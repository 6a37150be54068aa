//! The tests of `ssm::map_ssm`.
//!
//! Known answer: a skew product `x' = f(x)`, `y' = B y + g(x)` with `g = h o f - B h`, whose
//! SSM is exactly the graph `y = h(x)` and whose reduced map is `f`. The SSM's polar
//! coefficients must equal the normal form of `f` computed by [`ssm::normal_form`] (an
//! independent code path, tested on its own known answers).

use ssm::map_ssm::*;

use nalgebra::{Complex, DMatrix};
use ssm::internals::{Table, structural};
use ssm::normal_form::Normalization;
use ssm::normal_form::{NormalFormOptions, normal_form_of_poly};
use ssm::poly;
use ssm::poly::Poly;

type C = Complex<f64>;

const DT: f64 = 0.03;

/// Real 4x4 linear part with multipliers `0.995 e^{+-0.15 i}` and `1.008 e^{+-1.63 i}`,
/// mixed by a fixed matrix.
fn linear_x() -> DMatrix<f64> {
    let blk = |r: f64, th: f64| [[r * th.cos(), -r * th.sin()], [r * th.sin(), r * th.cos()]];
    let (b1, b2) = (blk(0.995, 0.15), blk(1.008, 1.63));
    let mut d = DMatrix::<f64>::zeros(4, 4);
    for i in 0..2 {
        for j in 0..2 {
            d[(i, j)] = b1[i][j];
            d[(2 + i, 2 + j)] = b2[i][j];
        }
    }
    let m = DMatrix::from_row_slice(
        4,
        4,
        &[1.0, 0.2, -0.1, 0.3, 0.1, 0.9, 0.2, -0.2, -0.3, 0.1, 1.1, 0.2, 0.2, -0.3, 0.1, 0.8],
    );
    &m * d * m.try_inverse().unwrap()
}

/// Nonlinear part of `f` (quadratic and cubic), as (exponents in x, coefficients per output).
fn q_terms() -> Vec<(Vec<u32>, [f64; 4])> {
    vec![
        (vec![2, 0, 0, 0], [0.3, -0.2, 0.1, 0.05]),
        (vec![0, 1, 1, 0], [-0.4, 0.1, 0.2, 0.3]),
        (vec![1, 0, 0, 1], [0.1, 0.2, -0.3, 0.1]),
        (vec![3, 0, 0, 0], [-0.5, 0.2, 0.1, -0.1]),
        (vec![1, 1, 1, 0], [0.2, -0.3, 0.4, 0.2]),
        (vec![0, 0, 2, 1], [0.1, 0.1, -0.6, 0.3]),
        (vec![0, 1, 0, 2], [-0.2, 0.4, 0.1, -0.7]),
    ]
}

/// `h(x)`: two quadratic components.
fn h_terms() -> Vec<(Vec<u32>, [f64; 2])> {
    vec![
        (vec![1, 1, 0, 0], [0.5, 0.0]),
        (vec![0, 0, 2, 0], [-0.3, 0.0]),
        (vec![1, 0, 0, 1], [0.0, 0.2]),
        (vec![0, 2, 0, 0], [0.0, 1.0]),
    ]
}

const B: [f64; 2] = [0.3, -0.2];

/// The 6D skew-product map and the 4D reduced map `f` (as a [`Poly`] increment).
fn system() -> (PolynomialMap, Poly) {
    let l = linear_x();
    let tab = Table::new(4, 6);
    let nt = tab.exps.len();
    let var = |i: usize| {
        let mut p = vec![C::new(0.0, 0.0); nt];
        let mut e = vec![0u32; 4];
        e[i] = 1;
        p[tab.index[&e]] = C::new(1.0, 0.0);
        p
    };
    // f as polynomials.
    let mut f: Vec<Vec<C>> = (0..4)
        .map(|o| {
            let mut p = vec![C::new(0.0, 0.0); nt];
            for j in 0..4 {
                let x = var(j);
                for (a, b) in p.iter_mut().zip(&x) {
                    *a += b * l[(o, j)];
                }
            }
            p
        })
        .collect();
    for (e, c) in q_terms() {
        for o in 0..4 {
            f[o][tab.index[&e]] += C::new(c[o], 0.0);
        }
    }
    let hexps: Vec<Vec<u32>> = h_terms().iter().map(|(e, _)| e.clone()).collect();
    let hf = tab.monomials(&hexps, &f, 6);
    let hx = tab.monomials(&hexps, &(0..4).map(var).collect::<Vec<_>>(), 6);
    // g_o = sum_t c_t (m_t(f) - B_o m_t(x)).
    let mut g = vec![vec![C::new(0.0, 0.0); nt]; 2];
    for (t, (_, c)) in h_terms().iter().enumerate() {
        let (mf, mx) = (hf[t].as_ref().unwrap(), hx[t].as_ref().unwrap());
        for o in 0..2 {
            for i in 0..nt {
                g[o][i] += (mf[i] - mx[i] * B[o]) * c[o];
            }
        }
    }
    // G in 6 variables (x, y): rows 0..4 the q terms, rows 4..6 g(x).
    let mut exps = Vec::new();
    let mut coef: Vec<Vec<f64>> = vec![Vec::new(); 6];
    for (i, e) in tab.exps.iter().enumerate() {
        if e.iter().sum::<u32>() < 2 {
            continue;
        }
        let mut e6 = e.clone();
        e6.extend([0, 0]);
        exps.push(e6);
        let qv = q_terms().iter().find(|(qe, _)| qe == e).map(|(_, c)| *c).unwrap_or([0.0; 4]);
        for o in 0..4 {
            coef[o].push(qv[o]);
        }
        for o in 0..2 {
            assert!(g[o][i].im.abs() < 1e-14);
            coef[4 + o].push(g[o][i].re);
        }
    }
    let mut linear = vec![0.0; 36];
    for i in 0..4 {
        for j in 0..4 {
            linear[i * 6 + j] = l[(i, j)];
        }
    }
    linear[4 * 6 + 4] = B[0];
    linear[5 * 6 + 5] = B[1];
    let mut proj = vec![0.0; 36];
    for i in 0..6 {
        proj[i * 6 + i] = 1.0;
    }
    let map = PolynomialMap { dim: 6, linear, nproj: 6, proj, exps, coef };
    // f - identity as a Poly of degree 1..=3.
    let pexps = poly::exponents(4, 1, 3);
    let mut pc = vec![0.0; pexps.len() * 4];
    for (k, e) in pexps.iter().enumerate() {
        for o in 0..4 {
            let mut v = f[o][tab.index[e]].re;
            if e.iter().sum::<u32>() == 1 && e[o] == 1 {
                v -= 1.0;
            }
            pc[k * 4 + o] = v;
        }
    }
    (map, Poly { dim_in: 4, dim_out: 4, scale: vec![1.0; 4], exps: pexps, coef: pc })
}

fn opts(order: u32) -> MapSsmOptions {
    MapSsmOptions {
        order,
        pairs: 2,
        resonance_tol: 1e-3,
        observable: vec![1.0, 0.0, 0.5, 0.0, 0.0, 0.0],
        dt: DT,
        amplitude: Amplitude::Spectral,
    }
}

#[test]
fn polar_coefficients_equal_the_normal_form_of_the_reduced_map() {
    let (map, f) = system();
    let ssm = map_ssm(&map, &opts(7)).unwrap();
    let nf_opts = NormalFormOptions {
        order: Some(7),
        small_divisor: 1e-3,
        normalization: Normalization::Observable(vec![1.0, 0.0, 0.5, 0.0]),
    };
    let want = normal_form_of_poly(&f, Some(DT), &nf_opts).unwrap();
    let got = &ssm.polar;
    assert_eq!(got.pexps, want.pexps);
    for i in 0..2 {
        // Linear rates: ln|mu|/dt exactly.
        let r = [0.995f64, 1.008][i].ln() / DT;
        assert!((got.amp[i][0] - r).abs() < 1e-11, "mode {i}: {} vs {r}", got.amp[i][0]);
        for k in 0..got.pexps.len() {
            let scale = want.amp[i][k].abs().max(want.phase[i][k].abs()).max(1.0);
            assert!(
                (got.amp[i][k] - want.amp[i][k]).abs() < 1e-8 * scale,
                "amp {i} {k}: {} vs {}",
                got.amp[i][k],
                want.amp[i][k]
            );
            assert!(
                (got.phase[i][k] - want.phase[i][k]).abs() < 1e-8 * scale,
                "phase {i} {k}: {} vs {}",
                got.phase[i][k],
                want.phase[i][k]
            );
        }
    }
    assert!(ssm.extra_resonances.is_empty());
    assert!(ssm.min_divisor > 1e-3);
}

/// The computed manifold is the graph `y = h(x)`: its y rows equal `h` of its x rows.
#[test]
fn manifold_is_the_known_graph_and_real() {
    let (map, _) = system();
    let ssm = map_ssm(&map, &opts(6)).unwrap();
    let z1 = C::from_polar(0.02, 0.4);
    let z2 = C::from_polar(0.015, -1.1);
    let z = [z1, z1.conj(), z2, z2.conj()];
    let s = ssm.manifold_at(&z, 6);
    assert!(s.iter().all(|v| v.im.abs() < 1e-15), "{s:?}");
    let x: Vec<f64> = s[..4].iter().map(|v| v.re).collect();
    let h: Vec<f64> = (0..2)
        .map(|o| {
            h_terms()
                .iter()
                .map(|(e, c)| c[o] * e.iter().zip(&x).map(|(&k, v)| v.powi(k as i32)).product::<f64>())
                .sum()
        })
        .collect();
    for o in 0..2 {
        // Truncation at order 6 of the graph: O(|z|^7) (|z|^7 ~ 1e-12, times coefficients
        // grown by the slow pair's small divisors |mu_1^2 - mu_1| ~ 0.15).
        assert!((s[4 + o].re - h[o]).abs() < 1e-9, "y{o}: {} vs {}", s[4 + o].re, h[o]);
    }
}

/// Invariance error falls with the order on a ball of radius 0.05 (amplitudes in the
/// observable's units), roughly like radius^(order+1).
#[test]
fn invariance_error_falls_with_the_order() {
    let (map, _) = system();
    let ssm = map_ssm(&map, &opts(9)).unwrap();
    let errs: Vec<f64> = [3, 5, 7, 9].iter().map(|&k| ssm.invariance_error(&map, k, 0.05, 6).abs).collect();
    for w in errs.windows(2) {
        assert!(w[1] < w[0] / 5.0, "{errs:?}");
    }
    eprintln!("invariance errors at orders 3, 5, 7, 9: {errs:?}");
    assert!(errs[3] < 1e-8, "{errs:?}");
    assert!(ssm.order_stats.iter().all(|s| s.w_max.is_finite() && s.r_max.is_finite()));
}

/// `W`, `R` and `F` evaluated from cached powers (factors with zero exponent left out) give
/// the same bits as the former evaluation (`powu` of every variable in every monomial, a
/// factor `powu(0) = 1` included), at every truncation order, including rows with exact zeros.
#[test]
fn cached_power_evaluation_is_bit_identical() {
    let (map, _) = system();
    let mut ssm = map_ssm(&map, &opts(9)).unwrap();
    // Exact zeros (either sign) in some coefficients: the signed-zero argument of
    // `monomial_times`.
    for (k, c) in ssm.w[0].iter_mut().enumerate().filter(|(k, _)| k % 5 == 0) {
        *c = if k % 2 == 0 { (0.0, c.1) } else { (-0.0, -0.0) };
    }
    let old_eval = |rows: &[Vec<(f64, f64)>], z: &[C], order: u32| -> Vec<C> {
        rows.iter()
            .map(|coef| {
                ssm.exps
                    .iter()
                    .zip(coef)
                    .filter(|(e, _)| e.iter().sum::<u32>() <= order)
                    .map(|(e, &(re, im))| e.iter().zip(z).fold(C::new(re, im), |acc, (&k, x)| acc * x.powu(k)))
                    .sum()
            })
            .collect()
    };
    let old_map = |s: &[C]| -> Vec<C> {
        let (d, m) = (map.dim, map.nproj);
        let v: Vec<C> = (0..m).map(|k| (0..d).map(|j| s[j] * map.proj[k * d + j]).sum()).collect();
        let mono: Vec<C> =
            map.exps.iter().map(|e| e.iter().zip(&v).fold(C::new(1.0, 0.0), |a, (&k, x)| a * x.powu(k))).collect();
        (0..d)
            .map(|r| {
                let lin: C = (0..d).map(|j| s[j] * map.linear[r * d + j]).sum();
                lin + map.coef[r].iter().zip(&mono).map(|(c, x)| x * *c).sum::<C>()
            })
            .collect()
    };
    let bits = |v: &[C]| v.iter().map(|c| (c.re.to_bits(), c.im.to_bits())).collect::<Vec<_>>();
    for (r, th) in [(0.05, 0.3), (0.2, -1.7), (0.0, 0.0)] {
        let z1 = C::from_polar(r, th);
        let z2 = C::from_polar(0.6 * r, 2.0 * th + 0.1);
        let z = [z1, z1.conj(), z2, z2.conj()];
        for order in [1, 3, 6, 9, 12] {
            assert_eq!(
                bits(&ssm.manifold_at(&z, order)),
                bits(&old_eval(&ssm.w, &z, order)),
                "W at r = {r}, order {order}"
            );
            assert_eq!(
                bits(&ssm.reduced_at(&z, order)),
                bits(&old_eval(&ssm.r, &z, order)),
                "R at r = {r}, order {order}"
            );
        }
        let s = ssm.manifold_at(&z, 9);
        assert_eq!(bits(&map.eval_c(&s)), bits(&old_map(&s)), "F at r = {r}");
    }
}

/// A tolerance above some non-structural divisor keeps those terms in the reduced map and
/// reports them (never divided), and the result stays invariant.
#[test]
fn near_resonances_are_kept_and_reported() {
    let (map, _) = system();
    let mut o = opts(5);
    o.resonance_tol = 0.3;
    let ssm = map_ssm(&map, &o).unwrap();
    assert!(!ssm.extra_resonances.is_empty());
    assert!(ssm.extra_resonances.iter().all(|e| e.divisor < 0.3));
    assert!(ssm.min_divisor >= 0.3);
    let e3 = ssm.invariance_error(&map, 3, 0.05, 6).abs;
    let e5 = ssm.invariance_error(&map, 5, 0.05, 6).abs;
    assert!(e5 < e3 / 5.0, "{e3} {e5}");
}

#[test]
fn bad_options_are_named() {
    let (map, _) = system();
    let cases: [(MapSsmOptions, &str); 4] = [
        (MapSsmOptions { order: 10, ..opts(3) }, "order"),
        (MapSsmOptions { pairs: 4, ..opts(3) }, "pairs"),
        (MapSsmOptions { observable: vec![1.0], ..opts(3) }, "observable"),
        (MapSsmOptions { dt: 0.0, ..opts(3) }, "dt"),
    ];
    for (o, what) in cases {
        let e = map_ssm(&map, &o).unwrap_err();
        assert!(e.to_string().contains(what), "{e}");
    }
    let mut bad = map.clone();
    bad.coef[0][0] = f64::NAN;
    assert!(matches!(map_ssm(&bad, &opts(3)), Err(MapSsmError::BadMap(_))));
}

/// `master_coordinates` inverts the parametrization: on the manifold it returns the `z`
/// the point was made from; the left eigenvectors are dual to the right ones.
#[test]
fn master_coordinates_invert_the_manifold() {
    let (map, _) = system();
    let ssm = map_ssm(&map, &opts(7)).unwrap();
    assert_eq!(ssm.left.len(), 4);
    let z1 = C::from_polar(0.03, 0.4);
    let z2 = C::from_polar(0.02, -1.1);
    let z = [z1, z1.conj(), z2, z2.conj()];
    let s: Vec<f64> = ssm.manifold_at(&z, 7).iter().map(|v| v.re).collect();
    let back = ssm.master_coordinates(&s, 7, 1e-14).unwrap();
    for (a, b) in back.iter().zip(&z) {
        assert!((a - b).norm() < 1e-12, "{back:?} vs {z:?}");
    }
    // u_j^T v_l = delta_jl with v_l the order-1 columns of W.
    for (j, u) in ssm.left.iter().enumerate() {
        for l in 0..4 {
            let mut e = vec![0u32; 4];
            e[l] = 1;
            let q = ssm.exps.iter().position(|x| *x == e).unwrap();
            let dot: C = u.iter().zip(&ssm.w).map(|(&(ur, ui), row)| C::new(ur, ui) * C::new(row[q].0, row[q].1)).sum();
            let want = if j == l { 1.0 } else { 0.0 };
            assert!((dot - C::new(want, 0.0)).norm() < 1e-10, "u_{j} . v_{l} = {dot}");
        }
    }
    assert!(ssm.master_coordinates(&s[..3], 7, 1e-14).is_none());
}

/// Index of the structural monomial `z_i |z_1|^{2 p_1} |z_2|^{2 p_2}` (equation of `z_i`,
/// `i` = 0 or 1 the mode) in `ssm.exps`.
fn structural_index(ssm: &MapSsm, i: usize, p: [u32; 2]) -> usize {
    let mut e = vec![p[0], p[0], p[1], p[1]];
    e[2 * i] += 1;
    ssm.exps.iter().position(|x| *x == e).unwrap()
}

/// `Amplitude::Observable`: the observable has no nonlinear part at a mode's own frequency
/// (`c . W_m = 0` for every structural `m` of degree >= 2), so on a torus `|z_j| = rho_j`
/// the observable's first harmonic at mode `j` is exactly `rho_j` (checked by a 2D DFT over
/// the phases); the manifold stays invariant (error falls with the order as with
/// `Spectral`); both normalizations have the same linear part and the same manifold at
/// order 1.
#[test]
fn observable_amplitude_is_the_first_harmonic() {
    let (map, _) = system();
    let o = MapSsmOptions { amplitude: Amplitude::Observable, ..opts(7) };
    let ssm = map_ssm(&map, &o).unwrap();
    let spec = map_ssm(&map, &opts(7)).unwrap();
    let c = &o.observable;
    for (k, e) in ssm.exps.iter().enumerate() {
        let deg: u32 = e.iter().sum();
        let is_struct = (0..4).any(|j| structural(j, e));
        let cw: C = c.iter().zip(&ssm.w).map(|(ci, row)| C::new(row[k].0, row[k].1) * *ci).sum();
        if deg >= 2 && is_struct {
            assert!(cw.norm() < 1e-13, "c . W_{e:?} = {cw}");
        }
        if deg == 1 {
            assert_eq!(ssm.w.iter().map(|r| r[k]).collect::<Vec<_>>(), spec.w.iter().map(|r| r[k]).collect::<Vec<_>>());
        }
    }
    let rho = [0.03, 0.02];
    let n = 16;
    let mut h = [C::new(0.0, 0.0); 2];
    for a in 0..n {
        for b in 0..n {
            let (t1, t2) = (std::f64::consts::TAU * a as f64 / n as f64, std::f64::consts::TAU * b as f64 / n as f64);
            let (z1, z2) = (C::from_polar(rho[0], t1), C::from_polar(rho[1], t2));
            let s = ssm.manifold_at(&[z1, z1.conj(), z2, z2.conj()], 7);
            let x: f64 = c.iter().zip(&s).map(|(ci, v)| ci * v.re).sum();
            h[0] += C::from_polar(x, -t1) / (n * n) as f64;
            h[1] += C::from_polar(x, -t2) / (n * n) as f64;
        }
    }
    for j in 0..2 {
        assert!(
            (2.0 * h[j].norm() - rho[j]).abs() < 1e-14,
            "mode {j}: first harmonic {} vs rho {}",
            2.0 * h[j].norm(),
            rho[j]
        );
    }
    let errs: Vec<f64> = [3, 5, 7].iter().map(|&k| ssm.invariance_error(&map, k, 0.05, 6).abs).collect();
    assert!(errs[1] < errs[0] / 5.0 && errs[2] < errs[1] / 5.0, "{errs:?}");
    for i in 0..2 {
        assert_eq!(ssm.polar.amp[i][0], spec.polar.amp[i][0]);
        assert_eq!(ssm.polar.phase[i][0], spec.polar.phase[i][0]);
    }
}

/// The two normalizations are related by `rho_i^obs = rho_i |1 + sum_j kappa_ij rho_j^2 +
/// ...|` with `kappa_ij = 2 c . W^spec_m` (`m` the structural monomial `z_i |z_j|^2`, and
/// `c . v_i = 1/2`): the cubic coefficient of `rho_i rho_j^2` must move by exactly
/// `2 Re(kappa_ij) Re(lambda_j)` (`rho_i' = rho_i (a_i + b_ij rho_j^2)` in `r_i = rho_i (1 +
/// k_ij rho_j^2)` is `r_i' = r_i (a_i + (b_ij + 2 k_ij a_j) r_j^2) + O(r^5)`).
#[test]
fn cubic_coefficients_move_by_two_kappa_lambda() {
    let (map, _) = system();
    let obs = map_ssm(&map, &MapSsmOptions { amplitude: Amplitude::Observable, ..opts(5) }).unwrap();
    let spec = map_ssm(&map, &opts(5)).unwrap();
    let c = &opts(5).observable;
    for i in 0..2 {
        for j in 0..2 {
            let mut p = [0u32; 2];
            p[j] = 1;
            let k = structural_index(&spec, i, p);
            let cw: C = c.iter().zip(&spec.w).map(|(ci, row)| C::new(row[k].0, row[k].1) * *ci).sum();
            let kappa = 2.0 * cw.re;
            let col = spec.polar.pexps.iter().position(|e| e[..] == p[..]).unwrap();
            let (b_s, b_o) = (spec.polar.amp[i][col], obs.polar.amp[i][col]);
            let want = b_s + 2.0 * kappa * spec.polar.amp[j][0];
            assert!(
                (b_o - want).abs() < 1e-9 * want.abs().max(1.0),
                "b_{i}{j}: observable {b_o}, spectral {b_s} + 2 kappa a_j = {want}"
            );
            assert!((b_o - b_s).abs() > 1e-6, "b_{i}{j} unchanged: the test needs kappa != 0");
        }
    }
}

/// The first-harmonic basis of `ssm::normal_form` applied to the equation-driven model's
/// own reduced map and observable (`MapSsm::real_form`, the form of a data-driven model)
/// reproduces the `Amplitude::Observable` polar coefficients, from either normalization of
/// the SSM; the linear-row `Observable` normal form of the same map does not.
#[test]
fn first_harmonic_normal_form_of_the_reduced_map_is_the_observable_amplitude() {
    let (map, _) = system();
    let order = 7;
    let obs = map_ssm(&map, &MapSsmOptions { amplitude: Amplitude::Observable, ..opts(order) }).unwrap();
    let c = opts(order).observable;
    for amplitude in [Amplitude::Spectral, Amplitude::Observable] {
        let ssm = map_ssm(&map, &MapSsmOptions { amplitude, ..opts(order) }).unwrap();
        let (inc, x) = ssm.real_form(&c).unwrap();
        let fh = NormalFormOptions {
            order: Some(order),
            small_divisor: 1e-3,
            normalization: Normalization::FirstHarmonic(x.clone()),
        };
        let nf = normal_form_of_poly(&inc, Some(DT), &fh).unwrap();
        let want = &obs.polar;
        assert_eq!(nf.pexps, want.pexps);
        for i in 0..2 {
            for k in 0..want.pexps.len() {
                let scale = want.amp[i][k].abs().max(want.phase[i][k].abs()).max(1.0);
                assert!(
                    (nf.amp[i][k] - want.amp[i][k]).abs() < 1e-9 * scale,
                    "{amplitude:?} amp {i} {k}: {} vs {}",
                    nf.amp[i][k],
                    want.amp[i][k]
                );
                assert!(
                    (nf.phase[i][k] - want.phase[i][k]).abs() < 1e-9 * scale,
                    "{amplitude:?} phase {i} {k}: {} vs {}",
                    nf.phase[i][k],
                    want.phase[i][k]
                );
            }
        }
        if amplitude == Amplitude::Spectral {
            let lin = NormalFormOptions { normalization: Normalization::Observable(x.linear_part()), ..fh.clone() };
            let nl = normal_form_of_poly(&inc, Some(DT), &lin).unwrap();
            assert!(
                (nl.amp[0][1] - want.amp[0][1]).abs() > 1e-6,
                "linear-row normal form equals the observable one: the test sees nothing"
            );
        }
    }
    assert!(map_ssm(&map, &opts(3)).unwrap().real_form(&[1.0]).is_err());
}
