//! Device cost table: instructions per call of the controllers and the RBF predictor,
//! counted with SysTick under QEMU's `-icount shift=7` (run by `cargo xtask device-table`).
//!
//! Under `-icount shift=7` every instruction advances virtual time by 2^7 ns and SysTick
//! (core clock, 25 MHz, 40 ns a tick) counts that time, so `instructions = ticks * 40 / 128`.
//! The 24-bit counter is extended by the wrap interrupt. Each measurement runs `reps` calls
//! and a baseline loop doing the same input loads without the call; the xtask converts
//! `(ticks - base) * 40 / 128 / reps`. A block of 1,000 `nop`s calibrates the conversion.
//!
//! Output lines (semihosting), parsed by the xtask:
//! `dt KEY reps=R ticks=T base=B`, `dt predval k=K sqrt=S w=W bits=0x...`, `dt done`.
//! Anything going wrong prints `dt error ...` and exits with failure.
#![no_std]
#![no_main]

use core::hint::black_box;
use core::sync::atomic::{AtomicU32, Ordering};

use controller::predictor::{Predictor, SqrtFlavour};
use controller::{FloatPd, IntPd};
use cortex_m::peripheral::SYST;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m_rt::{ExceptionFrame, entry, exception};
use cortex_m_semihosting::{debug, hprintln};
use panic_semihosting as _;

#[allow(dead_code)] // the trace data are shared with the test binary; only the inputs are used here
mod data {
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/target-data/traces.rs"));
    include!(concat!(env!("CARGO_MANIFEST_DIR"), "/target-data/device_table.rs"));
}

/// Capacities sized for the largest table model: p <= 16, d <= 6, K <= 1000, lift order 3
/// at d = 6 (77 monomials), window <= 64 samples.
type Pred = Predictor<16, 6, 1000, 80, 64>;
static mut PREDICTOR: Pred = Pred::empty(SqrtFlavour::DEFAULT);

static WRAPS: AtomicU32 = AtomicU32::new(0);
const RELOAD: u32 = 0x00FF_FFFF;

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// Ticks since the counter started (24-bit down-counter extended by the wrap count).
#[inline(never)]
fn now() -> u64 {
    loop {
        let w1 = WRAPS.load(Ordering::Relaxed);
        let cv = SYST::get_current();
        let w2 = WRAPS.load(Ordering::Relaxed);
        if w1 == w2 {
            return (u64::from(w1) << 24) + u64::from(RELOAD - cv);
        }
    }
}

/// Ticks of one run of `f`.
fn ticks(mut f: impl FnMut()) -> u64 {
    let t0 = now();
    f();
    now().saturating_sub(t0)
}

fn report(key: &str, reps: usize, t: u64, base: u64) {
    hprintln!("dt {} reps={} ticks={} base={}", key, reps, t, base);
}

fn fail(why: &str) -> ! {
    hprintln!("dt error {}", why);
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}

#[inline(never)]
fn nops_1000() {
    // SAFETY: a block of no-ops; touches no memory or registers.
    unsafe { core::arch::asm!(".rept 1000", "nop", ".endr", options(nomem, nostack, preserves_flags)) };
}

#[inline(never)]
fn nops_0() {
    // SAFETY: as above, empty.
    unsafe { core::arch::asm!("", options(nomem, nostack, preserves_flags)) };
}

const CTRL_REPS: usize = 1000;

fn bench_controllers() {
    let inputs = data::TRACE_INPUTS.get(..CTRL_REPS).unwrap_or_else(|| fail("too few trace inputs"));
    let base = ticks(|| {
        for &(qy, qz) in inputs {
            black_box((black_box(qy), black_box(qz)));
        }
    });
    let cfg = data::TRACE_CASES.get(1).unwrap_or_else(|| fail("no pid trace case")).config;
    let mut pd = IntPd::<{ data::TRACE_H }>::try_new(&cfg).unwrap_or_else(|_| fail("IntPd config"));
    let t = ticks(|| {
        for &(qy, qz) in inputs {
            black_box(pd.step(black_box(qy), black_box(qz)));
        }
    });
    report("ctrl_int", CTRL_REPS, t, base);

    let q = cfg.quant.unwrap_or_else(|| fail("trace config without quant"));
    let float_cfg = shared::ControllerConfig { quant: None, ..cfg };
    let (hy, hz) = (q.h_adc as f32, q.h_adc_phi as f32);
    let base = ticks(|| {
        for &(qy, qz) in inputs {
            black_box((black_box(qy as f32 * hy), black_box(qz as f32 * hz)));
        }
    });
    let mut f32pd = FloatPd::<f32, 8>::try_new(&float_cfg).unwrap_or_else(|_| fail("FloatPd<f32> config"));
    let t = ticks(|| {
        for &(qy, qz) in inputs {
            let _ = black_box(f32pd.step(black_box(qy as f32 * hy), black_box(qz as f32 * hz)));
        }
    });
    report("ctrl_f32", CTRL_REPS, t, base);

    let (hy, hz) = (q.h_adc, q.h_adc_phi);
    let base = ticks(|| {
        for &(qy, qz) in inputs {
            black_box((black_box(f64::from(qy) * hy), black_box(f64::from(qz) * hz)));
        }
    });
    let mut f64pd = FloatPd::<f64, 8>::try_new(&float_cfg).unwrap_or_else(|_| fail("FloatPd<f64> config"));
    let t = ticks(|| {
        for &(qy, qz) in inputs {
            let _ = black_box(f64pd.step(black_box(f64::from(qy) * hy), black_box(f64::from(qz) * hz)));
        }
    });
    report("ctrl_f64", CTRL_REPS, t, base);
}

fn flavour_name(s: SqrtFlavour) -> &'static str {
    match s {
        SqrtFlavour::Libm => "libm",
        SqrtFlavour::Fast => "fast",
        SqrtFlavour::Hardware => "hardware",
    }
}

fn bench_predictor() {
    // SAFETY: the only reference to PREDICTOR, taken once here.
    let p = unsafe { &mut *(&raw mut PREDICTOR) };
    let first = data::MODELS.first().unwrap_or_else(|| fail("no models"));
    for (k, blob) in data::MODELS {
        if p.load(blob).is_err() {
            fail("model did not load");
        }
        if p.model().k() != k {
            fail("model has the wrong number of centres");
        }
        let window = data::WINDOWS.first().unwrap_or_else(|| fail("no windows"));
        for &bits in window.iter() {
            p.push(f32::from_bits(bits)).unwrap_or_else(|_| fail("sample refused"));
        }
        let eta = p.reduce().unwrap_or_else(|_| fail("window not full"));
        let reps = (20_000 / k).max(4);
        for sqrt in SqrtFlavour::ALL {
            p.set_sqrt_flavour(sqrt);
            let base = ticks(|| {
                for _ in 0..reps {
                    black_box(black_box(&eta));
                }
            });
            let t = ticks(|| {
                for _ in 0..reps {
                    black_box(p.step(black_box(&eta)));
                }
            });
            hprintln!("dt pred k={} sqrt={} reps={} ticks={} base={}", k, flavour_name(sqrt), reps, t, base);
            for (w, window) in data::WINDOWS.iter().enumerate() {
                p.reset();
                for &bits in window.iter() {
                    p.push(f32::from_bits(bits)).unwrap_or_else(|_| fail("sample refused"));
                }
                let y = p.predict(data::HORIZON).unwrap_or_else(|_| fail("predict failed"));
                hprintln!("dt predval k={} sqrt={} w={} bits={:#010x}", k, flavour_name(sqrt), w, y.to_bits());
            }
        }
        if k == first.0 {
            // Projection and lift do not depend on K or the sqrt flavour.
            const REPS: usize = 200;
            let y = p.embedding().unwrap_or_else(|_| fail("window not full"));
            let base = ticks(|| {
                for _ in 0..REPS {
                    black_box(black_box(&y));
                }
            });
            let t = ticks(|| {
                for _ in 0..REPS {
                    black_box(p.project(black_box(&y)));
                }
            });
            report("project", REPS, t, base);
            let base = ticks(|| {
                for _ in 0..REPS {
                    black_box(black_box(&eta));
                }
            });
            let t = ticks(|| {
                for _ in 0..REPS {
                    black_box(p.lift(black_box(&eta)));
                }
            });
            report("lift", REPS, t, base);
        }
    }
}

#[entry]
fn main() -> ! {
    let cp = cortex_m::Peripherals::take().unwrap_or_else(|| fail("core peripherals taken"));
    let mut syst = cp.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
    while SYST::get_current() == 0 {}

    let base = ticks(nops_0);
    let t = ticks(nops_1000);
    report("calib_nops1000", 1, t, base);
    bench_controllers();
    bench_predictor();
    hprintln!("dt done");
    debug::exit(debug::EXIT_SUCCESS);
    loop {
        cortex_m::asm::wfi();
    }
}

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    hprintln!("dt error HardFault at pc = {:#010x}", frame.pc());
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::wfi();
    }
}
