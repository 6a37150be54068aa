//! What accuracy costs in time: sampling periods simulated per second against the max theta
//! error versus a tight reference, for the project's integrator at several accuracies and a
//! plain RK4 baseline, all measured in the same run. Ratios are against that baseline.

use serde::Serialize;
use sim::closed_loop::{SimError, Trajectory, simulate};
use sim::scene::{IntegratorSpec, MethodKind, Scene, SceneBuilder, Task};
use sim::units::s_to_ms;
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

/// The benchmark's scene, the report's number of periods, its start angle (rad) and the
/// reference's relative tolerance.
pub const SCENE: &str = "furuta-dt30.8";
pub const PERIODS: u64 = 200;
pub const THETA0: f64 = 0.05;
pub const REFERENCE_RTOL: f64 = 1e-13;

/// The benchmark problem: [`SCENE`], `periods` periods from theta0 = [`THETA0`], the rest at rest.
pub fn problem(periods: u64) -> Result<Scene, SimError> {
    Ok(SceneBuilder::load(SCENE)?
        .periods(periods)
        .initial_state(&[THETA0, 0.0, 0.0, 0.0])
        .tasks(&[Task::Simulate])
        .build()?)
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
        MethodKind::ExprbSplit => format!("exprb43-split rtol={:e}", i.rtol.unwrap_or_default()),
        // atol = rtol (not rtol / 100): the tolerance the full-system scene uses.
        MethodKind::ExprbLean if i.atol.is_some() && i.atol == i.rtol => {
            format!("exprb43-lean rtol=atol={:e}", i.rtol.unwrap_or_default())
        }
        MethodKind::ExprbLean => format!("exprb43-lean rtol={:e}", i.rtol.unwrap_or_default()),
        MethodKind::ExprbFiltered if i.atol.is_some() && i.atol == i.rtol => {
            format!("exprb43-filtered rtol=atol={:e}", i.rtol.unwrap_or_default())
        }
        MethodKind::ExprbFiltered => format!("exprb43-filtered rtol={:e}", i.rtol.unwrap_or_default()),
        MethodKind::Exprb54 => format!("exprb54s4 rtol={:e}", i.rtol.unwrap_or_default()),
        MethodKind::Exprb54Filtered => format!("exprb54s4-filtered rtol={:e}", i.rtol.unwrap_or_default()),
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

/// Timing window per configuration (s) of [`bench_simulate`] (full table; quick: 0.02 s).
/// Each configuration repeats until this much wall time has passed (at least 3 runs) and
/// keeps its fastest run; the baseline gets a second window after the others (its faster
/// one counts), so one disturbed window cannot move every ratio. Was 0.5 s: on the loaded
/// 2-core machine (docs/decisions/0003) two tables at 0.5 s already differ by up to 2x in single rows,
/// and 0.1 s windows give the same rows within that spread in about half the wall time
/// and half the CPU (the timing loop is most of the section).
pub const TIMING_WINDOW_S: f64 = 0.1;

/// Runs the table. `quick` uses fewer configurations and shorter timing windows (tests).
pub fn bench_simulate(
    periods: u64,
    quick: bool,
    progress: impl FnMut(&str),
) -> Result<(Vec<BenchRow>, String), SimError> {
    bench_simulate_window(periods, quick, if quick { 0.02 } else { TIMING_WINDOW_S }, progress)
}

/// [`bench_simulate`] with the timing window `window` (s) per configuration.
pub fn bench_simulate_window(
    periods: u64,
    quick: bool,
    window: f64,
    mut progress: impl FnMut(&str),
) -> Result<(Vec<BenchRow>, String), SimError> {
    let base = problem(periods)?;
    progress(&format!("reference: rodas4 rtol={REFERENCE_RTOL:e}"));
    let reference = simulate(&with(&base, MethodKind::Rodas, Some(REFERENCE_RTOL), None), None)?;
    let mut configs = vec![with(&base, MethodKind::Rk4, None, Some(175))];
    let rtols: &[f64] = if quick { &[1e-8, 1e-11] } else { &[1e-6, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12] };
    configs.extend(rtols.iter().map(|&r| with(&base, MethodKind::Rodas, Some(r), None)));
    let fixed: &[u32] = if quick { &[8] } else { &[2, 4, 8, 16, 32] };
    configs.extend(fixed.iter().map(|&n| with(&base, MethodKind::RodasFixed, None, Some(n))));
    let ex: &[f64] = if quick { &[1e-8] } else { &[1e-7, 1e-8, 1e-9, 1e-10] };
    configs.extend(ex.iter().map(|&r| with(&base, MethodKind::Exprb, Some(r), None)));
    let rk: &[u32] = if quick { &[] } else { &[350, 700, 1400] };
    configs.extend(rk.iter().map(|&n| with(&base, MethodKind::Rk4, None, Some(n))));
    let split: &[f64] = if quick { &[1e-8] } else { &[1e-7, 1e-8, 1e-9, 1e-10] };
    configs.extend(split.iter().map(|&r| with(&base, MethodKind::ExprbSplit, Some(r), None)));
    let lean: &[f64] = if quick { &[4e-9] } else { &[1e-7, 1e-8, 4e-9, 1e-9, 1e-10] };
    configs.extend(lean.iter().map(|&r| with(&base, MethodKind::ExprbLean, Some(r), None)));
    let lean_abs: &[f64] = if quick { &[4e-9] } else { &[1e-8, 4e-9, 2e-9] };
    configs.extend(lean_abs.iter().map(|&r| {
        let mut s = with(&base, MethodKind::ExprbLean, Some(r), None);
        s.integrator.atol = Some(r);
        s
    }));
    let filtered: &[f64] = if quick { &[4e-9] } else { &[1e-8, 4e-9, 2e-9, 1e-9] };
    configs.extend(filtered.iter().map(|&r| {
        let mut s = with(&base, MethodKind::ExprbFiltered, Some(r), None);
        s.integrator.atol = Some(r);
        s
    }));
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
    // The baseline once more at the end, keeping its faster window: every ratio divides by
    // it, so one disturbed window there would move the whole column.
    if let (Some(c), Some(r)) = (configs.first(), rows.first_mut()) {
        let (secs, tr) = time(c, window)?;
        r.periods_per_s = r.periods_per_s.max((tr.rows() - 1) as f64 / secs);
    }
    let baseline = rows.first().map_or(1.0, |r| r.periods_per_s);
    for r in &mut rows {
        r.ratio_vs_baseline = r.periods_per_s / baseline;
    }
    Ok((rows, label(&configs[0])))
}

// ------------------------------------------------------------------------ plant forms

/// One row of the plant-form table: the benchmark problem with one integrator, the plant
/// built in (Rust) or written as equations in the scene (`furuta-equations`), the latter's
/// tapes run as native code (where there is some) or interpreted.
#[derive(Clone, Debug, Serialize)]
pub struct PlantFormRow {
    /// One of [`PLANT_FORMS`].
    pub plant: String,
    pub integrator: String,
    /// Thread CPU time per sampling period, s (the median over the interleaved rounds).
    pub cpu_s_per_period: f64,
    /// This row's CPU time per period over the built-in plant's with the same integrator:
    /// the median of the ratios of the rounds, each round one run of either form back to
    /// back, so a change of load hits both sides of a ratio alike.
    pub cpu_ratio_vs_builtin: f64,
    /// The smallest and largest ratio of the rounds.
    pub cpu_ratio_range: [f64; 2],
    /// Interleaved rounds timed.
    pub rounds: usize,
    /// Max |theta| error against the tight reference (the built-in plant, rodas4 rtol=1e-13).
    pub max_err_rad: f64,
    /// Right-hand side evaluations per period (f64, plus dual-number Jacobians).
    pub rhs_per_period: f64,
    pub jac_per_period: f64,
    /// One `f64` right-hand side evaluation, ns (timing loop at a state near the run's).
    pub ns_per_rhs: f64,
    /// Instructions per `f64` right-hand side evaluation (hardware counter), when readable.
    pub instructions_per_rhs: Option<f64>,
    /// Instructions of the equations plant's tape (one evaluation gives the mass matrix and
    /// the forces; the solve is on top).
    pub tape_instructions: Option<usize>,
}

/// The plant-form table and how the instruction counts were obtained.
#[derive(Clone, Debug, Serialize)]
pub struct PlantForms {
    pub rows: Vec<PlantFormRow>,
    /// `perf_event_open` instruction counts, or why there are none.
    pub counters: String,
    /// The machine's 1-minute load average before and after the timed rounds (`/proc/loadavg`;
    /// `None` where it cannot be read): the CPU ratios were measured under this load.
    pub load_average: [Option<f64>; 2],
}

/// The plant forms of the table: the built-in Furuta, `furuta-equations` as it runs (its
/// tapes as native code where the platform has it), and the same with its tapes
/// interpreted.
pub const PLANT_FORMS: [&str; 3] = ["built-in", "equations", "interpreted"];

/// The integrators of the plant-form table: method, rtol (atol = rtol / 100), steps.
pub const PLANT_FORM_INTEGRATORS: [(MethodKind, Option<f64>, Option<u32>); 2] =
    [(MethodKind::Exprb, Some(1e-9), None), (MethodKind::Rk4, None, Some(175))];

/// The plant-form table's two scenes: the benchmark problem ([`problem`]) with the built-in
/// Furuta, and the same problem with the plant written as equations (`furuta-equations`).
pub fn plant_form_scenes(periods: u64) -> Result<(Scene, Scene), SimError> {
    let builtin = problem(periods)?;
    let equations = SceneBuilder::load("furuta-equations")?
        .dt_ms(builtin.controller.dt_ms)
        .periods(periods)
        .initial_state(&[0.05, 0.0, 0.0, 0.0])
        .tasks(&[Task::Simulate])
        .build()?;
    Ok((builtin, equations))
}

/// `scene` with the integrator `(method, rtol, steps)` (atol = rtol / 100) and its label.
pub fn with_integrator(scene: &Scene, method: MethodKind, rtol: Option<f64>, steps: Option<u32>) -> (Scene, String) {
    let s = with(scene, method, rtol, steps);
    let l = label(&s);
    (s, l)
}

/// Thread CPU time, s.
fn thread_cpu_s() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes one timespec through a valid pointer.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    if rc != 0 {
        return f64::NAN;
    }
    ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64
}

/// Thread CPU time of one run of each scene on its built plant, back to back, repeated for
/// at least `min_seconds` (at least 5 rounds): the per-round CPU times of each scene, and
/// each scene's last trajectory.
fn cpu_rounds(
    scenes: &[(&Scene, &sim::closed_loop::AnyPlant)],
    min_seconds: f64,
) -> Result<(Vec<Vec<f64>>, Vec<Trajectory>), SimError> {
    let mut times = vec![Vec::new(); scenes.len()];
    let mut last = Vec::new();
    let start = Instant::now();
    let mut rounds = 0;
    while rounds < 5 || start.elapsed().as_secs_f64() < min_seconds {
        last.clear();
        for ((s, plant), t) in scenes.iter().zip(times.iter_mut()) {
            let c0 = thread_cpu_s();
            let tr = sim::closed_loop::simulate_plant(s, plant, None)?;
            t.push(thread_cpu_s() - c0);
            last.push(tr);
        }
        rounds += 1;
    }
    Ok((times, last))
}

/// The median of `v` (NaN when empty).
fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => 0.5 * (s[n / 2 - 1] + s[n / 2]),
    }
}

/// The 1-minute load average (`/proc/loadavg`), if readable.
fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg").ok()?.split_whitespace().next()?.parse().ok()
}

/// ns per `f64` rhs evaluation (fastest of 5 loops of `iters`) and, when the hardware
/// counter opens, instructions per evaluation.
fn rhs_cost<P: sim::plant::Plant<N>, const N: usize>(
    p: &P,
    iters: u64,
    counter: Option<&crate::perf::Counter>,
) -> (f64, Option<f64>) {
    let mut x = [0.0; N];
    for (i, v) in x.iter_mut().enumerate() {
        *v = 0.05 / (1.0 + i as f64);
    }
    let run = || {
        for _ in 0..iters {
            std::hint::black_box(p.rhs(std::hint::black_box(&x), std::hint::black_box(0.3)));
        }
    };
    let mut best = f64::INFINITY;
    for _ in 0..5 {
        let t0 = Instant::now();
        run();
        best = best.min(t0.elapsed().as_secs_f64());
    }
    let instructions = counter.and_then(|c| c.count(run)).map(|n| n as f64 / iters as f64);
    (1e9 * best / iters as f64, instructions)
}

/// The plant-form table: the benchmark problem ([`problem`]) with the built-in Furuta plant
/// and with the same plant written as equations (`furuta-equations`), its tapes run as
/// native code and interpreted ([`PLANT_FORMS`]), for the adaptive exponential integrator
/// and fixed-step RK4, all timed in one run; errors against one tight reference.
pub fn bench_plant_forms(periods: u64, quick: bool, mut progress: impl FnMut(&str)) -> Result<PlantForms, SimError> {
    let window = if quick { 0.02 } else { TIMING_WINDOW_S };
    let (builtin, equations) = plant_form_scenes(periods)?;
    progress("plant forms: reference rodas4 rtol=1e-13");
    let reference = simulate(&with(&builtin, MethodKind::Rodas, Some(1e-13), None), None)?;
    let counter = crate::perf::Counter::instructions();
    let counters = match &counter {
        Ok(_) => "instructions per rhs from the hardware counter (perf_event_open, user space)".to_string(),
        Err(e) => format!("hardware counters not readable in this machine ({e}); ns per rhs from a timing loop"),
    };
    let iters = if quick { 20_000 } else { 200_000 };
    let plants = [
        sim::closed_loop::build_plant(&builtin)?,
        sim::closed_loop::build_plant(&equations)?,
        sim::expr::interpreted(|| sim::closed_loop::build_plant(&equations))?,
    ];
    let mut costs = Vec::new();
    for plant in &plants {
        let tape = match plant {
            sim::closed_loop::AnyPlant::Equations2(p) => Some(p.model().tape().len()),
            _ => None,
        };
        let (ns, ins) = sim::with_plant!(plant, p => rhs_cost(p, iters, counter.as_ref().ok()));
        costs.push((ns, ins, tape));
    }
    let mut rows = Vec::new();
    let load_before = load_average();
    for (method, rtol, steps) in PLANT_FORM_INTEGRATORS {
        let configs = [with(&builtin, method, rtol, steps), with(&equations, method, rtol, steps)];
        let integrator = label(&configs[0]);
        progress(&format!("plant forms: {integrator}, the three forms interleaved"));
        let runs = [(&configs[0], &plants[0]), (&configs[1], &plants[1]), (&configs[1], &plants[2])];
        // The single window per run: the rounds hold three runs each.
        let (times, trs) = cpu_rounds(&runs, 3.0 * window)?;
        for (k, ((name, tr), &(ns, ins, tape))) in PLANT_FORMS.iter().zip(&trs).zip(&costs).enumerate() {
            let n = (tr.rows() - 1) as f64;
            let ratios: Vec<f64> = times[k].iter().zip(&times[0]).map(|(e, b)| e / b).collect();
            let (ratio, range) = if k == 0 {
                (1.0, [1.0, 1.0])
            } else {
                let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                (median(&ratios), [lo, hi])
            };
            rows.push(PlantFormRow {
                plant: name.to_string(),
                integrator: integrator.clone(),
                cpu_s_per_period: median(&times[k]) / n,
                cpu_ratio_vs_builtin: ratio,
                cpu_ratio_range: range,
                rounds: ratios.len(),
                max_err_rad: max_err(tr, &reference),
                rhs_per_period: tr.ode_stats.rhs_evals as f64 / n,
                jac_per_period: tr.ode_stats.jac_evals as f64 / n,
                ns_per_rhs: ns,
                instructions_per_rhs: ins,
                tape_instructions: tape,
            });
        }
    }
    let load_average = [load_before, load_average()];
    Ok(PlantForms { rows, counters, load_average })
}

// ------------------------------------------------------------------------ fitting cost

/// One row of the fitting cost table (second table): one setting varied from the
/// recommended sloshing fit, which is the baseline.
#[derive(Clone, Debug, Serialize)]
pub struct FitBenchRow {
    pub setting: String,
    /// Best-of-repeats wall time of one fit, ms.
    pub fit_ms: f64,
    /// `fit_ms` over the baseline's, same run.
    pub ratio_vs_baseline: f64,
    pub nmte_test: f64,
    pub dtw_nmte_test: f64,
    /// Why the test prediction stopped early, if it did.
    pub stopped: Option<String>,
}

/// The recommended 2D sloshing fit (p = 5, shift 1, manifold order 3, polynomial map of
/// order 5, no ridge): the baseline of [`bench_fit`].
pub fn sloshing_fit_options() -> ssm::FitOptions {
    fit_opts(5, 3, 5, ssm::Dynamics::Map)
}

fn fit_opts(p: usize, k: u32, r: u32, dynamics: ssm::Dynamics) -> ssm::FitOptions {
    ssm::FitOptions {
        dim: 2,
        embed: p,
        shift: 1,
        manifold_order: k,
        dyn_order: r,
        dynamics,
        ridge: ssm::Ridge::Fixed(0.0),
        linear_anchor: None,
        anchor_joint: false,
    }
}

/// Best-of-`reps` fit time (s) and the last model.
pub fn timed_fit(
    train: &[ssm::TimeSeries],
    o: &ssm::FitOptions,
    reps: usize,
) -> Result<(f64, ssm::SsmModel), ssm::FitError> {
    let mut best = f64::INFINITY;
    let mut model = None;
    for _ in 0..reps.max(1) {
        let t0 = Instant::now();
        let m = ssm::fit(train, o)?;
        best = best.min(t0.elapsed().as_secs_f64());
        model = Some(m);
    }
    Ok((best, model.ok_or(ssm::FitError::NoTrainingData)?))
}

/// Fit time against test error: manifold order, map order, embedding dimension, number of
/// training samples, flow vs map, RBF centres, each varied alone from
/// [`sloshing_fit_options`] (first row, the baseline). `train` are the training series, `test`
/// the held-out one. Returns the rows and the 50-centre RBF model (exported by the report).
pub fn bench_fit(
    train: &[ssm::TimeSeries],
    test: &ssm::TimeSeries,
    quick: bool,
    mut progress: impl FnMut(&str),
) -> Result<(Vec<FitBenchRow>, Option<ssm::SsmModel>), ssm::FitError> {
    use ssm::{Dynamics, TimeSeries};
    let mut configs: Vec<(String, ssm::FitOptions, f64)> =
        vec![("baseline: p = 5, manifold 3, map 5".into(), sloshing_fit_options(), 1.0)];
    for k in [1, 5, 7] {
        configs.push((format!("manifold order {k}"), fit_opts(5, k, 5, Dynamics::Map), 1.0));
    }
    for r in [3, 7, 9] {
        configs.push((format!("map order {r}"), fit_opts(5, 3, r, Dynamics::Map), 1.0));
    }
    for p in [7, 9, 13] {
        configs.push((format!("embedding p = {p}"), fit_opts(p, 3, 5, Dynamics::Map), 1.0));
    }
    for frac in [0.25, 0.5] {
        configs.push((format!("{:.0} % of training samples", frac * 100.0), sloshing_fit_options(), frac));
    }
    configs.push(("flow, order 5".into(), fit_opts(5, 3, 5, Dynamics::Flow), 1.0));
    for a in [0.01, 0.2] {
        // Measured data decay into sensor noise: the small-amplitude pairs are noise
        // dominated, so anchoring the linear part there costs accuracy (the row shows how much).
        configs.push((
            format!("linear part anchored within {:.0} %", a * 100.0),
            ssm::FitOptions { linear_anchor: Some(a), anchor_joint: false, ..sloshing_fit_options() },
            1.0,
        ));
    }
    for c in [25, 50, 100] {
        configs.push((format!("RBF map, {c} centres"), fit_opts(5, 3, 1, Dynamics::Rbf { centers: c }), 1.0));
    }
    let reps = if quick { 2 } else { 10 };
    let mut rows: Vec<FitBenchRow> = Vec::new();
    let mut rbf50 = None;
    for (label, o, frac) in &configs {
        progress(label);
        let tr: Vec<TimeSeries> = train
            .iter()
            .map(|s| {
                let n = ((s.x.len() as f64) * frac) as usize;
                TimeSeries::new(s.name.clone(), s.t[..n].to_vec(), s.x[..n].to_vec())
            })
            .collect::<Result<_, _>>()?;
        let (secs, m) = timed_fit(&tr, o, reps)?;
        let p = m.predict(test)?;
        let base = rows.first().map_or(s_to_ms(secs), |b| b.fit_ms);
        rows.push(FitBenchRow {
            setting: label.clone(),
            fit_ms: s_to_ms(secs),
            ratio_vs_baseline: s_to_ms(secs) / base,
            nmte_test: p.nmte(test),
            dtw_nmte_test: p.nmte_dtw(test, None),
            stopped: p.stop.as_ref().map(|s| format!("{:?}", s.reason)),
        });
        if matches!(o.dynamics, Dynamics::Rbf { centers: 50 }) {
            rbf50 = Some(m);
        }
    }
    Ok((rows, rbf50))
}
