//! Vectorised f64 math over pulp lanes: `sqrt`, `sin_cos`, `atan2`, `acos`.
//!
//! Every function is generic over [`pulp::Simd`] and `#[inline(always)]`, so
//! it compiles into the caller's instruction set (AVX2, AVX-512, NEON or the
//! one-lane scalar fallback). Only additions, subtractions, multiplications,
//! divisions, square roots, comparisons and bit selects are used — no fused
//! multiply-add — so every instruction set gives bit-identical results, and a
//! lane gives the same bits as the scalar (one-lane) instantiation.
//!
//! The kernels are the fdlibm (Sun, 1993) minimax approximations, arranged
//! without data-dependent branches (both sides of every case are computed and
//! the lane picks one with a select) and with the polynomials evaluated by
//! Estrin's scheme (short dependency chains).
//!
//! Each function comes in two forms: on one vector (`sin_cos(simd, x)`), and
//! on `K` vectors in lockstep ([`sin_cos_lanes`] on a [`Lanes<S, K>`]), which
//! interleaves `K` independent dependency chains for the out-of-order core.
//! Both give the same bits lane by lane.
//!
//! The slice functions ([`sin_cos_slice`], ...) dispatch at run time with
//! `pulp::Arch::new()`; they are conveniences for callers outside a SIMD
//! context and for the tests.

// fdlibm's coefficients are kept as published (21 significant digits)
#![allow(clippy::excessive_precision)]

use super::lanes::{Lanes, Mask};
use pulp::{Simd, WithSimd};

// ---------------------------------------------------------------- constants

/// 1.5 * 2^52: adding it rounds a double below 2^51 to an integer held in
/// the low mantissa bits.
const MAGIC: f64 = 6755399441055744.0;
const TWO_OVER_PI: f64 = core::f64::consts::FRAC_2_PI;
/// pi/2 in four parts: three of 33 bits (so `q * P_k` is exact for
/// |q| < 2^20) and the rest (fdlibm's `pio2_1`, `pio2_2`, `pio2_3`, `pio2_3t`).
const PIO2_1: f64 = f64::from_bits(0x3FF921FB54400000);
const PIO2_2: f64 = f64::from_bits(0x3DD0B4611A600000);
const PIO2_3: f64 = f64::from_bits(0x3BA3198A2E000000);
const PIO2_3T: f64 = f64::from_bits(0x397B839A252049C1);

/// Largest |x| for which [`sin_cos`] uses its own reduction (|q| <= 2^20 *
/// (2/pi) < 2^20 keeps every `q * PIO2_k` exact); beyond it, the lanes fall
/// back to `f64::sin`/`f64::cos`.
pub const SIN_COS_FAST_MAX: f64 = 1_048_576.0;

// fdlibm k_sin.c / k_cos.c, minimax on |x| <= pi/4.
const S1: f64 = -1.66666666666666324348e-01;
const S2: f64 = 8.33333333332248946124e-03;
const S3: f64 = -1.98412698298579493134e-04;
const S4: f64 = 2.75573137070700676789e-06;
const S5: f64 = -2.50507602534068634195e-08;
const S6: f64 = 1.58969099521155010221e-10;
const C1: f64 = 4.16666666666666019037e-02;
const C2: f64 = -1.38888888888741095749e-03;
const C3: f64 = 2.48015872894767294178e-05;
const C4: f64 = -2.75573143513906633035e-07;
const C5: f64 = 2.08757232129817482790e-09;
const C6: f64 = -1.13596475577881948265e-11;

// fdlibm s_atan.c, minimax for atan on |x| <= 7/16: even and odd
// coefficients (atan(x) = x - x (z P_even(z^2) + z^2 P_odd(z^2)), z = x^2).
const AT_EVEN: [f64; 6] = [
    3.33333333333329318027e-01,
    1.42857142725034663711e-01,
    9.09088713343650656196e-02,
    6.66107313738753120669e-02,
    4.97687799461593236017e-02,
    1.62858201153657823623e-02,
];
const AT_ODD: [f64; 5] = [
    -1.99999999998764832476e-01,
    -1.11111104054623557880e-01,
    -7.69187620504482999495e-02,
    -5.83357013379057348645e-02,
    -3.65315727442169155270e-02,
];
/// Breakpoint angles `R` = atan(1/2), pi/4 as `(hi, lo)` with `hi` cut to
/// 30 significant bits, so that `Q +- hi` is exact for the quadrant angles
/// `Q` = pi/2, pi below (their `hi` have no bits under 2^-49).
const ATAN_HALF: (f64, f64) = (0.463647608878091, 1.2271513854549401e-10);
const PIO4: (f64, f64) = (0.7853981633670628, 3.038550253253096e-11);
/// `(hi, lo)` of pi/2 and pi: `hi` the nearest double, `lo` the rest.
const PIO2: (f64, f64) = (core::f64::consts::FRAC_PI_2, 6.123233995736766e-17);
const PI: (f64, f64) = (core::f64::consts::PI, 1.2246467991473532e-16);

// fdlibm e_acos.c: asin(x) = x + x^3 pS(x^2)/qS(x^2) on |x| <= 1/2.
const PS: [f64; 6] = [
    1.66666666666666657415e-01,
    -3.25565818622400915405e-01,
    2.01212532134862925881e-01,
    -4.00555345006794114027e-02,
    7.91534994289814532176e-04,
    3.47933107596021167570e-05,
];
const QS: [f64; 5] = [
    1.0,
    -2.40339491173441421878e+00,
    2.02094576023350569471e+00,
    -6.88283971605453293030e-01,
    7.70381505559019352791e-02,
];

// ---------------------------------------------------------------- helpers

type L<S, const K: usize> = Lanes<S, K>;

/// Error-free `a + b = s + e` (Knuth's TwoSum, no ordering condition).
#[inline(always)]
fn two_sum<S: Simd, const K: usize>(a: L<S, K>, b: L<S, K>) -> (L<S, K>, L<S, K>) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// `c[0] + c[1] z + c[2] z^2 + ...` (at most 8 coefficients) by Estrin's
/// scheme: pairs `c[2k] + c[2k+1] z`, then pairs of pairs with z^2, ... —
/// a dependency chain of about log2(len) multiply-adds instead of len.
#[inline(always)]
fn poly<S: Simd, const K: usize>(z: L<S, K>, c: &[f64]) -> L<S, K> {
    let mut len = c.len();
    assert!(len > 0 && len <= 8);
    let mut t = [z; 8];
    for k in 0..len.div_ceil(2) {
        t[k] = if 2 * k + 1 < len {
            c[2 * k] + z * c[2 * k + 1]
        } else {
            L::splat(z.simd, c[2 * k])
        };
    }
    len = len.div_ceil(2);
    let mut zk = z;
    while len > 1 {
        zk = zk * zk;
        for k in 0..len.div_ceil(2) {
            t[k] = if 2 * k + 1 < len {
                t[2 * k] + zk * t[2 * k + 1]
            } else {
                t[2 * k]
            };
        }
        len = len.div_ceil(2);
    }
    t[0]
}

// ---------------------------------------------------------------- sqrt

/// Square root of every lane: the hardware instruction (IEEE 754 correctly
/// rounded, error <= 0.5 ulp, bit-identical to `f64::sqrt`, NaN for x < 0).
#[inline(always)]
pub fn sqrt<S: Simd>(simd: S, x: S::f64s) -> S::f64s {
    simd.sqrt_f64s(x)
}

// ---------------------------------------------------------------- sin_cos

/// fdlibm `__kernel_sin(x, y)`: sin(x + y) for |x + y| <= ~pi/4, |y| << |x|.
#[inline(always)]
fn kernel_sin<S: Simd, const K: usize>(x: L<S, K>, y: L<S, K>) -> L<S, K> {
    let z = x * x;
    let v = z * x;
    let r = poly(z, &[S2, S3, S4, S5, S6]);
    // x - ((z (y/2 - v r) - y) - v S1)
    x - ((z * (y * 0.5 - v * r) - y) - v * S1)
}

/// fdlibm `__kernel_cos(x, y)`: cos(x + y) for |x + y| <= ~pi/4, |y| << |x|.
#[inline(always)]
fn kernel_cos<S: Simd, const K: usize>(x: L<S, K>, y: L<S, K>) -> L<S, K> {
    let z = x * x;
    let r = z * poly(z, &[C1, C2, C3, C4, C5, C6]);
    let hz = z * 0.5;
    let w = 1.0 - hz;
    // w + (((1 - w) - hz) + (z r - x y))
    w + (((1.0 - w) - hz) + (z * r - x * y))
}

/// `(sin x, cos x)` of every lane.
///
/// **Error bound:** for |x| <= [`SIN_COS_FAST_MAX`] (2^20) both results are
/// faithfully rounded (error < 1 ulp of the exact value; absolute error
/// < 1.12e-16). Method: q = nearest integer to x 2/pi, the reduced argument
/// x - q pi/2 carried as a double-double from a four-part pi/2 (each of the
/// first three products is exact, so there is no cancellation loss even next
/// to multiples of pi/2), then fdlibm's degree-13/14 minimax kernels with the
/// tail correction. Tests assert every result equal or adjacent to
/// `f64::sin`/`f64::cos` (which, if both are faithful, is implied) on dense
/// and edge samples over |x| <= 2^20; signs of zero are kept (sin(-0) = -0).
///
/// Outside that range: lanes with |x| > 2^20 are recomputed with
/// `f64::sin`/`f64::cos` (slow path, the platform libm's accuracy); +-inf and
/// NaN give NaN in both outputs.
#[inline(always)]
pub fn sin_cos<S: Simd>(simd: S, x: S::f64s) -> (S::f64s, S::f64s) {
    let (s, c) = sin_cos_lanes(L::<S, 1>::new(simd, [x]));
    (s.v[0], c.v[0])
}

/// [`sin_cos`] on `K` vectors in lockstep.
#[inline(always)]
pub fn sin_cos_lanes<S: Simd, const K: usize>(x: L<S, K>) -> (L<S, K>, L<S, K>) {
    let far = x.abs().gt_c(SIN_COS_FAST_MAX);
    if far.any() {
        return sin_cos_far(x, far);
    }
    sin_cos_near(x)
}

/// [`sin_cos_lanes`] without the range check (garbage for |x| > 2^20).
#[inline(always)]
fn sin_cos_near<S: Simd, const K: usize>(x: L<S, K>) -> (L<S, K>, L<S, K>) {
    let t = x * TWO_OVER_PI + MAGIC;
    let q = t - MAGIC;
    // r1 = x - q P1 is exact; then subtract q P2 (exact product) with TwoSum,
    // and fold q P3 (exact) + q P3t (rounded, ~1e-31 q) into the tail.
    let r1 = x - q * PIO2_1;
    let (a, ea) = two_sum(r1, -(q * PIO2_2));
    let tail = (ea - q * PIO2_3) - q * PIO2_3T;
    let (y0, y1) = two_sum(a, tail);
    let s = kernel_sin(y0, y1);
    let c = kernel_cos(y0, y1);
    // quadrant q mod 4 (the low bits of t): (s, c), (c, -s), (-s, -c), (-c, s)
    let odd = t.any_bits(1);
    let neg_sin = t.any_bits(2);
    let neg_cos = neg_sin ^ odd;
    let sin = odd.select(c, s).negate_where(neg_sin);
    let cos = odd.select(s, c).negate_where(neg_cos);
    // the double-double sum turns -0 into +0: sin(+-0) = +-0
    (x.eq_c(0.0).select(x, sin), cos)
}

/// Slow path of [`sin_cos_lanes`]: libm for the lanes in `far`.
#[cold]
#[inline(never)]
fn sin_cos_far<S: Simd, const K: usize>(x: L<S, K>, far: Mask<S, K>) -> (L<S, K>, L<S, K>) {
    let (sin, cos) = sin_cos_near(x);
    let (mut s_far, mut c_far) = (x, x);
    for k in 0..K {
        let xs = pulp::bytemuck::cast_slice::<S::f64s, f64>(core::slice::from_ref(&x.v[k]));
        let ss =
            pulp::bytemuck::cast_slice_mut::<S::f64s, f64>(core::slice::from_mut(&mut s_far.v[k]));
        let cs =
            pulp::bytemuck::cast_slice_mut::<S::f64s, f64>(core::slice::from_mut(&mut c_far.v[k]));
        for ((xi, si), ci) in xs.iter().zip(ss.iter_mut()).zip(cs.iter_mut()) {
            (*si, *ci) = xi.sin_cos();
        }
    }
    (far.select(s_far, sin), far.select(c_far, cos))
}

// ---------------------------------------------------------------- atan2

/// Four-quadrant arctangent of `y / x` of every lane, in [-pi, pi], with
/// the IEEE / C99 special cases of `f64::atan2` (signed zeros: atan2(+-0, +0)
/// = +-0, atan2(+-0, -0) = +-pi; infinities: atan2(+-inf, +-inf) = +-pi/4 or
/// +-3pi/4, ...; NaN in either argument gives NaN).
///
/// **Error bound:** within 1 ulp of the exact value for all finite and
/// infinite arguments (including subnormal and near-overflow ones), so
/// absolute error <= 4.5e-16. Method: one division giving a reduced
/// argument |u| < 7/16 by fdlibm's breakpoints (t = min/max in [0, 7/16),
/// [7/16, 11/16), [11/16, 1] -> u = t, (2t - 1)/(2 + t), (t - 1)/(t + 1),
/// each formed from the operands so the numerator is exact), fdlibm's
/// degree-22 minimax atan, and the quadrant/breakpoint offset added as a
/// double-double. Tests assert results equal or adjacent to `f64::atan2` on
/// dense samples (angles on circles of radius 1e-5..1e5, uniform squares,
/// tiny/huge/subnormal pairs) and bit-equality on the special cases.
#[inline(always)]
pub fn atan2<S: Simd>(simd: S, y: S::f64s, x: S::f64s) -> S::f64s {
    atan2_lanes(L::<S, 1>::new(simd, [y]), L::new(simd, [x])).v[0]
}

/// [`atan2`] on `K` vectors in lockstep.
#[inline(always)]
pub fn atan2_lanes<S: Simd, const K: usize>(y: L<S, K>, x: L<S, K>) -> L<S, K> {
    let simd = x.simd;
    let ax = x.abs();
    let ay = y.abs();
    let swap = ay.gt(ax);
    let mut n = swap.select(ax, ay);
    let mut d = swap.select(ay, ax);
    // keep 2d + n finite: scale near-overflow pairs by 2^-4 (exact for d)
    let huge = d.gt_c(f64::from_bits(0x7E70000000000000));
    let scale = huge.select(L::splat(simd, 0.0625), L::splat(simd, 1.0));
    n = n * scale;
    d = d * scale;
    let one = L::splat(simd, 1.0);
    let both_inf = n.eq_c(f64::INFINITY) & d.eq_c(f64::INFINITY);
    n = both_inf.select(one, n);
    d = both_inf.select(one, d);
    d = d.eq_c(0.0).select(one, d);
    // t = n/d in [0, 1]; three ranges
    let r2 = n.ge(d * 0.6875);
    let r1 = n.ge(d * 0.4375);
    let num = r2.select(n - d, r1.select((n + n) - d, n));
    let den = r2.select(n + d, r1.select((d + d) + n, d));
    let u = num / den;
    // angle = Q + s (R + atan(u)): quadrant angle Q and sign s by (x < 0,
    // swap) — (0, +), (pi/2, -), (pi, -), (pi/2, +) — and breakpoint angle R
    // by range — 0, atan(1/2), pi/4
    let neg = x.sign_bit();
    let minus = neg ^ swap;
    let zero = L::splat(simd, 0.0);
    let pair = |p: (f64, f64)| (L::splat(simd, p.0), L::splat(simd, p.1));
    let q = swap.select2(pair(PIO2), neg.select2(pair(PI), (zero, zero)));
    let r = r2.select2(pair(PIO4), r1.select2(pair(ATAN_HALF), (zero, zero)));
    // hi exact (see PIO4), lo rounded (error ~1e-26)
    let hi = q.0 + r.0.negate_where(minus);
    let lo = q.1 + r.1.negate_where(minus);
    let su = u.negate_where(minus);
    // atan(su) = su - su (z P_even(w) + w P_odd(w)), z = su^2, w = z^2
    let z = su * su;
    let w = z * z;
    let p = z * poly(w, &AT_EVEN) + w * poly(w, &AT_ODD);
    // hi + lo + atan(su) = hi - ((su p - lo) - su)
    let a = hi - ((su * p - lo) - su);
    // a >= 0 (or NaN): give it y's sign
    a.or_bits(y.and_bits(1 << 63))
}

// ---------------------------------------------------------------- acos

/// Arccosine of every lane, in [0, pi].
///
/// **Error bound:** within 1 ulp of the exact value on [-1, 1] (absolute
/// error <= 4.5e-16); acos(+-0) = pi/2 rounded, acos(1) = +0, acos(-1) = pi
/// rounded. |x| > 1, +-inf and NaN give NaN. Method: fdlibm's e_acos.c
/// (rational minimax of asin on [0, 1/2]; for |x| >= 1/2 the half-angle form
/// 2 asin(sqrt((1 - |x|)/2)) with a split square root), both branches
/// computed and selected per lane. Tests assert results equal or adjacent to
/// `f64::acos` on dense samples of [-1, 1], samples crowding both ends
/// (1 - e^-40 .. 1 - e^-0), and the edge values.
#[inline(always)]
pub fn acos<S: Simd>(simd: S, x: S::f64s) -> S::f64s {
    acos_lanes(L::<S, 1>::new(simd, [x])).v[0]
}

/// [`acos`] on `K` vectors in lockstep.
#[inline(always)]
pub fn acos_lanes<S: Simd, const K: usize>(x: L<S, K>) -> L<S, K> {
    let ax = x.abs();
    let small = ax.lt_c(0.5);
    let z = small.select(x * x, (1.0 - ax) * 0.5);
    let r = (z * poly(z, &PS)) / poly(z, &QS);
    // |x| < 1/2: pi/2 - (x - (pio2_lo - x r))
    let small_res = PIO2.0 - (x - (PIO2.1 - x * r));
    let s = z.sqrt();
    // x <= -1/2: pi - 2 (s + (r s - pio2_lo))
    let neg_res = PI.0 - 2.0 * (s + (r * s - PIO2.1));
    // x >= 1/2: 2 (df + (r s + c)), df = s with its low 32 bits cleared,
    // c = (z - df^2) / (s + df) (0 when s = 0)
    let df = s.and_bits(0xFFFF_FFFF_0000_0000);
    let sd = s + df;
    let sd = sd.eq_c(0.0).select(L::splat(x.simd, 1.0), sd);
    let c = (z - df * df) / sd;
    let pos_res = 2.0 * (df + (r * s + c));
    small.select(small_res, x.lt_c(0.0).select(neg_res, pos_res))
}

// ---------------------------------------------------------------- slices

/// Applies a lane function to the inputs one vector at a time; the last,
/// partial vector is padded with its first value and only its lanes stored.
#[inline(always)]
fn map_lanes<S: Simd, F: LaneFn<I, O>, const I: usize, const O: usize>(
    simd: S,
    inputs: [&[f64]; I],
    outputs: [&mut [f64]; O],
    f: &F,
) {
    let len = inputs[0].len();
    assert!(inputs.iter().all(|v| v.len() == len) && outputs.iter().all(|v| v.len() == len));
    let w = S::F64_LANES;
    let full = len / w * w;
    let heads: [&[S::f64s]; I] = core::array::from_fn(|i| S::as_simd_f64s(&inputs[i][..full]).0);
    let mut split = outputs.map(|o| {
        let (h, t) = o.split_at_mut(full);
        (S::as_mut_simd_f64s(h).0, t)
    });
    for v in 0..full / w {
        let mut xs = [simd.splat_f64s(0.0); I];
        for (x, h) in xs.iter_mut().zip(heads) {
            *x = h[v];
        }
        let ys = f.apply(simd, xs);
        for ((o, _), y) in split.iter_mut().zip(ys) {
            o[v] = y;
        }
    }
    if full < len {
        let m = len - full;
        let mut xs = [simd.splat_f64s(0.0); I];
        for (v, x) in xs.iter_mut().zip(inputs) {
            *v = simd.splat_f64s(x[full]);
            let lanes = pulp::bytemuck::cast_slice_mut::<S::f64s, f64>(core::slice::from_mut(v));
            lanes[..m].copy_from_slice(&x[full..]);
        }
        let ys = f.apply(simd, xs);
        for ((_, o), y) in split.iter_mut().zip(ys.iter()) {
            let lanes = pulp::bytemuck::cast_slice::<S::f64s, f64>(core::slice::from_ref(y));
            o.copy_from_slice(&lanes[..m]);
        }
    }
}

struct MapOp<'a, F, const I: usize, const O: usize> {
    inputs: [&'a [f64]; I],
    outputs: [&'a mut [f64]; O],
    f: F,
}

/// A lane function of `I` inputs and `O` outputs, generic over the SIMD type.
trait LaneFn<const I: usize, const O: usize> {
    fn apply<S: Simd>(&self, simd: S, x: [S::f64s; I]) -> [S::f64s; O];
}

impl<F: LaneFn<I, O>, const I: usize, const O: usize> WithSimd for MapOp<'_, F, I, O> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        map_lanes(simd, self.inputs, self.outputs, &self.f);
    }
}

struct SinCosFn;
impl LaneFn<1, 2> for SinCosFn {
    #[inline(always)]
    fn apply<S: Simd>(&self, simd: S, x: [S::f64s; 1]) -> [S::f64s; 2] {
        let (s, c) = sin_cos(simd, x[0]);
        [s, c]
    }
}
struct Atan2Fn;
impl LaneFn<2, 1> for Atan2Fn {
    #[inline(always)]
    fn apply<S: Simd>(&self, simd: S, x: [S::f64s; 2]) -> [S::f64s; 1] {
        [atan2(simd, x[0], x[1])]
    }
}
#[cfg(test)]
struct AcosFn;
#[cfg(test)]
impl LaneFn<1, 1> for AcosFn {
    #[inline(always)]
    fn apply<S: Simd>(&self, simd: S, x: [S::f64s; 1]) -> [S::f64s; 1] {
        [acos(simd, x[0])]
    }
}
#[cfg(test)]
struct SqrtFn;
#[cfg(test)]
impl LaneFn<1, 1> for SqrtFn {
    #[inline(always)]
    fn apply<S: Simd>(&self, simd: S, x: [S::f64s; 1]) -> [S::f64s; 1] {
        [sqrt(simd, x[0])]
    }
}

fn run<F: LaneFn<I, O>, const I: usize, const O: usize>(
    arch: pulp::Arch,
    inputs: [&[f64]; I],
    outputs: [&mut [f64]; O],
    f: F,
) {
    arch.dispatch(MapOp { inputs, outputs, f });
}

/// `sin`/`cos` of every element of `x` (see [`sin_cos`] for the bound), with
/// run-time dispatch. Panics if the lengths differ.
pub fn sin_cos_slice(x: &[f64], sin: &mut [f64], cos: &mut [f64]) {
    run(pulp::Arch::new(), [x], [sin, cos], SinCosFn);
}

/// `(cos, sin)` of every element of `x` into `cs`, without SIMD dispatch:
/// the [`sin_cos`] kernel on plain `f64`s, four elements in lockstep (four
/// independent dependency chains), so a short vector of joint angles costs
/// about one call's latency. Same bits as [`sin_cos`] lane by lane (same
/// error bound). Panics if the lengths differ.
#[inline(always)]
pub fn cos_sin_short(x: &[f64], cs: &mut [(f64, f64)]) {
    assert_eq!(x.len(), cs.len(), "cos_sin_short: lengths differ");
    for (xc, cc) in x.chunks(4).zip(cs.chunks_mut(4)) {
        let mut v = [0.0; 4];
        v[..xc.len()].copy_from_slice(xc);
        let (s, c) = sin_cos_quick(v);
        for (k, o) in cc.iter_mut().enumerate() {
            *o = (c[k], s[k]);
        }
    }
}

/// `(sin, cos)` of `K` values by [`sin_cos_lanes`] on scalars, without the
/// range reduction when every value lies in quadrant 0 (|x| < pi/4: the
/// reduction gives y0 = x, y1 = 0 there, so the same bits): joint angles
/// mostly do.
#[inline(always)]
pub fn sin_cos_quick<const K: usize>(v: [f64; K]) -> ([f64; K], [f64; K]) {
    let simd = pulp::Scalar::new();
    let x = L::<pulp::Scalar, K>::new(simd, v);
    let (s, c) = if v.iter().all(|t| t.abs() < core::f64::consts::FRAC_PI_4) {
        let zero = L::splat(simd, 0.0);
        let s = kernel_sin(x, zero);
        (x.eq_c(0.0).select(x, s), kernel_cos(x, zero))
    } else {
        sin_cos_lanes(x)
    };
    (s.v, c.v)
}

/// `atan2(y, x)` of every pair (see [`atan2`]), with run-time dispatch.
pub fn atan2_slice(y: &[f64], x: &[f64], out: &mut [f64]) {
    run(pulp::Arch::new(), [y, x], [out], Atan2Fn);
}

/// `acos` of every element (see [`acos`]), with run-time dispatch.
#[cfg(test)]
pub fn acos_slice(x: &[f64], out: &mut [f64]) {
    run(pulp::Arch::new(), [x], [out], AcosFn);
}

/// `sqrt` of every element (see [`sqrt`]), with run-time dispatch.
#[cfg(test)]
pub fn sqrt_slice(x: &[f64], out: &mut [f64]) {
    run(pulp::Arch::new(), [x], [out], SqrtFn);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both dispatch paths the slice functions can take: the best available
    /// instruction set, and pulp's one-lane scalar fallback.
    fn paths() -> [pulp::Arch; 2] {
        [pulp::Arch::new(), pulp::Arch::Scalar]
    }

    /// Distance in ulps of `got` from `want` (ulp of `want`); 0 for equal
    /// values of the same sign, infinite for a sign or NaN mismatch.
    fn ulps(got: f64, want: f64) -> f64 {
        if got.is_nan() || want.is_nan() {
            return if got.is_nan() && want.is_nan() {
                0.0
            } else {
                f64::INFINITY
            };
        }
        if got == want {
            return if got.is_sign_negative() == want.is_sign_negative() {
                0.0
            } else {
                f64::INFINITY
            };
        }
        let a = want.abs();
        let ulp = if a == f64::MAX {
            a - a.next_down()
        } else {
            a.next_up() - a
        };
        (got - want).abs() / ulp
    }

    /// Deterministic uniform samples in [lo, hi) (SplitMix64).
    fn uniform(seed: u64, count: usize, lo: f64, hi: f64) -> Vec<f64> {
        let mut s = seed;
        (0..count)
            .map(|_| {
                s = s.wrapping_add(0x9E3779B97F4A7C15);
                let mut z = s;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
                z ^= z >> 31;
                lo + (hi - lo) * ((z >> 11) as f64 / (1u64 << 53) as f64)
            })
            .collect()
    }

    fn sin_cos_points() -> Vec<f64> {
        let mut x = uniform(1, 100_000, -1e4, 1e4);
        x.extend(uniform(2, 100_000, -4.0, 4.0));
        x.extend(uniform(3, 20_000, -SIN_COS_FAST_MAX, SIN_COS_FAST_MAX));
        // the doubles nearest to and next to multiples of pi/2 (worst cancellation)
        for k in -6400i32..=6400 {
            let m = k as f64 * std::f64::consts::FRAC_PI_2;
            x.extend([m, m.next_up(), m.next_down()]);
        }
        let pi = std::f64::consts::PI;
        x.extend([
            0.0,
            -0.0,
            pi,
            -pi,
            pi / 2.0,
            -pi / 2.0,
            pi / 4.0,
            -pi / 4.0,
            1e-300,
            -1e-300,
            5e-324,
            1e-8,
            1e4,
            -1e4,
            SIN_COS_FAST_MAX,
            -SIN_COS_FAST_MAX,
            355.0,
            103993.0,
        ]);
        x
    }

    #[test]
    fn short_cos_sin_has_the_bits_of_the_vector_kernel() {
        // short vectors (the joint angles of a solve) mixing the unreduced
        // quadrant-0 path with the reduced one, edges at pi/4 and signed zeros
        let q = std::f64::consts::FRAC_PI_4;
        let mut x = sin_cos_points();
        x.extend(uniform(7, 40_000, -0.8, 0.8));
        x.extend([
            0.0,
            -0.0,
            q,
            -q,
            q.next_down(),
            (-q).next_up(),
            q.next_up(),
            1e-300,
            -5e-324,
        ]);
        let (mut s, mut c) = (vec![0.0; x.len()], vec![0.0; x.len()]);
        sin_cos_slice(&x, &mut s, &mut c);
        let mut start = 0;
        let mut len = 1;
        while start < x.len() {
            let end = (start + len).min(x.len());
            let mut cs = vec![(0.0, 0.0); end - start];
            cos_sin_short(&x[start..end], &mut cs);
            for (k, (co, si)) in cs.iter().enumerate() {
                let i = start + k;
                assert_eq!(si.to_bits(), s[i].to_bits(), "sin({:e})", x[i]);
                assert_eq!(co.to_bits(), c[i].to_bits(), "cos({:e})", x[i]);
            }
            start = end;
            len = len % 9 + 1;
        }
    }

    #[test]
    fn simd_sin_cos_within_1_ulp_of_libm() {
        let x = sin_cos_points();
        for arch in paths() {
            let (mut s, mut c) = (vec![0.0; x.len()], vec![0.0; x.len()]);
            run(arch, [&x], [&mut s, &mut c], SinCosFn);
            let mut worst = (0.0f64, 0.0f64);
            for i in 0..x.len() {
                let (es, ec) = (ulps(s[i], x[i].sin()), ulps(c[i], x[i].cos()));
                assert!(
                    es <= 1.0,
                    "sin({:e}) = {:e}, libm {:e}",
                    x[i],
                    s[i],
                    x[i].sin()
                );
                assert!(
                    ec <= 1.0,
                    "cos({:e}) = {:e}, libm {:e}",
                    x[i],
                    c[i],
                    x[i].cos()
                );
                assert!((s[i] - x[i].sin()).abs() < 1.12e-16);
                assert!((c[i] - x[i].cos()).abs() < 1.12e-16);
                worst = (worst.0.max(es), worst.1.max(ec));
            }
            eprintln!(
                "sin_cos {}: worst {worst:?} ulp over {}",
                super::super::instruction_set_of(arch),
                x.len()
            );
        }
    }

    #[test]
    fn simd_sin_cos_edges() {
        for arch in paths() {
            let x = [
                0.0,
                -0.0,
                f64::NAN,
                f64::INFINITY,
                f64::NEG_INFINITY,
                1e7,
                -3e9,
                1e300,
                2.0,
            ];
            let (mut s, mut c) = ([0.0; 9], [0.0; 9]);
            run(arch, [&x], [&mut s, &mut c], SinCosFn);
            assert_eq!(s[0].to_bits(), 0.0f64.to_bits());
            assert_eq!(s[1].to_bits(), (-0.0f64).to_bits());
            assert_eq!((c[0], c[1]), (1.0, 1.0));
            for i in 2..5 {
                assert!(s[i].is_nan() && c[i].is_nan(), "{}", x[i]);
            }
            // beyond 2^20: libm per lane, bit for bit
            for i in 5..8 {
                assert_eq!(s[i].to_bits(), x[i].sin().to_bits());
                assert_eq!(c[i].to_bits(), x[i].cos().to_bits());
            }
            assert!(ulps(s[8], 2.0f64.sin()) <= 1.0 && ulps(c[8], 2.0f64.cos()) <= 1.0);
        }
    }

    fn atan2_points() -> Vec<(f64, f64)> {
        let t = uniform(4, 200_000, -std::f64::consts::PI, std::f64::consts::PI);
        let r = uniform(5, 200_000, -11.5, 11.5);
        let mut p: Vec<(f64, f64)> = t
            .iter()
            .zip(&r)
            .map(|(t, r)| (r.exp() * t.sin(), r.exp() * t.cos()))
            .collect();
        let a = uniform(6, 100_000, -1.0, 1.0);
        let b = uniform(7, 100_000, -1.0, 1.0);
        p.extend(a.iter().zip(&b).map(|(a, b)| (*a, *b)));
        // near the breakpoints 7/16, 11/16, 1 of the reduction, both orders
        for (i, v) in uniform(8, 30_000, -1e-6, 1e-6).iter().enumerate() {
            let bp = [0.4375, 0.6875, 1.0][i % 3] + v;
            p.extend([(bp, 1.0), (1.0, -bp), (-bp, -1.0)]);
        }
        // tiny, huge, subnormal and near-overflow magnitudes
        let mags = [
            5e-324,
            1e-310,
            1e-300,
            1e-200,
            1e-20,
            1.0,
            3.0,
            1e20,
            1e200,
            1e300,
            1e308,
            1.7e308,
            f64::MAX,
        ];
        for &m in &mags {
            for &k in &mags {
                for (sy, sx) in [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)] {
                    p.push((sy * m, sx * k));
                    p.push((sy * m, sx * k * 0.77));
                }
            }
        }
        p
    }

    #[test]
    fn simd_atan2_within_1_ulp_of_libm() {
        let p = atan2_points();
        let y: Vec<f64> = p.iter().map(|v| v.0).collect();
        let x: Vec<f64> = p.iter().map(|v| v.1).collect();
        for arch in paths() {
            let mut a = vec![0.0; p.len()];
            run(arch, [&y, &x], [&mut a], Atan2Fn);
            let mut worst = 0.0f64;
            for i in 0..p.len() {
                let want = y[i].atan2(x[i]);
                let e = ulps(a[i], want);
                assert!(
                    e <= 1.0,
                    "atan2({:e}, {:e}) = {:e}, libm {:e}",
                    y[i],
                    x[i],
                    a[i],
                    want
                );
                assert!((a[i] - want).abs() <= 4.5e-16);
                worst = worst.max(e);
            }
            eprintln!(
                "atan2 {}: worst {worst} ulp over {}",
                super::super::instruction_set_of(arch),
                p.len()
            );
        }
    }

    #[test]
    fn simd_atan2_special_cases_match_libm_bitwise() {
        let v = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            1e-320,
            -1e-320,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        let (mut y, mut x) = (vec![], vec![]);
        for a in v {
            for b in v {
                y.push(a);
                x.push(b);
            }
        }
        for arch in paths() {
            let mut out = vec![0.0; y.len()];
            run(arch, [&y, &x], [&mut out], Atan2Fn);
            for i in 0..y.len() {
                let want = y[i].atan2(x[i]);
                if want.is_nan() {
                    assert!(out[i].is_nan(), "atan2({}, {})", y[i], x[i]);
                } else if [0.0, 1.0, 1e300, f64::INFINITY].contains(&y[i].abs())
                    && [0.0, 1.0, 1e300, f64::INFINITY].contains(&x[i].abs())
                    && (y[i] == 0.0
                        || x[i] == 0.0
                        || y[i].is_infinite()
                        || x[i].is_infinite()
                        || y[i].abs() == x[i].abs())
                {
                    // exact cases (0, +-pi/4, +-pi/2, +-3pi/4, +-pi, signed zeros)
                    assert_eq!(
                        out[i].to_bits(),
                        want.to_bits(),
                        "atan2({}, {}) = {} want {}",
                        y[i],
                        x[i],
                        out[i],
                        want
                    );
                } else {
                    assert!(ulps(out[i], want) <= 1.0, "atan2({}, {})", y[i], x[i]);
                }
            }
        }
    }

    #[test]
    fn simd_acos_within_1_ulp_of_libm() {
        let mut x = uniform(9, 300_000, -1.0, 1.0);
        for e in uniform(10, 50_000, -40.0, 0.0) {
            x.push(1.0 - e.exp());
            x.push(-1.0 + e.exp());
        }
        x.extend([
            0.0,
            -0.0,
            1.0,
            -1.0,
            0.5,
            -0.5,
            0.5f64.next_down(),
            (-0.5f64).next_up(),
            1.0f64.next_down(),
            (-1.0f64).next_up(),
            1e-300,
            -1e-300,
            5e-324,
            1e-9,
        ]);
        for arch in paths() {
            let mut a = vec![0.0; x.len()];
            run(arch, [&x], [&mut a], AcosFn);
            let mut worst = 0.0f64;
            for i in 0..x.len() {
                let want = x[i].acos();
                let e = ulps(a[i], want);
                assert!(e <= 1.0, "acos({:e}) = {:e}, libm {:e}", x[i], a[i], want);
                assert!((a[i] - want).abs() <= 4.5e-16);
                worst = worst.max(e);
            }
            eprintln!(
                "acos {}: worst {worst} ulp over {}",
                super::super::instruction_set_of(arch),
                x.len()
            );
        }
    }

    #[test]
    fn simd_acos_edges() {
        for arch in paths() {
            let x = [
                1.0,
                -1.0,
                0.0,
                -0.0,
                1.0f64.next_up(),
                -1.5,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NAN,
            ];
            let mut a = [0.0; 9];
            run(arch, [&x], [&mut a], AcosFn);
            assert_eq!(a[0].to_bits(), 0.0f64.to_bits());
            assert_eq!(a[1], std::f64::consts::PI);
            assert_eq!(a[2], std::f64::consts::FRAC_PI_2);
            assert_eq!(a[3], std::f64::consts::FRAC_PI_2);
            for v in &a[4..] {
                assert!(v.is_nan());
            }
        }
    }

    #[test]
    fn simd_sqrt_is_correctly_rounded() {
        let mut x = uniform(11, 10_000, 0.0, 1e3);
        x.extend([
            0.0,
            -0.0,
            5e-324,
            f64::MAX,
            f64::INFINITY,
            2.0,
            -1.0,
            f64::NAN,
        ]);
        for arch in paths() {
            let mut a = vec![0.0; x.len()];
            run(arch, [&x], [&mut a], SqrtFn);
            for i in 0..x.len() {
                let want = x[i].sqrt();
                assert!(a[i].to_bits() == want.to_bits() || (a[i].is_nan() && want.is_nan()));
            }
        }
    }

    #[test]
    fn simd_math_is_bit_identical_across_instruction_sets() {
        // no fused multiply-add: the dispatched SIMD path and the scalar
        // fallback give the same bits
        let x = sin_cos_points();
        let p = atan2_points();
        let y: Vec<f64> = p.iter().map(|v| v.0).collect();
        let xx: Vec<f64> = p.iter().map(|v| v.1).collect();
        let u = uniform(12, 50_000, -1.0, 1.0);
        let mut out: Vec<[Vec<f64>; 4]> = vec![];
        for arch in paths() {
            let (mut s, mut c, mut a, mut q) = (
                vec![0.0; x.len()],
                vec![0.0; x.len()],
                vec![0.0; y.len()],
                vec![0.0; u.len()],
            );
            run(arch, [&x], [&mut s, &mut c], SinCosFn);
            run(arch, [&y, &xx], [&mut a], Atan2Fn);
            run(arch, [&u], [&mut q], AcosFn);
            out.push([s, c, a, q]);
        }
        for (fast, scalar) in out[0].iter().zip(&out[1]) {
            for (a, b) in fast.iter().zip(scalar) {
                assert!(a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()));
            }
        }
    }

    /// sin_cos, atan2, acos on 3 vectors in lockstep, per lane.
    struct Lockstep3<'a> {
        x: &'a [f64],
        y: &'a [f64],
        out: &'a mut [[f64; 4]],
    }
    impl WithSimd for Lockstep3<'_> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: Simd>(self, simd: S) {
            let w = S::F64_LANES;
            let load = |v: &[f64], at: usize| {
                let mut r = simd.splat_f64s(0.0);
                let lanes =
                    pulp::bytemuck::cast_slice_mut::<S::f64s, f64>(core::slice::from_mut(&mut r));
                lanes.copy_from_slice(&v[at..at + w]);
                r
            };
            for start in (0..self.x.len() / (3 * w)).map(|b| b * 3 * w) {
                let x = Lanes::<S, 3>::new(
                    simd,
                    [
                        load(self.x, start),
                        load(self.x, start + w),
                        load(self.x, start + 2 * w),
                    ],
                );
                let y = Lanes::<S, 3>::new(
                    simd,
                    [
                        load(self.y, start),
                        load(self.y, start + w),
                        load(self.y, start + 2 * w),
                    ],
                );
                let (s, c) = sin_cos_lanes(x);
                let a = atan2_lanes(y, x);
                let q = acos_lanes(y);
                for (k, r) in [s, c, a, q].iter().enumerate() {
                    let lanes = pulp::bytemuck::cast_slice::<S::f64s, f64>(&r.v);
                    for (i, v) in lanes.iter().enumerate() {
                        self.out[start + i][k] = *v;
                    }
                }
            }
        }
    }

    #[test]
    fn simd_lockstep_lanes_match_single_vectors() {
        let mut x = uniform(13, 3 * 8 * 500, -10.0, 10.0);
        x[5] = 3e6; // one lane on the libm path
        let y = uniform(14, x.len(), -1.0, 1.0);
        for arch in paths() {
            let mut out = vec![[0.0; 4]; x.len()];
            arch.dispatch(Lockstep3 {
                x: &x,
                y: &y,
                out: &mut out,
            });
            let (mut s, mut c, mut a, mut q) = (
                vec![0.0; x.len()],
                vec![0.0; x.len()],
                vec![0.0; x.len()],
                vec![0.0; x.len()],
            );
            run(arch, [&x], [&mut s, &mut c], SinCosFn);
            run(arch, [&y, &x], [&mut a], Atan2Fn);
            run(arch, [&y], [&mut q], AcosFn);
            for i in 0..x.len() {
                assert_eq!(
                    out[i].map(f64::to_bits),
                    [s[i], c[i], a[i], q[i]].map(f64::to_bits),
                    "{i}"
                );
            }
        }
    }

    #[test]
    fn simd_slice_functions_handle_tails() {
        // every length 0..13 (several lane counts and tails) against the lane code
        for len in 0..13 {
            let x: Vec<f64> = (0..len).map(|i| 0.3 * i as f64 - 1.0).collect();
            let y: Vec<f64> = (0..len).map(|i| 1.0 - 0.17 * i as f64).collect();
            let (mut s, mut c, mut a, mut q, mut r) = (
                vec![9.0; len],
                vec![9.0; len],
                vec![9.0; len],
                vec![9.0; len],
                vec![9.0; len],
            );
            sin_cos_slice(&x, &mut s, &mut c);
            atan2_slice(&y, &x, &mut a);
            acos_slice(&y, &mut q);
            sqrt_slice(&y, &mut r);
            for i in 0..len {
                assert!(ulps(s[i], x[i].sin()) <= 1.0 && ulps(c[i], x[i].cos()) <= 1.0);
                assert!(ulps(a[i], y[i].atan2(x[i])) <= 1.0);
                assert!(ulps(q[i], y[i].acos()) <= 1.0 || (q[i].is_nan() && y[i].abs() > 1.0));
                assert!(r[i].to_bits() == y[i].sqrt().to_bits() || (r[i].is_nan() && y[i] < 0.0));
            }
        }
    }
}
