//! The tests of `ssm::frc`.

use ssm::dynamics::ReducedDynamics;
use ssm::fit::SsmModel;
use ssm::frc::*;
use ssm::poly::{self, Poly};

// The Duffing normal form: z' = z (A + i (W + C |z|^2)) (constant damping, hardening
// backbone), observed through y_0 = Re z (amplitude exactly rho).
const A: f64 = -0.05;
const W: f64 = 2.0;
const C: f64 = 0.8;
const F: f64 = 0.025;

/// `z' = z (a + i w + (b + i c) |z|^2)` in `eta = (Re z, Im z)`.
fn field(a: f64, w: f64, b: f64, c: f64) -> Poly {
    let exps = poly::exponents(2, 1, 3);
    let mut coef = vec![0.0; exps.len() * 2];
    for (k, e) in exps.iter().enumerate() {
        let (o0, o1) = match (e[0], e[1]) {
            (1, 0) => (a, w),
            (0, 1) => (-w, a),
            (3, 0) | (1, 2) => (b, c),
            (2, 1) | (0, 3) => (-c, b),
            _ => (0.0, 0.0),
        };
        coef[k * 2] = o0;
        coef[k * 2 + 1] = o1;
    }
    Poly { dim_in: 2, dim_out: 2, scale: vec![1.0, 1.0], exps, coef }
}

fn model(a: f64, w: f64, b: f64, c: f64) -> SsmModel {
    let mut m = crate::backbone::model(0.0, 0.0);
    m.dynamics = ReducedDynamics::Flow { field: field(a, w, b, c), conditioning: ssm::ridge::Conditioning::NONE };
    m
}

/// Real roots of `c[3] x^3 + c[2] x^2 + c[1] x + c[0]` (c[3] != 0), trigonometric or
/// Cardano form of the depressed cubic, ascending.
fn cubic_roots(c: [f64; 4]) -> Vec<f64> {
    let (a, b, cc) = (c[2] / c[3], c[1] / c[3], c[0] / c[3]);
    let p = b - a * a / 3.0;
    let q = 2.0 * a.powi(3) / 27.0 - a * b / 3.0 + cc;
    let disc = (q / 2.0).powi(2) + (p / 3.0).powi(3);
    let mut r = if disc > 0.0 {
        let s = disc.sqrt();
        vec![(-q / 2.0 + s).cbrt() + (-q / 2.0 - s).cbrt()]
    } else {
        let m = 2.0 * (-p / 3.0).sqrt();
        let th = (3.0 * q / (p * m)).acos() / 3.0;
        (0..3).map(|k| m * (th - 2.0 * std::f64::consts::PI * k as f64 / 3.0).cos()).collect()
    };
    for x in &mut r {
        *x -= a / 3.0;
    }
    r.sort_by(f64::total_cmp);
    r
}

/// First-order harmonic balance of the Duffing normal form: `P = rho^2` solves
/// `C^2 P^3 + 2 C (W - Omega) P^2 + (A^2 + (W - Omega)^2) P - F^2 = 0`; with three
/// positive roots the middle one is unstable (a saddle between the folds).
fn harmonic_balance(omega: f64) -> Vec<(f64, bool)> {
    let d = W - omega;
    let p: Vec<f64> =
        cubic_roots([-F * F, A * A + d * d, 2.0 * C * d, C * C]).into_iter().filter(|&p| p > 0.0).collect();
    let n = p.len();
    p.into_iter().enumerate().map(|(i, p)| (p.sqrt(), !(n == 3 && i == 1))).collect()
}

/// The upper fold: max over P of `W + C P + sqrt(F^2 / P - A^2)` (where its derivative
/// `C - F^2 / (2 P^2 sqrt(F^2 / P - A^2))` vanishes; the lower fold is the other zero).
fn folds() -> (f64, f64) {
    let om = |p: f64| W + C * p + (F * F / p - A * A).sqrt();
    let d = |p: f64| C - F * F / (2.0 * p * p * (F * F / p - A * A).sqrt());
    let p_peak = (F / A).powi(2);
    // d < 0 at small P, > 0 in between, < 0 near the peak: two zeros.
    let zero = |mut lo: f64, mut hi: f64| {
        let s = d(lo) < 0.0;
        for _ in 0..200 {
            let m = 0.5 * (lo + hi);
            if (d(m) < 0.0) == s {
                lo = m;
            } else {
                hi = m;
            }
        }
        0.5 * (lo + hi)
    };
    let grid: Vec<f64> = (1..2000).map(|k| p_peak * k as f64 / 2000.0).collect();
    let i = grid.iter().position(|&p| d(p) > 0.0).unwrap();
    let j = i + grid[i..].iter().position(|&p| d(p) < 0.0).unwrap();
    (om(zero(grid[i - 1], grid[i])), om(zero(grid[j - 1], grid[j])))
}

#[test]
fn frc_of_the_duffing_normal_form_is_the_harmonic_balance_one() {
    let m = model(A, W, 0.0, C);
    let opts = FrcOptions { amplitude_max: Some(1.0), ..FrcOptions::new(0) };
    // Calibrate at a point of the exact curve below resonance: the forcing comes back.
    let om_c = W - 0.15;
    let hb = harmonic_balance(om_c);
    assert_eq!(hb.len(), 1);
    let fr = ForcedResponse::calibrate(&m, &opts, Calibration { freq_rad_s: om_c, amplitude: hb[0].0 }).unwrap();
    assert!((fr.forced.forcing - F).abs() < 1e-9 * F, "forcing {} vs {F}", fr.forced.forcing);
    assert!((fr.calibration.rho - hb[0].0).abs() < 1e-9);
    let (fold_lo, fold_hi) = folds();
    let mut three = 0;
    for k in 0..=300 {
        let om = W - 0.3 + 0.8 * k as f64 / 300.0;
        let hb = harmonic_balance(om);
        let got = fr.at(om).unwrap();
        three += usize::from(hb.len() == 3);
        assert_eq!(got.len(), hb.len(), "Omega {om}: {got:?} vs {hb:?}");
        for (g, (rho, stable)) in got.iter().zip(&hb) {
            assert!((g.rho - rho).abs() < 1e-9 && (g.amplitude - rho).abs() < 1e-9, "Omega {om}: {g:?} vs {rho}");
            assert_eq!(g.stable, *stable, "Omega {om}: {g:?}");
        }
    }
    eprintln!("{three} of 301 frequencies with three steady states");
    assert!(three > 20, "the hysteresis window is resolved ({three} frequencies with 3 solutions)");
    // The curve: stable up through the peak to the upper fold, unstable back to the
    // lower fold, stable again; the folds where harmonic balance puts them.
    let (lo, hi) = (W - 0.3, W + 0.5);
    let curve = fr.curve(lo, hi, 400).unwrap();
    let st: Vec<bool> = curve.branches.iter().map(|b| b.stable).collect();
    assert_eq!(
        st,
        [true, false, true],
        "{:?}",
        curve.branches.iter().map(|b| (b.stable, b.freq_rad_s.len())).collect::<Vec<_>>()
    );
    let b = &curve.branches;
    let (f_hi, f_lo) = (*b[0].freq_rad_s.last().unwrap(), *b[1].freq_rad_s.last().unwrap());
    assert!(
        (f_hi - fold_hi).abs() < 1e-9 && (f_lo - fold_lo).abs() < 1e-9,
        "folds {f_lo} {f_hi} vs {fold_lo} {fold_hi}"
    );
    assert!((b[0].freq_rad_s[0] - lo).abs() < 1e-12 && (b[2].freq_rad_s.last().unwrap() - hi).abs() < 1e-12);
    assert_eq!(b[0].freq_rad_s.last(), b[1].freq_rad_s.first().map(|_| b[0].freq_rad_s.last().unwrap()));
    // Every point is a steady state with the forcing, and the peak is at rho = F / |A|.
    let mut top: f64 = 0.0;
    for br in b {
        for (om, rho) in br.freq_rad_s.iter().zip(&br.rho) {
            assert!((fr.forced.forcing_for(*rho, *om) - F).abs() < 1e-9, "({om}, {rho})");
            top = top.max(*rho);
        }
        // Resolution: steps of at most 1/400 of the range in frequency and of rho_max in rho.
        for w in br.freq_rad_s.windows(2).zip(br.rho.windows(2)) {
            assert!(
                (w.0[1] - w.0[0]).abs() <= (hi - lo) / 400.0 + 1e-12
                    && (w.1[1] - w.1[0]).abs() <= fr.rho_max / 400.0 + 1e-12
            );
        }
    }
    assert!((top - F / A.abs()).abs() < 1e-4, "peak {top}");
}

#[test]
fn bad_calibrations_and_ranges_are_named() {
    let m = model(A, W, 0.0, C);
    let opts = FrcOptions { amplitude_max: Some(1.0), ..FrcOptions::new(0) };
    let cal = |freq_rad_s, amplitude| ForcedResponse::calibrate(&m, &opts, Calibration { freq_rad_s, amplitude });
    for (f, a, what) in [
        (0.0, 0.1, "forcing frequency"),
        (-1.0, 0.1, "forcing frequency"),
        (2.0, 0.0, "positive number"),
        (2.0, f64::NAN, "positive number"),
    ] {
        let e = cal(f, a).err().unwrap();
        assert!(matches!(e, FrcError::OffCurve { .. }) && e.to_string().contains(what), "{e}");
    }
    let e = cal(2.0, 1.5).err().unwrap();
    assert!(
        e.to_string().contains("above the largest the model covers (1") && e.to_string().contains("amplitude 1.5"),
        "{e}"
    );
    // The middle (saddle) solution in the hysteresis window.
    let (fold_lo, fold_hi) = folds();
    let om = 0.5 * (fold_lo + fold_hi);
    let hb = harmonic_balance(om);
    assert_eq!(hb.len(), 3);
    let e = cal(om, hb[1].0).err().unwrap();
    assert!(e.to_string().contains("unstable steady state"), "{e}");
    let ok = cal(om, hb[2].0).unwrap();
    assert!((ok.forced.forcing - F).abs() < 1e-9);
    for (lo, hi, what) in [
        (0.0, 3.0, "must be > 0"),
        (-1.0, 3.0, "must be > 0"),
        (2.0, 2.0, "above the lower end"),
        (2.0, f64::INFINITY, "above"),
    ] {
        let e = ok.curve(lo, hi, 100).unwrap_err();
        assert!(
            matches!(e, FrcError::BadOption { what: "frequency range", .. }) && e.to_string().contains(what),
            "{e}"
        );
    }
    assert!(ok.at(0.0).is_err());
    assert!(matches!(ok.curve(1.0, 3.0, 1).unwrap_err(), FrcError::BadOption { what: "points", .. }));
    let e = ForcedResponse::calibrate(
        &m,
        &FrcOptions { observable: 3, ..opts },
        Calibration { freq_rad_s: 2.0, amplitude: 0.1 },
    )
    .err()
    .unwrap();
    assert!(matches!(e, FrcError::Observable { index: 3, count: 3 }), "{e}");
    let e =
        ForcedResponse::calibrate(&m, &FrcOptions { mode: 1, ..opts }, Calibration { freq_rad_s: 2.0, amplitude: 0.1 })
            .err()
            .unwrap();
    assert!(e.to_string().contains("mode 2 of a normal form with 1 mode"), "{e}");
}

/// Amplitude-dependent damping (`B < 0`) closes the curve below the range's edge; with
/// the default range (the model's training range of eta, here |eta_i| <= 1) the curve is
/// cut there: with `F` large enough the peak lies beyond it and the two sides are
/// separate open branches.
#[test]
fn default_range_is_the_training_range_of_eta() {
    let m = model(A, W, -0.5, C);
    let fr = ForcedResponse::calibrate(&m, &FrcOptions::new(0), Calibration { freq_rad_s: W - 1.0, amplitude: 0.5 })
        .unwrap();
    assert!(fr.forced.forcing > 0.55, "f {} > max rho |A(rho)| = 0.55: open curve", fr.forced.forcing);
    // eta_range = (1, 1) and y_0 = Re z: amplitude 1 at rho = 1.
    assert!(
        (fr.rho_max - 1.0).abs() < 1e-9 && (fr.amplitude_max - 1.0).abs() < 1e-9,
        "{} {}",
        fr.rho_max,
        fr.amplitude_max
    );
    let c = fr.curve(0.5, 4.0, 200).unwrap();
    assert!(c.branches.len() >= 2);
    let top = c.branches.iter().flat_map(|b| b.amplitude.iter()).fold(0.0_f64, |a, &b| a.max(b));
    assert!((top - 1.0).abs() < 1e-9, "cut at the range: {top}");
}
