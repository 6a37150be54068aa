//! Multi-step (trajectory) refinement of a fitted RBF map: starting from the one-step ridge
//! solution, the coefficients (kernel weights, linear rows and constant row; the centres and
//! the kernel stay) are refined to minimize the `h`-step rollout error on the training
//! trajectories, ridge kept.
//!
//! Loss, over windows of `h + 1` consecutive training points (a window starts every
//! `stride` points of every trajectory):
//!
//! `L(W) = (1 / R) sum_windows sum_{j=1..h} ||F_W^j(eta_s) - eta_{s+j}||^2 + (lambda / (N d)) ||W||_F^2`
//!
//! with `R` the number of residual entries (windows x h x d), `lambda = alpha s_max^2` and
//! `N` the ridge and rows of the one-step regression ([`RbfMap::conditioning`]). With
//! `h = 1` and `stride = 1` this is the one-step ridge objective itself, whose minimizer the
//! map already holds. Minimized by Levenberg-Marquardt: the rollout's sensitivities
//! `S_j = dF_W^j / dW` are propagated forward with the map's Jacobian,
//! `S_j = DF(eta_{j-1}) S_{j-1} + dF/dW(eta_{j-1})`, and the Gauss-Newton matrix `J^T J`
//! is accumulated block by block (lower triangle). A step is kept only when the loss
//! decreases; a rollout that leaves the finite numbers or goes beyond
//! [`ESCAPE_FACTOR`] times the training data's largest `|eta_i|` counts as an infinite loss.
//! The horizon is reached by doubling from 2 (`2, 4, ..., h`), each stage starting from the
//! previous one's coefficients: long rollouts of a chaotic map make a rough loss landscape,
//! short ones start close to the one-step solution.
//!
//! Cost: the normal matrix has `P = (centres + d + 1) d` rows (820 for 200 centres in 4D);
//! forming it is `R P^2 / 2` multiply-adds per iteration; a `stride` above 1 divides `R`
//! (windows that tile the data at `stride = h`), at some cost in accuracy.

// Index loops mirror the formulas over small fixed dimensions.
#![allow(clippy::needless_range_loop)]

use faer::linalg::matmul::triangular::{BlockStructure, matmul};
use faer::{Accum, Mat, Par, Side};
use serde::{Deserialize, Serialize};

use super::dynamics::{EtaTrajectory, RbfMap};
use super::error::FitError;

/// A rollout whose reduced coordinates exceed this multiple of the training data's largest
/// `|eta_i|` counts as an infinite loss (the step that led there is refused).
pub const ESCAPE_FACTOR: f64 = 10.0;

/// Options of [`refine_multistep`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MultiStep {
    /// Rollout horizon `h` in map steps (>= 1); reached by doubling from 2.
    pub horizon: usize,
    /// A window starts every `stride` points (>= 1). 1 (every point starts a window) fits
    /// best; larger strides divide the cost (on the twist map of the tests, stride = horizon
    /// lowers the 16-step error less than stride 1 does, and worsens the map).
    pub stride: usize,
    /// Levenberg-Marquardt iterations per stage (>= 1).
    pub iterations: usize,
}

/// What [`refine_multistep`] did, per stage.
#[derive(Clone, Debug, Serialize)]
pub struct StageReport {
    pub horizon: usize,
    pub windows: usize,
    /// Rollout RMS error `sqrt(sum ||e||^2 / R)` (no ridge term) before and after the stage.
    pub rms_before: f64,
    pub rms_after: f64,
    /// Loss (with the ridge term) before and after.
    pub loss_before: f64,
    pub loss_after: f64,
    /// Steps kept / tried.
    pub accepted: usize,
    pub tried: usize,
}

/// Checks the options alone.
impl MultiStep {
    pub fn validate(&self) -> Result<(), FitError> {
        let bad = |why: String| Err(FitError::BadOption { what: "multistep", why });
        if self.horizon == 0 {
            return bad("the horizon must be >= 1 map step".into());
        }
        if self.stride == 0 {
            return bad("the window stride must be >= 1 point".into());
        }
        if self.iterations == 0 {
            return bad("the Levenberg-Marquardt iterations per stage must be >= 1".into());
        }
        crate::limits::check("multistep horizon", self.horizon, 100_000)?;
        Ok(())
    }

    /// The stages' horizons: 2, 4, ... below `horizon`, then `horizon` (just `[1]` for 1).
    pub fn stages(&self) -> Vec<usize> {
        let mut out = Vec::new();
        let mut h = 2;
        while h < self.horizon {
            out.push(h);
            h *= 2;
        }
        out.push(self.horizon);
        out
    }
}

/// `eta -> F(eta)` with its Jacobian `DF(eta)` (row-major d x d) and the features `phi(eta)`.
fn step_jacobian(map: &RbfMap, eta: &[f64], feat: &mut [f64], next: &mut [f64], jac: &mut [f64]) {
    let d = map.dim;
    let k = map.n_centers();
    map.features(eta, feat);
    next.copy_from_slice(eta);
    jac.fill(0.0);
    for i in 0..d {
        jac[i * d + i] = 1.0;
    }
    for (r, f) in feat.iter().enumerate() {
        for o in 0..d {
            next[o] += map.coef[r * d + o] * f;
        }
    }
    for c in 0..k {
        let ctr = &map.centers[c * d..(c + 1) * d];
        let r = ctr.iter().zip(eta).zip(&map.scale).map(|((c, e), s)| (e / s - c).powi(2)).sum::<f64>().sqrt();
        // The linear kernel's kink at a centre: the zero subgradient.
        let Some(g) = map.kernel.dphi_over_r(r) else { continue };
        for j in 0..d {
            let dz = g * (eta[j] / map.scale[j] - ctr[j]) / map.scale[j];
            for o in 0..d {
                jac[o * d + j] += map.coef[c * d + o] * dz;
            }
        }
    }
    for j in 0..d {
        for o in 0..d {
            jac[o * d + j] += map.coef[(k + j) * d + o] / map.scale[j];
        }
    }
}

/// Window starts `(trajectory, first row)` for horizon `h` and `stride`.
fn windows(trajs: &[EtaTrajectory<'_>], h: usize, stride: usize) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (t, tr) in trajs.iter().enumerate() {
        let n = tr.eta.nrows();
        if n > h {
            out.extend((0..n - h).step_by(stride).map(|s| (t, s)));
        }
    }
    out
}

/// Sum of squared rollout errors over the windows, or `None` when a rollout escapes.
fn rollout_sse(map: &RbfMap, trajs: &[EtaTrajectory<'_>], win: &[(usize, usize)], h: usize, bound: f64) -> Option<f64> {
    let d = map.dim;
    let mut feat = Vec::new();
    let mut eta = vec![0.0; d];
    let mut sse = 0.0;
    for &(t, s) in win {
        let e = trajs[t].eta;
        for i in 0..d {
            eta[i] = e[(s, i)];
        }
        for j in 1..=h {
            map.step(&mut eta, &mut feat);
            if !eta.iter().all(|v| v.is_finite() && v.abs() <= bound) {
                return None;
            }
            sse += (0..d).map(|i| (eta[i] - e[(s + j, i)]).powi(2)).sum::<f64>();
        }
    }
    Some(sse)
}

/// Rows of the residual blocks accumulated into the normal matrix at once.
const BLOCK_ROWS: usize = 512;

/// Gauss-Newton normal matrix (lower triangle) and gradient of the data term, unscaled:
/// `J^T J`, `J^T e`.
fn normal_equations(
    map: &RbfMap,
    trajs: &[EtaTrajectory<'_>],
    win: &[(usize, usize)],
    h: usize,
) -> (Mat<f64>, Vec<f64>) {
    let d = map.dim;
    let nf = map.n_centers() + d + 1;
    let p = nf * d;
    let mut jtj = Mat::<f64>::zeros(p, p);
    let mut jte = vec![0.0; p];
    let mut block = Mat::<f64>::zeros(BLOCK_ROWS, p);
    let mut res = vec![0.0; BLOCK_ROWS];
    let mut rows = 0;
    let (mut feat, mut eta, mut next, mut jac) = (vec![0.0; nf], vec![0.0; d], vec![0.0; d], vec![0.0; d * d]);
    // S (d x p) and the product DF S.
    let (mut sens, mut tmp) = (vec![0.0; d * p], vec![0.0; d * p]);
    let flush = |block: &Mat<f64>, res: &[f64], rows: usize, jtj: &mut Mat<f64>, jte: &mut [f64]| {
        if rows == 0 {
            return;
        }
        let b = block.as_ref().subrows(0, rows);
        matmul(
            jtj.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Add,
            b.transpose(),
            BlockStructure::Rectangular,
            b,
            BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        );
        for r in 0..rows {
            let e = res[r];
            if e != 0.0 {
                for c in 0..p {
                    jte[c] += b[(r, c)] * e;
                }
            }
        }
    };
    for &(t, s) in win {
        let e = trajs[t].eta;
        for i in 0..d {
            eta[i] = e[(s, i)];
        }
        sens.fill(0.0);
        for j in 1..=h {
            step_jacobian(map, &eta, &mut feat, &mut next, &mut jac);
            // S <- DF S + dF/dW; dF_o/dW[r, o] = phi_r, parameter index r d + o.
            for a in 0..d {
                let row = &mut tmp[a * p..(a + 1) * p];
                row.fill(0.0);
                for b in 0..d {
                    let w = jac[a * d + b];
                    if w != 0.0 {
                        for (x, y) in row.iter_mut().zip(&sens[b * p..(b + 1) * p]) {
                            *x += w * y;
                        }
                    }
                }
                for r in 0..nf {
                    row[r * d + a] += feat[r];
                }
            }
            std::mem::swap(&mut sens, &mut tmp);
            eta.copy_from_slice(&next);
            for a in 0..d {
                for c in 0..p {
                    block[(rows, c)] = sens[a * p + c];
                }
                res[rows] = eta[a] - e[(s + j, a)];
                rows += 1;
                if rows == BLOCK_ROWS {
                    flush(&block, &res, rows, &mut jtj, &mut jte);
                    rows = 0;
                }
            }
        }
    }
    flush(&block, &res, rows, &mut jtj, &mut jte);
    (jtj, jte)
}

/// Refines `map`'s coefficients in place to minimize the multi-step loss on `trajs` (see
/// the module docs); the trajectories are those the map was fitted to (same step). Returns
/// what each stage did. Bad options, trajectories of the wrong dimension, too few windows
/// or a too large problem are errors naming what is wrong; a stage whose every step is
/// refused leaves the coefficients as they were.
pub fn refine_multistep(
    map: &mut RbfMap,
    trajs: &[EtaTrajectory<'_>],
    opts: &MultiStep,
) -> Result<Vec<StageReport>, FitError> {
    opts.validate()?;
    let d = map.dim;
    let nf = map.n_centers() + d + 1;
    let p = nf * d;
    if trajs.is_empty() {
        return Err(FitError::NoTrainingData);
    }
    if let Some(t) = trajs.iter().position(|t| t.eta.ncols() != d) {
        return Err(FitError::DimMismatch {
            name: format!("multistep training trajectory {t}"),
            got: trajs[t].eta.ncols(),
            expected: d,
        });
    }
    if map.coef.len() != p || map.scale.len() != d {
        return Err(FitError::BadOption {
            what: "multistep",
            why: format!("the RBF map has {} coefficients, {p} expected", map.coef.len()),
        });
    }
    crate::limits::check_matrix("multistep normal matrix", p, p, false)?;
    let data_max = trajs
        .iter()
        .flat_map(|t| (0..t.eta.nrows()).flat_map(move |i| (0..d).map(move |j| t.eta[(i, j)].abs())))
        .fold(0.0, f64::max);
    let bound = ESCAPE_FACTOR * data_max;
    let c = map.conditioning;
    let n1 = c.rows.max(1) as f64;
    // Ridge weight per residual entry, as in the one-step objective.
    let ridge = c.alpha * c.s_max * c.s_max / (n1 * d as f64);
    let mut reports = Vec::new();
    for h in opts.stages() {
        let win = windows(trajs, h, opts.stride);
        let r_entries = (win.len() * h * d) as f64;
        if win.len() * h * d < p {
            return Err(FitError::Underdetermined {
                what: "multistep refinement (residual entries vs coefficients)",
                rows: win.len() * h * d,
                cols: p,
            });
        }
        let norm2 = |m: &RbfMap| m.coef.iter().map(|v| v * v).sum::<f64>();
        let loss =
            |m: &RbfMap| rollout_sse(m, trajs, &win, h, bound).map(|sse| (sse / r_entries + ridge * norm2(m), sse));
        let Some((mut l, sse0)) = loss(map) else {
            return Err(FitError::BadOption {
                what: "multistep",
                why: format!(
                    "the starting map's {h}-step rollouts escape the data (beyond {ESCAPE_FACTOR} x max |eta_i|)"
                ),
            });
        };
        let mut rep = StageReport {
            horizon: h,
            windows: win.len(),
            rms_before: (sse0 / r_entries).sqrt(),
            rms_after: 0.0,
            loss_before: l,
            loss_after: l,
            accepted: 0,
            tried: 0,
        };
        let mut sse = sse0;
        let mut mu = 1e-3;
        let mut fresh = true;
        let (mut jtj, mut jte) = (Mat::<f64>::zeros(0, 0), Vec::new());
        for _ in 0..opts.iterations {
            if fresh {
                (jtj, jte) = normal_equations(map, trajs, &win, h);
                fresh = false;
            }
            // (H + mu diag H) delta = -g, H = J^T J / R + ridge I, g = J^T e / R + ridge w.
            // (a floor of 1e-12 of the largest diagonal keeps an unregularized H definite).
            let floor = 1e-12 * (0..p).map(|j| jtj[(j, j)] / r_entries).fold(0.0, f64::max);
            let mut a = Mat::<f64>::zeros(p, p);
            for j in 0..p {
                for i in j..p {
                    a[(i, j)] = jtj[(i, j)] / r_entries;
                }
                a[(j, j)] += ridge;
                a[(j, j)] = a[(j, j)] * (1.0 + mu) + mu * floor;
            }
            let g = Mat::<f64>::from_fn(p, 1, |i, _| -(jte[i] / r_entries + ridge * map.coef[i]));
            rep.tried += 1;
            let Ok(llt) = a.llt(Side::Lower) else {
                mu *= 10.0;
                continue;
            };
            let delta = faer::linalg::solvers::Solve::solve(&llt, &g);
            let mut trial = map.clone();
            for i in 0..p {
                trial.coef[i] += delta[(i, 0)];
            }
            match loss(&trial) {
                Some((lt, st)) if lt < l => {
                    let gain = (l - lt) / l.max(f64::MIN_POSITIVE);
                    *map = trial;
                    (l, sse) = (lt, st);
                    rep.accepted += 1;
                    mu = (mu / 3.0).max(1e-12);
                    fresh = true;
                    if gain < 1e-9 {
                        break;
                    }
                }
                _ => mu *= 10.0,
            }
            if mu > 1e8 {
                break;
            }
        }
        rep.rms_after = (sse / r_entries).sqrt();
        rep.loss_after = l;
        reports.push(rep);
    }
    Ok(reports)
}

/// [`refine_multistep`] on a fitted model's RBF dynamics, with the reduced trajectories of
/// the training series `train` (the series the model was fitted to, through its own
/// embedding and manifold); the linear-part eigenvalues are updated. Polynomial dynamics
/// are an error.
pub fn refine_model(
    model: &mut crate::SsmModel,
    train: &[crate::TimeSeries],
    opts: &MultiStep,
) -> Result<Vec<StageReport>, FitError> {
    let crate::ReducedDynamics::Rbf(map) = &mut model.dynamics else {
        return Err(FitError::BadOption { what: "multistep", why: "applies to RBF map dynamics only".into() });
    };
    let (ys, dts) = crate::fit::embed_training(train, &model.options)?;
    if let Some(&dt) = dts.iter().find(|&&dt| (dt - map.dt).abs() > crate::dynamics::MAP_DT_RTOL * map.dt) {
        return Err(FitError::StepMismatch {
            name: "multistep training series".into(),
            dt,
            dt_model: map.dt,
            rtol: crate::dynamics::MAP_DT_RTOL,
        });
    }
    let etas: Vec<Mat<f64>> = ys.iter().map(|y| model.manifold.reduce_points(y.as_ref())).collect();
    let trajs: Vec<EtaTrajectory> = etas.iter().map(|e| EtaTrajectory { eta: e.as_ref(), dt: map.dt }).collect();
    let reports = refine_multistep(map, &trajs, opts)?;
    model.eigenvalues_ct = model.dynamics.eigenvalues_ct()?;
    Ok(reports)
}
