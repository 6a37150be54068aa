//! The Python module `ssm_ctl`: the SSM learner (`host/ssm`) for people who use SSMLearn or
//! SSMLearnPy, with numpy arrays in and out. Built by maturin (`pip install ./host/python`).
//!
//! - [`trajectory`]: `Trajectory` (one trajectory of one or several observables, from numpy
//!   arrays, a CSV file or an SSMLearn `.mat` file; time windows, observable selection);
//! - [`model`]: `fit` (the options of `ssmctl fit`), `Model` (prediction, NMTE, eigenvalues,
//!   normal form, backbone curves, the device blob, saved-model JSON) and `Prediction`;
//! - [`closed_loop`]: `simulate` and `stability` of a scene (the simulator, `host/sim`), with
//!   the `--set` overrides of `ssmctl`;
//! - [`convert`]: errors as Python `ValueError`s carrying the Rust message, JSON-shaped
//!   values as Python objects, numpy arrays.
//!
//! Architecture: an app layer beside `ssmctl`, on `ssm`, `sim` and `shared` only; it wraps
//! the libraries' API (what `ssmctl`'s `fit_command.rs` drives), never the command line.

pub mod closed_loop;
pub mod convert;
pub mod model;
pub mod trajectory;

use pyo3::prelude::*;

/// How this module was compiled: `opt_level` and `debug` (cargo's values), `profile` (the
/// profile's output folder, `debug` or `release`), `debug_assertions`.
fn build_info(py: Python<'_>) -> PyResult<Bound<'_, pyo3::types::PyDict>> {
    let d = pyo3::types::PyDict::new(py);
    d.set_item("opt_level", env!("SSM_CTL_BUILD_OPT_LEVEL"))?;
    d.set_item("debug", env!("SSM_CTL_BUILD_DEBUG"))?;
    d.set_item("profile", env!("SSM_CTL_BUILD_PROFILE"))?;
    d.set_item("debug_assertions", cfg!(debug_assertions))?;
    Ok(d)
}

/// The module: classes and functions listed in `host/python/README.md`.
#[pymodule]
fn ssm_ctl(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("__build__", build_info(m.py())?)?;
    m.add("MODEL_FORMAT", ssm::MODEL_FORMAT)?;
    m.add("MODEL_FORMAT_VERSION", ssm::MODEL_FORMAT_VERSION)?;
    m.add_class::<trajectory::Trajectory>()?;
    m.add_class::<model::Model>()?;
    m.add_class::<model::Prediction>()?;
    m.add_function(wrap_pyfunction!(trajectory::load_csv, m)?)?;
    m.add_function(wrap_pyfunction!(trajectory::load_mat, m)?)?;
    m.add_function(wrap_pyfunction!(model::fit, m)?)?;
    m.add_function(wrap_pyfunction!(model::load_model, m)?)?;
    m.add_function(wrap_pyfunction!(model::inspect_blob, m)?)?;
    m.add_function(wrap_pyfunction!(closed_loop::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(closed_loop::stability, m)?)?;
    Ok(())
}
