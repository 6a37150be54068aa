//! Plants: continuous-time mechanical systems driven by a held input `u` (volts).
//!
//! Owns the equations of motion and their parameter validation. Must not know about
//! sampling, quantization or the controller: the simulator composes those.

pub mod scalar;

pub use scalar::{Dual, Scalar};

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
}
