//! The tests of `sim`, one module per file, linked into one test binary: the integration
//! tests (`exprb_filtered`, `exprb_lean`, `exprb_split`, `fuzz_scene`) and, one module per
//! source module, the tests of the library's modules through its public API (`[lib] test =
//! false`: the library is compiled once, not again with `--test`). Each test binary links the
//! crate and its dependencies, so one binary instead of several saves most of that work. Run
//! one module with a filter, e.g. `cargo test -p sim --test integration exprb_lean::` or
//! `cargo test -p sim --test integration taylor::`.

mod chart;
mod closed_loop;
mod common;
mod equations_fast;
mod expr;
mod exprb_filtered;
mod exprb_lean;
mod exprb_split;
mod fuzz_scene;
mod linear;
mod ode;
mod plant;
mod scalar;
mod scene;
mod stability;
mod taylor;
mod units;
