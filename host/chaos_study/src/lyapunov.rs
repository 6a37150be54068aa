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

#[cfg(test)]
mod tests {
    use super::*;
    use ssm::tangent::rbf_jacobian;

    use ssm::fixtures::random_rbf;

    /// A Benettin run through [`dynamics_lyapunov`] (the fused step and Jacobian of
    /// `ssm::tangent::Tangent`) against `benettin_qr` with the RBF map's step and
    /// Jacobian apart, in dimensions 2..=6: the same spectrum bit for bit.
    #[test]
    fn fused_benettin_equals_the_separate_step_and_jacobian() {
        let mut rng = ssm::testing::XorShift64::new(0x9e37_79b9_7f4a_7c15);
        let mut rnd = move || rng.centered();
        for d in 2..=6 {
            let m = random_rbf(d, 100, true, &mut rnd);
            let dynamics = ReducedDynamics::Rbf(m.clone());
            let eta0: Vec<f64> = (0..d).map(|_| 0.2 * rnd()).collect();
            let fused = dynamics_lyapunov(&dynamics, &eta0, 1e3, 100, 2000).unwrap();
            let p = BenettinParams {
                transient: 100,
                steps: 2000,
                time_step: 0.03,
                renorm_every: 1,
                bound: 1e3,
                blocks: 20,
            };
            let mut feat = Vec::new();
            let apart = benettin_qr(
                &eta0,
                |x, out| {
                    out.copy_from_slice(x);
                    m.step(out, &mut feat);
                },
                |x, j| rbf_jacobian(&m, x, j),
                d,
                &p,
            )
            .unwrap();
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&fused.spectrum), bits(&apart.exponents), "d {d}");
            assert_eq!(fused.std_error.to_bits(), apart.std_error[0].to_bits());
            assert_eq!(fused.kaplan_yorke.map(f64::to_bits), chaos::kaplan_yorke(&apart.exponents).map(f64::to_bits));
        }
    }
}
