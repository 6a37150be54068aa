//! Report section: what the parametric Furuta SSM model predicts at sampling periods it was
//! not trained on (paper section 3.1, fig. 4): trajectory predictions with NMTE, DTW-NMTE and
//! spectra, from a parametric model whose manifold and map coefficients are interpolated
//! in dt (linearly, and by a natural cubic spline for comparison).

use crate::plot::{self, Series};
use crate::report::{Report, num};
use crate::nfreport::PAPER_DTS;
use crate::ssm::furuta::{FurutaOptions, ParametricModel};
use crate::ssm::portrait::{
    FixedPoint, HeteroclinicEvent, HopfEvent, PointKind, PortraitOptions, ScanOptions, fixed_points, heteroclinic_dt, plot_portrait,
    portrait, torus_hopf_dt,
};
use crate::ssm::furuta_predict::{Interp, PredictOptions, PredictionResult, predictions, shared_parametric};
use plotters::style::RGBColor;
use serde_json::{Value, json};
use std::error::Error;

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
        &[Series { name: "full system", points: &tp, color: BLACK }, Series { name: "SSM model (interpolated)", points: &pp, color: RED }],
        (760, 260),
    )?;
    let band = |s: &crate::ssm::furuta_predict::Spectrum| -> Vec<(f64, f64)> {
        s.freq_hz.iter().copied().zip(s.amp.iter().copied()).filter(|p| p.0 <= 12.0).collect()
    };
    let (st, sp) = (band(&r.spectrum_true), band(&r.spectrum_pred));
    plot::lines(
        &rep.dir().join(&spec),
        &format!("dt = {} ms: amplitude spectra", r.dt_ms),
        "f [Hz]",
        "amplitude [rad]",
        &[Series { name: "full system", points: &st, color: BLACK }, Series { name: "SSM model", points: &sp, color: RED }],
        (520, 260),
    )?;
    Ok((traj, spec))
}

/// Predictions at the paper's unseen sampling periods; `summary.json` key `predictions`
/// (linear interpolation, the paper's choice) and `predictions_spline`.
pub fn predictions_section(rep: &mut Report) -> Result<(), Box<dyn Error>> {
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
    let model = shared_parametric(&FurutaOptions::default())?;
    let lin = predictions(&model, &po, Interp::Linear)?;
    let spl = predictions(&model, &po, Interp::Spline)?;
    let mut rows = Vec::new();
    for (a, b) in lin.iter().zip(&spl) {
        let stop = |r: &PredictionResult| r.stop.as_ref().map_or("-".to_string(), |s| format!("model left range at {:.1} s", s.t));
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
        &["dt [ms]", "NMTE (linear)", "DTW-NMTE (linear)", "NMTE (spline)", "DTW-NMTE (spline)", "test length [s]", "test run cut", "model stop"],
        &rows,
    );
    let mut sorted: Vec<&PredictionResult> = lin.iter().collect();
    sorted.sort_by(|a, b| a.dt_ms.total_cmp(&b.dt_ms));
    for r in sorted {
        let (traj, spec) = prediction_figures(rep, r)?;
        rep.figure(&traj, &format!("dt = {} ms: test trajectory and the linearly interpolated model's prediction", r.dt_ms));
        rep.figure(&spec, &format!("dt = {} ms: FFT amplitude spectra over the compared samples", r.dt_ms));
    }
    let list = |v: &[PredictionResult]| -> Value {
        Value::Array(v.iter().map(|r| json!({"dt_ms": r.dt_ms, "nmte": r.nmte, "dtw_nmte": r.dtw_nmte})).collect())
    };
    rep.summary.insert("predictions".into(), list(&lin));
    rep.summary.insert("predictions_spline".into(), list(&spl));
    Ok(())
}

fn kind_text(k: PointKind) -> String {
    match k {
        PointKind::Equilibrium => "equilibrium".into(),
        PointKind::LimitCycle { mode } => format!("limit cycle (mode {mode})"),
        PointKind::Torus2 => "2-torus".into(),
    }
}

/// Box of the amplitude plane drawn and searched: the fitted models saw |theta| <= 0.3 rad.
pub const RHO_MAX: [f64; 2] = [0.6, 0.3];

/// The model's bifurcation values: heteroclinic connection of the saddle cycles and the
/// loss of stability of the 2-torus, found on the linearly interpolated normal forms.
pub struct ModelBifurcations {
    pub heteroclinic: Option<HeteroclinicEvent>,
    pub hopf: Option<HopfEvent>,
    /// The 2-torus at 30.8 ms: amplitudes (rad) and frequencies (Hz).
    pub torus_30p8: Option<FixedPoint>,
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
                format!("{:+.4} {:+.4}i, {:+.4} {:+.4}i", f.eigenvalues[0].0, f.eigenvalues[0].1, f.eigenvalues[1].0, f.eigenvalues[1].1),
                format!("{:.3}, {:.3}", f.freqs_hz[0], f.freqs_hz[1]),
            ]);
        }
        for o in &p.orbits {
            rows.push(vec![
                format!("{dt}"),
                format!("3-torus ({})", if o.stable { "stable" } else { "unstable" }),
                format!("rho_1 {:.3}..{:.3}, rho_2 {:.3}..{:.3}", o.rho_range[0][0], o.rho_range[0][1], o.rho_range[1][0], o.rho_range[1][1]),
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
    let sopts = ScanOptions { portrait: PortraitOptions { rho_max: RHO_MAX, ..ScanOptions::default().portrait }, ..ScanOptions::default() };
    let nf_at = |dt: f64| pm.normal_form_at(dt);
    let heteroclinic = heteroclinic_dt(nf_at, lo, hi, &sopts)?;
    let hopf = torus_hopf_dt(nf_at, lo, hi, &sopts)?;
    let torus_30p8 = fixed_points(&pm.normal_form_at(30.8)?, &popts)?.into_iter().find(|f| f.kind == PointKind::Torus2);
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
            if h.complex_pair { "a complex pair crosses: a Hopf bifurcation of the amplitude equations" } else { "a real eigenvalue crosses" },
            h.frequency_hz
        ),
        None => format!("The 2-torus does not change stability in {lo}..{hi} ms."),
    });
    rep.summary.insert("portraits".into(), Value::Array(list));
    rep.summary.insert(
        "torus_hopf_dt_ms".into(),
        json!({"model": hopf.as_ref().map(|h| h.dt), "complex_pair": hopf.as_ref().map(|h| h.complex_pair)}),
    );
    Ok(ModelBifurcations { heteroclinic, hopf, torus_30p8 })
}
