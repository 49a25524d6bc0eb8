//! Pose IK: the joint angles that put the end frame on a target, by the
//! shared damped least squares ([`crate::lm`], the step of
//! [`crate::lm::Step::levenberg`]: minimal norm unless the task has more rows
//! than the arm has joints), with a task mask over the robot kind's
//! task-space coordinates. Planar arms (`x`, `y`, `phi`): the full pose, the
//! position only, or any weights, with the closed form of 3-joint arms (both
//! branches, the one nearest the seed) as their fast path. Spatial arms
//! ([`SpatialIk`], `x, y, z` and the rotation): the position, the pointing
//! direction or the full pose, on the one model's chain.

use crate::chain::Chain;
use crate::error::{CdsmError, Result};
use crate::geometry::ArmGeometry;
use crate::kinds::{exp_so3, log_so3, Kind, Masks, Se3};
use crate::kinematics::fk_jacobian;
use crate::limits::Limits;
use crate::lm::{self, Lm, Problem, Reason, Step, Workspace};
use crate::model::Model;
use crate::robot::Robot;
use crate::solve::{SolveOptions, Status};
use std::f64::consts::{PI, TAU};

/// Task-space coordinates of a planar arm: `x`, `y` (m), `phi` (rad).
pub const PLANAR_TASK: usize = 3;

/// Which task-space coordinates the IK matches, as weights on their residuals
/// (`0` leaves a coordinate free). Convergence is judged on the weighted residual.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskMask {
    pub weights: [f64; PLANAR_TASK],
}

impl TaskMask {
    /// Position and attitude.
    pub const POSE: TaskMask = TaskMask {
        weights: [1.0, 1.0, 1.0],
    };
    /// Position only; the attitude is free.
    #[cfg(test)]
    pub const POSITION: TaskMask = TaskMask {
        weights: [1.0, 1.0, 0.0],
    };

    /// Indices of the matched coordinates.
    fn active(&self) -> ([usize; PLANAR_TASK], usize) {
        let mut idx = [0; PLANAR_TASK];
        let mut m = 0;
        for (i, w) in self.weights.iter().enumerate() {
            if *w != 0.0 {
                idx[m] = i;
                m += 1;
            }
        }
        (idx, m)
    }
}

/// The pose-IK problem: `r_i = w_i (fk_i(theta) - target_i)` over the active
/// coordinates. `N`: the number of joints when it is known at compile time
/// (the full pose of a small arm: the solver's loops then have constant trip
/// counts), else 0.
struct PoseProblem<'a, const N: usize> {
    robot: &'a Robot,
    target: [f64; 3],
    mask: TaskMask,
    active: [usize; PLANAR_TASK],
    m: usize,
    jac: &'a mut [[f64; 3]],
    /// The joint-limit box when the limits are enforced.
    limits: Option<Limits<&'a [[f64; 2]]>>,
}

impl<const N: usize> Problem for PoseProblem<'_, N> {
    #[inline(always)]
    fn dims(&self) -> (usize, usize) {
        if N > 0 {
            (PLANAR_TASK, N)
        } else {
            (self.m, self.robot.n())
        }
    }

    #[inline(always)]
    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        let (m, n) = self.dims();
        let p = fk_jacobian(self.robot, &x[..n], &mut self.jac[..n]);
        for (row, &i) in self.active[..m].iter().enumerate() {
            r[row] = self.mask.weights[i] * (p[i] - self.target[i]);
        }
        if let Some(j) = jac {
            for (row, &i) in self.active[..m].iter().enumerate() {
                for k in 0..n {
                    j[row * n + k] = self.mask.weights[i] * self.jac[k][i];
                }
            }
        }
        true
    }

    fn project(&self, x: &mut [f64]) {
        if let Some(l) = &self.limits {
            l.clamp(x);
        }
    }

    fn on_bound(&self, x: &[f64]) -> bool {
        self.limits.as_ref().is_some_and(|l| l.on_bound(x))
    }
}

/// A pose-IK solver with its buffers, reused across many solves.
pub struct IkSolver<'a> {
    robot: &'a Robot,
    pub opts: SolveOptions,
    mask: TaskMask,
    lm: Lm,
    ws: Workspace,
    jac: Vec<[f64; 3]>,
}

impl<'a> IkSolver<'a> {
    pub fn new(robot: &'a Robot, mask: TaskMask, opts: SolveOptions) -> Self {
        // more task rows than joints (a 1- or 2-joint arm, full pose): the
        // normal-equation form of the step
        let step = Step::levenberg(mask.active().1, robot.n());
        IkSolver {
            robot,
            opts,
            mask,
            lm: Lm::equations(step, opts.tol, opts.max_iter),
            ws: Workspace::default(),
            jac: vec![[0.0; 3]; robot.n()],
        }
    }

    /// `theta` holds the seed on entry and the answer on exit.
    pub fn solve(&mut self, target: &[f64; 3], theta: &mut [f64]) -> Status {
        fn run<const N: usize>(s: &mut IkSolver, target: &[f64; 3], theta: &mut [f64]) -> Status {
            let (active, m) = s.mask.active();
            let mut p = PoseProblem::<N> {
                robot: s.robot,
                target: *target,
                mask: s.mask,
                active,
                m,
                jac: &mut s.jac,
                limits: s.opts.enforce_limits.then(|| s.robot.limits()),
            };
            lm::solve(&mut p, theta, &s.lm, &mut s.ws)
        }
        if self.mask.active().1 < PLANAR_TASK {
            return run::<0>(self, target, theta);
        }
        match self.robot.n() {
            3 => run::<3>(self, target, theta),
            4 => run::<4>(self, target, theta),
            _ => run::<0>(self, target, theta),
        }
    }
}

/// How the pose IK is solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IkMethod {
    /// Damped least squares from the seed (any arm, any task mask).
    Lm,
    /// The closed form of a 3-joint arm, full pose (`docs/model.md`).
    ClosedForm,
}

/// Whether [`IkMethod::ClosedForm`] applies to `robot` with `mask`; an
/// error naming the field otherwise.
pub fn check_closed_form(robot: &Robot, mask: TaskMask) -> Result<()> {
    if robot.n() != 3 {
        return Err(CdsmError::Option {
            name: "method".into(),
            problem: format!(
                "'closed_form' needs a 3-joint arm, this one has {}",
                robot.n()
            ),
        });
    }
    if mask.weights.contains(&0.0) {
        return Err(CdsmError::Option {
            name: "mask".into(),
            problem: "method 'closed_form' solves the full pose (x, y, phi): use mask 'pose'"
                .into(),
        });
    }
    Ok(())
}

/// `t` moved by whole turns to lie within pi of `seed` (`t - seed` in `(-pi, pi]`).
#[inline]
fn near(t: f64, seed: f64) -> f64 {
    let d = t - seed;
    if d > -PI && d <= PI {
        return t;
    }
    let mut d = d.rem_euclid(TAU);
    if d > PI {
        d -= TAU;
    }
    seed + d
}

/// Closed-form pose IK of a 3-joint arm (`docs/model.md`, "Closed-form pose
/// IK"): `theta` holds the seed on entry and the answer on exit (unchanged
/// when the pose is out of reach). The caller checks [`check_closed_form`].
pub fn ik_closed_form(
    robot: &Robot,
    pose: &[f64; 3],
    theta: &mut [f64],
    opts: &SolveOptions,
) -> Status {
    let (lb, la, th) = (&robot.link_before, &robot.link_after, &robot.thickness);
    let r1 = la[0] + th[0] + lb[1];
    let r2 = la[1] + th[1] + lb[2];
    let a3 = la[2] + th[2];
    let [x, y, phi] = *pose;
    let (sp, cp) = phi.sin_cos();
    let (dx, dy) = (x - a3 * cp - lb[0], y - a3 * sp);
    let c2 = (dx * dx + dy * dy - r1 * r1 - r2 * r2) / (2.0 * r1 * r2);
    let residual_at = |t: &[f64]| {
        let p = robot.fk(t);
        (0..3).map(|k| (p[k] - pose[k]).abs()).fold(0.0, f64::max)
    };
    if c2.is_nan() || c2.abs() > 1.0 {
        // out of reach: theta stays the seed, the residual is the seed's
        let residual = residual_at(theta);
        return Status {
            converged: false,
            iterations: 0,
            residual,
            cost: residual * residual,
            reason: Reason::Unreachable,
        };
    }
    let seed = [theta[0], theta[1], theta[2]];
    // theta_2 = s acos(c2), sin(theta_2) = s sqrt(1 - c2^2): theta_1 = base - s gamma
    let a = c2.acos();
    let base = dy.atan2(dx);
    let gamma = (r2 * (1.0 - c2 * c2).max(0.0).sqrt()).atan2(r1 + r2 * c2);
    // branches s = +1 and s = -1 (sin theta_2 <= 0: the paper's)
    let branch = |s: f64| -> ([f64; 3], f64) {
        let t1 = near(base - s * gamma, seed[0]);
        let t2 = near(s * a, seed[1]);
        let t = [t1, t2, phi - t1 - t2];
        let d = t.iter().zip(&seed).map(|(a, b)| (a - b) * (a - b)).sum();
        (t, d)
    };
    let (plus, minus) = (branch(1.0), branch(-1.0));
    let tie = 1e-12 * (1.0 + seed.iter().map(|v| v * v).sum::<f64>());
    let nearest = if plus.1 < minus.1 - tie {
        plus.0
    } else {
        minus.0
    };
    let other = if nearest == plus.0 { minus.0 } else { plus.0 };
    let mut reason = Reason::Converged;
    let limits = robot.limits();
    let pick = if !opts.enforce_limits || limits.contains(&nearest) {
        nearest
    } else if limits.contains(&other) {
        other
    } else {
        reason = Reason::OutsideLimits;
        nearest
    };
    theta.copy_from_slice(&pick);
    let residual = residual_at(theta);
    let converged = reason == Reason::Converged && residual <= opts.tol;
    if reason == Reason::Converged && !converged {
        reason = Reason::Singular;
    }
    Status {
        converged,
        iterations: 0,
        residual,
        cost: residual * residual,
        reason,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ArmGeometry;
    use crate::lm::Reason;

    /// Pose IK of one target (full pose): `theta` holds the seed on entry
    /// and the answer on exit.
    fn ik(robot: &Robot, pose: &[f64; 3], theta: &mut [f64], opts: &SolveOptions) -> Status {
        IkSolver::new(robot, TaskMask::POSE, *opts).solve(pose, theta)
    }

    /// A mask is parsed for the arm's kind, as its table says it is given:
    /// weights on a planar arm, names on a spatial one; the other's, a
    /// wrong count of weights and an unknown name are refused naming `mask`.
    #[test]
    fn masks_parse_as_the_kind_takes_them() {
        let w = [1.0, 1.0, 0.0];
        assert_eq!(
            Mask::parse(Kind::Planar, MaskArg::Weights(&w)).unwrap(),
            Mask::Weights(TaskMask { weights: w })
        );
        for (name, form) in NAMED_MASKS {
            assert_eq!(
                Mask::parse(Kind::Spatial, MaskArg::Name(name)).unwrap(),
                Mask::Form(form)
            );
        }
        let error = |kind, arg| Mask::parse(kind, arg).unwrap_err().to_string();
        assert_eq!(
            error(Kind::Planar, MaskArg::Name("pose")),
            "`mask`: a spatial mask is not a mask of a planar arm"
        );
        assert_eq!(
            error(Kind::Spatial, MaskArg::Weights(&w)),
            "`mask`: a planar weight triple is not a mask of a spatial arm"
        );
        assert_eq!(
            error(Kind::Planar, MaskArg::Weights(&w[..2])),
            "`mask`: expected 3 weights (x, y, phi), got 2"
        );
        assert!(error(Kind::Spatial, MaskArg::Name("bogus")).contains("got \"bogus\""));
    }

    #[test]
    fn ik_reaches_a_forward_pose() {
        let r = Robot::paper();
        let want = [0.2, -0.3, 0.45];
        let pose = r.fk(&want);
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
        assert_ne!(st.reason, Reason::Converged);
    }

    #[test]
    fn position_mask_leaves_the_attitude_free() {
        let r = Robot::paper();
        let want = [0.3, -0.2, 0.4];
        let p = r.fk(&want);
        let mut th = [0.0, -1e-3, 0.0];
        let mut s = IkSolver::new(&r, TaskMask::POSITION, SolveOptions::default());
        let st = s.solve(&[p[0], p[1], 123.0], &mut th);
        assert!(st.converged, "{st:?}");
        let q = r.fk(&th);
        assert!((q[0] - p[0]).abs() < 1e-12 && (q[1] - p[1]).abs() < 1e-12);
    }
}

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

/// The named masks, in the order the error names them.
const NAMED_MASKS: [(&str, SpatialMask); 3] = [
    ("position", SpatialMask::Position),
    ("pointing", SpatialMask::Pointing),
    ("pose", SpatialMask::Pose),
];

/// A pose-IK mask as given: a name or weights on the task coordinates.
#[derive(Debug, Clone, Copy)]
pub enum MaskArg<'a> {
    Name(&'a str),
    Weights(&'a [f64]),
}

/// What the pose IK of an arm matches ([`crate::arm::ik`]), parsed for
/// its kind by [`Mask::parse`]: weights on a planar arm's `x, y, phi`, or
/// a named form of a spatial arm's pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mask {
    Weights(TaskMask),
    Form(SpatialMask),
}

impl Mask {
    /// The mask `arg` of an arm of kind `kind`, as the kind takes it
    /// ([`KindInfo::masks`](crate::kinds::KindInfo)); an error naming
    /// `mask` for a mask of the wrong shape, an unknown name or a mask the
    /// kind does not take.
    pub fn parse(kind: Kind, arg: MaskArg) -> Result<Mask> {
        let bad = |problem: String| CdsmError::Option {
            name: "mask".into(),
            problem,
        };
        let takes = kind.info().masks;
        match arg {
            MaskArg::Weights(w) => {
                let [x, y, p] = w[..] else {
                    return Err(bad(format!(
                        "expected 3 weights (x, y, phi), got {}",
                        w.len()
                    )));
                };
                match takes {
                    Masks::Weights => Ok(Mask::Weights(TaskMask { weights: [x, y, p] })),
                    Masks::Named => Err(bad(format!(
                        "a planar weight triple is not a mask of a {} arm",
                        kind.name()
                    ))),
                }
            }
            MaskArg::Name(name) => {
                let Some(&(_, form)) = NAMED_MASKS.iter().find(|(n, _)| *n == name) else {
                    return Err(bad(format!(
                        "expected 'position', 'pointing' or 'pose' for a spatial arm, got {name:?}"
                    )));
                };
                match takes {
                    Masks::Named => Ok(Mask::Form(form)),
                    Masks::Weights => Err(bad(format!(
                        "a spatial mask is not a mask of a {} arm",
                        kind.name()
                    ))),
                }
            }
        }
    }
}

type M3 = [[f64; 3]; 3];

fn column0(r: &M3) -> [f64; 3] {
    [r[0][0], r[1][0], r[2][0]]
}

fn transpose(r: &M3) -> M3 {
    std::array::from_fn(|i| std::array::from_fn(|j| r[j][i]))
}

fn mul(a: &M3, b: &M3) -> M3 {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

fn mul_v(a: &M3, v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| (0..3).map(|k| a[i][k] * v[k]).sum())
}

/// The pose-IK problem of a spatial arm (`docs/spatial.md`, "Solves"):
/// position `p - p_t`; pointing `R e_x - R_t e_x`; pose `R_t log(R_t^T R)`.
struct SpatialPose<'a> {
    model: &'a Model,
    mask: SpatialMask,
    target_p: [f64; 3],
    target_r: M3,
    chain: Chain<f64, Se3<f64>>,
    jac: Vec<f64>,
    limits: Option<Limits>,
}

impl Problem for SpatialPose<'_> {
    fn dims(&self) -> (usize, usize) {
        (self.mask.rows(), self.model.n())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        let n = x.len();
        self.chain.at(self.model, self.model, x);
        self.chain.world(self.model, self.model);
        let end = *self.chain.end();
        for ((ri, t), p) in r.iter_mut().zip(end.t).zip(self.target_p) {
            *ri = t - p;
        }
        let d = column0(&end.r);
        match self.mask {
            SpatialMask::Position => {}
            SpatialMask::Pointing => {
                let dt = column0(&self.target_r);
                for i in 0..3 {
                    r[3 + i] = d[i] - dt[i];
                }
            }
            SpatialMask::Pose => {
                let e = mul_v(
                    &self.target_r,
                    log_so3(&mul(&transpose(&self.target_r), &end.r)),
                );
                r[3..6].copy_from_slice(&e);
            }
        }
        if let Some(j) = jac {
            self.chain.joints_world(self.model);
            self.chain.geometric_jacobian(&mut self.jac);
            j[..3 * n].copy_from_slice(&self.jac[..3 * n]);
            match self.mask {
                SpatialMask::Position => {}
                SpatialMask::Pointing => {
                    for k in 0..n {
                        let w = [
                            self.jac[3 * n + k],
                            self.jac[4 * n + k],
                            self.jac[5 * n + k],
                        ];
                        let v = crate::kinds::cross(w, d);
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
            l.clamp(x);
        }
    }

    fn on_bound(&self, x: &[f64]) -> bool {
        self.limits.as_ref().is_some_and(|l| l.on_bound(x))
    }
}

/// A pose-IK solver of a spatial arm with its buffers.
pub struct SpatialIk<'a> {
    model: &'a Model,
    mask: SpatialMask,
    opts: SolveOptions,
    ws: Workspace,
}

impl<'a> SpatialIk<'a> {
    pub fn new(model: &'a Model, mask: SpatialMask, opts: SolveOptions) -> Self {
        SpatialIk {
            model,
            mask,
            opts,
            ws: Workspace::default(),
        }
    }

    /// Target `[x, y, z, rx, ry, rz]` (m, rotation vector rad) to `theta`
    /// (seed on entry, answer on exit).
    pub fn solve(&mut self, target: &[f64; 6], theta: &mut [f64]) -> Status {
        let n = self.model.n();
        let mut p = SpatialPose {
            model: self.model,
            mask: self.mask,
            target_p: [target[0], target[1], target[2]],
            target_r: exp_so3([target[3], target[4], target[5]]),
            chain: Chain::new(self.model),
            jac: vec![0.0; 6 * n],
            limits: self.opts.enforce_limits.then(|| self.model.limits()),
        };
        let lm = Lm::equations(
            Step::levenberg(self.mask.rows(), n),
            self.opts.tol,
            self.opts.max_iter,
        );
        lm::solve(&mut p, theta, &lm, &mut self.ws)
    }
}
