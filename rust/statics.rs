//! Statics of the hybrid-controlled arm: upper-cable tensions from the moment
//! balance at every joint, slack detection, and cable elasticity (Hooke) with
//! the coupled elastic cable solve.
//!
//! Force balance (frictionless pins, massless straight cables): cut the arm
//! just distal of joint `k` (across segment `k` of every cable of pair `>= k`).
//! The cut-off part — linkages `k..n` with the cable pieces inside them — is
//! held by the pin force at joint `k` (no moment), the cut cables and the
//! external loads. Cable `c` pulls the part at its hole `A_k` (face `a` of
//! disk `k`) with `T_c · unit(B_{k-1} − A_k)`. The moment about joint `k`:
//!
//! ```text
//! sum_c T_c · m_{c,k} + tau_k = 0,   m_{c,k} = (A_k − J_k) × unit(B_{k-1} − A_k)
//! ```
//!
//! with `tau_k` the moment of the external loads on the cut-off part about
//! `J_k`. The upper cable of pair `i` crosses joints `1..=i`, so the system in
//! the `n` upper tensions is triangular and is solved from the tip joint down.
//!
//! Mass model: linkage `i`'s whole mass (Table 1) sits at the centre of disk
//! `i`, the point `(thickness_i / 2, 0)` of frame `O_{i,a}`; gravity is an
//! in-plane vector `g` (m/s², base frame; default none: horizontal plane).
//! The tip wrench `[Fx, Fy, Mz]` (N, N, N·m) acts at the tip (origin of
//! `O_{n,b}`), base frame.
//!
//! Elasticity: a cable piece of rest length `l` under tension `T` is
//! `l (1 + T/(E A))` long, `A = pi d² / 4`. The actuator fixes the rest length
//! `L_cmd + L_route` from the screw to the anchor on disk `i`, where
//! `L_route` (robot file `[cable] routing_length`, default 0) is the cable path
//! behind the base disk: it carries the same tension (frictionless routing), so
//! it stretches too, while its geometric length stays `L_route`. The length
//! the arm sees is therefore
//!
//! ```text
//! L_geom = (L_cmd + L_route)(1 + eps) − L_route,   eps = T / (E A).
//! ```
//!
//! The lower cables are force controlled (hanging weights): their stretch is
//! taken up by the weights and does not move the arm.

use crate::batch::{rows_of, split_rows, BatchSolution};
use crate::cables::CableGeometry;
use crate::error::{check_finite, CdsmError, Result};
use crate::geometry::{pair, ArmGeometry};
use crate::lm::{self, Lm, Problem, Step, Workspace};
use crate::real::{Dual, Real};
use crate::robot::Robot;
use crate::solve::{self, CableMethod, SolveOptions, Status};

/// External loads and force-controlled tensions for one configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Loads<'a> {
    /// Lower-cable tensions (N), one per pair.
    pub lower: &'a [f64],
    /// Tip wrench `[Fx, Fy, Mz]` (N, N, N·m), base frame.
    pub tip_wrench: [f64; 3],
    /// In-plane gravity (m/s²), base frame; `[0, 0]` for a horizontal plane.
    pub gravity: [f64; 2],
}

impl<'a> Loads<'a> {
    /// The robot file's loads: its lower tensions and gravity, no tip wrench.
    pub fn of(robot: &'a Robot) -> Loads<'a> {
        Loads {
            lower: &robot.lower_tension,
            tip_wrench: [0.0; 3],
            gravity: robot.gravity,
        }
    }
}

#[inline]
fn cross<S: Real>(a: [S; 2], b: [S; 2]) -> S {
    a[0] * b[1] - a[1] * b[0]
}

/// Axial stiffness `E A` (N) of the robot's cable.
pub fn axial_stiffness(robot: &Robot) -> f64 {
    let d = robot.cable.diameter;
    robot.cable.youngs_modulus * std::f64::consts::PI * d * d / 4.0
}

/// Reusable buffers of the statics of an `n`-joint arm, in any scalar.
#[derive(Debug, Clone)]
pub struct TensionBuffers<S> {
    cs: Vec<(S, S)>,
    joint: Vec<[S; 2]>,
    centre: Vec<[S; 2]>,
    /// `m_{c,k}` at `c * n + k` (N·m per N of tension): minus the segment's
    /// length derivative.
    moment: Vec<S>,
}

impl<S: Real> TensionBuffers<S> {
    pub fn new(n: usize) -> Self {
        let z = S::cst(0.0);
        TensionBuffers {
            cs: vec![(z, z); n],
            joint: vec![[z, z]; n],
            centre: vec![[z, z]; n],
            moment: vec![z; 2 * n * n],
        }
    }
}

/// Upper-cable tensions (N) of `arm` at `theta` into `out` (n): the moment
/// balance about every joint of the part distal of it (`docs/model.md`),
/// triangular, tip joint first. The moment arm of a unit tension in segment
/// `k` of cable `c` is `-dL_c/dtheta_k` (the segment geometry's derivative).
/// `mass` (kg) carries the gravity of `loads`. NaN where an upper cable has no
/// moment arm about its own joint.
pub fn upper_tensions<S: Real, A: ArmGeometry<S>>(
    arm: &A,
    theta: &[S],
    loads: &Loads,
    mass: &[f64],
    buf: &mut TensionBuffers<S>,
    out: &mut [S],
) {
    let n = arm.n();
    let z = S::cst(0.0);
    for (c, t) in buf.cs.iter_mut().zip(theta) {
        let (s, co) = t.sin_cos();
        *c = (co, s);
    }
    for c in 0..2 * n {
        for k in 0..n {
            buf.moment[c * n + k] = if k <= pair(c) {
                -arm.segment(c, k, z).length_and_derivative(buf.cs[k]).1
            } else {
                z
            };
        }
    }
    let gravity = loads.gravity != [0.0, 0.0];
    let [fx, fy, mz] = loads.tip_wrench;
    let wrench = fx != 0.0 || fy != 0.0 || mz != 0.0;
    let tip = if gravity || wrench {
        arm.chain(theta, &mut buf.joint, &mut buf.centre)
    } else {
        [z, z]
    };
    for k in (0..n).rev() {
        let mut rhs = z;
        if wrench {
            let d = [tip[0] - buf.joint[k][0], tip[1] - buf.joint[k][1]];
            rhs += cross(d, [S::cst(fx), S::cst(fy)]) + mz;
        }
        if gravity {
            for (c, m) in buf.centre[k..n].iter().zip(&mass[k..n]) {
                let w = [S::cst(m * loads.gravity[0]), S::cst(m * loads.gravity[1])];
                let d = [c[0] - buf.joint[k][0], c[1] - buf.joint[k][1]];
                rhs += cross(d, w);
            }
        }
        for p in k..n {
            rhs += buf.moment[(2 * p + 1) * n + k] * loads.lower[p];
        }
        for (p, tp) in out.iter().enumerate().skip(k + 1) {
            rhs += *tp * buf.moment[2 * p * n + k];
        }
        let a = buf.moment[2 * k * n + k];
        out[k] = if a.val() != 0.0 {
            -rhs / a
        } else {
            S::cst(f64::NAN)
        };
    }
}

/// The statics of one robot with its buffers (`f64`).
pub struct Statics<'a> {
    robot: &'a Robot,
    buf: TensionBuffers<f64>,
}

impl<'a> Statics<'a> {
    pub fn new(robot: &'a Robot) -> Self {
        Statics {
            robot,
            buf: TensionBuffers::new(robot.n()),
        }
    }

    /// Upper-cable tensions (N) at `theta` into `out` (n); see [`upper_tensions`].
    pub fn tensions(&mut self, theta: &[f64], loads: &Loads, out: &mut [f64]) {
        upper_tensions(
            self.robot,
            theta,
            loads,
            &self.robot.mass,
            &mut self.buf,
            out,
        );
    }
}

/// Whether every upper tension exceeds `min_tension` (N); NaN is infeasible.
#[inline]
pub fn feasible(tension: &[f64], min_tension: f64) -> bool {
    tension.iter().all(|t| *t > min_tension)
}

/// Elongation (m) of an upper cable whose arm length is `l_geom` (m) under
/// tension `t` (N): `(l_geom + L_route) · eps / (1 + eps)`.
#[inline]
pub fn stretch(l_geom: f64, t: f64, ea: f64, routing: f64) -> f64 {
    let eps = t / ea;
    (l_geom + routing) * eps / (1.0 + eps)
}

/// The elastic cable solve as a problem of the shared solver:
/// `r = L_geom(theta) - (L_cmd + L_route) T(theta)/(E A) - L_cmd`, with the
/// Jacobian `dL_geom/dtheta - diag((L_cmd + L_route)/(E A)) dT/dtheta`,
/// `dT/dtheta` exact in dual numbers.
struct ElasticProblem<'a> {
    robot: &'a Robot,
    geom: &'a CableGeometry,
    upper: &'a [f64],
    loads: &'a Loads<'a>,
    ea: f64,
    route: f64,
    cs: Vec<(f64, f64)>,
    lg: Vec<f64>,
    jg: Vec<f64>,
    t: Vec<f64>,
    buf: TensionBuffers<f64>,
    dbuf: TensionBuffers<Dual>,
    dtheta: Vec<Dual>,
    dt: Vec<Dual>,
}

impl<'a> ElasticProblem<'a> {
    fn new(
        robot: &'a Robot,
        geom: &'a CableGeometry,
        upper: &'a [f64],
        loads: &'a Loads<'a>,
    ) -> Self {
        let n = robot.n();
        ElasticProblem {
            robot,
            geom,
            upper,
            loads,
            ea: axial_stiffness(robot),
            route: robot.cable.routing_length,
            cs: vec![(1.0, 0.0); n],
            lg: vec![0.0; n],
            jg: vec![0.0; n * n],
            t: vec![0.0; n],
            buf: TensionBuffers::new(n),
            dbuf: TensionBuffers::new(n),
            dtheta: vec![Dual::default(); n],
            dt: vec![Dual::default(); n],
        }
    }

    fn tensions(&mut self, theta: &[f64]) {
        upper_tensions(
            self.robot,
            theta,
            self.loads,
            &self.robot.mass,
            &mut self.buf,
            &mut self.t,
        );
    }
}

impl Problem for ElasticProblem<'_> {
    fn dims(&self) -> (usize, usize) {
        (self.upper.len(), self.upper.len())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        let n = x.len();
        for (c, t) in self.cs.iter_mut().zip(x) {
            let (s, co) = t.sin_cos();
            *c = (co, s);
        }
        self.geom
            .upper_lengths_and_jacobian(&self.cs, &mut self.lg, &mut self.jg);
        self.tensions(x);
        for (((ri, lg), up), t) in r.iter_mut().zip(&self.lg).zip(self.upper).zip(&self.t) {
            *ri = lg - (up + self.route) * t / self.ea - up;
        }
        if let Some(j) = jac {
            j.copy_from_slice(&self.jg);
            for k in 0..n {
                for (l, d) in self.dtheta.iter_mut().enumerate() {
                    *d = Dual::new(x[l], if l == k { 1.0 } else { 0.0 });
                }
                upper_tensions(
                    self.robot,
                    &self.dtheta,
                    self.loads,
                    &self.robot.mass,
                    &mut self.dbuf,
                    &mut self.dt,
                );
                for i in 0..n {
                    j[i * n + k] -= (self.upper[i] + self.route) / self.ea * self.dt[i].der();
                }
            }
        }
        r.iter().all(|v| v.is_finite())
    }
}

/// Coupled elastic cable solve for one configuration: commanded (unstretched)
/// upper lengths `upper` (m) to `theta` (seed on entry, answer on exit), by
/// the shared solver (normal-equation step) on
/// `r = L_geom(theta) - (L_cmd + L_route) T(theta)/(E A) - L_cmd`.
/// `tension` gets the upper tensions at the answer.
#[allow(clippy::too_many_arguments)]
pub fn solve_cables_elastic(
    robot: &Robot,
    geom: &CableGeometry,
    upper: &[f64],
    loads: &Loads,
    theta: &mut [f64],
    tension: &mut [f64],
    opts: &SolveOptions,
    ws: &mut Workspace,
) -> Status {
    let mut p = ElasticProblem::new(robot, geom, upper, loads);
    let lm = Lm::equations(Step::Normal, opts.tol, opts.max_iter);
    let st = lm::solve(&mut p, theta, &lm, ws);
    p.tensions(theta);
    tension.copy_from_slice(&p.t);
    st
}

// ---------------------------------------------------------------------------
// Batched drivers
// ---------------------------------------------------------------------------

/// Per-row or shared loads of a batch (validated).
#[derive(Debug, Clone, Copy)]
pub struct BatchLoads<'a> {
    /// `(n,)` shared or `(N, n)` per row (N); `None`: the robot's lower tensions.
    pub lower: Option<&'a [f64]>,
    /// `(3,)` shared or `(N, 3)` per row; `None`: no wrench.
    pub tip_wrench: Option<&'a [f64]>,
    /// `(2,)`; `None`: the robot file's gravity.
    pub gravity: Option<&'a [f64]>,
}

fn shared_or_rows(name: &str, v: &[f64], width: usize, rows: usize) -> Result<bool> {
    check_finite(name, v)?;
    if v.len() == width {
        Ok(false)
    } else if v.len() == rows * width {
        Ok(true)
    } else {
        Err(CdsmError::Shape {
            name: name.into(),
            expected: format!("({width},) or ({rows}, {width})"),
            got: format!("{} values", v.len()),
        })
    }
}

/// A validated batch of loads: `at(i)` gives row `i`'s [`Loads`].
struct LoadRows<'a> {
    lower: &'a [f64],
    lower_rows: bool,
    wrench: Option<(&'a [f64], bool)>,
    gravity: [f64; 2],
    n: usize,
}

impl<'a> LoadRows<'a> {
    fn new(robot: &'a Robot, loads: &BatchLoads<'a>, rows: usize) -> Result<Self> {
        let n = robot.n();
        let (lower, lower_rows) = match loads.lower {
            Some(l) => (l, shared_or_rows("lower", l, n, rows)?),
            None => (robot.lower_tension.as_slice(), false),
        };
        let wrench = match loads.tip_wrench {
            Some(w) => Some((w, shared_or_rows("tip_wrench", w, 3, rows)?)),
            None => None,
        };
        let gravity = match loads.gravity {
            Some(g) => {
                check_finite("gravity", g)?;
                if g.len() != 2 {
                    return Err(CdsmError::Shape {
                        name: "gravity".into(),
                        expected: "(2,) [gx, gy] m/s^2".into(),
                        got: format!("{} values", g.len()),
                    });
                }
                [g[0], g[1]]
            }
            None => robot.gravity,
        };
        Ok(LoadRows {
            lower,
            lower_rows,
            wrench,
            gravity,
            n,
        })
    }

    fn at(&self, i: usize) -> Loads<'a> {
        let n = self.n;
        let lower = if self.lower_rows {
            &self.lower[i * n..(i + 1) * n]
        } else {
            self.lower
        };
        let tip_wrench = match self.wrench {
            Some((w, true)) => [w[3 * i], w[3 * i + 1], w[3 * i + 2]],
            Some((w, false)) => [w[0], w[1], w[2]],
            None => [0.0; 3],
        };
        Loads {
            lower,
            tip_wrench,
            gravity: self.gravity,
        }
    }
}

fn check_min_tension(min_tension: f64) -> Result<()> {
    if min_tension.is_finite() {
        Ok(())
    } else {
        Err(CdsmError::Option {
            name: "min_tension".into(),
            problem: format!("must be finite, got {min_tension}"),
        })
    }
}

/// Batched upper tensions: `theta (N, n)` -> `(N, n)` N.
pub fn tensions(
    robot: &Robot,
    theta: &[f64],
    loads: &BatchLoads,
    threads: usize,
) -> Result<Vec<f64>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    let lr = LoadRows::new(robot, loads, rows)?;
    Ok(split_rows(rows, threads, |r| {
        let mut st = Statics::new(robot);
        let mut out = vec![0.0; r.len() * n];
        for (j, i) in r.enumerate() {
            st.tensions(
                &theta[i * n..(i + 1) * n],
                &lr.at(i),
                &mut out[j * n..(j + 1) * n],
            );
        }
        out
    })
    .concat())
}

/// Batched feasibility: every upper tension `> min_tension` (N), `(N,)`.
pub fn feasibility(
    robot: &Robot,
    theta: &[f64],
    loads: &BatchLoads,
    min_tension: f64,
    threads: usize,
) -> Result<Vec<bool>> {
    check_min_tension(min_tension)?;
    let n = robot.n();
    let t = tensions(robot, theta, loads, threads)?;
    Ok(t.chunks(n).map(|row| feasible(row, min_tension)).collect())
}

/// Batched upper-cable elongation (m) at `theta (N, n)` under the statics
/// tensions: `(N, n)`.
pub fn stretches(
    robot: &Robot,
    theta: &[f64],
    loads: &BatchLoads,
    threads: usize,
) -> Result<Vec<f64>> {
    let n = robot.n();
    let mut out = tensions(robot, theta, loads, threads)?;
    let g = CableGeometry::new(robot, None);
    let ea = axial_stiffness(robot);
    let route = robot.cable.routing_length;
    let mut cs = vec![(1.0, 0.0); n];
    for (th, row) in theta.chunks(n).zip(out.chunks_mut(n)) {
        for (c, t) in cs.iter_mut().zip(th) {
            *c = (t.cos(), t.sin());
        }
        for (p, o) in row.iter_mut().enumerate() {
            *o = stretch(g.length(2 * p, &cs), *o, ea, route);
        }
    }
    Ok(out)
}

/// Result of a batch of elastic solves.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ElasticSolution {
    pub solution: BatchSolution,
    /// `(N, n)` upper tensions at the answer (N).
    pub tension: Vec<f64>,
    /// Every upper tension `> min_tension`.
    pub feasible: Vec<bool>,
}

/// Batched coupled elastic cable solve: commanded (unstretched) upper lengths
/// `(N, n)` m. Each row: the rigid cable solve (auto) from the seed (default
/// zeros), then the elastic LM from there.
pub fn solve_elastic(
    robot: &Robot,
    upper: &[f64],
    seed: Option<&[f64]>,
    loads: &BatchLoads,
    min_tension: f64,
    opts: &SolveOptions,
    threads: usize,
) -> Result<ElasticSolution> {
    let n = robot.n();
    let rows = rows_of("upper", upper, n)?;
    let seed = crate::batch::seeds(seed, rows, n)?;
    crate::batch::check_options(opts)?;
    check_min_tension(min_tension)?;
    let lr = LoadRows::new(robot, loads, rows)?;
    let g = CableGeometry::new(robot, None);
    let parts = split_rows(rows, threads, |r| {
        let mut out = ElasticSolution::default();
        let mut th = vec![0.0; n];
        let mut t = vec![0.0; n];
        let mut rigid = solve::CableSolver::new(robot, CableMethod::Auto, *opts);
        let mut ws = Workspace::default();
        let mut start = vec![0.0; n];
        for i in r {
            match seed {
                Some(s) => th.copy_from_slice(&s[i * n..(i + 1) * n]),
                None => th.fill(0.0),
            }
            let target = &upper[i * n..(i + 1) * n];
            start.copy_from_slice(&th);
            if !rigid.solve(&g, target, &mut th).converged {
                th.copy_from_slice(&start);
            }
            let loads = lr.at(i);
            let st =
                solve_cables_elastic(robot, &g, target, &loads, &mut th, &mut t, opts, &mut ws);
            out.solution.push(robot, &th, st);
            out.tension.extend_from_slice(&t);
            out.feasible.push(feasible(&t, min_tension));
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
    use crate::geometry::ArmGeometry;
    use crate::kinematics::{fk, fk_jacobian};

    const G: f64 = 9.80665;

    fn no_loads(r: &Robot) -> Loads<'_> {
        Loads {
            lower: &r.lower_tension,
            tip_wrench: [0.0; 3],
            gravity: [0.0; 2],
        }
    }

    #[test]
    fn straight_pose_tensions_equal_the_weights() {
        let r = Robot::paper();
        let mut t = [0.0; 3];
        Statics::new(&r).tensions(&[0.0; 3], &no_loads(&r), &mut t);
        for k in 0..3 {
            assert!((t[k] - r.lower_tension[k]).abs() < 1e-14, "{t:?}");
        }
    }

    #[test]
    fn virtual_work_matches_the_cable_jacobian() {
        // sum_c T_c dL_c/dtheta_k = tau_k, tau from the tip wrench and gravity.
        let r = Robot::paper();
        let g = CableGeometry::new(&r, None);
        let th = [0.3, -0.45, 0.2];
        let loads = Loads {
            lower: &r.lower_tension,
            tip_wrench: [0.3, -0.2, 0.01],
            gravity: [1.0, -9.81],
        };
        let mut t = [0.0; 3];
        Statics::new(&r).tensions(&th, &loads, &mut t);
        let mut jac = [0.0; 18];
        g.jacobian(&th, &mut jac);
        let mut jt = [[0.0; 3]; 3];
        fk_jacobian(&r, &th, &mut jt);
        for k in 0..3 {
            let work: f64 = (0..6)
                .map(|c| {
                    jac[c * 3 + k]
                        * if c % 2 == 0 {
                            t[c / 2]
                        } else {
                            r.lower_tension[c / 2]
                        }
                })
                .sum();
            let mut tau: f64 = (0..3).map(|i| jt[k][i] * loads.tip_wrench[i]).sum();
            // gravity: d(centre_j)/d theta_k by central differences of the chain
            let h = 1e-6;
            let (mut a, mut b) = (th, th);
            a[k] += h;
            b[k] -= h;
            let (mut ja, mut ca, mut jb, mut cb) =
                ([[0.0; 2]; 3], [[0.0; 2]; 3], [[0.0; 2]; 3], [[0.0; 2]; 3]);
            r.chain(&a, &mut ja, &mut ca);
            r.chain(&b, &mut jb, &mut cb);
            for j in 0..3 {
                let d = [ca[j][0] - cb[j][0], ca[j][1] - cb[j][1]];
                tau += r.mass[j] * (d[0] * loads.gravity[0] + d[1] * loads.gravity[1]) / (2.0 * h);
            }
            assert!((work - tau).abs() < 1e-9, "{k}: {work} vs {tau}");
        }
    }

    #[test]
    fn tip_position_from_statics_walk_equals_fk() {
        let r = Robot::paper();
        let th = [0.1, 0.2, -0.3];
        let (mut j, mut c) = ([[0.0; 2]; 3], [[0.0; 2]; 3]);
        let tip = r.chain(&th, &mut j, &mut c);
        let p = fk(&r, &th);
        assert!((tip[0] - p[0]).abs() < 1e-15 && (tip[1] - p[1]).abs() < 1e-15);
    }

    #[test]
    fn paper_cable_stretch_is_about_two_hundredths_of_a_mm() {
        let r = Robot::paper();
        let s = stretch(0.230, 0.050 * G, axial_stiffness(&r), 0.0);
        assert!(s > 0.0234e-3 / 2.0 && s < 0.0234e-3 * 2.0, "{s}");
    }

    #[test]
    fn elastic_solve_meets_its_equation_and_stiff_limit() {
        let r = Robot::paper();
        let g = CableGeometry::new(&r, None);
        let th0 = [0.2, -0.3, 0.25];
        let mut l = [0.0; 6];
        g.lengths(&th0, &mut l);
        let cmd = [l[0], l[2], l[4]];
        let mut th = th0;
        let mut t = [0.0; 3];
        let st = solve_cables_elastic(
            &r,
            &g,
            &cmd,
            &no_loads(&r),
            &mut th,
            &mut t,
            &SolveOptions::default(),
            &mut Workspace::default(),
        );
        assert!(st.converged, "{st:?}");
        // The stretched cables let the arm move a little (steel: < 0.1 mrad).
        let moved = th
            .iter()
            .zip(th0)
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(moved > 1e-7 && moved < 1e-3, "{moved}");
        let mut lg = [0.0; 6];
        g.lengths(&th, &mut lg);
        let ea = axial_stiffness(&r);
        for i in 0..3 {
            assert!((lg[2 * i] - cmd[i] * (1.0 + t[i] / ea)).abs() < 1e-12);
        }
    }
}
