//! Tests of the exact linear stability against independent routes and the physics of
//! `shared/MODEL.md`.

mod expm;

use nalgebra::DVector;
use nalgebra::{Complex, DMatrix, Matrix4, Vector4};
use shared::ControllerConfig;
use sim::linear::*;
use sim::units::ms_to_s;

/// The eigenvalues of `m` through faer (`Mat::eigenvalues`): the independent second route
/// [`eigenvalues`] (nalgebra's Schur decomposition) is checked against.
fn eigenvalues_faer(m: &DMatrix<f64>) -> Result<Vec<Complex<f64>>, LinearError> {
    let n = m.nrows();
    let fm = faer::Mat::<f64>::from_fn(n, m.ncols(), |i, j| m[(i, j)]);
    let ev = fm.eigenvalues().map_err(|e| LinearError::Eigen { n, reason: format!("faer: {e:?}") })?;
    Ok(ev.into_iter().map(|c| Complex::new(c.re, c.im)).collect())
}

/// Paper parameters (MODEL.md).
pub(crate) mod furuta {
    pub const M: f64 = 0.191;
    pub const L: f64 = 0.15;
    pub const R: f64 = 0.094;
    pub const G: f64 = 9.81;
    pub const JP: f64 = 5.73e-3;
    pub const JA: f64 = 1.34e-3;
    pub const B1: f64 = 0.039;
    pub const B2: f64 = 0.02094;
    pub const NM: f64 = 1.05;
    pub const K: f64 = 1.12706;
}

/// Linearization of the corrected Furuta model at the upright equilibrium, state
/// (theta, w_theta, phi, w_phi), written out by hand from MODEL.md.
pub(crate) fn furuta_ab() -> (Matrix4<f64>, Vector4<f64>) {
    use furuta::*;
    let mrl = M * R * L;
    let mgl = M * G * L;
    let d0 = JP * JA - mrl * mrl;
    let kb = K + B2;
    let a = Matrix4::new(
        0.0,
        1.0,
        0.0,
        0.0,
        JA * mgl / d0,
        -JA * B1 / d0,
        0.0,
        -mrl * kb / d0,
        0.0,
        0.0,
        0.0,
        1.0,
        mrl * mgl / d0,
        -mrl * B1 / d0,
        0.0,
        -JP * kb / d0,
    );
    let b = Vector4::new(0.0, mrl * NM / d0, 0.0, JP * NM / d0);
    (a, b)
}

fn plant() -> LinearPlant {
    let (a, b) = furuta_ab();
    LinearPlant::new(&a, &b, 0, 2).unwrap()
}

fn max_rel_diff(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    (a - b).iter().fold(0.0f64, |m, v| m.max(v.abs())) / scale
}

/// Phi and Gamma by classical RK4 on `X' = A X, X(0) = I` and `G' = A G + B, G(0) = 0`
/// with a fixed step of about `h` s.
fn zoh_rk4(p: &LinearPlant, dt: f64, h: f64) -> (DMatrix<f64>, DVector<f64>) {
    let n = p.dim();
    let steps = (dt / h).round() as usize;
    let h = dt / steps as f64;
    // Columns 0..n: X, column n: G; derivative of column n carries + B.
    let mut y = DMatrix::<f64>::zeros(n, n + 1);
    y.view_mut((0, 0), (n, n)).fill_with_identity();
    let f = |y: &DMatrix<f64>| {
        let mut d = p.a() * y;
        let mut last = d.column_mut(n);
        last += p.b();
        d
    };
    for _ in 0..steps {
        let k1 = f(&y);
        let k2 = f(&(&y + &k1 * (h / 2.0)));
        let k3 = f(&(&y + &k2 * (h / 2.0)));
        let k4 = f(&(&y + &k3 * h));
        y += (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0);
    }
    (y.view((0, 0), (n, n)).into_owned(), y.column(n).into_owned())
}

/// Phi and Gamma from the eigendecomposition of A (real, distinct eigenvalues here):
/// `Phi = V e^{L dt} V^-1`, `Gamma = V diag(phi1(l dt) dt) V^-1 B`, with each
/// eigenvector computed as the null vector of `A - l I` (SVD).
fn zoh_eigen(p: &LinearPlant, dt: f64) -> (DMatrix<f64>, DVector<f64>) {
    let n = p.dim();
    let ev = eigenvalues_faer(p.a()).unwrap();
    let mut v = DMatrix::<f64>::zeros(n, n);
    let mut lam = Vec::new();
    for (k, c) in ev.iter().enumerate() {
        assert!(c.im.abs() < 1e-9 * c.re.abs().max(1.0), "complex eigenvalue {c}");
        let shifted = p.a() - DMatrix::<f64>::identity(n, n) * c.re;
        let svd = shifted.svd(false, true);
        let vt = svd.v_t.unwrap();
        let (imin, _) = svd.singular_values.argmin();
        v.set_column(k, &vt.row(imin).transpose());
        lam.push(c.re);
    }
    let vinv = v.clone().try_inverse().unwrap();
    let e = DMatrix::from_diagonal(&DVector::from_iterator(n, lam.iter().map(|l| (l * dt).exp())));
    let phi1 = DMatrix::from_diagonal(&DVector::from_iterator(
        n,
        lam.iter().map(|l| if *l == 0.0 { dt } else { (l * dt).exp_m1() / l }),
    ));
    (&v * e * &vinv, &v * phi1 * &vinv * p.b())
}

/// Pair each multiplier of `a` with the nearest unused one of `b`; largest distance
/// relative to max(1, |mu|), over multipliers with |mu| >= floor.
fn multiplier_distance(a: &[Multiplier], b: &[Multiplier], floor: f64) -> f64 {
    assert_eq!(a.len(), b.len());
    let mut used = vec![false; b.len()];
    let mut worst = 0.0f64;
    for x in a {
        let (j, d) = b
            .iter()
            .enumerate()
            .filter(|(j, _)| !used[*j])
            .map(|(j, y)| (j, (x.re - y.re).hypot(x.im - y.im)))
            .min_by(|p, q| p.1.total_cmp(&q.1))
            .unwrap();
        used[j] = true;
        if x.abs >= floor {
            worst = worst.max(d / x.abs.max(1.0));
        }
    }
    worst
}

#[test]
fn furuta_linearization_has_the_documented_eigenvalues() {
    // MODEL.md: about -1.56e4, -11.1, 0 and +4.39 1/s.
    let mut ev: Vec<f64> = eigenvalues(plant().a()).unwrap().iter().map(|c| c.re).collect();
    ev.sort_by(f64::total_cmp);
    assert!((ev[0] / -1.56e4 - 1.0).abs() < 0.01, "{ev:?}");
    assert!((ev[1] / -11.1 - 1.0).abs() < 0.01, "{ev:?}");
    assert!(ev[2].abs() < 1e-9, "{ev:?}");
    assert!((ev[3] / 4.39 - 1.0).abs() < 0.01, "{ev:?}");
}

#[test]
fn zoh_matches_eigendecomposition_rk4_and_nalgebra() {
    let p = plant();
    for dt in [0.001, 0.02, 0.025, 0.0308, 0.0323] {
        let z = p.discretize(dt).unwrap();
        let (phi_e, gamma_e) = zoh_eigen(&p, dt);
        let (phi_r, gamma_r) = zoh_rk4(&p, dt, 1e-6);
        let g = |v: &DVector<f64>| DMatrix::from_column_slice(v.len(), 1, v.as_slice());
        let e_phi = max_rel_diff(&z.phi, &phi_e);
        let e_gamma = max_rel_diff(&g(&z.gamma), &g(&gamma_e));
        let r_phi = max_rel_diff(&z.phi, &phi_r);
        let r_gamma = max_rel_diff(&g(&z.gamma), &g(&gamma_r));
        // nalgebra's own exp() of the same augmented matrix.
        let n = p.dim();
        let mut aug = DMatrix::<f64>::zeros(n + 1, n + 1);
        aug.view_mut((0, 0), (n, n)).copy_from(&(p.a() * dt));
        aug.view_mut((0, n), (n, 1)).copy_from(&(p.b() * dt));
        let na = aug.exp();
        let n_phi = max_rel_diff(&z.phi, &na.view((0, 0), (n, n)).into_owned());
        println!(
            "dt {dt}: vs eigen {e_phi:.1e} {e_gamma:.1e}; vs RK4 {r_phi:.1e} {r_gamma:.1e}; vs nalgebra exp {n_phi:.1e}"
        );
        assert!(e_phi < 1e-9 && e_gamma < 1e-9, "eigen route: {e_phi:e} {e_gamma:e}");
        assert!(r_phi < 1e-9 && r_gamma < 1e-9, "RK4 route: {r_phi:e} {r_gamma:e}");
        assert!(n_phi < 1e-9, "nalgebra exp: {n_phi:e}");
        // phi never enters: column 2 of Phi is e_2 (to rounding).
        for i in 0..n {
            let want = if i == 2 { 1.0 } else { 0.0 };
            assert!((z.phi[(i, 2)] - want).abs() < 1e-14, "Phi[{i}][2] = {}", z.phi[(i, 2)]);
        }
    }
}

#[test]
fn multipliers_match_those_of_independent_discretizations() {
    let p = plant();
    for dt in [0.02, 0.025, 0.0308, 0.0323] {
        let cfg = ControllerConfig::paper(dt);
        let z = p.discretize(dt).unwrap();
        let ours = z.closed_loop(&cfg).unwrap().multipliers().unwrap();
        for (phi, gamma) in [zoh_eigen(&p, dt), zoh_rk4(&p, dt, 1e-6)] {
            let mut zo = z.clone();
            (zo.phi, zo.gamma) = (phi, gamma);
            let other = zo.closed_loop(&cfg).unwrap().multipliers().unwrap();
            let d = multiplier_distance(&ours, &other, 1e-3);
            assert!(d < 1e-9, "dt {dt}: multiplier distance {d:e}");
        }
    }
}

#[test]
fn faer_and_nalgebra_eigenvalues_agree() {
    let p = plant();
    for (dt, kp, kd) in [(0.025, 15.5, 5.45), (0.02, 25.0, 6.0), (0.0308, 15.5, 5.45), (0.03, 0.0, 0.0)] {
        let cfg = ControllerConfig::shorthand(kp, kd, 1.5, dt);
        let m = p.closed_loop(&cfg).unwrap();
        let a: Vec<_> = eigenvalues(&m.matrix).unwrap().iter().map(|c| Multiplier::new(c.re, c.im, dt)).collect();
        let b: Vec<_> = eigenvalues_faer(&m.matrix).unwrap().iter().map(|c| Multiplier::new(c.re, c.im, dt)).collect();
        let d = multiplier_distance(&a, &b, 1e-3);
        assert!(d < 1e-11, "dt {dt} kp {kp} kd {kd}: {d:e}");
    }
}

/// Runs the delayed law by hand (ring buffers of past samples) and compares with powers of
/// the closed-loop matrix: checks the layout of the augmented state and the law.
#[test]
fn closed_loop_matrix_reproduces_the_delayed_law() {
    let p = plant();
    for (delay, ki) in [(0u32, 0.0), (1, 0.0), (2, 0.0), (1, 3.0), (3, 2.0)] {
        let dt = 0.02;
        let cfg = ControllerConfig { delay, ki, ..ControllerConfig::paper(dt) };
        let z = p.discretize(dt).unwrap();
        let map = z.closed_loop(&cfg).unwrap();
        let lay = map.layout;
        let r = delay as usize;
        assert_eq!(lay.dim, 4 + 2 * (r + 1) + usize::from(ki != 0.0));
        // An arbitrary initial augmented state.
        let s0 = DVector::from_iterator(lay.dim, (0..lay.dim).map(|k| ((k as f64 + 1.0) * 0.731).sin() * 0.1));
        // Histories: y_hist[d] = y_{i-d}, d = 0..=r+1 (y_hist[0] filled from x each step).
        let mut x: DVector<f64> = s0.rows(0, 4).into_owned();
        let mut y_hist: Vec<f64> = std::iter::once(x[0]).chain((0..=r).map(|k| s0[lay.y_start + k])).collect();
        let mut z_hist: Vec<f64> = std::iter::once(x[2]).chain((0..=r).map(|k| s0[lay.z_start + k])).collect();
        let mut xi = lay.integral.map_or(0.0, |s| s0[s]);
        let mut s = s0.clone();
        for step in 0..40 {
            y_hist[0] = x[0];
            z_hist[0] = x[2];
            xi += dt * y_hist[r];
            let (kp, kd, kphi_d) = cfg.as_shorthand().unwrap();
            let u = -kp * y_hist[r] - kd * (y_hist[r] - y_hist[r + 1]) / dt + kphi_d * (z_hist[r] - z_hist[r + 1]) / dt
                - cfg.ki * xi;
            x = &z.phi * &x + &z.gamma * u;
            y_hist.rotate_right(1);
            z_hist.rotate_right(1);
            s = &map.matrix * &s;
            let mut want = DVector::<f64>::zeros(lay.dim);
            want.rows_mut(0, 4).copy_from(&x);
            for k in 0..=r {
                want[lay.y_start + k] = y_hist[k + 1];
                want[lay.z_start + k] = z_hist[k + 1];
            }
            if let Some(si) = lay.integral {
                want[si] = xi;
            }
            let err = (&s - &want).amax() / want.amax();
            assert!(err < 1e-12, "delay {delay} ki {ki} step {step}: {err:e}");
        }
    }
}

#[test]
fn structural_multiplier_is_removed_exactly() {
    let p = plant();
    for (dt, delay, ki) in [(0.025, 1u32, 0.0), (0.02, 0, 0.0), (0.0308, 2, 1.0)] {
        let cfg = ControllerConfig { delay, ki, ..ControllerConfig::paper(dt) };
        let map = p.closed_loop(&cfg).unwrap();
        // The known eigenvector: M v = v.
        let v = map.structural_eigenvector();
        let res = (&map.matrix * &v - &v).amax();
        assert!(res < 1e-14, "M v - v = {res:e}");
        let all = map.multipliers().unwrap();
        let dom = map.dominant_multipliers().unwrap();
        assert_eq!(dom.len() + 1, all.len());
        // Exact identity: det(M - l I) = (1 - l) det(R - l I) for the deflated map R.
        let r = map.deflated().unwrap();
        for l in [Complex::new(0.3, 0.8), Complex::new(-1.2, 0.1), Complex::new(2.0, 0.0)] {
            let shift = |m: &DMatrix<f64>| {
                DMatrix::<Complex<f64>>::from_fn(m.nrows(), m.ncols(), |i, j| {
                    Complex::new(m[(i, j)], 0.0) - if i == j { l } else { Complex::new(0.0, 0.0) }
                })
                .determinant()
            };
            let (full, defl) = (shift(&map.matrix), shift(&r) * (Complex::new(1.0, 0.0) - l));
            assert!((full - defl).norm() < 1e-12 * full.norm(), "l = {l}: {full} vs {defl}");
        }
        // The deflated spectrum plus the multiplier 1 is the full spectrum. With integral
        // action a second multiplier sits close to 1, and eigenvalues of such a cluster are
        // only determined to about sqrt(eps) in the full map; hence the looser tolerance.
        let mut with_one = dom.clone();
        with_one.push(Multiplier::new(1.0, 0.0, dt));
        let d = multiplier_distance(&all, &with_one, 1e-3);
        let tol = if ki == 0.0 { 1e-10 } else { 1e-6 };
        assert!(d < tol, "dt {dt} delay {delay}: {d:e}");
    }
}

#[test]
fn coupled_secondary_has_no_structural_multiplier() {
    let (mut a, b) = furuta_ab();
    a[(1, 2)] = 1e-3;
    let err = dominant_multipliers(&a, &b, 0, 2, &ControllerConfig::paper(0.025)).unwrap_err();
    assert_eq!(err, LinearError::SecondaryCouples { index: 2, row: 1, value: 1e-3 });
    // Without deflation the multipliers still exist.
    assert_eq!(multipliers(&a, &b, 0, 2, &ControllerConfig::paper(0.025)).unwrap().len(), 8);
}

#[test]
fn bad_inputs_are_named() {
    let (a, b) = furuta_ab();
    let cfg = ControllerConfig::paper(0.025);
    let mut an = a;
    an[(3, 1)] = f64::NAN;
    assert!(matches!(multipliers(&an, &b, 0, 2, &cfg), Err(LinearError::NonFinite { what: "A", row: 3, col: 1, .. })));
    let mut bn = b;
    bn[1] = f64::INFINITY;
    assert!(matches!(multipliers(&a, &bn, 0, 2, &cfg), Err(LinearError::NonFinite { what: "B", row: 1, .. })));
    for dt in [0.0, -0.01, f64::NAN] {
        assert!(matches!(multipliers(&a, &b, 0, 2, &ControllerConfig::paper(dt)), Err(LinearError::BadDt(_))));
    }
    let mut bad = cfg;
    bad.gains[0].d = f64::NAN;
    assert!(matches!(multipliers(&a, &b, 0, 2, &bad), Err(LinearError::BadGain { name: "kd", .. })));
    assert_eq!(multipliers(&a, &b, 0, 0, &cfg), Err(LinearError::SameIndex(0)));
    assert!(matches!(
        multipliers(&a, &b, 0, 4, &cfg),
        Err(LinearError::IndexOutOfRange { which: "secondary", index: 4, n: 4 })
    ));
    let long = ControllerConfig { delay: MAX_DELAY + 1, ..cfg };
    assert_eq!(multipliers(&a, &b, 0, 2, &long), Err(LinearError::DelayTooLarge(MAX_DELAY + 1)));
    let z = plant().discretize(0.02).unwrap();
    assert!(matches!(z.closed_loop(&cfg), Err(LinearError::DtMismatch { .. })));
}

#[test]
fn multiplier_fields_and_json() {
    let dt = 0.025;
    let m = Multiplier::new(-0.5, -0.5, dt);
    assert!((m.abs - 0.5f64.sqrt()).abs() < 1e-15);
    assert!((m.freq_hz - 0.375 / dt).abs() < 1e-12, "{}", m.freq_hz);
    assert!((m.rate - 0.5f64.sqrt().ln() / dt).abs() < 1e-12);
    let json = serde_json::to_value(Multiplier::new(0.0, 0.0, dt)).unwrap();
    assert_eq!(json, serde_json::json!({"re": 0.0, "im": 0.0, "abs": 0.0, "freq_hz": 0.0, "rate": null}));
    let json = serde_json::to_value(Multiplier::new(2.0, 0.0, 0.5)).unwrap();
    let obj = json.as_object().unwrap();
    assert_eq!(obj.len(), 5);
    assert!((obj["rate"].as_f64().unwrap() - 2.0f64.ln() / 0.5).abs() < 1e-15);
}

/// The two complex pairs of largest modulus among the non-structural multipliers:
/// (fast, slow) by frequency.
fn two_pairs(dom: &[Multiplier]) -> (Multiplier, Multiplier) {
    let pairs: Vec<_> = dom.iter().filter(|m| m.im > 0.0).take(2).copied().collect();
    assert_eq!(pairs.len(), 2, "{dom:?}");
    if pairs[0].freq_hz > pairs[1].freq_hz { (pairs[0], pairs[1]) } else { (pairs[1], pairs[0]) }
}

#[test]
fn paper_point_at_25_ms_is_just_past_the_double_hopf() {
    let (a, b) = furuta_ab();
    let dom = dominant_multipliers(&a, &b, 0, 2, &ControllerConfig::paper(0.025)).unwrap();
    for m in &dom {
        println!("{m:?}");
    }
    let (fast, slow) = two_pairs(&dom);
    // One pair just outside the unit circle at ~10 Hz, one just inside at ~0.45 Hz, and
    // nothing else near or outside the circle.
    assert!(fast.abs > 1.0 && fast.abs < 1.02, "{fast:?}");
    assert!((fast.freq_hz - 10.0).abs() < 1.0, "{fast:?}");
    assert!(slow.abs < 1.0 && slow.abs > 0.98, "{slow:?}");
    assert!((slow.freq_hz - 0.45).abs() < 0.05, "{slow:?}");
    // Sorted by modulus: the two pairs come first, the rest is well inside.
    assert_eq!((dom[0].abs, dom[2].abs), (fast.abs, slow.abs), "{dom:?}");
    assert!(dom[4].abs < 0.9, "{dom:?}");
}

#[test]
fn rates_reproduce_the_normal_form_linear_coefficients() {
    let (a, b) = furuta_ab();
    let table = [
        // dt (ms), rho_1 (slow) and rho_2 (fast) linear coefficients of the paper's table.
        (30.80, -0.11, 0.27),
        (31.40, -0.10, 0.27),
        (31.41, -0.10, 0.27),
        (31.55, -0.09, 0.27),
        (31.68, -0.09, 0.26),
        (32.30, -0.07, 0.27),
    ];
    println!("dt [ms]  fast: |mu| f [Hz] rate [1/s]   slow: |mu| f [Hz] rate [1/s]");
    for dt_ms in [30.5, 30.8, 31.0, 31.2, 31.4, 31.41, 31.55, 31.68, 32.0, 32.3, 32.5] {
        let dom = dominant_multipliers(&a, &b, 0, 2, &ControllerConfig::paper(ms_to_s(dt_ms))).unwrap();
        let (fast, slow) = two_pairs(&dom);
        println!(
            "{dt_ms:6.2}  {:.6} {:.4} {:+.5}   {:.6} {:.4} {:+.5}",
            fast.abs, fast.freq_hz, fast.rate, slow.abs, slow.freq_hz, slow.rate
        );
        if let Some(&(_, slow_nf, fast_nf)) = table.iter().find(|t| t.0 == dt_ms) {
            // The table prints two decimals, and a fitted normal form is not exact: allow
            // 0.015 1/s (rounding 0.005 plus a fit error of 0.01).
            assert!((fast.rate - fast_nf).abs() < 0.015, "dt {dt_ms}: fast {} vs {fast_nf}", fast.rate);
            assert!((slow.rate - slow_nf).abs() < 0.015, "dt {dt_ms}: slow {} vs {slow_nf}", slow.rate);
        }
    }
}

#[test]
fn experimental_gains_are_unstable_at_20_ms() {
    let (a, b) = furuta_ab();
    let cfg = ControllerConfig::shorthand(25.0, 6.0, 1.5, 0.02);
    let dom = dominant_multipliers(&a, &b, 0, 2, &cfg).unwrap();
    assert!(spectral_radius(&dom) > 1.0, "{dom:?}");
    // MODEL.md: KD must be below about 5.3 at 20 ms.
    let at = |kd: f64| spectral_radius(&dominant_multipliers(&a, &b, 0, 2, &cfg.with_primary(25.0, kd)).unwrap());
    assert!(at(5.2) < 1.0 && at(5.4) > 1.0, "{} {}", at(5.2), at(5.4));
}

/// Regression: `kp = 1e200` or `dt = 1e-303 s` gave multipliers and rates that are rounding
/// noise. The computation checks its own accuracy
/// bound and refuses, naming the gain or dt; ordinary and even large-but-sane values pass.
#[test]
fn untrustworthy_multipliers_are_refused_naming_the_cause() {
    let p = plant();
    let cfg = |kp: f64, kd: f64, dt: f64| ControllerConfig::shorthand(kp, kd, 1.5, dt);
    for (c, cause) in [
        (cfg(1e200, 5.45, 0.025), "controller gain kp = 1e200"),
        (cfg(1e12, 5.45, 0.025), "controller gain kp = 1e12"),
        (cfg(15.5, -1e15, 0.025), "controller gain kd = -1e15"),
        (ControllerConfig::shorthand(15.5, 5.45, 1e14, 0.025), "controller gain kphi_d = 1e14"),
    ] {
        for e in [
            p.closed_loop(&c).unwrap().multipliers().unwrap_err(),
            p.closed_loop(&c).unwrap().dominant_multipliers().unwrap_err(),
        ] {
            assert!(matches!(e, LinearError::MultipliersInaccurate { .. }), "{e}");
            assert!(e.to_string().starts_with(cause) && e.to_string().contains("refusing"), "{e}");
        }
    }
    // A step that does not move the state on the f64 grid is refused at the discretization;
    // a longer one whose rates the rounding swamps, at the multipliers. Both are the
    // sampling period's error.
    for dt in [1e-303, 1e-21] {
        let e = p.closed_loop(&cfg(15.5, 5.45, dt)).unwrap_err();
        assert!(matches!(e, LinearError::StepUnderflow { .. }), "dt {dt}: {e}");
        assert!(e.to_string().contains(&format!("dt = {dt:e} s underflows")), "{e}");
        assert_eq!(e.scene_key(), Some("controller.dt_ms"));
    }
    for dt in [1e-18, 1e-14] {
        let e = p.closed_loop(&cfg(15.5, 5.45, dt)).unwrap().multipliers().unwrap_err();
        assert!(matches!(e, LinearError::RatesInaccurate { .. }), "dt {dt}: {e}");
        assert!(e.to_string().contains(&format!("dt = {dt:e} s")), "{e}");
        assert_eq!(e.scene_key(), Some("controller.dt_ms"));
    }
    // A period so long that e^(A dt) cannot be formed accurately: named by dt.
    let e = p.closed_loop(&cfg(15.5, 5.45, 1e5)).unwrap_err();
    assert!(matches!(e, LinearError::ExponentTooLarge { .. }) && e.to_string().contains("dt = 100000 s"), "{e}");
    // What the study and the charts use passes, as do large but resolvable values.
    for c in [
        cfg(15.5, 5.45, 0.025),
        cfg(40.0, 8.0, 0.001),
        cfg(1e5, 1e3, 1e-4),
        cfg(15.5, 5.45, 1e-7),
        cfg(15.5, 5.45, 0.1),
    ] {
        let m = p.closed_loop(&c).unwrap();
        assert!(m.multipliers().is_ok() && m.dominant_multipliers().is_ok(), "{c:?}: {:?}", m.check_accuracy());
    }
}
