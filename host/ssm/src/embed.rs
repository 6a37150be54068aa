//! Delay embedding of a scalar series.
//!
//! With `p` coordinates and a shift of `s` samples, embedded point `n` is
//! `y_n = [x_n, x_{n+s}, ..., x_{n+(p-1)s}]`, for `n = 0 .. N - (p-1)s`. The embedded point
//! is attached to time `t_n` (its first coordinate is the observable now).

use faer::Mat;

use super::data::{DataError, TimeSeries};

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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embeds_with_shift() {
        let ts = TimeSeries::new("a", (0..7).map(|i| i as f64).collect(), (0..7).map(|i| (i * i) as f64).collect()).unwrap();
        let y = delay_embed(&ts, 3, 2, 1).unwrap();
        assert_eq!((y.nrows(), y.ncols()), (3, 3));
        assert_eq!(embedded_len(7, 3, 2), Some(3));
        // column 1 = [x1, x3, x5]
        assert_eq!([y[(0, 1)], y[(1, 1)], y[(2, 1)]], [1.0, 9.0, 25.0]);
        let e = delay_embed(&ts, 3, 2, 4).unwrap_err();
        assert!(matches!(e, DataError::TooShort { have: 7, need: 8, .. }), "{e}");
    }
}
