//! Scalars the models are written over: `f64`, [`Jet`]s that carry
//! derivatives along `K` directions (forward mode; [`Dual`] is `Jet<1>`),
//! and lane packs of several rows at once ([`pack::Pack`]).
//! The plant, the statics and the cable geometry are generic over [`Real`],
//! so one code path gives values and exact derivatives (no finite
//! differences); the geometry of a configuration (frames, cable lengths and
//! their Jacobian) only needs [`Arith`], so it also runs on lanes ([`Lane`]:
//! `f64` is the one-lane case).

pub mod pack;

use std::ops::{Add, AddAssign, BitAnd, BitOr, Div, Mul, MulAssign, Neg, Not, Sub, SubAssign};

/// The arithmetic the geometry of a configuration needs of a scalar.
pub trait Arith:
    Copy
    + std::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
{
    /// A constant (zero derivative; every lane).
    fn cst(v: f64) -> Self;
    fn sqrt(self) -> Self;
    fn sin_cos(self) -> (Self, Self);
    /// `1 / self`, or 0 where `self` is 0 (a zero-length segment's
    /// direction contributes nothing).
    fn recip_or_zero(self) -> Self;
}

/// What the models need of a scalar: one value to branch on (a lane of
/// its own: [`Lane`]'s comparisons are on the value).
pub trait Real: Lane<Mask = bool> {
    /// The value (derivative dropped).
    fn val(self) -> f64;
    fn tanh(self) -> Self;
    fn atan2(self, x: Self) -> Self;
    fn exp(self) -> Self;
    /// Whether the value carries a derivative (always false for `f64`).
    #[inline]
    fn is_variable(self) -> bool {
        false
    }
    /// `max(self, 0)` by value (the derivative of the larger one).
    #[inline]
    fn max0(self) -> Self {
        if self.val() > 0.0 {
            self
        } else {
            Self::cst(0.0)
        }
    }
    #[inline]
    fn hypot2(x: Self, y: Self) -> Self {
        (x * x + y * y).sqrt()
    }
}

/// A scalar of one or several rows in lockstep (lanes), with per-lane
/// comparisons: the solves written over it run one row (`f64`, or a jet,
/// compared by its value) or several (a pack) with the same operations,
/// lane by lane.
pub trait Lane: Arith {
    /// Per-lane booleans.
    type Mask: Copy
        + std::fmt::Debug
        + BitAnd<Output = Self::Mask>
        + BitOr<Output = Self::Mask>
        + Not<Output = Self::Mask>;
    /// Lanes.
    const LANES: usize;
    fn abs(self) -> Self;
    fn max(self, o: Self) -> Self;
    fn min(self, o: Self) -> Self;
    fn lt(self, o: Self) -> Self::Mask;
    fn le(self, o: Self) -> Self::Mask;
    fn eq(self, o: Self) -> Self::Mask;
    /// Lanes whose value is finite.
    fn finite(self) -> Self::Mask;
    /// Per lane: `a` where `m` is set, `b` elsewhere.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;
    /// A mask of every lane `b`.
    fn mask(b: bool) -> Self::Mask;
    fn any(m: Self::Mask) -> bool;
    fn all(m: Self::Mask) -> bool;
    /// Lane `i`.
    fn lane(self, i: usize) -> f64;
    /// Lane `i` of a mask.
    fn lane_set(m: Self::Mask, i: usize) -> bool;
    /// `v` in lane `i`.
    fn set_lane(&mut self, i: usize, v: f64);
    /// `(cos, sin)` of every element of `x` into `cs`: for `f64` and packs
    /// the SIMD kernel of [`crate::simd::math`] (within 1 ulp; lane by lane
    /// the same bits for every pack width), for jets their `sin_cos`.
    fn cos_sin(x: &[Self], cs: &mut [(Self, Self)]);
}

impl Arith for f64 {
    #[inline]
    fn cst(v: f64) -> f64 {
        v
    }
    #[inline]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    #[inline]
    fn sin_cos(self) -> (f64, f64) {
        f64::sin_cos(self)
    }
    #[inline]
    fn recip_or_zero(self) -> f64 {
        if self == 0.0 {
            0.0
        } else {
            1.0 / self
        }
    }
}

impl Real for f64 {
    #[inline]
    fn val(self) -> f64 {
        self
    }
    #[inline]
    fn tanh(self) -> f64 {
        f64::tanh(self)
    }
    #[inline]
    fn atan2(self, x: f64) -> f64 {
        f64::atan2(self, x)
    }
    #[inline]
    fn exp(self) -> f64 {
        f64::exp(self)
    }
}

impl Lane for f64 {
    type Mask = bool;
    const LANES: usize = 1;
    #[inline(always)]
    fn abs(self) -> f64 {
        f64::abs(self)
    }
    #[inline(always)]
    fn max(self, o: f64) -> f64 {
        f64::max(self, o)
    }
    #[inline(always)]
    fn min(self, o: f64) -> f64 {
        f64::min(self, o)
    }
    #[inline(always)]
    fn lt(self, o: f64) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: f64) -> bool {
        self <= o
    }
    #[inline(always)]
    fn eq(self, o: f64) -> bool {
        self == o
    }
    #[inline(always)]
    fn finite(self) -> bool {
        self.is_finite()
    }
    #[inline(always)]
    fn select(m: bool, a: f64, b: f64) -> f64 {
        if m {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn mask(b: bool) -> bool {
        b
    }
    #[inline(always)]
    fn any(m: bool) -> bool {
        m
    }
    #[inline(always)]
    fn all(m: bool) -> bool {
        m
    }
    #[inline(always)]
    fn lane(self, _i: usize) -> f64 {
        self
    }
    #[inline(always)]
    fn lane_set(m: bool, _i: usize) -> bool {
        m
    }
    #[inline(always)]
    fn set_lane(&mut self, _i: usize, v: f64) {
        *self = v;
    }
    #[inline(always)]
    fn cos_sin(x: &[f64], cs: &mut [(f64, f64)]) {
        crate::simd::math::cos_sin_short(x, cs);
    }
}

/// A value and its derivatives along `K` directions at once (forward mode):
/// one evaluation of a model in `Jet<K>` gives `K` columns of its Jacobian.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jet<const K: usize> {
    pub v: f64,
    pub d: [f64; K],
}

/// A value and its derivative along one direction.
pub type Dual = Jet<1>;

impl<const K: usize> Default for Jet<K> {
    #[inline]
    fn default() -> Self {
        Jet {
            v: 0.0,
            d: [0.0; K],
        }
    }
}

impl<const K: usize> Jet<K> {
    /// `v` with derivative 1 along direction `k` (0 along the others; none
    /// when `k >= K`).
    #[inline]
    pub fn seeded(v: f64, k: usize) -> Self {
        let mut d = [0.0; K];
        if k < K {
            d[k] = 1.0;
        }
        Jet { v, d }
    }
    /// `v` with the derivatives `d`.
    #[inline]
    pub fn with(v: f64, d: [f64; K]) -> Self {
        Jet { v, d }
    }
    /// The value `v` of a function whose derivative with respect to `self`
    /// is `dv` (chain rule).
    #[inline]
    fn chain(self, v: f64, dv: f64) -> Self {
        let mut d = self.d;
        for x in d.iter_mut() {
            *x *= dv;
        }
        Jet { v, d }
    }
}

impl Dual {
    /// The variable itself: derivative 1.
    #[cfg(test)]
    pub fn var(v: f64) -> Dual {
        Jet { v, d: [1.0] }
    }
    /// `v` with derivative `d`.
    #[inline]
    pub fn new(v: f64, d: f64) -> Dual {
        Jet { v, d: [d] }
    }
    /// The derivative.
    #[cfg(test)]
    pub fn der(self) -> f64 {
        self.d[0]
    }
}

impl<const K: usize> Add for Jet<K> {
    type Output = Self;
    #[inline]
    fn add(mut self, o: Self) -> Self {
        self.v += o.v;
        for (a, b) in self.d.iter_mut().zip(o.d) {
            *a += b;
        }
        self
    }
}
impl<const K: usize> Sub for Jet<K> {
    type Output = Self;
    #[inline]
    fn sub(mut self, o: Self) -> Self {
        self.v -= o.v;
        for (a, b) in self.d.iter_mut().zip(o.d) {
            *a -= b;
        }
        self
    }
}
impl<const K: usize> Mul for Jet<K> {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        let mut d = [0.0; K];
        for ((x, a), b) in d.iter_mut().zip(self.d).zip(o.d) {
            *x = a * o.v + self.v * b;
        }
        Jet { v: self.v * o.v, d }
    }
}
impl<const K: usize> Div for Jet<K> {
    type Output = Self;
    #[inline]
    fn div(self, o: Self) -> Self {
        let q = self.v / o.v;
        let inv = 1.0 / o.v;
        let mut d = [0.0; K];
        for ((x, a), b) in d.iter_mut().zip(self.d).zip(o.d) {
            *x = (a - q * b) * inv;
        }
        Jet { v: q, d }
    }
}
impl<const K: usize> Neg for Jet<K> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.chain(-self.v, -1.0)
    }
}
impl<const K: usize> AddAssign for Jet<K> {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}
impl<const K: usize> SubAssign for Jet<K> {
    #[inline]
    fn sub_assign(&mut self, o: Self) {
        *self = *self - o;
    }
}
impl<const K: usize> MulAssign for Jet<K> {
    #[inline]
    fn mul_assign(&mut self, o: Self) {
        *self = *self * o;
    }
}
impl<const K: usize> Add<f64> for Jet<K> {
    type Output = Self;
    #[inline]
    fn add(mut self, o: f64) -> Self {
        self.v += o;
        self
    }
}
impl<const K: usize> Sub<f64> for Jet<K> {
    type Output = Self;
    #[inline]
    fn sub(mut self, o: f64) -> Self {
        self.v -= o;
        self
    }
}
impl<const K: usize> Mul<f64> for Jet<K> {
    type Output = Self;
    #[inline]
    fn mul(self, o: f64) -> Self {
        self.chain(self.v * o, o)
    }
}
impl<const K: usize> Div<f64> for Jet<K> {
    type Output = Self;
    #[inline]
    fn div(self, o: f64) -> Self {
        self.chain(self.v / o, 1.0 / o)
    }
}

impl<const K: usize> Arith for Jet<K> {
    #[inline]
    fn cst(v: f64) -> Self {
        Jet { v, d: [0.0; K] }
    }
    #[inline]
    fn sqrt(self) -> Self {
        let r = self.v.sqrt();
        // d sqrt(0) is infinite; a zero derivative keeps a zero-length segment finite
        self.chain(r, if r > 0.0 { 0.5 / r } else { 0.0 })
    }
    #[inline]
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.v.sin_cos();
        (self.chain(s, c), self.chain(c, -s))
    }
    #[inline]
    fn recip_or_zero(self) -> Self {
        if self.v == 0.0 {
            Self::cst(0.0)
        } else {
            Self::cst(1.0) / self
        }
    }
}

/// A jet is one lane whose comparisons are on its value (pivots, limits);
/// a selection takes the whole jet, derivatives with it.
impl<const K: usize> Lane for Jet<K> {
    type Mask = bool;
    const LANES: usize = 1;
    #[inline]
    fn abs(self) -> Self {
        if self.v < 0.0 {
            -self
        } else {
            self
        }
    }
    #[inline]
    fn max(self, o: Self) -> Self {
        if o.v > self.v || self.v.is_nan() {
            o
        } else {
            self
        }
    }
    #[inline]
    fn min(self, o: Self) -> Self {
        if o.v < self.v || self.v.is_nan() {
            o
        } else {
            self
        }
    }
    #[inline]
    fn lt(self, o: Self) -> bool {
        self.v < o.v
    }
    #[inline]
    fn le(self, o: Self) -> bool {
        self.v <= o.v
    }
    #[inline]
    fn eq(self, o: Self) -> bool {
        self.v == o.v
    }
    #[inline]
    fn finite(self) -> bool {
        self.v.is_finite()
    }
    #[inline]
    fn select(m: bool, a: Self, b: Self) -> Self {
        if m {
            a
        } else {
            b
        }
    }
    #[inline]
    fn mask(b: bool) -> bool {
        b
    }
    #[inline]
    fn any(m: bool) -> bool {
        m
    }
    #[inline]
    fn all(m: bool) -> bool {
        m
    }
    #[inline]
    fn lane(self, _i: usize) -> f64 {
        self.v
    }
    #[inline]
    fn lane_set(m: bool, _i: usize) -> bool {
        m
    }
    #[inline]
    fn set_lane(&mut self, _i: usize, v: f64) {
        *self = Self::cst(v);
    }
    fn cos_sin(x: &[Self], cs: &mut [(Self, Self)]) {
        for (t, o) in x.iter().zip(cs.iter_mut()) {
            let (s, c) = t.sin_cos();
            *o = (c, s);
        }
    }
}

impl<const K: usize> Real for Jet<K> {
    #[inline]
    fn is_variable(self) -> bool {
        self.d.iter().any(|x| *x != 0.0)
    }
    #[inline]
    fn val(self) -> f64 {
        self.v
    }
    #[inline]
    fn tanh(self) -> Self {
        let t = self.v.tanh();
        self.chain(t, 1.0 - t * t)
    }
    #[inline]
    fn exp(self) -> Self {
        let e = self.v.exp();
        self.chain(e, e)
    }
    #[inline]
    fn atan2(self, x: Self) -> Self {
        let r2 = self.v * self.v + x.v * x.v;
        let (a, b) = if r2 > 0.0 {
            (x.v / r2, -self.v / r2)
        } else {
            (0.0, 0.0)
        };
        let mut d = [0.0; K];
        for ((o, dy), dx) in d.iter_mut().zip(self.d).zip(x.d) {
            *o = a * dy + b * dx;
        }
        Jet {
            v: self.v.atan2(x.v),
            d,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(f: impl Fn(Dual) -> Dual, g: impl Fn(f64) -> f64, x: f64) {
        let h = 1e-6;
        let fd = (g(x + h) - g(x - h)) / (2.0 * h);
        let ad = f(Dual::var(x));
        assert!((ad.v - g(x)).abs() < 1e-15, "value at {x}");
        assert!(
            (ad.der() - fd).abs() < 1e-7 * (1.0 + fd.abs()),
            "{} vs {fd} at {x}",
            ad.der()
        );
    }

    #[test]
    fn derivatives_match_central_differences() {
        for x in [-1.3, -0.2, 0.4, 2.1] {
            check(|v| v.sin_cos().0 * v.sin_cos().1, |v| v.sin() * v.cos(), x);
            check(
                |v| v.tanh() / (v * v + 1.0),
                |v| v.tanh() / (v * v + 1.0),
                x,
            );
            check(
                |v| Arith::sqrt(v * v + 3.0) - v * 2.0,
                |v| (v * v + 3.0).sqrt() - 2.0 * v,
                x,
            );
            check(
                |v| Real::atan2(v * 0.5 + 0.1, Dual::cst(0.7) - v),
                |v| (0.5 * v + 0.1).atan2(0.7 - v),
                x,
            );
            check(
                |v| Real::exp(v * 0.7 - 0.2) * v,
                |v| (0.7 * v - 0.2).exp() * v,
                x,
            );
            check(
                |v| <Dual as Real>::hypot2(v, v * v - 2.0),
                |v| v.hypot(v * v - 2.0),
                x,
            );
        }
    }

    #[test]
    fn a_jet_carries_the_partials_of_every_direction_at_once() {
        // f(x, y, z) = atan2(x y + 0.3, z) sqrt(1 + z^2) tanh(x) / (2 + sin y)
        fn f<S: Real>(x: S, y: S, z: S) -> S {
            let (s, _) = y.sin_cos();
            Real::atan2(x * y + 0.3, z) * Arith::sqrt(z * z + 1.0) * x.tanh() / (s + 2.0)
        }
        let p = [0.7, -1.1, 0.4];
        let j: Jet<3> = f(
            Jet::seeded(p[0], 0),
            Jet::seeded(p[1], 1),
            Jet::seeded(p[2], 2),
        );
        for k in 0..3 {
            let d = |i: usize| Dual::new(p[i], if i == k { 1.0 } else { 0.0 });
            let one = f(d(0), d(1), d(2));
            assert_eq!(j.v, one.v);
            assert!((j.d[k] - one.der()).abs() <= 1e-15 * one.der().abs().max(1.0));
        }
        assert!(!Jet::<3>::cst(1.0).is_variable() && j.is_variable());
    }
}
