//! SSM-reduced dynamics fitted to reduced-coordinate trajectories (paper appendix A,
//! "Data-driven modeling of the SSM-reduced dynamics").
//!
//! * [`ReducedDynamics::Flow`]: `eta' = R(eta)`, a polynomial of degrees 1..=K (no constant,
//!   the fixed point is the origin) fitted to derivatives from 4th-order central finite
//!   differences `(-e[n+2] + 8 e[n+1] - 8 e[n-1] + e[n-2]) / (12 dt)`, dropping two samples
//!   at each end of every trajectory. Integrated with classic RK4, [`RK4_SUBSTEPS`] steps
//!   per sample.
//! * [`ReducedDynamics::Map`]: `eta_{n+1} = eta_n + P(eta_n)`, P a polynomial of degrees
//!   1..=K. The regression target is the increment so that the ridge shrinks towards the
//!   identity map (no motion) instead of the zero map (spurious damping).
//! * [`ReducedDynamics::Rbf`]: `eta_{n+1} = eta_n + sum_i C_i phi(||z_n - c_i||) + A z_n + b`,
//!   by default the linear kernel `phi(r) = r` (Xu et al. 2024; [`Dynamics::Rbf`]), or a
//!   [`Kernel`] chosen with [`Dynamics::RbfWith`] (cubic `r^3`, thin-plate `r^2 ln r`,
//!   Gaussian `exp(-(eps r)^2)`), `z = eta / s` scaled like the polynomials,
//!   centres `c_i` a farthest-point subset of the (scaled) training points, started from the
//!   point of largest norm. The affine augmentation `A z + b` makes the regression well
//!   posed (the linear kernel alone is only conditionally positive definite). Coefficients
//!   are the ridge least-squares fit over all training pairs (not interpolation), solved
//!   through the SVD (see [`super::ridge`]).
//!
//! Linear part: for a flow, `DR(0)`; for a map, `DF(0)`, converted to continuous time by
//! `ln(mu) / dt`. For the RBF map the Jacobian at the origin is used (the linear kernel is
//! differentiable there unless a centre sits exactly at the origin, which is reported).

// Index loops mirror the formulas over small fixed dimensions.
#![allow(clippy::needless_range_loop)]

use faer::{Mat, MatRef};
use serde::{Deserialize, Serialize};

use super::error::FitError;
use super::manifold::{design_matrix, design_matrix_in};
use super::poly::{self, Poly, PolyScratch, PreparedPoly};
use super::ridge::{self, Conditioning, Ridge};
pub use super::weight::{LowDegreeStage, RowWeight};
use super::weight::{envelope, scale_rows};

/// RK4 steps per sampling interval when integrating a flow.
pub const RK4_SUBSTEPS: usize = 4;

/// Which reduced dynamics to fit.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Dynamics {
    /// Continuous-time polynomial vector field.
    Flow,
    /// Discrete-time polynomial map at the sampling step.
    Map,
    /// Discrete-time RBF map with the linear kernel and this many centres.
    Rbf { centers: usize },
    /// Discrete-time RBF map with this many centres and the given kernel
    /// (`RbfWith { centers, kernel: Kernel::Linear }` is `Rbf { centers }` exactly).
    RbfWith { centers: usize, kernel: Kernel },
}

impl Dynamics {
    /// Centres and kernel of an RBF map, `None` for polynomial dynamics.
    pub fn rbf(&self) -> Option<(usize, Kernel)> {
        match *self {
            Dynamics::Rbf { centers } => Some((centers, Kernel::Linear)),
            Dynamics::RbfWith { centers, kernel } => Some((centers, kernel)),
            Dynamics::Flow | Dynamics::Map => None,
        }
    }
}

/// Radial kernel `phi(r)` of an RBF map, `r = ||z - c||` in scaled coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Kernel {
    /// `phi(r) = r`, the paper's (Xu et al. 2024); conditionally positive definite of order 1.
    #[default]
    Linear,
    /// `phi(r) = r^3` (conditionally positive definite of order 2; the affine part covers it).
    Cubic,
    /// Thin-plate spline `phi(r) = r^2 ln r` (`phi(0) = 0`).
    ThinPlate,
    /// Gaussian `phi(r) = exp(-(eps r)^2)`, shape parameter `eps > 0` (in 1 / scaled units).
    Gaussian { eps: f64 },
}

impl Kernel {
    /// `phi(r)`.
    #[inline]
    pub fn phi(&self, r: f64) -> f64 {
        match *self {
            Kernel::Linear => r,
            Kernel::Cubic => r * r * r,
            Kernel::ThinPlate => {
                if r > 0.0 {
                    r * r * r.ln()
                } else {
                    0.0
                }
            }
            Kernel::Gaussian { eps } => (-(eps * r) * (eps * r)).exp(),
        }
    }

    /// `phi'(r) / r`: the gradient of `phi(||z - c||)` in `z` is this times `z - c`. `None`
    /// where it does not exist (the linear kernel at `r = 0`, its kink); the other kernels
    /// are differentiable everywhere (limits at `r = 0`: 0, 0, `-2 eps^2`).
    #[inline]
    pub fn dphi_over_r(&self, r: f64) -> Option<f64> {
        match *self {
            Kernel::Linear => {
                if r > 0.0 {
                    Some(1.0 / r)
                } else {
                    None
                }
            }
            Kernel::Cubic => Some(3.0 * r),
            Kernel::ThinPlate => Some(if r > 0.0 { 2.0 * r.ln() + 1.0 } else { 0.0 }),
            Kernel::Gaussian { eps } => Some(-2.0 * eps * eps * (-(eps * r) * (eps * r)).exp()),
        }
    }

    /// Checks the kernel's parameter (Gaussian: `eps` finite and positive).
    pub fn validate(&self) -> Result<(), FitError> {
        match *self {
            Kernel::Gaussian { eps } if !(eps.is_finite() && eps > 0.0) => Err(FitError::BadOption {
                what: "rbf kernel",
                why: format!("the Gaussian shape parameter eps must be finite and > 0, got {eps}"),
            }),
            _ => Ok(()),
        }
    }

    /// Short name: `linear`, `cubic`, `thin-plate`, `gaussian:EPS` (what [`Kernel::parse`] reads).
    pub fn name(&self) -> String {
        match *self {
            Kernel::Linear => "linear".into(),
            Kernel::Cubic => "cubic".into(),
            Kernel::ThinPlate => "thin-plate".into(),
            Kernel::Gaussian { eps } => format!("gaussian:{eps}"),
        }
    }

    /// Parses [`Kernel::name`]'s forms; an unknown name or a bad `eps` is an error saying so.
    pub fn parse(s: &str) -> Result<Self, FitError> {
        let bad = |why: String| FitError::BadOption { what: "rbf kernel", why };
        let k = match s {
            "linear" => Kernel::Linear,
            "cubic" => Kernel::Cubic,
            "thin-plate" => Kernel::ThinPlate,
            _ => match s.strip_prefix("gaussian:") {
                Some(e) => Kernel::Gaussian {
                    eps: e.parse().map_err(|_| bad(format!("`{e}` in `{s}` is not a number (gaussian:EPS)")))?,
                },
                None => return Err(bad(format!("`{s}` is not one of linear, cubic, thin-plate, gaussian:EPS"))),
            },
        };
        k.validate()?;
        Ok(k)
    }
}

/// A fitted reduced model.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub enum ReducedDynamics {
    Flow { field: Poly, conditioning: Conditioning },
    Map { increment: Poly, dt: f64, conditioning: Conditioning },
    Rbf(RbfMap),
}

/// RBF map, kernel plus affine augmentation (see the module docs).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RbfMap {
    pub dim: usize,
    /// The radial kernel (saved models without the field are linear).
    #[serde(default)]
    pub kernel: Kernel,
    /// Sampling step of the map.
    pub dt: f64,
    /// Scaling `z = eta / scale` (the same value for every coordinate, see `fit`).
    pub scale: Vec<f64>,
    /// Centres in scaled coordinates, `centers.len() / dim` of them, row-major.
    pub centers: Vec<f64>,
    /// Coefficients, row-major `(n_centers + dim + 1) x dim`: kernel weights, then the
    /// linear rows (one per z coordinate), then the constant row.
    pub coef: Vec<f64>,
    pub conditioning: Conditioning,
}

impl RbfMap {
    pub fn n_centers(&self) -> usize {
        self.centers.len() / self.dim
    }

    /// The RBF features of the state `eta` into `out` (`n_centers() + dim + 1` values): the
    /// kernel of each centre's scaled distance, then the scaled state, then 1.
    pub fn features(&self, eta: &[f64], out: &mut [f64]) {
        let d = self.dim;
        let k = self.n_centers();
        // The scaled state once (the same quotients as per centre, so the same features).
        let mut z_stack = [0.0; 32];
        let mut z_heap = Vec::new();
        let z: &mut [f64] = if d <= z_stack.len() {
            &mut z_stack[..d]
        } else {
            z_heap.resize(d, 0.0);
            &mut z_heap
        };
        for ((z, e), s) in z.iter_mut().zip(eta).zip(&self.scale) {
            *z = e / s;
        }
        match d {
            2 => self.centre_features::<2>(z, &mut out[..k]),
            4 => self.centre_features::<4>(z, &mut out[..k]),
            6 => self.centre_features::<6>(z, &mut out[..k]),
            _ => {
                for i in 0..k {
                    let c = &self.centers[i * d..(i + 1) * d];
                    let r = c.iter().zip(z.iter()).map(|(c, z)| (z - c).powi(2)).sum::<f64>().sqrt();
                    out[i] = self.kernel.phi(r);
                }
            }
        }
        for j in 0..d {
            out[k + j] = eta[j] / self.scale[j];
        }
        out[k + d] = 1.0;
    }

    /// The centre features of [`RbfMap::features`] for `D` coordinates (`z` the scaled
    /// state): the same expression per centre with the length known at compile time, so the
    /// same operations in the same order.
    #[inline]
    fn centre_features<const D: usize>(&self, z: &[f64], out: &mut [f64]) {
        let mut zz = [0.0; D];
        zz.copy_from_slice(&z[..D]);
        for (c, o) in self.centers.chunks_exact(D).zip(out.iter_mut()) {
            let c: &[f64; D] = c.try_into().unwrap_or(&[0.0; D]);
            let r = c.iter().zip(zz.iter()).map(|(c, z)| (z - c).powi(2)).sum::<f64>().sqrt();
            *o = self.kernel.phi(r);
        }
    }

    /// Next state `eta_{n+1}` in place.
    pub fn step(&self, eta: &mut [f64], feat: &mut Vec<f64>) {
        let d = self.dim;
        let fused = match d {
            2 => self.step_fixed::<2>(eta),
            3 => self.step_fixed::<3>(eta),
            4 => self.step_fixed::<4>(eta),
            5 => self.step_fixed::<5>(eta),
            6 => self.step_fixed::<6>(eta),
            _ => false,
        };
        if fused {
            return;
        }
        feat.resize(self.n_centers() + d + 1, 0.0);
        self.features(eta, feat);
        for (r, f) in feat.iter().enumerate() {
            for j in 0..d {
                eta[j] += self.coef[r * d + j] * f;
            }
        }
    }

    /// [`RbfMap::step`] in dimension `D` known at compile time, in one pass over the centres:
    /// each feature is added to the state (kept in registers) as soon as it is formed, not
    /// stored first. Every feature is the same expression as [`RbfMap::features`]' (the
    /// distance from the scaled state `z = eta / s` of the step's start, the kernel of it,
    /// then the linear features `eta_j / s_j` of the start and the constant 1), and every
    /// coordinate adds `coef * feature` feature by feature in the same order: the same bits.
    /// `false` (nothing done) when the shapes do not fit `D`.
    #[inline]
    fn step_fixed<const D: usize>(&self, eta: &mut [f64]) -> bool {
        let k = self.n_centers();
        if eta.len() < D || self.scale.len() < D || self.coef.len() < (k + D + 1) * D {
            return false;
        }
        let e0: [f64; D] = core::array::from_fn(|j| eta[j]);
        let z: [f64; D] = core::array::from_fn(|j| e0[j] / self.scale[j]);
        let mut nx = e0;
        let (kern, lin) = self.coef.split_at(k * D);
        let dist = |c: &[f64]| -> f64 {
            let c: &[f64; D] = c.try_into().unwrap_or(&[0.0; D]);
            c.iter().zip(z.iter()).map(|(c, z)| (z - c).powi(2)).sum::<f64>().sqrt()
        };
        if self.kernel == Kernel::Linear {
            for (c, w) in self.centers.chunks_exact(D).zip(kern.chunks_exact(D)) {
                let f = dist(c);
                for j in 0..D {
                    nx[j] += w[j] * f;
                }
            }
        } else {
            for (c, w) in self.centers.chunks_exact(D).zip(kern.chunks_exact(D)) {
                let f = self.kernel.phi(dist(c));
                for j in 0..D {
                    nx[j] += w[j] * f;
                }
            }
        }
        for (j2, w) in lin.chunks_exact(D).take(D).enumerate() {
            let f = e0[j2] / self.scale[j2];
            for j in 0..D {
                nx[j] += w[j] * f;
            }
        }
        for j in 0..D {
            nx[j] += lin[D * D + j] * 1.0;
        }
        eta[..D].copy_from_slice(&nx);
        true
    }

    /// Jacobian of the map at the origin (row-major d x d), or `None` if a centre sits at
    /// the origin and the kernel is linear (not differentiable there).
    pub fn jacobian_at_origin(&self) -> Option<Vec<f64>> {
        let d = self.dim;
        let k = self.n_centers();
        let mut jac = vec![0.0; d * d];
        for i in 0..d {
            jac[i * d + i] = 1.0;
        }
        for c in 0..k {
            let ctr = &self.centers[c * d..(c + 1) * d];
            let r = ctr.iter().map(|v| v * v).sum::<f64>().sqrt();
            if self.kernel == Kernel::Linear {
                if r == 0.0 {
                    return None;
                }
                // d/d eta_j ||z - c|| at z = 0 = (0 - c_j) / r / scale_j.
                for out in 0..d {
                    let w = self.coef[c * d + out];
                    for j in 0..d {
                        jac[out * d + j] += w * (-ctr[j] / r) / self.scale[j];
                    }
                }
                continue;
            }
            // d/d eta_j phi(||z - c||) at z = 0 = phi'(r) / r (0 - c_j) / scale_j.
            let g = self.kernel.dphi_over_r(r)?;
            for out in 0..d {
                let w = self.coef[c * d + out];
                for j in 0..d {
                    jac[out * d + j] += w * g * (-ctr[j]) / self.scale[j];
                }
            }
        }
        for j in 0..d {
            for out in 0..d {
                jac[out * d + j] += self.coef[(k + j) * d + out] / self.scale[j];
            }
        }
        Some(jac)
    }
}

/// Reduced trajectories as `M_i x d` matrices (rows = time samples) with their steps.
pub struct EtaTrajectory<'a> {
    pub eta: MatRef<'a, f64>,
    pub dt: f64,
}

/// Per-coordinate max |eta| over all trajectories.
pub fn eta_scale(trajs: &[EtaTrajectory<'_>]) -> Vec<f64> {
    let d = trajs.first().map(|t| t.eta.ncols()).unwrap_or(0);
    (0..d)
        .map(|j| trajs.iter().flat_map(|t| (0..t.eta.nrows()).map(move |i| t.eta[(i, j)].abs())).fold(0.0, f64::max))
        .collect()
}

/// 4th-order central differences of the rows of `eta`, dropping two rows at each end.
/// Returns (points, derivatives), both `(M - 4) x d`.
pub fn central_diff4(eta: MatRef<'_, f64>, dt: f64) -> (Mat<f64>, Mat<f64>) {
    let m = eta.nrows().saturating_sub(4);
    let d = eta.ncols();
    let pts = Mat::from_fn(m, d, |i, j| eta[(i + 2, j)]);
    let der = Mat::from_fn(m, d, |i, j| {
        let n = i + 2;
        (-eta[(n + 2, j)] + 8.0 * eta[(n + 1, j)] - 8.0 * eta[(n - 1, j)] + eta[(n - 2, j)]) / (12.0 * dt)
    });
    (pts, der)
}

fn stack(parts: &[Mat<f64>]) -> (Mat<f64>, Vec<std::ops::Range<usize>>) {
    let n: usize = parts.iter().map(|p| p.nrows()).sum();
    let c = parts.first().map(|p| p.ncols()).unwrap_or(0);
    let mut out = Mat::<f64>::zeros(n, c);
    let mut groups = Vec::new();
    let mut off = 0;
    for p in parts {
        for i in 0..p.nrows() {
            for j in 0..c {
                out[(off + i, j)] = p[(i, j)];
            }
        }
        groups.push(off..off + p.nrows());
        off += p.nrows();
    }
    (out, groups)
}

/// Smallest number of anchor pairs per reduced coordinate for an anchored linear part.
pub const ANCHOR_MIN_ROWS_PER_DIM: usize = 10;

/// The rows of the plain anchor: points with `||x_i|| <= frac max ||x||`; at least
/// [`ANCHOR_MIN_ROWS_PER_DIM`] per coordinate, else an error naming the count.
fn anchor_rows(x: MatRef<'_, f64>, frac: f64) -> Result<Vec<usize>, FitError> {
    let (n, d) = (x.nrows(), x.ncols());
    let norm = |i: usize| (0..d).map(|j| x[(i, j)] * x[(i, j)]).sum::<f64>().sqrt();
    let r = frac * (0..n).map(norm).fold(0.0, f64::max);
    let rows: Vec<usize> = (0..n).filter(|&i| norm(i) <= r).collect();
    let need = ANCHOR_MIN_ROWS_PER_DIM * d;
    if rows.len() < need {
        return Err(FitError::BadOption {
            what: "linear_anchor",
            why: format!(
                "{} training pairs within {frac} of the largest |eta| ({r:.3e}), need at least {need}; raise the fraction or add small-amplitude data",
                rows.len()
            ),
        });
    }
    Ok(rows)
}

/// Copies the coefficient rows `part` into `w` from row `at` on (the anchored fit's linear
/// and higher-order parts into one coefficient matrix).
fn place_rows(w: &mut Mat<f64>, at: usize, part: MatRef<'_, f64>) {
    for k in 0..part.nrows() {
        for c in 0..part.ncols() {
            w[(at + k, c)] = part[(k, c)];
        }
    }
}

/// [`poly_regression`] on the design matrix of `x` (monomials `exps`, scaled by `scale`),
/// built here in parts so that the big regressions factorize their design matrix in its
/// own storage ([`ridge::fit_owned`]): the same solution and conditioning, at about a third
/// of the peak memory; the anchored and the weighted fits also solve through `Q^T b` without
/// forming `U` ([`ridge::fit_owned_qtb_no_residual`]): the same solution up to rounding, about half the
/// cost. The joint anchored fit takes the whole matrix. With row
/// factors `rows` (square roots of [`RowWeight`]'s weights) the fit is weighted: with a
/// plain anchor the linear part stays unweighted on the anchor rows and the higher orders
/// are weighted; the residual reported is the unweighted one of the whole fit; the joint
/// anchor is refused.
#[allow(clippy::too_many_arguments)]
fn poly_fit(
    x: MatRef<'_, f64>,
    scale: &[f64],
    exps: &[Vec<u32>],
    y: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    ridge: Ridge,
    anchor: Option<f64>,
    joint: bool,
    rows: Option<&[f64]>,
    low: Option<(usize, &[f64])>,
    what: &'static str,
) -> Result<(Mat<f64>, Conditioning), FitError> {
    // A monomial's column depends on nothing else: parts of the matrix are its columns.
    let design = |e: &[Vec<u32>]| design_matrix(x, scale, e);
    let design_in = |buf: Mat<f64>, e: &[Vec<u32>]| design_matrix_in(buf, x, scale, e);
    let (d, nm) = (x.ncols(), exps.len());
    if let Some(f) = rows {
        if f.len() != x.nrows() {
            return Err(FitError::BadOption {
                what: "row weights",
                why: format!("{} factors for {} rows", f.len(), x.nrows()),
            });
        }
        if anchor.is_some() && joint {
            return Err(FitError::BadOption {
                what: "row weights",
                why: "not supported with the joint anchor (anchor_joint)".into(),
            });
        }
    }
    // Weighted least squares: the regression's rows scaled by the factors (without: as is).
    let weigh = |m: Mat<f64>| match rows {
        Some(f) => scale_rows(m, f),
        None => m,
    };
    if let Some((n_low, f)) = low {
        if rows.is_none()
            || anchor.is_none()
            || joint
            || n_low == 0
            || n_low >= nm.saturating_sub(d)
            || f.len() != x.nrows()
        {
            return Err(FitError::BadOption {
                what: "row weight low-degree stage",
                why: format!(
                    "needs row weights, the plain linear anchor and 2 <= max_degree < the order ({n_low} low monomials of {})",
                    nm.saturating_sub(d)
                ),
            });
        }
    }
    let frac = match anchor {
        // The plain fit keeps the `U` solve, bit for bit as before: the chaos study's map
        // models are fitted this way, and their finite-time Lyapunov and PDF statistics turn a
        // rounding change of the coefficients into changes of several percent (the chaos-cost
        // table's poly rows). The anchored and weighted fits below (the
        // Furuta models) solve through `Q^T b`.
        None if rows.is_none() => return ridge::fit_owned(design(exps), y, groups, ridge, what, || design(exps)),
        None => {
            let (w, mut cond, buf) =
                ridge::fit_owned_qtb_keep(weigh(design(exps)), weigh(y.to_owned()).as_ref(), groups, ridge, what)?;
            // The residual reported is the unweighted one.
            cond.rel_residual = ridge::rel_residual(design_in(buf, exps).as_ref(), y, w.as_ref());
            return Ok((w, cond));
        }
        Some(frac) if !joint && nm > d => frac,
        Some(_) => {
            let a = design(exps);
            return poly_regression(a.as_ref(), x, y, groups, ridge, anchor, joint, what);
        }
    };
    // The two-stage anchored fit of `poly_regression`, step for step.
    let rows = anchor_rows(x, frac)?;
    let (lin, higher) = exps.split_at(d);
    let a_l = design(lin);
    let a_lin = ridge::take_rows(a_l.as_ref(), &rows);
    let y_lin = ridge::take_rows(y, &rows);
    let (w_lin, _) =
        ridge::fit(a_lin.as_ref(), y_lin.as_ref(), &[0..rows.len()], Ridge::Fixed(0.0), "anchored linear part")?;
    let mut w = Mat::<f64>::zeros(nm, y.ncols());
    place_rows(&mut w, 0, w_lin.as_ref());
    let resid = y - &a_l * &w_lin;
    drop(a_l);
    // One allocation for the stages' design matrices and the residual's (each factorized
    // in place and handed back): its pages are mapped once.
    let mut buf = Mat::<f64>::with_capacity(x.nrows(), nm);
    // The residual reported is the whole fit's (below): the stages' own are not computed.
    let (w_nl, mut cond) = match low {
        None => {
            let (w_nl, cond, back) =
                ridge::fit_owned_qtb_keep(weigh(design_in(buf, higher)), weigh(resid).as_ref(), groups, ridge, what)?;
            buf = back;
            (w_nl, cond)
        }
        Some((n_low, f)) => {
            // Stage 1: every higher degree on the low-knee weights; keep the low degrees.
            let (w1, _, back) = ridge::fit_owned_qtb_keep(
                scale_rows(design_in(buf, higher), f),
                scale_rows(resid.clone(), f).as_ref(),
                groups,
                ridge,
                what,
            )?;
            let (lo, hi) = higher.split_at(n_low);
            let w_lo = w1.subrows(0, n_low).to_owned();
            place_rows(&mut w, d, w_lo.as_ref());
            // Stage 2: the degrees above on what the low ones leave, main weights.
            let a_lo = design_in(back, lo);
            let resid2 = resid - &a_lo * &w_lo;
            let (w_hi, cond, back) =
                ridge::fit_owned_qtb_keep(weigh(design_in(a_lo, hi)), weigh(resid2).as_ref(), groups, ridge, what)?;
            buf = back;
            let mut w_nl = Mat::<f64>::zeros(higher.len(), y.ncols());
            place_rows(&mut w_nl, 0, w_lo.as_ref());
            place_rows(&mut w_nl, n_low, w_hi.as_ref());
            (w_nl, cond)
        }
    };
    place_rows(&mut w, d, w_nl.as_ref());
    // Residual relative to the whole target (not to the part left by the linear terms).
    let a = design_in(buf, exps);
    cond.rel_residual = ridge::rel_residual(a.as_ref(), y, w.as_ref());
    Ok((w, cond))
}

/// Polynomial regression `a w ~ y` (columns of `a`: the monomials, degree 1 first, the
/// first `d = x.ncols()` being the linear ones). Without an anchor one ridge fit; with
/// `Some(f)` the two-stage fit of [`ReducedDynamics::fit_anchored`]; the conditioning
/// reported is then that of the higher-order regression, with the residual of the whole
/// fit relative to the whole target.
fn poly_regression(
    a: MatRef<'_, f64>,
    x: MatRef<'_, f64>,
    y: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    ridge: Ridge,
    anchor: Option<f64>,
    joint: bool,
    what: &'static str,
) -> Result<(Mat<f64>, Conditioning), FitError> {
    let Some(frac) = anchor else {
        return ridge::fit(a, y, groups, ridge, what);
    };
    if joint {
        return joint_anchored(a, x, y, groups, ridge, frac, what);
    }
    let (d, nm) = (x.ncols(), a.ncols());
    let rows = anchor_rows(x, frac)?;
    let a_lin = ridge::take_rows(a.subcols(0, d), &rows);
    let y_lin = ridge::take_rows(y, &rows);
    let (w_lin, _) =
        ridge::fit(a_lin.as_ref(), y_lin.as_ref(), &[0..rows.len()], Ridge::Fixed(0.0), "anchored linear part")?;
    let mut w = Mat::<f64>::zeros(nm, y.ncols());
    place_rows(&mut w, 0, w_lin.as_ref());
    if nm == d {
        let cond = ridge::RidgeLs::new(a, what)?.conditioning(a, y, w.as_ref(), 0.0);
        return Ok((w, cond));
    }
    let resid = y - a.subcols(0, d) * &w_lin;
    let a_nl = a.subcols(d, nm - d);
    let (w_nl, mut cond) = ridge::fit(a_nl, resid.as_ref(), groups, ridge, what)?;
    place_rows(&mut w, d, w_nl.as_ref());
    // Residual relative to the whole target (not to the part left by the linear terms).
    cond.rel_residual = ridge::rel_residual(a, y, w.as_ref());
    Ok((w, cond))
}

/// The low-degree stage of `weight` (if any) on the pairs `x`: the number of monomials of
/// degrees `2..=max_degree` in `d` variables and the stage's row factors.
fn low_stage(
    weight: Option<&RowWeight>,
    x: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    d: usize,
) -> Option<(usize, Vec<f64>)> {
    let st = weight?.low_degrees?;
    let n = poly::count(d, 2, st.max_degree).unwrap_or(usize::MAX);
    Some((n, st.weight().row_factors(x, groups)))
}

/// The joint anchored fit (see [`FitOptions::anchor_joint`](super::fit::FitOptions::anchor_joint)).
/// Envelope of row `i`: the max `||x||` over the rows of its trajectory (group) within one
/// oscillation of it (the largest gap between successive local maxima of `||x||` in the
/// group). The selected rows `S` (envelope within `frac` of the largest) and all rows solve
/// `A_S,l^T (y_S - A_S,l w_l - A_S,n w_n) = 0` and `A_n^T (y - A_l w_l - A_n w_n) = lambda w_n`
/// together (one linear system; `lambda` the ridge of a plain fit of the higher orders).
fn joint_anchored(
    a: MatRef<'_, f64>,
    x: MatRef<'_, f64>,
    y: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    ridge: Ridge,
    frac: f64,
    what: &'static str,
) -> Result<(Mat<f64>, Conditioning), FitError> {
    use faer::linalg::solvers::Solve;
    let (n, d, nm, q) = (a.nrows(), x.ncols(), a.ncols(), y.ncols());
    let env = envelope(x, groups);
    let top = env.iter().copied().fold(0.0, f64::max);
    let rows: Vec<usize> = (0..n).filter(|&i| env[i] <= frac * top).collect();
    let need = ANCHOR_MIN_ROWS_PER_DIM * d;
    if rows.len() < need {
        return Err(FitError::BadOption {
            what: "linear_anchor",
            why: format!(
                "{} training pairs with an envelope within {frac} of the largest ({:.3e}), need at least {need}; raise the fraction or add small-amplitude data",
                rows.len(),
                frac * top
            ),
        });
    }
    if nm == d {
        let a_s = ridge::take_rows(a, &rows);
        let y_s = ridge::take_rows(y, &rows);
        let (w, _) =
            ridge::fit(a_s.as_ref(), y_s.as_ref(), &[0..rows.len()], Ridge::Fixed(0.0), "anchored linear part")?;
        let cond = ridge::RidgeLs::new(a, what)?.conditioning(a, y, w.as_ref(), 0.0);
        return Ok((w, cond));
    }
    // The ridge of the higher orders: that of a plain fit of them to the whole target.
    let a_nl = a.subcols(d, nm - d);
    let (_, c0) = ridge::fit(a_nl, y, groups, ridge, what)?;
    let lambda = c0.alpha * c0.s_max * c0.s_max;
    let a_s = ridge::take_rows(a, &rows);
    let y_s = ridge::take_rows(y, &rows);
    let (a_sl, a_sn) = (a_s.as_ref().subcols(0, d), a_s.as_ref().subcols(d, nm - d));
    let a_l = a.subcols(0, d);
    let mut m = Mat::<f64>::zeros(nm, nm);
    let mut rhs = Mat::<f64>::zeros(nm, q);
    let blocks = [
        (0, 0, a_sl.transpose() * a_sl),
        (0, d, a_sl.transpose() * a_sn),
        (d, 0, a_nl.transpose() * a_l),
        (d, d, a_nl.transpose() * a_nl),
    ];
    for (r0, c0, b) in &blocks {
        for i in 0..b.nrows() {
            for j in 0..b.ncols() {
                m[(r0 + i, c0 + j)] = b[(i, j)];
            }
        }
    }
    for k in d..nm {
        m[(k, k)] += lambda;
    }
    let (r_l, r_n) = (a_sl.transpose() * y_s.as_ref(), a_nl.transpose() * y);
    for c in 0..q {
        for i in 0..d {
            rhs[(i, c)] = r_l[(i, c)];
        }
        for i in 0..nm - d {
            rhs[(d + i, c)] = r_n[(i, c)];
        }
    }
    let w = m.partial_piv_lu().solve(&rhs);
    if w.col_iter().any(|c| c.iter().any(|v| !v.is_finite())) {
        return Err(FitError::BadOption {
            what: "linear_anchor",
            why: "the joint anchored system is singular (too few distinct small-amplitude pairs)".into(),
        });
    }
    let mut cond = c0;
    cond.rel_residual = ridge::rel_residual(a, y, w.as_ref());
    Ok((w, cond))
}

fn to_poly(w: &Mat<f64>, exps: Vec<Vec<u32>>, scale: Vec<f64>) -> Poly {
    let (nm, d) = (w.nrows(), w.ncols());
    let mut coef = vec![0.0; nm * d];
    for k in 0..nm {
        for i in 0..d {
            coef[k * d + i] = w[(k, i)];
        }
    }
    Poly { dim_in: scale.len(), dim_out: d, scale, exps, coef }
}

/// Farthest-point subset of the rows of `z` (scaled points): starts from the row of
/// largest norm, then repeatedly adds the row farthest from the chosen set.
pub fn farthest_points(z: MatRef<'_, f64>, k: usize) -> Vec<usize> {
    let n = z.nrows();
    let d = z.ncols();
    // The rows contiguous (row-major), so each distance reads one slice; the sums are the
    // same, term by term in the same order.
    let rows: Vec<f64> = (0..n).flat_map(|i| (0..d).map(move |j| z[(i, j)])).collect();
    let row = |a: usize| &rows[a * d..(a + 1) * d];
    let dist2 = |a: usize, b: usize| row(a).iter().zip(row(b)).map(|(x, y)| (x - y).powi(2)).sum::<f64>();
    let norm2 = |a: usize| row(a).iter().map(|x| x.powi(2)).sum::<f64>();
    let mut chosen = Vec::with_capacity(k.min(n));
    if n == 0 || k == 0 {
        return chosen;
    }
    let first = (0..n).max_by(|&a, &b| norm2(a).total_cmp(&norm2(b))).unwrap_or(0);
    chosen.push(first);
    let mut mind: Vec<f64> = (0..n).map(|i| dist2(i, first)).collect();
    let update: Option<fn(&[f64], &[f64], &mut [f64]) -> usize> = match d {
        2 => Some(farthest_update::<2>),
        3 => Some(farthest_update::<3>),
        4 => Some(farthest_update::<4>),
        5 => Some(farthest_update::<5>),
        6 => Some(farthest_update::<6>),
        7 => Some(farthest_update::<7>),
        8 => Some(farthest_update::<8>),
        _ => None,
    };
    if let Some(update) = update {
        // The same picks by one pass per centre: the distances' update and the next pick.
        let mut next = last_max(&mind);
        while chosen.len() < k.min(n) {
            if mind[next] == 0.0 {
                break;
            }
            chosen.push(next);
            let c: Vec<f64> = row(next).to_vec();
            next = update(&rows, &c, &mut mind);
        }
        return chosen;
    }
    while chosen.len() < k.min(n) {
        let next = (0..n).max_by(|&a, &b| mind[a].total_cmp(&mind[b])).unwrap_or(0);
        if mind[next] == 0.0 {
            break; // remaining points duplicate chosen ones
        }
        chosen.push(next);
        let c = row(next);
        for (m, r) in mind.iter_mut().zip(rows.chunks_exact(d.max(1))) {
            *m = m.min(r.iter().zip(c).map(|(x, y)| (x - y).powi(2)).sum::<f64>());
        }
    }
    chosen
}

/// The RBF design matrix of [`fit_rbf_with`] (row `i`: [`RbfMap::features`] of row `i` of
/// `x`), filled column by column for dimensions 2..=6: each entry is the same expression
/// of the same operands as the row's features (the scaled state `x_ij / s_j`, the distance
/// to the centre summed over `j` in order, the kernel of it; then `x_ij / s_j` and 1), the
/// columns written contiguously (rows side by side) instead of one row across all
/// columns. `None` for other dimensions (filled row by row).
#[doc(hidden)]
pub fn design_by_columns(map: &RbfMap, x: MatRef<'_, f64>) -> Option<Mat<f64>> {
    match map.dim {
        2 => Some(design_columns::<2>(map, x)),
        3 => Some(design_columns::<3>(map, x)),
        4 => Some(design_columns::<4>(map, x)),
        5 => Some(design_columns::<5>(map, x)),
        6 => Some(design_columns::<6>(map, x)),
        _ => None,
    }
}

fn design_columns<const D: usize>(map: &RbfMap, x: MatRef<'_, f64>) -> Mat<f64> {
    let n = x.nrows();
    let k = map.n_centers();
    let mut a = Mat::<f64>::zeros(n, k + D + 1);
    // The scaled states by coordinate: z[j][i] = x_ij / s_j.
    let z: Vec<Vec<f64>> = (0..D).map(|j| (0..n).map(|i| x[(i, j)] / map.scale[j]).collect()).collect();
    let zc: [&[f64]; D] = core::array::from_fn(|j| &z[j][..]);
    let mut r = vec![0.0; n];
    for (c, ctr) in map.centers.chunks_exact(D).enumerate() {
        let ctr: [f64; D] = core::array::from_fn(|j| ctr[j]);
        for (i, ri) in r.iter_mut().enumerate() {
            *ri = (0..D).map(|j| (zc[j][i] - ctr[j]).powi(2)).sum::<f64>().sqrt();
        }
        let col = a.col_mut(c).try_as_col_major_mut().map(|c| c.as_slice_mut());
        match col {
            Some(col) if map.kernel == Kernel::Linear => col.copy_from_slice(&r),
            Some(col) => col.iter_mut().zip(&r).for_each(|(o, &ri)| *o = map.kernel.phi(ri)),
            None => (0..n).for_each(|i| a[(i, c)] = map.kernel.phi(r[i])),
        }
    }
    for j in 0..D {
        for i in 0..n {
            a[(i, k + j)] = zc[j][i];
        }
    }
    for i in 0..n {
        a[(i, k + D)] = 1.0;
    }
    a
}

/// The index `(0..n).max_by(|&a, &b| v[a].total_cmp(&v[b]))` picks: the last of the largest
/// values in `total_cmp`'s order (0 when `v` is empty).
fn last_max(v: &[f64]) -> usize {
    let mut best = 0;
    for (i, x) in v.iter().enumerate().skip(1) {
        if v[best].total_cmp(x) != std::cmp::Ordering::Greater {
            best = i;
        }
    }
    best
}

/// [`farthest_points`]' update of the distances `mind` to the chosen set after adding the
/// point `c` (`D` coordinates, rows of `rows`), the same expression per row, and the next
/// pick of the new distances as [`last_max`] gives it, in the same pass.
fn farthest_update<const D: usize>(rows: &[f64], c: &[f64], mind: &mut [f64]) -> usize {
    let c: [f64; D] = core::array::from_fn(|j| c[j]);
    let mut best = 0;
    let mut best_v = f64::NAN;
    for (i, (m, r)) in mind.iter_mut().zip(rows.chunks_exact(D)).enumerate() {
        let r: &[f64; D] = r.try_into().unwrap_or(&[0.0; D]);
        *m = m.min(r.iter().zip(&c).map(|(x, y)| (x - y).powi(2)).sum::<f64>());
        if i == 0 || best_v.total_cmp(m) != std::cmp::Ordering::Greater {
            best = i;
            best_v = *m;
        }
    }
    best
}

/// How the centres of an RBF map are chosen from the scaled training points (docs/decisions/0002: the
/// centre set as a model choice). [`CentreChoice::Farthest`], the default, is what
/// [`ReducedDynamics::fit`] does; the others are seeded (the same seed gives the same
/// centres) and used through [`ReducedDynamics::fit_rbf_centres`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum CentreChoice {
    /// [`farthest_points`] from the point of largest norm (deterministic).
    #[default]
    Farthest,
    /// [`farthest_points`]' rule started from a point drawn uniformly with `seed`.
    FarthestFrom { seed: u64 },
    /// k-means++ seeding: each next centre a training point drawn with probability
    /// proportional to its squared distance from the chosen ones (denser regions get more
    /// centres than under the farthest-point rule, outliers fewer).
    KMeansPP { seed: u64 },
    /// A uniformly drawn subset of the training points (centres follow the data's density).
    Random { seed: u64 },
    /// k-means++ seeding, then `iterations` Lloyd steps: the centres are the means of
    /// their clusters (not training points); an emptied cluster keeps its centre.
    KMeans { seed: u64, iterations: u32 },
}

impl CentreChoice {
    /// Short name: `farthest`, `farthest@S`, `kmeans++@S`, `random@S`, `kmeansI@S`.
    pub fn name(&self) -> String {
        match *self {
            CentreChoice::Farthest => "farthest".into(),
            CentreChoice::FarthestFrom { seed } => format!("farthest@{seed}"),
            CentreChoice::KMeansPP { seed } => format!("kmeans++@{seed}"),
            CentreChoice::Random { seed } => format!("random@{seed}"),
            CentreChoice::KMeans { seed, iterations } => format!("kmeans{iterations}@{seed}"),
        }
    }

    /// Parses [`CentreChoice::name`]'s forms; anything else is an error saying what is read.
    pub fn parse(s: &str) -> Result<Self, FitError> {
        let bad = || FitError::BadOption {
            what: "rbf centres",
            why: format!(
                "`{s}` is not one of farthest, farthest@SEED, kmeans++@SEED, random@SEED, kmeansITERATIONS@SEED"
            ),
        };
        if s == "farthest" {
            return Ok(CentreChoice::Farthest);
        }
        let (kind, seed) = s.split_once('@').ok_or_else(bad)?;
        let seed: u64 = seed.parse().map_err(|_| bad())?;
        Ok(match kind {
            "farthest" => CentreChoice::FarthestFrom { seed },
            "kmeans++" => CentreChoice::KMeansPP { seed },
            "random" => CentreChoice::Random { seed },
            _ => CentreChoice::KMeans {
                seed,
                iterations: kind.strip_prefix("kmeans").and_then(|i| i.parse().ok()).ok_or_else(bad)?,
            },
        })
    }
}

/// xorshift64 uniform numbers in [0, 1) from a seed (any seed, 0 included).
struct Uniform(u64);

impl Uniform {
    fn new(seed: u64) -> Self {
        Uniform(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// An index in `0..n` (`n >= 1`).
    fn index(&mut self, n: usize) -> usize {
        ((self.next() * n as f64) as usize).min(n.saturating_sub(1))
    }
}

/// Centres (row-major, `d` values each, at most `k` of them) chosen from the rows of `z`
/// (scaled points) by `choice`. [`CentreChoice::Farthest`] gives exactly the rows of
/// [`farthest_points`]; every choice stops early when the remaining points duplicate chosen
/// ones (the point-subset rules) or keeps `min(k, n)` centres (k-means).
pub fn choose_centres(z: MatRef<'_, f64>, k: usize, choice: CentreChoice) -> Vec<f64> {
    let (n, d) = (z.nrows(), z.ncols());
    let rows: Vec<f64> = (0..n).flat_map(|i| (0..d).map(move |j| z[(i, j)])).collect();
    let row = |a: usize| &rows[a * d..(a + 1) * d];
    let dist2 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>();
    let gather = |idx: &[usize]| idx.iter().flat_map(|&i| row(i).iter().copied()).collect::<Vec<f64>>();
    if n == 0 || k == 0 {
        return Vec::new();
    }
    let k = k.min(n);
    // D^2 sampling (k-means++) or farthest point from a given first index.
    let grow = |first: usize, rng: Option<&mut Uniform>| -> Vec<usize> {
        let mut rng = rng;
        let mut chosen = vec![first];
        let mut mind: Vec<f64> = (0..n).map(|i| dist2(row(i), row(first))).collect();
        while chosen.len() < k {
            let next = match rng.as_deref_mut() {
                None => (0..n).max_by(|&a, &b| mind[a].total_cmp(&mind[b])).unwrap_or(0),
                Some(r) => {
                    let total: f64 = mind.iter().sum();
                    if !(total > 0.0) {
                        break;
                    }
                    let mut u = r.next() * total;
                    // Rounding can leave `u` past the last weight: the last point of
                    // positive weight then.
                    let mut pick = (0..n).rev().find(|&i| mind[i] > 0.0).unwrap_or(0);
                    for (i, m) in mind.iter().enumerate() {
                        if u < *m {
                            pick = i;
                            break;
                        }
                        u -= m;
                    }
                    pick
                }
            };
            if mind[next] == 0.0 {
                break;
            }
            chosen.push(next);
            let c = row(next).to_vec();
            for (i, m) in mind.iter_mut().enumerate() {
                *m = m.min(dist2(row(i), &c));
            }
        }
        chosen
    };
    match choice {
        CentreChoice::Farthest => gather(&farthest_points(z, k)),
        CentreChoice::FarthestFrom { seed } => {
            let first = Uniform::new(seed).index(n);
            gather(&grow(first, None))
        }
        CentreChoice::KMeansPP { seed } => {
            let mut rng = Uniform::new(seed);
            let first = rng.index(n);
            gather(&grow(first, Some(&mut rng)))
        }
        CentreChoice::Random { seed } => {
            // Partial Fisher-Yates shuffle of the indices.
            let mut rng = Uniform::new(seed);
            let mut idx: Vec<usize> = (0..n).collect();
            for i in 0..k {
                let j = i + rng.index(n - i);
                idx.swap(i, j);
            }
            gather(&idx[..k])
        }
        CentreChoice::KMeans { seed, iterations } => {
            let mut rng = Uniform::new(seed);
            let first = rng.index(n);
            let mut c = gather(&grow(first, Some(&mut rng)));
            let kc = c.len() / d.max(1);
            let mut sums = vec![0.0; kc * d];
            let mut counts = vec![0usize; kc];
            for _ in 0..iterations {
                sums.iter_mut().for_each(|s| *s = 0.0);
                counts.iter_mut().for_each(|s| *s = 0);
                for i in 0..n {
                    let p = row(i);
                    let best = (0..kc)
                        .min_by(|&a, &b| dist2(p, &c[a * d..(a + 1) * d]).total_cmp(&dist2(p, &c[b * d..(b + 1) * d])))
                        .unwrap_or(0);
                    counts[best] += 1;
                    for j in 0..d {
                        sums[best * d + j] += p[j];
                    }
                }
                for a in 0..kc {
                    if counts[a] > 0 {
                        for j in 0..d {
                            c[a * d + j] = sums[a * d + j] / counts[a] as f64;
                        }
                    }
                }
            }
            c
        }
    }
}

impl ReducedDynamics {
    /// An RBF map (`kind` an RBF kind) fitted as [`Self::fit`] fits it, with the centres
    /// chosen by `choice` ([`CentreChoice::Farthest`]: the same map as [`Self::fit`]).
    pub fn fit_rbf_centres(
        trajs: &[EtaTrajectory<'_>],
        kind: Dynamics,
        ridge: Ridge,
        choice: CentreChoice,
    ) -> Result<Self, FitError> {
        let Some((centers, kernel)) = kind.rbf() else {
            return Err(FitError::BadOption { what: "dynamics", why: "a centre choice is for RBF maps only".into() });
        };
        let d = trajs.first().map(|t| t.eta.ncols()).ok_or(FitError::NoTrainingData)?;
        let dt = common_dt(trajs)?;
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for t in trajs {
            if t.eta.ncols() != d {
                return Err(FitError::DimMismatch {
                    name: "training trajectory (reduced dimension)".into(),
                    got: t.eta.ncols(),
                    expected: d,
                });
            }
            let m = t.eta.nrows().saturating_sub(1);
            xs.push(Mat::from_fn(m, d, |i, j| t.eta[(i, j)]));
            ys.push(Mat::from_fn(m, d, |i, j| t.eta[(i + 1, j)] - t.eta[(i, j)]));
        }
        let (x, groups) = stack(&xs);
        let (y, _) = stack(&ys);
        let _reserved = ridge::reserve(
            x.nrows().saturating_mul(centers.saturating_add(d + 1)).saturating_mul(2 * std::mem::size_of::<f64>()),
        );
        let common = eta_scale(trajs).iter().fold(0.0_f64, |m, v| m.max(*v));
        fit_rbf_with(x.as_ref(), y.as_ref(), &groups, vec![common; d], centers, kernel, dt, ridge, choice)
            .map(ReducedDynamics::Rbf)
    }

    /// Fits the requested dynamics of polynomial order `order` (ignored for RBF).
    pub fn fit(trajs: &[EtaTrajectory<'_>], kind: Dynamics, order: u32, ridge: Ridge) -> Result<Self, FitError> {
        Self::fit_anchored(trajs, kind, order, ridge, None)
    }

    /// [`Self::fit`] with the linear part optionally anchored on small-amplitude data:
    /// with `anchor = Some(f)`, the degree-1 coefficients of a polynomial flow or map are
    /// fitted (plain least squares) to the pairs whose point has `||eta|| <= f max ||eta||`
    /// over all training points, then the degrees `2..=order` to the residual over all
    /// pairs (with `ridge`). The linear part is then that of the dynamics near the fixed
    /// point instead of a compromise with the higher-order terms over the whole range (see
    /// [`FitOptions::linear_anchor`](super::fit::FitOptions::linear_anchor)). RBF dynamics
    /// have no separate linear part: an anchor is an error there.
    pub fn fit_anchored(
        trajs: &[EtaTrajectory<'_>],
        kind: Dynamics,
        order: u32,
        ridge: Ridge,
        anchor: Option<f64>,
    ) -> Result<Self, FitError> {
        Self::fit_with(trajs, kind, order, ridge, anchor, false)
    }

    /// [`Self::fit_anchored`] with the plain anchor (`joint = false`) or the joint one
    /// (see [`FitOptions::anchor_joint`](super::fit::FitOptions::anchor_joint)).
    pub fn fit_with(
        trajs: &[EtaTrajectory<'_>],
        kind: Dynamics,
        order: u32,
        ridge: Ridge,
        anchor: Option<f64>,
        joint: bool,
    ) -> Result<Self, FitError> {
        Self::fit_weighted(trajs, kind, order, ridge, anchor, joint, None)
    }

    /// [`Self::fit_with`] with the regression's rows weighted by `weight` (see
    /// [`RowWeight`]; polynomial flow or map dynamics, plain anchor or none). `None` is
    /// [`Self::fit_with`] itself.
    pub fn fit_weighted(
        trajs: &[EtaTrajectory<'_>],
        kind: Dynamics,
        order: u32,
        ridge: Ridge,
        anchor: Option<f64>,
        joint: bool,
        weight: Option<&RowWeight>,
    ) -> Result<Self, FitError> {
        if let Some(wt) = weight {
            wt.validate()?;
            if kind.rbf().is_some() {
                return Err(FitError::BadOption {
                    what: "row weights",
                    why: "apply to polynomial flow or map dynamics, not to RBF".into(),
                });
            }
        }
        if let Some(f) = anchor {
            if !(f > 0.0 && f <= 1.0) {
                return Err(FitError::BadOption {
                    what: "linear_anchor",
                    why: format!("the radius fraction must be in (0, 1], got {f}"),
                });
            }
            if kind.rbf().is_some() {
                return Err(FitError::BadOption {
                    what: "linear_anchor",
                    why: "applies to polynomial flow or map dynamics, not to RBF".into(),
                });
            }
        }
        let d = trajs.first().map(|t| t.eta.ncols()).ok_or(FitError::NoTrainingData)?;
        if order == 0 {
            return Err(FitError::BadOption { what: "dyn_order", why: "must be >= 1".into() });
        }
        let scale = eta_scale(trajs);
        match kind {
            Dynamics::Flow => {
                let mut xs = Vec::new();
                let mut ys = Vec::new();
                for t in trajs {
                    let (p, dv) = central_diff4(t.eta, t.dt);
                    xs.push(p);
                    ys.push(dv);
                }
                let (x, groups) = stack(&xs);
                let (y, _) = stack(&ys);
                let nm = poly::count(d, 1, order).unwrap_or(usize::MAX);
                crate::limits::check_matrix("flow regression", x.nrows(), nm, true)?;
                let _reserved =
                    ridge::reserve(x.nrows().saturating_mul(nm).saturating_mul(2 * std::mem::size_of::<f64>()));
                let exps = poly::exponents(d, 1, order);
                let rows = weight.map(|wt| wt.row_factors(x.as_ref(), &groups));
                let low = low_stage(weight, x.as_ref(), &groups, d);
                let (w, conditioning) = poly_fit(
                    x.as_ref(),
                    &scale,
                    &exps,
                    y.as_ref(),
                    &groups,
                    ridge,
                    anchor,
                    joint,
                    rows.as_deref(),
                    low.as_ref().map(|(n, f)| (*n, f.as_slice())),
                    "flow regression",
                )?;
                Ok(ReducedDynamics::Flow { field: to_poly(&w, exps, scale), conditioning })
            }
            Dynamics::Map | Dynamics::Rbf { .. } | Dynamics::RbfWith { .. } => {
                let dt = common_dt(trajs)?;
                let mut xs = Vec::new();
                let mut ys = Vec::new();
                for t in trajs {
                    let m = t.eta.nrows().saturating_sub(1);
                    xs.push(Mat::from_fn(m, d, |i, j| t.eta[(i, j)]));
                    ys.push(Mat::from_fn(m, d, |i, j| t.eta[(i + 1, j)] - t.eta[(i, j)]));
                }
                let (x, groups) = stack(&xs);
                let (y, _) = stack(&ys);
                // The design matrix and its factors (at most two copies, see `ridge::fit_owned`).
                let cols = match kind.rbf() {
                    Some((centers, _)) => centers.saturating_add(d + 1),
                    None => poly::count(d, 1, order).unwrap_or(usize::MAX),
                };
                let _reserved =
                    ridge::reserve(x.nrows().saturating_mul(cols).saturating_mul(2 * std::mem::size_of::<f64>()));
                if let Some((centers, kernel)) = kind.rbf() {
                    // One common scale for all coordinates: the kernel then stays a Euclidean
                    // distance in eta itself (||eta/s - c|| = ||eta - s c|| / s), which is what
                    // the exported device model evaluates.
                    let common = scale.iter().fold(0.0_f64, |m, v| m.max(*v));
                    let uniform = vec![common; scale.len()];
                    return fit_rbf_with(
                        x.as_ref(),
                        y.as_ref(),
                        &groups,
                        uniform,
                        centers,
                        kernel,
                        dt,
                        ridge,
                        CentreChoice::Farthest,
                    )
                    .map(ReducedDynamics::Rbf);
                }
                let nm = poly::count(d, 1, order).unwrap_or(usize::MAX);
                crate::limits::check_matrix("map regression", x.nrows(), nm, true)?;
                let exps = poly::exponents(d, 1, order);
                let rows = weight.map(|wt| wt.row_factors(x.as_ref(), &groups));
                let low = low_stage(weight, x.as_ref(), &groups, d);
                let (w, conditioning) = poly_fit(
                    x.as_ref(),
                    &scale,
                    &exps,
                    y.as_ref(),
                    &groups,
                    ridge,
                    anchor,
                    joint,
                    rows.as_deref(),
                    low.as_ref().map(|(n, f)| (*n, f.as_slice())),
                    "map regression",
                )?;
                Ok(ReducedDynamics::Map { increment: to_poly(&w, exps, scale), dt, conditioning })
            }
        }
    }

    /// An RBF map fitted on pairs whose inputs and targets come from different versions of
    /// the same trajectories (errors in variables): the point `inputs[t][i]` maps to
    /// `targets[t][i + 1]` (the regression's increment is `targets[t][i + 1] - inputs[t][i]`).
    /// With denoised inputs and raw targets, white measurement noise no longer sits in the
    /// regressors, where ordinary least squares shrinks the map towards its mean; the noise
    /// left in the targets only adds variance. Centres, scale and ridge are chosen from the
    /// inputs as in [`Self::fit`]. Every target trajectory must have its input's shape.
    pub fn fit_rbf_pairs(
        inputs: &[EtaTrajectory<'_>],
        targets: &[EtaTrajectory<'_>],
        kind: Dynamics,
        ridge: Ridge,
    ) -> Result<Self, FitError> {
        let Some((centers, kernel)) = kind.rbf() else {
            return Err(FitError::BadOption {
                what: "dynamics",
                why: "pair fitting (denoised inputs, raw targets) is for RBF maps only".into(),
            });
        };
        let d = inputs.first().map(|t| t.eta.ncols()).ok_or(FitError::NoTrainingData)?;
        if inputs.len() != targets.len() {
            return Err(FitError::DimMismatch {
                name: "pair-fit target trajectories".into(),
                got: targets.len(),
                expected: inputs.len(),
            });
        }
        for (k, (a, b)) in inputs.iter().zip(targets).enumerate() {
            if a.eta.ncols() != d || b.eta.ncols() != d {
                return Err(FitError::DimMismatch {
                    name: format!("pair-fit trajectory {k} (reduced dimension)"),
                    got: a.eta.ncols().max(b.eta.ncols()),
                    expected: d,
                });
            }
            if a.eta.nrows() != b.eta.nrows() {
                return Err(FitError::DimMismatch {
                    name: format!("pair-fit trajectory {k} (points)"),
                    got: b.eta.nrows(),
                    expected: a.eta.nrows(),
                });
            }
        }
        let dt = common_dt(inputs)?;
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for (a, b) in inputs.iter().zip(targets) {
            let m = a.eta.nrows().saturating_sub(1);
            xs.push(Mat::from_fn(m, d, |i, j| a.eta[(i, j)]));
            ys.push(Mat::from_fn(m, d, |i, j| b.eta[(i + 1, j)] - a.eta[(i, j)]));
        }
        let (x, groups) = stack(&xs);
        let (y, _) = stack(&ys);
        let _reserved = ridge::reserve(
            x.nrows().saturating_mul(centers.saturating_add(d + 1)).saturating_mul(2 * std::mem::size_of::<f64>()),
        );
        let common = eta_scale(inputs).iter().fold(0.0_f64, |m, v| m.max(*v));
        fit_rbf_with(
            x.as_ref(),
            y.as_ref(),
            &groups,
            vec![common; d],
            centers,
            kernel,
            dt,
            ridge,
            CentreChoice::Farthest,
        )
        .map(ReducedDynamics::Rbf)
    }

    /// Conditioning of the dynamics regression.
    pub fn conditioning(&self) -> &Conditioning {
        match self {
            ReducedDynamics::Flow { conditioning, .. } | ReducedDynamics::Map { conditioning, .. } => conditioning,
            ReducedDynamics::Rbf(r) => &r.conditioning,
        }
    }

    /// The sampling step of a discrete model (`None` for a flow).
    pub fn map_dt(&self) -> Option<f64> {
        match self {
            ReducedDynamics::Flow { .. } => None,
            ReducedDynamics::Map { dt, .. } => Some(*dt),
            ReducedDynamics::Rbf(r) => Some(r.dt),
        }
    }

    /// Linear part at the origin: `DR(0)` for a flow, `DF(0)` for a map (row-major d x d).
    pub fn linear_part(&self) -> Result<Vec<f64>, FitError> {
        match self {
            ReducedDynamics::Flow { field, .. } => Ok(field.linear_part()),
            ReducedDynamics::Map { increment, .. } => {
                let mut a = increment.linear_part();
                let d = increment.dim_in;
                for i in 0..d {
                    a[i * d + i] += 1.0;
                }
                Ok(a)
            }
            ReducedDynamics::Rbf(r) => r.jacobian_at_origin().ok_or(FitError::BadOption {
                what: "rbf centres",
                why: "a centre sits at the origin, the linear part is undefined".into(),
            }),
        }
    }

    /// Continuous-time eigenvalues of the linear part, sorted by decreasing real part, then
    /// decreasing imaginary part. Maps use `ln(mu) / dt` (principal logarithm).
    pub fn eigenvalues_ct(&self) -> Result<Vec<(f64, f64)>, FitError> {
        let a = self.linear_part()?;
        let d = (a.len() as f64).sqrt() as usize;
        let m = Mat::from_fn(d, d, |i, j| a[i * d + j]);
        let ev = m.eigenvalues().map_err(|_| FitError::Eigen { what: "linear part of the reduced dynamics" })?;
        let mut out: Vec<(f64, f64)> = ev
            .iter()
            .map(|z| match self.map_dt() {
                None => (z.re, z.im),
                Some(dt) => ((z.re.hypot(z.im)).ln() / dt, z.im.atan2(z.re) / dt),
            })
            .collect();
        out.sort_by(|a, b| b.0.total_cmp(&a.0).then(b.1.total_cmp(&a.1)));
        Ok(out)
    }

    /// Advances `eta` by one sampling interval `dt` (for maps `dt` must equal the map's step;
    /// the caller checks).
    pub fn step(&self, eta: &mut [f64], dt: f64, s: &mut StepScratch) {
        match self {
            ReducedDynamics::Flow { field, .. } => rk4_step(|x, sc, out| field.eval_into(x, sc, out), eta, dt, s),
            ReducedDynamics::Map { increment, .. } => map_step(|x, sc, out| increment.eval_into(x, sc, out), eta, s),
            ReducedDynamics::Rbf(r) => r.step(eta, &mut s.feat),
        }
    }

    /// The dynamics prepared for many steps ([`PreparedDynamics::step`]: the same bits as
    /// [`ReducedDynamics::step`], the polynomial evaluated by [`PreparedPoly`]).
    pub fn prepare(&self) -> PreparedDynamics<'_> {
        let kind = match self {
            ReducedDynamics::Flow { field: p, .. } | ReducedDynamics::Map { increment: p, .. } => PreparedPoly::new(p),
            ReducedDynamics::Rbf(_) => None,
        };
        PreparedDynamics { dynamics: self, poly: kind }
    }
}

/// [`ReducedDynamics`] prepared for many steps ([`ReducedDynamics::prepare`]).
#[derive(Clone, Debug)]
pub struct PreparedDynamics<'a> {
    dynamics: &'a ReducedDynamics,
    /// The field's or increment's polynomial prepared (`None`: RBF, or a polynomial of
    /// inconsistent shape, stepped the plain way).
    #[doc(hidden)]
    pub poly: Option<PreparedPoly<'a>>,
}

impl PreparedDynamics<'_> {
    /// [`ReducedDynamics::step`], the same bits.
    pub fn step(&self, eta: &mut [f64], dt: f64, s: &mut StepScratch) {
        match (self.dynamics, &self.poly) {
            (ReducedDynamics::Flow { .. }, Some(pp)) => rk4_step(|x, sc, out| pp.eval_into(x, sc, out), eta, dt, s),
            (ReducedDynamics::Map { .. }, Some(pp)) => map_step(|x, sc, out| pp.eval_into(x, sc, out), eta, s),
            (d, _) => d.step(eta, dt, s),
        }
    }
}

/// One RK4 step of `dt` (in [`RK4_SUBSTEPS`] substeps) of the field `f`.
fn rk4_step(f: impl Fn(&[f64], &mut PolyScratch, &mut [f64]), eta: &mut [f64], dt: f64, s: &mut StepScratch) {
    let d = eta.len();
    let h = dt / RK4_SUBSTEPS as f64;
    s.resize(d);
    for _ in 0..RK4_SUBSTEPS {
        f(eta, &mut s.poly, &mut s.k1);
        for i in 0..d {
            s.tmp[i] = eta[i] + 0.5 * h * s.k1[i];
        }
        f(&s.tmp, &mut s.poly, &mut s.k2);
        for i in 0..d {
            s.tmp[i] = eta[i] + 0.5 * h * s.k2[i];
        }
        f(&s.tmp, &mut s.poly, &mut s.k3);
        for i in 0..d {
            s.tmp[i] = eta[i] + h * s.k3[i];
        }
        f(&s.tmp, &mut s.poly, &mut s.k4);
        for i in 0..d {
            eta[i] += h / 6.0 * (s.k1[i] + 2.0 * s.k2[i] + 2.0 * s.k3[i] + s.k4[i]);
        }
    }
}

/// One step `eta += f(eta)` of the map with increment `f`.
fn map_step(f: impl Fn(&[f64], &mut PolyScratch, &mut [f64]), eta: &mut [f64], s: &mut StepScratch) {
    s.resize(eta.len());
    f(eta, &mut s.poly, &mut s.k1);
    for (e, k) in eta.iter_mut().zip(&s.k1) {
        *e += k;
    }
}

/// Scratch buffers for [`ReducedDynamics::step`].
#[derive(Default)]
pub struct StepScratch {
    poly: PolyScratch,
    k1: Vec<f64>,
    k2: Vec<f64>,
    k3: Vec<f64>,
    k4: Vec<f64>,
    tmp: Vec<f64>,
    feat: Vec<f64>,
}

impl StepScratch {
    fn resize(&mut self, d: usize) {
        for v in [&mut self.k1, &mut self.k2, &mut self.k3, &mut self.k4, &mut self.tmp] {
            v.resize(d, 0.0);
        }
    }
}

/// Relative tolerance on sampling steps for discrete-time models.
pub const MAP_DT_RTOL: f64 = 1e-3;

fn common_dt(trajs: &[EtaTrajectory<'_>]) -> Result<f64, FitError> {
    let dt0 = trajs[0].dt;
    for (i, t) in trajs.iter().enumerate() {
        if (t.dt - dt0).abs() > MAP_DT_RTOL * dt0 {
            return Err(FitError::StepMismatch {
                name: format!("training trajectory {i}"),
                dt: t.dt,
                dt_model: dt0,
                rtol: MAP_DT_RTOL,
            });
        }
    }
    Ok(trajs.iter().map(|t| t.dt).sum::<f64>() / trajs.len() as f64)
}

#[allow(clippy::too_many_arguments)]
fn fit_rbf_with(
    x: MatRef<'_, f64>,
    y: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    scale: Vec<f64>,
    n_centers: usize,
    kernel: Kernel,
    dt: f64,
    ridge: Ridge,
    choice: CentreChoice,
) -> Result<RbfMap, FitError> {
    let (n, d) = (x.nrows(), x.ncols());
    if n_centers == 0 {
        return Err(FitError::BadOption { what: "rbf centers", why: "need at least one centre".into() });
    }
    kernel.validate()?;
    crate::limits::check("rbf centers", n_centers, crate::limits::MAX_CENTERS)?;
    crate::limits::check_matrix("rbf regression", n, n_centers + d + 1, true)?;
    let z = Mat::from_fn(n, d, |i, j| x[(i, j)] / scale[j]);
    let centers = choose_centres(z.as_ref(), n_centers, choice);
    let mut map = RbfMap { dim: d, kernel, dt, scale, centers, coef: Vec::new(), conditioning: Conditioning::NONE };
    let nf = map.n_centers() + d + 1;
    let design = || {
        if let Some(a) = design_by_columns(&map, x) {
            return a;
        }
        let mut a = Mat::<f64>::zeros(n, nf);
        let mut feat = vec![0.0; nf];
        let mut eta = vec![0.0; d];
        for i in 0..n {
            for j in 0..d {
                eta[j] = x[(i, j)];
            }
            map.features(&eta, &mut feat);
            for (k, f) in feat.iter().enumerate() {
                a[(i, k)] = *f;
            }
        }
        a
    };
    // Factorized in the design matrix's own storage; made again for the residual.
    let (w, conditioning) = ridge::fit_owned(design(), y, groups, ridge, "rbf regression", design)?;
    map.coef = (0..nf).flat_map(|k| (0..d).map(move |j| (k, j))).map(|(k, j)| w[(k, j)]).collect();
    map.conditioning = conditioning;
    Ok(map)
}
