//! `fit` (the options of `ssmctl fit`, on `Trajectory` objects), `Model` (wraps
//! `ssm::SsmModel`: prediction and NMTE, eigenvalues, the polar normal form, backbone curves,
//! the device blob, saved-model JSON), `Prediction`, `load_model` and `inspect_blob`.
//! Long computations release the GIL.

use numpy::{Complex64, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyList};
use ssm::backbone::{BackboneOptions, backbone};
use ssm::frc::{Calibration, FrcOptions, frc};
use ssm::{Dynamics, FitOptions, MultiSeries, Ridge, SsmModel, fit_multi};

use crate::convert::{guard, to_python, type_error, value_error, windows};
use crate::trajectory::{Trajectory, matrix};

/// A fitted SSM model: manifold, reduced dynamics and the options it was fitted with.
#[pyclass(module = "ssm_ctl", frozen)]
pub struct Model {
    pub inner: SsmModel,
    /// Wall time of the fit (s); None for a loaded model.
    pub fit_seconds: Option<f64>,
    /// With `fit(..., auto=True)`: the chosen settings, the runner-up and why.
    pub selection: Option<ssm::auto::AutoChoice>,
    /// With intervals: the bootstrap intervals.
    pub intervals: Option<ssm::auto::Intervals>,
}

/// A prediction of a trajectory from its first embedded point.
#[pyclass(module = "ssm_ctl", frozen)]
pub struct Prediction {
    inner: ssm::Prediction,
    q: usize,
    d: usize,
}

/// The trajectories of `obj`: one `Trajectory` or a sequence of them.
fn trajectories(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<MultiSeries>> {
    if let Ok(t) = obj.cast::<Trajectory>() {
        return Ok(vec![t.get().inner.clone()]);
    }
    let mut out = Vec::new();
    let it = obj.try_iter().map_err(|_| type_error(format!("{what}: expected a Trajectory or a list of them")))?;
    for item in it {
        let item = item?;
        let t = item.cast::<Trajectory>().map_err(|_| {
            type_error(format!("{what}: `{item}` is not a Trajectory (ssm_ctl.Trajectory(t, x), load_csv, load_mat)"))
        })?;
        out.push(t.get().inner.clone());
    }
    if out.is_empty() {
        return Err(value_error(format!("{what}: no trajectories")));
    }
    Ok(out)
}

fn parse_dynamics(s: &str, centers: usize) -> PyResult<Dynamics> {
    match s {
        "flow" => Ok(Dynamics::Flow),
        "map" => Ok(Dynamics::Map),
        "rbf" => Ok(Dynamics::Rbf { centers }),
        _ => match s.strip_prefix("rbf:") {
            Some(k) => ssm::Kernel::parse(k)
                .map(|kernel| Dynamics::RbfWith { centers, kernel })
                .map_err(|e| value_error(format!("dynamics `{s}`: {e}"))),
            None => Err(value_error(format!(
                "dynamics `{s}`: expected flow, map or rbf (or rbf:KERNEL, KERNEL: linear, cubic, thin-plate, gaussian:EPS)"
            ))),
        },
    }
}

fn parse_ridge(obj: &Bound<'_, PyAny>) -> PyResult<Ridge> {
    if let Ok(s) = obj.extract::<String>() {
        return if s == "cv" {
            Ok(Ridge::CrossValidated)
        } else {
            Err(value_error(format!("ridge `{s}`: expected a number >= 0 or \"cv\"")))
        };
    }
    match obj.extract::<f64>() {
        Ok(a) if a.is_finite() && a >= 0.0 => Ok(Ridge::Fixed(a)),
        Ok(_) => Err(value_error(format!("ridge `{obj}`: expected a number >= 0 or \"cv\""))),
        Err(_) => Err(type_error(format!("ridge `{obj}`: expected a number >= 0 or \"cv\""))),
    }
}

/// `fit(train, dim=None, embed=None, *, shift=1, order=3, dyn_order=5, dynamics="map",
/// centers=100, ridge=0.0, linear_anchor=None, anchor_joint=False, t_from=None, t_to=None,
/// auto=False, budget=40, intervals=None, replicates=200, seed=1, backbone_amplitude=None,
/// backbone_observable=0)`: fits an SSM model to the
/// training trajectories (a `Trajectory` or a list; every one with the same observables),
/// with the options and defaults of `ssmctl fit`: SSM dimension `dim`, `embed` delayed
/// copies of every observable (SSMLearn's `OverEmbedding` is `embed - 1`), manifold
/// polynomial order `order`, reduced dynamics `flow` | `map` (polynomial of order
/// `dyn_order`) | `rbf` (`centers` centres), ridge alpha or `"cv"`, the linear part anchored on
/// small amplitudes (`linear_anchor`, a fraction of the largest |eta|; with `anchor_joint`
/// the small pairs are picked by their envelope and the linear part is fitted jointly with
/// the higher orders, `ssmctl fit --anchor-joint`). `t_from`/`t_to`: time
/// windows (SSMLearn's `sliceTrajectories`): one number for all, or one per trajectory
/// (None entries leave that side open).
///
/// `auto=True` (`ssmctl fit --auto`): the settings are chosen by cross-validation (`dim`,
/// when given, fixes the dimension; `embed`, `shift`, the orders, `ridge` and the anchor must
/// stay at their defaults); `model.selection` holds the choice, the runner-up and why.
/// `intervals` (default: on with `auto`): bootstrap 95 % intervals in `model.intervals`
/// (eigenvalues, damping ratios, and backbone bands of observable `backbone_observable`
/// up to `backbone_amplitude`, when given).
#[pyfunction]
#[pyo3(signature = (train, dim=None, embed=None, *, shift=1, order=3, dyn_order=5, dynamics="map", centers=100, ridge=None, linear_anchor=None, anchor_joint=false, t_from=None, t_to=None, auto=false, budget=40, intervals=None, replicates=200, seed=1, backbone_amplitude=None, backbone_observable=0))]
#[allow(clippy::too_many_arguments)]
pub fn fit(
    py: Python<'_>,
    train: &Bound<'_, PyAny>,
    dim: Option<usize>,
    embed: Option<usize>,
    shift: usize,
    order: u32,
    dyn_order: u32,
    dynamics: &str,
    centers: usize,
    ridge: Option<&Bound<'_, PyAny>>,
    linear_anchor: Option<f64>,
    anchor_joint: bool,
    t_from: Option<&Bound<'_, PyAny>>,
    t_to: Option<&Bound<'_, PyAny>>,
    auto: bool,
    budget: usize,
    intervals: Option<bool>,
    replicates: usize,
    seed: u64,
    backbone_amplitude: Option<f64>,
    backbone_observable: usize,
) -> PyResult<Model> {
    guard(|| {
        let mut train = trajectories(train, "train")?;
        let n = train.len();
        let (from, to) = (windows(t_from, n, "t_from")?, windows(t_to, n, "t_to")?);
        for (k, t) in train.iter_mut().enumerate() {
            if from[k].is_some() || to[k].is_some() {
                *t = t.window(from[k], to[k]).map_err(value_error)?;
            }
        }
        let dynamics = parse_dynamics(dynamics, centers)?;
        if auto {
            let fixed = [
                ("embed", embed.is_some()),
                ("shift", shift != 1),
                ("order", order != 3),
                ("dyn_order", dyn_order != 5),
                ("ridge", ridge.is_some()),
                ("linear_anchor", linear_anchor.is_some()),
                ("t_from", t_from.is_some()),
            ];
            if let Some((name, _)) = fixed.iter().find(|(_, set)| *set) {
                return Err(value_error(format!("{name}: auto=True chooses it; leave it at its default")));
            }
        }
        let setting = if auto {
            None
        } else {
            let (Some(dim), Some(embed)) = (dim, embed) else {
                return Err(value_error("dim and embed are required without auto=True"));
            };
            Some(ssm::auto::Setting {
                cut: 0.0,
                options: FitOptions {
                    dim,
                    embed,
                    shift,
                    manifold_order: order,
                    dyn_order,
                    dynamics,
                    ridge: match ridge {
                        None => Ridge::Fixed(0.0),
                        Some(r) => parse_ridge(r)?,
                    },
                    linear_anchor,
                    anchor_joint,
                },
            })
        };
        let want_intervals = intervals.unwrap_or(auto);
        let backbone = match backbone_amplitude {
            Some(a) => Some((BackboneOptions::new(backbone_observable, a), 41)),
            None => None,
        };
        let run = || -> Result<_, ssm::Error> {
            let t0 = std::time::Instant::now();
            let (setting, selection) = match setting {
                Some(s) => (s, None),
                None => {
                    let o = ssm::auto::AutoOptions { dynamics, dim, budget, ..Default::default() };
                    let c = ssm::auto::select(&train, &o)?;
                    (c.best.setting, Some(c))
                }
            };
            let cut = ssm::auto::cut(&train, setting.cut);
            let model = fit_multi(&cut, &setting.options)?;
            let secs = t0.elapsed().as_secs_f64();
            let iv = if want_intervals {
                let o = ssm::auto::IntervalOptions { replicates, seed, backbone, ..Default::default() };
                Some(ssm::auto::intervals(&train, &setting, &o)?)
            } else {
                None
            };
            Ok((model, secs, selection, iv))
        };
        let (model, secs, selection, iv) = py.detach(run).map_err(value_error)?;
        Ok(Model { inner: model, fit_seconds: Some(secs), selection, intervals: iv })
    })
}

/// `load_model(path)`: a model saved by `Model.save` or `ssmctl fit --save`.
#[pyfunction]
pub fn load_model(path: std::path::PathBuf) -> PyResult<Model> {
    guard(|| Model::load(path))
}

/// `inspect_blob(blob)`: header and shapes of a device blob (bytes) after a full decode (magic,
/// version, lengths, CRC, every value): a dict; a bad blob is a `ValueError` naming what is
/// wrong.
#[pyfunction]
pub fn inspect_blob<'py>(py: Python<'py>, blob: &[u8]) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let (h, _) = shared::model::Header::parse(blob).map_err(|e| value_error(format!("blob: {e}")))?;
        let bytes = blob.to_vec();
        // `ssmctl inspect`'s decoder (on a thread of its own: the fixed-capacity model is several MB).
        let decoded = py.detach(move || {
            ssm::device::decode_host(&bytes)
                .map(|m| (m.p(), m.d(), m.k(), m.lift_order(), m.sample_period(), m.config().dt))
                .map_err(|e| format!("blob: {e}"))
        });
        let (p, d, k, lift_order, sample_period, dt) = decoded.map_err(value_error)?;
        let out = PyDict::new(py);
        out.set_item("format_version", h.version)?;
        out.set_item("bytes", blob.len())?;
        out.set_item("payload_bytes", h.payload_len)?;
        out.set_item("crc32", h.crc)?;
        out.set_item("p", p)?;
        out.set_item("d", d)?;
        out.set_item("centres", k)?;
        out.set_item("lift_order", lift_order)?;
        out.set_item("sample_period_s", sample_period)?;
        out.set_item("controller_dt_s", dt)?;
        Ok(out)
    })
}

#[pymethods]
impl Model {
    /// Predicts `traj` (same observables as the training data) from its first embedded
    /// point; a prediction that leaves the training range stops early (see `stopped`).
    fn predict(&self, py: Python<'_>, traj: PyRef<'_, Trajectory>) -> PyResult<Prediction> {
        guard(|| {
            let ts = traj.inner.clone();
            let p = py.detach(|| self.inner.predict_multi(&ts)).map_err(value_error)?;
            Ok(Prediction { inner: p, q: self.inner.observables, d: self.inner.manifold.dim })
        })
    }

    /// NMTE over all observables of the prediction of `traj` (SSMLearn's definition);
    /// infinite when the prediction stopped early.
    fn nmte(&self, py: Python<'_>, traj: PyRef<'_, Trajectory>) -> PyResult<f64> {
        guard(|| {
            let ts = traj.inner.clone();
            let p = py.detach(|| self.inner.predict_multi(&ts)).map_err(value_error)?;
            Ok(p.nmte_multi(&ts))
        })
    }

    /// Eigenvalues of the linear part, continuous time (1/s): complex numpy array.
    #[getter]
    fn eigenvalues<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<Complex64>>> {
        guard(|| {
            let v: Vec<Complex64> =
                self.inner.eigenvalues_ct().iter().map(|&(re, im)| Complex64::new(re, im)).collect();
            Ok(PyArray1::from_vec(py, v))
        })
    }

    /// Sampling step of the training data (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.inner.dt
    }

    /// SSM dimension d.
    #[getter]
    fn dim(&self) -> usize {
        self.inner.manifold.dim
    }

    /// Number of observables the model was fitted to.
    #[getter]
    fn observables(&self) -> usize {
        self.inner.observables
    }

    /// The fit options as a dict (`dim`, `embed`, `shift`, `manifold_order`, `dyn_order`,
    /// `dynamics`, `ridge`, `linear_anchor`).
    #[getter]
    fn options<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| to_python(py, &self.inner.options))
    }

    /// Wall time of the fit (s); None for a loaded model.
    #[getter]
    fn fit_seconds(&self) -> Option<f64> {
        self.fit_seconds
    }

    /// With `fit(..., auto=True)`: a dict with `dim` (the SSM dimension, the singular values
    /// and how it was chosen), `best` and `runner_up` (`setting` with `cut` and `options`,
    /// held-out `nmte`, eigenvalue `spread`, `score`), `folds`, `evaluated` and `reasons`;
    /// None otherwise.
    #[getter]
    fn selection<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.selection.as_ref().map(|s| to_python(py, s)).transpose()
    }

    /// With intervals: a dict with `method`, `level`, `replicates`, `failed`,
    /// `eigenvalues` (per eigenvalue, sorted by decreasing imaginary part: `re`, `im`,
    /// `damping_ratio`, each `{estimate, lo, hi}`) and `backbone` (bands: `amplitude`,
    /// `freq_rad_s`, `damping_ratio`); None otherwise.
    #[getter]
    fn intervals<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.intervals.as_ref().map(|s| to_python(py, s)).transpose()
    }

    /// Condition numbers of the manifold (None when linear) and dynamics regressions.
    #[getter]
    fn conditioning(&self) -> (Option<f64>, f64) {
        (self.inner.manifold.conditioning.map(|c| c.cond), self.inner.dynamics.conditioning().cond)
    }

    /// The extended normal form in polar coordinates (polynomial flow or map dynamics, even
    /// d): a dict with `modes`, `order`, `eigenvalues` (`[re, im]` per mode), `pexps`, `amp`
    /// and `phase` (coefficients of `rho_i' = rho_i sum_k amp[i][k] P^pexps[k]`, `theta_i' =
    /// sum_k phase[i][k] P^pexps[k]`, `P_j = rho_j^2`), and `table` (rows `{mode, monomial,
    /// rho_exps, value}` of the `rho_i'` equations, as `ssmctl fit --normal-form`).
    #[pyo3(signature = (order=None))]
    fn normal_form<'py>(&self, py: Python<'py>, order: Option<u32>) -> PyResult<Bound<'py, PyAny>> {
        guard(|| {
            let opts = ssm::normal_form::NormalFormOptions { order, ..Default::default() };
            let nf = py.detach(|| ssm::normal_form::model_normal_form(&self.inner, &opts)).map_err(value_error)?;
            let out = to_python(py, &nf)?;
            out.set_item("table", to_python(py, &nf.table().rows)?)?;
            Ok(out)
        })
    }

    /// Backbone curves, one dict per mode: `mode` (1-based), `observable` (0-based index),
    /// and numpy arrays `amplitude` (of the observable through the manifold, its own units),
    /// `freq_rad_s`, `damping_ratio` (`-Re lambda/|lambda|`), `rate`, `rho`, from 0 to
    /// `amplitude` in `points` steps.
    #[pyo3(signature = (amplitude, observable=0, points=101))]
    fn backbone<'py>(
        &self,
        py: Python<'py>,
        amplitude: f64,
        observable: usize,
        points: usize,
    ) -> PyResult<Bound<'py, PyList>> {
        guard(|| {
            let opts = BackboneOptions { points, ..BackboneOptions::new(observable, amplitude) };
            let curves = py.detach(|| backbone(&self.inner, &opts)).map_err(value_error)?;
            let out = PyList::empty(py);
            for c in &curves {
                let d = PyDict::new(py);
                d.set_item("mode", c.mode)?;
                d.set_item("observable", c.observable)?;
                let col = |f: fn(&ssm::backbone::BackbonePoint) -> f64| {
                    PyArray1::from_vec(py, c.points.iter().map(f).collect())
                };
                d.set_item("amplitude", col(|p| p.amplitude))?;
                d.set_item("freq_rad_s", col(|p| p.freq_rad_s))?;
                d.set_item("damping_ratio", col(|p| p.damping_ratio))?;
                d.set_item("rate", col(|p| p.rate))?;
                d.set_item("rho", col(|p| p.rho))?;
                out.append(d)?;
            }
            Ok(out)
        })
    }

    /// The forced response curve (SSMLearn's `calibrateFRC`; `ssmctl frc`): harmonic forcing
    /// added to the normal form of mode `mode`, its amplitude calibrated so that a steady
    /// state of amplitude `calibrate_amplitude` (max |observable| over a period) lies at the
    /// forcing frequency `calibrate_freq` (rad/s); all branches over `freq_min..freq_max`
    /// (rad/s, `points` frequencies) with their stability. Returns a dict: `calibration`
    /// (`freq_rad_s`, `amplitude`, `rho`, `forcing`), `amplitude_max`, `rho_max` and
    /// `branches`, a list of dicts with `stable` and numpy arrays `freq_rad_s`, `amplitude`,
    /// `rho`.
    #[pyo3(signature = (freq_min, freq_max, calibrate_freq, calibrate_amplitude, observable=0, mode=0, points=301, amplitude_max=None))]
    #[allow(clippy::too_many_arguments)]
    fn forced_response<'py>(
        &self,
        py: Python<'py>,
        freq_min: f64,
        freq_max: f64,
        calibrate_freq: f64,
        calibrate_amplitude: f64,
        observable: usize,
        mode: usize,
        points: usize,
        amplitude_max: Option<f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let opts = FrcOptions { mode, amplitude_max, ..FrcOptions::new(observable) };
            let cal = Calibration { freq_rad_s: calibrate_freq, amplitude: calibrate_amplitude };
            let curve = py.detach(|| frc(&self.inner, &opts, cal, freq_min, freq_max, points)).map_err(value_error)?;
            let out = PyDict::new(py);
            let c = curve.calibration;
            let cal_d = PyDict::new(py);
            cal_d.set_item("freq_rad_s", c.freq_rad_s)?;
            cal_d.set_item("amplitude", c.amplitude)?;
            cal_d.set_item("rho", c.rho)?;
            cal_d.set_item("forcing", c.forcing)?;
            out.set_item("calibration", cal_d)?;
            out.set_item("mode", curve.mode)?;
            out.set_item("observable", curve.observable)?;
            out.set_item("amplitude_max", curve.amplitude_max)?;
            out.set_item("rho_max", curve.rho_max)?;
            let branches = PyList::empty(py);
            for b in &curve.branches {
                let d = PyDict::new(py);
                d.set_item("stable", b.stable)?;
                d.set_item("freq_rad_s", PyArray1::from_slice(py, &b.freq_rad_s))?;
                d.set_item("amplitude", PyArray1::from_slice(py, &b.amplitude))?;
                d.set_item("rho", PyArray1::from_slice(py, &b.rho))?;
                branches.append(d)?;
            }
            out.set_item("branches", branches)?;
            Ok(out)
        })
    }

    /// The device blob (bytes) of an RBF model of one observable, for the paper's controller
    /// at the model's sampling step (what `ssmctl export` writes without `--scene`).
    fn device_blob<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        guard(|| {
            let owned = ssm::device::to_device_model(&self.inner, shared::ControllerConfig::paper(self.inner.dt))
                .map_err(value_error)?;
            let blob = ssm::device::encode(&owned).map_err(value_error)?;
            Ok(PyBytes::new(py, &blob))
        })
    }

    /// The saved-model JSON (`{"format": "ssm-model", "version": 1, "model": ...}`), the
    /// format of `ssmctl fit --save`.
    fn to_json(&self) -> PyResult<String> {
        guard(|| self.inner.to_json().map_err(value_error))
    }

    /// Writes the saved-model JSON to `path`.
    fn save(&self, path: std::path::PathBuf) -> PyResult<()> {
        guard(|| {
            let text = self.to_json()?;
            // The tool's one writer: complete or absent, never through a link or into a device.
            fileio::write_atomic(&path, text.as_bytes()).map_err(|e| value_error(e.to_string()))
        })
    }

    /// A model from its saved JSON text (other formats and versions are refused).
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Model> {
        guard(|| {
            Ok(Model {
                inner: SsmModel::from_json(text).map_err(value_error)?,
                fit_seconds: None,
                selection: None,
                intervals: None,
            })
        })
    }

    /// A model from a saved-model file.
    #[staticmethod]
    fn load(path: std::path::PathBuf) -> PyResult<Model> {
        guard(|| {
            let text = ssm::limits::read_text_limited(&path, ssm::limits::MAX_MODEL_FILE_BYTES)
                .map_err(|e| value_error(format!("{}: cannot read: {e}", path.display())))?;
            Ok(Model {
                inner: SsmModel::from_json(&text).map_err(|e| value_error(format!("{}: {e}", path.display())))?,
                fit_seconds: None,
                selection: None,
                intervals: None,
            })
        })
    }

    fn __repr__(&self) -> String {
        let o = &self.inner.options;
        format!(
            "Model(dim={}, embed={}, observables={}, dynamics={:?}, order={}, dt={} s)",
            o.dim, o.embed, self.inner.observables, o.dynamics, o.manifold_order, self.inner.dt
        )
    }
}

#[pymethods]
impl Prediction {
    /// Times of the predicted samples (s), shape `(n,)` (a prefix of the trajectory's when
    /// the prediction stopped early).
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.t)
    }

    /// Predicted observables, shape `(n, q)`.
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        matrix(py, &self.inner.x, self.q)
    }

    /// Reduced coordinates of the embedded points, shape `(m, d)`.
    #[getter]
    fn eta<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        matrix(py, &self.inner.eta, self.d)
    }

    /// None, or why and where the prediction stopped: `{"index", "t", "reason"}`.
    #[getter]
    fn stopped<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_python(py, &self.inner.stop)
    }

    /// NMTE over all observables against `traj` (infinite when stopped early).
    fn nmte(&self, traj: PyRef<'_, Trajectory>) -> PyResult<f64> {
        guard(|| Ok(self.inner.nmte_multi(&traj.inner)))
    }

    /// NMTE after DTW alignment (Sakoe-Chiba band of `band` samples, None: no band).
    #[pyo3(signature = (traj, band=None))]
    fn nmte_dtw(&self, traj: PyRef<'_, Trajectory>, band: Option<usize>) -> PyResult<f64> {
        guard(|| Ok(self.inner.nmte_dtw_multi(&traj.inner, band)))
    }

    fn __len__(&self) -> usize {
        self.inner.t.len()
    }
}
