//! Figures of computed results: stability charts and phase portraits.

pub mod chart;
pub mod portrait;
