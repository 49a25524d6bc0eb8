//! The planar arm's fast paths that run across rows: its closed forms on
//! SIMD lanes ([`crate::simd`]), bit for bit the scalar closed forms of
//! [`crate::solve`] and [`crate::ik`] on every lane they settle.
//!
//! * [`cable_lanes`]: the closed-form cable solve across rows, as a lane
//!   kernel, blocks of rows and a row-major batch function.
//! * [`ik_lanes`]: the closed-form pose IK of 3-joint arms across rows.

pub mod cable_lanes;
pub mod ik_lanes;

pub use cable_lanes::{
    closed_form_lanes, closed_form_lanes_x, solve_cables_closed_form_batch,
    solve_cables_closed_form_batch_in,
};
