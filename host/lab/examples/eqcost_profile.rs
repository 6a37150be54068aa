//! Cost split of the equation-driven report tasks (profiling aid; prints, not a test).
//! `cargo run --release -p lab --example eqcost_profile -- [all|expand|ssm|bif|models] [dt...]`
use std::time::Instant;

use furuta::equation_ssm::{
    EquationModel, equation_bifurcations, furuta_equation_polar, furuta_equation_ssm, scene_period_map,
};
use sim::taylor::FlowOptions;
use ssm::interp::Interp;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let what = args.first().map(String::as_str).unwrap_or("all");
    let t = Instant::now();
    if what == "expand" || what == "all" {
        for order in [5, 7, 9] {
            let t0 = Instant::now();
            let scene = furuta::full_system::scene_at(31.0)?;
            let pm = scene_period_map(&scene, order, &FlowOptions::default())?;
            eprintln!("expand order {order}: {:.3} s, {} steps", t0.elapsed().as_secs_f64(), pm.flow.steps);
        }
    }
    if what == "ssm" || what == "all" {
        for order in [5, 7, 9] {
            let t0 = Instant::now();
            let e = furuta_equation_ssm(31.0, order)?;
            eprintln!(
                "equation_ssm order {order}: {:.3} s total (expansion {:.3}, ssm {:.3})",
                t0.elapsed().as_secs_f64(),
                e.expansion_seconds,
                e.ssm_seconds
            );
        }
    }
    if what == "bif" || what == "all" {
        for order in [5, 7] {
            let nodes: Vec<f64> = (0..=8).map(|k| 30.5 + 0.25 * k as f64).collect();
            let t0 = Instant::now();
            let m = EquationModel::furuta(&nodes, order)?;
            let t1 = Instant::now();
            let b = equation_bifurcations(&m, Interp::Spline)?;
            eprintln!(
                "order {order}: model {:.3} s, bifurcations {:.3} s: het {:?} hopf {:?} sw {:?}",
                (t1 - t0).as_secs_f64(),
                t1.elapsed().as_secs_f64(),
                b.heteroclinic.map(|h| h.dt),
                b.hopf.map(|h| h.dt),
                b.small_start_switch
            );
        }
    }
    if what == "hash" {
        // Bits of the period maps and polar forms: compare before/after a change.
        for dt in [31.0, 31.3, 32.25] {
            for order in [5, 7, 9] {
                let t0 = Instant::now();
                let scene = furuta::full_system::scene_at(dt)?;
                let pm = scene_period_map(&scene, order, &FlowOptions::default())?;
                let mut h = 0xcbf29ce484222325u64;
                let eat = |h: &mut u64, x: f64| {
                    *h ^= x.to_bits();
                    *h = h.wrapping_mul(0x100000001b3);
                };
                pm.coef.iter().flatten().for_each(|&x| eat(&mut h, x));
                pm.linear.iter().for_each(|&x| eat(&mut h, x));
                pm.flow.outputs.iter().flatten().for_each(|&x| eat(&mut h, x));
                let hp = h;
                let nf = furuta_equation_polar(dt, order)?;
                nf.amp.iter().flatten().for_each(|&x| eat(&mut h, x));
                let e = furuta_equation_ssm(dt, order)?;
                e.invariance.iter().for_each(|v| eat(&mut h, v.abs));
                let zeros = (0..=order)
                    .map(|d| pm.flow.outputs.iter().all(|c| c[pm.flow.table.degree_range(d)].iter().all(|&v| v == 0.0)))
                    .collect::<Vec<_>>();
                println!(
                    "dt {dt} order {order}: map {hp:016x} all {h:016x} ({:.2} s) zero degrees {zeros:?}",
                    t0.elapsed().as_secs_f64()
                );
            }
        }
    }
    if what == "basin" {
        // model_basin (prepared field) against a trajectory per start (the former path):
        // same points and fates, bit for bit, and the time of each.
        use ssm::portrait::{PortraitOptions, PreparedField, trajectory};
        let popts = PortraitOptions { rho_max: furuta::bifurcations::RHO_MAX, ..PortraitOptions::default() };
        let classify =
            PortraitOptions { ray_samples: 0, flow_grid: 0, converge_tol: 1e-6, manifold_eps: 1e-5, ..popts };
        let bopts = furuta::basin::BasinOptions::quick();
        let (r1, r2) = bopts.values();
        for dt in [31.3, 31.5] {
            let nf = furuta_equation_polar(dt, 7)?;
            let starts: Vec<[f64; 2]> = r1.iter().flat_map(|&a| r2.iter().map(move |&b| [a, b])).collect();
            let t0 = Instant::now();
            let old: Vec<_> =
                starts.iter().map(|&r| trajectory(&nf, r, 2000.0, &classify)).collect::<Result<_, _>>()?;
            let t1 = Instant::now();
            let field = PreparedField::new(&nf, &classify)?;
            let new: Vec<_> = starts.iter().map(|&r| field.trajectory(r, 2000.0)).collect::<Result<_, _>>()?;
            let t2 = Instant::now();
            let same = old.iter().zip(&new).all(|((p, f), (q, g))| {
                f == g
                    && p.len() == q.len()
                    && p.iter().zip(q).all(|(a, b)| a.0.to_bits() == b.0.to_bits() && a.1.to_bits() == b.1.to_bits())
            });
            let mb = furuta::basin::model_basin(
                &nf,
                ssm::portrait::PointKind::Torus2,
                &r1,
                &r2,
                bopts.periods as f64 * dt * 1e-3,
                2000.0,
                &classify,
            )?;
            println!(
                "basin {dt}: {} starts, per-start trajectory {:.3} s, prepared {:.3} s, bit-identical {same}; model_basin {:.3} s, principal {}",
                starts.len(),
                (t1 - t0).as_secs_f64(),
                (t2 - t1).as_secs_f64(),
                t2.elapsed().as_secs_f64(),
                mb.asymptotic.iter().filter(|f| **f == furuta::basin::ModelFate::Principal).count()
            );
        }
    }
    if what == "report" {
        // The full report's expansions and SSMs of global/equation and global/equation-map
        // (nodes 30.5..32.5 by 0.25 ms; the order-9 diagnostics first, then the order-5 and
        // -7 models, then the reduced-map families): time the process with /usr/bin/time.
        use furuta::equation_map::{EquationMapFamily, MapStyle};
        use rayon::prelude::*;
        let nodes: Vec<f64> = (0..=8).map(|k| 30.5 + 0.25 * k as f64).collect();
        let t0 = Instant::now();
        let diag = nodes.par_iter().map(|&dt| furuta_equation_ssm(dt, 9)).collect::<Result<Vec<_>, _>>()?;
        let t1 = Instant::now();
        let models = [5u32, 7].par_iter().map(|&o| EquationModel::furuta(&nodes, o)).collect::<Result<Vec<_>, _>>()?;
        let t2 = Instant::now();
        let jobs = [(5u32, MapStyle::Graph), (7, MapStyle::Graph), (9, MapStyle::Graph), (7, MapStyle::NormalForm)];
        let fams = jobs
            .par_iter()
            .map(|&(o, st)| EquationMapFamily::furuta_styled(&nodes, o, st))
            .collect::<Result<Vec<_>, _>>()?;
        eprintln!(
            "report: diag (order 9) {:.2} s, models 5/7 {:.2} s, map families {:.2} s wall; {} + {} + {} results",
            (t1 - t0).as_secs_f64(),
            (t2 - t1).as_secs_f64(),
            t2.elapsed().as_secs_f64(),
            diag.len(),
            models.len(),
            fams.len()
        );
    }
    if what == "models" {
        for dt in [31.3, 31.4] {
            let t0 = Instant::now();
            let nf = furuta_equation_polar(dt, 7)?;
            eprintln!("polar {dt} order 7: {:.3} s ({} terms)", t0.elapsed().as_secs_f64(), nf.pexps.len());
        }
    }
    eprintln!("total {:.3} s", t.elapsed().as_secs_f64());
    Ok(())
}
