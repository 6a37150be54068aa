//! The integration tests of the `ssmctl` command, one module per concern, linked into one test
//! binary: every test binary links the whole workspace, so one binary instead of ten saves
//! most of that work. Run one module with a filter, e.g.
//! `cargo test -p ssmctl --test commands cli::`.

mod bad_input;
mod cli;
mod equations;
mod exit_codes;
mod fuzz_boundaries;
mod outputs;
mod pil_children;
mod readers;
mod study;
mod sweep;
