//! The tests of `ssm::backbone`.

use nalgebra::Complex;
use ssm::backbone::*;
use ssm::dynamics::ReducedDynamics;
use ssm::fit::SsmModel;
use ssm::manifold::Manifold;
use ssm::normal_form::{NormalFormOptions, model_normal_form_with_transform};
use ssm::poly::{self, Poly};
use ssm::ridge::Conditioning;
use ssm::{Dynamics, FitOptions, Ridge};

const A: f64 = -0.08;
const W: f64 = 3.0;
const B: f64 = -0.6;
const CC: f64 = 0.9;

/// The field of `z' = z (A + i W + (B + i CC) |z|^2)` for `eta = (Re z, Im z)`,
/// monomials on `eta / scale`.
fn synthetic_field(scale: [f64; 2]) -> Poly {
    let exps = poly::exponents(2, 1, 3);
    let mut coef = vec![0.0; exps.len() * 2];
    for (k, e) in exps.iter().enumerate() {
        let (out0, out1) = match (e[0], e[1]) {
            (1, 0) => (A, W),
            (0, 1) => (-W, A),
            (3, 0) => (B, CC),
            (2, 1) => (-CC, B),
            (1, 2) => (B, CC),
            (0, 3) => (-CC, B),
            _ => (0.0, 0.0),
        };
        let sc = scale[0].powi(e[0] as i32) * scale[1].powi(e[1] as i32);
        coef[k * 2] = out0 * sc;
        coef[k * 2 + 1] = out1 * sc;
    }
    Poly { dim_in: 2, dim_out: 2, scale: scale.to_vec(), exps, coef }
}

/// A hand-built model: the synthetic field above and three observables, linear in eta
/// with rows `(cos a, -sin a)` (`y_0 = Re(e^{ia} z)`, amplitude |z|) and
/// `(2 sin a, cos(a) / 2)`, and quadratic `y_2 = kappa eta_0^2`.
pub(crate) fn model(alpha: f64, kappa: f64) -> SsmModel {
    let v1 = vec![alpha.cos(), 2.0 * alpha.sin(), 0.0, -alpha.sin(), 0.5 * alpha.cos(), 0.0];
    let exps = poly::exponents(2, 2, 2);
    let mut coef = vec![0.0; exps.len() * 3];
    coef[2] = kappa * 0.5 * 0.5; // monomial (eta_1 / 0.5)^2, output row 2
    let manifold = Manifold {
        dim: 2,
        p: 3,
        v1,
        singular_values: vec![1.0, 1.0, 0.0],
        eta_scale: vec![0.5, 0.5],
        nonlinear: Some(Poly { dim_in: 2, dim_out: 3, scale: vec![0.5, 0.5], exps, coef }),
        conditioning: None,
    };
    let dynamics = ReducedDynamics::Flow { field: synthetic_field([0.7, 1.3]), conditioning: Conditioning::NONE };
    let options = FitOptions {
        dim: 2,
        embed: 1,
        shift: 1,
        manifold_order: 2,
        dyn_order: 3,
        dynamics: Dynamics::Flow,
        ridge: Ridge::Fixed(0.0),
        linear_anchor: None,
        anchor_joint: false,
    };
    SsmModel {
        options,
        dt: 0.01,
        manifold,
        dynamics,
        eigenvalues_ct: vec![],
        eta_range: vec![1.0, 1.0],
        n_points: 0,
        observables: 3,
    }
}

/// The analytic backbone of `rho' = (A + B rho^2) rho`, `theta' = W + CC rho^2`:
/// frequency `W + CC rho^2`, damping ratio `-(A + B rho^2) / |(A + B rho^2) + i (W + CC
/// rho^2)|`. Amplitudes: the normalization on observable 0 makes `y_0 = rho cos theta`,
/// so its amplitude is rho; a linear observable `c . eta` has `2 |c . w| rho` and
/// `y_2 = kappa eta_0^2` has `kappa (2 |w_0| rho)^2`, with `w` the eigenvector of
/// `A + i W` (`(1, -i)` in eta) scaled so that `c_0 . w = 1/2`.
#[test]
fn known_normal_form_backbone_is_exact() {
    let (alpha, kappa) = (0.35, 0.7);
    let m = model(alpha, kappa);
    let c = [alpha.cos(), -alpha.sin()];
    let w = [Complex::new(1.0, 0.0), Complex::new(0.0, -1.0)];
    let cw = w[0] * c[0] + w[1] * c[1];
    let w: Vec<Complex<f64>> = w.iter().map(|x| x * 0.5 / cw).collect();
    let c1 = [2.0 * alpha.sin(), 0.5 * alpha.cos()];
    let gain1 = 2.0 * (w[0] * c1[0] + w[1] * c1[1]).norm();
    let gain_eta0 = 2.0 * w[0].norm();
    for (obs, amp_of) in [
        (0usize, Box::new(|r: f64| r) as Box<dyn Fn(f64) -> f64>),
        (1, Box::new(move |r: f64| gain1 * r)),
        (2, Box::new(move |r: f64| kappa * (gain_eta0 * r).powi(2))),
    ] {
        let target = amp_of(1.0);
        let bb = backbone(&m, &BackboneOptions::new(obs, target)).unwrap();
        assert_eq!(bb.len(), 1);
        let pts = &bb[0].points;
        assert!((pts.last().unwrap().rho - 1.0).abs() < 1e-9, "observable {obs}: rho_max {}", pts.last().unwrap().rho);
        for p in pts {
            let (a, om) = (A + B * p.rho * p.rho, W + CC * p.rho * p.rho);
            assert!((p.freq_rad_s - om).abs() < 1e-12, "{p:?}");
            assert!((p.damping_ratio - (-a / (a * a + om * om).sqrt())).abs() < 1e-12, "{p:?}");
            assert!((p.rate - a).abs() < 1e-12, "{p:?}");
            assert!(
                (p.amplitude - amp_of(p.rho)).abs() < 1e-12 * target.max(1.0),
                "observable {obs}: {p:?} vs {}",
                amp_of(p.rho)
            );
        }
    }
    let e = backbone(&m, &BackboneOptions::new(3, 1.0)).unwrap_err();
    assert!(matches!(e, BackboneError::Observable { index: 3, count: 3 }), "{e}");
    // An observable that saturates (tanh) never reaches amplitude 2.
    let (nf, tr) = model_normal_form_with_transform(&m, &NormalFormOptions::default()).unwrap();
    let e = backbone_of(&nf, &tr, &mut |eta: &[f64]| eta[0].tanh(), 0, &BackboneOptions::new(0, 2.0)).unwrap_err();
    assert!(matches!(e, BackboneError::Unreached { .. }) && e.to_string().contains("amplitude 2 "), "{e}");
    let e = backbone(&m, &BackboneOptions { points: 1, ..BackboneOptions::new(0, 1.0) }).unwrap_err();
    assert!(matches!(e, BackboneError::BadOption { what: "points", .. }), "{e}");
}

/// Two modes (4D): `z_j' = z_j (lambda_j + beta_j1 |z_1|^2 + beta_j2 |z_2|^2)` in
/// `eta = (Re z_1, Im z_1, Re z_2, Im z_2)`, observed through `y_0 = Re z_1 + Re z_2`
/// (the normalization row, so each mode alone has amplitude rho_j). The backbone of mode
/// j (the other at zero) is that of its own `lambda_j + beta_jj rho^2`; modes come out by
/// increasing frequency although the fast one is first in eta.
#[test]
fn four_dimensional_normal_form_has_one_backbone_per_mode() {
    // (lambda, beta_self, beta_cross) per mode; eta block 0 is the FAST mode.
    let fast = ((-0.3, 9.0), (-0.2, -1.5), (0.7, 0.4));
    let slow = ((-0.05, 2.0), (-0.8, 0.6), (-0.1, 0.9));
    let exps = poly::exponents(4, 1, 3);
    let mut coef = vec![0.0; exps.len() * 4];
    let mut add = |e: [u32; 4], out: usize, v: f64| {
        let k = exps.iter().position(|x| x.as_slice() == e).unwrap();
        coef[k * 4 + out] += v;
    };
    for (blk, (lam, bs, bc)) in [(0usize, fast), (1, slow)] {
        let (r, i) = (2 * blk, 2 * blk + 1);
        let unit = |k: usize| {
            let mut e = [0u32; 4];
            e[k] = 1;
            e
        };
        // linear: (a x - w y, w x + a y)
        add(unit(r), r, lam.0);
        add(unit(i), r, -lam.1);
        add(unit(r), i, lam.1);
        add(unit(i), i, lam.0);
        // cubic: (b x - c y, c x + b y) times |z_self|^2 and |z_other|^2
        for (other, (b, c)) in [(blk, bs), (1 - blk, bc)] {
            for sq in [2 * other, 2 * other + 1] {
                let with = |k: usize| {
                    let mut e = unit(k);
                    e[sq] += 2;
                    e
                };
                add(with(r), r, b);
                add(with(i), r, -c);
                add(with(r), i, c);
                add(with(i), i, b);
            }
        }
    }
    let field = Poly { dim_in: 4, dim_out: 4, scale: vec![1.0; 4], exps, coef };
    let mut m = model(0.0, 0.0);
    m.manifold = Manifold {
        dim: 4,
        p: 5,
        v1: vec![1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        singular_values: vec![1.0; 5],
        eta_scale: vec![1.0; 4],
        nonlinear: None,
        conditioning: None,
    };
    // Row 0 of V1 = (1, 0, 1, 0): y_0 = eta_0 + eta_2.
    m.dynamics = ReducedDynamics::Flow { field, conditioning: Conditioning::NONE };
    m.options.dim = 4;
    m.observables = 5;
    let bb = backbone(&m, &BackboneOptions::new(0, 0.8)).unwrap();
    assert_eq!(bb.len(), 2);
    for (curve, (lam, bs, _)) in bb.iter().zip([slow, fast]) {
        for p in &curve.points {
            let (a, om) = (lam.0 + bs.0 * p.rho * p.rho, lam.1 + bs.1 * p.rho * p.rho);
            assert!(
                (p.freq_rad_s - om).abs() < 1e-12 && (p.damping_ratio - damping_ratio(a, om)).abs() < 1e-12,
                "mode {}: {p:?}",
                curve.mode
            );
            assert!((p.amplitude - p.rho).abs() < 1e-12, "mode {}: {p:?}", curve.mode);
        }
        assert!((curve.points.last().unwrap().amplitude - 0.8).abs() < 1e-12);
    }
    assert_eq!((bb[0].mode, bb[1].mode), (1, 2));
}

/// With a non-resonant quadratic term the normal form needs a transformation `h`:
/// normal-form trajectories mapped through `eta = W (u + h(u))` follow the true field
/// to `O(rho^4)` (order 3), while ignoring `h` leaves an `O(rho^2)` error.
#[test]
fn transformation_conjugates_to_the_reduced_flow() {
    let mut field = synthetic_field([1.0, 1.0]);
    // add 0.4 eta_0^2 to eta_0' and -0.3 eta_0 eta_1 to eta_1'
    let k20 = field.exps.iter().position(|e| e == &vec![2, 0]).unwrap();
    let k11 = field.exps.iter().position(|e| e == &vec![1, 1]).unwrap();
    field.coef[k20 * 2] = 0.4;
    field.coef[k11 * 2 + 1] = -0.3;
    let dynamics = ReducedDynamics::Flow { field: field.clone(), conditioning: Conditioning::NONE };
    let opts = NormalFormOptions { order: Some(3), ..Default::default() };
    let (nf, tr) = ssm::normal_form::normal_form_with_transform(&dynamics, &opts).unwrap();
    let f = |eta: &[f64]| field.eval(eta);
    let rk4 = |y: &mut Vec<f64>, h: f64, g: &dyn Fn(&[f64]) -> Vec<f64>| {
        let k1 = g(y);
        let k2 = g(&y.iter().zip(&k1).map(|(a, b)| a + 0.5 * h * b).collect::<Vec<_>>());
        let k3 = g(&y.iter().zip(&k2).map(|(a, b)| a + 0.5 * h * b).collect::<Vec<_>>());
        let k4 = g(&y.iter().zip(&k3).map(|(a, b)| a + h * b).collect::<Vec<_>>());
        for i in 0..y.len() {
            y[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
    };
    let mut errs = Vec::new();
    for rho0 in [0.02, 0.04] {
        // polar NF state (rho, theta) and the field state from the same start.
        let mut polar = vec![rho0, 0.3];
        let mut eta = tr.eta(&[rho0], &[0.3]);
        let mut worst: f64 = 0.0;
        let nf_rhs = |s: &[f64]| {
            let (dr, dth) = nf.eval(&[s[0]]);
            vec![dr[0], dth[0]]
        };
        for _ in 0..2000 {
            rk4(&mut polar, 1e-3, &nf_rhs);
            rk4(&mut eta, 1e-3, &f);
            let mapped = tr.eta(&[polar[0]], &[polar[1]]);
            worst = worst.max(mapped.iter().zip(&eta).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max));
        }
        errs.push(worst);
    }
    // Halving rho divides an O(rho^4) error by ~16.
    assert!(errs[0] < 1e-5 && errs[1] / errs[0] > 10.0, "conjugacy errors {errs:?}");
}
