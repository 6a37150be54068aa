//! The equation-driven SSM's polar coefficients next to the data-driven parametric model's
//! (default training options), with timings and invariance errors by order. Prints; not a
//! test. Run: `cargo run --profile test -p lab --example equation_ssm -- 7 31.0 31.5`
//! (`--equation-only` first skips training the data-driven model).
//! `-- --bifurcations 7 9 5` instead prints the equation-driven model's heteroclinic and
//! torus-Hopf values at orders 7, 9, 5 (nodes every 0.25 ms over 30.5-32.5 ms, linear and
//! spline interpolation), each confirmed by a direct scan (no interpolation) on a narrow
//! bracket (`--no-direct` skips that; at order 9 it takes minutes); `--nodes 0.125` sets
//! the node spacing (ms).

use furuta::equation_ssm::{
    EquationModel, equation_bifurcations, equation_bifurcations_with, furuta_equation_ssm, polynomial_map,
    scan_options, scene_period_map,
};
use nalgebra::Complex;
use sim::closed_loop::{AnyPlant, build_plant};
use sim::ode::Method;
use sim::scene::SceneBuilder;
use sim::taylor::FlowOptions;
use ssm::interp::Interp;
use ssm::map_ssm::{Amplitude, MapSsmOptions, map_ssm};
use ssm::portrait::{PortraitOptions, ScanOptions};

/// Invariance error against the exact (integrated, untruncated) period map, on the sphere
/// of radius `r` (rad of theta), for the truncations of the order-`order` SSM.
fn exact_invariance(dt: f64, order: u32, r: f64) -> Result<Vec<(u32, f64)>, Box<dyn std::error::Error>> {
    let scene = SceneBuilder::load("furuta-dt30.5")?.dt_ms(dt).build()?;
    let AnyPlant::Furuta(plant) = build_plant(&scene)? else { return Err("not a Furuta scene".into()) };
    let pm = scene_period_map(&scene, order, &FlowOptions::default())?;
    let map = polynomial_map(&pm);
    let mut observable = vec![0.0; pm.dim()];
    observable[pm.primary] = 1.0;
    let s = map_ssm(
        &map,
        &MapSsmOptions {
            order,
            pairs: 2,
            resonance_tol: 1e-3,
            observable,
            dt: pm.dt,
            amplitude: Amplitude::Observable,
        },
    )?;
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

/// The equation-driven model's bifurcation values at each order in `args`.
fn bifurcations(args: &[String]) -> Result<(), Box<dyn std::error::Error>> {
    let mut step: f64 = 0.25;
    let mut direct = true;
    let mut orders = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--no-direct" {
            direct = false;
        } else if a == "--nodes" {
            step = it.next().ok_or("--nodes needs a spacing (ms)")?.parse()?;
        } else {
            orders.push(a.parse::<u32>()?);
        }
    }
    if orders.is_empty() {
        orders = vec![7];
    }
    let n = ((32.5 - 30.5) / step).round() as usize;
    let nodes: Vec<f64> = (0..=n).map(|k| 30.5 + 2.0 * k as f64 / n as f64).collect();
    println!(
        "data-driven model: saddle connection 31.83 ms, torus Hopf 31.86 ms; full system small-start switch [31.32, 31.34] ms"
    );
    for order in orders {
        let t0 = std::time::Instant::now();
        let model = EquationModel::furuta(&nodes, order)?;
        println!(
            "\n== order {order}: {} nodes every {step} ms, normal forms in {:.1} s",
            nodes.len(),
            t0.elapsed().as_secs_f64()
        );
        // Interpolation error at the midpoints of the first two intervals.
        for k in 0..2.min(nodes.len() - 1) {
            let mid = 0.5 * (nodes[k] + nodes[k + 1]);
            let exact = furuta::equation_ssm::furuta_equation_polar(mid, order)?;
            for interp in [Interp::Linear, Interp::Spline] {
                let nf = model.normal_form_at(mid, interp)?;
                let rel = |a: &Vec<Vec<f64>>, b: &Vec<Vec<f64>>| {
                    a.iter()
                        .flatten()
                        .zip(b.iter().flatten())
                        .map(|(x, y)| (x - y).abs() / y.abs().max(1e-12))
                        .fold(0.0f64, f64::max)
                };
                println!(
                    "  interpolation at {mid:.4} ms ({interp:?}): max rel. error of amplitude coefficients {:.2e}",
                    rel(&nf.amp, &exact.amp)
                );
            }
        }
        // Where the fixed points of the amplitude equations sit (truncation matters most at
        // the saddle cycles' large amplitudes).
        for dt in [31.0, 31.3, 31.6] {
            let o = PortraitOptions { rho_max: furuta::bifurcations::RHO_MAX, ..scan_options().portrait };
            for f in ssm::portrait::fixed_points(&model.normal_form_at(dt, Interp::Spline)?, &o)? {
                println!("  {dt} ms: {:?} at rho = [{:.4}, {:.4}] rad, {:?}", f.kind, f.rho[0], f.rho[1], f.stability);
            }
        }
        for interp in [Interp::Linear, Interp::Spline] {
            let t1 = std::time::Instant::now();
            let b = equation_bifurcations(&model, interp)?;
            println!(
                "  {interp:?}: saddle connection {} ms (saddle {:?}, {:?} -> {:?}), torus Hopf {} ms ({}), torus at 30.8 ms {:?} rad; scans {:.1} s",
                b.heteroclinic.as_ref().map_or("-".into(), |h| format!("{:.4}", h.dt)),
                b.heteroclinic.as_ref().map(|h| h.saddle),
                b.heteroclinic.as_ref().map(|h| h.fate_below),
                b.heteroclinic.as_ref().map(|h| h.fate_above),
                b.hopf.as_ref().map_or("-".into(), |h| format!("{:.4}", h.dt)),
                b.hopf.as_ref().map_or("-".into(), |h| format!(
                    "complex pair {}, {:.3} Hz, loses stability {}",
                    h.complex_pair, h.frequency_hz, h.loses_stability
                )),
                b.torus_30p8.as_ref().map(|t| t.rho),
                t1.elapsed().as_secs_f64()
            );
            println!("  heteroclinic event: {:?}", b.heteroclinic);
            println!("  small-start switch {:?} ms", b.small_start_switch);
            let long = ScanOptions {
                portrait: PortraitOptions { t_max: 50_000.0, max_steps: 2_000_000, ..scan_options().portrait },
                ..scan_options()
            };
            let bl = equation_bifurcations_with(&model, interp, &long)?;
            println!(
                "  t_max 50000 s: saddle connection {:?} (exact hit {:?}), torus Hopf {:?}",
                bl.heteroclinic.as_ref().map(|h| h.bracket),
                bl.heteroclinic.as_ref().map(|h| h.exact_hit),
                bl.hopf.as_ref().map(|h| h.dt)
            );
            if direct && interp == Interp::Spline {
                // Confirm without interpolation on a bracket 0.02 ms wider than both values.
                let t2 = std::time::Instant::now();
                let vals: Vec<f64> = b.heteroclinic.iter().map(|h| h.dt).chain(b.hopf.iter().map(|h| h.dt)).collect();
                if !vals.is_empty() {
                    let lo = vals.iter().copied().fold(f64::INFINITY, f64::min) - 0.02;
                    let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max) + 0.02;
                    let grid = ((hi - lo) / 0.02).ceil() as usize + 1;
                    let (dh, dp) = furuta::equation_ssm::equation_bifurcations_direct(order, lo, hi, grid, 1e-3)?;
                    println!(
                        "  direct (no interpolation) on [{lo:.3}, {hi:.3}] ms: saddle connection {:?} (exact hit {:?}, nearest saddle {:?}), torus Hopf {:?}",
                        dh.as_ref().map(|e| e.bracket),
                        dh.as_ref().map(|e| e.exact_hit),
                        dh.as_ref().and_then(|e| e.nearest_saddle),
                        dp.map(|e| e.bracket)
                    );
                }
                println!("  direct scans {:.1} s", t2.elapsed().as_secs_f64());
            }
        }
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().is_some_and(|a| a == "--bifurcations") {
        return bifurcations(&args[1..]);
    }
    let equation_only = args.first().is_some_and(|a| a == "--equation-only");
    if equation_only {
        args.remove(0);
    }
    let order: u32 = args.first().map(|s| s.parse()).transpose()?.unwrap_or(7);
    let dts: Vec<f64> =
        if args.len() > 1 { args[1..].iter().map(|s| s.parse()).collect::<Result<_, _>>()? } else { vec![31.0, 31.5] };
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
            println!(
                "kept near resonance: equation {} monomial {:?} coefficient {:?} divisor {:.3e}",
                x.equation, x.exponents, x.coefficient, x.divisor
            );
        }
        for inv in &e.invariance {
            println!(
                "invariance order {}: abs {:.3e}, rel {:.3e} (radius {})",
                inv.order, inv.abs, inv.rel, inv.radius
            );
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
