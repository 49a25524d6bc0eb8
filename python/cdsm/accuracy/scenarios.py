"""Single error scenarios (the paper's Fig. 3): the tip deviation caused by a
cable-length error ``dL`` on the upper cables, a hole-location error (``dh``
per disk, or ``dholes`` per hole coordinate), or both, solved in the Rust
core; for spatial arms on the position-controlled cables and any hole
coordinate (x, y, z). SI units: m, rad."""

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

    theta0: (N, n) initial joint angles, rad — or poses: (N, 3) [x, y, phi]
    (m, m, rad), solved by the pose IK from ``ik_seed`` (default theta = 0).
    dL: (n,) error on each upper cable, m (L = L0 + dL). dh: (n,) the paper's
    error on disk i's holes (hole height of pair i), m. dholes: (2n, n+1, 2, 2)
    an error on every hole coordinate, m. Holes and lengths may be combined.
    ``statics``: also judge every configuration's cables taut before and
    after (:attr:`Deviation.feasible`; None without) — on an arm of many
    position cables the statics cost more than the solves.
    """
    t0, ik = _theta0(robot, theta0, poses, ik_seed)
    if robot.kind == "spatial":
        if dh is not None:
            raise CdsmInputError("`dh`: the per-disk hole-height error is planar; give `dholes` for a spatial arm")
        return _spatial_deviation(robot, t0, ik, dL, dholes, tol, max_iter, statics)
    dl = np.zeros(robot.n) if dL is None else as_vector("dL", dL, robot.n)
    if dh is not None and dholes is not None:
        raise CdsmInputError("`dh`, `dholes`: give at most one of them")
    holes = None
    if dh is not None:
        holes = robot.hole_height_error(dh)
    elif dholes is not None:
        d = as_array("dholes", dholes)
        if d.shape != robot.holes.shape:
            raise CdsmInputError(f"`dholes`: expected shape {robot.holes.shape}, got {d.shape}")
        if not np.isfinite(d).all():
            raise CdsmInputError("`dholes`: contains non-finite values")
        holes = robot.holes + d
    if holes is not None:
        holes = np.ascontiguousarray(holes.reshape(-1))
    res = robot.core.deviation(t0, dl, holes, method, as_finite("tol", tol), as_iterations("max_iter", max_iter),
                               robot.threads)
    sol = Solution.from_core(res.solution, robot.n, False)
    feasible = robot.feasible(t0) & robot.feasible(sol.theta) if statics else None
    return Deviation(res.ds.reshape(-1, 3), t0, sol, ik, feasible)


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


def _spatial_deviation(robot, t0, ik, dL, dholes, tol, max_iter, statics=True) -> Deviation:
    m = len(robot.position_cables)
    dl = np.zeros(m) if dL is None else as_vector("dL", dL, m)
    moved = robot
    if dholes is not None:
        flat = robot.flat_holes
        d = as_array("dholes", dholes).reshape(-1)
        if d.shape != flat.shape or not np.isfinite(d).all():
            raise CdsmInputError(f"`dholes`: expected {flat.size} finite values (every hole's x, y, z, m)")
        moved = robot.with_holes(flat + d, within_disks=False)
    sol = moved.solve_cables(robot.position_lengths(t0) + dl, seed=t0, tol=tol, max_iter=max_iter)
    f0, f1 = robot.fk_matrix(t0), moved.fk_matrix(sol.theta)
    ds = np.concatenate([f1[:, :3, 3] - f0[:, :3, 3],
                         np.einsum("nij,nj->ni", f0[:, :3, :3],
                                   rotation_vectors(np.einsum("nji,njk->nik", f0[:, :3, :3], f1[:, :3, :3])))],
                        axis=1)
    ds[~np.asarray(sol.converged)] = np.nan
    feasible = robot.feasible(t0) & moved.feasible(sol.theta) if statics else None
    return Deviation(ds, t0, sol, ik, feasible)
