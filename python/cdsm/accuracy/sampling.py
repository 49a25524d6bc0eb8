"""Sampled configurations of an arm and what is judged on them: a Sobol
sequence (NumPy, up to 32 dimensions), seeded random and Sobol samples of
the joint box, neighbour-based jump detection, and the singular measure of
the position Jacobian. SI units: m, rad.

A full joint grid is impossible past a few joints (13 values per joint and 8
joints are 8e8 configurations); a study of a spatial arm samples its joint
box instead, and judges jumps against each configuration's nearest
neighbours in joint space rather than along grid lines
(:func:`cdsm.accuracy.workspace.jump_points`).

**Sobol sequence.** Gray-code order, 32-bit direction numbers: dimension 1
is the van der Corput sequence, dimensions 2..32 use the primitive
polynomials and initial direction numbers of S. Joe and F. Y. Kuo,
"Constructing Sobol sequences with better two-dimensional projections",
SIAM J. Sci. Comput. 30 (2008) 2635-2654 (their file
``new-joe-kuo-6.21201``, rows d = 2..32). Unscrambled, point 0 is the
origin. Scrambled: a random linear matrix scramble (a lower-triangular
binary matrix with unit diagonal per dimension, applied to the direction
numbers) and a random digital shift, both seeded — it keeps the
stratification of every power-of-two prefix (each 1-D projection of the
first 2**m points has exactly one point in each interval [k/2**m, (k+1)/2**m)).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..inputs import CdsmInputError, as_batch

__all__ = ["SOBOL_MAX_DIM", "sobol", "sample_configurations", "sampling_limits", "nearest_neighbours",
           "SampledJumps", "jump_points", "singular_measure", "position_singular_values", "METHODS"]

#: Sampling methods of :func:`sample_configurations`.
METHODS = ("sobol", "random")

#: Bits of the Sobol integers (points are multiples of 2**-32).
_BITS = 32

#: Joe–Kuo ``new-joe-kuo-6.21201``, dimensions 2..32: (degree s, polynomial a, m_1..m_s).
_JOE_KUO = (
    (1, 0, (1,)),
    (2, 1, (1, 3)),
    (3, 1, (1, 3, 1)),
    (3, 2, (1, 1, 1)),
    (4, 1, (1, 1, 3, 3)),
    (4, 4, (1, 3, 5, 13)),
    (5, 2, (1, 1, 5, 5, 17)),
    (5, 4, (1, 1, 5, 5, 5)),
    (5, 7, (1, 1, 7, 11, 19)),
    (5, 11, (1, 1, 5, 1, 1)),
    (5, 13, (1, 1, 1, 3, 11)),
    (5, 14, (1, 3, 5, 5, 31)),
    (6, 1, (1, 3, 3, 9, 7, 49)),
    (6, 13, (1, 1, 1, 15, 21, 21)),
    (6, 16, (1, 3, 1, 13, 27, 49)),
    (6, 19, (1, 1, 1, 15, 7, 5)),
    (6, 22, (1, 3, 1, 15, 13, 25)),
    (6, 25, (1, 1, 5, 5, 19, 61)),
    (7, 1, (1, 3, 7, 11, 23, 15, 103)),
    (7, 4, (1, 3, 7, 13, 13, 15, 69)),
    (7, 7, (1, 1, 3, 13, 7, 35, 63)),
    (7, 8, (1, 3, 5, 9, 1, 25, 53)),
    (7, 14, (1, 3, 1, 13, 9, 35, 107)),
    (7, 19, (1, 3, 1, 5, 27, 61, 31)),
    (7, 21, (1, 1, 5, 11, 19, 41, 61)),
    (7, 28, (1, 3, 5, 3, 3, 13, 69)),
    (7, 31, (1, 1, 7, 13, 1, 19, 1)),
    (7, 32, (1, 3, 7, 5, 13, 19, 59)),
    (7, 37, (1, 1, 3, 9, 25, 29, 41)),
    (7, 41, (1, 3, 5, 13, 23, 1, 55)),
    (7, 42, (1, 3, 7, 3, 13, 59, 17)),
)

#: Largest dimension of :func:`sobol`.
SOBOL_MAX_DIM = len(_JOE_KUO) + 1


def _direction_numbers(dim: int) -> np.ndarray:
    """(dim, 32) direction numbers V_1..V_32 (scaled by 2**32) as uint64."""
    v = np.zeros((dim, _BITS), dtype=np.uint64)
    v[0] = [1 << (_BITS - 1 - i) for i in range(_BITS)]
    for j in range(1, dim):
        s, a, m = _JOE_KUO[j - 1]
        row = [0] * (_BITS + 1)  # 1-based
        for i in range(1, s + 1):
            row[i] = m[i - 1] << (_BITS - i)
        for i in range(s + 1, _BITS + 1):
            x = row[i - s] ^ (row[i - s] >> s)
            for k in range(1, s):
                if (a >> (s - 1 - k)) & 1:
                    x ^= row[i - k]
            row[i] = x
        v[j] = row[1:]
    return v


def _scramble(v: np.ndarray, rng: np.random.Generator) -> tuple:
    """Linear matrix scramble of the direction numbers ``v`` (dim, 32) and a
    digital shift (dim,): both uint64, from ``rng``."""
    dim = v.shape[0]
    weights = np.uint64(1) << np.arange(_BITS - 1, -1, -1, dtype=np.uint64)  # bit 0 = most significant
    bits = ((v[:, :, None] >> np.arange(_BITS - 1, -1, -1, dtype=np.uint64)) & np.uint64(1)).astype(np.int64)
    low = np.tril(rng.integers(0, 2, (dim, _BITS, _BITS)), -1) + np.eye(_BITS, dtype=np.int64)
    # new bit i of V_k = XOR over l <= i of L[i, l] * bit l of V_k
    new = np.einsum("dil,dkl->dki", low, bits) & 1
    scrambled = (new.astype(np.uint64) * weights).sum(axis=2, dtype=np.uint64)
    shift = rng.integers(0, 1 << _BITS, dim, dtype=np.uint64)
    return scrambled, shift


def sobol(count: int, dim: int, scramble: bool = False, seed: int = 0, skip: int = 0) -> np.ndarray:
    """The points ``skip .. skip + count - 1`` of the ``dim``-dimensional Sobol
    sequence (Joe–Kuo direction numbers, Gray-code order), (count, dim) in
    [0, 1). ``scramble``: linear matrix scramble and digital shift from
    ``seed`` (see the module doc). Balance holds for power-of-two prefixes."""
    count, dim, skip = int(count), int(dim), int(skip)
    if not 1 <= dim <= SOBOL_MAX_DIM:
        raise CdsmInputError(f"`dim`: the Sobol sequence has 1..{SOBOL_MAX_DIM} dimensions, got {dim} "
                             "(use method='random' for more joints)")
    if count < 0 or skip < 0 or skip + count > 1 << _BITS:
        raise CdsmInputError(f"`count`, `skip`: need 0 <= skip and skip + count <= 2**32, got {count}, {skip}")
    v = _direction_numbers(dim)
    shift = np.zeros(dim, dtype=np.uint64)
    if scramble:
        v, shift = _scramble(v, np.random.default_rng([int(seed), 0x50B0]))
    i = np.arange(skip, skip + count, dtype=np.uint64)
    gray = i ^ (i >> np.uint64(1))
    x = np.broadcast_to(shift, (count, dim)).copy()
    for k in range(_BITS):
        bit = ((gray >> np.uint64(k)) & np.uint64(1)).astype(bool)
        if not bit.any():
            break
        x[bit] ^= v[:, k]
    return x.astype(np.float64) / float(1 << _BITS)


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
    False — then point 0 is the box's lower corner; n <= 32) or ``"random"``
    (uniform, seeded). Equal arguments give equal samples."""
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
def nearest_neighbours(theta, k: int = 6, block: int = 1024) -> np.ndarray:
    """(N, k) indices of each configuration's ``k`` nearest other
    configurations of ``theta`` (N, n) rad, Euclidean in joint space, nearest
    first (brute force in blocks of ``block`` rows: fine up to a few
    thousand configurations)."""
    t = np.asarray(theta, dtype=np.float64)
    if t.ndim != 2:
        raise CdsmInputError(f"`theta`: expected shape (N, n), got {t.shape}")
    n_pts = len(t)
    k = int(k)
    if not 1 <= k < n_pts:
        raise CdsmInputError(f"`k`: need 1 <= k < N = {n_pts}, got {k}")
    sq = (t * t).sum(axis=1)
    out = np.empty((n_pts, k), dtype=np.int64)
    for s in range(0, n_pts, block):
        rows = slice(s, min(s + block, n_pts))
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
    rows = 3 if robot.kind == "spatial" else 2
    return np.linalg.svd(j[:, :rows, :], compute_uv=False)


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
