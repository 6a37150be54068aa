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

/// `sim`'s module errors lifted into a higher layer's error.
/// Implements `From<E>` for `$target` for every module error `E` of this layer, through this
/// layer's [`Error`]: for a crate above whose error wraps it, since `?` does not chain two
/// `From` steps. The list lives here, beside the enum, so a new module error is lifted everywhere.
#[macro_export]
macro_rules! lift_sim_errors {
    ($target:ty) => {
        impl ::core::convert::From<$crate::scene::SceneError> for $target {
            fn from(e: $crate::scene::SceneError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::closed_loop::SimError> for $target {
            fn from(e: $crate::closed_loop::SimError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::ode::OdeError> for $target {
            fn from(e: $crate::ode::OdeError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::plant::PlantError> for $target {
            fn from(e: $crate::plant::PlantError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::linear::LinearError> for $target {
            fn from(e: $crate::linear::LinearError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::chart::ChartError> for $target {
            fn from(e: $crate::chart::ChartError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::stability::StabilityError> for $target {
            fn from(e: $crate::stability::StabilityError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::taylor::TaylorError> for $target {
            fn from(e: $crate::taylor::TaylorError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
    };
}
