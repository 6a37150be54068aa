//! The equation-driven SSM's polar coefficients next to the data-driven parametric model's
//! (default training options), with timings and invariance errors by order. Prints; not a
//! test. Run: `cargo run --profile test -p furuta --example equation_ssm -- 7 31.0 31.5`
//! (`--equation-only` first skips training the data-driven model).

use furuta::equation_ssm::furuta_equation_ssm;
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
        for inv in &e.invariance {
            println!("invariance order {}: abs {:.3e}, rel {:.3e} (radius {})", inv.order, inv.abs, inv.rel, inv.radius);
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
