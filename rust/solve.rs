//! Inverse solves: pose IK (pose -> theta) and the cable solve (upper-cable
//! lengths -> theta), both Levenberg–Marquardt with adaptive damping, plus the
//! closed-form triangular cable solve (fast path and branch census).
//! The algorithms are specified in `docs/model.md`.

use crate::cables::CableGeometry;
use crate::kinematics::{fk, fk_jacobian};
use crate::robot::Robot;
use faer::linalg::solvers::Solve;
use faer::Mat;
use nalgebra::{Matrix3, Vector3};

/// Options shared by the solves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveOptions {
    /// Convergence: max |residual| (m for lengths and positions, rad for phi).
    pub tol: f64,
    /// Maximum number of trial steps.
    pub max_iter: u32,
    /// Project every trial onto the joint-limit box.
    pub enforce_limits: bool,
}

impl Default for SolveOptions {
    fn default() -> Self {
        SolveOptions {
            tol: 1e-12,
            max_iter: 100,
            enforce_limits: false,
        }
    }
}

/// Outcome of one solve; the angles are written to the caller's slice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Status {
    pub converged: bool,
    /// Trial steps taken (0 for the closed form).
    pub iterations: u32,
    /// max |residual| at the returned angles.
    pub residual: f64,
}

const LAMBDA0: f64 = 1e-3;
const LAMBDA_MIN: f64 = 1e-12;
const LAMBDA_MAX: f64 = 1e12;

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn project(robot: &Robot, theta: &mut [f64]) {
    for (t, l) in theta.iter_mut().zip(&robot.joint_limits) {
        *t = t.clamp(l[0], l[1]);
    }
}

/// Generic LM driver: `eval(theta, r)` writes the residual; `step(theta, r,
/// lambda, delta)` writes the damped step. Shared by both solves.
pub(crate) fn levenberg_marquardt(
    robot: &Robot,
    theta: &mut [f64],
    m: usize,
    opts: &SolveOptions,
    mut eval: impl FnMut(&[f64], &mut [f64]),
    mut step: impl FnMut(&[f64], &[f64], f64, &mut [f64]) -> bool,
) -> Status {
    let n = theta.len();
    let mut r = vec![0.0; m];
    let mut r_trial = vec![0.0; m];
    let mut delta = vec![0.0; n];
    let mut trial = vec![0.0; n];
    eval(theta, &mut r);
    let mut cost: f64 = r.iter().map(|x| x * x).sum();
    let mut lambda = LAMBDA0;
    let mut iterations = 0;
    loop {
        let res = max_abs(&r);
        if res <= opts.tol {
            return Status {
                converged: true,
                iterations,
                residual: res,
            };
        }
        if iterations >= opts.max_iter || lambda > LAMBDA_MAX || !res.is_finite() {
            return Status {
                converged: false,
                iterations,
                residual: res,
            };
        }
        iterations += 1;
        if !step(theta, &r, lambda, &mut delta) {
            lambda *= 10.0;
            continue;
        }
        for k in 0..n {
            trial[k] = theta[k] + delta[k];
        }
        if opts.enforce_limits {
            project(robot, &mut trial);
        }
        eval(&trial, &mut r_trial);
        let c: f64 = r_trial.iter().map(|x| x * x).sum();
        if c < cost {
            theta.copy_from_slice(&trial);
            std::mem::swap(&mut r, &mut r_trial);
            cost = c;
            lambda = (lambda / 10.0).max(LAMBDA_MIN);
        } else {
            lambda *= 10.0;
        }
    }
}

/// Pose IK: `theta` holds the seed on entry and the answer on exit.
/// Minimal-norm damped step `J^T (J J^T + lambda I)^-1 r` (any n >= 1).
pub fn ik(robot: &Robot, pose: &[f64; 3], theta: &mut [f64], opts: &SolveOptions) -> Status {
    let n = theta.len();
    let mut jac = vec![[0.0; 3]; n];
    levenberg_marquardt(
        robot,
        theta,
        3,
        opts,
        |th, r| {
            let p = fk(robot, th);
            for i in 0..3 {
                r[i] = pose[i] - p[i];
            }
        },
        |th, r, lambda, delta| {
            fk_jacobian(robot, th, &mut jac);
            let mut a = Matrix3::<f64>::identity() * lambda;
            for col in &jac {
                let v = Vector3::from(*col);
                a += v * v.transpose();
            }
            let Some(y) = a.lu().solve(&Vector3::new(r[0], r[1], r[2])) else {
                return false;
            };
            for (d, col) in delta.iter_mut().zip(&jac) {
                *d = col[0] * y[0] + col[1] * y[1] + col[2] * y[2];
            }
            true
        },
    )
}

/// Solves the symmetric positive-definite `n x n` system `a x = b` (`a`
/// row-major): nalgebra fixed-size Cholesky for n <= 6, faer beyond.
/// Returns `false` if `a` is not positive definite.
pub fn solve_spd(n: usize, a: &[f64], b: &[f64], x: &mut [f64]) -> bool {
    fn fixed<const N: usize>(a: &[f64], b: &[f64], x: &mut [f64]) -> bool {
        let m = nalgebra::SMatrix::<f64, N, N>::from_row_slice(a);
        let v = nalgebra::SVector::<f64, N>::from_column_slice(b);
        match m.cholesky() {
            Some(ch) => {
                x.copy_from_slice(ch.solve(&v).as_slice());
                true
            }
            None => false,
        }
    }
    match n {
        1 => fixed::<1>(a, b, x),
        2 => fixed::<2>(a, b, x),
        3 => fixed::<3>(a, b, x),
        4 => fixed::<4>(a, b, x),
        5 => fixed::<5>(a, b, x),
        6 => fixed::<6>(a, b, x),
        _ => {
            let m = Mat::<f64>::from_fn(n, n, |i, j| a[i * n + j]);
            let rhs = Mat::<f64>::from_fn(n, 1, |i, _| b[i]);
            match m.llt(faer::Side::Lower) {
                Ok(ch) => {
                    let sol = ch.solve(&rhs);
                    for (i, xi) in x.iter_mut().enumerate() {
                        *xi = sol[(i, 0)];
                    }
                    true
                }
                Err(_) => false,
            }
        }
    }
}

/// Cable solve by LM: upper-cable lengths `target` (m, n) to `theta`
/// (seed on entry). Normal equations `(J^T J + lambda I) delta = J^T r`.
pub fn solve_cables_lm(
    robot: &Robot,
    geom: &CableGeometry,
    target: &[f64],
    theta: &mut [f64],
    opts: &SolveOptions,
) -> Status {
    let n = theta.len();
    let mut cs = vec![(1.0, 0.0); n];
    let mut jac = vec![0.0; n * n];
    let mut a = vec![0.0; n * n];
    let mut g = vec![0.0; n];
    levenberg_marquardt(
        robot,
        theta,
        n,
        opts,
        |th, r| {
            for (c, t) in cs.iter_mut().zip(th) {
                *c = (t.cos(), t.sin());
            }
            geom.upper_lengths(&cs, r);
            for (ri, ti) in r.iter_mut().zip(target) {
                *ri = ti - *ri;
            }
        },
        |th, r, lambda, delta| {
            for (k, t) in th.iter().enumerate() {
                let csk = (t.cos(), t.sin());
                for i in 0..n {
                    jac[i * n + k] = geom.derivative(2 * i, k, csk);
                }
            }
            normal_equations(n, &jac, r, lambda, &mut a, &mut g);
            solve_spd(n, &a, &g, delta) && delta.iter().all(|d| d.is_finite())
        },
    )
}

/// `a = J^T J + lambda I` and `g = J^T r` for a square `n x n` row-major `J`.
pub(crate) fn normal_equations(
    n: usize,
    jac: &[f64],
    r: &[f64],
    lambda: f64,
    a: &mut [f64],
    g: &mut [f64],
) {
    for k in 0..n {
        for l in 0..n {
            a[k * n + l] = (0..n).map(|i| jac[i * n + k] * jac[i * n + l]).sum::<f64>();
        }
        a[k * n + k] += lambda;
        g[k] = (0..n).map(|i| jac[i * n + k] * r[i]).sum();
    }
}

/// Closed-form cable solve in cos/sin form, joint by joint (triangular): for
/// each joint the branch nearest the seed (largest `cos(t − seed)`), without
/// inverse trigonometry. `seed_cs`: `(cos, sin)` of the seed angles; `cs`
/// gets those of the answer. Returns the residual max |L_upper − target| (m;
/// each cable's length re-evaluated at the answer), or `None` when some joint
/// has no real solution. `branches[k]` counts the real solutions of joint k
/// given joints `< k`.
pub fn closed_form_cs(
    geom: &CableGeometry,
    target: &[f64],
    seed_cs: &[(f64, f64)],
    cs: &mut [(f64, f64)],
    mut branches: Option<&mut [u8]>,
) -> Option<f64> {
    let mut residual = 0.0f64;
    for i in 0..target.len() {
        let c = 2 * i;
        let mut s = target[i] - geom.traverse[c];
        for (k, csk) in cs.iter().enumerate().take(i) {
            s -= geom.segment(c, k, *csk);
        }
        let Some(b) = geom.joint_solution(c, i, s) else {
            if let Some(br) = branches.as_deref_mut() {
                br[i] = 0;
            }
            return None;
        };
        if let Some(br) = branches.as_deref_mut() {
            br[i] = if b.single() { 1 } else { 2 };
        }
        let (c0, s0) = seed_cs[i];
        let (plus, minus) = (b.cos_sin(1.0), b.cos_sin(-1.0));
        cs[i] = if plus.0 * c0 + plus.1 * s0 >= minus.0 * c0 + minus.1 * s0 {
            plus
        } else {
            minus
        };
        // cable i's length at the answer minus its target: only segment i is new
        residual = residual.max((geom.segment(c, i, cs[i]) - s).abs());
    }
    Some(residual)
}

/// `(cos, sin)` of `t − t0` from those of `t` and `t0`.
#[inline]
pub fn cs_difference(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 * b.0 + a.1 * b.1, a.1 * b.0 - a.0 * b.1)
}

/// Closed-form cable solve with angles: [`closed_form_cs`] from the seed
/// `theta` (whose cos/sin are `seed_cs`), then `theta_k = seed_k + atan2(sin(t
/// − seed), cos(t − seed))` (the answer within pi of the seed). `theta` is
/// unchanged on `None`.
pub fn solve_cables_closed_form(
    geom: &CableGeometry,
    target: &[f64],
    theta: &mut [f64],
    seed_cs: &[(f64, f64)],
    cs: &mut [(f64, f64)],
    branches: Option<&mut [u8]>,
) -> Option<f64> {
    let residual = closed_form_cs(geom, target, seed_cs, cs, branches)?;
    for ((t, c), s0) in theta.iter_mut().zip(cs.iter()).zip(seed_cs) {
        let d = cs_difference(*c, *s0);
        *t += d.1.atan2(d.0);
    }
    Some(residual)
}

/// Which cable-solve algorithm to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CableMethod {
    /// Closed form, verified; LM from the closed form (or the seed) if it fails.
    Auto,
    /// Damped Newton (LM) only.
    Newton,
    /// Closed form only.
    ClosedForm,
}

/// A cable solver with its buffers, reused across many solves (no allocation
/// per solve on the closed-form path).
pub struct CableSolver<'a> {
    robot: &'a Robot,
    pub method: CableMethod,
    pub opts: SolveOptions,
    seed: Vec<f64>,
    seed_cs: Vec<(f64, f64)>,
    cs: Vec<(f64, f64)>,
}

impl<'a> CableSolver<'a> {
    pub fn new(robot: &'a Robot, method: CableMethod, opts: SolveOptions) -> Self {
        let n = robot.n();
        CableSolver {
            robot,
            method,
            opts,
            seed: vec![0.0; n],
            seed_cs: vec![(1.0, 0.0); n],
            cs: vec![(1.0, 0.0); n],
        }
    }

    /// Upper-cable lengths `target` (m) to `theta` (seed on entry, answer on exit).
    pub fn solve(&mut self, geom: &CableGeometry, target: &[f64], theta: &mut [f64]) -> Status {
        let (robot, opts) = (self.robot, &self.opts);
        if self.method == CableMethod::Newton {
            let st = solve_cables_lm(robot, geom, target, theta, opts);
            self.refresh(theta);
            return st;
        }
        self.seed.copy_from_slice(theta);
        for (c, t) in self.seed_cs.iter_mut().zip(theta.iter()) {
            *c = (t.cos(), t.sin());
        }
        let closed =
            solve_cables_closed_form(geom, target, theta, &self.seed_cs, &mut self.cs, None);
        let ok = closed.is_some();
        let residual = closed.unwrap_or(f64::INFINITY);
        let in_box = !opts.enforce_limits || crate::kinematics::within_limits(robot, theta);
        if ok && residual <= opts.tol && in_box {
            return Status {
                converged: true,
                iterations: 0,
                residual,
            };
        }
        if self.method == CableMethod::ClosedForm {
            if !ok {
                theta.copy_from_slice(&self.seed);
                self.refresh(theta);
            }
            return Status {
                converged: false,
                iterations: 0,
                residual,
            };
        }
        if !ok || !in_box {
            theta.copy_from_slice(&self.seed);
        }
        let st = solve_cables_lm(robot, geom, target, theta, opts);
        self.refresh(theta);
        st
    }

    fn refresh(&mut self, theta: &[f64]) {
        for (c, t) in self.cs.iter_mut().zip(theta) {
            *c = (t.cos(), t.sin());
        }
    }

    /// End pose at the angles of the last solve (uses the cached cos/sin).
    pub fn pose(&self, theta: &[f64]) -> [f64; 3] {
        crate::kinematics::fk_cs(self.robot, &self.cs, theta.iter().sum())
    }
}

/// Upper-cable lengths `target` (m) to `theta` (seed on entry): one solve.
pub fn solve_cables(
    robot: &Robot,
    geom: &CableGeometry,
    target: &[f64],
    theta: &mut [f64],
    method: CableMethod,
    opts: &SolveOptions,
) -> Status {
    CableSolver::new(robot, method, *opts).solve(geom, target, theta)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ik_reaches_a_forward_pose() {
        let r = Robot::paper();
        let want = [0.2, -0.3, 0.45];
        let pose = fk(&r, &want);
        let mut th = want.map(|t| t + 0.05);
        let st = ik(&r, &pose, &mut th, &SolveOptions::default());
        assert!(st.converged, "{st:?}");
        for k in 0..3 {
            assert!((th[k] - want[k]).abs() < 1e-10);
        }
    }

    #[test]
    fn ik_flags_an_unreachable_pose() {
        let r = Robot::paper();
        let mut th = [0.0; 3];
        let st = ik(&r, &[0.3, 0.0, 0.0], &mut th, &SolveOptions::default());
        assert!(!st.converged);
        assert!(st.residual > 0.07 - 1e-9, "{st:?}");
    }

    #[test]
    fn cable_methods_agree() {
        let r = Robot::paper();
        let g = CableGeometry::new(&r, None);
        let want = [0.3, -0.25, 0.1];
        let mut l = [0.0; 6];
        g.lengths(&want, &mut l);
        let target = [l[0], l[2], l[4]];
        for m in [
            CableMethod::Auto,
            CableMethod::Newton,
            CableMethod::ClosedForm,
        ] {
            let mut th = [0.0; 3];
            let st = solve_cables(&r, &g, &target, &mut th, m, &SolveOptions::default());
            assert!(st.converged, "{m:?} {st:?}");
            for k in 0..3 {
                assert!((th[k] - want[k]).abs() < 1e-10, "{m:?}");
            }
        }
    }

    #[test]
    fn closed_form_counts_two_branches() {
        let r = Robot::paper();
        let g = CableGeometry::new(&r, None);
        let mut th = [0.0; 3];
        let mut cs = [(1.0, 0.0); 3];
        let mut br = [9u8; 3];
        let target = [0.076, 0.152, 0.228];
        let seed = [(1.0, 0.0); 3];
        let res =
            solve_cables_closed_form(&g, &target, &mut th, &seed, &mut cs, Some(&mut br)).unwrap();
        assert!(res < 1e-15, "{res}");
        assert_eq!(br, [2, 2, 2]);
        assert!(th.iter().all(|t| t.abs() < 1e-7), "{th:?}");
    }
}
