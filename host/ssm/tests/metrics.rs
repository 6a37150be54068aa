//! The tests of `ssm::metrics`.

use ssm::metrics::*;

/// A complex sample as `(re, im)`, as the spectra take it.
type C = (f64, f64);

#[test]
fn nmte_matches_definition() {
    // truth norms 1, 2 -> max 2; errors 0.5 and 0.0 -> mean 0.25 -> NMTE 0.125.
    let truth = [1.0, 0.0, 0.0, 2.0];
    let pred = [1.0, 0.5, 0.0, 2.0];
    assert!((nmte(&pred, &truth, 2).unwrap() - 0.125).abs() < 1e-15);
    assert_eq!(nmte(&pred, &truth[..2], 2), None);
}

/// Regression: data scaled by 1e-300 gave NMTE = inf (the squares underflow to 0). The NMTE
/// is scale-invariant; tiny and huge data give the unscaled value.
#[test]
fn nmte_is_scale_invariant_down_to_subnormal_squares() {
    let truth = [1.0, 0.0, 0.0, 2.0];
    let pred = [1.0, 0.5, 0.0, 2.0];
    for s in [1e-300, 1e-200, 1e200, 1e300] {
        let (t, p): (Vec<f64>, Vec<f64>) = truth.iter().zip(&pred).map(|(a, b)| (a * s, b * s)).unzip();
        let v = nmte(&p, &t, 2).unwrap();
        assert!((v - 0.125).abs() < 1e-14, "scale {s}: {v}");
        let w = nmte_dtw(&p, &t, 2, None).unwrap();
        let w0 = nmte_dtw(&pred, &truth, 2, None).unwrap();
        assert!((w - w0).abs() < 1e-14 * w0.max(1.0), "scale {s}: {w} vs {w0}");
    }
    // Non-finite or all-zero data stay `None` (the caller reports it).
    assert_eq!(nmte(&[f64::NAN, 0.0], &[1.0, 0.0], 2), None);
    assert_eq!(nmte(&[1.0, 0.0], &[0.0, 0.0], 2), None);
}

/// Brute-force DTW over all monotone paths for tiny sequences as an independent check.
fn dtw_brute(a: &[f64], b: &[f64]) -> f64 {
    fn rec(a: &[f64], b: &[f64], i: usize, j: usize) -> f64 {
        let c = (a[i] - b[j]).abs();
        if i == a.len() - 1 && j == b.len() - 1 {
            return c;
        }
        let mut best = f64::INFINITY;
        if i + 1 < a.len() {
            best = best.min(rec(a, b, i + 1, j));
        }
        if j + 1 < b.len() {
            best = best.min(rec(a, b, i, j + 1));
        }
        if i + 1 < a.len() && j + 1 < b.len() {
            best = best.min(rec(a, b, i + 1, j + 1));
        }
        c + best
    }
    rec(a, b, 0, 0)
}

#[test]
fn dtw_matches_brute_force_and_aligns_shift() {
    let a = [0.0, 1.0, 3.0, 2.0, 0.5, -1.0, 0.0];
    let b = [0.2, 0.9, 1.1, 2.8, 1.0, -0.8];
    let c = dtw(&a, &b, 1, None).unwrap();
    assert!((c.total - dtw_brute(&a, &b)).abs() < 1e-12);
    // A time-shifted copy aligns almost perfectly while plain NMTE sees a large error.
    let s: Vec<f64> = (0..200).map(|i| (0.1 * i as f64).sin()).collect();
    let t: Vec<f64> = (0..200).map(|i| (0.1 * (i as f64 - 3.0)).sin()).collect();
    let plain = nmte(&s, &t, 1).unwrap();
    let warped = nmte_dtw(&s, &t, 1, Some(10)).unwrap();
    assert!(plain > 0.15 && warped < 0.01, "plain {plain} warped {warped}");
    // A band of 0 forces the diagonal: equals plain NMTE for equal lengths.
    let diag = nmte_dtw(&s, &t, 1, Some(0)).unwrap();
    assert!((diag - plain).abs() < 1e-12);
}

#[test]
#[allow(clippy::needless_range_loop)]
fn dft_matches_direct_sum() {
    for n in [1usize, 2, 7, 8, 12, 100] {
        let x: Vec<C> = (0..n).map(|i| ((i as f64 * 0.7).sin(), (i as f64 * 0.3).cos())).collect();
        let fast = dft(&x);
        for k in 0..n {
            let mut s = (0.0, 0.0);
            for (j, v) in x.iter().enumerate() {
                let a = -2.0 * std::f64::consts::PI * (k * j) as f64 / n as f64;
                s = (s.0 + v.0 * a.cos() - v.1 * a.sin(), s.1 + v.0 * a.sin() + v.1 * a.cos());
            }
            assert!((fast[k].0 - s.0).abs() < 1e-9 && (fast[k].1 - s.1).abs() < 1e-9, "n={n} k={k}");
        }
    }
}

#[test]
fn spectrum_reads_sinusoid_amplitude() {
    let (n, dt) = (300, 0.01);
    let f0 = 10.0 / (n as f64 * dt); // on bin 10
    let x: Vec<f64> = (0..n).map(|i| 0.5 + 2.5 * (2.0 * std::f64::consts::PI * f0 * i as f64 * dt).cos()).collect();
    let (f, a) = amplitude_spectrum(&x, dt);
    assert_eq!(f.len(), 151);
    assert!((f[10] - f0).abs() < 1e-12);
    assert!((a[10] - 2.5).abs() < 1e-9 && (a[0] - 0.5).abs() < 1e-9 && a[11] < 1e-9);
}
