//! The report's verdict on the Furuta microchaos (docs/decisions/0002): the numbers come from
//! [`chaos_study::verdict`]; this writes the subsection and the `summary.json` key
//! `microchaos_verdict`.

use std::error::Error;

use chaos_study::verdict::{MicrochaosVerdictSummary, VerdictOptions, microchaos_verdict};
use serde_json::{Value, json};

use crate::report::prose::Prose;
use crate::report::{Report, esc};

/// The data FSLE's slope of ln lambda against ln delta for chaos and for diffusion (theory).
pub const FSLE_SLOPE_CHAOS: f64 = 0.0;
pub const FSLE_SLOPE_DIFFUSION: f64 = -2.0;

/// The introduction over the setup (the options, the scenes and the theory's slopes).
pub const INTRO: &str = "The quantized loop at the paper's settings ({{ quantized }}, {{ dt_ms | num }} ms) against its \
    smooth twin ({{ smooth }}, no quantization) and its noisy twin ({{ noisy }}). The period map's own tangent (the \
    quantizer's derivative is zero almost everywhere: only the open-loop flow acts), the tangent of the smooth closed loop \
    along the quantized orbit, twin runs started {{ options.twin_deltas | first | sci(0) }}..{{ options.twin_deltas | last \
    | sci(0) }} rad apart read as finite-size Lyapunov exponents lambda(delta) = ln(r) / mean passage time from delta to \
    r delta (separation in theta, dt theta', dt phi'), and on theta series: the 0-1 test (correlation method, median K \
    over {{ options.zero_one_c }} random c, coarsened to the autocorrelation's first zero), data FSLE (slope of ln lambda \
    vs ln delta: {{ fsle_slope.chaos | num }} for chaos, {{ fsle_slope.diffusion | num }} for diffusion) and IAAFT \
    surrogates (prediction error, time reversal; rank p-values).";

/// The conclusion over the summary `v` (`microchaos_verdict`, with its `conclusion` as `c`) and
/// the theory's FSLE slopes (`fsle_slope`); series 0, 1, 2 are the quantized, smooth and noisy
/// loops.
pub const CONCLUSION: &str = "{% macro f2(x) %}{% if x is none %}-{% else %}{{ x | fixed(2) }}{% endif %}{% endmacro %}\
    {% set q = v.series[0] %}{% set sm = v.series[1] %}{% set nz = v.series[2] %}\
    {% if v.chaotic %}The noise-free quantized loop is chaotic in the strict sense (bounded, deterministic, positive \
    exponent), but only below one encoder step.{% else %}The noise-free quantized loop shows no exponential separation \
    that matches the period map's exponent below one encoder step.{% endif %} Below one encoder step (h = \
    {{ c.encoder_step | sci(2) }} rad) twins of the noise-free quantized loop separate at {{ f2(v.rate_below_step) }} \
    1/s, the exponent of the period map's own tangent ({{ v.period_map.quantized_tangent | fixed(2) }} 1/s: the \
    quantizer's derivative is zero almost everywhere, so the tangent is the open-loop flow's, \
    {{ v.period_map.open_loop_rate | fixed(2) }} 1/s at the upright equilibrium) until a count flips; one flip (a DAC \
    kick) takes the separation from ~h/2 to {{ c.separation_after_flip | sci(1) }} rad within a period. At the \
    attractor's scales ({{ v.attractor_scales[0] | sci(1) }}..{{ v.attractor_scales[1] | sci(1) }} rad) the twin rate \
    is {{ f2(v.attractor_rate) }} 1/s on average but falls with the scale (slope of ln lambda vs ln delta \
    {{ f2(v.attractor_slope) }}; data FSLE slope {{ f2(q.fsle_slope) }}, diffusion gives {{ fsle_slope.diffusion | num }}, \
    chaos {{ fsle_slope.chaos | num }}): {% if v.chaotic_at_attractor_scale %}exponential separation at the attractor's \
    scale{% else %}no exponential separation at the attractor's scale: there it is a torus diffused by count-flip \
    kicks, like the noisy loop{% endif %}. 0-1 test K = {{ q.zero_one_k | fixed(2) }} (smooth loop \
    {{ sm.zero_one_k | fixed(2) }}, noisy loop {{ nz.zero_one_k | fixed(2) }}; displacements over \
    {{ c.zero_one_span_s | fixed(0) }} s of data: K reads diffusion, so it rises with the record's length for both the \
    quantized and the noisy loop); IAAFT surrogates reject a linear Gaussian process by prediction error for all three \
    (p = {{ q.surrogate_p_prediction | fixed(3) }}, {{ sm.surrogate_p_prediction | fixed(3) }}, \
    {{ nz.surrogate_p_prediction | fixed(3) }}; the smooth torus too: they show nonlinear determinism, not chaos), time \
    reversal rejects none (p = {{ q.surrogate_p_time_reversal | fixed(2) }}, {{ sm.surrogate_p_time_reversal | fixed(2) }}, \
    {{ nz.surrogate_p_time_reversal | fixed(2) }}). The smooth (unquantized) closed loop's tangent along the quantized \
    orbit has exponents {% for x in v.period_map.smooth_tangent %}{{ x | signed(3) }}{% if not loop.last %}, \
    {% endif %}{% endfor %} 1/s (the orbit stays near the upright equilibrium, where the linearized loop expands at \
    {{ v.period_map.linear_closed_loop_rate | fixed(3) }} 1/s, inside the smooth loop's torus): a smooth reduced model \
    has no open-loop expansion below a count and no kicks, and on its own orbit it settles on the torus; it can carry \
    the attractor-scale torus and, kicked by its residuals, the diffusion, not the sub-step chaos.";

/// The first table: the period map's exponents (summary `microchaos_verdict`, and
/// `page_chaos_verdict` for the count of smooth exponents).
const EXPONENT_ROWS: [[&str; 2]; 6] = [
    ["open-loop ZOH map at the equilibrium, ln rho(Phi)/dt", "{{ v.period_map.open_loop_rate | num }}"],
    [
        "quantized period map's tangent (Q' = 0) along {{ v.period_map.periods }} periods",
        "{{ v.period_map.quantized_tangent | num }}",
    ],
    [
        "linearized smooth closed loop at the equilibrium, ln rho(M)/dt",
        "{{ v.period_map.linear_closed_loop_rate | num }}",
    ],
    [
        "smooth closed loop's tangent along the quantized orbit ({{ page.smooth_exponents }} leading, QR)",
        "{{ v.period_map.smooth_tangent | nums }}",
    ],
    ["twin FSLE below h/100 (noise-free quantized)", "{{ v.rate_below_step | num_or }}"],
    [
        "twin FSLE over the attractor's scales {{ v.attractor_scales[0] | sci(1) }}..{{ v.attractor_scales[1] | sci(1) }} rad: mean / slope",
        "{{ v.attractor_rate | num_or }} / {{ v.attractor_slope | num_or }}",
    ],
];
const TWINS: &str = "Twin FSLE by scale ({{ page.twins.starts }} starts on the attractor, {{ page.twins.periods }} \
    periods each, initial separations {% for d in page.twins.deltas0 %}{{ d | sci(0) }}{% if not loop.last %}, {% endif \
    %}{% endfor %}): noise-free quantized loop, and the noisy loop with both twins driven by the same noise sequence. \
    \"jump\": the band was crossed within one period (a count flip).";
/// A row of the twin table: a band of the noise-free twins and the noisy twins' same band.
const TWIN_CELLS: [&str; 5] = [
    "{{ r.delta | sci(2) }}",
    "{% if r.lambda is none %}jump (0 s){% else %}{{ r.lambda | num }}{% endif %}",
    "{{ r.pairs }}",
    "{% if n is none %}-{% elif n.lambda is none %}jump (0 s){% else %}{{ n.lambda | num }}{% endif %}",
    "{% if n is none %}-{% else %}{{ n.pairs }}{% endif %}",
];
/// A row of the series table (`s` from `microchaos_verdict.series`, `x` from
/// `page_chaos_verdict.series`).
const SERIES_CELLS: [&str; 6] = [
    "{{ s.name }}",
    "{{ s.zero_one_k | num }} (stride {{ x.stride }})",
    "{{ s.fsle_slope | num_or }}",
    "{% for r in s.fsle if r.lambda is not none %}{{ r.delta | fixed(3) }}: {{ r.lambda | num }}{% if not loop.last %}; \
     {% endif %}{% endfor %}",
    "{{ s.surrogate_p_prediction | num }} ({{ x.statistic_data | num }} vs {{ x.statistic_min | num }}..{{ \
     x.statistic_max | num }})",
    "{{ s.surrogate_p_time_reversal | num }}",
];
const MODELS: &str = "Reduced models of the same loop (chaos section): Benettin exponent of the smooth RBF map {{ \
    m.lle_model_rbf_benettin | num_or }} 1/s, polynomial {{ m.lle_model_poly_benettin | num_or }} 1/s (their own \
    attractors are tori), against {{ v.period_map.quantized_tangent | fixed(2) }} 1/s below a count and {{ \
    v.attractor_rate | num_or }} 1/s at the attractor's scale here; the residual-kicked RBF model gives a time-series \
    (Rosenstein) exponent of {{ m.lle_model_rbf_kicked | num_or }} 1/s (data {{ m.lle_data_rosenstein | num_or }} 1/s) \
    with PDF divergence {{ m.pdf_divergence_rbf_kicked | num_or }} bits: the kicks, not the smooth map, carry the \
    separation.";

/// The subsection "Is the quantized loop chaotic?", the summary key `microchaos_verdict` and
/// what else its page reads, `page_chaos_verdict`. Reads the third PIL recording (the chaos
/// section's held-out run) when present; the reduced models' exponents come from the chaos
/// section's summary when it ran before.
pub fn microchaos_verdict_section(rep: &mut Report, quick: bool) -> Result<(), Box<dyn Error>> {
    let o = if quick { VerdictOptions::quick() } else { VerdictOptions::full() };
    let [quantized, smooth, noisy] = chaos_study::verdict::SCENES;
    let dt_ms = sim::scene::Scene::load(quantized, &[])?.controller.dt_ms;
    let setup = json!({
        "options": &o, "dt_ms": dt_ms, "quantized": quantized, "smooth": smooth, "noisy": noisy,
        "fsle_slope": {"chaos": FSLE_SLOPE_CHAOS, "diffusion": FSLE_SLOPE_DIFFUSION},
    });
    let pil_file = std::path::Path::new(crate::report::chaos::PIL_RECORD_DIR).join("run3/record.csv");
    let pil = if pil_file.is_file() { Some(crate::report::chaos::pil_plant_theta(&pil_file)?) } else { None };
    let v = microchaos_verdict(pil.as_ref(), &o)?;
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
    let mut summary = serde_json::to_value(MicrochaosVerdictSummary::from(&v))?;
    if let (Some(obj), Some(m)) = (summary.as_object_mut(), models) {
        obj.insert("reduced_models".into(), m);
    }
    rep.summary.insert("microchaos_verdict".into(), summary);
    let series: Vec<Value> = v
        .series
        .iter()
        .map(|s| {
            let sp = &s.surrogate_prediction;
            json!({"stride": s.zero_one.stride, "statistic_data": sp.statistic_data,
                   "statistic_min": min(&sp.statistic_surrogates), "statistic_max": max(&sp.statistic_surrogates)})
        })
        .collect();
    rep.summary.insert(
        "page_chaos_verdict".into(),
        json!({"setup": setup, "smooth_exponents": v.period_map.smooth_tangent.len(),
               "twins": {"starts": v.twins.starts, "periods": v.twins.periods, "deltas0": v.twins.deltas0},
               "series": series}),
    );
    render(rep, &Value::Object(rep.summary.clone()))
}

/// Writes the subsection from the summary `s` (`microchaos_verdict`, `page_chaos_verdict`).
pub fn render(rep: &mut Report, s: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    let v = s.get("microchaos_verdict").ok_or("report: summary lacks `microchaos_verdict`")?;
    let page = s.get("page_chaos_verdict").ok_or("report: summary lacks `page_chaos_verdict`")?;
    rep.section(
        "chaos-verdict",
        "Is the quantized loop chaotic? Tests that tell chaos from noise-driven diffusion",
        &p.html("chaos-verdict/intro", INTRO, &page["setup"])?,
    );
    let text = |k: &str| v[k].as_str().ok_or(format!("report: microchaos_verdict.{k} is not a string"));
    let values = json!({"v": v, "c": v.get("conclusion"), "fsle_slope": page["setup"]["fsle_slope"]});
    rep.para(&p.html("chaos-verdict/conclusion", CONCLUSION, &values)?);
    rep.para(&format!("Noisy data: {}.", esc(text("noisy_source")?)));
    let vp = json!({"v": v, "page": page});
    let rows: Vec<Vec<String>> = EXPONENT_ROWS
        .iter()
        .map(|cells| cells.iter().map(|c| p.text("chaos-verdict/exponent", c, &vp)).collect())
        .collect::<Result<_, String>>()?;
    rep.table(&["exponent [1/s]", "value"], &rows);
    let list = |k: &str| v[k].as_array().ok_or(format!("report: microchaos_verdict.{k} is not a list"));
    let noisy = list("fsle_twins_noisy")?;
    let items: Vec<Value> = list("fsle_twins")?
        .iter()
        .map(|r| json!({"r": r, "n": noisy.iter().find(|n| n["delta"] == r["delta"])}))
        .collect();
    rep.para(&p.html("chaos-verdict/twins", TWINS, &vp)?);
    rep.table(
        &["delta [rad]", "lambda [1/s]", "pairs", "lambda noisy [1/s]", "pairs noisy"],
        &p.rows("chaos-verdict/twin", &TWIN_CELLS, &items)?,
    );
    let extra = page["series"].as_array().ok_or("report: page_chaos_verdict.series is not a list")?;
    let series = list("series")?;
    if series.len() != extra.len() {
        return Err("report: microchaos_verdict.series and page_chaos_verdict.series differ in length".into());
    }
    let items: Vec<Value> = series.iter().zip(extra).map(|(s, x)| json!({"s": s, "x": x})).collect();
    rep.table(
        &[
            "series",
            "0-1 test K",
            "data FSLE slope",
            "data FSLE delta [rad]: lambda [1/s]",
            "surrogates: prediction error p (data vs surrogates)",
            "time reversal p",
        ],
        &p.rows("chaos-verdict/series", &SERIES_CELLS, &items)?,
    );
    if let Some(m) = v.get("reduced_models") {
        rep.para(&p.html("chaos-verdict/models", MODELS, &json!({"m": m, "v": v}))?);
    }
    Ok(())
}

fn min(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

fn max(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
}
