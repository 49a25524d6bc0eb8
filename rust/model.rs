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
use crate::robot::{CableMaterial, Robot};
use crate::robot_file::{
    bad, coordinates, from_table, joint_limits, positive_length, robot_name, toml_table, Exact,
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
    /// The planar description of a planar arm: the data of its closed forms
    /// and SIMD kernels, made with the model ([`Model::planar`]).
    planar: Option<Box<Robot>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    kind: String,
    name: Option<String>,
    gravity: Option<Exact<3>>,
    cable: Option<MaterialFile>,
    base: BaseFile,
    linkage: Vec<LinkageFile>,
    cables: Vec<CableFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialFile {
    youngs_modulus: f64,
    diameter: f64,
    #[serde(default)]
    routing_length: f64,
    #[serde(default = "crate::robot::feed_forward_default")]
    stretch_feed_forward: bool,
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
    offset: Exact<3>,
    limits: Option<Exact<2>>,
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
    /// Parses and validates a robot description of either kind: a spatial
    /// file as written, a planar file through [`Robot::from_table`] and
    /// [`Model::from_planar`].
    pub fn from_toml(text: &str) -> Result<Model> {
        Model::from_table(toml_table(text)?)
    }

    /// Validates a robot description of either kind given as its table: a
    /// parsed file, or data built as one (the same fields, the same checks,
    /// the same field paths in errors; no text in between).
    pub fn from_table(table: toml::Table) -> Result<Model> {
        match kind_of_table(&table)?.as_str() {
            "planar" => Ok(Model::from_planar(&Robot::from_table(table)?)),
            _ => Model::from_spatial_table(table),
        }
    }

    /// A planar arm as the one model: joint `i` about `z` at the offset
    /// `(link_before[i], 0, 0)`, disk `i` at `link_after = (link_after[i], 0,
    /// 0)` with its mass at its centre `(thickness / 2, 0, 0)`; cable `2i`
    /// (upper) position-controlled and cable `2i + 1` (lower) force-controlled
    /// at `lower_tension[i]`, both ending at disk `i + 1`, their holes
    /// `(x, y, 0)`; gravity `(gx, gy, 0)`. A disk's radius is the largest
    /// `|y|` of its holes (the planar file has none).
    pub fn from_planar(robot: &Robot) -> Model {
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
                }
            })
            .collect();
        let radius = |d: usize| {
            cables
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
        let disks = (0..n)
            .map(|i| Disk {
                joints: i..i + 1,
                link_after: [robot.link_after[i], 0.0, 0.0],
                thickness: robot.thickness[i],
                radius: radius(i + 1),
                mass: robot.mass[i],
                com: [robot.thickness[i] / 2.0, 0.0, 0.0],
            })
            .collect();
        let joints = (0..n)
            .map(|i| Joint {
                axis: [0.0, 0.0, 1.0],
                offset: [robot.link_before[i], 0.0, 0.0],
                limits: robot.joint_limits[i],
            })
            .collect();
        Model {
            name: robot.name.clone(),
            kind: Kind::Planar,
            joints,
            disks,
            base_radius: radius(0),
            gravity: [robot.gravity[0], robot.gravity[1], 0.0],
            cables,
            cable: robot.cable.clone(),
            planar: Some(Box::new(robot.clone())),
        }
    }

    /// The same arm with another cable material (validated).
    pub fn with_cable(&self, cable: CableMaterial) -> Result<Model> {
        cable.validate()?;
        if let Some(p) = self.planar() {
            let mut r = p.clone();
            r.cable = cable;
            return Ok(Model::from_planar(&r));
        }
        let mut m = self.clone();
        m.cable = cable;
        Ok(m)
    }

    /// A robot file (TOML, SI units) that rebuilds this arm exactly: a
    /// planar arm in the planar format (explicit holes), a spatial one in
    /// the spatial format (explicit holes); every float in its shortest
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
        if self.kind == Kind::Spatial {
            line(w, "kind = \"spatial\"".into());
        }
        line(w, format!("name = {}", toml_string(&self.name)));
        let g = if self.kind == Kind::Planar {
            &self.gravity[..2]
        } else {
            &self.gravity[..]
        };
        line(w, format!("gravity = {}", toml_fs(g)));
        line(w, String::new());
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
        if let Some(r) = self.planar() {
            line(w, format!("\n# {} linkages", r.n()));
            for i in 0..r.n() {
                line(w, String::new());
                line(w, "[[linkage]]".into());
                line(w, format!("link_before = {}", toml_f(r.link_before[i])));
                line(w, format!("link_after = {}", toml_f(r.link_after[i])));
                line(w, format!("thickness = {}", toml_f(r.thickness[i])));
                line(w, format!("mass = {}", toml_f(r.mass[i])));
                line(w, format!("lower_tension = {}", toml_f(r.lower_tension[i])));
                line(w, format!("joint_limits = {}", toml_fs(&r.joint_limits[i])));
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
                    format!(
                        "  {{ axis = {}, offset = {}, limits = {} }},",
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
                Mode::Position => line(w, "mode = \"position\"".into()),
                Mode::Force => {
                    line(w, "mode = \"force\"".into());
                    line(w, format!("tension = {}", toml_f(c.tension)));
                }
            }
            let pts: Vec<String> = c.holes.iter().map(|h| toml_fs(h)).collect();
            line(w, format!("holes = [{}]", pts.join(", ")));
        }
        t
    }

    /// The planar description of a planar arm (its fast paths' data), `None`
    /// for a spatial one.
    pub fn planar(&self) -> Option<&Robot> {
        self.planar.as_deref()
    }

    /// Validates a spatial robot description (`docs/spatial.md`) given as
    /// its table.
    fn from_spatial_table(table: toml::Table) -> Result<Model> {
        let f: File = from_table(table)?;
        if f.kind != "spatial" {
            return Err(bad(
                "kind".into(),
                format!("expected \"spatial\", got {:?}", f.kind),
            ));
        }
        if f.linkage.is_empty() {
            return Err(bad(
                "linkage".into(),
                "at least one [[linkage]] is required",
            ));
        }
        let cable = match f.cable {
            Some(c) => {
                let m = CableMaterial {
                    youngs_modulus: c.youngs_modulus,
                    diameter: c.diameter,
                    routing_length: c.routing_length,
                    stretch_feed_forward: c.stretch_feed_forward,
                };
                m.validate()?;
                m
            }
            None => CableMaterial {
                youngs_modulus: 1.8e11,
                diameter: 0.18e-3,
                routing_length: 0.0,
                stretch_feed_forward: true,
            },
        };
        let gravity = finite3("gravity", f.gravity.map_or([0.0; 3], |g| g.0))?;
        let base_radius = positive_length("base.radius".into(), f.base.radius)?;
        let (mut joints, mut disks) = (Vec::new(), Vec::new());
        for (k, l) in f.linkage.iter().enumerate() {
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
                    offset: coordinates(jfield("offset"), jf.offset.0)?,
                    limits: lim,
                });
            }
            let thickness = positive_length(field("thickness"), l.thickness)?;
            if !(l.mass.is_finite() && l.mass >= 0.0) {
                return Err(bad(
                    field("mass"),
                    format!("must be finite and >= 0 (kg), got {}", l.mass),
                ));
            }
            disks.push(Disk {
                joints: first..joints.len(),
                link_after: coordinates(field("link_after"), l.link_after.0)?,
                thickness,
                radius: positive_length(field("radius"), l.radius)?,
                mass: l.mass,
                com: coordinates(
                    field("com"),
                    l.com.map_or([thickness / 2.0, 0.0, 0.0], |c| c.0),
                )?,
            });
        }
        if f.cables.is_empty() {
            return Err(bad("cables".into(), "at least one [[cables]] is required"));
        }
        let mut cables = Vec::new();
        for (c, cf) in f.cables.iter().enumerate() {
            let field = |name: &str| format!("cables[{c}].{name}");
            if cf.end < 1 || cf.end > disks.len() {
                return Err(bad(
                    field("end"),
                    format!("must be a disk 1..{}, got {}", disks.len(), cf.end),
                ));
            }
            let (mode, tension) = match (cf.mode.as_str(), cf.tension) {
                ("position", None) => (Mode::Position, 0.0),
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
                        format!("must be \"position\" or \"force\", got {m:?}"),
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
            cables.push(Cable {
                end: cf.end,
                mode,
                tension,
                holes,
            });
        }
        let robot = Model {
            name: robot_name(f.name)?,
            kind: Kind::Spatial,
            joints,
            disks,
            base_radius,
            gravity,
            cables,
            cable,
            planar: None,
        };
        robot.check_holes()?;
        let m = robot.position_cables().len();
        if m < robot.n() {
            return Err(bad(
                "cables".into(),
                format!(
                    "{m} position-controlled cables cannot determine {} joints (at least as many are needed)",
                    robot.n()
                ),
            ));
        }
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
        // cables in pairs: 2k of them, cable 2i position and 2i + 1 force, both
        // ending at disk i + 1 (a planar file's upper and lower cables)
        let k = self.disks.len();
        let pairs = self.cables.len() == 2 * k
            && self.cables.iter().enumerate().all(|(c, cable)| {
                let mode = if c % 2 == 0 {
                    Mode::Position
                } else {
                    Mode::Force
                };
                cable.end == c / 2 + 1 && cable.mode == mode
            });
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

    /// The same robot with holes `flat` (as [`Self::flat_holes`]); no radius check
    /// (errors of a few tenths of a mm may leave the disk in a study). A
    /// planar arm's holes stay in its plane (`z` must be 0).
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
        if let Some(p) = self.planar() {
            if let Some(i) = (0..flat.len() / 3).find(|i| flat[3 * i + 2] != 0.0) {
                return Err(bad(
                    "holes".into(),
                    format!(
                        "a planar arm's holes lie in its plane: hole {i} has z = {}",
                        flat[3 * i + 2]
                    ),
                ));
            }
            let mut holes = p.holes.clone();
            for (c, cable) in r.cables.iter().enumerate() {
                for (i, h) in cable.holes.iter().enumerate() {
                    let (d, f) = if i == 0 {
                        (0, 1)
                    } else {
                        (i.div_ceil(2), 1 - i % 2)
                    };
                    let at = p.hole_index(c, d, f);
                    holes[at] = h[0];
                    holes[at + 1] = h[1];
                }
            }
            r = Model::from_planar(&p.with_holes(&holes)?);
        }
        Ok(r)
    }
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
            if let Some(p) = m.planar.as_mut() {
                p.name = m.name.clone();
            }
            let back = Model::from_toml(&m.to_toml()).unwrap();
            assert_eq!(back, m, "{}", m.to_toml());
        }
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
