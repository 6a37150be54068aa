//! Lyapunov exponents of fitted reduced maps themselves (paper section 3.2): Benettin's
//! method (`chaos::benettin_qr`, QR re-orthonormalization every step) with the maps' analytic
//! tangent maps (`ssm::tangent::Tangent`) on the model's own attractor after a transient, so
//! the smooth model's exponent is measured directly, not through a time-series estimator;
//! the spectrum gives the Kaplan-Yorke dimension (`chaos::kaplan_yorke`).
//! [`iterate_dynamics`]: a long bounded iteration of a reduced map that reports escape.
//!
//! The scale and accuracy-vs-cost studies that use these are in [`crate::chaos_tables`].

use crate::Error;
use chaos::{BenettinParams, Orbit, benettin_qr, iterate_map};
use serde::Serialize;

use ssm::SsmModel;
use ssm::dynamics::ReducedDynamics;
use ssm::fit::BLOWUP_FACTOR;
use ssm::tangent::Tangent;

/// Benettin result of a reduced map, in 1/s.
#[derive(Clone, Debug, Serialize)]
pub struct ModelLyapunov {
    /// Largest exponent, 1/s.
    pub exponent: f64,
    /// Its block standard error, 1/s.
    pub std_error: f64,
    /// All `d` exponents, 1/s, largest first.
    pub spectrum: Vec<f64>,
    pub kaplan_yorke: Option<f64>,
    pub transient: usize,
    pub steps: usize,
    /// Map step, s.
    pub dt: f64,
}

/// Benettin's method with the analytic tangent map and QR re-orthonormalization every step,
/// from `eta0` after `transient` steps, over `steps` steps (20 blocks). Escape (any
/// `|eta_i| > bound` or a non-finite state) and a hit on an RBF centre are errors with the
/// step number.
pub fn dynamics_lyapunov(
    dynamics: &ReducedDynamics,
    eta0: &[f64],
    bound: f64,
    transient: usize,
    steps: usize,
) -> Result<ModelLyapunov, Error> {
    let tangent = Tangent::new(dynamics).ok_or(Error::NotAMap)?;
    let (d, dt) = (tangent.dim(), tangent.dt());
    if eta0.len() != d {
        return Err(Error::Shape { expected: d, got: eta0.len() });
    }
    let p = BenettinParams { transient, steps, time_step: dt, renorm_every: 1, bound, blocks: 20 };
    let r = benettin_qr(eta0, |x, out| tangent.step(x, out), |x, j| tangent.jacobian(x, j), d, &p)?;
    Ok(ModelLyapunov {
        exponent: r.exponents[0],
        std_error: r.std_error[0],
        kaplan_yorke: r.kaplan_yorke,
        spectrum: r.exponents,
        transient,
        steps: r.steps,
        dt,
    })
}

/// [`dynamics_lyapunov`] for a fitted model, bounded by [`BLOWUP_FACTOR`] x the largest
/// training range of the reduced coordinates (the prediction's blow-up rule).
pub fn model_lyapunov(model: &SsmModel, eta0: &[f64], transient: usize, steps: usize) -> Result<ModelLyapunov, Error> {
    dynamics_lyapunov(&model.dynamics, eta0, model_bound(model), transient, steps)
}

/// The escape bound used for a model: [`BLOWUP_FACTOR`] x max training |eta_i|.
pub fn model_bound(model: &SsmModel) -> f64 {
    BLOWUP_FACTOR * model.eta_range.iter().fold(0.0_f64, |m, v| m.max(*v))
}

/// Iterates a discrete reduced map `steps` times from `eta0` (recording every
/// `record_every`-th state, 0 = none); escape beyond `bound` is an error with the step.
pub fn iterate_dynamics(
    dynamics: &ReducedDynamics,
    eta0: &[f64],
    steps: usize,
    bound: f64,
    record_every: usize,
) -> Result<Orbit, Error> {
    let dt = dynamics.map_dt().ok_or(Error::NotAMap)?;
    let d = ssm::tangent::dynamics_dim(dynamics);
    if eta0.len() != d {
        return Err(Error::Shape { expected: d, got: eta0.len() });
    }
    let mut scratch = ssm::dynamics::StepScratch::default();
    let map = dynamics.prepare();
    Ok(iterate_map(
        eta0,
        |x, out| {
            out.copy_from_slice(x);
            map.step(out, dt, &mut scratch);
        },
        steps,
        bound,
        record_every,
    )?)
}
