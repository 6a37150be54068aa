//! The integration tests of the `ssmctl` command, one module per concern, and the library's unit
//! tests, one module per source module (`draw`, `fit_command`, `pil`, `plot`, `report`), linked
//! into one test binary: every test binary links the whole workspace, so one binary instead of
//! ten saves most of that work, and the library is not compiled a second time with `--test`.
//! Run one module with a filter, e.g. `cargo test -p ssmctl --test commands cli::` or
//! `report::chaos::`.

mod bad_input;
mod cli;
mod draw;
mod equations;
mod exit_codes;
mod fit_command;
mod fuzz_boundaries;
mod outputs;
mod pil;
mod pil_children;
mod plot;
mod readers;
mod report;
mod study;
mod sweep;
