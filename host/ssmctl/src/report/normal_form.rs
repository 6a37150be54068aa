//! Report section: the Furuta parametric SSM model (paper section 3.1): 4D SSMs with
//! normal-form polar dynamics fitted at the training sampling periods, linearly interpolated
//! in dt, checked against the exact linear multipliers.

use crate::report::Report;
use crate::report::prose::Prose;
use furuta::parametric::{FurutaOptions, ParametricModel, TrainingRuns, exact_modes, furuta_parametric_from};
use serde_json::{Value, json};
use std::error::Error;

pub const PAPER_DTS: [f64; 6] = [30.8, 31.4, 31.41, 31.55, 31.68, 32.3];

/// The accuracy the fitted linear rates aim at, relative to the exact ones: at the training
/// sampling periods and interpolated between them.
pub const RATE_TARGETS: [f64; 2] = [0.01, 0.02];

/// The section's introduction over its setup (the summary entry `parametric_setup`).
pub const INTRO: &str = "4D SSMs (delay embedding p = {{ embed }} of theta, manifold order {{ manifold_order }}\
    {% if linear_normal %} as a graph over the data's own SVD tangent with a degree-1 normal part (the SVD tangent of \
    finite-amplitude data is tilted against the manifold's tangent at the fixed point; without that part the cubic terms \
    absorb the tilt, FurutaOptions::linear_normal){% else %} as a graph over the data's own SVD tangent (normal part of \
    degrees 2 and up){% endif %}, polynomial map of order {{ dyn_order }}) fitted at dt = {{ dts_ms | nums }} ms from \
    {{ initial_states }} small initial conditions and {{ slow_starts }} starts on the slow eigenvector each \
    ({% if linear_anchor is none %}one regression over all pairs{% else %}linear part fitted to the pairs within \
    {{ linear_anchor | pct(0) }} % of the largest reduced amplitude, the higher orders to all pairs \
    (<code>FitOptions::linear_anchor</code>){% endif %}), reduced to the extended normal form in polar coordinates \
    (rho_1 the slow ~{{ modes_hz[0] | fixed(2) }} Hz mode, rho_2 the fast ~{{ modes_hz[1] | fixed(1) }} Hz mode; \
    amplitudes in radians of theta) and interpolated linearly in dt. Exact reference: ln|mu|/dt of the two dominant \
    multiplier pairs of the exact ZOH map; targets {{ targets[0] | pct(0) }} % at training dt, {{ targets[1] | pct(0) }} \
    % interpolated.";

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
    let first = *opts.dts_ms.first().ok_or("FurutaOptions::default has no training dt")?;
    let setup = json!({
        "embed": f.embed, "manifold_order": f.manifold_order, "dyn_order": f.dyn_order,
        "linear_normal": opts.linear_normal, "linear_anchor": f.linear_anchor, "dts_ms": opts.dts_ms,
        "initial_states": opts.initial_states.len(), "slow_starts": opts.slow_starts.len(),
        "modes_hz": exact_modes(first)?.freqs_hz, "targets": RATE_TARGETS,
    });
    rep.summary.insert("parametric_setup".into(), setup);
    let model = furuta_parametric_from(&opts, &runs)?;
    let mut list = Vec::new();
    let mut dts: Vec<(f64, bool)> = opts.dts_ms.iter().map(|d| (*d, true)).collect();
    dts.extend(PAPER_DTS.iter().map(|d| (*d, false)));
    dts.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (dt, training) in dts {
        let [slow, fast] = model.linear_rates_at(dt)?;
        let ex = exact_modes(dt)?;
        let rel = |a: f64, b: f64| 100.0 * (a - b) / b.abs();
        list.push(json!({"dt_ms": dt, "training": training, "fast_rate_fit": fast, "fast_rate_exact": ex.rates[1],
                         "slow_rate_fit": slow, "slow_rate_exact": ex.rates[0],
                         "fast_rate_error_pct": rel(fast, ex.rates[1]), "slow_rate_error_pct": rel(slow, ex.rates[0])}));
    }
    // Coefficient table at the paper's unseen dt.
    let tables: Vec<_> = PAPER_DTS.iter().map(|d| model.coefficients_at(*d)).collect::<Result<_, _>>()?;
    let mut tjson = Vec::new();
    if let Some(first) = tables.first() {
        for (i, r) in first.rows.iter().enumerate() {
            let vals: Vec<f64> = tables.iter().map(|t| t.rows.get(i).map_or(f64::NAN, |x| x.value)).collect();
            tjson.push(json!({"mode": r.mode, "monomial": r.monomial, "values": vals}));
        }
    }
    rep.summary.insert("linear_nf".into(), Value::Array(list));
    rep.summary.insert("normal_form_table".into(), json!({"dt_ms": PAPER_DTS, "rows": tjson}));
    render(rep, &Value::Object(rep.summary.clone()))?;
    Ok((model, runs))
}

/// A row of the rate table (an item of the summary's `linear_nf`): fit, exact and the
/// relative error (%) of each mode's rate.
const RATE_CELLS: [&str; 8] = [
    "{{ dt_ms | plain }}",
    "{% if training %}training{% else %}interpolated{% endif %}",
    "{{ fast_rate_fit | signed(4) }}",
    "{{ fast_rate_exact | signed(4) }}",
    "{{ fast_rate_error_pct | signed(2) }} %",
    "{{ slow_rate_fit | signed(4) }}",
    "{{ slow_rate_exact | signed(4) }}",
    "{{ slow_rate_error_pct | signed(2) }} %",
];

/// Writes the section from the summary `s` (`parametric_setup`, `linear_nf`,
/// `normal_form_table`).
pub fn render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    let setup = s.get("parametric_setup").ok_or("report: summary lacks `parametric_setup`")?;
    rep.section(
        "parametric",
        "Parametric SSM model of the Furuta loop (normal forms)",
        &p.html("parametric/intro", INTRO, setup)?,
    );
    let rates = s["linear_nf"].as_array().ok_or("report: summary lacks the list `linear_nf`")?;
    rep.table(
        &["dt [ms]", "", "fast rate fit", "fast exact", "error", "slow rate fit", "slow exact", "error"],
        &p.rows("parametric/rate", &RATE_CELLS, rates)?,
    );
    let t = &s["normal_form_table"];
    let dts = t["dt_ms"].as_array().ok_or("report: normal_form_table.dt_ms is not a list")?;
    let mut header = vec!["equation".to_string(), "monomial".to_string()];
    for d in dts {
        header.push(p.text("parametric/coef-head", "{{ d | plain }} ms", &json!({ "d": d }))?);
    }
    let mut rows = Vec::new();
    for r in t["rows"].as_array().ok_or("report: normal_form_table.rows is not a list")? {
        let mut row = vec![
            p.text("parametric/coef-eq", "rho_{{ mode }}'", r)?,
            p.text("parametric/coef-mono", "{{ monomial }}", r)?,
        ];
        for v in r["values"].as_array().ok_or("report: normal_form_table.rows[].values is not a list")? {
            row.push(p.text("parametric/coef", "{{ v | num }}", &json!({ "v": v }))?);
        }
        rows.push(row);
    }
    rep.para("Normal-form coefficients (polar amplitude equations) at the paper's unseen sampling periods:");
    let h: Vec<&str> = header.iter().map(String::as_str).collect();
    rep.table(&h, &rows);
    Ok(())
}
