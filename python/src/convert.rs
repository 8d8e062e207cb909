//! Python values in, errors out: dicts and arrays become the JSON values the host library
//! reads (so a problem from Python is checked by exactly the code that checks a file), and the
//! host's field errors become `omcbsa.InputError`, a `ValueError` naming each field.

use numpy::ndarray::ArrayViewD;
use omcbsa::error::{FieldError, InputError};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::{Map, Number, Value};

/// The exception type, in its own module so that Python sees it as `omcbsa.InputError`.
pub mod exception {
    use pyo3::exceptions::PyValueError;

    pyo3::create_exception!(
        omcbsa,
        InputError,
        PyValueError,
        "Bad input: the message has one line `field: what is wrong` per problem (the command \
     line's words); `errors` holds the same as (field, message) pairs."
    );
}

/// The `ValueError` of one or more field errors, with the pairs in its `errors` attribute.
pub fn input_error(py: Python<'_>, e: &InputError) -> PyErr {
    let err = exception::InputError::new_err(e.to_string());
    let pairs: Vec<(String, String)> = (e.errors.iter())
        .map(|f| (f.path.clone(), f.message.clone()))
        .collect();
    match err.value(py).setattr("errors", pairs) {
        Ok(()) => err,
        Err(e) => e,
    }
}

/// One field error as a `ValueError`.
pub fn field_error(py: Python<'_>, path: impl Into<String>, message: impl Into<String>) -> PyErr {
    input_error(py, &InputError::from(FieldError::new(path, message)))
}

/// A finite number as JSON, or the error naming `path`.
pub fn number(x: f64, path: &str) -> Result<Value, FieldError> {
    Number::from_f64(x)
        .map(Value::Number)
        .ok_or_else(|| FieldError::new(path, format!("{x} is not a finite number")))
}

/// A Python value (dict with str keys, list, tuple, str, bool, int, float, None, NumPy arrays
/// and scalars) as JSON. A NaN or infinity, or a value of another type, is an error naming
/// where it is (`trajectories[0].poses[3].position[1]`).
pub fn to_json(obj: &Bound<'_, PyAny>, path: &str) -> PyResult<Value> {
    let py = obj.py();
    if obj.is_none() {
        Ok(Value::Null)
    } else if obj.is_instance_of::<PyBool>() {
        Ok(Value::Bool(obj.extract()?))
    } else if obj.is_instance_of::<PyInt>() {
        match obj.extract::<i64>() {
            Ok(i) => Ok(Value::from(i)),
            Err(_) => Err(field_error(py, path, "integer too large")),
        }
    } else if obj.is_instance_of::<PyFloat>() {
        number(obj.extract()?, path).map_err(|e| input_error(py, &e.into()))
    } else if let Ok(s) = obj.cast::<PyString>() {
        Ok(Value::String(s.to_cow()?.into_owned()))
    } else if let Ok(d) = obj.cast::<PyDict>() {
        let mut map = Map::new();
        for (k, v) in d.iter() {
            let Ok(key) = k.cast::<PyString>() else {
                return Err(field_error(
                    py,
                    path,
                    format!("keys must be strings, got {}", k.repr()?),
                ));
            };
            let key = key.to_cow()?.into_owned();
            let inner = if path.is_empty() {
                key.clone()
            } else {
                format!("{path}.{key}")
            };
            map.insert(key, to_json(&v, &inner)?);
        }
        Ok(Value::Object(map))
    } else if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let items = (obj.try_iter()?.enumerate())
            .map(|(i, item)| to_json(&item?, &format!("{path}[{i}]")))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(Value::Array(items))
    } else if obj.hasattr("tolist")? && obj.hasattr("dtype")? {
        // NumPy arrays and scalars: their Python equivalent.
        to_json(&obj.call_method0("tolist")?, path)
    } else {
        let what = if path.is_empty() { "the value" } else { path };
        Err(PyTypeError::new_err(format!(
            "{what}: cannot be written as JSON (a {})",
            obj.get_type().name()?
        )))
    }
}

/// The values of an array whose last axis has `width` entries, in row-major order (`name`
/// and `what` for errors); take rows with `chunks_exact(width)`.
pub fn flat(
    py: Python<'_>,
    a: &ArrayViewD<'_, f64>,
    width: usize,
    name: &str,
    what: &str,
) -> PyResult<Vec<f64>> {
    let shape = a.shape();
    if shape.last() != Some(&width) {
        return Err(field_error(
            py,
            name,
            format!("expected an array of shape {what}, got shape {shape:?}"),
        ));
    }
    Ok(a.iter().copied().collect())
}

/// `name[i][j]` for row `k` of an array of leading shape `lead` (row-major).
pub fn index_path(name: &str, lead: &[usize], mut k: usize) -> String {
    let mut idx = vec![0; lead.len()];
    for (slot, &n) in idx.iter_mut().zip(lead).rev() {
        *slot = k % n.max(1);
        k /= n.max(1);
    }
    let mut s = name.to_string();
    for i in idx {
        s.push_str(&format!("[{i}]"));
    }
    s
}

/// A pose as the files write it, from 7 numbers: position then quaternion xyzw.
pub fn pose_value(row: &[f64], path: &str) -> Result<Value, FieldError> {
    let nums = |xs: &[f64], field: &str| -> Result<Value, FieldError> {
        (xs.iter().enumerate())
            .map(|(i, &x)| number(x, &format!("{path}.{field}[{i}]")))
            .collect::<Result<Vec<_>, _>>()
            .map(Value::Array)
    };
    let mut map = Map::new();
    map.insert("position".into(), nums(&row[..3], "position")?);
    map.insert("quat_xyzw".into(), nums(&row[3..7], "quat_xyzw")?);
    Ok(Value::Object(map))
}
