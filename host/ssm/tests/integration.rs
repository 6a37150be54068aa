//! The tests of `ssm`, one module per file, linked into one test binary: the integration
//! tests (`auto_intervals`, `auto_select`, `backbone_known`, `damping_known`, `frc_duffing`,
//! `fuzz_inputs`, `mat_files`) and, one module per source module, the tests of the library's
//! modules (`pipeline` for the crate root's end-to-end tests) through its public API (`[lib]
//! test = false`: the library is compiled once, not again with `--test`). Run one module with
//! a filter, e.g. `cargo test -p ssm --test integration auto_intervals::`.

mod auto_intervals;
mod auto_select;
mod backbone;
mod backbone_known;
mod damping_known;
mod data;
mod device;
mod dynamics;
mod embed;
mod frc;
mod frc_duffing;
mod fuzz_inputs;
mod interp;
mod manifold;
mod map_ssm;
mod mat;
mod mat_files;
mod metrics;
mod multistep;
mod normal_form;
mod pipeline;
mod poly;
mod portrait;
mod ridge;
mod spectrum;
mod tangent;
mod testing;
