//! The tests of `chaos_study::verdict`.

use chaos::FsleRow;
use chaos_study::verdict::*;
use sim::closed_loop::simulate;
use sim::scene::SceneBuilder;

/// The RK4 dual-number flow Jacobian at the equilibrium is the exact ZOH (matrix
/// exponential) of the linearization.
#[test]
fn flow_jacobian_at_equilibrium_is_the_zoh() {
    let plant = sim::plant::Furuta::paper();
    let (a, b) = sim::plant::linearize(&plant);
    let dt = 0.025;
    let zoh = sim::linear::LinearPlant::new(&a, &b, 0, 2).unwrap().discretize(dt).unwrap();
    let a_norm = (0..4).map(|j| (0..4).map(|i| a[(i, j)].abs()).sum::<f64>()).fold(0.0, f64::max);
    let steps = rk4_steps(a_norm, dt);
    let (end, jx, ju) = flow_jacobian(&plant, &[0.0; 4], 0.0, dt, steps);
    assert_eq!(end, [0.0; 4]);
    for i in 0..4 {
        for j in 0..4 {
            assert!(
                (jx[i][j] - zoh.phi[(i, j)]).abs() < 1e-7 * zoh.phi[(i, j)].abs().max(1.0),
                "{i} {j}: {} vs {}",
                jx[i][j],
                zoh.phi[(i, j)]
            );
        }
        assert!(
            (ju[i] - zoh.gamma[i]).abs() < 1e-7 * zoh.gamma[i].abs().max(1e-3),
            "{i}: {} vs {}",
            ju[i],
            zoh.gamma[i]
        );
    }
}

/// The law row read back from the linear closed-loop map rebuilds the map.
#[test]
fn law_row_rebuilds_the_closed_loop_map() {
    let s = SceneBuilder::load("furuta-dt25").unwrap().build().unwrap();
    let plant = sim::plant::Furuta::paper();
    let (a, b) = sim::plant::linearize(&plant);
    let zoh = sim::linear::LinearPlant::new(&a, &b, 0, 2).unwrap().discretize(0.025).unwrap();
    let cl = zoh.closed_loop(&s.controller_config()).unwrap();
    let g = law_row(&cl.matrix, &zoh.phi, &zoh.gamma).unwrap();
    for i in 0..4 {
        for j in 0..cl.matrix.ncols() {
            let want = cl.matrix[(i, j)];
            let got = if j < 4 { zoh.phi[(i, j)] } else { 0.0 } + zoh.gamma[i] * g[j];
            assert!((got - want).abs() < 1e-12 * want.abs().max(1.0), "{i} {j}");
        }
    }
    // u = -(kp + kd/dt) y_{i-1} + kd/dt y_{i-2} + ... for delay 1 (layout: y_{i-1} at 4).
    let cfg = s.controller_config();
    let (kp, kd, _) = cfg.as_shorthand().unwrap();
    assert!((g[4] + kp + kd / cfg.dt).abs() < 1e-9 * (kd / cfg.dt), "{g:?}");
}

/// Known answer: along the orbit that sits at the upright equilibrium (zero state, zero
/// input), the Q' = 0 tangent is the open-loop ZOH map (its exponent the open-loop rate)
/// and the smooth tangent is the linear closed-loop map, whose leading exponents are
/// ln |mu| / dt of its largest multipliers.
#[test]
fn exponents_at_the_equilibrium_are_the_linear_ones() {
    let s = SceneBuilder::load("furuta-dt25").unwrap().periods(2000).initial_state(&[0.0; 4]).build().unwrap();
    let t = simulate(&s, None).unwrap();
    assert!(t.states.iter().all(|&v| v == 0.0) && t.u.iter().all(|&u| u == 0.0));
    let e = period_map_exponents(&s, &t, 0, 2000).unwrap();
    assert!((e.quantized_tangent - e.open_loop_rate).abs() < 0.02 * e.open_loop_rate, "{e:?}");
    let plant = sim::plant::Furuta::paper();
    let (a, b) = sim::plant::linearize(&plant);
    let cl = sim::linear::LinearPlant::new(&a, &b, 0, 2).unwrap().closed_loop(&s.controller_config()).unwrap();
    let mut mu: Vec<f64> =
        sim::linear::eigenvalues(&cl.matrix).unwrap().iter().map(|c| c.norm().ln() / 0.025).collect();
    mu.sort_by(|x, y| y.total_cmp(x));
    assert!((e.linear_closed_loop_rate - mu[0]).abs() < 1e-9);
    for k in 0..3 {
        assert!((e.smooth_tangent[k] - mu[k]).abs() < 0.02, "{k}: {:?} vs {:?}", e.smooth_tangent, &mu[..3]);
    }
}

/// A twin restarted from a row of a noise-free quantized run (state and the controller's
/// pre-history) is that run: the same DAC codes, the same states to integrator accuracy
/// for a second (the restart's 1e-12 differences grow at ~6 1/s and reach 1e-7 after
/// about 80 periods: the chaos itself).
#[test]
fn restarted_twin_reproduces_the_run() {
    let s = SceneBuilder::load("furuta-quant-dt25").unwrap().periods(1200).build().unwrap();
    let t = simulate(&s, None).unwrap();
    let r = 1000;
    let x: Vec<f64> = (0..4).map(|i| t.state(r, i)).collect();
    let hist = [[t.state(r - 2, 0), t.state(r - 2, 2)], [t.state(r - 1, 0), t.state(r - 1, 2)]];
    let re = simulate(&s.clone().builder().periods(100).initial_state(&x).history(Some(&hist)).build().unwrap(), None)
        .unwrap();
    let (c0, c1) = (t.codes.as_ref().unwrap(), re.codes.as_ref().unwrap());
    for k in 0..=40 {
        assert_eq!(c0[r + k].code, c1[k].code, "period {k}");
        assert!((t.state(r + k, 0) - re.state(k, 0)).abs() < 1e-7, "period {k}");
    }
}

#[test]
fn band_rate_reads_the_band() {
    let row = |delta: f64, lambda: f64| FsleRow { delta, lambda: Some(lambda), mean_time: Some(1.0), pairs: 5 };
    let rows = [row(1.0, 4.0), row(2.0, 1.0), row(4.0, 0.25), row(8.0, 9.0)];
    let (mean, slope) = band_rate(&rows, 1.0, 4.0);
    assert_eq!(mean, Some(2.5));
    assert!((slope.unwrap() + 2.0).abs() < 1e-12);
    assert_eq!(band_rate(&rows, 10.0, 20.0), (None, None));
}

#[test]
fn bad_options_are_named() {
    let o = VerdictOptions { twin_deltas: vec![0.5], ..VerdictOptions::quick() };
    assert!(microchaos_verdict(None, &o).unwrap_err().to_string().contains("twin_deltas"));
    let o = VerdictOptions { periods: 10, ..VerdictOptions::quick() };
    assert!(microchaos_verdict(None, &o).unwrap_err().to_string().contains("periods"));
}
