//! Report section: what the parametric Furuta SSM model predicts at sampling periods it was
//! not trained on (paper section 3.1, fig. 4): trajectory predictions with NMTE, DTW-NMTE and
//! spectra, from a parametric model whose manifold and map coefficients are interpolated
//! in dt (linearly, and by a natural cubic spline for comparison).

use crate::plot::{self, Series};
use crate::report::{Report, num};
use crate::ssm::furuta::FurutaOptions;
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
