//! `ssmctl ssm-equations`: the equation-driven SSM of a scene's sampled-data loop
//! (`furuta::equation_ssm`) as text or JSON.

use furuta::equation_ssm::{EquationSsm, equation_ssm};
use sim::scene::Scene;

/// The JSON document: the polar table, exact rates, invariance errors by order and radius,
/// kept near resonances, divisors, conditioning and timings.
pub fn to_json(e: &EquationSsm) -> serde_json::Value {
    serde_json::json!({
        "scene": e.scene,
        "dt_ms": e.dt_ms,
        "order": e.order,
        "exact_rates": e.exact_rates,
        "exact_freqs_hz": e.exact_freqs_hz,
        "eigenvalues": e.polar.eigenvalues,
        "table": e.table.rows,
        "phase": { "pexps": e.polar.pexps, "coefficients": e.polar.phase },
        "invariance": e.invariance,
        "extra_resonances": e.extra_resonances,
        "resonance_tol": furuta::equation_ssm::RESONANCE_TOL,
        "min_divisor": e.min_divisor,
        "min_complement_divisor": e.min_complement_divisor,
        "order_stats": e.order_stats,
        "flow_steps": e.flow_steps,
        "expansion_seconds": e.expansion_seconds,
        "ssm_seconds": e.ssm_seconds,
    })
}

/// Plain-text summary.
pub fn to_text(e: &EquationSsm) -> String {
    let mut s = format!(
        "{}: dt = {} ms, order {}: expansion {:.2} s ({} RK4 steps), SSM {:.2} s\n",
        e.scene, e.dt_ms, e.order, e.expansion_seconds, e.flow_steps, e.ssm_seconds
    );
    let rates: Vec<String> = match e.exact_rates.as_slice() {
        [slow, fast] => vec![format!("slow {slow:.6} 1/s"), format!("fast {fast:.6} 1/s")],
        rates => rates.iter().enumerate().map(|(i, r)| format!("mode {} {r:.6} 1/s", i + 1)).collect(),
    };
    s.push_str(&format!("exact rates ln|mu|/dt: {}\n", rates.join(", ")));
    s.push_str(&e.table.to_text());
    for inv in &e.invariance {
        s.push_str(&format!(
            "invariance error, order {} on |rho| = {} rad: {:.3e} (relative {:.3e})\n",
            inv.order, inv.radius, inv.abs, inv.rel
        ));
    }
    s.push_str(&format!(
        "smallest divisor removed {:.3e}; near resonances kept (< {:e}): {}\n",
        e.min_divisor,
        furuta::equation_ssm::RESONANCE_TOL,
        e.extra_resonances.len()
    ));
    s
}

/// Computes the equation-driven SSM of `scene` at `order`.
pub fn compute(scene: &Scene, order: u32) -> Result<EquationSsm, furuta::Error> {
    equation_ssm(scene, order)
}
