//! Conversions at the boundary: NumPy arrays to slices (C-contiguous
//! float64, named in errors), vectors to arrays, option strings to the
//! core's enums, and the core's errors to `CdsmInputError`.

use crate::error::CdsmError;
use crate::ik::IkMethod;
use crate::plant::Reading;
use crate::solve::{CableMethod, SolveOptions};
use numpy::{PyArray1, PyReadonlyArrayDyn};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};

create_exception!(
    _cdsm,
    CdsmInputError,
    PyValueError,
    "Bad input: the message names the field and the problem."
);

/// The one conversion of the core's errors to Python.
pub fn err(e: CdsmError) -> PyErr {
    CdsmInputError::new_err(e.to_string())
}

pub type Arr<'py> = PyReadonlyArrayDyn<'py, f64>;
pub type Array<'py> = Bound<'py, PyArray1<f64>>;

/// The data of a C-contiguous float64 array; an error naming it otherwise.
pub fn slice<'a>(name: &str, a: &'a PyReadonlyArrayDyn<'_, f64>) -> PyResult<&'a [f64]> {
    a.as_slice().map_err(|_| {
        CdsmInputError::new_err(format!("`{name}`: must be a C-contiguous float64 array"))
    })
}

/// [`slice`] of an optional array.
pub fn opt_slice<'a>(name: &str, a: &'a Option<Arr<'_>>) -> PyResult<Option<&'a [f64]>> {
    a.as_ref().map(|a| slice(name, a)).transpose()
}

/// A 1-D NumPy array owning `v`.
pub fn vec1<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>) -> Bound<'py, PyArray1<T>> {
    PyArray1::from_vec(py, v)
}

/// Solver options, checked as every solve checks them (`tol` positive and
/// finite, `max_iter` at least 1).
pub fn options(tol: f64, max_iter: u32, enforce_limits: bool) -> PyResult<SolveOptions> {
    let o = SolveOptions {
        tol,
        max_iter,
        enforce_limits,
    };
    o.check().map_err(err)?;
    Ok(o)
}

pub fn method(name: &str) -> PyResult<CableMethod> {
    match name {
        "auto" => Ok(CableMethod::Auto),
        "newton" => Ok(CableMethod::Newton),
        "closed_form" => Ok(CableMethod::ClosedForm),
        other => Err(CdsmInputError::new_err(format!(
            "`method`: expected 'auto', 'newton' or 'closed_form', got {other:?}"
        ))),
    }
}

/// The pose-IK method from its name.
pub fn ik_method(name: &str) -> PyResult<IkMethod> {
    match name {
        "lm" => Ok(IkMethod::Lm),
        "closed_form" => Ok(IkMethod::ClosedForm),
        other => Err(CdsmInputError::new_err(format!(
            "`method`: expected 'lm' or 'closed_form', got {other:?}"
        ))),
    }
}

/// Rows' readings from their codes (0 absolute, 1 displacement, 2 unmeasured).
pub fn readings(codes: &[u8]) -> PyResult<Vec<Reading>> {
    codes
        .iter()
        .map(|c| Reading::from_code(*c).map_err(err))
        .collect()
}

/// A robot file's table built from Python data of the file's structure
/// (dicts as tables, lists and tuples as arrays, `str`, `float`, `int`,
/// `bool`): the robot built from data, with no text in between. A value
/// of another type, or a key that is not a string, is an error naming its
/// path (`linkage[0].mass`).
pub fn robot_table(data: &Bound<'_, PyDict>) -> PyResult<toml::Table> {
    table_of(data, "")
}

fn table_of(data: &Bound<'_, PyDict>, path: &str) -> PyResult<toml::Table> {
    let mut table = toml::Table::new();
    for (k, v) in data.iter() {
        let Ok(key) = k.cast::<PyString>() else {
            return Err(CdsmInputError::new_err(format!(
                "robot data{}: key {} is not a string",
                if path.is_empty() {
                    String::new()
                } else {
                    format!(" `{path}`")
                },
                k.repr()?
            )));
        };
        let key = unicode(key, path)?;
        let at = if path.is_empty() {
            key.clone()
        } else {
            format!("{path}.{key}")
        };
        table.insert(key, value_of(&v, &at)?);
    }
    Ok(table)
}

fn unicode(s: &Bound<'_, PyString>, path: &str) -> PyResult<String> {
    s.to_cow().map(|c| c.into_owned()).map_err(|_| {
        CdsmInputError::new_err(format!(
            "robot data `{path}`: {} is not valid Unicode (a lone surrogate)",
            s.repr()
                .map_or_else(|_| "the string".to_string(), |r| r.to_string())
        ))
    })
}

fn value_of(v: &Bound<'_, PyAny>, path: &str) -> PyResult<toml::Value> {
    use toml::Value;
    if let Ok(b) = v.cast::<PyBool>() {
        return Ok(Value::Boolean(b.is_true()));
    }
    if v.is_instance_of::<PyInt>() {
        return v.extract::<i64>().map(Value::Integer).map_err(|_| {
            CdsmInputError::new_err(format!("robot data `{path}`: integer {v} out of range"))
        });
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(Value::Float(v.extract::<f64>()?));
    }
    if let Ok(s) = v.cast::<PyString>() {
        return Ok(Value::String(unicode(s, path)?));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        return Ok(Value::Table(table_of(d, path)?));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items = v
            .try_iter()?
            .enumerate()
            .map(|(i, item)| value_of(&item?, &format!("{path}[{i}]")))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(Value::Array(items));
    }
    Err(CdsmInputError::new_err(format!(
        "robot data `{path}`: a {} is not a robot file's value (str, float, int, bool, list or dict)",
        v.get_type().name()?
    )))
}
