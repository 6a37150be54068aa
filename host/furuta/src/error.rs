//! The study's error: one enum for the whole crate. Failures of the layers below (scenes and
//! simulations, fits, estimators) pass through with their own messages; the study's own
//! variants name the option, input or sampling period that is wrong.

use chaos::ChaosError;

/// Anything the study refuses or fails at.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Sim(#[from] sim::Error),
    #[error(transparent)]
    Ssm(#[from] ssm::Error),
    #[error(transparent)]
    Chaos(#[from] ChaosError),
    #[error("dt = {dt} ms: {source}")]
    NormalForm { dt: f64, source: ssm::normal_form::NormalFormError },
    #[error("invalid option {what}: {why}")]
    BadOption { what: &'static str, why: String },
    #[error("invalid input {what}: {why}")]
    BadInput { what: &'static str, why: String },
    #[error("dt = {dt} ms outside the training range [{lo}, {hi}] ms (no extrapolation)")]
    OutOfRange { dt: f64, lo: f64, hi: f64 },
    #[error("dt = {dt_ms} ms: simulation from {ic:?} stopped early: {why}")]
    Escaped { dt_ms: f64, ic: [f64; 4], why: String },
    #[error("dt = {dt_ms} ms: the run escaped ({why}); a torus needs a bounded run")]
    TorusEscaped { dt_ms: f64, why: String },
    /// A value of the scene that the computation cannot use, under its key.
    #[error("scene {scene}: `{key}`: {why}")]
    SceneKey { scene: String, key: &'static str, why: String },
    #[error("dt = {dt_ms} ms: expected two oscillatory multiplier pairs, got {got}")]
    Multipliers { dt_ms: f64, got: usize },
    #[error("Benettin's method here needs a discrete map; these reduced dynamics are a continuous flow")]
    NotAMap,
    /// A sweep spec, shard or merge problem; the message names the spec key, file or cell.
    #[error("{0}")]
    Sweep(String),
    #[error("initial state has {got} coordinates, the reduced dynamics have {expected}")]
    Shape { expected: usize, got: usize },
}

// `?` on a module error of a lower layer: lift it through that layer's enum.
sim::lift_sim_errors!(Error);
ssm::lift_ssm_errors!(Error);
