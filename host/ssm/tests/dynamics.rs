//! The tests of `ssm::dynamics`.

use faer::{Mat, MatRef};
use ssm::dynamics::*;
use ssm::error::FitError;
use ssm::internals::design_by_columns;
use ssm::poly::{self, Poly};
use ssm::ridge::{Conditioning, Ridge};

/// The features as computed before the per-dimension loops (kept here): every centre's
/// distance by the slice loop.
fn features_plain(m: &RbfMap, eta: &[f64], out: &mut [f64]) {
    let d = m.dim;
    let k = m.n_centers();
    let z: Vec<f64> = eta.iter().zip(&m.scale).map(|(e, s)| e / s).collect();
    for i in 0..k {
        let c = &m.centers[i * d..(i + 1) * d];
        let r = c.iter().zip(z.iter()).map(|(c, z)| (z - c).powi(2)).sum::<f64>().sqrt();
        out[i] = m.kernel.phi(r);
    }
    for j in 0..d {
        out[k + j] = eta[j] / m.scale[j];
    }
    out[k + d] = 1.0;
}

/// `RbfMap::features` (dimensions 2, 4, 6 by the fixed-length loops, others by the slice
/// loop) equals the plain loop bit for bit, for every kernel, at centres too (r = 0).
#[test]
fn features_match_the_plain_loop() {
    let mut u = 0.3_f64;
    let mut next = move || {
        u = (u * 3.7 + 0.11).fract();
        u - 0.5
    };
    for d in 1..=7 {
        for kernel in [Kernel::Linear, Kernel::Cubic, Kernel::ThinPlate, Kernel::Gaussian { eps: 0.7 }] {
            let k = 37;
            let centers: Vec<f64> = (0..k * d).map(|_| next()).collect();
            let m = RbfMap {
                dim: d,
                kernel,
                dt: 0.1,
                scale: vec![0.8; d],
                coef: vec![0.0; (k + d + 1) * d],
                centers: centers.clone(),
                conditioning: Conditioning::NONE,
            };
            for p in 0..20 {
                // The last point sits on a centre (scaled): r = 0 exactly.
                let eta: Vec<f64> = if p == 19 {
                    centers[..d].iter().map(|c| c * 0.8).collect()
                } else {
                    (0..d).map(|_| next()).collect()
                };
                let (mut got, mut want) = (vec![0.0; k + d + 1], vec![0.0; k + d + 1]);
                m.features(&eta, &mut got);
                features_plain(&m, &eta, &mut want);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&got), bits(&want), "d {d}, {kernel:?}, point {p}");
            }
        }
    }
}

/// Linear oscillator eta' = A eta sampled exactly: flow, map and RBF must all recover
/// the eigenvalues -0.3 +- 2i.
#[test]
fn recovers_linear_eigenvalues() {
    let (sig, om, dt) = (-0.3, 2.0, 0.01);
    let mut trajs = Vec::new();
    for (r0, ph) in [(1.0, 0.0), (0.7, 1.0)] {
        let n = 800;
        trajs.push(Mat::from_fn(n, 2, |i, j| {
            let t = i as f64 * dt;
            let a = r0 * (sig * t).exp();
            if j == 0 { a * (om * t + ph).cos() } else { a * (om * t + ph).sin() }
        }));
    }
    let et: Vec<EtaTrajectory> = trajs.iter().map(|m| EtaTrajectory { eta: m.as_ref(), dt }).collect();
    for (kind, tol) in [(Dynamics::Flow, 1e-6), (Dynamics::Map, 1e-9), (Dynamics::Rbf { centers: 20 }, 2e-2)] {
        let dynm = ReducedDynamics::fit(&et, kind, 3, Ridge::Fixed(0.0)).unwrap();
        let ev = dynm.eigenvalues_ct().unwrap();
        assert!((ev[0].0 - sig).abs() < tol && (ev[0].1 - om).abs() < tol, "{kind:?}: {ev:?}");
        assert!((ev[1].0 - sig).abs() < tol && (ev[1].1 + om).abs() < tol, "{kind:?}: {ev:?}");
    }
}

/// A stable focus with a strong cubic amplitude nonlinearity, `r' = -0.3 r - c r^3`,
/// `phi' = 2`, sampled exactly from r = 1 down to r ~ 1e-4: fitted with too low an order
/// over the whole range, the linear part of the map is biased; anchored on the pairs
/// within 1 % of the largest amplitude it is that of the fixed point.
#[test]
fn anchored_linear_part_recovers_fixed_point_rates() {
    let (sig, om, c, dt) = (-0.3_f64, 2.0, 1.0, 0.01);
    let mut trajs = Vec::new();
    for (r0, ph) in [(1.0_f64, 0.0), (0.8, 1.0)] {
        // u = r^-2 solves u' = -2 sig u + 2 c exactly.
        let (u0, q) = (r0.powi(-2), c / sig);
        trajs.push(Mat::from_fn(3000, 2, |i, j| {
            let t = i as f64 * dt;
            let r = ((u0 - q) * (-2.0 * sig * t).exp() + q).powf(-0.5);
            if j == 0 { r * (om * t + ph).cos() } else { r * (om * t + ph).sin() }
        }));
    }
    let et: Vec<EtaTrajectory> = trajs.iter().map(|m| EtaTrajectory { eta: m.as_ref(), dt }).collect();
    let err = |dynm: &ReducedDynamics| {
        let ev = dynm.eigenvalues_ct().unwrap();
        ((ev[0].0 - sig).abs() / sig.abs()).max((ev[0].1.abs() - om).abs() / om)
    };
    for (kind, order) in [(Dynamics::Map, 1), (Dynamics::Map, 3), (Dynamics::Flow, 3)] {
        let plain = ReducedDynamics::fit(&et, kind, order, Ridge::Fixed(0.0)).unwrap();
        let anchored = ReducedDynamics::fit_anchored(&et, kind, order, Ridge::Fixed(0.0), Some(0.01)).unwrap();
        let (ep, ea) = (err(&plain), err(&anchored));
        println!("{kind:?} order {order}: rate error plain {ep:.2e}, anchored {ea:.2e}");
        // The exact map has all orders, so every plain map fit is biased; the flow field is
        // exactly cubic, so the plain flow fit is exact and the anchor costs the bias of a
        // linear fit within 1 % (c r^2 ~ 1e-4).
        assert!(ea < 2e-4, "{kind:?} {order}: anchored {ea}");
        match (kind, order) {
            (Dynamics::Flow, _) => assert!(ep < 1e-6, "exact cubic field: plain {ep}"),
            (_, 1) => assert!(ep > 0.5, "linear fit over the whole range: plain {ep}"),
            _ => assert!(ep > 5.0 * ea, "{kind:?} {order}: plain {ep} vs anchored {ea}"),
        }
        // The residual is reported against the whole target.
        let rr = anchored.conditioning().rel_residual;
        assert!(rr.is_finite() && rr < 1.0, "{rr}");
    }
    // Bad anchors are errors that say what is wrong.
    for (kind, f, what) in [
        (Dynamics::Map, 0.0, "must be in (0, 1]"),
        (Dynamics::Map, 1.5, "must be in (0, 1]"),
        (Dynamics::Rbf { centers: 10 }, 0.1, "not to RBF"),
        (Dynamics::Map, 1e-9, "training pairs within"),
    ] {
        let e = ReducedDynamics::fit_anchored(&et, kind, 3, Ridge::Fixed(0.0), Some(f)).unwrap_err();
        assert!(
            matches!(e, FitError::BadOption { what: "linear_anchor", .. }) && e.to_string().contains(what),
            "{f}: {e}"
        );
    }
}

/// Row weights: with a steep knee the fitted map does not depend on data far beyond it
/// (docs/decisions/0001: training runs cut at 0.3 instead of 0.2 rad), while the unweighted fit
/// does; exact polynomial data are fitted exactly with or without weights; bad weights
/// and unsupported combinations are errors naming the option.
/// The low-degree first stage ([`LowDegreeStage`]): its degrees are exactly those of a
/// fit weighted at the stage's own knee (bit for bit), the degrees above are refitted (they
/// differ from that fit's), the low degrees differ from the main knee's fit; bad settings
/// are refused. (Its benefit is measured on the Furuta data: `furuta::parametric::MAP_LOW_DEGREE`.)
#[test]
fn low_degree_stage_takes_the_low_degrees_from_the_small_amplitudes() {
    // A damped rotation whose amplitude dependence has a degree-7 term, fitted at order 5
    // (so every fit is biased, and differently by each weight).
    let f = |x: [f64; 2], c7: f64| {
        let r2 = x[0] * x[0] + x[1] * x[1];
        let g = 0.995 - 0.3 * r2 + c7 * r2 * r2 * r2;
        let (c, s) = (0.2f64.cos(), 0.2f64.sin());
        [g * (c * x[0] - s * x[1]), g * (s * x[0] + c * x[1])]
    };
    let runs = |c7: f64| -> Vec<Mat<f64>> {
        [0.02, 0.1, 0.3, 0.5, 0.7]
            .iter()
            .map(|&a: &f64| {
                let mut x = [a, 0.0];
                let mut rows = Vec::new();
                for _ in 0..400 {
                    rows.push(x);
                    x = f(x, c7);
                }
                Mat::from_fn(400, 2, |i, j| rows[i][j])
            })
            .collect()
    };
    let fit = |ms: &[Mat<f64>], order: u32, wt: &RowWeight| {
        let t: Vec<EtaTrajectory> = ms.iter().map(|m| EtaTrajectory { eta: m.as_ref(), dt: 0.01 }).collect();
        ReducedDynamics::fit_weighted(&t, Dynamics::Map, order, Ridge::Fixed(0.0), Some(0.05), false, Some(wt))
    };
    let coef = |d: &ReducedDynamics| match d {
        ReducedDynamics::Map { increment, .. } => increment.coef.clone(),
        _ => unreachable!("map dynamics"),
    };
    let main = RowWeight { knee: 0.6, power: 32.0, low_degrees: None };
    let small = RowWeight { knee: 0.25, power: 32.0, low_degrees: None };
    let staged = RowWeight { low_degrees: Some(LowDegreeStage { max_degree: 3, knee: 0.25, power: 32.0 }), ..main };
    let data = runs(0.5);
    let (a, b, c) = (
        coef(&fit(&data, 5, &staged).unwrap()),
        coef(&fit(&data, 5, &small).unwrap()),
        coef(&fit(&data, 5, &main).unwrap()),
    );
    // Degrees 1..=3 in 2 variables: 2 + 3 + 4 monomials, 2 outputs each.
    let n_low = 2 * 9;
    assert_eq!(a[..n_low], b[..n_low], "low degrees = the small-knee fit's");
    let differs = a[n_low..].iter().zip(&b[n_low..]).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
    let from_main = a[..n_low].iter().zip(&c[..n_low]).map(|(u, v)| (u - v).abs()).fold(0.0, f64::max);
    println!("degrees 4..5 staged vs small-knee fit: {differs:.1e}; degrees 2..3 staged vs main fit: {from_main:.1e}");
    assert!(differs > 1e-6 && from_main > 1e-6, "{differs} {from_main}");
    // Refused: without the plain anchor, max_degree below 2 or not below the order.
    let t: Vec<EtaTrajectory> = data.iter().map(|m| EtaTrajectory { eta: m.as_ref(), dt: 0.01 }).collect();
    let e =
        ReducedDynamics::fit_weighted(&t, Dynamics::Map, 5, Ridge::Fixed(0.0), None, false, Some(&staged)).unwrap_err();
    assert!(matches!(e, FitError::BadOption { what: "row weight low-degree stage", .. }), "{e}");
    for (deg, order) in [(1, 5), (5, 5), (3, 3)] {
        let w = RowWeight { low_degrees: Some(LowDegreeStage { max_degree: deg, knee: 0.25, power: 32.0 }), ..main };
        let e = fit(&data, order, &w).unwrap_err();
        assert!(matches!(e, FitError::BadOption { what: "row weight low-degree stage", .. }), "{deg} {order}: {e}");
    }
    let w = RowWeight { low_degrees: Some(LowDegreeStage { max_degree: 3, knee: -1.0, power: 32.0 }), ..main };
    assert!(matches!(fit(&data, 5, &w).unwrap_err(), FitError::BadOption { what: "row weight low-degree stage", .. }));
}

#[test]
fn row_weights_make_the_fit_independent_of_data_beyond_the_knee() {
    // The twist map scaled by 0.55 (not polynomial): inner runs from r <= 0.5, and an
    // outer run kept for 60 steps from r = 2.5 (r >= 1.85, weight below (0.6 / 1.85)^32
    // = 2e-16).
    let inner: Vec<Mat<f64>> =
        twist_trajectories().into_iter().map(|m| Mat::from_fn(m.nrows(), 2, |i, j| 0.55 * m[(i, j)])).collect();
    let outer = {
        let mut x: [f64; 2] = [2.5 / 0.55, 0.0];
        let mut rows = Vec::new();
        for _ in 0..60 {
            rows.push([0.55 * x[0], 0.55 * x[1]]);
            let r2 = x[0] * x[0] + x[1] * x[1];
            let (c, s) = ((0.3 + 0.5 * r2).cos(), (0.3 + 0.5 * r2).sin());
            x = [0.995 * (c * x[0] - s * x[1]), 0.995 * (s * x[0] + c * x[1])];
        }
        Mat::from_fn(60, 2, |i, j| rows[i][j])
    };
    let with_outer: Vec<Mat<f64>> = inner.iter().cloned().chain(std::iter::once(outer)).collect();
    let fit = |ms: &[Mat<f64>], wt: Option<&RowWeight>| {
        let t: Vec<EtaTrajectory> = ms.iter().map(|m| EtaTrajectory { eta: m.as_ref(), dt: 0.01 }).collect();
        ReducedDynamics::fit_weighted(&t, Dynamics::Map, 5, Ridge::Fixed(0.0), None, false, wt).unwrap()
    };
    let image = |d: &ReducedDynamics, x: [f64; 2]| {
        let mut e = x.to_vec();
        d.step(&mut e, 0.01, &mut StepScratch::default());
        e
    };
    let gap = |a: &ReducedDynamics, b: &ReducedDynamics| {
        [[0.3, 0.0], [0.0, -0.2], [0.15, 0.25], [-0.4, 0.1]]
            .iter()
            .map(|&x| {
                let (u, v) = (image(a, x), image(b, x));
                (u[0] - v[0]).abs().max((u[1] - v[1]).abs())
            })
            .fold(0.0, f64::max)
    };
    let wt = RowWeight { knee: 0.6, power: 32.0, low_degrees: None };
    let (g_w, g_u) =
        (gap(&fit(&inner, Some(&wt)), &fit(&with_outer, Some(&wt))), gap(&fit(&inner, None), &fit(&with_outer, None)));
    println!(
        "one-step images inside r = 0.45, fits with vs without the outer run: weighted {g_w:.1e}, unweighted {g_u:.1e}"
    );
    // Weighted: equal to rounding; unweighted: moved by the outer run.
    assert!(g_w < 1e-10 && g_u > 1e-4, "weighted {g_w}, unweighted {g_u}");
    // Exact data of a cubic map: recovered with and without weights.
    let cubic = |x: [f64; 2]| {
        let r2 = x[0] * x[0] + x[1] * x[1];
        [0.99 * x[0] - 0.1 * x[1] - 0.3 * r2 * x[0], 0.1 * x[0] + 0.99 * x[1] - 0.2 * r2 * x[1]]
    };
    let runs: Vec<Mat<f64>> = [[0.5, 0.0], [0.0, 0.4], [0.3, -0.3]]
        .iter()
        .map(|&s| {
            let mut x = s;
            let mut rows = Vec::new();
            for _ in 0..200 {
                rows.push(x);
                x = cubic(x);
            }
            Mat::from_fn(200, 2, |i, j| rows[i][j])
        })
        .collect();
    for w in [None, Some(&wt), Some(&RowWeight { knee: 0.2, power: 4.0, low_degrees: None })] {
        let d = fit(&runs, w);
        let err = [[0.2, 0.1], [-0.3, 0.2]]
            .iter()
            .map(|&x| {
                let (u, v) = (image(&d, x), cubic(x));
                (u[0] - v[0]).abs().max((u[1] - v[1]).abs())
            })
            .fold(0.0, f64::max);
        assert!(err < 1e-10, "{w:?}: {err}");
    }
    // None is fit_with itself.
    let t: Vec<EtaTrajectory> = inner.iter().map(|m| EtaTrajectory { eta: m.as_ref(), dt: 0.01 }).collect();
    let (a, b) = (
        ReducedDynamics::fit_with(&t, Dynamics::Map, 3, Ridge::Fixed(0.0), Some(0.2), false).unwrap(),
        ReducedDynamics::fit_weighted(&t, Dynamics::Map, 3, Ridge::Fixed(0.0), Some(0.2), false, None).unwrap(),
    );
    assert_eq!(gap(&a, &b), 0.0);
    // The plain anchor with weights: linear part unweighted on the anchor rows.
    let aw =
        ReducedDynamics::fit_weighted(&t, Dynamics::Map, 3, Ridge::Fixed(0.0), Some(0.2), false, Some(&wt)).unwrap();
    assert_eq!(aw.linear_part().unwrap(), a.linear_part().unwrap());
    // Errors.
    for (w, anchor, joint, kind, what) in [
        (RowWeight { knee: 0.0, power: 8.0, low_degrees: None }, None, false, Dynamics::Map, "row weight knee"),
        (RowWeight { knee: f64::NAN, power: 8.0, low_degrees: None }, None, false, Dynamics::Map, "row weight knee"),
        (RowWeight { knee: 0.5, power: 0.5, low_degrees: None }, None, false, Dynamics::Map, "row weight power"),
        (RowWeight { knee: 0.5, power: 100.0, low_degrees: None }, None, false, Dynamics::Map, "row weight power"),
        (wt, Some(0.05), true, Dynamics::Map, "row weights"),
        (wt, None, false, Dynamics::Rbf { centers: 10 }, "row weights"),
    ] {
        let e = ReducedDynamics::fit_weighted(&t, kind, 3, Ridge::Fixed(0.0), anchor, joint, Some(&w)).unwrap_err();
        assert!(matches!(e, FitError::BadOption { what: w2, .. } if w2 == what), "{w:?} {kind:?}: {e}");
    }
}

/// Samples of a nonlinear 2D map (a damped, amplitude-dependent rotation) for the
/// kernel tests.
fn twist_trajectories() -> Vec<Mat<f64>> {
    let mut out = Vec::new();
    for start in [[0.9, 0.0], [0.0, -0.6], [0.4, 0.4]] {
        let mut x: [f64; 2] = start;
        let mut rows = Vec::new();
        for _ in 0..400 {
            rows.push(x);
            let r2 = x[0] * x[0] + x[1] * x[1];
            let (c, s) = ((0.3 + 0.5 * r2).cos(), (0.3 + 0.5 * r2).sin());
            x = [0.995 * (c * x[0] - s * x[1]), 0.995 * (s * x[0] + c * x[1])];
        }
        out.push(Mat::from_fn(400, 2, |i, j| rows[i][j]));
    }
    out
}

/// `RbfWith { kernel: Linear }` is today's `Rbf` bit for bit (coefficients, steps, the
/// saved kernel), and a saved RBF map without the `kernel` field reads as linear.
#[test]
fn linear_kernel_is_the_default_bit_for_bit() {
    let trajs = twist_trajectories();
    let et: Vec<EtaTrajectory> = trajs.iter().map(|m| EtaTrajectory { eta: m.as_ref(), dt: 0.1 }).collect();
    let ReducedDynamics::Rbf(a) =
        ReducedDynamics::fit(&et, Dynamics::Rbf { centers: 30 }, 1, Ridge::Fixed(1e-10)).unwrap()
    else {
        panic!()
    };
    let ReducedDynamics::Rbf(b) =
        ReducedDynamics::fit(&et, Dynamics::RbfWith { centers: 30, kernel: Kernel::Linear }, 1, Ridge::Fixed(1e-10))
            .unwrap()
    else {
        panic!()
    };
    assert_eq!(a.kernel, Kernel::Linear);
    assert!(a.coef.iter().zip(&b.coef).all(|(x, y)| x.to_bits() == y.to_bits()) && a.coef.len() == b.coef.len());
    let mut v = serde_json::to_value(&a).unwrap();
    v.as_object_mut().unwrap().remove("kernel");
    let old: RbfMap = serde_json::from_value(v).unwrap();
    assert_eq!(old.kernel, Kernel::Linear);
    let (mut e1, mut e2, mut f) = (vec![0.3, -0.2], vec![0.3, -0.2], Vec::new());
    for _ in 0..50 {
        a.step(&mut e1, &mut f);
        old.step(&mut e2, &mut f);
    }
    assert_eq!(e1[0].to_bits(), e2[0].to_bits());
    assert_eq!(e1[1].to_bits(), e2[1].to_bits());
}

/// Every kernel fits the twist map; one-step errors on the training pairs are small, the
/// Jacobian at the origin matches central differences of the step, and bad kernels are
/// errors that say what is wrong.
#[test]
fn kernels_fit_and_their_jacobians_match_differences() {
    let trajs = twist_trajectories();
    let et: Vec<EtaTrajectory> = trajs.iter().map(|m| EtaTrajectory { eta: m.as_ref(), dt: 0.1 }).collect();
    for kernel in [Kernel::Linear, Kernel::Cubic, Kernel::ThinPlate, Kernel::Gaussian { eps: 1.5 }] {
        let dynm =
            ReducedDynamics::fit(&et, Dynamics::RbfWith { centers: 40, kernel }, 1, Ridge::Fixed(1e-10)).unwrap();
        let ReducedDynamics::Rbf(m) = &dynm else { panic!() };
        assert_eq!(m.kernel, kernel);
        let rr = dynm.conditioning().rel_residual;
        eprintln!("{kernel:?}: relative residual of the increments {rr:.1e}");
        // A loose bound on the fit's quality; the Jacobian check below is the sharp one.
        assert!(rr < 2e-2, "{kernel:?}: residual {rr}");
        let jac = dynm.linear_part().unwrap();
        let (h, mut f) = (1e-6, Vec::new());
        for j in 0..2 {
            let (mut p, mut q) = (vec![0.0; 2], vec![0.0; 2]);
            p[j] = h;
            q[j] = -h;
            m.step(&mut p, &mut f);
            m.step(&mut q, &mut f);
            for i in 0..2 {
                let fd = (p[i] - q[i]) / (2.0 * h);
                assert!((fd - jac[i * 2 + j]).abs() < 1e-6, "{kernel:?} J[{i}][{j}]: {fd} vs {}", jac[i * 2 + j]);
            }
        }
    }
    for (k, what) in
        [("gaussian:0", "eps must be finite and > 0"), ("gaussian:x", "not a number"), ("quintic", "not one of")]
    {
        let e = Kernel::parse(k).unwrap_err().to_string();
        assert!(e.contains(what) && e.contains("rbf kernel"), "{k}: {e}");
    }
    assert_eq!(Kernel::parse("gaussian:2.5").unwrap(), Kernel::Gaussian { eps: 2.5 });
    for k in [Kernel::Linear, Kernel::Cubic, Kernel::ThinPlate, Kernel::Gaussian { eps: 0.75 }] {
        assert_eq!(Kernel::parse(&k.name()).unwrap(), k);
    }
    let e = ReducedDynamics::fit(
        &et,
        Dynamics::RbfWith { centers: 5, kernel: Kernel::Gaussian { eps: f64::NAN } },
        1,
        Ridge::Fixed(0.0),
    )
    .unwrap_err();
    assert!(e.to_string().contains("Gaussian shape parameter"), "{e}");
}

#[test]
fn central_difference_is_fourth_order() {
    // d/dt sin(t) at step h: error ~ h^4/30 * |f^(5)|.
    let h = 0.05;
    let e = Mat::from_fn(50, 1, |i, _| (i as f64 * h).sin());
    let (p, dv) = central_diff4(e.as_ref(), h);
    for i in 0..p.nrows() {
        let t = (i + 2) as f64 * h;
        assert!((dv[(i, 0)] - t.cos()).abs() < h.powi(4) / 30.0 * 1.01, "i={i}");
    }
}

#[test]
fn farthest_points_spread() {
    let z = Mat::from_fn(5, 1, |i, _| [0.0, 0.1, 0.5, 0.9, -1.0][i]);
    assert_eq!(farthest_points(z.as_ref(), 3), vec![4, 3, 0]);
}

/// Centre choices: `Farthest` is `farthest_points` and the default fit, bit for bit; the
/// seeded subsets are reproducible, distinct training rows, seed-dependent; k-means on two
/// separated symmetric clusters lands on their means; a polynomial kind is refused.
#[test]
fn centre_choices() {
    let et_m = twist_trajectories();
    let et: Vec<_> = et_m.iter().map(|e| EtaTrajectory { eta: e.as_ref(), dt: 0.1 }).collect();
    let ReducedDynamics::Rbf(a) =
        ReducedDynamics::fit(&et, Dynamics::Rbf { centers: 30 }, 1, Ridge::Fixed(1e-10)).unwrap()
    else {
        panic!()
    };
    let ReducedDynamics::Rbf(b) = ReducedDynamics::fit_rbf_centres(
        &et,
        Dynamics::Rbf { centers: 30 },
        Ridge::Fixed(1e-10),
        CentreChoice::Farthest,
    )
    .unwrap() else {
        panic!()
    };
    assert_eq!(a.centers, b.centers);
    assert_eq!(a.coef, b.coef);
    let z = Mat::from_fn(200, 2, |i, j| ((i * 7 + j * 13) % 37) as f64 / 37.0 + 0.01 * i as f64);
    let rows: Vec<Vec<f64>> = (0..200).map(|i| vec![z[(i, 0)], z[(i, 1)]]).collect();
    assert_eq!(
        choose_centres(z.as_ref(), 12, CentreChoice::Farthest),
        farthest_points(z.as_ref(), 12).iter().flat_map(|&i| rows[i].clone()).collect::<Vec<_>>()
    );
    for ch in
        [CentreChoice::FarthestFrom { seed: 3 }, CentreChoice::KMeansPP { seed: 3 }, CentreChoice::Random { seed: 3 }]
    {
        let c = choose_centres(z.as_ref(), 12, ch);
        assert_eq!(c.len(), 24, "{ch:?}");
        assert_eq!(c, choose_centres(z.as_ref(), 12, ch), "{ch:?} reproducible");
        let other = match ch {
            CentreChoice::FarthestFrom { .. } => CentreChoice::FarthestFrom { seed: 4 },
            CentreChoice::KMeansPP { .. } => CentreChoice::KMeansPP { seed: 4 },
            _ => CentreChoice::Random { seed: 4 },
        };
        assert_ne!(c, choose_centres(z.as_ref(), 12, other), "{ch:?} seed-dependent");
        let pts: Vec<&[f64]> = c.chunks(2).collect();
        assert!(pts.iter().all(|p| rows.iter().any(|r| r.as_slice() == *p)), "{ch:?}: centres are training rows");
        assert!((0..12).all(|i| (0..i).all(|j| pts[i] != pts[j])), "{ch:?}: distinct");
    }
    // Two clusters of 4 points each around (0, 0) and (10, 0) (means exactly these).
    let pts = [[0.5, 0.0], [-0.5, 0.0], [0.0, 0.5], [0.0, -0.5], [10.5, 0.0], [9.5, 0.0], [10.0, 0.5], [10.0, -0.5]];
    let z2 = Mat::from_fn(8, 2, |i, j| pts[i][j]);
    for seed in 0..5 {
        let mut c: Vec<Vec<f64>> = choose_centres(z2.as_ref(), 2, CentreChoice::KMeans { seed, iterations: 5 })
            .chunks(2)
            .map(|p| p.to_vec())
            .collect();
        c.sort_by(|a, b| a[0].total_cmp(&b[0]));
        assert_eq!(c, vec![vec![0.0, 0.0], vec![10.0, 0.0]], "seed {seed}");
    }
    let e = ReducedDynamics::fit_rbf_centres(&et, Dynamics::Map, Ridge::Fixed(0.0), CentreChoice::Random { seed: 1 })
        .unwrap_err();
    assert!(matches!(e, FitError::BadOption { what: "dynamics", .. }), "{e}");
    for c in [
        CentreChoice::Farthest,
        CentreChoice::FarthestFrom { seed: 7 },
        CentreChoice::KMeansPP { seed: 0 },
        CentreChoice::Random { seed: 9 },
        CentreChoice::KMeans { seed: 2, iterations: 10 },
    ] {
        assert_eq!(CentreChoice::parse(&c.name()).unwrap(), c);
    }
    assert_eq!(CentreChoice::KMeans { seed: 2, iterations: 10 }.name(), "kmeans10@2");
    for bad in ["far", "random@x", "kmeans@1", "kmeansx@1", "farthest@"] {
        assert!(matches!(CentreChoice::parse(bad), Err(FitError::BadOption { what: "rbf centres", .. })), "{bad}");
    }
}

/// Errors in variables, known answer: pairs `p -> A p` (A = 0.95 x rotation by 0.3, `p`
/// uniform in [-1, 1]^2) observed with white noise of sd 0.3 on both ends. The ordinary
/// fit on noisy inputs shrinks the map (a linear fit by var(p) / (var(p) + sd^2) = 0.787);
/// the pair fit on clean inputs and noisy targets has gain 1 along A. With inputs equal
/// to targets the pair fit is the ordinary fit, bit for bit.
#[test]
fn rbf_pair_fit_removes_errors_in_variables_shrinkage() {
    let mut rng = ssm::testing::XorShift64::new(0x2545_F491_4F6C_DD1D);
    let mut uni = move || rng.open01();
    let gauss = |u: &mut dyn FnMut() -> f64| (-2.0 * u().ln()).sqrt() * (2.0 * std::f64::consts::PI * u()).cos();
    let (c, s) = (0.3f64.cos(), 0.3f64.sin());
    let a = [0.95 * c, -0.95 * s, 0.95 * s, 0.95 * c];
    let n = 4000;
    let (mut clean, mut noisy_in, mut noisy_out) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..n {
        let p = [2.0 * uni() - 1.0, 2.0 * uni() - 1.0];
        let q = [a[0] * p[0] + a[1] * p[1], a[2] * p[0] + a[3] * p[1]];
        let e: Vec<f64> = (0..4).map(|_| 0.3 * gauss(&mut uni)).collect();
        clean.push(Mat::from_fn(2, 2, |i, j| if i == 0 { p[j] } else { q[j] }));
        noisy_in.push(Mat::from_fn(2, 2, |i, j| if i == 0 { p[j] + e[j] } else { q[j] }));
        noisy_out.push(Mat::from_fn(2, 2, |i, j| if i == 0 { p[j] + e[j] } else { q[j] + e[2 + j] }));
    }
    fn tr(m: &[Mat<f64>]) -> Vec<EtaTrajectory<'_>> {
        m.iter().map(|e| EtaTrajectory { eta: e.as_ref(), dt: 1.0 }).collect()
    }
    let kind = Dynamics::Rbf { centers: 4 };
    // The fitted map's gain along A on a grid over the data: sum f(p).Ap / sum |Ap|^2.
    let gain = |d: &ReducedDynamics| {
        let (mut num, mut den) = (0.0, 0.0);
        let mut sc = StepScratch::default();
        for i in 0..21 {
            for j in 0..21 {
                let p = [-0.9 + 0.09 * i as f64, -0.9 + 0.09 * j as f64];
                let q = [a[0] * p[0] + a[1] * p[1], a[2] * p[0] + a[3] * p[1]];
                let mut f = p.to_vec();
                d.step(&mut f, 1.0, &mut sc);
                num += f[0] * q[0] + f[1] * q[1];
                den += q[0] * q[0] + q[1] * q[1];
            }
        }
        num / den
    };
    let ols = ReducedDynamics::fit(&tr(&noisy_out), kind, 1, Ridge::Fixed(1e-10)).unwrap();
    // Clean inputs, targets with noise: the clean input rows of `clean`, the targets of `noisy_out`.
    let pairs = ReducedDynamics::fit_rbf_pairs(&tr(&clean), &tr(&noisy_out), kind, Ridge::Fixed(1e-10)).unwrap();
    let (go, gp) = (gain(&ols), gain(&pairs));
    eprintln!("gain along A: ordinary fit {go:.3}, pair fit {gp:.3}");
    // The ordinary fit shrinks a little less than a linear fit would (0.787): the kernel
    // terms follow the nonlinear conditional mean E[p | noisy p] of a uniform p.
    assert!((gp - 1.0).abs() < 0.02, "pair fit gain {gp}");
    assert!((0.78..=0.88).contains(&go), "ordinary fit gain {go}");
    let same = ReducedDynamics::fit_rbf_pairs(&tr(&noisy_in), &tr(&noisy_in), kind, Ridge::Fixed(1e-10)).unwrap();
    let plain = ReducedDynamics::fit(&tr(&noisy_in), kind, 1, Ridge::Fixed(1e-10)).unwrap();
    let (ReducedDynamics::Rbf(x), ReducedDynamics::Rbf(y)) = (&same, &plain) else { unreachable!() };
    assert_eq!(x.coef, y.coef);
    // Bad input names what is wrong.
    let e = ReducedDynamics::fit_rbf_pairs(&tr(&clean), &tr(&clean[..10]), kind, Ridge::Fixed(1e-10))
        .unwrap_err()
        .to_string();
    assert!(e.contains("pair-fit target trajectories"), "{e}");
    let e = ReducedDynamics::fit_rbf_pairs(&tr(&clean), &tr(&clean), Dynamics::Map, Ridge::Fixed(1e-10))
        .unwrap_err()
        .to_string();
    assert!(e.contains("RBF maps only"), "{e}");
}

/// [`PreparedDynamics::step`] is [`ReducedDynamics::step`] bit for bit along 300 steps of
/// a polynomial map (d = 4, order 7, the Furuta map's shape), a polynomial flow (RK4) and
/// an RBF map (stepped the plain way), with one scratch per path.
#[test]
fn prepared_step_is_the_same_bits() {
    let mut r = ssm::testing::lcg_centered(5);
    let cond = Conditioning::NONE;
    let mut poly = |d: usize, order: u32, gain: f64| {
        let exps = poly::exponents(d, 1, order);
        let coef: Vec<f64> = (0..exps.len() * d).map(|k| if k < d * d { -0.02 * r() } else { gain * r() }).collect();
        Poly { dim_in: d, dim_out: d, scale: (0..d).map(|i| 0.5 + 0.1 * i as f64).collect(), exps, coef }
    };
    let centers = vec![0.1, -0.2, 0.3, 0.05, -0.25, 0.15];
    let cases = [
        (ReducedDynamics::Map { increment: poly(4, 7, 1e-3), dt: 0.03, conditioning: cond }, 0.03),
        (ReducedDynamics::Flow { field: poly(3, 5, 1e-2), conditioning: cond }, 0.01),
        (
            ReducedDynamics::Rbf(RbfMap {
                dim: 2,
                kernel: Kernel::Linear,
                dt: 1.0,
                scale: vec![1.0; 2],
                centers,
                coef: (0..12).map(|k| 0.01 * (k as f64 - 5.0)).collect(),
                conditioning: cond,
            }),
            1.0,
        ),
    ];
    for (dynamics, dt) in &cases {
        let d = match dynamics {
            ReducedDynamics::Map { increment: p, .. } | ReducedDynamics::Flow { field: p, .. } => p.dim_in,
            ReducedDynamics::Rbf(m) => m.dim,
        };
        let prepared = dynamics.prepare();
        assert_eq!(prepared.poly.is_some(), !matches!(dynamics, ReducedDynamics::Rbf(_)));
        let (mut a, mut b): (Vec<f64>, Vec<f64>) =
            ((0..d).map(|i| 0.3 - 0.1 * i as f64).collect(), (0..d).map(|i| 0.3 - 0.1 * i as f64).collect());
        let (mut sa, mut sb) = (StepScratch::default(), StepScratch::default());
        for n in 0..300 {
            dynamics.step(&mut a, *dt, &mut sa);
            prepared.step(&mut b, *dt, &mut sb);
            let (ba, bb): (Vec<u64>, Vec<u64>) =
                (a.iter().map(|v| v.to_bits()).collect(), b.iter().map(|v| v.to_bits()).collect());
            assert_eq!(ba, bb, "step {n}: {a:?} vs {b:?}");
        }
        assert!(a.iter().all(|v| v.is_finite() && *v != 0.0), "{a:?}");
    }
}

/// `RbfMap::step` (dimensions 2..=6 by the one-pass fixed-length loop) equals the step
/// as it was (kept here): the features stored by `features_plain`, then added to the
/// state feature by feature, bit for bit, for every kernel and dimension 1..=8, per-
/// coordinate scales, states at a centre (r = 0) and far out, 40 steps of each orbit.
#[test]
fn fused_rbf_step_equals_features_then_sum() {
    let mut rnd = ssm::testing::XorShift64::new(17);
    let cond = Conditioning::NONE;
    let mut cases = 0;
    for d in 1..=8 {
        for kernel in [Kernel::Linear, Kernel::Cubic, Kernel::ThinPlate, Kernel::Gaussian { eps: 0.7 }] {
            for &k in &[1usize, 7, 500] {
                let scale: Vec<f64> = (0..d).map(|_| 0.3 + rnd.open01()).collect();
                let centers: Vec<f64> = (0..k * d).map(|_| rnd.centered()).collect();
                let coef: Vec<f64> = (0..(k + d + 1) * d)
                    .map(|i| if i < k * d { 1e-3 * rnd.centered() } else { 0.1 * rnd.centered() })
                    .collect();
                let m = RbfMap { dim: d, kernel, dt: 0.1, scale, centers, coef, conditioning: cond };
                for start in 0..4 {
                    let mut eta: Vec<f64> = match start {
                        // exactly at the first centre
                        0 => (0..d).map(|j| m.centers[j] * m.scale[j]).collect(),
                        1 => (0..d).map(|_| 30.0 * rnd.centered()).collect(),
                        _ => (0..d).map(|_| rnd.centered()).collect(),
                    };
                    let mut old = eta.clone();
                    let mut feat = Vec::new();
                    let mut f = vec![0.0; k + d + 1];
                    for n in 0..40 {
                        m.step(&mut eta, &mut feat);
                        features_plain(&m, &old, &mut f);
                        for (r, fr) in f.iter().enumerate() {
                            for j in 0..d {
                                old[j] += m.coef[r * d + j] * fr;
                            }
                        }
                        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                        assert_eq!(bits(&eta), bits(&old), "d {d} {kernel:?} k {k} start {start} step {n}");
                        cases += 1;
                    }
                }
            }
        }
    }
    assert_eq!(cases, 8 * 4 * 3 * 4 * 40);
}

/// `farthest_points` (dimensions 2..=8 by the one-pass update and pick) equals the
/// two-pass loop as it was (kept here) on random rows, rows on a coarse grid (ties of
/// distances, duplicate rows: the early stop) and signed zeros, for k up to past n.
#[test]
fn farthest_points_equal_the_two_pass_loop() {
    fn farthest_plain(z: MatRef<'_, f64>, k: usize) -> Vec<usize> {
        let n = z.nrows();
        let d = z.ncols();
        let rows: Vec<f64> = (0..n).flat_map(|i| (0..d).map(move |j| z[(i, j)])).collect();
        let row = |a: usize| &rows[a * d..(a + 1) * d];
        let dist2 = |a: usize, b: usize| row(a).iter().zip(row(b)).map(|(x, y)| (x - y).powi(2)).sum::<f64>();
        let norm2 = |a: usize| row(a).iter().map(|x| x.powi(2)).sum::<f64>();
        let mut chosen = Vec::with_capacity(k.min(n));
        if n == 0 || k == 0 {
            return chosen;
        }
        let first = (0..n).max_by(|&a, &b| norm2(a).total_cmp(&norm2(b))).unwrap_or(0);
        chosen.push(first);
        let mut mind: Vec<f64> = (0..n).map(|i| dist2(i, first)).collect();
        while chosen.len() < k.min(n) {
            let next = (0..n).max_by(|&a, &b| mind[a].total_cmp(&mind[b])).unwrap_or(0);
            if mind[next] == 0.0 {
                break;
            }
            chosen.push(next);
            let c = row(next);
            for (m, r) in mind.iter_mut().zip(rows.chunks_exact(d.max(1))) {
                *m = m.min(r.iter().zip(c).map(|(x, y)| (x - y).powi(2)).sum::<f64>());
            }
        }
        chosen
    }
    let mut rnd = ssm::testing::XorShift64::new(3);
    let mut cases = 0;
    for d in 1..=9 {
        for kind in 0..3 {
            for &n in &[0usize, 1, 2, 5, 60, 400] {
                let z = Mat::from_fn(n, d, |_, _| match kind {
                    0 => rnd.centered(),
                    1 => (rnd.centered() * 4.0).round() / 4.0,
                    _ => {
                        if rnd.centered() < 0.0 {
                            -0.0
                        } else {
                            0.0
                        }
                    }
                });
                for &k in &[0usize, 1, 3, 50, 500] {
                    assert_eq!(
                        farthest_points(z.as_ref(), k),
                        farthest_plain(z.as_ref(), k),
                        "d {d} kind {kind} n {n} k {k}"
                    );
                    cases += 1;
                }
            }
        }
    }
    assert_eq!(cases, 9 * 3 * 6 * 5);
}

/// The RBF design matrix filled by columns (dimensions 2..=6) equals the row-by-row fill
/// by `RbfMap::features` (the fit's loop, kept here) bit for bit, for every kernel, with
/// rows at centres (r = 0), signed zeros and per-coordinate scales.
#[test]
fn design_by_columns_equals_the_row_features() {
    let mut rnd = ssm::testing::XorShift64::new(29);
    let cond = Conditioning::NONE;
    for d in 1..=7 {
        for kernel in [Kernel::Linear, Kernel::Cubic, Kernel::ThinPlate, Kernel::Gaussian { eps: 0.7 }] {
            let (n, k) = (203, 37);
            let scale: Vec<f64> = (0..d).map(|_| 0.3 + rnd.open01()).collect();
            let x = Mat::from_fn(n, d, |i, _| if i % 17 == 5 { -0.0 } else { rnd.centered() });
            // Centres: scaled rows of x (as the fit picks them), so some distances are 0.
            let centers: Vec<f64> =
                (0..k).flat_map(|c| (0..d).map(move |j| (c * 5, j))).map(|(i, j)| x[(i, j)] / scale[j]).collect();
            let m = RbfMap { dim: d, kernel, dt: 0.1, scale, centers, coef: Vec::new(), conditioning: cond };
            let nf = k + d + 1;
            let mut rows = Mat::<f64>::zeros(n, nf);
            let mut feat = vec![0.0; nf];
            let mut eta = vec![0.0; d];
            for i in 0..n {
                for j in 0..d {
                    eta[j] = x[(i, j)];
                }
                m.features(&eta, &mut feat);
                for (c, f) in feat.iter().enumerate() {
                    rows[(i, c)] = *f;
                }
            }
            match design_by_columns(&m, x.as_ref()) {
                None => assert!(!(2..=6).contains(&d)),
                Some(cols) => {
                    assert!((2..=6).contains(&d));
                    for i in 0..n {
                        for c in 0..nf {
                            assert_eq!(
                                cols[(i, c)].to_bits(),
                                rows[(i, c)].to_bits(),
                                "d {d} {kernel:?} row {i} col {c}"
                            );
                        }
                    }
                }
            }
        }
    }
}
