//! The tests of `ssm`.
//!
//! End-to-end tests of the fitting pipeline: real sloshing data (skipped with a message
//! when `../shared/data` is absent) and synthetic data with a known answer.

use std::path::PathBuf;
use std::time::Instant;

use ssm::*;

fn sloshing_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/sloshing");
    if dir.join("decay_0.csv").exists() {
        Some(dir)
    } else {
        eprintln!("SKIPPED: sloshing data not found at {} (needs ../shared/data next to the workspace)", dir.display());
        None
    }
}

fn load_sloshing(dir: &std::path::Path) -> Vec<TimeSeries> {
    (0..3).map(|i| load_csv(dir.join(format!("decay_{i}.csv"))).unwrap()).collect()
}

/// Fits on decay_0, decay_1, returns (fit ms (best of `reps`, the machine is shared), train
/// NMTE (mean of the two), test NMTE on decay_2).
fn run(data: &[TimeSeries], opts: &FitOptions, reps: usize) -> (f64, f64, f64, SsmModel) {
    let train = &data[..2];
    let mut best = f64::INFINITY;
    let mut model = None;
    for _ in 0..reps {
        let t0 = Instant::now();
        let m = fit(train, opts).unwrap();
        best = best.min(t0.elapsed().as_secs_f64() * 1e3);
        model = Some(m);
    }
    let model = model.unwrap();
    let train_nmte = train.iter().map(|ts| model.predict(ts).unwrap().nmte(ts)).sum::<f64>() / 2.0;
    let test_nmte = model.predict(&data[2]).unwrap().nmte(&data[2]);
    (best, train_nmte, test_nmte, model)
}

/// The recommended sloshing settings (see the module report table).
pub fn sloshing_options() -> FitOptions {
    FitOptions {
        dim: 2,
        embed: 5,
        shift: 1,
        manifold_order: 3,
        dyn_order: 5,
        dynamics: Dynamics::Map,
        ridge: Ridge::Fixed(0.0),
        linear_anchor: None,
        anchor_joint: false,
    }
}

#[test]
fn sloshing_sweep_table() {
    let Some(dir) = sloshing_dir() else { return };
    let data = load_sloshing(&dir);
    let mut rows = Vec::new();
    for (p, shift) in [(5, 1), (7, 1), (5, 3), (9, 2)] {
        for (km, kd) in [(1, 3), (1, 5), (3, 3), (3, 5), (5, 5), (3, 7), (7, 7)] {
            for dynm in [Dynamics::Flow, Dynamics::Map] {
                let opts = FitOptions {
                    embed: p,
                    shift,
                    manifold_order: km,
                    dyn_order: kd,
                    dynamics: dynm,
                    ..sloshing_options()
                };
                let (ms, tr, te, _) = run(&data, &opts, 3);
                rows.push(format!(
                    "p={p} s={shift} K={km} R={kd} {dynm:?}: fit {ms:.2} ms, train NMTE {tr:.4}, test NMTE {te:.4}"
                ));
            }
        }
    }
    for dynm in [Dynamics::Flow, Dynamics::Map] {
        let opts = FitOptions { dynamics: dynm, ridge: Ridge::CrossValidated, ..sloshing_options() };
        let (ms, tr, te, m) = run(&data, &opts, 3);
        let a = m.dynamics.conditioning().alpha;
        rows.push(format!(
            "p=5 s=1 K=3 R=5 {dynm:?} ridge CV (alpha {a:e}): fit {ms:.2} ms, train NMTE {tr:.4}, test NMTE {te:.4}"
        ));
    }
    for c in [50, 150] {
        let opts = FitOptions { dynamics: Dynamics::Rbf { centers: c }, ..sloshing_options() };
        let (ms, tr, te, _) = run(&data, &opts, 3);
        rows.push(format!("p=5 s=1 K=3 RBF({c}): fit {ms:.2} ms, train NMTE {tr:.4}, test NMTE {te:.4}"));
    }
    for r in &rows {
        println!("{r}");
    }
}

#[test]
fn sloshing_meets_reference_nmte() {
    let Some(dir) = sloshing_dir() else { return };
    let data = load_sloshing(&dir);
    let (ms, tr, te, model) = run(&data, &sloshing_options(), 20);
    println!("sloshing {:?}: fit {ms:.2} ms, train NMTE {tr:.4}, test NMTE {te:.4}", sloshing_options());
    println!("eigenvalues (ct): {:?}", model.eigenvalues_ct());
    assert!(te <= 0.012, "test NMTE {te} above the reference 0.012");
    // Slow mode of the tank: about 7.8 rad/s (SSMLearn's sloshing example), lightly damped.
    let (re, im) = model.eigenvalues_ct()[0];
    assert!(re < 0.0 && (im.abs() - 7.8).abs() < 0.3, "eigenvalue {re} + {im}i");
    let json = model.to_json().unwrap();
    let back = SsmModel::from_json(&json).unwrap();
    // Other formats and versions are refused, naming what was found.
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    assert_eq!((v["format"].as_str(), v["version"].as_u64()), (Some("ssm-model"), Some(1)));
    let e = SsmModel::from_json(&json.replacen("\"version\": 1", "\"version\": 2", 1)).unwrap_err().to_string();
    assert!(e.contains("version 2") && e.contains("reads version 1"), "{e}");
    let e = SsmModel::from_json(&serde_json::to_string(&v["model"]).unwrap()).unwrap_err().to_string();
    assert!(e.contains("no \"format\" key"), "{e}");
    // serde_json's default float parsing may differ in the last bit: compare with a tolerance.
    let p2 = back.predict(&data[2]).unwrap();
    let p1 = model.predict(&data[2]).unwrap();
    assert_eq!(p1.x.len(), p2.x.len());
    for (a, b) in p1.x.iter().zip(&p2.x) {
        assert!((a - b).abs() <= 1e-9 * (1.0 + a.abs()), "{a} vs {b}");
    }
}

/// Exact solution of the planar system (polar form)
/// `rho' = -s rho - b rho^3`, `theta' = w + g rho^2`, whose linear part at the origin has
/// eigenvalues `-s +- i w`. Returns (eta1, eta2) at time t.
fn known_ssm_state(s: f64, w: f64, b: f64, g: f64, rho0: f64, th0: f64, t: f64) -> (f64, f64) {
    let u = (-2.0 * s * t).exp();
    let denom = s + b * rho0 * rho0 * (1.0 - u);
    let rho = (s * rho0 * rho0 * u / denom).sqrt();
    let theta = th0 + w * t + g / (2.0 * b) * (denom / s).ln();
    (rho * theta.cos(), rho * theta.sin())
}

/// A generic nonlinear scalar observable of the reduced state.
fn observable(e1: f64, e2: f64) -> f64 {
    e1 + 0.2 * e1 * e1 - 0.1 * e1 * e2 + 0.05 * e2 * e2 * e2
}

const S: f64 = 0.15;
const W: f64 = 2.0;
const B: f64 = 0.4;
const G: f64 = 0.6;

fn synthetic(name: &str, rho0: f64, th0: f64, dt: f64, n: usize) -> TimeSeries {
    let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
    let x = t.iter().map(|&ti| {
        let (a, b) = known_ssm_state(S, W, B, G, rho0, th0, ti);
        observable(a, b)
    });
    TimeSeries::new(name, t.clone(), x.collect()).unwrap()
}

#[test]
fn exact_solution_satisfies_ode() {
    // Independent check of the closed form: finite-difference rho' and theta'.
    let (h, t) = (1e-5, 1.3);
    let polar = |t: f64| {
        let (a, b) = known_ssm_state(S, W, B, G, 0.8, 0.3, t);
        (a.hypot(b), b.atan2(a))
    };
    let (r0, _) = polar(t);
    let (rp, thp) = polar(t + h);
    let (rm, thm) = polar(t - h);
    assert!(((rp - rm) / (2.0 * h) - (-S * r0 - B * r0.powi(3))).abs() < 1e-8);
    assert!(((thp - thm) / (2.0 * h) - (W + G * r0 * r0)).abs() < 1e-8);
}

/// Data on a known 2D SSM observed through a nonlinear scalar observable: the fitted
/// continuous-time eigenvalues must match -0.15 +- 2i (invariant under the unknown smooth
/// conjugacy between the fitted and true reduced coordinates).
#[test]
fn synthetic_known_eigenvalues() {
    let dt = 0.05;
    let train: Vec<TimeSeries> = [(0.6, 0.0), (0.5, 2.0), (0.55, 4.0)]
        .iter()
        .enumerate()
        .map(|(i, &(r, th))| synthetic(&format!("train{i}"), r, th, dt, 800))
        .collect();
    let test = synthetic("test", 0.45, 1.0, dt, 800);
    for (dynm, kd, tol) in [(Dynamics::Flow, 5, 5e-4), (Dynamics::Map, 5, 5e-4)] {
        let opts = FitOptions {
            dim: 2,
            embed: 5,
            shift: 2,
            manifold_order: 5,
            dyn_order: kd,
            dynamics: dynm,
            ridge: Ridge::Fixed(0.0),
            linear_anchor: None,
            anchor_joint: false,
        };
        let model = fit(&train, &opts).unwrap();
        let ev = model.eigenvalues_ct();
        println!("{dynm:?}: eigenvalues {ev:?}");
        assert!((ev[0].0 + S).abs() < tol && (ev[0].1 - W).abs() < tol, "{dynm:?}: {ev:?}");
        assert!((ev[1].0 + S).abs() < tol && (ev[1].1 + W).abs() < tol, "{dynm:?}: {ev:?}");
        let pred = model.predict(&test).unwrap();
        let e = pred.nmte(&test);
        println!("{dynm:?}: test NMTE {e}");
        assert!(pred.stop.is_none() && e < 5e-3, "{dynm:?}: NMTE {e}");
        assert!(model.manifold.constraint_defect() < 1e-10);
    }
}

/// A high manifold and dynamics order (K = 9) is ill-conditioned: cross-validation must
/// pick a ridge that brings the regularized condition number down, the conditioning must
/// be reported, and the prediction must be finite (or stopped with a reason).
#[test]
fn high_order_engages_ridge_and_reports_conditioning() {
    let dt = 0.05;
    let train: Vec<TimeSeries> = [(0.6, 0.0), (0.5, 2.0)]
        .iter()
        .enumerate()
        .map(|(i, &(r, th))| synthetic(&format!("train{i}"), r, th, dt, 600))
        .collect();
    let test = synthetic("test", 0.45, 1.0, dt, 600);
    let opts = FitOptions {
        dim: 2,
        embed: 5,
        shift: 2,
        manifold_order: 9,
        dyn_order: 9,
        dynamics: Dynamics::Flow,
        ridge: Ridge::CrossValidated,
        linear_anchor: None,
        anchor_joint: false,
    };
    let model = fit(&train, &opts).unwrap();
    let pred = model.predict(&test).unwrap();
    let mc = pred.manifold_conditioning.unwrap();
    let dc = pred.dynamics_conditioning;
    println!("K=9 manifold {mc:?}\nK=9 dynamics {dc:?}\nstop {:?}, NMTE {}", pred.stop, pred.nmte(&test));
    for c in [mc, dc] {
        assert!(c.cond > 1e3 && c.cond_regularized <= c.cond, "{c:?}");
        if c.alpha > 0.0 {
            assert!(c.cond_regularized < c.cond, "{c:?}");
        }
    }
    assert!(pred.x.iter().all(|v| v.is_finite()));
    match &pred.stop {
        None => assert!(pred.nmte(&test) < 2e-2, "NMTE {}", pred.nmte(&test)),
        Some(s) => assert!(s.index < test.len()),
    }
    let ev = model.eigenvalues_ct();
    assert!((ev[0].0 + S).abs() < 1e-2 && (ev[0].1 - W).abs() < 1e-2, "{ev:?}");
}

/// A model of a growing oscillation predicted far beyond its training range must stop with
/// `LeftRange`, never emit non-finite values.
#[test]
fn blow_up_is_detected_and_truncated() {
    let dt = 0.05;
    let grow = |name: &str, r0: f64, n: usize| {
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let x = t.iter().map(|&ti| r0 * (0.2 * ti).exp() * (W * ti).cos()).collect();
        TimeSeries::new(name, t, x).unwrap()
    };
    let train = [grow("a", 0.1, 200), grow("b", 0.15, 200)];
    let opts = FitOptions {
        dim: 2,
        embed: 5,
        shift: 1,
        manifold_order: 1,
        dyn_order: 1,
        dynamics: Dynamics::Map,
        ridge: Ridge::Fixed(0.0),
        linear_anchor: None,
        anchor_joint: false,
    };
    let model = fit(&train, &opts).unwrap();
    assert!(model.eigenvalues_ct()[0].0 > 0.19 && model.eigenvalues_ct()[0].0 < 0.21, "{:?}", model.eigenvalues_ct());
    let test = grow("long", 0.1, 1000);
    let pred = model.predict(&test).unwrap();
    let stop = pred.stop.clone().expect("must stop");
    assert!(matches!(stop.reason, StopReason::LeftRange { .. }), "{stop:?}");
    // Shown to users in words (the CLI printed the Debug text `LeftRange { coord: 0, ... }`).
    let words = stop.reason.to_string();
    assert!(words.starts_with("reduced coordinate ") && words.contains(" reached ") && !words.contains('{'), "{words}");
    // Training amplitude reaches ~0.15 e^2 ~ 1.1; x10 = 11 is reached from 0.1 at t = ln(110) / 0.2 ~ 23.5 s.
    assert!(stop.t > 18.0 && stop.t < 28.0, "{stop:?}");
    assert_eq!(pred.x.len(), stop.index);
    assert!(pred.x.iter().all(|v| v.is_finite()));
    assert_eq!(pred.nmte(&test), f64::INFINITY);
}

#[test]
fn bad_options_and_inputs_are_reported() {
    let dt = 0.05;
    let train = [synthetic("a", 0.5, 0.0, dt, 300)];
    let base = FitOptions {
        dim: 2,
        embed: 5,
        shift: 1,
        manifold_order: 2,
        dyn_order: 3,
        dynamics: Dynamics::Map,
        ridge: Ridge::Fixed(0.0),
        linear_anchor: None,
        anchor_joint: false,
    };
    let e = fit(&train, &FitOptions { embed: 4, ..base }).unwrap_err();
    assert!(matches!(e, FitError::BadOption { what: "embed", .. }), "{e}");
    let e = fit(&train, &FitOptions { shift: 0, ..base }).unwrap_err();
    assert!(matches!(e, FitError::BadOption { what: "shift", .. }), "{e}");
    let e = fit(&train, &FitOptions { ridge: Ridge::Fixed(-1.0), ..base }).unwrap_err();
    assert!(matches!(e, FitError::BadOption { what: "ridge alpha", .. }), "{e}");
    let e = fit(&[], &base).unwrap_err();
    assert!(matches!(e, FitError::NoTrainingData), "{e}");
    let e = fit(&[synthetic("short", 0.5, 0.0, dt, 10)], &base).unwrap_err();
    assert!(matches!(e, FitError::Data(DataError::TooShort { have: 10, need: 12, .. })), "{e}");
    // A discrete-time model refuses a test series sampled at another step.
    let model = fit(&train, &base).unwrap();
    let e = model.predict(&synthetic("other step", 0.5, 0.0, 0.06, 300)).unwrap_err();
    assert!(matches!(e, FitError::StepMismatch { .. }), "{e}");
    // A test series shorter than one embedded point.
    let e = model.predict(&synthetic("tiny", 0.5, 0.0, dt, 4)).unwrap_err();
    assert!(matches!(e, FitError::Data(DataError::TooShort { .. })), "{e}");
}

// ------------------------------------------------------------------ known normal form, end to end

/// Two coupled oscillators given directly in polar normal form (cubic truncation):
/// `rho_i' = rho_i (A_i + B_i1 rho_1^2 + B_i2 rho_2^2)`,
/// `phi_i' = W_i + G_i1 rho_1^2 + G_i2 rho_2^2`, observed through
/// `x = rho_1 cos phi_1 + rho_2 cos phi_2` plus quadratic and cubic terms. The
/// observable's linear part makes `rho_i` the mode amplitude in `x`. Cubic normal-form
/// coefficients change under a near-identity coordinate change `w = z + c z|z|^2` by
/// `2 Re(lambda) c` (they are invariant only at `Re lambda = 0`), and the nonlinear observable
/// and the delay embedding are such changes: the linear rates are therefore kept small
/// (-0.02, -0.03 1/s; with rates several times larger the recovered cubic coefficients are far
/// off), while the cubic terms make the data span amplitudes 0.42 .. 0.05. The fitted
/// normal form must then return `A`, `W` and the cubic `B`, `G` (the worst relative error is
/// printed).
const NF_A: [f64; 2] = [-0.02, -0.03];
const NF_W: [f64; 2] = [2.0, 5.3];
const NF_B: [[f64; 2]; 2] = [[-0.4, 0.3], [-0.5, -0.2]];
const NF_G: [[f64; 2]; 2] = [[0.6, -0.3], [0.2, 0.4]];

fn nf_field(s: [f64; 4]) -> [f64; 4] {
    let (p1, p2) = (s[0] * s[0], s[1] * s[1]);
    [
        s[0] * (NF_A[0] + NF_B[0][0] * p1 + NF_B[0][1] * p2),
        s[1] * (NF_A[1] + NF_B[1][0] * p1 + NF_B[1][1] * p2),
        NF_W[0] + NF_G[0][0] * p1 + NF_G[0][1] * p2,
        NF_W[1] + NF_G[1][0] * p1 + NF_G[1][1] * p2,
    ]
}

/// Samples every `dt` of the polar system integrated by RK4 with 100 substeps per sample
/// (local error ~ (dt/100)^5 ~ 3e-16 per step: exact at the test's tolerances).
fn nf_series(name: &str, s0: [f64; 4], dt: f64, n: usize) -> TimeSeries {
    let h = dt / 100.0;
    let mut s = s0;
    let mut t = Vec::with_capacity(n);
    let mut x = Vec::with_capacity(n);
    for i in 0..n {
        let (u, v) = (s[0] * s[2].cos(), s[1] * s[3].cos());
        let w = s[1] * s[3].sin();
        t.push(i as f64 * dt);
        x.push(u + v + 0.2 * u * u - 0.1 * u * w + 0.05 * v * v * v);
        for _ in 0..100 {
            let add =
                |a: [f64; 4], k: [f64; 4], c: f64| [a[0] + c * k[0], a[1] + c * k[1], a[2] + c * k[2], a[3] + c * k[3]];
            let k1 = nf_field(s);
            let k2 = nf_field(add(s, k1, h / 2.0));
            let k3 = nf_field(add(s, k2, h / 2.0));
            let k4 = nf_field(add(s, k3, h));
            for j in 0..4 {
                s[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
            }
        }
    }
    TimeSeries::new(name, t, x).unwrap()
}

#[test]
fn synthetic_known_normal_form_is_recovered() {
    use ssm::normal_form::{NormalFormOptions, model_normal_form};
    let dt = 0.05;
    let starts = [
        [0.6, 0.1, 0.0, 1.0],
        [0.1, 0.6, 2.0, 0.5],
        [0.45, 0.45, 4.0, 3.0],
        [0.55, 0.3, 1.0, 5.0],
        [0.25, 0.55, 3.0, 2.0],
        [0.4, 0.2, 5.5, 0.2],
    ];
    // Amplitudes up to 0.42, 1000 samples (50 s) each.
    let train: Vec<TimeSeries> = starts
        .iter()
        .enumerate()
        .map(|(i, s)| nf_series(&format!("nf{i}"), [0.7 * s[0], 0.7 * s[1], s[2], s[3]], dt, 1000))
        .collect();
    let opts = FitOptions {
        dim: 4,
        embed: 11,
        shift: 1,
        manifold_order: 3,
        dyn_order: 5,
        dynamics: Dynamics::Map,
        ridge: Ridge::Fixed(0.0),
        linear_anchor: None,
        anchor_joint: false,
    };
    let model = fit(&train, &opts).unwrap();
    let nf = model_normal_form(&model, &NormalFormOptions::default()).unwrap();
    let t = nf.table();
    println!("{}", t.to_text());
    println!("phase {:?}", nf.phase);
    // Linear part: rates and frequencies.
    for i in 0..2 {
        assert!((nf.amp[i][0] - NF_A[i]).abs() < 2e-3, "rate {i}: {} vs {}", nf.amp[i][0], NF_A[i]);
        assert!((nf.phase[i][0] - NF_W[i]).abs() < 2e-3, "freq {i}: {} vs {}", nf.phase[i][0], NF_W[i]);
    }
    // Cubic amplitude coefficients (table) and frequency coefficients (pexps [1,0], [0,1]).
    let cubic = [
        (1, "rho_1^3", NF_B[0][0]),
        (1, "rho_1 rho_2^2", NF_B[0][1]),
        (2, "rho_1^2 rho_2", NF_B[1][0]),
        (2, "rho_2^3", NF_B[1][1]),
    ];
    let mut worst: f64 = 0.0;
    for (mode, mono, want) in cubic {
        let got = t.get(mode, mono).unwrap();
        worst = worst.max((got - want).abs() / want.abs());
        assert!((got - want).abs() < 0.05 * want.abs(), "rho_{mode}' {mono}: {got} vs {want}");
    }
    let k1 = nf.pexps.iter().position(|e| e == &[1, 0]).unwrap();
    let k2 = nf.pexps.iter().position(|e| e == &[0, 1]).unwrap();
    for i in 0..2 {
        for (k, j) in [(k1, 0), (k2, 1)] {
            let (got, want) = (nf.phase[i][k], NF_G[i][j]);
            worst = worst.max((got - want).abs() / want.abs());
            assert!((got - want).abs() < 0.08 * want.abs(), "phi_{}' P_{}: {got} vs {want}", i + 1, j + 1);
        }
    }
    println!("worst relative coefficient error {worst:.2e}");
}

// ------------------------------------------------------------------ docs/decisions/0004: limits and saved models

/// Sizes implied by the options are checked against `limits` before anything of that size
/// is allocated (docs/decisions/0004: `fit --dim 100 --embed 201` allocated gigabytes before failing);
/// the error names the option and the limit.
#[test]
fn option_sizes_are_checked_against_the_stated_limits() {
    use ssm::limits::{MAX_CENTERS, MAX_DIM, MAX_EMBED, MAX_ORDER, MAX_TERMS};
    let dt = 0.05;
    let train = [synthetic("a", 0.5, 0.0, dt, 300)];
    let base = FitOptions {
        dim: 2,
        embed: 5,
        shift: 1,
        manifold_order: 2,
        dyn_order: 3,
        dynamics: Dynamics::Map,
        ridge: Ridge::Fixed(0.0),
        linear_anchor: None,
        anchor_joint: false,
    };
    let cases: Vec<(FitOptions, &str, String)> = vec![
        (FitOptions { dim: 100, embed: 201, ..base }, "dim: 100", MAX_DIM.to_string()),
        (FitOptions { embed: 5000, ..base }, "embed: 5000", MAX_EMBED.to_string()),
        (FitOptions { manifold_order: 1000, ..base }, "manifold_order: 1000", MAX_ORDER.to_string()),
        (FitOptions { dyn_order: u32::MAX, ..base }, "dyn_order", MAX_ORDER.to_string()),
        (FitOptions { dim: 20, embed: 41, manifold_order: 6, ..base }, "manifold monomials", MAX_TERMS.to_string()),
        (
            FitOptions { dim: 12, embed: 25, manifold_order: 1, dyn_order: 9, ..base },
            "dynamics monomials",
            MAX_TERMS.to_string(),
        ),
        (
            FitOptions { dynamics: Dynamics::Rbf { centers: usize::MAX }, ..base },
            "rbf centers",
            MAX_CENTERS.to_string(),
        ),
    ];
    for (o, what, limit) in cases {
        let t0 = std::time::Instant::now();
        let e = fit(&train, &o).unwrap_err();
        assert!(matches!(e, FitError::TooLarge { .. }), "{o:?}: {e}");
        let m = e.to_string();
        assert!(m.contains(what) && m.contains(&format!("limit of {limit}")), "{m}");
        assert!(t0.elapsed().as_secs_f64() < 1.0, "{m}: took {:?}", t0.elapsed());
    }
    let e = fit(&train, &FitOptions { dynamics: Dynamics::Rbf { centers: 0 }, ..base }).unwrap_err();
    assert!(matches!(e, FitError::BadOption { what: "rbf centers", .. }), "{e}");
    // Data-dependent sizes: more unknowns than rows is refused before the design matrix exists.
    let e = fit(&train, &FitOptions { dim: 4, embed: 9, manifold_order: 12, ..base }).unwrap_err();
    assert!(matches!(e, FitError::Underdetermined { what: "manifold regression", cols: 1815, .. }), "{e}");
    let e = fit(&train, &FitOptions { dynamics: Dynamics::Rbf { centers: 5000 }, ..base }).unwrap_err();
    assert!(matches!(e, FitError::Underdetermined { what: "rbf regression", cols: 5003, .. }), "{e}");
}

/// A fitted RBF model saved as JSON, as a `serde_json::Value` to corrupt.
fn saved_rbf_model() -> serde_json::Value {
    let dt = 0.05;
    let train = [synthetic("a", 0.5, 0.0, dt, 300), synthetic("b", 0.4, 1.0, dt, 300)];
    let o = FitOptions {
        dim: 2,
        embed: 5,
        shift: 1,
        manifold_order: 3,
        dyn_order: 3,
        dynamics: Dynamics::Rbf { centers: 10 },
        ridge: Ridge::Fixed(1e-8),
        linear_anchor: None,
        anchor_joint: false,
    };
    serde_json::from_str(&fit(&train, &o).unwrap().to_json().unwrap()).unwrap()
}

/// Regression: a saved model with inconsistent shapes indexed out of bounds, divided by a zero
/// dimension, exported an empty scale vector or allocated gigabytes for a huge exponent.
/// Every such model is refused on load with the field named.
#[test]
fn saved_model_shapes_are_validated_on_load() {
    let good = saved_rbf_model();
    assert!(SsmModel::from_json(&good.to_string()).is_ok());
    type Edit = fn(&mut serde_json::Value);
    let cases: [(Edit, &str, &str); 14] = [
        (|m| m["manifold"]["v1"].as_array_mut().unwrap().truncate(3), "`manifold.v1`", "length 3, expected 10"),
        (
            |m| {
                m["options"]["dim"] = 0.into();
                m["manifold"]["dim"] = 0.into();
                m["dynamics"]["Rbf"]["dim"] = 0.into();
            },
            "`options`",
            "dim",
        ),
        (|m| m["manifold"]["dim"] = 3.into(), "`manifold.dim`", "differs from options.dim = 2"),
        (|m| m["manifold"]["p"] = 7.into(), "`manifold.p`", "differs from options.embed x observables = 5"),
        (|m| m["dynamics"]["Rbf"]["scale"] = serde_json::json!([]), "`dynamics.Rbf.scale`", "length 0, expected 2"),
        (|m| m["dynamics"]["Rbf"]["scale"][1] = (-1.0).into(), "`dynamics.Rbf.scale[1]`", "must be > 0"),
        (
            |m| m["dynamics"]["Rbf"]["centers"].as_array_mut().unwrap().truncate(3),
            "`dynamics.Rbf.centers`",
            "not a positive multiple of dim = 2",
        ),
        (
            |m| m["dynamics"]["Rbf"]["coef"].as_array_mut().unwrap().pop().map(|_| ()).unwrap(),
            "`dynamics.Rbf.coef`",
            "expected 26",
        ),
        (|m| m["dynamics"]["Rbf"]["dt"] = (-0.05).into(), "`dynamics.Rbf.dt`", "must be finite and > 0"),
        (
            |m| m["manifold"]["nonlinear"]["exps"][0] = serde_json::json!([4000000000u32, 0]),
            "`manifold.nonlinear.exps[0]`",
            "total degree 4000000000, expected 1..=32",
        ),
        (
            |m| m["manifold"]["nonlinear"]["exps"][0] = serde_json::json!([1, 1, 0]),
            "`manifold.nonlinear.exps[0]`",
            "length 3",
        ),
        (|m| m["manifold"]["nonlinear"]["dim_out"] = 4.into(), "`manifold.nonlinear.dim_out`", "expected 5"),
        (|m| m["manifold"]["eta_scale"] = serde_json::json!([1.0]), "`manifold.eta_scale`", "length 1, expected 2"),
        (|m| m["dt"] = 0.0.into(), "`dt`", "must be finite and > 0"),
    ];
    for (edit, field, why) in cases {
        let mut v = good.clone();
        edit(&mut v["model"]);
        let e = SsmModel::from_json(&v.to_string()).unwrap_err();
        assert!(matches!(e, ssm::ModelFileError::Invalid { .. }), "{field}: {e}");
        let m = e.to_string();
        assert!(m.contains(field) && m.contains(why), "{field} / {why}: {m}");
    }
}

/// A saved model keeps its RBF kernel; a saved kernel that is invalid or differs from the
/// options' is refused naming `dynamics.Rbf.kernel`; old files (no kernel) read as linear;
/// the device export takes only the linear kernel its predictor implements.
#[test]
fn rbf_kernel_saves_validates_and_exports_only_linear() {
    let dt = 0.05;
    let train = [synthetic("a", 0.5, 0.0, dt, 300), synthetic("b", 0.4, 1.0, dt, 300)];
    let base = FitOptions {
        dim: 2,
        embed: 5,
        shift: 1,
        manifold_order: 3,
        dyn_order: 3,
        dynamics: Dynamics::Rbf { centers: 10 },
        ridge: Ridge::Fixed(1e-8),
        linear_anchor: None,
        anchor_joint: false,
    };
    let cfg = shared::ControllerConfig::paper(dt);
    // The linear default exports, also when the saved file has no kernel field.
    let mut old = saved_rbf_model();
    assert_eq!(old["model"]["dynamics"]["Rbf"]["kernel"], serde_json::json!("Linear"));
    old["model"]["dynamics"]["Rbf"].as_object_mut().unwrap().remove("kernel");
    let m = SsmModel::from_json(&old.to_string()).unwrap();
    assert!(ssm::device::to_device_model(&m, cfg).is_ok());
    let o =
        FitOptions { dynamics: Dynamics::RbfWith { centers: 10, kernel: ssm::Kernel::Gaussian { eps: 0.8 } }, ..base };
    let m = fit(&train, &o).unwrap();
    let back = SsmModel::from_json(&m.to_json().unwrap()).unwrap();
    let ReducedDynamics::Rbf(r) = &back.dynamics else { panic!() };
    assert_eq!(r.kernel, ssm::Kernel::Gaussian { eps: 0.8 });
    let test = synthetic("t", 0.45, 1.0, dt, 200);
    let (p1, p2) = (m.predict(&test).unwrap(), back.predict(&test).unwrap());
    // (serde_json's float parsing is not exactly round-trip: equal to 1e-12.)
    let dmax = p1.x.iter().zip(&p2.x).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    assert!(
        p1.x.len() == p2.x.len() && dmax <= 1e-12,
        "{} / {} samples, max difference {dmax:e}, stop {:?}",
        p1.x.len(),
        p2.x.len(),
        p1.stop
    );
    let e = ssm::device::to_device_model(&back, cfg).unwrap_err().to_string();
    assert!(e.contains("linear RBF kernel") && e.contains("gaussian:0.8"), "{e}");
    let good: serde_json::Value = serde_json::from_str(&m.to_json().unwrap()).unwrap();
    type Edit = fn(&mut serde_json::Value);
    let cases: [(Edit, &str); 3] = [
        (
            |m| m["dynamics"]["Rbf"]["kernel"] = serde_json::json!({"Gaussian": {"eps": -1.0}}),
            "eps must be finite and > 0",
        ),
        (|m| m["dynamics"]["Rbf"]["kernel"] = serde_json::json!("Cubic"), "differs from the options' kernel"),
        (
            |m| m["options"]["dynamics"] = serde_json::json!({"Rbf": {"centers": 10}}),
            "differs from the options' kernel",
        ),
    ];
    for (edit, why) in cases {
        let mut v = good.clone();
        edit(&mut v["model"]);
        let e = SsmModel::from_json(&v.to_string()).unwrap_err().to_string();
        assert!(e.contains("dynamics.Rbf.kernel") && e.contains(why), "{why}: {e}");
    }
}

/// Found by the model-JSON fuzz target: a valid model with extreme lift coefficients lifted
/// finite states to infinite samples (documented: all values finite), and a shift large
/// against a short test series made the sample index underflow (a panic).
#[test]
fn prediction_never_emits_non_finite_samples_nor_indexes_past_short_series() {
    let mut v = saved_rbf_model();
    for c in v["model"]["manifold"]["nonlinear"]["coef"].as_array_mut().unwrap() {
        *c = 1.7e308.into();
    }
    let m = SsmModel::from_json(&v.to_string()).unwrap();
    let test = synthetic("test", 0.45, 1.0, 0.05, 200);
    let p = m.predict(&test).unwrap();
    assert!(matches!(p.stop, Some(Stop { reason: StopReason::NonFinite, .. })), "{:?}", p.stop);
    assert!(p.x.iter().all(|x| x.is_finite()) && p.eta.len() == p.x.len() * 2);
    // shift 45, p = 5: 200 samples give 20 embedded points, fewer than the shift.
    let mut v = saved_rbf_model();
    v["model"]["options"]["shift"] = 45.into();
    let m = SsmModel::from_json(&v.to_string()).unwrap();
    let e = m.predict(&test).unwrap_err();
    assert!(matches!(e, FitError::Data(DataError::TooShort { have: 200, need: 225, .. })), "{e}");
}
