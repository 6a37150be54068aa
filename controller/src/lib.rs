//! Sampled-data PD/PID control law as it runs on the device.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
