//! `ssm::auto` against the exhaustive default grid (2,187 settings) on every data set of
//! [`furuta::auto_sets::all_sets`]: the Duffing CSVs, one Duffing CSV alone, `duffing.mat`,
//! the sloshing decays (`--data-dir`, default `../shared/data` from the workspace root) and
//! the Furuta decays at three sampling periods.
//!
//!     nice cargo run --release -p furuta --example auto_table -- --write [--data-dir DIR]
//!
//! Prints one row per data set (auto's choice, the grid's winner, the ratios auto / grid of
//! held-out NMTE and eigenvalue error, the costs); with `--write` also writes
//! `studies/results/auto/grid.json`, which the report's auto table and `docs/fit-auto.md`
//! read. Slow (minutes): not part of the tests.

use std::path::PathBuf;

use furuta::auto_sets::{GRID_COMMAND, GridResults, all_sets, grid_file, grid_row};
use ssm::auto::AutoOptions;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let write = args.iter().any(|a| a == "--write");
    let data_dir = match args.iter().position(|a| a == "--data-dir") {
        Some(i) => PathBuf::from(args.get(i + 1).ok_or("--data-dir needs a folder")?),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
    };
    if let Some(a) = args.iter().find(|a| a.starts_with("--") && *a != "--write" && *a != "--data-dir") {
        return Err(format!("unknown option {a}; use --write, --data-dir DIR").into());
    }
    let o = AutoOptions::default();
    let mut rows = Vec::new();
    println!(
        "| data set | auto's choice | grid winner | NMTE auto / grid min | eig. error auto / grid winner / grid min | auto s (settings) | grid s |"
    );
    println!("|---|---|---|---|---|---|---|");
    for set in all_sets(&data_dir)? {
        let r = grid_row(&set, &o)?;
        let eig = match (r.auto_eig_error, r.winner_eig_error, r.min_eig_error) {
            (Some(a), Some(w), Some(m)) => format!("{a:.2e} / {w:.2e} / {m:.2e}"),
            _ => "-".into(),
        };
        println!(
            "| {} | {} | {} | {:.4} / {:.4} | {eig} | {:.2} ({}) | {:.0} |",
            r.set,
            r.auto.describe(),
            r.winner.describe(),
            r.auto_nmte,
            r.min_nmte,
            r.auto_seconds,
            r.auto_evaluated,
            r.seconds
        );
        rows.push(r);
    }
    if write {
        let res = GridResults { command: GRID_COMMAND.into(), grid: o.grid, rows };
        let path = grid_file();
        let dir = path.parent().ok_or("grid file has no folder")?;
        fileio::create_dir(dir)?;
        fileio::write_atomic(&path, format!("{}\n", serde_json::to_string_pretty(&res)?).as_bytes())?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}
