//! Host side of the workspace: plants, the closed-loop simulator that runs the device's own
//! controller, exact linear stability, SSM fitting and model export, and the `ssmctl` CLI.

pub mod chart;
pub mod linear;
pub mod ode;
pub mod plant;
pub mod scene;
pub mod ssm;
