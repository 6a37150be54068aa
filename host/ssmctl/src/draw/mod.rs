//! Figures of computed results: stability charts, phase portraits, backbone curves and
//! forced response curves, basin maps of sweeps.

pub mod backbone;
pub mod basin;
pub mod chart;
pub mod frc;
pub mod portrait;
