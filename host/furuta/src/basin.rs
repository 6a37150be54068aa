//! The full system's basin near the global bifurcation (docs/decisions/0001), and where the
//! reduced models put its boundary.
//!
//! - [`full_basin`]: bounded vs escape of the full closed loop over a grid of mode-shaped
//!   starts (slow amplitude `rho_1` x fast amplitude `rho_2` at fixed phases) at a few
//!   sampling periods: a basin [`Sweep`] (axes `slow_amp`, `fast_amp`, `dt_ms`, the scene
//!   `furuta-dt30.5`), so `ssmctl sweep` on [`BasinOptions::spec`] gives the same cells.
//! - [`model_basin`]: the same grid classified by a reduced model's amplitude equations
//!   (any [`PolarNormalForm`]): asymptotically (the fate of the trajectory) and within the
//!   full runs' horizon.
//! - [`Agreement`]: the fraction of grid cells where model and full system disagree.
//! - [`torus_continuation`]: the full system's 2-torus followed across dt by long runs, each
//!   started from the end of the previous one; where it stops attracting.

use std::time::Instant;

use serde::Serialize;
use sim::chart::Axis;
use ssm::normal_form::PolarNormalForm;
use ssm::portrait::{Fate, FixedPoint, PointKind, PortraitOptions, PreparedField};

use crate::Error;
use crate::full_system::{AMP_WINDOW_S, ESCAPE_THETA, base_scene, end_start, run_with, start_from_rho};
use crate::sweep::shard::{RESULT_FORMAT, SweepResult};
use crate::sweep::{AxisSpec, BasinSpec, Cell, FORMAT_VERSION, Kind, Shard, SpecFile, Sweep, run_shard};
use sim::scene::{IntegratorSpec, MethodKind};
use ssm::spectrum::mode_amplitudes;

/// The basin grid: sampling periods, the two amplitude axes, the phases and the horizon.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BasinOptions {
    /// Sampling periods (ms), strictly increasing: one panel each.
    pub dts_ms: Vec<f64>,
    /// Slow-mode theta amplitude `rho_1` (rad): `lo`, `hi`, `n` (both ends included).
    pub rho1: Axis,
    /// Fast-mode theta amplitude `rho_2` (rad).
    pub rho2: Axis,
    /// Phases (rad) of the slow and the fast mode in every start.
    pub phases: [f64; 2],
    /// Horizon of every run (sampling periods).
    pub periods: u64,
    /// The integrator method of the runs (`None`: the scene's; tolerances are the scene's).
    pub method: Option<MethodKind>,
}

impl BasinOptions {
    /// The report's full grid: 20 x 20 starts, `rho_1` 0.005..0.25, `rho_2` 0.004..0.12 rad,
    /// phases 0, at 31.3, 31.4, 31.5, 31.6 ms, 3,000 periods, by
    /// [`crate::full_system::VERDICT_METHOD`].
    pub fn full() -> Self {
        BasinOptions {
            dts_ms: vec![31.3, 31.4, 31.5, 31.6],
            rho1: Axis { lo: 0.005, hi: 0.25, n: 20 },
            rho2: Axis { lo: 0.004, hi: 0.12, n: 20 },
            phases: [0.0, 0.0],
            periods: 3000,
            method: Some(crate::full_system::VERDICT_METHOD),
        }
    }

    /// The quick report's grid: the same box as [`BasinOptions::full`], 8 x 8 starts,
    /// 1,500 periods (the quick report reads how the escape fraction grows with dt and how
    /// the models agree with the full system, which a coarse grid shows as well).
    pub fn quick() -> Self {
        BasinOptions {
            rho1: Axis { n: 8, ..Self::full().rho1 },
            rho2: Axis { n: 8, ..Self::full().rho2 },
            periods: 1500,
            ..Self::full()
        }
    }

    /// The sweep spec of this grid (axes `slow_amp`, `fast_amp`, `dt_ms` in that order, so
    /// `ssmctl sweep` draws one panel per dt).
    pub fn spec(&self, name: &str) -> SpecFile {
        let range = |name: &str, a: &Axis| AxisSpec {
            name: name.into(),
            lo: Some(a.lo),
            hi: Some(a.hi),
            n: Some(a.n),
            values: None,
        };
        SpecFile {
            name: name.into(),
            description:
                "bounded vs escape of the full system over slow x fast mode amplitudes near the global bifurcation"
                    .into(),
            kind: Kind::Basin,
            scene: "furuta-dt30.5".into(),
            set: self.method.iter().map(|m| format!("integrator.method=\"{}\"", m.key())).collect(),
            axes: vec![
                range("slow_amp", &self.rho1),
                range("fast_amp", &self.rho2),
                AxisSpec { name: "dt_ms".into(), lo: None, hi: None, n: None, values: Some(self.dts_ms.clone()) },
            ],
            record: None,
            shards: None,
            basin: Some(BasinSpec {
                periods: Some(self.periods),
                escape_theta: Some(ESCAPE_THETA),
                slow_amp: None,
                fast_amp: None,
                slow_phase: Some(self.phases[0]),
                fast_phase: Some(self.phases[1]),
            }),
        }
    }

    /// The amplitude values of the two axes.
    pub fn values(&self) -> (Vec<f64>, Vec<f64>) {
        ((0..self.rho1.n).map(|j| self.rho1.at(j)).collect(), (0..self.rho2.n).map(|j| self.rho2.at(j)).collect())
    }
}

/// The full system's basin: the merged sweep result and what it cost.
#[derive(Clone, Debug, Serialize)]
pub struct FullBasin {
    pub options: BasinOptions,
    /// Every cell, in the sweep's index order.
    pub result: SweepResult,
    /// Wall time (s) and the rayon pool size it ran on.
    pub wall_seconds: f64,
    pub threads: usize,
}

impl FullBasin {
    /// Bounded (`true`) or escaped per start at the `p`-th sampling period, `rho_1`-major:
    /// entry `i * n2 + j` is the start `(rho1[i], rho2[j])`.
    pub fn bounded_at(&self, p: usize) -> Vec<bool> {
        let (n1, n2) = (self.options.rho1.n, self.options.rho2.n);
        (0..n1 * n2).map(|ij| self.cell(ij / n2, ij % n2, p).bounded.unwrap_or(false)).collect()
    }

    /// The cell of start `(rho1[i], rho2[j])` at the `p`-th sampling period.
    pub fn cell(&self, i: usize, j: usize, p: usize) -> &Cell {
        let k = self.result.spec.index_of(&[i, j, p]) as usize;
        &self.result.cells[k]
    }

    /// Fraction of escaping starts at the `p`-th sampling period.
    pub fn escape_fraction(&self, p: usize) -> f64 {
        let b = self.bounded_at(p);
        b.iter().filter(|x| !**x).count() as f64 / b.len().max(1) as f64
    }
}

/// Runs the full-system basin of `opts` on the rayon pool (cells in index order, bit-identical
/// for every pool size).
pub fn full_basin(opts: &BasinOptions) -> Result<FullBasin, Error> {
    if opts.dts_ms.is_empty() || opts.dts_ms.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Error::BadInput {
            what: "dts_ms",
            why: format!("need at least one, strictly increasing, got {:?}", opts.dts_ms),
        });
    }
    let sweep = Sweep::from_spec("basin", opts.spec("basin"), std::path::Path::new("."))?;
    let t0 = Instant::now();
    let cells = run_shard(&sweep, Shard::WHOLE)?;
    let wall_seconds = t0.elapsed().as_secs_f64();
    let result = SweepResult {
        format: RESULT_FORMAT.into(),
        version: FORMAT_VERSION,
        spec_hash: sweep.hash()?,
        spec: sweep,
        cells,
    };
    Ok(FullBasin { options: opts.clone(), result, wall_seconds, threads: rayon::current_num_threads() })
}

/// A reduced model's verdict on one start.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum ModelFate {
    /// Converges to a fixed point of the principal kind (e.g. the 2-torus), or is still inside
    /// the box at the time limit (e.g. circling it on a 3-torus): the full system's "bounded".
    Principal,
    /// Converges to another stable fixed point (another attractor of the model, e.g. a
    /// large-amplitude cycle).
    OtherAttractor,
    /// Leaves the box.
    LeavesBox,
    /// Reaches a saddle (on a separatrix) or the integration stopped: no verdict.
    Undecided,
}

impl ModelFate {
    /// The verdict on a trajectory ending at `last` with `fate`; at the time limit, a stop
    /// within [`NEAR_ATTRACTOR`] of a stable fixed point of another kind counts as reaching
    /// it (a slow approach), anything else as circling the principal attractor.
    fn of(fate: &Fate, last: Option<(f64, f64)>, fps: &[FixedPoint], principal: PointKind) -> Self {
        match fate {
            Fate::LeavesBox { .. } => ModelFate::LeavesBox,
            Fate::StepLimit | Fate::ApproachesSaddle { .. } => ModelFate::Undecided,
            Fate::TimeLimit => {
                let near_other = last.is_some_and(|(x, y)| {
                    fps.iter().any(|f| {
                        f.kind != principal
                            && f.stability.is_stable()
                            && (f.rho[0] - x).hypot(f.rho[1] - y) < NEAR_ATTRACTOR
                    })
                });
                if near_other { ModelFate::OtherAttractor } else { ModelFate::Principal }
            }
            Fate::Converges { point } => match fps.get(*point) {
                Some(f) if f.kind == principal => ModelFate::Principal,
                Some(_) => ModelFate::OtherAttractor,
                None => ModelFate::Undecided,
            },
        }
    }

    /// `Some(bounded)` in the full system's sense (only [`ModelFate::Principal`] is bounded),
    /// `None` when undecided.
    pub fn bounded(self) -> Option<bool> {
        match self {
            ModelFate::Principal => Some(true),
            ModelFate::OtherAttractor | ModelFate::LeavesBox => Some(false),
            ModelFate::Undecided => None,
        }
    }
}

/// Distance (rad) from a stable fixed point within which a trajectory stopped by the time
/// limit counts as reaching it ([`ModelFate`]).
pub const NEAR_ATTRACTOR: f64 = 1e-3;

/// A reduced model's classification of a grid of starts `(rho1[i], rho2[j])`, `rho_1`-major.
#[derive(Clone, Debug, Serialize)]
pub struct ModelBasin {
    /// Fate of the trajectory within `t_max` s (the asymptotic fate).
    pub asymptotic: Vec<ModelFate>,
    /// The asymptotic fate, except that leaving the box after `horizon_s` counts as
    /// [`ModelFate::Principal`] (what a run as long as the full system's sees).
    pub horizon: Vec<ModelFate>,
    pub t_max: f64,
    pub horizon_s: f64,
}

/// Classifies every start `(rho1[i], rho2[j])` (entry `i * rho2.len() + j`) by the amplitude
/// equations of `nf` in the box `opts.rho_max`: the fate within `t_max` s and within
/// `horizon_s` s ([`ssm::portrait::trajectory`]), on the rayon pool; `principal` is the kind
/// of fixed point whose basin counts as bounded (the 2-torus for the Furuta loop: the full
/// system has no other attractor near the upright position). Amplitudes must be non-negative
/// and inside the box; `0 < horizon_s <= t_max`.
pub fn model_basin(
    nf: &PolarNormalForm,
    principal: PointKind,
    rho1: &[f64],
    rho2: &[f64],
    horizon_s: f64,
    t_max: f64,
    opts: &PortraitOptions,
) -> Result<ModelBasin, Error> {
    if !(horizon_s.is_finite() && t_max.is_finite() && horizon_s > 0.0 && horizon_s <= t_max) {
        return Err(Error::BadOption {
            what: "horizon_s",
            why: format!("need 0 < horizon_s <= t_max, finite; got {horizon_s}, {t_max}"),
        });
    }
    for (name, v, m) in [("rho1", rho1, opts.rho_max[0]), ("rho2", rho2, opts.rho_max[1])] {
        if v.is_empty() {
            return Err(Error::BadInput { what: "model basin", why: format!("{name} is empty") });
        }
        if let Some(x) = v.iter().find(|x| !(x.is_finite() && **x >= 0.0 && **x < m)) {
            return Err(Error::BadInput {
                what: "model basin",
                why: format!("{name} value {x} is not in [0, {m}) (the box rho_max)"),
            });
        }
    }
    // The field and the fixed points `trajectory` numbers its fates by, computed once (the
    // same computation as `trajectory`'s per start).
    let field = PreparedField::new(nf, opts)?;
    let fps = field.fixed_points();
    let starts: Vec<[f64; 2]> = rho1.iter().flat_map(|&a| rho2.iter().map(move |&b| [a, b])).collect();
    let fates = crate::par_map(&starts, |&r| -> Result<(ModelFate, ModelFate), Error> {
        let (pts, fate) = field.trajectory(r, t_max)?;
        let asym = ModelFate::of(&fate, pts.last().copied(), fps, principal);
        // Within the horizon: the asymptotic verdict, except that a start which leaves the
        // box only after the horizon is still bounded (a second, shorter integration).
        let hor = match fate {
            Fate::LeavesBox { .. } => {
                let (pts, fate) = field.trajectory(r, horizon_s)?;
                // Still in the box at the horizon: bounded so far, wherever it heads.
                if fate == Fate::TimeLimit {
                    ModelFate::Principal
                } else {
                    ModelFate::of(&fate, pts.last().copied(), fps, principal)
                }
            }
            _ => asym,
        };
        Ok((asym, hor))
    })?;
    let (asymptotic, horizon) = fates.into_iter().unzip();
    Ok(ModelBasin { asymptotic, horizon, t_max, horizon_s })
}

/// How a model's classification of a grid compares with the full system's.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Agreement {
    /// Cells compared (the model decided).
    pub cells: usize,
    /// Cells where the model said bounded and the full system escaped.
    pub model_bounded_full_escaped: usize,
    /// Cells where the model said escape and the full system stayed bounded.
    pub model_escaped_full_bounded: usize,
    /// Cells without a model verdict (not compared).
    pub undecided: usize,
    /// Disagreeing cells over compared cells.
    pub disagreement: f64,
}

/// Compares a model's fates with the full system's `bounded` cell by cell (same order).
pub fn agreement(model: &[ModelFate], full_bounded: &[bool]) -> Result<Agreement, Error> {
    if model.len() != full_bounded.len() {
        return Err(Error::Shape { expected: full_bounded.len(), got: model.len() });
    }
    let mut a = Agreement {
        cells: 0,
        model_bounded_full_escaped: 0,
        model_escaped_full_bounded: 0,
        undecided: 0,
        disagreement: 0.0,
    };
    for (m, &f) in model.iter().zip(full_bounded) {
        match m.bounded() {
            None => a.undecided += 1,
            Some(b) => {
                a.cells += 1;
                match (b, f) {
                    (true, false) => a.model_bounded_full_escaped += 1,
                    (false, true) => a.model_escaped_full_bounded += 1,
                    _ => {}
                }
            }
        }
    }
    a.disagreement = (a.model_bounded_full_escaped + a.model_escaped_full_bounded) as f64 / a.cells.max(1) as f64;
    Ok(a)
}

// ---------------------------------------------------------------------------------------
// The full system's torus across dt
// ---------------------------------------------------------------------------------------

/// One step of [`torus_continuation`].
#[derive(Clone, Debug, Serialize)]
pub struct TorusStep {
    pub dt_ms: f64,
    /// Time (s) of the escape, `None` when the run stayed bounded.
    pub escape_t: Option<f64>,
    /// Mean `(rho_1, rho_2)` over the last third of the run (bounded runs only).
    pub rho: Option<[f64; 2]>,
    /// Spread (max - min) of `rho_1` over the middle and the last third of the run (bounded
    /// runs only): an attracting torus keeps them small and not growing.
    pub spread_mid: Option<f64>,
    pub spread_last: Option<f64>,
    /// Growth rate (1/s) of the slow amplitude's oscillation about the torus: `ln(spread_last
    /// / spread_mid)` over the time between the two thirds (bounded runs only; negative:
    /// decaying, the torus attracts; positive: growing).
    pub growth_rate: Option<f64>,
    /// The growth rate's noise floor (1/s): half the difference between the rates measured
    /// the same way on the two halves of the measured span (sixths 3 -> 4 and 5 -> 6 of the
    /// run, each over a sixth's time). A rate within +-this is neither growth nor decay for
    /// [`TorusContinuation::growth_onset`]. `None` when a sixth is shorter than the amplitude
    /// window or a spread is zero (then the floor is 0).
    pub rate_noise: Option<f64>,
    /// The torus stopped attracting here ([`TORUS_GROWTH`] rule).
    pub lost: bool,
}

/// The rule of [`TorusStep::lost`]: the run escaped, or the slow amplitude's spread over the
/// last third is more than this factor times that over the middle third and above
/// [`TORUS_SPREAD_MIN`] (a growing oscillation about the torus; 1: growing at all, since
/// near the loss the oscillation grows or decays slowly from one third to the next).
pub const TORUS_GROWTH: f64 = 1.0;

/// Spreads of `rho_1` below this (rad) count as the torus itself (the sliding fit's ripple on
/// an attracting 2-torus is below 1e-3 rad).
pub const TORUS_SPREAD_MIN: f64 = 0.005;

/// The full system's 2-torus followed across dt.
#[derive(Clone, Debug, Serialize)]
pub struct TorusContinuation {
    pub start_rho: [f64; 2],
    pub periods: u64,
    pub steps: Vec<TorusStep>,
    /// `(last dt where the torus attracts, first dt where it is lost)`; `None` when it is
    /// never lost on the grid or lost at the first dt.
    pub lost_between: Option<(f64, f64)>,
    /// Where the oscillation about the torus stops decaying: the zero of
    /// [`TorusStep::growth_rate`], linear in dt between the last step that decays (rate below
    /// minus its [`TorusStep::rate_noise`]) and the first that grows (rate above its noise, or
    /// lost); steps within their noise floor between them decide nothing (the torus's linear
    /// stability; a subcritical loss shows it before the growth is large enough for
    /// [`TorusStep::lost`] within the run). `None` when no step grows, none decays before the
    /// first that grows, or that one escaped.
    pub growth_onset: Option<f64>,
}

impl TorusContinuation {
    /// The continuation of `steps` (in dt order, stopped at the first loss).
    pub fn from_steps(start_rho: [f64; 2], periods: u64, steps: Vec<TorusStep>) -> Self {
        let lost_between = match steps.iter().position(|s| s.lost) {
            Some(i) if i > 0 => Some((steps[i - 1].dt_ms, steps[i].dt_ms)),
            _ => None,
        };
        let floor = |s: &TorusStep| s.rate_noise.unwrap_or(0.0);
        let grows = |s: &TorusStep| s.lost || s.growth_rate.is_none_or(|r| r > floor(s));
        let decays = |s: &TorusStep| !s.lost && s.growth_rate.is_some_and(|r| r < -floor(s));
        let growth_onset = steps.iter().position(grows).and_then(|i| {
            let j = steps[..i].iter().rposition(decays)?;
            match (steps[j].growth_rate, steps[i].growth_rate) {
                (Some(a), Some(b)) if a < 0.0 && b > 0.0 => {
                    Some(steps[j].dt_ms + (steps[i].dt_ms - steps[j].dt_ms) * (-a) / (b - a))
                }
                _ => None,
            }
        });
        TorusContinuation { start_rho, periods, steps, lost_between, growth_onset }
    }

    /// The torus is lost at the grid's first dt already (then [`Self::lost_between`] is
    /// `None`, as when it is never lost).
    pub fn lost_at_first_dt(&self) -> bool {
        self.steps.first().is_some_and(|s| s.lost)
    }
}

/// The torus-loss rule of one continuation step, shared by the full system
/// ([`torus_continuation`]) and the fitted map (`crate::map_global::map_torus_continuation`):
/// `theta` is the run's primary angle, one sample per sampling period `sample_dt` (s), at
/// `dt_ms`; `escape_t` the time of its escape, if it escaped (then the torus is lost and
/// nothing is measured). Otherwise the slow and fast amplitudes ([`mode_amplitudes`], window
/// [`AMP_WINDOW_S`], at the spectral peaks of the last third, the exact linear frequencies
/// when a band has no peak) over the middle and the last third of the run: `rho` is the mean
/// over the last third, and the torus is lost when `rho_1`'s spread over the last third is
/// above [`TORUS_GROWTH`] times that over the middle third and above [`TORUS_SPREAD_MIN`];
/// the growth rate is the log ratio of the two spreads over the time between the thirds, its
/// noise floor the half difference of that rate on the two halves of the measured span.
pub fn torus_step(dt_ms: f64, theta: &[f64], sample_dt: f64, escape_t: Option<f64>) -> Result<TorusStep, Error> {
    let mut step = TorusStep {
        dt_ms,
        escape_t,
        rho: None,
        spread_mid: None,
        spread_last: None,
        growth_rate: None,
        rate_noise: None,
        lost: true,
    };
    if escape_t.is_some() {
        return Ok(step);
    }
    if !(sample_dt.is_finite() && sample_dt > 0.0) {
        return Err(Error::BadInput {
            what: "sample_dt",
            why: format!("must be positive and finite, got {sample_dt}"),
        });
    }
    if let Some(v) = theta.iter().find(|v| !v.is_finite()) {
        return Err(Error::BadInput { what: "theta", why: format!("a bounded run must be finite, got {v}") });
    }
    let n = theta.len();
    let third = |k: usize| &theta[k * n / 3..(k + 1) * n / 3];
    let lin = crate::parametric::exact_modes(dt_ms)?.freqs_hz;
    let split = (lin[0] * lin[1]).sqrt();
    let last = third(2);
    let freqs = match (
        ssm::spectrum::band_peak(last, sample_dt, 0.0, split),
        ssm::spectrum::band_peak(last, sample_dt, split, 0.5 / sample_dt),
    ) {
        (Some(a), Some(b)) => [a.freq_hz, b.freq_hz],
        _ => lin,
    };
    let amps = |s: &[f64]| mode_amplitudes(s, sample_dt, freqs, AMP_WINDOW_S);
    let (mid, end) = (amps(third(1))?, amps(last)?);
    if mid.is_empty() || end.is_empty() {
        return Err(Error::BadInput {
            what: "periods",
            why: format!("a third of the {n} samples is shorter than the amplitude window {AMP_WINDOW_S} s"),
        });
    }
    let spread = |a: &[(f64, [f64; 2])]| {
        let (lo, hi) =
            a.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x.1[0]), hi.max(x.1[0])));
        hi - lo
    };
    let k = end.len() as f64;
    step.rho = Some([end.iter().map(|a| a.1[0]).sum::<f64>() / k, end.iter().map(|a| a.1[1]).sum::<f64>() / k]);
    let (sm, sl) = (spread(&mid), spread(&end));
    step.spread_mid = Some(sm);
    step.spread_last = Some(sl);
    // The thirds' starts are n / 3 samples apart.
    step.growth_rate = (sm > 0.0 && sl > 0.0).then(|| (sl / sm).ln() / ((n / 3) as f64 * sample_dt));
    // The same rate on each half of the measured span (the last two thirds), sixth to sixth.
    let sixth = |k: usize| -> Result<Option<f64>, Error> {
        let a = amps(&theta[k * n / 6..(k + 1) * n / 6])?;
        Ok((!a.is_empty()).then(|| spread(&a)))
    };
    let half_rate = |k: usize| -> Result<Option<f64>, Error> {
        Ok(match (sixth(k)?, sixth(k + 1)?) {
            (Some(a), Some(b)) if a > 0.0 && b > 0.0 => Some((b / a).ln() / ((n / 6) as f64 * sample_dt)),
            _ => None,
        })
    };
    step.rate_noise = match (half_rate(2)?, half_rate(4)?) {
        (Some(a), Some(b)) => Some(0.5 * (a - b).abs()),
        _ => None,
    };
    step.lost = sl > TORUS_GROWTH * sm && sl > TORUS_SPREAD_MIN;
    Ok(step)
}

/// Follows the full system's 2-torus over `dts_ms` (strictly increasing): a run of
/// `periods` periods at the first dt from the mode start at `start_rho` (phases 0), every
/// further run from the end state and controller samples of the previous one (so it starts on
/// the previous dt's torus, a small perturbation of this one's). Stops after the first step
/// where the torus is lost ([`TorusStep::lost`]). Serial by nature: each run needs the last.
pub fn torus_continuation(dts_ms: &[f64], start_rho: [f64; 2], periods: u64) -> Result<TorusContinuation, Error> {
    torus_continuation_with(None, dts_ms, start_rho, periods)
}

/// [`torus_continuation`] with the scene's integrator replaced by `integrator` (`None`: the
/// scene's; [`crate::full_system::run_with`]).
pub fn torus_continuation_with(
    integrator: Option<&IntegratorSpec>,
    dts_ms: &[f64],
    start_rho: [f64; 2],
    periods: u64,
) -> Result<TorusContinuation, Error> {
    if dts_ms.is_empty() || dts_ms.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Error::BadInput {
            what: "dts_ms",
            why: format!("need at least one, strictly increasing, got {dts_ms:?}"),
        });
    }
    let (x, h) = start_from_rho(dts_ms[0], start_rho, [0.0, 0.0])?;
    let mut start = (x, Some(h));
    let mut steps = Vec::new();
    for &dt in dts_ms {
        let tr = run_with(integrator, dt, &start, periods, ESCAPE_THETA)?;
        let escape_t = if tr.stopped.is_some() { tr.t.last().copied() } else { None };
        let step = torus_step(dt, &tr.primary(), tr.dt, escape_t)?;
        if !step.lost {
            // The next run starts from this one's end: plant state of the last row and the
            // controller's `delay + 1` samples before it, oldest first ([`end_start`]).
            let delay = base_scene()?.controller.delay as usize;
            start = end_start(&tr, delay)?;
        }
        let lost = step.lost;
        steps.push(step);
        if lost {
            break;
        }
    }
    Ok(TorusContinuation::from_steps(start_rho, periods, steps))
}
