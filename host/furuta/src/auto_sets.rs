//! The data sets on which `ssm::auto` is compared with the exhaustive grid (the 1.2x test,
//! the example `auto_table` and the report's table): the bundled Duffing decays (CSV and
//! `.mat`, exact eigenvalue known), the measured sloshing decays, and simulated runs of the
//! Furuta loop at several sampling periods from small displacements, whose exact linear
//! eigenvalues are the closed-loop multipliers of the scene's exact ZOH map, `ln(mu) / dt`.
//! (At the paper's gains the loop's leading pair, 8-10 Hz, lies just outside the unit
//! circle and a slow pair, 0.44 Hz, just inside: the runs are a slowly growing fast
//! oscillation over a decaying slow one, not pure decays.)

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use sim::closed_loop::simulate;
use sim::scene::SceneBuilder;
use sim::stability::dominant_pairs;
use ssm::auto::{AutoGrid, AutoOptions, Setting, cut, exhaustive, select};
use ssm::{MultiSeries, fit_multi, load_csv_observables, load_mat};

use crate::error::Error;

/// Exact damped Duffing oscillator of the bundled data (`host/ssm/tests/data/make_mat.py`):
/// `w = 2 pi`, `zeta = 0.02`.
pub const DUFFING_W: f64 = std::f64::consts::TAU;
pub const DUFFING_ZETA: f64 = 0.02;

/// Scenes of the Furuta decays: far from, near and at the edge of the loop's stability
/// boundary.
pub const FURUTA_SCENES: [&str; 3] = ["furuta-dt25", "furuta-dt30.8", "furuta-dt31.4"];
/// Initial pendulum angles of the Furuta decays, rad: small, so the decays stay near the
/// linear regime the exact multipliers describe.
pub const FURUTA_THETAS: [f64; 3] = [0.04, 0.03, 0.02];

/// One data set: its trajectories and, where known, the exact continuous-time eigenvalues
/// of its modes (`re`, `im >= 0`, one per conjugate pair), leading (largest multiplier)
/// first; empty when unknown.
#[derive(Clone, Debug)]
pub struct AutoSet {
    pub name: String,
    pub train: Vec<MultiSeries>,
    pub exact: Vec<(f64, f64)>,
}

/// The bundled Duffing data folder.
pub fn duffing_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../ssm/tests/data")
}

fn duffing_exact() -> (f64, f64) {
    (-DUFFING_ZETA * DUFFING_W, DUFFING_W * (1.0 - DUFFING_ZETA * DUFFING_ZETA).sqrt())
}

/// The three Duffing CSVs through `x` alone.
pub fn duffing_csv() -> Result<AutoSet, Error> {
    let dir = duffing_dir();
    let train = (1..=3)
        .map(|i| load_csv_observables(dir.join(format!("duffing_{i}.csv")), Some(&["x".to_string()])))
        .collect::<Result<Vec<_>, _>>()?;
    Ok(AutoSet { name: "Duffing CSVs (x, 3 decays)".into(), train, exact: vec![duffing_exact()] })
}

/// The first Duffing CSV alone (one trajectory: blocked folds, residual bootstrap).
pub fn duffing_single() -> Result<AutoSet, Error> {
    let mut s = duffing_csv()?;
    s.train.truncate(1);
    s.name = "Duffing CSV 1 alone (x)".into();
    Ok(s)
}

/// `duffing.mat` (`xData`, three observables per decay).
pub fn duffing_mat() -> Result<AutoSet, Error> {
    let train = load_mat(duffing_dir().join("duffing.mat"), "xData")?;
    Ok(AutoSet { name: "Duffing .mat (3 observables, 3 decays)".into(), train, exact: vec![duffing_exact()] })
}

/// The sloshing decays of `data_dir/sloshing`; `None` when the folder is absent.
pub fn sloshing(data_dir: &Path) -> Result<Option<AutoSet>, Error> {
    let dir = data_dir.join("sloshing");
    let files: Vec<PathBuf> = (0..3).map(|i| dir.join(format!("decay_{i}.csv"))).collect();
    if !files.iter().all(|f| f.is_file()) {
        return Ok(None);
    }
    let train = files.iter().map(|f| load_csv_observables(f, None)).collect::<Result<Vec<_>, _>>()?;
    Ok(Some(AutoSet { name: "sloshing (3 measured decays)".into(), train, exact: Vec::new() }))
}

/// Decays of the pendulum angle of scene `scene` from `theta0` in `thetas` (the other states
/// at rest), `periods` samples each, and the exact eigenvalue of the leading multiplier pair.
pub fn furuta_decays(scene: &str, thetas: &[f64], periods: u64) -> Result<AutoSet, Error> {
    let mut train = Vec::with_capacity(thetas.len());
    let mut dt = f64::NAN;
    let mut exact = Vec::new();
    for &th in thetas {
        let s = SceneBuilder::load(scene)?.initial_state(&[th, 0.0, 0.0, 0.0]).periods(periods).build()?;
        let tr = simulate(&s, None)?;
        if let Some(why) = tr.stopped {
            return Err(Error::Escaped { dt_ms: s.controller.dt_ms, ic: [th, 0.0, 0.0, 0.0], why });
        }
        if exact.is_empty() {
            dt = s.dt();
            exact = dominant_pairs(&s)?.iter().map(|m| (m.abs.ln() / dt, m.im.atan2(m.re) / dt)).collect();
            if exact.is_empty() {
                return Err(Error::BadInput { what: "scene", why: format!("{scene}: no closed-loop multiplier") });
            }
        }
        train.push(MultiSeries::new(
            format!("{scene} theta0 = {th}"),
            tr.t.clone(),
            vec!["theta".into()],
            tr.primary(),
        )?);
    }
    Ok(AutoSet { name: format!("Furuta {scene} ({} runs, {:.1} ms)", thetas.len(), 1e3 * dt), train, exact })
}

/// Eigenvalue error of `m` against the exact modes `exact` (leading first): for each of the
/// first `dim / 2` exact eigenvalues (at least one), the distance of the closest fitted
/// eigenvalue (conjugates matched), relative to the exact one's modulus; the largest of these.
pub fn eigenvalue_error(m: &ssm::SsmModel, exact: &[(f64, f64)]) -> f64 {
    let eig = m.eigenvalues_ct();
    let pairs = (m.options.dim / 2).max(1).min(exact.len());
    exact[..pairs]
        .iter()
        .map(|x| eig.iter().map(|e| (e.0 - x.0).hypot(e.1.abs() - x.1) / x.0.hypot(x.1)).fold(f64::INFINITY, f64::min))
        .fold(0.0, f64::max)
}

/// Samples per Furuta decay.
pub const FURUTA_PERIODS: u64 = 400;

/// Every data set, in the table's order; sloshing only when `data_dir/sloshing` exists.
pub fn all_sets(data_dir: &Path) -> Result<Vec<AutoSet>, Error> {
    let mut out = vec![duffing_csv()?, duffing_single()?, duffing_mat()?];
    out.extend(sloshing(data_dir)?);
    for scene in FURUTA_SCENES {
        out.push(furuta_decays(scene, &FURUTA_THETAS, FURUTA_PERIODS)?);
    }
    Ok(out)
}

/// The leading eigenvalue of a list: the slowest decaying one with `im > 0` (the first
/// when none oscillates).
pub fn leading(eig: &[(f64, f64)]) -> Option<(f64, f64)> {
    eig.iter().copied().filter(|e| e.1 > 0.0).max_by(|a, b| a.0.total_cmp(&b.0)).or_else(|| eig.first().copied())
}

/// The exhaustive grid on one data set, and auto's choice in the same run.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridRow {
    pub set: String,
    /// SSM dimension (from the singular values, as auto chooses it).
    pub dim: usize,
    /// Settings scored and the wall time of the whole grid, s.
    pub settings: usize,
    pub seconds: f64,
    /// The grid's winner by auto's score, its held-out NMTE, and its leading eigenvalue
    /// fitted on all the data (after its cut).
    pub winner: Setting,
    pub winner_score: f64,
    pub winner_nmte: f64,
    pub winner_eig: (f64, f64),
    /// Smallest held-out NMTE of any setting.
    pub min_nmte: f64,
    /// Eigenvalue errors (relative to |exact|) of the winner and the smallest of any
    /// setting, where the exact value is known.
    pub winner_eig_error: Option<f64>,
    pub min_eig_error: Option<f64>,
    /// Auto's choice in the same run, its NMTE and eigenvalue error, settings scored, wall s.
    pub auto: Setting,
    pub auto_nmte: f64,
    pub auto_eig_error: Option<f64>,
    pub auto_evaluated: usize,
    pub auto_seconds: f64,
}

/// `studies/results/auto/grid.json`: the full default grid on every data set.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GridResults {
    /// The command that wrote the file.
    pub command: String,
    pub grid: AutoGrid,
    pub rows: Vec<GridRow>,
}

/// The command that refreshes [`grid_file`].
pub const GRID_COMMAND: &str = "nice cargo run --profile test -p lab --example auto_table -- --write";

/// Where the bundled grid results live, relative to the workspace root (as messages name it).
pub const GRID_PATH: &str = "studies/results/auto/grid.json";

/// [`GRID_PATH`] in this source tree.
pub fn grid_file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(GRID_PATH)
}

impl GridResults {
    /// Reads `path`; the error names the file and what is wrong.
    pub fn load(path: &Path) -> Result<Self, Error> {
        let bad =
            |why: String| Error::BadInput { what: "auto grid results", why: format!("{}: {why}", path.display()) };
        let text = infile::read_text(path, infile::MAX_REPORT_INPUT_BYTES)
            .map_err(|e| bad(format!("{e} (`{GRID_COMMAND}` writes it)")))?;
        let de = &mut serde_json::Deserializer::from_str(&text);
        let r: GridResults = serde_path_to_error::deserialize(de).map_err(|e| bad(e.to_string()))?;
        if r.grid != AutoGrid::default() {
            return Err(bad(format!("made with another grid than the default; run `{GRID_COMMAND}`")));
        }
        Ok(r)
    }

    /// The row of data set `name`.
    pub fn row(&self, name: &str) -> Option<&GridRow> {
        self.rows.iter().find(|r| r.set == name)
    }
}

/// Runs auto and the exhaustive grid `o.grid` on `set` (the row of [`GridResults`]).
pub fn grid_row(set: &AutoSet, o: &AutoOptions) -> Result<GridRow, Error> {
    let t0 = Instant::now();
    let auto = select(&set.train, o)?;
    let auto_seconds = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let (all, at) = exhaustive(&set.train, o)?;
    let seconds = t0.elapsed().as_secs_f64();
    let fit = |s: &Setting| fit_multi(&cut(&set.train, s.cut), &s.options);
    let w = &all[at];
    let wm = fit(&w.setting)?;
    let known = !set.exact.is_empty();
    let err = |m: &ssm::SsmModel| known.then(|| eigenvalue_error(m, &set.exact));
    let min_eig_error = known.then(|| {
        all.par_iter()
            .filter_map(|s| fit(&s.setting).ok().map(|m| eigenvalue_error(&m, &set.exact)))
            .filter(|v| v.is_finite())
            .reduce(|| f64::INFINITY, f64::min)
    });
    Ok(GridRow {
        set: set.name.clone(),
        dim: w.setting.options.dim,
        settings: all.len(),
        seconds,
        winner: w.setting,
        winner_score: w.score,
        winner_nmte: w.nmte,
        winner_eig: leading(wm.eigenvalues_ct()).unwrap_or((f64::NAN, f64::NAN)),
        min_nmte: all.iter().map(|s| s.nmte).fold(f64::INFINITY, f64::min),
        winner_eig_error: err(&wm),
        min_eig_error,
        auto: auto.best.setting,
        auto_nmte: auto.best.nmte,
        auto_eig_error: err(&fit(&auto.best.setting)?),
        auto_evaluated: auto.evaluated,
        auto_seconds,
    })
}
