//! The cable solve of the one arm model (`docs/model.md`, "Solves"): the
//! lengths of the position-controlled cables to the joint angles, through
//! the shared solver ([`crate::lm`]) on the chain of either kind and any
//! numbers (the model's own, or a plant's moved arm). As many cables as
//! joints: damped Newton; more: least squares (converged when an accepted
//! step lowers the squared misfit by less than `1e-12` of itself). The
//! planar kind's closed forms ([`crate::solve`]) are its fast path.

use crate::chain::{Chain, Numbers};
use crate::kinds::Frame;
use crate::lm::{self, Lm, Problem, Step, Workspace};
use crate::model::Model;
use crate::solve::{clamp_to_limits_box, SolveOptions, Status};

struct CableProblem<'a, F: Frame<f64>, N> {
    model: &'a Model,
    nums: &'a N,
    cables: &'a [usize],
    target: &'a [f64],
    chain: &'a mut Chain<f64, F>,
    row: &'a mut [f64],
    limits: Option<&'a [[f64; 2]]>,
}

impl<F: Frame<f64>, N: Numbers<f64>> Problem for CableProblem<'_, F, N> {
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

/// A cable solver of one model with its buffers (reused across solves, and
/// across arms of the model's structure with other numbers).
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
        let mut p = CableProblem {
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
    use crate::kinds::Se3;

    #[test]
    fn it_solves_what_the_spatial_solver_solves() {
        let m = Model::from_toml(include_str!("../python/cdsm/robots/two_universal.toml")).unwrap();
        let o = SolveOptions::default();
        let mut a = CableSolve::<Se3<f64>>::new(&m, o);
        let mut b = crate::spatial::solve::SpatialCableSolver::new(&m, o);
        let pos = m.position_cables();
        let th0 = [0.2, -0.3, 0.1, 0.25];
        let mut ch = Chain::<f64, Se3<f64>>::new(&m);
        ch.at(&m, &m, &th0);
        let target: Vec<f64> = pos
            .iter()
            .map(|c| ch.cable_length(&m, &m, *c, None) + 1e-4)
            .collect();
        let (mut x, mut y) = (th0, th0);
        let sa = a.solve(&m, &m, &target, &mut x);
        let sb = b.solve(&m, &target, &mut y);
        assert!(sa.converged && sb.converged);
        for k in 0..4 {
            assert!((x[k] - y[k]).abs() < 1e-12);
        }
    }
}
