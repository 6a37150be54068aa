//! The integration tests of `sim`, one module per file, linked into one test binary:
//! each test binary links the crate and its dependencies, so one binary instead of four
//! saves most of that work. Run one module with a filter, e.g.
//! `cargo test -p sim --test integration exprb_lean::`.

mod common;
mod equations_fast;
mod exprb_filtered;
mod exprb_lean;
mod exprb_split;
mod fuzz_scene;
