//! The inverted flag's experiment as its own model, and the pick of a flag model on a
//! validation run (issue 12, after [`crate::flag_pipeline_fit`]).
//!
//! - [`experiment_as_model`]: every other run of the flag (whole, and pieces of the held-out
//!   run's length) is treated as the output of a perfect model and measured against the
//!   held-out run traj_8 with exactly the estimators, settings and reduced coordinates the
//!   model rows use ([`crate::model_selection::evaluate_candidate`]): the Rosenstein exponent
//!   and D2 of the series at map step 4 with traj_8's lag, Theiler window and embedding, and
//!   the mean JS divergence of the densities of the SSM's reduced coordinates (d = 4, p = 9,
//!   fitted on traj_9 + traj_7). Benettin needs the equations of a map: a run of the
//!   experiment has none, so it is not measured here. [`FLAG_SELF`] are the committed rows,
//!   [`self_counts`] how many meet each target, [`placement`] where a model's statistic
//!   falls among the runs'.
//! - [`candidate_from_name`] and [`validation_pick`]: the committed candidates of
//!   [`crate::flag_pipeline_fit::FLAG_CENTRES`] measured on a validation run that is neither
//!   training nor test ([`FLAG_VALIDATION`]: traj_3) and picked there by
//!   [`crate::model_selection::select`]'s rule; the pick's numbers on traj_8 are its
//!   committed test row.

use chaos::{Bins, CorrSumParams, Points, ScalingRule, correlation_dimension, delay_embed};
use serde::Serialize;
use ssm::{Dynamics, FitOptions, TimeSeries, fit};

use crate::Error;
use crate::flag_pipeline::PipelineRow;
use crate::flag_pipeline_fit::{FLAG_DATA, FlagRow, variant};
use crate::microchaos::reduce_series;
use crate::model_selection::{Candidate, DataStats, EvalSettings, Targets, data_stats, phase_subsamples, subsample};

/// Map step of the flag's candidates, in samples.
pub const STEP: usize = 4;

/// One run (or piece of a run) of the flag measured as if it were a model's output: which
/// run, the first sample and the length of the piece at map step [`STEP`], and its
/// statistics against the held-out run.
#[derive(Clone, Debug, Serialize, PartialEq)]
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
pub fn experiment_as_model(train: &[TimeSeries], test: &TimeSeries, runs: &[(usize, TimeSeries)], s: &EvalSettings) -> Result<(DataStats, Vec<SelfRow>), Error> {
    let (ds, ctx) = data_stats(test, STEP, s)?;
    let m = flag_manifold(train)?;
    let d = m.options.dim;
    let eta_test = Points::from_flat(d, reduce_series(&m, &subsample(test, STEP, 0)?)?)?;
    let mut rows = Vec::new();
    for (run, ts) in runs {
        let k = subsample(ts, STEP, 0)?;
        for (run, start, len) in pieces(*run, k.x.len(), ds.len) {
            let piece = TimeSeries::new(format!("traj_{run} /{STEP} [{start}, {})", start + len), k.t[start..start + len].to_vec(), k.x[start..start + len].to_vec())?;
            let x = &piece.x;
            let rosenstein = ctx.lle(x, &mut Vec::new(), "run").ok().map(|(l, _)| l);
            let cd = delay_embed(x, ctx.embed, ctx.lag)
                .and_then(|p| correlation_dimension(&p, &CorrSumParams { theiler: ctx.theiler, ..Default::default() }, &ScalingRule::default()))
                .ok();
            let js = reduce_series(&m, &piece)
                .ok()
                .and_then(|e| Points::from_flat(d, e).ok())
                .and_then(|p| chaos::compare_pdfs(&eta_test, &p, Bins::default()).ok())
                .map(|c| c.mean_js_bits);
            rows.push(SelfRow { run, start, len, rosenstein, corr_dim: cd.as_ref().map(|c| c.dimension), corr_dim_err: cd.map(|c| c.slope_std), js });
        }
    }
    Ok((ds, rows))
}

/// Which of the three targets a model's (or a run's) statistics meet against the held-out
/// data `(Rosenstein, D2, D2 error bar)` ([`Targets::default`]): Rosenstein within 5 %, D2
/// within the error bar, JS <= 0.01.
pub fn self_passes(rosenstein: Option<f64>, corr_dim: Option<f64>, js: Option<f64>, data: (f64, f64, f64)) -> [bool; 3] {
    let t = Targets::default();
    let (lle, d2, d2_err) = data;
    [
        rosenstein.is_some_and(|r| (r - lle).abs() <= t.rosenstein_rel * lle.abs()),
        corr_dim.is_some_and(|v| (v - d2).abs() <= d2_err),
        js.is_some_and(|j| j <= t.js_max),
    ]
}

/// One committed row of [`FLAG_SELF`]: (run, first sample, length at step 4, Rosenstein
/// [1/s], D2, D2 error bar, JS [bits]).
pub type SelfRowC = (usize, usize, usize, Option<f64>, Option<f64>, Option<f64>, Option<f64>);

/// The held-out run traj_8 at step 4: its length in samples.
pub const FLAG_TEST_LEN: usize = 1973;

/// The flag's runs as perfect models of traj_8 ([`experiment_as_model`] with train traj_9 +
/// traj_7, example `flag_pipeline -- flag-self`): the nine other runs whole, and the first and
/// last traj_8-length pieces of the three longer ones (traj_3, traj_7, traj_9). Rounded as
/// the model rows are (Rosenstein 3 decimals, D2 2, JS 4).
pub const FLAG_SELF: &[SelfRowC] = &[
    (0, 0, 1954, Some(0.560), Some(3.68), Some(0.16), Some(0.0047)),
    (1, 0, 908, Some(0.342), None, None, Some(0.0034)),
    (2, 0, 943, Some(0.502), Some(3.47), Some(0.14), Some(0.0195)),
    (3, 0, 2247, Some(0.320), Some(3.70), Some(0.21), Some(0.0028)),
    (3, 0, 1973, Some(0.162), Some(3.65), Some(0.19), Some(0.0034)),
    (3, 274, 1973, Some(0.326), Some(3.76), Some(0.16), Some(0.0028)),
    (4, 0, 1438, Some(0.312), Some(3.05), Some(0.22), Some(0.0029)),
    (5, 0, 1246, Some(0.271), Some(2.13), Some(0.12), Some(0.0032)),
    (6, 0, 1534, Some(0.269), Some(3.74), Some(0.21), Some(0.0041)),
    (7, 0, 3158, Some(0.221), Some(4.38), Some(0.24), Some(0.0025)),
    (7, 0, 1973, Some(0.272), Some(2.43), Some(0.19), Some(0.0045)),
    (7, 1185, 1973, Some(0.423), Some(3.47), Some(0.23), Some(0.0037)),
    (9, 0, 3231, Some(0.310), Some(4.00), Some(0.13), Some(0.0038)),
    (9, 0, 1973, Some(0.204), Some(3.58), Some(0.21), Some(0.0051)),
    (9, 1258, 1973, Some(0.320), Some(3.83), Some(0.23), Some(0.0041)),
];

/// Each run through the held-out estimator with its OWN settings (lag and Theiler window
/// from its own series by [`data_stats`], as the pipeline measures a held-out run; example
/// `flag_pipeline -- flag-self`): (run, lag, Theiler window, Rosenstein [1/s], D2, D2 error
/// bar). traj_1 is left out: its D2 has no scaling range, so its statistics fail as a whole.
/// traj_8's are [`FLAG_DATA`]'s (lag 11, Theiler 38).
pub const FLAG_RUNS_OWN: &[(usize, usize, usize, f64, f64, f64)] = &[
    (0, 12, 37, 0.481, 3.56, 0.23),
    (2, 12, 37, 0.517, 1.04, 0.05),
    (3, 12, 38, 0.291, 1.93, 0.10),
    (4, 12, 38, 0.350, 3.28, 0.19),
    (5, 11, 38, 0.271, 2.13, 0.12),
    (6, 11, 37, 0.267, 3.74, 0.21),
    (7, 12, 38, 0.229, 4.01, 0.28),
    (8, 11, 38, 0.332, 3.36, 0.17),
    (9, 11, 38, 0.310, 4.00, 0.13),
];

/// [`FLAG_SELF`] as [`SelfRow`]s.
pub fn flag_self_rows() -> Vec<SelfRow> {
    FLAG_SELF.iter().map(|&(run, start, len, rosenstein, corr_dim, corr_dim_err, js)| SelfRow { run, start, len, rosenstein, corr_dim, corr_dim_err, js }).collect()
}

/// Whether a row is a whole run (not a piece of one).
pub fn is_whole(r: &SelfRow, rows: &[SelfRow]) -> bool {
    r.start == 0 && rows.iter().filter(|q| q.run == r.run).all(|q| q.len <= r.len)
}

/// Counts of `rows` meeting each target against `data` ([`self_passes`]): (rows,
/// Rosenstein, D2, JS, all three).
pub fn self_counts(rows: &[&SelfRow], data: (f64, f64, f64)) -> (usize, usize, usize, usize, usize) {
    let p: Vec<[bool; 3]> = rows.iter().map(|r| self_passes(r.rosenstein, r.corr_dim, r.js, data)).collect();
    (rows.len(), p.iter().filter(|p| p[0]).count(), p.iter().filter(|p| p[1]).count(), p.iter().filter(|p| p[2]).count(), p.iter().filter(|p| p.iter().all(|&b| b)).count())
}

/// Mean and sample sd of `v` (`None` with fewer than two values).
pub fn mean_sd(v: &[f64]) -> Option<(f64, f64)> {
    if v.len() < 2 {
        return None;
    }
    let m = v.iter().sum::<f64>() / v.len() as f64;
    Some((m, (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64).sqrt()))
}

/// Where `x` falls among the values `v`: (share of `v` below `x`, ties counting half; the
/// z-score `(x - mean) / sd`). `None` with fewer than two values or no spread.
pub fn placement(x: f64, v: &[f64]) -> Option<(f64, f64)> {
    let (m, sd) = mean_sd(v).filter(|&(_, sd)| sd > 0.0)?;
    let below = v.iter().map(|&y| if y < x { 1.0 } else if y == x { 0.5 } else { 0.0 }).sum::<f64>();
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
        t.strip_prefix(key).ok_or_else(|| bad(&format!("expected {key}.., got `{t}`")))?.parse::<f64>().map_err(|_| bad(&format!("`{t}` is not {key}NUMBER")))
    };
    let centers = num(tok.next(), "")? as usize;
    let ridge = num(tok.next(), "r=")?;
    let dim = num(tok.next(), "d=")? as usize;
    let embed = num(tok.next(), "p=")? as usize;
    let (mut centres, mut ms) = (ssm::dynamics::CentreChoice::Farthest, None);
    while let Some(t) = tok.next() {
        match t {
            "centres" => centres = ssm::dynamics::CentreChoice::parse(tok.next().ok_or_else(|| bad("centre choice missing"))?).map_err(ssm::Error::from)?,
            "ms" => {
                let horizon = num(tok.next(), "h=")? as usize;
                let stride = (tok.next() == Some("stride")).then(|| num(tok.next(), "")).ok_or_else(|| bad("expected stride"))?? as usize;
                let iterations = (tok.next() == Some("it")).then(|| num(tok.next(), "")).ok_or_else(|| bad("expected it"))?? as usize;
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

/// The held-out statistics a row is judged against: (Rosenstein [1/s], D2, D2 error bar).
pub type DataRef = (f64, f64, f64);

/// Score of a row as [`crate::model_selection::CandidateResult::score`] (each error over its
/// tolerance, summed; infinite for a failed row or a missing value).
pub fn row_score(r: &PipelineRow) -> f64 {
    if r.failed.is_some() {
        return f64::INFINITY;
    }
    let t = Targets::default();
    let l = r.data_rosenstein.abs();
    let e = |v: Option<f64>, x: f64, tol: f64| v.map_or(f64::INFINITY, |v| (v - x).abs() / tol);
    e(r.benettin, r.data_rosenstein, t.benettin_rel * l)
        + e(r.rosenstein, r.data_rosenstein, t.rosenstein_rel * l)
        + e(r.corr_dim, r.data_corr_dim, r.data_corr_dim_err.max(1e-12))
        + r.js.map_or(f64::INFINITY, |j| j / t.js_max)
}

/// Rows of committed `rows` against the data `data`.
pub fn rows_against(rows: &[FlagRow], data: DataRef) -> Vec<PipelineRow> {
    rows.iter()
        .map(|&(name, benettin, rosenstein, corr_dim, js, failed)| {
            let m = crate::flag_pipeline::Measured { benettin, rosenstein, corr_dim, js };
            PipelineRow::from_values(name, 1, &m, (!failed.is_empty()).then(|| failed.to_string()), data.0, data.1, data.2, data.0)
        })
        .collect()
}

/// The pick among `rows` by [`crate::model_selection::select`]'s rule: most targets met,
/// ties by the smallest [`row_score`]; failed rows are never picked. Index into `rows`.
pub fn pick(rows: &[PipelineRow]) -> Option<usize> {
    let mut best: Option<(usize, usize, f64)> = None;
    for (i, r) in rows.iter().enumerate() {
        if r.failed.is_some() {
            continue;
        }
        let (n, sc) = (r.passes.iter().filter(|&&p| p).count(), row_score(r));
        if best.is_none_or(|(_, bn, bs)| n > bn || (n == bn && sc < bs)) {
            best = Some((i, n, sc));
        }
    }
    best.map(|b| b.0)
}

/// The validation run's statistics at step 4 (traj_3: Rosenstein, D2, error bar).
pub const FLAG_VALIDATION_DATA: DataRef = (0.0, 0.0, 0.0);

/// Every row of [`crate::flag_pipeline_fit::FLAG_CENTRES`] fitted on traj_9 + traj_7 again and
/// measured on the validation run traj_3 (neither training nor test; example `flag_pipeline
/// -- flag-validate 3`). Rows as [`crate::flag_pipeline_fit::FLAG_FIT`].
pub const FLAG_VALIDATION: &[FlagRow] = &[];

/// The validation pick ([`pick`] over [`FLAG_VALIDATION`] against [`FLAG_VALIDATION_DATA`]):
/// its validation row, and its committed test row ([`crate::flag_pipeline_fit::FLAG_CENTRES`]
/// against traj_8).
pub fn validation_pick() -> Option<(PipelineRow, PipelineRow)> {
    let val = rows_against(FLAG_VALIDATION, FLAG_VALIDATION_DATA);
    let i = pick(&val)?;
    let test = crate::flag_pipeline_fit::flag_centre_rows().into_iter().find(|r| r.candidate == val[i].candidate)?;
    Some((val[i].clone(), test))
}

#[cfg(test)]
mod tests;
