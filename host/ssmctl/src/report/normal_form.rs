//! Report section: the Furuta parametric SSM model (paper section 3.1): 4D SSMs with
//! normal-form polar dynamics fitted at the training sampling periods, linearly interpolated
//! in dt, checked against the exact linear multipliers.

use crate::report::{Report, num};
use furuta::parametric::{FurutaOptions, ParametricModel, TrainingRuns, exact_modes, furuta_parametric_from};
use serde_json::{Value, json};
use std::error::Error;

pub const PAPER_DTS: [f64; 6] = [30.8, 31.4, 31.41, 31.55, 31.68, 32.3];

/// Writes the section and returns the fitted parametric model (reused by the bifurcation
/// section) and the training runs it was fitted on: simulated once for the model, the
/// shared-tangent model of the predictions and, unless `quick`, the sensitivity variants
/// (see [`TrainingRuns`]).
pub fn section(rep: &mut Report, quick: bool) -> Result<(ParametricModel, TrainingRuns), Box<dyn Error>> {
    let opts = FurutaOptions::default();
    let variants = if quick { Vec::new() } else { furuta::bifurcations::sensitivity_variants() };
    let sets: Vec<&FurutaOptions> = std::iter::once(&opts).chain(variants.iter().map(|(_, o)| o)).collect();
    let runs = TrainingRuns::simulate(&sets)?;
    let f = &opts.fit;
    rep.section(
        "parametric",
        "Parametric SSM model of the Furuta loop (normal forms)",
        &format!(
            "4D SSMs (delay embedding p = {} of theta, manifold order {}{}, polynomial map of order {}) fitted at dt = {} ms \
             from {} small initial conditions and {} starts on the slow eigenvector each ({}), reduced to the extended normal \
             form in polar coordinates (rho_1 the slow ~0.44 Hz mode, rho_2 the fast ~8.4 Hz mode; amplitudes in radians of \
             theta) and interpolated linearly in dt. Exact reference: ln|mu|/dt of the two dominant multiplier pairs of \
             the exact ZOH map; targets 1 % at training dt, 2 % interpolated.",
            f.embed,
            f.manifold_order,
            if opts.linear_normal {
                " as a graph over the data's own SVD tangent with a degree-1 normal part (the SVD tangent of finite-amplitude \
                 data is tilted against the manifold's tangent at the fixed point; without that part the cubic terms absorb the \
                 tilt, FurutaOptions::linear_normal)"
            } else {
                " as a graph over the data's own SVD tangent (normal part of degrees 2 and up)"
            },
            f.dyn_order,
            opts.dts_ms.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", "),
            opts.initial_states.len(),
            opts.slow_starts.len(),
            f.linear_anchor.map_or("one regression over all pairs".to_string(), |a| format!(
                "linear part fitted to the pairs within {} % of the largest reduced amplitude, the higher orders to all pairs \
                 (`FitOptions::linear_anchor`)",
                100.0 * a
            ))
        ),
    );
    let model = furuta_parametric_from(&opts, &runs)?;
    let mut rows = Vec::new();
    let mut list = Vec::new();
    let mut dts: Vec<(f64, bool)> = opts.dts_ms.iter().map(|d| (*d, true)).collect();
    dts.extend(PAPER_DTS.iter().map(|d| (*d, false)));
    dts.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (dt, training) in dts {
        let [slow, fast] = model.linear_rates_at(dt)?;
        let ex = exact_modes(dt)?;
        let rel = |a: f64, b: f64| 100.0 * (a - b) / b.abs();
        rows.push(vec![
            format!("{dt}"),
            if training { "training".into() } else { "interpolated".into() },
            format!("{fast:+.4}"),
            format!("{:+.4}", ex.rates[1]),
            format!("{:+.2} %", rel(fast, ex.rates[1])),
            format!("{slow:+.4}"),
            format!("{:+.4}", ex.rates[0]),
            format!("{:+.2} %", rel(slow, ex.rates[0])),
        ]);
        list.push(json!({"dt_ms": dt, "training": training, "fast_rate_fit": fast, "fast_rate_exact": ex.rates[1],
                         "slow_rate_fit": slow, "slow_rate_exact": ex.rates[0]}));
    }
    rep.table(&["dt [ms]", "", "fast rate fit", "fast exact", "error", "slow rate fit", "slow exact", "error"], &rows);
    // Coefficient table at the paper's unseen dt.
    let tables: Vec<_> = PAPER_DTS.iter().map(|d| model.coefficients_at(*d)).collect::<Result<_, _>>()?;
    let mut header = vec!["equation".to_string(), "monomial".to_string()];
    header.extend(PAPER_DTS.iter().map(|d| format!("{d} ms")));
    let mut trows = Vec::new();
    let mut tjson = Vec::new();
    if let Some(first) = tables.first() {
        for (i, r) in first.rows.iter().enumerate() {
            let mut row = vec![format!("rho_{}'", r.mode), r.monomial.clone()];
            let vals: Vec<f64> = tables.iter().map(|t| t.rows.get(i).map_or(f64::NAN, |x| x.value)).collect();
            row.extend(vals.iter().map(|v| num(*v)));
            trows.push(row);
            tjson.push(json!({"mode": r.mode, "monomial": r.monomial, "values": vals}));
        }
    }
    rep.para("Normal-form coefficients (polar amplitude equations) at the paper's unseen sampling periods:");
    let h: Vec<&str> = header.iter().map(String::as_str).collect();
    rep.table(&h, &trows);
    rep.summary.insert("linear_nf".into(), Value::Array(list));
    rep.summary.insert("normal_form_table".into(), json!({"dt_ms": PAPER_DTS, "rows": tjson}));
    Ok((model, runs))
}
