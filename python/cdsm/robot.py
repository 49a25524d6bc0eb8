"""The robot: a thin, typed front over the Rust core (SI units: m, rad, N, kg).

Arrays in, arrays out. Batch inputs are ``(N, k)``; a single configuration may
be given 1-D and then comes back 1-D. Integer and non-contiguous arrays are
accepted (copied once); NaN/inf and wrong shapes raise :class:`CdsmInputError`
naming the argument.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, Optional, Tuple

import numpy as np

from . import _cdsm
from .files import read_text, toml_string
from .inputs import CdsmInputError, as_batch, as_finite, as_iterations, as_vector

__all__ = ["Arm", "Robot", "Solution", "KINDS", "ElasticSolution", "CdsmInputError", "REASONS", "TASK_MASKS",
           "IK_METHODS", "packaged_robots"]

_ROBOTS = Path(__file__).parent / "robots"

#: Robot kinds by name: a function building the robot from its TOML text.
#: Each kind's module registers itself (``planar`` here, ``spatial`` in
#: :mod:`cdsm.spatial`, imported by ``cdsm``).
KINDS: Dict[str, Callable[[str], "Arm"]] = {}


def packaged_robots() -> Tuple[str, ...]:
    """Names of the robot descriptions shipped with cdsm (``cdsm/robots/*.toml``),
    for :meth:`Robot.packaged`."""
    return tuple(sorted(p.stem for p in _ROBOTS.glob("*.toml")))


#: Why a solve ended, by code (``Solution.reason`` holds the names).
REASONS = tuple(_cdsm.REASONS)

_REASON_NAMES = np.array(REASONS)

#: Pose-IK methods (:meth:`Robot.ik`).
IK_METHODS = ("lm", "closed_form")

#: Named task masks of the pose IK over the planar task coordinates (x, y, phi).
TASK_MASKS = {"pose": (1.0, 1.0, 1.0), "position": (1.0, 1.0, 0.0)}


@dataclass(frozen=True)
class Solution:
    """Result of a batch of solves.

    theta: (N, n) joint angles, rad. converged: (N,) bool; a failed element
    keeps its last iterate and must not be used as an answer. iterations: (N,)
    trial steps (0 = closed form). residual: (N,) max |residual| (m, or rad for
    the attitude). within_limits: (N,) all angles within the joint limits.
    reason: (N,) why each solve ended: ``"converged"``, ``"iteration limit"``,
    ``"singular"`` (the step could not be computed), ``"unreachable"`` (the
    residual cannot be lowered: the target is out of reach) or ``"outside
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


class Arm:
    """What every robot kind shares: the core it wraps, the worker threads of
    its batch calls, and batch handling of inputs and seeds. See
    :class:`Robot` (planar) and :class:`cdsm.spatial.SpatialRobot`."""

    #: ``"planar"`` or ``"spatial"``
    kind = ""

    def __init__(self, core, threads: int = 0):
        #: the Rust core robot, used by the other modules
        self.core = core
        self.threads = threads

    @property
    def threads(self) -> int:
        """Worker threads of batch calls (0 = all cores); they run without the GIL."""
        return self._threads

    @threads.setter
    def threads(self, value: int) -> None:
        try:
            v = int(value)
        except (TypeError, ValueError):
            raise CdsmInputError(f"`threads`: expected a non-negative integer, got {value!r}") from None
        if v < 0 or v != value:
            raise CdsmInputError(f"`threads`: expected a non-negative integer, got {value!r}")
        self._threads = v

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.core.n

    @property
    def name(self) -> str:
        return self.core.name

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

    @classmethod
    def packaged(cls, name: str) -> "Arm":
        """A robot description shipped with cdsm (``cdsm/robots/<name>.toml``),
        planar or spatial: see :func:`packaged_robots`."""
        names = packaged_robots()
        if name not in names:
            raise CdsmInputError(f"`name`: no packaged robot {name!r}; packaged: {', '.join(names)}")
        return Robot.from_toml(_ROBOTS / f"{name}.toml")

    @classmethod
    def from_toml(cls, path: "str | os.PathLike[str]") -> "Arm":
        """Read a robot description (TOML, SI units): a :class:`Robot`, or a
        :class:`cdsm.spatial.SpatialRobot` when it says ``kind = "spatial"``.

        ``path`` is a file, or the name of a packaged robot
        (:func:`packaged_robots`, e.g. ``"two_universal"``) when no such file
        exists: the one rule for naming a robot everywhere (``--robot`` too).
        A name that is neither says so and lists the packaged names."""
        if not os.path.exists(path):
            name = os.fspath(path)
            if name in packaged_robots():
                return cls.packaged(name)
            raise CdsmInputError(f"robot file {name!r}: does not exist, and no packaged robot has that name "
                                 f"(packaged: {', '.join(packaged_robots())})")
        return Robot.from_toml_str(read_text(path, "robot"))


class Robot(Arm):
    """A planar cable-driven serpentine manipulator with ``n`` joints and ``2n`` cables.

    Build with :meth:`paper` (the seed paper's prototype, Table 1) or
    :meth:`from_toml`. The model and solver conventions are in ``docs/model.md``.
    """

    kind = "planar"

    def __init__(self, core: "_cdsm.CoreRobot", threads: int = 0):
        super().__init__(core, threads)

    # ---- construction -------------------------------------------------
    @classmethod
    def paper(cls) -> "Robot":
        """The paper's 3-DOF prototype: Table 1, lower cables 50/10/5 g, limits ±35°."""
        return cls(_cdsm.CoreRobot.paper())

    @staticmethod
    def from_toml_str(text: str) -> "Arm":
        """Parse a robot description given as TOML text (planar, or spatial
        when it says ``kind = "spatial"``)."""
        kind = _cdsm.robot_kind(text)
        if kind not in KINDS:
            raise CdsmInputError(f"`kind`: robots of kind {kind!r} are not available (import cdsm first)")
        return KINDS[kind](text)

    def with_holes(self, holes) -> "Robot":
        """The same robot with hole positions ``holes`` (2n, n+1, 2, 2), m."""
        h = np.ascontiguousarray(np.asarray(holes, dtype=np.float64))
        if h.shape != self.holes.shape:
            raise CdsmInputError(f"`holes`: expected shape {self.holes.shape}, got {h.shape}")
        return Robot(self.core.with_holes(h), self.threads)

    def hole_height_error(self, dh) -> np.ndarray:
        """Hole positions (2n, n+1, 2, 2), m, after the paper's per-disk hole-height
        error ``dh`` (n,), m: pair i's holes move outward by ``dh[i]`` on every face."""
        d = as_vector("dh", dh, self.n)
        return self.core.hole_height_error(d).reshape(self.holes.shape)

    # ---- description --------------------------------------------------
    @property
    def link_before(self) -> np.ndarray:
        """(n,) link before each joint, m (the paper's link_{i-1,J_i})."""
        return self.core.link_before

    @property
    def link_after(self) -> np.ndarray:
        """(n,) link after each joint, m (the paper's link_{J_i,i})."""
        return self.core.link_after

    @property
    def thickness(self) -> np.ndarray:
        """(n,) disk thickness, m (the paper's B)."""
        return self.core.thickness

    @property
    def mass(self) -> np.ndarray:
        """(n,) linkage masses, kg."""
        return self.core.mass

    @property
    def lower_tension(self) -> np.ndarray:
        """(n,) tension on the lower (force-controlled) cable of each pair, N."""
        return self.core.lower_tension

    @property
    def joint_limits(self) -> np.ndarray:
        """(n, 2) joint limits [lo, hi], rad."""
        return self.core.joint_limits.reshape(-1, 2)

    @property
    def holes(self) -> np.ndarray:
        """(2n, n+1, 2, 2) hole positions: cable, disk (0 = base), face (a, b), (x, y); m."""
        n = self.n
        return self.core.holes.reshape(2 * n, n + 1, 2, 2)

    @property
    def youngs_modulus(self) -> float:
        """Cable Young's modulus, Pa."""
        return self.core.youngs_modulus

    @property
    def cable_diameter(self) -> float:
        """Cable diameter, m."""
        return self.core.cable_diameter

    def to_toml(self) -> str:
        """A TOML description that rebuilds this robot exactly (explicit
        ``upper_holes``/``lower_holes``, every float by ``repr``; SI units).
        Hole entries the model never uses (base face a, disks beyond a
        cable's pair) are not written and read back as 0."""
        def f(v) -> str:
            x = float(v)
            if not math.isfinite(x):
                raise CdsmInputError(f"to_toml: non-finite value {x}")
            return repr(x)

        n = self.n
        lb, la, h, lim = self.link_before, self.link_after, self.holes, self.joint_limits
        lines = [
            "# written by cdsm.Robot.to_toml; SI units (m, kg, N, rad, Pa)",
            f"name = {toml_string(self.name)}",
            f"n = {n}",
            "",
            "[cable]",
            f"youngs_modulus = {f(self.youngs_modulus)}",
            f"diameter = {f(self.cable_diameter)}",
            f"routing_length = {f(self.routing_length)}",
        ]
        for i in range(n):
            pts = []
            for c in (2 * i, 2 * i + 1):
                row = []
                for j in range(2 * i + 3):  # base face b, then faces a, b of disks 1..i+1
                    d, face = (0, 1) if j == 0 else ((j + 1) // 2, 1 - j % 2)
                    x, y = h[c, d, face]
                    row.append(f"[{f(x)}, {f(y)}]")
                pts.append("[" + ", ".join(row) + "]")
            lines += [
                "",
                "[[linkage]]",
                f"link_before = {f(lb[i])}",
                f"link_after = {f(la[i])}",
                f"thickness = {f(self.thickness[i])}",
                f"mass = {f(self.mass[i])}",
                f"lower_tension = {f(self.lower_tension[i])}",
                f"joint_limits = [{f(lim[i, 0])}, {f(lim[i, 1])}]",
                f"upper_holes = {pts[0]}",
                f"lower_holes = {pts[1]}",
            ]
        return "\n".join(lines) + "\n"

    def __repr__(self) -> str:
        return f"Robot({self.name!r}, n={self.n})"

    # ---- kinematics ---------------------------------------------------
    def fk(self, theta) -> np.ndarray:
        """End pose [x (m), y (m), phi (rad)]: (N, n) -> (N, 3); (n,) -> (3,)."""
        t, single = as_batch("theta", theta, self.n)
        return self._out(self.core.fk(t, self.threads), (3,), single)

    def fk_matrix(self, theta) -> np.ndarray:
        """End frame as a homogeneous transform in 3-D (the plane is z = 0,
        joints turn about z), as spatial arms give it: (N, n) -> (N, 4, 4);
        (n,) -> (4, 4). Rotation Rz(phi), translation (x, y, 0) m."""
        t, single = as_batch("theta", theta, self.n)
        pose = self.core.fk(t, self.threads).reshape(-1, 3)
        c, s = np.cos(pose[:, 2]), np.sin(pose[:, 2])
        f = np.zeros((len(pose), 4, 4))
        f[:, 0, 0], f[:, 0, 1], f[:, 1, 0], f[:, 1, 1] = c, -s, s, c
        f[:, 2, 2] = f[:, 3, 3] = 1.0
        f[:, 0, 3], f[:, 1, 3] = pose[:, 0], pose[:, 1]
        return f[0] if single else f

    def fk_jacobian(self, theta) -> np.ndarray:
        """d[x, y, phi]/d theta: (N, n) -> (N, 3, n)."""
        t, single = as_batch("theta", theta, self.n)
        return self._out(self.core.fk_jacobian(t, self.threads), (3, self.n), single)

    def cable_lengths(self, theta) -> np.ndarray:
        """Lengths of all 2n cables, m: (N, n) -> (N, 2n), order L_c1_1, L_c1_2, ..., L_cn_2."""
        t, single = as_batch("theta", theta, self.n)
        return self._out(self.core.cable_lengths(t, self.threads), (2 * self.n,), single)

    def upper_lengths(self, theta) -> np.ndarray:
        """Lengths of the n upper (position-controlled) cables, m: (N, n) -> (N, n)."""
        return self.cable_lengths(theta)[..., 0::2]

    def cable_jacobian(self, theta) -> np.ndarray:
        """dL/d theta, m/rad: (N, n) -> (N, 2n, n) (lower triangular in pairs)."""
        t, single = as_batch("theta", theta, self.n)
        return self._out(self.core.cable_jacobian(t, self.threads), (2 * self.n, self.n), single)

    def within_limits(self, theta) -> np.ndarray:
        """Whether every angle lies within the joint limits: (N, n) -> (N,) bool."""
        t, single = as_batch("theta", theta, self.n)
        ok = self.core.within_limits(t, self.threads)
        return ok[0] if single else ok

    # ---- solves -------------------------------------------------------
    def ik(self, pose, seed=None, tol: float = 1e-12, max_iter: int = 100,
           enforce_limits: bool = False, mask="pose", method: str = "lm") -> Solution:
        """Pose IK: pose [x (m), y (m), phi (rad)] (N, 3) -> Solution.

        ``method``: ``"lm"`` (default) — damped least squares
        (Levenberg–Marquardt, minimal-norm steps; normal-equation steps when
        the task has more rows than the arm has joints) from the seed, any arm and
        mask; ``"closed_form"`` — 3-joint arms, full pose: both branches, the
        one nearest the seed (ties: theta_2 <= 0, the paper's), 0 iterations
        (``docs/model.md``). ``seed`` (N, n) or (n,), rad; default theta = 0.
        ``mask``: which task coordinates to match — ``"pose"`` (x, y, phi),
        ``"position"`` (x, y; the attitude is free, its column of ``pose``
        ignored) or three non-negative weights on the x, y, phi residuals
        (m, m, rad). Convergence is judged on the weighted residual. Joint
        limits are flagged (``within_limits``) and enforced only with
        ``enforce_limits``.
        """
        p, single = as_batch("pose", pose, 3, finite=False)  # checked by the core
        if method not in IK_METHODS:
            raise CdsmInputError(f"`method`: expected one of {', '.join(map(repr, IK_METHODS))}, got {method!r}")
        res = self.core.ik(p, self._seed(seed, p.shape[0]), self._mask(mask), method, float(tol),
                           as_iterations("max_iter", max_iter), bool(enforce_limits), self.threads)
        return Solution.from_core(res, self.n, single, self)

    @staticmethod
    def _mask(mask) -> list:
        if isinstance(mask, str):
            if mask not in TASK_MASKS:
                raise CdsmInputError(f"`mask`: expected one of {', '.join(map(repr, TASK_MASKS))} "
                                     f"or 3 weights, got {mask!r}")
            return list(TASK_MASKS[mask])
        return [float(v) for v in as_vector("mask", mask, 3)]

    def solve_cables(self, upper, seed=None, method: str = "auto", tol: float = 1e-12,
                     max_iter: int = 100, enforce_limits: bool = False) -> Solution:
        """Upper-cable lengths (N, n), m -> joint angles (hybrid control: the lower
        cables are force controlled and follow).

        method: ``"newton"`` (damped Newton / LM from the seed), ``"closed_form"``
        (per joint, the acos branch nearest the seed) or ``"auto"`` (closed form,
        verified, LM if it fails).
        """
        u, single = as_batch("upper", upper, self.n, finite=False)  # checked by the core
        res = self.core.solve_cables(u, self._seed(seed, u.shape[0]), str(method), float(tol),
                                     as_iterations("max_iter", max_iter), bool(enforce_limits), self.threads)
        return Solution.from_core(res, self.n, single, self)


    # ---- statics and cable elasticity (issue 4; model in rust/statics.rs) --
    def _loads(self, rows: int, lower, tip_wrench, gravity):
        """Validated load arrays for the core: shared (k,) or per row (N, k)."""
        def rowed(name, value, width):
            if value is None:
                return None
            arr, single = as_batch(name, value, width)
            if not single and arr.shape[0] != rows:
                raise CdsmInputError(f"`{name}`: expected shape ({rows}, {width}) or ({width},), "
                                     f"got {np.shape(value)}")
            return arr.reshape(-1)
        g = None if gravity is None else as_vector("gravity", gravity, 2)
        return rowed("lower", lower, self.n), rowed("tip_wrench", tip_wrench, 3), g

    def tensions(self, theta, lower=None, tip_wrench=None, gravity=None) -> np.ndarray:
        """Upper-cable tensions, N (positive = taut): (N, n) -> (N, n); (n,) -> (n,).

        Moment balance about every (frictionless) joint of the part distal of
        it; each cable pulls that part at its hole in disk k along its segment.
        lower: lower (force-controlled) tensions, N, (n,) or (N, n); default the
        robot file's (paper: 50, 10, 5 g on disks 1, 2, 3). tip_wrench:
        [Fx (N), Fy (N), Mz (N m)] at the tip, base frame, (3,) or (N, 3).
        gravity: [gx, gy] (m/s^2) in the base frame; default the robot file's
        (``gravity``; [0, 0]: horizontal plane); linkage i's mass sits at the
        centre of disk i. NaN where an upper cable has no moment arm about its
        own joint.
        """
        t, single = as_batch("theta", theta, self.n)
        lo, w, g = self._loads(t.shape[0], lower, tip_wrench, gravity)
        out = self.core.tensions(t, lo, w, g, self.threads)
        return self._out(out, (self.n,), single)

    def feasible(self, theta, min_tension: float = 0.0, lower=None, tip_wrench=None,
                 gravity=None) -> np.ndarray:
        """Whether every upper cable is taut beyond ``min_tension`` (N):
        (N, n) -> (N,) bool. False where a cable would have to go slack
        (tension <= min_tension) or the balance is impossible (NaN)."""
        t, single = as_batch("theta", theta, self.n)
        lo, w, g = self._loads(t.shape[0], lower, tip_wrench, gravity)
        ok = self.core.feasible(t, lo, w, g, as_finite("min_tension", min_tension), self.threads)
        return ok[0] if single else ok

    def stretch(self, theta, lower=None, tip_wrench=None, gravity=None) -> np.ndarray:
        """Elongation of every upper cable, m, under the statics tensions at theta:
        ``(L_geom + routing_length) * eps / (1 + eps)``, ``eps = T / (E A)``,
        ``A = pi d^2 / 4``. (N, n) -> (N, n)."""
        t, single = as_batch("theta", theta, self.n)
        lo, w, g = self._loads(t.shape[0], lower, tip_wrench, gravity)
        out = self.core.stretch(t, lo, w, g, self.threads)
        return self._out(out, (self.n,), single)

    @property
    def routing_length(self) -> float:
        """Cable path behind the base disk to the actuator, m (stretches with the cable)."""
        return self.core.routing_length

    @property
    def axial_stiffness(self) -> float:
        """Cable axial stiffness E A, N (A = pi d^2 / 4)."""
        return self.core.axial_stiffness

    @property
    def gravity(self) -> np.ndarray:
        """(2,) in-plane gravity [gx, gy], m/s^2, base frame: the default of
        every statics path (robot file ``gravity``; [0, 0]: horizontal plane)."""
        return np.array(self.core.gravity)

    @property
    def straight_length(self) -> float:
        """Length of the straight arm, m: the tip x at theta = 0."""
        return self.core.straight_length

    def with_loads(self, lower_tension=None, gravity=None) -> "Robot":
        """The same robot with other lower-cable tensions (n,), N, and/or
        gravity [gx, gy], m/s^2 (e.g. the paper's other readings)."""
        lo = self.lower_tension if lower_tension is None else as_vector("lower_tension", lower_tension, self.n)
        g = self.gravity if gravity is None else as_vector("gravity", gravity, 2)
        return Robot(self.core.with_loads(np.ascontiguousarray(lo, float), np.ascontiguousarray(g, float)),
                     self.threads)

    def with_cable(self, youngs_modulus: Optional[float] = None, diameter: Optional[float] = None,
                   routing_length: Optional[float] = None) -> "Robot":
        """The same robot with another cable material (Pa, m) or routing length (m)."""
        e = self.youngs_modulus if youngs_modulus is None else as_finite("youngs_modulus", youngs_modulus)
        d = self.cable_diameter if diameter is None else as_finite("diameter", diameter)
        r = self.routing_length if routing_length is None else as_finite("routing_length", routing_length)
        return Robot(self.core.with_cable(e, d, r), self.threads)

    def solve_cables_elastic(self, upper, seed=None, lower=None, tip_wrench=None, gravity=None,
                             min_tension: float = 0.0, tol: float = 1e-12,
                             max_iter: int = 100) -> "ElasticSolution":
        """Commanded (unstretched) upper-cable lengths (N, n), m -> joint angles
        with elastic cables whose tensions depend on theta (coupled solve).

        The arm sees ``L_geom = (L_cmd + routing_length)(1 + T/(E A)) - routing_length``
        per upper cable, T from :meth:`tensions` at the answer. Each row: the
        rigid cable solve (auto) from ``seed`` (default 0), then damped Newton
        (LM) on the coupled equations. Returns an :class:`ElasticSolution`
        (also flags slack cables: ``feasible``).
        """
        u, single = as_batch("upper", upper, self.n)
        lo, w, g = self._loads(u.shape[0], lower, tip_wrench, gravity)
        res = self.core.solve_elastic(u, self._seed(seed, u.shape[0]), lo, w, g,
                                      as_finite("min_tension", min_tension), float(tol),
                                      as_iterations("max_iter", max_iter), self.threads)
        return ElasticSolution.from_core(res.solution, self.n, single, self, tension=res.tension.reshape(-1, self.n),
                                         _feasible=res.feasible)


@dataclass(frozen=True)
class ElasticSolution(Solution):
    """A :class:`Solution` of the elastic cable solve, plus the statics at the
    answer: tension (N, n) upper-cable tensions, N; ``feasible`` (N,) here means
    every upper tension above ``min_tension`` (False: some cable would go slack)."""

    tension: np.ndarray = None



KINDS["planar"] = lambda text: Robot(_cdsm.CoreRobot.from_toml(text))
