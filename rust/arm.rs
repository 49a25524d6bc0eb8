//! Batched calls on an arm of either kind ([`Model`]), over threads: the
//! kinematics, the cable solve, the pose IK and the statics (the Monte
//! Carlo of its errors: [`crate::accuracy::monte_carlo`]). A planar arm
//! runs its fast paths (the planar drivers of [`crate::batch`]: closed forms, SIMD, the triangular Newton);
//! every arm can run the general ones on the one model's chain, which are
//! the only ones of a spatial arm. SI units; arrays row-major.

use crate::batch;
use crate::chain::{Broadcast, Chain};
use crate::error::{CdsmError, Result};
use crate::friction::{Holes, Profile, Sliding};
use crate::kinds::{Frame, Group, Spatial, Visit};
use crate::lm::Reason;
use crate::model::Model;
use crate::qp::min_norm_active;
use crate::real::pack::Pack;
use crate::rows::{row_of, rows_of, seeds, shared_or_rows, split_rows, BatchSolution};
use crate::solve::{planar_evaluator, CableMethod, CableNewton, CableSolver, SolveOptions};
use crate::tension::{Balance, Wrench};
use pulp::{Simd, WithSimd};
use std::marker::PhantomData;
use std::ops::Range;

/// A row-wise map over `theta (N, n)` producing `width` values per row from
/// the chain of the configuration (after [`Chain::at`] and [`Chain::world`]).
fn map_chain<G: Group>(
    model: &Model,
    theta: &[f64],
    width: usize,
    threads: usize,
    f: impl Fn(&mut Chain<f64, G::Frame<f64>>, &mut [f64]) + Sync,
) -> Result<Vec<f64>> {
    let n = model.n();
    let rows = rows_of("theta", theta, n)?;
    let parts = split_rows(rows, threads, |r| {
        let mut chain = Chain::new(model);
        let mut out = vec![0.0; r.len() * width];
        for (local, i) in r.enumerate() {
            chain.at(model, model, &theta[i * n..(i + 1) * n]);
            chain.world(model, model);
            f(&mut chain, &mut out[local * width..(local + 1) * width]);
        }
        out
    });
    Ok(parts.concat())
}

/// End poses: planar `[x, y, phi]`, spatial `[x, y, z, rx, ry, rz]` (m,
/// rad; `(N, TASK)`).
pub fn fk(model: &Model, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    kinematics(model, theta, threads, batch::fk, 6, |c, o| c.end().task(o))
}

/// One batched kinematic quantity, `width` values per row: by `planar`, the
/// planar view's angle-addition fast path, where the arm has one; else
/// by `chain` from every row's chain ([`map_chain`]). The one place the
/// kinematics choose their fast path.
fn kinematics(
    model: &Model,
    theta: &[f64],
    threads: usize,
    planar: fn(&crate::robot::PlanarView, &[f64], usize) -> Result<Vec<f64>>,
    width: usize,
    chain: impl Fn(&mut Chain<f64, <Spatial as Group>::Frame<f64>>, &mut [f64]) + Sync,
) -> Result<Vec<f64>> {
    match model.planar() {
        Some(r) => planar(r, theta, threads),
        None => map_chain::<Spatial>(model, theta, width, threads, chain),
    }
}

/// End frames as row-major 4x4 matrices `(N, 16)` (m).
pub fn fk_matrix(model: &Model, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    map_chain::<Spatial>(model, theta, 16, threads, |c, o| {
        let e = c.end();
        for i in 0..3 {
            o[4 * i..4 * i + 3].copy_from_slice(&e.r[i]);
            o[4 * i + 3] = e.t[i];
        }
        o[12..16].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
    })
}

/// The face frames of every disk in the base frame `(N, K, 2, 4, 4)`: face
/// `a` (proximal) then face `b` (distal) of disks `1..=K`, homogeneous,
/// translation in m (the base face is the identity).
pub fn disk_frames(model: &Model, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let k = model.disks.len();
    map_chain::<Spatial>(model, theta, 32 * k, threads, |c, o| {
        for d in 0..k {
            for (f, frame) in [&c.face_a[d], &c.face_b[d]].into_iter().enumerate() {
                let m = &mut o[32 * d + 16 * f..32 * d + 16 * (f + 1)];
                for i in 0..3 {
                    m[4 * i..4 * i + 3].copy_from_slice(&frame.r[i]);
                    m[4 * i + 3] = frame.t[i];
                }
                m[12..16].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
            }
        }
    })
}

/// Task Jacobians `(N, TASK, n)`: planar `d[x, y, phi]/dtheta`, spatial the
/// geometric Jacobian (velocity of the end frame's origin, then its angular
/// velocity).
pub fn fk_jacobian(model: &Model, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let width = 6 * model.n();
    kinematics(model, theta, threads, batch::fk_jacobian, width, |c, o| {
        c.joints_world(model);
        c.geometric_jacobian(o)
    })
}

/// Lengths of every cable, in the model's cable order `(N, cables)` (m).
pub fn cable_lengths(model: &Model, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let m = model.cables.len();
    kinematics(model, theta, threads, batch::cable_lengths, m, |c, o| {
        for (k, v) in o.iter_mut().enumerate() {
            *v = c.cable_length(model, model, k, None);
        }
    })
}

/// Cable Jacobians `(N, cables, n)` (m/rad).
pub fn cable_jacobian(model: &Model, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let (m, n) = (model.cables.len(), model.n());
    kinematics(
        model,
        theta,
        threads,
        batch::cable_jacobian,
        m * n,
        |c, o| {
            for k in 0..m {
                c.cable_jacobian_row(model, model, k, &mut o[k * n..(k + 1) * n]);
            }
        },
    )
}

/// Joint-limit checks `(N,)`.
pub fn within_limits(model: &Model, theta: &[f64], threads: usize) -> Result<Vec<bool>> {
    let n = model.n();
    let rows = rows_of("theta", theta, n)?;
    let limits = model.limits();
    Ok(split_rows(rows, threads, |r| {
        r.map(|i| limits.contains(&theta[i * n..(i + 1) * n]))
            .collect::<Vec<bool>>()
    })
    .concat())
}

/// The cable solve of a batch: lengths `(N, m_pos)` of the position cables
/// (m), `seed (N, n)` or zeros. A planar arm by `method` (closed form,
/// Newton or both); a spatial arm has no closed form: `auto` and `newton`
/// run the general solve, `closed_form` is an error. A row that fails with
/// a length outside [`Model::cable_length_bounds`] is reported
/// `unreachable` (no configuration realises it), whatever the solver saw.
pub fn solve_cables(
    model: &Model,
    lengths: &[f64],
    seed: Option<&[f64]>,
    method: CableMethod,
    opts: &SolveOptions,
    threads: usize,
) -> Result<BatchSolution> {
    let mut out = solve_cables_by_kind(model, lengths, seed, method, opts, threads)?;
    let bounds = model.cable_length_bounds();
    let pos = model.position_cables();
    let m = pos.len();
    for (i, reason) in out.reason.iter_mut().enumerate() {
        if out.converged[i] {
            continue;
        }
        let row = &lengths[i * m..(i + 1) * m];
        let outside = row.iter().zip(&pos).any(|(l, &c)| {
            let [lo, hi] = bounds[c];
            // a margin of the solve's tolerance and of rounding
            let slack = opts.tol + 1e-12 * hi;
            *l < lo - slack || *l > hi + slack
        });
        if outside {
            *reason = Reason::Unreachable as u8;
        }
    }
    Ok(out)
}

fn solve_cables_by_kind(
    model: &Model,
    lengths: &[f64],
    seed: Option<&[f64]>,
    method: CableMethod,
    opts: &SolveOptions,
    threads: usize,
) -> Result<BatchSolution> {
    if planar_evaluator(model, model) {
        return batch::solve_cables(model, lengths, seed, method, opts, threads);
    }
    if method == CableMethod::ClosedForm {
        return Err(CdsmError::Option {
            name: "method".into(),
            problem:
                "a spatial arm's cable solve has no closed form (its joints are not all parallel); \
                      use 'auto' or 'newton'"
                    .into(),
        });
    }
    solve_cables_general::<Spatial>(model, lengths, seed, opts, threads)
}

/// Rows per pack of the general cable solve's Newton phase on lanes.
pub const PACK: usize = 4;
type P = Pack<PACK>;

/// The general cable solve of a batch (an arm without a planar view):
/// packs of [`PACK`] rows through the Newton phase on lanes
/// ([`CableNewton`], compiled for the machine's instruction set by `pulp`'s
/// dispatch), the rows that leave it through the cable solver
/// ([`CableSolver`], there the chain's evaluator) from their seeds.
pub fn solve_cables_general<G: Group>(
    model: &Model,
    lengths: &[f64],
    seed: Option<&[f64]>,
    opts: &SolveOptions,
    threads: usize,
) -> Result<BatchSolution> {
    let (n, m) = (model.n(), model.position_cables().len());
    let rows = rows_of("lengths", lengths, m)?;
    let seed = seeds(seed, rows, n)?;
    opts.check()?;
    let mut traverse = Vec::new();
    Broadcast::traversals(model, model, &model.position_cables(), &mut traverse);
    let arch = pulp::Arch::new();
    let parts = split_rows(rows, threads, |r| {
        arch.dispatch(SolveRows::<G> {
            model,
            traverse: &traverse,
            lengths,
            seed,
            opts,
            rows: r,
            kind: PhantomData,
        })
    });
    Ok(BatchSolution::concat(parts))
}

/// The rows `rows` of [`solve_cables_general`], in packs.
struct SolveRows<'a, G> {
    model: &'a Model,
    traverse: &'a [f64],
    lengths: &'a [f64],
    seed: Option<&'a [f64]>,
    opts: &'a SolveOptions,
    rows: Range<usize>,
    kind: PhantomData<G>,
}

impl<G: Group> WithSimd for SolveRows<'_, G> {
    type Output = BatchSolution;

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> BatchSolution {
        let SolveRows {
            model,
            traverse,
            lengths,
            seed,
            opts,
            rows,
            ..
        } = self;
        let (n, m) = (model.n(), model.position_cables().len());
        let arm = Broadcast::new(model, traverse);
        let mut out = BatchSolution::with_capacity(rows.len(), n);
        let mut lanes = CableNewton::<P, G::Frame<P>>::new(model, *opts);
        let mut solver = CableSolver::<G::Frame<f64>>::new(model, model, CableMethod::Auto, *opts);
        let mut th = vec![0.0; n];
        let limits = model.limits();
        let seed_of = |i: usize, k: usize| seed.map_or(0.0, |s| s[i * n + k]);
        for start in rows.clone().step_by(PACK) {
            let count = PACK.min(rows.end - start);
            // a short pack repeats its last row in the spare lanes
            for b in 0..PACK {
                let i = start + b.min(count - 1);
                for (k, x) in lanes.x.iter_mut().enumerate() {
                    x.0[b] = seed_of(i, k);
                }
                for (k, t) in lanes.target.iter_mut().enumerate() {
                    t.0[b] = lengths[i * m + k];
                }
            }
            let o = lanes.run(model, &arm);
            for b in 0..count {
                let i = start + b;
                let st = match o.status(b) {
                    Some(st) => {
                        for (t, x) in th.iter_mut().zip(&lanes.x) {
                            *t = x.0[b];
                        }
                        st
                    }
                    None => {
                        for (k, t) in th.iter_mut().enumerate() {
                            *t = seed_of(i, k);
                        }
                        solver.solve(&lengths[i * m..(i + 1) * m], &mut th)
                    }
                };
                out.push_row(&th, st, limits.contains(&th));
            }
        }
        out
    }
}

/// The loads of a statics batch: the robot file's gravity and force-cable
/// tensions unless given (`gravity` (3,) m/s²; `force` per force cable, N,
/// shared `(f,)` or per row `(N, f)`), and the tip wrench `[F (3), M]` (N, N
/// m; `M`: 1 planar, 3 spatial), shared or per row; all in the base frame.
pub struct Loads<'a> {
    pub gravity: Option<[f64; 3]>,
    pub force: Option<&'a [f64]>,
    pub wrench: Option<&'a [f64]>,
}

/// The position-cable tensions at a batch of configurations `(N, m_pos)`
/// (N) and whether they hold the arm with every tension above `floor` (N)
/// `(N,)`, under `loads`. As many position cables as joints: the balance
/// has one solution, returned even where a cable would have to push (then
/// not feasible; NaN where it is singular), feasible when every tension is
/// strictly above the floor. More: the minimum-norm set at or above the
/// floor (`crate::qp`), NaN rows where none exists. With `sliding`, friction
/// in the holes in a bounding sliding state (`docs/model.md`, "Friction in
/// the holes"; `None`: frictionless): the tensions are then the routing's (at
/// the actuators).
pub fn tensions(
    model: &Model,
    theta: &[f64],
    loads: &Loads,
    floor: f64,
    sliding: Option<Sliding>,
    threads: usize,
) -> Result<(Vec<f64>, Vec<bool>)> {
    if let Some(s) = sliding {
        s.check()?;
    }
    model.kind.visit(Tensions {
        model,
        theta,
        loads,
        floor,
        sliding,
        threads,
    })
}

/// [`tensions`] over the model's motion group.
struct Tensions<'a> {
    model: &'a Model,
    theta: &'a [f64],
    loads: &'a Loads<'a>,
    floor: f64,
    sliding: Option<Sliding>,
    threads: usize,
}

impl Visit for Tensions<'_> {
    type Out = Result<(Vec<f64>, Vec<bool>)>;
    fn visit<G: Group>(self) -> Self::Out {
        let Tensions {
            model,
            theta,
            loads,
            floor,
            sliding,
            threads,
        } = self;
        tensions_k::<G>(model, theta, loads, floor, sliding, threads)
    }
}

fn tensions_k<G: Group>(
    model: &Model,
    theta: &[f64],
    loads: &Loads,
    floor: f64,
    sliding: Option<Sliding>,
    threads: usize,
) -> Result<(Vec<f64>, Vec<bool>)> {
    if !floor.is_finite() {
        return Err(CdsmError::Option {
            name: "min_tension".into(),
            problem: format!("must be finite (N), got {floor}"),
        });
    }
    let n = model.n();
    let rows = rows_of("theta", theta, n)?;
    let nf = model.cables.len() - model.position_cables().len();
    let couple = model.kind.task() - model.kind.dim();
    let wrench = shared_or_rows("tip_wrench", loads.wrench, 3 + couple, rows)?;
    let force = shared_or_rows("force", loads.force, nf, rows)?;
    if let Some(g) = loads.gravity {
        crate::error::check_finite("gravity", &g)?;
    }
    let g = loads.gravity.unwrap_or(model.gravity);
    let m = model.position_cables().len();
    let parts = split_rows(rows, threads, |r| {
        let mut chain = Chain::<f64, G::Frame<f64>>::new(model);
        let mut bal = Balance::<f64>::new(model);
        let mut t = vec![0.0; m];
        let mut out = (Vec::with_capacity(r.len() * m), Vec::with_capacity(r.len()));
        let holes = Holes::of(model);
        let mut profile = Profile::<f64>::new(model);
        let mobil = sliding.map(|s| s.mobilisations(model, &holes));
        for i in r {
            chain.at(model, model, &theta[i * n..(i + 1) * n]);
            let w = row_of(wrench, 3 + couple, i).unwrap_or(&[0.0; 6][..3 + couple]);
            let wrench = Wrench {
                force: [w[0], w[1], w[2]],
                couple: &w[3..],
            };
            match (sliding, &mobil) {
                (Some(s), Some(z)) => {
                    let route = model.cable.routing_length;
                    profile.at(model, model, &chain, &holes, z, s.mu, route);
                    bal.at_friction(
                        model,
                        model,
                        &mut chain,
                        g,
                        wrench,
                        row_of(force, nf, i),
                        &profile.gap,
                    );
                }
                _ => bal.at_with(model, model, &mut chain, g, wrench, row_of(force, nf, i)),
            }
            let ok = held(&mut bal, floor, &mut t);
            out.0.extend_from_slice(&t);
            out.1.push(ok);
        }
        out
    });
    let mut all = (Vec::new(), Vec::new());
    for (t, ok) in parts {
        all.0.extend(t);
        all.1.extend(ok);
    }
    Ok(all)
}

/// Solves a balance for its position tensions `t` (N) and says whether
/// they hold the arm above `floor` (N). As many position cables as joints:
/// the one solution (NaN where singular), held when every tension is
/// strictly above the floor; more: the minimum-norm set at or above the
/// floor, NaN where none exists.
pub(crate) fn held(bal: &mut Balance<f64>, floor: f64, t: &mut [f64]) -> bool {
    if bal.n == bal.m {
        if !bal.solve_square(t) {
            t.fill(f64::NAN);
        }
        t.iter().all(|v| *v > floor)
    } else {
        match above_floor(bal, floor) {
            Some(s) => {
                t.copy_from_slice(&s);
                true
            }
            None => {
                t.fill(f64::NAN);
                false
            }
        }
    }
}

/// The minimum-norm tensions of a balance above `floor` (N), if any.
fn above_floor(bal: &Balance<f64>, floor: f64) -> Option<Vec<f64>> {
    let a = faer::Mat::<f64>::from_fn(bal.n, bal.m, |j, i| bal.a[j * bal.m + i]);
    min_norm_active(&a, &bal.b, floor).map(|s| s.t)
}

/// A planar arm's holes after the paper's per-disk hole-height error `dh
/// (n,)` m, in the planar layout `(2n, n+1, 2, 2)` flat
/// ([`crate::robot::PlanarView::hole_height_error_into`]); an error naming
/// `hole_height_error` for another kind.
pub fn hole_height_error(model: &Model, dh: &[f64]) -> Result<Vec<f64>> {
    let r = model.planar_only("hole_height_error")?;
    if dh.len() != r.n() {
        return Err(CdsmError::Shape {
            name: "dh".into(),
            expected: format!("({},)", r.n()),
            got: format!("{} values", dh.len()),
        });
    }
    crate::error::check_finite("dh", dh)?;
    let mut out = vec![0.0; r.holes.len()];
    r.hole_height_error_into(dh, &mut out);
    Ok(out)
}
