//! `K` pulp vectors handled in lockstep, with arithmetic operators.
//!
//! [`Lanes<S, K>`] holds `K` vectors of `S::f64s` (`K * S::F64_LANES`
//! values); every operation is applied to the `K` vectors one after the
//! other, so a kernel written once over `Lanes` interleaves `K` independent
//! dependency chains instruction by instruction (the out-of-order core then
//! overlaps their latencies). `K = 1` is a plain vector. All methods are
//! `#[inline(always)]` so they compile into the caller's instruction set.

use core::ops::{Add, BitAnd, BitOr, BitXor, Div, Mul, Neg, Not, Sub};
use pulp::Simd;

/// `K` vectors of f64 lanes.
#[derive(Debug, Clone, Copy)]
pub struct Lanes<S: Simd, const K: usize> {
    pub simd: S,
    pub v: [S::f64s; K],
}

/// `K` vectors of lane masks (the result of comparing [`Lanes`]).
#[derive(Debug, Clone, Copy)]
pub struct Mask<S: Simd, const K: usize> {
    pub simd: S,
    pub v: [S::m64s; K],
}

impl<S: Simd, const K: usize> Lanes<S, K> {
    #[inline(always)]
    pub fn new(simd: S, v: [S::f64s; K]) -> Self {
        Lanes { simd, v }
    }

    /// Every lane `x`.
    #[inline(always)]
    pub fn splat(simd: S, x: f64) -> Self {
        Lanes {
            simd,
            v: [simd.splat_f64s(x); K],
        }
    }

    #[inline(always)]
    fn map(self, f: impl Fn(S, S::f64s) -> S::f64s) -> Self {
        let mut v = self.v;
        for x in v.iter_mut() {
            *x = f(self.simd, *x);
        }
        Lanes { simd: self.simd, v }
    }

    #[inline(always)]
    fn zip(self, o: Self, f: impl Fn(S, S::f64s, S::f64s) -> S::f64s) -> Self {
        let mut v = self.v;
        for (x, y) in v.iter_mut().zip(o.v) {
            *x = f(self.simd, *x, y);
        }
        Lanes { simd: self.simd, v }
    }

    #[inline(always)]
    fn cmp(self, o: Self, f: impl Fn(S, S::f64s, S::f64s) -> S::m64s) -> Mask<S, K> {
        let z = self.simd.equal_f64s(self.v[0], self.v[0]);
        let mut v = [z; K];
        for ((m, x), y) in v.iter_mut().zip(self.v).zip(o.v) {
            *m = f(self.simd, x, y);
        }
        Mask { simd: self.simd, v }
    }

    #[inline(always)]
    pub fn sqrt(self) -> Self {
        self.map(|s, x| s.sqrt_f64s(x))
    }

    #[inline(always)]
    pub fn abs(self) -> Self {
        self.map(|s, x| s.abs_f64s(x))
    }

    /// `max(self, o)` as the x86 instruction: `o` when either is NaN (so
    /// `x.max(0)` is 0 for a NaN `x`, like `f64::max`).
    #[inline(always)]
    pub fn max(self, o: Self) -> Self {
        self.zip(o, |s, x, y| s.max_f64s(x, y))
    }

    #[inline(always)]
    pub fn lt(self, o: Self) -> Mask<S, K> {
        self.cmp(o, |s, x, y| s.less_than_f64s(x, y))
    }

    #[inline(always)]
    pub fn le(self, o: Self) -> Mask<S, K> {
        self.cmp(o, |s, x, y| s.less_than_or_equal_f64s(x, y))
    }

    #[inline(always)]
    pub fn gt(self, o: Self) -> Mask<S, K> {
        self.cmp(o, |s, x, y| s.greater_than_f64s(x, y))
    }

    #[inline(always)]
    pub fn ge(self, o: Self) -> Mask<S, K> {
        self.cmp(o, |s, x, y| s.greater_than_or_equal_f64s(x, y))
    }

    #[inline(always)]
    pub fn eq(self, o: Self) -> Mask<S, K> {
        self.cmp(o, |s, x, y| s.equal_f64s(x, y))
    }

    /// Comparisons with a constant.
    #[inline(always)]
    pub fn lt_c(self, c: f64) -> Mask<S, K> {
        self.lt(Self::splat(self.simd, c))
    }

    #[inline(always)]
    pub fn gt_c(self, c: f64) -> Mask<S, K> {
        self.gt(Self::splat(self.simd, c))
    }

    #[inline(always)]
    pub fn ge_c(self, c: f64) -> Mask<S, K> {
        self.ge(Self::splat(self.simd, c))
    }

    #[inline(always)]
    pub fn le_c(self, c: f64) -> Mask<S, K> {
        self.le(Self::splat(self.simd, c))
    }

    #[inline(always)]
    pub fn eq_c(self, c: f64) -> Mask<S, K> {
        self.eq(Self::splat(self.simd, c))
    }

    /// Bitwise AND of the lanes' bit patterns with `bits`.
    #[inline(always)]
    pub fn and_bits(self, bits: u64) -> Self {
        self.map(|s, x| {
            s.transmute_f64s_u64s(s.and_u64s(s.transmute_u64s_f64s(x), s.splat_u64s(bits)))
        })
    }

    /// Bitwise OR of the lanes' bit patterns with those of `o`.
    #[inline(always)]
    pub fn or_bits(self, o: Self) -> Self {
        self.zip(o, |s, x, y| s.or_f64s(x, y))
    }

    /// Lanes whose bit pattern has any of `bits` set.
    #[inline(always)]
    pub fn any_bits(self, bits: u64) -> Mask<S, K> {
        let s = self.simd;
        let zero = s.splat_u64s(0);
        let mut v = [s.equal_f64s(self.v[0], self.v[0]); K];
        for (m, x) in v.iter_mut().zip(self.v) {
            let b = s.and_u64s(s.transmute_u64s_f64s(x), s.splat_u64s(bits));
            *m = s.not_m64s(s.equal_u64s(b, zero));
        }
        Mask { simd: s, v }
    }

    /// Lanes whose sign bit is set (-0.0, negative numbers, negative NaNs).
    #[inline(always)]
    pub fn sign_bit(self) -> Mask<S, K> {
        self.any_bits(1 << 63)
    }

    /// `self` with its sign flipped where `m` is set.
    #[inline(always)]
    pub fn negate_where(self, m: Mask<S, K>) -> Self {
        m.select(-self, self)
    }
}

impl<S: Simd, const K: usize> Mask<S, K> {
    /// Per lane: `a` where set, `b` elsewhere.
    #[inline(always)]
    pub fn select(self, a: Lanes<S, K>, b: Lanes<S, K>) -> Lanes<S, K> {
        let mut v = b.v;
        for ((x, m), y) in v.iter_mut().zip(self.v).zip(a.v) {
            *x = self.simd.select_f64s(m, y, *x);
        }
        Lanes { simd: b.simd, v }
    }

    /// [`Mask::select`] on `(hi, lo)` pairs.
    #[inline(always)]
    pub fn select2(
        self,
        a: (Lanes<S, K>, Lanes<S, K>),
        b: (Lanes<S, K>, Lanes<S, K>),
    ) -> (Lanes<S, K>, Lanes<S, K>) {
        (self.select(a.0, b.0), self.select(a.1, b.1))
    }

    /// Whether any lane is set.
    #[inline(always)]
    pub fn any(self) -> bool {
        self.v
            .iter()
            .any(|m| self.simd.first_true_m64s(*m) < S::F64_LANES)
    }

    /// Every lane set.
    #[inline(always)]
    pub fn all_set(simd: S) -> Self {
        let z = simd.splat_f64s(0.0);
        Mask {
            simd,
            v: [simd.equal_f64s(z, z); K],
        }
    }
}

macro_rules! binop {
    ($trait:ident, $method:ident, $op:ident) => {
        impl<S: Simd, const K: usize> $trait for Lanes<S, K> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                self.zip(o, |s, x, y| s.$op(x, y))
            }
        }
        impl<S: Simd, const K: usize> $trait<f64> for Lanes<S, K> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, c: f64) -> Self {
                self.$method(Self::splat(self.simd, c))
            }
        }
        impl<S: Simd, const K: usize> $trait<Lanes<S, K>> for f64 {
            type Output = Lanes<S, K>;
            #[inline(always)]
            fn $method(self, o: Lanes<S, K>) -> Lanes<S, K> {
                Lanes::splat(o.simd, self).$method(o)
            }
        }
    };
}
binop!(Add, add, add_f64s);
binop!(Sub, sub, sub_f64s);
binop!(Mul, mul, mul_f64s);
binop!(Div, div, div_f64s);

impl<S: Simd, const K: usize> Neg for Lanes<S, K> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        self.map(|s, x| s.neg_f64s(x))
    }
}

macro_rules! maskop {
    ($trait:ident, $method:ident, $op:ident) => {
        impl<S: Simd, const K: usize> $trait for Mask<S, K> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                let mut v = self.v;
                for (x, y) in v.iter_mut().zip(o.v) {
                    *x = self.simd.$op(*x, y);
                }
                Mask { simd: self.simd, v }
            }
        }
    };
}
maskop!(BitAnd, bitand, and_m64s);
maskop!(BitOr, bitor, or_m64s);
maskop!(BitXor, bitxor, xor_m64s);

impl<S: Simd, const K: usize> Not for Mask<S, K> {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        let mut v = self.v;
        for x in v.iter_mut() {
            *x = self.simd.not_m64s(*x);
        }
        Mask { simd: self.simd, v }
    }
}
