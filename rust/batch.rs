//! The planar arm's batch drivers (its fast paths): forward kinematics
//! and its Jacobian by angle addition, cable lengths and Jacobians from the
//! segment coefficients, the pose IK (closed form across SIMD lanes, or
//! damped least squares) and the cable solve (closed form across SIMD
//! lanes, then Newton), each over rows in threads ([`crate::rows`]).

use crate::cables::CableGeometry;
use crate::error::{check_finite, CdsmError, Result};
use crate::ik::{check_closed_form, ik_closed_form, IkMethod, IkSolver, TaskMask};
use crate::kinematics;
use crate::lm::Reason;
use crate::planar::cable_lanes::solve_cables_closed_form_batch_in;
use crate::planar::ik_lanes::ik_closed_form_batch;
use crate::robot::Robot;
use crate::rows::{map_rows, rows_of, seeds, split_rows, BatchSolution};
use crate::solve::{self, CableMethod, SolveOptions, Status};

/// Batched forward kinematics: `(N, n)` -> `(N, 3)`.
pub fn fk(robot: &Robot, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    Ok(map_rows(rows, 3, threads, |i, out| {
        out.copy_from_slice(&kinematics::fk(robot, &theta[i * n..(i + 1) * n]));
    }))
}

/// Batched pose Jacobian: `(N, n)` -> `(N, 3, n)`.
pub fn fk_jacobian(robot: &Robot, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
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
pub fn cable_lengths(robot: &Robot, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    let g = CableGeometry::new(robot, None);
    Ok(map_rows(rows, 2 * n, threads, |i, out| {
        g.lengths(&theta[i * n..(i + 1) * n], out)
    }))
}

/// Batched cable Jacobian: `(N, n)` -> `(N, 2n, n)`.
pub fn cable_jacobian(robot: &Robot, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    let g = CableGeometry::new(robot, None);
    Ok(map_rows(rows, 2 * n * n, threads, |i, out| {
        g.jacobian(&theta[i * n..(i + 1) * n], out)
    }))
}

/// Batched pose IK: `pose (N, 3)` targets matched on the coordinates of
/// `mask`, `seed (N, n)` or zeros.
pub fn ik(
    robot: &Robot,
    pose: &[f64],
    seed: Option<&[f64]>,
    mask: TaskMask,
    method: IkMethod,
    opts: &SolveOptions,
    threads: usize,
) -> Result<BatchSolution> {
    let n = robot.n();
    let rows = rows_of("pose", pose, 3)?;
    let seed = seeds(seed, rows, n)?;
    opts.check()?;
    check_finite("mask", &mask.weights)?;
    if mask.weights.iter().all(|w| *w == 0.0) || mask.weights.iter().any(|w| *w < 0.0) {
        return Err(CdsmError::Option {
            name: "mask".into(),
            problem: format!(
                "weights must be >= 0 with at least one > 0, got {:?}",
                mask.weights
            ),
        });
    }
    if method == IkMethod::ClosedForm {
        check_closed_form(robot, mask)?;
        if !opts.enforce_limits {
            return Ok(ik_closed_form_rows(robot, pose, seed, opts, threads));
        }
    }
    let parts = split_rows(rows, threads, |r| {
        let mut out = BatchSolution::with_capacity(r.len(), n);
        let mut th = vec![0.0; n];
        let mut solver = IkSolver::new(robot, mask, *opts);
        for i in r {
            match seed {
                Some(s) => th.copy_from_slice(&s[i * n..(i + 1) * n]),
                None => th.fill(0.0),
            }
            let p = [pose[3 * i], pose[3 * i + 1], pose[3 * i + 2]];
            let st = match method {
                IkMethod::Lm => solver.solve(&p, &mut th),
                IkMethod::ClosedForm => ik_closed_form(robot, &p, &mut th, opts),
            };
            out.push_row(&th, st, robot.limits().contains(&th));
        }
        out
    });
    Ok(BatchSolution::concat(parts))
}

/// The closed-form pose IK of a 3-joint arm over a batch: SIMD across rows,
/// the rows the lanes leave (out of reach, whole turns from the seed) by the
/// scalar function.
fn ik_closed_form_rows(
    robot: &Robot,
    pose: &[f64],
    seed: Option<&[f64]>,
    opts: &SolveOptions,
    threads: usize,
) -> BatchSolution {
    let arch = pulp::Arch::new();
    let rows = pose.len() / 3;
    let parts = split_rows(rows, threads, |r| {
        let m = r.len();
        let zeros;
        let seed = match seed {
            Some(s) => &s[r.start * 3..r.end * 3],
            None => {
                zeros = vec![0.0; m * 3];
                &zeros
            }
        };
        let pose = &pose[r.start * 3..r.end * 3];
        let mut theta = vec![0.0; m * 3];
        let (mut residual, mut done) = (vec![0.0; m], vec![false; m]);
        ik_closed_form_batch(
            arch,
            robot,
            pose,
            seed,
            &mut theta,
            &mut residual,
            &mut done,
        );
        let mut out = BatchSolution::with_capacity(m, 3);
        for i in 0..m {
            let th = &mut theta[i * 3..(i + 1) * 3];
            let st = if done[i] {
                let converged = residual[i] <= opts.tol;
                Status {
                    converged,
                    iterations: 0,
                    residual: residual[i],
                    cost: residual[i] * residual[i],
                    reason: if converged {
                        Reason::Converged
                    } else {
                        Reason::Singular
                    },
                }
            } else {
                th.copy_from_slice(&seed[i * 3..(i + 1) * 3]);
                let p = [pose[3 * i], pose[3 * i + 1], pose[3 * i + 2]];
                ik_closed_form(robot, &p, th, opts)
            };
            out.push_row(th, st, robot.limits().contains(th));
        }
        out
    });
    BatchSolution::concat(parts)
}

/// Batched cable solve: upper-cable lengths `(N, n)`, `seed (N, n)` or zeros.
pub fn solve_cables(
    robot: &Robot,
    upper: &[f64],
    seed: Option<&[f64]>,
    method: CableMethod,
    opts: &SolveOptions,
    threads: usize,
) -> Result<BatchSolution> {
    let n = robot.n();
    let rows = rows_of("upper", upper, n)?;
    let seed = seeds(seed, rows, n)?;
    opts.check()?;
    let g = CableGeometry::new(robot, None);
    let arch = pulp::Arch::new();
    let parts = split_rows(rows, threads, |r| {
        let m = r.len();
        let mut solver = solve::CableSolver::new(robot, method, *opts);
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
                let st = solver.solve(&g, &upper[i * n..(i + 1) * n], th);
                let within = robot.limits().contains(th);
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
        solve_cables_closed_form_batch_in(
            arch,
            &g,
            upper,
            seed,
            &mut theta,
            &mut residual,
            &mut ok,
        );
        let mut converged = vec![false; m];
        let mut iterations = vec![0u32; m];
        let mut within_limits = vec![false; m];
        let mut reason = vec![Reason::Converged as u8; m];
        for i in 0..m {
            let rows_i = i * n..(i + 1) * n;
            let th = &mut theta[rows_i.clone()];
            let within = robot.limits().contains(th);
            if ok[i] && solver.accepts(residual[i], within) {
                (converged[i], within_limits[i]) = (true, within);
                continue;
            }
            let closed = ok[i].then_some(residual[i]);
            let st = solver.finish_from(&g, &upper[rows_i.clone()], &seed[rows_i], th, closed);
            converged[i] = st.converged;
            iterations[i] = st.iterations;
            residual[i] = st.residual;
            within_limits[i] = robot.limits().contains(th);
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
