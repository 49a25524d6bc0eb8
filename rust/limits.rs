//! The joint-limit box of an arm (`docs/model.md`): `[lo, hi]` per joint
//! (rad), bounds included. One type answers the three questions the solves
//! ask of it: is a configuration inside, where is its nearest point inside
//! (the solver's projection), and does a configuration sit on a bound (a
//! solve stuck there ends `outside limits`).

/// The joint-limit box: `[lo, hi]` per joint (rad). `B` holds the bounds,
/// owned ([`crate::model::Model::limits`]) or borrowed
/// ([`crate::robot::PlanarView::limits`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits<B = Vec<[f64; 2]>>(pub B);

impl<B: AsRef<[[f64; 2]]>> Limits<B> {
    /// The bounds, `[lo, hi]` per joint (rad).
    #[inline(always)]
    pub fn bounds(&self) -> &[[f64; 2]] {
        self.0.as_ref()
    }

    /// Whether every angle of `theta` (rad) lies within its joint's limits
    /// (inclusive).
    #[inline]
    pub fn contains(&self, theta: &[f64]) -> bool {
        theta
            .iter()
            .zip(self.bounds())
            .all(|(t, l)| *t >= l[0] && *t <= l[1])
    }

    /// `theta` (rad) moved onto the box, angle by angle.
    #[inline]
    pub fn clamp(&self, theta: &mut [f64]) {
        for (t, l) in theta.iter_mut().zip(self.bounds()) {
            *t = t.clamp(l[0], l[1]);
        }
    }

    /// Whether some angle of `theta` (rad) sits on (or past) one of its bounds.
    #[inline]
    pub fn on_bound(&self, theta: &[f64]) -> bool {
        theta
            .iter()
            .zip(self.bounds())
            .any(|(t, l)| *t <= l[0] || *t >= l[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_box_includes_its_bounds() {
        let l = Limits(vec![[-1.0, 1.0], [0.0, 2.0]]);
        assert!(l.contains(&[-1.0, 2.0]) && l.contains(&[0.5, 1.0]));
        assert!(!l.contains(&[1.5, 1.0]) && !l.contains(&[0.0, f64::NAN]));
        assert!(l.on_bound(&[-1.0, 1.0]) && l.on_bound(&[0.0, 3.0]));
        assert!(!l.on_bound(&[0.5, 1.0]));
        let mut t = [3.0, -0.5];
        l.clamp(&mut t);
        assert_eq!(t, [1.0, 0.0]);
        let borrowed = Limits(&l.0[..]);
        assert!(borrowed.contains(&[0.0, 0.0]));
    }
}
