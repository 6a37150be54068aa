//! Forced response curves (FRC) predicted from decay data: harmonic forcing added to the
//! polar normal form of a fitted model, the forcing amplitude calibrated from one measured
//! forced-response point (SSMLearn's `calibrateFRC` and analytic FRC, in our own code).
//!
//! # Model
//!
//! Mode `j` of the polar normal form ([`PolarNormalForm`]) with the other modes at zero has
//! `rho' = rho A(rho)`, `theta' = w(rho)` (the backbone's rate and frequency). Forcing at
//! frequency `Omega` enters at leading order as `z' = z (A + i w) + f e^{i Omega t}` with a
//! constant normal-form forcing amplitude `f > 0`; in polar form with the phase relative to
//! the forcing, `psi = theta - Omega t`:
//!
//! ```text
//! rho' = rho A(rho) + f cos(psi)
//! psi' = w(rho) - Omega - (f / rho) sin(psi)
//! ```
//!
//! * Steady states (periodic responses at the forcing frequency) solve
//!   `f^2 = rho^2 (A(rho)^2 + (w(rho) - Omega)^2)`: for every `rho` with `f >= rho |A(rho)|`,
//!   `Omega = w(rho) -+ sqrt(f^2 / rho^2 - A(rho)^2)` (closed form, parametrized by `rho`).
//!   The two branches meet where `f = rho |A|` (the peak, on the backbone `Omega = w`).
//! * Stability from the Jacobian of `(rho', psi')` at the steady state,
//!   `J = [[A + rho A', -rho (w - Omega)], [w' + (w - Omega) / rho, A]]`: stable iff
//!   `tr J = 2 A + rho A' < 0` and `det J = (A + rho A') A + (w - Omega)^2 + rho w' (w - Omega) > 0`.
//!   Folds (saddle-nodes) are where `det J` changes sign. For a model with several modes
//!   the forced mode's response (others at zero) must also be stable against the others:
//!   their rates `A_k` at `rho_j = rho` must be negative.
//! * Calibration: a measured steady-state amplitude `a_c` of the observable at forcing
//!   frequency `Omega_c` gives `rho_c` through the amplitude map (below) and then
//!   `f = rho_c sqrt(A(rho_c)^2 + (w(rho_c) - Omega_c)^2)`. The point must be a stable
//!   steady state of the curve it defines (a measurement cannot settle on an unstable one)
//!   and within the amplitudes the model covers.
//! * Amplitude: that of the backbone ([`crate::backbone`]): the max over a period of the
//!   observable on the manifold above `eta = W (u + h(u))`, so in the observable's units,
//!   through the normal-form transformation and the manifold. (At leading order in the
//!   forcing the manifold and the transformation are the autonomous ones.)
//!
//! # Range of the model
//!
//! The curve is computed for `rho` up to `rho_max`, where the amplitude reaches
//! `amplitude_max` (SSMLearn's optional `rhoMax`, against spurious isolas of the
//! extrapolated polynomials): given, or by default the `rho` where the reduced coordinates
//! above `(rho, theta)` leave the training data's range (`|eta_i| <= eta_range_i`).

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::backbone::{amplitude_at, first_rho_reaching};
use crate::fit::SsmModel;
use crate::normal_form::{
    NormalFormError, NormalFormOptions, NormalFormTransform, PolarNormalForm, model_normal_form_with_transform,
};
use crate::poly::PolyScratch;

/// Largest number of points per frequency range of a curve (the `points` of [`ForcedResponse::curve`]).
pub const MAX_FRC_POINTS: usize = 100_000;

/// Errors of the forced-response computation.
#[derive(Debug, Error)]
pub enum FrcError {
    #[error(transparent)]
    NormalForm(#[from] NormalFormError),
    #[error("observable {index} does not exist: the model has {count} observable(s) (0-based)")]
    Observable { index: usize, count: usize },
    #[error("forced response option {what}: {why}")]
    BadOption { what: &'static str, why: String },
    #[error(
        "calibration point (forcing frequency {freq_rad_s} rad/s, amplitude {amplitude}) is off the forced response curve: {why}"
    )]
    OffCurve { freq_rad_s: f64, amplitude: f64, why: String },
    #[error(
        "mode {mode}: {what} is not reached (largest {reached} up to rho = {rho}); give a smaller largest amplitude"
    )]
    Unreached { mode: usize, what: String, reached: f64, rho: f64 },
}

/// Options of the forced response.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrcOptions {
    /// Observable index (0-based; row of the embedding at delay 0).
    pub observable: usize,
    /// The forced mode (0-based, by increasing linear frequency); the others stay at zero.
    pub mode: usize,
    /// Largest amplitude the model is trusted at, in the observable's units (> 0); `None`:
    /// where the reduced coordinates leave the training range (see the module docs).
    pub amplitude_max: Option<f64>,
    /// Phase grid for the max over a period (>= 8) before refinement.
    pub phases: usize,
}

impl FrcOptions {
    /// Mode 0, amplitude range from the training data, 64 phases.
    pub fn new(observable: usize) -> Self {
        FrcOptions { observable, mode: 0, amplitude_max: None, phases: 64 }
    }
}

/// A measured forced-response point: steady-state amplitude of the observable (its max
/// |value| over a period, as the backbone's) at a forcing frequency.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// Forcing frequency, rad/s (> 0).
    pub freq_rad_s: f64,
    /// Amplitude in the observable's units (> 0).
    pub amplitude: f64,
}

/// The calibration and what it determined.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrcCalibration {
    pub freq_rad_s: f64,
    pub amplitude: f64,
    /// Normal-form amplitude of the calibration point.
    pub rho: f64,
    /// Normal-form forcing amplitude `f` (units of rho per second).
    pub forcing: f64,
}

/// One continuous piece of a forced response curve with one stability.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrcBranch {
    pub stable: bool,
    /// Forcing frequency, rad/s.
    pub freq_rad_s: Vec<f64>,
    /// Steady-state amplitude of the observable.
    pub amplitude: Vec<f64>,
    /// Normal-form amplitude.
    pub rho: Vec<f64>,
}

/// A forced response curve over a frequency range.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Frc {
    /// Forced mode (1-based).
    pub mode: usize,
    /// Observable (0-based).
    pub observable: usize,
    pub calibration: FrcCalibration,
    /// The amplitude range of the model (curve cut there) and its normal-form amplitude.
    pub amplitude_max: f64,
    pub rho_max: f64,
    /// Pieces in order along the curve (lower-frequency side of the backbone first), split
    /// at the range ends, at stability changes and where the curve leaves the model range.
    pub branches: Vec<FrcBranch>,
}

/// One steady state at a given forcing frequency.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrcPoint {
    pub freq_rad_s: f64,
    pub amplitude: f64,
    pub rho: f64,
    pub stable: bool,
}

/// The forced polar normal form of one mode: `A(rho) = sum_n rate[n] rho^(2n)`,
/// `w(rho) = sum_n freq[n] rho^(2n)`, the other modes' rates along it, and the forcing.
#[derive(Clone, Debug, PartialEq)]
pub struct ForcedMode {
    pub rate: Vec<f64>,
    pub freq: Vec<f64>,
    /// Per other mode, the coefficients of its rate `A_k` in `rho^(2n)` (rho of the forced mode).
    pub transverse: Vec<Vec<f64>>,
    /// Normal-form forcing amplitude `f`.
    pub forcing: f64,
}

/// `(sum c[n] r^(2n), d/dr of it)`.
fn even_poly(c: &[f64], r: f64) -> (f64, f64) {
    let p = r * r;
    let (mut v, mut dv, mut pk) = (0.0, 0.0, 1.0);
    for (n, cn) in c.iter().enumerate() {
        v += cn * pk;
        if n > 0 {
            // d/dr r^(2n) = 2 n r^(2n-1) = 2 n r^(2n-2) r
            dv += 2.0 * n as f64 * cn * (pk / p) * r;
        }
        pk *= p;
    }
    if p == 0.0 {
        dv = 0.0;
    }
    (v, dv)
}

impl ForcedMode {
    /// Mode `mode` (0-based) of `nf` with the others at zero, forced with amplitude `forcing`.
    pub fn of(nf: &PolarNormalForm, mode: usize, forcing: f64) -> Self {
        let n = nf.pexps.iter().map(|e| e[mode] as usize).max().unwrap_or(0) + 1;
        let mut rate = vec![0.0; n];
        let mut freq = vec![0.0; n];
        let mut transverse = vec![vec![0.0; n]; nf.modes.saturating_sub(1)];
        for (k, e) in nf.pexps.iter().enumerate() {
            if e.iter().enumerate().any(|(i, &x)| i != mode && x != 0) {
                continue;
            }
            let p = e[mode] as usize;
            rate[p] += nf.amp[mode][k];
            freq[p] += nf.phase[mode][k];
            for (t, i) in (0..nf.modes).filter(|&i| i != mode).enumerate() {
                transverse[t][p] += nf.amp[i][k];
            }
        }
        ForcedMode { rate, freq, transverse, forcing }
    }

    /// `(A, A')` at `rho`.
    pub fn rate_at(&self, rho: f64) -> (f64, f64) {
        even_poly(&self.rate, rho)
    }

    /// `(w, w')` at `rho`, rad/s.
    pub fn freq_at(&self, rho: f64) -> (f64, f64) {
        even_poly(&self.freq, rho)
    }

    /// The forcing frequencies with a steady state at amplitude `rho > 0`: `(lower, upper)`
    /// (equal at the peak), `None` where `f < rho |A(rho)|`.
    pub fn frequencies(&self, rho: f64) -> Option<(f64, f64)> {
        let (a, _) = self.rate_at(rho);
        let (w, _) = self.freq_at(rho);
        let g = (self.forcing / rho).powi(2) - a * a;
        (g >= 0.0).then(|| (w - g.sqrt(), w + g.sqrt()))
    }

    /// The forcing amplitude that puts a steady state at `(rho, omega)`.
    pub fn forcing_for(&self, rho: f64, omega: f64) -> f64 {
        rho * self.rate_at(rho).0.hypot(self.freq_at(rho).0 - omega)
    }

    /// `(trace, determinant)` of the Jacobian of `(rho', psi')` at the steady state
    /// `(rho, omega)` (see the module docs).
    pub fn trace_det(&self, rho: f64, omega: f64) -> (f64, f64) {
        let (a, da) = self.rate_at(rho);
        let (w, dw) = self.freq_at(rho);
        let dr = a + rho * da;
        let s = w - omega;
        (dr + a, dr * a + s * s + rho * dw * s)
    }

    /// Whether the steady state `(rho, omega)` is asymptotically stable (also against the
    /// other modes).
    pub fn is_stable(&self, rho: f64, omega: f64) -> bool {
        let (tr, det) = self.trace_det(rho, omega);
        tr < 0.0 && det > 0.0 && self.transverse.iter().all(|c| even_poly(c, rho).0 < 0.0)
    }

    /// Every steady-state amplitude `rho` in `(0, rho_max]` at forcing frequency `omega`:
    /// the roots of `rho^2 (A^2 + (w - omega)^2) - f^2` bracketed on `grid` equal steps and
    /// refined by bisection (a double root at an exact fold may be missed).
    pub fn amplitudes_at(&self, omega: f64, rho_max: f64, grid: usize) -> Vec<f64> {
        let g = |r: f64| {
            let (a, _) = self.rate_at(r);
            let (w, _) = self.freq_at(r);
            r * r * (a * a + (w - omega).powi(2)) - self.forcing * self.forcing
        };
        let mut out = Vec::new();
        let (mut r0, mut g0) = (0.0, g(0.0));
        for k in 1..=grid.max(1) {
            let r1 = rho_max * k as f64 / grid.max(1) as f64;
            let g1 = g(r1);
            if g1 == 0.0 {
                out.push(r1);
            } else if g0 != 0.0 && (g0 < 0.0) != (g1 < 0.0) {
                let (mut lo, mut hi) = (r0, r1);
                for _ in 0..100 {
                    let mid = 0.5 * (lo + hi);
                    if (g(mid) < 0.0) == (g0 < 0.0) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                out.push(0.5 * (lo + hi));
            }
            (r0, g0) = (r1, g1);
        }
        out
    }
}

/// A model's forced mode, calibrated: the steady states and their amplitudes in the
/// observable. Built by [`ForcedResponse::calibrate`].
pub struct ForcedResponse<'m> {
    model: &'m SsmModel,
    tr: NormalFormTransform,
    modes: usize,
    opts: FrcOptions,
    /// The forced polar normal form.
    pub forced: ForcedMode,
    pub calibration: FrcCalibration,
    /// Largest amplitude of the model (observable units) and its `rho`.
    pub amplitude_max: f64,
    pub rho_max: f64,
}

impl<'m> ForcedResponse<'m> {
    /// The normal form of `model` (polynomial flow or map dynamics, observable
    /// normalization), its mode `opts.mode` forced with the amplitude that puts a stable
    /// steady state at `cal`.
    pub fn calibrate(model: &'m SsmModel, opts: &FrcOptions, cal: Calibration) -> Result<Self, FrcError> {
        let bad = |what, why: String| Err(FrcError::BadOption { what, why });
        if opts.observable >= model.observables {
            return Err(FrcError::Observable { index: opts.observable, count: model.observables });
        }
        if opts.phases < 8 {
            return bad("phases", format!("need >= 8, got {}", opts.phases));
        }
        let off = |why: String| Err(FrcError::OffCurve { freq_rad_s: cal.freq_rad_s, amplitude: cal.amplitude, why });
        if !(cal.freq_rad_s > 0.0 && cal.freq_rad_s.is_finite()) {
            return off("the forcing frequency must be a positive number of rad/s".into());
        }
        if !(cal.amplitude > 0.0 && cal.amplitude.is_finite()) {
            return off("the amplitude must be a positive number (a steady-state max |observable|)".into());
        }
        let (nf, tr) = model_normal_form_with_transform(model, &NormalFormOptions::default())?;
        if opts.mode >= nf.modes {
            return bad("mode", format!("mode {} of a normal form with {} mode(s)", opts.mode + 1, nf.modes));
        }
        let mut me = ForcedResponse {
            model,
            tr,
            modes: nf.modes,
            opts: *opts,
            forced: ForcedMode::of(&nf, opts.mode, 0.0),
            calibration: FrcCalibration {
                freq_rad_s: cal.freq_rad_s,
                amplitude: cal.amplitude,
                rho: 0.0,
                forcing: 0.0,
            },
            amplitude_max: 0.0,
            rho_max: 0.0,
        };
        let mode = opts.mode + 1;
        let (rho_max, source) = match opts.amplitude_max {
            Some(a) => {
                if !(a > 0.0 && a.is_finite()) {
                    return bad("amplitude_max", format!("must be a positive number, got {a}"));
                }
                let what = format!("amplitude {a} of observable {}", opts.observable);
                let r = first_rho_reaching(&mut |rho| me.amplitude(rho), a)
                    .map_err(|(reached, rho)| FrcError::Unreached { mode, what, reached, rho })?;
                (r, "the given largest amplitude")
            }
            None => {
                let range = &model.eta_range;
                let (tr, modes, m, phases) = (&me.tr, me.modes, opts.mode, opts.phases);
                let mut rel = |rho: f64| {
                    amplitude_at(
                        tr,
                        &mut |eta: &[f64]| eta.iter().zip(range).map(|(e, r)| (e / r).abs()).fold(0.0, f64::max),
                        modes,
                        m,
                        rho,
                        phases,
                    )
                };
                let r = first_rho_reaching(&mut rel, 1.0).map_err(|(reached, rho)| FrcError::Unreached {
                    mode,
                    what: "the edge of the training range of the reduced coordinates (max |eta_i| / eta_range_i = 1)"
                        .into(),
                    reached,
                    rho,
                })?;
                (r, "the edge of the training data's range")
            }
        };
        me.rho_max = rho_max;
        me.amplitude_max = me.amplitude(rho_max);
        if cal.amplitude > me.amplitude_max {
            return off(format!(
                "the amplitude is above the largest the model covers ({}, {source}); no forcing puts a steady state of the model there",
                me.amplitude_max
            ));
        }
        let rho = first_rho_reaching(&mut |r| me.amplitude(r), cal.amplitude)
            .map_err(|(reached, _)| FrcError::OffCurve {
                freq_rad_s: cal.freq_rad_s,
                amplitude: cal.amplitude,
                why: format!("the model's amplitude does not reach it (largest {reached})"),
            })?
            .min(rho_max);
        me.forced.forcing = me.forced.forcing_for(rho, cal.freq_rad_s);
        me.calibration.rho = rho;
        me.calibration.forcing = me.forced.forcing;
        if !(me.forced.forcing > 0.0 && me.forced.forcing.is_finite()) {
            return off(format!("the forcing it implies is not a positive number ({})", me.forced.forcing));
        }
        if !me.forced.is_stable(rho, cal.freq_rad_s) {
            let (t, d) = me.forced.trace_det(rho, cal.freq_rad_s);
            return off(format!(
                "it is an unstable steady state of the curve through it (Jacobian trace {t:.3e}, determinant {d:.3e}), which no measurement settles on"
            ));
        }
        Ok(me)
    }

    /// Amplitude of the observable at normal-form amplitude `rho` (see the module docs).
    pub fn amplitude(&self, rho: f64) -> f64 {
        let m = &self.model.manifold;
        let mut scratch = PolyScratch::default();
        let mut y = vec![0.0; m.p];
        let k = self.opts.observable;
        let mut observe = |eta: &[f64]| {
            m.lift_into(eta, &mut scratch, &mut y);
            y[k]
        };
        amplitude_at(&self.tr, &mut observe, self.modes, self.opts.mode, rho, self.opts.phases)
    }

    /// Every steady state at forcing frequency `omega` (> 0) within the model's range, by
    /// increasing amplitude.
    pub fn at(&self, omega: f64) -> Result<Vec<FrcPoint>, FrcError> {
        if !(omega > 0.0 && omega.is_finite()) {
            return Err(FrcError::BadOption {
                what: "forcing frequency",
                why: format!("must be a positive number of rad/s, got {omega}"),
            });
        }
        Ok(self
            .forced
            .amplitudes_at(omega, self.rho_max, 4000)
            .into_iter()
            .map(|rho| FrcPoint {
                freq_rad_s: omega,
                amplitude: self.amplitude(rho),
                rho,
                stable: self.forced.is_stable(rho, omega),
            })
            .collect())
    }

    /// The forced response curve for forcing frequencies in `[freq_min, freq_max]` rad/s
    /// (`0 < freq_min < freq_max`), all branches with their stability; consecutive points
    /// at most `1 / points` of the frequency range or of `rho_max` apart.
    pub fn curve(&self, freq_min: f64, freq_max: f64, points: usize) -> Result<Frc, FrcError> {
        let bad = |what, why: String| Err(FrcError::BadOption { what, why });
        if !(freq_min > 0.0 && freq_min.is_finite()) {
            return bad(
                "frequency range",
                format!("forcing frequencies must be > 0 rad/s, got a lower end of {freq_min}"),
            );
        }
        if !(freq_max > freq_min && freq_max.is_finite()) {
            return bad(
                "frequency range",
                format!("the upper end ({freq_max}) must be a number above the lower end ({freq_min})"),
            );
        }
        if points < 2 {
            return bad("points", format!("need >= 2, got {points}"));
        }
        if points > MAX_FRC_POINTS {
            return bad("points", format!("at most {MAX_FRC_POINTS}, got {points}"));
        }
        let chains = self.chains(freq_max);
        let mut samplers = Vec::new();
        for legs in chains {
            let c = Chain {
                fm: &self.forced,
                legs,
                lo: freq_min,
                hi: freq_max,
                tol: 1.0 / points as f64,
                rho_max: self.rho_max,
            };
            samplers.push(c.branches());
        }
        let branches = samplers
            .into_iter()
            .flatten()
            .map(|(stable, pts)| FrcBranch {
                stable,
                freq_rad_s: pts.iter().map(|p| p.omega).collect(),
                amplitude: pts.iter().map(|p| self.amplitude(p.rho)).collect(),
                rho: pts.iter().map(|p| p.rho).collect(),
            })
            .collect();
        Ok(Frc {
            mode: self.opts.mode + 1,
            observable: self.opts.observable,
            calibration: self.calibration,
            amplitude_max: self.amplitude_max,
            rho_max: self.rho_max,
            branches,
        })
    }

    /// The connected pieces of the curve in `rho`-space: intervals of `(0, rho_max]` where
    /// `f >= rho |A|`, each as legs `(sign, rho_from, rho_to)` traversed in order.
    fn chains(&self, freq_max: f64) -> Vec<Vec<(f64, f64, f64)>> {
        let fm = &self.forced;
        let f = fm.forcing;
        let h = |r: f64| f * f - (r * fm.rate_at(r).0).powi(2);
        let grid = 2000;
        let mut edges = Vec::new(); // sign changes of h in (0, rho_max)
        let mut r0 = 0.0;
        let mut h0 = h(0.0);
        for k in 1..=grid {
            let r1 = self.rho_max * k as f64 / grid as f64;
            let h1 = h(r1);
            if (h0 >= 0.0) != (h1 >= 0.0) {
                let (mut lo, mut hi) = (r0, r1);
                for _ in 0..100 {
                    let mid = 0.5 * (lo + hi);
                    if (h(mid) >= 0.0) == (h0 >= 0.0) {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                edges.push(if h0 >= 0.0 { lo } else { hi });
            }
            (r0, h0) = (r1, h1);
        }
        // Intervals: [0, e0], [e1, e2], ... ; the last may end at rho_max (open).
        let mut ends = vec![0.0];
        ends.extend(edges);
        if ends.len() % 2 == 1 {
            ends.push(self.rho_max);
        }
        // Near rho = 0 both branches are far outside any range: start where f / rho exceeds
        // four times the largest |frequency| involved.
        let (w0, a0) = (fm.freq_at(0.0).0.abs(), fm.rate_at(0.0).0.abs());
        let r_small = f / (4.0 * (w0 + freq_max + a0) + 1.0);
        let mut out = Vec::new();
        for pair in ends.chunks(2) {
            let (lo, hi) = (pair[0], pair[1]);
            let (lo_open, hi_open) = (lo == 0.0, hi >= self.rho_max);
            let lo = if lo_open { r_small.min(0.5 * hi) } else { lo };
            if hi <= lo {
                continue;
            }
            match (lo_open, hi_open) {
                (_, false) => out.push(vec![(-1.0, lo, hi), (1.0, hi, lo)]),
                (true, true) => {
                    out.push(vec![(-1.0, lo, hi)]);
                    out.push(vec![(1.0, hi, lo)]);
                }
                (false, true) => out.push(vec![(1.0, hi, lo), (-1.0, lo, hi)]),
            }
        }
        out
    }
}

/// One point of a chain.
#[derive(Clone, Copy, Debug)]
struct Sample {
    s: f64,
    rho: f64,
    omega: f64,
    stable: bool,
}

/// Connected legs of the curve, sampled adaptively, cut to `[lo, hi]` and split by stability.
struct Chain<'a> {
    fm: &'a ForcedMode,
    legs: Vec<(f64, f64, f64)>,
    lo: f64,
    hi: f64,
    tol: f64,
    rho_max: f64,
}

impl Chain<'_> {
    fn eval(&self, s: f64) -> Sample {
        let k = (s.floor() as usize).min(self.legs.len() - 1);
        let t = s - k as f64;
        let (sign, a, b) = self.legs[k];
        let rho = a + t * (b - a);
        let (ar, _) = self.fm.rate_at(rho);
        let (w, _) = self.fm.freq_at(rho);
        let g = ((self.fm.forcing / rho).powi(2) - ar * ar).max(0.0);
        let omega = w + sign * g.sqrt();
        Sample { s, rho, omega, stable: self.fm.is_stable(rho, omega) }
    }

    fn inside(&self, p: &Sample) -> bool {
        p.omega >= self.lo && p.omega <= self.hi
    }

    /// Bisection in `s` between `a` and `b` for the change of `key`.
    fn change(&self, a: Sample, b: Sample, key: &dyn Fn(&Sample) -> bool) -> (Sample, Sample) {
        let (mut a, mut b) = (a, b);
        let ka = key(&a);
        for _ in 0..60 {
            let m = self.eval(0.5 * (a.s + b.s));
            if key(&m) == ka {
                a = m;
            } else {
                b = m;
            }
        }
        (a, b)
    }

    /// The point where the curve crosses `bound` between `a` and `b` (exact frequency).
    fn crossing(&self, a: Sample, b: Sample, bound: f64) -> Sample {
        let below = |p: &Sample| p.omega < bound;
        let (x, y) = self.change(a, b, &below);
        let mut p = if (x.omega - bound).abs() <= (y.omega - bound).abs() { x } else { y };
        p.omega = p.omega.clamp(self.lo, self.hi);
        p
    }

    fn refine(&self, a: Sample, b: Sample, depth: u32, out: &mut Vec<Sample>) {
        let span = self.hi - self.lo;
        let relevant = self.inside(&a)
            || self.inside(&b)
            || (a.omega < self.lo) != (b.omega < self.lo)
            || (a.omega > self.hi) != (b.omega > self.hi);
        let far = ((a.omega - b.omega).abs() / span).max((a.rho - b.rho).abs() / self.rho_max) > self.tol;
        if depth < 40 && relevant && far {
            let m = self.eval(0.5 * (a.s + b.s));
            self.refine(a, m, depth + 1, out);
            self.refine(m, b, depth + 1, out);
        } else {
            out.push(b);
        }
    }

    /// `(stable, points)` pieces inside the range.
    fn branches(&self) -> Vec<(bool, Vec<Sample>)> {
        let n0 = 64;
        let total = self.legs.len() * n0;
        let mut pts = vec![self.eval(0.0)];
        for i in 1..=total {
            let b = self.eval(i as f64 / n0 as f64);
            let a = *pts.last().unwrap_or(&b);
            self.refine(a, b, 0, &mut pts);
        }
        let mut out: Vec<(bool, Vec<Sample>)> = Vec::new();
        let mut cur: Option<(bool, Vec<Sample>)> = None;
        let close = |cur: &mut Option<(bool, Vec<Sample>)>, out: &mut Vec<(bool, Vec<Sample>)>| {
            if let Some((st, v)) = cur.take() {
                if v.len() >= 2 {
                    out.push((st, v));
                }
            }
        };
        if self.inside(&pts[0]) {
            cur = Some((pts[0].stable, vec![pts[0]]));
        }
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            let (ia, ib) = (self.inside(&a), self.inside(&b));
            let mut start = a;
            if !ia && ib {
                let bound = if a.omega < self.lo { self.lo } else { self.hi };
                start = self.crossing(a, b, bound);
                cur = Some((start.stable, vec![start]));
            }
            if ib {
                // start and b inside: split at a stability change
                if start.stable != b.stable {
                    let (x, y) = self.change(start, b, &|p: &Sample| p.stable);
                    if let Some((_, v)) = cur.as_mut() {
                        v.push(x);
                    }
                    close(&mut cur, &mut out);
                    cur = Some((b.stable, vec![y]));
                }
                match cur.as_mut() {
                    Some((_, v)) => v.push(b),
                    None => cur = Some((b.stable, vec![b])),
                }
            } else if ia {
                let bound = if b.omega < self.lo { self.lo } else { self.hi };
                let p = self.crossing(a, b, bound);
                if let Some((st, v)) = cur.as_mut() {
                    v.push(Sample { stable: *st, ..p });
                }
                close(&mut cur, &mut out);
            }
        }
        close(&mut cur, &mut out);
        out
    }
}

/// Forced response curve of `model`'s mode `opts.mode` calibrated at `cal`, over
/// `[freq_min, freq_max]` rad/s (see [`ForcedResponse`]).
pub fn frc(
    model: &SsmModel,
    opts: &FrcOptions,
    cal: Calibration,
    freq_min: f64,
    freq_max: f64,
    points: usize,
) -> Result<Frc, FrcError> {
    ForcedResponse::calibrate(model, opts, cal)?.curve(freq_min, freq_max, points)
}
