//! The one segment geometry of the model (`docs/model.md`, Eq. 1–5), written
//! once over any [`Real`] scalar: cable segments across the joints, disk
//! traversals, and the chain of frames. Cable lengths, their Jacobians, the
//! closed form's coefficients, hole sensitivities, the statics' moment arms
//! and the plant (with perturbed holes, links and hole clearance) all use it.
//!
//! Joint `k` (0-based) sits between disk `k` (0 = base) and disk `k + 1`.
//! Segment `k` of cable `c` runs from the hole on face `b` of disk `k` to the
//! hole on face `a` of disk `k + 1`; in the frame of disk `k`'s face `b`:
//! `v = A - p = w + Rot(theta_k) u` with `w = (link_before[k], 0) - p` and
//! `u = q + (link_after[k], 0)`, so `|v|^2 = P + Q cos(theta_k) + R sin(theta_k)`.

use crate::real::Real;
use crate::robot::{hole_index, PlanarView};

/// Links, disks and holes of an arm in any scalar (m): implemented by the
/// robot description ([`PlanarView`], `f64`) and by [`WithHoles`] (its numbers
/// with other holes). The geometry is written once, in
/// the provided methods.
pub trait ArmGeometry<S: Real> {
    /// Number of joints.
    fn n(&self) -> usize;
    fn link_before(&self, k: usize) -> S;
    fn link_after(&self, k: usize) -> S;
    fn thickness(&self, k: usize) -> S;
    /// `(x, y)` of the hole of cable `c` in disk `d`, face `f` (0 = a, 1 = b).
    fn hole(&self, c: usize, d: usize, f: usize) -> [S; 2];

    /// Segment `k` of cable `c`, both of its holes moved by `shift` along
    /// their `y` (hole clearance; 0 for the arm's own holes).
    #[inline]
    fn segment(&self, c: usize, k: usize, shift: S) -> Segment<S> {
        let p = self.hole(c, k, 1);
        let q = self.hole(c, k + 1, 0);
        Segment {
            w: [self.link_before(k) - p[0], -(p[1] + shift)],
            u: [q[0] + self.link_after(k), q[1] + shift],
        }
    }

    /// Length of cable `c`'s path through disk `k + 1` (m), its face-`a` hole
    /// moved by `shift_a` and its face-`b` hole by `shift_b` along `y`.
    #[inline]
    fn traversal(&self, c: usize, k: usize, shift_a: S, shift_b: S) -> S {
        let a = self.hole(c, k + 1, 0);
        let b = self.hole(c, k + 1, 1);
        let t = traversal_vector(self.thickness(k), a, b, shift_a, shift_b);
        S::hypot2(t[0], t[1])
    }

    /// Length of cable `c` (m) at the joints' `(cos, sin)` (the arm's own holes).
    fn cable_length(&self, c: usize, cs: &[(S, S)]) -> S {
        let z = S::cst(0.0);
        let mut len = z;
        for (k, csk) in cs.iter().enumerate().take(pair(c) + 1) {
            len += self.segment(c, k, z).length(*csk) + self.traversal(c, k, z, z);
        }
        len
    }

    /// End pose `[x, y, phi]` (Eq. 1–3) from the joint angles (m, m, rad).
    fn fk(&self, theta: &[S]) -> [S; 3] {
        let z = S::cst(0.0);
        let (mut x, mut y, mut phi) = (z, z, z);
        for (k, t) in theta.iter().enumerate() {
            let (s, c) = phi.sin_cos();
            x += self.link_before(k) * c;
            y += self.link_before(k) * s;
            phi += *t;
            let (s, c) = phi.sin_cos();
            let l = self.link_after(k) + self.thickness(k);
            x += l * c;
            y += l * s;
        }
        [x, y, phi]
    }

    /// End position from the joints' `(cos, sin)` and their sum `phi`, without
    /// trigonometry: the rotations compose by angle addition.
    fn fk_cs(&self, cs: &[(S, S)], phi: S) -> [S; 3] {
        let z = S::cst(0.0);
        let (mut x, mut y) = (z, z);
        let (mut c, mut s) = (S::cst(1.0), z);
        for (k, &(ck, sk)) in cs.iter().enumerate() {
            x += self.link_before(k) * c;
            y += self.link_before(k) * s;
            (c, s) = (c * ck - s * sk, s * ck + c * sk);
            let l = self.link_after(k) + self.thickness(k);
            x += l * c;
            y += l * s;
        }
        [x, y, phi]
    }

    /// The chain in the base frame: joint positions `J_k`, disk centres
    /// (the point `(thickness/2, 0)` of face `a`'s frame), and the tip.
    fn chain(&self, theta: &[S], joint: &mut [[S; 2]], centre: &mut [[S; 2]]) -> [S; 2] {
        let z = S::cst(0.0);
        let mut o = [z, z];
        let mut phi = z;
        for (k, t) in theta.iter().enumerate() {
            let (s, c) = phi.sin_cos();
            let j = [
                o[0] + self.link_before(k) * c,
                o[1] + self.link_before(k) * s,
            ];
            phi += *t;
            let (s, c) = phi.sin_cos();
            let a = [j[0] + self.link_after(k) * c, j[1] + self.link_after(k) * s];
            joint[k] = j;
            let h = self.thickness(k) * 0.5;
            centre[k] = [a[0] + h * c, a[1] + h * s];
            o = [a[0] + self.thickness(k) * c, a[1] + self.thickness(k) * s];
        }
        o
    }
}

/// Pair (0-based) of cable `c`: cable `c` crosses joints `0..=pair(c)`.
#[inline]
pub fn pair(c: usize) -> usize {
    c / 2
}

/// The robot description in any scalar: its numbers are constants.
impl<S: Real> ArmGeometry<S> for PlanarView {
    #[inline]
    fn n(&self) -> usize {
        self.link_before.len()
    }
    #[inline]
    fn link_before(&self, k: usize) -> S {
        S::cst(self.link_before[k])
    }
    #[inline]
    fn link_after(&self, k: usize) -> S {
        S::cst(self.link_after[k])
    }
    #[inline]
    fn thickness(&self, k: usize) -> S {
        S::cst(self.thickness[k])
    }
    #[inline]
    fn hole(&self, c: usize, d: usize, f: usize) -> [S; 2] {
        let i = hole_index(self.link_before.len(), c, d, f);
        [S::cst(self.holes[i]), S::cst(self.holes[i + 1])]
    }
}

/// A robot's links with other hole positions (flat `(2n, n+1, 2, 2)`, m).
#[derive(Debug, Clone, Copy)]
pub struct WithHoles<'a> {
    pub robot: &'a PlanarView,
    pub holes: &'a [f64],
}

impl ArmGeometry<f64> for WithHoles<'_> {
    #[inline]
    fn n(&self) -> usize {
        self.robot.link_before.len()
    }
    #[inline]
    fn link_before(&self, k: usize) -> f64 {
        self.robot.link_before[k]
    }
    #[inline]
    fn link_after(&self, k: usize) -> f64 {
        self.robot.link_after[k]
    }
    #[inline]
    fn thickness(&self, k: usize) -> f64 {
        self.robot.thickness[k]
    }
    #[inline]
    fn hole(&self, c: usize, d: usize, f: usize) -> [f64; 2] {
        let i = hole_index(self.n(), c, d, f);
        [self.holes[i], self.holes[i + 1]]
    }
}

/// The vector through a disk from its face-`a` hole to its face-`b` hole, in
/// face `a`'s frame: `(thickness + b_x - a_x, (b_y + shift_b) - (a_y + shift_a))`.
#[inline]
pub fn traversal_vector<S: Real>(
    thickness: S,
    a: [S; 2],
    b: [S; 2],
    shift_a: S,
    shift_b: S,
) -> [S; 2] {
    [thickness + b[0] - a[0], (b[1] + shift_b) - (a[1] + shift_a)]
}

/// One cable segment across a joint: `v(theta) = w + Rot(theta) u` (m).
#[derive(Debug, Clone, Copy)]
pub struct Segment<S> {
    pub w: [S; 2],
    pub u: [S; 2],
}

impl<S: Real> Segment<S> {
    /// `Rot(theta) u` from `(cos, sin)` of the joint angle.
    #[inline]
    pub fn rotated_u(&self, (c, s): (S, S)) -> [S; 2] {
        [c * self.u[0] - s * self.u[1], s * self.u[0] + c * self.u[1]]
    }

    /// `v = A - p`, from the hole of the proximal disk to the one of the distal disk.
    #[inline]
    pub fn vector(&self, cs: (S, S)) -> [S; 2] {
        let r = self.rotated_u(cs);
        [self.w[0] + r[0], self.w[1] + r[1]]
    }

    /// Segment length `|v|` (m).
    #[inline]
    pub fn length(&self, cs: (S, S)) -> S {
        let v = self.vector(cs);
        S::hypot2(v[0], v[1])
    }

    /// Length and its derivative with respect to the joint angle,
    /// `d|v|/dtheta = (Rot u) x v / |v|` (m, m/rad). Minus the derivative is
    /// the moment arm of a unit tension about the joint (statics).
    #[cfg(test)]
    pub fn length_and_derivative(&self, cs: (S, S)) -> (S, S) {
        let r = self.rotated_u(cs);
        let v = [self.w[0] + r[0], self.w[1] + r[1]];
        let l = S::hypot2(v[0], v[1]);
        let d = if l.val() > 0.0 {
            (r[0] * v[1] - r[1] * v[0]) / l
        } else {
            S::cst(0.0)
        };
        (l, d)
    }
}

impl Segment<f64> {
    /// `[P, Q, R]` with `|v|^2 = P + Q cos(theta) + R sin(theta)`.
    #[inline]
    pub fn pqr(&self) -> [f64; 3] {
        let (w, u) = (self.w, self.u);
        [
            w[0] * w[0] + w[1] * w[1] + u[0] * u[0] + u[1] * u[1],
            2.0 * (w[0] * u[0] + w[1] * u[1]),
            2.0 * (w[1] * u[0] - w[0] * u[1]),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::real::{Arith, Dual};

    /// An owned arm in any scalar (m): links, disks and holes (flat
    /// `(2n, n+1, 2, 2)` C-order: cable, disk, face (a, b), (x, y)).
    #[derive(Debug, Clone)]
    struct Arm<S> {
        link_before: Vec<S>,
        link_after: Vec<S>,
        thickness: Vec<S>,
        holes: Vec<S>,
    }

    impl<S: Real> Arm<S> {
        /// The arm of `robot`, with other hole positions `holes` (flat, m) if given.
        fn of(robot: &PlanarView, holes: Option<&[f64]>) -> Arm<S> {
            let cv = |v: &[f64]| v.iter().map(|x| S::cst(*x)).collect::<Vec<S>>();
            Arm {
                link_before: cv(&robot.link_before),
                link_after: cv(&robot.link_after),
                thickness: cv(&robot.thickness),
                holes: cv(holes.unwrap_or(&robot.holes)),
            }
        }
    }

    impl<S: Real> ArmGeometry<S> for Arm<S> {
        #[inline]
        fn n(&self) -> usize {
            self.link_before.len()
        }
        #[inline]
        fn link_before(&self, k: usize) -> S {
            self.link_before[k]
        }
        #[inline]
        fn link_after(&self, k: usize) -> S {
            self.link_after[k]
        }
        #[inline]
        fn thickness(&self, k: usize) -> S {
            self.thickness[k]
        }
        #[inline]
        fn hole(&self, c: usize, d: usize, f: usize) -> [S; 2] {
            let i = hole_index(self.link_before.len(), c, d, f);
            [self.holes[i], self.holes[i + 1]]
        }
    }

    #[test]
    fn pqr_form_equals_the_vector_length() {
        let arm = PlanarView::paper();
        for c in 0..6 {
            for k in 0..=pair(c) {
                let seg = arm.segment(c, k, 0.0);
                let [p, q, rr] = seg.pqr();
                for t in [-0.7f64, 0.1, 0.5] {
                    let (s, co) = t.sin_cos();
                    let l = seg.length((co, s));
                    assert!((l * l - (p + q * co + rr * s)).abs() < 1e-16);
                }
            }
        }
    }

    #[test]
    fn derivative_is_exact_in_dual_numbers() {
        let r = PlanarView::paper();
        let arm = Arm::<Dual>::of(&r, None);
        for t in [-0.4f64, 0.0, 0.3] {
            let (s, c) = Dual::var(t).sin_cos();
            let seg = arm.segment(4, 1, Dual::cst(0.0));
            let (l, d) = seg.length_and_derivative((c, s));
            assert!((l.der() - d.v).abs() < 1e-15, "{t}: {} vs {}", l.der(), d.v);
        }
    }
}
