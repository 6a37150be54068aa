//! Host side of the workspace: plants, the closed-loop simulator that runs the device's own
//! controller, exact linear stability, SSM fitting and model export, and the `ssmctl` CLI.

pub mod bench;
pub mod bifreport;
pub mod chaoscmd;
pub mod chaostable;
pub mod chart;
pub mod cli;
pub mod export;
pub mod fitcmd;
pub mod fitreport;
pub mod furcheck;
pub mod linear;
pub mod nfreport;
pub mod ode;
pub mod pil;
pub mod plant;
pub mod plot;
pub mod report;
pub mod reproduce;
pub mod scene;
pub mod sim;
pub mod ssm;
pub mod stability;
