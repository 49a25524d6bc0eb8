//! Compensation: the upper-cable commands that put the tip of a fitted plant
//! ([`crate::plant`]) on target poses. SI units (m, rad).
//!
//! For each target the shared solver ([`crate::lm`]) finds the lengths the
//! screws must deliver, `r`, such that the plant's observation meets the
//! target on the weighted coordinates (`w = [1, 1, L]` with `L` the straight
//! arm length when the attitude is a target, `[1, 1, 0]` otherwise); the
//! Jacobian is exact (implicit function theorem through the settle). The
//! targets are then run in order through the backlash: a cable whose
//! delivered length must grow is commanded `r + b`, one that must shrink
//! `r - b`, one that stays is not moved.

use crate::batch::{rows_exactly, split_rows};
use crate::cables::CableGeometry;
use crate::error::{CdsmError, Result};
use crate::lm::{self, Lm, Problem, Step, Workspace};
use crate::plant::{Plant, SettleWork};
use crate::robot::Robot;
use crate::solve::SolveOptions;

/// Appends the command that makes the screws deliver `delivered` (m) from
/// the delivered lengths `state` (updated) through dead bands of half-width
/// `b`: a cable whose delivered length must grow is commanded `r + b`, one
/// that must shrink `r - b`, one that stays is not moved.
pub fn command_through_backlash(
    delivered: &[f64],
    b: &[f64],
    state: &mut [f64],
    out: &mut Vec<f64>,
) {
    for i in 0..delivered.len() {
        let r = delivered[i];
        out.push(if r > state[i] {
            r + b[i]
        } else if r < state[i] {
            r - b[i]
        } else {
            state[i]
        });
        state[i] = r;
    }
}

/// The compensated commands of `N` targets.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Compensation {
    /// `(N, m)` length commands of the commanded cables (m), in the targets' order.
    pub command: Vec<f64>,
    /// `(N, m)` the nominal commands at `theta_cmd` (m).
    pub nominal: Vec<f64>,
    /// `(N,)` the solve met the target within `tol`.
    pub converged: Vec<bool>,
    /// `(N,)` largest weighted residual at the answer (m).
    pub residual: Vec<f64>,
    /// `(N, n)` the configuration the plant settles at (rad).
    pub theta: Vec<f64>,
    /// `(N, width)` what the instrument is predicted to see with the commands
    /// (planar `[x, y, phi]`, spatial `[x, y, z, rx, ry, rz]`).
    pub seen: Vec<f64>,
    /// `(N, width)` the same with the nominal commands (run through the backlash too).
    pub seen_nominal: Vec<f64>,
}

/// One target as a problem of the shared solver; the unknowns are the
/// delivered lengths.
struct Target<'a> {
    plant: &'a Plant<'a>,
    work: SettleWork<'a>,
    target: [f64; 3],
    weights: [f64; 3],
    active: Vec<usize>,
    seed: &'a [f64],
    real: Vec<f64>,
    theta: Vec<f64>,
    dseen: Vec<f64>,
}

impl Target<'_> {
    fn settle(&mut self, r: &[f64]) -> bool {
        self.plant.actuate(r, &mut self.real);
        self.theta.copy_from_slice(self.seed);
        self.plant
            .settle(&self.real, &mut self.theta, &mut self.work)
    }
}

impl Problem for Target<'_> {
    fn dims(&self) -> (usize, usize) {
        (self.active.len(), self.seed.len())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        if !self.settle(x) {
            return false;
        }
        let seen = self.plant.observe(&self.theta);
        for (row, &c) in self.active.iter().enumerate() {
            r[row] = self.weights[c] * (seen[c] - self.target[c]);
        }
        if let Some(j) = jac {
            let n = x.len();
            let (real, theta) = (self.real.clone(), self.theta.clone());
            if !self
                .plant
                .observe_linear(&real, &theta, &mut self.dseen, &mut self.work)
            {
                return false;
            }
            let gain = self.plant.gain();
            for (row, &c) in self.active.iter().enumerate() {
                for k in 0..n {
                    j[row * n + k] = self.weights[c] * self.dseen[c * n + k] * gain;
                }
            }
        }
        r.iter().all(|v| v.is_finite())
    }
}

/// Compensated commands for `targets (N, 3)` (m, m, rad) on the plant `p`
/// (flat), from the nominal configurations `theta_cmd (N, n)` (the nominal
/// pose IK of each target, rad), matching the coordinates with non-zero
/// `weights` (`[1, 1, L]` or `[1, 1, 0]`). `start`: the backlash state (the
/// delivered lengths, m) before the first target; `None`: the straight pose.
#[allow(clippy::too_many_arguments)]
pub fn compensate(
    robot: &Robot,
    p: &[f64],
    theta_cmd: &[f64],
    targets: &[f64],
    weights: [f64; 3],
    start: Option<&[f64]>,
    opts: &SolveOptions,
    tol: f64,
    max_iter: u32,
    threads: usize,
) -> Result<Compensation> {
    let n = robot.n();
    let rows = crate::batch::rows_of("targets", targets, 3)?;
    rows_exactly("theta_cmd", theta_cmd, n, rows)?;
    crate::error::check_finite("weights", &weights)?;
    let active: Vec<usize> = (0..3).filter(|c| weights[*c] != 0.0).collect();
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
    let plant = Plant::new(robot, p)?;
    if let Some(s) = start {
        rows_exactly("start", s, n, 1)?;
    }
    let geom = CableGeometry::new(robot, None);
    let mut nominal = vec![0.0; rows * n];
    let mut cs = vec![(1.0, 0.0); n];
    for i in 0..rows {
        for (c, t) in cs.iter_mut().zip(&theta_cmd[i * n..(i + 1) * n]) {
            let (s, co) = t.sin_cos();
            *c = (co, s);
        }
        geom.upper_lengths(&cs, &mut nominal[i * n..(i + 1) * n]);
    }
    let lm = Lm::equations(Step::levenberg(active.len(), n), tol, max_iter);
    // every target's delivered lengths (independent of the order)
    let parts = split_rows(rows, threads, |range| {
        let mut ws = Workspace::default();
        let mut out = Vec::with_capacity(range.len());
        for i in range {
            let seed = &theta_cmd[i * n..(i + 1) * n];
            let mut prob = Target {
                plant: &plant,
                work: SettleWork::new(&plant, *opts),
                target: [targets[3 * i], targets[3 * i + 1], targets[3 * i + 2]],
                weights,
                active: active.clone(),
                seed,
                real: vec![0.0; n],
                theta: vec![0.0; n],
                dseen: vec![0.0; 3 * n],
            };
            let mut r = nominal[i * n..(i + 1) * n].to_vec();
            let st = lm::solve(&mut prob, &mut r, &lm, &mut ws);
            let settled = prob.settle(&r);
            let seen = if settled {
                plant.observe(&prob.theta)
            } else {
                [f64::NAN; 3]
            };
            out.push((r, st, settled, prob.theta.clone(), seen));
        }
        out
    });
    let mut res = Compensation {
        nominal: nominal.clone(),
        ..Compensation::default()
    };
    // in order through the backlash
    let mut state = start.map_or_else(|| plant.reference_lengths().to_vec(), |s| s.to_vec());
    for (r, st, settled, theta, seen) in parts.into_iter().flatten() {
        command_through_backlash(&r, plant.backlash(), &mut state, &mut res.command);
        res.converged.push(st.converged && settled);
        res.residual.push(st.residual);
        res.theta.extend_from_slice(&theta);
        res.seen.extend_from_slice(&seen);
    }
    // the nominal commands through the same plant, in order
    let mut state = start.map_or_else(|| plant.reference_lengths().to_vec(), |s| s.to_vec());
    let mut work = SettleWork::new(&plant, *opts);
    let mut real = vec![0.0; n];
    let mut th = vec![0.0; n];
    for i in 0..rows {
        plant.realise_one(&nominal[i * n..(i + 1) * n], &mut state, &mut real);
        th.copy_from_slice(&theta_cmd[i * n..(i + 1) * n]);
        let seen = if plant.settle(&real, &mut th, &mut work) {
            plant.observe(&th)
        } else {
            [f64::NAN; 3]
        };
        res.seen_nominal.extend_from_slice(&seen);
    }
    Ok(res)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ArmGeometry;
    use crate::plant::effect_offsets;

    #[test]
    fn compensated_commands_put_the_plant_on_target() {
        let r = Robot::paper();
        let (off, total) = effect_offsets(3);
        let mut p = vec![0.0; total];
        p[off[0]] = 0.03;
        p[off[2]] = 3e-4;
        p[off[8]] = 5e-5;
        p[off[5]] = 1e-4;
        let theta = [0.2, -0.3, 0.25, -0.1, 0.2, 0.1];
        let mut targets = Vec::new();
        for t in theta.chunks(3) {
            targets.extend_from_slice(&r.fk(t));
        }
        let l = r.straight_length();
        let res = compensate(
            &r,
            &p,
            &theta,
            &targets,
            [1.0, 1.0, l],
            None,
            &SolveOptions::default(),
            1e-10,
            40,
            1,
        )
        .unwrap();
        for i in 0..2 {
            assert!(res.converged[i], "{res:?}");
            for c in 0..3 {
                let w = if c == 2 { l } else { 1.0 };
                assert!((res.seen[3 * i + c] - targets[3 * i + c]).abs() * w < 1e-9);
                // without compensation the plant misses by far more
            }
            let miss = (res.seen_nominal[3 * i] - targets[3 * i])
                .hypot(res.seen_nominal[3 * i + 1] - targets[3 * i + 1]);
            assert!(miss > 1e-4, "{miss}");
        }
    }
}
