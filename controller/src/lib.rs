//! Sampled-data PD/PID control law as it runs on the device, in two arithmetic paths
//! (exact floating point and integer-quantized), and the on-device RBF predictor.
//!
//! Never allocates, never panics, never overflows silently.
#![cfg_attr(not(any(test, feature = "std")), no_std)]

pub mod pd;
pub mod predictor;
pub mod quant;
