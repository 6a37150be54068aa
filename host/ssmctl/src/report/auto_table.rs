//! Report section: settings chosen by cross-validation (`fit --auto`) on every data set the
//! project has, with bootstrap intervals, against the exhaustive default grid
//! (`studies/results/auto/grid.json`, written by the example `auto_table`) and SSMLearnPy
//! with its example's settings (`studies/results/auto/ssmlearnpy.json`, written by
//! `host/python/bench/ssmlearnpy_table.py`).

use crate::report::Report;
use crate::report::prose::Prose;
use furuta::auto_sets::{AutoSet, GRID_COMMAND, GRID_PATH, GridResults, all_sets, eigenvalue_error, grid_file};
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

/// [`py_file`] relative to the workspace root, as messages name it.
pub const PY_PATH: &str = "studies/results/auto/ssmlearnpy.json";

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

fn row(
    set: &AutoSet,
    grid: Option<&GridResults>,
    py: Option<&PyResults>,
    replicates: usize,
) -> Result<Value, Box<dyn Error>> {
    let c = select(&set.train, &AutoOptions::default())?;
    let s = c.best.setting;
    let model = fit_multi(&cut(&set.train, s.cut), &s.options)?;
    let iv = intervals(&set.train, &s, &IntervalOptions { replicates, ..Default::default() })?;
    let e = leading_interval(&iv.eigenvalues).ok_or_else(|| format!("{}: no oscillatory eigenvalue", set.name))?;
    let g = grid.and_then(|g| g.row(&set.name));
    let grid_missing = || match grid {
        None => format!("not run: {GRID_PATH} absent (`{GRID_COMMAND}` writes it)"),
        Some(_) => format!("not in {GRID_PATH} (`{GRID_COMMAND} --resume` adds it)"),
    };
    let winner = g.map(|g| zeta_hz(g.winner_eig));
    let exact = set.exact.first().copied().map(zeta_hz);
    let auto_err = (!set.exact.is_empty()).then(|| eigenvalue_error(&model, &set.exact));
    let hz = |v: f64| v / TAU;
    let py_cell = match py {
        None => format!("not run: {PY_PATH} absent (`{PY_COMMAND}` writes it)"),
        Some(p) => match p.rows.iter().find(|r| r.set == set.name) {
            Some(PyRow { damping_ratio: Some(z), freq_hz: Some(f), settings, .. }) => {
                format!("{z:.5}, {f:.4} Hz ({})", settings.as_deref().unwrap_or("example settings"))
            }
            Some(PyRow { not_run: Some(why), .. }) => format!("not run: {why}"),
            Some(_) => format!("not run: {}", p.ssmlearnpy),
            None => "not run: the script reads data files only (simulated decays are made here in Rust)".into(),
        },
    };
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
        "auto_describe": s.describe(),
        "grid_winner_describe": g.map(|g| g.winner.describe()),
        "grid_settings": g.map(|g| g.settings),
        "grid_missing": grid_missing(),
    });
    Ok(json)
}

const INTRO: &str = "On every data set the project has, <code>ssmctl fit --auto</code>'s choice (coordinate descent \
    over the default grid, at most {{ budget }} settings, scored by held-out NMTE x (1 + spread of the linear part across \
    folds)), the damping ratio and frequency of its leading eigenvalue with {{ level | pct(0) }} % bootstrap intervals \
    (over trajectories, segments, or the residuals of a lone trajectory), the exact values where known, the winner of \
    the exhaustive grid (all {{ grid_size }} settings; read from <code>studies/results/auto/grid.json</code>), the ratio \
    of auto's held-out NMTE to the grid's smallest, the eigenvalue errors (relative to |lambda|) of auto and the grid \
    winner, and SSMLearnPy with its example's settings (<code>studies/results/auto/ssmlearnpy.json</code>). The Furuta \
    runs are simulated from {{ furuta_thetas | min | plain }}-{{ furuta_thetas | max | plain }} rad at the paper's gains, \
    where the loop's leading pair lies just outside the unit circle (negative damping). On noise-free data (Duffing, \
    Furuta) an interval measures the spread of the estimate over resampled data, not the bias of the truncated model, \
    which can be larger: the exact value may lie just outside it.";
const MISSING: &str = "The sloshing decays are left out: {{ sloshing_dir }} not found.";
const CELLS: [&str; 10] = [
    "{{ set }}",
    "{{ auto_describe }}",
    "{{ damping_ratio.estimate | fixed(5) }} [{{ damping_ratio.lo | fixed(5) }}, {{ damping_ratio.hi | fixed(5) }}]",
    "{{ freq_hz.estimate | fixed(4) }} [{{ freq_hz.lo | fixed(4) }}, {{ freq_hz.hi | fixed(4) }}]",
    "{% if exact is none %}-{% else %}{{ exact.damping_ratio | fixed(5) }}, {{ exact.freq_hz | fixed(4) }}{% endif %}",
    "{% if grid_winner_describe is none %}{{ grid_missing }}{% else %}{{ grid_winner_describe }} ({{ grid_settings }} \
     settings){% endif %}",
    "{% if grid_winner_damping_ratio is none %}-{% else %}{{ grid_winner_damping_ratio | fixed(5) }}, {{ \
     grid_winner_freq_hz | fixed(4) }}{% endif %}",
    "{% if nmte_auto_over_grid_min is none %}-{% else %}{{ nmte_auto_over_grid_min | fixed(2) }}{% endif %}",
    "{% if eig_error_auto is none %}-{% else %}{{ eig_error_auto | sci(1) }} / {% if eig_error_grid_winner is none \
     %}-{% else %}{{ eig_error_grid_winner | sci(1) }}{% endif %}{% endif %}",
    "{{ ssmlearnpy }}",
];
const FOOT: &str = "{{ replicates }} bootstrap replicates per interval. The grid results are refreshed by <code>{{ \
    grid_command }}</code>; <code>docs/fit-auto.md</code> reads them for the choice of defaults.";

/// The section; the data sets absent from `data_dir` (sloshing) are left out with a note.
/// Summary key `fit_auto` (with what the text reads besides the rows).
pub fn section(rep: &mut Report, data_dir: &Path, quick: bool) -> Result<(), Box<dyn Error>> {
    let grid = if grid_file().is_file() { Some(GridResults::load(&grid_file())?) } else { None };
    let py = load_py(&py_file())?;
    let sets = all_sets(data_dir)?;
    let sloshing_missing = !sets.iter().any(|s| s.name.starts_with("sloshing"));
    let replicates = if quick { 50 } else { 200 };
    let rows =
        crate::report::par_map(&sets, |s| row(s, grid.as_ref(), py.as_ref(), replicates).map_err(|e| e.to_string()))?;
    let o = AutoOptions::default();
    rep.summary.insert(
        "fit_auto".into(),
        json!({"replicates": replicates, "rows": rows,
               "budget": o.budget, "level": IntervalOptions::default().level, "grid_size": o.grid.size(),
               "furuta_thetas": furuta::auto_sets::FURUTA_THETAS, "grid_command": GRID_COMMAND,
               "sloshing_dir": sloshing_missing.then(|| data_dir.join("sloshing").display().to_string())}),
    );
    render(rep, &rep.summary["fit_auto"].clone())
}

/// Writes the section from its summary value `v` (`fit_auto`).
pub fn render(rep: &mut Report, v: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    rep.section(
        "fit-auto",
        "Fits that choose their own settings: cross-validation against the exhaustive grid",
        &p.html("fit-auto/intro", INTRO, v)?,
    );
    if !v["sloshing_dir"].is_null() {
        rep.para(&p.html("fit-auto/missing", MISSING, v)?);
    }
    let rows = v["rows"].as_array().ok_or("report: fit_auto.rows is not a list")?;
    let zeta = p.text("fit-auto/head", "damping ratio [{{ level | pct(0) }} %]", v)?;
    let hz = p.text("fit-auto/head", "frequency Hz [{{ level | pct(0) }} %]", v)?;
    rep.table(
        &[
            "data set",
            "auto's choice",
            zeta.as_str(),
            hz.as_str(),
            "exact damping, Hz",
            "exhaustive grid's winner",
            "its damping, Hz",
            "NMTE auto / grid min",
            "eig. error auto / winner",
            "SSMLearnPy (example settings)",
        ],
        &p.rows("fit-auto/row", &CELLS, rows)?,
    );
    rep.para(&p.html("fit-auto/foot", FOOT, v)?);
    Ok(())
}
