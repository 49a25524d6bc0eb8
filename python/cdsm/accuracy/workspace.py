"""Workspace sweeps, the error-study protocols, singular states and jump
points. SI units: m, rad.

Protocols (each figure of a study report says which one it uses):

* ``joint`` — the error is applied at the grid angles themselves.
* ``attitude0`` — the paper's protocol as we read it: the tip position of each
  grid configuration, attitude set to 0, pose IK (seed :func:`paper_ik_seed`),
  then the error. Grid points whose (X, Y, 0) the IK cannot reach are counted
  and reported (``reachable`` False), never dropped. For planar arms without
  redundancy only (:mod:`cdsm.study` chooses).
* ``sampled`` — the error is applied at configurations sampled in the joint
  box (:func:`sample`): arms whose joint grid would be too coarse (spatial
  arms, planar arms of many joints). Jumps are judged between nearest
  neighbours in joint space (:func:`cdsm.accuracy.sampling.jump_points`).
* ``commanded`` — an elastic arm (its angles are the equilibrium of its
  commands): the error is applied at the equilibria of commands sampled in
  a box (:func:`cdsm.accuracy.plant_errors.sample_commands`); jumps between
  nearest neighbours in command space.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..inputs import CdsmInputError, as_batch, as_count, as_finite
from ..robot import Robot, Solution
from ..display import ShortRepr
from .sampling import nearest_neighbours, sample_configurations

__all__ = [
    "joint_grid", "default_step", "grid_neighbours", "paper_ik_seed", "Workspace", "sweep", "sample",
    "grid_values", "singular_values", "cable_fold_ratio", "jump_points", "Jumps", "REASONS", "MIN_LINE", "GRID_LIMIT",
]


#: The most configurations :func:`joint_grid` makes.
GRID_LIMIT = 50_000_000


def joint_grid(n: int, lo: float = np.radians(-30.0), hi: float = np.radians(30.0),
               step: float = np.radians(5.0)) -> np.ndarray:
    """Every combination of joint angles from ``lo`` to ``hi`` (rad) in ``step``
    (rad): (K**n, n), joint 1 slowest (the paper's nested loops). ±30° in 5° for
    n = 3 gives 2197 configurations."""
    n = as_count("n", n, 1)
    lo, hi, step = as_finite("lo", lo), as_finite("hi", hi), as_finite("step", step)
    if not (step > 0 and hi >= lo):
        raise CdsmInputError(f"`lo`, `hi`, `step`: need lo <= hi and step > 0, got {lo}, {hi}, {step}")
    span = (hi - lo) / step  # inf where hi - lo overflows a float
    if not span < GRID_LIMIT:
        raise CdsmInputError(f"`lo`, `hi`, `step`: (hi - lo) / step = {span:.3g} values per joint is too large "
                             f"a grid (at most {GRID_LIMIT} configurations)")
    k = int(np.floor(span + 1e-9)) + 1
    if k ** n > GRID_LIMIT:
        raise CdsmInputError(f"`step`: a grid of {k}**{n} configurations is too large (at most {GRID_LIMIT})")
    axis = lo + step * np.arange(k)
    mesh = np.meshgrid(*([axis] * n), indexing="ij")
    return np.stack(mesh, axis=-1).reshape(-1, n)


def grid_neighbours(k: int, n: int) -> np.ndarray:
    """Grid-neighbour pairs of a :func:`joint_grid` with ``k`` values per joint:
    (E, 4) int rows ``[a, b, prev, next]`` — points ``a`` and ``b`` one step
    apart in one joint, and the indices of the edges before ``a`` and after
    ``b`` along the same grid line (-1 at the line's ends)."""
    idx = np.arange(k ** n).reshape((k,) * n)
    rows, offset = [], 0
    for ax in range(n):
        a = np.take(idx, np.arange(k - 1), axis=ax)
        b = np.take(idx, np.arange(1, k), axis=ax)
        eid = offset + np.arange(a.size).reshape(a.shape)
        prev = np.full(a.shape, -1)
        nxt = np.full(a.shape, -1)
        if k > 2:
            sl = [slice(None)] * n
            sl_lo, sl_hi = list(sl), list(sl)
            sl_lo[ax], sl_hi[ax] = slice(0, k - 2), slice(1, k - 1)
            prev[tuple(sl_hi)] = eid[tuple(sl_lo)]
            nxt[tuple(sl_lo)] = eid[tuple(sl_hi)]
        rows.append(np.stack([a.ravel(), b.ravel(), prev.ravel(), nxt.ravel()], axis=1))
        offset += a.size
    return np.concatenate(rows)


def paper_ik_seed(n: int) -> np.ndarray:
    """Pose-IK seed that picks the paper's branch: theta = 0 with theta_2 = -1 mrad.

    For n = 3 at phi = 0 all nine Table 3 points lie on the theta_2 <= 0
    solution; a mirror-symmetric damped Newton from exactly theta = 0 picks
    theta_2 >= 0 for Y > 0 instead (see docs/model.md)."""
    s = np.zeros(n)
    if n >= 2:
        s[1] = -1e-3
    return s


@dataclass(frozen=True, repr=False)
class Workspace(ShortRepr):
    """A set of initial configurations for an error study.

    protocol: ``"joint"``, ``"attitude0"`` or ``"sampled"``. grid: (N, n)
    grid (or sampled) angles, rad. poses: (N, task) initial poses (planar
    [x, y, phi], m, m, rad; spatial [x, y, z, rx, ry, rz], m and rad).
    theta0: (N, n) initial angles (rad; for attitude0 the IK answer, NaN
    where unreachable). reachable: (N,) bool. ik: the IK solution
    (attitude0 only). neighbours: grid protocols (E, 4) grid-neighbour pairs
    with their adjacent edges (:func:`grid_neighbours`; empty for a plain
    list of configurations); ``sampled`` (N, k) each configuration's nearest
    neighbours in joint space. params: how the configurations were made
    (``sampled``: method, seed, k). commands: (N, m_c) m the commanded
    cables' extras the configurations settle at (the ``commanded`` protocol
    of an elastic arm, :func:`cdsm.accuracy.plant_errors.sample_commands`:
    its angles are the equilibrium of its commands), else None.
    path_dependent: (N,) bool, ``commanded`` only: the commands with two
    equilibria (:func:`cdsm.accuracy.plant_errors.path_dependent`), else None.
    """

    protocol: str
    grid: np.ndarray
    poses: np.ndarray
    theta0: np.ndarray
    reachable: np.ndarray
    neighbours: np.ndarray
    ik: Optional[Solution] = None
    params: Optional[dict] = None
    commands: Optional[np.ndarray] = None
    path_dependent: Optional[np.ndarray] = None

    @property
    def n_unreachable(self) -> int:
        return int((~self.reachable).sum())

    def describe_grid(self) -> str:
        """'±A° in S° steps' for a symmetric joint grid, else 'N configurations'."""
        if self.protocol in ("joint", "attitude0"):
            v = np.unique(np.round(np.degrees(self.grid), 9))
            if len(v) > 1 and np.isclose(v[0], -v[-1]):
                return f"±{v[-1]:g}° in {np.diff(v).min():g}° steps"
        return f"{len(self.grid)} configurations"


#: Grid values per joint below which jump points are not detected.
MIN_LINE = 5


def default_step(n: int, max_points: int = 20_000) -> float:
    """The paper's 5° step (rad) when the ±30° grid has at most ``max_points``
    configurations (n <= 3), else the smallest step of the form 60°/(k-1)
    that keeps it under that size (n = 4: 6°, n = 8: 20°)."""
    k = 13
    while k > 3 and k ** n > max_points:
        k -= 1
    return np.radians(60.0 / (k - 1))


def grid_values(n: int, max_points: int = 20_000) -> int:
    """Values per joint of the default grid of an ``n``-joint arm (the
    ±30° grid of :func:`default_step`)."""
    return int(round(60.0 / np.degrees(default_step(n, max_points)))) + 1


def sample(robot: Robot, configurations: int = 1000, method: str = "sobol", seed: int = 0, k: int = 6,
           theta=None) -> Workspace:
    """The ``sampled`` protocol: ``configurations`` joint angles sampled in
    the robot's joint box (:func:`cdsm.accuracy.sampling.sample_configurations`:
    ``method`` ``"sobol"``, scrambled with ``seed``, or ``"random"``), or the
    given ``theta`` (N, n) rad, with each one's ``k`` nearest neighbours in
    joint space (for jump points). Either kind."""
    given = theta is not None
    if given:
        t = np.ascontiguousarray(np.asarray(theta, dtype=np.float64))
        if t.ndim != 2 or t.shape[1] != robot.n or not np.isfinite(t).all():
            raise CdsmInputError(f"`theta`: expected finite (N, {robot.n}) joint angles, got shape {t.shape}")
    else:
        t = sample_configurations(robot, configurations, method=method, seed=seed)
    if len(t) <= int(k):
        raise CdsmInputError(f"`configurations`: need more than k = {k} configurations, got {len(t)}")
    nb = nearest_neighbours(t, k)
    return Workspace("sampled", t, robot.fk(t), t.copy(), np.ones(len(t), bool), nb,
                     params=dict(method="given" if given else method, seed=int(seed), k=int(k)))


def sweep(robot: Robot, protocol: str = "attitude0", grid=None, ik_seed=None,
          neighbours=None) -> Workspace:
    """Initial configurations of an error study over ``grid`` (N, n) rad
    (default: ±30° in 5° steps — coarser for n > 3, see :func:`default_step` —
    with its neighbour pairs)."""
    if grid is None:
        grid = joint_grid(robot.n, step=default_step(robot.n))
        k = round(len(grid) ** (1.0 / robot.n))
        # a jump is judged against the adjacent changes along a grid line: with
        # fewer than MIN_LINE values per joint there is no trend to compare to
        neighbours = grid_neighbours(k, robot.n) if k >= MIN_LINE else None
    g, _ = as_batch("grid", grid, robot.n)
    nb = np.zeros((0, 4), dtype=np.int64) if neighbours is None else np.asarray(neighbours, dtype=np.int64)
    if protocol == "joint":
        return Workspace("joint", g, robot.fk(g), g.copy(), np.ones(len(g), bool), nb)
    if protocol != "attitude0":
        raise CdsmInputError(f"`protocol`: expected 'joint' or 'attitude0', got {protocol!r}")
    poses = robot.fk(g)
    poses[:, 2] = 0.0
    seed = paper_ik_seed(robot.n) if ik_seed is None else ik_seed
    sol = robot.ik(poses, seed=seed)
    ok = np.asarray(sol.converged, bool)
    theta0 = np.where(ok[:, None], sol.theta, np.nan)
    return Workspace("attitude0", g, poses, theta0, ok, nb, sol)


def singular_values(robot: Robot, theta, attitude_scale: Optional[float] = None) -> np.ndarray:
    """Singular values (N, 3), descending, of the pose Jacobian with the
    attitude row scaled by ``attitude_scale`` (m/rad; default the straight
    length) so that all rows are in m. A zero means a lost direction (Fig. 12:
    all joints zero loses X)."""
    t, _ = as_batch("theta", theta, robot.n)
    j = robot.fk_jacobian(t)
    scale = float(np.sum(robot.link_before + robot.link_after + robot.thickness)) \
        if attitude_scale is None else float(attitude_scale)
    j = j.copy()
    j[:, 2, :] *= scale
    return np.linalg.svd(j, compute_uv=False)


@dataclass(frozen=True, repr=False)
class Jumps(ShortRepr):
    """Jump points of one deviation map.

    change: (E,) |Δ d(X, Y)| across each neighbour pair, m (NaN if either end
    failed). edge_jump: (E,) bool, pairs where the deviation changes abruptly:
    by more than ``factor`` times the change across the adjacent pairs of the
    same grid line (the paper: "the variation tendency changed … the deviation
    suddenly changed greatly"), and by more than ``floor`` of the map's 95th
    percentile and by more than ``min_change`` (m). point: (N,) bool,
    configurations on a jump pair. reason: (E,) str per jump pair — ``branch
    switch`` (the initial IK answer jumps to another solution), ``cable fold``
    (an upper cable is near its longest or shortest: its own joint barely
    changes its length, the cable Jacobian nearly loses rank), ``near-singular``
    (the pose Jacobian nearly loses rank at an end), ``reach boundary`` (an end
    has an unreachable grid neighbour), or ``steep``.
    """

    change: np.ndarray
    edge_jump: np.ndarray
    point: np.ndarray
    reason: np.ndarray

    def counts(self) -> dict:
        vals, cnt = np.unique(self.reason[self.edge_jump], return_counts=True)
        return {str(v): int(c) for v, c in zip(vals, cnt)}


REASONS = ("branch switch", "cable fold", "near-singular", "reach boundary", "steep")


def cable_fold_ratio(robot: Robot, theta) -> np.ndarray:
    """(N,) smallest |dL_i/dtheta_i| of the upper cables relative to its value
    at the straight pose: near 0 the cable is at a fold (its longest or
    shortest length), where the cable solve is ill-conditioned."""
    t, _ = as_batch("theta", theta, robot.n)
    d = np.abs(np.diagonal(robot.cable_jacobian(t)[:, 0::2, :], axis1=1, axis2=2))
    d0 = np.abs(np.diagonal(robot.cable_jacobian(np.zeros(robot.n))[0::2, :]))
    return (d / np.maximum(d0, 1e-300)).min(axis=1)


def jump_points(robot: Robot, ws: Workspace, dS: np.ndarray, factor: float = 4.0,
                floor: float = 0.1, min_change: float = 5e-5, singular_ratio: float = 0.02,
                fold_ratio: float = 0.1) -> Jumps:
    """Jump points of the deviation map ``dS`` (N, 3) (NaN where failed) over
    the grid workspace ``ws`` (see :class:`Jumps`). ``min_change`` (m, default
    0.05 mm) keeps changes below what a laser tracker resolves from counting."""
    ds = np.asarray(dS, dtype=np.float64)
    nb = ws.neighbours
    e = len(nb)
    if e == 0:
        z = np.zeros(0)
        return Jumps(z, z.astype(bool), np.zeros(len(ds), bool), z.astype(str))
    a, b, prev, nxt = nb[:, 0], nb[:, 1], nb[:, 2], nb[:, 3]
    ok = np.isfinite(ds[:, :2]).all(axis=1)
    both = ok[a] & ok[b]
    change = np.full(e, np.nan)
    change[both] = np.linalg.norm(ds[a[both], :2] - ds[b[both], :2], axis=1)
    ext = np.append(change, np.nan)  # index -1 -> NaN
    local = np.fmax(ext[prev], ext[nxt])  # the larger adjacent change along the line
    pos = np.hypot(ds[:, 0], ds[:, 1])
    scale = float(np.nanpercentile(pos[ok], 95)) if ok.any() else 0.0
    with np.errstate(invalid="ignore"):
        edge = (both & np.isfinite(local) & (change > factor * local) & (change > floor * scale)
                & (change > min_change))
    theta = np.where(np.isfinite(ws.theta0), ws.theta0, 0.0)
    sv = singular_values(robot, theta)
    near_sing = sv[:, -1] / np.maximum(sv[:, 0], 1e-300) < singular_ratio
    fold = cable_fold_ratio(robot, theta) < fold_ratio
    dtheta = np.abs(theta[a] - theta[b]).max(axis=1)
    dgrid = np.abs(ws.grid[a] - ws.grid[b]).max(axis=1)
    switch = dtheta > 3.0 * dgrid
    unreach_nb = np.zeros(len(ds), bool)
    cut = ws.reachable[a] != ws.reachable[b]
    unreach_nb[a[cut]] = True
    unreach_nb[b[cut]] = True
    reason = np.full(e, "", dtype=object)
    reason[edge] = "steep"
    reason[edge & (unreach_nb[a] | unreach_nb[b])] = "reach boundary"
    reason[edge & (near_sing[a] | near_sing[b])] = "near-singular"
    reason[edge & (fold[a] | fold[b])] = "cable fold"
    reason[edge & switch] = "branch switch"
    point = np.zeros(len(ds), bool)
    point[a[edge]] = True
    point[b[edge]] = True
    return Jumps(change, edge, point, reason.astype(str))
