//! Fits that choose their own settings ([`select`]) and say how sure they are
//! ([`intervals`]).
//!
//! # Selection
//! * The SSM dimension comes from the singular-value spectrum of the delay-embedded data
//!   ([`choose_dim`]): the largest ratio `s_k / s_{k+1}` for `k = 1..=max_dim` (an
//!   oscillatory mode is a pair of nearly equal singular values followed by a drop).
//! * The other settings (transient cut at each trajectory's start, delay-embedding size and
//!   shift, manifold order, reduced-dynamics order, ridge, joint linear anchor or none) are
//!   chosen by cross-validation: leave one trajectory out, or with a single trajectory
//!   blocked splits in time (each block held out in turn, the rest trained on as separate
//!   pieces). Every candidate is scored on the same held-out data (held-out pieces cut at
//!   the largest candidate cut, so cuts are compared on equal terms) by
//!   `score = mean held-out NMTE x (1 + spread)`, where `spread` is the largest relative
//!   spread across folds of an eigenvalue's real part (std over folds / |mean|): a linear
//!   part that moves from fold to fold is penalized.
//! * The search is coordinate descent over [`AutoGrid`] from its first values: each knob in
//!   turn tries all its values with the others fixed at the current best, sweeps repeat until
//!   nothing improves; at most [`AutoOptions::budget`] distinct settings are scored.
//!   [`exhaustive`] scores the whole grid the same way (the reference of the tests).
//! * Deterministic for any thread count: candidates of one step are scored in parallel
//!   but collected in order, ties go to the earlier candidate, the budget counts settings
//!   (not seconds).
//!
//! # Intervals
//! Bootstrap: the fit is repeated on resampled data and the central `level` range of each
//! eigenvalue's real and imaginary part, damping ratio, and of the backbone curves
//! (frequency and damping at fixed amplitudes) is reported. The data are resampled as
//! * whole trajectories drawn with replacement when there are at least
//!   [`MIN_TRAJ_BOOTSTRAP`] (percentile intervals);
//! * with two or three, segments of the trajectories (blocks after the transient) drawn with
//!   replacement (percentile intervals);
//! * a lone trajectory by its residuals: the fitted model's prediction of the trajectory
//!   plus its residuals (data minus prediction) drawn with replacement in blocks of the
//!   embedding's span plus one sample (a model-based residual bootstrap, the whole fit
//!   repeated on each synthetic trajectory). Its replicates come from the fitted model, so
//!   they carry the estimator's bias once more: the intervals are basic ones,
//!   `[2 est - q_hi, 2 est - q_lo]`, which take that bias out.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::backbone::{Backbone, BackboneError, BackboneOptions, backbone};
use crate::data::{DataError, MultiSeries, check_same_observables};
use crate::dynamics::Dynamics;
use crate::embed::delay_embed_multi;
use crate::error::FitError;
use crate::fit::{FitOptions, SsmModel, fit_multi};
use crate::ridge::Ridge;

/// Fewest trajectories for the trajectory bootstrap; with fewer, segments are resampled.
pub const MIN_TRAJ_BOOTSTRAP: usize = 4;
/// Fewest embedded points of every training piece and held-out piece.
const MIN_POINTS: usize = 16;

/// What [`select`] and [`intervals`] refuse or fail at.
#[derive(Debug, thiserror::Error)]
pub enum AutoError {
    #[error(transparent)]
    Fit(#[from] FitError),
    #[error(transparent)]
    Data(#[from] DataError),
    #[error("auto option {what}: {why}")]
    BadOption { what: &'static str, why: String },
    #[error("too little data for {what}: {why}")]
    TooLittleData { what: &'static str, why: String },
    #[error("no candidate setting could be fitted and scored on every fold (first failure: {0})")]
    NoCandidate(String),
    #[error(
        "bootstrap: only {ok} of {total} replicates could be fitted{what} (first failure: {first}); the estimate is too fragile for an interval"
    )]
    Bootstrap { ok: usize, total: usize, what: String, first: String },
    #[error(transparent)]
    Backbone(#[from] BackboneError),
}

/// The values [`select`] may choose from; the first value of each list is the start of the
/// search.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AutoGrid {
    /// Fraction of each trajectory's samples dropped at its start (in `[0, 0.5)`).
    pub cuts: Vec<f64>,
    /// Delay-embedding copies above the fewest Takens allows (`q p > 2 d`).
    pub embed_extra: Vec<usize>,
    /// Delay-embedding shifts, in samples.
    pub shifts: Vec<usize>,
    pub manifold_orders: Vec<u32>,
    pub dyn_orders: Vec<u32>,
    /// Relative ridge parameters ([`Ridge::Fixed`]).
    pub ridges: Vec<f64>,
    /// Joint linear anchors (`None`: no anchor); see [`FitOptions::anchor_joint`].
    pub anchors: Vec<Option<f64>>,
}

impl Default for AutoGrid {
    fn default() -> Self {
        AutoGrid {
            cuts: vec![0.0, 0.05, 0.15],
            embed_extra: vec![0, 2, 4],
            shifts: vec![1, 2, 4],
            manifold_orders: vec![3, 1, 5],
            dyn_orders: vec![5, 3, 7],
            ridges: vec![0.0, 1e-8, 1e-5],
            anchors: vec![None, Some(0.1), Some(0.3)],
        }
    }
}

/// Knob names, in the order of [`AutoGrid`]'s lists.
pub const KNOBS: [&str; 7] = ["cut", "embed", "shift", "manifold_order", "dyn_order", "ridge", "anchor"];

impl AutoGrid {
    fn sizes(&self) -> [usize; 7] {
        [
            self.cuts.len(),
            self.embed_extra.len(),
            self.shifts.len(),
            self.manifold_orders.len(),
            self.dyn_orders.len(),
            self.ridges.len(),
            self.anchors.len(),
        ]
    }

    /// Number of settings in the whole grid.
    pub fn size(&self) -> usize {
        self.sizes().iter().product()
    }

    fn validate(&self) -> Result<(), AutoError> {
        for (k, n) in KNOBS.iter().zip(self.sizes()) {
            if n == 0 {
                return Err(AutoError::BadOption { what: "grid", why: format!("no value for `{k}`") });
            }
        }
        if let Some(c) = self.cuts.iter().find(|c| !(**c >= 0.0 && **c < 0.5)) {
            return Err(AutoError::BadOption { what: "grid.cuts", why: format!("{c} is not in [0, 0.5)") });
        }
        if let Some(r) = self.ridges.iter().find(|r| !(r.is_finite() && **r >= 0.0)) {
            return Err(AutoError::BadOption { what: "grid.ridges", why: format!("{r} is not a number >= 0") });
        }
        Ok(())
    }

    fn setting(&self, idx: [usize; 7], dim: usize, q: usize, dynamics: Dynamics) -> Setting {
        let p_min = 2 * dim / q + 1;
        let anchor = self.anchors[idx[6]];
        Setting {
            cut: self.cuts[idx[0]],
            options: FitOptions {
                dim,
                embed: p_min + self.embed_extra[idx[1]],
                shift: self.shifts[idx[2]],
                manifold_order: self.manifold_orders[idx[3]],
                dyn_order: self.dyn_orders[idx[4]],
                dynamics,
                ridge: Ridge::Fixed(self.ridges[idx[5]]),
                linear_anchor: anchor,
                anchor_joint: anchor.is_some(),
            },
        }
    }

    fn value(&self, knob: usize, i: usize) -> String {
        match knob {
            0 => format!("{}", self.cuts[i]),
            1 => format!("+{}", self.embed_extra[i]),
            2 => format!("{}", self.shifts[i]),
            3 => format!("{}", self.manifold_orders[i]),
            4 => format!("{}", self.dyn_orders[i]),
            5 => format!("{:e}", self.ridges[i]),
            _ => self.anchors[i].map_or("off".into(), |a| format!("{a}")),
        }
    }
}

/// Options of [`select`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AutoOptions {
    /// Kind of reduced dynamics (polynomial flow or map).
    pub dynamics: Dynamics,
    /// Largest SSM dimension considered by [`choose_dim`].
    pub max_dim: usize,
    /// A fixed SSM dimension instead of [`choose_dim`]'s.
    pub dim: Option<usize>,
    /// Blocks in time of a single trajectory (its folds).
    pub blocks: usize,
    /// Most distinct settings scored (each costs one fit per fold).
    pub budget: usize,
    pub grid: AutoGrid,
}

impl Default for AutoOptions {
    fn default() -> Self {
        AutoOptions { dynamics: Dynamics::Map, max_dim: 4, dim: None, blocks: 3, budget: 40, grid: AutoGrid::default() }
    }
}

/// A setting: the fit options and the transient cut.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Setting {
    /// Fraction of each trajectory's samples dropped at its start.
    pub cut: f64,
    pub options: FitOptions,
}

impl Setting {
    /// One line: `cut 0.05, p 5, shift 1, manifold 3, map 5, ridge 0, anchor off`.
    pub fn describe(&self) -> String {
        let o = &self.options;
        let kind = match o.dynamics {
            Dynamics::Flow => "flow",
            Dynamics::Map => "map",
            _ => "rbf",
        };
        let ridge = match o.ridge {
            Ridge::Fixed(a) => format!("{a:e}"),
            Ridge::CrossValidated => "cv".into(),
        };
        format!(
            "dim {}, cut {:.0} %, embed {}, shift {}, manifold order {}, {kind} order {}, ridge {ridge}, anchor {}",
            o.dim,
            100.0 * self.cut,
            o.embed,
            o.shift,
            o.manifold_order,
            o.dyn_order,
            o.linear_anchor.map_or("off".into(), |a| format!("{a} (joint)"))
        )
    }
}

/// One scored setting.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Scored {
    pub setting: Setting,
    /// Grid indices of the setting (see [`KNOBS`]).
    pub index: [usize; 7],
    /// Held-out NMTE of each fold (infinite when the fold failed or its prediction stopped).
    pub nmte_folds: Vec<f64>,
    /// Mean of `nmte_folds`.
    pub nmte: f64,
    /// Largest relative spread across folds of an eigenvalue's real part.
    pub spread: f64,
    /// `nmte x (1 + spread)`; lower is better, infinite when any fold failed.
    pub score: f64,
    /// Why a fold failed.
    pub failure: Option<String>,
}

/// The SSM dimension from the singular values.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DimChoice {
    pub dim: usize,
    /// Singular values of the delay-embedded data, largest first.
    pub singular_values: Vec<f64>,
    /// `s_dim / s_{dim+1}`.
    pub gap: f64,
    /// How it was chosen.
    pub method: String,
}

/// What [`select`] chose, and why.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct AutoChoice {
    pub dim: DimChoice,
    pub best: Scored,
    pub runner_up: Option<Scored>,
    /// How the folds were made: `leave one trajectory out (3 folds)` or `3 blocks in time`.
    pub folds: String,
    /// Settings scored.
    pub evaluated: usize,
    /// Whether the budget stopped the search before it converged.
    pub budget_exhausted: bool,
    /// One line per knob: the score of each value with the others at the choice.
    pub reasons: Vec<String>,
}

/// The SSM dimension: the `k` in `1..=max_dim` with the largest `s_k / s_{k+1}` of the
/// singular values of the data delay-embedded with shift 1 and enough copies for
/// `2 max_dim + 1` coordinates.
pub fn choose_dim(train: &[MultiSeries], max_dim: usize) -> Result<DimChoice, AutoError> {
    let first = train.first().ok_or(FitError::NoTrainingData)?;
    if max_dim == 0 || max_dim > crate::limits::MAX_DIM {
        return Err(AutoError::BadOption {
            what: "max_dim",
            why: format!("{max_dim} is not in 1..={}", crate::limits::MAX_DIM),
        });
    }
    let q = first.dim();
    let copies = (2 * max_dim + 1).div_ceil(q) + 1;
    let ys = train.iter().map(|t| delay_embed_multi(t, copies, 1, MIN_POINTS)).collect::<Result<Vec<_>, _>>()?;
    let (_, s) = crate::manifold::tangent_space(&ys, 1)?;
    let top = max_dim.min(s.len().saturating_sub(1));
    let mut best = (0, f64::NEG_INFINITY);
    for k in 1..=top {
        let r = if s[k] > 0.0 { s[k - 1] / s[k] } else { f64::INFINITY };
        if r > best.1 {
            best = (k, r);
        }
    }
    if best.0 == 0 {
        return Err(AutoError::TooLittleData {
            what: "the SSM dimension",
            why: format!("{} singular values, need at least 2", s.len()),
        });
    }
    Ok(DimChoice {
        dim: best.0,
        singular_values: s,
        gap: best.1,
        method: format!(
            "singular-value spectrum of the delay embedding ({copies} copies, shift 1): largest ratio s_k/s_(k+1) for k <= {max_dim}"
        ),
    })
}

/// A piece of a trajectory used for training: `at_start` when it begins where the
/// trajectory begins (the transient cut applies), `full` the trajectory's length.
#[derive(Clone, Debug)]
struct Piece {
    series: MultiSeries,
    at_start: bool,
    full: usize,
}

#[derive(Clone, Debug)]
struct Fold {
    train: Vec<Piece>,
    test: MultiSeries,
}

/// Samples `a..b` of `t` as a trajectory named `name`.
fn slice(t: &MultiSeries, a: usize, b: usize, name: String) -> MultiSeries {
    let q = t.dim();
    MultiSeries { name, t: t.t[a..b].to_vec(), observables: t.observables.clone(), x: t.x[a * q..b * q].to_vec() }
}

fn cut_len(full: usize, cut: f64) -> usize {
    (cut * full as f64).round() as usize
}

/// The trajectories without the first `cut` fraction of each one's samples (a
/// [`Setting::cut`]).
pub fn cut(train: &[MultiSeries], cut: f64) -> Vec<MultiSeries> {
    train
        .iter()
        .map(|t| {
            let c = cut_len(t.len(), cut).min(t.len());
            slice(t, c, t.len(), t.name.clone())
        })
        .collect()
}

impl Piece {
    fn cut(&self, cut: f64) -> MultiSeries {
        if !self.at_start {
            return self.series.clone();
        }
        let c = cut_len(self.full, cut).min(self.series.len());
        slice(&self.series, c, self.series.len(), self.series.name.clone())
    }
}

/// The folds: leave one trajectory out, or `blocks` blocks of a single trajectory; checks
/// that every piece is long enough for the grid's largest embedding span after the largest
/// cut.
fn make_folds(train: &[MultiSeries], o: &AutoOptions, span: usize) -> Result<(Vec<Fold>, String), AutoError> {
    let max_cut = o.grid.cuts.iter().copied().fold(0.0, f64::max);
    let need = span + MIN_POINTS;
    let short = |name: &str, have: usize, role: &str| AutoError::TooLittleData {
        what: "the cross-validation folds",
        why: format!(
            "{name}: {have} samples as {role}, need at least {need} (the largest embedding span {span} + {MIN_POINTS} points) after the largest transient cut {:.0} %; give longer or more trajectories, or a smaller grid",
            100.0 * max_cut
        ),
    };
    if train.len() >= 2 {
        let mut folds = Vec::new();
        for (i, held) in train.iter().enumerate() {
            let c = cut_len(held.len(), max_cut);
            if held.len() - c.min(held.len()) < need {
                return Err(short(&held.name, held.len() - c.min(held.len()), "held-out trajectory"));
            }
            let test = slice(held, c, held.len(), held.name.clone());
            let pieces = train
                .iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, t)| Piece { series: t.clone(), at_start: true, full: t.len() })
                .collect();
            folds.push(Fold { train: pieces, test });
        }
        return Ok((folds, format!("leave one trajectory out ({} folds)", train.len())));
    }
    let t = &train[0];
    let k = o.blocks;
    if k < 2 {
        return Err(AutoError::BadOption {
            what: "blocks",
            why: format!("{k}: a single trajectory needs >= 2 blocks"),
        });
    }
    let n = t.len();
    let c = cut_len(n, max_cut);
    let bounds: Vec<usize> = (0..=k).map(|i| i * n / k).collect();
    for i in 0..k {
        let (a, b) = (bounds[i], bounds[i + 1]);
        let usable = if i == 0 { b.saturating_sub(c.max(a)) } else { b - a };
        if usable < need {
            return Err(short(&format!("{} block {} of {k}", t.name, i + 1), usable, "a block in time"));
        }
    }
    let mut folds = Vec::new();
    for i in 0..k {
        let (a, b) = (bounds[i], bounds[i + 1]);
        let test = slice(t, if i == 0 { c } else { a }, b, format!("{} block {}", t.name, i + 1));
        let mut pieces = Vec::new();
        if a > 0 {
            pieces.push(Piece {
                series: slice(t, 0, a, format!("{} before block {}", t.name, i + 1)),
                at_start: true,
                full: n,
            });
        }
        if b < n {
            pieces.push(Piece {
                series: slice(t, b, n, format!("{} after block {}", t.name, i + 1)),
                at_start: false,
                full: n,
            });
        }
        folds.push(Fold { train: pieces, test });
    }
    Ok((folds, format!("{k} blocks in time of the single trajectory")))
}

/// Eigenvalues sorted by decreasing imaginary part, then real part (a fixed order across
/// fits: modes by frequency, conjugates apart).
fn sorted_eigs(m: &SsmModel) -> Vec<(f64, f64)> {
    let mut e = m.eigenvalues_ct().to_vec();
    e.sort_by(|a, b| b.1.total_cmp(&a.1).then(b.0.total_cmp(&a.0)));
    e
}

fn score_setting(folds: &[Fold], setting: Setting, index: [usize; 7]) -> Scored {
    let mut nmte_folds = Vec::with_capacity(folds.len());
    let mut eigs: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut failure = None;
    for (f, fold) in folds.iter().enumerate() {
        let train: Vec<MultiSeries> = fold.train.iter().map(|p| p.cut(setting.cut)).collect();
        let r = fit_multi(&train, &setting.options).and_then(|m| {
            let p = m.predict_multi(&fold.test)?;
            Ok((p.nmte_multi(&fold.test), p.stop.is_some(), sorted_eigs(&m)))
        });
        match r {
            Ok((e, stopped, ev)) => {
                if stopped && failure.is_none() {
                    failure = Some(format!("fold {}: the held-out prediction of {} blew up", f + 1, fold.test.name));
                }
                nmte_folds.push(e);
                eigs.push(ev);
            }
            Err(e) => {
                if failure.is_none() {
                    failure = Some(format!("fold {}: {e}", f + 1));
                }
                nmte_folds.push(f64::INFINITY);
            }
        }
    }
    let nmte = nmte_folds.iter().sum::<f64>() / nmte_folds.len().max(1) as f64;
    let spread = if eigs.len() == folds.len() && eigs.len() >= 2 {
        let d = eigs[0].len();
        (0..d)
            .map(|j| {
                let re: Vec<f64> = eigs.iter().map(|e| e[j].0).collect();
                let (m, s) = mean_std(&re);
                if m == 0.0 { f64::INFINITY } else { s / m.abs() }
            })
            .fold(0.0, f64::max)
    } else {
        f64::INFINITY
    };
    let score = if nmte.is_finite() && spread.is_finite() { nmte * (1.0 + spread) } else { f64::INFINITY };
    Scored { setting, index, nmte_folds, nmte, spread, score, failure }
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, var.sqrt())
}

/// Validated inputs of [`select`] and [`exhaustive`]: the dimension and the folds.
struct Prepared {
    dim: DimChoice,
    folds: Vec<Fold>,
    fold_kind: String,
    q: usize,
}

fn prepare(train: &[MultiSeries], o: &AutoOptions) -> Result<Prepared, AutoError> {
    if train.is_empty() {
        return Err(FitError::NoTrainingData.into());
    }
    for t in train {
        t.validate()?;
    }
    check_same_observables(train, false)?;
    o.grid.validate()?;
    if o.budget == 0 {
        return Err(AutoError::BadOption { what: "budget", why: "must be >= 1 setting".into() });
    }
    if !matches!(o.dynamics, Dynamics::Flow | Dynamics::Map) {
        return Err(AutoError::BadOption {
            what: "dynamics",
            why: "auto selection fits polynomial flows or maps".into(),
        });
    }
    let q = train[0].dim();
    let dim = match o.dim {
        Some(d) => DimChoice { dim: d, singular_values: Vec::new(), gap: f64::NAN, method: "given".into() },
        None => choose_dim(train, o.max_dim)?,
    };
    let p_max = 2 * dim.dim / q + 1 + o.grid.embed_extra.iter().copied().max().unwrap_or(0);
    let s_max = o.grid.shifts.iter().copied().max().unwrap_or(1);
    let span = (p_max - 1) * s_max;
    let (folds, fold_kind) = make_folds(train, o, span)?;
    Ok(Prepared { dim, folds, fold_kind, q })
}

fn best_of(scored: &[Scored]) -> Option<&Scored> {
    let mut best: Option<&Scored> = None;
    for s in scored {
        if best.is_none_or(|b| s.score < b.score) {
            best = Some(s);
        }
    }
    best
}

/// Chooses the settings by cross-validation (see the module docs).
pub fn select(train: &[MultiSeries], o: &AutoOptions) -> Result<AutoChoice, AutoError> {
    let pr = prepare(train, o)?;
    let sizes = o.grid.sizes();
    let mut memo: Vec<Scored> = Vec::new();
    let mut exhausted = false;
    let mut current = [0usize; 7];
    let eval = |cands: Vec<[usize; 7]>| -> Vec<Scored> {
        cands
            .into_par_iter()
            .map(|idx| score_setting(&pr.folds, o.grid.setting(idx, pr.dim.dim, pr.q, o.dynamics), idx))
            .collect()
    };
    memo.extend(eval(vec![current]));
    'sweeps: loop {
        let before = current;
        for knob in 0..7 {
            let mut cands = Vec::new();
            for v in 0..sizes[knob] {
                let mut idx = current;
                idx[knob] = v;
                if !memo.iter().any(|s| s.index == idx) && !cands.contains(&idx) {
                    cands.push(idx);
                }
            }
            let room = o.budget.saturating_sub(memo.len());
            if cands.len() > room {
                cands.truncate(room);
                exhausted = true;
            }
            memo.extend(eval(cands));
            if let Some(b) = best_of(&memo) {
                current = b.index;
            }
            if exhausted {
                break 'sweeps;
            }
        }
        if current == before {
            break;
        }
    }
    let best = best_of(&memo).cloned().ok_or_else(|| AutoError::NoCandidate("nothing scored".into()))?;
    if !best.score.is_finite() {
        return Err(AutoError::NoCandidate(best.failure.unwrap_or_else(|| "infinite score".into())));
    }
    let runner_up = best_of(&memo.iter().filter(|s| s.index != best.index).cloned().collect::<Vec<_>>())
        .filter(|s| s.score.is_finite())
        .cloned();
    let reasons = reasons(&o.grid, &pr.dim, &best, runner_up.as_ref(), &memo);
    Ok(AutoChoice {
        dim: pr.dim,
        best,
        runner_up,
        folds: pr.fold_kind,
        evaluated: memo.len(),
        budget_exhausted: exhausted,
        reasons,
    })
}

/// Scores every setting of the grid (the dimension as [`select`] chooses it); returns them
/// in grid order and the index of the best.
pub fn exhaustive(train: &[MultiSeries], o: &AutoOptions) -> Result<(Vec<Scored>, usize), AutoError> {
    let pr = prepare(train, o)?;
    let sizes = o.grid.sizes();
    let mut all = Vec::with_capacity(o.grid.size());
    for i0 in 0..sizes[0] {
        for i1 in 0..sizes[1] {
            for i2 in 0..sizes[2] {
                for i3 in 0..sizes[3] {
                    for i4 in 0..sizes[4] {
                        for i5 in 0..sizes[5] {
                            for i6 in 0..sizes[6] {
                                all.push([i0, i1, i2, i3, i4, i5, i6]);
                            }
                        }
                    }
                }
            }
        }
    }
    let scored: Vec<Scored> = all
        .into_par_iter()
        .map(|idx| score_setting(&pr.folds, o.grid.setting(idx, pr.dim.dim, pr.q, o.dynamics), idx))
        .collect();
    let best = best_of(&scored).map(|b| b.index).ok_or_else(|| AutoError::NoCandidate("empty grid".into()))?;
    let at = scored.iter().position(|s| s.index == best).unwrap_or(0);
    if !scored[at].score.is_finite() {
        return Err(AutoError::NoCandidate(scored[at].failure.clone().unwrap_or_default()));
    }
    Ok((scored, at))
}

fn fmt_score(s: f64) -> String {
    if s.is_finite() { format!("{s:.4}") } else { "failed".into() }
}

fn reasons(grid: &AutoGrid, dim: &DimChoice, best: &Scored, runner: Option<&Scored>, memo: &[Scored]) -> Vec<String> {
    let mut out = Vec::new();
    if dim.singular_values.is_empty() {
        out.push(format!("dimension {}: given", dim.dim));
    } else {
        let sv: Vec<String> = dim.singular_values.iter().take(dim.dim + 3).map(|s| format!("{s:.3e}")).collect();
        out.push(format!(
            "dimension {}: singular values {} ...; s_{}/s_{} = {:.1} is the largest gap",
            dim.dim,
            sv.join(", "),
            dim.dim,
            dim.dim + 1,
            dim.gap
        ));
    }
    out.push(format!(
        "chosen: score {} = held-out NMTE {} x (1 + eigenvalue spread {:.3})",
        fmt_score(best.score),
        fmt_score(best.nmte),
        best.spread
    ));
    if let Some(r) = runner {
        let differs: Vec<String> = (0..7)
            .filter(|&k| r.index[k] != best.index[k])
            .map(|k| format!("{} {} instead of {}", KNOBS[k], grid.value(k, r.index[k]), grid.value(k, best.index[k])))
            .collect();
        out.push(format!(
            "runner-up ({}): score {} (NMTE {}, spread {:.3}), {:.1} % worse",
            differs.join(", "),
            fmt_score(r.score),
            fmt_score(r.nmte),
            r.spread,
            100.0 * (r.score / best.score - 1.0)
        ));
    }
    for (k, knob) in KNOBS.iter().enumerate() {
        let mut vals = Vec::new();
        for s in memo {
            if (0..7).all(|j| j == k || s.index[j] == best.index[j]) {
                vals.push((s.index[k], s.score));
            }
        }
        vals.sort_by_key(|v| v.0);
        if vals.len() > 1 {
            let list: Vec<String> =
                vals.iter().map(|(i, sc)| format!("{} -> {}", grid.value(k, *i), fmt_score(*sc))).collect();
            out.push(format!("{knob}: {}", list.join(", ")));
        }
    }
    out
}

// ------------------------------------------------------------------------ intervals

/// Options of [`intervals`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IntervalOptions {
    /// Bootstrap replicates.
    pub replicates: usize,
    /// Coverage of the intervals (0.95: from the 2.5 % to the 97.5 % percentile).
    pub level: f64,
    /// Seed of the resampling (the result is the same for any thread count).
    pub seed: u64,
    /// Segments per trajectory for the segment bootstrap: the trajectories are cut into
    /// about `segments / trajectories` blocks each (at least 2).
    pub segments: usize,
    /// Backbone bands: the curves' options and the number of amplitudes of the bands.
    pub backbone: Option<(BackboneOptions, usize)>,
    /// Block length, in samples, of the residual bootstrap of a lone trajectory (`None`:
    /// the delay embedding's span plus one, so residuals within one embedded point stay
    /// together).
    pub residual_block: Option<usize>,
}

impl Default for IntervalOptions {
    fn default() -> Self {
        IntervalOptions { replicates: 200, level: 0.95, seed: 1, segments: 8, backbone: None, residual_block: None }
    }
}

/// A point estimate and its interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    pub estimate: f64,
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    /// Whether `v` lies in `[lo, hi]`.
    pub fn contains(&self, v: f64) -> bool {
        self.lo <= v && v <= self.hi
    }

    /// `hi - lo`.
    pub fn width(&self) -> f64 {
        self.hi - self.lo
    }
}

/// Intervals of one continuous-time eigenvalue.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EigenInterval {
    pub re: Interval,
    pub im: Interval,
    /// `-re / |lambda|`.
    pub damping_ratio: Interval,
}

/// A backbone curve as a band: frequency and damping ratio at fixed amplitudes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BackboneBand {
    pub mode: usize,
    pub observable: usize,
    pub amplitude: Vec<f64>,
    pub freq_rad_s: Vec<Interval>,
    pub damping_ratio: Vec<Interval>,
}

/// What [`intervals`] found.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Intervals {
    /// `trajectories` or `segments (N blocks)`.
    pub method: String,
    pub level: f64,
    pub replicates: usize,
    /// Replicates whose fit failed (left out of the eigenvalue intervals).
    pub failed: usize,
    /// Replicates whose backbone failed (left out of the bands).
    pub backbone_failed: usize,
    /// Sorted by decreasing imaginary part (modes by frequency, conjugates apart).
    pub eigenvalues: Vec<EigenInterval>,
    pub backbone: Vec<BackboneBand>,
}

/// The `p` quantile of sorted `v` (linear interpolation).
fn quantile(v: &[f64], p: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let h = p * (v.len() - 1) as f64;
    let (i, f) = (h.floor() as usize, h - h.floor());
    let j = (i + 1).min(v.len() - 1);
    v[i] + f * (v[j] - v[i])
}

/// The percentile interval of the replicates `v`, or with `basic` the basic (reverse
/// percentile) interval `[2 est - q_hi, 2 est - q_lo]`, which removes the bias the
/// replicates add to the estimate once more when they are simulated from the fitted model.
fn interval(estimate: f64, mut v: Vec<f64>, level: f64, basic: bool) -> Interval {
    v.sort_by(f64::total_cmp);
    let a = (1.0 - level) / 2.0;
    let (lo, hi) = (quantile(&v, a), quantile(&v, 1.0 - a));
    if basic {
        Interval { estimate, lo: 2.0 * estimate - hi, hi: 2.0 * estimate - lo }
    } else {
        Interval { estimate, lo, hi }
    }
}

/// The curve's frequency and damping at `amp` (linear between its points; `None` beyond).
fn at_amplitude(b: &Backbone, amp: f64) -> Option<(f64, f64)> {
    let pts = &b.points;
    if let Some(p0) = pts.first().filter(|p0| amp <= p0.amplitude) {
        return Some((p0.freq_rad_s, p0.damping_ratio));
    }
    for w in pts.windows(2) {
        let (a, c) = (&w[0], &w[1]);
        if amp >= a.amplitude && amp <= c.amplitude && c.amplitude > a.amplitude {
            let f = (amp - a.amplitude) / (c.amplitude - a.amplitude);
            return Some((
                a.freq_rad_s + f * (c.freq_rad_s - a.freq_rad_s),
                a.damping_ratio + f * (c.damping_ratio - a.damping_ratio),
            ));
        }
    }
    None
}

/// How the bootstrap resamples.
enum Scheme {
    /// Whole trajectories or blocks of them, drawn with replacement.
    Units(Vec<MultiSeries>),
    /// A lone trajectory: its fitted model's prediction plus blocks of `block` of its
    /// residuals, each from a random place (drawn with replacement).
    Residual { base: MultiSeries, pred: Vec<f64>, resid: Vec<f64>, block: usize },
}

/// Resampling of `train` (already cut): whole trajectories when there are enough, blocks
/// of them with two or three, the residuals of `model` with a single one.
fn scheme(
    train: &[MultiSeries],
    model: &SsmModel,
    setting: &Setting,
    o: &IntervalOptions,
) -> Result<(Scheme, String), AutoError> {
    let cut = train;
    if cut.len() >= MIN_TRAJ_BOOTSTRAP {
        let n = cut.len();
        return Ok((Scheme::Units(cut.to_vec()), format!("trajectories ({n} drawn with replacement)")));
    }
    let span = (setting.options.embed - 1) * setting.options.shift;
    let need = span + 2 * MIN_POINTS;
    if let [t] = cut {
        // As much data as the segment bootstrap asks of several trajectories together.
        let need_lone = MIN_TRAJ_BOOTSTRAP * need;
        if t.len() < need_lone {
            return Err(AutoError::TooLittleData {
                what: "the residual bootstrap",
                why: format!(
                    "{}: {} samples after the cut, need at least {need_lone} ({MIN_TRAJ_BOOTSTRAP} x (embedding span {span} + {})) for an interval from a lone trajectory",
                    t.name,
                    t.len(),
                    2 * MIN_POINTS
                ),
            });
        }
        let p = model.predict_multi(t)?;
        if let Some(s) = &p.stop {
            return Err(AutoError::TooLittleData {
                what: "the residual bootstrap",
                why: format!(
                    "{}: the fitted model's prediction stops at t = {} ({:?}), so it has no residuals to resample; choose other settings",
                    t.name, s.t, s.reason
                ),
            });
        }
        let resid: Vec<f64> = t.x.iter().zip(&p.x).map(|(a, b)| a - b).collect();
        let block = o.residual_block.unwrap_or(span + 1);
        let method = format!(
            "residuals (a lone trajectory: its fitted model's prediction plus its residuals drawn with replacement in blocks of {block} samples; basic intervals)"
        );
        return Ok((Scheme::Residual { base: t.clone(), pred: p.x, resid, block }, method));
    }
    let per = o.segments.div_ceil(cut.len()).max(2);
    let mut out = Vec::new();
    for t in cut {
        let k = per.min(t.len() / need);
        if k < 1 {
            return Err(AutoError::TooLittleData {
                what: "the segment bootstrap",
                why: format!("{}: {} samples after the cut, need at least {need} for one segment", t.name, t.len()),
            });
        }
        for i in 0..k {
            let (a, b) = (i * t.len() / k, (i + 1) * t.len() / k);
            out.push(slice(t, a, b, format!("{} segment {}", t.name, i + 1)));
        }
    }
    if out.len() < MIN_TRAJ_BOOTSTRAP {
        return Err(AutoError::TooLittleData {
            what: "the segment bootstrap",
            why: format!(
                "{} segments of at least {need} samples, need {MIN_TRAJ_BOOTSTRAP}; give longer or more trajectories",
                out.len()
            ),
        });
    }
    let n = out.len();
    Ok((Scheme::Units(out), format!("segments ({n} blocks of the trajectories drawn with replacement)")))
}

impl Scheme {
    /// The data of one replicate.
    fn draw(&self, rng: &mut ChaCha8Rng) -> Vec<MultiSeries> {
        match self {
            Scheme::Units(units) => {
                let n = units.len();
                (0..n).map(|_| units[rng.random_range(0..n)].clone()).collect()
            }
            Scheme::Residual { base, pred, resid, block } => {
                let q = base.dim();
                let n = base.len();
                let l = (*block).min(n);
                let mut x = pred.clone();
                for chunk in x.chunks_mut(l * q) {
                    let s = rng.random_range(0..=n - l) * q;
                    for (v, r) in chunk.iter_mut().zip(&resid[s..]) {
                        *v += r;
                    }
                }
                vec![MultiSeries { x, ..base.clone() }]
            }
        }
    }
}

/// One bootstrap replicate: its sorted eigenvalues and, if asked, its backbone curves.
type Replicate = (Vec<(f64, f64)>, Option<Result<Vec<Backbone>, String>>);

/// Bootstrap intervals of the fit of `train` with `setting` (see the module docs).
pub fn intervals(train: &[MultiSeries], setting: &Setting, o: &IntervalOptions) -> Result<Intervals, AutoError> {
    if o.replicates < 20 {
        return Err(AutoError::BadOption { what: "replicates", why: format!("{}: need at least 20", o.replicates) });
    }
    if !(o.level > 0.0 && o.level < 1.0) {
        return Err(AutoError::BadOption { what: "level", why: format!("{} is not in (0, 1)", o.level) });
    }
    if o.residual_block == Some(0) {
        return Err(AutoError::BadOption { what: "residual_block", why: "0 samples: need at least 1".into() });
    }
    let full = cut(train, setting.cut);
    let model = fit_multi(&full, &setting.options)?;
    let est_eigs = sorted_eigs(&model);
    let est_bb = match &o.backbone {
        Some((bo, _)) => Some(backbone(&model, bo)?),
        None => None,
    };
    let (scheme, method) = scheme(&full, &model, setting, o)?;
    let basic = matches!(scheme, Scheme::Residual { .. });
    let reps: Vec<Result<Replicate, String>> = (0..o.replicates)
        .into_par_iter()
        .map(|r| {
            let mut rng = ChaCha8Rng::seed_from_u64(o.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(r as u64));
            let draw = scheme.draw(&mut rng);
            let m = fit_multi(&draw, &setting.options).map_err(|e| e.to_string())?;
            let bb = o.backbone.as_ref().map(|(bo, _)| backbone(&m, bo).map_err(|e| e.to_string()));
            Ok((sorted_eigs(&m), bb))
        })
        .collect();
    let ok: Vec<&Replicate> = reps.iter().filter_map(|r| r.as_ref().ok()).collect();
    let first_err = |it: &mut dyn Iterator<Item = String>| it.next().unwrap_or_default();
    if ok.len() * 10 < o.replicates * 9 {
        return Err(AutoError::Bootstrap {
            ok: ok.len(),
            total: o.replicates,
            what: String::new(),
            first: first_err(&mut reps.iter().filter_map(|r| r.as_ref().err().cloned())),
        });
    }
    let eigenvalues = est_eigs
        .iter()
        .enumerate()
        .map(|(j, &(re, im))| {
            let res: Vec<f64> = ok.iter().map(|r| r.0[j].0).collect();
            let ims: Vec<f64> = ok.iter().map(|r| r.0[j].1).collect();
            let zs: Vec<f64> = ok.iter().map(|r| -r.0[j].0 / r.0[j].0.hypot(r.0[j].1)).collect();
            EigenInterval {
                re: interval(re, res, o.level, basic),
                im: interval(im, ims, o.level, basic),
                damping_ratio: interval(-re / re.hypot(im), zs, o.level, basic),
            }
        })
        .collect();
    let mut bands = Vec::new();
    let mut backbone_failed = 0;
    if let (Some((bo, npts)), Some(est)) = (&o.backbone, est_bb) {
        let amps: Vec<f64> = (0..*npts).map(|i| bo.amplitude_max * i as f64 / (npts - 1).max(1) as f64).collect();
        let curves: Vec<&Vec<Backbone>> =
            ok.iter().filter_map(|r| r.1.as_ref().and_then(|b| b.as_ref().ok())).collect();
        backbone_failed = ok.len() - curves.len();
        if curves.len() * 10 < ok.len() * 9 {
            return Err(AutoError::Bootstrap {
                ok: curves.len(),
                total: ok.len(),
                what: " with a backbone".into(),
                first: first_err(&mut ok.iter().filter_map(|r| r.1.as_ref().and_then(|b| b.as_ref().err().cloned()))),
            });
        }
        for (mi, eb) in est.iter().enumerate() {
            let (mut fr, mut zr) = (Vec::new(), Vec::new());
            for &a in &amps {
                let e = at_amplitude(eb, a).unwrap_or((f64::NAN, f64::NAN));
                let vals: Vec<(f64, f64)> =
                    curves.iter().filter_map(|c| c.get(mi).and_then(|b| at_amplitude(b, a))).collect();
                fr.push(interval(e.0, vals.iter().map(|v| v.0).collect(), o.level, basic));
                zr.push(interval(e.1, vals.iter().map(|v| v.1).collect(), o.level, basic));
            }
            bands.push(BackboneBand {
                mode: eb.mode,
                observable: eb.observable,
                amplitude: amps.clone(),
                freq_rad_s: fr,
                damping_ratio: zr,
            });
        }
    }
    Ok(Intervals {
        method,
        level: o.level,
        replicates: o.replicates,
        failed: o.replicates - ok.len(),
        backbone_failed,
        eigenvalues,
        backbone: bands,
    })
}
