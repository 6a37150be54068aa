//! The tests of `chaos_study::calibration`.

use chaos_study::calibration::*;
use chaos_study::model_selection::{EvalSettings, data_stats};

/// Population standard deviation, as the library's data statistics take it.
fn sd(x: &[f64]) -> f64 {
    let n = x.len().max(1) as f64;
    let m = x.iter().sum::<f64>() / n;
    (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / n).sqrt()
}

/// The flag's sampling constants are what `data_stats` measures on traj_8 at step 4 (when
/// the data are there).
#[test]
fn flag_sampling_constants_match_the_data() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/inverted_flag_chaotic/traj_8.csv");
    if !path.is_file() {
        println!("inverted-flag data not found at {}: skipped", path.display());
        return;
    }
    let ts = ssm::load_csv(&path).unwrap();
    let (d, _) = data_stats(&ts, 4, &EvalSettings::default()).unwrap();
    let s = sd(&ts.x);
    assert_eq!((d.len, d.lag, d.theiler), (FLAG_SAMPLING.samples, FLAG_SAMPLING.lag, FLAG_SAMPLING.theiler), "{d:?}");
    assert!((d.noise_sd / s - FLAG_SAMPLING.noise_rel).abs() < 0.01 * FLAG_SAMPLING.noise_rel, "{} / {s}", d.noise_sd);
    assert!((d.lle - FLAG_SAMPLING.lle).abs() < 1e-3 && (d.dt - FLAG_SAMPLING.dt).abs() < 1e-9, "{d:?}");
}

/// The calibration (docs/decisions/0002): known exponents on the exact side; then the Rosenstein
/// estimator with the flag's settings, sampling, length and noise. Systems as calm as the flag
/// (few nats per lag time) read close to their exact exponent on average, but one segment of the
/// flag's length scatters widely; Lorenz-96 at the flag's nats per lag time reads far below and far
/// above it. So no bias of about one half holds for attractors like the flag's, the two exponent
/// targets are not shown to exclude each other, and a 5 % Rosenstein target lies inside the
/// estimator's own scatter on one series of this length. The rows are printed below.
#[test]
fn calibration_on_known_answers_sampled_like_the_flag() {
    let rows = calibration_rows(&FLAG_SAMPLING, &[0.0, 1.0], 8).unwrap();
    let get = |sys: &str, noisy: bool| rows.iter().find(|r| r.system == sys && (r.noise_rel > 0.0) == noisy).unwrap();
    for r in &rows {
        eprintln!("{r:?}");
    }
    // Exact side: Rössler 0.0714, Lorenz 0.906, hyperchaotic Rössler 0.112 (literature); the
    // tolerances cover the spread of the exact estimate over the segments.
    for (sys, lit, tol) in [("Rössler", 0.0714, 0.005), ("Lorenz", 0.906, 0.04), ("hyperchaotic Rössler", 0.112, 0.01)]
    {
        let r = get(sys, false);
        assert!((r.exact - lit).abs() < tol, "{r:?}");
    }
    // Sampled like the flag: every row's lag is within 1 sample of the flag's except where
    // the data settings choose otherwise on the segment.
    assert!(rows.iter().filter(|r| r.lag.abs_diff(FLAG_SAMPLING.lag) <= 1).count() >= 16, "{rows:?}");
    let calm: Vec<&CalibrationRow> = rows.iter().filter(|r| r.noise_rel > 0.0 && r.per_lag <= CALM_PER_LAG).collect();
    assert_eq!(calm.len(), 5);
    for r in &calm {
        let m = r.ratio_mean.unwrap();
        assert!((0.85..=1.10).contains(&m) && r.fitted == r.segments, "{r:?}");
        assert!((2.0..=2.9).contains(&r.corr_dim.unwrap()), "{r:?}");
    }
    let s = summarize(&rows, &FLAG_SAMPLING).unwrap();
    eprintln!("{s:?}");
    assert!((s.data_per_lag - 0.487).abs() < 0.001, "{s:?}");
    assert!(s.calm_noise_shift_max < 0.1, "{s:?}");
    // One series of the flag's length: the scatter dwarfs a 5 % tolerance.
    assert!(s.calm_segment_sd_max > 0.3 && s.calm_segment_range.0 < 0.5 && s.calm_segment_range.1 > 1.3, "{s:?}");
    // The flag's regime: system means from below 0.3 to above 2.5 of the exact exponent.
    assert!(s.chaotic_mean_range.0 < 0.3 && s.chaotic_mean_range.1 > 2.5, "{s:?}");
    assert!(s.chaotic_implied_exponent.0 < 0.15 && s.chaotic_implied_exponent.1 > 1.5, "{s:?}");
    // No system reads about one half on average in the calm regime.
    assert!(calm.iter().all(|r| r.ratio_mean.unwrap() > 0.7), "{calm:?}");
}

/// Bad options are errors naming what is wrong.
#[test]
fn calibration_rejects_bad_options() {
    let short = FlagSampling { samples: 50, ..FLAG_SAMPLING };
    let e = calibration_rows(&short, &[0.0], 2).unwrap_err().to_string();
    assert!(e.contains("200 samples"), "{e}");
    let e = calibration_rows(&FLAG_SAMPLING, &[-1.0], 2).unwrap_err().to_string();
    assert!(e.contains("noise"), "{e}");
}
