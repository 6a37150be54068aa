//! The chaotic-data study's error: the layers below lifted with their messages, and the
//! study's own bad options and inputs, each naming what is wrong.

use chaos::ChaosError;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Sim(#[from] sim::Error),
    #[error(transparent)]
    Ssm(#[from] ssm::Error),
    #[error(transparent)]
    Chaos(#[from] ChaosError),
    #[error("invalid option {what}: {why}")]
    BadOption { what: &'static str, why: String },
    #[error("invalid input {what}: {why}")]
    BadInput { what: &'static str, why: String },
    #[error("Benettin's method here needs a discrete map; these reduced dynamics are a continuous flow")]
    NotAMap,
    #[error("initial state has {got} coordinates, the reduced dynamics have {expected}")]
    Shape { expected: usize, got: usize },
}

sim::lift_sim_errors!(Error);
ssm::lift_ssm_errors!(Error);
