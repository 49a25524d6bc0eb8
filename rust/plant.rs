//! The real arm as the nominal model plus candidate unmodelled effects (the
//! "plant"), as specified in `docs/model.md` ("The plant"): commands in
//! sequence through backlash and the actuators, an arm with perturbed holes
//! and links whose cables bear on oversized holes and stretch, seen by an
//! instrument through a tip offset and a frame. All-zero parameters give the
//! nominal model exactly. SI units (m, rad, N).
//!
//! The residual of the settling equation and the observation are written
//! once over [`Real`]: in `f64` they settle and predict, in [`Jet`]s they give
//! exact derivatives along [`JET`] directions per evaluation, so the Jacobian
//! of the predictions with respect to the parameters follows from the
//! implicit function theorem at the settled configuration (no finite
//! differences, no extra settles).

use crate::batch::{rows_of, split_rows};
use crate::cables::CableGeometry;
use crate::error::{CdsmError, Result};
use crate::geometry::{pair, Arm, ArmGeometry};
use crate::lm::{self, solve_general, Lm, Problem, Step, Workspace};
use crate::real::{Jet, Real};
use crate::robot::Robot;
use crate::solve::{CableMethod, CableSolver, SolveOptions};
use crate::statics::{upper_tensions, Loads, TensionBuffers};

/// The effects, in the order of the parameter vector (the last two were
/// added after the first eight and sit at the end).
pub const EFFECTS: [&str; 10] = [
    "actuation_scale",
    "cable_offset",
    "hole_height",
    "link_length",
    "cable_elasticity",
    "hole_clearance",
    "frame_misalignment",
    "tip_offset",
    "backlash",
    "clearance_width",
];

/// The clearance's transition width at `clearance_width = 0` (rad).
pub const CLEARANCE_WIDTH: f64 = 0.01;

/// Number of parameters of each effect for an `n`-joint robot.
pub fn effect_sizes(n: usize) -> [usize; 10] {
    [1, n, n, n + 1, 1, 1, 3, 2, n, 1]
}

/// Offset of each effect's parameters in the flat parameter vector, and the total.
pub fn effect_offsets(n: usize) -> ([usize; 10], usize) {
    let sizes = effect_sizes(n);
    let mut off = [0; 10];
    let mut total = 0;
    for (o, s) in off.iter_mut().zip(sizes) {
        *o = total;
        total += s;
    }
    (off, total)
}

/// The physical domain of each parameter as `[lower, upper]` bounds (SI):
/// non-negative compliance, clearance and backlash, a clearance below the
/// smallest hole height (a hole cannot be wider than its distance from the
/// axis), a transition width in (1e-4, 1] rad, links and actuator gain kept
/// above a tenth of their nominal value.
pub fn bounds(robot: &Robot) -> (Vec<f64>, Vec<f64>) {
    let n = robot.n();
    let (off, total) = effect_offsets(n);
    let mut lo = vec![f64::NEG_INFINITY; total];
    let mut hi = vec![f64::INFINITY; total];
    let min_hole = robot
        .holes
        .chunks_exact(2)
        .map(|p| p[1].abs())
        .filter(|h| *h > 0.0)
        .fold(f64::INFINITY, f64::min);
    if min_hole.is_finite() {
        hi[off[5]] = min_hole;
    }
    hi[off[9]] = 1.0 - CLEARANCE_WIDTH;
    lo[off[0]] = -0.9;
    lo[off[3]] = -0.9 * robot.link_before[0];
    for i in 0..n {
        lo[off[3] + 1 + i] = -0.9 * robot.link_after[i];
        lo[off[8] + i] = 0.0;
    }
    lo[off[4]] = 0.0;
    lo[off[5]] = 0.0;
    lo[off[9]] = 1e-4 - CLEARANCE_WIDTH;
    (lo, hi)
}

/// The parameters of one plant, unpacked, in any scalar.
#[derive(Debug, Clone)]
struct Params<S> {
    scale: S,
    offset: Vec<S>,
    dh: Vec<S>,
    dl: Vec<S>,
    kappa: S,
    clearance: S,
    width: S,
    frame: [S; 3],
    tip: [S; 2],
    backlash: Vec<S>,
}

impl<S: Real> Params<S> {
    /// From the flat vector `p`; the component `dir` (if any) carries derivative 1.
    fn unpack(n: usize, p: &[f64], lift: impl Fn(usize, f64) -> S) -> Params<S> {
        let (off, _) = effect_offsets(n);
        let v = |i: usize| lift(i, p[i]);
        let span = |o: usize, len: usize| (o..o + len).map(v).collect::<Vec<S>>();
        Params {
            scale: v(off[0]),
            offset: span(off[1], n),
            dh: span(off[2], n),
            dl: span(off[3], n + 1),
            kappa: v(off[4]),
            clearance: v(off[5]),
            width: v(off[9]) + CLEARANCE_WIDTH,
            frame: [v(off[6]), v(off[6] + 1), v(off[6] + 2)],
            tip: [v(off[7]), v(off[7] + 1)],
            backlash: span(off[8], n),
        }
    }

    /// The plant's arm: holes of pair `i` moved by `dh_i` (upper `+`, lower
    /// `-`) on every face it crosses, links lengthened by `dl`.
    fn arm(&self, robot: &Robot) -> Arm<S> {
        let n = robot.n();
        let mut arm = Arm::<S>::of(robot, None);
        for c in 0..2 * n {
            let sign = if c % 2 == 0 { 1.0 } else { -1.0 };
            for d in 0..=pair(c) + 1 {
                for f in 0..2 {
                    let i = robot.hole_index(c, d, f) + 1;
                    arm.holes[i] += self.dh[pair(c)] * sign;
                }
            }
        }
        arm.link_before[0] += self.dl[0];
        for i in 0..n {
            arm.link_after[i] += self.dl[i + 1];
        }
        arm
    }
}

/// Whether the flat parameters `p` describe a physical plant (within
/// [`bounds`], finite).
pub fn physical(robot: &Robot, p: &[f64]) -> bool {
    let (lo, hi) = bounds(robot);
    p.iter()
        .zip(lo.iter().zip(&hi))
        .all(|(v, (l, h))| v.is_finite() && *v >= *l && *v <= *h)
}

/// What a measurement row is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum RowKind {
    /// One command `C + dL`, observed.
    Absolute = 0,
    /// Two commands `C` then `C + dL`; the difference of the observations.
    Displacement = 1,
    /// One command `C + dL`, executed, not observed.
    Unmeasured = 2,
}

impl RowKind {
    pub fn from_code(code: u8) -> Result<RowKind> {
        match code {
            0 => Ok(RowKind::Absolute),
            1 => Ok(RowKind::Displacement),
            2 => Ok(RowKind::Unmeasured),
            other => Err(CdsmError::Option {
                name: "kind".into(),
                problem: format!("row kind must be 0, 1 or 2, got {other}"),
            }),
        }
    }
}

/// A data set's commands in execution order: `theta_cmd (N, n)` rad,
/// `dl (N, n)` m and each row's kind.
#[derive(Debug, Clone, Copy)]
pub struct Rows<'a> {
    pub theta_cmd: &'a [f64],
    pub dl: &'a [f64],
    pub kind: &'a [RowKind],
}

/// The command sequence of a data set, built once from the nominal model:
/// every command's nominal upper lengths and the row it belongs to.
#[derive(Debug, Clone)]
pub struct Sequence {
    n: usize,
    rows: usize,
    /// `(commands, n)` nominal commanded upper lengths (m).
    command: Vec<f64>,
    /// Row of each command.
    row: Vec<usize>,
    /// First and last command of each row.
    span: Vec<[usize; 2]>,
    kind: Vec<RowKind>,
    theta_cmd: Vec<f64>,
}

impl Sequence {
    pub fn new(robot: &Robot, data: &Rows) -> Result<Sequence> {
        let n = robot.n();
        let rows = rows_of("theta_cmd", data.theta_cmd, n)?;
        crate::batch::rows_exactly("dl", data.dl, n, rows)?;
        if data.kind.len() != rows {
            return Err(CdsmError::Shape {
                name: "kind".into(),
                expected: format!("({rows},)"),
                got: format!("({},)", data.kind.len()),
            });
        }
        let geom = CableGeometry::new(robot, None);
        let mut seq = Sequence {
            n,
            rows,
            command: Vec::with_capacity(2 * rows * n),
            row: Vec::with_capacity(2 * rows),
            span: Vec::with_capacity(rows),
            kind: data.kind.to_vec(),
            theta_cmd: data.theta_cmd.to_vec(),
        };
        let mut cs = vec![(1.0, 0.0); n];
        let mut c = vec![0.0; n];
        for i in 0..rows {
            for (x, t) in cs.iter_mut().zip(&data.theta_cmd[i * n..(i + 1) * n]) {
                let (s, co) = t.sin_cos();
                *x = (co, s);
            }
            geom.upper_lengths(&cs, &mut c);
            let first = seq.row.len();
            if data.kind[i] == RowKind::Displacement {
                seq.command.extend_from_slice(&c);
                seq.row.push(i);
            }
            for (ck, d) in c.iter().zip(&data.dl[i * n..(i + 1) * n]) {
                seq.command.push(ck + d);
            }
            seq.row.push(i);
            seq.span.push([first, seq.row.len() - 1]);
        }
        Ok(seq)
    }

    /// Number of commands.
    pub fn len(&self) -> usize {
        self.row.len()
    }

    pub fn is_empty(&self) -> bool {
        self.row.is_empty()
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }
}

/// The delivered length of one cable after the command `cmd` (m) from the
/// delivered length `state`, through a dead band of half-width `b`
/// (`docs/model.md`, "Backlash"): it follows the command at `b` behind,
/// and stays while the command is within the band.
#[inline]
pub fn dead_band<S: Real>(cmd: f64, state: S, b: S) -> S {
    let gap = cmd - state.val();
    if gap > b.val() {
        S::cst(cmd) - b
    } else if gap < -b.val() {
        S::cst(cmd) + b
    } else {
        state
    }
}

/// The realised rest lengths of every command (`(commands, n)`, m): the
/// backlash scan from the straight pose, then the actuators.
fn realised<S: Real>(seq: &Sequence, prm: &Params<S>, l_ref: &[f64]) -> Vec<S> {
    let n = seq.n;
    let mut state: Vec<S> = l_ref.iter().map(|v| S::cst(*v)).collect();
    let mut out = Vec::with_capacity(seq.command.len());
    for cmd in seq.command.chunks_exact(n) {
        for i in 0..n {
            state[i] = dead_band(cmd[i], state[i], prm.backlash[i]);
            let r = state[i];
            out.push((r - l_ref[i]) * (prm.scale + 1.0) + l_ref[i] + prm.offset[i]);
        }
    }
    out
}

/// Buffers of the plant's residual in one scalar.
struct Buffers<S> {
    cs: Vec<(S, S)>,
    shift: Vec<S>,
    lengths: Vec<S>,
    tension: Vec<S>,
    statics: TensionBuffers<S>,
}

impl<S: Real> Buffers<S> {
    fn new(n: usize) -> Self {
        let z = S::cst(0.0);
        Buffers {
            cs: vec![(z, z); n],
            shift: vec![z; n],
            lengths: vec![z; n],
            tension: vec![z; n],
            statics: TensionBuffers::new(n),
        }
    }
}

/// The settling residual `F_i = L_arm,i(theta) - (L_i + L_route)(1 + kappa T_i) + L_route`
/// (m) of the plant with parameters `prm` and arm `arm` at `theta`, realised
/// lengths `real`.
fn residual<S: Real>(
    robot: &Robot,
    arm: &Arm<S>,
    prm: &Params<S>,
    real: &[S],
    theta: &[S],
    buf: &mut Buffers<S>,
    out: &mut [S],
) {
    let n = robot.n();
    let z = S::cst(0.0);
    let clear = prm.clearance.val() != 0.0 || prm.clearance.is_variable();
    for ((cs, shift), t) in buf.cs.iter_mut().zip(buf.shift.iter_mut()).zip(theta) {
        let (s, c) = t.sin_cos();
        *cs = (c, s);
        *shift = if clear {
            prm.clearance * (*t / prm.width).tanh()
        } else {
            z
        };
    }
    for i in 0..n {
        let c = 2 * i;
        let mut len = z;
        for k in 0..=i {
            len += arm.segment(c, k, buf.shift[k]).length(buf.cs[k]);
            let next = if k < i { buf.shift[k + 1] } else { z };
            len += arm.traversal(c, k, buf.shift[k], next);
        }
        buf.lengths[i] = len;
    }
    let route = robot.cable.routing_length;
    let elastic = prm.kappa.val() != 0.0 || prm.kappa.is_variable();
    if elastic {
        let loads = Loads::of(robot);
        upper_tensions(
            arm,
            theta,
            &loads,
            &robot.mass,
            &mut buf.statics,
            &mut buf.tension,
        );
    }
    for i in 0..n {
        let stretch = if elastic {
            (real[i] + route) * prm.kappa * buf.tension[i]
        } else {
            z
        };
        out[i] = buf.lengths[i] - real[i] - stretch;
    }
}

/// What the instrument sees of the arm at `theta`: `[x, y, phi]`.
fn observe<S: Real>(arm: &Arm<S>, prm: &Params<S>, theta: &[S]) -> [S; 3] {
    let p = arm.fk(theta);
    let (s, c) = p[2].sin_cos();
    let [tx, ty] = prm.tip;
    let tip = [p[0] + c * tx - s * ty, p[1] + s * tx + c * ty];
    let (sa, ca) = prm.frame[0].sin_cos();
    [
        ca * tip[0] - sa * tip[1] + prm.frame[1],
        sa * tip[0] + ca * tip[1] + prm.frame[2],
        p[2] + prm.frame[0],
    ]
}

/// Directions carried by one forward-mode evaluation of the plant.
pub const JET: usize = 8;
type J = Jet<JET>;

/// The settle of one command as a problem of the shared solver: `F(theta) = 0`
/// with the Jacobian `dF/dtheta` in jets.
struct SettleProblem<'a, 'b> {
    plant: &'a Plant<'a>,
    real: &'a [f64],
    work: &'b mut JetWork,
}

impl Problem for SettleProblem<'_, '_> {
    fn dims(&self) -> (usize, usize) {
        (self.real.len(), self.real.len())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        let p = self.plant;
        residual(
            p.robot,
            &p.arm,
            &p.prm,
            self.real,
            x,
            &mut self.work.fbuf,
            r,
        );
        if let Some(j) = jac {
            let n = x.len();
            for (d, v) in self.work.real.iter_mut().zip(self.real) {
                *d = J::cst(*v);
            }
            for c in 0..n.div_ceil(JET) {
                for (l, d) in self.work.theta.iter_mut().enumerate() {
                    *d = J::seeded(x[l], l.wrapping_sub(c * JET));
                }
                let w = &mut *self.work;
                residual(
                    p.robot, &p.carm, &p.cprm, &w.real, &w.theta, &mut w.buf, &mut w.f,
                );
                for s in 0..JET.min(n - c * JET) {
                    for i in 0..n {
                        j[i * n + c * JET + s] = w.f[i].d[s];
                    }
                }
            }
        }
        r.iter().all(|v| v.is_finite())
    }
}

/// Buffers of the forward-mode evaluations at one command.
pub struct JetWork {
    fbuf: Buffers<f64>,
    buf: Buffers<J>,
    theta: Vec<J>,
    real: Vec<J>,
    f: Vec<J>,
    /// `(n, dirs)` residual and `(3, dirs)` observation derivatives.
    df: Vec<f64>,
    dobs: Vec<f64>,
    /// `(3, n)`: `O_theta F_theta^-1`.
    y: Vec<f64>,
    ft: Vec<f64>,
    rhs: Vec<f64>,
}

impl JetWork {
    fn new(n: usize) -> JetWork {
        JetWork {
            fbuf: Buffers::new(n),
            buf: Buffers::new(n),
            theta: vec![J::default(); n],
            real: vec![J::default(); n],
            f: vec![J::default(); n],
            df: Vec::new(),
            dobs: Vec::new(),
            y: vec![0.0; 3 * n],
            ft: vec![0.0; n * n],
            rhs: vec![0.0; n],
        }
    }
}

/// The inputs of one chunk of [`JET`] directions at one command: the
/// parameters and arm (seeded along the chunk's parameter directions) and the
/// realised lengths (seeded along the chunk's length directions).
struct Chunk<'a> {
    prm: &'a Params<J>,
    arm: &'a Arm<J>,
    real: &'a [J],
}

/// The derivatives of one settled command's observation along `dirs` input
/// directions by the implicit function theorem,
/// `dO/dx = O_x - O_theta F_theta^-1 F_x` (`out`: `(3, dirs)` row-major).
/// Direction `g` of the combined list `theta_0..theta_{n-1}, x_0..` sits in
/// slot `g % JET` of chunk `g / JET`. False where `F_theta` is singular.
fn implicit_derivatives<'c>(
    robot: &Robot,
    theta: &[f64],
    dirs: usize,
    chunk: impl Fn(usize) -> Chunk<'c>,
    w: &mut JetWork,
    out: &mut [f64],
) -> bool {
    let n = theta.len();
    let total = n + dirs;
    w.df.resize(n * total, 0.0);
    w.dobs.resize(3 * total, 0.0);
    for c in 0..total.div_ceil(JET) {
        let ch = chunk(c);
        for (l, d) in w.theta.iter_mut().enumerate() {
            *d = J::seeded(theta[l], l.wrapping_sub(c * JET));
        }
        residual(
            robot, ch.arm, ch.prm, ch.real, &w.theta, &mut w.buf, &mut w.f,
        );
        let o = observe(ch.arm, ch.prm, &w.theta);
        for s in 0..JET.min(total - c * JET) {
            let g = c * JET + s;
            for i in 0..n {
                w.df[i * total + g] = w.f[i].d[s];
            }
            for (k, ok) in o.iter().enumerate() {
                w.dobs[k * total + g] = ok.d[s];
            }
        }
    }
    // y_k solves F_theta^T y_k = O_theta[k]^T
    for i in 0..n {
        for l in 0..n {
            w.ft[l * n + i] = w.df[i * total + l];
        }
    }
    for k in 0..3 {
        w.rhs.copy_from_slice(&w.dobs[k * total..k * total + n]);
        let (rhs, y) = (&w.rhs, &mut w.y[k * n..(k + 1) * n]);
        if !solve_general(n, &w.ft, rhs, y) {
            return false;
        }
    }
    for k in 0..3 {
        for q in 0..dirs {
            let mut v = w.dobs[k * total + n + q];
            for i in 0..n {
                v -= w.y[k * n + i] * w.df[i * total + n + q];
            }
            out[k * dirs + q] = v;
        }
    }
    true
}

/// One plant (parameters `p`, flat), ready to settle and observe commands.
pub struct Plant<'a> {
    robot: &'a Robot,
    p: Vec<f64>,
    prm: Params<f64>,
    arm: Arm<f64>,
    /// The same parameters and arm as constants in jets (for `dF/dtheta`).
    cprm: Params<J>,
    carm: Arm<J>,
    /// The arm as a robot description (for the rigid closed form).
    arm_robot: Robot,
    geom: CableGeometry,
    l_ref: Vec<f64>,
    rigid: bool,
}

impl<'a> Plant<'a> {
    /// The plant of `robot` with the flat parameters `p` (see [`EFFECTS`]);
    /// an error when `p` has the wrong length or leaves the physical domain.
    pub fn new(robot: &'a Robot, p: &[f64]) -> Result<Plant<'a>> {
        let n = robot.n();
        let (_, total) = effect_offsets(n);
        if p.len() != total {
            return Err(CdsmError::Shape {
                name: "params".into(),
                expected: format!("({total},)"),
                got: format!("({},)", p.len()),
            });
        }
        crate::error::check_finite("params", p)?;
        if !physical(robot, p) {
            return Err(CdsmError::Option {
                name: "params".into(),
                problem:
                    "outside the physical domain (non-negative compliance, clearance and backlash, \
                          links and actuator gain above a tenth of nominal)"
                        .into(),
            });
        }
        let prm = Params::<f64>::unpack(n, p, |_, v| v);
        let arm = prm.arm(robot);
        let arm_robot = Robot {
            link_before: arm.link_before.clone(),
            link_after: arm.link_after.clone(),
            holes: arm.holes.clone(),
            ..robot.clone()
        };
        let geom = CableGeometry::new(&arm_robot, None);
        let mut l_ref = vec![0.0; n];
        CableGeometry::new(robot, None).upper_lengths(&vec![(1.0, 0.0); n], &mut l_ref);
        let rigid = prm.kappa == 0.0 && prm.clearance == 0.0;
        let cprm = Params::<J>::unpack(n, p, |_, v| J::cst(v));
        let carm = cprm.arm(robot);
        Ok(Plant {
            robot,
            p: p.to_vec(),
            prm,
            arm,
            cprm,
            carm,
            arm_robot,
            geom,
            l_ref,
            rigid,
        })
    }

    /// The plant's arm as a robot description (perturbed holes and links).
    pub fn arm(&self) -> &Robot {
        &self.arm_robot
    }

    /// The realised rest lengths of every command of `seq` (`(commands, n)`, m).
    pub fn realised(&self, seq: &Sequence) -> Vec<f64> {
        realised(seq, &self.prm, &self.l_ref)
    }

    /// The upper lengths the screws deliver and the actuators realise for
    /// one command `cmd` from the backlash state `state` (updated), m.
    pub fn realise_one(&self, cmd: &[f64], state: &mut [f64], out: &mut [f64]) {
        for i in 0..cmd.len() {
            state[i] = dead_band(cmd[i], state[i], self.prm.backlash[i]);
        }
        self.actuate(state, out);
    }

    /// The realised rest lengths (m) for the delivered lengths `delivered`
    /// (m): `L_ref + (1 + s)(delivered - L_ref) + o`.
    pub fn actuate(&self, delivered: &[f64], out: &mut [f64]) {
        for i in 0..delivered.len() {
            out[i] = self.l_ref[i]
                + (1.0 + self.prm.scale) * (delivered[i] - self.l_ref[i])
                + self.prm.offset[i];
        }
    }

    /// The straight-pose upper lengths of the nominal robot (the backlash
    /// state at the start and the actuators' pivot), m.
    pub fn reference_lengths(&self) -> &[f64] {
        &self.l_ref
    }

    /// The backlash half-widths (m).
    pub fn backlash(&self) -> &[f64] {
        &self.prm.backlash
    }

    /// Settles the arm for realised lengths `real` (m); `theta` holds the seed
    /// on entry (the commanded configuration) and the answer on exit.
    /// `work` must have been made for this plant ([`SettleWork::new`]).
    pub fn settle(&self, real: &[f64], theta: &mut [f64], work: &mut SettleWork) -> bool {
        work.start.copy_from_slice(theta);
        let ok = work.rigid.solve(&self.geom, real, theta).converged;
        if self.rigid {
            return ok;
        }
        if !ok {
            theta.copy_from_slice(&work.start);
        }
        let mut prob = SettleProblem {
            plant: self,
            real,
            work: &mut work.jet,
        };
        // cable i crosses joints 1..i: without stretch (whose tensions couple
        // every joint) dF/dtheta is lower triangular; Newton first, damped on failure
        let step = if self.prm.kappa == 0.0 {
            Step::Triangular
        } else {
            Step::Normal
        };
        let lm = Lm {
            lambda0: 0.0,
            ..Lm::equations(step, work.opts.tol, work.opts.max_iter)
        };
        lm::solve(&mut prob, theta, &lm, &mut work.ws).converged
    }

    /// What the instrument sees at the settled `theta` for realised lengths
    /// `real`, and its derivative with respect to `real` (`jac`, `(3, n)`
    /// row-major, 1) by the implicit function theorem. False where `dF/dtheta`
    /// is singular.
    pub fn observe_linear(
        &self,
        real: &[f64],
        theta: &[f64],
        jac: &mut [f64],
        work: &mut SettleWork,
    ) -> bool {
        let n = theta.len();
        // directions: theta (n), then each realised length (n)
        let reals: Vec<Vec<J>> = (0..(2 * n).div_ceil(JET))
            .map(|c| {
                (0..n)
                    .map(|i| J::seeded(real[i], (n + i).wrapping_sub(c * JET)))
                    .collect()
            })
            .collect();
        implicit_derivatives(
            self.robot,
            theta,
            n,
            |c| Chunk {
                prm: &self.cprm,
                arm: &self.carm,
                real: &reals[c],
            },
            &mut work.jet,
            jac,
        )
    }

    /// The actuators' gain `1 + s` (realised length per delivered length).
    pub fn gain(&self) -> f64 {
        1.0 + self.prm.scale
    }

    /// What the instrument sees at `theta`: `[x, y, phi]`.
    pub fn observe(&self, theta: &[f64]) -> [f64; 3] {
        observe(&self.arm, &self.prm, theta)
    }

    /// The nominal robot the controller believes in.
    pub fn nominal(&self) -> &Robot {
        self.robot
    }
}

/// Per-thread buffers of the settles of one plant.
pub struct SettleWork<'a> {
    opts: SolveOptions,
    rigid: CableSolver<'a>,
    start: Vec<f64>,
    jet: JetWork,
    ws: Workspace,
}

impl<'a> SettleWork<'a> {
    pub fn new(plant: &'a Plant, opts: SolveOptions) -> Self {
        let n = plant.robot.n();
        SettleWork {
            opts,
            rigid: CableSolver::new(&plant.arm_robot, CableMethod::Auto, opts),
            start: vec![0.0; n],
            jet: JetWork::new(n),
            ws: Workspace::default(),
        }
    }
}

/// Predictions of `K` plants for one data set: observations `(K, N, 3)` (NaN
/// for unmeasured rows and rows that did not settle), converged `(K, N)`, and
/// the configuration each row's last command settles at `(K, N, n)` (rad).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Predictions {
    pub observation: Vec<f64>,
    pub converged: Vec<bool>,
    pub theta: Vec<f64>,
}

/// The settled configurations and observations of every command of `seq`
/// for one plant (in parallel over the commands).
fn settle_all(
    plant: &Plant,
    seq: &Sequence,
    opts: &SolveOptions,
    threads: usize,
) -> (Vec<f64>, Vec<[f64; 3]>, Vec<bool>) {
    let n = seq.n;
    let real = plant.realised(seq);
    let parts = split_rows(seq.len(), threads, |range| {
        let mut work = SettleWork::new(plant, *opts);
        let mut th = vec![0.0; n];
        let mut out = (
            Vec::with_capacity(range.len() * n),
            Vec::with_capacity(range.len()),
            Vec::with_capacity(range.len()),
        );
        for j in range {
            let row = seq.row[j];
            th.copy_from_slice(&seq.theta_cmd[row * n..(row + 1) * n]);
            let ok = plant.settle(&real[j * n..(j + 1) * n], &mut th, &mut work);
            out.0.extend_from_slice(&th);
            out.1.push(if ok {
                plant.observe(&th)
            } else {
                [f64::NAN; 3]
            });
            out.2.push(ok);
        }
        out
    });
    let mut theta = Vec::with_capacity(seq.len() * n);
    let mut obs = Vec::with_capacity(seq.len());
    let mut ok = Vec::with_capacity(seq.len());
    for (t, o, c) in parts {
        theta.extend(t);
        obs.extend(o);
        ok.extend(c);
    }
    (theta, obs, ok)
}

/// Row observations from command observations.
fn rows_from_commands(
    seq: &Sequence,
    theta: &[f64],
    obs: &[[f64; 3]],
    ok: &[bool],
    out: &mut Predictions,
) {
    let n = seq.n;
    for (i, [a, b]) in seq.span.iter().enumerate() {
        let conv = ok[*a] && ok[*b];
        let o = match seq.kind[i] {
            RowKind::Absolute => obs[*b],
            RowKind::Displacement => [
                obs[*b][0] - obs[*a][0],
                obs[*b][1] - obs[*a][1],
                obs[*b][2] - obs[*a][2],
            ],
            RowKind::Unmeasured => [f64::NAN; 3],
        };
        out.observation
            .extend_from_slice(&if conv { o } else { [f64::NAN; 3] });
        out.converged.push(conv);
        out.theta.extend(
            theta[b * n..(b + 1) * n]
                .iter()
                .map(|t| if conv { *t } else { f64::NAN }),
        );
    }
}

/// Predictions of `K` parameter sets (`params (K, P)`) for the data set
/// `rows`; see [`Predictions`]. A parameter set outside the physical domain
/// predicts no row (all not converged).
pub fn predict(
    robot: &Robot,
    params: &[f64],
    rows: &Rows,
    opts: &SolveOptions,
    threads: usize,
) -> Result<Predictions> {
    let n = robot.n();
    let (_, total) = effect_offsets(n);
    let k = rows_of("params", params, total)?;
    let seq = Sequence::new(robot, rows)?;
    let mut out = Predictions::default();
    for j in 0..k {
        let p = &params[j * total..(j + 1) * total];
        match Plant::new(robot, p) {
            Ok(plant) => {
                let (theta, obs, ok) = settle_all(&plant, &seq, opts, threads);
                rows_from_commands(&seq, &theta, &obs, &ok, &mut out);
            }
            Err(CdsmError::Option { .. }) => {
                out.observation
                    .extend(std::iter::repeat_n(f64::NAN, 3 * seq.rows()));
                out.converged.extend(std::iter::repeat_n(false, seq.rows()));
                out.theta
                    .extend(std::iter::repeat_n(f64::NAN, n * seq.rows()));
            }
            Err(e) => return Err(e),
        }
    }
    Ok(out)
}

/// Predictions of one plant and their Jacobian with respect to the
/// parameters `free` (indices into the flat vector): `jacobian (N, 3, k)`
/// (NaN rows where a command did not settle or its Jacobian is singular).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Linearised {
    pub predictions: Predictions,
    pub jacobian: Vec<f64>,
}

/// The derivatives `(commands, 3, k)` of every command's observation with
/// respect to the parameters `free`, by the implicit function theorem at the
/// settled `theta` (NaN where a command did not settle).
fn command_derivatives(
    plant: &Plant,
    seq: &Sequence,
    theta: &[f64],
    ok: &[bool],
    free: &[usize],
    threads: usize,
) -> Vec<f64> {
    let n = seq.n;
    let robot = plant.robot;
    let kf = free.len();
    // chunk c carries directions c*JET.. of theta_0..theta_{n-1}, free_0..free_{k-1}
    let chunks: Vec<(Params<J>, Arm<J>, Vec<J>)> = (0..(n + kf).div_ceil(JET))
        .map(|c| {
            let prm = Params::<J>::unpack(n, &plant.p, |i, v| {
                let mut d = [0.0; JET];
                for (s, x) in d.iter_mut().enumerate() {
                    let g = c * JET + s;
                    if g >= n && g < n + kf && free[g - n] == i {
                        *x = 1.0;
                    }
                }
                J::with(v, d)
            });
            let arm = prm.arm(robot);
            let real = realised(seq, &prm, &plant.l_ref);
            (prm, arm, real)
        })
        .collect();
    let parts = split_rows(seq.len(), threads, |range| {
        let mut out = vec![f64::NAN; range.len() * 3 * kf];
        let mut w = JetWork::new(n);
        for (local, j) in range.enumerate() {
            if !ok[j] {
                continue;
            }
            let t0 = &theta[j * n..(j + 1) * n];
            let dst = &mut out[local * 3 * kf..(local + 1) * 3 * kf];
            let done = implicit_derivatives(
                robot,
                t0,
                kf,
                |c| Chunk {
                    prm: &chunks[c].0,
                    arm: &chunks[c].1,
                    real: &chunks[c].2[j * n..(j + 1) * n],
                },
                &mut w,
                dst,
            );
            if !done {
                dst.fill(f64::NAN);
            }
        }
        out
    });
    parts.concat()
}

/// [`Linearised`] predictions of the plant `p` (flat) for the data set `rows`.
pub fn linearise(
    robot: &Robot,
    p: &[f64],
    free: &[usize],
    rows: &Rows,
    opts: &SolveOptions,
    threads: usize,
) -> Result<Linearised> {
    let seq = Sequence::new(robot, rows)?;
    let plant = Plant::new(robot, p)?;
    let settled = Settled::new(&plant, &seq, opts, threads);
    let predictions = settled.predictions(&seq);
    let jacobian = settled.jacobian(&plant, &seq, free, threads)?;
    Ok(Linearised {
        predictions,
        jacobian,
    })
}

/// Every command of a data set settled by one plant: the configurations,
/// observations and flags (the state a fit keeps between a trial and its
/// Jacobian).
#[derive(Debug, Clone, Default)]
pub struct Settled {
    theta: Vec<f64>,
    obs: Vec<[f64; 3]>,
    ok: Vec<bool>,
}

impl Settled {
    /// Settles every command of `seq` for `plant` (threads over the commands).
    pub fn new(plant: &Plant, seq: &Sequence, opts: &SolveOptions, threads: usize) -> Settled {
        let (theta, obs, ok) = settle_all(plant, seq, opts, threads);
        Settled { theta, obs, ok }
    }

    /// The rows' predictions.
    pub fn predictions(&self, seq: &Sequence) -> Predictions {
        let mut out = Predictions::default();
        rows_from_commands(seq, &self.theta, &self.obs, &self.ok, &mut out);
        out
    }

    /// `(N, 3, k)` derivatives of the rows' observations with respect to the
    /// parameters `free` (NaN rows where not defined); `plant` must be the one
    /// that settled.
    pub fn jacobian(
        &self,
        plant: &Plant,
        seq: &Sequence,
        free: &[usize],
        threads: usize,
    ) -> Result<Vec<f64>> {
        let total = plant.p.len();
        if let Some(f) = free.iter().find(|f| **f >= total) {
            return Err(CdsmError::Option {
                name: "free".into(),
                problem: format!("parameter index {f} is beyond the {total} parameters"),
            });
        }
        let kf = free.len();
        let dcmd = command_derivatives(plant, seq, &self.theta, &self.ok, free, threads);
        let mut jac = vec![f64::NAN; seq.rows() * 3 * kf];
        for (i, [a, b]) in seq.span.iter().enumerate() {
            if !(self.ok[*a] && self.ok[*b]) || seq.kind[i] == RowKind::Unmeasured {
                continue;
            }
            for c in 0..3 {
                for q in 0..kf {
                    let vb = dcmd[(b * 3 + c) * kf + q];
                    jac[(i * 3 + c) * kf + q] = match seq.kind[i] {
                        RowKind::Displacement => vb - dcmd[(a * 3 + c) * kf + q],
                        _ => vb,
                    };
                }
            }
        }
        Ok(jac)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn zeros(r: &Robot) -> Vec<f64> {
        vec![0.0; effect_offsets(r.n()).1]
    }

    fn rows(th: &[f64], dl: &[f64], kind: &[RowKind]) -> (Vec<f64>, Vec<f64>, Vec<RowKind>) {
        (th.to_vec(), dl.to_vec(), kind.to_vec())
    }

    #[test]
    fn zero_parameters_are_the_nominal_model() {
        let r = Robot::paper();
        let (th, dl, kind) = rows(
            &[0.2, -0.3, 0.25, -0.1, 0.0, 0.3],
            &[-1e-3, 0.0, 0.0, 0.0, 5e-4, 0.0],
            &[RowKind::Absolute, RowKind::Absolute],
        );
        let o = SolveOptions::default();
        let data = Rows {
            theta_cmd: &th,
            dl: &dl,
            kind: &kind,
        };
        let pr = predict(&r, &zeros(&r), &data, &o, 1).unwrap();
        assert!(pr.converged.iter().all(|x| *x));
        let (dev, _) =
            crate::accuracy::deviation(&r, &th[..3], &dl[..3], None, CableMethod::Auto, &o, 1)
                .unwrap();
        let p0 = r.fk(&th[..3]);
        for q in 0..3 {
            assert!((pr.observation[q] - (p0[q] + dev[q])).abs() < 1e-12);
        }
    }

    #[test]
    fn dual_jacobian_matches_central_differences_of_the_predictions() {
        // every effect at once, on absolute and displacement rows, with backlash
        let r = Robot::paper();
        let (off, total) = effect_offsets(3);
        let mut p = zeros(&r);
        p[off[0]] = 0.01;
        p[off[1] + 1] = 1e-4;
        p[off[2]] = 2e-4;
        p[off[3] + 2] = -3e-4;
        p[off[4]] = 0.02;
        p[off[5]] = 1e-4;
        p[off[6]] = 3e-3;
        p[off[7]] = 5e-4;
        p[off[8]] = 4e-5;
        p[off[8] + 2] = 2e-5;
        p[off[9]] = 0.005;
        let (th, dl, kind) = rows(
            &[0.2, -0.3, 0.25, -0.1, 0.15, 0.3, 0.05, 0.2, -0.2],
            &[-1e-3, 0.0, 0.0, 0.0, 5e-4, 0.0, 0.0, 0.0, 1e-3],
            &[RowKind::Absolute, RowKind::Displacement, RowKind::Absolute],
        );
        let data = Rows {
            theta_cmd: &th,
            dl: &dl,
            kind: &kind,
        };
        let o = SolveOptions::default();
        let free: Vec<usize> = (0..total).collect();
        let lin = linearise(&r, &p, &free, &data, &o, 1).unwrap();
        let h = 1e-7;
        let (lo, _) = bounds(&r);
        for (q, &f) in free.iter().enumerate() {
            let step = h * (1.0 + p[f].abs() * 100.0);
            let (mut a, mut b) = (p.clone(), p.clone());
            a[f] += step;
            // one-sided at a lower bound (backlash at 0)
            let central = p[f] - step >= lo[f];
            if central {
                b[f] -= step;
            }
            let div = if central { 2.0 * step } else { step };
            let pa = predict(&r, &a, &data, &o, 1).unwrap();
            let pb = predict(&r, &b, &data, &o, 1).unwrap();
            for i in 0..3 {
                for c in 0..3 {
                    let fd = (pa.observation[i * 3 + c] - pb.observation[i * 3 + c]) / div;
                    let an = lin.jacobian[(i * 3 + c) * total + q];
                    assert!(
                        (fd - an).abs() < 1e-5 * (1.0 + an.abs()),
                        "param {f} row {i} comp {c}: fd {fd} vs dual {an}"
                    );
                }
            }
        }
    }

    #[test]
    fn frame_translation_cancels_in_displacements() {
        let r = Robot::paper();
        let (off, _) = effect_offsets(3);
        let mut p = zeros(&r);
        p[off[6] + 1] = 0.01;
        p[off[6] + 2] = -0.02;
        let (th, dl, kind) = rows(
            &[0.2, -0.3, 0.25],
            &[-1e-3, 0.0, 0.0],
            &[RowKind::Displacement],
        );
        let data = Rows {
            theta_cmd: &th,
            dl: &dl,
            kind: &kind,
        };
        let o = SolveOptions::default();
        let a = predict(&r, &zeros(&r), &data, &o, 1).unwrap().observation;
        let b = predict(&r, &p, &data, &o, 1).unwrap().observation;
        for q in 0..3 {
            assert!((a[q] - b[q]).abs() < 1e-15);
        }
    }

    #[test]
    fn a_reversal_loses_the_whole_dead_band() {
        // cable 1 commanded +1 mm then back: the second move delivers 2b less
        let r = Robot::paper();
        let (off, _) = effect_offsets(3);
        let mut p = zeros(&r);
        p[off[8]] = 3e-5;
        let plant = Plant::new(&r, &p).unwrap();
        let l_ref = plant.reference_lengths().to_vec();
        let mut state = l_ref.clone();
        let mut out = [0.0; 3];
        let up = [l_ref[0] + 1e-3, l_ref[1], l_ref[2]];
        plant.realise_one(&up, &mut state, &mut out);
        assert!((out[0] - (up[0] - 3e-5)).abs() < 1e-15);
        plant.realise_one(&l_ref, &mut state, &mut out);
        assert!((out[0] - (l_ref[0] + 3e-5)).abs() < 1e-15);
    }

    #[test]
    fn a_non_physical_plant_predicts_no_row() {
        let r = Robot::paper();
        let (off, _) = effect_offsets(3);
        let mut p = zeros(&r);
        p[off[3] + 1] = -1.0; // a negative link
        let (th, dl, kind) = rows(&[0.2, -0.3, 0.25], &[0.0; 3], &[RowKind::Absolute]);
        let data = Rows {
            theta_cmd: &th,
            dl: &dl,
            kind: &kind,
        };
        let pr = predict(&r, &p, &data, &SolveOptions::default(), 1).unwrap();
        assert!(!pr.converged[0] && pr.observation[0].is_nan());
    }
}
