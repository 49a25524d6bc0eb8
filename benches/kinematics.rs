//! Benches of the core: FK, cable lengths, cable solve and pose IK
//! for n = 3 (the paper's prototype) and n = 20; statics: upper tensions and
//! the coupled elastic cable solve; spatial arms (the 8-joint arm of
//! `benches/bench_scale.py` and the packaged 24-joint SJTU snake): the
//! general cable solve and the Monte Carlo, per row of a batch.

use cdsm::accuracy::{self, HoleErrors};
use cdsm::cables::CableGeometry;
use cdsm::chain::Chain;
use cdsm::ik::{IkSolver, Mask, MaskArg, PlanarTask};
use cdsm::kinds::{Kind, Se2};
use cdsm::kinematics::fk;
use cdsm::model::Model;
use cdsm::plant::{self, LoadRows};
use cdsm::solve::{CableMethod, PlanarSolver, SolveOptions};
use cdsm::tension::{Balance, Wrench};
use cdsm::{arm, PlanarView};
use std::borrow::Cow;
use std::hint::black_box;

mod timing;

fn robot(n: usize) -> PlanarView {
    if n == 3 {
        return PlanarView::paper();
    }
    let mut text = String::new();
    for i in 0..n {
        text += &format!(
            "[[linkage]]\nlink_before = 0.02\nlink_after = 0.02\nthickness = 0.005\nhole_height = {}\njoint_limits = [-0.5, 0.5]\n",
            0.03 - 0.0005 * i as f64
        );
    }
    PlanarView::from_toml(&text).unwrap()
}

fn theta(n: usize) -> Vec<f64> {
    (0..n).map(|k| 0.3 * ((k as f64) * 1.7).sin()).collect()
}

/// The 8-joint spatial arm of `benches/bench_scale.py` (`spatial_toml(4)`):
/// four universal-joint sections, two position and two force cables ending
/// at each disk.
fn spatial_arm(sections: usize) -> Model {
    let mut t = String::from("kind = \"spatial\"\nname = \"generated\"\ngravity = [0.0, 0.0, -9.80665]\n[base]\nradius = 0.03\n");
    for _ in 0..sections {
        t += "[[linkage]]\njoints = [\n  { axis = [0.0, 1.0, 0.0], offset = [0.015, 0.0, 0.0], limits = [-0.6, 0.6] },\n  { axis = [0.0, 0.0, 1.0], offset = [0.0, 0.0, 0.0], limits = [-0.6, 0.6] },\n]\nlink_after = [0.015, 0.0, 0.0]\nthickness = 0.005\nradius = 0.03\nmass = 0.015\ncom = [0.0025, 0.0, 0.0]\n";
    }
    for s in 0..sections {
        let r = 0.028 - 0.002 * s as f64;
        for k in 0..4 {
            let mode = if k < 2 {
                "mode = \"position\""
            } else {
                "mode = \"force\"\ntension = 1.0"
            };
            t += &format!(
                "[[cables]]\nend = {}\n{mode}\nradius = {r}\nangle = {}\n",
                s + 1,
                k as f64 * std::f64::consts::FRAC_PI_2
            );
        }
    }
    Model::from_toml(&t).unwrap()
}

/// Uniform numbers in `[-1, 1)` from a fixed stream.
fn uniform(count: usize, seed: u64) -> Vec<f64> {
    let mut s = seed;
    (0..count)
        .map(|_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            2.0 * ((s >> 11) as f64 / (1u64 << 53) as f64) - 1.0
        })
        .collect()
}

/// The general cable solve and the Monte Carlo of a spatial arm, per row:
/// `rows` configurations in +-`spread` rad, solved from theta + 0.02 rad;
/// Monte Carlo of `configs` x `samples` with the paper's +-1 mm cable and
/// +-0.35 mm hole errors (every hole coordinate).
fn spatial(
    c: &timing::Bench,
    name: &str,
    model: &Model,
    spread: f64,
    configs: usize,
    samples: usize,
) {
    let opts = SolveOptions::default();
    let n = model.n();
    let m = model.position_cables().len();
    let rows = 256;
    let th: Vec<f64> = uniform(rows * n, 1).iter().map(|u| spread * u).collect();
    let lengths: Vec<f64> = {
        let all = arm::cable_lengths(model, &th, 1).unwrap();
        let pos = model.position_cables();
        let k = model.cables.len();
        (0..rows)
            .flat_map(|i| pos.iter().map(move |&p| (i, p)))
            .map(|(i, p)| all[i * k + p])
            .collect()
    };
    let seed: Vec<f64> = th.iter().map(|t| t + 0.02).collect();
    let sol = arm::solve_cables(model, &lengths, Some(&seed), CableMethod::Auto, &opts, 1).unwrap();
    assert!(
        sol.converged.iter().all(|c| *c),
        "{name}: the bench's solves converge"
    );
    c.run(&format!("cable_solve_spatial/{name}"), rows as u64, || {
        arm::solve_cables(
            model,
            black_box(&lengths),
            Some(&seed),
            CableMethod::Auto,
            &opts,
            1,
        )
    });
    let theta0 = &th[..configs * n];
    let dl: Vec<f64> = uniform(samples * m, 2).iter().map(|u| 1e-3 * u).collect();
    let h = model.flat_holes().len();
    let dh: Vec<f64> = uniform(samples * h, 3)
        .iter()
        .map(|u| 0.35e-3 * u)
        .collect();
    c.run(
        &format!("monte_carlo_spatial/{name}"),
        (configs * samples) as u64,
        || {
            let holes = HoleErrors::Full(&dh);
            let method = CableMethod::Auto;
            accuracy::monte_carlo(
                model,
                black_box(theta0),
                &dl,
                holes,
                method,
                &opts,
                false,
                1,
            )
        },
    );
}

fn main() {
    let c = timing::Bench::from_args();
    let opts = SolveOptions::default();
    spatial(&c, "n=8", &spatial_arm(4), 0.4, 64, 16);
    let snake = Model::from_toml(include_str!("../python/cdsm/robots/sjtu_snake.toml")).unwrap();
    spatial(&c, "sjtu_snake_n=24", &snake, 0.34, 8, 8);
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
            let mut solver = PlanarSolver::new(Cow::Borrowed(&r), m, opts);
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
        let pose_mask = Mask::parse(Kind::Planar, MaskArg::Weights(&[1.0; 3])).unwrap();
        let mut ik = IkSolver::new(PlanarTask::new(&r), pose_mask, opts);
        let mut t = th.clone();
        c.run(&format!("pose_ik/n={n}"), 1, || {
            for (x, y) in t.iter_mut().zip(&th) {
                *x = y + 0.02;
            }
            ik.solve(black_box(&pose), &mut t)
        });
    }
}
