"""Monte-Carlo error studies (the paper's Fig. 7) in the Rust core: random
composite errors on the upper-cable lengths and hole heights (spatial arms:
on the position-controlled cables and every hole coordinate), streamed in
chunks with bounded memory and reduced to per-configuration statistics, and
those statistics as arrays (``.npz``). SI units: m, rad.

Cluster runs (Dask) split the same chunks over workers:
:mod:`cdsm.accuracy.distributed`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Dict, Optional, Sequence, Tuple

import numpy as np

from .. import _cdsm, plant
from ..files import check_path, json_safe, read_npz, write_npz
from ..inputs import CdsmInputError, as_batch, as_count, as_finite, as_tolerances
from ..kinds import KINDS, PLANAR, SPATIAL
from ..progress import Progress
from ..robot import Robot
from .scenarios import PAPER_DH_TOL, PAPER_DL_TOL
from ..display import ShortRepr

__all__ = ["QUANTILE_BOUND", "hist_quantile", "MonteCarlo", "monte_carlo", "monte_carlo_chunk", "chunk_sizes",
           "sample_errors",
           "QUANTITY_NAMES", "QUANTITY_UNITS", "SPATIAL_QUANTITY_NAMES", "SPATIAL_QUANTITY_UNITS",
           "DEFAULT_PERCENTILES", "percentile_key", "percentile_text", "error_widths",
           "hole_error_sizes", "plate_hole_twins",
           "summary", "save_npz", "load_npz"]

DEFAULT_PERCENTILES = (50.0, 95.0, 99.0)
#: The quantities of a planar arm's study: dX, dY (m), dphi (rad), |d(X, Y)| (m) (the planar kind's).
QUANTITY_NAMES = PLANAR.quantities
QUANTITY_UNITS = PLANAR.quantity_units
#: The quantities of a spatial arm's study: dX, dY, dZ, |d(X, Y, Z)| (m), rotation angle (rad) (the spatial kind's).
SPATIAL_QUANTITY_NAMES = SPATIAL.quantities
SPATIAL_QUANTITY_UNITS = SPATIAL.quantity_units
#: The units of a study's quantities, by the quantities' names (each kind's).
_UNITS = {k.quantities: k.quantity_units for k in KINDS.values()}


@dataclass(repr=False)
class MonteCarlo(ShortRepr):
    """Per-configuration statistics of a Monte-Carlo error study.

    Columns of the (N, Q) arrays (``quantities``): planar dX (m), dY (m),
    dphi (rad), |d(X, Y)| (m); spatial dX, dY, dZ, |d(X, Y, Z)| (m) and the
    rotation angle of the end frame (rad). ``hist`` (N, W) counts the
    position-error norm in the log-spaced bins ``hist_lo .. hist_lo + W`` of
    the histogram (:attr:`hist_edges`; every bin outside that window is
    empty): the window a study's errors reach, a few hundred of the
    ``HIST_BINS`` bins (:meth:`dense_hist` gives all of them); uint32
    counts from one chunk, int64 once chunks are merged.
    ``feasible0`` (N,): every upper cable taut at the initial configuration.
    ``slack`` (N,): converged samples whose configuration needs a slack
    position cable — no taut set of position tensions holds it under the
    robot's gravity and force cables (only with ``check_slack``, else None).
    """

    theta0: np.ndarray
    count: np.ndarray
    failed: np.ndarray
    sum: np.ndarray
    sum_sq: np.ndarray
    min: np.ndarray
    max: np.ndarray
    hist: np.ndarray
    hist_lo: int = 0
    params: dict = field(default_factory=dict)
    feasible0: Optional[np.ndarray] = None
    slack: Optional[np.ndarray] = None
    quantities: Tuple[str, ...] = QUANTITY_NAMES

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
        """(N,) p-th percentile (0–100) of the position-error norm (|d(X, Y)|;
        spatial |d(X, Y, Z)|), m, over each configuration's converged samples:
        the sample quantile (the smallest sample with at least p % of them at
        or below it) to within :data:`QUANTILE_BOUND` (0.498 %) — the
        geometric middle of its histogram bin. Below 1 nm or above 10 m (the
        histogram's ends) the bound does not hold: the end is returned. NaN
        for a configuration without samples."""
        return hist_quantile(self.hist, p, lo=self.hist_lo)

    def dense_hist(self) -> np.ndarray:
        """(N, HIST_BINS) counts of every bin of the histogram."""
        out = np.zeros((len(self.count), _cdsm.HIST_BINS), np.int64)
        out[:, self.hist_lo:self.hist_lo + self.hist.shape[1]] = self.hist
        return out

    def pooled_hist(self, rows=None) -> np.ndarray:
        """(HIST_BINS,) counts of every bin summed over the configurations
        ``rows`` (an index or mask of the N; default all)."""
        sel = slice(None) if rows is None else rows
        out = np.zeros(_cdsm.HIST_BINS, np.int64)
        out[self.hist_lo:self.hist_lo + self.hist.shape[1]] = self.hist[sel].sum(axis=0)
        return out

    def merge(self, other: "MonteCarlo") -> None:
        """Adds the samples of ``other`` (same configurations) to this one."""
        self.count += other.count
        self.failed += other.failed
        self.sum += other.sum
        self.sum_sq += other.sum_sq
        np.minimum(self.min, other.min, out=self.min)
        np.maximum(self.max, other.max, out=self.max)
        # the union of the two windows, counted in int64
        windows = [(h.hist_lo, h.hist_lo + h.hist.shape[1]) for h in (self, other) if h.hist.shape[1]]
        lo, hi = (min(w[0] for w in windows), max(w[1] for w in windows)) if windows else (0, 0)
        if (lo, hi) != (self.hist_lo, self.hist_lo + self.hist.shape[1]) or self.hist.dtype != np.int64:
            wide = np.zeros((len(self.count), hi - lo), np.int64)
            if self.hist.shape[1]:
                wide[:, self.hist_lo - lo:self.hist_lo - lo + self.hist.shape[1]] = self.hist
            self.hist, self.hist_lo = wide, lo
        if other.hist.shape[1]:
            self.hist[:, other.hist_lo - lo:other.hist_lo - lo + other.hist.shape[1]] += other.hist
        if self.slack is not None and other.slack is not None:
            self.slack += other.slack
        else:
            self.slack = None


def sample_errors(n: int, samples: int, seed: int, chunk_index: int, dl_tol, dh_tol):
    """Uniform errors of one chunk, from the stream (seed, chunk_index):
    dl (samples, k) within ±dl_tol, dh (samples, h) within ±dh_tol, m — ``k``,
    ``h`` the lengths of the tolerance arrays (scalars: ``n``)."""
    rng = np.random.default_rng([int(seed), int(chunk_index)])
    wl, wh = (np.size(t) if np.ndim(t) else n for t in (dl_tol, dh_tol))
    dl = rng.uniform(-1.0, 1.0, (samples, wl)) * dl_tol
    dh = rng.uniform(-1.0, 1.0, (samples, wh)) * dh_tol
    return np.ascontiguousarray(dl), np.ascontiguousarray(dh)


def monte_carlo(robot: Robot, theta0, samples: int = 1000, seed: int = 0, dl_tol=PAPER_DL_TOL,
                dh_tol=PAPER_DH_TOL, chunk: int = 100, progress: bool = True,
                method: str = "auto", check_slack: bool = False, label: str = "monte carlo") -> MonteCarlo:
    """Random composite errors (the paper's Fig. 7): every sample draws a
    uniform error within ±dl_tol on each upper cable and ±dh_tol on each disk's
    hole height (m, scalars or (n,)); every configuration of theta0 (N, n) is
    solved for every sample in the Rust core. Chunks of ``chunk`` samples keep
    memory bounded; chunk c draws from the stream (seed, c). With
    ``check_slack`` every converged sample is also checked for a slack
    position cable (statics, either kind; planar about twice the run time):
    ``MonteCarlo.slack``. An elastic arm is refused: its configurations are
    the equilibria of its commands
    (:func:`cdsm.accuracy.plant_errors.monte_carlo_commands`).
    """
    if robot.is_elastic:
        raise CdsmInputError("`theta0`: an elastic arm's configurations are the equilibria of its commands, not "
                             "joint angles; its Monte Carlo is "
                             "cdsm.accuracy.plant_errors.monte_carlo_commands(robot, dL) (dL (N, m_c) m on its "
                             "commanded cables), as `cdsm paper --robot` runs it")
    t0, _ = as_batch("theta0", theta0, robot.n)
    samples, chunk = as_count("samples", samples, 1), as_count("chunk", chunk, 1)
    seed = as_count("seed", seed)
    wl, wh = error_widths(robot)
    dlt, dht = as_tolerances("dl_tol", dl_tol, wl), as_tolerances("dh_tol", dh_tol, wh)
    total, out = samples, None
    bar = Progress(total, label, progress)
    for c, m in enumerate(chunk_sizes(total, chunk)):
        part = monte_carlo_chunk(robot, t0, seed, c, m, dlt, dht, method, check_slack=check_slack)
        if out is None:
            out = part
        else:
            out.merge(part)
        bar.update(m)
    out.feasible0 = robot.feasible(t0)
    out.params = dict(samples=total, seed=seed, chunk=chunk, dl_tol_m=dlt.tolist(),
                      dh_tol_m=dht.tolist(), method=method, check_slack=bool(check_slack))
    return out


#: Relative bound of every Monte-Carlo quantile (:meth:`MonteCarlo.percentile`):
#: half a histogram bin in log space, ``sqrt(10**(1/HIST_PER_DECADE)) - 1``.
QUANTILE_BOUND = float(np.sqrt(10.0 ** (1.0 / _cdsm.HIST_PER_DECADE)) - 1.0)


def hist_quantile(hist: np.ndarray, p: float, above: Optional[np.ndarray] = None,
                  interpolate: bool = False, lo: int = 0) -> np.ndarray:
    """The p-th percentile (0–100, m) of the samples each row of ``hist``
    (N, W) counts in the histogram's bins ``lo .. lo + W``, plus ``above`` (N,) samples counted above every
    bin (failed solves, say: inf when they reach the percentile): the
    smallest sample with at least p % at or below it lies in one bin; its
    geometric middle is returned (within :data:`QUANTILE_BOUND`), or with
    ``interpolate`` a log-linear interpolation by rank inside the bin (an
    estimate within the bin, 1 % at worst). The underflow and overflow bins
    return their edge; NaN for a row without samples."""
    if not 0.0 <= float(p) <= 100.0:
        raise CdsmInputError(f"`p`: must be within [0, 100], got {p}")
    h = np.atleast_2d(hist).astype(np.int64)
    if h.shape[1] == 0:  # no sample in any bin
        h = np.zeros((len(h), 1), np.int64)
    extra = np.zeros(len(h), np.int64) if above is None else np.asarray(above, np.int64)
    total = h.sum(axis=1) + extra
    need = np.maximum(np.ceil(float(p) / 100.0 * total).astype(np.int64), 1)
    cum = np.cumsum(h, axis=1)
    inside = cum[:, -1] >= need
    i = np.argmax(cum >= need[:, None], axis=1)  # the bin in the window
    idx = np.where(inside, i + int(lo), _cdsm.HIST_BINS)  # ... in the histogram
    edges = MonteCarlo.hist_edges()
    last = len(edges)  # the overflow bin
    out = np.full(len(h), np.inf)
    reg = inside & (idx >= 1) & (idx < last)
    k = np.clip(idx, 1, last - 1)  # a regular bin's index (the others are set below)
    e0, e1 = edges[k - 1], edges[k]
    if interpolate:
        rows = np.arange(len(h))
        below = np.where(i >= 1, cum[rows, np.maximum(i - 1, 0)], 0)
        frac = (need - below) / np.maximum(h[rows, i], 1)
        est = e0 * (e1 / e0) ** np.clip(frac, 0.0, 1.0)
    else:
        est = np.sqrt(e0 * e1)
    out[reg] = est[reg]
    out[inside & (idx == 0)] = edges[0]
    out[inside & (idx == last)] = edges[-1]
    return np.where(total > 0, out, np.nan)


def hole_error_sizes(robot) -> np.ndarray:
    """(G,) how many hole errors each hole group of the arm draws (the
    groups of the core's ``CoreRobot.structure()``, in their order): one for
    a coherent group (a planar disk's hole height moves every hole of its
    pair by one error), one per hole coordinate otherwise (a spatial cable's
    holes: each coordinate its own error)."""
    groups = robot.core.structure()["hole_groups"]
    return np.array([1 if g["coherent"] else len(g["coords"]) for g in groups], dtype=np.int64)


def plate_hole_twins(robot) -> Tuple[np.ndarray, np.ndarray]:
    """``(face_b, face_a)``: positions among the hole errors a sample draws
    (:func:`hole_error_sizes`, one per coordinate of a group that is not
    coherent) of the coordinates of a zero-thickness disk's face-b holes and
    of their face-a twins, which take one error (:func:`cdsm.plant.plate_twins`);
    empty without such disks or when every group is coherent (a planar arm's
    hole heights)."""
    if not (np.asarray(robot.disk_thickness) == 0.0).any():
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    groups = robot.core.structure()["hole_groups"]
    if any(g["coherent"] for g in groups):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return plant.plate_twins(robot, np.concatenate([np.asarray(g["coords"], np.int64) for g in groups]))


def error_widths(robot) -> Tuple[int, int]:
    """How many cable-length and hole errors a sample draws: one per
    position-controlled cable, and :func:`hole_error_sizes` summed — planar
    (n, n) (upper cables, disks' hole heights); spatial (position-controlled
    cables, every hole coordinate)."""
    return len(robot.position_cables), int(hole_error_sizes(robot).sum())


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
    twins = plate_hole_twins(robot)  # a zero-thickness disk's two faces: one hole, one error
    if twins[0].size:
        dh = plant.tie_errors(dh, twins)
    th = robot.threads if threads is None else as_count("threads", threads)
    # the hole errors go by the kind's argument (per-disk heights or every coordinate), none when all are 0
    holes = {"dh": None, "dholes": None}
    holes[robot.kind.hole_error_arg] = dh if np.any(dh_tol) else None
    st = robot.core.monte_carlo(theta0, dl, holes["dh"], holes["dholes"], method, 1e-12, 100, bool(check_slack), th)
    names = robot.kind.quantities
    q = st.quantities
    return MonteCarlo(theta0=theta0, count=st.count.astype(np.int64), failed=st.failed.astype(np.int64),
                      sum=st.sum.reshape(-1, q), sum_sq=st.sum_sq.reshape(-1, q),
                      min=st.min.reshape(-1, q), max=st.max.reshape(-1, q),
                      hist=st.hist.reshape(len(st.count), st.hist_width), hist_lo=st.hist_lo,
                      slack=st.slack.astype(np.int64) if check_slack else None, quantities=names)


# ---------------------------------------------------------------------------
# results as arrays
# ---------------------------------------------------------------------------
def percentile_text(p: float) -> str:
    """A percentile written exactly and shortest: ``%g`` where that is
    exact (``95``, ``99.9``), else every digit it needs (``99.99999``, which
    ``%g`` rounds to ``100``)."""
    v = float(p) + 0.0  # -0.0 is 0.0
    text = f"{v:g}"
    return text if float(text) == v else str(np.format_float_positional(v, unique=True, trim="-"))


def percentile_key(p: float) -> str:
    """The key of the ``p``-th percentile in :func:`summary`: ``p`` and
    :func:`percentile_text`, ``.`` as ``_`` (``p95``, ``p99_9``,
    ``p99_99999``): two percentiles never share a key."""
    return "p" + percentile_text(p).replace(".", "_")


def summary(mc: MonteCarlo, percentiles: Sequence[float] = DEFAULT_PERCENTILES) -> Dict[str, np.ndarray]:
    """Per-configuration arrays of a study (N configurations): ``count``,
    ``failed`` (N,); ``mean``, ``std``, ``min``, ``max``, ``max_abs``, ``sum``,
    ``sum_sq`` (N, 4) over [dX (m), dY (m), dphi (rad), |d(X, Y)| (m)];
    ``p50``, ``p95``, ... (N,) percentiles of |d(X, Y)|, m (keys by
    :func:`percentile_key`: ``p99_9`` for 99.9; each percentile once), also
    stacked as ``dxy_percentiles`` (N, P) with ``percentiles`` (P,);
    ``hist`` (N, bins) and ``hist_edges`` (bins - 1,) m."""
    pct = np.asarray([as_finite("percentiles", p) for p in percentiles], dtype=np.float64)
    keys = [percentile_key(p) for p in pct]
    if len(set(keys)) < len(keys):
        twice = next(p for p, k in zip(pct, keys) if keys.count(k) > 1)
        raise CdsmInputError(f"`percentiles`: {percentile_text(twice)} is given more than once")
    out = dict(theta0=mc.theta0, count=mc.count, failed=mc.failed, mean=mc.mean, std=mc.std,
               min=mc.min, max=mc.max, max_abs=mc.max_abs, sum=mc.sum, sum_sq=mc.sum_sq,
               hist=mc.dense_hist(), hist_edges=mc.hist_edges(), percentiles=pct,
               quantities=np.array(mc.quantities),
               units=np.array(_UNITS.get(tuple(mc.quantities), QUANTITY_UNITS)))
    cols = [mc.percentile(p) for p in pct]
    out["dxy_percentiles"] = np.stack(cols, axis=1) if cols else np.zeros((len(mc.count), 0))
    for key, col in zip(keys, cols):
        out[key] = col
    return out


def save_npz(path: str, mc: MonteCarlo, poses: Optional[np.ndarray] = None,
             params: Optional[dict] = None,
             percentiles: Sequence[float] = DEFAULT_PERCENTILES) -> Dict[str, np.ndarray]:
    """Writes :func:`summary` (+ ``poses`` (N, 3) [x, y, phi] m, m, rad) to a
    compressed .npz; ``params`` (run parameters, merged over ``mc.params``) as
    a JSON string (0-d str array, key ``params``). Returns the arrays."""
    check_path(path, "Monte-Carlo file")  # before the summary is computed
    arrays = summary(mc, percentiles)
    if poses is not None:
        arrays["poses"] = np.asarray(poses, dtype=np.float64)
    p = dict(mc.params)
    p.update(params or {})
    arrays["params"] = np.array(json.dumps(json_safe(p), sort_keys=True))
    write_npz(path, arrays, "Monte-Carlo")
    return arrays


def load_npz(path: str) -> Tuple[MonteCarlo, dict]:
    """A study written by :func:`save_npz`: the :class:`MonteCarlo` (exact
    sums and histogram, mergeable with another run's) and its params."""
    z = read_npz(path, "Monte-Carlo")
    try:
        params = json.loads(str(z["params"]))
        mc = MonteCarlo(theta0=z["theta0"], count=z["count"], failed=z["failed"], sum=z["sum"],
                        sum_sq=z["sum_sq"], min=z["min"], max=z["max"], hist=z["hist"],
                        params=params,
                        quantities=tuple(str(q) for q in z["quantities"]) if "quantities" in z else QUANTITY_NAMES)
    except KeyError as exc:
        raise CdsmInputError(f"Monte-Carlo file {str(path)!r}: missing array {exc}") from None
    return mc, params
