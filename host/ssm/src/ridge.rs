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
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Condvar, Mutex};

use super::error::FitError;

/// A budget of working memory shared by threads: reservations that do not fit next to the
/// ones held wait for them (one alone always goes ahead, whatever its size).
#[doc(hidden)]
pub struct Budget {
    /// Bytes; 0 means no limit.
    #[doc(hidden)]
    pub limit: AtomicUsize,
    #[doc(hidden)]
    pub used: Mutex<usize>,
    released: Condvar,
}

/// The process's budget for the large regressions (see [`set_memory_budget`]).
static REGRESSIONS: Budget = Budget::new();

/// Limits the summed working memory (bytes) of the regressions that run at the same time on
/// several threads (design matrix and its factors): a regression whose reservation does not
/// fit next to the running ones waits for them (one always runs, whatever its size). Only the
/// schedule changes, never a result. 0 removes the limit (the default).
pub fn set_memory_budget(bytes: usize) {
    REGRESSIONS.limit.store(bytes, Ordering::Relaxed);
}

/// Reserves `bytes` of the regressions' budget (see [`Budget::reserve`]).
pub(crate) fn reserve(bytes: usize) -> Reservation<'static> {
    REGRESSIONS.reserve(bytes)
}

/// A reservation of a [`Budget`], returned when dropped.
#[doc(hidden)]
pub struct Reservation<'a>(&'a Budget, usize);

impl Budget {
    #[doc(hidden)]
    pub const fn new() -> Self {
        Budget { limit: AtomicUsize::new(0), used: Mutex::new(0), released: Condvar::new() }
    }

    /// Reserves `bytes`, waiting while other reservations hold too much. Sizes below 1/16 of
    /// the limit are not counted.
    #[doc(hidden)]
    pub fn reserve(&self, bytes: usize) -> Reservation<'_> {
        let limit = self.limit.load(Ordering::Relaxed);
        if limit == 0 || bytes < limit / 16 {
            return Reservation(self, 0);
        }
        let mut used = self.used.lock().unwrap_or_else(|e| e.into_inner());
        while *used > 0 && used.saturating_add(bytes) > limit {
            used = self.released.wait(used).unwrap_or_else(|e| e.into_inner());
        }
        *used = used.saturating_add(bytes);
        Reservation(self, bytes)
    }
}

impl Drop for Reservation<'_> {
    fn drop(&mut self) {
        if self.1 > 0 {
            let mut used = self.0.used.lock().unwrap_or_else(|e| e.into_inner());
            *used = used.saturating_sub(self.1);
            self.0.released.notify_all();
        }
    }
}

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

impl Conditioning {
    /// The record of a model no regression produced (written from equations or by hand): an
    /// empty design matrix and every number zero.
    pub const NONE: Conditioning = Conditioning {
        rows: 0,
        cols: 0,
        s_max: 0.0,
        s_min: 0.0,
        cond: 0.0,
        alpha: 0.0,
        cond_regularized: 0.0,
        rel_residual: 0.0,
    };
}

/// Thin-SVD factorization of a design matrix, reusable for several ridge parameters.
///
/// A tall design matrix given by value ([`RidgeLs::from_owned`]) is factorized as faer's
/// `thin_svd` does it, step by step (a QR factorization, the SVD of `R`, `U = Q [U_R; 0]`),
/// but in the matrix's own storage: the same operations give the same bits, without faer's
/// working copy of the matrix, so the peak memory of a fit is two design-matrix sizes
/// (the QR factors and `U`) instead of three; one and a block of `U` for a single solve
/// ([`RidgeLs::solve_owned`], used by [`fit_owned`]).
pub struct RidgeLs {
    u: Mat<f64>,
    #[doc(hidden)]
    pub s: Vec<f64>,
    v: Mat<f64>,
    rows: usize,
}

/// Whether faer's SVD starts with a QR factorization (more than 11/6 rows per column).
#[doc(hidden)]
pub fn qr_first(rows: usize, cols: usize) -> bool {
    let p: faer::Spec<faer::linalg::svd::SvdParams, f64> = Default::default();
    cols > 0 && rows as f64 / cols as f64 > p.config.qr_ratio_threshold
}

impl RidgeLs {
    /// A factorization from its parts `U` (`rows x n`), the singular values and `V` (`n x n`),
    /// for the tests that check the factored path against faer's own thin SVD.
    #[doc(hidden)]
    pub fn from_parts(u: Mat<f64>, s: Vec<f64>, v: Mat<f64>, rows: usize) -> Self {
        RidgeLs { u, s, v, rows }
    }

    /// Factorizes `a` (rows >= 1, cols >= 1, all finite).
    pub fn new(a: MatRef<'_, f64>, what: &'static str) -> Result<Self, FitError> {
        Self::check(a, what)?;
        let svd = a.thin_svd().map_err(|_| FitError::Svd { what })?;
        let s: Vec<f64> = (0..a.ncols()).map(|i| svd.S()[i]).collect();
        Ok(RidgeLs { u: svd.U().to_owned(), s, v: svd.V().to_owned(), rows: a.nrows() })
    }

    /// [`RidgeLs::new`] factorizing `a` in its own storage: the same factors, bit for bit,
    /// without a working copy of `a`.
    pub fn from_owned(a: Mat<f64>, what: &'static str) -> Result<Self, FitError> {
        Self::check(a.as_ref(), what)?;
        if !qr_first(a.nrows(), a.ncols()) {
            return Self::new(a.as_ref(), what);
        }
        Self::factor_qr(a, what)
    }

    fn check(a: MatRef<'_, f64>, what: &'static str) -> Result<(), FitError> {
        if a.nrows() < a.ncols() {
            return Err(FitError::Underdetermined { what, rows: a.nrows(), cols: a.ncols() });
        }
        if !all_finite(a) {
            return Err(FitError::NonFinite { what });
        }
        Ok(())
    }

    /// faer's tall-matrix thin SVD (`faer::linalg::svd::svd` with its default parameters and
    /// the global parallelism), its steps in `qr`'s storage.
    fn factor_qr(qr: Mat<f64>, what: &'static str) -> Result<Self, FitError> {
        let f = TallSvd::new(qr, what)?;
        let n = f.qr.ncols();
        let u = f.u_cols(0..n);
        let rows = u.nrows();
        let TallSvd { s, v, .. } = f;
        Ok(RidgeLs { u, s, v, rows })
    }

    /// [`RidgeLs::from_owned`] followed by [`RidgeLs::solve`] for one `b`, without ever holding
    /// all of `U`: for a tall `a` its columns are formed a block at a time and only `U^T b` is
    /// kept, so the peak memory is one size of `a` plus one block of `U` (at most
    /// [`U_BLOCK`]` * 3/2` columns) instead of two sizes of `a`. The same bits as
    /// `from_owned(a)?.solve(b, alpha)`: each column of `U` and each row of `U^T b` goes through
    /// the same kernels in the same order (blocks start at multiples of [`U_BLOCK`], a multiple
    /// of every register-tile size of faer's x86 kernels, and are wider than 48 columns, where
    /// those kernels switch). Returns the solution and the singular values (descending).
    pub fn solve_owned(
        a: Mat<f64>,
        b: MatRef<'_, f64>,
        alpha: f64,
        what: &'static str,
    ) -> Result<(Mat<f64>, Vec<f64>), FitError> {
        Self::check(a.as_ref(), what)?;
        if b.nrows() != a.nrows() {
            return Err(FitError::BadOption {
                what,
                why: format!("{} right-hand-side rows for {} matrix rows", b.nrows(), a.nrows()),
            });
        }
        let n = a.ncols();
        if !qr_first(a.nrows(), n) || n <= 2 * U_BLOCK {
            let ls = Self::from_owned(a, what)?;
            let x = ls.solve(b, alpha);
            return Ok((x, ls.s));
        }
        let f = TallSvd::new(a, what)?;
        let mut utb = Mat::<f64>::zeros(n, b.ncols());
        for cols in u_blocks(n) {
            let u = f.u_cols(cols.clone());
            let part = u.transpose() * b;
            for j in 0..b.ncols() {
                for (i, k) in cols.clone().enumerate() {
                    utb[(k, j)] = part[(i, j)];
                }
            }
        }
        Ok(f.solve_utb(utb.as_ref(), alpha))
    }

    /// [`RidgeLs::solve_owned`] without `U`: for a tall `a`, `U^T b = U_R^T (Q^T b)[..n]`
    /// with `Q^T b` from the QR factors' Householder sequence applied to `b` (cost `4 m n q`),
    /// where `solve_owned` forms `U = Q [U_R; 0]` a block at a time (`4 m n^2`, twice the QR
    /// factorization itself). The same solution up to rounding (both are backward stable; the
    /// sums run in another order), so NOT the same bits; the same singular values, bit for
    /// bit. Matrices not tall enough for faer's QR-first SVD take [`RidgeLs::solve_owned`].
    pub fn solve_owned_qtb(
        a: Mat<f64>,
        b: MatRef<'_, f64>,
        alpha: f64,
        what: &'static str,
    ) -> Result<(Mat<f64>, Vec<f64>), FitError> {
        Self::solve_owned_qtb_keep(a, b, alpha, what).map(|(x, s, _)| (x, s))
    }

    /// [`RidgeLs::solve_owned_qtb`], also handing back `a`'s storage (its values those of
    /// the QR factors; empty when `a` was not factorized in place) for the caller's next
    /// matrix ([`crate::manifold::design_matrix_in`]).
    fn solve_owned_qtb_keep(
        a: Mat<f64>,
        b: MatRef<'_, f64>,
        alpha: f64,
        what: &'static str,
    ) -> Result<(Mat<f64>, Vec<f64>, Mat<f64>), FitError> {
        Self::check(a.as_ref(), what)?;
        if b.nrows() != a.nrows() {
            return Err(FitError::BadOption {
                what,
                why: format!("{} right-hand-side rows for {} matrix rows", b.nrows(), a.nrows()),
            });
        }
        if !qr_first(a.nrows(), a.ncols()) {
            let (x, s) = Self::solve_owned(a, b, alpha, what)?;
            return Ok((x, s, Mat::new()));
        }
        let f = TallSvd::new(a, what)?;
        let utb = f.utb_by_qt(b);
        Ok(f.solve_utb_keep(utb.as_ref(), alpha))
    }

    /// `U^T b` (`cols x q`).
    pub fn utb(&self, b: MatRef<'_, f64>) -> Mat<f64> {
        self.u.transpose() * b
    }

    /// Solves for right-hand sides `b` (rows x q) with relative ridge `alpha`.
    pub fn solve(&self, b: MatRef<'_, f64>, alpha: f64) -> Mat<f64> {
        self.solve_utb(self.utb(b).as_ref(), alpha)
    }

    /// [`RidgeLs::solve`] from `U^T b` ([`RidgeLs::utb`]), for several `alpha` on one `b`.
    pub fn solve_utb(&self, utb: MatRef<'_, f64>, alpha: f64) -> Mat<f64> {
        let s_max = self.s.first().copied().unwrap_or(0.0);
        let lambda = alpha * s_max * s_max;
        let cut = self.rows.max(self.s.len()) as f64 * f64::EPSILON * s_max;
        let n = self.s.len();
        let mut scaled = Mat::<f64>::zeros(n, utb.ncols());
        for i in 0..n {
            let si = self.s[i];
            let f = if lambda > 0.0 {
                si / (si * si + lambda)
            } else if si > cut {
                1.0 / si
            } else {
                0.0
            };
            for j in 0..utb.ncols() {
                scaled[(i, j)] = f * utb[(i, j)];
            }
        }
        &self.v * &scaled
    }

    /// Conditioning report for a solution `x` of `a x ~ b` with ridge `alpha`.
    pub fn conditioning(&self, a: MatRef<'_, f64>, b: MatRef<'_, f64>, x: MatRef<'_, f64>, alpha: f64) -> Conditioning {
        conditioning_of(&self.s, a, b, x, alpha)
    }
}

/// Columns of `U` formed at a time by [`RidgeLs::solve_owned`]: a multiple of the row tiles
/// of faer's f64 kernels (12 with AVX2, 24 or 48 with AVX-512) and above 48.
pub const U_BLOCK: usize = 96;

/// The column blocks of `U` for `n` columns: [`U_BLOCK`] wide, the last one between
/// `U_BLOCK / 2 + 1` and `3 U_BLOCK / 2` wide (a rest of at most `U_BLOCK / 2` joins the
/// block before it).
#[doc(hidden)]
pub fn u_blocks(n: usize) -> Vec<std::ops::Range<usize>> {
    let mut out = Vec::new();
    let mut j = 0;
    while j < n {
        let rest = n - j;
        let w = if rest <= U_BLOCK + U_BLOCK / 2 { rest } else { U_BLOCK };
        out.push(j..j + w);
        j += w;
    }
    out
}

/// faer's tall thin SVD up to `U`: the QR factors in the matrix's own storage, the SVD of
/// `R`; `U = Q [U_R; 0]` is formed on request, all of it or some of its columns.
struct TallSvd {
    qr: Mat<f64>,
    hh: Mat<f64>,
    bs: usize,
    u_r: Mat<f64>,
    s: Vec<f64>,
    v: Mat<f64>,
}

impl TallSvd {
    fn new(mut qr: Mat<f64>, what: &'static str) -> Result<Self, FitError> {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::{qr::no_pivoting::factor, svd};
        let (m, n) = qr.shape();
        let par = faer::get_global_parallelism();
        let bs = factor::recommended_block_size::<f64>(m, n);
        let mut hh = Mat::<f64>::zeros(bs, n);
        {
            let mut mem = MemBuffer::new(factor::qr_in_place_scratch::<f64>(m, n, bs, par, Default::default()));
            factor::qr_in_place(qr.as_mut(), hh.as_mut(), par, MemStack::new(&mut mem), Default::default());
        }
        let r = Mat::from_fn(n, n, |i, j| if i <= j { qr[(i, j)] } else { 0.0 });
        let mut s = faer::diag::Diag::<f64>::zeros(n);
        let mut u_r = Mat::<f64>::zeros(n, n);
        let mut v = Mat::<f64>::zeros(n, n);
        {
            let thin = svd::ComputeSvdVectors::Thin;
            let mut mem = MemBuffer::new(svd::svd_scratch::<f64>(n, n, thin, thin, par, Default::default()));
            svd::svd(
                r.as_ref(),
                s.as_mut(),
                Some(u_r.as_mut()),
                Some(v.as_mut()),
                par,
                MemStack::new(&mut mem),
                Default::default(),
            )
            .map_err(|_| FitError::Svd { what })?;
        }
        let s: Vec<f64> = (0..n).map(|i| s[i]).collect();
        Ok(TallSvd { qr, hh, bs, u_r, s, v })
    }

    /// The columns `cols` of `U = Q [U_R; 0]`.
    fn u_cols(&self, cols: std::ops::Range<usize>) -> Mat<f64> {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::householder;
        let (m, n) = self.qr.shape();
        let par = faer::get_global_parallelism();
        let mut u = Mat::<f64>::zeros(m, cols.len());
        for (c, j) in cols.enumerate() {
            for i in 0..n {
                u[(i, c)] = self.u_r[(i, j)];
            }
        }
        let mut mem = MemBuffer::new(
            householder::apply_block_householder_sequence_on_the_left_in_place_scratch::<f64>(m, self.bs, u.ncols()),
        );
        householder::apply_block_householder_sequence_on_the_left_in_place_with_conj(
            self.qr.as_ref(),
            self.hh.as_ref(),
            faer::Conj::No,
            u.as_mut(),
            par,
            MemStack::new(&mut mem),
        );
        u
    }
}

impl TallSvd {
    /// `U^T b = U_R^T (Q^T b)[..n]`, `Q^T b` by the Householder sequence on a copy of `b`.
    fn utb_by_qt(&self, b: MatRef<'_, f64>) -> Mat<f64> {
        use faer::dyn_stack::{MemBuffer, MemStack};
        use faer::linalg::householder;
        let n = self.qr.ncols();
        let par = faer::get_global_parallelism();
        let mut qtb = b.to_owned();
        let mut mem = MemBuffer::new(
            householder::apply_block_householder_sequence_transpose_on_the_left_in_place_scratch::<f64>(
                self.qr.nrows(),
                self.bs,
                qtb.ncols(),
            ),
        );
        householder::apply_block_householder_sequence_transpose_on_the_left_in_place_with_conj(
            self.qr.as_ref(),
            self.hh.as_ref(),
            faer::Conj::No,
            qtb.as_mut(),
            par,
            MemStack::new(&mut mem),
        );
        self.u_r.transpose() * qtb.as_ref().subrows(0, n)
    }

    /// The ridge solution from `U^T b` and the singular values (the QR factors dropped).
    fn solve_utb(self, utb: MatRef<'_, f64>, alpha: f64) -> (Mat<f64>, Vec<f64>) {
        let (x, s, _) = self.solve_utb_keep(utb, alpha);
        (x, s)
    }

    /// [`TallSvd::solve_utb`], handing back the QR factors' storage instead of dropping it.
    fn solve_utb_keep(self, utb: MatRef<'_, f64>, alpha: f64) -> (Mat<f64>, Vec<f64>, Mat<f64>) {
        let TallSvd { qr, s, v, .. } = self;
        let ls = RidgeLs { u: Mat::new(), s, v, rows: qr.nrows() };
        let x = ls.solve_utb(utb, alpha);
        (x, ls.s, qr)
    }
}

/// The conditioning report from the singular values `s` (descending) of `a`.
fn conditioning_of(s: &[f64], a: MatRef<'_, f64>, b: MatRef<'_, f64>, x: MatRef<'_, f64>, alpha: f64) -> Conditioning {
    conditioning_from(s, a.nrows(), a.ncols(), alpha, rel_residual(a, b, x))
}

/// The conditioning report of a `rows x cols` design matrix with singular values `s`
/// (descending), ridge `alpha` and the given relative residual.
fn conditioning_from(s: &[f64], rows: usize, cols: usize, alpha: f64, rel_residual: f64) -> Conditioning {
    let s_max = s.first().copied().unwrap_or(0.0);
    let s_min = s.last().copied().unwrap_or(0.0);
    let lambda = alpha * s_max * s_max;
    Conditioning {
        rows,
        cols,
        s_max,
        s_min,
        cond: if s_min > 0.0 { s_max / s_min } else { f64::INFINITY },
        alpha,
        cond_regularized: if s_min * s_min + lambda > 0.0 {
            ((s_max * s_max + lambda) / (s_min * s_min + lambda)).sqrt()
        } else {
            f64::INFINITY
        },
        rel_residual,
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

/// The ridge parameter `ridge` asks for: a fixed value (checked finite and >= 0) or the
/// cross-validated one over the trajectory folds `groups`.
fn choose_alpha(
    a: MatRef<'_, f64>,
    b: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    ridge: Ridge,
    what: &'static str,
) -> Result<f64, FitError> {
    match ridge {
        Ridge::Fixed(alpha) => {
            if !(alpha >= 0.0 && alpha.is_finite()) {
                return Err(FitError::BadOption {
                    what: "ridge alpha",
                    why: format!("{alpha} is not a finite number >= 0"),
                });
            }
            Ok(alpha)
        }
        Ridge::CrossValidated => cross_validate(a, b, groups, what),
    }
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
    let alpha = choose_alpha(a, b, groups, ridge, what)?;
    let ls = RidgeLs::new(a, what)?;
    let x = ls.solve(b, alpha);
    let cond = ls.conditioning(a, b, x.as_ref(), alpha);
    Ok((x, cond))
}

/// [`fit`] on a design matrix given by value, factorized in its own storage (the same
/// solution and report; for a tall `a` the peak memory is two sizes of `a` instead of
/// three, and one plus a block of `U` with [`RidgeLs::solve_owned`]); `rebuild` makes `a` again for the residual of the conditioning report, after the
/// factors are dropped.
pub fn fit_owned(
    a: Mat<f64>,
    b: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    ridge: Ridge,
    what: &'static str,
    rebuild: impl FnOnce() -> Mat<f64>,
) -> Result<(Mat<f64>, Conditioning), FitError> {
    let alpha = choose_alpha(a.as_ref(), b, groups, ridge, what)?;
    // The factors are gone before `a` comes back.
    let (x, s) = RidgeLs::solve_owned(a, b, alpha, what)?;
    let a = rebuild();
    let cond = conditioning_of(&s, a.as_ref(), b, x.as_ref(), alpha);
    Ok((x, cond))
}

/// [`fit_owned`] through [`RidgeLs::solve_owned_qtb`] (no `U`; the solution equal up to
/// rounding, not bit for bit, at about a third of the cost for a tall design matrix with few
/// right-hand sides: the weighted and anchored polynomial map and flow fits), for a caller
/// that computes the residual itself (the two-stage fits report the residual of the whole
/// fit): the design matrix is not rebuilt and the report's `rel_residual` is NaN until the
/// caller sets it.
pub fn fit_owned_qtb_no_residual(
    a: Mat<f64>,
    b: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    ridge: Ridge,
    what: &'static str,
) -> Result<(Mat<f64>, Conditioning), FitError> {
    fit_owned_qtb_keep(a, b, groups, ridge, what).map(|(x, c, _)| (x, c))
}

/// [`fit_owned_qtb_no_residual`], also handing back `a`'s storage (overwritten by its QR
/// factors; empty when not factorized in place), so that the caller's next design matrix of
/// the same rows reuses it ([`crate::manifold::design_matrix_in`]). The same solution and
/// report.
pub(crate) fn fit_owned_qtb_keep(
    a: Mat<f64>,
    b: MatRef<'_, f64>,
    groups: &[std::ops::Range<usize>],
    ridge: Ridge,
    what: &'static str,
) -> Result<(Mat<f64>, Conditioning, Mat<f64>), FitError> {
    let alpha = choose_alpha(a.as_ref(), b, groups, ridge, what)?;
    let (rows, cols) = a.shape();
    let (x, s, storage) = RidgeLs::solve_owned_qtb_keep(a, b, alpha, what)?;
    Ok((x, conditioning_from(&s, rows, cols, alpha, f64::NAN), storage))
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
        let ls = RidgeLs::from_owned(at, what)?;
        let utb = ls.utb(bt.as_ref());
        for (e, &alpha) in err.iter_mut().zip(CV_GRID.iter()) {
            let x = ls.solve_utb(utb.as_ref(), alpha);
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
