//! The report's chaos sections: the chaos analysis of the simulated quantized loop, the PIL
//! recordings and the inverted flag (figures and tables), the scale dependence of the
//! time-series exponent and the accuracy-vs-cost table. The numbers come from
//! [`chaos_study::microchaos`] and [`chaos_study::chaos_tables`].

use std::error::Error;

use chaos::{Context, Points};
use chaos_study::chaos_tables::*;
use chaos_study::flag_pipeline::PipelineRow;
use chaos_study::lyapunov::ModelLyapunov;
use chaos_study::microchaos::*;
use chaos_study::study_results::SearchRow;
use ssm::{SsmModel, TimeSeries};

use crate::report::prose::Prose;

/// The chaos section's introduction over the estimators' settings.
pub const INTRO: &str = "Correlation dimension by Grassberger-Procaccia (self-pairs and a Theiler window of one dominant \
    period excluded; scaling range: the longest run of radii whose local slopes stay within \
    {{ scaling_tolerance | pct(0) }} % of their median, error bar = their standard deviation), SSM dimension = smallest \
    even integer above the estimate plus its error bar (the paper's rule); SSMs of that dimension with RBF (linear \
    kernel, {{ centers }} centres) and polynomial map dynamics of order {{ poly_order }}; largest Lyapunov exponent by \
    Rosenstein's estimator with identical settings on data and model series, and of the reduced maps themselves by \
    Benettin's method (analytic Jacobians, QR); mean Jensen-Shannon divergence of the reduced-coordinate PDFs. Models \
    are fitted on the training trajectories; the data statistics come from a held-out trajectory, from whose first \
    point the model series start.";

/// The plant angle `theta_rad` of a PIL `record.csv` (`t_s,theta_rad,phi_rad,theta_meas_rad,
/// code,prediction`). The chaos study uses it rather than the encoder reading `theta.csv`:
/// the reading is quantized to whole counts, so delay vectors tie exactly and the Lyapunov
/// estimators' log-distances are undefined at their first steps.
pub fn pil_plant_theta(path: &std::path::Path) -> Result<TimeSeries, Box<dyn Error>> {
    let text =
        infile::read_text(path, infile::MAX_DATA_BYTES).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let mut lines = text.lines();
    let header = lines.next().ok_or_else(|| format!("{}: empty file", path.display()))?;
    if !header.starts_with("t_s,theta_rad,") {
        return Err(
            format!("{}: header `{header}` is not a PIL record (expected t_s,theta_rad,...)", path.display()).into()
        );
    }
    let (mut t, mut x) = (Vec::new(), Vec::new());
    for (i, l) in lines.enumerate() {
        let mut f = l.split(',');
        let mut num = |what: &str| -> Result<f64, Box<dyn Error>> {
            let v = f.next().ok_or_else(|| format!("{}: line {}: no {what}", path.display(), i + 2))?;
            v.trim().parse::<f64>().map_err(|e| format!("{}: line {}: {what} `{v}`: {e}", path.display(), i + 2).into())
        };
        t.push(num("t_s")?);
        x.push(num("theta_rad")?);
    }
    let name = format!(
        "run {} plant theta",
        path.parent().and_then(|p| p.file_name()).map_or("?".into(), |n| n.to_string_lossy())
    );
    Ok(TimeSeries::new(name, t, x)?)
}

/// Figures of one data set: the PDF of each reduced coordinate (held-out data vs the RBF and
/// polynomial models, on the models' common grids), the attractor projected on
/// `(eta_1, eta_2)`, and the amplitude spectra of the observable. `models` are the ones
/// [`analyse_held_out_runs`] fitted (`"rbf"` / `"poly"`, in that order), `held` their runs over
/// `test` it made (the predictions and the data's reduced coordinates, drawn as they are).
/// Writes the PNGs under `dir` and returns the figures for the page (`path`, `title`, `kind`,
/// and `samples` of the spectra), captioned by `FIGURE_CAPTIONS`.
pub fn chaos_figures(
    dir: &std::path::Path,
    tag: &str,
    title: &str,
    test: &TimeSeries,
    models: &[(&str, SsmModel)],
    held: &[HeldOutRun],
    o: &ChaosOptions,
) -> Result<Vec<serde_json::Value>, Box<dyn Error>> {
    use crate::plot::{Panel, Series, grid};
    let mut figs = Vec::new();
    let fig = |path: &str, kind: &str, samples: Option<usize>| serde_json::json!({ "path": path, "name": title, "kind": kind, "samples": samples });
    use plotters::style::RGBColor;
    let colors = [RGBColor(0, 0, 0), RGBColor(200, 30, 30), RGBColor(30, 90, 200)];
    let dt = test.dt().ok_or("held-out series has no sampling step")?;
    let ctx = Context::from_series(&test.x, dt, o.gp_embed)?;
    if held.len() != models.len() {
        return Err(format!("{tag}: {} model runs for {} models", held.len(), models.len()).into());
    }
    let runs: Vec<(&str, &SsmModel, &ssm::Prediction)> = models
        .iter()
        .zip(held)
        .map(|((kind, m), h)| (if *kind == "rbf" { "RBF model" } else { "polynomial model" }, m, &h.prediction))
        .collect();
    let (Some((_, m0, _)), Some(h0)) = (runs.first(), held.first()) else { return Ok(figs) };
    let d = m0.options.dim;
    // The data's reduced coordinates under the first model (`reduce_series(m0, test)`).
    let eta_data = &h0.eta_data;
    let data_pts = Points::from_flat(d, eta_data.clone())?;
    // PDFs per coordinate.
    let mut pdf_lines: Vec<Vec<Vec<(f64, f64)>>> = vec![Vec::new(); d];
    for (k, (_, _, p)) in runs.iter().enumerate() {
        if p.eta.len() < 2 * d {
            continue;
        }
        let cmp = chaos::compare_pdfs(&data_pts, &Points::from_flat(d, p.eta.clone())?, chaos::Bins::default())?;
        for c in &cmp.coords {
            if k == 0 {
                pdf_lines[c.coord].push(c.centers.iter().copied().zip(c.data_density.iter().copied()).collect());
            }
            pdf_lines[c.coord].push(c.centers.iter().copied().zip(c.model_density.iter().copied()).collect());
        }
    }
    let names: Vec<&str> = std::iter::once("data (held out)").chain(runs.iter().map(|r| r.0)).collect();
    let panels: Vec<Panel<'_>> = pdf_lines
        .iter()
        .enumerate()
        .filter(|(_, l)| !l.is_empty())
        .map(|(c, lines)| Panel {
            title: format!("PDF of eta_{}", c + 1),
            xlabel: "eta",
            ylabel: "density",
            series: lines
                .iter()
                .enumerate()
                .map(|(k, pts)| Series { name: names[k.min(names.len() - 1)], points: pts, color: colors[k % 3] })
                .collect(),
        })
        .collect();
    if !panels.is_empty() {
        let path = format!("fig/chaos_{tag}_pdfs.png");
        grid(&dir.join(&path), &panels, 3, (1050, 300 * panels.len().div_ceil(3) as u32))?;
        figs.push(fig(&path, "pdfs", None));
    }
    // Attractor projections and spectra.
    let proj = |eta: &[f64]| -> Vec<(f64, f64)> {
        let n = eta.len() / d;
        let step = (n / 20_000).max(1);
        (0..n).step_by(step).map(|i| (eta[i * d], eta[i * d + 1])).collect()
    };
    let mut projs = vec![("data (held out)".to_string(), proj(eta_data))];
    projs.extend(runs.iter().map(|(n, _, p)| (n.to_string(), proj(&p.eta))));
    let panels: Vec<Panel<'_>> = projs
        .iter()
        .enumerate()
        .map(|(k, (n, pts))| Panel {
            title: n.clone(),
            xlabel: "eta_1",
            ylabel: "eta_2",
            series: vec![Series { name: n, points: pts, color: colors[k % 3] }],
        })
        .collect();
    let path = format!("fig/chaos_{tag}_attractor.png");
    grid(&dir.join(&path), &panels, 3, (1050, 330))?;
    figs.push(fig(&path, "attractor", None));
    let fmax = 10.0 / (ctx.theiler as f64 * dt);
    let spec = |x: &[f64]| -> Vec<(f64, f64)> {
        let (f, a) = ssm::metrics::amplitude_spectrum(x, dt);
        f.into_iter().zip(a).filter(|p| p.0 <= fmax).collect()
    };
    let n = runs.iter().map(|r| r.2.x.len()).min().unwrap_or(test.x.len()).min(test.x.len());
    let mut specs = vec![("data (held out)".to_string(), spec(&test.x[..n]))];
    specs.extend(runs.iter().map(|(nm, _, p)| (nm.to_string(), spec(&p.x[..n]))));
    let series: Vec<Series<'_>> =
        specs.iter().enumerate().map(|(k, (nm, pts))| Series { name: nm, points: pts, color: colors[k % 3] }).collect();
    let path = format!("fig/chaos_{tag}_spectrum.png");
    grid(
        &dir.join(&path),
        &[Panel { title: format!("{title}: amplitude spectra"), xlabel: "f [Hz]", ylabel: "amplitude", series }],
        1,
        (760, 300),
    )?;
    figs.push(fig(&path, "spectrum", Some(n)));
    Ok(figs)
}

/// The captions of [`chaos_figures`]'s figures by `kind`, over the figure's values.
const FIGURE_CAPTIONS: [(&str, &str); 3] = [
    ("pdfs", "{{ name }}: PDFs of the reduced coordinates, held-out data vs models"),
    ("attractor", "{{ name }}: attractor projected on (eta_1, eta_2)"),
    ("spectrum", "{{ name }}: amplitude spectra of the observable over the same {{ samples }} samples"),
];

/// Where `cargo xtask reproduce` leaves the processor-in-the-loop recordings (relative to
/// the workspace root, where `reproduce` runs).
pub const PIL_RECORD_DIR: &str = "qemu/target/pil-record";

/// The main chaos page as it is computed: its blocks in page order, each a paragraph, a table
/// or a figure named by its template and the values it is written from. Stored in the summary
/// as `page_chaos` and written by [`render`] from there alone.
#[derive(Default)]
pub struct Page {
    /// The blocks in page order (`para`, `table` or `figure` objects).
    pub blocks: Vec<serde_json::Value>,
}

impl Page {
    /// A paragraph: the template `PARAS` names `id`, over `values`.
    pub fn para(&mut self, id: &str, values: serde_json::Value) {
        self.blocks.push(serde_json::json!({ "para": id, "values": values }));
    }
    /// A table: the header and cell templates `TABLES` names `id`, the header over `head`,
    /// the cells over each of `rows`.
    pub fn table(&mut self, id: &str, head: serde_json::Value, rows: Vec<serde_json::Value>) {
        self.blocks.push(serde_json::json!({ "table": id, "head": head, "rows": rows }));
    }
    /// A figure of [`chaos_figures`].
    pub fn figure(&mut self, values: serde_json::Value) {
        self.blocks.push(serde_json::json!({ "figure": values }));
    }
}

/// The main chaos section: computes the data sets' analyses, the model selection and the
/// flag study's tables, writes the summary keys `chaos`, `rosenstein_check`,
/// `flag_estimator_bias`, `flag_pipeline_check`, `flag_pipeline_fit` and the page's blocks
/// `page_chaos`, then the page from the summary (`render`).
pub fn section(rep: &mut crate::report::Report, data_dir: &std::path::Path, quick: bool) -> Result<(), Box<dyn Error>> {
    let mut page = Page::default();
    let o = ChaosOptions::default();
    let setup = serde_json::json!({
        "scaling_tolerance": chaos::ScalingRule::default().tolerance, "centers": o.centers, "poly_order": o.poly_order,
    });
    page.para("chaos/intro", setup);
    // (name, training series, held-out series)
    let mut sets: Vec<(String, Vec<TimeSeries>, TimeSeries)> = Vec::new();
    let periods = if quick { 6000 } else { 30000 };
    let starts: Vec<(usize, f64)> = [0.02, 0.035, 0.05].into_iter().enumerate().collect();
    let mut sim = crate::report::par_map(&starts, |&(i, th)| {
        simulate_quantized(periods, th, &format!("furuta-quant-dt25 #{i}"))
    })?;
    let sim_test = sim.pop().ok_or("no simulated series")?;
    sets.push(("simulated: furuta-quant-dt25 (theta)".into(), sim, sim_test));
    // The "experiment": processor-in-the-loop recordings with sensor noise
    // (`cargo xtask pil-record`, run by `cargo xtask reproduce`).
    let pil_dir = std::path::Path::new(PIL_RECORD_DIR);
    let pil_files: Vec<_> = (1..=3).map(|r| pil_dir.join(format!("run{r}/record.csv"))).collect();
    if pil_files.iter().all(|f| f.is_file()) {
        let mut runs: Vec<TimeSeries> = pil_files.iter().map(|f| pil_plant_theta(f)).collect::<Result<_, _>>()?;
        let test = runs.pop().ok_or("no PIL run")?;
        sets.push(("processor in the loop: furuta-quant-dt25-noise (plant theta)".into(), runs, test));
    } else {
        page.para("chaos/no-pil", serde_json::json!({ "dir": pil_dir.display().to_string(), "out": PIL_RECORD_DIR }));
    }
    // The flag study's measured results (studies/results/flag, written by `ssmctl study`),
    // whose training and held-out runs the flag's row uses.
    let results = chaos_study::study_results::FlagResults::bundled()?;
    let flag = data_dir.join("inverted_flag_chaotic");
    let csv = |run: &str| flag.join(format!("{run}.csv"));
    let (train_runs, test_run) = (&results.held_out.train_runs, &results.held_out.test_run);
    if train_runs.iter().chain([test_run]).all(|r| csv(r).is_file()) {
        sets.push((
            "measured: inverted flag (tip deflection)".into(),
            train_runs.iter().map(|r| ssm::load_csv(csv(r))).collect::<Result<_, _>>()?,
            ssm::load_csv(csv(test_run))?,
        ));
    } else {
        page.para("chaos/no-flag", serde_json::json!({ "dir": flag.display().to_string() }));
    }
    let mut rows = Vec::new();
    let mut list = serde_json::Map::new();
    let mut figs = Vec::new();
    let mut selections = Vec::new();
    for (name, train, test) in &sets {
        let label = serde_json::json!({
            "name": name, "train": train.iter().map(|t| t.name.as_str()).collect::<Vec<_>>(), "test": test.name,
        });
        let (r, models, held) = match analyse_held_out_runs(train, Some(test), &ChaosOptions::default()) {
            Ok(r) => r,
            Err(e) => {
                // One data set failing an estimator's precondition is reported, not fatal.
                rows.push(serde_json::json!({ "s": label, "a": null, "error": e.to_string() }));
                list.insert(name.clone(), serde_json::json!({"error": e.to_string()}));
                continue;
            }
        };
        rows.push(serde_json::json!({ "s": label, "a": r, "error": null }));
        let mut value = serde_json::to_value(&r)?;
        // Model selection by held-out long-term statistics (new keys `chosen_model` and
        // `model_candidates`; the values above are unchanged).
        let mut cands =
            chaos_study::model_selection::standard_candidates(&ChaosOptions::default(), r.ssm_dim, &[1], test)?;
        if name.starts_with("measured: inverted flag") {
            cands.extend(chaos_study::model_selection::flag_candidates());
        }
        // The step-1 candidates are the models just fitted, on the same data statistics.
        let known = chaos_study::model_selection::Known::from_analysis(test, &ChaosOptions::default(), &r, &models)?;
        let (results, sel) = chaos_study::model_selection::evaluate_and_select_known(
            train,
            test,
            &cands,
            &Default::default(),
            &Default::default(),
            &known,
        )?;
        drop(known);
        if let Some(m) = value.as_object_mut() {
            m.insert("chosen_model".into(), chaos_study::model_selection::chosen_json(&results, &sel));
            m.insert("model_candidates".into(), serde_json::to_value(&results)?);
        }
        selections.push((name.clone(), results, sel));
        list.insert(name.clone(), value);
        let tag: String =
            name.split(':').next().unwrap_or("set").chars().filter(|c| c.is_ascii_alphanumeric()).collect();
        figs.push((tag, name.clone(), test.clone(), r, models, held));
    }
    page.table("chaos/sets", serde_json::Value::Null, rows);
    rep.summary.insert("chaos".into(), serde_json::Value::Object(list));
    let theory = serde_json::json!({ "window_ratio": WINDOW_RATIO, "diffusion_power": DIFFUSION_POWER });
    page.para("chaos/separation", theory);
    let grows: Vec<serde_json::Value> = figs
        .iter()
        .map(|(_, name, _, r, _, _)| {
            let spec = |b: &Option<ModelLyapunov>| b.as_ref().map(|b| b.spectrum.iter().take(2).copied().collect::<Vec<_>>());
            serde_json::json!({ "name": name, "windows": r.growth_windows_data, "rbf": spec(&r.benettin_rbf),
                                "poly": spec(&r.benettin_poly),
                                "kicked": { "lle_rbf": r.lle_model_rbf_kicked, "js_rbf": r.pdf_divergence_rbf_kicked,
                                            "lle_poly": r.lle_model_poly_kicked, "js_poly": r.pdf_divergence_poly_kicked } })
        })
        .collect();
    page.table("chaos/growth", serde_json::Value::Null, grows);
    for (tag, name, test, _, models, held) in &figs {
        for f in chaos_figures(rep.dir(), tag, name, test, models, held, &ChaosOptions::default())? {
            page.figure(f);
        }
    }
    selection_tables(rep, &mut page, &selections, &results, quick)?;
    let flag_runs: Option<Vec<TimeSeries>> =
        (0..10).map(|k| ssm::load_csv(flag.join(format!("traj_{k}.csv"))).ok()).collect();
    estimator_check_tables(rep, &mut page, &selections, flag_runs.as_deref(), quick)?;
    rep.summary.insert("page_chaos".into(), serde_json::Value::Array(page.blocks));
    render(rep, &serde_json::Value::Object(rep.summary.clone()))
}

/// The paragraphs of the main chaos page: id and the parts of its template (HTML, values
/// escaped), joined.
const PARAS: &[(&str, &[&str])] = &[
    ("chaos/intro", &[INTRO]),
    (
        "chaos/no-pil",
        &["No processor-in-the-loop recordings under {{ dir | esc }} (run <code>cargo xtask pil-record --out \
           {{ out | esc }}</code>): skipped."],
    ),
    ("chaos/no-flag", &["Inverted-flag data not found under {{ dir | esc }}: skipped."]),
    ("chaos/separation", &[SEPARATION]),
    ("chaos/selection", &[SELECTION]),
    ("chaos/pick", &[PICK]),
    ("chaos/search-intro", &[SEARCH_INTRO]),
    ("chaos/search-findings", &[SEARCH_FINDINGS]),
    ("chaos/bias", &[BIAS]),
    ("chaos/calibration", &[CALIBRATION]),
    ("chaos/calibration-says", &[CALIBRATION_SAYS]),
    ("chaos/pipeline-check", &[PIPELINE_CHECK]),
    ("chaos/pipeline-does", &[SEP, PIPELINE_DOES]),
    ("chaos/fnn", &[FNN]),
    ("chaos/diagnosis", &[SPAN, NOISY_STATE, DIAGNOSIS]),
    ("chaos/multistep", &[SPAN, MULTISTEP]),
    ("chaos/centre-sets", &[CENTRE_SETS]),
    ("chaos/experiment-as-model", &[EXPERIMENT_AS_MODEL]),
    ("chaos/validation", &[VALIDATION]),
    ("chaos/rosenstein-check", &[ROSENSTEIN_CHECK]),
    ("chaos/rosenstein-models", &[ROSENSTEIN_MODELS]),
    ("chaos/data-spread", &[DATA_SPREAD]),
];

/// `-` for none, else `fixed(n)`: the cells' optional values.
const O: &str = "{% macro o(v, n) %}{% if v is none %}-{% else %}{{ v | fixed(n) }}{% endif %}{% endmacro %}";

/// The tables of the main chaos page: id, header templates (over the block's `head`) and cell
/// templates (over each row; with [`O`] before each).
#[allow(clippy::type_complexity)]
const TABLES: &[(&str, &[&str], &[&str])] = &[
    (
        "chaos/sets",
        &[
            "data",
            "corr. dim",
            "SSM dim",
            "LLE data [1/s]",
            "LLE RBF",
            "LLE poly",
            "LLE RBF Benettin",
            "LLE poly Benettin",
            "JS RBF [bits]",
            "JS poly [bits]",
            "notes",
        ],
        &[
            "{{ s.name }}; train {{ s.train | join(' + ') }}, test {{ s.test }}",
            "{% if error is none %}{{ a.corr_dim | fixed(2) }} ± {{ a.corr_dim_err | fixed(2) }}{% else %}analysis \
             failed: {{ error }}{% endif %}",
            "{% if error is none %}{{ a.ssm_dim }}{% endif %}",
            "{% if error is none %}{{ a.lle_data | num }}{% endif %}",
            "{% if error is none %}{{ a.lle_model_rbf | num_or }}{% endif %}",
            "{% if error is none %}{{ a.lle_model_poly | num_or }}{% endif %}",
            "{% if error is none %}{{ a.lle_model_rbf_benettin | num_or }}{% endif %}",
            "{% if error is none %}{{ a.lle_model_poly_benettin | num_or }}{% endif %}",
            "{% if error is none %}{{ a.pdf_divergence_rbf | num_or }}{% endif %}",
            "{% if error is none %}{{ a.pdf_divergence_poly | num_or }}{% endif %}",
            "{% if error is none %}{{ a.notes | join('; ') }}{% endif %}",
        ],
    ),
    (
        "chaos/growth",
        &[
            "data",
            "slope over [t, 2t] [1/s]",
            "power a per window",
            "RBF Benettin (1st, 2nd)",
            "poly Benettin (1st, 2nd)",
            "kicked RBF: LLE / JS",
            "kicked poly: LLE / JS",
        ],
        &[
            "{{ name }}",
            "{% for g in windows %}{{ g.t0 | fixed(2) }}-{{ g.t1 | fixed(2) }} s: {{ g.slope | fixed(3) }}\
             {% if not loop.last %}; {% endif %}{% endfor %}",
            "{% for g in windows %}{{ g.power | fixed(2) }}{% if not loop.last %}, {% endif %}{% endfor %}",
            "{% if rbf is none %}-{% else %}{% for v in rbf %}{{ v | signed(4) }}{% if not loop.last %}, {% endif %}\
             {% endfor %}{% endif %}",
            "{% if poly is none %}-{% else %}{% for v in poly %}{{ v | signed(4) }}{% if not loop.last %}, {% endif %}\
             {% endfor %}{% endif %}",
            "{{ kicked.lle_rbf | num_or }} / {{ kicked.js_rbf | num_or }}",
            "{{ kicked.lle_poly | num_or }} / {{ kicked.js_poly | num_or }}",
        ],
    ),
    (
        "chaos/candidates",
        &[
            "data",
            "candidate",
            "Benettin [1/s]",
            "2nd Benettin",
            "Rosenstein model / data [1/s]",
            "D2 model / data",
            "JS [bits]",
            "rollout error (horizon)",
            "long run",
        ],
        &[
            "{{ set }}",
            "{{ r.name }}{% if picked %} (picked){% endif %}",
            "{{ o(r.benettin, 3) }} ± {{ o(r.benettin_err, 3) }}",
            "{{ o(r.benettin_2nd, 3) }}",
            "{{ o(r.rosenstein, 3) }} / {{ r.data.lle | fixed(3) }}",
            "{{ o(r.corr_dim, 2) }} / {{ r.data.corr_dim | fixed(2) }} ± {{ r.data.corr_dim_err | fixed(2) }}",
            "{{ o(r.js, 4) }}",
            "{{ o(r.rollout, 3) }} ({{ horizon }} steps)",
            "{% if r.failed is none %}ok{% else %}FAILED: {{ r.failed }}{% endif %}",
        ],
    ),
    (
        "chaos/search",
        &chaos_study::study_results::SearchResults::HEADER,
        &[
            "{{ r.candidate }}",
            "{{ r.data_rosenstein | fixed(3) }}",
            "{{ o(r.benettin, 3) }} ({{ o(r.benettin_2nd, 3) }})",
            "{{ o(r.rosenstein, 3) }}{% if r.rosenstein_noisy is not none %} ({{ r.rosenstein_noisy | fixed(3) }})\
             {% endif %}",
            "{{ o(r.corr_dim, 2) }} ({{ r.data_corr_dim | fixed(2) }} ± {{ r.data_corr_dim_err | fixed(2) }})",
            "{{ o(r.js, 4) }}",
            "{{ o(r.excursion, 2) }}",
            "{% if failed is not none %}FAILED: {{ failed }}{% elif r.chaotic %}chaotic{% else %}not chaotic (torus \
             or periodic){% endif %}",
            "{{ r.notes }}",
        ],
    ),
    (
        "chaos/calibration",
        &[
            "system",
            "dt",
            "lag / Theiler",
            "exact [1/s]",
            "nats per lag",
            "D2",
            "noise [% sd]",
            "ratio mean ± sd",
            "median",
            "range",
            "fitted",
        ],
        &[
            "{{ r.system }} ({{ r.observable }})",
            "{{ r.dt | fixed(4) }}",
            "{{ r.lag }} / {{ r.theiler }}",
            "{{ r.exact | fixed(4) }} ± {{ r.exact_err | fixed(4) }}",
            "{{ r.per_lag | fixed(3) }}",
            "{{ o(r.corr_dim, 2) }} ± {{ o(r.corr_dim_err, 2) }}",
            "{{ r.noise_rel | pct(2) }}",
            "{{ o(r.ratio_mean, 2) }} ± {{ o(r.ratio_sd, 2) }}",
            "{{ o(r.ratio_median, 2) }}",
            "{{ o(r.ratio_min, 2) }} .. {{ o(r.ratio_max, 2) }}",
            "{{ r.fitted }} / {{ r.segments }}",
        ],
    ),
    (
        "chaos/pipeline",
        &[
            "candidate",
            "training data (x flag)",
            "Benettin [1/s] (/ exact)",
            "Rosenstein [1/s] (data)",
            "D2 (data)",
            "JS [bits]",
            WITHIN_EXACT,
            "targets met (against the data, as on the flag)",
            "failed",
        ],
        &[
            "{{ r.candidate }}",
            "{{ r.scale }}x",
            "{{ o(r.benettin, 3) }} ({{ o(r.benettin_over_exact, 2) }})",
            "{{ o(r.rosenstein, 3) }} ({{ r.data_rosenstein | fixed(3) }})",
            "{{ o(r.corr_dim, 2) }} ({{ r.data_corr_dim | fixed(2) }} ± {{ r.data_corr_dim_err | fixed(2) }})",
            "{{ o(r.js, 4) }}",
            "{% if r.benettin_exact_ok %}yes{% else %}no{% endif %}",
            "{{ met }}/{{ targets }}",
            "{% if r.failed is not none %}{{ r.failed }}{% endif %}",
        ],
    ),
    (
        "chaos/diagnosis",
        &[
            "varied",
            "model",
            "training data (x flag)",
            "noise / sd",
            "Benettin [1/s] (/ exact)",
            "Rosenstein [1/s]",
            "D2",
            "JS [bits]",
            WITHIN_EXACT,
            "failed",
        ],
        &[
            "{{ what }}",
            "{{ r.candidate }}",
            "{{ r.scale }}x",
            "{{ noise | pct(2) }} %",
            "{{ o(r.benettin, 3) }} ({{ o(r.benettin_over_exact, 2) }})",
            "{{ o(r.rosenstein, 3) }}",
            "{{ o(r.corr_dim, 2) }}",
            "{{ o(r.js, 4) }}",
            "{% if r.benettin_exact_ok %}yes{% else %}no{% endif %}",
            "{% if r.failed is not none %}{{ r.failed }}{% endif %}",
        ],
    ),
    (
        "chaos/experiment",
        &[
            "run (as a model of {{ test_run }})",
            "samples at step {{ step }}",
            "Rosenstein [1/s]",
            "D2",
            "JS [bits]",
            "targets R/D2/JS",
        ],
        &[
            "{{ prefix }}{{ r.run }}{% if training %} (training){% endif %}",
            "{{ r.start }}-{{ end }}",
            "{{ o(r.rosenstein, 3) }}",
            "{{ o(r.corr_dim, 2) }}{% if r.corr_dim_err is not none %} ± {{ r.corr_dim_err | fixed(2) }}{% endif %}",
            "{{ o(r.js, 4) }}",
            "{% for p in passes %}{% if p %}y{% else %}n{% endif %}{% endfor %}",
        ],
    ),
    (
        "chaos/rosenstein",
        &[
            "system",
            "observable",
            "samples",
            "dt [s]",
            "lag / Theiler [samples]",
            "exact (Benettin) [1/s]",
            "Rosenstein [1/s]",
            "ratio",
            "notes",
        ],
        &[
            "{{ r.system }}",
            "{{ r.observable }}",
            "{{ r.samples }}",
            "{{ r.dt | plain }}",
            "{{ r.lag }} / {{ r.theiler }}",
            "{{ r.exact | fixed(4) }} ± {{ r.exact_err | fixed(4) }}",
            "{{ o(r.rosenstein, 4) }}",
            "{{ o(r.ratio, 3) }}",
            "{% if r.data_rosenstein is defined %}Rosenstein model / data {{ o(r.rosenstein, 3) }} / \
             {{ r.data_rosenstein | fixed(3) }} = {{ r.rosenstein_over_data | fixed(2) }}{% else %}{{ r.note }}{% endif %}",
        ],
    ),
    (
        "chaos/spread",
        &["estimates", "n", "mean ± sd [1/s]", "CV", "range [1/s]"],
        &[
            "{% if s is none %}per run{% else %}{{ s.what }} (k = {{ s.step }}){% endif %}",
            "{% if s is none %}{{ count }}{% else %}{{ s.n }}{% endif %}",
            "{% if s is none %}{% for r in per_run %}{{ r.name }} k={{ r.step }}: {{ o(r.rosenstein, 3) }}\
             {% if not loop.last %}; {% endif %}{% endfor %}{% else %}{{ s.mean | fixed(3) }} ± {{ s.sd | fixed(3) }}\
             {% endif %}",
            "{% if s is not none %}{{ s.cv | pct(0) }} %{% endif %}",
            "{% if s is not none %}{{ s.min | fixed(3) }} .. {{ s.max | fixed(3) }}{% endif %}",
        ],
    ),
];

/// The main chaos section's title.
const TITLE: &str = "Chaotic statistics: data vs SSM models";

/// Writes the main chaos section from the summary `s`: the blocks of `page_chaos` in order
/// (the first the section's introduction), through `PARAS`, `TABLES` and
/// `FIGURE_CAPTIONS`.
pub fn render(rep: &mut crate::report::Report, s: &serde_json::Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    let blocks = key(s, "page_chaos")?.as_array().ok_or("report: page_chaos is not a list")?;
    for (i, b) in blocks.iter().enumerate() {
        if let Some(id) = b.get("para").and_then(|v| v.as_str()) {
            let (_, parts) =
                PARAS.iter().find(|x| x.0 == id).ok_or_else(|| format!("report: page_chaos: no paragraph `{id}`"))?;
            let text = p.html(id, &parts.concat(), &b["values"])?;
            match (i, id) {
                (0, "chaos/intro") => rep.section("chaos", TITLE, &text),
                (0, _) | (_, "chaos/intro") => {
                    return Err(format!("report: page_chaos: `{id}` at block {i}; the introduction comes first").into());
                }
                _ => rep.para(&text),
            }
        } else if let Some(id) = b.get("table").and_then(|v| v.as_str()) {
            let (_, head, cells) =
                TABLES.iter().find(|x| x.0 == id).ok_or_else(|| format!("report: page_chaos: no table `{id}`"))?;
            let head: Vec<String> = head.iter().map(|h| p.text(id, h, &b["head"])).collect::<Result<_, _>>()?;
            let cells: Vec<String> = cells.iter().map(|c| format!("{O}{c}")).collect();
            let cells: Vec<&str> = cells.iter().map(String::as_str).collect();
            let rows = b["rows"].as_array().ok_or_else(|| format!("report: page_chaos: table `{id}` has no rows"))?;
            let head: Vec<&str> = head.iter().map(String::as_str).collect();
            rep.table(&head, &p.rows(id, &cells, rows)?);
        } else if let Some(f) = b.get("figure") {
            let kind = f["kind"].as_str().unwrap_or_default();
            let (_, caption) = FIGURE_CAPTIONS
                .iter()
                .find(|x| x.0 == kind)
                .ok_or_else(|| format!("report: page_chaos: no figure kind `{kind}`"))?;
            let path = f["path"].as_str().ok_or("report: page_chaos: a figure without a path")?;
            rep.figure(path, &p.text("chaos/figure", caption, f)?);
        } else {
            return Err(format!("report: page_chaos: block {i} is no paragraph, table or figure").into());
        }
    }
    Ok(())
}

/// The Rosenstein check's introduction over its settings (embedding, the systems' parameters).
pub const ROSENSTEIN_CHECK: &str = "ROSENSTEIN_CHECK: is the data's time-series exponent the exponent a model should have? \
    The Rosenstein estimator with exactly the settings used on the data (embedding {{ embed }}, lag = first zero of the \
    autocorrelation, Theiler window = dominant period, curve of three Theiler windows, the same fit-window rule and \
    fallbacks) against exact largest exponents: the Rössler (a = {{ rossler[0] | num }}, b = {{ rossler[1] | num }}, c = \
    {{ rossler[2] | num }}) and Lorenz ({{ lorenz | nums }}) flows sampled about as densely per oscillation as the flag \
    at the model step, exponent by Benettin with the exact variational equation; and the chaotic fitted models above, \
    Rosenstein on the model's output against the model's own Benettin exponent. Ratio = Rosenstein / exact.";

/// What the check says of the fitted models, over their ratio range and the known answers'.
pub const ROSENSTEIN_MODELS: &str = "On the fitted models the estimator reads {{ range[0] | fixed(2) }} to \
    {{ range[1] | fixed(2) }} of the model's own exponent ({{ models }} chaotic models), against \
    {{ rossler_x | fixed(2) }} on Rössler x and {{ lorenz_z | fixed(2) }} on Lorenz z. The fair comparison of a model \
    with the data is therefore Rosenstein on the model's output against Rosenstein on the data (the selection table's \
    column), not the model's Benettin exponent against the data's Rosenstein number.";

/// The data spread table's introduction over the number of runs.
pub const DATA_SPREAD: &str = "Spread of the flag data's own Rosenstein estimate (data settings, each series its own lag \
    and Theiler window) over the {{ runs }} recorded runs and over consecutive windows cut from them, at map step k \
    (every k-th frame): the uncertainty of the number the models are compared with.";

/// The calibration's introduction over the flag's sampling ([`chaos_study::calibration::FLAG_SAMPLING`]).
pub const CALIBRATION: &str = "Calibration of the estimator on known answers sampled like the flag: smooth chaotic \
    systems with an exact largest exponent (Benettin with the exact tangent dynamics of the equations that make the \
    series; Mackey-Glass as Heun's method on a grid of delay steps, the map that makes the series), sampled so that \
    the data settings choose the flag's lag ({{ flag.lag }} samples), cut into segments of the flag's held-out length \
    ({{ flag.samples }} samples), with white noise at the flag's measured level ({{ flag.noise_rel | pct(2) }} % of the \
    series sd) or none, through exactly the estimator and settings used on the flag. Ratio = Rosenstein / exact over \
    the segments; nats per lag = exact x lag x dt (the flag reads {{ flag_per_lag | fixed(2) }} at its Rosenstein \
    value {{ flag.lle | fixed(3) }} 1/s); D2 of the first noise-free segment with the data settings.";

/// What the calibration says, over its summary and the regimes' systems.
pub const CALIBRATION_SAYS: &str = "{% macro range(r, n) %}{% if r is none %}-{% else %}{{ r[0] | fixed(n) }}-\
    {{ r[1] | fixed(n) }}{% endif %}{% endmacro %}What the calibration says. With at most {{ calm_per_lag | num }} nats \
    per lag ({{ calm.systems | join(', ') }}; D2 {{ range(calm.corr_dim, 1) }}) the estimator reads \
    {{ s.calm_mean_range[0] | fixed(2) }} to {{ s.calm_mean_range[1] | fixed(2) }} of the exact exponent on average, \
    but one series of the flag's length reads {{ s.calm_segment_range[0] | fixed(2) }} to \
    {{ s.calm_segment_range[1] | fixed(2) }} (segment sd up to {{ s.calm_segment_sd_max | fixed(2) }}); the flag's \
    noise level moves a mean by at most {{ s.calm_noise_shift_max | fixed(2) }}. With the flag's chaos per lag \
    ({{ chaotic.systems | join(', ') }}; D2 {{ range(chaotic.corr_dim, 1) }}) the mean ratio ranges from \
    {{ s.chaotic_mean_range[0] | fixed(2) }} to {{ s.chaotic_mean_range[1] | fixed(2) }} between systems and \
    {{ s.chaotic_segment_range[0] | fixed(2) }} to {{ s.chaotic_segment_range[1] | fixed(2) }} between segments. So \
    there is no fixed bias for attractors like the flag's: {% if models_ratio is none %}the fitted models' \
    Rosenstein / Benettin{% else %}the fitted models' Rosenstein / Benettin of {{ range(models_ratio, 2) }}{% endif %} \
    is within the spread of this regime, not a law, and the data's exponent is pinned by its Rosenstein number only to \
    {{ s.chaotic_implied_exponent[0] | fixed(2) }}-{{ s.chaotic_implied_exponent[1] | fixed(2) }} 1/s by the \
    flag-regime means ({{ s.calm_implied_exponent[0] | fixed(2) }}-{{ s.calm_implied_exponent[1] | fixed(2) }} 1/s if \
    it were read as in the calm regime). The two exponent targets are therefore not shown to exclude each other; but \
    a {{ targets.rosenstein_rel | pct(0) }} % Rosenstein target on one series of this length is far inside the \
    estimator's own scatter, and a {{ targets.benettin_rel | pct(0) }} % Benettin target against the data's Rosenstein \
    number has no firmer reference than that number.";

/// The Rosenstein estimator against exact exponents (ROSENSTEIN_CHECK) and the spread of the
/// flag data's own estimate over its runs and windows ([`chaos_study::estimator_check`]); summary
/// key `rosenstein_check`.
fn estimator_check_tables(
    rep: &mut crate::report::Report,
    page: &mut Page,
    selections: &[(
        String,
        Vec<chaos_study::model_selection::CandidateResult>,
        chaos_study::model_selection::Selection,
    )],
    flag_runs: Option<&[TimeSeries]>,
    quick: bool,
) -> Result<(), Box<dyn Error>> {
    use chaos_study::estimator_check::{CheckRow, data_spread, known_answer_rows, model_rows};
    let mut rows: Vec<CheckRow> = known_answer_rows(quick)?;
    let n_known = rows.len();
    for (name, results, _) in selections {
        rows.extend(model_rows(name.split(':').next().unwrap_or(name), results));
    }
    let (ro, lo_) = (chaos::reference::Rossler::default(), chaos::reference::Lorenz::default());
    let setup = serde_json::json!({
        "embed": chaos_study::estimator_check::EMBED,
        "rossler": [ro.a, ro.b, ro.c], "lorenz": [lo_.sigma, lo_.rho, lo_.beta],
    });
    page.para("chaos/rosenstein-check", setup);
    let table = rows.iter().map(|r| serde_json::json!({ "r": r })).collect();
    page.table("chaos/rosenstein", serde_json::Value::Null, table);
    let ratios: Vec<f64> = rows[n_known..].iter().filter_map(|r| r.ratio).collect();
    let (lo, hi) = ratios.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
    let mut json = serde_json::json!({ "known_answer": &rows[..n_known], "models": &rows[n_known..] });
    if !ratios.is_empty() {
        // The known answers' first rows of each system and observable, as the text names them.
        let known = |system: &str, obs: &str| {
            rows[..n_known].iter().find(|r| r.system == system && r.observable == obs).and_then(|r| r.ratio)
        };
        let v = serde_json::json!({
            "range": [lo, hi], "models": ratios.len(),
            "rossler_x": known("Rössler", "x"), "lorenz_z": known("Lorenz", "z"),
        });
        page.para("chaos/rosenstein-models", v);
    }
    if let Some(runs) = flag_runs {
        // The held-out length at step 4 is 1,973 samples; windows of 900 fit every run.
        let steps: &[usize] = if quick { &[4] } else { &[1, 4] };
        let mut all_rows = Vec::new();
        let mut spreads = Vec::new();
        for &k in steps {
            let (r, s) = data_spread(runs, &[k], if k == 1 { 3600 } else { 900 })?;
            all_rows.extend(r);
            spreads.extend(s);
        }
        page.para("chaos/data-spread", serde_json::json!({ "runs": runs.len() }));
        let short = |n: &str| n.split(" (").next().unwrap_or(n).to_string() + n.rsplit_once(')').map_or("", |(_, w)| w);
        let mut t: Vec<serde_json::Value> =
            spreads.iter().map(|s| serde_json::json!({ "s": s, "per_run": null, "count": null })).collect();
        let per_run: Vec<serde_json::Value> = all_rows
            .iter()
            .filter(|r| !r.series.contains(" window "))
            .map(|r| serde_json::json!({ "name": short(&r.series), "step": r.step, "rosenstein": r.rosenstein }))
            .collect();
        t.push(serde_json::json!({ "s": null, "count": per_run.len(), "per_run": per_run }));
        page.table("chaos/spread", serde_json::Value::Null, t);
        json["data_spread"] = serde_json::json!({ "spreads": spreads, "rows": all_rows });
    }
    rep.summary.insert("rosenstein_check".into(), json);
    Ok(())
}

/// The growth windows' end over their start ([`chaos::held_out::growth_windows`]), and the power
/// of separation by diffusion along a neutral direction (theory: d ~ t^(1/2)).
pub const WINDOW_RATIO: f64 = 2.0;
pub const DIFFUSION_POWER: f64 = 0.5;

/// How the data separate, over the windows' ratio and the diffusion's power.
pub const SEPARATION: &str = "How the data separate: the secant slope of each data set's Rosenstein curve over doubling \
    windows [t, {{ window_ratio | num }}t], and the same rise read as a power law d ~ t^a (a = rise / \
    ln({{ window_ratio | num }})). Exponential separation (chaos) keeps the slope and lets a grow with t; diffusion along \
    a neutral direction (a torus shaken by quantization or noise) keeps a near {{ diffusion_power | num }} while the \
    slope falls like 1/t, and then the single Rosenstein number depends on its fit window. The models' Benettin spectra \
    (first two exponents) tell whether the smooth model's own attractor is a torus (two zeros). The kicked models are \
    the smooth maps driven by their own one-step training residuals, drawn at random and added after every step (a \
    bootstrap of what the smooth map misses, e.g. the quantization kicks): same estimators, same start.";

/// The flag study's SSM dimension (its dimension rule's choice; the search's plain rows).
pub const FLAG_DIM: usize = 4;

/// How candidates are judged, over the evaluation settings and the targets.
pub const SELECTION: &str = "Model selection by held-out long-term statistics: each candidate is fitted on the training \
    trajectories and run on its own from the held-out trajectory's first point for {{ long_runs }} held-out lengths. \
    Measured as on the data (same estimators, same settings, at the candidate's map step): its own Benettin exponent, \
    the Rosenstein exponent and correlation dimension of its observable series, the mean JS divergence of the \
    reduced-coordinate PDFs over the long run. A run leaving the data's region (|eta| above {{ region_factor | num }} x \
    the data's largest |eta_i|) or escaping fails the candidate. Targets: Benettin positive and within \
    {{ targets.benettin_rel | pct(0) }} % of the data's exponent, Rosenstein within {{ targets.rosenstein_rel | pct(0) }} \
    %, D2 within the data's error bar, JS &lt;= {{ targets.js_max | num }} bits; the pick meets most targets, ties by \
    the smallest sum of errors over their tolerances. Candidates with map step k samples are fitted on every pair \
    (n, n + k) (the k phase-shifted subsamplings) and compared with the held-out series subsampled by k. The JS \
    divergence here is over the long run, so it differs from the first table's (one held-out length): a model that \
    covers the data's distribution during its transient and then settles on a regular attractor (the one-sample RBF \
    model) is seen here for what it settles to. Rollout error: the multi-step loss on the held-out trajectory, RMS \
    distance of the model's reduced coordinates run a quarter of the dominant period (in map steps) from \
    {{ rollout_starts }} evenly spaced held-out points to the data's, over the data's RMS; reported, not used in the \
    pick.";

/// The flag's candidate search table's introduction, over the study's runs.
pub const SEARCH_INTRO: &str = "Inverted flag: the candidate search behind the flag's candidates (train \
    {{ train | join(' + ') }}, held out {{ test }}; <code>ssmctl study studies/flag-first-search.toml \
    --data-dir ../shared/data</code>). Columns as above; k = map step in samples, d = SSM dimension, p = embedding dimension, s = \
    shift (samples of the subsampled series), m = manifold order, c = RBF centres, r = relative ridge.";

/// What the flag's candidate search shows, over [`search_findings`].
pub const SEARCH_FINDINGS: &str = "{% macro range(r, n) %}{% if r is none %}-{% elif r[0] == r[1] %}{{ r[0] | fixed(n) }}\
    {% else %}{{ r[0] | fixed(n) }} to {{ r[1] | fixed(n) }}{% endif %}{% endmacro %}\
    What the search shows. The map step decides chaos: of the one-sample-step models ({{ one_sample.rows }} in the \
    search, and the first table's RBF and polynomial models) {{ one_sample.chaotic }} is chaotic. Per map step, the \
    RBF maps with the paper's linear kernel at d = {{ dim }} (one-step fits of the raw data): \
    {% for s in steps %}k = {{ s.k }}: {{ s.chaotic }} of {{ s.rows }} chaotic, {{ s.failed }} escaped\
    {% if not loop.last %}; {% endif %}{% endfor %}. At the flag study's step k = {{ step }} the chaotic ones have \
    Benettin {{ range(chaotic.benettin, 2) }} 1/s and JS at most {{ chaotic.js_max | fixed(4) }} bits: chaos is fragile \
    in the fit settings (neighbouring centre counts or ridges flip a model between chaos, a torus and escape; the rows \
    above). The two exponent targets pull apart for these smooth models: the Rosenstein estimator applied to a \
    chaotic model's own series reads {{ range(chaotic.ratio, 2) }} of the model's Benettin exponent, so Benettin within \
    {{ targets.benettin_rel | pct(0) }} % of the data's Rosenstein {{ data.rosenstein | fixed(3) }} 1/s and Rosenstein \
    within {{ targets.rosenstein_rel | pct(0) }} % of it hold together only where that ratio is near one (the \
    estimator's bias is taken up below). The correlation dimension of the chaotic model series ranges over \
    {{ range(chaotic.corr_dim, 2) }} between neighbouring models; {{ chaotic.corr_dim_in_bar }} of them within the \
    data's {{ data.corr_dim | fixed(2) }} ± {{ data.corr_dim_err | fixed(2) }}. \
    {% for g in variants %}{{ g.what }}: {{ g.chaotic }} of {{ g.rows }} chaotic, {{ g.failed }} escaped{% if g.benettin is not none %} (Benettin {{ range(g.benettin, 3) }} 1/s){% endif %}\
    {% if g.corr_dim is not none %}, D2 {{ range(g.corr_dim, 2) }}{% endif %}{% if g.js is not none %}, JS \
    {{ range(g.js, 4) }}{% endif %}. {% endfor %}\
    Neither another kernel, a multi-step loss, denoised inputs (the flag's noise is \
    {{ noise_rel | pct(2) }} % of its sd, too small for the errors-in-variables shrinkage to matter) nor smoothing \
    brings a model's Rosenstein exponent and D2 to the data's: what changes is which attractor the fragile fit lands \
    on. Short-term accuracy (the rollout error in the notes) does not choose the attractor.";

/// The facts of the flag's candidate search (`rows`, the table's rows) that
/// [`SEARCH_FINDINGS`] states: outcomes per map step of the plain RBF rows at SSM dimension `dim`, the chaotic
/// ones' statistics at map step `step`, and each variant's (kernels, multistep, denoised or
/// smoothed inputs, d = 6).
pub fn search_findings(rows: &[SearchRow], step: usize, dim: usize) -> serde_json::Value {
    use serde_json::json;
    // The candidate's spec tokens (`k=4 d=4 ... kernel ...`) say which variant a row is.
    let token = |c: &str, key: &str| {
        c.split_whitespace().find_map(|t| t.strip_prefix(key)).and_then(|v| v.parse::<usize>().ok())
    };
    let variant = |c: &str| {
        if let Some((_, k)) = c.split_once(" kernel ") {
            let k = k.split_whitespace().next().unwrap_or(k);
            let rest = if c.contains(" multistep") || c.contains(" denoised") { " (refined or denoised)" } else { "" };
            Some(format!("kernel {}{rest}", k.split(':').next().unwrap_or(k)))
        } else if c.contains(" multistep") {
            Some("multi-step loss".to_string())
        } else if c.contains(" denoised inputs") {
            Some("denoised inputs".to_string())
        } else if c.contains(" smooth=") {
            Some("smoothed training data".to_string())
        } else if c.contains("polynomial") {
            Some("polynomial map".to_string())
        } else if token(c, "d=") != Some(dim) {
            Some("another SSM dimension".to_string())
        } else {
            None
        }
    };
    let range = |v: &[f64]| {
        if v.is_empty() {
            serde_json::Value::Null
        } else {
            json!([
                v.iter().copied().fold(f64::INFINITY, f64::min),
                v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            ])
        }
    };
    fn chaotic(r: &SearchRow) -> bool {
        r.failed.is_none() && r.chaotic
    }
    let failed = |r: &SearchRow| r.failed.is_some();
    /// A value of the chaotic rows among `rows`.
    fn col(rows: &[&SearchRow], v: impl Fn(&SearchRow) -> Option<f64>) -> Vec<f64> {
        rows.iter().filter(|r| chaotic(r)).filter_map(|r| v(r)).collect()
    }
    let plain: Vec<&SearchRow> = rows.iter().filter(|r| variant(&r.candidate).is_none()).collect();
    let mut ks: Vec<usize> = plain.iter().filter_map(|r| token(&r.candidate, "k=")).collect();
    ks.sort_unstable();
    ks.dedup();
    let steps: Vec<serde_json::Value> = ks
        .iter()
        .map(|&k| {
            let at: Vec<_> = plain.iter().filter(|r| token(&r.candidate, "k=") == Some(k)).collect();
            json!({ "k": k, "rows": at.len(), "chaotic": at.iter().filter(|r| chaotic(r)).count(),
                    "failed": at.iter().filter(|r| failed(r)).count() })
        })
        .collect();
    let at_step: Vec<&SearchRow> = plain.iter().copied().filter(|r| token(&r.candidate, "k=") == Some(step)).collect();
    let data = at_step.first().map_or(json!({ "rosenstein": null, "corr_dim": null, "corr_dim_err": null }), |r| {
        json!({ "rosenstein": r.data_rosenstein, "corr_dim": r.data_corr_dim, "corr_dim_err": r.data_corr_dim_err })
    });
    let (dc, de) = (data["corr_dim"].as_f64().unwrap_or(f64::NAN), data["corr_dim_err"].as_f64().unwrap_or(f64::NAN));
    let d2 = col(&at_step, |r| r.corr_dim);
    let ratios: Vec<f64> =
        at_step.iter().filter(|r| chaotic(r)).filter_map(|r| Some(r.rosenstein? / r.benettin?)).collect();
    let one: Vec<&SearchRow> = rows.iter().filter(|r| token(&r.candidate, "k=") == Some(1)).collect();
    let mut names: Vec<String> = Vec::new();
    for r in rows {
        if let Some(v) = variant(&r.candidate).filter(|v| !names.contains(v)) {
            names.push(v);
        }
    }
    let variants: Vec<serde_json::Value> = names
        .iter()
        .map(|n| {
            let g: Vec<&SearchRow> = rows.iter().filter(|r| variant(&r.candidate).as_ref() == Some(n)).collect();
            json!({ "what": n, "rows": g.len(), "chaotic": g.iter().filter(|r| chaotic(r)).count(),
                    "failed": g.iter().filter(|r| failed(r)).count(), "benettin": range(&col(&g, |r| r.benettin)),
                    "corr_dim": range(&col(&g, |r| r.corr_dim)), "js": range(&col(&g, |r| r.js)) })
        })
        .collect();
    json!({
        "one_sample": { "rows": one.len(), "chaotic": one.iter().filter(|r| chaotic(r)).count() },
        "dim": dim, "steps": steps, "step": step, "data": data, "targets": chaos::Targets::default(),
        "chaotic": { "benettin": range(&col(&at_step, |r| r.benettin)), "js_max": col(&at_step, |r| r.js).into_iter().fold(f64::NAN, f64::max),
                     "ratio": range(&ratios), "corr_dim": range(&d2),
                     "corr_dim_in_bar": d2.iter().filter(|v| (*v - dc).abs() <= de).count() },
        "variants": variants,
        "noise_rel": chaos_study::calibration::FLAG_SAMPLING.noise_rel,
    })
}

/// The model-selection tables: the candidates of each data set with their held-out long-term
/// statistics and the pick, then the inverted-flag candidate search behind the flag's
/// candidates (`ssmctl study studies/flag-first-search.toml`, read from `search.json`).
fn selection_tables(
    rep: &mut crate::report::Report,
    page: &mut Page,
    selections: &[(
        String,
        Vec<chaos_study::model_selection::CandidateResult>,
        chaos_study::model_selection::Selection,
    )],
    results: &chaos_study::study_results::FlagResults,
    quick: bool,
) -> Result<(), Box<dyn Error>> {
    use serde_json::json;
    let es = chaos_study::model_selection::EvalSettings::default();
    let t = chaos::Targets::default();
    let setup = json!({
        "long_runs": es.long_runs, "region_factor": es.region_factor, "targets": t,
        "rollout_starts": chaos_study::model_selection::ROLLOUT_STARTS,
    });
    page.para("chaos/selection", setup);
    // A candidate's values as the table and the pick paragraph print them.
    let cand = |r: &chaos_study::model_selection::CandidateResult| {
        json!({ "name": r.name, "benettin": r.benettin, "benettin_err": r.benettin_err, "benettin_2nd": r.benettin_2nd,
                "rosenstein": r.rosenstein, "corr_dim": r.corr_dim, "js": r.js, "rollout": r.rollout,
                "failed": r.failed,
                "data": { "lle": r.data.lle, "corr_dim": r.data.corr_dim, "corr_dim_err": r.data.corr_dim_err } })
    };
    let mut rows = Vec::new();
    for (name, results, sel) in selections {
        for (i, r) in results.iter().enumerate() {
            rows.push(json!({ "set": name, "r": cand(r), "picked": sel.index == Some(i),
                              "horizon": chaos::rollout_horizon(r.data.theiler) }));
        }
    }
    page.table("chaos/candidates", serde_json::Value::Null, rows);
    for (name, results, sel) in selections {
        let failed = results.iter().filter(|r| r.failed.is_some()).count();
        let pick = sel.index.and_then(|i| results.get(i)).map(|r| {
            let keys = ["benettin", "rosenstein", "corr_dim", "js"];
            let met: Vec<&str> = keys.iter().zip(r.passes(&t)).filter(|(_, ok)| *ok).map(|(k, _)| *k).collect();
            // Chaos of the data (Rosenstein above the margin 0 of `evaluate_and_select_known`) and of the pick.
            let (data_chaotic, model_chaotic) = (r.data.lle > 0.0, chaos::is_chaotic(r.benettin, r.benettin_err));
            let warning = match (data_chaotic, model_chaotic) {
                (true, false) => "data_chaotic",
                (false, true) => "model_chaotic",
                _ => "none",
            };
            json!({ "r": cand(r), "met_count": met.len(), "met": met, "targets": keys.len(), "score": r.score(&t),
                    "warning": warning })
        });
        if pick.as_ref().is_some_and(|p| (p["warning"] == "none") != sel.warnings.is_empty()) {
            return Err(format!("chaos: {name}: the pick's warnings {:?} are not the page's", sel.warnings).into());
        }
        page.para(
            "chaos/pick",
            json!({ "set": name, "pick": pick, "failed": failed, "total": results.len(), "targets": t }),
        );
    }
    let runs = json!({ "train": results.held_out.train_runs, "test": results.held_out.test_run });
    page.para("chaos/search-intro", runs);
    let rows = results.search.rows.iter().map(|r| json!({ "r": r, "failed": r.failed })).collect();
    page.table("chaos/search", serde_json::Value::Null, rows);
    let shows = search_findings(&results.search.rows, chaos_study::flag_self::STEP, FLAG_DIM);
    page.para("chaos/search-findings", shows);
    estimator_bias(rep, page, results, quick)?;
    flag_pipeline_check(rep, page, results, quick)
}

/// How the pick of one data set was made, over its values (`set`, the pick `pick` with its
/// candidate `r`, the targets it met, its score and which chaos warning it gets; `failed`
/// of `total` candidates), as [`chaos_study::model_selection::select`] says it.
pub const PICK: &str = "{% macro o(v) %}{% if v is none %}-{% else %}{{ v | fixed(3) }}{% endif %}{% endmacro %}\
    {% macro tname(k) %}{% if k == 'benettin' %}Benettin within {{ targets.benettin_rel | pct(0) }} %\
    {% elif k == 'rosenstein' %}Rosenstein within {{ targets.rosenstein_rel | pct(0) }} %{% elif k == 'corr_dim' %}D2 \
    within the data's error bar{% else %}JS within bound{% endif %}{% endmacro %}\
    {{ set | esc }}: picked {% if pick is none %}none. all {{ total }} candidates failed (escape, left the data's region \
    or fit error) <b>Warning:</b> no model: every candidate failed.{% else %}{{ pick.r.name | esc }}. \
    {{ pick.r.name | esc }} meets {{ pick.met_count }} of {{ pick.targets }} targets ({% for k in pick.met %}\
    {{ tname(k) }}{% if not loop.last %}, {% endif %}{% else %}none{% endfor %}) with normalized error \
    {{ pick.score | fixed(2) }}: Benettin {{ o(pick.r.benettin) }} 1/s, Rosenstein {{ o(pick.r.rosenstein) }} vs data \
    {{ pick.r.data.lle | fixed(3) }} 1/s, D2 {{ o(pick.r.corr_dim) }} vs {{ pick.r.data.corr_dim | fixed(2) }} +- \
    {{ pick.r.data.corr_dim_err | fixed(2) }}, JS {{ o(pick.r.js) }}; {{ failed }} of {{ total }} candidates failed\
    {% if pick.warning == 'data_chaotic' %} <b>Warning:</b> the data look chaotic (Rosenstein \
    {{ pick.r.data.lle | fixed(3) }} 1/s) but the best model is not (Benettin {{ o(pick.r.benettin) }} +- \
    {{ o(pick.r.benettin_err) }} 1/s): its irregularity is not reproduced by its own dynamics.\
    {% elif pick.warning == 'model_chaotic' %} <b>Warning:</b> the best model is chaotic (Benettin \
    {{ o(pick.r.benettin) }} 1/s) but the data do not look so (Rosenstein {{ pick.r.data.lle | fixed(3) }} 1/s).\
    {% endif %}{% endif %}";

/// The Rosenstein estimator's bias on the chaotic candidates of the flag search
/// ([`chaos_study::model_selection::flag_search_ratios`]): the ratio on the models that match the
/// data's D2 and PDFs best, the data's exponent it implies, and the ratio range in which the
/// two exponent targets can hold together; then the estimator calibrated on known answers
/// sampled like the flag ([`chaos_study::calibration`]). Summary key `flag_estimator_bias`
/// (`calibration`: the sampling, the rows and their summary).
fn estimator_bias(
    rep: &mut crate::report::Report,
    page: &mut Page,
    results: &chaos_study::study_results::FlagResults,
    quick: bool,
) -> Result<(), Box<dyn Error>> {
    use chaos::Targets;
    use chaos_study::model_selection::{BEST_MATCH_D2, BEST_MATCH_JS, best_matching, flag_search_ratios};
    let rows = flag_search_ratios(&results.search);
    let (lo, hi) = Targets::default().joint_ratio_range();
    let best = best_matching(&rows);
    let range = |f: &dyn Fn(&&chaos_study::model_selection::RatioRow) -> f64| {
        best.iter().map(f).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)))
    };
    let (r_lo, r_hi) = range(&|r| r.ratio);
    let (e_lo, e_hi) = range(&|r| r.implied_data_exponent);
    let in_range: Vec<_> = rows.iter().filter(|r| r.ratio >= lo && r.ratio <= hi).collect();
    let inside = in_range.len();
    let inside_close = in_range.iter().filter(|r| (r.corr_dim - r.data_corr_dim).abs() <= BEST_MATCH_D2).count();
    let t = Targets::default();
    page.para(
        "chaos/bias",
        serde_json::json!({
            "rows": rows.len(), "best": best.iter().map(|r| &r.candidate).collect::<Vec<_>>(), "best_count": best.len(),
            "data_corr_dim": best.first().map(|r| r.data_corr_dim), "d2": BEST_MATCH_D2, "js": BEST_MATCH_JS,
            "ratio": [r_lo, r_hi], "exponent": [e_lo, e_hi], "joint": [lo, hi], "targets": t,
            "inside": inside, "inside_close": inside_close,
        }),
    );
    let calibration = estimator_calibration(page, quick, (!best.is_empty()).then_some([r_lo, r_hi]))?;
    rep.summary.insert(
        "flag_estimator_bias".into(),
        serde_json::json!({
            "joint_ratio_range": [lo, hi],
            "best_matching": best,
            "best_ratio_range": if best.is_empty() { serde_json::Value::Null } else { serde_json::json!([r_lo, r_hi]) },
            "implied_data_exponent": if best.is_empty() { serde_json::Value::Null } else { serde_json::json!([e_lo, e_hi]) },
            "chaotic_rows": rows.len(),
            "rows_in_joint_range": inside,
            "rows_in_joint_range_near_data_d2": inside_close,
            "calibration": calibration,
        }),
    );
    Ok(())
}

/// The estimator-bias paragraph over `estimator_bias`'s values: the chaotic rows of the search
/// (`rows`), the ones closest to the data (`best`, matched within `d2` and `js`), their ratio
/// and the data exponent it implies, the joint ratio range of the targets and the rows in it.
pub const BIAS: &str = "{% if best_count == 0 %}Estimator bias: no chaotic candidate of the search matches the data's D2 \
    (within {{ d2 | plain }}) and PDFs (JS <= {{ js | plain }}).{% else %}Estimator bias, computed from the search \
    table: Rosenstein / Benettin over the {{ rows }} chaotic rows; the {{ best_count }} one-step models closest to the \
    data (D2 within {{ d2 | plain }} of {{ data_corr_dim | fixed(2) }}, JS <= {{ js | plain }}: {% for c in best %}\
    {{ c | esc }}{% if not loop.last %}; {% endif %}{% endfor %}) read {{ ratio[0] | fixed(2) }} to \
    {{ ratio[1] | fixed(2) }}. If the estimator is as biased on the data, the data's exponent is \
    {{ exponent[0] | fixed(2) }} to {{ exponent[1] | fixed(2) }} 1/s, not its Rosenstein value. Benettin within \
    {{ targets.benettin_rel | pct(0) }} % and Rosenstein within {{ targets.rosenstein_rel | pct(0) }} % of the data's \
    number hold together only for a ratio in [{{ joint[0] | fixed(3) }}, {{ joint[1] | fixed(3) }}]: {{ inside }} \
    chaotic rows are in it, {{ inside_close }} of them with D2 within {{ d2 | plain }} of the data's.{% endif %}";

/// The Rosenstein estimator on known answers sampled like the flag (lag, length, noise), its
/// table and paragraph; returns the summary's `calibration` value. Quick: 4 segments per
/// system, else 8.
fn estimator_calibration(
    page: &mut Page,
    quick: bool,
    models_ratio: Option<[f64; 2]>,
) -> Result<serde_json::Value, Box<dyn Error>> {
    use chaos_study::calibration::{CALM_PER_LAG, FLAG_SAMPLING, calibration_rows, summarize};
    let f = FLAG_SAMPLING;
    let rows = calibration_rows(&f, &[0.0, 1.0], if quick { 4 } else { 8 })?;
    let setup = serde_json::json!({ "flag": f, "flag_per_lag": f.lle * f.lag as f64 * f.dt });
    page.para("chaos/calibration", setup);
    page.table(
        "chaos/calibration",
        serde_json::Value::Null,
        rows.iter().map(|r| serde_json::json!({ "r": r })).collect(),
    );
    let summary = summarize(&rows, &f);
    if let Some(s) = &summary {
        // The systems of each regime at the flag's noise level, and their D2 (noise-free rows).
        let regime = |calm: bool| {
            let at: Vec<_> = rows
                .iter()
                .filter(|r| r.noise_rel == f.noise_rel && r.ratio_mean.is_some() && (r.per_lag <= CALM_PER_LAG) == calm)
                .collect();
            let mut names: Vec<String> = Vec::new();
            for r in &at {
                if !names.contains(&r.system) {
                    names.push(r.system.clone());
                }
            }
            let d2: Vec<f64> = rows
                .iter()
                .filter(|r| r.noise_rel == 0.0 && names.contains(&r.system))
                .filter_map(|r| r.corr_dim)
                .collect();
            let (lo, hi) = d2.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
            serde_json::json!({ "systems": names, "corr_dim": if d2.is_empty() { serde_json::Value::Null } else { serde_json::json!([lo, hi]) } })
        };
        let v = serde_json::json!({
            "calm_per_lag": CALM_PER_LAG, "s": s, "calm": regime(true), "chaotic": regime(false),
            "models_ratio": models_ratio, "targets": chaos::Targets::default(),
        });
        page.para("chaos/calibration-says", v);
    }
    Ok(serde_json::json!({ "sampling": f, "rows": rows, "summary": summary }))
}

/// The scale table's header and cells over one row `r` of one study `s` of `chaos_scale`.
const SCALE_HEADER: [&str; 9] =
    ["data", "eps", "eps / unit", "unit", "LLE Kantz [1/s]", "fit window [s]", "rise [nats]", "neighbours", "note"];
const SCALE_CELLS: [&str; 9] = [
    "{{ s.name }}",
    "{{ r.eps | sci(3) }}",
    "{{ r.eps_units | fixed(3) }}",
    "{{ s.unit_name }}",
    "{{ r.exponent | fixed_or(3, '-') }}",
    "{% if r.window_s is none %}-{% else %}{{ r.window_s[0] | fixed(2) }}..{{ r.window_s[1] | fixed(2) }}{% endif %}",
    "{{ r.rise | fixed_or(2, '-') }}",
    "{{ r.mean_neighbours | fixed(1) }}",
    "{{ r.note }}",
];

/// The accuracy-vs-cost table's header and cells over one row `r` of `chaos_cost.rows`.
const COST_HEADER: [&str; 11] = [
    "model",
    "centres / order",
    "LLE Rosenstein [1/s]",
    "|LLE model - LLE data|",
    "LLE Benettin [1/s]",
    "JS [bits]",
    "fit [s]",
    "step [us]",
    "fit ratio",
    "step ratio",
    "notes",
];
const COST_CELLS: [&str; 11] = [
    "{{ r.kind }}",
    "{{ r.setting }}",
    "{{ r.lle_rosenstein | fixed_or(3, '-') }}",
    "{{ r.lle_abs_error | fixed_or(3, '-') }}",
    "{{ r.lle_benettin | fixed_or(3, '-') }}",
    "{{ r.pdf_js | fixed_or(3, '-') }}",
    "{{ r.fit_s | fixed(3) }}",
    "{{ r.step_us | fixed(2) }}",
    "{{ r.fit_ratio | fixed(2) }}",
    "{{ r.step_ratio | fixed(2) }}",
    "{{ r.notes | join('; ') }}",
];

/// The scale section's introduction over Kantz's settings ([`chaos_study::chaos_tables`]).
pub const SCALE_INTRO: &str = "Kantz's estimator (embedding dimension {{ embed }}, lag = first zero of the \
    autocorrelation, Theiler window = dominant period, at most {{ references }} references with {{ neighbours }} \
    neighbours each) at {{ scales }} log-spaced neighbourhood radii. In a quantized loop, states closer than one \
    quantization step receive the same control codes and separate at the open-loop rate; the microchaotic rate appears \
    only at scales of a few steps and above.";

/// The accuracy-vs-cost section's introduction over its models' SSM dimension.
pub const COST_INTRO: &str = "SSM models of dimension {{ dim }}: |LLE model - LLE data| with the same Rosenstein settings \
    on both series, the map's own Benettin exponent, mean Jensen-Shannon divergence of the reduced-coordinate PDFs, wall \
    time of the fit and per reduced-map step (this machine, single run), and the time ratios to the smallest \
    configuration.";

/// Report section with the scale table: summary keys `chaos_scale` (the studies) and
/// `page_chaos_scale` (Kantz's settings), the page written from them ([`scale_render`]).
pub fn scale_section(
    rep: &mut crate::report::Report,
    data_dir: &std::path::Path,
    quick: bool,
) -> Result<(), Box<dyn Error>> {
    let setup = serde_json::json!({
        "embed": SCALE_EMBED, "references": KANTZ_REFERENCES, "neighbours": KANTZ_NEIGHBOURS, "scales": SCALES,
    });
    let studies = scale_studies(data_dir, if quick { 6000 } else { 30000 })?;
    rep.summary.insert("chaos_scale".into(), serde_json::to_value(&studies)?);
    rep.summary.insert("page_chaos_scale".into(), setup);
    scale_render(rep, &serde_json::Value::Object(rep.summary.clone()))
}

/// The summary value at `key` of `s`, or an error naming it.
fn key<'a>(s: &'a serde_json::Value, key: &str) -> Result<&'a serde_json::Value, String> {
    s.get(key).ok_or_else(|| format!("report: summary lacks `{key}`"))
}

/// Writes the scale section from the summary `s` (`chaos_scale`, `page_chaos_scale`).
pub fn scale_render(rep: &mut crate::report::Report, s: &serde_json::Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    rep.section(
        "chaos-scale",
        "Scale dependence of the time-series Lyapunov exponent",
        &p.html("chaos-scale/intro", SCALE_INTRO, key(s, "page_chaos_scale")?)?,
    );
    let studies = key(s, "chaos_scale")?.as_array().ok_or("report: chaos_scale is not a list")?;
    let items: Vec<serde_json::Value> = studies
        .iter()
        .flat_map(|st| st["rows"].as_array().into_iter().flatten().map(move |r| serde_json::json!({ "s": st, "r": r })))
        .collect();
    rep.table(&SCALE_HEADER, &p.rows("chaos-scale/row", &SCALE_CELLS, &items)?);
    Ok(())
}

/// Report section with the accuracy-vs-cost table: summary keys `chaos_cost` (the study,
/// when the flag data are there) and `page_chaos_cost` (the models' dimension, whether the
/// data were found), the page written from them ([`cost_render`]).
pub fn cost_section(rep: &mut crate::report::Report, data_dir: &std::path::Path) -> Result<(), Box<dyn Error>> {
    let study = flag_cost_study(data_dir)?;
    if let Some(st) = &study {
        rep.summary.insert("chaos_cost".into(), serde_json::to_value(st)?);
    }
    rep.summary.insert("page_chaos_cost".into(), serde_json::json!({ "dim": COST_DIM, "found": study.is_some() }));
    cost_render(rep, &serde_json::Value::Object(rep.summary.clone()))
}

/// Writes the accuracy-vs-cost section from the summary `s` (`page_chaos_cost`, `chaos_cost`).
pub fn cost_render(rep: &mut crate::report::Report, s: &serde_json::Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    let page = key(s, "page_chaos_cost")?;
    rep.section(
        "chaos-cost",
        "Model accuracy against cost (inverted flag)",
        &p.html("chaos-cost/intro", COST_INTRO, page)?,
    );
    if page["found"].as_bool() != Some(true) {
        rep.para("Inverted-flag data not found: skipped.");
        return Ok(());
    }
    let st = key(s, "chaos_cost")?;
    rep.para(&p.html("chaos-cost/data", "Data exponent (Rosenstein): {{ lle_data | fixed(3) }} 1/s.", st)?);
    let items: Vec<serde_json::Value> = st["rows"]
        .as_array()
        .ok_or("report: chaos_cost.rows is not a list")?
        .iter()
        .map(|r| serde_json::json!({ "r": r }))
        .collect();
    rep.table(&COST_HEADER, &p.rows("chaos-cost/row", &COST_CELLS, &items)?);
    Ok(())
}

/// The flag's model search on a known chaotic system sampled like the flag
/// ([`chaos_study::flag_pipeline`]): the system as the data settings read it (computed here, over 8
/// held-out-length pieces; quick: a shorter Benettin run) and the committed candidate rows
/// (`studies/results/flag/known_system.json`, written by `ssmctl study studies/flag-known-system.toml`). Summary key
/// `flag_pipeline_check`.
fn flag_pipeline_check(
    rep: &mut crate::report::Report,
    page: &mut Page,
    results: &chaos_study::study_results::FlagResults,
    quick: bool,
) -> Result<(), Box<dyn Error>> {
    use chaos_study::flag_pipeline::{CHOSEN, FLAG_LAYOUT, known_stats, segment_stats, summarize};
    let (k, series) = known_stats(&CHOSEN, &FLAG_LAYOUT, 1, if quick { 1000.0 } else { 4000.0 })?;
    let seg = segment_stats(&CHOSEN, k.dt, &FLAG_LAYOUT, 8)?;
    let mut scales: Vec<usize> = results.known.check_rows().iter().map(|r| r.scale).collect();
    scales.sort_unstable();
    scales.dedup();
    let fs = chaos_study::calibration::FLAG_SAMPLING;
    let fit = chaos_study::flag_pipeline::flag_like_candidates(FLAG_LAYOUT.step, &[])
        .first()
        .map(|c| c.fit)
        .ok_or("flag_like_candidates gave no candidate")?;
    let v = serde_json::json!({
        "system": k, "pieces": seg, "segments": seg.corr_dims.len(), "layout": FLAG_LAYOUT, "scales": scales,
        "ratios": seg.rosensteins.iter().map(|r| r.map(|r| r / k.exact)).collect::<Vec<_>>(),
        "flag": { "lag": fs.lag, "theiler": fs.theiler, "per_lag": fs.lle * fs.lag as f64 * fs.dt },
        "fit": { "dim": fit.dim, "embed": fit.embed, "shift": fit.shift, "manifold_order": fit.manifold_order },
    });
    page.para("chaos/pipeline-check", v);
    let rows = results.known.check_rows();
    page.table("chaos/pipeline", serde_json::json!({ "targets": chaos::Targets::default() }), pipeline_items(&rows));
    let mut scales: Vec<usize> = rows.iter().map(|r| r.scale).collect();
    scales.sort_unstable();
    scales.dedup();
    let summaries: Vec<_> = scales.iter().map(|&s| summarize(&rows, s)).collect();
    let v = pipeline_conclusion(&rows, &summaries, &k, &seg, &fit);
    page.para("chaos/pipeline-does", v);
    rep.summary.insert(
        "flag_pipeline_check".into(),
        serde_json::json!({
            "system": k,
            "pieces": seg,
            "layout": FLAG_LAYOUT,
            "committed_data": results.known.data,
            "rows": rows,
            "summary": summaries,
        }),
    );
    flag_pipeline_fit(rep, page, results, &series)
}

/// The table items of pipeline rows: the row and the count of targets it met of all.
fn pipeline_items(rows: &[PipelineRow]) -> Vec<serde_json::Value> {
    rows.iter()
        .map(|r| {
            serde_json::json!({ "r": r, "met": r.passes.iter().filter(|&&p| p).count(), "targets": r.passes.len() })
        })
        .collect()
}

/// The pipeline check's introduction over the known system's statistics (`system`, `pieces`),
/// the flag's layout and sampling, the candidates' fit settings and the data scales.
pub const PIPELINE_CHECK: &str = "{% macro o(v, n) %}{% if v is none %}-{% else %}{{ v | fixed(n) }}{% endif %}{% endmacro %}\
    Pipeline on a known chaotic system like the flag: {{ system.system }} (exact exponent by Benettin with the exact \
    tangent dynamics), sampled at {{ system.dt | fixed(5) }} s so that the data settings pick the flag's lag at map \
    step {{ layout.step }}; two training series and one held-out series of the flag's lengths ({{ layout.train[0] }} + \
    {{ layout.train[1] }} and {{ layout.test }} samples, or {% for s in scales[1:] %}{{ s }}{% if not loop.last %} and \
    {% endif %}{% endfor %} times longer training series), white noise at the flag's level \
    ({{ system.noise_rel | pct(2) }} % of each series' sd); then exactly the flag's candidate search (SSM dimension \
    {{ fit.dim }}, embedding {{ fit.embed }}, shift {{ fit.shift }}, manifold order {{ fit.manifold_order }}, RBF maps \
    with the flag search's centres and ridges, the polynomial map) and estimators. Example: <code>cargo run --release \
    -p lab --example flag_pipeline -- scan</code> (the systems) and {% for s in scales %}<code>check {{ s }}</code>\
    {% if not loop.last %} / {% endif %}{% endfor %} (the rows below). The system, held-out series: lag \
    {{ system.lag }} / Theiler window {{ system.theiler }} (the flag: {{ flag.lag }} / {{ flag.theiler }}), D2 \
    {{ system.corr_dim | fixed(2) }} ± {{ system.corr_dim_err | fixed(2) }}, Rosenstein {{ system.rosenstein | fixed(3) }} \
    1/s; exact exponent {{ system.exact | fixed(3) }} ± {{ system.exact_err | fixed(3) }} 1/s, \
    {{ system.per_lag | fixed(2) }} nats per lag (the flag: {{ flag.per_lag | fixed(2) }} at its Rosenstein value). \
    Over {{ segments }} held-out-length pieces of one orbit D2 reads {{ o(pieces.corr_dim_mean, 2) }} \
    ± {{ o(pieces.corr_dim_sd, 2) }} ({% for d in pieces.corr_dims %}{{ o(d, 2) }}{% if not loop.last %}, \
    {% endif %}{% endfor %}) and Rosenstein / exact {% for q in ratios %}{{ o(q, 2) }}{% if not loop.last %}, \
    {% endif %}{% endfor %}.";

/// The table header of the rows' Benettin check against the exact exponent, over the targets.
const WITHIN_EXACT: &str = "Benettin within {{ targets.benettin_rel | pct(0) }} % of exact";

/// The projection's false nearest neighbours and the dimension rule, over the embedding
/// (`embed`, `shift`, map `step`), the projections (`proj` at `dims`), the rule (`ratio`,
/// `max_fnn`, `max_dim`) and its result (`rule_dim`, `rows`).
pub const FNN: &str = "Why the fit misses it (example <code>flag_pipeline -- fnn | fnn-rule | variants | state</code>). \
    Is the SSM's linear projection one-to-one? Projected on its first d singular directions, the flag's embedding of \
    the system's first training series ({{ embed }} samples, shift {{ shift }}, map step {{ step }}) has \
    {% for r in proj %}{{ r.fnn | pct(1) }} %{% if not loop.last %}, {% endif %}{% endfor %} false nearest \
    neighbours (a neighbour whose distance in the discarded directions exceeds {{ ratio | plain }} times the projected \
    one) at d = {{ dims | plain }}. The dimension rule (the smallest d whose projection of the embedding p = 2d + 1 has \
    at most {{ max_fnn | pct(1) }} % false neighbours) gives {% if rule_dim is none %}no d up to {{ max_dim }}\
    {% else %}d = {{ rule_dim }}{% endif %}: {% for r in rows %}d = {{ r.dim }} (p = {{ 2 * r.dim + 1 }}) \
    {{ r.fnn | pct(1) }} %{% if not loop.last %}, {% endif %}{% endfor %}.";

/// `, ` between the items of a list and ` and ` before its last, from the loop's `revindex`.
pub const SEP: &str = "{% macro sep(r) %}{% if r == 2 %} and {% elif r > 2 %}, {% endif %}{% endmacro %}";

/// What the pipeline does per data amount and what the check concludes, over
/// [`pipeline_conclusion`] (with [`SEP`]).
pub const PIPELINE_DOES: &str = "What the pipeline does on it: {% for s in summaries %}with {{ s.scale }}x the flag's \
    training data {{ s.chaotic }} of {{ s.candidates }} candidates chaotic (Benettin / exact \
    {% if s.benettin_over_exact is none %}-{% elif s.benettin_over_exact[0] == s.benettin_over_exact[1] %}\
    {{ s.benettin_over_exact[0] | fixed(2) }}{% else %}{{ s.benettin_over_exact[0] | fixed(2) }}-\
    {{ s.benettin_over_exact[1] | fixed(2) }}{% endif %}), {{ s.benettin_within_10pct_of_exact }} within \
    {{ targets.benettin_rel | pct(0) }} % of the exact exponent, {{ s.exact_d2_js }} of them also with D2 in the data's \
    error bar and JS <= {{ targets.js_max | plain }}, {{ s.failed }} failed; {{ s.all_four }} meet all the targets as \
    set on the flag{% if not loop.last %}; {% endif %}{% endfor %}. So on data made by a smooth system of exactly \
    {{ dim }} dimensions, with the flag's sampling, lengths, noise, D2 ({{ corr_dim_mean | fixed_or(1, '-') }} over \
    pieces) and chaos per lag, the flag's pipeline does not recover the system: most candidates escape or are not \
    chaotic ({% for s in scales %}{{ s.not_chaotic }} of {{ s.candidates }}{{ sep(loop.revindex) }}{% endfor %} at \
    {% for s in scales %}{{ s.scale }}x{{ sep(loop.revindex) }}{% endfor %} the flag's training data), the chaotic \
    ones read {{ ratio_range[0] | fixed(2) }} to {{ ratio_range[1] | fixed(2) }} times the exact exponent (a different \
    attractor at every RBF size and data amount), {% if exact_d2_js == 0 %}none{% else %}{{ exact_d2_js }}{% endif %} \
    has its exponent within {{ targets.benettin_rel | pct(0) }} % together with the data's D2 and PDFs, and \
    {% if all_four == 0 %}none{% else %}{{ all_four }}{% endif %} meets the targets. {% for s in scales[1:] %}\
    {{ s.scale }}{{ sep(loop.revindex) }}{% endfor %} times more training data do not make it better (the chaotic \
    models' Benettin / exact: {% for s in scales %}{% for q in s.ratios %}{{ q | fixed(2) }}{{ sep(loop.revindex) }}\
    {% endfor %} at {{ s.scale }}x{% if not loop.last %}; {% endif %}{% endfor %}). The Rosenstein number of one \
    held-out series is no firmer a reference here than on the flag: {{ held_ratio | fixed(2) }} of the exact exponent \
    on the held-out piece, {{ others_range[0] | fixed(2) }} to {{ others_range[1] | fixed(2) }} on the others. What \
    this measures: the failure on the flag is what this pipeline does on data like the flag's even when a smooth \
    {{ dim }}-dimensional model of the data exists (the system itself, a {{ dim }}-D flow, seen in a delay embedding of \
    {{ embed }} samples, Takens' bound for that dimension, with SSM dimension {{ dim }}: the flag settings); it is a \
    limit of the fit (one-step ridge regression on data this sparse and chaotic lands on a fragile, size-dependent \
    attractor), not evidence that no smooth reduced model of the flag exists, and not cured by the amount of data.";

/// The values of [`PIPELINE_DOES`], from the check's rows (`rows`, their per-scale
/// `summaries`) and the system's statistics (`k`, over pieces `seg`): per scale the
/// candidates not chaotic and the chaotic ones' Benettin / exact, and their ranges.
pub fn pipeline_conclusion(
    rows: &[chaos_study::flag_pipeline::PipelineRow],
    summaries: &[chaos_study::flag_pipeline::PipelineSummary],
    k: &chaos_study::flag_pipeline::KnownStats,
    seg: &chaos_study::flag_pipeline::SegmentStats,
    fit: &ssm::FitOptions,
) -> serde_json::Value {
    // The chaotic rows' Benettin / exact (chaotic as in `summarize`), per scale in row order.
    let chaotic_ratio = |r: &&chaos_study::flag_pipeline::PipelineRow| {
        r.failed.is_none() && r.benettin_over_exact.is_some_and(|q| q > 0.01)
    };
    let ratios: Vec<f64> = rows.iter().filter(chaotic_ratio).filter_map(|r| r.benettin_over_exact).collect();
    let (lo, hi) = ratios.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &q| (a.min(q), b.max(q)));
    let scales: Vec<serde_json::Value> = summaries
        .iter()
        .map(|s| {
            let v: Vec<f64> = rows
                .iter()
                .filter(|r| r.scale == s.scale)
                .filter(chaotic_ratio)
                .filter_map(|r| r.benettin_over_exact)
                .collect();
            serde_json::json!({ "scale": s.scale, "not_chaotic": s.candidates - s.chaotic, "candidates": s.candidates,
                                "ratios": v })
        })
        .collect();
    let others: Vec<f64> = seg.rosensteins.iter().skip(1).flatten().map(|r| r / k.exact).collect();
    let (o_lo, o_hi) = others.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &q| (a.min(q), b.max(q)));
    serde_json::json!({
        "summaries": summaries, "scales": scales, "targets": chaos::Targets::default(), "dim": fit.dim,
        "embed": fit.embed, "corr_dim_mean": seg.corr_dim_mean, "ratio_range": [lo, hi],
        "exact_d2_js": summaries.iter().map(|s| s.exact_d2_js).sum::<usize>(),
        "all_four": summaries.iter().map(|s| s.all_four).sum::<usize>(),
        "held_ratio": k.rosenstein / k.exact, "others_range": [o_lo, o_hi],
    })
}

/// Why the flag's fit misses the known system's chaos ([`chaos_study::flag_pipeline_fit`]): the
/// projection's false nearest neighbours and the dimension rule (computed here on the
/// known system's series), the committed diagnosis rows (`known_system.json` `diagnosis`;
/// one re-run by a test) and the flag's search at the rule's dimension
/// (`held_out.json` `fit`). Summary key `flag_pipeline_fit`.
pub fn flag_pipeline_fit(
    rep: &mut crate::report::Report,
    page: &mut Page,
    results: &chaos_study::study_results::FlagResults,
    series: &[ssm::TimeSeries],
) -> Result<(), Box<dyn Error>> {
    use chaos_study::flag_pipeline::FLAG_LAYOUT;
    use chaos_study::flag_pipeline_fit::{FNN_RULE, d6_scan_counts, fnn_dimension, projection_fnn};
    let held = &results.held_out;
    let train = chaos_study::model_selection::subsample(&series[0], FLAG_LAYOUT.step, 0)?;
    let ctx = chaos::Context::from_series(&train.x, train.dt().unwrap_or(1.0), 6)?;
    let (ratio, max_fnn) = FNN_RULE;
    let fit = chaos_study::flag_pipeline::flag_like_candidates(FLAG_LAYOUT.step, &[])
        .first()
        .map(|c| c.fit)
        .ok_or("flag_like_candidates gave no candidate")?;
    // The projections checked (SSM dimensions around the flag's), the rule's largest
    // dimension and the reference points of the neighbour search.
    let (dims, max_dim, points) = ([fit.dim - 1, fit.dim, fit.dim + 1, fit.dim + 2], 2 * fit.dim, 800);
    let proj = projection_fnn(&train.x, fit.embed, fit.shift, ctx.theiler, &dims, ratio, points)?;
    let (rule_dim, rule_rows) = fnn_dimension(&train.x, fit.shift, ctx.theiler, ratio, max_fnn, max_dim, points)?;
    let v = serde_json::json!({
        "embed": fit.embed, "shift": fit.shift, "step": FLAG_LAYOUT.step, "proj": proj, "dims": dims,
        "ratio": ratio, "max_fnn": max_fnn, "max_dim": max_dim, "rule_dim": rule_dim, "rows": rule_rows,
    });
    page.para("chaos/fnn", v);
    let diag = results.known.diagnosis_rows();
    let items =
        diag.iter().map(|(what, noise, r)| serde_json::json!({ "what": what, "noise": noise, "r": r })).collect();
    page.table("chaos/diagnosis", serde_json::json!({ "targets": chaos::Targets::default() }), items);
    let fnoise = chaos_study::calibration::FLAG_SAMPLING.noise_rel;
    let groups = diagnosis_groups(&diag);
    let flag = held.fit_rows();
    let noisy = noisy_state_values(&chaos_study::study_results::default_dir())?;
    let v = diagnosis_values(results, &diag, fit.embed, &noisy);
    page.para("chaos/diagnosis", v);
    // The multistep scan at d = 6 on the known system, and multistep on the flag.
    let scan = |ms: bool, scale: usize, noise: f64| d6_scan_counts(&diag, ms, scale, noise);
    let scan_cases = [("1x_flag_noise", 1, fnoise), ("3x_flag_noise", D6_SCALE, fnoise), ("1x_noise_free", 1, 0.0)];
    page.para("chaos/multistep", multistep_values(results, &diag));
    // Other RBF centre sets on the flag, and why D2 stays low (committed rows).
    use chaos_study::flag_pipeline_fit::target_counts;
    let fcs = held.centre_rows();
    let (cn, cfail, cb, cd, cj, cbj, cbdj) = target_counts(&fcs);
    page.para("chaos/centre-sets", centre_set_values(held, &fcs));
    // The experiment as its own model, the pick on a validation run, an ensemble (committed rows).
    let self_keys = flag_self_paragraphs(page, results, &fcs)?;
    rep.summary.insert(
        "flag_pipeline_fit".into(),
        serde_json::json!({
            "fnn_rule": { "ratio": ratio, "max_fnn": max_fnn, "theiler": ctx.theiler, "dim": rule_dim, "rows": rule_rows },
            "projection_fnn_p9": proj,
            "diagnosis": diag.iter().map(|(w, n, r)| serde_json::json!({ "varied": w, "noise_rel": n, "row": r })).collect::<Vec<_>>(),
            "noisy_state_realizations": noisy,
            "within_10pct_of_exact": groups.iter().map(|(n, (a, b))| (n.to_string(), serde_json::json!([a, b]))).collect::<serde_json::Map<_, _>>(),
            "flag": { "data": held.data, "rows": flag, "multistep_rows": held.multistep_rows(),
                "centre_rows": fcs, "centre_counts": { "rows": cn, "failed": cfail, "benettin": cb, "corr_dim": cd, "js": cj, "benettin_js": cbj, "benettin_corr_dim_js": cbdj },
                "kaplan_yorke": held.dimension,
                "corr_dim_runs": held.corr_dim_runs.iter().map(|r| r.corr_dim).collect::<Vec<_>>(),
                "corr_dim_smoothed_3_5_noise_added": [held.corr_dim_smoothed.smoothed_3, held.corr_dim_smoothed.smoothed_5, held.corr_dim_smoothed.noise_added],
                "model_noisy_corr_dim": held.model_noisy_corr_dim,
                "experiment_as_model": self_keys.0, "validation_pick": self_keys.1, "ensemble": self_keys.2 },
            "d6_multistep_scan": scan_cases.iter().map(|&(k, scale, noise)| {
                let (m, p) = (scan(true, scale, noise), scan(false, scale, noise));
                (k.to_string(), serde_json::json!({ "multistep": [m.0, m.1, m.2], "one_step": [p.0, p.1, p.2] }))
            }).collect::<serde_json::Map<_, _>>(),
        }),
    );
    Ok(())
}

/// The diagnosis groups of the larger SSM dimensions (as `known_system.json` names them) and
/// the larger training data of the second.
const D5: &str = "(b) d = 5";
const D6: &str = "(b) d = 6";
const D6_SCALE: usize = 3;

/// `lo to hi` of a `[lo, hi]` with `n` decimals, one value when they print alike, `-` for none
/// (the values from `span_of`).
pub const SPAN: &str = "{% macro span(r, n) %}{% if r is none %}-{% elif (r[0] | fixed(n)) == (r[1] | fixed(n)) %}\
    {{ r[0] | fixed(n) }}{% else %}{{ r[0] | fixed(n) }} to {{ r[1] | fixed(n) }}{% endif %}{% endmacro %}";

/// The range `[lo, hi]` of `v` for [`SPAN`] (negative zeros as 0), `null` when empty.
fn span_of(v: &[f64]) -> serde_json::Value {
    if v.is_empty() {
        return serde_json::Value::Null;
    }
    let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| (a.min(x + 0.0), b.max(x + 0.0)));
    serde_json::json!([lo, hi])
}

/// The diagnosis rows' groups: (name, (rows with Benettin within the target of exact, rows)).
fn diagnosis_groups(diag: &[(String, f64, PipelineRow)]) -> Vec<(&'static str, (usize, usize))> {
    let count = |f: &dyn Fn(&str, f64, usize) -> bool| {
        let sel: Vec<_> = diag.iter().filter(|(w, n, r)| f(w, *n, r.scale)).collect();
        (sel.iter().filter(|(_, _, r)| r.benettin_exact_ok).count(), sel.len())
    };
    let fnoise = chaos_study::calibration::FLAG_SAMPLING.noise_rel;
    vec![
        ("noise_free_d4", count(&|w, _, _| w == "(a) noise-free")),
        ("d5", count(&|w, _, _| w == D5)),
        ("d6_1x", count(&|w, n, s| w == D6 && n == fnoise && s == 1)),
        ("d6_3x", count(&|w, n, s| w == D6 && n == fnoise && s == D6_SCALE)),
        ("d6_noise_free", count(&|w, n, _| w == D6 && n == 0.0)),
        ("shift", count(&|w, _, _| w == "(b) shift")),
        ("whole_delay_vector", count(&|w, _, _| w == "(b) whole delay vector")),
        ("ridge", count(&|w, _, _| w == "ridge")),
        ("denoised_inputs", count(&|w, _, _| w == "denoised inputs")),
        ("multistep", count(&|w, _, _| w == "multistep")),
        ("true_state_noise_free", count(&|w, n, _| w == "(c) true state" && n == 0.0)),
        ("true_state_noisy", count(&|w, n, _| w == "(c) true state" && n > 0.0)),
    ]
}

/// What the diagnosis shows, over [`diagnosis_values`] (with [`SPAN`]).
pub const DIAGNOSIS: &str = "{% macro o(v, n) %}{% if v is none %}-{% else %}{{ v | fixed(n) }}{% endif %}{% endmacro %}\
    {% macro g(k) %}{{ groups[k][0] }}/{{ groups[k][1] }}{% endmacro %}\
    What the diagnosis shows (Benettin within {{ targets.benettin_rel | pct(0) }} % of the exact exponent, of the rows): \
    (a) noise-free data with the flag's settings: {{ g('noise_free_d4') }} (the noise is not the cause); (c) the same \
    RBF and polynomial maps fitted on the true state x1..x4 sampled at the map step: {{ g('true_state_noise_free') }} \
    noise-free ({{ span(state_ratio, 2) }} of exact, JS {{ span(state_js, 4) }}): the model class and the data amount \
    suffice; with the flag's noise on the state {{ g('true_state_noisy') }} in the table's realization of the noise, \
    and {{ noisy_state(noisy) }}; (b) the coordinates are what fails: rows \
    \"{{ d5 }}\": {{ g('d5') }}, \"{{ d6 }}\" (the rule's choice): {{ g('d6_1x') }} at the flag's data amount, \
    {{ g('d6_3x') }} at {{ d6_scale }}x it, but {{ g('d6_noise_free') }} on noise-free data (there the small singular \
    directions are fitted without the noise's regularization and the attractor moves again); wider shifts \
    {{ g('shift') }}, the whole {{ embed }}-sample delay vector without projection {{ g('whole_delay_vector') }}. Fixes \
    on the fit itself: a larger ridge (rows \"ridge\") {{ g('ridge') }} ({{ span(ridge_ratio, 2) }} of exact: the \
    regularization removes the chaos before it steadies the attractor); denoised inputs (errors in variables, moving \
    averages of the inputs) {{ g('denoised_inputs') }} (Benettin {{ span(denoised_ratio, 1) }} of exact: the smoothing \
    steepens the map), multistep refinement {{ g('multistep') }} (Benettin {{ span(multistep_ratio, 2) }} of exact, JS \
    {{ span(multistep_js, 4) }}). So a larger reduced dimension brings the exponent within \
    {{ targets.benettin_rel | pct(0) }} % for most RBF sizes at the flag's noise, but the fit in delay coordinates stays \
    fragile (one RBF size or data amount away from a wrong attractor), unlike the same fit on the true state. The \
    Rosenstein exponent of the model series is {{ span(state_rosenstein, 2) }} 1/s for the maps fitted on the true \
    state whose own exponent is within {{ targets.benettin_rel | pct(0) }} % of exact, against the held-out piece's \
    {{ known_rosenstein | fixed(3) }}: on one held-out-length piece the estimator is no firm reference (the pieces \
    above), so the Rosenstein and D2 targets cannot be met reliably even by an exact model. On the flag (train \
    {{ train | join(' + ') }}, held out {{ test }}, data Rosenstein {{ data.rosenstein | fixed(3) }} 1/s, D2 \
    {{ data.corr_dim | fixed(2) }} ± {{ data.corr_dim_err | fixed(2) }}) the larger dimensions of the study's fits \
    ({% for r in flag %}{{ r.candidate }}{% if not loop.last %}; {% endif %}{% endfor %}) give Benettin \
    {% for r in flag %}{{ o(r.benettin, 3) }}{% if not loop.last %}, {% endif %}{% endfor %} 1/s, Rosenstein \
    {% for r in flag %}{{ o(r.rosenstein, 3) }}{% if not loop.last %}, {% endif %}{% endfor %}, D2 \
    {% for r in flag %}{{ o(r.corr_dim, 2) }}{% if not loop.last %}, {% endif %}{% endfor %}, JS \
    {% for r in flag %}{{ o(r.js, 4) }}{% if not loop.last %}, {% endif %}{% endfor %}: targets met \
    {% for r in flag %}{{ r.met }}/{{ r.targets }}{% if not loop.last %}, {% endif %}{% endfor %}; the flag's own \
    dimension rule keeps d = {{ flag_dim }}, whose rows are the flag search's above.";

/// The noisy-state fits over realizations of the noise, in [`DIAGNOSIS`] (with [`SPAN`]): per
/// model the realizations with Benettin within the target of exact, median and range of
/// Benettin / exact and of D2 ([`noisy_state_values`]).
pub const NOISY_STATE: &str = "{% macro stat(s, n) %}{% if s is none %}-{% else %}{{ s.median | fixed(n) }} \
    ({{ span(s.range, n) }}){% endif %}{% endmacro %}\
    {% macro noisy_state(m) %}over {{ m.realizations }} realizations of that noise (<code>ssmctl study {{ m.spec }}</code>; \
    the median and the range over the realizations): \
    {% for r in m.models %}{{ r.model }} {{ r.within }}/{{ r.n }}{% if r.failed %} ({{ r.failed }} failed){% endif %}, \
    Benettin / exact {{ stat(r.ratio, 2) }}, D2 {{ stat(r.corr_dim, 2) }}{% if not loop.last %}; {% endif %}{% endfor %}; \
    against the held-out piece's D2 of {{ m.data_corr_dim | fixed(2) }} ± {{ m.data_corr_dim_err | fixed(2) }}, one \
    noisy-state row is one draw of the noise{% endmacro %}";

/// The values of [`NOISY_STATE`] from the noise-realization rows in `dir`
/// ([`chaos_study::study_results::NOISE_REALIZATIONS`]): the rows grouped by model (the name
/// without ` seed N`), in their order. Summary key `flag_pipeline_fit.noisy_state_realizations`.
pub fn noisy_state_values(dir: &std::path::Path) -> Result<serde_json::Value, Box<dyn Error>> {
    use chaos_study::study_results::{KnownSystemResults, NOISE_REALIZATIONS, read};
    let path = dir.join(NOISE_REALIZATIONS);
    let r: KnownSystemResults = read(&path)?;
    let rows = r.diagnosis_rows();
    let split = |name: &str| {
        name.rsplit_once(" seed ").map_or((name.to_string(), "0".to_string()), |(m, s)| (m.to_string(), s.to_string()))
    };
    let (mut models, mut seeds): (Vec<String>, Vec<String>) = (Vec::new(), Vec::new());
    for (_, _, row) in &rows {
        let (m, seed) = split(&row.candidate);
        if !models.contains(&m) {
            models.push(m);
        }
        if !seeds.contains(&seed) {
            seeds.push(seed);
        }
    }
    if models.is_empty() {
        return Err(format!("{}: no diagnosis rows", path.display()).into());
    }
    // Median and range of `v` (`null` when empty).
    let stat = |mut v: Vec<f64>| {
        if v.is_empty() {
            return serde_json::Value::Null;
        }
        v.sort_by(f64::total_cmp);
        let k = v.len() / 2;
        let median = if v.len().is_multiple_of(2) { 0.5 * (v[k - 1] + v[k]) } else { v[k] };
        serde_json::json!({ "median": median, "range": span_of(&v) })
    };
    let per_model: Vec<serde_json::Value> = models
        .iter()
        .map(|m| {
            let sel: Vec<&PipelineRow> =
                rows.iter().map(|(_, _, r)| r).filter(|r| split(&r.candidate).0 == *m).collect();
            serde_json::json!({
                "model": m,
                "n": sel.len(),
                "failed": sel.iter().filter(|r| r.failed.is_some()).count(),
                "within": sel.iter().filter(|r| r.benettin_exact_ok).count(),
                "ratio": stat(sel.iter().filter_map(|r| r.benettin_over_exact).collect()),
                "corr_dim": stat(sel.iter().filter_map(|r| r.corr_dim).collect()),
            })
        })
        .collect();
    let spec = r.produced_by.strip_prefix("ssmctl study ").unwrap_or(&r.produced_by);
    Ok(serde_json::json!({
        "spec": spec, "realizations": seeds.len(), "models": per_model,
        "data_corr_dim": r.data.corr_dim, "data_corr_dim_err": r.data.corr_dim_err,
    }))
}

/// The values of [`DIAGNOSIS`]: the groups' counts (`diagnosis_groups`), the ranges of their
/// rows' Benettin / exact, JS and Rosenstein, the noisy-state fits over noise realizations
/// (`noisy`, [`noisy_state_values`]) and the flag's fits at the larger dimensions.
pub fn diagnosis_values(
    results: &chaos_study::study_results::FlagResults,
    diag: &[(String, f64, PipelineRow)],
    embed: usize,
    noisy: &serde_json::Value,
) -> serde_json::Value {
    use serde_json::json;
    let field = |sel: &dyn Fn(&str, f64) -> bool, f: &dyn Fn(&PipelineRow) -> Option<f64>| {
        span_of(&diag.iter().filter(|(w, n, _)| sel(w, *n)).filter_map(|(_, _, r)| f(r)).collect::<Vec<_>>())
    };
    let b_e = |r: &PipelineRow| r.benettin_over_exact;
    let js = |r: &PipelineRow| r.js;
    let state_free = |w: &str, n: f64| w == "(c) true state" && n == 0.0;
    let held = &results.held_out;
    let flag_data = held.data.tuple();
    let groups: serde_json::Map<String, serde_json::Value> =
        diagnosis_groups(diag).into_iter().map(|(k, (a, b))| (k.to_string(), json!([a, b]))).collect();
    let flag: Vec<serde_json::Value> = held
        .fit_rows()
        .iter()
        .map(|r| {
            json!({ "candidate": r.candidate, "benettin": r.benettin, "rosenstein": r.rosenstein,
                    "corr_dim": r.corr_dim, "js": r.js, "met": r.passes.iter().filter(|&&p| p).count(),
                    "targets": r.passes.len() })
        })
        .collect();
    json!({
        "targets": chaos::Targets::default(), "groups": groups, "d5": D5, "d6": D6, "d6_scale": D6_SCALE,
        "embed": embed, "flag_dim": FLAG_DIM,
        "state_ratio": field(&state_free, &b_e), "state_js": field(&state_free, &js),
        "ridge_ratio": field(&|w, _| w == "ridge", &b_e),
        "denoised_ratio": field(&|w, _| w == "denoised inputs", &b_e),
        "multistep_ratio": field(&|w, _| w == "multistep", &b_e), "multistep_js": field(&|w, _| w == "multistep", &js),
        "state_rosenstein": span_of(
            &diag
                .iter()
                .filter(|(w, _, r)| w == "(c) true state" && r.benettin_exact_ok)
                .filter_map(|(_, _, r)| r.rosenstein)
                .collect::<Vec<_>>(),
        ),
        "known_rosenstein": results.known.data.rosenstein,
        "noisy": noisy,
        "train": held.train_runs, "test": held.test_run,
        "data": { "rosenstein": flag_data.0, "corr_dim": flag_data.1, "corr_dim_err": flag_data.2 },
        "flag": flag,
    })
}

/// The SSM dimension of the known system's multistep scan (rows `d = 6 scan`, candidates `d=6`).
const SCAN_DIM: usize = 6;
/// The model whose fits on other realizations of the series (`seed N` candidates) are compared.
const SEED_MODEL: &str = "RBF 250";

/// The multistep paragraph, over [`multistep_values`] (with [`SPAN`]).
pub const MULTISTEP: &str = "{% macro o(v, n) %}{% if v is none %}-{% else %}{{ v | fixed(n) }}{% endif %}{% endmacro %}\
    {% macro list(k, n) %}{% for r in flag %}{{ o(r[k], n) }}{% if not loop.last %}, {% endif %}{% endfor %}\
    {% endmacro %}Multistep refinement scanned on the known system (<code>ssmctl study \
    studies/flag-known-system.toml</code>, names with <code>seed N</code> for other realizations of the series; RBF \
    sizes and horizons reached by doubling as the rows \"{{ scan_group }}\" above name them): {% for c in scan %}\
    {{ c.scale }}x the data, {% if c.noise_free %}noise-free{% else %}the flag's noise{% endif %}: multistep \
    {{ c.multistep[0] }}/{{ c.multistep[2] }} within {{ targets.benettin_rel | pct(0) }} %, {{ c.multistep[1] }}/\
    {{ c.multistep[2] }} with JS <= {{ targets.js_max | plain }} too; one-step {{ c.one_step[0] }}/{{ c.one_step[2] }} \
    and {{ c.one_step[1] }}/{{ c.one_step[2] }}{% if not loop.last %}; {% endif %}{% endfor %}. On other realizations \
    of the series (seeds {{ seeds | join(' and ') }}) the one-step {{ seed_model }} gives Benettin \
    {{ span(one_step_ratio, 2) }} of exact (JS {{ span(one_step_js, 2) }}) where the refined one gives \
    {{ span(refined_ratio, 2) }} of exact (JS {{ span(refined_js, 4) }}), while at {{ d6_scale }}x the data the refined \
    {{ seed_model }} gives {{ span(refined_3x, 2) }} of exact: the refinement can keep the chaos but does not make that \
    fit reliable: the chaotic refined fits' Benettin / exact moves with the RBF size, the horizon and the realization \
    ({{ span(refined_chaotic, 2) }}), and JS stays above {{ targets.js_max | plain }} (best \
    {{ best_refined_js | fixed_or(4, '-') }}). On the flag (d = {{ flag_dim }}, the flag's rule, and the known \
    system's larger dimensions) multistep rows give Benettin {{ list('benettin', 3) }} 1/s against the data's \
    {{ data.rosenstein | fixed(3) }}, Rosenstein {{ list('rosenstein', 3) }}, D2 {{ list('corr_dim', 2) }} against \
    {{ data.corr_dim | fixed(2) }} ± {{ data.corr_dim_err | fixed(2) }}, JS {{ list('js', 4) }}: targets met \
    {% for r in flag %}{{ r.met }}/{{ r.targets }}{% if not loop.last %}, {% endif %}{% endfor %}. The refinement \
    lowers the flag's rollout error only a little per stage (on the known system's d = {{ scan_dim }} fits it is what \
    lowered JS). Best by JS: {% if best is none %}- (JS -, Benettin - 1/s: - of the data's; D2 -, NaN error bars low)\
    {% else %}{{ best.candidate }} (JS {{ best.js | fixed(4) }}, Benettin {{ o(best.benettin, 3) }} 1/s: \
    {{ o(best.ratio, 2) }} of the data's; D2 {{ o(best.corr_dim, 2) }}, {{ best.bars | fixed(1) }} error bars low)\
    {% endif %}; the rows meeting the Benettin target: {% for r in flag if r.benettin_ok %}{{ r.candidate }} \
    ({{ o(r.benettin, 3) }} 1/s, JS {{ o(r.js, 4) }}, D2 {{ o(r.corr_dim, 2) }}){% if not loop.last %}; {% endif %}\
    {% else %}none{% endfor %}. Rows meeting JS and Benettin together: {{ both }}; D2 {{ span(ms_d2, 1) }} against \
    {{ data.corr_dim | fixed(2) }} ± {{ data.corr_dim_err | fixed(2) }} where measured, and Rosenstein \
    {{ span(ms_ros, 2) }} against {{ data.rosenstein | fixed(3) }}: no multistep candidate joins the report's \
    selection.";

/// The values of [`MULTISTEP`]: the known system's multistep scan and its fits on other
/// realizations (from the diagnosis rows `diag`), and the flag's multistep rows.
pub fn multistep_values(
    results: &chaos_study::study_results::FlagResults,
    diag: &[(String, f64, PipelineRow)],
) -> serde_json::Value {
    use chaos_study::flag_pipeline_fit::d6_scan_counts;
    use serde_json::json;
    let fnoise = chaos_study::calibration::FLAG_SAMPLING.noise_rel;
    let scan: Vec<serde_json::Value> = [(1, fnoise), (D6_SCALE, fnoise), (1, 0.0)]
        .iter()
        .map(|&(scale, noise)| {
            let (m, p) = (d6_scan_counts(diag, true, scale, noise), d6_scan_counts(diag, false, scale, noise));
            json!({ "scale": scale, "noise_free": noise <= 0.0, "multistep": [m.0, m.1, m.2], "one_step": [p.0, p.1, p.2] })
        })
        .collect();
    // The seeds as numbers: values of the text, not names.
    let mut seed_list: Vec<u64> = diag
        .iter()
        .filter_map(|(_, _, r)| r.candidate.split_once(" seed ").and_then(|(_, n)| n.split_whitespace().next()))
        .filter_map(|n| n.parse().ok())
        .collect();
    seed_list.sort_unstable();
    seed_list.dedup();
    let seeds = |ms: bool, field: &dyn Fn(&PipelineRow) -> Option<f64>| {
        let v: Vec<f64> = diag
            .iter()
            .filter(|(_, _, r)| r.candidate.contains(" seed ") && r.candidate.contains(SEED_MODEL))
            .filter(|(_, _, r)| r.candidate.contains(" ms ") == ms)
            .filter_map(|(_, _, r)| field(r))
            .collect();
        span_of(&v)
    };
    let b_e = |r: &PipelineRow| r.benettin_over_exact;
    let js = |r: &PipelineRow| r.js;
    let (dim, group) = (format!("d={SCAN_DIM}"), format!("d = {SCAN_DIM} scan"));
    let refined = |r: &PipelineRow| r.candidate.contains(&dim) && r.candidate.contains(" ms ");
    let refined_3x: Vec<f64> = diag
        .iter()
        .filter(|(w, n, r)| *w == group && *n > 0.0 && r.scale == D6_SCALE && refined(r))
        .filter_map(|(_, _, r)| r.benettin_over_exact)
        .collect();
    let refined_chaotic: Vec<f64> = diag
        .iter()
        .filter(|(_, n, r)| *n > 0.0 && r.scale == 1 && refined(r))
        .filter_map(|(_, _, r)| r.benettin_over_exact)
        .filter(|&q| q > 0.1)
        .collect();
    let best_refined_js = diag
        .iter()
        .filter(|(_, n, r)| *n > 0.0 && refined(r))
        .filter_map(|(_, _, r)| r.js)
        .fold(f64::INFINITY, f64::min);
    let held = &results.held_out;
    let flag_data = held.data.tuple();
    let fms = held.multistep_rows();
    let best = fms
        .iter()
        .filter(|r| r.failed.is_none())
        .filter_map(|r| r.js.map(|j| (j, r)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(j, r)| {
            json!({ "candidate": r.candidate, "js": j, "benettin": r.benettin,
                    "ratio": r.benettin.map(|b| b / flag_data.0), "corr_dim": r.corr_dim,
                    "bars": r.corr_dim.map(|d| (flag_data.1 - d) / flag_data.2) })
        });
    let flag: Vec<serde_json::Value> = fms
        .iter()
        .map(|r| {
            json!({ "candidate": r.candidate, "benettin": r.benettin, "rosenstein": r.rosenstein,
                    "corr_dim": r.corr_dim, "js": r.js, "met": r.passes.iter().filter(|&&p| p).count(),
                    "targets": r.passes.len(), "benettin_ok": r.passes[0] })
        })
        .collect();
    json!({
        "scan": scan, "scan_group": group, "scan_dim": SCAN_DIM, "targets": chaos::Targets::default(),
        "seeds": seed_list, "seed_model": SEED_MODEL, "d6_scale": D6_SCALE, "flag_dim": FLAG_DIM,
        "one_step_ratio": seeds(false, &b_e), "one_step_js": seeds(false, &js),
        "refined_ratio": seeds(true, &b_e), "refined_js": seeds(true, &js),
        "refined_3x": span_of(&refined_3x), "refined_chaotic": span_of(&refined_chaotic),
        "best_refined_js": best_refined_js.is_finite().then_some(best_refined_js),
        "data": { "rosenstein": flag_data.0, "corr_dim": flag_data.1, "corr_dim_err": flag_data.2 },
        "flag": flag, "best": best,
        "both": fms.iter().filter(|r| r.passes[0] && r.passes[3]).count(),
        "ms_d2": span_of(&fms.iter().filter_map(|r| r.corr_dim).collect::<Vec<_>>()),
        "ms_ros": span_of(&fms.iter().filter_map(|r| r.rosenstein).collect::<Vec<_>>()),
    })
}

/// Error bars below the data's D2 within which a centre-set row counts as high-D2.
const HIGH_D2_BARS: f64 = 3.0;

/// The centre-set paragraph, over [`centre_set_values`].
pub const CENTRE_SETS: &str = "{% macro o(v, n) %}{% if v is none %}-{% else %}{{ v | fixed(n) }}{% endif %}{% endmacro %}\
    Other RBF centre sets on the flag (<code>ssm::dynamics::CentreChoice</code>: the farthest-point rule from a \
    seeded start, k-means++, random subsets, k-means; example <code>flag_pipeline -- flag</code>; the sizes, ridges and \
    seeds the rows name, one-step and multistep): {{ c.rows }} rows, {{ c.failed }} escaped; Benettin within \
    {{ targets.benettin_rel | pct(0) }} %: {{ c.benettin }}, D2 within the error bar: {{ c.corr_dim }}, JS <= \
    {{ targets.js_max | plain }}: {{ c.js }}, Benettin and JS together: {{ c.benettin_js }}{% if best_bj is not none %} \
    (highest D2 of these: {{ best_bj.candidate }}, Benettin {{ o(best_bj.benettin, 3) }}, D2 \
    {{ o(best_bj.corr_dim, 2) }}, JS {{ o(best_bj.js, 4) }}){% endif %}, all three: {{ c.benettin_corr_dim_js }}. Among \
    the rows within {{ targets.benettin_rel | pct(0) }} % on Benettin, D2 is at most {{ d2_b10 | fixed(2) }} \
    ({{ d2_b10_bars | fixed(1) }} error bars low); the rows with D2 within {{ high_d2_bars | plain }} error bars of the \
    data's have Benettin {{ high_benettin[0] | fixed(3) }}-{{ high_benettin[1] | fixed(3) }} 1/s \
    ({{ high_ratio[0] | fixed(2) }}-{{ high_ratio[1] | fixed(2) }} of the data's {{ data.rosenstein | fixed(3) }}). Why: \
    the Kaplan-Yorke dimension of every chaotic model's Lyapunov spectrum is {{ kaplan_yorke[0] | fixed(2) }}-\
    {{ kaplan_yorke[1] | fixed(2) }}, below the data's {{ data.corr_dim | fixed(2) }}. D2 of one held-out-length piece \
    scatters around that: over {{ pieces }} pieces of one long run up to {% if spread is none %}- (-: ---){% else %}\
    {{ spread.width | fixed(2) }} ({{ spread.candidate }}: {{ spread.lo | fixed(2) }}-{{ spread.hi | fixed(2) }})\
    {% endif %}. The data's D2 is not inflated by measurement noise (two moving averages of the series: \
    {{ smoothed[0] | fixed(2) }}, {{ smoothed[1] | fixed(2) }}; its noise added again: {{ smoothed[2] | fixed(2) }}; on \
    the model series the data's noise moves D2 by {{ noisy.mean_change | signed(2) }} on average over {{ noisy.rows }} \
    rows, though by more than {{ d2_change | plain }} on {{ noisy.changed_over_0_2 }}, either way: the scaling range \
    the estimator finds is fragile), but it scatters the same way over the flag's runs: {% for r in runs %}\
    {{ run_prefix }}{{ r.run }} {{ o(r.corr_dim, 2) }}{% if not loop.last %}, {% endif %}{% endfor %} \
    ({{ runs_mean | fixed(2) }} ± {{ runs_sd | fixed(2) }}, {{ runs_range[0] | fixed(2) }}-{{ runs_range[1] | fixed(2) }}; \
    {{ no_range }} without a scaling range), {{ sd_bars | fixed(1) }} times the one-run error bar of ± \
    {{ data.corr_dim_err | fixed(2) }} that the D2 target uses. No centre set joins the report's selection.";

/// The values of [`CENTRE_SETS`]: the flag's other centre sets (`fcs`) against the targets,
/// the Kaplan-Yorke dimensions of the chaotic ones, and D2 over pieces, smoothings and runs.
pub fn centre_set_values(held: &chaos_study::study_results::HeldOutResults, fcs: &[PipelineRow]) -> serde_json::Value {
    use chaos_study::flag_pipeline_fit::target_counts;
    let flag_data = held.data.tuple();
    let (cn, cfail, cb, cd, cj, cbj, cbdj) = target_counts(fcs);
    let d2_b10 = fcs.iter().filter(|r| r.passes[0]).filter_map(|r| r.corr_dim).fold(f64::MIN, f64::max);
    let high_d2: Vec<f64> = fcs
        .iter()
        .filter(|r| r.failed.is_none() && r.corr_dim.is_some_and(|d| d >= flag_data.1 - HIGH_D2_BARS * flag_data.2))
        .filter_map(|r| r.benettin)
        .collect();
    let range = |v: &[f64]| (v.iter().copied().fold(f64::MAX, f64::min), v.iter().copied().fold(f64::MIN, f64::max));
    let (hb_lo, hb_hi) = range(&high_d2);
    let best_bj = fcs
        .iter()
        .filter(|r| r.passes[0] && r.passes[3])
        .max_by(|a, b| a.corr_dim.unwrap_or(0.0).total_cmp(&b.corr_dim.unwrap_or(0.0)));
    // Chaotic: Benettin above 10 % of the data's exponent.
    let chaotic = |name: &str| {
        fcs.iter()
            .any(|r| r.candidate == name && r.failed.is_none() && r.benettin.is_some_and(|b| b > 0.1 * flag_data.0))
    };
    let kys: Vec<f64> =
        held.dimension.iter().filter(|r| chaotic(&r.candidate)).filter_map(|r| r.kaplan_yorke).collect();
    let (ky_lo, ky_hi) = range(&kys);
    let spread = held
        .dimension
        .iter()
        .filter_map(|r| {
            let v: Vec<f64> = r.corr_dim_pieces.iter().flatten().copied().collect();
            let (lo, hi) = range(&v);
            (v.len() == r.corr_dim_pieces.len()).then_some((hi - lo, r.candidate.as_str(), lo, hi))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0));
    let runs: Vec<f64> = held.corr_dim_runs.iter().filter_map(|r| r.corr_dim).collect();
    let mean = runs.iter().sum::<f64>() / runs.len() as f64;
    let sd = (runs.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (runs.len() - 1) as f64).sqrt();
    let (run_lo, run_hi) = range(&runs);
    let sm = &held.corr_dim_smoothed;
    serde_json::json!({
        "c": { "rows": cn, "failed": cfail, "benettin": cb, "corr_dim": cd, "js": cj, "benettin_js": cbj,
               "benettin_corr_dim_js": cbdj },
        "targets": chaos::Targets::default(),
        "best_bj": best_bj.map(|r| serde_json::json!({ "candidate": r.candidate, "benettin": r.benettin,
                                                       "corr_dim": r.corr_dim, "js": r.js })),
        "d2_b10": d2_b10, "d2_b10_bars": (flag_data.1 - d2_b10) / flag_data.2, "high_d2_bars": HIGH_D2_BARS,
        "high_benettin": [hb_lo, hb_hi], "high_ratio": [hb_lo / flag_data.0, hb_hi / flag_data.0],
        "data": { "rosenstein": flag_data.0, "corr_dim": flag_data.1, "corr_dim_err": flag_data.2 },
        "kaplan_yorke": [ky_lo, ky_hi],
        "pieces": held.dimension.first().map_or(0, |r| r.corr_dim_pieces.len()),
        "spread": spread.map(|s| serde_json::json!({ "width": s.0, "candidate": s.1, "lo": s.2, "hi": s.3 })),
        "smoothed": [sm.smoothed_3, sm.smoothed_5, sm.noise_added],
        "noisy": held.model_noisy_corr_dim, "d2_change": chaos_study::flag_study::D2_CHANGE,
        "run_prefix": held.test_run.trim_end_matches(|c: char| c.is_ascii_digit()),
        "runs": held.corr_dim_runs.iter().map(|r| serde_json::json!({ "run": r.run, "corr_dim": r.corr_dim }))
            .collect::<Vec<_>>(),
        "runs_mean": mean, "runs_sd": sd, "runs_range": [run_lo, run_hi],
        "no_range": held.corr_dim_runs.len() - runs.len(), "sd_bars": sd / flag_data.2,
    })
}

/// The centre-set row the experiment-as-model paragraph places among the runs.
const BEST_ROW: &str = "RBF 250 r=5e-9 d=4 p=9 centres kmeans++@3";

/// The experiment as its own model, over [`experiment_values`].
pub const EXPERIMENT_AS_MODEL: &str = "{% macro o(v, n) %}{% if v is none %}-{% else %}{{ v | fixed(n) }}{% endif %}\
    {% endmacro %}{% macro pl(p) %}{% if p is none %}-{% else %}percentile {{ p[0] | pct(0) }}, z \
    {% if p[1] >= 0 %}+{% endif %}{{ p[1] | fixed(2) }}{% endif %}{% endmacro %}{% macro ms(v, n) %}{% if v is none \
    %}-{% else %}{{ v[0] | fixed(n) }} ± {{ v[1] | fixed(n) }}{% endif %}{% endmacro %}\
    The experiment as its own model (<code>chaos_study::flag_self</code>; <code>ssmctl study studies/flag.toml</code>, \
    results in <code>studies/results/flag</code>): each of the other {{ whole.rows }} runs of the flag, whole, and the \
    first and last {{ test_run }}-length pieces ({{ test_len }} samples at step {{ step }}) of the {{ longer }} longer \
    ones, is treated as the output of a perfect model and measured against {{ test_run }} exactly as a model row is: \
    Rosenstein exponent and D2 of the series with {{ test_run }}'s lag, Theiler window and embedding, JS of the \
    densities in the SSM's reduced coordinates (d = {{ dim }}, p = {{ embed }}, fitted on {{ train_runs | join(' + ') \
    }}). Benettin needs the equations of a map and has no value for data. Whole runs: Rosenstein within \
    {{ targets.rosenstein_rel | pct(0) }} % of {{ data.rosenstein | fixed(3) }}: {{ whole.rosenstein }} of \
    {{ whole.rows }}, D2 within {{ data.corr_dim | fixed(2) }} ± {{ data.corr_dim_err | fixed(2) }}: \
    {{ whole.corr_dim }}, JS &lt;= {{ targets.js_max | num }}: {{ whole.js }}, all three: {{ whole.all_three }}; \
    {{ test_run }}-length pieces: Rosenstein {{ pieces.rosenstein }}, D2 {{ pieces.corr_dim }}, JS {{ pieces.js }} of \
    {{ pieces.rows }}, all three: {{ pieces.all_three }}. {% if whole.all_three + pieces.all_three == 0 %}The real \
    system meets the three one-run targets together on none of its runs: a perfect model would fail them as the runs \
    do, so they cannot be required of a model on one run.{% else %}The real system meets the three one-run targets \
    together on only some of its runs.{% endif %} The estimators are fragile at this length: two pieces of \
    {{ run_prefix }}{{ fragile.run }} that share {{ fragile.share | pct(0) }} % of their samples read Rosenstein \
    {% for r in fragile.rosenstein %}{{ o(r, 3) }}{% if not loop.last %} and {% endif %}{% endfor %}; with each run's \
    own settings (as the pipeline measures a held-out run; lag {{ lags[0] }} to {{ lags[1] }} samples) D2 moves, \
    {% for r in own %}{{ run_prefix }}{{ r.run }} {{ o(r.corr_dim, 2) }} to {{ r.own_corr_dim | fixed(2) }} (lag \
    {{ r.lag }}){% if not loop.last %}, {% endif %}{% endfor %}. The best model row ({{ best.name }}) among the \
    {{ whole.rows }} runs: Rosenstein {{ o(best.rosenstein, 3) }} ({{ pl(best.placement[0]) }}; runs \
    {{ ms(best.runs[0], 3) }}), D2 {{ o(best.corr_dim, 2) }} ({{ pl(best.placement[1]) }}; runs \
    {{ ms(best.runs[1], 2) }}), JS {{ o(best.js, 4) }} ({{ pl(best.placement[2]) }}; runs {{ ms(best.runs[2], 4) }}): \
    its exponent is typical of a run, its D2 low, and its densities further from {{ test_run }}'s than most runs' are.";

/// The values of [`EXPERIMENT_AS_MODEL`]: the runs as models of the held-out run (whole runs and
/// pieces of the longer ones), the most overlapping pieces, the runs whose D2 moves most with
/// their own settings, and `BEST_ROW` of `test_rows` placed among the whole runs.
pub fn experiment_values(
    results: &chaos_study::study_results::FlagResults,
    test_rows: &[PipelineRow],
) -> Result<serde_json::Value, Box<dyn Error>> {
    use chaos_study::flag_self::{SelfRow, is_whole, mean_sd, placement, self_counts};
    let rows = &results.experiment.rows;
    let whole: Vec<&SelfRow> = rows.iter().filter(|r| is_whole(r, rows)).collect();
    let part: Vec<&SelfRow> = rows.iter().filter(|r| !is_whole(r, rows)).collect();
    let col = |f: &dyn Fn(&SelfRow) -> Option<f64>| whole.iter().filter_map(|r| f(r)).collect::<Vec<f64>>();
    let stats = [col(&|r| r.rosenstein), col(&|r| r.corr_dim), col(&|r| r.js)];
    let best = test_rows.iter().find(|r| r.candidate == BEST_ROW);
    let best_vals = best.map_or([None; 3], |r| [r.rosenstein, r.corr_dim, r.js]);
    let best_place: Vec<Option<(f64, f64)>> =
        stats.iter().zip(best_vals).map(|(runs, x)| x.and_then(|x| placement(x, runs))).collect();
    let (whole, part) = (&whole[..], &part[..]);
    let held = &results.held_out;
    let flag_data = held.data.tuple();
    let counts = |c: (usize, usize, usize, usize, usize)| serde_json::json!({ "rows": c.0, "rosenstein": c.1, "corr_dim": c.2, "js": c.3, "all_three": c.4 });
    let mut longer: Vec<usize> = part.iter().map(|r| r.run).collect();
    longer.dedup();
    // The two pieces of one run that share the most samples.
    let fragile = longer
        .iter()
        .filter_map(|&run| {
            let p: Vec<_> = part.iter().filter(|r| r.run == run).collect();
            let (a, b) = (p.first()?, p.last()?);
            let shared = (a.start + a.len).saturating_sub(b.start) as f64 / a.len as f64;
            (p.len() > 1).then(|| (shared, run, p.iter().map(|r| r.rosenstein).collect::<Vec<_>>()))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0));
    let fit = chaos_study::flag_pipeline::flag_like_candidates(chaos_study::flag_self::STEP, &[])
        .first()
        .map(|c| c.fit)
        .ok_or("flag_like_candidates gave no candidate")?;
    let own = &results.experiment.runs_own;
    let lags = own.iter().map(|r| r.lag).fold((usize::MAX, 0), |(a, b), l| (a.min(l), b.max(l)));
    // The two runs whose D2 moves most with their own settings, in run order.
    let mut moves: Vec<(f64, usize, Option<f64>, f64, usize)> = whole
        .iter()
        .filter_map(|r| {
            let o = results.experiment.own(r.run)?;
            Some(((r.corr_dim? - o.corr_dim).abs(), r.run, r.corr_dim, o.corr_dim, o.lag))
        })
        .collect();
    moves.sort_by(|a, b| b.0.total_cmp(&a.0));
    moves.truncate(2);
    moves.sort_by_key(|m| m.1);
    let run_prefix = held.test_run.trim_end_matches(|c: char| c.is_ascii_digit());
    Ok(serde_json::json!({
        "test_run": held.test_run, "train_runs": held.train_runs, "test_len": held.test_len,
        "step": chaos_study::flag_self::STEP, "longer": longer.len(), "dim": fit.dim, "embed": fit.embed,
        "data": held.data, "targets": chaos::Targets::default(), "run_prefix": run_prefix,
        "whole": counts(self_counts(whole, flag_data)), "pieces": counts(self_counts(part, flag_data)),
        "fragile": fragile.map(|(share, run, r)| serde_json::json!({ "share": share, "run": run, "rosenstein": r })),
        "lags": [lags.0, lags.1],
        "own": moves.iter().map(|m| serde_json::json!({ "run": m.1, "corr_dim": m.2, "own_corr_dim": m.3, "lag": m.4 })).collect::<Vec<_>>(),
        "best": {
            "name": BEST_ROW, "rosenstein": best.and_then(|r| r.rosenstein), "corr_dim": best.and_then(|r| r.corr_dim),
            "js": best.and_then(|r| r.js), "placement": best_place.iter().map(|p| p.map(|p| [p.0, p.1])).collect::<Vec<_>>(),
            "runs": stats.iter().map(|v| mean_sd(v).map(|(m, s)| [m, s])).collect::<Vec<_>>(),
        },
    }))
}

/// The pick on a validation run, on a second one, and the ensemble, over [`validation_values`].
pub const VALIDATION: &str = "{% macro o(v, n) %}{% if v is none %}-{% else %}{{ v | fixed(n) }}{% endif %}{% endmacro %}\
    {% macro row4(r) %}{% if r is none %}-{% else %}Benettin {{ o(r.benettin, 3) }}, Rosenstein \
    {{ o(r.rosenstein, 3) }}, D2 {{ o(r.corr_dim, 2) }}, JS {{ o(r.js, 4) }}{% endif %}{% endmacro %}\
    {% macro pl(p) %}{% if p is none %}-{% else %}percentile {{ p[0] | pct(0) }}, z {{ p[1] | signed(2) }}{% endif %}\
    {% endmacro %}{% macro ms(v, n) %}{% if v is none %}-{% else %}{{ v[0] | fixed(n) }} ± {{ v[1] | fixed(n) }}\
    {% endif %}{% endmacro %}{% macro name(r) %}{% if r is none %}-{% else %}{{ r.candidate }}{% endif %}{% endmacro %}\
    {% macro met(r) %}{% if r is none %}0{% else %}{{ r.met }}{% endif %}{% endmacro %}\
    Selection on a validation run, not the test run: the {{ c.rows }} centre-set rows fitted again on \
    {{ train | join(' + ') }} and measured on {{ prefix }}{{ run }} (neither training nor test; its own settings: \
    Rosenstein {{ data.rosenstein | fixed(3) }}, D2 {{ data.corr_dim | fixed(2) }} ± {{ data.corr_dim_err | fixed(2) }}; \
    example <code>ssmctl study studies/flag.toml</code>): {{ c.failed }} escaped; Benettin within \
    {{ targets.benettin_rel | pct(0) }} %: {{ c.benettin }}, Rosenstein within {{ targets.rosenstein_rel | pct(0) }} %: \
    {{ c.rosenstein }}, D2: {{ c.corr_dim }}, JS: {{ c.js }}, Benettin and JS: {{ c.benettin_js }}, Benettin, D2 and JS: \
    {{ c.benettin_corr_dim_js }}. The report's selection rule (most targets, then the smallest normalized error) picks \
    {{ name(pick) }} there ({{ row4(pick) }}; {{ met(pick) }} of {{ targets_n }} targets); on the test run {{ test }} it \
    reads {{ row4(pick_test) }} ({{ met(pick_test) }} of {{ targets_n }} targets; among the {{ runs }} runs as models of \
    {{ test }}: Rosenstein {{ pl(placement[0]) }}, D2 {{ pl(placement[1]) }}, JS {{ pl(placement[2]) }}). The same \
    rule on {{ test }} itself picks {{ name(test_pick) }} ({{ row4(test_pick) }}), which reads Rosenstein \
    {% if test_pick_val is none %}-{% else %}{{ o(test_pick_val.rosenstein, 3) }}{% endif %} and D2 \
    {% if test_pick_val is none %}-{% else %}{{ o(test_pick_val.corr_dim, 2) }}{% endif %} on {{ prefix }}{{ run }}: the \
    one-run statistics that the pick rests on move with the run as much as between models. A second validation run, \
    {{ prefix }}{{ second.run }} (Rosenstein {{ second.data.rosenstein | fixed(3) }}, D2 \
    {{ second.data.corr_dim | fixed(2) }} ± {{ second.data.corr_dim_err | fixed(2) }}), picks yet another row, \
    {{ name(second.pick) }} ({{ row4(second.pick) }}), which on {{ test }} reads {{ row4(second.pick_test) }} \
    ({{ met(second.pick_test) }} of {{ targets_n }} targets). An ensemble of the {{ ensemble.members }} best-ranked d = \
    {{ flag_dim }} models on {{ test }}: Benettin {{ ms(ensemble.benettin, 3) }} (the data's \
    {{ test_data.rosenstein | fixed(3) }}), Rosenstein {{ ms(ensemble.rosenstein, 3) }}, D2 \
    {{ ms(ensemble.corr_dim, 2) }}; JS of the pooled long runs {{ ensemble.js_pooled | fixed(4) }} (members \
    {% for j in ensemble.js %}{{ j | fixed(4) }}{% if not loop.last %}, {% endif %}{% endfor %}).";

/// The values of [`VALIDATION`]: the centre-set rows measured on the validation run and their
/// counts against the targets, the picks there, on the test run (`test_rows`) and on a second
/// validation run, the pick's place among the runs as models, and the ensemble.
pub fn validation_values(
    results: &chaos_study::study_results::FlagResults,
    test_rows: &[PipelineRow],
) -> Result<serde_json::Value, Box<dyn Error>> {
    use chaos_study::flag_self::{
        SelfRow, ensemble_members, is_whole, mean_sd, placement, validation_pick, validation_pick_on,
    };
    use serde_json::json;
    let held = &results.held_out;
    let primary = results.validation.primary()?;
    let second = results.validation.runs.get(1).ok_or_else(|| {
        format!("{}: a second validation run is missing in `runs`", chaos_study::study_results::VALIDATION)
    })?;
    let rows = &results.experiment.rows;
    let whole: Vec<&SelfRow> = rows.iter().filter(|r| is_whole(r, rows)).collect();
    let col = |f: &dyn Fn(&SelfRow) -> Option<f64>| whole.iter().filter_map(|r| f(r)).collect::<Vec<f64>>();
    let stats = [col(&|r| r.rosenstein), col(&|r| r.corr_dim), col(&|r| r.js)];
    let val = primary.pipeline_rows();
    let (vn, vfail, vb, vd, vj, vbj, vbdj) = chaos_study::flag_pipeline_fit::target_counts(&val);
    let row = |r: &PipelineRow| {
        json!({ "candidate": r.candidate, "benettin": r.benettin, "rosenstein": r.rosenstein, "corr_dim": r.corr_dim,
                "js": r.js, "met": r.passes.iter().filter(|&&p| p).count() })
    };
    let test_pick = chaos_study::flag_self::pick(test_rows).map(|i| &test_rows[i]);
    let picked = validation_pick(results)?;
    let picked0 = validation_pick_on(second, held);
    let placement: Vec<serde_json::Value> = picked
        .as_ref()
        .map_or([None; 3], |(_, t)| [t.rosenstein, t.corr_dim, t.js])
        .iter()
        .zip(&stats)
        .map(|(x, runs)| json!(x.and_then(|x| placement(x, runs)).map(|p| [p.0, p.1])))
        .collect();
    let members = ensemble_members(primary, results.validation.ensemble.members);
    let mrows: Vec<&PipelineRow> =
        members.iter().filter_map(|n| test_rows.iter().find(|r| r.candidate == *n)).collect();
    let mcol = |f: &dyn Fn(&PipelineRow) -> Option<f64>| mrows.iter().filter_map(|r| f(r)).collect::<Vec<f64>>();
    let ms = |v: &[f64]| mean_sd(v).map(|(m, s)| [m, s]);
    let flag_data = held.data.tuple();
    Ok(json!({
        "c": { "rows": vn, "failed": vfail, "benettin": vb, "rosenstein": val.iter().filter(|r| r.passes[1]).count(),
               "corr_dim": vd, "js": vj, "benettin_js": vbj, "benettin_corr_dim_js": vbdj },
        "train": held.train_runs, "test": held.test_run, "run": primary.run,
        "prefix": held.test_run.trim_end_matches(|c: char| c.is_ascii_digit()),
        "data": primary.data, "targets": chaos::Targets::default(), "targets_n": val.first().map_or(0, |r| r.passes.len()),
        "runs": whole.len(), "flag_dim": FLAG_DIM,
        "pick": picked.as_ref().map(|(v, _)| row(v)), "pick_test": picked.as_ref().map(|(_, t)| row(t)),
        "placement": placement,
        "test_pick": test_pick.map(row),
        "test_pick_val": test_pick.and_then(|t| val.iter().find(|r| r.candidate == t.candidate)).map(row),
        "second": { "run": second.run, "data": second.data, "pick": picked0.as_ref().map(|(v, _)| row(v)),
                    "pick_test": picked0.as_ref().map(|(_, t)| row(t)) },
        "test_data": { "rosenstein": flag_data.0 },
        "ensemble": { "members": members.len(), "benettin": ms(&mcol(&|r| r.benettin)),
                      "rosenstein": ms(&mcol(&|r| r.rosenstein)), "corr_dim": ms(&mcol(&|r| r.corr_dim)),
                      "js_pooled": results.validation.ensemble.js_pooled, "js": mcol(&|r| r.js) },
    }))
}

/// The flag's experiment as its own model, the candidate pick on the validation run and the
/// ensemble of the validation-ranked models ([`chaos_study::flag_self`], committed rows): two
/// paragraphs, a table, and the summary values (experiment as model, validation pick,
/// ensemble) under `flag_pipeline_fit.flag`.
#[allow(clippy::type_complexity)]
fn flag_self_paragraphs(
    page: &mut Page,
    results: &chaos_study::study_results::FlagResults,
    test_rows: &[chaos_study::flag_pipeline::PipelineRow],
) -> Result<(serde_json::Value, serde_json::Value, serde_json::Value), Box<dyn Error>> {
    use chaos_study::flag_self::{
        SelfRow, ensemble_members, is_whole, mean_sd, placement, self_counts, self_passes, validation_pick,
        validation_pick_on,
    };
    let flag_data = results.held_out.data.tuple();
    let rows = &results.experiment.rows;
    let primary = results.validation.primary()?;
    let validation_run = primary.run;
    let second = results.validation.runs.get(1).ok_or_else(|| {
        format!("{}: a second validation run is missing in `runs`", chaos_study::study_results::VALIDATION)
    })?;
    let ensemble_result = results.validation.ensemble;
    let whole: Vec<&SelfRow> = rows.iter().filter(|r| is_whole(r, rows)).collect();
    let part: Vec<&SelfRow> = rows.iter().filter(|r| !is_whole(r, rows)).collect();
    let (cw, cp) = (self_counts(&whole, flag_data), self_counts(&part, flag_data));
    let col = |f: &dyn Fn(&SelfRow) -> Option<f64>| whole.iter().filter_map(|r| f(r)).collect::<Vec<f64>>();
    let stats: [(&str, Vec<f64>, usize); 3] =
        [("rosenstein", col(&|r| r.rosenstein), 3), ("corr_dim", col(&|r| r.corr_dim), 2), ("js", col(&|r| r.js), 4)];
    let best = test_rows.iter().find(|r| r.candidate == BEST_ROW);
    let model_vals = |r: &chaos_study::flag_pipeline::PipelineRow| [r.rosenstein, r.corr_dim, r.js];
    let place = |r: Option<&chaos_study::flag_pipeline::PipelineRow>| -> Vec<Option<(f64, f64)>> {
        let v = r.map(model_vals).unwrap_or([None; 3]);
        stats.iter().zip(v).map(|((_, runs, _), x)| x.and_then(|x| placement(x, runs))).collect()
    };
    let best_place = place(best);
    let v = experiment_values(results, test_rows)?;
    page.para("chaos/experiment-as-model", v);
    let held = &results.held_out;
    let run_prefix = held.test_run.trim_end_matches(|c: char| c.is_ascii_digit());
    let table = rows
        .iter()
        .map(|r| {
            serde_json::json!({
                "r": r, "end": r.start + r.len, "prefix": run_prefix,
                "training": held.train_runs.contains(&format!("{run_prefix}{}", r.run)),
                "passes": self_passes(r.rosenstein, r.corr_dim, r.js, flag_data),
            })
        })
        .collect();
    let head =
        serde_json::json!({ "test_run": held.test_run, "step": chaos_study::flag_self::STEP, "prefix": run_prefix });
    page.table("chaos/experiment", head, table);
    // The pick on the validation run, and the ensemble.
    let val = primary.pipeline_rows();
    let (vn, vfail, vb, vd, vj, vbj, vbdj) = chaos_study::flag_pipeline_fit::target_counts(&val);
    let vr = val.iter().filter(|r| r.passes[1]).count();
    let test_pick = chaos_study::flag_self::pick(test_rows).map(|i| &test_rows[i]);
    let picked = validation_pick(results)?;
    let picked0 = validation_pick_on(second, &results.held_out);
    let pick_place = place(picked.as_ref().map(|(_, t)| t));
    let pick_place_json: serde_json::Map<String, serde_json::Value> = ["rosenstein", "corr_dim", "js"]
        .iter()
        .zip(&pick_place)
        .map(|(k, p)| (k.to_string(), serde_json::json!(p.map(|p| [p.0, p.1]))))
        .collect();
    let members = ensemble_members(primary, ensemble_result.members);
    let mrows: Vec<&chaos_study::flag_pipeline::PipelineRow> =
        members.iter().filter_map(|n| test_rows.iter().find(|r| r.candidate == *n)).collect();
    let mcol = |f: &dyn Fn(&chaos_study::flag_pipeline::PipelineRow) -> Option<f64>| {
        mrows.iter().filter_map(|r| f(r)).collect::<Vec<f64>>()
    };
    let (eb, er, ed, ej) = (mcol(&|r| r.benettin), mcol(&|r| r.rosenstein), mcol(&|r| r.corr_dim), mcol(&|r| r.js));
    page.para("chaos/validation", validation_values(results, test_rows)?);
    let per_stat: serde_json::Map<String, serde_json::Value> = stats
        .iter()
        .zip(&best_place)
        .map(|((k, v, _), p)| {
            let (m, sd) = mean_sd(v).unwrap_or((f64::NAN, f64::NAN));
            (k.to_string(), serde_json::json!({ "runs_mean": m, "runs_sd": sd, "best_row_percentile": p.map(|p| p.0), "best_row_z": p.map(|p| p.1) }))
        })
        .collect();
    let counts = |c: (usize, usize, usize, usize, usize)| serde_json::json!({ "rows": c.0, "rosenstein": c.1, "corr_dim": c.2, "js": c.3, "all_three": c.4 });
    Ok((
        serde_json::json!({
            "rows": rows, "counts_whole_runs": counts(cw), "counts_pieces": counts(cp), "best_row": best.map(|r| r.candidate.clone()), "placement": per_stat,
            "runs_own_settings": results.experiment.runs_own,
        }),
        serde_json::json!({
            "run": validation_run, "data": primary.data,
            "counts": { "rows": vn, "failed": vfail, "benettin": vb, "rosenstein": vr, "corr_dim": vd, "js": vj, "benettin_js": vbj, "benettin_corr_dim_js": vbdj },
            "pick": picked.as_ref().map(|(v, _)| v.candidate.clone()), "pick_validation": picked.as_ref().map(|(v, _)| v.clone()), "pick_test": picked.as_ref().map(|(_, t)| t.clone()),
            "pick_test_placement": pick_place_json,
            "test_run_pick": test_pick.map(|r| r.candidate.clone()),
            "second_run": { "run": second.run, "data": second.data,
                "pick_validation": picked0.as_ref().map(|(v, _)| v.clone()), "pick_test": picked0.as_ref().map(|(_, t)| t.clone()) },
        }),
        serde_json::json!({
            "members": members, "js_pooled": ensemble_result.js_pooled, "js_members": ej,
            "benettin_mean_sd": mean_sd(&eb), "rosenstein_mean_sd": mean_sd(&er), "corr_dim_mean_sd": mean_sd(&ed),
        }),
    ))
}
