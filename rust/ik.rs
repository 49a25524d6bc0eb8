//! Pose IK: the joint angles that put the end frame on a target, by one
//! damped least squares over the one model ([`IkSolver`]: [`crate::lm`],
//! the step of [`crate::lm::Step::levenberg`]: minimal norm unless the task
//! has more rows than the arm has joints), with a task mask parsed for the
//! arm's kind ([`Mask`]). Two evaluators of the end pose: a planar arm's
//! angle-addition kinematics ([`PlanarTask`]: `x, y, phi`, any weights) and
//! the chain of any arm ([`ChainTask`]: the position, the pointing
//! direction or the full pose). [`solve_batch`] chooses, once, a planar
//! arm's fast paths: that evaluator, and the closed form of 3-joint arms
//! (full pose; both branches, the one nearest the seed) on SIMD lanes.

use crate::chain::Chain;
use crate::error::{check_finite, CdsmError, Result};
use crate::geometry::ArmGeometry;
use crate::kinds::{cross, exp_so3, log_so3, Kind, Masks, Se3};
use crate::kinematics::fk_jacobian;
use crate::limits::Limits;
use crate::lm::{self, Lm, Problem, Reason, Step, Workspace};
use crate::model::Model;
use crate::planar::ik_lanes::ik_closed_form_batch;
use crate::robot::PlanarView;
use crate::rows::{rows_of, seeds, split_rows, BatchSolution};
use crate::solve::{SolveOptions, Status};
use std::f64::consts::{PI, TAU};

/// The rows a spatial mask adds after the weighted coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Attitude {
    /// None (a planar arm's, whose angle is a weighted coordinate; a
    /// spatial arm's position).
    Free,
    /// The direction of the end frame's x axis: `R e_x - R_t e_x` (3 rows, 2 DOF).
    Pointing,
    /// The orientation: `R_t log(R_t^T R)` (3 rows).
    LogMap,
}

impl Attitude {
    fn rows(self) -> usize {
        match self {
            Attitude::Free => 0,
            _ => 3,
        }
    }
}

/// What the pose IK of an arm matches, parsed for its kind by
/// [`Mask::parse`]: weights on the residuals of the kind's weighted task
/// coordinates (a planar arm's `x, y, phi`, any non-negative weights; a
/// spatial arm's `x, y, z`, all 1), then the unweighted rows of the
/// attitude. Convergence is judged on the weighted residual.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mask {
    /// The kind of the arms it fits.
    pub kind: Kind,
    /// Weights on the weighted coordinates' residuals (`0` leaves one free).
    pub weights: [f64; 3],
    /// The attitude rows after them.
    pub attitude: Attitude,
}

/// A spatial arm's named masks, in the order the error names them.
const NAMED_MASKS: [(&str, Attitude); 3] = [
    ("position", Attitude::Free),
    ("pointing", Attitude::Pointing),
    ("pose", Attitude::LogMap),
];

/// A pose-IK mask as given: a name or weights on the task coordinates.
#[derive(Debug, Clone, Copy)]
pub enum MaskArg<'a> {
    Name(&'a str),
    Weights(&'a [f64]),
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
                    Masks::Weights => Ok(Mask {
                        kind,
                        weights: [x, y, p],
                        attitude: Attitude::Free,
                    }),
                    Masks::Named => Err(bad(format!(
                        "a planar weight triple is not a mask of a {} arm",
                        kind.name()
                    ))),
                }
            }
            MaskArg::Name(name) => {
                let Some(&(_, attitude)) = NAMED_MASKS.iter().find(|(n, _)| *n == name) else {
                    return Err(bad(format!(
                        "expected 'position', 'pointing' or 'pose' for a spatial arm, got {name:?}"
                    )));
                };
                match takes {
                    Masks::Named => Ok(Mask {
                        kind,
                        weights: [1.0; 3],
                        attitude,
                    }),
                    Masks::Weights => Err(bad(format!(
                        "a spatial mask is not a mask of a {} arm",
                        kind.name()
                    ))),
                }
            }
        }
    }

    /// An error naming `mask` for weights that are not finite, negative or
    /// all zero.
    fn check(&self) -> Result<()> {
        check_finite("mask", &self.weights)?;
        if self.weights.iter().all(|w| *w == 0.0) || self.weights.iter().any(|w| *w < 0.0) {
            return Err(CdsmError::Option {
                name: "mask".into(),
                problem: format!(
                    "weights must be >= 0 with at least one > 0, got {:?}",
                    self.weights
                ),
            });
        }
        Ok(())
    }

    /// Indices of the matched weighted coordinates.
    fn active(&self) -> ([usize; 3], usize) {
        let mut idx = [0; 3];
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

/// An arm's end pose as the pose IK reads it: the errors `p_i - t_i` of the
/// three weighted task coordinates and their Jacobian rows, and the
/// attitude rows of a mask.
pub trait TaskEval {
    /// The targets' name in errors.
    const TARGET: &'static str;
    /// Whether the solver may fix the joint count at compile time (a small
    /// arm's full pose: the solver's loops then have constant trip counts).
    const FIXED: bool;
    /// Joints.
    fn n(&self) -> usize;
    /// The joint-limit box.
    fn limits(&self) -> Limits;
    /// Sets the target (one row of the kind's task width).
    fn set_target(&mut self, target: &[f64]);
    /// Evaluates at `theta`: keeps the errors and, with `jac`, their rows;
    /// writes the rows of `attitude` into `r` and `jac` (`rows x n`).
    /// False when the pose is not finite.
    fn eval(
        &mut self,
        theta: &[f64],
        attitude: Attitude,
        r: &mut [f64],
        jac: Option<&mut [f64]>,
    ) -> bool;
    /// Error of weighted coordinate `i` at the last [`TaskEval::eval`].
    fn error(&self, i: usize) -> f64;
    /// `d error_i / d theta_k` at the last [`TaskEval::eval`] with `jac`.
    fn row(&self, i: usize, k: usize) -> f64;
}

/// A planar arm's end pose `x, y, phi` by angle addition
/// ([`crate::kinematics::fk_jacobian`]).
pub struct PlanarTask<'a> {
    robot: &'a PlanarView,
    target: [f64; 3],
    p: [f64; 3],
    jac: Vec<[f64; 3]>,
}

impl<'a> PlanarTask<'a> {
    pub fn new(robot: &'a PlanarView) -> Self {
        PlanarTask {
            robot,
            target: [0.0; 3],
            p: [0.0; 3],
            jac: vec![[0.0; 3]; robot.n()],
        }
    }
}

impl TaskEval for PlanarTask<'_> {
    const TARGET: &'static str = "pose";
    const FIXED: bool = true;

    #[inline(always)]
    fn n(&self) -> usize {
        self.robot.n()
    }

    fn limits(&self) -> Limits {
        Limits(self.robot.limits().0.to_vec())
    }

    #[inline(always)]
    fn set_target(&mut self, target: &[f64]) {
        self.target = [target[0], target[1], target[2]];
    }

    #[inline(always)]
    fn eval(&mut self, theta: &[f64], _: Attitude, _: &mut [f64], _: Option<&mut [f64]>) -> bool {
        let n = theta.len();
        self.p = fk_jacobian(self.robot, theta, &mut self.jac[..n]);
        true
    }

    #[inline(always)]
    fn error(&self, i: usize) -> f64 {
        self.p[i] - self.target[i]
    }

    #[inline(always)]
    fn row(&self, i: usize, k: usize) -> f64 {
        self.jac[k][i]
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

/// Any arm's end pose on the one model's chain (`docs/spatial.md`,
/// "Solves"): target `[x, y, z, rx, ry, rz]` (m, rotation vector rad);
/// errors `p - p_t`, pointing rows `R e_x - R_t e_x`, pose rows
/// `R_t log(R_t^T R)`, the geometric Jacobian. Its chain and Jacobian are
/// sized once and reused for every solve.
pub struct ChainTask<'a> {
    model: &'a Model,
    target_p: [f64; 3],
    target_r: M3,
    chain: Chain<f64, Se3<f64>>,
    e: [f64; 3],
    jac: Vec<f64>,
}

impl<'a> ChainTask<'a> {
    pub fn new(model: &'a Model) -> Self {
        ChainTask {
            model,
            target_p: [0.0; 3],
            target_r: exp_so3([0.0; 3]),
            chain: Chain::new(model),
            e: [0.0; 3],
            jac: vec![0.0; 6 * model.n()],
        }
    }
}

impl TaskEval for ChainTask<'_> {
    const TARGET: &'static str = "target";
    const FIXED: bool = false;

    fn n(&self) -> usize {
        self.model.n()
    }

    fn limits(&self) -> Limits {
        self.model.limits()
    }

    fn set_target(&mut self, target: &[f64]) {
        self.target_p = [target[0], target[1], target[2]];
        self.target_r = exp_so3([target[3], target[4], target[5]]);
    }

    fn eval(
        &mut self,
        x: &[f64],
        attitude: Attitude,
        r: &mut [f64],
        jac: Option<&mut [f64]>,
    ) -> bool {
        let n = x.len();
        self.chain.at(self.model, self.model, x);
        self.chain.world(self.model, self.model);
        let end = *self.chain.end();
        for ((ei, t), p) in self.e.iter_mut().zip(end.t).zip(self.target_p) {
            *ei = t - p;
        }
        let d = column0(&end.r);
        match attitude {
            Attitude::Free => {}
            Attitude::Pointing => {
                let dt = column0(&self.target_r);
                for i in 0..3 {
                    r[i] = d[i] - dt[i];
                }
            }
            Attitude::LogMap => {
                let e = mul_v(
                    &self.target_r,
                    log_so3(&mul(&transpose(&self.target_r), &end.r)),
                );
                r[..3].copy_from_slice(&e);
            }
        }
        if let Some(j) = jac {
            self.chain.joints_world(self.model);
            self.chain.geometric_jacobian(&mut self.jac);
            match attitude {
                Attitude::Free => {}
                Attitude::Pointing => {
                    for k in 0..n {
                        let w = [
                            self.jac[3 * n + k],
                            self.jac[4 * n + k],
                            self.jac[5 * n + k],
                        ];
                        let v = cross(w, d);
                        for i in 0..3 {
                            j[i * n + k] = v[i];
                        }
                    }
                }
                Attitude::LogMap => j[..3 * n].copy_from_slice(&self.jac[3 * n..6 * n]),
            }
        }
        self.e
            .iter()
            .chain(&r[..attitude.rows()])
            .all(|v| v.is_finite())
    }

    #[inline(always)]
    fn error(&self, i: usize) -> f64 {
        self.e[i]
    }

    #[inline(always)]
    fn row(&self, i: usize, k: usize) -> f64 {
        self.jac[i * self.model.n() + k]
    }
}

/// The pose-IK problem: `r_i = w_i (p_i - t_i)` over the matched weighted
/// coordinates, then the attitude rows. `M`, `N`: the rows and joints when
/// they are known at compile time (see [`TaskEval::FIXED`]), else 0.
struct PoseProblem<'a, E: TaskEval, const M: usize, const N: usize> {
    task: &'a mut E,
    mask: Mask,
    active: [usize; 3],
    /// Matched weighted coordinates, and all rows.
    w: usize,
    m: usize,
    /// The joint-limit box when the limits are enforced.
    limits: Option<Limits<&'a [[f64; 2]]>>,
}

impl<E: TaskEval, const M: usize, const N: usize> Problem for PoseProblem<'_, E, M, N> {
    #[inline(always)]
    fn dims(&self) -> (usize, usize) {
        if N > 0 {
            (M, N)
        } else {
            (self.m, self.task.n())
        }
    }

    #[inline(always)]
    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        let (m, n) = self.dims();
        // the attitude rows: none on the fixed path
        let w = if N > 0 { M } else { self.w };
        let (rw, ra) = r[..m].split_at_mut(w);
        let (jw, ja) = match jac {
            Some(j) => {
                let (a, b) = j[..m * n].split_at_mut(w * n);
                (Some(a), Some(b))
            }
            None => (None, None),
        };
        let ok = self.task.eval(&x[..n], self.mask.attitude, ra, ja);
        for (row, &i) in self.active[..w].iter().enumerate() {
            rw[row] = self.mask.weights[i] * self.task.error(i);
        }
        if let Some(j) = jw {
            for (row, &i) in self.active[..w].iter().enumerate() {
                for k in 0..n {
                    j[row * n + k] = self.mask.weights[i] * self.task.row(i, k);
                }
            }
        }
        ok
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

/// A pose-IK solver over an evaluator, with its buffers, reused across
/// many solves.
pub struct IkSolver<E: TaskEval> {
    task: E,
    mask: Mask,
    active: [usize; 3],
    w: usize,
    m: usize,
    lm: Lm,
    ws: Workspace,
    /// The joint-limit box when the limits are enforced.
    limits: Option<Limits>,
}

impl<E: TaskEval> IkSolver<E> {
    pub fn new(task: E, mask: Mask, opts: SolveOptions) -> Self {
        let (active, w) = mask.active();
        let m = w + mask.attitude.rows();
        // more task rows than joints (a 1- or 2-joint planar arm's full
        // pose): the normal-equation form of the step
        let step = Step::levenberg(m, task.n());
        IkSolver {
            limits: opts.enforce_limits.then(|| task.limits()),
            task,
            mask,
            active,
            w,
            m,
            lm: Lm::equations(step, opts.tol, opts.max_iter),
            ws: Workspace::default(),
        }
    }

    /// One target row; `theta` holds the seed on entry and the answer on exit.
    pub fn solve(&mut self, target: &[f64], theta: &mut [f64]) -> Status {
        fn run<E: TaskEval, const M: usize, const N: usize>(
            s: &mut IkSolver<E>,
            theta: &mut [f64],
        ) -> Status {
            let mut p = PoseProblem::<E, M, N> {
                task: &mut s.task,
                mask: s.mask,
                active: s.active,
                w: s.w,
                m: s.m,
                limits: s.limits.as_ref().map(|l| Limits(l.bounds())),
            };
            lm::solve(&mut p, theta, &s.lm, &mut s.ws)
        }
        self.task.set_target(target);
        if !E::FIXED || self.w < 3 || self.m > 3 {
            return run::<E, 0, 0>(self, theta);
        }
        match self.task.n() {
            3 => run::<E, 3, 3>(self, theta),
            4 => run::<E, 3, 4>(self, theta),
            _ => run::<E, 0, 0>(self, theta),
        }
    }
}

/// How the pose IK is solved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IkMethod {
    /// Damped least squares from the seed (any arm, any task mask).
    Lm,
    /// The closed form of a 3-joint planar arm, full pose (`docs/model.md`).
    ClosedForm,
}

/// The pose IK of a batch: targets `(N, task)` (m, rad), `seed (N, n)` or
/// zeros; `mask` parsed for the arm's kind ([`Mask::parse`]). The planar
/// fast paths are chosen here: a planar arm's angle-addition evaluator,
/// and with [`IkMethod::ClosedForm`] the closed form (SIMD lanes across
/// rows unless the limits are enforced).
pub fn solve_batch(
    model: &Model,
    target: &[f64],
    seed: Option<&[f64]>,
    mask: Mask,
    method: IkMethod,
    opts: &SolveOptions,
    threads: usize,
) -> Result<BatchSolution> {
    if mask.kind != model.kind {
        return Err(CdsmError::Option {
            name: "mask".into(),
            problem: format!("{mask:?} is not a mask of a {} arm", model.kind.name()),
        });
    }
    match model.planar() {
        Some(robot) => {
            let (rows, seed) = check::<PlanarTask>(model, target, seed, &mask, opts)?;
            if method == IkMethod::ClosedForm {
                check_closed_form(robot, &mask)?;
                if !opts.enforce_limits {
                    return Ok(ik_closed_form_rows(robot, target, seed, opts, threads));
                }
                let solve = || {
                    |t: &[f64], th: &mut [f64]| ik_closed_form(robot, &[t[0], t[1], t[2]], th, opts)
                };
                return Ok(each_row(model, rows, target, seed, threads, solve));
            }
            Ok(each_row(model, rows, target, seed, threads, || {
                let mut s = IkSolver::new(PlanarTask::new(robot), mask, *opts);
                move |t: &[f64], th: &mut [f64]| s.solve(t, th)
            }))
        }
        None => {
            if method == IkMethod::ClosedForm {
                return Err(CdsmError::Option {
                    name: "method".into(),
                    problem: format!(
                        "a {} arm's pose IK has no closed form; use 'lm'",
                        model.kind.name()
                    ),
                });
            }
            let (rows, seed) = check::<ChainTask>(model, target, seed, &mask, opts)?;
            Ok(each_row(model, rows, target, seed, threads, || {
                let mut s = IkSolver::new(ChainTask::new(model), mask, *opts);
                move |t: &[f64], th: &mut [f64]| s.solve(t, th)
            }))
        }
    }
}

/// The rows of `target` (named as the evaluator `E` names them) and the
/// seeds, checked against `model`'s widths, and the options and mask.
fn check<'s, E: TaskEval>(
    model: &Model,
    target: &[f64],
    seed: Option<&'s [f64]>,
    mask: &Mask,
    opts: &SolveOptions,
) -> Result<(usize, Option<&'s [f64]>)> {
    let rows = rows_of(E::TARGET, target, model.kind.info().task)?;
    let seed = seeds(seed, rows, model.n())?;
    opts.check()?;
    mask.check()?;
    Ok((rows, seed))
}

/// `solve(target row, theta)` over the rows of `model`'s targets in
/// threads (one `solve` each, from `make`: the closed form, or a solver
/// with its buffers), `theta` the row's seed or zeros on entry.
fn each_row<S: FnMut(&[f64], &mut [f64]) -> Status>(
    model: &Model,
    rows: usize,
    target: &[f64],
    seed: Option<&[f64]>,
    threads: usize,
    make: impl Fn() -> S + Sync,
) -> BatchSolution {
    let (n, width, limits) = (model.n(), model.kind.info().task, model.limits());
    let parts = split_rows(rows, threads, |r| {
        let mut out = BatchSolution::with_capacity(r.len(), n);
        let mut th = vec![0.0; n];
        let mut solve = make();
        for i in r {
            match seed {
                Some(s) => th.copy_from_slice(&s[i * n..(i + 1) * n]),
                None => th.fill(0.0),
            }
            let st = solve(&target[i * width..(i + 1) * width], &mut th);
            out.push_row(&th, st, limits.contains(&th));
        }
        out
    });
    BatchSolution::concat(parts)
}

/// Whether [`IkMethod::ClosedForm`] applies to `robot` with `mask`; an
/// error naming the field otherwise.
pub fn check_closed_form(robot: &PlanarView, mask: &Mask) -> Result<()> {
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
    robot: &PlanarView,
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

/// The closed-form pose IK of a 3-joint arm over a batch: SIMD across rows,
/// the rows the lanes leave (out of reach, whole turns from the seed) by the
/// scalar function.
fn ik_closed_form_rows(
    robot: &PlanarView,
    pose: &[f64],
    seed: Option<&[f64]>,
    opts: &SolveOptions,
    threads: usize,
) -> BatchSolution {
    let arch = pulp::Arch::new();
    let rows = pose.len() / 3;
    let parts = split_rows(rows, threads, |r| {
        let m = r.len();
        let zeros;
        let seed = match seed {
            Some(s) => &s[r.start * 3..r.end * 3],
            None => {
                zeros = vec![0.0; m * 3];
                &zeros
            }
        };
        let pose = &pose[r.start * 3..r.end * 3];
        let mut theta = vec![0.0; m * 3];
        let (mut residual, mut done) = (vec![0.0; m], vec![false; m]);
        ik_closed_form_batch(
            arch,
            robot,
            pose,
            seed,
            &mut theta,
            &mut residual,
            &mut done,
        );
        let mut out = BatchSolution::with_capacity(m, 3);
        for i in 0..m {
            let th = &mut theta[i * 3..(i + 1) * 3];
            let st = if done[i] {
                let converged = residual[i] <= opts.tol;
                Status {
                    converged,
                    iterations: 0,
                    residual: residual[i],
                    cost: residual[i] * residual[i],
                    reason: if converged {
                        Reason::Converged
                    } else {
                        Reason::Singular
                    },
                }
            } else {
                th.copy_from_slice(&seed[i * 3..(i + 1) * 3]);
                let p = [pose[3 * i], pose[3 * i + 1], pose[3 * i + 2]];
                ik_closed_form(robot, &p, th, opts)
            };
            out.push_row(th, st, robot.limits().contains(th));
        }
        out
    });
    BatchSolution::concat(parts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ArmGeometry;
    use crate::lm::Reason;

    /// A planar mask of weights on `x, y, phi`.
    fn weights(weights: [f64; 3]) -> Mask {
        Mask::parse(Kind::Planar, MaskArg::Weights(&weights)).unwrap()
    }

    /// Pose IK of one target (full pose): `theta` holds the seed on entry
    /// and the answer on exit.
    fn ik(robot: &PlanarView, pose: &[f64; 3], theta: &mut [f64], opts: &SolveOptions) -> Status {
        IkSolver::new(PlanarTask::new(robot), weights([1.0; 3]), *opts).solve(pose, theta)
    }

    fn two_universal() -> Model {
        Model::from_toml(include_str!("../python/cdsm/robots/two_universal.toml")).unwrap()
    }

    /// One spatial solver, its chain and Jacobian reused, solves every row
    /// as a fresh solver does, bit for bit, for every named mask.
    #[test]
    fn a_reused_chain_solver_equals_fresh_ones() {
        let model = two_universal();
        let n = model.n();
        let theta: Vec<f64> = (0..3 * n).map(|i| 0.3 * (0.7 * i as f64).sin()).collect();
        let target = crate::arm::fk(&model, &theta, 1).unwrap();
        for (name, _) in NAMED_MASKS {
            let mask = Mask::parse(Kind::Spatial, MaskArg::Name(name)).unwrap();
            let opts = SolveOptions::default();
            let mut reused = IkSolver::new(ChainTask::new(&model), mask, opts);
            for i in 0..3 {
                let t = &target[6 * i..6 * i + 6];
                let (mut a, mut b) = (vec![0.05; n], vec![0.05; n]);
                let sa = reused.solve(t, &mut a);
                let sb = IkSolver::new(ChainTask::new(&model), mask, opts).solve(t, &mut b);
                assert!(sa.converged, "{name} row {i}: {sa:?}");
                assert_eq!(format!("{sa:?}"), format!("{sb:?}"), "{name} row {i}");
                assert_eq!(
                    a.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    b.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    "{name} row {i}"
                );
            }
        }
    }

    /// A mask parsed for another kind is refused by the batch, naming
    /// `mask`; a spatial arm has no closed form, naming `method`.
    #[test]
    fn the_batch_refuses_another_kinds_mask_and_a_spatial_closed_form() {
        let spatial = two_universal();
        let planar = Model::from_planar(&PlanarView::paper());
        let opts = SolveOptions::default();
        let named = Mask::parse(Kind::Spatial, MaskArg::Name("pose")).unwrap();
        let error = |model, mask, method| {
            solve_batch(model, &[0.0; 6], None, mask, method, &opts, 1)
                .unwrap_err()
                .to_string()
        };
        assert!(error(&spatial, weights([1.0; 3]), IkMethod::Lm).starts_with("`mask`:"));
        assert!(error(&planar, named, IkMethod::Lm).starts_with("`mask`:"));
        assert!(error(&spatial, named, IkMethod::ClosedForm).starts_with("`method`:"));
    }

    /// A mask is parsed for the arm's kind, as its table says it is given:
    /// weights on a planar arm, names on a spatial one; the other's, a
    /// wrong count of weights and an unknown name are refused naming `mask`.
    #[test]
    fn masks_parse_as_the_kind_takes_them() {
        let w = [1.0, 1.0, 0.0];
        assert_eq!(
            Mask::parse(Kind::Planar, MaskArg::Weights(&w)).unwrap(),
            Mask {
                kind: Kind::Planar,
                weights: w,
                attitude: Attitude::Free
            }
        );
        for (name, attitude) in NAMED_MASKS {
            assert_eq!(
                Mask::parse(Kind::Spatial, MaskArg::Name(name)).unwrap(),
                Mask {
                    kind: Kind::Spatial,
                    weights: [1.0; 3],
                    attitude
                }
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
        let r = PlanarView::paper();
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
        let r = PlanarView::paper();
        let mut th = [0.0; 3];
        let st = ik(&r, &[0.3, 0.0, 0.0], &mut th, &SolveOptions::default());
        assert!(!st.converged);
        assert!(st.residual > 0.07 - 1e-9, "{st:?}");
        assert_ne!(st.reason, Reason::Converged);
    }

    #[test]
    fn position_mask_leaves_the_attitude_free() {
        let r = PlanarView::paper();
        let want = [0.3, -0.2, 0.4];
        let p = r.fk(&want);
        let mut th = [0.0, -1e-3, 0.0];
        let position = weights([1.0, 1.0, 0.0]);
        let mut s = IkSolver::new(PlanarTask::new(&r), position, SolveOptions::default());
        let st = s.solve(&[p[0], p[1], 123.0], &mut th);
        assert!(st.converged, "{st:?}");
        let q = r.fk(&th);
        assert!((q[0] - p[0]).abs() < 1e-12 && (q[1] - p[1]).abs() < 1e-12);
    }
}
