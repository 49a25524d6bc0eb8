//! Scalars the models are written over: `f64`, and [`Dual`] numbers that
//! carry one directional derivative (forward mode). The plant, the statics
//! and the cable geometry are generic over [`Real`], so one code path gives
//! values and exact derivatives (no finite differences).

use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// What the models need of a scalar.
pub trait Real:
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
    /// A constant (zero derivative).
    fn cst(v: f64) -> Self;
    /// The value (derivative dropped).
    fn val(self) -> f64;
    fn sqrt(self) -> Self;
    fn sin_cos(self) -> (Self, Self);
    fn tanh(self) -> Self;
    fn atan2(self, x: Self) -> Self;
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

impl Real for f64 {
    #[inline]
    fn cst(v: f64) -> f64 {
        v
    }
    #[inline]
    fn val(self) -> f64 {
        self
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
    fn tanh(self) -> f64 {
        f64::tanh(self)
    }
    #[inline]
    fn atan2(self, x: f64) -> f64 {
        f64::atan2(self, x)
    }
}

/// A value and its derivative along one direction.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Dual {
    pub v: f64,
    pub d: f64,
}

impl Dual {
    /// The variable itself: derivative 1.
    #[inline]
    pub fn var(v: f64) -> Dual {
        Dual { v, d: 1.0 }
    }
    /// `v` with derivative `d`.
    #[inline]
    pub fn new(v: f64, d: f64) -> Dual {
        Dual { v, d }
    }
}

impl Add for Dual {
    type Output = Dual;
    #[inline]
    fn add(self, o: Dual) -> Dual {
        Dual::new(self.v + o.v, self.d + o.d)
    }
}
impl Sub for Dual {
    type Output = Dual;
    #[inline]
    fn sub(self, o: Dual) -> Dual {
        Dual::new(self.v - o.v, self.d - o.d)
    }
}
impl Mul for Dual {
    type Output = Dual;
    #[inline]
    fn mul(self, o: Dual) -> Dual {
        Dual::new(self.v * o.v, self.d * o.v + self.v * o.d)
    }
}
impl Div for Dual {
    type Output = Dual;
    #[inline]
    fn div(self, o: Dual) -> Dual {
        let q = self.v / o.v;
        Dual::new(q, (self.d - q * o.d) / o.v)
    }
}
impl Neg for Dual {
    type Output = Dual;
    #[inline]
    fn neg(self) -> Dual {
        Dual::new(-self.v, -self.d)
    }
}
impl AddAssign for Dual {
    #[inline]
    fn add_assign(&mut self, o: Dual) {
        *self = *self + o;
    }
}
impl SubAssign for Dual {
    #[inline]
    fn sub_assign(&mut self, o: Dual) {
        *self = *self - o;
    }
}
impl MulAssign for Dual {
    #[inline]
    fn mul_assign(&mut self, o: Dual) {
        *self = *self * o;
    }
}
impl Add<f64> for Dual {
    type Output = Dual;
    #[inline]
    fn add(self, o: f64) -> Dual {
        Dual::new(self.v + o, self.d)
    }
}
impl Sub<f64> for Dual {
    type Output = Dual;
    #[inline]
    fn sub(self, o: f64) -> Dual {
        Dual::new(self.v - o, self.d)
    }
}
impl Mul<f64> for Dual {
    type Output = Dual;
    #[inline]
    fn mul(self, o: f64) -> Dual {
        Dual::new(self.v * o, self.d * o)
    }
}
impl Div<f64> for Dual {
    type Output = Dual;
    #[inline]
    fn div(self, o: f64) -> Dual {
        Dual::new(self.v / o, self.d / o)
    }
}

impl Real for Dual {
    #[inline]
    fn cst(v: f64) -> Dual {
        Dual::new(v, 0.0)
    }
    #[inline]
    fn is_variable(self) -> bool {
        self.d != 0.0
    }
    #[inline]
    fn val(self) -> f64 {
        self.v
    }
    #[inline]
    fn sqrt(self) -> Dual {
        let r = self.v.sqrt();
        // d sqrt(0) is infinite; a zero derivative keeps a zero-length segment finite
        let d = if r > 0.0 { self.d / (2.0 * r) } else { 0.0 };
        Dual::new(r, d)
    }
    #[inline]
    fn sin_cos(self) -> (Dual, Dual) {
        let (s, c) = self.v.sin_cos();
        (Dual::new(s, c * self.d), Dual::new(c, -s * self.d))
    }
    #[inline]
    fn tanh(self) -> Dual {
        let t = self.v.tanh();
        Dual::new(t, (1.0 - t * t) * self.d)
    }
    #[inline]
    fn atan2(self, x: Dual) -> Dual {
        let r2 = self.v * self.v + x.v * x.v;
        let d = if r2 > 0.0 {
            (x.v * self.d - self.v * x.d) / r2
        } else {
            0.0
        };
        Dual::new(self.v.atan2(x.v), d)
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
            (ad.d - fd).abs() < 1e-7 * (1.0 + fd.abs()),
            "{} vs {fd} at {x}",
            ad.d
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
                |v| Real::sqrt(v * v + 3.0) - v * 2.0,
                |v| (v * v + 3.0).sqrt() - 2.0 * v,
                x,
            );
            check(
                |v| Real::atan2(v * 0.5 + 0.1, Dual::cst(0.7) - v),
                |v| (0.5 * v + 0.1).atan2(0.7 - v),
                x,
            );
            check(
                |v| <Dual as Real>::hypot2(v, v * v - 2.0),
                |v| v.hypot(v * v - 2.0),
                x,
            );
        }
    }
}
