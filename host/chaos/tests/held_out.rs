//! The tests of `chaos::held_out`.

use chaos::DivergenceCurve;
use chaos::held_out::*;

/// The targets on hand-made statistics: each one in and out, a missing value fails its
/// target and makes the score infinite, and the score adds the errors over tolerances.
#[test]
fn targets_and_score_on_known_values() {
    let t = Targets::default();
    let data = Reference { lle: 0.5, corr_dim: 3.0, corr_dim_err: 0.2 };
    let m = Statistics { benettin: Some(0.54), rosenstein: Some(0.51), corr_dim: Some(3.1), js: Some(0.005) };
    assert_eq!(t.passes(&m, &data), [true, true, true, true]);
    assert!((t.score(&m, &data) - (0.8 + 0.4 + 0.5 + 0.5)).abs() < 1e-12);
    let out = Statistics { benettin: Some(-0.5), rosenstein: Some(0.6), corr_dim: Some(3.3), js: Some(0.02) };
    assert_eq!(t.passes(&out, &data), [false; 4]);
    assert_eq!(t.met(&out, &data), 0);
    let missing = Statistics { js: None, ..m };
    assert_eq!(t.passes(&missing, &data), [true, true, true, false]);
    assert_eq!(t.score(&missing, &data), f64::INFINITY);
    let (lo, hi) = t.joint_ratio_range();
    assert!((lo - 0.95 / 1.1).abs() < 1e-15 && (hi - 1.05 / 0.9).abs() < 1e-15);
    assert!(is_chaotic(Some(0.3), Some(0.1)) && !is_chaotic(Some(0.3), Some(0.2)) && !is_chaotic(Some(0.3), None));
}

/// The pick: most targets first, then the smallest score, the first of equals, never a
/// failed row.
#[test]
fn best_of_prefers_targets_then_score() {
    let rows = [(false, 2, 5.0), (true, 4, 0.0), (false, 3, 9.0), (false, 3, 1.0), (false, 3, 1.0)];
    assert_eq!(best_of(rows), Some((3, 3, 1.0)));
    assert_eq!(best_of([(true, 4, 0.0)]), None);
}

/// Known answers of the noise checks: a moving average of a line is the line inside; the
/// noise level of white noise is its sd; the noise is the same for the same seed.
#[test]
fn noise_checks_known_answers() {
    let line: Vec<f64> = (0..20).map(|i| i as f64).collect();
    let ma = moving_average(&line, 2);
    assert!(ma[2..18].iter().zip(&line[2..18]).all(|(a, b)| (a - b).abs() < 1e-12));
    assert_eq!(moving_average(&line, 0), line);
    let noise = add_noise(&vec![0.0; 200_000], 0.3, 5);
    assert!((noise_sd(&noise) - 0.3).abs() < 0.01, "{}", noise_sd(&noise));
    assert_eq!(add_noise(&line, 0.1, 9), add_noise(&line, 0.1, 9));
    assert_ne!(add_noise(&line, 0.1, 9), add_noise(&line, 0.1, 10));
}

/// A curve with a noise jump of 80 % of its rise at the first step, then a straight rise
/// at 0.25 1/s that saturates: the fallback skips the jump and returns the slope.
#[test]
fn noise_jump_is_skipped_and_the_slope_recovered() {
    let dt = 0.05;
    let mut y = vec![0.0];
    for k in 1..=60 {
        let t = (k - 1) as f64 * dt;
        y.push(4.0 + 0.25 * t.min(2.0));
    }
    let curve = DivergenceCurve {
        time: (0..y.len()).map(|k| k as f64 * dt).collect(),
        n_terms: vec![10; y.len()],
        mean_log_distance: y,
        n_reference: 10,
        zero_distances: 0,
    };
    let (f, note) = fit_lle_curve(&curve).unwrap();
    assert!((f.exponent - 0.25).abs() < 1e-9, "{}", f.exponent);
    assert!(note.unwrap().contains("noise-dominated first 1 step"));
    assert!(f.window_time.0 >= dt, "{:?}", f.window_time);
}

/// Exponential and power-law curves read over doubling windows: exponential keeps the
/// slope (0.3 1/s), a t^0.5 law keeps the power (0.5) while the slope halves.
#[test]
fn growth_windows_tell_exponential_from_diffusive() {
    let dt = 0.05;
    let curve = |f: &dyn Fn(f64) -> f64| {
        let time: Vec<f64> = (0..=80).map(|k| k as f64 * dt).collect();
        DivergenceCurve {
            mean_log_distance: time.iter().map(|&t| f(t)).collect(),
            n_terms: vec![10; time.len()],
            time,
            n_reference: 10,
            zero_distances: 0,
        }
    };
    let e = growth_windows(&curve(&|t| -5.0 + 0.3 * t));
    assert_eq!(e.len(), 6, "{e:?}"); // 0.05..0.1, ..., 1.6..3.2 (the curve ends at 4.0)
    for g in &e {
        assert!((g.slope - 0.3).abs() < 1e-9 && (g.t1 - 2.0 * g.t0).abs() < 1e-9, "{g:?}");
        assert!((g.power - 0.3 * g.t0 / 2f64.ln()).abs() < 1e-9, "{g:?}");
    }
    let d = growth_windows(&curve(&|t| -5.0 + 0.5 * t.max(1e-12).ln()));
    for w in d.windows(2) {
        assert!((w[0].power - 0.5).abs() < 1e-9 && (w[1].slope - 0.5 * w[0].slope).abs() < 1e-9, "{w:?}");
    }
    assert!(growth_windows(&curve(&|_| 0.0)).iter().all(|g| g.slope == 0.0));
}
