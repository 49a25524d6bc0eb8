"""Single error scenarios (the paper's Fig. 3): the tip deviation caused by a
cable-length error ``dL`` on the position-controlled cables (planar: the upper
cables), a hole-location error (``dh`` per disk on planar arms, or ``dholes``
per hole coordinate), or both, solved in the Rust core for either kind. SI
units: m, rad."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..inputs import CdsmInputError, as_array, as_batch, as_finite, as_iterations, as_vector
from ..robot import Robot, Solution
from ..display import ShortRepr

__all__ = ["deviation", "Deviation", "rotation_vectors", "PAPER_DL_TOL", "PAPER_DH_TOL"]

#: The paper's error magnitudes (its Monte-Carlo bounds and single-error
#: scenarios): 1 mm on an upper cable's length, 0.35 mm on a disk's hole height.
PAPER_DL_TOL = 1e-3
PAPER_DH_TOL = 0.35e-3


@dataclass(frozen=True, repr=False)
class Deviation(ShortRepr):
    """Result of :func:`deviation`.

    dS: (N, 3) tip deviation [dX (m), dY (m), dphi (rad)], NaN where the solve
    failed (spatial arms: (N, 6) [dX, dY, dZ (m), rotation vector of the end
    frame's change (rad, base frame)]). theta0: (N, n) initial angles, rad. solution: the perturbed cable
    solves. ik: the pose IK that produced theta0, when poses were given.
    feasible: (N,) every upper cable taut (tension > 0 N, the robot's lower
    tensions, no external load) both before and after the error; False flags
    a configuration the hybrid-controlled arm cannot hold with taut cables
    (None when not asked for: ``deviation(..., statics=False)``).
    """

    dS: np.ndarray
    theta0: np.ndarray
    solution: Solution
    ik: Optional[Solution] = None
    feasible: Optional[np.ndarray] = None

    @property
    def ok(self) -> np.ndarray:
        """(N,) both the initial pose IK (if any) and the perturbed solve converged."""
        ok = np.asarray(self.solution.converged, dtype=bool)
        if self.ik is not None:
            ok = ok & np.asarray(self.ik.converged, dtype=bool)
        return ok


def _theta0(robot: Robot, theta0, poses, ik_seed):
    if (theta0 is None) == (poses is None):
        raise CdsmInputError("`theta0`, `poses`: give exactly one of them")
    if theta0 is not None:
        t, _ = as_batch("theta0", theta0, robot.n)
        return t, None
    p, _ = as_batch("poses", poses, robot.kind.task)
    sol = robot.ik(p, seed=ik_seed)
    return np.ascontiguousarray(np.atleast_2d(sol.theta)), sol


def deviation(robot: Robot, theta0=None, *, poses=None, dL=None, dh=None, dholes=None,
              ik_seed=None, method: str = "auto", tol: float = 1e-12,
              max_iter: int = 100, statics: bool = True) -> Deviation:
    """Tip deviation caused by cable-length and hole-location errors (Fig. 3a–c).

    theta0: (N, n) initial joint angles, rad — or poses: (N, task) (planar
    [x, y, phi], m, m, rad), solved by the pose IK from ``ik_seed`` (default
    theta = 0). dL: (m_pos,) error on each position-controlled cable (planar:
    the n upper cables), m (L = L0 + dL). dh: (n,) the paper's error on disk
    i's holes (hole height of pair i), m — the kind's argument where
    :attr:`cdsm.kinds.Kind.hole_error_arg` is ``"dh"`` (planar). dholes: an
    error on every hole coordinate, m: planar (2n, n+1, 2, 2)
    (:attr:`Robot.holes`), spatial flat like :attr:`Robot.flat_holes`. Holes
    and lengths may be combined (at most one of dh, dholes). Solved in the
    core for either kind (``CoreRobot.deviation``). ``statics``: also judge
    every configuration's cables taut before and after
    (:attr:`Deviation.feasible`; None without) — on an arm of many position
    cables the statics cost more than the solves.
    """
    t0, ik = _theta0(robot, theta0, poses, ik_seed)
    kind = robot.kind
    if dh is not None and kind.hole_error_arg != "dh":
        raise CdsmInputError(f"`dh`: the per-disk hole-height error is planar; give `{kind.hole_error_arg}` for a "
                             f"{kind} arm")
    m = len(robot.position_cables)
    dl = np.zeros(m) if dL is None else as_vector("dL", dL, m)
    if dh is not None and dholes is not None:
        raise CdsmInputError("`dh`, `dholes`: give at most one of them")
    holes = None if dh is None and dholes is None else _moved_holes(robot, dh, dholes)
    res = robot.core.deviation(t0, dl, holes, method, as_finite("tol", tol), as_iterations("max_iter", max_iter),
                               robot.threads)
    # the arm whose statics judge the configuration after the error (the kind's choice)
    after = robot
    if holes is not None and kind.deviation_statics_on_moved_arm:
        after = robot.with_holes(holes, within_disks=False)
    sol = Solution.from_core(res.solution, robot.n, False, after)
    feasible = robot.feasible(t0) & after.feasible(sol.theta) if statics else None
    return Deviation(res.ds.reshape(-1, kind.task), t0, sol, ik, feasible)


def _moved_holes(robot: Robot, dh, dholes) -> np.ndarray:
    """Every hole after the error ``dh`` or ``dholes`` (see :func:`deviation`),
    flat in the core's layout of the arm's kind (planar (2n, n+1, 2, 2),
    spatial :attr:`Robot.flat_holes`), m."""
    if dh is not None:
        return np.ascontiguousarray(robot.hole_height_error(dh).reshape(-1))
    d = as_array("dholes", dholes)
    if robot.kind.pair_holes:
        if d.shape != robot.holes.shape:
            raise CdsmInputError(f"`dholes`: expected shape {robot.holes.shape}, got {d.shape}")
        if not np.isfinite(d).all():
            raise CdsmInputError("`dholes`: contains non-finite values")
        return np.ascontiguousarray((robot.holes + d).reshape(-1))
    flat, d = robot.flat_holes, d.reshape(-1)
    if d.shape != flat.shape or not np.isfinite(d).all():
        raise CdsmInputError(f"`dholes`: expected {flat.size} finite values (every hole's x, y, z, m)")
    return flat + d


def rotation_vectors(r: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) rad of rotation matrices (..., 3, 3): angle
    times unit axis, accurate for the small rotations of error studies (and
    any angle below pi)."""
    v = 0.5 * np.stack([r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0],
                        r[..., 1, 0] - r[..., 0, 1]], axis=-1)
    s = np.linalg.norm(v, axis=-1)
    c = 0.5 * (np.trace(r, axis1=-2, axis2=-1) - 1.0)
    angle = np.arctan2(s, c)
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(s > 1e-300, angle / s, 1.0)
    return v * k[..., None]

