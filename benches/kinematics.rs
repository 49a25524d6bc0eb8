//! Benches of the core: FK, cable lengths, cable solve and pose IK
//! for n = 3 (the paper's prototype) and n = 20; statics: upper tensions and
//! the coupled elastic cable solve.

use cdsm::cables::CableGeometry;
use cdsm::chain::Chain;
use cdsm::ik::{IkSolver, TaskMask};
use cdsm::kinds::Se2;
use cdsm::kinematics::fk;
use cdsm::model::Model;
use cdsm::plant::{self, LoadRows};
use cdsm::solve::{CableMethod, CableSolver, SolveOptions};
use cdsm::tension::{Balance, Wrench};
use cdsm::Robot;
use std::hint::black_box;

mod timing;

fn robot(n: usize) -> Robot {
    if n == 3 {
        return Robot::paper();
    }
    let mut text = String::new();
    for i in 0..n {
        text += &format!(
            "[[linkage]]\nlink_before = 0.02\nlink_after = 0.02\nthickness = 0.005\nhole_height = {}\njoint_limits = [-0.5, 0.5]\n",
            0.03 - 0.0005 * i as f64
        );
    }
    Robot::from_toml(&text).unwrap()
}

fn theta(n: usize) -> Vec<f64> {
    (0..n).map(|k| 0.3 * ((k as f64) * 1.7).sin()).collect()
}

fn main() {
    let c = timing::Bench::from_args();
    let opts = SolveOptions::default();
    for n in [3usize, 20] {
        let r = robot(n);
        let th = theta(n);
        let g = CableGeometry::new(&r, None);
        let mut l = vec![0.0; 2 * n];
        g.lengths(&th, &mut l);
        let upper: Vec<f64> = (0..n).map(|i| l[2 * i]).collect();
        let pose = fk(&r, &th);
        c.run(&format!("fk/n={n}"), 1, || fk(&r, black_box(&th)));
        c.run(&format!("cable_lengths/n={n}"), 1, || {
            g.lengths(black_box(&th), &mut l)
        });
        for (name, m) in [("auto", CableMethod::Auto), ("newton", CableMethod::Newton)] {
            let mut solver = CableSolver::new(&r, m, opts);
            let mut t = th.clone();
            c.run(&format!("cable_solve_{name}/n={n}"), 1, || {
                for (x, y) in t.iter_mut().zip(&th) {
                    *x = y + 0.02;
                }
                solver.solve(&g, black_box(&upper), &mut t)
            });
        }
        // the n = 20 robot file has no weights: hang 0.5 N on every lower cable
        let lower = if n == 3 {
            r.lower_tension.clone()
        } else {
            vec![0.5; n]
        };
        let model = Model::from_planar(&r);
        let mut chain = Chain::<f64, Se2<f64>>::new(&model);
        let mut bal = Balance::<f64>::new(&model);
        let wrench = [0.0, -0.1, 0.0];
        let couple = [0.0];
        let mut t = vec![0.0; n];
        c.run(&format!("tensions/n={n}"), 1, || {
            chain.at(&model, &model, black_box(&th));
            bal.at_with(
                &model,
                &model,
                &mut chain,
                [0.0, -9.81, 0.0],
                Wrench {
                    force: wrench,
                    couple: &couple,
                },
                Some(&lower),
            );
            bal.solve_square(&mut t)
        });
        let tip = [0.0, -0.1, 0.0, 0.0];
        let loads = LoadRows {
            force: Some(&lower),
            wrench: Some(&tip),
            gravity: Some([0.0, -9.81, 0.0]),
        };
        c.run(&format!("cable_solve_elastic/n={n}"), 1, || {
            plant::solve_elastic(&model, black_box(&upper), Some(&th), &loads, 0.0, &opts, 1)
        });
        // per row of a batch of 64 (the setup shared, as in a Monte-Carlo run)
        let rows = 64;
        let many_upper: Vec<f64> = (0..rows).flat_map(|_| upper.iter().copied()).collect();
        let many_th: Vec<f64> = (0..rows).flat_map(|_| th.iter().copied()).collect();
        c.run(
            &format!("cable_solve_elastic_batch/n={n}"),
            rows as u64,
            || {
                plant::solve_elastic(
                    &model,
                    black_box(&many_upper),
                    Some(&many_th),
                    &loads,
                    0.0,
                    &opts,
                    1,
                )
            },
        );
        let mut ik = IkSolver::new(&r, TaskMask::POSE, opts);
        let mut t = th.clone();
        c.run(&format!("pose_ik/n={n}"), 1, || {
            for (x, y) in t.iter_mut().zip(&th) {
                *x = y + 0.02;
            }
            ik.solve(black_box(&pose), &mut t)
        });
    }
}
