//! Data-driven spectral submanifold (SSM) models from scalar time series: the SSMLearn
//! algorithm (paper appendix A) in our own code.
//!
//! Pipeline: [`data`] (CSV loading, validation) -> [`embed`] (delay embedding) ->
//! [`manifold`] (tangent space by SVD, constrained graph-style polynomial parametrization)
//! -> [`dynamics`] (polynomial flow / polynomial map / linear-kernel RBF map) -> [`fit`]
//! (options, fitted model, prediction with blow-up detection); [`metrics`] holds NMTE,
//! DTW-aligned NMTE and FFT amplitude spectra. Linear least squares go through [`ridge`].
//!
//! This module owns only host-side numerics: it never touches plants, the controller or
//! the embedded model format.

pub mod data;
pub mod dynamics;
pub mod embed;
pub mod error;
pub mod fit;
pub mod furuta;
pub mod furuta_predict;
pub mod manifold;
pub mod metrics;
pub mod normal_form;
pub mod poly;
pub mod portrait;
pub mod ridge;

pub use data::{DataError, TimeSeries, load_csv, load_csv_column};
pub use dynamics::{Dynamics, ReducedDynamics};
pub use error::FitError;
pub use fit::{FitOptions, Prediction, SsmModel, Stop, StopReason, fit};
pub use ridge::{Conditioning, Ridge};

#[cfg(test)]
mod tests;
