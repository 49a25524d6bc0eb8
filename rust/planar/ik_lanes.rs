//! The closed-form pose IK of 3-joint arms ([`crate::ik::ik_closed_form`])
//! SIMD across rows: one pose per lane.
//!
//! Every lane does what the scalar function does — the wrist, `c2`, both
//! branches, the branch nearest the seed (ties to `sin theta_2 <= 0`), the
//! residual from the forward kinematics — with the lane-wise `acos`, `atan2`
//! and `sin_cos` of [`crate::simd::math`] (each within 1 ulp of libm), so its
//! angles agree with the scalar function's to a few 1e-16 rad. Lanes the
//! kernel does not settle — out of reach, or a branch more than pi from the
//! seed (whole turns to remove) — are marked for the scalar function.

use crate::robot::PlanarView;
use crate::simd::lanes::{Lanes, Mask};
use crate::simd::math::{acos_lanes, atan2_lanes, sin_cos_lanes};
use pulp::{Simd, WithSimd};
use std::f64::consts::PI;

/// Vectors per block (their dependency chains interleaved).
const BLOCK: usize = 2;

/// Closed-form pose IK of the rows of `pose` (`N x 3`: x, y m, phi rad) from
/// `seed` (`N x 3`, rad): `theta` (`N x 3`) and `residual` (`N`, the max over
/// x, y, phi of |fk(theta) - pose|) on rows with `done[i]`; the other rows
/// (out of reach, or needing whole turns) are left for the scalar function.
/// `robot` must have 3 joints.
pub fn ik_closed_form_batch(
    arch: pulp::Arch,
    robot: &PlanarView,
    pose: &[f64],
    seed: &[f64],
    theta: &mut [f64],
    residual: &mut [f64],
    done: &mut [bool],
) {
    let rows = residual.len();
    assert_eq!(robot.n(), 3, "the closed form needs a 3-joint arm");
    assert!(pose.len() == 3 * rows && seed.len() == 3 * rows && theta.len() == 3 * rows);
    assert_eq!(done.len(), rows);
    arch.dispatch(IkOp {
        robot,
        pose,
        seed,
        theta,
        residual,
        done,
    });
}

struct IkOp<'a> {
    robot: &'a PlanarView,
    pose: &'a [f64],
    seed: &'a [f64],
    theta: &'a mut [f64],
    residual: &'a mut [f64],
    done: &'a mut [bool],
}

impl WithSimd for IkOp<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        kernel::<S, BLOCK>(simd, self)
    }
}

#[inline(always)]
fn kernel<S: Simd, const U: usize>(simd: S, op: IkOp<'_>) {
    let IkOp {
        robot,
        pose,
        seed,
        theta,
        residual,
        done,
    } = op;
    let (lb, la, th) = (&robot.link_before, &robot.link_after, &robot.thickness);
    let l = [la[0] + th[0], la[1] + th[1], la[2] + th[2]];
    let (r1, r2, a3) = (l[0] + lb[1], l[1] + lb[2], l[2]);
    let rows = residual.len();
    let w = U * S::F64_LANES;
    let z = [simd.splat_f64s(0.0); U];
    let zero = Lanes::<S, U>::splat(simd, 0.0);
    let mut col = [[z; 3]; 2]; // pose, seed columns
    let mut start = 0;
    while start < rows {
        let m = w.min(rows - start);
        // columns of this block (a short tail repeats its last row)
        for (src, dst) in [pose, seed].into_iter().zip(col.iter_mut()) {
            for (j, d) in dst.iter_mut().enumerate() {
                let flat = pulp::bytemuck::cast_slice_mut::<S::f64s, f64>(d);
                for (r, x) in flat.iter_mut().enumerate() {
                    *x = src[(start + r.min(m - 1)) * 3 + j];
                }
            }
        }
        let [x, y, phi] = [0, 1, 2].map(|j| Lanes::<S, U>::new(simd, col[0][j]));
        let [s1, s2, s3] = [0, 1, 2].map(|j| Lanes::<S, U>::new(simd, col[1][j]));
        let (sp, cp) = sin_cos_lanes(phi);
        let dx = x - cp * a3 - lb[0];
        let dy = y - sp * a3;
        let c2 = (dx * dx + dy * dy - r1 * r1 - r2 * r2) / (2.0 * r1 * r2);
        let reach = c2.abs().le_c(1.0);
        let c2 = reach.select(c2, zero);
        let a = acos_lanes(c2);
        let base = atan2_lanes(dy, dx);
        let gamma = atan2_lanes((1.0 - c2 * c2).max(zero).sqrt() * r2, c2 * r2 + r1);
        // branch +: theta_2 = a, theta_1 = base - gamma; branch -: the mirror
        let (p1, p2) = (base - gamma, a);
        let (m1, m2) = (base + gamma, -a);
        let plain = within_half_turn(p1 - s1)
            & within_half_turn(p2 - s2)
            & within_half_turn(m1 - s1)
            & within_half_turn(m2 - s2);
        let (p3, m3) = (phi - p1 - p2, phi - m1 - m2);
        let tie = (s1 * s1 + s2 * s2 + s3 * s3 + 1.0) * 1e-12;
        let take_plus =
            sum_sq(p1 - s1, p2 - s2, p3 - s3).lt(sum_sq(m1 - s1, m2 - s2, m3 - s3) - tie);
        let t1 = take_plus.select(p1, m1);
        let t2 = take_plus.select(p2, m2);
        let t3 = take_plus.select(p3, m3);
        // the residual from the forward kinematics, in its order of operations
        let q1 = t1;
        let q2 = q1 + t2;
        let q3 = q2 + t3;
        let (sn1, cs1) = sin_cos_lanes(q1);
        let (sn2, cs2) = sin_cos_lanes(q2);
        let (sn3, cs3) = sin_cos_lanes(q3);
        let px =
            ((((zero + lb[0] + cs1 * l[0]) + cs1 * lb[1]) + cs2 * l[1]) + cs2 * lb[2]) + cs3 * l[2];
        let py = ((((zero + sn1 * l[0]) + sn1 * lb[1]) + sn2 * l[1]) + sn2 * lb[2]) + sn3 * l[2];
        let res = (px - x).abs().max((py - y).abs()).max((q3 - phi).abs());
        let ok: Mask<S, U> = reach & plain;
        for (j, t) in [t1, t2, t3].iter().enumerate() {
            let flat = pulp::bytemuck::cast_slice::<S::f64s, f64>(&t.v);
            for r in 0..m {
                theta[(start + r) * 3 + j] = flat[r];
            }
        }
        let res = pulp::bytemuck::cast_slice::<S::f64s, f64>(&res.v);
        residual[start..start + m].copy_from_slice(&res[..m]);
        let flags = ok.select(zero + 1.0, zero).v;
        let flags = pulp::bytemuck::cast_slice::<S::f64s, f64>(&flags);
        for (d, f) in done[start..start + m].iter_mut().zip(flags) {
            *d = *f != 0.0;
        }
        start += m;
    }
}

/// Lanes with `d` in `(-pi, pi]`.
#[inline(always)]
fn within_half_turn<S: Simd, const U: usize>(d: Lanes<S, U>) -> Mask<S, U> {
    d.gt_c(-PI) & d.le_c(PI)
}

#[inline(always)]
fn sum_sq<S: Simd, const U: usize>(a: Lanes<S, U>, b: Lanes<S, U>, c: Lanes<S, U>) -> Lanes<S, U> {
    a * a + b * b + c * c
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ArmGeometry;
    use crate::ik::ik_closed_form;
    use crate::solve::SolveOptions;

    #[test]
    fn lanes_agree_with_the_scalar_closed_form() {
        let r = PlanarView::paper();
        let (mut pose, mut seed) = (Vec::new(), Vec::new());
        for i in 0..203 {
            let a = i as f64 * 0.61;
            let t = [0.6 * a.sin(), -0.7 * (1.3 * a).cos(), 0.5 * (0.7 * a).sin()];
            pose.extend_from_slice(&r.fk(&t));
            // seeds near either branch, a few whole turns away on some rows
            let turn = if i % 17 == 0 {
                std::f64::consts::TAU
            } else {
                0.0
            };
            seed.extend_from_slice(&[0.1 * (2.0 * a).cos() + turn, 0.2 * (3.0 * a).sin(), 0.0]);
        }
        pose.extend_from_slice(&[0.3, 0.0, 0.0]); // out of reach
        seed.extend_from_slice(&[0.0, -1e-3, 0.0]);
        let rows = seed.len() / 3;
        let (mut th, mut res, mut done) = (vec![0.0; 3 * rows], vec![0.0; rows], vec![false; rows]);
        for arch in [pulp::Arch::new(), pulp::Arch::Scalar] {
            ik_closed_form_batch(arch, &r, &pose, &seed, &mut th, &mut res, &mut done);
            let mut settled = 0;
            for i in 0..rows {
                let mut t = [seed[3 * i], seed[3 * i + 1], seed[3 * i + 2]];
                let p = [pose[3 * i], pose[3 * i + 1], pose[3 * i + 2]];
                let st = ik_closed_form(&r, &p, &mut t, &SolveOptions::default());
                if !done[i] {
                    continue;
                }
                settled += 1;
                assert!(
                    st.converged && res[i] <= 1e-12,
                    "row {i}: {st:?} {}",
                    res[i]
                );
                for k in 0..3 {
                    assert!((th[3 * i + k] - t[k]).abs() < 1e-13, "row {i} joint {k}");
                }
            }
            assert!(
                !done[rows - 1],
                "the unreachable row is left to the scalar function"
            );
            assert!(
                settled > rows * 9 / 10 && settled < rows - 5,
                "{settled} of {rows}"
            );
        }
    }
}
