//! The plant's effects by name, and the rule that sizes each one's block of
//! the flat parameter vector (`docs/model.md`, "Parameters"). Which effects
//! an arm has, in which order and with which sizes, is data of its kind
//! ([`crate::kinds::KindInfo::layout`]); the plant reads it from there.

/// The effects of the library, by name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Effect {
    /// `s`: realised `= L_ref + (1 + s)(delivered - L_ref) + o` (1).
    ActuationScale,
    /// `o` per position cable (m).
    CableOffset,
    /// Planar: the holes of the cables ending at disk `i` moved along their
    /// local `y`, position cable `+dh_i`, force cable `-dh_i` (m, one per disk).
    HoleHeight,
    /// Spatial: every hole of the position cables moved, `[x, y, z]` in its face frame (m).
    HolePosition,
    /// Planar: `link_before[1]` and every `link_after` lengthened (m, `n + 1`);
    /// spatial: every joint offset, then every disk's `link_after` moved by a 3-vector (m).
    LinkLength,
    /// Compliance `kappa >= 0` of the position cables (1/N).
    CableElasticity,
    /// Clearance `cl` of the holes beside every bend (m).
    HoleClearance,
    /// The clearance's transition width, `w = 0.01 rad + dw` (rad).
    ClearanceWidth,
    /// The instrument frame: planar `alpha, fx, fy`; spatial rotation vector, translation (rad, m).
    FrameMisalignment,
    /// The measured point in the end frame (m; 2 planar, 3 spatial).
    TipOffset,
    /// Dead-band half-width `b >= 0` per position cable (m).
    Backlash,
    /// Spatial: every joint axis tilted by two angles (rad).
    JointAxis,
    /// Coulomb friction `mu` of every cable in every hole (1;
    /// `docs/model.md`, "Friction in the holes", [`crate::friction`]).
    CableFriction,
    /// Elastic arms: a relative change `s > -1` of every joint spring of a
    /// segment, `k_j -> (1 + s) k_j` (1, one per segment: the joints between
    /// consecutive cable terminations, [`crate::plant::segments`]).
    JointStiffness,
    /// Spatial elastic arms: every hole of a commanded cable rotated by an
    /// angle about its disk's backbone axis `x` (rad, one per commanded cable).
    CableAngle,
}

impl Effect {
    pub fn name(self) -> &'static str {
        match self {
            Effect::ActuationScale => "actuation_scale",
            Effect::CableOffset => "cable_offset",
            Effect::HoleHeight => "hole_height",
            Effect::HolePosition => "hole_position",
            Effect::LinkLength => "link_length",
            Effect::CableElasticity => "cable_elasticity",
            Effect::HoleClearance => "hole_clearance",
            Effect::ClearanceWidth => "clearance_width",
            Effect::FrameMisalignment => "frame_misalignment",
            Effect::TipOffset => "tip_offset",
            Effect::Backlash => "backlash",
            Effect::JointAxis => "joint_axis",
            Effect::CableFriction => "cable_friction",
            Effect::JointStiffness => "joint_stiffness",
            Effect::CableAngle => "cable_angle",
        }
    }
}

/// How many parameters an effect's block holds, by a rule over the model's
/// structure (`n` joints, `k` disks, `m` position cables).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Size {
    /// One number.
    One,
    /// One per position cable (`m`).
    PerPositionCable,
    /// One per disk (`k`): a coherent group of holes each.
    PerDisk,
    /// The three coordinates of every hole of every position cable.
    PerPositionHoleCoord,
    /// The links as lengths along each one's `x`: the base's offset to joint
    /// 1 and every disk's `link_after` (`1 + k`; planar).
    LinkLengths,
    /// The links as 3-vectors: every joint offset, then every disk's
    /// `link_after` (`3 (n + k)`; spatial).
    LinkVectors,
    /// The instrument frame: one per task component (3 or 6).
    Instrument,
    /// A point in the end frame: one per position dimension (2 or 3).
    Point,
    /// Two tilt angles per joint (`2 n`).
    PerJointTilt,
    /// One per segment of an elastic arm (the joints between cable
    /// terminations, `crate::plant::segments`).
    PerSegment,
}
