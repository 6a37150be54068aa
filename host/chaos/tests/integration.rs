//! The integration tests of `chaos`, one module per file, linked into one test binary:
//! each test binary links the crate and its dependencies, so one binary instead of two
//! saves most of that work. Run one module with a filter, e.g.
//! `cargo test -p chaos --test integration real_data::`.

mod known_answers;
mod real_data;
