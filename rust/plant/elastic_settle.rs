//! The plant of an elastic arm (`docs/model.md`, "The plant", "Elastic
//! arms"): the same commands, effects and observation as a rigid arm's, the
//! settle the frictionless elastic equilibrium ([`crate::elastic`]) of the
//! plant's arm for the realised rest lengths of its commanded cables,
//! warm-started along the sequence, and the derivatives by the implicit
//! function theorem, `dq/dp = -H^-1 dg/dp` (`g`, `H` the gradient and
//! Hessian of the potential; `dg/dp` at fixed `q` in jets, one-sided at a
//! slack or capped cable as [`crate::elastic`] is), then the observation's
//! total derivative in jets along `(dq/dp, p)`.
//!
//! A commanded cable `c` with the realised rest length `r_c` (m) pulls with
//! `clip(P_c + k_c (L_c(q) - r_c), 0, T_max,c)`: a displacement cable at
//! its series stiffness `k_c = 1 / (1/k_a + (L0_c + L_r)/(E A))` (`L0_c` its
//! path at the rest angles on the plant's arm), a position cable at
//! `E A / (r_c + L_r)`; the joint springs of a segment scaled by `1 + s`.

use super::{commanded_cables, observe_at, realised, Params, Plant, Sequence, Settled, J, JET};
use crate::chain::Chain;
use crate::effect::Effect;
use crate::elastic::{self, Batch, Commands, Elastic, XTOL};
use crate::kinds::{Frame, Group, Vector};
use crate::model::{Mode, Model};
use crate::real::{Arith, Real};
use crate::rows::split_rows;
use crate::solve::SolveOptions;
use faer::linalg::solvers::Solve;
use faer::Mat;

/// The nominal model with the plant's numbers (its moved holes, links,
/// axes, and springs scaled per segment): the arm [`crate::elastic`] settles.
pub(super) fn moved(model: &Model, prm: &Params<f64>) -> Model {
    let mut m = model.clone();
    for (j, joint) in m.joints.iter_mut().enumerate() {
        joint.axis = prm.arm.axis[j];
        joint.offset = prm.arm.offset[j];
        joint.stiffness *= prm.spring[j];
    }
    for (d, disk) in m.disks.iter_mut().enumerate() {
        disk.link_after = prm.arm.link_after[d];
        disk.thickness = prm.arm.thickness[d];
        disk.com = prm.arm.com[d];
    }
    for (c, cable) in m.cables.iter_mut().enumerate() {
        cable.holes.clone_from(&prm.arm.holes[c]);
    }
    m
}

/// The realised rest lengths of one command split into the elastic
/// statics' commands: the position cables' lengths, the displacement
/// cables' displacements from the plant arm's rest lengths `l0` (so that
/// each rest length is the realised one).
fn split(
    model: &Model,
    cmd: &[usize],
    l0: &[f64],
    real: &[f64],
    pos: &mut Vec<f64>,
    dis: &mut Vec<f64>,
) {
    for (i, &c) in cmd.iter().enumerate() {
        if model.cables[c].mode == Mode::Position {
            pos.push(real[i]);
        } else {
            dis.push(l0[c] - real[i]);
        }
    }
}

/// Every command of `seq` settled by the elastic plant, in order, each from
/// the previous command's answer (the first from the default seed of
/// [`crate::elastic::equilibria`]); a command that does not converge is
/// flagged, its observation NaN.
pub(super) fn settle_all<G: Group>(
    plant: &Plant<G>,
    seq: &Sequence,
    opts: &SolveOptions,
) -> Settled {
    let model = plant.model;
    let (n, m) = (seq.n, seq.m);
    let task = <G::Frame<f64> as Frame<f64>>::TASK;
    let count = seq.len();
    let failed = || Settled {
        theta: vec![f64::NAN; count * n],
        obs: vec![f64::NAN; count * task],
        ok: vec![false; count],
        reason: vec![super::NOT_SETTLED; count],
    };
    if count == 0 {
        return Settled::default();
    }
    let arm = moved(model, &plant.prm);
    let el = Elastic::new(&arm);
    let cmd = commanded_cables(model);
    let real = plant.realised(seq);
    let (mut pos, mut dis) = (Vec::new(), Vec::new());
    for r in real.chunks_exact(m) {
        split(&arm, &cmd, el.rest_lengths(), r, &mut pos, &mut dis);
    }
    let batch = Batch {
        lengths: &pos,
        displacements: &dis,
        wrench: &[],
    };
    let Ok(eq) = elastic::equilibria(&arm, &batch, None, true, XTOL, opts.max_iter, 1) else {
        return failed();
    };
    let mut chain = Chain::<f64, G::Frame<f64>>::new(model);
    let mut o = vec![0.0; task];
    let mut obs = Vec::with_capacity(count * task);
    for (j, ok) in eq.converged.iter().enumerate() {
        if *ok {
            plant.observe(&eq.theta[j * n..(j + 1) * n], &mut chain, &mut o);
            obs.extend_from_slice(&o);
        } else {
            obs.extend(std::iter::repeat_n(f64::NAN, task));
        }
    }
    Settled {
        theta: eq.theta,
        obs,
        ok: eq.converged,
        reason: eq.reason,
    }
}

/// The laws of the commanded cables in a scalar: per commanded cable its
/// series stiffness (N/m; displacement cables, from the plant arm's rest
/// length), pretension and cap (N).
struct Laws<S> {
    /// Commanded index of every cable (`None`: a force cable).
    index: Vec<Option<usize>>,
    displacement: Vec<bool>,
    ks: Vec<S>,
    pre: Vec<f64>,
    cap: Vec<f64>,
    ea: f64,
    lr: f64,
}

impl<S: Real> Laws<S> {
    fn new<F: Frame<S>>(model: &Model, prm: &Params<S>, chain: &mut Chain<S, F>) -> Self {
        let cmd = commanded_cables(model);
        let ea = 1.0 / model.cable.compliance();
        let lr = model.cable.routing_length;
        let rest: Vec<S> = model.joints.iter().map(|j| S::cst(j.rest)).collect();
        chain.at(model, &prm.arm, &rest);
        let mut index = vec![None; model.cables.len()];
        let mut laws = Laws {
            index: Vec::new(),
            displacement: Vec::with_capacity(cmd.len()),
            ks: Vec::with_capacity(cmd.len()),
            pre: Vec::with_capacity(cmd.len()),
            cap: Vec::with_capacity(cmd.len()),
            ea,
            lr,
        };
        for (i, &c) in cmd.iter().enumerate() {
            index[c] = Some(i);
            let cable = &model.cables[c];
            let d = cable.mode == Mode::Displacement;
            laws.displacement.push(d);
            if d {
                let l0 = chain.cable_length(model, &prm.arm, c, None);
                let inv = (l0 + lr) / ea + 1.0 / cable.actuator.stiffness;
                laws.ks.push(S::cst(1.0) / inv);
                laws.pre.push(cable.actuator.pretension);
                laws.cap.push(cable.actuator.max_tension);
            } else {
                laws.ks.push(S::cst(f64::NAN));
                laws.pre.push(0.0);
                laws.cap.push(f64::INFINITY);
            }
        }
        laws.index = index;
        laws
    }
}

/// Buffers of [`gradient`].
struct Grad<S: Real, F: Frame<S>> {
    chain: Chain<S, F>,
    row: Vec<S>,
    tau: Vec<S>,
    g: Vec<S>,
}

/// The gradient of the potential `g = K (q - rest) + J_L^T T - tau` (N m)
/// of the plant `prm` at `q` for the realised rest lengths `real` of one
/// command (the equations of [`crate::elastic`], in any scalar), into `w.g`.
fn gradient<S: Real, F: Frame<S>>(
    model: &Model,
    prm: &Params<S>,
    laws: &Laws<S>,
    real: &[S],
    q: &[S],
    w: &mut Grad<S, F>,
) {
    let n = model.n();
    w.chain.at(model, &prm.arm, q);
    for (j, joint) in model.joints.iter().enumerate() {
        w.g[j] = (q[j] - joint.rest) * (prm.spring[j] * joint.stiffness);
    }
    for (c, cable) in model.cables.iter().enumerate() {
        let len = w.chain.cable_length_and_row(model, &prm.arm, c, &mut w.row);
        let t = match laws.index[c] {
            Some(i) => {
                let k = if laws.displacement[i] {
                    laws.ks[i]
                } else {
                    S::cst(laws.ea) / (real[i] + laws.lr)
                };
                let sigma = (len - real[i]) * k + laws.pre[i];
                if sigma.val() <= 0.0 {
                    continue;
                }
                if sigma.val() >= laws.cap[i] {
                    S::cst(laws.cap[i])
                } else {
                    sigma
                }
            }
            None => S::cst(cable.tension),
        };
        for j in 0..n {
            w.g[j] += t * w.row[j];
        }
    }
    super::subtract_gravity(model, &prm.arm, &mut w.chain, &mut w.tau, &mut w.g);
}

/// What the directions of one chunk of [`JET`] free parameters move: the
/// arm (its numbers or springs: `dg/dp` in jets), only the realised lengths
/// (actuation, offsets, backlash: `dg/dp = sum_c dg/dl_c dl_c/dp`), or only
/// the observation (frame, marker: `dq/dp = 0`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Moves {
    Arm,
    Lengths,
    Observation,
}

/// One chunk of [`JET`] free directions: the plant's parameters seeded
/// along them, the realised lengths and cable laws in jets, what they move.
struct Directions {
    prm: Params<J>,
    real: Vec<J>,
    laws: Laws<J>,
    moves: Moves,
}

/// What the parameter `i` of the layout moves.
fn moves(lay: &super::Layout, i: usize) -> Moves {
    let e = lay
        .blocks
        .iter()
        .find(|b| i >= b.1 && i < b.1 + b.2)
        .map(|b| b.0);
    match e {
        Some(Effect::FrameMisalignment | Effect::TipOffset) => Moves::Observation,
        Some(Effect::ActuationScale | Effect::CableOffset | Effect::Backlash) => Moves::Lengths,
        _ => Moves::Arm,
    }
}

/// `f` in jets of constant value: its origin, and its attitude rebuilt from
/// its rotation (the plane: its angle with its cosine and sine; space: the
/// axis and the cosine and sine of the angle of its matrix, Rodrigues'
/// formula giving the matrix back to rounding).
fn lift<G: Group>(f: &G::Frame<f64>) -> G::Frame<J> {
    type V<G> = <<G as Group>::Frame<J> as Frame<J>>::V;
    let o = f.origin().to3().map(J::cst);
    let task = <G::Frame<f64> as Frame<f64>>::TASK;
    let unit = |i: usize| {
        let mut e = [0.0; 3];
        e[i] = 1.0;
        f.dir(<G::Frame<f64> as Frame<f64>>::V::of(e)).to3()
    };
    let (axis, theta, c, s) = if task == 3 {
        let mut t = [0.0; 3];
        f.task(&mut t);
        let x = unit(0);
        ([0.0, 0.0, 1.0], t[2], x[0], x[1])
    } else {
        // columns of R; R = c I + s [k]x + (1 - c) k k^T
        let col = [unit(0), unit(1), unit(2)];
        let r = |i: usize, j: usize| col[j][i];
        let c = 0.5 * (r(0, 0) + r(1, 1) + r(2, 2) - 1.0);
        let vee = [
            0.5 * (r(2, 1) - r(1, 2)),
            0.5 * (r(0, 2) - r(2, 0)),
            0.5 * (r(1, 0) - r(0, 1)),
        ];
        let s = (vee[0] * vee[0] + vee[1] * vee[1] + vee[2] * vee[2]).sqrt();
        let k = if c > 0.0 {
            // small angles: the axis from the skew part
            if s > 0.0 {
                vee.map(|v| v / s)
            } else {
                [0.0, 0.0, 1.0]
            }
        } else {
            // large angles: from the symmetric part's largest diagonal
            let sym = |i: usize, j: usize| 0.5 * (r(i, j) + r(j, i)) - if i == j { c } else { 0.0 };
            let i = (0..3)
                .max_by(|a, b| sym(*a, *a).total_cmp(&sym(*b, *b)))
                .expect("three");
            let mut k = [sym(0, i), sym(1, i), sym(2, i)];
            let norm = (k[0] * k[0] + k[1] * k[1] + k[2] * k[2]).sqrt();
            let sign = if k[0] * vee[0] + k[1] * vee[1] + k[2] * vee[2] < 0.0 {
                -1.0
            } else {
                1.0
            };
            k = k.map(|v| sign * v / norm);
            k
        };
        (k, s.atan2(c), c, s)
    };
    <G::Frame<J> as Frame<J>>::at_turned(
        V::<G>::of(o),
        axis.map(J::cst),
        J::cst(theta),
        (J::cst(c), J::cst(s)),
    )
}

/// The task vector in jets of `E · end · Trans(tip)` with the instrument
/// `E` and marker `tip` of `prm` (`end`: the chain's end frame in jets).
fn seen<G: Group>(prm: &Params<J>, delta: &G::Frame<J>, end: &G::Frame<J>, out: &mut [J]) {
    let mut tip = [J::cst(0.0); 3];
    tip[..prm.tip.len()].copy_from_slice(&prm.tip);
    <G::Frame<J> as Frame<J>>::instrument(&prm.instrument)
        .compose(delta)
        .compose(end)
        .translated(<<G::Frame<J> as Frame<J>>::V as Vector<J>>::of(tip))
        .task(out);
}

/// The derivatives `(commands, TASK, k)` of every settled command's
/// observation with respect to the parameters `free` (NaN where a command
/// did not settle or the Hessian is not positive definite there), by the
/// adjoint of the implicit function theorem: `dobs/dp = (dobs/dp)_q -
/// Lambda^T dg/dp` with `H Lambda = (dobs/dq)^T` (one Cholesky of `H` and
/// `TASK` solves per command, whatever the number of parameters). `dobs/dq
/// = D Xi`: `D` the observation's derivative along a small motion of the
/// base frame `delta` (the instrument's parameters: rotation, then
/// translation) between the instrument and the arm (in jets), `Xi` the
/// joints' twists in the base frame. Per chunk of directions: `dg/dp` in
/// jets and `(dobs/dp)_q` of the chain in jets where the chunk moves the
/// arm; else `dg/dp = sum_c dg/dl_c dl_c/dp` (`dg/dl_c = g_c dsigma_c/dl_c`,
/// `g_c = dL_c/dq`) and `(dobs/dp)_q` of the end frame at `q` in jets.
pub(super) fn command_derivatives<G: Group>(
    plant: &Plant<G>,
    seq: &Sequence,
    theta: &[f64],
    ok: &[bool],
    free: &[usize],
    threads: usize,
) -> Vec<f64> {
    let model = plant.model;
    let (n, m) = (seq.n, seq.m);
    let task = <G::Frame<f64> as Frame<f64>>::TASK;
    let kf = free.len();
    let arm = moved(model, &plant.prm);
    let el = Elastic::new(&arm);
    let cmd = commanded_cables(model);
    let real = plant.realised(seq);
    let laws = Laws::new(
        model,
        &plant.prm,
        &mut Chain::<f64, G::Frame<f64>>::new(model),
    );
    // chunk c carries the directions free[c*JET..]
    let chunks: Vec<Directions> = (0..kf.div_ceil(JET))
        .map(|c| {
            let prm = Params::<J>::unpack(model, &plant.lay, &plant.p, |i, v| {
                let mut d = [0.0; JET];
                for (s, x) in d.iter_mut().enumerate() {
                    if free.get(c * JET + s) == Some(&i) {
                        *x = 1.0;
                    }
                }
                J::with(v, d)
            });
            let real = realised(seq, &prm, &plant.l_ref);
            let mut chain = Chain::<J, G::Frame<J>>::new(model);
            let laws = Laws::new(model, &prm, &mut chain);
            let kinds: Vec<Moves> = free[c * JET..kf.min((c + 1) * JET)]
                .iter()
                .map(|i| moves(&plant.lay, *i))
                .collect();
            let moves = if kinds.contains(&Moves::Arm) {
                Moves::Arm
            } else if kinds.contains(&Moves::Lengths) {
                Moves::Lengths
            } else {
                Moves::Observation
            };
            Directions {
                prm,
                real,
                laws,
                moves,
            }
        })
        .collect();
    let lengths = chunks.iter().any(|c| c.moves == Moves::Lengths);
    let dim = <G::Frame<f64> as Frame<f64>>::DIM;
    let parts = split_rows(seq.len(), threads, |range| {
        let mut out = vec![f64::NAN; range.len() * task * kf];
        let mut w = Grad::<J, G::Frame<J>> {
            chain: Chain::new(model),
            row: vec![J::default(); n],
            tau: vec![J::default(); n],
            g: vec![J::default(); n],
        };
        let mut fchain = Chain::<f64, G::Frame<f64>>::new(model);
        let mut frow = vec![0.0; n];
        // dsigma_c/dl_c g_c of the commanded cables (n x m)
        let mut b = vec![0.0; n * m];
        // (dobs/dq)^T, then Lambda (n x task)
        let mut dodq = Mat::<f64>::zeros(n, task);
        // Lambda^T B (task x m)
        let mut lb = vec![0.0; task * m];
        let mut qc = vec![J::default(); n];
        let mut obs = vec![J::default(); task];
        let mut ang = [0.0; 3];
        let (mut pos, mut dis) = (Vec::new(), Vec::new());
        let id = <G::Frame<J> as Frame<J>>::identity();
        for (local, j) in range.enumerate() {
            if !ok[j] {
                continue;
            }
            let q = &theta[j * n..(j + 1) * n];
            let rj = &real[j * m..(j + 1) * m];
            pos.clear();
            dis.clear();
            split(&arm, &cmd, el.rest_lengths(), rj, &mut pos, &mut dis);
            let c = Commands {
                lengths: &pos,
                displacements: &dis,
                wrench: [0.0; 6],
            };
            let Ok((_, _, h)) = el.potential(&arm, &c, q) else {
                continue;
            };
            let Ok(llt) = Mat::<f64>::from_fn(n, n, |a, b| h[a * n + b]).llt(faer::Side::Lower)
            else {
                continue;
            };
            fchain.at(model, &plant.prm.arm, q);
            fchain.world(model, &plant.prm.arm);
            fchain.joints_world(model);
            let end = lift::<G>(fchain.end());
            // D (task x task): the observation along delta
            let delta = <G::Frame<J> as Frame<J>>::instrument(
                &(0..task)
                    .map(|s| {
                        let mut d = [0.0; JET];
                        d[s] = 1.0;
                        J::with(0.0, d)
                    })
                    .collect::<Vec<_>>(),
            );
            seen::<G>(&plant.cprm, &delta, &end, &mut obs);
            // (dobs/dq)^T = Xi^T D^T, Xi's column a = [angular; rate about the origin]
            let origin = <<G::Frame<f64> as Frame<f64>>::V as Vector<f64>>::zero();
            for a in 0..n {
                let axis = fchain.world_w[a];
                <G::Frame<f64> as Frame<f64>>::angular(axis, &mut ang);
                let v = <G::Frame<f64> as Frame<f64>>::rate(axis, fchain.world_p[a], origin).to3();
                for (k, ok) in obs.iter().enumerate() {
                    let mut sum = 0.0;
                    for (s, x) in ang[..task - dim].iter().enumerate() {
                        sum += ok.d[s] * x;
                    }
                    for (s, x) in v[..dim].iter().enumerate() {
                        sum += ok.d[task - dim + s] * x;
                    }
                    dodq[(a, k)] = sum;
                }
            }
            let lam = llt.solve(&dodq);
            if lengths {
                fchain.at(model, &plant.prm.arm, q);
                for (i, &cc) in cmd.iter().enumerate() {
                    let len = fchain.cable_length_and_row(model, &plant.prm.arm, cc, &mut frow);
                    let r = rj[i];
                    let (k, dk) = if laws.displacement[i] {
                        (laws.ks[i], 1.0)
                    } else {
                        let k = laws.ea / (r + laws.lr);
                        (k, (len + laws.lr) / (r + laws.lr))
                    };
                    let sigma = (len - r) * k + laws.pre[i];
                    let taut = sigma > 0.0 && sigma < laws.cap[i];
                    let ds = if taut { -k * dk } else { 0.0 };
                    for a in 0..n {
                        b[a * m + i] = frow[a] * ds;
                    }
                }
                for k in 0..task {
                    for i in 0..m {
                        lb[k * m + i] = (0..n).map(|a| lam[(a, k)] * b[a * m + i]).sum();
                    }
                }
            }
            for (a, v) in qc.iter_mut().zip(q) {
                *a = J::cst(*v);
            }
            let dst = &mut out[local * task * kf..(local + 1) * task * kf];
            for (ci, ch) in chunks.iter().enumerate() {
                let (prm, realc) = (&ch.prm, &ch.real);
                let width = JET.min(kf - ci * JET);
                let col = |k: usize, s: usize| k * kf + ci * JET + s;
                match ch.moves {
                    Moves::Arm => {
                        gradient(
                            model,
                            prm,
                            &ch.laws,
                            &realc[j * m..(j + 1) * m],
                            &qc,
                            &mut w,
                        );
                        // the chain is at q with the chunk's numbers
                        observe_at(model, prm, &mut w.chain, &mut obs);
                        for (k, o) in obs.iter().enumerate() {
                            for s in 0..width {
                                let adj: f64 = (0..n).map(|a| lam[(a, k)] * w.g[a].d[s]).sum();
                                dst[col(k, s)] = o.d[s] - adj;
                            }
                        }
                    }
                    Moves::Lengths | Moves::Observation => {
                        seen::<G>(prm, &id, &end, &mut obs);
                        let dl = &realc[j * m..(j + 1) * m];
                        for (k, o) in obs.iter().enumerate() {
                            for s in 0..width {
                                let adj: f64 = if ch.moves == Moves::Lengths {
                                    (0..m).map(|i| lb[k * m + i] * dl[i].d[s]).sum()
                                } else {
                                    0.0
                                };
                                dst[col(k, s)] = o.d[s] - adj;
                            }
                        }
                    }
                }
            }
        }
        out
    });
    parts.concat()
}
