//! The tests of `ssm::spectrum`.

use ssm::spectrum::*;
use std::f64::consts::TAU;

fn two_tone(n: usize, dt: f64, a1: impl Fn(f64) -> f64, a2: impl Fn(f64) -> f64, f: [f64; 2]) -> Vec<f64> {
    (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            0.01 + a1(t) * (TAU * f[0] * t + 0.3).cos() + a2(t) * (TAU * f[1] * t + 1.1).cos()
        })
        .collect()
}

/// Constant amplitudes lie in the fitted span: recovered to round-off in every window.
/// Linearly varying amplitudes: the fit is a phase-dependent weighted mean of the envelope
/// over the window (`tau sin(w tau)` is even and leaks into the cosine term), so the error is
/// first order in the slope: |error| <= 0.1 |A'| W. Curved envelopes (a 30 % modulation
/// at 0.02 Hz; a growth at 0.05 1/s) are biased by the curvature across the window:
/// |error| <= 0.3 max|A''| W^2 (the quadratic term's projection, ~W^2/12, amplified by the
/// near-collinearity of the constant and a 1.1-cycle slow tone). The test prints the ratios.
fn envelope_errors(a1: impl Fn(f64) -> f64 + Copy, a2: impl Fn(f64) -> f64 + Copy) -> [f64; 2] {
    let (dt, f) = (0.0315, [0.44, 8.4]);
    let x = two_tone(3000, dt, a1, a2, f);
    let a = mode_amplitudes(&x, dt, f, 2.5).unwrap();
    let mut worst = [0.0f64; 2];
    for (t, r) in &a {
        worst[0] = worst[0].max((r[0] - a1(*t)).abs());
        worst[1] = worst[1].max((r[1] - a2(*t)).abs());
    }
    worst
}

#[test]
fn mode_amplitudes_recovers_known_envelopes() {
    let (dt, f) = (0.0315, [0.44, 8.4]);
    let x = two_tone(3000, dt, |_| 0.08, |_| 0.03, f);
    let a = mode_amplitudes(&x, dt, f, 2.5).unwrap();
    let w = (2.5f64 / dt).round() as usize;
    assert_eq!(a.len(), 3000 - w + 1);
    for (_, r) in &a {
        assert!((r[0] - 0.08).abs() < 1e-10 && (r[1] - 0.03).abs() < 1e-10, "{r:?}");
    }
    let lin = envelope_errors(|t| 0.08 + 5e-4 * t, |t| 0.03 - 2e-4 * t);
    eprintln!(
        "linear envelopes: worst absolute errors {lin:?}, ratios {:?}",
        [lin[0] / (5e-4 * 2.5), lin[1] / (2e-4 * 2.5)]
    );
    assert!(lin[0] < 0.1 * 5e-4 * 2.5 && lin[1] < 0.1 * 2e-4 * 2.5, "{lin:?}");
    let om = TAU * 0.02;
    let curved = envelope_errors(|t| 0.08 * (1.0 + 0.3 * (om * t).sin()), |t| 0.03 * (0.05 * (t - 50.0)).exp());
    let w2 = 2.5f64 * 2.5;
    let max_curv = [0.08 * 0.3 * om * om, 0.03 * 0.0025 * (0.05f64 * (3000.0 * dt - 50.0)).exp()];
    eprintln!(
        "curved envelopes: worst absolute errors {curved:?}, ratios {:?}",
        [curved[0] / (max_curv[0] * w2), curved[1] / (max_curv[1] * w2)]
    );
    assert!(curved[0] < 0.3 * max_curv[0] * w2 && curved[1] < 0.3 * max_curv[1] * w2, "{curved:?}");
    // Bad inputs are named, not clamped.
    assert!(mode_amplitudes(&x, dt, [0.44, 20.0], 2.5).is_err());
    assert!(mode_amplitudes(&x, dt, [0.44, 0.44], 2.5).is_err());
    assert!(mode_amplitudes(&x, dt, f, 0.1).is_err());
    assert!(mode_amplitudes(&x[..10], dt, f, 2.5).unwrap().is_empty());
}

/// Off-bin tones: the log-quadratic interpolation of the zero-padded Hann spectrum reads
/// frequency and amplitude; a 40 % amplitude modulation at 0.03 Hz shows as sidebands whose
/// spacing is the modulation frequency. The sidebands must be resolved: 0.03 Hz is 5.7 bins
/// of the 6000-sample series (at 2.8 bins, 3000 samples, the carrier's Hann lobe biases the
/// sideband amplitude and the spacing).
#[test]
fn spectral_peaks_read_tones_and_sidebands() {
    let (n, dt) = (3000, 0.0315);
    let bin = 1.0 / (n as f64 * dt);
    let f = [0.4937, 8.2467];
    let x = two_tone(n, dt, |_| 0.07, |_| 0.02, f);
    let p = spectral_peaks(&x, dt, PEAK_REL_THRESHOLD).unwrap();
    eprintln!("{p:?} (bin {bin:.5} Hz)");
    assert_eq!(p.len(), 2, "{p:?}");
    for (q, (fr, am)) in p.iter().zip([(f[0], 0.07), (f[1], 0.02)]) {
        assert!((q.freq_hz - fr).abs() < 0.02 * bin, "{q:?} vs {fr}");
        assert!((q.amplitude - am).abs() < 0.01 * am, "{q:?} vs {am}");
    }
    let n = 6000;
    let bin = 1.0 / (n as f64 * dt);
    let x = two_tone(n, dt, |t| 0.07 * (1.0 + 0.4 * (TAU * 0.03 * t).cos()), |_| 0.02, f);
    let p = spectral_peaks(&x, dt, PEAK_REL_THRESHOLD).unwrap();
    eprintln!("{p:?}");
    assert_eq!(p.len(), 4, "{p:?}");
    assert!((p[0].amplitude - 0.014).abs() < 0.02 * 0.014 && (p[2].amplitude - 0.014).abs() < 0.02 * 0.014, "{p:?}");
    let s = sideband_spacing(&p, 2.0).unwrap();
    assert!((s - 0.03).abs() < 0.05 * bin, "spacing {s}");
}
