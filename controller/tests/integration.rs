//! The integration tests of `controller`, one module per file, linked into one test binary:
//! each test binary links the crate and its dependencies, so one binary instead of four
//! saves most of that work. Run one module with a filter, e.g.
//! `cargo test -p controller --test integration int_path::`.

mod common;
mod config_errors;
mod float_path;
mod int_path;
mod literal_and_law;
