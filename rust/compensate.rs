//! Compensation: the position-cable commands that put the tip of a fitted
//! plant ([`crate::plant`]) on target poses, written once over the arm's
//! kind. SI units (m, rad).
//!
//! For each target the shared solver ([`crate::lm`]) finds the lengths the
//! screws must deliver, `r`, such that the plant's observation meets the
//! target on the weighted coordinates (planar `[x, y, phi]`, spatial `[x, y,
//! z, rx, ry, rz]`; a weight of 0 leaves a coordinate free; an attitude
//! counts as the tip displacement it causes, its weight the straight arm's
//! length); the Jacobian is exact (implicit function theorem through the
//! settle). The targets are then run in order through the backlash: a cable
//! whose delivered length must grow is commanded `r + b`, one that must
//! shrink `r - b`, one that stays is not moved. With friction in the holes
//! every target is solved in the sliding state the nominal motion through
//! the targets in order leaves there (`docs/model.md`, "Compensation with
//! friction"), so a target approached from the other side gets other
//! commands.

use crate::chain::Chain;
use crate::error::{CdsmError, Result};
use crate::kinds::{Frame, Group, Visit};
use crate::lm::{self, Lm, Problem, Step, Workspace};
use crate::model::Model;
use crate::plant::{position_lengths, Plant, SettleWork};
use crate::rows::{rows_exactly, split_rows};
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
struct Target<'a, G: Group> {
    plant: &'a Plant<'a, G>,
    work: SettleWork<'a, G>,
    chain: Chain<f64, G::Frame<f64>>,
    target: &'a [f64],
    weights: &'a [f64],
    active: &'a [usize],
    seed: &'a [f64],
    real: Vec<f64>,
    theta: Vec<f64>,
    seen: Vec<f64>,
    dseen: Vec<f64>,
}

impl<G: Group> Target<'_, G> {
    fn settle(&mut self, r: &[f64]) -> bool {
        self.plant.actuate(r, &mut self.real);
        self.theta.copy_from_slice(self.seed);
        self.plant
            .settle(&self.real, &mut self.theta, &mut self.work)
    }
}

impl<G: Group> Problem for Target<'_, G> {
    fn dims(&self) -> (usize, usize) {
        (self.active.len(), self.real.len())
    }

    fn eval(&mut self, x: &[f64], r: &mut [f64], jac: Option<&mut [f64]>) -> bool {
        if !self.settle(x) {
            return false;
        }
        self.plant
            .observe(&self.theta, &mut self.chain, &mut self.seen);
        for (row, &c) in self.active.iter().enumerate() {
            r[row] = self.weights[c] * (self.seen[c] - self.target[c]);
        }
        if let Some(j) = jac {
            let m = x.len();
            let (real, theta) = (self.real.clone(), self.theta.clone());
            if !self
                .plant
                .observe_linear(&real, &theta, &mut self.dseen, &mut self.work)
            {
                return false;
            }
            let gain = self.plant.gain();
            for (row, &c) in self.active.iter().enumerate() {
                for k in 0..m {
                    j[row * m + k] = self.weights[c] * self.dseen[c * m + k] * gain;
                }
            }
        }
        r.iter().all(|v| v.is_finite())
    }
}

/// Compensated commands for `targets (N, TASK)` (m, rad: planar `[x, y,
/// phi]`, spatial `[x, y, z, rx, ry, rz]`) on the plant `p` (flat), from the
/// nominal configurations `theta_cmd (N, n)` (the nominal IK of each target,
/// rad), matching the coordinates with non-zero `weights` (`TASK` values,
/// each `>= 0`). `start`: the backlash state (the delivered lengths, m)
/// before the first target; `None`: the straight pose.
#[allow(clippy::too_many_arguments)]
pub fn compensate(
    model: &Model,
    p: &[f64],
    theta_cmd: &[f64],
    targets: &[f64],
    weights: &[f64],
    start: Option<&[f64]>,
    opts: &SolveOptions,
    tol: f64,
    max_iter: u32,
    threads: usize,
) -> Result<Compensation> {
    let args = (
        p, theta_cmd, targets, weights, start, opts, tol, max_iter, threads,
    );
    model.kind.visit(Compensate { model, args })
}

/// [`compensate`] over the model's motion group.
struct Compensate<'a> {
    model: &'a Model,
    args: Args<'a>,
}

impl Visit for Compensate<'_> {
    type Out = Result<Compensation>;
    fn visit<G: Group>(self) -> Self::Out {
        compensate_k::<G>(self.model, self.args)
    }
}

type Args<'a> = (
    &'a [f64],
    &'a [f64],
    &'a [f64],
    &'a [f64],
    Option<&'a [f64]>,
    &'a SolveOptions,
    f64,
    u32,
    usize,
);

fn compensate_k<G: Group>(model: &Model, args: Args) -> Result<Compensation> {
    let (p, theta_cmd, targets, weights, start, opts, tol, max_iter, threads) = args;
    let n = model.n();
    let task = <G::Frame<f64> as Frame<f64>>::TASK;
    let rows = crate::rows::rows_of("targets", targets, task)?;
    rows_exactly("theta_cmd", theta_cmd, n, rows)?;
    crate::error::check_finite("weights", weights)?;
    if weights.len() != task {
        return Err(CdsmError::Shape {
            name: "weights".into(),
            expected: format!("({task},)"),
            got: format!("({},)", weights.len()),
        });
    }
    let active: Vec<usize> = (0..task).filter(|c| weights[*c] != 0.0).collect();
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
    let plant = Plant::<G>::new(model, p)?;
    let m = plant.reference_lengths().len();
    if let Some(s) = start {
        rows_exactly("start", s, m, 1)?;
    }
    let mut nominal = Vec::with_capacity(rows * m);
    for i in 0..rows {
        nominal.extend(position_lengths(model, &theta_cmd[i * n..(i + 1) * n]));
    }
    let lm = Lm::equations(Step::levenberg(active.len(), m), tol, max_iter);
    // friction: the holes' sliding state at every target, in order
    let mobil = plant.mobilisation_along(theta_cmd);
    let h = mobil.len() / rows.max(1);
    // every target's delivered lengths (independent of the order)
    let parts = split_rows(rows, threads, |range| {
        let mut ws = Workspace::default();
        let mut out = Vec::with_capacity(range.len());
        for i in range {
            let mut prob = Target {
                plant: &plant,
                work: SettleWork::new(&plant, *opts),
                chain: Chain::new(model),
                target: &targets[task * i..task * (i + 1)],
                weights,
                active: &active,
                seed: &theta_cmd[i * n..(i + 1) * n],
                real: vec![0.0; m],
                theta: vec![0.0; n],
                seen: vec![0.0; task],
                dseen: vec![0.0; task * m],
            };
            prob.work.mobil = mobil[i * h..(i + 1) * h].to_vec();
            let mut r = nominal[i * m..(i + 1) * m].to_vec();
            let st = lm::solve(&mut prob, &mut r, &lm, &mut ws);
            let settled = prob.settle(&r);
            let mut seen = vec![f64::NAN; task];
            if settled {
                plant.observe(&prob.theta, &mut prob.chain, &mut seen);
            }
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
    let mut chain = Chain::new(model);
    let (mut real, mut th, mut seen) = (vec![0.0; m], vec![0.0; n], vec![0.0; task]);
    for i in 0..rows {
        plant.realise_one(&nominal[i * m..(i + 1) * m], &mut state, &mut real);
        th.copy_from_slice(&theta_cmd[i * n..(i + 1) * n]);
        work.mobil.clear();
        work.mobil.extend_from_slice(&mobil[i * h..(i + 1) * h]);
        if plant.settle(&real, &mut th, &mut work) {
            plant.observe(&th, &mut chain, &mut seen);
        } else {
            seen.fill(f64::NAN);
        }
        res.seen_nominal.extend_from_slice(&seen);
    }
    Ok(res)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ArmGeometry;
    use crate::plant::{layout, Effect};
    use crate::robot::PlanarView;

    #[test]
    fn compensated_commands_put_the_plant_on_target() {
        let r = PlanarView::paper();
        let m = Model::from_planar(&r);
        let lay = layout(&m);
        let at = |e| lay.find(e).unwrap().0;
        let mut p = vec![0.0; lay.total];
        p[at(Effect::ActuationScale)] = 0.03;
        p[at(Effect::HoleHeight)] = 3e-4;
        p[at(Effect::Backlash)] = 5e-5;
        p[at(Effect::HoleClearance)] = 1e-4;
        let theta = [0.2, -0.3, 0.25, -0.1, 0.2, 0.1];
        let mut targets = Vec::new();
        for t in theta.chunks(3) {
            targets.extend_from_slice(&r.fk(t));
        }
        let l = r.straight_length();
        let res = compensate(
            &m,
            &p,
            &theta,
            &targets,
            &[1.0, 1.0, l],
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
