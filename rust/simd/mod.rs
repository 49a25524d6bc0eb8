//! SIMD kernels (several configurations per instruction) on stable Rust,
//! with run-time dispatch through `pulp` (`pulp::Arch::new().dispatch`):
//! x86-64-v3 (AVX2 + FMA, 4 f64 lanes) when present, AVX-512 (x86-64-v4, 8
//! lanes) only if pulp's `x86-v4` feature is enabled, NEON (2 lanes) on
//! aarch64, and a one-lane scalar fallback otherwise. One binary runs on any
//! x86-64; no `-C target-cpu` is needed.
//!
//! * [`math`]: lane-wise `sqrt`, `sin_cos`, `atan2`, `acos`, each within
//!   1 ulp (bounds and domains in their docs).
//! * [`lanes`]: `K` vectors in lockstep with arithmetic operators, the
//!   building block of the kernels.
//!
//! The kernels built on them sit with what they compute: the planar
//! closed forms across rows in [`crate::planar`], and `W` rows as one
//! scalar of the code written over [`crate::real::Arith`] (the chain, the
//! general cable solve's Newton phase) in [`crate::real::pack`].
//!
//! The kernels use no fused multiply-add, so every instruction set (and the
//! scalar fallback) gives the same bits.

pub mod lanes;
pub mod math;

pub use lanes::{Lanes, Mask};

struct InstructionSet;

impl pulp::WithSimd for InstructionSet {
    type Output = String;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> String {
        format!(
            "{} ({} f64 lanes)",
            core::any::type_name::<S>(),
            <S as pulp::Simd>::F64_LANES
        )
    }
}

/// The instruction set `pulp::Arch::new()` dispatches to on this machine
/// and its f64 lane count, e.g. `"pulp::x86::v3::V3 (4 f64 lanes)"`.
pub fn instruction_set() -> String {
    instruction_set_of(pulp::Arch::new())
}

/// Name and f64 lane count of the instruction set behind `arch`.
pub fn instruction_set_of(arch: pulp::Arch) -> String {
    arch.dispatch(InstructionSet)
}
