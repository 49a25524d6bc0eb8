//! Coulomb friction of the cables in the holes (`docs/model.md`, "Friction
//! in the holes"), written once over the arm's kind and any [`Real`]
//! scalar: the wrap angle of every cable at every hole it turns through,
//! the capstan profile of its tension (each gap's tension over the
//! routing's, and the length-weighted mean the stretch needs), and the
//! sliding state of every hole over a command sequence (the mobilisation
//! `z`, a play through a sticking band on the nominal motion).
//!
//! Holes of cable `c` ending at disk `e`: `i = 0` on the base face `b`,
//! `2k - 1` on face `a` and `2k` on face `b` of disk `k`, `i < 2e` (the
//! anchor is not a turn); segments: `0` the routing (along the base frame's
//! `x`), `2k - 1` the gap before disk `k`, `2k` the traversal of disk `k`.
//! Hole `i` joins segments `i` and `i + 1`; `T_{i+1} = T_i exp(-mu z_i
//! beta_i)`.

use faer::Mat;

use crate::chain::{Chain, Numbers};
use crate::error::{CdsmError, Result};
use crate::kinds::{cross, Frame, Group, Vector};
use crate::model::{Mode, Model};
use crate::real::Real;
use crate::tension::{Balance, Wrench};

/// The largest friction coefficient of the physical domain (1; a fit at it
/// says friction alone does not explain the data).
pub const MU_MAX: f64 = 1.0;

/// The typical friction coefficient of a cable in a hole (1; oiled or greased
/// steel on metal, `docs/model.md`, "Friction in the holes"): the default of
/// the friction studies and the typical size of the plant's `cable_friction`.
pub const MU_TYPICAL: f64 = 0.15;

/// An error naming the field `name` unless `0 <= mu <= MU_MAX` (NaN refused):
/// the one check of the friction coefficient's domain.
pub fn check_mu(name: &str, mu: f64) -> Result<()> {
    if !(0.0..=MU_MAX).contains(&mu) {
        return Err(CdsmError::Option {
            name: name.into(),
            problem: format!("the friction coefficient must be within [0, {MU_MAX}], got {mu}"),
        });
    }
    Ok(())
}

/// Where every cable's holes sit in a flat per-hole vector: cable `c` has
/// `2 e_c` of them from `start[c]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Holes {
    pub start: Vec<usize>,
    pub total: usize,
}

impl Holes {
    pub fn of(model: &Model) -> Holes {
        let mut start = Vec::with_capacity(model.cables.len());
        let mut total = 0;
        for c in &model.cables {
            start.push(total);
            total += 2 * c.end;
        }
        Holes { start, total }
    }
}

/// The angle (rad, in `[0, pi]`) between two direction vectors:
/// `atan2(|u × w|, u · w)` (in the plane `|u × w| = |u_x w_y - u_y w_x|`).
#[inline]
pub fn angle<S: Real, V: Vector<S>>(u: V, w: V) -> S {
    let (a, b) = (u.to3(), w.to3());
    let planar = |x: S| x.val() == 0.0 && !x.is_variable();
    let sin = if planar(a[2]) && planar(b[2]) {
        let z = a[0] * b[1] - a[1] * b[0];
        if z.val() < 0.0 {
            -z
        } else {
            z
        }
    } else {
        let c = cross(a, b);
        c.dot(c).sqrt()
    };
    sin.atan2(u.dot(w))
}

/// Whether a traversal is a point (every component exactly 0 and constant):
/// a via plate's (thickness 0) one hole on both faces, which has no
/// direction; the cable turns there from its gap into the next one
/// (`docs/model.md`, "Friction in the holes").
#[inline]
fn is_point<S: Real, V: Vector<S>>(t: V) -> bool {
    t.to3().iter().all(|x| x.val() == 0.0 && !x.is_variable())
}

/// `sinh(x)`.
#[inline]
fn sinh<S: Real>(x: S) -> S {
    (x.exp() - (-x).exp()) * 0.5
}

/// The capstan profile of every cable at one configuration: `gap[c * K +
/// k - 1]` cable `c`'s tension in the gap before disk `k` over its routing
/// tension (1 past its end), `mean[c]` the length-weighted mean factor with
/// the routing, `ebar = (L_r + sum_s g_s E_s) / (L_r + L_arm)`.
#[derive(Debug, Clone)]
pub struct Profile<S> {
    pub gap: Vec<S>,
    pub mean: Vec<S>,
}

impl<S: Real> Profile<S> {
    pub fn new(model: &Model) -> Self {
        let one = S::cst(1.0);
        Profile {
            gap: vec![one; model.cables.len() * model.disks.len()],
            mean: vec![one; model.cables.len()],
        }
    }

    /// The profile at the configuration of `chain` ([`Chain::at`] done) of
    /// the arm `nums` with the mobilisations `z` (per hole, [`Holes`];
    /// missing entries count as `+1`, the start state), coefficient `mu`
    /// and routing length `routing` (m). Lengths, directions and angles are
    /// the holes' own (no clearance shift).
    #[allow(clippy::too_many_arguments)]
    pub fn at<F: Frame<S>, N: Numbers<S>>(
        &mut self,
        model: &Model,
        nums: &N,
        chain: &Chain<S, F>,
        holes: &Holes,
        z: &[S],
        mu: S,
        routing: f64,
    ) {
        for c in 0..model.cables.len() {
            self.cable(model, nums, chain, holes, z, mu, routing, c);
        }
    }

    /// [`Profile::at`] of cable `c` alone (its entries of [`Profile::gap`]
    /// and [`Profile::mean`]; the other cables' stay).
    #[allow(clippy::too_many_arguments)]
    pub fn cable<F: Frame<S>, N: Numbers<S>>(
        &mut self,
        model: &Model,
        nums: &N,
        chain: &Chain<S, F>,
        holes: &Holes,
        z: &[S],
        mu: S,
        routing: f64,
        c: usize,
    ) {
        let kd = model.disks.len();
        let z_at = |i: usize| z.get(i).copied().unwrap_or(S::cst(1.0));
        let zero = S::cst(0.0);
        let cable = &model.cables[c];
        let h0 = holes.start[c];
        let mut cum = zero;
        let mut sum = zero;
        let mut len = zero;
        // the routing reaches the base hole along the base frame's x
        let mut prev = F::V::of([S::cst(1.0), zero, zero]);
        for k in 1..=cable.end {
            // hole 2k - 2 (face b of disk k - 1): from `prev` into the gap
            let v = chain.gap(nums, c, k);
            cum += z_at(h0 + 2 * k - 2) * angle(prev, v);
            let e_gap = (-(mu * cum)).exp();
            self.gap[c * kd + k - 1] = e_gap;
            let g = v.norm();
            sum += g * e_gap;
            len += g;
            // hole 2k - 1 (face a of disk k): from the gap into the traversal
            let t = chain.traversal(nums, c, k);
            let va = chain.local[k - 1].dir_inv(v);
            if is_point(t) {
                // a via plate's one hole: the turn is hole 2k's, into the next gap
                prev = va;
                continue;
            }
            cum += z_at(h0 + 2 * k - 1) * angle(va, t);
            let tl = t.norm();
            sum += tl * (-(mu * cum)).exp();
            len += tl;
            prev = t;
        }
        for k in cable.end + 1..=kd {
            self.gap[c * kd + k - 1] = S::cst(1.0);
        }
        self.mean[c] = (sum + routing) / (len + routing);
    }
}

/// Every hole's distal length `d_i` (m, the cable's length distal of it)
/// and wrap angle `beta_i` (rad) at the configuration of `chain` (the
/// model's own holes), per hole ([`Holes`]).
pub fn hole_geometry<F: Frame<f64>>(
    model: &Model,
    chain: &Chain<f64, F>,
    holes: &Holes,
    d: &mut [f64],
    beta: &mut [f64],
) {
    for (c, cable) in model.cables.iter().enumerate() {
        let h0 = holes.start[c];
        let mut prev = F::V::of([1.0, 0.0, 0.0]);
        // segment lengths 1..2e into d (shifted by one), then the distal sums
        for k in 1..=cable.end {
            let v = chain.gap(model, c, k);
            beta[h0 + 2 * k - 2] = angle(prev, v);
            d[h0 + 2 * k - 2] = v.norm();
            let t = chain.traversal(model, c, k);
            let va = chain.local[k - 1].dir_inv(v);
            if is_point(t) {
                // a via plate's one hole: the turn is hole 2k's, into the next gap
                beta[h0 + 2 * k - 1] = 0.0;
                d[h0 + 2 * k - 1] = 0.0;
                prev = va;
                continue;
            }
            beta[h0 + 2 * k - 1] = angle(va, t);
            d[h0 + 2 * k - 1] = t.norm();
            prev = t;
        }
        let mut acc = 0.0;
        for i in (h0..h0 + 2 * cable.end).rev() {
            acc += d[i];
            d[i] = acc;
        }
    }
}

/// The frictionless tension of every cable (N) of the nominal statics at
/// the configuration of `chain` under the robot file's loads: a force
/// cable's set tension; a position cable's from the balance (square), or
/// with more position cables than joints the minimum-norm set at or above
/// 0; 0 where negative or undefined.
fn nominal_tensions<F: Frame<f64>>(
    model: &Model,
    chain: &mut Chain<f64, F>,
    bal: &mut Balance<f64>,
    out: &mut [f64],
) {
    let zero = [0.0; 3];
    bal.at(
        model,
        model,
        chain,
        model.gravity,
        Wrench {
            force: zero,
            couple: &zero,
        },
    );
    let m = bal.m;
    let t = if bal.n == m {
        let mut t = vec![0.0; m];
        if !bal.solve_square(&mut t) {
            t.fill(0.0);
        }
        t
    } else {
        let a = Mat::<f64>::from_fn(bal.n, m, |j, i| bal.a[j * m + i]);
        crate::qp::min_norm_above(&a, &bal.b, 0.0).unwrap_or_else(|| vec![0.0; m])
    };
    let mut p = 0;
    for (o, cable) in out.iter_mut().zip(&model.cables) {
        *o = match cable.mode {
            Mode::Force | Mode::Displacement => cable.tension,
            Mode::Position => {
                p += 1;
                t[p - 1]
            }
        };
        if !(o.is_finite() && *o > 0.0) {
            *o = 0.0;
        }
    }
}

/// The nominal motion of a command sequence, what the sliding directions
/// and the sticking bands need (`docs/model.md`, "Sliding directions and
/// the sticking band"): per command and hole the distal length `d` (m),
/// the wrap angle `beta` (rad) and the cable's frictionless tension
/// `tension` (N) at the command's nominal configuration, and `d0` the
/// straight pose's distal lengths.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    pub holes: Holes,
    pub d: Vec<f64>,
    pub beta: Vec<f64>,
    pub tension: Vec<f64>,
    pub d0: Vec<f64>,
}

impl Motion {
    /// The motion through the nominal configurations `configs` (`(R, n)`, rad).
    pub fn new<G: Group>(model: &Model, configs: &[f64]) -> Motion {
        let n = model.n();
        let holes = Holes::of(model);
        let h = holes.total;
        let rows = configs.len() / n.max(1);
        let mut chain = Chain::<f64, G::Frame<f64>>::new(model);
        let mut bal = Balance::<f64>::new(model);
        let mut t = vec![0.0; model.cables.len()];
        let mut out = Motion {
            d: vec![0.0; rows * h],
            beta: vec![0.0; rows * h],
            tension: vec![0.0; rows * h],
            d0: vec![0.0; h],
            holes,
        };
        let mut scratch = vec![0.0; h];
        chain.at(model, model, &vec![0.0; n]);
        hole_geometry(model, &chain, &out.holes, &mut out.d0, &mut scratch);
        for j in 0..rows {
            chain.at(model, model, &configs[j * n..(j + 1) * n]);
            let (d, beta) = (
                &mut out.d[j * h..(j + 1) * h],
                &mut out.beta[j * h..(j + 1) * h],
            );
            hole_geometry(model, &chain, &out.holes, d, beta);
            nominal_tensions(model, &mut chain, &mut bal, &mut t);
            for (c, cable) in model.cables.iter().enumerate() {
                let s = out.holes.start[c];
                out.tension[j * h + s..j * h + s + 2 * cable.end].fill(t[c]);
            }
        }
        out
    }

    /// Number of commands.
    pub fn len(&self) -> usize {
        self.d.len() / self.holes.total.max(1)
    }

    pub fn is_empty(&self) -> bool {
        self.d.is_empty()
    }
}

/// A change of a distal length (m) at or below which a hole counts as
/// still: the round-off of lengths that did not move (a hole straight at
/// the nominal configuration has a band of round-off width, so it would
/// otherwise take the sign of the round-off).
pub const STILL: f64 = 1e-12;

/// The mobilisation of every hole after each command of `motion` (`(R,
/// H)`), for friction `mu` and compliance `kappa` (1/N), from the start
/// state (every hole at `z = +1` at the straight pose): per command and
/// hole, with `Δd` the change of its distal length and `w = kappa T d
/// sinh(mu beta)` its band's half-width, `z <- clamp(z - Δd / w, -1, 1)`
/// (`w > 0`), `z <- -sign(Δd)` (`w = 0`); unchanged where `|Δd| <=` [`STILL`].
pub fn mobilisation<S: Real>(motion: &Motion, mu: S, kappa: S) -> Vec<S> {
    let h = motion.holes.total;
    let rows = motion.len();
    let one = S::cst(1.0);
    let mut z = vec![one; h];
    let mut prev = motion.d0.clone();
    let mut out = Vec::with_capacity(rows * h);
    for j in 0..rows {
        for i in 0..h {
            let k = j * h + i;
            let d = motion.d[k];
            let step = d - prev[i];
            let w = kappa * (motion.tension[k] * d) * sinh(mu * motion.beta[k]);
            if step.abs() <= STILL {
                // round-off of a length that did not move: the hole holds
            } else if w.val() > 0.0 {
                let t = z[i] - S::cst(step) / w;
                z[i] = if t.val() > 1.0 {
                    one
                } else if t.val() < -1.0 {
                    -one
                } else {
                    t
                };
            } else {
                z[i] = S::cst(-step.signum());
            }
            out.push(z[i]);
            prev[i] = d;
        }
    }
    out
}

/// A bounding sliding state of the statics: friction `mu` with every hole
/// of every position cable at mobilisation `position` and of every force
/// cable at `force` (pulling: `+1, -1`; releasing: `-1, +1`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sliding {
    pub mu: f64,
    pub position: f64,
    pub force: f64,
}

impl Sliding {
    /// Pulling: the actuators haul the arm against the force cables
    /// (position cables' holes at `z = +1`, force cables' at `-1`).
    pub fn pulling(mu: f64) -> Sliding {
        Sliding {
            mu,
            position: 1.0,
            force: -1.0,
        }
    }

    /// Releasing: the opposite state (`z = -1` and `+1`).
    pub fn releasing(mu: f64) -> Sliding {
        Sliding {
            mu,
            position: -1.0,
            force: 1.0,
        }
    }

    /// An error naming `friction` unless `0 <= mu <= MU_MAX` ([`check_mu`])
    /// and the mobilisations are within `[-1, 1]`.
    pub fn check(&self) -> Result<()> {
        check_mu("friction", self.mu)?;
        if !(self.position.abs() <= 1.0 && self.force.abs() <= 1.0) {
            return Err(CdsmError::Option {
                name: "sliding".into(),
                problem: "mobilisations must be within [-1, 1]".into(),
            });
        }
        Ok(())
    }

    /// The mobilisation of every hole (per hole, [`Holes`]).
    pub fn mobilisations(&self, model: &Model, holes: &Holes) -> Vec<f64> {
        let mut z = vec![0.0; holes.total];
        for (c, cable) in model.cables.iter().enumerate() {
            let v = match cable.mode {
                Mode::Position => self.position,
                Mode::Force | Mode::Displacement => self.force,
            };
            z[holes.start[c]..holes.start[c] + 2 * cable.end].fill(v);
        }
        z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinds::{Planar, Se2, Se3};
    use crate::robot::PlanarView;

    #[test]
    fn planar_and_spatial_profiles_of_the_paper_arm_agree() {
        // the planar arm and the same arm as a spatial file: the same wraps
        let r = PlanarView::paper();
        let m = Model::from_planar(&r);
        let s = Model::from_toml(include_str!("../python/cdsm/robots/paper_spatial.toml")).unwrap();
        let holes = Holes::of(&m);
        assert_eq!(holes, Holes::of(&s));
        let th = [0.3, -0.2, 0.25];
        let z: Vec<f64> = (0..holes.total)
            .map(|i| if i % 3 == 0 { -1.0 } else { 0.4 })
            .collect();
        let mut a = Chain::<f64, Se2<f64>>::new(&m);
        let mut b = Chain::<f64, Se3<f64>>::new(&s);
        a.at(&m, &m, &th);
        b.at(&s, &s, &th);
        let (mut pa, mut pb) = (Profile::<f64>::new(&m), Profile::<f64>::new(&s));
        pa.at(&m, &m, &a, &holes, &z, 0.2, 0.05);
        pb.at(&s, &s, &b, &holes, &z, 0.2, 0.05);
        for (x, y) in pa
            .gap
            .iter()
            .zip(&pb.gap)
            .chain(pa.mean.iter().zip(&pb.mean))
        {
            assert!((x - y).abs() < 1e-14, "{x} vs {y}");
        }
        // at mu = 0 every factor is 1
        pa.at(&m, &m, &a, &holes, &z, 0.0, 0.05);
        assert!(pa.gap.iter().all(|g| *g == 1.0));
        assert!(pa.mean.iter().all(|g| (*g - 1.0).abs() < 1e-15));
        let _ = Motion::new::<Planar>(&m, &th);
    }
}
