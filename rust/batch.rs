//! Batched, multi-threaded drivers over rows of configurations. Threads are
//! `std::thread::scope` workers over contiguous row ranges (no rayon).

use crate::cables::CableGeometry;
use crate::error::{check_finite, check_rows, CdsmError, Result};
use crate::ik::{check_closed_form, ik_closed_form, IkMethod, IkSolver, TaskMask};
use crate::kinematics;
use crate::lm::Reason;
use crate::robot::Robot;
use crate::simd::cables::solve_cables_closed_form_batch_in;
use crate::simd::ik::ik_closed_form_batch;
use crate::solve::{self, CableMethod, SolveOptions, Status};
use std::ops::Range;

/// Number of worker threads: `0` means all available cores.
pub fn resolve_threads(threads: usize) -> usize {
    if threads > 0 {
        threads
    } else {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    }
}

/// Runs `work` on contiguous ranges of `0..rows` in up to `threads` scoped
/// threads and returns the per-range results in row order. A range whose
/// thread the system cannot start (too many threads) is worked by the
/// calling thread: the result does not depend on how many start.
pub fn split_rows<T: Send>(
    rows: usize,
    threads: usize,
    work: impl Fn(Range<usize>) -> T + Sync,
) -> Vec<T> {
    let threads = resolve_threads(threads).min(rows.max(1));
    if threads <= 1 {
        return vec![work(0..rows)];
    }
    let per = rows.div_ceil(threads);
    std::thread::scope(|s| {
        let w = &work;
        let started: Vec<_> = (0..threads)
            .map(|t| {
                let r = (t * per).min(rows)..((t + 1) * per).min(rows);
                std::thread::Builder::new()
                    .spawn_scoped(s, {
                        let r = r.clone();
                        move || w(r)
                    })
                    .map_err(|_| r)
            })
            .collect();
        started
            .into_iter()
            .map(|h| match h {
                Ok(h) => h.join().expect("worker thread panicked"),
                Err(r) => w(r),
            })
            .collect()
    })
}

/// Per-row `f64` map: `f(row_index, out_row)` fills `width` outputs per row.
pub fn map_rows(
    rows: usize,
    width: usize,
    threads: usize,
    f: impl Fn(usize, &mut [f64]) + Sync,
) -> Vec<f64> {
    split_rows(rows, threads, |r| {
        let mut out = vec![0.0; r.len() * width];
        for (j, i) in r.enumerate() {
            f(i, &mut out[j * width..(j + 1) * width]);
        }
        out
    })
    .concat()
}

/// Results of a batch of solves, one entry per row. Every batch solve of the
/// crate (cable solves, pose IK, deviations, elastic solves) assembles its
/// rows with [`BatchSolution::push`] and joins its threads' parts with
/// [`BatchSolution::extend`].
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BatchSolution {
    /// `(N, n)` row-major joint angles (rad).
    pub theta: Vec<f64>,
    pub converged: Vec<bool>,
    pub iterations: Vec<u32>,
    /// max |residual| per row (m, or rad for phi).
    pub residual: Vec<f64>,
    /// All angles within the joint limits.
    pub within_limits: Vec<bool>,
    /// Why each solve ended ([`crate::lm::Reason`] as `u8`).
    pub reason: Vec<u8>,
}

impl BatchSolution {
    pub(crate) fn with_capacity(rows: usize, n: usize) -> Self {
        BatchSolution {
            theta: Vec::with_capacity(rows * n),
            converged: Vec::with_capacity(rows),
            iterations: Vec::with_capacity(rows),
            residual: Vec::with_capacity(rows),
            within_limits: Vec::with_capacity(rows),
            reason: Vec::with_capacity(rows),
        }
    }

    /// Appends one row: the angles and the status of their solve.
    pub(crate) fn push(&mut self, robot: &Robot, theta: &[f64], st: Status) {
        self.push_row(theta, st, kinematics::within_limits(robot, theta));
    }

    /// Appends one row whose joint-limit flag is known.
    pub(crate) fn push_row(&mut self, theta: &[f64], st: Status, within_limits: bool) {
        self.theta.extend_from_slice(theta);
        self.push_status(st, within_limits);
    }

    /// Appends the status of a row whose angles are already in `theta`.
    pub(crate) fn push_status(&mut self, st: Status, within_limits: bool) {
        self.converged.push(st.converged);
        self.iterations.push(st.iterations);
        self.residual.push(st.residual);
        self.within_limits.push(within_limits);
        self.reason.push(st.reason as u8);
    }

    /// Appends the rows of `other` after those of `self`.
    pub(crate) fn extend(&mut self, other: BatchSolution) {
        self.theta.extend(other.theta);
        self.converged.extend(other.converged);
        self.iterations.extend(other.iterations);
        self.residual.extend(other.residual);
        self.within_limits.extend(other.within_limits);
        self.reason.extend(other.reason);
    }

    /// The parts' rows in order (one part is moved, not copied).
    pub(crate) fn concat(parts: Vec<BatchSolution>) -> Self {
        let mut parts = parts.into_iter();
        let mut out = parts.next().unwrap_or_default();
        for p in parts {
            out.extend(p);
        }
        out
    }
}

/// Validates a flat `(N, width)` batch; returns `N`.
pub fn rows_of(name: &str, values: &[f64], width: usize) -> Result<usize> {
    let rows = check_rows(name, values, width)?;
    check_finite(name, values).map_err(|e| match e {
        CdsmError::NonFinite { name, index, value } => CdsmError::NonFiniteAt {
            name,
            row: index / width,
            column: index % width,
            value,
        },
        e => e,
    })?;
    Ok(rows)
}

/// Validates a flat `(rows, width)` batch that must have exactly `rows` rows.
pub fn rows_exactly(name: &str, values: &[f64], width: usize, rows: usize) -> Result<()> {
    let got = rows_of(name, values, width)?;
    if got != rows {
        return Err(CdsmError::Shape {
            name: name.into(),
            expected: format!("({rows}, {width})"),
            got: format!("({got}, {width})"),
        });
    }
    Ok(())
}

/// Seeds: `None` gives zeros, otherwise `(N, n)` checked against `rows`.
pub fn seeds(seed: Option<&[f64]>, rows: usize, n: usize) -> Result<Option<&[f64]>> {
    if let Some(s) = seed {
        rows_exactly("seed", s, n, rows)?;
    }
    Ok(seed)
}

/// Batched forward kinematics: `(N, n)` -> `(N, 3)`.
pub fn fk(robot: &Robot, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    Ok(map_rows(rows, 3, threads, |i, out| {
        out.copy_from_slice(&kinematics::fk(robot, &theta[i * n..(i + 1) * n]));
    }))
}

/// Batched joint-limit check: `(N, n)` -> `(N,)`.
pub fn within_limits(robot: &Robot, theta: &[f64], threads: usize) -> Result<Vec<bool>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    Ok(split_rows(rows, threads, |r| {
        r.map(|i| kinematics::within_limits(robot, &theta[i * n..(i + 1) * n]))
            .collect::<Vec<bool>>()
    })
    .concat())
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
    check_options(opts)?;
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
            out.push(robot, &th, st);
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
            out.push(robot, th, st);
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
    check_options(opts)?;
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
                let within = kinematics::within_limits(robot, th);
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
            let within = kinematics::within_limits(robot, th);
            if ok[i] && solver.accepts(residual[i], within) {
                (converged[i], within_limits[i]) = (true, within);
                continue;
            }
            let closed = ok[i].then_some(residual[i]);
            let st = solver.finish_from(&g, &upper[rows_i.clone()], &seed[rows_i], th, closed);
            converged[i] = st.converged;
            iterations[i] = st.iterations;
            residual[i] = st.residual;
            within_limits[i] = kinematics::within_limits(robot, th);
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

/// Rejects solver options outside their domain.
pub fn check_options(opts: &SolveOptions) -> Result<()> {
    if !(opts.tol.is_finite() && opts.tol > 0.0) {
        return Err(CdsmError::Option {
            name: "tol".into(),
            problem: format!("must be positive and finite, got {}", opts.tol),
        });
    }
    if opts.max_iter == 0 {
        return Err(CdsmError::Option {
            name: "max_iter".into(),
            problem: "must be at least 1".into(),
        });
    }
    Ok(())
}
