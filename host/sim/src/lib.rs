//! The simulator: plants, period-by-period ODE integrators, scenes, the closed loop that runs
//! the device's own controller code, exact linear stability of the sampled-data loop (ZOH
//! multipliers) and stability charts (computation only).
//!
//! Architecture invariant: knows no SSM (does not depend on `ssm`), draws nothing, and runs
//! control arithmetic only through the `controller` crate. Units: see [`units`].
// Library code returns errors: no unwrap/expect/panic outside tests (CI runs clippy).
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod chart;
pub mod closed_loop;
pub mod error;
pub mod expr;
pub mod linear;
pub mod ode;
pub mod plant;
pub mod scalar;
pub mod scene;
pub mod stability;
pub mod taylor;
pub mod units;

pub use error::Error;
