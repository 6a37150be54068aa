//! Run-level cost of the report's full-system tasks (docs/decisions/0003; profiling aid, prints, not a
//! test): one task at full settings, for `perf record`, and the integrator's work counters
//! per period of its runs.
//!
//! ```text
//! cargo run --release -p lab --example fullprof -- TASK [count]
//! RAYON_NUM_THREADS=1 perf record -g target/profiling/examples/fullprof basin
//! ```
//! TASK: `scan` (fullsystem/scan: 21 dt x 8 default starts, 8,000 periods, the scene's
//! integrator), `basin` (global/full-basin: 4 dt x 20 x 20 mode starts, 3,000 periods, the
//! verdict integrator), `connection` (global/full-connection), `torus` (global/full-torus),
//! `fates` (fullsystem/fast-fates and doa-fates). With `count` the runs of `scan`, `basin`
//! and `fates` are repeated one by one on this thread, summing the integrator's counters
//! (accepted and rejected steps, right-hand sides, Jacobians) and timing the start's set-up
//! apart from the simulation.

use std::time::Instant;

use furuta::basin::{BasinOptions, full_basin, torus_continuation_with};
use furuta::full_system::{
    DEFAULT_SCAN_PERIODS, ESCAPE_THETA, Start, default_dts, default_ics, default_switch_scan, run_with, start_from_rho,
    verdict_integrator,
};
use furuta::map_global::{ConnectionOptions, full_connection_with};
use sim::ode::OdeStats;

/// CPU seconds of the whole process (user + system, from /proc/self/stat, 10 ms ticks).
fn process_cpu() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let rest = s.rsplit(')').next().unwrap_or("");
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

/// CPU seconds of this thread (ns resolution, /proc/thread-self/schedstat).
fn thread_cpu() -> f64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    s.split_whitespace().next().and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0) * 1e-9
}

#[derive(Default)]
struct Tally {
    runs: usize,
    escaped: usize,
    periods: u64,
    stats: OdeStats,
    setup_s: f64,
    sim_s: f64,
}

impl Tally {
    fn add(&mut self, tr: &sim::closed_loop::Trajectory) {
        self.runs += 1;
        self.escaped += usize::from(tr.stopped.is_some());
        self.periods += tr.rows().saturating_sub(1) as u64;
        let s = tr.ode_stats;
        self.stats.steps += s.steps;
        self.stats.rejected += s.rejected;
        self.stats.rhs_evals += s.rhs_evals;
        self.stats.jac_evals += s.jac_evals;
    }

    fn print(&self, name: &str) {
        let p = self.periods.max(1) as f64;
        let s = self.stats;
        eprintln!(
            "{name}: {} runs ({} escaped), {} periods; per period: {:.2} accepted + {:.2} rejected steps, {:.2} rhs, {:.2} jacobians; \
             set-up {:.3} s, simulation {:.3} s thread CPU ({:.0} periods/s, {:.2} us/step)",
            self.runs,
            self.escaped,
            self.periods,
            s.steps as f64 / p,
            s.rejected as f64 / p,
            s.rhs_evals as f64 / p,
            s.jac_evals as f64 / p,
            self.setup_s,
            self.sim_s,
            p / self.sim_s,
            1e6 * self.sim_s / (s.steps + s.rejected).max(1) as f64
        );
    }
}

fn timed<T>(acc: &mut f64, f: impl FnOnce() -> T) -> T {
    let t0 = thread_cpu();
    let r = f();
    *acc += thread_cpu() - t0;
    r
}

/// [`timed`] in process CPU (for calls that run on the rayon pool).
fn timed_p<T>(acc: &mut f64, f: impl FnOnce() -> T) -> T {
    let t0 = process_cpu();
    let r = f();
    *acc += process_cpu() - t0;
    r
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let what = args.first().map(String::as_str).unwrap_or("basin");
    let count = args.iter().any(|a| a == "count");
    let (w0, c0) = (Instant::now(), process_cpu());
    let vi = verdict_integrator()?;
    match (what, count) {
        ("scan", false) => {
            let s = default_switch_scan(DEFAULT_SCAN_PERIODS)?;
            eprintln!("scan: {} runs, bracket {:?}", s.runs, s.bracket());
        }
        ("scan", true) => {
            let mut t = Tally::default();
            for dt in default_dts() {
                let mut setup = 0.0;
                let ics: Vec<Start> = timed(&mut setup, || default_ics(dt))?;
                t.setup_s += setup;
                for ic in &ics {
                    let tr = timed(&mut t.sim_s, || run_with(None, dt, ic, DEFAULT_SCAN_PERIODS, ESCAPE_THETA))?;
                    t.add(&tr);
                }
            }
            t.print("scan");
        }
        ("basin", false) => {
            let b = full_basin(&BasinOptions::full())?;
            eprintln!("basin: escape fractions {:?}", (0..4).map(|p| b.escape_fraction(p)).collect::<Vec<_>>());
        }
        ("basin", true) => {
            let o = BasinOptions::full();
            let (r1, r2) = o.values();
            let mut t = Tally::default();
            for &dt in &o.dts_ms {
                for &a in &r1 {
                    for &b in &r2 {
                        let (x, h) = timed(&mut t.setup_s, || start_from_rho(dt, [a, b], o.phases))?;
                        let tr =
                            timed(&mut t.sim_s, || run_with(Some(&vi), dt, &(x, Some(h)), o.periods, ESCAPE_THETA))?;
                        t.add(&tr);
                    }
                }
            }
            t.print("basin");
        }
        ("connection", true) => {
            // One dt of the rule: the fast circle (Newton on the exact period map) apart from
            // the whole evaluation (circle + the pushed runs).
            let o = ConnectionOptions::default();
            for dt in [31.0, 31.4, 31.8] {
                let (mut expand, mut circle, mut all) = (0.0, 0.0, 0.0);
                let scene = furuta::full_system::scene_at(dt)?;
                timed_p(&mut expand, || furuta::convergence::ExactMap::new(&scene, o.guess_order))?;
                eprintln!(
                    "connection dt {dt}: the order-{} expansion of the period map (ExactMap::new) {expand:.3} s",
                    o.guess_order
                );
                let rows = timed_p(&mut circle, || {
                    furuta::saddle_cycles::saddle_cycles(&[dt], 2, &[o.guess_order], &o.circle)
                })?;
                let f = timed_p(&mut all, || furuta::map_global::full_connection_fates_with(Some(&vi), dt, &o))?;
                eprintln!(
                    "connection dt {dt}: circle {circle:.3} s process CPU (newton steps {:?}), circle + runs {all:.3} s; escapes {:?}, escape times {:?}",
                    rows[0].full.as_ref().map(|c| c.newton_steps),
                    f.escapes(),
                    f.outcomes.iter().map(|o| o.escape_t).collect::<Vec<_>>()
                );
            }
        }
        ("connection", false) => {
            let c = full_connection_with(Some(&vi), 31.0, 32.0, 6, 0.005, &ConnectionOptions::default())?;
            eprintln!("connection: {:?}", c.switch);
        }
        ("torus", _) => {
            let dts: Vec<f64> = (0..=14).map(|k| ((31.3 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
            let c = torus_continuation_with(Some(&vi), &dts, [0.097, 0.0277], 16_000)?;
            eprintln!("torus: lost between {:?}, onset {:?}", c.lost_between, c.growth_onset);
        }
        ("fates", _) => {
            let mut t = Tally::default();
            let mut go = |dt: f64, rho: [f64; 2], periods: u64| -> Result<(), furuta::Error> {
                let (x, h) = timed(&mut t.setup_s, || start_from_rho(dt, rho, [0.0, 0.0]))?;
                let tr = timed(&mut t.sim_s, || run_with(None, dt, &(x, Some(h)), periods, ESCAPE_THETA))?;
                t.add(&tr);
                Ok(())
            };
            for dt in [30.8, 31.2, 31.4, 31.6] {
                go(dt, [1e-7, 0.005], 3000)?;
            }
            for rho in [[0.08, 0.03], [0.02, 0.03], [0.14, 0.055]] {
                go(31.55, rho, 6000)?;
            }
            t.print("fates");
        }
        ("shared", _) => {
            // The chaos section's held-out quantized run, then the verdict's shorter one.
            let long = sim::scene::SceneBuilder::load("furuta-quant-dt25")?
                .periods(30_000)
                .initial_state(&[0.02, 0.0, 0.0, 0.0])
                .build()?;
            let t = chaos_study::microchaos::simulate_shared(&long)?;
            eprintln!("long: rows {} saturated {} stopped {:?}", t.rows(), t.saturated_samples, t.stopped);
            let short = sim::scene::SceneBuilder::load("furuta-quant-dt25")?
                .periods(20_000)
                .initial_state(&[0.02, 0.0, 0.0, 0.0])
                .build()?;
            let (mut c, w) = (0.0, Instant::now());
            let s = timed(&mut c, || chaos_study::microchaos::simulate_shared(&short))?;
            eprintln!("short: rows {} in {c:.3} s CPU, {:.3} s wall", s.rows(), w.elapsed().as_secs_f64());
        }
        _ => return Err(format!("unknown task {what}").into()),
    }
    eprintln!("{what}: wall {:.2} s, process CPU {:.2} s", w0.elapsed().as_secs_f64(), process_cpu() - c0);
    Ok(())
}
