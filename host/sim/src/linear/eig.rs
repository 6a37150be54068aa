//! Eigenvalues of a small general real matrix.
//!
//! The primary route is nalgebra's real Schur decomposition (Hessenberg QR) with an
//! iteration cap, so that non-convergence is an error, not a hang; for the 7x7 and 8x8
//! maps here it is faster than faer's solver, which matters for the charts.
//! faer's `eigenvalues()` is kept as the independent second route for the tests; the two
//! agree within 1e-11 on the closed-loop maps (the `linear` tests).

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
    let schur = nalgebra::linalg::Schur::try_new(m.clone(), f64::EPSILON, 200 * n.max(1)).ok_or_else(|| {
        LinearError::Eigen { n, reason: format!("Schur QR did not converge in {} iterations", 200 * n) }
    })?;
    Ok(schur.complex_eigenvalues().iter().copied().collect())
}
