//! Cable lengths from hole positions (Eq. 4–5), their Jacobian, and the
//! closed-form per-joint inverse.
//!
//! Each segment of cable `c` between disk `k-1` and disk `k` has squared length
//! `P + Q cos(theta_k) + R sin(theta_k)`; cable `c` of pair `i` crosses joints
//! `1..=i` only, so the upper-cable solve is triangular.

pub use crate::geometry::pair;
use crate::geometry::{ArmGeometry, WithHoles};
use crate::robot::PlanarView;

/// Segment coefficients of every cable: the geometry the solves need,
/// precomputed once per set of hole positions.
#[derive(Debug, Clone, PartialEq)]
pub struct CableGeometry {
    pub n: usize,
    /// `[P, Q, R]` of cable `c`, joint `k`, at `c * n + k` (zero past the cable's pair).
    pub seg: Vec<[f64; 3]>,
    /// Constant part of each cable: the sum of its disk traversals (m).
    pub traverse: Vec<f64>,
    /// `[atan2(R, Q), hypot(Q, R), Q / hypot, R / hypot]` of each segment, for the closed form.
    pub phase: Vec<[f64; 4]>,
}

impl CableGeometry {
    /// Coefficients for `robot` with the hole positions `holes` (flat
    /// `(2n, n+1, 2, 2)`, m); `None` uses the robot's own holes.
    pub fn new(robot: &PlanarView, holes: Option<&[f64]>) -> CableGeometry {
        match holes {
            Some(h) => Self::of(&WithHoles { robot, holes: h }),
            None => Self::of(robot),
        }
    }

    /// Coefficients of any arm description.
    pub fn of<A: ArmGeometry<f64>>(arm: &A) -> CableGeometry {
        let n = arm.n();
        let mut seg = vec![[0.0; 3]; 2 * n * n];
        let mut traverse = vec![0.0; 2 * n];
        for c in 0..2 * n {
            for k in 0..=pair(c) {
                seg[c * n + k] = arm.segment(c, k, 0.0).pqr();
                traverse[c] += arm.traversal(c, k, 0.0, 0.0);
            }
        }
        let phase = seg
            .iter()
            .map(|[_, q, r]| {
                let amp = q.hypot(*r);
                let (cm, sm) = if amp > 0.0 {
                    (q / amp, r / amp)
                } else {
                    (1.0, 0.0)
                };
                [r.atan2(*q), amp, cm, sm]
            })
            .collect();
        CableGeometry {
            n,
            seg,
            traverse,
            phase,
        }
    }

    /// Length of segment `k` of cable `c` given `(cos, sin)` of theta_k.
    #[inline]
    pub fn segment(&self, c: usize, k: usize, cs: (f64, f64)) -> f64 {
        let [p, q, r] = self.seg[c * self.n + k];
        (p + q * cs.0 + r * cs.1).max(0.0).sqrt()
    }

    /// Length of cable `c` (m) from the `(cos, sin)` of every joint angle.
    #[inline]
    pub fn length(&self, c: usize, cs: &[(f64, f64)]) -> f64 {
        self.traverse[c]
            + (0..=pair(c))
                .map(|k| self.segment(c, k, cs[k]))
                .sum::<f64>()
    }

    /// All `2n` cable lengths (m) into `out`.
    pub fn lengths(&self, theta: &[f64], out: &mut [f64]) {
        let cs: Vec<(f64, f64)> = theta.iter().map(|t| (t.cos(), t.sin())).collect();
        for (c, o) in out.iter_mut().enumerate() {
            *o = self.length(c, &cs);
        }
    }

    /// `d L_c / d theta_k` for the given cable (0 for joints it does not cross).
    #[inline]
    pub fn derivative(&self, c: usize, k: usize, cs: (f64, f64)) -> f64 {
        if k > pair(c) {
            return 0.0;
        }
        let [_, q, r] = self.seg[c * self.n + k];
        segment_slope(q, r, cs, self.segment(c, k, cs))
    }

    /// Cable Jacobian `(2n, n)` row-major into `out`.
    pub fn jacobian(&self, theta: &[f64], out: &mut [f64]) {
        let n = self.n;
        let cs: Vec<(f64, f64)> = theta.iter().map(|t| (t.cos(), t.sin())).collect();
        for c in 0..2 * n {
            for k in 0..n {
                out[c * n + k] = self.derivative(c, k, cs[k]);
            }
        }
    }

    /// Upper-cable lengths (m) and their Jacobian (row-major `n x n`, lower
    /// triangular, m/rad) from the joints' `(cos, sin)`: one square root per
    /// segment, the lengths first, then the derivatives from the roots.
    #[inline(always)]
    pub fn upper_lengths_and_jacobian(&self, cs: &[(f64, f64)], len: &mut [f64], jac: &mut [f64]) {
        self.upper_lengths_and_roots(cs, len, jac);
        self.roots_to_jacobian(cs, jac);
    }

    /// Upper-cable lengths (m, `n` into `len`) from the joints' `(cos, sin)`,
    /// and the segments' lengths (m) into the lower triangle of `roots`
    /// (row-major `n x n`, cable by joint; the rest left as it is): with
    /// [`CableGeometry::roots_to_jacobian`], the Jacobian without a second
    /// square root.
    #[inline(always)]
    pub fn upper_lengths_and_roots(&self, cs: &[(f64, f64)], len: &mut [f64], roots: &mut [f64]) {
        let n = len.len();
        debug_assert_eq!(n, self.n);
        for (i, (out, row)) in len.iter_mut().zip(roots.chunks_exact_mut(n)).enumerate() {
            let c = 2 * i;
            let segs = &self.seg[c * n..(c + 1) * n];
            let mut l = self.traverse[c];
            for ((d, &(ck, sk)), &[p, q, r]) in row[..=i].iter_mut().zip(cs).zip(segs) {
                let root = (p + q * ck + r * sk).max(0.0).sqrt();
                l += root;
                *d = root;
            }
            *out = l;
        }
    }

    /// The upper cables' Jacobian (m/rad), in place over the segment lengths
    /// that [`CableGeometry::upper_lengths_and_roots`] wrote into `jac` at the
    /// same `(cos, sin)`; zeros past the diagonal.
    #[inline(always)]
    pub fn roots_to_jacobian(&self, cs: &[(f64, f64)], jac: &mut [f64]) {
        let n = cs.len();
        for (i, row) in jac.chunks_exact_mut(n).enumerate() {
            let segs = &self.seg[2 * i * n..(2 * i + 1) * n];
            // one loop over the whole row (zeros past the diagonal written in
            // it: no memset call per row)
            for (k, ((d, &c), &[_, q, r])) in row.iter_mut().zip(cs).zip(segs).enumerate() {
                *d = if k > i {
                    0.0
                } else {
                    segment_slope(q, r, c, *d)
                };
            }
        }
    }

    /// Upper-cable lengths (cables 0, 2, 4, ...) at `theta` into `out` (n).
    pub fn upper_lengths(&self, cs: &[(f64, f64)], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.length(2 * i, cs);
        }
    }

    /// Both angles of joint `k` that give segment `k` of cable `c` the length
    /// `s` (m): `atan2(R, Q) ± acos((s² − P) / hypot(Q, R))`. `None` when no
    /// angle does (the paper's "one-to-many" has two branches or none).
    #[cfg(test)]
    pub fn joint_branches(&self, c: usize, k: usize, s: f64) -> Option<[f64; 2]> {
        let b = self.joint_solution(c, k, s)?;
        Some([b.angle(1.0), b.angle(-1.0)])
    }

    /// The two solutions of joint `k` for segment length `s`, in a form that
    /// gives their cos/sin without trigonometry (see [`Branches`]).
    #[inline]
    pub fn joint_solution(&self, c: usize, k: usize, s: f64) -> Option<Branches> {
        let p = self.seg[c * self.n + k][0];
        let [mid, amp, cos_mid, sin_mid] = self.phase[c * self.n + k];
        if s < 0.0 || amp == 0.0 {
            return None;
        }
        let arg = (s * s - p) / amp;
        if !(-1.0..=1.0).contains(&arg) {
            return None;
        }
        Some(Branches {
            mid,
            cos_half: arg,
            sin_half: (1.0 - arg * arg).max(0.0).sqrt(),
            cos_mid,
            sin_mid,
        })
    }
}

/// `d/dtheta` (m/rad) of a segment of length `root` (m) whose squared length
/// is `P + Q cos + R sin` at the joint's `(cos, sin)` `cs`; the denominator
/// kept finite at a zero-length segment.
#[inline(always)]
fn segment_slope(q: f64, r: f64, cs: (f64, f64), root: f64) -> f64 {
    (r * cs.0 - q * cs.1) / (2.0 * root.max(f64::MIN_POSITIVE.sqrt()))
}

/// The two angles `mid ± half` solving one joint of the closed form, with
/// `cos(half) = (s² − P) / hypot(Q, R)`.
#[derive(Debug, Clone, Copy)]
pub struct Branches {
    pub mid: f64,
    pub cos_half: f64,
    pub sin_half: f64,
    cos_mid: f64,
    sin_mid: f64,
}

impl Branches {
    /// Whether the two branches coincide (the cable is at a fold).
    #[inline]
    pub fn single(&self) -> bool {
        self.sin_half == 0.0
    }

    /// Angle of the branch `mid + sign · half` (rad).
    #[cfg(test)]
    pub fn angle(&self, sign: f64) -> f64 {
        self.mid + sign * self.cos_half.acos()
    }

    /// `(cos, sin)` of the branch `mid + sign · half`, by angle addition.
    #[inline]
    pub fn cos_sin(&self, sign: f64) -> (f64, f64) {
        (
            self.cos_mid * self.cos_half - sign * self.sin_mid * self.sin_half,
            self.sin_mid * self.cos_half + sign * self.cos_mid * self.sin_half,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_lengths_are_link_sums() {
        let r = PlanarView::paper();
        let g = CableGeometry::new(&r, None);
        let mut l = [0.0; 6];
        g.lengths(&[0.0; 3], &mut l);
        for (c, lc) in l.iter().enumerate() {
            let want = 0.076 * (c / 2 + 1) as f64;
            assert!((lc - want).abs() < 1e-15, "{c}: {lc}");
        }
    }

    #[test]
    fn bending_up_shortens_the_upper_cable() {
        let r = PlanarView::paper();
        let g = CableGeometry::new(&r, None);
        let mut l = [0.0; 6];
        g.lengths(&[0.1, 0.0, 0.0], &mut l);
        assert!(l[0] < 0.076 && l[1] > 0.076);
    }

    #[test]
    fn jacobian_matches_central_differences() {
        let r = PlanarView::paper();
        let g = CableGeometry::new(&r, None);
        let th = [0.3, -0.2, 0.5];
        let mut jac = [0.0; 18];
        g.jacobian(&th, &mut jac);
        for k in 0..3 {
            let h = 1e-6;
            let (mut a, mut b) = (th, th);
            a[k] += h;
            b[k] -= h;
            let (mut la, mut lb) = ([0.0; 6], [0.0; 6]);
            g.lengths(&a, &mut la);
            g.lengths(&b, &mut lb);
            for c in 0..6 {
                assert!(((la[c] - lb[c]) / (2.0 * h) - jac[c * 3 + k]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn closed_form_branches_reproduce_the_segment() {
        let r = PlanarView::paper();
        let g = CableGeometry::new(&r, None);
        let t: f64 = 0.4;
        let s = g.segment(0, 0, (t.cos(), t.sin()));
        let b = g.joint_branches(0, 0, s).unwrap();
        assert!(b
            .iter()
            .any(|x| (x - t).sin().abs() < 1e-12 && (x - t).cos() > 0.0));
        for x in b {
            assert!((g.segment(0, 0, (x.cos(), x.sin())) - s).abs() < 1e-14);
        }
    }
}
