//! Closed-form cable solve over SIMD lanes: one configuration (row) per lane,
//! all lanes sharing one [`CableGeometry`].
//!
//! [`closed_form_lanes`] is [`crate::solve::closed_form_cs`] on `W` lanes
//! (structure of arrays, joint-major: `target[i]` holds joint `i` of every
//! lane). It performs the scalar code's floating-point operations in the
//! same order and without fused multiply-adds, so on lanes with a real
//! solution its `(cos, sin)`, residual and branch choice are bit-identical to
//! the scalar function's given the same seed `(cos, sin)`.
//!
//! [`solve_cables_closed_form_batch`] is [`crate::solve::solve_cables_closed_form`]
//! over row-major batches, seeds given as angles: the seed's cos/sin come from
//! [`crate::simd::math::sin_cos`] and the angle from [`crate::simd::math::atan2`] (each
//! within 1 ulp of libm), so its angles agree with the scalar path to a few
//! 1e-16 rad (the branch can differ from the scalar one only when the seed is
//! within ~1e-16 of equidistant from both branches).

use crate::cables::CableGeometry;
use crate::simd::lanes::{Lanes, Mask};
use crate::simd::math::{atan2_lanes, sin_cos_lanes};
use pulp::{Simd, WithSimd};

/// Segment `seg = [P, Q, R]`: `sqrt(max(P + Q cos + R sin, 0))`, the scalar
/// [`CableGeometry::segment`] order of operations.
#[inline(always)]
fn segment<S: Simd, const U: usize>(seg: [f64; 3], c: Lanes<S, U>, s: Lanes<S, U>) -> Lanes<S, U> {
    let [p, q, r] = seg;
    // max(v, 0) returns 0 for a NaN v, as f64::max does
    ((p + c * q) + s * r).max(Lanes::splat(c.simd, 0.0)).sqrt()
}

/// Closed-form cable solve on the `W = S::F64_LANES` lanes of `simd`.
///
/// Inputs, each a slice of `geom.n` vectors (joint `i` of every lane at
/// index `i`): `target` the upper-cable lengths (m), `seed_cos`/`seed_sin`
/// the seed angles' cos/sin. Outputs: `cos`/`sin` (`geom.n` vectors) the
/// answer's; the return value is `(residual, ok)`: per lane the residual
/// max over cables |segment(c, i, cs_i) − s| (m, as the scalar code computes
/// it) and whether every joint had a real solution.
///
/// Per joint the branch with the largest cos(t − seed) is taken, the `+`
/// branch on a tie, exactly as [`crate::solve::closed_form_cs`]. On lanes
/// with `ok` set, `cos`, `sin` and `residual` are bit-identical to that
/// function's (same seed cos/sin). On the other lanes (the scalar function
/// returns `None`) `cos`/`sin` are the seed's and `residual` is +inf.
///
/// Panics if a slice is shorter than `geom.n`. See [`closed_form_lanes_x`]
/// for several vectors at once (hides the joint-to-joint latency).
#[inline(always)]
pub fn closed_form_lanes<S: Simd>(
    simd: S,
    geom: &CableGeometry,
    target: &[S::f64s],
    seed_cos: &[S::f64s],
    seed_sin: &[S::f64s],
    cos: &mut [S::f64s],
    sin: &mut [S::f64s],
) -> (S::f64s, S::m64s) {
    use pulp::bytemuck::{cast_slice, cast_slice_mut};
    let (residual, ok) = closed_form_lanes_x::<S, 1>(
        simd,
        geom,
        cast_slice(target),
        cast_slice(seed_cos),
        cast_slice(seed_sin),
        cast_slice_mut(cos),
        cast_slice_mut(sin),
    );
    (residual[0], ok[0])
}

/// [`closed_form_lanes`] on `U` independent vectors per joint (`U * W`
/// configurations): `target[i][u]` is joint `i` of vector `u`. Same
/// semantics lane by lane; the `U` dependency chains (each joint waits for
/// the square roots of the joints before it) are interleaved, so the
/// out-of-order core overlaps them.
#[inline(always)]
pub fn closed_form_lanes_x<S: Simd, const U: usize>(
    simd: S,
    geom: &CableGeometry,
    target: &[[S::f64s; U]],
    seed_cos: &[[S::f64s; U]],
    seed_sin: &[[S::f64s; U]],
    cos: &mut [[S::f64s; U]],
    sin: &mut [[S::f64s; U]],
) -> ([S::f64s; U], [S::m64s; U]) {
    let n = geom.n;
    let (target, seed_cos, seed_sin) = (&target[..n], &seed_cos[..n], &seed_sin[..n]);
    let (cos, sin) = (&mut cos[..n], &mut sin[..n]);
    let l = |v: [S::f64s; U]| Lanes::new(simd, v);
    let zero = Lanes::splat(simd, 0.0);
    let mut ok = Mask::<S, U>::all_set(simd);
    let mut residual = zero;
    for i in 0..n {
        let c = 2 * i;
        let row = c * n;
        // length left for segment i: the target minus the traversals and
        // the segments of the joints already solved
        let mut s = l(target[i]) - geom.traverse[c];
        for k in 0..i {
            s = s - segment(geom.seg[row + k], l(cos[k]), l(sin[k]));
        }
        // CableGeometry::joint_solution
        let p = geom.seg[row + i][0];
        let [_, amp, cos_mid, sin_mid] = geom.phase[row + i];
        let arg = (s * s - p) / amp;
        // no solution for any lane when the segment does not depend on the angle
        ok = if amp == 0.0 {
            !Mask::all_set(simd)
        } else {
            ok & s.ge_c(0.0) & arg.ge_c(-1.0) & arg.le_c(1.0)
        };
        let sin_half = (1.0 - arg * arg).max(zero).sqrt();
        // Branches::cos_sin(+1) and (-1)
        let (a, b) = (arg * cos_mid, sin_half * sin_mid);
        let (e, f) = (arg * sin_mid, sin_half * cos_mid);
        let plus = (a - b, e + f);
        let minus = (a + b, e - f);
        let (c0, s0) = (l(seed_cos[i]), l(seed_sin[i]));
        let take_plus = (plus.0 * c0 + plus.1 * s0).ge(minus.0 * c0 + minus.1 * s0);
        let (ci, si) = take_plus.select2(plus, minus);
        cos[i] = ci.v;
        sin[i] = si.v;
        // cable i's length at the answer minus its target: only segment i is new
        residual = residual.max((segment(geom.seg[row + i], ci, si) - s).abs());
    }
    for i in 0..n {
        cos[i] = ok.select(l(cos[i]), l(seed_cos[i])).v;
        sin[i] = ok.select(l(sin[i]), l(seed_sin[i])).v;
    }
    let residual = ok.select(residual, Lanes::splat(simd, f64::INFINITY));
    (residual.v, ok.v)
}

/// Vectors per block of the batch: `BLOCK * W` rows are solved together,
/// their `BLOCK` dependency chains interleaved (4 was the fastest of 1, 2,
/// 3, 4, 6, 8 on AVX2: 16 rows per block).
const BLOCK: usize = 4;

struct BatchOp<'a> {
    geom: &'a CableGeometry,
    target: &'a [f64],
    seed: &'a [f64],
    theta: &'a mut [f64],
    residual: &'a mut [f64],
    ok: &'a mut [bool],
}

impl WithSimd for BatchOp<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        batch::<S, BLOCK>(simd, self)
    }
}

#[inline(always)]
fn batch<S: Simd, const U: usize>(simd: S, op: BatchOp<'_>) {
    let BatchOp {
        geom,
        target,
        seed,
        theta,
        residual,
        ok,
    } = op;
    let n = geom.n;
    let rows = residual.len();
    let w = S::F64_LANES;
    let zero = simd.splat_f64s(0.0);
    // joint-major lane buffers: target, seed, seed cos/sin, answer cos/sin
    let mut buf = vec![[zero; U]; 6 * n];
    let (tv, rest) = buf.split_at_mut(n);
    let (sv, rest) = rest.split_at_mut(n);
    let (sc, rest) = rest.split_at_mut(n);
    let (ss, rest) = rest.split_at_mut(n);
    let (cv, snv) = rest.split_at_mut(n);
    let bw = U * w;
    let mut start = 0;
    while start < rows {
        // rows start..start+m: row start + r is lane r % w of vector r / w; a
        // short tail repeats its last row
        let m = bw.min(rows - start);
        let block = start * n..(start + m) * n;
        gather::<S, U>(&target[block.clone()], n, m, tv);
        gather::<S, U>(&seed[block.clone()], n, m, sv);
        for j in 0..n {
            let (s, c) = sin_cos_lanes(Lanes::new(simd, sv[j]));
            (ss[j], sc[j]) = (s.v, c.v);
        }
        let (res, good) = closed_form_lanes_x(simd, geom, tv, sc, ss, cv, snv);
        let good = Mask::<S, U> { simd, v: good };
        for j in 0..n {
            // theta = seed + atan2(sin(t - seed), cos(t - seed))
            let l = |v: [S::f64s; U]| Lanes::new(simd, v);
            let (c, s, c0, s0, seed) = (l(cv[j]), l(snv[j]), l(sc[j]), l(ss[j]), l(sv[j]));
            let th = seed + atan2_lanes(s * c0 - c * s0, c * c0 + s * s0);
            tv[j] = good.select(th, seed).v;
        }
        scatter::<S, U>(tv, n, m, &mut theta[block]);
        let res = pulp::bytemuck::cast_slice::<S::f64s, f64>(&res);
        residual[start..start + m].copy_from_slice(&res[..m]);
        let flags = good
            .select(Lanes::splat(simd, 1.0), Lanes::splat(simd, 0.0))
            .v;
        let flags = pulp::bytemuck::cast_slice::<S::f64s, f64>(&flags);
        for (o, f) in ok[start..start + m].iter_mut().zip(flags) {
            *o = *f != 0.0;
        }
        start += m;
    }
}

/// Rows (`m` of them, `n` columns, row-major) into joint-major vectors:
/// row `r` becomes lane `r % W` of vector `r / W` of `out[j]`; lanes past
/// `m` repeat row `m - 1`.
#[inline(always)]
fn gather<S: Simd, const U: usize>(rows: &[f64], n: usize, m: usize, out: &mut [[S::f64s; U]]) {
    let bw = U * S::F64_LANES;
    let flat = pulp::bytemuck::cast_slice_mut::<S::f64s, f64>(out[..n].as_flattened_mut());
    for (j, col) in flat.chunks_exact_mut(bw).enumerate() {
        for (x, row) in col.iter_mut().zip(rows.chunks_exact(n)) {
            *x = row[j];
        }
        let last = col[m - 1];
        col[m..].fill(last);
    }
}

/// The inverse of [`gather`] for the first `m` rows.
#[inline(always)]
fn scatter<S: Simd, const U: usize>(v: &[[S::f64s; U]], n: usize, m: usize, rows: &mut [f64]) {
    let bw = U * S::F64_LANES;
    let flat = pulp::bytemuck::cast_slice::<S::f64s, f64>(v[..n].as_flattened());
    for (j, col) in flat.chunks_exact(bw).enumerate() {
        for (x, row) in col[..m].iter().zip(rows.chunks_exact_mut(n)) {
            row[j] = *x;
        }
    }
}

/// Closed-form cable solve of a row-major batch, SIMD across rows, with the
/// instruction set chosen at run time (`pulp::Arch::new()`).
///
/// `target`: upper-cable lengths (m), `N x n`; `seed`: seed angles (rad),
/// `N x n`; outputs `theta` (`N x n`, rad), `residual` (`N`, m) and `ok`
/// (`N`). Row by row this is [`crate::solve::solve_cables_closed_form`]
/// seeded with `theta = seed`: `theta = seed + atan2(sin(t − seed), cos(t −
/// seed))` per joint, `ok` = the closed form has a real solution, `residual`
/// = its residual. Rows without a real solution keep `theta = seed` (bit for
/// bit) and get `residual = +inf`. `N` need not be a multiple of the lane
/// count. Panics if the lengths disagree (`N` is `residual.len()`).
pub fn solve_cables_closed_form_batch(
    geom: &CableGeometry,
    target: &[f64],
    seed: &[f64],
    theta: &mut [f64],
    residual: &mut [f64],
    ok: &mut [bool],
) {
    solve_cables_closed_form_batch_in(pulp::Arch::new(), geom, target, seed, theta, residual, ok);
}

/// [`solve_cables_closed_form_batch`] on the given `pulp::Arch` (for
/// example `pulp::Arch::Scalar` to force the one-lane fallback, or an `Arch`
/// detected once and reused).
pub fn solve_cables_closed_form_batch_in(
    arch: pulp::Arch,
    geom: &CableGeometry,
    target: &[f64],
    seed: &[f64],
    theta: &mut [f64],
    residual: &mut [f64],
    ok: &mut [bool],
) {
    let rows = residual.len();
    let len = rows * geom.n;
    assert_eq!(target.len(), len, "target must be N x n");
    assert_eq!(seed.len(), len, "seed must be N x n");
    assert_eq!(theta.len(), len, "theta must be N x n");
    assert_eq!(ok.len(), rows, "ok must have N entries");
    arch.dispatch(BatchOp {
        geom,
        target,
        seed,
        theta,
        residual,
        ok,
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solve::{closed_form_cs, solve_cables_closed_form};
    use crate::PlanarView;

    /// Lanes of `v` as a slice.
    #[inline(always)]
    fn lanes<S: Simd>(v: &S::f64s) -> &[f64] {
        pulp::bytemuck::cast_slice::<S::f64s, f64>(core::slice::from_ref(v))
    }

    #[inline(always)]
    fn lanes_mut<S: Simd>(v: &mut S::f64s) -> &mut [f64] {
        pulp::bytemuck::cast_slice_mut::<S::f64s, f64>(core::slice::from_mut(v))
    }

    fn robot8() -> PlanarView {
        let mut t = String::from("name = \"t8\"\n");
        for i in 0..8 {
            t += &format!(
                "[[linkage]]\nlink_before = 0.02\nlink_after = 0.02\nthickness = 0.008\nhole_height = {}\njoint_limits = [-0.6, 0.6]\n",
                0.025 - 0.001 * i as f64
            );
        }
        PlanarView::from_toml(&t).unwrap()
    }

    /// The paper robot with every hole coordinate moved by up to 1 mm.
    fn perturbed() -> PlanarView {
        let mut r = PlanarView::paper();
        for (k, v) in r.holes.iter_mut().enumerate() {
            *v += 1e-3 * ((k * 37 % 11) as f64 - 5.0) / 5.0;
        }
        r
    }

    fn robots() -> Vec<(&'static str, PlanarView)> {
        vec![
            ("paper", PlanarView::paper()),
            ("8 joints", robot8()),
            ("perturbed holes", perturbed()),
        ]
    }

    /// SplitMix64.
    struct Rng(u64);
    impl Rng {
        fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
            self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
            z ^= z >> 31;
            lo + (hi - lo) * ((z >> 11) as f64 / (1u64 << 53) as f64)
        }
    }

    fn upper(geom: &CableGeometry, theta: &[f64]) -> Vec<f64> {
        let mut l = vec![0.0; 2 * geom.n];
        geom.lengths(theta, &mut l);
        (0..geom.n).map(|i| l[2 * i]).collect()
    }

    /// Random rows `(target, seed)`: mostly reachable targets (+-1 mm noise)
    /// seeded near the answer, plus seeds far from it, targets too long or
    /// too short for some joint, and zero seeds.
    fn cases(
        robot: &PlanarView,
        geom: &CableGeometry,
        rows: usize,
        seed: u64,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = geom.n;
        let mut rng = Rng(seed);
        let (mut target, mut seeds) = (Vec::new(), Vec::new());
        for row in 0..rows {
            let th: Vec<f64> = robot
                .joint_limits
                .iter()
                .map(|l| rng.uniform(1.2 * l[0], 1.2 * l[1]))
                .collect();
            let mut t = upper(geom, &th);
            for v in t.iter_mut() {
                *v += rng.uniform(-1e-3, 1e-3);
            }
            let mut s: Vec<f64> = th.iter().map(|x| x + rng.uniform(-0.3, 0.3)).collect();
            match row % 10 {
                6 => s.iter_mut().for_each(|x| *x += rng.uniform(-3.1, 3.1)),
                7 => s
                    .iter_mut()
                    .for_each(|x| *x += std::f64::consts::PI + rng.uniform(-0.1, 0.1)),
                8 => {
                    let j = row / 10 % n;
                    t[j] += if row % 20 == 8 { 0.05 } else { -0.05 };
                }
                9 => s.iter_mut().for_each(|x| *x = 0.0),
                _ => {}
            }
            if row % 50 == 5 {
                s.iter_mut().for_each(|x| *x += 1e3);
            }
            target.extend(t);
            seeds.extend(s);
        }
        (target, seeds)
    }

    /// The scalar path, row by row, as `PlanarSolver` runs it.
    fn scalar_batch(
        geom: &CableGeometry,
        target: &[f64],
        seed: &[f64],
    ) -> (Vec<f64>, Vec<f64>, Vec<bool>) {
        let n = geom.n;
        let rows = target.len() / n;
        let (mut theta, mut res, mut ok) = (seed.to_vec(), vec![0.0; rows], vec![false; rows]);
        let mut cs = vec![(1.0, 0.0); n];
        for r in 0..rows {
            let sc: Vec<(f64, f64)> = seed[r * n..(r + 1) * n]
                .iter()
                .map(|x| (x.cos(), x.sin()))
                .collect();
            let out = solve_cables_closed_form(
                geom,
                &target[r * n..(r + 1) * n],
                &mut theta[r * n..(r + 1) * n],
                &sc,
                &mut cs,
                None,
            );
            ok[r] = out.is_some();
            res[r] = out.unwrap_or(f64::INFINITY);
        }
        (theta, res, ok)
    }

    fn simd_batch(
        arch: pulp::Arch,
        geom: &CableGeometry,
        target: &[f64],
        seed: &[f64],
    ) -> (Vec<f64>, Vec<f64>, Vec<bool>) {
        let rows = target.len() / geom.n;
        let (mut theta, mut res, mut ok) =
            (vec![7.0; target.len()], vec![7.0; rows], vec![false; rows]);
        solve_cables_closed_form_batch_in(arch, geom, target, seed, &mut theta, &mut res, &mut ok);
        (theta, res, ok)
    }

    /// [`closed_form_lanes`] over row-major rows given seed cos/sin.
    struct LanesOp<'a> {
        geom: &'a CableGeometry,
        target: &'a [f64],
        seed_cs: &'a [(f64, f64)],
        cs: &'a mut [(f64, f64)],
        residual: &'a mut [f64],
        ok: &'a mut [bool],
    }

    impl WithSimd for LanesOp<'_> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: Simd>(self, simd: S) {
            let n = self.geom.n;
            let w = S::F64_LANES;
            let rows = self.residual.len();
            let z = simd.splat_f64s(0.0);
            let (mut t, mut c0, mut s0, mut c, mut s) =
                (vec![z; n], vec![z; n], vec![z; n], vec![z; n], vec![z; n]);
            for start in (0..rows).step_by(w) {
                let m = w.min(rows - start);
                for j in 0..n {
                    for l in 0..w {
                        let r = start + l.min(m - 1);
                        lanes_mut::<S>(&mut t[j])[l] = self.target[r * n + j];
                        lanes_mut::<S>(&mut c0[j])[l] = self.seed_cs[r * n + j].0;
                        lanes_mut::<S>(&mut s0[j])[l] = self.seed_cs[r * n + j].1;
                    }
                }
                let (res, ok) = closed_form_lanes(simd, self.geom, &t, &c0, &s0, &mut c, &mut s);
                let flag = simd.select_f64s(ok, simd.splat_f64s(1.0), z);
                for l in 0..m {
                    for j in 0..n {
                        self.cs[(start + l) * n + j] = (lanes::<S>(&c[j])[l], lanes::<S>(&s[j])[l]);
                    }
                    self.residual[start + l] = lanes::<S>(&res)[l];
                    self.ok[start + l] = lanes::<S>(&flag)[l] != 0.0;
                }
            }
        }
    }

    /// Lane kernel vs `closed_form_cs`, bit for bit, on every dispatch path.
    fn assert_lanes_match_scalar(
        geom: &CableGeometry,
        target: &[f64],
        seed_cs: &[(f64, f64)],
        what: &str,
    ) -> usize {
        let n = geom.n;
        let rows = target.len() / n;
        let mut solvable = 0;
        for arch in [pulp::Arch::new(), pulp::Arch::Scalar] {
            let (mut cs, mut res, mut ok) = (
                vec![(9.0, 9.0); rows * n],
                vec![9.0; rows],
                vec![false; rows],
            );
            arch.dispatch(LanesOp {
                geom,
                target,
                seed_cs,
                cs: &mut cs,
                residual: &mut res,
                ok: &mut ok,
            });
            let mut want = vec![(1.0, 0.0); n];
            solvable = 0;
            for r in 0..rows {
                let sc = &seed_cs[r * n..(r + 1) * n];
                let got = closed_form_cs(geom, &target[r * n..(r + 1) * n], sc, &mut want, None);
                assert_eq!(ok[r], got.is_some(), "{what}: row {r} ok");
                let bits = |v: &[(f64, f64)]| {
                    v.iter()
                        .map(|p| (p.0.to_bits(), p.1.to_bits()))
                        .collect::<Vec<_>>()
                };
                if let Some(w) = got {
                    solvable += 1;
                    assert_eq!(res[r].to_bits(), w.to_bits(), "{what}: row {r} residual");
                    assert_eq!(
                        bits(&cs[r * n..(r + 1) * n]),
                        bits(&want),
                        "{what}: row {r} cos/sin"
                    );
                } else {
                    assert_eq!(res[r], f64::INFINITY);
                    assert_eq!(
                        bits(&cs[r * n..(r + 1) * n]),
                        bits(sc),
                        "{what}: row {r} keeps the seed"
                    );
                }
            }
        }
        solvable
    }

    /// Batch vs the scalar solve: same ok flags, same branch (|theta
    /// difference| <= 1e-12 rad), residuals within 1e-15 m, unsolvable rows
    /// keep the seed bit for bit.
    fn assert_batch_matches_scalar(
        geom: &CableGeometry,
        target: &[f64],
        seed: &[f64],
        what: &str,
    ) -> f64 {
        let n = geom.n;
        let (th0, res0, ok0) = scalar_batch(geom, target, seed);
        let mut worst = 0.0f64;
        for arch in [pulp::Arch::new(), pulp::Arch::Scalar] {
            let (th, res, ok) = simd_batch(arch, geom, target, seed);
            assert_eq!(ok, ok0, "{what}: ok flags");
            for r in 0..ok.len() {
                for j in r * n..(r + 1) * n {
                    if ok[r] {
                        let d = (th[j] - th0[j]).abs();
                        assert!(
                            d <= 1e-12 || (th[j].is_nan() && th0[j].is_nan()),
                            "{what}: row {r}: {} vs {}",
                            th[j],
                            th0[j]
                        );
                        worst = worst.max(d);
                    } else {
                        assert_eq!(
                            th[j].to_bits(),
                            seed[j].to_bits(),
                            "{what}: row {r} keeps the seed"
                        );
                    }
                }
                if ok[r] {
                    assert!(
                        (res[r] - res0[r]).abs() <= 1e-15,
                        "{what}: row {r} residual {} vs {}",
                        res[r],
                        res0[r]
                    );
                } else {
                    assert_eq!(res[r], f64::INFINITY);
                }
            }
        }
        worst
    }

    #[test]
    fn simd_lanes_bitwise_match_closed_form_cs() {
        for (name, robot) in robots() {
            let g = CableGeometry::new(&robot, None);
            let (target, seed) = cases(&robot, &g, 1003, 17);
            let seed_cs: Vec<(f64, f64)> = seed.iter().map(|x| (x.cos(), x.sin())).collect();
            let solvable = assert_lanes_match_scalar(&g, &target, &seed_cs, name);
            assert!(
                solvable > 500 && solvable < 1003,
                "{name}: {solvable} solvable"
            );
        }
    }

    #[test]
    fn simd_batch_matches_scalar_solve() {
        for (name, robot) in robots() {
            let g = CableGeometry::new(&robot, None);
            let (target, seed) = cases(&robot, &g, 1003, 23);
            let worst = assert_batch_matches_scalar(&g, &target, &seed, name);
            eprintln!("{name}: max |theta difference| {worst:.1e} rad");
        }
    }

    #[test]
    fn simd_batch_handles_every_tail_length() {
        let robot = PlanarView::paper();
        let g = CableGeometry::new(&robot, None);
        let (target, seed) = cases(&robot, &g, 20, 5);
        for rows in 0..=20 {
            assert_batch_matches_scalar(
                &g,
                &target[..3 * rows],
                &seed[..3 * rows],
                &format!("{rows} rows"),
            );
        }
    }

    #[test]
    fn simd_fold_parity() {
        // joint j at its fold (theta_j = the segment's phase: cos(half) = 1,
        // both branches coincide), the target swept by single ulps across it
        for (name, robot) in robots() {
            let g = CableGeometry::new(&robot, None);
            let n = g.n;
            let (mut target, mut seed) = (vec![], vec![]);
            for j in 0..n {
                let mut th: Vec<f64> = (0..n).map(|k| 0.1 * (k as f64 + 1.0).sin()).collect();
                th[j] = g.phase[2 * j * n + j][0];
                let base = upper(&g, &th);
                let mut up = base[j];
                let mut down = base[j];
                for _ in 0..40 {
                    for v in [up, down] {
                        let mut t = base.clone();
                        t[j] = v;
                        target.extend(&t);
                        seed.extend(th.iter().map(|x| x + 0.2));
                    }
                    up = up.next_up();
                    down = down.next_down();
                }
            }
            let rows = target.len() / n;
            let seed_cs: Vec<(f64, f64)> = seed.iter().map(|x| (x.cos(), x.sin())).collect();
            let solvable = assert_lanes_match_scalar(&g, &target, &seed_cs, name);
            assert!(
                solvable > 0 && solvable < rows,
                "{name}: {solvable} of {rows} solvable"
            );
            assert_batch_matches_scalar(&g, &target, &seed, name);
        }
    }

    #[test]
    fn simd_ties_and_far_seeds() {
        use std::f64::consts::{FRAC_PI_2, PI};
        for (name, robot) in robots() {
            let g = CableGeometry::new(&robot, None);
            let n = g.n;
            let th: Vec<f64> = (0..n).map(|k| 0.3 * (1.7 * k as f64).sin()).collect();
            let t = upper(&g, &th);
            let (mut target, mut seed_cs, mut seed) = (vec![], vec![], vec![]);
            // kinds 0, 1: seeds on the bisector of the two branches and its
            // opposite (cos(t - seed) ties up to rounding); 2, 3: its normals;
            // 4..7: seeds 1e3 and 1e5 rad away, opposite the answer, at zero
            for kind in 0..8 {
                target.extend(&t);
                for (i, thi) in th.iter().enumerate() {
                    let [mid, _, cm, sm] = g.phase[2 * i * n + i];
                    let (a, cs) = match kind {
                        0 => (mid, (cm, sm)),
                        1 => (mid + PI, (-cm, -sm)),
                        2 => (mid + FRAC_PI_2, (-sm, cm)),
                        3 => (mid - FRAC_PI_2, (sm, -cm)),
                        k => {
                            let a = thi + [1e3, -1e5, PI, -thi][k - 4];
                            (a, (a.cos(), a.sin()))
                        }
                    };
                    seed.push(a);
                    seed_cs.push(cs);
                }
            }
            // the lane kernel breaks ties exactly as the scalar code (same bits);
            // a seed picking the other branch of a joint can leave a later
            // joint without a solution, so not every row is solvable
            assert!(assert_lanes_match_scalar(&g, &target, &seed_cs, name) >= 4);
            // from angles, the tie rows (0, 1) hinge on the last bit of the
            // seed's cos/sin: compare the rows away from a tie
            assert_batch_matches_scalar(&g, &target[2 * n..], &seed[2 * n..], name);
        }
    }

    #[test]
    fn simd_nan_targets_and_seeds_and_flat_segments() {
        let robot = PlanarView::paper();
        let g = CableGeometry::new(&robot, None);
        let t = upper(&g, &[0.1, -0.2, 0.3]);
        let mut target = vec![];
        let mut seed = vec![];
        for k in 0..6 {
            let mut tk = t.clone();
            let mut sk = vec![0.0, -0.0, 0.5];
            match k {
                0 => tk[0] = f64::NAN,
                1 => tk[2] = f64::NAN,
                2 => sk[1] = f64::NAN,
                3 => sk[0] = f64::INFINITY,
                4 => tk[1] = f64::INFINITY,
                _ => {}
            }
            target.extend(tk);
            seed.extend(sk);
        }
        let (th, _, ok) = simd_batch(pulp::Arch::new(), &g, &target, &seed);
        assert_eq!(ok, [false, false, true, true, false, true]);
        assert!(th[7].is_nan() && th[9].is_nan());
        assert_eq!(th[1].to_bits(), (-0.0f64).to_bits()); // unsolvable rows keep the seed bits
        assert_batch_matches_scalar(&g, &target, &seed, "nan/inf");
        // segment 1 of cable 2 (pair 1) made independent of its angle
        // (hypot(Q, R) = 0): no row has a solution
        let mut flat = g.clone();
        flat.phase[2 * 3 + 1][1] = 0.0;
        let seed_cs: Vec<(f64, f64)> = seed.iter().map(|x| (x.cos(), x.sin())).collect();
        assert_eq!(
            assert_lanes_match_scalar(&flat, &target, &seed_cs, "flat"),
            0
        );
    }
}

/// Rows per [`ClosedFormBlock`]: 16 (four AVX2 vectors, eight NEON ones,
/// two AVX-512 ones, sixteen scalar lanes).
pub const BLOCK_ROWS: usize = 16;

/// Buffers of [`closed_form_block`]: up to [`BLOCK_ROWS`] rows sharing one
/// geometry, joint-major (`x[j * BLOCK_ROWS + r]` is joint `j` of row `r`).
/// Inputs `target` (m) and the seed's `seed_cos`/`seed_sin`; outputs the
/// answer's `cos`/`sin`, `residual` (m, +inf without a solution) and `ok`.
#[derive(Debug, Clone)]
pub struct ClosedFormBlock {
    pub target: Vec<f64>,
    pub seed_cos: Vec<f64>,
    pub seed_sin: Vec<f64>,
    pub cos: Vec<f64>,
    pub sin: Vec<f64>,
    pub residual: [f64; BLOCK_ROWS],
    pub ok: [bool; BLOCK_ROWS],
}

impl ClosedFormBlock {
    /// Buffers for `n` joints (the seed starts at angle 0).
    pub fn new(n: usize) -> Self {
        ClosedFormBlock {
            target: vec![0.0; n * BLOCK_ROWS],
            seed_cos: vec![1.0; n * BLOCK_ROWS],
            seed_sin: vec![0.0; n * BLOCK_ROWS],
            cos: vec![1.0; n * BLOCK_ROWS],
            sin: vec![0.0; n * BLOCK_ROWS],
            residual: [0.0; BLOCK_ROWS],
            ok: [false; BLOCK_ROWS],
        }
    }
}

struct BlockOp<'a> {
    geom: &'a CableGeometry,
    block: &'a mut ClosedFormBlock,
}

impl WithSimd for BlockOp<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        match S::F64_LANES {
            1 => block::<S, 16>(simd, self),
            2 => block::<S, 8>(simd, self),
            4 => block::<S, 4>(simd, self),
            8 => block::<S, 2>(simd, self),
            _ => block::<S, 1>(simd, self),
        }
    }
}

/// The closed form of `block` in place: its joint-major buffers are `n`
/// vectors of `U` SIMD vectors each (`U * W == BLOCK_ROWS`), read and
/// written as such (no copies, no stack buffers to clear).
#[inline(always)]
fn block<S: Simd, const U: usize>(simd: S, op: BlockOp<'_>) {
    use pulp::bytemuck::{cast_slice, cast_slice_mut};
    let BlockOp { geom, block } = op;
    debug_assert_eq!(U * S::F64_LANES, BLOCK_ROWS);
    let len = geom.n * BLOCK_ROWS;
    // f64 slices as slices of [S::f64s; U] (exact: len is a multiple of U * W)
    fn vectors<S: Simd, const U: usize>(x: &[f64]) -> &[[S::f64s; U]] {
        cast_slice::<f64, S::f64s>(x).as_chunks::<U>().0
    }
    fn vectors_mut<S: Simd, const U: usize>(x: &mut [f64]) -> &mut [[S::f64s; U]] {
        cast_slice_mut::<f64, S::f64s>(x).as_chunks_mut::<U>().0
    }
    let (res, good) = closed_form_lanes_x::<S, U>(
        simd,
        geom,
        vectors::<S, U>(&block.target[..len]),
        vectors::<S, U>(&block.seed_cos[..len]),
        vectors::<S, U>(&block.seed_sin[..len]),
        vectors_mut::<S, U>(&mut block.cos[..len]),
        vectors_mut::<S, U>(&mut block.sin[..len]),
    );
    block
        .residual
        .copy_from_slice(cast_slice::<S::f64s, f64>(&res));
    let flags = Mask::<S, U> { simd, v: good }
        .select(Lanes::splat(simd, 1.0), Lanes::splat(simd, 0.0))
        .v;
    for (o, f) in block.ok.iter_mut().zip(cast_slice::<S::f64s, f64>(&flags)) {
        *o = *f != 0.0;
    }
}

/// The closed form of the [`BLOCK_ROWS`] rows of `block`, SIMD across rows
/// with the instruction set of `simd` (call it from code compiled for that
/// set, e.g. inside a `pulp::WithSimd` op): on rows with a solution, `cos`,
/// `sin` and `residual` are bit-identical to [`crate::solve::closed_form_cs`]
/// from the same seed `(cos, sin)`.
#[inline(always)]
pub fn closed_form_block<S: Simd>(simd: S, geom: &CableGeometry, block: &mut ClosedFormBlock) {
    BlockOp { geom, block }.with_simd(simd)
}
