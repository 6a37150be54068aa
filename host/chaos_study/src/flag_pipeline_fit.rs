//! Why the flag's fit misses the known system's chaos, and what recovers it (docs/decisions/0002,
//! after [`crate::flag_pipeline`]).
//!
//! Diagnosis on the known system ([`crate::flag_pipeline::CHOSEN`] sampled like the flag):
//! - [`projection_fnn`]: is the SSM's linear projection of the delay embedding injective? The
//!   share of false nearest neighbours of the points projected on the first `d` singular
//!   directions (a neighbour in the projection whose distance in the discarded directions is
//!   more than `ratio` times the projected distance), and the singular values against the
//!   noise floor;
//! - [`state_model_check`]: the model class (RBF or polynomial map, one-step ridge, optional
//!   multistep refinement) fitted on the TRUE state `x_1..x_4` sampled at the map step (no
//!   delay embedding, no projection): what the fitting can do at best with this data amount;
//! - variants of the flag's candidates (noise-free data, SSM dimension, embedding shift,
//!   multistep refinement, denoised inputs) through [`crate::flag_pipeline::pipeline_check`]
//!   itself, built by [`variant`].

use chaos::{Bins, CorrSumParams, Points, ScalingRule, correlation_dimension, delay_embed};
use faer::Mat;
use serde::Serialize;
use ssm::dynamics::{EtaTrajectory, ReducedDynamics};
use ssm::multistep::{MultiStep, refine_multistep};
use ssm::{Dynamics, FitOptions, Ridge, TimeSeries};

use crate::Error;
use crate::flag_pipeline::{FlagLayout, KnownStats, KnownSystem, Measured, PipelineRow, known_stats};
use crate::lyapunov::{dynamics_lyapunov, iterate_dynamics};
use crate::model_selection::{Candidate, EvalSettings, data_stats, subsample};
use chaos::add_noise;

/// False nearest neighbours of a delay embedding projected on its first `dim` singular
/// directions.
#[derive(Clone, Debug, Serialize)]
pub struct FnnRow {
    pub dim: usize,
    /// Singular value `dim` (1-based) over the first.
    pub singular_rel: f64,
    /// Share of query points whose nearest neighbour in the projection (outside the Theiler
    /// window) is false.
    pub fnn: f64,
}

/// [`FnnRow`]s of the series `x` delay-embedded with `embed` coordinates `shift` samples
/// apart (as the SSM fit embeds it), for each dimension in `dims` (< `embed`): nearest
/// neighbours found by brute force for `queries` points spread over the series, Theiler
/// window `theiler` samples; a neighbour is false when its distance in the discarded
/// directions exceeds `ratio` times the projected distance. The singular directions are the
/// SSM fit's ([`ssm::manifold::tangent_space`]).
pub fn projection_fnn(
    x: &[f64],
    embed: usize,
    shift: usize,
    theiler: usize,
    dims: &[usize],
    ratio: f64,
    queries: usize,
) -> Result<Vec<FnnRow>, Error> {
    if embed < 2
        || shift == 0
        || queries == 0
        || ratio.is_nan()
        || ratio <= 0.0
        || dims.iter().any(|&d| d == 0 || d >= embed)
    {
        return Err(Error::BadOption {
            what: "projection_fnn",
            why: format!(
                "need embed >= 2, shift >= 1, queries >= 1, ratio > 0, 1 <= dim < embed (got {embed}, {shift}, {queries}, {ratio}, {dims:?})"
            ),
        });
    }
    let n = x.len().checked_sub((embed - 1) * shift).filter(|&n| n > 2 * theiler + 2).ok_or(Error::BadInput {
        what: "projection_fnn series",
        why: format!("{} samples are too few for embedding {embed} x {shift} and Theiler window {theiler}", x.len()),
    })?;
    let y = Mat::from_fn(embed, n, |i, j| x[j + i * shift]);
    let (v, sv) = ssm::manifold::tangent_space(std::slice::from_ref(&y), embed - 1).map_err(ssm::Error::from)?;
    // Coordinates in the singular basis (the last one completes it: the residual norm).
    let p = embed;
    let proj: Vec<Vec<f64>> =
        (0..n).map(|j| (0..p - 1).map(|c| (0..p).map(|i| v[c * p + i] * y[(i, j)]).sum()).collect()).collect();
    let full2 = |a: usize, b: usize| (0..p).map(|i| (y[(i, a)] - y[(i, b)]).powi(2)).sum::<f64>();
    let stride = (n / queries).max(1);
    let mut out = Vec::with_capacity(dims.len());
    for &d in dims {
        let (mut false_nn, mut total) = (0usize, 0usize);
        for a in (0..n).step_by(stride) {
            let mut best = (f64::INFINITY, usize::MAX);
            for b in 0..n {
                if a.abs_diff(b) <= theiler {
                    continue;
                }
                let d2: f64 = (0..d).map(|c| (proj[a][c] - proj[b][c]).powi(2)).sum();
                if d2 < best.0 {
                    best = (d2, b);
                }
            }
            if best.1 == usize::MAX {
                continue;
            }
            total += 1;
            let rest = (full2(a, best.1) - best.0).max(0.0);
            false_nn += (rest > ratio * ratio * best.0) as usize;
        }
        out.push(FnnRow { dim: d, singular_rel: sv[d - 1] / sv[0], fnn: false_nn as f64 / total.max(1) as f64 });
    }
    Ok(out)
}

/// The reduced dimension chosen by false nearest neighbours of the projection: the smallest
/// `d` in `1..=max_dim` whose projection of the embedding the fit would use (`p = 2 d + 1`
/// samples `shift` apart, Takens' bound) has at most `max_fnn` false neighbours at `ratio`
/// ([`projection_fnn`]); `None` if none does. Also the row of every `d` tried.
pub fn fnn_dimension(
    x: &[f64],
    shift: usize,
    theiler: usize,
    ratio: f64,
    max_fnn: f64,
    max_dim: usize,
    queries: usize,
) -> Result<(Option<usize>, Vec<FnnRow>), Error> {
    let mut rows = Vec::with_capacity(max_dim);
    for d in 1..=max_dim {
        let r = projection_fnn(x, 2 * d + 1, shift, theiler, &[d], ratio, queries)?.remove(0);
        let ok = r.fnn <= max_fnn;
        rows.push(r);
        if ok {
            return Ok((Some(d), rows));
        }
    }
    Ok((None, rows))
}

/// The rule of [`fnn_dimension`] as used on the known system and the flag: ratio 2, at most
/// 0.5 % false neighbours, shift 1, 800 query points.
pub const FNN_RULE: (f64, f64) = (2.0, 0.005);

/// A variant of the flag's candidates ([`crate::flag_pipeline::flag_like_candidates`]) at map
/// step `step`: RBF map with `centers` (0 = the polynomial map of order 4) and `ridge`, SSM
/// dimension `dim`, embedding `embed` with `shift`, manifold order 3, optional multistep
/// refinement and denoised inputs (half-width `denoise`, 0 = off).
#[allow(clippy::too_many_arguments)]
pub fn variant(
    step: usize,
    centers: usize,
    ridge: f64,
    dim: usize,
    embed: usize,
    shift: usize,
    multistep: Option<MultiStep>,
    denoise: usize,
) -> Candidate {
    let dynamics = if centers == 0 { Dynamics::Map } else { Dynamics::Rbf { centers } };
    let kind = if centers == 0 { "poly 4".to_string() } else { format!("RBF {centers}") };
    let mut name = format!("{kind} /{step} r={ridge:e} d={dim} p={embed} s={shift}");
    if let Some(ms) = &multistep {
        name += &format!(" ms h={} stride {} it {}", ms.horizon, ms.stride, ms.iterations);
    }
    if denoise > 0 {
        name += &format!(" denoised {}", 2 * denoise + 1);
    }
    Candidate {
        name,
        step,
        fit: FitOptions {
            dim,
            embed,
            shift,
            manifold_order: 3,
            dyn_order: 4,
            dynamics,
            ridge: Ridge::Fixed(ridge),
            linear_anchor: None,
            anchor_joint: false,
        },
        smooth: 0,
        multistep,
        denoise_inputs: denoise,
        centres: Default::default(),
    }
}

/// Coordinates a map is fitted in by [`state_model_check`].
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub enum Coords {
    /// The true state `x_1..x_n` (noise-free unless [`StateFit::noise_rel`]).
    State,
    /// The whole delay vector of the observed (noisy) series at the map step: `embed`
    /// samples `shift` apart, no projection (the map moves the window and predicts its
    /// newest sample among the rest).
    Delay { embed: usize, shift: usize },
}

/// The model class in given coordinates: options of [`state_model_check`].
#[derive(Clone, Copy, Debug, Serialize)]
pub struct StateFit {
    pub coords: Coords,
    /// RBF centres (0 = polynomial map of order `order`).
    pub centers: usize,
    pub order: u32,
    pub ridge: f64,
    pub multistep: Option<MultiStep>,
    /// With [`Coords::State`]: white noise on every state coordinate, times that
    /// coordinate's sd.
    pub noise_rel: f64,
    /// The realization of that noise (0: the first; each seed offsets the noise seeds by
    /// [`NOISE_SEED_STRIDE`]).
    pub noise_seed: u64,
}

/// The offset of the state noise's seeds from one realization to the next: more than the
/// noise streams of one realization (one per coordinate of each training piece).
pub const NOISE_SEED_STRIDE: u64 = 1_000;

impl StateFit {
    pub fn name(&self) -> String {
        let c = match self.coords {
            Coords::State => "state".to_string(),
            Coords::Delay { embed, shift } => format!("delay {embed} x {shift}"),
        };
        let mut s =
            if self.centers == 0 { format!("{c} poly {}", self.order) } else { format!("{c} RBF {}", self.centers) };
        s += &format!(" r={:e}", self.ridge);
        if let Some(ms) = &self.multistep {
            s += &format!(" ms h={}", ms.horizon);
        }
        if self.noise_rel > 0.0 && self.coords == Coords::State {
            s += &format!(" noise {}", self.noise_rel);
            if self.noise_seed != 0 {
                s += &format!(" seed {}", self.noise_seed);
            }
        }
        s
    }
}

/// Rows of the state `n x dim` (row-major) every `step` from `offset`, as a matrix.
fn state_rows(s: &[f64], dim: usize, step: usize, offset: usize) -> Mat<f64> {
    let n = s.len() / dim;
    let rows: Vec<usize> = (offset..n).step_by(step).collect();
    Mat::from_fn(rows.len(), dim, |r, c| s[rows[r] * dim + c])
}

/// Delay vectors (rows) of `x`: `embed` samples `shift` apart, newest last.
fn delay_rows(x: &[f64], embed: usize, shift: usize) -> Result<Mat<f64>, Error> {
    let n = x.len().checked_sub((embed - 1) * shift).filter(|&n| n >= 2).ok_or(Error::BadInput {
        what: "delay coordinates",
        why: format!("{} samples are too few for {embed} x {shift}", x.len()),
    })?;
    Ok(Mat::from_fn(n, embed, |r, c| x[r + c * shift]))
}

/// The map class fitted in the coordinates `fit.coords` of `sys` (sampled as `layout`,
/// training data `scale` times the flag's, map step `layout.step`, every phase a trajectory
/// as in the flag's search) and measured like a candidate: Benettin from the held-out
/// piece's first point, the long run (5 held-out lengths) for escape, Rosenstein and D2 of
/// its `x_1` (the first coordinate) with the held-out data's settings, JS of the PDFs of
/// all coordinates against the held-out piece's. The row's references are the held-out
/// observed series' (as [`known_stats`]).
pub fn state_model_check(
    sys: &KnownSystem,
    layout: &FlagLayout,
    scale: usize,
    fit: &StateFit,
    benettin_time: f64,
) -> Result<(KnownStats, PipelineRow), Error> {
    let (stats, series) = known_stats(sys, layout, scale, benettin_time)?;
    let row = state_model_row(sys, layout, scale, fit, &stats, &series, &EvalSettings::default())?;
    Ok((stats, row))
}

/// [`state_model_check`] on the series [`known_stats`] gave (`stats`, `series`: training,
/// then held-out), with the estimator settings `s`.
pub fn state_model_row(
    sys: &KnownSystem,
    layout: &FlagLayout,
    scale: usize,
    fit: &StateFit,
    stats: &KnownStats,
    series: &[TimeSeries],
    s: &EvalSettings,
) -> Result<PipelineRow, Error> {
    if series.len() != 3 {
        return Err(Error::BadInput {
            what: "state model series",
            why: format!("{} series: need two training series and the held-out one", series.len()),
        });
    }
    let (_, ctx) = data_stats(&series[2], layout.step, s)?;
    let (train, test): (Vec<Mat<f64>>, Mat<f64>) = match fit.coords {
        Coords::State => {
            let mut states =
                sys.flag_like_states(stats.dt, &[layout.test, layout.train[0] * scale, layout.train[1] * scale])?;
            states.rotate_left(1);
            let dim = states[0].len() / (layout.train[0] * scale);
            if fit.noise_rel > 0.0 {
                let streams = 2 * dim as u64;
                let base = fit
                    .noise_seed
                    .checked_mul(NOISE_SEED_STRIDE)
                    .filter(|_| streams <= NOISE_SEED_STRIDE)
                    .and_then(|b| b.checked_add(101))
                    .ok_or_else(|| Error::BadOption {
                        what: "state noise seed",
                        why: format!(
                            "seed {} with {streams} noise streams: needs at most {NOISE_SEED_STRIDE} streams and seed x {NOISE_SEED_STRIDE} within 64 bits",
                            fit.noise_seed
                        ),
                    })?;
                for (i, piece) in states.iter_mut().take(2).enumerate() {
                    for c in 0..dim {
                        let col: Vec<f64> = piece.iter().skip(c).step_by(dim).copied().collect();
                        let m = col.iter().sum::<f64>() / col.len() as f64;
                        let sd = (col.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / col.len() as f64).sqrt();
                        let noisy = add_noise(&col, fit.noise_rel * sd, base + (i * dim + c) as u64);
                        for (k, v) in noisy.into_iter().enumerate() {
                            piece[k * dim + c] = v;
                        }
                    }
                }
            }
            let train = states[..2]
                .iter()
                .flat_map(|p| (0..layout.step).map(move |o| state_rows(p, dim, layout.step, o)))
                .collect();
            (train, state_rows(&states[2], dim, layout.step, 0))
        }
        Coords::Delay { embed, shift } => {
            if embed == 0 || shift == 0 {
                return Err(Error::BadOption {
                    what: "delay coordinates",
                    why: format!("need embed >= 1 and shift >= 1 (got {embed}, {shift})"),
                });
            }
            let mut train = Vec::new();
            for ts in &series[..2] {
                for o in 0..layout.step {
                    train.push(delay_rows(&subsample(ts, layout.step, o)?.x, embed, shift)?);
                }
            }
            // Newest sample first, so that coordinate 0 is the observable at the point's time.
            let flip = |m: Mat<f64>| Mat::from_fn(m.nrows(), m.ncols(), |r, c| m[(r, m.ncols() - 1 - c)]);
            let train = train.into_iter().map(flip).collect();
            (train, flip(delay_rows(&subsample(&series[2], layout.step, 0)?.x, embed, shift)?))
        }
    };
    let dim = test.ncols();
    let step_dt = stats.step_dt;
    let trajs: Vec<EtaTrajectory> = train.iter().map(|e| EtaTrajectory { eta: e.as_ref(), dt: step_dt }).collect();
    let kind = if fit.centers == 0 { Dynamics::Map } else { Dynamics::Rbf { centers: fit.centers } };
    let mut dynamics = ReducedDynamics::fit(&trajs, kind, fit.order, Ridge::Fixed(fit.ridge))?;
    if let (Some(ms), ReducedDynamics::Rbf(map)) = (&fit.multistep, &mut dynamics) {
        refine_multistep(map, &trajs, ms)?;
    }
    let data_max = train
        .iter()
        .flat_map(|m| (0..m.nrows()).flat_map(move |r| (0..dim).map(move |c| m[(r, c)].abs())))
        .fold(0.0, f64::max);
    let eta0: Vec<f64> = (0..dim).map(|c| test[(0, c)]).collect();
    let bound = ssm::fit::BLOWUP_FACTOR * data_max;
    let mut m = Measured { benettin: None, rosenstein: None, corr_dim: None, js: None };
    let mut failed = None;
    if let Ok(b) = dynamics_lyapunov(&dynamics, &eta0, bound, s.benettin_transient, s.benettin_steps) {
        m.benettin = Some(b.exponent);
    }
    let n_long = test.nrows() * s.long_runs;
    match iterate_dynamics(&dynamics, &eta0, n_long, bound, 1) {
        Err(e) => failed = Some(format!("escaped in the long run: {e}")),
        Ok(orbit) => match orbit.recorded {
            None => failed = Some("long run recorded nothing".into()),
            Some(pts) => {
                let exc = pts.as_flat().iter().fold(0.0_f64, |a, v| a.max(v.abs())) / data_max;
                if exc.is_nan() || exc > s.region_factor {
                    failed = Some(format!("left the data's region: {exc:.2} x the data's largest |x_i|"));
                } else {
                    let x: Vec<f64> = (0..test.nrows().min(pts.len())).map(|i| pts.point(i)[0]).collect();
                    m.rosenstein = ctx.lle(&x, &mut Vec::new(), "state model").ok().map(|(l, _)| l);
                    m.corr_dim = delay_embed(&x, ctx.embed, ctx.lag)
                        .and_then(|p| {
                            correlation_dimension(
                                &p,
                                &CorrSumParams { theiler: ctx.theiler, ..Default::default() },
                                &ScalingRule::default(),
                            )
                        })
                        .ok()
                        .map(|c| c.dimension);
                    let flat: Vec<f64> = (0..test.nrows())
                        .flat_map(|r| (0..dim).map(move |c| (r, c)))
                        .map(|(r, c)| test[(r, c)])
                        .collect();
                    m.js = Points::from_flat(dim, flat)
                        .and_then(|a| chaos::compare_pdfs(&a, &pts, Bins::default()))
                        .ok()
                        .map(|c| c.mean_js_bits);
                }
            }
        },
    }
    let row = PipelineRow::from_values(
        &fit.name(),
        scale,
        &m,
        failed,
        stats.rosenstein,
        stats.corr_dim,
        stats.corr_dim_err,
        stats.exact,
    );
    Ok(row)
}

/// The d = 6 rows of [`crate::study_results::KnownSystemResults::diagnosis_rows`] (groups "(b) d = 6", "multistep" and "d = 6 scan",
/// every seed) with multistep refinement or without (`multistep`), at training-data `scale`
/// and noise `noise`: (Benettin within 10 % of the exact exponent, that and JS <= 0.01, rows).
pub fn d6_scan_counts(
    rows: &[(String, f64, PipelineRow)],
    multistep: bool,
    scale: usize,
    noise: f64,
) -> (usize, usize, usize) {
    let js_max = chaos::Targets::default().js_max;
    let sel: Vec<&PipelineRow> = rows
        .iter()
        .filter(|(w, n, r)| {
            ["(b) d = 6", "multistep", "d = 6 scan"].contains(&w.as_str())
                && r.candidate.contains("d=6")
                && r.candidate.contains(" ms ") == multistep
                && r.scale == scale
                && *n == noise
        })
        .map(|(_, _, r)| r)
        .collect();
    let b10 = sel.iter().filter(|r| r.benettin_exact_ok).count();
    let both = sel.iter().filter(|r| r.benettin_exact_ok && r.js.is_some_and(|j| j <= js_max)).count();
    (b10, both, sel.len())
}

/// Counts over flag rows: (rows, failed, Benettin target, D2 target, JS target, Benettin and
/// JS, Benettin and D2 and JS).
pub fn target_counts(rows: &[PipelineRow]) -> (usize, usize, usize, usize, usize, usize, usize) {
    let n = |f: &dyn Fn(&[bool; 4]) -> bool| rows.iter().filter(|r| f(&r.passes)).count();
    (
        rows.len(),
        rows.iter().filter(|r| r.failed.is_some()).count(),
        n(&|p| p[0]),
        n(&|p| p[2]),
        n(&|p| p[3]),
        n(&|p| p[0] && p[3]),
        n(&|p| p[0] && p[2] && p[3]),
    )
}

/// The held-out observed series of `sys` subsampled at the map step (for [`projection_fnn`]).
pub fn held_out_at_step(series: &[TimeSeries], step: usize) -> Result<TimeSeries, Error> {
    let last = series.last().ok_or(Error::BadInput { what: "series", why: "none given".into() })?;
    subsample(last, step, 0)
}
