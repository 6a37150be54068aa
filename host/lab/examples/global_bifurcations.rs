//! The science of the global bifurcations: prints, not a test.
//! `cargo run --profile test -p lab --example global_bifurcations -- SUBCOMMAND ...`:
//! * `convergence ORDER DT...`: invariance and reduced-dynamics errors of the
//!   equation-driven SSM against the exact period map on spheres of 0.05-0.2 rad
//!   (`furuta::convergence`).
//! * `cycles MODE ORDER DT...`: the full system's saddle cycle of `MODE` (invariant circle
//!   of the exact period map, continuation over the DTs in order) next to the
//!   equation-driven model's (`furuta::saddle_cycles`).
//! * `fit VARIANT...`: trains the data-driven model per variant (see [`variant`]), prints its
//!   bifurcation values, its saddle cycles next to the full system's and its cubic and
//!   quintic coefficients next to the equation-driven ones.
//! * `mapswitch [--periods N] VARIANT...`: the small-start switch of the fitted map itself
//!   (shared-tangent model, `bifurcations::map_small_start_switch`, 31.0-32.0 ms, bisection
//!   to 0.005 ms) per variant (`default` or a sensitivity variant, see [`variant`]), with
//!   direct runs on both sides of the bracket.
//! * `mapglobal [--full] [--periods N] VARIANT...`: the saddle connection of the fitted map by
//!   the fate of the fast saddle cycle's pushed unstable branch (`map_global::map_connection`,
//!   linear and spline in dt) and its torus loss by continuation, per variant; `--full` also
//!   the full system's connection by the same rule.
//! * `mapcycles DT...`: slow and fast saddle cycles of the fitted map (`fitted_map_cycle`
//!   on `model_at(dt)`) next to the full system's.
//! * `torus [--periods N] [--variant V] [--settle DT0 N0] DT...`: the full system and the
//!   fitted map from the same start, slow/fast amplitudes per tenth of the run.
//! * `fullcont PERIODS DT...`: the full system's torus continuation, step by step.
//! * `maptorus VARIANT...`: the fitted map's torus continuation per training variant.
//! * `coeffs VARIANT...`: data-driven vs equation-driven polar coefficients at the training dts.
//! * `fhcoeffs VARIANT...`: the same on the first-harmonic basis (both sides' rho the
//!   observable's first harmonic), next to the linear-row basis and the shared-tangent map's.
//! * `fhsplit VARIANT`: the per-period fit's cubic gap on the first-harmonic basis split
//!   by tangent (own SVD, own + degree-1 normal part, pooled) and the map's row weight.
//! * `eqbasis ORDER DT...`: the first-harmonic normal form of the equation-driven model's own
//!   reduced map against its `Amplitude::Observable` coefficients.
//! * `ratefun [VARIANT]`: their nonlinear amplitude rates at a few amplitude points.
//! * `cuts [--conn] [--steps] [--spline] [--cubic] [--notorus] VARIANT...`: the fitted map's
//!   torus onset and loss (and saddle connection; its cubic terms on the first-harmonic basis
//!   against the equation-driven ones) per training variant on shared training runs (issue
//!   11's cut and cubic).
//! * `fhmix CUT`: the fitted map's cubic with its manifold and/or its map refitted on runs cut
//!   at CUT rad (which half bends `rho_1^3`).

use furuta::bifurcations::{model_row, sensitivity_variants};
use furuta::convergence::furuta_convergence;
use furuta::equation_ssm::coefficient_comparison;
use furuta::parametric::{FurutaOptions, furuta_parametric};
use furuta::saddle_cycles::{CircleOptions, fitted_map_cycle, model_cycle, saddle_cycles};

type R = Result<(), Box<dyn std::error::Error>>;

fn convergence(args: &[String]) -> R {
    let order: u32 = args.first().ok_or("convergence ORDER DT...")?.parse()?;
    for dt in &args[1..] {
        let t0 = std::time::Instant::now();
        let c = furuta_convergence(dt.parse()?, order)?;
        println!("{}({:.1} s)\n", c.to_text(), t0.elapsed().as_secs_f64());
    }
    Ok(())
}

fn cycles(args: &[String]) -> R {
    let usage = "cycles MODE ORDERS(e.g. 5,7,9) [--n N] [--data] DT...";
    let mode: usize = args.first().ok_or(usage)?.parse()?;
    let orders: Vec<u32> = args.get(1).ok_or(usage)?.split(',').map(|s| s.parse()).collect::<Result<_, _>>()?;
    let mut opts = CircleOptions::default();
    let mut data = false;
    let mut dts: Vec<f64> = Vec::new();
    let mut it = args[2..].iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--n" => opts.n = it.next().ok_or(usage)?.parse()?,
            "--data" => data = true,
            x => dts.push(x.parse()?),
        }
    }
    let t0 = std::time::Instant::now();
    let pm = if data { Some(furuta_parametric(&FurutaOptions::default())?) } else { None };
    let rows = saddle_cycles(&dts, mode, &orders, &opts)?;
    println!(
        "mode {mode}: full system (invariant circle of the exact period map, n = {}) vs equation-driven orders {orders:?} (rho*, theta first harmonic){}",
        opts.n,
        if data { " and data-driven rho*" } else { "" }
    );
    for r in rows {
        let f = r.full.as_ref();
        let mut line = format!(
            "{:<6} full theta1 {:>8} f {:>8} Hz (res {:>7}, mid {:>7}, {} steps)",
            r.dt_ms,
            f.map_or("-".into(), |c| format!("{:.5}", c.theta_amplitude)),
            f.map_or("-".into(), |c| format!("{:.4}", c.freq_hz)),
            f.map_or("-".into(), |c| format!("{:.0e}", c.residual)),
            f.map_or("-".into(), |c| format!("{:.0e}", c.residual_midpoints)),
            f.map_or("-".into(), |c| c.newton_steps.to_string()),
        );
        for e in &r.equation {
            line.push_str(&format!(
                " | eq{} rho* {} th1 {} f {}",
                e.order,
                e.rho.map_or("-".into(), |x| format!("{x:.5}")),
                e.theta_amplitude.map_or("-".into(), |x| format!("{x:.5}")),
                e.freq_hz.map_or("-".into(), |x| format!("{x:.4}"))
            ));
        }
        if let Some(pm) = &pm {
            let c = model_cycle(&pm.normal_form_at(r.dt_ms)?, mode)?;
            line.push_str(&format!(
                " | data rho* {} f {}",
                c.as_ref().map_or("-".into(), |c| format!("{:.5}", c.rho[mode - 1])),
                c.as_ref().map_or("-".into(), |c| format!("{:.4}", c.freqs_hz[mode - 1]))
            ));
        }
        if let Some(w) = &r.full_failure {
            line.push_str(&format!(" [{w}]"));
        }
        println!("{line}");
    }
    println!("({:.1} s)", t0.elapsed().as_secs_f64());
    Ok(())
}

/// Training variants: a base (`default`, or a sensitivity variant's name with spaces as
/// `_`, e.g. `cut_0.3_rad`) and modifiers joined by `+`: `slowsaddle` (slow-eigenvector
/// starts 0.06-0.14 rad, inside the slow saddle cycle), `slowcycle` (0.12-0.135 rad, just inside it at 32.5 ms), `joint` (anchor_joint), `man5` (manifold order 5), `dyn5`,
/// `dyn9` (dynamics order), `noweight` (the fitted map's regression unweighted), `knee=THETA`,
/// `pow=P` (its row weight, see `furuta::parametric::map_row_weight`), `nolow` (the map
/// without its low-degree first stage, the default before docs/decisions/0001's cubic fix),
/// `low=DEG:KNEE[:POWER]` (that stage's degrees and knee in rad of theta), `mknee=THETA` /
/// `nomweight` (the shared model's manifold regression weighted at that knee / unweighted),
/// `ridge=ALPHA` (a fixed relative ridge).
fn variant(name: &str) -> Result<FurutaOptions, Box<dyn std::error::Error>> {
    let mut parts = name.split('+');
    let base = parts.next().unwrap_or("default");
    let mut o = if base == "default" {
        FurutaOptions::default()
    } else {
        sensitivity_variants()
            .into_iter()
            .find(|(n, _)| n.replace(' ', "_") == base)
            .ok_or(format!("unknown base variant {base}"))?
            .1
    };
    for m in parts {
        match m {
            "slowsaddle" => o.slow_starts.extend([(0.06, 0.4), (0.1, 1.3), (0.14, 2.2)]),
            "slowcycle" => o.slow_starts.extend([(0.12, 0.4), (0.13, 1.3), (0.135, 2.2)]),
            "joint" => o.fit.anchor_joint = true,
            "dyn5" => o.fit.dyn_order = 5,
            "man5" => o.fit.manifold_order = 5,
            "dyn9" => o.fit.dyn_order = 9,
            "noweight" => o.map_weight = None,
            "noanchor" => o.fit.linear_anchor = None,
            x if x.starts_with("mknee=") => {
                o.manifold_weight = Some(furuta::parametric::map_row_weight(
                    x[6..].parse()?,
                    o.fit.embed,
                    furuta::parametric::MAP_WEIGHT_POWER,
                ))
            }
            "nomweight" => o.manifold_weight = None,
            "nolow" => {
                if let Some(w) = o.map_weight.as_mut() {
                    w.low_degrees = None;
                }
            }
            x if x.starts_with("low=") => {
                // low=DEG:KNEE_THETA[:POWER]: the map's low-degree first stage.
                let v: Vec<&str> = x[4..].split(':').collect();
                let knee =
                    furuta::parametric::map_row_weight(v.get(1).ok_or("low=DEG:KNEE")?.parse()?, o.fit.embed, 32.0)
                        .knee;
                let power = v.get(2).map_or(Ok(32.0), |p| p.parse())?;
                let w = o.map_weight.get_or_insert(furuta::parametric::map_row_weight(
                    furuta::parametric::MAP_WEIGHT_KNEE_THETA,
                    o.fit.embed,
                    furuta::parametric::MAP_WEIGHT_POWER,
                ));
                w.low_degrees = Some(ssm::LowDegreeStage { max_degree: v[0].parse()?, knee, power });
            }
            x if x.starts_with("ridge=") => o.fit.ridge = ssm::ridge::Ridge::Fixed(x[6..].parse()?),
            "slowmid" => o.slow_starts.extend([(0.02, 0.4), (0.04, 1.3), (0.06, 2.2), (0.08, 3.1)]),
            x if x.starts_with("embed=") => o.fit.embed = x[6..].parse()?,
            x if x.starts_with("cut=") => o.max_theta = x[4..].parse()?,
            x if x.starts_with("man=") => o.fit.manifold_order = x[4..].parse()?,
            x if x.starts_with("dyn=") => o.fit.dyn_order = x[4..].parse()?,
            x if x.starts_with("knee=") || x.starts_with("pow=") => {
                let v: f64 = x.split('=').nth(1).unwrap_or("").parse()?;
                let w = o.map_weight.get_or_insert(furuta::parametric::map_row_weight(
                    furuta::parametric::MAP_WEIGHT_KNEE_THETA,
                    o.fit.embed,
                    furuta::parametric::MAP_WEIGHT_POWER,
                ));
                if x.starts_with("knee=") {
                    *w = ssm::RowWeight {
                        low_degrees: w.low_degrees,
                        ..furuta::parametric::map_row_weight(v, o.fit.embed, w.power)
                    };
                } else {
                    w.power = v;
                }
            }
            x => return Err(format!("unknown modifier {x}").into()),
        }
    }
    Ok(o)
}

/// Full-system slow saddle cycle, theta first harmonic (rad), from `cycles 1 ... --n 65`.
const FULL_SLOW_CYCLE: [(f64, f64); 3] = [(31.0, 0.17016), (31.3, 0.16505), (31.6, 0.15975)];

/// Full-system slow saddle cycle at the training periods: (dt ms, theta first harmonic rad,
/// frequency Hz), from `cycles 1 3,5,7,9 --n 65`.
const FULL_SLOW_CYCLE_TRAINING: [(f64, f64, f64); 4] =
    [(30.5, 0.17830, 0.5455), (31.0, 0.17016, 0.5362), (32.0, 0.15231, 0.5173), (32.5, 0.14230, 0.5074)];

fn fit(args: &[String]) -> R {
    for name in args {
        let o = variant(name)?;
        let t0 = std::time::Instant::now();
        let pm = furuta_parametric(&o)?;
        let secs = t0.elapsed().as_secs_f64();
        let row = model_row(name, &o, &pm, Some(secs))?;
        println!(
            "\n== {name}: fit {secs:.0} s; saddle connection {:?} ms, torus Hopf {:?} ms, small-start switch {:?} ms, torus at 30.8 {:?}",
            row.heteroclinic_dt_ms, row.torus_hopf_dt_ms, row.small_start_switch_dt_ms, row.torus_30p8_rho
        );
        for (dt, full) in FULL_SLOW_CYCLE {
            let nf = pm.normal_form_at(dt)?;
            let c1 = model_cycle(&nf, 1)?.map(|c| c.rho[0]);
            let c2 = model_cycle(&nf, 2)?.map(|c| c.rho[1]);
            println!("  {dt} ms: slow saddle cycle rho* {c1:?} (full system theta1 {full}), fast cycle rho* {c2:?}");
        }
        // The fitted reduced maps themselves (no normal form) at the training periods.
        for t in &pm.trained {
            let Some(&(_, full, f_hz)) = FULL_SLOW_CYCLE_TRAINING.iter().find(|x| x.0 == t.dt_ms) else { continue };
            let opts = CircleOptions { n: 65, ..CircleOptions::default() };
            let omega0 = std::f64::consts::TAU * f_hz * t.dt_ms * 1e-3;
            match fitted_map_cycle(&t.model, 1, full, omega0, &opts) {
                Ok(c) => println!(
                    "  {} ms fitted map's slow cycle: theta1 {:.5} f {:.4} Hz (residual {:.0e}, {} steps); full system theta1 {full} f {f_hz}",
                    t.dt_ms, c.theta_amplitude, c.freq_hz, c.residual, c.newton_steps
                ),
                Err(e) => println!("  {} ms fitted map's slow cycle: not found ({e})", t.dt_ms),
            }
        }
        let rows = coefficient_comparison(&[31.0, 31.5], 5, |dt| pm.normal_form_at(dt))?;
        for r in rows.iter().filter(|r| r.degree >= 3) {
            println!(
                "  {} ms rho_{}' {:<16} eq {:>10.4} data {:>10.4} rel {:+.3}",
                r.dt_ms,
                r.mode,
                r.monomial,
                r.equation,
                r.data.unwrap_or(f64::NAN),
                r.rel_diff.unwrap_or(f64::NAN)
            );
        }
    }
    Ok(())
}

/// CPU seconds (user + system) of this process so far, from /proc/self/stat (Linux; 0 elsewhere).
fn cpu_s() -> f64 {
    let s = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let f: Vec<&str> = s.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

fn mapswitch(args: &[String]) -> R {
    use furuta::bifurcations::{map_outcome, map_small_start_switch};
    use furuta::full_system::{DEFAULT_SCAN_PERIODS, ESCAPE_THETA, default_ics};
    let mut periods = DEFAULT_SCAN_PERIODS;
    let mut names = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--periods" => periods = it.next().ok_or("--periods N")?.parse()?,
            x => names.push(x.to_string()),
        }
    }
    for name in &names {
        let o = variant(name)?;
        let t0 = std::time::Instant::now();
        let c0 = cpu_s();
        let sm = furuta::shared_tangent::shared_parametric(&o)?;
        let fit_s = t0.elapsed().as_secs_f64();
        println!("{name}: shared fit {:.1} s CPU", cpu_s() - c0);
        for interp in [ssm::interp::Interp::Linear, ssm::interp::Interp::Spline] {
            let (t1, c1) = (std::time::Instant::now(), cpu_s());
            let sw = map_small_start_switch(|dt| sm.model_at(dt, interp), default_ics, 31.0, 32.0, 11, periods, 0.005)?;
            println!(
                "{name} {interp:?}: map switch {:?} ms (fit {fit_s:.0} s, scan {:.1} s wall {:.1} s CPU, {} runs), grid escapes {:?}, monotone {}",
                sw.bracket,
                t1.elapsed().as_secs_f64(),
                cpu_s() - c1,
                sw.evaluations,
                sw.grid.iter().map(|g| g.1).collect::<Vec<_>>(),
                sw.monotone
            );
            if let Some((a, b)) = sw.bracket {
                for dt in [a, b] {
                    let m = sm.model_at(dt, interp)?;
                    let outs: Vec<String> = default_ics(dt)?
                        .iter()
                        .map(|ic| {
                            map_outcome(&m, dt, ic, periods, ESCAPE_THETA)
                                .map(|o| o.escape_t.map_or(format!("B({:.3})", o.max_theta), |t| format!("E@{t:.0}s")))
                        })
                        .collect::<Result<_, _>>()?;
                    println!("   direct at {dt:.4} ms: {}", outs.join(" "));
                }
            }
        }
    }
    Ok(())
}

fn mapglobal(args: &[String]) -> R {
    use furuta::map_global::{ConnectionOptions, full_connection, map_connection, map_torus_continuation};
    let mut o = ConnectionOptions::default();
    let mut full = false;
    let mut names = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--periods" => o.periods = it.next().ok_or("--periods N")?.parse()?,
            "--full" => full = true,
            x => names.push(x.to_string()),
        }
    }
    if full {
        let (t, c) = (std::time::Instant::now(), cpu_s());
        let f = full_connection(31.0, 32.0, 11, 0.005, &o)?;
        println!(
            "full system connection {:?} ({:.0} s wall, {:.0} s CPU, {} runs) grid {:?}",
            f.switch.bracket,
            t.elapsed().as_secs_f64(),
            cpu_s() - c,
            f.switch.evaluations,
            f.switch.grid
        );
    }
    let dts: Vec<f64> = (0..=14).map(|k| ((31.3 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
    for name in &names {
        let v = variant(name)?;
        let sm = furuta::shared_tangent::shared_parametric(&v)?;
        for interp in [ssm::interp::Interp::Linear, ssm::interp::Interp::Spline] {
            let (t, c) = (std::time::Instant::now(), cpu_s());
            let m = map_connection(|dt| Ok(sm.model_at(dt, interp)?), 31.0, 32.0, 11, 0.005, &o)?;
            let (t2, c2) = (std::time::Instant::now(), cpu_s());
            let tc = map_torus_continuation(|dt| Ok(sm.model_at(dt, interp)?), &dts, [0.097, 0.0277], 16_000)?;
            println!(
                "{name} {interp:?}: map connection {:?} ({:.1} s wall {:.1} s CPU) grid {:?}; torus lost {:?} ({:.1} s CPU)",
                m.switch.bracket,
                t.elapsed().as_secs_f64(),
                c2 - c,
                m.switch.grid,
                tc.lost_between,
                cpu_s() - c2
            );
            let _ = t2;
        }
    }
    Ok(())
}

fn mapcycles(args: &[String]) -> R {
    let dts: Vec<f64> = args.iter().map(|a| a.parse()).collect::<Result<_, _>>()?;
    let t0 = std::time::Instant::now();
    let sm = furuta::shared_tangent::shared_parametric(&FurutaOptions::default())?;
    let opts = CircleOptions { n: 65, ..CircleOptions::default() };
    println!("fit {:.0} s", t0.elapsed().as_secs_f64());
    for mode in [1usize, 2] {
        let t1 = std::time::Instant::now();
        let full = saddle_cycles(&dts, mode, &[7], &opts)?;
        println!("mode {mode}: full system {:.0} s", t1.elapsed().as_secs_f64());
        for r in &full {
            let Some(fc) = &r.full else {
                println!("{:6} mode {mode}: full not found {:?}", r.dt_ms, r.full_failure);
                continue;
            };
            let m = sm.model_at(r.dt_ms, ssm::interp::Interp::Linear)?;
            let line = match fitted_map_cycle(&m, mode, fc.theta_amplitude, fc.omega, &opts) {
                Ok(c) => format!(
                    "map theta1 {:.5} f {:.4} Hz (res {:.0e}) rel {:+.4}",
                    c.theta_amplitude,
                    c.freq_hz,
                    c.residual,
                    c.theta_amplitude / fc.theta_amplitude - 1.0
                ),
                Err(e) => format!("map: not found ({e})"),
            };
            println!(
                "{:6} mode {mode}: full theta1 {:.5} f {:.4} Hz | {line}",
                r.dt_ms, fc.theta_amplitude, fc.freq_hz
            );
        }
    }
    Ok(())
}

/// Slow/fast amplitudes of a primary-angle series (one sample per period `h` s) at the
/// spectral peaks of its last third (the exact linear frequencies when a band has none), as
/// `basin::torus_step` measures them.
fn torus_amps(theta: &[f64], h: f64, dt_ms: f64) -> Result<Vec<(f64, [f64; 2])>, Box<dyn std::error::Error>> {
    let lin = furuta::parametric::exact_modes(dt_ms)?.freqs_hz;
    let split = (lin[0] * lin[1]).sqrt();
    let last = &theta[2 * theta.len() / 3..];
    let freqs = match (ssm::spectrum::band_peak(last, h, 0.0, split), ssm::spectrum::band_peak(last, h, split, 0.5 / h))
    {
        (Some(a), Some(b)) => [a.freq_hz, b.freq_hz],
        _ => lin,
    };
    Ok(ssm::spectrum::mode_amplitudes(theta, h, freqs, furuta::full_system::AMP_WINDOW_S)?)
}

/// One line per tenth of the amplitude series: mean rho_1, its spread, mean rho_2.
fn torus_tenths(label: &str, theta: &[f64], h: f64, dt_ms: f64, escape: Option<f64>) -> R {
    let a = torus_amps(theta, h, dt_ms)?;
    let n = a.len();
    let mut out = format!("{label:>6} esc {:>8}", escape.map_or("-".into(), |t| format!("{t:.0}s")));
    if n >= 10 {
        for k in 0..10 {
            let seg = &a[k * n / 10..(k + 1) * n / 10];
            let m1 = seg.iter().map(|x| x.1[0]).sum::<f64>() / seg.len() as f64;
            let (lo, hi) =
                seg.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), x| (l.min(x.1[0]), h.max(x.1[0])));
            let m2 = seg.iter().map(|x| x.1[1]).sum::<f64>() / seg.len() as f64;
            out += &format!(" | {m1:.4} ±{:.4} {m2:.4}", 0.5 * (hi - lo));
        }
    }
    println!("{out}");
    Ok(())
}

/// `torus [--periods N] [--variant V] [--settle DT0 N0] DT...`: from the mode start (0.097,
/// 0.0277) rad, phases 0, at each DT (or from the end of N0 periods at DT0 from it), the full system and the fitted map (linear and spline in dt, from
/// the full system's first delay vector): escape time, and per tenth of the run the slow
/// amplitude's mean and half-spread and the fast amplitude's mean.
///
/// Measured (default variant): from the mode start, 16,000 periods, the full system and the
/// map agree at 31.4-31.8 ms to 1e-4 rad in the means and 1e-3 in the half-spreads (31.8: both
/// grow, 0.0059 -> 0.0142 full, 0.0059 -> 0.0156 linear). With `--settle 31.6 48000`, 64,000
/// periods from the settled torus (half-spread 0.0013): at 31.7 the full system decays
/// (0.0013 -> 0.0011), the map stays (linear 0.0013) or decays (spline 0.0012 -> 0.0009); at
/// 31.75 all grow (0.0020 -> 0.0089 full, -> 0.0128 linear, -> 0.0080 spline); at 31.8 all
/// escape (full 1519 s, linear 1403 s, spline 1548 s), at 31.85 after 955 / 926 / 946 s.
fn torus(args: &[String]) -> R {
    use furuta::full_system::{ESCAPE_THETA, run, start_from_rho};
    let mut periods = 16_000u64;
    let mut name = "default".to_string();
    let mut settle = None;
    let mut dts = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--periods" => periods = it.next().ok_or("--periods N")?.parse()?,
            "--variant" => name = it.next().ok_or("--variant V")?.clone(),
            "--settle" => {
                settle = Some((
                    it.next().ok_or("--settle DT N")?.parse::<f64>()?,
                    it.next().ok_or("--settle DT N")?.parse::<u64>()?,
                ))
            }
            x => dts.push(x.parse::<f64>()?),
        }
    }
    // With `--settle DT N`: every run starts from the end of N periods at DT from the mode start.
    let settled = match settle {
        Some((dt0, n0)) => {
            let (x, hist) = start_from_rho(dt0, [0.097, 0.0277], [0.0, 0.0])?;
            let tr = run(dt0, &(x, Some(hist)), n0, ESCAPE_THETA)?;
            let delay = sim::scene::SceneBuilder::load("furuta-dt30.5")?.dt_ms(dt0).build()?.controller.delay as usize;
            torus_tenths(&format!("settle {dt0}"), &tr.primary(), tr.dt, dt0, None)?;
            Some(furuta::full_system::end_start(&tr, delay)?)
        }
        None => None,
    };
    let c0 = cpu_s();
    let sm = furuta::shared_tangent::shared_parametric(&variant(&name)?)?;
    println!("fit {:.0} s CPU; columns: per tenth of the run, rho_1 mean ± half-spread, rho_2 mean", cpu_s() - c0);
    let rows: Vec<Result<Vec<(String, Vec<f64>, f64, Option<f64>)>, String>> = {
        use rayon::prelude::*;
        dts.par_iter()
            .map(|&dt| -> Result<_, Box<dyn std::error::Error + Send + Sync>> {
                let start = match &settled {
                    Some(s) => s.clone(),
                    None => {
                        let (x, hist) = start_from_rho(dt, [0.097, 0.0277], [0.0, 0.0])?;
                        (x, Some(hist))
                    }
                };
                let c = cpu_s();
                let tr = run(dt, &start, periods, ESCAPE_THETA)?;
                let full_cpu = cpu_s() - c;
                let esc = if tr.stopped.is_some() { tr.t.last().copied() } else { None };
                let mut out = vec![(format!("full {dt}"), tr.primary(), tr.dt, esc)];
                let _ = full_cpu;
                for interp in [ssm::interp::Interp::Linear, ssm::interp::Interp::Spline] {
                    let m = sm.model_at(dt, interp)?;
                    let p = m.manifold.p;
                    let h = m.dynamics.map_dt().ok_or("not a map")?;
                    let head = run(dt, &start, p as u64, f64::MAX)?.primary();
                    let mut eta = m.manifold.reduce(&head[..p]);
                    let (mut scratch, mut sc) =
                        (ssm::dynamics::StepScratch::default(), ssm::poly::PolyScratch::default());
                    let mut y = vec![0.0; p];
                    let mut theta = Vec::with_capacity(periods as usize + 1);
                    let mut esc = None;
                    for k in 0..=periods {
                        m.manifold.lift_into(&eta, &mut sc, &mut y);
                        if !(y[p - 1].abs() <= ESCAPE_THETA) {
                            esc = Some(k as f64 * h);
                            break;
                        }
                        theta.push(y[p - 1]);
                        m.dynamics.step(&mut eta, h, &mut scratch);
                    }
                    out.push((format!("{interp:?} {dt}"), theta, h, esc));
                }
                Ok(out)
            })
            .map(|r| r.map_err(|e| e.to_string()))
            .collect()
    };
    for (dt, r) in dts.iter().zip(rows) {
        let r: Vec<(String, Vec<f64>, f64, Option<f64>)> = r?;
        for (label, theta, h, esc) in r {
            torus_tenths(&label, &theta, h, *dt, esc)?;
        }
    }
    println!("total {:.0} s CPU", cpu_s() - c0);
    Ok(())
}

/// `fullcont PERIODS DT...`: the full system's torus continuation (`basin::torus_continuation`
/// from (0.097, 0.0277) rad) over the DTs, each step printed.
fn fullcont(args: &[String]) -> R {
    let periods: u64 = args.first().ok_or("fullcont PERIODS DT...")?.parse()?;
    let dts: Vec<f64> = args[1..].iter().map(|a| a.parse()).collect::<Result<_, _>>()?;
    let c0 = cpu_s();
    let c = furuta::basin::torus_continuation(&dts, [0.097, 0.0277], periods)?;
    for s in &c.steps {
        println!(
            "{:6} esc {:?} rho {:?} spread mid {:?} last {:?} lost {}",
            s.dt_ms, s.escape_t, s.rho, s.spread_mid, s.spread_last, s.lost
        );
    }
    println!("lost between {:?} ({:.0} s CPU)", c.lost_between, cpu_s() - c0);
    Ok(())
}

/// `coeffs VARIANT...`: the data-driven polar coefficients (per training dt, the fit's own
/// normal form) next to the equation-driven ones (order 7) at the training dts, cubic and
/// quintic rows with relative differences.
fn coeffs(args: &[String]) -> R {
    for name in args {
        let v = variant(name)?;
        let c0 = cpu_s();
        let pm = furuta_parametric(&v)?;
        let rows = coefficient_comparison(&v.dts_ms, 7, |dt| pm.normal_form_at(dt))?;
        println!("{name} ({:.0} s CPU)", cpu_s() - c0);
        for r in rows.iter().filter(|r| r.degree >= 1 && r.degree <= 5) {
            println!(
                "  {} ms rho_{}' {:<16} eq {:>12.5} data {:>12.5} rel {:+.4}",
                r.dt_ms,
                r.mode,
                r.monomial,
                r.equation,
                r.data.unwrap_or(f64::NAN),
                r.rel_diff.unwrap_or(f64::NAN)
            );
        }
    }
    Ok(())
}

/// `fhcoeffs VARIANT...`: per training variant (see [`variant`]), each training period's
/// polar coefficients (cubic and quintic) on the linear-row basis (the report's data column)
/// and on the first-harmonic basis (`ssm::normal_form::Normalization::FirstHarmonic`, the
/// equation-driven model's definition of rho), and the shared-tangent fitted map's
/// (weighted regression) on the first-harmonic basis, each next to the equation-driven
/// order-7 value: `equation | row (rel) | first harmonic (rel) | shared map fh (rel)`.
fn fhcoeffs(args: &[String]) -> R {
    use ssm::normal_form::{NormalFormOptions, model_normal_form_first_harmonic};
    let dts = FurutaOptions::default().dts_ms;
    let eq: Vec<_> =
        dts.iter().map(|&dt| furuta::equation_ssm::furuta_equation_polar(dt, 7)).collect::<Result<_, _>>()?;
    for name in args {
        let v = variant(name)?;
        let c0 = cpu_s();
        let pm = furuta_parametric(&v)?;
        let sm = furuta::shared_tangent::shared_parametric(&v)?;
        println!("== {name} ({:.0} s CPU)", cpu_s() - c0);
        let mut worst: std::collections::BTreeMap<String, (f64, f64, f64)> = Default::default();
        for t in &pm.trained {
            let Some(k) = dts.iter().position(|d| *d == t.dt_ms) else { continue };
            let fh = model_normal_form_first_harmonic(&t.model, &NormalFormOptions::default())?;
            let smf = model_normal_form_first_harmonic(
                &sm.model_at(t.dt_ms, ssm::interp::Interp::Linear)?,
                &NormalFormOptions::default(),
            )?;
            let (row, fht, smt) = (t.normal_form.table(), fh.table(), smf.table());
            for r in eq[k]
                .table()
                .rows
                .iter()
                .filter(|r| r.rho_exps.iter().sum::<u32>() == 3 || r.rho_exps.iter().sum::<u32>() == 5)
            {
                let g = |tb: &ssm::normal_form::NormalFormTable| tb.get(r.mode, &r.monomial).unwrap_or(f64::NAN);
                let (a, b, c) = (g(&row), g(&fht), g(&smt));
                let rel = |x: f64| x / r.value - 1.0;
                println!(
                    "  {} ms rho_{}' {:<16} eq {:>11.4} | row {:>11.4} ({:+7.1} %) | fh {:>11.4} ({:+7.1} %) | shared fh {:>11.4} ({:+7.1} %)",
                    t.dt_ms,
                    r.mode,
                    r.monomial,
                    r.value,
                    a,
                    100.0 * rel(a),
                    b,
                    100.0 * rel(b),
                    c,
                    100.0 * rel(c)
                );
                let w = worst.entry(format!("rho_{}' {}", r.mode, r.monomial)).or_insert((0.0, 0.0, 0.0));
                *w = (w.0.max(rel(a).abs()), w.1.max(rel(b).abs()), w.2.max(rel(c).abs()));
            }
        }
        for (k, (a, b, c)) in &worst {
            println!(
                "  max |rel| {k:<24} row {:6.1} %  fh {:6.1} %  shared fh {:6.1} %",
                100.0 * a,
                100.0 * b,
                100.0 * c
            );
        }
    }
    Ok(())
}

/// `fhsplit VARIANT`: where the per-period fit's cubic gap comes from: each training period
/// fitted as a graph over (a) its own SVD tangent (the report's per-period fit), (b) its own
/// tangent with a degree-1 normal part (`fit_with_tangent`), (c) the tangent of all periods'
/// data pooled (the shared-tangent model, unweighted) and (d) the same with the map's row
/// weight (the fitted map); cubic coefficients on the first-harmonic basis, relative to the
/// equation-driven order-7 ones.
fn fhsplit(args: &[String]) -> R {
    use ssm::fit::{embed_training, fit, fit_with_tangent_weighted};
    use ssm::manifold::tangent_space;
    use ssm::normal_form::{NormalFormOptions, model_normal_form_first_harmonic};
    let v = variant(args.first().map_or("default", String::as_str))?;
    let series: Vec<_> =
        v.dts_ms.iter().map(|&dt| furuta::parametric::training_series(&v, dt)).collect::<Result<_, _>>()?;
    let mut pooled = Vec::new();
    for s in &series {
        pooled.extend(embed_training(s, &v.fit)?.0);
    }
    let (v1_pool, _) = tangent_space(&pooled, v.fit.dim)?;
    drop(pooled);
    for (dt, train) in v.dts_ms.iter().zip(&series) {
        let eq = furuta::equation_ssm::furuta_equation_polar(*dt, 7)?.table();
        let (v1_own, _) = tangent_space(&embed_training(train, &v.fit)?.0, v.fit.dim)?;
        let models = [
            ("own svd", fit(train, &v.fit)?),
            ("own+deg1", fit_with_tangent_weighted(train, &v.fit, &v1_own, None)?),
            ("pooled", fit_with_tangent_weighted(train, &v.fit, &v1_pool, None)?),
            ("pooled+weight", fit_with_tangent_weighted(train, &v.fit, &v1_pool, v.map_weight.as_ref())?),
        ];
        for (name, m) in &models {
            let t = model_normal_form_first_harmonic(m, &NormalFormOptions::default())?.table();
            let cells: Vec<String> = eq
                .rows
                .iter()
                .filter(|r| r.rho_exps.iter().sum::<u32>() == 3)
                .map(|r| {
                    format!(
                        "rho_{}' {} {:+.1} %",
                        r.mode,
                        r.monomial,
                        100.0 * (t.get(r.mode, &r.monomial).unwrap_or(f64::NAN) / r.value - 1.0)
                    )
                })
                .collect();
            println!("{dt} ms {name:<14} {}", cells.join(" | "));
        }
    }
    Ok(())
}

/// `eqbasis ORDER DT...`: the first-harmonic normal form applied to the equation-driven
/// model's own reduced map and observable (the spectral-normalized SSM, `MapSsm::real_form`)
/// against its `Amplitude::Observable` polar coefficients: largest relative difference.
fn eqbasis(args: &[String]) -> R {
    use furuta::equation_ssm::{polynomial_map, scene_period_map};
    use ssm::map_ssm::{Amplitude, MapSsmOptions, map_ssm};
    use ssm::normal_form::{NormalFormOptions, Normalization, normal_form_of_poly};
    let order: u32 = args.first().ok_or("eqbasis ORDER DT...")?.parse()?;
    for a in &args[1..] {
        let dt: f64 = a.parse()?;
        let scene = sim::scene::SceneBuilder::load("furuta-dt30.5")?.dt_ms(dt).build()?;
        let pm = scene_period_map(&scene, order, &sim::taylor::FlowOptions::default())?;
        let map = polynomial_map(&pm);
        let mut c = vec![0.0; pm.dim()];
        c[pm.primary] = 1.0;
        let o = MapSsmOptions {
            order,
            pairs: 2,
            resonance_tol: 1e-3,
            observable: c.clone(),
            dt: pm.dt,
            amplitude: Amplitude::Spectral,
        };
        let spec = map_ssm(&map, &o)?;
        let obs = map_ssm(&map, &MapSsmOptions { amplitude: Amplitude::Observable, ..o })?;
        let (inc, x) = spec.real_form(&c)?;
        let nf = normal_form_of_poly(
            &inc,
            Some(pm.dt),
            &NormalFormOptions {
                order: Some(order),
                small_divisor: 1e-3,
                normalization: Normalization::FirstHarmonic(x),
            },
        )?;
        let (a, b) = (nf.table(), obs.polar.table());
        let mut worst = 0.0f64;
        for r in &b.rows {
            let got = a.get(r.mode, &r.monomial).unwrap_or(f64::NAN);
            worst = worst.max((got / r.value - 1.0).abs());
            if r.rho_exps.iter().sum::<u32>() <= 5 {
                println!(
                    "  {dt} ms rho_{}' {:<16} observable {:>14.8} first harmonic of the spectral map {:>14.8}",
                    r.mode, r.monomial, r.value, got
                );
            }
        }
        println!("{dt} ms order {order}: largest relative difference {worst:.2e}");
    }
    Ok(())
}

/// `maptorus VARIANT...`: the fitted map's torus continuation (linear and spline in dt,
/// 31.3-32.0 ms by 0.05, 16,000 periods, the report's) per training variant.
fn maptorus(args: &[String]) -> R {
    use furuta::map_global::map_torus_continuation;
    let dts: Vec<f64> = (0..=14).map(|k| ((31.3 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
    for name in args {
        let sm = furuta::shared_tangent::shared_parametric(&variant(name)?)?;
        for interp in [ssm::interp::Interp::Linear, ssm::interp::Interp::Spline] {
            let c0 = cpu_s();
            let tc = map_torus_continuation(|dt| Ok(sm.model_at(dt, interp)?), &dts, [0.097, 0.0277], 16_000)?;
            let last = tc.steps.last().map(|s| (s.spread_mid, s.spread_last));
            println!(
                "{name} {interp:?}: torus lost {:?} (last step spreads {last:?}; {:.1} s CPU)",
                tc.lost_between,
                cpu_s() - c0
            );
        }
    }
    Ok(())
}

/// `ratefun VARIANT`: the nonlinear part of the amplitude rates `rho_i'/rho_i - linear`
/// (1/s) of the data-driven normal form (each training period's fit) and the equation-driven
/// ones (orders 7 and 9) at a few amplitude points, cubic terms alone and all terms.
fn ratefun(args: &[String]) -> R {
    let v = variant(args.first().map_or("default", String::as_str))?;
    let pm = furuta_parametric(&v)?;
    let pts = [(0.05, 0.01), (0.05, 0.03), (0.1, 0.01), (0.1, 0.0277), (0.15, 0.02)];
    for t in &pm.trained {
        let e7 = furuta::equation_ssm::furuta_equation_polar(t.dt_ms, 7)?;
        let e9 = furuta::equation_ssm::furuta_equation_polar(t.dt_ms, 9)?;
        let nl = |f: &ssm::normal_form::PolarNormalForm, mode: usize, r: [f64; 2], maxdeg: u32| -> f64 {
            f.table()
                .rows
                .iter()
                .filter(|row| row.mode == mode && (3..=maxdeg).contains(&row.rho_exps.iter().sum::<u32>()))
                .map(|row| {
                    row.value * r[0].powi(row.rho_exps[0] as i32) * r[1].powi(row.rho_exps[1] as i32) / r[mode - 1]
                })
                .sum()
        };
        for &(a, b) in &pts {
            let r = [a, b];
            let line: Vec<String> = [1usize, 2]
                .iter()
                .map(|&m| {
                    format!(
                        "rho_{m}: cubic data {:+.4} eq {:+.4} | all data {:+.4} eq7 {:+.4} eq9 {:+.4}",
                        nl(&t.normal_form, m, r, 3),
                        nl(&e7, m, r, 3),
                        nl(&t.normal_form, m, r, 99),
                        nl(&e7, m, r, 99),
                        nl(&e9, m, r, 99)
                    )
                })
                .collect();
            println!("{} ms ({a}, {b}): {}", t.dt_ms, line.join(" || "));
        }
    }
    Ok(())
}

/// `cuts [--conn] [--steps] [--spline] VARIANT...`: docs/decisions/0001's cut sensitivity in one process:
/// the training runs of every variant simulated once (`TrainingRuns`, as the report), then
/// per variant the shared-tangent map's torus continuation on the full report's grid
/// (31.3-32.0 ms by 0.05, 16,000 periods; linear in dt, `--spline` also spline): growth onset
/// and loss bracket; `--steps` each step's rho, spreads and growth rate; `--conn` the map's
/// saddle connection (the report's range 31.0-32.0, 6 points, 0.005 ms). Variants whose runs
/// differ (modifiers adding starts) are simulated on their own.
fn cuts(args: &[String]) -> R {
    use furuta::map_global::{ConnectionOptions, map_connection, map_torus_continuation};
    use furuta::parametric::TrainingRuns;
    let (mut conn, mut steps, mut spline, mut cubic, mut notorus) = (false, false, false, false, false);
    let mut names = Vec::new();
    for a in args {
        match a.as_str() {
            "--conn" => conn = true,
            "--cubic" => cubic = true,
            "--notorus" => notorus = true,
            "--steps" => steps = true,
            "--spline" => spline = true,
            x => names.push(x.to_string()),
        }
    }
    let opts: Vec<FurutaOptions> = names.iter().map(|n| variant(n)).collect::<Result<_, _>>()?;
    let (t0, c0) = (std::time::Instant::now(), cpu_s());
    let refs: Vec<&FurutaOptions> = opts.iter().collect();
    let runs = TrainingRuns::simulate(&refs)?;
    println!("training runs: {:.1} s wall {:.1} s CPU", t0.elapsed().as_secs_f64(), cpu_s() - c0);
    let dts: Vec<f64> = (0..=14).map(|k| ((31.3 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
    // The equation-driven order-7 normal forms at the training periods (cubic comparison).
    let eq_dts = FurutaOptions::default().dts_ms;
    let eqs: Vec<_> = if cubic {
        eq_dts.iter().map(|&dt| furuta::equation_ssm::furuta_equation_polar(dt, 7)).collect::<Result<_, _>>()?
    } else {
        Vec::new()
    };
    let interps: &[ssm::interp::Interp] = if spline {
        &[ssm::interp::Interp::Linear, ssm::interp::Interp::Spline]
    } else {
        &[ssm::interp::Interp::Linear]
    };
    for (name, o) in names.iter().zip(&opts) {
        let (t1, c1) = (std::time::Instant::now(), cpu_s());
        let sm = match furuta::shared_tangent::shared_parametric_from(o, &runs) {
            Ok(sm) => sm,
            Err(e) => {
                println!("{name}: not fitted ({e})");
                continue;
            }
        };
        let fit_s = cpu_s() - c1;
        if cubic {
            // The fitted map's cubic terms on the first-harmonic basis at its nodes (the
            // report's `first_harmonic_fitted_map` column), relative to the equation-driven ones.
            use ssm::normal_form::{NormalFormOptions, model_normal_form_first_harmonic};
            let mut worst: Vec<(String, f64)> = Vec::new();
            let mut cells: Vec<String> = Vec::new();
            for (dt, eq) in eq_dts.iter().zip(&eqs) {
                if !o.dts_ms.contains(dt) {
                    continue;
                }
                let f = model_normal_form_first_harmonic(
                    &sm.model_at(*dt, ssm::interp::Interp::Linear)?,
                    &NormalFormOptions::default(),
                )?;
                let rows = furuta::equation_ssm::compare_forms(*dt, eq, &f);
                let mut line = Vec::new();
                for r in rows.iter().filter(|r| r.degree == 3) {
                    let e = r.rel_diff.unwrap_or(f64::NAN);
                    line.push(format!("{} {:+.1}", r.monomial, 100.0 * e));
                    let k = format!("rho_{}' {}", r.mode, r.monomial);
                    match worst.iter_mut().find(|w| w.0 == k) {
                        Some(w) => w.1 = w.1.max(e.abs()),
                        None => worst.push((k, e.abs())),
                    }
                }
                cells.push(format!("{dt}: {}", line.join(", ")));
            }
            println!("{name:<40} cubic % | {}", cells.join(" | "));
            println!(
                "{name:<40} cubic max |rel| % {}",
                worst.iter().map(|w| format!("{} {:.1}", w.0, 100.0 * w.1)).collect::<Vec<_>>().join(", ")
            );
        }
        if notorus {
            continue;
        }
        for &interp in interps {
            let c2 = cpu_s();
            let tc = map_torus_continuation(|dt| Ok(sm.model_at(dt, interp)?), &dts, [0.097, 0.0277], 16_000)?;
            let tor_s = cpu_s() - c2;
            let c = if conn {
                let c3 = cpu_s();
                let m = map_connection(
                    |dt| Ok(sm.model_at(dt, interp)?),
                    31.0,
                    32.0,
                    6,
                    0.005,
                    &ConnectionOptions::default(),
                );
                format!(
                    "connection {:?} ({:.1} s CPU)",
                    m.map(|m| m.switch.bracket).map_err(|e| e.to_string()),
                    cpu_s() - c3
                )
            } else {
                String::new()
            };
            println!(
                "{name:<40} {interp:?}: onset {} lost {:?}{} {c} (fit {fit_s:.1} s, torus {tor_s:.1} s CPU, {:.0} s wall)",
                tc.growth_onset.map_or("none".into(), |v| format!("{v:.4}")),
                tc.lost_between,
                if tc.lost_at_first_dt() { " (at the first dt)" } else { "" },
                t1.elapsed().as_secs_f64()
            );
            if steps {
                for s in &tc.steps {
                    println!(
                        "   {:6.2} rho {:?} spreads {:?} / {:?} rate {:?} noise {:?} lost {} esc {:?}",
                        s.dt_ms,
                        s.rho.map(|r| [(r[0] * 1e4).round() / 1e4, (r[1] * 1e4).round() / 1e4]),
                        s.spread_mid,
                        s.spread_last,
                        s.growth_rate,
                        s.rate_noise,
                        s.lost,
                        s.escape_t
                    );
                }
            }
        }
    }
    Ok(())
}

/// `fhmix CUT`: which half of the fitted map's model bends its rho_1^3 on the first-harmonic
/// basis: the default shared-tangent model at each node with (a) its manifold refitted over
/// the same `V1` on the training runs cut at `CUT` rad, (b) its map refitted on them
/// (weighted), (c) both; cubic terms relative to the equation-driven order-7 ones.
fn fhmix(args: &[String]) -> R {
    use furuta::parametric::TrainingRuns;
    use ssm::fit::{embed_training, fit_with_tangent_weighted};
    use ssm::manifold::Manifold;
    use ssm::normal_form::{NormalFormOptions, model_normal_form_first_harmonic};
    let cut: f64 = args.first().ok_or("fhmix CUT")?.parse()?;
    let d = FurutaOptions::default();
    let c = FurutaOptions { max_theta: cut, ..d.clone() };
    let runs = TrainingRuns::simulate(&[&d, &c])?;
    let sm = furuta::shared_tangent::shared_parametric_from(&d, &runs)?;
    for &dt in &d.dts_ms {
        let eq = furuta::equation_ssm::furuta_equation_polar(dt, 7)?;
        let train = runs.series(&c, dt)?;
        let (ys, _) = embed_training(&train, &c.fit)?;
        let man = Manifold::fit_with_tangent(&ys, &sm.v1, 4, c.fit.manifold_order, c.fit.ridge)?;
        let refit = fit_with_tangent_weighted(&train, &c.fit, &sm.v1, c.map_weight.as_ref())?;
        let base = sm.model_at(dt, ssm::interp::Interp::Linear)?;
        let mut a = base.clone();
        a.manifold = man.clone();
        let mut b = base.clone();
        b.dynamics = refit.dynamics.clone();
        let mut both = base.clone();
        both.manifold = man;
        both.dynamics = refit.dynamics;
        for (name, m) in [("default", &base), ("manifold cut", &a), ("map cut", &b), ("both cut", &both)] {
            let f = model_normal_form_first_harmonic(m, &NormalFormOptions::default())?;
            let cells: Vec<String> = furuta::equation_ssm::compare_forms(dt, &eq, &f)
                .iter()
                .filter(|r| r.degree == 3)
                .map(|r| format!("{} {:+.1} %", r.monomial, 100.0 * r.rel_diff.unwrap_or(f64::NAN)))
                .collect();
            println!("{dt} ms {name:<13} {}", cells.join(", "));
        }
    }
    Ok(())
}

/// `bands VARIANT`: training samples per band of the envelope of |theta| (max over +-37
/// samples, about one slow period), per training period and in all.
fn bands(args: &[String]) -> R {
    let o = variant(args.first().map_or("default", String::as_str))?;
    let edges = [0.0, 0.01, 0.03, 0.05, 0.08, 0.11, 0.15, 0.2, 0.25, 0.3, 1.0];
    let mut all = vec![0usize; edges.len() - 1];
    for &dt in &o.dts_ms {
        let ser = furuta::parametric::training_series(&o, dt)?;
        let mut c = vec![0usize; edges.len() - 1];
        for s in &ser {
            let n = s.x.len();
            for i in 0..n {
                let e = s.x[i.saturating_sub(37)..(i + 38).min(n)].iter().fold(0.0f64, |m, v| m.max(v.abs()));
                if let Some(b) = edges.windows(2).position(|w| e >= w[0] && e < w[1]) {
                    c[b] += 1;
                }
            }
        }
        println!("{dt:5.2} ms: {c:?}");
        all.iter_mut().zip(&c).for_each(|(a, b)| *a += b);
    }
    println!("edges {edges:?}\nall: {all:?}");
    Ok(())
}

fn main() -> R {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("convergence") => convergence(&args[1..]),
        Some("cycles") => cycles(&args[1..]),
        Some("fit") => fit(&args[1..]),
        Some("mapswitch") => mapswitch(&args[1..]),
        Some("mapcycles") => mapcycles(&args[1..]),
        Some("mapglobal") => mapglobal(&args[1..]),
        Some("torus") => torus(&args[1..]),
        Some("fullcont") => fullcont(&args[1..]),
        Some("coeffs") => coeffs(&args[1..]),
        Some("fhcoeffs") => fhcoeffs(&args[1..]),
        Some("eqbasis") => eqbasis(&args[1..]),
        Some("fhsplit") => fhsplit(&args[1..]),
        Some("maptorus") => maptorus(&args[1..]),
        Some("ratefun") => ratefun(&args[1..]),
        Some("cuts") => cuts(&args[1..]),
        Some("bands") => bands(&args[1..]),
        Some("fhmix") => fhmix(&args[1..]),
        _ => Err("subcommands: convergence ORDER DT... | cycles MODE ORDER DT...".into()),
    }
}
