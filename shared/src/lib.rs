//! Types that cross the host/device boundary: the controller configuration a device is
//! flashed with, and (module `model`) the postcard reduced-model format.
//!
//! This crate must not depend on `host` or `controller`, never allocates and never panics on
//! bad input: every decoder returns an error naming what is wrong.
#![cfg_attr(not(any(test, feature = "std")), no_std)]

pub mod config;
pub mod model;

pub use config::{ControllerConfig, QuantMode, Quantization};
