//! What accuracy costs in time: sampling periods simulated per second against the max theta
//! error versus a tight reference, for the project's integrator at several accuracies and a
//! plain RK4 baseline, all measured in the same run. Ratios are against that baseline.

use crate::scene::{IntegratorSpec, MethodKind, Scene};
use crate::sim::{SimError, Trajectory, simulate};
use serde::Serialize;
use std::time::Instant;

/// One row of the table.
#[derive(Clone, Debug, Serialize)]
pub struct BenchRow {
    pub method: String,
    pub periods_per_s: f64,
    pub max_err_rad: f64,
    /// periods_per_s divided by the baseline's (RK4 at its stable step), same run.
    pub ratio_vs_baseline: f64,
    /// Integrator steps per sampling period (accepted + rejected).
    pub steps_per_period: f64,
}

/// The benchmark problem: `furuta-dt30.8`, 200 periods from theta0 = 0.05 rad, the rest at rest.
pub fn problem(periods: u64) -> Result<Scene, SimError> {
    Ok(Scene::load(
        "furuta-dt30.8",
        &[format!("run.periods={periods}"), "initial.state=[0.05, 0.0, 0.0, 0.0]".into(), "run.tasks=[\"simulate\"]".into()],
    )?)
}

fn with(scene: &Scene, method: MethodKind, rtol: Option<f64>, steps: Option<u32>) -> Scene {
    let mut s = scene.clone();
    s.integrator = IntegratorSpec { method, rtol, atol: rtol.map(|r| r * 1e-2), steps };
    s
}

fn label(s: &Scene) -> String {
    let i = &s.integrator;
    match i.method {
        MethodKind::Rodas => format!("rodas4 rtol={:e}", i.rtol.unwrap_or_default()),
        MethodKind::RodasFixed => format!("rodas4 fixed {} steps/period", i.steps.unwrap_or_default()),
        MethodKind::Rk4 => format!("rk4 {} steps/period", i.steps.unwrap_or_default()),
        MethodKind::Exprb => format!("exprb43 rtol={:e}", i.rtol.unwrap_or_default()),
        MethodKind::ExprbFixed => format!("exprb43 fixed {} steps/period", i.steps.unwrap_or_default()),
    }
}

fn max_err(a: &Trajectory, b: &Trajectory) -> f64 {
    if a.rows() != b.rows() {
        return f64::INFINITY;
    }
    a.primary().iter().zip(b.primary()).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// Times one configuration: repeats until `min_seconds` of wall time (at least 3 runs) and
/// keeps the fastest run, which is the least disturbed by the rest of the machine.
fn time(scene: &Scene, min_seconds: f64) -> Result<(f64, Trajectory), SimError> {
    let mut best = f64::INFINITY;
    let mut runs = 0;
    let start = Instant::now();
    let mut last = None;
    while runs < 3 || start.elapsed().as_secs_f64() < min_seconds {
        let t0 = Instant::now();
        let tr = simulate(scene, None)?;
        best = best.min(t0.elapsed().as_secs_f64());
        last = Some(tr);
        runs += 1;
    }
    // `last` is set: the loop runs at least three times.
    Ok((best, last.ok_or_else(|| SimError::Controller { scene: scene.name.clone(), message: "no run".into() })?))
}

/// Runs the table. `quick` uses fewer configurations and shorter timing windows (tests).
pub fn bench_simulate(periods: u64, quick: bool, mut progress: impl FnMut(&str)) -> Result<(Vec<BenchRow>, String), SimError> {
    let base = problem(periods)?;
    progress("reference: rodas4 rtol=1e-13");
    let reference = simulate(&with(&base, MethodKind::Rodas, Some(1e-13), None), None)?;
    let mut configs = vec![with(&base, MethodKind::Rk4, None, Some(175))];
    let rtols: &[f64] = if quick { &[1e-8, 1e-11] } else { &[1e-6, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12] };
    configs.extend(rtols.iter().map(|&r| with(&base, MethodKind::Rodas, Some(r), None)));
    let fixed: &[u32] = if quick { &[8] } else { &[2, 4, 8, 16, 32] };
    configs.extend(fixed.iter().map(|&n| with(&base, MethodKind::RodasFixed, None, Some(n))));
    let ex: &[f64] = if quick { &[1e-8] } else { &[1e-7, 1e-8, 1e-9, 1e-10] };
    configs.extend(ex.iter().map(|&r| with(&base, MethodKind::Exprb, Some(r), None)));
    let rk: &[u32] = if quick { &[] } else { &[350, 700, 1400] };
    configs.extend(rk.iter().map(|&n| with(&base, MethodKind::Rk4, None, Some(n))));
    let window = if quick { 0.02 } else { 0.5 };
    let mut rows = Vec::new();
    for c in &configs {
        let name = label(c);
        progress(&name);
        let (secs, tr) = time(c, window)?;
        let n = (tr.rows() - 1) as f64;
        let st = tr.ode_stats;
        rows.push(BenchRow {
            method: name,
            periods_per_s: n / secs,
            max_err_rad: max_err(&tr, &reference),
            ratio_vs_baseline: 0.0,
            steps_per_period: (st.steps + st.rejected) as f64 / n,
        });
    }
    let baseline = rows.first().map_or(1.0, |r| r.periods_per_s);
    for r in &mut rows {
        r.ratio_vs_baseline = r.periods_per_s / baseline;
    }
    Ok((rows, label(&configs[0])))
}
