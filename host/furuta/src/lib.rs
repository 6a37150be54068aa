//! The paper's study, where the simulator, the SSM learner and the chaos estimators meet:
//! the parametric Furuta model (normal forms and shared-tangent maps interpolated in the
//! sampling period), full-system checks of its bifurcations, and the chaotic-statistics study
//! of data against reduced models. Library only: returns data, draws nothing.
// Library code returns errors: no unwrap/expect/panic outside tests (CI runs clippy).
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod auto_sets;
pub mod basin;
pub mod bifurcations;
pub mod calibration;
pub mod chaos_tables;
pub mod convergence;
pub mod device_model;
pub mod equation_map;
pub mod equation_ssm;
pub mod error;
pub mod estimator_check;
pub mod flag_pipeline;
pub mod flag_pipeline_fit;
pub mod flag_self;
pub mod flag_study;
pub mod full_system;
pub mod lyapunov;
pub mod map_global;
pub mod microchaos;
pub mod model_selection;
pub mod parametric;
pub mod saddle_cycles;
pub mod shared_tangent;
pub mod study_results;
pub mod sweep;
pub mod verdict;

pub use error::Error;

/// `f` over `items` on the rayon pool, collected in input order: the values are the serial
/// loop's, whatever the pool size (each task depends only on its item), and the error is the
/// first in input order, as the serial loop's would be.
pub(crate) fn par_map<T: Sync, U: Send, E: Send>(
    items: &[T],
    f: impl Fn(&T) -> Result<U, E> + Sync + Send,
) -> Result<Vec<U>, E> {
    use rayon::prelude::*;
    let out: Vec<Result<U, E>> = items.par_iter().map(f).collect();
    out.into_iter().collect()
}
