//! The homogeneous-transform chain of Eq. (1)–(3): joint angles to end pose
//! and its Jacobian. The chain itself is written once
//! in [`crate::geometry::ArmGeometry::fk`].

use crate::geometry::ArmGeometry;
use crate::robot::PlanarView;
use crate::simd::math::cos_sin_short;

/// End pose `[x, y, phi]` (m, m, rad) for joint angles `theta` (rad, length n).
#[inline]
pub fn fk(robot: &PlanarView, theta: &[f64]) -> [f64; 3] {
    robot.fk(theta)
}

/// End pose and its Jacobian: `jac[k] = d[x, y, phi]/d theta_k` (column k).
/// The attitudes' cos/sin by angle addition from the joints' (those by the
/// crate's sin/cos kernel, four joints in lockstep).
#[inline(always)]
pub fn fk_jacobian(robot: &PlanarView, theta: &[f64], jac: &mut [[f64; 3]]) -> [f64; 3] {
    let n = theta.len();
    let mut stack = [(1.0, 0.0); 8];
    let mut heap;
    let cs: &mut [(f64, f64)] = if n <= stack.len() {
        &mut stack[..n]
    } else {
        heap = vec![(1.0, 0.0); n];
        &mut heap
    };
    cos_sin_short(theta, cs);
    let (mut x, mut y, mut phi) = (0.0f64, 0.0f64, 0.0f64);
    // (sin, cos) of the attitude before joint k: the one after joint k - 1
    let (mut s, mut c) = (0.0f64, 1.0f64);
    for (k, (&t, &(ck, sk))) in theta.iter().zip(cs.iter()).enumerate() {
        x += robot.link_before[k] * c;
        y += robot.link_before[k] * s;
        jac[k] = [x, y, 1.0]; // joint k position, finished below
        phi += t;
        (c, s) = (c * ck - s * sk, s * ck + c * sk);
        let l = robot.link_after[k] + robot.thickness[k];
        x += l * c;
        y += l * s;
    }
    for col in jac.iter_mut().take(n) {
        let (jx, jy) = (col[0], col[1]);
        *col = [-(y - jy), x - jx, 1.0];
    }
    [x, y, phi]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_pose_is_the_straight_length() {
        let r = PlanarView::paper();
        let p = fk(&r, &[0.0; 3]);
        assert!(
            (p[0] - 0.228).abs() < 1e-15 && p[1] == 0.0 && p[2] == 0.0,
            "{p:?}"
        );
    }

    #[test]
    fn jacobian_matches_central_differences() {
        let r = PlanarView::paper();
        let th = [0.3, -0.2, 0.5];
        let mut jac = [[0.0; 3]; 3];
        fk_jacobian(&r, &th, &mut jac);
        for k in 0..3 {
            let h = 1e-6;
            let (mut a, mut b) = (th, th);
            a[k] += h;
            b[k] -= h;
            let (pa, pb) = (fk(&r, &a), fk(&r, &b));
            for i in 0..3 {
                assert!(((pa[i] - pb[i]) / (2.0 * h) - jac[k][i]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn angle_addition_pose_equals_the_chain() {
        let r = PlanarView::paper();
        let th = [0.3, -0.7, 0.45];
        let cs: Vec<(f64, f64)> = th.iter().map(|t: &f64| (t.cos(), t.sin())).collect();
        let (a, b) = (fk(&r, &th), r.fk_cs(&cs, th.iter().sum()));
        for i in 0..3 {
            assert!((a[i] - b[i]).abs() < 1e-15);
        }
    }

    #[test]
    fn all_zero_joints_lose_x() {
        // Fig. 12: at theta = 0 no joint moves the tip along X.
        let r = PlanarView::paper();
        let mut jac = [[0.0; 3]; 3];
        fk_jacobian(&r, &[0.0; 3], &mut jac);
        assert!(jac.iter().all(|c| c[0] == 0.0));
    }
}
