//! Chaotic statistics, data vs SSM models (paper section 3.2): correlation dimension
//! (Grassberger-Procaccia) and the SSM dimension rule (the smallest
//! even dimension above it); SSM fits with RBF and polynomial reduced dynamics; the largest
//! Lyapunov exponent by Rosenstein's estimator applied identically to data and to
//! model-generated series; PDFs of the reduced coordinates and their Jensen-Shannon divergence.
//!
//! Stated choices: delay lag = first zero of the autocorrelation; Theiler window = dominant
//! period (both from the training data, reused unchanged for model series); GP embedding
//! dimension `gp_embed` (default 6); Rosenstein in the same embedding, curve length
//! 3 Theiler windows (30..1000 samples), fit window by the chaos crate's straightest-section
//! rule. Model series are as long as the data series and start from the data's first point.

use crate::ssm::embed::delay_embed as ssm_embed;
use crate::ssm::{Dynamics, FitOptions, Ridge, SsmModel, TimeSeries, fit};
use chaos::{
    Bins, CorrSumParams, DivergenceParams, FitRule, Points, ScalingRule, correlation_dimension, delay_embed,
    dominant_period, first_zero_crossing, rosenstein, ssm_dimension,
};
use serde::Serialize;
use std::error::Error;

#[derive(Clone, Debug)]
pub struct ChaosOptions {
    /// Embedding dimension for the correlation dimension and Lyapunov estimates.
    pub gp_embed: usize,
    /// Override the SSM dimension (default: the paper's rule from the dimension estimate).
    pub ssm_dim: Option<usize>,
    /// RBF centres.
    pub centers: usize,
    /// Polynomial map order.
    pub poly_order: u32,
}

impl Default for ChaosOptions {
    fn default() -> Self {
        Self { gp_embed: 6, ssm_dim: None, centers: 200, poly_order: 3 }
    }
}

/// What `ssmctl chaos --json` prints (and `summary.json` holds per data set).
#[derive(Clone, Debug, Serialize)]
pub struct ChaosSummary {
    pub corr_dim: f64,
    pub corr_dim_err: f64,
    pub ssm_dim: usize,
    /// Largest Lyapunov exponents, 1/s (Rosenstein, identical settings).
    pub lle_data: f64,
    pub lle_model_rbf: Option<f64>,
    pub lle_model_poly: Option<f64>,
    /// Mean Jensen-Shannon divergence (bits, 0..1) of the reduced-coordinate PDFs.
    pub pdf_divergence_rbf: Option<f64>,
    pub pdf_divergence_poly: Option<f64>,
    pub lag_samples: usize,
    pub theiler_samples: usize,
    pub gp_embed: usize,
    pub lle_fit_window_s: (f64, f64),
    /// Why a model value is missing (blow-up, estimator failure).
    pub notes: Vec<String>,
    pub seconds: f64,
}

/// Model-generated observable series and reduced coordinates.
struct ModelRun {
    x: Vec<f64>,
    eta: Vec<f64>,
    stopped: Option<String>,
}

fn run_model(m: &SsmModel, data: &TimeSeries) -> Result<ModelRun, Box<dyn Error>> {
    let p = m.predict(data)?;
    Ok(ModelRun { x: p.x, eta: p.eta, stopped: p.stop.map(|s| format!("stopped at t = {:.2} s: {:?}", s.t, s.reason)) })
}

/// Runs the whole analysis on training series (the longest is the reference data).
pub fn analyse(train: &[TimeSeries], o: &ChaosOptions) -> Result<ChaosSummary, Box<dyn Error>> {
    let t0 = std::time::Instant::now();
    let data = train.iter().max_by_key(|s| s.x.len()).ok_or("no training series")?;
    let dt = data.dt().ok_or("data series has no sampling step")?;
    let n = data.x.len();
    let lag = first_zero_crossing(&data.x, n / 4)?.max(1);
    let theiler = dominant_period(&data.x, n / 4)?.max(1);
    let pts = delay_embed(&data.x, o.gp_embed, lag)?;
    let cd = correlation_dimension(&pts, &CorrSumParams { theiler, ..Default::default() }, &ScalingRule::default())?;
    let ssm_dim = match o.ssm_dim {
        Some(d) => d,
        None => ssm_dimension(cd.dimension)?,
    };
    let dp = DivergenceParams { theiler, max_steps: (3 * theiler).clamp(30, 1000), dt, ..Default::default() };
    let rule = FitRule::default();
    // The straightest-section rule first; a bent curve (quantized data) with no 5-sample run
    // within +-20 % gets a second try at +-50 %, then a fit over the first 70 % of the rise;
    // the notes say which.
    let loose = FitRule { tolerance: 0.5, ..rule };
    let whole = FitRule { tolerance: 1e6, ..rule };
    let lle = |x: &[f64], notes: &mut Vec<String>, who: &str| -> Result<(f64, (f64, f64)), Box<dyn Error>> {
        let pts = delay_embed(x, o.gp_embed, lag)?;
        let e = match rosenstein(&pts, &dp, &rule) {
            Ok(e) => e,
            Err(chaos::ChaosError::NoFitWindow { .. }) => match rosenstein(&pts, &dp, &loose) {
                Ok(e) => {
                    notes.push(format!("{who}: Lyapunov fit window found only at +-50 % slope tolerance"));
                    e
                }
                Err(chaos::ChaosError::NoFitWindow { .. }) => {
                    notes.push(format!("{who}: divergence curve has no straight section; slope fitted over its first 70 % rise"));
                    rosenstein(&pts, &dp, &whole)?
                }
                Err(e) => return Err(e.into()),
            },
            Err(e) => return Err(e.into()),
        };
        Ok((e.fit.exponent, e.fit.window_time))
    };
    let mut notes = Vec::new();
    let (lle_data, window) = lle(&data.x, &mut notes, "data")?;
    let embed = 2 * ssm_dim + 1;
    let base = FitOptions { dim: ssm_dim, embed, shift: 1, manifold_order: 2, dyn_order: o.poly_order, dynamics: Dynamics::Map, ridge: Ridge::Fixed(1e-8) };
    // Reduced coordinates of the data, for the PDFs.
    let mut models = Vec::new();
    for (name, dynamics) in [("rbf", Dynamics::Rbf { centers: o.centers }), ("poly", Dynamics::Map)] {
        let mut opts = base.clone();
        opts.dynamics = dynamics;
        match fit(train, &opts) {
            Ok(m) => models.push((name, m)),
            Err(e) => notes.push(format!("{name} fit failed: {e}")),
        }
    }
    let mut out = ChaosSummary {
        corr_dim: cd.dimension,
        corr_dim_err: cd.slope_std,
        ssm_dim,
        lle_data,
        lle_model_rbf: None,
        lle_model_poly: None,
        pdf_divergence_rbf: None,
        pdf_divergence_poly: None,
        lag_samples: lag,
        theiler_samples: theiler,
        gp_embed: o.gp_embed,
        lle_fit_window_s: window,
        notes: Vec::new(),
        seconds: 0.0,
    };
    for (name, m) in &models {
        let y = ssm_embed(data, m.manifold.p, m.options.shift, 1)?;
        let mut eta_data = Vec::with_capacity(y.ncols() * ssm_dim);
        let mut col = vec![0.0; m.manifold.p];
        for j in 0..y.ncols() {
            for (i, c) in col.iter_mut().enumerate() {
                *c = y[(i, j)];
            }
            eta_data.extend(m.manifold.reduce(&col));
        }
        let run = run_model(m, data)?;
        if let Some(s) = &run.stopped {
            notes.push(format!("{name} model {s}"));
        }
        let min_len = 10 * theiler;
        if run.x.len() < min_len {
            notes.push(format!("{name} model series too short ({} samples < {min_len}) for the estimators", run.x.len()));
            continue;
        }
        let l = lle(&run.x, &mut notes, name).map(|v| v.0);
        let js = chaos::compare_pdfs(&Points::from_flat(ssm_dim, eta_data)?, &Points::from_flat(ssm_dim, run.eta)?, Bins::default())
            .map(|c| c.mean_js_bits);
        let (lv, jv) = match *name {
            "rbf" => (&mut out.lle_model_rbf, &mut out.pdf_divergence_rbf),
            _ => (&mut out.lle_model_poly, &mut out.pdf_divergence_poly),
        };
        match l {
            Ok(v) => *lv = Some(v),
            Err(e) => notes.push(format!("{name} model Lyapunov: {e}")),
        }
        match js {
            Ok(v) => *jv = Some(v),
            Err(e) => notes.push(format!("{name} model PDFs: {e}")),
        }
    }
    out.notes = notes;
    out.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// Report section: the chaos analysis for the simulated quantized loop and the inverted flag.
pub fn section(rep: &mut crate::report::Report, data_dir: &std::path::Path, quick: bool) -> Result<(), Box<dyn Error>> {
    use crate::report::{esc, num};
    rep.section(
        "chaos",
        "Chaotic statistics: data vs SSM models",
        "Correlation dimension by Grassberger-Procaccia (self-pairs and a Theiler window of one dominant period \
         excluded; scaling range: the longest run of radii whose local slopes stay within 10 % of their median, \
         error bar = their standard deviation), SSM dimension = smallest even integer above it (the paper's rule); \
         4D/6D SSMs with RBF (linear kernel) and cubic polynomial map dynamics; largest Lyapunov exponent by \
         Rosenstein's estimator with identical settings on data and model series; mean Jensen-Shannon divergence \
         of the reduced-coordinate PDFs.",
    );
    let mut sets: Vec<(String, Vec<TimeSeries>)> = Vec::new();
    let periods = if quick { "run.periods=6000" } else { "run.periods=30000" };
    let mut sim = Vec::new();
    for (i, th) in ["0.02", "0.035"].iter().enumerate() {
        let s = crate::scene::Scene::load("furuta-quant-dt25", &[periods.into(), format!("initial.state=[{th},0,0,0]")])?;
        let tr = crate::sim::simulate(&s, None)?;
        // Drop the first 20 s of transient.
        let skip = (20.0 / tr.dt) as usize;
        sim.push(TimeSeries::new(format!("furuta-quant-dt25 #{i}"), tr.t[skip..].to_vec(), tr.primary()[skip..].to_vec())?);
    }
    sets.push(("simulated: furuta-quant-dt25 (theta)".into(), sim));
    let flag = data_dir.join("inverted_flag_chaotic");
    if flag.join("traj_9.csv").is_file() {
        sets.push((
            "measured: inverted flag (tip deflection)".into(),
            vec![crate::ssm::load_csv(flag.join("traj_9.csv"))?, crate::ssm::load_csv(flag.join("traj_7.csv"))?],
        ));
    } else {
        rep.para(&format!("Inverted-flag data not found under {}: skipped.", esc(&flag.display().to_string())));
    }
    let mut rows = Vec::new();
    let mut list = serde_json::Map::new();
    for (name, train) in &sets {
        let r = analyse(train, &ChaosOptions::default())?;
        let opt = |v: Option<f64>| v.map_or("-".to_string(), num);
        rows.push(vec![
            name.clone(),
            format!("{:.2} ± {:.2}", r.corr_dim, r.corr_dim_err),
            r.ssm_dim.to_string(),
            num(r.lle_data),
            opt(r.lle_model_rbf),
            opt(r.lle_model_poly),
            opt(r.pdf_divergence_rbf),
            opt(r.pdf_divergence_poly),
            r.notes.join("; "),
        ]);
        list.insert(name.clone(), serde_json::to_value(&r)?);
    }
    rep.table(
        &["data", "corr. dim", "SSM dim", "LLE data [1/s]", "LLE RBF", "LLE poly", "JS RBF [bits]", "JS poly [bits]", "notes"],
        &rows,
    );
    rep.summary.insert("chaos".into(), serde_json::Value::Object(list));
    Ok(())
}
