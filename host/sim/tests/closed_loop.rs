use sim::closed_loop::*;
use sim::scene::{MethodKind, Scene};

/// A three-mass chain with an encoder on every mass, each of its own resolution.
const CHAIN3: &str = r#"
name = "chain3-quant"
description = "Three-mass Duffing chain, PD on the first mass, D on the others, three encoders"

[plant]
kind = "equations"
coordinates = ["x1", "x2", "x3"]
parameters = { m = 1.0, k = 100.0, k3 = 1.0e4, c = 0.05 }
mass = [["m", "0", "0"], ["0", "m", "0"], ["0", "0", "m"]]
forces = ["-k*x1 - k3*x1^3 - k*(x1 - x2) - c*x1_dot + u",
      "-k*(x2 - x1) - k*(x2 - x3) - c*x2_dot",
      "-k*(x3 - x2) - c*x3_dot"]

[controller]
gains = { x1 = { p = 5.0, d = 1.0, h_adc = 1.0e-5 }, x2 = { d = 0.5, h_adc = 2.0e-5 }, x3 = { d = 0.25, h_adc = 5.0e-5 } }
dt_ms = 5.0
delay = 1

[initial]
state = { x1 = 0.02, x2 = -0.01, x3 = 0.005 }

[run]
periods = 2000

[effects.quantization]
mode = "counts"
h_adc = 1.0e-5
h_dac = 1.0e-4

[integrator]
method = "rodas"
rtol = 1e-10
atol = 1e-12
"#;

/// Quantized runs read every measured coordinate through its own encoder: with three,
/// the recorded counts are `floor(q_j / h_j)` of the state, each DAC code is the integer
/// controller's output on the recorded counts (a fresh `controller::IntPd` replayed, bit
/// for bit) and within one DAC step of the float law on the same counts, the held input
/// is the code times the DAC step, and the CSV has a column per measured coordinate.
#[test]
fn quantized_run_with_three_encoders_is_the_integer_controller() {
    let dir = std::env::temp_dir().join(format!("sim-chain3-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("chain3-quant.toml");
    std::fs::write(&path, CHAIN3).unwrap();
    let s = Scene::load(path.to_str().unwrap(), &[]).unwrap();
    let tr = simulate(&s, None).unwrap();
    let cfg = s.controller_config();
    assert_eq!(cfg.gains.len(), 3);
    let codes = tr.codes.as_ref().unwrap();
    assert_eq!(codes.len(), tr.rows());
    let h: Vec<f64> = cfg.gains.iter().map(|g| g.h_adc).collect();
    assert_eq!(h, [1.0e-5, 2.0e-5, 5.0e-5]);
    let idx: Vec<usize> = cfg.gains.iter().map(|g| usize::from(g.index)).collect();
    let mut pd = controller::IntPd::<HISTORY>::try_new(&cfg).unwrap();
    let first: Vec<i32> = codes[0].counts().collect();
    pd.prime(&[first.clone(), first].concat()).unwrap();
    let h_dac = cfg.quant.unwrap().h_dac;
    let mut worst = 0.0f64;
    for (i, c) in codes.iter().enumerate() {
        let q: Vec<i32> = c.counts().collect();
        assert_eq!(q.len(), 3);
        for (j, &k) in idx.iter().enumerate() {
            assert_eq!(q[j], (tr.state(i, k) / h[j]).floor() as i32, "row {i} coordinate {j}");
        }
        let o = pd.step(&q).unwrap();
        assert_eq!(o.code, c.code, "row {i}");
        assert_eq!(tr.u[i], pd.volts(c.code), "row {i}");
        if i >= 2 {
            let (q1, q2): (Vec<i32>, Vec<i32>) = (codes[i - 1].counts().collect(), codes[i - 2].counts().collect());
            let u: f64 = -cfg
                .gains
                .iter()
                .enumerate()
                .map(|(j, g)| {
                    let (a, b) = (f64::from(q1[j]) * h[j], f64::from(q2[j]) * h[j]);
                    g.p * a + g.d * (a - b) / cfg.dt
                })
                .sum::<f64>();
            worst = worst.max((f64::from(c.code) * h_dac - u).abs() / h_dac);
        }
    }
    eprintln!("three encoders: {} rows, integer law vs float law on the counts: {worst:.3} DAC steps", tr.rows());
    assert!(worst <= 1.0, "{worst}");
    assert!(codes.iter().any(|c| c.q_rest[0] != 0), "the third encoder never moved");
    let mut csv = Vec::new();
    tr.write_csv_to(&mut csv).unwrap();
    let csv = String::from_utf8(csv).unwrap();
    assert!(csv.starts_with("t,x1,x1_dot,x2,x2_dot,x3,x3_dot,u,q_theta,q_phi,code,q_2\n"), "{}", &csv[..80]);
    let _ = std::fs::remove_dir_all(&dir);
}

fn scene(name: &str, o: &[&str]) -> Scene {
    Scene::load(name, &o.iter().map(|s| s.to_string()).collect::<Vec<_>>()).unwrap()
}

/// A `Stepper` driven by a simulation's held inputs retraces that simulation's states bit
/// for bit (the built-in Furuta, a four-coordinate equations plant), whether it builds the
/// plant itself or is given one already built, and refuses a state of the wrong length
/// without touching it. `simulate_plant` on that built plant is `simulate`, bit for bit.
#[test]
fn stepper_retraces_the_simulation_and_refuses_a_wrong_state_length() {
    for (s, states) in [
        (scene("furuta-quant-dt25-noise", &["run.periods=300"]), 4),
        (scene("duffing-chain4", &["run.periods=300"]), 8),
    ] {
        let tr = simulate(&s, None).unwrap();
        let plant = build_plant(&s).unwrap();
        let again = simulate_plant(&s, &plant, None).unwrap();
        assert_eq!(again.states.len(), tr.states.len(), "{}", s.name);
        assert!(again.states.iter().zip(&tr.states).all(|(a, b)| a.to_bits() == b.to_bits()), "{}", s.name);
        assert_eq!((&again.u, &again.codes), (&tr.u, &tr.codes), "{}", s.name);
        for (how, mut stepper) in
            [("built by new", Stepper::new(&s).unwrap()), ("given", Stepper::with_plant(&s, plant.clone()).unwrap())]
        {
            assert_eq!((stepper.states(), tr.n_states()), (states, states), "{}: {how}", s.name);
            let mut x = vec![0.0; states];
            if !s.initial.state.is_empty() {
                x.copy_from_slice(&s.initial.state);
            }
            let dt = s.controller_config().dt;
            for i in 0..tr.rows() {
                for (k, xk) in x.iter().enumerate() {
                    assert_eq!(xk.to_bits(), tr.state(i, k).to_bits(), "{}: {how}: period {i}, state {k}", s.name);
                }
                if i + 1 < tr.rows() {
                    stepper.advance(&mut x, tr.u[i], dt).unwrap();
                }
            }
            let mut short = vec![0.25; states - 1];
            let e = stepper.advance(&mut short, 0.0, dt).unwrap_err().to_string();
            assert!(
                e.contains(&format!("a state of {} values", states - 1)) && e.contains(&format!("of {states} states")),
                "{e}"
            );
            assert!(short.iter().all(|&v| v == 0.25));
        }
    }
}

/// Long quantized runs stay finite and repeat bit for bit.
#[test]
fn quantized_1e5_periods_finite_and_bitwise_reproducible() {
    let mut s = scene("furuta-quant-dt25", &["run.periods=100000"]);
    s.integrator =
        sim::scene::IntegratorSpec { method: MethodKind::RodasFixed, rtol: None, atol: None, steps: Some(8) };
    let a = simulate(&s, None).unwrap();
    let b = simulate(&s, None).unwrap();
    assert_eq!(a.rows(), 100_001);
    assert!(a.states.iter().all(|v| v.is_finite()));
    assert!(a.states.iter().zip(&b.states).all(|(x, y)| x.to_bits() == y.to_bits()));
    assert_eq!(a.codes, b.codes);
    // Bounded: the quantized loop stays within the neighbourhood (no escape).
    assert!(a.primary().iter().all(|t| t.abs() < 0.5));
    // The held voltage is exactly the DAC step times the integer code.
    let c = a.codes.as_ref().unwrap();
    assert!(a.u.iter().zip(c).all(|(u, c)| *u == 4.8828125e-3 * f64::from(c.code)));
}

/// Both readings of the quantizer (integer counts/DAC codes, and the paper's formula read
/// literally) give long bounded irregular motion at the paper's gains, dt = 25 ms: twin
/// runs started 1e-9 rad apart separate to the attractor's size (sensitive dependence),
/// and the motion neither settles nor escapes.
#[test]
fn both_quantizer_readings_give_bounded_chaotic_runs() {
    for name in ["furuta-quant-dt25", "furuta-literal-dt25"] {
        let a = simulate(&scene(name, &["run.periods=3000"]), None).unwrap();
        let b = simulate(&scene(name, &["run.periods=3000", "initial.state=[0.020000001,0,0,0]"]), None).unwrap();
        assert!(a.stopped.is_none() && b.stopped.is_none(), "{name}: {:?} {:?}", a.stopped, b.stopped);
        let (xa, xb) = (a.primary(), b.primary());
        let amp = xa.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let sep_at = xa.iter().zip(&xb).position(|(p, q)| (p - q).abs() > 0.1 * amp);
        // Irregular, not settled: the spread of the last third stays at the attractor's size.
        let tail = &xa[2000..];
        let mean = tail.iter().sum::<f64>() / tail.len() as f64;
        let sd = (tail.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / tail.len() as f64).sqrt();
        println!("{name}: max |theta| {amp:.4}, tail sd {sd:.4}, twins separate at sample {sep_at:?}");
        assert!(amp < 0.5, "{name}: escaped the neighbourhood ({amp})");
        assert!(sd > 0.1 * amp, "{name}: settled (sd {sd}, amplitude {amp})");
        let k = sep_at.unwrap_or(usize::MAX);
        assert!(k < 2000, "{name}: twins 1e-9 apart did not separate within 50 s");
    }
}

#[test]
fn effects_are_simulated_only_when_named() {
    let plain = simulate(&scene("furuta-dt25", &["run.periods=40"]), None).unwrap();
    assert!(plain.codes.is_none(), "unquantized scene touched the integer path");
    assert_eq!(plain.saturated_samples, 0);
    let noisy = |seed: &str| {
        simulate(&scene("furuta-noise-pid", &["run.periods=200", &format!("effects.noise.seed={seed}")]), None).unwrap()
    };
    let (a, b, c) = (noisy("1"), noisy("1"), noisy("2"));
    assert_eq!(a.states, b.states, "same seed, same run");
    assert_ne!(a.states, c.states, "another seed, another run");
    // Noise off: the run equals the noiseless scene exactly.
    let quiet = simulate(
        &scene("furuta-noise-pid", &["run.periods=200", "effects.noise.sigma_theta=0", "effects.noise.sigma_phi=0"]),
        None,
    )
    .unwrap();
    let mut s = scene("furuta-noise-pid", &["run.periods=200"]);
    s.effects.noise = None;
    let none = simulate(&s, None).unwrap();
    assert_eq!(quiet.states, none.states);
}

#[test]
fn saturation_scene_escapes_to_the_tilted_rotating_state_and_clips() {
    let tr = simulate(&scene("furuta-saturation", &[]), None).unwrap();
    assert!(tr.saturated_samples > 0);
    // The clipped rows, in order: exactly those whose held input sits at the limit.
    assert_eq!(tr.saturated_rows.len() as u64, tr.saturated_samples);
    assert!(tr.saturated_rows.windows(2).all(|w| w[0] < w[1]) && tr.saturated_rows.iter().all(|&r| r < tr.rows()));
    assert!(tr.saturated_rows.iter().all(|&r| tr.u[r].abs() == 24.0));
    let late = &tr.primary()[tr.rows() - 200..];
    let mean = late.iter().sum::<f64>() / late.len() as f64;
    let spread = late.iter().fold(0.0_f64, |m, t| m.max((t - mean).abs()));
    // theta settles tilted and steady, away from upright and short of hanging down
    // (MODEL.md: saturation creates an attracting tilted rotating state).
    assert!(mean.abs() > 0.3 && mean.abs() < 2.5 && spread < 0.05, "late theta {mean} +- {spread}");
    assert!(tr.u.iter().all(|u| u.abs() <= 24.0));
}

#[test]
fn bad_initial_state_length_is_an_error() {
    let e = simulate(&scene("furuta-dt25", &["initial.state=[0.1, 0.0]"]), None).unwrap_err().to_string();
    assert!(e.contains("initial.state") && e.contains('4'), "{e}");
}
