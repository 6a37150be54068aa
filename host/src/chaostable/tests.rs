//! Known-answer tests of the model Benettin exponents, the scale study and the hard cases.

use super::*;
use crate::ssm::Ridge;
use crate::ssm::dynamics::EtaTrajectory;
use chaos::reference::Henon;
use faer::Mat;

/// Published largest exponent of the Hénon map (a = 1.4, b = 0.3), per iteration.
const HENON_LAMBDA: f64 = 0.41922;

/// Hénon's fixed point (x*, b x*), x* = (b - 1 + sqrt((1 - b)^2 + 4 a)) / (2 a). The
/// reduced-map fitters assume the fixed point at the origin (no constant term), so the
/// tests work in `u = x - x*`, where Hénon is the polynomial
/// `u' = -2 a x* u1 - a u1^2 + u2`, `u2' = b u1`.
fn henon_fixed_point() -> [f64; 2] {
    let (a, b) = (1.4_f64, 0.3_f64);
    let x = (b - 1.0 + ((1.0 - b) * (1.0 - b) + 4.0 * a).sqrt()) / (2.0 * a);
    [x, b * x]
}

/// `n` shifted Hénon states after `transient` iterations from (0.1, 0.1).
fn henon_shifted(n: usize, transient: usize) -> Vec<[f64; 2]> {
    let f = henon_fixed_point();
    Henon::default().orbit(n, transient).iter().map(|p| [p[0] - f[0], p[1] - f[1]]).collect()
}

fn henon_eta(n: usize) -> Mat<f64> {
    let orbit = henon_shifted(n, 1000);
    Mat::from_fn(n, 2, |i, j| orbit[i][j])
}

/// A start on the attractor, in shifted coordinates.
fn start() -> [f64; 2] {
    henon_shifted(1, 3000)[0]
}

fn fit_henon(kind: Dynamics, order: u32, n: usize) -> ReducedDynamics {
    let eta = henon_eta(n);
    let trajs = [EtaTrajectory { eta: eta.as_ref(), dt: 1.0 }];
    ReducedDynamics::fit(&trajs, kind, order, Ridge::Fixed(0.0)).unwrap()
}

/// Central finite differences of the map, step `h` per coordinate.
fn fd_jacobian(dynamics: &ReducedDynamics, eta: &[f64], h: f64) -> Vec<f64> {
    let d = eta.len();
    let mut s = StepScratch::default();
    let mut jac = vec![0.0; d * d];
    for j in 0..d {
        let (mut a, mut b) = (eta.to_vec(), eta.to_vec());
        a[j] += h;
        b[j] -= h;
        dynamics.step(&mut a, 1.0, &mut s);
        dynamics.step(&mut b, 1.0, &mut s);
        for i in 0..d {
            jac[i * d + j] = (a[i] - b[i]) / (2.0 * h);
        }
    }
    jac
}

#[test]
fn analytic_jacobians_match_finite_differences() {
    let mut worst = 0.0_f64;
    for (kind, order) in [(Dynamics::Rbf { centers: 100 }, 1), (Dynamics::Map, 3)] {
        let dynm = fit_henon(kind, order, 2000);
        let near_centre = |p: &[f64]| match &dynm {
            ReducedDynamics::Rbf(m) => m.centers.chunks(2).any(|c| (p[0] / m.scale[0] - c[0]).hypot(p[1] / m.scale[1] - c[1]) < 1e-2),
            _ => false,
        };
        // Points on the attractor at least 1e-2 (scaled) from every centre: the kernel's
        // curvature ~1/r would otherwise dominate the finite-difference error.
        let pts: Vec<[f64; 2]> = henon_shifted(2000, 5000).into_iter().filter(|p| !near_centre(p)).take(50).collect();
        assert_eq!(pts.len(), 50);
        for (k, p) in pts.iter().enumerate() {
            let mut jac = vec![0.0; 4];
            map_jacobian(&dynm, p, &mut jac).unwrap();
            // Step 1e-6: the linear kernel's curvature ~1/r near a centre makes larger steps
            // inaccurate; rounding stays below ~1e-9 here.
            let fd = fd_jacobian(&dynm, p, 1e-6);
            for (a, b) in jac.iter().zip(&fd) {
                worst = worst.max((a - b).abs());
                assert!((a - b).abs() < 1e-7, "{kind:?} point {k}: analytic {jac:?} vs FD {fd:?}");
            }
        }
    }
    println!("largest |analytic - FD| Jacobian entry: {worst:.2e}");
    // The quadratic map fitted exactly reproduces Hénon's own Jacobian [[-2 a x, 1], [b, 0]].
    let quad = fit_henon(Dynamics::Map, 2, 500);
    let mut jac = vec![0.0; 4];
    map_jacobian(&quad, &[0.3, -0.2], &mut jac).unwrap();
    let exact = [-2.0 * 1.4 * (0.3 + henon_fixed_point()[0]), 1.0, 0.3, 0.0];
    for (a, b) in jac.iter().zip(exact) {
        assert!((a - b).abs() < 1e-9, "{jac:?}");
    }
    // Exactly at a centre the linear kernel has no derivative: reported, not NaN.
    let ReducedDynamics::Rbf(m) = fit_henon(Dynamics::Rbf { centers: 20 }, 1, 500) else { unreachable!() };
    let at: Vec<f64> = (0..2).map(|j| m.centers[j] * m.scale[j]).collect();
    assert_eq!(rbf_jacobian(&m, &at, &mut jac), Err(RBF_KINK));
}

#[test]
fn benettin_of_maps_fitted_to_henon() {
    // Quadratic polynomial map: an exact fit of Hénon, so Hénon's exponent within the
    // Benettin statistical error (block se ~1e-3 at 1e5 steps): tolerance 0.005.
    let quad = fit_henon(Dynamics::Map, 2, 1000);
    let r = dynamics_lyapunov(&quad, &start(), 10.0, 1000, 100_000).unwrap();
    println!("poly-2 Henon fit: {:.4} +- {:.4}, spectrum {:?}", r.exponent, r.std_error, r.spectrum);
    assert!((r.exponent - HENON_LAMBDA).abs() < 0.005, "{}", r.exponent);
    assert!((r.spectrum[0] + r.spectrum[1] - 0.3f64.ln()).abs() < 1e-6, "{:?}", r.spectrum);

    // Linear-kernel RBF map (200 centres, 4000 training pairs): an approximation, so a
    // looser tolerance of 0.03 on the exponent; the same map by the two-trajectory method
    // (d0 = 1e-8, no Jacobian) must agree with the tangent method within 0.01.
    let rbf = fit_henon(Dynamics::Rbf { centers: 200 }, 1, 4000);
    let r = dynamics_lyapunov(&rbf, &start(), 10.0, 1000, 100_000).unwrap();
    println!("rbf-200 Henon fit: {:.4} +- {:.4}, spectrum {:?}, KY {:?}", r.exponent, r.std_error, r.spectrum, r.kaplan_yorke);
    assert!((r.exponent - HENON_LAMBDA).abs() < 0.03, "{}", r.exponent);
    let mut s = StepScratch::default();
    let two = chaos::benettin_two_trajectory(
        &start(),
        |x| rbf.step(x, 1.0, &mut s),
        1e-8,
        &BenettinParams { transient: 1000, steps: 100_000, bound: 10.0, ..Default::default() },
    )
    .unwrap();
    println!("rbf-200 Henon fit, two-trajectory: {:.4}", two.exponent);
    assert!((two.exponent - r.exponent).abs() < 0.01, "{} vs {}", two.exponent, r.exponent);
}

#[test]
fn rbf_map_million_steps_bounded_and_escape_reported() {
    let rbf = fit_henon(Dynamics::Rbf { centers: 200 }, 1, 4000);
    let o = iterate_dynamics(&rbf, &start(), 1_000_000, 10.0, 10_000).unwrap();
    assert_eq!(o.steps, 1_000_000);
    assert_eq!(o.recorded.as_ref().map(|p| p.len()), Some(101));
    // Stays on (near) Hénon's attractor: |x| < 1.5, |y| < 0.45 (attractor: 1.28, 0.39).
    let f = henon_fixed_point();
    for p in o.recorded.as_ref().unwrap().as_flat().chunks(2) {
        assert!((p[0] + f[0]).abs() < 1.5 && (p[1] + f[1]).abs() < 0.45, "{p:?}");
    }
    // Outside the training region the fitted map escapes like Hénon itself: reported with
    // the step, not as NaN.
    let e = iterate_dynamics(&rbf, &[3.0, 0.0], 1_000_000, 10.0, 0).unwrap_err();
    match e {
        ChaosTableError::Chaos(ChaosError::Escape { step, reason, .. }) => {
            println!("rbf escape from (3, 0) at step {step}: {reason}");
            assert!(step < 100, "{step}");
        }
        other => panic!("expected escape, got {other}"),
    }
    assert!(matches!(iterate_dynamics(&rbf, &[0.1], 10, 10.0, 0), Err(ChaosTableError::Shape { expected: 2, got: 1 })));
}

/// The micro-chaos map x' = a x - b h floor(x / h): inside one quantization cell two states
/// separate by exactly `a` per step, so below `h` the exponent is ln a; far above `h`
/// separations saturate at the attractor size.
fn microchaos(n: usize, a: f64, b: f64, h: f64) -> Vec<f64> {
    let mut x = 0.123_456;
    let mut out = Vec::with_capacity(n);
    for k in 0..n + 1000 {
        x = a * x - b * h * (x / h).floor();
        if k >= 1000 {
            out.push(x);
        }
    }
    out
}

#[test]
fn scale_dependence_of_a_microchaos_map() {
    let (a, b, h) = (2.0, 1.5, 1e-3);
    let x = microchaos(20_000, a, b, h);
    let s = scale_dependence("microchaos", &x, 1.0, 1, "h", h, &[1e-3, 1e-2, 1e-1, 1.0, 10.0]).unwrap();
    let (hd, rows, json) = scale_table(std::slice::from_ref(&s));
    println!("{}", print_table("micro-chaos map", &hd, &rows));
    assert_eq!(rows.len(), 5);
    assert_eq!(json[0]["rows"].as_array().map(|r| r.len()), Some(5));
    let small = s.rows[0].exponent.expect("a fit at eps = 1e-3 h");
    assert!((small - a.ln()).abs() < 0.05, "eps = 1e-3 h: {small} vs ln a = {}", a.ln());
    // Too short for the curve: a clear error naming what is short.
    let e = scale_dependence("short", &x[..40], 1.0, 1, "h", h, &[1.0]).unwrap_err();
    assert!(matches!(e, ChaosError::TooShort { .. }), "{e}");
    println!("40 samples: {e}");
}

fn flag_dir() -> Option<std::path::PathBuf> {
    let d = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/inverted_flag_chaotic");
    if d.join("traj_9.csv").is_file() {
        Some(d)
    } else {
        println!("SKIP: inverted-flag data not found under {} (the shared data folder is absent)", d.display());
        None
    }
}

fn flag(files: &[usize]) -> Option<Vec<TimeSeries>> {
    let d = flag_dir()?;
    Some(files.iter().map(|k| crate::ssm::load_csv(d.join(format!("traj_{k}.csv"))).unwrap()).collect())
}

/// Exploration of model settings on the inverted flag (prints only; run with
/// `--ignored --nocapture`).
#[test]
#[ignore]
fn explore_flag_models() {
    let Some(two) = flag(&[9, 7]) else { return };
    let all = flag(&[9, 7, 3, 8, 0, 6, 4, 5, 2, 1]).unwrap();
    let spec = std::env::var("CHAOS_EXPLORE").unwrap_or_default();
    for cfg in spec.split(';').filter(|s| !s.is_empty()) {
        let mut o = ChaosOptions::default();
        let mut train = &two;
        for kv in cfg.split(',') {
            let (k, v) = kv.split_once('=').unwrap();
            match k {
                "d" => o.ssm_dim = Some(v.parse().unwrap()),
                "c" => o.centers = v.parse().unwrap(),
                "r" => o.ridge = v.parse().unwrap(),
                "s" => o.shift = Some(v.parse().unwrap()),
                "p" => o.embed = Some(v.parse().unwrap()),
                "m" => o.manifold_order = v.parse().unwrap(),
                "k" => o.poly_order = v.parse().unwrap(),
                "all" => train = &all,
                _ => panic!("{k}"),
            }
        }
        let t0 = Instant::now();
        match crate::chaoscmd::analyse(train, &o) {
            Ok(r) => println!(
                "{cfg:<28} d{} data {:.3} | rbf R {} B {} JS {} | poly R {} B {} JS {} | {:.1}s | {}",
                r.ssm_dim,
                r.lle_data,
                fmt_opt(r.lle_model_rbf, 3),
                fmt_opt(r.lle_model_rbf_benettin, 3),
                fmt_opt(r.pdf_divergence_rbf, 3),
                fmt_opt(r.lle_model_poly, 3),
                fmt_opt(r.lle_model_poly_benettin, 3),
                fmt_opt(r.pdf_divergence_poly, 3),
                t0.elapsed().as_secs_f64(),
                r.notes.join("; ").chars().take(300).collect::<String>()
            ),
            Err(e) => println!("{cfg}: {e}"),
        }
    }
}

/// The scale and accuracy-vs-cost tables as a criterion-free bench print (run with
/// `--ignored --nocapture`; timings are printed, never asserted).
#[test]
#[ignore]
fn bench_scale_and_cost_tables() {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    let t0 = Instant::now();
    let studies = scale_studies(&data, 30000).unwrap();
    let (h, rows, _) = scale_table(&studies);
    println!("{}", print_table(&format!("scale dependence ({:.1} s)", t0.elapsed().as_secs_f64()), &h, &rows));
    for s in &studies {
        println!("{}: {} samples, lag {}, Theiler {}, curve {} samples", s.name, s.samples, s.lag, s.theiler, s.max_steps);
    }
    if let Some(st) = flag_cost_study(&data).unwrap() {
        let (h, rows, _) = cost_table(&st);
        println!("{}", print_table(&format!("accuracy vs cost, data LLE {:.3} 1/s", st.lle_data), &h, &rows));
    }
    if let Some(train) = flag(&[9, 7]) {
        let r = crate::chaoscmd::analyse(&train, &ChaosOptions::default()).unwrap();
        println!("{}", serde_json::to_string_pretty(&r).unwrap());
    }
}

/// The default analysis on the simulated quantized loop (prints only; `--ignored`).
#[test]
#[ignore]
fn explore_simulated_quantized() {
    let train: Vec<TimeSeries> = [0.02, 0.035]
        .iter()
        .enumerate()
        .map(|(i, th)| crate::chaoscmd::simulate_quantized(30000, *th, &format!("sim #{i}")).unwrap())
        .collect();
    let mut o = ChaosOptions::default();
    if let Ok(v) = std::env::var("CHAOS_SIM_DIM") {
        o.ssm_dim = Some(v.parse().unwrap());
    }
    if let Ok(v) = std::env::var("CHAOS_SIM_SHIFT") {
        o.shift = Some(v.parse().unwrap());
    }
    let r = crate::chaoscmd::analyse(&train, &o).unwrap();
    println!(
        "sim: D2 {:.2}+-{:.2} d{} shift {} data {:.3} | rbf R {} B {} JS {} | poly R {} B {} JS {} | {:.1}s | {}",
        r.corr_dim,
        r.corr_dim_err,
        r.ssm_dim,
        r.ssm_shift,
        r.lle_data,
        fmt_opt(r.lle_model_rbf, 3),
        fmt_opt(r.lle_model_rbf_benettin, 3),
        fmt_opt(r.pdf_divergence_rbf, 3),
        fmt_opt(r.lle_model_poly, 3),
        fmt_opt(r.lle_model_poly_benettin, 3),
        fmt_opt(r.pdf_divergence_poly, 3),
        r.seconds,
        r.notes.join("; ")
    );
}
