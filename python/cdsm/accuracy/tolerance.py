"""Tolerance allocation and its converse (tolerances -> tip-error distribution
per region), verified by the Rust Monte Carlo. SI units: m, rad.

Error model of the allocation: every upper-cable length error ``dl_j`` is
uniform in ``±tc_j`` and every per-disk hole-height error ``dh_i`` (the
paper's "error on disk i's holes") uniform in ``±th_i``, all independent. The
tolerance vector is ``t = alpha * shape`` with ``shape_j = w_j * base_j``
(``base`` = 1 mm per cable and 0.35 mm per disk, the paper's ratio; weights
``w`` default 1): equal relative cost — the answer maximises the smallest
relative tolerance ``min_j t_j / (w_j base_j)``, which puts every tolerance at
the same fraction ``alpha`` of its weighted reference. ``shape="equal-effect"``
instead sets ``shape_j = w_j / rms_region |d(x, y)/de_j|`` (every error
contributes equally to the linear tip variance). The linear picture that
starts the search is :mod:`cdsm.accuracy.sensitivity`.

The pooled percentile over a region merges the per-configuration histograms
of the Monte-Carlo study (:attr:`cdsm.accuracy.MonteCarlo.hist`; 60 log bins
per decade, the percentile is the upper edge of its bin: conservative, at
most 3.9 % high). Failed solves count as errors above every bin.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import _cdsm
from ..files import read_table, read_text, table_column
from ..inputs import CdsmInputError, as_batch, as_tolerances
from ..robot import Robot
from .montecarlo import MonteCarlo, monte_carlo
from .scenarios import PAPER_DH_TOL, PAPER_DL_TOL
from .sensitivity import error_matrix, linear_percentile, sensitivities, tolerance_vector
from .workspace import joint_grid, paper_ik_seed

__all__ = ["HIST_RESOLUTION", "pooled_percentile", "Allocation", "allocate", "distribution",
           "region_cells", "load_tolerances", "parse_region"]

#: Relative width of a histogram bin of the Monte-Carlo study (10**(1/60) - 1).
HIST_RESOLUTION = 10.0 ** (1.0 / _cdsm.HIST_PER_DECADE) - 1.0


def pooled_percentile(mc: MonteCarlo, p: float, rows=None, interpolate: bool = False) -> float:
    """p-th percentile (m) of |d(x, y)| pooled over the configurations ``rows``
    (default all) of a Monte-Carlo study: the per-configuration histograms are
    summed; failed solves count as above every bin (inf if they reach the
    percentile). Upper bin edge: at most :data:`HIST_RESOLUTION` high; with
    ``interpolate`` a log-linear interpolation inside the bin (an estimate, not
    a bound)."""
    sel = slice(None) if rows is None else rows
    hist = mc.hist[sel].sum(axis=0).astype(np.int64)
    hist[-1] += int(mc.failed[sel].sum())
    total = int(hist.sum())
    if total == 0:
        return float("nan")
    need = max(int(np.ceil(p / 100.0 * total)), 1)
    cum = np.cumsum(hist)
    idx = int(np.argmax(cum >= need))
    edges = MonteCarlo.hist_edges()
    upper = np.append(edges, np.inf)
    hi = float(upper[min(idx, len(upper) - 1)])
    if not interpolate or idx == 0 or not np.isfinite(hi):
        return hi
    lo = float(edges[idx - 1])
    below = cum[idx - 1]
    frac = (need - below) / max(hist[idx], 1)
    return float(lo * (hi / lo) ** frac)


# ---------------------------------------------------------------------------
# allocation
# ---------------------------------------------------------------------------
@dataclass
class Allocation:
    """Answer of :func:`allocate` (all lengths in m unless the key says mm).

    cable_length_tol_m: (n,) ± tolerance per upper cable. hole_height_tol_m:
    (n,) ± tolerance per disk's hole height. achieved_m: the pooled percentile
    of |d(x, y)| over the region verified by Monte Carlo at this answer
    (<= target). achieved_1p25_m: the same with every tolerance × 1.25 (> target:
    the answer is not loose). alpha: common scale of ``shape`` (m per unit).
    linear_m: the linear-model percentile at the answer. history: (alpha,
    achieved) of every Monte-Carlo evaluation.
    """

    cable_length_tol_m: np.ndarray
    hole_height_tol_m: np.ndarray
    achieved_m: float
    achieved_1p25_m: float
    target_m: float
    percentile: float
    alpha: float
    shape: np.ndarray
    linear_m: float
    alpha_linear: float
    failed: int
    history: List[tuple] = field(default_factory=list)
    params: dict = field(default_factory=dict)

    @property
    def holds(self) -> bool:
        return bool(self.achieved_m <= self.target_m)

    @property
    def not_loose(self) -> bool:
        return bool(self.achieved_1p25_m > self.target_m)

    def to_json(self) -> dict:
        """The fixed keys (``cable_length_tol_m``, ``hole_height_tol_m``,
        ``achieved_mm``) plus extras."""
        return dict(
            cable_length_tol_m=[float(v) for v in self.cable_length_tol_m],
            hole_height_tol_m=[float(v) for v in self.hole_height_tol_m],
            achieved_mm=self.achieved_m * 1e3,
            achieved_interpolated_mm=self.params.get("achieved_interpolated_m", float("nan")) * 1e3,
            target_mm=self.target_m * 1e3,
            percentile=self.percentile,
            holds=self.holds,
            achieved_at_1p25_tol_mm=self.achieved_1p25_m * 1e3,
            not_loose=self.not_loose,
            linear_estimate_mm=self.linear_m * 1e3,
            alpha=self.alpha,
            alpha_linear=self.alpha_linear,
            histogram_resolution=HIST_RESOLUTION,
            failed_solves=self.failed,
            monte_carlo_evaluations=[dict(alpha=a, achieved_mm=v * 1e3) for a, v in self.history],
            **self.params,
        )


def _shape(robot: Robot, m: np.ndarray, weights, base, shape: str) -> np.ndarray:
    n = robot.n
    w = np.ones(2 * n) if weights is None else np.asarray(weights, dtype=np.float64).reshape(-1)
    if w.size == 2:
        w = np.repeat(w, n)
    if w.size != 2 * n or not np.isfinite(w).all() or (w <= 0).any():
        raise CdsmInputError(f"`weights`: need 2 or 2n = {2 * n} positive numbers "
                             f"(n cables then n disks), got {weights}")
    if shape == "ratio":
        b = np.asarray(base, dtype=np.float64).reshape(-1)
        if b.size != 2 or not np.isfinite(b).all() or (b <= 0).any():
            raise CdsmInputError(f"`base`: need two positive lengths (cable, hole), m, got {base}")
        return w * np.repeat(b, n)
    if shape == "equal-effect":
        ok = np.isfinite(m).all(axis=(1, 2))
        rms = np.sqrt((m[ok] ** 2).sum(axis=1).mean(axis=0))
        return w / np.maximum(rms, 1e-12) * 1e-3
    raise CdsmInputError(f"`shape`: expected 'ratio' or 'equal-effect', got {shape!r}")


def allocate(robot: Robot, target_m: float, theta=None, percentile: float = 95.0,
             weights=None, base=(PAPER_DL_TOL, PAPER_DH_TOL), shape: str = "ratio",
             samples: int = 1000, seed: int = 0, rel_tol: float = 0.01,
             max_evals: int = 30, progress: bool = False) -> Allocation:
    """Largest tolerances (common scale ``alpha`` of the cost shape, see the
    module doc) such that the pooled ``percentile`` of |d(x, y)| over the
    configurations ``theta (N, n)`` rad (errors applied at these angles;
    default the ±30°/5° joint grid) stays within ``target_m``.

    1. Sensitivities (Rust) -> linear model -> ``alpha_lin = T / P_lin(1)``
       (the linear percentile is proportional to alpha).
    2. Monte Carlo in the Rust core (``samples`` per configuration, common
       random numbers: the same seed at every alpha) brackets and bisects
       alpha until ``hi / lo <= 1 + rel_tol``; the answer is ``lo``, verified
       ``achieved(lo) <= T``, and ``achieved(1.25 lo) > T`` is evaluated.
    """
    t = joint_grid(robot.n) if theta is None else theta
    t, _ = as_batch("theta", t, robot.n)
    target = float(target_m)
    if not (np.isfinite(target) and target > 0):
        raise CdsmInputError(f"`target_m`: must be positive and finite, got {target_m}")
    if not 0.0 < float(percentile) < 100.0:
        raise CdsmInputError(f"`percentile`: must be within (0, 100), got {percentile}")
    n = robot.n
    sens = sensitivities(robot, t)
    m = error_matrix(sens)
    shp = _shape(robot, m, weights, base, shape)
    p_lin1 = linear_percentile(m, shp, percentile, seed=seed)
    if not (np.isfinite(p_lin1) and p_lin1 > 0):
        raise CdsmInputError("the linear model gives no tip error over this region (no sensitivity)")
    a_lin = target / p_lin1
    cache: Dict[float, MonteCarlo] = {}
    history: List[tuple] = []

    def run(alpha: float) -> MonteCarlo:
        if alpha not in cache:
            tol = alpha * shp
            cache[alpha] = monte_carlo(robot, t, samples=samples, seed=seed, dl_tol=tol[:n],
                                       dh_tol=tol[n:], progress=False)
        return cache[alpha]

    def achieved(alpha: float) -> float:
        v = pooled_percentile(run(alpha), percentile)
        history.append((float(alpha), v))
        if progress:
            import sys
            print(f"  alpha {alpha:.6g}: P{percentile:g} = {v * 1e3:.4f} mm", file=sys.stderr)
        return v

    lo, hi = None, None
    a = a_lin
    for _ in range(max_evals):
        v = achieved(a)
        if v <= target:
            lo = a
            if hi is not None:
                break
            a = a * float(np.clip(target / v, 1.02, 1.3))
        else:
            hi = a
            if lo is not None:
                break
            a = a * float(np.clip(target / v, 0.5, 0.98))
    if lo is None or hi is None:
        raise CdsmInputError("tolerance allocation: could not bracket the target "
                             f"(history {history})")
    evals = len(history)
    while hi / lo > 1.0 + rel_tol and evals < max_evals:
        mid = float(np.sqrt(lo * hi))
        if achieved(mid) <= target:
            lo = mid
        else:
            hi = mid
        evals += 1
    ach = pooled_percentile(run(lo), percentile)
    mc = run(lo)
    ach_i = pooled_percentile(mc, percentile, interpolate=True)
    a125 = pooled_percentile(run(1.25 * lo), percentile)
    tol = lo * shp
    return Allocation(
        cable_length_tol_m=tol[:n], hole_height_tol_m=tol[n:], achieved_m=ach,
        achieved_1p25_m=a125, target_m=target, percentile=float(percentile), alpha=float(lo),
        shape=shp, linear_m=float(lo * p_lin1), alpha_linear=float(a_lin),
        failed=int(mc.failed.sum()), history=history,
        params=dict(achieved_interpolated_m=ach_i, samples=int(samples), seed=int(seed), configurations=int(len(t)),
                    shape=shape, weights=None if weights is None else np.asarray(weights, float).ravel().tolist(),
                    base_m=[float(v) for v in np.asarray(base, float).ravel()],
                    robot=robot.name, n=n))


# ---------------------------------------------------------------------------
# converse: tolerances -> error distribution per region
# ---------------------------------------------------------------------------
def region_cells(xy: np.ndarray, k: int = 3) -> np.ndarray:
    """(N,) cell index ``iy * k + ix`` of a k×k grid over the bounding box of
    the nominal tip positions ``xy (N, 2)`` m (equal widths)."""
    xy = np.asarray(xy, dtype=np.float64)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = np.where(hi > lo, hi - lo, 1.0)
    ij = np.clip(((xy - lo) / span * k).astype(int), 0, k - 1)
    return ij[:, 1] * k + ij[:, 0]


def distribution(robot: Robot, dl_tol, dh_tol, theta=None, percentiles: Sequence[float] = (50, 95, 99),
                 samples: int = 1000, seed: int = 0, cells: int = 3, mc: Optional[MonteCarlo] = None) -> dict:
    """Tip-error distribution over a region for given tolerances (m; scalars or
    (n,)): Monte Carlo in the Rust core at every configuration ``theta (N, n)``
    (default the ±30°/5° joint grid). Returns ``pooled`` {P: m} over the whole
    region, ``per_config`` (N, len(percentiles)) m, and ``regions``: one row
    per non-empty cell of a ``cells``×``cells`` grid over the nominal tip
    (X, Y) with its bounds (m), configuration count and pooled percentiles (m).
    """
    t = joint_grid(robot.n) if theta is None else theta
    t, _ = as_batch("theta", t, robot.n)
    tol = tolerance_vector(robot, dl_tol, dh_tol)
    n = robot.n
    if mc is None:
        mc = monte_carlo(robot, t, samples=samples, seed=seed, dl_tol=tol[:n], dh_tol=tol[n:],
                         progress=False)
    xy = robot.fk(t)[:, :2]
    cell = region_cells(xy, cells)
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    w = (hi - lo) / cells
    rows = []
    for c in range(cells * cells):
        sel = np.flatnonzero(cell == c)
        if len(sel) == 0:
            continue
        ix, iy = c % cells, c // cells
        rows.append(dict(cell=int(c), x_lo_m=float(lo[0] + ix * w[0]), x_hi_m=float(lo[0] + (ix + 1) * w[0]),
                         y_lo_m=float(lo[1] + iy * w[1]), y_hi_m=float(lo[1] + (iy + 1) * w[1]),
                         configurations=int(len(sel)),
                         **{f"p{p:g}_m": pooled_percentile(mc, p, sel) for p in percentiles}))
    per = np.stack([mc.percentile(p) for p in percentiles], axis=1)
    return dict(pooled={float(p): pooled_percentile(mc, p) for p in percentiles}, per_config=per,
                regions=rows, cell=cell, mc=mc, dl_tol_m=tol[:n], dh_tol_m=tol[n:])


# ---------------------------------------------------------------------------
# tolerances
# ---------------------------------------------------------------------------
def load_tolerances(path: str, n: int) -> Tuple[np.ndarray, np.ndarray]:
    """Tolerances from a JSON file (as ``cdsm tolerance --json`` writes it):
    ``cable_length_tol_m`` — (n,) per upper cable, m — and
    ``hole_height_tol_m`` — (n,) per disk, m (a scalar applies to all; other
    keys are ignored). Returns (dl_tol, dh_tol), each (n,) m."""
    text = read_text(path, "tolerance")
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise CdsmInputError(f"tolerance file {path!r}: not valid JSON ({exc})") from None
    if not isinstance(data, dict):
        raise CdsmInputError(f"tolerance file {path!r}: expected a JSON object")
    out = []
    for key in ("cable_length_tol_m", "hole_height_tol_m"):
        if key not in data:
            raise CdsmInputError(f"tolerance file {path!r}: missing key {key!r}")
        try:
            arr = np.asarray(data[key], dtype=np.float64)
        except (TypeError, ValueError):
            raise CdsmInputError(f"tolerance file {path!r}: `{key}` is not a number "
                                 f"or a list of numbers") from None
        if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] != n):
            raise CdsmInputError(f"tolerance file {path!r}: `{key}` needs {n} values "
                                 f"(one per {'upper cable' if key[0] == 'c' else 'disk'}), "
                                 f"got shape {arr.shape}")
        try:
            out.append(as_tolerances(key, arr, n))
        except CdsmInputError as exc:
            raise CdsmInputError(f"tolerance file {path!r}: {exc}") from None
    return out[0], out[1]


# ---------------------------------------------------------------------------
# regions
# ---------------------------------------------------------------------------
def _region_file(spec: str, path: str, columns: List[str], what: str) -> np.ndarray:
    """The ``columns`` of a region CSV file, (N, len(columns)): a header naming
    them, or no header (or a header of other names) and exactly those columns
    in that order."""
    try:
        cols, rows = read_table(path, f"--region {what}", headerless=columns)
    except CdsmInputError as exc:
        raise CdsmInputError(f"--region {spec!r}: {exc}") from None
    missing = [c for c in columns if c not in cols]
    if missing and len(cols) == len(columns):  # positional columns under other names
        rows = [{c: r[k] for c, k in zip(columns, cols)} for r in rows]
        missing = []
    if missing:
        raise CdsmInputError(f"--region {spec!r}: {path!r} has no column(s) {', '.join(missing)} "
                             f"(need {', '.join(columns)}, or no header and {len(columns)} values a row)")
    return np.stack([table_column(rows, c, path) for c in columns], axis=1)


def parse_region(spec: str, robot: Robot, seed: int = 0) -> Tuple[np.ndarray, str]:
    """Joint angles (N, n) rad of a region spec, and a description:
    ``grid:LO_DEG:HI_DEG:STEP_DEG[:N]`` (every joint; a grid of more than
    20000 points, or N given, is subsampled to N (default 2000) with ``seed``),
    ``joints:FILE.csv`` (columns ``theta_1..theta_n``, rad, or no header) or
    ``poses:FILE.csv`` (columns ``x, y, phi``, m, m, rad, or no header; pose IK
    from the paper's seed)."""
    kind, _, rest = spec.partition(":")
    if kind == "grid":
        try:
            vals = [float(v) for v in rest.split(":")]
        except ValueError:
            vals = []
        if len(vals) not in (3, 4):
            raise CdsmInputError(f"--region {spec!r}: expected grid:LO_DEG:HI_DEG:STEP_DEG[:N]")
        lo, hi, step = vals[:3]
        if not (np.isfinite(vals).all() and step > 0 and hi >= lo):
            raise CdsmInputError(f"--region {spec!r}: need LO <= HI and STEP > 0 (degrees)")
        k = int(np.floor((hi - lo) / step + 1e-9)) + 1
        want = int(vals[3]) if len(vals) == 4 else None
        if want is not None and want < 1:
            raise CdsmInputError(f"--region {spec!r}: N must be >= 1")
        total = k ** robot.n
        if total <= 20000 and want is None:
            return joint_grid(robot.n, np.radians(lo), np.radians(hi), np.radians(step)), \
                f"grid {lo:g}..{hi:g} deg step {step:g} ({total} configurations)"
        want = 2000 if want is None else want
        rng = np.random.default_rng([int(seed), 11])
        axis = np.radians(lo + step * np.arange(k))
        theta = axis[rng.integers(0, k, (min(want, total), robot.n))]
        return theta, f"grid {lo:g}..{hi:g} deg step {step:g}, {len(theta)} random points of {total}"
    if kind == "joints":
        t = _region_file(spec, rest, [f"theta_{i}" for i in range(1, robot.n + 1)], "joints")
        return t, f"{len(t)} configurations from {rest}"
    if kind == "poses":
        p = _region_file(spec, rest, ["x", "y", "phi"], "poses")
        sol = robot.ik(p, seed=paper_ik_seed(robot.n))
        bad = np.flatnonzero(~np.asarray(sol.converged, bool))
        if len(bad):
            raise CdsmInputError(f"--region {spec!r}: pose IK failed for row(s) {bad[:5].tolist()} (unreachable?)")
        return np.atleast_2d(sol.theta), f"{len(p)} poses from {rest} (pose IK, paper seed)"
    raise CdsmInputError(f"--region {spec!r}: expected grid:LO:HI:STEP[:N], joints:FILE.csv or poses:FILE.csv")
