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
use crate::kinematics::within_limits;
use crate::robot::Robot;
use crate::solve::{self, levenberg_marquardt, CableMethod, SolveOptions, Status};

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

#[inline]
fn cross(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

#[inline]
fn rot(c: f64, s: f64, v: [f64; 2]) -> [f64; 2] {
    [c * v[0] - s * v[1], s * v[0] + c * v[1]]
}

#[inline]
fn sub(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [a[0] - b[0], a[1] - b[1]]
}

/// Axial stiffness `E A` (N) of the robot's cable.
pub fn axial_stiffness(robot: &Robot) -> f64 {
    let d = robot.cable.diameter;
    robot.cable.youngs_modulus * std::f64::consts::PI * d * d / 4.0
}

/// Reusable buffers for the statics of one robot.
pub struct Statics<'a> {
    robot: &'a Robot,
    n: usize,
    /// Joint positions `J_k` (base frame).
    joint: Vec<[f64; 2]>,
    /// Disk centres (base frame).
    centre: Vec<[f64; 2]>,
    /// `m_{c,k}` at `c * n + k` (N·m per N of tension).
    moment: Vec<f64>,
    tip: [f64; 2],
}

impl<'a> Statics<'a> {
    pub fn new(robot: &'a Robot) -> Self {
        let n = robot.n();
        Statics {
            robot,
            n,
            joint: vec![[0.0; 2]; n],
            centre: vec![[0.0; 2]; n],
            moment: vec![0.0; 2 * n * n],
            tip: [0.0; 2],
        }
    }

    /// Walks the chain in the base frame: joints, disk centres, tip and the
    /// moment arm of every cable segment about its joint.
    fn geometry(&mut self, theta: &[f64]) {
        let (r, n) = (self.robot, self.n);
        let mut o = [0.0f64; 2]; // origin of O_{k-1,b}
        let (mut c0, mut s0) = (1.0f64, 0.0f64); // its axis
        for (k, tk) in theta.iter().enumerate().take(n) {
            let j = [o[0] + r.link_before[k] * c0, o[1] + r.link_before[k] * s0];
            let (st, ct) = tk.sin_cos();
            let (c1, s1) = (c0 * ct - s0 * st, s0 * ct + c0 * st);
            let a = [j[0] + r.link_after[k] * c1, j[1] + r.link_after[k] * s1];
            self.joint[k] = j;
            self.centre[k] = [
                a[0] + 0.5 * r.thickness[k] * c1,
                a[1] + 0.5 * r.thickness[k] * s1,
            ];
            for c in 0..2 * n {
                self.moment[c * n + k] = if k <= c / 2 {
                    let p = rot(c0, s0, r.hole(c, k, 1));
                    let q = rot(c1, s1, r.hole(c, k + 1, 0));
                    let b_prev = [o[0] + p[0], o[1] + p[1]];
                    let a_k = [a[0] + q[0], a[1] + q[1]];
                    let d = sub(b_prev, a_k);
                    cross(sub(a_k, j), d) / d[0].hypot(d[1])
                } else {
                    0.0
                };
            }
            o = [a[0] + r.thickness[k] * c1, a[1] + r.thickness[k] * s1];
            (c0, s0) = (c1, s1);
        }
        self.tip = o;
    }

    /// Moment about joint `k` of the external loads on the part distal of it.
    fn external_moment(&self, k: usize, loads: &Loads) -> f64 {
        let [fx, fy, mz] = loads.tip_wrench;
        let mut tau = cross(sub(self.tip, self.joint[k]), [fx, fy]) + mz;
        if loads.gravity != [0.0, 0.0] {
            for j in k..self.n {
                let w = self.robot.mass[j];
                tau += cross(
                    sub(self.centre[j], self.joint[k]),
                    [w * loads.gravity[0], w * loads.gravity[1]],
                );
            }
        }
        tau
    }

    /// Upper-cable tensions (N) at `theta` into `out` (n): triangular moment
    /// balance, tip joint first. NaN where an upper cable has no moment arm
    /// about its own joint (the balance cannot be met).
    pub fn tensions(&mut self, theta: &[f64], loads: &Loads, out: &mut [f64]) {
        self.geometry(theta);
        let n = self.n;
        for k in (0..n).rev() {
            let mut rhs = self.external_moment(k, loads);
            for p in k..n {
                rhs += loads.lower[p] * self.moment[(2 * p + 1) * n + k];
            }
            for (p, tp) in out.iter().enumerate().skip(k + 1) {
                rhs += tp * self.moment[2 * p * n + k];
            }
            let arm = self.moment[2 * k * n + k];
            out[k] = if arm != 0.0 { -rhs / arm } else { f64::NAN };
        }
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

/// Coupled elastic cable solve for one configuration: commanded (unstretched)
/// upper lengths `upper` (m) to `theta` (seed on entry, answer on exit).
/// Residual `r = L_cmd − (L_geom(theta) − (L_cmd + L_route) T(theta)/(E A))`,
/// LM with the Jacobian `dL_geom/dtheta − diag((L_cmd + L_route)/(E A)) dT/dtheta`
/// (`dT/dtheta` by central differences, step 1e-7 rad). `tension` gets the
/// upper tensions at the answer.
#[allow(clippy::too_many_arguments)]
pub fn solve_cables_elastic(
    robot: &Robot,
    geom: &CableGeometry,
    upper: &[f64],
    loads: &Loads,
    theta: &mut [f64],
    tension: &mut [f64],
    opts: &SolveOptions,
) -> Status {
    let n = robot.n();
    let ea = axial_stiffness(robot);
    let route = robot.cable.routing_length;
    let mut st = Statics::new(robot);
    let mut cs = vec![(1.0, 0.0); n];
    let mut lg = vec![0.0; n];
    let mut t = vec![0.0; n];
    let mut tp = vec![0.0; n];
    let mut tm = vec![0.0; n];
    let mut th = vec![0.0; n];
    let mut jac = vec![0.0; n * n];
    let (mut a, mut g) = (vec![0.0; n * n], vec![0.0; n]);
    let status = {
        let model =
            |th: &[f64], st: &mut Statics, cs: &mut [(f64, f64)], lg: &mut [f64], t: &mut [f64]| {
                for (c, x) in cs.iter_mut().zip(th) {
                    *c = (x.cos(), x.sin());
                }
                geom.upper_lengths(cs, lg);
                st.tensions(th, loads, t);
            };
        let st_cell = std::cell::RefCell::new(&mut st);
        levenberg_marquardt(
            robot,
            theta,
            n,
            opts,
            |x, r| {
                let mut s = st_cell.borrow_mut();
                model(x, &mut s, &mut cs, &mut lg, &mut t);
                for i in 0..n {
                    r[i] = upper[i] - (lg[i] - (upper[i] + route) * t[i] / ea);
                }
            },
            |x, r, lambda, delta| {
                let mut s = st_cell.borrow_mut();
                let h = 1e-7;
                for (k, xk) in x.iter().enumerate() {
                    let csk = (xk.cos(), xk.sin());
                    for i in 0..n {
                        jac[i * n + k] = geom.derivative(2 * i, k, csk);
                    }
                }
                for k in 0..n {
                    th.copy_from_slice(x);
                    th[k] = x[k] + h;
                    s.tensions(&th, loads, &mut tp);
                    th[k] = x[k] - h;
                    s.tensions(&th, loads, &mut tm);
                    for i in 0..n {
                        jac[i * n + k] -= (upper[i] + route) / ea * (tp[i] - tm[i]) / (2.0 * h);
                    }
                }
                solve::normal_equations(n, &jac, r, lambda, &mut a, &mut g);
                solve::solve_spd(n, &a, &g, delta) && delta.iter().all(|d| d.is_finite())
            },
        )
    };
    st.tensions(theta, loads, tension);
    status
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
    /// `(2,)`; `None`: no gravity.
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
            None => [0.0, 0.0],
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
        for i in r {
            match seed {
                Some(s) => th.copy_from_slice(&s[i * n..(i + 1) * n]),
                None => th.fill(0.0),
            }
            let target = &upper[i * n..(i + 1) * n];
            let start = th.clone();
            if !rigid.solve(&g, target, &mut th).converged {
                th.copy_from_slice(&start);
            }
            let st = solve_cables_elastic(robot, &g, target, &lr.at(i), &mut th, &mut t, opts);
            let s = &mut out.solution;
            s.theta.extend_from_slice(&th);
            s.converged.push(st.converged);
            s.iterations.push(st.iterations);
            s.residual.push(st.residual);
            s.within_limits.push(within_limits(robot, &th));
            out.tension.extend_from_slice(&t);
            out.feasible.push(feasible(&t, min_tension));
        }
        out
    });
    let mut all = ElasticSolution::default();
    for p in parts {
        all.solution.theta.extend(p.solution.theta);
        all.solution.converged.extend(p.solution.converged);
        all.solution.iterations.extend(p.solution.iterations);
        all.solution.residual.extend(p.solution.residual);
        all.solution.within_limits.extend(p.solution.within_limits);
        all.tension.extend(p.tension);
        all.feasible.extend(p.feasible);
    }
    Ok(all)
}

#[cfg(test)]
mod tests {
    use super::*;
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
            let mut sa = Statics::new(&r);
            sa.geometry(&a);
            let mut sb = Statics::new(&r);
            sb.geometry(&b);
            for j in 0..3 {
                let d = sub(sa.centre[j], sb.centre[j]);
                tau += r.mass[j] * (d[0] * loads.gravity[0] + d[1] * loads.gravity[1]) / (2.0 * h);
            }
            assert!((work - tau).abs() < 1e-9, "{k}: {work} vs {tau}");
        }
    }

    #[test]
    fn tip_position_from_statics_walk_equals_fk() {
        let r = Robot::paper();
        let th = [0.1, 0.2, -0.3];
        let mut s = Statics::new(&r);
        s.geometry(&th);
        let p = fk(&r, &th);
        assert!((s.tip[0] - p[0]).abs() < 1e-15 && (s.tip[1] - p[1]).abs() < 1e-15);
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
