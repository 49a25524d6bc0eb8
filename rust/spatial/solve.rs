//! Solves of spatial arms through the shared solver ([`crate::lm`]): the
//! cable solve of the position-controlled cables (square: damped Newton,
//! more cables than joints: least squares) and the masked pose IK
//! (`docs/spatial.md`, "Solves").

use super::kinematics::{cable_length, log_of, rotation_of, Chain};
use crate::lm::{self, Lm, Problem, Step, Workspace};
use crate::model::SpatialRobot;
use crate::solve::{clamp_to_limits_box, SolveOptions, Status};
use nalgebra::{Matrix3, Vector3};

type V3 = Vector3<f64>;

/// What the pose IK of a spatial arm matches.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpatialMask {
    /// The end origin (3 rows).
    Position,
    /// The origin and the direction of the end frame's x axis (6 rows, 5 DOF).
    Pointing,
    /// The origin and the orientation (6 rows).
    Pose,
}

impl SpatialMask {
    pub fn rows(&self) -> usize {
        match self {
            SpatialMask::Position => 3,
            _ => 6,
        }
    }
}

/// Whether every angle lies within its joint's limits.
pub fn within_limits(robot: &SpatialRobot, theta: &[f64]) -> bool {
    theta
        .iter()
        .zip(&robot.joints)
        .all(|(t, j)| *t >= j.limits[0] && *t <= j.limits[1])
}

fn limits(robot: &SpatialRobot) -> Vec<[f64; 2]> {
    robot.joints.iter().map(|j| j.limits).collect()
}

struct CableProblem<'a> {
    robot: &'a SpatialRobot,
    cables: &'a [usize],
    target: &'a [f64],
    chain: &'a mut Chain,
    pts: &'a mut Vec<V3>,
    limits: Option<&'a [[f64; 2]]>,
}

impl Problem for CableProblem<'_> {
    fn dims(&self) -> (usize, usize) {
        (self.cables.len(), self.robot.n())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], mut jac: Option<&mut [f64]>) -> bool {
        let n = x.len();
        self.chain.at(self.robot, x);
        for (i, &c) in self.cables.iter().enumerate() {
            let row = jac.as_deref_mut().map(|j| &mut j[i * n..(i + 1) * n]);
            r[i] = cable_length(self.robot, self.chain, c, self.pts, row) - self.target[i];
        }
        r.iter().all(|v| v.is_finite())
    }

    fn project(&self, x: &mut [f64]) {
        if let Some(l) = self.limits {
            clamp_to_limits_box(l, x);
        }
    }

    fn on_bound(&self, x: &[f64]) -> bool {
        self.limits
            .is_some_and(|l| x.iter().zip(l).any(|(t, b)| *t <= b[0] || *t >= b[1]))
    }
}

/// A spatial cable solver with its buffers (reused across solves, and
/// across robots of the same structure, e.g. with perturbed holes).
pub struct SpatialCableSolver {
    cables: Vec<usize>,
    opts: SolveOptions,
    limits: Vec<[f64; 2]>,
    ws: Workspace,
    /// The chain of the last solve (at the answer when it converged).
    pub chain: Chain,
    pts: Vec<V3>,
}

impl SpatialCableSolver {
    pub fn new(robot: &SpatialRobot, opts: SolveOptions) -> Self {
        SpatialCableSolver {
            cables: robot.position_cables(),
            opts,
            limits: limits(robot),
            ws: Workspace::default(),
            chain: Chain::new(robot),
            pts: Vec::new(),
        }
    }

    /// Lengths `target` (m) of the position-controlled cables (file order) of
    /// `robot` to `theta` (seed on entry, answer on exit).
    pub fn solve(&mut self, robot: &SpatialRobot, target: &[f64], theta: &mut [f64]) -> Status {
        let (m, n) = (self.cables.len(), robot.n());
        let mut p = CableProblem {
            robot,
            cables: &self.cables,
            target,
            chain: &mut self.chain,
            pts: &mut self.pts,
            limits: self.opts.enforce_limits.then_some(&self.limits[..]),
        };
        let lm = Lm {
            lambda0: 0.0,
            min_decrease: if m > n { 1e-12 } else { 0.0 },
            ..Lm::equations(Step::Normal, self.opts.tol, self.opts.max_iter)
        };
        let st = lm::solve(&mut p, theta, &lm, &mut self.ws);
        self.chain.at(robot, theta);
        st
    }
}

struct PoseProblem<'a> {
    robot: &'a SpatialRobot,
    mask: SpatialMask,
    target_p: V3,
    target_r: Matrix3<f64>,
    chain: Chain,
    jac: Vec<f64>,
    limits: Option<Vec<[f64; 2]>>,
}

impl Problem for PoseProblem<'_> {
    fn dims(&self) -> (usize, usize) {
        (self.mask.rows(), self.robot.n())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        let n = x.len();
        self.chain.at(self.robot, x);
        let end = *self.chain.end();
        let dp = end.p - self.target_p;
        r[..3].copy_from_slice(dp.as_slice());
        super::kinematics::geometric_jacobian(&self.chain, &mut self.jac);
        match self.mask {
            SpatialMask::Position => {}
            SpatialMask::Pointing => {
                let d = end.r.column(0).into_owned();
                let dt = self.target_r.column(0).into_owned();
                let e = d - dt;
                r[3..6].copy_from_slice(e.as_slice());
            }
            SpatialMask::Pose => {
                let e = self.target_r * log_of(&(self.target_r.transpose() * end.r));
                r[3..6].copy_from_slice(e.as_slice());
            }
        }
        if let Some(j) = jac {
            j[..3 * n].copy_from_slice(&self.jac[..3 * n]);
            match self.mask {
                SpatialMask::Position => {}
                SpatialMask::Pointing => {
                    let d = end.r.column(0).into_owned();
                    for k in 0..n {
                        let w = V3::new(
                            self.jac[3 * n + k],
                            self.jac[4 * n + k],
                            self.jac[5 * n + k],
                        );
                        let v = w.cross(&d);
                        for i in 0..3 {
                            j[(3 + i) * n + k] = v[i];
                        }
                    }
                }
                SpatialMask::Pose => j[3 * n..6 * n].copy_from_slice(&self.jac[3 * n..6 * n]),
            }
        }
        r.iter().all(|v| v.is_finite())
    }

    fn project(&self, x: &mut [f64]) {
        if let Some(l) = &self.limits {
            clamp_to_limits_box(l, x);
        }
    }

    fn on_bound(&self, x: &[f64]) -> bool {
        self.limits
            .as_ref()
            .is_some_and(|l| x.iter().zip(l).any(|(t, b)| *t <= b[0] || *t >= b[1]))
    }
}

/// A spatial pose-IK solver with its buffers.
pub struct SpatialIkSolver<'a> {
    robot: &'a SpatialRobot,
    mask: SpatialMask,
    opts: SolveOptions,
    ws: Workspace,
}

impl<'a> SpatialIkSolver<'a> {
    pub fn new(robot: &'a SpatialRobot, mask: SpatialMask, opts: SolveOptions) -> Self {
        SpatialIkSolver {
            robot,
            mask,
            opts,
            ws: Workspace::default(),
        }
    }

    /// Target `[x, y, z, rx, ry, rz]` (m, rotation vector rad) to `theta`
    /// (seed on entry, answer on exit).
    pub fn solve(&mut self, target: &[f64; 6], theta: &mut [f64]) -> Status {
        let n = self.robot.n();
        let mut p = PoseProblem {
            robot: self.robot,
            mask: self.mask,
            target_p: V3::new(target[0], target[1], target[2]),
            target_r: rotation_of(&[target[3], target[4], target[5]]),
            chain: Chain::new(self.robot),
            jac: vec![0.0; 6 * n],
            limits: self.opts.enforce_limits.then(|| limits(self.robot)),
        };
        let lm = Lm::equations(
            Step::levenberg(self.mask.rows(), n),
            self.opts.tol,
            self.opts.max_iter,
        );
        lm::solve(&mut p, theta, &lm, &mut self.ws)
    }
}
