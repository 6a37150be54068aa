//! Largest Lyapunov exponent of a smooth model (Benettin et al.), and bounded iteration.
//!
//! - [`benettin_tangent`]: the caller supplies a step that advances the state and a
//!   tangent vector together (`v <- DF(x) v`, e.g. from an exact Jacobian, forward-mode AD,
//!   or an RK4 step of the variational equations of a flow). The tangent vector is
//!   renormalized every `renorm_every` steps and the logs of its growth are summed.
//! - [`benettin_two_trajectory`]: only a step map is known; a companion trajectory at
//!   distance `d0` is renormalized back to `d0` every `renorm_every` steps. For a smooth
//!   model and small `d0` this equals the tangent method; for a non-smooth (quantized)
//!   model it is a finite-size exponent at scale `d0`, so state the scale.
//!
//! The exponent is per unit of `time_step` (1 for a map; the integration step `h` for a
//! flow's step map). A transient of `transient` steps is discarded first (the tangent vector
//! is also evolved over it so it aligns with the most unstable direction). The measurement
//! is split into `blocks` equal blocks; the error bar is the standard deviation of the block
//! exponents divided by `sqrt(blocks)`. Every step is checked: a non-finite state or one
//! with `max |x_i| > bound` is returned as [`ChaosError::Escape`], never as NaN.

use crate::{ChaosError, Points, Result, at_least, mean_std, positive};

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BenettinParams {
    pub transient: usize,
    /// Measured steps (a multiple of `renorm_every * blocks` is used: the remainder is
    /// dropped and `BenettinResult::steps` says how many were measured).
    pub steps: usize,
    /// Time per step.
    pub time_step: f64,
    pub renorm_every: usize,
    /// Escape bound on `max |x_i|`.
    pub bound: f64,
    pub blocks: usize,
}

impl Default for BenettinParams {
    fn default() -> Self {
        Self { transient: 1000, steps: 100_000, time_step: 1.0, renorm_every: 1, bound: 1e6, blocks: 20 }
    }
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BenettinResult {
    pub exponent: f64,
    /// Standard deviation of the block exponents / sqrt(blocks).
    pub std_error: f64,
    pub block_exponents: Vec<f64>,
    /// Running estimate `(time since the transient, exponent so far)` at each block end.
    pub running: Vec<(f64, f64)>,
    pub steps: usize,
    pub final_state: Vec<f64>,
}

/// States of an iterated map kept every `record_every` steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Orbit {
    /// Recorded states (the initial state first), or `None` when nothing was recorded.
    pub recorded: Option<Points>,
    pub final_state: Vec<f64>,
    pub steps: usize,
}

fn inf_norm(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// `Ok(norm)` or the escape error for the state reached at `step`.
fn check_state(x: &[f64], step: usize, bound: f64, last_norm: f64) -> Result<f64> {
    if x.iter().any(|v| !v.is_finite()) {
        return Err(ChaosError::Escape { step, norm: last_norm, reason: "non-finite state" });
    }
    let n = inf_norm(x);
    if n > bound {
        return Err(ChaosError::Escape { step, norm: n, reason: "state left the bound" });
    }
    Ok(n)
}

fn check_params(x0: &[f64], p: &BenettinParams) -> Result<()> {
    if x0.is_empty() {
        return Err(ChaosError::Shape { what: "initial state", expected: 1, got: 0 });
    }
    crate::check_finite(x0, x0.len())?;
    positive("time_step", p.time_step)?;
    positive("bound", p.bound)?;
    at_least("renorm_every", p.renorm_every, 1)?;
    at_least("blocks", p.blocks, 2)?;
    let need = p.renorm_every * p.blocks;
    if p.steps < need {
        return Err(ChaosError::TooShort { param: "steps (renorm_every * blocks)", have: p.steps, need });
    }
    Ok(())
}

/// Shared driver: `advance(k)` does `renorm_every` steps and returns the log growth of the
/// separation (already renormalized), or an error.
fn drive(p: &BenettinParams, mut advance: impl FnMut(usize) -> Result<f64>) -> Result<BenettinResult> {
    let chunks_per_block = p.steps / (p.renorm_every * p.blocks);
    let block_time = (chunks_per_block * p.renorm_every) as f64 * p.time_step;
    let mut step = p.transient;
    let mut total = 0.0;
    let mut block_exponents = Vec::with_capacity(p.blocks);
    let mut running = Vec::with_capacity(p.blocks);
    for b in 0..p.blocks {
        let mut s = 0.0;
        for _ in 0..chunks_per_block {
            s += advance(step)?;
            step += p.renorm_every;
        }
        total += s;
        block_exponents.push(s / block_time);
        running.push(((b + 1) as f64 * block_time, total / ((b + 1) as f64 * block_time)));
    }
    let (_, sd) = mean_std(&block_exponents);
    Ok(BenettinResult {
        exponent: total / (p.blocks as f64 * block_time),
        std_error: sd / (p.blocks as f64).sqrt(),
        block_exponents,
        running,
        steps: p.blocks * chunks_per_block * p.renorm_every,
        final_state: Vec::new(),
    })
}

/// Benettin with a tangent map: `step(x, v)` advances `x` by one step and sets
/// `v <- DF(x_old) v`.
pub fn benettin_tangent<F>(x0: &[f64], mut step: F, p: &BenettinParams) -> Result<BenettinResult>
where
    F: FnMut(&mut [f64], &mut [f64]),
{
    check_params(x0, p)?;
    let d = x0.len();
    let mut x = x0.to_vec();
    // A generic start direction (not aligned with a coordinate axis).
    let mut v: Vec<f64> = (0..d).map(|k| 1.0 + 0.1 * k as f64).collect();
    normalize(&mut v);
    let mut last = inf_norm(&x);
    for k in 0..p.transient {
        step(&mut x, &mut v);
        last = check_state(&x, k + 1, p.bound, last)?;
        let g = norm2(&v);
        if !(g.is_finite() && g > 0.0) {
            return Err(ChaosError::Collapsed { step: k + 1 });
        }
        v.iter_mut().for_each(|c| *c /= g);
    }
    let mut res = drive(p, |start| {
        for k in 0..p.renorm_every {
            step(&mut x, &mut v);
            last = check_state(&x, start + k + 1, p.bound, last)?;
        }
        let g = norm2(&v);
        if !(g.is_finite() && g > 0.0) {
            return Err(ChaosError::Collapsed { step: start + p.renorm_every });
        }
        v.iter_mut().for_each(|c| *c /= g);
        Ok(g.ln())
    })?;
    res.final_state = x;
    Ok(res)
}

/// Benettin with two trajectories at separation `d0` (Euclidean), renormalized every
/// `renorm_every` steps; `step(x)` advances `x` in place.
pub fn benettin_two_trajectory<F>(x0: &[f64], mut step: F, d0: f64, p: &BenettinParams) -> Result<BenettinResult>
where
    F: FnMut(&mut [f64]),
{
    check_params(x0, p)?;
    positive("d0", d0)?;
    let d = x0.len();
    let mut x = x0.to_vec();
    let mut last = inf_norm(&x);
    for k in 0..p.transient {
        step(&mut x);
        last = check_state(&x, k + 1, p.bound, last)?;
    }
    let mut dir: Vec<f64> = (0..d).map(|k| 1.0 + 0.1 * k as f64).collect();
    normalize(&mut dir);
    let mut y: Vec<f64> = x.iter().zip(&dir).map(|(a, e)| a + d0 * e).collect();
    let mut res = drive(p, |start| {
        for k in 0..p.renorm_every {
            step(&mut x);
            step(&mut y);
            last = check_state(&x, start + k + 1, p.bound, last)?;
            check_state(&y, start + k + 1, p.bound, last)?;
        }
        let sep = x.iter().zip(&y).map(|(a, b)| (b - a) * (b - a)).sum::<f64>().sqrt();
        if sep == 0.0 {
            return Err(ChaosError::Collapsed { step: start + p.renorm_every });
        }
        for (yc, xc) in y.iter_mut().zip(x.iter()) {
            *yc = xc + (*yc - xc) * d0 / sep;
        }
        Ok((sep / d0).ln())
    })?;
    res.final_state = x;
    Ok(res)
}

/// Tangent step for a map given as `f(x, out)` and its Jacobian `jac(x, out)` (row-major
/// `d x d`), for use with [`benettin_tangent`].
pub fn jacobian_tangent_step<F, J>(dim: usize, f: F, jac: J) -> impl FnMut(&mut [f64], &mut [f64])
where
    F: Fn(&[f64], &mut [f64]),
    J: Fn(&[f64], &mut [f64]),
{
    let mut next = vec![0.0; dim];
    let mut jm = vec![0.0; dim * dim];
    let mut w = vec![0.0; dim];
    move |x: &mut [f64], v: &mut [f64]| {
        jac(x, &mut jm);
        for r in 0..dim {
            w[r] = (0..dim).map(|c| jm[r * dim + c] * v[c]).sum();
        }
        v.copy_from_slice(&w);
        f(x, &mut next);
        x.copy_from_slice(&next);
    }
}

/// Iterate `f(x, out)` for `steps` steps from `x0`, checking every state; record every
/// `record_every`-th state (0: none). Escape (non-finite or `max |x_i| > bound`) is an
/// error carrying the step.
pub fn iterate_map<F>(x0: &[f64], mut f: F, steps: usize, bound: f64, record_every: usize) -> Result<Orbit>
where
    F: FnMut(&[f64], &mut [f64]),
{
    if x0.is_empty() {
        return Err(ChaosError::Shape { what: "initial state", expected: 1, got: 0 });
    }
    positive("bound", bound)?;
    let mut x = x0.to_vec();
    let mut last = check_state(&x, 0, bound, f64::NAN)?;
    let mut next = vec![0.0; x.len()];
    let mut rec = Vec::new();
    if record_every > 0 {
        rec.extend_from_slice(&x);
    }
    for k in 1..=steps {
        f(&x, &mut next);
        std::mem::swap(&mut x, &mut next);
        last = check_state(&x, k, bound, last)?;
        if record_every > 0 && k % record_every == 0 {
            rec.extend_from_slice(&x);
        }
    }
    let recorded = if record_every > 0 { Some(Points::from_flat(x.len(), rec)?) } else { None };
    Ok(Orbit { recorded, final_state: x, steps })
}

fn norm2(v: &[f64]) -> f64 {
    v.iter().map(|c| c * c).sum::<f64>().sqrt()
}

fn normalize(v: &mut [f64]) {
    let g = norm2(v);
    v.iter_mut().for_each(|c| *c /= g);
}

/// The `k` largest Lyapunov exponents of a smooth map by Benettin's method with QR
/// re-orthonormalization ([`benettin_qr`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SpectrumResult {
    /// Exponents per unit of `time_step`, largest first (the order QR produces them).
    pub exponents: Vec<f64>,
    /// Per exponent: standard deviation of the block values / sqrt(blocks).
    pub std_error: Vec<f64>,
    /// Kaplan-Yorke dimension `j + (l_1 + ... + l_j) / |l_{j+1}|` from the measured
    /// exponents, or `None` when their partial sums never turn negative (`k` too small).
    pub kaplan_yorke: Option<f64>,
    pub steps: usize,
    pub final_state: Vec<f64>,
}

/// Benettin's method with `k` tangent vectors and QR re-orthonormalization (modified
/// Gram-Schmidt) every `renorm_every` steps. `f(x, out)` is the map, `jac(x, out)` its
/// row-major `d x d` Jacobian at `x`; `jac` returns `Err(reason)` where the map is not
/// differentiable (e.g. a linear-kernel RBF map exactly at a centre), which is reported as
/// [`ChaosError::NotDifferentiable`] with the step. The `i`-th exponent is the mean log of
/// the `i`-th diagonal entry of `R`. State checks, transient and blocks as in
/// [`benettin_tangent`] (the tangent frame is evolved over the transient too).
pub fn benettin_qr<F, J>(x0: &[f64], mut f: F, mut jac: J, k: usize, p: &BenettinParams) -> Result<SpectrumResult>
where
    F: FnMut(&[f64], &mut [f64]),
    J: FnMut(&[f64], &mut [f64]) -> std::result::Result<(), &'static str>,
{
    check_params(x0, p)?;
    let d = x0.len();
    if k == 0 || k > d {
        return Err(ChaosError::BadParameter {
            name: "k (tangent vectors)",
            value: k as f64,
            reason: "need 1 <= k <= state dimension",
        });
    }
    let mut x = x0.to_vec();
    let mut next = vec![0.0; d];
    let mut jm = vec![0.0; d * d];
    // Frame: k vectors of length d, row-major; a generic start (not axis aligned).
    let mut q: Vec<f64> = (0..k * d)
        .map(|i| ((i * 7919 % 101) as f64 / 101.0) - 0.5 + if i % (d + 1) == 0 { 1.0 } else { 0.0 })
        .collect();
    let mut w = vec![0.0; k * d];
    let mut logs = vec![0.0; k];
    gram_schmidt(&mut q, d, k, &mut logs).ok_or(ChaosError::Collapsed { step: 0 })?;
    let mut last = inf_norm(&x);
    let mut one_step = |x: &mut Vec<f64>, q: &mut Vec<f64>, step: usize, last: &mut f64| -> Result<()> {
        jac(x, &mut jm).map_err(|reason| ChaosError::NotDifferentiable { step, reason })?;
        for v in 0..k {
            for r in 0..d {
                w[v * d + r] = (0..d).map(|c| jm[r * d + c] * q[v * d + c]).sum();
            }
        }
        q.copy_from_slice(&w);
        f(x, &mut next);
        x.copy_from_slice(&next);
        *last = check_state(x, step + 1, p.bound, *last)?;
        Ok(())
    };
    for s in 0..p.transient {
        one_step(&mut x, &mut q, s, &mut last)?;
        if (s + 1) % p.renorm_every == 0 || s + 1 == p.transient {
            gram_schmidt(&mut q, d, k, &mut logs).ok_or(ChaosError::Collapsed { step: s + 1 })?;
        }
    }
    let chunks_per_block = p.steps / (p.renorm_every * p.blocks);
    let block_time = (chunks_per_block * p.renorm_every) as f64 * p.time_step;
    let mut step = p.transient;
    let mut totals = vec![0.0; k];
    let mut blocks = vec![Vec::with_capacity(p.blocks); k];
    for _ in 0..p.blocks {
        let mut sums = vec![0.0; k];
        for _ in 0..chunks_per_block {
            for _ in 0..p.renorm_every {
                one_step(&mut x, &mut q, step, &mut last)?;
                step += 1;
            }
            gram_schmidt(&mut q, d, k, &mut logs).ok_or(ChaosError::Collapsed { step })?;
            sums.iter_mut().zip(&logs).for_each(|(s, l)| *s += l);
        }
        for i in 0..k {
            totals[i] += sums[i];
            blocks[i].push(sums[i] / block_time);
        }
    }
    let total_time = p.blocks as f64 * block_time;
    let exponents: Vec<f64> = totals.iter().map(|t| t / total_time).collect();
    let std_error = blocks.iter().map(|b| mean_std(b).1 / (p.blocks as f64).sqrt()).collect();
    Ok(SpectrumResult {
        kaplan_yorke: kaplan_yorke(&exponents),
        exponents,
        std_error,
        steps: p.blocks * chunks_per_block * p.renorm_every,
        final_state: x,
    })
}

/// Kaplan-Yorke dimension of exponents sorted largest first (`None` if the partial sums
/// stay non-negative through the last one). All negative: 0.
pub fn kaplan_yorke(exponents: &[f64]) -> Option<f64> {
    let mut sum = 0.0;
    for (j, &l) in exponents.iter().enumerate() {
        if sum + l < 0.0 {
            return Some(j as f64 + sum / l.abs());
        }
        sum += l;
    }
    None
}

/// Modified Gram-Schmidt on the `k` rows (length `d`) of `q`, in place; `logs[i]` gets
/// `ln R_ii`. `None` if a vector collapses (zero or non-finite norm).
fn gram_schmidt(q: &mut [f64], d: usize, k: usize, logs: &mut [f64]) -> Option<()> {
    for i in 0..k {
        for j in 0..i {
            let dot: f64 = (0..d).map(|c| q[i * d + c] * q[j * d + c]).sum();
            for c in 0..d {
                q[i * d + c] -= dot * q[j * d + c];
            }
        }
        let n = norm2(&q[i * d..(i + 1) * d]);
        if !(n.is_finite() && n > 0.0) {
            return None;
        }
        q[i * d..(i + 1) * d].iter_mut().for_each(|c| *c /= n);
        logs[i] = n.ln();
    }
    Some(())
}
