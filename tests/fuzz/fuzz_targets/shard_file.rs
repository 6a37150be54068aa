//! libFuzzer target: [`fuzz_targets::shard_file`] (the body and its properties live there).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| fuzz_targets::shard_file(data));
