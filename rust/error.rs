//! Errors of the core. No Python here: the binding (`python/convert.rs`)
//! maps them to exceptions.

use thiserror::Error;

/// Everything the core can refuse. Solves never fail as a whole: a failed
/// element is flagged in its [`crate::solve::Solution`], not raised.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum CdsmError {
    /// A robot description that is not physical or not well formed.
    #[error("robot description: field `{field}`: {problem}")]
    Robot { field: String, problem: String },
    /// An input array of the wrong size.
    #[error("`{name}`: expected {expected}, got {got}")]
    Shape {
        name: String,
        expected: String,
        got: String,
    },
    /// A NaN or infinite value in an input.
    #[error("`{name}`: non-finite value {value} at index {index}")]
    NonFinite {
        name: String,
        index: usize,
        value: f64,
    },
    /// A NaN or infinite value in a batch of rows.
    #[error("`{name}`: non-finite value {value} at row {row}, column {column}")]
    NonFiniteAt {
        name: String,
        row: usize,
        column: usize,
        value: f64,
    },
    /// An option outside its domain.
    #[error("`{name}`: {problem}")]
    Option { name: String, problem: String },
}

pub type Result<T> = std::result::Result<T, CdsmError>;

/// Checks that every value of `values` is finite; names the argument otherwise.
pub fn check_finite(name: &str, values: &[f64]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(index) => Err(CdsmError::NonFinite {
            name: name.to_string(),
            index,
            value: values[index],
        }),
    }
}

/// Checks that a flat batch has a whole number of rows of `width`.
pub fn check_rows(name: &str, values: &[f64], width: usize) -> Result<usize> {
    if width == 0 || !values.len().is_multiple_of(width) {
        return Err(CdsmError::Shape {
            name: name.to_string(),
            expected: format!("rows of {width} values"),
            got: format!("{} values", values.len()),
        });
    }
    Ok(values.len() / width)
}
