//! The tests of `chaos::embed`.

use chaos::ChaosError;
use chaos::embed::*;

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

/// The autocorrelation as it was computed before [`lag_block`]: one sum per lag.
fn autocorrelation_plain(x: &[f64], max_lag: usize) -> Vec<f64> {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let d: Vec<f64> = x.iter().map(|v| v - m).collect();
    let c0: f64 = d.iter().map(|v| v * v).sum();
    (0..=max_lag).map(|k| d.iter().zip(&d[k..]).map(|(a, b)| a * b).sum::<f64>() / c0).collect()
}

/// The blocked sums equal one sum per lag bit for bit (random series, a series with
/// samples at its mean so products are +-0, every max_lag remainder), and the lag and
/// period from one autocorrelation equal the plain search over it.
#[test]
fn blocked_autocorrelation_equals_one_sum_per_lag() {
    let mut s = 0x9E37_79B9_7F4A_7C15u64;
    let mut rnd = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let noisy: Vec<f64> = (0..1500).map(|i| (i as f64 * 0.17).sin() + 0.3 * rnd()).collect();
    let mut flat = vec![1.0; 300];
    flat[7] = 3.0;
    flat[150] = -1.0;
    flat[200] = 0.0;
    for x in [&noisy, &flat] {
        for max_lag in [0, 1, 3, 4, 5, 63, 64, 65, 130, x.len() / 4] {
            let a = autocorrelation(x, max_lag).unwrap();
            let b = autocorrelation_plain(x, max_lag);
            assert_eq!(a.len(), b.len());
            assert!(a.iter().zip(&b).all(|(p, q)| p.to_bits() == q.to_bits()), "max_lag {max_lag}");
            let z = b.iter().position(|&v| v <= 0.0);
            assert_eq!(first_zero_crossing(x, max_lag).ok(), z, "max_lag {max_lag}");
            if let Ok((lz, _)) = lag_and_period(x, max_lag) {
                assert_eq!(Some(lz), z);
            }
        }
    }
    let (z, p) = lag_and_period(&noisy, 375).unwrap();
    assert_eq!((z, p), (first_zero_crossing(&noisy, 375).unwrap(), dominant_period(&noisy, 375).unwrap()));
}

#[test]
fn sine_period_and_quarter() {
    // period 40 samples
    let x: Vec<f64> = (0..2000).map(|i| (2.0 * std::f64::consts::PI * i as f64 / 40.0).sin()).collect();
    assert_eq!(dominant_period(&x, 100).unwrap(), 40);
    let z = first_zero_crossing(&x, 100).unwrap();
    assert!((10..=11).contains(&z), "{z}");
}
