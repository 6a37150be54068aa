//! Trajectory predictions of the parametric Furuta SSM model at sampling periods not used
//! for training (paper section 3.1, fig. "TrajectoryPredictions1").
//!
//! A prediction needs a full model (manifold and reduced map) at the test period. The
//! per-period fits of [`super::furuta`] each take their tangent basis `V1` from their own
//! SVD, so their coefficients live in different coordinates and cannot be mixed. Here all
//! training periods share ONE tangent basis: `V1` from the SVD of the pooled embedded data
//! of every training period. Each period is then fitted over that `V1`
//! ([`fit_with_tangent`]: graph with a degree-1 normal part, since the shared `V1` is only
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

use serde::{Deserialize, Serialize};

use super::data::TimeSeries;
use super::dynamics::ReducedDynamics;
use super::fit::{Prediction, SsmModel, Stop, embed_training, fit_with_tangent};
use super::furuta::{
    ExactModes, FurutaError, FurutaOptions, exact_modes, furuta_series_with_history, slow_mode_start, training_series,
    validate_options,
};
use super::manifold::tangent_space;
use super::metrics::amplitude_spectrum;
use super::normal_form::{NormalFormOptions, Normalization, PolarNormalForm, normal_form};
use super::poly::Poly;

/// How coefficients are interpolated in the sampling period.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Interp {
    /// Piecewise linear between the two bracketing training periods.
    Linear,
    /// Natural cubic spline (zero second derivative at the end periods) through all
    /// training periods.
    Spline,
}

/// Weights `w_i` such that the interpolant at `x` of values `f_i` at `nodes` (strictly
/// increasing) is `sum_i w_i f_i`. Both interpolants are linear in the node values, so the
/// weights serve every coefficient at once. No extrapolation: `x` outside the nodes is an
/// error. With one node the weight is 1; with two the spline is the straight line.
pub fn interp_weights(nodes: &[f64], x: f64, interp: Interp) -> Result<Vec<f64>, FurutaError> {
    let n = nodes.len();
    if n == 0 || nodes.iter().any(|v| !v.is_finite()) || nodes.windows(2).any(|w| w[1] <= w[0]) {
        return Err(FurutaError::BadOption { what: "interpolation nodes", why: format!("need finite, strictly increasing nodes, got {nodes:?}") });
    }
    let (lo, hi) = (nodes[0], nodes[n - 1]);
    if !(x >= lo && x <= hi) {
        return Err(FurutaError::OutOfRange { dt: x, lo, hi });
    }
    let mut w = vec![0.0; n];
    if n == 1 {
        w[0] = 1.0;
        return Ok(w);
    }
    let k = nodes.windows(2).position(|s| x <= s[1]).unwrap_or(n - 2);
    let h = nodes[k + 1] - nodes[k];
    let (a, b) = ((nodes[k + 1] - x) / h, (x - nodes[k]) / h);
    w[k] += a;
    w[k + 1] += b;
    if interp == Interp::Linear || n == 2 {
        return Ok(w);
    }
    // Second derivatives m = S y (m_0 = m_{n-1} = 0) from the tridiagonal system
    // h_{i-1} m_{i-1} + 2 (h_{i-1} + h_i) m_i + h_i m_{i+1} = 6 (dy_i/h_i - dy_{i-1}/h_{i-1});
    // the value is a y_k + b y_{k+1} + ((a^3 - a) m_k + (b^3 - b) m_{k+1}) h^2 / 6.
    let m = second_derivative_operator(nodes);
    for (j, wj) in w.iter_mut().enumerate() {
        *wj += ((a * a * a - a) * m[k][j] + (b * b * b - b) * m[k + 1][j]) * h * h / 6.0;
    }
    Ok(w)
}

/// Matrix `S` (`n x n`, rows = nodes) with `m = S y` the natural spline's second
/// derivatives at the nodes (`n >= 3`), by the Thomas algorithm on each unit vector.
fn second_derivative_operator(x: &[f64]) -> Vec<Vec<f64>> {
    let n = x.len();
    let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
    let mut s = vec![vec![0.0; n]; n];
    let inner = n - 2;
    for j in 0..n {
        // right-hand side for y = e_j
        let y = |i: usize| if i == j { 1.0 } else { 0.0 };
        let rhs: Vec<f64> =
            (1..n - 1).map(|i| 6.0 * ((y(i + 1) - y(i)) / h[i] - (y(i) - y(i - 1)) / h[i - 1])).collect();
        let diag: Vec<f64> = (1..n - 1).map(|i| 2.0 * (h[i - 1] + h[i])).collect();
        let mut c = vec![0.0; inner];
        let mut d = vec![0.0; inner];
        for r in 0..inner {
            let lower = if r > 0 { h[r] } else { 0.0 }; // coefficient of m_{r} in row r+1
            let upper = if r + 1 < inner { h[r + 1] } else { 0.0 };
            let den = diag[r] - lower * if r > 0 { c[r - 1] } else { 0.0 };
            c[r] = upper / den;
            d[r] = (rhs[r] - lower * if r > 0 { d[r - 1] } else { 0.0 }) / den;
        }
        let mut m = vec![0.0; inner];
        for r in (0..inner).rev() {
            m[r] = d[r] - if r + 1 < inner { c[r] * m[r + 1] } else { 0.0 };
        }
        for (row, mr) in s[1..n - 1].iter_mut().zip(&m) {
            row[j] = *mr;
        }
    }
    s
}

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
fn model_modes(model: &SsmModel, dt_ms: f64) -> Result<([f64; 2], [f64; 2]), FurutaError> {
    let mut up: Vec<(f64, f64)> = model.eigenvalues_ct.iter().copied().filter(|e| e.1 > 0.0).collect();
    if up.len() != 2 {
        return Err(FurutaError::Multipliers { dt_ms, got: up.len() });
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
/// series as [`super::furuta::furuta_parametric`]; polynomial map dynamics required).
pub fn shared_parametric(opts: &FurutaOptions) -> Result<SharedParametricModel, FurutaError> {
    validate_options(opts)?;
    if opts.fit.dynamics != super::dynamics::Dynamics::Map {
        return Err(FurutaError::BadOption { what: "fit.dynamics", why: "the shared-tangent model interpolates polynomial maps; use Dynamics::Map".into() });
    }
    let mut series = Vec::with_capacity(opts.dts_ms.len());
    let mut pooled = Vec::new();
    for &dt_ms in &opts.dts_ms {
        let train = training_series(opts, dt_ms)?;
        pooled.extend(embed_training(&train, &opts.fit)?.0);
        series.push(train);
    }
    let (v1, singular_values) = tangent_space(&pooled, opts.fit.dim)?;
    drop(pooled);
    let mut fits = Vec::with_capacity(series.len());
    for (train, &dt_ms) in series.iter().zip(&opts.dts_ms) {
        fits.push((dt_ms, fit_with_tangent(train, &opts.fit, &v1)?));
    }
    let d = opts.fit.dim;
    let scale: Vec<f64> = (0..d).map(|j| fits.iter().map(|(_, m)| m.manifold.eta_scale[j]).fold(0.0, f64::max)).collect();
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
    pub fn model_at(&self, dt_ms: f64, interp: Interp) -> Result<SsmModel, FurutaError> {
        let dts = self.dts_ms();
        let w = interp_weights(&dts, dt_ms, interp)?;
        let nearest = (0..dts.len()).min_by(|&a, &b| (dts[a] - dt_ms).abs().total_cmp(&(dts[b] - dt_ms).abs())).unwrap_or(0);
        let mut out = self.nodes[nearest].model.clone();
        let mix = |get: &dyn Fn(&SsmModel) -> Option<&Poly>| -> Result<Option<Poly>, FurutaError> {
            let Some(base) = get(&out) else { return Ok(None) };
            let mut p = base.clone();
            p.coef.iter_mut().for_each(|c| *c = 0.0);
            for (node, wi) in self.nodes.iter().zip(&w) {
                let q = get(&node.model).filter(|q| q.exps == p.exps && q.scale == p.scale && q.dim_out == p.dim_out);
                let q = q.ok_or_else(|| FurutaError::BadOption {
                    what: "shared fits",
                    why: format!("dt = {} ms has other monomials or scales than dt = {} ms", node.dt_ms, dts[nearest]),
                })?;
                for (c, v) in p.coef.iter_mut().zip(&q.coef) {
                    *c += wi * v;
                }
            }
            Ok(Some(p))
        };
        let manifold_poly = mix(&|m: &SsmModel| m.manifold.nonlinear.as_ref())?;
        let map_poly = mix(&|m: &SsmModel| match &m.dynamics {
            ReducedDynamics::Map { increment, .. } => Some(increment),
            _ => None,
        })?;
        out.manifold.nonlinear = manifold_poly;
        out.manifold.singular_values = self.singular_values.clone();
        if let (ReducedDynamics::Map { increment, dt, .. }, Some(p)) = (&mut out.dynamics, map_poly) {
            *increment = p;
            *dt = dt_ms * 1e-3;
        }
        out.dt = dt_ms * 1e-3;
        out.eigenvalues_ct = out.dynamics.eigenvalues_ct()?;
        out.eta_range =
            (0..self.scale.len()).map(|j| self.nodes.iter().map(|n| n.model.eta_range[j]).fold(0.0, f64::max)).collect();
        out.n_points = self.nodes.iter().map(|n| n.model.n_points).sum();
        Ok(out)
    }

    /// Predicts `test` (sampled at `dt_ms`) from its first embedded point with the model
    /// interpolated at `dt_ms`. Blow-up shows as `stop` in the prediction.
    pub fn predict_at(&self, dt_ms: f64, test: &TimeSeries, interp: Interp) -> Result<Prediction, FurutaError> {
        Ok(self.model_at(dt_ms, interp)?.predict(test)?)
    }

    /// Linear `ln|mu|/dt` rates `[slow, fast]` of the interpolated map at `dt_ms`.
    pub fn rates_at(&self, dt_ms: f64, interp: Interp) -> Result<[f64; 2], FurutaError> {
        Ok(model_modes(&self.model_at(dt_ms, interp)?, dt_ms)?.0)
    }

    /// Polar normal form of the interpolated map at `dt_ms`, observable convention on
    /// theta (linear observable row including the manifold's degree-1 normal part).
    pub fn normal_form_at(&self, dt_ms: f64, interp: Interp) -> Result<PolarNormalForm, FurutaError> {
        let m = self.model_at(dt_ms, interp)?;
        let o = NormalFormOptions { normalization: Normalization::Observable(m.manifold.observable_row()), ..NormalFormOptions::default() };
        normal_form(&m.dynamics, &o).map_err(|source| FurutaError::NormalForm { dt: dt_ms, source })
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
pub fn test_series(dt_ms: f64, o: &PredictOptions) -> Result<TimeSeries, FurutaError> {
    let (mut ic, mut hist) = slow_mode_start(dt_ms, o.slow.0, o.slow.1)?;
    ic[0] += o.theta0;
    hist.iter_mut().for_each(|h| h[0] += o.theta0);
    if !(o.horizon_s > 0.0 && o.horizon_s.is_finite()) {
        return Err(FurutaError::BadOption { what: "horizon_s", why: format!("must be positive and finite, got {}", o.horizon_s) });
    }
    let periods = (o.horizon_s / (dt_ms * 1e-3)).ceil() as u64;
    furuta_series_with_history(dt_ms, ic, Some(&hist), periods, o.skip, o.max_theta)
}

/// Predictions at every period of `o.dts_ms` with interpolation `interp`.
pub fn predictions(model: &SharedParametricModel, o: &PredictOptions, interp: Interp) -> Result<Vec<PredictionResult>, FurutaError> {
    o.dts_ms.iter().map(|&dt_ms| predict_one(model, dt_ms, &test_series(dt_ms, o)?, o, interp)).collect()
}

/// The prediction and its metrics for one test series.
pub fn predict_one(
    model: &SharedParametricModel,
    dt_ms: f64,
    test: &TimeSeries,
    o: &PredictOptions,
    interp: Interp,
) -> Result<PredictionResult, FurutaError> {
    let pred = model.predict_at(dt_ms, test, interp)?;
    let n = pred.x.len();
    let truth = &test.x[..n];
    let bad = |what: &str| FurutaError::BadOption { what: "prediction", why: format!("dt = {dt_ms} ms: {what} undefined ({n} samples)") };
    let nmte = super::metrics::nmte(&pred.x, truth, 1).ok_or_else(|| bad("NMTE"))?;
    let dtw_nmte = pred.nmte_dtw(test, o.dtw_band);
    if !dtw_nmte.is_finite() {
        return Err(bad("DTW-NMTE"));
    }
    let dt = dt_ms * 1e-3;
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spline_weights() {
        // Node values reproduced exactly, by both interpolants.
        let nodes = [30.5, 31.0, 32.0, 32.5];
        for interp in [Interp::Linear, Interp::Spline] {
            for (i, &x) in nodes.iter().enumerate() {
                let w = interp_weights(&nodes, x, interp).unwrap();
                for (j, wj) in w.iter().enumerate() {
                    assert!((wj - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14, "{interp:?} node {i}: {w:?}");
                }
            }
        }
        // Hand-derived natural spline through (0,0), (1,1), (2,0): m_1 = -3, so on [0,1]
        // S(x) = -x^3/2 + 3x/2, and by symmetry S(2-x) = S(x).
        let n3 = [0.0, 1.0, 2.0];
        let y3 = [0.0, 1.0, 0.0];
        let ev = |x: f64| interp_weights(&n3, x, Interp::Spline).unwrap().iter().zip(&y3).map(|(w, y)| w * y).sum::<f64>();
        for x in [0.1, 0.25, 0.5, 0.9] {
            let s = -x * x * x / 2.0 + 1.5 * x;
            assert!((ev(x) - s).abs() < 1e-14 && (ev(2.0 - x) - s).abs() < 1e-14, "x {x}: {} vs {s}", ev(x));
        }
        // A natural spline is exact for straight lines; on the training nodes a cubic
        // y = (x - 31)^3 is NOT reproduced (its ends have nonzero curvature), but the
        // interpolant is C2 with zero end curvature: check by finite differences.
        let f = |x: f64| 2.0 - 0.3 * x;
        let yc: Vec<f64> = nodes.iter().map(|&x| (x - 31.0f64).powi(3)).collect();
        let s = |x: f64, y: &[f64]| interp_weights(&nodes, x, Interp::Spline).unwrap().iter().zip(y).map(|(w, v)| w * v).sum::<f64>();
        let yl: Vec<f64> = nodes.iter().map(|&x| f(x)).collect();
        for x in [30.6, 30.9, 31.3, 31.77, 32.2, 32.45] {
            assert!((s(x, &yl) - f(x)).abs() < 1e-12, "line at {x}");
        }
        let h = 1e-4;
        let d2 = |x: f64| (s(x + h, &yc) - 2.0 * s(x, &yc) + s(x - h, &yc)) / (h * h);
        let d1 = |x: f64, side: f64| (s(x + side * h, &yc) - s(x, &yc)) / (side * h);
        assert!(d2(30.5 + h).abs() < 5e-3 && d2(32.5 - h).abs() < 5e-3 && d2(31.5).abs() > 0.5, "end curvature {} {}", d2(30.5 + h), d2(32.5 - h));
        for &xi in &nodes[1..3] {
            // one-sided slopes agree to O(h), second derivatives on both sides too
            assert!((d1(xi, 1.0) - d1(xi, -1.0)).abs() < 1e-2, "C1 at {xi}");
            assert!((d2(xi + 2.0 * h) - d2(xi - 2.0 * h)).abs() < 0.1, "C2 at {xi}: {} vs {}", d2(xi + 2.0 * h), d2(xi - 2.0 * h));
        }
        assert!(matches!(interp_weights(&nodes, 32.6, Interp::Spline), Err(FurutaError::OutOfRange { .. })));
        assert!(matches!(interp_weights(&[1.0, 1.0], 1.0, Interp::Linear), Err(FurutaError::BadOption { .. })));
    }

    /// One shared fit (~15 s in the test profile) reused for every check.
    #[test]
    fn shared_tangent_rates_and_predictions() {
        let pm = shared_parametric(&FurutaOptions::default()).unwrap();
        // 1. The shared-V1 maps keep the exact linear rates like the own-V1 fits (anchored
        //    linear part; measured: slow -0.9e-4 / -1.2e-4 / -2.5e-4 / -3.1e-4, fast -3.0e-4 /
        //    -3.3e-4 / -5.0e-4 / -4.7e-4 at 30.5 / 31 / 32 / 32.5 ms).
        for n in &pm.nodes {
            let err = [(n.rates[0] - n.exact.rates[0]) / n.exact.rates[0], (n.rates[1] - n.exact.rates[1]) / n.exact.rates[1]];
            eprintln!("node {:5.2}: rate errors slow {:+.2e}, fast {:+.2e}", n.dt_ms, err[0], err[1]);
            assert!(err[0].abs() < 0.01 && err[1].abs() < 0.01, "dt {}: {:?} vs {:?}", n.dt_ms, n.rates, n.exact.rates);
            let f = [(n.freqs_hz[0] - n.exact.freqs_hz[0]) / n.exact.freqs_hz[0], (n.freqs_hz[1] - n.exact.freqs_hz[1]) / n.exact.freqs_hz[1]];
            if n.dt_ms <= 31.0 {
                assert!(f[0].abs() < 1e-3 && f[1].abs() < 1e-4, "dt {}: freqs {:?} vs {:?}", n.dt_ms, n.freqs_hz, n.exact.freqs_hz);
            }
        }
        // 2. At a training period both interpolants return that period's model exactly.
        let node = &pm.nodes[1];
        for interp in [Interp::Linear, Interp::Spline] {
            let m = pm.model_at(node.dt_ms, interp).unwrap();
            let (ReducedDynamics::Map { increment: a, .. }, ReducedDynamics::Map { increment: b, .. }) = (&m.dynamics, &node.model.dynamics) else {
                panic!("map dynamics expected")
            };
            assert_eq!(a.coef, b.coef, "{interp:?}");
            assert_eq!(m.manifold.nonlinear.as_ref().unwrap().coef, node.model.manifold.nonlinear.as_ref().unwrap().coef);
        }
        // 3. Normal-form spline interpolation (ParametricModel::normal_form_at_with) on
        //    normal forms of the shared nodes: nodes reproduced, Linear = normal_form_at.
        let pmod = super::super::furuta::ParametricModel {
            trained: pm
                .nodes
                .iter()
                .map(|n| super::super::furuta::TrainedDt {
                    dt_ms: n.dt_ms,
                    model: n.model.clone(),
                    normal_form: pm.normal_form_at(n.dt_ms, Interp::Linear).unwrap(),
                    exact: n.exact.clone(),
                })
                .collect(),
        };
        for t in &pmod.trained {
            let nf = pmod.normal_form_at_with(t.dt_ms, Interp::Spline).unwrap();
            for (u, v) in nf.amp.iter().flatten().zip(t.normal_form.amp.iter().flatten()) {
                assert!((u - v).abs() <= 1e-12 * v.abs().max(1.0), "dt {}: {u} vs {v}", t.dt_ms);
            }
            // linear rates of the shared normal form = ln|mu|/dt of the map
            let r = t.normal_form.linear_rates();
            let node = pm.nodes.iter().find(|n| n.dt_ms == t.dt_ms).unwrap();
            assert!((r[0] - node.rates[0]).abs() < 1e-9 && (r[1] - node.rates[1]).abs() < 1e-9, "{r:?} vs {:?}", node.rates);
        }
        assert_eq!(pmod.normal_form_at_with(30.8, Interp::Linear).unwrap().amp, pmod.normal_form_at(30.8).unwrap().amp);
        // 4. Predictions at the six unseen periods, both interpolants: full horizon, no
        //    blow-up, finite metrics. At 30.8 ms (linear) the measured NMTE is 9.3e-4; the
        //    bound 3e-3 leaves room for rounding differences between platforms but fails
        //    for a model off by a few percent in rate or amplitude over the 30 s run. As an
        //    independent scale: predicting 0 gives NMTE = mean|theta| / max|theta| (about 0.18
        //    here); every period must do better than a quarter of that (measured: at most 0.17).
        let o = PredictOptions::default();
        for interp in [Interp::Linear, Interp::Spline] {
            let res = predictions(&pm, &o, interp).unwrap();
            assert_eq!(res.len(), 6);
            for r in &res {
                let zero = r.x_true.iter().map(|v| v.abs()).sum::<f64>() / r.x_true.len() as f64 / r.x_true.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                let peak = r.spectrum_true.amp.iter().zip(&r.spectrum_true.freq_hz).skip(1).fold((0.0, 0.0), |m, (a, f)| if *a > m.0 { (*a, *f) } else { m });
                eprintln!(
                    "{interp:?} dt {:5.2}: NMTE {:.4}, DTW-NMTE {:.4} (zero predictor {:.3}), {} samples, stop {:?}, cut {:?}, true peak {:.2e} rad at {:.2} Hz",
                    r.dt_ms, r.nmte, r.dtw_nmte, zero, r.x_pred.len(), r.stop, r.test_cut, peak.0, peak.1
                );
                assert!(r.stop.is_none() && r.x_pred.len() == r.x_true.len(), "dt {}: {:?}", r.dt_ms, r.stop);
                assert!(r.t.last().unwrap() - r.t[0] > 20.0, "dt {}: horizon", r.dt_ms);
                assert!(r.nmte.is_finite() && r.dtw_nmte.is_finite());
                assert!(r.nmte < 0.25 * zero, "dt {}: NMTE {} vs zero predictor {}", r.dt_ms, r.nmte, zero);
                if r.dt_ms == 30.8 && interp == Interp::Linear {
                    assert!(r.nmte < 3e-3, "30.8 ms NMTE {}", r.nmte);
                }
                // Measured (training runs cut at 0.2 rad): linear 0.0005 / 0.0007 / 0.0010 /
                // 0.0012 / 0.0008 / 0.0010 at 30.8 / 31.2 / 31.8 / 32.2 / 31.42 / 31.65 ms,
                // spline within 0.0002 of those (with the 0.3 rad cut: up to 0.045).
                assert!(r.nmte < 0.005, "dt {}: NMTE {}", r.dt_ms, r.nmte);
            }
        }
    }

    /// Exploration print of the whole pipeline (not a check).
    #[test]
    #[ignore = "exploration, prints only"]
    fn shared_explore() {
        let t0 = std::time::Instant::now();
        let fo = super::super::furuta::explore_options();
        let pm = shared_parametric(&fo).unwrap();
        eprintln!("fit {:.1} s; sv {:?}", t0.elapsed().as_secs_f64(), &pm.singular_values[..6]);
        for n in &pm.nodes {
            eprintln!(
                "node {:5.2}: slow {:+.5} vs {:+.5} ({:+.2e}), fast {:+.5} vs {:+.5} ({:+.2e}); freqs {:?} vs {:?}",
                n.dt_ms, n.rates[0], n.exact.rates[0], (n.rates[0] - n.exact.rates[0]) / n.exact.rates[0],
                n.rates[1], n.exact.rates[1], (n.rates[1] - n.exact.rates[1]) / n.exact.rates[1], n.freqs_hz, n.exact.freqs_hz
            );
        }
        let o = PredictOptions::default();
        for interp in [Interp::Linear, Interp::Spline] {
            for &dt in &o.dts_ms {
                let e = exact_modes(dt).unwrap();
                let r = pm.rates_at(dt, interp).unwrap();
                let ts = test_series(dt, &o).unwrap();
                let res = predict_one(&pm, dt, &ts, &o, interp).unwrap();
                eprintln!(
                    "{interp:?} dt {dt:5.2}: n {} / {}, NMTE {:.4}, DTW-NMTE {:.4}, stop {:?}, cut {:?}; rates {:+.4} {:+.4} vs exact {:+.4} {:+.4}",
                    res.x_pred.len(), res.x_true.len(), res.nmte, res.dtw_nmte, res.stop, res.test_cut, r[0], r[1], e.rates[0], e.rates[1]
                );
            }
        }
    }
}
