//! The pendulum study, where the simulator and the SSM learner meet: the parametric Furuta
//! model (normal forms and shared-tangent maps interpolated in the sampling period), the
//! equation-driven SSM of the period map, full-system checks of the local and global
//! bifurcations, basins and the sweep machinery. The chaotic-data study is `chaos_study`.
//! Library only: returns data, draws nothing.
// Library code returns errors: no unwrap/expect/panic (CI runs clippy); the tests are in
// `tests/`, so the library is never built with `cfg(test)`.
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

pub mod auto_sets;
pub mod basin;
pub mod bifurcations;
pub mod convergence;
pub mod device_model;
pub mod equation_map;
pub mod equation_ssm;
pub mod error;
pub mod full_system;
pub mod map_global;
pub mod parametric;
pub mod saddle_cycles;
pub mod shared_tangent;
pub mod sweep;

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
