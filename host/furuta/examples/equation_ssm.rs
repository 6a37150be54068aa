//! The equation-driven SSM's polar coefficients next to the data-driven parametric model's
//! (default training options), with timings and invariance errors by order. Prints; not a
//! test. Run: `cargo run --profile test -p furuta --example equation_ssm -- 7 31.0 31.5`
//! (`--equation-only` first skips training the data-driven model).

use furuta::equation_ssm::{furuta_equation_ssm, polynomial_map, scene_period_map};
use nalgebra::Complex;
use sim::closed_loop::{AnyPlant, build_plant};
use sim::ode::Method;
use sim::scene::SceneBuilder;
use sim::taylor::FlowOptions;
use ssm::map_ssm::{MapSsmOptions, map_ssm};

/// Invariance error against the exact (integrated, untruncated) period map, on the sphere
/// of radius `r` (rad of theta), for the truncations of the order-`order` SSM.
fn exact_invariance(dt: f64, order: u32, r: f64) -> Result<Vec<(u32, f64)>, Box<dyn std::error::Error>> {
    let scene = SceneBuilder::load("furuta-dt30.5")?.dt_ms(dt).build()?;
    let AnyPlant::Furuta(plant) = build_plant(&scene)? else { return Err("not a Furuta scene".into()) };
    let pm = scene_period_map(&scene, order, &FlowOptions::default())?;
    let map = polynomial_map(&pm);
    let mut observable = vec![0.0; pm.dim()];
    observable[pm.primary] = 1.0;
    let s = map_ssm(&map, &MapSsmOptions { order, pairs: 2, resonance_tol: 1e-3, observable, dt: pm.dt })?;
    let method = Method::Rodas { rtol: 1e-13, atol: 1e-15 };
    let mut out = Vec::new();
    for k in (3..=order).step_by(2) {
        let mut worst = 0.0f64;
        for a in 0..4 {
            let alpha = (a as f64 + 0.5) / 4.0 * std::f64::consts::FRAC_PI_2;
            for p in 0..16 {
                let (t1, t2) = ((p % 4) as f64 * 1.57, (p / 4) as f64 * 1.57 + 0.3);
                let z1 = Complex::from_polar(r * alpha.cos(), t1);
                let z2 = Complex::from_polar(r * alpha.sin(), t2);
                let z = [z1, z1.conj(), z2, z2.conj()];
                let w: Vec<f64> = s.manifold_at(&z, k).iter().map(|c| c.re).collect();
                let fw = pm.exact(&plant, &w, method)?;
                let wr: Vec<f64> = s.manifold_at(&s.reduced_at(&z, k), k).iter().map(|c| c.re).collect();
                worst = fw.iter().zip(&wr).fold(worst, |m, (x, y)| m.max((x - y).abs()));
            }
        }
        out.push((k, worst));
    }
    Ok(out)
}
use furuta::parametric::{FurutaOptions, furuta_parametric};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let equation_only = args.first().is_some_and(|a| a == "--equation-only");
    if equation_only {
        args.remove(0);
    }
    let order: u32 = args.first().map(|s| s.parse()).transpose()?.unwrap_or(7);
    let dts: Vec<f64> = if args.len() > 1 { args[1..].iter().map(|s| s.parse()).collect::<Result<_, _>>()? } else { vec![31.0, 31.5] };
    let t0 = std::time::Instant::now();
    let pm = if equation_only { None } else { Some(furuta_parametric(&FurutaOptions::default())?) };
    if pm.is_some() {
        println!("data-driven parametric model trained in {:.1} s", t0.elapsed().as_secs_f64());
    }
    for dt in dts {
        let e = furuta_equation_ssm(dt, order)?;
        println!(
            "\n== dt = {dt} ms, order {order}: expansion {:.2} s ({} RK4 steps), SSM {:.2} s; min divisor {:.3e}, min complement divisor {:.3e}, extra resonances {}",
            e.expansion_seconds,
            e.flow_steps,
            e.ssm_seconds,
            e.min_divisor,
            e.min_complement_divisor,
            e.extra_resonances.len()
        );
        for x in &e.extra_resonances {
            println!("kept near resonance: equation {} monomial {:?} coefficient {:?} divisor {:.3e}", x.equation, x.exponents, x.coefficient, x.divisor);
        }
        for inv in &e.invariance {
            println!("invariance order {}: abs {:.3e}, rel {:.3e} (radius {})", inv.order, inv.abs, inv.rel, inv.radius);
        }
        for r in [0.02, 0.05] {
            for (k, err) in exact_invariance(dt, order, r)? {
                println!("invariance against the exact (integrated) map, order {k}, radius {r}: {err:.3e}");
            }
        }
        for s in &e.order_stats {
            println!("order {}: max |W_m| {:.3e}, max |R_m| {:.3e}", s.order, s.w_max, s.r_max);
        }
        println!("exact rates {:?}; equation freqs (rad/s) {:?}", e.exact_rates, e.polar.eigenvalues);
        let dd = match &pm {
            Some(pm) => Some(pm.normal_form_at(dt)?.table()),
            None => None,
        };
        println!("{:<6} {:<22} {:>12} {:>12} {:>9}", "eq", "monomial", "equation", "data", "ratio");
        for r in &e.table.rows {
            let d = dd.as_ref().and_then(|dd| dd.get(r.mode, &r.monomial));
            let ratio = d.map(|d| d / r.value);
            println!(
                "rho_{}' {:<22} {:>12.5} {:>12} {:>9}",
                r.mode,
                r.monomial,
                r.value,
                d.map_or("-".into(), |d| format!("{d:.5}")),
                ratio.map_or("-".into(), |x| format!("{x:.3}"))
            );
        }
    }
    Ok(())
}
