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
