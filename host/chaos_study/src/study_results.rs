//! The measured results of the flag study, read from data files: the library computes them
//! (`ssmctl study studies/flag.toml` writes the flag data's files, see `studies/README.md`),
//! the report reads them here. Nothing measured lives in source.
//!
//! One JSON file per group under [`default_dir`]:
//! - [`KNOWN_SYSTEM`]: the flag pipeline on the known system ([`crate::flag_pipeline::CHOSEN`]):
//!   its held-out statistics, the candidate rows at 1, 3 and 10 times the flag's training
//!   data and the diagnosis rows;
//! - [`NOISE_REALIZATIONS`]: the known system's maps fitted on the noisy true state, over
//!   realizations of the noise (a [`KnownSystemResults`] of diagnosis rows alone);
//! - [`SEARCH`]: the inverted flag's candidate search, one typed row per candidate;
//! - [`HELD_OUT`]: every candidate on the held-out run (traj_8): the fits at d = 5 and 6, the
//!   multistep rows, the centre-set rows, the models' dimensions and D2 of every run;
//! - [`EXPERIMENT`]: the flag's runs as perfect models of the held-out run and each run
//!   through the estimator with its own settings;
//! - [`VALIDATION`]: the centre-set candidates on the validation runs and the ensemble.
//!
//! Every file names the command that writes it (`produced_by`); a missing file, a missing or
//! unknown key or a wrong type is an error naming the file and the key.

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::Error;

/// File of [`KnownSystemResults`].
pub const KNOWN_SYSTEM: &str = "known_system.json";
/// File of the noisy-state rows over noise realizations (`studies/flag-noise-realizations.toml`).
pub const NOISE_REALIZATIONS: &str = "noise_realizations.json";
/// File of [`SearchResults`].
pub const SEARCH: &str = "search.json";
/// File of [`HeldOutResults`].
pub const HELD_OUT: &str = "held_out.json";
/// File of [`ExperimentResults`].
pub const EXPERIMENT: &str = "experiment_as_model.json";
/// File of [`ValidationResults`].
pub const VALIDATION: &str = "validation.json";

/// The bundled results of the flag study: `studies/results/flag` of the workspace.
pub fn default_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../studies/results/flag")
}

/// The statistics of a held-out (or validation) run that model rows are judged against.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunStats {
    /// Rosenstein exponent, 1/s.
    pub rosenstein: f64,
    /// Correlation dimension and its error bar.
    pub corr_dim: f64,
    pub corr_dim_err: f64,
}

impl RunStats {
    /// `(Rosenstein, D2, D2 error bar)`, as the row functions take them.
    pub fn tuple(&self) -> (f64, f64, f64) {
        (self.rosenstein, self.corr_dim, self.corr_dim_err)
    }
}

/// One candidate measured on a run: its name (as [`crate::flag_self::candidate_from_name`]
/// reads it), the model's Benettin exponent, the Rosenstein exponent and D2 of its series
/// (1/s), the JS divergence of its reduced-coordinate densities (bits), or why it failed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelRow {
    pub candidate: String,
    pub benettin: Option<f64>,
    pub rosenstein: Option<f64>,
    pub corr_dim: Option<f64>,
    pub js: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

/// The held-out statistics of the known system's series at the flag's layout, with its exact
/// exponent (1/s).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KnownData {
    pub rosenstein: f64,
    pub corr_dim: f64,
    pub corr_dim_err: f64,
    pub exact: f64,
}

/// One candidate of the pipeline check at `scale` times the flag's training data.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckRow {
    pub candidate: String,
    pub scale: usize,
    pub benettin: Option<f64>,
    pub rosenstein: Option<f64>,
    pub corr_dim: Option<f64>,
    pub js: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

/// One diagnosis row: what is varied (`group`), the candidate, the training data scale and
/// the noise over the series sd, and the row's measured values.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagRow {
    pub group: String,
    pub candidate: String,
    pub scale: usize,
    pub noise_rel: f64,
    pub benettin: Option<f64>,
    pub rosenstein: Option<f64>,
    pub corr_dim: Option<f64>,
    pub js: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

/// [`KNOWN_SYSTEM`]: the flag pipeline on the known system.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KnownSystemResults {
    pub produced_by: String,
    /// The held-out data the rows were measured against (scale 1, 4,000 s of Benettin).
    pub data: KnownData,
    /// The flag's candidate search on the system (RBF sizes within the design-matrix limit
    /// at each scale).
    pub pipeline_check: Vec<CheckRow>,
    /// Variants of the flag's candidates: noise-free data, SSM dimension, shift, the whole
    /// delay vector, multistep refinement, denoised inputs and fits on the true state.
    pub diagnosis: Vec<DiagRow>,
}

/// One candidate of the inverted flag's search measured on the held-out run: the held-out
/// run's Rosenstein exponent and D2 (with its error bar) at the candidate's map step, the
/// model's two largest Benettin exponents, the Rosenstein exponent of its series (and with the
/// data's noise added, where measured), D2, JS (bits), the long run's largest excursion over
/// the data's, whether the model is chaotic ([`chaos::is_chaotic`]) or why it failed, and the
/// evaluation's notes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SearchRow {
    pub candidate: String,
    pub data_rosenstein: f64,
    pub benettin: Option<f64>,
    pub benettin_2nd: Option<f64>,
    pub rosenstein: Option<f64>,
    pub rosenstein_noisy: Option<f64>,
    pub corr_dim: Option<f64>,
    pub data_corr_dim: f64,
    pub data_corr_dim_err: f64,
    pub js: Option<f64>,
    pub excursion: Option<f64>,
    pub chaotic: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
    pub notes: String,
}

impl SearchRow {
    /// The verdict column: the failure, chaotic, or not.
    pub fn outcome(&self) -> String {
        match &self.failed {
            Some(f) => format!("FAILED: {f}"),
            None if self.chaotic => "chaotic".into(),
            None => "not chaotic (torus or periodic)".into(),
        }
    }

    /// The row's cells under [`SearchResults::HEADER`] (exponents 3 decimals, D2 2, JS 4,
    /// excursion 2; `-` where there is no value).
    pub fn cells(&self) -> [String; 9] {
        let f = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |v| format!("{v:.p$}"));
        let rosenstein = match self.rosenstein_noisy {
            Some(n) => format!("{} ({n:.3})", f(self.rosenstein, 3)),
            None => f(self.rosenstein, 3),
        };
        [
            self.candidate.clone(),
            format!("{:.3}", self.data_rosenstein),
            format!("{} ({})", f(self.benettin, 3), f(self.benettin_2nd, 3)),
            rosenstein,
            format!("{} ({:.2} ± {:.2})", f(self.corr_dim, 2), self.data_corr_dim, self.data_corr_dim_err),
            f(self.js, 4),
            f(self.excursion, 2),
            self.outcome(),
            self.notes.clone(),
        ]
    }
}

/// [`SEARCH`]: the inverted flag's candidate search (train traj_9 + traj_7, held out
/// traj_8), one row per candidate in the spec's order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SearchResults {
    pub produced_by: String,
    pub rows: Vec<SearchRow>,
}

impl SearchResults {
    /// The columns of [`SearchRow::cells`].
    pub const HEADER: [&str; 9] = [
        "candidate",
        "data Rosenstein at step k [1/s]",
        "Benettin (2nd) [1/s]",
        "Rosenstein (with the data's noise) [1/s]",
        "D2 (data)",
        "JS [bits]",
        "excursion",
        "outcome",
        "notes",
    ];
}

/// The dimension of one model: the Kaplan-Yorke dimension of its Lyapunov spectrum from the
/// held-out run's first point, and D2 of the five held-out-length pieces of its long run
/// (the first being the row's D2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DimensionRow {
    pub candidate: String,
    pub kaplan_yorke: Option<f64>,
    pub corr_dim_pieces: [Option<f64>; 5],
}

/// D2 of one run through the held-out run's estimator and settings (`None`: no scaling range).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunCorrDim {
    pub run: usize,
    pub corr_dim: Option<f64>,
}

/// The held-out run's D2 after centred moving averages of 3 and 5 samples at the full rate,
/// and with white noise of its own level added again.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SmoothedCorrDim {
    pub smoothed_3: f64,
    pub smoothed_5: f64,
    pub noise_added: f64,
}

/// The model side of the noise check: over the centre-set rows with both values, the rows,
/// the mean of D2 with the data's noise added minus D2 without, and the rows where the two
/// differ by more than 0.2 either way.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoisyModelCorrDim {
    pub rows: usize,
    pub mean_change: f64,
    pub changed_over_0_2: usize,
}

/// [`HELD_OUT`]: candidates fitted on the training runs and measured on the held-out run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeldOutResults {
    pub produced_by: String,
    /// The held-out run and the training runs, by name.
    pub test_run: String,
    pub train_runs: Vec<String>,
    /// The held-out run's length at the map step, samples.
    pub test_len: usize,
    /// The held-out run's statistics at the map step.
    pub data: RunStats,
    /// SSM dimensions 5 and 6 (the known system's rule).
    pub fit: Vec<ModelRow>,
    /// With multistep refinement at d = 4, 5, 6.
    pub multistep: Vec<ModelRow>,
    /// Centre sets, ridges and sizes at d = 4, 5, 6.
    pub centres: Vec<ModelRow>,
    pub dimension: Vec<DimensionRow>,
    pub corr_dim_runs: Vec<RunCorrDim>,
    pub corr_dim_smoothed: SmoothedCorrDim,
    pub model_noisy_corr_dim: NoisyModelCorrDim,
}

impl HeldOutResults {
    /// D2 of run `run` ([`Self::corr_dim_runs`]); `None` when it has none or is not listed.
    pub fn corr_dim_of_run(&self, run: usize) -> Option<f64> {
        self.corr_dim_runs.iter().find(|r| r.run == run).and_then(|r| r.corr_dim)
    }
}

/// One run through the held-out estimator with its own settings (lag and Theiler window
/// from its own series).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunOwnStats {
    pub run: usize,
    pub lag: usize,
    pub theiler: usize,
    pub rosenstein: f64,
    pub corr_dim: f64,
    pub corr_dim_err: f64,
}

impl RunOwnStats {
    /// The run's statistics.
    pub fn stats(&self) -> RunStats {
        RunStats { rosenstein: self.rosenstein, corr_dim: self.corr_dim, corr_dim_err: self.corr_dim_err }
    }
}

/// One run (or piece of a run) of the flag measured as if it were a model's output: which
/// run, the first sample and the length of the piece at map step the flag's map step, and its
/// statistics against the held-out run.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct SelfRow {
    pub run: usize,
    pub start: usize,
    pub len: usize,
    /// Rosenstein exponent of the piece (held-out settings), 1/s.
    pub rosenstein: Option<f64>,
    /// Correlation dimension of the piece and its error bar (held-out settings).
    pub corr_dim: Option<f64>,
    pub corr_dim_err: Option<f64>,
    /// Mean JS divergence of the reduced-coordinate densities of the piece against the
    /// held-out run's, bits.
    pub js: Option<f64>,
}

/// [`EXPERIMENT`]: the flag's runs as perfect models of the held-out run
/// ([`crate::flag_self::experiment_as_model`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentResults {
    pub produced_by: String,
    pub rows: Vec<SelfRow>,
    /// Every run but one without a scaling range, with its own settings.
    pub runs_own: Vec<RunOwnStats>,
}

impl ExperimentResults {
    /// The own-settings statistics of run `run`.
    pub fn own(&self, run: usize) -> Option<&RunOwnStats> {
        self.runs_own.iter().find(|r| r.run == run)
    }
}

/// The candidates measured on one validation run (neither training nor test).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValidationRun {
    pub run: usize,
    /// The run's statistics with its own settings.
    pub data: RunStats,
    /// The rows of [`HeldOutResults::centres`], in their order.
    pub rows: Vec<ModelRow>,
}

/// The ensemble of the best validation-ranked d = 4 models: how many, and the JS of their
/// pooled long runs against the held-out run (bits).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnsembleResult {
    pub members: usize,
    pub js_pooled: f64,
}

/// [`VALIDATION`]: the pick on validation runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ValidationResults {
    pub produced_by: String,
    /// The first run picks; the others show how much the pick depends on the run.
    pub runs: Vec<ValidationRun>,
    pub ensemble: EnsembleResult,
}

impl ValidationResults {
    /// The validation run that picks (the first).
    pub fn primary(&self) -> Result<&ValidationRun, Error> {
        self.runs
            .first()
            .ok_or_else(|| Error::BadInput { what: "study results", why: format!("{VALIDATION}: `runs` is empty") })
    }

    /// The validation run `run`.
    pub fn run(&self, run: usize) -> Result<&ValidationRun, Error> {
        self.runs.iter().find(|r| r.run == run).ok_or_else(|| Error::BadInput {
            what: "study results",
            why: format!("{VALIDATION}: no validation run {run} in `runs`"),
        })
    }
}

/// All the flag study's results.
#[derive(Clone, Debug, PartialEq)]
pub struct FlagResults {
    pub known: KnownSystemResults,
    pub search: SearchResults,
    pub held_out: HeldOutResults,
    pub experiment: ExperimentResults,
    pub validation: ValidationResults,
}

impl FlagResults {
    /// Every file of the study's results from `dir`.
    pub fn load(dir: &Path) -> Result<Self, Error> {
        let out = Self {
            known: read(&dir.join(KNOWN_SYSTEM))?,
            search: read(&dir.join(SEARCH))?,
            held_out: read(&dir.join(HELD_OUT))?,
            experiment: read(&dir.join(EXPERIMENT))?,
            validation: read(&dir.join(VALIDATION))?,
        };
        out.check()
            .map_err(|why| Error::BadInput { what: "study results", why: format!("{}: {why}", dir.display()) })?;
        Ok(out)
    }

    /// The bundled results ([`default_dir`]).
    pub fn bundled() -> Result<Self, Error> {
        Self::load(&default_dir())
    }

    /// The files agree with each other: every validation run measures the centre-set
    /// candidates in their order.
    fn check(&self) -> Result<(), String> {
        for v in &self.validation.runs {
            let same = v.rows.len() == self.held_out.centres.len()
                && v.rows.iter().zip(&self.held_out.centres).all(|(a, b)| a.candidate == b.candidate);
            if !same {
                return Err(format!(
                    "{VALIDATION}: run {} does not list the candidates of {HELD_OUT} `centres` in their order",
                    v.run
                ));
            }
        }
        Ok(())
    }
}

/// One results file: `T` from the JSON at `path`, the error naming the file and the key.
pub fn read<T: DeserializeOwned>(path: &Path) -> Result<T, Error> {
    let bad = |why: String| Error::BadInput { what: "study results", why: format!("{}: {why}", path.display()) };
    let text = std::fs::read_to_string(path).map_err(|e| {
        bad(format!("{e} (the study's results; `ssmctl study studies/flag.toml` writes them, see studies/README.md)"))
    })?;
    let de = &mut serde_json::Deserializer::from_str(&text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let at = e.path().to_string();
        bad(format!("at `{at}`: {}", e.into_inner()))
    })
}

/// `value` as the pretty JSON of a results file (with a final newline).
pub fn to_json<T: Serialize>(value: &T) -> Result<String, Error> {
    serde_json::to_string_pretty(value)
        .map(|s| s + "\n")
        .map_err(|e| Error::BadInput { what: "study results", why: format!("cannot serialize: {e}") })
}
