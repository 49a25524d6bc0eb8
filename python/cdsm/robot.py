"""The robot of either kind: a thin, typed front over the Rust core (SI
units: m, rad, N, kg).

Arrays in, arrays out. Batch inputs are ``(N, k)``; a single configuration may
be given 1-D and then comes back 1-D. Integer and non-contiguous arrays are
accepted (copied once); NaN/inf and wrong shapes raise :class:`CdsmInputError`
naming the argument.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from types import MappingProxyType
from typing import Dict, List, Mapping, Optional, Tuple

import numpy as np

from . import _cdsm
from .files import read_text
from .inputs import (CdsmDataWarning, CdsmInputError, as_array, as_batch, as_count, as_finite, as_iterations, as_vector,
                     did_you_mean)
from .display import ShortRepr, degrees
from .elastic import XTOL, Equilibrium, EquilibriumDerivatives
from .kinds import KINDS as _KIND_OBJECTS, PLANAR, SPATIAL, Kind, kind_of

__all__ = ["Robot", "Solution", "KINDS", "kind_facts", "ElasticSolution", "CdsmInputError", "REASONS", "TASK_MASKS",
           "SPATIAL_MASKS", "IK_METHODS", "MAX_THREADS", "PLAUSIBLE_LENGTH", "packaged_robots"]

_ROBOTS = Path(__file__).parent / "robots"

#: The robot kinds (:class:`cdsm.kinds.Kind`, strings).
KINDS = tuple(_KIND_OBJECTS.values())


@lru_cache(maxsize=None)
def kind_facts(kind: str) -> Mapping:
    """The facts of the arm kind ``kind`` (``"planar"`` or ``"spatial"``), the
    Rust core's (``rust/kinds.rs``, ``KindInfo``), read-only: ``dim`` (2, 3),
    ``task`` (3, 6), ``task_axes`` and ``task_units``, ``rotation``
    (``"angle"``: phi; ``"vector"``: a rotation vector), ``quantities`` and
    ``quantity_units`` (a Monte-Carlo study's, per sample), ``hole_grouping``
    and ``layout`` (the plant's parameter blocks in order). Lists are tuples.
    :class:`CdsmInputError` naming ``kind`` for another name."""
    facts = _cdsm.kind_info(kind)
    return MappingProxyType({k: tuple(v) if isinstance(v, list) else v for k, v in facts.items()})


#: The longest straight arm (m) taken without a warning about its unit.
PLAUSIBLE_LENGTH = 10.0

#: The most worker threads a robot takes (:attr:`Robot.threads`).
MAX_THREADS = 4096


def packaged_robots() -> Tuple[str, ...]:
    """Names of the robot descriptions shipped with cdsm (``cdsm/robots/*.toml``),
    for :meth:`Robot.packaged`."""
    return tuple(sorted(p.stem for p in _ROBOTS.glob("*.toml")))


#: Why a solve ended, by code (``Solution.reason`` holds the names).
REASONS = tuple(_cdsm.REASONS)

_REASON_NAMES = np.array(REASONS)

#: Pose-IK methods (:meth:`Robot.ik`).
IK_METHODS = ("lm", "closed_form")

#: Named task masks of the pose IK over the planar task coordinates (x, y, phi) (the planar kind's).
TASK_MASKS = PLANAR.masks

#: Task masks of a spatial arm's pose IK (the spatial kind's).
SPATIAL_MASKS = tuple(SPATIAL.masks)


@dataclass(frozen=True, repr=False)
class Solution(ShortRepr):
    """Result of a batch of solves.

    theta: (N, n) joint angles, rad. converged: (N,) bool; a failed element
    keeps its last iterate and must not be used as an answer. iterations: (N,)
    trial steps (0 = closed form). residual: (N,) max |residual| (m, or rad for
    the attitude). within_limits: (N,) all angles within the joint limits.
    reason: (N,) why each solve ended: ``"converged"``, ``"iteration limit"``,
    ``"singular"`` (the step could not be computed), ``"stalled"`` (the
    residual stopped falling short of zero: a local minimum, or a closed
    form's branch without an answer — another seed may succeed),
    ``"unreachable"`` (proven: no configuration realises the target, e.g. a
    cable length outside the range its geometry allows) or ``"outside
    limits"`` (stuck on the joint-limit box while limits are enforced).
    feasible: (N,) every upper cable taut (tension > 0 N) at theta under the
    robot's lower tensions and gravity — False flags a configuration the
    hybrid-controlled arm cannot hold (computed on first access; None where
    no robot is attached).
    """

    theta: np.ndarray
    converged: np.ndarray
    iterations: np.ndarray
    residual: np.ndarray
    within_limits: np.ndarray
    #: (N,) uint8 codes of :data:`REASONS` (``reason`` gives the names)
    reason_code: np.ndarray = None
    _feasible: Optional[np.ndarray] = field(default=None, repr=False, compare=False)
    _robot: Optional["Robot"] = field(default=None, repr=False, compare=False)

    @property
    def reason(self) -> np.ndarray:
        """(N,) why each solve ended, by name (see the class doc)."""
        return _REASON_NAMES[self.reason_code]

    @property
    def feasible(self) -> Optional[np.ndarray]:
        if self._feasible is None and self._robot is not None:
            object.__setattr__(self, "_feasible", self._robot.feasible(self.theta))
        return self._feasible

    @classmethod
    def from_core(cls, res: "_cdsm.SolveResult", n: int, single: bool,
                  robot: Optional["Robot"] = None, **extra) -> "Solution":
        """The solution of a batch from the core's :class:`cdsm._cdsm.SolveResult`
        (``single``: one row given 1-D, returned 1-D)."""
        theta = res.theta.reshape(-1, n)
        parts = [theta, res.converged, res.iterations, res.residual, res.within_limits, res.reason]
        if single:
            parts = [p[0] for p in parts]
            extra = {k: v[0] for k, v in extra.items()}
        return cls(*parts, _robot=robot, **extra)


class Robot:
    """A cable-driven serpentine manipulator of either kind: ``"planar"``
    (``n`` joints with parallel axes and ``2n`` cables, the seed paper's
    kind: ``docs/model.md``) or ``"spatial"`` (revolute axes anywhere,
    universal joints, holes anywhere on the disks, position- and
    force-controlled cables: ``docs/spatial.md``). One class: the kind is
    data (:attr:`kind`), and so are the task space (planar ``[x, y, phi]``,
    spatial ``[x, y, z, rx, ry, rz]``: the end frame's origin, m, and its
    rotation vector, rad) and what the arm's calls return.

    Build with :meth:`paper`, :meth:`from_toml` (a file or a packaged name)
    or :meth:`packaged`. SI units: m, rad, N, kg.
    """

    def __init__(self, core: "_cdsm.CoreRobot", threads: int = 0):
        #: the Rust core robot, used by the other modules
        self.core = core
        self.threads = threads

    # ---- construction -------------------------------------------------
    @classmethod
    def paper(cls) -> "Robot":
        """The paper's 3-DOF prototype: Table 1, lower cables 50/10/5 g, limits ±35°."""
        return cls(_cdsm.CoreRobot.paper())

    @classmethod
    def packaged(cls, name: str) -> "Robot":
        """A robot description shipped with cdsm (``cdsm/robots/<name>.toml``),
        planar or spatial: see :func:`packaged_robots`."""
        names = packaged_robots()
        if name not in names:
            raise CdsmInputError(f"`name`: no packaged robot {name!r}{did_you_mean(name, names)} (packaged: "
                                 f"{', '.join(names)})")
        return cls.from_toml_str(read_text(_ROBOTS / f"{name}.toml", "robot"))

    @classmethod
    def from_toml(cls, path: "str | os.PathLike[str]") -> "Robot":
        """Read a robot description (TOML, SI units), of either kind.

        ``path`` is a file, or the name of a packaged robot
        (:func:`packaged_robots`, e.g. ``"two_universal"``) when no such file
        exists: the one rule for naming a robot everywhere (``--robot`` too).
        A name that is neither says so and lists the packaged names."""
        if not os.path.exists(path):
            name = os.fspath(path)
            if name in packaged_robots():
                return cls.packaged(name)
            raise CdsmInputError(f"robot file {name!r}: does not exist, and no packaged robot has that name"
                                 f"{did_you_mean(name, packaged_robots())} (packaged: {', '.join(packaged_robots())})")
        return cls.from_toml_str(read_text(path, "robot"))

    @classmethod
    def load(cls, source: "str | os.PathLike[str]") -> "Robot":
        """A robot by the one rule every command's ``--robot`` follows: a
        robot file (TOML, either kind), an OpenCR generation config (a
        ``.json`` file: :meth:`from_opencr`), or — when no such file exists —
        the name of a packaged robot (:func:`packaged_robots`, e.g.
        ``"two_universal"``) or of a packaged OpenCR config
        (:data:`cdsm.interop.opencr.PACKAGED`, e.g. ``"ftdcr_v4"``, the real
        FTDCR v4's design). A name that is none of these says so and lists
        the names. SI units."""
        from .interop import opencr

        name = os.fspath(source)
        if os.path.exists(name):
            return cls.from_opencr(name) if name.lower().endswith(".json") else cls.from_toml(name)
        configs = list(opencr.CONFIGS)
        if name in configs:
            return cls.from_opencr(name)
        if name in packaged_robots():
            return cls.packaged(name)
        known = list(packaged_robots()) + configs
        raise CdsmInputError(f"robot file {name!r}: does not exist, and no packaged robot has that name"
                             f"{did_you_mean(name, known)} (packaged: {', '.join(known)})")

    @classmethod
    def from_toml_str(cls, text: str) -> "Robot":
        """Parse a robot description given as TOML text (either kind). A
        description whose straight arm is longer than
        :data:`PLAUSIBLE_LENGTH` (a file in mm read as m, most likely)
        raises a :class:`CdsmDataWarning`."""
        return _plausible(cls(_cdsm.CoreRobot.from_toml(text)))

    @classmethod
    def from_data(cls, data: dict) -> "Robot":
        """A robot from a robot file's data instead of its text: a dict of
        the file's structure (tables as dicts, arrays as lists; str, float,
        int, bool values; either kind, ``docs/model.md``,
        ``docs/spatial.md``), checked as the file would be, errors naming
        the field by the same path (``linkage[0].mass``). No text is
        formatted in between, so no value (a name, say) can become another
        setting. SI units. The same :class:`CdsmDataWarning` as
        :meth:`from_toml_str`."""
        if not isinstance(data, dict):
            raise CdsmInputError(f"`data`: expected a dict of the robot file's structure, got {type(data).__name__}")
        return _plausible(cls(_cdsm.CoreRobot.from_data(data)))

    @classmethod
    def from_opencr(cls, config: "str | os.PathLike[str] | dict") -> "Robot":
        """A tendon-driven continuum robot from an OpenCR-MuJoCo generation
        config (https://github.com/ContinuumRoboticsLab/opencr-mujoco): a
        JSON file's path, a packaged config's name (``"ftdcr_v4_sysid"``,
        :data:`cdsm.interop.opencr.PACKAGED`) or the parsed JSON object,
        built as OpenCR's generator builds its model
        (:func:`cdsm.interop.opencr.robot_data`: elastic joints from the
        backbone rod, one displacement tendon per actuator, OpenCR's order).
        cdsm's backbone runs along ``x``: OpenCR's ``(x, y, z)`` is cdsm's
        ``(y, z, x)``. SI units. Settle it with :meth:`equilibrium`."""
        from .interop import opencr

        if isinstance(config, dict):
            return cls.from_data(opencr.robot_data(config))
        path = config
        if isinstance(config, str) and config in opencr.PACKAGED and not os.path.exists(config):
            path = opencr.packaged(config)
        return cls.from_data(opencr.robot_data(opencr.load_config(path)))

    @classmethod
    def from_caspr(cls, bodies_xml: "str | os.PathLike[str]", cables_xml: "str | os.PathLike[str]",
                   cable_set: Optional[str] = None) -> "Robot":
        """A spatial robot from a CASPR multi-link model (https://github.com/darwinlau/CASPR):
        the paths of its ``<name>_bodies.xml`` and ``<name>_cables.xml``, and
        the id of the cable set (None: the file's ``default_cable_set``, else
        its only set; an unknown id is an error listing the ids).

        Joints in CASPR's order (link by link, each joint type's axes in
        order; ``R_X``, ``R_Y``, ``R_Z``, ``R_AXIS``, ``U_XY``, ``U_XZ``,
        ``U_YZ``), cables in the file's order, all position-controlled; a
        cable's length is the sum of the straight segments between its
        consecutive attachments, as in CASPR. CASPR's vectors are turned by
        one constant rotation so that the links point along ``+x``
        (``docs/interop.md`` has the whole mapping;
        :func:`cdsm.interop.caspr.caspr_robot_data` builds the robot file's
        data, :meth:`from_data` the robot; :meth:`to_toml` writes it as a
        robot file). What is not kept (inertia tensors, cable force limits,
        names, ...) is said in one ``UserWarning``; what cannot be
        represented (a cable that does not start at the base, another joint
        type, a tree, ...) raises :class:`CdsmInputError` naming the link or
        cable. SI units."""
        from .interop.caspr import caspr_robot_data

        data = caspr_robot_data(bodies_xml, cables_xml, cable_set)
        try:
            return cls.from_data(data)
        except CdsmInputError as exc:
            raise CdsmInputError(f"CASPR model {os.fspath(bodies_xml)!r}: cdsm cannot represent it: {exc}") from None

    def to_mjcf(self) -> str:
        """MuJoCo's MJCF of this robot (XML text): a body per disk with one
        hinge per joint in cdsm's order (``nq = n``, limits), masses and
        centres of mass with the inertia of a uniform solid cylinder of the
        disk's radius and thickness (the robot file has no inertia tensor), a
        site at every hole, a spatial tendon per cable through its holes in
        cdsm's cable order (tendon length = :meth:`cable_lengths`, ``ten_J``
        = :meth:`cable_jacobian`), a ``position`` actuator on each position
        cable (a linear spring ``E A / L_0``, pulling only) and a ``general``
        actuator of constant force ``-T`` on each force cable (its set
        tension). ``docs/interop.md``, :mod:`cdsm.interop.mjcf`. SI units.
        A disk without mass raises :class:`CdsmInputError` (MuJoCo rejects
        it)."""
        from .interop.mjcf import to_mjcf

        return to_mjcf(self)

    def to_urdf(self) -> str:
        """The URDF of this robot (XML text): links ``base``, one per joint,
        revolute joints in cdsm's order (a universal joint as two, limits),
        inertials as in :meth:`to_mjcf`, and a link ``tip`` fixed at the end
        frame (its pose is :meth:`fk_matrix`). ``docs/interop.md``,
        :mod:`cdsm.interop.urdf`. SI units."""
        from .interop.urdf import to_urdf

        return to_urdf(self)

    def to_toml(self) -> str:
        """A robot file (TOML, SI units) that rebuilds this robot exactly:
        its own kind's format, explicit holes (also those set by
        :meth:`with_holes`), every float in its shortest round-trip form,
        the name in any Unicode."""
        return self.core.to_toml()

    def with_holes(self, holes, within_disks: bool = True) -> "Robot":
        """The same robot with other holes, m: planar ``(2n, n+1, 2, 2)``
        (:attr:`holes`; a slot no cable crosses is not read); spatial a list like :attr:`holes`, or one flat array
        of every ``[x, y, z]`` (:attr:`flat_holes`). ``within_disks``: a
        spatial hole outside its disk's radius is refused, as in a robot
        file (False for error studies that move holes past the nominal
        outline; such a robot's :meth:`to_toml` does not load back)."""
        if self.kind.pair_holes:
            h = np.ascontiguousarray(as_array("holes", holes))
            if h.shape != self.holes.shape:
                raise CdsmInputError(f"`holes`: expected shape {self.holes.shape}, got {h.shape}")
            return Robot(self.core.with_holes(h), self.threads)
        if isinstance(holes, (list, tuple)):
            if len(holes) != len(self.holes):
                raise CdsmInputError(f"`holes`: expected {len(self.holes)} arrays (one per cable), got {len(holes)}")
            parts = [as_array(f"holes[{c}]", h) for c, h in enumerate(holes)]
            for c, (got, want) in enumerate(zip(parts, self.holes)):
                if got.shape != want.shape:
                    raise CdsmInputError(f"`holes[{c}]`: expected shape {want.shape}, got {got.shape}")
            flat = np.concatenate([p.reshape(-1) for p in parts])
        else:
            flat = as_array("holes", holes).reshape(-1)
        return Robot(self.core.with_holes(np.ascontiguousarray(flat), bool(within_disks)), self.threads)

    def hole_height_error(self, dh) -> np.ndarray:
        """Planar arms: hole positions (2n, n+1, 2, 2), m, after the paper's
        per-disk hole-height error ``dh`` (n,), m: pair i's holes move
        outward by ``dh[i]`` on every face."""
        d = as_vector("dh", dh, self.n)
        return self.core.hole_height_error(d).reshape(self.holes.shape)

    # ---- what every kind has -------------------------------------------
    @property
    def kind(self) -> Kind:
        """``"planar"`` or ``"spatial"``: a :class:`cdsm.kinds.Kind`, the
        string with the kind's facts (task axes, masks, ...)."""
        return kind_of(self.core.kind)

    @property
    def threads(self) -> int:
        """Worker threads of batch calls (0 = all cores, at most
        :data:`MAX_THREADS`); they run without the GIL. Where the system
        cannot start as many, the calling thread does the rest."""
        return self._threads

    @threads.setter
    def threads(self, value: int) -> None:
        self._threads = as_count("threads", value, 0, MAX_THREADS)

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.core.n

    @property
    def name(self) -> str:
        return self.core.name

    @property
    def task(self) -> int:
        """Width of the task vector: 3 (planar ``[x, y, phi]``) or 6 (spatial)."""
        return self.kind.task

    @property
    def joint_limits(self) -> np.ndarray:
        """(n, 2) joint limits [lo, hi], rad."""
        return self.core.joint_limits.reshape(-1, 2)

    @property
    def axes(self) -> np.ndarray:
        """(n, 3) unit joint axes, each in its joint's local frame (planar: z)."""
        return self.core.axes.reshape(-1, 3)

    @property
    def gravity(self) -> np.ndarray:
        """Gravity, m/s^2, base frame: planar the in-plane ``[gx, gy]`` (2,),
        spatial ``(3,)``. The default of every statics call (robot file
        ``gravity``; 0: a horizontal plane)."""
        g = np.array(self.core.gravity)
        return g[:self.kind.dim]

    @property
    def straight_length(self) -> float:
        """Distance of the straight arm's tip (theta = 0) from the base, m."""
        return self.core.straight_length

    @property
    def cables(self) -> int:
        """Number of cables (planar: 2n, upper and lower of each pair)."""
        return self.core.cables

    @property
    def position_cables(self) -> List[int]:
        """Indices of the position-controlled cables (their lengths are
        commanded; planar: the upper cables 0, 2, 4, ...)."""
        return list(self.core.position_cables)

    @property
    def cable_ends(self) -> List[int]:
        """The disk (1-based) each cable ends at."""
        return list(self.core.cable_ends)

    @property
    def cable_tensions(self) -> np.ndarray:
        """(cables,) set tension of each force-controlled cable, N (0 for position cables)."""
        return self.core.cable_tensions

    @property
    def flat_holes(self) -> np.ndarray:
        """Every hole as one flat array: cable by cable, face by face (base
        face b, then faces a and b of each disk it crosses), ``[x, y, z]``
        in the face's frame, m."""
        return self.core.flat_holes

    @property
    def radii(self) -> np.ndarray:
        """Disk radii (base first), m (planar: the largest hole height of each disk)."""
        return self.core.radii

    @property
    def mass(self) -> np.ndarray:
        """(disks,) disk (linkage) masses, kg."""
        return self.core.mass

    @property
    def offsets(self) -> np.ndarray:
        """(n, 3) each joint's offset from the previous frame, in that frame,
        m (``docs/spatial.md``; planar: ``(link_before, 0, 0)``)."""
        return self.core.offsets.reshape(-1, 3)

    @property
    def joint_disks(self) -> List[int]:
        """The disk (1-based) each joint belongs to (the joints before it)."""
        return list(self.core.joint_disks)

    @property
    def disk_link_after(self) -> np.ndarray:
        """(disks, 3) last joint -> proximal face (face a) of each disk, in
        the last joint's frame, m (planar: ``(link_after, 0, 0)``)."""
        return self.core.disk_link_after.reshape(-1, 3)

    @property
    def disk_thickness(self) -> np.ndarray:
        """(disks,) disk thickness along the disk's local x axis (face a ->
        face b), m; both kinds (:attr:`thickness` is the planar name)."""
        return self.core.disk_thickness

    @property
    def com(self) -> np.ndarray:
        """(disks, 3) centre of mass of each disk in its face-a frame, m
        (planar: the disk's centre, ``(thickness / 2, 0, 0)``)."""
        return self.core.com.reshape(-1, 3)

    @property
    def youngs_modulus(self) -> float:
        """Cable Young's modulus, Pa."""
        return self.core.youngs_modulus

    @property
    def cable_diameter(self) -> float:
        """Cable diameter, m."""
        return self.core.cable_diameter

    @property
    def routing_length(self) -> float:
        """Cable path behind the base disk to the actuator, m (stretches with the cable)."""
        return self.core.routing_length

    @property
    def stretch_feed_forward(self) -> bool:
        """The controller's premise (robot file ``[cable] stretch_feed_forward``, default
        True): it pays the cable's frictionless stretch (compliance ``1 / (E A)``, 1/N) out
        with its commands, so the plant's ``cable_elasticity`` is the compliance beyond the
        cable's; False: it commands the rigid model's lengths and ``cable_elasticity`` is
        the whole compliance (``docs/model.md``, "Commands and their order")."""
        return self.core.stretch_feed_forward

    @property
    def cable_stated(self) -> bool:
        """Whether the robot states its cable (a robot file's ``[cable]`` table, or
        :meth:`with_cable`); False: cdsm's default cable (steel, 0.18 mm) stands in, a
        placeholder (a CASPR import gives no cable)."""
        return self.core.cable_stated

    @property
    def redundant_settle(self) -> Optional[str]:
        """How the plant (diagnosis, virtual prototype, compensation) settles this rigid arm
        with more position cables than joints (``docs/model.md``, "Settling"):
        ``"potential"`` -- its cable stated (:attr:`cable_stated`), at the minimum of the
        potential of its position cables as springs of ``E A / (L + L_r)`` that cannot push,
        with gravity, force cables and each cable's ``pretension``; ``"least_squares"`` --
        its cable not stated, at the unweighted least squares on the cable lengths (the
        default cable's stiffness is no physics: on the packaged ``sjtu_snake`` it would let
        the snake fold under its weight).  Opt in by stating the cable (a ``[cable]`` table,
        or :meth:`with_cable`).  None for any other arm (as many position cables as joints:
        one answer; joint springs or displacement cables: the elastic statics)."""
        return self.core.redundant_settle

    @property
    def axial_stiffness(self) -> float:
        """Cable axial stiffness E A, N (A = pi d^2 / 4)."""
        return self.core.axial_stiffness

    @property
    def holes(self):
        """Planar: ``(2n, n+1, 2, 2)`` hole positions: cable, disk (0 = base),
        face (a, b), (x, y), m. Spatial: per cable, its holes ``(2 end + 1,
        3)`` in face frames, m."""
        if self.kind.pair_holes:
            n = self.n
            return self.core.holes.reshape(2 * n, n + 1, 2, 2)
        return self.holes_by_cable()

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, n={self.n}, kind={self.kind!r}, cables={self.cables})"

    def summary_tables(self) -> Dict[str, Tuple[List[str], List[List[str]]]]:
        """The robot as tables of text (SI units in the headers): ``joints``,
        ``disks``, ``cables`` — each ``(header, rows)`` — for :meth:`__str__`
        and the notebook view."""
        joints = (["joint", "disk", "axis", "offset (m)", "limits (deg)"],
                  [[str(j + 1), str(d), _vec(a, 3), _vec(o, 4), f"[{degrees(lo)}, {degrees(hi)}]"]
                   for j, (d, a, o, (lo, hi)) in enumerate(zip(self.joint_disks, self.axes, self.offsets,
                                                                self.joint_limits))])
        disks = (["disk", "link after (m)", "thickness (m)", "radius (m)", "mass (kg)"],
                 [[str(d + 1), _vec(la, 4), f"{t:.4g}", f"{r:.4g}", f"{m:.4g}"]
                  for d, (la, t, r, m) in enumerate(zip(self.disk_link_after, self.disk_thickness,
                                                        self.radii[1:], self.mass))])
        cab_rows = []
        for c, (e, h, t, m) in enumerate(zip(self.cable_ends, self.holes_by_cable(), self.cable_tensions,
                                            self.cable_modes)):
            mode = f"force, {t:.4g} N" if m == "force" else m
            cab_rows.append([str(c + 1), str(e), mode, _vec(h[0], 4), _vec(h[-1], 4)])
        cables = (["cable", "ends at disk", "mode", "base hole (m)", "last hole (m)"], cab_rows)
        return {"joints": joints, "disks": disks, "cables": cables}

    def holes_by_cable(self) -> List[np.ndarray]:
        """Each cable's holes ``(2 end + 1, 3)`` in face frames (base face b,
        then faces a and b of each disk it crosses), m — both kinds."""
        flat, out, k = self.flat_holes, [], 0
        for e in self.cable_ends:
            out.append(flat[k:k + 3 * (2 * e + 1)].reshape(-1, 3))
            k += 3 * (2 * e + 1)
        return out

    def _headline(self) -> str:
        m = len(self.position_cables)
        g = np.linalg.norm(self.gravity)
        return (f"{self.name!r}: {self.kind} arm, {self.n} joints on {len(self.disk_thickness)} disks, "
                f"{self.cables} cables ({m} position-, {self.cables - m} force-controlled), straight length "
                f"{self.straight_length:.4g} m, gravity {g:.4g} m/s^2, cable E = {self.youngs_modulus:.3g} Pa, "
                f"d = {self.cable_diameter:.3g} m")

    def __str__(self) -> str:
        parts = [self._headline()]
        for name, (head, rows) in self.summary_tables().items():
            widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(head)]
            parts.append(name + ":")
            parts.append("  " + "  ".join(h.ljust(w) for h, w in zip(head, widths)))
            parts += ["  " + "  ".join(v.ljust(w) for v, w in zip(r, widths)) for r in rows]
        return "\n".join(parts)

    def _repr_html_(self) -> str:
        import html

        out = [f"<p><b>{html.escape(self._headline())}</b></p>"]
        for name, (head, rows) in self.summary_tables().items():
            out.append(f"<details{' open' if name != 'cables' else ''}><summary>{name}</summary><table>")
            out.append("<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in head) + "</tr>")
            out += ["<tr>" + "".join(f"<td>{html.escape(v)}</td>" for v in r) + "</tr>" for r in rows]
            out.append("</table></details>")
        return "".join(out)

    def disk_frames(self, theta) -> np.ndarray:
        """Face frames of every disk in the base frame: (N, n) rad -> (N, K,
        2, 4, 4): face a (proximal) then face b (distal) of disks 1..K as
        homogeneous transforms, translation in m (the base face is the
        identity; a planar arm lies in z = 0)."""
        k = len(self.disk_thickness)
        return self._map(theta, self.core.disk_frames, (k, 2, 4, 4))

    def plot(self, theta=None, ax=None, cables: bool = True):
        """Draw the arm at ``theta`` (n,) rad (default: straight) with
        matplotlib — in its plane for a planar arm, in 3-D for a spatial
        one — and return the axes (:func:`cdsm.report.drawing.draw_arm`)."""
        from .report.drawing import draw_arm

        return draw_arm(self, theta, ax=ax, cables=cables)

    # ---- planar arms' description ----------------------------------------
    @property
    def link_before(self) -> np.ndarray:
        """Planar: (n,) link before each joint, m (the paper's link_{i-1,J_i}):
        the joint offsets' x (:attr:`offsets`)."""
        self.kind.require_pairs("link_before")
        return self.offsets[:, 0].copy()

    @property
    def link_after(self) -> np.ndarray:
        """Planar: (n,) link after each joint, m (the paper's link_{J_i,i}):
        the disks' ``link_after`` x (:attr:`disk_link_after`)."""
        self.kind.require_pairs("link_after")
        return self.disk_link_after[:, 0].copy()

    @property
    def thickness(self) -> np.ndarray:
        """Planar: (n,) disk thickness, m (the paper's B; :attr:`disk_thickness`)."""
        self.kind.require_pairs("thickness")
        return self.disk_thickness

    @property
    def lower_tension(self) -> np.ndarray:
        """Planar: (n,) tension on the lower (force-controlled) cable of each
        pair, N (:attr:`cable_tensions` of the force cables)."""
        self.kind.require_pairs("lower_tension")
        return self.core.cable_tensions[self.core.structure()["force"]]

    # ---- batches --------------------------------------------------------
    def _out(self, flat: np.ndarray, shape: Tuple[int, ...], single: bool) -> np.ndarray:
        out = flat.reshape((-1,) + shape)
        return out[0] if single else out

    def _seed(self, seed, rows: int) -> Optional[np.ndarray]:
        if seed is None:
            return None
        # every solve's core checks its seeds (row and column named)
        s, single = as_batch("seed", seed, self.n, finite=False)
        if single and rows > 1:
            s = np.ascontiguousarray(np.broadcast_to(s, (rows, self.n)))
        if s.shape[0] != rows:
            raise CdsmInputError(f"`seed`: expected shape ({rows}, {self.n}) or ({self.n},), got {s.shape}")
        return s

    def _theta(self, theta) -> Tuple[np.ndarray, bool]:
        """``theta`` as a finite (N, n) batch (:func:`as_batch`); a planar
        arm's disk angles are running sums of the joint angles, so a row
        whose sum overflows a float (``1e308 + 1e308``) is refused too."""
        t, single = as_batch("theta", theta, self.n)
        if self.kind.summed_angles:
            with np.errstate(over="ignore"):
                bad = ~np.isfinite(np.cumsum(t, axis=1)).all(axis=1)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise CdsmInputError(f"`theta`: row {i}: the joint angles add up past the largest float "
                                     f"({t[i].tolist()} rad): no disk has such an angle")
        return t, single

    def _map(self, theta, method, shape):
        t, single = self._theta(theta)
        return self._out(method(t, self.threads), shape, single)

    # ---- kinematics ---------------------------------------------------
    def fk(self, theta) -> np.ndarray:
        """End pose: (N, n) -> (N, task); (n,) -> (task,). Planar ``[x (m), y
        (m), phi (rad)]``, spatial ``[x, y, z (m), rx, ry, rz (rad, rotation
        vector)]``."""
        return self._map(theta, self.core.fk, (self.task,))

    def fk_matrix(self, theta) -> np.ndarray:
        """End frame as a homogeneous transform in 3-D (a planar arm's plane
        is z = 0, its joints turn about z): (N, n) -> (N, 4, 4), m."""
        return self._map(theta, self.core.fk_matrix, (4, 4))

    def fk_jacobian(self, theta) -> np.ndarray:
        """Task Jacobian: (N, n) -> (N, task, n). Planar ``d[x, y, phi]/d
        theta``; spatial the geometric Jacobian: rows 0-2 the velocity of the
        end frame's origin (m/rad), rows 3-5 its angular velocity."""
        return self._map(theta, self.core.fk_jacobian, (self.task, self.n))

    def cable_lengths(self, theta) -> np.ndarray:
        """Lengths of every cable, m: (N, n) -> (N, cables) (planar order
        L_c1_1, L_c1_2, ..., L_cn_2: upper and lower of each pair)."""
        return self._map(theta, self.core.cable_lengths, (self.cables,))

    def position_lengths(self, theta) -> np.ndarray:
        """Lengths of the position-controlled cables, m: (N, n) -> (N, m_pos)."""
        return self.cable_lengths(theta)[..., self.position_cables]

    def upper_lengths(self, theta) -> np.ndarray:
        """Planar name of :meth:`position_lengths`: the n upper cables, m."""
        return self.position_lengths(theta)

    def cable_jacobian(self, theta) -> np.ndarray:
        """dL/d theta, m/rad: (N, n) -> (N, cables, n)."""
        return self._map(theta, self.core.cable_jacobian, (self.cables, self.n))

    def within_limits(self, theta) -> np.ndarray:
        """Whether every angle lies within the joint limits: (N, n) -> (N,) bool."""
        t, single = as_batch("theta", theta, self.n)
        ok = self.core.within_limits(t, self.threads)
        return ok[0] if single else ok

    # ---- solves -------------------------------------------------------
    def ik(self, target=None, seed=None, tol: float = 1e-12, max_iter: int = 100,
           enforce_limits: bool = False, mask="pose", method: str = "lm", pose=None) -> Solution:
        """Pose IK: targets (N, task) -> :class:`Solution`; ``seed`` (N, n) or
        (n,), rad (default theta = 0). ``pose`` is the planar name of ``target``.

        ``method``: ``"lm"`` (default) — damped least squares
        (Levenberg–Marquardt, minimal-norm steps; normal-equation steps when
        the task has more rows than the arm has joints) from the seed;
        ``"closed_form"`` — planar 3-joint arms, full pose: both branches,
        the one nearest the seed (ties: theta_2 <= 0, the paper's), 0
        iterations (``docs/model.md``). ``mask``: what to match. Planar:
        ``"pose"`` (x, y, phi), ``"position"`` (x, y; the attitude free) or
        three non-negative weights on the x, y, phi residuals (m, m, rad).
        Spatial: ``"position"`` (the end origin; the rotation columns
        ignored), ``"pointing"`` (the origin and the direction of the end
        frame's x axis) or ``"pose"``. Convergence is judged on the
        (weighted) residual. Joint limits are flagged (``within_limits``) and
        enforced only with ``enforce_limits``.
        """
        # the kind's word for it: a planar arm's pose, a spatial arm's target
        name, target = ("pose", pose) if pose is not None else (self.kind.target_arg, target)
        if target is None:
            raise CdsmInputError("`target`: the targets (N, task) are missing")
        p, single = as_batch(name, target, self.task, finite=False)  # checked by the core
        if method not in IK_METHODS:
            raise CdsmInputError(f"`method`: expected one of {', '.join(map(repr, IK_METHODS))}, got {method!r}")
        res = self.core.ik(p, self._seed(seed, p.shape[0]), self.kind.core_mask(mask), method, as_finite("tol", tol),
                           as_iterations("max_iter", max_iter), bool(enforce_limits), self.threads)
        return Solution.from_core(res, self.n, single, self)

    def solve_cables(self, lengths, seed=None, method: str = "auto", tol: float = 1e-12,
                     max_iter: int = 100, enforce_limits: bool = False) -> Solution:
        """Lengths of the position-controlled cables (N, m_pos), m -> joint
        angles (the force-controlled cables follow).

        method: planar arms ``"newton"`` (damped Newton / LM from the seed),
        ``"closed_form"`` (per joint, the acos branch nearest the seed) or
        ``"auto"`` (closed form, verified, LM if it fails); spatial arms have
        no closed form: ``"auto"`` and ``"newton"`` run the damped Newton
        with as many cables as joints, least squares with more
        (``residual`` reports the misfit, m). ``seed`` (N, n) or (n,), rad;
        default 0.
        """
        # the kind's word for them: a planar arm's upper cables
        name = self.kind.command_arg
        u, single = as_batch(name, lengths, len(self.position_cables), finite=False)  # checked by the core
        res = self.core.solve_cables(u, self._seed(seed, u.shape[0]), str(method), as_finite("tol", tol),
                                     as_iterations("max_iter", max_iter), bool(enforce_limits), self.threads)
        return Solution.from_core(res, self.n, single, self)

    # ---- statics ------------------------------------------------------
    def _statics(self, theta, min_tension, tip_wrench, force, gravity, force_name="force", friction=None,
                 sliding="pull"):
        t, single = self._theta(theta)
        if not isinstance(sliding, str) or sliding not in ("pull", "release"):
            raise CdsmInputError(f"`sliding`: expected 'pull' or 'release' (one sliding state for every row), "
                                 f"got {sliding!r}")
        if friction is not None:  # its domain: the core's (friction::check_mu)
            friction = as_finite("friction", friction)
        rows = t.shape[0]

        def rowed(name, value, width):
            if value is None:
                return None
            arr, one = as_batch(name, value, width)
            if not one and arr.shape[0] != rows:
                raise CdsmInputError(f"`{name}`: expected shape ({rows}, {width}) or ({width},), "
                                     f"got {np.shape(value)}")
            return arr

        w = rowed("tip_wrench", tip_wrench, self.task)
        w = None if w is None else self.kind.core_wrench(w)
        f = rowed(force_name, force, self.cables - len(self.position_cables))
        g = None if gravity is None else self.kind.core_gravity(gravity)
        res = self.core.tensions(t, None if f is None else f.reshape(-1), None if w is None else w.reshape(-1),
                                 g, as_finite("min_tension", min_tension), self.threads, friction,
                                 sliding == "pull")
        return res, single

    def tensions(self, theta, tip_wrench=None, min_tension: float = 0.0, force=None, gravity=None,
                 lower=None, friction: Optional[float] = None, sliding: str = "pull") -> np.ndarray:
        """Tensions of the position-controlled cables, N: (N, n) -> (N, m_pos).

        The moment balance about every (frictionless) joint of the part
        distal of it (``docs/model.md``, "Statics"): gravity (``gravity``,
        m/s^2, base frame: planar ``[gx, gy]``, spatial ``(3,)``; default the
        robot file's) on the disks' masses, the force-controlled cables at
        their tensions (``force`` (f,) or (N, f), N; default the robot
        file's; ``lower`` is its planar name: the lower cables of the pairs)
        and the tip wrench in the task space (planar ``[Fx, Fy, Mz]``, spatial
        ``[Fx, Fy, Fz, Mx, My, Mz]``; N, N m, base frame; (task,) or (N,
        task)). As many position cables as joints (a planar arm): the
        balance's one solution, negative where a cable would have to push,
        NaN where a cable has no moment arm; more: the minimum-norm set at or
        above ``min_tension`` (N), NaN rows where none exists.

        ``friction``: Coulomb friction ``mu`` (1, within [0, 1]) of every cable in
        every hole (``docs/model.md``, "Friction in the holes"), in the bounding
        sliding state ``sliding``: ``"pull"`` (the actuators haul the arm, the
        position cables slide toward them, the force cables away) or
        ``"release"`` (the opposite); the tensions are then those at the
        actuators (the routing's), each hole multiplying a cable's tension by
        ``exp(-mu z beta)`` toward its end."""
        force, name = self._force(force, lower)
        res, single = self._statics(theta, min_tension, tip_wrench, force, gravity, name, friction, sliding)
        return self._out(res.tension, (len(self.position_cables),), single)

    @staticmethod
    def _force(force, lower):
        """The force-cable tensions and the name they were given by."""
        if lower is None:
            return force, "force"
        if force is not None:
            raise CdsmInputError("`lower`, `force`: give one of them (lower is the planar name of force)")
        return lower, "lower"

    def feasible(self, theta, min_tension: float = 0.0, tip_wrench=None, force=None, gravity=None,
                 lower=None, friction: Optional[float] = None, sliding: str = "pull") -> np.ndarray:
        """Whether the position cables hold the arm, every tension above
        ``min_tension`` (N): (N, n) -> (N,) bool (False: a cable would have to
        go slack). Loads, ``friction`` and ``sliding`` as :meth:`tensions`.

        With friction the two sliding states lose a cable in opposite ways
        (``docs/model.md``, "Statics with friction"). **Slack comes first
        pulling**: each position cable slides toward its actuator, its
        tension growing toward it (``T_proximal = T_distal exp(mu beta)``
        at each hole), and each force cable is drawn distally, its tension
        growing from its weight toward its end; at a joint, the pairs that
        end beyond it then pull harder on the position side than at their
        own joints, taking over part of the moment the position cable
        ending there must make, and its tension drops toward zero.
        Releasing reverses every hole, and the position cables pull harder.
        **A positive floor is crossed first releasing**: the tension checked
        is the actuator's, and as a cable pays out the holes grip it and
        carry part of the load, so the actuator holds the gap's tension
        divided by ``exp(mu sum beta)``. The paper prototype at ``mu = 1``
        over the ±30° grid in 5° steps (2197 configurations): every cable
        taut at 1576 pulling and 2197 releasing; every tension above 0.05 N
        at 1354 pulling and 6 releasing."""
        force, name = self._force(force, lower)
        res, single = self._statics(theta, min_tension, tip_wrench, force, gravity, name, friction, sliding)
        ok = np.asarray(res.feasible, bool)
        return ok[0] if single else ok

    def stretch(self, theta, tip_wrench=None, force=None, gravity=None, lower=None) -> np.ndarray:
        """Elongation of every position cable, m, under the statics tensions
        at theta (loads as :meth:`tensions`): ``(L_geom + routing_length) *
        eps / (1 + eps)``, ``eps = T / (E A)``, ``A = pi d^2 / 4``. (N, n) ->
        (N, m_pos). NaN where the tensions are."""
        t = self.tensions(theta, tip_wrench=tip_wrench, force=force, gravity=gravity, lower=lower)
        eps = t / self.axial_stiffness
        return (self.position_lengths(theta) + self.routing_length) * eps / (1.0 + eps)

    def with_loads(self, lower_tension=None, gravity=None) -> "Robot":
        """The same robot with other loads: the force-controlled cables'
        tensions, N, one per force cable in file order (a planar arm's lower
        cables, (n,)), and/or gravity, m/s^2, shaped as :attr:`gravity` (e.g.
        the paper's other readings)."""
        force = self.core.structure()["force"]
        lo = (self.cable_tensions[force] if lower_tension is None
              else as_vector("lower_tension", lower_tension, len(force)))
        g = self.gravity if gravity is None else as_vector("gravity", gravity, self.kind.dim)
        return Robot(self.core.with_loads(np.ascontiguousarray(lo, float), np.ascontiguousarray(g, float)),
                     self.threads)

    def with_cable(self, youngs_modulus: Optional[float] = None, diameter: Optional[float] = None,
                   routing_length: Optional[float] = None,
                   stretch_feed_forward: Optional[bool] = None) -> "Robot":
        """The same robot with another cable material (Pa, m), routing length (m) or
        controller premise (:attr:`stretch_feed_forward`, True or False); its cable then
        stated (:attr:`cable_stated`, :attr:`redundant_settle`)."""
        e = self.youngs_modulus if youngs_modulus is None else as_finite("youngs_modulus", youngs_modulus)
        d = self.cable_diameter if diameter is None else as_finite("diameter", diameter)
        r = self.routing_length if routing_length is None else as_finite("routing_length", routing_length)
        f = self.stretch_feed_forward if stretch_feed_forward is None else stretch_feed_forward
        if not isinstance(f, (bool, np.bool_)):
            raise CdsmInputError(f"`stretch_feed_forward`: expected True or False, got {f!r}")
        return Robot(self.core.with_cable(e, d, r, bool(f)), self.threads)

    def solve_cables_elastic(self, lengths, seed=None, lower=None, tip_wrench=None, gravity=None,
                             min_tension: float = 0.0, tol: float = 1e-12, max_iter: int = 100,
                             force=None) -> "ElasticSolution":
        """Commanded (unstretched) lengths of the position cables (N, m_pos),
        m -> joint angles with elastic cables whose tensions depend on theta
        (coupled solve; ``docs/model.md``, "Statics").

        The arm sees ``L_geom = (L_cmd + routing_length)(1 + T/(E A)) -
        routing_length`` per position cable: with as many position cables as
        joints T from the balance (:meth:`tensions`), with more the cables'
        own Hooke tensions at the equilibrium. Loads as :meth:`tensions`
        (``lower`` the planar name of ``force``). Each row: the rigid cable
        solve from ``seed`` (default 0), then damped Newton (LM) on the
        coupled equations. Returns an :class:`ElasticSolution` (also flags
        slack cables: ``feasible``).
        """
        name = self.kind.command_arg
        u, single = as_batch(name, lengths, len(self.position_cables))
        force, fname = self._force(force, lower)
        rows = u.shape[0]

        def rowed(label, value, width):
            if value is None:
                return None
            arr, one = as_batch(label, value, width)
            if not one and arr.shape[0] != rows:
                raise CdsmInputError(f"`{label}`: expected shape ({rows}, {width}) or ({width},), "
                                     f"got {np.shape(value)}")
            return arr

        w = rowed("tip_wrench", tip_wrench, self.task)
        w = None if w is None else self.kind.core_wrench(w)
        f = rowed(fname, force, self.cables - len(self.position_cables))
        g = None if gravity is None else self.kind.core_gravity(gravity)
        res = self.core.solve_elastic(u, self._seed(seed, rows), None if f is None else f.reshape(-1),
                                      None if w is None else w.reshape(-1), g,
                                      as_finite("min_tension", min_tension), as_finite("tol", tol),
                                      as_iterations("max_iter", max_iter), self.threads)
        m = len(self.position_cables)
        return ElasticSolution.from_core(res.solution, self.n, single, self, tension=res.tension.reshape(-1, m),
                                         _feasible=res.feasible)


    # ---- elastic arms (docs/model.md, "Elastic arms") --------------------
    @property
    def joint_stiffness(self) -> np.ndarray:
        """Every joint's spring stiffness ``(n,)`` N m/rad (0: a free joint), as
        given per joint or derived from the file's ``[backbone]``."""
        return np.asarray(self.core.joint_stiffness)

    @property
    def rest_angles(self) -> np.ndarray:
        """Every joint spring's rest angle ``(n,)`` rad."""
        return np.asarray(self.core.rest_angles)

    @property
    def displacement_cables(self) -> List[int]:
        """Indices (0-based, file order) of the cables commanded in displacement
        through a series stiffness."""
        return list(self.core.displacement_cables)

    @property
    def cable_modes(self) -> List[str]:
        """Every cable's mode: ``"position"``, ``"force"`` or ``"displacement"``."""
        return list(self.core.cable_modes)

    @property
    def is_elastic(self) -> bool:
        """Whether the arm has joint springs (or rest angles) or displacement
        cables: its statics is :meth:`equilibrium`; the rigid solves and
        statics refuse it."""
        return bool(np.any(self.joint_stiffness != 0.0) or np.any(self.rest_angles != 0.0)
                    or self.displacement_cables)

    def elastic_cables(self) -> Dict[str, np.ndarray]:
        """Every cable's ``rest_length (m,)`` m (its path at the rest angles) and
        ``series_stiffness (m,)`` N/m (``1 / (1/k_a + (L0 + L_r)/(E A))``; NaN but
        for displacement cables) and the actuators' ``stiffness`` N/m (inf:
        rigid), ``pretension`` N (a position cable's too: its tension at its commanded
        length, ``docs/model.md``, "Settling") and ``max_tension`` N (inf: none)."""
        rest, ks = self.core.elastic_cables()
        k, p, cap = self.core.actuators
        return dict(rest_length=np.asarray(rest), series_stiffness=np.asarray(ks), stiffness=np.asarray(k),
                    pretension=np.asarray(p), max_tension=np.asarray(cap))

    def _elastic_commands(self, lengths, displacements, tip_wrench) -> Tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                              int, bool]:
        """The commands as flat arrays, the number of rows and whether they came 1-D."""
        parts, rows, single = [], None, None
        for name, value, width in (("lengths", lengths, len(self.position_cables)),
                                   ("displacements", displacements, len(self.displacement_cables))):
            if value is None:
                if width:
                    raise CdsmInputError(f"`{name}`: the arm has {width} such cables; give `{name}` (N, {width}) m")
                parts.append(None)
                continue
            if not width:
                raise CdsmInputError(f"`{name}`: the arm has no such cables (give None)")
            arr, one = as_batch(name, value, width)
            if rows is not None and arr.shape[0] != rows:
                raise CdsmInputError(f"`{name}`: {arr.shape[0]} rows, the other commands {rows}")
            rows, single = arr.shape[0], one if single is None else single and one
            parts.append(arr)
        if tip_wrench is None:
            w = np.zeros(0)
        else:
            w, one = as_batch("tip_wrench", tip_wrench, self.task)
            if not one:
                if rows is not None and w.shape[0] != rows:
                    raise CdsmInputError(f"`tip_wrench`: {w.shape[0]} rows, the commands {rows}")
                rows, single = w.shape[0], False
        rows = 1 if rows is None else rows
        single = True if single is None else single
        flat = [np.zeros(0) if a is None else a.reshape(-1) for a in parts]
        return flat[0], flat[1], np.ascontiguousarray(w).reshape(-1), rows, single

    def equilibrium(self, lengths=None, displacements=None, tip_wrench=None, seed=None, sequence: bool = False,
                    xtol: float = XTOL, max_iter: int = 100) -> Equilibrium:
        """The frictionless forward statics of an elastic arm (``docs/model.md``,
        "Elastic arms"): per row of commands, the configuration that minimises
        the potential energy (joint springs, the elastic cables' stretch with
        slack cables carrying nothing, force cables, gravity, the tip force),
        for any number of joints and cables.

        Commands: ``lengths (N, m_pos)`` m of the position cables (order of
        :attr:`position_cables`), ``displacements (N, m_d)`` m of the
        displacement cables (order of :attr:`displacement_cables`, positive =
        pull); each needed when the arm has such cables. ``tip_wrench`` the
        kind's rows (planar ``[Fx, Fy, Mz]`` N, N, N m; spatial ``[Fx, Fy, Fz,
        0, 0, 0]``: a spatial tip moment has no potential and is refused),
        ``(t,)`` or ``(N, t)``. ``seed`` ``(n,)`` or ``(N, n)`` rad (default:
        the rest angles; for an arm without springs and with at least as many
        position cables as joints the rigid cable solve). ``sequence``: solve
        the rows in order, each from the previous row's answer (the first from
        ``seed``): the warm start along a recorded sequence (one thread).

        Newton's method with an Armijo line search on the potential, using the
        structure (per-disk blocks plus the taut cables' low-rank term);
        converged when the unshifted step is at most ``xtol`` rad. A row that
        does not converge is flagged with its reason. Returns an
        :class:`~cdsm.elastic.Equilibrium`.
        """
        L, d, w, rows, single = self._elastic_commands(lengths, displacements, tip_wrench)
        if seed is None:
            s = None
        elif sequence:
            s = as_vector("seed", seed, self.n)
        else:
            s = self._seed(seed, rows).reshape(-1)
        res = self.core.equilibrium(L, d, w, s, bool(sequence), as_finite("xtol", xtol),
                                    as_iterations("max_iter", max_iter), self.threads)
        return Equilibrium.from_core(res, self.n, self.cables, single)

    def equilibrium_derivatives(self, theta, lengths=None, displacements=None,
                                tip_wrench=None) -> EquilibriumDerivatives:
        """Derivatives of the equilibria ``theta (N, n)`` rad (:meth:`equilibrium`
        of the same commands) by the implicit function theorem: ``dq/dp =
        -H^-1 dg/dp`` per commanded length (m), displacement (m) and wrench row
        (N, N m), and the task vector's and tensions' derivatives
        (:class:`~cdsm.elastic.EquilibriumDerivatives`). At a cable's slack (or
        cap) transition: the one-sided derivative of the side its flag says."""
        L, d, w, rows, single = self._elastic_commands(lengths, displacements, tip_wrench)
        th, one = as_batch("theta", theta, self.n)
        res = self.core.equilibrium_derivatives(L, d, w, th.reshape(-1), self.threads)
        widths = (len(self.position_cables), len(self.displacement_cables), self.task)
        return EquilibriumDerivatives.from_core(res, self.n, self.task, self.cables, widths, single and one)


@dataclass(frozen=True, repr=False)
class ElasticSolution(Solution):
    """A :class:`Solution` of the elastic cable solve, plus the statics at the
    answer: tension (N, m_pos) position-cable tensions, N; ``feasible`` (N,)
    here means every such tension above ``min_tension`` (False: some cable
    would go slack)."""

    tension: np.ndarray = None


def _vec(v, digits: int) -> str:
    """A short vector for the summary tables."""
    return "[" + ", ".join(f"{x:.{digits}g}" for x in np.asarray(v, dtype=float)) + "]"


def _plausible(robot: Robot) -> Robot:
    """``robot``, with a :class:`CdsmDataWarning` when its straight arm is
    longer than :data:`PLAUSIBLE_LENGTH` (a file in mm read as m, most
    likely)."""
    length = robot.straight_length
    if length > PLAUSIBLE_LENGTH:
        warnings.warn(f"robot {robot.name!r}: the straight arm is {length:.4g} m long; is the file in mm? cdsm "
                      "reads SI units: metres (divide every length by 1000)", CdsmDataWarning, stacklevel=3)
    return robot
