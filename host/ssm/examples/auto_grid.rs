//! `ssm::auto` against the exhaustive default grid, with its cost, on the Duffing data
//! (`tests/data`, exact eigenvalue known) and the sloshing decays (`../shared/data`):
//!
//!     cargo run --release -p ssm --example auto_grid [-- --no-grid]
//!
//! Prints one table row per data set: auto's choice and cost, its damping ratio and
//! frequency with 95 % bootstrap intervals, the exhaustive grid's winner and the ratios
//! auto / grid of held-out NMTE (and of the eigenvalue error where the exact value is known).

use ssm::auto::{AutoOptions, IntervalOptions, exhaustive, intervals, select};
use ssm::{MultiSeries, load_csv_observables};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let grid = !std::env::args().any(|a| a == "--no-grid");
    let root = env!("CARGO_MANIFEST_DIR");
    let mut sets: Vec<(&str, Vec<MultiSeries>, Option<(f64, f64)>)> = Vec::new();
    let duffing: Vec<MultiSeries> = (1..=3)
        .map(|i| load_csv_observables(format!("{root}/tests/data/duffing_{i}.csv"), Some(&["x".to_string()])))
        .collect::<Result<_, _>>()?;
    let (w, z) = (std::f64::consts::TAU, 0.02);
    sets.push(("duffing x (3 traj.)", duffing.clone(), Some((-z * w, w * (1.0f64 - z * z).sqrt()))));
    sets.push(("duffing x, traj. 1 alone", duffing[..1].to_vec(), Some((-z * w, w * (1.0f64 - z * z).sqrt()))));
    let slosh = std::path::Path::new(root).join("../../../shared/data/sloshing");
    if slosh.is_dir() {
        let s: Vec<MultiSeries> = (0..3)
            .map(|i| load_csv_observables(slosh.join(format!("decay_{i}.csv")), None))
            .collect::<Result<_, _>>()?;
        sets.push(("sloshing (3 decays)", s, None));
    } else {
        eprintln!("sloshing skipped: {} not found", slosh.display());
    }
    let o = AutoOptions::default();
    println!(
        "| data set | auto's choice | auto s | settings | held-out NMTE | damping ratio [95 %] | frequency Hz [95 %] | bootstrap s | grid winner | grid s | NMTE auto/grid | eig. error auto/grid |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (name, train, exact) in sets {
        let t0 = Instant::now();
        let c = select(&train, &o)?;
        let t_auto = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let iv = intervals(&train, &c.best.setting, &IntervalOptions::default())?;
        let t_boot = t0.elapsed().as_secs_f64();
        let e = iv.eigenvalues[0];
        let eig_err = |s: &ssm::auto::Setting| -> Result<Option<f64>, Box<dyn std::error::Error>> {
            let m = ssm::fit_multi(&ssm::auto::cut(&train, s.cut), &s.options)?;
            Ok(exact.map(|(re, im)| {
                m.eigenvalues_ct().iter().map(|e| (e.0 - re).hypot(e.1.abs() - im) / re.hypot(im)).fold(0.0, f64::max)
            }))
        };
        let (grid_txt, t_grid, ratio_nmte, ratio_eig) = if grid {
            let t0 = Instant::now();
            let (all, at) = exhaustive(&train, &o)?;
            let t = t0.elapsed().as_secs_f64();
            let g = &all[at];
            let min_nmte = all.iter().map(|s| s.nmte).fold(f64::INFINITY, f64::min);
            let ratio_eig = match (eig_err(&c.best.setting)?, eig_err(&g.setting)?) {
                (Some(a), Some(b)) => format!("{:.2} ({a:.1e} / {b:.1e})", a / b),
                _ => "-".into(),
            };
            (
                format!("{} (NMTE {:.4}; grid min {:.4})", g.setting.describe(), g.nmte, min_nmte),
                format!("{t:.1}"),
                format!("{:.2}", c.best.nmte / g.nmte),
                ratio_eig,
            )
        } else {
            ("-".into(), "-".into(), "-".into(), "-".into())
        };
        let hz = |v: f64| v / std::f64::consts::TAU;
        println!(
            "| {name} | {} | {t_auto:.2} | {} | {:.4} | {:.4} [{:.4}, {:.4}] | {:.4} [{:.4}, {:.4}] | {t_boot:.2} | {grid_txt} | {t_grid} | {ratio_nmte} | {ratio_eig} |",
            c.best.setting.describe(),
            c.evaluated,
            c.best.nmte,
            e.damping_ratio.estimate,
            e.damping_ratio.lo,
            e.damping_ratio.hi,
            hz(e.im.estimate),
            hz(e.im.lo),
            hz(e.im.hi),
        );
        for r in &c.reasons {
            eprintln!("  {name}: {r}");
        }
    }
    Ok(())
}
