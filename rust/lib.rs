//! cdsm — kinematics and tip-positioning accuracy of cable-driven serpentine
//! manipulators (CDSMs), planar and spatial. SI units throughout (m, rad, N, kg).
//!
//! The model and the solver specifications are in `docs/model.md`. This crate
//! knows nothing of Python; `python/` (feature `python`) converts types.

pub mod accuracy;
pub mod arm;
pub mod batch;
pub mod cables;
pub mod chain;
pub mod compensate;
pub mod effect;
pub mod elastic;
pub mod error;
pub mod fit;
pub mod friction;
pub mod geometry;
pub mod ik;
pub mod kinds;
pub mod kinematics;
pub mod limits;
pub mod lm;
pub mod model;
pub mod planar;
pub mod plant;
pub mod qp;
pub mod real;
pub mod robot;
pub mod robot_file;
pub mod rows;
pub mod sensitivity;
pub mod simd;
pub mod solve;
pub mod tension;

#[cfg(feature = "python")]
mod python;

pub use error::{CdsmError, Result};
pub use robot::PlanarView;
