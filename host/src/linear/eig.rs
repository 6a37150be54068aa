//! Eigenvalues of a small general real matrix.
//!
//! The primary route is faer's real Schur (Hessenberg QR) eigenvalue solver, which returns
//! non-convergence as an error. `nalgebra`'s Schur decomposition with an iteration cap
//! is kept as an independent second route for the tests (see `linear::tests`).

use nalgebra::{Complex, DMatrix};

use super::LinearError;

/// All eigenvalues of the square matrix `m` (order unspecified).
pub fn eigenvalues(m: &DMatrix<f64>) -> Result<Vec<Complex<f64>>, LinearError> {
    let n = m.nrows();
    if let Some(((row, col), &value)) =
        m.iter().enumerate().map(|(k, v)| ((k % n, k / n), v)).find(|(_, v)| !v.is_finite())
    {
        return Err(LinearError::NonFinite { what: "closed-loop map", row, col, value });
    }
    let fm = faer::Mat::<f64>::from_fn(n, m.ncols(), |i, j| m[(i, j)]);
    let ev = fm
        .eigenvalues()
        .map_err(|e| LinearError::Eigen { n, reason: format!("faer: {e:?}") })?;
    Ok(ev.into_iter().map(|c| Complex::new(c.re, c.im)).collect())
}

/// The same through nalgebra's Schur decomposition (iteration cap `200 n`).
#[cfg(test)]
pub(crate) fn eigenvalues_nalgebra(m: &DMatrix<f64>) -> Result<Vec<Complex<f64>>, LinearError> {
    let n = m.nrows();
    let schur = nalgebra::linalg::Schur::try_new(m.clone(), f64::EPSILON, 200 * n)
        .ok_or_else(|| LinearError::Eigen { n, reason: "nalgebra Schur did not converge".into() })?;
    Ok(schur.complex_eigenvalues().iter().copied().collect())
}
