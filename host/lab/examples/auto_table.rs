//! `ssm::auto` against the exhaustive default grid (2,187 settings) on every data set of
//! [`furuta::auto_sets::all_sets`]: the Duffing CSVs, one Duffing CSV alone, `duffing.mat`,
//! the sloshing decays (`--data-dir`, default `../shared/data` from the workspace root) and
//! the Furuta decays at three sampling periods.
//!
//!     nice cargo run --profile test -p lab --example auto_table -- --write [--data-dir DIR]
//!
//! Prints one row per data set (auto's choice, the grid's winner, the ratios auto / grid of
//! held-out NMTE and eigenvalue error, the costs); with `--write` also writes
//! `studies/results/auto/grid.json`, which the report's auto table reads, and
//! `docs/fit-auto-grid.md` from it. Slow (tens of minutes): not part of the tests.
//!
//!     cargo run --profile test -p lab --example auto_table -- --docs
//!
//! only rewrites `docs/fit-auto-grid.md` from the stored `grid.json`; `--write --resume`
//! keeps the stored rows and runs the data sets missing from them (the file is rewritten
//! after each data set).

use std::path::PathBuf;

use furuta::auto_sets::{GRID_COMMAND, GridResults, all_sets, grid_file, grid_row};
use ssm::auto::AutoOptions;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let write = args.iter().any(|a| a == "--write");
    if args.iter().any(|a| a == "--docs") {
        return write_docs(&GridResults::load(&grid_file())?);
    }
    let data_dir = match args.iter().position(|a| a == "--data-dir") {
        Some(i) => PathBuf::from(args.get(i + 1).ok_or("--data-dir needs a folder")?),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"),
    };
    if let Some(a) =
        args.iter().find(|a| a.starts_with("--") && *a != "--write" && *a != "--resume" && *a != "--data-dir")
    {
        return Err(format!("unknown option {a}; use --write, --resume, --docs, --data-dir DIR").into());
    }
    let o = AutoOptions::default();
    // With --write the file is rewritten after each data set; --resume keeps the rows of a
    // stored file made with the same grid and runs only the data sets it lacks.
    let resume = args.iter().any(|a| a == "--resume");
    let mut rows: Vec<furuta::auto_sets::GridRow> =
        if resume && grid_file().is_file() { GridResults::load(&grid_file())?.rows } else { Vec::new() };
    let save = |rows: &[furuta::auto_sets::GridRow]| -> Result<(), Box<dyn std::error::Error>> {
        let res = GridResults { command: GRID_COMMAND.into(), grid: o.grid.clone(), rows: rows.to_vec() };
        let path = grid_file();
        let dir = path.parent().ok_or("grid file has no folder")?;
        fileio::create_dir(dir)?;
        fileio::write_atomic(&path, format!("{}\n", serde_json::to_string_pretty(&res)?).as_bytes())?;
        eprintln!("wrote {} ({} data sets)", path.display(), rows.len());
        Ok(())
    };
    println!(
        "| data set | auto's choice | grid winner | NMTE auto / grid min | eig. error auto / grid winner / grid min | auto s (settings) | grid s |"
    );
    println!("|---|---|---|---|---|---|---|");
    for set in all_sets(&data_dir)? {
        if rows.iter().any(|r| r.set == set.name) {
            eprintln!("{}: kept from the stored file", set.name);
            continue;
        }
        let r = grid_row(&set, &o)?;
        let eig = match (r.auto_eig_error, r.winner_eig_error, r.min_eig_error) {
            (Some(a), Some(w), Some(m)) => format!("{a:.2e} / {w:.2e} / {m:.2e}"),
            _ => "-".into(),
        };
        println!(
            "| {} | {} | {} | {:.3e} / {:.3e} | {eig} | {:.2} ({}) | {:.0} |",
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
        if write {
            save(&rows)?;
        }
    }
    if write {
        write_docs(&GridResults::load(&grid_file())?)?;
    }
    Ok(())
}

/// `docs/fit-auto-grid.md`: per data set, the knobs of auto's choice and of the grid's winner,
/// and the ratios; the evidence `docs/fit-auto.md` decides the defaults from.
fn write_docs(res: &GridResults) -> Result<(), Box<dyn std::error::Error>> {
    use std::fmt::Write as _;
    let mut md = String::new();
    writeln!(md, "# `fit --auto` against the exhaustive grid: the data (generated)")?;
    writeln!(md)?;
    writeln!(
        md,
        "Written by `{GRID_COMMAND}` (or `-- --docs` from the stored `studies/results/auto/grid.json`); do not edit. \
         The grid: {} settings per data set (cut x embedding x shift x manifold order x dynamics order x ridge x \
         joint anchor, `ssm::auto::AutoGrid::default()`), each scored as `fit --auto` scores: held-out NMTE \
         x (1 + spread of the linear part across folds). Eigenvalue errors are relative to the exact modulus, \
         against the exact modes the model's dimension holds.",
        res.grid.size()
    )?;
    writeln!(md)?;
    writeln!(
        md,
        "| data set | dim | chooser | cut | embed | shift | manifold | dynamics | ridge | anchor | held-out NMTE | eig. error |"
    )?;
    writeln!(md, "|---|---|---|---|---|---|---|---|---|---|---|---|")?;
    for r in &res.rows {
        for (who, s, nmte, eig) in [
            ("auto", &r.auto, r.auto_nmte, r.auto_eig_error),
            ("grid winner", &r.winner, r.winner_nmte, r.winner_eig_error),
        ] {
            let o = &s.options;
            writeln!(
                md,
                "| {} | {} | {who} | {:.0} % | {} | {} | {} | {} | {} | {} | {nmte:.3e} | {} |",
                r.set,
                o.dim,
                100.0 * s.cut,
                o.embed,
                o.shift,
                o.manifold_order,
                o.dyn_order,
                match o.ridge {
                    ssm::Ridge::Fixed(a) => format!("{a:e}"),
                    ssm::Ridge::CrossValidated => "cv".into(),
                },
                o.linear_anchor.map_or("off".into(), |a| format!("{a}")),
                eig.map_or("-".into(), |e| format!("{e:.2e}")),
            )?;
        }
    }
    writeln!(md)?;
    writeln!(
        md,
        "| data set | NMTE auto / grid min | eig. error auto / winner / grid min | auto: settings, s | grid s |"
    )?;
    writeln!(md, "|---|---|---|---|---|")?;
    for r in &res.rows {
        let eig = match (r.auto_eig_error, r.winner_eig_error, r.min_eig_error) {
            (Some(a), Some(w), Some(m)) => format!("{a:.2e} / {w:.2e} / {m:.2e}"),
            _ => "-".into(),
        };
        writeln!(
            md,
            "| {} | {:.3} | {eig} | {}, {:.1} | {:.0} |",
            r.set,
            r.auto_nmte / r.min_nmte,
            r.auto_evaluated,
            r.auto_seconds,
            r.seconds
        )?;
    }
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/fit-auto-grid.md");
    fileio::write_atomic(&path, md.as_bytes())?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
