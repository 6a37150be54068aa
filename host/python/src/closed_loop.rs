//! The simulator for Python: `simulate(scene, set=None)` runs a scene's closed loop and
//! returns its columns as numpy arrays, `stability(scene, set=None)` its exact closed-loop
//! multipliers. `scene` is a bundled scene name or a scene file (a `str` or `os.PathLike`),
//! `set` the `--set` overrides of `ssmctl`: a dict `{"plant.parameters.m": 0.25}` or a list
//! of `"key=value"` strings.

use numpy::{Complex64, PyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use sim::scene::Scene;

use crate::convert::{guard, type_error, value_error};

/// Deepest nesting of lists and dicts in one override value.
const MAX_DEPTH: usize = 16;

/// The scene's name or path from a `str` or `os.PathLike`.
fn scene_ref(obj: &Bound<'_, PyAny>) -> PyResult<String> {
    if let Ok(s) = obj.extract::<String>() {
        return Ok(s);
    }
    let path = obj.py().import("os")?.call_method1("fspath", (obj,)).map_err(|_| {
        type_error(format!(
            "scene: expected a bundled scene name or a path (str or os.PathLike), got {}",
            type_name(obj)
        ))
    })?;
    path.extract::<String>()
        .map_err(|_| type_error("scene: the path is not valid text (bytes paths are not supported)"))
}

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type().name().map_or_else(|_| "an object".into(), |n| format!("a {n}"))
}

/// A Python value as a TOML value: bools, ints, floats, strings, and lists, tuples and
/// dicts of them; anything else is a `TypeError` naming the key.
fn toml_value(v: &Bound<'_, PyAny>, key: &str, depth: usize) -> PyResult<toml::Value> {
    if depth > MAX_DEPTH {
        return Err(value_error(format!("set[{key:?}]: nested deeper than {MAX_DEPTH} levels")));
    }
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        let i: i64 = v.extract().map_err(|_| value_error(format!("set[{key:?}]: integer {v} out of range")))?;
        return Ok(toml::Value::Integer(i));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let mut out = Vec::new();
        for (i, item) in v.try_iter()?.enumerate() {
            out.push(toml_value(&item?, &format!("{key}[{i}]"), depth + 1)?);
        }
        return Ok(toml::Value::Array(out));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut t = toml::Table::new();
        for (k, item) in d.iter() {
            let k: String =
                k.extract().map_err(|_| type_error(format!("set[{key:?}]: a table key must be a string, got {k}")))?;
            let value = toml_value(&item, &format!("{key}.{k}"), depth + 1)?;
            t.insert(k, value);
        }
        return Ok(toml::Value::Table(t));
    }
    // numpy scalars and other number types: integers by `__index__`, else floats.
    if v.hasattr("__index__")? && !v.hasattr("__len__")? {
        if let Ok(i) = v.call_method0("__index__").and_then(|i| i.extract::<i64>()) {
            return Ok(toml::Value::Integer(i));
        }
    }
    if v.hasattr("__float__")? && !v.hasattr("__len__")? {
        if let Ok(x) = v.call_method0("__float__").and_then(|f| f.extract::<f64>()) {
            return Ok(toml::Value::Float(x));
        }
    }
    Err(type_error(format!(
        "set[{key:?}]: {} is not a scene value (numbers, booleans, strings, lists or dicts of them)",
        type_name(v)
    )))
}

/// The overrides `PATH=VALUE` from `set`: `None`, a dict of key paths to values, a list or
/// tuple of `"key=value"` strings, or one such string.
fn overrides(set: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<String>> {
    let Some(set) = set.filter(|s| !s.is_none()) else { return Ok(Vec::new()) };
    if let Ok(s) = set.extract::<String>() {
        return Ok(vec![s]);
    }
    if let Ok(d) = set.cast::<PyDict>() {
        let mut out = Vec::with_capacity(d.len());
        for (k, v) in d.iter() {
            let k: String = k
                .extract()
                .map_err(|_| type_error(format!("set: keys are scene key paths (str), got {}", type_name(&k))))?;
            let v = toml_value(&v, &k, 0)?;
            out.push(format!("{k}={v}"));
        }
        return Ok(out);
    }
    if set.is_instance_of::<PyList>() || set.is_instance_of::<PyTuple>() {
        let mut out = Vec::new();
        for (i, item) in set.try_iter()?.enumerate() {
            let item = item?;
            out.push(item.extract::<String>().map_err(|_| {
                type_error(format!("set[{i}]: expected a \"key=value\" string, got {}", type_name(&item)))
            })?);
        }
        return Ok(out);
    }
    Err(type_error(format!("set: expected a dict, a list of \"key=value\" strings or None, got {}", type_name(set))))
}

fn load(scene: &Bound<'_, PyAny>, set: Option<&Bound<'_, PyAny>>) -> PyResult<Scene> {
    let name = scene_ref(scene)?;
    Scene::load(&name, &overrides(set)?).map_err(value_error)
}

/// Simulates the scene's closed loop; returns a dict of numpy arrays named like the columns
/// of `ssmctl simulate`'s CSV: `t`, each coordinate and `<coordinate>_dot`, `u` (and
/// `q_theta`, `q_phi`, `code` when the scene quantizes in counts).
#[pyfunction]
#[pyo3(signature = (scene, set = None))]
pub fn simulate<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    set: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    guard(|| {
        let s = load(scene, set)?;
        if !s.wants(sim::scene::Task::Simulate) {
            return Err(value_error(format!(
                "scene {} asks only for {:?} (run.tasks); it runs no simulation",
                s.name, s.run.tasks
            )));
        }
        let tr = sim::closed_loop::simulate(&s, None).map_err(value_error)?;
        let out = PyDict::new(py);
        out.set_item("t", PyArray1::from_slice(py, &tr.t))?;
        let n = tr.n_states();
        for (k, name) in tr.state_names.iter().enumerate() {
            let col: Vec<f64> = (0..tr.rows()).map(|i| tr.states[i * n + k]).collect();
            out.set_item(*name, PyArray1::from_vec(py, col))?;
        }
        out.set_item("u", PyArray1::from_slice(py, &tr.u))?;
        if let Some(codes) = &tr.codes {
            out.set_item("q_theta", PyArray1::from_vec(py, codes.iter().map(|c| c.q_theta).collect()))?;
            out.set_item("q_phi", PyArray1::from_vec(py, codes.iter().map(|c| c.q_phi).collect()))?;
            out.set_item("code", PyArray1::from_vec(py, codes.iter().map(|c| c.code).collect()))?;
        }
        Ok(out)
    })
}

/// The exact multipliers of the scene's linearized sampled-data loop (ZOH, delay), as a
/// complex numpy array sorted as `ssmctl stability --json` sorts them: largest modulus
/// first.
#[pyfunction]
#[pyo3(signature = (scene, set = None))]
pub fn stability<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    set: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<Complex64>>> {
    guard(|| {
        let s = load(scene, set)?;
        let m = sim::stability::scene_multipliers(&s).map_err(value_error)?;
        Ok(PyArray1::from_vec(py, m.iter().map(|m| Complex64::new(m.re, m.im)).collect()))
    })
}
