//! The fitting pipeline and the fitted model: delay embedding -> tangent space and graph
//! parametrization -> reduced dynamics; prediction from a test series' first embedded
//! point with blow-up detection. Scalar series ([`fit`], [`SsmModel::predict`]) are the
//! one-observable case of trajectories of several observables ([`fit_multi`],
//! [`SsmModel::predict_multi`]), which over-embed every observable
//! ([`crate::embed::delay_embed_multi`]).

use serde::{Deserialize, Serialize};

use super::data::{MultiSeries, TimeSeries, check_same_observables};
use super::dynamics::{Dynamics, EtaTrajectory, MAP_DT_RTOL, ReducedDynamics, RowWeight, StepScratch};
use super::embed::{delay_embed_multi, embedded_len};
use super::error::FitError;
use super::manifold::Manifold;
use super::metrics;
use super::poly::PolyScratch;
use super::ridge::{Conditioning, Ridge};

/// A prediction stops when a reduced coordinate exceeds this multiple of its training range.
pub const BLOWUP_FACTOR: f64 = 10.0;

/// Options of [`fit`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitOptions {
    /// SSM dimension d (>= 1).
    pub dim: usize,
    /// Delay-embedding dimension p (> 2 d): the number of delayed copies of the observable.
    /// With q observables ([`fit_multi`]) every observable is copied p times, `q p > 2 d`
    /// coordinates (SSMLearn's `OverEmbedding` is `p - 1`; p = 1 uses the observables as
    /// they are).
    pub embed: usize,
    /// Delay between embedding coordinates, in samples (>= 1).
    pub shift: usize,
    /// Polynomial order K of the manifold parametrization (1 = linear).
    pub manifold_order: u32,
    /// Polynomial order of the reduced dynamics (ignored for RBF).
    pub dyn_order: u32,
    /// Kind of reduced dynamics.
    pub dynamics: Dynamics,
    /// Ridge parameter choice, used for both regressions.
    pub ridge: Ridge,
    /// Anchor the linear part of polynomial dynamics on small amplitudes: `Some(f)` fits
    /// the degree-1 terms to the training pairs within `f` times the largest `||eta||`
    /// only, then the higher degrees to the rest (see
    /// [`ReducedDynamics::fit_anchored`]). Use it when the linear rates matter (normal
    /// forms, stability) and the data also reach large amplitudes: over the whole range
    /// the degree-1 terms otherwise trade accuracy at the fixed point against the
    /// truncated higher orders. `None`: one regression over all pairs. Needs clean data
    /// near the fixed point: on measured decays that end in sensor noise the small pairs are
    /// noise dominated and the anchor costs accuracy (on the sloshing decays the anchored
    /// fits' test NMTE is worse than without; `ssmctl bench fit` shows the rows).
    #[serde(default)]
    pub linear_anchor: Option<f64>,
    /// With `linear_anchor`: fit the anchored linear part JOINTLY with the higher orders
    /// (see [`ReducedDynamics::fit_with`](super::dynamics::ReducedDynamics::fit_with)):
    /// the small-amplitude pairs are chosen by their envelope (max `||eta||` over one
    /// period of the trajectory, not `||eta||` itself, which on elongated orbits picks
    /// phases instead of amplitudes) and the degree-1 terms are fitted to them with the
    /// higher-order terms' contribution removed, the higher orders to all pairs with the
    /// linear part removed, both at once. The plain anchor fits the degree-1 terms alone to
    /// the small pairs, so the higher orders present there bias them (the damping most:
    /// `tests/damping_known.rs` prints the errors of both). `false` keeps the plain anchor.
    #[serde(default)]
    pub anchor_joint: bool,
}

impl FitOptions {
    /// Checks the options alone (no data) for one observable: see [`FitOptions::validate_for`].
    pub fn validate(&self) -> Result<(), FitError> {
        self.validate_for(1)
    }

    /// Checks the options alone (no data) for data of `q` observables: ranges, and the sizes
    /// the options imply against [`crate::limits`] (dimensions, orders, monomial counts,
    /// centres), so that nothing of that size is allocated first. [`fit`] calls it; the
    /// data-dependent sizes (rows of the regressions) are checked where the data are known,
    /// before each matrix is built.
    pub fn validate_for(&self, q: usize) -> Result<(), FitError> {
        use crate::limits::{self, MAX_CENTERS, MAX_DIM, MAX_EMBED, MAX_ORDER, MAX_SHIFT, MAX_TERMS};
        let bad = |what, why: String| Err(FitError::BadOption { what, why });
        if self.dim == 0 {
            return bad("dim", "must be >= 1".into());
        }
        limits::check("dim", self.dim, MAX_DIM)?;
        limits::check("embed", self.embed.saturating_mul(q), MAX_EMBED)?;
        if q == 1 && self.embed <= 2 * self.dim {
            return bad("embed", format!("p = {} must exceed 2 d = {} (Takens)", self.embed, 2 * self.dim));
        }
        if self.embed == 0 || q * self.embed <= 2 * self.dim {
            return bad(
                "embed",
                format!(
                    "p = {} copies of {q} observables = {} coordinates must exceed 2 d = {} (Takens)",
                    self.embed,
                    q * self.embed,
                    2 * self.dim
                ),
            );
        }
        if self.shift == 0 {
            return bad("shift", "must be >= 1 sample".into());
        }
        limits::check("shift", self.shift, MAX_SHIFT)?;
        if self.manifold_order == 0 {
            return bad("manifold_order", "must be >= 1".into());
        }
        limits::check("manifold_order", self.manifold_order as usize, MAX_ORDER as usize)?;
        if self.dyn_order == 0 {
            return bad("dyn_order", "must be >= 1".into());
        }
        limits::check("dyn_order", self.dyn_order as usize, MAX_ORDER as usize)?;
        let terms = |min: u32, max: u32| super::poly::count(self.dim, min, max).unwrap_or(usize::MAX);
        limits::check("manifold monomials (dim, manifold_order)", terms(1, self.manifold_order), MAX_TERMS)?;
        match self.dynamics {
            Dynamics::Flow | Dynamics::Map => {
                limits::check("dynamics monomials (dim, dyn_order)", terms(1, self.dyn_order), MAX_TERMS)?;
            }
            Dynamics::Rbf { centers } | Dynamics::RbfWith { centers, .. } => {
                if let Dynamics::RbfWith { kernel, .. } = self.dynamics {
                    kernel.validate()?;
                }
                if centers == 0 {
                    return bad("rbf centers", "need at least one centre".into());
                }
                limits::check("rbf centers", centers, MAX_CENTERS)?;
            }
        }
        if let Some(f) = self.linear_anchor {
            if !(f > 0.0 && f <= 1.0) {
                return bad("linear_anchor", format!("the radius fraction must be in (0, 1], got {f}"));
            }
        }
        Ok(())
    }
}

/// The `format` tag of a saved model file.
pub const MODEL_FORMAT: &str = "ssm-model";
/// The saved-model format version this build writes and reads.
pub const MODEL_FORMAT_VERSION: u32 = 1;

/// A saved model file that cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum ModelFileError {
    #[error("not a saved SSM model ({0}; `ssmctl fit --save` writes \"format\": \"ssm-model\")")]
    NotAModel(String),
    #[error("saved-model format version {found}; this build reads version 1 (refit and save with this version)")]
    Version { found: String },
    #[error("saved model: {0}")]
    Json(serde_json::Error),
    #[error("saved model: `{field}`: {why}")]
    Invalid { field: String, why: String },
}

/// A fitted SSM-reduced model (serializable, e.g. to JSON).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SsmModel {
    pub options: FitOptions,
    /// Mean sampling step of the training data.
    pub dt: f64,
    pub manifold: Manifold,
    pub dynamics: ReducedDynamics,
    /// Continuous-time eigenvalues (re, im) of the linear part of the reduced dynamics.
    pub eigenvalues_ct: Vec<(f64, f64)>,
    /// Per-coordinate max |eta| over the training data (blow-up detection reference).
    pub eta_range: Vec<f64>,
    /// Number of embedded training points.
    pub n_points: usize,
    /// Number of observables q of the training data (1 for scalar series; absent from
    /// saved scalar models, which read back as 1).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub observables: usize,
}

fn one() -> usize {
    1
}

fn is_one(q: &usize) -> bool {
    *q == 1
}

/// Why a prediction stopped early.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum StopReason {
    /// A reduced coordinate became NaN or infinite.
    NonFinite,
    /// Coordinate `coord` reached `value`, beyond `BLOWUP_FACTOR` x its training range.
    LeftRange { coord: usize, value: f64, limit: f64 },
}

impl std::fmt::Display for StopReason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StopReason::NonFinite => write!(f, "a reduced coordinate became non-finite"),
            StopReason::LeftRange { coord, value, limit } => write!(
                f,
                "reduced coordinate {coord} reached {value:.6e}, beyond {limit:.6e} (the blow-up limit from its training range)"
            ),
        }
    }
}

/// Where and why a prediction stopped.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stop {
    /// Index of the first embedded sample that was not produced.
    pub index: usize,
    pub t: f64,
    pub reason: StopReason,
}

/// A model prediction of the observable. All values are finite.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Prediction {
    /// Times of the predicted samples (a prefix of the test's times).
    pub t: Vec<f64>,
    /// Predicted observable. Full test length when `stop` is `None`: sample `n` comes from
    /// embedded point `m = n - k shift` (coordinate k, the smallest k with m in range), so
    /// the last `(p-1) shift` samples use the later coordinates of the last point.
    /// When stopped early, only the samples of the produced embedded points. With q
    /// observables ([`SsmModel::predict_multi`]) row-major `len x q`, as
    /// [`MultiSeries::x`].
    pub x: Vec<f64>,
    /// Reduced coordinates of the produced embedded points, row-major `len x d`.
    pub eta: Vec<f64>,
    pub stop: Option<Stop>,
    /// Conditioning of the manifold regression (absent for a linear manifold).
    pub manifold_conditioning: Option<Conditioning>,
    /// Conditioning of the dynamics regression.
    pub dynamics_conditioning: Conditioning,
}

impl Prediction {
    /// NMTE of the predicted observable against `test` (SSMLearn definition, see
    /// [`metrics::nmte`]). Infinite when the prediction stopped early (as SSMLearn does for
    /// failed integrations).
    pub fn nmte(&self, test: &TimeSeries) -> f64 {
        if self.stop.is_some() || self.x.len() != test.x.len() {
            return f64::INFINITY;
        }
        metrics::nmte(&self.x, &test.x, 1).unwrap_or(f64::INFINITY)
    }

    /// NMTE over all observables of `test` (the error norm of the observable vector, see
    /// [`metrics::nmte`]); infinite when the prediction stopped early.
    pub fn nmte_multi(&self, test: &MultiSeries) -> f64 {
        if self.stop.is_some() || self.x.len() != test.x.len() {
            return f64::INFINITY;
        }
        metrics::nmte(&self.x, &test.x, test.dim()).unwrap_or(f64::INFINITY)
    }

    /// NMTE after DTW alignment (Sakoe-Chiba band `band` samples), on the predicted prefix.
    pub fn nmte_dtw(&self, test: &TimeSeries, band: Option<usize>) -> f64 {
        let n = self.x.len().min(test.x.len());
        metrics::nmte_dtw(&self.x[..n], &test.x[..n], 1, band).unwrap_or(f64::INFINITY)
    }

    /// [`Prediction::nmte_dtw`] over all observables of `test`.
    pub fn nmte_dtw_multi(&self, test: &MultiSeries, band: Option<usize>) -> f64 {
        let n = self.x.len().min(test.x.len());
        metrics::nmte_dtw(&self.x[..n], &test.x[..n], test.dim(), band).unwrap_or(f64::INFINITY)
    }
}

/// Fits an SSM-reduced model to training series `train` (each validated again here).
pub fn fit(train: &[TimeSeries], opts: &FitOptions) -> Result<SsmModel, FitError> {
    fit_impl(&as_multi(train)?, opts, Tangent::Own, None)
}

/// Fits an SSM-reduced model to trajectories of several observables (each validated again
/// here; all must have the same number of observables): `opts.embed` copies of every
/// observable are stacked (see [`crate::embed`]), and predictions and NMTE are over all
/// observables.
pub fn fit_multi(train: &[MultiSeries], opts: &FitOptions) -> Result<SsmModel, FitError> {
    fit_impl(train, opts, Tangent::Own, None)
}

/// Scalar series as one-observable trajectories, each validated as a scalar series first
/// (so errors read as before).
fn as_multi(train: &[TimeSeries]) -> Result<Vec<MultiSeries>, FitError> {
    train
        .iter()
        .map(|ts| {
            ts.validate()?;
            Ok(MultiSeries::from(ts))
        })
        .collect()
}

/// [`fit`] with a degree-1 normal part in the manifold (tangent = the SVD of `train`'s own
/// data, see [`Manifold::fit_with_linear_normal`]). The model's `options` do not record it:
/// the manifold's normal part has degree-1 terms.
pub fn fit_with_linear_normal(train: &[TimeSeries], opts: &FitOptions) -> Result<SsmModel, FitError> {
    fit_impl(&as_multi(train)?, opts, Tangent::OwnLinearNormal, None)
}

/// [`fit`] with a given tangent basis `v1` (`p x d`, column-major, orthonormal columns)
/// instead of the SVD of `train`'s own data: the manifold is a graph over `v1` including a
/// degree-1 normal part (see [`Manifold::fit_with_tangent`]). Models fitted with the same
/// `v1` share their reduced coordinates `eta = V1^T y`, so their coefficients can be
/// compared and interpolated.
pub fn fit_with_tangent(train: &[TimeSeries], opts: &FitOptions, v1: &[f64]) -> Result<SsmModel, FitError> {
    fit_impl(&as_multi(train)?, opts, Tangent::Given(v1, None), None)
}

/// [`fit_with_tangent`] with the reduced dynamics' regression rows weighted by `weight`
/// ([`ReducedDynamics::fit_weighted`]; `None`: [`fit_with_tangent`]). The weight is training
/// metadata: the model's `options` do not record it.
pub fn fit_with_tangent_weighted(
    train: &[TimeSeries],
    opts: &FitOptions,
    v1: &[f64],
    weight: Option<&RowWeight>,
) -> Result<SsmModel, FitError> {
    fit_with_tangent_weights(train, opts, v1, weight, None)
}

/// [`fit_with_tangent_weighted`] with the manifold's regression rows weighted too, by
/// `manifold_weight` ([`Manifold::fit_with_tangent_weighted`]); `None` leaves it unweighted.
pub fn fit_with_tangent_weights(
    train: &[TimeSeries],
    opts: &FitOptions,
    v1: &[f64],
    weight: Option<&RowWeight>,
    manifold_weight: Option<&RowWeight>,
) -> Result<SsmModel, FitError> {
    fit_impl(&as_multi(train)?, opts, Tangent::Given(v1, manifold_weight), weight)
}

/// Delay embeddings (`p x M_i`) and sampling steps of validated training series.
pub fn embed_training(train: &[TimeSeries], opts: &FitOptions) -> Result<(Vec<faer::Mat<f64>>, Vec<f64>), FitError> {
    embed_training_multi(&as_multi(train)?, opts)
}

/// Embeddings (`q p x M_i`) and sampling steps of validated trajectories of q observables.
pub fn embed_training_multi(
    train: &[MultiSeries],
    opts: &FitOptions,
) -> Result<(Vec<faer::Mat<f64>>, Vec<f64>), FitError> {
    opts.validate_for(train.first().map_or(1, MultiSeries::dim))?;
    if train.is_empty() {
        return Err(FitError::NoTrainingData);
    }
    check_same_observables(train, false)?;
    // Flow fitting drops 2 points per end; require a few usable points per trajectory.
    let min_points = 8;
    let mut ys = Vec::with_capacity(train.len());
    let mut dts = Vec::with_capacity(train.len());
    let mut total = 0usize;
    for ts in train {
        ts.validate()?;
        total = total.saturating_add(embedded_len(ts.len(), opts.embed, opts.shift).unwrap_or(0));
        crate::limits::check_matrix(
            "delay embedding of the training data",
            opts.embed.saturating_mul(ts.dim()),
            total,
            false,
        )?;
        ys.push(delay_embed_multi(ts, opts.embed, opts.shift, min_points)?);
        dts.push(ts.dt().unwrap_or(0.0));
    }
    Ok((ys, dts))
}

/// The manifold's tangent basis in [`fit_impl`].
#[derive(Clone, Copy)]
enum Tangent<'a> {
    /// The SVD of the training data, normal part of degrees 2..=K ([`Manifold::fit`]).
    Own,
    /// The SVD of the training data, normal part of degrees 1..=K.
    OwnLinearNormal,
    /// A given basis, normal part of degrees 1..=K ([`Manifold::fit_with_tangent`]), its
    /// rows weighted if a weight is given.
    Given(&'a [f64], Option<&'a RowWeight>),
}

fn fit_impl(
    train: &[MultiSeries],
    opts: &FitOptions,
    tangent: Tangent<'_>,
    weight: Option<&RowWeight>,
) -> Result<SsmModel, FitError> {
    let (ys, dts) = embed_training_multi(train, opts)?;
    let manifold = match tangent {
        Tangent::Own => Manifold::fit(&ys, opts.dim, opts.manifold_order, opts.ridge)?,
        Tangent::OwnLinearNormal => Manifold::fit_with_linear_normal(&ys, opts.dim, opts.manifold_order, opts.ridge)?,
        Tangent::Given(v1, w) => {
            Manifold::fit_with_tangent_weighted(&ys, v1, opts.dim, opts.manifold_order, opts.ridge, w)?
        }
    };
    let etas: Vec<_> = ys.iter().map(|y| manifold.reduce_points(y.as_ref())).collect();
    let trajs: Vec<EtaTrajectory> =
        etas.iter().zip(&dts).map(|(e, &dt)| EtaTrajectory { eta: e.as_ref(), dt }).collect();
    let dynamics = ReducedDynamics::fit_weighted(
        &trajs,
        opts.dynamics,
        opts.dyn_order,
        opts.ridge,
        opts.linear_anchor,
        opts.anchor_joint,
        weight,
    )?;
    let eigenvalues_ct = dynamics.eigenvalues_ct()?;
    let eta_range = super::dynamics::eta_scale(&trajs);
    let dt = dts.iter().sum::<f64>() / dts.len() as f64;
    Ok(SsmModel {
        options: *opts,
        dt,
        manifold,
        dynamics,
        eigenvalues_ct,
        eta_range,
        n_points: ys.iter().map(|y| y.ncols()).sum(),
        observables: train[0].dim(),
    })
}

impl SsmModel {
    /// Continuous-time eigenvalues (re, im) of the reduced dynamics' linear part.
    pub fn eigenvalues_ct(&self) -> &[(f64, f64)] {
        &self.eigenvalues_ct
    }

    /// Predicts the observable of `test` from its first embedded point over its whole
    /// length. Blow-up (non-finite state or a reduced coordinate beyond
    /// [`BLOWUP_FACTOR`] x its training range) truncates the prediction and sets `stop`.
    pub fn predict(&self, test: &TimeSeries) -> Result<Prediction, FitError> {
        test.validate()?;
        self.predict_multi(&MultiSeries::from(test))
    }

    /// [`SsmModel::predict`] for a trajectory of the model's q observables: `x` of the
    /// prediction is row-major `len x q`.
    pub fn predict_multi(&self, test: &MultiSeries) -> Result<Prediction, FitError> {
        test.validate()?;
        let q = self.observables;
        if test.dim() != q {
            return Err(FitError::Observables { name: test.name.clone(), got: test.dim(), expected: q });
        }
        let (copies, s, d) = (self.options.embed, self.options.shift, self.options.dim);
        let p = self.manifold.p;
        crate::limits::check_matrix(
            "delay embedding of the test data",
            p,
            embedded_len(test.len(), copies, s).unwrap_or(0),
            false,
        )?;
        // At least `s` embedded points: every sample is then some coordinate of a produced
        // point (with fewer, samples between the last point's coordinates have none).
        let y = delay_embed_multi(test, copies, s, s)?;
        let dt = test.dt().unwrap_or(self.dt);
        let map_dt = self.dynamics.map_dt().unwrap_or(dt);
        if (dt - map_dt).abs() > MAP_DT_RTOL * map_dt {
            return Err(FitError::StepMismatch { name: test.name.clone(), dt, dt_model: map_dt, rtol: MAP_DT_RTOL });
        }
        let m_total = embedded_len(test.len(), copies, s).unwrap_or(0);
        let y0: Vec<f64> = (0..p).map(|i| y[(i, 0)]).collect();
        let mut eta = self.manifold.reduce(&y0);
        let mut etas = Vec::with_capacity(m_total * d);
        let mut scratch = StepScratch::default();
        let mut stop = None;
        // Map and lift prepared once for the run (the same bits as the plain ones).
        let (map, manifold) = (self.dynamics.prepare(), self.manifold.prepare());
        for n in 0..m_total {
            if let Some(reason) = self.check(&eta) {
                stop = Some(Stop { index: n, t: test.t[n], reason });
                break;
            }
            etas.extend_from_slice(&eta);
            if n + 1 < m_total {
                map.step(&mut eta, dt, &mut scratch);
            }
        }
        let mut produced = etas.len() / d;
        let mut lifted = vec![0.0; produced * p];
        let mut ps = PolyScratch::default();
        for (k, e) in etas.chunks_exact(d).enumerate() {
            let out = &mut lifted[k * p..(k + 1) * p];
            manifold.lift_into(e, &mut ps, out);
            // A finite state can still lift to a non-finite observable (coefficients of a
            // corrupted or extreme model): the prediction stops there, it never emits one.
            if out.iter().any(|v| !v.is_finite()) {
                produced = k;
                stop = Some(Stop { index: k, t: test.t[k], reason: StopReason::NonFinite });
                break;
            }
        }
        etas.truncate(produced * d);
        lifted.truncate(produced * p);
        let len = if stop.is_some() { produced } else { test.len() };
        let mut x = Vec::with_capacity(len * q);
        for n in 0..len {
            // smallest k with m = n - k s <= produced - 1
            let over = n.saturating_sub(produced.saturating_sub(1));
            let k = over.div_ceil(s);
            let m = n - k * s;
            x.extend_from_slice(&lifted[m * p + k * q..m * p + (k + 1) * q]);
        }
        Ok(Prediction {
            t: test.t[..len].to_vec(),
            x,
            eta: etas,
            stop,
            manifold_conditioning: self.manifold.conditioning,
            dynamics_conditioning: *self.dynamics.conditioning(),
        })
    }

    fn check(&self, eta: &[f64]) -> Option<StopReason> {
        if eta.iter().any(|v| !v.is_finite()) {
            return Some(StopReason::NonFinite);
        }
        for (coord, (v, r)) in eta.iter().zip(&self.eta_range).enumerate() {
            let limit = BLOWUP_FACTOR * r;
            if v.abs() > limit {
                return Some(StopReason::LeftRange { coord, value: *v, limit });
            }
        }
        None
    }

    /// The model as pretty JSON in the saved-model format: `{"format": MODEL_FORMAT,
    /// "version": MODEL_FORMAT_VERSION, "model": {...}}`.
    pub fn to_json(&self) -> Result<String, serde_json::Error> {
        #[derive(Serialize)]
        struct Saved<'a> {
            format: &'static str,
            version: u32,
            model: &'a SsmModel,
        }
        serde_json::to_string_pretty(&Saved { format: MODEL_FORMAT, version: MODEL_FORMAT_VERSION, model: self })
    }

    /// Reads a model saved by [`SsmModel::to_json`]; another format or version is an error
    /// naming what was found, and so is a model whose shapes do not fit together.
    pub fn from_json(text: &str) -> Result<Self, ModelFileError> {
        let v: serde_json::Value = serde_json::from_str(text).map_err(ModelFileError::Json)?;
        let format = v.get("format").and_then(serde_json::Value::as_str);
        if format != Some(MODEL_FORMAT) {
            return Err(ModelFileError::NotAModel(
                format.map_or_else(|| "no \"format\" key".into(), |f| format!("format \"{f}\"")),
            ));
        }
        match v.get("version").and_then(serde_json::Value::as_u64) {
            Some(n) if n == u64::from(MODEL_FORMAT_VERSION) => {}
            found => {
                return Err(ModelFileError::Version { found: found.map_or_else(|| "none".into(), |n| n.to_string()) });
            }
        }
        let model = v.get("model").ok_or(ModelFileError::NotAModel("no \"model\" key".into()))?;
        let m: SsmModel = serde_json::from_value(model.clone()).map_err(ModelFileError::Json)?;
        m.validate()?;
        Ok(m)
    }

    /// Checks that the parts of a model fit together before anything indexes them: the
    /// options within [`crate::limits`], every vector of the length the dimensions imply
    /// (`manifold.v1` = p * dim, scales = dim, coefficients = terms * outputs, ...), every
    /// exponent vector of length dim with degree 1..=[`crate::limits::MAX_ORDER`], steps and
    /// scales positive, every number finite. The error names the field (its JSON path
    /// under `model`).
    pub fn validate(&self) -> Result<(), ModelFileError> {
        let inv = |field: &str, why: String| Err(ModelFileError::Invalid { field: field.to_string(), why });
        if self.observables == 0 {
            return inv("observables", "must be >= 1".into());
        }
        if let Err(e) = self.options.validate_for(self.observables) {
            return inv("options", e.to_string());
        }
        // The embedding holds `embed` delayed copies of every observable.
        let (d, p) = (self.options.dim, self.options.embed * self.observables);
        time_step("dt", self.dt, None)?;
        let man = &self.manifold;
        if man.dim != d {
            return inv("manifold.dim", format!("{} differs from options.dim = {d}", man.dim));
        }
        if man.p != p {
            return inv("manifold.p", format!("{} differs from options.embed x observables = {p}", man.p));
        }
        finite_vec("manifold.v1", &man.v1, p * d)?;
        if man.singular_values.len() > p {
            return inv("manifold.singular_values", format!("{} values, at most p = {p}", man.singular_values.len()));
        }
        finite_vec("manifold.singular_values", &man.singular_values, man.singular_values.len())?;
        positive_vec("manifold.eta_scale", &man.eta_scale, d)?;
        if let Some(poly) = &man.nonlinear {
            check_poly("manifold.nonlinear", poly, d, p)?;
        }
        match &self.dynamics {
            ReducedDynamics::Flow { field, .. } => check_poly("dynamics.Flow.field", field, d, d)?,
            ReducedDynamics::Map { increment, dt, .. } => {
                check_poly("dynamics.Map.increment", increment, d, d)?;
                time_step("dynamics.Map.dt", *dt, Some(self.dt))?;
            }
            ReducedDynamics::Rbf(r) => {
                if r.dim != d {
                    return inv("dynamics.Rbf.dim", format!("{} differs from options.dim = {d}", r.dim));
                }
                time_step("dynamics.Rbf.dt", r.dt, Some(self.dt))?;
                positive_vec("dynamics.Rbf.scale", &r.scale, d)?;
                if r.centers.is_empty() || r.centers.len() % d != 0 {
                    return inv(
                        "dynamics.Rbf.centers",
                        format!("length {} is not a positive multiple of dim = {d}", r.centers.len()),
                    );
                }
                let k = r.centers.len() / d;
                if k > crate::limits::MAX_CENTERS {
                    return inv(
                        "dynamics.Rbf.centers",
                        format!("{k} centres exceed the limit of {}", crate::limits::MAX_CENTERS),
                    );
                }
                finite_vec("dynamics.Rbf.centers", &r.centers, k * d)?;
                finite_vec("dynamics.Rbf.coef", &r.coef, (k + d + 1) * d)?;
                if let Err(e) = r.kernel.validate() {
                    return inv("dynamics.Rbf.kernel", e.to_string());
                }
                if self.options.dynamics.rbf().is_some_and(|(_, k)| k != r.kernel) {
                    return inv(
                        "dynamics.Rbf.kernel",
                        format!("{} differs from the options' kernel {:?}", r.kernel.name(), self.options.dynamics),
                    );
                }
            }
        }
        if self.eigenvalues_ct.len() != d {
            return inv("eigenvalues_ct", format!("{} values, expected dim = {d}", self.eigenvalues_ct.len()));
        }
        finite_vec("eta_range", &self.eta_range, d)?;
        if let Some(v) = self.eta_range.iter().find(|v| **v < 0.0) {
            return inv("eta_range", format!("contains the negative range {v}"));
        }
        Ok(())
    }
}

/// `field` must be finite and > 0.
/// A time step: positive, finite and a normal number, and (for a part of the model) the
/// model's own `dt` within [`crate::dynamics::MAP_DT_RTOL`].
fn time_step(field: &str, v: f64, model_dt: Option<f64>) -> Result<(), ModelFileError> {
    positive(field, v)?;
    if !v.is_normal() {
        return Err(ModelFileError::Invalid { field: field.to_string(), why: format!("{v:e} s is subnormal") });
    }
    if let Some(dt) = model_dt {
        if (v - dt).abs() > crate::dynamics::MAP_DT_RTOL * dt {
            return Err(ModelFileError::Invalid {
                field: field.to_string(),
                why: format!("{v} s differs from the model's dt = {dt} s"),
            });
        }
    }
    Ok(())
}

fn positive(field: &str, v: f64) -> Result<(), ModelFileError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ModelFileError::Invalid { field: field.to_string(), why: format!("must be finite and > 0, got {v}") })
    }
}

/// `field` must hold exactly `len` finite values.
fn finite_vec(field: &str, v: &[f64], len: usize) -> Result<(), ModelFileError> {
    if v.len() != len {
        return Err(ModelFileError::Invalid {
            field: field.to_string(),
            why: format!("length {}, expected {len}", v.len()),
        });
    }
    if let Some((i, x)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(ModelFileError::Invalid { field: format!("{field}[{i}]"), why: format!("not finite ({x})") });
    }
    Ok(())
}

/// `field` must hold exactly `len` finite values > 0.
fn positive_vec(field: &str, v: &[f64], len: usize) -> Result<(), ModelFileError> {
    finite_vec(field, v, len)?;
    if let Some((i, x)) = v.iter().enumerate().find(|(_, x)| **x <= 0.0) {
        return Err(ModelFileError::Invalid { field: format!("{field}[{i}]"), why: format!("must be > 0, got {x}") });
    }
    Ok(())
}

/// A polynomial `dim_in -> dim_out`: shapes, degrees within the limit, finite values.
fn check_poly(field: &str, poly: &super::poly::Poly, dim_in: usize, dim_out: usize) -> Result<(), ModelFileError> {
    use crate::limits::{MAX_ORDER, MAX_TERMS};
    let inv = |sub: &str, why: String| Err(ModelFileError::Invalid { field: format!("{field}.{sub}"), why });
    if poly.dim_in != dim_in {
        return inv("dim_in", format!("{} differs from the expected {dim_in}", poly.dim_in));
    }
    if poly.dim_out != dim_out {
        return inv("dim_out", format!("{} differs from the expected {dim_out}", poly.dim_out));
    }
    positive_vec(&format!("{field}.scale"), &poly.scale, dim_in)?;
    if poly.exps.is_empty() || poly.exps.len() > MAX_TERMS {
        return inv("exps", format!("{} monomials, expected 1..={MAX_TERMS}", poly.exps.len()));
    }
    for (k, e) in poly.exps.iter().enumerate() {
        if e.len() != dim_in {
            return inv(&format!("exps[{k}]"), format!("length {}, expected dim_in = {dim_in}", e.len()));
        }
        let deg: u64 = e.iter().map(|&x| u64::from(x)).sum();
        if deg == 0 || deg > u64::from(MAX_ORDER) {
            return inv(&format!("exps[{k}]"), format!("total degree {deg}, expected 1..={MAX_ORDER}"));
        }
    }
    finite_vec(&format!("{field}.coef"), &poly.coef, poly.exps.len() * dim_out)
}
