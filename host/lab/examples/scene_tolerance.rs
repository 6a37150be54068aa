//! The full-system scene's integrator near the saddle connection: the pure fast-mode start of
//! 1e-3 rad at 31.38 and 31.4 ms run for N periods with several integrators, against RODAS4
//! at rtol 1e-13 (verdict, max |theta|, theta difference to the reference over the run, CPU).
//!
//!     cargo run --release -p lab --example scene_tolerance -- [PERIODS]
use furuta::parametric::mode_start;
use sim::closed_loop::simulate;
use sim::scene::{IntegratorSpec, MethodKind, SceneBuilder};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let periods: u64 = std::env::args().nth(1).map(|s| s.parse()).transpose()?.unwrap_or(3000);
    let spec =
        |method, rtol: f64, atol: f64| IntegratorSpec { method, rtol: Some(rtol), atol: Some(atol), steps: None };
    let cands = [
        ("rodas 1e-13 (reference)", spec(MethodKind::Rodas, 1e-13, 1e-15)),
        ("exprb 1e-9/1e-11 (scene today)", spec(MethodKind::Exprb, 1e-9, 1e-11)),
        ("exprb 1e-11/1e-13", spec(MethodKind::Exprb, 1e-11, 1e-13)),
        ("exprb-lean 1e-10", spec(MethodKind::ExprbLean, 1e-10, 1e-10)),
        ("exprb-lean 3e-11", spec(MethodKind::ExprbLean, 3e-11, 3e-11)),
        ("exprb-lean 1e-11", spec(MethodKind::ExprbLean, 1e-11, 1e-11)),
        ("exprb-filtered 1e-10", spec(MethodKind::ExprbFiltered, 1e-10, 1e-10)),
        ("exprb-filtered 3e-11", spec(MethodKind::ExprbFiltered, 3e-11, 3e-11)),
        ("exprb-filtered 1e-11", spec(MethodKind::ExprbFiltered, 1e-11, 1e-11)),
    ];
    for dt in [31.38, 31.4] {
        let (x, h) = mode_start(dt, None, Some((1e-3, 0.0)))?;
        let mut reference: Option<Vec<f64>> = None;
        for (name, s) in &cands {
            let scene = SceneBuilder::load("furuta-dt30.5")?
                .dt_ms(dt)
                .periods(periods)
                .initial_state(&x)
                .escape_theta(1.0)
                .history(Some(&h))
                .integrator(s.clone())
                .build()?;
            let t0 = Instant::now();
            let tr = simulate(&scene, None)?;
            let cpu = t0.elapsed().as_secs_f64();
            let n = tr.state_names.len();
            let theta: Vec<f64> = tr.states.chunks(n).map(|r| r[0]).collect();
            let maxth = theta.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let diff = reference.as_ref().map(|r| r.iter().zip(&theta).fold(0.0f64, |m, (a, b)| m.max((a - b).abs())));
            println!(
                "dt {dt} {name:32} samples {:6} escaped {:5} max|theta| {maxth:.4e} max diff to ref {} {cpu:.2} s",
                theta.len(),
                tr.stopped.is_some(),
                diff.map_or("-".into(), |d| format!("{d:.3e}"))
            );
            if reference.is_none() {
                reference = Some(theta);
            }
        }
    }
    Ok(())
}
