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
use crate::flag_pipeline_fit::{FlagRow, variant};
use crate::microchaos::reduce_series;
use crate::model_selection::{
    Candidate, DataStats, EvalSettings, Targets, best_of, data_stats, phase_subsamples, score_of, subsample,
};

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
    let t = Targets::default();
    let (lle, d2, d2_err) = data;
    [
        rosenstein.is_some_and(|r| (r - lle).abs() <= t.rosenstein_rel * lle.abs()),
        corr_dim.is_some_and(|v| (v - d2).abs() <= d2_err),
        js.is_some_and(|j| j <= t.js_max),
    ]
}

/// One committed row of [`FLAG_SELF`]: (run, first sample, length at step 4, Rosenstein
/// (1/s), D2, D2 error bar, JS (bits)).
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
/// traj_8's are [`crate::flag_pipeline_fit::FLAG_DATA`]'s (lag 11, Theiler 38).
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
    FLAG_SELF
        .iter()
        .map(|&(run, start, len, rosenstein, corr_dim, corr_dim_err, js)| SelfRow {
            run,
            start,
            len,
            rosenstein,
            corr_dim,
            corr_dim_err,
            js,
        })
        .collect()
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

/// The held-out statistics a row is judged against: (Rosenstein [1/s], D2, D2 error bar).
pub type DataRef = (f64, f64, f64);

/// Score of a row as [`crate::model_selection::CandidateResult::score`] (each error over its
/// tolerance, summed; infinite for a failed row or a missing value).
pub fn row_score(r: &PipelineRow) -> f64 {
    if r.failed.is_some() {
        return f64::INFINITY;
    }
    score_of(
        [r.benettin, r.rosenstein, r.corr_dim, r.js],
        (r.data_rosenstein, r.data_corr_dim, r.data_corr_dim_err),
        &Targets::default(),
    )
}

/// Rows of committed `rows` against the data `data`.
pub fn rows_against(rows: &[FlagRow], data: DataRef) -> Vec<PipelineRow> {
    rows.iter()
        .map(|&(name, benettin, rosenstein, corr_dim, js, failed)| {
            let m = crate::flag_pipeline::Measured { benettin, rosenstein, corr_dim, js };
            PipelineRow::from_values(
                name,
                1,
                &m,
                (!failed.is_empty()).then(|| failed.to_string()),
                data.0,
                data.1,
                data.2,
                data.0,
            )
        })
        .collect()
}

/// The pick among `rows` by [`crate::model_selection::select`]'s rule: most targets met,
/// ties by the smallest [`row_score`]; failed rows are never picked. Index into `rows`.
pub fn pick(rows: &[PipelineRow]) -> Option<usize> {
    best_of(rows.iter().map(|r| (r.failed.is_some(), r.passes.iter().filter(|&&p| p).count(), row_score(r))))
        .map(|b| b.0)
}

/// The validation run traj_3 at step 4 with its own settings (lag 12, Theiler window 38, as
/// [`FLAG_RUNS_OWN`]): Rosenstein (1/s), D2, error bar.
pub const FLAG_VALIDATION_DATA: DataRef = (0.291, 1.93, 0.10);

/// The validation run.
pub const VALIDATION_RUN: usize = 3;

/// Every row of [`crate::flag_pipeline_fit::FLAG_CENTRES`] fitted on traj_9 + traj_7 again and
/// measured on the validation run traj_3 (neither training nor test; example `flag_pipeline
/// -- flag-validate 3`). Rows as [`crate::flag_pipeline_fit::FLAG_FIT`].
pub const FLAG_VALIDATION: &[FlagRow] = &[
    ("RBF 200 r=3e-9 d=4 p=9", Some(0.499), Some(0.283), Some(2.89), Some(0.0041), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@1", Some(0.000), Some(0.223), Some(2.90), Some(0.2875), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@1", Some(0.440), Some(0.215), Some(2.36), Some(0.0063), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@1", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans10@1", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@2", Some(0.463), Some(0.212), Some(3.08), Some(0.0096), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@2", Some(0.543), Some(0.251), Some(2.83), Some(0.0079), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans10@2", Some(0.000), Some(-0.007), Some(1.03), Some(0.1617), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@3", Some(0.342), Some(0.158), Some(2.44), Some(0.0047), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@3", Some(0.468), Some(0.352), Some(3.17), Some(0.0080), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@3", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans10@3", Some(0.000), Some(0.039), Some(1.08), Some(0.1550), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@4", None, Some(0.213), Some(2.31), Some(0.0048), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@4", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@4", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans10@4", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=1e-8 d=4 p=9", Some(0.388), Some(0.255), Some(2.82), Some(0.0082), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres farthest@1", Some(0.268), Some(0.190), Some(2.64), Some(0.0080), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans++@1", Some(0.373), Some(0.220), Some(2.55), Some(0.0047), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres random@1", Some(0.428), Some(0.240), Some(2.09), Some(0.0146), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans10@1", Some(0.000), Some(-0.003), Some(1.04), Some(0.1463), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres farthest@2", Some(0.392), Some(0.236), Some(1.64), Some(0.0103), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans++@2", Some(0.514), Some(0.345), Some(2.82), Some(0.0059), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans10@2", Some(0.000), Some(0.008), Some(1.05), Some(0.1461), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres farthest@3", Some(0.253), Some(0.130), Some(1.73), Some(0.0090), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans++@3", Some(-0.000), Some(-0.019), Some(1.05), Some(0.1439), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres random@3", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans10@3", Some(-0.000), Some(-0.007), Some(1.10), Some(0.1709), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres farthest@4", Some(0.318), Some(0.238), Some(2.65), Some(0.0081), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans++@4", Some(0.410), Some(0.201), Some(3.08), Some(0.0109), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres random@4", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans10@4", Some(0.360), Some(0.162), Some(2.79), Some(0.0165), ""),
    ("RBF 150 r=3e-9 d=4 p=9", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres farthest@1", Some(0.381), Some(0.199), Some(2.09), Some(0.0189), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans++@1", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres random@1", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans10@1", Some(0.000), Some(-0.001), Some(1.03), Some(0.2448), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres farthest@2", Some(0.000), Some(0.034), Some(1.08), Some(0.1166), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans++@2", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans10@2", Some(-0.000), Some(-0.004), Some(1.04), Some(0.1671), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres farthest@3", Some(0.317), Some(0.164), Some(2.10), Some(0.0092), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans++@3", Some(0.441), Some(0.359), Some(2.23), Some(0.0076), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres random@3", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans10@3", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres farthest@4", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans++@4", Some(0.445), Some(0.272), Some(2.92), Some(0.0063), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres random@4", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans10@4", Some(-0.000), Some(-0.008), Some(1.03), Some(0.1664), ""),
    ("RBF 150 r=1e-8 d=4 p=9", Some(-0.100), Some(0.024), None, Some(0.1547), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres farthest@1", Some(0.000), Some(0.035), Some(1.12), Some(0.1140), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans++@1", None, Some(0.196), Some(3.03), Some(0.0177), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres random@1", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans10@1", Some(0.000), Some(-0.001), Some(0.70), Some(0.2364), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres farthest@2", Some(0.000), Some(0.025), Some(1.05), Some(0.1355), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans++@2", Some(0.574), Some(0.292), Some(2.99), Some(0.0112), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans10@2", Some(-0.000), Some(0.017), Some(1.21), Some(0.2154), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres farthest@3", Some(0.000), Some(0.056), Some(1.14), Some(0.1135), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans++@3", Some(0.000), Some(0.094), Some(1.07), Some(0.1140), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres random@3", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans10@3", Some(0.000), Some(0.006), Some(1.05), Some(0.1981), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres farthest@4", Some(-0.000), Some(0.015), Some(1.03), Some(0.1310), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans++@4", Some(0.381), Some(0.166), Some(2.71), Some(0.0104), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres random@4", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans10@4", Some(-0.000), Some(-0.014), Some(1.00), Some(0.1626), ""),
    ("RBF 300 r=3e-9 d=4 p=9", Some(0.304), Some(0.267), Some(2.20), Some(0.0058), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres farthest@1", Some(0.363), Some(0.255), Some(2.33), Some(0.0042), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans++@1", Some(0.298), Some(0.248), Some(2.25), Some(0.0140), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres random@1", Some(0.460), Some(0.177), Some(2.51), Some(0.0108), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans10@1", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=3e-9 d=4 p=9 centres farthest@2", Some(0.313), Some(0.162), Some(2.62), Some(0.0167), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans++@2", Some(0.445), Some(0.311), Some(2.84), Some(0.0061), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres random@2", Some(-0.022), Some(0.253), Some(1.12), Some(0.6043), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans10@2", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=3e-9 d=4 p=9 centres farthest@3", Some(0.350), Some(0.190), Some(1.96), Some(0.0044), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans++@3", Some(0.367), Some(0.261), Some(3.15), Some(0.0047), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres random@3", Some(0.436), Some(0.272), Some(2.69), Some(0.0055), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans10@3", Some(0.248), Some(0.128), Some(1.97), Some(0.0526), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres farthest@4", Some(-0.023), Some(0.202), Some(1.62), Some(0.0055), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans++@4", Some(-0.087), Some(0.144), Some(1.11), Some(0.0502), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres random@4", Some(0.371), Some(0.308), Some(2.29), Some(0.0152), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans10@4", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=1e-8 d=4 p=9", Some(0.209), Some(0.210), Some(1.90), Some(0.0091), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@1", Some(0.236), Some(0.102), Some(1.88), Some(0.0087), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@1", Some(0.230), Some(0.169), Some(1.35), Some(0.0111), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@1", Some(-0.099), Some(0.016), Some(0.82), Some(0.0708), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans10@1", Some(0.061), Some(0.139), Some(2.54), Some(0.0219), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@2", Some(0.191), Some(0.186), Some(1.53), Some(0.0102), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@2", Some(0.359), Some(0.205), Some(3.02), Some(0.0077), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@2", Some(0.404), Some(0.167), Some(2.69), Some(0.0314), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans10@2", Some(0.105), Some(0.096), Some(1.39), Some(0.0495), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@3", Some(0.205), Some(0.179), Some(2.24), Some(0.0093), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@3", Some(0.295), Some(0.158), Some(2.68), Some(0.0080), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@3", Some(0.399), Some(0.161), Some(2.78), Some(0.0051), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans10@3", Some(0.053), Some(0.125), Some(1.23), Some(0.0440), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@4", Some(0.190), Some(0.165), Some(1.99), Some(0.0108), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@4", Some(0.304), Some(0.140), Some(2.57), Some(0.0134), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@4", Some(0.326), Some(0.151), Some(2.09), Some(0.0070), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans10@4", Some(0.126), Some(0.158), Some(2.51), Some(0.0307), ""),
    ("RBF 200 r=3e-9 d=4 p=9 ms h=4 stride 8 it 4", Some(0.418), Some(0.218), Some(1.72), Some(0.0101), ""),
    (
        "RBF 200 r=3e-9 d=4 p=9 centres farthest@2 ms h=4 stride 8 it 4",
        Some(0.320),
        Some(0.176),
        Some(2.20),
        Some(0.0303),
        "",
    ),
    (
        "RBF 200 r=3e-9 d=4 p=9 centres kmeans++@4 ms h=4 stride 8 it 4",
        Some(0.436),
        Some(0.199),
        Some(2.40),
        Some(0.0110),
        "",
    ),
    (
        "RBF 300 r=1e-8 d=4 p=9 centres kmeans++@2 ms h=4 stride 8 it 4",
        Some(0.354),
        Some(0.151),
        Some(1.35),
        Some(0.0120),
        "",
    ),
    (
        "RBF 300 r=1e-8 d=4 p=9 centres random@3 ms h=4 stride 8 it 4",
        Some(0.316),
        Some(0.212),
        Some(2.25),
        Some(0.0070),
        "",
    ),
    (
        "RBF 150 r=1e-8 d=4 p=9 centres kmeans++@2 ms h=4 stride 8 it 4",
        Some(0.466),
        Some(0.256),
        Some(2.16),
        Some(0.0126),
        "",
    ),
    (
        "RBF 300 r=1e-8 d=4 p=9 centres random@1 ms h=4 stride 8 it 4",
        Some(0.327),
        Some(0.105),
        Some(2.85),
        Some(0.0156),
        "",
    ),
    ("RBF 200 r=3e-9 d=4 p=9 ms h=2 stride 8 it 4", Some(0.448), Some(0.221), Some(2.25), Some(0.0081), ""),
    (
        "RBF 300 r=1e-8 d=4 p=9 centres kmeans++@2 ms h=2 stride 8 it 4",
        Some(0.273),
        Some(0.256),
        Some(1.73),
        Some(0.0145),
        "",
    ),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@5", Some(0.372), Some(0.188), Some(1.13), Some(0.0222), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@5", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@5", Some(0.204), Some(0.312), Some(1.74), Some(0.0142), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@6", Some(0.351), Some(0.195), Some(2.53), Some(0.0054), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@6", Some(0.034), Some(0.141), Some(2.44), Some(0.0407), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@6", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@7", Some(0.028), Some(0.026), Some(1.15), Some(0.6546), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@7", Some(0.463), Some(0.198), Some(1.96), Some(0.0057), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@7", Some(0.552), Some(0.332), Some(2.08), Some(0.0081), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@8", Some(0.069), Some(0.202), Some(3.07), Some(0.1362), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@8", Some(0.435), Some(0.189), Some(2.03), Some(0.0108), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@8", Some(0.502), Some(0.163), Some(2.81), Some(0.0068), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@9", Some(0.284), Some(0.219), Some(1.73), Some(0.0049), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@9", Some(-0.096), Some(0.116), Some(1.20), Some(0.0961), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@9", Some(0.000), Some(-0.007), Some(1.05), Some(0.5778), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@10", Some(0.386), Some(0.231), Some(2.76), Some(0.0089), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@10", Some(0.513), Some(0.169), Some(3.25), Some(0.0048), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@10", None, Some(0.197), Some(2.82), Some(0.0254), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@11", Some(0.445), Some(0.220), Some(3.06), Some(0.0083), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@11", Some(0.480), Some(0.242), Some(2.83), Some(0.0058), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@11", Some(0.473), Some(0.245), Some(3.19), Some(0.0054), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@12", Some(0.355), Some(0.292), Some(2.47), Some(0.0064), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@12", Some(0.460), Some(0.221), Some(2.82), Some(0.0123), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@12", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@5", Some(0.166), Some(0.162), Some(2.31), Some(0.0090), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@5", Some(0.288), Some(0.145), Some(2.70), Some(0.0091), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@5", Some(0.412), Some(0.328), Some(2.77), Some(0.0069), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@6", Some(0.207), Some(0.175), Some(2.03), Some(0.0098), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@6", Some(0.293), Some(0.204), Some(2.05), Some(0.0086), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@6", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@7", Some(0.214), Some(0.135), Some(2.66), Some(0.0076), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@7", Some(0.278), Some(0.114), Some(1.59), Some(0.0075), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@7", Some(0.437), Some(0.297), Some(3.07), Some(0.0070), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@8", Some(0.222), Some(0.067), Some(2.60), Some(0.0111), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@8", Some(0.249), Some(0.138), Some(1.74), Some(0.0179), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@8", Some(0.439), Some(0.253), Some(2.86), Some(0.0053), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@9", Some(0.250), Some(0.250), Some(2.39), Some(0.0069), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@9", Some(0.330), Some(0.287), Some(2.94), Some(0.0053), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@9", Some(0.385), Some(0.307), Some(1.55), Some(0.0039), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@10", Some(0.259), Some(0.240), Some(2.24), Some(0.0068), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@10", Some(0.290), Some(0.116), Some(2.94), Some(0.0049), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@10", Some(0.363), Some(0.210), Some(2.54), Some(0.0108), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@11", Some(0.307), Some(0.185), Some(2.49), Some(0.0078), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@11", Some(0.294), Some(0.164), Some(1.52), Some(0.0047), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@11", Some(0.381), Some(0.172), Some(2.58), Some(0.0059), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@12", Some(0.248), Some(0.161), Some(1.91), Some(0.0060), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@12", Some(0.273), Some(0.166), Some(2.68), Some(0.0103), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@12", Some(0.506), Some(0.288), Some(3.01), Some(0.0115), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@5", Some(0.235), Some(0.133), Some(2.15), Some(0.0095), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@5", Some(0.399), Some(0.226), Some(2.49), Some(0.0093), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@5", Some(0.456), Some(0.178), Some(1.98), Some(0.0048), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@6", Some(0.270), Some(0.181), Some(2.13), Some(0.0099), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@6", Some(0.330), Some(0.111), Some(2.30), Some(0.0151), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@6", None, None, None, None, "escaped in the long run"),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@7", Some(0.272), Some(0.136), Some(2.58), Some(0.0104), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@7", Some(0.340), Some(0.137), Some(2.46), Some(0.0063), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@7", Some(0.457), Some(0.199), Some(2.38), Some(0.0078), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@8", Some(0.264), Some(0.198), Some(2.44), Some(0.0133), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@8", Some(0.204), Some(0.119), Some(2.05), Some(0.0238), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@8", Some(0.456), Some(0.118), Some(3.04), Some(0.0057), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@9", Some(0.261), Some(0.223), Some(2.51), Some(0.0055), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@9", Some(0.336), Some(0.158), Some(2.28), Some(0.0082), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@9", Some(0.416), Some(0.226), Some(2.66), Some(0.0067), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@10", Some(0.229), Some(0.194), Some(2.26), Some(0.0086), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@10", Some(0.384), Some(0.202), Some(3.31), Some(0.0083), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@10", Some(0.417), Some(0.105), Some(2.30), Some(0.0093), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@11", Some(0.338), Some(0.194), Some(2.21), Some(0.0094), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@11", Some(0.300), Some(0.213), Some(1.96), Some(0.0067), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@11", Some(0.401), Some(0.130), Some(2.14), Some(0.0104), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@12", Some(0.303), Some(0.152), Some(1.61), Some(0.0060), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@12", Some(0.332), Some(0.199), Some(2.55), Some(0.0090), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@12", Some(0.451), Some(0.160), Some(2.60), Some(0.0056), ""),
    ("RBF 200 r=3e-9 d=5 p=11", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=5 p=11 centres kmeans++@1", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=5 p=11 centres random@1", Some(0.424), Some(0.180), Some(2.67), Some(0.0324), ""),
    ("RBF 200 r=3e-9 d=5 p=11 centres kmeans++@2", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=5 p=11 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=5 p=11 centres kmeans++@3", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=5 p=11 centres random@3", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=1e-8 d=5 p=11", Some(-0.070), Some(-0.077), None, Some(0.0570), ""),
    ("RBF 300 r=1e-8 d=5 p=11 centres kmeans++@1", Some(0.091), Some(0.093), Some(1.10), Some(0.0486), ""),
    ("RBF 300 r=1e-8 d=5 p=11 centres random@1", Some(-0.052), Some(0.115), Some(1.89), Some(0.0482), ""),
    ("RBF 300 r=1e-8 d=5 p=11 centres kmeans++@2", Some(0.143), Some(0.137), Some(2.01), Some(0.0381), ""),
    ("RBF 300 r=1e-8 d=5 p=11 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=1e-8 d=5 p=11 centres kmeans++@3", Some(-0.015), Some(-0.004), Some(1.19), Some(0.0624), ""),
    ("RBF 300 r=1e-8 d=5 p=11 centres random@3", Some(0.154), Some(0.137), Some(1.87), Some(0.0418), ""),
    ("RBF 200 r=3e-9 d=6 p=13", Some(0.231), Some(0.167), Some(2.51), Some(0.0285), ""),
    ("RBF 200 r=3e-9 d=6 p=13 centres kmeans++@1", Some(0.268), Some(0.149), Some(2.41), Some(0.0347), ""),
    ("RBF 200 r=3e-9 d=6 p=13 centres random@1", Some(-0.044), Some(0.180), Some(2.38), Some(0.0319), ""),
    ("RBF 200 r=3e-9 d=6 p=13 centres kmeans++@2", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=6 p=13 centres random@2", Some(-0.000), Some(0.052), Some(1.06), Some(0.3116), ""),
    ("RBF 200 r=3e-9 d=6 p=13 centres kmeans++@3", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=6 p=13 centres random@3", Some(0.242), Some(0.185), Some(1.90), Some(0.0359), ""),
    ("RBF 300 r=1e-8 d=6 p=13", Some(-0.277), Some(-0.070), None, Some(0.0820), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres kmeans++@1", Some(-0.067), Some(-0.026), Some(0.96), Some(0.0671), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres random@1", Some(0.199), Some(0.163), Some(1.71), Some(0.0387), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres kmeans++@2", Some(-0.048), Some(-0.023), Some(0.48), Some(0.0597), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres random@2", Some(0.097), Some(0.113), Some(1.92), Some(0.0448), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres kmeans++@3", Some(0.079), Some(0.117), Some(1.31), Some(0.0445), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres random@3", Some(0.104), Some(0.082), Some(1.23), Some(0.0412), ""),
    ("RBF 250 r=5e-9 d=4 p=9", Some(0.386), Some(0.247), Some(2.22), Some(0.0042), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@1", Some(0.425), Some(0.151), Some(2.60), Some(0.0060), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@1", None, None, None, None, "escaped in the long run"),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@2", Some(0.436), Some(0.165), Some(2.62), Some(0.0088), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@2", Some(0.410), Some(0.212), Some(2.43), Some(0.0138), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@3", Some(0.336), Some(0.167), Some(1.66), Some(0.0099), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@3", Some(0.416), Some(0.254), Some(2.65), Some(0.0047), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@4", Some(0.369), Some(0.180), Some(1.94), Some(0.0301), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@4", None, None, None, None, "escaped in the long run"),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@5", None, None, None, None, "escaped in the long run"),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@5", Some(0.441), Some(0.438), Some(2.65), Some(0.0086), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@6", Some(0.442), Some(0.125), Some(3.02), Some(0.0174), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@6", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=5e-9 d=4 p=9", Some(0.274), Some(0.178), Some(1.42), Some(0.0056), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@1", Some(-0.033), Some(0.245), Some(2.56), Some(0.0420), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@1", Some(0.461), Some(0.274), Some(2.02), Some(0.0099), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@2", Some(0.413), Some(0.254), Some(2.71), Some(0.0074), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@2", Some(0.424), Some(0.184), Some(2.35), Some(0.0101), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@3", Some(0.348), Some(0.154), Some(2.59), Some(0.0060), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@3", Some(0.431), Some(0.296), Some(2.28), Some(0.0040), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@4", Some(0.316), Some(0.201), Some(1.85), Some(0.0343), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@4", Some(0.347), Some(0.166), Some(1.77), Some(0.0255), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@5", Some(0.366), Some(0.137), Some(2.49), Some(0.0125), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@5", Some(0.443), Some(0.218), Some(2.46), Some(0.0077), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@6", Some(0.371), Some(0.254), Some(2.46), Some(0.0088), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@6", None, None, None, None, "escaped in the long run"),
];

/// The second validation run traj_0 with its own settings (lag 12, Theiler window 37):
/// Rosenstein (1/s), D2, error bar.
pub const FLAG_VALIDATION_0_DATA: DataRef = (0.481, 3.56, 0.23);

/// [`FLAG_VALIDATION`] on the second validation run traj_0 (example `flag_pipeline --
/// flag-validate 0`): how much the pick depends on which run validates.
pub const FLAG_VALIDATION_0: &[FlagRow] = &[
    ("RBF 200 r=3e-9 d=4 p=9", Some(0.508), Some(0.214), Some(2.97), Some(0.0082), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@1", Some(0.000), Some(0.144), Some(1.08), Some(0.3381), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@1", Some(0.442), Some(0.273), Some(2.74), Some(0.0072), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@1", None, Some(0.303), Some(2.38), Some(0.0070), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans10@1", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@2", Some(0.473), Some(0.278), Some(3.35), Some(0.0151), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@2", Some(0.537), Some(0.376), Some(1.77), Some(0.0123), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans10@2", Some(0.000), Some(-0.011), Some(1.05), Some(0.1428), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@3", Some(0.330), Some(0.215), Some(2.66), Some(0.0082), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@3", Some(0.471), Some(0.205), Some(2.87), Some(0.0164), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@3", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans10@3", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@4", Some(0.371), Some(0.150), Some(2.30), Some(0.0059), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@4", Some(0.504), Some(0.214), Some(2.62), Some(0.0188), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@4", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans10@4", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=1e-8 d=4 p=9", Some(0.390), Some(0.245), Some(3.06), Some(0.0146), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres farthest@1", Some(0.266), Some(0.179), Some(2.36), Some(0.0125), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans++@1", Some(0.371), Some(0.324), Some(2.86), Some(0.0086), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres random@1", Some(0.422), Some(0.265), Some(1.94), Some(0.0138), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans10@1", Some(-0.000), Some(0.001), Some(1.07), Some(0.1503), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres farthest@2", Some(0.391), Some(0.214), Some(2.71), Some(0.0170), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans++@2", Some(0.506), Some(0.332), Some(2.92), Some(0.0083), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans10@2", Some(-0.000), Some(0.017), Some(1.04), Some(0.1583), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres farthest@3", Some(0.240), Some(0.186), Some(2.19), Some(0.0152), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans++@3", Some(-0.000), Some(-0.011), Some(1.08), Some(0.1513), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres random@3", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans10@3", Some(0.196), Some(0.140), Some(1.80), Some(0.0662), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres farthest@4", Some(0.320), Some(0.224), Some(2.86), Some(0.0133), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans++@4", Some(0.416), Some(0.234), Some(2.49), Some(0.0184), ""),
    ("RBF 200 r=1e-8 d=4 p=9 centres random@4", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=1e-8 d=4 p=9 centres kmeans10@4", Some(0.355), Some(0.170), Some(2.41), Some(0.0241), ""),
    ("RBF 150 r=3e-9 d=4 p=9", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres farthest@1", Some(0.371), Some(0.194), Some(2.16), Some(0.0280), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans++@1", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres random@1", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans10@1", Some(0.000), Some(0.002), Some(1.03), Some(0.2395), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres farthest@2", Some(0.000), Some(0.004), Some(1.06), Some(0.1495), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans++@2", None, Some(0.254), Some(2.88), Some(0.0118), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans10@2", Some(0.000), Some(-0.001), Some(1.04), Some(0.1755), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres farthest@3", Some(0.330), Some(0.161), Some(1.60), Some(0.0140), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans++@3", Some(0.448), Some(0.241), Some(2.39), Some(0.0099), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres random@3", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans10@3", Some(0.000), Some(-0.004), Some(0.89), Some(0.1632), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres farthest@4", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans++@4", None, Some(0.199), Some(2.60), Some(0.0117), ""),
    ("RBF 150 r=3e-9 d=4 p=9 centres random@4", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=3e-9 d=4 p=9 centres kmeans10@4", Some(-0.000), Some(-0.014), Some(1.05), Some(0.1554), ""),
    ("RBF 150 r=1e-8 d=4 p=9", Some(-0.101), Some(-0.092), Some(0.11), Some(0.1843), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres farthest@1", Some(-0.000), Some(0.019), Some(1.09), Some(0.1311), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans++@1", Some(0.422), Some(0.162), Some(2.89), Some(0.0260), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres random@1", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans10@1", Some(0.000), Some(0.008), Some(1.23), Some(0.2229), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres farthest@2", Some(-0.000), Some(-0.010), Some(1.03), Some(0.1517), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans++@2", Some(0.571), Some(0.139), Some(3.01), Some(0.0170), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans10@2", Some(-0.000), Some(-0.006), Some(1.23), Some(0.2211), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres farthest@3", Some(-0.000), Some(0.030), Some(1.07), Some(0.1343), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans++@3", Some(0.033), Some(0.171), Some(2.72), Some(0.0147), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres random@3", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans10@3", Some(-0.000), Some(0.003), Some(1.04), Some(0.2122), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres farthest@4", Some(0.000), Some(0.097), Some(1.18), Some(0.1151), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans++@4", Some(0.393), Some(0.276), Some(2.41), Some(0.0179), ""),
    ("RBF 150 r=1e-8 d=4 p=9 centres random@4", None, None, None, None, "escaped in the long run"),
    ("RBF 150 r=1e-8 d=4 p=9 centres kmeans10@4", Some(0.000), Some(-0.010), Some(1.06), Some(0.1648), ""),
    ("RBF 300 r=3e-9 d=4 p=9", Some(0.309), Some(0.206), Some(2.65), Some(0.0071), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres farthest@1", Some(0.370), Some(0.105), Some(1.55), Some(0.0084), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans++@1", Some(0.308), Some(0.131), Some(2.35), Some(0.0166), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres random@1", Some(0.462), Some(0.280), Some(1.94), Some(0.0078), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans10@1", Some(0.208), Some(0.181), Some(1.33), Some(0.0585), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres farthest@2", Some(0.312), Some(0.194), Some(1.91), Some(0.0209), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans++@2", Some(0.446), Some(0.211), Some(2.96), Some(0.0078), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres random@2", Some(-0.022), Some(0.092), Some(3.01), Some(0.4414), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans10@2", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=3e-9 d=4 p=9 centres farthest@3", Some(0.354), Some(0.267), Some(1.53), Some(0.0071), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans++@3", Some(0.361), Some(0.274), Some(1.95), Some(0.0053), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres random@3", Some(0.433), Some(0.161), Some(2.62), Some(0.0050), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans10@3", Some(0.247), Some(0.138), Some(1.98), Some(0.0594), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres farthest@4", Some(-0.052), Some(0.251), Some(1.94), Some(0.0062), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans++@4", Some(0.274), Some(0.205), Some(1.79), Some(0.0475), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres random@4", Some(0.376), Some(0.252), Some(2.16), Some(0.0111), ""),
    ("RBF 300 r=3e-9 d=4 p=9 centres kmeans10@4", Some(0.331), Some(0.162), Some(2.29), Some(0.0577), ""),
    ("RBF 300 r=1e-8 d=4 p=9", Some(0.204), Some(0.132), Some(2.13), Some(0.0154), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@1", Some(0.241), Some(0.187), Some(2.33), Some(0.0147), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@1", Some(0.237), Some(0.187), Some(2.41), Some(0.0161), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@1", Some(0.370), Some(0.350), Some(1.60), Some(0.0109), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans10@1", Some(0.059), Some(0.137), Some(2.31), Some(0.0245), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@2", Some(0.196), Some(0.128), Some(1.65), Some(0.0165), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@2", Some(0.358), Some(0.174), Some(2.48), Some(0.0186), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@2", Some(0.410), Some(0.202), Some(2.43), Some(0.0330), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans10@2", Some(0.108), Some(0.065), Some(1.50), Some(0.0599), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@3", Some(0.194), Some(0.237), Some(1.49), Some(0.0140), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@3", Some(0.299), Some(0.195), Some(2.33), Some(0.0154), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@3", Some(0.395), Some(0.219), Some(2.98), Some(0.0108), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans10@3", Some(0.052), Some(0.049), Some(1.18), Some(0.0747), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@4", Some(0.188), Some(0.133), Some(2.28), Some(0.0152), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@4", Some(0.318), Some(0.139), Some(1.61), Some(0.0213), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@4", Some(0.329), Some(0.206), Some(1.53), Some(0.0068), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans10@4", Some(0.120), Some(0.112), Some(1.79), Some(0.0587), ""),
    ("RBF 200 r=3e-9 d=4 p=9 ms h=4 stride 8 it 4", Some(0.413), Some(0.216), Some(1.50), Some(0.0182), ""),
    (
        "RBF 200 r=3e-9 d=4 p=9 centres farthest@2 ms h=4 stride 8 it 4",
        Some(0.315),
        Some(0.215),
        Some(1.94),
        Some(0.0385),
        "",
    ),
    (
        "RBF 200 r=3e-9 d=4 p=9 centres kmeans++@4 ms h=4 stride 8 it 4",
        Some(0.441),
        Some(0.268),
        Some(2.62),
        Some(0.0155),
        "",
    ),
    (
        "RBF 300 r=1e-8 d=4 p=9 centres kmeans++@2 ms h=4 stride 8 it 4",
        Some(0.353),
        Some(0.213),
        Some(1.20),
        Some(0.0180),
        "",
    ),
    (
        "RBF 300 r=1e-8 d=4 p=9 centres random@3 ms h=4 stride 8 it 4",
        Some(0.323),
        Some(0.294),
        Some(2.20),
        Some(0.0068),
        "",
    ),
    (
        "RBF 150 r=1e-8 d=4 p=9 centres kmeans++@2 ms h=4 stride 8 it 4",
        Some(0.476),
        Some(0.317),
        Some(2.81),
        Some(0.0096),
        "",
    ),
    (
        "RBF 300 r=1e-8 d=4 p=9 centres random@1 ms h=4 stride 8 it 4",
        Some(0.165),
        Some(0.191),
        Some(1.20),
        Some(0.0209),
        "",
    ),
    ("RBF 200 r=3e-9 d=4 p=9 ms h=2 stride 8 it 4", Some(0.446), Some(0.262), Some(2.95), Some(0.0121), ""),
    (
        "RBF 300 r=1e-8 d=4 p=9 centres kmeans++@2 ms h=2 stride 8 it 4",
        Some(0.285),
        Some(0.259),
        Some(2.04),
        Some(0.0207),
        "",
    ),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@5", Some(0.364), Some(0.148), Some(2.09), Some(0.0383), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@5", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@5", Some(-0.018), Some(0.175), Some(2.69), Some(0.6052), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@6", Some(0.340), Some(0.200), Some(2.27), Some(0.0075), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@6", Some(0.077), Some(0.195), Some(2.66), Some(0.0073), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@6", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@7", Some(0.359), Some(0.174), Some(1.69), Some(0.0092), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@7", Some(0.454), Some(0.172), Some(1.76), Some(0.0066), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@7", None, Some(0.274), Some(2.09), Some(0.0089), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@8", Some(0.079), Some(0.181), Some(1.81), Some(0.0114), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@8", Some(0.440), Some(0.146), Some(2.57), Some(0.0147), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@8", Some(0.495), Some(0.387), Some(2.94), Some(0.0081), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@9", Some(0.382), Some(0.317), Some(3.20), Some(0.0061), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@9", Some(-0.127), Some(-0.015), Some(0.16), Some(0.7296), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@9", Some(0.000), Some(-0.009), Some(1.05), Some(0.5233), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@10", Some(0.374), Some(0.226), Some(2.45), Some(0.0145), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@10", Some(0.504), Some(0.139), Some(2.30), Some(0.0145), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@10", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@11", Some(0.434), Some(0.260), Some(3.10), Some(0.0129), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@11", Some(0.462), Some(0.231), Some(1.52), Some(0.0105), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@11", Some(0.459), Some(0.241), Some(2.50), Some(0.0109), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres farthest@12", Some(0.364), Some(0.171), Some(1.79), Some(0.0093), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres kmeans++@12", Some(0.445), Some(0.242), Some(3.02), Some(0.0175), ""),
    ("RBF 200 r=3e-9 d=4 p=9 centres random@12", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@5", Some(0.148), Some(0.139), Some(2.13), Some(0.0170), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@5", Some(0.284), Some(0.188), Some(1.59), Some(0.0142), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@5", Some(0.409), Some(0.271), Some(2.29), Some(0.0122), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@6", Some(0.207), Some(0.149), Some(2.12), Some(0.0161), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@6", Some(0.292), Some(0.191), Some(1.39), Some(0.0153), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@6", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@7", Some(0.220), Some(0.152), Some(2.23), Some(0.0133), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@7", Some(0.291), Some(0.154), Some(2.32), Some(0.0157), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@7", Some(0.435), Some(0.300), Some(3.33), Some(0.0134), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@8", Some(0.212), Some(0.165), Some(1.93), Some(0.0203), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@8", Some(0.239), Some(0.178), Some(1.22), Some(0.0247), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@8", Some(0.440), Some(0.201), Some(2.94), Some(0.0108), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@9", Some(0.258), Some(0.163), Some(2.98), Some(0.0124), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@9", Some(0.322), Some(0.201), Some(2.31), Some(0.0104), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@9", Some(0.377), Some(0.182), Some(2.61), Some(0.0070), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@10", Some(0.247), Some(0.190), Some(2.32), Some(0.0129), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@10", Some(0.300), Some(0.206), Some(1.81), Some(0.0124), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@10", Some(0.346), Some(0.161), Some(2.60), Some(0.0161), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@11", Some(0.306), Some(0.190), Some(2.40), Some(0.0151), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@11", Some(0.301), Some(0.168), Some(1.45), Some(0.0129), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@11", Some(0.379), Some(0.153), Some(2.72), Some(0.0121), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres farthest@12", Some(0.258), Some(0.181), Some(1.97), Some(0.0106), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres kmeans++@12", Some(0.274), Some(0.146), Some(2.34), Some(0.0160), ""),
    ("RBF 300 r=1e-8 d=4 p=9 centres random@12", None, Some(0.277), Some(2.88), Some(0.0190), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@5", Some(0.246), Some(0.216), Some(2.61), Some(0.0164), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@5", Some(0.399), Some(0.181), Some(2.34), Some(0.0185), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@5", Some(0.457), Some(0.260), Some(2.38), Some(0.0072), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@6", Some(0.275), Some(0.169), Some(2.18), Some(0.0150), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@6", Some(0.321), Some(0.191), Some(2.11), Some(0.0256), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@6", None, None, None, None, "escaped in the long run"),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@7", Some(0.264), Some(0.191), Some(1.44), Some(0.0156), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@7", Some(0.335), Some(0.117), Some(2.85), Some(0.0115), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@7", Some(0.449), Some(0.103), Some(3.09), Some(0.0150), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@8", Some(0.261), Some(0.195), Some(2.51), Some(0.0226), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@8", Some(0.215), Some(0.238), Some(1.79), Some(0.0335), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@8", Some(0.470), Some(0.207), Some(2.64), Some(0.0092), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@9", Some(0.263), Some(0.200), Some(2.61), Some(0.0075), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@9", Some(0.331), Some(0.176), Some(1.53), Some(0.0140), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@9", Some(0.408), Some(0.282), Some(2.65), Some(0.0094), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@10", Some(0.236), Some(0.328), Some(2.41), Some(0.0123), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@10", Some(0.383), Some(0.323), Some(2.38), Some(0.0154), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@10", None, None, None, None, "escaped in the long run"),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@11", Some(0.338), Some(0.171), Some(2.49), Some(0.0149), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@11", Some(0.293), Some(0.229), Some(2.51), Some(0.0125), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@11", Some(0.384), Some(0.155), Some(1.90), Some(0.0143), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres farthest@12", Some(0.305), Some(0.146), Some(1.67), Some(0.0104), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres kmeans++@12", Some(0.328), Some(0.177), Some(2.48), Some(0.0161), ""),
    ("RBF 250 r=1e-8 d=4 p=9 centres random@12", Some(0.460), Some(0.284), Some(2.28), Some(0.0100), ""),
    ("RBF 200 r=3e-9 d=5 p=11", Some(0.265), Some(0.203), Some(2.52), Some(0.0431), ""),
    ("RBF 200 r=3e-9 d=5 p=11 centres kmeans++@1", Some(-0.000), Some(-0.015), Some(1.07), Some(0.5012), ""),
    ("RBF 200 r=3e-9 d=5 p=11 centres random@1", Some(0.434), Some(0.215), Some(2.80), Some(0.0419), ""),
    ("RBF 200 r=3e-9 d=5 p=11 centres kmeans++@2", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=5 p=11 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=5 p=11 centres kmeans++@3", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=5 p=11 centres random@3", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=1e-8 d=5 p=11", Some(-0.070), Some(-0.067), None, Some(0.0711), ""),
    ("RBF 300 r=1e-8 d=5 p=11 centres kmeans++@1", Some(0.092), Some(0.077), Some(1.24), Some(0.0595), ""),
    ("RBF 300 r=1e-8 d=5 p=11 centres random@1", Some(-0.052), Some(0.023), Some(0.67), Some(0.0816), ""),
    ("RBF 300 r=1e-8 d=5 p=11 centres kmeans++@2", Some(-0.123), Some(-0.001), None, Some(0.0703), ""),
    ("RBF 300 r=1e-8 d=5 p=11 centres random@2", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=1e-8 d=5 p=11 centres kmeans++@3", Some(-0.015), Some(0.175), Some(1.75), Some(0.0472), ""),
    ("RBF 300 r=1e-8 d=5 p=11 centres random@3", Some(0.145), Some(0.145), Some(1.91), Some(0.0522), ""),
    ("RBF 200 r=3e-9 d=6 p=13", Some(0.237), Some(0.206), Some(2.04), Some(0.0442), ""),
    ("RBF 200 r=3e-9 d=6 p=13 centres kmeans++@1", Some(0.254), Some(0.159), Some(2.58), Some(0.0474), ""),
    ("RBF 200 r=3e-9 d=6 p=13 centres random@1", None, Some(0.182), Some(1.99), Some(0.0426), ""),
    ("RBF 200 r=3e-9 d=6 p=13 centres kmeans++@2", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=6 p=13 centres random@2", Some(-0.000), Some(0.002), Some(1.05), Some(0.3296), ""),
    ("RBF 200 r=3e-9 d=6 p=13 centres kmeans++@3", None, None, None, None, "escaped in the long run"),
    ("RBF 200 r=3e-9 d=6 p=13 centres random@3", Some(0.236), Some(0.165), Some(2.34), Some(0.0460), ""),
    ("RBF 300 r=1e-8 d=6 p=13", Some(-0.277), Some(-0.082), Some(0.01), Some(0.1034), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres kmeans++@1", Some(-0.067), Some(-0.052), Some(0.20), Some(0.0650), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres random@1", Some(0.186), Some(0.183), Some(1.85), Some(0.0488), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres kmeans++@2", Some(-0.048), Some(-0.034), Some(0.30), Some(0.0680), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres random@2", Some(0.103), Some(0.114), Some(1.96), Some(0.0532), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres kmeans++@3", Some(0.078), Some(0.061), Some(1.26), Some(0.0586), ""),
    ("RBF 300 r=1e-8 d=6 p=13 centres random@3", Some(0.105), Some(0.048), Some(1.03), Some(0.0537), ""),
    ("RBF 250 r=5e-9 d=4 p=9", Some(0.379), Some(0.194), Some(2.72), Some(0.0053), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@1", Some(0.406), Some(0.232), Some(3.01), Some(0.0089), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@1", None, Some(0.366), Some(3.47), Some(0.0113), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@2", Some(0.436), Some(0.272), Some(2.59), Some(0.0074), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@2", Some(0.400), Some(0.240), Some(2.70), Some(0.0073), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@3", Some(0.337), Some(0.157), Some(2.40), Some(0.0157), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@3", Some(0.422), Some(0.236), Some(2.66), Some(0.0070), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@4", Some(0.365), Some(0.223), Some(1.98), Some(0.0386), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@4", None, None, None, None, "escaped in the long run"),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@5", Some(0.421), Some(0.195), Some(2.01), Some(0.0380), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@5", Some(0.462), Some(0.376), Some(2.02), Some(0.0095), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres kmeans++@6", Some(0.436), Some(0.261), Some(2.48), Some(0.0191), ""),
    ("RBF 250 r=5e-9 d=4 p=9 centres random@6", None, None, None, None, "escaped in the long run"),
    ("RBF 300 r=5e-9 d=4 p=9", Some(0.283), Some(0.193), Some(2.46), Some(0.0055), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@1", Some(-0.026), Some(0.128), Some(1.22), Some(0.0270), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@1", Some(0.474), Some(0.348), Some(2.80), Some(0.0078), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@2", Some(0.414), Some(0.216), Some(2.43), Some(0.0104), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@2", Some(0.274), Some(0.139), Some(2.50), Some(0.0145), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@3", Some(0.337), Some(0.193), Some(2.30), Some(0.0100), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@3", Some(0.432), Some(0.311), Some(2.25), Some(0.0069), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@4", Some(0.322), Some(0.189), Some(2.40), Some(0.0430), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@4", Some(0.339), Some(0.349), Some(2.18), Some(0.0220), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@5", Some(0.353), Some(0.246), Some(2.53), Some(0.0217), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@5", Some(0.426), Some(0.192), Some(1.41), Some(0.0077), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres kmeans++@6", Some(0.366), Some(0.132), Some(2.64), Some(0.0103), ""),
    ("RBF 300 r=5e-9 d=4 p=9 centres random@6", None, None, None, None, "escaped in the long run"),
];

/// The validation pick ([`pick`] over [`FLAG_VALIDATION`] against [`FLAG_VALIDATION_DATA`]):
/// its validation row, and its committed test row ([`crate::flag_pipeline_fit::FLAG_CENTRES`]
/// against traj_8).
pub fn validation_pick() -> Option<(PipelineRow, PipelineRow)> {
    validation_pick_on(FLAG_VALIDATION, FLAG_VALIDATION_DATA)
}

/// [`validation_pick`] over the validation rows `rows` against `data`.
pub fn validation_pick_on(rows: &[FlagRow], data: DataRef) -> Option<(PipelineRow, PipelineRow)> {
    let val = rows_against(rows, data);
    let i = pick(&val)?;
    let test = crate::flag_pipeline_fit::flag_centre_rows().into_iter().find(|r| r.candidate == val[i].candidate)?;
    Some((val[i].clone(), test))
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

/// The ensemble of the five best validation-ranked d = 4 models ([`ensemble_members`]`(5)`,
/// example `flag_pipeline -- flag-ensemble 5`): JS of their pooled long runs against traj_8
/// (bits; the members' own: 0.0070, 0.0050, 0.0037, 0.0079, 0.0051, their committed rows).
pub const FLAG_ENSEMBLE: (usize, f64) = (5, 0.0037);

/// The first `k` rows of [`FLAG_VALIDATION`] in [`ranked`] order that have d = 4 and p = 9
/// (the members of [`ensemble`]).
pub fn ensemble_members(k: usize) -> Vec<&'static str> {
    let val = rows_against(FLAG_VALIDATION, FLAG_VALIDATION_DATA);
    ranked(&val).into_iter().map(|i| FLAG_VALIDATION[i].0).filter(|n| n.contains(" d=4 p=9")).take(k).collect()
}

#[cfg(test)]
mod tests;
