//! Batched calls on an arm of either kind ([`Model`]), over threads: the
//! kinematics, the cable solve, the pose IK, the statics and the Monte
//! Carlo of its errors. A planar arm runs its fast paths (the planar
//! drivers of [`crate::batch`]: closed forms, SIMD, the triangular Newton);
//! every arm can run the general ones on the one model's chain, which are
//! the only ones of a spatial arm. SI units; arrays row-major.

use crate::accuracy::{HoleErrors, McStats};
use crate::batch;
use crate::chain::{Broadcast, Chain};
use crate::error::{CdsmError, Result};
use crate::friction::{Holes, Profile, Sliding};
use crate::kinds::{log_so3, Frame, Group, Se3, Spatial, Vector, Visit};
use crate::lm::Reason;
use crate::model::Model;
use crate::qp::min_norm_active;
use crate::real::pack::Pack;
use crate::real::Lane;
use crate::rows::{
    row_of, rows_exactly, rows_of, seeds, shared_or_rows, split_rows, BatchSolution,
};
use crate::solve::{CableMethod, CableNewton, CableSolve, SolveOptions};
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
    match model.planar() {
        Some(r) => batch::fk(r, theta, threads),
        None => map_chain::<Spatial>(model, theta, 6, threads, |c, o| c.end().task(o)),
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
    match model.planar() {
        Some(r) => batch::fk_jacobian(r, theta, threads),
        None => map_chain::<Spatial>(model, theta, 6 * model.n(), threads, |c, o| {
            c.joints_world(model);
            c.geometric_jacobian(o)
        }),
    }
}

/// Lengths of every cable, in the model's cable order `(N, cables)` (m).
pub fn cable_lengths(model: &Model, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let m = model.cables.len();
    match model.planar() {
        Some(r) => batch::cable_lengths(r, theta, threads),
        None => map_chain::<Spatial>(model, theta, m, threads, |c, o| {
            for (k, v) in o.iter_mut().enumerate() {
                *v = c.cable_length(model, model, k, None);
            }
        }),
    }
}

/// Cable Jacobians `(N, cables, n)` (m/rad).
pub fn cable_jacobian(model: &Model, theta: &[f64], threads: usize) -> Result<Vec<f64>> {
    let (m, n) = (model.cables.len(), model.n());
    match model.planar() {
        Some(r) => batch::cable_jacobian(r, theta, threads),
        None => map_chain::<Spatial>(model, theta, m * n, threads, |c, o| {
            for k in 0..m {
                c.cable_jacobian_row(model, model, k, &mut o[k * n..(k + 1) * n]);
            }
        }),
    }
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
    if let Some(r) = model.planar() {
        return batch::solve_cables(r, lengths, seed, method, opts, threads);
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

/// The general cable solve of a batch (any kind): packs of [`PACK`] rows
/// through the Newton phase on lanes ([`CableNewton`], compiled for the
/// machine's instruction set by `pulp`'s dispatch), the rows that leave it
/// through [`CableSolve`] from their seeds.
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
        let mut solver = CableSolve::<G::Frame<f64>>::new(model, *opts);
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
                        solver.solve(model, model, &lengths[i * m..(i + 1) * m], &mut th)
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
fn held(bal: &mut Balance<f64>, floor: f64, t: &mut [f64]) -> bool {
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

/// Monte Carlo of an arm's errors (`theta0 (N, n)` rad, `dl (S, m_pos)` m):
/// one call for either kind, its kernel chosen here. A planar arm runs its
/// fast kernel ([`crate::accuracy::monte_carlo`]: closed form across lanes,
/// `method`; hole errors as per-disk heights `dh (S, n)` or every hole
/// coordinate `dholes` in the planar layout, at most one of them; quantities
/// dX, dY, dphi, |dXY|); a spatial arm the general solve
/// ([`general_monte_carlo`]: `dholes (S, 3H)` over [`Model::flat_holes`];
/// `dh` refused). Both with the optional slack check.
#[allow(clippy::too_many_arguments)]
pub fn monte_carlo(
    model: &Model,
    theta0: &[f64],
    dl: &[f64],
    dh: Option<&[f64]>,
    dholes: Option<&[f64]>,
    method: CableMethod,
    opts: &SolveOptions,
    check_slack: bool,
    threads: usize,
) -> Result<McStats> {
    let Some(r) = model.planar() else {
        if dh.is_some() {
            return Err(CdsmError::Option {
                name: "dh".into(),
                problem: "per-pair hole heights are planar; a spatial arm's Monte Carlo takes \
                          `dholes`"
                    .into(),
            });
        }
        return general_monte_carlo(model, theta0, dl, dholes, opts, check_slack, threads);
    };
    let holes = match (dh, dholes) {
        (None, None) => HoleErrors::None,
        (Some(a), None) => HoleErrors::PerPair(a),
        (None, Some(a)) => HoleErrors::Full(a),
        _ => {
            return Err(CdsmError::Option {
                name: "dh, dholes".into(),
                problem: "give at most one of them".into(),
            })
        }
    };
    crate::accuracy::monte_carlo(r, theta0, dl, holes, method, opts, check_slack, threads)
}

/// First-order sensitivities at `theta (N, n)`: a planar arm's closed
/// forms ([`crate::sensitivity::sensitivities`]: `cable`, `pair` and
/// `holes` in the planar layout), any other arm's general ones
/// ([`crate::sensitivity::general`]: `holes` over [`Model::flat_holes`]).
pub fn sensitivities(
    model: &Model,
    theta: &[f64],
    with_holes: bool,
    threads: usize,
) -> Result<crate::sensitivity::Sensitivities> {
    match model.planar() {
        Some(r) => crate::sensitivity::sensitivities(r, theta, with_holes, threads),
        None => crate::sensitivity::general(model, theta, with_holes, threads),
    }
}

/// A planar arm's holes after the paper's per-disk hole-height error `dh
/// (n,)` m, in the planar layout `(2n, n+1, 2, 2)` flat
/// ([`crate::robot::Robot::hole_height_error_into`]); an error naming
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

/// Monte Carlo of an arm's errors by the general solve: for every sample
/// `s` (errors `dl[s]` on the position cables, m, and `dholes[s]` on every
/// hole, as [`Model::flat_holes`], m, when given) and every configuration
/// `theta0[j]`, the cable solve seeded at `theta0[j]` and the end frame's
/// deviation, reduced to [`McStats`] with the spatial quantities `dX, dY,
/// dZ, |dXYZ|` (m) and the rotation angle (rad). With `check_slack`, every
/// converged sample's configuration is also checked for a set of position
/// tensions holding the arm under its gravity and force cables (the
/// perturbed holes for the moment arms; [`tensions`] at floor 0) and
/// counted in `slack` when none exists. (A planar arm's Monte-Carlo kernel
/// is [`crate::accuracy::monte_carlo`].)
pub fn general_monte_carlo(
    model: &Model,
    theta0: &[f64],
    dl: &[f64],
    dholes: Option<&[f64]>,
    opts: &SolveOptions,
    check_slack: bool,
    threads: usize,
) -> Result<McStats> {
    let n = model.n();
    let m = model.position_cables().len();
    let rows = rows_of("theta0", theta0, n)?;
    let samples = crate::accuracy::check_samples(rows_of("dl", dl, m)?)?;
    opts.check()?;
    let nominal_holes = model.flat_holes();
    let h = nominal_holes.len();
    let models: Vec<Model> = match dholes {
        None => Vec::new(),
        Some(d) => {
            rows_exactly("dholes", d, h, samples)?;
            (0..samples)
                .map(|s| {
                    let flat: Vec<f64> = nominal_holes
                        .iter()
                        .zip(&d[s * h..(s + 1) * h])
                        .map(|(a, b)| a + b)
                        .collect();
                    model.with_flat_holes(&flat)
                })
                .collect::<Result<_>>()?
        }
    };
    let model_of = |s: usize| models.get(s).unwrap_or(model);
    // every arm's traversals once (the nominal one's when no hole moves)
    let pos = model.position_cables();
    let traverse: Vec<Vec<f64>> = (0..samples.min(models.len()).max(1))
        .map(|s| {
            let mut t = Vec::new();
            Broadcast::traversals(model_of(s), model_of(s), &pos, &mut t);
            t
        })
        .collect();
    let arch = pulp::Arch::new();
    let parts = split_rows(rows, threads, |r| {
        arch.dispatch(McRows {
            model,
            models: &models,
            traverse: &traverse,
            theta0,
            dl,
            opts,
            check_slack,
            rows: r,
        })
    });
    let mut out = McStats::with_quantities(0, SPATIAL_QUANTITIES);
    for p in parts {
        out.extend(p);
    }
    Ok(out)
}

/// The configurations `rows` of [`monte_carlo`]: packs of [`PACK`]
/// configurations, each sample's solves of a pack in lanes (sharing the
/// sample's arm), the lanes that leave the Newton phase through
/// [`CableSolve`]; every configuration gets its samples in sample order.
struct McRows<'a> {
    model: &'a Model,
    /// the samples' arms (empty: every sample the nominal one)
    models: &'a [Model],
    traverse: &'a [Vec<f64>],
    theta0: &'a [f64],
    dl: &'a [f64],
    opts: &'a SolveOptions,
    check_slack: bool,
    rows: Range<usize>,
}

/// Lane `b` of a pack of frames.
fn lane_frame(f: &Se3<P>, b: usize) -> Se3<f64> {
    Se3 {
        r: std::array::from_fn(|i| std::array::from_fn(|k| f.r[i][k].0[b])),
        t: std::array::from_fn(|i| f.t[i].0[b]),
    }
}

/// A Monte-Carlo sample's quantities: the end frame `end` against the
/// nominal `end0`: dX, dY, dZ, |dXYZ| (m) and the rotation angle (rad).
fn sample_quantities(end0: &Se3<f64>, end: &Se3<f64>) -> [f64; SPATIAL_QUANTITIES] {
    let d = end.t.sub(end0.t);
    let rel: [[f64; 3]; 3] = std::array::from_fn(|a| {
        std::array::from_fn(|b| (0..3).map(|k| end0.r[k][a] * end.r[k][b]).sum())
    });
    [d[0], d[1], d[2], d.norm(), log_so3(&rel).norm()]
}

impl WithSimd for McRows<'_> {
    type Output = McStats;

    #[inline(always)]
    fn with_simd<S: Simd>(self, _simd: S) -> McStats {
        let McRows {
            model,
            models,
            traverse,
            theta0,
            dl,
            opts,
            check_slack,
            rows: r,
        } = self;
        let (n, pos) = (model.n(), model.position_cables());
        let m = pos.len();
        let samples = dl.len() / m;
        let model_of = |s: usize| models.get(s).unwrap_or(model);
        let mut stats = McStats::with_quantities(r.len(), SPATIAL_QUANTITIES);
        let mut lanes = CableNewton::<P, Se3<P>>::new(model, *opts);
        let mut solver = CableSolve::<Se3<f64>>::new(model, *opts);
        let mut chain = Chain::<f64, Se3<f64>>::new(model);
        let (mut l0, mut end0) = (vec![0.0; PACK * m], [Se3::<f64>::identity(); PACK]);
        let (mut target, mut th) = (vec![0.0; m], vec![0.0; n]);
        let mut bal = Balance::<f64>::new(model);
        let mut t = vec![0.0; m];
        let zero = [0.0; 3];
        for start in r.clone().step_by(PACK) {
            let count = PACK.min(r.end - start);
            for b in 0..count {
                let t0 = &theta0[(start + b) * n..(start + b + 1) * n];
                chain.at(model, model, t0);
                chain.world(model, model);
                for (k, &c) in pos.iter().enumerate() {
                    l0[b * m + k] = chain.cable_length(model, model, c, None);
                }
                end0[b] = *chain.end();
            }
            stats.open(start - r.start, count);
            for s in 0..samples {
                let ms = model_of(s);
                let arm = Broadcast::new(ms, &traverse[s.min(traverse.len() - 1)]);
                let ds = &dl[s * m..(s + 1) * m];
                // a short pack repeats its last configuration in the spare lanes
                for b in 0..PACK {
                    let (i, bb) = (start + b.min(count - 1), b.min(count - 1));
                    for (k, x) in lanes.x.iter_mut().enumerate() {
                        x.0[b] = theta0[i * n + k];
                    }
                    for (k, tk) in lanes.target.iter_mut().enumerate() {
                        tk.0[b] = l0[bb * m + k] + ds[k];
                    }
                }
                let o = lanes.run(ms, &arm);
                if P::any(o.converged) {
                    lanes.chain.world(ms, &arm);
                }
                for b in 0..count {
                    let (i, j) = (start + b, start + b - r.start);
                    let end = if o.status(b).is_some() {
                        for (tk, x) in th.iter_mut().zip(&lanes.x) {
                            *tk = x.0[b];
                        }
                        lane_frame(lanes.chain.end(), b)
                    } else {
                        for (k, tk) in target.iter_mut().enumerate() {
                            *tk = l0[b * m + k] + ds[k];
                        }
                        th.copy_from_slice(&theta0[i * n..(i + 1) * n]);
                        if !solver.solve(ms, ms, &target, &mut th).converged {
                            stats.failed[j] += 1;
                            continue;
                        }
                        f64::cos_sin(&th, &mut chain.cs);
                        chain.at_cs(ms, ms, &th);
                        chain.world(ms, ms);
                        *chain.end()
                    };
                    stats.add_values(j, &sample_quantities(&end0[b], &end));
                    if check_slack {
                        let wrench = Wrench {
                            force: zero,
                            couple: &zero,
                        };
                        chain.at(ms, ms, &th);
                        bal.at(ms, ms, &mut chain, ms.gravity, wrench);
                        if !held(&mut bal, 0.0, &mut t) {
                            stats.slack[j] += 1;
                        }
                    }
                }
            }
            stats.close();
        }
        stats
    }
}

/// Quantities of a spatial Monte-Carlo sample: dX, dY, dZ, |dXYZ| (m),
/// rotation angle (rad).
pub const SPATIAL_QUANTITIES: usize = 5;
