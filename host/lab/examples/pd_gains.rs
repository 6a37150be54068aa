//! PD gains for every measured coordinate of a scene from a discrete LQR of its sampled,
//! delayed linearization. Prints; not a test.
//! Run: `cargo run --profile test -p lab --example pd_gains -- SCENE W1,W2,...` with one
//! state weight per plant state (q1, q1_dot, q2, q2_dot, ...: Bryson's rule, 1/max^2).
//!
//! The plant's exact ZOH discretization `x+ = Phi x + Gamma u` is augmented with the `r`
//! inputs in flight (the law's delay): `v_k = u_{k+r}` is decided from `x_k`. The LQR of
//! that system (cost `x'Qx + rho v^2`, the Riccati equation iterated to convergence) gives
//! `v_k = -K_x x_k - K_buf (inputs in flight)`; the PD law keeps `K_x` (p_i on q_i, d_i on
//! dq_i/dt, read `r` samples late with the velocity as a backward difference) and drops the
//! in-flight terms, which it cannot read. That projection is not optimal, so `rho` is scanned
//! over a log grid and each candidate is judged by the exact spectral radius of the delayed
//! PD loop (`sim::linear`, the `stability` command's computation). The gains are printed to
//! four significant digits, as the scene takes them, with the radius of those rounded gains.

use nalgebra::{DMatrix, DVector};
use sim::linear::spectral_radius;
use sim::scene::Scene;
use sim::stability::linear_plant;

/// rho, the loop's spectral radius and the (p, d) of each measured coordinate.
type Candidate = (f64, f64, Vec<(f64, f64)>);

/// Solves the discrete algebraic Riccati equation by fixed-point iteration; the gain `K`.
fn dlqr(a: &DMatrix<f64>, b: &DVector<f64>, q: &DMatrix<f64>, rho: f64) -> Option<DVector<f64>> {
    let mut p = q.clone();
    for _ in 0..200_000 {
        let bp = b.transpose() * &p;
        let s = rho + (&bp * b)[(0, 0)];
        let k = (&bp * a) / s;
        let next = q + a.transpose() * &p * a - (a.transpose() * &p * b) * &k;
        let next = (&next + next.transpose()) * 0.5;
        let change = (&next - &p).norm() / next.norm().max(1e-300);
        p = next;
        if change < 1e-13 {
            let bp = b.transpose() * &p;
            let s = rho + (&bp * b)[(0, 0)];
            return Some(((&bp * a) / s).transpose().column(0).into_owned());
        }
        if !p.iter().all(|v| v.is_finite()) {
            return None;
        }
    }
    None
}

/// `x` to four significant digits.
fn sig4(x: f64) -> f64 {
    if x == 0.0 {
        return 0.0;
    }
    let e = 10f64.powi(3 - x.abs().log10().floor() as i32);
    (x * e).round() / e
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene_name, weights] = args.as_slice() else {
        return Err("usage: pd_gains SCENE W1,W2,... (one weight per plant state)".into());
    };
    let scene = Scene::load(scene_name, &[])?;
    let lp = linear_plant(&scene)?;
    let n = lp.dim();
    let w: Vec<f64> = weights.split(',').map(str::parse).collect::<Result<_, _>>()?;
    if w.len() != n {
        return Err(format!("{} weights for {n} plant states", w.len()).into());
    }
    let cfg0 = scene.controller_config();
    let r = usize::try_from(cfg0.delay)?;
    let zoh = lp.discretize(cfg0.dt)?;
    // z = (x_k, v_{k-r}, ..., v_{k-1}); v_k enters the last slot.
    let m = n + r;
    let mut a = DMatrix::<f64>::zeros(m, m);
    a.view_mut((0, 0), (n, n)).copy_from(&zoh.phi);
    let mut b = DVector::<f64>::zeros(m);
    if r == 0 {
        b.rows_mut(0, n).copy_from(&zoh.gamma);
    } else {
        a.view_mut((0, n), (n, 1)).copy_from(&zoh.gamma);
        for i in 0..r - 1 {
            a[(n + i, n + i + 1)] = 1.0;
        }
        b[m - 1] = 1.0;
    }
    let mut q = DMatrix::<f64>::zeros(m, m);
    for (i, wi) in w.iter().enumerate() {
        q[(i, i)] = *wi;
    }
    let names = scene.coordinate_names();
    println!("scene {} (dt = {} s, delay {r}), {} measured coordinates", scene.name, cfg0.dt, cfg0.gains.len());
    // (rho, spectral radius, (p, d) per measured coordinate) of the best candidate.
    let mut best: Option<Candidate> = None;
    for j in -24..=24 {
        let rho = 10f64.powf(f64::from(j) / 4.0);
        let Some(k) = dlqr(&a, &b, &q, rho) else {
            println!("rho = {rho:.3e}: Riccati iteration did not converge");
            continue;
        };
        let mut cfg = cfg0;
        let mut pd = Vec::new();
        for g in cfg.gains.iter_mut() {
            let i = usize::from(g.index);
            g.p = sig4(k[i]);
            g.d = sig4(k[i + 1]);
            pd.push((g.p, g.d));
        }
        let radius = match lp.closed_loop(&cfg).and_then(|c| c.multipliers()) {
            Ok(ms) => spectral_radius(&ms),
            Err(e) => {
                println!("rho = {rho:.3e}: {e}");
                continue;
            }
        };
        println!("rho = {rho:.3e}: spectral radius of the delayed PD loop {radius:.6}");
        if best.as_ref().is_none_or(|b| radius < b.1) {
            best = Some((rho, radius, pd));
        }
    }
    let (rho, radius, pd) = best.ok_or("no rho gave a loop")?;
    println!("best: rho = {rho:.3e}, spectral radius {radius:.6}");
    let entries: Vec<String> = cfg0
        .gains
        .iter()
        .zip(&pd)
        .map(|(g, (p, d))| {
            let name = names.get(usize::from(g.index) / 2).map_or("?", String::as_str);
            format!("{name} = {{ p = {p:?}, d = {d:?} }}")
        })
        .collect();
    println!("gains = {{ {} }}", entries.join(", "));
    Ok(())
}
