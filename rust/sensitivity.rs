//! First-order sensitivities of the tip pose to the upper-cable lengths and to
//! the hole positions (issue 7), from analytic Jacobians.
//!
//! The cable solve keeps the upper-cable lengths at their targets:
//! `L_upper(theta; holes) = L0 + dl`. By the implicit function theorem
//!
//! ```text
//! dS/dl     =  J_pose · (dL_upper/dtheta)^-1                     (3, n)
//! dS/dholes = -J_pose · (dL_upper/dtheta)^-1 · dL_upper/dholes   (3, H)
//! ```
//!
//! with `J_pose = d[x, y, phi]/dtheta` (Eq. 1–3) and `dL_upper/dtheta` lower
//! triangular (cable `2i` crosses joints `0..=i`), so the inverse is one
//! triangular solve per pose row. `dL_upper/dholes` is analytic from the
//! segment geometry of `docs/model.md`: segment `k` of cable `c` is
//! `v = A_k - p`, `A_k = (link_before[k], 0) + Rot(theta_k)(q + (link_after[k], 0))`,
//! `p = holes[c, k, b]`, `q = holes[c, k+1, a]`, so with `e = v / |v|`:
//! `d|v|/dp = -e`, `d|v|/dq = Rot(theta_k)^T e`; the traversal of disk `k+1`,
//! `t = (thickness[k] + b.x - a.x, b.y - a.y)`, gives `d|t|/db = t/|t|`,
//! `d|t|/da = -t/|t|` (`a`, `b` its holes on faces a and b).
//! Lower cables are force controlled: their holes do not move the tip.
//!
//! The paper's per-disk hole-height error `dh_i` moves every hole of the upper
//! cable of pair `i` by `+dh_i` in y (and the lower one by `-dh_i`), so
//! `dS/ddh_i = -J_pose · (dL_upper/dtheta)^-1 [:, i] · sum_holes dL_{2i}/dy`.
//! Units: m/m for x, y; rad/m for phi.
//!
//! One output for an arm of either kind ([`sensitivities`]): `cable`,
//! `groups` (per coherent hole group) and `coords` (per coordinate of
//! [`Model::flat_holes`]); the planar closed forms above are the fast path
//! ([`closed_forms`]), the general sensitivities over the one model's chain
//! ([`general`]) serve every other arm.

use crate::cables::CableGeometry;
use crate::chain::{Chain, Numbers};
use crate::error::Result;
use crate::geometry::{pair, traversal_vector, ArmGeometry};
use crate::kinds::{Frame, Group, Vector, Visit};
use crate::kinematics::fk_jacobian;
use crate::model::{pair_slot, Model};
use crate::robot::PlanarView;
use crate::rows::{map_rows, rows_of};

/// Sensitivities of a batch of configurations (row-major, flat), the same
/// fields for an arm of either kind ([`sensitivities`]); `task` is the
/// kind's task width (planar `x, y, phi`; spatial `x, y, z`, then the
/// rotation as an angular velocity).
#[derive(Debug, Clone, PartialEq)]
pub struct Sensitivities {
    /// `(N, task, m_pos)`: d(task) / d(position-cable length) (m/m, rad/m).
    pub cable: Vec<f64>,
    /// `(N, task, G)`: d(task) / d(error of each coherent hole group of
    /// [`crate::model::Structure::hole_groups`], in their order; a planar
    /// arm's are the disks' hole heights, the paper's dh); `G = 0` where no
    /// group is coherent (a spatial arm's).
    pub groups: Vec<f64>,
    /// `(N, task, 3H)`: d(task) / d(every hole coordinate) in the order of
    /// [`Model::flat_holes`]; empty unless requested.
    pub coords: Vec<f64>,
    /// `(N,)`: the cable Jacobian has full rank (otherwise NaN rows).
    pub ok: Vec<bool>,
}

/// Gradient of the length of cable `c` with respect to every hole coordinate,
/// written (added) into `grad` (flat hole layout, length H); `cs` are the
/// `(cos, sin)` of the joint angles.
pub fn cable_hole_gradient(robot: &PlanarView, c: usize, cs: &[(f64, f64)], grad: &mut [f64]) {
    let z = 0.0;
    for (k, &(ct, st)) in cs.iter().enumerate().take(pair(c) + 1) {
        let ip = robot.hole_index(c, k, 1);
        let iq = robot.hole_index(c, k + 1, 0);
        let v = robot.segment(c, k, z).vector((ct, st));
        let s = v[0].hypot(v[1]);
        if s > 0.0 {
            // v = w + Rot u, w = (lb, 0) - p, u = q + (la, 0): dv/dp = -I, dv/dq = Rot
            let e = [v[0] / s, v[1] / s];
            grad[ip] -= e[0];
            grad[ip + 1] -= e[1];
            grad[iq] += ct * e[0] + st * e[1];
            grad[iq + 1] += -st * e[0] + ct * e[1];
        }
        let ib = robot.hole_index(c, k + 1, 1);
        let t = traversal_vector(
            robot.thickness[k],
            robot.hole(c, k + 1, 0),
            robot.hole(c, k + 1, 1),
            z,
            z,
        );
        let tl = t[0].hypot(t[1]);
        if tl > 0.0 {
            grad[ib] += t[0] / tl;
            grad[ib + 1] += t[1] / tl;
            grad[iq] -= t[0] / tl;
            grad[iq + 1] -= t[1] / tl;
        }
    }
}

/// Sum of the y-gradients of cable `c` over the holes it uses: the derivative
/// of its length with respect to a common shift of its hole heights.
fn height_derivative(robot: &PlanarView, c: usize, grad: &[f64]) -> f64 {
    let mut s = grad[robot.hole_index(c, 0, 1) + 1];
    for d in 1..=pair(c) + 1 {
        s += grad[robot.hole_index(c, d, 0) + 1] + grad[robot.hole_index(c, d, 1) + 1];
    }
    s
}

/// Sensitivities of one configuration `theta` (n). Writes `cable (3, n)`,
/// `pair (3, n)` and, when given, `holes (3, H)` (overwritten); returns false
/// (and NaN everywhere) when the upper-cable Jacobian is singular.
pub fn config_sensitivity(
    robot: &PlanarView,
    geom: &CableGeometry,
    theta: &[f64],
    cable: &mut [f64],
    pair_out: &mut [f64],
    holes: Option<&mut [f64]>,
) -> bool {
    let n = robot.n();
    let hl = robot.holes.len();
    let cs: Vec<(f64, f64)> = theta.iter().map(|t| (t.cos(), t.sin())).collect();
    let mut jp = vec![[0.0; 3]; n];
    fk_jacobian(robot, theta, &mut jp);
    // jc[i * n + k] = dL_{2i}/dtheta_k, lower triangular.
    let mut jc = vec![0.0; n * n];
    for i in 0..n {
        for k in 0..=i {
            jc[i * n + k] = geom.derivative(2 * i, k, cs[k]);
        }
    }
    let scale = jc.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    // a NaN diagonal counts as singular too
    let singular = (0..n).any(|k| {
        let d = jc[k * n + k].abs();
        d.is_nan() || d <= 1e-12 * scale.max(f64::MIN_POSITIVE)
    });
    if singular {
        cable.fill(f64::NAN);
        pair_out.fill(f64::NAN);
        if let Some(h) = holes {
            h.fill(f64::NAN);
        }
        return false;
    }
    // Row r of S = J_pose Jc^-1 solves x Jc = jp_r: back substitution
    // x_k = (b_k - sum_{i>k} x_i Jc[i][k]) / Jc[k][k].
    for r in 0..3 {
        let x = &mut cable[r * n..(r + 1) * n];
        for k in (0..n).rev() {
            let mut acc = jp[k][r];
            for i in k + 1..n {
                acc -= x[i] * jc[i * n + k];
            }
            x[k] = acc / jc[k * n + k];
        }
    }
    let want_holes = holes.is_some();
    let mut hs = holes;
    if let Some(h) = hs.as_deref_mut() {
        h.fill(0.0);
    }
    let mut grad = vec![0.0; hl];
    for i in 0..n {
        let c = 2 * i;
        grad.fill(0.0);
        cable_hole_gradient(robot, c, &cs, &mut grad);
        let dy = height_derivative(robot, c, &grad);
        for r in 0..3 {
            pair_out[r * n + i] = -cable[r * n + i] * dy;
        }
        if want_holes {
            let h = hs.as_deref_mut().unwrap();
            // Cable 2i uses only its own hole entries: copy them, scaled.
            let lo = robot.hole_index(c, 0, 0);
            let hi = robot.hole_index(c + 1, 0, 0);
            for r in 0..3 {
                let sr = -cable[r * n + i];
                for j in lo..hi {
                    h[r * hl + j] = sr * grad[j];
                }
            }
        }
    }
    true
}

/// The fast path of an arm, chosen once for the sensitivities and the RMS
/// amplification: a planar arm's closed forms ([`config_sensitivity`] on
/// its planar view), `None` for the general sensitivities ([`general`]).
pub fn closed_forms(model: &Model) -> Option<&PlanarView> {
    model.planar()
}

/// First-order sensitivities of an arm of either kind at `theta (N, n)`
/// (rad): `cable` and `groups` always, `coords` when asked
/// ([`Sensitivities`]). A planar arm runs its closed forms
/// ([`config_sensitivity`], its hole coordinates copied from the planar
/// layout into [`Model::flat_holes`]' order), any other arm the general
/// sensitivities ([`general`]). Threads: 0 = all cores.
pub fn sensitivities(
    model: &Model,
    theta: &[f64],
    coords: bool,
    threads: usize,
) -> Result<Sensitivities> {
    match closed_forms(model) {
        Some(robot) => planar(model, robot, theta, coords, threads),
        None => general(model, theta, coords, threads),
    }
}

/// The planar-layout index (`(2n, n+1, 2, 2)` flat) of every coordinate of
/// [`Model::flat_holes`] of a planar arm; `None` for a `z` (the planar
/// layout has none).
fn planar_slots(model: &Model, robot: &PlanarView) -> Vec<Option<usize>> {
    let mut slots = Vec::new();
    for (c, cable) in model.cables.iter().enumerate() {
        for i in 0..cable.holes.len() {
            let (d, f) = pair_slot(i);
            let k = robot.hole_index(c, d, f);
            slots.extend([Some(k), Some(k + 1), None]);
        }
    }
    slots
}

/// [`sensitivities`] of a planar arm by its closed forms
/// ([`config_sensitivity`]): `cable (N, 3, n)`, `groups (N, 3, n)` (per
/// disk's hole height) and, when asked, `coords (N, 3, 3H)` copied from the
/// planar layout (`z` columns 0, NaN on a singular row).
fn planar(
    model: &Model,
    robot: &PlanarView,
    theta: &[f64],
    coords: bool,
    threads: usize,
) -> Result<Sensitivities> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    let hl = robot.holes.len();
    let slots = if coords {
        planar_slots(model, robot)
    } else {
        Vec::new()
    };
    let fl = slots.len();
    let geom = CableGeometry::new(robot, None);
    let width = 6 * n + 1 + 3 * fl;
    let flat = map_rows(rows, width, threads, |i, out| {
        let (cable, rest) = out.split_at_mut(3 * n);
        let (pair_out, rest) = rest.split_at_mut(3 * n);
        let (flag, flat_out) = rest.split_at_mut(1);
        let mut holes = vec![0.0; if coords { 3 * hl } else { 0 }];
        let ok = config_sensitivity(
            robot,
            &geom,
            &theta[i * n..(i + 1) * n],
            cable,
            pair_out,
            coords.then_some(&mut holes[..]),
        );
        flag[0] = if ok { 1.0 } else { 0.0 };
        let z = if ok { 0.0 } else { f64::NAN };
        for r in 0..3 {
            for (j, slot) in slots.iter().enumerate() {
                flat_out[r * fl + j] = slot.map_or(z, |k| holes[r * hl + k]);
            }
        }
    });
    let mut out = Sensitivities {
        cable: Vec::with_capacity(rows * 3 * n),
        groups: Vec::with_capacity(rows * 3 * n),
        coords: Vec::with_capacity(rows * 3 * fl),
        ok: Vec::with_capacity(rows),
    };
    for row in flat.chunks_exact(width.max(1)) {
        out.cable.extend_from_slice(&row[..3 * n]);
        out.groups.extend_from_slice(&row[3 * n..6 * n]);
        out.ok.push(row[6 * n] != 0.0);
        out.coords.extend_from_slice(&row[6 * n + 1..]);
    }
    Ok(out)
}

/// Linear RMS of the tip position error |d(x, y)| (m) at one configuration
/// for independent uniform errors within `tol` (2n: per upper cable, then
/// per disk's hole height, m): `sqrt(sum_{i in x, y} sum_j S_ij^2 t_j^2 / 3)`;
/// infinite where the cable Jacobian is singular.
fn rms_one(
    robot: &PlanarView,
    geom: &CableGeometry,
    theta: &[f64],
    tol: &[f64],
    cable: &mut [f64],
    pair_out: &mut [f64],
) -> f64 {
    let n = robot.n();
    if !config_sensitivity(robot, geom, theta, cable, pair_out, None) {
        return f64::INFINITY;
    }
    let mut acc = 0.0;
    for r in 0..2 {
        for j in 0..n {
            acc += (cable[r * n + j] * tol[j]).powi(2) + (pair_out[r * n + j] * tol[n + j]).powi(2);
        }
    }
    (acc / 3.0).sqrt()
}

/// The linear RMS of the tip position error (m) over `theta (N, n)` and its
/// gradient `(N, n)` (m/rad) by central differences of `h` rad (the
/// objective of the least-sensitive configurations), for independent
/// uniform errors within `tol` (m): `sqrt(sum_{i in position rows} sum_j
/// S_ij^2 t_j^2 / 3)`, infinite where the cable Jacobian is singular. Either
/// kind, over the fast-path choice of [`sensitivities`] ([`closed_forms`]):
/// a planar arm's closed
/// forms ([`rms_one`], `tol` 2n: per upper cable, then per disk's hole
/// height) or the general sensitivities ([`general`], `tol` per position
/// cable, then per hole coordinate of [`Model::flat_holes`]).
pub fn rms_amplification(
    model: &Model,
    theta: &[f64],
    tol: &[f64],
    h: f64,
    threads: usize,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let n = model.n();
    let rows = rows_of("theta", theta, n)?;
    let fast = closed_forms(model);
    let width = match fast {
        Some(_) => 2 * n,
        None => model.position_cables().len() + model.flat_holes().len(),
    };
    crate::rows::rows_exactly("tol", tol, width, 1)?;
    if !(h > 0.0 && h.is_finite()) {
        return Err(crate::error::CdsmError::Option {
            name: "h".into(),
            problem: format!("must be a positive step (rad), got {h}"),
        });
    }
    let Some(robot) = fast else {
        return rms_general(model, theta, rows, tol, h, threads);
    };
    let geom = CableGeometry::new(robot, None);
    let flat = map_rows(rows, n + 1, threads, |i, out| {
        let (mut cable, mut pair_out) = (vec![0.0; 3 * n], vec![0.0; 3 * n]);
        let t = &theta[i * n..(i + 1) * n];
        out[0] = rms_one(robot, &geom, t, tol, &mut cable, &mut pair_out);
        let mut x = t.to_vec();
        for k in 0..n {
            x[k] = t[k] + h;
            let a = rms_one(robot, &geom, &x, tol, &mut cable, &mut pair_out);
            x[k] = t[k] - h;
            let b = rms_one(robot, &geom, &x, tol, &mut cable, &mut pair_out);
            x[k] = t[k];
            out[1 + k] = (a - b) / (2.0 * h);
        }
    });
    let mut v = Vec::with_capacity(rows);
    let mut g = Vec::with_capacity(rows * n);
    for row in flat.chunks_exact(n + 1) {
        v.push(row[0]);
        g.extend_from_slice(&row[1..]);
    }
    Ok((v, g))
}

/// [`rms_amplification`] over the general sensitivities: one batch of
/// [`general`] at every row, then at `+h` and at `-h` on each joint in turn
/// (`theta + 0.0`, `theta + h e_k`, `theta - h e_k`, the other joints moved by
/// `+0.0` and `-0.0`), the position rows (x, y, z) only.
fn rms_general(
    model: &Model,
    theta: &[f64],
    rows: usize,
    tol: &[f64],
    h: f64,
    threads: usize,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let n = model.n();
    let steps = 2 * n + 1;
    let m = model.position_cables().len();
    let hl = model.flat_holes().len();
    let task = model.kind.task();
    // rows per batch: the hole sensitivities of about 2^22 values at a time
    let chunk = ((1 << 22) / (steps * task * (m + hl)).max(1)).max(1);
    let sum_sq = |block: &[f64], width: usize, j: usize| {
        block[j] * block[j]
            + block[width + j] * block[width + j]
            + block[2 * width + j] * block[2 * width + j]
    };
    let mut v = Vec::with_capacity(rows);
    let mut g = Vec::with_capacity(rows * n);
    for part in theta[..rows * n].chunks(chunk * n) {
        let mut batch = Vec::with_capacity(part.len() * steps);
        for t in part.chunks_exact(n) {
            for s in 0..steps {
                for (j, &tj) in t.iter().enumerate() {
                    let d = match s {
                        0 => 0.0,
                        s if s <= n => {
                            if j + 1 == s {
                                h
                            } else {
                                0.0
                            }
                        }
                        s => {
                            if j + 1 + n == s {
                                -h
                            } else {
                                -0.0
                            }
                        }
                    };
                    batch.push(tj + d);
                }
            }
        }
        let sens = general(model, &batch, true, threads)?;
        let value = |r: usize| {
            if !sens.ok[r] {
                return f64::INFINITY;
            }
            let cable = &sens.cable[r * task * m..(r + 1) * task * m];
            let holes = &sens.coords[r * task * hl..(r + 1) * task * hl];
            let mut acc = 0.0;
            for (j, t) in tol[..m].iter().enumerate() {
                acc += sum_sq(cable, m, j) * (t * t);
            }
            for (j, t) in tol[m..].iter().enumerate() {
                acc += sum_sq(holes, hl, j) * (t * t);
            }
            (acc / 3.0).sqrt()
        };
        for i in 0..part.len() / n {
            let at = i * steps;
            v.push(value(at));
            for k in 0..n {
                g.push((value(at + 1 + k) - value(at + 1 + n + k)) / (2.0 * h));
            }
        }
    }
    Ok((v, g))
}

// ---------------------------------------------------------------------------
// Any arm: the one model's chain
// ---------------------------------------------------------------------------

/// Sensitivities of an arm of either kind over the one model's chain
/// (`docs/model.md`, "Sensitivities"): the position cables keep their
/// lengths, so `dtheta = (J_p^T J_p)^-1 J_p^T dL` (least squares with more
/// cables than joints, `J_p^-1` with as many), `dS/dL = J_task dtheta/dL` and
/// `dS/dholes = -dS/dL dL_p/dholes`. `J_task` is the task Jacobian (planar
/// `d[x, y, phi]/dtheta`; spatial the geometric Jacobian, angular velocity in
/// its last rows); every hole coordinate in the order of
/// [`Model::flat_holes`] (force cables' holes move nothing); a coherent hole
/// group's column is `sum coef dS/dcoord` over its coordinates.
pub fn general(
    model: &Model,
    theta: &[f64],
    with_holes: bool,
    threads: usize,
) -> Result<Sensitivities> {
    model.kind.visit(General {
        model,
        theta,
        with_holes,
        threads,
    })
}

/// [`general`] over the model's motion group.
struct General<'a> {
    model: &'a Model,
    theta: &'a [f64],
    with_holes: bool,
    threads: usize,
}

impl Visit for General<'_> {
    type Out = Result<Sensitivities>;
    fn visit<G: Group>(self) -> Self::Out {
        general_k::<G>(self.model, self.theta, self.with_holes, self.threads)
    }
}

fn general_k<G: Group>(
    model: &Model,
    theta: &[f64],
    with_holes: bool,
    threads: usize,
) -> Result<Sensitivities> {
    let n = model.n();
    let rows = rows_of("theta", theta, n)?;
    let pos = model.position_cables();
    let m = pos.len();
    let task = model.kind.task();
    let hl = model.flat_holes().len();
    let groups: Vec<_> = model
        .structure()
        .hole_groups
        .into_iter()
        .filter(|g| g.coherent)
        .collect();
    let ng = groups.len();
    // the hole coordinates are needed for the output or the groups
    let need_holes = with_holes || ng > 0;
    // where each cable's holes start in the flat layout
    let mut start = Vec::with_capacity(model.cables.len());
    let mut at = 0;
    for c in &model.cables {
        start.push(at);
        at += 3 * c.holes.len();
    }
    let width = task * m + task * ng + 1 + if with_holes { task * hl } else { 0 };
    let flat = map_rows(rows, width, threads, |i, out| {
        let mut chain = Chain::<f64, G::Frame<f64>>::new(model);
        let th = &theta[i * n..(i + 1) * n];
        chain.at(model, model, th);
        chain.world(model, model);
        chain.joints_world(model);
        let mut jt = vec![0.0; task * n];
        chain.geometric_jacobian(&mut jt);
        let mut jp = vec![0.0; m * n];
        for (k, &c) in pos.iter().enumerate() {
            chain.cable_jacobian_row(model, model, c, &mut jp[k * n..(k + 1) * n]);
        }
        // G = J_p^T J_p (n x n); X = G^-1 J_p^T (n x m)
        let mut g = vec![0.0; n * n];
        for a in 0..n {
            for b in 0..n {
                g[a * n + b] = (0..m).map(|k| jp[k * n + a] * jp[k * n + b]).sum();
            }
        }
        let (cable, rest) = out.split_at_mut(task * m);
        let (group_out, rest) = rest.split_at_mut(task * ng);
        let (flag, holes_out) = rest.split_at_mut(1);
        let mut x = vec![0.0; n * m];
        let mut ok = true;
        for k in 0..m {
            let rhs: Vec<f64> = (0..n).map(|a| jp[k * n + a]).collect();
            let mut col = vec![0.0; n];
            if !crate::lm::solve_spd(n, &g, &rhs, &mut col) {
                ok = false;
                break;
            }
            for a in 0..n {
                x[a * m + k] = col[a];
            }
        }
        if !ok {
            cable.fill(f64::NAN);
            group_out.fill(f64::NAN);
            holes_out.fill(f64::NAN);
            flag[0] = 0.0;
            return;
        }
        for r in 0..task {
            for k in 0..m {
                cable[r * m + k] = (0..n).map(|a| jt[r * n + a] * x[a * m + k]).sum();
            }
        }
        flag[0] = 1.0;
        if need_holes {
            let mut scratch = Vec::new();
            let holes = if with_holes {
                holes_out
            } else {
                scratch.resize(task * hl, 0.0);
                &mut scratch[..]
            };
            holes.fill(0.0);
            let mut grad = vec![0.0; hl];
            for (k, &c) in pos.iter().enumerate() {
                grad.fill(0.0);
                hole_gradient(&chain, model, c, &mut grad[start[c]..]);
                for r in 0..task {
                    let sr = -cable[r * m + k];
                    for (h, gj) in holes[r * hl..(r + 1) * hl].iter_mut().zip(&grad) {
                        *h += sr * gj;
                    }
                }
            }
            for r in 0..task {
                let row = &holes[r * hl..(r + 1) * hl];
                for (q, grp) in groups.iter().enumerate() {
                    group_out[r * ng + q] = grp
                        .coords
                        .iter()
                        .zip(&grp.coefs)
                        .map(|(&j, c)| c * row[j])
                        .sum();
                }
            }
        }
    });
    let mut out = Sensitivities {
        cable: Vec::with_capacity(rows * task * m),
        groups: Vec::with_capacity(rows * task * ng),
        coords: Vec::with_capacity(if with_holes { rows * task * hl } else { 0 }),
        ok: Vec::with_capacity(rows),
    };
    let gw = task * m + task * ng;
    for row in flat.chunks_exact(width.max(1)) {
        out.cable.extend_from_slice(&row[..task * m]);
        out.groups.extend_from_slice(&row[task * m..gw]);
        out.ok.push(row[gw] != 0.0);
        out.coords.extend_from_slice(&row[gw + 1..]);
    }
    Ok(out)
}

/// The gradient of cable `c`'s length with respect to its own holes'
/// coordinates (`[x, y, z]` per hole, in its order), into `grad`: segment `k`
/// `v = T_k a - b` gives `d|v|/da = R_k^T u`, `d|v|/db = -u`; the traversal
/// of disk `k`, `t = thickness e_x + b_k - a_k`, `d|t|/db_k = t/|t|`,
/// `d|t|/da_k = -t/|t|` (a planar arm's `z` derivative is 0).
fn hole_gradient<F: Frame<f64>>(chain: &Chain<f64, F>, model: &Model, c: usize, grad: &mut [f64]) {
    let nums = model;
    let add = |g: &mut [f64], i: usize, v: [f64; 3], s: f64| {
        for q in 0..3 {
            g[3 * i + q] += s * v[q];
        }
    };
    for k in 1..=model.cables[c].end {
        let a = F::V::of(nums.hole(c, 2 * k - 1));
        let b = F::V::of(nums.hole(c, 2 * k - 2));
        let v = chain.local[k - 1].point(a).sub(b);
        let l = v.norm();
        if l > 0.0 {
            let u = v.scale(1.0 / l);
            add(grad, 2 * k - 1, chain.local[k - 1].dir_inv(u).to3(), 1.0);
            add(grad, 2 * k - 2, u.to3(), -1.0);
        }
        let ha: [f64; 3] = nums.hole(c, 2 * k - 1);
        let hb: [f64; 3] = nums.hole(c, 2 * k);
        let t = [
            model.disks[k - 1].thickness + hb[0] - ha[0],
            hb[1] - ha[1],
            hb[2] - ha[2],
        ];
        let tl = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
        if tl > 0.0 {
            let e = [t[0] / tl, t[1] / tl, t[2] / tl];
            add(grad, 2 * k, e, 1.0);
            add(grad, 2 * k - 1, e, -1.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The planar kernel's output at one configuration: `cable (3, n)`,
    /// `pair (3, n)`, holes `(3, 2n, n+1, 2, 2)` in the planar layout.
    fn kernel(r: &PlanarView, th: &[f64]) -> (Vec<f64>, Vec<f64>, Vec<f64>, bool) {
        let n = r.n();
        let geom = CableGeometry::new(r, None);
        let mut cable = vec![0.0; 3 * n];
        let mut pair = vec![0.0; 3 * n];
        let mut holes = vec![0.0; 3 * r.holes.len()];
        let ok = config_sensitivity(r, &geom, th, &mut cable, &mut pair, Some(&mut holes));
        (cable, pair, holes, ok)
    }

    #[test]
    fn flat_coords_of_a_planar_arm_are_the_planar_layout_reindexed() {
        // the hole coordinates of the model (cable by cable: base face b,
        // then faces a and b of disks 1..=end; x, y, z) picked from the
        // planar layout (cable, disk, face, x/y), written out here
        let mut tilted = PlanarView::paper();
        for (k, v) in tilted.holes.iter_mut().enumerate() {
            *v += 1e-3 * ((k * 37 % 11) as f64 - 5.0) / 5.0;
        }
        let cases = [
            (PlanarView::paper(), vec![0.3, -0.2, 0.45, -0.5, 0.1, -0.05]),
            (tilted, vec![0.2, 0.3, -0.4, 0.0, 0.0, 0.0]),
            (robot8(), vec![0.1, -0.2, 0.3, 0.05, -0.15, 0.25, -0.3, 0.1]),
        ];
        for (r, th) in cases {
            let n = r.n();
            let m = Model::from_planar(&r);
            let s = sensitivities(&m, &th, true, 1).unwrap();
            let fl = m.flat_holes().len();
            assert_eq!(s.coords.len(), th.len() / n * 3 * fl);
            for (row, t) in th.chunks(n).enumerate() {
                let (cable, pair, holes, ok) = kernel(&r, t);
                assert!(ok && s.ok[row]);
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&s.cable[row * 3 * n..(row + 1) * 3 * n]), bits(&cable));
                assert_eq!(bits(&s.groups[row * 3 * n..(row + 1) * 3 * n]), bits(&pair));
                let planar = 2 * n * (n + 1) * 2 * 2;
                for q in 0..3 {
                    let got = &s.coords[(row * 3 + q) * fl..(row * 3 + q + 1) * fl];
                    let old = &holes[q * planar..(q + 1) * planar];
                    let mut k = 0;
                    for c in 0..2 * n {
                        let mut faces = vec![(0, 1)];
                        for d in 1..=c / 2 + 1 {
                            faces.extend([(d, 0), (d, 1)]);
                        }
                        for (d, f) in faces {
                            for xy in 0..2 {
                                let at = ((c * (n + 1) + d) * 2 + f) * 2 + xy;
                                assert_eq!(got[k + xy].to_bits(), old[at].to_bits());
                            }
                            assert_eq!(got[k + 2], 0.0, "z of cable {c}");
                            k += 3;
                        }
                    }
                    assert_eq!(k, fl);
                }
            }
        }
    }

    #[test]
    fn general_sensitivities_of_a_planar_arm_are_the_planar_ones() {
        let r = PlanarView::paper();
        let m = Model::from_planar(&r);
        let th = [0.3, -0.4, 0.2, -0.1, 0.25, 0.5];
        let a = general(&m, &th, true, 1).unwrap();
        let b = sensitivities(&m, &th, true, 1).unwrap();
        assert_eq!(a.ok, b.ok);
        assert_eq!(a.groups.len(), 2 * 3 * 3);
        for (x, y) in a.cable.iter().zip(&b.cable) {
            assert!((x - y).abs() < 1e-12, "{x} vs {y}");
        }
        // a disk's hole height: the coherent group's column
        for (x, y) in a.groups.iter().zip(&b.groups) {
            assert!((x - y).abs() < 1e-12, "{x} vs {y}");
        }
        assert_eq!(a.coords.len(), b.coords.len());
        for (x, y) in a.coords.iter().zip(&b.coords) {
            assert!((x - y).abs() < 1e-12, "{x} vs {y}");
        }
        // without the coordinates, the groups still
        let c = general(&m, &th, false, 1).unwrap();
        assert!(c.coords.is_empty());
        assert_eq!(c.groups, a.groups);
    }

    use crate::accuracy::deviation;
    use crate::solve::{CableMethod, SolveOptions};

    fn dev(r: &PlanarView, th: &[f64], dl: &[f64], holes: Option<&[f64]>) -> Vec<f64> {
        let (ds, sol) = deviation(
            &Model::from_planar(r),
            th,
            dl,
            holes,
            CableMethod::Newton,
            &SolveOptions {
                tol: 1e-16,
                max_iter: 400,
                enforce_limits: false,
            },
            1,
        )
        .unwrap();
        assert!(sol.converged.iter().all(|c| *c));
        ds
    }

    fn robot8() -> PlanarView {
        let mut t = String::from("name = \"t8\"\n");
        for i in 0..8 {
            t += &format!(
                "[[linkage]]\nlink_before = 0.02\nlink_after = 0.02\nthickness = 0.008\nhole_height = {}\njoint_limits = [-0.6, 0.6]\n",
                0.025 - 0.001 * i as f64
            );
        }
        PlanarView::from_toml(&t).unwrap()
    }

    fn check(r: &PlanarView, th: &[f64]) {
        let n = r.n();
        let hl = r.holes.len();
        let (cable, pair, holes, ok) = kernel(r, th);
        assert!(ok);
        let h = 1e-6;
        let zero = vec![0.0; n];
        for j in 0..n {
            let mut a = zero.clone();
            let mut b = zero.clone();
            a[j] = h;
            b[j] = -h;
            let (pa, pb) = (dev(r, th, &a, None), dev(r, th, &b, None));
            for q in 0..3 {
                let fd = (pa[q] - pb[q]) / (2.0 * h);
                let an = cable[q * n + j];
                assert!(
                    (fd - an).abs() < 1e-6 * (1.0 + an.abs()),
                    "cable {j} q{q}: {fd} vs {an}"
                );
            }
            // per-pair hole height
            let mut ha = vec![0.0; hl];
            let mut hb = vec![0.0; hl];
            let mut dh = zero.clone();
            dh[j] = h;
            r.hole_height_error_into(&dh, &mut ha);
            dh[j] = -h;
            r.hole_height_error_into(&dh, &mut hb);
            let (pa, pb) = (dev(r, th, &zero, Some(&ha)), dev(r, th, &zero, Some(&hb)));
            for q in 0..3 {
                let fd = (pa[q] - pb[q]) / (2.0 * h);
                let an = pair[q * n + j];
                assert!(
                    (fd - an).abs() < 1e-6 * (1.0 + an.abs()),
                    "dh {j} q{q}: {fd} vs {an}"
                );
            }
        }
        // every hole coordinate of every cable
        for idx in 0..hl {
            let mut ha = r.holes.clone();
            let mut hb = r.holes.clone();
            ha[idx] += h;
            hb[idx] -= h;
            let (pa, pb) = (dev(r, th, &zero, Some(&ha)), dev(r, th, &zero, Some(&hb)));
            for q in 0..3 {
                let fd = (pa[q] - pb[q]) / (2.0 * h);
                let an = holes[q * hl + idx];
                assert!(
                    (fd - an).abs() < 1e-6 * (1.0 + an.abs()),
                    "hole {idx} q{q}: {fd} vs {an}"
                );
            }
        }
    }

    #[test]
    fn matches_finite_differences_of_the_deviation_paper() {
        let r = PlanarView::paper();
        check(&r, &[0.3, -0.2, 0.45]);
        check(&r, &[-0.5, 0.1, -0.05]);
    }

    #[test]
    fn matches_finite_differences_of_the_deviation_tilted_holes() {
        // non-straight holes: perturb every hole so all terms matter
        let mut r = PlanarView::paper();
        for (k, v) in r.holes.iter_mut().enumerate() {
            *v += 1e-3 * ((k * 37 % 11) as f64 - 5.0) / 5.0;
        }
        check(&r, &[0.2, 0.3, -0.4]);
    }

    #[test]
    fn matches_finite_differences_of_the_deviation_8_joints() {
        let r = robot8();
        check(&r, &[0.1, -0.2, 0.3, 0.05, -0.15, 0.25, -0.3, 0.1]);
    }

    #[test]
    fn straight_arm_has_no_first_order_x() {
        // Fig. 12: at theta = 0 the tip loses X to first order.
        let s = sensitivities(
            &Model::from_planar(&PlanarView::paper()),
            &[0.0; 3],
            false,
            1,
        )
        .unwrap();
        assert!(s.cable[0..3].iter().all(|v| v.abs() < 1e-15));
        // Table 3, point 1: -1 mm on cable 1 gives dY = 2.43 mm (solve); the
        // linear picture says 2.53 mm: 4 % off at the singular state.
        let lin = -s.cable[3];
        assert!(lin > 2.4 && lin < 2.6, "{lin}");
    }
}
