//! The real arm as the nominal model plus candidate unmodelled effects: the
//! parametric "plant" that the sim-to-real diagnosis fits to measurements and
//! that the virtual prototype uses to make data. All-zero parameters give the
//! nominal model exactly. SI units (m, rad, N).
//!
//! The controller commands the nominal model's upper-cable lengths
//! `L_cmd = L_nom(theta_cmd) + dL`. The plant realises
//! `L_real = L_ref + (1 + s)(L_cmd − L_ref) + o_i` (`L_ref`: straight-pose
//! lengths; `s`: `actuation_scale`; `o`: `cable_offset`), on an arm whose hole
//! heights (`hole_height`, per pair) and link lengths (`link_length`: base to
//! joint 1, then joint `i` to disk `i`) differ from the nominal, whose cables
//! stretch (`cable_elasticity`: compliance `1/(E A)` in 1/N, tensions from
//! [`crate::statics`]) and bear on the wall of oversized holes
//! (`hole_clearance` `c`: the holes on both sides of joint `k` shift by
//! `c · tanh(theta_k / THETA_SMOOTH)` toward the concave side). The tip is then
//! offset in the end frame (`tip_offset`) and seen in a rotated, translated
//! instrument frame (`frame_misalignment`: angle, x, y).

use crate::batch::{rows_of, split_rows};
use crate::cables::CableGeometry;
use crate::error::{CdsmError, Result};
use crate::kinematics::fk;
use crate::robot::Robot;
use crate::solve::{
    levenberg_marquardt, normal_equations, solve_spd, CableMethod, CableSolver, SolveOptions,
};
use crate::statics::{Loads, Statics};

/// Width of the clearance's smooth sign (rad): `tanh(theta / THETA_SMOOTH)`.
pub const THETA_SMOOTH: f64 = 0.01;

/// The effects, in the order of the parameter vector.
pub const EFFECTS: [&str; 8] = [
    "actuation_scale",
    "cable_offset",
    "hole_height",
    "link_length",
    "cable_elasticity",
    "hole_clearance",
    "frame_misalignment",
    "tip_offset",
];

/// Number of parameters of each effect for an `n`-joint robot.
pub fn effect_sizes(n: usize) -> [usize; 8] {
    [1, n, n, n + 1, 1, 1, 3, 2]
}

/// Offset of each effect's parameters in the flat parameter vector, and the total.
pub fn effect_offsets(n: usize) -> ([usize; 8], usize) {
    let sizes = effect_sizes(n);
    let mut off = [0; 8];
    let mut total = 0;
    for (o, s) in off.iter_mut().zip(sizes) {
        *o = total;
        total += s;
    }
    (off, total)
}

/// A plant: the nominal robot, the perturbed geometry and the effect values.
pub struct Plant<'a> {
    nominal: &'a Robot,
    arm: Robot,
    geom: CableGeometry,
    l_ref: Vec<f64>,
    scale: f64,
    offset: Vec<f64>,
    compliance: f64,
    clearance: f64,
    frame: [f64; 3],
    tip: [f64; 2],
}

impl<'a> Plant<'a> {
    /// Builds the plant of `nominal` with the flat parameters `p` (see [`EFFECTS`]).
    pub fn new(nominal: &'a Robot, p: &[f64]) -> Result<Plant<'a>> {
        let n = nominal.n();
        let (off, total) = effect_offsets(n);
        if p.len() != total {
            return Err(CdsmError::Shape {
                name: "params".into(),
                expected: format!("({total},)"),
                got: format!("({},)", p.len()),
            });
        }
        crate::error::check_finite("params", p)?;
        let mut arm = nominal.clone();
        let mut holes = vec![0.0; arm.holes.len()];
        nominal.hole_height_error_into(&p[off[2]..off[2] + n], &mut holes);
        arm.holes = holes;
        arm.link_before[0] += p[off[3]];
        for i in 0..n {
            arm.link_after[i] += p[off[3] + 1 + i];
        }
        arm.validate().map_err(|e| CdsmError::Option {
            name: "params".into(),
            problem: format!("non-physical plant: {e}"),
        })?;
        if p[off[4]] < 0.0 || p[off[5]] < 0.0 {
            return Err(CdsmError::Option {
                name: "params".into(),
                problem: "cable_elasticity and hole_clearance must be >= 0".into(),
            });
        }
        let nominal_geom = CableGeometry::new(nominal, None);
        let mut l_ref = vec![0.0; n];
        nominal_geom.upper_lengths(&vec![(1.0, 0.0); n], &mut l_ref);
        let geom = CableGeometry::new(&arm, None);
        Ok(Plant {
            nominal,
            geom,
            l_ref,
            scale: p[off[0]],
            offset: p[off[1]..off[1] + n].to_vec(),
            compliance: p[off[4]],
            clearance: p[off[5]],
            frame: [p[off[6]], p[off[6] + 1], p[off[6] + 2]],
            tip: [p[off[7]], p[off[7] + 1]],
            arm,
        })
    }

    /// The perturbed arm (hole heights and link lengths applied).
    pub fn arm(&self) -> &Robot {
        &self.arm
    }

    /// Upper-cable lengths the actuators realise for commanded lengths `cmd` (m).
    pub fn realised(&self, cmd: &[f64], out: &mut [f64]) {
        for i in 0..cmd.len() {
            out[i] = self.l_ref[i] + (1.0 + self.scale) * (cmd[i] - self.l_ref[i]) + self.offset[i];
        }
    }

    /// Geometric upper-cable lengths of the arm at `theta`, with hole clearance (m).
    pub fn arm_lengths(&self, theta: &[f64], out: &mut [f64]) {
        let r = &self.arm;
        let shift = |k: usize| self.clearance * (theta[k] / THETA_SMOOTH).tanh();
        for (i, o) in out.iter_mut().enumerate() {
            let c = 2 * i;
            let mut len = 0.0;
            for (k, tk) in theta.iter().enumerate().take(i + 1) {
                let d = shift(k);
                let p = r.hole(c, k, 1);
                let q = r.hole(c, k + 1, 0);
                let (s, co) = tk.sin_cos();
                let u = [q[0] + r.link_after[k], q[1] + d];
                let ax = r.link_before[k] + co * u[0] - s * u[1] - p[0];
                let ay = s * u[0] + co * u[1] - (p[1] + d);
                len += ax.hypot(ay);
                // traversal of disk k+1: face a shifted with joint k, face b with joint k+1 (if crossed)
                let b = r.hole(c, k + 1, 1);
                let d_next = if k < i { shift(k + 1) } else { 0.0 };
                let dx = r.thickness[k] + b[0] - q[0];
                let dy = (b[1] + d_next) - (q[1] + d);
                len += dx.hypot(dy);
            }
            *o = len;
        }
    }

    /// Joint angles the arm settles at for commanded upper lengths `cmd` (m);
    /// `theta` holds the seed on entry. `statics` is the arm's statics.
    pub fn settle(
        &self,
        cmd: &[f64],
        theta: &mut [f64],
        statics: &mut Statics,
        opts: &SolveOptions,
    ) -> bool {
        let n = cmd.len();
        let mut real = vec![0.0; n];
        self.realised(cmd, &mut real);
        // rigid, no clearance: the closed form on the perturbed geometry
        let mut rigid = CableSolver::new(&self.arm, CableMethod::Auto, *opts);
        let start = theta.to_vec();
        let ok = rigid.solve(&self.geom, &real, theta).converged;
        if self.compliance == 0.0 && self.clearance == 0.0 {
            return ok;
        }
        if !ok {
            theta.copy_from_slice(&start);
        }
        let route = self.arm.cable.routing_length;
        let lower = self.arm.lower_tension.clone();
        let loads = Loads {
            lower: &lower,
            tip_wrench: [0.0; 3],
            gravity: [0.0; 2],
        };
        let (mut lg, mut t) = (vec![0.0; n], vec![0.0; n]);
        let (mut jac, mut a, mut g) = (vec![0.0; n * n], vec![0.0; n * n], vec![0.0; n]);
        let (mut rp, mut rm, mut th) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let st = std::cell::RefCell::new(statics);
        let residual = |x: &[f64], r: &mut [f64], lg: &mut [f64], t: &mut [f64]| {
            self.arm_lengths(x, lg);
            if self.compliance > 0.0 {
                st.borrow_mut().tensions(x, &loads, t);
            } else {
                t.fill(0.0);
            }
            for i in 0..n {
                r[i] = (real[i] + route) * (1.0 + self.compliance * t[i]) - route - lg[i];
            }
        };
        let status = levenberg_marquardt(
            &self.arm,
            theta,
            n,
            opts,
            |x, r| residual(x, r, &mut lg, &mut t),
            |x, r, lambda, delta| {
                // Jacobian of the residual by central differences (the clearance's
                // tanh and the statics make it awkward analytically)
                let h = 1e-7;
                let (mut lg2, mut t2) = (vec![0.0; n], vec![0.0; n]);
                for k in 0..n {
                    th.copy_from_slice(x);
                    th[k] = x[k] + h;
                    residual(&th, &mut rp, &mut lg2, &mut t2);
                    th[k] = x[k] - h;
                    residual(&th, &mut rm, &mut lg2, &mut t2);
                    for i in 0..n {
                        // LM solves for r -> 0 with r = target - model: J = -dr/dtheta
                        jac[i * n + k] = -(rp[i] - rm[i]) / (2.0 * h);
                    }
                }
                normal_equations(n, &jac, r, lambda, &mut a, &mut g);
                solve_spd(n, &a, &g, delta) && delta.iter().all(|d| d.is_finite())
            },
        );
        status.converged
    }

    /// Tip pose of the arm at `theta` seen by the instrument: `[x, y, phi]`.
    pub fn observe(&self, theta: &[f64]) -> [f64; 3] {
        let p = fk(&self.arm, theta);
        let (s, c) = p[2].sin_cos();
        let tip = [
            p[0] + c * self.tip[0] - s * self.tip[1],
            p[1] + s * self.tip[0] + c * self.tip[1],
        ];
        let (sa, ca) = self.frame[0].sin_cos();
        [
            ca * tip[0] - sa * tip[1] + self.frame[1],
            sa * tip[0] + ca * tip[1] + self.frame[2],
            p[2] + self.frame[0],
        ]
    }

    /// The nominal robot the controller believes in.
    pub fn nominal(&self) -> &Robot {
        self.nominal
    }
}

/// What a measurement row observes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Observation {
    /// The tip pose in the instrument frame.
    Absolute,
    /// The tip displacement caused by `dL` (same command with and without it).
    Displacement,
}

/// Predictions of a batch: observations `(K, N, 3)`, converged `(K, N)`, and
/// the joint angles the arm settles at with `dL` applied `(K, N, n)` (rad).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Predictions {
    pub observation: Vec<f64>,
    pub converged: Vec<bool>,
    pub theta: Vec<f64>,
}

/// Predicted observations for `K` parameter sets (`params (K, P)`) and `N`
/// rows (`theta_cmd (N, n)`, `dl (N, n)`); see [`Predictions`]. Work is split
/// over `K x N` in scoped threads.
pub fn predict(
    robot: &Robot,
    params: &[f64],
    theta_cmd: &[f64],
    dl: &[f64],
    kind: Observation,
    opts: &SolveOptions,
    threads: usize,
) -> Result<Predictions> {
    let n = robot.n();
    let (_, total) = effect_offsets(n);
    let k = rows_of("params", params, total)?;
    let rows = rows_of("theta_cmd", theta_cmd, n)?;
    crate::batch::rows_exactly("dl", dl, n, rows)?;
    let plants: Vec<Plant> = (0..k)
        .map(|j| Plant::new(robot, &params[j * total..(j + 1) * total]))
        .collect::<Result<_>>()?;
    let nominal = CableGeometry::new(robot, None);
    let parts = split_rows(k * rows, threads, |range| {
        let mut out = Predictions::default();
        let mut cs = vec![(1.0, 0.0); n];
        let (mut cmd, mut th) = (vec![0.0; n], vec![0.0; n]);
        let mut statics: Vec<Option<Statics>> = (0..k).map(|_| None).collect();
        for idx in range {
            let (j, i) = (idx / rows, idx % rows);
            let plant = &plants[j];
            let st = statics[j].get_or_insert_with(|| Statics::new(plant.arm()));
            let t0 = &theta_cmd[i * n..(i + 1) * n];
            for (c, t) in cs.iter_mut().zip(t0) {
                *c = (t.cos(), t.sin());
            }
            nominal.upper_lengths(&cs, &mut cmd);
            let mut pose_at = |extra: Option<&[f64]>, th: &mut [f64]| {
                let mut l = cmd.clone();
                if let Some(e) = extra {
                    for (a, b) in l.iter_mut().zip(e) {
                        *a += b;
                    }
                }
                th.copy_from_slice(t0);
                let ok = plant.settle(&l, th, st, opts);
                (ok, plant.observe(th))
            };
            let d = &dl[i * n..(i + 1) * n];
            let (ok, obs) = match kind {
                Observation::Absolute => pose_at(Some(d), &mut th),
                Observation::Displacement => {
                    // both poses seen by the instrument: its translation cancels,
                    // its rotation stays
                    let (ok0, p0) = pose_at(None, &mut th);
                    let (ok1, p1) = pose_at(Some(d), &mut th);
                    (ok0 && ok1, [p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]])
                }
            };
            out.observation
                .extend_from_slice(&if ok { obs } else { [f64::NAN; 3] });
            out.converged.push(ok);
            out.theta
                .extend(th.iter().map(|t| if ok { *t } else { f64::NAN }));
        }
        out
    });
    let mut all = Predictions::default();
    for p in parts {
        all.observation.extend(p.observation);
        all.converged.extend(p.converged);
        all.theta.extend(p.theta);
    }
    Ok(all)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn zeros(r: &Robot) -> Vec<f64> {
        vec![0.0; effect_offsets(r.n()).1]
    }

    #[test]
    fn zero_parameters_are_the_nominal_model() {
        let r = Robot::paper();
        let th = [0.2, -0.3, 0.25, -0.1, 0.0, 0.3];
        let dl = [-1e-3, 0.0, 0.0, 0.0, 5e-4, 0.0];
        let o = SolveOptions::default();
        let Predictions {
            observation: abs,
            converged: ok,
            ..
        } = predict(&r, &zeros(&r), &th, &dl, Observation::Absolute, &o, 1).unwrap();
        assert!(ok.iter().all(|x| *x));
        let (dev, _) =
            crate::accuracy::deviation(&r, &th[..3], &dl[..3], None, CableMethod::Auto, &o, 1)
                .unwrap();
        let p0 = fk(&r, &th[..3]);
        for q in 0..3 {
            assert!((abs[q] - (p0[q] + dev[q])).abs() < 1e-12);
        }
    }

    #[test]
    fn clearance_and_elasticity_paths_agree_with_the_rigid_one_at_zero() {
        // tiny clearance / compliance move the answer continuously from the rigid one
        let r = Robot::paper();
        let (off, _) = effect_offsets(3);
        let th = [0.2, -0.3, 0.25];
        let dl = [0.0; 3];
        let o = SolveOptions::default();
        let a = predict(&r, &zeros(&r), &th, &dl, Observation::Absolute, &o, 1)
            .unwrap()
            .observation;
        for idx in [off[4], off[5]] {
            let mut p = zeros(&r);
            p[idx] = 1e-12;
            let Predictions {
                observation: b,
                converged: ok,
                ..
            } = predict(&r, &p, &th, &dl, Observation::Absolute, &o, 1).unwrap();
            assert!(ok[0]);
            for q in 0..3 {
                assert!((a[q] - b[q]).abs() < 1e-9, "{idx}: {a:?} {b:?}");
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
        let th = [0.2, -0.3, 0.25];
        let dl = [-1e-3, 0.0, 0.0];
        let o = SolveOptions::default();
        let a = predict(&r, &zeros(&r), &th, &dl, Observation::Displacement, &o, 1)
            .unwrap()
            .observation;
        let b = predict(&r, &p, &th, &dl, Observation::Displacement, &o, 1)
            .unwrap()
            .observation;
        for q in 0..3 {
            assert!((a[q] - b[q]).abs() < 1e-15);
        }
    }

    #[test]
    fn clearance_shortens_nothing_at_the_straight_pose() {
        let r = Robot::paper();
        let (off, _) = effect_offsets(3);
        let mut p = zeros(&r);
        p[off[5]] = 1e-4;
        let plant = Plant::new(&r, &p).unwrap();
        let mut l = [0.0; 3];
        plant.arm_lengths(&[0.0; 3], &mut l);
        for (i, li) in l.iter().enumerate() {
            assert!((li - 0.076 * (i + 1) as f64).abs() < 1e-15);
        }
    }
}
