//! The geometry of the one arm model, written once over the arm's kind (its
//! [`Frame`]) and any [`Arith`] scalar (`docs/model.md`, "The arm model"):
//! the motion across each disk's joints, the chain of frames, cable lengths
//! and their Jacobian, the end frame, the geometric Jacobian and the
//! moments of gravity and of a tip wrench about the joint axes.
//!
//! Disk `k` (1-based) follows its joints: the motion from the distal face
//! `b` of disk `k - 1` (the base frame for `k = 1`) to the proximal face `a`
//! of disk `k` is
//!
//! ```text
//! T_k = prod_{j in disk k} Trans(offset_j) Rot(axis_j, theta_j) · Trans(link_after_k)
//! ```
//!
//! and face `b` is face `a` moved by `thickness_k` along its `x`. Segment `k`
//! of cable `c` runs from its hole `b_{k-1}` on face `b` of disk `k - 1` to
//! its hole `a_k` on face `a` of disk `k`: in the frame of face `b` of disk
//! `k - 1` it is `v_k = T_k a_k - b_{k-1}`, so its length depends on disk `k`'s
//! joints alone and `dL_c / dtheta_j = u_k · (w_j × (T_k a_k - p_j))` for a
//! joint `j` of disk `k` (`u_k = v_k / |v_k|`, `p_j`, `w_j` the joint's origin
//! and axis in that frame). The traversal of disk `k` is the constant
//! `|thickness_k e_x + b_k - a_k|`.

use crate::kinds::{Frame, Se3, Vector};
use crate::model::Model;
use crate::real::Arith;

/// The numbers of an arm in a scalar (m; unit axes): the model's own, or a
/// perturbed copy ([`ArmNumbers`], the plant's arm).
pub trait Numbers<S: Arith> {
    /// Unit axis of joint `j` in its frame.
    fn axis(&self, j: usize) -> [S; 3];
    /// Offset of joint `j` from the previous frame, in that frame.
    fn offset(&self, j: usize) -> [S; 3];
    /// Last joint of disk `d + 1` -> its proximal face (0-based `d`).
    fn link_after(&self, d: usize) -> [S; 3];
    /// Thickness of disk `d + 1`.
    fn thickness(&self, d: usize) -> S;
    /// Hole `i` of cable `c` in its face frame: `i = 0` on the base face
    /// `b`, `2k - 1` on face `a` and `2k` on face `b` of disk `k`.
    fn hole(&self, c: usize, i: usize) -> [S; 3];
    /// Centre of mass of disk `d + 1` in its face-`a` frame.
    fn com(&self, d: usize) -> [S; 3];
    /// The sum of cable `c`'s traversals of the disks it crosses (m): the
    /// part of its length no joint changes (holes without clearance).
    fn traverse(&self, model: &Model, c: usize) -> S {
        let z = S::cst(0.0);
        (1..=model.cables[c].end).fold(z, |acc, k| {
            let t = [self.thickness(k - 1), z, z]
                .add(self.hole(c, 2 * k))
                .sub(self.hole(c, 2 * k - 1));
            acc + t.norm()
        })
    }
}

#[inline]
fn cst3<S: Arith>(v: &[f64; 3]) -> [S; 3] {
    [S::cst(v[0]), S::cst(v[1]), S::cst(v[2])]
}

impl<S: Arith> Numbers<S> for Model {
    #[inline]
    fn axis(&self, j: usize) -> [S; 3] {
        cst3(&self.joints[j].axis)
    }
    #[inline]
    fn offset(&self, j: usize) -> [S; 3] {
        cst3(&self.joints[j].offset)
    }
    #[inline]
    fn link_after(&self, d: usize) -> [S; 3] {
        cst3(&self.disks[d].link_after)
    }
    #[inline]
    fn thickness(&self, d: usize) -> S {
        S::cst(self.disks[d].thickness)
    }
    #[inline]
    fn hole(&self, c: usize, i: usize) -> [S; 3] {
        cst3(&self.cables[c].holes[i])
    }
    #[inline]
    fn com(&self, d: usize) -> [S; 3] {
        cst3(&self.disks[d].com)
    }
}

/// An arm's numbers held in a scalar: the model's, then moved (the plant's
/// perturbed arm). The structure (which joints a disk has, where a cable
/// ends) stays the model's.
#[derive(Debug, Clone, PartialEq)]
pub struct ArmNumbers<S> {
    pub axis: Vec<[S; 3]>,
    pub offset: Vec<[S; 3]>,
    pub link_after: Vec<[S; 3]>,
    pub thickness: Vec<S>,
    pub com: Vec<[S; 3]>,
    /// Per cable, its holes as [`Numbers::hole`] numbers them.
    pub holes: Vec<Vec<[S; 3]>>,
    /// Per cable, [`Numbers::traverse`] (kept by [`ArmNumbers::settled`]).
    traverse: Vec<S>,
}

impl<S: Arith> ArmNumbers<S> {
    /// The model's numbers as constants.
    pub fn of(model: &Model) -> Self {
        let mut a = ArmNumbers {
            axis: model.joints.iter().map(|j| cst3(&j.axis)).collect(),
            offset: model.joints.iter().map(|j| cst3(&j.offset)).collect(),
            link_after: model.disks.iter().map(|d| cst3(&d.link_after)).collect(),
            thickness: model.disks.iter().map(|d| S::cst(d.thickness)).collect(),
            com: model.disks.iter().map(|d| cst3(&d.com)).collect(),
            holes: model
                .cables
                .iter()
                .map(|c| c.holes.iter().map(cst3).collect())
                .collect(),
            traverse: Vec::new(),
        };
        a.settled(model);
        a
    }

    /// Recomputes what is derived from the numbers (the traversals): call
    /// after moving them.
    pub fn settled(&mut self, model: &Model) {
        self.traverse = Vec::new();
        self.traverse = (0..model.cables.len())
            .map(|c| Numbers::traverse(self, model, c))
            .collect();
    }
}

impl<S: Arith> Numbers<S> for ArmNumbers<S> {
    #[inline]
    fn axis(&self, j: usize) -> [S; 3] {
        self.axis[j]
    }
    #[inline]
    fn offset(&self, j: usize) -> [S; 3] {
        self.offset[j]
    }
    #[inline]
    fn link_after(&self, d: usize) -> [S; 3] {
        self.link_after[d]
    }
    #[inline]
    fn thickness(&self, d: usize) -> S {
        self.thickness[d]
    }
    #[inline]
    fn hole(&self, c: usize, i: usize) -> [S; 3] {
        self.holes[c][i]
    }
    #[inline]
    fn com(&self, d: usize) -> [S; 3] {
        self.com[d]
    }
    fn traverse(&self, model: &Model, c: usize) -> S {
        match self.traverse.get(c) {
            Some(t) => *t,
            None => {
                let z = S::cst(0.0);
                (1..=model.cables[c].end).fold(z, |acc, k| {
                    let t = [self.thickness[k - 1], z, z]
                        .add(self.holes[c][2 * k])
                        .sub(self.holes[c][2 * k - 1]);
                    acc + t.norm()
                })
            }
        }
    }
}

/// An arm's `f64` numbers as the numbers of any scalar (a pack's lanes all
/// hold the same arm), with the traversals ([`Numbers::traverse`]) given,
/// computed once per arm ([`Broadcast::traversals`]).
#[derive(Debug, Clone, Copy)]
pub struct Broadcast<'a, N> {
    pub nums: &'a N,
    traverse: &'a [f64],
}

impl<'a, N: Numbers<f64>> Broadcast<'a, N> {
    /// `traverse`: [`Broadcast::traversals`] of `nums`.
    pub fn new(nums: &'a N, traverse: &'a [f64]) -> Self {
        Broadcast { nums, traverse }
    }

    /// The traversal sums of the arm `nums` (m) of the cables `cables`
    /// into `out`, indexed by cable (the others NaN: not to be read).
    pub fn traversals(model: &Model, nums: &N, cables: &[usize], out: &mut Vec<f64>) {
        out.clear();
        out.resize(model.cables.len(), f64::NAN);
        for &c in cables {
            out[c] = nums.traverse(model, c);
        }
    }
}

#[inline(always)]
fn splat3<S: Arith>(v: [f64; 3]) -> [S; 3] {
    [S::cst(v[0]), S::cst(v[1]), S::cst(v[2])]
}

impl<S: Arith, N: Numbers<f64>> Numbers<S> for Broadcast<'_, N> {
    #[inline(always)]
    fn axis(&self, j: usize) -> [S; 3] {
        splat3(self.nums.axis(j))
    }
    #[inline(always)]
    fn offset(&self, j: usize) -> [S; 3] {
        splat3(self.nums.offset(j))
    }
    #[inline(always)]
    fn link_after(&self, d: usize) -> [S; 3] {
        splat3(self.nums.link_after(d))
    }
    #[inline(always)]
    fn thickness(&self, d: usize) -> S {
        S::cst(self.nums.thickness(d))
    }
    #[inline(always)]
    fn hole(&self, c: usize, i: usize) -> [S; 3] {
        splat3(self.nums.hole(c, i))
    }
    #[inline(always)]
    fn com(&self, d: usize) -> [S; 3] {
        splat3(self.nums.com(d))
    }
    #[inline(always)]
    fn traverse(&self, _model: &Model, c: usize) -> S {
        S::cst(self.traverse[c])
    }
}

/// The frames of one configuration: the motion across every disk's joints
/// (local), the joints within it, and (after [`Chain::world`]) every frame
/// in the base frame. Buffers sized once per model.
#[derive(Debug, Clone)]
pub struct Chain<S: Arith, F: Frame<S>> {
    /// `T_k` per disk (index `k - 1`): face `b` of disk `k - 1` -> face `a` of disk `k`.
    pub local: Vec<F>,
    /// Origin and axis of every joint in the frame of face `b` of the disk before it.
    pub joint_p: Vec<F::V>,
    pub joint_w: Vec<F::Axis>,
    /// Faces `a` and `b` of every disk in the base frame.
    pub face_a: Vec<F>,
    pub face_b: Vec<F>,
    /// Origin and axis of every joint in the base frame.
    pub world_p: Vec<F::V>,
    pub world_w: Vec<F::Axis>,
    /// `(cos, sin)` of every joint angle.
    pub cs: Vec<(S, S)>,
    /// Whether the world frames are those of the last [`Chain::at`].
    world_done: bool,
}

impl<S: Arith, F: Frame<S>> Chain<S, F> {
    pub fn new(model: &Model) -> Self {
        let (n, k) = (model.n(), model.disks.len());
        let id = F::identity();
        let w = id.axis([S::cst(0.0), S::cst(0.0), S::cst(1.0)]);
        Chain {
            local: vec![id; k],
            joint_p: vec![F::V::zero(); n],
            joint_w: vec![w; n],
            face_a: vec![id; k],
            face_b: vec![id; k],
            world_p: vec![F::V::zero(); n],
            world_w: vec![w; n],
            cs: vec![(S::cst(1.0), S::cst(0.0)); n],
            world_done: false,
        }
    }

    /// The motions across the disks at `theta` (rad): [`Chain::local`] and
    /// the joints in their disks' frames.
    pub fn at<N: Numbers<S>>(&mut self, model: &Model, nums: &N, theta: &[S]) {
        for (cs, t) in self.cs.iter_mut().zip(theta) {
            let (s, c) = t.sin_cos();
            *cs = (c, s);
        }
        self.at_cs(model, nums, theta);
    }

    /// [`Chain::at`] with the `(cos, sin)` of `theta` already in
    /// [`Chain::cs`] (the solves compute them with their lanes' kernel).
    #[inline(always)]
    pub fn at_cs<N: Numbers<S>>(&mut self, model: &Model, nums: &N, theta: &[S]) {
        for (d, disk) in model.disks.iter().enumerate() {
            let mut g = F::identity();
            for j in disk.joints.clone() {
                let a = nums.axis(j);
                let o = F::V::of(nums.offset(j));
                if j == disk.joints.start {
                    self.joint_p[j] = o;
                    self.joint_w[j] = F::base_axis(a);
                    g = F::at_turned(o, a, theta[j], self.cs[j]);
                } else {
                    g = g.translated(o);
                    self.joint_p[j] = g.origin();
                    self.joint_w[j] = g.axis(a);
                    g = g.turned(a, theta[j], self.cs[j]);
                }
            }
            self.local[d] = g.translated(F::V::of(nums.link_after(d)));
        }
        self.world_done = false;
    }

    /// Every face frame in the base frame, from the motions of
    /// [`Chain::at`] (once per configuration: a second call returns at once).
    pub fn world<N: Numbers<S>>(&mut self, model: &Model, nums: &N) {
        if self.world_done {
            return;
        }
        self.world_done = true;
        let mut prev = F::identity();
        for d in 0..model.disks.len() {
            let a = prev.compose(&self.local[d]);
            let z = S::cst(0.0);
            let b = a.translated(F::V::of([nums.thickness(d), z, z]));
            self.face_a[d] = a;
            self.face_b[d] = b;
            prev = b;
        }
    }

    /// Every joint's origin and axis in the base frame ([`Chain::world_p`],
    /// [`Chain::world_w`]), after [`Chain::world`].
    pub fn joints_world(&mut self, model: &Model) {
        let id = F::identity();
        for (d, disk) in model.disks.iter().enumerate() {
            let prev = if d == 0 { &id } else { &self.face_b[d - 1] };
            for j in disk.joints.clone() {
                self.world_p[j] = prev.point(self.joint_p[j]);
                self.world_w[j] = prev.map_axis(self.joint_w[j]);
            }
        }
    }

    /// The end frame (face `b` of the last disk) after [`Chain::world`].
    pub fn end(&self) -> &F {
        self.face_b.last().expect("a model has at least one disk")
    }

    /// Segment `k` (1-based disk) of cable `c` in the frame of face `b` of
    /// disk `k - 1`: `(A_k, B_{k-1})` with its holes moved by `shift`
    /// (`(on face b, on face a)`, as [`Frame::bend_shift`]).
    #[inline(always)]
    fn segment<N: Numbers<S>>(
        &self,
        nums: &N,
        c: usize,
        k: usize,
        shift: Option<(F::V, F::V)>,
    ) -> (F::V, F::V) {
        let mut a = F::V::of(nums.hole(c, 2 * k - 1));
        let mut b = F::V::of(nums.hole(c, 2 * k - 2));
        if let Some((sb, sa)) = shift {
            a = a.add(sa);
            b = b.add(sb);
        }
        (self.local[k - 1].point(a), b)
    }

    /// Gap `k` (1-based disk) of cable `c` as a vector (m), from its hole on
    /// face `b` of disk `k - 1` to its hole on face `a` of disk `k`, in the
    /// frame of face `b` of disk `k - 1` (the model's own holes).
    #[inline]
    pub fn gap<N: Numbers<S>>(&self, nums: &N, c: usize, k: usize) -> F::V {
        let (a, b) = self.segment(nums, c, k, None);
        a.sub(b)
    }

    /// The traversal of disk `k` (1-based) by cable `c` as a vector (m),
    /// from its hole on face `a` to its hole on face `b`, in the frame of
    /// face `a` (the model's own holes).
    #[inline]
    pub fn traversal<N: Numbers<S>>(&self, nums: &N, c: usize, k: usize) -> F::V {
        let z = S::cst(0.0);
        F::V::of([nums.thickness(k - 1), z, z])
            .add(F::V::of(nums.hole(c, 2 * k)))
            .sub(F::V::of(nums.hole(c, 2 * k - 1)))
    }

    /// Length of cable `c` (m) at the configuration of [`Chain::at`]; with
    /// `shift` (per disk, [`Frame::bend_shift`] of its motion), the holes
    /// beside every bend moved (hole clearance; the end disk's face-`b`
    /// hole, which no bend follows, stays).
    pub fn cable_length<N: Numbers<S>>(
        &self,
        model: &Model,
        nums: &N,
        c: usize,
        shift: Option<&[(F::V, F::V)]>,
    ) -> S {
        let end = model.cables[c].end;
        let z = S::cst(0.0);
        let Some(s) = shift else {
            let mut len = nums.traverse(model, c);
            for k in 1..=end {
                let (a, b) = self.segment(nums, c, k, None);
                len += a.sub(b).norm();
            }
            return len;
        };
        let mut len = z;
        for k in 1..=end {
            let (a, b) = self.segment(nums, c, k, Some(s[k - 1]));
            len += a.sub(b).norm();
            // traversal of disk k, in its face-a frame
            let ha = F::V::of(nums.hole(c, 2 * k - 1)).add(s[k - 1].1);
            let mut hb = F::V::of(nums.hole(c, 2 * k));
            if k < end {
                hb = hb.add(s[k].0);
            }
            let t = F::V::of([nums.thickness(k - 1), z, z]).add(hb).sub(ha);
            len += t.norm();
        }
        len
    }

    /// Row `c` of the cable Jacobian, `dL_c / dtheta` (m/rad, `n` values
    /// into `row`, zero past the cable's end), at the configuration of
    /// [`Chain::at`] (the model's own holes). A zero-length segment
    /// contributes 0.
    pub fn cable_jacobian_row<N: Numbers<S>>(
        &self,
        model: &Model,
        nums: &N,
        c: usize,
        row: &mut [S],
    ) {
        self.cable_length_and_row(model, nums, c, row);
    }

    /// The length of cable `c` (m, the model's own holes) and its row of
    /// the cable Jacobian (as [`Chain::cable_jacobian_row`]) in one pass.
    #[inline(always)]
    pub fn cable_length_and_row<N: Numbers<S>>(
        &self,
        model: &Model,
        nums: &N,
        c: usize,
        row: &mut [S],
    ) -> S {
        row.fill(S::cst(0.0));
        let mut len = nums.traverse(model, c);
        for k in 1..=model.cables[c].end {
            let (a, b) = self.segment(nums, c, k, None);
            let v = a.sub(b);
            let l = v.norm();
            len += l;
            let inv = l.recip_or_zero();
            for j in model.disks[k - 1].joints.clone() {
                row[j] = v.dot(F::rate(self.joint_w[j], self.joint_p[j], a)) * inv;
            }
        }
        len
    }

    /// The geometric Jacobian of the end frame (`(TASK, n)` row-major: the
    /// velocity of its origin, then its angular velocity) after
    /// [`Chain::world`] and [`Chain::joints_world`].
    pub fn geometric_jacobian(&self, out: &mut [S]) {
        let n = self.world_p.len();
        let tip = self.end().origin();
        let dim = F::DIM;
        let mut ang = [S::cst(0.0); 3];
        for j in 0..n {
            let v = F::rate(self.world_w[j], self.world_p[j], tip).to3();
            for i in 0..dim {
                out[i * n + j] = v[i];
            }
            F::angular(self.world_w[j], &mut ang);
            for i in 0..F::TASK - dim {
                out[(dim + i) * n + j] = ang[i];
            }
        }
    }

    /// The moments about every joint axis (N m, `n` into `out`) of gravity
    /// `g` (m/s², base frame) on the disks' masses (kg, at their centres of
    /// mass) distal of the joint and of the tip wrench `force` (N) and
    /// `couple` (N m, `[Mz]` or `[Mx, My, Mz]`) at the end frame's origin,
    /// base frame; after [`Chain::world`] and [`Chain::joints_world`].
    #[allow(clippy::too_many_arguments)]
    pub fn load_moments<N: Numbers<S>>(
        &self,
        model: &Model,
        nums: &N,
        g: [f64; 3],
        force: [S; 3],
        couple: &[S],
        out: &mut [S],
    ) {
        let gravity = g.iter().any(|v| *v != 0.0);
        let tip = self.end().origin();
        let f = F::V::of(force);
        // centres of mass in the base frame
        for (d, disk) in model.disks.iter().enumerate() {
            for j in disk.joints.clone() {
                let (w, p) = (self.world_w[j], self.world_p[j]);
                let mut t = F::moment(w, tip.sub(p), f) + F::couple(w, couple);
                if gravity {
                    for (b, db) in model.disks.iter().enumerate().skip(d) {
                        let c = self.face_a[b].point(F::V::of(nums.com(b)));
                        let weight = F::V::of(cst3(&g).scale(S::cst(db.mass)));
                        t += F::moment(w, c.sub(p), weight);
                    }
                }
                out[j] = t;
            }
        }
    }
}

/// Length of the straight arm along its chain (m): the distance of the
/// end frame's origin from the base at `theta = 0`.
pub fn straight_length(model: &Model) -> f64 {
    let mut chain = Chain::<f64, Se3<f64>>::new(model);
    chain.at(model, model, &vec![0.0; model.n()]);
    chain.world(model, model);
    let p = chain.end().origin();
    (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinds::Se2;
    use crate::real::Dual;
    use crate::robot::PlanarView;

    const TWO_UNIVERSAL: &str = include_str!("../python/cdsm/robots/two_universal.toml");
    const PAPER_SPATIAL: &str = include_str!("../python/cdsm/robots/paper_spatial.toml");

    fn thetas(n: usize, rows: usize) -> Vec<Vec<f64>> {
        (0..rows)
            .map(|r| {
                (0..n)
                    .map(|j| 0.5 * ((r * 7 + j * 3) as f64 * 0.713).sin())
                    .collect()
            })
            .collect()
    }

    #[test]
    fn spatial_jacobians_meet_central_differences() {
        let m = Model::from_toml(TWO_UNIVERSAL).unwrap();
        let n = m.n();
        let mut ch = Chain::<f64, Se3<f64>>::new(&m);
        let h = 1e-6;
        let at = |ch: &mut Chain<f64, Se3<f64>>, th: &[f64]| {
            ch.at(&m, &m, th);
            ch.world(&m, &m);
            let lens: Vec<f64> = (0..m.cables.len())
                .map(|c| ch.cable_length(&m, &m, c, None))
                .collect();
            (*ch.end(), lens)
        };
        for th in thetas(n, 10) {
            ch.at(&m, &m, &th);
            ch.world(&m, &m);
            ch.joints_world(&m);
            let mut jac = vec![0.0; 6 * n];
            ch.geometric_jacobian(&mut jac);
            let rows: Vec<Vec<f64>> = (0..m.cables.len())
                .map(|c| {
                    let mut row = vec![0.0; n];
                    ch.cable_jacobian_row(&m, &m, c, &mut row);
                    row
                })
                .collect();
            for k in 0..n {
                let (mut a, mut b) = (th.clone(), th.clone());
                a[k] += h;
                b[k] -= h;
                let ((fa, la), (fb, lb)) = (at(&mut ch, &a), at(&mut ch, &b));
                // angular velocity: log(R_a R_b^T) / 2h
                let rel: [[f64; 3]; 3] = std::array::from_fn(|i| {
                    std::array::from_fn(|j| (0..3).map(|q| fa.r[i][q] * fb.r[j][q]).sum())
                });
                let w = crate::kinds::log_so3(&rel);
                for i in 0..3 {
                    let v = (fa.t[i] - fb.t[i]) / (2.0 * h);
                    assert!((jac[i * n + k] - v).abs() < 1e-9, "velocity {i} joint {k}");
                    assert!(
                        (jac[(3 + i) * n + k] - w[i] / (2.0 * h)).abs() < 1e-9,
                        "omega {i} joint {k}"
                    );
                }
                for (c, row) in rows.iter().enumerate() {
                    let d = (la[c] - lb[c]) / (2.0 * h);
                    assert!(
                        (row[k] - d).abs() < 1e-9,
                        "cable {c} joint {k}: {} vs {d}",
                        row[k]
                    );
                }
            }
        }
    }

    #[test]
    fn the_planar_chain_is_the_planar_geometry_and_the_spatial_one() {
        let r = PlanarView::paper();
        let m = Model::from_planar(&r);
        let s = Model::from_toml(PAPER_SPATIAL).unwrap();
        let geom = crate::cables::CableGeometry::new(&r, None);
        let mut a = Chain::<f64, Se2<f64>>::new(&m);
        let mut b = Chain::<f64, Se3<f64>>::new(&s);
        for th in thetas(3, 30) {
            a.at(&m, &m, &th);
            a.world(&m, &m);
            a.joints_world(&m);
            b.at(&s, &s, &th);
            b.world(&s, &s);
            let p = crate::geometry::ArmGeometry::<f64>::fk(&r, &th);
            let mut ta = [0.0; 3];
            a.end().task(&mut ta);
            for i in 0..3 {
                assert!((ta[i] - p[i]).abs() < 1e-15, "{ta:?} vs {p:?}");
            }
            assert!((b.end().t[0] - p[0]).abs() < 1e-15 && (b.end().t[1] - p[1]).abs() < 1e-15);
            let mut lens = [0.0; 6];
            let mut jac = [0.0; 18];
            geom.lengths(&th, &mut lens);
            geom.jacobian(&th, &mut jac);
            for c in 0..6 {
                let la = a.cable_length(&m, &m, c, None);
                let lb = b.cable_length(&s, &s, c, None);
                assert!((la - lens[c]).abs() < 1e-15 && (lb - lens[c]).abs() < 1e-15);
                let mut row = [0.0; 3];
                a.cable_jacobian_row(&m, &m, c, &mut row);
                for k in 0..3 {
                    assert!((row[k] - jac[c * 3 + k]).abs() < 1e-14);
                }
            }
            let mut ga = [0.0; 9];
            a.geometric_jacobian(&mut ga);
            let mut fj = [[0.0; 3]; 3];
            crate::kinematics::fk_jacobian(&r, &th, &mut fj);
            for k in 0..3 {
                for i in 0..3 {
                    assert!((ga[i * 3 + k] - fj[k][i]).abs() < 1e-15);
                }
            }
        }
    }

    #[test]
    fn hole_clearance_in_the_plane_is_the_planar_plants_and_in_space_reduces_to_it() {
        // the planar plant's clearance lengths (docs/model.md) from the segment
        // geometry, against the chain's shifted holes, both kinds
        let r = PlanarView::paper();
        let m = Model::from_planar(&r);
        let s = Model::from_toml(PAPER_SPATIAL).unwrap();
        let (cl, w) = (1.5e-4, 0.02);
        let mut a = Chain::<f64, Se2<f64>>::new(&m);
        let mut b = Chain::<f64, Se3<f64>>::new(&s);
        for th in thetas(3, 10) {
            a.at(&m, &m, &th);
            b.at(&s, &s, &th);
            let sa: Vec<_> = a.local.iter().map(|f| f.bend_shift(cl, w)).collect();
            let sb: Vec<_> = b.local.iter().map(|f| f.bend_shift(cl, w)).collect();
            let d: Vec<f64> = th.iter().map(|t| cl * (t / w).tanh()).collect();
            for c in (0..6).step_by(2) {
                let i = c / 2;
                let mut want = 0.0;
                for k in 0..=i {
                    let cs = (th[k].cos(), th[k].sin());
                    want += crate::geometry::ArmGeometry::<f64>::segment(&r, c, k, d[k]).length(cs);
                    let next = if k < i { d[k + 1] } else { 0.0 };
                    want += crate::geometry::ArmGeometry::<f64>::traversal(&r, c, k, d[k], next);
                }
                let la = a.cable_length(&m, &m, c, Some(&sa));
                let lb = b.cable_length(&s, &s, c, Some(&sb));
                assert!((la - want).abs() < 1e-15, "{la} vs {want}");
                assert!((lb - want).abs() < 1e-15, "{lb} vs {want}");
            }
        }
    }

    #[test]
    fn the_spatial_bend_shift_is_smooth_through_the_straight_pose() {
        // at theta = 0 the shift's derivative is cl / w times the bend's
        let s = Model::from_toml(TWO_UNIVERSAL).unwrap();
        let (cl, w) = (1e-4, 0.01);
        let mut ch = Chain::<Dual, Se3<Dual>>::new(&s);
        for j in 0..2 {
            let th: Vec<Dual> = (0..4)
                .map(|i| Dual::new(0.0, if i == j { 1.0 } else { 0.0 }))
                .collect();
            ch.at(&s, &s, &th);
            let (sb, sa) = ch.local[0].bend_shift(Dual::cst(cl), Dual::cst(w));
            // pitch about y bends toward -z, yaw about z toward +y
            let want = if j == 0 {
                [0.0, 0.0, -1.0]
            } else {
                [0.0, 1.0, 0.0]
            };
            for i in 0..3 {
                assert!((sb[i].d[0] - cl / w * want[i]).abs() < 1e-15, "{j} {i}");
                assert!((sa[i].d[0] - cl / w * want[i]).abs() < 1e-15, "{j} {i}");
                assert_eq!(sb[i].v, 0.0);
            }
        }
    }

    #[test]
    fn load_moments_are_the_virtual_work_of_the_loads() {
        // tau_j = sum_b m_b g . dc_b/dtheta_j + F . dtip/dtheta_j + M . omega_j
        let m = Model::from_toml(TWO_UNIVERSAL).unwrap();
        let n = m.n();
        let mut ch = Chain::<f64, Se3<f64>>::new(&m);
        let w = [0.3, -0.2, 0.5, 0.01, -0.02, 0.03];
        let h = 1e-6;
        let points = |ch: &mut Chain<f64, Se3<f64>>, th: &[f64]| {
            ch.at(&m, &m, th);
            ch.world(&m, &m);
            let coms: Vec<[f64; 3]> = (0..m.disks.len())
                .map(|b| ch.face_a[b].point(m.disks[b].com))
                .collect();
            (coms, *ch.end())
        };
        for th in thetas(n, 10) {
            ch.at(&m, &m, &th);
            ch.world(&m, &m);
            ch.joints_world(&m);
            let mut tau = vec![0.0; n];
            ch.load_moments(&m, &m, m.gravity, [w[0], w[1], w[2]], &w[3..], &mut tau);
            let mut jac = vec![0.0; 6 * n];
            ch.geometric_jacobian(&mut jac);
            for k in 0..n {
                let (mut a, mut b) = (th.clone(), th.clone());
                a[k] += h;
                b[k] -= h;
                let ((ca, ea), (cb, eb)) = (points(&mut ch, &a), points(&mut ch, &b));
                let mut want = 0.0;
                for (bi, disk) in m.disks.iter().enumerate() {
                    for i in 0..3 {
                        want += disk.mass * m.gravity[i] * (ca[bi][i] - cb[bi][i]) / (2.0 * h);
                    }
                }
                for i in 0..3 {
                    want +=
                        w[i] * (ea.t[i] - eb.t[i]) / (2.0 * h) + w[3 + i] * jac[(3 + i) * n + k];
                }
                assert!(
                    (tau[k] - want).abs() < 1e-9,
                    "joint {k}: {} vs {want}",
                    tau[k]
                );
            }
        }
    }
}
