//! The tests of `chaos_study`, linked into one test binary: one module per source module, the
//! tests of the library's modules through its public API (`[lib] test = false`: the library is
//! compiled once, not again with `--test`). Run one module with a filter, e.g.
//! `cargo test -p chaos_study --test integration verdict::`.

mod calibration;
mod chaos_tables;
mod estimator_check;
mod flag_pipeline;
mod flag_pipeline_fit;
mod flag_self;
mod flag_study;
mod known_system_study;
mod lyapunov;
mod microchaos;
mod model_selection;
mod selection_study;
mod study_results;
mod verdict;
