//! Friction in the holes of an elastic arm (`docs/model.md`, "Elastic arms
//! in the plant", "Friction in the holes"): the capstan of
//! [`crate::friction`] with its sequence semantics (every hole's
//! mobilisation `z` from the scan along the nominal motion, here the nominal
//! frictionless elastic equilibria of the commands) in the elastic settle.
//!
//! Per command the residual (N m)
//!
//! `r(q) = K (q - rest) + sum_c T_(c,0)(q) E_(c,gap(j)) dL_c/dq_j - tau(q)`
//!
//! with every elastic cable's actuator tension from its compatibility with
//! the capstan profile's mean factor `ebar_c`: a displacement cable
//! `T_0 = (L_c - l_c + P_c / k_s,c) / (1/k_s,c + (L0_c + L_r)(ebar_c - 1)/(E A))`,
//! a position cable `T_0 = E A (L_c - l_c) / ((l_c + L_r) ebar_c)`, 0 where
//! that is not positive, the cap above it; a force cable its set tension.
//! No potential: Newton on `r` with its Jacobian (forward mode in jets), a
//! backtracking line search on `|r|`, from the command's frictionless
//! equilibrium; the derivatives by the implicit function theorem of the
//! non-symmetric system, `dq/dp = -(dr/dq)^-1 dr/dp`. At `mu = 0` the plant
//! does not come here (the frictionless settle, bit for bit) but for the
//! derivatives when `mu` is free (one-sided, full slip).

use super::{elastic_settle, observe, realised, Params, Plant, Sequence, Settled, J, JET};
use crate::chain::Chain;
use crate::elastic::XTOL;
use crate::friction::{hole_geometry, mobilisation, Holes, Motion, Profile};
use crate::kinds::{Frame, Group};
use crate::model::{Mode, Model};
use crate::real::{Arith, Real};
use crate::rows::split_rows;
use crate::solve::SolveOptions;
use faer::linalg::solvers::Solve;
use faer::Mat;

/// [`super::REASONS`]' code of a command whose friction Jacobian is singular.
pub(super) const SINGULAR: u8 = 7;

/// Backtracking halvings of the line search on `|r|`.
const HALVINGS: usize = 40;

/// A Newton step (rad) at or below which a step the line search refuses is
/// taken whole: `|r|` is at its rounding level there and the step within
/// Newton's local convergence.
const ROUNDING_STEP: f64 = 1e-8;

/// The cable laws of the friction residual in a scalar, per model cable.
struct Cables<S> {
    /// Commanded index of every cable (`None`: a force cable).
    index: Vec<Option<usize>>,
    displacement: Vec<bool>,
    /// Displacement cables: `1/k_s` (m/N) and the cable's share of it,
    /// `(L0 + L_r)/(E A)` (m/N), `L0` on the plant's arm.
    inv: Vec<S>,
    share: Vec<S>,
    pre: Vec<f64>,
    cap: Vec<f64>,
    ea: f64,
    lr: f64,
    /// The disk (0-based) of every joint.
    disk: Vec<usize>,
}

impl<S: Real> Cables<S> {
    fn new<F: Frame<S>>(model: &Model, prm: &Params<S>, chain: &mut Chain<S, F>) -> Self {
        let cmd = super::commanded_cables(model);
        let ea = 1.0 / model.cable.compliance();
        let lr = model.cable.routing_length;
        let rest: Vec<S> = model.joints.iter().map(|j| S::cst(j.rest)).collect();
        chain.at(model, &prm.arm, &rest);
        let mut disk = vec![0; model.n()];
        for (k, d) in model.disks.iter().enumerate() {
            disk[d.joints.clone()].fill(k);
        }
        let mut out = Cables {
            index: vec![None; model.cables.len()],
            displacement: Vec::with_capacity(cmd.len()),
            inv: Vec::with_capacity(cmd.len()),
            share: Vec::with_capacity(cmd.len()),
            pre: Vec::with_capacity(cmd.len()),
            cap: Vec::with_capacity(cmd.len()),
            ea,
            lr,
            disk,
        };
        for (i, &c) in cmd.iter().enumerate() {
            out.index[c] = Some(i);
            let cable = &model.cables[c];
            let d = cable.mode == Mode::Displacement;
            out.displacement.push(d);
            if d {
                let l0 = chain.cable_length(model, &prm.arm, c, None);
                let share = (l0 + lr) / ea;
                out.inv.push(share + 1.0 / cable.actuator.stiffness);
                out.share.push(share);
                out.pre.push(cable.actuator.pretension);
                out.cap.push(cable.actuator.max_tension);
            } else {
                out.inv.push(S::cst(f64::NAN));
                out.share.push(S::cst(f64::NAN));
                out.pre.push(0.0);
                out.cap.push(f64::INFINITY);
            }
        }
        out
    }

    /// The actuator tension `T_0` (N) of cable `c` of path length `len` (m)
    /// with the mean capstan factor `ebar`, for the realised rest lengths
    /// `real` of the commanded cables; `None` where it is slack.
    fn tension(&self, model: &Model, c: usize, len: S, real: &[S], ebar: S) -> Option<S> {
        let Some(i) = self.index[c] else {
            return Some(S::cst(model.cables[c].tension));
        };
        let t = if self.displacement[i] {
            (len - real[i] + self.inv[i] * self.pre[i])
                / (self.inv[i] + self.share[i] * (ebar - 1.0))
        } else {
            (len - real[i]) * self.ea / ((real[i] + self.lr) * ebar)
        };
        if t.val() <= 0.0 {
            None
        } else if t.val() >= self.cap[i] {
            Some(S::cst(self.cap[i]))
        } else {
            Some(t)
        }
    }
}

/// Buffers of [`residual`].
struct Work<S: Real, F: Frame<S>> {
    chain: Chain<S, F>,
    profile: Profile<S>,
    row: Vec<S>,
    tau: Vec<S>,
    r: Vec<S>,
}

impl<S: Real, F: Frame<S>> Work<S, F> {
    fn new(model: &Model) -> Self {
        let n = model.n();
        Work {
            chain: Chain::new(model),
            profile: Profile::new(model),
            row: vec![S::cst(0.0); n],
            tau: vec![S::cst(0.0); n],
            r: vec![S::cst(0.0); n],
        }
    }
}

/// The friction residual `r(q)` (N m, module doc) of the plant `prm` for
/// one command (realised rest lengths `real`, mobilisations `z` per hole),
/// into `w.r`.
#[allow(clippy::too_many_arguments)]
fn residual<S: Real, F: Frame<S>>(
    model: &Model,
    prm: &Params<S>,
    cab: &Cables<S>,
    holes: &Holes,
    real: &[S],
    z: &[S],
    q: &[S],
    w: &mut Work<S, F>,
) {
    let n = model.n();
    let kd = model.disks.len();
    w.chain.at(model, &prm.arm, q);
    w.profile
        .at(model, &prm.arm, &w.chain, holes, z, prm.mu, cab.lr);
    for (j, joint) in model.joints.iter().enumerate() {
        w.r[j] = (q[j] - joint.rest) * (prm.spring[j] * joint.stiffness);
    }
    for c in 0..model.cables.len() {
        let len = w.chain.cable_length_and_row(model, &prm.arm, c, &mut w.row);
        let Some(t) = cab.tension(model, c, len, real, w.profile.mean[c]) else {
            continue;
        };
        for j in 0..n {
            w.r[j] += t * w.profile.gap[c * kd + cab.disk[j]] * w.row[j];
        }
    }
    super::subtract_gravity(model, &prm.arm, &mut w.chain, &mut w.tau, &mut w.r);
}

/// The constants of one plant's friction residual in jets (no direction
/// seeded): its parameters, cable laws, realised lengths and mobilisations.
struct Constants<'a> {
    prm: &'a Params<J>,
    /// Commanded cables.
    m: usize,
    cab: Cables<J>,
    real: Vec<J>,
    z: Vec<J>,
}

/// One chunk of [`JET`] free directions: the plant's parameters seeded along
/// them, its cable laws, realised lengths and mobilisations in jets.
struct Chunk {
    prm: Params<J>,
    cab: Cables<J>,
    real: Vec<J>,
    z: Vec<J>,
}

impl<'a> Constants<'a> {
    /// Those of `plant` over the commands of `seq`.
    fn new<G: Group>(plant: &'a Plant<G>, seq: &Sequence) -> Self {
        let model = plant.model;
        Constants {
            prm: &plant.cprm,
            m: seq.m,
            cab: Cables::new(model, &plant.cprm, &mut Chain::<J, G::Frame<J>>::new(model)),
            real: plant.realised(seq).into_iter().map(J::cst).collect(),
            z: mobilisations::<f64, G>(model, seq, plant.prm.mu)
                .into_iter()
                .map(J::cst)
                .collect(),
        }
    }
}

/// `dr/dq` (`n x n`, N m/rad) at `q` for command `j`, in jets, `JET`
/// columns per evaluation; `r(q)` into `r`.
fn jacobian_q<F: Frame<J>>(
    model: &Model,
    k: &Constants,
    holes: &Holes,
    j: usize,
    q: &[f64],
    w: &mut Work<J, F>,
    r: &mut [f64],
) -> Mat<f64> {
    let n = model.n();
    let (m, h) = (k.m, holes.total);
    let mut a = Mat::<f64>::zeros(n, n);
    let mut qj = vec![J::default(); n];
    for chunk in 0..n.div_ceil(JET) {
        for (i, x) in qj.iter_mut().enumerate() {
            *x = if i >= chunk * JET {
                J::seeded(q[i], i - chunk * JET)
            } else {
                J::cst(q[i])
            };
        }
        residual(
            model,
            k.prm,
            &k.cab,
            holes,
            &k.real[j * m..(j + 1) * m],
            &k.z[j * h..(j + 1) * h],
            &qj,
            w,
        );
        let width = JET.min(n - chunk * JET);
        for (row, v) in w.r.iter().enumerate() {
            for s in 0..width {
                a[(row, chunk * JET + s)] = v.d[s];
            }
        }
    }
    for (ri, v) in r.iter_mut().zip(&w.r) {
        *ri = v.val();
    }
    a
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// Newton on the friction residual of command `j` from `q` (rad, the
/// answer in place): `(converged, code of REASONS)`.
#[allow(clippy::too_many_arguments)]
fn settle_one<F: Frame<J>, Ff: Frame<f64>>(
    model: &Model,
    prm: &Params<f64>,
    cab: &Cables<f64>,
    k: &Constants,
    holes: &Holes,
    j: usize,
    q: &mut [f64],
    max_iter: u32,
    w: &mut Work<J, F>,
    wf: &mut Work<f64, Ff>,
) -> (bool, u8) {
    let n = model.n();
    let h = holes.total;
    let m = cab.pre.len();
    let zf: Vec<f64> = k.z[j * h..(j + 1) * h].iter().map(|v| v.val()).collect();
    let real: Vec<f64> = k.real[j * m..(j + 1) * m].iter().map(|v| v.val()).collect();
    let mut r = vec![0.0; n];
    let mut qt = vec![0.0; n];
    for _ in 0..max_iter {
        let a = jacobian_q(model, k, holes, j, q, w, &mut r);
        if !r.iter().all(|v| v.is_finite())
            || !a.col_iter().all(|c| c.iter().all(|v| v.is_finite()))
        {
            return (false, 3);
        }
        let rhs = Mat::<f64>::from_fn(n, 1, |i, _| -r[i]);
        let s = a.partial_piv_lu().solve(&rhs);
        let step: Vec<f64> = (0..n).map(|i| s[(i, 0)]).collect();
        if !step.iter().all(|v| v.is_finite()) {
            return (false, SINGULAR);
        }
        let smax = step.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if smax <= XTOL {
            for (x, d) in q.iter_mut().zip(&step) {
                *x += d;
            }
            return (true, 0);
        }
        let r0 = norm(&r);
        let mut t = 1.0;
        let mut taken = false;
        for _ in 0..HALVINGS {
            for ((x, a), d) in qt.iter_mut().zip(q.iter()).zip(&step) {
                *x = a + t * d;
            }
            residual(model, prm, cab, holes, &real, &zf, &qt, wf);
            let rt = norm(&wf.r);
            if rt.is_finite() && rt <= (1.0 - 1e-4 * t) * r0 {
                taken = true;
                break;
            }
            t *= 0.5;
        }
        if !taken {
            if smax > ROUNDING_STEP {
                return (false, 2);
            }
            for ((x, a), d) in qt.iter_mut().zip(q.iter()).zip(&step) {
                *x = a + d;
            }
        }
        q.copy_from_slice(&qt);
    }
    (false, 1)
}

/// The compliance of the sticking band (1/N): the cable's own, `1 / (E A)`
/// (the actuator is proximal of every hole).
fn band_compliance(model: &Model) -> f64 {
    model.cable.compliance()
}

/// The mobilisation of every hole after every command of `seq` (`(commands,
/// H)`) for the friction `mu`.
pub(super) fn mobilisations<S: Real, G: Group>(model: &Model, seq: &Sequence, mu: S) -> Vec<S> {
    mobilisation(seq.motion::<G>(model), mu, S::cst(band_compliance(model)))
}

/// Every command of `seq` settled with friction in the holes, each from its
/// frictionless equilibrium ([`elastic_settle::settle_all`]); a command
/// that does not converge is flagged with its reason, its observation NaN.
pub(super) fn settle_all<G: Group>(
    plant: &Plant<G>,
    seq: &Sequence,
    opts: &SolveOptions,
    threads: usize,
) -> Settled {
    let base = elastic_settle::settle_all(plant, seq, opts);
    let model = plant.model;
    let n = model.n();
    let task = <G::Frame<f64> as Frame<f64>>::TASK;
    let count = seq.len();
    if count == 0 {
        return base;
    }
    let holes = Holes::of(model);
    let k = Constants::new(plant, seq);
    let cab = Cables::new(
        model,
        &plant.prm,
        &mut Chain::<f64, G::Frame<f64>>::new(model),
    );
    let parts = split_rows(count, threads, |range| {
        let mut w = Work::<J, G::Frame<J>>::new(model);
        let mut wf = Work::<f64, G::Frame<f64>>::new(model);
        let mut chain = Chain::<f64, G::Frame<f64>>::new(model);
        let mut o = vec![0.0; task];
        let mut out = Settled::default();
        for j in range {
            let mut q = base.theta[j * n..(j + 1) * n].to_vec();
            let (ok, reason) = if base.ok[j] {
                settle_one(
                    model,
                    &plant.prm,
                    &cab,
                    &k,
                    &holes,
                    j,
                    &mut q,
                    opts.max_iter,
                    &mut w,
                    &mut wf,
                )
            } else {
                (false, base.reason[j])
            };
            if ok {
                plant.observe(&q, &mut chain, &mut o);
                out.obs.extend_from_slice(&o);
            } else {
                q.fill(f64::NAN);
                out.obs.extend(std::iter::repeat_n(f64::NAN, task));
            }
            out.theta.extend_from_slice(&q);
            out.ok.push(ok);
            out.reason.push(reason);
        }
        out
    });
    Settled::joined(parts)
}

/// The derivatives `(commands, TASK, k)` of every settled command's
/// observation with respect to the parameters `free` (NaN where a command
/// did not settle or `dr/dq` is singular there): per command one LU of
/// `dr/dq`; per chunk of [`JET`] directions `dr/dp` at fixed `q` in jets
/// (the mobilisations' derivatives through the band), `dq/dp = -(dr/dq)^-1
/// dr/dp`, and the observation in jets along `(dq/dp, p)`.
pub(super) fn command_derivatives<G: Group>(
    plant: &Plant<G>,
    seq: &Sequence,
    set: &Settled,
    free: &[usize],
    threads: usize,
) -> Vec<f64> {
    let (theta, ok) = (&set.theta, &set.ok);
    let model = plant.model;
    let n = model.n();
    let m = seq.m;
    let task = <G::Frame<f64> as Frame<f64>>::TASK;
    let kf = free.len();
    let holes = Holes::of(model);
    let h = holes.total;
    let k = Constants::new(plant, seq);
    let chunks: Vec<Chunk> = free
        .chunks(JET)
        .map(|dirs| {
            // direction s along parameter dirs[s]
            let prm = Params::<J>::unpack(model, &plant.lay, &plant.p, |i, v| {
                J::with(
                    v,
                    std::array::from_fn(|s| f64::from(dirs.get(s) == Some(&i))),
                )
            });
            let real = realised(seq, &prm, &plant.l_ref);
            let cab = Cables::new(model, &prm, &mut Chain::<J, G::Frame<J>>::new(model));
            let z = mobilisations::<J, G>(model, seq, prm.mu);
            Chunk { prm, cab, real, z }
        })
        .collect();
    let parts = split_rows(seq.len(), threads, |range| {
        let mut out = vec![f64::NAN; range.len() * task * kf];
        let mut w = Work::<J, G::Frame<J>>::new(model);
        let mut r = vec![0.0; n];
        let mut qc = vec![J::default(); n];
        let mut qt = vec![J::default(); n];
        let mut obs = vec![J::default(); task];
        for (local, j) in range.enumerate() {
            if !ok[j] {
                continue;
            }
            let q = &theta[j * n..(j + 1) * n];
            let a = jacobian_q(model, &k, &holes, j, q, &mut w, &mut r);
            let lu = a.partial_piv_lu();
            for (x, v) in qc.iter_mut().zip(q) {
                *x = J::cst(*v);
            }
            let dst = &mut out[local * task * kf..(local + 1) * task * kf];
            for (ci, Chunk { prm, cab, real, z }) in chunks.iter().enumerate() {
                let width = JET.min(kf - ci * JET);
                residual(
                    model,
                    prm,
                    cab,
                    &holes,
                    &real[j * m..(j + 1) * m],
                    &z[j * h..(j + 1) * h],
                    &qc,
                    &mut w,
                );
                let rhs = Mat::<f64>::from_fn(n, width, |i, s| w.r[i].d[s]);
                let y = lu.solve(&rhs);
                for (i, t) in qt.iter_mut().enumerate() {
                    *t = J::with(
                        q[i],
                        std::array::from_fn(|s| if s < width { -y[(i, s)] } else { 0.0 }),
                    );
                }
                observe(model, prm, &qt, &mut w.chain, &mut obs);
                for (kk, v) in obs.iter().enumerate() {
                    for s in 0..width {
                        let d = v.d[s];
                        dst[kk * kf + ci * JET + s] = if d.is_finite() { d } else { f64::NAN };
                    }
                }
            }
        }
        out
    });
    parts.concat()
}

/// The nominal motion of an elastic arm's commands (`docs/model.md`,
/// "Elastic arms in the plant", friction): every command's nominal
/// frictionless equilibrium (the nominal plant's settle along the
/// sequence; the row's `theta_cmd` where it does not converge), the holes'
/// distal lengths and wrap angles there and every cable's frictionless
/// tension (a commanded cable's `clip(sigma)`, a force cable's set one).
pub(super) fn nominal_motion<G: Group>(model: &Model, seq: &Sequence) -> Motion {
    let n = model.n();
    let m = seq.m;
    let nominal = Plant::<G>::new(model, &vec![0.0; super::layout(model).total])
        .expect("the nominal plant is physical");
    let set = elastic_settle::settle_all(&nominal, seq, &SolveOptions::default());
    let real = nominal.realised(seq);
    let mut chain = Chain::<f64, G::Frame<f64>>::new(model);
    let cab = Cables::new(model, &nominal.prm, &mut chain);
    let holes = Holes::of(model);
    let h = holes.total;
    let count = seq.len();
    let mut out = Motion {
        d: vec![0.0; count * h],
        beta: vec![0.0; count * h],
        tension: vec![0.0; count * h],
        d0: vec![0.0; h],
        holes,
    };
    let mut scratch = vec![0.0; h];
    chain.at(model, model, &vec![0.0; n]);
    hole_geometry(model, &chain, &out.holes, &mut out.d0, &mut scratch);
    for j in 0..count {
        let row = seq.row[j];
        let q = if set.ok[j] {
            &set.theta[j * n..(j + 1) * n]
        } else {
            &seq.theta_cmd[row * n..(row + 1) * n]
        };
        chain.at(model, model, q);
        let (d, beta) = (
            &mut out.d[j * h..(j + 1) * h],
            &mut out.beta[j * h..(j + 1) * h],
        );
        hole_geometry(model, &chain, &out.holes, d, beta);
        for (c, cable) in model.cables.iter().enumerate() {
            let len = chain.cable_length(model, model, c, None);
            let t = cab
                .tension(model, c, len, &real[j * m..(j + 1) * m], 1.0)
                .unwrap_or(0.0);
            let t = if t.is_finite() { t } else { 0.0 };
            let s = out.holes.start[c];
            out.tension[j * h + s..j * h + s + 2 * cable.end].fill(t);
        }
    }
    out
}
