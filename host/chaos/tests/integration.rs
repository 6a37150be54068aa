//! The tests of `chaos`, one module per file, linked into one test binary: the integration
//! tests (`known_answers`, `real_data`) and, one module per source module, the tests of the
//! library's modules (`[lib] test = false`: the library is compiled once, not again with
//! `--test`). Run one module with a filter, e.g. `cargo test -p chaos --test integration
//! real_data::`.

mod corrdim;
mod density;
mod embed;
mod fsle;
mod held_out;
mod known_answers;
mod lyapunov;
mod real_data;
mod surrogate;
mod zero_one;
