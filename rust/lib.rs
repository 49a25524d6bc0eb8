//! cdsm — kinematics and tip-positioning accuracy of planar cable-driven
//! serpentine manipulators (CDSMs). SI units throughout (m, rad, N, kg).
//!
//! The model and the solver specifications are in `docs/model.md`. This crate
//! knows nothing of Python; `python.rs` (feature `python`) converts types.

pub mod accuracy;
pub mod batch;
pub mod cables;
pub mod error;
pub mod kinematics;
pub mod plant;
pub mod robot;
pub mod sensitivity;
pub mod solve;
pub mod statics;

#[cfg(feature = "python")]
mod python;

pub use error::{CdsmError, Result};
pub use robot::Robot;
