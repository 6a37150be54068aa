//! Report section: what the parametric Furuta SSM model predicts at sampling periods it was
//! not trained on (paper section 3.1, fig. 4): trajectory predictions with NMTE, DTW-NMTE and
//! spectra, from a parametric model whose manifold and map coefficients are interpolated
//! in dt (linearly, and by a natural cubic spline for comparison).

use crate::draw::portrait::plot_portrait;
use crate::plot::{self, Series};
use crate::report::normal_form::PAPER_DTS;
use crate::report::tasks::task;
use crate::report::{Report, num, par_map};
use furuta::bifurcations::{
    ModelBifurcations, RHO_MAX, SensitivityRow, model_bifurcations, model_default_switch, model_row, row_from,
    sensitivity_variants,
};
use furuta::parametric::{FurutaOptions, ParametricModel, TrainingRuns, furuta_parametric_family};
use furuta::shared_tangent::{
    PredictOptions, PredictionResult, predictions_on, shared_parametric_from, test_series_all,
};
use plotters::style::RGBColor;
use serde_json::{Value, json};
use ssm::interp::Interp;
use ssm::portrait::{Fate, PointKind, PortraitOptions, fixed_points, portrait, trajectory};
use std::error::Error;

/// Start of the transient run near the 3-torus, (rho_1, rho_2) in rad.
const TRANSIENT_RHO: [f64; 2] = [0.02, 0.035];
/// The full system's torus across dt: the start (on the torus), the run's length in periods
/// and the tail (s) its mean and spread are measured over.
const TORUS_RHO: [f64; 2] = [0.095, 0.028];
const TORUS_PERIODS: u64 = 16_000;
const TORUS_TAIL_S: f64 = 125.0;

const BLACK: RGBColor = RGBColor(0, 0, 0);
const RED: RGBColor = RGBColor(200, 30, 30);

/// Trajectory and spectrum figures of one prediction; returns the two relative paths.
fn prediction_figures(rep: &Report, r: &PredictionResult) -> Result<(String, String), Box<dyn Error>> {
    let tag = format!("{}", r.dt_ms).replace('.', "p");
    let traj = format!("fig/prediction_dt{tag}.png");
    let spec = format!("fig/prediction_spectrum_dt{tag}.png");
    let tp: Vec<(f64, f64)> = r.t.iter().copied().zip(r.x_true.iter().copied()).collect();
    let pp: Vec<(f64, f64)> = r.t.iter().copied().zip(r.x_pred.iter().copied()).collect();
    plot::lines(
        &rep.dir().join(&traj),
        &format!("dt = {} ms: full system vs parametric SSM model", r.dt_ms),
        "t [s]",
        "theta [rad]",
        &[
            Series { name: "full system", points: &tp, color: BLACK },
            Series { name: "SSM model (interpolated)", points: &pp, color: RED },
        ],
        (760, 260),
    )?;
    let band = |s: &furuta::shared_tangent::Spectrum| -> Vec<(f64, f64)> {
        s.freq_hz.iter().copied().zip(s.amp.iter().copied()).filter(|p| p.0 <= 12.0).collect()
    };
    let (st, sp) = (band(&r.spectrum_true), band(&r.spectrum_pred));
    plot::lines(
        &rep.dir().join(&spec),
        &format!("dt = {} ms: amplitude spectra", r.dt_ms),
        "f [Hz]",
        "amplitude [rad]",
        &[
            Series { name: "full system", points: &st, color: BLACK },
            Series { name: "SSM model", points: &sp, color: RED },
        ],
        (520, 260),
    )?;
    Ok((traj, spec))
}

/// Predictions at the paper's unseen sampling periods; `summary.json` key `predictions`
/// (linear interpolation, the paper's choice) and `predictions_spline`.
/// `runs`: the training runs of the parametric section (the same series, simulated once).
/// Returns the shared-tangent model it predicted with (the fitted map of the global sections).
pub fn predictions_section(
    rep: &mut Report,
    runs: &TrainingRuns,
) -> Result<furuta::shared_tangent::SharedParametricModel, Box<dyn Error>> {
    let po = PredictOptions::default();
    rep.section(
        "predictions",
        "Parametric model: trajectory predictions at unseen sampling periods",
        &format!(
            "All training periods are fitted in one tangent space (V1 from the pooled embedded data, plus a linear normal \
             part per period), so manifold and map coefficients can be interpolated in dt. Test runs of the full system \
             at dt = {} ms start on the slow eigenvector (theta amplitude {} rad) plus a theta offset of {} rad and last \
             {} s (cut at |theta| > {} rad); the model predicts from the first delay vector. NMTE as SSMLearn defines it; \
             DTW-NMTE after dynamic time warping (unconstrained band).",
            po.dts_ms.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(", "),
            po.slow.0,
            po.theta0,
            po.horizon_s,
            po.max_theta
        ),
    );
    let model = task("predictions/shared-fit", || shared_parametric_from(&FurutaOptions::default(), runs))?;
    // The test runs once, read by both interpolations.
    let tests = task("predictions/test-runs", || test_series_all(&po))?;
    let (lin, spl) = rayon::join(
        || task("predictions/linear", || predictions_on(&model, &po, &tests, Interp::Linear)),
        || task("predictions/spline", || predictions_on(&model, &po, &tests, Interp::Spline)),
    );
    let (lin, spl) = (lin?, spl?);
    let mut rows = Vec::new();
    for (a, b) in lin.iter().zip(&spl) {
        let stop = |r: &PredictionResult| {
            r.stop.as_ref().map_or("-".to_string(), |s| format!("model left range at {:.1} s", s.t))
        };
        rows.push(vec![
            format!("{}", a.dt_ms),
            num(a.nmte),
            num(a.dtw_nmte),
            num(b.nmte),
            num(b.dtw_nmte),
            format!("{:.1}", a.t.last().copied().unwrap_or(0.0)),
            a.test_cut.clone().unwrap_or_else(|| "-".into()),
            stop(a),
        ]);
    }
    rep.table(
        &[
            "dt [ms]",
            "NMTE (linear)",
            "DTW-NMTE (linear)",
            "NMTE (spline)",
            "DTW-NMTE (spline)",
            "test length [s]",
            "test run cut",
            "model stop",
        ],
        &rows,
    );
    let mut sorted: Vec<&PredictionResult> = lin.iter().collect();
    sorted.sort_by(|a, b| a.dt_ms.total_cmp(&b.dt_ms));
    for r in sorted {
        let (traj, spec) = prediction_figures(rep, r)?;
        rep.figure(
            &traj,
            &format!("dt = {} ms: test trajectory and the linearly interpolated model's prediction", r.dt_ms),
        );
        rep.figure(&spec, &format!("dt = {} ms: FFT amplitude spectra over the compared samples", r.dt_ms));
    }
    let list = |v: &[PredictionResult]| -> Value {
        Value::Array(v.iter().map(|r| json!({"dt_ms": r.dt_ms, "nmte": r.nmte, "dtw_nmte": r.dtw_nmte})).collect())
    };
    rep.summary.insert("predictions".into(), list(&lin));
    rep.summary.insert("predictions_spline".into(), list(&spl));
    map_switch_part(rep, &model)?;
    Ok(model)
}

/// Range and resolution of the fitted map's small-start switch scan [ms].
pub(crate) const MAP_SWITCH_RANGE_MS: (f64, f64, usize, f64) = (31.0, 32.0, 11, 0.005);

/// The global bifurcation read off the fitted map itself (no normal form): the same small,
/// mode-shaped starts as the full system's scan (`full_system::default_ics`), the same horizon
/// and escape rule, iterated on the shared-tangent model's map at each dt; grid, then
/// bisection. Summary key `map_switch_dt_ms`.
fn map_switch_part(
    rep: &mut Report,
    model: &furuta::shared_tangent::SharedParametricModel,
) -> Result<(), Box<dyn Error>> {
    use furuta::full_system::{DEFAULT_SCAN_PERIODS, ESCAPE_THETA, default_ics};
    let (lo, hi, n, tol) = MAP_SWITCH_RANGE_MS;
    let scan = |interp: Interp| {
        furuta::bifurcations::map_small_start_switch(
            |dt| model.model_at(dt, interp),
            default_ics,
            lo,
            hi,
            n,
            DEFAULT_SCAN_PERIODS,
            tol,
        )
    };
    let (ml, ms) = rayon::join(
        || task("predictions/map-switch-linear", || scan(Interp::Linear)),
        || task("predictions/map-switch-spline", || scan(Interp::Spline)),
    );
    let (ml, ms) = (ml?, ms?);
    rep.para(&format!(
        "The global bifurcation read off the fitted map itself, without a normal form: the model above (its maps \
         interpolated in dt) is iterated from the full system's small mode-shaped starts (the first delay vector from \
         the full system, then the map) for {DEFAULT_SCAN_PERIODS} periods, escape when |theta| exceeds {ESCAPE_THETA} rad, on \
         a grid of {n} values of dt over [{lo}, {hi}] ms, then bisected to {tol} ms. The polar normal form is a Taylor \
         series valid to about 0.1 rad, while the slow saddle cycle lies at 0.14-0.18 rad: the normal form loses that \
         cycle and its bifurcations come late; the map keeps it."
    ));
    let bracket = |b: Option<(f64, f64)>| b.map_or("none".to_string(), |(a, b)| format!("[{a:.4}, {b:.4}]"));
    let full = rep.summary.get("heteroclinic_dt_ms").and_then(|h| h.get("full_system")).cloned().unwrap_or(Value::Null);
    let rows: Vec<Vec<String>> = [("linear", &ml), ("spline", &ms)]
        .iter()
        .map(|(name, sw)| {
            vec![
                (*name).to_string(),
                bracket(sw.bracket),
                sw.grid.iter().map(|g| g.1.to_string()).collect::<Vec<_>>().join(" "),
                if sw.monotone { "yes".into() } else { "no".into() },
                sw.evaluations.to_string(),
            ]
        })
        .collect();
    rep.table(&["interpolation", "switch bracket [ms]", "escaping starts per grid dt", "monotone", "map runs"], &rows);
    let js = |sw: &furuta::bifurcations::MapSwitch| {
        json!({
            "bracket": sw.bracket.map(|(a, b)| vec![a, b]),
            "grid": sw.grid.iter().map(|g| json!([g.0, g.1])).collect::<Vec<_>>(),
            "monotone": sw.monotone,
        })
    };
    rep.summary.insert(
        "map_switch_dt_ms".into(),
        json!({"linear": js(&ml), "spline": js(&ms), "full_system": full, "periods": DEFAULT_SCAN_PERIODS, "range_ms": [lo, hi], "tol_ms": tol}),
    );
    Ok(())
}

fn kind_text(k: PointKind) -> String {
    match k {
        PointKind::Equilibrium => "equilibrium".into(),
        PointKind::LimitCycle { mode } => format!("limit cycle (mode {mode})"),
        PointKind::Torus2 => "2-torus".into(),
    }
}

/// Phase portraits in `(rho_1, rho_2)` at the paper's unseen sampling periods: fixed points
/// (equilibrium, limit cycles, 2-torus) and their stability, the saddle cycles' stable and
/// unstable manifolds, unstable 3-tori; then the heteroclinic and torus-Hopf values of dt.
pub fn portraits_section(rep: &mut Report, pm: &ParametricModel) -> Result<ModelBifurcations, Box<dyn Error>> {
    rep.section(
        "portraits",
        "Parametric model: phase portraits and bifurcations",
        "Amplitude equations rho' = f(rho; dt) of the interpolated normal form. Fixed points: the origin is the \
         equilibrium, a point on an axis a limit cycle of that mode, an interior point a 2-torus; a closed orbit of the \
         amplitude equations is a 3-torus. Saddles' stable manifolds in blue, unstable in red, 3-tori in green. \
         The heteroclinic value is where the interior unstable branch of a saddle cycle switches fate (it lands on the \
         other saddle's stable manifold there), refined by bisection; the torus loses stability where the real part of \
         its Jacobian eigenvalues crosses zero.",
    );
    let popts = PortraitOptions { rho_max: RHO_MAX, ..PortraitOptions::default() };
    let mut rows = Vec::new();
    let mut list = Vec::new();
    for &dt in PAPER_DTS.iter() {
        let nf = pm.normal_form_at(dt)?;
        let p = portrait(&nf, &popts)?;
        for f in &p.fixed_points {
            rows.push(vec![
                format!("{dt}"),
                kind_text(f.kind),
                format!("({:.4}, {:.4})", f.rho[0], f.rho[1]),
                format!("{:?}", f.stability),
                format!(
                    "{:+.4} {:+.4}i, {:+.4} {:+.4}i",
                    f.eigenvalues[0].0, f.eigenvalues[0].1, f.eigenvalues[1].0, f.eigenvalues[1].1
                ),
                format!("{:.3}, {:.3}", f.freqs_hz[0], f.freqs_hz[1]),
            ]);
        }
        for o in &p.orbits {
            rows.push(vec![
                format!("{dt}"),
                format!("3-torus ({})", if o.stable { "stable" } else { "unstable" }),
                format!(
                    "rho_1 {:.3}..{:.3}, rho_2 {:.3}..{:.3}",
                    o.rho_range[0][0], o.rho_range[0][1], o.rho_range[1][0], o.rho_range[1][1]
                ),
                format!("multiplier {:.4}", o.multiplier),
                format!("period {:.2} s", o.period),
                String::new(),
            ]);
        }
        list.push(json!({"dt_ms": dt, "fixed_points": p.fixed_points, "orbits": p.orbits.iter().map(|o| json!({
            "rho_range": o.rho_range, "period_s": o.period, "multiplier": o.multiplier, "stable": o.stable})).collect::<Vec<_>>()}));
        let tag = format!("{dt}").replace('.', "p");
        let path = format!("fig/portrait_dt{tag}.png");
        plot_portrait(&rep.dir().join(&path), &p, &format!("dt = {dt} ms"), &[])?;
        rep.figure(&path, &format!("Phase portrait of the amplitude equations at dt = {dt} ms"));
    }
    rep.table(&["dt [ms]", "object", "rho (rad)", "stability", "eigenvalues [1/s]", "freqs [Hz]"], &rows);
    let (lo, hi) = pm.range();
    let bif = model_bifurcations(pm)?;
    let (heteroclinic, hopf) = (&bif.heteroclinic, &bif.hopf);
    rep.para(&match &heteroclinic {
        Some(h) => format!(
            "Heteroclinic bifurcation (model): dt = {:.4} ms (bracket {:.4}..{:.4}); the interior unstable branch of the {} \
             goes from {:?} below to {:?} above.",
            h.dt,
            h.bracket.0,
            h.bracket.1,
            kind_text(h.saddle),
            h.fate_below,
            h.fate_above
        ),
        None => format!("No heteroclinic switch found in {lo}..{hi} ms."),
    });
    rep.para(&match &hopf {
        Some(h) => format!(
            "The 2-torus {} at dt = {:.4} ms ({}; the 3-torus frequency there is {:.4} Hz).",
            if h.loses_stability { "loses stability" } else { "gains stability" },
            h.dt,
            if h.complex_pair {
                "a complex pair crosses: a Hopf bifurcation of the amplitude equations"
            } else {
                "a real eigenvalue crosses"
            },
            h.frequency_hz
        ),
        None => format!("The 2-torus does not change stability in {lo}..{hi} ms."),
    });
    rep.summary.insert("portraits".into(), Value::Array(list));
    rep.summary.insert(
        "torus_hopf_dt_ms".into(),
        json!({"model": hopf.as_ref().map(|h| h.dt), "complex_pair": hopf.as_ref().map(|h| h.complex_pair)}),
    );
    Ok(bif)
}

// ------------------------------------------------------------------ model vs full system

/// Full-system checks of the model's predictions: where small starts switch from bounded to
/// escape, the 2-torus at 30.8 ms, the domain of attraction at 31.55 ms (three starts, paper
/// fig. 5), and the transient spectrum near the 3-torus (paper fig. 6). Returns the model's
/// small-start switch bracket ([`model_default_switch`]), which
/// the sensitivity section's default row reuses.
pub fn fullsystem_section(
    rep: &mut Report,
    pm: &ParametricModel,
    bif: &ModelBifurcations,
    quick: bool,
) -> Result<Option<(f64, f64)>, Box<dyn Error>> {
    use furuta::full_system::{
        DEFAULT_SCAN_PERIODS, ESCAPE_THETA, default_ics, default_switch_scan, fate_from, start_from_rho,
        switch_scan_per_dt, torus_full, transient_analysis,
    };
    // The integrator of the full-system runs here: the scene's (`furuta-dt30.5`); the basin,
    // torus-continuation and connection runs of the global section take the verdict method.
    let scene = furuta::full_system::base_scene()?;
    let integrator = sim::ode::Integrator::<4>::new(sim::closed_loop::method_of(scene))?.describe();
    let verdict = furuta::full_system::verdict_integrator()?;
    rep.section(
        "fullsystem",
        "Parametric model vs the full system: bifurcations, torus, domain of attraction",
        &format!(
            "The full system is simulated (scene {}: {integrator}) from small starts built on the exact linear eigenvectors with \
             given slow/fast theta amplitudes (rho_1, rho_2); a run escapes when |theta| > {ESCAPE_THETA} rad. Mode \
             amplitudes of full-system runs are sliding least-squares fits of the slow and fast components (2.5 s windows), \
             drawn in the model's (rho_1, rho_2) plane. The global section's basin map, torus continuation and \
             connection runs use {} at the same tolerances: against RODAS4 at rtol 1e-13 it keeps every verdict of \
             those runs (on the full basin, 1,600 runs, every escape time is the scene integrator's) at about half the \
             CPU; the scans from the default starts keep the scene's integrator, because one of their runs (the fast-mode \
             start at 31.38 ms) is decided by the integration error at every tolerance above about 2e-12 \
             (host/lab/examples/fullsystem_integrators.rs).",
            scene.name,
            verdict.method.key()
        ),
    );
    // The full-system runs of the four parts below and the model's small-start scan share
    // nothing: they run together on the pool, then the parts are written in order.
    let (lo, hi) = pm.range();
    let fast_dts = [30.8, 31.2, 31.4, 31.6];
    let dt_doa = 31.55;
    let starts: [[f64; 2]; 3] = [[0.08, 0.03], [0.02, 0.03], [0.14, 0.055]];
    let periods = if quick { 2000 } else { 6000 };
    let dt_tr = 31.5;
    let model_switch = || model_default_switch(pm);
    let scan = || {
        if quick {
            let two = |dt: f64| default_ics(dt).map(|v| v.into_iter().take(2).collect());
            switch_scan_per_dt(&[31.2, 31.3, 31.4, 31.5, 31.6], two, 3000)
        } else {
            default_switch_scan(DEFAULT_SCAN_PERIODS)
        }
    };
    let torus = || {
        torus_full(
            30.8,
            &([0.05, 0.0, 0.0, 0.0], None),
            if quick { 4000 } else { 8000 },
            if quick { 40.0 } else { 80.0 },
        )
    };
    let fast_fates = || par_map(&fast_dts, |&dt| fate_from(dt, [1e-7, 0.005], [0.0, 0.0], 3000));
    let doa_fates = || par_map(&starts, |&rho| fate_from(dt_doa, rho, [0.0, 0.0], periods));
    let transient = || {
        let start = start_from_rho(dt_tr, TRANSIENT_RHO, [0.0, 0.0])?;
        transient_analysis(dt_tr, &(start.0, Some(start.1)), if quick { 60.0 } else { 150.0 })
    };
    let ((model_switch, scan), ((tf, fast_fates), (doa_fates, ta))) = rayon::join(
        || rayon::join(|| task("fullsystem/model-switch", model_switch), || task("fullsystem/scan", scan)),
        || {
            rayon::join(
                || rayon::join(|| task("fullsystem/torus", torus), || task("fullsystem/fast-fates", fast_fates)),
                || rayon::join(|| task("fullsystem/doa-fates", doa_fates), || task("fullsystem/transient", transient)),
            )
        },
    );
    let (model_switch, scan, tf, fast_fates, doa_fates, ta) = (model_switch?, scan?, tf?, fast_fates?, doa_fates?, ta?);

    // 1. Small-start switch.
    let full_bracket = scan.bracket();
    rep.para(&format!(
        "Small starts, full system: {} runs of {} periods over dt = {:.2}..{:.2} ms ({:.1} s wall): all bounded up to \
         {}, some escape from {}{}; every start escapes from {}. Model: a small start follows the fast-mode saddle cycle's \
         interior unstable branch, which reaches the torus born at 30.8 ms (or the 3-torus around it) up to {} ms. Heteroclinic \
         search on the model's saddle cycles (unstable branch switching fate between converging and leaving): {}.",
        scan.runs,
        scan.periods,
        scan.dts_ms.first().copied().unwrap_or(f64::NAN),
        scan.dts_ms.last().copied().unwrap_or(f64::NAN),
        scan.wall_seconds,
        full_bracket.map_or("-".into(), |b| format!("{} ms", b.0)),
        full_bracket.map_or("-".into(), |b| format!("{} ms", b.1)),
        if scan.monotone() { "" } else { " (not monotone in dt)" },
        scan.all_escape_from().map_or("never in the scan".into(), |d| format!("{d} ms")),
        model_switch.map_or(format!("the end of the range ({:.2} ms)", hi.min(32.3)), |b| format!("{:.3}", b.0)),
        bif.heteroclinic.as_ref().map_or("none found".into(), |h| format!("{:.4} ms", h.dt)),
    ));
    rep.para(&format!("<pre>{}</pre>", crate::report::esc(&scan.to_text())));
    rep.summary.insert(
        "heteroclinic_dt_ms".into(),
        json!({
            "model": model_switch.map(|b| 0.5 * (b.0 + b.1)),
            "model_rule": "first dt where the fast saddle cycle's interior unstable branch no longer ends on the continued 2-torus or a 3-torus around it",
            "model_saddle_connection": bif.heteroclinic.as_ref().map(|h| h.dt),
            "full_system": full_bracket.map(|b| [b.0, b.1]),
            "full_system_all_escape_from": scan.all_escape_from(),
            "scan_periods": scan.periods,
        }),
    );
    let _ = lo;

    // 2. The 2-torus at 30.8 ms.
    let tm = bif.torus_30p8.as_ref();
    let amp_model = tm.map(|t| t.rho[0] + t.rho[1]);
    rep.table(
        &[
            "2-torus at 30.8 ms",
            "max |theta| [rad]",
            "rho_1 (slow) [rad]",
            "rho_2 (fast) [rad]",
            "slow [Hz]",
            "fast [Hz]",
        ],
        &[
            vec![
                "model (fixed point of the amplitude equations; max |theta| = rho_1 + rho_2)".into(),
                amp_model.map_or("-".into(), |a| format!("{a:.4}")),
                tm.map_or("-".into(), |t| format!("{:.4}", t.rho[0])),
                tm.map_or("-".into(), |t| format!("{:.4}", t.rho[1])),
                tm.map_or("-".into(), |t| format!("{:.4}", t.freqs_hz[0])),
                tm.map_or("-".into(), |t| format!("{:.4}", t.freqs_hz[1])),
            ],
            vec![
                format!("full system (last {:.0} s of {:.0} s from theta0 = 0.05)", tf.tail_s, tf.total_s),
                format!("{:.4}", tf.amplitude_theta),
                format!("{:.4}", tf.rho[0]),
                format!("{:.4}", tf.rho[1]),
                format!("{:.4}", tf.freqs_hz[0]),
                format!("{:.4}", tf.freqs_hz[1]),
            ],
            vec![
                "exact linear frequencies".into(),
                String::new(),
                String::new(),
                String::new(),
                format!("{:.4}", tf.linear_freqs_hz[0]),
                format!("{:.4}", tf.linear_freqs_hz[1]),
            ],
        ],
    );
    rep.summary.insert(
        "torus_30p8".into(),
        json!({
            "amplitude_theta_model": amp_model,
            "amplitude_theta_full": tf.amplitude_theta,
            "rho_model": tm.map(|t| t.rho),
            "rho_full": tf.rho,
            "freqs_hz_model": tm.map(|t| t.freqs_hz),
            "freqs_hz_full": tf.freqs_hz,
        }),
    );

    // 2b. The fast-mode cycle (the saddle small starts pass first): the full system started
    // on the fast mode with a 1e-7 rad slow part stays near the cycle for tens of seconds;
    // its plateau (mean rho_2 while rho_1 < 1e-3, after 15 s) against the model's cycle.
    let mut crows = Vec::new();
    let mut clist = Vec::new();
    let popts = PortraitOptions { rho_max: RHO_MAX, ray_samples: 0, flow_grid: 0, ..PortraitOptions::default() };
    for (dt, f) in fast_dts.into_iter().zip(fast_fates) {
        let plateau: Vec<f64> = f.amps.iter().filter(|(t, r)| *t > 15.0 && r[0] < 1e-3).map(|(_, r)| r[1]).collect();
        let full = (!plateau.is_empty()).then(|| plateau.iter().sum::<f64>() / plateau.len() as f64);
        let model = fixed_points(&pm.normal_form_at(dt)?, &popts)?
            .into_iter()
            .filter(|p| p.kind == (PointKind::LimitCycle { mode: 2 }))
            .map(|p| p.rho[1])
            .min_by(f64::total_cmp);
        let rel = match (model, full) {
            (Some(m), Some(f)) => format!("{:+.1} %", 100.0 * (m - f) / f),
            _ => "-".into(),
        };
        let o = |v: Option<f64>| v.map_or("-".to_string(), |x| format!("{x:.4}"));
        crows.push(vec![format!("{dt}"), o(model), o(full), rel]);
        clist.push(json!({"dt_ms": dt, "rho2_model": model, "rho2_full": full}));
    }
    rep.para(
        "The fast-mode cycle (the saddle every small start passes first): the model's limit cycle against the full \
              system started on the fast mode (slow part 1e-7 rad), mean rho_2 while rho_1 < 1e-3 after 15 s.",
    );
    rep.table(&["dt [ms]", "model rho_2 [rad]", "full system rho_2 [rad]", "model - full"], &crows);
    rep.summary.insert("fast_cycle".into(), Value::Array(clist));

    // 3. Domain of attraction (paper fig. 5): three starts at 31.55 ms.
    let nf = pm.normal_form_at(dt_doa)?;
    let popts = PortraitOptions { rho_max: RHO_MAX, ..PortraitOptions::default() };
    let p = portrait(&nf, &popts)?;
    let mut rows = Vec::new();
    let mut curves: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    let mut doa = Vec::new();
    for (rho, f) in starts.into_iter().zip(doa_fates) {
        let (mpts, mfate) = trajectory(&nf, rho, 2000.0, &popts)?;
        let model_class = match mfate {
            Fate::LeavesBox { .. } => "leaves the box (escape)".to_string(),
            Fate::Converges { point } => format!(
                "converges to the {}",
                kind_text(p.fixed_points.get(point).map_or(PointKind::Torus2, |x| x.kind))
            ),
            Fate::TimeLimit => "stays bounded (3-torus)".to_string(),
            other => format!("{other:?}"),
        };
        rows.push(vec![
            format!("({}, {})", rho[0], rho[1]),
            model_class.clone(),
            if f.bounded {
                format!("bounded for {:.0} s", periods as f64 * dt_doa * 1e-3)
            } else {
                format!("escapes at {:.1} s", f.escape_t.unwrap_or(f64::NAN))
            },
        ]);
        doa.push(json!({"rho": rho, "model": model_class, "full_bounded": f.bounded, "full_escape_t": f.escape_t}));
        curves.push((format!("full ({}, {})", rho[0], rho[1]), f.amps.iter().map(|(_, r)| (r[0], r[1])).collect()));
        let _ = mpts;
    }
    let extra: Vec<(&str, &[(f64, f64)])> = curves.iter().map(|(n, c)| (n.as_str(), c.as_slice())).collect();
    plot_portrait(
        &rep.dir().join("fig/domain_31p55.png"),
        &p,
        "dt = 31.55 ms: model portrait, full-system runs",
        &extra,
    )?;
    rep.table(&["start (rho_1, rho_2) [rad]", "model", "full system"], &rows);
    rep.figure(
        "fig/domain_31p55.png",
        "Domain of attraction at 31.55 ms: the model's portrait with three full-system runs in amplitude coordinates",
    );
    rep.summary.insert("domain_of_attraction".into(), json!({"dt_ms": dt_doa, "starts": doa}));

    // 4. Transient spectrum near the 3-torus (paper fig. 6).
    let model_orbit = portrait(&pm.normal_form_at(dt_tr)?, &popts)?.orbits.first().map(|o| 1.0 / o.period);
    rep.para(&format!(
        "Transient at {dt_tr} ms from (rho_1, rho_2) = ({}, {}), {:.0} s analysed{}: {} spectral peaks above {} % of \
         the largest ({}); slow {:.4} Hz, fast {:.4} Hz; the third frequency as sideband spacing {} and as the oscillation \
         of rho_1(t) {}; the model's 3-torus at {dt_tr} ms circles at {}.",
        TRANSIENT_RHO[0],
        TRANSIENT_RHO[1],
        ta.analysed_s,
        ta.escape_t.map_or(String::new(), |t| format!(" (escapes at {t:.1} s)")),
        ta.peaks.len(),
        num(100.0 * ssm::spectrum::PEAK_REL_THRESHOLD),
        ta.peaks.iter().map(|p| format!("{:.4}", p.freq_hz)).collect::<Vec<_>>().join(", "),
        ta.slow.freq_hz,
        ta.fast.freq_hz,
        ta.sideband_spacing_hz.map_or("-".into(), |s| format!("{s:.4} Hz")),
        ta.envelope_freq_hz.map_or("-".into(), |s| format!("{s:.4} Hz")),
        model_orbit.map_or("- (no 3-torus in the model)".into(), |f| format!("{f:.4} Hz")),
    ));
    rep.summary.insert(
        "transient_3torus".into(),
        json!({"dt_ms": dt_tr, "peaks_hz": ta.peaks.iter().map(|p| p.freq_hz).collect::<Vec<_>>(),
               "sideband_spacing_hz": ta.sideband_spacing_hz, "envelope_freq_hz": ta.envelope_freq_hz,
               "model_3torus_freq_hz": model_orbit}),
    );
    Ok(model_switch)
}

/// How the model's bifurcation values depend on the training data: the amplitude cut of
/// the training runs and the density of training periods (full report only: four more
/// parametric fits). `default` is the report's model, fitted with `FurutaOptions::default()`;
/// `runs` its training runs, which cover the variants (simulated once); the variants share
/// the fits of their common (period, cut) pairs and reuse `default`'s. `default`'s row is
/// made from `bif` (its [`model_bifurcations`]) and `switch` (its small-start switch, the
/// full-system section's), the values [`model_row`] would compute again.
pub fn sensitivity_section(
    rep: &mut Report,
    default: &ParametricModel,
    bif: &ModelBifurcations,
    switch: Option<(f64, f64)>,
    runs: &TrainingRuns,
) -> Result<(), Box<dyn Error>> {
    rep.section(
        "bifsensitivity",
        "Model bifurcations vs training choices",
        "The parametric model's bifurcation values are a property of the fitted normal-form coefficients, and those depend \
         on which amplitudes the training runs cover: each row refits the model (same embedding, orders and starts) with \
         the training runs cut at a different |theta| or with more training periods. The linear rates stay within 0.2 % \
         of the exact ones in every variant; the higher-order coefficients, and with them the bifurcations, do not.",
    );
    let base = FurutaOptions::default();
    let variants = sensitivity_variants();
    let mut rows = Vec::new();
    let mut list = Vec::new();
    let f = |v: Option<f64>| v.map_or("none".to_string(), |x| format!("{x:.3}"));
    // The refits per variant and the full system's torus across dt (below) run together on
    // the pool; rows are kept in this order, the default model's first.
    let dts = [30.8, 31.2, 31.4, 31.6, 31.8, 31.9];
    let tori = || {
        par_map(&dts, |&dt| {
            let (x, h) = furuta::full_system::start_from_rho(dt, TORUS_RHO, [0.0, 0.0])?;
            Ok::<_, furuta::Error>(furuta::full_system::torus_full(dt, &(x, Some(h)), TORUS_PERIODS, TORUS_TAIL_S))
        })
    };
    let first = row_from("default (paper's periods, cut 0.2 rad)", &base, bif, switch, None);
    let (rest, tori) = rayon::join(
        || -> Result<Vec<SensitivityRow>, furuta::Error> {
            let sets: Vec<&FurutaOptions> = variants.iter().map(|(_, o)| o).collect();
            let models = task("bifsensitivity/family", || furuta_parametric_family(&base, default, &sets, runs))?;
            let items: Vec<(&(&str, FurutaOptions), (ParametricModel, f64))> = variants.iter().zip(models).collect();
            task("bifsensitivity/rows", || {
                par_map(&items, |((name, o), (pm, secs))| model_row(name, o, pm, Some(*secs)))
            })
        },
        || task("bifsensitivity/tori", tori),
    );
    let mut all = vec![first];
    all.extend(rest?);
    let tori = tori?;
    for r in all {
        rows.push(vec![
            r.variant.clone(),
            f(r.torus_hopf_dt_ms),
            f(r.heteroclinic_dt_ms),
            f(r.small_start_switch_dt_ms),
            r.torus_30p8_rho.map_or("none".into(), |t| format!("({:.4}, {:.4})", t[0], t[1])),
            r.fit_seconds.map_or("(above)".into(), |t| format!("{t:.1}")),
        ]);
        list.push(r);
    }
    rep.table(
        &[
            "training",
            "torus Hopf [ms]",
            "saddle connection [ms]",
            "small-start switch [ms]",
            "torus at 30.8 ms (rho_1, rho_2)",
            "fit [s]",
        ],
        &rows,
    );
    // The full system's torus across dt: started on it, measured over the run's tail.
    let mut trows = Vec::new();
    let mut tlist = Vec::new();
    for (dt, torus) in dts.into_iter().zip(tori) {
        match torus {
            Ok(t) => {
                trows.push(vec![
                    format!("{dt}"),
                    format!("({:.4}, {:.4})", t.rho[0], t.rho[1]),
                    format!("{:.4}", t.rho_spread[0]),
                    format!("{:.4}", t.rho_spread[1]),
                ]);
                tlist.push(json!({"dt_ms": dt, "rho": t.rho, "rho_spread": t.rho_spread, "escaped": false}));
            }
            Err(furuta::Error::TorusEscaped { why, .. }) => {
                trows.push(vec![format!("{dt}"), format!("escaped ({why})"), "-".into(), "-".into()]);
                tlist.push(json!({"dt_ms": dt, "escaped": true}));
            }
            Err(e) => return Err(e.into()),
        }
    }
    rep.para(&format!(
        "The full system's torus for comparison: started at (rho_1, rho_2) = ({}, {}), {TORUS_PERIODS} periods, mean and \
         spread (max - min) of the mode amplitudes over the last {TORUS_TAIL_S} s. A spread near zero is an attracting \
         2-torus; it grows where the torus loses attraction. The full system's small-start switch is in the section above.",
        TORUS_RHO[0],
        TORUS_RHO[1],
    ));
    rep.table(&["dt [ms]", "mean (rho_1, rho_2)", "rho_1 spread", "rho_2 spread"], &trows);
    rep.summary.insert("torus_full_vs_dt".into(), Value::Array(tlist));
    rep.summary.insert("bifurcation_sensitivity".into(), serde_json::to_value(&list)?);
    Ok(())
}
