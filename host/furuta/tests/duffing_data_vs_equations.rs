//! Data and equations agree on a plant written as equations: the SSM model fitted on
//! simulated decays of the `duffing-chain` scene (`ssm::fit`, a 2D map on the delay-embedded
//! first mass) against the equation-driven SSM of the same loop (`ssm-equations`): the slow
//! pair's linear rate and frequency, and the backbone (frequency and damping ratio against
//! the first-harmonic amplitude of `x1`) over the amplitudes the data cover.

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
/// Periods (5 ms) per decay, and the first ones left out (the fast mode's share decays). The
/// amplitudes stay where both order-5 truncations hold: from larger starts the fitted and the
/// equation-driven damping part at the top of the range, where the data are few.
const PERIODS: u64 = 4000;
const SKIP: usize = 1000;

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

#[test]
fn duffing_chain_fit_matches_its_equation_ssm() {
    let eq = equation_ssm(&Scene::load("duffing-chain", &[]).unwrap(), 5).unwrap();
    // Slow pair: mode 1 (the table orders modes by frequency).
    let (eq_rate, eq_omega) = eq.polar.eigenvalues[0];
    let train = decays();
    let rho_max = train.iter().flat_map(|s| s.x.iter()).fold(0.0f64, |m, v| m.max(v.abs()));
    let opts = FitOptions {
        dim: 2,
        embed: 9,
        shift: 10,
        manifold_order: 3,
        dyn_order: 5,
        dynamics: Dynamics::Map,
        ridge: Ridge::Fixed(0.0),
        linear_anchor: None,
        anchor_joint: false,
    };
    let model = fit(&train, &opts).unwrap();
    let (re, im) = model.eigenvalues_ct()[0];
    let rate_err = re / eq_rate - 1.0;
    let freq_err = im.abs() / eq_omega - 1.0;
    eprintln!(
        "linear: fit {re:.6} 1/s, {:.6} rad/s; equations {eq_rate:.6} 1/s, {eq_omega:.6} rad/s; relative {rate_err:.2e}, {freq_err:.2e}",
        im.abs()
    );
    let nf_opts = NormalFormOptions { order: None, ..NormalFormOptions::default() };
    let data = model_normal_form_first_harmonic(&model, &nf_opts).unwrap();
    let mut worst = (0.0f64, 0.0f64);
    for k in 1..=10 {
        let rho = rho_max * k as f64 / 10.0;
        let (a_d, w_d) = instantaneous(&data, 0, rho);
        let (a_e, w_e) = instantaneous(&eq.polar, 0, rho);
        let (z_d, z_e) = (damping_ratio(a_d, w_d), damping_ratio(a_e, w_e));
        let (ew, ez) = ((w_d / w_e - 1.0).abs(), (z_d / z_e - 1.0).abs());
        eprintln!("rho {rho:.5}: omega fit {w_d:.5} eq {w_e:.5} ({ew:.2e}); zeta fit {z_d:.6} eq {z_e:.6} ({ez:.2e})");
        worst = (worst.0.max(ew), worst.1.max(ez));
    }
    eprintln!("backbone over rho <= {rho_max:.5}: frequency {:.2e}, damping ratio {:.2e}", worst.0, worst.1);
    assert!(rate_err.abs() < 1e-3 && freq_err.abs() < 1e-3, "{rate_err} {freq_err}");
    assert!(worst.0 < 1e-2 && worst.1 < 1e-2, "{worst:?}");
}
