"""The paper's error studies (Fig. 3) over the Rust core. SI units: m, rad.

* :func:`deviation` — one scenario: cable-length error ``dL`` on the upper
  cables, hole-location error (``dh`` per disk, or ``dholes`` per hole), or both.
* :func:`monte_carlo` — random composite errors (Fig. 7), streamed in chunks with
  bounded memory and reduced to per-configuration statistics.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from . import _cdsm
from .robot import CdsmInputError, Robot, Solution, _batch, _vector

__all__ = ["deviation", "Deviation", "monte_carlo", "monte_carlo_chunk", "chunk_sizes",
           "MonteCarlo", "Progress"]


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
        t, _ = _batch("theta0", theta0, robot.n)
        return t, None
    p, _ = _batch("poses", poses, 3)
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
    dl = np.zeros(robot.n) if dL is None else _vector("dL", dL, robot.n)
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
    ds, parts = robot._core.deviation(t0, dl, holes, method, float(tol), int(max_iter), robot.threads)
    sol = Solution._from_core(parts, robot.n, False)
    feasible = robot.feasible(t0) & robot.feasible(sol.theta)
    return Deviation(ds.reshape(-1, 3), t0, sol, ik, feasible)


class Progress:
    """A plain progress line on stderr (shown when ``enabled``)."""

    def __init__(self, total: int, label: str, enabled: bool = True):
        self.total, self.label, self.enabled = total, label, enabled
        self.done, self.t0 = 0, time.perf_counter()

    def update(self, k: int) -> None:
        self.done += k
        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        frac = self.done / max(self.total, 1)
        eta = el / frac - el if frac > 0 else float("nan")
        bar = "#" * int(30 * frac)
        sys.stderr.write(f"\r{self.label} [{bar:<30}] {self.done}/{self.total} "
                         f"{el:6.1f}s elapsed, {eta:6.1f}s left")
        if self.done >= self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()


QUANTITY_NAMES = ("dX", "dY", "dphi", "dXY")


@dataclass
class MonteCarlo:
    """Per-configuration statistics of a Monte-Carlo error study.

    Columns of the (N, 4) arrays: dX (m), dY (m), dphi (rad), |d(X, Y)| (m).
    ``hist`` (N, bins) counts |d(X, Y)| in log-spaced bins (:attr:`hist_edges`).
    ``feasible0`` (N,): every upper cable taut at the initial configuration.
    ``slack`` (N,): converged samples whose configuration needs a slack upper
    cable (only with ``check_slack``, else None).
    """

    theta0: np.ndarray
    count: np.ndarray
    failed: np.ndarray
    sum: np.ndarray
    sum_sq: np.ndarray
    min: np.ndarray
    max: np.ndarray
    hist: np.ndarray
    params: dict = field(default_factory=dict)
    feasible0: Optional[np.ndarray] = None
    slack: Optional[np.ndarray] = None

    @property
    def mean(self) -> np.ndarray:
        """(N, 4) mean over converged samples."""
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.sum / self.count[:, None]

    @property
    def std(self) -> np.ndarray:
        """(N, 4) standard deviation over converged samples."""
        with np.errstate(invalid="ignore", divide="ignore"):
            m = self.mean
            return np.sqrt(np.maximum(self.sum_sq / self.count[:, None] - m * m, 0.0))

    @property
    def max_abs(self) -> np.ndarray:
        """(N, 4) largest absolute value."""
        return np.maximum(np.abs(self.min), np.abs(self.max))

    @staticmethod
    def hist_edges() -> np.ndarray:
        """Edges (m) of the regular bins; bin 0 is below the first, the last above the last."""
        return _cdsm.hist_edges()

    def percentile(self, p: float) -> np.ndarray:
        """(N,) p-th percentile (0–100) of |d(X, Y)|, m, to the bin resolution
        (upper bin edge: conservative, at most 3.9 % high)."""
        if not 0.0 <= p <= 100.0:
            raise CdsmInputError(f"`p`: must be within [0, 100], got {p}")
        edges = self.hist_edges()
        upper = np.append(edges, np.inf)
        cum = np.cumsum(self.hist, axis=1)
        need = np.ceil(p / 100.0 * self.count).astype(np.int64)
        idx = np.argmax(cum >= np.maximum(need, 1)[:, None], axis=1)
        out = upper[np.minimum(idx, len(upper) - 1)]
        return np.where(self.count > 0, out, np.nan)

    def merge(self, other: "MonteCarlo") -> None:
        """Adds the samples of ``other`` (same configurations) to this one."""
        self.count += other.count
        self.failed += other.failed
        self.sum += other.sum
        self.sum_sq += other.sum_sq
        np.minimum(self.min, other.min, out=self.min)
        np.maximum(self.max, other.max, out=self.max)
        self.hist += other.hist
        if self.slack is not None and other.slack is not None:
            self.slack += other.slack
        else:
            self.slack = None


def sample_errors(n: int, samples: int, seed: int, chunk_index: int, dl_tol, dh_tol):
    """Uniform errors of one chunk, from the stream (seed, chunk_index):
    dl (samples, n) within ±dl_tol, dh (samples, n) within ±dh_tol, m."""
    rng = np.random.default_rng([int(seed), int(chunk_index)])
    dl = rng.uniform(-1.0, 1.0, (samples, n)) * dl_tol
    dh = rng.uniform(-1.0, 1.0, (samples, n)) * dh_tol
    return np.ascontiguousarray(dl), np.ascontiguousarray(dh)


def _tolerance(name: str, value, n: int) -> np.ndarray:
    arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (n,)).copy()
    if not np.isfinite(arr).all() or (arr < 0).any():
        raise CdsmInputError(f"`{name}`: tolerances must be finite and >= 0 (m), got {value}")
    return arr


def monte_carlo(robot: Robot, theta0, samples: int = 1000, seed: int = 0, dl_tol=1e-3,
                dh_tol=0.35e-3, chunk: int = 100, progress: bool = True,
                method: str = "auto", check_slack: bool = False) -> MonteCarlo:
    """Random composite errors (the paper's Fig. 7): every sample draws a
    uniform error within ±dl_tol on each upper cable and ±dh_tol on each disk's
    hole height (m, scalars or (n,)); every configuration of theta0 (N, n) is
    solved for every sample in the Rust core. Chunks of ``chunk`` samples keep
    memory bounded; chunk c draws from the stream (seed, c). With
    ``check_slack`` every converged sample is also checked for a slack upper
    cable (statics; about twice the run time): ``MonteCarlo.slack``.
    """
    t0, _ = _batch("theta0", theta0, robot.n)
    if int(samples) < 1 or int(chunk) < 1:
        raise CdsmInputError(f"`samples`, `chunk`: must be >= 1, got {samples}, {chunk}")
    dlt, dht = _tolerance("dl_tol", dl_tol, robot.n), _tolerance("dh_tol", dh_tol, robot.n)
    total, out = int(samples), None
    bar = Progress(total, "monte carlo", progress)
    for c, m in enumerate(chunk_sizes(total, chunk)):
        part = monte_carlo_chunk(robot, t0, seed, c, m, dlt, dht, method, check_slack=check_slack)
        if out is None:
            out = part
        else:
            out.merge(part)
        bar.update(m)
    out.feasible0 = robot.feasible(t0)
    out.params = dict(samples=total, seed=int(seed), chunk=int(chunk), dl_tol_m=dlt.tolist(),
                      dh_tol_m=dht.tolist(), method=method, check_slack=bool(check_slack))
    return out


def chunk_sizes(samples: int, chunk: int):
    """Sample counts of the chunks of a study, lazily (an iterator): chunk c
    holds samples [c * chunk, min((c + 1) * chunk, samples)) and draws from the
    stream (seed, c)."""
    total, chunk = int(samples), int(chunk)
    return (min(chunk, total - start) for start in range(0, total, chunk))


def monte_carlo_chunk(robot: Robot, theta0: np.ndarray, seed: int, chunk_index: int, size: int,
                      dl_tol: np.ndarray, dh_tol: np.ndarray, method: str = "auto",
                      threads: Optional[int] = None, check_slack: bool = False) -> MonteCarlo:
    """One chunk of :func:`monte_carlo`: ``size`` samples from the stream
    (seed, chunk_index), one Rust call over every configuration of ``theta0``
    (N, n) rad (validated, C-contiguous). dl_tol, dh_tol: (n,) m. ``threads``
    (default ``robot.threads``) only splits the configurations: the result does
    not depend on it. This is the unit of work of local and cluster runs."""
    dl, dh = sample_errors(robot.n, size, seed, chunk_index, dl_tol, dh_tol)
    th = robot.threads if threads is None else int(threads)
    raw = robot._core.monte_carlo(theta0, dl, dh, None, method, 1e-12, 100, bool(check_slack), th)
    out = _stats(theta0, raw)
    if check_slack:
        out.slack = raw["slack"].astype(np.int64)
    return out


def _stats(theta0: np.ndarray, raw: dict) -> MonteCarlo:
    q = _cdsm.QUANTITIES
    return MonteCarlo(theta0=theta0, count=raw["count"].astype(np.int64),
                      failed=raw["failed"].astype(np.int64),
                      sum=raw["sum"].reshape(-1, q), sum_sq=raw["sum_sq"].reshape(-1, q),
                      min=raw["min"].reshape(-1, q), max=raw["max"].reshape(-1, q),
                      hist=raw["hist"].reshape(-1, _cdsm.HIST_BINS).astype(np.int64))
