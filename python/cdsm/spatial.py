"""Spatial arms (``kind = "spatial"``): a thin, typed front over the Rust
core's spatial model (``docs/spatial.md``). SI units: m, rad, N, kg.

Build one with :meth:`cdsm.Robot.from_toml` or :meth:`cdsm.Robot.packaged`
on a spatial robot file (``paper_spatial``, ``two_universal``). Batch inputs
are ``(N, k)``; a single configuration may be given 1-D and comes back 1-D.
The task-space vector of a spatial arm is ``[x, y, z, rx, ry, rz]``: the end
frame's origin (m) and its rotation as a rotation vector (rad).
"""

from __future__ import annotations

from typing import List, Optional

import numpy as np

from . import _cdsm
from .inputs import CdsmInputError, as_batch, as_finite, as_iterations
from .robot import KINDS, Arm, Solution

__all__ = ["SpatialRobot", "SPATIAL_MASKS", "TASK"]

#: Task masks of the spatial pose IK.
SPATIAL_MASKS = ("position", "pointing", "pose")
#: Task-space width: x, y, z (m), rotation vector (rad).
TASK = 6


class SpatialRobot(Arm):
    """A spatial cable-driven serpentine arm: ``n`` revolute joints, disks
    with holes anywhere within their radius, position- and force-controlled
    cables (``docs/spatial.md``)."""

    kind = "spatial"

    def __init__(self, core: "_cdsm.CoreSpatialRobot", threads: int = 0, toml: str = ""):
        super().__init__(core, threads)
        self._toml = toml

    def to_toml(self) -> str:
        """The robot file this robot was read from (TOML, SI units); holes
        changed since (:meth:`with_holes`) are not in it."""
        return self._toml

    def __repr__(self) -> str:
        return f"SpatialRobot({self.name!r}, n={self.n}, cables={self.cables})"

    # ---- description --------------------------------------------------
    @property
    def joint_limits(self) -> np.ndarray:
        """(n, 2) joint limits [lo, hi], rad."""
        return self.core.joint_limits.reshape(-1, 2)

    @property
    def axes(self) -> np.ndarray:
        """(n, 3) unit joint axes, each in its joint's local frame."""
        return self.core.axes.reshape(-1, 3)

    @property
    def gravity(self) -> np.ndarray:
        """(3,) gravity, m/s^2, base frame."""
        return self.core.gravity

    @property
    def straight_length(self) -> float:
        """Distance of the straight arm's tip (theta = 0) from the base, m."""
        return self.core.straight_length

    @property
    def cables(self) -> int:
        """Number of cables."""
        return self.core.cables

    @property
    def position_cables(self) -> List[int]:
        """Indices of the position-controlled cables (their lengths are commanded)."""
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
    def holes(self) -> List[np.ndarray]:
        """Per cable, its holes (2 end + 1, 3) in face frames, m."""
        flat = self.core.holes
        out, k = [], 0
        for e in self.cable_ends:
            out.append(flat[k:k + 3 * (2 * e + 1)].reshape(-1, 3))
            k += 3 * (2 * e + 1)
        return out

    @property
    def radii(self) -> np.ndarray:
        """Disk radii (base first), m."""
        return self.core.radii

    def with_holes(self, holes) -> "SpatialRobot":
        """The same robot with other holes: a list like :attr:`holes`, or one
        flat array of every ``[x, y, z]`` (m)."""
        if isinstance(holes, (list, tuple)):
            flat = np.concatenate([np.asarray(h, dtype=float).reshape(-1) for h in holes])
        else:
            flat = np.asarray(holes, dtype=float).reshape(-1)
        return SpatialRobot(self.core.with_holes(np.ascontiguousarray(flat)), self.threads, self._toml)

    # ---- kinematics ---------------------------------------------------
    def _map(self, theta, method, shape):
        t, single = as_batch("theta", theta, self.n)
        return self._out(method(t, self.threads), shape, single)

    def fk(self, theta) -> np.ndarray:
        """End pose [x, y, z (m), rx, ry, rz (rad, rotation vector)]: (N, n) -> (N, 6)."""
        return self._map(theta, self.core.fk, (TASK,))

    def fk_matrix(self, theta) -> np.ndarray:
        """End frame as a homogeneous matrix: (N, n) -> (N, 4, 4) (m)."""
        return self._map(theta, self.core.fk_matrix, (4, 4))

    def fk_jacobian(self, theta) -> np.ndarray:
        """Geometric Jacobian of the end frame: (N, n) -> (N, 6, n): rows 0-2
        the velocity of its origin (m/rad), rows 3-5 its angular velocity."""
        return self._map(theta, self.core.fk_jacobian, (6, self.n))

    def cable_lengths(self, theta) -> np.ndarray:
        """Lengths of every cable (file order), m: (N, n) -> (N, cables)."""
        return self._map(theta, self.core.cable_lengths, (self.cables,))

    def position_lengths(self, theta) -> np.ndarray:
        """Lengths of the position-controlled cables, m: (N, n) -> (N, m_pos)."""
        return self.cable_lengths(theta)[..., self.position_cables]

    def cable_jacobian(self, theta) -> np.ndarray:
        """dL/d theta, m/rad: (N, n) -> (N, cables, n)."""
        return self._map(theta, self.core.cable_jacobian, (self.cables, self.n))

    def within_limits(self, theta) -> np.ndarray:
        """Whether every angle lies within the joint limits: (N, n) -> (N,) bool."""
        t, single = as_batch("theta", theta, self.n)
        lim = self.joint_limits
        ok = np.all((t >= lim[:, 0]) & (t <= lim[:, 1]), axis=1)
        return ok[0] if single else ok

    # ---- solves -------------------------------------------------------
    def solve_cables(self, lengths, seed=None, tol: float = 1e-12, max_iter: int = 100,
                     enforce_limits: bool = False) -> Solution:
        """Lengths of the position-controlled cables (N, m_pos), m -> joint
        angles (the force-controlled cables follow). Damped Newton with as
        many cables as joints; least squares with more (``residual`` reports
        the misfit, m). ``seed`` (N, n) or (n,), rad; default 0."""
        m = len(self.position_cables)
        u, single = as_batch("lengths", lengths, m)
        res = self.core.solve_cables(u, self._seed(seed, u.shape[0]), float(tol),
                                     as_iterations("max_iter", max_iter), bool(enforce_limits), self.threads)
        return Solution.from_core(res, self.n, single, self)

    def ik(self, target, seed=None, tol: float = 1e-12, max_iter: int = 100,
           enforce_limits: bool = False, mask: str = "pose") -> Solution:
        """Pose IK by damped least squares: target [x, y, z (m), rx, ry, rz
        (rad)] (N, 6) -> Solution. ``mask``: ``"position"`` (the end origin;
        the rotation columns are ignored), ``"pointing"`` (the origin and the
        direction of the end frame's x axis) or ``"pose"``. Universal joints
        have no closed form: this is the only IK of spatial arms."""
        if mask not in SPATIAL_MASKS:
            raise CdsmInputError(f"`mask`: expected one of {', '.join(map(repr, SPATIAL_MASKS))}, got {mask!r}")
        p, single = as_batch("target", target, TASK)
        res = self.core.ik(p, self._seed(seed, p.shape[0]), mask, float(tol),
                           as_iterations("max_iter", max_iter), bool(enforce_limits), self.threads)
        return Solution.from_core(res, self.n, single, self)

    # ---- statics ------------------------------------------------------
    def _statics(self, theta, tip_wrench, min_tension):
        t, single = as_batch("theta", theta, self.n)
        w = [0.0] * 6 if tip_wrench is None else [float(v) for v in as_batch("tip_wrench", tip_wrench, 6)[0][0]]
        res = self.core.tensions(t, w, as_finite("min_tension", min_tension), self.threads)
        return res, single

    def tensions(self, theta, tip_wrench: Optional[np.ndarray] = None, min_tension: float = 0.0) -> np.ndarray:
        """Tensions of the position-controlled cables (N, m_pos), N: the
        minimum-norm set at or above ``min_tension`` that holds the arm
        (gravity of the robot file, force cables at their tension, the tip
        wrench [F (N), M (N m)] in the base frame); NaN rows where none exists."""
        res, single = self._statics(theta, tip_wrench, min_tension)
        return self._out(res.tension, (len(self.position_cables),), single)

    def feasible(self, theta, min_tension: float = 0.0, tip_wrench: Optional[np.ndarray] = None) -> np.ndarray:
        """Whether a tension set at or above ``min_tension`` (N) holds the arm:
        (N, n) -> (N,) bool (False: a cable would have to go slack)."""
        res, single = self._statics(theta, tip_wrench, min_tension)
        ok = np.asarray(res.feasible, bool)
        return ok[0] if single else ok


KINDS["spatial"] = lambda text: SpatialRobot(_cdsm.CoreSpatialRobot.from_toml(text), toml=text)
