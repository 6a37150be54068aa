//! Explorations of the parametric Furuta model and its bifurcations against the full
//! system. They print only (nothing is checked); the measured results they led to are
//! recorded in the doc comments below and in MODEL.md. Run with
//!
//! ```text
//! cargo run --release -p lab --example explore_bifurcations -- <subcommand>
//! ```
//!
//! Subcommands (the former `#[ignore]` test names):
//!
//! - `furuta`: fits the parametric model with [`explore_options`] (environment overrides
//!   `FUR_*`), prints the fit time, the linear-rate errors against the exact ZOH rates at
//!   each training period and at interpolated periods, and the normal-form coefficient
//!   table at 30.8 ms.
//! - `furuta-linear-first`: the linear part from small-amplitude samples only (default
//!   options, dt 30.5, 32.0, 32.5 ms); prints the slow/fast rate errors per radius.
//! - `shared`: the shared-tangent parametric model ([`explore_options`]): fit time,
//!   singular values, node rates against the exact ones, then the predictions at the
//!   default test periods (linear and spline interpolation): NMTE, DTW-NMTE, stop, rates.
//! - `model-bifurcations`: the model's bifurcation row (heteroclinic, torus Hopf,
//!   small-start switch, torus at 30.8 ms) for [`explore_options`], and the fixed points
//!   with their stability and eigenvalues at 30.8 ... 32.3 ms.
//! - `sensitivity`: the bifurcation rows of the default model and of four training variants
//!   (amplitude cut, denser periods; four more fits), then the full system's torus across dt
//!   (16,000 periods each); prints JSON. Long (minutes).
//! - `furcheck`: full-system experiments selected by `FC_WHAT` (or the second argument):
//!   `torus`, `scan`, `fate`, `spec`, `one`, `grid`; knobs `FC_DT`, `FC_P`, `FC_TAIL`,
//!   `FC_R1`, `FC_R2`, `FC_P1`, `FC_P2`, `FC_S`, `FC_K`, `FC_DTS` (see [`furcheck`]).
//! - `fast-cycle`: the full system's fast-mode cycle at 30.8 ... 31.6 ms (start on the fast
//!   mode, slow part 1e-7 rad); prints the amplitude history.

use std::time::Instant;

use faer::Mat;
use furuta::bifurcations::{RHO_MAX, model_row, sensitivity_row, sensitivity_variants};
use furuta::full_system::{
    AMP_WINDOW_S, ESCAPE_THETA, default_ics, default_switch_scan, fate_from, outcome_of, run, start_from_rho,
    torus_full, transient_analysis,
};
use furuta::parametric::{FurutaOptions, exact_modes, furuta_parametric, training_series};
use furuta::shared_tangent::{PredictOptions, predict_one, shared_parametric, test_series};
use serde_json::{Value, json};
use ssm::Ridge;
use ssm::fit::embed_training;
use ssm::interp::Interp;
use ssm::manifold::Manifold;
use ssm::portrait::{PortraitOptions, fixed_points};
use ssm::spectrum::mode_amplitudes;

const USAGE: &str = "usage: explore_bifurcations <furuta | furuta-linear-first | shared | model-bifurcations | sensitivity | furcheck [WHAT] | fast-cycle>";

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("furuta") => furuta_explore(),
        Some("furuta-linear-first") => furuta_linear_first_explore(),
        Some("shared") => shared_explore(),
        Some("model-bifurcations") => model_bifurcations_explore(),
        Some("sensitivity") => sensitivity_explore(),
        Some("furcheck") => furcheck(args.get(1).cloned()),
        Some("fast-cycle") => fast_cycle_explore(),
        _ => {
            eprintln!("{USAGE}");
            std::process::exit(2);
        }
    }
}

/// [`FurutaOptions::default`] with the explorations' environment overrides:
/// `FUR_P` embedding, `FUR_SHIFT`, `FUR_R` map order, `FUR_K` manifold order, `FUR_RIDGE`,
/// `FUR_ANCHOR` (0 = none), `FUR_MAXTH` amplitude cut, `FUR_SLOW` slow-start amplitude,
/// `FUR_SLOW_EXTRA` comma list of extra slow-start amplitudes (two phases each),
/// `FUR_IC=0` only two default starts, `FUR_DTS` comma list of training periods.
fn explore_options() -> FurutaOptions {
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    let mut o = FurutaOptions::default();
    if let Some(p) = env("FUR_P") {
        o.fit.embed = p as usize;
    }
    if let Some(p) = env("FUR_SHIFT") {
        o.fit.shift = p as usize;
    }
    if let Some(p) = env("FUR_R") {
        o.fit.dyn_order = p as u32;
    }
    if let Some(p) = env("FUR_K") {
        o.fit.manifold_order = p as u32;
    }
    if let Some(p) = env("FUR_RIDGE") {
        o.fit.ridge = Ridge::Fixed(p);
    }
    if let Some(p) = env("FUR_ANCHOR") {
        o.fit.linear_anchor = if p > 0.0 { Some(p) } else { None };
    }
    if let Some(p) = env("FUR_MAXTH") {
        o.max_theta = p;
    }
    if let Some(a) = env("FUR_SLOW") {
        o.slow_starts = vec![(a, 0.0), (a, std::f64::consts::FRAC_PI_2), (2.0 * a, 0.7), (4.0 * a, 2.3)];
    }
    if let Ok(v) = std::env::var("FUR_SLOW_EXTRA") {
        for a in v.split(',').map(|x| x.parse::<f64>().unwrap()) {
            o.slow_starts.extend([(a, 0.0), (a, std::f64::consts::FRAC_PI_2)]);
        }
    }
    if env("FUR_IC") == Some(0.0) {
        o.initial_states.truncate(2);
    }
    if let Ok(v) = std::env::var("FUR_DTS") {
        o.dts_ms = v.split(',').map(|x| x.parse().unwrap()).collect();
    }
    o
}

// ===================================================================== parametric model

/// Exploration: see [`explore_options`] for the overrides; prints the rate errors.
fn furuta_explore() {
    let o = explore_options();
    let t0 = Instant::now();
    let pm = furuta_parametric(&o).unwrap();
    println!("fit time {:.1} s", t0.elapsed().as_secs_f64());
    for t in &pm.trained {
        let (r, e) = (t.normal_form.linear_rates(), t.exact.rates);
        println!(
            "EXP dt {:5.2}: slow err {:+.3e} ({:+.5} vs {:+.5}), fast err {:+.3e}",
            t.dt_ms,
            (r[0] - e[0]) / e[0],
            r[0],
            e[0],
            (r[1] - e[1]) / e[1]
        );
    }
    for dt in [30.8, 31.4, 31.41, 31.55, 31.68, 32.3] {
        let r = pm.linear_rates_at(dt).unwrap();
        let e = exact_modes(dt).unwrap().rates;
        println!("EXP interp {dt:5.2}: slow err {:+.3e}, fast err {:+.3e}", (r[0] - e[0]) / e[0], (r[1] - e[1]) / e[1]);
    }
    println!("table at 30.8 ms:\n{}", pm.coefficients_at(30.8).unwrap().to_text());
}

/// Exploration: linear part from small-amplitude samples only, then nonlinear terms on
/// the residual. Prints the rate errors per radius.
fn furuta_linear_first_explore() {
    let o = FurutaOptions::default();
    for dt_ms in [30.5, 32.0, 32.5] {
        let train = training_series(&o, dt_ms).unwrap();
        let (ys, _dts) = embed_training(&train, &o.fit).unwrap();
        let man = Manifold::fit(&ys, 4, o.fit.manifold_order, o.fit.ridge).unwrap();
        let etas: Vec<Mat<f64>> = ys.iter().map(|y| man.reduce_points(y.as_ref())).collect();
        let e = exact_modes(dt_ms).unwrap();
        let dt = dt_ms * 1e-3;
        let gmax = etas
            .iter()
            .flat_map(|m| (0..m.nrows()).map(move |i| (0..4).map(|j| m[(i, j)] * m[(i, j)]).sum::<f64>().sqrt()))
            .fold(0.0, f64::max);
        for frac in [0.01, 0.03, 0.1, 0.3, 1.0] {
            let r = frac * gmax;
            let mut xs = Vec::new();
            let mut ysn = Vec::new();
            for m in &etas {
                for i in 0..m.nrows() - 1 {
                    let n2 = (0..4).map(|j| m[(i, j)] * m[(i, j)]).sum::<f64>().sqrt();
                    if n2 <= r {
                        xs.push([m[(i, 0)], m[(i, 1)], m[(i, 2)], m[(i, 3)]]);
                        ysn.push([m[(i + 1, 0)], m[(i + 1, 1)], m[(i + 1, 2)], m[(i + 1, 3)]]);
                    }
                }
            }
            let n = xs.len();
            if n < 20 {
                continue;
            }
            let a = Mat::from_fn(n, 4, |i, j| xs[i][j]);
            let b = Mat::from_fn(n, 4, |i, j| ysn[i][j]);
            // One segment: all n pairs.
            let (w, _) =
                ssm::ridge::fit(a.as_ref(), b.as_ref(), std::slice::from_ref(&(0..n)), Ridge::Fixed(0.0), "lin")
                    .unwrap();
            let am = nalgebra::Matrix4::from_fn(|i, j| w[(j, i)]);
            let ev = am.complex_eigenvalues();
            let mut rates: Vec<(f64, f64)> =
                ev.iter().map(|z| (z.norm().ln() / dt, z.arg().abs() / dt / std::f64::consts::TAU)).collect();
            rates.sort_by(|a, b| a.1.total_cmp(&b.1));
            println!(
                "EXP dt {dt_ms}: r {frac:.2} (n {n}): slow {:+.5} ({:+.2e}) fast {:+.5} ({:+.2e}); freqs {:.4} {:.4}",
                rates[0].0,
                (rates[0].0 - e.rates[0]) / e.rates[0],
                rates[3].0,
                (rates[3].0 - e.rates[1]) / e.rates[1],
                rates[0].1,
                rates[3].1
            );
        }
    }
}

/// Exploration print of the whole shared-tangent pipeline (not a check).
fn shared_explore() {
    let t0 = Instant::now();
    let fo = explore_options();
    let pm = shared_parametric(&fo).unwrap();
    println!(
        "fit {:.1} s; sv {:?}",
        t0.elapsed().as_secs_f64(),
        &pm.singular_values[..6.min(pm.singular_values.len())]
    );
    for n in &pm.nodes {
        println!(
            "node {:5.2}: slow {:+.5} vs {:+.5} ({:+.2e}), fast {:+.5} vs {:+.5} ({:+.2e}); freqs {:?} vs {:?}",
            n.dt_ms,
            n.rates[0],
            n.exact.rates[0],
            (n.rates[0] - n.exact.rates[0]) / n.exact.rates[0],
            n.rates[1],
            n.exact.rates[1],
            (n.rates[1] - n.exact.rates[1]) / n.exact.rates[1],
            n.freqs_hz,
            n.exact.freqs_hz
        );
    }
    let o = PredictOptions::default();
    for interp in [Interp::Linear, Interp::Spline] {
        for &dt in &o.dts_ms {
            let e = exact_modes(dt).unwrap();
            let r = pm.rates_at(dt, interp).unwrap();
            let ts = test_series(dt, &o).unwrap();
            let res = predict_one(&pm, dt, &ts, &o, interp).unwrap();
            println!(
                "{interp:?} dt {dt:5.2}: n {} / {}, NMTE {:.4}, DTW-NMTE {:.4}, stop {:?}, cut {:?}; rates {:+.4} {:+.4} vs exact {:+.4} {:+.4}",
                res.x_pred.len(),
                res.x_true.len(),
                res.nmte,
                res.dtw_nmte,
                res.stop,
                res.test_cut,
                r[0],
                r[1],
                e.rates[0],
                e.rates[1]
            );
        }
    }
}

// ====================================================================== bifurcations

/// Exploration: the model's bifurcation values for the default options (overrides of
/// [`explore_options`]); prints only.
fn model_bifurcations_explore() {
    let o = explore_options();
    let pm = furuta_parametric(&o).unwrap();
    for t in &pm.trained {
        println!("BIF trained {} : {} series rho range {:?}", t.dt_ms, t.model.n_points, t.model.eta_range);
    }
    let (lo, hi) = pm.range();
    println!("BIF {:?}", model_row("explore", &o, &pm, None).unwrap());
    let popts = PortraitOptions { rho_max: RHO_MAX, ..PortraitOptions::default() };
    for dt in [30.8, 31.4, 31.55, 31.68, 32.3].into_iter().filter(|d| *d >= lo && *d <= hi) {
        let fps = fixed_points(&pm.normal_form_at(dt).unwrap(), &popts).unwrap();
        for f in fps {
            println!("BIF dt {dt}: {:?} rho {:.4?} {:?} ev {:.4?}", f.kind, f.rho, f.stability, f.eigenvalues);
        }
    }
}

/// Exploration: the bifurcation values of the default model and of the training variants
/// of the report's sensitivity section, and the full system's torus across dt; prints the
/// JSON the report stores (`bifurcation_sensitivity`, `torus_full_vs_dt`).
/// The sensitivity row of the default training reproduces the portraits section's
/// values (same fit, same scans), and the full system's torus spread grows with dt.
///
/// The variants are `furuta::bifurcations::sensitivity_variants`, the report's.
fn sensitivity_explore() {
    let base = FurutaOptions::default();
    let pm = furuta_parametric(&base).unwrap();
    let variants = sensitivity_variants();
    let mut rows = vec![model_row("default (paper's periods, cut 0.2 rad)", &base, &pm, None).unwrap()];
    for (name, o) in &variants {
        rows.push(sensitivity_row(name, o).unwrap());
    }
    // The full system's torus across dt: started on it, 16,000 periods (~500 s), measured
    // on the last 125 s.
    let mut tlist = Vec::new();
    for dt in [30.8, 31.2, 31.4, 31.6, 31.8, 31.9] {
        let (x, h) = start_from_rho(dt, [0.095, 0.028], [0.0, 0.0]).unwrap();
        match torus_full(dt, &(x, Some(h)), 16_000, 125.0) {
            Ok(t) => tlist.push(json!({"dt_ms": dt, "rho": t.rho, "rho_spread": t.rho_spread, "escaped": false})),
            Err(furuta::Error::TorusEscaped { .. }) => tlist.push(json!({"dt_ms": dt, "escaped": true})),
            Err(e) => panic!("{e}"),
        }
    }
    let summary = json!({"bifurcation_sensitivity": rows, "torus_full_vs_dt": Value::Array(tlist)});
    println!("{}", serde_json::to_string_pretty(&summary).unwrap());
}

// ======================================================================= full system

/// Exploration, prints only: `FC_WHAT` (or `what`, the second argument) selects the
/// experiment:
///
/// - `torus`: the full system's torus from theta0 = 0.05 at `FC_DT` (30.8), `FC_P` (3000)
///   periods, last `FC_TAIL` (40) s.
/// - `scan`: the default small-start switch scan, `FC_P` (3000) periods.
/// - `fate`: the fate of the start (`FC_R1`, `FC_R2`) = (0.05, 0.02) with phases (`FC_P1`,
///   `FC_P2`) at `FC_DT` (31.5), `FC_P` periods; amplitude history.
/// - `spec`: the transient spectrum of that start over `FC_S` (60) s.
/// - `one`: default start `FC_K` (2) at each of `FC_DTS` (comma list, required), `FC_P`
///   (20000) periods; outcome and amplitude history.
/// - `grid`: escape times over a (rho_1, rho_2) grid at `FC_DT` (31.45), `FC_P` (6000)
///   periods (`B` = bounded).
fn furcheck(what: Option<String>) {
    let what = what.unwrap_or_else(|| std::env::var("FC_WHAT").unwrap_or_default());
    let envf = |k: &str, d: f64| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok()).unwrap_or(d);
    match what.as_str() {
        "torus" => {
            let dt = envf("FC_DT", 30.8);
            let t0 = Instant::now();
            let tf = torus_full(dt, &([0.05, 0.0, 0.0, 0.0], None), envf("FC_P", 3000.0) as u64, envf("FC_TAIL", 40.0))
                .unwrap();
            println!("{tf:?} in {:.2} s", t0.elapsed().as_secs_f64());
        }
        "scan" => {
            let t0 = Instant::now();
            let s = default_switch_scan(envf("FC_P", 3000.0) as u64).unwrap();
            println!("{}", s.to_text());
            println!(
                "bracket {:?} monotone {} runs {} wall {:.1} s ({:.1})",
                s.bracket(),
                s.monotone(),
                s.runs,
                s.wall_seconds,
                t0.elapsed().as_secs_f64()
            );
        }
        "fate" => {
            let dt = envf("FC_DT", 31.5);
            let rho = [envf("FC_R1", 0.05), envf("FC_R2", 0.02)];
            let f = fate_from(dt, rho, [envf("FC_P1", 0.0), envf("FC_P2", 0.0)], envf("FC_P", 3000.0) as u64).unwrap();
            println!("bounded {} escape {:?}", f.bounded, f.escape_t);
            for a in f.amps.iter().step_by(64) {
                println!("  t {:7.2}  rho {:.4} {:.4}", a.0, a.1[0], a.1[1]);
            }
        }
        "spec" => {
            let dt = envf("FC_DT", 31.5);
            let rho = [envf("FC_R1", 0.05), envf("FC_R2", 0.02)];
            let (x, h) = start_from_rho(dt, rho, [envf("FC_P1", 0.0), envf("FC_P2", 0.0)]).unwrap();
            let a = transient_analysis(dt, &(x, Some(h)), envf("FC_S", 60.0)).unwrap();
            for q in &a.peaks {
                println!("  {:.4} Hz  {:.5}", q.freq_hz, q.amplitude);
            }
            println!(
                "analysed {:.1} s escape {:?} slow {:?} fast {:?} sideband {:?} envelope {:?}",
                a.analysed_s, a.escape_t, a.slow, a.fast, a.sideband_spacing_hz, a.envelope_freq_hz
            );
        }
        "one" => {
            let p = envf("FC_P", 20000.0) as u64;
            let k = envf("FC_K", 2.0) as usize;
            let Ok(dts) = std::env::var("FC_DTS") else {
                eprintln!("set FC_DTS (comma list of sampling periods, ms)");
                std::process::exit(2);
            };
            for dt in dts.split(',').map(|v| v.parse::<f64>().unwrap()) {
                let ic = default_ics(dt).unwrap().swap_remove(k);
                let tr = run(dt, &ic, p, ESCAPE_THETA).unwrap();
                let o = outcome_of(&tr);
                let fr = exact_modes(dt).unwrap().freqs_hz;
                let am = mode_amplitudes(&tr.primary(), tr.dt, fr, AMP_WINDOW_S).unwrap();
                let pts: Vec<String> =
                    am.iter().step_by(320).map(|a| format!("{:.0}:({:.3},{:.3})", a.0, a.1[0], a.1[1])).collect();
                println!("dt {dt} ic {k}: {o:?}\n   {}", pts.join(" "));
            }
        }
        "grid" => {
            let dt = envf("FC_DT", 31.45);
            let p = envf("FC_P", 6000.0) as u64;
            let r1s: Vec<f64> = (0..10).map(|i| 0.02 + 0.015 * i as f64).collect();
            let r2s: Vec<f64> = (0..7).map(|i| 0.005 + 0.01 * i as f64).collect();
            for &r2 in r2s.iter().rev() {
                let mut line = format!("r2 {r2:.3}: ");
                for &r1 in &r1s {
                    let (x, h) = start_from_rho(dt, [r1, r2], [0.0, 0.0]).unwrap();
                    let o = outcome_of(&run(dt, &(x, Some(h)), p, ESCAPE_THETA).unwrap());
                    line.push_str(&match o.escape_t {
                        None => "   B  ".to_string(),
                        Some(t) => format!("{t:5.0} "),
                    });
                }
                println!("{line}");
            }
            println!("r1 = {r1s:?}");
        }
        _ => {
            eprintln!("set FC_WHAT (or pass it as the second argument): torus | scan | fate | spec | one | grid");
            std::process::exit(2);
        }
    }
}

/// Exploration: the full system's fast-mode cycle (start on the fast mode only, tiny slow
/// part) against the model's fast saddle cycle; prints the amplitude history.
fn fast_cycle_explore() {
    for dt in [30.8, 31.2, 31.4, 31.6] {
        let f = fate_from(dt, [1e-7, 0.005], [0.0, 0.0], 6000).unwrap();
        let pick: Vec<String> = f
            .amps
            .iter()
            .step_by((f.amps.len() / 16).max(1))
            .map(|(t, r)| format!("{t:.0}:({:.4},{:.4})", r[0], r[1]))
            .collect();
        println!("FAST dt {dt}: bounded {} escape {:?}: {}", f.bounded, f.escape_t, pick.join(" "));
    }
}
