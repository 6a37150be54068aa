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

mod board;
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
    Test { name: "board::memory_map", run: board_tests::memory_map },
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
    Test { name: "intpd::golden_trace_pd_one_coordinate_delay1", run: trace_tests::case::<5> },
    Test { name: "intpd::golden_trace_pid_four_coordinates_delay2", run: trace_tests::case::<6> },
    Test { name: "intpd::golden_trace_pd_three_coordinates_delay1", run: trace_tests::case::<7> },
    Test { name: "intpd::golden_trace_pid_three_coordinates_delay4", run: trace_tests::case::<8> },
    Test { name: "intpd::golden_trace_pd_four_coordinates_delay0_no_umax", run: trace_tests::case::<9> },
    Test { name: "intpd::all_golden_cases_listed", run: trace_tests::all_cases_listed },
];

/// Checks that the image runs in the memory map of the board it was built for.
mod board_tests {
    use crate::board::{FLASH, RAM, contains};
    use core::sync::atomic::{AtomicU32, Ordering};

    unsafe extern "C" {
        /// Start of cortex-m-rt's vector table (placed at ORIGIN(FLASH)).
        static __vector_table: u32;
        /// Initial stack pointer: ORIGIN(RAM) + LENGTH(RAM).
        static _stack_start: u32;
    }

    /// A static in `.bss` (RAM), written and read back.
    static IN_RAM: AtomicU32 = AtomicU32::new(0);

    /// The linker placed the vector table at the board's flash origin and the stack at the
    /// end of its RAM; at run time this code executes from flash, the stack and statics
    /// live in RAM, and (where flash is not at address 0) the vector table's first word read
    /// from flash is that stack top.
    pub fn memory_map() -> Result<(), &'static str> {
        let vectors = (&raw const __vector_table) as usize;
        let stack_top = (&raw const _stack_start) as usize;
        let code = memory_map as fn() -> Result<(), &'static str> as usize;
        let local = 0u32;
        let sp = core::hint::black_box(&raw const local) as usize;
        IN_RAM.store(0xA5A5_5A5A, Ordering::SeqCst);
        let ram_static = (&raw const IN_RAM) as usize;
        cortex_m_semihosting::hprintln!(
            "  flash {:#010x}+{:#x}: vector table {:#010x}, code {:#010x}; ram {:#010x}+{:#x}: stack top {:#010x}, stack {:#010x}, static {:#010x}",
            FLASH.0,
            FLASH.1,
            vectors,
            code,
            RAM.0,
            RAM.1,
            stack_top,
            sp,
            ram_static
        );
        if vectors != FLASH.0 {
            return Err("vector table is not at the board's flash origin");
        }
        if stack_top != RAM.0 + RAM.1 {
            return Err("initial stack pointer is not the end of the board's RAM");
        }
        if !contains(FLASH, code) {
            return Err("code does not run from the board's flash");
        }
        if !contains(RAM, sp) || sp >= stack_top {
            return Err("stack is not in the board's RAM below the stack top");
        }
        if !contains(RAM, ram_static) || IN_RAM.load(Ordering::SeqCst) != 0xA5A5_5A5A {
            return Err("static is not in the board's RAM or does not keep its value");
        }
        if FLASH.0 != 0 {
            // SAFETY: the vector table's first word, in flash (non-null here), word-aligned.
            let initial_sp = unsafe { core::ptr::read_volatile(&raw const __vector_table) } as usize;
            if initial_sp != stack_top {
                return Err("the vector table read from flash does not hold the stack top");
            }
        }
        Ok(())
    }
}

#[entry]
fn main() -> ! {
    hprintln!("running {} on-target tests (board: {})", TESTS.len(), board::NAME);
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
