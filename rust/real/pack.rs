//! [`Pack<W>`]: `W` rows' `f64`s in lockstep as one scalar of the geometry
//! ([`crate::real::Arith`]) and of the solves ([`crate::real::Lane`]), so
//! the code written once over the scalar (the chain of frames, cable
//! lengths and their Jacobian, the Newton step) runs `W` rows per
//! instruction.
//!
//! Every operation is element-wise on `[f64; W]` and `#[inline(always)]`:
//! compiled inside a `pulp::Arch::dispatch` (x86-64-v3: AVX2) the compiler
//! turns each into vector instructions, elsewhere into the baseline's
//! (SSE2 pairs) or scalar ones. No fused multiply-add is formed (Rust does
//! not contract), and `sin_cos` is the lane kernel of [`crate::simd::math`]
//! that `f64`'s [`Lane::cos_sin`] also runs, so lane `i` of every result
//! has the bits of the same operations on the `f64`s of row `i`.

use super::{Arith, Lane};
use crate::simd::math::sin_cos_quick;
use std::ops::{Add, AddAssign, BitAnd, BitOr, Div, Mul, MulAssign, Neg, Not, Sub, SubAssign};

/// `W` lanes of `f64`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pack<const W: usize>(pub [f64; W]);

/// `W` lane booleans (all bits set or none, per lane).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PackMask<const W: usize>(pub [u64; W]);

impl<const W: usize> Pack<W> {
    /// Every lane `v`.
    #[inline(always)]
    pub fn splat(v: f64) -> Self {
        Pack([v; W])
    }

    #[inline(always)]
    fn map(self, f: impl Fn(f64) -> f64) -> Self {
        let mut v = self.0;
        for x in v.iter_mut() {
            *x = f(*x);
        }
        Pack(v)
    }

    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(f64, f64) -> f64) -> Self {
        let mut v = self.0;
        for (x, y) in v.iter_mut().zip(o.0) {
            *x = f(*x, y);
        }
        Pack(v)
    }

    #[inline(always)]
    fn cmp(self, o: Self, f: impl Fn(f64, f64) -> bool) -> PackMask<W> {
        let mut m = [0u64; W];
        for ((b, x), y) in m.iter_mut().zip(self.0).zip(o.0) {
            *b = if f(x, y) { u64::MAX } else { 0 };
        }
        PackMask(m)
    }
}

impl<const W: usize> PackMask<W> {
    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(u64, u64) -> u64) -> Self {
        let mut v = self.0;
        for (x, y) in v.iter_mut().zip(o.0) {
            *x = f(*x, y);
        }
        PackMask(v)
    }
}

macro_rules! binop {
    ($trait:ident, $method:ident, $assign:ident, $amethod:ident, $op:tt) => {
        impl<const W: usize> $trait for Pack<W> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                self.zip(o, |x, y| x $op y)
            }
        }
        impl<const W: usize> $trait<f64> for Pack<W> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, c: f64) -> Self {
                self.map(|x| x $op c)
            }
        }
        impl<const W: usize> $assign for Pack<W> {
            #[inline(always)]
            fn $amethod(&mut self, o: Self) {
                *self = *self $op o;
            }
        }
    };
}
binop!(Add, add, AddAssign, add_assign, +);
binop!(Sub, sub, SubAssign, sub_assign, -);
binop!(Mul, mul, MulAssign, mul_assign, *);

impl<const W: usize> Div for Pack<W> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        self.zip(o, |x, y| x / y)
    }
}

impl<const W: usize> Div<f64> for Pack<W> {
    type Output = Self;
    #[inline(always)]
    fn div(self, c: f64) -> Self {
        self.map(|x| x / c)
    }
}

impl<const W: usize> Neg for Pack<W> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|x| -x)
    }
}

impl<const W: usize> BitAnd for PackMask<W> {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, o: Self) -> Self {
        self.zip(o, |x, y| x & y)
    }
}

impl<const W: usize> BitOr for PackMask<W> {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, o: Self) -> Self {
        self.zip(o, |x, y| x | y)
    }
}

impl<const W: usize> Not for PackMask<W> {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        let mut v = self.0;
        for x in v.iter_mut() {
            *x = !*x;
        }
        PackMask(v)
    }
}

/// `(cos, sin)` of the lanes of `x` by the lane kernel.
#[inline(always)]
fn cos_sin_pack<const W: usize>(x: Pack<W>) -> (Pack<W>, Pack<W>) {
    let (s, c) = sin_cos_quick(x.0);
    (Pack(c), Pack(s))
}

impl<const W: usize> Arith for Pack<W> {
    #[inline(always)]
    fn cst(v: f64) -> Self {
        Pack([v; W])
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        self.map(f64::sqrt)
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let (c, s) = cos_sin_pack(self);
        (s, c)
    }
    #[inline(always)]
    fn recip_or_zero(self) -> Self {
        self.map(|x| if x == 0.0 { 0.0 } else { 1.0 / x })
    }
}

impl<const W: usize> Lane for Pack<W> {
    type Mask = PackMask<W>;
    const LANES: usize = W;
    #[inline(always)]
    fn abs(self) -> Self {
        self.map(f64::abs)
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        self.zip(o, f64::max)
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        self.zip(o, f64::min)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> PackMask<W> {
        self.cmp(o, |x, y| x < y)
    }
    #[inline(always)]
    fn le(self, o: Self) -> PackMask<W> {
        self.cmp(o, |x, y| x <= y)
    }
    #[inline(always)]
    fn eq(self, o: Self) -> PackMask<W> {
        self.cmp(o, |x, y| x == y)
    }
    #[inline(always)]
    fn finite(self) -> PackMask<W> {
        // |x| < inf is false for infinities and NaN
        self.abs().lt(Pack::splat(f64::INFINITY))
    }
    #[inline(always)]
    fn select(m: PackMask<W>, a: Self, b: Self) -> Self {
        let mut v = b.0;
        for ((x, y), k) in v.iter_mut().zip(a.0).zip(m.0) {
            *x = f64::from_bits((y.to_bits() & k) | (x.to_bits() & !k));
        }
        Pack(v)
    }
    #[inline(always)]
    fn mask(b: bool) -> PackMask<W> {
        PackMask([if b { u64::MAX } else { 0 }; W])
    }
    #[inline(always)]
    fn any(m: PackMask<W>) -> bool {
        m.0.iter().fold(0, |a, x| a | x) != 0
    }
    #[inline(always)]
    fn all(m: PackMask<W>) -> bool {
        m.0.iter().fold(u64::MAX, |a, x| a & x) != 0
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f64 {
        self.0[i]
    }
    #[inline(always)]
    fn lane_set(m: PackMask<W>, i: usize) -> bool {
        m.0[i] != 0
    }
    #[inline(always)]
    fn set_lane(&mut self, i: usize, v: f64) {
        self.0[i] = v;
    }
    #[inline(always)]
    fn cos_sin(x: &[Self], cs: &mut [(Self, Self)]) {
        for (t, o) in x.iter().zip(cs.iter_mut()) {
            *o = cos_sin_pack(*t);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pack_computes_lane_by_lane_what_f64_computes() {
        let xs = [0.3, -1.7, 0.0, 2.5e-9];
        let ys = [1.1, 0.25, -3.0, 0.0];
        let (x, y) = (Pack(xs), Pack(ys));
        let mut cs = [(Pack::<4>::splat(0.0), Pack::splat(0.0))];
        Pack::cos_sin(&[x], &mut cs);
        for i in 0..4 {
            let (a, b) = (xs[i], ys[i]);
            assert_eq!((x + y).0[i], a + b);
            assert_eq!((x * y - y / 3.0).0[i], a * b - b / 3.0);
            assert_eq!((x / y).0[i].to_bits(), (a / b).to_bits());
            assert_eq!(Arith::sqrt(y.abs()).0[i], b.abs().sqrt());
            assert_eq!(y.recip_or_zero().0[i], b.recip_or_zero());
            let mut one = [(0.0, 0.0)];
            f64::cos_sin(&[a], &mut one);
            assert_eq!((cs[0].0 .0[i], cs[0].1 .0[i]), one[0]);
            let m = x.lt(y);
            assert_eq!(Pack::lane_set(m, i), a < b);
            assert_eq!(Pack::select(m, x, y).0[i], if a < b { a } else { b });
        }
        let inf = Pack([1.0, f64::INFINITY, f64::NAN, -0.0]);
        assert_eq!(inf.finite().0.map(|b| b != 0), [true, false, false, true]);
        assert!(Pack::any(x.lt(y)) && !Pack::all(x.lt(y)));
    }
}
