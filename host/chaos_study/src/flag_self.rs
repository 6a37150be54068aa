//! The inverted flag's experiment as its own model, and the pick of a flag model on a
//! validation run (docs/decisions/0002, after [`crate::flag_pipeline_fit`]).
//!
//! - [`experiment_as_model`]: every other run of the flag (whole, and pieces of the held-out
//!   run's length) is treated as the output of a perfect model and measured against the
//!   held-out run with exactly the estimators, settings and reduced coordinates the model
//!   rows use ([`crate::model_selection::evaluate_candidate`]): the Rosenstein exponent and
//!   D2 of the series at map step 4 with the held-out run's lag, Theiler window and
//!   embedding, and the mean JS divergence of the densities of the SSM's reduced coordinates
//!   (d = 4, p = 9, fitted on the training runs). Benettin needs the equations of a map: a
//!   run of the experiment has none, so it is not measured here. [`self_counts`] counts the
//!   rows meeting each target, [`placement`] says where a model's statistic falls among the
//!   runs'.
//! - [`candidate_from_name`] and [`validation_pick`]: the centre-set candidates measured on a
//!   validation run that is neither training nor test and picked there by
//!   [`crate::model_selection::select`]'s rule; the pick's numbers on the test run are its
//!   test row. The rows are the study's results files ([`crate::study_results`]).

use chaos::{Bins, CorrSumParams, Points, ScalingRule, correlation_dimension, delay_embed};
use serde::Serialize;
use ssm::{Dynamics, FitOptions, TimeSeries, fit};

use crate::Error;
use crate::flag_pipeline::PipelineRow;
use crate::flag_pipeline_fit::variant;
use crate::microchaos::reduce_series;
use crate::model_selection::{Candidate, DataStats, EvalSettings, data_stats, phase_subsamples, subsample};
use crate::study_results::{FlagResults, HeldOutResults, ValidationRun};
use chaos::{Reference, Statistics, Targets, best_of};

/// Map step of the flag's candidates, in samples.
pub const STEP: usize = 4;

pub use crate::study_results::SelfRow;

/// The pieces of a run `run` that is `len` samples long at map step [`STEP`]: the whole run,
/// and when it is longer than `piece` samples (the held-out run's length) its first and its
/// last `piece` samples (they overlap when the run is shorter than two pieces).
pub fn pieces(run: usize, len: usize, piece: usize) -> Vec<(usize, usize, usize)> {
    let mut out = vec![(run, 0, len)];
    if piece > 0 && len > piece {
        out.push((run, 0, piece));
        out.push((run, len - piece, piece));
    }
    out
}

/// The reduced coordinates of the flag's candidates at d = 4, p = 9: the SSM manifold
/// fitted on `train` at map step [`STEP`] as every d = 4, p = 9 candidate fits it (the
/// manifold does not depend on the reduced dynamics; the cheap linear map is fitted).
pub fn flag_manifold(train: &[TimeSeries]) -> Result<ssm::SsmModel, Error> {
    let c = variant(STEP, 250, 5e-9, 4, 9, 1, None, 0);
    let first = FitOptions { dynamics: Dynamics::Map, dyn_order: 1, ..c.fit };
    Ok(fit(&phase_subsamples(train, STEP)?, &first)?)
}

/// Every run of `runs` (number and series; pieces as [`pieces`]) measured against the
/// held-out series `test` as a model's series is (see the module docs): statistics of
/// `test` at map step [`STEP`] ([`data_stats`]) and one [`SelfRow`] per piece. The reduced
/// coordinates are those of [`flag_manifold`] on `train`. A statistic that cannot be
/// measured on a piece is `None`.
pub fn experiment_as_model(
    train: &[TimeSeries],
    test: &TimeSeries,
    runs: &[(usize, TimeSeries)],
    s: &EvalSettings,
) -> Result<(DataStats, Vec<SelfRow>), Error> {
    let (ds, ctx) = data_stats(test, STEP, s)?;
    let m = flag_manifold(train)?;
    let d = m.options.dim;
    let eta_test = Points::from_flat(d, reduce_series(&m, &subsample(test, STEP, 0)?)?)?;
    let mut rows = Vec::new();
    for (run, ts) in runs {
        let k = subsample(ts, STEP, 0)?;
        for (run, start, len) in pieces(*run, k.x.len(), ds.len) {
            let piece = TimeSeries::new(
                format!("traj_{run} /{STEP} [{start}, {})", start + len),
                k.t[start..start + len].to_vec(),
                k.x[start..start + len].to_vec(),
            )?;
            let x = &piece.x;
            let rosenstein = ctx.lle(x, &mut Vec::new(), "run").ok().map(|(l, _)| l);
            let cd = delay_embed(x, ctx.embed, ctx.lag)
                .and_then(|p| {
                    correlation_dimension(
                        &p,
                        &CorrSumParams { theiler: ctx.theiler, ..Default::default() },
                        &ScalingRule::default(),
                    )
                })
                .ok();
            let js = reduce_series(&m, &piece)
                .ok()
                .and_then(|e| Points::from_flat(d, e).ok())
                .and_then(|p| chaos::compare_pdfs(&eta_test, &p, Bins::default()).ok())
                .map(|c| c.mean_js_bits);
            rows.push(SelfRow {
                run,
                start,
                len,
                rosenstein,
                corr_dim: cd.as_ref().map(|c| c.dimension),
                corr_dim_err: cd.map(|c| c.slope_std),
                js,
            });
        }
    }
    Ok((ds, rows))
}

/// Which of the three targets a model's (or a run's) statistics meet against the held-out
/// data `(Rosenstein, D2, D2 error bar)` ([`Targets::default`]): Rosenstein within 5 %, D2
/// within the error bar, JS <= 0.01.
pub fn self_passes(
    rosenstein: Option<f64>,
    corr_dim: Option<f64>,
    js: Option<f64>,
    data: (f64, f64, f64),
) -> [bool; 3] {
    let (lle, corr_dim_data, corr_dim_err) = data;
    let m = Statistics { benettin: None, rosenstein, corr_dim, js };
    let [_, r, d, j] = Targets::default().passes(&m, &Reference { lle, corr_dim: corr_dim_data, corr_dim_err });
    [r, d, j]
}

/// Whether a row is a whole run (not a piece of one).
pub fn is_whole(r: &SelfRow, rows: &[SelfRow]) -> bool {
    r.start == 0 && rows.iter().filter(|q| q.run == r.run).all(|q| q.len <= r.len)
}

/// Counts of `rows` meeting each target against `data` ([`self_passes`]): (rows,
/// Rosenstein, D2, JS, all three).
pub fn self_counts(rows: &[&SelfRow], data: (f64, f64, f64)) -> (usize, usize, usize, usize, usize) {
    let p: Vec<[bool; 3]> = rows.iter().map(|r| self_passes(r.rosenstein, r.corr_dim, r.js, data)).collect();
    (
        rows.len(),
        p.iter().filter(|p| p[0]).count(),
        p.iter().filter(|p| p[1]).count(),
        p.iter().filter(|p| p[2]).count(),
        p.iter().filter(|p| p.iter().all(|&b| b)).count(),
    )
}

/// Mean and sample sd of `v` (`None` with fewer than two values).
pub fn mean_sd(v: &[f64]) -> Option<(f64, f64)> {
    (v.len() >= 2).then(|| chaos::mean_std(v))
}

/// Where `x` falls among the values `v`: (share of `v` below `x`, ties counting half; the
/// z-score `(x - mean) / sd`). `None` with fewer than two values or no spread.
pub fn placement(x: f64, v: &[f64]) -> Option<(f64, f64)> {
    let (m, sd) = mean_sd(v).filter(|&(_, sd)| sd > 0.0)?;
    let below = v
        .iter()
        .map(|&y| {
            if y < x {
                1.0
            } else if y == x {
                0.5
            } else {
                0.0
            }
        })
        .sum::<f64>();
    Some((below / v.len() as f64, (x - m) / sd))
}

/// The candidate of a committed flag row's name (`RBF C r=R d=D p=P[ centres CHOICE][ ms h=H
/// stride T it I]`, as [`variant`] with shift 1 and map step [`STEP`] names it, without the
/// step and shift); the name is kept as given.
pub fn candidate_from_name(name: &str) -> Result<Candidate, Error> {
    let bad = |why: &str| Error::BadInput { what: "flag row name", why: format!("`{name}`: {why}") };
    let mut tok = name.split_whitespace();
    if tok.next() != Some("RBF") {
        return Err(bad("does not start with RBF"));
    }
    let num = |t: Option<&str>, key: &str| -> Result<f64, Error> {
        let t = t.ok_or_else(|| bad(&format!("{key} missing")))?;
        t.strip_prefix(key)
            .ok_or_else(|| bad(&format!("expected {key}.., got `{t}`")))?
            .parse::<f64>()
            .map_err(|_| bad(&format!("`{t}` is not {key}NUMBER")))
    };
    let centers = num(tok.next(), "")? as usize;
    let ridge = num(tok.next(), "r=")?;
    let dim = num(tok.next(), "d=")? as usize;
    let embed = num(tok.next(), "p=")? as usize;
    let (mut centres, mut ms) = (ssm::dynamics::CentreChoice::Farthest, None);
    while let Some(t) = tok.next() {
        match t {
            "centres" => {
                centres = ssm::dynamics::CentreChoice::parse(tok.next().ok_or_else(|| bad("centre choice missing"))?)
                    .map_err(ssm::Error::from)?
            }
            "ms" => {
                let horizon = num(tok.next(), "h=")? as usize;
                let stride = (tok.next() == Some("stride"))
                    .then(|| num(tok.next(), ""))
                    .ok_or_else(|| bad("expected stride"))?? as usize;
                let iterations = (tok.next() == Some("it"))
                    .then(|| num(tok.next(), ""))
                    .ok_or_else(|| bad("expected it"))?? as usize;
                ms = Some(ssm::multistep::MultiStep { horizon, stride, iterations });
            }
            _ => return Err(bad(&format!("unknown token `{t}`"))),
        }
    }
    let mut c = variant(STEP, centers, ridge, dim, embed, 1, ms, 0);
    c.name = name.to_string();
    c.centres = centres;
    Ok(c)
}

/// Score of a row as [`crate::model_selection::CandidateResult::score`] (each error over its
/// tolerance, summed; infinite for a failed row or a missing value).
pub fn row_score(r: &PipelineRow) -> f64 {
    if r.failed.is_some() {
        return f64::INFINITY;
    }
    Targets::default().score(
        &Statistics { benettin: r.benettin, rosenstein: r.rosenstein, corr_dim: r.corr_dim, js: r.js },
        &Reference { lle: r.data_rosenstein, corr_dim: r.data_corr_dim, corr_dim_err: r.data_corr_dim_err },
    )
}

/// The pick among `rows` by [`crate::model_selection::select`]'s rule: most targets met,
/// ties by the smallest [`row_score`]; failed rows are never picked. Index into `rows`.
pub fn pick(rows: &[PipelineRow]) -> Option<usize> {
    best_of(rows.iter().map(|r| (r.failed.is_some(), r.passes.iter().filter(|&&p| p).count(), row_score(r))))
        .map(|b| b.0)
}

/// The validation pick ([`pick`] over the primary validation run's rows): its validation
/// row, and its test row (the same candidate among the held-out run's centre-set rows).
pub fn validation_pick(res: &FlagResults) -> Result<Option<(PipelineRow, PipelineRow)>, Error> {
    Ok(validation_pick_on(res.validation.primary()?, &res.held_out))
}

/// [`validation_pick`] over the validation run `val`, its test row from `held_out`.
pub fn validation_pick_on(val: &ValidationRun, held_out: &HeldOutResults) -> Option<(PipelineRow, PipelineRow)> {
    let rows = val.pipeline_rows();
    let i = pick(&rows)?;
    let test = held_out.centre_rows().into_iter().find(|r| r.candidate == rows[i].candidate)?;
    Some((rows[i].clone(), test))
}

/// The candidates of `rows` in the order of [`pick`]'s rule (most targets met first, then the
/// smallest [`row_score`]); failed rows are left out. Indices into `rows`.
pub fn ranked(rows: &[PipelineRow]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..rows.len()).filter(|&i| rows[i].failed.is_none()).collect();
    let n = |i: usize| rows[i].passes.iter().filter(|&&p| p).count();
    idx.sort_by(|&a, &b| n(b).cmp(&n(a)).then(row_score(&rows[a]).total_cmp(&row_score(&rows[b]))));
    idx
}

/// An ensemble of flag models: the members, each member's JS against the held-out run (its
/// own long run, as [`crate::model_selection::evaluate_candidate`] measures it) and the JS
/// of the pooled long runs of all members.
#[derive(Clone, Debug, Serialize)]
pub struct Ensemble {
    pub members: Vec<String>,
    pub js_members: Vec<Option<f64>>,
    /// Members whose long run escaped or left the data's region (their points are left out).
    pub failed: Vec<String>,
    pub js_pooled: Option<f64>,
}

/// The members `names` (committed row names, d = 4 and p = 9: every member then has the
/// reduced coordinates of [`flag_manifold`]) fitted on `train` and run from the held-out
/// run's first point for [`EvalSettings::long_runs`] held-out lengths, as the model rows
/// are; their long runs pooled into one density and compared with the held-out run's.
pub fn ensemble(train: &[TimeSeries], test: &TimeSeries, names: &[&str], s: &EvalSettings) -> Result<Ensemble, Error> {
    let test_k = subsample(test, STEP, 0)?;
    let m0 = flag_manifold(train)?;
    let eta_test = reduce_series(&m0, &test_k)?;
    let d = m0.options.dim;
    let data_max = eta_test.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let reference = Points::from_flat(d, eta_test.clone())?;
    let mut out = Ensemble { members: Vec::new(), js_members: Vec::new(), failed: Vec::new(), js_pooled: None };
    let mut pooled = Vec::new();
    let data = data_stats(test, STEP, s)?;
    for name in names {
        let c = candidate_from_name(name)?;
        if c.fit.dim != d || c.fit.embed != m0.options.embed {
            return Err(Error::BadInput {
                what: "ensemble member",
                why: format!("`{name}`: members need d = {d}, p = {} (shared reduced coordinates)", m0.options.embed),
            });
        }
        out.members.push(name.to_string());
        let (r, m) = crate::model_selection::evaluate_candidate_fitted(train, test, &c, &data, s)?;
        let Some(m) = m.filter(|_| r.failed.is_none()) else {
            out.failed.push(name.to_string());
            out.js_members.push(None);
            continue;
        };
        let eta = reduce_series(&m, &test_k)?;
        if eta.len() != eta_test.len()
            || eta.iter().zip(&eta_test).any(|(a, b)| (a - b).abs() > 1e-9 * data_max.max(1.0))
        {
            return Err(Error::BadInput {
                what: "ensemble member",
                why: format!("`{name}`: its reduced coordinates differ from the shared ones"),
            });
        }
        out.js_members.push(r.js);
        let n_long = test_k.x.len() * s.long_runs.max(1);
        let orbit =
            crate::lyapunov::iterate_dynamics(&m.dynamics, &eta[..d], n_long, crate::lyapunov::model_bound(&m), 1)?;
        if let Some(p) = orbit.recorded {
            pooled.extend_from_slice(p.as_flat());
        }
    }
    if !pooled.is_empty() {
        out.js_pooled =
            Some(chaos::compare_pdfs(&reference, &Points::from_flat(d, pooled)?, Bins::default())?.mean_js_bits);
    }
    Ok(out)
}

/// The first `k` rows of the validation run `val` in [`ranked`] order that have d = 4 and
/// p = 9 (the members of [`ensemble`]).
pub fn ensemble_members(val: &ValidationRun, k: usize) -> Vec<String> {
    let rows = val.pipeline_rows();
    ranked(&rows)
        .into_iter()
        .map(|i| val.rows[i].candidate.clone())
        .filter(|n| n.contains(" d=4 p=9"))
        .take(k)
        .collect()
}
