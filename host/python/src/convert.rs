//! Conversions at the Python boundary: a wrong value (a bad option, shape, number or
//! file) is a `ValueError` with the library's message (which names the file, option,
//! trajectory or dimension), a wrong type (not a number, not an array of real numbers, not a
//! `Trajectory`) a `TypeError`, and a panic of the library (a bug) is caught by [`guard`]
//! and raised as a `RuntimeError` saying so, never a `PanicException`; serializable values
//! become Python objects through `json`; arrays come in as float64 numpy arrays, their
//! size checked before they are copied.

use numpy::{PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;

/// A `ValueError` carrying `e`'s message.
pub fn value_error(e: impl std::fmt::Display) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// A `TypeError` carrying `e`'s message.
pub fn type_error(e: impl std::fmt::Display) -> PyErr {
    PyTypeError::new_err(e.to_string())
}

/// Runs `f`, turning a panic of the library into a `RuntimeError` (a bug to report), so no
/// panic crosses into Python. Every function and method of the module runs in it.
pub fn guard<T>(f: impl FnOnce() -> PyResult<T>) -> PyResult<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(r) => r,
        Err(payload) => {
            let msg = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "no message".into());
            Err(PyRuntimeError::new_err(format!("internal error in ssm_ctl (a bug; please report it): {msg}")))
        }
    }
}

/// `serde_json` text of `v` parsed by Python's `json.loads` (dicts, lists, floats, strings).
pub fn to_python<'py>(py: Python<'py>, v: &impl serde::Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(value_error)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// `obj` as a float64 array (numpy's `asarray`: lists, integer and float arrays and views
/// are converted), with its shape and its values in row-major order. Arrays of anything but
/// real numbers (complex, object, strings, booleans, dates) are a `TypeError`, never cast;
/// more than [`ssm::limits::MAX_MATRIX_ENTRIES`] values a `ValueError`, before the copy.
pub fn float_array(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let np = obj.py().import("numpy")?;
    let arr =
        np.call_method1("asarray", (obj,)).map_err(|e| type_error(format!("{what}: not an array of numbers ({e})")))?;
    let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
    let named = match kind.as_str() {
        "f" | "i" | "u" => None,
        "c" => Some("complex numbers (the imaginary part would be lost)"),
        "O" => Some("Python objects"),
        "b" => Some("booleans"),
        "U" | "S" => Some("strings"),
        "M" | "m" => Some("dates or time spans"),
        _ => Some("values of a non-numeric type"),
    };
    if let Some(t) = named {
        let dtype = arr.getattr("dtype")?.str()?.to_string();
        return Err(type_error(format!("{what}: an array of {t} (dtype {dtype}); expected real numbers")));
    }
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let size = shape.iter().try_fold(1usize, |a, &n| a.checked_mul(n));
    if size.is_none_or(|n| n > ssm::limits::MAX_MATRIX_ENTRIES) {
        return Err(value_error(format!(
            "{what}: shape {shape:?} has more than {} values, the limit",
            ssm::limits::MAX_MATRIX_ENTRIES
        )));
    }
    let arr = np
        .call_method1("ascontiguousarray", (arr, "float64"))
        .map_err(|e| value_error(format!("{what}: not convertible to float64 ({e})")))?;
    let arr = arr.cast_into::<PyArrayDyn<f64>>().map_err(|e| value_error(format!("{what}: {e}")))?;
    let ro = arr.readonly();
    let shape = ro.shape().to_vec();
    let values = ro.as_array().iter().copied().collect();
    Ok((shape, values))
}

/// Time windows for `n` trajectories from a Python value: `None` (no cut), one number for
/// every trajectory, or a sequence of `n` numbers or `None`s (the rule of `ssmctl fit
/// --from/--to`).
pub fn windows(obj: Option<&Bound<'_, PyAny>>, n: usize, what: &str) -> PyResult<Vec<Option<f64>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else { return Ok(vec![None; n]) };
    if let Ok(v) = obj.extract::<f64>() {
        return Ok(vec![Some(v); n]);
    }
    let v: Vec<Option<f64>> = obj.extract().map_err(|_| {
        type_error(format!("{what}: expected None, a number or a sequence of numbers/None, one per trajectory"))
    })?;
    if v.len() != n {
        return Err(value_error(format!(
            "{what}: {} values for {n} trajectories; give one for all, or one per trajectory",
            v.len()
        )));
    }
    Ok(v)
}

/// Observable names from a Python value: a string (`"all"` or one name), an int (a `.mat`
/// row, 1-based as SSMLearn numbers them) or a sequence of them. `None` stays `None`.
pub fn observable_names(obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<String>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else { return Ok(None) };
    let one = |o: &Bound<'_, PyAny>| -> PyResult<String> {
        if let Ok(s) = o.extract::<String>() {
            Ok(s)
        } else if let Ok(k) = o.extract::<i64>() {
            Ok(k.to_string())
        } else {
            Err(type_error(format!("observables: `{o}` is neither a name nor a row number")))
        }
    };
    if obj.is_instance_of::<pyo3::types::PyString>() || obj.extract::<i64>().is_ok() {
        return Ok(Some(vec![one(obj)?]));
    }
    let mut out = Vec::new();
    for item in
        obj.try_iter().map_err(|_| type_error("observables: expected a name, a row number or a sequence of them"))?
    {
        out.push(one(&item?)?);
    }
    if out.is_empty() {
        return Err(value_error("observables: the list is empty"));
    }
    Ok(Some(out))
}
