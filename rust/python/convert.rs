//! Conversions at the boundary: NumPy arrays to slices (C-contiguous
//! float64, named in errors), vectors to arrays, option strings to the
//! core's enums, and the core's errors to `CdsmInputError`.

use crate::error::CdsmError;
use crate::ik::IkMethod;
use crate::plant::RowKind;
use crate::solve::{CableMethod, SolveOptions};
use numpy::{PyArray1, PyReadonlyArrayDyn};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

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
    crate::batch::check_options(&o).map_err(err)?;
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

/// Row kinds from their codes (0 absolute, 1 displacement, 2 unmeasured).
pub fn kinds(codes: &[u8]) -> PyResult<Vec<RowKind>> {
    codes
        .iter()
        .map(|c| RowKind::from_code(*c).map_err(err))
        .collect()
}
