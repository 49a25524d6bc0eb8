//! The one damped least-squares solver of cdsm (Levenberg–Marquardt), with a
//! pluggable step. The pose IK, the cable solves, the elastic and plant
//! settles, the diagnosis fit and compensation all run it.
//!
//! Residual `r(x)` (m), Jacobian `J = dr/dx`. A trial `x + delta` is accepted
//! when it lowers `|r|^2`; then `lambda <- max(lambda / 10, 1e-12)`;
//! otherwise `lambda <- 10 lambda` (from an undamped start: `1e-3`)
//! and the step is retried. Equations stop converged when `max |r| <= tol`;
//! least-squares problems (`min_decrease > 0`) also stop converged when an
//! accepted step lowers the cost by less than that fraction or the problem
//! finds the step small ([`Problem::small_step`]), or when no step lowers it
//! at all (the damping passes 1e12). The step:
//!
//! * [`Step::Triangular`]: square lower-triangular `J` (the planar cable
//!   solves): forward substitution `J delta = -r` (Gauss–Newton; the
//!   diagonal's reciprocals formed first) while `lambda <= 1e-12` (it may
//!   start at 0), the damped normal equations otherwise;
//! * [`Step::Square`]: square `J` (the general cable solve): the Newton step
//!   `J delta = -r` while `lambda <= 1e-12` — block by block when the
//!   problem gives `J`'s block lower-triangular structure
//!   ([`Problem::blocks`], [`block_solve`]), else by LU with partial
//!   pivoting ([`lu_solve`]) — and the damped normal equations otherwise;
//! * [`Step::Normal`]: `(J^T J + lambda D) delta = -J^T r` by Cholesky;
//! * [`Step::MinNorm`]: `delta = -J^T (J J^T + lambda I)^-1 r` (more unknowns
//!   than residuals: the pose IK of redundant arms);
//! * [`Step::Qr`]: the damped least squares `[J; sqrt(lambda D)] delta = -[r; 0]`
//!   by Householder QR (ill-conditioned fits).
//!
//! `D` is the identity ([`Damping::Levenberg`]) or `diag(J^T J)`
//! ([`Damping::Marquardt`]). The solver allocates nothing per solve once its
//! [`Workspace`] has seen the problem's size (Cholesky and LU of more than 6
//! unknowns and the QR step allocate in faer). The square Newton step, the
//! normal equations and the `L D L^T` solve are written over
//! [`crate::real::Lane`], so the general cable solve's lanes
//! ([`crate::solve`]) take the same steps with the same operations.

use crate::real::Lane;
use faer::linalg::solvers::{Solve, SolveLstsq};
use faer::Mat;

/// The damped step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Step {
    Triangular,
    Square,
    Normal,
    MinNorm,
    Qr,
}

impl Step {
    /// The damped Levenberg step for `m` residuals and `n` unknowns, in the
    /// form whose matrix is regular: minimal norm, `(J J^T + lambda I)` of
    /// size `m`, while `m <= n`; the normal equations, `(J^T J + lambda I)`
    /// of size `n`, when there are more residuals than unknowns (`J J^T` is
    /// then singular). The two are the same step in exact arithmetic.
    pub fn levenberg(m: usize, n: usize) -> Step {
        if m <= n {
            Step::MinNorm
        } else {
            Step::Normal
        }
    }
}

/// The damping matrix `D` of the normal-equation and QR steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Damping {
    Levenberg,
    Marquardt,
}

/// Why a solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Reason {
    Converged = 0,
    /// `max_iter` trial steps without converging.
    IterationLimit = 1,
    /// The step could not be computed (singular Jacobian) or went nowhere.
    Singular = 2,
    /// Proven out of reach: no configuration realises the target (a
    /// bound on the cable lengths, the closed-form pose IK's reach).
    Unreachable = 3,
    /// Stuck on the joint-limit box while limits are enforced.
    OutsideLimits = 4,
    /// Stopped at a non-zero residual with no proof that the target is out
    /// of reach: a stationary point of the misfit (a local minimum), or a
    /// closed form whose branch has no answer; another seed may succeed.
    Stalled = 5,
}

impl Reason {
    /// The names, in code order (`Reason as u8` indexes them).
    pub const NAMES: [&'static str; 6] = [
        "converged",
        "iteration limit",
        "singular",
        "unreachable",
        "outside limits",
        "stalled",
    ];
}

/// The solver's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lm {
    pub step: Step,
    pub damping: Damping,
    /// Converged when `max |r| <= tol`.
    pub tol: f64,
    /// Maximum number of trial steps.
    pub max_iter: u32,
    /// Initial damping (0: start undamped).
    pub lambda0: f64,
    /// Least squares: converged when an accepted step lowers the cost by less
    /// than this fraction (0: equations, converged only at `tol`).
    pub min_decrease: f64,
}

/// The smallest damping after an accepted step; the triangular step treats
/// it as none (Gauss–Newton).
pub const LAMBDA_MIN: f64 = 1e-12;
/// Damping after a rejected undamped step.
pub const LAMBDA_RESTART: f64 = 1e-3;
/// Damping beyond which the solve gives up.
pub const LAMBDA_MAX: f64 = 1e12;

impl Lm {
    /// Equations `r(x) = 0` with the given step; `lambda0 = 1e-3`.
    pub fn equations(step: Step, tol: f64, max_iter: u32) -> Lm {
        Lm {
            step,
            damping: Damping::Levenberg,
            tol,
            max_iter,
            lambda0: LAMBDA_RESTART,
            min_decrease: 0.0,
        }
    }
}

/// A problem the solver can run: `r(x)` and `J(x)` (row-major `m x n`).
pub trait Problem {
    /// `(m, n)`: residuals and unknowns.
    fn dims(&self) -> (usize, usize);
    /// Writes `r(x)` and, when asked, `J(x)`; false when the model cannot be
    /// evaluated at `x` (the trial is then rejected).
    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool;
    /// Whether a trial's Jacobian comes with its residual (cheap Jacobians:
    /// the default). Otherwise the solver evaluates trials without it and
    /// asks [`Problem::jacobian`] at accepted points only.
    fn jacobian_with_residual(&self) -> bool {
        true
    }
    /// `J` at `x`, the point of the last successful [`Problem::eval`].
    fn jacobian(&mut self, x: &[f64], jac: &mut [f64]) -> bool {
        let (m, _) = self.dims();
        let mut r = vec![0.0; m];
        self.eval(x, &mut r, Some(jac))
    }
    /// Whether the solve must end with the Jacobian at the answer in the
    /// workspace (the default). Otherwise, with
    /// [`Problem::jacobian_with_residual`] false, an accepted trial within
    /// tol ends the solve without [`Problem::jacobian`] being asked for it.
    fn answer_jacobian(&self) -> bool {
        true
    }
    /// The block lower-triangular structure of a square `J`, if it has
    /// one (the square step then solves block by block); by default none.
    fn blocks(&self) -> Option<&Blocks> {
        None
    }
    /// Moves a trial into the feasible set (bounds); by default none.
    fn project(&self, _x: &mut [f64]) {}
    /// Whether `x` sits on the boundary of the feasible set.
    fn on_bound(&self, _x: &[f64]) -> bool {
        false
    }
    /// Whether the problem holds components on bounds ([`Problem::blocked`]).
    fn bounded(&self) -> bool {
        false
    }
    /// Whether a bound blocks moving `x[k]` in the direction of the sign of
    /// `toward` (box-constrained least squares: such a component is held
    /// out of the step, an active set).
    fn blocked(&self, _x: &[f64], _k: usize, _toward: f64) -> bool {
        false
    }
    /// Least squares: whether the accepted step from `from` to `to` is
    /// small enough to stop converged, with `J` and the cost `|r|^2` at
    /// `to` (by default never: the decrease test of [`Lm::min_decrease`]
    /// alone).
    fn small_step(&self, _from: &[f64], _to: &[f64], _jac: &[f64], _cost: f64) -> bool {
        false
    }
}

/// Outcome of one solve (the answer is in the caller's `x`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Status {
    pub converged: bool,
    /// Trial steps taken.
    pub iterations: u32,
    /// `max |r|` at the answer.
    pub residual: f64,
    /// `|r|^2` at the answer.
    pub cost: f64,
    pub reason: Reason,
}

/// Reusable buffers of the solver.
#[derive(Debug, Default, Clone)]
pub struct Workspace {
    /// `(m, n, step)` the buffers are sized for.
    sized: Option<(usize, usize, Step)>,
    /// The current point (the accepted trial; copied to the caller's `x` at the end).
    x: Vec<f64>,
    r: Vec<f64>,
    r_trial: Vec<f64>,
    jac: Vec<f64>,
    jac_trial: Vec<f64>,
    x_trial: Vec<f64>,
    delta: Vec<f64>,
    a: Vec<f64>,
    g: Vec<f64>,
    /// The Jacobian with the columns of blocked components zeroed.
    jac_free: Vec<f64>,
    active: Vec<bool>,
}

impl Workspace {
    #[inline]
    fn fit(&mut self, m: usize, n: usize, step: Step) {
        if self.sized != Some((m, n, step)) {
            self.resize(m, n, step);
        }
    }

    fn resize(&mut self, m: usize, n: usize, step: Step) {
        self.sized = Some((m, n, step));
        // the system of the step: (m, m) for the minimal-norm step, (n, n) otherwise
        let s = if step == Step::MinNorm { m } else { n };
        for (v, len) in [
            (&mut self.x, n),
            (&mut self.r, m),
            (&mut self.r_trial, m),
            (&mut self.jac, m * n),
            (&mut self.jac_trial, m * n),
            (&mut self.x_trial, n),
            (&mut self.delta, n),
            (&mut self.a, s * s),
            (&mut self.g, s),
        ] {
            if v.len() != len {
                v.resize(len, 0.0);
            }
        }
        if self.active.len() != n {
            self.active.resize(n, false);
        }
    }

    /// The residual at the answer of the last solve.
    pub fn residual(&self) -> &[f64] {
        &self.r
    }

    /// The Jacobian at the answer of the last solve (row-major `m x n`);
    /// unspecified when the problem did not ask for it
    /// ([`Problem::answer_jacobian`] false).
    pub fn jacobian(&self) -> &[f64] {
        &self.jac
    }
}

/// `max |v_i|`, NaN when any entry is NaN (`f64::max` would drop it and
/// report a NaN residual as 0).
fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(
        0.0,
        |m: f64, x| {
            if x.is_nan() {
                f64::NAN
            } else {
                m.max(x.abs())
            }
        },
    )
}

fn sum_sq(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum()
}

/// Runs the solver on `problem` from `x` (the answer on exit).
pub fn solve<P: Problem + ?Sized>(
    problem: &mut P,
    x: &mut [f64],
    lm: &Lm,
    ws: &mut Workspace,
) -> Status {
    let (m, n) = problem.dims();
    ws.fit(m, n, lm.step);
    let (st, flipped) = iterate(problem, x, lm, ws, m, n);
    if flipped {
        // the answer's residual and Jacobian are in the trial buffers
        std::mem::swap(&mut ws.x, &mut ws.x_trial);
        std::mem::swap(&mut ws.r, &mut ws.r_trial);
        std::mem::swap(&mut ws.jac, &mut ws.jac_trial);
    }
    st
}

/// [`solve`] of a square problem of `N` unknowns known at compile time
/// (`N > 0`) with the triangular step, unbounded, starting undamped: its
/// undamped steps run first on arrays of `N` (no workspace, constant trip
/// counts), the same operations in the same order as [`solve`], so while
/// every step is accepted the iterates, the answer and its [`Status`] are
/// [`solve`]'s bit for bit. At the first step [`solve`] would damp (or any
/// other case) [`solve`] runs from the seed and repeats the same steps.
#[inline]
pub fn solve_undamped_first<P: Problem + ?Sized, const N: usize>(
    problem: &mut P,
    x: &mut [f64],
    lm: &Lm,
    ws: &mut Workspace,
) -> Status {
    // the damped solve, kept out of the undamped phase's code
    #[cold]
    #[inline(never)]
    fn damped<P: Problem + ?Sized>(
        p: &mut P,
        x: &mut [f64],
        lm: &Lm,
        ws: &mut Workspace,
    ) -> Status {
        solve(p, x, lm, ws)
    }
    let fits = N > 0
        && problem.dims() == (N, N)
        && lm.step == Step::Triangular
        && lm.lambda0 <= LAMBDA_MIN
        && lm.min_decrease == 0.0
        && !problem.bounded();
    if fits {
        if let Some(st) = undamped::<P, N>(problem, x, lm) {
            return st;
        }
    }
    damped(problem, x, lm, ws)
}

/// The undamped phase of [`solve_undamped_first`]: the converged status
/// (answer into `x`), or None at the first step [`solve`] would not take
/// undamped.
#[inline(always)]
fn undamped<P: Problem + ?Sized, const N: usize>(
    problem: &mut P,
    x: &mut [f64],
    lm: &Lm,
) -> Option<Status> {
    let (mut cx, mut cr, mut cj) = ([0.0; N], [0.0; N], [[0.0; N]; N]);
    let (mut tx, mut tr, mut tj) = ([0.0; N], [0.0; N], [[0.0; N]; N]);
    let (mut inv, mut delta) = ([0.0; N], [0.0; N]);
    cx.copy_from_slice(&x[..N]);
    if !problem.eval(&cx, &mut cr, Some(cj.as_flattened_mut())) {
        return None;
    }
    let mut cost = sum_sq(&cr);
    let mut iterations = 0;
    loop {
        let res = max_abs(&cr);
        if res <= lm.tol {
            x[..N].copy_from_slice(&cx);
            return Some(Status {
                converged: true,
                iterations,
                residual: res,
                cost: sum_sq(&cr),
                reason: Reason::Converged,
            });
        }
        if !res.is_finite() || iterations >= lm.max_iter {
            return None;
        }
        iterations += 1;
        let ok = forward_substitution(cj.as_flattened(), &cr, N, &mut inv, &mut delta);
        if !ok || !delta.iter().all(|d| d.is_finite()) {
            return None;
        }
        for ((t, xk), d) in tx.iter_mut().zip(&cx).zip(&delta) {
            *t = xk + d;
        }
        problem.project(&mut tx);
        let (accept, c) = try_point(problem, &tx, &mut tr, tj.as_flattened_mut(), cost, lm.tol);
        if !accept {
            return None;
        }
        std::mem::swap(&mut cx, &mut tx);
        std::mem::swap(&mut cr, &mut tr);
        std::mem::swap(&mut cj, &mut tj);
        cost = c;
    }
}

/// A point of the solve: `x`, `r(x)`, `J(x)`, views of exact length into
/// the workspace (an accepted trial swaps the views, not the buffers).
struct Point<'w> {
    x: &'w mut [f64],
    r: &'w mut [f64],
    jac: &'w mut [f64],
}

/// The iterations of [`solve`] from `x0` (the answer written back there),
/// and whether the answer was left in the trial buffers.
fn iterate<P: Problem + ?Sized>(
    problem: &mut P,
    x0: &mut [f64],
    lm: &Lm,
    ws: &mut Workspace,
    m: usize,
    n: usize,
) -> (Status, bool) {
    let Workspace {
        x,
        r,
        r_trial,
        jac,
        jac_trial,
        x_trial,
        delta,
        a,
        g,
        jac_free,
        active,
        ..
    } = ws;
    let mut cur = Point {
        x: &mut x[..n],
        r: &mut r[..m],
        jac: &mut jac[..m * n],
    };
    let mut trial = Point {
        x: &mut x_trial[..n],
        r: &mut r_trial[..m],
        jac: &mut jac_trial[..m * n],
    };
    let (delta, active) = (&mut delta[..n], &mut active[..n]);
    let mut flipped = false;
    cur.x.copy_from_slice(x0);
    let mut done = |cur: &Point, converged: bool, iterations: u32, reason: Reason| {
        x0.copy_from_slice(cur.x);
        Status {
            converged,
            iterations,
            residual: max_abs(cur.r),
            cost: sum_sq(cur.r),
            reason,
        }
    };
    if !problem.eval(cur.x, cur.r, Some(cur.jac)) {
        cur.r.fill(f64::NAN);
        return (done(&cur, false, 0, Reason::Singular), flipped);
    }
    let mut cost = sum_sq(cur.r);
    let mut lambda = lm.lambda0;
    let mut iterations = 0;
    loop {
        if let Some((converged, reason)) = stop(problem, &cur, lm, lambda, iterations, m, n) {
            return (done(&cur, converged, iterations, reason), flipped);
        }
        iterations += 1;
        // components a bound stops from going downhill are held out of the step
        let any = hold(problem, &cur, lm, active, m, n);
        let jac: &[f64] = if any {
            jac_free.clear();
            jac_free.extend_from_slice(cur.jac);
            for row in jac_free.chunks_exact_mut(n) {
                for (v, a) in row.iter_mut().zip(active.iter()) {
                    if *a {
                        *v = 0.0;
                    }
                }
            }
            jac_free
        } else {
            cur.jac
        };
        // the undamped triangular step inline (the cable solves' hot path),
        // every other step in `step`
        let ok = if lm.step == Step::Triangular && lambda <= LAMBDA_MIN && m == n {
            forward_substitution(jac, cur.r, n, g, delta)
        } else if lm.step == Step::Square && lambda <= LAMBDA_MIN && m == n {
            square_step(jac, cur.r, n, problem.blocks(), a, delta)
        } else {
            step(lm, jac, cur.r, m, n, lambda, a, g, delta)
        };
        if any {
            for (d, a) in delta.iter_mut().zip(active.iter()) {
                if *a {
                    *d = 0.0;
                }
            }
            if lm.min_decrease > 0.0 && active.iter().all(|a| *a) {
                // every component held (bounds, no information): a minimum
                return (done(&cur, true, iterations, Reason::Converged), flipped);
            }
        }
        if !ok || !delta.iter().all(|d| d.is_finite()) {
            lambda = raise(lambda);
            continue;
        }
        for ((t, xk), d) in trial.x.iter_mut().zip(cur.x.iter()).zip(delta.iter()) {
            *t = xk + d;
        }
        problem.project(trial.x);
        let (accept, c) = try_point(problem, trial.x, trial.r, trial.jac, cost, lm.tol);
        if accept {
            std::mem::swap(&mut cur, &mut trial);
            flipped = !flipped;
            let small = lm.min_decrease > 0.0
                && (cost - c <= lm.min_decrease * cost
                    || problem.small_step(trial.x, cur.x, cur.jac, c));
            cost = c;
            if small {
                return (done(&cur, true, iterations, Reason::Converged), flipped);
            }
            lambda = (lambda / 10.0).max(LAMBDA_MIN);
        } else {
            lambda = raise(lambda);
        }
    }
}

/// Whether [`iterate`] stops at `cur` before its next step, converged or
/// not, and why: the residual within the tolerance (converged), not finite,
/// the iteration limit (stalled where the gradient vanishes), or the damping
/// past [`LAMBDA_MAX`] (a least-squares minimum; else a bound, a stationary
/// point or a singular Jacobian).
#[inline(always)]
fn stop<P: Problem + ?Sized>(
    problem: &P,
    cur: &Point,
    lm: &Lm,
    lambda: f64,
    iterations: u32,
    m: usize,
    n: usize,
) -> Option<(bool, Reason)> {
    let res = max_abs(cur.r);
    if res <= lm.tol {
        return Some((true, Reason::Converged));
    }
    if !res.is_finite() {
        return Some((false, Reason::Singular));
    }
    if iterations >= lm.max_iter {
        let reason = if stationary(cur.jac, cur.r, m, n) {
            Reason::Stalled
        } else {
            Reason::IterationLimit
        };
        return Some((false, reason));
    }
    if lambda > LAMBDA_MAX {
        if lm.min_decrease > 0.0 {
            // least squares: no step lowers the cost any more, a minimum
            return Some((true, Reason::Converged));
        }
        let reason = if problem.on_bound(cur.x) {
            Reason::OutsideLimits
        } else if stationary(cur.jac, cur.r, m, n) {
            Reason::Stalled
        } else {
            Reason::Singular
        };
        return Some((false, reason));
    }
    None
}

/// Marks in `active` the components held out of the next step: those a
/// bound stops from going downhill and, in least squares, those the
/// residual does not depend on (no information: they stay put). Whether
/// any is held.
#[inline(always)]
fn hold<P: Problem + ?Sized>(
    problem: &P,
    cur: &Point,
    lm: &Lm,
    active: &mut [bool],
    m: usize,
    n: usize,
) -> bool {
    let mut any = false;
    if problem.bounded() || lm.min_decrease > 0.0 {
        for (k, held) in active.iter_mut().enumerate() {
            let gk: f64 = (0..m).map(|i| cur.jac[i * n + k] * cur.r[i]).sum();
            let blind = lm.min_decrease > 0.0 && (0..m).all(|i| cur.jac[i * n + k] == 0.0);
            *held = blind || problem.blocked(cur.x, k, -gk);
            any |= *held;
        }
    }
    any
}

/// The trial point `x` of a step from a point of cost `cost`: its residual
/// into `r` (and its Jacobian into `jac` when the problem evaluates them
/// together), its cost (infinite where it cannot be evaluated) and whether
/// the step is taken — the cost lower and the Jacobian there known (evaluated
/// with the residual, not needed because the residual is within `tol` and
/// the problem wants no Jacobian at its answer, or evaluated now).
#[inline(always)]
fn try_point<P: Problem + ?Sized>(
    problem: &mut P,
    x: &[f64],
    r: &mut [f64],
    jac: &mut [f64],
    cost: f64,
    tol: f64,
) -> (bool, f64) {
    let joint = problem.jacobian_with_residual();
    let evaluated = if joint {
        problem.eval(x, r, Some(jac))
    } else {
        problem.eval(x, r, None)
    };
    let c = if evaluated { sum_sq(r) } else { f64::INFINITY };
    let accept = c < cost
        && (joint || (!problem.answer_jacobian() && max_abs(r) <= tol) || problem.jacobian(x, jac));
    (accept, c)
}

/// The undamped triangular step: forward substitution `J delta = -r`, `J`
/// lower triangular (`n x n`), with the diagonal's reciprocals (into `inv`)
/// formed first, off the substitution's dependency chain. False when a
/// diagonal entry is zero or not finite.
#[inline(always)]
fn forward_substitution(
    jac: &[f64],
    r: &[f64],
    n: usize,
    inv: &mut [f64],
    delta: &mut [f64],
) -> bool {
    let inv = &mut inv[..n];
    let mut finite = true;
    for (i, v) in inv.iter_mut().enumerate() {
        let d = jac[i * n + i];
        *v = 1.0 / d;
        finite &= d.is_finite() && v.is_finite();
    }
    if !finite {
        return false;
    }
    for (i, (row, v)) in jac.chunks_exact(n).zip(inv.iter()).enumerate() {
        let mut acc = -r[i];
        for (j, d) in row[..i].iter().zip(delta.iter()) {
            acc -= j * d;
        }
        delta[i] = acc * v;
    }
    true
}

#[inline]
fn raise(lambda: f64) -> f64 {
    if lambda == 0.0 {
        LAMBDA_RESTART
    } else {
        lambda * 10.0
    }
}

/// Whether `J^T r` vanishes relative to `|J| |r|` (a stationary point).
fn stationary(jac: &[f64], r: &[f64], m: usize, n: usize) -> bool {
    let jn = jac.iter().map(|v| v * v).sum::<f64>().sqrt();
    let rn = sum_sq(r).sqrt();
    let mut g2 = 0.0;
    for k in 0..n {
        let gk: f64 = (0..m).map(|i| jac[i * n + k] * r[i]).sum();
        g2 += gk * gk;
    }
    g2.sqrt() <= 1e-6 * jn * rn
}

/// The damped step into `delta` (the undamped triangular one is
/// [`forward_substitution`], taken by the caller); false when it cannot be
/// computed.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn step(
    lm: &Lm,
    jac: &[f64],
    r: &[f64],
    m: usize,
    n: usize,
    lambda: f64,
    a: &mut [f64],
    g: &mut [f64],
    delta: &mut [f64],
) -> bool {
    match lm.step {
        Step::Triangular | Step::Square | Step::Normal => {
            normal_equations_f64(jac, r, m, n, lambda, lm.damping, a, g);
            solve_spd(n, &a[..n * n], &g[..n], delta)
        }
        Step::MinNorm => {
            // (lambda I + J J^T) y = -r, delta = J^T y; the damping goes in
            // first and the columns' outer products are added in order
            // (the lower triangle: the LDL^T reads no more; mirrored for LU)
            for i in 0..m {
                let ji = &jac[i * n..(i + 1) * n];
                for l in 0..=i {
                    let mut v = if i == l { lambda } else { 0.0 };
                    for (x, y) in ji.iter().zip(&jac[l * n..(l + 1) * n]) {
                        v += x * y;
                    }
                    a[i * m + l] = v;
                }
                g[i] = -r[i];
            }
            let mut y = [0.0; 8];
            let mut yv;
            let ys: &mut [f64] = if m <= 8 {
                &mut y[..m]
            } else {
                yv = vec![0.0; m];
                &mut yv
            };
            // symmetric positive definite when lambda > 0 or J has full row
            // rank: Cholesky, else the pivoted LU
            if !solve_spd(m, &a[..m * m], &g[..m], ys) {
                for i in 0..m {
                    for l in i + 1..m {
                        a[i * m + l] = a[l * m + i];
                    }
                }
                if !solve_general(m, &a[..m * m], &g[..m], ys) {
                    return false;
                }
            }
            for (k, d) in delta.iter_mut().enumerate() {
                *d = (0..m).map(|i| jac[i * n + k] * ys[i]).sum();
            }
            true
        }
        Step::Qr => qr_step(jac, r, m, n, lambda, lm.damping, delta),
    }
}

/// [`newton_step`] on one row, out of line (the solver's loop stays small).
#[inline(never)]
fn square_step(
    jac: &[f64],
    r: &[f64],
    n: usize,
    blocks: Option<&Blocks>,
    a: &mut [f64],
    delta: &mut [f64],
) -> bool {
    newton_step(jac, r, n, blocks, a, delta) && delta.iter().all(|d| d.is_finite())
}

/// [`normal_equations`] on one row, out of line.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn normal_equations_f64(
    jac: &[f64],
    r: &[f64],
    m: usize,
    n: usize,
    lambda: f64,
    damping: Damping,
    a: &mut [f64],
    g: &mut [f64],
) {
    normal_equations(jac, r, m, n, None, lambda, damping, a, g)
}

/// `sum f(i)` over `rows`, in order, from 0.
#[inline(always)]
fn sum_over<L: Lane>(rows: impl Iterator<Item = usize>, f: impl Fn(usize) -> L) -> L {
    let mut v = L::cst(0.0);
    for i in rows {
        v += f(i);
    }
    v
}

/// `a = J^T J + lambda D` (n x n) and `g = -J^T r`, lane by lane. With
/// `rows`, `rows[k]` lists (ascending) the rows that may be non-zero in
/// column `k` of `J` (`m x n`): every other entry of the column must be an
/// exact zero, whose products the sums skip — the same bits, fewer
/// operations (a long arm's cables reach only the joints before their end).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn normal_equations<L: Lane>(
    jac: &[L],
    r: &[L],
    m: usize,
    n: usize,
    rows: Option<&[Vec<usize>]>,
    lambda: L,
    damping: Damping,
    a: &mut [L],
    g: &mut [L],
) {
    for k in 0..n {
        for l in 0..=k {
            let f = |i: usize| jac[i * n + k] * jac[i * n + l];
            let v = match rows {
                Some(rs) => sum_over(rs[k].iter().copied(), f),
                None => sum_over(0..m, f),
            };
            a[k * n + l] = v;
            a[l * n + k] = v;
        }
        let f = |i: usize| jac[i * n + k] * r[i];
        let v = match rows {
            Some(rs) => sum_over(rs[k].iter().copied(), f),
            None => sum_over(0..m, f),
        };
        g[k] = -v;
    }
    for k in 0..n {
        let d = match damping {
            Damping::Levenberg => L::cst(1.0),
            Damping::Marquardt => a[k * n + k].max(L::cst(1e-300)),
        };
        a[k * n + k] += lambda * d;
    }
}

/// The undamped square step into `delta`: the Newton step `J delta = -r`
/// (`J` `n x n`), lane by lane, by [`block_solve`] with `blocks`, else by
/// [`lu_solve`] of `J` copied into `a` (`n x n` scratch). The lanes where
/// `J` (a diagonal block) is singular come back false.
#[inline(always)]
pub fn newton_step<L: Lane>(
    jac: &[L],
    r: &[L],
    n: usize,
    blocks: Option<&Blocks>,
    a: &mut [L],
    delta: &mut [L],
) -> L::Mask {
    if let Some(b) = blocks {
        return block_solve(n, jac, r, b, a, delta);
    }
    let a = &mut a[..n * n];
    a.copy_from_slice(&jac[..n * n]);
    for (d, ri) in delta.iter_mut().zip(r) {
        *d = -*ri;
    }
    lu_solve(n, a, delta)
}

/// The block lower-triangular structure of a square `n x n` matrix: a
/// permutation of its rows and consecutive ranges of its columns, the
/// blocks, such that the rows of block `b` (`rows[cols_b]`, as many as its
/// columns `cols_b`) vanish in the columns of every later block. (The
/// general cable solve's Jacobian when as many position cables end at each
/// disk as it has joints: a cable does not depend on the joints past its
/// end.)
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Blocks {
    /// The rows, block by block.
    pub rows: Vec<usize>,
    /// The columns of each block, in order, covering `0..n`.
    pub cols: Vec<std::ops::Range<usize>>,
}

/// Solves `J delta = -r` (`J` `n x n` row-major with the structure
/// `blocks`) by block forward substitution, lane by lane: for each block in
/// order its rows' right-hand side less the columns already solved, then
/// [`lu_solve`] of its square diagonal block (copied into `a`). The lanes
/// where a diagonal block is singular come back false.
#[inline(always)]
pub fn block_solve<L: Lane>(
    n: usize,
    jac: &[L],
    r: &[L],
    blocks: &Blocks,
    a: &mut [L],
    delta: &mut [L],
) -> L::Mask {
    let mut ok = L::mask(true);
    for cols in &blocks.cols {
        let (c0, k) = (cols.start, cols.len());
        for (bi, &i) in blocks.rows[cols.clone()].iter().enumerate() {
            let row = &jac[i * n..(i + 1) * n];
            let mut v = -r[i];
            for (j, d) in row[..c0].iter().zip(&delta[..c0]) {
                v -= *j * *d;
            }
            delta[c0 + bi] = v;
            a[bi * k..(bi + 1) * k].copy_from_slice(&row[cols.clone()]);
        }
        ok = ok & lu_solve(k, &mut a[..k * k], &mut delta[cols.clone()]);
    }
    ok
}

/// Solves the square `a x = b` (`n x n` row-major `a`, overwritten by its
/// factors; `b` overwritten by `x`) by Gaussian elimination with partial
/// pivoting (in each column the entry of largest magnitude, the last of
/// equals), lane by lane: each lane pivots on its own rows (a jet on its
/// values). The lanes whose pivot is zero or not finite (a singular matrix)
/// come back false, their `x` unspecified. The LU of the square Newton
/// step, of its lanes, and of the statics' square balance
/// ([`crate::tension::Balance::solve_square`]).
#[inline(always)]
pub fn lu_solve<L: Lane>(n: usize, a: &mut [L], b: &mut [L]) -> L::Mask {
    let mut ok = L::mask(true);
    for k in 0..n {
        let mut best = a[k * n + k].abs();
        let mut piv = L::cst(k as f64);
        for i in k + 1..n {
            let v = a[i * n + k].abs();
            let m = best.le(v);
            best = L::select(m, v, best);
            piv = L::select(m, L::cst(i as f64), piv);
        }
        ok = ok & L::cst(0.0).lt(best) & best.finite();
        // rows k and piv swap in the lanes that pivot on row i (selects
        // without a branch: which rows pivot varies from lane to lane)
        for i in k + 1..n {
            let m = piv.eq(L::cst(i as f64));
            if !L::any(m) {
                // no lane pivots on row i: its selects would keep every entry
                continue;
            }
            for j in k..n {
                let (x, y) = (a[k * n + j], a[i * n + j]);
                a[k * n + j] = L::select(m, y, x);
                a[i * n + j] = L::select(m, x, y);
            }
            let (x, y) = (b[k], b[i]);
            b[k] = L::select(m, y, x);
            b[i] = L::select(m, x, y);
        }
        let inv = L::cst(1.0) / a[k * n + k];
        for i in k + 1..n {
            let f = a[i * n + k] * inv;
            for j in k + 1..n {
                let v = a[k * n + j];
                a[i * n + j] -= f * v;
            }
            let v = b[k];
            b[i] -= f * v;
        }
    }
    for k in (0..n).rev() {
        let mut v = b[k];
        for j in k + 1..n {
            v -= a[k * n + j] * b[j];
        }
        b[k] = v / a[k * n + k];
    }
    ok
}

/// Solves the symmetric positive-definite `a x = b` (`n x n` row-major; its
/// lower triangle read, `a` overwritten; `b` overwritten by `x`) by the
/// square-root-free `L D L^T` in place (`L` below the diagonal, `L D` above
/// it, the pivots' reciprocals on it), lane by lane. The lanes whose pivot
/// is not > 0 or not finite come back false.
#[inline(always)]
pub fn ldlt_solve<L: Lane>(n: usize, a: &mut [L], b: &mut [L]) -> L::Mask {
    let mut ok = L::mask(true);
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[k * n + j];
        }
        ok = ok & L::cst(0.0).lt(d) & d.finite();
        let dinv = L::cst(1.0) / d;
        a[j * n + j] = dinv;
        for i in j + 1..n {
            let mut v = a[i * n + j];
            for k in 0..j {
                // l[i][k] w[j][k]: l below the diagonal, w = L D above it
                v -= a[i * n + k] * a[k * n + j];
            }
            a[j * n + i] = v;
            a[i * n + j] = v * dinv;
        }
    }
    for i in 0..n {
        let mut v = b[i];
        for k in 0..i {
            v -= a[i * n + k] * b[k];
        }
        b[i] = v;
    }
    for i in (0..n).rev() {
        let mut v = b[i] * a[i * n + i];
        for k in i + 1..n {
            v -= a[k * n + i] * b[k];
        }
        b[i] = v;
    }
    ok
}

/// The damped least-squares step by Householder QR (faer).
fn qr_step(
    jac: &[f64],
    r: &[f64],
    m: usize,
    n: usize,
    lambda: f64,
    damping: Damping,
    delta: &mut [f64],
) -> bool {
    let rows = m + n;
    let diag = |k: usize| -> f64 {
        match damping {
            Damping::Levenberg => 1.0,
            Damping::Marquardt => (0..m)
                .map(|i| jac[i * n + k] * jac[i * n + k])
                .sum::<f64>()
                .max(1e-300),
        }
    };
    let sq: Vec<f64> = (0..n).map(|k| (lambda * diag(k)).sqrt()).collect();
    let a = Mat::<f64>::from_fn(rows, n, |i, k| {
        if i < m {
            jac[i * n + k]
        } else if i - m == k {
            sq[k]
        } else {
            0.0
        }
    });
    let b = Mat::<f64>::from_fn(rows, 1, |i, _| if i < m { -r[i] } else { 0.0 });
    let qr = a.qr();
    let x = qr.solve_lstsq(&b);
    for (k, d) in delta.iter_mut().enumerate() {
        *d = x[(k, 0)];
    }
    delta.iter().all(|d| d.is_finite())
}

/// The triangular factor `R` (`(min(m, n), n)`, row-major) of the
/// Householder QR of the `(m, n)` row-major `jac`: `J^T J = R^T R`, and `R`
/// has the singular values of `J` (faer).
pub fn r_factor(jac: &[f64], m: usize, n: usize) -> Vec<f64> {
    if m == 0 || n == 0 {
        return Vec::new();
    }
    let a = Mat::<f64>::from_fn(m, n, |i, k| jac[i * n + k]);
    let qr = a.qr();
    let r = qr.thin_R();
    let rows = m.min(n);
    let mut out = vec![0.0; rows * n];
    for i in 0..rows {
        for k in i..n {
            out[i * n + k] = r[(i, k)];
        }
    }
    out
}

/// Solves the symmetric positive-definite `n x n` system `a x = b` (`a`
/// row-major): the square-root-free `L D L^T` of [`ldlt_solve`] on a copy on
/// the stack for n <= 6 (the pivots' reciprocals formed once, so the
/// substitutions only multiply), faer's Cholesky beyond. Returns `false` if
/// `a` is not positive definite (a pivot not > 0, or not finite).
#[inline(never)]
pub fn solve_spd(n: usize, a: &[f64], b: &[f64], x: &mut [f64]) -> bool {
    /// [`ldlt_solve`] of a constant size (its loops unrolled).
    fn fixed<const N: usize>(a: &[f64], b: &[f64], x: &mut [f64]) -> bool {
        // the lower triangle, element by element (the factorisation reads
        // no more; a whole-matrix copy would be a call to memcpy)
        let a = &a[..N * N];
        let mut f: [[f64; N]; N] = std::array::from_fn(|i| {
            std::array::from_fn(|j| if j <= i { a[i * N + j] } else { 0.0 })
        });
        let f = f.as_flattened_mut();
        let x = &mut x[..N];
        x.copy_from_slice(&b[..N]);
        ldlt_solve(N, f, x) && x.iter().all(|v| v.is_finite())
    }
    match n {
        1 => return fixed::<1>(a, b, x),
        2 => return fixed::<2>(a, b, x),
        3 => return fixed::<3>(a, b, x),
        4 => return fixed::<4>(a, b, x),
        5 => return fixed::<5>(a, b, x),
        6 => return fixed::<6>(a, b, x),
        _ => {}
    }
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

/// Solves the general `n x n` system `a x = b` by LU (nalgebra for n <= 6,
/// faer beyond); false when `a` is singular.
pub fn solve_general(n: usize, a: &[f64], b: &[f64], x: &mut [f64]) -> bool {
    solve_general_each(n, a, b, x)
}

/// [`solve_general`] of `a` with each right-hand side `b[k n..(k + 1) n]`
/// into `x[k n..(k + 1) n]`, `a` factored once (each answer the numbers of
/// its own [`solve_general`]); false when `a` is singular or an answer is
/// not finite (the answers after it unspecified).
pub fn solve_general_each(n: usize, a: &[f64], b: &[f64], x: &mut [f64]) -> bool {
    debug_assert_eq!(b.len(), x.len());
    let mut rhs = b.chunks_exact(n.max(1)).zip(x.chunks_exact_mut(n.max(1)));
    macro_rules! fixed {
        ($n:literal) => {{
            let lu = nalgebra::SMatrix::<f64, $n, $n>::from_row_slice(a).lu();
            rhs.all(|(bk, xk)| {
                let v = nalgebra::SVector::<f64, $n>::from_column_slice(bk);
                match lu.solve(&v) {
                    Some(s) => {
                        xk.copy_from_slice(s.as_slice());
                        xk.iter().all(|v| v.is_finite())
                    }
                    None => false,
                }
            })
        }};
    }
    match n {
        0 => true,
        1 => fixed!(1),
        2 => fixed!(2),
        3 => fixed!(3),
        4 => fixed!(4),
        5 => fixed!(5),
        6 => fixed!(6),
        _ => {
            let lu = Mat::<f64>::from_fn(n, n, |i, j| a[i * n + j]).partial_piv_lu();
            rhs.all(|(bk, xk)| {
                let r = Mat::<f64>::from_fn(n, 1, |i, _| bk[i]);
                let sol = lu.solve(&r);
                for (i, xi) in xk.iter_mut().enumerate() {
                    *xi = sol[(i, 0)];
                }
                xk.iter().all(|v| v.is_finite())
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fixed pseudo-random sequence in [-0.5, 0.5) (an LCG from `seed`).
    fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        }
    }

    /// r(x) = [x0^2 - 2, x0 x1 - 1]: lower triangular Jacobian.
    struct Tri;
    impl Problem for Tri {
        fn dims(&self) -> (usize, usize) {
            (2, 2)
        }
        fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
            r[0] = x[0] * x[0] - 2.0;
            r[1] = x[0] * x[1] - 1.0;
            if let Some(j) = jac {
                j.copy_from_slice(&[2.0 * x[0], 0.0, x[1], x[0]]);
            }
            true
        }
    }

    /// Fit y = a exp(b t) to exact data: a least-squares problem with zero residual.
    struct Exp {
        t: Vec<f64>,
        y: Vec<f64>,
    }
    impl Problem for Exp {
        fn dims(&self) -> (usize, usize) {
            (self.t.len(), 2)
        }
        fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
            for (i, (t, y)) in self.t.iter().zip(&self.y).enumerate() {
                r[i] = x[0] * (x[1] * t).exp() - y;
            }
            if let Some(j) = jac {
                for (i, t) in self.t.iter().enumerate() {
                    let e = (x[1] * t).exp();
                    j[2 * i] = e;
                    j[2 * i + 1] = x[0] * t * e;
                }
            }
            true
        }
    }

    #[test]
    fn every_step_finds_the_root_or_minimum() {
        let sqrt2 = 2f64.sqrt();
        for (step, lambda0) in [(Step::Triangular, 0.0), (Step::Triangular, 1e-3)] {
            let mut x = [1.0, 1.0];
            let lm = Lm {
                lambda0,
                ..Lm::equations(step, 1e-14, 100)
            };
            let st = solve(&mut Tri, &mut x, &lm, &mut Workspace::default());
            assert!(st.converged, "{step:?} {st:?}");
            assert!((x[0] - sqrt2).abs() < 1e-13 && (x[1] - 1.0 / sqrt2).abs() < 1e-13);
        }
        let t: Vec<f64> = (0..20).map(|i| i as f64 * 0.1).collect();
        let y: Vec<f64> = t.iter().map(|t| 1.5 * (-0.7 * t).exp()).collect();
        for step in [Step::Normal, Step::Qr] {
            for damping in [Damping::Levenberg, Damping::Marquardt] {
                let mut x = [1.0, 0.0];
                let lm = Lm {
                    step,
                    damping,
                    tol: 1e-13,
                    max_iter: 200,
                    lambda0: 1e-3,
                    min_decrease: 0.0,
                };
                let mut p = Exp {
                    t: t.clone(),
                    y: y.clone(),
                };
                let st = solve(&mut p, &mut x, &lm, &mut Workspace::default());
                assert!(st.converged, "{step:?} {damping:?} {st:?}");
                assert!((x[0] - 1.5).abs() < 1e-10 && (x[1] + 0.7).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn small_spd_solve_matches_faer_and_rejects_indefinite_matrices() {
        // a = M M^T + 0.1 I from a fixed pseudo-random M, n = 1..6
        let mut rnd = uniform(7);
        for n in 1..=6 {
            let m: Vec<f64> = (0..n * n).map(|_| rnd()).collect();
            let a: Vec<f64> = (0..n * n)
                .map(|ij| {
                    let (i, j) = (ij / n, ij % n);
                    let v: f64 = (0..n).map(|k| m[i * n + k] * m[j * n + k]).sum();
                    v + if i == j { 0.1 } else { 0.0 }
                })
                .collect();
            let b: Vec<f64> = (0..n).map(|_| rnd()).collect();
            let mut x = vec![0.0; n];
            assert!(solve_spd(n, &a, &b, &mut x));
            let fa = Mat::<f64>::from_fn(n, n, |i, j| a[i * n + j]);
            let fb = Mat::<f64>::from_fn(n, 1, |i, _| b[i]);
            let want = fa.llt(faer::Side::Lower).unwrap().solve(&fb);
            for i in 0..n {
                assert!(
                    (x[i] - want[(i, 0)]).abs() < 1e-12 * (1.0 + want[(i, 0)].abs()),
                    "n={n}"
                );
            }
            // an indefinite matrix (the last pivot negative) and NaN are refused
            let mut bad = a.clone();
            bad[n * n - 1] = -1.0;
            assert!(!solve_spd(n, &bad, &b, &mut x), "n={n}");
            bad[0] = f64::NAN;
            assert!(!solve_spd(n, &bad, &b, &mut x), "n={n}");
        }
    }

    #[test]
    fn one_factorisation_solves_each_right_hand_side_as_its_own_solve() {
        // solve_general_each: every right-hand side the bits of a solve of
        // it alone that factors the matrix again (nalgebra up to n = 6,
        // faer beyond), a singular matrix false
        let mut rnd = uniform(5);
        for n in 1..=10 {
            let a: Vec<f64> = (0..n * n).map(|_| rnd()).collect();
            let b: Vec<f64> = (0..6 * n).map(|_| rnd()).collect();
            let mut x = vec![0.0; 6 * n];
            assert!(solve_general_each(n, &a, &b, &mut x), "n={n}");
            for k in 0..6 {
                // the one-right-hand-side solve, factoring each time
                let bk = &b[k * n..(k + 1) * n];
                let want: Vec<f64> = if n <= 6 {
                    let m = nalgebra::DMatrix::from_row_slice(n, n, &a);
                    let v = nalgebra::DVector::from_column_slice(bk);
                    m.lu().solve(&v).unwrap().as_slice().to_vec()
                } else {
                    let m = Mat::<f64>::from_fn(n, n, |i, j| a[i * n + j]);
                    let r = Mat::<f64>::from_fn(n, 1, |i, _| bk[i]);
                    let sol = m.partial_piv_lu().solve(&r);
                    (0..n).map(|i| sol[(i, 0)]).collect()
                };
                let got = &x[k * n..(k + 1) * n];
                assert!(
                    got.iter()
                        .zip(&want)
                        .all(|(g, w)| g.to_bits() == w.to_bits()),
                    "n={n} k={k}"
                );
                // and it solves: a x = b
                for i in 0..n {
                    let r: f64 = (0..n).map(|j| a[i * n + j] * got[j]).sum();
                    assert!((r - b[k * n + i]).abs() < 1e-9, "n={n} k={k}");
                }
            }
            let mut singular = a.clone();
            for j in 0..n {
                singular[(n - 1) * n + j] = 0.0;
            }
            assert!(!solve_general_each(n, &singular, &b, &mut x), "n={n}");
        }
    }

    #[test]
    fn lane_solves_match_faer_lane_by_lane() {
        use crate::real::pack::Pack;
        // four systems per pack (n = 8): random, one with a zero leading
        // entry (it must pivot), one singular (its lane comes back false);
        // each lane equals faer's LU (and, SPD, its Cholesky) to 1e-12 and
        // has the bits of the same solve of its own row in f64
        let mut rnd = uniform(11);
        let n = 8;
        let mut a = vec![Pack::<4>::splat(0.0); n * n];
        let mut b = vec![Pack::<4>::splat(0.0); n];
        for v in a.iter_mut().chain(b.iter_mut()) {
            *v = Pack([rnd(), rnd(), rnd(), rnd()]);
        }
        a[0].0[1] = 0.0;
        for j in 0..n {
            // lane 3: row 5 = 2 row 2
            let v = a[2 * n + j].0[3];
            a[5 * n + j].0[3] = 2.0 * v;
        }
        let lane = |m: &[Pack<4>], i: usize| m.iter().map(|p| p.0[i]).collect::<Vec<f64>>();
        let close = |x: &[f64], want: &Mat<f64>| {
            (0..n).all(|i| (x[i] - want[(i, 0)]).abs() < 1e-12 * (1.0 + want[(i, 0)].abs()))
        };
        let (mut lu, mut x) = (a.clone(), b.clone());
        let ok = lu_solve(n, &mut lu, &mut x);
        for i in 0..4 {
            let (ai, bi) = (lane(&a, i), lane(&b, i));
            let (mut a1, mut x1) = (ai.clone(), bi.clone());
            let ok1 = lu_solve(n, &mut a1, &mut x1);
            assert_eq!(Pack::lane_set(ok, i), ok1, "lane {i}");
            assert_eq!(ok1, i != 3, "lane {i}");
            if i == 3 {
                continue;
            }
            assert_eq!(lane(&x, i), x1, "lane {i}: the bits of its own row");
            let fa = Mat::<f64>::from_fn(n, n, |r, c| ai[r * n + c]);
            let fb = Mat::<f64>::from_fn(n, 1, |r, _| bi[r]);
            assert!(close(&x1, &fa.partial_piv_lu().solve(&fb)), "lane {i}");
        }
        // L D L^T of a^T a + 0.1 I
        let mut spd = vec![Pack::<4>::splat(0.0); n * n];
        for r in 0..n {
            for c in 0..n {
                let mut v = Pack::splat(if r == c { 0.1 } else { 0.0 });
                for k in 0..n {
                    v += a[k * n + r] * a[k * n + c];
                }
                spd[r * n + c] = v;
            }
        }
        let (mut f, mut x) = (spd.clone(), b.clone());
        assert!(Pack::all(ldlt_solve(n, &mut f, &mut x)));
        for i in 0..4 {
            let (si, bi) = (lane(&spd, i), lane(&b, i));
            let (mut f1, mut x1) = (si.clone(), bi.clone());
            assert!(ldlt_solve(n, &mut f1, &mut x1));
            assert_eq!(lane(&x, i), x1, "lane {i}: the bits of its own row");
            let fa = Mat::<f64>::from_fn(n, n, |r, c| si[r * n + c]);
            let fb = Mat::<f64>::from_fn(n, 1, |r, _| bi[r]);
            let want = fa.llt(faer::Side::Lower).unwrap().solve(&fb);
            assert!(close(&x1, &want), "lane {i}");
        }
    }

    #[test]
    fn normal_equations_skip_only_zero_products() {
        // J (5 x 3) whose column k is zero above row k (a cable reaching
        // only the joints before its end): the sums over the rows that
        // reach each column have the bits of the full sums
        let (m, n) = (5, 3);
        let jac: Vec<f64> = (0..m * n)
            .map(|ij| {
                let (i, k) = (ij / n, ij % n);
                if i < k {
                    0.0
                } else {
                    ((ij as f64) * 0.37).sin() - 0.1
                }
            })
            .collect();
        let r: Vec<f64> = (0..m).map(|i| (i as f64 * 1.3).cos()).collect();
        let rows: Vec<Vec<usize>> = (0..n).map(|k| (k..m).collect()).collect();
        let (mut a0, mut g0, mut a1, mut g1) =
            (vec![0.0; 9], vec![0.0; 3], vec![0.0; 9], vec![0.0; 3]);
        normal_equations(
            &jac,
            &r,
            m,
            n,
            None,
            0.5,
            Damping::Marquardt,
            &mut a0,
            &mut g0,
        );
        normal_equations(
            &jac,
            &r,
            m,
            n,
            Some(&rows),
            0.5,
            Damping::Marquardt,
            &mut a1,
            &mut g1,
        );
        assert_eq!(
            a0.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            a1.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(
            g0.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            g1.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        // against the definition, J^T J + 0.5 diag(J^T J) and -J^T r
        for k in 0..n {
            let gk: f64 = -(0..m).map(|i| jac[i * n + k] * r[i]).sum::<f64>();
            assert!((g1[k] - gk).abs() < 1e-15);
            for l in 0..n {
                let v: f64 = (0..m).map(|i| jac[i * n + k] * jac[i * n + l]).sum();
                let want = if k == l { 1.5 * v } else { v };
                assert!((a1[k * n + l] - want).abs() < 1e-14, "{k} {l}");
            }
        }
    }

    /// x = 1 and x = -1 at once: no root; the best is x = 0 with |r| = 1.
    struct NoRoot;
    impl Problem for NoRoot {
        fn dims(&self) -> (usize, usize) {
            (2, 1)
        }
        fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
            r[0] = x[0] - 1.0;
            r[1] = x[0] + 1.0;
            if let Some(j) = jac {
                j.copy_from_slice(&[1.0, 1.0]);
            }
            true
        }
    }

    #[test]
    fn a_stationary_misfit_is_reported_as_stalled() {
        let mut x = [0.3];
        let lm = Lm::equations(Step::Normal, 1e-12, 100);
        let st = solve(&mut NoRoot, &mut x, &lm, &mut Workspace::default());
        assert!(!st.converged);
        assert_eq!(st.reason, Reason::Stalled, "{st:?}");
        // the cost 2 + 2 x^2 stops falling in floating point once x^2 < 1e-16
        assert!(
            (st.residual - 1.0).abs() < 1e-7 && x[0].abs() < 1e-7,
            "{x:?}"
        );
    }
}
