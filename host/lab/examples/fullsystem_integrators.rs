//! The report's full-system runs under other integrators than the scene's (`furuta-dt30.5`:
//! exprb-lean at rtol = atol = 3e-11), to decide whether a cheaper setting gives the same
//! verdicts: every run's outcome is written to a CSV per (part, integrator), and `compare`
//! sets candidates against a reference (RODAS4 at rtol 1e-13) and the scene's setting.
//!
//! ```text
//! cargo run --release -p lab --example fullsystem_integrators -- run PART CAND DIR [CELLS]
//! cargo run --release -p lab --example fullsystem_integrators -- compare PART DIR REF CAND...
//! ```
//! PART: `basin-quick` / `basin-full` (the report's basin grids, every dt), `scan-quick` /
//! `scan-full` (the default-start switch scans), `torus-quick` / `torus-full` (the torus
//! continuation across dt), `connection` (the pushed starts off the fast saddle cycle at the
//! full report's connection bracket ends, 31.328 and 31.331 ms, and a step beyond each). CAND: `METHOD:RTOL[:ATOL]` (atol = rtol if absent), e.g.
//! `exprb-lean:3e-11`, `exprb-filtered:1e-11`, `rodas:1e-13:1e-15`. CELLS: a file of run
//! indices (one a line) to run only those (the reference on the cells where candidates
//! disagree, or on a sample). The runs go on the rayon pool (`RAYON_NUM_THREADS`).
//!
//! Measured at 8f19813 (one thread each, user CPU-s on a loaded 2-core machine; "flips":
//! runs whose bounded/escape verdict differs):
//!
//! | runs | exprb-lean 3e-11 (scene) | exprb-filtered 3e-11 | exprb-lean 1e-10 | exprb-filtered 1e-10 |
//! |---|---|---|---|---|
//! | basin-quick (576 runs): CPU-s | 30.9 | 14.6 | - | 11.5 |
//! | flips against the scene's | - | 0 | 0 | 0 |
//! | max diff of max theta, bounded (134) | - | 6.6e-9 | 2.8e-9 | 1.8e-8 |
//! | escape times (442) | - | identical | identical | identical |
//! | basin-quick, the 108 runs on the basin's edge, against RODAS4 1e-13 (184 CPU-s): flips | 0 | 0 | 0 | 0 |
//! | max theta error, bounded (51) | 1.2e-9 | 7.8e-9 | 4.0e-9 | 1.9e-8 |
//! | escape times (57) | identical | identical | identical | identical |
//! | scan-quick (10 runs) against RODAS4 1e-13: flips | 0 | 0 | 0 | 0 |
//! | max theta error, bounded (6) | 6.1e-11 | 4.9e-10 | 2.1e-10 | 1.3e-9 |
//! | escape times (4) | identical | identical | identical | identical |
//! | torus-quick against RODAS4 1e-13: CPU-s | 5.6 | 2.7 | | |
//! | lost bracket [31.8, 31.9] ms | same | same | | |
//! | largest error of rho / spreads / rates | 2.0e-11 / 1.9e-10 / 2.4e-10 | 1.3e-10 / 2.2e-9 / 1.1e-9 | | |
//! | growth onset error (ms) | 1.8e-9 | 1.1e-8 | | |
//! | connection (16 runs, 31.325 ... 31.334 ms): CPU-s | 18.4 | 12.0 | | |
//! | against RODAS4 1e-13 (213 CPU-s): flips, escape times (2) | 0, identical | 0, identical | | |
//! | max theta error, bounded (14) | 1.0e-9 | 3.5e-9 | | |
//! | scan-full (168 runs, 8,000 periods): CPU-s | 67.9 | 33.0 | | |
//! | flips against the scene's | - | 1: 31.38 ms, fast-mode start (escapes at 170.3 s) | | |
//! | escape times (115 both) | - | 100 identical, the rest up to 0.157 s apart | | |
//!
//! The one flip, the fast-mode start of 1e-3 rad at 31.38 ms over 8,000 periods (scan-full
//! run 36), by integrator (B = bounded, max theta; E = escape time):
//!
//! | integrator | verdict | CPU-s |
//! |---|---|---|
//! | RODAS4 1e-11 / 1e-12 / 1e-13 (atol rtol/100) | B 0.17613 / 0.17612 / 0.17612 | 4.3 / 7.9 / 14.3 |
//! | exprb-lean 1e-12, 2e-12, 3e-12 | B 0.17612, 0.17612, 0.17613 | 1.9, 1.7, 1.4 |
//! | exprb-lean 5e-12 | E 193.4 s | 1.1 |
//! | exprb-lean 1e-11, 2e-11 | E 176.3, 177.5 s | 0.8, 0.7 |
//! | exprb-lean 3e-11 (scene), 4e-11 | B 0.17621, 0.17615 | 0.8, 0.7 |
//! | exprb-lean 5e-11, 1e-10 | E 179.8, 107.9 s | 0.6, 0.3 |
//! | exprb 1e-11 / 1e-13 | E 177.7 s | 1.5 |
//! | exprb-filtered 1e-12, 3e-12, 1e-11, 3e-11 | E 177.0, 194.7, 103.3, 170.3 s | 0.6, 0.5, 0.3, - |
//!
//! So this verdict is decided by the integration error at every tolerance above ~2e-12; the
//! scene's setting gets it right with the reference, exprb-filtered does not at any tolerance
//! tried, and the scene keeps exprb-lean at 3e-11.
//!
//! The opt-in order-5 method `exprb54-filtered` (exprb54s4, `sim::ode`; no scene uses it), at
//! exprb5 (one thread each, user CPU-s on a 2-core machine at load 4-8, so +-20 %; exprb-filtered
//! rerun alongside):
//!
//! | runs | exprb-filtered 3e-11 | exprb54-filtered 3e-11 | exprb54-filtered 1e-10 |
//! |---|---|---|---|
//! | scan-quick: CPU-s / flips against RODAS4 1e-13 / max theta error, bounded (6) | 1.35 / 0 / 4.9e-10 | 0.88 / 0 / 4.8e-11 | 0.97 / 0 / 1.6e-10 |
//! | torus-quick: CPU-s / lost bracket / largest error of rho, spreads | 3.00 / same / 1.3e-10, 2.2e-9 | 2.72 / same / 2.3e-12, 1.5e-10 | 1.85 / same / 7.1e-12, 4.2e-10 |
//! | basin-quick (576): CPU-s / flips and escape times against exprb-filtered 3e-11 | 13.77 / - | 12.66 (10.56 on a quieter run) / 0, identical | 8.43 / 0, identical |
//! | connection (16): CPU-s / flips against RODAS4 1e-13 / max theta error, bounded (14) | 12.49 / 0 / 3.5e-9 | 11.03 / 0 / 4.6e-10 | 10.32 / 0 / 1.3e-9 |
//!
//! scan-full run 36 (the fast-mode start at 31.38 ms, 8,000 periods; RODAS4 B 0.17612):
//! exprb54-filtered B 0.17612 at 1e-12, 3e-12, 5e-12 and 1e-11 (0.34 CPU-s), B 0.17617 at 3e-11,
//! E at 2e-11, 5e-11 and 1e-10 (172-181 s); exprb54 (unfiltered) E at 1e-11 and 3e-11, B at 3e-12.

use furuta::basin::{BasinOptions, torus_continuation_with};
use furuta::full_system::{DEFAULT_SCAN_PERIODS, ESCAPE_THETA, default_dts, default_ics, outcome_of, run_with};
use furuta::map_global::{ConnectionOptions, full_connection_fates_with};
use furuta::sweep::Sweep;
use rayon::prelude::*;
use sim::scene::{IntegratorSpec, MethodKind};
use std::collections::BTreeMap;
use std::error::Error;
use std::fmt::Write as _;
use std::time::Instant;

type R<T> = Result<T, Box<dyn Error + Send + Sync>>;

fn parse_cand(s: &str) -> R<IntegratorSpec> {
    let parts: Vec<&str> = s.split(':').collect();
    if parts.len() < 2 || parts.len() > 3 {
        return Err(format!("integrator `{s}`: want METHOD:RTOL[:ATOL]").into());
    }
    let method: MethodKind = toml::Value::String(parts[0].into()).try_into()?;
    let rtol: f64 = parts[1].parse()?;
    let atol: f64 = parts.get(2).map_or(Ok(rtol), |a| a.parse())?;
    Ok(IntegratorSpec { method, rtol: Some(rtol), atol: Some(atol), steps: None })
}

/// One run's record: index, label (dt and start), bounded, escape time, max |theta| (or the
/// torus step's numbers).
struct Row {
    index: usize,
    label: String,
    values: Vec<f64>,
}

fn basin_sweep(full: bool, spec: &IntegratorSpec) -> R<Sweep> {
    let opts = if full { BasinOptions::full() } else { BasinOptions::quick() };
    let mut sweep = Sweep::from_spec("cmp", opts.spec("cmp"), std::path::Path::new("."))?;
    sweep.scene.integrator = spec.clone();
    Ok(sweep)
}

/// The switch scan's runs: (dt, start index) in the report's order.
fn scan_runs(full: bool) -> R<Vec<(f64, usize, u64)>> {
    Ok(if full {
        default_dts().into_iter().flat_map(|dt| (0..8).map(move |j| (dt, j, DEFAULT_SCAN_PERIODS))).collect()
    } else {
        [31.2, 31.3, 31.4, 31.5, 31.6].into_iter().flat_map(|dt| (0..2).map(move |j| (dt, j, 3000))).collect()
    })
}

fn torus_settings(full: bool) -> (Vec<f64>, u64) {
    if full {
        ((0..=14).map(|k| ((31.3 + 0.05 * k as f64) * 1e4).round() / 1e4).collect(), 16_000)
    } else {
        ((0..=6).map(|k| ((31.4 + 0.1 * k as f64) * 1e4).round() / 1e4).collect(), 8000)
    }
}

fn run_part(part: &str, spec: &IntegratorSpec, cells: Option<&[usize]>) -> R<Vec<Row>> {
    let pick = |n: usize| -> Vec<usize> {
        cells.map_or_else(|| (0..n).collect(), |c| c.iter().copied().filter(|&k| k < n).collect())
    };
    match part {
        "basin-quick" | "basin-full" => {
            let sweep = basin_sweep(part == "basin-full", spec)?;
            let ks = pick(sweep.cells() as usize);
            ks.par_iter()
                .map(|&k| -> R<Row> {
                    let c = sweep.compute(k as u64)?;
                    let v = &c.values;
                    Ok(Row {
                        index: k,
                        label: format!("dt {} rho ({:.4} {:.4})", v[2], v[0], v[1]),
                        values: vec![
                            f64::from(u8::from(c.bounded.unwrap_or(false))),
                            c.escape_t.unwrap_or(f64::NAN),
                            c.max_theta.unwrap_or(f64::NAN),
                        ],
                    })
                })
                .collect()
        }
        "scan-quick" | "scan-full" => {
            let runs = scan_runs(part == "scan-full")?;
            let ks = pick(runs.len());
            ks.par_iter()
                .map(|&k| -> R<Row> {
                    let (dt, j, periods) = runs[k];
                    let ic = default_ics(dt)?.swap_remove(j);
                    let o = outcome_of(&run_with(Some(spec), dt, &ic, periods, ESCAPE_THETA)?);
                    Ok(Row {
                        index: k,
                        label: format!("dt {dt} start {j}"),
                        values: vec![f64::from(u8::from(o.bounded())), o.escape_t.unwrap_or(f64::NAN), o.max_theta],
                    })
                })
                .collect()
        }
        "torus-quick" | "torus-full" => {
            let (dts, periods) = torus_settings(part == "torus-full");
            let c = torus_continuation_with(Some(spec), &dts, [0.097, 0.0277], periods)?;
            let j = serde_json::to_value(&c)?;
            let steps = j["steps"].as_array().cloned().unwrap_or_default();
            let num = |s: &serde_json::Value, k: &str| s[k].as_f64().unwrap_or(f64::NAN);
            let mut rows: Vec<Row> = steps
                .iter()
                .enumerate()
                .map(|(i, s)| {
                    let rho = s["rho"].as_array().map_or([f64::NAN; 2], |r| {
                        [r[0].as_f64().unwrap_or(f64::NAN), r[1].as_f64().unwrap_or(f64::NAN)]
                    });
                    Row {
                        index: i,
                        label: format!("dt {}", num(s, "dt_ms")),
                        values: vec![
                            f64::from(u8::from(!s["lost"].as_bool().unwrap_or(true))),
                            num(s, "escape_t"),
                            rho[0],
                            rho[1],
                            num(s, "spread_mid"),
                            num(s, "spread_last"),
                            num(s, "growth_rate"),
                        ],
                    }
                })
                .collect();
            // The continuation's own summary numbers, as one more row.
            let flat: Vec<f64> = ["lost_between", "growth_onset"]
                .iter()
                .flat_map(|k| match &j[*k] {
                    serde_json::Value::Array(a) => a.iter().map(|v| v.as_f64().unwrap_or(f64::NAN)).collect(),
                    v => vec![v.as_f64().unwrap_or(f64::NAN)],
                })
                .collect();
            rows.push(Row { index: steps.len(), label: "summary".into(), values: flat });
            Ok(rows)
        }
        "connection" => {
            // The pushed starts off the fast saddle cycle at the full report's bracket ends
            // and one step beyond each ([`full_connection_fates_with`], default options).
            let o = ConnectionOptions::default();
            let dts = [31.325, 31.328, 31.331, 31.334];
            let fates: Vec<_> =
                dts.par_iter().map(|&dt| full_connection_fates_with(Some(spec), dt, &o)).collect::<Result<_, _>>()?;
            Ok(fates
                .iter()
                .flat_map(|f| f.outcomes.iter().enumerate().map(move |(j, o)| (f.dt_ms, j, o.clone())))
                .enumerate()
                .map(|(k, (dt, j, o))| Row {
                    index: k,
                    label: format!("dt {dt} push {j}"),
                    values: vec![f64::from(u8::from(o.bounded())), o.escape_t.unwrap_or(f64::NAN), o.max_theta],
                })
                .collect())
        }
        _ => Err(format!("unknown part `{part}`").into()),
    }
}

fn file_of(dir: &str, part: &str, cand: &str) -> String {
    format!("{dir}/{part}-{}.csv", cand.replace(':', "_"))
}

fn read_rows(path: &str) -> R<BTreeMap<usize, (String, Vec<f64>)>> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let mut m = BTreeMap::new();
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        // index, label (may hold commas), values: the numeric fields from the end.
        let f: Vec<&str> = line.split(',').collect();
        let n_num = f.iter().rev().take_while(|v| v.parse::<f64>().is_ok()).count().min(f.len() - 2);
        let values = f[f.len() - n_num..].iter().map(|v| v.parse::<f64>()).collect::<Result<Vec<_>, _>>()?;
        m.insert(f[0].parse::<usize>()?, (f[1..f.len() - n_num].join(","), values));
    }
    Ok(m)
}

fn compare(part: &str, dir: &str, refc: &str, cands: &[String]) -> R<String> {
    let reference = read_rows(&file_of(dir, part, refc))?;
    let mut out = String::new();
    writeln!(out, "{part}: reference {refc}, {} runs", reference.len())?;
    let torus = part.starts_with("torus");
    for c in cands {
        let rows = read_rows(&file_of(dir, part, c))?;
        let common: Vec<usize> = reference.keys().copied().filter(|k| rows.contains_key(k)).collect();
        let mut flips = Vec::new();
        let (mut d_max, mut d_esc, mut n_esc) = (0.0f64, 0.0f64, 0usize);
        let mut d_cols = vec![0.0f64; 8];
        for k in &common {
            let (label, a) = &reference[k];
            let b = &rows[k].1;
            if a[0] != b[0] {
                flips.push(format!(
                    "{label} ({}: {})",
                    if a[0] == 1.0 { "B -> E" } else { "E -> B" },
                    if a[0] == 1.0 { b[1] } else { a[1] }
                ));
            }
            if torus && label != "summary" {
                for (i, (x, y)) in a.iter().zip(b).enumerate() {
                    if x.is_finite() && y.is_finite() {
                        d_cols[i] = d_cols[i].max((x - y).abs());
                    }
                }
            } else if torus {
                // The continuation's summary row is printed below.
            } else if a[0] == 1.0 && b[0] == 1.0 {
                d_max = d_max.max((a[2] - b[2]).abs());
            } else if a[0] == 0.0 && b[0] == 0.0 {
                d_esc = d_esc.max((a[1] - b[1]).abs());
                n_esc += 1;
            }
        }
        let bounded = common.iter().filter(|k| rows[k].1[0] == 1.0).count();
        writeln!(out, "  {c:28} runs {:5} bounded {bounded:5} verdict flips {:3}", common.len(), flips.len())?;
        if torus {
            writeln!(
                out,
                "    max |diff| per column (attracting, escape_t, rho1, rho2, spread_mid, spread_last, growth_rate): {:?}",
                &d_cols[..7]
            )?;
            if let (Some(a), Some(b)) = (reference.values().last(), rows.values().last()) {
                writeln!(out, "    summary (lost bracket, growth onset): ref {:?} cand {:?}", a.1, b.1)?;
            }
        } else {
            writeln!(
                out,
                "    both bounded: max |diff max_theta| {d_max:.3e} rad; both escaped ({n_esc}): max |diff escape_t| {d_esc:.3} s"
            )?;
        }
        for f in &flips {
            writeln!(out, "    flip: {f}")?;
        }
    }
    Ok(out)
}

fn main() -> R<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: run PART CAND DIR [CELLS] | compare PART DIR REF CAND...";
    match args.first().map(String::as_str) {
        Some("run") if args.len() >= 4 => {
            let (part, cand, dir) = (&args[1], &args[2], &args[3]);
            let spec = parse_cand(cand)?;
            let cells: Option<Vec<usize>> = match args.get(4) {
                Some(f) => {
                    Some(std::fs::read_to_string(f)?.split_whitespace().map(str::parse).collect::<Result<_, _>>()?)
                }
                None => None,
            };
            let t0 = Instant::now();
            let rows = run_part(part, &spec, cells.as_deref())?;
            let secs = t0.elapsed().as_secs_f64();
            std::fs::create_dir_all(dir)?;
            let path = file_of(dir, part, cand);
            // Rows of an earlier run of other cells are kept (the reference is run in pieces).
            let mut all = read_rows(&path).unwrap_or_default();
            for r in rows {
                all.insert(r.index, (r.label, r.values));
            }
            let mut text = format!("# {part} {cand}: {} runs in {secs:.1} s wall\n", all.len());
            for (k, (label, v)) in &all {
                let vs: Vec<String> = v.iter().map(|x| format!("{x:e}")).collect();
                writeln!(text, "{k},{label},{}", vs.join(","))?;
            }
            std::fs::write(&path, text)?;
            println!("{part} {cand}: {} runs, {secs:.1} s wall -> {path}", all.len());
        }
        Some("compare") if args.len() >= 5 => print!("{}", compare(&args[1], &args[2], &args[3], &args[4..])?),
        _ => return Err(usage.into()),
    }
    Ok(())
}
