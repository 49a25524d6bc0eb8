//! The real arm as the nominal model plus candidate unmodelled effects (the
//! "plant", `docs/model.md`, "The plant"), written once over the arm's kind:
//! commands in sequence through backlash and the actuators, an arm with
//! moved holes, links and joint axes whose cables bear on oversized holes
//! and stretch, seen by an instrument through a tip offset and a frame.
//! All-zero parameters give the nominal model exactly. SI units (m, rad, N).
//!
//! The flat parameter vector's layout is the kind's ([`layout`]): which
//! effects an arm of that kind has, and how many numbers each takes. The
//! effects themselves move the one model's numbers ([`ArmNumbers`]) and are
//! written once.
//!
//! The equations of the settled state and the observation are written once
//! over [`Real`]: in `f64` they settle and predict, in [`Jet`]s they give
//! exact derivatives along [`JET`] directions per evaluation, so the
//! Jacobian of the predictions with respect to the parameters follows from
//! the implicit function theorem at the settled configuration.

use crate::chain::{straight_length, ArmNumbers, Chain};
pub use crate::effect::Effect;
use crate::effect::Size;
use crate::elastic::{Commands, Elastic};
use crate::error::{CdsmError, Result};
use crate::fit::{FitModel, Predictions};
use crate::friction::{mobilisation, Holes, Motion, Profile, MU_MAX};
use crate::kinds::{Frame, Group, Rotation, Vector, Visit};
use crate::lm::{self, solve_general_each, Lm, Problem, Step, Workspace};
use crate::model::{Mode, Model, RedundantSettle};
use crate::real::{Arith, Jet, Real};
use crate::rows::{
    row_of, rows_exactly, rows_of, seeds, shared_or_rows, split_rows, BatchSolution,
};
use crate::solve::{CableMethod, CableSolver, SolveOptions};
use crate::tension::{Balance, Wrench};

mod elastic_friction;
mod elastic_settle;

/// Why a row was not predicted, by code: 0-4 the elastic settle's
/// ([`crate::elastic::REASONS`]), then a rigid settle that did not converge,
/// a parameter set outside the physical domain and an elastic settle with
/// friction whose Jacobian is singular.
pub const REASONS: [&str; 8] = [
    "converged",
    "iteration limit",
    "line search",
    "not finite",
    "not a minimum",
    "did not settle",
    "not physical",
    "singular Jacobian",
];
/// [`REASONS`]' code of a rigid settle that did not converge.
const NOT_SETTLED: u8 = 5;
/// [`REASONS`]' code of a parameter set outside the physical domain.
const NOT_PHYSICAL: u8 = 6;

/// The clearance's transition width at `clearance_width = 0` (rad).
pub const CLEARANCE_WIDTH: f64 = 0.01;

/// The flat parameter vector of a model's plant: its effects in order, each
/// with its offset and size.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    pub blocks: Vec<(Effect, usize, usize)>,
    pub total: usize,
}

impl Layout {
    /// Offset and size of `e`'s parameters, if the kind has the effect.
    pub fn find(&self, e: Effect) -> Option<(usize, usize)> {
        self.blocks.iter().find(|b| b.0 == e).map(|b| (b.1, b.2))
    }
}

/// The cables the plant commands (`docs/model.md`, "The plant"): a rigid
/// arm's position cables; an elastic arm's ([`Model::is_elastic`]) elastic
/// cables, position and displacement, in model order (force cables keep
/// their set tension).
pub fn commanded_cables(model: &Model) -> Vec<usize> {
    if model.is_elastic() {
        (0..model.cables.len())
            .filter(|c| model.cables[*c].mode != Mode::Force)
            .collect()
    } else {
        model.position_cables()
    }
}

/// The segments of an arm (`docs/model.md`, "Elastic arms"): the joints
/// between consecutive cable terminations (the disks where some cable
/// ends), base to tip; joints beyond the last termination are a segment of
/// their own.
pub fn segments(model: &Model) -> Vec<std::ops::Range<usize>> {
    let mut ends: Vec<usize> = model.cables.iter().map(|c| c.end).collect();
    ends.push(model.disks.len());
    ends.sort_unstable();
    ends.dedup();
    let mut out = Vec::with_capacity(ends.len());
    let mut start = 0;
    for e in ends {
        if e == 0 {
            continue;
        }
        let stop = model.disks[e - 1].joints.end;
        if stop > start {
            out.push(start..stop);
            start = stop;
        }
    }
    out
}

/// The effects the elastic settle does not model (`docs/model.md`, "The
/// plant", elastic arms): the extra compliance and the holes' clearance have
/// no block on an elastic arm; friction's comes last in its layout.
const NOT_ELASTIC: [Effect; 4] = [
    Effect::CableElasticity,
    Effect::HoleClearance,
    Effect::ClearanceWidth,
    Effect::CableFriction,
];

/// The number of parameters `size` gives a block of `model`'s plant.
pub fn block_size(model: &Model, size: Size) -> usize {
    let (n, k) = (model.n(), model.disks.len());
    let info = model.kind.info();
    match size {
        Size::One => 1,
        Size::PerPositionCable => commanded_cables(model).len(),
        Size::PerDisk => k,
        Size::PerPositionHoleCoord => {
            3 * commanded_cables(model)
                .iter()
                .map(|c| model.cables[*c].holes.len())
                .sum::<usize>()
        }
        Size::LinkLengths => 1 + k,
        Size::LinkVectors => 3 * (n + k),
        Size::Instrument => info.task,
        Size::Point => info.dim,
        Size::PerJointTilt => 2 * n,
        Size::PerSegment => segments(model).len(),
    }
}

/// The layout of `model`'s plant (`docs/model.md`, "Parameters"): its kind's
/// blocks ([`crate::kinds::KindInfo::layout`]) sized by its structure; an
/// elastic arm's without the blocks the elastic settle does not model and
/// with its kind's elastic blocks at the end
/// ([`crate::kinds::KindInfo::elastic_layout`]): `joint_stiffness` (one per
/// [`segments`], when some joint has a spring) and, spatial, `cable_angle`
/// (one per commanded cable). A rigid arm's layout is its kind's.
pub fn layout(model: &Model) -> Layout {
    let info = model.kind.info();
    let rules = info.layout;
    let elastic = model.is_elastic();
    let mut blocks = Vec::with_capacity(rules.len() + 2);
    let mut total = 0;
    let mut put = |e: Effect, s: usize| {
        blocks.push((e, total, s));
        total += s;
    };
    for &(e, size) in rules {
        if elastic && NOT_ELASTIC.contains(&e) {
            continue;
        }
        put(e, block_size(model, size));
    }
    if elastic {
        let sprung = model.joints.iter().any(|j| j.stiffness > 0.0);
        for &(e, size) in info.elastic_layout {
            if e != Effect::JointStiffness || sprung {
                put(e, block_size(model, size));
            }
        }
        put(Effect::CableFriction, 1);
    }
    Layout { blocks, total }
}

/// The size rule of `e`'s block in `model`'s layout, if its kind has the effect.
fn size_rule(model: &Model, e: Effect) -> Option<Size> {
    model
        .kind
        .info()
        .layout
        .iter()
        .find(|b| b.0 == e)
        .map(|b| b.1)
}

/// The SI unit of a plant parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unit {
    Metre,
    Radian,
    /// Dimensionless (a gain, a friction coefficient).
    One,
    /// A compliance, `1/(E A)`.
    PerNewton,
}

impl Unit {
    pub fn symbol(self) -> &'static str {
        match self {
            Unit::Metre => "m",
            Unit::Radian => "rad",
            Unit::One => "1",
            Unit::PerNewton => "1/N",
        }
    }
}

/// One parameter of the flat vector: its block, what it is on the arm (the
/// cable, hole, joint or disk, and the component) and its unit.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    pub effect: Effect,
    pub label: String,
    pub unit: Unit,
}

/// Every parameter of `model`'s plant, in the order of [`layout`] (the
/// meaning of each block: `docs/model.md`, "Parameters"). Cables, joints
/// and disks are numbered from 1 as in the robot file.
pub fn parameters(model: &Model) -> Vec<Parameter> {
    let info = model.kind.info();
    let link_lengths = size_rule(model, Effect::LinkLength) == Some(Size::LinkLengths);
    let pos = commanded_cables(model);
    let xyz = ["x", "y", "z"];
    let cable = |c: usize| format!("cable {} (to disk {})", c + 1, model.cables[c].end);
    let lay = layout(model);
    let mut out = Vec::with_capacity(lay.total);
    for &(e, _, s) in &lay.blocks {
        let before = out.len();
        let mut put = |label: String, unit: Unit| {
            out.push(Parameter {
                effect: e,
                label,
                unit,
            })
        };
        match e {
            Effect::ActuationScale => put("s (actuator gain 1 + s)".into(), Unit::One),
            Effect::CableOffset | Effect::Backlash => {
                for &c in &pos {
                    put(cable(c), Unit::Metre);
                }
            }
            Effect::HoleHeight => {
                for d in 1..=model.disks.len() {
                    put(format!("holes of the cables to disk {d}"), Unit::Metre);
                }
            }
            Effect::HolePosition => {
                for &c in &pos {
                    for h in 0..model.cables[c].holes.len() {
                        let face = match h {
                            0 => "base face b".to_string(),
                            _ => format!("disk {} face {}", h.div_ceil(2), ["b", "a"][h % 2]),
                        };
                        for x in xyz {
                            put(format!("cable {}, {face}, {x}", c + 1), Unit::Metre);
                        }
                    }
                }
            }
            Effect::LinkLength if link_lengths => {
                put("base → joint 1".into(), Unit::Metre);
                for (i, d) in model.disks.iter().enumerate() {
                    put(
                        format!("joint {} → disk {}", d.joints.end, i + 1),
                        Unit::Metre,
                    );
                }
            }
            Effect::LinkLength => {
                for j in 1..=model.n() {
                    for x in xyz {
                        put(format!("joint {j} offset, {x}"), Unit::Metre);
                    }
                }
                for d in 1..=model.disks.len() {
                    for x in xyz {
                        put(format!("disk {d} link after, {x}"), Unit::Metre);
                    }
                }
            }
            Effect::CableElasticity => put("compliance 1/(E A)".into(), Unit::PerNewton),
            Effect::HoleClearance => put("clearance c".into(), Unit::Metre),
            Effect::ClearanceWidth => put(
                format!("transition width w − {CLEARANCE_WIDTH} rad"),
                Unit::Radian,
            ),
            Effect::FrameMisalignment if info.rotation == Rotation::Angle => {
                put("instrument frame rotation".into(), Unit::Radian);
                for x in &xyz[..2] {
                    put(format!("instrument frame {x}"), Unit::Metre);
                }
            }
            Effect::FrameMisalignment => {
                for x in xyz {
                    put(
                        format!("instrument frame rotation vector, {x}"),
                        Unit::Radian,
                    );
                }
                for x in xyz {
                    put(format!("instrument frame {x}"), Unit::Metre);
                }
            }
            Effect::TipOffset => {
                for x in &xyz[..info.dim] {
                    put(format!("tip offset {x} (end frame)"), Unit::Metre);
                }
            }
            Effect::JointAxis => {
                for j in 1..=model.n() {
                    put(format!("joint {j} tilt d1 (toward e1)"), Unit::Radian);
                    put(format!("joint {j} tilt d2 (toward e2)"), Unit::Radian);
                }
            }
            Effect::CableFriction => put("μ (every cable, every hole)".into(), Unit::One),
            Effect::JointStiffness => {
                for r in segments(model) {
                    put(
                        format!(
                            "segment of joints {}–{} (springs 1 + s)",
                            r.start + 1,
                            r.end
                        ),
                        Unit::One,
                    );
                }
            }
            Effect::CableAngle => {
                for &c in &pos {
                    put(
                        format!("{} about the backbone axis", cable(c)),
                        Unit::Radian,
                    );
                }
            }
        }
        debug_assert_eq!(out.len() - before, s, "{}", e.name());
    }
    out
}

/// The smallest distance of a hole from its disk's axis (m, 0 excluded):
/// a clearance cannot be wider.
fn least_hole_radius(model: &Model) -> f64 {
    model
        .cables
        .iter()
        .flat_map(|c| c.holes.iter().map(|h| h[1].hypot(h[2])))
        .filter(|r| *r > 0.0)
        .fold(f64::INFINITY, f64::min)
}

/// The physical domain of each parameter as `[lower, upper]` bounds (SI):
/// actuator gain above a tenth of nominal, non-negative compliance, clearance
/// and backlash, a clearance below the least hole radius, a transition width
/// in `[1e-4, 1]` rad, planar links above a tenth of their nominal length,
/// friction in `[0, MU_MAX]`; joint springs above a tenth of nominal
/// (`s >= -0.9`), cable angles in `[-pi, pi]` rad.
pub fn bounds(model: &Model) -> (Vec<f64>, Vec<f64>) {
    let lay = layout(model);
    let mut lo = vec![f64::NEG_INFINITY; lay.total];
    let mut hi = vec![f64::INFINITY; lay.total];
    for &(e, o, s) in &lay.blocks {
        match e {
            Effect::ActuationScale => lo[o] = -0.9,
            Effect::CableElasticity => lo[o] = 0.0,
            Effect::HoleClearance => {
                lo[o] = 0.0;
                let r = least_hole_radius(model);
                if r.is_finite() {
                    hi[o] = r;
                }
            }
            Effect::ClearanceWidth => {
                lo[o] = 1e-4 - CLEARANCE_WIDTH;
                hi[o] = 1.0 - CLEARANCE_WIDTH;
            }
            Effect::Backlash => lo[o..o + s].fill(0.0),
            Effect::CableFriction => {
                lo[o] = 0.0;
                hi[o] = MU_MAX;
            }
            Effect::JointStiffness => lo[o..o + s].fill(-0.9),
            Effect::CableAngle => {
                lo[o..o + s].fill(-std::f64::consts::PI);
                hi[o..o + s].fill(std::f64::consts::PI);
            }
            Effect::LinkLength if size_rule(model, e) == Some(Size::LinkLengths) => {
                lo[o] = -0.9 * model.joints[0].offset[0];
                for (i, d) in model.disks.iter().enumerate() {
                    lo[o + 1 + i] = -0.9 * d.link_after[0];
                }
            }
            _ => {}
        }
    }
    (lo, hi)
}

/// Whether the flat parameters `p` describe a physical plant (within
/// [`bounds`], finite).
pub fn physical(model: &Model, p: &[f64]) -> bool {
    let (lo, hi) = bounds(model);
    p.len() == lo.len()
        && p.iter()
            .zip(lo.iter().zip(&hi))
            .all(|(v, (l, h))| v.is_finite() && *v >= *l && *v <= *h)
}

/// Two unit vectors completing the unit `a` to a right-handed basis: `e1`
/// the arm's direction `x` made perpendicular to `a` (`y` when `a` is along
/// `x`), `e2 = a × e1`. A joint axis tilts by `d1 e1 + d2 e2`.
pub fn tilt_basis(a: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let x = if a[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let d = x.dot(a);
    let e = x.sub(a.scale(d));
    let e1 = e.scale(1.0 / e.norm());
    (e1, crate::kinds::cross(a, e1))
}

/// The parameters of one plant, unpacked, in any scalar.
#[derive(Debug, Clone)]
struct Params<S> {
    scale: S,
    offset: Vec<S>,
    /// The compliance (1/N) the settle stretches the cables at: the
    /// parameter `kappa`, plus the robot file's cable's `1 / (E A)` where
    /// the arm settles at its cables' potential
    /// ([`RedundantSettle::Potential`], `docs/model.md`, "Settling").
    kappa: S,
    clearance: S,
    width: S,
    instrument: Vec<S>,
    tip: Vec<S>,
    backlash: Vec<S>,
    /// Friction coefficient in the holes (1).
    mu: S,
    /// Elastic arms: every joint's spring factor `1 + s` of its segment (1, `n`).
    spring: Vec<S>,
    /// The compliance whose frictionless stretch the controller feeds
    /// forward (1/N): the robot file's cable's `1 / (E A)` with
    /// `stretch_feed_forward` and as many position cables as joints, else 0.
    /// A cable has one compliance, `kappa + kff`, whatever makes its tension
    /// (`docs/model.md`, "Friction in the holes").
    kff: f64,
    /// The plant's arm: the model's numbers, moved.
    arm: ArmNumbers<S>,
}

impl<S: Real> Params<S> {
    /// From the flat vector `p`; `lift(i, p[i])` makes parameter `i` a scalar
    /// (constant, or seeded along a derivative direction).
    fn unpack(model: &Model, lay: &Layout, p: &[f64], lift: impl Fn(usize, f64) -> S) -> Params<S> {
        let v = |i: usize| lift(i, p[i]);
        let z = S::cst(0.0);
        let span = |e: Effect| -> Vec<S> {
            lay.find(e)
                .map_or_else(Vec::new, |(o, s)| (o..o + s).map(v).collect())
        };
        let one = |e: Effect| lay.find(e).map_or(z, |(o, _)| v(o));
        let pos = model.position_cables();
        let commanded = commanded_cables(model);
        let mut arm = ArmNumbers::<S>::of(model);
        let mut spring = vec![S::cst(1.0); model.n()];
        if let Some((o, _)) = lay.find(Effect::JointStiffness) {
            for (s, r) in segments(model).into_iter().enumerate() {
                let f = v(o + s) + 1.0;
                spring[r].fill(f);
            }
        }
        if let Some((o, _)) = lay.find(Effect::CableAngle) {
            // about the disk frames' x, the backbone axis
            for (i, &c) in commanded.iter().enumerate() {
                let (sn, cs) = v(o + i).sin_cos();
                for h in arm.holes[c].iter_mut() {
                    let (y, z) = (h[1], h[2]);
                    h[1] = y * cs - z * sn;
                    h[2] = y * sn + z * cs;
                }
            }
        }
        if let Some((o, _)) = lay.find(Effect::HoleHeight) {
            for (c, cable) in model.cables.iter().enumerate() {
                let dh = v(o + cable.end - 1);
                let dh = if cable.mode == Mode::Position {
                    dh
                } else {
                    -dh
                };
                for h in arm.holes[c].iter_mut() {
                    h[1] += dh;
                }
            }
        }
        if let Some((o, _)) = lay.find(Effect::HolePosition) {
            let mut k = o;
            for &c in &commanded {
                for h in arm.holes[c].iter_mut() {
                    for x in h.iter_mut() {
                        *x += v(k);
                        k += 1;
                    }
                }
            }
        }
        if let Some((o, s)) = lay.find(Effect::LinkLength) {
            if size_rule(model, Effect::LinkLength) == Some(Size::LinkLengths) {
                arm.offset[0][0] += v(o);
                for (i, la) in arm.link_after.iter_mut().enumerate() {
                    la[0] += v(o + 1 + i);
                }
            } else {
                let mut k = o;
                for x in arm
                    .offset
                    .iter_mut()
                    .chain(arm.link_after.iter_mut())
                    .flatten()
                {
                    *x += v(k);
                    k += 1;
                }
                debug_assert_eq!(k, o + s);
            }
        }
        if let Some((o, _)) = lay.find(Effect::JointAxis) {
            for (j, joint) in model.joints.iter().enumerate() {
                let (e1, e2) = tilt_basis(joint.axis);
                let (d1, d2) = (v(o + 2 * j), v(o + 2 * j + 1));
                let a: [S; 3] =
                    std::array::from_fn(|i| S::cst(joint.axis[i]) + d1 * e1[i] + d2 * e2[i]);
                let norm = a.norm();
                arm.axis[j] = a.scale(S::cst(1.0) / norm);
            }
        }
        arm.settled(model);
        Params {
            scale: one(Effect::ActuationScale),
            offset: span(Effect::CableOffset),
            // a redundant arm on its stated cable: nothing is fed forward,
            // it settles on the file's cables, stretched at kappa + 1/(E A)
            kappa: if model.redundant_settle() == Some(RedundantSettle::Potential) {
                one(Effect::CableElasticity) + S::cst(model.cable.compliance())
            } else {
                one(Effect::CableElasticity)
            },
            clearance: one(Effect::HoleClearance),
            width: one(Effect::ClearanceWidth) + CLEARANCE_WIDTH,
            instrument: span(Effect::FrameMisalignment),
            tip: span(Effect::TipOffset),
            backlash: span(Effect::Backlash),
            mu: one(Effect::CableFriction),
            spring,
            // with more position cables than joints the statics fix no
            // frictionless tensions to feed forward: kappa is the whole compliance
            kff: if pos.len() == model.n() {
                model.cable.fed_forward()
            } else {
                0.0
            },
            arm,
        }
    }

    fn elastic(&self) -> bool {
        self.kappa.val() != 0.0 || self.kappa.is_variable()
    }

    fn clear(&self) -> bool {
        self.clearance.val() != 0.0 || self.clearance.is_variable()
    }

    /// Friction in the holes: with `mu = 0` the equations are the
    /// frictionless ones, the same code path.
    fn friction(&self) -> bool {
        self.mu.val() != 0.0 || self.mu.is_variable()
    }

    /// The cable's one compliance (1/N): every tension stretches it, friction's
    /// change of the tensions too.
    fn friction_compliance(&self) -> S {
        self.kappa + self.kff
    }
}

/// What a measurement row is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Reading {
    /// One command `C + dL`, observed.
    Absolute = 0,
    /// Two commands `C` then `C + dL`; the difference of the observations.
    Displacement = 1,
    /// One command `C + dL`, executed, not observed.
    Unmeasured = 2,
}

impl Reading {
    pub fn from_code(code: u8) -> Result<Reading> {
        match code {
            0 => Ok(Reading::Absolute),
            1 => Ok(Reading::Displacement),
            2 => Ok(Reading::Unmeasured),
            other => Err(CdsmError::Option {
                name: "reading".into(),
                problem: format!("a row's reading code must be 0, 1 or 2, got {other}"),
            }),
        }
    }
}

/// A data set's commands in execution order: `theta_cmd (N, n)` rad,
/// `dl (N, m)` m (the commanded cables, [`commanded_cables`], file order)
/// and each row's reading ([`Reading`]).
#[derive(Debug, Clone, Copy)]
pub struct Rows<'a> {
    pub theta_cmd: &'a [f64],
    pub dl: &'a [f64],
    pub reading: &'a [Reading],
}

/// The command sequence of a data set, built once from the nominal model:
/// every command's nominal position-cable lengths and the row it belongs to.
#[derive(Debug, Clone)]
pub struct Sequence {
    n: usize,
    m: usize,
    rows: usize,
    /// `(commands, m)` nominal commanded lengths (m).
    command: Vec<f64>,
    /// Row of each command.
    row: Vec<usize>,
    /// First and last command of each row.
    span: Vec<[usize; 2]>,
    /// What each row measured.
    reading: Vec<Reading>,
    theta_cmd: Vec<f64>,
    /// The nominal motion the friction's sliding directions follow, made
    /// the first time a plant with friction settles the sequence.
    motion: std::sync::OnceLock<Motion>,
}

/// The lengths of `model`'s position cables at `theta` (rad), m.
pub fn position_lengths(model: &Model, theta: &[f64]) -> Vec<f64> {
    position_lengths_rows(model, theta)
}

/// The lengths of `model`'s position cables at every configuration of
/// `theta (N, n)` (rad): `(N, m)` m.
pub fn position_lengths_rows(model: &Model, theta: &[f64]) -> Vec<f64> {
    model.kind.visit(PositionLengths {
        model,
        theta,
        cables: model.position_cables(),
    })
}

/// The lengths of `model`'s commanded cables ([`commanded_cables`]) at
/// every configuration of `theta (N, n)` (rad): `(N, m)` m.
pub fn commanded_lengths_rows(model: &Model, theta: &[f64]) -> Vec<f64> {
    model.kind.visit(PositionLengths {
        model,
        theta,
        cables: commanded_cables(model),
    })
}

/// The lengths of some cables over the model's motion group: one chain,
/// one configuration after another.
struct PositionLengths<'a> {
    model: &'a Model,
    theta: &'a [f64],
    cables: Vec<usize>,
}

impl Visit for PositionLengths<'_> {
    type Out = Vec<f64>;
    fn visit<G: Group>(self) -> Vec<f64> {
        let model = self.model;
        let pos = self.cables;
        let mut ch = Chain::<f64, G::Frame<f64>>::new(model);
        let mut out = Vec::with_capacity(self.theta.len() / model.n().max(1) * pos.len());
        for theta in self.theta.chunks_exact(model.n()) {
            ch.at(model, model, theta);
            for c in &pos {
                out.push(ch.cable_length(model, model, *c, None));
            }
        }
        out
    }
}

impl Sequence {
    pub fn new(model: &Model, data: &Rows) -> Result<Sequence> {
        let n = model.n();
        let m = commanded_cables(model).len();
        let rows = rows_of("theta_cmd", data.theta_cmd, n)?;
        rows_exactly("dl", data.dl, m, rows)?;
        if data.reading.len() != rows {
            return Err(CdsmError::Shape {
                name: "reading".into(),
                expected: format!("({rows},)"),
                got: format!("({},)", data.reading.len()),
            });
        }
        let mut seq = Sequence {
            n,
            m,
            rows,
            command: Vec::with_capacity(2 * rows * m),
            row: Vec::with_capacity(2 * rows),
            span: Vec::with_capacity(rows),
            reading: data.reading.to_vec(),
            theta_cmd: data.theta_cmd.to_vec(),
            motion: std::sync::OnceLock::new(),
        };
        let lengths = commanded_lengths_rows(model, data.theta_cmd);
        for i in 0..rows {
            let c = &lengths[i * m..(i + 1) * m];
            let first = seq.row.len();
            if data.reading[i] == Reading::Displacement {
                seq.command.extend_from_slice(c);
                seq.row.push(i);
            }
            for (ck, d) in c.iter().zip(&data.dl[i * m..(i + 1) * m]) {
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

    /// The nominal motion of the commands (`docs/model.md`, "Sliding
    /// directions and the sticking band"): every command's nominal
    /// configuration, the rigid cable solve of its nominal lengths from its
    /// row's `theta_cmd` (a displacement row's first command: `theta_cmd`
    /// itself; `theta_cmd` where the solve fails); an elastic arm's, its
    /// nominal frictionless equilibria ([`elastic_friction::nominal_motion`]).
    pub fn motion<G: Group>(&self, model: &Model) -> &Motion {
        if model.is_elastic() {
            return self
                .motion
                .get_or_init(|| elastic_friction::nominal_motion::<G>(model, self));
        }
        self.motion.get_or_init(|| {
            let n = self.n;
            let nominal = Plant::<G>::new(model, &vec![0.0; layout(model).total])
                .expect("the nominal plant is physical");
            let mut work = SettleWork::new(&nominal, SolveOptions::default());
            let mut configs = Vec::with_capacity(self.len() * n);
            let mut th = vec![0.0; n];
            for j in 0..self.len() {
                let row = self.row[j];
                let seed = &self.theta_cmd[row * n..(row + 1) * n];
                th.copy_from_slice(seed);
                let first = self.reading[row] == Reading::Displacement && self.span[row][0] == j;
                if !first
                    && !nominal
                        .rigid_solve(
                            &self.command[j * self.m..(j + 1) * self.m],
                            &mut th,
                            &mut work,
                        )
                        .converged
                {
                    th.copy_from_slice(seed);
                }
                configs.extend_from_slice(&th);
            }
            Motion::new::<G>(model, &configs)
        })
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

/// The realised rest lengths of every command (`(commands, m)`, m): the
/// backlash scan from the straight pose, then the actuators.
fn realised<S: Real>(seq: &Sequence, prm: &Params<S>, l_ref: &[f64]) -> Vec<S> {
    let m = seq.m;
    let mut state: Vec<S> = l_ref.iter().map(|v| S::cst(*v)).collect();
    let mut out = Vec::with_capacity(seq.command.len());
    for cmd in seq.command.chunks_exact(m) {
        for i in 0..m {
            state[i] = dead_band(cmd[i], state[i], prm.backlash[i]);
            let r = state[i];
            out.push((r - l_ref[i]) * (prm.scale + 1.0) + l_ref[i] + prm.offset[i]);
        }
    }
    out
}

/// The loads of a settle: gravity (m/s², base frame), the force cables'
/// tensions (N, in the order of the force cables; `None`: the model's) and
/// a tip wrench `[F (3), M]` (N, N m, base frame; `M`: `[Mz]` planar, 3
/// spatial) at the end frame's origin.
#[derive(Debug, Clone, PartialEq)]
pub struct Loads {
    pub gravity: [f64; 3],
    pub force: Option<Vec<f64>>,
    pub wrench: [f64; 6],
}

impl Loads {
    /// The robot file's: its gravity and force tensions, no tip wrench.
    pub fn of(model: &Model) -> Loads {
        Loads {
            gravity: model.gravity,
            force: None,
            wrench: [0.0; 6],
        }
    }
}

/// Buffers of the plant's equations in one scalar.
struct Buffers<S: Real, F: Frame<S>> {
    chain: Chain<S, F>,
    shift: Vec<(F::V, F::V)>,
    lengths: Vec<S>,
    tension: Vec<S>,
    bal: Balance<S>,
    /// The frictionless tensions (friction's change).
    tension0: Vec<S>,
    row: Vec<S>,
    /// Position and force cables of the model.
    pos: Vec<usize>,
    /// The capstan profile (friction) and where every cable's holes sit.
    profile: Profile<S>,
    holes: Holes,
}

impl<S: Real, F: Frame<S>> Buffers<S, F> {
    fn new(model: &Model) -> Self {
        let pos = model.position_cables();
        let z = S::cst(0.0);
        Buffers {
            chain: Chain::new(model),
            shift: vec![(F::V::zero(), F::V::zero()); model.disks.len()],
            lengths: vec![z; pos.len()],
            tension: vec![z; pos.len()],
            bal: Balance::new(model),
            tension0: vec![z; pos.len()],
            row: vec![z; model.n()],
            pos,
            profile: Profile::new(model),
            holes: Holes::of(model),
        }
    }
}

/// The equations of the settled state (`docs/model.md`, "Settling"), `n` of
/// them: with as many position cables as joints, per cable
/// `L_arm,i(theta) - (L_i + L_route)(1 + kappa T_i(theta)) + L_route` (m;
/// `T` the statics tensions); with more, the balance of the joints:
/// rigid, `sum_i dL_i/dtheta_j (L_arm,i - L_i)` (the least-squares
/// condition), elastic, `sum_i dL_i/dtheta_j max(0, s_i) - kappa (tau_j -
/// sum_f dL_f/dtheta_j T_f)` with the strains `s_i = (L_arm,i + L_route) /
/// (L_i + L_route) - 1` (m per rad). With friction (`docs/model.md`,
/// "Friction in the holes"; `mobil` the command's mobilisation of every
/// hole, [`Holes`], missing ones at `+1`) the balance takes each cable's
/// tension in the gap of each joint and the stretch the capstan profile's
/// mean `ebar`: `(L_i + L_route) kappa T_i ebar_i`, `max(0, s_i) / ebar_i`.
#[allow(clippy::too_many_arguments)]
fn equations<S: Real, F: Frame<S>>(
    model: &Model,
    prm: &Params<S>,
    loads: &Loads,
    real: &[S],
    mobil: &[S],
    theta: &[S],
    b: &mut Buffers<S, F>,
    out: &mut [S],
) {
    b.chain.at(model, &prm.arm, theta);
    cable_statics(model, prm, loads, mobil, None, b);
    settled_equations(model, prm, real, b, out);
}

/// The statics and the position cables' lengths of [`equations`] at the
/// configuration of `b.chain` ([`Chain::at`] done): into `b.bal`,
/// `b.profile`, `b.tension0` and `b.lengths`. With `only`, of those cables
/// alone (position cables, by model index), made again from `prm` on a
/// state `b` otherwise left by a whole call of the same configuration, the
/// same loads and mobilisations, and parameters that differ from `prm` in
/// nothing but those cables' holes ([`hole_columns`]).
fn cable_statics<S: Real, F: Frame<S>>(
    model: &Model,
    prm: &Params<S>,
    loads: &Loads,
    mobil: &[S],
    only: Option<&[usize]>,
    b: &mut Buffers<S, F>,
) {
    let (n, m) = (model.n(), b.pos.len());
    let arm = &prm.arm;
    let clear = prm.clear();
    let elastic = prm.elastic();
    let friction = prm.friction();
    let statics = elastic || friction;
    if statics {
        // the statics: the moment balance (its cable lengths are the holes'
        // own, without clearance)
        let w: [S; 6] = std::array::from_fn(|i| S::cst(loads.wrench[i]));
        let couple = model.kind.task() - model.kind.dim();
        let wrench = Wrench {
            force: [w[0], w[1], w[2]],
            couple: &w[3..3 + couple],
        };
        if let (true, Some(cables)) = (friction, only) {
            let route = model.cable.routing_length;
            for &c in cables {
                let h = &b.holes;
                b.profile
                    .cable(model, arm, &b.chain, h, mobil, prm.mu, route, c);
                b.bal
                    .refill_position(model, arm, &b.chain, c, Some(&b.profile.gap));
            }
        } else if let Some(cables) = only {
            for &c in cables {
                b.bal.refill_position(model, arm, &b.chain, c, None);
            }
        } else if friction {
            b.profile.at(
                model,
                arm,
                &b.chain,
                &b.holes,
                mobil,
                prm.mu,
                model.cable.routing_length,
            );
            b.bal.at_friction(
                model,
                arm,
                &mut b.chain,
                loads.gravity,
                wrench,
                loads.force.as_deref(),
                &b.profile.gap,
            );
        } else {
            b.bal.at_with(
                model,
                arm,
                &mut b.chain,
                loads.gravity,
                wrench,
                loads.force.as_deref(),
            );
        }
        // the frictionless tensions: the stretch friction changes
        if friction && m == n && !b.bal.solve_square_frictionless(&mut b.tension0) {
            b.tension0.fill(S::cst(f64::NAN));
        }
    }
    if clear && only.is_none() {
        for (s, f) in b.shift.iter_mut().zip(&b.chain.local) {
            *s = f.bend_shift(prm.clearance, prm.width);
        }
    }
    for (l, &c) in b.lengths.iter_mut().zip(&b.pos) {
        if only.is_some_and(|cs| !cs.contains(&c)) {
            continue;
        }
        *l = if statics && !clear {
            b.bal.lengths[c]
        } else {
            b.chain
                .cable_length(model, arm, c, clear.then_some(&b.shift[..]))
        };
    }
}

/// The equations of [`equations`] from the statics and lengths of
/// [`cable_statics`] (the rows of more cables than joints without statics
/// from the cable Jacobian of `b.chain`).
fn settled_equations<S: Real, F: Frame<S>>(
    model: &Model,
    prm: &Params<S>,
    real: &[S],
    b: &mut Buffers<S, F>,
    out: &mut [S],
) {
    let (n, m) = (model.n(), b.pos.len());
    let arm = &prm.arm;
    let elastic = prm.elastic();
    let friction = prm.friction();
    let statics = elastic || friction;
    let z = S::cst(0.0);
    let route = S::cst(model.cable.routing_length);
    if m == n {
        if statics && !b.bal.solve_square(&mut b.tension) {
            b.tension.fill(S::cst(f64::NAN));
        }
        for i in 0..n {
            let stretch = if friction {
                // (kappa + kff) T ebar - kff T*: the whole stretch at the
                // cable's one compliance, less the frictionless stretch the
                // controller feeds forward
                let t = b.tension[i] * b.profile.mean[b.pos[i]];
                let whole = prm.kappa * t;
                if prm.kff == 0.0 {
                    (real[i] + route) * whole
                } else {
                    (real[i] + route) * (whole + (t - b.tension0[i]) * prm.kff)
                }
            } else if elastic {
                (real[i] + route) * prm.kappa * b.tension[i]
            } else {
                z
            };
            out[i] = b.lengths[i] - real[i] - stretch;
        }
        return;
    }
    if elastic {
        // b.bal.b = tau - J_f^T T_f; its rows J_p^T
        for (o, bj) in out[..n].iter_mut().zip(&b.bal.b) {
            *o = -(prm.kappa * *bj);
        }
        for (i, l) in b.lengths.iter().enumerate() {
            let mut s = (*l + route) / (real[i] + route) - 1.0;
            let pre = model.cables[b.pos[i]].actuator.pretension;
            if pre != 0.0 {
                // the command shortened by P (L_i + L_route) kappa: T = P + s / kappa
                s += prm.kappa * S::cst(pre);
            }
            let mut f = taut_strain(s);
            if friction {
                f = f / b.profile.mean[b.pos[i]];
            }
            for (j, o) in out[..n].iter_mut().enumerate() {
                *o += b.bal.a[j * m + i] * f;
            }
        }
    } else {
        out[..n].fill(z);
        for (i, &c) in b.pos.iter().enumerate() {
            b.chain.cable_jacobian_row(model, arm, c, &mut b.row);
            let f = b.lengths[i] - real[i];
            for (o, r) in out[..n].iter_mut().zip(&b.row) {
                *o += *r * f;
            }
        }
    }
}

/// `max(0, s)` of a cable's strain `s`, with the taut side's derivative at
/// `s = 0` (a cable at zero stretch: the Newton step sees its stiffness, so
/// a settle that starts with every cable at zero stretch, as the rigid
/// answer of consistent lengths does, can move).
#[inline]
fn taut_strain<S: Real>(s: S) -> S {
    if s.val() >= 0.0 {
        s
    } else {
        S::cst(0.0)
    }
}

/// What the instrument sees of the arm at `theta`: the task vector of the
/// frame `E · F_end · Trans(tip)` (`E` the instrument frame).
fn observe<S: Real, F: Frame<S>>(
    model: &Model,
    prm: &Params<S>,
    theta: &[S],
    chain: &mut Chain<S, F>,
    out: &mut [S],
) {
    chain.at(model, &prm.arm, theta);
    observe_at(model, prm, chain, out);
}

/// `g -= tau`, `tau` (N m, into `tau`) the moments of gravity on the disks
/// about the joints' axes at the configuration of `chain` ([`Chain::at`]
/// done on `arm`); nothing without gravity or masses.
fn subtract_gravity<S: Real, F: Frame<S>>(
    model: &Model,
    arm: &ArmNumbers<S>,
    chain: &mut Chain<S, F>,
    tau: &mut [S],
    g: &mut [S],
) {
    let gravity =
        model.gravity.iter().any(|v| *v != 0.0) && model.disks.iter().any(|d| d.mass > 0.0);
    if gravity {
        chain.world(model, arm);
        chain.joints_world(model);
        let couple = vec![S::cst(0.0); model.kind.task() - model.kind.dim()];
        let z = S::cst(0.0);
        chain.load_moments(model, arm, model.gravity, [z, z, z], &couple, tau);
        for (gj, tj) in g.iter_mut().zip(tau.iter()) {
            *gj -= *tj;
        }
    }
}

/// [`observe`] from a chain already at the configuration ([`Chain::at`]).
fn observe_at<S: Real, F: Frame<S>>(
    model: &Model,
    prm: &Params<S>,
    chain: &mut Chain<S, F>,
    out: &mut [S],
) {
    chain.world(model, &prm.arm);
    let mut tip = [S::cst(0.0); 3];
    tip[..prm.tip.len()].copy_from_slice(&prm.tip);
    let seen = F::instrument(&prm.instrument)
        .compose(chain.end())
        .translated(F::V::of(tip));
    seen.task(out);
}

/// Directions carried by one forward-mode evaluation of the plant.
pub const JET: usize = 8;
type J = Jet<JET>;

/// One plant (parameters `p`, flat), ready to settle and observe commands.
pub struct Plant<'a, G: Group> {
    model: &'a Model,
    p: Vec<f64>,
    lay: Layout,
    prm: Params<f64>,
    /// The same parameters as constants in jets (for `dE/dtheta`).
    cprm: Params<J>,
    l_ref: Vec<f64>,
    /// With more position cables than joints on a stated cable
    /// ([`RedundantSettle::Potential`]), no clearance and no friction: the
    /// plant's arm, its cables at the compliance `kappa`, and its elastic
    /// statics (the settle's minimum of the potential).
    statics: Option<Box<Statics>>,
    _kind: std::marker::PhantomData<G>,
}

impl<'a, G: Group> Plant<'a, G> {
    /// The plant of `model` with the flat parameters `p` (see [`layout`]);
    /// an error when `p` has the wrong length or leaves the physical domain.
    pub fn new(model: &'a Model, p: &[f64]) -> Result<Self> {
        let lay = layout(model);
        if p.len() != lay.total {
            return Err(CdsmError::Shape {
                name: "params".into(),
                expected: format!("({},)", lay.total),
                got: format!("({},)", p.len()),
            });
        }
        crate::error::check_finite("params", p)?;
        if !physical(model, p) {
            return Err(CdsmError::Option {
                name: "params".into(),
                problem:
                    "outside the physical domain (non-negative compliance, clearance and backlash, \
                          links and actuator gain above a tenth of nominal)"
                        .into(),
            });
        }
        let prm = Params::<f64>::unpack(model, &lay, p, |_, v| v);
        let cprm = Params::<J>::unpack(model, &lay, p, |_, v| J::cst(v));
        let l_ref = commanded_lengths_rows(model, &vec![0.0; model.n()]);
        let statics = (model.redundant_settle() == Some(RedundantSettle::Potential)
            && !prm.clear()
            && !prm.friction())
        .then(|| {
            let mut arm = elastic_settle::moved(model, &prm);
            // E A = 1 / kappa: the cables of the settle
            let d = arm.cable.diameter;
            arm.cable.youngs_modulus = 1.0 / (prm.kappa * std::f64::consts::PI * d * d / 4.0);
            let el = Elastic::new(&arm);
            // no load: the potential is >= 0, and 0 where every length is met
            let unloaded = (model.gravity == [0.0; 3] || model.disks.iter().all(|d| d.mass == 0.0))
                && model.cables.iter().all(|c| match c.mode {
                    Mode::Position => c.actuator.pretension == 0.0,
                    _ => false,
                });
            Box::new(Statics { arm, el, unloaded })
        });
        Ok(Plant {
            model,
            p: p.to_vec(),
            lay,
            prm,
            cprm,
            l_ref,
            statics,
            _kind: std::marker::PhantomData,
        })
    }

    /// The realised rest lengths of every command of `seq` (`(commands, m)`, m).
    pub fn realised(&self, seq: &Sequence) -> Vec<f64> {
        realised(seq, &self.prm, &self.l_ref)
    }

    /// The mobilisation of every hole after every command of `seq`
    /// (`(commands, H)`, [`Holes`]; empty without friction).
    pub fn mobilisation(&self, seq: &Sequence) -> Vec<f64> {
        if self.prm.friction() && self.model.is_elastic() {
            elastic_friction::mobilisations::<f64, G>(self.model, seq, self.prm.mu)
        } else if self.prm.friction() {
            mobilisation(
                seq.motion::<G>(self.model),
                self.prm.mu,
                self.prm.friction_compliance(),
            )
        } else {
            Vec::new()
        }
    }

    /// The mobilisation of every hole (`(R, H)`, [`Holes`]) along the
    /// nominal configurations `configs` (`(R, n)`, rad) in order, from the
    /// start state at the straight pose (empty without friction): the
    /// sliding state a motion through them leaves at each.
    pub fn mobilisation_along(&self, configs: &[f64]) -> Vec<f64> {
        if self.prm.friction() {
            let motion = Motion::new::<G>(self.model, configs);
            mobilisation(&motion, self.prm.mu, self.prm.friction_compliance())
        } else {
            Vec::new()
        }
    }

    /// The friction coefficient in the holes (1).
    pub fn friction(&self) -> f64 {
        self.prm.mu
    }

    /// The lengths the screws deliver and the actuators realise for one
    /// command `cmd` from the backlash state `state` (updated), m.
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

    /// The straight-pose position-cable lengths of the nominal model (the
    /// backlash state at the start and the actuators' pivot), m.
    pub fn reference_lengths(&self) -> &[f64] {
        &self.l_ref
    }

    /// The backlash half-widths (m).
    pub fn backlash(&self) -> &[f64] {
        &self.prm.backlash
    }

    /// The actuators' gain `1 + s` (realised length per delivered length).
    pub fn gain(&self) -> f64 {
        1.0 + self.prm.scale
    }

    /// The nominal model the controller believes in.
    pub fn nominal(&self) -> &Model {
        self.model
    }

    /// Settles the arm for realised lengths `real` (m); `theta` holds the
    /// seed on entry (the commanded configuration) and the answer on exit.
    /// `work` must have been made for this plant ([`SettleWork::new`]).
    pub fn settle(&self, real: &[f64], theta: &mut [f64], work: &mut SettleWork<'_, G>) -> bool {
        self.settle_status(real, theta, work).converged
    }

    /// [`Plant::settle`] with the solver's status (the rigid solve's, or the
    /// elastic / clearance solve's that follows it).
    pub fn settle_status(
        &self,
        real: &[f64],
        theta: &mut [f64],
        work: &mut SettleWork<'_, G>,
    ) -> crate::solve::Status {
        let (n, m) = (self.model.n(), real.len());
        work.start.copy_from_slice(theta);
        let rigid = self.rigid_solve(real, theta, work);
        if let Some(st) = self.statics.as_deref() {
            if work.loads == Loads::of(self.model) {
                // the minimum of the potential from the rigid answer (the
                // branch), from the seed where the rigid solve failed
                if !rigid.converged {
                    theta.copy_from_slice(&work.start);
                } else if st.unloaded && rigid.residual <= work.opts.tol {
                    // every length met without a load: the potential's
                    // global minimum, 0, with every cable at zero stretch
                    // (a kink the elastic statics cannot call a minimum)
                    return rigid;
                }
                // ten times the settle's budget: a Newton step of the
                // minimisation is cheap, and where cables go slack on stiff
                // cables it crosses one kink at a time (`docs/model.md`,
                // "Settling")
                return statics_settle(st, real, theta, work.opts.max_iter.saturating_mul(10));
            }
        }
        let clear = self.prm.clear();
        if !self.prm.elastic() && !clear && !self.prm.friction() {
            return rigid;
        }
        if !rigid.converged {
            theta.copy_from_slice(&work.start);
        }
        let mut prob = SettleProblem {
            plant: self,
            loads: &work.loads,
            real,
            mobil: &work.mobil,
            work: &mut work.jet,
        };
        // with as many cables as joints and no stretch, cable i crosses the
        // joints of the disks up to its end: planar dE/dtheta is lower triangular
        let step =
            if m == n && !self.prm.elastic() && !self.prm.friction() && work.rigid.is_planar() {
                Step::Triangular
            } else {
                Step::Normal
            };
        let lm = Lm {
            lambda0: work.lambda0,
            ..Lm::equations(step, work.opts.tol, work.opts.max_iter)
        };
        lm::solve(&mut prob, theta, &lm, &mut work.ws)
    }

    /// The rigid cable solve of the plant's arm for realised lengths `real`
    /// (m) from the seed in `theta` (the answer on exit; least squares with
    /// more position cables than joints).
    fn rigid_solve(
        &self,
        real: &[f64],
        theta: &mut [f64],
        work: &mut SettleWork<'_, G>,
    ) -> crate::solve::Status {
        work.rigid.solve(real, theta)
    }

    /// What the instrument sees at `theta` (the task vector, `TASK` values).
    pub fn observe(&self, theta: &[f64], chain: &mut Chain<f64, G::Frame<f64>>, out: &mut [f64]) {
        observe(self.model, &self.prm, theta, chain, out)
    }

    /// What the instrument sees at the settled `theta` for realised lengths
    /// `real`, and its derivative with respect to `real` (`jac`, `(TASK, m)`
    /// row-major) by the implicit function theorem. False where the
    /// equations' Jacobian is singular.
    pub fn observe_linear(
        &self,
        real: &[f64],
        theta: &[f64],
        jac: &mut [f64],
        work: &mut SettleWork<'_, G>,
    ) -> bool {
        let (n, m) = (theta.len(), real.len());
        // directions: theta (n), then each realised length (m)
        let reals: Vec<Vec<J>> = (0..(n + m).div_ceil(JET))
            .map(|c| {
                (0..m)
                    .map(|i| J::seeded(real[i], (n + i).wrapping_sub(c * JET)))
                    .collect()
            })
            .collect();
        let mobil: Vec<J> = work.mobil.iter().map(|v| J::cst(*v)).collect();
        implicit_derivatives(
            self.model,
            theta,
            m,
            n + m,
            |c| Chunk {
                prm: &self.cprm,
                real: &reals[c],
                mobil: &mobil,
            },
            |_| {},
            &mut work.jet,
            jac,
        )
    }
}

/// The statics of a redundant arm's settle ([`Plant`]'s `statics`).
struct Statics {
    /// The plant's arm, its cables at `E A = 1 / kappa`.
    arm: Model,
    el: Elastic,
    /// No gravity, force cable or pretension: the potential is the cables'
    /// stretch alone.
    unloaded: bool,
}

/// The settle of a redundant arm ([`Plant`]'s `statics`): the minimum of
/// the potential of its position cables commanded to the realised lengths
/// `real` (m), from the seed in `theta` (the answer on exit).
fn statics_settle(
    st: &Statics,
    real: &[f64],
    theta: &mut [f64],
    max_iter: u32,
) -> crate::solve::Status {
    let (arm, el) = (&st.arm, &st.el);
    let cmd = Commands {
        lengths: real,
        displacements: &[],
        wrench: [0.0; 6],
    };
    let (converged, iterations, residual, reason) =
        match el.equilibrium(arm, &cmd, theta, crate::elastic::XTOL, max_iter) {
            Ok(eq) => {
                theta.copy_from_slice(&eq.theta);
                let reason = match eq.reason {
                    crate::elastic::Reason::Converged => lm::Reason::Converged,
                    crate::elastic::Reason::IterationLimit => lm::Reason::IterationLimit,
                    _ => lm::Reason::Stalled,
                };
                (eq.converged, eq.iterations, eq.gradient, reason)
            }
            Err(_) => (false, 0, f64::NAN, lm::Reason::Singular),
        };
    crate::solve::Status {
        converged,
        iterations,
        residual,
        cost: residual * residual,
        reason,
    }
}

/// Per-thread buffers of the settles of one plant.
pub struct SettleWork<'a, G: Group> {
    opts: SolveOptions,
    /// The loads the settles hold the arm against (default the robot file's).
    pub loads: Loads,
    /// The initial damping of the elastic / clearance solve (default 0:
    /// Newton first; the batch elastic solve starts damped, `1e-3`).
    pub lambda0: f64,
    /// The rigid settle: the moved arm's cable solve.
    rigid: CableSolver<'a, G::Frame<f64>, ArmNumbers<f64>>,
    start: Vec<f64>,
    jet: JetWork<G>,
    ws: Workspace,
    /// The mobilisation of every hole ([`Holes`]) at the command settled
    /// (friction; missing entries count as `+1`, the start state).
    pub mobil: Vec<f64>,
}

impl<'a, G: Group> SettleWork<'a, G> {
    pub fn new(plant: &'a Plant<G>, opts: SolveOptions) -> Self {
        let model = plant.model;
        SettleWork {
            opts,
            loads: Loads::of(model),
            lambda0: 0.0,
            rigid: CableSolver::new(model, &plant.prm.arm, CableMethod::Auto, opts),
            start: vec![0.0; model.n()],
            jet: JetWork::new(model),
            ws: Workspace::default(),
            mobil: Vec::new(),
        }
    }
}

/// The settle of one command as a problem of the shared solver: the
/// equations of the settled state with their Jacobian in jets.
struct SettleProblem<'a, 'b, G: Group> {
    plant: &'a Plant<'a, G>,
    loads: &'b Loads,
    real: &'a [f64],
    mobil: &'b [f64],
    work: &'b mut JetWork<G>,
}

impl<G: Group> Problem for SettleProblem<'_, '_, G> {
    fn dims(&self) -> (usize, usize) {
        let n = self.plant.model.n();
        (n, n)
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        let p = self.plant;
        equations(
            p.model,
            &p.prm,
            self.loads,
            self.real,
            self.mobil,
            x,
            &mut self.work.fbuf,
            r,
        );
        if let Some(j) = jac {
            let n = x.len();
            for (d, v) in self.work.real.iter_mut().zip(self.real) {
                *d = J::cst(*v);
            }
            self.work.mobil.clear();
            self.work
                .mobil
                .extend(self.mobil.iter().map(|v| J::cst(*v)));
            for c in 0..n.div_ceil(JET) {
                for (l, d) in self.work.theta.iter_mut().enumerate() {
                    *d = J::seeded(x[l], l.wrapping_sub(c * JET));
                }
                let w = &mut *self.work;
                equations(
                    p.model, &p.cprm, self.loads, &w.real, &w.mobil, &w.theta, &mut w.buf, &mut w.f,
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
pub struct JetWork<G: Group> {
    /// The loads of the implicit derivatives (the robot file's).
    loads: Loads,
    fbuf: Buffers<f64, G::Frame<f64>>,
    buf: Buffers<J, G::Frame<J>>,
    theta: Vec<J>,
    real: Vec<J>,
    mobil: Vec<J>,
    f: Vec<J>,
    obs: Vec<J>,
    /// `(n, dirs)` equation and `(TASK, dirs)` observation derivatives.
    df: Vec<f64>,
    dobs: Vec<f64>,
    /// `(TASK, n)`: `O_theta E_theta^-1`.
    y: Vec<f64>,
    ft: Vec<f64>,
    /// `(TASK, n)`: the right-hand sides of `y`.
    rhs: Vec<f64>,
    /// [`hole_columns`] with statics: the balance, capstan profile and
    /// lengths of the plant's parameters as constants at the command, and
    /// the cables of one chunk.
    hole_bal: Balance<J>,
    hole_profile: Profile<J>,
    hole_lengths: Vec<J>,
    hole_cables: Vec<usize>,
}

impl<G: Group> JetWork<G> {
    fn new(model: &Model) -> Self {
        let n = model.n();
        let m = model.position_cables().len();
        let task = <G::Frame<J> as Frame<J>>::TASK;
        JetWork {
            loads: Loads::of(model),
            fbuf: Buffers::new(model),
            buf: Buffers::new(model),
            theta: vec![J::default(); n],
            real: vec![J::default(); m],
            mobil: Vec::new(),
            f: vec![J::default(); n],
            obs: vec![J::default(); task],
            df: Vec::new(),
            dobs: Vec::new(),
            y: vec![0.0; task * n],
            ft: vec![0.0; n * n],
            rhs: vec![0.0; task * n],
            hole_bal: Balance::new(model),
            hole_profile: Profile::new(model),
            hole_lengths: vec![J::default(); m],
            hole_cables: Vec::new(),
        }
    }
}

/// The inputs of one chunk of [`JET`] directions at one command: the
/// parameters (seeded along the chunk's parameter directions) and the
/// realised lengths (seeded along the chunk's length directions).
struct Chunk<'a> {
    prm: &'a Params<J>,
    real: &'a [J],
    mobil: &'a [J],
}

/// The derivatives of one settled command's observation along `dirs` input
/// directions by the implicit function theorem,
/// `dO/dx = O_x - O_theta E_theta^-1 E_x` (`out`: `(TASK, dirs)` row-major).
/// Direction `g` of the combined list `theta_0..theta_{n-1}, x_0..` sits in
/// slot `g % JET` of chunk `g / JET`. False where `E_theta` is singular.
/// Only the first `full` directions are evaluated by full passes (chunks
/// `0..full.div_ceil(JET)`); `rest` fills the columns `full..` of `w.df`
/// and `w.dobs` (`(n, total)`, `(TASK, total)` row-major).
#[allow(clippy::too_many_arguments)]
fn implicit_derivatives<'c, G: Group>(
    model: &Model,
    theta: &[f64],
    dirs: usize,
    full: usize,
    chunk: impl Fn(usize) -> Chunk<'c>,
    rest: impl FnOnce(&mut JetWork<G>),
    w: &mut JetWork<G>,
    out: &mut [f64],
) -> bool {
    let n = theta.len();
    let task = <G::Frame<J> as Frame<J>>::TASK;
    let total = n + dirs;
    w.df.resize(n * total, 0.0);
    w.dobs.resize(task * total, 0.0);
    for c in 0..full.div_ceil(JET) {
        let ch = chunk(c);
        for (l, d) in w.theta.iter_mut().enumerate() {
            *d = J::seeded(theta[l], l.wrapping_sub(c * JET));
        }
        equations(
            model, ch.prm, &w.loads, ch.real, ch.mobil, &w.theta, &mut w.buf, &mut w.f,
        );
        observe_at(model, ch.prm, &mut w.buf.chain, &mut w.obs);
        for s in 0..JET.min(full - c * JET) {
            let g = c * JET + s;
            for i in 0..n {
                w.df[i * total + g] = w.f[i].d[s];
            }
            for (k, ok) in w.obs.iter().enumerate() {
                w.dobs[k * total + g] = ok.d[s];
            }
        }
    }
    rest(w);
    // y_k solves E_theta^T y_k = O_theta[k]^T
    for i in 0..n {
        for l in 0..n {
            w.ft[l * n + i] = w.df[i * total + l];
        }
    }
    for k in 0..task {
        w.rhs[k * n..(k + 1) * n].copy_from_slice(&w.dobs[k * total..k * total + n]);
    }
    if !solve_general_each(n, &w.ft, &w.rhs, &mut w.y) {
        return false;
    }
    // out[k][q] = dobs[k][n + q] - sum_i y[k][i] df[i][n + q], the terms
    // taken in order of i (row by row: the same numbers, each row of df read
    // whole)
    for k in 0..task {
        let o = &mut out[k * dirs..(k + 1) * dirs];
        o.copy_from_slice(&w.dobs[k * total + n..(k + 1) * total]);
        for i in 0..n {
            let yi = w.y[k * n + i];
            for (v, d) in o.iter_mut().zip(&w.df[i * total + n..(i + 1) * total]) {
                *v -= yi * *d;
            }
        }
    }
    true
}

/// Every command of a data set settled by one plant: the configurations,
/// observations and flags (the state a fit keeps between a trial and its
/// Jacobian).
#[derive(Debug, Clone, Default)]
pub struct Settled {
    theta: Vec<f64>,
    obs: Vec<f64>,
    ok: Vec<bool>,
    /// Per command, a code of [`REASONS`].
    reason: Vec<u8>,
}

/// The settled configurations and observations of every command of `seq`
/// for one plant (in parallel over the commands).
fn settle_all<G: Group>(
    plant: &Plant<G>,
    seq: &Sequence,
    opts: &SolveOptions,
    threads: usize,
) -> Settled {
    let n = seq.n;
    let m = seq.m;
    let task = <G::Frame<f64> as Frame<f64>>::TASK;
    let real = plant.realised(seq);
    let mobil = plant.mobilisation(seq);
    let h = mobil.len() / seq.len().max(1);
    let parts = split_rows(seq.len(), threads, |range| {
        let mut work = SettleWork::new(plant, *opts);
        let mut chain = Chain::new(plant.model);
        let mut th = vec![0.0; n];
        let mut o = vec![0.0; task];
        let mut out = Settled {
            theta: Vec::with_capacity(range.len() * n),
            obs: Vec::with_capacity(range.len() * task),
            ok: Vec::with_capacity(range.len()),
            reason: Vec::with_capacity(range.len()),
        };
        for j in range {
            let row = seq.row[j];
            th.copy_from_slice(&seq.theta_cmd[row * n..(row + 1) * n]);
            work.mobil.clear();
            work.mobil.extend_from_slice(&mobil[j * h..(j + 1) * h]);
            let ok = plant.settle(&real[j * m..(j + 1) * m], &mut th, &mut work);
            out.theta.extend_from_slice(&th);
            if ok {
                plant.observe(&th, &mut chain, &mut o);
                out.obs.extend_from_slice(&o);
            } else {
                out.obs.extend(std::iter::repeat_n(f64::NAN, task));
            }
            out.ok.push(ok);
            out.reason.push(if ok { 0 } else { NOT_SETTLED });
        }
        out
    });
    Settled::joined(parts)
}

impl Settled {
    /// The commands of `parts` in order, one after another.
    fn joined(parts: Vec<Settled>) -> Settled {
        let mut all = Settled::default();
        for p in parts {
            all.theta.extend(p.theta);
            all.obs.extend(p.obs);
            all.ok.extend(p.ok);
            all.reason.extend(p.reason);
        }
        all
    }

    fn new<G: Group>(
        plant: &Plant<G>,
        seq: &Sequence,
        opts: &SolveOptions,
        threads: usize,
    ) -> Self {
        if plant.model.is_elastic() && plant.prm.friction() {
            return elastic_friction::settle_all(plant, seq, opts, threads);
        }
        if plant.model.is_elastic() {
            return elastic_settle::settle_all(plant, seq, opts);
        }
        settle_all(plant, seq, opts, threads)
    }

    /// The rows' predictions (`task` observed components per row).
    fn predictions(&self, seq: &Sequence, task: usize) -> Predictions {
        let n = seq.n;
        let mut out = Predictions::default();
        for (i, [a, b]) in seq.span.iter().enumerate() {
            let conv = self.ok[*a] && self.ok[*b];
            let (oa, ob) = (
                &self.obs[a * task..(a + 1) * task],
                &self.obs[b * task..(b + 1) * task],
            );
            for k in 0..task {
                let v = match seq.reading[i] {
                    Reading::Absolute => ob[k],
                    Reading::Displacement => ob[k] - oa[k],
                    Reading::Unmeasured => f64::NAN,
                };
                out.observation.push(if conv { v } else { f64::NAN });
            }
            out.converged.push(conv);
            out.reason.push(if self.ok[*a] {
                self.reason[*b]
            } else {
                self.reason[*a]
            });
            out.theta
                .extend(self.theta[b * n..(b + 1) * n].iter().map(|t| {
                    if conv {
                        *t
                    } else {
                        f64::NAN
                    }
                }));
        }
        out
    }

    /// `(N, TASK, k)` derivatives of the rows' observations with respect to
    /// the parameters `free` (NaN rows where not defined); `plant` must be
    /// the one that settled.
    fn jacobian<G: Group>(
        &self,
        plant: &Plant<G>,
        seq: &Sequence,
        free: &[usize],
        threads: usize,
    ) -> Result<Vec<f64>> {
        self.jacobian_of(plant, seq, free, threads, None)
    }

    /// [`Settled::jacobian`] of the rows flagged in `rows` (`(N,)`; default
    /// all): the commands no such row reads are not derived (their rows
    /// NaN), except where friction carries a command's state to the next.
    fn jacobian_of<G: Group>(
        &self,
        plant: &Plant<G>,
        seq: &Sequence,
        free: &[usize],
        threads: usize,
        rows: Option<&[bool]>,
    ) -> Result<Vec<f64>> {
        let total = plant.p.len();
        if let Some(f) = free.iter().find(|f| **f >= total) {
            return Err(CdsmError::Option {
                name: "free".into(),
                problem: format!("parameter index {f} is beyond the {total} parameters"),
            });
        }
        let task = <G::Frame<f64> as Frame<f64>>::TASK;
        let kf = free.len();
        let mu_free = plant
            .lay
            .find(Effect::CableFriction)
            .is_some_and(|(o, _)| free.contains(&o));
        // the commands derived: those settled that a flagged row reads
        let mut ok = self.ok.clone();
        if let Some(rows) = rows.filter(|r| r.len() == seq.rows()) {
            let mut read = vec![false; ok.len()];
            for ([a, b], _) in seq.span.iter().zip(rows).filter(|(_, r)| **r) {
                read[*a] = true;
                read[*b] = true;
            }
            for (o, r) in ok.iter_mut().zip(read) {
                *o &= r;
            }
        }
        let dcmd = if plant.model.is_elastic() && (plant.prm.friction() || mu_free) {
            elastic_friction::command_derivatives(plant, seq, self, free, threads)
        } else if plant.model.is_elastic() {
            elastic_settle::command_derivatives(plant, seq, &self.theta, &ok, free, threads)
        } else {
            command_derivatives(plant, seq, &self.theta, &ok, free, threads)
        };
        let mut jac = vec![f64::NAN; seq.rows() * task * kf];
        for (i, [a, b]) in seq.span.iter().enumerate() {
            if !(ok[*a] && ok[*b]) || seq.reading[i] == Reading::Unmeasured {
                continue;
            }
            for c in 0..task {
                for q in 0..kf {
                    let vb = dcmd[(b * task + c) * kf + q];
                    jac[(i * task + c) * kf + q] = match seq.reading[i] {
                        Reading::Displacement => vb - dcmd[(a * task + c) * kf + q],
                        _ => vb,
                    };
                }
            }
        }
        Ok(jac)
    }
}

/// The derivatives `(commands, TASK, k)` of every command's observation
/// with respect to the parameters `free`, by the implicit function theorem
/// at the settled `theta` (NaN where a command did not settle).
fn command_derivatives<G: Group>(
    plant: &Plant<G>,
    seq: &Sequence,
    theta: &[f64],
    ok: &[bool],
    free: &[usize],
    threads: usize,
) -> Vec<f64> {
    derive_commands(plant, seq, theta, ok, free, threads, true)
}

/// [`command_derivatives`], the holes' coordinates apart ([`hole_columns`])
/// or (`holes_apart` false) all by full passes (the same numbers).
fn derive_commands<G: Group>(
    plant: &Plant<G>,
    seq: &Sequence,
    theta: &[f64],
    ok: &[bool],
    free: &[usize],
    threads: usize,
    holes_apart: bool,
) -> Vec<f64> {
    let (n, m) = (seq.n, seq.m);
    let model = plant.model;
    let task = <G::Frame<f64> as Frame<f64>>::TASK;
    let kf = free.len();
    // the free parameters in the order derived: those by full passes, then
    // the holes' coordinates (each moves only its own cable's geometry,
    // [`hole_cables`], [`hole_columns`])
    let cable_of = if holes_apart {
        hole_cables(plant, free)
    } else {
        vec![None; kf]
    };
    let mut order: Vec<usize> = (0..kf).filter(|q| cable_of[*q].is_none()).collect();
    let full = n + order.len();
    order.extend((0..kf).filter(|q| cable_of[*q].is_some()));
    let holes: Vec<usize> = order[full - n..]
        .iter()
        .filter_map(|q| cable_of[*q])
        .collect();
    // chunk c carries directions c*JET.. of theta_0..theta_{n-1}, then the
    // free parameters in `order` (the holes' chunks after the full ones).
    // No hole moves the realised lengths or the mobilisations: the holes'
    // chunks share their first one's (a jet's directions are independent,
    // so each of them would make the same numbers)
    let passes = full.div_ceil(JET);
    let chunks: Vec<(Params<J>, Vec<J>, Vec<J>)> = (0..passes + holes.len().div_ceil(JET))
        .map(|c| {
            // the directions g of chunk c's slots
            let first = if c < passes {
                c * JET
            } else {
                full + (c - passes) * JET
            };
            let end = if c < passes { full } else { n + kf };
            let prm = Params::<J>::unpack(model, &plant.lay, &plant.p, |i, v| {
                let mut d = [0.0; JET];
                for (s, x) in d.iter_mut().enumerate() {
                    let g = first + s;
                    if g >= n && g < end && free[order[g - n]] == i {
                        *x = 1.0;
                    }
                }
                J::with(v, d)
            });
            if c > passes {
                return (prm, Vec::new(), Vec::new());
            }
            let real = realised(seq, &prm, &plant.l_ref);
            let mobil = if prm.friction() {
                mobilisation(seq.motion::<G>(model), prm.mu, prm.friction_compliance())
            } else {
                Vec::new()
            };
            (prm, real, mobil)
        })
        .collect();
    let h = chunks[0].2.len() / seq.len().max(1);
    let parts = split_rows(seq.len(), threads, |range| {
        let mut out = vec![f64::NAN; range.len() * task * kf];
        let mut w = JetWork::<G>::new(model);
        let mut ordered = vec![0.0; task * kf];
        for (local, j) in range.enumerate() {
            if !ok[j] {
                continue;
            }
            let t0 = &theta[j * n..(j + 1) * n];
            let dst = &mut out[local * task * kf..(local + 1) * task * kf];
            let done = implicit_derivatives(
                model,
                t0,
                kf,
                full,
                |c| Chunk {
                    prm: &chunks[c].0,
                    real: &chunks[c].1[j * m..(j + 1) * m],
                    mobil: chunks[c].2.get(j * h..(j + 1) * h).unwrap_or(&[]),
                },
                |w| {
                    if !holes.is_empty() {
                        let at = (j, h);
                        hole_columns(
                            model,
                            &plant.cprm,
                            t0,
                            full,
                            &holes,
                            &chunks[passes..],
                            at,
                            w,
                        );
                    }
                },
                &mut w,
                &mut ordered,
            );
            if done {
                for k in 0..task {
                    for (r, q) in order.iter().enumerate() {
                        dst[k * kf + q] = ordered[k * kf + r];
                    }
                }
            } else {
                dst.fill(f64::NAN);
            }
        }
        out
    });
    parts.concat()
}

/// Per free parameter, the cable whose hole coordinate it is: a hole
/// coordinate moves only its own cable's length, row of the cable Jacobian
/// and, with statics, capstan profile and column of the balance
/// ([`hole_columns`]). `None` for the other parameters, and for every one
/// where a free cable elasticity or friction sits at zero: the passes that
/// carry it have statics and the others not, and the holes stay in the
/// full passes (the numbers as they were).
fn hole_cables<G: Group>(plant: &Plant<G>, free: &[usize]) -> Vec<Option<usize>> {
    let lay = &plant.lay;
    let idle = |e: Effect, v: f64| lay.find(e).is_some_and(|(o, _)| free.contains(&o)) && v == 0.0;
    let mixed =
        idle(Effect::CableElasticity, plant.prm.kappa) || idle(Effect::CableFriction, plant.prm.mu);
    let mut cable = vec![None; lay.total];
    if let (false, Some((o, _))) = (mixed, lay.find(Effect::HolePosition)) {
        let mut k = o;
        for c in commanded_cables(plant.model) {
            for _ in 0..3 * plant.model.cables[c].holes.len() {
                cable[k] = Some(c);
                k += 1;
            }
        }
    }
    free.iter().map(|i| cable[*i]).collect()
}

/// The columns `full..` of the equations' and observation's derivatives
/// (`w.df`, `w.dobs`) along hole coordinates (`cables`: each one's cable;
/// `chunks`: their seeded parameters, [`JET`] a chunk, the first one's
/// realised lengths and mobilisations those of every one) at `theta`, command `at.0` (`at.1` mobilisations a
/// command); `base`: the plant's parameters as constants. The holes move
/// no frame: the observation does not move, and one chain at `theta` serves
/// every hole coordinate. Without statics only the equations of the
/// coordinate's cable move, by the same jet arithmetic as [`equations`] on
/// the one cable (the other cables' terms are zero); with statics every
/// equation moves through the tensions, and each chunk makes again only its
/// cables' profiles and columns of the balance on the plant's, then the
/// same equations ([`cable_statics`], [`settled_equations`]). Either way
/// the full passes' numbers bit for bit.
#[allow(clippy::too_many_arguments)]
fn hole_columns<G: Group>(
    model: &Model,
    base: &Params<J>,
    theta: &[f64],
    full: usize,
    cables: &[usize],
    chunks: &[(Params<J>, Vec<J>, Vec<J>)],
    at: (usize, usize),
    w: &mut JetWork<G>,
) {
    let n = theta.len();
    let total = full + cables.len();
    let task = w.dobs.len() / total;
    let m = w.buf.pos.len();
    let (real_at, mobil_at) = (at.0 * m, at.0 * at.1..(at.0 + 1) * at.1);
    for (t, v) in w.theta.iter_mut().zip(theta) {
        *t = J::cst(*v);
    }
    for k in 0..task {
        w.dobs[k * total + full..(k + 1) * total].fill(0.0);
    }
    for i in 0..n {
        w.df[i * total + full..(i + 1) * total].fill(0.0);
    }
    let prm0 = &chunks[0].0;
    if !(prm0.elastic() || prm0.friction()) {
        return rigid_hole_columns(model, theta, full, cables, chunks, real_at, w);
    }
    let b = &mut w.buf;
    let kd = model.disks.len();
    b.chain.at(model, &base.arm, &w.theta);
    let mobil = chunks[0].2.get(mobil_at).unwrap_or(&[]);
    let real = &chunks[0].1[real_at..real_at + m];
    cable_statics(model, base, &w.loads, mobil, None, b);
    w.hole_bal.copy_from(&b.bal);
    w.hole_profile.gap.clone_from(&b.profile.gap);
    w.hole_profile.mean.clone_from(&b.profile.mean);
    w.hole_lengths.clone_from(&b.lengths);
    for (c, ch) in chunks.iter().enumerate() {
        let slots = &cables[c * JET..cables.len().min((c + 1) * JET)];
        w.hole_cables.clear();
        for cable in slots {
            if !w.hole_cables.contains(cable) {
                w.hole_cables.push(*cable);
            }
        }
        let prm = &ch.0;
        cable_statics(model, prm, &w.loads, mobil, Some(&w.hole_cables[..]), b);
        settled_equations(model, prm, real, b, &mut w.f);
        let first = full + c * JET;
        for s in 0..slots.len() {
            for i in 0..n {
                w.df[i * total + first + s] = w.f[i].d[s];
            }
        }
        // the plant's own again
        for &cable in &w.hole_cables {
            b.bal.restore_position(model, &w.hole_bal, cable);
            let g = cable * kd..(cable + 1) * kd;
            b.profile.gap[g.clone()].copy_from_slice(&w.hole_profile.gap[g]);
            b.profile.mean[cable] = w.hole_profile.mean[cable];
            if let Some(i) = b.pos.iter().position(|p| *p == cable) {
                b.lengths[i] = w.hole_lengths[i];
            }
        }
    }
}

/// [`hole_columns`] of a plant without statics (the columns zero on entry).
fn rigid_hole_columns<G: Group>(
    model: &Model,
    theta: &[f64],
    full: usize,
    cables: &[usize],
    chunks: &[(Params<J>, Vec<J>, Vec<J>)],
    real_at: usize,
    w: &mut JetWork<G>,
) {
    let total = full + cables.len();
    let b = &mut w.buf;
    let m = b.pos.len();
    let n = theta.len();
    let z = J::cst(0.0);
    // the holes move no frame: one chain (and clearance shift) for all
    let prm0 = &chunks[0].0;
    b.chain.at(model, &prm0.arm, &w.theta);
    let clear = prm0.clear();
    if clear {
        for (s, f) in b.shift.iter_mut().zip(&b.chain.local) {
            *s = f.bend_shift(prm0.clearance, prm0.width);
        }
    }
    let real = &chunks[0].1[real_at..real_at + m];
    for (c, (prm, _, _)) in chunks.iter().enumerate() {
        let slots = &cables[c * JET..cables.len().min((c + 1) * JET)];
        for (s, &cable) in slots.iter().enumerate() {
            // once per cable of the chunk
            if slots[..s].contains(&cable) {
                continue;
            }
            let Some(i) = b.pos.iter().position(|p| *p == cable) else {
                continue;
            };
            let len = b
                .chain
                .cable_length(model, &prm.arm, cable, clear.then_some(&b.shift[..]));
            let first = full + c * JET;
            let mine = |s2: usize| slots[s2] == cable;
            if m == n {
                let e = len - real[i] - z;
                for s2 in (0..slots.len()).filter(|s2| mine(*s2)) {
                    w.df[i * total + first + s2] = e.d[s2];
                }
            } else {
                b.chain
                    .cable_jacobian_row(model, &prm.arm, cable, &mut b.row);
                let f = len - real[i];
                for (jj, r) in b.row.iter().enumerate() {
                    let e = z + *r * f;
                    for s2 in (0..slots.len()).filter(|s2| mine(*s2)) {
                        w.df[jj * total + first + s2] = e.d[s2];
                    }
                }
            }
        }
    }
}

/// Observed components per row of a model's measurements: 3 planar, 6 spatial.
pub fn width(model: &Model) -> usize {
    model.kind.task()
}

/// Predictions of `K` parameter sets (`params (K, P)`) for the data set
/// `rows`; see [`Predictions`]. A parameter set outside the physical domain
/// predicts no row (all not converged).
pub fn predict(
    model: &Model,
    params: &[f64],
    rows: &Rows,
    opts: &SolveOptions,
    threads: usize,
) -> Result<Predictions> {
    model.kind.visit(Predict {
        model,
        params,
        rows,
        opts,
        threads,
    })
}

/// [`predict`] over the model's motion group.
struct Predict<'a> {
    model: &'a Model,
    params: &'a [f64],
    rows: &'a Rows<'a>,
    opts: &'a SolveOptions,
    threads: usize,
}

impl Visit for Predict<'_> {
    type Out = Result<Predictions>;
    fn visit<G: Group>(self) -> Self::Out {
        predict_k::<G>(self.model, self.params, self.rows, self.opts, self.threads)
    }
}

fn predict_k<G: Group>(
    model: &Model,
    params: &[f64],
    rows: &Rows,
    opts: &SolveOptions,
    threads: usize,
) -> Result<Predictions> {
    let n = model.n();
    let total = layout(model).total;
    let task = <G::Frame<f64> as Frame<f64>>::TASK;
    let k = rows_of("params", params, total)?;
    let seq = Sequence::new(model, rows)?;
    let mut out = Predictions::default();
    for j in 0..k {
        let p = &params[j * total..(j + 1) * total];
        match Plant::<G>::new(model, p) {
            Ok(plant) => {
                let pr = Settled::new(&plant, &seq, opts, threads).predictions(&seq, task);
                out.observation.extend(pr.observation);
                out.converged.extend(pr.converged);
                out.theta.extend(pr.theta);
                out.reason.extend(pr.reason);
            }
            Err(CdsmError::Option { .. }) => {
                out.observation
                    .extend(std::iter::repeat_n(f64::NAN, task * seq.rows()));
                out.converged.extend(std::iter::repeat_n(false, seq.rows()));
                out.reason
                    .extend(std::iter::repeat_n(NOT_PHYSICAL, seq.rows()));
                out.theta
                    .extend(std::iter::repeat_n(f64::NAN, n * seq.rows()));
            }
            Err(e) => return Err(e),
        }
    }
    Ok(out)
}

/// Predictions of one plant and their Jacobian with respect to the
/// parameters `free` (indices into the flat vector): `jacobian (N, TASK, k)`
/// (NaN rows where a command did not settle or its Jacobian is singular).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Linearised {
    pub predictions: Predictions,
    pub jacobian: Vec<f64>,
}

/// [`Linearised`] predictions of the plant `p` (flat) for the data set `rows`.
pub fn linearise(
    model: &Model,
    p: &[f64],
    free: &[usize],
    rows: &Rows,
    opts: &SolveOptions,
    threads: usize,
) -> Result<Linearised> {
    model.kind.visit(Linearise {
        model,
        p,
        free,
        rows,
        opts,
        threads,
    })
}

/// [`linearise`] over the model's motion group.
struct Linearise<'a> {
    model: &'a Model,
    p: &'a [f64],
    free: &'a [usize],
    rows: &'a Rows<'a>,
    opts: &'a SolveOptions,
    threads: usize,
}

impl Visit for Linearise<'_> {
    type Out = Result<Linearised>;
    fn visit<G: Group>(self) -> Self::Out {
        let s = self;
        linearise_k::<G>(s.model, s.p, s.free, s.rows, s.opts, s.threads)
    }
}

fn linearise_k<G: Group>(
    model: &Model,
    p: &[f64],
    free: &[usize],
    rows: &Rows,
    opts: &SolveOptions,
    threads: usize,
) -> Result<Linearised> {
    let seq = Sequence::new(model, rows)?;
    let plant = Plant::<G>::new(model, p)?;
    let settled = Settled::new(&plant, &seq, opts, threads);
    let task = <G::Frame<f64> as Frame<f64>>::TASK;
    let predictions = settled.predictions(&seq, task);
    let jacobian = settled.jacobian(&plant, &seq, free, threads)?;
    Ok(Linearised {
        predictions,
        jacobian,
    })
}

/// The plant of a model on one data set, for the diagnosis fit
/// ([`crate::fit`]): exact Jacobians by the implicit function theorem.
pub struct PlantFit<'a, G: Group> {
    pub model: &'a Model,
    pub seq: &'a Sequence,
    /// Settle options.
    pub opts: SolveOptions,
    /// Worker threads of the Jacobian (default 1: folds run in parallel;
    /// its rows are independent, the answer does not depend on them).
    pub threads: usize,
    pub _kind: std::marker::PhantomData<G>,
}

impl<'a, G: Group> PlantFit<'a, G> {
    pub fn new(model: &'a Model, seq: &'a Sequence, opts: SolveOptions) -> Self {
        PlantFit {
            model,
            seq,
            opts,
            threads: 1,
            _kind: std::marker::PhantomData,
        }
    }
}

impl<G: Group> FitModel for PlantFit<'_, G> {
    type State = Settled;

    fn rows(&self) -> usize {
        self.seq.rows()
    }

    fn width(&self) -> usize {
        <G::Frame<f64> as Frame<f64>>::TASK
    }

    fn weights(&self) -> Vec<f64> {
        let l = straight_length(self.model);
        let dim = <G::Frame<f64> as Frame<f64>>::DIM;
        (0..self.width())
            .map(|c| if c < dim { 1.0 } else { l })
            .collect()
    }

    fn params(&self) -> usize {
        layout(self.model).total
    }

    fn bounds(&self) -> (Vec<f64>, Vec<f64>) {
        bounds(self.model)
    }

    fn settle(&self, p: &[f64]) -> Option<Settled> {
        let plant = Plant::<G>::new(self.model, p).ok()?;
        Some(Settled::new(&plant, self.seq, &self.opts, 1))
    }

    fn predictions(&self, state: &Settled) -> Predictions {
        state.predictions(self.seq, self.width())
    }

    fn jacobian(
        &self,
        p: &[f64],
        state: &Settled,
        free: &[usize],
        rows: &[bool],
    ) -> Option<Vec<f64>> {
        let plant = Plant::<G>::new(self.model, p).ok()?;
        state
            .jacobian_of(&plant, self.seq, free, self.threads, Some(rows))
            .ok()
    }

    fn costly(&self) -> bool {
        self.model.is_elastic()
    }
}

/// Result of a batch of elastic cable solves.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ElasticSolution {
    pub solution: BatchSolution,
    /// `(N, m)` position-cable tensions at the answer (N).
    pub tension: Vec<f64>,
    /// Every position tension `> min_tension`.
    pub feasible: Vec<bool>,
}

/// Per-row or shared loads of a batch of elastic solves (validated by the
/// caller's shapes): `force` `(f,)` or `(N, f)` N, `wrench` `(3 + c,)` or
/// `(N, 3 + c)` (`c` = 1 planar, 3 spatial), `gravity` (m/s²).
#[derive(Debug, Clone, Copy, Default)]
pub struct LoadRows<'a> {
    pub force: Option<&'a [f64]>,
    pub wrench: Option<&'a [f64]>,
    pub gravity: Option<[f64; 3]>,
}

/// The coupled elastic cable solve of a batch (`docs/model.md`,
/// "Statics"): commanded (unstretched) lengths `(N, m)` of the position
/// cables (m) to the configuration where the cables, stretched under their
/// tensions (`E A` of the robot file's cable: the plant's equations with
/// `kappa = 1/(E A)` and no other effect), hold the arm under the loads;
/// `seed (N, n)` or zeros (the rigid solve first). With the tensions at the
/// answer (the balance's, or Hooke's where the cables outnumber the joints)
/// and whether each is above `min_tension` (N).
pub fn solve_elastic(
    model: &Model,
    lengths: &[f64],
    seed: Option<&[f64]>,
    loads: &LoadRows,
    min_tension: f64,
    opts: &SolveOptions,
    threads: usize,
) -> Result<ElasticSolution> {
    model.kind.visit(SolveElastic {
        model,
        lengths,
        seed,
        loads,
        min_tension,
        opts,
        threads,
    })
}

/// [`solve_elastic`] over the model's motion group.
struct SolveElastic<'a> {
    model: &'a Model,
    lengths: &'a [f64],
    seed: Option<&'a [f64]>,
    loads: &'a LoadRows<'a>,
    min_tension: f64,
    opts: &'a SolveOptions,
    threads: usize,
}

impl Visit for SolveElastic<'_> {
    type Out = Result<ElasticSolution>;
    fn visit<G: Group>(self) -> Self::Out {
        let s = self;
        solve_elastic_k::<G>(
            s.model,
            s.lengths,
            s.seed,
            s.loads,
            s.min_tension,
            s.opts,
            s.threads,
        )
    }
}

fn solve_elastic_k<G: Group>(
    model: &Model,
    lengths: &[f64],
    seed: Option<&[f64]>,
    loads: &LoadRows,
    min_tension: f64,
    opts: &SolveOptions,
    threads: usize,
) -> Result<ElasticSolution> {
    let (n, m) = (model.n(), model.position_cables().len());
    let rows = rows_of("lengths", lengths, m)?;
    let seed = seeds(seed, rows, n)?;
    opts.check()?;
    if !min_tension.is_finite() {
        return Err(CdsmError::Option {
            name: "min_tension".into(),
            problem: format!("must be finite, got {min_tension}"),
        });
    }
    let nf = model.cables.len() - m;
    let cw = 3 + model.kind.task() - model.kind.dim();
    let force_rows = shared_or_rows("lower", loads.force, nf, rows)?;
    let wrench_rows = shared_or_rows("tip_wrench", loads.wrench, cw, rows)?;
    if let Some(g) = loads.gravity {
        crate::error::check_finite("gravity", &g)?;
    }
    let kappa = model.cable.compliance();
    let lay = layout(model);
    let mut p = vec![0.0; lay.total];
    if model.redundant_settle() != Some(RedundantSettle::Potential) {
        // a redundant arm on its stated cable: the plant's settle
        // stretches the file's cable itself (`Params::kappa`)
        p[lay
            .find(Effect::CableElasticity)
            .expect("every kind has elasticity")
            .0] = kappa;
    }
    let plant = Plant::<G>::new(model, &p)?;
    let route = model.cable.routing_length;
    let parts = split_rows(rows, threads, |r| {
        let mut out = ElasticSolution::default();
        let mut work = SettleWork::new(&plant, *opts);
        work.lambda0 = crate::lm::LAMBDA_RESTART;
        let mut chain = Chain::<f64, G::Frame<f64>>::new(model);
        let mut bal = Balance::<f64>::new(model);
        let (mut th, mut t) = (vec![0.0; n], vec![0.0; m]);
        let limits = model.limits();
        for i in r {
            match seed {
                Some(s) => th.copy_from_slice(&s[i * n..(i + 1) * n]),
                None => th.fill(0.0),
            }
            let force = row_of(force_rows, nf, i);
            let wrench = row_of(wrench_rows, cw, i);
            work.loads = Loads {
                gravity: loads.gravity.unwrap_or(model.gravity),
                force: force.map(|f| f.to_vec()),
                wrench: std::array::from_fn(|k| {
                    wrench.and_then(|w| w.get(k).copied()).unwrap_or(0.0)
                }),
            };
            let target = &lengths[i * m..(i + 1) * m];
            let st = plant.settle_status(target, &mut th, &mut work);
            // the tensions at the answer
            chain.at(model, model, &th);
            let w = work.loads.wrench;
            bal.at_with(
                model,
                model,
                &mut chain,
                work.loads.gravity,
                Wrench {
                    force: [w[0], w[1], w[2]],
                    couple: &w[3..cw],
                },
                force,
            );
            if m == n {
                if !bal.solve_square(&mut t) {
                    t.fill(f64::NAN);
                }
            } else {
                for (k, tk) in t.iter_mut().enumerate() {
                    let s = (bal.lengths[model.position_cables()[k]] + route) / (target[k] + route)
                        - 1.0;
                    *tk = s.max(0.0) / kappa;
                }
            }
            out.solution.push_row(&th, st, limits.contains(&th));
            out.tension.extend_from_slice(&t);
            out.feasible.push(t.iter().all(|v| *v > min_tension));
        }
        out
    });
    let mut all = ElasticSolution::default();
    for p in parts {
        all.solution.extend(p.solution);
        all.tension.extend(p.tension);
        all.feasible.extend(p.feasible);
    }
    Ok(all)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinds::{Kind, Planar, Spatial};
    use crate::robot::PlanarView;

    const TWO_UNIVERSAL: &str = include_str!("../python/cdsm/robots/two_universal.toml");

    /// Every packaged robot file.
    const PACKAGED: [&str; 8] = [
        include_str!("../python/cdsm/robots/paper.toml"),
        include_str!("../python/cdsm/robots/paper_reversed_weights.toml"),
        include_str!("../python/cdsm/robots/paper_vertical.toml"),
        include_str!("../python/cdsm/robots/paper_vertical_reversed_weights.toml"),
        include_str!("../python/cdsm/robots/serpentine8.toml"),
        include_str!("../python/cdsm/robots/two_universal.toml"),
        include_str!("../python/cdsm/robots/paper_spatial.toml"),
        include_str!("../python/cdsm/robots/sjtu_snake.toml"),
    ];

    /// The layout is the parameter vector's meaning (model files, the
    /// library's search order): the kind's table must give the blocks the
    /// plant had before the kind was data, written out here as they were.
    #[test]
    fn layout_from_the_kind_table_is_the_blocks_of_before() {
        use Effect::*;
        for text in PACKAGED {
            let model = Model::from_toml(text).unwrap();
            let (n, k) = (model.n(), model.disks.len());
            let m = model.position_cables().len();
            let want: Vec<(Effect, usize)> = if model.kind == Kind::Planar {
                vec![
                    (ActuationScale, 1),
                    (CableOffset, m),
                    (HoleHeight, k),
                    (LinkLength, n + 1),
                    (CableElasticity, 1),
                    (HoleClearance, 1),
                    (FrameMisalignment, 3),
                    (TipOffset, 2),
                    (Backlash, m),
                    (ClearanceWidth, 1),
                    (CableFriction, 1),
                ]
            } else {
                let holes: usize = model
                    .position_cables()
                    .iter()
                    .map(|c| model.cables[*c].holes.len())
                    .sum();
                vec![
                    (ActuationScale, 1),
                    (CableOffset, m),
                    (HolePosition, 3 * holes),
                    (LinkLength, 3 * (n + k)),
                    (CableElasticity, 1),
                    (FrameMisalignment, 6),
                    (TipOffset, 3),
                    (Backlash, m),
                    (HoleClearance, 1),
                    (ClearanceWidth, 1),
                    (JointAxis, 2 * n),
                    (CableFriction, 1),
                ]
            };
            let lay = layout(&model);
            let got: Vec<(Effect, usize)> = lay.blocks.iter().map(|b| (b.0, b.2)).collect();
            assert_eq!(got, want, "{}", model.name);
            assert_eq!(lay.total, want.iter().map(|b| b.1).sum::<usize>());
            assert_eq!(parameters(&model).len(), lay.total);
        }
    }

    /// The planar hole groups of the model's structure move the holes as the
    /// plant's `hole_height` effect does: group `g`'s error on disk `g + 1`.
    #[test]
    fn planar_hole_groups_are_the_hole_height_effect() {
        for text in &PACKAGED[..5] {
            let model = Model::from_toml(text).unwrap();
            let groups = model.structure().hole_groups;
            let lay = layout(&model);
            let (o, s) = lay.find(Effect::HoleHeight).unwrap();
            assert_eq!(groups.len(), s);
            for (g, group) in groups.iter().enumerate() {
                assert!(group.coherent);
                let mut p = vec![0.0; lay.total];
                p[o + g] = 1e-3 * (g + 1) as f64;
                let moved = Params::<f64>::unpack(&model, &lay, &p, |_, v| v).arm.holes;
                let mut want = model.flat_holes();
                for (i, c) in group.coords.iter().zip(&group.coefs) {
                    want[*i] += c * p[o + g];
                }
                let got: Vec<f64> = moved.iter().flatten().flatten().copied().collect();
                assert_eq!(got, want, "{} disk {}", model.name, g + 1);
            }
        }
    }

    fn data(n: usize, m: usize, rows: usize) -> (Vec<f64>, Vec<f64>, Vec<Reading>) {
        let mut th = Vec::new();
        let mut dl = Vec::new();
        let mut reading = Vec::new();
        for i in 0..rows {
            let a = i as f64 * 0.37;
            for j in 0..n {
                th.push(0.35 * (a * (1.0 + 0.3 * j as f64) + j as f64).sin());
            }
            for k in 0..m {
                dl.push(if (i + k) % 3 == 0 {
                    8e-4 * (1.7 * a + k as f64).cos()
                } else {
                    0.0
                });
            }
            reading.push(match i % 4 {
                1 => Reading::Displacement,
                3 => Reading::Unmeasured,
                _ => Reading::Absolute,
            });
        }
        (th, dl, reading)
    }

    /// A parameter vector with every effect of the model's layout at a small size.
    fn every_effect(model: &Model) -> Vec<f64> {
        let lay = layout(model);
        let mut p = vec![0.0; lay.total];
        for &(e, o, s) in &lay.blocks {
            for i in 0..s {
                let wiggle = 1.0 + 0.3 * ((i * 7 + o) as f64).sin();
                p[o + i] = wiggle
                    * match e {
                        Effect::ActuationScale => 0.01,
                        Effect::CableOffset => 1e-4,
                        Effect::HoleHeight => 2e-4,
                        Effect::HolePosition => 5e-5,
                        Effect::LinkLength => -3e-4,
                        Effect::CableElasticity => 2e-3,
                        Effect::HoleClearance => 1e-4,
                        Effect::ClearanceWidth => 0.005,
                        Effect::FrameMisalignment => 3e-3,
                        Effect::TipOffset => 5e-4,
                        Effect::Backlash => 3e-5,
                        Effect::JointAxis => 4e-3,
                        Effect::CableFriction => 0.2,
                        Effect::JointStiffness => 0.05,
                        Effect::CableAngle => 0.01,
                    };
            }
        }
        p
    }

    fn planar() -> Model {
        Model::from_planar(&PlanarView::paper())
    }

    #[test]
    fn the_rigid_settle_solves_by_the_planar_evaluator_where_the_arm_has_a_planar_view() {
        // its settle's triangular step rests on the planar evaluator
        let m = planar();
        let plant = Plant::<Planar>::new(&m, &vec![0.0; layout(&m).total]).unwrap();
        assert!(SettleWork::new(&plant, SolveOptions::default())
            .rigid
            .is_planar());
        let s = Model::from_toml(TWO_UNIVERSAL).unwrap();
        let plant = Plant::<Spatial>::new(&s, &vec![0.0; layout(&s).total]).unwrap();
        assert!(!SettleWork::new(&plant, SolveOptions::default())
            .rigid
            .is_planar());
    }

    /// FTDCR v4: three segments of 20 joints (its tendons end at stations
    /// 10, 20, 30), its nine tendons commanded; every parameter labelled.
    #[test]
    fn an_elastic_arm_has_its_segments_and_commanded_cables() {
        let m = Model::from_toml(include_str!("../tests/data/opencr/ftdcr_v4.toml")).unwrap();
        assert_eq!(segments(&m), vec![0..20, 20..40, 40..60]);
        assert_eq!(commanded_cables(&m), (0..9).collect::<Vec<_>>());
        let lay = layout(&m);
        assert_eq!(lay.find(Effect::JointStiffness).map(|b| b.1), Some(3));
        assert_eq!(lay.find(Effect::CableAngle).map(|b| b.1), Some(9));
        assert_eq!(lay.find(Effect::CableOffset).map(|b| b.1), Some(9));
        assert_eq!(
            lay.blocks.last().map(|b| (b.0, b.2)),
            Some((Effect::CableFriction, 1))
        );
        assert_eq!(parameters(&m).len(), lay.total);
    }

    #[test]
    fn every_parameter_has_a_label_and_a_unit_in_layout_order() {
        for m in [planar(), Model::from_toml(TWO_UNIVERSAL).unwrap()] {
            let (lay, ps) = (layout(&m), parameters(&m));
            assert_eq!(ps.len(), lay.total);
            for &(e, o, s) in &lay.blocks {
                assert!(ps[o..o + s].iter().all(|p| p.effect == e), "{}", e.name());
                let labels: std::collections::HashSet<_> =
                    ps[o..o + s].iter().map(|p| &p.label).collect();
                assert_eq!(labels.len(), s, "{}: labels repeat", e.name());
            }
        }
        let ps = parameters(&planar());
        let of = |e: Effect| -> Vec<(String, &'static str)> {
            ps.iter()
                .filter(|p| p.effect == e)
                .map(|p| (p.label.clone(), p.unit.symbol()))
                .collect()
        };
        // the upper cables are cables 1, 3, 5 of the paper robot
        assert_eq!(
            of(Effect::CableOffset)[1],
            ("cable 3 (to disk 2)".into(), "m")
        );
        assert_eq!(of(Effect::LinkLength)[0], ("base → joint 1".into(), "m"));
        assert_eq!(of(Effect::LinkLength)[3], ("joint 3 → disk 3".into(), "m"));
        assert_eq!(of(Effect::FrameMisalignment)[0].1, "rad");
        assert_eq!(of(Effect::CableFriction)[0].1, "1");
        assert_eq!(of(Effect::CableElasticity)[0].1, "1/N");
        let ps = parameters(&Model::from_toml(TWO_UNIVERSAL).unwrap());
        let holes: Vec<_> = ps
            .iter()
            .filter(|p| p.effect == Effect::HolePosition)
            .map(|p| p.label.as_str())
            .collect();
        // cable 1 ends at disk 1: base face b, disk 1 faces a and b
        assert_eq!(
            holes[..9],
            [
                "cable 1, base face b, x",
                "cable 1, base face b, y",
                "cable 1, base face b, z",
                "cable 1, disk 1 face a, x",
                "cable 1, disk 1 face a, y",
                "cable 1, disk 1 face a, z",
                "cable 1, disk 1 face b, x",
                "cable 1, disk 1 face b, y",
                "cable 1, disk 1 face b, z",
            ]
        );
        let axis: Vec<_> = ps
            .iter()
            .filter(|p| p.effect == Effect::JointAxis)
            .collect();
        assert_eq!((axis.len(), axis[0].unit), (8, Unit::Radian));
    }

    #[test]
    fn zero_parameters_are_the_nominal_model() {
        let r = PlanarView::paper();
        let m = planar();
        let (th, dl, _) = data(3, 3, 2);
        let reading = [Reading::Absolute; 2];
        let o = SolveOptions::default();
        let rows = Rows {
            theta_cmd: &th,
            dl: &dl,
            reading: &reading,
        };
        let pr = predict(&m, &vec![0.0; layout(&m).total], &rows, &o, 1).unwrap();
        assert!(pr.converged.iter().all(|x| *x));
        for i in 0..2 {
            let t = &th[3 * i..3 * i + 3];
            let (dev, _) = crate::accuracy::deviation(
                &Model::from_planar(&r),
                t,
                &dl[3 * i..3 * i + 3],
                None,
                CableMethod::Auto,
                &o,
                1,
            )
            .unwrap();
            let p0 = crate::geometry::ArmGeometry::<f64>::fk(&r, t);
            for q in 0..3 {
                assert!((pr.observation[3 * i + q] - (p0[q] + dev[q])).abs() < 1e-12);
            }
        }
        let s = Model::from_toml(TWO_UNIVERSAL).unwrap();
        let (th, _, _) = data(4, 4, 3);
        let dl = vec![0.0; 12];
        let reading = [Reading::Absolute; 3];
        let rows = Rows {
            theta_cmd: &th,
            dl: &dl,
            reading: &reading,
        };
        let pr = predict(&s, &vec![0.0; layout(&s).total], &rows, &o, 1).unwrap();
        let want = crate::arm::fk(&s, &th, 1).unwrap();
        for (a, b) in pr.observation.iter().zip(&want) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
    }

    #[test]
    fn planar_jet_jacobian_matches_central_differences_of_the_predictions() {
        // every effect at once, on absolute and displacement rows, with backlash
        let m = planar();
        let (th, dl, reading) = data(3, 3, 8);
        check_jacobian(&m, &th, &dl, &reading, (0..layout(&m).total).collect());
    }

    #[test]
    fn frame_translation_cancels_in_displacements() {
        for m in [planar(), Model::from_toml(TWO_UNIVERSAL).unwrap()] {
            let lay = layout(&m);
            let (o, s) = lay.find(Effect::FrameMisalignment).unwrap();
            let mut p = vec![0.0; lay.total];
            for k in s - m.kind.dim()..s {
                p[o + k] = 0.01 * (k as f64 + 1.0);
            }
            let (th, mut dl, _) = data(m.n(), m.position_cables().len(), 1);
            dl[0] = -1e-3;
            let reading = [Reading::Displacement];
            let rows = Rows {
                theta_cmd: &th,
                dl: &dl,
                reading: &reading,
            };
            let opts = SolveOptions::default();
            let a = predict(&m, &vec![0.0; lay.total], &rows, &opts, 1).unwrap();
            let b = predict(&m, &p, &rows, &opts, 1).unwrap();
            for (x, y) in a.observation.iter().zip(&b.observation) {
                assert!((x - y).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn a_reversal_loses_the_whole_dead_band() {
        // cable 1 commanded +1 mm then back: the second move delivers 2b less
        let m = planar();
        let lay = layout(&m);
        let mut p = vec![0.0; lay.total];
        p[lay.find(Effect::Backlash).unwrap().0] = 3e-5;
        let plant = Plant::<Planar>::new(&m, &p).unwrap();
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
        let m = planar();
        let lay = layout(&m);
        let mut p = vec![0.0; lay.total];
        p[lay.find(Effect::LinkLength).unwrap().0 + 1] = -1.0; // a negative link
        let th = [0.2, -0.3, 0.25];
        let rows = Rows {
            theta_cmd: &th,
            dl: &[0.0; 3],
            reading: &[Reading::Absolute],
        };
        let pr = predict(&m, &p, &rows, &SolveOptions::default(), 1).unwrap();
        assert!(!pr.converged[0] && pr.observation[0].is_nan());
    }

    #[test]
    fn the_elastic_solve_meets_its_equation_and_moves_a_steel_arm_a_little() {
        let r = PlanarView::paper();
        let m = planar();
        let th0 = [0.2, -0.3, 0.25];
        let cmd = position_lengths(&m, &th0);
        let out = solve_elastic(
            &m,
            &cmd,
            Some(&th0),
            &LoadRows::default(),
            0.0,
            &SolveOptions::default(),
            1,
        )
        .unwrap();
        assert!(out.solution.converged[0] && out.feasible[0]);
        let th = &out.solution.theta[..3];
        // the stretched cables let the arm move a little (steel: < 1 mrad)
        let moved = th
            .iter()
            .zip(th0)
            .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
        assert!(moved > 1e-7 && moved < 1e-3, "{moved}");
        // L_geom = L_cmd (1 + T / (E A)) per upper cable
        let lg = position_lengths(&m, th);
        let d = r.cable.diameter;
        let ea = r.cable.youngs_modulus * std::f64::consts::PI * d * d / 4.0;
        for i in 0..3 {
            assert!((lg[i] - cmd[i] * (1.0 + out.tension[i] / ea)).abs() < 1e-12);
        }
    }

    /// The jets' Jacobian of the predictions against central differences
    /// (one-sided at a lower bound), for the parameters `free` of
    /// [`every_effect`].
    fn check_jacobian(m: &Model, th: &[f64], dl: &[f64], reading: &[Reading], free: Vec<usize>) {
        check_jacobian_at(m, &every_effect(m), th, dl, reading, free);
    }

    /// [`check_jacobian`] at the parameters `p`.
    fn check_jacobian_at(
        m: &Model,
        p: &[f64],
        th: &[f64],
        dl: &[f64],
        reading: &[Reading],
        free: Vec<usize>,
    ) {
        let rows = Rows {
            theta_cmd: th,
            dl,
            reading,
        };
        let o = SolveOptions::default();
        let p = p.to_vec();
        let w = width(m);
        let lin = linearise(m, &p, &free, &rows, &o, 1).unwrap();
        let (lo, _) = bounds(m);
        let h = 1e-7;
        for (q, &f) in free.iter().enumerate() {
            let step = h * (1.0 + p[f].abs() * 100.0);
            let (mut a, mut b) = (p.clone(), p.clone());
            a[f] += step;
            let central = p[f] - step >= lo[f];
            if central {
                b[f] -= step;
            }
            let div = if central { 2.0 * step } else { step };
            let pa = predict(m, &a, &rows, &o, 1).unwrap();
            let pb = predict(m, &b, &rows, &o, 1).unwrap();
            for (i, k) in reading.iter().enumerate() {
                if !lin.predictions.converged[i] || *k == Reading::Unmeasured {
                    continue;
                }
                for c in 0..w {
                    let fd = (pa.observation[i * w + c] - pb.observation[i * w + c]) / div;
                    let an = lin.jacobian[(i * w + c) * free.len() + q];
                    assert!(
                        (fd - an).abs() < 1e-5 * (1.0 + an.abs()),
                        "param {f} row {i} comp {c}: fd {fd} vs jets {an}"
                    );
                }
            }
        }
    }

    #[test]
    fn elastic_adjoint_jacobian_matches_central_differences_of_the_predictions() {
        // the FTDCR v4 (60 joints, 9 displacement tendons), every effect of
        // its layout at once but friction (chunks of arm, lengths and
        // observation directions mixed: the frictionless adjoint), tendons
        // pulled and paid out (slack ones too)
        let m = Model::from_toml(include_str!("../tests/data/opencr/ftdcr_v4.toml")).unwrap();
        assert!(m.is_elastic());
        let lay = layout(&m);
        let mut p = every_effect(&m);
        let friction = lay.find(Effect::CableFriction).map_or(lay.total, |b| b.0);
        p[friction..].iter_mut().for_each(|v| *v = 0.0);
        let (_, dl, reading) = data(m.n(), m.cables.len(), 3);
        let th = vec![0.0; 3 * m.n()];
        let free = (0..lay.total)
            .filter(|i| *i < friction)
            .step_by(2)
            .collect();
        check_jacobian_at(&m, &p, &th, &dl, &reading, free);
    }

    /// A rigid plant without statics, with hole errors (and clearance, a
    /// moved frame, backlash ...): every effect but elasticity and friction.
    fn rigid_with_hole_errors(m: &Model) -> Vec<f64> {
        let lay = layout(m);
        let mut p = every_effect(m);
        for e in [Effect::CableElasticity, Effect::CableFriction] {
            if let Some((o, s)) = lay.find(e) {
                p[o..o + s].fill(0.0);
            }
        }
        p
    }

    /// The holes' columns apart ([`hole_columns`]) are the full passes'
    /// numbers bit for bit at the parameters `p`, every free parameter of
    /// `free` at once (hole coordinates sharing chunks with the others and
    /// with each other), and they do go apart; at least `min_ok` commands
    /// settled (those that did not: NaN both ways).
    fn holes_apart_are_the_full_passes_at(
        m: &Model,
        p: &[f64],
        free: &[usize],
        rows: usize,
        min_ok: usize,
    ) {
        let (th, dl, reading) = data(m.n(), commanded_cables(m).len(), rows);
        let rows = Rows {
            theta_cmd: &th,
            dl: &dl,
            reading: &reading,
        };
        let seq = Sequence::new(m, &rows).unwrap();
        let plant = Plant::<Spatial>::new(m, p).unwrap();
        let settled = Settled::new(&plant, &seq, &SolveOptions::default(), 1);
        let ok = settled.ok.iter().filter(|o| **o).count();
        assert!(ok >= min_ok, "{ok} of {} commands settled", seq.len());
        let (o, s) = layout(m).find(Effect::HolePosition).unwrap();
        let holes = |f: &usize| (o..o + s).contains(f);
        let apart = hole_cables(&plant, free);
        for (f, c) in free.iter().zip(&apart) {
            assert_eq!(holes(f), c.is_some(), "parameter {f} apart: {c:?}");
        }
        let args = (&plant, &seq, &settled.theta, &settled.ok, free, 1);
        let apart = derive_commands(args.0, args.1, args.2, args.3, args.4, args.5, true);
        let whole = derive_commands(args.0, args.1, args.2, args.3, args.4, args.5, false);
        assert_eq!(apart.len(), whole.len());
        assert!(free.iter().filter(|f| holes(f)).count() == s);
        let mut moved = 0;
        let per = apart.len() / seq.len();
        for (k, (a, b)) in apart.iter().zip(&whole).enumerate() {
            if !settled.ok[k / per] {
                assert!(a.is_nan() && b.is_nan());
                continue;
            }
            assert!(a.is_finite(), "entry {k}: {a}");
            assert!(a == b, "entry {k}: holes apart {a} vs full passes {b}");
            if holes(&free[k % free.len()]) && *a != 0.0 {
                moved += 1;
            }
        }
        assert!(moved > 0);
    }

    /// Every parameter of `m` but those of `idle` (their values zeroed in
    /// `p`), the holes first, in between and last.
    fn all_free_but(m: &Model, p: &mut [f64], idle: &[Effect]) -> Vec<usize> {
        let lay = layout(m);
        let (o, s) = lay.find(Effect::HolePosition).unwrap();
        let mut rest = Vec::new();
        for &(e, eo, es) in &lay.blocks {
            if idle.contains(&e) {
                p[eo..eo + es].fill(0.0);
            } else if e != Effect::HolePosition {
                rest.extend(eo..eo + es);
            }
        }
        (o..o + s)
            .step_by(2)
            .chain(rest)
            .chain((o + 1..o + s).step_by(2))
            .collect()
    }

    /// [`holes_apart_are_the_full_passes_at`] of a plant without statics
    /// (hole errors, clearance, a moved frame, backlash ...).
    fn holes_apart_are_the_full_passes(text: &str) {
        let m = Model::from_toml(text).unwrap();
        let mut p = every_effect(&m);
        let idle = [Effect::CableElasticity, Effect::CableFriction];
        let free = all_free_but(&m, &mut p, &idle);
        assert_eq!(p, rigid_with_hole_errors(&m));
        holes_apart_are_the_full_passes_at(&m, &p, &free, 3, 4);
    }

    #[test]
    fn hole_columns_apart_are_the_full_passes_on_two_universal() {
        holes_apart_are_the_full_passes(TWO_UNIVERSAL);
    }

    #[test]
    fn hole_columns_apart_are_the_full_passes_with_more_cables_than_joints() {
        // the packaged file states no cable: the least-squares settle
        let sjtu = include_str!("../python/cdsm/robots/sjtu_snake.toml");
        holes_apart_are_the_full_passes(sjtu);
    }

    #[test]
    fn hole_columns_apart_are_the_full_passes_on_a_stated_redundant_cable() {
        // stated 1 mm steel cables (the settle at the potential; on the
        // default 0.18 mm cable the snake would fold under its weight),
        // without clearance (with it the redundant
        // arm's settle is the damped Newton on the balance, which fails
        // where cables go slack): `docs/model.md`, "Settling"
        let sjtu = format!(
            "{}\n[cable]\nyoungs_modulus = 1.8e11\ndiameter = 1e-3\n",
            include_str!("../python/cdsm/robots/sjtu_snake.toml")
        );
        let m = Model::from_toml(&sjtu).unwrap();
        let mut p = every_effect(&m);
        let idle = [
            Effect::CableElasticity,
            Effect::CableFriction,
            Effect::HoleClearance,
        ];
        let free = all_free_but(&m, &mut p, &idle);
        holes_apart_are_the_full_passes_at(&m, &p, &free, 3, 3);
    }

    /// The 8-joint spatial arm of `benches/bench_scale.py` (`spatial_toml(4)`):
    /// four sections of two joints, each with two position and two force
    /// cables ending at its disk.
    fn eight_joint_arm() -> Model {
        let mut t = String::from(
            "kind = \"spatial\"\nname = \"generated spatial arm, 8 joints\"\n\
             gravity = [0.0, 0.0, -9.80665]\n\n[base]\nradius = 0.03\n\n",
        );
        for _ in 0..4 {
            t += "[[linkage]]\njoints = [\n\
                  { axis = [0.0, 1.0, 0.0], offset = [0.015, 0.0, 0.0], limits = [-0.6, 0.6] },\n\
                  { axis = [0.0, 0.0, 1.0], offset = [0.0, 0.0, 0.0], limits = [-0.6, 0.6] },\n]\n\
                  link_after = [0.015, 0.0, 0.0]\nthickness = 0.005\nradius = 0.03\n\
                  mass = 0.015\ncom = [0.0025, 0.0, 0.0]\n\n";
        }
        for s in 0..4 {
            let r = 0.028 - 0.002 * s as f64;
            for (k, mode) in ["position", "position", "force", "force"]
                .iter()
                .enumerate()
            {
                let angle = k as f64 * std::f64::consts::PI / 2.0;
                t += &format!(
                    "[[cables]]\nend = {}\nmode = \"{mode}\"\nradius = {r:.4}\nangle = {angle:?}\n",
                    s + 1
                );
                if *mode == "force" {
                    t += "tension = 1.0\n";
                }
                t += "\n";
            }
        }
        Model::from_toml(&t).unwrap()
    }

    #[test]
    fn hole_columns_apart_are_the_full_passes_on_the_eight_joint_arm() {
        let m = eight_joint_arm();
        assert_eq!((m.n(), m.position_cables().len()), (8, 8));
        assert_eq!(layout(&m).find(Effect::HolePosition).unwrap().1, 144);
        let mut p = every_effect(&m);
        let free = all_free_but(
            &m,
            &mut p,
            &[Effect::CableElasticity, Effect::CableFriction],
        );
        holes_apart_are_the_full_passes_at(&m, &p, &free, 3, 4);
    }

    /// With statics (a stretching cable, friction in the holes, with and
    /// without clearance) a hole coordinate moves every equation through
    /// the tensions: its columns apart are still the full passes' numbers
    /// bit for bit, on arms with as many position cables as joints and more.
    #[test]
    fn hole_columns_with_statics_apart_are_the_full_passes() {
        use Effect::{CableElasticity as Kappa, CableFriction as Mu, HoleClearance as Clear};
        let arms = [
            Model::from_toml(TWO_UNIVERSAL).unwrap(),
            Model::from_toml(include_str!("../python/cdsm/robots/paper_spatial.toml")).unwrap(),
            eight_joint_arm(),
        ];
        for m in &arms {
            // elastic; elastic with friction and clearance; friction alone
            for idle in [&[Mu, Clear][..], &[], &[Kappa, Clear]] {
                let mut p = every_effect(m);
                let free = all_free_but(m, &mut p, idle);
                let plant = Plant::<Spatial>::new(m, &p).unwrap();
                assert!(plant.prm.elastic() || plant.prm.friction());
                holes_apart_are_the_full_passes_at(m, &p, &free, 3, 4);
            }
        }
    }

    #[test]
    fn hole_columns_with_statics_and_more_cables_than_joints_are_the_full_passes() {
        // two_universal with force cables position-controlled: 6 on 4 joints
        let text = TWO_UNIVERSAL.replace("mode = \"force\"\ntension = 1.0", "mode = \"position\"");
        let m = Model::from_toml(&text).unwrap();
        assert_eq!((m.n(), m.position_cables().len()), (4, 6));
        let keep = [Effect::CableElasticity, Effect::HolePosition];
        let lay = layout(&m);
        let idle: Vec<Effect> = lay
            .blocks
            .iter()
            .map(|b| b.0)
            .filter(|e| !keep.contains(e))
            .collect();
        let mut p = every_effect(&m);
        let free = all_free_but(&m, &mut p, &idle);
        holes_apart_are_the_full_passes_at(&m, &p, &free, 6, 2);
    }

    /// A free cable elasticity or friction at zero has statics in the
    /// passes that carry it and none in the others: the holes stay in the
    /// full passes.
    #[test]
    fn holes_stay_in_the_full_passes_beside_a_free_statics_effect_at_zero() {
        let m = Model::from_toml(TWO_UNIVERSAL).unwrap();
        let lay = layout(&m);
        let (o, _) = lay.find(Effect::HolePosition).unwrap();
        for e in [Effect::CableElasticity, Effect::CableFriction] {
            let mut p = every_effect(&m);
            let (k, _) = lay.find(e).unwrap();
            p[k] = 0.0;
            let plant = Plant::<Spatial>::new(&m, &p).unwrap();
            assert_eq!(hole_cables(&plant, &[o, k]), vec![None, None]);
            assert!(hole_cables(&plant, &[o])[0].is_some());
        }
    }

    #[test]
    fn hole_columns_with_statics_match_central_differences_of_the_predictions() {
        let m = Model::from_toml(TWO_UNIVERSAL).unwrap();
        let (th, dl, reading) = data(4, 4, 6);
        let (o, s) = layout(&m).find(Effect::HolePosition).unwrap();
        for idle in [&[Effect::CableFriction][..], &[]] {
            let mut p = every_effect(&m);
            all_free_but(&m, &mut p, idle);
            check_jacobian_at(&m, &p, &th, &dl, &reading, (o..o + s).collect());
        }
    }

    #[test]
    fn rigid_hole_columns_match_central_differences_of_the_predictions() {
        let m = Model::from_toml(TWO_UNIVERSAL).unwrap();
        let (th, dl, reading) = data(4, 4, 6);
        let (o, s) = layout(&m).find(Effect::HolePosition).unwrap();
        let p = rigid_with_hole_errors(&m);
        check_jacobian_at(&m, &p, &th, &dl, &reading, (o..o + s).collect());
    }

    #[test]
    fn spatial_jet_jacobian_matches_central_differences_of_the_predictions() {
        // every effect at once (hole clearance and joint axes too), on
        // absolute and displacement rows, with backlash
        let m = Model::from_toml(TWO_UNIVERSAL).unwrap();
        let (th, dl, reading) = data(4, 4, 6);
        check_jacobian(
            &m,
            &th,
            &dl,
            &reading,
            (0..layout(&m).total).step_by(3).collect(),
        );
    }
}
