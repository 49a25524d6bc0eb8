"""One description of an arm of either kind, and the reader of both robot-file forms.

Written from ``docs/model.md`` ("The arm model": both kinds of robot file read
into one model) and ``docs/spatial.md`` ("Robot file"), and the planar file
format of ``README.md``.  Independent of the Rust core.

An arm (:class:`Robot`) has revolute joints ``j = 1..n`` (a unit ``axis``, an
``offset`` in the previous frame, ``joint_limits``), disks ``k = 1..K`` (the
joints before each, ``link_after``, ``thickness``, ``radius``, ``mass`` and
centre of mass ``com``), cables ``c = 0..m-1`` (the disk each ends at, its
control mode, a force cable's tension, a hole on every face it crosses),
the cable material and gravity.  Its ``kind`` (``"planar"`` or
``"spatial"``) is the form its file was written in and fixes the task space
(planar: ``x, y, phi``; spatial: ``x, y, z`` and a rotation vector).

The planar shorthand (``[[linkage]]`` tables with ``link_before``,
``link_after``, ``thickness``, ``hole_height`` or ``upper_holes`` /
``lower_holes``, ``mass``, ``lower_tension``, ``joint_limits``) desugars as
``docs/model.md`` defines it: every axis ``z``, ``offset_i = (link_before[i],
0, 0)``, ``link_after_i = (link_after[i], 0, 0)``, holes ``(x, y, 0)``, cable
``2i`` (upper) position-controlled and ``2i + 1`` (lower) force-controlled at
``lower_tension[i]``, both ending at disk ``i + 1``, each linkage's mass at
its disk's centre ``(thickness/2, 0, 0)``; a disk's radius is the largest
``|y|`` of its holes.  The planar closed forms read the arm back in the
planar layout (:class:`PlanarView`, ``Robot.planar``).

Units: SI everywhere -- m, rad, N, kg, Pa, m/s^2.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .rotations import log_so3

__all__ = [
    "Kind",
    "KINDS",
    "Robot",
    "PlanarView",
    "read_robot",
    "load_robot",
    "as_robot",
    "position_cables",
    "force_cables",
    "displacement_cables",
    "axis_class",
    "AXIS_CLASS_TOL",
    "used_hole_mask",
    "hole_height_moves",
    "hole_height_error",
    "to_planar_layout",
    "STANDARD_GRAVITY",
    "PAPER_JOINT_LIMIT",
]

#: Defaults of the cable material (steel, 0.18 mm), both file forms.
DEFAULT_YOUNGS_MODULUS = 1.8e11
DEFAULT_DIAMETER = 0.18e-3

#: Standard gravity (m/s^2): hanging weights given in kg.
STANDARD_GRAVITY = 9.80665

#: Joint limit of the paper prototype, rad (35 deg).
PAPER_JOINT_LIMIT = float(np.deg2rad(35.0))

_MODES = ("position", "force", "displacement")

#: A joint axis within this angle (rad) of the perpendicular to, or of the direction of, its
#: frame's x axis (the backbone) is a bending, or a torsion, joint of a ``[backbone]``.
AXIS_CLASS_TOL = 1e-9


# --------------------------------------------------------------------------
# The kinds of arm
# --------------------------------------------------------------------------
class Kind(str):
    """An arm's kind (``"planar"`` or ``"spatial"``, a string) with the facts that differ
    between the kinds, so that the algorithms ask it instead of branching (``docs/model.md``,
    "The arm model"; ``docs/spatial.md``).

    ``dim``: the position coordinates of the task vector (2: ``x, y``; 3: ``x, y, z``).
    ``rotation``: the task's attitude, ``"angle"`` (one angle about ``z``, kept unwrapped:
    ``phi = theta_1 + ... + theta_n``) or ``"vector"`` (the principal rotation vector).
    ``task_rows``: the rows of the end frame's ``[linear; angular]`` velocity (or of a
    wrench ``[F; M]``) that the task vector takes (planar ``x, y`` and the turn about
    ``z``).  ``masks``: the IK masks by name, each ``(position weights (dim,), rotation
    form, rotation weight)``, the rotation form ``"free"``, ``"angle"``, ``"pointing"``
    or ``"log"``; ``default_mask``.  ``layout``: the plant's parameter blocks in the order
    of the flat vector, ``(effect, size rule)`` (``docs/model.md``, "Parameters"; the
    rules are :mod:`.plant`'s).
    """

    dim: int
    rotation: str
    task_rows: tuple
    masks: dict
    default_mask: str
    layout: tuple

    def __new__(cls, name, dim, rotation, task_rows, masks, default_mask, layout):
        kind = super().__new__(cls, name)
        kind.dim, kind.rotation, kind.task_rows = dim, rotation, tuple(task_rows)
        kind.masks, kind.default_mask, kind.layout = dict(masks), default_mask, tuple(layout)
        return kind

    def attitude(self, R: np.ndarray, theta: np.ndarray, turn: float = 0.0) -> np.ndarray:
        """The task's attitude ``(N, 1)`` or ``(N, 3)`` rad of frames ``R (N, 3, 3)`` of the arm
        at ``theta (N, n)`` rad: ``sum(theta) + turn`` (``turn`` a rotation about ``z``
        applied to the frame) or the principal rotation vector of ``R``."""
        if self.rotation == "angle":
            return theta.sum(axis=1, keepdims=True) + turn
        return log_so3(R)

    def attitude_change(self, R0: np.ndarray, R1: np.ndarray, theta0: np.ndarray, theta1: np.ndarray):
        """The attitude's change ``(N, 1)`` or ``(N, 3)`` rad from ``(R0, theta0)`` to ``(R1,
        theta1)``: the angle's difference, or the rotation ``R0 log(R0^T R1)`` in the base frame."""
        if self.rotation == "angle":
            return self.attitude(R1, theta1) - self.attitude(R0, theta0)
        return np.einsum("nij,nj->ni", R0, log_so3(np.swapaxes(R0, 1, 2) @ R1))


#: The two kinds.  Planar: task ``[x, y, phi]``, IK masks ``"pose"`` and ``"position"`` (or
#: three weights on ``x, y, phi``), the parameter layout of cdsm 0.1; spatial: task ``[x, y, z,
#: rx, ry, rz]``, masks ``"position"``, ``"pointing"``, ``"pose"``, the layout of cdsm 0.2
#: and the effects added since.
KINDS = {
    "planar": Kind(
        "planar", dim=2, rotation="angle", task_rows=(0, 1, 5),
        masks={"pose": ((1.0, 1.0), "angle", 1.0), "position": ((1.0, 1.0), "free", 0.0)}, default_mask="pose",
        layout=(("actuation_scale", "one"), ("cable_offset", "position cables"),
                ("hole_height", "disk hole heights"), ("link_length", "first offset and links along x"),
                ("cable_elasticity", "one"), ("hole_clearance", "one"),
                ("frame_misalignment", "turn about z and origin in the plane"), ("tip_offset", "point in the plane"),
                ("backlash", "position cables"), ("clearance_width", "one"), ("cable_friction", "one"))),
    "spatial": Kind(
        "spatial", dim=3, rotation="vector", task_rows=(0, 1, 2, 3, 4, 5),
        masks={"position": ((1.0, 1.0, 1.0), "free", 0.0), "pointing": ((1.0, 1.0, 1.0), "pointing", 1.0),
               "pose": ((1.0, 1.0, 1.0), "log", 1.0)}, default_mask="pose",
        layout=(("actuation_scale", "one"), ("cable_offset", "position cables"),
                ("hole_position", "position cables' hole points"),
                ("link_length", "offsets and links"), ("cable_elasticity", "one"),
                ("frame_misalignment", "rotation vector and origin"), ("tip_offset", "point in space"),
                ("backlash", "position cables"), ("hole_clearance", "one"), ("clearance_width", "one"),
                ("joint_axis", "joint tilts"), ("cable_friction", "one"))),
}


# --------------------------------------------------------------------------
# The description
# --------------------------------------------------------------------------
@dataclass
class Robot:
    """An arm, every number explicit (SI units).

    ``n`` joints (numbered over all disks in order), ``K`` disks, ``m`` cables.

    ================  ==================  ===============================================
    field             shape               meaning
    ================  ==================  ===============================================
    ``name``          str
    ``kind``          :class:`Kind`       ``"planar"`` or ``"spatial"``, with its facts
    ``axes``          ``(n, 3)``          unit joint axes, in the joint frame
    ``offsets``       ``(n, 3)``          m, previous frame -> joint, previous frame
    ``joint_limits``  ``(n, 2)``          rad, ``[lo, hi]``
    ``joint_disk``    ``(n,)`` int        the disk (1-based) joint ``j`` moves
    ``link_after``    ``(K, 3)``          m, last joint -> proximal face of disk k
    ``thickness``     ``(K,)``            m, along the disk's local x axis
    ``radius``        ``(K,)``            m, disk radius (holes lie within)
    ``mass``          ``(K,)``            kg
    ``com``           ``(K, 3)``          m, centre of mass in the proximal-face frame
    ``base_radius``   float               m
    ``gravity``       ``(3,)``            m/s^2, base frame
    ``cable_end``     ``(m,)`` int        the disk cable c is fixed to (1-based)
    ``cable_mode``    tuple of str        ``"position"`` or ``"force"``
    ``cable_tension`` ``(m,)``            N for force cables, NaN for position cables
    ``holes``         tuple of arrays     m, per cable ``(2 e_c + 1, 3)`` face-frame
                                          points: base face b, then faces a, b of
                                          disks ``1..e_c``
    ``youngs_modulus`` float              Pa
    ``diameter``      float               m
    ``routing_length`` float              m, every cable's path behind the base disk
    ``stretch_feed_forward`` bool         the controller feeds the cable's frictionless
                                          stretch forward (``docs/model.md``, "Commands")
    ``cable_stated``  bool                the robot file states its cable (a ``[cable]``
                                          table; else the default is a placeholder): an
                                          arm with more position cables than joints
                                          settles on it (``docs/model.md``, "Settling")
    ``joint_stiffness`` ``(n,)``          N m/rad, the joint's spring (0: a free joint)
    ``rest_angle``    ``(n,)``            rad, the spring's rest angle
    ``cable_stiffness`` ``(m,)``          N/m, a displacement cable's actuator (inf:
                                          rigid; inf for the other modes)
    ``pretension``    ``(m,)``            N, a displacement cable's tension at ``d = 0``
                                          in the rest pose; a position cable's at its
                                          commanded length (``docs/model.md``,
                                          "Settling"); 0 for force cables
    ``max_tension``   ``(m,)``            N, a displacement cable's cap (inf: none)
    ================  ==================  ===============================================

    The last five default to a free, unloaded arm (``docs/model.md``, "Elastic arms").
    """

    name: str
    kind: Kind
    axes: np.ndarray
    offsets: np.ndarray
    joint_limits: np.ndarray
    joint_disk: np.ndarray
    link_after: np.ndarray
    thickness: np.ndarray
    radius: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    base_radius: float
    gravity: np.ndarray
    cable_end: np.ndarray
    cable_mode: tuple
    cable_tension: np.ndarray
    holes: tuple
    youngs_modulus: float = DEFAULT_YOUNGS_MODULUS
    diameter: float = DEFAULT_DIAMETER
    routing_length: float = 0.0
    stretch_feed_forward: bool = True
    cable_stated: bool = False
    joint_stiffness: np.ndarray = None
    rest_angle: np.ndarray = None
    cable_stiffness: np.ndarray = None
    pretension: np.ndarray = None
    max_tension: np.ndarray = None

    def __post_init__(self):
        n, m = int(self.axes.shape[0]), int(self.cable_end.shape[0])
        for name, size, default in (("joint_stiffness", n, 0.0), ("rest_angle", n, 0.0),
                                    ("cable_stiffness", m, np.inf), ("pretension", m, 0.0),
                                    ("max_tension", m, np.inf)):
            value = getattr(self, name)
            value = np.full(size, default) if value is None else np.array(value, dtype=float).reshape(size)
            setattr(self, name, value)

    @property
    def n(self) -> int:
        """Number of joints."""
        return int(self.axes.shape[0])

    @property
    def disks(self) -> int:
        """Number of disks ``K``, the base disk not counted."""
        return int(self.thickness.shape[0])

    @property
    def m(self) -> int:
        """Number of cables."""
        return int(self.cable_end.shape[0])

    @property
    def planar(self) -> "PlanarView":
        """The arm in the planar layout (:class:`PlanarView`); ``ValueError`` when it
        is not a planar arm (every axis ``z``, one joint per disk, links along ``x``,
        cables in upper/lower pairs, holes in the plane)."""
        return PlanarView.of(self)

    @classmethod
    def from_heights(cls, link_before, link_after, thickness, hole_height, joint_limits=None, mass=None,
                     lower_tension=None, gravity=None, name="planar arm", **material) -> "Robot":
        """A planar arm with straight holes at ``+-hole_height`` ``(n,)`` m: the planar
        shorthand with ``hole_height``.  ``joint_limits`` ``(n, 2)`` rad (default
        ``[-pi, pi]``), ``mass`` ``(n,)`` kg and ``lower_tension`` ``(n,)`` N (default
        0), in-plane ``gravity`` ``(2,)`` m/s^2 (default none); ``material``:
        ``youngs_modulus``, ``diameter``, ``routing_length``, ``stretch_feed_forward``."""
        h = np.asarray(hole_height, dtype=float).reshape(-1)
        n = h.size
        holes = np.zeros((2 * n, n + 1, 2, 2))
        mask = used_hole_mask(n)
        for c in range(2 * n):
            holes[c, mask[c], 1] = (1.0 if c % 2 == 0 else -1.0) * h[c // 2]
        return _planar_robot(name, link_before, link_after, thickness, holes, joint_limits, mass, lower_tension,
                             gravity, **material)

    @classmethod
    def paper(cls) -> "Robot":
        """The 3-DOF prototype of the seed paper (Table 1): links 33 mm, disks 10 mm,
        holes at 30, 28, 26 mm, joint limits +-35 deg, lower cables 50, 10, 5 g,
        linkage masses 32.2, 33.4, 21.0 g, a horizontal plane."""
        return cls.from_heights(
            link_before=[0.033, 0.033, 0.033],
            link_after=[0.033, 0.033, 0.033],
            thickness=[0.010, 0.010, 0.010],
            hole_height=[0.030, 0.028, 0.026],
            joint_limits=np.tile([-PAPER_JOINT_LIMIT, PAPER_JOINT_LIMIT], (3, 1)),
            mass=[0.0322, 0.0334, 0.0210],
            lower_tension=np.array([50.0, 10.0, 5.0]) * 1e-3 * STANDARD_GRAVITY,
            name="paper prototype (Table 1)",
        )

    @classmethod
    def like(cls, robot) -> "Robot":
        """A :class:`Robot` of ``robot``: a copy of one, or a planar arm read from any
        object with the planar attributes (``link_before``, ``link_after``,
        ``thickness`` ``(n,)`` m, ``holes`` ``(2n, n+1, 2, 2)`` m, ``joint_limits``
        ``(n, 2)`` rad; optional ``mass``, ``lower_tension``, in-plane ``gravity``,
        ``routing_length``, ``youngs_modulus``, ``cable_diameter``, ``stretch_feed_forward``) such as
        ``cdsm.Robot``."""
        if isinstance(robot, Robot):
            return dataclasses.replace(robot)

        def opt(name, default=None):
            v = getattr(robot, name, None)
            return default if v is None else v

        return _planar_robot(
            str(opt("name", "planar arm")), robot.link_before, robot.link_after, robot.thickness, robot.holes,
            robot.joint_limits, opt("mass"), opt("lower_tension"), opt("gravity"),
            youngs_modulus=float(opt("youngs_modulus", DEFAULT_YOUNGS_MODULUS)),
            diameter=float(opt("cable_diameter", opt("diameter", DEFAULT_DIAMETER))),
            routing_length=float(opt("routing_length", 0.0)),
            stretch_feed_forward=bool(opt("stretch_feed_forward", True)),
        )

    def with_holes(self, holes) -> "Robot":
        """The same arm with other holes: one ``(2 e_c + 1, 3)`` m array per cable."""
        holes = tuple(np.array(h, dtype=float) for h in holes)
        if len(holes) != self.m or any(h.shape != g.shape for h, g in zip(holes, self.holes)):
            raise ValueError(f"holes must be {self.m} arrays of shapes {[g.shape for g in self.holes]}")
        return dataclasses.replace(self, holes=holes)

    def with_planar_holes(self, holes) -> "Robot":
        """The same planar arm with other holes in the planar layout ``(2n, n+1, 2, 2)`` m
        (``holes[c, d, f] = (x, y)``, :class:`PlanarView`; unused entries ignored)."""
        n = self.planar.n
        holes = np.asarray(holes, dtype=float).reshape(2 * n, n + 1, 2, 2)
        return self.with_holes(_cable_holes(holes))


def as_robot(robot) -> Robot:
    """``robot`` itself when it is a :class:`Robot`, else :meth:`Robot.like` of it."""
    return robot if isinstance(robot, Robot) else Robot.like(robot)


def position_cables(robot: Robot) -> np.ndarray:
    """Indices (0-based, file order) of the position-controlled cables, ``(m_pos,)`` int."""
    return np.array([c for c, mode in enumerate(robot.cable_mode) if mode == "position"], dtype=np.int64)


def force_cables(robot: Robot) -> np.ndarray:
    """Indices (0-based, file order) of the force-controlled cables, ``(m_f,)`` int."""
    return np.array([c for c, mode in enumerate(robot.cable_mode) if mode == "force"], dtype=np.int64)


def displacement_cables(robot: Robot) -> np.ndarray:
    """Indices (0-based, file order) of the cables commanded in displacement through a
    series stiffness (``docs/model.md``, "Elastic arms"), ``(m_d,)`` int."""
    return np.array([c for c, mode in enumerate(robot.cable_mode) if mode == "displacement"], dtype=np.int64)


def axis_class(axis) -> str | None:
    """How a ``[backbone]`` reads a joint of unit ``axis (3,)`` (in the joint's frame, whose
    ``x`` is the backbone's direction there): ``"bending"`` when the axis is perpendicular
    to ``x`` (``|a_x| <= AXIS_CLASS_TOL``), ``"torsion"`` when it lies along ``x``
    (``sqrt(a_y^2 + a_z^2) <= AXIS_CLASS_TOL``), else None (a backbone derives no
    stiffness for it)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    if abs(a[0]) <= AXIS_CLASS_TOL:
        return "bending"
    if math.hypot(a[1], a[2]) <= AXIS_CLASS_TOL:
        return "torsion"
    return None


def hole_height_moves(robot: Robot, dh) -> tuple:
    """The paper's "error on disk i's holes" (``docs/model.md``, the plant's ``hole_height``)
    as moves of the holes: one ``(2 e_c + 1, 3)`` m array per cable, every hole of the
    cables ending at disk ``i`` along its local ``y`` by ``dh_i`` m (``dh (K,)``), a
    position cable's ``+dh_i``, a force cable's ``-dh_i``, on every face the cable crosses."""
    robot = as_robot(robot)
    dh = np.asarray(dh, dtype=float).reshape(robot.disks)
    moves = []
    for c, h in enumerate(robot.holes):
        d = np.zeros_like(h)
        d[:, 1] = (1.0 if robot.cable_mode[c] == "position" else -1.0) * dh[robot.cable_end[c] - 1]
        moves.append(d)
    return tuple(moves)


def hole_height_error(robot: Robot, dh) -> Robot:
    """The arm with its holes moved by :func:`hole_height_moves` of ``dh (K,)`` m."""
    robot = as_robot(robot)
    return robot.with_holes(h + d for h, d in zip(robot.holes, hole_height_moves(robot, dh)))


def to_planar_layout(robot: Robot, values) -> np.ndarray:
    """An array over the arm's hole coordinates, last axis ``3H`` (every cable's holes
    flat: cable by cable, point by point, ``x, y, z``), in the planar layout: last
    axes ``(2n, n+1, 2, 2)`` (``[c, d, f] = (x, y)``, :class:`PlanarView`; ``z``
    dropped, entries no cable uses 0)."""
    n = robot.planar.n
    values = np.asarray(values, dtype=float)
    out = np.zeros(values.shape[:-1] + (2 * n, n + 1, 2, 2))
    start = 0
    for c, h in enumerate(robot.holes):
        pts = values[..., start:start + h.size].reshape(values.shape[:-1] + h.shape)[..., :2]
        start += h.size
        out[..., c, 0, 1, :] = pts[..., 0, :]
        for d in range(1, c // 2 + 2):
            out[..., c, d, 0, :] = pts[..., 2 * d - 1, :]
            out[..., c, d, 1, :] = pts[..., 2 * d, :]
    return out


# --------------------------------------------------------------------------
# The planar layout
# --------------------------------------------------------------------------
def used_hole_mask(n: int) -> np.ndarray:
    """Boolean mask ``(2n, n+1, 2)`` of the entries of the planar hole layout a planar
    arm of ``n`` joints uses: ``mask[c, d, f]`` is True when cable ``c`` crosses face
    ``f`` of disk ``d`` (``d = 0`` the base, face ``b`` only; ``1 <= d <= c // 2 + 1``
    both faces)."""
    mask = np.zeros((2 * n, n + 1, 2), dtype=bool)
    for c in range(2 * n):
        mask[c, 0, 1] = True
        mask[c, 1:c // 2 + 2, :] = True
    return mask


def _cable_holes(layout: np.ndarray) -> tuple:
    """Per-cable ``(2 e + 1, 3)`` holes of the planar layout ``(2n, n+1, 2, 2)``: cable
    ``c`` ends at disk ``e = c // 2 + 1``; ``z = 0``."""
    out = []
    for c in range(layout.shape[0]):
        e = c // 2 + 1
        pts = [layout[c, 0, 1]] + [layout[c, d, f] for d in range(1, e + 1) for f in (0, 1)]
        out.append(np.column_stack([np.array(pts), np.zeros(2 * e + 1)]))
    return tuple(out)


@dataclass
class PlanarView:
    """A planar arm in the planar layout of ``docs/model.md`` (read-only numbers
    derived from a :class:`Robot`; the planar closed forms read these).

    ``link_before``, ``link_after``, ``thickness`` ``(n,)`` m; ``holes``
    ``(2n, n+1, 2, 2)`` m, ``holes[c, d, f] = (x, y)`` of cable ``c`` in disk ``d``
    (0 the base), face ``f`` (0 = a, 1 = b), entries no cable uses 0;
    ``joint_limits`` ``(n, 2)`` rad; ``lower_tension`` ``(n,)`` N; ``mass`` ``(n,)``
    kg; ``gravity`` ``(2,)`` m/s^2."""

    link_before: np.ndarray
    link_after: np.ndarray
    thickness: np.ndarray
    holes: np.ndarray
    joint_limits: np.ndarray
    lower_tension: np.ndarray
    mass: np.ndarray
    gravity: np.ndarray

    @property
    def n(self) -> int:
        return int(self.link_before.size)

    @classmethod
    def of(cls, robot: Robot) -> "PlanarView":
        """The planar view of ``robot``; ``ValueError`` naming what is not planar."""
        n = robot.n
        if robot.disks != n or not np.array_equal(robot.joint_disk, np.arange(1, n + 1)):
            raise ValueError("not a planar arm: one joint per disk is needed")
        if not np.array_equal(robot.axes, np.tile([0.0, 0.0, 1.0], (n, 1))):
            raise ValueError("not a planar arm: every joint axis must be z")
        if np.any(robot.offsets[:, 1:] != 0.0) or np.any(robot.link_after[:, 1:] != 0.0):
            raise ValueError("not a planar arm: offsets and link_after must lie along x")
        want_end = np.arange(2 * n) // 2 + 1
        want_mode = tuple("position" if c % 2 == 0 else "force" for c in range(2 * n))
        if robot.m != 2 * n or not np.array_equal(robot.cable_end, want_end) or robot.cable_mode != want_mode:
            raise ValueError("not a planar arm: cables must come in pairs (upper position, lower force) "
                             "ending at disks 1..n")
        if any(np.any(h[:, 2] != 0.0) for h in robot.holes):
            raise ValueError("not a planar arm: every hole must lie in the plane z = 0")
        holes = np.zeros((2 * n, n + 1, 2, 2))
        for c, h in enumerate(robot.holes):
            holes[c, 0, 1] = h[0, :2]
            for d in range(1, c // 2 + 2):
                holes[c, d, 0] = h[2 * d - 1, :2]
                holes[c, d, 1] = h[2 * d, :2]
        return cls(
            link_before=robot.offsets[:, 0].copy(),
            link_after=robot.link_after[:, 0].copy(),
            thickness=np.array(robot.thickness, dtype=float),
            holes=holes,
            joint_limits=np.array(robot.joint_limits, dtype=float),
            lower_tension=np.array(robot.cable_tension[1::2], dtype=float),
            mass=np.array(robot.mass, dtype=float),
            gravity=np.array(robot.gravity[:2], dtype=float),
        )


def _planar_robot(name, link_before, link_after, thickness, holes, joint_limits=None, mass=None,
                  lower_tension=None, gravity=None, youngs_modulus=DEFAULT_YOUNGS_MODULUS,
                  diameter=DEFAULT_DIAMETER, routing_length=0.0, stretch_feed_forward=True, joint_stiffness=None,
                  rest_angle=None) -> Robot:
    """The desugar of the planar shorthand (``docs/model.md``, "The arm model"), from
    the planar layout ``holes (2n, n+1, 2, 2)`` m (unused entries ignored); the joint
    springs ``joint_stiffness (n,)`` N m/rad and ``rest_angle (n,)`` rad (default free)."""
    lb = np.asarray(link_before, dtype=float).reshape(-1)
    n = lb.size
    if n < 1:
        raise ValueError("linkage: at least one linkage is needed")
    la = np.asarray(link_after, dtype=float).reshape(n)
    t = np.asarray(thickness, dtype=float).reshape(n)
    limits = (np.tile([-math.pi, math.pi], (n, 1)) if joint_limits is None
              else np.asarray(joint_limits, dtype=float).reshape(n, 2))
    mass = np.zeros(n) if mass is None else np.asarray(mass, dtype=float).reshape(n)
    lower = np.zeros(n) if lower_tension is None else np.asarray(lower_tension, dtype=float).reshape(n)
    g = np.zeros(2) if gravity is None else np.asarray(gravity, dtype=float).reshape(2)
    cable_holes = _cable_holes(np.asarray(holes, dtype=float).reshape(2 * n, n + 1, 2, 2))

    def radius(d):
        """The largest |y| of the holes on disk d (0 the base)."""
        rows = [h[:1] if d == 0 else h[2 * d - 1:2 * d + 1] for c, h in enumerate(cable_holes) if c // 2 + 1 >= d]
        return float(np.abs(np.concatenate(rows)[:, 1]).max())

    zeros = np.zeros((n, 2))
    return Robot(
        name=name,
        kind=KINDS["planar"],
        axes=np.tile([0.0, 0.0, 1.0], (n, 1)),
        offsets=np.column_stack([lb, zeros]),
        joint_limits=limits.copy(),
        joint_disk=np.arange(1, n + 1, dtype=np.int64),
        link_after=np.column_stack([la, zeros]),
        thickness=t.copy(),
        radius=np.array([radius(d) for d in range(1, n + 1)]),
        mass=mass.copy(),
        com=np.column_stack([0.5 * t, zeros]),
        base_radius=radius(0),
        gravity=np.array([g[0], g[1], 0.0]),
        cable_end=np.arange(2 * n, dtype=np.int64) // 2 + 1,
        cable_mode=tuple("position" if c % 2 == 0 else "force" for c in range(2 * n)),
        cable_tension=np.array([np.nan if c % 2 == 0 else lower[c // 2] for c in range(2 * n)]),
        holes=cable_holes,
        youngs_modulus=float(youngs_modulus),
        diameter=float(diameter),
        routing_length=float(routing_length),
        stretch_feed_forward=bool(stretch_feed_forward),
        joint_stiffness=joint_stiffness,
        rest_angle=rest_angle,
    )


# --------------------------------------------------------------------------
# Reading robot files: checks that name the field
# --------------------------------------------------------------------------
def _number(v, field: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"{field}: must be a number, got {v!r}")
    x = float(v)
    if not math.isfinite(x):
        raise ValueError(f"{field}: must be a finite number, got {v!r}")
    return x


def _positive(v, field: str) -> float:
    x = _number(v, field)
    if x <= 0.0:
        raise ValueError(f"{field}: must be positive, got {v!r}")
    return x


def _non_negative(v, field: str) -> float:
    x = _number(v, field)
    if x < 0.0:
        raise ValueError(f"{field}: must be non-negative, got {v!r}")
    return x


def _vector(v, size: int, field: str) -> np.ndarray:
    if not isinstance(v, list) or len(v) != size:
        raise ValueError(f"{field}: must be a list of {size} numbers, got {v!r}")
    return np.array([_number(x, f"{field}[{i}]") for i, x in enumerate(v)])


def _limits(v, field: str) -> np.ndarray:
    """``[lo, hi]`` rad with ``lo < hi``; default ``[-pi, pi]``."""
    if v is None:
        return np.array([-math.pi, math.pi])
    lim = _vector(v, 2, field)
    if not lim[0] < lim[1]:
        raise ValueError(f"{field}: must be [lo, hi] with lo < hi, got {v!r}")
    return lim


def _table(v, field: str) -> dict:
    if not isinstance(v, dict):
        raise ValueError(f"{field}: must be a table, got {v!r}")
    return v


def _table_list(v, field: str) -> list:
    if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
        raise ValueError(f"{field}: must be a list of tables ([[{field}]] or inline), got {v!r}")
    return v


def _known_keys(table: dict, allowed, field: str) -> None:
    for key in table:
        if key not in allowed:
            raise ValueError(f"{field}.{key}: unknown key" if field else f"{key}: unknown key")


def _required(table: dict, key: str, field: str):
    if key not in table:
        raise ValueError(f"{field}.{key}: missing" if field else f"{key}: missing")
    return table[key]


def _load_toml(text: str) -> dict:
    try:  # tomllib is Python >= 3.11; imported here so that the package imports on 3.9
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover
        try:
            import tomli as tomllib
        except ModuleNotFoundError as exc:
            raise RuntimeError("reading robot files needs Python >= 3.11 (tomllib) or the tomli package") from exc
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"robot file: not valid TOML: {exc}") from exc


def _material(doc: dict) -> dict:
    """The optional ``[cable]`` table: ``youngs_modulus`` Pa, ``diameter`` m,
    ``routing_length`` m (defaults steel, 0.18 mm, 0 m), ``stretch_feed_forward`` (default true)."""
    table = _table(doc.get("cable", {}), "cable")
    _known_keys(table, {"youngs_modulus", "diameter", "routing_length", "stretch_feed_forward"}, "cable")
    feed = table.get("stretch_feed_forward", True)
    if not isinstance(feed, bool):
        raise ValueError(f"cable.stretch_feed_forward: must be true or false, got {feed!r}")
    return dict(stretch_feed_forward=feed,
        youngs_modulus=_positive(table.get("youngs_modulus", DEFAULT_YOUNGS_MODULUS), "cable.youngs_modulus"),
        diameter=_positive(table.get("diameter", DEFAULT_DIAMETER), "cable.diameter"),
        routing_length=_non_negative(table.get("routing_length", 0.0), "cable.routing_length"),
    )


def read_robot(text: str) -> Robot:
    """Read a robot file (TOML text) of either form: ``kind = "planar"`` (or no
    ``kind``), the planar shorthand of ``README.md``; ``kind = "spatial"``, the general
    form of ``docs/spatial.md``.

    Errors raise ``ValueError`` whose message starts with the field (1-based indices),
    e.g. ``linkage[2].joints[1].axis: ...``, ``cables[3].end: ...`` or
    ``linkage[1].thickness: ...``.  Unknown keys are rejected.
    """
    doc = _load_toml(text)
    kind = doc.get("kind", "planar")
    if kind not in _FORMS:
        raise ValueError(f'kind: must be "planar" or "spatial", got {kind!r}')
    name = doc.get("name", "")
    if not isinstance(name, str):
        raise ValueError(f"name: must be a string, got {name!r}")
    return _FORMS[kind](doc, name)


def load_robot(path) -> Robot:
    """:func:`read_robot` of the file at ``path``."""
    return read_robot(Path(path).read_text(encoding="utf-8"))


def _read_planar(doc: dict, name: str) -> Robot:
    """The planar shorthand: ``n``, in-plane ``gravity``, ``[cable]``, ``[[linkage]]``."""
    general = sorted({"base", "cables"} & set(doc))
    if general:
        raise ValueError(f'kind: a planar file is written in the planar shorthand; {general[0]!r} belongs to '
                         f'the general form (kind = "spatial")')
    _known_keys(doc, {"kind", "name", "n", "gravity", "cable", "linkage", "backbone"}, "")
    linkages = _table_list(_required(doc, "linkage", ""), "linkage")
    n = len(linkages)
    if n == 0:
        raise ValueError("linkage: at least one linkage is needed")
    if "n" in doc and doc["n"] != n:
        raise ValueError(f"n: declares {doc['n']!r} joints but {n} [[linkage]] tables are given")
    gravity = _vector(doc["gravity"], 2, "gravity") if "gravity" in doc else np.zeros(2)
    keys = {"link_before", "link_after", "thickness", "hole_height", "upper_holes", "lower_holes", "mass",
            "lower_tension", "joint_limits", "stiffness", "rest_angle"}
    lb, la, t, mass, lower, limits, springs = [], [], [], [], [], [], []
    holes = np.zeros((2 * n, n + 1, 2, 2))
    mask = used_hole_mask(n)
    for i, lk in enumerate(linkages):
        f = f"linkage[{i + 1}]"
        _known_keys(lk, keys, f)
        lb.append(_positive(_required(lk, "link_before", f), f"{f}.link_before"))
        la.append(_positive(_required(lk, "link_after", f), f"{f}.link_after"))
        t.append(_positive(_required(lk, "thickness", f), f"{f}.thickness"))
        mass.append(_non_negative(lk.get("mass", 0.0), f"{f}.mass"))
        lower.append(_non_negative(lk.get("lower_tension", 0.0), f"{f}.lower_tension"))
        limits.append(_limits(lk.get("joint_limits"), f"{f}.joint_limits"))
        springs.append(_spring(lk, "stiffness", "rest_angle", limits[-1], f))
        count = 2 * i + 3  # base face b, then faces a, b of disks 1..i+1
        if "hole_height" in lk and not ({"upper_holes", "lower_holes"} & set(lk)):
            h = _positive(lk["hole_height"], f"{f}.hole_height")
            sides = (np.tile([0.0, h], (count, 1)), np.tile([0.0, -h], (count, 1)))
        elif "hole_height" not in lk and {"upper_holes", "lower_holes"} <= set(lk):
            sides = []
            for side in ("upper_holes", "lower_holes"):
                pts = lk[side]
                if not isinstance(pts, list) or len(pts) != count:
                    raise ValueError(f"{f}.{side}: needs {count} [x, y] points (base face b, then faces a and b "
                                     f"of disks 1..{i + 1}), got {pts!r}")
                sides.append(np.array([_vector(p, 2, f"{f}.{side}[{j}]") for j, p in enumerate(pts)]))
        else:
            raise ValueError(f"{f}.hole_height: give either hole_height or both upper_holes and lower_holes")
        for s, pts in enumerate(sides):
            holes[2 * i + s][mask[2 * i + s]] = pts  # C order: base face b, then disks' faces a, b
    stiffness, rest = _joint_springs(doc, springs, np.tile([0.0, 0.0, 1.0], (n, 1)), np.arange(1, n + 1),
                                     [f"linkage[{i + 1}]" for i in range(n)], "stiffness")
    return _planar_robot(name, lb, la, t, holes, limits, mass, lower, gravity, **_material(doc),
                         joint_stiffness=stiffness, rest_angle=rest)


def _spring(table: dict, stiffness_key: str, rest_key: str, limits: np.ndarray, field: str) -> tuple:
    """A joint's ``(stiffness or None, rest)``: ``stiffness`` N m/rad >= 0 (None when not
    given), ``rest`` rad within the joint's limits (default 0)."""
    k = _non_negative(table[stiffness_key], f"{field}.{stiffness_key}") if stiffness_key in table else None
    rest = _number(table[rest_key], f"{field}.{rest_key}") if rest_key in table else 0.0
    if not limits[0] <= rest <= limits[1]:
        raise ValueError(f"{field}.{rest_key}: {rest!r} rad is outside the joint's limits "
                         f"[{limits[0]!r}, {limits[1]!r}] rad")
    return k, rest


def _joint_springs(doc: dict, springs: list, axes: np.ndarray, joint_disk: np.ndarray, fields: list,
                   stiffness_key: str) -> tuple:
    """Every joint's stiffness ``(n,)`` N m/rad and rest angle ``(n,)`` rad: as given
    (``springs``, ``(stiffness or None, rest)`` per joint; a joint without one is free),
    or derived from the ``[backbone]`` table (``docs/model.md``, "Elastic arms"; a joint
    stiffness given beside it is refused).  ``axes (n, 3)`` unit, ``joint_disk (n,)``
    1-based, ``fields`` the joints' field names (the axis is ``{field}.axis`` when it is
    written, as in the general form)."""
    rest = np.array([r for _, r in springs], dtype=float)
    if "backbone" not in doc:
        return np.array([0.0 if k is None else k for k, _ in springs]), rest
    for (k, _), f in zip(springs, fields):
        if k is not None:
            raise ValueError(f"{f}.{stiffness_key}: give either joint stiffnesses or a [backbone], not both "
                             f"(the backbone derives every joint's stiffness)")
    return _backbone_stiffness(_table(doc["backbone"], "backbone"), axes, joint_disk, fields), rest


def _backbone_stiffness(table: dict, axes: np.ndarray, joint_disk: np.ndarray, fields: list) -> np.ndarray:
    """Joint stiffnesses ``(n,)`` N m/rad of a ``[backbone]``: a solid rod (``radius`` m,
    ``youngs_modulus`` E and ``shear_modulus`` G, Pa) in ``[[backbone.segments]]``
    (``length`` m, ``links``: the number of consecutive disks it spans, base to tip; the
    links add up to the disks).  A joint of a disk of segment ``s`` has ``l = length_s /
    links_s`` and ``k = E I / l`` (bending, ``I = pi r^4 / 4``) or ``k = G J / l``
    (torsion, ``J = pi r^4 / 2``) by :func:`axis_class`; an axis neither is refused."""
    _known_keys(table, {"youngs_modulus", "shear_modulus", "radius", "segments"}, "backbone")
    E = _positive(_required(table, "youngs_modulus", "backbone"), "backbone.youngs_modulus")
    G = _positive(table["shear_modulus"], "backbone.shear_modulus") if "shear_modulus" in table else None
    r = _positive(_required(table, "radius", "backbone"), "backbone.radius")
    segments = _table_list(_required(table, "segments", "backbone"), "backbone.segments")
    if not segments:
        raise ValueError("backbone.segments: at least one segment is needed")
    link = []  # the link length l of every disk, base to tip
    for i, sg in enumerate(segments, start=1):
        f = f"backbone.segments[{i}]"
        _known_keys(sg, {"length", "links"}, f)
        length = _positive(_required(sg, "length", f), f"{f}.length")
        links = _required(sg, "links", f)
        if isinstance(links, bool) or not isinstance(links, int) or links < 1:
            raise ValueError(f"{f}.links: must be a whole number of disks >= 1, got {links!r}")
        link += [length / links] * links
    K = int(joint_disk.max())
    if len(link) != K:
        raise ValueError(f"backbone.segments: the segments' links add up to {len(link)} but the arm has {K} "
                         f"disks (one link per disk, base to tip)")
    area_moment = math.pi * r**4 / 4.0  # I, m^4
    out = np.empty(len(axes))
    for j, (a, k, f) in enumerate(zip(axes, joint_disk, fields)):
        link_length = link[int(k) - 1]
        kind = axis_class(a)
        if kind == "bending":
            out[j] = E * area_moment / link_length
        elif kind == "torsion":
            if G is None:
                raise ValueError(f"backbone.shear_modulus: missing ({f} is a torsion joint: its axis lies along "
                                 f"the backbone)")
            out[j] = G * 2.0 * area_moment / link_length
        else:
            raise ValueError(f"{f}.axis: a [backbone] derives bending joints (axis perpendicular to the "
                             f"backbone, the joint frame's x) and torsion joints (axis along x); "
                             f"{[float(v) for v in a]} is neither")
    return out


def _read_general(doc: dict, name: str) -> Robot:
    """The general form: ``gravity``, ``[base]``, ``[[linkage]]`` with ``joints``,
    ``[[cables]]``, ``[cable]`` (``docs/spatial.md``).  Defaults where the spec gives
    none: joint ``offset`` ``[0, 0, 0]``, ``mass`` 0 kg, ``com`` the disk centre."""
    _known_keys(doc, {"kind", "name", "gravity", "base", "linkage", "cables", "cable", "backbone"}, "")
    gravity = _vector(doc["gravity"], 3, "gravity") if "gravity" in doc else np.zeros(3)
    base = _table(_required(doc, "base", ""), "base")
    _known_keys(base, {"radius"}, "base")
    base_radius = _positive(_required(base, "radius", "base"), "base.radius")
    joints, disks = _general_linkages(_table_list(_required(doc, "linkage", ""), "linkage"))
    radii = [base_radius] + [d["radius"] for d in disks]
    cables = _general_cables(_table_list(_required(doc, "cables", ""), "cables"), radii)
    n = len(joints)
    axes = np.array([j["axis"] for j in joints]).reshape(n, 3)
    joint_disk = np.array([j["disk"] for j in joints], dtype=np.int64)
    stiffness, rest = _joint_springs(doc, [j["spring"] for j in joints], axes, joint_disk,
                                     [j["field"] for j in joints], "stiffness")
    n_pos = sum(c["mode"] == "position" for c in cables)
    n_cmd = n_pos + sum(c["mode"] == "displacement" for c in cables)
    n_free = int(np.sum(stiffness == 0.0))
    if n_cmd < n_free:
        if n_free == n and n_cmd == n_pos:
            raise ValueError(f"cables: {n_pos} position-controlled cables for {n} joints (mode = \"position\" "
                             f"needed on at least {n})")
        raise ValueError(f"cables: {n_cmd} position or displacement cables for {n_free} joints without stiffness "
                         f"(at least as many commanded cables as free joints are needed)")
    elastic = np.any(stiffness != 0.0) or np.any(rest != 0.0) or n_cmd > n_pos
    stated = "cable" in doc
    if n_pos <= n or elastic or not stated:
        for c, cb in enumerate(cables, start=1):
            if cb["mode"] != "position" or cb["pretension"] == 0.0:
                continue
            if n_pos <= n or elastic:
                raise ValueError(f"cables[{c}].pretension: a position cable's pretension needs more position "
                                 f"cables than joints on an arm without joint springs or displacement cables")
            raise ValueError(f"cables[{c}].pretension: a position cable's pretension needs the arm's cable "
                             f"stated (a [cable] table)")
    K = len(disks)
    return Robot(
        name=name,
        kind=KINDS["spatial"],
        axes=axes,
        offsets=np.array([j["offset"] for j in joints]).reshape(n, 3),
        joint_limits=np.array([j["limits"] for j in joints]).reshape(n, 2),
        joint_disk=joint_disk,
        link_after=np.array([d["link_after"] for d in disks]).reshape(K, 3),
        thickness=np.array([d["thickness"] for d in disks]),
        radius=np.array([d["radius"] for d in disks]),
        mass=np.array([d["mass"] for d in disks]),
        com=np.array([d["com"] for d in disks]).reshape(K, 3),
        base_radius=base_radius,
        gravity=gravity,
        cable_end=np.array([c["end"] for c in cables], dtype=np.int64),
        cable_mode=tuple(c["mode"] for c in cables),
        cable_tension=np.array([c["tension"] for c in cables], dtype=float),
        holes=tuple(c["holes"] for c in cables),
        **_material(doc),
        cable_stated=stated,
        joint_stiffness=stiffness,
        rest_angle=rest,
        cable_stiffness=np.array([c["stiffness"] for c in cables], dtype=float),
        pretension=np.array([c["pretension"] for c in cables], dtype=float),
        max_tension=np.array([c["max_tension"] for c in cables], dtype=float),
    )


def _general_linkages(linkages: list) -> tuple:
    """Joints (axis, offset, limits, disk, spring ``(stiffness or None, rest)``, field) and
    disks (link_after, thickness, radius, mass, com) of the general form's ``[[linkage]]``
    tables.  A disk's ``thickness`` may be 0: a via plate (its two faces coincide)."""
    if not linkages:
        raise ValueError("linkage: at least one linkage is needed")
    joints, disks = [], []
    for k, lk in enumerate(linkages, start=1):
        f = f"linkage[{k}]"
        _known_keys(lk, {"joints", "link_after", "thickness", "radius", "mass", "com"}, f)
        table = _table_list(_required(lk, "joints", f), f"{f}.joints")
        if not table:
            raise ValueError(f"{f}.joints: every linkage needs at least one joint")
        for i, jt in enumerate(table, start=1):
            fj = f"{f}.joints[{i}]"
            _known_keys(jt, {"axis", "offset", "limits", "stiffness", "rest"}, fj)
            a = _vector(_required(jt, "axis", fj), 3, f"{fj}.axis")
            norm = float(np.linalg.norm(a))
            if not norm > 0.0 or not math.isfinite(norm):
                raise ValueError(f"{fj}.axis: must be a non-zero vector (it is normalised), got {jt['axis']!r}")
            limits = _limits(jt.get("limits"), f"{fj}.limits")
            joints.append(dict(axis=a / norm, disk=k,
                               offset=_vector(jt["offset"], 3, f"{fj}.offset") if "offset" in jt else np.zeros(3),
                               limits=limits, spring=_spring(jt, "stiffness", "rest", limits, fj), field=fj))
        t = _non_negative(_required(lk, "thickness", f), f"{f}.thickness")
        disks.append(dict(
            link_after=_vector(_required(lk, "link_after", f), 3, f"{f}.link_after"),
            thickness=t,
            radius=_positive(_required(lk, "radius", f), f"{f}.radius"),
            mass=_non_negative(lk["mass"], f"{f}.mass") if "mass" in lk else 0.0,
            com=_vector(lk["com"], 3, f"{f}.com") if "com" in lk else np.array([0.5 * t, 0.0, 0.0]),
        ))
    return joints, disks


def _general_cables(cables: list, radii: list) -> list:
    """The general form's ``[[cables]]``: end, mode, tension, holes (radius + angle, or
    explicit points within their disks' ``radii``, index 0 the base); a displacement
    cable's actuator ``stiffness`` N/m (default inf: rigid), ``pretension`` N (default 0)
    and ``max_tension`` N (default inf: no cap); a position cable's ``pretension`` N
    (default 0)."""
    if not cables:
        raise ValueError("cables: at least one cable is needed")
    K = len(radii) - 1
    out = []
    for c, cb in enumerate(cables, start=1):
        f = f"cables[{c}]"
        _known_keys(cb, {"end", "mode", "tension", "radius", "angle", "holes", "stiffness", "pretension",
                         "max_tension"}, f)
        end = _required(cb, "end", f)
        if isinstance(end, bool) or not isinstance(end, int) or not 1 <= end <= K:
            raise ValueError(f"{f}.end: must be a disk index in 1..{K}, got {end!r}")
        mode = _required(cb, "mode", f)
        if mode not in _MODES:
            raise ValueError(f'{f}.mode: must be "position", "force" or "displacement", got {mode!r}')
        if mode == "force":
            tension = _positive(_required(cb, "tension", f), f"{f}.tension")
        elif "tension" in cb:
            raise ValueError(f"{f}.tension: only force-controlled cables carry a tension")
        else:
            tension = float("nan")
        actuator = dict(stiffness=math.inf, pretension=0.0, max_tension=math.inf)
        if "pretension" in cb and mode == "force":
            raise ValueError(f"{f}.pretension: only position and displacement cables have a pretension")
        for key in ("stiffness", "max_tension"):
            if key in cb and mode != "displacement":
                raise ValueError(f'{f}.{key}: only displacement cables (mode = "displacement") have a {key}')
        if mode == "position":
            # its command shortened by P (L + L_r) / (E A) (docs/model.md, "Settling")
            actuator["pretension"] = _non_negative(cb.get("pretension", 0.0), f"{f}.pretension")
        if mode == "displacement":
            if "stiffness" in cb:
                actuator["stiffness"] = _positive(cb["stiffness"], f"{f}.stiffness")
            actuator["pretension"] = _non_negative(cb.get("pretension", 0.0), f"{f}.pretension")
            if "max_tension" in cb:
                actuator["max_tension"] = _positive(cb["max_tension"], f"{f}.max_tension")
                if not actuator["max_tension"] > actuator["pretension"]:
                    raise ValueError(f"{f}.max_tension: must exceed the pretension ({actuator['pretension']!r} N), "
                                     f"got {cb['max_tension']!r}")
        polar = "radius" in cb or "angle" in cb
        if polar and "holes" in cb:
            raise ValueError(f"{f}.holes: give either radius + angle or holes, not both")
        count = 2 * end + 1
        if "holes" in cb:
            pts = cb["holes"]
            if not isinstance(pts, list) or len(pts) != count:
                got = len(pts) if isinstance(pts, list) else pts
                raise ValueError(f"{f}.holes: needs 2 end + 1 = {count} points, got {got!r}")
            h = np.array([_vector(p, 3, f"{f}.holes[{i}]") for i, p in enumerate(pts)])
            for i in range(count):
                d = (i + 1) // 2  # point i lies on disk d (0 = base)
                r = math.hypot(h[i, 1], h[i, 2])
                if r > radii[d]:
                    where = "the base" if d == 0 else f"disk {d}"
                    raise ValueError(f"{f}.holes[{i}]: outside {where} (sqrt(y^2 + z^2) = {r!r} m"
                                     f" > radius {radii[d]!r} m)")
        elif polar:
            r = _non_negative(_required(cb, "radius", f), f"{f}.radius")
            a = _number(_required(cb, "angle", f), f"{f}.angle")
            for d in range(end + 1):
                if r > radii[d]:
                    where = "the base" if d == 0 else f"disk {d}"
                    raise ValueError(f"{f}.radius: {r!r} m is outside {where} (radius {radii[d]!r} m)")
            h = np.tile([0.0, r * math.cos(a), r * math.sin(a)], (count, 1))
        else:
            raise ValueError(f"{f}.holes: missing (give radius + angle, or holes)")
        out.append(dict(end=end, mode=mode, tension=tension, holes=h, **actuator))
    return out


#: The reader of each form of robot file, by its ``kind``.
_FORMS = {"planar": _read_planar, "spatial": _read_general}
