//! Ridge-regularized linear least squares through the thin SVD, with conditioning reports
//! and k-fold cross-validation over groups of rows (trajectories).
//!
//! Problem: minimize `||A X - B||_F^2 + lambda ||X||_F^2` with `lambda = alpha * s_max(A)^2`,
//! i.e. `alpha` is relative to the largest squared singular value, so it is independent of
//! the number of rows and of the scale of `A`. Solution
//! `X = sum_i v_i s_i / (s_i^2 + lambda) u_i^T B`. With `alpha = 0` singular values below
//! `n * eps * s_max` are dropped (pseudo-inverse), never divided by.

use faer::{Mat, MatRef};
use serde::{Deserialize, Serialize};

use super::error::FitError;

/// The default grid of relative ridge parameters tried by cross-validation.
pub const CV_GRID: [f64; 9] = [0.0, 1e-14, 1e-12, 1e-10, 1e-8, 1e-7, 1e-6, 1e-5, 1e-4];

/// How the ridge parameter is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Ridge {
    /// A fixed relative ridge parameter `alpha >= 0` (see the module docs).
    Fixed(f64),
    /// k-fold cross-validation over trajectories on [`CV_GRID`] (contiguous blocks when
    /// only one trajectory is given).
    CrossValidated,
}

/// Conditioning of one regression, reported with every fitted model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Conditioning {
    /// Rows x columns of the design matrix.
    pub rows: usize,
    pub cols: usize,
    /// Largest and smallest singular value of the design matrix.
    pub s_max: f64,
    pub s_min: f64,
    /// 2-norm condition number `s_max / s_min` of the design matrix (inf if rank deficient).
    pub cond: f64,
    /// Relative ridge parameter used.
    pub alpha: f64,
    /// Condition number of the regularized problem, `sqrt((s_max^2 + l) / (s_min^2 + l))`.
    pub cond_regularized: f64,
    /// Relative residual `||A X - B||_F / ||B||_F` on the rows used for the fit.
    pub rel_residual: f64,
}

/// Thin-SVD factorization of a design matrix, reusable for several ridge parameters.
pub struct RidgeLs {
    u: Mat<f64>,
    s: Vec<f64>,
    v: Mat<f64>,
    rows: usize,
}

impl RidgeLs {
    /// Factorizes `a` (rows >= 1, cols >= 1, all finite).
    pub fn new(a: MatRef<'_, f64>, what: &'static str) -> Result<Self, FitError> {
        if a.nrows() < a.ncols() {
            return Err(FitError::Underdetermined { what, rows: a.nrows(), cols: a.ncols() });
        }
        if !all_finite(a) {
            return Err(FitError::NonFinite { what });
        }
        let svd = a.thin_svd().map_err(|_| FitError::Svd { what })?;
        let s: Vec<f64> = (0..a.ncols()).map(|i| svd.S()[i]).collect();
        Ok(RidgeLs { u: svd.U().to_owned(), s, v: svd.V().to_owned(), rows: a.nrows() })
    }

    /// Solves for right-hand sides `b` (rows x q) with relative ridge `alpha`.
    pub fn solve(&self, b: MatRef<'_, f64>, alpha: f64) -> Mat<f64> {
        let utb = self.u.transpose() * b;
        let s_max = self.s.first().copied().unwrap_or(0.0);
        let lambda = alpha * s_max * s_max;
        let cut = self.rows.max(self.s.len()) as f64 * f64::EPSILON * s_max;
        let n = self.s.len();
        let mut scaled = Mat::<f64>::zeros(n, b.ncols());
        for i in 0..n {
            let si = self.s[i];
            let f = if lambda > 0.0 {
                si / (si * si + lambda)
            } else if si > cut {
                1.0 / si
            } else {
                0.0
            };
            for j in 0..b.ncols() {
                scaled[(i, j)] = f * utb[(i, j)];
            }
        }
        &self.v * &scaled
    }

    /// Conditioning report for a solution `x` of `a x ~ b` with ridge `alpha`.
    pub fn conditioning(&self, a: MatRef<'_, f64>, b: MatRef<'_, f64>, x: MatRef<'_, f64>, alpha: f64) -> Conditioning {
        let s_max = self.s.first().copied().unwrap_or(0.0);
        let s_min = self.s.last().copied().unwrap_or(0.0);
        let lambda = alpha * s_max * s_max;
        Conditioning {
            rows: a.nrows(),
            cols: a.ncols(),
            s_max,
            s_min,
            cond: if s_min > 0.0 { s_max / s_min } else { f64::INFINITY },
            alpha,
            cond_regularized: if s_min * s_min + lambda > 0.0 {
                ((s_max * s_max + lambda) / (s_min * s_min + lambda)).sqrt()
            } else {
                f64::INFINITY
            },
            rel_residual: rel_residual(a, b, x),
        }
    }
}

/// `||a x - b||_F / ||b||_F` (the absolute residual when `b` is zero).
pub fn rel_residual(a: MatRef<'_, f64>, b: MatRef<'_, f64>, x: MatRef<'_, f64>) -> f64 {
    let r = (a * x - b).norm_l2();
    let nb = b.norm_l2();
    if nb > 0.0 { r / nb } else { r }
}

fn all_finite(a: MatRef<'_, f64>) -> bool {
    (0..a.ncols()).all(|j| (0..a.nrows()).all(|i| a[(i, j)].is_finite()))
}

/// Copies the rows listed in `rows` of `a`.
pub(crate) fn take_rows(a: MatRef<'_, f64>, rows: &[usize]) -> Mat<f64> {
    Mat::from_fn(rows.len(), a.ncols(), |i, j| a[(rows[i], j)])
}

/// Fits `a x ~ b` with the ridge chosen by `ridge`. `groups[k]` is the row range of
/// trajectory `k` (used as cross-validation folds). Returns the solution and its
/// conditioning (on all rows).
pub fn fit(
    a: MatRef<'_, f64>,
    b: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    ridge: Ridge,
    what: &'static str,
) -> Result<(Mat<f64>, Conditioning), FitError> {
    let alpha = match ridge {
        Ridge::Fixed(alpha) => {
            if !(alpha >= 0.0 && alpha.is_finite()) {
                return Err(FitError::BadOption { what: "ridge alpha", why: format!("{alpha} is not a finite number >= 0") });
            }
            alpha
        }
        Ridge::CrossValidated => cross_validate(a, b, groups, what)?,
    };
    let ls = RidgeLs::new(a, what)?;
    let x = ls.solve(b, alpha);
    let cond = ls.conditioning(a, b, x.as_ref(), alpha);
    Ok((x, cond))
}

/// Picks the alpha on [`CV_GRID`] with the smallest summed validation error over folds
/// (one fold per group; 5 contiguous blocks when there is a single group).
pub fn cross_validate(
    a: MatRef<'_, f64>,
    b: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    what: &'static str,
) -> Result<f64, FitError> {
    let n = a.nrows();
    let folds: Vec<std::ops::Range<usize>> = if groups.len() >= 2 {
        groups.to_vec()
    } else {
        let k = 5;
        (0..k).map(|i| (i * n / k)..((i + 1) * n / k)).collect()
    };
    let mut err = vec![0.0; CV_GRID.len()];
    for fold in &folds {
        let train: Vec<usize> = (0..n).filter(|i| !fold.contains(i)).collect();
        let val: Vec<usize> = fold.clone().collect();
        let at = take_rows(a, &train);
        let bt = take_rows(b, &train);
        let av = take_rows(a, &val);
        let bv = take_rows(b, &val);
        let ls = RidgeLs::new(at.as_ref(), what)?;
        for (e, &alpha) in err.iter_mut().zip(CV_GRID.iter()) {
            let x = ls.solve(bt.as_ref(), alpha);
            let r = &av * &x - &bv;
            let v = r.norm_l2();
            *e += v * v;
        }
    }
    let mut best = 0;
    for (i, e) in err.iter().enumerate() {
        if e.is_finite() && *e < err[best] {
            best = i;
        }
    }
    Ok(CV_GRID[best])
}

#[cfg(test)]
#[allow(clippy::single_range_in_vec_init)]
mod tests {
    use super::*;

    #[test]
    fn exact_solution_without_ridge() {
        // a = [[1,0],[0,2],[1,1]], x = [3, -1] -> b exactly representable.
        let a = faer::mat![[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]];
        let b = faer::mat![[3.0], [-2.0], [2.0]];
        let (x, c) = fit(a.as_ref(), b.as_ref(), &[0..3], Ridge::Fixed(0.0), "t").unwrap();
        assert!((x[(0, 0)] - 3.0).abs() < 1e-13 && (x[(1, 0)] + 1.0).abs() < 1e-13);
        assert!(c.rel_residual < 1e-14);
        assert!(c.cond > 1.0 && c.cond.is_finite());
    }

    #[test]
    fn ridge_matches_normal_equations() {
        // Independent reference: (A^T A + l I) x = A^T b solved by hand for a 2x2 system.
        let a = faer::mat![[1.0, 2.0], [3.0, 4.0], [5.0, 7.0]];
        let b = faer::mat![[1.0], [0.0], [2.0]];
        let alpha = 1e-2;
        let ls = RidgeLs::new(a.as_ref(), "t").unwrap();
        let x = ls.solve(b.as_ref(), alpha);
        let smax2 = ls.s[0] * ls.s[0];
        let l = alpha * smax2;
        let ata = a.transpose() * &a;
        let atb = a.transpose() * &b;
        let (p, q, r, s) = (ata[(0, 0)] + l, ata[(0, 1)], ata[(1, 0)], ata[(1, 1)] + l);
        let det = p * s - q * r;
        let x0 = (s * atb[(0, 0)] - q * atb[(1, 0)]) / det;
        let x1 = (-r * atb[(0, 0)] + p * atb[(1, 0)]) / det;
        assert!((x[(0, 0)] - x0).abs() < 1e-12 && (x[(1, 0)] - x1).abs() < 1e-12);
    }

    #[test]
    fn rank_deficient_is_reported_not_divided() {
        let a = faer::mat![[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]];
        let b = faer::mat![[1.0], [2.0], [3.0]];
        let (x, c) = fit(a.as_ref(), b.as_ref(), &[0..3], Ridge::Fixed(0.0), "t").unwrap();
        assert!(x[(0, 0)].is_finite() && (x[(0, 0)] - 0.5).abs() < 1e-12);
        assert!(c.cond > 1e12, "cond {}", c.cond);
    }
}
