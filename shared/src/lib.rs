//! Types that cross the host/device boundary: the controller configuration a device is
//! flashed with, (module `model`) the postcard reduced-model format, and (module `frame`)
//! the processor-in-the-loop frame the host and the firmware exchange.
//!
//! This crate must not depend on `host` or `controller`, never allocates and never panics on
//! bad input: every decoder returns an error naming what is wrong.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
// Input-parsing, device-side code: no unwrap/expect/panic/indexing (docs/decisions/0004; CI runs clippy).
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing))]

pub mod config;
pub mod frame;
pub mod model;

pub use config::{ControllerConfig, Gain, Gains, MAX_GAINS, QuantMode, Quantization};
