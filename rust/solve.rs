//! The cable solve (position-cable lengths -> joint angles), one driver
//! ([`CableSolver`]) over two evaluators picked once from the arm: its
//! planar view present, the planar one ([`PlanarSolver`]: the closed form,
//! joint by joint (fast path and branch census), and damped Newton through
//! the shared solver ([`crate::lm`]) with its triangular step); else the
//! chain's ([`ChainSolver`], any arm, with its Newton phase on lanes
//! [`CableNewton`]). The options and the per-element status shared with
//! the pose IK ([`crate::ik`]) live here. The algorithms are specified in
//! `docs/model.md`.

use crate::cables::CableGeometry;
use crate::chain::{ArmNumbers, Broadcast, Chain, Numbers};
use crate::error::{CdsmError, Result};
use crate::geometry::ArmGeometry;
use crate::kinds::Frame;
use crate::limits::Limits;
use crate::lm::{self, Blocks, Damping, Lm, Problem, Reason, Step, Workspace};
use crate::model::{Model, PlanarNumbers};
use crate::real::Lane;
use crate::robot::PlanarView;
use crate::simd::math::cos_sin_short;
use std::borrow::Cow;

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

impl SolveOptions {
    /// Rejects options outside their domain, naming the option.
    pub fn check(&self) -> Result<()> {
        if !(self.tol.is_finite() && self.tol > 0.0) {
            return Err(CdsmError::Option {
                name: "tol".into(),
                problem: format!("must be positive and finite, got {}", self.tol),
            });
        }
        if self.max_iter == 0 {
            return Err(CdsmError::Option {
                name: "max_iter".into(),
                problem: "must be at least 1".into(),
            });
        }
        Ok(())
    }
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
pub type Status = lm::Status;

/// The status of a closed-form answer (no trial steps).
pub fn closed_form_status(residual: Option<f64>, tol: f64) -> Status {
    match residual {
        Some(r) => Status {
            converged: r <= tol,
            iterations: 0,
            residual: r,
            cost: r * r,
            reason: if r <= tol {
                Reason::Converged
            } else {
                Reason::Singular
            },
        },
        None => Status {
            converged: false,
            iterations: 0,
            residual: f64::INFINITY,
            cost: f64::INFINITY,
            // the branch nearest the seed has no answer; the other may
            reason: Reason::Stalled,
        },
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
    /// Closed form, verified; damped Newton from the closed form (or the seed) if it fails.
    Auto,
    /// Damped Newton only.
    Newton,
    /// Closed form only.
    ClosedForm,
}

/// The damped-Newton problem of the cable solve: `r = L_upper(theta) - target`
/// with its lower-triangular Jacobian. `N` is the number of joints when it is
/// known at compile time (small arms: the solver's loops then have constant
/// trip counts), else 0 (any `n`, taken from `target`).
struct CableProblem<'a, const N: usize> {
    geom: &'a CableGeometry,
    target: &'a [f64],
    /// `(cos, sin)` and segment lengths of the last evaluation (its Jacobian
    /// is formed from them when the solver asks): a small arm's (`N > 0`)
    /// in the problem, the solver's buffers otherwise
    cs_n: [(f64, f64); N],
    roots_n: [[f64; N]; N],
    cs: &'a mut [(f64, f64)],
    roots: &'a mut [f64],
    /// The joint-limit box when the limits are enforced.
    limits: Option<Limits<&'a [[f64; 2]]>>,
}

impl<const N: usize> CableProblem<'_, N> {
    /// The `(cos, sin)` and segment-length buffers of an `n`-joint arm.
    #[inline(always)]
    fn buffers(&mut self, n: usize) -> (&mut [(f64, f64)], &mut [f64]) {
        if N > 0 {
            (&mut self.cs_n[..], self.roots_n.as_flattened_mut())
        } else {
            (&mut self.cs[..n], &mut self.roots[..n * n])
        }
    }
}

impl<const N: usize> Problem for CableProblem<'_, N> {
    #[inline(always)]
    fn dims(&self) -> (usize, usize) {
        let n = if N > 0 { N } else { self.target.len() };
        (n, n)
    }

    #[inline(always)]
    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        let n = self.dims().0;
        let geom = self.geom;
        let (cs, roots) = self.buffers(n);
        let r = &mut r[..n];
        cos_sin_short(&x[..n], cs);
        match jac {
            Some(j) => geom.upper_lengths_and_jacobian(cs, r, &mut j[..n * n]),
            None => geom.upper_lengths_and_roots(cs, r, roots),
        }
        for (ri, ti) in r.iter_mut().zip(&self.target[..n]) {
            *ri -= ti;
        }
        true
    }

    /// Trials are evaluated without their Jacobian (no divisions): it is
    /// formed at accepted points from the evaluation's segment lengths.
    #[inline(always)]
    fn jacobian_with_residual(&self) -> bool {
        false
    }

    #[inline(always)]
    fn jacobian(&mut self, _x: &[f64], jac: &mut [f64]) -> bool {
        let n = self.dims().0;
        let geom = self.geom;
        let (cs, roots) = self.buffers(n);
        let jac = &mut jac[..n * n];
        jac.copy_from_slice(roots);
        geom.roots_to_jacobian(cs, jac);
        true
    }

    /// The answer's Jacobian is not needed: a trial within tol ends the
    /// solve without it.
    #[inline(always)]
    fn answer_jacobian(&self) -> bool {
        false
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

/// The damped-Newton settings of the cable solve: the triangular step,
/// starting undamped.
pub fn newton_lm(opts: &SolveOptions) -> Lm {
    Lm {
        lambda0: 0.0,
        ..Lm::equations(Step::Triangular, opts.tol, opts.max_iter)
    }
}

/// The planar evaluator's solver (the closed form, then undamped-first
/// triangular Newton on the PQR coefficients) on a planar view, with its
/// buffers, reused across many solves (no allocation per solve). Made by
/// [`CableSolver::new`] for an arm with a planar view; the planar fast
/// paths reach it there ([`CableSolver::planar_mut`]) to solve against
/// other cable geometries (perturbed holes) and to finish SIMD closed forms.
pub struct PlanarSolver<'a> {
    robot: Cow<'a, PlanarView>,
    pub method: CableMethod,
    pub opts: SolveOptions,
    lm: Lm,
    ws: Workspace,
    seed: Vec<f64>,
    seed_cs: Vec<(f64, f64)>,
    /// cos/sin of the last answer when `cs_fresh` (else of some trial)
    cs: Vec<(f64, f64)>,
    cs_fresh: bool,
    /// segment lengths of the last evaluation (`n x n`, arms past 4 joints)
    roots: Vec<f64>,
}

impl<'a> PlanarSolver<'a> {
    /// The planar solver of the view `robot` (borrowed or owned).
    pub fn new(robot: Cow<'a, PlanarView>, method: CableMethod, opts: SolveOptions) -> Self {
        let n = robot.n();
        PlanarSolver {
            robot,
            method,
            opts,
            lm: newton_lm(&opts),
            ws: Workspace::default(),
            seed: vec![0.0; n],
            seed_cs: vec![(1.0, 0.0); n],
            cs: vec![(1.0, 0.0); n],
            cs_fresh: false,
            roots: vec![0.0; n * n],
        }
    }

    fn newton(&mut self, geom: &CableGeometry, target: &[f64], theta: &mut [f64]) -> Status {
        fn run<const N: usize>(
            s: &mut PlanarSolver,
            geom: &CableGeometry,
            target: &[f64],
            theta: &mut [f64],
        ) -> Status {
            let mut p = CableProblem::<N> {
                geom,
                target,
                cs_n: [(1.0, 0.0); N],
                roots_n: [[0.0; N]; N],
                cs: &mut s.cs,
                roots: &mut s.roots,
                limits: s.opts.enforce_limits.then(|| s.robot.limits()),
            };
            lm::solve_undamped_first::<_, N>(&mut p, theta, &s.lm, &mut s.ws)
        }
        let st = match target.len() {
            1 => run::<1>(self, geom, target, theta),
            2 => run::<2>(self, geom, target, theta),
            3 => run::<3>(self, geom, target, theta),
            4 => run::<4>(self, geom, target, theta),
            _ => run::<0>(self, geom, target, theta),
        };
        // `self.cs` does not hold the answer's cos/sin (a small arm's stay
        // local; otherwise the last evaluation may have been a rejected trial)
        self.cs_fresh = false;
        st
    }

    /// Upper-cable lengths `target` (m) to `theta` (seed on entry, answer on exit).
    pub fn solve(&mut self, geom: &CableGeometry, target: &[f64], theta: &mut [f64]) -> Status {
        if self.method == CableMethod::Newton {
            return self.newton(geom, target, theta);
        }
        self.seed.copy_from_slice(theta);
        for (c, t) in self.seed_cs.iter_mut().zip(theta.iter()) {
            let (s, co) = t.sin_cos();
            *c = (co, s);
        }
        let closed =
            solve_cables_closed_form(geom, target, theta, &self.seed_cs, &mut self.cs, None);
        self.cs_fresh = closed.is_some();
        self.finish(geom, target, None, theta, closed)
    }

    /// The rest of [`PlanarSolver::solve`] once the closed form has run from
    /// the seed: `closed` its residual (`None`: no real solution, `theta`
    /// still the seed), `theta` its answer. Accepts it (within tol, and the
    /// limits when enforced), or reports why not (`ClosedForm`), or runs
    /// damped Newton (`Auto`) from the closed form's answer when it had one
    /// within the limits, else from the seed. `seed`: the seed angles when
    /// they are not already the solver's (copied only when a row is not
    /// accepted).
    fn finish(
        &mut self,
        geom: &CableGeometry,
        target: &[f64],
        seed: Option<&[f64]>,
        theta: &mut [f64],
        closed: Option<f64>,
    ) -> Status {
        let ok = closed.is_some();
        let mut closed = closed;
        let limits = self.robot.limits();
        let mut in_box = !self.opts.enforce_limits || limits.contains(theta);
        if ok && !in_box {
            // an answer a rounding outside a limit (a configuration on the
            // limit): the limit itself, when its lengths still match
            let mut on = theta.to_vec();
            limits.clamp(&mut on);
            let mut l = vec![0.0; 2 * self.robot.n()];
            geom.lengths(&on, &mut l);
            let r = target
                .iter()
                .enumerate()
                .map(|(i, t)| (l[2 * i] - t).abs())
                .fold(0.0, f64::max);
            if r <= self.opts.tol {
                theta.copy_from_slice(&on);
                self.cs_fresh = false;
                closed = Some(r);
                in_box = true;
            }
        }
        let st = closed_form_status(closed, self.opts.tol);
        if closed.is_some_and(|r| self.accepts(r, in_box)) {
            return st;
        }
        if let Some(s) = seed {
            self.seed.copy_from_slice(s);
        }
        if self.method == CableMethod::ClosedForm {
            if !ok {
                theta.copy_from_slice(&self.seed);
                self.refresh(theta);
            }
            let reason = if ok && !in_box {
                Reason::OutsideLimits
            } else {
                st.reason
            };
            return Status {
                converged: false,
                reason,
                ..st
            };
        }
        if !ok || !in_box {
            theta.copy_from_slice(&self.seed);
        }
        self.newton(geom, target, theta)
    }

    /// Whether a closed-form answer with residual `residual` (m) is accepted
    /// as it is: within tol, and within the joint limits (`within_limits`)
    /// when they are enforced.
    #[inline]
    pub fn accepts(&self, residual: f64, within_limits: bool) -> bool {
        residual <= self.opts.tol && (within_limits || !self.opts.enforce_limits)
    }

    /// [`PlanarSolver::finish`] for a closed form computed elsewhere (SIMD
    /// across rows): `seed` the seed angles it started from.
    pub fn finish_from(
        &mut self,
        geom: &CableGeometry,
        target: &[f64],
        seed: &[f64],
        theta: &mut [f64],
        closed: Option<f64>,
    ) -> Status {
        self.cs_fresh = false;
        self.finish(geom, target, Some(seed), theta, closed)
    }

    fn refresh(&mut self, theta: &[f64]) {
        for (c, t) in self.cs.iter_mut().zip(theta) {
            let (s, co) = t.sin_cos();
            *c = (co, s);
        }
        self.cs_fresh = true;
    }

    /// End pose at the angles `theta` of the last solve (from the closed
    /// form's cos/sin when it gave the answer).
    pub fn pose(&mut self, theta: &[f64]) -> [f64; 3] {
        if !self.cs_fresh {
            self.refresh(theta);
        }
        self.robot.fk_cs(&self.cs, theta.iter().sum())
    }
}

/// Upper-cable lengths `target` (m) to `theta` (seed on entry): one solve.
#[cfg(test)]
pub(crate) fn solve_cables(
    robot: &PlanarView,
    geom: &CableGeometry,
    target: &[f64],
    theta: &mut [f64],
    method: CableMethod,
    opts: &SolveOptions,
) -> Status {
    PlanarSolver::new(Cow::Borrowed(robot), method, *opts).solve(geom, target, theta)
}

/// The position cables' residuals `r = L(x) - target` (m) and their
/// Jacobian `jac` (`(m, n)` row-major, m/rad) at `x` (rad): the chain at
/// `x` (the `(cos, sin)` by the lane kernel), then each cable's length and
/// row in one pass. Written once over the lane scalar: the damped solver's
/// problem ([`GeneralProblem`], `f64`) and the Newton phase on lanes
/// ([`CableNewton`]) evaluate with the same operations.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn cable_residuals<L: Lane, F: Frame<L>, N: Numbers<L>>(
    model: &Model,
    nums: &N,
    cables: &[usize],
    chain: &mut Chain<L, F>,
    x: &[L],
    target: &[L],
    r: &mut [L],
    jac: &mut [L],
) {
    let n = x.len();
    L::cos_sin(x, &mut chain.cs);
    chain.at_cs(model, nums, x);
    for (i, &c) in cables.iter().enumerate() {
        let row = &mut jac[i * n..(i + 1) * n];
        r[i] = chain.cable_length_and_row(model, nums, c, row) - target[i];
    }
}

/// The general cable solve as a problem of the damped solver.
struct GeneralProblem<'a, F: Frame<f64>, N> {
    model: &'a Model,
    nums: &'a N,
    cables: &'a [usize],
    target: &'a [f64],
    chain: &'a mut Chain<f64, F>,
    blocks: Option<&'a Blocks>,
    limits: Option<Limits<&'a [[f64; 2]]>>,
}

impl<F: Frame<f64>, N: Numbers<f64>> Problem for GeneralProblem<'_, F, N> {
    fn dims(&self) -> (usize, usize) {
        (self.cables.len(), self.model.n())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        match jac {
            Some(jac) => cable_residuals(
                self.model,
                self.nums,
                self.cables,
                self.chain,
                x,
                self.target,
                r,
                jac,
            ),
            None => {
                f64::cos_sin(x, &mut self.chain.cs);
                self.chain.at_cs(self.model, self.nums, x);
                for (i, &c) in self.cables.iter().enumerate() {
                    r[i] = self.chain.cable_length(self.model, self.nums, c, None) - self.target[i];
                }
            }
        }
        r.iter().all(|v| v.is_finite())
    }

    fn blocks(&self) -> Option<&Blocks> {
        self.blocks
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

/// The block lower-triangular structure of the position cables' Jacobian
/// (rows: the position cables `cables`; columns: the joints) when as many
/// of them end at each disk as it has joints: a cable's length does not
/// depend on the joints past the disk it ends at, so the cables ending at
/// disk `k` and the joints of disk `k` form the diagonal blocks. `None`
/// otherwise.
pub fn cable_blocks(model: &Model, cables: &[usize]) -> Option<Blocks> {
    let mut rows = Vec::with_capacity(cables.len());
    let mut cols = Vec::with_capacity(model.disks.len());
    for (d, disk) in model.disks.iter().enumerate() {
        let ending = cables
            .iter()
            .enumerate()
            .filter(|(_, &c)| model.cables[c].end == d + 1)
            .map(|(i, _)| i);
        let before = rows.len();
        rows.extend(ending);
        if rows.len() - before != disk.joints.len() {
            return None;
        }
        cols.push(disk.joints.clone());
    }
    Some(Blocks { rows, cols })
}

/// The least-squares stop of the general cable solve with more cables than
/// joints: converged when an accepted step lowers `|r|^2` by less than this
/// fraction of itself.
pub const MIN_DECREASE: f64 = 1e-12;

/// The damped solver's settings of the general cable solve of `m` cables
/// and `n` joints: undamped first; as many cables as joints, the square
/// Newton step ([`Step::Square`]); more, Gauss–Newton on the normal
/// equations, least squares.
fn general_lm(m: usize, n: usize, opts: &SolveOptions) -> Lm {
    let step = if m == n { Step::Square } else { Step::Normal };
    Lm {
        lambda0: 0.0,
        min_decrease: if m > n { MIN_DECREASE } else { 0.0 },
        ..Lm::equations(step, opts.tol, opts.max_iter)
    }
}

/// The general cable solve (`docs/model.md`, "Solves"): the lengths of the
/// position-controlled cables to the joint angles through the shared solver
/// on the chain of either kind and any numbers (the model's own, or a
/// plant's moved arm). As many cables as joints: Newton on the square cable
/// Jacobian (LU), damped when a step does not lower `|r|^2`; more: least
/// squares (converged when an accepted step lowers the squared misfit by
/// less than [`MIN_DECREASE`] of itself). With its buffers, reused across
/// solves and across arms of the model's structure with other numbers (no
/// allocation per solve). Batches run the Newton phase on lanes first
/// ([`CableNewton`]) and come here for the rows that leave it.
pub struct ChainSolver<F: Frame<f64>> {
    cables: Vec<usize>,
    blocks: Option<Blocks>,
    opts: SolveOptions,
    limits: Limits,
    ws: Workspace,
    traverse: Vec<f64>,
    /// The chain at the last evaluation (the answer's when the solve
    /// converged by `tol`).
    pub chain: Chain<f64, F>,
}

impl<F: Frame<f64>> ChainSolver<F> {
    pub fn new(model: &Model, opts: SolveOptions) -> Self {
        let cables = model.position_cables();
        ChainSolver {
            blocks: cable_blocks(model, &cables),
            cables,
            opts,
            limits: model.limits(),
            ws: Workspace::default(),
            traverse: Vec::with_capacity(model.cables.len()),
            chain: Chain::new(model),
        }
    }

    /// Lengths `target` (m) of the position-controlled cables (file order)
    /// of the arm `nums` to `theta` (seed on entry, answer on exit).
    pub fn solve<N: Numbers<f64>>(
        &mut self,
        model: &Model,
        nums: &N,
        target: &[f64],
        theta: &mut [f64],
    ) -> Status {
        Broadcast::traversals(model, nums, &self.cables, &mut self.traverse);
        let arm = Broadcast::new(nums, &self.traverse);
        let (m, n) = (self.cables.len(), model.n());
        let mut p = GeneralProblem {
            model,
            nums: &arm,
            cables: &self.cables,
            target,
            chain: &mut self.chain,
            blocks: self.blocks.as_ref(),
            limits: self
                .opts
                .enforce_limits
                .then(|| Limits(self.limits.bounds())),
        };
        lm::solve(&mut p, theta, &general_lm(m, n, &self.opts), &mut self.ws)
    }
}

/// The numbers of an arm as the one cable solver ([`CableSolver`]) reads
/// them: the chain's ([`Numbers`]) and their planar view
/// ([`Model::planar_view`]), where the structure has one.
pub trait CableNumbers: Numbers<f64> {
    /// The planar view of the arm `model` with these numbers (borrowed when
    /// the model keeps it), `None` when it has none.
    fn planar_view<'a>(&'a self, model: &'a Model) -> Option<Cow<'a, PlanarView>>;
}

/// A model's own numbers: its kept planar view ([`Model::planar`]).
impl CableNumbers for Model {
    fn planar_view<'a>(&'a self, _model: &'a Model) -> Option<Cow<'a, PlanarView>> {
        self.planar().map(Cow::Borrowed)
    }
}

/// A moved arm's numbers (a plant's): the planar view of them.
impl CableNumbers for ArmNumbers<f64> {
    fn planar_view<'a>(&'a self, model: &'a Model) -> Option<Cow<'a, PlanarView>> {
        model
            .planar_view(&PlanarNumbers {
                axis: &self.axis,
                offset: &self.offset,
                link_after: &self.link_after,
                thickness: &self.thickness,
                holes: &self.holes,
            })
            .map(Cow::Owned)
    }
}

/// Whether the cable solver of the arm `nums` of `model`'s structure
/// solves by the planar evaluator ([`CableSolver::new`]'s choice: the arm
/// has a planar view); batches pick their fast path by it.
pub fn planar_evaluator<N: CableNumbers>(model: &Model, nums: &N) -> bool {
    nums.planar_view(model).is_some()
}

/// The cable solve's evaluator, picked once per solver.
enum Evaluator<'a, F: Frame<f64>> {
    /// The planar view's: PQR coefficients, closed form, triangular step.
    Planar {
        geom: CableGeometry,
        solver: PlanarSolver<'a>,
    },
    /// The chain's: lengths and rows in one pass, square or normal step.
    Chain(ChainSolver<F>),
}

/// The one cable solver (`docs/model.md`, "Solves"): the position-cable
/// lengths of the arm `nums` (of the model's structure) to its joint
/// angles, by the evaluator picked once from the arm: its planar view
/// present, the planar closed form and triangular Newton
/// ([`PlanarSolver`], by `method`); else the general solve on the chain
/// ([`ChainSolver`]; `method` is not read: it has no closed form). With
/// its buffers, reused across solves (no allocation per solve).
pub struct CableSolver<'a, F: Frame<f64>, N: CableNumbers = Model> {
    model: &'a Model,
    nums: &'a N,
    eval: Evaluator<'a, F>,
}

impl<'a, F: Frame<f64>, N: CableNumbers> CableSolver<'a, F, N> {
    /// The solver of the arm `nums` of `model`'s structure.
    pub fn new(model: &'a Model, nums: &'a N, method: CableMethod, opts: SolveOptions) -> Self {
        let eval = match nums.planar_view(model) {
            Some(view) => Evaluator::Planar {
                geom: CableGeometry::new(&view, None),
                solver: PlanarSolver::new(view, method, opts),
            },
            None => Evaluator::Chain(ChainSolver::new(model, opts)),
        };
        CableSolver { model, nums, eval }
    }

    /// Lengths `target` (m) of the position-controlled cables (file order)
    /// to `theta` (seed on entry, answer on exit).
    #[inline]
    pub fn solve(&mut self, target: &[f64], theta: &mut [f64]) -> Status {
        match &mut self.eval {
            Evaluator::Planar { geom, solver } => solver.solve(geom, target, theta),
            Evaluator::Chain(s) => s.solve(self.model, self.nums, target, theta),
        }
    }

    /// Whether the planar evaluator solves (cable `i` crosses the joints up
    /// to `i`: the lengths are lower triangular in the joints, the step of
    /// [`Step::Triangular`] applies to what is built on them).
    #[inline]
    pub fn is_planar(&self) -> bool {
        matches!(self.eval, Evaluator::Planar { .. })
    }

    /// The planar evaluator's solver and its nominal cable geometry (the
    /// planar fast paths), `None` on the chain's.
    pub fn planar_mut(&mut self) -> Option<(&mut PlanarSolver<'a>, &CableGeometry)> {
        match &mut self.eval {
            Evaluator::Planar { geom, solver } => Some((solver, geom)),
            Evaluator::Chain(_) => None,
        }
    }

    /// The chain evaluator's solver (the Newton phase on lanes leaves its
    /// rows to it, on arms of the model's structure with other numbers),
    /// `None` on the planar one.
    pub fn chain_mut(&mut self) -> Option<&mut ChainSolver<F>> {
        match &mut self.eval {
            Evaluator::Planar { .. } => None,
            Evaluator::Chain(s) => Some(s),
        }
    }
}

/// What the Newton phase of the general cable solve ([`CableNewton::run`])
/// decided on each lane.
#[derive(Debug, Clone, Copy)]
pub struct NewtonOutcome<L: Lane> {
    /// Lanes that converged (their status is [`NewtonOutcome::status`]).
    pub converged: L::Mask,
    /// Trial steps taken (per lane).
    pub iterations: L,
    /// `max |r|` and `|r|^2` at the answer (m, m^2).
    pub residual: L,
    pub cost: L,
}

impl<L: Lane> NewtonOutcome<L> {
    /// The status of lane `i` when it converged; `None` when it left the
    /// Newton phase (the damped solver decides it).
    pub fn status(&self, i: usize) -> Option<Status> {
        L::lane_set(self.converged, i).then(|| Status {
            converged: true,
            iterations: self.iterations.lane(i) as u32,
            residual: self.residual.lane(i),
            cost: self.cost.lane(i),
            reason: Reason::Converged,
        })
    }
}

/// The general cable solve's Newton phase on a lane scalar `L` (a pack of
/// rows; `f64` for one): the steps [`ChainSolver`]'s damped solver takes
/// while it takes no damping — Newton on the square cable Jacobian (LU,
/// [`lm::lu_solve`]), or with more cables than joints Gauss–Newton on the
/// normal equations (the damping `0`, then `1e-12`, [`lm::ldlt_solve`]) —
/// with the same evaluations and the same stops (`max|r| <= tol`; least
/// squares also a step lowering `|r|^2` by less than [`MIN_DECREASE`] of
/// itself), every lane on its own rows. A lane leaves the phase where the
/// damped solver would do something else: a step that does not lower
/// `|r|^2`, a singular Jacobian or a non-finite step, a residual that is
/// not finite, the iteration limit, or (least squares) a column of zeros;
/// [`ChainSolver`] then solves that row from its seed (`docs/model.md`,
/// "Solves": the fast path). Buffers reused across solves.
pub struct CableNewton<L: Lane, F: Frame<L>> {
    cables: Vec<usize>,
    blocks: Option<Blocks>,
    /// Per joint, the position cables (rows) that reach it: those ending
    /// at its disk or past it (the other rows of its Jacobian column are
    /// exact zeros).
    reach: Vec<Vec<usize>>,
    tol: f64,
    max_iter: u32,
    limits: Option<Vec<[L; 2]>>,
    /// The seeds on entry, the answers on exit (`n`, rad).
    pub x: Vec<L>,
    /// The position cables' target lengths (`m`, m).
    pub target: Vec<L>,
    r: Vec<L>,
    jac: Vec<L>,
    xt: Vec<L>,
    rt: Vec<L>,
    jact: Vec<L>,
    a: Vec<L>,
    delta: Vec<L>,
    /// The chain at the last evaluation: every converged lane's answer.
    pub chain: Chain<L, F>,
}

/// `sum r_i^2` and `max |r_i|` and whether every `r_i` is finite, per lane.
#[inline(always)]
fn norms<L: Lane>(r: &[L]) -> (L, L, L::Mask) {
    let mut cost = L::cst(0.0);
    let mut res = L::cst(0.0);
    let mut finite = L::mask(true);
    for v in r {
        cost += *v * *v;
        res = res.max(v.abs());
        finite = finite & v.finite();
    }
    (cost, res, finite)
}

impl<L: Lane, F: Frame<L>> CableNewton<L, F> {
    pub fn new(model: &Model, opts: SolveOptions) -> Self {
        let cables = model.position_cables();
        let (m, n) = (cables.len(), model.n());
        let z = L::cst(0.0);
        let reach = model
            .disks
            .iter()
            .enumerate()
            .flat_map(|(d, disk)| disk.joints.clone().map(move |_| d))
            .map(|d| {
                (0..m)
                    .filter(|&i| model.cables[cables[i]].end > d)
                    .collect()
            })
            .collect();
        CableNewton {
            blocks: cable_blocks(model, &cables),
            reach,
            cables,
            tol: opts.tol,
            max_iter: opts.max_iter,
            limits: opts.enforce_limits.then(|| {
                model
                    .joints
                    .iter()
                    .map(|j| [L::cst(j.limits[0]), L::cst(j.limits[1])])
                    .collect()
            }),
            x: vec![z; n],
            target: vec![z; m],
            r: vec![z; m],
            jac: vec![z; m * n],
            xt: vec![z; n],
            rt: vec![z; m],
            jact: vec![z; m * n],
            a: vec![z; n * n],
            delta: vec![z; n],
            chain: Chain::new(model),
        }
    }

    /// The Newton phase from the seeds [`CableNewton::x`] to the lengths
    /// [`CableNewton::target`] of the arm `nums` (a [`Broadcast`] of its
    /// numbers); the answers in `x` (those of lanes that left are
    /// unspecified).
    #[inline(always)]
    pub fn run<N: Numbers<L>>(&mut self, model: &Model, nums: &N) -> NewtonOutcome<L> {
        // one loop per case (each compiled without the other's steps)
        if self.cables.len() > model.n() {
            self.phase::<N, true>(model, nums)
        } else {
            self.phase::<N, false>(model, nums)
        }
    }

    /// [`CableNewton::run`] with as many cables as joints, or more
    /// (`LEAST_SQUARES`).
    #[inline(always)]
    fn phase<N: Numbers<L>, const LEAST_SQUARES: bool>(
        &mut self,
        model: &Model,
        nums: &N,
    ) -> NewtonOutcome<L> {
        let (m, n) = (self.cables.len(), model.n());
        let least_squares = LEAST_SQUARES;
        let zero = L::cst(0.0);
        cable_residuals(
            model,
            nums,
            &self.cables,
            &mut self.chain,
            &self.x,
            &self.target,
            &mut self.r,
            &mut self.jac,
        );
        let (mut cost, mut res, finite) = norms(&self.r);
        let mut converged = L::mask(false);
        // a lane whose residual cannot be evaluated leaves at once
        let mut done = !finite;
        let mut iterations = zero;
        let mut lambda = zero;
        let (tol, max_iter) = (L::cst(self.tol), L::cst(self.max_iter as f64));
        loop {
            let hit = !done & res.le(tol);
            converged = converged | hit;
            done = done | hit | !res.finite() | max_iter.le(iterations);
            if L::all(done) {
                break;
            }
            let mut live = !done;
            iterations += L::select(live, L::cst(1.0), zero);
            let ok = if least_squares {
                // a column of zeros is held out of the damped solver's step
                let mut blind = L::mask(false);
                for (k, rows) in self.reach.iter().enumerate() {
                    let mut zero_col = L::mask(true);
                    for &i in rows {
                        zero_col = zero_col & self.jac[i * n + k].eq(zero);
                    }
                    blind = blind | zero_col;
                }
                lm::normal_equations(
                    &self.jac,
                    &self.r,
                    m,
                    n,
                    Some(&self.reach),
                    lambda,
                    Damping::Levenberg,
                    &mut self.a,
                    &mut self.delta,
                );
                !blind & lm::ldlt_solve(n, &mut self.a, &mut self.delta)
            } else {
                lm::newton_step(
                    &self.jac,
                    &self.r,
                    n,
                    self.blocks.as_ref(),
                    &mut self.a,
                    &mut self.delta,
                )
            };
            let mut step_finite = L::mask(true);
            for d in &self.delta {
                step_finite = step_finite & d.finite();
            }
            let failed = live & !(ok & step_finite);
            done = done | failed;
            live = live & !failed;
            // the trial; lanes not stepping stay where they are
            for (k, (t, (x, d))) in self
                .xt
                .iter_mut()
                .zip(self.x.iter().zip(&self.delta))
                .enumerate()
            {
                let mut v = *x + *d;
                if let Some(l) = &self.limits {
                    // f64::clamp
                    let [lo, hi] = l[k];
                    v = L::select(v.lt(lo), lo, L::select(hi.lt(v), hi, v));
                }
                *t = L::select(live, v, *x);
            }
            cable_residuals(
                model,
                nums,
                &self.cables,
                &mut self.chain,
                &self.xt,
                &self.target,
                &mut self.rt,
                &mut self.jact,
            );
            let (c, res_t, finite_t) = norms(&self.rt);
            let accept = live & finite_t & c.lt(cost);
            done = done | (live & !accept);
            if least_squares {
                let small = accept & (cost - c).le(cost * MIN_DECREASE);
                converged = converged | small;
                done = done | small;
                lambda = L::select(accept, L::cst(lm::LAMBDA_MIN), lambda);
            }
            // every lane not stepping was evaluated where it stands: the
            // trial buffers hold every lane's current point
            std::mem::swap(&mut self.x, &mut self.xt);
            std::mem::swap(&mut self.r, &mut self.rt);
            std::mem::swap(&mut self.jac, &mut self.jact);
            cost = L::select(accept, c, cost);
            res = res_t;
        }
        NewtonOutcome {
            converged,
            iterations,
            residual: res,
            cost,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undamped_first_is_the_damped_solve_bit_for_bit() {
        // targets near and far from the seeds (far ones leave the undamped
        // phase, fail, or stall): every answer and status equals lm::solve's
        let r = PlanarView::paper();
        let g = CableGeometry::new(&r, None);
        let lm = newton_lm(&SolveOptions::default());
        let mut ws = (lm::Workspace::default(), lm::Workspace::default());
        let (mut left, mut state) = (0, 0x2545f4914f6cdd1du64);
        let mut uniform = |a: f64| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            a * ((state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0)
        };
        for i in 0..1500 {
            let want = [uniform(0.6), uniform(0.6), uniform(0.6)];
            let mut l = [0.0; 6];
            g.lengths(&want, &mut l);
            let spread = [1e-3, 2e-2, 0.2][i % 3];
            let target = [
                l[0] + uniform(spread),
                l[2] + uniform(spread),
                l[4] + uniform(spread),
            ];
            let seed = [uniform(0.6), uniform(0.6), uniform(0.6)];
            let problem = || CableProblem::<3> {
                geom: &g,
                target: &target,
                cs_n: [(1.0, 0.0); 3],
                roots_n: [[0.0; 3]; 3],
                cs: &mut [],
                roots: &mut [],
                limits: None,
            };
            let (mut a, mut b) = (seed, seed);
            let sa = lm::solve(&mut problem(), &mut a, &lm, &mut ws.0);
            let sb = lm::solve_undamped_first::<_, 3>(&mut problem(), &mut b, &lm, &mut ws.1);
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "case {i}");
            // as text: a failed solve's residual may be NaN (never == itself)
            assert_eq!(format!("{sa:?}"), format!("{sb:?}"), "case {i}");
            left += usize::from(!sa.converged || sa.iterations > 6);
        }
        // about 690 of the 1500 leave the undamped phase, the rest end in it
        assert!(
            (300..1200).contains(&left),
            "both phases exercised ({left} cases)"
        );
    }

    #[test]
    fn the_cable_solver_picks_its_evaluator_from_the_planar_view() {
        use crate::kinds::{Se2, Se3};
        let paper = Model::from_planar(&PlanarView::paper());
        let spatial =
            Model::from_toml(include_str!("../python/cdsm/robots/two_universal.toml")).unwrap();
        assert!(planar_evaluator(&paper, &paper));
        assert!(!planar_evaluator(&spatial, &spatial));
        // a moved arm's numbers: planar while they stay in the plane
        let moved = ArmNumbers::<f64>::of(&paper);
        assert!(planar_evaluator(&paper, &moved));
        let mut tilted = moved.clone();
        tilted.axis[1] = [0.0, 0.1f64.sin(), 0.1f64.cos()];
        assert!(!planar_evaluator(&paper, &tilted));
        let opts = SolveOptions::default();
        assert!(
            CableSolver::<Se2<f64>, _>::new(&paper, &moved, CableMethod::Auto, opts).is_planar()
        );
        let mut off = CableSolver::<Se3<f64>, _>::new(&paper, &tilted, CableMethod::Auto, opts);
        assert!(!off.is_planar() && off.chain_mut().is_some() && off.planar_mut().is_none());

        // the driver's answers are its evaluator's, bit for bit
        let view = CableNumbers::planar_view(&paper, &paper).unwrap();
        let (r, g) = (view.as_ref(), CableGeometry::new(&view, None));
        let mut l = [0.0; 6];
        g.lengths(&[0.3, -0.25, 0.1], &mut l);
        let target = [l[0] + 1e-3, l[2], l[4] - 2e-3];
        for m in [
            CableMethod::Auto,
            CableMethod::Newton,
            CableMethod::ClosedForm,
        ] {
            let (mut a, mut b) = ([0.1; 3], [0.1; 3]);
            let mut driver = CableSolver::<Se2<f64>>::new(&paper, &paper, m, opts);
            assert!(driver.is_planar() && driver.chain_mut().is_none());
            let sa = driver.solve(&target, &mut a);
            let sb = PlanarSolver::new(Cow::Borrowed(r), m, opts).solve(&g, &target, &mut b);
            assert!(sa.converged, "{m:?} {sa:?}");
            assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits), "{m:?}");
            assert_eq!(format!("{sa:?}"), format!("{sb:?}"), "{m:?}");
        }
        let n = spatial.n();
        let want: Vec<f64> = (0..n).map(|k| 0.2 - 0.1 * k as f64).collect();
        let mut chain = Chain::<f64, Se3<f64>>::new(&spatial);
        chain.at(&spatial, &spatial, &want);
        let target: Vec<f64> = spatial
            .position_cables()
            .iter()
            .map(|&c| chain.cable_length(&spatial, &spatial, c, None))
            .collect();
        let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
        let mut driver = CableSolver::<Se3<f64>>::new(&spatial, &spatial, CableMethod::Auto, opts);
        let sa = driver.solve(&target, &mut a);
        let sb =
            ChainSolver::<Se3<f64>>::new(&spatial, opts).solve(&spatial, &spatial, &target, &mut b);
        assert!(sa.converged, "{sa:?}");
        assert_eq!(
            a.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(format!("{sa:?}"), format!("{sb:?}"));
    }

    #[test]
    fn cable_methods_agree() {
        let r = PlanarView::paper();
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
        let r = PlanarView::paper();
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

    #[test]
    fn too_long_a_cable_is_unreachable() {
        let r = PlanarView::paper();
        let g = CableGeometry::new(&r, None);
        let mut th = [0.0; 3];
        let st = solve_cables(
            &r,
            &g,
            &[0.2, 0.152, 0.228],
            &mut th,
            CableMethod::ClosedForm,
            &SolveOptions::default(),
        );
        assert!(!st.converged && st.reason == Reason::Stalled, "{st:?}");
    }
}
