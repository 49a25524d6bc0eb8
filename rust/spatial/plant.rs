//! The real spatial arm as the nominal model plus unmodelled effects
//! (`docs/spatial.md`, "The plant"): commands in sequence through backlash
//! and the actuators, an arm with moved holes and link offsets whose cables
//! stretch, seen by an instrument through a tip offset and a frame. All-zero
//! parameters give the nominal model exactly. The Jacobian of the
//! predictions is by central differences of warm-started settles. SI units.

use super::kinematics::{cable_length, log_of, rotation_of, Chain};
use super::robot::SpatialRobot;
use super::solve::SpatialCableSolver;
use super::statics::position_tensions;
use crate::batch::{rows_exactly, rows_of, split_rows};
use crate::error::{CdsmError, Result};
use crate::fit::FitModel;
use crate::lm::{self, Lm, Problem, Step, Workspace};
use crate::plant::{dead_band, Predictions, RowKind};
use crate::solve::SolveOptions;
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// The effects of a spatial plant, in the order of the parameter vector.
pub const EFFECTS: [&str; 8] = [
    "actuation_scale",
    "cable_offset",
    "hole_position",
    "link_length",
    "cable_elasticity",
    "frame_misalignment",
    "tip_offset",
    "backlash",
];

/// Observed components of a spatial row: x, y, z (m), rotation vector (rad).
pub const WIDTH: usize = 6;

/// Number of parameters of each effect: 1, m_pos, 3 per hole of the
/// position-controlled cables, 3 per joint offset and per disk's
/// `link_after`, 1, 6, 3, m_pos.
pub fn effect_sizes(robot: &SpatialRobot) -> [usize; 8] {
    let pos = robot.position_cables();
    let holes: usize = pos.iter().map(|c| robot.cables[*c].holes.len()).sum();
    let m = pos.len();
    [
        1,
        m,
        3 * holes,
        3 * (robot.n() + robot.disks.len()),
        1,
        6,
        3,
        m,
    ]
}

/// Offset of each effect's parameters in the flat vector, and the total.
pub fn effect_offsets(robot: &SpatialRobot) -> ([usize; 8], usize) {
    let mut off = [0; 8];
    let mut total = 0;
    for (o, s) in off.iter_mut().zip(effect_sizes(robot)) {
        *o = total;
        total += s;
    }
    (off, total)
}

/// The physical domain: actuator gain above a tenth of nominal,
/// non-negative compliance and backlash.
pub fn bounds(robot: &SpatialRobot) -> (Vec<f64>, Vec<f64>) {
    let (off, total) = effect_offsets(robot);
    let mut lo = vec![f64::NEG_INFINITY; total];
    let hi = vec![f64::INFINITY; total];
    lo[off[0]] = -0.9;
    lo[off[4]] = 0.0;
    for v in &mut lo[off[7]..total] {
        *v = 0.0;
    }
    (lo, hi)
}

/// A data set's commands in execution order, built from the nominal model.
#[derive(Debug, Clone)]
pub struct SpatialSequence {
    rows: usize,
    /// Nominal position-cable lengths of every command `(commands, m_pos)`.
    command: Vec<f64>,
    /// Row of each command and the commanded configuration (the settle's seed).
    row: Vec<usize>,
    span: Vec<[usize; 2]>,
    kind: Vec<RowKind>,
    theta_cmd: Vec<f64>,
}

impl SpatialSequence {
    /// `theta_cmd (N, n)` rad, `dl (N, m_pos)` m, a kind per row.
    pub fn new(
        robot: &SpatialRobot,
        theta_cmd: &[f64],
        dl: &[f64],
        kind: &[RowKind],
    ) -> Result<Self> {
        let n = robot.n();
        let pos = robot.position_cables();
        let m = pos.len();
        let rows = rows_of("theta_cmd", theta_cmd, n)?;
        rows_exactly("dl", dl, m, rows)?;
        if kind.len() != rows {
            return Err(CdsmError::Shape {
                name: "kind".into(),
                expected: format!("({rows},)"),
                got: format!("({},)", kind.len()),
            });
        }
        let mut chain = Chain::new(robot);
        let mut pts = Vec::new();
        let mut s = SpatialSequence {
            rows,
            command: Vec::new(),
            row: Vec::new(),
            span: Vec::new(),
            kind: kind.to_vec(),
            theta_cmd: theta_cmd.to_vec(),
        };
        for i in 0..rows {
            chain.at(robot, &theta_cmd[i * n..(i + 1) * n]);
            let l: Vec<f64> = pos
                .iter()
                .map(|c| cable_length(robot, &chain, *c, &mut pts, None))
                .collect();
            let first = s.row.len();
            if kind[i] == RowKind::Displacement {
                s.command.extend_from_slice(&l);
                s.row.push(i);
            }
            s.command
                .extend(l.iter().zip(&dl[i * m..(i + 1) * m]).map(|(a, b)| a + b));
            s.row.push(i);
            s.span.push([first, s.row.len() - 1]);
        }
        Ok(s)
    }

    pub fn rows(&self) -> usize {
        self.rows
    }
}

/// One spatial plant (parameters `p`, flat), ready to settle and observe.
pub struct SpatialPlant<'a> {
    nominal: &'a SpatialRobot,
    /// The perturbed arm (holes, links).
    arm: SpatialRobot,
    p: Vec<f64>,
    off: [usize; 8],
    l_ref: Vec<f64>,
    /// Position-controlled cables.
    pos: Vec<usize>,
}

impl<'a> SpatialPlant<'a> {
    /// The plant of `robot` with the flat parameters `p`; an error when `p`
    /// has the wrong length or leaves the physical domain.
    pub fn new(robot: &'a SpatialRobot, p: &[f64]) -> Result<SpatialPlant<'a>> {
        let (off, total) = effect_offsets(robot);
        if p.len() != total {
            return Err(CdsmError::Shape {
                name: "params".into(),
                expected: format!("({total},)"),
                got: format!("({},)", p.len()),
            });
        }
        crate::error::check_finite("params", p)?;
        let (lo, hi) = bounds(robot);
        if p.iter()
            .zip(lo.iter().zip(&hi))
            .any(|(v, (l, h))| *v < *l || *v > *h)
        {
            return Err(CdsmError::Option {
                name: "params".into(),
                problem: "outside the physical domain (actuator gain above a tenth, non-negative compliance and \
                          backlash)"
                    .into(),
            });
        }
        let pos = robot.position_cables();
        let mut arm = robot.clone();
        let mut k = off[2];
        for &c in &pos {
            for h in arm.cables[c].holes.iter_mut() {
                for v in h.iter_mut() {
                    *v += p[k];
                    k += 1;
                }
            }
        }
        let mut k = off[3];
        for j in arm.joints.iter_mut() {
            for v in j.offset.iter_mut() {
                *v += p[k];
                k += 1;
            }
        }
        for d in arm.disks.iter_mut() {
            for v in d.link_after.iter_mut() {
                *v += p[k];
                k += 1;
            }
        }
        let mut chain = Chain::new(robot);
        chain.at(robot, &vec![0.0; robot.n()]);
        let mut pts = Vec::new();
        let l_ref = pos
            .iter()
            .map(|c| cable_length(robot, &chain, *c, &mut pts, None))
            .collect();
        Ok(SpatialPlant {
            nominal: robot,
            arm,
            p: p.to_vec(),
            off,
            l_ref,
            pos,
        })
    }

    /// The realised rest lengths of every command of `seq` (`(commands, m_pos)`):
    /// the backlash scan from the straight pose, then the actuators.
    pub fn realised(&self, seq: &SpatialSequence) -> Vec<f64> {
        let m = self.pos.len();
        let b = self.backlash();
        let mut state = self.l_ref.clone();
        let mut out = Vec::with_capacity(seq.command.len());
        for cmd in seq.command.chunks_exact(m) {
            for i in 0..m {
                state[i] = dead_band(cmd[i], state[i], b[i]);
            }
            self.actuate(&state, &mut out);
        }
        out
    }

    /// Appends the realised rest lengths of the delivered lengths
    /// `delivered` (m): `L_ref + (1 + s)(delivered - L_ref) + o`.
    pub fn actuate(&self, delivered: &[f64], out: &mut Vec<f64>) {
        let m = self.pos.len();
        let (s, o) = (self.p[self.off[0]], &self.p[self.off[1]..self.off[1] + m]);
        for i in 0..m {
            out.push(self.l_ref[i] + (1.0 + s) * (delivered[i] - self.l_ref[i]) + o[i]);
        }
    }

    /// The backlash half-widths of the position cables (m).
    pub fn backlash(&self) -> &[f64] {
        let m = self.pos.len();
        &self.p[self.off[7]..self.off[7] + m]
    }

    /// The straight-pose lengths (the backlash state at the start), m.
    pub fn reference_lengths(&self) -> &[f64] {
        &self.l_ref
    }

    /// Settles the arm for realised lengths `real` (m); `theta` holds the seed
    /// on entry and the answer on exit.
    pub fn settle(&self, real: &[f64], theta: &mut [f64], work: &mut SettleWork) -> bool {
        let kappa = self.p[self.off[4]];
        let st = work.rigid.solve(&self.arm, real, theta);
        if kappa == 0.0 {
            return st.converged;
        }
        let route = self.nominal.cable.routing_length;
        let mut prob = ElasticProblem {
            plant: self,
            real,
            kappa,
            route,
            chain: Chain::new(&self.arm),
            pts: Vec::new(),
        };
        let lm = Lm {
            lambda0: 0.0,
            ..Lm::equations(Step::Normal, work.opts.tol, work.opts.max_iter)
        };
        lm::solve(&mut prob, theta, &lm, &mut work.ws).converged
    }

    /// What the instrument sees at `theta`: `[x, y, z, rx, ry, rz]`.
    pub fn observe(&self, theta: &[f64], chain: &mut Chain) -> [f64; 6] {
        chain.at(&self.arm, theta);
        let end = *chain.end();
        let t = &self.p[self.off[6]..self.off[6] + 3];
        let tip = end.p + end.r * V3::new(t[0], t[1], t[2]);
        let f = &self.p[self.off[5]..self.off[5] + 6];
        let rf = rotation_of(&[f[0], f[1], f[2]]);
        let q = rf * tip + V3::new(f[3], f[4], f[5]);
        let r = log_of(&(rf * end.r));
        [q[0], q[1], q[2], r[0], r[1], r[2]]
    }
}

/// The elastic settle: position cables stretched by their statics tension.
struct ElasticProblem<'a> {
    plant: &'a SpatialPlant<'a>,
    real: &'a [f64],
    kappa: f64,
    route: f64,
    chain: Chain,
    pts: Vec<V3>,
}

impl Problem for ElasticProblem<'_> {
    fn dims(&self) -> (usize, usize) {
        (self.real.len(), self.plant.arm.n())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], mut jac: Option<&mut [f64]>) -> bool {
        let arm = &self.plant.arm;
        let n = x.len();
        self.chain.at(arm, x);
        let Some(t) = position_tensions(arm, &self.chain, &[0.0; 6], 0.0) else {
            return false;
        };
        for (i, &c) in self.plant.pos.iter().enumerate() {
            let row = jac.as_deref_mut().map(|j| &mut j[i * n..(i + 1) * n]);
            let l = cable_length(arm, &self.chain, c, &mut self.pts, row);
            r[i] = l - ((self.real[i] + self.route) * (1.0 + self.kappa * t[i]) - self.route);
        }
        r.iter().all(|v| v.is_finite())
    }
}

/// Per-thread buffers of the settles of one plant.
pub struct SettleWork {
    opts: SolveOptions,
    rigid: SpatialCableSolver,
    ws: Workspace,
    chain: Chain,
}

impl SettleWork {
    pub fn new(robot: &SpatialRobot, opts: SolveOptions) -> Self {
        SettleWork {
            opts,
            rigid: SpatialCableSolver::new(robot, opts),
            ws: Workspace::default(),
            chain: Chain::new(robot),
        }
    }
}

/// Every command settled: configurations, observations and flags.
#[derive(Debug, Clone, Default)]
pub struct SpatialSettled {
    theta: Vec<f64>,
    obs: Vec<[f64; 6]>,
    ok: Vec<bool>,
}

fn settle_all(
    plant: &SpatialPlant,
    seq: &SpatialSequence,
    seeds: Option<&[f64]>,
    opts: &SolveOptions,
    threads: usize,
) -> SpatialSettled {
    let n = plant.nominal.n();
    let m = plant.pos.len();
    let real = plant.realised(seq);
    let parts = split_rows(seq.row.len(), threads, |range| {
        let mut work = SettleWork::new(plant.nominal, *opts);
        let mut out = SpatialSettled::default();
        let mut th = vec![0.0; n];
        for j in range {
            match seeds {
                Some(s) => th.copy_from_slice(&s[j * n..(j + 1) * n]),
                None => {
                    let row = seq.row[j];
                    th.copy_from_slice(&seq.theta_cmd[row * n..(row + 1) * n]);
                }
            }
            let ok = plant.settle(&real[j * m..(j + 1) * m], &mut th, &mut work);
            out.theta.extend_from_slice(&th);
            out.obs.push(if ok {
                plant.observe(&th, &mut work.chain)
            } else {
                [f64::NAN; 6]
            });
            out.ok.push(ok);
        }
        out
    });
    let mut all = SpatialSettled::default();
    for p in parts {
        all.theta.extend(p.theta);
        all.obs.extend(p.obs);
        all.ok.extend(p.ok);
    }
    all
}

fn rows_of_commands(seq: &SpatialSequence, s: &SpatialSettled, n: usize) -> Predictions {
    let mut out = Predictions::default();
    for (i, [a, b]) in seq.span.iter().enumerate() {
        let conv = s.ok[*a] && s.ok[*b];
        let o = match seq.kind[i] {
            RowKind::Absolute => s.obs[*b],
            RowKind::Displacement => std::array::from_fn(|c| s.obs[*b][c] - s.obs[*a][c]),
            RowKind::Unmeasured => [f64::NAN; 6],
        };
        out.observation
            .extend_from_slice(&if conv { o } else { [f64::NAN; 6] });
        out.converged.push(conv);
        out.theta.extend(
            s.theta[b * n..(b + 1) * n]
                .iter()
                .map(|t| if conv { *t } else { f64::NAN }),
        );
    }
    out
}

/// Predictions of `K` parameter sets (`params (K, P)`) for a data set: see
/// [`Predictions`] (observation width 6). A parameter set outside the
/// physical domain predicts no row.
pub fn predict(
    robot: &SpatialRobot,
    params: &[f64],
    seq: &SpatialSequence,
    opts: &SolveOptions,
    threads: usize,
) -> Result<Predictions> {
    let (_, total) = effect_offsets(robot);
    let k = rows_of("params", params, total)?;
    let n = robot.n();
    let mut out = Predictions::default();
    for j in 0..k {
        match SpatialPlant::new(robot, &params[j * total..(j + 1) * total]) {
            Ok(plant) => {
                let s = settle_all(&plant, seq, None, opts, threads);
                let p = rows_of_commands(seq, &s, n);
                out.observation.extend(p.observation);
                out.converged.extend(p.converged);
                out.theta.extend(p.theta);
            }
            Err(CdsmError::Option { .. }) => {
                out.observation
                    .extend(std::iter::repeat_n(f64::NAN, WIDTH * seq.rows));
                out.converged.extend(std::iter::repeat_n(false, seq.rows));
                out.theta
                    .extend(std::iter::repeat_n(f64::NAN, n * seq.rows));
            }
            Err(e) => return Err(e),
        }
    }
    Ok(out)
}

/// The spatial plant on one data set, for the diagnosis fit.
pub struct SpatialFit<'a> {
    pub robot: &'a SpatialRobot,
    pub seq: &'a SpatialSequence,
    pub opts: SolveOptions,
    /// Step of the central differences, per parameter (its typical size
    /// times 1e-4).
    pub steps: Vec<f64>,
}

impl FitModel for SpatialFit<'_> {
    type State = SpatialSettled;

    fn rows(&self) -> usize {
        self.seq.rows
    }

    fn width(&self) -> usize {
        WIDTH
    }

    fn weights(&self) -> Vec<f64> {
        let l = self.robot.straight_length();
        vec![1.0, 1.0, 1.0, l, l, l]
    }

    fn params(&self) -> usize {
        effect_offsets(self.robot).1
    }

    fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
        bounds(self.robot)
    }

    fn settle(&self, p: &[f64]) -> Option<SpatialSettled> {
        let plant = SpatialPlant::new(self.robot, p).ok()?;
        Some(settle_all(&plant, self.seq, None, &self.opts, 1))
    }

    fn predictions(&self, state: &SpatialSettled) -> Predictions {
        rows_of_commands(self.seq, state, self.robot.n())
    }

    fn jacobian(&self, p: &[f64], state: &SpatialSettled, free: &[usize]) -> Option<Vec<f64>> {
        let rows = self.seq.rows;
        let k = free.len();
        let n = self.robot.n();
        let mut jac = vec![f64::NAN; rows * WIDTH * k];
        let (lo, hi) = bounds(self.robot);
        for (q, &f) in free.iter().enumerate() {
            let h = self.steps.get(f).copied().unwrap_or(1e-7);
            // central where the domain allows, one-sided at a bound
            let (a, b) = (p[f] - h >= lo[f], p[f] + h <= hi[f]);
            let at = |v: f64| -> Option<Predictions> {
                let mut pp = p.to_vec();
                pp[f] = v;
                let plant = SpatialPlant::new(self.robot, &pp).ok()?;
                let s = settle_all(&plant, self.seq, Some(&state.theta), &self.opts, 1);
                Some(rows_of_commands(self.seq, &s, n))
            };
            let (plus, minus, span) = match (a, b) {
                (true, true) => (at(p[f] + h)?, at(p[f] - h)?, 2.0 * h),
                (false, true) => (at(p[f] + h)?, self.predictions(state), h),
                (true, false) => (self.predictions(state), at(p[f] - h)?, h),
                (false, false) => return None,
            };
            for i in 0..rows {
                for c in 0..WIDTH {
                    let d =
                        (plus.observation[i * WIDTH + c] - minus.observation[i * WIDTH + c]) / span;
                    jac[(i * WIDTH + c) * k + q] = d;
                }
            }
        }
        Some(jac)
    }
}

impl SpatialRobot {
    /// Length of the straight arm along its chain (m): the tip distance at theta = 0.
    pub fn straight_length(&self) -> f64 {
        let mut chain = Chain::new(self);
        chain.at(self, &vec![0.0; self.n()]);
        chain.end().p.norm()
    }
}

/// One compensation target: the delivered lengths that put the plant's
/// observation on the target (weighted components), Jacobian by central
/// differences of warm-started settles.
struct Target<'a> {
    plant: &'a SpatialPlant<'a>,
    work: SettleWork,
    chain: Chain,
    target: [f64; 6],
    weights: [f64; 6],
    active: Vec<usize>,
    seed: &'a [f64],
    theta: Vec<f64>,
    real: Vec<f64>,
}

impl Target<'_> {
    fn seen(&mut self, r: &[f64]) -> Option<[f64; 6]> {
        self.real.clear();
        self.plant.actuate(r, &mut self.real);
        self.theta.copy_from_slice(self.seed);
        let real = std::mem::take(&mut self.real);
        let ok = self.plant.settle(&real, &mut self.theta, &mut self.work);
        self.real = real;
        ok.then(|| self.plant.observe(&self.theta, &mut self.chain))
    }
}

impl Problem for Target<'_> {
    fn dims(&self) -> (usize, usize) {
        (self.active.len(), self.plant.pos.len())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        let Some(o) = self.seen(x) else {
            return false;
        };
        for (k, &c) in self.active.iter().enumerate() {
            r[k] = self.weights[c] * (o[c] - self.target[c]);
        }
        if let Some(j) = jac {
            let m = x.len();
            let h = 1e-7;
            let mut xp = x.to_vec();
            for q in 0..m {
                xp[q] = x[q] + h;
                let Some(a) = self.seen(&xp) else {
                    return false;
                };
                xp[q] = x[q] - h;
                let Some(b) = self.seen(&xp) else {
                    return false;
                };
                xp[q] = x[q];
                for (k, &c) in self.active.iter().enumerate() {
                    j[k * m + q] = self.weights[c] * (a[c] - b[c]) / (2.0 * h);
                }
            }
        }
        r.iter().all(|v| v.is_finite())
    }
}

/// Compensation of a spatial plant `p`: for every target `[x, y, z, rx, ry,
/// rz]` (m, rad; weights per component, 0: free) the position-cable lengths
/// the screws must deliver so that the plant's observation meets it, seeded
/// at `theta_cmd` (the nominal configuration), then commanded in order through
/// the backlash from `start` (delivered lengths, m; `None`: the straight pose).
#[allow(clippy::too_many_arguments)]
pub fn compensate(
    robot: &SpatialRobot,
    p: &[f64],
    theta_cmd: &[f64],
    targets: &[f64],
    weights: [f64; 6],
    start: Option<&[f64]>,
    opts: &SolveOptions,
    tol: f64,
    max_iter: u32,
    threads: usize,
) -> Result<crate::compensate::Compensation> {
    let n = robot.n();
    let rows = rows_of("targets", targets, WIDTH)?;
    rows_exactly("theta_cmd", theta_cmd, n, rows)?;
    crate::error::check_finite("weights", &weights)?;
    let active: Vec<usize> = (0..WIDTH).filter(|c| weights[*c] != 0.0).collect();
    if active.is_empty() || weights.iter().any(|w| *w < 0.0) {
        return Err(CdsmError::Option {
            name: "weights".into(),
            problem: format!("need weights >= 0 with at least one > 0, got {weights:?}"),
        });
    }
    if !(tol > 0.0 && tol.is_finite()) {
        return Err(CdsmError::Option {
            name: "tol".into(),
            problem: format!("must be positive and finite, got {tol}"),
        });
    }
    let plant = SpatialPlant::new(robot, p)?;
    let m = plant.pos.len();
    if let Some(s) = start {
        rows_exactly("start", s, m, 1)?;
    }
    let mut chain = Chain::new(robot);
    let mut pts = Vec::new();
    let mut nominal = Vec::with_capacity(rows * m);
    for i in 0..rows {
        chain.at(robot, &theta_cmd[i * n..(i + 1) * n]);
        nominal.extend(
            plant
                .pos
                .iter()
                .map(|c| cable_length(robot, &chain, *c, &mut pts, None)),
        );
    }
    let lm = Lm::equations(Step::levenberg(active.len(), m), tol, max_iter);
    let parts = split_rows(rows, threads, |range| {
        let mut ws = Workspace::default();
        let mut out = Vec::with_capacity(range.len());
        for i in range {
            let mut prob = Target {
                plant: &plant,
                work: SettleWork::new(robot, *opts),
                chain: Chain::new(robot),
                target: std::array::from_fn(|c| targets[WIDTH * i + c]),
                weights,
                active: active.clone(),
                seed: &theta_cmd[i * n..(i + 1) * n],
                theta: vec![0.0; n],
                real: Vec::with_capacity(m),
            };
            let mut r = nominal[i * m..(i + 1) * m].to_vec();
            let st = lm::solve(&mut prob, &mut r, &lm, &mut ws);
            let seen = prob.seen(&r);
            out.push((r, st, seen, prob.theta.clone()));
        }
        out
    });
    let mut res = crate::compensate::Compensation {
        nominal: nominal.clone(),
        ..Default::default()
    };
    let mut state = start.map_or_else(|| plant.l_ref.clone(), |s| s.to_vec());
    for (r, st, seen, theta) in parts.into_iter().flatten() {
        crate::compensate::command_through_backlash(
            &r,
            plant.backlash(),
            &mut state,
            &mut res.command,
        );
        res.converged.push(st.converged && seen.is_some());
        res.residual.push(st.residual);
        res.theta.extend_from_slice(&theta);
        res.seen.extend_from_slice(&seen.unwrap_or([f64::NAN; 6]));
    }
    // the nominal commands through the same plant, in order
    let mut state = start.map_or_else(|| plant.l_ref.clone(), |s| s.to_vec());
    let mut work = SettleWork::new(robot, *opts);
    let (mut real, mut th) = (Vec::with_capacity(m), vec![0.0; n]);
    for i in 0..rows {
        for (k, s) in state.iter_mut().enumerate() {
            *s = dead_band(nominal[i * m + k], *s, plant.backlash()[k]);
        }
        real.clear();
        plant.actuate(&state, &mut real);
        th.copy_from_slice(&theta_cmd[i * n..(i + 1) * n]);
        let seen = if plant.settle(&real, &mut th, &mut work) {
            plant.observe(&th, &mut chain)
        } else {
            [f64::NAN; 6]
        };
        res.seen_nominal.extend_from_slice(&seen);
    }
    Ok(res)
}
