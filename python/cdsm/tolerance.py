"""Design for accuracy (issue 7): tip sensitivities, amplification maps,
linear-vs-Monte-Carlo comparison, tolerance allocation and the converse
(tolerances -> tip-error distribution per region). SI units: m, rad.

Sensitivities (Rust core, ``rust/sensitivity.rs``; implicit function theorem,
the cable solve keeps the upper-cable lengths)::

    dS/dl     =  J_pose (dL_upper/dtheta)^-1                      (N, 3, n)
    dS/dholes = -J_pose (dL_upper/dtheta)^-1 dL_upper/dholes      (N, 3, 2n, n+1, 2, 2)
    dS/ddh_i  =  dS/dholes summed over the holes of upper cable i (N, 3, n)

Error model of the allocation: every upper-cable length error ``dl_j`` is
uniform in ``±tc_j`` and every per-disk hole-height error ``dh_i`` (the
paper's "error on disk i's holes") uniform in ``±th_i``, all independent. The
tolerance vector is ``t = alpha * shape`` with ``shape_j = w_j * base_j``
(``base`` = 1 mm per cable and 0.35 mm per disk, the paper's ratio; weights
``w`` default 1): equal relative cost — the answer maximises the smallest
relative tolerance ``min_j t_j / (w_j base_j)``, which puts every tolerance at
the same fraction ``alpha`` of its weighted reference. ``shape="equal-effect"``
instead sets ``shape_j = w_j / rms_region |d(x, y)/de_j|`` (every error
contributes equally to the linear tip variance).

Linear amplification (per configuration, tolerances ``t``):

* worst case: ``worst_x = sum_j |S_xj| t_j``, ``worst_y = sum_j |S_yj| t_j``,
  ``worst_xy = hypot(worst_x, worst_y)`` (a bound on |d(x, y)|);
* RMS of |d(x, y)| for uniform errors: ``sqrt(sum_{i in x,y} sum_j S_ij^2 t_j^2 / 3)``.

The pooled percentile over a region merges the per-configuration histograms
of the Monte-Carlo study (``errors.MonteCarlo.hist``; 60 log bins per decade,
the percentile is the upper edge of its bin: conservative, at most 3.9 %
high). Failed solves count as errors above every bin.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence

import numpy as np

from . import _cdsm
from .errors import MonteCarlo, monte_carlo
from .robot import CdsmInputError, Robot, _batch

__all__ = [
    "BASE_CABLE_M", "BASE_HOLE_M", "HIST_RESOLUTION", "Sensitivities", "sensitivities",
    "error_matrix", "amplification", "linear_percentile", "pooled_percentile",
    "Allocation", "allocate", "distribution", "region_cells", "linear_vs_mc",
    "amplification_maps",
]

#: Reference tolerances of the default cost (the paper's Monte-Carlo study), m.
BASE_CABLE_M = 1e-3
BASE_HOLE_M = 0.35e-3
#: Relative width of a histogram bin of the Monte-Carlo study (10**(1/60) - 1).
HIST_RESOLUTION = 10.0 ** (1.0 / _cdsm.HIST_PER_DECADE) - 1.0


# ---------------------------------------------------------------------------
# sensitivities
# ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Sensitivities:
    """First-order sensitivities of the tip pose at ``theta (N, n)`` rad.

    cable: (N, 3, n) d[x, y, phi]/d(upper-cable length), m/m (rad/m for phi).
    pair: (N, 3, n) d[x, y, phi]/d(hole height of disk i) (the paper's dh), m/m.
    holes: (N, 3, 2n, n+1, 2, 2) d[x, y, phi]/d(every hole coordinate), or None.
    ok: (N,) the upper-cable Jacobian is invertible (NaN rows otherwise).
    """

    theta: np.ndarray
    cable: np.ndarray
    pair: np.ndarray
    holes: Optional[np.ndarray]
    ok: np.ndarray


def sensitivities(robot: Robot, theta, holes: bool = False) -> Sensitivities:
    """Analytic tip sensitivities (Rust core) over ``theta (N, n)`` rad (or (n,))."""
    t, _ = _batch("theta", theta, robot.n)
    n = robot.n
    c, p, h, ok = _cdsm.sensitivity_tip(robot._core, t, bool(holes), robot.threads)
    hs = None if h is None else h.reshape((-1, 3) + robot.holes.shape)
    return Sensitivities(t, c.reshape(-1, 3, n), p.reshape(-1, 3, n), hs, np.asarray(ok, bool))


def error_matrix(sens: Sensitivities) -> np.ndarray:
    """(N, 2, 2n) d(x, y)/d[dl_1..dl_n, dh_1..dh_n], m/m: the linear map from
    the allocation's error vector to the tip position error."""
    return np.concatenate([sens.cable[:, :2, :], sens.pair[:, :2, :]], axis=2)


def _tol_vector(robot: Robot, dl_tol, dh_tol) -> np.ndarray:
    n = robot.n
    out = []
    for name, v in (("dl_tol", dl_tol), ("dh_tol", dh_tol)):
        a = np.broadcast_to(np.asarray(v, dtype=np.float64), (n,)).copy()
        if not np.isfinite(a).all() or (a < 0).any():
            raise CdsmInputError(f"`{name}`: tolerances must be finite and >= 0 (m), got {v}")
        out.append(a)
    return np.concatenate(out)


def amplification(sens: Sensitivities, dl_tol, dh_tol) -> Dict[str, np.ndarray]:
    """Linear tip-error amplification for tolerances ``dl_tol`` (per upper
    cable) and ``dh_tol`` (per disk), m (scalars or (n,)).

    Returns (N,) arrays in m: ``worst_x``, ``worst_y`` (sum_j |S_ij| t_j),
    ``worst_xy`` (their hypot), ``rms_xy`` (RMS of |d(x, y)| for independent
    uniform errors, sqrt(sum S^2 t^2 / 3)); and the per-unit maps (m of tip per
    m of error, tolerances 1 on that group only): ``cable_worst``,
    ``cable_rms``, ``hole_worst``, ``hole_rms``.
    """
    n = sens.cable.shape[2]
    m = error_matrix(sens)
    t = np.concatenate([np.broadcast_to(np.asarray(dl_tol, float), (n,)),
                        np.broadcast_to(np.asarray(dh_tol, float), (n,))])
    wx = np.abs(m[:, 0, :]) @ t
    wy = np.abs(m[:, 1, :]) @ t
    rms = np.sqrt(((m ** 2).sum(axis=1) @ (t ** 2)) / 3.0)
    cab, hol = m[:, :, :n], m[:, :, n:]
    return dict(
        worst_x=wx, worst_y=wy, worst_xy=np.hypot(wx, wy), rms_xy=rms,
        cable_worst=np.hypot(np.abs(cab[:, 0]).sum(1), np.abs(cab[:, 1]).sum(1)),
        cable_rms=np.sqrt((cab ** 2).sum(axis=(1, 2)) / 3.0),
        hole_worst=np.hypot(np.abs(hol[:, 0]).sum(1), np.abs(hol[:, 1]).sum(1)),
        hole_rms=np.sqrt((hol ** 2).sum(axis=(1, 2)) / 3.0),
    )


def linear_percentile(m: np.ndarray, tol: np.ndarray, p: float, samples: int = 2000,
                      seed: int = 0) -> float:
    """Pooled p-th percentile (m) of |d(x, y)| over all configurations under
    the linear model ``m (N, 2, k)`` with independent uniform errors within
    ``±tol (k,)`` (``samples`` common draws). Exactly proportional to ``tol``."""
    rng = np.random.default_rng([int(seed), 7])
    v = rng.uniform(-1.0, 1.0, (int(samples), m.shape[2])) * tol
    ok = np.isfinite(m).all(axis=(1, 2))
    e = np.einsum("nik,sk->nsi", m[ok], v)
    return float(np.percentile(np.hypot(e[..., 0], e[..., 1]), p))


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
             weights=None, base=(BASE_CABLE_M, BASE_HOLE_M), shape: str = "ratio",
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
    from .workspace import joint_grid

    t = joint_grid(robot.n) if theta is None else theta
    t, _ = _batch("theta", t, robot.n)
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
    from .workspace import joint_grid

    t = joint_grid(robot.n) if theta is None else theta
    t, _ = _batch("theta", t, robot.n)
    tol = _tol_vector(robot, dl_tol, dh_tol)
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
# where the linear picture holds
# ---------------------------------------------------------------------------
def linear_vs_mc(robot: Robot, protocol: str = "joint", dl_tol=BASE_CABLE_M, dh_tol=BASE_HOLE_M,
                 samples: int = 500, seed: int = 0, depart: float = 0.1, ws=None) -> dict:
    """Compare the linear picture with the nonlinear solves over a workspace
    (``workspace.sweep(robot, protocol)`` unless ``ws`` is given).

    Two measures per configuration: ``ratio_rms`` = Monte-Carlo RMS of
    |d(x, y)| / linear RMS (tolerances ``dl_tol``, ``dh_tol``, m), and
    ``rel_single`` = |dS_solve - S dl| / |dS_solve| for the paper's single
    error (upper cable 1 shortened by 1 mm). Departures above ``depart`` are
    classified against the special points: ``jump`` (``workspace.jump_points``
    of the single-error map), ``near_singular`` (pose-Jacobian singular-value
    ratio < 0.02) and ``other``; ``summary`` gives median / 95th pct / max of
    |ratio_rms - 1| and rel_single per class.
    """
    from .errors import deviation
    from .workspace import jump_points, singular_values, sweep

    if ws is None:
        ws = sweep(robot, protocol)
    ok = np.asarray(ws.reachable, bool) & np.isfinite(ws.theta0).all(axis=1)
    t = np.where(ok[:, None], ws.theta0, 0.0)
    n = robot.n
    sens = sensitivities(robot, t)
    amp = amplification(sens, dl_tol, dh_tol)
    tol = _tol_vector(robot, dl_tol, dh_tol)
    mc = monte_carlo(robot, t, samples=samples, seed=seed, dl_tol=tol[:n], dh_tol=tol[n:], progress=False)
    with np.errstate(invalid="ignore", divide="ignore"):
        mc_rms = np.sqrt(mc.sum_sq[:, 3] / mc.count)
        ratio = mc_rms / amp["rms_xy"]
    dl = np.zeros(n)
    dl[0] = -1e-3
    dev = deviation(robot, t, dL=dl)
    lin = sens.cable[:, :, 0] * dl[0]
    ds = np.where(ok[:, None], dev.dS, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.linalg.norm(ds[:, :2] - lin[:, :2], axis=1) / np.linalg.norm(ds[:, :2], axis=1)
    jumps = jump_points(robot, ws, ds)
    sv = singular_values(robot, t)
    sing = sv[:, -1] / np.maximum(sv[:, 0], 1e-300) < 0.02
    cls = np.full(len(t), "other", dtype=object)
    cls[sing] = "near_singular"
    cls[jumps.point] = "jump"
    cls[~ok] = "unreachable"
    summary = {}
    for name in ("jump", "near_singular", "other"):
        sel = (cls == name) & np.isfinite(ratio) & np.isfinite(rel)
        if not sel.any():
            summary[name] = dict(count=0)
            continue
        d = np.abs(ratio[sel] - 1.0)
        summary[name] = dict(
            count=int(sel.sum()),
            rms_ratio_dev_median=float(np.median(d)), rms_ratio_dev_p95=float(np.percentile(d, 95)),
            rms_ratio_dev_max=float(d.max()),
            single_rel_median=float(np.median(rel[sel])), single_rel_p95=float(np.percentile(rel[sel], 95)),
            single_rel_max=float(rel[sel].max()),
            departing=int(((d > depart) | (rel[sel] > depart)).sum()))
    return dict(protocol=ws.protocol, ratio_rms=ratio, rel_single=rel, klass=cls.astype(str),
                jump=jumps.point, near_singular=sing, amplification=amp, mc=mc, summary=summary,
                theta=t, ok=ok, ws=ws)


# ---------------------------------------------------------------------------
# amplification maps (report)
# ---------------------------------------------------------------------------
def amplification_maps(robot: Robot, protocol: str = "attitude0", ws=None) -> dict:
    """Worst-case and RMS amplification maps over a workspace (default the
    paper's attitude-0 protocol on the ±30°/5° grid): per configuration the
    nominal tip (x, y) (m) and :func:`amplification` per unit tolerance
    (``cable_worst``, ``cable_rms``: mm of tip per mm on every upper cable;
    ``hole_worst``, ``hole_rms``: mm of tip per mm on every disk's hole height)."""
    from .workspace import sweep

    if ws is None:
        ws = sweep(robot, protocol)
    ok = np.asarray(ws.reachable, bool) & np.isfinite(ws.theta0).all(axis=1)
    t = np.where(ok[:, None], ws.theta0, 0.0)
    amp = amplification(sensitivities(robot, t), 1.0, 1.0)
    out = {k: np.where(ok, v, np.nan) for k, v in amp.items()
           if k in ("cable_worst", "cable_rms", "hole_worst", "hole_rms")}
    out["xy"] = ws.poses[:, :2]
    out["ok"] = ok
    out["protocol"] = ws.protocol
    return out
