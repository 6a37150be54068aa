//! The simulator: plants, period-by-period ODE integrators, scenes, the closed loop that runs
//! the device's own controller code, exact linear stability of the sampled-data loop (ZOH
//! multipliers) and stability charts (computation only).
//!
//! Architecture invariant: knows no SSM (does not depend on `ssm`), draws nothing, and runs
//! control arithmetic only through the `controller` crate. Units: see [`units`].

pub mod chart;
pub mod closed_loop;
pub mod error;
pub mod linear;
pub mod ode;
pub mod plant;
pub mod scene;
pub mod stability;
pub mod taylor;
pub mod units;

pub use error::Error;
