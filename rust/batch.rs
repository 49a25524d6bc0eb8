//! The planar arm's batch drivers (its fast paths): forward kinematics
//! and its Jacobian by angle addition, cable lengths and Jacobians from the
//! segment coefficients and the cable solve (closed form across SIMD
//! lanes, then Newton), each over rows in threads ([`crate::rows`]). The
//! pose IK's fast paths are chosen in [`crate::ik::solve_batch`].

use crate::cables::CableGeometry;
use crate::error::Result;
use crate::kinds::Se2;
use crate::kinematics;
use crate::lm::Reason;
use crate::model::Model;
use crate::planar::cable_lanes::solve_cables_closed_form_batch_in;
use crate::robot::PlanarView;
use crate::rows::{map_rows, rows_of, seeds, split_rows, BatchSolution};
use crate::solve::{CableMethod, CableSolver, SolveOptions};

/// Batched forward kinematics: `(N, n)` -> `(N, 3)`.
pub fn fk(robot: &PlanarView, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    Ok(map_rows(rows, 3, threads, |i, out| {
        out.copy_from_slice(&kinematics::fk(robot, &theta[i * n..(i + 1) * n]));
    }))
}

/// Batched pose Jacobian: `(N, n)` -> `(N, 3, n)`.
pub fn fk_jacobian(robot: &PlanarView, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    Ok(map_rows(rows, 3 * n, threads, |i, out| {
        let mut jac = vec![[0.0; 3]; n];
        kinematics::fk_jacobian(robot, &theta[i * n..(i + 1) * n], &mut jac);
        for (k, col) in jac.iter().enumerate() {
            for r in 0..3 {
                out[r * n + k] = col[r];
            }
        }
    }))
}

/// Batched cable lengths: `(N, n)` -> `(N, 2n)`.
pub fn cable_lengths(robot: &PlanarView, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    let g = CableGeometry::new(robot, None);
    Ok(map_rows(rows, 2 * n, threads, |i, out| {
        g.lengths(&theta[i * n..(i + 1) * n], out)
    }))
}

/// Batched cable Jacobian: `(N, n)` -> `(N, 2n, n)`.
pub fn cable_jacobian(robot: &PlanarView, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    let g = CableGeometry::new(robot, None);
    Ok(map_rows(rows, 2 * n * n, threads, |i, out| {
        g.jacobian(&theta[i * n..(i + 1) * n], out)
    }))
}

/// Batched cable solve of an arm the cable solver solves by its planar
/// evaluator ([`crate::solve::planar_evaluator`]): upper-cable lengths
/// `(N, n)`, `seed (N, n)` or zeros.
pub fn solve_cables(
    model: &Model,
    upper: &[f64],
    seed: Option<&[f64]>,
    method: CableMethod,
    opts: &SolveOptions,
    threads: usize,
) -> Result<BatchSolution> {
    let n = model.n();
    let rows = rows_of("upper", upper, n)?;
    let seed = seeds(seed, rows, n)?;
    opts.check()?;
    let arch = pulp::Arch::new();
    let parts = split_rows(rows, threads, |r| {
        let m = r.len();
        let mut driver = CableSolver::<Se2<f64>>::new(model, model, method, *opts);
        let (solver, g) = driver
            .planar_mut()
            .expect("an arm with a planar view has the planar evaluator");
        let limits = model.limits();
        let zeros;
        let seed = match seed {
            Some(s) => &s[r.start * n..r.end * n],
            None => {
                zeros = vec![0.0; m * n];
                &zeros
            }
        };
        let upper = &upper[r.start * n..r.end * n];
        if method == CableMethod::Newton {
            // the seeds copied once, each row solved in place
            let mut out = BatchSolution::with_capacity(m, n);
            out.theta.extend_from_slice(seed);
            for i in 0..m {
                let th = &mut out.theta[i * n..(i + 1) * n];
                let st = solver.solve(g, &upper[i * n..(i + 1) * n], th);
                let within = limits.contains(th);
                out.push_status(st, within);
            }
            return out;
        }
        // the closed form SIMD across rows, straight into the answer; then
        // each row decided as the scalar solver does: a row the closed form
        // solved within tol (and within the limits when they are enforced) is
        // accepted in place, any other goes through the solver's `finish`
        let mut theta = vec![0.0; m * n];
        let mut residual = vec![0.0; m];
        let mut ok = vec![false; m];
        solve_cables_closed_form_batch_in(arch, g, upper, seed, &mut theta, &mut residual, &mut ok);
        let mut converged = vec![false; m];
        let mut iterations = vec![0u32; m];
        let mut within_limits = vec![false; m];
        let mut reason = vec![Reason::Converged as u8; m];
        for i in 0..m {
            let rows_i = i * n..(i + 1) * n;
            let th = &mut theta[rows_i.clone()];
            let within = limits.contains(th);
            if ok[i] && solver.accepts(residual[i], within) {
                (converged[i], within_limits[i]) = (true, within);
                continue;
            }
            let closed = ok[i].then_some(residual[i]);
            let st = solver.finish_from(g, &upper[rows_i.clone()], &seed[rows_i], th, closed);
            converged[i] = st.converged;
            iterations[i] = st.iterations;
            residual[i] = st.residual;
            within_limits[i] = limits.contains(th);
            reason[i] = st.reason as u8;
        }
        BatchSolution {
            theta,
            converged,
            iterations,
            residual,
            within_limits,
            reason,
        }
    });
    Ok(BatchSolution::concat(parts))
}
