//! Explorations of the chaos study (`chaos_study::microchaos`, `chaos_study::chaos_tables`): model
//! settings on the measured inverted flag and on the simulated quantized Furuta loop. They
//! print only (nothing is checked; timings are printed, never asserted). Run with
//!
//! ```text
//! cargo run --release -p lab --example explore_chaos -- <subcommand>
//! ```
//!
//! Subcommands (the former `#[ignore]` test names):
//!
//! - `flag-models`: the default analysis on the inverted flag (traj_9 + traj_7, or all ten
//!   runs) for each configuration in `CHAOS_EXPLORE` (see [`explore_flag_models`]); one
//!   line per configuration: SSM dim, data LLE, the models' Rosenstein/Benettin/JS columns,
//!   time and notes. Prints nothing without `CHAOS_EXPLORE`.
//! - `scale-and-cost-tables`: the report's scale-dependence rows (simulated quantized loop,
//!   30,000 periods, and the flag) and accuracy-vs-cost rows (flag: RBF centres 50..500,
//!   polynomial orders 2..5), then the default flag analysis as JSON. Long (minutes).
//! - `simulated-quantized`: the default analysis trained on two simulated quantized runs
//!   (30,000 periods each); `CHAOS_SIM_DIM` and `CHAOS_SIM_SHIFT` override the SSM dimension
//!   and shift. Prints D2, the data LLE and the model columns.
//! - `quantized-models`: model fits on the simulated quantized loop for each configuration
//!   in `CHAOS_Q` (default `d=6`; see [`explore_quantized_models`]): data statistics, then per
//!   model Rosenstein, Benettin spectrum, JS, fit and evaluation time, linear rates; with
//!   `kick=f` the residual-kicked model and windowed Rosenstein slopes, with `diag=1` spectra
//!   and local D2 slopes.
//! - `quantized-data-scales`: Kantz's exponent of the held-out quantized run against the
//!   scale (multiples of the series sd, subsampled /1 and /3, and of the encoder step h);
//!   `CHAOS_Q_N` periods (default 30,000).
//! - `flag-window-slopes`: windowed Rosenstein slopes of the inverted flag's traj_8.
//! - The candidate search of `studies/results/flag/search.json` is the spec
//!   `studies/flag-first-search.toml`, run by `ssmctl study` (`studies/README.md`).
//! - `flag-embedding`: the embedding from the data: average mutual information against the
//!   lag and false nearest neighbours against the dimension (traj_8, steps 1 and 4).
//!
//! The flag data are read from `../shared/data/inverted_flag_chaotic` next to the workspace
//! (the subcommands that need them print `SKIP` when it is absent). Simulated quantized runs
//! are cached as CSV under `$TMPDIR/chaos-explore` (the simulation is deterministic).

use std::time::Instant;

use chaos::{BenettinParams, Context, benettin_qr, delay_embed, dimension_rule};
use chaos_study::chaos_tables::{CostStudy, ScaleStudy, flag_cost_study, scale_dependence, scale_studies};
use chaos_study::lyapunov::model_bound;
use chaos_study::microchaos::{
    ChaosOptions, ChaosSummary, analyse, evaluate_model, fit_options, reduce_series, simulate_scene,
};
use sim::scene::SceneBuilder;
use ssm::dynamics::StepScratch;
use ssm::tangent::map_jacobian;
use ssm::{Dynamics, SsmModel, TimeSeries, fit};

const USAGE: &str = "usage: explore_chaos <flag-models | scale-and-cost-tables | simulated-quantized | quantized-models | quantized-data-scales | flag-window-slopes | flag-embedding>";

fn main() {
    match std::env::args().nth(1).as_deref() {
        Some("flag-models") => explore_flag_models(),
        Some("scale-and-cost-tables") => bench_scale_and_cost_tables(),
        Some("simulated-quantized") => explore_simulated_quantized(),
        Some("quantized-models") => explore_quantized_models(),
        Some("quantized-data-scales") => explore_quantized_data_scales(),
        Some("flag-window-slopes") => explore_flag_window_slopes(),
        Some("flag-embedding") => explore_flag_embedding(),
        _ => {
            eprintln!("{USAGE}");
            std::process::exit(2);
        }
    }
}

// ========================================================================== subcommands

/// The embedding from the data (traj_8, at map steps 1 and 4): the first minimum of the
/// average mutual information (32-bin histograms) against the lag, and Kennel's false
/// nearest neighbours (R_tol = 15, A_tol = 2, 2000 reference points, brute force) against
/// the embedding dimension at that lag.
fn explore_flag_embedding() {
    let Some(mut v) = flag(&[8]) else { return };
    let ts = v.pop().unwrap();
    for k in [1usize, 4] {
        let x: Vec<f64> = ts.x.iter().step_by(k).copied().collect();
        let (lo, hi) = x.iter().fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(*v), b.max(*v)));
        let bins = 32usize;
        let bin = |v: f64| (((v - lo) / (hi - lo) * bins as f64) as usize).min(bins - 1);
        let ami = |lag: usize| {
            let n = x.len() - lag;
            let mut pxy = vec![0.0; bins * bins];
            let (mut px, mut py) = (vec![0.0; bins], vec![0.0; bins]);
            for i in 0..n {
                let (a, b) = (bin(x[i]), bin(x[i + lag]));
                pxy[a * bins + b] += 1.0;
                px[a] += 1.0;
                py[b] += 1.0;
            }
            let nf = n as f64;
            let mut s = 0.0;
            for a in 0..bins {
                for b in 0..bins {
                    let p = pxy[a * bins + b] / nf;
                    if p > 0.0 {
                        s += p * (p / (px[a] / nf * py[b] / nf)).log2();
                    }
                }
            }
            s
        };
        let curve: Vec<f64> = (0..=200 / k).map(ami).collect();
        let first_min =
            (1..curve.len() - 1).find(|&l| curve[l] < curve[l - 1] && curve[l] <= curve[l + 1]).unwrap_or(0);
        let ctx = Context::from_series(&x, ts.dt().unwrap() * k as f64, 6).unwrap();
        println!(
            "step {k}: AMI first minimum at lag {first_min} ({:.3} s, {:.2} bits); autocorrelation zero at lag {}, dominant period {} samples",
            first_min as f64 * ts.dt().unwrap() * k as f64,
            curve[first_min],
            ctx.lag,
            ctx.theiler
        );
        for lag in [first_min.max(1), 1] {
            let mut line = format!("  FNN at lag {lag}:");
            for m in 1..=8usize {
                let n = x.len() - m * lag;
                let pt = |i: usize, j: usize| x[i + j * lag];
                let refs: Vec<usize> = (0..n).step_by((n / 2000).max(1)).collect();
                let mut false_nn = 0usize;
                let sd = sd_of(&x);
                for &i in &refs {
                    let mut best = (f64::MAX, 0usize);
                    for j in 0..n {
                        if (i as isize - j as isize).unsigned_abs() <= ctx.theiler.min(20) {
                            continue;
                        }
                        let d2: f64 = (0..m).map(|c| (pt(i, c) - pt(j, c)).powi(2)).sum();
                        if d2 < best.0 && d2 > 0.0 {
                            best = (d2, j);
                        }
                    }
                    let dist = best.0.sqrt();
                    let extra = (pt(i, m) - pt(best.1, m)).abs();
                    if extra / dist > 15.0 || (best.0 + extra * extra).sqrt() / sd > 2.0 {
                        false_nn += 1;
                    }
                }
                line.push_str(&format!(" m={m}: {:.1} %", 100.0 * false_nn as f64 / refs.len() as f64));
            }
            println!("{line}");
        }
    }
}

/// Exploration of model settings on the inverted flag (prints only). Configurations in
/// `CHAOS_EXPLORE` separated by `;`, each a comma list of `key=value`: the model keys of
/// [`model_key`], and `all=1` to train on all ten runs instead of traj_9 + traj_7.
fn explore_flag_models() {
    let Some(two) = flag(&[9, 7]) else { return };
    let all = flag(&[9, 7, 3, 8, 0, 6, 4, 5, 2, 1]).unwrap();
    let spec = std::env::var("CHAOS_EXPLORE").unwrap_or_default();
    for cfg in spec.split(';').filter(|s| !s.is_empty()) {
        let mut o = ChaosOptions::default();
        let mut train = &two;
        for kv in cfg.split(',') {
            let (k, v) = kv.split_once('=').unwrap();
            if model_key(&mut o, k, v) {
                continue;
            }
            match k {
                "all" => train = &all,
                _ => panic!("{k}"),
            }
        }
        let t0 = Instant::now();
        match analyse(train, &o) {
            Ok(r) => println!(
                "{cfg:<28} d{} data {:.3} | {} | {:.1}s | {}",
                r.ssm_dim,
                r.lle_data,
                model_columns(&r),
                t0.elapsed().as_secs_f64(),
                r.notes.join("; ").chars().take(300).collect::<String>()
            ),
            Err(e) => println!("{cfg}: {e}"),
        }
    }
}

/// The scale and accuracy-vs-cost tables as a criterion-free bench print (timings are
/// printed, never asserted). The rows are those of `ssmctl`'s report tables, one line each.
fn bench_scale_and_cost_tables() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    let t0 = Instant::now();
    let studies = scale_studies(&data, 30000).unwrap();
    println!("scale dependence ({:.1} s)", t0.elapsed().as_secs_f64());
    print_scale_rows(&studies);
    for s in &studies {
        println!(
            "{}: {} samples, lag {}, Theiler {}, curve {} samples",
            s.name, s.samples, s.lag, s.theiler, s.max_steps
        );
    }
    if let Some(st) = flag_cost_study(&data).unwrap() {
        println!("accuracy vs cost, data LLE {:.3} 1/s", st.lle_data);
        print_cost_rows(&st);
    }
    if let Some(train) = flag(&[9, 7]) {
        let r = analyse(&train, &ChaosOptions::default()).unwrap();
        println!("{}", serde_json::to_string_pretty(&r).unwrap());
    }
}

/// The default analysis on the simulated quantized loop (prints only).
fn explore_simulated_quantized() {
    let train: Vec<TimeSeries> = [0.02, 0.035]
        .iter()
        .enumerate()
        .map(|(i, th)| chaos_study::microchaos::simulate_quantized(30000, *th, &format!("sim #{i}")).unwrap())
        .collect();
    let mut o = ChaosOptions::default();
    if let Ok(v) = std::env::var("CHAOS_SIM_DIM") {
        o.ssm_dim = Some(v.parse().unwrap());
    }
    if let Ok(v) = std::env::var("CHAOS_SIM_SHIFT") {
        o.shift = Some(v.parse().unwrap());
    }
    let r = analyse(&train, &o).unwrap();
    println!(
        "sim: D2 {:.2}+-{:.2} d{} shift {} data {:.3} | {} | {:.1}s | {}",
        r.corr_dim,
        r.corr_dim_err,
        r.ssm_dim,
        r.ssm_shift,
        r.lle_data,
        model_columns(&r),
        r.seconds,
        r.notes.join("; ")
    );
}

/// Model exploration on the simulated quantized loop (prints only). Configurations in
/// `CHAOS_Q` separated by `;`, each a comma list of `key=value`: `d` SSM dim, `c` RBF
/// centres, `r` ridge, `s` shift, `p` embedding, `m` manifold order, `k` map order, `sub`
/// subsampling factor (map step `sub` x 25 ms), `n` periods per run, `kd` derivative gain,
/// `noise=1` the sensor-noise scene, `a` linear anchor, `only` rbf|poly, `diag=1` spectra
/// and local D2 slopes of data and model series, `kick=f` the model driven by its own
/// one-step residuals scaled by `f` (see [`kicked_model`]) with windowed Rosenstein slopes
/// of data and kicked series.
fn explore_quantized_models() {
    let spec = std::env::var("CHAOS_Q").unwrap_or_else(|_| "d=6".into());
    for cfg in spec.split(';').filter(|s| !s.trim().is_empty()) {
        let mut o = ChaosOptions::default();
        let (mut sub, mut periods, mut kd, mut scene, mut anchor, mut only, mut diag) =
            (1usize, 30000usize, None::<f64>, "furuta-quant-dt25", None, None::<String>, false);
        let mut kick = None;
        for kv in cfg.split(',') {
            let (k, v) = kv.trim().split_once('=').unwrap();
            if model_key(&mut o, k, v) {
                continue;
            }
            match k {
                "sub" => sub = v.parse().unwrap(),
                "n" => periods = v.parse().unwrap(),
                "kd" => kd = Some(v.parse().unwrap()),
                "noise" => scene = "furuta-quant-dt25-noise",
                "a" => anchor = Some(v.parse::<f64>().unwrap()),
                "only" => only = Some(v.to_string()),
                "diag" => diag = v == "1",
                "kick" => kick = Some(v.parse::<f64>().unwrap()),
                _ => panic!("unknown key {k}"),
            }
        }
        let t0 = Instant::now();
        let (train, test) = quant_runs(scene, kd, periods);
        let sim_s = t0.elapsed().as_secs_f64();
        let train: Vec<TimeSeries> = train.iter().map(|t| subsample(t, sub)).collect();
        let test = subsample(&test, sub);
        let dt = test.dt().unwrap();
        let ctx = Context::from_series(&test.x, dt, o.gp_embed).unwrap();
        let pts = delay_embed(&test.x, o.gp_embed, ctx.lag).unwrap();
        let cd = chaos::correlation_dimension(
            &pts,
            &chaos::CorrSumParams { theiler: ctx.theiler, ..Default::default() },
            &chaos::ScalingRule::default(),
        )
        .unwrap();
        let d = o.ssm_dim.unwrap_or_else(|| dimension_rule(cd.dimension, cd.slope_std).unwrap());
        let mut notes = Vec::new();
        let (lle_data, win) = ctx.lle(&test.x, &mut notes, "data").unwrap();
        let mut base = fit_options(&o, d, &ctx);
        base.linear_anchor = anchor;
        println!(
            "== {cfg}: sim {sim_s:.0}s, dt {:.3}s, {} test samples, sd {:.2e}, lag {} Theiler {}, D2 {:.2}+-{:.2}, d {d}, p {} shift {}, data LLE {lle_data:.3} (window {:.2}..{:.2}s)",
            dt,
            test.x.len(),
            sd_of(&test.x),
            ctx.lag,
            ctx.theiler,
            cd.dimension,
            cd.slope_std,
            base.embed,
            base.shift,
            win.0,
            win.1
        );
        if diag {
            println!("   data spectrum {} | D2 slopes {}", spectral_peaks(&test.x, dt), d2_profile(&test.x, &ctx));
        }
        for (name, dynamics) in [("rbf", Dynamics::Rbf { centers: o.centers }), ("poly", Dynamics::Map)] {
            if only.as_deref().is_some_and(|w| w != name) {
                continue;
            }
            let mut opts = base;
            opts.dynamics = dynamics;
            let t1 = Instant::now();
            let m = match fit(&train, &opts) {
                Ok(m) => m,
                Err(e) => {
                    println!("   {name}: fit failed: {e}");
                    continue;
                }
            };
            let fit_s = t1.elapsed().as_secs_f64();
            let s = evaluate_model(&m, &test, &ctx, &o, name).unwrap();
            let spec = s
                .benettin
                .as_ref()
                .map_or("-".into(), |b| b.spectrum.iter().map(|v| format!("{v:.3}")).collect::<Vec<_>>().join(","));
            let rates: Vec<String> = m.eigenvalues_ct().iter().map(|(re, im)| format!("{re:.2}{:+.1}i", im)).collect();
            println!(
                "   {name:<4} R {} B {} [{spec}] JS {} | fit {fit_s:.1}s eval {:.1}s | lin {} | {}",
                fmt_opt(s.lle_rosenstein, 4),
                fmt_opt(s.benettin.as_ref().map(|b| b.exponent), 4),
                fmt_opt(s.js, 3),
                t1.elapsed().as_secs_f64() - fit_s,
                rates.join(" "),
                s.notes.join("; ").chars().take(200).collect::<String>()
            );
            if let Some(f) = kick {
                let (r, js, rms, rds, xk) = kicked_model(&m, &train, &test, &ctx, f, 1);
                let rds = rds.map_or("-".into(), |v| v.iter().map(|x| format!("{x:.3}")).collect::<Vec<_>>().join(","));
                println!(
                    "        kicked (residual bootstrap x{f}, residual rms {rms:.2e}): R {} JS {} | Benettin along kicked orbit [{rds}]",
                    fmt_opt(r, 4),
                    fmt_opt(js, 3)
                );
                println!("        windowed Rosenstein slopes, data:   {}", window_slopes(&test.x, &ctx));
                println!("        windowed Rosenstein slopes, kicked: {}", window_slopes(&xk, &ctx));
            }
            if diag {
                let p = m.predict(&test).unwrap();
                if p.x.len() > 20 * ctx.theiler {
                    println!(
                        "        model spectrum {} | sd {:.2e} | D2 slopes {}",
                        spectral_peaks(&p.x, dt),
                        sd_of(&p.x),
                        d2_profile(&p.x, &ctx)
                    );
                }
            }
        }
    }
}

/// The held-out quantized data's Kantz exponent against the scale (multiples of the series'
/// standard deviation and of the encoder count h), prints only.
fn explore_quantized_data_scales() {
    let periods = std::env::var("CHAOS_Q_N").map_or(30000, |v| v.parse().unwrap());
    let (_, test) = quant_runs("furuta-quant-dt25", None, periods);
    let dt = test.dt().unwrap();
    let sd = sd_of(&test.x);
    let h = std::f64::consts::PI / 1000.0;
    let mut studies = Vec::new();
    for k in [1usize, 3] {
        let x = subsample(&test, k);
        studies.push(
            scale_dependence(
                &format!("quant /{k} (sd)"),
                &x.x,
                dt * k as f64,
                6,
                "sd",
                sd,
                &[0.01, 0.03, 0.1, 0.2, 0.4],
            )
            .unwrap(),
        );
    }
    studies.push(scale_dependence("quant (h)", &test.x, dt, 6, "h", h, &[0.1, 0.3, 1.0, 3.0]).unwrap());
    println!("quantized data, sd {sd:.3e}");
    print_scale_rows(&studies);
}

/// Windowed Rosenstein slopes of the inverted-flag data (measured chaos) for comparison
/// with the quantized loop (prints only).
fn explore_flag_window_slopes() {
    let Some(v) = flag(&[8]) else { return };
    let ts = &v[0];
    let ctx = Context::from_series(&ts.x, ts.dt().unwrap(), 6).unwrap();
    println!("flag traj_8 (Theiler {}): {}", ctx.theiler, window_slopes(&ts.x, &ctx));
}

// ============================================================================== helpers

fn fmt_opt(v: Option<f64>, prec: usize) -> String {
    v.map_or("-".into(), |x| format!("{x:.prec$}"))
}

/// One line per scale of each study: data, eps, eps in units, unit, Kantz exponent, fit
/// window, rise, mean neighbours, note (the columns of the report's scale table).
fn print_scale_rows(studies: &[ScaleStudy]) {
    for s in studies {
        for r in &s.rows {
            println!(
                "  {}  eps {:.3e} = {:.3} x {}  LLE {}  window {}  rise {}  neighbours {:.1}  {}",
                s.name,
                r.eps,
                r.eps_units,
                s.unit_name,
                fmt_opt(r.exponent, 3),
                r.window_s.map_or("-".into(), |(a, b)| format!("{a:.2}..{b:.2}")),
                fmt_opt(r.rise, 2),
                r.mean_neighbours,
                r.note
            );
        }
    }
}

/// One line per model configuration (the columns of the report's accuracy-vs-cost table).
fn print_cost_rows(st: &CostStudy) {
    for r in &st.rows {
        println!(
            "  {:<4} {:>4}  R {}  |R - data| {}  B {}  JS {}  fit {:.3} s  step {:.2} us  ratios fit {:.2} step {:.2}  {}",
            r.kind,
            r.setting,
            fmt_opt(r.lle_rosenstein, 3),
            fmt_opt(r.lle_abs_error, 3),
            fmt_opt(r.lle_benettin, 3),
            fmt_opt(r.pdf_js, 3),
            r.fit_s,
            r.step_us,
            r.fit_ratio,
            r.step_ratio,
            r.notes.join("; ")
        );
    }
}

/// The smooth model driven by its own one-step residuals: the residual vectors
/// `eta_{n+1} - F(eta_n)` of the training data are resampled at random (xorshift, `seed`),
/// scaled by `f` and added after each map step, from the held-out data's first point over
/// its length. Returns the Rosenstein exponent (settings of `ctx`) of the lifted first
/// delay coordinate, the mean PDF divergence against the held-out reduced coordinates, the
/// residual rms, the Benettin spectrum along a kicked orbit and the lifted series. Tests
/// whether the data's exponent is the smooth torus plus the quantization kicks.
#[allow(clippy::type_complexity)]
fn kicked_model(
    m: &SsmModel,
    train: &[TimeSeries],
    test: &TimeSeries,
    ctx: &Context,
    f: f64,
    seed: u64,
) -> (Option<f64>, Option<f64>, f64, Option<Vec<f64>>, Vec<f64>) {
    let d = m.options.dim;
    let mut sc = StepScratch::default();
    let mut res = Vec::new();
    for ts in train {
        let e = reduce_series(m, ts).unwrap();
        for w in e.chunks_exact(d).collect::<Vec<_>>().windows(2) {
            let mut x = w[0].to_vec();
            m.dynamics.step(&mut x, m.dt, &mut sc);
            res.extend(w[1].iter().zip(&x).map(|(a, b)| a - b));
        }
    }
    let nres = res.len() / d;
    let rms = (res.iter().map(|v| v * v).sum::<f64>() / nres as f64).sqrt();
    let eta_test = reduce_series(m, test).unwrap();
    let n = eta_test.len() / d;
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut rnd = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut eta = eta_test[..d].to_vec();
    let mut etas = Vec::with_capacity(n * d);
    let mut x = Vec::with_capacity(n);
    let mut lifted = vec![0.0; m.manifold.p];
    let mut ps = ssm::poly::PolyScratch::default();
    let bound = model_bound(m);
    for _ in 0..n {
        if !eta.iter().all(|v| v.is_finite() && v.abs() <= bound) {
            break;
        }
        etas.extend_from_slice(&eta);
        m.manifold.lift_into(&eta, &mut ps, &mut lifted);
        x.push(lifted[0]);
        m.dynamics.step(&mut eta, m.dt, &mut sc);
        let k = (rnd() % nres as u64) as usize;
        for (e, r) in eta.iter_mut().zip(&res[k * d..(k + 1) * d]) {
            *e += f * r;
        }
    }
    // Benettin along a kicked orbit (random-map exponent): the kick is additive, so the
    // tangent map is the smooth map's Jacobian at each state.
    let bp = BenettinParams { transient: 5000, steps: 50_000, time_step: m.dt, renorm_every: 1, bound, blocks: 20 };
    let mut sc2 = StepScratch::default();
    let fk = |a: &[f64], out: &mut [f64]| {
        out.copy_from_slice(a);
        m.dynamics.step(out, m.dt, &mut sc2);
        let k = (rnd() % nres as u64) as usize;
        for (e, r) in out.iter_mut().zip(&res[k * d..(k + 1) * d]) {
            *e += f * r;
        }
    };
    let rds = benettin_qr(&eta_test[..d], fk, |a, j| map_jacobian(&m.dynamics, a, j), d, &bp).ok().map(|r| r.exponents);
    let mut notes = Vec::new();
    let lle = ctx.lle(&x, &mut notes, "kicked").ok().map(|v| v.0);
    let js = chaos::Points::from_flat(d, eta_test)
        .and_then(|a| chaos::compare_pdfs(&a, &chaos::Points::from_flat(d, etas)?, chaos::Bins::default()))
        .ok()
        .map(|c| c.mean_js_bits);
    (lle, js, rms, rds, x)
}

/// Applies one `key=value` of the exploration configurations that sets a model option
/// (`d` SSM dim, `c` centres, `r` ridge, `s` shift, `p` embedding, `m` manifold order, `k`
/// map order); false for other keys.
fn model_key(o: &mut ChaosOptions, k: &str, v: &str) -> bool {
    match k {
        "d" => o.ssm_dim = Some(v.parse().unwrap()),
        "c" => o.centers = v.parse().unwrap(),
        "r" => o.ridge = v.parse().unwrap(),
        "s" => o.shift = Some(v.parse().unwrap()),
        "p" => o.embed = Some(v.parse().unwrap()),
        "m" => o.manifold_order = v.parse().unwrap(),
        "k" => o.poly_order = v.parse().unwrap(),
        _ => return false,
    }
    true
}

/// The model columns of the exploration prints: Rosenstein, Benettin and JS per model.
fn model_columns(r: &ChaosSummary) -> String {
    format!(
        "rbf R {} B {} JS {} | poly R {} B {} JS {}",
        fmt_opt(r.lle_model_rbf, 3),
        fmt_opt(r.lle_model_rbf_benettin, 3),
        fmt_opt(r.pdf_divergence_rbf, 3),
        fmt_opt(r.lle_model_poly, 3),
        fmt_opt(r.lle_model_poly_benettin, 3),
        fmt_opt(r.pdf_divergence_poly, 3)
    )
}

fn flag_dir() -> Option<std::path::PathBuf> {
    let d = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/inverted_flag_chaotic");
    if d.join("traj_9.csv").is_file() {
        Some(d)
    } else {
        println!("SKIP: inverted-flag data not found under {} (the shared data folder is absent)", d.display());
        None
    }
}

fn flag(files: &[usize]) -> Option<Vec<TimeSeries>> {
    let d = flag_dir()?;
    Some(files.iter().map(|k| ssm::load_csv(d.join(format!("traj_{k}.csv"))).unwrap()).collect())
}

/// Three runs (theta(0) = 0.02, 0.035, 0.05) of `scene` (derivative gain `kd` if set),
/// `periods` each: the first two train, the third is held out. Cached as CSV in the temp
/// folder (the simulation is deterministic, so a cache hit is the same data).
fn quant_runs(scene: &str, kd: Option<f64>, periods: usize) -> (Vec<TimeSeries>, TimeSeries) {
    let dir = std::env::temp_dir().join("chaos-explore");
    std::fs::create_dir_all(&dir).unwrap();
    let tag: String = format!("{scene}-{}-{periods}", kd.map_or(String::new(), |v| format!("controller.kd={v}")))
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '.' || c == '-' { c } else { '_' })
        .collect();
    let mut runs: Vec<TimeSeries> = [0.02, 0.035, 0.05]
        .iter()
        .enumerate()
        .map(|(i, th)| {
            let path = dir.join(format!("{tag}-{i}.csv"));
            if let Ok(ts) = ssm::load_csv(&path) {
                return ts;
            }
            let mut builder = SceneBuilder::load(scene).unwrap();
            if let Some(v) = kd {
                builder = builder.kd(v);
            }
            let ts = simulate_scene(builder, periods, *th, &format!("{scene} #{i}")).unwrap();
            let mut text = String::from("t,x\n");
            for (t, x) in ts.t.iter().zip(&ts.x) {
                text.push_str(&format!("{t:e},{x:e}\n"));
            }
            std::fs::write(&path, text).unwrap();
            ts
        })
        .collect();
    let test = runs.pop().unwrap();
    (runs, test)
}

/// Every `k`-th sample of `ts` (map step `k dt`).
fn subsample(ts: &TimeSeries, k: usize) -> TimeSeries {
    TimeSeries::new(
        format!("{} /{k}", ts.name),
        ts.t.iter().step_by(k).copied().collect(),
        ts.x.iter().step_by(k).copied().collect(),
    )
    .unwrap()
}

/// The three largest local maxima of the amplitude spectrum of `x` (Hz, amplitude).
fn spectral_peaks(x: &[f64], dt: f64) -> String {
    let (f, a) = ssm::metrics::amplitude_spectrum(x, dt);
    let mut peaks: Vec<(f64, f64)> =
        (1..a.len().saturating_sub(1)).filter(|&i| a[i] > a[i - 1] && a[i] >= a[i + 1]).map(|i| (f[i], a[i])).collect();
    peaks.sort_by(|p, q| q.1.total_cmp(&p.1));
    peaks.iter().take(3).map(|(f, a)| format!("{f:.2}Hz:{a:.1e}")).collect::<Vec<_>>().join(" ")
}

/// Local correlation-dimension slopes of `x` (embedding `embed`, lag/Theiler of `ctx`) at
/// radii spaced by half a decade, largest first, as "r/diam:slope".
fn d2_profile(x: &[f64], ctx: &Context) -> String {
    let pts = delay_embed(x, ctx.embed, ctx.lag).unwrap();
    let c = chaos::correlation_sum(
        &pts,
        &chaos::CorrSumParams { theiler: ctx.theiler, max_reference: 1500, ..Default::default() },
    )
    .unwrap();
    let n = c.radius.len();
    (0..n)
        .rev()
        .step_by(10)
        .skip(1)
        .filter(|&i| c.count[i] >= 100)
        .map(|i| format!("{:.0e}:{:.2}", c.radius[i] / c.diameter, c.local_slope[i]))
        .collect::<Vec<_>>()
        .join(" ")
}

fn sd_of(x: &[f64]) -> f64 {
    let m = x.iter().sum::<f64>() / x.len() as f64;
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / x.len() as f64).sqrt()
}

/// Slopes of the Rosenstein curve of `x` (settings of `ctx`) over the time windows
/// [t, 2t] for t = 0.125, 0.25, ... s, each as "t..2t: slope (2t x slope)". An exponential
/// separation has a constant slope; a power law (distance ~ t^a) has secant slope
/// a ln 2 / t, so the product stays at 2 a ln 2 (0.69 for a diffusing phase, a = 1/2).
fn window_slopes(x: &[f64], ctx: &Context) -> String {
    let pts = delay_embed(x, ctx.embed, ctx.lag).unwrap();
    let c = chaos::rosenstein_curve(&pts, &ctx.divergence_params()).unwrap();
    let at = |t: f64| c.time.iter().position(|&s| s >= t - 1e-12);
    let mut out = Vec::new();
    let mut t = 0.125;
    while let (Some(a), Some(b)) = (at(t), at(2.0 * t)) {
        let slope = (c.mean_log_distance[b] - c.mean_log_distance[a]) / (c.time[b] - c.time[a]);
        out.push(format!("{t}..{}: {slope:.3} ({:.2})", 2.0 * t, 2.0 * t * slope));
        t *= 2.0;
    }
    out.join(" | ")
}
