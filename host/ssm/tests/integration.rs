//! The integration tests of `ssm`, one module per file, linked into one test binary:
//! each test binary links the crate and its dependencies, so one binary instead of seven
//! saves most of that work. Run one module with a filter, e.g.
//! `cargo test -p ssm --test integration auto_intervals::`.

mod auto_intervals;
mod auto_select;
mod backbone_known;
mod damping_known;
mod frc_duffing;
mod fuzz_inputs;
mod mat_files;
