//! Does the time-series exponent mean what it says? The Rosenstein estimator with the
//! settings the chaos study uses on the data ([`chaos::Context`]: delay embedding
//! of dimension 6, lag = first zero of the autocorrelation, Theiler window = dominant period,
//! divergence curve of three Theiler windows, the fit-window rule with its fallbacks) against
//! exact largest exponents:
//!
//! - [`known_answer_rows`]: the Rössler and Lorenz flows, sampled about as densely per
//!   oscillation as the flag data at the model step and as long, their exponent by Benettin's
//!   method with the exact variational equation (RK4 of state and tangent together), the
//!   Rosenstein estimate on one observable (Rössler x, Lorenz z and x);
//! - [`model_rows`]: fitted reduced models (the model-selection candidates), Rosenstein on
//!   the model's observable series (data settings) against the model's own Benettin
//!   exponent;
//! - [`data_spread`]: the scatter of the data's own Rosenstein estimate over the recorded
//!   runs and over windows of the held-out length.
//!
//! Together they say which comparison is fair: where the estimator reads a fraction of the
//! true exponent, a model is to be compared with the data by the same estimator on both
//! (Rosenstein on model output against Rosenstein on the data), not by its Benettin exponent
//! against the data's Rosenstein number.

use chaos::reference::{Flow, Rossler, rk4_flow};
use chaos::{BenettinParams, benettin_tangent};
use serde::Serialize;
use ssm::TimeSeries;

use crate::Error;
use crate::model_selection::{CandidateResult, subsample};
use chaos::Context;

/// Embedding dimension of the Rosenstein estimate (the study's `gp_embed`).
pub const EMBED: usize = 6;

/// One comparison of the Rosenstein estimate with an exact exponent.
#[derive(Clone, Debug, Serialize)]
pub struct CheckRow {
    pub system: String,
    pub observable: String,
    /// Samples of the series and the sampling step, s.
    pub samples: usize,
    pub dt: f64,
    /// Lag and Theiler window the data settings chose, samples.
    pub lag: usize,
    pub theiler: usize,
    /// The exact largest exponent (Benettin), 1/s, and its block standard error.
    pub exact: f64,
    pub exact_err: f64,
    /// Rosenstein estimate, 1/s (`None` when it could not be fitted; see `note`).
    pub rosenstein: Option<f64>,
    /// `rosenstein / exact`.
    pub ratio: Option<f64>,
    /// A fitted model's row: the data's Rosenstein exponent (1/s) and the model's over it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub data_rosenstein: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rosenstein_over_data: Option<f64>,
    pub note: String,
}

/// A sampled flow: `substeps` RK4 steps per sample of `dt`, a `transient` of samples from `x0`.
#[derive(Clone, Copy, Debug)]
pub struct Sampling {
    /// Sampling step (s).
    pub dt: f64,
    /// RK4 steps per sample.
    pub substeps: usize,
    /// Samples dropped before the series and the exponent.
    pub transient: usize,
    /// Initial state.
    pub x0: [f64; 3],
}

/// The exact largest exponent (Benettin with the variational equation, renormalized every
/// sample, 20 blocks over `steps` samples) and `n` samples of the state after the transient.
pub fn exponent_and_series<F: Flow>(
    f: &F,
    s: &Sampling,
    n: usize,
    steps: usize,
) -> Result<(f64, f64, Vec<[f64; 3]>), Error> {
    let advance = |x: &mut [f64], v: &mut [f64]| rk4_flow(f, x, v, s.dt, s.substeps);
    let p = BenettinParams { transient: s.transient, steps, time_step: s.dt, renorm_every: 1, bound: 1e6, blocks: 20 };
    let r = benettin_tangent(&s.x0, advance, &p)?;
    let mut x = s.x0;
    let mut v = [0.0; 3];
    for _ in 0..s.transient {
        advance(&mut x, &mut v);
    }
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        out.push(x);
        advance(&mut x, &mut v);
    }
    Ok((r.exponent, r.std_error, out))
}

/// Rosenstein with the data settings on `x` sampled every `dt`: (exponent, lag, Theiler,
/// note). An estimator failure is a note, not an error.
pub fn rosenstein_as_on_data(x: &[f64], dt: f64) -> Result<(Option<f64>, usize, usize, String), Error> {
    let ctx = Context::from_series(x, dt, EMBED)?;
    let mut notes = Vec::new();
    let l = match ctx.lle(x, &mut notes, "series") {
        Ok((l, _)) => Some(l),
        Err(e) => {
            notes.push(format!("Rosenstein failed: {e}"));
            None
        }
    };
    Ok((l, ctx.lag, ctx.theiler, notes.join("; ")))
}

/// The known-answer cases of [`known_answer_rows`]: (system, observable index and name,
/// sampling step, RK4 substeps, samples).
fn cases(quick: bool) -> Vec<(&'static str, usize, &'static str, f64, usize, usize)> {
    // About 12 samples per oscillation, as the flag has at the model step (each step is a
    // system's mean turn time over 12), as long as the flag's held-out series at step 4
    // and, in the full report, 4x longer.
    let mut out = Vec::new();
    let lengths: &[usize] = if quick { &[2000] } else { &[2000, 8000] };
    for &n in lengths {
        out.push(("Rössler", 0, "x", 0.5, 25, n));
        out.push(("Lorenz", 2, "z", 0.06, 6, n));
        out.push(("Lorenz", 0, "x", 0.06, 6, n));
    }
    out
}

/// Rosenstein (data settings) against Benettin on Rössler (x) and Lorenz (z, x), on the
/// rayon pool in a fixed order.
pub fn known_answer_rows(quick: bool) -> Result<Vec<CheckRow>, Error> {
    let cs = cases(quick);
    crate::par_map(&cs, |&(system, obs, obs_name, dt, substeps, n)| {
        let s = Sampling { dt, substeps, transient: 2000, x0: [1.0, 1.0, 1.0] };
        // Benettin over 20,000 samples (1e4 s Rössler, 1,200 s Lorenz).
        let (exact, exact_err, states) = match system {
            "Rössler" => exponent_and_series(&Rossler::default(), &s, n, 20_000)?,
            _ => exponent_and_series(&chaos::reference::Lorenz::default(), &s, n, 20_000)?,
        };
        let x: Vec<f64> = states.iter().map(|p| p[obs]).collect();
        let (l, lag, theiler, note) = rosenstein_as_on_data(&x, dt)?;
        Ok(CheckRow {
            system: system.to_string(),
            observable: obs_name.to_string(),
            samples: n,
            dt,
            lag,
            theiler,
            exact,
            exact_err,
            rosenstein: l,
            ratio: l.map(|l| l / exact),
            data_rosenstein: None,
            rosenstein_over_data: None,
            note,
        })
    })
}

/// Rows for the fitted reduced models among `results` that have both their own Benettin
/// exponent and a Rosenstein estimate on their output (data settings): the exact value is
/// the model's Benettin exponent. Non-chaotic models (Benettin <= twice its error) are
/// skipped: the ratio means nothing there.
pub fn model_rows(data_name: &str, results: &[CandidateResult]) -> Vec<CheckRow> {
    results
        .iter()
        .filter(|r| r.failed.is_none())
        .filter_map(|r| {
            let (b, e, l) = (r.benettin?, r.benettin_err.unwrap_or(0.0), r.rosenstein?);
            (b > 2.0 * e && b > 0.0).then(|| CheckRow {
                system: format!("{data_name}: model {}", r.name),
                observable: "lifted observable".into(),
                samples: r.data.len,
                dt: r.data.dt,
                lag: r.data.lag,
                theiler: r.data.theiler,
                exact: b,
                exact_err: e,
                rosenstein: Some(l),
                ratio: Some(l / b),
                data_rosenstein: Some(r.data.lle),
                rosenstein_over_data: Some(l / r.data.lle),
                note: String::new(),
            })
        })
        .collect()
}

/// One Rosenstein estimate of a data series (or a window of one).
#[derive(Clone, Debug, Serialize)]
pub struct SpreadRow {
    pub series: String,
    pub step: usize,
    pub samples: usize,
    pub lag: usize,
    pub theiler: usize,
    pub rosenstein: Option<f64>,
    pub note: String,
}

/// Mean, standard deviation and coefficient of variation of the estimates.
#[derive(Clone, Debug, Serialize)]
pub struct Spread {
    pub what: String,
    pub step: usize,
    pub n: usize,
    pub mean: f64,
    pub sd: f64,
    /// `sd / |mean|`.
    pub cv: f64,
    pub min: f64,
    pub max: f64,
}

fn spread_of(what: &str, step: usize, rows: &[&SpreadRow]) -> Option<Spread> {
    let v: Vec<f64> = rows.iter().filter_map(|r| r.rosenstein).collect();
    if v.len() < 2 {
        return None;
    }
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0)).sqrt();
    let (min, max) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(*x), b.max(*x)));
    Some(Spread { what: what.to_string(), step, n: v.len(), mean, sd, cv: sd / mean.abs(), min, max })
}

/// The data's own Rosenstein estimate (data settings, each series its own lag and Theiler
/// window, as on the held-out series) over every run of `runs` and over consecutive windows
/// of `window` samples (after subsampling) cut from all runs, at each map step of `steps`.
/// Returns the rows (runs first, then windows, per step) and the spreads (per step: over
/// runs, over windows).
pub fn data_spread(
    runs: &[TimeSeries],
    steps: &[usize],
    window: usize,
) -> Result<(Vec<SpreadRow>, Vec<Spread>), Error> {
    let mut jobs: Vec<(String, usize, Vec<f64>, f64, bool)> = Vec::new();
    for &k in steps {
        for ts in runs {
            let sub = subsample(ts, k, 0)?;
            let dt = sub
                .dt()
                .ok_or(Error::BadInput { what: "data series", why: format!("{}: no sampling step", sub.name) })?;
            jobs.push((ts.name.clone(), k, sub.x.clone(), dt, false));
            if window >= 100 {
                for (w, chunk) in sub.x.chunks_exact(window).enumerate() {
                    jobs.push((format!("{} window {}", ts.name, w + 1), k, chunk.to_vec(), dt, true));
                }
            }
        }
    }
    let rows = crate::par_map(&jobs, |(name, k, x, dt, _)| {
        let (l, lag, theiler, note) = rosenstein_as_on_data(x, *dt)?;
        Ok::<_, Error>(SpreadRow {
            series: name.clone(),
            step: *k,
            samples: x.len(),
            lag,
            theiler,
            rosenstein: l,
            note,
        })
    })?;
    let mut spreads = Vec::new();
    for &k in steps {
        let of = |win: bool| -> Vec<&SpreadRow> {
            rows.iter().zip(&jobs).filter(|(r, j)| r.step == k && j.4 == win).map(|(r, _)| r).collect()
        };
        spreads.extend(spread_of("runs", k, &of(false)));
        spreads.extend(spread_of(&format!("windows of {window} samples"), k, &of(true)));
    }
    Ok((rows, spreads))
}
