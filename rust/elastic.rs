//! Elastic arms without friction (`docs/model.md`, "Elastic arms"): joint
//! springs, cables commanded in displacement through a series stiffness,
//! unilateral cables, and the forward statics as the minimum of the
//! potential energy, for any number of joints and cables (fewer cables than
//! joints included), on the one model's chain (both kinds: a planar arm is
//! the case with every axis `z`).
//!
//! Every elastic cable `c` (position or displacement) pulls with
//! `T_c = clip(sigma_c, 0, T_max,c)`, `sigma_c = P_c + k_c (L_c(q) - l_c)`;
//! a force cable with its set tension. The potential
//!
//! ```text
//! U(q) = 1/2 sum_j k_j (q_j - rest_j)^2 + sum_elastic W_c(sigma_c) + sum_force T_f L_f(q)
//!        - sum_b mass_b g . c_b(q) - F . p_tip(q) - M_z phi(q)   (M_z: planar arms)
//! ```
//!
//! its gradient `g = K (q - rest) + J_L^T T - tau` and Hessian `H = K + sum_c
//! T_c d2L_c + sum_taut k_c g_c g_c^T - dtau/dq`. The Newton step uses the
//! structure: without gravity and tip force `H = D + G_t C G_t^T` with `D`
//! block diagonal (one block per disk: its joints), solved by Woodbury over
//! the taut cables (a Cholesky per block and one `m_t x m_t` solve); a dense
//! Cholesky (faer) is the fallback (loads present, or a block of `D` not
//! positive definite), with the shift of "The solver" step 2. Armijo line
//! search on `U`; converged when the unshifted step is at most `xtol` rad.
//! Derivatives by the implicit function theorem (one-sided at a slack or
//! capped transition: the side the flags say). SI units: m, rad, N, N m,
//! N/m, N m/rad, J.

use crate::chain::{Chain, Numbers};
use crate::error::{check_finite, CdsmError, Result};
use crate::kinds::{cross, Frame, KindInfo, Se3};
use crate::model::{Mode, Model};
use crate::rows::split_rows;
use crate::solve::{CableMethod, SolveOptions};
use faer::linalg::solvers::Solve;
use faer::Mat;

/// Armijo's sufficient-decrease constant of the line search.
pub const ARMIJO: f64 = 1e-4;
/// Converged when the unshifted Newton step's largest component is at most this (rad).
pub const XTOL: f64 = 1e-12;
/// The first shift of a Hessian that is not positive definite, relative to its mean |diagonal|.
pub const SHIFT: f64 = 1e-3;
/// Halvings of the line search before a row is declared stuck.
pub const HALVINGS: usize = 50;
/// A structured step at most this long (rad) is followed by the chord test
/// of convergence ([`Elastic::chord_step`]): the next step with this step's
/// factorisation, the Newton step to a relative `~1e-6` there; a test that
/// fails goes on as Newton (the next point's own Hessian).
pub const CHORD: f64 = 1e-6;
/// A full unshifted step whose predicted decrease is below this many ulps of
/// `U`'s rounding level is taken as it is (`docs/model.md`, step 4).
pub const ROUNDING_ULPS: f64 = 64.0;

/// Why a row's solve ended (its code is the index in [`REASONS`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Reason {
    Converged = 0,
    IterationLimit = 1,
    LineSearch = 2,
    NotFinite = 3,
    NotAMinimum = 4,
}

/// The reasons' words, by code.
pub const REASONS: [&str; 5] = [
    "converged",
    "iteration limit",
    "line search",
    "not finite",
    "not a minimum",
];

type Chn = Chain<f64, Se3<f64>>;

/// What the elastic statics needs of an arm, computed once: the joints'
/// springs, every cable's rest length and series stiffness, the blocks.
#[derive(Debug, Clone)]
pub struct Elastic {
    n: usize,
    /// Joint stiffness (N m/rad) and rest angle (rad).
    k: Vec<f64>,
    rest: Vec<f64>,
    /// Every cable's rest length `L0` (m, at the rest angles).
    l0: Vec<f64>,
    /// Every cable's traversals (m, the part no joint changes).
    traverse: Vec<f64>,
    /// Series stiffness `k_s` of the displacement cables (N/m; NaN for the others).
    ks: Vec<f64>,
    /// `E A` (N) and the routing length `L_r` (m).
    ea: f64,
    lr: f64,
    pos: Vec<usize>,
    dis: Vec<usize>,
    /// Joint ranges of the disks (the blocks of `D`).
    blocks: Vec<std::ops::Range<usize>>,
    /// Per cable, its reach: the joints before the end of its last disk
    /// (its length depends on `q[..reach]` alone).
    reach: Vec<usize>,
    /// Per cable, the index of its first gap (the gaps cable after cable).
    first_gap: Vec<usize>,
    /// Per cable and joint (`m x n`), a bound of `|dL_c/dq_j|` at every
    /// configuration (m/rad; [`Elastic::arms`]); per cable their sum.
    arm: Vec<f64>,
    arm_sum: Vec<f64>,
    /// Every disk has two joints (the blocks are the pairs `2d, 2d + 1`).
    pairs: bool,
    /// Gravity acts on some mass.
    gravity: bool,
    /// The kind's facts: the width of its wrench and task rows.
    kind: &'static KindInfo,
}

/// The commands of one row: commanded lengths of the position cables (m,
/// order of [`Model::position_cables`]), displacements of the displacement
/// cables (m, positive = pull, order of [`Model::displacement_cables`]),
/// and the tip wrench `[F, M]` (N, N m; base frame; a moment only about `z`
/// of a planar arm).
#[derive(Debug, Clone, Copy)]
pub struct Commands<'a> {
    pub lengths: &'a [f64],
    pub displacements: &'a [f64],
    pub wrench: [f64; 6],
}

/// The cables' laws of one row: rest length `l` (m), stiffness `k` (N/m),
/// pretension `P` and cap (N) of the elastic cables; the set tension of
/// force cables.
#[derive(Debug, Clone, Default)]
struct Laws {
    elastic: Vec<bool>,
    l: Vec<f64>,
    k: Vec<f64>,
    p: Vec<f64>,
    cap: Vec<f64>,
    force: Vec<f64>,
}

/// The answer of one row.
#[derive(Debug, Clone, PartialEq)]
pub struct Equilibrium {
    /// Joint angles (rad).
    pub theta: Vec<f64>,
    /// Every cable's tension (N; force cables their set tension).
    pub tension: Vec<f64>,
    /// Elastic cables at `sigma <= 0` (carrying nothing).
    pub slack: Vec<bool>,
    /// Elastic cables at `sigma >= T_max`.
    pub capped: Vec<bool>,
    pub converged: bool,
    pub reason: Reason,
    pub iterations: u32,
    /// `max_j |g_j|` (N m) at the last point evaluated: of a converged row
    /// the point its last Newton step (at most `xtol`) starts from.
    pub gradient: f64,
    /// The potential at the answer (J).
    pub energy: f64,
}

/// A batch of answers, row-major.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Equilibria {
    /// `(N, n)` rad.
    pub theta: Vec<f64>,
    /// `(N, m)` N.
    pub tension: Vec<f64>,
    /// `(N, m)`.
    pub slack: Vec<bool>,
    pub capped: Vec<bool>,
    pub converged: Vec<bool>,
    /// Codes of [`REASONS`].
    pub reason: Vec<u8>,
    pub iterations: Vec<u32>,
    /// N m.
    pub gradient: Vec<f64>,
    /// J.
    pub energy: Vec<f64>,
}

impl Equilibria {
    fn push(&mut self, e: Equilibrium) {
        self.theta.extend(&e.theta);
        self.tension.extend(&e.tension);
        self.slack.extend(&e.slack);
        self.capped.extend(&e.capped);
        self.converged.push(e.converged);
        self.reason.push(e.reason as u8);
        self.iterations.push(e.iterations);
        self.gradient.push(e.gradient);
        self.energy.push(e.energy);
    }

    fn extend(&mut self, o: Equilibria) {
        self.theta.extend(o.theta);
        self.tension.extend(o.tension);
        self.slack.extend(o.slack);
        self.capped.extend(o.capped);
        self.converged.extend(o.converged);
        self.reason.extend(o.reason);
        self.iterations.extend(o.iterations);
        self.gradient.extend(o.gradient);
        self.energy.extend(o.energy);
    }
}

/// The values of `U` and its derivatives at one configuration.
#[derive(Debug, Clone)]
struct Work {
    chain: Chn,
    /// Per cable: its length (m), `sigma` (N), tension (N).
    len: Vec<f64>,
    sigma: Vec<f64>,
    t: Vec<f64>,
    /// `G`: per cable its row `dL_c/dq` (`m x n`).
    grad_l: Vec<f64>,
    /// Per cable and gap: `A_k` (face `b` of disk `k - 1` frame) and `v`.
    gap_a: Vec<[f64; 3]>,
    gap_v: Vec<[f64; 3]>,
    /// Per gap: its length (m) and, per joint of its disk (`maxj` slots),
    /// `v_j = w_j x (A_k - p_j)` (m/rad).
    gap_l: Vec<f64>,
    gap_va: Vec<[f64; 3]>,
    maxj: usize,
    /// Per gap: `1 / length` (1/m; 0 at length 0).
    gap_inv: Vec<f64>,
    /// The configuration of the chain (rad; empty: none yet), and per
    /// cable: its length and gaps are made of it (`exact`), else `len_hi`
    /// bounds its length from above (m, [`Elastic::place`]); its row of `G`
    /// is made (`rows`). `dq`: scratch of the move.
    at: Vec<f64>,
    exact: Vec<bool>,
    len_hi: Vec<f64>,
    rows: Vec<bool>,
    dq: Vec<f64>,
    /// `U` (J), its rounding level (J), `g` (N m).
    u: f64,
    scale: f64,
    g: Vec<f64>,
    /// `D = K + sum_c T_c d2L_c`, per disk a dense block (row-major).
    d: Vec<Vec<f64>>,
    /// The loads' curvature `Q = -dtau/dq` (`n x n`), when there are loads.
    q: Vec<f64>,
    loads: bool,
    /// Taut cables' stiffness (0 for the others).
    c: Vec<f64>,
}

fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn norm3(a: [f64; 3]) -> f64 {
    dot3(a, a).sqrt()
}

/// `W(sigma)` (J) of a cable of stiffness `k` and cap `cap`: 0 slack,
/// `sigma^2 / (2k)` up to the cap, linear above it (`dW/dL = T`).
pub fn tendon_energy(sigma: f64, k: f64, cap: f64) -> f64 {
    let s = sigma.max(0.0);
    if s > cap {
        (cap * s - 0.5 * cap * cap) / k
    } else {
        0.5 * s * s / k
    }
}

/// In-place Cholesky of the `n x n` row-major `a` (lower triangle); false
/// when `a` is not positive definite (or not finite).
fn cholesky(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    true
}

/// Solves `L L^T x = b` in place (`l` from [`cholesky`]).
fn cholesky_solve(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * n + k] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k * n + i] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
}

/// The inverse (`n x n` row-major, into `out`) of `L L^T`, `l` from
/// [`cholesky`].
fn invert_from_cholesky(l: &[f64], n: usize, out: &mut [f64]) {
    match n {
        1 => out[0] = 1.0 / (l[0] * l[0]),
        2 => {
            let (ia, ic) = (1.0 / l[0], 1.0 / l[3]);
            let m10 = -l[2] * ia * ic;
            out[0] = ia * ia + m10 * m10;
            out[1] = m10 * ic;
            out[2] = out[1];
            out[3] = ic * ic;
        }
        _ => {
            for j in 0..n {
                let col = &mut out[j * n..(j + 1) * n];
                col.fill(0.0);
                col[j] = 1.0;
                cholesky_solve(l, n, col);
            }
        }
    }
}

impl Elastic {
    /// The elastic statics' data of `model`.
    pub fn new(model: &Model) -> Elastic {
        let n = model.n();
        let mut chain = Chn::new(model);
        let rest: Vec<f64> = model.joints.iter().map(|j| j.rest).collect();
        chain.at(model, model, &rest);
        let traverse: Vec<f64> = (0..model.cables.len())
            .map(|c| Numbers::<f64>::traverse(model, model, c))
            .collect();
        let l0: Vec<f64> = (0..model.cables.len())
            .map(|c| chain.cable_length(model, model, c, None))
            .collect();
        let ea = 1.0 / model.cable.compliance();
        let lr = model.cable.routing_length;
        let ks = model
            .cables
            .iter()
            .zip(&l0)
            .map(|(c, l)| {
                if c.mode == Mode::Displacement {
                    1.0 / (1.0 / c.actuator.stiffness + (l + lr) / ea)
                } else {
                    f64::NAN
                }
            })
            .collect();
        let arm = Elastic::arms(model);
        let arm_sum = arm.chunks_exact(n.max(1)).map(|r| r.iter().sum()).collect();
        Elastic {
            n,
            arm,
            arm_sum,
            k: model.joints.iter().map(|j| j.stiffness).collect(),
            rest,
            l0,
            traverse,
            ks,
            ea,
            lr,
            pos: model.position_cables(),
            dis: model.displacement_cables(),
            blocks: model.disks.iter().map(|d| d.joints.clone()).collect(),
            reach: model
                .cables
                .iter()
                .map(|c| match c.end {
                    0 => 0,
                    e => model.disks[e - 1].joints.end,
                })
                .collect(),
            first_gap: model
                .cables
                .iter()
                .scan(0, |at, c| {
                    let first = *at;
                    *at += c.end;
                    Some(first)
                })
                .collect(),
            pairs: model
                .disks
                .iter()
                .enumerate()
                .all(|(d, disk)| disk.joints == (2 * d..2 * d + 2)),
            gravity: model.gravity.iter().any(|g| *g != 0.0)
                && model.disks.iter().any(|d| d.mass > 0.0),
            kind: model.kind.info(),
        }
    }

    /// Per cable `c` and joint `j` (`m x n`, row-major), a bound of
    /// `|dL_c/dq_j|` over every configuration (m/rad): `j` of disk `k`
    /// moves gap `k` alone, `dl_k/dq_j = u . (w_j x (A_k - p_j))` with `u`
    /// a unit vector, and `A_k - p_j` is, turned, the offsets of the disk's
    /// joints after `j` plus its link and the hole: `|w_j| (sum |offset| +
    /// |link_after + a_k|)`, with a relative margin of `1e-9` for rounding.
    fn arms(model: &Model) -> Vec<f64> {
        let n = model.n();
        let mut arm = vec![0.0; model.cables.len() * n];
        for (c, cable) in model.cables.iter().enumerate() {
            for k in 1..=cable.end {
                let disk = &model.disks[k - 1];
                let hole = cable.holes[2 * k - 1];
                let tail = [
                    disk.link_after[0] + hole[0],
                    disk.link_after[1] + hole[1],
                    disk.link_after[2] + hole[2],
                ];
                let mut r = norm3(tail);
                for j in disk.joints.clone().rev() {
                    arm[c * n + j] = norm3(model.joints[j].axis) * r * (1.0 + 1e-9);
                    r += norm3(model.joints[j].offset);
                }
            }
        }
        arm
    }

    /// Every cable's rest length `L0` (m): its path at the rest angles.
    pub fn rest_lengths(&self) -> &[f64] {
        &self.l0
    }

    /// The series stiffness of every cable (N/m; NaN but for displacement cables).
    pub fn series_stiffness(&self) -> &[f64] {
        &self.ks
    }

    /// The width of the tip wrench rows of the kind: its task's (planar
    /// `[Fx, Fy, Mz]`, spatial `[Fx, Fy, Fz, Mx, My, Mz]`).
    pub fn wrench_width(&self) -> usize {
        self.kind.task
    }

    /// Where each component of the kind's task (or wrench) row sits in the
    /// six of `[x, y, z, rx, ry, rz]` (or `[F, M]`): the first `dim` along
    /// the axes, the `task - dim` rotations about the last of them (a
    /// planar arm's about `z`).
    fn task_rows(&self) -> Vec<usize> {
        let (dim, task) = (self.kind.dim, self.kind.task);
        (0..dim).chain(6 - (task - dim)..6).collect()
    }

    /// The base-frame `[F, M]` of a row of the kind's wrench; a tip moment
    /// is refused where the kind rotates about more than one axis (no
    /// potential).
    pub fn wrench(&self, row: &[f64]) -> Result<[f64; 6]> {
        check_finite("tip_wrench", row)?;
        let (dim, task) = (self.kind.dim, self.kind.task);
        if task - dim > 1 && row[dim..task].iter().any(|v| *v != 0.0) {
            return Err(CdsmError::Option {
                name: "tip_wrench".into(),
                problem: "a spatial tip moment is not conservative (no potential); apply forces \
                          instead (a couple as two forces at two points of the end disk)"
                    .into(),
            });
        }
        let mut out = [0.0; 6];
        out[..dim].copy_from_slice(&row[..dim]);
        if task - dim == 1 {
            // a moment about the one axis of rotation: `M phi` its potential
            out[5] = row[dim];
        }
        Ok(out)
    }

    fn laws(&self, model: &Model, cmd: &Commands) -> Result<Laws> {
        let m = model.cables.len();
        let mut laws = Laws {
            elastic: vec![false; m],
            l: vec![f64::NAN; m],
            k: vec![0.0; m],
            p: vec![0.0; m],
            cap: vec![f64::INFINITY; m],
            force: vec![0.0; m],
        };
        for (i, &c) in self.pos.iter().enumerate() {
            let l = cmd.lengths[i];
            let positive = l + self.lr > 0.0; // NaN is refused too
            if !positive {
                return Err(CdsmError::Option {
                    name: "lengths".into(),
                    problem: format!(
                        "a commanded cable length plus the routing length ({} m) must be > 0 m, \
                         got {l}",
                        self.lr
                    ),
                });
            }
            laws.elastic[c] = true;
            laws.l[c] = l;
            laws.k[c] = self.ea / (l + self.lr);
            // its command shortened by P (L + L_r) / (E A) (0 unless redundant)
            laws.p[c] = model.cables[c].actuator.pretension;
        }
        for (i, &c) in self.dis.iter().enumerate() {
            let a = &model.cables[c].actuator;
            laws.elastic[c] = true;
            laws.l[c] = self.l0[c] - cmd.displacements[i];
            laws.k[c] = self.ks[c];
            laws.p[c] = a.pretension;
            laws.cap[c] = a.max_tension;
        }
        for (c, cable) in model.cables.iter().enumerate() {
            if cable.mode == Mode::Force {
                laws.force[c] = cable.tension;
            }
        }
        Ok(laws)
    }

    fn work(&self, model: &Model) -> Work {
        let m = model.cables.len();
        let gaps: usize = model.cables.iter().map(|c| c.end).sum();
        let maxj = self.blocks.iter().map(|b| b.len()).max().unwrap_or(1);
        Work {
            chain: Chn::new(model),
            len: vec![0.0; m],
            sigma: vec![0.0; m],
            t: vec![0.0; m],
            grad_l: vec![0.0; m * self.n],
            gap_a: vec![[0.0; 3]; gaps],
            gap_v: vec![[0.0; 3]; gaps],
            gap_l: vec![0.0; gaps],
            gap_va: vec![[0.0; 3]; gaps * maxj],
            maxj,
            gap_inv: vec![0.0; gaps],
            at: Vec::new(),
            exact: vec![false; m],
            len_hi: vec![f64::INFINITY; m],
            rows: vec![false; m],
            dq: vec![0.0; self.n],
            u: 0.0,
            scale: 0.0,
            g: vec![0.0; self.n],
            d: self
                .blocks
                .iter()
                .map(|b| vec![0.0; b.len() * b.len()])
                .collect(),
            q: Vec::new(),
            loads: false,
            c: vec![0.0; m],
        }
    }

    /// `U` at `q` and, with `order >= 1`, `g`, with `order >= 2` the parts
    /// of `H`, into `w`: the geometry of `q` ([`Elastic::geometry`], every
    /// row of `G` with `order >= 1`), then the laws and loads on it
    /// ([`Elastic::apply`]).
    fn evaluate(
        &self,
        model: &Model,
        laws: &Laws,
        wrench: &[f64; 6],
        q: &[f64],
        order: u8,
        w: &mut Work,
    ) {
        self.place(model, q, w);
        self.geometry(model, order.min(1), w);
        self.apply(model, laws, wrench, q, order, w);
    }

    /// [`Elastic::evaluate`] with the lengths and rows of `G` that `U` and
    /// its derivatives use (the Newton iteration's): an elastic cable whose
    /// bound of `sigma` ([`Elastic::place`]) is below 0 is slack, its length
    /// not computed; a slack cable's row of `G` is not used.
    fn evaluate_pulling(
        &self,
        model: &Model,
        laws: &Laws,
        wrench: &[f64; 6],
        q: &[f64],
        order: u8,
        w: &mut Work,
    ) {
        self.place(model, q, w);
        self.apply(model, laws, wrench, q, order, w);
    }

    /// Moves the chain to `q` (rad): no length nor row of `G` of `q` made
    /// yet; every cable's length bounded from above by its value (or bound)
    /// at the last point plus [`Elastic::arms`] times the move (`+inf` at
    /// the first point).
    fn place(&self, model: &Model, q: &[f64], w: &mut Work) {
        let n = self.n;
        w.chain.at(model, model, q);
        let moved = w.at.len() == n;
        if moved {
            for ((d, a), b) in w.dq.iter_mut().zip(&w.at).zip(q) {
                *d = (b - a).abs();
            }
        }
        for c in 0..model.cables.len() {
            let base = if w.exact[c] { w.len[c] } else { w.len_hi[c] };
            w.len_hi[c] = if moved {
                let r = self.reach[c];
                base + dot(&self.arm[c * n..c * n + r], &w.dq[..r])
            } else {
                f64::INFINITY
            };
        }
        w.exact.fill(false);
        w.rows.fill(false);
        w.at.clear();
        w.at.extend_from_slice(q);
    }

    /// What of `U` and its derivatives depends on the configuration of the
    /// last [`Elastic::place`] alone (not on the laws), up to `order`: every
    /// cable's length (order 0, [`Elastic::cable_length`]), then its row of
    /// `G` (order 1, [`Elastic::cable_row`]). (The gaps' curvature, needed
    /// of the cables that pull alone, is [`Elastic::add_curvature`].)
    fn geometry(&self, model: &Model, order: u8, w: &mut Work) {
        for c in 0..model.cables.len() {
            self.cable_length(model, c, w);
        }
        if order >= 1 {
            for c in 0..model.cables.len() {
                self.cable_row(model, c, w);
            }
        }
    }

    /// Cable `c`'s gaps' vectors and lengths and its length at the chain's
    /// configuration, unless `w` holds them already.
    fn cable_length(&self, model: &Model, c: usize, w: &mut Work) {
        if w.exact[c] {
            return;
        }
        // the gaps' vectors, then their lengths in a pass of their own
        // (square roots independent of one another), then the sum
        let ch = &w.chain;
        let cable = &model.cables[c];
        let gaps = self.first_gap[c]..self.first_gap[c] + cable.end;
        for (k, at) in (1..=cable.end).zip(gaps.clone()) {
            let a = ch.local[k - 1].point(cable.holes[2 * k - 1]);
            let v = sub3(a, cable.holes[2 * k - 2]);
            w.gap_a[at] = a;
            w.gap_v[at] = v;
            w.gap_l[at] = dot3(v, v);
        }
        for l in w.gap_l[gaps.clone()].iter_mut() {
            *l = l.sqrt();
        }
        let mut l = self.traverse[c];
        for lk in &w.gap_l[gaps] {
            l += lk;
        }
        w.len[c] = l;
        w.exact[c] = true;
    }

    /// Cable `c`'s row of `G` (with its gaps' moment arms and inverse
    /// lengths) from its length `w` holds, unless it holds it already: a
    /// row is 0 past the joints of the cable's last disk (zeros from
    /// [`Elastic::work`], never written). The rows of the cables that pull
    /// are made as [`Elastic::apply`] needs them; a slack cable's only for
    /// the answer ([`Elastic::answer`]) or by [`Elastic::geometry`].
    fn cable_row(&self, model: &Model, c: usize, w: &mut Work) {
        if w.rows[c] {
            return;
        }
        let n = self.n;
        let maxj = w.maxj;
        let at0 = self.first_gap[c];
        let cable = &model.cables[c];
        let ch = &w.chain;
        let row = &mut w.grad_l[c * n..(c + 1) * n];
        for k in 1..=cable.end {
            let at = at0 + k - 1;
            let l = w.gap_l[at];
            let inv = if l > 0.0 { 1.0 / l } else { 0.0 };
            w.gap_inv[at] = inv;
            let blk = model.disks[k - 1].joints.clone();
            let vas = &mut w.gap_va[at * maxj..(at + 1) * maxj];
            let (a, v) = (w.gap_a[at], w.gap_v[at]);
            for (i, j) in blk.enumerate() {
                let va = cross(ch.joint_w[j], sub3(a, ch.joint_p[j]));
                vas[i] = va;
                row[j] = dot3(v, va) * inv;
            }
        }
        w.rows[c] = true;
    }

    /// Adds the cables' curvature to `D` ([`Work::d`] holding the springs):
    /// `T_c d2l/dq_a dq_b` of every gap of the cables that pull, from the
    /// geometry of order 1 `w` holds and its tensions. Per pair `ia <= ib` of
    /// the gap's disk's joints, `d2l/dq_a dq_b = ((v_a + v x w_a) . v_b - u_a
    /// u_b) / l` with `u_j = dl/dq_j` (`v . (w_a x v_b) = (v x w_a) . v_b`).
    fn add_curvature(&self, model: &Model, w: &mut Work) {
        let n = self.n;
        let Work {
            chain: ch,
            grad_l,
            gap_v,
            gap_va,
            gap_inv,
            maxj,
            t,
            d,
            ..
        } = w;
        let maxj = *maxj;
        let mut at = 0;
        for (c, cable) in model.cables.iter().enumerate() {
            let tc = t[c];
            if tc == 0.0 {
                at += cable.end;
                continue;
            }
            let row = &grad_l[c * n..(c + 1) * n];
            for k in 1..=cable.end {
                let blk = model.disks[k - 1].joints.clone();
                let s = blk.len();
                let vas = &gap_va[at * maxj..(at + 1) * maxj];
                let (v, inv) = (gap_v[at], gap_inv[at]);
                at += 1;
                let db = &mut d[k - 1];
                if s == 2 {
                    // a pair of joints (every disk of a continuum arm): the
                    // three entries, as the loop below computes them
                    let j0 = blk.start;
                    let (u0, u1) = (row[j0], row[j0 + 1]);
                    let e = |wa: [f64; 3], va: [f64; 3]| {
                        [
                            va[0] + v[1] * wa[2] - v[2] * wa[1],
                            va[1] + v[2] * wa[0] - v[0] * wa[2],
                            va[2] + v[0] * wa[1] - v[1] * wa[0],
                        ]
                    };
                    let e0 = e(ch.joint_w[j0], vas[0]);
                    let e1 = e(ch.joint_w[j0 + 1], vas[1]);
                    let h00 = tc * ((dot3(e0, vas[0]) - u0 * u0) * inv);
                    let h01 = tc * ((dot3(e0, vas[1]) - u0 * u1) * inv);
                    let h11 = tc * ((dot3(e1, vas[1]) - u1 * u1) * inv);
                    db[0] += h00;
                    db[1] += h01;
                    db[2] += h01;
                    db[3] += h11;
                    continue;
                }
                for ia in 0..s {
                    let wa = ch.joint_w[blk.start + ia];
                    let va = vas[ia];
                    let e = [
                        va[0] + v[1] * wa[2] - v[2] * wa[1],
                        va[1] + v[2] * wa[0] - v[0] * wa[2],
                        va[2] + v[0] * wa[1] - v[1] * wa[0],
                    ];
                    let ua = row[blk.start + ia];
                    for ib in ia..s {
                        let h = (dot3(e, vas[ib]) - ua * row[blk.start + ib]) * inv;
                        let th = tc * h;
                        db[ia * s + ib] += th;
                        if ia != ib {
                            db[ib * s + ia] += th;
                        }
                    }
                }
            }
        }
    }

    /// `U` and, up to `order`, `g` and the parts of `H` at `q` (rad) from the
    /// geometry `w` holds of `q` (at least its lengths; the rows of `G` of
    /// the cables that pull are made here when missing): the springs, the
    /// cables' laws, the loads.
    fn apply(
        &self,
        model: &Model,
        laws: &Laws,
        wrench: &[f64; 6],
        q: &[f64],
        order: u8,
        w: &mut Work,
    ) {
        let n = self.n;
        let force = [wrench[0], wrench[1], wrench[2]];
        let tip_force = force.iter().any(|v| *v != 0.0);
        let mz = wrench[5];
        w.loads = self.gravity || tip_force;
        if w.loads || (order >= 1 && mz != 0.0) {
            w.chain.world(model, model);
        }
        // springs
        let mut u = 0.0;
        for ((qj, rj), kj) in q.iter().zip(&self.rest).zip(&self.k) {
            let dq = qj - rj;
            u += 0.5 * kj * dq * dq;
        }
        let mut scale = u;
        // cables; an elastic cable whose length is not made is slack when its
        // bound of `sigma` is below 0 (beyond rounding), else its length is made
        for c in 0..model.cables.len() {
            if !w.exact[c] {
                if laws.elastic[c] {
                    let (p, k, l) = (laws.p[c], laws.k[c], laws.l[c]);
                    let hi = p + k * (w.len_hi[c] - l);
                    if hi < -1e-9 * (p.abs() + k * (w.len_hi[c].abs() + l.abs())) {
                        w.sigma[c] = hi;
                        w.t[c] = 0.0;
                        continue;
                    }
                }
                self.cable_length(model, c, w);
            }
            let l = w.len[c];
            let (t, energy, sigma) = if laws.elastic[c] {
                let s = laws.p[c] + laws.k[c] * (l - laws.l[c]);
                (
                    s.clamp(0.0, laws.cap[c]),
                    tendon_energy(s, laws.k[c], laws.cap[c]),
                    s,
                )
            } else {
                let t = laws.force[c];
                (t, t * l, t)
            };
            w.sigma[c] = sigma;
            w.t[c] = t;
            u += energy;
            scale += energy.abs() + t.abs() * l;
        }
        // loads: gravity on the disks' centres of mass, the tip force, a planar moment
        let ch = &w.chain;
        if w.loads {
            for (b, disk) in model.disks.iter().enumerate() {
                if self.gravity && disk.mass > 0.0 {
                    let c = ch.face_a[b].point(disk.com);
                    let f = model.gravity.map(|g| g * disk.mass);
                    u -= dot3(f, c);
                    scale += norm3(f) * norm3(c);
                }
            }
            if tip_force {
                let p = ch.end().origin();
                u -= dot3(force, p);
                scale += norm3(force) * norm3(p);
            }
        }
        if mz != 0.0 {
            let phi: f64 = q.iter().sum();
            u -= mz * phi;
            scale += (mz * phi).abs();
        }
        w.u = u;
        w.scale = scale;
        if order < 1 {
            return;
        }
        // the gradient: the rows of `G` of the cables that pull
        for c in 0..model.cables.len() {
            if w.t[c] != 0.0 {
                self.cable_row(model, c, w);
            }
        }
        for (((gj, qj), rj), kj) in w.g.iter_mut().zip(q).zip(&self.rest).zip(&self.k) {
            *gj = kj * (qj - rj);
        }
        for c in 0..model.cables.len() {
            let t = w.t[c];
            if t != 0.0 {
                let reach = self.reach[c];
                let row = &w.grad_l[c * n..c * n + reach];
                for (gj, rj) in w.g[..reach].iter_mut().zip(row) {
                    *gj += t * rj;
                }
            }
        }
        if w.loads || mz != 0.0 {
            w.chain.joints_world(model);
        }
        if w.loads {
            if order >= 2 {
                w.q.clear();
                w.q.resize(n * n, 0.0);
            }
            let load = |f: [f64; 3], p: [f64; 3], last: usize, w: &mut Work| {
                // joints 0..last are proximal of the point p
                for b in 0..last {
                    let xb = cross(w.chain.world_w[b], sub3(p, w.chain.world_p[b]));
                    w.g[b] -= dot3(f, xb);
                    if order >= 2 {
                        for a in 0..=b {
                            // F . (w_a x (w_b x (P - p_b)))
                            let h = dot3(f, cross(w.chain.world_w[a], xb));
                            w.q[a * n + b] -= h;
                            if a != b {
                                w.q[b * n + a] -= h;
                            }
                        }
                    }
                }
            };
            if self.gravity {
                for (b, disk) in model.disks.iter().enumerate() {
                    if disk.mass > 0.0 {
                        let c = w.chain.face_a[b].point(disk.com);
                        let f = model.gravity.map(|g| g * disk.mass);
                        load(f, c, disk.joints.end, w);
                    }
                }
            }
            if tip_force {
                let p = w.chain.end().origin();
                load(force, p, n, w);
            }
        }
        if mz != 0.0 {
            for j in 0..n {
                w.g[j] -= mz * w.chain.world_w[j][2];
            }
        }
        if order < 2 {
            return;
        }
        // D: the springs and the cables' curvature, block by block
        for (d, blk) in self.blocks.iter().enumerate() {
            let s = blk.len();
            let db = &mut w.d[d];
            db.fill(0.0);
            for (i, j) in blk.clone().enumerate() {
                db[i * s + i] = self.k[j];
            }
        }
        self.add_curvature(model, w);
        for c in 0..model.cables.len() {
            let s = w.sigma[c];
            w.c[c] = if laws.elastic[c] && s > 0.0 && s < laws.cap[c] {
                laws.k[c]
            } else {
                0.0
            };
        }
    }

    /// The dense Hessian of the last [`Elastic::evaluate`] (`n x n`).
    fn dense_hessian(&self, w: &Work, h: &mut Vec<f64>) {
        let n = self.n;
        h.clear();
        h.resize(n * n, 0.0);
        for (d, blk) in self.blocks.iter().enumerate() {
            let s = blk.len();
            for (ia, ja) in blk.clone().enumerate() {
                for (ib, jb) in blk.clone().enumerate() {
                    h[ja * n + jb] = w.d[d][ia * s + ib];
                }
            }
        }
        for (c, &kc) in w.c.iter().enumerate() {
            if kc == 0.0 {
                continue;
            }
            let row = &w.grad_l[c * n..(c + 1) * n];
            for a in 0..n {
                if row[a] == 0.0 {
                    continue;
                }
                let ra = kc * row[a];
                for b in 0..n {
                    h[a * n + b] += ra * row[b];
                }
            }
        }
        if w.loads {
            for (x, q) in h.iter_mut().zip(&w.q) {
                *x += q;
            }
        }
    }

    /// The step `s` of `(H + tau I) s = -g` and `tau` (`docs/model.md`,
    /// "The solver", step 2): by the structure when there are no loads and
    /// every block of `D` is positive definite (then `H` is, `tau = 0`),
    /// else by the dense Cholesky with the shift. `None`: no shift helps.
    fn step(&self, w: &Work, s: &mut [f64], scratch: &mut Scratch) -> Option<f64> {
        scratch.structured = !w.loads && self.structured(w, s, scratch);
        if scratch.structured {
            return Some(0.0);
        }
        self.dense_step(w, s, scratch)
    }

    /// Woodbury over the taut cables: false when a block of `D` is not
    /// positive definite.
    fn structured(&self, w: &Work, s: &mut [f64], sc: &mut Scratch) -> bool {
        let n = self.n;
        if !self.invert_blocks(w, sc) {
            return false;
        }
        sc.taut.clear();
        sc.taut.extend((0..w.c.len()).filter(|c| w.c[*c] > 0.0));
        let mt = sc.taut.len();
        // X = D^-1 [g, G_t] (columns), column-major n x (1 + mt); a cable's
        // column only up to its reach (its gradient is 0 past it)
        let mut x = std::mem::take(&mut sc.x);
        x.clear();
        x.resize(n * (1 + mt), 0.0);
        self.block_solve(sc, &w.g, &mut x[..n], n);
        for (i, &c) in sc.taut.iter().enumerate() {
            let r = self.reach[c];
            let col = &mut x[(1 + i) * n..(2 + i) * n];
            self.block_solve(sc, &w.grad_l[c * n..c * n + r], col, r);
        }
        sc.x = x;
        for (sj, xj) in s.iter_mut().zip(&sc.x[..n]) {
            *sj = -xj;
        }
        if mt == 0 {
            return true;
        }
        // S = C^-1 + G_t^T D^-1 G_t (symmetric: one triangle), y = G_t^T D^-1 g
        sc.small.clear();
        sc.small.resize(mt * mt, 0.0);
        sc.y.clear();
        sc.y.resize(mt, 0.0);
        for (a, &ca) in sc.taut.iter().enumerate() {
            let ra = self.reach[ca];
            let ga = &w.grad_l[ca * n..ca * n + ra];
            for b in 0..=a {
                let r = ra.min(self.reach[sc.taut[b]]);
                let xb = &sc.x[(1 + b) * n..(1 + b) * n + r];
                let v = dot4(&ga[..r], xb);
                sc.small[a * mt + b] = v;
                sc.small[b * mt + a] = v;
            }
            sc.small[a * mt + a] += 1.0 / w.c[ca];
            sc.y[a] = dot4(ga, &sc.x[..ra]);
        }
        if !cholesky(&mut sc.small, mt) {
            return false;
        }
        cholesky_solve(&sc.small, mt, &mut sc.y);
        for (b, &cb) in sc.taut.iter().enumerate() {
            let r = self.reach[cb];
            let yb = sc.y[b];
            let xb = &sc.x[(1 + b) * n..(1 + b) * n + r];
            for (sj, xj) in s[..r].iter_mut().zip(xb) {
                *sj += yb * xj;
            }
        }
        true
    }

    /// The convergence test of [`CHORD`]: with `w` at order 1 at a point
    /// a small structured step from the last factorised one, and the same
    /// taut cables, the step `s` of that factorisation (the Newton step to
    /// within a relative change of `H` over the small step); true when it is
    /// finite and at most `xtol` (rad; `s` then holds it).
    fn chord_step(
        &self,
        laws: &Laws,
        w: &Work,
        s: &mut [f64],
        sc: &mut Scratch,
        xtol: f64,
    ) -> bool {
        let n = self.n;
        if !(w.u.is_finite() && w.g.iter().all(|v| v.is_finite())) {
            return false;
        }
        // the same taut cables
        let mut i = 0;
        for (c, &sig) in w.sigma.iter().enumerate() {
            let taut = laws.elastic[c] && sig > 0.0 && sig < laws.cap[c];
            let was = sc.taut.get(i) == Some(&c);
            if taut != was {
                return false;
            }
            i += usize::from(was);
        }
        let mt = sc.taut.len();
        let mut x0 = std::mem::take(&mut sc.y0);
        x0.clear();
        x0.resize(n, 0.0);
        self.block_solve(sc, &w.g, &mut x0, n);
        sc.y.clear();
        for (a, &c) in sc.taut.iter().enumerate() {
            let r = self.reach[c];
            sc.y.push(dot4(&sc.gt[a * n..a * n + r], &x0[..r]));
        }
        if mt > 0 {
            cholesky_solve(&sc.small, mt, &mut sc.y);
        }
        for (sj, xj) in s.iter_mut().zip(&x0) {
            *sj = -xj;
        }
        for (b, &cb) in sc.taut.iter().enumerate() {
            let r = self.reach[cb];
            let yb = sc.y[b];
            let xb = &sc.x[(1 + b) * n..(1 + b) * n + r];
            for (sj, xj) in s[..r].iter_mut().zip(xb) {
                *sj += yb * xj;
            }
        }
        sc.y0 = x0;
        s.iter().all(|v| v.abs() <= xtol)
    }

    /// Every block of `D`'s inverse into `sc`: false when one is not
    /// positive definite (its Cholesky factorisation fails).
    fn invert_blocks(&self, w: &Work, sc: &mut Scratch) -> bool {
        if self.pairs {
            // 2 x 2: pivots `a` and `e - c^2 / a`, the inverse by its adjugate
            sc.pairs.resize(self.blocks.len(), [0.0; 3]);
            for (b, inv) in w.d.iter().zip(sc.pairs.iter_mut()) {
                let (a, c, e) = (b[0], b[2], b[3]);
                if !(a > 0.0 && a.is_finite()) {
                    return false;
                }
                let p = e - c * c / a;
                if !(p > 0.0 && p.is_finite()) {
                    return false;
                }
                let r = 1.0 / (a * p);
                *inv = [e * r, -c * r, a * r];
            }
            return true;
        }
        if sc.blocks.len() != self.blocks.len() {
            sc.blocks = w.d.clone();
            sc.chol = w.d.clone();
        }
        for (d, blk) in self.blocks.iter().enumerate() {
            let b = &mut sc.chol[d];
            b.copy_from_slice(&w.d[d]);
            if !cholesky(b, blk.len()) {
                return false;
            }
            invert_from_cholesky(b, blk.len(), &mut sc.blocks[d]);
        }
        true
    }

    /// `out[..r] = D^-1 rhs[..r]` with the blocks' inverses of
    /// [`Elastic::invert_blocks`], for `r` at a block's end (the blocks past
    /// it are not read nor written).
    fn block_solve(&self, sc: &Scratch, rhs: &[f64], out: &mut [f64], r: usize) {
        if self.pairs {
            for ((o, x), inv) in out[..r]
                .chunks_exact_mut(2)
                .zip(rhs[..r].chunks_exact(2))
                .zip(&sc.pairs)
            {
                o[0] = inv[0] * x[0] + inv[1] * x[1];
                o[1] = inv[1] * x[0] + inv[2] * x[1];
            }
            return;
        }
        for (d, blk) in self.blocks.iter().enumerate() {
            if blk.start >= r {
                break;
            }
            let s = blk.len();
            let bi = &sc.blocks[d];
            let x = &rhs[blk.clone()];
            for (i, o) in out[blk.clone()].iter_mut().enumerate() {
                *o = dot(&bi[i * s..(i + 1) * s], x);
            }
        }
    }

    fn dense_step(&self, w: &Work, s: &mut [f64], sc: &mut Scratch) -> Option<f64> {
        let n = self.n;
        self.dense_hessian(w, &mut sc.h);
        if !(sc.h.iter().all(|v| v.is_finite()) && w.g.iter().all(|v| v.is_finite())) {
            return None;
        }
        let mean = (0..n).map(|j| sc.h[j * n + j].abs()).sum::<f64>() / n.max(1) as f64;
        let beta = if SHIFT * mean > 0.0 {
            SHIFT * mean
        } else {
            1.0
        };
        let mut tau = 0.0;
        for _ in 0..61 {
            let mat = Mat::<f64>::from_fn(n, n, |i, j| {
                sc.h[i * n + j] + if i == j { tau } else { 0.0 }
            });
            if let Ok(llt) = mat.llt(faer::Side::Lower) {
                let rhs = Mat::<f64>::from_fn(n, 1, |i, _| -w.g[i]);
                let x = llt.solve(&rhs);
                for (j, sj) in s.iter_mut().enumerate() {
                    *sj = x[(j, 0)];
                }
                return Some(tau);
            }
            tau = if tau == 0.0 { beta } else { 2.0 * tau };
        }
        None
    }

    /// Newton with the Armijo line search from `q` (in place): the reason and
    /// the iterations. Converged, `q` is the last point evaluated (`w` holds
    /// `U`, `g` and the tensions there) and `sc.s` its Newton step (at most
    /// `xtol`), not taken (`sc.pending`): the answer is `q + s`
    /// ([`Elastic::answer`]), `w` stays of `q`.
    #[allow(clippy::too_many_arguments)]
    fn newton(
        &self,
        model: &Model,
        laws: &Laws,
        wrench: &[f64; 6],
        q: &mut [f64],
        xtol: f64,
        max_iter: u32,
        w: &mut Work,
        sc: &mut Scratch,
    ) -> (Reason, u32) {
        self.newton_at(model, laws, wrench, q, xtol, max_iter, w, sc, false)
    }

    /// [`Elastic::newton`]; with `placed`, `w` holds the geometry of `q`
    /// (the last evaluation was at `q`, with any laws: the previous row's
    /// answer along a sequence), not computed again.
    #[allow(clippy::too_many_arguments)]
    fn newton_at(
        &self,
        model: &Model,
        laws: &Laws,
        wrench: &[f64; 6],
        q: &mut [f64],
        xtol: f64,
        max_iter: u32,
        w: &mut Work,
        sc: &mut Scratch,
        placed: bool,
    ) -> (Reason, u32) {
        let n = self.n;
        let mut s = std::mem::take(&mut sc.s);
        let mut trial = std::mem::take(&mut sc.trial);
        s.resize(n, 0.0);
        trial.resize(n, 0.0);
        let out = self.descend(
            model, laws, wrench, q, xtol, max_iter, w, sc, &mut s, &mut trial, placed,
        );
        sc.s = s;
        sc.trial = trial;
        out
    }

    #[allow(clippy::too_many_arguments)]
    fn descend(
        &self,
        model: &Model,
        laws: &Laws,
        wrench: &[f64; 6],
        q: &mut [f64],
        xtol: f64,
        max_iter: u32,
        w: &mut Work,
        sc: &mut Scratch,
        s: &mut [f64],
        trial: &mut [f64],
        mut placed: bool,
    ) -> (Reason, u32) {
        let n = self.n;
        let mut it = 0;
        sc.pending = false;
        // `w` holds U and its derivatives at `q` (a full step's trial
        // evaluated to the second order, then accepted)
        let mut fresh = false;
        while it < max_iter {
            if placed {
                self.apply(model, laws, wrench, q, 2, w);
                placed = false;
            } else if !fresh {
                self.evaluate_pulling(model, laws, wrench, q, 2, w);
            }
            fresh = false;
            let Some(tau) = self.step(w, s, sc) else {
                return (Reason::NotFinite, it);
            };
            if !(s.iter().all(|v| v.is_finite()) && w.u.is_finite()) {
                return (Reason::NotFinite, it);
            }
            let big = s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if big <= xtol {
                if tau == 0.0 {
                    sc.pending = true;
                    return (Reason::Converged, it + 1);
                }
                return (Reason::NotAMinimum, it);
            }
            it += 1;
            let slope = dot(&w.g, s);
            if tau == 0.0 && -slope <= ROUNDING_ULPS * f64::EPSILON * w.scale {
                for (qj, sj) in q.iter_mut().zip(s.iter()) {
                    *qj += sj;
                }
                continue;
            }
            // a small structured step: the next step is likely the last (at
            // most `xtol`), tested first with this step's factorisation
            let chord = tau == 0.0 && sc.structured && big <= CHORD;
            if chord {
                sc.keep_taut_rows(w, self);
            }
            let u0 = w.u;
            let mut t = 1.0;
            let mut ok = false;
            for _ in 0..HALVINGS {
                for j in 0..n {
                    trial[j] = q[j] + t * s[j];
                }
                // the full step usually passes: its derivatives serve the next
                // step (its curvature once the chord test has not ended the solve)
                let order = match (t == 1.0, chord) {
                    (true, true) => 1,
                    (true, false) => 2,
                    (false, _) => 0,
                };
                self.evaluate_pulling(model, laws, wrench, trial, order, w);
                if w.u <= u0 + ARMIJO * t * slope {
                    ok = true;
                    fresh = order >= 1;
                    break;
                }
                t *= 0.5;
            }
            if !ok {
                return (Reason::LineSearch, it);
            }
            q.copy_from_slice(trial);
            if fresh && chord && it < max_iter {
                if self.chord_step(laws, w, s, sc, xtol) {
                    sc.pending = true;
                    return (Reason::Converged, it + 1);
                }
                self.apply(model, laws, wrench, q, 2, w);
            }
        }
        (Reason::IterationLimit, it)
    }

    /// The answer of a solve from `q` that ended for `reason`: converged,
    /// `q + s` of the last step pending in `sc`, with `U`, the tensions and
    /// the slack and capped flags carried from `q` over the step to first
    /// order (the step is at most `xtol`: its second order is below
    /// rounding) and the gradient measured at `q`; else `q` itself, `U` and
    /// its gradient evaluated there. `w` is left of `q` either way.
    #[allow(clippy::too_many_arguments)]
    fn answer(
        &self,
        model: &Model,
        laws: &Laws,
        wrench: &[f64; 6],
        q: &[f64],
        reason: Reason,
        iterations: u32,
        w: &mut Work,
        sc: &Scratch,
    ) -> Equilibrium {
        let n = self.n;
        let m = model.cables.len();
        let pending = sc.pending && reason == Reason::Converged;
        let mut theta = q.to_vec();
        let mut sigma = w.sigma.clone();
        let mut tension = w.t.clone();
        let mut energy = w.u;
        if pending {
            let s = &sc.s[..n];
            for (tj, sj) in theta.iter_mut().zip(s) {
                *tj += sj;
            }
            let big = s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for c in 0..m {
                if laws.elastic[c] {
                    let (p, k, l) = (laws.p[c], laws.k[c], laws.l[c]);
                    if w.t[c] == 0.0 {
                        // slack at `q` (`sigma` or its bound <= 0): slack over
                        // the step when even the step's largest change of
                        // `sigma` leaves it below 0 (its tension 0, as carried)
                        let hi = sigma[c] + k * self.arm_sum[c] * big;
                        let len = if w.exact[c] { w.len[c] } else { w.len_hi[c] };
                        if hi < -1e-9 * (p.abs() + k * (len.abs() + l.abs())) {
                            continue;
                        }
                    }
                    if !w.exact[c] {
                        self.cable_length(model, c, w);
                        sigma[c] = p + k * (w.len[c] - l);
                    }
                    self.cable_row(model, c, w);
                    let r = self.reach[c];
                    let dl = dot(&w.grad_l[c * n..c * n + r], &s[..r]);
                    sigma[c] += laws.k[c] * dl;
                    tension[c] = sigma[c].clamp(0.0, laws.cap[c]);
                }
            }
            // the Newton model: U + g.s + s.H s / 2 with H s = -g
            energy += 0.5 * dot(&w.g, s);
        } else {
            self.evaluate(model, laws, wrench, q, 1, w);
            sigma.copy_from_slice(&w.sigma);
            tension.copy_from_slice(&w.t);
            energy = w.u;
        }
        Equilibrium {
            tension,
            slack: (0..m)
                .map(|c| {
                    let pulls = sigma[c] > 0.0; // NaN counts as slack
                    laws.elastic[c] && !pulls
                })
                .collect(),
            capped: (0..m)
                .map(|c| laws.elastic[c] && sigma[c] >= laws.cap[c])
                .collect(),
            converged: reason == Reason::Converged,
            reason,
            iterations,
            gradient: w.g.iter().fold(0.0f64, |m, v| m.max(v.abs())),
            energy,
            theta,
        }
    }

    /// The frictionless equilibrium of one row from `seed` (rad).
    pub fn equilibrium(
        &self,
        model: &Model,
        cmd: &Commands,
        seed: &[f64],
        xtol: f64,
        max_iter: u32,
    ) -> Result<Equilibrium> {
        let laws = self.laws(model, cmd)?;
        let mut w = self.work(model);
        let mut sc = Scratch::default();
        let mut q = seed.to_vec();
        let (reason, it) = self.newton(
            model,
            &laws,
            &cmd.wrench,
            &mut q,
            xtol,
            max_iter,
            &mut w,
            &mut sc,
        );
        Ok(self.answer(model, &laws, &cmd.wrench, &q, reason, it, &mut w, &sc))
    }

    /// `U` (J), `g` (N m, `n`) and the dense `H` (N m/rad, `n x n`
    /// row-major) at `q` (rad) for one row's commands.
    pub fn potential(
        &self,
        model: &Model,
        cmd: &Commands,
        q: &[f64],
    ) -> Result<(f64, Vec<f64>, Vec<f64>)> {
        let laws = self.laws(model, cmd)?;
        let mut w = self.work(model);
        self.evaluate(model, &laws, &cmd.wrench, q, 2, &mut w);
        let mut h = Vec::new();
        self.dense_hessian(&w, &mut h);
        Ok((w.u, w.g.clone(), h))
    }

    /// The Newton step of the structure and of the dense Hessian at `q`
    /// (rad), `None` for the structured one when it does not apply: for
    /// the tests of the structured solve.
    pub fn steps(&self, model: &Model, cmd: &Commands, q: &[f64]) -> Result<StepPair> {
        let laws = self.laws(model, cmd)?;
        let mut w = self.work(model);
        self.evaluate(model, &laws, &cmd.wrench, q, 2, &mut w);
        let mut sc = Scratch::default();
        let mut a = vec![0.0; self.n];
        let structured = (!w.loads && self.structured(&w, &mut a, &mut sc)).then_some(a);
        let mut b = vec![0.0; self.n];
        let dense = self.dense_step(&w, &mut b, &mut sc).map(|_| b);
        Ok((structured, dense))
    }
}

/// The structured and the dense Newton step ([`Elastic::steps`]).
pub type StepPair = (Option<Vec<f64>>, Option<Vec<f64>>);

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// [`dot`] summed in four lanes (not one chain of additions).
fn dot4(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for i in 0..4 {
            acc[i] += x[i] * y[i];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    (acc[0] + acc[1]) + (acc[2] + acc[3]) + tail
}

/// Buffers of the Newton step.
#[derive(Debug, Clone, Default)]
struct Scratch {
    /// The last Newton step; `pending`: not taken (converged: the answer is
    /// the last point evaluated plus it).
    s: Vec<f64>,
    pending: bool,
    trial: Vec<f64>,
    /// Per block of `D`: its inverse, its Cholesky factor; when every block
    /// is a pair of joints, their inverses `[i00, i01, i11]` instead.
    blocks: Vec<Vec<f64>>,
    chol: Vec<Vec<f64>>,
    pairs: Vec<[f64; 3]>,
    /// The last step was structured; its taut cables, their rows of `G`
    /// (`taut x n`, kept for [`Elastic::chord_step`]).
    structured: bool,
    taut: Vec<usize>,
    gt: Vec<f64>,
    y0: Vec<f64>,
    x: Vec<f64>,
    small: Vec<f64>,
    y: Vec<f64>,
    h: Vec<f64>,
}

impl Scratch {
    /// Keeps the rows of `G` of the last structured step's taut cables.
    fn keep_taut_rows(&mut self, w: &Work, el: &Elastic) {
        let n = el.n;
        self.gt.clear();
        for &c in &self.taut {
            self.gt.extend_from_slice(&w.grad_l[c * n..(c + 1) * n]);
        }
    }
}

/// A batch of commands: `lengths (N, m_pos)` m, `displacements (N, m_d)`
/// m, `wrench` `(N, t)` or one row `(t,)` of the kind's rows (or empty: none).
#[derive(Debug, Clone, Copy)]
pub struct Batch<'a> {
    pub lengths: &'a [f64],
    pub displacements: &'a [f64],
    pub wrench: &'a [f64],
}

impl Batch<'_> {
    /// The number of rows, checked against every array's width.
    fn rows(&self, model: &Model, el: &Elastic) -> Result<usize> {
        let shape = |name: &str, v: &[f64], width: usize| -> Result<Option<usize>> {
            if width == 0 {
                if v.is_empty() {
                    return Ok(None);
                }
                return Err(CdsmError::Shape {
                    name: name.into(),
                    expected: "no values (the arm has no such cables)".into(),
                    got: format!("{} values", v.len()),
                });
            }
            check_finite(name, v)?;
            Ok(Some(crate::error::check_rows(name, v, width)?))
        };
        let mp = model.position_cables().len();
        let md = model.displacement_cables().len();
        let a = shape("lengths", self.lengths, mp)?;
        let b = shape("displacements", self.displacements, md)?;
        let t = el.wrench_width();
        let c = if self.wrench.is_empty() || self.wrench.len() == t {
            None
        } else {
            shape("tip_wrench", self.wrench, t)?
        };
        let mut rows = None;
        for (name, r) in [("lengths", a), ("displacements", b), ("tip_wrench", c)] {
            if let Some(r) = r {
                match rows {
                    None => rows = Some(r),
                    Some(q) if q != r => {
                        return Err(CdsmError::Shape {
                            name: name.into(),
                            expected: format!("{q} rows (as the other commands)"),
                            got: format!("{r} rows"),
                        })
                    }
                    _ => {}
                }
            }
        }
        Ok(rows.unwrap_or(1))
    }

    fn row(&self, model: &Model, el: &Elastic, i: usize) -> Result<([f64; 6], usize, usize)> {
        let t = el.wrench_width();
        let w = if self.wrench.is_empty() {
            [0.0; 6]
        } else if self.wrench.len() == t {
            el.wrench(self.wrench)?
        } else {
            el.wrench(&self.wrench[i * t..(i + 1) * t])?
        };
        Ok((
            w,
            model.position_cables().len(),
            model.displacement_cables().len(),
        ))
    }

    fn commands(&self, i: usize, mp: usize, md: usize, wrench: [f64; 6]) -> Commands<'_> {
        Commands {
            lengths: if mp == 0 {
                &[]
            } else {
                &self.lengths[i * mp..(i + 1) * mp]
            },
            displacements: if md == 0 {
                &[]
            } else {
                &self.displacements[i * md..(i + 1) * md]
            },
            wrench,
        }
    }
}

/// Seeds of a batch: given `(N, n)` or `(n,)`, or the default of
/// `docs/model.md` ("The solver"): for an arm without springs and with at
/// least as many position cables as joints the rigid cable solve of the
/// commanded lengths from the rest angles (the rest angles where it fails),
/// else the rest angles.
fn seeds(
    model: &Model,
    el: &Elastic,
    batch: &Batch,
    rows: usize,
    seed: Option<&[f64]>,
) -> Result<Vec<f64>> {
    let n = el.n;
    if let Some(s) = seed {
        check_finite("seed", s)?;
        if s.len() == n {
            return Ok(s.repeat(rows));
        }
        if s.len() != rows * n {
            return Err(CdsmError::Shape {
                name: "seed".into(),
                expected: format!("({rows}, {n}) or ({n},)"),
                got: format!("{} values", s.len()),
            });
        }
        return Ok(s.to_vec());
    }
    let rest = el.rest.repeat(rows);
    let rigid = el.k.iter().all(|k| *k == 0.0) && el.pos.len() >= n;
    if !rigid {
        return Ok(rest);
    }
    let sol = crate::arm::solve_cables(
        model,
        batch.lengths,
        Some(&rest),
        CableMethod::Auto,
        &SolveOptions::default(),
        1,
    )?;
    let mut out = rest;
    for i in 0..rows {
        let row = &sol.theta[i * n..(i + 1) * n];
        if row.iter().all(|v| v.is_finite()) {
            out[i * n..(i + 1) * n].copy_from_slice(row);
        }
    }
    Ok(out)
}

/// The frictionless equilibria of a batch of commands (`docs/model.md`,
/// "Elastic arms"): every row on its own from its seed (given, or the
/// default of [`seeds`]), in up to `threads` threads; with `sequence`,
/// the rows in order, each from the previous row's answer (the first from
/// `seed`, default as above): the warm start along a sequence, one thread.
pub fn equilibria(
    model: &Model,
    batch: &Batch,
    seed: Option<&[f64]>,
    sequence: bool,
    xtol: f64,
    max_iter: u32,
    threads: usize,
) -> Result<Equilibria> {
    if !(xtol.is_finite() && xtol > 0.0) {
        return Err(CdsmError::Option {
            name: "xtol".into(),
            problem: format!("must be positive and finite (rad), got {xtol}"),
        });
    }
    let el = Elastic::new(model);
    let rows = batch.rows(model, &el)?;
    let n = el.n;
    // every row's commands checked (and its laws) before any solve
    let mut wr = Vec::with_capacity(rows);
    for i in 0..rows {
        let (w, mp, md) = batch.row(model, &el, i)?;
        el.laws(model, &batch.commands(i, mp, md, w))?;
        wr.push(w);
    }
    let (mp, md) = (el.pos.len(), el.dis.len());
    if sequence {
        let first = match seed {
            Some(s) if s.len() == n => Some(s),
            Some(s) => {
                return Err(CdsmError::Shape {
                    name: "seed".into(),
                    expected: format!("({n},): the start of the sequence"),
                    got: format!("{} values", s.len()),
                })
            }
            None => None,
        };
        let one = Batch {
            lengths: if mp == 0 { &[] } else { &batch.lengths[..mp] },
            displacements: &[],
            wrench: &[],
        };
        let mut q = seeds(model, &el, &one, 1, first)?;
        let mut out = Equilibria::default();
        let mut w = el.work(model);
        let mut sc = Scratch::default();
        for (i, wrench) in wr.iter().enumerate() {
            let laws = el.laws(model, &batch.commands(i, mp, md, *wrench))?;
            // from the second row on, `q` is the previous row's last point
            // evaluated (its answer, or within `xtol` of it) and `w` holds its
            // geometry
            let (reason, it) = el.newton_at(
                model,
                &laws,
                wrench,
                &mut q,
                xtol,
                max_iter,
                &mut w,
                &mut sc,
                i > 0,
            );
            let e = el.answer(model, &laws, wrench, &q, reason, it, &mut w, &sc);
            out.push(e);
        }
        return Ok(out);
    }
    let start = seeds(model, &el, batch, rows, seed)?;
    let parts = split_rows(rows, threads, |r| {
        let mut out = Equilibria::default();
        let mut w = el.work(model);
        let mut sc = Scratch::default();
        for i in r {
            let laws = el
                .laws(model, &batch.commands(i, mp, md, wr[i]))
                .expect("checked above");
            let mut q = start[i * n..(i + 1) * n].to_vec();
            let (reason, it) = el.newton(
                model, &laws, &wr[i], &mut q, xtol, max_iter, &mut w, &mut sc,
            );
            out.push(el.answer(model, &laws, &wr[i], &q, reason, it, &mut w, &sc));
        }
        out
    });
    let mut out = Equilibria::default();
    for p in parts {
        out.extend(p);
    }
    Ok(out)
}

/// Derivatives of equilibria by the implicit function theorem, row-major
/// per row: `theta_*` `(n, p)` rad per unit, `task_*` `(t, p)` (the kind's
/// task rows; rotations as angular velocities), `tension_*` `(m, p)` N per
/// unit, for `p` = the position cables' lengths (m), the displacements (m)
/// and the kind's wrench rows (N or N m). `definite`: `H` positive definite
/// (else NaN).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Derivatives {
    pub theta_lengths: Vec<f64>,
    pub theta_displacements: Vec<f64>,
    pub theta_wrench: Vec<f64>,
    pub task_lengths: Vec<f64>,
    pub task_displacements: Vec<f64>,
    pub task_wrench: Vec<f64>,
    pub tension_lengths: Vec<f64>,
    pub tension_displacements: Vec<f64>,
    pub tension_wrench: Vec<f64>,
    pub definite: Vec<bool>,
}

/// [`Derivatives`] at the equilibria `theta (N, n)` rad of `batch`: `dq/dp =
/// -H^-1 dg/dp` with `dg/dp` at fixed `q` (`docs/model.md`, "Derivatives"):
/// a displacement `k_c g_c`, a commanded length `g_c dsigma_c/dL_cmd`,
/// `dsigma/dL_cmd = -k_c (L_c(q) + L_r)/(L_cmd + L_r)` (both 0 unless the
/// cable is taut: one-sided at a transition, the side of the flags); the
/// tip wrench `-J_task^T`.
pub fn derivatives(
    model: &Model,
    batch: &Batch,
    theta: &[f64],
    threads: usize,
) -> Result<Derivatives> {
    let el = Elastic::new(model);
    let n = el.n;
    let rows = crate::error::check_rows("theta", theta, n)?;
    check_finite("theta", theta)?;
    let given = batch.rows(model, &el)?;
    if given != rows && !(given == 1 && batch.lengths.is_empty() && batch.displacements.is_empty())
    {
        return Err(CdsmError::Shape {
            name: "theta".into(),
            expected: format!("{given} rows (as the commands)"),
            got: format!("{rows} rows"),
        });
    }
    let (mp, md) = (el.pos.len(), el.dis.len());
    let t = el.wrench_width();
    let task_rows = el.task_rows();
    let m = model.cables.len();
    let mut wr = Vec::with_capacity(rows);
    for i in 0..rows {
        let (w, _, _) = batch.row(model, &el, i.min(given - 1))?;
        el.laws(model, &batch.commands(i.min(given - 1), mp, md, w))?;
        wr.push(w);
    }
    let parts = split_rows(rows, threads, |r| {
        let mut out = Derivatives::default();
        let mut w = el.work(model);
        let mut h = Vec::new();
        let mut jac = vec![0.0; 6 * n];
        for i in r {
            let gi = i.min(given - 1);
            let cmd = batch.commands(gi, mp, md, wr[i]);
            let laws = el.laws(model, &cmd).expect("checked above");
            let q = &theta[i * n..(i + 1) * n];
            el.evaluate(model, &laws, &wr[i], q, 2, &mut w);
            el.dense_hessian(&w, &mut h);
            w.chain.world(model, model);
            w.chain.joints_world(model);
            w.chain.geometric_jacobian(&mut jac);
            let mat = Mat::<f64>::from_fn(n, n, |a, b| h[a * n + b]);
            let llt = mat.llt(faer::Side::Lower).ok();
            out.definite.push(llt.is_some());
            // dsigma/dp at fixed q per command column (0 unless taut)
            let dsig_l: Vec<f64> = el
                .pos
                .iter()
                .enumerate()
                .map(|(p, &c)| {
                    if w.c[c] > 0.0 {
                        -laws.k[c] * (w.len[c] + el.lr) / (cmd.lengths[p] + el.lr)
                    } else {
                        0.0
                    }
                })
                .collect();
            let dsig_d: Vec<f64> = el
                .dis
                .iter()
                .map(|&c| if w.c[c] > 0.0 { laws.k[c] } else { 0.0 })
                .collect();
            let groups: [(&[usize], &[f64]); 2] = [(&el.pos, &dsig_l), (&el.dis, &dsig_d)];
            for (gi, (cols, dsig)) in groups.iter().enumerate() {
                let p = cols.len();
                // rhs = dg/dp (n x p)
                let rhs = Mat::<f64>::from_fn(n, p, |j, k| w.grad_l[cols[k] * n + j] * dsig[k]);
                let dq = solve_neg(&llt, &rhs, n, p);
                let (th, ta, te) = if gi == 0 {
                    (
                        &mut out.theta_lengths,
                        &mut out.task_lengths,
                        &mut out.tension_lengths,
                    )
                } else {
                    (
                        &mut out.theta_displacements,
                        &mut out.task_displacements,
                        &mut out.tension_displacements,
                    )
                };
                push_parts(
                    th,
                    ta,
                    te,
                    &dq,
                    n,
                    p,
                    &jac,
                    &task_rows,
                    &w,
                    m,
                    Some((cols, dsig)),
                );
            }
            let rhs = Mat::<f64>::from_fn(n, t, |j, k| -jac[task_rows[k] * n + j]);
            let dq = solve_neg(&llt, &rhs, n, t);
            push_parts(
                &mut out.theta_wrench,
                &mut out.task_wrench,
                &mut out.tension_wrench,
                &dq,
                n,
                t,
                &jac,
                &task_rows,
                &w,
                m,
                None,
            );
        }
        out
    });
    let mut out = Derivatives::default();
    for p in parts {
        out.theta_lengths.extend(p.theta_lengths);
        out.theta_displacements.extend(p.theta_displacements);
        out.theta_wrench.extend(p.theta_wrench);
        out.task_lengths.extend(p.task_lengths);
        out.task_displacements.extend(p.task_displacements);
        out.task_wrench.extend(p.task_wrench);
        out.tension_lengths.extend(p.tension_lengths);
        out.tension_displacements.extend(p.tension_displacements);
        out.tension_wrench.extend(p.tension_wrench);
        out.definite.extend(p.definite);
    }
    Ok(out)
}

/// `-H^-1 rhs` (`n x p`, row-major) or NaN without a factorisation.
fn solve_neg(
    llt: &Option<faer::linalg::solvers::Llt<f64>>,
    rhs: &Mat<f64>,
    n: usize,
    p: usize,
) -> Vec<f64> {
    match llt {
        None => vec![f64::NAN; n * p],
        Some(l) => {
            let x = l.solve(rhs);
            let mut out = vec![0.0; n * p];
            for j in 0..n {
                for k in 0..p {
                    out[j * p + k] = -x[(j, k)];
                }
            }
            out
        }
    }
}

/// Appends one row's `theta_*`, `task_*` and `tension_*` of `dq (n x p)`.
#[allow(clippy::too_many_arguments)]
fn push_parts(
    th: &mut Vec<f64>,
    ta: &mut Vec<f64>,
    te: &mut Vec<f64>,
    dq: &[f64],
    n: usize,
    p: usize,
    jac: &[f64],
    task_rows: &[usize],
    w: &Work,
    m: usize,
    direct: Option<(&&[usize], &&[f64])>,
) {
    th.extend_from_slice(dq);
    for &r in task_rows {
        for k in 0..p {
            ta.push((0..n).map(|j| jac[r * n + j] * dq[j * p + k]).sum());
        }
    }
    for c in 0..m {
        for k in 0..p {
            let mut v = if w.c[c] > 0.0 {
                w.c[c]
                    * (0..n)
                        .map(|j| w.grad_l[c * n + j] * dq[j * p + k])
                        .sum::<f64>()
            } else {
                0.0
            };
            if let Some((cols, dsig)) = direct {
                if cols[k] == c {
                    v += dsig[k];
                }
            }
            te.push(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FTDCR: &str = include_str!("../tests/data/opencr/ftdcr_v4.toml");

    fn ftdcr() -> Model {
        Model::from_toml(FTDCR).unwrap()
    }

    #[test]
    fn the_ftdcr_reads_with_its_backbone_springs() {
        let m = ftdcr();
        assert_eq!(m.n(), 60);
        assert_eq!(m.displacement_cables().len(), 9);
        // E I / l with l = L / 30 (docs/model.md: 0.39480 N m/rad)
        let want = 50e9 * std::f64::consts::PI * 0.0005f64.powi(4) / 4.0 / (0.1865 / 30.0);
        for j in &m.joints {
            assert!(
                (j.stiffness - want).abs() <= 1e-12 * want,
                "{}",
                j.stiffness
            );
        }
        assert!((want - 0.39480).abs() < 1e-5);
    }

    #[test]
    fn the_gradient_and_hessian_meet_central_differences() {
        let m = ftdcr();
        let el = Elastic::new(&m);
        let d = [0.004, -0.003, 0.0, 0.006, 0.0, -0.002, 0.001, 0.0, 0.0];
        for wrench in [[0.0; 6], [0.3, -0.2, 0.1, 0.0, 0.0, 0.0]] {
            let cmd = Commands {
                lengths: &[],
                displacements: &d,
                wrench,
            };
            let q: Vec<f64> = (0..60).map(|j| 0.02 * ((j as f64) * 0.7).sin()).collect();
            let (_, g, h) = el.potential(&m, &cmd, &q).unwrap();
            let e = 1e-6;
            for j in (0..60).step_by(7) {
                let (mut a, mut b) = (q.clone(), q.clone());
                a[j] += e;
                b[j] -= e;
                let (ua, ga, _) = el.potential(&m, &cmd, &a).unwrap();
                let (ub, gb, _) = el.potential(&m, &cmd, &b).unwrap();
                let fd = (ua - ub) / (2.0 * e);
                assert!(
                    (g[j] - fd).abs() <= 1e-6 * (1.0 + fd.abs()),
                    "g {j}: {} vs {fd}",
                    g[j]
                );
                for i in 0..60 {
                    let fd = (ga[i] - gb[i]) / (2.0 * e);
                    assert!(
                        (h[i * 60 + j] - fd).abs() <= 1e-5 * (1.0 + fd.abs()),
                        "H {i} {j}: {} vs {fd}",
                        h[i * 60 + j]
                    );
                }
            }
        }
    }

    #[test]
    fn the_arms_bound_every_cable_gradient() {
        // |dL_c/dq_j| <= arm_cj at configurations far from the rest angles
        let m = ftdcr();
        let el = Elastic::new(&m);
        let laws = el
            .laws(
                &m,
                &Commands {
                    lengths: &[],
                    displacements: &[0.0; 9],
                    wrench: [0.0; 6],
                },
            )
            .unwrap();
        let mut w = el.work(&m);
        for r in 0..20 {
            let q: Vec<f64> = (0..60)
                .map(|j| 0.6 * ((j * 7 + r * 13) as f64 * 0.37).sin())
                .collect();
            el.evaluate(&m, &laws, &[0.0; 6], &q, 1, &mut w);
            for (g, a) in w.grad_l.iter().zip(&el.arm) {
                assert!(g.abs() <= *a, "{g} > {a}");
            }
        }
    }

    #[test]
    fn a_cable_bounded_slack_is_as_evaluated() {
        // the Newton iteration's evaluation, which skips the lengths of the
        // cables its bound tells slack, gives U, g, H's parts and the
        // tensions of the full evaluation, bit for bit
        let m = ftdcr();
        let el = Elastic::new(&m);
        let d = [0.004, -0.003, 0.0, 0.006, 0.0, -0.002, 0.001, 0.0, 0.0];
        let laws = el
            .laws(
                &m,
                &Commands {
                    lengths: &[],
                    displacements: &d,
                    wrench: [0.0; 6],
                },
            )
            .unwrap();
        let (mut a, mut b) = (el.work(&m), el.work(&m));
        let mut skipped = 0;
        let mut q: Vec<f64> = vec![0.0; 60];
        for r in 0..6 {
            el.evaluate_pulling(&m, &laws, &[0.0; 6], &q, 2, &mut a);
            el.evaluate(&m, &laws, &[0.0; 6], &q, 2, &mut b);
            skipped += a.exact.iter().filter(|e| !**e).count();
            assert_eq!(a.u.to_bits(), b.u.to_bits());
            assert_eq!(a.g, b.g);
            assert_eq!(a.t, b.t);
            assert_eq!(a.d, b.d);
            assert_eq!(a.c, b.c);
            for (sa, sb) in a.sigma.iter().zip(&b.sigma) {
                assert!(sa == sb || (*sb < 0.0 && sa >= sb && *sa < 0.0));
            }
            for (j, qj) in q.iter_mut().enumerate() {
                *qj += 1e-3 * ((j + r) as f64 * 0.9).cos();
            }
        }
        assert!(skipped > 0);
    }

    #[test]
    fn the_structured_step_is_the_dense_one() {
        let m = ftdcr();
        let el = Elastic::new(&m);
        let d = [0.004, -0.003, 0.0, 0.006, 0.0, -0.002, 0.001, 0.0, 0.0];
        let cmd = Commands {
            lengths: &[],
            displacements: &d,
            wrench: [0.0; 6],
        };
        let q: Vec<f64> = (0..60).map(|j| 0.01 * ((j as f64) * 0.3).cos()).collect();
        let (a, b) = el.steps(&m, &cmd, &q).unwrap();
        let (a, b) = (a.unwrap(), b.unwrap());
        let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() <= 1e-10 * scale, "{x} vs {y}");
        }
    }

    #[test]
    fn the_structured_step_of_one_joint_disks_is_the_dense_one() {
        // the paper's planar arm with springs, no loads: 1 x 1 blocks
        let text = include_str!("../python/cdsm/robots/paper.toml").replace(
            "[[linkage]]\n",
            "[[linkage]]\nstiffness = 2.0\nrest_angle = 0.02\n",
        );
        let m = Model::from_toml(&text).unwrap();
        let el = Elastic::new(&m);
        assert!(!el.pairs && m.position_cables().len() == 3);
        let at = [0.1, -0.2, 0.3];
        let mut ch = Chn::new(&m);
        ch.at(&m, &m, &at);
        let lengths: Vec<f64> = m
            .position_cables()
            .iter()
            .map(|&c| ch.cable_length(&m, &m, c, None) - 1e-5)
            .collect();
        let cmd = Commands {
            lengths: &lengths,
            displacements: &[],
            wrench: [0.0; 6],
        };
        // three taut cables (1e-5 m stretched) and the springs
        let (a, b) = el.steps(&m, &cmd, &at).unwrap();
        let (a, b) = (a.unwrap(), b.unwrap());
        let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(scale > 1e-6, "{b:?}");
        for (x, y) in a.iter().zip(&b) {
            assert!((x - y).abs() <= 1e-10 * scale, "{x} vs {y}");
        }
    }

    #[test]
    fn a_block_inverse_is_the_inverse() {
        for n in 1..=3 {
            // a symmetric positive definite n x n
            let a: Vec<f64> = (0..n * n)
                .map(|k| {
                    let (i, j) = (k / n, k % n);
                    if i == j {
                        3.0 + i as f64
                    } else {
                        0.5 + 0.1 * (i + j) as f64
                    }
                })
                .collect();
            let mut l = a.clone();
            assert!(cholesky(&mut l, n));
            let mut inv = vec![0.0; n * n];
            invert_from_cholesky(&l, n, &mut inv);
            for i in 0..n {
                for j in 0..n {
                    let e: f64 = (0..n).map(|k| a[i * n + k] * inv[k * n + j]).sum();
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((e - want).abs() < 1e-14, "{n}: ({i}, {j}) {e}");
                }
            }
        }
    }

    fn sequence_rows(rows: usize) -> Vec<f64> {
        (0..rows * 9)
            .map(|k| {
                let (i, c) = ((k / 9) as f64, (k % 9) as f64);
                0.004 * ((0.7 * c + 0.4 * i).sin()) - 0.001
            })
            .collect()
    }

    #[test]
    fn a_sequence_is_its_rows_each_from_the_previous_answer() {
        // the sequence starts each row at the previous row's last point
        // evaluated (within `xtol` of its answer), its geometry kept, not
        // computed again: the answers of the rows each from the previous
        // answer, to the rounding of a converged minimum
        let m = ftdcr();
        let el = Elastic::new(&m);
        let rows = 8;
        let d = sequence_rows(rows);
        let batch = Batch {
            lengths: &[],
            displacements: &d,
            wrench: &[],
        };
        let seq = equilibria(&m, &batch, None, true, XTOL, 100, 1).unwrap();
        let mut q = el.rest.clone();
        for i in 0..rows {
            let cmd = Commands {
                lengths: &[],
                displacements: &d[i * 9..(i + 1) * 9],
                wrench: [0.0; 6],
            };
            let e = el.equilibrium(&m, &cmd, &q, XTOL, 100).unwrap();
            assert!(e.converged && seq.converged[i], "{i}: {:?}", e.reason);
            for (a, b) in e.theta.iter().zip(&seq.theta[i * 60..(i + 1) * 60]) {
                assert!((a - b).abs() < 1e-14, "{i}: {a} {b}");
            }
            for (a, b) in e.tension.iter().zip(&seq.tension[i * 9..(i + 1) * 9]) {
                assert!((a - b).abs() < 1e-10, "{i}: {a} {b}");
            }
            assert_eq!(e.slack, seq.slack[i * 9..(i + 1) * 9], "{i}");
            q = e.theta;
        }
        assert!(seq.slack.iter().any(|s| *s) && seq.slack.iter().any(|s| !*s));
    }

    #[test]
    fn a_converged_answer_carries_the_values_at_its_angles() {
        // the tensions, flags and potential of an answer are carried over
        // its last step (at most `xtol`), not evaluated again: they are the
        // values at its angles to rounding
        let m = ftdcr();
        let el = Elastic::new(&m);
        let d = sequence_rows(6);
        let batch = Batch {
            lengths: &[],
            displacements: &d,
            wrench: &[],
        };
        for sequence in [false, true] {
            let e = equilibria(&m, &batch, None, sequence, XTOL, 100, 1).unwrap();
            for i in 0..6 {
                assert!(e.converged[i]);
                let cmd = Commands {
                    lengths: &[],
                    displacements: &d[i * 9..(i + 1) * 9],
                    wrench: [0.0; 6],
                };
                let laws = el.laws(&m, &cmd).unwrap();
                let mut w = el.work(&m);
                let theta = &e.theta[i * 60..(i + 1) * 60];
                el.evaluate(&m, &laws, &cmd.wrench, theta, 1, &mut w);
                // the rounding levels of `sigma` (64 ulps of `k L`) and `U`
                let ulps = ROUNDING_ULPS * f64::EPSILON;
                for c in 0..9 {
                    let t = e.tension[i * 9 + c];
                    let tol = ulps * laws.k[c] * w.len[c];
                    assert!((t - w.t[c]).abs() <= tol, "{i} {c}: {t} {}", w.t[c]);
                    assert_eq!(e.slack[i * 9 + c], w.sigma[c] <= 0.0, "{i} {c}");
                }
                assert!((e.energy[i] - w.u).abs() <= ulps * w.scale, "{i}");
                let g = w.g.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                assert!(
                    g < 1e-9 && e.gradient[i] < 1e-9,
                    "{i}: {g} {}",
                    e.gradient[i]
                );
            }
        }
    }

    #[test]
    fn an_ftdcr_equilibrium_is_a_minimum_with_slack_tendons() {
        let m = ftdcr();
        let mut d = vec![-0.01; 9];
        d[0] = 0.01;
        let batch = Batch {
            lengths: &[],
            displacements: &d,
            wrench: &[],
        };
        let e = equilibria(&m, &batch, None, false, XTOL, 100, 1).unwrap();
        assert!(e.converged[0], "{:?}", e.reason);
        assert!(e.gradient[0] < 1e-9, "{}", e.gradient[0]);
        // pulled: tendon 0 taut, the paid-out others slack
        assert!(!e.slack[0] && e.tension[0] > 0.0);
        assert!(
            e.slack[1..].iter().filter(|s| **s).count() >= 6,
            "{:?}",
            e.slack
        );
    }
}
