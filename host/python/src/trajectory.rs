//! `Trajectory` (wraps `ssm::MultiSeries`): one uniformly sampled trajectory of one or
//! several observables, made from numpy arrays or read from a CSV file or an SSMLearn `.mat`
//! file (`load_csv`, `load_mat`); `window` is SSMLearn's `sliceTrajectories`, `select` picks
//! observables. Arrays out are copies: `t` of shape `(n,)`, `x` of shape `(n, q)`.

use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;
use ssm::MultiSeries;

use crate::convert::{float_array, guard, observable_names, value_error};

/// One trajectory: times `t` (s, strictly increasing, uniform) and samples `x`, one row per
/// time and one column per observable.
#[pyclass(module = "ssm_ctl", frozen)]
#[derive(Clone)]
pub struct Trajectory {
    pub inner: MultiSeries,
}

/// `x` (row-major `n x q`) as a numpy array of shape `(n, q)`.
pub fn matrix<'py>(py: Python<'py>, x: &[f64], q: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = x.len().checked_div(q).unwrap_or(0);
    PyArray1::from_slice(py, x).reshape([n, q])
}

#[pymethods]
impl Trajectory {
    /// `Trajectory(t, x, observables=None, name="array")`: `t` of shape `(n,)`, `x` of shape
    /// `(n,)` or `(n, q)` (samples along the first axis; SSMLearn's `X`, one row per
    /// observable, is `x.T`). Observables default to `"1"`, ..., `"q"`, as the rows of a
    /// `.mat` file's X. Validated like a file: finite, uniform increasing times, no constant
    /// observable.
    #[new]
    #[pyo3(signature = (t, x, observables=None, name="array"))]
    fn new(t: &Bound<'_, PyAny>, x: &Bound<'_, PyAny>, observables: Option<Vec<String>>, name: &str) -> PyResult<Self> {
        guard(|| {
            let (ts, t) = float_array(t, "t")?;
            if ts.len() != 1 {
                return Err(value_error(format!("{name}: t has shape {ts:?}; expected a 1-D array of times")));
            }
            let n = t.len();
            let (xs, x) = float_array(x, "x")?;
            let q = match xs.as_slice() {
                [m] if *m == n => 1,
                [m, q] if *m == n => *q,
                [q, m] if *m == n => {
                    return Err(value_error(format!(
                        "{name}: x is {q} x {m} for {n} times: samples go along the first axis, shape ({n}, q) (x.T for SSMLearn's X)"
                    )));
                }
                _ => {
                    return Err(value_error(format!(
                        "{name}: x has shape {xs:?}; expected ({n},) or ({n}, q) for {n} times"
                    )));
                }
            };
            let observables = observables.unwrap_or_else(|| (1..=q).map(|i| i.to_string()).collect());
            if observables.len() != q {
                return Err(value_error(format!(
                    "{name}: {} observable names for {q} columns of x",
                    observables.len()
                )));
            }
            Ok(Trajectory { inner: MultiSeries::new(name, t, observables, x).map_err(value_error)? })
        })
    }

    /// Sample times (s), shape `(n,)`.
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.t)
    }

    /// Samples, shape `(n, q)`.
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        matrix(py, &self.inner.x, self.inner.dim())
    }

    /// Observable names (CSV columns; `"1"`, `"2"`, ... for the rows of a `.mat` X).
    #[getter]
    fn observables(&self) -> Vec<String> {
        self.inner.observables.clone()
    }

    /// The name used in error messages (file, and `xData{k,:}` for a `.mat` row).
    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }

    /// Mean sampling step (s).
    #[getter]
    fn dt(&self) -> Option<f64> {
        self.inner.dt()
    }

    fn __len__(&self) -> usize {
        self.inner.len()
    }

    fn __repr__(&self) -> String {
        let (a, b) =
            (self.inner.t.first().copied().unwrap_or(f64::NAN), self.inner.t.last().copied().unwrap_or(f64::NAN));
        format!(
            "Trajectory({:?}, {} samples, t = {a} .. {b} s, observables {:?})",
            self.inner.name,
            self.inner.len(),
            self.inner.observables
        )
    }

    /// The samples with `start <= t <= end` (either may be None), as SSMLearn's
    /// `sliceTrajectories`: a window outside the data is a `ValueError` naming the
    /// trajectory and its time span.
    #[pyo3(signature = (start=None, end=None))]
    fn window(&self, start: Option<f64>, end: Option<f64>) -> PyResult<Self> {
        guard(|| Ok(Trajectory { inner: self.inner.window(start, end).map_err(value_error)? }))
    }

    /// The observables named (a name, a `.mat` row number, or a list of them), in that order.
    fn select(&self, observables: &Bound<'_, PyAny>) -> PyResult<Self> {
        guard(|| {
            let names = observable_names(Some(observables))?.unwrap_or_default();
            Ok(Trajectory { inner: self.inner.select(&names).map_err(value_error)? })
        })
    }
}

fn all(o: &[String]) -> bool {
    o.len() == 1 && o[0] == "all"
}

/// `load_csv(path, observables=None, column=None)`: a CSV file with a header, time in the
/// first column. `observables`: None (a two-column file, or the one named by `column`),
/// `"all"`, or column names (several observables).
#[pyfunction]
#[pyo3(signature = (path, observables=None, column=None))]
pub fn load_csv(
    py: Python<'_>,
    path: std::path::PathBuf,
    observables: Option<&Bound<'_, PyAny>>,
    column: Option<String>,
) -> PyResult<Trajectory> {
    guard(|| {
        let names = observable_names(observables)?;
        if names.is_some() && column.is_some() {
            return Err(value_error("load_csv: give observables or column, not both"));
        }
        let inner = py
            .detach(|| match &names {
                None => ssm::load_csv_column(&path, column.as_deref()).map(|ts| MultiSeries::from(&ts)),
                Some(o) if all(o) => ssm::load_csv_observables(&path, None),
                Some(o) => ssm::load_csv_observables(&path, Some(o)),
            })
            .map_err(value_error)?;
        Ok(Trajectory { inner })
    })
}

/// `load_mat(path, var="xData", observables=None)`: every trajectory of an SSMLearn `.mat`
/// file (MATLAB v5-v7: a cell array with one row `{t, X}` per trajectory, X one row per
/// observable). `observables`: None or `"all"` for every row of X, else row numbers
/// (1-based, as SSMLearn) or their names `"1"`, `"2"`, ... A v7.3 (HDF5) file is a
/// `ValueError` saying how to convert it.
#[pyfunction]
#[pyo3(signature = (path, var="xData", observables=None))]
pub fn load_mat(
    py: Python<'_>,
    path: std::path::PathBuf,
    var: &str,
    observables: Option<&Bound<'_, PyAny>>,
) -> PyResult<Vec<Trajectory>> {
    guard(|| {
        let names = observable_names(observables)?;
        let trajs = py.detach(|| ssm::load_mat(&path, var)).map_err(value_error)?;
        let trajs = match &names {
            Some(o) if !all(o) => {
                trajs.iter().map(|t| t.select(o)).collect::<Result<Vec<_>, _>>().map_err(value_error)?
            }
            _ => trajs,
        };
        Ok(trajs.into_iter().map(|inner| Trajectory { inner }).collect())
    })
}
