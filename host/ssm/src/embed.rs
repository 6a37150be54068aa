//! Delay embedding of a scalar series, and over-embedding of several observables.
//!
//! With `p` coordinates and a shift of `s` samples, embedded point `n` is
//! `y_n = [x_n, x_{n+s}, ..., x_{n+(p-1)s}]`, for `n = 0 .. N - (p-1)s`. The embedded point
//! is attached to time `t_n` (its first coordinate is the observable now).
//!
//! With `q` observables `X_n` (a vector), `p` copies stack delayed copies of every
//! observable, `y_n = [X_n; X_{n+s}; ...; X_{n+(p-1)s}]` (`q p` coordinates: row `k q + i`
//! is observable `i` delayed by `k s` samples), as SSMLearn's `coordinatesEmbedding` with
//! `OverEmbedding = p - 1` stacks them. For `q = 1` it is the scalar embedding above.

use faer::Mat;

use super::data::{DataError, MultiSeries, TimeSeries};

/// Number of embedded points of a series of length `n`, or `None` if it is too short.
pub fn embedded_len(n: usize, p: usize, shift: usize) -> Option<usize> {
    let span = p.checked_sub(1)?.checked_mul(shift)?;
    n.checked_sub(span).filter(|&m| m > 0)
}

/// Embeds `ts` into a `p x M` matrix (columns are points). `min_points` embedded points
/// are required (e.g. for finite differences); fewer gives [`DataError::TooShort`].
pub fn delay_embed(ts: &TimeSeries, p: usize, shift: usize, min_points: usize) -> Result<Mat<f64>, DataError> {
    let need = (p.saturating_sub(1)).saturating_mul(shift).saturating_add(min_points.max(1));
    ts.require_len(need, &format!("delay embedding with p = {p}, shift = {shift} and {} points", min_points.max(1)))?;
    let m = ts.len() - (p.saturating_sub(1)) * shift;
    Ok(Mat::from_fn(p, m, |i, j| ts.x[j + i * shift]))
}

/// Embeds the `q` observables of `ts` with `p` copies into a `q p x M` matrix (see the
/// module docs); `min_points` as for [`delay_embed`].
pub fn delay_embed_multi(ts: &MultiSeries, p: usize, shift: usize, min_points: usize) -> Result<Mat<f64>, DataError> {
    let need = (p.saturating_sub(1)).saturating_mul(shift).saturating_add(min_points.max(1));
    if ts.len() < need {
        return Err(DataError::TooShort {
            name: ts.name.clone(),
            have: ts.len(),
            need,
            why: format!("delay embedding with p = {p}, shift = {shift} and {} points", min_points.max(1)),
        });
    }
    let q = ts.dim();
    let m = ts.len() - (p.saturating_sub(1)) * shift;
    Ok(Mat::from_fn(q * p, m, |r, j| ts.x[(j + (r / q) * shift) * q + r % q]))
}
