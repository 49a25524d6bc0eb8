"""Single error scenarios (the paper's Fig. 3): the tip deviation caused by a
cable-length error ``dL`` on the upper cables, a hole-location error (``dh``
per disk, or ``dholes`` per hole coordinate), or both, solved in the Rust
core. SI units: m, rad."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..inputs import CdsmInputError, as_batch, as_vector
from ..robot import Robot, Solution

__all__ = ["deviation", "Deviation", "PAPER_DL_TOL", "PAPER_DH_TOL"]

#: The paper's error magnitudes (its Monte-Carlo bounds and single-error
#: scenarios): 1 mm on an upper cable's length, 0.35 mm on a disk's hole height.
PAPER_DL_TOL = 1e-3
PAPER_DH_TOL = 0.35e-3


@dataclass(frozen=True)
class Deviation:
    """Result of :func:`deviation`.

    dS: (N, 3) tip deviation [dX (m), dY (m), dphi (rad)], NaN where the solve
    failed. theta0: (N, n) initial angles, rad. solution: the perturbed cable
    solves. ik: the pose IK that produced theta0, when poses were given.
    feasible: (N,) every upper cable taut (tension > 0 N, the robot's lower
    tensions, no external load) both before and after the error; False flags
    a configuration the hybrid-controlled arm cannot hold with taut cables.
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
    p, _ = as_batch("poses", poses, 3)
    sol = robot.ik(p, seed=ik_seed)
    return np.ascontiguousarray(np.atleast_2d(sol.theta)), sol


def deviation(robot: Robot, theta0=None, *, poses=None, dL=None, dh=None, dholes=None,
              ik_seed=None, method: str = "auto", tol: float = 1e-12,
              max_iter: int = 100) -> Deviation:
    """Tip deviation caused by cable-length and hole-location errors (Fig. 3a–c).

    theta0: (N, n) initial joint angles, rad — or poses: (N, 3) [x, y, phi]
    (m, m, rad), solved by the pose IK from ``ik_seed`` (default theta = 0).
    dL: (n,) error on each upper cable, m (L = L0 + dL). dh: (n,) the paper's
    error on disk i's holes (hole height of pair i), m. dholes: (2n, n+1, 2, 2)
    an error on every hole coordinate, m. Holes and lengths may be combined.
    """
    t0, ik = _theta0(robot, theta0, poses, ik_seed)
    dl = np.zeros(robot.n) if dL is None else as_vector("dL", dL, robot.n)
    if dh is not None and dholes is not None:
        raise CdsmInputError("`dh`, `dholes`: give at most one of them")
    holes = None
    if dh is not None:
        holes = robot.hole_height_error(dh)
    elif dholes is not None:
        d = np.asarray(dholes, dtype=np.float64)
        if d.shape != robot.holes.shape:
            raise CdsmInputError(f"`dholes`: expected shape {robot.holes.shape}, got {d.shape}")
        if not np.isfinite(d).all():
            raise CdsmInputError("`dholes`: contains non-finite values")
        holes = robot.holes + d
    if holes is not None:
        holes = np.ascontiguousarray(holes.reshape(-1))
    res = robot.core.deviation(t0, dl, holes, method, float(tol), int(max_iter), robot.threads)
    sol = Solution.from_core(res.solution, robot.n, False)
    feasible = robot.feasible(t0) & robot.feasible(sol.theta)
    return Deviation(res.ds.reshape(-1, 3), t0, sol, ik, feasible)
