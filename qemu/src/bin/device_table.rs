//! Device cost table: instructions per call of the controllers and the RBF predictor,
//! counted with SysTick under QEMU's `-icount shift=7` (run by `cargo xtask device-table`).
//!
//! Under `-icount shift=7` every instruction advances virtual time by 2^7 ns and SysTick
//! (core clock, 25 MHz, 40 ns a tick) counts that time, so `instructions = ticks * 40 / 128`.
//! The 24-bit counter is extended by the wrap interrupt. Each measurement runs `reps` calls
//! and a baseline loop doing the same input loads without the call; the xtask converts
//! `(ticks - base) * 40 / 128 / reps`. A block of 1,000 `nop`s calibrates the conversion.
//!
//! f32 against f64: the library predictor is f32 only (the M4F's FPU is single precision,
//! f64 arithmetic runs in software: compiler-builtins' `__aeabi_d*` and `libm::sqrt`). The
//! [`generic`] module here evaluates the same model formula with a generic scalar, in the
//! library's operation order, and is counted as f32 and as f64 for K = 50 and 200 (the step
//! instructions and `predict(HORIZON)` on every window, printed as f64 bits).
//!
//! Output lines (semihosting), parsed by the xtask:
//! `dt KEY reps=R ticks=T base=B`, `dt predval k=K sqrt=S w=W bits=0x...`,
//! `dt gstep k=K scalar=S reps=R ticks=T base=B`, `dt gpredval k=K scalar=S w=W bits=0x...`
//! (64-bit), `dt done`.
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

/// The integer controller's step on the coordinates of `cfg`: the call the PIL firmware
/// makes per period, `IntPd::step_counts` on the received counts (padded to four). Inlined
/// at each call with its configuration from the static trace data, as the controller rows
/// were measured before the gain vector (the compiler may fold the configuration in);
/// `bench_int_opaque` measures the same step with a configuration it cannot see.
#[inline(always)]
fn bench_int(key: &str, cfg: &shared::ControllerConfig, inputs: &[[i32; 4]]) {
    let base = ticks(|| {
        for q in inputs {
            black_box(black_box(q));
        }
    });
    let mut pd = IntPd::<{ data::TRACE_H }>::try_new(cfg).unwrap_or_else(|_| fail("IntPd config"));
    let t = ticks(|| {
        for q in inputs {
            black_box(pd.step_counts(black_box(q)));
        }
    });
    report(key, CTRL_REPS, t, base);
}

#[inline(never)]
fn bench_int_opaque(key: &str, cfg: &shared::ControllerConfig, inputs: &[[i32; 4]]) {
    bench_int(key, cfg, inputs);
}

fn bench_controllers() {
    let inputs = data::TRACE_INPUTS.get(..CTRL_REPS).unwrap_or_else(|| fail("too few trace inputs"));
    // The Furuta's configuration (two coordinates), and one, three and four coordinates:
    // the golden-trace cases of the same gains (PID but for the one-coordinate case).
    let case = |i: usize| data::TRACE_CASES.get(i).unwrap_or_else(|| fail("no such trace case")).config;
    let cfg = case(1);
    bench_int("ctrl_int", &cfg, inputs);
    bench_int("ctrl_int_n1", &case(5), inputs);
    bench_int("ctrl_int_n3", &case(8), inputs);
    bench_int("ctrl_int_n4", &case(6), inputs);
    // The configuration as the PIL firmware has it: decoded at run time, opaque here.
    bench_int_opaque("ctrl_int_rt", &black_box(cfg), inputs);
    bench_int_opaque("ctrl_int_rt_n1", &black_box(case(5)), inputs);
    bench_int_opaque("ctrl_int_rt_n3", &black_box(case(8)), inputs);
    bench_int_opaque("ctrl_int_rt_n4", &black_box(case(6)), inputs);
    // The bundled Furuta scenes' law: the same two coordinates without integral action.
    bench_int_opaque("ctrl_int_rt_pd", &black_box(case(0)), inputs);

    let (hy, hz) = match cfg.gains.as_slice() {
        [a, b] => (a.h_adc, b.h_adc),
        _ => fail("trace config is not the two-angle shorthand"),
    };
    let float_cfg = shared::ControllerConfig { quant: None, ..cfg };
    let (fy, fz) = (hy as f32, hz as f32);
    let base = ticks(|| {
        for q in inputs {
            black_box(black_box([q[0] as f32 * fy, q[1] as f32 * fz]));
        }
    });
    let mut f32pd = FloatPd::<f32, 8>::try_new(&float_cfg).unwrap_or_else(|_| fail("FloatPd<f32> config"));
    let t = ticks(|| {
        for q in inputs {
            let _ = black_box(f32pd.step(&black_box([q[0] as f32 * fy, q[1] as f32 * fz])));
        }
    });
    report("ctrl_f32", CTRL_REPS, t, base);

    let base = ticks(|| {
        for q in inputs {
            black_box(black_box([f64::from(q[0]) * hy, f64::from(q[1]) * hz]));
        }
    });
    let mut f64pd = FloatPd::<f64, 8>::try_new(&float_cfg).unwrap_or_else(|_| fail("FloatPd<f64> config"));
    let t = ticks(|| {
        for q in inputs {
            let _ = black_box(f64pd.step(&black_box([f64::from(q[0]) * hy, f64::from(q[1]) * hz])));
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

/// The RBF model formula (reduce, step, lift component 0) for a generic scalar, in the
/// library predictor's operation order; model entries (f32) are widened on use.
mod generic {
    use core::ops::{Add, AddAssign, Div, Mul, Sub};
    use shared::model::Model;
    use shared::model::monomial::degree_count;

    pub trait Real:
        Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self> + AddAssign
    {
        const ZERO: Self;
        fn from_f32(x: f32) -> Self;
        fn sqrt(self) -> Self;
        fn to_f64(self) -> f64;
    }

    impl Real for f32 {
        const ZERO: Self = 0.0;
        #[inline(always)]
        fn from_f32(x: f32) -> Self {
            x
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            // `vsqrt.f32`, as the library's `SqrtFlavour::Hardware`.
            controller::predictor::SqrtFlavour::Hardware.sqrt(self)
        }
        fn to_f64(self) -> f64 {
            f64::from(self)
        }
    }

    impl Real for f64 {
        const ZERO: Self = 0.0;
        #[inline(always)]
        fn from_f32(x: f32) -> Self {
            f64::from(x)
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            libm::sqrt(self)
        }
        fn to_f64(self) -> f64 {
            self
        }
    }

    /// `eta_j = sum_i V1[i][j] (y_i - offset) / scale` with `y_i = window[i * shift]`.
    pub fn reduce<S: Real, const P: usize, const D: usize, const K: usize, const T: usize>(
        m: &Model<P, D, K, T>,
        window: &[u32],
    ) -> [S; D] {
        let mut eta = [S::ZERO; D];
        let (off, scale) = (S::from_f32(m.offset()), S::from_f32(m.scale()));
        for (i, row) in m.v1().iter().enumerate() {
            let y = window.get(i.saturating_mul(m.shift())).map_or(S::ZERO, |&b| S::from_f32(f32::from_bits(b)));
            let z = (y - off) / scale;
            for (e, &v) in eta.iter_mut().zip(row.iter()).take(m.d()) {
                *e += S::from_f32(v) * z;
            }
        }
        eta
    }

    /// One step of the RBF map: affine part, then the centres in order.
    #[inline(never)]
    pub fn step<S: Real, const P: usize, const D: usize, const K: usize, const T: usize>(
        m: &Model<P, D, K, T>,
        eta: &[S; D],
    ) -> [S; D] {
        let mut out = [S::ZERO; D];
        for ((o, row), &b) in out.iter_mut().zip(m.affine_linear()).zip(m.affine_bias()) {
            let mut acc = S::from_f32(b);
            for (&a, &x) in row.iter().zip(eta.iter()) {
                acc += S::from_f32(a) * x;
            }
            *o = acc;
        }
        for (c, w) in m.centres().iter().zip(m.weights()) {
            let mut r2 = S::ZERO;
            for (&x, &ci) in eta.iter().zip(c.iter()) {
                let diff = x - S::from_f32(ci);
                r2 += diff * diff;
            }
            let r = r2.sqrt();
            for (o, &wi) in out.iter_mut().zip(w.iter()) {
                *o += S::from_f32(wi) * r;
            }
        }
        out
    }

    /// Component 0 of the lift: `(sum_j V1[0][j] eta_j + sum_t L[0][t] m_t(eta)) * scale +
    /// offset`, monomials in the graded order of `shared::model::monomial` (degree `k` as
    /// `eta_i` times the suffix of degree `k-1`). `None` if a capacity is exceeded.
    pub fn lift0<S: Real, const P: usize, const D: usize, const K: usize, const T: usize>(
        m: &Model<P, D, K, T>,
        eta: &[S; D],
    ) -> Option<S> {
        let d = m.d();
        let e = eta.get(..d)?;
        let mut mono = [S::ZERO; T];
        let mut prev_start = 0usize;
        let mut write = 0usize;
        for k in 2..=m.lift_order() {
            let prev_len = degree_count(d, k - 1)?;
            for (i, &ei) in e.iter().enumerate() {
                let suffix_len = degree_count(d - i, k - 1)?;
                let suffix_start = prev_len.checked_sub(suffix_len)?;
                for s in suffix_start..prev_len {
                    let factor = if k == 2 { *e.get(s)? } else { *mono.get(prev_start + s)? };
                    *mono.get_mut(write)? = ei * factor;
                    write += 1;
                }
            }
            if k > 2 {
                prev_start += prev_len;
            }
        }
        let v = m.v1().first()?;
        let l = m.lift().first()?;
        let mut acc = S::ZERO;
        for (&a, &x) in v.iter().zip(e.iter()) {
            acc += S::from_f32(a) * x;
        }
        for (&a, &x) in l.iter().zip(mono.iter()).take(write) {
            acc += S::from_f32(a) * x;
        }
        Some(acc * S::from_f32(m.scale()) + S::from_f32(m.offset()))
    }

    /// `lift0(step^n(reduce(window)))`.
    pub fn predict<S: Real, const P: usize, const D: usize, const K: usize, const T: usize>(
        m: &Model<P, D, K, T>,
        window: &[u32],
        n: u32,
    ) -> Option<S> {
        let mut eta = reduce::<S, P, D, K, T>(m, window);
        for _ in 0..n {
            eta = step(m, &eta);
        }
        lift0(m, &eta)
    }
}

/// Centre counts of the generic f32 / f64 rows.
const GENERIC_K: [usize; 2] = [50, 200];

fn bench_generic<S: generic::Real>(p: &Pred, k: usize, name: &str) {
    let m = p.model();
    let first = data::WINDOWS.first().unwrap_or_else(|| fail("no windows"));
    let eta: [S; 6] = generic::reduce(m, first);
    let reps = (2_000 / k).max(4);
    let base = ticks(|| {
        for _ in 0..reps {
            black_box(black_box(&eta));
        }
    });
    let t = ticks(|| {
        for _ in 0..reps {
            black_box(generic::step(m, black_box(&eta)));
        }
    });
    hprintln!("dt gstep k={} scalar={} reps={} ticks={} base={}", k, name, reps, t, base);
    for (w, window) in data::WINDOWS.iter().enumerate() {
        let y: S = generic::predict(m, window, data::HORIZON).unwrap_or_else(|| fail("generic lift: capacity"));
        hprintln!("dt gpredval k={} scalar={} w={} bits={:#018x}", k, name, w, y.to_f64().to_bits());
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
        if GENERIC_K.contains(&k) {
            bench_generic::<f32>(p, k, "f32");
            bench_generic::<f64>(p, k, "f64");
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
