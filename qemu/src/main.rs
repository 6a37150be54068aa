//! On-target test runner for the Cortex-M4F.
//!
//! Runs every test of [`TESTS`] in order, prints `test NAME ... ok|FAILED` and a summary line
//! over semihosting, and exits 0 only if all passed (semihosting `exit` sets QEMU's exit
//! code). A panic or a HardFault exits with failure. New test groups (integer controller
//! ...) add a module and entries to [`TESTS`].
#![no_std]
#![no_main]

use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use panic_semihosting as _;

mod model_tests;
mod trace_tests;

/// The host-generated data: `model.bin` (the blob) and `vectors.rs` (inputs and the
/// expected outputs computed on the host by the same predictor code).
pub mod data {
    pub static MODEL_BLOB: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/target-data/model.bin"));
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/target-data/vectors.rs"));
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/target-data/traces.rs"));
}

/// A test: its name and a function returning `Err(reason)` on failure (details may be
/// printed before returning).
pub struct Test {
    pub name: &'static str,
    pub run: fn() -> Result<(), &'static str>,
}

const TESTS: &[Test] = &[
    Test { name: "model::decodes_embedded_blob", run: model_tests::decodes_embedded_blob },
    Test { name: "model::rejects_targeted_corruptions", run: model_tests::rejects_targeted_corruptions },
    Test { name: "model::rejects_random_corruptions", run: model_tests::rejects_random_corruptions },
    Test { name: "predictor::rolling_matches_host_libm", run: model_tests::rolling_libm },
    Test { name: "predictor::rolling_matches_host_fast", run: model_tests::rolling_fast },
    Test { name: "predictor::rolling_matches_host_hardware", run: model_tests::rolling_hardware },
    Test { name: "predictor::free_run_matches_host_all_flavours", run: model_tests::free_run_all },
    Test { name: "intpd::golden_trace_pd_delay1", run: trace_tests::case::<0> },
    Test { name: "intpd::golden_trace_pid_delay1", run: trace_tests::case::<1> },
    Test { name: "intpd::golden_trace_pd_delay3", run: trace_tests::case::<2> },
    Test { name: "intpd::golden_trace_pid_delay3", run: trace_tests::case::<3> },
    Test { name: "intpd::golden_trace_pid_delay1_no_umax", run: trace_tests::case::<4> },
    Test { name: "intpd::all_golden_cases_listed", run: trace_tests::all_cases_listed },
];

#[entry]
fn main() -> ! {
    hprintln!("running {} on-target tests", TESTS.len());
    let (mut passed, mut failed) = (0u32, 0u32);
    for t in TESTS {
        match (t.run)() {
            Ok(()) => {
                passed += 1;
                hprintln!("test {} ... ok", t.name);
            }
            Err(why) => {
                failed += 1;
                hprintln!("test {} ... FAILED: {}", t.name, why);
            }
        }
    }
    hprintln!("on-target result: {} passed, {} failed", passed, failed);
    debug::exit(if failed == 0 { debug::EXIT_SUCCESS } else { debug::EXIT_FAILURE });
    loop {
        cortex_m::asm::wfi();
    }
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    hprintln!("HardFault at pc = {:#010x}", frame.pc());
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
