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
use crate::flag_self::{STEP, candidate_from_name};
use crate::flag_study::FlagStudySpec;
use crate::model_selection::{Candidate, CandidateResult, DataStats, EvalSettings, Selection, data_stats};
use chaos::Context;

/// The value of `kind` that marks a selection spec.
pub const KIND: &str = "selection";

/// The bundled flag study, whose centre-set search is the default search.
const FLAG_SPEC: &str = include_str!("../../../studies/flag.toml");

/// The data: training files and the test file (under the data folder; absolute paths as
/// they are), and the column of wider CSV files (the first column is the time).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectionData {
    pub training: Vec<String>,
    /// The held-out series; `None`: the longest training series (nothing held out).
    #[serde(default)]
    pub test: Option<String>,
    #[serde(default)]
    pub column: Option<String>,
}

/// The estimator settings ([`EvalSettings`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectionStatistics {
    pub gp_embed: usize,
    pub long_runs: usize,
    pub benettin_transient: usize,
    pub benettin_steps: usize,
    pub region_factor: f64,
}

impl SelectionStatistics {
    /// The settings of [`EvalSettings::default`] (the flag study's).
    pub fn standard() -> Self {
        let s = EvalSettings::default();
        Self {
            gp_embed: s.gp_embed,
            long_runs: s.long_runs,
            benettin_transient: s.benettin_transient,
            benettin_steps: s.benettin_steps,
            region_factor: s.region_factor,
        }
    }

    pub fn settings(&self) -> EvalSettings {
        EvalSettings {
            gp_embed: self.gp_embed,
            long_runs: self.long_runs,
            benettin_transient: self.benettin_transient,
            benettin_steps: self.benettin_steps,
            region_factor: self.region_factor,
        }
    }
}

/// The candidates by name ([`candidate_from_name`], map step [`STEP`]), in the order the
/// pick breaks ties; `dim` sets the SSM dimension of every candidate (embedding `2 dim + 1`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SelectionModels {
    pub candidates: Vec<String>,
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
    pub statistics: SelectionStatistics,
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
        if self.kind != KIND {
            return Err(format!("kind = `{}`: expected `{KIND}` (or no kind for a flag study)", self.kind));
        }
        if self.data.training.is_empty() {
            return Err("data.training is empty".into());
        }
        if let Some(t) = &self.data.test {
            if self.data.training.contains(t) {
                return Err(format!("data.test `{t}` is also a training file"));
            }
        }
        if self.models.candidates.is_empty() {
            return Err("models.candidates is empty".into());
        }
        if self.models.dim == Some(0) {
            return Err("models.dim = 0: the SSM dimension must be >= 1".into());
        }
        let s = &self.statistics;
        if s.gp_embed == 0 || s.gp_embed > crate::microchaos::MAX_GP_EMBED {
            return Err(format!(
                "statistics.gp_embed = {}: needs 1 ..= {}",
                s.gp_embed,
                crate::microchaos::MAX_GP_EMBED
            ));
        }
        if s.long_runs == 0 || s.benettin_steps == 0 {
            return Err("statistics.long_runs and statistics.benettin_steps must be >= 1".into());
        }
        if !(s.region_factor.is_finite() && s.region_factor >= 1.0) {
            return Err(format!("statistics.region_factor = {}: needs a finite value >= 1", s.region_factor));
        }
        for c in self.candidates()? {
            c.fit.validate().map_err(|e| format!("models.candidates: `{}`: {e}", c.name))?;
        }
        Ok(())
    }

    /// The candidates, in the spec's order, at the spec's dimension.
    pub fn candidates(&self) -> Result<Vec<Candidate>, String> {
        self.candidate_names()
            .iter()
            .map(|n| candidate_from_name(n).map_err(|e| format!("models.candidates: {e}")))
            .collect()
    }

    /// The candidates' names as they are measured (with `models.dim` applied).
    pub fn candidate_names(&self) -> Vec<String> {
        self.models.candidates.iter().map(|n| self.models.dim.map_or_else(|| n.clone(), |d| with_dim(n, d))).collect()
    }

    /// The spec with its candidate list cut to its first `n`.
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
            data: SelectionData { training, test, column },
            statistics: SelectionStatistics::standard(),
            models: SelectionModels { candidates, dim },
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
    pub data: (DataStats, Context),
    pub candidates: Vec<Candidate>,
    pub settings: EvalSettings,
}

fn load(path: &Path, column: Option<&str>) -> Result<TimeSeries, Error> {
    ssm::load_csv_column(path, column)
        .map_err(|e| Error::BadInput { what: "study data", why: format!("{}: {e}", path.display()) })
}

/// Loads the spec's data under `data_dir` and measures the test series at the map step.
pub fn prepare(spec: &SelectionSpec, data_dir: &Path) -> Result<Prepared, Error> {
    let col = spec.data.column.as_deref();
    let train: Vec<TimeSeries> =
        spec.training_paths(data_dir).iter().map(|p| load(p, col)).collect::<Result<_, _>>()?;
    let (test, held_out) = match spec.test_path(data_dir) {
        Some(p) => (load(&p, col)?, true),
        None => {
            // The longest training series, the first of equals.
            let mut best = 0;
            for (i, t) in train.iter().enumerate() {
                if t.x.len() > train[best].x.len() {
                    best = i;
                }
            }
            (train[best].clone(), false)
        }
    };
    let settings = spec.statistics.settings();
    let data = data_stats(&test, STEP, &settings)?;
    let candidates = spec.candidates().map_err(|why| Error::BadInput { what: "study spec", why })?;
    Ok(Prepared { train, test, held_out, data, candidates, settings })
}

/// Measures candidate `i` of `p`.
pub fn evaluate(p: &Prepared, i: usize) -> Result<CandidateResult, Error> {
    let c = p.candidates.get(i).ok_or_else(|| Error::BadInput {
        what: "candidate index",
        why: format!("{i}: the spec has {} candidates", p.candidates.len()),
    })?;
    crate::model_selection::evaluate_candidate(&p.train, &p.test, c, &p.data, &p.settings)
}

/// The results file of a selection spec (`selection.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SelectionResults {
    pub name: String,
    pub training: Vec<String>,
    pub test: String,
    /// Whether the test series is held out (not a training series).
    pub held_out: bool,
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
        data: serde_json::to_value(&p.data.0)
            .map_err(|e| Error::BadInput { what: "data statistics", why: e.to_string() })?,
        candidates: results,
        selection,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPEC: &str = r#"
kind = "selection"
name = "t"
[data]
training = ["a.csv"]
test = "b.csv"
[statistics]
gp_embed = 6
long_runs = 5
benettin_transient = 5000
benettin_steps = 50000
region_factor = 1.5
[models]
candidates = ["RBF 200 r=3e-9 d=4 p=9", "RBF 300 r=1e-8 d=4 p=9 centres kmeans++@2"]
"#;

    #[test]
    fn spec_parses_and_names_bad_keys() {
        let s = SelectionSpec::parse("t.toml", SPEC).unwrap();
        assert_eq!(spec_kind("t.toml", SPEC).unwrap().as_deref(), Some(KIND));
        assert_eq!(s.candidates().unwrap().len(), 2);
        let bad = |from: &str, to: &str, want: &str| {
            let e = SelectionSpec::parse("t.toml", &SPEC.replace(from, to)).unwrap_err().to_string();
            assert!(e.contains("t.toml") && e.contains(want), "{e}");
        };
        bad("region_factor = 1.5", "region_factor = 1.5\nextra = 1", "extra");
        bad("kind = \"selection\"", "kind = \"sweep\"", "kind");
        bad("test = \"b.csv\"", "test = \"a.csv\"", "data.test");
        bad("\"RBF 200", "\"RBX 200", "RBX");
        bad("gp_embed = 6", "gp_embed = 0", "gp_embed");
        bad("[models]\n", "[models]\ndim = 0\n", "models.dim");
        assert!(spec_kind("f.toml", "name = \"flag\"").unwrap().is_none());
    }

    #[test]
    fn dimension_and_budget_of_the_default_search() {
        assert_eq!(with_dim("RBF 200 r=3e-9 d=4 p=9 centres random@3", 6), "RBF 200 r=3e-9 d=6 p=13 centres random@3");
        let s = SelectionSpec::default_search(vec!["a.csv".into()], None, None, 5, Some(3)).unwrap();
        assert_eq!(s.models.candidates.len(), 5);
        let c = s.candidates().unwrap();
        assert!(c.iter().all(|c| c.fit.dim == 3 && c.fit.embed == 7), "{c:?}");
        let e = SelectionSpec::default_search(vec!["a.csv".into()], None, None, 0, None).unwrap_err();
        assert!(e.to_string().contains("budget"), "{e}");
        let e = SelectionSpec::default_search(vec!["a.csv".into()], None, None, 10_000, None).unwrap_err();
        assert!(e.to_string().contains("budget"), "{e}");
    }
}
