//! The flag pipeline on a known chaotic system (`chaos_study::flag_pipeline`, docs/decisions/0002). Prints
//! only (timings are printed, never asserted). Run with
//!
//! ```text
//! cargo run --release -p lab --example flag_pipeline -- <subcommand>
//! ```
//!
//! - `scan`: known systems sampled like the flag (lag 11 at map step 4, the flag's lengths and
//!   noise): full-rate step, lag / Theiler window, D2 of the held-out series, its Rosenstein
//!   exponent, the exact exponent and the nats per lag. `FLAG4_SYSTEMS` selects systems by
//!   substring of their names; `FLAG4_L96=n:f,n:f` scans those Lorenz-96 systems instead.
//! - `fnn [ratio]`, `fnn-rule [csv]`: false nearest neighbours of the SSM projection and the
//!   dimension rule (`chaos_study::flag_pipeline_fit`).
//! - The candidate search on the chosen system at 1, 3 and 10 times the flag's training data and
//!   the diagnosis variants (`studies/results/flag/known_system.json`) are the spec
//!   `studies/flag-known-system.toml`, run by `ssmctl study` (`studies/README.md`).
//! - `flag SPEC..`: the specs on the inverted flag itself (train traj_9 + traj_7, held out
//!   traj_8, map step 4) with the Kaplan-Yorke dimension of each model and D2 of its series
//!   with the data's noise added (exploration; `ssmctl study studies/flag.toml` computes the
//!   study's rows, `studies/README.md`).

use chaos_study::flag_pipeline::{FLAG_LAYOUT, KnownSystem, known_stats};

fn scan() {
    let mut systems = vec![];
    for f in [10.0, 15.0, 20.0, 30.0] {
        systems.push(KnownSystem::Lorenz96 { n: 4, f });
    }
    for f in [8.0, 8.5, 9.0, 10.0, 12.0, 15.0, 20.0] {
        systems.push(KnownSystem::Lorenz96 { n: 5, f });
    }
    for (a, b, c) in [(0.2, 0.2, 5.7), (0.3, 0.1, 8.5), (0.38, 0.3, 4.82), (0.25, 0.4, 8.5)] {
        systems.push(KnownSystem::Rossler { a, b, c });
    }
    for c in [1.0, 4.0] {
        systems.push(KnownSystem::CoupledLorenz { c });
    }
    if let Ok(list) = std::env::var("FLAG4_L96") {
        // "n:f,n:f,..": Lorenz-96 systems only.
        systems = list
            .split(',')
            .filter_map(|p| p.split_once(':'))
            .filter_map(|(n, f)| Some(KnownSystem::Lorenz96 { n: n.trim().parse().ok()?, f: f.trim().parse().ok()? }))
            .collect();
    }
    let pick = std::env::var("FLAG4_SYSTEMS").ok();
    println!(
        "| system | dt | lag / Theiler | D2 | Rosenstein [1/s] | exact [1/s] | nats per lag | D2 over 8 pieces: mean ± sd (values) | Rosenstein / exact over the pieces | s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for s in systems {
        if let Some(p) = &pick
            && !p.split(',').any(|q| s.name().contains(q))
        {
            continue;
        }
        let t0 = std::time::Instant::now();
        match known_stats(&s, &FLAG_LAYOUT, 1, 4000.0) {
            Ok((k, _)) => {
                let seg = chaos_study::flag_pipeline::segment_stats(&s, k.dt, &FLAG_LAYOUT, 8);
                let o = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
                let (d2s, ratios) = match &seg {
                    Ok(g) => (
                        format!(
                            "{} ± {} ({})",
                            o(g.corr_dim_mean),
                            o(g.corr_dim_sd),
                            g.corr_dims.iter().map(|d| o(*d)).collect::<Vec<_>>().join(", ")
                        ),
                        g.rosensteins.iter().map(|r| o(r.map(|r| r / k.exact))).collect::<Vec<_>>().join(", "),
                    ),
                    Err(e) => (format!("error: {e}"), String::new()),
                };
                println!(
                    "| {} | {:.5} | {} / {} | {:.2} ± {:.2} | {:.3} | {:.4} ± {:.4} | {:.3} | {d2s} | {ratios} | {:.1} |",
                    k.system,
                    k.dt,
                    k.lag,
                    k.theiler,
                    k.corr_dim,
                    k.corr_dim_err,
                    k.rosenstein,
                    k.exact,
                    k.exact_err,
                    k.per_lag,
                    t0.elapsed().as_secs_f64()
                )
            }
            Err(e) => println!("| {} | error: {e} |", s.name()),
        }
    }
}

/// A candidate spec: tokens separated by spaces: `cN` RBF centres (`c0`: polynomial map of
/// order 4), `rX` ridge, `dN` SSM dimension, `pN` embedding, `sN` shift, `hN` multistep
/// horizon (with `tN` window stride, `iN` LM iterations per stage), `wN` denoised inputs,
/// `gCHOICE` the RBF centre choice (`ssm::dynamics::CentreChoice::parse`: `grandom@3`,
/// `gkmeans++@1`, `gkmeans10@2`, `gfarthest@5`).
fn parse_spec(spec: &str, step: usize) -> Option<chaos_study::model_selection::Candidate> {
    let (mut c, mut r, mut d, mut p, mut s, mut h, mut t, mut it, mut w) =
        (200usize, 3e-9, 4usize, 9usize, 1usize, 0usize, 4usize, 10usize, 0usize);
    let mut centres = ssm::dynamics::CentreChoice::Farthest;
    for tok in spec.split_whitespace() {
        if let Some(g) = tok.strip_prefix('g') {
            centres = ssm::dynamics::CentreChoice::parse(g).ok()?;
            continue;
        }
        let (k, v) = tok.split_at(1);
        match k {
            "c" => c = v.parse().ok()?,
            "r" => r = v.parse().ok()?,
            "d" => d = v.parse().ok()?,
            "p" => p = v.parse().ok()?,
            "s" => s = v.parse().ok()?,
            "h" => h = v.parse().ok()?,
            "t" => t = v.parse().ok()?,
            "i" => it = v.parse().ok()?,
            "w" => w = v.parse().ok()?,
            _ => return None,
        }
    }
    let ms = (h > 0).then_some(ssm::multistep::MultiStep { horizon: h, stride: t, iterations: it });
    let mut cand = chaos_study::flag_pipeline_fit::variant(step, c, r, d, p, s, ms, w);
    if centres != ssm::dynamics::CentreChoice::Farthest {
        cand.name += &format!(" centres {}", centres.name());
        cand.centres = centres;
    }
    Some(cand)
}

/// `flag SPEC..`: the candidates (specs of [`parse_spec`], map step 4) on the inverted flag
/// itself (train traj_9 + traj_7, held out traj_8), with diagnostics of the dimension: per
/// row Benettin, Rosenstein, D2, JS, the Kaplan-Yorke dimension of the model's Lyapunov
/// spectrum, and D2 of the model series with white noise of the data's level added
/// (`noisy D2`); first the data's D2 raw and after 3- and 5-point moving averages.
/// `FLAG12_QUIET_DATA=1` skips the data lines.
fn flag_rows(specs: &[String]) {
    use chaos::add_noise;
    use chaos_study::model_selection::{EvalSettings, data_stats, evaluate_candidate_fitted, moving_average};
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/inverted_flag_chaotic");
    let load = |k: usize| ssm::load_csv(dir.join(format!("traj_{k}.csv")));
    let (Ok(a), Ok(b), Ok(test)) = (load(9), load(7), load(8)) else {
        return println!("SKIP: inverted-flag data not found under {}", dir.display());
    };
    let train = [a, b];
    let s = EvalSettings::default();
    let t0 = std::time::Instant::now();
    let data = match data_stats(&test, 4, &s) {
        Ok(d) => d,
        Err(e) => return println!("data: error: {e}"),
    };
    let (ds, ctx) = &data;
    let d2 = |x: &[f64]| {
        chaos::delay_embed(x, ctx.embed, ctx.lag)
            .and_then(|p| {
                chaos::correlation_dimension(
                    &p,
                    &chaos::CorrSumParams { theiler: ctx.theiler, ..Default::default() },
                    &chaos::ScalingRule::default(),
                )
            })
            .map(|c| (c.dimension, c.slope_std))
            .ok()
    };
    let o2 = |v: Option<(f64, f64)>| v.map_or("-".to_string(), |(a, b)| format!("{a:.2} ± {b:.2}"));
    println!(
        "data (traj_8 /4): Rosenstein {:.3}, D2 {:.2} ± {:.2}, noise sd {:.5} (lag {}, Theiler {}, embed {}; {:.1} s)",
        ds.lle,
        ds.corr_dim,
        ds.corr_dim_err,
        ds.noise_sd,
        ctx.lag,
        ctx.theiler,
        ctx.embed,
        t0.elapsed().as_secs_f64()
    );
    if std::env::var("FLAG12_QUIET_DATA").is_err() {
        let x4 =
            |ts: &ssm::TimeSeries| chaos_study::model_selection::subsample(ts, 4, 0).map(|t| t.x).unwrap_or_default();
        for w in [1, 2] {
            if let Ok(sm) = moving_average(&test, w) {
                println!("data smoothed ({} points, full rate): D2 {}", 2 * w + 1, o2(d2(&x4(&sm))));
            }
        }
        // The data's noise added to the data again: how much D2 moves with the noise.
        let x = x4(&test);
        println!("data + its noise level again: D2 {}", o2(d2(&add_noise(&x, ds.noise_sd, 7))));
        // Every run of the flag at step 4 through the same estimator (traj_8's lag, Theiler
        // window and embedding): the spread of D2 over runs of the same system.
        let runs: Vec<String> =
            (0..10).map(|k| load(k).map_or("-".to_string(), |ts| format!("traj_{k} {}", o2(d2(&x4(&ts)))))).collect();
        println!("D2 of every run: {}", runs.join("; "));
    }
    println!(
        "| candidate | Benettin | Rosenstein | D2 | JS | KY dim | spectrum | noisy D2 | D2 of 5 pieces of the long run | targets B/R/D2/JS | failed | s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    let targets = chaos::Targets::default();
    for spec in specs {
        let Some(c) = parse_spec(spec, 4) else {
            println!("bad spec `{spec}`");
            continue;
        };
        let t1 = std::time::Instant::now();
        let (r, m) = match evaluate_candidate_fitted(&train, &test, &c, &data, &s) {
            Ok(v) => v,
            Err(e) => {
                println!("| {} | error: {e} |", c.name);
                continue;
            }
        };
        let (mut ky, mut spec_s, mut noisy, mut pieces) =
            ("-".to_string(), "-".to_string(), "-".to_string(), "-".to_string());
        if let (Some(m), None) = (&m, &r.failed) {
            let eta = chaos_study::microchaos::reduce_series(
                m,
                &chaos_study::model_selection::subsample(&test, 4, 0).expect("subsample"),
            )
            .unwrap_or_default();
            let d = m.options.dim;
            if eta.len() >= d {
                let eta0 = &eta[..d];
                if let Ok(l) = chaos_study::lyapunov::model_lyapunov(m, eta0, s.benettin_transient, s.benettin_steps) {
                    ky = l.kaplan_yorke.map_or("-".into(), |v| format!("{v:.2}"));
                    spec_s = l.spectrum.iter().map(|v| format!("{v:.2}")).collect::<Vec<_>>().join(" ");
                }
                let n = eta.len() / d;
                if let Ok(orbit) = chaos_study::lyapunov::iterate_dynamics(
                    &m.dynamics,
                    eta0,
                    n * s.long_runs,
                    chaos_study::lyapunov::model_bound(m),
                    1,
                ) && let Some(pts) = orbit.recorded
                {
                    let mut lifted = vec![0.0; m.manifold.p];
                    let mut ps = ssm::poly::PolyScratch::default();
                    let x: Vec<f64> = (0..pts.len())
                        .map(|i| {
                            m.manifold.lift_into(pts.point(i), &mut ps, &mut lifted);
                            lifted[0]
                        })
                        .collect();
                    noisy = o2(d2(&add_noise(&x[..n.min(x.len())], ds.noise_sd, 1)));
                    pieces = x
                        .chunks_exact(n)
                        .map(|p| d2(p).map_or("-".to_string(), |(v, _)| format!("{v:.2}")))
                        .collect::<Vec<_>>()
                        .join(", ");
                }
            }
        }
        let o = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |v| format!("{v:.p$}"));
        println!(
            "| {} | {} | {} | {} | {} | {ky} | {spec_s} | {noisy} | {pieces} | {} | {} | {:.0} |",
            c.name,
            o(r.benettin, 3),
            o(r.rosenstein, 3),
            o(r.corr_dim, 2),
            o(r.js, 4),
            r.passes(&targets).iter().map(|&p| if p { "y" } else { "n" }).collect::<String>(),
            r.failed.as_deref().map_or("", |f| f.split(':').next().unwrap_or(f)),
            t1.elapsed().as_secs_f64()
        );
    }
}

/// `fnn`: false nearest neighbours of the projection, noise-free and at the flag's noise,
/// for embeddings (9, 1), (9, 2), (9, 3), (11, 1), (13, 1); neighbours false beyond `ratio` (default 10).
fn fnn(ratio: f64) {
    for noise in [0.0, FLAG_LAYOUT.noise_rel] {
        let layout = chaos_study::flag_pipeline::FlagLayout { noise_rel: noise, ..FLAG_LAYOUT };
        let (k, series) = match known_stats(&chaos_study::flag_pipeline::CHOSEN, &layout, 1, 100.0) {
            Ok(v) => v,
            Err(e) => return println!("error: {e}"),
        };
        let x = chaos_study::flag_pipeline_fit::held_out_at_step(&series, layout.step).expect("held-out");
        // The first training piece at phase 0 (3,231 points) as well.
        let tr = chaos_study::model_selection::subsample(&series[0], layout.step, 0).expect("train");
        for (name, ts) in [("held-out", &x), ("train #0", &tr)] {
            for (p, s) in [(9, 1), (9, 2), (9, 3), (11, 1), (13, 1)] {
                match chaos_study::flag_pipeline_fit::projection_fnn(
                    &ts.x,
                    p,
                    s,
                    k.theiler,
                    &(2..p.min(9)).collect::<Vec<_>>(),
                    ratio,
                    800,
                ) {
                    Ok(rows) => println!(
                        "noise {noise} {name} p={p} s={s}: {}",
                        rows.iter()
                            .map(|r| format!("d{} sv {:.1e} fnn {:.3}", r.dim, r.singular_rel, r.fnn))
                            .collect::<Vec<_>>()
                            .join("; ")
                    ),
                    Err(e) => println!("error: {e}"),
                }
            }
        }
    }
}

/// `fnn-rule [CSV]`: the dimension rule ([`chaos_study::flag_pipeline_fit::fnn_dimension`] with
/// [`chaos_study::flag_pipeline_fit::FNN_RULE`]) at map step 4 on the known system's first
/// training series, or on the series in CSV (the flag: traj_9).
fn fnn_rule(path: Option<&String>) {
    let ts = match path {
        Some(p) => ssm::load_csv(p).expect("csv"),
        None => known_stats(&chaos_study::flag_pipeline::CHOSEN, &FLAG_LAYOUT, 1, 100.0).expect("series").1.remove(0),
    };
    let x = chaos_study::model_selection::subsample(&ts, FLAG_LAYOUT.step, 0).expect("subsample");
    let ctx = chaos::Context::from_series(&x.x, x.dt().unwrap_or(1.0), 6).expect("context");
    let (ratio, max_fnn) = chaos_study::flag_pipeline_fit::FNN_RULE;
    match chaos_study::flag_pipeline_fit::fnn_dimension(&x.x, 1, ctx.theiler, ratio, max_fnn, 8, 800) {
        Ok((d, rows)) => println!(
            "{}: lag {} Theiler {}; chosen d = {d:?}; {}",
            ts.name,
            ctx.lag,
            ctx.theiler,
            rows.iter()
                .map(|r| format!("d{} (p {}) fnn {:.4}", r.dim, 2 * r.dim + 1, r.fnn))
                .collect::<Vec<_>>()
                .join("; ")
        ),
        Err(e) => println!("error: {e}"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("scan") => scan(),
        Some("flag") => flag_rows(&args[1..]),
        Some("fnn-rule") => fnn_rule(args.get(1)),
        Some("fnn") => fnn(args.get(1).and_then(|s| s.parse().ok()).unwrap_or(10.0)),
        _ => eprintln!(
            "usage: flag_pipeline scan | fnn [ratio] | fnn-rule [csv] | flag SPEC.. (the check and diagnosis rows: ssmctl study studies/flag-known-system.toml)"
        ),
    }
}
