//! The report's verdict on the Furuta microchaos (docs/decisions/0002): the numbers come from
//! [`chaos_study::verdict`]; this writes the subsection and the `summary.json` key
//! `microchaos_verdict`.

use std::error::Error;

use chaos_study::verdict::{MicrochaosVerdictSummary, VerdictOptions, microchaos_verdict};
use serde_json::json;

use crate::report::prose::Prose;
use crate::report::{Report, esc, num};

/// The data FSLE's slope of ln lambda against ln delta for chaos and for diffusion (theory).
const FSLE_SLOPE_CHAOS: f64 = 0.0;
const FSLE_SLOPE_DIFFUSION: f64 = -2.0;

/// The introduction over the setup (the options, the scenes and the theory's slopes).
const INTRO: &str = "The quantized loop at the paper's settings ({{ quantized }}, {{ dt_ms | num }} ms) against its \
    smooth twin ({{ smooth }}, no quantization) and its noisy twin ({{ noisy }}). The period map's own tangent (the \
    quantizer's derivative is zero almost everywhere: only the open-loop flow acts), the tangent of the smooth closed loop \
    along the quantized orbit, twin runs started {{ options.twin_deltas | first | sci(0) }}..{{ options.twin_deltas | last \
    | sci(0) }} rad apart read as finite-size Lyapunov exponents lambda(delta) = ln(r) / mean passage time from delta to \
    r delta (separation in theta, dt theta', dt phi'), and on theta series: the 0-1 test (correlation method, median K \
    over {{ options.zero_one_c }} random c, coarsened to the autocorrelation's first zero), data FSLE (slope of ln lambda \
    vs ln delta: {{ fsle_slope.chaos | num }} for chaos, {{ fsle_slope.diffusion | num }} for diffusion) and IAAFT \
    surrogates (prediction error, time reversal; rank p-values).";

/// The subsection "Is the quantized loop chaotic?" and the summary key `microchaos_verdict`.
/// Reads the third PIL recording (the chaos section's held-out run) when present; the
/// reduced models' exponents come from the chaos section's summary when it ran before.
pub fn microchaos_verdict_section(rep: &mut Report, quick: bool) -> Result<(), Box<dyn Error>> {
    let o = if quick { VerdictOptions::quick() } else { VerdictOptions::full() };
    let [quantized, smooth, noisy] = chaos_study::verdict::SCENES;
    let dt_ms = sim::scene::Scene::load(quantized, &[])?.controller.dt_ms;
    let setup = json!({
        "options": &o, "dt_ms": dt_ms, "quantized": quantized, "smooth": smooth, "noisy": noisy,
        "fsle_slope": {"chaos": FSLE_SLOPE_CHAOS, "diffusion": FSLE_SLOPE_DIFFUSION},
    });
    rep.section(
        "chaos-verdict",
        "Is the quantized loop chaotic? Tests that tell chaos from noise-driven diffusion",
        &Prose::new().html("chaos-verdict/intro", INTRO, &setup)?,
    );
    let pil_file = std::path::Path::new(crate::report::chaos::PIL_RECORD_DIR).join("run3/record.csv");
    let pil = if pil_file.is_file() { Some(crate::report::chaos::pil_plant_theta(&pil_file)?) } else { None };
    let v = microchaos_verdict(pil.as_ref(), &o)?;
    rep.para(&esc(&v.verdict));
    rep.para(&format!("Noisy data: {}.", esc(&v.noisy_source)));
    let pm = &v.period_map;
    rep.table(
        &["exponent [1/s]", "value"],
        &[
            vec!["open-loop ZOH map at the equilibrium, ln rho(Phi)/dt".into(), num(pm.open_loop_rate)],
            vec![
                format!("quantized period map's tangent (Q' = 0) along {} periods", pm.periods),
                num(pm.quantized_tangent),
            ],
            vec![
                "linearized smooth closed loop at the equilibrium, ln rho(M)/dt".into(),
                num(pm.linear_closed_loop_rate),
            ],
            vec![
                "smooth closed loop's tangent along the quantized orbit (3 leading, QR)".into(),
                pm.smooth_tangent.iter().map(|v| num(*v)).collect::<Vec<_>>().join(", "),
            ],
            vec!["twin FSLE below h/100 (noise-free quantized)".into(), v.rate_below_step.map_or("-".into(), num)],
            vec![
                format!(
                    "twin FSLE over the attractor's scales {:.1e}..{:.1e} rad: mean / slope",
                    v.attractor_scales.0, v.attractor_scales.1
                ),
                format!("{} / {}", v.attractor_rate.map_or("-".into(), num), v.attractor_slope.map_or("-".into(), num)),
            ],
        ],
    );
    let opt = |r: Option<&chaos::FsleRow>| r.map_or("-".to_string(), |r| r.lambda.map_or("jump (0 s)".into(), num));
    let rows: Vec<Vec<String>> = v
        .twins
        .fsle
        .iter()
        .map(|r| {
            let noisy = v.twins_noisy.fsle.iter().find(|n| n.delta == r.delta);
            vec![
                format!("{:.2e}", r.delta),
                opt(Some(r)),
                r.pairs.to_string(),
                opt(noisy),
                noisy.map_or("-".into(), |n| n.pairs.to_string()),
            ]
        })
        .collect();
    rep.para(&format!(
        "Twin FSLE by scale ({} starts on the attractor, {} periods each, initial separations {}): noise-free quantized loop, and the noisy loop with both twins \
         driven by the same noise sequence. \"jump\": the band was crossed within one period (a count flip).",
        v.twins.starts,
        v.twins.periods,
        v.twins.deltas0.iter().map(|d| format!("{d:.0e}")).collect::<Vec<_>>().join(", ")
    ));
    rep.table(&["delta [rad]", "lambda [1/s]", "pairs", "lambda noisy [1/s]", "pairs noisy"], &rows);
    let srows: Vec<Vec<String>> = v
        .series
        .iter()
        .map(|s| {
            vec![
                esc(&s.name),
                format!("{} (stride {})", num(s.zero_one.k), s.zero_one.stride),
                s.fsle_slope.map_or("-".into(), num),
                s.fsle
                    .iter()
                    .filter_map(|r| r.lambda.map(|l| format!("{:.3}: {}", r.delta, num(l))))
                    .collect::<Vec<_>>()
                    .join("; "),
                format!(
                    "{} ({} vs {}..{})",
                    num(s.surrogate_prediction.p_value),
                    num(s.surrogate_prediction.statistic_data),
                    num(min(&s.surrogate_prediction.statistic_surrogates)),
                    num(max(&s.surrogate_prediction.statistic_surrogates))
                ),
                num(s.surrogate_time_reversal.p_value),
            ]
        })
        .collect();
    rep.table(
        &[
            "series",
            "0-1 test K",
            "data FSLE slope",
            "data FSLE delta [rad]: lambda [1/s]",
            "surrogates: prediction error p (data vs surrogates)",
            "time reversal p",
        ],
        &srows,
    );
    // What the smooth reduced models of the chaos section did on the same loop.
    let models = rep.summary.get("chaos").and_then(|c| c.get("simulated: furuta-quant-dt25 (theta)")).map(|c| {
        let g = |k: &str| c.get(k).cloned().unwrap_or(serde_json::Value::Null);
        json!({
            "lle_model_rbf_benettin": g("lle_model_rbf_benettin"),
            "lle_model_poly_benettin": g("lle_model_poly_benettin"),
            "lle_data_rosenstein": g("lle_data"),
            "lle_model_rbf_kicked": g("lle_model_rbf_kicked"),
            "pdf_divergence_rbf_kicked": g("pdf_divergence_rbf_kicked"),
        })
    });
    if let Some(m) = &models {
        let f = |k: &str| m[k].as_f64().map_or("-".to_string(), num);
        rep.para(&format!(
            "Reduced models of the same loop (chaos section): Benettin exponent of the smooth RBF map {} 1/s, polynomial {} 1/s (their own attractors are tori), \
             against {:.2} 1/s below a count and {} 1/s at the attractor's scale here; the residual-kicked RBF model gives a time-series (Rosenstein) exponent of {} 1/s \
             (data {} 1/s) with PDF divergence {} bits: the kicks, not the smooth map, carry the separation.",
            f("lle_model_rbf_benettin"),
            f("lle_model_poly_benettin"),
            pm.quantized_tangent,
            v.attractor_rate.map_or("-".into(), num),
            f("lle_model_rbf_kicked"),
            f("lle_data_rosenstein"),
            f("pdf_divergence_rbf_kicked")
        ));
    }
    let mut summary = serde_json::to_value(MicrochaosVerdictSummary::from(&v))?;
    if let (Some(obj), Some(m)) = (summary.as_object_mut(), models) {
        obj.insert("reduced_models".into(), m);
    }
    rep.summary.insert("microchaos_verdict".into(), summary);
    Ok(())
}

fn min(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::prose::{perturbed, unmoved};

    /// Every number of the introduction comes from the options, the scene or the theory's
    /// slopes: with all of them moved, every number of the text moves.
    #[test]
    fn intro_numbers_follow_the_setup() {
        let setup = json!({
            "options": VerdictOptions::quick(), "dt_ms": 25.0, "quantized": "q", "smooth": "s", "noisy": "n",
            "fsle_slope": {"chaos": FSLE_SLOPE_CHAOS, "diffusion": FSLE_SLOPE_DIFFUSION},
        });
        let p = Prose::new();
        let a = p.html("chaos-verdict/intro", INTRO, &setup).unwrap();
        assert!(
            a.contains("(q, 25 ms)") && a.contains("started 1e-9..1e-3 rad apart") && a.contains("-2 for diffusion")
        );
        let b = p.html("chaos-verdict/intro", INTRO, &perturbed(&setup)).unwrap();
        assert_eq!(unmoved(&a, &b).unwrap(), [], "{a}\n{b}");
    }
}
