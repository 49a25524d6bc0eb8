//! Closed-form cable solve, scalar loop vs SIMD batch, on the speed anchors'
//! workload (`../shared/anchors/`): the paper robot, the 13^3 joint grid
//! (-30..30 deg in 5 deg steps) x 200 samples of uniform +-1 mm errors on
//! each upper cable, every solve seeded at its grid angles. One thread;
//! throughput in solves (elements) per second.

use cdsm::cables::CableGeometry;
use cdsm::planar;
use cdsm::simd;
use cdsm::solve::solve_cables_closed_form;
use cdsm::PlanarView;
use std::hint::black_box;

mod timing;

const SAMPLES: usize = 200;

/// Row-major `(target, seed)` of the anchors' workload, sample-major like
/// `c_closed.c` (sample g: every grid point with that sample's errors).
fn workload(geom: &CableGeometry) -> (Vec<f64>, Vec<f64>) {
    let n = geom.n;
    let mut grid = Vec::new();
    for a in 0..13 {
        for b in 0..13 {
            for c in 0..13 {
                grid.extend([a, b, c].map(|k| ((-30 + 5 * k) as f64).to_radians()));
            }
        }
    }
    let configs = grid.len() / n;
    let mut upper = vec![0.0; grid.len()];
    let mut l = vec![0.0; 2 * n];
    for (th, u) in grid.chunks(n).zip(upper.chunks_mut(n)) {
        geom.lengths(th, &mut l);
        for i in 0..n {
            u[i] = l[2 * i];
        }
    }
    // SplitMix64 uniform in [-1, 1) mm
    let mut state = 0u64;
    let mut uniform = || {
        state = state.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^= z >> 31;
        ((z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0) * 1e-3
    };
    let mut target = Vec::with_capacity(SAMPLES * grid.len());
    let mut seed = Vec::with_capacity(SAMPLES * grid.len());
    for _ in 0..SAMPLES {
        let e: Vec<f64> = (0..n).map(|_| uniform()).collect();
        for k in 0..configs {
            for i in 0..n {
                target.push(upper[k * n + i] + e[i]);
            }
        }
        seed.extend_from_slice(&grid);
    }
    (target, seed)
}

/// The scalar path as `PlanarSolver` runs it: seed cos/sin from libm, then
/// `solve_cables_closed_form`.
fn scalar_loop(
    geom: &CableGeometry,
    target: &[f64],
    seed: &[f64],
    theta: &mut [f64],
    residual: &mut [f64],
    ok: &mut [bool],
) {
    let n = geom.n;
    let mut seed_cs = vec![(1.0, 0.0); n];
    let mut cs = vec![(1.0, 0.0); n];
    for (row, ((t, s), th)) in target
        .chunks(n)
        .zip(seed.chunks(n))
        .zip(theta.chunks_mut(n))
        .enumerate()
    {
        th.copy_from_slice(s);
        for (c, x) in seed_cs.iter_mut().zip(s) {
            *c = (x.cos(), x.sin());
        }
        let r = solve_cables_closed_form(geom, t, th, &seed_cs, &mut cs, None);
        ok[row] = r.is_some();
        residual[row] = r.unwrap_or(f64::INFINITY);
    }
}

fn main() {
    let c = timing::Bench::from_args();
    let robot = PlanarView::paper();
    let geom = CableGeometry::new(&robot, None);
    let n = geom.n;
    let (target, seed) = workload(&geom);
    let rows = target.len() / n;
    eprintln!(
        "simd bench: {rows} solves per iteration; pulp dispatches to {}",
        simd::instruction_set()
    );
    let mut theta = vec![0.0; rows * n];
    let mut residual = vec![0.0; rows];
    let mut ok = vec![false; rows];

    // sanity: the two paths agree on this workload
    let (mut th2, mut res2, mut ok2) = (theta.clone(), residual.clone(), ok.clone());
    scalar_loop(&geom, &target, &seed, &mut theta, &mut residual, &mut ok);
    planar::solve_cables_closed_form_batch(&geom, &target, &seed, &mut th2, &mut res2, &mut ok2);
    assert_eq!(ok, ok2);
    let dmax = theta
        .iter()
        .zip(&th2)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(dmax <= 1e-12, "max |theta difference| {dmax}");
    eprintln!(
        "agreement: {} of {rows} rows solvable in both, max |theta diff| {dmax:.1e} rad",
        ok.iter().filter(|x| **x).count()
    );

    c.run(
        "closed_form_anchor_workload/scalar_loop",
        rows as u64,
        || {
            scalar_loop(
                &geom,
                black_box(&target),
                black_box(&seed),
                &mut theta,
                &mut residual,
                &mut ok,
            )
        },
    );
    c.run(
        "closed_form_anchor_workload/simd_batch",
        rows as u64,
        || {
            planar::solve_cables_closed_form_batch(
                &geom,
                black_box(&target),
                black_box(&seed),
                &mut theta,
                &mut residual,
                &mut ok,
            )
        },
    );
    c.run(
        "closed_form_anchor_workload/simd_batch_forced_scalar_fallback",
        rows as u64,
        || {
            planar::solve_cables_closed_form_batch_in(
                pulp::Arch::Scalar,
                &geom,
                black_box(&target),
                black_box(&seed),
                &mut theta,
                &mut residual,
                &mut ok,
            )
        },
    );
}
