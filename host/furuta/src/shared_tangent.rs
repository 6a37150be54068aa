//! Trajectory predictions of the parametric Furuta SSM model at sampling periods not used
//! for training (paper section 3.1, fig. "TrajectoryPredictions1").
//!
//! A prediction needs a full model (manifold and reduced map) at the test period. The
//! per-period fits of [`crate::parametric`] each take their tangent basis `V1` from their own
//! SVD, so their coefficients live in different coordinates and cannot be mixed. Here all
//! training periods share ONE tangent basis: `V1` from the SVD of the pooled embedded data
//! of every training period. Each period is then fitted over that `V1`
//! ([`ssm::fit::fit_with_tangent`]: graph with a degree-1 normal part, since the shared `V1` is only
//! close to each period's own tangent space), so `eta = V1^T y` means the same at every
//! period. The reduced coordinates are a linear image of the SSM, so the map's linear part
//! is still conjugate to the true one: its eigenvalues `ln|mu|/dt` must match
//! [`exact_modes`] as well as with the own-SVD fits (checked in the tests).
//!
//! All polynomials are rescaled to one common monomial scale (the largest per-coordinate
//! scale over the periods; rescaling a coefficient by `prod (S_j/s_j)^{k_j}` leaves the
//! polynomial unchanged), then every coefficient of the manifold and of the map increment is
//! interpolated in the sampling period, linearly between the bracketing periods or by a
//! natural cubic spline through all of them ([`Interp`]). The interpolated model is a plain
//! [`SsmModel`] at the test step, so prediction (embed the first `p` test samples, project
//! `eta0 = V1^T y0`, iterate the map, lift, read theta) and blow-up detection are those of
//! [`SsmModel::predict`].

use crate::Error;
use serde::{Deserialize, Serialize};
use sim::units::ms_to_s;

use crate::parametric::{
    ExactModes, FurutaOptions, TrainingRuns, exact_modes, furuta_series_with_history, slow_mode_start, training_series,
    validate_options,
};
use ssm::data::TimeSeries;
use ssm::dynamics::ReducedDynamics;
use ssm::fit::{Prediction, SsmModel, Stop, embed_training, fit_with_tangent_weights};
use ssm::interp::{Interp, MixError, V1Mix, interp_weights, mix_models};
use ssm::manifold::tangent_space;
use ssm::metrics::amplitude_spectrum;
use ssm::normal_form::{NormalFormOptions, Normalization, PolarNormalForm, normal_form};
use ssm::poly::Poly;

/// One training period of the shared-tangent model.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SharedNode {
    pub dt_ms: f64,
    /// Fit over the shared `V1`, polynomials rescaled to the common scale.
    pub model: SsmModel,
    /// `ln|mu|/dt` of the map's slow and fast multiplier pairs (1/s).
    pub rates: [f64; 2],
    /// `arg(mu)/(2 pi dt)` of the slow and fast pairs (Hz).
    pub freqs_hz: [f64; 2],
    pub exact: ExactModes,
}

/// Parametric model whose training fits share one tangent basis.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SharedParametricModel {
    /// Shared tangent basis, `p x 4` column-major.
    pub v1: Vec<f64>,
    /// Singular values of the pooled embedded training data.
    pub singular_values: Vec<f64>,
    /// Common monomial scale of every polynomial (per reduced coordinate).
    pub scale: Vec<f64>,
    pub nodes: Vec<SharedNode>,
}

/// Slow and fast `(rate 1/s, freq Hz)` of a model's linear part (pairs with positive
/// imaginary part, by increasing frequency).
fn model_modes(model: &SsmModel, dt_ms: f64) -> Result<([f64; 2], [f64; 2]), Error> {
    let mut up: Vec<(f64, f64)> = model.eigenvalues_ct.iter().copied().filter(|e| e.1 > 0.0).collect();
    if up.len() != 2 {
        return Err(Error::Multipliers { dt_ms, got: up.len() });
    }
    up.sort_by(|a, b| a.1.total_cmp(&b.1));
    let tau = std::f64::consts::TAU;
    Ok(([up[0].0, up[1].0], [up[0].1 / tau, up[1].1 / tau]))
}

/// `poly` re-expressed on the monomial scale `to` (same polynomial function).
fn rescale(poly: &Poly, to: &[f64]) -> Poly {
    let mut out = poly.clone();
    for (k, e) in poly.exps.iter().enumerate() {
        let f: f64 = e.iter().zip(to.iter().zip(&poly.scale)).map(|(&q, (t, s))| (t / s).powi(q as i32)).product();
        for c in &mut out.coef[k * poly.dim_out..(k + 1) * poly.dim_out] {
            *c *= f;
        }
    }
    out.scale = to.to_vec();
    out
}

/// Fits the shared-tangent parametric model on the training data of `opts` (the same
/// series as [`crate::parametric::furuta_parametric`]; polynomial map dynamics required).
pub fn shared_parametric(opts: &FurutaOptions) -> Result<SharedParametricModel, Error> {
    validate_options(opts)?;
    if opts.fit.dynamics != ssm::dynamics::Dynamics::Map {
        return Err(Error::BadOption {
            what: "fit.dynamics",
            why: "the shared-tangent model interpolates polynomial maps; use Dynamics::Map".into(),
        });
    }
    // Training runs and fits per period on the rayon pool, collected in order.
    let series = crate::par_map(&opts.dts_ms, |&dt_ms| training_series(opts, dt_ms))?;
    shared_parametric_on(opts, series)
}

/// [`shared_parametric`] on training series cut from `runs` (simulated once for several
/// option sets, see [`TrainingRuns`]): the same model.
pub fn shared_parametric_from(opts: &FurutaOptions, runs: &TrainingRuns) -> Result<SharedParametricModel, Error> {
    validate_options(opts)?;
    if opts.fit.dynamics != ssm::dynamics::Dynamics::Map {
        return Err(Error::BadOption {
            what: "fit.dynamics",
            why: "the shared-tangent model interpolates polynomial maps; use Dynamics::Map".into(),
        });
    }
    let series = crate::par_map(&opts.dts_ms, |&dt_ms| runs.series(opts, dt_ms))?;
    shared_parametric_on(opts, series)
}

/// The shared-tangent fit on the training series of each period of `opts` (in order).
fn shared_parametric_on(opts: &FurutaOptions, series: Vec<Vec<TimeSeries>>) -> Result<SharedParametricModel, Error> {
    let mut pooled = Vec::new();
    for train in &series {
        pooled.extend(embed_training(train, &opts.fit)?.0);
    }
    let (v1, singular_values) = tangent_space(&pooled, opts.fit.dim)?;
    drop(pooled);
    let tasks: Vec<(&Vec<TimeSeries>, f64)> = series.iter().zip(opts.dts_ms.iter().copied()).collect();
    let fits = crate::par_map(&tasks, |&(train, dt_ms)| {
        Ok::<_, Error>((
            dt_ms,
            fit_with_tangent_weights(train, &opts.fit, &v1, opts.map_weight.as_ref(), opts.manifold_weight.as_ref())?,
        ))
    })?;
    let d = opts.fit.dim;
    let scale: Vec<f64> =
        (0..d).map(|j| fits.iter().map(|(_, m)| m.manifold.eta_scale[j]).fold(0.0, f64::max)).collect();
    let mut nodes = Vec::with_capacity(fits.len());
    for (dt_ms, mut model) in fits {
        if let Some(nl) = &model.manifold.nonlinear {
            model.manifold.nonlinear = Some(rescale(nl, &scale));
        }
        model.manifold.eta_scale = scale.clone();
        if let ReducedDynamics::Map { increment, .. } = &mut model.dynamics {
            *increment = rescale(increment, &scale);
        }
        let (rates, freqs_hz) = model_modes(&model, dt_ms)?;
        nodes.push(SharedNode { dt_ms, model, rates, freqs_hz, exact: exact_modes(dt_ms)? });
    }
    Ok(SharedParametricModel { v1, singular_values, scale, nodes })
}

impl SharedParametricModel {
    /// Training periods (ms).
    pub fn dts_ms(&self) -> Vec<f64> {
        self.nodes.iter().map(|n| n.dt_ms).collect()
    }

    /// The full model (manifold and map) at `dt_ms`, every coefficient interpolated by
    /// `interp`. Blow-up reference `eta_range`: the largest training range over all
    /// periods. Conditioning records: those of the nearest training period.
    pub fn model_at(&self, dt_ms: f64, interp: Interp) -> Result<SsmModel, Error> {
        let dts = self.dts_ms();
        let w = interp_weights(&dts, dt_ms, interp)?;
        let nearest =
            (0..dts.len()).min_by(|&a, &b| (dts[a] - dt_ms).abs().total_cmp(&(dts[b] - dt_ms).abs())).unwrap_or(0);
        let models: Vec<&SsmModel> = self.nodes.iter().map(|n| &n.model).collect();
        // One tangent space: V1 is the nearest node's, copied (bit-identical), not mixed.
        let mut out = mix_models(&models, &w, nearest, V1Mix::Shared, ms_to_s(dt_ms)).map_err(|e| match e {
            ssm::Error::Mix(MixError::Mismatch { index, .. }) => Error::BadOption {
                what: "shared fits",
                why: format!(
                    "dt = {} ms has other monomials or scales than dt = {} ms",
                    self.nodes[index].dt_ms, dts[nearest]
                ),
            },
            e => e.into(),
        })?;
        out.manifold.singular_values = self.singular_values.clone();
        out.eta_range = (0..self.scale.len())
            .map(|j| self.nodes.iter().map(|n| n.model.eta_range[j]).fold(0.0, f64::max))
            .collect();
        out.n_points = self.nodes.iter().map(|n| n.model.n_points).sum();
        Ok(out)
    }

    /// Predicts `test` (sampled at `dt_ms`) from its first embedded point with the model
    /// interpolated at `dt_ms`. Blow-up shows as `stop` in the prediction.
    pub fn predict_at(&self, dt_ms: f64, test: &TimeSeries, interp: Interp) -> Result<Prediction, Error> {
        Ok(self.model_at(dt_ms, interp)?.predict(test)?)
    }

    /// Linear `ln|mu|/dt` rates `[slow, fast]` of the interpolated map at `dt_ms`.
    pub fn rates_at(&self, dt_ms: f64, interp: Interp) -> Result<[f64; 2], Error> {
        Ok(model_modes(&self.model_at(dt_ms, interp)?, dt_ms)?.0)
    }

    /// Polar normal form of the interpolated map at `dt_ms`, observable convention on
    /// theta (linear observable row including the manifold's degree-1 normal part).
    pub fn normal_form_at(&self, dt_ms: f64, interp: Interp) -> Result<PolarNormalForm, Error> {
        let m = self.model_at(dt_ms, interp)?;
        let o = NormalFormOptions {
            normalization: Normalization::Observable(m.manifold.observable_row()),
            ..NormalFormOptions::default()
        };
        normal_form(&m.dynamics, &o).map_err(|source| Error::NormalForm { dt: dt_ms, source })
    }
}

/// Test trajectories for [`predictions`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PredictOptions {
    /// Unseen sampling periods (ms), inside the training range.
    pub dts_ms: Vec<f64>,
    /// Initial theta offset (rad) added to the plant state and to the pre-history (plant at
    /// rest at that angle before t = 0), exciting mostly the fast mode.
    pub theta0: f64,
    /// Slow-eigenvector part of the start: `(theta amplitude rad, phase rad)`.
    pub slow: (f64, f64),
    /// Simulated horizon (s); the series is cut earlier at `|theta| > max_theta`.
    pub horizon_s: f64,
    /// Samples dropped at the start.
    pub skip: usize,
    pub max_theta: f64,
    /// Sakoe-Chiba band of the DTW alignment in samples (`None`: unconstrained).
    pub dtw_band: Option<usize>,
}

impl Default for PredictOptions {
    fn default() -> Self {
        PredictOptions {
            dts_ms: vec![30.8, 31.2, 31.8, 32.2, 31.42, 31.65],
            theta0: 0.01,
            slow: (0.004, 0.0),
            horizon_s: 30.0,
            skip: 20,
            max_theta: 0.3,
            dtw_band: None,
        }
    }
}

/// An amplitude spectrum: frequencies (Hz) and single-sided amplitudes (rad).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Spectrum {
    pub freq_hz: Vec<f64>,
    pub amp: Vec<f64>,
}

impl Spectrum {
    fn of(x: &[f64], dt: f64) -> Self {
        let (freq_hz, amp) = amplitude_spectrum(x, dt);
        Spectrum { freq_hz, amp }
    }
}

/// One prediction at an unseen sampling period.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PredictionResult {
    pub dt_ms: f64,
    pub interp: Interp,
    /// NMTE over the predicted samples (all of them unless `stop` is set, then the prefix
    /// before the blow-up).
    pub nmte: f64,
    /// NMTE after DTW alignment over the same samples.
    pub dtw_nmte: f64,
    /// Times of the test series (s).
    pub t: Vec<f64>,
    /// Simulated theta (rad), the whole test series.
    pub x_true: Vec<f64>,
    /// Predicted theta (rad); shorter than `x_true` when `stop` is set.
    pub x_pred: Vec<f64>,
    /// Spectra over the compared samples (`x_pred.len()` of each).
    pub spectrum_true: Spectrum,
    pub spectrum_pred: Spectrum,
    /// Model blow-up, if any.
    pub stop: Option<Stop>,
    /// Why the simulated test run ended before the horizon (escape), if it did.
    pub test_cut: Option<String>,
}

/// The test series at `dt_ms` of [`PredictOptions`]: plant state and pre-history of the
/// slow-mode start plus a `theta0` offset in theta.
pub fn test_series(dt_ms: f64, o: &PredictOptions) -> Result<TimeSeries, Error> {
    let (mut ic, mut hist) = slow_mode_start(dt_ms, o.slow.0, o.slow.1)?;
    ic[0] += o.theta0;
    hist.iter_mut().for_each(|h| h[0] += o.theta0);
    if !(o.horizon_s > 0.0 && o.horizon_s.is_finite()) {
        return Err(Error::BadOption {
            what: "horizon_s",
            why: format!("must be positive and finite, got {}", o.horizon_s),
        });
    }
    let periods = (o.horizon_s / (ms_to_s(dt_ms))).ceil() as u64;
    furuta_series_with_history(dt_ms, ic, Some(&hist), periods, o.skip, o.max_theta)
}

/// Predictions at every period of `o.dts_ms` with interpolation `interp`.
pub fn predictions(
    model: &SharedParametricModel,
    o: &PredictOptions,
    interp: Interp,
) -> Result<Vec<PredictionResult>, Error> {
    crate::par_map(&o.dts_ms, |&dt_ms| predict_one(model, dt_ms, &test_series(dt_ms, o)?, o, interp))
}

/// The test series of every period of `o.dts_ms` ([`test_series`], full-system runs), on the
/// pool, for [`predictions_on`]: the linear and the spline reads of the report test against
/// the same runs, simulated once.
pub fn test_series_all(o: &PredictOptions) -> Result<Vec<TimeSeries>, Error> {
    crate::par_map(&o.dts_ms, |&dt_ms| test_series(dt_ms, o))
}

/// [`predictions`] against test series already simulated (`tests[i]` the series at
/// `o.dts_ms[i]`, as [`test_series_all`] gives): the same results.
pub fn predictions_on(
    model: &SharedParametricModel,
    o: &PredictOptions,
    tests: &[TimeSeries],
    interp: Interp,
) -> Result<Vec<PredictionResult>, Error> {
    if tests.len() != o.dts_ms.len() {
        return Err(Error::Shape { expected: o.dts_ms.len(), got: tests.len() });
    }
    let pairs: Vec<(f64, &TimeSeries)> = o.dts_ms.iter().copied().zip(tests).collect();
    crate::par_map(&pairs, |&(dt_ms, test)| predict_one(model, dt_ms, test, o, interp))
}

/// The prediction and its metrics for one test series.
pub fn predict_one(
    model: &SharedParametricModel,
    dt_ms: f64,
    test: &TimeSeries,
    o: &PredictOptions,
    interp: Interp,
) -> Result<PredictionResult, Error> {
    let pred = model.predict_at(dt_ms, test, interp)?;
    let n = pred.x.len();
    let truth = &test.x[..n];
    let bad = |what: &str| Error::BadOption {
        what: "prediction",
        why: format!("dt = {dt_ms} ms: {what} undefined ({n} samples)"),
    };
    let nmte = ssm::metrics::nmte(&pred.x, truth, 1).ok_or_else(|| bad("NMTE"))?;
    let dtw_nmte = pred.nmte_dtw(test, o.dtw_band);
    if !dtw_nmte.is_finite() {
        return Err(bad("DTW-NMTE"));
    }
    let dt = ms_to_s(dt_ms);
    let horizon = test.t.first().copied().unwrap_or(0.0) + o.horizon_s - (o.skip as f64 + 2.0) * dt;
    let test_cut = (test.t.last().copied().unwrap_or(0.0) < horizon)
        .then(|| format!("|theta| > {} rad at t = {:.2} s", o.max_theta, test.t.last().copied().unwrap_or(0.0)));
    Ok(PredictionResult {
        dt_ms,
        interp,
        nmte,
        dtw_nmte,
        t: test.t.clone(),
        x_true: test.x.clone(),
        spectrum_true: Spectrum::of(truth, dt),
        spectrum_pred: Spectrum::of(&pred.x, dt),
        x_pred: pred.x,
        stop: pred.stop,
        test_cut,
    })
}
