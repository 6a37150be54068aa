//! libFuzzer target: [`fuzz_targets::sweep_spec`] (the body and its properties live there).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| fuzz_targets::sweep_spec(data));
