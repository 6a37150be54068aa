//! Why is the equation-driven model's 2-torus at 30.8 ms 5 % off the full
//! system's in rho_1? Measures the torus of each truncation the way the full system's is
//! measured (`full_system::torus_full`: first-harmonic amplitudes of sampled theta by
//! sliding least squares at the spectral peaks): (a) the polar fixed point mapped through
//! the manifold `W` (theta = c . W(z)); (b) the reduced 4D map `R` iterated; (c) the
//! order-K Taylor period map `F` iterated in the full state; each for both amplitude
//! normalizations (`ssm::map_ssm::Amplitude`). Prints; not a test.
//! Run: `cargo run --release -p lab --example eqtorus -- [dt_ms] [orders...]`;
//! `-- --table DT...` the order-7 polar coefficients of both normalizations;
//! `-- --embed DT P F1 F2` how a P-sample delay embedding's modal projection (span of the
//! linear modes) reads a pure tone at F1 / F2 Hz (the data-driven chart, idealized).
//!
//! Measured at 30.8 ms (full system, 8000 periods, last 80 s: rho (0.09467, 0.03045)):
//! Spectral, orders 5/7/9: polar fixed point rho_1 0.1008/0.0992/0.0996, theta's first
//! harmonic on it 0.0961/0.0944/0.0948; Observable: 0.0953/0.09467/0.09472 (= the first
//! harmonic); reduced map iterated: the polar fixed point (phase averaging exact: no
//! non-structural term kept); Taylor map iterated: 0.09470/0.09471/0.09471 at every order.

use furuta::bifurcations::RHO_MAX;
use furuta::equation_ssm::{polynomial_map, scene_period_map};
use furuta::full_system::{AMP_WINDOW_S, torus_full};
use furuta::parametric::exact_modes;
use nalgebra::Complex;
use sim::scene::SceneBuilder;
use sim::taylor::FlowOptions;
use ssm::map_ssm::{Amplitude, MapSsmOptions, map_ssm};
use ssm::portrait::{PointKind, PortraitOptions, fixed_points};
use ssm::spectrum::{band_peak, mode_amplitudes};

type C = Complex<f64>;

/// `torus_full`'s measurement on a series `x` sampled at `dt` (s): peak frequencies and the
/// mean sliding first-harmonic amplitudes.
fn measure(x: &[f64], dt: f64, dt_ms: f64) -> Result<([f64; 2], [f64; 2]), Box<dyn std::error::Error>> {
    let lin = exact_modes(dt_ms)?.freqs_hz;
    let split = (lin[0] * lin[1]).sqrt();
    let slow = band_peak(x, dt, 0.0, split).ok_or("no slow peak")?;
    let fast = band_peak(x, dt, split, 0.5 / dt).ok_or("no fast peak")?;
    let f = [slow.freq_hz, fast.freq_hz];
    let amps = mode_amplitudes(x, dt, f, AMP_WINDOW_S)?;
    let k = amps.len() as f64;
    Ok((f, [amps.iter().map(|a| a.1[0]).sum::<f64>() / k, amps.iter().map(|a| a.1[1]).sum::<f64>() / k]))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--embed") {
        // The data-driven chart on a torus: a delay embedding of `p` samples of a pure tone
        // at frequency f (|lambda| = 1), projected onto the span of the linear modes'
        // embeddings and read in modal coordinates: |[E^+ e(lambda)]_j| (1 at the linear
        // multiplier itself). Args: dt_ms p f1_hz f2_hz.
        let v: Vec<f64> = args[1..].iter().map(|s| s.parse()).collect::<Result<_, _>>()?;
        let (dt_ms, p, f) = (v[0], v[1] as usize, [v[2], v[3]]);
        let scene = SceneBuilder::load("furuta-dt30.5")?.dt_ms(dt_ms).build()?;
        let pm = scene_period_map(&scene, 3, &FlowOptions::default())?;
        let map = polynomial_map(&pm);
        let mut observable = vec![0.0; pm.dim()];
        observable[pm.primary] = 1.0;
        let s = map_ssm(
            &map,
            &MapSsmOptions {
                order: 3,
                pairs: 2,
                resonance_tol: 1e-3,
                observable,
                dt: pm.dt,
                amplitude: Amplitude::Observable,
            },
        )?;
        let mu: Vec<C> = s.multipliers.iter().map(|&(re, im)| C::new(re, im)).collect();
        for forward in [true, false] {
            let e = |l: C| -> nalgebra::DVector<C> {
                nalgebra::DVector::from_fn(p, |k, _| if forward { l.powu(k as u32) } else { l.powi(-(k as i32)) })
            };
            let emat = nalgebra::DMatrix::from_fn(p, 4, |k, j| e(mu[j])[k]);
            let pinv = emat.clone().pseudo_inverse(1e-14)?;
            for j in 0..2 {
                let lam = C::from_polar(1.0, std::f64::consts::TAU * f[j] * pm.dt);
                let q = &pinv * e(lam);
                let ql = &pinv * e(mu[2 * j]);
                println!(
                    "{} embedding p = {p}: mode {} linear f {:.4} Hz |mu| {:.5}; at f = {} Hz: |q_j| = {:.5} (at mu: {:.5})",
                    if forward { "forward" } else { "backward" },
                    j + 1,
                    mu[2 * j].arg() / (std::f64::consts::TAU * pm.dt),
                    mu[2 * j].norm(),
                    f[j],
                    q[2 * j].norm(),
                    ql[2 * j].norm()
                );
            }
        }
        return Ok(());
    }
    if args.first().map(String::as_str) == Some("--table") {
        // Polar coefficients of both normalizations at each dt in the rest of the args.
        args.remove(0);
        for a in &args {
            let dt_ms: f64 = a.parse()?;
            let scene = SceneBuilder::load("furuta-dt30.5")?.dt_ms(dt_ms).build()?;
            let pm = scene_period_map(&scene, 7, &FlowOptions::default())?;
            let map = polynomial_map(&pm);
            let mut observable = vec![0.0; pm.dim()];
            observable[pm.primary] = 1.0;
            let t: Vec<_> = [Amplitude::Spectral, Amplitude::Observable]
                .into_iter()
                .map(|amplitude| {
                    map_ssm(
                        &map,
                        &MapSsmOptions {
                            order: 7,
                            pairs: 2,
                            resonance_tol: 1e-3,
                            observable: observable.clone(),
                            dt: pm.dt,
                            amplitude,
                        },
                    )
                    .map(|s| s.polar.table())
                })
                .collect::<Result<_, _>>()?;
            for (a, b) in t[0].rows.iter().zip(&t[1].rows) {
                println!(
                    "{dt_ms} rho_{}' {:<18} spectral {:>12.5} observable {:>12.5}",
                    a.mode, a.monomial, a.value, b.value
                );
            }
        }
        return Ok(());
    }
    let dt_ms: f64 = args.first().map(|s| s.parse()).transpose()?.unwrap_or(30.8);
    let orders: Vec<u32> =
        if args.len() > 1 { args[1..].iter().map(|s| s.parse()).collect::<Result<_, _>>()? } else { vec![5, 7, 9] };
    let scene = SceneBuilder::load("furuta-dt30.5")?.dt_ms(dt_ms).build()?;
    let (periods, tail_s) = (8000usize, 80.0);
    let tf = torus_full(dt_ms, &([0.05, 0.0, 0.0, 0.0], None), periods as u64, tail_s)?;
    println!("full system at {dt_ms} ms: rho {:.5?}, freqs {:.4?} Hz", tf.rho, tf.freqs_hz);
    for (order, amplitude) in orders.iter().flat_map(|&k| [(k, Amplitude::Spectral), (k, Amplitude::Observable)]) {
        let pm = scene_period_map(&scene, order, &FlowOptions::default())?;
        let map = polynomial_map(&pm);
        let p = pm.primary;
        let mut observable = vec![0.0; pm.dim()];
        observable[p] = 1.0;
        let s =
            map_ssm(&map, &MapSsmOptions { order, pairs: 2, resonance_tol: 1e-3, observable, dt: pm.dt, amplitude })?;
        let popts = PortraitOptions { rho_max: RHO_MAX, ..PortraitOptions::default() };
        let Some(t) = fixed_points(&s.polar, &popts)?.into_iter().find(|f| f.kind == PointKind::Torus2) else {
            println!("order {order} ({amplitude:?}): no 2-torus");
            continue;
        };
        println!("order {order} ({amplitude:?}): polar fixed point rho {:.5?}, freqs {:.4?} Hz", t.rho, t.freqs_hz);
        // Exact first harmonic of c . W(z) on the torus |z_j| = rho_j: the sum over the
        // structural monomials z_j |z_1|^2a |z_2|^2b of their theta coefficients.
        let mut h = [C::new(0.0, 0.0); 2];
        for (k, e) in s.exps.iter().enumerate() {
            for j in 0..2 {
                let sign_ok = (0..2).all(|l| e[2 * l] as i64 - e[2 * l + 1] as i64 == if l == j { 1 } else { 0 });
                if sign_ok {
                    let mag: f64 = (0..2).map(|l| t.rho[l].powi((e[2 * l] + e[2 * l + 1]) as i32)).product();
                    let (re, im) = s.w[p][k];
                    h[j] += C::new(re, im) * mag;
                }
            }
        }
        println!(
            "  (a) first harmonic of theta = c.W(z) on the polar torus: [{:.5}, {:.5}]",
            2.0 * h[0].norm(),
            2.0 * h[1].norm()
        );
        // (a') the same by the sliding measurement, on the reduced map's orbit.
        let z0 = [C::from_polar(t.rho[0], 0.0), C::from_polar(t.rho[1], 0.0)];
        let mut z = vec![z0[0], z0[0].conj(), z0[1], z0[1].conj()];
        let mut theta_w = Vec::with_capacity(periods);
        let mut amp_r = [0.0; 2];
        for _ in 0..periods {
            theta_w.push(s.manifold_at(&z, order)[p].re);
            z = s.reduced_at(&z, order);
            amp_r[0] += z[0].norm() / periods as f64;
            amp_r[1] += z[2].norm() / periods as f64;
        }
        let n_tail = (tail_s / pm.dt).round() as usize;
        let (f, m) = measure(&theta_w[theta_w.len() - n_tail..], pm.dt, dt_ms)?;
        println!(
            "  (b) reduced map R iterated: mean |z| [{:.5}, {:.5}]; theta = c.W(z) measured: rho [{:.5}, {:.5}], freqs {:.4?}",
            amp_r[0], amp_r[1], m[0], m[1], f
        );
        // (c) the Taylor period map iterated from W(z0).
        let mut x: Vec<f64> =
            s.manifold_at(&[z0[0], z0[0].conj(), z0[1], z0[1].conj()], order).iter().map(|c| c.re).collect();
        let mut theta_f = Vec::with_capacity(periods);
        let mut ok = true;
        for _ in 0..periods {
            theta_f.push(x[p]);
            x = pm.eval(&x)?;
            if !x[p].is_finite() || x[p].abs() > 1.0 {
                ok = false;
                break;
            }
        }
        if ok {
            let (f, m) = measure(&theta_f[theta_f.len() - n_tail..], pm.dt, dt_ms)?;
            println!("  (c) Taylor map F (order {order}) iterated: rho [{:.5}, {:.5}], freqs {:.4?}", m[0], m[1], f);
        } else {
            println!("  (c) Taylor map F (order {order}) iterated: escaped");
        }
    }
    Ok(())
}
