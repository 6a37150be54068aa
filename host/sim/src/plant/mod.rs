//! Plants: continuous-time mechanical systems driven by a held input `u` (volts).
//!
//! Owns the equations of motion and their parameter validation. Must not know about
//! sampling, quantization or the controller: the simulator composes those.

pub mod cart;
pub mod equations;
pub mod furuta;
pub mod linearize;
/// Re-exported from the crate root, where the expression tape also uses it.
pub use crate::scalar;

pub use cart::{Cart, CartParams};
pub use equations::{EquationsModel, EquationsPlant, EquationsSpec};
pub use furuta::{Furuta, FurutaParams};
pub use linearize::{jacobian, linearize};
pub use scalar::{Dual, Scalar};

/// A physical parameter set that cannot describe a real plant.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlantError {
    #[error("parameter `{field}` must be finite, got {value}")]
    NotFinite { field: &'static str, value: f64 },
    #[error("parameter `{field}` must be positive, got {value}")]
    NotPositive { field: &'static str, value: f64 },
    #[error("parameter `{field}` must be non-negative, got {value}")]
    Negative { field: &'static str, value: f64 },
    #[error(
        "the mass matrix is singular somewhere in the range of theta: \
         its minimal determinant {delta_min:e} ({formula}) is not positive"
    )]
    SingularMassMatrix { delta_min: f64, formula: &'static str },
    #[error(
        "the mass matrix is nearly singular: its minimal determinant {delta_min:e} ({formula}) \
         is below {threshold:e} (1e-9 of the product of its diagonal terms)"
    )]
    NearSingularMassMatrix { delta_min: f64, threshold: f64, formula: &'static str },
}

/// What a parameter must satisfy besides being finite.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Sign {
    Positive,
    NonNegative,
}

/// Checks each `(name, value, sign)` in order; the first violation is returned.
pub(crate) fn check_fields(fields: &[(&'static str, f64, Sign)]) -> Result<(), PlantError> {
    for &(field, value, sign) in fields {
        if !value.is_finite() {
            return Err(PlantError::NotFinite { field, value });
        }
        match sign {
            Sign::Positive if value <= 0.0 => return Err(PlantError::NotPositive { field, value }),
            Sign::NonNegative if value < 0.0 => return Err(PlantError::Negative { field, value }),
            _ => {}
        }
    }
    Ok(())
}

/// Rejects a mass-matrix determinant minimum that is not positive, or below `1e-9 * reference`.
pub(crate) fn check_delta(delta_min: f64, reference: f64, formula: &'static str) -> Result<(), PlantError> {
    if !(delta_min > 0.0) {
        return Err(PlantError::SingularMassMatrix { delta_min, formula });
    }
    let threshold = 1e-9 * reference;
    if delta_min < threshold {
        return Err(PlantError::NearSingularMassMatrix { delta_min, threshold, formula });
    }
    Ok(())
}

/// A mechanical plant with `N` first-order states, driven by one scalar input held constant
/// over each sampling period.
///
/// The right-hand side is generic over [`Scalar`] so the integrator and the linear
/// stability analysis get exact Jacobians from dual numbers instead of finite differences.
pub trait Plant<const N: usize> {
    /// Index of the primary (stabilized) angle in the state, read by the controller as `theta`.
    const PRIMARY: usize;
    /// Index of the secondary measured angle (arm angle, cart position), read as `phi`.
    const SECONDARY: usize;
    /// Short name, e.g. `"furuta"`.
    fn name(&self) -> &'static str;
    /// Names of the state components, used as CSV column names.
    fn state_names(&self) -> [&'static str; N];
    /// `dx/dt` at state `x` under held input `u`.
    fn rhs<S: Scalar>(&self, x: &[S; N], u: S) -> [S; N];
    /// Total mechanical energy (kinetic plus potential), J.
    fn energy(&self, x: &[f64; N]) -> f64;
    /// The exact `f(x, u)` and `df/dx` at `(x, u)` that [`jacobian`] returns (the
    /// integrators' and the linearization's): by default one dual-number evaluation
    /// ([`linearize::dual_jacobian`]); a plant written as equations evaluates its compiled
    /// symbolic derivatives instead, equal to rounding.
    #[inline]
    fn exact_jacobian(&self, x: &[f64; N], u: f64) -> ([f64; N], [[f64; N]; N])
    where
        Self: Sized,
    {
        linearize::dual_jacobian(self, x, u)
    }
    /// `f(x, u)` and `df/dx` at `(x, u)` (`jac[i][j] = d f_i / d x_j`). The default is
    /// [`jacobian`]; a plant may override it with a closed form
    /// (the Furuta plant does, for `exprb-lean`), which must agree with it to rounding.
    #[inline]
    fn rhs_and_jacobian(&self, x: &[f64; N], u: f64) -> ([f64; N], [[f64; N]; N])
    where
        Self: Sized,
    {
        jacobian(self, x, u)
    }
}
