//! The planar view of an arm (link lengths, disks, hole positions, masses,
//! lower-cable tensions and joint limits, SI units: the data of the planar
//! closed forms and SIMD kernels), derived from the one model by
//! [`crate::model::Model::planar_view`]; and the cable material.

use crate::error::Result;
use crate::limits::Limits;
use crate::robot_file::{bad, non_negative, positive, positive_length, MAX_LENGTH};

/// Cable material, for the elasticity model.
#[derive(Debug, Clone, PartialEq)]
pub struct CableMaterial {
    /// Young's modulus (Pa).
    pub youngs_modulus: f64,
    /// Cable diameter (m).
    pub diameter: f64,
    /// Length of each upper cable's path behind the base disk, from the base
    /// disk to the actuator (m, default 0). It carries the cable's tension and
    /// stretches with it (`docs/model.md`, "Statics, slack cables and cable
    /// elasticity").
    pub routing_length: f64,
    /// The controller's premise (default `true`): it pays the frictionless
    /// stretch of this cable (`1 / (E A)`) out with its commands, so the
    /// plant's `cable_elasticity` is the compliance beyond it; `false`: it
    /// commands the rigid model's lengths and `cable_elasticity` is the whole
    /// compliance (`docs/model.md`, "Commands and their order").
    pub stretch_feed_forward: bool,
    /// The robot states this cable (a robot file's `[cable]` table, or
    /// [`crate::model::Model::with_cable`]); `false`: cdsm's default cable, a
    /// placeholder. An arm with more position cables than joints settles on
    /// a stated cable's stiffness, else in least squares on the lengths
    /// (`docs/model.md`, "Settling").
    pub stated: bool,
}

impl Default for CableMaterial {
    /// A robot file's material when it gives no `[cable]`: steel, 0.18 mm
    /// (not stated).
    fn default() -> Self {
        CableMaterial {
            youngs_modulus: 1.8e11,
            diameter: 0.18e-3,
            routing_length: 0.0,
            stretch_feed_forward: true,
            stated: false,
        }
    }
}

impl CableMaterial {
    /// The compliance of the cable, `1 / (E A)` with `A = pi d^2 / 4` (1/N).
    pub fn compliance(&self) -> f64 {
        1.0 / (self.youngs_modulus * std::f64::consts::PI * self.diameter * self.diameter / 4.0)
    }

    /// The compliance whose frictionless stretch the controller feeds
    /// forward (1/N): [`Self::compliance`] with `stretch_feed_forward`, else 0.
    pub fn fed_forward(&self) -> f64 {
        if self.stretch_feed_forward {
            self.compliance()
        } else {
            0.0
        }
    }

    /// Checks that the numbers are physical (positive modulus and diameter,
    /// a routing length `>= 0`), naming the field.
    pub fn validate(&self) -> Result<()> {
        positive("cable.youngs_modulus".into(), self.youngs_modulus, "Pa")?;
        positive_length("cable.diameter".into(), self.diameter)?;
        non_negative("cable.routing_length".into(), self.routing_length, "m")?;
        if self.routing_length > MAX_LENGTH {
            return Err(bad(
                "cable.routing_length".into(),
                format!(
                    "must be at most {MAX_LENGTH} m, got {}",
                    self.routing_length
                ),
            ));
        }
        Ok(())
    }
}

/// Index of `holes[c, d, f, 0]` in the flat hole array of an `n`-joint arm.
#[inline]
pub fn hole_index(n: usize, c: usize, d: usize, f: usize) -> usize {
    ((c * (n + 1) + d) * 2 + f) * 2
}

/// The planar view of a CDSM with `n` joints and `2n` cables (see
/// `docs/model.md`).
#[derive(Debug, Clone, PartialEq)]
pub struct PlanarView {
    pub name: String,
    /// Link before joint `i` (m), the paper's link_{i-1,J_i}.
    pub link_before: Vec<f64>,
    /// Link after joint `i` (m), the paper's link_{J_i,i}.
    pub link_after: Vec<f64>,
    /// Thickness of disk `i` (m), the paper's `B`.
    pub thickness: Vec<f64>,
    /// Mass of linkage `i` (kg).
    pub mass: Vec<f64>,
    /// Tension on the lower (force-controlled) cable of pair `i` (N).
    pub lower_tension: Vec<f64>,
    /// Joint limits `[lo, hi]` (rad).
    pub joint_limits: Vec<[f64; 2]>,
    /// Hole positions, flat `(2n, n+1, 2, 2)` C-order: cable, disk, face (a, b), (x, y) in m.
    pub holes: Vec<f64>,
    pub cable: CableMaterial,
    /// In-plane gravity `[gx, gy]` (m/s², base frame) the statics use by
    /// default; `[0, 0]`: a horizontal plane.
    pub gravity: [f64; 2],
}

impl PlanarView {
    /// Number of joints.
    pub fn n(&self) -> usize {
        self.link_before.len()
    }

    /// Index of `holes[c, d, f, 0]` in the flat hole array.
    #[inline]
    pub fn hole_index(&self, c: usize, d: usize, f: usize) -> usize {
        hole_index(self.n(), c, d, f)
    }

    /// The joint-limit box.
    pub fn limits(&self) -> Limits<&[[f64; 2]]> {
        Limits(&self.joint_limits)
    }

    /// Checks array sizes and that every number is finite and physical.
    pub fn validate(&self) -> Result<()> {
        let n = self.n();
        for (name, v) in [
            ("link_after", &self.link_after),
            ("thickness", &self.thickness),
            ("mass", &self.mass),
            ("lower_tension", &self.lower_tension),
        ] {
            if v.len() != n {
                return Err(bad(
                    name.into(),
                    format!("has {} entries for {n} joints", v.len()),
                ));
            }
        }
        if self.joint_limits.len() != n {
            return Err(bad("joint_limits".into(), format!("needs {n} entries")));
        }
        if self.holes.len() != 2 * n * (n + 1) * 4 {
            return Err(bad(
                "holes".into(),
                format!("needs shape (2n, n+1, 2, 2) = ({}, {}, 2, 2)", 2 * n, n + 1),
            ));
        }
        for i in 0..n {
            positive_length(format!("linkage[{i}].link_before"), self.link_before[i])?;
            positive_length(format!("linkage[{i}].link_after"), self.link_after[i])?;
            positive_length(format!("linkage[{i}].thickness"), self.thickness[i])?;
        }
        self.cable.validate()?;
        if !(self.gravity[0].is_finite() && self.gravity[1].is_finite()) {
            return Err(bad(
                "gravity".into(),
                format!("must be finite [gx, gy] (m/s^2), got {:?}", self.gravity),
            ));
        }
        if let Some(k) = self
            .holes
            .iter()
            .position(|v| !(v.is_finite() && v.abs() <= MAX_LENGTH))
        {
            return Err(bad(
                "holes".into(),
                format!(
                    "every coordinate must be finite and within ±{MAX_LENGTH} m, got {} at flat index {k}",
                    self.holes[k]
                ),
            ));
        }
        Ok(())
    }

    /// The same robot with other hole positions (flat `(2n, n+1, 2, 2)`, m).
    pub fn with_holes(&self, holes: &[f64]) -> Result<PlanarView> {
        let mut r = self.clone();
        r.holes = holes.to_vec();
        r.validate()?;
        Ok(r)
    }

    /// Hole positions after the paper's "error on disk i's holes": the hole
    /// height of pair `i` grows by `dh[i]` (m) on every face that pair crosses
    /// (upper `y += dh`, lower `y -= dh`). Writes into `out` (flat holes).
    pub fn hole_height_error_into(&self, dh: &[f64], out: &mut [f64]) {
        out.copy_from_slice(&self.holes);
        let n = self.n();
        for c in 0..2 * n {
            let pair = c / 2;
            let sign = if c % 2 == 0 { 1.0 } else { -1.0 };
            for d in 0..=pair + 1 {
                for f in 0..2 {
                    out[self.hole_index(c, d, f) + 1] += sign * dh[pair];
                }
            }
        }
    }

    /// Straight length of the whole arm (m): the tip X at theta = 0.
    pub fn straight_length(&self) -> f64 {
        (0..self.n())
            .map(|i| self.link_before[i] + self.link_after[i] + self.thickness[i])
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ArmGeometry;

    #[test]
    fn paper_robot_matches_table_1() {
        let r = PlanarView::paper();
        assert_eq!(r.n(), 3);
        assert!((r.straight_length() - 0.228).abs() < 1e-15);
        assert_eq!(ArmGeometry::<f64>::hole(&r, 0, 0, 1), [0.0, 0.030]);
        assert_eq!(ArmGeometry::<f64>::hole(&r, 3, 2, 0), [0.0, -0.028]);
        assert_eq!(ArmGeometry::<f64>::hole(&r, 4, 3, 1), [0.0, 0.026]);
        // masses 50, 10, 5 g on the lower cables of disks 1, 2, 3
        let g = 9.80665;
        for (t, m) in r.lower_tension.iter().zip([0.050, 0.010, 0.005]) {
            assert!((t - m * g).abs() < 1e-12);
        }
    }

    #[test]
    fn rejects_non_physical_and_unknown() {
        let base = "[[linkage]]\nlink_before = 0.033\nlink_after = 0.033\nthickness = 0.01\nhole_height = 0.03\n";
        assert!(PlanarView::from_toml(base).is_ok());
        let neg = base.replace("link_after = 0.033", "link_after = -0.033");
        let e = PlanarView::from_toml(&neg).unwrap_err().to_string();
        assert!(e.contains("linkage[0].link_after"), "{e}");
        let unk = format!("{base}colour = 1\n");
        let e = PlanarView::from_toml(&unk).unwrap_err().to_string();
        assert!(e.contains("colour"), "{e}");
        let g = format!("gravity = [0, nan]\n{base}");
        let e = PlanarView::from_toml(&g).unwrap_err().to_string();
        assert!(e.contains("gravity"), "{e}");
        let g = format!("gravity = [0, -9.81]\n{base}");
        assert_eq!(PlanarView::from_toml(&g).unwrap().gravity, [0.0, -9.81]);
        let nan = base.replace("0.03\n", "nan\n");
        let e = PlanarView::from_toml(&nan).unwrap_err().to_string();
        assert!(e.contains("hole_height"), "{e}");
        let e = PlanarView::from_toml(&format!("n = 2\n{base}"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("`n`"), "{e}");
    }

    #[test]
    fn stretch_feed_forward_defaults_to_true_and_names_its_field() {
        let base = "[cable]\nyoungs_modulus = 1.8e11\ndiameter = 0.18e-3\n[[linkage]]\nlink_before = 0.033\nlink_after = 0.033\nthickness = 0.01\nhole_height = 0.03\n";
        let r = PlanarView::from_toml(base).unwrap();
        assert!(r.cable.stretch_feed_forward);
        assert_eq!(r.cable.fed_forward(), r.cable.compliance());
        let rigid = base.replace(
            "diameter = 0.18e-3\n",
            "diameter = 0.18e-3\nstretch_feed_forward = false\n",
        );
        let r = PlanarView::from_toml(&rigid).unwrap();
        assert!(!r.cable.stretch_feed_forward);
        assert_eq!(r.cable.fed_forward(), 0.0);
        let bad = base.replace(
            "diameter = 0.18e-3\n",
            "diameter = 0.18e-3\nstretch_feed_forward = 1\n",
        );
        let e = PlanarView::from_toml(&bad).unwrap_err().to_string();
        assert!(e.contains("stretch_feed_forward"), "{e}");
    }

    #[test]
    fn routing_length_is_optional_and_validated() {
        let base = "[cable]\nyoungs_modulus = 1.8e11\ndiameter = 0.18e-3\n[[linkage]]\nlink_before = 0.033\nlink_after = 0.033\nthickness = 0.01\nhole_height = 0.03\n";
        assert_eq!(
            PlanarView::from_toml(base).unwrap().cable.routing_length,
            0.0
        );
        let with = base.replace(
            "diameter = 0.18e-3\n",
            "diameter = 0.18e-3\nrouting_length = 0.5\n",
        );
        assert_eq!(
            PlanarView::from_toml(&with).unwrap().cable.routing_length,
            0.5
        );
        let neg = with.replace("0.5", "-0.5");
        let e = PlanarView::from_toml(&neg).unwrap_err().to_string();
        assert!(e.contains("cable.routing_length"), "{e}");
    }

    #[test]
    fn explicit_holes_equal_hole_height() {
        let a = "[[linkage]]\nlink_before = 0.033\nlink_after = 0.033\nthickness = 0.01\nhole_height = 0.03\n";
        let b = "[[linkage]]\nlink_before = 0.033\nlink_after = 0.033\nthickness = 0.01\nupper_holes = [[0, 0.03], [0, 0.03], [0, 0.03]]\nlower_holes = [[0, -0.03], [0, -0.03], [0, -0.03]]\n";
        assert_eq!(
            PlanarView::from_toml(a).unwrap(),
            PlanarView::from_toml(b).unwrap()
        );
    }
}
