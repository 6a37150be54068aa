//! Profiling driver for the report's fitted-model tasks (issue 13): each stage timed in
//! thread CPU, to run under `perf record -g` (build with `--profile profiling`).
//!
//! `cargo run --profile profiling -p furuta --example fitcost_profile -- STAGE...` with
//! STAGE among `runs` (the training runs of the default and the variants), `default` (the
//! default shared-tangent fit), `variant` (the 7-period, cut 0.3 rad variant's fit),
//! `parametric` (the per-period normal-form fits), `basin` (the fitted map's verdict on the
//! full basin grid), `reads` (the map's connection and torus continuation, linear).

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
        let starts: Vec<_> = (0..100).map(|k| furuta::full_system::start_from_rho_in(&basis, [0.005 + 0.002 * k as f64, 0.01], [0.0, 0.0])).collect::<Result<_, _>>()?;
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
    if has("parametric") {
        let pm = furuta_parametric_from(&base, &runs)?;
        lap("parametric fit");
        std::hint::black_box(pm);
    }
    let need_default = has("default") || has("basin") || has("reads");
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
