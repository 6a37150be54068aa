//! Why the flag's fit misses the known system's chaos, and what recovers it (issue 12,
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
use crate::model_selection::{Candidate, EvalSettings, add_noise, data_stats, subsample};

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
pub fn projection_fnn(x: &[f64], embed: usize, shift: usize, theiler: usize, dims: &[usize], ratio: f64, queries: usize) -> Result<Vec<FnnRow>, Error> {
    if embed < 2 || shift == 0 || queries == 0 || !(ratio > 0.0) || dims.iter().any(|&d| d == 0 || d >= embed) {
        return Err(Error::BadOption { what: "projection_fnn", why: format!("need embed >= 2, shift >= 1, queries >= 1, ratio > 0, 1 <= dim < embed (got {embed}, {shift}, {queries}, {ratio}, {dims:?})") });
    }
    let n = x.len().checked_sub((embed - 1) * shift).filter(|&n| n > 2 * theiler + 2).ok_or(Error::BadInput {
        what: "projection_fnn series",
        why: format!("{} samples are too few for embedding {embed} x {shift} and Theiler window {theiler}", x.len()),
    })?;
    let y = Mat::from_fn(embed, n, |i, j| x[j + i * shift]);
    let (v, sv) = ssm::manifold::tangent_space(std::slice::from_ref(&y), embed - 1).map_err(ssm::Error::from)?;
    // Coordinates in the singular basis (the last one completes it: the residual norm).
    let p = embed;
    let proj: Vec<Vec<f64>> = (0..n).map(|j| (0..p - 1).map(|c| (0..p).map(|i| v[c * p + i] * y[(i, j)]).sum()).collect()).collect();
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

/// A variant of the flag's candidates ([`crate::flag_pipeline::flag_like_candidates`]) at map
/// step `step`: RBF map with `centers` (0 = the polynomial map of order 4) and `ridge`, SSM
/// dimension `dim`, embedding `embed` with `shift`, manifold order 3, optional multistep
/// refinement and denoised inputs (half-width `denoise`, 0 = off).
#[allow(clippy::too_many_arguments)]
pub fn variant(step: usize, centers: usize, ridge: f64, dim: usize, embed: usize, shift: usize, multistep: Option<MultiStep>, denoise: usize) -> Candidate {
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
        fit: FitOptions { dim, embed, shift, manifold_order: 3, dyn_order: 4, dynamics, ridge: Ridge::Fixed(ridge), linear_anchor: None, anchor_joint: false },
        smooth: 0,
        multistep,
        denoise_inputs: denoise,
    }
}

/// The model class on the true state: options of [`state_model_check`].
#[derive(Clone, Copy, Debug, Serialize)]
pub struct StateFit {
    /// RBF centres (0 = polynomial map of order `order`).
    pub centers: usize,
    pub order: u32,
    pub ridge: f64,
    pub multistep: Option<MultiStep>,
    /// White noise on every state coordinate, times that coordinate's sd.
    pub noise_rel: f64,
}

impl StateFit {
    pub fn name(&self) -> String {
        let mut s = if self.centers == 0 { format!("state poly {}", self.order) } else { format!("state RBF {}", self.centers) };
        s += &format!(" r={:e}", self.ridge);
        if let Some(ms) = &self.multistep {
            s += &format!(" ms h={}", ms.horizon);
        }
        if self.noise_rel > 0.0 {
            s += &format!(" noise {}", self.noise_rel);
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

/// The map class fitted on the true state of `sys` (sampled as `layout`, training data
/// `scale` times the flag's, map step `layout.step`, every phase a trajectory as in the
/// flag's search) and measured like a candidate: Benettin from the held-out piece's first
/// state, the long run (5 held-out lengths) for escape, Rosenstein and D2 of its `x_1` with
/// the held-out data's settings, JS of the 4-D state PDFs against the held-out states. The
/// row's references are the held-out observed series' (as [`known_stats`]).
pub fn state_model_check(sys: &KnownSystem, layout: &FlagLayout, scale: usize, fit: &StateFit, benettin_time: f64) -> Result<(KnownStats, PipelineRow), Error> {
    let (stats, series) = known_stats(sys, layout, scale, benettin_time)?;
    let s = EvalSettings::default();
    let (_, ctx) = data_stats(&series[2], layout.step, &s)?;
    let mut states = sys.flag_like_states(stats.dt, &[layout.test, layout.train[0] * scale, layout.train[1] * scale])?;
    states.rotate_left(1);
    let dim = states[0].len() / (layout.train[0] * scale);
    if fit.noise_rel > 0.0 {
        for (i, piece) in states.iter_mut().take(2).enumerate() {
            for c in 0..dim {
                let col: Vec<f64> = piece.iter().skip(c).step_by(dim).copied().collect();
                let m = col.iter().sum::<f64>() / col.len() as f64;
                let sd = (col.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / col.len() as f64).sqrt();
                let noisy = add_noise(&col, fit.noise_rel * sd, 101 + (i * dim + c) as u64);
                for (k, v) in noisy.into_iter().enumerate() {
                    piece[k * dim + c] = v;
                }
            }
        }
    }
    let step_dt = stats.step_dt;
    let train: Vec<Mat<f64>> = states[..2].iter().flat_map(|p| (0..layout.step).map(move |o| state_rows(p, dim, layout.step, o))).collect();
    let trajs: Vec<EtaTrajectory> = train.iter().map(|e| EtaTrajectory { eta: e.as_ref(), dt: step_dt }).collect();
    let kind = if fit.centers == 0 { Dynamics::Map } else { Dynamics::Rbf { centers: fit.centers } };
    let mut dynamics = ReducedDynamics::fit(&trajs, kind, fit.order, Ridge::Fixed(fit.ridge))?;
    if let (Some(ms), ReducedDynamics::Rbf(map)) = (&fit.multistep, &mut dynamics) {
        refine_multistep(map, &trajs, ms)?;
    }
    let test = state_rows(&states[2], dim, layout.step, 0);
    let data_max = train.iter().flat_map(|m| (0..m.nrows()).flat_map(move |r| (0..dim).map(move |c| m[(r, c)].abs()))).fold(0.0, f64::max);
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
                if !(exc <= s.region_factor) {
                    failed = Some(format!("left the data's region: {exc:.2} x the data's largest |x_i|"));
                } else {
                    let x: Vec<f64> = (0..test.nrows().min(pts.len())).map(|i| pts.point(i)[0]).collect();
                    m.rosenstein = ctx.lle(&x, &mut Vec::new(), "state model").ok().map(|(l, _)| l);
                    m.corr_dim = delay_embed(&x, ctx.embed, ctx.lag)
                        .and_then(|p| correlation_dimension(&p, &CorrSumParams { theiler: ctx.theiler, ..Default::default() }, &ScalingRule::default()))
                        .ok()
                        .map(|c| c.dimension);
                    let flat: Vec<f64> = (0..test.nrows()).flat_map(|r| (0..dim).map(move |c| (r, c))).map(|(r, c)| test[(r, c)]).collect();
                    m.js = Points::from_flat(dim, flat).and_then(|a| chaos::compare_pdfs(&a, &pts, Bins::default())).ok().map(|c| c.mean_js_bits);
                }
            }
        },
    }
    let row = PipelineRow::from_values(&fit.name(), scale, &m, failed, stats.rosenstein, stats.corr_dim, stats.corr_dim_err, stats.exact);
    Ok((stats, row))
}

/// The held-out observed series of `sys` subsampled at the map step (for [`projection_fnn`]).
pub fn held_out_at_step(series: &[TimeSeries], step: usize) -> Result<TimeSeries, Error> {
    let last = series.last().ok_or(Error::BadInput { what: "series", why: "none given".into() })?;
    subsample(last, step, 0)
}

#[cfg(test)]
mod tests;
