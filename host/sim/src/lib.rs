//! The simulator: plants, period-by-period ODE integrators, scenes, the closed loop that runs
//! the device's own controller code, exact linear stability of the sampled-data loop (ZOH
//! multipliers) and stability charts (computation only).
//!
//! Knows no SSM and draws nothing. Time is in seconds everywhere inside; the scene file's
//! `controller.dt_ms` is the one millisecond field, read through [`scene::Scene::dt`].

pub mod chart;
pub mod closed_loop;
pub mod linear;
pub mod ode;
pub mod plant;
pub mod scene;
pub mod stability;
