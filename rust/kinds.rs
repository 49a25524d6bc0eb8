//! The two kinds of arm as the motion groups their joints span, written over
//! any [`Real`] scalar (`docs/model.md`, "The arm model"): a planar arm's
//! frames are rigid motions of the plane (SE(2): every joint turns about
//! `z`), a spatial arm's rigid motions of space (SE(3): a joint turns about
//! any unit axis). The geometry, statics, plant and fit are written once
//! over [`Frame`]; the planar kind is the case whose frames carry one angle
//! and a 2-D origin, so its algorithms cost what the plane costs.
//!
//! The kind of a model is data: [`Kind`], whose facts (task axes, position
//! dimension, attitude form, Monte-Carlo quantities, the plant's parameter
//! layout) are one static [`KindInfo`] each; [`Kind::visit`] is the one
//! place that turns it into the motion group as a type ([`Group`]: [`Planar`]
//! for SE(2), [`Spatial`] for SE(3)).

use crate::effect::{Effect, Size};
use crate::real::{Arith, Real};

/// A vector of the arm's space: `[S; 2]` in the plane, `[S; 3]` in space.
pub trait Vector<S: Arith>: Copy + std::fmt::Debug {
    fn zero() -> Self;
    /// From a 3-D vector (the plane keeps `x`, `y`: a planar model has `z = 0`).
    fn of(v: [S; 3]) -> Self;
    /// As a 3-D vector (`z = 0` in the plane).
    fn to3(self) -> [S; 3];
    fn add(self, o: Self) -> Self;
    fn sub(self, o: Self) -> Self;
    fn scale(self, k: S) -> Self;
    fn dot(self, o: Self) -> S;
    #[inline(always)]
    fn norm(self) -> S {
        self.dot(self).sqrt()
    }
}

impl<S: Arith> Vector<S> for [S; 2] {
    #[inline(always)]
    fn zero() -> Self {
        [S::cst(0.0); 2]
    }
    #[inline(always)]
    fn of(v: [S; 3]) -> Self {
        [v[0], v[1]]
    }
    #[inline(always)]
    fn to3(self) -> [S; 3] {
        [self[0], self[1], S::cst(0.0)]
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        [self[0] + o[0], self[1] + o[1]]
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        [self[0] - o[0], self[1] - o[1]]
    }
    #[inline(always)]
    fn scale(self, k: S) -> Self {
        [self[0] * k, self[1] * k]
    }
    #[inline(always)]
    fn dot(self, o: Self) -> S {
        self[0] * o[0] + self[1] * o[1]
    }
}

impl<S: Arith> Vector<S> for [S; 3] {
    #[inline(always)]
    fn zero() -> Self {
        [S::cst(0.0); 3]
    }
    #[inline(always)]
    fn of(v: [S; 3]) -> Self {
        v
    }
    #[inline(always)]
    fn to3(self) -> [S; 3] {
        self
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        [self[0] + o[0], self[1] + o[1], self[2] + o[2]]
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        [self[0] - o[0], self[1] - o[1], self[2] - o[2]]
    }
    #[inline(always)]
    fn scale(self, k: S) -> Self {
        [self[0] * k, self[1] * k, self[2] * k]
    }
    #[inline(always)]
    fn dot(self, o: Self) -> S {
        self[0] * o[0] + self[1] * o[1] + self[2] * o[2]
    }
}

/// `a × b` in 3-D.
#[inline(always)]
pub fn cross<S: Arith>(a: [S; 3], b: [S; 3]) -> [S; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// A rigid frame of an arm (its rotation and origin in a parent frame).
pub trait Frame<S: Arith>: Copy + std::fmt::Debug {
    /// Points and vectors of the arm's space.
    type V: Vector<S>;
    /// A joint axis in a parent frame: nothing in the plane (always `z`),
    /// a unit vector in space.
    type Axis: Copy + std::fmt::Debug;
    /// Width of the task vector: 3 (`x, y, phi`) or 6 (`x, y, z, rx, ry, rz`).
    const TASK: usize;
    /// Parameters of an instrument frame: 3 (`alpha, fx, fy`) or 6
    /// (rotation vector, then translation).
    const INSTRUMENT: usize;
    /// Parameters of a point offset in the end frame: 2 or 3.
    const DIM: usize;

    fn identity() -> Self;
    /// `Trans(v)`: the identity moved by `v`.
    fn at(v: Self::V) -> Self;
    /// `self · Trans(v)`.
    fn translated(&self, v: Self::V) -> Self;
    /// `self · Rot(axis, theta)` for a joint at angle `theta` with `(cos,
    /// sin)` `cs` (the plane ignores `axis`: its joints turn about `z`).
    fn turned(&self, axis: [S; 3], theta: S, cs: (S, S)) -> Self;
    /// `Trans(v) · Rot(axis, theta)`: [`Frame::at`] then
    /// [`Frame::turned`], without turning the identity.
    #[inline(always)]
    fn at_turned(v: Self::V, axis: [S; 3], theta: S, cs: (S, S)) -> Self {
        Self::at(v).turned(axis, theta, cs)
    }
    /// The unit axis `local` of the identity frame ([`Frame::axis`]).
    #[inline(always)]
    fn base_axis(local: [S; 3]) -> Self::Axis {
        Self::identity().axis(local)
    }
    /// `self · o`.
    fn compose(&self, o: &Self) -> Self;
    /// A point given in this frame, in the parent frame.
    fn point(&self, p: Self::V) -> Self::V;
    /// A vector given in this frame, in the parent frame.
    fn dir(&self, v: Self::V) -> Self::V;
    /// A vector given in the parent frame, in this frame.
    fn dir_inv(&self, v: Self::V) -> Self::V;
    /// The origin in the parent frame.
    fn origin(&self) -> Self::V;
    /// The unit axis `local` of this frame in the parent frame.
    fn axis(&self, local: [S; 3]) -> Self::Axis;
    /// An axis given in this frame, in the parent frame.
    fn map_axis(&self, a: Self::Axis) -> Self::Axis;
    /// `axis × (q − p)`: the velocity of the point `q` turning at unit rate
    /// about the axis through `p`.
    fn rate(axis: Self::Axis, p: Self::V, q: Self::V) -> Self::V;
    /// `axis · (arm × force)`: the moment of `force` applied at `arm` from a
    /// point of the axis, about the axis.
    fn moment(axis: Self::Axis, arm: Self::V, force: Self::V) -> S;
    /// The moment `couple` (`[Mz]` planar, `[Mx, My, Mz]` spatial) about the axis.
    fn couple(axis: Self::Axis, couple: &[S]) -> S;
    /// The angular rows of a geometric Jacobian column (1 or 3 values).
    fn angular(axis: Self::Axis, out: &mut [S]);
    /// The task vector (`TASK` values): the origin, then the attitude
    /// (planar: the angle, unwrapped; spatial: the rotation vector, angle in
    /// `[0, pi]`).
    fn task(&self, out: &mut [S])
    where
        S: Real;
    /// The instrument frame of the parameters `e` (`INSTRUMENT` values).
    fn instrument(e: &[S]) -> Self
    where
        S: Real;
    /// Hole clearance across a bend (`docs/model.md`, "The plant"): with
    /// this frame the motion from a disk's distal face to the next disk's
    /// proximal face, the shifts of a cable's two holes beside the bend,
    /// each in its own face frame, of magnitude `cl tanh(phi / w)` toward
    /// the bend (`phi` the bend angle): `(shift on the proximal face b,
    /// shift on the distal face a)`.
    fn bend_shift(&self, cl: S, w: S) -> (Self::V, Self::V)
    where
        S: Real;
}

/// A rigid motion of the plane: rotation by `angle` (kept unwrapped, with
/// its cosine and sine) and origin `(x, y)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Se2<S> {
    pub angle: S,
    pub c: S,
    pub s: S,
    pub x: S,
    pub y: S,
}

impl<S: Arith> Frame<S> for Se2<S> {
    type V = [S; 2];
    type Axis = ();
    const TASK: usize = 3;
    const INSTRUMENT: usize = 3;
    const DIM: usize = 2;

    #[inline(always)]
    fn identity() -> Self {
        let z = S::cst(0.0);
        Se2 {
            angle: z,
            c: S::cst(1.0),
            s: z,
            x: z,
            y: z,
        }
    }
    #[inline(always)]
    fn at(v: [S; 2]) -> Self {
        Se2 {
            x: v[0],
            y: v[1],
            ..Self::identity()
        }
    }
    #[inline(always)]
    fn translated(&self, v: [S; 2]) -> Self {
        Se2 {
            x: self.x + self.c * v[0] - self.s * v[1],
            y: self.y + self.s * v[0] + self.c * v[1],
            ..*self
        }
    }
    #[inline(always)]
    fn turned(&self, _axis: [S; 3], theta: S, (c, s): (S, S)) -> Self {
        Se2 {
            angle: self.angle + theta,
            c: self.c * c - self.s * s,
            s: self.s * c + self.c * s,
            ..*self
        }
    }
    #[inline(always)]
    fn compose(&self, o: &Self) -> Self {
        let p = self.point([o.x, o.y]);
        Se2 {
            angle: self.angle + o.angle,
            c: self.c * o.c - self.s * o.s,
            s: self.s * o.c + self.c * o.s,
            x: p[0],
            y: p[1],
        }
    }
    #[inline(always)]
    fn point(&self, p: [S; 2]) -> [S; 2] {
        [
            self.x + self.c * p[0] - self.s * p[1],
            self.y + self.s * p[0] + self.c * p[1],
        ]
    }
    #[inline(always)]
    fn dir(&self, v: [S; 2]) -> [S; 2] {
        [self.c * v[0] - self.s * v[1], self.s * v[0] + self.c * v[1]]
    }
    #[inline(always)]
    fn dir_inv(&self, v: [S; 2]) -> [S; 2] {
        [self.c * v[0] + self.s * v[1], self.c * v[1] - self.s * v[0]]
    }
    #[inline(always)]
    fn origin(&self) -> [S; 2] {
        [self.x, self.y]
    }
    #[inline(always)]
    fn axis(&self, _local: [S; 3]) {}
    #[inline(always)]
    fn map_axis(&self, _a: ()) {}
    #[inline(always)]
    fn rate(_axis: (), p: [S; 2], q: [S; 2]) -> [S; 2] {
        [p[1] - q[1], q[0] - p[0]]
    }
    #[inline(always)]
    fn moment(_axis: (), arm: [S; 2], f: [S; 2]) -> S {
        arm[0] * f[1] - arm[1] * f[0]
    }
    #[inline(always)]
    fn couple(_axis: (), couple: &[S]) -> S {
        couple[0]
    }
    #[inline(always)]
    fn angular(_axis: (), out: &mut [S]) {
        out[0] = S::cst(1.0);
    }
    #[inline]
    fn task(&self, out: &mut [S])
    where
        S: Real,
    {
        out[0] = self.x;
        out[1] = self.y;
        out[2] = self.angle;
    }
    #[inline]
    fn bend_shift(&self, cl: S, w: S) -> ([S; 2], [S; 2])
    where
        S: Real,
    {
        let d = cl * (self.angle / w).tanh();
        let z = S::cst(0.0);
        ([z, d], [z, d])
    }
    #[inline]
    fn instrument(e: &[S]) -> Self
    where
        S: Real,
    {
        let (s, c) = e[0].sin_cos();
        Se2 {
            angle: e[0],
            c,
            s,
            x: e[1],
            y: e[2],
        }
    }
}

/// A rigid motion of space: rotation matrix `r` (row-major) and origin `t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Se3<S> {
    pub r: [[S; 3]; 3],
    pub t: [S; 3],
}

/// `m v` for a row-major 3x3 matrix.
#[inline(always)]
fn mul_v<S: Arith>(m: &[[S; 3]; 3], v: [S; 3]) -> [S; 3] {
    [m[0].dot(v), m[1].dot(v), m[2].dot(v)]
}

/// `a b` for row-major 3x3 matrices.
#[inline(always)]
fn mul_m<S: Arith>(a: &[[S; 3]; 3], b: &[[S; 3]; 3]) -> [[S; 3]; 3] {
    let row = |r: &[S; 3]| {
        [
            r[0] * b[0][0] + r[1] * b[1][0] + r[2] * b[2][0],
            r[0] * b[0][1] + r[1] * b[1][1] + r[2] * b[2][1],
            r[0] * b[0][2] + r[1] * b[1][2] + r[2] * b[2][2],
        ]
    };
    [row(&a[0]), row(&a[1]), row(&a[2])]
}

/// The rotation by the angle with `(cos, sin)` `cs` about the unit `axis`
/// (Rodrigues: `I + s [a]x + (1 - c) [a]x^2`).
#[inline(always)]
pub fn rotation<S: Arith>(a: [S; 3], (c, s): (S, S)) -> [[S; 3]; 3] {
    let one = S::cst(1.0);
    let v = one - c;
    let (x, y, z) = (a[0], a[1], a[2]);
    [
        [c + x * x * v, x * y * v - z * s, x * z * v + y * s],
        [y * x * v + z * s, c + y * y * v, y * z * v - x * s],
        [z * x * v - y * s, z * y * v + x * s, c + z * z * v],
    ]
}

/// The rotation matrix of the rotation vector `v` (rad): Rodrigues with
/// `A = sin(t)/t`, `B = (1 - cos t)/t^2`, `t = |v|`, by their series in `t^2`
/// near 0 (smooth through `v = 0`, where derivatives are taken).
pub fn exp_so3<S: Real>(v: [S; 3]) -> [[S; 3]; 3] {
    // a vector past 1e154 rad would overflow |v|^2: scale it down first
    // (any finite vector is a rotation; its angle counts modulo 2 pi)
    let big = v.iter().fold(0.0f64, |m, x| m.max(x.val().abs()));
    if big > 1e150 {
        let k = S::cst(big);
        let w = [v[0] / k, v[1] / k, v[2] / k];
        let tw = w.dot(w).sqrt();
        let u = [w[0] / tw, w[1] / tw, w[2] / tw];
        let (s, c) = (k * tw).sin_cos();
        return rotation_about(u, s, S::cst(1.0) - c);
    }
    let t2 = v.dot(v);
    let (a, b) = if t2.val() < 1e-2 {
        // A = 1 - t2/6 + t2^2/120 - t2^3/5040 + t2^4/362880
        // B = 1/2 - t2/24 + t2^2/720 - t2^3/40320 + t2^4/3628800
        let a = S::cst(1.0)
            + t2 * (S::cst(-1.0 / 6.0)
                + t2 * (S::cst(1.0 / 120.0)
                    + t2 * (S::cst(-1.0 / 5040.0) + t2 * (1.0 / 362880.0))));
        let b = S::cst(0.5)
            + t2 * (S::cst(-1.0 / 24.0)
                + t2 * (S::cst(1.0 / 720.0)
                    + t2 * (S::cst(-1.0 / 40320.0) + t2 * (1.0 / 3628800.0))));
        (a, b)
    } else {
        let t = t2.sqrt();
        let (s, c) = t.sin_cos();
        (s / t, (S::cst(1.0) - c) / t2)
    };
    rotation_about(v, a, b)
}

/// `I + a [u]x + b [u]x^2` (Rodrigues: a unit axis `u` with `a = sin t`,
/// `b = 1 - cos t`, or the rotation vector with `a = sin t / t`,
/// `b = (1 - cos t) / t^2`).
fn rotation_about<S: Real>(u: [S; 3], a: S, b: S) -> [[S; 3]; 3] {
    let (x, y, z) = (u[0], u[1], u[2]);
    let one = S::cst(1.0);
    [
        [
            one - b * (y * y + z * z),
            b * x * y - a * z,
            b * x * z + a * y,
        ],
        [
            b * x * y + a * z,
            one - b * (x * x + z * z),
            b * y * z - a * x,
        ],
        [
            b * x * z - a * y,
            b * y * z + a * x,
            one - b * (x * x + y * y),
        ],
    ]
}

/// The rotation vector (rad, angle in `[0, pi]`) of a rotation matrix: its
/// unit quaternion by Shepperd's branches (`w >= 0`), then `2 atan2(|q|, w)
/// q / |q|`, by a series in `|q|^2 / w^2` near the identity (smooth there).
pub fn log_so3<S: Real>(r: &[[S; 3]; 3]) -> [S; 3] {
    let (m00, m11, m22) = (r[0][0].val(), r[1][1].val(), r[2][2].val());
    let tr = m00 + m11 + m22;
    let one = S::cst(1.0);
    // (w, x, y, z) up to a common sign; in each branch the largest of them
    // from the diagonal (`2w`, `2x`, ... under the root), the others from
    // the off-diagonal sums and differences divided by four times it
    let (w, x, y, z) = if tr >= m00 && tr >= m11 && tr >= m22 {
        let w2 = (one + r[0][0] + r[1][1] + r[2][2]).sqrt(); // 2w
        let k = one / w2;
        (
            w2 * 0.5,
            (r[2][1] - r[1][2]) * k * 0.5,
            (r[0][2] - r[2][0]) * k * 0.5,
            (r[1][0] - r[0][1]) * k * 0.5,
        )
    } else if m00 >= m11 && m00 >= m22 {
        let x2 = (one + r[0][0] - r[1][1] - r[2][2]).sqrt(); // 2x
        let k = one / x2;
        (
            (r[2][1] - r[1][2]) * k * 0.5,
            x2 * 0.5,
            (r[0][1] + r[1][0]) * k * 0.5,
            (r[0][2] + r[2][0]) * k * 0.5,
        )
    } else if m11 >= m22 {
        let y2 = (one - r[0][0] + r[1][1] - r[2][2]).sqrt();
        let k = one / y2;
        (
            (r[0][2] - r[2][0]) * k * 0.5,
            (r[0][1] + r[1][0]) * k * 0.5,
            y2 * 0.5,
            (r[1][2] + r[2][1]) * k * 0.5,
        )
    } else {
        let z2 = (one - r[0][0] - r[1][1] + r[2][2]).sqrt();
        let k = one / z2;
        (
            (r[1][0] - r[0][1]) * k * 0.5,
            (r[0][2] + r[2][0]) * k * 0.5,
            (r[1][2] + r[2][1]) * k * 0.5,
            z2 * 0.5,
        )
    };
    let (w, x, y, z) = if w.val() < 0.0 {
        (-w, -x, -y, -z)
    } else {
        (w, x, y, z)
    };
    let s2 = x * x + y * y + z * z;
    let u2 = s2 / (w * w);
    // factor = angle / |q| = 2 atan(|q|/w) / |q|
    let factor = if w.val() > 0.0 && u2.val() < 1e-2 {
        // 2/w atan(u)/u, u2 = u^2 < 1e-2 (angles below 0.2 rad), by its
        // series sum_k (-u2)^k / (2k + 1), k = 0..=8, in Horner form. The
        // first term left out, u2^9/19 < 6e-20, lies far below the rounding
        // of the sum (a cut after k = 5 left u2^6/13: up to 1.5e-14 rad at
        // 0.2 rad).
        let v = -u2;
        let mut sum = S::cst(1.0 / 17.0);
        for k in (0..8).rev() {
            sum = sum * v + 1.0 / (2 * k + 1) as f64;
        }
        sum * 2.0 / w
    } else {
        let s = s2.sqrt();
        Real::atan2(s, w) * 2.0 / s
    };
    [x * factor, y * factor, z * factor]
}

impl<S: Arith> Frame<S> for Se3<S> {
    type V = [S; 3];
    type Axis = [S; 3];
    const TASK: usize = 6;
    const INSTRUMENT: usize = 6;
    const DIM: usize = 3;

    #[inline(always)]
    fn identity() -> Self {
        let (z, o) = (S::cst(0.0), S::cst(1.0));
        Se3 {
            r: [[o, z, z], [z, o, z], [z, z, o]],
            t: [z; 3],
        }
    }
    #[inline(always)]
    fn at(v: [S; 3]) -> Self {
        Se3 {
            t: v,
            ..Self::identity()
        }
    }
    #[inline(always)]
    fn translated(&self, v: [S; 3]) -> Self {
        Se3 {
            r: self.r,
            t: self.t.add(mul_v(&self.r, v)),
        }
    }
    #[inline(always)]
    fn turned(&self, axis: [S; 3], _theta: S, cs: (S, S)) -> Self {
        Se3 {
            r: mul_m(&self.r, &rotation(axis, cs)),
            t: self.t,
        }
    }
    #[inline(always)]
    fn at_turned(v: [S; 3], axis: [S; 3], _theta: S, cs: (S, S)) -> Self {
        Se3 {
            r: rotation(axis, cs),
            t: v,
        }
    }
    #[inline(always)]
    fn base_axis(local: [S; 3]) -> [S; 3] {
        local
    }
    #[inline(always)]
    fn compose(&self, o: &Self) -> Self {
        Se3 {
            r: mul_m(&self.r, &o.r),
            t: self.point(o.t),
        }
    }
    #[inline(always)]
    fn point(&self, p: [S; 3]) -> [S; 3] {
        self.t.add(mul_v(&self.r, p))
    }
    #[inline(always)]
    fn dir(&self, v: [S; 3]) -> [S; 3] {
        mul_v(&self.r, v)
    }
    #[inline(always)]
    fn dir_inv(&self, v: [S; 3]) -> [S; 3] {
        let r = &self.r;
        [
            r[0][0] * v[0] + r[1][0] * v[1] + r[2][0] * v[2],
            r[0][1] * v[0] + r[1][1] * v[1] + r[2][1] * v[2],
            r[0][2] * v[0] + r[1][2] * v[1] + r[2][2] * v[2],
        ]
    }
    #[inline(always)]
    fn origin(&self) -> [S; 3] {
        self.t
    }
    #[inline(always)]
    fn axis(&self, local: [S; 3]) -> [S; 3] {
        mul_v(&self.r, local)
    }
    #[inline(always)]
    fn map_axis(&self, a: [S; 3]) -> [S; 3] {
        mul_v(&self.r, a)
    }
    #[inline(always)]
    fn rate(w: [S; 3], p: [S; 3], q: [S; 3]) -> [S; 3] {
        cross(w, q.sub(p))
    }
    #[inline(always)]
    fn moment(w: [S; 3], arm: [S; 3], f: [S; 3]) -> S {
        w.dot(cross(arm, f))
    }
    #[inline(always)]
    fn couple(w: [S; 3], couple: &[S]) -> S {
        w[0] * couple[0] + w[1] * couple[1] + w[2] * couple[2]
    }
    #[inline(always)]
    fn angular(w: [S; 3], out: &mut [S]) {
        out[..3].copy_from_slice(&w);
    }
    #[inline]
    fn task(&self, out: &mut [S])
    where
        S: Real,
    {
        out[..3].copy_from_slice(&self.t);
        out[3..6].copy_from_slice(&log_so3(&self.r));
    }
    fn bend_shift(&self, cl: S, w: S) -> ([S; 3], [S; 3])
    where
        S: Real,
    {
        // n: the distal normal in the proximal face; m: the proximal normal
        // in the distal face; |(n_y, n_z)| = |(m_y, m_z)| = sin(phi)
        let r = &self.r;
        let (ny, nz) = (r[1][0], r[2][0]);
        let (my, mz) = (r[0][1], r[0][2]);
        let u = ny * ny + nz * nz;
        let phi = Real::atan2(u.sqrt(), r[0][0]);
        // g = tanh(phi / w) / sin(phi), even in phi: its series where phi << w
        let g = if phi.val() < 1e-8 {
            (S::cst(1.0) + phi * phi * (S::cst(1.0 / 6.0) - S::cst(1.0 / 3.0) / (w * w))) / w
        } else {
            (phi / w).tanh() / u.sqrt()
        };
        let k = cl * g;
        let z = S::cst(0.0);
        ([z, ny * k, nz * k], [z, -my * k, -mz * k])
    }
    #[inline]
    fn instrument(e: &[S]) -> Self
    where
        S: Real,
    {
        Se3 {
            r: exp_so3([e[0], e[1], e[2]]),
            t: [e[3], e[4], e[5]],
        }
    }
}

/// A motion group as a type: its frames in any scalar ([`Se2`] for planar
/// arms, [`Se3`] for spatial ones). The algorithms written once over the arm
/// are generic over it; [`Kind::visit`] picks it from the model's kind.
pub trait Group: Copy + Send + Sync + std::fmt::Debug + 'static {
    type Frame<S: Arith>: Frame<S>;
}

/// The planar group: SE(2) frames.
#[derive(Debug, Clone, Copy)]
pub struct Planar;
/// The spatial group: SE(3) frames.
#[derive(Debug, Clone, Copy)]
pub struct Spatial;

impl Group for Planar {
    type Frame<S: Arith> = Se2<S>;
}
impl Group for Spatial {
    type Frame<S: Arith> = Se3<S>;
}

/// The kind of an arm: which motion group its joints span and which task
/// space it is measured in. Every fact that differs between the kinds is
/// data of [`KindInfo`] ([`Kind::info`]); the one place that turns the kind
/// into a type is [`Kind::visit`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Parallel joint axes (`z`), a planar chain: task `[x, y, phi]`.
    Planar,
    /// Axes anywhere in 3-D: task `[x, y, z, rx, ry, rz]`.
    Spatial,
}

/// How a task vector holds the end frame's attitude.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rotation {
    /// One angle about `z` (rad).
    Angle,
    /// A rotation vector (rad, 3 components).
    Vector,
}

impl Rotation {
    pub fn name(self) -> &'static str {
        match self {
            Rotation::Angle => "angle",
            Rotation::Vector => "vector",
        }
    }
}

/// How the errors of an arm's holes group.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HoleGrouping {
    /// One coherent group per disk: every hole of the cables ending there
    /// moved along its face's `y`, a position cable's by `+dh`, a force
    /// cable's by `-dh` (a planar arm's hole height, `docs/model.md`).
    PerEndDisk,
    /// One group per cable: every coordinate of its holes, each its own error.
    PerCable,
}

impl HoleGrouping {
    pub fn name(self) -> &'static str {
        match self {
            HoleGrouping::PerEndDisk => "per_end_disk",
            HoleGrouping::PerCable => "per_cable",
        }
    }
}

/// How a kind's pose-IK mask is given (`crate::ik::Mask::parse`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Masks {
    /// Task-width weights on the residuals (planar `x, y, phi`).
    Weights,
    /// A name: `"position"`, `"pointing"` or `"pose"`.
    Named,
}

/// The facts of an arm kind, one static table per kind.
#[derive(Debug)]
pub struct KindInfo {
    /// `"planar"` or `"spatial"`.
    pub name: &'static str,
    /// Dimension of the arm's space: 2 or 3.
    pub dim: usize,
    /// Width of the task vector: 3 (`x, y, phi`) or 6 (`x, y, z, rx, ry, rz`).
    pub task: usize,
    /// The task vector's components and their units.
    pub task_axes: &'static [(&'static str, &'static str)],
    /// How the task vector holds the attitude (its last `task - dim` components).
    pub rotation: Rotation,
    /// The quantities of a Monte-Carlo study, per sample, and their units
    /// (`crate::accuracy::monte_carlo`, whose statistics are this wide).
    pub quantities: &'static [(&'static str, &'static str)],
    /// How hole errors group ([`crate::model::Structure`]).
    pub holes: HoleGrouping,
    /// How its pose-IK mask is given.
    pub masks: Masks,
    /// The plant's parameter blocks in the order of its flat vector
    /// (`docs/model.md`, "Parameters"): the planar one in the order of
    /// cdsm 0.1, the spatial one in the order of cdsm 0.2 with the effects
    /// added since at its end.
    pub layout: &'static [(Effect, Size)],
    /// The blocks an elastic arm's plant appends to its layout, in order
    /// (`joint_stiffness` only where some joint has a spring).
    pub elastic_layout: &'static [(Effect, Size)],
}

static PLANAR: KindInfo = KindInfo {
    name: "planar",
    dim: 2,
    task: 3,
    task_axes: &[("x", "m"), ("y", "m"), ("phi", "rad")],
    rotation: Rotation::Angle,
    quantities: &[("dX", "m"), ("dY", "m"), ("dphi", "rad"), ("dXY", "m")],
    holes: HoleGrouping::PerEndDisk,
    masks: Masks::Weights,
    layout: &[
        (Effect::ActuationScale, Size::One),
        (Effect::CableOffset, Size::PerPositionCable),
        (Effect::HoleHeight, Size::PerDisk),
        (Effect::LinkLength, Size::LinkLengths),
        (Effect::CableElasticity, Size::One),
        (Effect::HoleClearance, Size::One),
        (Effect::FrameMisalignment, Size::Instrument),
        (Effect::TipOffset, Size::Point),
        (Effect::Backlash, Size::PerPositionCable),
        (Effect::ClearanceWidth, Size::One),
        (Effect::CableFriction, Size::One),
    ],
    elastic_layout: &[(Effect::JointStiffness, Size::PerSegment)],
};

static SPATIAL: KindInfo = KindInfo {
    name: "spatial",
    dim: 3,
    task: 6,
    task_axes: &[
        ("x", "m"),
        ("y", "m"),
        ("z", "m"),
        ("rx", "rad"),
        ("ry", "rad"),
        ("rz", "rad"),
    ],
    rotation: Rotation::Vector,
    quantities: &[
        ("dX", "m"),
        ("dY", "m"),
        ("dZ", "m"),
        ("dXYZ", "m"),
        ("rot", "rad"),
    ],
    holes: HoleGrouping::PerCable,
    masks: Masks::Named,
    layout: &[
        (Effect::ActuationScale, Size::One),
        (Effect::CableOffset, Size::PerPositionCable),
        (Effect::HolePosition, Size::PerPositionHoleCoord),
        (Effect::LinkLength, Size::LinkVectors),
        (Effect::CableElasticity, Size::One),
        (Effect::FrameMisalignment, Size::Instrument),
        (Effect::TipOffset, Size::Point),
        (Effect::Backlash, Size::PerPositionCable),
        (Effect::HoleClearance, Size::One),
        (Effect::ClearanceWidth, Size::One),
        (Effect::JointAxis, Size::PerJointTilt),
        (Effect::CableFriction, Size::One),
    ],
    elastic_layout: &[
        (Effect::JointStiffness, Size::PerSegment),
        (Effect::CableAngle, Size::PerPositionCable),
    ],
};

/// Something done with the arm's motion group as a type: the body of a
/// [`Kind::visit`].
pub trait Visit {
    type Out;
    fn visit<G: Group>(self) -> Self::Out;
}

impl Kind {
    /// Both kinds.
    pub const ALL: [Kind; 2] = [Kind::Planar, Kind::Spatial];

    /// The kind's facts.
    pub fn info(self) -> &'static KindInfo {
        match self {
            Kind::Planar => &PLANAR,
            Kind::Spatial => &SPATIAL,
        }
    }

    /// The kind named `name` (`"planar"` or `"spatial"`).
    pub fn named(name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.info().name == name)
    }

    /// `"planar"` or `"spatial"`.
    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// Dimension of the arm's space: 2 or 3.
    pub fn dim(self) -> usize {
        self.info().dim
    }

    /// Width of the task vector: 3 (`x, y, phi`) or 6 (`x, y, z, rx, ry, rz`).
    pub fn task(self) -> usize {
        self.info().task
    }

    /// `v` over the kind's motion group ([`Se2`] or [`Se3`] frames): the one
    /// dispatch from the kind as data to the kind as a type.
    pub fn visit<V: Visit>(self, v: V) -> V::Out {
        match self {
            Kind::Planar => v.visit::<Planar>(),
            Kind::Spatial => v.visit::<Spatial>(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kind's table agrees with its motion group's frames and with the
    /// Monte-Carlo kernels' widths.
    #[test]
    fn kind_facts_agree_with_the_frames_and_kernels() {
        fn agree<G: Group>(kind: Kind) {
            let info = kind.info();
            assert_eq!(info.task, <G::Frame<f64> as Frame<f64>>::TASK);
            assert_eq!(info.dim, <G::Frame<f64> as Frame<f64>>::DIM);
            assert_eq!(info.task, <G::Frame<f64> as Frame<f64>>::INSTRUMENT);
            assert_eq!(info.task_axes.len(), info.task);
            assert_eq!(Kind::named(info.name), Some(kind));
        }
        agree::<Planar>(Kind::Planar);
        agree::<Spatial>(Kind::Spatial);
        assert_eq!(
            Kind::Planar.info().quantities.len(),
            crate::accuracy::QUANTITIES
        );
        assert_eq!(
            Kind::Spatial.info().quantities.len(),
            crate::accuracy::SPATIAL_QUANTITIES
        );
        assert_eq!(Kind::named("other"), None);
        // the one dispatch picks the kind's group
        struct Task;
        impl Visit for Task {
            type Out = usize;
            fn visit<G: Group>(self) -> usize {
                <G::Frame<f64> as Frame<f64>>::TASK
            }
        }
        assert_eq!(Kind::Planar.visit(Task), 3);
        assert_eq!(Kind::Spatial.visit(Task), 6);
    }
    use crate::real::{Dual, Jet};

    fn close3(a: [[f64; 3]; 3], b: [[f64; 3]; 3], tol: f64) -> bool {
        (0..3).all(|i| (0..3).all(|j| (a[i][j] - b[i][j]).abs() <= tol))
    }

    #[test]
    fn exp_and_log_invert_each_other_and_match_rodrigues() {
        for v in [
            [0.3, -0.2, 0.5],
            [1e-9, 2e-9, -1e-9],
            [0.0, 0.0, 0.0],
            [0.05, 0.0, 0.01],
            [2.0, 1.0, -1.5],
            [0.0, 3.0, 0.0],
        ] {
            let r = exp_so3(v);
            let t = v.dot(v).sqrt();
            let want = if t > 0.0 {
                rotation(v.scale(1.0 / t), (t.cos(), t.sin()))
            } else {
                Se3::<f64>::identity().r
            };
            assert!(close3(r, want, 1e-15), "{v:?}");
            let back = log_so3(&r);
            for k in 0..3 {
                assert!((back[k] - v[k]).abs() < 1e-14, "{v:?} -> {back:?}");
            }
        }
    }

    #[test]
    fn exp_and_log_are_smooth_through_the_identity_in_jets() {
        // d/dv exp(v) at 0 is [e_k]x; d/dR log at I is its inverse
        for k in 0..3 {
            let v: [Jet<3>; 3] = std::array::from_fn(|i| Jet::seeded(0.0, i));
            let r = exp_so3(v);
            let e: [f64; 3] = std::array::from_fn(|i| if i == k { 1.0 } else { 0.0 });
            let hat = [[0.0, -e[2], e[1]], [e[2], 0.0, -e[0]], [-e[1], e[0], 0.0]];
            for i in 0..3 {
                for j in 0..3 {
                    assert!((r[i][j].d[k] - hat[i][j]).abs() < 1e-15);
                }
            }
            let back = log_so3(&r);
            for i in 0..3 {
                assert!((back[i].d[k] - e[i]).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn log_derivative_matches_central_differences_away_from_the_identity() {
        let v0 = [0.4, -0.7, 0.2];
        for k in 0..3 {
            let v: [Dual; 3] =
                std::array::from_fn(|i| Dual::new(v0[i], if i == k { 1.0 } else { 0.0 }));
            let ad = log_so3(&exp_so3(v));
            let h = 1e-6;
            let (mut a, mut b) = (v0, v0);
            a[k] += h;
            b[k] -= h;
            let (la, lb) = (log_so3(&exp_so3(a)), log_so3(&exp_so3(b)));
            for i in 0..3 {
                let fd = (la[i] - lb[i]) / (2.0 * h);
                assert!((ad[i].d[0] - fd).abs() < 1e-8, "{k} {i}");
            }
        }
    }

    #[test]
    fn a_planar_chain_is_the_spatial_chain_about_z() {
        let steps: [(f64, f64); 3] = [(0.033, 0.4), (0.02, -0.9), (0.05, 0.25)];
        let (mut a, mut b) = (Se2::<f64>::identity(), Se3::<f64>::identity());
        for (l, t) in steps {
            let cs = (t.cos(), t.sin());
            a = a.translated([l, 0.0]).turned([0.0, 0.0, 1.0], t, cs);
            b = b.translated([l, 0.0, 0.0]).turned([0.0, 0.0, 1.0], t, cs);
        }
        let p = [0.01, -0.02];
        let (qa, qb) = (a.point(p), b.point([p[0], p[1], 0.0]));
        assert!((qa[0] - qb[0]).abs() < 1e-16 && (qa[1] - qb[1]).abs() < 1e-16 && qb[2] == 0.0);
        let (mut ta, mut tb) = ([0.0; 3], [0.0; 6]);
        a.task(&mut ta);
        b.task(&mut tb);
        assert!((ta[2] - tb[5]).abs() < 1e-15 && (ta[0] - tb[0]).abs() < 1e-16);
        // moments and rates agree with the 3-D cross products about z
        let (arm, f) = ([0.3, -0.1], [2.0, 0.5]);
        let m3 = Se3::<f64>::moment([0.0, 0.0, 1.0], arm.to3(), f.to3());
        assert_eq!(Se2::<f64>::moment((), arm, f), m3);
        let r3 = Se3::<f64>::rate([0.0, 0.0, 1.0], [0.1, 0.2, 0.0], arm.to3());
        let r2 = Se2::<f64>::rate((), [0.1, 0.2], arm);
        assert_eq!([r2[0], r2[1], 0.0], r3);
    }
}
