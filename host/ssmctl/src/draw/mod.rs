//! Figures of computed results: stability charts, phase portraits, backbone curves and
//! forced response curves.

pub mod backbone;
pub mod chart;
pub mod frc;
pub mod portrait;
