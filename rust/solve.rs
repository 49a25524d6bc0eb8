//! The cable solve (position-cable lengths -> joint angles): for planar
//! arms the closed form, joint by joint (fast path and branch census), and
//! damped Newton through the shared solver ([`crate::lm`]) with its
//! triangular step; for any arm the general solve on the one model's chain
//! ([`CableSolve`]). The options and the per-element status shared with the
//! pose IK ([`crate::ik`]) live here. The algorithms are specified in
//! `docs/model.md`.

use crate::cables::CableGeometry;
use crate::chain::{Chain, Numbers};
use crate::geometry::ArmGeometry;
use crate::kinds::Frame;
use crate::kinematics::within_limits;
use crate::lm::{self, Lm, Problem, Reason, Step, Workspace};
use crate::model::Model;
use crate::robot::Robot;
use crate::simd::math::cos_sin_short;

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

/// The joint-limit box of a robot as the solver's bounds.
pub(crate) fn clamp_to_limits(robot: &Robot, theta: &mut [f64]) {
    clamp_to_limits_box(&robot.joint_limits, theta);
}

/// `theta` clamped into the box `limits` (`[lo, hi]` per joint, rad).
pub(crate) fn clamp_to_limits_box(limits: &[[f64; 2]], theta: &mut [f64]) {
    for (t, l) in theta.iter_mut().zip(limits) {
        *t = t.clamp(l[0], l[1]);
    }
}

/// Whether some joint sits on its limit.
pub(crate) fn at_limit(robot: &Robot, theta: &[f64]) -> bool {
    theta
        .iter()
        .zip(&robot.joint_limits)
        .any(|(t, l)| *t <= l[0] || *t >= l[1])
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
    robot: &'a Robot,
    geom: &'a CableGeometry,
    target: &'a [f64],
    /// `(cos, sin)` and segment lengths of the last evaluation (its Jacobian
    /// is formed from them when the solver asks): a small arm's (`N > 0`)
    /// in the problem, the solver's buffers otherwise
    cs_n: [(f64, f64); N],
    roots_n: [[f64; N]; N],
    cs: &'a mut [(f64, f64)],
    roots: &'a mut [f64],
    enforce_limits: bool,
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
        if self.enforce_limits {
            clamp_to_limits(self.robot, x);
        }
    }

    fn on_bound(&self, x: &[f64]) -> bool {
        self.enforce_limits && at_limit(self.robot, x)
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

/// A cable solver with its buffers, reused across many solves (no allocation
/// per solve).
pub struct CableSolver<'a> {
    robot: &'a Robot,
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

impl<'a> CableSolver<'a> {
    pub fn new(robot: &'a Robot, method: CableMethod, opts: SolveOptions) -> Self {
        let n = robot.n();
        CableSolver {
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
            s: &mut CableSolver,
            geom: &CableGeometry,
            target: &[f64],
            theta: &mut [f64],
        ) -> Status {
            let mut p = CableProblem::<N> {
                robot: s.robot,
                geom,
                target,
                cs_n: [(1.0, 0.0); N],
                roots_n: [[0.0; N]; N],
                cs: &mut s.cs,
                roots: &mut s.roots,
                enforce_limits: s.opts.enforce_limits,
            };
            lm::solve(&mut p, theta, &s.lm, &mut s.ws)
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

    /// The rest of [`CableSolver::solve`] once the closed form has run from
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
        let mut in_box = !self.opts.enforce_limits || within_limits(self.robot, theta);
        if ok && !in_box {
            // an answer a rounding outside a limit (a configuration on the
            // limit): the limit itself, when its lengths still match
            let mut on = theta.to_vec();
            clamp_to_limits(self.robot, &mut on);
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

    /// [`CableSolver::finish`] for a closed form computed elsewhere (SIMD
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

struct GeneralProblem<'a, F: Frame<f64>, N> {
    model: &'a Model,
    nums: &'a N,
    cables: &'a [usize],
    target: &'a [f64],
    chain: &'a mut Chain<f64, F>,
    row: &'a mut [f64],
    limits: Option<&'a [[f64; 2]]>,
}

impl<F: Frame<f64>, N: Numbers<f64>> Problem for GeneralProblem<'_, F, N> {
    fn dims(&self) -> (usize, usize) {
        (self.cables.len(), self.model.n())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], mut jac: Option<&mut [f64]>) -> bool {
        let n = x.len();
        self.chain.at(self.model, self.nums, x);
        for (i, &c) in self.cables.iter().enumerate() {
            r[i] = self.chain.cable_length(self.model, self.nums, c, None) - self.target[i];
            if let Some(j) = jac.as_deref_mut() {
                self.chain
                    .cable_jacobian_row(self.model, self.nums, c, self.row);
                j[i * n..(i + 1) * n].copy_from_slice(self.row);
            }
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

/// The general cable solve (`docs/model.md`, "Solves"): the lengths of the
/// position-controlled cables to the joint angles through the shared solver
/// on the chain of either kind and any numbers (the model's own, or a
/// plant's moved arm). As many cables as joints: damped Newton; more: least
/// squares (converged when an accepted step lowers the squared misfit by
/// less than `1e-12` of itself). With its buffers, reused across solves and
/// across arms of the model's structure with other numbers.
pub struct CableSolve<F: Frame<f64>> {
    cables: Vec<usize>,
    opts: SolveOptions,
    limits: Vec<[f64; 2]>,
    ws: Workspace,
    row: Vec<f64>,
    /// The chain at the last evaluation (the answer's when the solve converged).
    pub chain: Chain<f64, F>,
}

impl<F: Frame<f64>> CableSolve<F> {
    pub fn new(model: &Model, opts: SolveOptions) -> Self {
        CableSolve {
            cables: model.position_cables(),
            opts,
            limits: model.joints.iter().map(|j| j.limits).collect(),
            ws: Workspace::default(),
            row: vec![0.0; model.n()],
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
        let (m, n) = (self.cables.len(), model.n());
        let mut p = GeneralProblem {
            model,
            nums,
            cables: &self.cables,
            target,
            chain: &mut self.chain,
            row: &mut self.row,
            limits: self.opts.enforce_limits.then_some(&self.limits[..]),
        };
        let lm = Lm {
            lambda0: 0.0,
            min_decrease: if m > n { 1e-12 } else { 0.0 },
            ..Lm::equations(Step::Normal, self.opts.tol, self.opts.max_iter)
        };
        lm::solve(&mut p, theta, &lm, &mut self.ws)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn too_long_a_cable_is_unreachable() {
        let r = Robot::paper();
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
