//! Backbone curves of polar normal forms: instantaneous damping and frequency against the
//! amplitude of an observable (SSMLearn's `backboneCurves`).
//!
//! # Definitions
//!
//! For mode `j` of a polar normal form ([`PolarNormalForm`]) with the other modes at zero,
//! `rho_j' = rho_j A_j(rho_j)`, `theta_j' = Omega_j(rho_j)`:
//! * the instantaneous eigenvalue is `lambda(rho) = A_j(rho) + i Omega_j(rho)`;
//! * the damping ratio is `zeta(rho) = -Re lambda / |lambda| = -A / sqrt(A^2 + Omega^2)`
//!   (for a linear oscillator `lambda = -zeta w_n + i w_n sqrt(1 - zeta^2)` this is its
//!   zeta exactly; SSMLearn's figures plot `-A / Omega`, larger by `1 / sqrt(1 - zeta^2)`,
//!   0.5 % at zeta = 0.1);
//! * the frequency is `Omega(rho)` in rad/s (for a map normal form, that of the flow whose
//!   time-dt map it is);
//! * the amplitude is `max over theta in [0, 2 pi)` of `|y_i|`, where `y_i` is observable
//!   `i` (row `i` of the embedding: observable i now) of the point of the manifold
//!   `M(eta)` above `eta = W (u + h(u))` ([`NormalFormTransform`]), `u` the normal-form
//!   coordinates at `(rho, theta)`. So the amplitude is in the observable's own units and
//!   includes the nonlinear manifold and the normal-form transformation, not only `rho`.
//!   The max is taken on a grid of phases and refined by golden-section search.
//!
//! The curve runs from `rho = 0` to the `rho` where the amplitude first reaches the
//! requested largest amplitude (by default, in `ssmctl`, the largest |observable| of the
//! training data).

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::fit::SsmModel;
use crate::normal_form::{
    NormalFormError, NormalFormOptions, NormalFormTransform, PolarNormalForm, model_normal_form_with_transform,
};
use crate::poly::PolyScratch;

/// Errors of the backbone computation.
#[derive(Debug, Error)]
pub enum BackboneError {
    #[error(transparent)]
    NormalForm(#[from] NormalFormError),
    #[error("observable {index} does not exist: the model has {count} observable(s) (0-based)")]
    Observable { index: usize, count: usize },
    #[error("backbone option {what}: {why}")]
    BadOption { what: &'static str, why: String },
    #[error(
        "mode {mode}: the backbone does not reach amplitude {target} of observable {observable} (largest {reached} up to rho = {rho}); ask for a smaller amplitude"
    )]
    Unreached { mode: usize, observable: usize, target: f64, reached: f64, rho: f64 },
}

/// Most points of one backbone curve.
pub const MAX_BACKBONE_POINTS: usize = 100_000;
/// Most phases sampled per amplitude.
pub const MAX_BACKBONE_PHASES: usize = 4096;

/// Options of [`backbone`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BackboneOptions {
    /// Observable index (0-based; row of the embedding at delay 0).
    pub observable: usize,
    /// Largest amplitude of the curve, in the observable's units (> 0).
    pub amplitude_max: f64,
    /// Points on the curve (>= 2), equally spaced in rho from 0.
    pub points: usize,
    /// Phase grid for the max over a period (>= 8) before refinement.
    pub phases: usize,
}

impl BackboneOptions {
    /// 101 points, 64 phases, for `observable` up to `amplitude_max`.
    pub fn new(observable: usize, amplitude_max: f64) -> Self {
        BackboneOptions { observable, amplitude_max, points: 101, phases: 64 }
    }
}

/// One point of a backbone curve.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BackbonePoint {
    /// Amplitude in the observable's units.
    pub amplitude: f64,
    /// Instantaneous frequency `Omega(rho)`, rad/s.
    pub freq_rad_s: f64,
    /// Instantaneous damping ratio `-A / |A + i Omega|`.
    pub damping_ratio: f64,
    /// Instantaneous growth rate `A(rho)`, 1/s (negative when damped).
    pub rate: f64,
    /// Normal-form amplitude.
    pub rho: f64,
}

/// The backbone curve of one mode.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Backbone {
    /// Mode (1-based, by increasing linear frequency).
    pub mode: usize,
    /// Observable (0-based).
    pub observable: usize,
    pub points: Vec<BackbonePoint>,
}

/// Instantaneous `(A, Omega)` of mode `mode` (0-based) at amplitude `rho`, others zero.
pub fn instantaneous(nf: &PolarNormalForm, mode: usize, rho: f64) -> (f64, f64) {
    let mut r = vec![0.0; nf.modes];
    r[mode] = rho;
    let (dr, dth) = nf.eval(&r);
    let a = if rho > 0.0 { dr[mode] / rho } else { nf.amp[mode][0] };
    (a, dth[mode])
}

/// `-a / |a + i omega|`.
pub fn damping_ratio(a: f64, omega: f64) -> f64 {
    -a / a.hypot(omega)
}

/// Max over one period of `|f(theta)|`: the best of `n` equally spaced phases, refined by
/// golden-section search on the neighbouring interval.
fn max_over_phase(f: &mut dyn FnMut(f64) -> f64, n: usize) -> f64 {
    let step = std::f64::consts::TAU / n as f64;
    let (mut best_k, mut best) = (0, f64::NEG_INFINITY);
    for k in 0..n {
        let v = f(k as f64 * step).abs();
        if v > best {
            (best_k, best) = (k, v);
        }
    }
    let g = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = ((best_k as f64 - 1.0) * step, (best_k as f64 + 1.0) * step);
    let (mut c, mut d) = (b - g * (b - a), a + g * (b - a));
    let (mut fc, mut fd) = (f(c).abs(), f(d).abs());
    for _ in 0..60 {
        if fc > fd {
            b = d;
            (d, fd) = (c, fc);
            c = b - g * (b - a);
            fc = f(c).abs();
        } else {
            a = c;
            (c, fc) = (d, fd);
            d = a + g * (b - a);
            fd = f(d).abs();
        }
    }
    best.max(fc).max(fd)
}

/// Amplitude of an observable on mode `mode` (0-based) of a normal form with `modes` modes
/// at normal-form amplitude `rho`, the other modes at zero: the max over the phase of
/// `|observe(eta)|`, `eta` the reduced coordinates above `(rho, theta)` through `tr`
/// (`phases` grid points, then golden-section refinement).
pub fn amplitude_at(
    tr: &NormalFormTransform,
    observe: &mut dyn FnMut(&[f64]) -> f64,
    modes: usize,
    mode: usize,
    rho: f64,
    phases: usize,
) -> f64 {
    let mut r = vec![0.0; modes];
    r[mode] = rho;
    let mut th = vec![0.0; modes];
    max_over_phase(
        &mut |theta| {
            th[mode] = theta;
            observe(&tr.eta(&r, &th))
        },
        phases,
    )
}

/// The first `rho` where `amplitude(rho)` reaches `target`: a linear gain from a small
/// probe, a march in 400 steps up to 5 times the linear estimate, then bisection (60
/// halvings). `Err((largest amplitude met, rho searched to))` when it is not reached.
pub(crate) fn first_rho_reaching(amplitude: &mut dyn FnMut(f64) -> f64, target: f64) -> Result<f64, (f64, f64)> {
    let probe = 1e-6;
    let gain = amplitude(probe) / probe;
    if !(gain > 0.0 && gain.is_finite()) {
        return Err((0.0, probe));
    }
    let rho_lin = target / gain;
    let (steps, reach) = (400, 5.0);
    let (mut lo, mut hi) = (0.0, None);
    let mut reached: f64 = 0.0;
    for k in 1..=steps {
        let rho = reach * rho_lin * k as f64 / steps as f64;
        let a = amplitude(rho);
        reached = reached.max(a);
        if a >= target {
            hi = Some(rho);
            break;
        }
        lo = rho;
    }
    let Some(mut hi) = hi else {
        return Err((reached, reach * rho_lin));
    };
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if amplitude(mid) >= target {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Ok(hi)
}

/// Backbone of mode `mode` (0-based) of `nf`, with the amplitude of `observe(eta)` (the
/// observable of the point above reduced coordinates `eta`), from rho = 0 to where the
/// amplitude first reaches `opts.amplitude_max`.
pub fn backbone_of(
    nf: &PolarNormalForm,
    tr: &NormalFormTransform,
    observe: &mut dyn FnMut(&[f64]) -> f64,
    mode: usize,
    opts: &BackboneOptions,
) -> Result<Backbone, BackboneError> {
    let bad = |what, why: String| Err(BackboneError::BadOption { what, why });
    if !(opts.amplitude_max > 0.0 && opts.amplitude_max.is_finite()) {
        return bad("amplitude_max", format!("must be a positive number, got {}", opts.amplitude_max));
    }
    if !(2..=MAX_BACKBONE_POINTS).contains(&opts.points) {
        return bad("points", format!("need 2 ..= {MAX_BACKBONE_POINTS}, got {}", opts.points));
    }
    if !(8..=MAX_BACKBONE_PHASES).contains(&opts.phases) {
        return bad("phases", format!("need 8 ..= {MAX_BACKBONE_PHASES}, got {}", opts.phases));
    }
    if mode >= nf.modes {
        return bad("mode", format!("mode {} of a normal form with {} modes", mode + 1, nf.modes));
    }
    let mut amplitude = |rho: f64| amplitude_at(tr, observe, nf.modes, mode, rho, opts.phases);
    let target = opts.amplitude_max;
    let hi = first_rho_reaching(&mut amplitude, target).map_err(|(reached, rho)| BackboneError::Unreached {
        mode: mode + 1,
        observable: opts.observable,
        target,
        reached,
        rho,
    })?;
    let points = (0..opts.points)
        .map(|k| {
            let rho = hi * k as f64 / (opts.points - 1) as f64;
            let (a, omega) = instantaneous(nf, mode, rho);
            BackbonePoint {
                amplitude: amplitude(rho),
                freq_rad_s: omega,
                damping_ratio: damping_ratio(a, omega),
                rate: a,
                rho,
            }
        })
        .collect();
    Ok(Backbone { mode: mode + 1, observable: opts.observable, points })
}

/// Backbone curves of every mode of a fitted model with polynomial dynamics (its normal
/// form with the observable convention, [`model_normal_form_with_transform`]), amplitudes
/// of observable `opts.observable` lifted through the manifold.
pub fn backbone(model: &SsmModel, opts: &BackboneOptions) -> Result<Vec<Backbone>, BackboneError> {
    if opts.observable >= model.observables {
        return Err(BackboneError::Observable { index: opts.observable, count: model.observables });
    }
    let (nf, tr) = model_normal_form_with_transform(model, &NormalFormOptions::default())?;
    let m = &model.manifold;
    let mut scratch = PolyScratch::default();
    let mut y = vec![0.0; m.p];
    let mut observe = |eta: &[f64]| {
        m.lift_into(eta, &mut scratch, &mut y);
        y[opts.observable]
    };
    (0..nf.modes).map(|j| backbone_of(&nf, &tr, &mut observe, j, opts)).collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::dynamics::ReducedDynamics;
    use crate::manifold::Manifold;
    use crate::poly::{self, Poly};
    use crate::ridge::Conditioning;
    use crate::{Dynamics, FitOptions, Ridge};
    use nalgebra::Complex;

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
            assert!(
                (pts.last().unwrap().rho - 1.0).abs() < 1e-9,
                "observable {obs}: rho_max {}",
                pts.last().unwrap().rho
            );
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
            v1: vec![
                1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
            ],
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
        let (nf, tr) = crate::normal_form::normal_form_with_transform(&dynamics, &opts).unwrap();
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
}
