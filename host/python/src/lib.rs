//! The Python module `ssm_ctl`: the SSM learner (`host/ssm`) for people who use SSMLearn or
//! SSMLearnPy, with numpy arrays in and out. Built by maturin (`pip install ./host/python`).
//!
//! - [`trajectory`]: `Trajectory` (one trajectory of one or several observables, from numpy
//!   arrays, a CSV file or an SSMLearn `.mat` file; time windows, observable selection);
//! - [`model`]: `fit` (the options of `ssmctl fit`), `Model` (prediction, NMTE, eigenvalues,
//!   normal form, backbone curves, the device blob, saved-model JSON) and `Prediction`;
//! - [`convert`]: errors as Python `ValueError`s carrying the Rust message, JSON-shaped
//!   values as Python objects, numpy arrays.
//!
//! Architecture: an app layer beside `ssmctl`, on `ssm` and `shared` only; it wraps the
//! library's API (what `ssmctl`'s `fit_command.rs` drives), never the command line.

pub mod convert;
pub mod model;
pub mod trajectory;

use pyo3::prelude::*;

/// The module: classes and functions listed in `host/python/README.md`.
#[pymodule]
fn ssm_ctl(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
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
    Ok(())
}
