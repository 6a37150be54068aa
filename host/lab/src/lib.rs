//! The lab: research and profiling programs kept out of the libraries and of the test build.
//! Each program is an example (`cargo run --release -p lab --example NAME`); see `README.md`.
