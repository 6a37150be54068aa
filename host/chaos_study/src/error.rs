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

macro_rules! lift {
    ($($t:ty => $via:ty),* $(,)?) => {$(
        impl From<$t> for Error {
            fn from(e: $t) -> Self {
                <$via>::from(e).into()
            }
        }
    )*};
}

lift!(
    sim::scene::SceneError => sim::Error,
    sim::closed_loop::SimError => sim::Error,
    sim::stability::StabilityError => sim::Error,
    sim::linear::LinearError => sim::Error,
    ssm::FitError => ssm::Error,
    ssm::DataError => ssm::Error,
    ssm::portrait::PortraitError => ssm::Error,
    ssm::interp::InterpError => ssm::Error,
    ssm::spectrum::SpectrumError => ssm::Error,
    ssm::device::ExportError => ssm::Error,
);
