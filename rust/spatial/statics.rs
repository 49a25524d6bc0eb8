//! Statics of spatial arms (`docs/spatial.md`, "Statics"): the moment balance
//! about every joint axis, force-controlled cables at their tension, and the
//! minimum-norm tensions of the position-controlled cables above a floor (a
//! small quadratic program solved by an active set). No solution above the
//! floor: the configuration needs a slack cable.

use super::kinematics::{cable_points, Chain};
use super::robot::{Mode, SpatialRobot};
use faer::Mat;
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// The moment balance at `chain`: `a (n, cables)` row-major, the moment of a
/// unit tension of each cable about each joint axis (N m/N), and `ext (n)`
/// the moments of gravity (robot's `gravity`) and of the tip wrench
/// `[F; M]` (N, N m, base frame) about each axis.
pub fn moments(robot: &SpatialRobot, chain: &Chain, tip_wrench: &[f64; 6]) -> (Vec<f64>, Vec<f64>) {
    let n = robot.n();
    let m = robot.cables.len();
    let mut a = vec![0.0; n * m];
    let mut ext = vec![0.0; n];
    let mut pts = Vec::new();
    let g = V3::new(robot.gravity[0], robot.gravity[1], robot.gravity[2]);
    let tip = chain.end().p;
    let force = V3::new(tip_wrench[0], tip_wrench[1], tip_wrench[2]);
    let torque = V3::new(tip_wrench[3], tip_wrench[4], tip_wrench[5]);
    for c in 0..m {
        cable_points(robot, chain, c, &mut pts);
        for j in 0..n {
            let k = chain.disk_of[j];
            if robot.cables[c].end < k {
                continue;
            }
            // segment k pulls the distal part from A_k towards B_(k-1)
            let (ak, bk) = (pts[2 * k - 1], pts[2 * k - 2]);
            let s = bk - ak;
            let l = s.norm();
            if l > 0.0 {
                a[j * m + c] = chain.w[j].dot(&(ak - chain.p[j]).cross(&(s / l)));
            }
        }
    }
    for (j, e) in ext.iter_mut().enumerate() {
        let k = chain.disk_of[j];
        let (w, p) = (chain.w[j], chain.p[j]);
        let mut t = w.dot(&((tip - p).cross(&force) + torque));
        for (b, disk) in robot.disks.iter().enumerate().skip(k - 1) {
            let c = chain.face_a[b].point(&disk.com);
            t += w.dot(&(c - p).cross(&(g * disk.mass)));
        }
        *e = t;
    }
    (a, ext)
}

/// The tensions of the position-controlled cables (file order, N) at
/// `chain`: the minimum-norm solution of the moment balance with every
/// tension at or above `floor`; `None` when there is none.
pub fn position_tensions(
    robot: &SpatialRobot,
    chain: &Chain,
    tip_wrench: &[f64; 6],
    floor: f64,
) -> Option<Vec<f64>> {
    let n = robot.n();
    let m = robot.cables.len();
    let (a, ext) = moments(robot, chain, tip_wrench);
    let pos = robot.position_cables();
    // b = -(ext + A_force T_force)
    let mut b: Vec<f64> = ext.iter().map(|v| -v).collect();
    for c in 0..m {
        if robot.cables[c].mode == Mode::Force {
            for j in 0..n {
                b[j] -= a[j * m + c] * robot.cables[c].tension;
            }
        }
    }
    let ap = Mat::<f64>::from_fn(n, pos.len(), |j, i| a[j * m + pos[i]]);
    min_norm_above(&ap, &b, floor)
}

/// `min |t|^2` subject to `A t = b`, `t >= floor`, by an active set (faer
/// dense algebra): solve the equality-constrained problem over the free
/// components (the others held at the floor) by the pseudoinverse, hold the
/// most negative one at the floor, release a held one whose multiplier is
/// negative; the Karush–Kuhn–Tucker conditions hold at the answer (to
/// `1e-10` of the problem's scale). `None` when no feasible `t` exists.
pub fn min_norm_above(a: &Mat<f64>, b: &[f64], floor: f64) -> Option<Vec<f64>> {
    let (n, m) = (a.nrows(), a.ncols());
    let amax = (0..n)
        .flat_map(|r| (0..m).map(move |c| (r, c)))
        .fold(0.0f64, |x, (r, c)| x.max(a[(r, c)].abs()));
    let scale = b
        .iter()
        .fold(amax * floor.abs(), |x, v| x.max(v.abs()))
        .max(1e-300);
    let tol = 1e-10 * scale;
    let mut held = vec![false; m];
    for _ in 0..(4 * m + 8) {
        let free: Vec<usize> = (0..m).filter(|i| !held[*i]).collect();
        let rhs = Mat::<f64>::from_fn(n, 1, |r, _| {
            b[r] - (0..m)
                .filter(|i| held[*i])
                .map(|i| a[(r, i)] * floor)
                .sum::<f64>()
        });
        let af = Mat::<f64>::from_fn(n, free.len(), |r, c| a[(r, free[c])]);
        // the minimum-norm solution tf = af^T nu, nu = (af af^T)^+ rhs
        let gram = &af * af.transpose();
        let nu = gram
            .self_adjoint_eigen(faer::Side::Lower)
            .ok()?
            .pseudoinverse()
            * &rhs;
        let tf = af.transpose() * &nu;
        let res = &af * &tf - &rhs;
        if (0..n).any(|r| res[(r, 0)].abs() > tol) {
            return None; // the balance cannot close with these cables free
        }
        let low = free
            .iter()
            .enumerate()
            .map(|(k, i)| (*i, tf[(k, 0)] - floor))
            .fold(
                (usize::MAX, -tol),
                |acc, x| if x.1 < acc.1 { x } else { acc },
            );
        if low.0 != usize::MAX {
            held[low.0] = true;
            continue;
        }
        // multipliers of the held components: mu_i = floor - a_i . nu
        let release = (0..m)
            .filter(|i| held[*i])
            .map(|i| {
                (
                    i,
                    floor - (0..n).map(|r| a[(r, i)] * nu[(r, 0)]).sum::<f64>(),
                )
            })
            .fold(
                (usize::MAX, -tol),
                |acc, x| if x.1 < acc.1 { x } else { acc },
            );
        if release.0 != usize::MAX {
            held[release.0] = false;
            continue;
        }
        let mut t = vec![floor; m];
        for (k, i) in free.iter().enumerate() {
            t[*i] = tf[(k, 0)].max(floor);
        }
        return Some(t);
    }
    None
}
