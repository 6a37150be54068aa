//! Picks the memory map for the board and checks that the host-generated test data exist.

use std::path::PathBuf;
use std::{env, fs};

fn main() {
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let board = if env::var_os("CARGO_FEATURE_STM32F407").is_some() { "stm32f407" } else { "mps2-an386" };
    let memory = manifest.join("memory").join(format!("{board}.x"));
    fs::copy(&memory, out.join("memory.x")).unwrap_or_else(|e| panic!("copy {}: {e}", memory.display()));
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory");

    let data = manifest.join("target-data");
    for file in ["model.bin", "vectors.rs", "traces.rs", "device_table.rs"] {
        let path = data.join(file);
        if !path.exists() {
            panic!(
                "{} is missing: run `cargo xtask qemu-test` (it generates the test data, then builds)",
                path.display()
            );
        }
        println!("cargo:rerun-if-changed={}", path.display());
    }
}
