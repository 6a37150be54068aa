//! The integration tests of `shared`, one module per file, linked into one test binary:
//! each test binary links the crate and its dependencies, so one binary instead of three
//! saves most of that work. Run one module with a filter, e.g.
//! `cargo test -p shared --test integration frame::`.

mod common;
mod frame;
mod model_format;
mod model_robustness;
