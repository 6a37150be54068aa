//! Report section: settings chosen by cross-validation (`fit --auto`) on every data set the
//! project has, with bootstrap intervals, against the exhaustive default grid
//! (`studies/results/auto/grid.json`, written by the example `auto_table`) and SSMLearnPy
//! with its example's settings (`studies/results/auto/ssmlearnpy.json`, written by
//! `host/python/bench/ssmlearnpy_table.py`).

use crate::report::{Report, esc};
use furuta::auto_sets::{AutoSet, GRID_COMMAND, GridResults, all_sets, eigenvalue_error, grid_file};
use serde::Deserialize;
use serde_json::{Value, json};
use ssm::auto::{AutoOptions, EigenInterval, IntervalOptions, cut, intervals, select};
use ssm::fit_multi;
use std::error::Error;
use std::f64::consts::TAU;
use std::path::{Path, PathBuf};

/// SSMLearnPy's results with its example's settings, per data set.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PyResults {
    pub command: String,
    /// The SSMLearnPy source it ran (commit), or why it could not run at all.
    pub ssmlearnpy: String,
    pub rows: Vec<PyRow>,
}

/// One data set: the leading eigenvalue's damping ratio and frequency, or why not.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PyRow {
    pub set: String,
    pub settings: Option<String>,
    pub damping_ratio: Option<f64>,
    pub freq_hz: Option<f64>,
    pub not_run: Option<String>,
}

/// The command that writes [`py_file`].
pub const PY_COMMAND: &str = "python host/python/bench/ssmlearnpy_table.py --write";

pub fn py_file() -> PathBuf {
    grid_file().with_file_name("ssmlearnpy.json")
}

fn load_py(path: &Path) -> Result<Option<PyResults>, Box<dyn Error>> {
    if !path.is_file() {
        return Ok(None);
    }
    let text =
        infile::read_text(path, infile::MAX_REPORT_INPUT_BYTES).map_err(|e| format!("{}: {e}", path.display()))?;
    let r: PyResults = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(Some(r))
}

/// The damping ratio and frequency (Hz) of a continuous-time eigenvalue.
fn zeta_hz(e: (f64, f64)) -> (f64, f64) {
    (-e.0 / e.0.hypot(e.1), e.1 / TAU)
}

/// The interval of the leading eigenvalue: the slowest decaying one with `im > 0`.
fn leading_interval(iv: &[EigenInterval]) -> Option<&EigenInterval> {
    iv.iter().filter(|e| e.im.estimate > 0.0).max_by(|a, b| a.re.estimate.total_cmp(&b.re.estimate))
}

struct Row {
    cells: Vec<String>,
    json: Value,
}

fn row(
    set: &AutoSet,
    grid: Option<&GridResults>,
    py: Option<&PyResults>,
    replicates: usize,
) -> Result<Row, Box<dyn Error>> {
    let c = select(&set.train, &AutoOptions::default())?;
    let s = c.best.setting;
    let model = fit_multi(&cut(&set.train, s.cut), &s.options)?;
    let iv = intervals(&set.train, &s, &IntervalOptions { replicates, ..Default::default() })?;
    let e = leading_interval(&iv.eigenvalues).ok_or_else(|| format!("{}: no oscillatory eigenvalue", set.name))?;
    let g = grid.and_then(|g| g.row(&set.name));
    let grid_missing = || match grid {
        None => format!("not run: {} absent (`{GRID_COMMAND}` writes it)", grid_file().display()),
        Some(_) => format!("not in {} (`{GRID_COMMAND} --resume` adds it)", grid_file().display()),
    };
    let winner = g.map(|g| zeta_hz(g.winner_eig));
    let exact = set.exact.first().copied().map(zeta_hz);
    let auto_err = (!set.exact.is_empty()).then(|| eigenvalue_error(&model, &set.exact));
    let hz = |v: f64| v / TAU;
    let py_cell = match py {
        None => format!("not run: {} absent (`{PY_COMMAND}` writes it)", py_file().display()),
        Some(p) => match p.rows.iter().find(|r| r.set == set.name) {
            Some(PyRow { damping_ratio: Some(z), freq_hz: Some(f), settings, .. }) => {
                format!("{z:.5}, {f:.4} Hz ({})", settings.as_deref().unwrap_or("example settings"))
            }
            Some(PyRow { not_run: Some(why), .. }) => format!("not run: {why}"),
            Some(_) => format!("not run: {}", p.ssmlearnpy),
            None => "not run: the script reads data files only (simulated decays are made here in Rust)".into(),
        },
    };
    let cells = vec![
        set.name.clone(),
        s.describe(),
        format!("{:.5} [{:.5}, {:.5}]", e.damping_ratio.estimate, e.damping_ratio.lo, e.damping_ratio.hi),
        format!("{:.4} [{:.4}, {:.4}]", hz(e.im.estimate), hz(e.im.lo), hz(e.im.hi)),
        exact.map_or("-".into(), |(z, f)| format!("{z:.5}, {f:.4}")),
        g.map_or_else(grid_missing, |g| format!("{} ({} settings)", g.winner.describe(), g.settings)),
        winner.map_or("-".into(), |(z, f)| format!("{z:.5}, {f:.4}")),
        g.map_or("-".into(), |g| format!("{:.2}", c.best.nmte / g.min_nmte)),
        match (auto_err, g.and_then(|g| g.winner_eig_error)) {
            (Some(a), Some(w)) => format!("{a:.1e} / {w:.1e}"),
            (Some(a), None) => format!("{a:.1e} / -"),
            _ => "-".into(),
        },
        py_cell.clone(),
    ];
    let json = json!({
        "set": set.name,
        "auto": s,
        "auto_nmte": c.best.nmte,
        "damping_ratio": e.damping_ratio,
        "freq_hz": {"estimate": hz(e.im.estimate), "lo": hz(e.im.lo), "hi": hz(e.im.hi)},
        "interval_method": iv.method,
        "exact": exact.map(|(z, f)| json!({"damping_ratio": z, "freq_hz": f})),
        "grid_winner": g.map(|g| g.winner),
        "grid_winner_damping_ratio": winner.map(|w| w.0),
        "grid_winner_freq_hz": winner.map(|w| w.1),
        "nmte_auto_over_grid_min": g.map(|g| c.best.nmte / g.min_nmte),
        "eig_error_auto": auto_err,
        "eig_error_grid_winner": g.and_then(|g| g.winner_eig_error),
        "ssmlearnpy": py_cell,
    });
    Ok(Row { cells, json })
}

/// The section; the data sets absent from `data_dir` (sloshing) are left out with a note.
pub fn section(rep: &mut Report, data_dir: &Path, quick: bool) -> Result<(), Box<dyn Error>> {
    rep.section(
        "fit-auto",
        "Fits that choose their own settings: cross-validation against the exhaustive grid",
        "On every data set the project has, <code>ssmctl fit --auto</code>'s choice (coordinate descent over the \
         default grid, at most 40 settings, scored by held-out NMTE x (1 + spread of the linear part across folds)), \
         the damping ratio and frequency of its leading eigenvalue with 95 % bootstrap intervals (over trajectories, \
         segments, or the residuals of a lone trajectory), the exact values where known, the winner of the exhaustive \
         grid (all 2,187 settings; read from <code>studies/results/auto/grid.json</code>), the ratio of auto's held-out \
         NMTE to the grid's smallest, the eigenvalue errors (relative to |lambda|) of auto and the grid winner, and \
         SSMLearnPy with its example's settings (<code>studies/results/auto/ssmlearnpy.json</code>). The Furuta runs \
         are simulated from 0.02-0.04 rad at the paper's gains, where the loop's leading pair lies just outside the \
         unit circle (negative damping). On noise-free data (Duffing, Furuta) an interval measures the spread of \
         the estimate over resampled data, not the bias of the truncated model, which can be larger: the exact \
         value may lie just outside it.",
    );
    let grid = if grid_file().is_file() { Some(GridResults::load(&grid_file())?) } else { None };
    let py = load_py(&py_file())?;
    let sets = all_sets(data_dir)?;
    if !sets.iter().any(|s| s.name.starts_with("sloshing")) {
        rep.para(&format!(
            "The sloshing decays are left out: {} not found.",
            esc(&data_dir.join("sloshing").display().to_string())
        ));
    }
    let replicates = if quick { 50 } else { 200 };
    let rows =
        crate::report::par_map(&sets, |s| row(s, grid.as_ref(), py.as_ref(), replicates).map_err(|e| e.to_string()))?;
    rep.table(
        &[
            "data set",
            "auto's choice",
            "damping ratio [95 %]",
            "frequency Hz [95 %]",
            "exact damping, Hz",
            "exhaustive grid's winner",
            "its damping, Hz",
            "NMTE auto / grid min",
            "eig. error auto / winner",
            "SSMLearnPy (example settings)",
        ],
        &rows.iter().map(|r| r.cells.clone()).collect::<Vec<_>>(),
    );
    rep.para(&format!(
        "{replicates} bootstrap replicates per interval. The grid results are refreshed by <code>{}</code>; \
         <code>docs/fit-auto.md</code> reads them for the choice of defaults.",
        esc(GRID_COMMAND)
    ));
    rep.summary.insert(
        "fit_auto".into(),
        json!({"replicates": replicates, "rows": rows.iter().map(|r| r.json.clone()).collect::<Vec<_>>()}),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
