//! libFuzzer target: [`fuzz_targets::csv_data`] (the body and its properties live there).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| fuzz_targets::csv_data(data));
