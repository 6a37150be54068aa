//! Delay embedding of a scalar series and the autocorrelation helpers used to choose the
//! lag and the Theiler window.

use crate::{ChaosError, Points, Result, at_least, check_finite};

/// Delay vectors `(x[i], x[i+tau], ..., x[i+(m-1)tau])` for `i = 0 .. n-(m-1)tau`.
///
/// Errors: `m` or `tau` zero, non-finite samples, zero variance, or fewer than
/// `(m-1)*tau + 2` samples (at least two vectors).
pub fn delay_embed(x: &[f64], m: usize, tau: usize) -> Result<Points> {
    at_least("m (embedding dimension)", m, 1)?;
    at_least("tau (lag in samples)", tau, 1)?;
    check_finite(x, 1)?;
    let window = (m - 1) * tau;
    if x.len() < window + 2 {
        return Err(ChaosError::TooShort {
            param: "delay embedding window (m-1)*tau",
            have: x.len(),
            need: window + 2,
        });
    }
    if x.iter().all(|&v| v == x[0]) {
        return Err(ChaosError::ZeroVariance { coord: 0, value: x[0] });
    }
    let n = x.len() - window;
    let mut data = Vec::with_capacity(n * m);
    for i in 0..n {
        for k in 0..m {
            data.push(x[i + k * tau]);
        }
    }
    Points::from_flat(m, data)
}

/// Normalized autocorrelation `r(k)`, `k = 0..=max_lag` (mean removed, `r(0) = 1`),
/// by direct sums (O(n * max_lag)).
pub fn autocorrelation(x: &[f64], max_lag: usize) -> Result<Vec<f64>> {
    let (d, c0) = centred(x, max_lag)?;
    let mut r = Vec::with_capacity(max_lag + 1);
    lag_block(&d, c0, 0, max_lag + 1, &mut r);
    Ok(r)
}

/// The series minus its mean and the sum of squares `c0`, after the checks of
/// [`autocorrelation`] (finite, at least `max_lag + 2` samples, non-zero variance).
fn centred(x: &[f64], max_lag: usize) -> Result<(Vec<f64>, f64)> {
    check_finite(x, 1)?;
    if x.len() < max_lag + 2 {
        return Err(ChaosError::TooShort { param: "max_lag", have: x.len(), need: max_lag + 2 });
    }
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let d: Vec<f64> = x.iter().map(|v| v - m).collect();
    let c0: f64 = d.iter().map(|v| v * v).sum();
    if c0 == 0.0 {
        return Err(ChaosError::ZeroVariance { coord: 0, value: x[0] });
    }
    Ok((d, c0))
}

/// Lags at a time in [`lag_block`].
const LAGS_AT_ONCE: usize = 4;

/// Appends `r(k)` for `k = from..to` to `out`: each `r(k)` is the sum of `d[i] d[i + k]`
/// over `i = 0..n - k` in increasing `i`, from `-0.0` (what `Iterator::sum` starts from),
/// over `c0`, the same value as `d.iter().zip(&d[k..]).map(|(a, b)| a * b).sum::<f64>() / c0`
/// bit for bit. Lags are summed [`LAGS_AT_ONCE`] at a time in one pass: each keeps its own
/// sum in its own order, so only the wait on one chain of additions is shared.
fn lag_block(d: &[f64], c0: f64, from: usize, to: usize, out: &mut Vec<f64>) {
    let n = d.len();
    let mut k = from;
    while k + LAGS_AT_ONCE <= to {
        let mut acc = [-0.0f64; LAGS_AT_ONCE];
        // Terms every lag of the block has: i + k + LAGS_AT_ONCE - 1 < n.
        let common = n - (k + LAGS_AT_ONCE - 1);
        for i in 0..common {
            let a = d[i];
            for (j, s) in acc.iter_mut().enumerate() {
                *s += a * d[i + k + j];
            }
        }
        // The shorter lags' remaining terms, in the same increasing i.
        for (j, s) in acc.iter_mut().enumerate() {
            for i in common..n - (k + j) {
                *s += d[i] * d[i + k + j];
            }
            out.push(*s / c0);
        }
        k += LAGS_AT_ONCE;
    }
    for k in k..to {
        out.push(d.iter().zip(&d[k..]).map(|(a, b)| a * b).sum::<f64>() / c0);
    }
}

/// First lag at which the autocorrelation becomes <= 0 (about a quarter period for an
/// oscillation: a common choice of the embedding lag), searched up to `max_lag`. The lags
/// are summed only up to the crossing (the values are [`autocorrelation`]'s).
pub fn first_zero_crossing(x: &[f64], max_lag: usize) -> Result<usize> {
    let (d, c0) = centred(x, max_lag)?;
    let mut r = Vec::new();
    // Blocks of 64 lags: a zero crossing at lag z costs about z + 64 sums, not max_lag.
    let mut from = 0;
    while from <= max_lag {
        let to = (from + 64).min(max_lag + 1);
        lag_block(&d, c0, from, to, &mut r);
        if let Some(z) = r[from..].iter().position(|&v| v <= 0.0) {
            return Ok(from + z);
        }
        from = to;
    }
    Err(no_zero(max_lag))
}

fn no_zero(max_lag: usize) -> ChaosError {
    ChaosError::BadParameter {
        name: "max_lag",
        value: max_lag as f64,
        reason: "autocorrelation stays positive up to max_lag",
    }
}

/// Dominant period in samples: the lag of the highest autocorrelation maximum after the
/// first zero crossing (a Theiler window of about one period is the usual choice).
pub fn dominant_period(x: &[f64], max_lag: usize) -> Result<usize> {
    lag_and_period(x, max_lag).map(|(_, p)| p)
}

/// [`first_zero_crossing`] and [`dominant_period`] of `x` from one autocorrelation: the
/// same two results (and the same first error) as the two calls.
pub fn lag_and_period(x: &[f64], max_lag: usize) -> Result<(usize, usize)> {
    let r = autocorrelation(x, max_lag)?;
    let z = r.iter().position(|&v| v <= 0.0).ok_or_else(|| no_zero(max_lag))?;
    let mut best: Option<(usize, f64)> = None;
    for k in z.max(1)..r.len().saturating_sub(1) {
        if r[k] > r[k - 1] && r[k] >= r[k + 1] && best.is_none_or(|(_, v)| r[k] > v) {
            best = Some((k, r[k]));
        }
    }
    let period = best.map(|(k, _)| k).ok_or(ChaosError::BadParameter {
        name: "max_lag",
        value: max_lag as f64,
        reason: "no autocorrelation maximum after the first zero crossing",
    })?;
    Ok((z, period))
}
