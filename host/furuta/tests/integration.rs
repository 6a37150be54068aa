//! The tests of `furuta`, one module per file, linked into one test binary: the integration
//! tests (`auto_furuta`, `duffing_data_vs_equations`) and, one module per source module, the
//! tests of the library's modules through its public API (`[lib] test = false`: the library is
//! compiled once, not again with `--test`). Run one module with a filter, e.g.
//! `cargo test -p furuta --test integration map_global::`. The fixtures shared across modules
//! (`parametric::test_runs`, `shared_tangent::test_model`) are computed once per process.

mod auto_furuta;
mod basin;
mod bifurcations;
mod convergence;
mod device_model;
mod duffing_data_vs_equations;
mod equation_map;
mod equation_ssm;
mod full_system;
mod map_global;
mod parametric;
mod saddle_cycles;
mod shared_tangent;
mod sweep;
