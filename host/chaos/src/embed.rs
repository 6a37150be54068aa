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
    Ok((0..=max_lag)
        .map(|k| d.iter().zip(&d[k..]).map(|(a, b)| a * b).sum::<f64>() / c0)
        .collect())
}

/// First lag at which the autocorrelation becomes <= 0 (about a quarter period for an
/// oscillation: a common choice of the embedding lag), searched up to `max_lag`.
pub fn first_zero_crossing(x: &[f64], max_lag: usize) -> Result<usize> {
    let r = autocorrelation(x, max_lag)?;
    r.iter().position(|&v| v <= 0.0).ok_or(ChaosError::BadParameter {
        name: "max_lag",
        value: max_lag as f64,
        reason: "autocorrelation stays positive up to max_lag",
    })
}

/// Dominant period in samples: the lag of the highest autocorrelation maximum after the
/// first zero crossing (a Theiler window of about one period is the usual choice).
pub fn dominant_period(x: &[f64], max_lag: usize) -> Result<usize> {
    let r = autocorrelation(x, max_lag)?;
    let z = r.iter().position(|&v| v <= 0.0).ok_or(ChaosError::BadParameter {
        name: "max_lag",
        value: max_lag as f64,
        reason: "autocorrelation stays positive up to max_lag",
    })?;
    let mut best: Option<(usize, f64)> = None;
    for k in z.max(1)..r.len().saturating_sub(1) {
        if r[k] > r[k - 1] && r[k] >= r[k + 1] && best.is_none_or(|(_, v)| r[k] > v) {
            best = Some((k, r[k]));
        }
    }
    best.map(|(k, _)| k).ok_or(ChaosError::BadParameter {
        name: "max_lag",
        value: max_lag as f64,
        reason: "no autocorrelation maximum after the first zero crossing",
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embeds_in_order() {
        let x: Vec<f64> = (0..10).map(|v| v as f64).collect();
        let p = delay_embed(&x, 3, 2).unwrap();
        assert_eq!(p.len(), 6);
        assert_eq!(p.point(0), &[0.0, 2.0, 4.0]);
        assert_eq!(p.point(5), &[5.0, 7.0, 9.0]);
    }

    #[test]
    fn rejects_bad_input() {
        let x: Vec<f64> = (0..10).map(|v| v as f64).collect();
        assert!(matches!(
            delay_embed(&x, 5, 3),
            Err(ChaosError::TooShort { param: "delay embedding window (m-1)*tau", have: 10, need: 14 })
        ));
        assert!(matches!(delay_embed(&x, 0, 1), Err(ChaosError::BadParameter { .. })));
        assert!(matches!(delay_embed(&[1.0; 20], 2, 1), Err(ChaosError::ZeroVariance { .. })));
        let mut y = x.clone();
        y[4] = f64::NAN;
        assert!(matches!(delay_embed(&y, 2, 1), Err(ChaosError::NonFinite { index: 4, .. })));
    }

    #[test]
    fn sine_period_and_quarter() {
        // period 40 samples
        let x: Vec<f64> =
            (0..2000).map(|i| (2.0 * std::f64::consts::PI * i as f64 / 40.0).sin()).collect();
        assert_eq!(dominant_period(&x, 100).unwrap(), 40);
        let z = first_zero_crossing(&x, 100).unwrap();
        assert!((10..=11).contains(&z), "{z}");
    }
}
