"""Sampled configurations of an arm and what is judged on them: a Sobol
sequence (``scipy.stats.qmc.Sobol``), seeded random and Sobol samples of
the joint box, neighbour-based jump detection (nearest neighbours from
``scipy.spatial.KDTree`` up to 12 joints), and the singular measure of the position
Jacobian. SI units: m, rad.

A full joint grid is impossible past a few joints (13 values per joint and 8
joints are 8e8 configurations); a study of a spatial arm samples its joint
box instead, and judges jumps against each configuration's nearest
neighbours in joint space rather than along grid lines
(:func:`cdsm.accuracy.workspace.jump_points`).

**Sobol sequence.** SciPy's Sobol sequence, 32-bit: Gray-code order, the
primitive polynomials and initial direction numbers of S. Joe and F. Y.
Kuo, "Constructing Sobol sequences with better two-dimensional
projections", SIAM J. Sci. Comput. 30 (2008) 2635-2654 (their file
``new-joe-kuo-6.21201``; dimension 1 is the van der Corput sequence).
Unscrambled, point 0 is the origin. Scrambled: a random linear matrix
scramble and a random digital shift (SciPy's LMS + shift), seeded — it
keeps the stratification of every power-of-two prefix (each 1-D projection
of the first 2**m points has exactly one point in each interval
[k/2**m, (k+1)/2**m)).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..inputs import CdsmInputError, as_batch

__all__ = ["SOBOL_MAX_DIM", "TREE_MAX_JOINTS", "sobol", "sample_configurations", "sampling_limits",
           "nearest_neighbours", "SampledJumps", "jump_points", "singular_measure", "position_singular_values",
           "METHODS"]

#: Sampling methods of :func:`sample_configurations`.
METHODS = ("sobol", "random")

#: Bits of the Sobol integers (points are multiples of 2**-32).
_BITS = 32

#: Largest dimension of :func:`sobol`: the rows of SciPy's Joe–Kuo table
#: (``scipy.stats.qmc.Sobol.MAXDIM``, a test; SciPy is imported on first use:
#: ``scipy.stats`` takes 0.5-0.8 s to import, once per process).
SOBOL_MAX_DIM = 21201

#: Leaf size of the neighbour search tree: 32-64 points per leaf is about
#: twice as fast as SciPy's default 16 from 8 joints up (benches/bench_sampling.py).
_LEAF = 64

#: Most joints for which :func:`nearest_neighbours` searches a k-d tree. In
#: more dimensions a tree visits nearly every leaf of uniform samples and is
#: 1.2-1.6x slower than comparing every pair by matrix products (4000
#: configurations, 14-24 joints; benches/bench_sampling.py); up to 12 joints
#: it is 1.3-10x faster.
TREE_MAX_JOINTS = 12


def _sobol_engine(dim: int, scramble: bool, rng: np.random.Generator):
    """SciPy's 32-bit Sobol engine (``scipy.stats.qmc.Sobol``) drawing its
    scramble from ``rng``."""
    from scipy.stats import qmc

    try:
        return qmc.Sobol(dim, scramble=scramble, bits=_BITS, rng=rng)
    except TypeError:  # SciPy < 1.15 names the generator `seed`
        return qmc.Sobol(dim, scramble=scramble, bits=_BITS, seed=rng)


def sobol(count: int, dim: int, scramble: bool = False, seed: int = 0, skip: int = 0) -> np.ndarray:
    """The points ``skip .. skip + count - 1`` of the ``dim``-dimensional Sobol
    sequence (Joe–Kuo direction numbers, Gray-code order; SciPy's
    ``qmc.Sobol``, 32 bits), (count, dim) in [0, 1). ``scramble``: linear
    matrix scramble and digital shift from ``seed`` (see the module doc).
    Balance holds for power-of-two prefixes."""
    count, dim, skip = int(count), int(dim), int(skip)
    if not 1 <= dim <= SOBOL_MAX_DIM:
        raise CdsmInputError(f"`dim`: the Sobol sequence has 1..{SOBOL_MAX_DIM} dimensions, got {dim} "
                             "(use method='random' for more joints)")
    if count < 0 or skip < 0 or skip + count > 1 << _BITS:
        raise CdsmInputError(f"`count`, `skip`: need 0 <= skip and skip + count <= 2**32, got {count}, {skip}")
    engine = _sobol_engine(dim, scramble, np.random.default_rng([int(seed), 0x50B0]))
    if skip:
        engine.fast_forward(skip)
    with warnings.catch_warnings():
        # SciPy warns on any count that is not a power of two; the docstring says where balance holds
        warnings.filterwarnings("ignore", message="The balance properties of Sobol", category=UserWarning)
        return np.ascontiguousarray(engine.random(count), dtype=np.float64)


def sampling_limits(robot, margin: float = 1.0, limits=None) -> np.ndarray:
    """(n, 2) rad: the box configurations are sampled in — the joint limits
    (or ``limits`` (n, 2)) clipped to [-pi, pi] (a wider range repeats
    configurations), shrunk about its centre to ``margin`` (0 < margin <= 1)
    of its width."""
    lim = np.asarray(robot.joint_limits if limits is None else limits, dtype=np.float64)
    if lim.shape != (robot.n, 2) or not np.isfinite(lim).all() or (lim[:, 1] < lim[:, 0]).any():
        raise CdsmInputError(f"`limits`: expected ({robot.n}, 2) finite [lo, hi] rows with lo <= hi")
    m = float(margin)
    if not (np.isfinite(m) and 0.0 < m <= 1.0):
        raise CdsmInputError(f"`margin`: must be within (0, 1], got {margin}")
    lim = np.clip(lim, -np.pi, np.pi)
    c, h = lim.mean(axis=1), 0.5 * (lim[:, 1] - lim[:, 0]) * m
    return np.stack([c - h, c + h], axis=1)


def sample_configurations(robot, count: int, method: str = "sobol", seed: int = 0, margin: float = 1.0,
                          scramble: bool = True, limits=None) -> np.ndarray:
    """(count, n) joint angles, rad, in the robot's joint box
    (:func:`sampling_limits`: limits clipped to [-pi, pi], ``margin`` of the
    width about the centre; ``limits`` (n, 2) rad replaces the robot's).

    ``method``: ``"sobol"`` (scrambled with ``seed`` unless ``scramble`` is
    False — then point 0 is the box's lower corner; n <= :data:`SOBOL_MAX_DIM`
    = 21201) or ``"random"`` (uniform, seeded). Equal arguments give equal
    samples."""
    count = int(count)
    if count < 1:
        raise CdsmInputError(f"`count`: must be >= 1, got {count}")
    box = sampling_limits(robot, margin, limits)
    if method == "sobol":
        u = sobol(count, robot.n, scramble=scramble, seed=seed)
    elif method == "random":
        u = np.random.default_rng([int(seed), 0x5A4D]).random((count, robot.n))
    else:
        raise CdsmInputError(f"`method`: expected one of {', '.join(map(repr, METHODS))}, got {method!r}")
    return np.ascontiguousarray(box[:, 0] + u * (box[:, 1] - box[:, 0]))


# ---------------------------------------------------------------------------
# neighbours and jumps
# ---------------------------------------------------------------------------
def nearest_neighbours(theta, k: int = 6) -> np.ndarray:
    """(N, k) indices of each configuration's ``k`` nearest other
    configurations of ``theta`` (N, n) rad, Euclidean in joint space, nearest
    first. Exact: ``scipy.spatial.KDTree`` up to :data:`TREE_MAX_JOINTS`
    joints, beyond every pair compared (squared distances by one matrix
    product per block of 1024 rows; faster there). Equal distances: any one
    of the tied configurations; a configuration repeated in ``theta`` is its
    copy's nearest neighbour (distance 0), never its own."""
    t = np.asarray(theta, dtype=np.float64)
    if t.ndim != 2:
        raise CdsmInputError(f"`theta`: expected shape (N, n), got {t.shape}")
    if not np.isfinite(t).all():
        raise CdsmInputError("`theta`: every angle must be finite")
    n_pts = len(t)
    k = int(k)
    if not 1 <= k < n_pts:
        raise CdsmInputError(f"`k`: need 1 <= k < N = {n_pts}, got {k}")
    if t.shape[1] > TREE_MAX_JOINTS:
        return _neighbours_by_blocks(t, k)
    from scipy.spatial import KDTree

    _, idx = KDTree(t, leafsize=_LEAF).query(t, k + 1)
    # drop each configuration itself; where k + 1 copies tie at distance 0 it may be left out: drop the last
    own = idx == np.arange(n_pts)[:, None]
    drop = np.where(own.any(axis=1), own.argmax(axis=1), k)
    keep = np.ones(idx.shape, bool)
    keep[np.arange(n_pts), drop] = False
    return idx[keep].reshape(n_pts, k).astype(np.int64)


def _neighbours_by_blocks(t: np.ndarray, k: int, block: int = 1024) -> np.ndarray:
    """:func:`nearest_neighbours` of ``t`` (N, n) by every pair's squared
    distance, ``block`` rows at a time."""
    sq = (t * t).sum(axis=1)
    out = np.empty((len(t), k), dtype=np.int64)
    for s in range(0, len(t), block):
        rows = slice(s, min(s + block, len(t)))
        d = sq[rows, None] + sq[None, :] - 2.0 * t[rows] @ t.T
        d[np.arange(rows.stop - rows.start), np.arange(rows.start, rows.stop)] = np.inf
        part = np.argpartition(d, k - 1, axis=1)[:, :k]
        order = np.argsort(np.take_along_axis(d, part, axis=1), axis=1, kind="stable")
        out[rows] = np.take_along_axis(part, order, axis=1)
    return out


@dataclass(frozen=True)
class SampledJumps:
    """Jump points of a map over sampled configurations (:func:`jump_points`).

    neighbours: (N, k) each configuration's nearest neighbours. pairs: (E, 2)
    distinct neighbour pairs ``a < b``. change: (E,) |values[a] - values[b]|
    (m for deviations; NaN where either is not finite). slope: (E,) change
    over the pair's joint-space distance (m/rad). reference: (N,) the median
    slope over each configuration's k neighbour pairs (m/rad). edge_jump:
    (E,) bool, jump pairs. point: (N,) bool, configurations on a jump pair.
    scale: the 95th percentile of |values| (norms of the rows).
    """

    neighbours: np.ndarray
    pairs: np.ndarray
    change: np.ndarray
    slope: np.ndarray
    reference: np.ndarray
    edge_jump: np.ndarray
    point: np.ndarray
    scale: float

    @property
    def count(self) -> int:
        """Number of jump points."""
        return int(self.point.sum())


def jump_points(theta, values, k: int = 6, factor: float = 4.0, floor: float = 0.1,
                min_change: float = 5e-5, neighbours: Optional[np.ndarray] = None) -> SampledJumps:
    """Jump points of ``values`` (N,) or (N, d) — e.g. the position deviation
    dS[:, :3] (m), NaN where unsolved — over sampled configurations ``theta``
    (N, n) rad: the planar rules (:func:`cdsm.accuracy.workspace.jump_points`)
    with nearest neighbours in joint space instead of grid lines.

    Every configuration is paired with its ``k`` nearest neighbours
    (``neighbours`` (N, k): a precomputed :func:`nearest_neighbours`). A pair
    (a, b) jumps when its change |values[a] - values[b]| exceeds ``floor``
    times the 95th percentile of |values| and ``min_change`` (m; 0.05 mm:
    below what a laser tracker resolves), and its slope (change per rad of
    joint-space distance) exceeds ``factor`` times the median slope over the
    neighbour pairs of a and over those of b. Grid lines compare steps of
    one length and direction; neighbour pairs differ in both, hence slopes
    (a smooth map's change grows with the step) and both ends (a median over
    k = 6 pairs in a few dimensions can be small where most neighbours lie
    along a level set: the plain change against a's median flags about a
    tenth of the configurations of a smooth map of four joints)."""
    t = np.asarray(theta, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    v = v[:, None] if v.ndim == 1 else v
    if t.ndim != 2 or v.ndim != 2 or len(v) != len(t):
        raise CdsmInputError(f"`theta`, `values`: expected (N, n) and (N,) or (N, d), got {t.shape}, {v.shape}")
    nb = nearest_neighbours(t, k) if neighbours is None else np.asarray(neighbours, dtype=np.int64)
    if nb.ndim != 2 or nb.shape[0] != len(t):
        raise CdsmInputError(f"`neighbours`: expected ({len(t)}, k) indices, got shape {nb.shape}")
    size = len(t)
    ok = np.isfinite(v).all(axis=1)
    a = np.repeat(np.arange(size), nb.shape[1])
    b = nb.ravel()
    dist = np.maximum(np.linalg.norm(t[a] - t[b], axis=1), 1e-300)
    with np.errstate(invalid="ignore"):
        change = np.where(ok[a] & ok[b], np.linalg.norm(v[a] - v[b], axis=1), np.nan)
        slope = change / dist
    ref = np.full(size, np.nan)
    rows = np.isfinite(slope.reshape(nb.shape)).any(axis=1)
    ref[rows] = np.nanmedian(slope.reshape(nb.shape)[rows], axis=1)
    mag = np.linalg.norm(v, axis=1)
    scale = float(np.percentile(mag[ok], 95)) if ok.any() else 0.0
    with np.errstate(invalid="ignore"):
        jump = (np.isfinite(change) & (slope > factor * np.fmax(ref[a], ref[b])) & (change > floor * scale)
                & (change > min_change))
    key = np.minimum(a, b) * size + np.maximum(a, b)
    uniq, first, inv = np.unique(key, return_index=True, return_inverse=True)
    edge = np.zeros(len(uniq), bool)
    np.logical_or.at(edge, inv, jump)
    pairs = np.stack([uniq // size, uniq % size], axis=1).astype(np.int64)
    point = np.zeros(size, bool)
    point[pairs[edge, 0]] = True
    point[pairs[edge, 1]] = True
    return SampledJumps(nb, pairs, change[first], slope[first], ref, edge, point, scale)


# ---------------------------------------------------------------------------
# singular measure
# ---------------------------------------------------------------------------
def position_singular_values(robot, theta) -> np.ndarray:
    """(N, min(3, n)) singular values, descending (m/rad), of the position
    rows of the geometric Jacobian (spatial arms: rows x, y, z; planar arms:
    x, y of the pose Jacobian)."""
    t, _ = as_batch("theta", theta, robot.n)
    j = robot.fk_jacobian(t)
    return np.linalg.svd(j[:, :robot.kind.dim, :], compute_uv=False)


def singular_measure(robot, theta, rel: float = 1e-12, probes: int = 16) -> np.ndarray:
    """(N,) smallest over largest singular value of the position Jacobian
    (:func:`position_singular_values`) at ``theta`` (N, n) rad: 1 is
    isotropic, 0 a lost direction of the tip.

    Directions the arm can never move in (a planar-equivalent arm has no z)
    are left out: the structural rank ``r`` is the largest number of singular
    values above ``rel`` times the largest, over ``theta`` and ``probes``
    seeded random configurations of the joint box; the measure is
    ``s_r / s_1``. (Dropping small singular values per configuration would
    call an exactly singular configuration — a row of zeros, as at theta = 0
    of a planar arm — perfectly conditioned.)"""
    s = position_singular_values(robot, theta)
    extra = position_singular_values(robot, sample_configurations(robot, probes, "random", seed=1))
    both = np.concatenate([s, extra])
    rank = int(np.max((both > rel * np.maximum(both[:, :1], 1e-300)).sum(axis=1)))
    if rank == 0:
        return np.zeros(len(s))
    return s[:, rank - 1] / np.maximum(s[:, 0], 1e-300)
