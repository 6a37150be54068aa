//! The paper's study, where the simulator, the SSM learner and the chaos estimators meet:
//! the parametric Furuta model (normal forms and shared-tangent maps interpolated in the
//! sampling period), full-system checks of its bifurcations, and the chaotic-statistics study
//! of data against reduced models. Library only: returns data, draws nothing.

pub mod bifurcations;
pub mod chaos_tables;
pub mod device_model;
pub mod error;
pub mod full_system;
pub mod lyapunov;
pub mod microchaos;
pub mod parametric;
pub mod shared_tangent;

pub use error::Error;
