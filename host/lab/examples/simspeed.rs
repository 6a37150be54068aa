//! The `bench simulate` problem (furuta-dt30.8, theta0 = 0.05 rad) with one integrator, for
//! profiling and instruction counts: prints the max theta error (and the max error of any state
//! component) against RODAS4 at rtol 1e-13,
//! steps per period and CPU-independent work counters.
//!
//! ```text
//! cargo run --release -p lab --example simspeed -- exprb-split 1e-8 [periods] [repeats] [noref]
//! valgrind --tool=callgrind target/release/examples/simspeed exprb-split 1e-8 201 1 noref
//! ```
//! The second argument is rtol (adaptive methods, atol = rtol/100, or rtol times the sixth
//! argument) or steps per period. Optional seventh to ninth: scene, theta0 (rad), dt (ms),
//! e.g. `exprb-lean 3e-11 3000 1 noref 1 furuta-dt30.5 0.02 31.5` (a basin run).

use sim::closed_loop::simulate;
use sim::scene::{IntegratorSpec, MethodKind, Scene, SceneBuilder, Task};
use std::time::Instant;

fn scene(
    periods: u64,
    kind: MethodKind,
    arg: f64,
    atol_factor: f64,
    at: &(String, f64, Option<f64>),
) -> Result<Scene, Box<dyn std::error::Error>> {
    let mut b =
        SceneBuilder::load(&at.0)?.periods(periods).initial_state(&[at.1, 0.0, 0.0, 0.0]).tasks(&[Task::Simulate]);
    if let Some(dt) = at.2 {
        b = b.dt_ms(dt);
    }
    let mut s = b.build()?;
    let adaptive = matches!(
        kind,
        MethodKind::Rodas
            | MethodKind::Exprb
            | MethodKind::ExprbSplit
            | MethodKind::ExprbLean
            | MethodKind::ExprbFiltered
            | MethodKind::Exprb54
            | MethodKind::Exprb54Filtered
    );
    s.integrator = if adaptive {
        IntegratorSpec { method: kind, rtol: Some(arg), atol: Some(arg * atol_factor), steps: None }
    } else {
        IntegratorSpec { method: kind, rtol: None, atol: None, steps: Some(arg as u32) }
    };
    Ok(s)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let kind: MethodKind =
        toml::Value::String(args.get(1).cloned().unwrap_or_else(|| "exprb-split".into())).try_into()?;
    let arg: f64 = args.get(2).map_or(Ok(1e-8), |a| a.parse())?;
    let periods: u64 = args.get(3).map_or(Ok(200), |a| a.parse())?;
    let repeats: usize = args.get(4).map_or(Ok(1), |a| a.parse())?;
    let noref = args.get(5).is_some_and(|a| a == "noref");
    let atol_factor: f64 = args.get(6).map_or(Ok(1e-2), |a| a.parse())?;
    let at = (
        args.get(7).cloned().unwrap_or_else(|| "furuta-dt30.8".into()),
        args.get(8).map_or(Ok(0.05), |a| a.parse())?,
        args.get(9).map(|a| a.parse()).transpose()?,
    );
    let s = scene(periods, kind, arg, atol_factor, &at)?;
    let t0 = Instant::now();
    let mut tr = simulate(&s, None)?;
    for _ in 1..repeats {
        tr = simulate(&s, None)?;
    }
    let secs = t0.elapsed().as_secs_f64() / repeats as f64;
    let st = tr.ode_stats;
    let n = (tr.rows() - 1) as f64;
    print!(
        "{}: {:.1} steps/period ({} rejected), {:.0} periods/s wall, {n} periods",
        tr.integrator,
        (st.steps + st.rejected) as f64 / n,
        st.rejected,
        n / secs
    );
    if !noref {
        let r = simulate(&scene(periods, MethodKind::Rodas, 1e-13, 1e-2, &at)?, None)?;
        let err = tr.primary().iter().zip(r.primary()).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        print!(", max theta error {err:.3e}");
        // Every state component at every sample (absolute; rad and rad/s).
        let err_state = tr.states.iter().zip(&r.states).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        print!(", max state error {err_state:.3e}");
    }
    println!();
    Ok(())
}
