//! Data and equations agree on a plant written as equations: the SSM model fitted on
//! simulated decays of the `duffing-chain` scene (`ssm::fit`, a 2D map on the delay-embedded
//! first mass) against the equation-driven SSM of the same loop (`ssm-equations`): the slow
//! pair's linear rate and frequency, and the backbone (frequency and damping ratio against
//! the first-harmonic amplitude of `x1`) over the amplitudes the data cover.
//!
//! Independent reference for the backbone: the decays themselves, read cycle by cycle with no
//! model (period between upward zero crossings, first-harmonic amplitude of the interpolated
//! signal, rate of its logarithm between cycles).

use furuta::equation_ssm::equation_ssm;
use sim::closed_loop::simulate;
use sim::scene::Scene;
use ssm::backbone::{damping_ratio, instantaneous};
use ssm::fit::{FitOptions, fit};
use ssm::normal_form::{NormalFormOptions, model_normal_form_first_harmonic};
use ssm::{Dynamics, Ridge, TimeSeries};

/// Start amplitudes of `x1` (m); `x2 = 2 x1` is the slow mode's shape (`k1 = 100`, `k2 = 50`,
/// `m2 = m1 / 2`: the linear modes are `(1, 2)` at 7.07 rad/s and `(1, -1)` at 14.1 rad/s).
const STARTS: [f64; 3] = [0.01, 0.015, 0.02];
/// Periods (5 ms) per decay, and the first ones left out (1 s: the fast mode's share decays).
const PERIODS: u64 = 4000;
const SKIP: usize = 200;

fn decays() -> Vec<TimeSeries> {
    STARTS
        .iter()
        .map(|&a| {
            let o = [
                format!("initial.state.x1={a}"),
                format!("initial.state.x2={}", 2.0 * a),
                format!("run.periods={PERIODS}"),
            ];
            let tr = simulate(&Scene::load("duffing-chain", &o).unwrap(), None).unwrap();
            let x: Vec<f64> = (SKIP..tr.rows()).map(|i| tr.state(i, 0)).collect();
            TimeSeries { name: format!("x1 = {a}"), t: tr.t[SKIP..].to_vec(), x }
        })
        .collect()
}

/// A cubic through the four samples around `t` (uniform step `h` from `t0`).
fn interp(t0: f64, h: f64, x: &[f64], t: f64) -> f64 {
    let s = (t - t0) / h;
    let i = (s.floor() as usize).clamp(1, x.len() - 3);
    let u = s - i as f64;
    let (a, b, c, d) = (x[i - 1], x[i], x[i + 1], x[i + 2]);
    // Lagrange on nodes -1, 0, 1, 2.
    -a * u * (u - 1.0) * (u - 2.0) / 6.0 + b * (u + 1.0) * (u - 1.0) * (u - 2.0) / 2.0
        - c * (u + 1.0) * u * (u - 2.0) / 2.0
        + d * (u + 1.0) * u * (u - 1.0) / 6.0
}

/// The backbone read off a decaying trajectory, with no model: per cycle between upward zero
/// crossings, the first-harmonic amplitude of the interpolated signal and the period; between
/// consecutive cycles, `(rho, rate of ln rho, omega)` at their geometric-mean amplitude.
fn trajectory_backbone(t: &[f64], x: &[f64]) -> Vec<(f64, f64, f64)> {
    let (t0, h) = (t[0], t[1] - t[0]);
    let f = |s: f64| interp(t0, h, x, s);
    let mut ups = Vec::new();
    for i in 2..x.len() - 2 {
        if x[i - 1] < 0.0 && x[i] >= 0.0 {
            let (mut lo, mut hi) = (t[i - 1], t[i]);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if f(mid) < 0.0 { lo = mid } else { hi = mid }
            }
            ups.push(0.5 * (lo + hi));
        }
    }
    let cycles: Vec<(f64, f64, f64)> = ups
        .windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let period = b - a;
            let n = 2000;
            let (mut c, mut s) = (0.0, 0.0);
            for k in 0..=n {
                let tk = a + period * k as f64 / n as f64;
                let wgt = if k == 0 || k == n {
                    1.0
                } else if k % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                let ph = std::f64::consts::TAU * (tk - a) / period;
                c += wgt * f(tk) * ph.cos();
                s += wgt * f(tk) * ph.sin();
            }
            let scale = period / (3.0 * n as f64) * 2.0 / period;
            (0.5 * (a + b), (c * scale).hypot(s * scale), period)
        })
        .collect();
    cycles
        .windows(2)
        .map(|w| {
            let ((m0, a0, p0), (m1, a1, p1)) = (w[0], w[1]);
            ((a0 * a1).sqrt(), (a1 / a0).ln() / (m1 - m0), std::f64::consts::TAU * 2.0 / (p0 + p1))
        })
        .collect()
}

#[test]
fn duffing_chain_fit_matches_its_equation_ssm() {
    let eq = equation_ssm(&Scene::load("duffing-chain", &[]).unwrap(), 5).unwrap();
    // Slow pair: mode 1 (the table orders modes by frequency).
    let (eq_rate, eq_omega) = eq.polar.eigenvalues[0];
    let train = decays();
    let opts = FitOptions {
        dim: 2,
        embed: 9,
        shift: 10,
        manifold_order: 3,
        dyn_order: 5,
        dynamics: Dynamics::Map,
        ridge: Ridge::Fixed(0.0),
        // The decays start at large amplitude: the linear part is anchored on the pairs within
        // a fifth of the radius, fitted jointly with the higher orders.
        linear_anchor: Some(0.2),
        anchor_joint: true,
    };
    let model = fit(&train, &opts).unwrap();
    let (re, im) = model.eigenvalues_ct()[0];
    let rate_err = re / eq_rate - 1.0;
    let freq_err = im.abs() / eq_omega - 1.0;
    eprintln!(
        "linear: fit {re:.6} 1/s, {:.6} rad/s; equations {eq_rate:.6} 1/s, {eq_omega:.6} rad/s; relative {rate_err:.2e}, {freq_err:.2e}",
        im.abs()
    );
    assert!(rate_err.abs() < 1e-3 && freq_err.abs() < 1e-3, "{rate_err} {freq_err}");

    // The backbones at the amplitudes the decays pass through (first harmonic of x1, the
    // backbones' amplitude), each against the trajectory read with no model.
    let nf_opts = NormalFormOptions { order: None, ..NormalFormOptions::default() };
    let data = model_normal_form_first_harmonic(&model, &nf_opts).unwrap();
    let reference: Vec<(f64, f64, f64)> = train.iter().flat_map(|s| trajectory_backbone(&s.t, &s.x)).collect();
    let rho_max = reference.iter().map(|r| r.0).fold(0.0, f64::max);
    let (mut fit_eq, mut fit_traj, mut eq_traj) = ([0.0f64; 2], [0.0f64; 2], [0.0f64; 2]);
    let worse = |w: &mut [f64; 2], a: f64, b: f64, za: f64, zb: f64| {
        *w = [w[0].max((a / b - 1.0).abs()), w[1].max((za / zb - 1.0).abs())];
    };
    for &(rho, a, w) in &reference {
        let (a_d, w_d) = instantaneous(&data, 0, rho);
        let (a_e, w_e) = instantaneous(&eq.polar, 0, rho);
        let (z_d, z_e, z) = (damping_ratio(a_d, w_d), damping_ratio(a_e, w_e), damping_ratio(a, w));
        worse(&mut fit_eq, w_d, w_e, z_d, z_e);
        worse(&mut fit_traj, w_d, w, z_d, z);
        worse(&mut eq_traj, w_e, w, z_e, z);
    }
    eprintln!(
        "backbone over rho <= {rho_max:.5} ({} cycle pairs), worst relative (frequency, damping ratio): \
         fit vs equations {:.2e} {:.2e}, fit vs trajectory {:.2e} {:.2e}, equations vs trajectory {:.2e} {:.2e}",
        reference.len(),
        fit_eq[0],
        fit_eq[1],
        fit_traj[0],
        fit_traj[1],
        eq_traj[0],
        eq_traj[1]
    );
    assert!(rho_max > 0.012, "the decays cover {rho_max} m");
    assert!(fit_eq.iter().all(|e| *e < 1e-2), "fit vs equations {fit_eq:?}");
    assert!(fit_traj.iter().all(|e| *e < 1e-2), "fit vs trajectory {fit_traj:?}");
    // The equation-driven SSM is the sharper of the two: its order-5 truncation holds over
    // the decays' range.
    assert!(eq_traj.iter().all(|e| *e < 2e-3), "equations vs trajectory {eq_traj:?}");
}

/// The trajectory reader on a signal with a known answer: a damped sinusoid sampled as the
/// decays are (5 ms) gives back its rate and frequency.
#[test]
fn trajectory_backbone_reads_a_damped_sinusoid() {
    let (sigma, omega) = (-0.2, 7.1);
    let t: Vec<f64> = (0..4000).map(|i| i as f64 * 0.005).collect();
    let x: Vec<f64> = t.iter().map(|&t| 0.01 * (sigma * t).exp() * (omega * t + 0.3).cos()).collect();
    let rows = trajectory_backbone(&t, &x);
    assert!(rows.len() > 15, "{} cycle pairs", rows.len());
    for (rho, a, w) in rows {
        assert!((a / sigma - 1.0).abs() < 1e-5 && (w / omega - 1.0).abs() < 1e-6, "rho {rho}: {a} {w}");
    }
}
