//! The one arm model (`docs/model.md`, "The arm model"): a chain of
//! revolute joints about axes in 3-D, disks with holes anywhere on their
//! faces, and per cable the disk it ends at and its control mode. Both robot
//! files read into it: a spatial file (`kind = "spatial"`, `docs/spatial.md`)
//! as written, a planar file (`docs/model.md`) as the case with every axis
//! along `z`, every offset and hole in the `x`–`y` plane, and its cables in
//! pairs (upper: position-controlled; lower: force-controlled at the file's
//! lower tension). The kind says which task space the arm is measured in
//! (planar `[x, y, phi]`, spatial `[x, y, z, rx, ry, rz]`) and lets the
//! planar closed forms serve it. SI units.

use crate::error::{CdsmError, Result};
use crate::kinds::{HoleGrouping, Kind};
use crate::limits::Limits;
use crate::robot::{CableMaterial, PlanarView};
use crate::robot_file::{
    bad, coordinates, from_table, joint_limits, non_negative, positive, positive_length,
    robot_name, toml_table, Exact, MAX_LENGTH,
};
use serde::Deserialize;

/// A group of hole coordinates that one error moves together: `coords`
/// index [`Model::flat_holes`], each moved by `coef` times the group's error
/// if `coherent` (one number for the group), each by its own error otherwise.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct HoleGroup {
    pub coords: Vec<usize>,
    pub coefs: Vec<f64>,
    pub coherent: bool,
}

/// The facts derived from one model's structure that algorithms and reports
/// ask instead of the kind: the cables by control mode, whether they come in
/// upper/lower pairs, and how hole errors group ([`HoleGroup`], by the kind's
/// [`HoleGrouping`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Structure {
    /// The position-controlled cables (file order).
    pub position: Vec<usize>,
    /// The force-controlled cables (file order).
    pub force: Vec<usize>,
    /// Cables in pairs ending at each disk in turn, position then force (a
    /// planar file's upper and lower cables).
    pub pairs: bool,
    /// The hole groups.
    pub hole_groups: Vec<HoleGroup>,
}

/// One revolute joint: a unit `axis` and the `offset` from the previous frame
/// to the joint (m), both in the previous frame; `limits` (rad).
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    pub axis: [f64; 3],
    pub offset: [f64; 3],
    pub limits: [f64; 2],
    /// The joint's spring (N m/rad, `docs/model.md` "Elastic arms"; 0: a
    /// free joint, today's) and its rest angle (rad).
    pub stiffness: f64,
    pub rest: f64,
}

/// One disk and the joints before it.
#[derive(Debug, Clone, PartialEq)]
pub struct Disk {
    /// Indices of its joints (consecutive).
    pub joints: std::ops::Range<usize>,
    /// Last joint -> proximal face (m, in the last joint's frame).
    pub link_after: [f64; 3],
    /// Thickness along the local x axis (m).
    pub thickness: f64,
    /// Radius (m).
    pub radius: f64,
    /// Mass (kg) and centre of mass (m, proximal-face frame).
    pub mass: f64,
    pub com: [f64; 3],
}

/// How a cable is driven.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Its length is commanded.
    Position,
    /// Its tension is held (N).
    Force,
    /// Its actuator moves by a commanded displacement (m, positive = pull)
    /// through a series stiffness ([`Actuator`]; `docs/model.md`, "Elastic
    /// arms"): read by the elastic statics ([`crate::elastic`]).
    Displacement,
}

/// The actuator of a displacement cable (`docs/model.md`, "Cables: position,
/// force, displacement"); a position cable's holds its pretension only
/// (`docs/model.md`, "Settling"), a force cable's the defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Actuator {
    /// The actuator's stiffness `k_a` (N/m; infinite: rigid).
    pub stiffness: f64,
    /// The tension at `d = 0` in the rest pose (N); a position cable's: its
    /// tension at the commanded length (N, its command shortened by
    /// `P (L + L_r) / (E A)`).
    pub pretension: f64,
    /// The cap of the tension (N; infinite: none).
    pub max_tension: f64,
}

impl Default for Actuator {
    fn default() -> Self {
        Actuator {
            stiffness: f64::INFINITY,
            pretension: 0.0,
            max_tension: f64::INFINITY,
        }
    }
}

/// One cable: the disk it ends at (1-based), its mode, its tension (force
/// cables, N) and its holes in face frames (`2 end + 1` points: base face b,
/// then faces a and b of disks `1..=end`, m).
#[derive(Debug, Clone, PartialEq)]
pub struct Cable {
    pub end: usize,
    pub mode: Mode,
    pub tension: f64,
    pub holes: Vec<[f64; 3]>,
    /// A displacement cable's actuator (the default for the other modes).
    pub actuator: Actuator,
}

/// How the plant settles a rigid arm with more position cables than joints
/// ([`Model::redundant_settle`], `docs/model.md`, "Settling").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RedundantSettle {
    /// At the minimum of the potential of its position cables as springs of
    /// `E A / (L + L_r)` (the stated cable), gravity and force cables.
    Potential,
    /// At the unweighted least squares on the cable lengths (the cable not
    /// stated).
    LeastSquares,
}

impl RedundantSettle {
    /// Its name in Python and the docs.
    pub fn name(self) -> &'static str {
        match self {
            RedundantSettle::Potential => "potential",
            RedundantSettle::LeastSquares => "least_squares",
        }
    }
}

/// A cable-driven serpentine arm of either kind.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    pub name: String,
    pub kind: Kind,
    pub joints: Vec<Joint>,
    pub disks: Vec<Disk>,
    pub base_radius: f64,
    /// Gravity (m/s², base frame).
    pub gravity: [f64; 3],
    pub cables: Vec<Cable>,
    pub cable: CableMaterial,
    /// Every disk's radius (and the base's) is the largest `|y|` of the holes
    /// on it, kept so when the holes move (a planar file gives no radii).
    pub radii_from_holes: bool,
    /// [`Model::planar`], made when first asked.
    view: ViewCache,
}

/// The planar view of a model once made ([`Model::planar`]): derived data,
/// so a clone starts without it and equality ignores it. A model whose
/// numbers change in place after its view was asked must be rebuilt (every
/// `with_*` returns a new model).
#[derive(Default)]
struct ViewCache(std::sync::OnceLock<Option<Box<PlanarView>>>);

impl Clone for ViewCache {
    fn clone(&self) -> Self {
        ViewCache::default()
    }
}

impl PartialEq for ViewCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for ViewCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ViewCache")
    }
}

/// The face of hole `i` of a cable (`0`: base face b; `2d - 1`, `2d`: faces
/// a, b of disk `d`) as `(disk, face)` of the planar layout `(2n, n+1, 2, 2)`.
pub(crate) fn pair_slot(i: usize) -> (usize, usize) {
    if i == 0 {
        (0, 1)
    } else {
        (i.div_ceil(2), 1 - i % 2)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    kind: String,
    name: Option<String>,
    gravity: Option<Vec<f64>>,
    cable: Option<MaterialFile>,
    base: BaseFile,
    linkage: Vec<LinkageFile>,
    cables: Vec<CableFile>,
    backbone: Option<BackboneFile>,
}

/// A `[backbone]`: a solid elastic rod lumped into the joints
/// (`docs/model.md`, "Joint springs").
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct BackboneFile {
    youngs_modulus: f64,
    shear_modulus: Option<f64>,
    radius: f64,
    segments: Vec<SegmentFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SegmentFile {
    length: f64,
    links: i64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    youngs_modulus: f64,
    diameter: f64,
    #[serde(default)]
    routing_length: f64,
    #[serde(default = "feed_forward_default")]
    stretch_feed_forward: bool,
}

/// The planar shorthand of a robot file (`docs/model.md`): per linkage one
/// joint about `z` and a pair of cables, desugared by [`Model::from_planar`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "RobotFile")] // the name its errors have shown
struct ShorthandFile {
    #[allow(dead_code)] // "planar" or none: the kind is read before
    kind: Option<String>,
    name: Option<String>,
    n: Option<usize>,
    gravity: Option<Exact<2>>,
    cable: Option<MaterialFile>,
    linkage: Vec<ShorthandLinkage>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, rename = "LinkageFile")]
struct ShorthandLinkage {
    link_before: f64,
    link_after: f64,
    thickness: f64,
    hole_height: Option<f64>,
    upper_holes: Option<Vec<Exact<2>>>,
    lower_holes: Option<Vec<Exact<2>>>,
    #[serde(default)]
    mass: f64,
    #[serde(default)]
    lower_tension: f64,
    joint_limits: Option<Exact<2>>,
}

/// A robot file's `[cable] stretch_feed_forward` when it does not say.
fn feed_forward_default() -> bool {
    true
}

/// A `[cable]` table as the material (not yet validated), the default
/// material without one.
fn material(c: Option<MaterialFile>) -> CableMaterial {
    c.map_or_else(CableMaterial::default, |c| CableMaterial {
        youngs_modulus: c.youngs_modulus,
        diameter: c.diameter,
        routing_length: c.routing_length,
        stretch_feed_forward: c.stretch_feed_forward,
        stated: true,
    })
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BaseFile {
    radius: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct JointFile {
    axis: Exact<3>,
    offset: Option<Exact<3>>,
    limits: Option<Exact<2>>,
    stiffness: Option<f64>,
    rest: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LinkageFile {
    joints: Vec<JointFile>,
    link_after: Exact<3>,
    thickness: f64,
    radius: f64,
    #[serde(default)]
    mass: f64,
    com: Option<Exact<3>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CableFile {
    end: usize,
    mode: String,
    tension: Option<f64>,
    radius: Option<f64>,
    angle: Option<f64>,
    holes: Option<Vec<Exact<3>>>,
    stiffness: Option<f64>,
    pretension: Option<f64>,
    max_tension: Option<f64>,
}

/// The numbers of an arm its planar view reads (m; joint axes unit): the
/// model's own, or a plant's moved ones (`crate::chain::ArmNumbers`).
pub struct PlanarNumbers<'a> {
    pub axis: &'a [[f64; 3]],
    pub offset: &'a [[f64; 3]],
    pub link_after: &'a [[f64; 3]],
    pub thickness: &'a [f64],
    /// Per cable, its holes (as [`Cable::holes`]).
    pub holes: &'a [Vec<[f64; 3]>],
}

/// A model's own numbers as [`PlanarNumbers`] read them.
struct OwnNumbers {
    axis: Vec<[f64; 3]>,
    offset: Vec<[f64; 3]>,
    link_after: Vec<[f64; 3]>,
    thickness: Vec<f64>,
    holes: Vec<Vec<[f64; 3]>>,
}

impl OwnNumbers {
    fn numbers(&self) -> PlanarNumbers<'_> {
        PlanarNumbers {
            axis: &self.axis,
            offset: &self.offset,
            link_after: &self.link_after,
            thickness: &self.thickness,
            holes: &self.holes,
        }
    }
}

/// Within this (of a unit axis's components) a joint's axis is
/// perpendicular to, or along, its frame's `x` (the backbone): a bending or
/// a torsion joint of a `[backbone]`.
pub const AXIS_CLASS_TOL: f64 = 1e-9;

/// How a `[backbone]` reads a joint (`docs/model.md`, "Joint springs").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisClass {
    /// The axis is perpendicular to the backbone: `k = E I / l`.
    Bending,
    /// The axis lies along the backbone: `k = G J / l`.
    Torsion,
}

/// The class of a unit `axis` in its joint's frame, `None` for neither.
pub fn axis_class(a: [f64; 3]) -> Option<AxisClass> {
    if a[0].abs() <= AXIS_CLASS_TOL {
        Some(AxisClass::Bending)
    } else if a[1].hypot(a[2]) <= AXIS_CLASS_TOL {
        Some(AxisClass::Torsion)
    } else {
        None
    }
}

/// A `[backbone]` table, its errors named under `backbone.`.
fn backbone_file(t: toml::Table) -> Result<BackboneFile> {
    from_table(t).map_err(|e| match e {
        CdsmError::Robot { field, problem } if field == "<file>" => bad("backbone".into(), problem),
        CdsmError::Robot { field, problem } => bad(format!("backbone.{field}"), problem),
        other => other,
    })
}

/// The error of segments whose links do not add up to the disks.
fn links_error(links: usize, disks: usize) -> CdsmError {
    bad(
        "backbone.segments".into(),
        format!(
            "the segments' links add up to {links} (or more) but the arm has {disks} disks (one \
             link per disk, base to tip)"
        ),
    )
}

/// A number of a robot file's table (an integer is taken as it is).
fn number(field: String, v: &toml::Value) -> Result<f64> {
    match v {
        toml::Value::Float(x) => Ok(*x),
        toml::Value::Integer(i) => Ok(*i as f64),
        other => Err(bad(
            field,
            format!("must be a number, got {}", other.type_str()),
        )),
    }
}

fn finite3(field: &str, v: [f64; 3]) -> Result<[f64; 3]> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(v)
    } else {
        Err(bad(field.into(), format!("non-finite value in {v:?}")))
    }
}

/// The unit vector along `a`: `a` itself when its length is 1 to within
/// rounding (a file written by [`Model::to_toml`] reads back to the same
/// bits), else `a` divided by its length, computed without overflow;
/// `None` for a zero vector.
fn unit_axis(a: [f64; 3]) -> Option<[f64; 3]> {
    let s = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    if s <= 0.0 || !s.is_finite() {
        return None;
    }
    let u = a.map(|v| v / s);
    let nu = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    if (s * nu - 1.0).abs() <= 4.0 * f64::EPSILON {
        return Some(a);
    }
    Some(u.map(|v| v / nu))
}

/// A float as TOML (its shortest round-trip form).
fn toml_f(v: f64) -> String {
    format!("{v:?}")
}

/// A TOML array of floats.
fn toml_fs(v: &[f64]) -> String {
    format!(
        "[{}]",
        v.iter().map(|x| toml_f(*x)).collect::<Vec<_>>().join(", ")
    )
}

/// `text` as a TOML basic string: UTF-8 as it is, `"` and `\` escaped,
/// control characters as `\uXXXX`.
pub fn toml_string(text: &str) -> String {
    let mut out = String::with_capacity(text.len() + 2);
    out.push('"');
    for ch in text.chars() {
        match ch {
            '"' | '\\' => {
                out.push('\\');
                out.push(ch);
            }
            c if (c as u32) < 0x20 || c as u32 == 0x7F => {
                out.push_str(&format!("\\u{:04X}", c as u32));
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// The `kind` of a robot description: `"planar"` (the default) or `"spatial"`.
pub fn kind_of(text: &str) -> Result<String> {
    kind_of_table(&toml_table(text)?)
}

/// [`kind_of`] of a description given as its table.
fn kind_of_table(table: &toml::Table) -> Result<String> {
    let kind = match table.get("kind") {
        None => "planar".to_string(),
        Some(v) => v
            .as_str()
            .ok_or_else(|| bad("kind".into(), format!("must be a string, got {v:?}")))?
            .to_string(),
    };
    if kind != "planar" && kind != "spatial" {
        return Err(bad(
            "kind".into(),
            format!("must be \"planar\" or \"spatial\", got {kind:?}"),
        ));
    }
    Ok(kind)
}

impl Model {
    /// Parses and validates a robot description of either kind: the general
    /// form as written, or a planar file's shorthand desugared
    /// ([`Model::from_planar`]).
    pub fn from_toml(text: &str) -> Result<Model> {
        Model::from_table(toml_table(text)?)
    }

    /// Validates a robot description of either kind given as its table: a
    /// parsed file, or data built as one (the same fields, the same checks,
    /// the same field paths in errors; no text in between).
    pub fn from_table(table: toml::Table) -> Result<Model> {
        // a planar file in the shorthand has no [base] and no [[cables]]
        let general = table.contains_key("base") || table.contains_key("cables");
        match kind_of_table(&table)?.as_str() {
            "planar" if !general => Model::from_planar_table(table),
            _ => Model::from_general_table(table),
        }
    }

    /// A planar description: the shorthand read ([`Model::shorthand`]) and
    /// desugared ([`Model::from_planar`]), with the joint springs of its `[[linkage]]` tables (`stiffness`,
    /// `rest_angle`) or of its `[backbone]` (`docs/model.md`, "Joint springs").
    fn from_planar_table(mut table: toml::Table) -> Result<Model> {
        let backbone = match table.remove("backbone") {
            None => None,
            Some(toml::Value::Table(t)) => Some(backbone_file(t)?),
            Some(v) => {
                return Err(bad(
                    "backbone".into(),
                    format!("must be a table, got {}", v.type_str()),
                ))
            }
        };
        let mut given = Vec::new();
        if let Some(toml::Value::Array(links)) = table.get_mut("linkage") {
            for (i, l) in links.iter_mut().enumerate() {
                let Some(l) = l.as_table_mut() else {
                    continue; // the planar reader names it
                };
                let mut take = |key: &str| -> Result<Option<f64>> {
                    match l.remove(key) {
                        None => Ok(None),
                        Some(v) => number(format!("linkage[{i}].{key}"), &v).map(Some),
                    }
                };
                given.push((take("stiffness")?, take("rest_angle")?));
            }
        }
        let mut model = Model::from_planar(&Model::shorthand(table)?);
        let fields = (0..model.n()).map(|i| format!("linkage[{i}]")).collect();
        model.set_springs(&given, fields, "stiffness", "rest_angle", backbone)?;
        model.check_enough_cables()?;
        Ok(model)
    }

    /// Reads and checks the planar shorthand (without its joint springs) as
    /// the planar view it describes: lengths, masses, lower tensions, joint
    /// limits and the holes of each linkage's cable pair (`hole_height`, or
    /// `upper_holes` and `lower_holes`), errors naming the field.
    fn shorthand(table: toml::Table) -> Result<PlanarView> {
        let file: ShorthandFile = from_table(table)?;
        let n = file.linkage.len();
        if n == 0 {
            return Err(bad(
                "linkage".into(),
                "at least one [[linkage]] is required",
            ));
        }
        if let Some(declared) = file.n {
            if declared != n {
                return Err(bad(
                    "n".into(),
                    format!("declares {declared} joints but {n} [[linkage]] tables are given"),
                ));
            }
        }
        let mut robot = PlanarView {
            name: robot_name(file.name)?,
            link_before: Vec::with_capacity(n),
            link_after: Vec::with_capacity(n),
            thickness: Vec::with_capacity(n),
            mass: Vec::with_capacity(n),
            lower_tension: Vec::with_capacity(n),
            joint_limits: Vec::with_capacity(n),
            holes: vec![0.0; 2 * n * (n + 1) * 4],
            cable: material(file.cable),
            gravity: file.gravity.map_or([0.0, 0.0], |g| g.0),
        };
        for (i, l) in file.linkage.iter().enumerate() {
            let f = |name: &str| format!("linkage[{i}].{name}");
            robot
                .link_before
                .push(positive_length(f("link_before"), l.link_before)?);
            robot
                .link_after
                .push(positive_length(f("link_after"), l.link_after)?);
            robot
                .thickness
                .push(positive_length(f("thickness"), l.thickness)?);
            robot.mass.push(non_negative(f("mass"), l.mass, "kg")?);
            robot
                .lower_tension
                .push(non_negative(f("lower_tension"), l.lower_tension, "N")?);
            let lim = joint_limits(f("joint_limits"), l.joint_limits)?;
            robot.joint_limits.push(lim);
        }
        for (i, l) in file.linkage.iter().enumerate() {
            let f = |name: &str| format!("linkage[{i}].{name}");
            let along = 2 * i + 3; // base face b, then faces a, b of disks 1..=i+1
            let explicit = (l.upper_holes.as_ref(), l.lower_holes.as_ref());
            let (upper, lower): (Vec<[f64; 2]>, Vec<[f64; 2]>) = match (l.hole_height, explicit) {
                (Some(h), (None, None)) => {
                    let h = positive_length(f("hole_height"), h)?;
                    (vec![[0.0, h]; along], vec![[0.0, -h]; along])
                }
                (None, (Some(u), Some(w))) => (
                    u.iter().map(|p| p.0).collect(),
                    w.iter().map(|p| p.0).collect(),
                ),
                _ => {
                    return Err(bad(
                        f("hole_height"),
                        "give either hole_height or both upper_holes and lower_holes",
                    ))
                }
            };
            for (side, pts) in [("upper_holes", &upper), ("lower_holes", &lower)] {
                if pts.len() != along {
                    return Err(bad(
                        f(side),
                        format!(
                            "needs {along} [x, y] points (base face b, then faces a and b of disks 1..{}), got {}",
                            i + 1,
                            pts.len()
                        ),
                    ));
                }
                for (j, p) in pts.iter().enumerate() {
                    coordinates(format!("linkage[{i}].{side}[{j}]"), *p)?;
                }
            }
            for (s, pts) in [upper, lower].iter().enumerate() {
                let c = 2 * i + s;
                for (j, p) in pts.iter().enumerate() {
                    let (d, face) = pair_slot(j);
                    let k = robot.hole_index(c, d, face);
                    robot.holes[k] = p[0];
                    robot.holes[k + 1] = p[1];
                }
            }
        }
        robot.validate()?;
        Ok(robot)
    }

    /// Sets every joint's spring (`docs/model.md`, "Joint springs"): as
    /// `given` (per joint `(stiffness, rest)`, N m/rad and rad, each
    /// optional: a free joint at rest 0), or derived from a `backbone`
    /// (a joint's stiffness beside it is refused); rest angles within the
    /// joint's limits. `fields` name the joints' tables.
    fn set_springs(
        &mut self,
        given: &[(Option<f64>, Option<f64>)],
        fields: Vec<String>,
        stiffness_key: &str,
        rest_key: &str,
        backbone: Option<BackboneFile>,
    ) -> Result<()> {
        for (j, ((k, rest), f)) in given.iter().zip(&fields).enumerate() {
            let joint = &mut self.joints[j];
            if let Some(k) = k {
                joint.stiffness = non_negative(format!("{f}.{stiffness_key}"), *k, "N m/rad")?;
            }
            let r = rest.unwrap_or(0.0);
            let [lo, hi] = joint.limits;
            if !(r.is_finite() && lo <= r && r <= hi) {
                return Err(bad(
                    format!("{f}.{rest_key}"),
                    format!("{r} rad is outside the joint's limits [{lo}, {hi}] rad"),
                ));
            }
            joint.rest = r;
        }
        let Some(b) = backbone else {
            return Ok(());
        };
        if let Some(f) = given.iter().zip(&fields).find(|((k, _), _)| k.is_some()) {
            return Err(bad(
                format!("{}.{stiffness_key}", f.1),
                "give either joint stiffnesses or a [backbone], not both (the backbone derives \
                 every joint's stiffness)",
            ));
        }
        let e = positive("backbone.youngs_modulus".into(), b.youngs_modulus, "Pa")?;
        let g = b
            .shear_modulus
            .map(|g| positive("backbone.shear_modulus".into(), g, "Pa"))
            .transpose()?;
        let r = positive_length("backbone.radius".into(), b.radius)?;
        if b.segments.is_empty() {
            return Err(bad(
                "backbone.segments".into(),
                "at least one segment is needed",
            ));
        }
        let mut link = Vec::new(); // the link length of every disk, base to tip
        for (i, sg) in b.segments.iter().enumerate() {
            let f = format!("backbone.segments[{i}]");
            let length = positive_length(format!("{f}.length"), sg.length)?;
            if sg.links < 1 {
                return Err(bad(
                    format!("{f}.links"),
                    format!("must be a whole number of disks >= 1, got {}", sg.links),
                ));
            }
            let links = sg.links as usize;
            if link.len() + links > self.disks.len() {
                return Err(links_error(link.len() + links, self.disks.len()));
            }
            link.extend(std::iter::repeat_n(length / links as f64, links));
        }
        if link.len() != self.disks.len() {
            return Err(links_error(link.len(), self.disks.len()));
        }
        let area = std::f64::consts::PI * r.powi(4) / 4.0; // I, m^4
        for (d, disk) in self.disks.iter().enumerate() {
            for j in disk.joints.clone() {
                let a = self.joints[j].axis;
                let f = &fields[j];
                self.joints[j].stiffness = match axis_class(a) {
                    Some(AxisClass::Bending) => e * area / link[d],
                    Some(AxisClass::Torsion) => match g {
                        Some(g) => g * 2.0 * area / link[d],
                        None => {
                            return Err(bad(
                                "backbone.shear_modulus".into(),
                                format!(
                                    "missing ({f} is a torsion joint: its axis lies along the \
                                     backbone)"
                                ),
                            ))
                        }
                    },
                    None => {
                        return Err(bad(
                            format!("{f}.axis"),
                            format!(
                                "a [backbone] derives bending joints (axis perpendicular to the \
                                 backbone, the joint frame's x) and torsion joints (axis along \
                                 x); {a:?} is neither"
                            ),
                        ))
                    }
                };
            }
        }
        Ok(())
    }

    /// `docs/model.md`, "Settling": how the plant settles a rigid arm
    /// (no joint springs, no displacement cables) with more position cables
    /// than joints; `None` for any other arm (its settle has one answer, or
    /// is the elastic statics). At the minimum of the potential of its
    /// cables as springs where the robot states its cable
    /// ([`CableMaterial::stated`]: their stiffness is the physics), else in
    /// least squares on the lengths (cdsm's default cable is a placeholder,
    /// e.g. for a CASPR import, which gives none).
    pub fn redundant_settle(&self) -> Option<RedundantSettle> {
        if self.position_cables().len() <= self.n() || self.is_elastic() {
            return None;
        }
        Some(if self.cable.stated {
            RedundantSettle::Potential
        } else {
            RedundantSettle::LeastSquares
        })
    }

    /// `docs/model.md`, "Settling": a position cable's pretension acts
    /// through its stretch where the cables, not the statics, fix the
    /// tensions (more position cables than joints, a rigid arm, its cable
    /// stated).
    fn check_position_pretension(&self) -> Result<()> {
        let settle = self.redundant_settle();
        if settle == Some(RedundantSettle::Potential) {
            return Ok(());
        }
        match (0..self.cables.len()).find(|&c| {
            self.cables[c].mode == Mode::Position && self.cables[c].actuator.pretension != 0.0
        }) {
            Some(c) if settle == Some(RedundantSettle::LeastSquares) => Err(bad(
                format!("cables[{c}].pretension"),
                "a position cable's pretension needs the arm's cable stated (a [cable] table: \
                 its stretch under the pretension); without one the arm settles in least \
                 squares on the lengths (docs/model.md, \"Settling\")",
            )),
            Some(c) => Err(bad(
                format!("cables[{c}].pretension"),
                "a position cable's pretension needs more position cables than joints on an \
                 arm without joint springs or displacement cables (docs/model.md, \"Settling\")",
            )),
            None => Ok(()),
        }
    }

    /// `docs/model.md`, "Enough cables": at least as many position or
    /// displacement cables as joints of stiffness 0 (today's rule, as many
    /// position cables as joints, for an arm without springs and
    /// displacement cables).
    fn check_enough_cables(&self) -> Result<()> {
        let m = self.position_cables().len();
        let commanded = m + self.displacement_cables().len();
        let free = self.joints.iter().filter(|j| j.stiffness == 0.0).count();
        if commanded >= free {
            return Ok(());
        }
        if free == self.n() && commanded == m {
            return Err(bad(
                "cables".into(),
                format!(
                    "{m} position-controlled cables cannot determine {} joints (at least as many are needed)",
                    self.n()
                ),
            ));
        }
        Err(bad(
            "cables".into(),
            format!(
                "{commanded} position or displacement cables for {free} joints without stiffness \
                 (at least as many commanded cables as free joints are needed)"
            ),
        ))
    }

    /// Whether the arm has anything of "Elastic arms" (`docs/model.md`): a
    /// joint spring, a rest angle other than 0, or a displacement cable.
    pub fn is_elastic(&self) -> bool {
        self.joints
            .iter()
            .any(|j| j.stiffness != 0.0 || j.rest != 0.0)
            || self.cables.iter().any(|c| c.mode == Mode::Displacement)
    }

    /// Indices of the displacement cables (file order).
    pub fn displacement_cables(&self) -> Vec<usize> {
        (0..self.cables.len())
            .filter(|c| self.cables[*c].mode == Mode::Displacement)
            .collect()
    }

    /// The planar shorthand as the one model: joint `i` about `z` at the offset
    /// `(link_before[i], 0, 0)`, disk `i` at `link_after = (link_after[i], 0,
    /// 0)` with its mass at its centre `(thickness / 2, 0, 0)`; cable `2i`
    /// (upper) position-controlled and cable `2i + 1` (lower) force-controlled
    /// at `lower_tension[i]`, both ending at disk `i + 1`, their holes
    /// `(x, y, 0)`; gravity `(gx, gy, 0)`. A disk's radius is the largest
    /// `|y|` of its holes (the planar file has none).
    pub fn from_planar(robot: &PlanarView) -> Model {
        let n = robot.n();
        let hole = |c: usize, d: usize, f: usize| {
            let k = robot.hole_index(c, d, f);
            [robot.holes[k], robot.holes[k + 1], 0.0]
        };
        let cables: Vec<Cable> = (0..2 * n)
            .map(|c| {
                let end = c / 2 + 1;
                let mut holes = vec![hole(c, 0, 1)];
                for d in 1..=end {
                    holes.push(hole(c, d, 0));
                    holes.push(hole(c, d, 1));
                }
                let lower = c % 2 == 1;
                Cable {
                    end,
                    mode: if lower { Mode::Force } else { Mode::Position },
                    tension: if lower {
                        robot.lower_tension[c / 2]
                    } else {
                        0.0
                    },
                    holes,
                    actuator: Actuator::default(),
                }
            })
            .collect();
        let disks = (0..n)
            .map(|i| Disk {
                joints: i..i + 1,
                link_after: [robot.link_after[i], 0.0, 0.0],
                thickness: robot.thickness[i],
                radius: 0.0,
                mass: robot.mass[i],
                com: [robot.thickness[i] / 2.0, 0.0, 0.0],
            })
            .collect();
        let joints = (0..n)
            .map(|i| Joint {
                axis: [0.0, 0.0, 1.0],
                offset: [robot.link_before[i], 0.0, 0.0],
                limits: robot.joint_limits[i],
                stiffness: 0.0,
                rest: 0.0,
            })
            .collect();
        let mut model = Model {
            name: robot.name.clone(),
            kind: Kind::Planar,
            joints,
            disks,
            base_radius: 0.0,
            gravity: [robot.gravity[0], robot.gravity[1], 0.0],
            cables,
            cable: robot.cable.clone(),
            radii_from_holes: true,
            view: ViewCache::default(),
        };
        model.set_radii_from_holes();
        model
    }

    /// Sets every disk's radius (and the base's) to the largest `|y|` of
    /// the holes on it.
    fn set_radii_from_holes(&mut self) {
        let radius = |d: usize| {
            self.cables
                .iter()
                .filter(|c| c.end >= d)
                .flat_map(|c| {
                    let pts = if d == 0 {
                        &c.holes[..1]
                    } else {
                        &c.holes[2 * d - 1..=2 * d]
                    };
                    pts.iter().map(|h| h[1].abs())
                })
                .fold(0.0f64, f64::max)
        };
        let radii: Vec<f64> = (0..=self.disks.len()).map(radius).collect();
        self.base_radius = radii[0];
        for (disk, r) in self.disks.iter_mut().zip(&radii[1..]) {
            disk.radius = *r;
        }
    }

    /// The planar view of this arm with the numbers `nums` (the data of the
    /// planar closed forms and SIMD kernels; `docs/model.md`): link `i`
    /// before joint `i` is `offset[i][0]`, after it `link_after[i][0]`, the
    /// holes' `(x, y)` in the layout `(2n, n+1, 2, 2)` (slots that are no
    /// hole hold 0), the masses, lower tensions, joint limits, cable and
    /// in-plane gravity the model's. `None` when the structure does not fit
    /// the planar fast paths: a kind whose space is not the plane, a disk
    /// with other than one joint, an axis other than `z`, an offset, link or
    /// hole out of the plane, gravity with a `z`, or cables not in pairs
    /// (cable `2i` position- and `2i + 1` force-controlled, both ending at
    /// disk `i + 1`). The numbers are copied, no arithmetic.
    pub fn planar_view(&self, nums: &PlanarNumbers) -> Option<PlanarView> {
        if self.kind.dim() != 2 || self.planar_misfit(nums).is_some() {
            return None;
        }
        let n = self.n();
        let mut r = PlanarView {
            name: self.name.clone(),
            link_before: nums.offset.iter().map(|o| o[0]).collect(),
            link_after: nums.link_after.iter().map(|o| o[0]).collect(),
            thickness: nums.thickness.to_vec(),
            mass: self.disks.iter().map(|d| d.mass).collect(),
            lower_tension: (0..n).map(|i| self.cables[2 * i + 1].tension).collect(),
            joint_limits: self.joints.iter().map(|j| j.limits).collect(),
            holes: vec![0.0; 2 * n * (n + 1) * 4],
            cable: self.cable.clone(),
            gravity: [self.gravity[0], self.gravity[1]],
        };
        for (c, holes) in nums.holes.iter().enumerate() {
            for (i, h) in holes.iter().enumerate() {
                let (d, f) = pair_slot(i);
                let k = r.hole_index(c, d, f);
                r.holes[k] = h[0];
                r.holes[k + 1] = h[1];
            }
        }
        Some(r)
    }

    /// The first thing in `nums` (and the model's structure) that keeps an
    /// arm from the planar fast paths ([`Model::planar_view`]), as the field
    /// of a general-form robot file that says it and the problem; `None`
    /// when everything fits.
    fn planar_misfit(&self, nums: &PlanarNumbers) -> Option<(String, String)> {
        let along_x = |v: &[f64; 3]| v[1] == 0.0 && v[2] == 0.0;
        for (k, d) in self.disks.iter().enumerate() {
            if d.joints != (k..k + 1) {
                let problem = "a planar arm has one joint per linkage, joint i in linkage i";
                return Some((format!("linkage[{k}].joints"), problem.into()));
            }
            let field = |name: &str| format!("linkage[{k}].joints[0].{name}");
            if nums.axis[k] != [0.0, 0.0, 1.0] {
                let problem = format!(
                    "a planar arm's joints turn about z: must be [0.0, 0.0, 1.0], got {:?}",
                    nums.axis[k]
                );
                return Some((field("axis"), problem));
            }
            if !along_x(&nums.offset[k]) {
                let problem = format!(
                    "a planar arm's links lie along x: must be [x, 0.0, 0.0], got {:?}",
                    nums.offset[k]
                );
                return Some((field("offset"), problem));
            }
            if !along_x(&nums.link_after[k]) {
                let problem = format!(
                    "a planar arm's links lie along x: must be [x, 0.0, 0.0], got {:?}",
                    nums.link_after[k]
                );
                return Some((format!("linkage[{k}].link_after"), problem));
            }
        }
        if self.disks.len() != self.n() {
            let problem = "a planar arm has one joint per linkage";
            return Some(("linkage".into(), problem.into()));
        }
        if !self.in_pairs() {
            let problem = "a planar arm's cables come in pairs: cable 2i position- and 2i + 1 \
                           force-controlled, both ending at disk i + 1";
            return Some(("cables".into(), problem.into()));
        }
        for (c, holes) in nums.holes.iter().enumerate() {
            if let Some(i) = holes.iter().position(|h| h[2] != 0.0) {
                let problem = format!(
                    "a planar arm's holes lie in its plane: z must be 0.0, got {:?}",
                    holes[i]
                );
                return Some((format!("cables[{c}].holes[{i}]"), problem));
            }
        }
        if self.gravity[2] != 0.0 {
            let problem = "a planar arm's gravity lies in its plane";
            return Some(("gravity".into(), problem.into()));
        }
        None
    }

    /// [`Model::planar_view`] of the model's own numbers.
    fn own_planar_view(&self) -> Option<PlanarView> {
        self.planar_view(&self.own_numbers().numbers())
    }

    /// The model's own numbers, gathered for [`PlanarNumbers`].
    fn own_numbers(&self) -> OwnNumbers {
        OwnNumbers {
            axis: self.joints.iter().map(|j| j.axis).collect(),
            offset: self.joints.iter().map(|j| j.offset).collect(),
            link_after: self.disks.iter().map(|d| d.link_after).collect(),
            thickness: self.disks.iter().map(|d| d.thickness).collect(),
            holes: self.cables.iter().map(|c| c.holes.clone()).collect(),
        }
    }

    /// The same arm with another cable material (validated), stated
    /// ([`CableMaterial::stated`]).
    pub fn with_cable(&self, cable: CableMaterial) -> Result<Model> {
        cable.validate()?;
        let mut m = self.clone();
        m.cable = CableMaterial {
            stated: true,
            ..cable
        };
        Ok(m)
    }

    /// A robot file (TOML, SI units) that rebuilds this arm exactly: an arm
    /// read from the planar shorthand in it ([`Model::radii_from_holes`]),
    /// any other in the general form (explicit holes either way); every float in its shortest
    /// round-trip form, the name in any Unicode.
    pub fn to_toml(&self) -> String {
        let mut t = String::new();
        let w = &mut t;
        let line = |w: &mut String, s: String| {
            w.push_str(&s);
            w.push('\n');
        };
        line(
            w,
            "# written by cdsm (Robot.to_toml); SI units: m, kg, N, rad, Pa, m/s^2".into(),
        );
        // the form of the file: the planar shorthand (its kind the default)
        // for an arm read from it (its radii are its holes': the shorthand
        // gives none), else the general form, which names its kind
        let shorthand = self.radii_from_holes;
        if !shorthand {
            line(w, format!("kind = {}", toml_string(self.kind.name())));
        }
        line(w, format!("name = {}", toml_string(&self.name)));
        let g = &self.gravity[..self.kind.dim()];
        line(w, format!("gravity = {}", toml_fs(g)));
        line(w, String::new());
        if self.cable.stated {
            line(w, "[cable]".into());
            line(
                w,
                format!("youngs_modulus = {}", toml_f(self.cable.youngs_modulus)),
            );
            line(w, format!("diameter = {}", toml_f(self.cable.diameter)));
            line(
                w,
                format!("routing_length = {}", toml_f(self.cable.routing_length)),
            );
            if !self.cable.stretch_feed_forward {
                line(w, "stretch_feed_forward = false".into());
            }
        } else {
            // not stated: the default cable, which a `[cable]` table would
            // state (`docs/model.md`, "Settling")
            line(
                w,
                "# no [cable]: cdsm's default cable (steel, 0.18 mm), not stated".into(),
            );
        }
        if shorthand {
            line(w, format!("\n# {} linkages", self.n()));
            for i in 0..self.n() {
                let (joint, disk) = (&self.joints[i], &self.disks[i]);
                line(w, String::new());
                line(w, "[[linkage]]".into());
                line(w, format!("link_before = {}", toml_f(joint.offset[0])));
                line(w, format!("link_after = {}", toml_f(disk.link_after[0])));
                line(w, format!("thickness = {}", toml_f(disk.thickness)));
                line(w, format!("mass = {}", toml_f(disk.mass)));
                let lower = self.cables[2 * i + 1].tension;
                line(w, format!("lower_tension = {}", toml_f(lower)));
                line(w, format!("joint_limits = {}", toml_fs(&joint.limits)));
                if joint.stiffness != 0.0 || joint.rest != 0.0 {
                    line(w, format!("stiffness = {}", toml_f(joint.stiffness)));
                    line(w, format!("rest_angle = {}", toml_f(joint.rest)));
                }
                for (key, c) in [("upper_holes", 2 * i), ("lower_holes", 2 * i + 1)] {
                    let pts: Vec<String> = self.cables[c]
                        .holes
                        .iter()
                        .map(|h| toml_fs(&h[..2]))
                        .collect();
                    line(w, format!("{key} = [{}]", pts.join(", ")));
                }
            }
            return t;
        }
        line(w, String::new());
        line(w, "[base]".into());
        line(w, format!("radius = {}", toml_f(self.base_radius)));
        for d in &self.disks {
            line(w, String::new());
            line(w, "[[linkage]]".into());
            let joints: Vec<String> = self.joints[d.joints.clone()]
                .iter()
                .map(|j| {
                    let spring = if j.stiffness != 0.0 || j.rest != 0.0 {
                        format!(
                            ", stiffness = {}, rest = {}",
                            toml_f(j.stiffness),
                            toml_f(j.rest)
                        )
                    } else {
                        String::new()
                    };
                    format!(
                        "  {{ axis = {}, offset = {}, limits = {}{spring} }},",
                        toml_fs(&j.axis),
                        toml_fs(&j.offset),
                        toml_fs(&j.limits)
                    )
                })
                .collect();
            line(w, format!("joints = [\n{}\n]", joints.join("\n")));
            line(w, format!("link_after = {}", toml_fs(&d.link_after)));
            line(w, format!("thickness = {}", toml_f(d.thickness)));
            line(w, format!("radius = {}", toml_f(d.radius)));
            line(w, format!("mass = {}", toml_f(d.mass)));
            line(w, format!("com = {}", toml_fs(&d.com)));
        }
        for c in &self.cables {
            line(w, String::new());
            line(w, "[[cables]]".into());
            line(w, format!("end = {}", c.end));
            match c.mode {
                Mode::Position => {
                    line(w, "mode = \"position\"".into());
                    if c.actuator.pretension != 0.0 {
                        line(w, format!("pretension = {}", toml_f(c.actuator.pretension)));
                    }
                }
                Mode::Force => {
                    line(w, "mode = \"force\"".into());
                    line(w, format!("tension = {}", toml_f(c.tension)));
                }
                Mode::Displacement => {
                    line(w, "mode = \"displacement\"".into());
                    let a = &c.actuator;
                    if a.stiffness.is_finite() {
                        line(w, format!("stiffness = {}", toml_f(a.stiffness)));
                    }
                    line(w, format!("pretension = {}", toml_f(a.pretension)));
                    if a.max_tension.is_finite() {
                        line(w, format!("max_tension = {}", toml_f(a.max_tension)));
                    }
                }
            }
            let pts: Vec<String> = c.holes.iter().map(|h| toml_fs(h)).collect();
            line(w, format!("holes = [{}]", pts.join(", ")));
        }
        t
    }

    /// The planar view of this arm's own numbers (its planar fast paths'
    /// data, [`Model::planar_view`]; made once), `None` when its structure
    /// does not fit them.
    pub fn planar(&self) -> Option<&PlanarView> {
        self.view
            .0
            .get_or_init(|| self.own_planar_view().map(Box::new))
            .as_deref()
    }

    /// The planar description for `call`, something only a planar arm has
    /// (yet): an error naming `call` for another kind.
    pub fn planar_only(&self, call: &str) -> Result<&PlanarView> {
        self.planar().ok_or_else(|| CdsmError::Option {
            name: call.into(),
            problem: format!(
                "available for planar arms only (this arm is {})",
                self.kind.name()
            ),
        })
    }

    /// A planar arm's holes in the planar layout `(2n, n+1, 2, 2)` flat (m),
    /// as given (also the slots that are no hole); an error for another kind.
    pub fn pair_holes(&self) -> Result<&[f64]> {
        Ok(&self.planar_only("holes")?.holes)
    }

    /// The same arm with other holes (m): in the planar view's layout
    /// `(2n, n+1, 2, 2)` flat for an arm that has one ([`Model::pair_holes`];
    /// a slot no cable crosses is not read), else every `[x, y, z]` flat (as
    /// [`Model::flat_holes`]). `within_disks`: refuse a hole outside its
    /// disk, as a robot file does. The joint springs are kept.
    pub fn with_holes(&self, holes: &[f64], within_disks: bool) -> Result<Model> {
        crate::error::check_finite("holes", holes)?;
        let m = match self.planar() {
            Some(view) => self.with_flat_holes(&self.flat_of_pair_holes(view, holes)?)?,
            None => self.with_flat_holes(holes)?,
        };
        if within_disks {
            m.check_holes()?;
        }
        Ok(m)
    }

    /// Every hole's `[x, y, z]` flat (as [`Model::flat_holes`], `z = 0`)
    /// from `holes` in the layout `(2n, n+1, 2, 2)` flat of the arm's planar
    /// `view`. A slot no cable crosses is no hole: it is not read (as no
    /// kernel ever read it; [`PlanarView::hole_height_error_into`] writes the
    /// base's face a too), and the view holds 0 there.
    fn flat_of_pair_holes(&self, view: &PlanarView, holes: &[f64]) -> Result<Vec<f64>> {
        let n = view.n();
        if holes.len() != view.holes.len() {
            return Err(bad(
                "holes".into(),
                format!(
                    "needs shape (2n, n+1, 2, 2) = ({}, {}, 2, 2), got {} values",
                    2 * n,
                    n + 1,
                    holes.len()
                ),
            ));
        }
        let mut flat = Vec::with_capacity(3 * holes.len() / 4);
        for (c, cable) in self.cables.iter().enumerate() {
            for i in 0..cable.holes.len() {
                let (d, f) = pair_slot(i);
                let k = view.hole_index(c, d, f);
                flat.extend([holes[k], holes[k + 1], 0.0]);
            }
        }
        Ok(flat)
    }

    /// The same arm with other loads: the force-controlled cables' tensions
    /// (file order, N, finite and `>= 0`) and gravity (the kind's `dim`
    /// components, m/s², base frame), validated; the joint springs kept.
    pub fn with_loads(&self, lower_tension: &[f64], gravity: &[f64]) -> Result<Model> {
        let force: Vec<usize> = (0..self.cables.len())
            .filter(|c| self.cables[*c].mode == Mode::Force)
            .collect();
        let dim = self.kind.dim();
        if lower_tension.len() != force.len() || gravity.len() != dim {
            return Err(CdsmError::Shape {
                name: "lower_tension, gravity".into(),
                expected: format!("({},) and ({dim},)", force.len()),
                got: format!("({},) and ({},)", lower_tension.len(), gravity.len()),
            });
        }
        let mut m = self.clone();
        for (i, (&c, &t)) in force.iter().zip(lower_tension).enumerate() {
            m.cables[c].tension = non_negative(format!("lower_tension[{i}]"), t, "N")?;
        }
        if gravity.iter().any(|g| !g.is_finite()) {
            return Err(bad(
                "gravity".into(),
                format!("must be finite (m/s^2), got {gravity:?}"),
            ));
        }
        m.gravity[..dim].copy_from_slice(gravity);
        Ok(m)
    }

    /// Validates a robot description in the general form (`docs/spatial.md`:
    /// joints, disks and `[[cables]]` as written) given as its table; a
    /// planar one (`kind = "planar"`, gravity `[gx, gy]`) must fit the
    /// plane: one joint about `z` per linkage, links along `x`, holes in the
    /// plane and cables in pairs ([`Model::planar_view`]).
    fn from_general_table(table: toml::Table) -> Result<Model> {
        let f: File = from_table(table)?;
        let Some(kind) = Kind::named(&f.kind) else {
            return Err(bad(
                "kind".into(),
                format!("must be \"planar\" or \"spatial\", got {:?}", f.kind),
            ));
        };
        if f.linkage.is_empty() {
            return Err(bad(
                "linkage".into(),
                "at least one [[linkage]] is required",
            ));
        }
        let cable = material(f.cable);
        cable.validate()?;
        // the kind's dim components (the rest 0)
        let mut gravity = [0.0; 3];
        if let Some(g) = f.gravity {
            if g.len() != kind.dim() {
                return Err(bad(
                    "gravity".into(),
                    format!(
                        "invalid length {}, expected exactly {} numbers",
                        g.len(),
                        kind.dim()
                    ),
                ));
            }
            gravity[..g.len()].copy_from_slice(&g);
        }
        let gravity = finite3("gravity", gravity)?;
        let base_radius = positive_length("base.radius".into(), f.base.radius)?;
        let (mut joints, mut disks) = (Vec::new(), Vec::new());
        let (mut springs, mut spring_fields) = (Vec::new(), Vec::new());
        for (k, l) in f.linkage.iter().enumerate() {
            disks.push(linkage_of(
                k,
                l,
                &mut joints,
                &mut springs,
                &mut spring_fields,
            )?);
        }
        if f.cables.is_empty() {
            return Err(bad("cables".into(), "at least one [[cables]] is required"));
        }
        let cables = (f.cables.iter().enumerate())
            .map(|(c, cf)| cable_of(c, cf, disks.len()))
            .collect::<Result<Vec<_>>>()?;
        let mut robot = Model {
            name: robot_name(f.name)?,
            kind,
            joints,
            disks,
            base_radius,
            gravity,
            cables,
            cable,
            radii_from_holes: false,
            view: ViewCache::default(),
        };
        if kind.dim() == 2 {
            // the planar kind's task is the plane's: its fast paths must fit
            let own = robot.own_numbers();
            if let Some((field, problem)) = robot.planar_misfit(&own.numbers()) {
                return Err(bad(field, problem));
            }
        }
        robot.check_holes()?;
        robot.set_springs(&springs, spring_fields, "stiffness", "rest", f.backbone)?;
        robot.check_enough_cables()?;
        robot.check_position_pretension()?;
        Ok(robot)
    }

    /// Number of joints.
    pub fn n(&self) -> usize {
        self.joints.len()
    }

    /// Checks that every hole lies within its disk (the base's or the
    /// disk's radius, to rounding), naming the cable and the hole.
    pub fn check_holes(&self) -> Result<()> {
        for (c, cable) in self.cables.iter().enumerate() {
            for (i, h) in cable.holes.iter().enumerate() {
                let disk = i.div_ceil(2); // 0: base; 2d-1, 2d: disk d
                let radius = if disk == 0 {
                    self.base_radius
                } else {
                    self.disks[disk - 1].radius
                };
                let rr = h[1].hypot(h[2]);
                if rr > radius * (1.0 + 1e-12) {
                    return Err(bad(
                        format!("cables[{c}].holes[{i}]"),
                        format!(
                            "lies {rr} m from the axis, outside the radius {radius} m of {}",
                            if disk == 0 {
                                "the base".to_string()
                            } else {
                                format!("disk {disk}")
                            }
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The joint-limit box (rad).
    pub fn limits(&self) -> Limits {
        Limits(self.joints.iter().map(|j| j.limits).collect())
    }

    /// The facts derived from this arm's structure ([`Structure`]).
    pub fn structure(&self) -> Structure {
        let by_mode = |mode| -> Vec<usize> {
            (0..self.cables.len())
                .filter(|c| self.cables[*c].mode == mode)
                .collect()
        };
        let k = self.disks.len();
        let pairs = self.in_pairs();
        let mut start = Vec::with_capacity(self.cables.len());
        let mut at = 0;
        for c in &self.cables {
            start.push(at);
            at += 3 * c.holes.len();
        }
        let grouping = self.kind.info().holes;
        let hole_groups = match grouping {
            HoleGrouping::PerEndDisk => (1..=k)
                .map(|d| {
                    let mut g = HoleGroup::default();
                    for (c, cable) in self.cables.iter().enumerate() {
                        if cable.end != d {
                            continue;
                        }
                        let sign = if cable.mode == Mode::Position {
                            1.0
                        } else {
                            -1.0
                        };
                        for h in 0..cable.holes.len() {
                            g.coords.push(start[c] + 3 * h + 1);
                            g.coefs.push(sign);
                        }
                    }
                    g.coherent = true;
                    g
                })
                .collect(),
            HoleGrouping::PerCable => (0..self.cables.len())
                .map(|c| HoleGroup {
                    coords: (start[c]..start[c] + 3 * self.cables[c].holes.len()).collect(),
                    coefs: vec![1.0; 3 * self.cables[c].holes.len()],
                    coherent: false,
                })
                .collect(),
        };
        Structure {
            position: by_mode(Mode::Position),
            force: by_mode(Mode::Force),
            pairs,
            hole_groups,
        }
    }

    /// Whether the cables come in pairs: `2k` of them for `k` disks, cable
    /// `2i` position- and `2i + 1` force-controlled, both ending at disk
    /// `i + 1` (a planar file's upper and lower cables).
    fn in_pairs(&self) -> bool {
        self.cables.len() == 2 * self.disks.len()
            && self.cables.iter().enumerate().all(|(c, cable)| {
                let mode = if c % 2 == 0 {
                    Mode::Position
                } else {
                    Mode::Force
                };
                cable.end == c / 2 + 1 && cable.mode == mode
            })
    }

    /// Indices of the position-controlled cables (file order).
    pub fn position_cables(&self) -> Vec<usize> {
        (0..self.cables.len())
            .filter(|c| self.cables[*c].mode == Mode::Position)
            .collect()
    }

    /// Disk (1-based) each joint belongs to.
    pub fn joint_disk(&self, j: usize) -> usize {
        self.disks
            .iter()
            .position(|d| d.joints.contains(&j))
            .map(|k| k + 1)
            .unwrap_or(0)
    }

    /// For every cable, an interval `[lo, hi]` (m) holding its length at
    /// every configuration, joint limits or not (`docs/model.md`, "Lengths
    /// no configuration reaches"): the traversals of the disks are fixed;
    /// a gap with one joint ranges exactly over
    /// `sqrt(da^2 + (|u_perp| -+ |w_perp|)^2)` (the parts of the two hole
    /// vectors along and across the axis); a gap with more joints is
    /// bounded by spherical shells about each joint's offset. A length
    /// outside its interval is reached by no configuration.
    pub fn cable_length_bounds(&self) -> Vec<[f64; 2]> {
        fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
            [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
        }
        fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
            a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
        }
        fn norm(a: [f64; 3]) -> f64 {
            a[0].hypot(a[1]).hypot(a[2])
        }
        // |o + R(axis) x| over every rotation about `axis` (exact)
        fn about_axis(o: [f64; 3], x: [f64; 3], axis: [f64; 3]) -> [f64; 2] {
            let (oa, xa) = (dot(o, axis), dot(x, axis));
            let perp =
                |v: [f64; 3], va: f64| norm(sub(v, [axis[0] * va, axis[1] * va, axis[2] * va]));
            let (op, xp) = (perp(o, oa), perp(x, xa));
            let along = oa + xa;
            [along.hypot(op - xp), along.hypot(op + xp)]
        }
        // |o + y| over every y with |y| in [r0, r1] (any direction)
        fn shell(o: [f64; 3], r: [f64; 2]) -> [f64; 2] {
            let d = norm(o);
            [(r[0] - d).max(d - r[1]).max(0.0), d + r[1]]
        }
        self.cables
            .iter()
            .map(|cable| {
                let mut total = [0.0, 0.0];
                for k in 1..=cable.end {
                    let disk = &self.disks[k - 1];
                    // gap: p on the previous face b, q on face a of disk k;
                    // A = o_1 + R_1 (o_2 + R_2 (... + R_J (link_after + q)))
                    let (p, q) = (cable.holes[2 * k - 2], cable.holes[2 * k - 1]);
                    let joints = &self.joints[disk.joints.clone()];
                    let mut x = [
                        disk.link_after[0] + q[0],
                        disk.link_after[1] + q[1],
                        disk.link_after[2] + q[2],
                    ];
                    let mut range: Option<[f64; 2]> = None;
                    for (i, j) in joints.iter().enumerate().rev() {
                        let o = if i == 0 { sub(j.offset, p) } else { j.offset };
                        let r = match range {
                            None => about_axis(o, x, j.axis),
                            Some(r) => shell(o, r),
                        };
                        range = Some(r);
                        x = [0.0; 3]; // known by its norm only from here on
                    }
                    let gap = range.expect("a disk has at least one joint");
                    // traversal of disk k, face a to face b
                    let b = cable.holes[2 * k];
                    let t = norm(sub([disk.thickness + b[0], b[1], b[2]], q));
                    total[0] += gap[0] + t;
                    total[1] += gap[1] + t;
                }
                total
            })
            .collect()
    }

    /// Every hole as one flat vector (cable by cable, `[x, y, z]` per face), m.
    pub fn flat_holes(&self) -> Vec<f64> {
        self.cables
            .iter()
            .flat_map(|c| c.holes.iter().flatten().copied())
            .collect()
    }

    /// The same robot with holes `flat` (as [`Self::flat_holes`]; every
    /// coordinate within ±[`MAX_LENGTH`]); no radius check (errors of a few
    /// tenths of a mm may leave the disk in a study; radii taken from the
    /// holes follow them). A planar arm's holes stay in its plane (`z` must
    /// be 0).
    pub fn with_flat_holes(&self, flat: &[f64]) -> Result<Model> {
        let want: usize = self.cables.iter().map(|c| 3 * c.holes.len()).sum();
        if flat.len() != want {
            return Err(CdsmError::Shape {
                name: "holes".into(),
                expected: format!("({want},)"),
                got: format!("({},)", flat.len()),
            });
        }
        crate::error::check_finite("holes", flat)?;
        let mut r = self.clone();
        let mut k = 0;
        for c in r.cables.iter_mut() {
            for h in c.holes.iter_mut() {
                *h = [flat[k], flat[k + 1], flat[k + 2]];
                k += 3;
            }
        }
        for (i, h) in flat.chunks_exact(3).enumerate() {
            coordinates(format!("holes[{i}]"), [h[0], h[1], h[2]])?;
        }
        // an arm in the plane keeps its holes there
        if self.kind.dim() == 2 {
            if let Some(i) = (0..flat.len() / 3).find(|i| flat[3 * i + 2] != 0.0) {
                return Err(bad(
                    "holes".into(),
                    format!(
                        "a planar arm's holes lie in its plane: hole {i} has z = {}",
                        flat[3 * i + 2]
                    ),
                ));
            }
        }
        if r.radii_from_holes {
            r.set_radii_from_holes();
        }
        Ok(r)
    }
}

/// The paper's prototype (Table 1), shipped with the Python package.
pub const PAPER_TOML: &str = include_str!("../python/cdsm/robots/paper.toml");

impl PlanarView {
    /// The planar view of the paper's 3-DOF prototype (Table 1; lower
    /// cables 50, 10, 5 g; ±35°).
    pub fn paper() -> PlanarView {
        PlanarView::from_toml(PAPER_TOML).expect("the shipped paper robot is valid")
    }

    /// The planar view ([`Model::planar`]) of the arm a robot file
    /// describes; an error naming `kind` for an arm without one.
    pub fn from_toml(text: &str) -> Result<PlanarView> {
        let model = Model::from_toml(text)?;
        model.own_planar_view().ok_or_else(|| {
            bad(
                "kind".into(),
                format!("a {} arm has no planar view", model.kind.name()),
            )
        })
    }
}

/// Linkage `k` of a general-form file: its joints appended to `joints` (and
/// their springs and spring fields to `springs`, `spring_fields`), its disk
/// returned.
fn linkage_of(
    k: usize,
    l: &LinkageFile,
    joints: &mut Vec<Joint>,
    springs: &mut Vec<(Option<f64>, Option<f64>)>,
    spring_fields: &mut Vec<String>,
) -> Result<Disk> {
    let field = |name: &str| format!("linkage[{k}].{name}");
    if l.joints.is_empty() {
        return Err(bad(field("joints"), "at least one joint is required"));
    }
    let first = joints.len();
    for (j, jf) in l.joints.iter().enumerate() {
        let jfield = |name: &str| format!("linkage[{k}].joints[{j}].{name}");
        let a = finite3(&jfield("axis"), jf.axis.0)?;
        let Some(axis) = unit_axis(a) else {
            return Err(bad(
                jfield("axis"),
                format!("must be a non-zero vector, got {a:?}"),
            ));
        };
        let lim = joint_limits(jfield("limits"), jf.limits)?;
        joints.push(Joint {
            axis,
            offset: coordinates(jfield("offset"), jf.offset.map_or([0.0; 3], |o| o.0))?,
            limits: lim,
            stiffness: 0.0,
            rest: 0.0,
        });
        springs.push((jf.stiffness, jf.rest));
        spring_fields.push(format!("linkage[{k}].joints[{j}]"));
    }
    // 0: a via plate (docs/model.md, "Joint springs")
    let thickness = non_negative(field("thickness"), l.thickness, "m")?;
    if thickness > MAX_LENGTH {
        return Err(bad(
            field("thickness"),
            format!("must be at most {MAX_LENGTH} m, got {thickness}"),
        ));
    }
    if !(l.mass.is_finite() && l.mass >= 0.0) {
        return Err(bad(
            field("mass"),
            format!("must be finite and >= 0 (kg), got {}", l.mass),
        ));
    }
    Ok(Disk {
        joints: first..joints.len(),
        link_after: coordinates(field("link_after"), l.link_after.0)?,
        thickness,
        radius: positive_length(field("radius"), l.radius)?,
        mass: l.mass,
        com: coordinates(
            field("com"),
            l.com.map_or([thickness / 2.0, 0.0, 0.0], |c| c.0),
        )?,
    })
}

/// Cable `c` of a general-form file, its `end` one of the `disks` disks:
/// its mode and set tension, its holes (on a circle, or given), its actuator.
fn cable_of(c: usize, cf: &CableFile, disks: usize) -> Result<Cable> {
    let field = |name: &str| format!("cables[{c}].{name}");
    if cf.end < 1 || cf.end > disks {
        return Err(bad(
            field("end"),
            format!("must be a disk 1..{}, got {}", disks, cf.end),
        ));
    }
    let (mode, tension) = match (cf.mode.as_str(), cf.tension) {
        ("position", None) => (Mode::Position, 0.0),
        ("displacement", None) => (Mode::Displacement, 0.0),
        ("displacement", Some(_)) => {
            return Err(bad(
                field("tension"),
                "only force-controlled cables carry a tension",
            ))
        }
        ("position", Some(_)) => {
            return Err(bad(
                field("tension"),
                "a position-controlled cable has no set tension",
            ))
        }
        ("force", Some(t)) if t.is_finite() && t > 0.0 => (Mode::Force, t),
        ("force", t) => {
            let got = t.map_or_else(|| "none".to_string(), |v| v.to_string());
            return Err(bad(
                field("tension"),
                format!("a force-controlled cable needs a positive tension (N), got {got}"),
            ));
        }
        (m, _) => {
            return Err(bad(
                field("mode"),
                format!("must be \"position\", \"force\" or \"displacement\", got {m:?}"),
            ))
        }
    };
    let count = 2 * cf.end + 1;
    let holes = match (cf.radius, cf.angle, &cf.holes) {
        (Some(r), Some(a), None) => {
            if !(r.is_finite() && r >= 0.0 && a.is_finite()) {
                return Err(bad(
                    field("radius"),
                    format!("needs finite radius >= 0 and angle, got {r}, {a}"),
                ));
            }
            vec![[0.0, r * a.cos(), r * a.sin()]; count]
        }
        (None, None, Some(h)) => h.iter().map(|p| p.0).collect(),
        _ => {
            return Err(bad(
                field("holes"),
                "give either radius and angle, or holes ([x, y, z] per face)",
            ))
        }
    };
    if holes.len() != count {
        return Err(bad(
            field("holes"),
            format!(
                "needs {count} [x, y, z] points (base face b, then faces a and b of disks 1..{}), got {}",
                cf.end,
                holes.len()
            ),
        ));
    }
    for (i, h) in holes.iter().enumerate() {
        coordinates(format!("cables[{c}].holes[{i}]"), *h)?;
    }
    let mut actuator = Actuator::default();
    if let (Some(_), Mode::Force) = (cf.pretension, mode) {
        return Err(bad(
            field("pretension"),
            "only position and displacement cables have a pretension",
        ));
    }
    if mode == Mode::Position {
        // the position cable's pretension: its command shortened by
        // P (L + L_r) / (E A) (`docs/model.md`, "Settling")
        actuator.pretension = non_negative(field("pretension"), cf.pretension.unwrap_or(0.0), "N")?;
    }
    for (key, given) in [("stiffness", cf.stiffness), ("max_tension", cf.max_tension)] {
        if given.is_some() && mode != Mode::Displacement {
            return Err(bad(
                field(key),
                format!("only displacement cables (mode = \"displacement\") have a {key}"),
            ));
        }
    }
    if mode == Mode::Displacement {
        if let Some(k) = cf.stiffness {
            actuator.stiffness = positive(field("stiffness"), k, "N/m")?;
        }
        actuator.pretension = non_negative(field("pretension"), cf.pretension.unwrap_or(0.0), "N")?;
        if let Some(t) = cf.max_tension {
            let t = positive(field("max_tension"), t, "N")?;
            if t <= actuator.pretension {
                return Err(bad(
                    field("max_tension"),
                    format!(
                        "must exceed the pretension ({} N), got {t}",
                        actuator.pretension
                    ),
                ));
            }
            actuator.max_tension = t;
        }
    }
    Ok(Cable {
        end: cf.end,
        mode,
        tension,
        holes,
        actuator,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_written_model_reads_back_exactly() {
        for text in [
            include_str!("../python/cdsm/robots/paper.toml"),
            include_str!("../python/cdsm/robots/paper_vertical.toml"),
            include_str!("../python/cdsm/robots/serpentine8.toml"),
            include_str!("../python/cdsm/robots/two_universal.toml"),
            include_str!("../python/cdsm/robots/paper_spatial.toml"),
            include_str!("../python/cdsm/robots/sjtu_snake.toml"),
        ] {
            let mut m = Model::from_toml(text).unwrap();
            m.name = "arm \u{1F4AA} \"q\" \\ \t\u{7f}".into();
            let back = Model::from_toml(&m.to_toml()).unwrap();
            assert_eq!(back, m, "{}", m.to_toml());
        }
    }

    /// Planar robot texts: every packaged and example planar robot, and
    /// test arms with explicit, uneven holes, loads, springs and 8 joints.
    fn planar_texts() -> Vec<String> {
        let mut t8 = String::from("name = \"t8\"\n");
        for i in 0..8 {
            t8 += &format!(
                "[[linkage]]\nlink_before = 0.02\nlink_after = 0.02\nthickness = 0.008\nhole_height = {}\njoint_limits = [-0.6, 0.6]\n",
                0.025 - 0.001 * i as f64
            );
        }
        let uneven = "name = \"uneven\"\nn = 2\ngravity = [0.3, -9.7]\n\
            [cable]\nyoungs_modulus = 2.1e11\ndiameter = 0.3e-3\nrouting_length = 0.4\nstretch_feed_forward = false\n\
            [[linkage]]\nlink_before = 0.031\nlink_after = 0.029\nthickness = 0.007\nmass = 0.02\nlower_tension = 0.7\n\
            joint_limits = [-0.5, 0.8]\nstiffness = 0.01\nrest_angle = 0.1\n\
            upper_holes = [[0.001, 0.03], [-0.0005, 0.0291], [0.0002, 0.0305]]\n\
            lower_holes = [[0.0, -0.028], [0.0003, -0.0299], [0.0, -0.031]]\n\
            [[linkage]]\nlink_before = 0.02\nlink_after = 0.025\nthickness = 0.006\nmass = 0.01\nlower_tension = 0.2\n\
            upper_holes = [[0.0, 0.02], [0.0, 0.021], [0.0, 0.022], [0.0011, 0.019], [0.0, 0.018]]\n\
            lower_holes = [[0.0, -0.02], [0.0, -0.021], [0.0, -0.022], [0.0, -0.019], [-0.001, -0.017]]\n";
        vec![
            include_str!("../python/cdsm/robots/paper.toml").to_string(),
            include_str!("../python/cdsm/robots/paper_reversed_weights.toml").to_string(),
            include_str!("../python/cdsm/robots/paper_vertical.toml").to_string(),
            include_str!("../python/cdsm/robots/paper_vertical_reversed_weights.toml").to_string(),
            include_str!("../python/cdsm/robots/serpentine8.toml").to_string(),
            include_str!("../examples/two_section_arm.toml").to_string(),
            t8,
            uneven.to_string(),
        ]
    }

    /// A planar file's description read straight from its TOML table by
    /// this test (no checks): the oracle of the planar view.
    fn read_by_hand(text: &str) -> PlanarView {
        let t: toml::Table = text.parse().unwrap();
        let num = |v: &toml::Value| {
            v.as_float()
                .or_else(|| v.as_integer().map(|i| i as f64))
                .unwrap()
        };
        let pair = |v: &toml::Value| {
            let a = v.as_array().unwrap();
            [num(&a[0]), num(&a[1])]
        };
        let links = t["linkage"].as_array().unwrap();
        let n = links.len();
        let each = |k: &str, default: f64| -> Vec<f64> {
            links
                .iter()
                .map(|l| l.get(k).map_or(default, num))
                .collect()
        };
        let mut holes = vec![0.0; 2 * n * (n + 1) * 4];
        for (i, l) in links.iter().enumerate() {
            let along = 2 * i + 3;
            let (upper, lower): (Vec<[f64; 2]>, Vec<[f64; 2]>) = match l.get("hole_height") {
                Some(h) => (vec![[0.0, num(h)]; along], vec![[0.0, -num(h)]; along]),
                None => (
                    l["upper_holes"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(pair)
                        .collect(),
                    l["lower_holes"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(pair)
                        .collect(),
                ),
            };
            for (side, pts) in [upper, lower].iter().enumerate() {
                let c = 2 * i + side;
                for (j, p) in pts.iter().enumerate() {
                    // base face b, then faces a and b of disks 1, 2, ...
                    let (d, f) = if j == 0 {
                        (0, 1)
                    } else {
                        (j.div_ceil(2), (j + 1) % 2)
                    };
                    let k = ((c * (n + 1) + d) * 2 + f) * 2;
                    holes[k] = p[0];
                    holes[k + 1] = p[1];
                }
            }
        }
        let cable = t.get("cable");
        let of_cable = |k: &str, default: f64| cable.and_then(|c| c.get(k)).map_or(default, num);
        PlanarView {
            name: t
                .get("name")
                .map_or("unnamed", |v| v.as_str().unwrap())
                .into(),
            link_before: each("link_before", f64::NAN),
            link_after: each("link_after", f64::NAN),
            thickness: each("thickness", f64::NAN),
            mass: each("mass", 0.0),
            lower_tension: each("lower_tension", 0.0),
            joint_limits: links
                .iter()
                .map(|l| {
                    l.get("joint_limits")
                        .map_or([-std::f64::consts::PI, std::f64::consts::PI], pair)
                })
                .collect(),
            holes,
            cable: CableMaterial {
                youngs_modulus: of_cable("youngs_modulus", 1.8e11),
                diameter: of_cable("diameter", 0.18e-3),
                routing_length: of_cable("routing_length", 0.0),
                stretch_feed_forward: cable
                    .and_then(|c| c.get("stretch_feed_forward"))
                    .is_none_or(|v| v.as_bool().unwrap()),
                stated: cable.is_some(),
            },
            gravity: t.get("gravity").map_or([0.0, 0.0], pair),
        }
    }

    #[test]
    fn the_planar_view_is_the_planar_file_read_as_before() {
        // field by field, bit for bit, against the file read by hand (the
        // planar description of cdsm 0.2, `PlanarView::from_toml`, was checked
        // equal before its reader became the model's), holes' slots that are
        // no hole included
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for text in planar_texts() {
            let r = read_by_hand(&text);
            let m = Model::from_toml(&text).unwrap();
            let v = m
                .own_planar_view()
                .expect("a planar file has the planar view");
            assert_eq!(v.name, r.name);
            assert_eq!(bits(&v.link_before), bits(&r.link_before), "{}", r.name);
            assert_eq!(bits(&v.link_after), bits(&r.link_after), "{}", r.name);
            assert_eq!(bits(&v.thickness), bits(&r.thickness), "{}", r.name);
            assert_eq!(bits(&v.mass), bits(&r.mass), "{}", r.name);
            assert_eq!(bits(&v.lower_tension), bits(&r.lower_tension), "{}", r.name);
            assert_eq!(
                bits(v.joint_limits.as_flattened()),
                bits(r.joint_limits.as_flattened()),
                "{}",
                r.name
            );
            assert_eq!(bits(&v.holes), bits(&r.holes), "{}", r.name);
            assert_eq!(bits(&v.gravity), bits(&r.gravity), "{}", r.name);
            let c = |m: &CableMaterial| {
                (
                    m.youngs_modulus.to_bits(),
                    m.diameter.to_bits(),
                    m.routing_length.to_bits(),
                    m.stretch_feed_forward,
                )
            };
            assert_eq!(c(&v.cable), c(&r.cable), "{}", r.name);
        }
    }

    #[test]
    fn a_planar_arm_reads_in_the_general_form_too() {
        let mut read = 0;
        for text in planar_texts() {
            let short = Model::from_toml(&text).unwrap();
            if short
                .cables
                .iter()
                .any(|c| c.mode == Mode::Force && c.tension == 0.0)
            {
                continue; // the general form's force cables pull (tension > 0)
            }
            let mut general = short.clone();
            general.radii_from_holes = false;
            let written = general.to_toml();
            assert!(
                written.contains("kind = \"planar\"") && written.contains("[[cables]]"),
                "{written}"
            );
            let back = Model::from_toml(&written).unwrap();
            assert_eq!(back, general);
            let view = |m: &Model| format!("{:?}", m.own_planar_view().unwrap());
            assert_eq!(view(&back), view(&short));
            read += 1;
        }
        assert!(read >= 5, "{read}");
        // what does not fit the plane is refused, naming the field
        let mut paper = Model::from_toml(PAPER_TOML).unwrap();
        paper.radii_from_holes = false;
        let text = paper.to_toml();
        let refused = |t: String, field: &str| {
            let e = Model::from_toml(&t).unwrap_err().to_string();
            assert!(e.contains(&format!("`{field}`")), "{field}: {e}");
        };
        let about_y = text.replacen("axis = [0.0, 0.0, 1.0]", "axis = [0.0, 1.0, 0.0]", 1);
        refused(about_y, "linkage[0].joints[0].axis");
        let off_axis = text.replacen(
            "offset = [0.033, 0.0, 0.0]",
            "offset = [0.033, 0.001, 0.0]",
            1,
        );
        assert_ne!(off_axis, text);
        refused(off_axis, "linkage[0].joints[0].offset");
        refused(
            text.replacen("gravity = [0.0, 0.0]", "gravity = [0.0, 0.0, -9.8]", 1),
            "gravity",
        );
        let one_cable_less = text.replacen("[[cables]]\nend = 1\nmode = \"position\"", "[[c]]", 1);
        let cut = one_cable_less.find("[[c]]").unwrap();
        let next = cut + one_cable_less[cut..].find("\n\n").unwrap();
        refused(
            format!("{}{}", &one_cable_less[..cut], &one_cable_less[next + 2..]),
            "cables",
        );
    }

    #[test]
    fn an_arm_out_of_the_plane_has_no_planar_view() {
        let base = Model::from_toml(include_str!("../python/cdsm/robots/paper.toml")).unwrap();
        assert!(base.own_planar_view().is_some());
        let tilted = |f: &dyn Fn(&mut Model)| {
            let mut m = base.clone();
            f(&mut m);
            m.own_planar_view()
        };
        assert!(tilted(&|m| m.joints[1].axis = [0.0, 1.0, 0.0]).is_none());
        assert!(tilted(&|m| m.joints[0].offset[2] = 1e-3).is_none());
        assert!(tilted(&|m| m.disks[2].link_after[1] = 1e-3).is_none());
        assert!(tilted(&|m| m.cables[3].holes[2][2] = 1e-4).is_none());
        assert!(tilted(&|m| m.gravity[2] = -9.8).is_none());
        assert!(tilted(&|m| m.cables[1].mode = Mode::Position).is_none());
        assert!(tilted(&|m| m.cables.truncate(5)).is_none());
        for text in [
            include_str!("../python/cdsm/robots/two_universal.toml"),
            include_str!("../python/cdsm/robots/paper_spatial.toml"),
        ] {
            assert!(Model::from_toml(text).unwrap().own_planar_view().is_none());
        }
    }

    #[test]
    fn a_planar_arms_new_holes_and_loads_are_its_view() {
        let view = |m: &Model| m.planar().expect("a planar arm has its view").clone();
        let paper = Model::from_toml(include_str!("../python/cdsm/robots/paper.toml")).unwrap();
        let v = view(&paper);
        // move one hole: the view follows, the radius of its disk too
        let mut holes = v.holes.clone();
        let k = v.hole_index(4, 3, 1) + 1;
        holes[k] = 0.04;
        let moved = paper.with_holes(&holes, true).unwrap();
        assert_eq!(view(&moved).holes, holes);
        assert_eq!(moved.disks[2].radius, 0.04);
        assert_eq!(view(&paper).holes, v.holes);
        // a slot that is no hole is not read (the hole-height error writes
        // the base's face a too): the view has 0 there
        let mut h = holes.clone();
        for (c, d, f) in [(0, 0, 0), (1, 2, 1), (5, 0, 0)] {
            h[v.hole_index(c, d, f)] = 1e-3;
        }
        assert_eq!(view(&paper.with_holes(&h, true).unwrap()).holes, holes);
        // loads: the force cables' tensions and the plane's gravity
        let loaded = paper.with_loads(&[0.1, 0.2, 0.3], &[0.0, -9.8]).unwrap();
        let lv = view(&loaded);
        assert_eq!(lv.lower_tension, vec![0.1, 0.2, 0.3]);
        assert_eq!(lv.gravity, [0.0, -9.8]);
        let e = paper
            .with_loads(&[0.1, -0.2, 0.3], &[0.0, 0.0])
            .unwrap_err();
        assert!(e.to_string().contains("lower_tension[1]"), "{e}");
        let e = paper
            .with_loads(&[0.1, 0.2, 0.3], &[0.0, f64::NAN])
            .unwrap_err();
        assert!(e.to_string().contains("gravity"), "{e}");
    }

    #[test]
    fn a_spatial_arm_takes_loads_and_refuses_holes_past_a_kilometre() {
        let m = Model::from_toml(include_str!("../python/cdsm/robots/two_universal.toml")).unwrap();
        let force: Vec<usize> = m.structure().force;
        let t: Vec<f64> = (0..force.len()).map(|i| 0.5 + i as f64).collect();
        let loaded = m.with_loads(&t, &[0.0, 0.0, -9.8]).unwrap();
        for (i, &c) in force.iter().enumerate() {
            assert_eq!(loaded.cables[c].tension, t[i]);
        }
        assert_eq!(loaded.gravity, [0.0, 0.0, -9.8]);
        let mut flat = m.flat_holes();
        flat[4] = 2e3;
        let e = m.with_holes(&flat, false).unwrap_err().to_string();
        assert!(e.contains("`holes[1]`"), "{e}");
    }

    #[test]
    fn every_reader_refuses_a_name_xml_forbids() {
        for text in [
            include_str!("../python/cdsm/robots/paper.toml"),
            include_str!("../python/cdsm/robots/two_universal.toml"),
        ] {
            let named = |name: &str| {
                let body: String = text
                    .lines()
                    .filter(|l| !l.starts_with("name ="))
                    .map(|l| format!("{l}\n"))
                    .collect();
                format!("name = {}\n{body}", toml_string(name))
            };
            assert_eq!(
                Model::from_toml(&named("ok \u{1F4AA}")).unwrap().name,
                "ok \u{1F4AA}"
            );
            for (bad_name, code) in [
                ("a\u{1}", "U+0001"),
                ("\u{1b}[2J", "U+001B"),
                ("\u{FFFE}", "U+FFFE"),
            ] {
                let e = Model::from_toml(&named(bad_name)).unwrap_err().to_string();
                assert!(e.contains("`name`") && e.contains(code), "{e}");
                let mut table = toml_table(&named("x")).unwrap();
                table.insert("name".into(), toml::Value::String(bad_name.into()));
                let e = Model::from_table(table).unwrap_err().to_string();
                assert!(e.contains("`name`") && e.contains(code), "{e}");
            }
        }
    }

    #[test]
    fn a_huge_axis_is_a_unit_axis_not_zero() {
        let u = unit_axis([0.0, 1e308, 1e308]).unwrap();
        assert!(
            u[0] == 0.0 && (u[1] - 0.5f64.sqrt()).abs() <= 2.0 * f64::EPSILON && u[1] == u[2],
            "{u:?}"
        );
        assert_eq!(unit_axis([0.0, 0.0, 0.0]), None);
        let a = [0.6, 0.8, 0.0];
        assert_eq!(unit_axis(a), Some(a));
    }

    #[test]
    fn every_configuration_has_its_cable_lengths_within_the_bounds() {
        // sampled far past the joint limits (the bounds hold at any angle);
        // a one-joint gap's interval is exact, so a planar pair-1 cable's
        // extremes are approached by the samples
        use crate::chain::Chain;
        use crate::kinds::Se3;
        for text in [
            include_str!("../python/cdsm/robots/paper.toml"),
            include_str!("../python/cdsm/robots/two_universal.toml"),
            include_str!("../python/cdsm/robots/sjtu_snake.toml"),
        ] {
            let m = Model::from_toml(text).unwrap();
            let bounds = m.cable_length_bounds();
            let mut chain = Chain::<f64, Se3<f64>>::new(&m);
            let mut seen = vec![[f64::INFINITY, f64::NEG_INFINITY]; m.cables.len()];
            let mut state = 0x2545f4914f6cdd1du64;
            for _ in 0..4000 {
                let th: Vec<f64> = (0..m.n())
                    .map(|_| {
                        state ^= state << 13;
                        state ^= state >> 7;
                        state ^= state << 17;
                        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 * std::f64::consts::PI
                            - std::f64::consts::PI
                    })
                    .collect();
                chain.at(&m, &m, &th);
                chain.world(&m, &m);
                for (c, b) in bounds.iter().enumerate() {
                    let l = chain.cable_length(&m, &m, c, None);
                    assert!(
                        l >= b[0] - 1e-12 && l <= b[1] + 1e-12,
                        "{c}: {l} not in {b:?}"
                    );
                    seen[c] = [seen[c][0].min(l), seen[c][1].max(l)];
                }
            }
            if m.planar().is_some() {
                // one joint crossed: the samples come close to both extremes
                for (c, (b, s)) in bounds.iter().zip(&seen).enumerate().take(2) {
                    let width = b[1] - b[0];
                    assert!(
                        s[0] - b[0] < 0.05 * width && b[1] - s[1] < 0.05 * width,
                        "{c}: {s:?} vs {b:?}"
                    );
                }
            }
        }
    }
}
