//! The chaotic-data study, where the simulator, the SSM learner and the chaos estimators meet:
//! reduced models of chaotic data (the inverted flag's measurements, the quantized Furuta's
//! microchaos, processor-in-the-loop recordings) chosen by held-out statistics, the reduced
//! maps' Lyapunov spectra and dimensions, the verdicts, and the flag study as a spec
//! (`flag_study`, run by `ssmctl study`). Library only: returns data, draws nothing.
// Library code returns errors: no unwrap/expect/panic (CI runs clippy); the tests are in
// `tests/`, so the library is never built with `cfg(test)`.
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

pub mod calibration;
pub mod chaos_tables;
pub mod error;
pub mod estimator_check;
pub mod flag_pipeline;
pub mod flag_pipeline_fit;
pub mod flag_self;
pub mod flag_study;
pub mod known_system_study;
pub mod lyapunov;
pub mod microchaos;
pub mod model_selection;
pub mod selection_study;
pub mod study_results;
pub mod verdict;

pub use error::Error;

/// `f` over `items` on the rayon pool, collected in input order (the serial loop's values
/// whatever the pool size), and the first error in input order.
pub(crate) fn par_map<T: Sync, U: Send, E: Send>(
    items: &[T],
    f: impl Fn(&T) -> Result<U, E> + Sync + Send,
) -> Result<Vec<U>, E> {
    use rayon::prelude::*;
    let out: Vec<Result<U, E>> = items.par_iter().map(f).collect();
    out.into_iter().collect()
}
