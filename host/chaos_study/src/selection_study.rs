//! A model-selection study as a spec (`kind = "selection"`): candidate reduced models fitted
//! on training series, run on their own from the test series' first point and chosen by
//! long-term statistics measured on both the same way (docs/decisions/0002,
//! [`crate::model_selection`]). `ssmctl study` runs such a spec; `ssmctl chaos` builds one
//! from its arguments ([`SelectionSpec::default_search`]: the flag study's centre-set
//! search, the report's, cut to a budget).
//!
//! The candidates are independent: [`prepare`] loads the data and measures the test series
//! once, [`evaluate`] measures one candidate (the unit a cache stores and a shard computes),
//! [`finish`] selects among the results in the spec's order, whatever computed them.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use ssm::TimeSeries;

use crate::Error;
use crate::flag_self::candidate_from_name;
use crate::flag_study::FlagStudySpec;
use crate::model_selection::{Candidate, CandidateResult, DataStats, EvalSettings, Selection, data_stats};
use chaos::Context;

/// The value of `kind` that marks a selection spec.
pub const KIND: &str = "selection";

/// The value of `kind` that marks a search spec: a selection spec whose candidates are named
/// in the search grammar ([`search_candidate`]) and whose result is the search table
/// ([`crate::study_results::SEARCH`]).
pub const SEARCH_KIND: &str = "search";

/// Window stride and Levenberg-Marquardt steps per stage of `multistep h=H` in a search name
/// that does not give them.
pub const SEARCH_MULTISTEP_DEFAULTS: (usize, usize) = (4, 10);

/// A candidate of a search spec by its name: `k=K d=D p=P s=S m=M (c=C | polynomial map order
/// O) r=R [smooth=W] [kernel KERNEL] [multistep h=H [stride S it I]] [denoised inputs W]
/// [centres CHOICE]`: map step K samples, SSM dimension D, embedding P with shift S (samples of
/// the subsampled series), manifold order M, an RBF map with C centres (kernel
/// [`ssm::Kernel::parse`], default linear) or a polynomial map, relative ridge R; the training
/// series smoothed by a moving average of W (odd) samples, multistep refinement
/// ([`SEARCH_MULTISTEP_DEFAULTS`]), the map refitted on inputs smoothed over W samples.
pub fn search_candidate(name: &str) -> Result<Candidate, Error> {
    let bad = |why: String| Error::BadInput { what: "search candidate", why: format!("`{name}`: {why}") };
    let toks: Vec<&str> = name.split_whitespace().collect();
    let mut i = 0;
    let count = |t: Option<&&str>, key: &str| -> Result<usize, Error> {
        let t = t.ok_or_else(|| bad(format!("`{key}` missing")))?;
        t.strip_prefix(key)
            .ok_or_else(|| bad(format!("expected `{key}N`, got `{t}`")))?
            .parse::<usize>()
            .map_err(|_| bad(format!("`{t}` is not {key}COUNT")))
    };
    let mut head = [0usize; 5];
    for (k, key) in ["k=", "d=", "p=", "s=", "m="].iter().enumerate() {
        head[k] = count(toks.get(i), key)?;
        i += 1;
    }
    let [step, dim, embed, shift, manifold_order] = head;
    let (mut centers, mut dyn_order) = (None, 4u32);
    if toks.get(i) == Some(&"polynomial") {
        if toks.get(i + 1..i + 3) != Some(&["map", "order"][..]) {
            return Err(bad("expected `polynomial map order O`".into()));
        }
        dyn_order = count(toks.get(i + 3), "")? as u32;
        i += 4;
    } else {
        centers = Some(count(toks.get(i), "c=")?);
        i += 1;
    }
    let ridge: f64 = toks
        .get(i)
        .and_then(|t| t.strip_prefix("r="))
        .ok_or_else(|| bad("`r=R` missing".into()))?
        .parse()
        .map_err(|_| bad("the ridge is not a number".into()))?;
    i += 1;
    let odd_half = |w: usize| -> Result<usize, Error> {
        if w < 3 || w.is_multiple_of(2) {
            Err(bad(format!("window {w}: must be odd and >= 3")))
        } else {
            Ok((w - 1) / 2)
        }
    };
    let (mut smooth, mut kernel, mut multistep, mut denoise, mut centres) =
        (0, ssm::Kernel::Linear, None, 0, ssm::dynamics::CentreChoice::Farthest);
    while let Some(&t) = toks.get(i) {
        i += 1;
        match t {
            _ if t.starts_with("smooth=") => smooth = odd_half(count(Some(&t), "smooth=")?)?,
            "kernel" => {
                kernel = ssm::Kernel::parse(toks.get(i).ok_or_else(|| bad("kernel missing".into()))?)
                    .map_err(|e| bad(e.to_string()))?;
                i += 1;
            }
            "multistep" => {
                let horizon = count(toks.get(i), "h=")?;
                i += 1;
                let (mut stride, mut iterations) = SEARCH_MULTISTEP_DEFAULTS;
                if toks.get(i) == Some(&"stride") {
                    stride = count(toks.get(i + 1), "")?;
                    i += 2;
                }
                if toks.get(i) == Some(&"it") {
                    iterations = count(toks.get(i + 1), "")?;
                    i += 2;
                }
                multistep = Some(ssm::multistep::MultiStep { horizon, stride, iterations });
            }
            "denoised" => {
                if toks.get(i) != Some(&"inputs") {
                    return Err(bad("expected `denoised inputs W`".into()));
                }
                denoise = odd_half(count(toks.get(i + 1), "")?)?;
                i += 2;
            }
            "centres" => {
                centres =
                    ssm::dynamics::CentreChoice::parse(toks.get(i).ok_or_else(|| bad("centre choice missing".into()))?)
                        .map_err(ssm::Error::from)?;
                i += 1;
            }
            _ => return Err(bad(format!("unknown token `{t}`"))),
        }
    }
    if step == 0 {
        return Err(bad("k=0: the map step must be >= 1".into()));
    }
    let dynamics = match (centers, kernel) {
        (None, _) => ssm::Dynamics::Map,
        (Some(c), ssm::Kernel::Linear) => ssm::Dynamics::Rbf { centers: c },
        (Some(c), kernel) => ssm::Dynamics::RbfWith { centers: c, kernel },
    };
    if centers.is_none() && kernel != ssm::Kernel::Linear {
        return Err(bad("a kernel needs an RBF map (c=C)".into()));
    }
    let fit = ssm::FitOptions {
        dim,
        embed,
        shift,
        manifold_order: manifold_order as u32,
        dyn_order,
        dynamics,
        ridge: ssm::Ridge::Fixed(ridge),
        linear_anchor: None,
        anchor_joint: false,
    };
    fit.validate().map_err(|e| bad(e.to_string()))?;
    Ok(Candidate { name: name.to_string(), step, fit, smooth, multistep, denoise_inputs: denoise, centres })
}

fn round(v: Option<f64>, decimals: i32) -> Option<f64> {
    let f = 10f64.powi(decimals);
    v.map(|v| (v * f).round() / f)
}

/// A candidate's result as a row of the search table, rounded as the table carries it
/// (exponents 3 decimals, D2 2, JS 4, excursion 2; a failed row has no model values).
pub fn search_row(r: &CandidateResult) -> crate::study_results::SearchRow {
    let ok = r.failed.is_none();
    let keep = |v: Option<f64>, d: i32| if ok { round(v, d) } else { None };
    crate::study_results::SearchRow {
        candidate: r.name.clone(),
        data_rosenstein: round(Some(r.data.lle), 3).unwrap_or(f64::NAN),
        benettin: keep(r.benettin, 3),
        benettin_2nd: keep(r.benettin_2nd, 3),
        rosenstein: keep(r.rosenstein, 3),
        rosenstein_noisy: keep(r.rosenstein_noisy, 3),
        corr_dim: keep(r.corr_dim, 2),
        data_corr_dim: round(Some(r.data.corr_dim), 2).unwrap_or(f64::NAN),
        data_corr_dim_err: round(Some(r.data.corr_dim_err), 2).unwrap_or(f64::NAN),
        js: keep(r.js, 4),
        excursion: keep(r.excursion, 2),
        chaotic: ok && chaos::is_chaotic(r.benettin, r.benettin_err),
        failed: r.failed.clone(),
        notes: r.notes.join("; "),
    }
}

/// The bundled flag study, whose centre-set search is the default search.
const FLAG_SPEC: &str = include_str!("../../../studies/flag.toml");

/// The data: training files and the test file (under the data folder; absolute paths as
/// they are) and the column of wider CSV files (the first column is the time); or runs of a
/// scene simulated here (`simulated`), whose last run is the test.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectionData {
    #[serde(default)]
    pub training: Vec<String>,
    /// The held-out series; `None`: the longest training series (nothing held out).
    #[serde(default)]
    pub test: Option<String>,
    #[serde(default)]
    pub column: Option<String>,
    #[serde(default)]
    pub simulated: Option<SimulatedRuns>,
}

/// Runs of a scene (bundled name or file) from `theta0` (rad, the other states 0) over
/// `periods` control periods each, the first 20 s dropped; the observable is the scene's
/// primary output. The last run is the test run, the others train.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulatedRuns {
    pub scene: String,
    pub periods: usize,
    pub theta0: Vec<f64>,
}

/// The study's standard candidates at each map step of `steps`: the RBF map with `centers`
/// centres and the polynomial map of order `poly_order`, both with relative ridge `ridge`,
/// at the SSM dimension of the dimension rule on the test series (or `models.dim`) and the
/// shift rule ([`crate::model_selection::standard_candidates`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StandardCandidates {
    pub steps: Vec<usize>,
    pub centers: usize,
    pub poly_order: u32,
    pub ridge: f64,
}

impl StandardCandidates {
    fn options(&self, gp_embed: usize, dim: Option<usize>) -> crate::microchaos::ChaosOptions {
        crate::microchaos::ChaosOptions {
            gp_embed,
            ssm_dim: dim,
            centers: self.centers,
            poly_order: self.poly_order,
            ridge: self.ridge,
            ..Default::default()
        }
    }
}

/// The candidates: the standard ones first (if any), then those by name
/// ([`candidate_from_name`], map step 4), in the order the pick breaks ties; `dim`
/// sets the SSM dimension of every candidate (embedding `2 dim + 1` for the named ones).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectionModels {
    #[serde(default)]
    pub candidates: Vec<String>,
    #[serde(default)]
    pub standard: Option<StandardCandidates>,
    #[serde(default)]
    pub dim: Option<usize>,
}

/// A selection spec.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectionSpec {
    pub kind: String,
    pub name: String,
    pub data: SelectionData,
    pub statistics: EvalSettings,
    pub models: SelectionModels,
}

/// The `kind` of a spec's TOML text: `None` for a flag study (no `kind` key).
pub fn spec_kind(origin: &str, text: &str) -> Result<Option<String>, Error> {
    let bad = |why: String| Error::BadInput { what: "study spec", why: format!("{origin}: {why}") };
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| bad(e.to_string()))?;
    match table.get("kind") {
        None => Ok(None),
        Some(toml::Value::String(k)) => Ok(Some(k.clone())),
        Some(v) => Err(bad(format!("at `kind`: expected a string, got `{v}`"))),
    }
}

/// `name` with its SSM dimension set to `dim` and its embedding to `2 dim + 1`.
pub fn with_dim(name: &str, dim: usize) -> String {
    name.split_whitespace()
        .map(|t| {
            if t.starts_with("d=") {
                format!("d={dim}")
            } else if t.starts_with("p=") {
                format!("p={}", 2 * dim + 1)
            } else {
                t.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

impl SelectionSpec {
    /// The spec in TOML `text` (from `origin`, for the messages); unknown or missing keys and
    /// bad values are errors naming the key.
    pub fn parse(origin: &str, text: &str) -> Result<Self, Error> {
        let bad = |why: String| Error::BadInput { what: "study spec", why: format!("{origin}: {why}") };
        let de = toml::Deserializer::parse(text).map_err(|e| bad(e.to_string()))?;
        let spec: Self = serde_path_to_error::deserialize(de)
            .map_err(|e| bad(format!("at `{}`: {}", e.path(), e.inner().message())))?;
        spec.check().map_err(bad)?;
        Ok(spec)
    }

    fn check(&self) -> Result<(), String> {
        if self.kind != KIND && self.kind != SEARCH_KIND {
            return Err(format!(
                "kind = `{}`: expected `{KIND}`, `{SEARCH_KIND}`, `{}` (or no kind for a flag study)",
                self.kind,
                crate::known_system_study::KIND
            ));
        }
        if self.kind == SEARCH_KIND && (self.models.dim.is_some() || self.models.standard.is_some()) {
            return Err("a search spec names every candidate: no models.dim or models.standard".into());
        }
        match &self.data.simulated {
            None if self.data.training.is_empty() => {
                return Err("data.training is empty (and no data.simulated runs)".into());
            }
            None => {}
            Some(_) if !self.data.training.is_empty() || self.data.test.is_some() || self.data.column.is_some() => {
                return Err("data.simulated and data files (training, test, column): give one or the other".into());
            }
            Some(sim) => {
                if sim.theta0.len() < 2 {
                    return Err(format!(
                        "data.simulated.theta0 has {} start(s): needs a training run and the test run",
                        sim.theta0.len()
                    ));
                }
                if let Some(t) = sim.theta0.iter().find(|t| !t.is_finite()) {
                    return Err(format!("data.simulated.theta0: {t} is not a finite angle"));
                }
                if sim.periods == 0 {
                    return Err("data.simulated.periods = 0".into());
                }
            }
        }
        if let Some(t) = self.data.test.as_ref().filter(|t| self.data.training.contains(t)) {
            return Err(format!("data.test `{t}` is also a training file"));
        }
        if self.models.candidates.is_empty() && self.models.standard.is_none() {
            return Err("models: no candidates and no standard candidates".into());
        }
        if let Some(st) = &self.models.standard {
            if st.steps.is_empty() || st.steps.contains(&0) {
                return Err(format!("models.standard.steps = {:?}: every map step must be >= 1 sample", st.steps));
            }
            st.options(self.statistics.gp_embed, self.models.dim)
                .validate()
                .map_err(|e| format!("models.standard: {e}"))?;
        }
        if self.models.dim == Some(0) {
            return Err("models.dim = 0: the SSM dimension must be >= 1".into());
        }
        self.statistics.check()?;
        for c in self.candidates()? {
            c.fit.validate().map_err(|e| format!("models.candidates: `{}`: {e}", c.name))?;
        }
        Ok(())
    }

    /// The named candidates, in the spec's order, at the spec's dimension.
    pub fn candidates(&self) -> Result<Vec<Candidate>, String> {
        let parse = if self.kind == SEARCH_KIND { search_candidate } else { candidate_from_name };
        self.candidate_names().iter().map(|n| parse(n).map_err(|e| format!("models.candidates: {e}"))).collect()
    }

    /// The candidates' names as they are measured (with `models.dim` applied).
    pub fn candidate_names(&self) -> Vec<String> {
        self.models.candidates.iter().map(|n| self.models.dim.map_or_else(|| n.clone(), |d| with_dim(n, d))).collect()
    }

    /// The spec with its named candidate list cut to its first `n`.
    pub fn limited(&self, n: usize) -> Self {
        let mut s = self.clone();
        s.models.candidates.truncate(n);
        s
    }

    /// The default search of `ssmctl chaos`: the bundled flag study's centre-set candidates
    /// (the report's search), the first `budget` of them, at SSM dimension `dim` (`None`:
    /// as named, d = 4), with the standard estimator settings.
    pub fn default_search(
        training: Vec<String>,
        test: Option<String>,
        column: Option<String>,
        budget: usize,
        dim: Option<usize>,
    ) -> Result<Self, Error> {
        let flag = FlagStudySpec::parse("studies/flag.toml (bundled)", FLAG_SPEC)?;
        let mut candidates = flag.models.centres;
        if budget == 0 || budget > candidates.len() {
            return Err(Error::BadOption {
                what: "budget",
                why: format!("{budget}: needs 1 ..= {} (the search's candidates)", candidates.len()),
            });
        }
        candidates.truncate(budget);
        let spec = Self {
            kind: KIND.into(),
            name: "chaos".into(),
            data: SelectionData { training, test, column, simulated: None },
            statistics: EvalSettings::default(),
            models: SelectionModels { candidates, standard: None, dim },
        };
        spec.check().map_err(|why| Error::BadInput { what: "chaos options", why })?;
        Ok(spec)
    }

    /// The training files under `data_dir`.
    pub fn training_paths(&self, data_dir: &Path) -> Vec<PathBuf> {
        self.data.training.iter().map(|f| data_dir.join(f)).collect()
    }

    /// The test file under `data_dir`, if the spec names one.
    pub fn test_path(&self, data_dir: &Path) -> Option<PathBuf> {
        self.data.test.as_ref().map(|f| data_dir.join(f))
    }
}

/// What every candidate is measured with: the training series, the test series, whether
/// it is held out, its statistics at the map step, and the candidates.
pub struct Prepared {
    pub train: Vec<TimeSeries>,
    pub test: TimeSeries,
    pub held_out: bool,
    /// The test series' statistics at each map step of the candidates, ascending.
    pub data: Vec<(DataStats, Context)>,
    pub candidates: Vec<Candidate>,
    pub settings: EvalSettings,
}

fn load(path: &Path, column: Option<&str>) -> Result<TimeSeries, Error> {
    ssm::load_csv_column(path, column)
        .map_err(|e| Error::BadInput { what: "study data", why: format!("{}: {e}", path.display()) })
}

/// The spec's series: (training, test, whether the test is held out).
pub fn load_series(spec: &SelectionSpec, data_dir: &Path) -> Result<(Vec<TimeSeries>, TimeSeries, bool), Error> {
    if let Some(sim) = &spec.data.simulated {
        let runs: Vec<(usize, f64)> = sim.theta0.iter().copied().enumerate().collect();
        let mut series = crate::par_map(&runs, |&(i, th)| {
            let scene = sim::scene::SceneBuilder::load(&sim.scene)?;
            crate::microchaos::simulate_scene(scene, sim.periods, th, &format!("{} #{i}", sim.scene))
        })?;
        let test = series.pop().ok_or(Error::BadInput { what: "study spec", why: "no simulated run".into() })?;
        return Ok((series, test, true));
    }
    let col = spec.data.column.as_deref();
    let train: Vec<TimeSeries> =
        spec.training_paths(data_dir).iter().map(|p| load(p, col)).collect::<Result<_, _>>()?;
    Ok(match spec.test_path(data_dir) {
        Some(p) => (train, load(&p, col)?, true),
        None => {
            // The longest training series, the first of equals.
            let mut best = 0;
            for (i, t) in train.iter().enumerate() {
                if t.x.len() > train[best].x.len() {
                    best = i;
                }
            }
            let test = train[best].clone();
            (train, test, false)
        }
    })
}

/// The SSM dimension of the standard candidates: `models.dim`, else the dimension rule on the
/// correlation dimension of the test series (as the chaos analysis takes it).
fn standard_dim(spec: &SelectionSpec, test: &TimeSeries) -> Result<usize, Error> {
    if let Some(d) = spec.models.dim {
        return Ok(d);
    }
    let dt =
        test.dt().ok_or(Error::BadInput { what: "test series", why: format!("{}: no sampling step", test.name) })?;
    let ctx = Context::from_series(&test.x, dt, spec.statistics.gp_embed)?;
    let cd = ctx.corr_dim(&test.x)?;
    Ok(chaos::dimension_rule(cd.dimension, cd.slope_std)?)
}

/// Loads (or simulates) the spec's data and measures the test series at each map step of
/// the candidates.
pub fn prepare(spec: &SelectionSpec, data_dir: &Path) -> Result<Prepared, Error> {
    let (train, test, held_out) = load_series(spec, data_dir)?;
    prepare_series(spec, train, test, held_out)
}

/// [`prepare`] on series already loaded by [`load_series`] (or read back from a cache).
pub fn prepare_series(
    spec: &SelectionSpec,
    train: Vec<TimeSeries>,
    test: TimeSeries,
    held_out: bool,
) -> Result<Prepared, Error> {
    let settings = spec.statistics;
    let mut candidates = Vec::new();
    if let Some(st) = &spec.models.standard {
        let dim = standard_dim(spec, &test)?;
        let o = st.options(spec.statistics.gp_embed, spec.models.dim);
        candidates.extend(crate::model_selection::standard_candidates(&o, dim, &st.steps, &test)?);
    }
    candidates.extend(spec.candidates().map_err(|why| Error::BadInput { what: "study spec", why })?);
    let mut steps: Vec<usize> = candidates.iter().map(|c| c.step).collect();
    steps.sort_unstable();
    steps.dedup();
    let data = crate::par_map(&steps, |&k| data_stats(&test, k, &settings))?;
    Ok(Prepared { train, test, held_out, data, candidates, settings })
}

/// Measures candidate `i` of `p`.
pub fn evaluate(p: &Prepared, i: usize) -> Result<CandidateResult, Error> {
    let c = p.candidates.get(i).ok_or_else(|| Error::BadInput {
        what: "candidate index",
        why: format!("{i}: the spec has {} candidates", p.candidates.len()),
    })?;
    let data = p.data.iter().find(|d| d.0.step == c.step).ok_or_else(|| Error::BadInput {
        what: "candidate",
        why: format!("{}: no data statistics at step {}", c.name, c.step),
    })?;
    crate::model_selection::evaluate_candidate(&p.train, &p.test, c, data, &p.settings)
}

/// The results file of a selection spec (`selection.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SelectionResults {
    pub name: String,
    pub training: Vec<String>,
    pub test: String,
    /// Whether the test series is held out (not a training series).
    pub held_out: bool,
    /// The test series' statistics at each map step of the candidates.
    pub data: serde_json::Value,
    /// Every candidate's result, in the spec's order, without its timing.
    pub candidates: Vec<serde_json::Value>,
    pub selection: Selection,
}

/// A candidate's result as the results file and the cache hold it: its JSON without the
/// timing (which differs from run to run).
pub fn result_json(r: &CandidateResult) -> Result<serde_json::Value, Error> {
    let mut v = serde_json::to_value(r)
        .map_err(|e| Error::BadInput { what: "candidate result", why: format!("{}: {e}", r.name) })?;
    if let Some(m) = v.as_object_mut() {
        m.remove("seconds");
    }
    Ok(v)
}

/// The result back from [`result_json`] (timing 0).
pub fn result_from_json(v: &serde_json::Value) -> Result<CandidateResult, Error> {
    let mut v = v.clone();
    if let Some(m) = v.as_object_mut() {
        m.insert("seconds".into(), 0.0.into());
    }
    serde_json::from_value(v).map_err(|e| Error::BadInput { what: "candidate result", why: e.to_string() })
}

/// The pick among `results` (in the spec's order, each as [`result_json`] gives it), by
/// [`crate::model_selection::select`]; the results file.
pub fn finish(spec: &SelectionSpec, p: &Prepared, results: Vec<serde_json::Value>) -> Result<SelectionResults, Error> {
    if results.len() != p.candidates.len() {
        return Err(Error::BadInput {
            what: "candidate results",
            why: format!("{} results for {} candidates", results.len(), p.candidates.len()),
        });
    }
    let rows: Vec<CandidateResult> = results.iter().map(result_from_json).collect::<Result<_, _>>()?;
    for (r, c) in rows.iter().zip(&p.candidates) {
        if r.name != c.name {
            return Err(Error::BadInput {
                what: "candidate results",
                why: format!("result of `{}` where `{}` was expected", r.name, c.name),
            });
        }
    }
    let selection = crate::model_selection::select(&rows, &chaos::Targets::default(), 0.0);
    Ok(SelectionResults {
        name: spec.name.clone(),
        training: p.train.iter().map(|t| t.name.clone()).collect(),
        test: p.test.name.clone(),
        held_out: p.held_out,
        data: serde_json::to_value(p.data.iter().map(|d| &d.0).collect::<Vec<_>>())
            .map_err(|e| Error::BadInput { what: "data statistics", why: e.to_string() })?,
        candidates: results,
        selection,
    })
}
