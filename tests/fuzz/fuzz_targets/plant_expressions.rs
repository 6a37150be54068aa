//! libFuzzer target: [`fuzz_targets::plant_expressions`] (the body and its properties live there).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| fuzz_targets::plant_expressions(data));
