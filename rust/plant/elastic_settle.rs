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

use super::{commanded_cables, observe, realised, Params, Plant, Sequence, Settled, J, JET};
use crate::chain::Chain;
use crate::effect::Effect;
use crate::elastic::{self, Batch, Commands, Elastic, XTOL};
use crate::kinds::{Frame, Group};
use crate::model::{Mode, Model};
use crate::real::{Arith, Real};
use crate::rows::split_rows;
use crate::solve::SolveOptions;
use faer::linalg::solvers::Solve;
use faer::Mat;

/// The nominal model with the plant's numbers (its moved holes, links,
/// axes, and springs scaled per segment): the arm [`crate::elastic`] settles.
fn moved(model: &Model, prm: &Params<f64>) -> Model {
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

/// The derivatives `(commands, TASK, k)` of every settled command's
/// observation with respect to the parameters `free` (NaN where a command
/// did not settle or the Hessian is not positive definite there): per
/// command one Cholesky of `H`; per chunk of directions `dg/dp` (in jets
/// where the chunk moves the arm; else through the realised lengths, `dg/dl_c
/// = g_c dsigma_c/dl_c` with `g_c = dL_c/dq`, one solve for every commanded
/// cable), `dq/dp = -H^-1 dg/dp`, and the observation in jets along `(dq/dp, p)`.
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
        let mut b = Mat::<f64>::zeros(n, m);
        let mut qc = vec![J::default(); n];
        let mut qt = vec![J::default(); n];
        let mut dq = vec![[0.0; JET]; n];
        let mut obs = vec![J::default(); task];
        let (mut pos, mut dis) = (Vec::new(), Vec::new());
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
            // X = H^-1 [g_c dsigma_c/dl_c] over the commanded cables
            let x = if lengths {
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
                        b[(a, i)] = frow[a] * ds;
                    }
                }
                Some(llt.solve(&b))
            } else {
                None
            };
            for (a, v) in qc.iter_mut().zip(q) {
                *a = J::cst(*v);
            }
            let dst = &mut out[local * task * kf..(local + 1) * task * kf];
            for (ci, ch) in chunks.iter().enumerate() {
                let (prm, realc) = (&ch.prm, &ch.real);
                let width = JET.min(kf - ci * JET);
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
                        let rhs = Mat::<f64>::from_fn(n, width, |a, s| w.g[a].d[s]);
                        let y = llt.solve(&rhs);
                        for (a, d) in dq.iter_mut().enumerate() {
                            *d = std::array::from_fn(|s| if s < width { -y[(a, s)] } else { 0.0 });
                        }
                    }
                    Moves::Lengths => {
                        let x = x.as_ref().expect("made for chunks of lengths");
                        let dl = &realc[j * m..(j + 1) * m];
                        for (a, d) in dq.iter_mut().enumerate() {
                            *d = std::array::from_fn(|s| {
                                -(0..m).map(|i| x[(a, i)] * dl[i].d[s]).sum::<f64>()
                            });
                        }
                    }
                    Moves::Observation => dq.iter_mut().for_each(|d| *d = [0.0; JET]),
                }
                for (a, t) in qt.iter_mut().enumerate() {
                    *t = J::with(q[a], dq[a]);
                }
                observe(model, prm, &qt, &mut w.chain, &mut obs);
                for (k, ok) in obs.iter().enumerate() {
                    for s in 0..width {
                        dst[k * kf + ci * JET + s] = ok.d[s];
                    }
                }
            }
        }
        out
    });
    parts.concat()
}
