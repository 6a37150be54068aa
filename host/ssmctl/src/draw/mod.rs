//! Figures of computed results: stability charts, phase portraits and backbone curves.

pub mod backbone;
pub mod chart;
pub mod portrait;
