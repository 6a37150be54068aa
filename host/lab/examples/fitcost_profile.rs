//! Profiling driver for the report's fitted-model tasks (docs/decisions/0003): each stage timed in
//! thread CPU, to run under `perf record -g` (build with `--profile profiling`).
//!
//! `cargo run --profile profiling -p lab --example fitcost_profile -- STAGE...` with
//! STAGE among `runs` (the training runs of the default and the variants), `default` (the
//! default shared-tangent fit), `variant` (the 7-period, cut 0.3 rad variant's fit),
//! `parametric` (the per-period normal-form fits), `basin` (the fitted map's verdict on the
//! full basin grid), `reads` (the map's connection and torus continuation, linear), `step`
//! (one step of the default map at 31.3 ms, linear, with its theta lift: ns per step over
//! 1e6 steps, median of 5).

use furuta::basin::BasinOptions;
use furuta::map_global::{ConnectionOptions, map_basin, map_connection, map_torus_continuation};
use furuta::parametric::{FurutaOptions, TrainingRuns, furuta_parametric_from};
use furuta::shared_tangent::shared_parametric_from;
use ssm::interp::Interp;

/// Process CPU seconds (user + system, all threads) from /proc/self/stat.
fn cpu() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let f: Vec<&str> = s.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let tick = 100.0;
    let u: f64 = f.get(11).and_then(|v| v.parse().ok()).unwrap_or(0.0);
    let k: f64 = f.get(12).and_then(|v| v.parse().ok()).unwrap_or(0.0);
    (u + k) / tick
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let stages: Vec<String> = std::env::args().skip(1).collect();
    let has = |s: &str| stages.iter().any(|x| x == s);
    let base = FurutaOptions::default();
    let variants = furuta::bifurcations::sensitivity_variants();
    let sets: Vec<&FurutaOptions> = std::iter::once(&base).chain(variants.iter().map(|(_, o)| o)).collect();
    let mut c0 = cpu();
    let mut lap = |what: &str| {
        let c = cpu();
        eprintln!("{what}: {:.2} CPU-s", c - c0);
        c0 = c;
    };
    if has("heads") {
        // The full-system head of a map-basin cell (the embedding window, 21 periods) against
        // longer runs from the same starts: the cost of a run's start-up.
        let basis = furuta::parametric::ModeBasis::at(31.5)?;
        let starts: Vec<_> = (0..100)
            .map(|k| furuta::full_system::start_from_rho_in(&basis, [0.005 + 0.002 * k as f64, 0.01], [0.0, 0.0]))
            .collect::<Result<_, _>>()?;
        for periods in [1u64, 21, 210] {
            for s in &starts {
                std::hint::black_box(furuta::full_system::run(31.5, &(s.0, Some(s.1.clone())), periods, 1.0)?);
            }
            lap(&format!("100 full-system runs of {periods} periods"));
        }
        return Ok(());
    }
    let runs = TrainingRuns::simulate(&sets)?;
    lap("runs");
    if has("hash") {
        // Fingerprints of the fitted models (their JSON, every number in shortest round-trip
        // form, so equal fingerprints are equal bits): an optimization of the fits is checked
        // bit for bit against the fingerprints of the code before it.
        let fp = |v: &dyn erased::Json| {
            use std::hash::{Hash, Hasher};
            let s = v.json();
            let mut h = std::collections::hash_map::DefaultHasher::new();
            s.hash(&mut h);
            format!("{:016x} ({} bytes)", h.finish(), s.len())
        };
        let pm = furuta_parametric_from(&base, &runs)?;
        eprintln!("hash parametric: {}", fp(&pm));
        let family = furuta::parametric::furuta_parametric_family(&base, &pm, &sets, &runs)?;
        for (i, (m, _)) in family.iter().enumerate() {
            eprintln!("hash family {i}: {}", fp(m));
        }
        eprintln!("hash shared default: {}", fp(&shared_parametric_from(&base, &runs)?));
        for (name, o) in &variants {
            eprintln!("hash shared {name}: {}", fp(&shared_parametric_from(o, &runs)?));
        }
        lap("hash fits");
        return Ok(());
    }
    if has("parametric") {
        let pm = furuta_parametric_from(&base, &runs)?;
        lap("parametric fit");
        std::hint::black_box(pm);
    }
    let need_default = has("default") || has("basin") || has("reads") || has("step");
    let sm = if need_default { Some(shared_parametric_from(&base, &runs)?) } else { None };
    if need_default {
        lap("default shared fit");
    }
    if has("variant") {
        let v = shared_parametric_from(&variants[3].1, &runs)?;
        lap("variant shared fit (7 periods, cut 0.3)");
        std::hint::black_box(v);
    }
    if let Some(sm) = &sm {
        if has("basin") {
            let b = map_basin(|dt| sm.model_at(dt, Interp::Linear), &BasinOptions::full())?;
            lap("map basin (full grid)");
            eprintln!("bounded cells: {}", b.iter().flatten().filter(|&&x| x).count());
        }
        if has("step") {
            step_bench(sm)?;
        }
        if has("reads") {
            let co = ConnectionOptions::default();
            let c = map_connection(|dt| sm.model_at(dt, Interp::Linear), 31.0, 32.0, 6, 0.005, &co)?;
            lap("map connection (linear)");
            eprintln!("connection {:?}", c.switch.bracket);
            let dts: Vec<f64> = (0..=14).map(|k| ((31.3 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
            let t = map_torus_continuation(|dt| sm.model_at(dt, Interp::Linear), &dts, [0.097, 0.0277], 16_000)?;
            lap("map torus (linear)");
            eprintln!("torus onset {:?}", t.growth_onset);
        }
    }
    Ok(())
}

/// This thread's CPU time in ns (/proc/thread-self/schedstat: time on a CPU), so that the
/// load of other processes on a shared machine counts less than in wall time.
fn thread_ns() -> f64 {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    s.split_whitespace().next().and_then(|v| v.parse().ok()).unwrap_or(0.0)
}

/// ns per map step (step + theta lift, as the basin and connection loops) on the default
/// shared model at 31.3 ms, from the torus continuation's start, in thread CPU time; the
/// plain path (`ReducedDynamics::step`, `Manifold::lift_one`) and the prepared one
/// (`PreparedDynamics`, `PreparedLift`) alternate, 5 runs of 1e6 steps each (restarted from
/// the start on escape), median of the 5 printed.
fn step_bench(sm: &furuta::shared_tangent::SharedParametricModel) -> Result<(), Box<dyn std::error::Error>> {
    use ssm::dynamics::StepScratch;
    use ssm::poly::PolyScratch;
    let dt_ms = 31.3;
    let model = sm.model_at(dt_ms, Interp::Linear)?;
    let p = model.manifold.p;
    let dt = model.dynamics.map_dt().ok_or("not a map")?;
    let (x, h) = furuta::full_system::start_from_rho(dt_ms, [0.097, 0.0277], [0.0, 0.0])?;
    let head = furuta::full_system::run(dt_ms, &(x, Some(h)), p as u64, f64::MAX)?.primary();
    let eta0 = model.manifold.reduce(&head[..p]);
    let n = 1_000_000u32;
    let (map, manifold) = (model.dynamics.prepare(), model.manifold.prepare());
    let run = |prepared: bool| {
        let (mut sc, mut lsc) = (StepScratch::default(), PolyScratch::default());
        let mut eta = eta0.clone();
        let mut sum = 0.0;
        let t = thread_ns();
        for _ in 0..n {
            let th = if prepared {
                manifold.lift_one(&eta, &mut lsc, p - 1)
            } else {
                model.manifold.lift_one(&eta, &mut lsc, p - 1)
            };
            if !th.is_finite() || th.abs() > furuta::full_system::ESCAPE_THETA {
                eta.copy_from_slice(&eta0);
            }
            sum += th;
            if prepared {
                map.step(&mut eta, dt, &mut sc);
            } else {
                model.dynamics.step(&mut eta, dt, &mut sc);
            }
        }
        ((thread_ns() - t) / f64::from(n), sum)
    };
    let (mut old, mut new) = (Vec::new(), Vec::new());
    for _ in 0..5 {
        let (a, sa) = run(false);
        let (b, sb) = run(true);
        if sa.to_bits() != sb.to_bits() {
            return Err(format!("the prepared path's theta sum {sb:e} differs from the plain {sa:e}").into());
        }
        old.push(a);
        new.push(b);
    }
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    eprintln!(
        "map step + theta lift, thread CPU ns/step, median of 5: plain {:.0} {old:.0?}, prepared {:.0} {new:.0?}",
        median(old.clone()),
        median(new.clone())
    );
    Ok(())
}

/// JSON of a serializable value behind a trait object (the fingerprints of `hash`).
mod erased {
    pub trait Json {
        fn json(&self) -> String;
    }
    impl<T: serde::Serialize> Json for T {
        fn json(&self) -> String {
            serde_json::to_string(self).unwrap_or_default()
        }
    }
}
