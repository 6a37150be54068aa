use furuta::auto_sets::{GRID_PATH, grid_file};
use ssmctl::report::Report;
use ssmctl::report::auto_table::*;
use std::path::Path;

/// The paths messages name are the files the section reads, relative to the workspace.
#[test]
fn message_paths_are_the_files_read() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let same = |a: &Path, b: &Path| a.canonicalize().unwrap() == b.canonicalize().unwrap();
    assert!(same(&root.join(GRID_PATH), &grid_file()));
    assert!(same(&root.join(PY_PATH), &py_file()));
}

/// The section on the bundled grid results (quick: fewer replicates): a row per data
/// set, auto's held-out NMTE within 1.2x of the grid's smallest, each interval ordered
/// and beside its estimate.
#[test]
fn the_auto_table_has_a_row_per_data_set() {
    let dir = std::env::temp_dir().join(format!("ssmctl-auto-table-{}", std::process::id()));
    let mut rep = Report::new(&dir).unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    section(&mut rep, &data, true).unwrap();
    let rows = rep.summary["fit_auto"]["rows"].as_array().unwrap().clone();
    for r in &rows {
        eprintln!(
            "{}: zeta {} Hz {} exact {} | {} | grid ratio {} | eig {} / {} | {}",
            r["set"],
            r["damping_ratio"],
            r["freq_hz"],
            r["exact"],
            r["interval_method"],
            r["nmte_auto_over_grid_min"],
            r["eig_error_auto"],
            r["eig_error_grid_winner"],
            r["ssmlearnpy"]
        );
    }
    assert!(rows.len() >= 6, "{rows:?}");
    for r in &rows {
        if let Some(ratio) = r["nmte_auto_over_grid_min"].as_f64() {
            assert!(ratio <= 1.2, "{}: NMTE auto / grid min {ratio}", r["set"]);
        }
        for k in ["damping_ratio", "freq_hz"] {
            let (lo, e, hi) =
                (r[k]["lo"].as_f64().unwrap(), r[k]["estimate"].as_f64().unwrap(), r[k]["hi"].as_f64().unwrap());
            // A percentile interval need not contain its estimate, but lies beside it.
            let w = hi - lo;
            assert!(w >= 0.0 && lo - w <= e && e <= hi + w, "{}: {k} {lo} {e} {hi}", r["set"]);
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
