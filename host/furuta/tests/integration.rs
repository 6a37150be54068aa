//! The integration tests of `furuta`, one module per file, linked into one test binary:
//! each test binary links the crate and its dependencies, so one binary instead of two
//! saves most of that work. Run one module with a filter, e.g.
//! `cargo test -p furuta --test integration auto_furuta::`.

mod auto_furuta;
mod duffing_data_vs_equations;
