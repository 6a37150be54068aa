//! The flag study as a spec run on data: which runs train, test and validate (by number),
//! which candidates are measured, the estimator settings; [`run`] computes the results files
//! of [`crate::study_results`] that the data drives ([`HeldOutResults`],
//! [`ExperimentResults`], [`ValidationResults`]). `studies/flag.toml` is today's study; the
//! same spec on another data set needs only other run numbers and file names.
//!
//! Values are rounded as the results tables carry them (exponents 3 decimals, dimensions 2,
//! JS divergences 4), so that counts against the targets are the same on every re-run.

use std::path::{Path, PathBuf};

use chaos::{CorrSumParams, ScalingRule, correlation_dimension, delay_embed};
use serde::{Deserialize, Serialize};
use ssm::TimeSeries;

use crate::Error;
use crate::flag_self::{STEP, candidate_from_name, ensemble, ensemble_members, experiment_as_model};
use crate::microchaos::reduce_series;
use crate::model_selection::{
    DataStats, EvalSettings, data_stats, evaluate_candidate_fitted, moving_average, subsample,
};
use crate::study_results::{
    DimensionRow, EnsembleResult, ExperimentResults, HeldOutResults, ModelRow, NoisyModelCorrDim, RunCorrDim,
    RunOwnStats, RunStats, SmoothedCorrDim, ValidationResults, ValidationRun,
};
use chaos::{Context, add_noise};

/// A change of a model series' D2 by the data's noise larger than this is counted
/// (`NoisyModelCorrDim::changed_over_0_2`).
pub const D2_CHANGE: f64 = 0.2;

/// Where the runs are: `folder` under the data directory, `file` the name of run `k` with
/// `{run}` standing for its number.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataSpec {
    pub folder: String,
    pub file: String,
}

/// The runs by number: the training runs, the held-out test run, the validation runs (the
/// first picks) and the runs measured as perfect models of the test run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunsSpec {
    pub training: Vec<usize>,
    pub test: usize,
    pub validation: Vec<usize>,
    pub experiment: Vec<usize>,
}

/// The estimator settings ([`EvalSettings`]); the map step is the flag's ([`STEP`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StatisticsSpec {
    pub step: usize,
    pub gp_embed: usize,
    pub long_runs: usize,
    pub benettin_transient: usize,
    pub benettin_steps: usize,
    pub region_factor: f64,
    /// Seeds of the white noise added to the test run and to the model series (the noise
    /// checks of D2).
    pub data_noise_seed: u64,
    pub model_noise_seed: u64,
}

impl StatisticsSpec {
    fn settings(&self) -> EvalSettings {
        EvalSettings {
            gp_embed: self.gp_embed,
            long_runs: self.long_runs,
            benettin_transient: self.benettin_transient,
            benettin_steps: self.benettin_steps,
            region_factor: self.region_factor,
        }
    }
}

/// The candidates by name ([`candidate_from_name`]): at other SSM dimensions (`fit`), with
/// multistep refinement (`multistep`), the centre-set search (`centres`, which the
/// validation runs measure again), and the centre-set rows whose dimension is diagnosed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelsSpec {
    pub fit: Vec<String>,
    pub multistep: Vec<String>,
    pub centres: Vec<String>,
    pub dimension: Vec<String>,
}

/// How many of the best validation-ranked d = 4 models are pooled.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnsembleSpec {
    pub members: usize,
}

/// A flag study spec (`studies/flag.toml`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FlagStudySpec {
    pub name: String,
    pub data: DataSpec,
    pub runs: RunsSpec,
    pub statistics: StatisticsSpec,
    pub models: ModelsSpec,
    pub ensemble: EnsembleSpec,
}

impl FlagStudySpec {
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
        if self.statistics.step != STEP {
            return Err(format!(
                "statistics.step = {}: the flag's candidates are fitted at step {STEP}",
                self.statistics.step
            ));
        }
        if !self.data.file.contains("{run}") {
            return Err(format!("data.file = `{}`: needs `{{run}}` for the run number", self.data.file));
        }
        let r = &self.runs;
        if r.training.is_empty() {
            return Err("runs.training is empty".into());
        }
        if r.training.contains(&r.test) || r.validation.iter().any(|v| *v == r.test || r.training.contains(v)) {
            return Err(
                "runs: the test run and the validation runs must be neither training runs nor each other".into()
            );
        }
        if r.validation.is_empty() {
            return Err("runs.validation is empty (the first validation run picks)".into());
        }
        if r.experiment.contains(&r.test) {
            return Err(format!("runs.experiment lists the test run {} (it is measured against itself)", r.test));
        }
        let m = &self.models;
        for n in m.fit.iter().chain(&m.multistep).chain(&m.centres) {
            candidate_from_name(n).map_err(|e| format!("models: {e}"))?;
        }
        if let Some(n) = m.dimension.iter().find(|n| !m.centres.contains(n)) {
            return Err(format!("models.dimension: `{n}` is not in models.centres"));
        }
        if self.ensemble.members == 0 {
            return Err("ensemble.members = 0".into());
        }
        Ok(())
    }

    /// The file of run `run` under `data_dir`.
    pub fn run_path(&self, data_dir: &Path, run: usize) -> PathBuf {
        data_dir.join(&self.data.folder).join(self.data.file.replace("{run}", &run.to_string()))
    }

    /// The name of run `run`: its file name without the extension.
    pub fn run_name(&self, run: usize) -> String {
        let f = self.data.file.replace("{run}", &run.to_string());
        Path::new(&f).file_stem().map_or(f.clone(), |s| s.to_string_lossy().into_owned())
    }

    /// Every run the study reads, ascending.
    pub fn all_runs(&self) -> Vec<usize> {
        let r = &self.runs;
        let mut v: Vec<usize> =
            r.training.iter().chain(&r.validation).chain(&r.experiment).copied().chain([r.test]).collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    /// The spec with each candidate list cut to its first `n` (a budget for a quick run);
    /// the dimension rows keep the names still among the centre-set rows.
    pub fn limited(&self, n: usize) -> Self {
        let mut s = self.clone();
        let m = &mut s.models;
        for v in [&mut m.fit, &mut m.multistep, &mut m.centres] {
            v.truncate(n);
        }
        let centres = m.centres.clone();
        m.dimension.retain(|d| centres.contains(d));
        s
    }
}

/// The results a spec computes.
#[derive(Clone, Debug, PartialEq)]
pub struct FlagStudyResults {
    pub held_out: HeldOutResults,
    pub experiment: ExperimentResults,
    pub validation: ValidationResults,
}

/// What writes the results (their `produced_by`).
pub const PRODUCED_BY: &str = "ssmctl study studies/flag.toml --data-dir ../shared/data --out studies/results/flag";

fn round(v: Option<f64>, decimals: i32) -> Option<f64> {
    let f = 10f64.powi(decimals);
    v.map(|v| (v * f).round() / f)
}

/// D2 of `x` with the settings `ctx` of the test run (`None` without a scaling range).
fn corr_dim_with(x: &[f64], ctx: &Context) -> Option<(f64, f64)> {
    delay_embed(x, ctx.embed, ctx.lag)
        .and_then(|p| {
            correlation_dimension(
                &p,
                &CorrSumParams { theiler: ctx.theiler, ..Default::default() },
                &ScalingRule::default(),
            )
        })
        .map(|c| (c.dimension, c.slope_std))
        .ok()
}

/// One candidate measured on `test`: its row and, for the dimension diagnosis, the model's
/// Kaplan-Yorke dimension, D2 of five test-length pieces of its long run and D2 of the first
/// piece with the data's noise added.
struct Measured {
    row: ModelRow,
    kaplan_yorke: Option<f64>,
    pieces: [Option<f64>; 5],
    noisy: Option<f64>,
}

fn measure(
    train: &[TimeSeries],
    test: &TimeSeries,
    name: &str,
    data: &(DataStats, Context),
    s: &EvalSettings,
    model_noise_seed: u64,
    diagnose: bool,
) -> Result<Measured, Error> {
    let c = candidate_from_name(name)?;
    let (r, m) = evaluate_candidate_fitted(train, test, &c, data, s)?;
    let failed = r.failed.as_deref().map(|f| f.split(':').next().unwrap_or(f).to_string());
    let row = ModelRow {
        candidate: name.to_string(),
        benettin: if failed.is_some() { None } else { round(r.benettin, 3) },
        rosenstein: if failed.is_some() { None } else { round(r.rosenstein, 3) },
        corr_dim: if failed.is_some() { None } else { round(r.corr_dim, 2) },
        js: if failed.is_some() { None } else { round(r.js, 4) },
        failed,
    };
    let mut out = Measured { row, kaplan_yorke: None, pieces: [None; 5], noisy: None };
    let (Some(m), None) = (m, &out.row.failed) else { return Ok(out) };
    let (ds, ctx) = data;
    let eta = reduce_series(&m, &subsample(test, STEP, 0)?)?;
    let d = m.options.dim;
    if eta.len() < d {
        return Ok(out);
    }
    let eta0 = &eta[..d];
    if diagnose {
        out.kaplan_yorke = crate::lyapunov::model_lyapunov(&m, eta0, s.benettin_transient, s.benettin_steps)
            .ok()
            .and_then(|l| round(l.kaplan_yorke, 2));
    }
    let n = eta.len() / d;
    let orbit =
        crate::lyapunov::iterate_dynamics(&m.dynamics, eta0, n * s.long_runs, crate::lyapunov::model_bound(&m), 1)?;
    let Some(pts) = orbit.recorded else { return Ok(out) };
    let mut lifted = vec![0.0; m.manifold.p];
    let mut ps = ssm::poly::PolyScratch::default();
    let x: Vec<f64> = (0..pts.len())
        .map(|i| {
            m.manifold.lift_into(pts.point(i), &mut ps, &mut lifted);
            lifted[0]
        })
        .collect();
    out.noisy =
        round(corr_dim_with(&add_noise(&x[..n.min(x.len())], ds.noise_sd, model_noise_seed), ctx).map(|c| c.0), 2);
    if diagnose {
        for (slot, piece) in out.pieces.iter_mut().zip(x.chunks_exact(n)) {
            *slot = round(corr_dim_with(piece, ctx).map(|c| c.0), 2);
        }
    }
    Ok(out)
}

/// Loads run `run` of the spec (the error names the file).
fn load(spec: &FlagStudySpec, data_dir: &Path, run: usize) -> Result<TimeSeries, Error> {
    let p = spec.run_path(data_dir, run);
    ssm::load_csv(&p).map_err(|e| Error::BadInput { what: "study data", why: format!("{}: {e}", p.display()) })
}

fn stats_of(ds: &DataStats) -> RunStats {
    RunStats {
        rosenstein: round(Some(ds.lle), 3).unwrap_or(f64::NAN),
        corr_dim: round(Some(ds.corr_dim), 2).unwrap_or(f64::NAN),
        corr_dim_err: round(Some(ds.corr_dim_err), 2).unwrap_or(f64::NAN),
    }
}

/// Runs the study `spec` on the runs under `data_dir`; `progress` hears one line per stage.
pub fn run(spec: &FlagStudySpec, data_dir: &Path, progress: &dyn Fn(&str)) -> Result<FlagStudyResults, Error> {
    let s = spec.statistics.settings();
    let r = &spec.runs;
    let runs: Vec<(usize, TimeSeries)> =
        spec.all_runs().into_iter().map(|k| load(spec, data_dir, k).map(|t| (k, t))).collect::<Result<_, _>>()?;
    let get = |k: usize| {
        runs.iter()
            .find(|(j, _)| *j == k)
            .map(|(_, t)| t)
            .ok_or(Error::BadInput { what: "study spec", why: format!("run {k} not loaded") })
    };
    let train: Vec<TimeSeries> = r.training.iter().map(|&k| get(k).cloned()).collect::<Result<_, _>>()?;
    let test = get(r.test)?;
    let data = data_stats(test, STEP, &s)?;
    let (ds, ctx) = &data;
    progress(&format!(
        "test run {}: {} samples at step {STEP}, lag {}, Theiler {}",
        r.test, ds.len, ctx.lag, ctx.theiler
    ));

    // Every candidate on the test run.
    let seed = spec.statistics.model_noise_seed;
    let m = &spec.models;
    let on_test = |names: &[String], what: &str| -> Result<Vec<Measured>, Error> {
        progress(&format!("{what}: {} candidates on run {}", names.len(), r.test));
        crate::par_map(names, |n| measure(&train, test, n, &data, &s, seed, m.dimension.contains(n)))
    };
    let fit = on_test(&m.fit, "fit")?;
    let multistep = on_test(&m.multistep, "multistep")?;
    let centres = on_test(&m.centres, "centres")?;
    let with_both: Vec<f64> = centres.iter().filter_map(|c| Some(c.noisy? - c.row.corr_dim?)).collect();
    let mean_change =
        if with_both.is_empty() { f64::NAN } else { with_both.iter().sum::<f64>() / with_both.len() as f64 };

    // The test run's D2 smoothed and with its noise added again; every run's D2 with the
    // test run's settings.
    let x4 = |ts: &TimeSeries| subsample(ts, STEP, 0).map(|t| t.x);
    let d2 = |x: &[f64]| corr_dim_with(x, ctx).map(|c| c.0);
    let smoothed = |w: usize| -> Result<Option<f64>, Error> { Ok(d2(&x4(&moving_average(test, w)?)?)) };
    let need = |v: Option<f64>, what: &str| {
        v.ok_or_else(|| Error::BadInput { what: "study data", why: format!("run {}: no D2 {what}", r.test) })
    };
    let corr_dim_smoothed = SmoothedCorrDim {
        smoothed_3: need(round(smoothed(1)?, 2), "after a 3-point moving average")?,
        smoothed_5: need(round(smoothed(2)?, 2), "after a 5-point moving average")?,
        noise_added: need(
            round(d2(&add_noise(&x4(test)?, ds.noise_sd, spec.statistics.data_noise_seed)), 2),
            "with its noise added",
        )?,
    };
    let corr_dim_runs = runs
        .iter()
        .map(|(k, ts)| Ok(RunCorrDim { run: *k, corr_dim: round(d2(&x4(ts)?), 2) }))
        .collect::<Result<_, Error>>()?;

    let held_out = HeldOutResults {
        produced_by: PRODUCED_BY.into(),
        test_run: spec.run_name(r.test),
        train_runs: r.training.iter().map(|&k| spec.run_name(k)).collect(),
        test_len: ds.len,
        data: stats_of(ds),
        fit: fit.into_iter().map(|c| c.row).collect(),
        multistep: multistep.into_iter().map(|c| c.row).collect(),
        dimension: m
            .dimension
            .iter()
            .filter_map(|n| centres.iter().find(|c| &c.row.candidate == n))
            .map(|c| DimensionRow {
                candidate: c.row.candidate.clone(),
                kaplan_yorke: c.kaplan_yorke,
                corr_dim_pieces: c.pieces,
            })
            .collect(),
        model_noisy_corr_dim: NoisyModelCorrDim {
            rows: with_both.len(),
            mean_change: round(Some(mean_change), 2).unwrap_or(f64::NAN),
            changed_over_0_2: with_both.iter().filter(|v| v.abs() > D2_CHANGE).count(),
        },
        centres: centres.into_iter().map(|c| c.row).collect(),
        corr_dim_runs,
        corr_dim_smoothed,
    };

    // The experiment as its own model, and every run with its own settings.
    progress("the runs as models of the test run");
    let exp_runs: Vec<(usize, TimeSeries)> =
        r.experiment.iter().map(|&k| get(k).map(|t| (k, t.clone()))).collect::<Result<_, _>>()?;
    let (_, mut self_rows) = experiment_as_model(&train, test, &exp_runs, &s)?;
    for row in &mut self_rows {
        row.rosenstein = round(row.rosenstein, 3);
        row.corr_dim = round(row.corr_dim, 2);
        row.corr_dim_err = round(row.corr_dim_err, 2);
        row.js = round(row.js, 4);
    }
    let mut own: Vec<usize> = r.experiment.iter().copied().chain([r.test]).collect();
    own.sort_unstable();
    let runs_own = own
        .iter()
        .filter_map(|&k| {
            let ts = get(k).ok()?;
            // A run whose statistics cannot be measured (no scaling range) is left out.
            let (d, _) = data_stats(ts, STEP, &s).ok()?;
            let st = stats_of(&d);
            Some(RunOwnStats {
                run: k,
                lag: d.lag,
                theiler: d.theiler,
                rosenstein: st.rosenstein,
                corr_dim: st.corr_dim,
                corr_dim_err: st.corr_dim_err,
            })
        })
        .collect();
    let experiment = ExperimentResults { produced_by: PRODUCED_BY.into(), rows: self_rows, runs_own };

    // The centre-set candidates on each validation run, and the ensemble.
    let mut vruns = Vec::new();
    for &v in &r.validation {
        let ts = get(v)?;
        let vdata = data_stats(ts, STEP, &s)?;
        progress(&format!("validation: {} candidates on run {v}", m.centres.len()));
        let rows = crate::par_map(&m.centres, |n| measure(&train, ts, n, &vdata, &s, seed, false))?;
        vruns.push(ValidationRun { run: v, data: stats_of(&vdata.0), rows: rows.into_iter().map(|c| c.row).collect() });
    }
    let members = ensemble_members(&vruns[0], spec.ensemble.members);
    let names: Vec<&str> = members.iter().map(String::as_str).collect();
    progress(&format!("ensemble of {} models", names.len()));
    let e = ensemble(&train, test, &names, &s)?;
    let js_pooled = round(e.js_pooled, 4).ok_or_else(|| Error::BadInput {
        what: "study results",
        why: format!(
            "the ensemble's pooled long runs have no density (members {:?}, failed {:?})",
            e.members, e.failed
        ),
    })?;
    let validation = ValidationResults {
        produced_by: PRODUCED_BY.into(),
        runs: vruns,
        ensemble: EnsembleResult { members: names.len(), js_pooled },
    };
    Ok(FlagStudyResults { held_out, experiment, validation })
}
