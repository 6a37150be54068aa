//! Matrix exponential of a small dense real matrix: scaling and squaring with the
//! degree-13 Padé approximant (Higham, "The scaling and squaring method for the matrix
//! exponential revisited", SIAM J. Matrix Anal. Appl. 26, 2005).
//!
//! Only the degree-13 branch is used: for the matrices met here (the stiff ZOH
//! augmented matrix, 1-norm of several hundred) it is the branch that would be taken
//! anyway, and for small norms it is merely more work than necessary, not less accurate.
//! Unlike `nalgebra`'s `exp()`, failure (a singular Padé denominator, non-finite input)
//! is returned as a value.

use nalgebra::DMatrix;

/// Coefficients b_0..b_13 of the [13/13] Padé approximant of `e^x`.
const PADE13: [f64; 14] = [
    64_764_752_532_480_000.0,
    32_382_376_266_240_000.0,
    7_771_770_303_897_600.0,
    1_187_353_796_428_800.0,
    129_060_195_264_000.0,
    10_559_470_521_600.0,
    670_442_572_800.0,
    33_522_128_640.0,
    1_323_241_920.0,
    40_840_800.0,
    960_960.0,
    16_380.0,
    182.0,
    1.0,
];

/// Largest 1-norm for which the unscaled [13/13] approximant is accurate to unit roundoff
/// in double precision (Higham 2005, table 2.3).
const THETA13: f64 = 5.371_920_351_148_152;

/// Why the exponential could not be formed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ExpmFailure {
    /// The input holds a NaN or an infinity.
    NonFinite,
    /// The Padé denominator `V - U` could not be factorized.
    SingularDenominator,
    /// The result holds a NaN or an infinity (overflow while squaring).
    Overflow { squarings: u32 },
}

/// `e^M` for a square real matrix `M`.
pub fn expm(m: &DMatrix<f64>) -> Result<DMatrix<f64>, ExpmFailure> {
    let n = m.nrows();
    debug_assert_eq!(n, m.ncols());
    if m.iter().any(|v| !v.is_finite()) {
        return Err(ExpmFailure::NonFinite);
    }
    let norm = m.column_iter().map(|c| c.iter().map(|v| v.abs()).sum::<f64>()).fold(0.0, f64::max);
    // Number of squarings s with ||M / 2^s||_1 <= theta_13.
    let s: u32 = if norm > THETA13 { (norm / THETA13).log2().ceil().max(0.0) as u32 } else { 0 };
    let a = m * 0.5f64.powi(s as i32);
    let ident = DMatrix::<f64>::identity(n, n);
    let a2 = &a * &a;
    let a4 = &a2 * &a2;
    let a6 = &a4 * &a2;
    let b = &PADE13;
    let inner_u = &a6 * (&a6 * b[13] + &a4 * b[11] + &a2 * b[9]);
    let u = &a * (inner_u + &a6 * b[7] + &a4 * b[5] + &a2 * b[3] + &ident * b[1]);
    let inner_v = &a6 * (&a6 * b[12] + &a4 * b[10] + &a2 * b[8]);
    let v = inner_v + &a6 * b[6] + &a4 * b[4] + &a2 * b[2] + &ident * b[0];
    let p = &v + &u;
    let q = &v - &u;
    let mut r = q.lu().solve(&p).ok_or(ExpmFailure::SingularDenominator)?;
    for _ in 0..s {
        r = &r * &r;
    }
    if r.iter().any(|v| !v.is_finite()) {
        return Err(ExpmFailure::Overflow { squarings: s });
    }
    Ok(r)
}
