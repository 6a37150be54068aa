//! The simulator layer's error: one enum over the module errors, each of which names the
//! scene, key path, time or matrix that is wrong. Every fallible public function of this
//! crate returns one of the variants' payloads, so `?` lifts it into [`Error`].

use crate::chart::ChartError;
use crate::closed_loop::SimError;
use crate::linear::LinearError;
use crate::ode::OdeError;
use crate::plant::PlantError;
use crate::scene::SceneError;
use crate::stability::StabilityError;
use crate::taylor::TaylorError;

/// Anything the simulator layer refuses or fails at.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Simulation(#[from] SimError),
    #[error(transparent)]
    Integrator(#[from] OdeError),
    #[error(transparent)]
    Plant(#[from] PlantError),
    #[error(transparent)]
    Linear(#[from] LinearError),
    #[error(transparent)]
    Chart(#[from] ChartError),
    #[error(transparent)]
    Stability(#[from] StabilityError),
    #[error(transparent)]
    Taylor(#[from] TaylorError),
}
