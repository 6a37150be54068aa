//! [`FitError`]: what can go wrong while fitting or evaluating a model. The crate's one
//! enum over every module error is [`crate::Error`].

use thiserror::Error;

use super::data::DataError;

/// Everything that can go wrong while fitting or evaluating an SSM model.
#[derive(Debug, Error)]
pub enum FitError {
    #[error(transparent)]
    Data(#[from] DataError),
    #[error("invalid option {what}: {why}")]
    BadOption { what: &'static str, why: String },
    #[error("{what}: {value} exceeds the limit of {limit} (ssm::limits)")]
    TooLarge { what: &'static str, value: String, limit: String },
    #[error("no training trajectories given")]
    NoTrainingData,
    #[error(
        "{what}: least-squares problem is underdetermined ({rows} rows < {cols} unknowns); use more data or lower orders"
    )]
    Underdetermined { what: &'static str, rows: usize, cols: usize },
    #[error("{what}: design matrix or data contains non-finite values")]
    NonFinite { what: &'static str },
    #[error(
        "{what}: the singular value decomposition did not converge (the data are degenerate or too badly scaled for \
         double precision)"
    )]
    Svd { what: &'static str },
    #[error("eigenvalue decomposition of the {what} did not converge")]
    Eigen { what: &'static str },
    #[error(
        "{name}: sampling step {dt} differs from the model's step {dt_model} (relative tolerance {rtol}); discrete-time models need the same step"
    )]
    StepMismatch { name: String, dt: f64, dt_model: f64, rtol: f64 },
    #[error("{name}: embedded dimension {got} does not match the model's {expected}")]
    DimMismatch { name: String, got: usize, expected: usize },
    #[error("{name}: {got} observables, the model was fitted to {expected}")]
    Observables { name: String, got: usize, expected: usize },
}
