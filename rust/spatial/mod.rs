//! Spatial arms (`kind = "spatial"`, `docs/spatial.md`): revolute axes in
//! 3-D, holes anywhere on the disks, position- and force-controlled cables.
//! The planar model is untouched; this module has its own description,
//! kinematics, cable geometry, solves and statics, and batch entry points
//! that run over threads like the planar ones.

pub mod kinematics;

pub mod solve;
pub mod statics;

use crate::accuracy::McStats;
use crate::batch::{rows_of, seeds, split_rows, BatchSolution};
use crate::error::{CdsmError, Result};
pub use crate::model::SpatialRobot;
use crate::solve::SolveOptions;
use kinematics::{cable_length, geometric_jacobian, pose_vector, Chain};
use solve::{within_limits, SpatialCableSolver, SpatialIkSolver, SpatialMask};

/// Task-space width of a spatial pose: x, y, z (m), rotation vector (rad).
pub const SPATIAL_TASK: usize = 6;
/// Quantities of a spatial Monte-Carlo sample: dX, dY, dZ, |dXYZ| (m),
/// rotation angle (rad).
pub const SPATIAL_QUANTITIES: usize = 5;

/// A row-wise map over `theta (N, n)` producing `width` values per row.
fn map_rows(
    robot: &SpatialRobot,
    theta: &[f64],
    width: usize,
    threads: usize,
    f: impl Fn(&mut Chain, &[f64], &mut [f64]) + Sync,
) -> Result<Vec<f64>> {
    let n = robot.n();
    let rows = rows_of("theta", theta, n)?;
    let parts = split_rows(rows, threads, |r| {
        let mut chain = Chain::new(robot);
        let mut out = vec![0.0; r.len() * width];
        for (local, i) in r.enumerate() {
            let t = &theta[i * n..(i + 1) * n];
            chain.at(robot, t);
            f(&mut chain, t, &mut out[local * width..(local + 1) * width]);
        }
        out
    });
    Ok(parts.concat())
}

/// End poses `[x, y, z, rx, ry, rz]` `(N, 6)`.
pub fn fk(robot: &SpatialRobot, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    map_rows(robot, theta, 6, threads, |c, _, o| {
        o.copy_from_slice(&pose_vector(c.end()))
    })
}

/// End frames as row-major 4x4 matrices `(N, 16)`.
pub fn fk_matrix(robot: &SpatialRobot, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    map_rows(robot, theta, 16, threads, |c, _, o| {
        o.copy_from_slice(&c.end().matrix())
    })
}

/// Geometric Jacobians `(N, 6, n)`.
pub fn fk_jacobian(robot: &SpatialRobot, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    map_rows(robot, theta, 6 * robot.n(), threads, |c, _, o| {
        geometric_jacobian(c, o)
    })
}

/// Lengths of every cable `(N, cables)` (m).
pub fn cable_lengths(robot: &SpatialRobot, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let m = robot.cables.len();
    map_rows(robot, theta, m, threads, |c, _, o| {
        let mut pts = Vec::new();
        for (k, v) in o.iter_mut().enumerate() {
            *v = cable_length(robot, c, k, &mut pts, None);
        }
    })
}

/// Cable Jacobians `(N, cables, n)` (m/rad).
pub fn cable_jacobian(robot: &SpatialRobot, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let (m, n) = (robot.cables.len(), robot.n());
    map_rows(robot, theta, m * n, threads, |c, _, o| {
        let mut pts = Vec::new();
        for k in 0..m {
            cable_length(robot, c, k, &mut pts, Some(&mut o[k * n..(k + 1) * n]));
        }
    })
}

/// Cable solve of a batch: lengths `(N, m_pos)` of the position-controlled
/// cables (file order, m), `seed (N, n)` or zeros.
pub fn solve_cables(
    robot: &SpatialRobot,
    lengths: &[f64],
    seed: Option<&[f64]>,
    opts: &SolveOptions,
    threads: usize,
) -> Result<BatchSolution> {
    let (n, m) = (robot.n(), robot.position_cables().len());
    let rows = rows_of("lengths", lengths, m)?;
    let seed = seeds(seed, rows, n)?;
    crate::batch::check_options(opts)?;
    let parts = split_rows(rows, threads, |r| {
        let mut out = BatchSolution::with_capacity(r.len(), n);
        let mut solver = SpatialCableSolver::new(robot, *opts);
        let mut th = vec![0.0; n];
        for i in r {
            match seed {
                Some(s) => th.copy_from_slice(&s[i * n..(i + 1) * n]),
                None => th.fill(0.0),
            }
            let st = solver.solve(robot, &lengths[i * m..(i + 1) * m], &mut th);
            out.push_row(&th, st, within_limits(robot, &th));
        }
        out
    });
    Ok(BatchSolution::concat(parts))
}

/// Monte-Carlo study of a spatial arm: for every sample `s` (errors `dl[s]`
/// (m_pos) on the position-controlled cables, m, and `dholes[s]` (every hole
/// coordinate, as [`SpatialRobot::flat_holes`], m) when given) and every
/// configuration `theta0[j]`, the cable solve seeded at `theta0[j]` and the
/// tip deviation, reduced to [`McStats`] with five quantities: dX, dY, dZ,
/// |dXYZ| (m) and the rotation angle of the end frame (rad).
pub fn monte_carlo(
    robot: &SpatialRobot,
    theta0: &[f64],
    dl: &[f64],
    dholes: Option<&[f64]>,
    opts: &SolveOptions,
    threads: usize,
) -> Result<McStats> {
    let n = robot.n();
    let m = robot.position_cables().len();
    let rows = rows_of("theta0", theta0, n)?;
    let samples = rows_of("dl", dl, m)?;
    crate::batch::check_options(opts)?;
    let nominal_holes = robot.flat_holes();
    let h = nominal_holes.len();
    let robots: Vec<SpatialRobot> = match dholes {
        None => Vec::new(),
        Some(d) => {
            crate::batch::rows_exactly("dholes", d, h, samples)?;
            (0..samples)
                .map(|s| {
                    let flat: Vec<f64> = nominal_holes
                        .iter()
                        .zip(&d[s * h..(s + 1) * h])
                        .map(|(a, b)| a + b)
                        .collect();
                    robot.with_flat_holes(&flat)
                })
                .collect::<Result<_>>()?
        }
    };
    let robot_of = |s: usize| robots.get(s).unwrap_or(robot);
    let pos = robot.position_cables();
    let parts = split_rows(rows, threads, |r| {
        let mut stats = McStats::with_quantities(r.len(), SPATIAL_QUANTITIES);
        let mut solver = SpatialCableSolver::new(robot, *opts);
        let mut chain = Chain::new(robot);
        let (mut pts, mut l0, mut target, mut th) =
            (Vec::new(), vec![0.0; m], vec![0.0; m], vec![0.0; n]);
        for (j, i) in r.enumerate() {
            let t0 = &theta0[i * n..(i + 1) * n];
            chain.at(robot, t0);
            for (k, &c) in pos.iter().enumerate() {
                l0[k] = cable_length(robot, &chain, c, &mut pts, None);
            }
            let end0 = *chain.end();
            for s in 0..samples {
                for k in 0..m {
                    target[k] = l0[k] + dl[s * m + k];
                }
                th.copy_from_slice(t0);
                let st = solver.solve(robot_of(s), &target, &mut th);
                if !st.converged {
                    stats.failed[j] += 1;
                    continue;
                }
                let end = solver.chain.end();
                let d = end.p - end0.p;
                let angle = kinematics::log_of(&(end0.r.transpose() * end.r)).norm();
                stats.add_values(j, &[d[0], d[1], d[2], d.norm(), angle]);
            }
        }
        stats
    });
    let mut out = McStats::with_quantities(0, SPATIAL_QUANTITIES);
    for p in parts {
        out.extend(p);
    }
    Ok(out)
}

/// Masked pose IK of a batch: targets `(N, 6)` (m, rotation vector rad),
/// `seed (N, n)` or zeros.
pub fn ik(
    robot: &SpatialRobot,
    target: &[f64],
    seed: Option<&[f64]>,
    mask: SpatialMask,
    opts: &SolveOptions,
    threads: usize,
) -> Result<BatchSolution> {
    let n = robot.n();
    let rows = rows_of("target", target, SPATIAL_TASK)?;
    let seed = seeds(seed, rows, n)?;
    crate::batch::check_options(opts)?;
    let parts = split_rows(rows, threads, |r| {
        let mut out = BatchSolution::with_capacity(r.len(), n);
        let mut solver = SpatialIkSolver::new(robot, mask, *opts);
        let mut th = vec![0.0; n];
        for i in r {
            match seed {
                Some(s) => th.copy_from_slice(&s[i * n..(i + 1) * n]),
                None => th.fill(0.0),
            }
            let mut t = [0.0; 6];
            t.copy_from_slice(&target[i * 6..(i + 1) * 6]);
            let st = solver.solve(&t, &mut th);
            out.push_row(&th, st, within_limits(robot, &th));
        }
        out
    });
    Ok(BatchSolution::concat(parts))
}

/// Tensions of the position-controlled cables `(N, m_pos)` (N; NaN where
/// none above `floor` exists) and the feasibility flags `(N)`.
pub fn tensions(
    robot: &SpatialRobot,
    theta: &[f64],
    tip_wrench: &[f64; 6],
    floor: f64,
    threads: usize,
) -> Result<(Vec<f64>, Vec<bool>)> {
    crate::error::check_finite("tip_wrench", tip_wrench)?;
    if !floor.is_finite() {
        return Err(CdsmError::Option {
            name: "min_tension".into(),
            problem: format!("must be finite (N), got {floor}"),
        });
    }
    let m = robot.position_cables().len();
    let flat = map_rows(
        robot,
        theta,
        m + 1,
        threads,
        |c, _, o| match statics::position_tensions(robot, c, tip_wrench, floor) {
            Some(t) => {
                o[..m].copy_from_slice(&t);
                o[m] = 1.0;
            }
            None => {
                o[..m].fill(f64::NAN);
                o[m] = 0.0;
            }
        },
    )?;
    let mut t = Vec::with_capacity(flat.len());
    let mut ok = Vec::with_capacity(flat.len() / (m + 1));
    for row in flat.chunks_exact(m + 1) {
        t.extend_from_slice(&row[..m]);
        ok.push(row[m] != 0.0);
    }
    Ok((t, ok))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ArmGeometry;
    use crate::Robot;

    const PAPER: &str = include_str!("../../python/cdsm/robots/paper_spatial.toml");

    #[test]
    fn the_paper_arm_written_spatially_is_the_planar_one() {
        let s = SpatialRobot::from_toml(PAPER).unwrap();
        let p = Robot::paper();
        let th = [0.3, -0.4, 0.25, -0.1, 0.2, 0.5];
        let pose = fk(&s, &th, 1).unwrap();
        let lens = cable_lengths(&s, &th, 1).unwrap();
        for row in 0..2 {
            let t = &th[3 * row..3 * row + 3];
            let q = p.fk(t);
            let mut l = vec![0.0; 6];
            crate::cables::CableGeometry::new(&p, None).lengths(t, &mut l);
            assert!(
                (pose[6 * row] - q[0]).abs() < 1e-12 && (pose[6 * row + 1] - q[1]).abs() < 1e-12
            );
            assert!(pose[6 * row + 2].abs() < 1e-15);
            for c in 0..6 {
                assert!((lens[6 * row + c] - l[c]).abs() < 1e-12, "cable {c}");
            }
        }
    }
}
