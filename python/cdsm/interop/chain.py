"""The arm as a chain of bodies, for the exporters (MJCF, URDF): an arm of
either kind (``docs/spatial.md``; a planar arm as its case, axes along
``z``, holes at ``z = 0``) in the frames the exporters write. SI units: m,
kg, kg m^2, rad, N.

cdsm's chain (``docs/spatial.md``, "Frames"): from face b of disk ``k - 1``,
``F · Trans(offset_j) · Rot(axis_j, theta_j)`` for each joint ``j`` of disk
``k``, then ``Trans(link_after_k)`` to face a and ``Trans(thickness_k, 0,
0)`` to face b. No fixed rotation anywhere: every frame of the chain is a
translation of the joint frames, so each placement below is a vector.

* :attr:`Joint.pos`: joint ``j``'s origin in the frame of joint ``j - 1``
  after its rotation (the base frame for ``j = 0``): ``offset_j``, plus
  ``link_after + (thickness, 0, 0)`` of the previous disk for a disk's first
  joint. (URDF: the joint's origin; ``tip`` at face b of the last disk.)
* :attr:`Joint.anchor`: joint ``j``'s origin in the frame of the disk's
  first joint after that joint's rotation, ``offset`` summed over the disk's
  joints after its first (MJCF: a body per disk carrying all its joints,
  each hinge about its own anchor, composed in order, as MuJoCo composes a
  body's joints).
* Disk ``k``'s faces, centre of mass and holes: in the frame of its last
  joint after the rotation (URDF); plus the anchor of the disk's last joint,
  in its MJCF body's frame.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import List, Tuple

import numpy as np

from ..inputs import CdsmInputError

__all__ = ["Joint", "Cable", "Chain", "chain", "cylinder_inertia", "fmt", "comment", "xml_text"]


def fmt(*values: float) -> str:
    """Numbers as an XML attribute: each float in its shortest round-trip
    form (``repr``), separated by spaces."""
    return " ".join(repr(float(v)) for v in values)


def comment(text: str) -> ET.Element:
    """An XML comment of ``text`` (any Unicode; ``--``, not allowed in a
    comment, and control characters written apart)."""
    text = "".join(ch if ch.isprintable() else " " for ch in text)
    while "--" in text:
        text = text.replace("--", "- -")
    return ET.Comment(f" {text.rstrip('-')} ")


def cylinder_inertia(mass: float, radius: float, thickness: float) -> Tuple[float, float, float]:
    """Principal moments (kg m^2) of a uniform solid cylinder of ``mass``
    (kg), ``radius`` and ``thickness`` (m) whose axis is ``x``, about its
    centre: ``(m r^2 / 2, m (3 r^2 + t^2) / 12, m (3 r^2 + t^2) / 12)``,
    the last two computed as ``Ixx / 2 + m t^2 / 12`` so that the triangle
    inequality MuJoCo checks (``Iyy + Izz >= Ixx``) holds in floating point
    too (``m (3 r^2 + t^2) / 12`` can round below ``Ixx / 2`` on a thin
    disk, ``t`` much less than ``r``)."""
    ix = mass * radius * radius / 2.0
    iy = ix / 2.0 + mass * thickness * thickness / 12.0
    return ix, iy, iy


def xml_text(root: ET.Element, what: str, name: str) -> str:
    """The XML document of ``root`` (a UTF-8 declaration, indented),
    checked to be well-formed by parsing it back, so that no caller writes
    a file every XML reader refuses: :class:`CdsmInputError` naming
    ``what`` (``to_mjcf``, ``to_urdf``) and the robot ``name`` (the one
    free text in an export) otherwise."""
    ET.indent(root, space="  ")
    text = '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
    try:
        ET.fromstring(text.encode("utf-8"))
    except (ET.ParseError, UnicodeEncodeError) as exc:
        raise CdsmInputError(f"{what}: the XML of robot {name!r} would not be well-formed ({exc}): the name holds a "
                             "character XML forbids (a control character, U+FFFE, U+FFFF or a lone surrogate); "
                             "nothing written") from None
    return text


@dataclass(frozen=True)
class Joint:
    """Joint ``index`` (0-based, cdsm's order) of disk ``disk`` (1-based):
    ``pos`` (3,) m and ``anchor`` (3,) m (see the module doc), the unit
    ``axis`` (3,) in its frame, ``limits`` (lo, hi) rad; ``first`` and
    ``last``: the disk's first or last joint."""

    index: int
    disk: int
    pos: np.ndarray
    anchor: np.ndarray
    axis: np.ndarray
    limits: Tuple[float, float]
    first: bool
    last: bool


@dataclass(frozen=True)
class Cable:
    """Cable ``index`` (0-based, cdsm's order) ending at disk ``end``
    (1-based): ``mode`` (``"position"`` or ``"force"``), set ``tension`` (N,
    force cables), and its ``2 end + 1`` holes as ``(disk, point)``: disk 0
    the base (point in the base frame), else the point in disk ``k``'s frame
    (its last joint's, m): base face b, then faces a and b of disks ``1 ..
    end``."""

    index: int
    end: int
    mode: str
    tension: float
    holes: List[Tuple[int, np.ndarray]]


@dataclass(frozen=True)
class Chain:
    """The arm for the exporters: joints, disks (faces a and b, centres of
    mass in the disk's frame, m; masses, kg; thickness and radii, m; the base
    radius), cables and gravity (3,) m/s^2 in the base frame."""

    name: str
    kind: str
    joints: List[Joint]
    face_a: np.ndarray
    face_b: np.ndarray
    com: np.ndarray
    mass: np.ndarray
    thickness: np.ndarray
    radius: np.ndarray
    base_radius: float
    cables: List[Cable]
    gravity: np.ndarray

    @property
    def disks(self) -> int:
        """Number of disks."""
        return len(self.mass)


def chain(robot) -> Chain:
    """The chain of ``robot`` (a :class:`cdsm.Robot` of either kind)."""
    offsets, axes, limits = robot.offsets, robot.axes, robot.joint_limits
    disk_of = robot.joint_disks
    thickness = robot.disk_thickness
    face_a = robot.disk_link_after
    face_b = face_a + np.outer(thickness, [1.0, 0.0, 0.0])
    joints: List[Joint] = []
    for j in range(robot.n):
        k = disk_of[j]
        first = j == 0 or disk_of[j - 1] != k
        last = j == robot.n - 1 or disk_of[j + 1] != k
        pos = face_b[k - 2] + offsets[j] if first and k > 1 else offsets[j].copy()
        anchor = np.zeros(3) if first else joints[-1].anchor + offsets[j]
        joints.append(Joint(j, k, pos, anchor, axes[j].copy(), (float(limits[j, 0]), float(limits[j, 1])),
                            first, last))
    position = set(robot.position_cables)
    tensions = robot.cable_tensions
    flat, at, cables = robot.flat_holes, 0, []
    for c, e in enumerate(robot.cable_ends):
        h = flat[at:at + 3 * (2 * e + 1)].reshape(-1, 3)
        at += 3 * (2 * e + 1)
        holes = [(0, h[0])]
        for k in range(1, e + 1):
            holes.append((k, face_a[k - 1] + h[2 * k - 1]))
            holes.append((k, face_b[k - 1] + h[2 * k]))
        cables.append(Cable(c, e, "position" if c in position else "force", float(tensions[c]), holes))
    radii = robot.radii
    return Chain(robot.name, robot.kind, joints, face_a, face_b, face_a + robot.com, robot.mass, thickness,
                 radii[1:], float(radii[0]), cables, np.asarray(robot.core.gravity, dtype=float))
