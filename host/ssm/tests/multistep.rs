//! The tests of `ssm::multistep`.

use faer::Mat;
use ssm::dynamics::{Dynamics, ReducedDynamics};
use ssm::dynamics::{EtaTrajectory, RbfMap};
use ssm::multistep::*;
use ssm::ridge::Ridge;

/// The twist map (a damped rotation whose angle grows with the amplitude).
fn twist(x: [f64; 2]) -> [f64; 2] {
    let r2 = x[0] * x[0] + x[1] * x[1];
    let (c, s) = ((0.3 + 0.5 * r2).cos(), (0.3 + 0.5 * r2).sin());
    [0.995 * (c * x[0] - s * x[1]), 0.995 * (s * x[0] + c * x[1])]
}

/// Orbits of the twist map from `starts`, `n` points each, with white measurement noise
/// of standard deviation `sd` (xorshift + Box-Muller, seeded).
fn orbits(starts: &[[f64; 2]], n: usize, sd: f64, seed: u64) -> (Vec<Mat<f64>>, Vec<Mat<f64>>) {
    let mut rng = ssm::testing::XorShift64::new(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
    let mut gauss = move || rng.gauss();
    let (mut clean, mut noisy) = (Vec::new(), Vec::new());
    for s in starts {
        let mut x = *s;
        let mut rows = Vec::new();
        for _ in 0..n {
            rows.push(x);
            x = twist(x);
        }
        clean.push(Mat::from_fn(n, 2, |i, j| rows[i][j]));
        let nz: Vec<[f64; 2]> = rows.iter().map(|r| [r[0] + sd * gauss(), r[1] + sd * gauss()]).collect();
        noisy.push(Mat::from_fn(n, 2, |i, j| nz[i][j]));
    }
    (clean, noisy)
}

fn rbf_fit(trajs: &[Mat<f64>], centers: usize, alpha: f64) -> RbfMap {
    let et: Vec<EtaTrajectory> = trajs.iter().map(|m| EtaTrajectory { eta: m.as_ref(), dt: 0.1 }).collect();
    let ReducedDynamics::Rbf(m) = ReducedDynamics::fit(&et, Dynamics::Rbf { centers }, 1, Ridge::Fixed(alpha)).unwrap()
    else {
        panic!()
    };
    m
}

/// RMS over the points of `clean` of `|F(x) - twist(x)|` (map recovery) and RMS `k`-step
/// rollout error from every 5th point against the clean orbit.
fn errors(m: &RbfMap, clean: &[Mat<f64>], k: usize) -> (f64, f64) {
    let (mut e1, mut n1, mut ek, mut nk, mut f) = (0.0, 0, 0.0, 0, Vec::new());
    for c in clean {
        for i in 0..c.nrows() {
            let x = [c[(i, 0)], c[(i, 1)]];
            let (mut y, t) = (x.to_vec(), twist(x));
            m.step(&mut y, &mut f);
            e1 += (y[0] - t[0]).powi(2) + (y[1] - t[1]).powi(2);
            n1 += 1;
        }
        for s in (0..c.nrows() - k).step_by(5) {
            let mut y = vec![c[(s, 0)], c[(s, 1)]];
            for j in 1..=k {
                m.step(&mut y, &mut f);
                ek += (y[0] - c[(s + j, 0)]).powi(2) + (y[1] - c[(s + j, 1)]).powi(2);
                nk += 1;
            }
        }
    }
    ((e1 / n1 as f64).sqrt(), (ek / nk as f64).sqrt())
}

/// Known answer: with `h = 1` and `stride = 1` the loss is the one-step ridge objective,
/// whose minimizer the fitted map already is: the refinement moves no coefficient by
/// more than 1e-6 of the largest and does not lower the loss by more than 1e-9.
#[test]
fn one_step_loss_keeps_the_ridge_solution() {
    let (clean, _) = orbits(&[[0.9, 0.0], [0.0, -0.6], [0.4, 0.4]], 400, 0.0, 1);
    for alpha in [1e-10, 1e-6] {
        let m0 = rbf_fit(&clean, 30, alpha);
        let mut m = m0.clone();
        let et: Vec<EtaTrajectory> = clean.iter().map(|c| EtaTrajectory { eta: c.as_ref(), dt: 0.1 }).collect();
        let rep = refine_multistep(&mut m, &et, &MultiStep { horizon: 1, stride: 1, iterations: 5 }).unwrap();
        let big = m0.coef.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let moved = m.coef.iter().zip(&m0.coef).fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
        assert_eq!(rep.len(), 1);
        assert!(moved <= 1e-6 * big, "alpha {alpha}: moved {moved:e} of {big:e}");
        assert!(rep[0].loss_after >= rep[0].loss_before * (1.0 - 1e-9), "{rep:?}");
    }
}

/// Known answer: orbits of the twist map under white measurement noise (sd 0.02 against
/// amplitudes up to 0.9), 40 centres, ridge 1e-6. The one-step ridge fit regresses on
/// noisy points (errors in variables); refined on 16-step rollouts from every point,
/// its held-out 16-step rollouts stay much closer to the clean orbit and the map itself
/// is closer to the true one on held-out clean points. The test prints both errors before
/// and after, and pins the one-step fit's errors against regressions.
#[test]
fn multistep_recovers_a_noisy_map_better_than_one_step_ridge() {
    let (_, noisy) = orbits(&[[0.9, 0.0], [0.0, -0.7], [0.5, 0.5], [-0.8, 0.2]], 500, 0.02, 7);
    let (held, _) = orbits(&[[0.1, 0.85], [-0.6, -0.3]], 400, 0.0, 9);
    let m0 = rbf_fit(&noisy, 40, 1e-6);
    let mut m = m0.clone();
    let et: Vec<EtaTrajectory> = noisy.iter().map(|c| EtaTrajectory { eta: c.as_ref(), dt: 0.1 }).collect();
    let rep = refine_multistep(&mut m, &et, &MultiStep { horizon: 16, stride: 1, iterations: 8 }).unwrap();
    let (f0, r0) = errors(&m0, &held, 16);
    let (f1, r1) = errors(&m, &held, 16);
    println!("ridge: map {f0:.5}, 16-step {r0:.5}; multistep: map {f1:.5}, 16-step {r1:.5}; {rep:?}");
    assert_eq!(rep.iter().map(|r| r.horizon).collect::<Vec<_>>(), vec![2, 4, 8, 16]);
    assert!(rep.iter().all(|r| r.loss_after <= r.loss_before && r.accepted >= 1), "{rep:?}");
    assert!((r0 - 0.0531).abs() < 0.002 && (f0 - 0.00668).abs() < 3e-4, "ridge {r0} {f0}");
    assert!(r1 < 0.4 * r0, "16-step error {r1} vs ridge {r0}");
    assert!(f1 < 0.93 * f0, "map error {f1} vs ridge {f0}");
}

/// Bad options and inputs are errors naming what is wrong.
#[test]
fn bad_options_and_inputs_say_what_is_wrong() {
    let (clean, _) = orbits(&[[0.9, 0.0], [0.4, 0.4]], 200, 0.0, 1);
    let m0 = rbf_fit(&clean, 10, 1e-10);
    let et: Vec<EtaTrajectory> = clean.iter().map(|c| EtaTrajectory { eta: c.as_ref(), dt: 0.1 }).collect();
    for (o, what) in [
        (MultiStep { horizon: 0, stride: 1, iterations: 3 }, "horizon must be >= 1"),
        (MultiStep { horizon: 4, stride: 0, iterations: 3 }, "stride must be >= 1"),
        (MultiStep { horizon: 4, stride: 1, iterations: 0 }, "iterations per stage"),
        (MultiStep { horizon: 300, stride: 1, iterations: 2 }, "underdetermined"),
    ] {
        let e = refine_multistep(&mut m0.clone(), &et, &o).unwrap_err().to_string();
        assert!(e.contains(what), "{o:?}: {e}");
    }
    let wide = Mat::<f64>::zeros(50, 3);
    let e = refine_multistep(
        &mut m0.clone(),
        &[EtaTrajectory { eta: wide.as_ref(), dt: 0.1 }],
        &MultiStep { horizon: 2, stride: 1, iterations: 1 },
    )
    .unwrap_err();
    assert!(e.to_string().contains("embedded dimension 3 does not match the model's 2"), "{e}");
    assert_eq!(MultiStep { horizon: 23, stride: 1, iterations: 1 }.stages(), vec![2, 4, 8, 16, 23]);
    assert_eq!(MultiStep { horizon: 1, stride: 1, iterations: 1 }.stages(), vec![1]);
}
