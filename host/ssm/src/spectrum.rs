//! Spectral readings of sampled signals: sliding least-squares amplitudes of two known tones
//! along a run, and Hann-windowed spectra with interpolated peaks.

use std::f64::consts::TAU;

use serde::Serialize;

use crate::metrics::amplitude_spectrum;

/// Peaks closer than this many (unpadded) frequency bins are merged into the larger one.
pub const PEAK_MERGE_BINS: f64 = 2.0;

/// Relative threshold of a transient's spectrum (`furuta::full_system::transient_spectrum`): peaks below this fraction of the largest are
/// not reported.
pub const PEAK_REL_THRESHOLD: f64 = 0.05;

/// Zero-padding factor of the spectra (finer frequency grid for peak interpolation).
const PAD: usize = 4;

/// A signal or parameter the spectral readings cannot use.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpectrumError {
    #[error("invalid input {what}: {why}")]
    BadInput { what: &'static str, why: String },
}

/// Amplitudes of the slow and fast components of `theta` (sampled at `dt` s) over time: at
/// each sample whose centred window of `window_s` seconds fits in the series, a least-squares
/// fit of `c + a_j cos(2 pi f_j t) + b_j sin(2 pi f_j t)` (j = 1, 2) on the window gives
/// `rho_j = hypot(a_j, b_j)`. Returns `(window centre time measured from the first sample,
/// [rho_1, rho_2])`. The estimate is a phase-dependent weighted mean of the envelope over the
/// window: a slope `A'` gives an error below `0.1 |A'| window`, a curvature `A''` below
/// `0.3 |A''| window^2` (the bounds the tests check on synthetic envelopes), and a
/// mismatch `df` between `f_j` and the true frequency a factor of about `sinc(pi df window)`.
///
/// Returns an empty vector when the series is shorter than one window. Errors on a bad
/// `dt`, bad frequencies (non-positive, not below Nyquist, equal), a window under 5 samples
/// or one too short to separate the two tones from the constant (singular fit).
pub fn mode_amplitudes(
    theta: &[f64],
    dt: f64,
    freqs_hz: [f64; 2],
    window_s: f64,
) -> Result<Vec<(f64, [f64; 2])>, SpectrumError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(SpectrumError::BadInput { what: "dt", why: format!("must be positive and finite, got {dt}") });
    }
    let nyq = 0.5 / dt;
    if freqs_hz.iter().any(|f| !(f.is_finite() && *f > 0.0 && *f < nyq)) || freqs_hz[0] == freqs_hz[1] {
        return Err(SpectrumError::BadInput {
            what: "freqs_hz",
            why: format!("need two distinct frequencies in (0, {nyq}) Hz, got {freqs_hz:?}"),
        });
    }
    let w = (window_s / dt).round() as usize;
    if !(window_s.is_finite()) || w < 5 {
        return Err(SpectrumError::BadInput {
            what: "window_s",
            why: format!("needs at least 5 samples, got {window_s} s at dt {dt} s"),
        });
    }
    if theta.len() < w {
        return Ok(Vec::new());
    }
    // Basis evaluated at absolute sample times; a phase reference change does not change
    // hypot(a, b).
    let basis = |i: usize| -> [f64; 5] {
        let t = i as f64 * dt;
        let (s1, c1) = (TAU * freqs_hz[0] * t).sin_cos();
        let (s2, c2) = (TAU * freqs_hz[1] * t).sin_cos();
        [1.0, c1, s1, c2, s2]
    };
    let rows: Vec<[f64; 5]> = (0..theta.len()).map(basis).collect();
    let mut out = Vec::with_capacity(theta.len() - w + 1);
    // Running sums of the normal equations over the window.
    let mut g = [[0.0f64; 5]; 5];
    let mut r = [0.0f64; 5];
    let add = |g: &mut [[f64; 5]; 5], r: &mut [f64; 5], row: &[f64; 5], y: f64, sign: f64| {
        for a in 0..5 {
            r[a] += sign * row[a] * y;
            for b in 0..5 {
                g[a][b] += sign * row[a] * row[b];
            }
        }
    };
    for i in 0..w {
        add(&mut g, &mut r, &rows[i], theta[i], 1.0);
    }
    for start in 0..=theta.len() - w {
        if start > 0 {
            // Recompute from scratch every 256 steps to keep round-off of the running sums
            // from accumulating.
            if start % 256 == 0 {
                g = [[0.0; 5]; 5];
                r = [0.0; 5];
                for i in start..start + w {
                    add(&mut g, &mut r, &rows[i], theta[i], 1.0);
                }
            } else {
                add(&mut g, &mut r, &rows[start - 1], theta[start - 1], -1.0);
                add(&mut g, &mut r, &rows[start + w - 1], theta[start + w - 1], 1.0);
            }
        }
        let c = solve5(g, r).ok_or_else(|| SpectrumError::BadInput {
            what: "window_s",
            why: format!("the window of {w} samples does not separate {freqs_hz:?} Hz (singular fit)"),
        })?;
        let centre = (start as f64 + 0.5 * (w - 1) as f64) * dt;
        out.push((centre, [c[1].hypot(c[2]), c[3].hypot(c[4])]));
    }
    Ok(out)
}

/// Gaussian elimination with partial pivoting on a 5x5 system; `None` if (near) singular.
fn solve5(mut a: [[f64; 5]; 5], mut b: [f64; 5]) -> Option<[f64; 5]> {
    let scale = a.iter().map(|r| r.iter().fold(0.0f64, |m, v| m.max(v.abs()))).fold(0.0f64, f64::max);
    for k in 0..5 {
        let p = (k..5).max_by(|&i, &j| a[i][k].abs().total_cmp(&a[j][k].abs()))?;
        if a[p][k].abs() <= 1e-12 * scale {
            return None;
        }
        a.swap(k, p);
        b.swap(k, p);
        for i in k + 1..5 {
            let f = a[i][k] / a[k][k];
            for j in k..5 {
                a[i][j] -= f * a[k][j];
            }
            b[i] -= f * b[k];
        }
    }
    let mut x = [0.0; 5];
    for k in (0..5).rev() {
        let s: f64 = (k + 1..5).map(|j| a[k][j] * x[j]).sum();
        x[k] = (b[k] - s) / a[k][k];
    }
    Some(x)
}

// ---------------------------------------------------------------------------------------
// Spectra with peak interpolation
// ---------------------------------------------------------------------------------------

/// One spectral peak.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Peak {
    /// Interpolated peak frequency (Hz).
    pub freq_hz: f64,
    /// Amplitude of the equivalent sinusoid (rad), Hann-window gain removed.
    pub amplitude: f64,
}

/// Hann-windowed, mean-removed, zero-padded (x[`PAD`], to a power of two) amplitude
/// spectrum, scaled so a sinusoid `A cos(...)` on a bin reads `A`. Returns `(freqs, amps,
/// bin width of the unpadded series in Hz)`.
fn hann_spectrum(x: &[f64], dt: f64) -> (Vec<f64>, Vec<f64>, f64) {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n as f64;
    let w: Vec<f64> = (0..n).map(|i| 0.5 - 0.5 * (TAU * i as f64 / n as f64).cos()).collect();
    let wsum: f64 = w.iter().sum();
    let m = (PAD * n).next_power_of_two();
    let mut y = vec![0.0; m];
    for i in 0..n {
        y[i] = (x[i] - mean) * w[i];
    }
    let (f, mut a) = amplitude_spectrum(&y, dt);
    let gain = m as f64 / wsum;
    for v in &mut a {
        *v *= gain;
    }
    (f, a, 1.0 / (n as f64 * dt))
}

/// Quadratic interpolation of the log-amplitude through bin `k` and its neighbours (exact
/// for a Gaussian peak, a close fit of the Hann main lobe): `(freq, amplitude)`.
fn interpolate(f: &[f64], a: &[f64], k: usize) -> (f64, f64) {
    if k == 0 || k + 1 >= a.len() || a[k - 1] <= 0.0 || a[k + 1] <= 0.0 || a[k] <= 0.0 {
        return (f[k], a[k]);
    }
    let (l, c, r) = (a[k - 1].ln(), a[k].ln(), a[k + 1].ln());
    let den = l - 2.0 * c + r;
    if den >= 0.0 {
        return (f[k], a[k]);
    }
    let d = 0.5 * (l - r) / den;
    let df = f[1] - f[0];
    (f[k] + d * df, (c - 0.25 * (l - r) * d).exp())
}

/// Local maxima of the Hann spectrum of `x` above `rel` times the largest, DC excluded,
/// peaks within [`PEAK_MERGE_BINS`] unpadded bins merged into the larger; sorted by
/// frequency.
pub fn spectral_peaks(x: &[f64], dt: f64, rel: f64) -> Result<Vec<Peak>, SpectrumError> {
    if x.len() < 16 {
        return Err(SpectrumError::BadInput {
            what: "series",
            why: format!("need at least 16 samples, got {}", x.len()),
        });
    }
    if !(dt.is_finite() && dt > 0.0) || !(rel.is_finite() && rel > 0.0 && rel < 1.0) {
        return Err(SpectrumError::BadInput {
            what: "spectral_peaks",
            why: format!("dt {dt} must be positive, rel {rel} in (0, 1)"),
        });
    }
    let (f, a, bin) = hann_spectrum(x, dt);
    // Skip the DC lobe (the Hann main lobe is 2 bins wide each side).
    let first = ((2.0 * bin) / (f[1] - f[0])).ceil() as usize;
    let mut cands: Vec<Peak> = (first.max(1)..a.len().saturating_sub(1))
        .filter(|&k| a[k] > a[k - 1] && a[k] >= a[k + 1])
        .map(|k| {
            let (freq_hz, amplitude) = interpolate(&f, &a, k);
            Peak { freq_hz, amplitude }
        })
        .collect();
    let top = cands.iter().fold(0.0f64, |m, p| m.max(p.amplitude));
    cands.retain(|p| p.amplitude >= rel * top);
    // Merge: repeatedly keep the largest and drop its neighbours within the merge distance.
    cands.sort_by(|p, q| q.amplitude.total_cmp(&p.amplitude));
    let mut kept: Vec<Peak> = Vec::new();
    for p in cands {
        if kept.iter().all(|k| (k.freq_hz - p.freq_hz).abs() > PEAK_MERGE_BINS * bin) {
            kept.push(p);
        }
    }
    kept.sort_by(|p, q| p.freq_hz.total_cmp(&q.freq_hz));
    Ok(kept)
}

/// The largest interpolated peak of the Hann spectrum of `x` within `[lo, hi)` Hz.
pub fn band_peak(x: &[f64], dt: f64, lo: f64, hi: f64) -> Option<Peak> {
    if x.len() < 16 {
        return None;
    }
    let (f, a, _) = hann_spectrum(x, dt);
    let k =
        (1..a.len().saturating_sub(1)).filter(|&k| f[k] >= lo && f[k] < hi).max_by(|&i, &j| a[i].total_cmp(&a[j]))?;
    let (freq_hz, amplitude) = interpolate(&f, &a, k);
    Some(Peak { freq_hz, amplitude })
}

/// Median of the adjacent-peak spacings within each of the two clusters split at `split` Hz.
pub fn sideband_spacing(peaks: &[Peak], split: f64) -> Option<f64> {
    let mut d: Vec<f64> = Vec::new();
    for cluster in [
        peaks.iter().filter(|p| p.freq_hz < split).collect::<Vec<_>>(),
        peaks.iter().filter(|p| p.freq_hz >= split).collect(),
    ] {
        d.extend(cluster.windows(2).map(|w| w[1].freq_hz - w[0].freq_hz));
    }
    if d.is_empty() {
        return None;
    }
    d.sort_by(f64::total_cmp);
    let m = d.len();
    Some(if m % 2 == 1 { d[m / 2] } else { 0.5 * (d[m / 2 - 1] + d[m / 2]) })
}
