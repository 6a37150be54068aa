//! One period map of the paper's loop expanded at order 9 (profiling aid for the Taylor
//! arithmetic: `sim::taylor::tps`; prints a hash of the coefficients and the time, not a test).
//! `cargo run --release -p lab --example tps_expand -- [dt_ms] [order] [reps]`
use std::time::Instant;

use furuta::equation_ssm::scene_period_map;
use sim::taylor::FlowOptions;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dt: f64 = args.first().and_then(|s| s.parse().ok()).unwrap_or(31.0);
    let order: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(9);
    let reps: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let scene = furuta::full_system::scene_at(dt)?;
    for _ in 0..reps {
        let t0 = Instant::now();
        let pm = scene_period_map(&scene, order, &FlowOptions::default())?;
        let mut h = 0xcbf29ce484222325u64;
        for v in pm.flow.outputs.iter().flatten() {
            h ^= v.to_bits();
            h = h.wrapping_mul(0x100000001b3);
        }
        println!("dt {dt} order {order}: {} steps, {:.3} s, hash {h:016x}", pm.flow.steps, t0.elapsed().as_secs_f64());
    }
    Ok(())
}
