//! The statics of the one arm model (`docs/model.md`, "Statics"), written
//! once over the arm's kind and any [`Real`] scalar: the moment balance
//! about every joint axis and the tensions of the position-controlled cables
//! that close it.
//!
//! Frictionless pins and holes, massless straight cables, quasi-static. By
//! virtual work a cable of tension `T_c` pulls the part of the arm distal of
//! joint `j` with the moment `-T_c dL_c/dtheta_j` about the joint's axis, so
//! the balance is
//!
//! ```text
//! sum_c T_c dL_c/dtheta_j = tau_j     (j = 1..n)
//! ```
//!
//! with `tau_j` the moment of the loads on that part (gravity on the disks'
//! masses at their centres of mass, a tip wrench at the end frame's origin).
//! Force-controlled cables carry their set tension; the position-controlled
//! ones solve `J_p^T T_p = tau - J_f^T T_f`: uniquely when they are as many
//! as the joints (a planar arm's upper cables), else the minimum-norm set
//! above a floor.

use crate::chain::{Chain, Numbers};
use crate::kinds::Frame;
use crate::model::{Mode, Model};
use crate::real::Real;

/// The moment balance at one configuration: `a T_p = b` with `a = J_p^T`
/// (`(n, m_pos)` row-major, m/rad) and `b = tau - J_f^T T_f` (`(n,)`, N m).
#[derive(Debug, Clone)]
pub struct Balance<S> {
    pub n: usize,
    pub m: usize,
    pub a: Vec<S>,
    pub b: Vec<S>,
    /// The length of every cable at the balance's configuration (m, the
    /// model's own holes).
    pub lengths: Vec<S>,
    row: Vec<S>,
    /// Scratch of the square solve.
    lu: Vec<S>,
    /// The disk (0-based) of every joint.
    joint_disk: Vec<usize>,
    /// The frictionless `a`, `b` of the last [`Balance::at_friction`].
    a0: Vec<S>,
    b0: Vec<S>,
}

/// A tip wrench in a scalar: force (N) and couple (N m, `[Mz]` planar,
/// `[Mx, My, Mz]` spatial), base frame, at the end frame's origin.
#[derive(Debug, Clone, Copy)]
pub struct Wrench<'a, S> {
    pub force: [S; 3],
    pub couple: &'a [S],
}

impl<S: Real> Balance<S> {
    pub fn new(model: &Model) -> Self {
        let (n, m) = (model.n(), model.position_cables().len());
        Balance {
            n,
            m,
            a: vec![S::cst(0.0); n * m],
            b: vec![S::cst(0.0); n],
            lengths: vec![S::cst(0.0); model.cables.len()],
            row: vec![S::cst(0.0); n],
            lu: vec![S::cst(0.0); n * m],
            a0: Vec::new(),
            b0: Vec::new(),
            joint_disk: model
                .disks
                .iter()
                .enumerate()
                .flat_map(|(d, disk)| disk.joints.clone().map(move |_| d))
                .collect(),
        }
    }

    /// The balance of `model` (numbers `nums`) at `chain` (after
    /// [`Chain::at`]): gravity `g` (m/s², base frame), the tip wrench
    /// `wrench`, force cables at their set tensions.
    pub fn at<F: Frame<S>, N: Numbers<S>>(
        &mut self,
        model: &Model,
        nums: &N,
        chain: &mut Chain<S, F>,
        g: [f64; 3],
        wrench: Wrench<S>,
    ) {
        self.at_with(model, nums, chain, g, wrench, None);
    }

    /// [`Balance::at`] with the force cables at the tensions `force` (N, in
    /// the order of the force cables) when given.
    pub fn at_with<F: Frame<S>, N: Numbers<S>>(
        &mut self,
        model: &Model,
        nums: &N,
        chain: &mut Chain<S, F>,
        g: [f64; 3],
        wrench: Wrench<S>,
        force: Option<&[f64]>,
    ) {
        self.fill(model, nums, chain, g, wrench, force, None);
    }

    /// [`Balance::at_with`] with friction in the holes (`docs/model.md`,
    /// "Friction in the holes"): `gap[c * K + d]` is cable `c`'s tension in
    /// the gap before disk `d + 1` over its routing tension (`K` disks), so
    /// the cable's entry of every joint of that disk is scaled by it; the
    /// position tensions solved are the routing's. The frictionless balance
    /// is kept too ([`Balance::solve_square_frictionless`]).
    #[allow(clippy::too_many_arguments)]
    pub fn at_friction<F: Frame<S>, N: Numbers<S>>(
        &mut self,
        model: &Model,
        nums: &N,
        chain: &mut Chain<S, F>,
        g: [f64; 3],
        wrench: Wrench<S>,
        force: Option<&[f64]>,
        gap: &[S],
    ) {
        self.fill(model, nums, chain, g, wrench, force, Some(gap));
    }

    #[allow(clippy::too_many_arguments)]
    fn fill<F: Frame<S>, N: Numbers<S>>(
        &mut self,
        model: &Model,
        nums: &N,
        chain: &mut Chain<S, F>,
        g: [f64; 3],
        wrench: Wrench<S>,
        force: Option<&[f64]>,
        gap: Option<&[S]>,
    ) {
        let loaded = g.iter().any(|v| *v != 0.0)
            || wrench
                .force
                .iter()
                .chain(wrench.couple)
                .any(|v| v.val() != 0.0 || v.is_variable());
        if loaded {
            chain.world(model, nums);
            chain.joints_world(model);
            chain.load_moments(model, nums, g, wrench.force, wrench.couple, &mut self.b);
        } else {
            self.b.fill(S::cst(0.0));
        }
        if gap.is_some() {
            self.a0.resize(self.a.len(), S::cst(0.0));
            self.b0.clone_from(&self.b);
        }
        let (mut i, mut f) = (0, 0);
        for (c, cable) in model.cables.iter().enumerate() {
            // a position cable's column, or a force cable's set tension
            let entry = match cable.mode {
                Mode::Position => Ok(i),
                Mode::Force => Err(S::cst(force.map_or(cable.tension, |v| v[f]))),
                // a displacement cable (an elastic arm's: crate::elastic) holds
                // nothing in the rigid statics
                Mode::Displacement => Err(S::cst(0.0)),
            };
            self.cable(model, nums, chain, c, entry, gap);
            match cable.mode {
                Mode::Position => i += 1,
                Mode::Force => f += 1,
                Mode::Displacement => {}
            }
        }
    }

    /// Cable `c`'s length and moment arms into the balance (`entry` as
    /// [`Balance::enter`]; `gap` as [`Balance::at_friction`]).
    fn cable<F: Frame<S>, N: Numbers<S>>(
        &mut self,
        model: &Model,
        nums: &N,
        chain: &Chain<S, F>,
        c: usize,
        entry: std::result::Result<usize, S>,
        gap: Option<&[S]>,
    ) {
        let disks = model.disks.len();
        self.lengths[c] = chain.cable_length_and_row(model, nums, c, &mut self.row);
        if let Some(gap) = gap {
            Self::enter(&self.row, &mut self.a0, &mut self.b0, self.m, entry);
            for (j, r) in self.row.iter_mut().enumerate() {
                *r *= gap[c * disks + self.joint_disk[j]];
            }
        }
        Self::enter(&self.row, &mut self.a, &mut self.b, self.m, entry);
    }

    /// The balance of the last [`Balance::at_with`] (`gap` `None`) or
    /// [`Balance::at_friction`] (`gap` its argument) with position cable
    /// `c`'s length and column made again from `nums` (the same arm but for
    /// that cable's holes), at the same configuration of `chain`: the
    /// right-hand sides and the other cables' columns stay.
    pub fn refill_position<F: Frame<S>, N: Numbers<S>>(
        &mut self,
        model: &Model,
        nums: &N,
        chain: &Chain<S, F>,
        c: usize,
        gap: Option<&[S]>,
    ) {
        self.cable(model, nums, chain, c, Ok(column(model, c)), gap);
    }

    /// `other`'s balance (of the same model) into `self`, without allocating.
    pub fn copy_from(&mut self, other: &Balance<S>) {
        self.a.clone_from(&other.a);
        self.b.clone_from(&other.b);
        self.lengths.clone_from(&other.lengths);
        self.a0.clone_from(&other.a0);
        self.b0.clone_from(&other.b0);
    }

    /// Position cable `c`'s length and columns as they are in `other` (of
    /// the same model and kind of fill): undoes a
    /// [`Balance::refill_position`] of a copy of `other`.
    pub fn restore_position(&mut self, model: &Model, other: &Balance<S>, c: usize) {
        let i = column(model, c);
        self.lengths[c] = other.lengths[c];
        for j in 0..self.n {
            self.a[j * self.m + i] = other.a[j * self.m + i];
            if !self.a0.is_empty() {
                self.a0[j * self.m + i] = other.a0[j * self.m + i];
            }
        }
    }

    /// One cable's moment-arm `row` into a balance: column `i` of `a`
    /// (`entry = Ok(i)`, a position cable) or, at its tension `t`, out of
    /// the right-hand side `b` (`Err(t)`, a force cable).
    fn enter(row: &[S], a: &mut [S], b: &mut [S], m: usize, entry: std::result::Result<usize, S>) {
        match entry {
            Ok(i) => {
                for (j, r) in row.iter().enumerate() {
                    a[j * m + i] = *r;
                }
            }
            Err(t) => {
                for (bj, r) in b.iter_mut().zip(row) {
                    *bj -= *r * t;
                }
            }
        }
    }

    /// The position tensions (N) when they are as many as the joints: the
    /// balance solved exactly (Gaussian elimination with partial pivoting);
    /// false where it is singular (a cable without a moment arm).
    pub fn solve_square(&mut self, out: &mut [S]) -> bool {
        Self::solve_into(self.n, &self.a, &self.b, &mut self.lu, out)
    }

    /// [`Balance::solve_square`] of the frictionless balance of the last
    /// [`Balance::at_friction`].
    pub fn solve_square_frictionless(&mut self, out: &mut [S]) -> bool {
        Self::solve_into(self.n, &self.a0, &self.b0, &mut self.lu, out)
    }

    fn solve_into(n: usize, a: &[S], b: &[S], lu: &mut [S], out: &mut [S]) -> bool {
        debug_assert_eq!(a.len(), n * n);
        lu.copy_from_slice(a);
        out.copy_from_slice(b);
        crate::lm::lu_solve(n, lu, out)
    }
}

/// The column of position cable `c` (model index) in [`Balance::a`].
fn column(model: &Model, c: usize) -> usize {
    debug_assert_eq!(model.cables[c].mode, Mode::Position);
    model.cables[..c]
        .iter()
        .filter(|k| k.mode == Mode::Position)
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinds::{Se2, Se3};
    use crate::real::{Arith, Dual};
    use crate::robot::PlanarView;

    #[test]
    fn the_straight_paper_arm_holds_its_weights() {
        // Table 1: at theta = 0 in a horizontal plane each upper cable carries
        // its pair's lower weight (50, 10, 5 g)
        let r = PlanarView::paper();
        let m = Model::from_planar(&r);
        let mut ch = Chain::<f64, Se2<f64>>::new(&m);
        ch.at(&m, &m, &[0.0; 3]);
        let mut bal = Balance::<f64>::new(&m);
        let zero = [0.0; 3];
        bal.at(
            &m,
            &m,
            &mut ch,
            [0.0; 3],
            Wrench {
                force: zero,
                couple: &zero[..1],
            },
        );
        let mut t = [0.0; 3];
        assert!(bal.solve_square(&mut t));
        for k in 0..3 {
            assert!((t[k] - r.lower_tension[k]).abs() < 1e-14, "{t:?}");
        }
    }

    #[test]
    fn the_planar_balance_is_the_virtual_work_of_its_loads() {
        // sum_c T_c dL_c/dtheta_k = tau_k: the tip wrench through the pose
        // Jacobian, gravity through the disks' centres by central differences
        let r = PlanarView::paper();
        let m = Model::from_planar(&r);
        let th = [0.3, -0.45, 0.2];
        let (w, g) = ([0.3, -0.2, 0.0, 0.01], [1.0, -9.81, 0.0]);
        let mut ch = Chain::<f64, Se2<f64>>::new(&m);
        ch.at(&m, &m, &th);
        let mut bal = Balance::<f64>::new(&m);
        bal.at(
            &m,
            &m,
            &mut ch,
            g,
            Wrench {
                force: [w[0], w[1], w[2]],
                couple: &w[3..],
            },
        );
        let mut t = [0.0; 3];
        assert!(bal.solve_square(&mut t));
        let mut jac = [0.0; 18];
        crate::cables::CableGeometry::new(&r, None).jacobian(&th, &mut jac);
        let mut jt = [[0.0; 3]; 3];
        crate::kinematics::fk_jacobian(&r, &th, &mut jt);
        let centres = |x: &[f64; 3]| {
            let (mut j, mut c) = ([[0.0; 2]; 3], [[0.0; 2]; 3]);
            crate::geometry::ArmGeometry::<f64>::chain(&r, x, &mut j, &mut c);
            c
        };
        for k in 0..3 {
            let work: f64 = (0..6)
                .map(|c| {
                    jac[c * 3 + k]
                        * if c % 2 == 0 {
                            t[c / 2]
                        } else {
                            r.lower_tension[c / 2]
                        }
                })
                .sum();
            let mut tau = jt[k][0] * w[0] + jt[k][1] * w[1] + jt[k][2] * w[3];
            let h = 1e-6;
            let (mut a, mut b) = (th, th);
            a[k] += h;
            b[k] -= h;
            let (ca, cb) = (centres(&a), centres(&b));
            for j in 0..3 {
                tau += r.mass[j] * ((ca[j][0] - cb[j][0]) * g[0] + (ca[j][1] - cb[j][1]) * g[1])
                    / (2.0 * h);
            }
            assert!((work - tau).abs() < 1e-9, "{k}: {work} vs {tau}");
        }
    }

    #[test]
    fn the_balance_is_the_spatial_statics_and_exact_in_dual_numbers() {
        let m = Model::from_toml(include_str!("../python/cdsm/robots/two_universal.toml")).unwrap();
        let th = [0.2, -0.3, 0.1, 0.25];
        let mut ch = Chain::<f64, Se3<f64>>::new(&m);
        ch.at(&m, &m, &th);
        let mut bal = Balance::<f64>::new(&m);
        let zero = [0.0; 3];
        bal.at(
            &m,
            &m,
            &mut ch,
            m.gravity,
            Wrench {
                force: zero,
                couple: &zero,
            },
        );
        let mut t = [0.0; 4];
        assert!(bal.solve_square(&mut t));
        // the virtual work of the tensions is the loads' (no tip wrench here)
        let mut tau = [0.0; 4];
        ch.load_moments(&m, &m, m.gravity, zero, &zero, &mut tau);
        for j in 0..4 {
            let mut work = 0.0;
            for (c, cable) in m.cables.iter().enumerate() {
                let mut row = [0.0; 4];
                ch.cable_jacobian_row(&m, &m, c, &mut row);
                let tc = match cable.mode {
                    Mode::Force => cable.tension,
                    Mode::Displacement => 0.0,
                    Mode::Position => t[m.position_cables().iter().position(|p| *p == c).unwrap()],
                };
                work += tc * row[j];
            }
            assert!(
                (work - tau[j]).abs() < 1e-12 * (1.0 + tau[j].abs()),
                "{j}: {work} vs {}",
                tau[j]
            );
        }
        // d T / d theta_0 by dual numbers against central differences
        let mut chd = Chain::<Dual, Se3<Dual>>::new(&m);
        let thd: Vec<Dual> = th
            .iter()
            .enumerate()
            .map(|(i, v)| Dual::new(*v, if i == 0 { 1.0 } else { 0.0 }))
            .collect();
        chd.at(&m, &m, &thd);
        let mut bd = Balance::<Dual>::new(&m);
        let zd = [Dual::cst(0.0); 3];
        bd.at(
            &m,
            &m,
            &mut chd,
            m.gravity,
            Wrench {
                force: zd,
                couple: &zd,
            },
        );
        let mut td = [Dual::cst(0.0); 4];
        assert!(bd.solve_square(&mut td));
        let h = 1e-6;
        let mut at = |d: f64| {
            let mut x = th;
            x[0] += d;
            ch.at(&m, &m, &x);
            bal.at(
                &m,
                &m,
                &mut ch,
                m.gravity,
                Wrench {
                    force: zero,
                    couple: &zero,
                },
            );
            let mut t = [0.0; 4];
            bal.solve_square(&mut t);
            t
        };
        let (tp, tm) = (at(h), at(-h));
        for k in 0..4 {
            let fd = (tp[k] - tm[k]) / (2.0 * h);
            assert!(
                (td[k].d[0] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                "{k}: {} vs {fd}",
                td[k].d[0]
            );
        }
    }
}
