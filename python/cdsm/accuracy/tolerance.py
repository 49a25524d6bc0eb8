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

Spatial arms (the same :func:`allocate`, its groups from the core's hole
structure and its policy from the kind, :attr:`cdsm.kinds.Kind.allocation`):
the errors are uniform in ``±tc_j`` on every position-controlled cable's
length and in
``±th_c`` on every coordinate (x, y, z) of every hole of cable ``c`` (one
tolerance per cable's holes; each coordinate an independent error);
``shape = w * [base_cable ... ; base_hole ...]``, or with
``shape="equal-effect"`` ``w`` over the RMS (over the region) of the error
group's linear effect on |d(x, y, z)| (a hole group: the root sum of squares
over its coordinates), so every group adds equally to the linear tip
variance (a group of no effect gets the largest tolerance of the others;
the planar rule instead caps the effect below at 1e-12). The linear first
guess, as for planar arms, comes from the sensitivities of
:mod:`cdsm.accuracy.sensitivity` (the general ones of the one model); Monte
Carlo then brackets and bisects ``alpha`` (:class:`Allocation`).
Regions are cut over the two position axes along which the tips spread most
(a planar arm's X, Y).

The pooled percentile over a region merges the per-configuration histograms
of the Monte-Carlo study (:attr:`cdsm.accuracy.MonteCarlo.hist`; 232 log
bins per decade, the percentile is the geometric middle of its bin: within
0.498 % of the sample quantile). Failed solves count as errors above every
bin.
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..files import read_table, read_text
from ..inputs import CdsmInputError, as_batch, as_tolerances
from ..kinds import SPATIAL, Kind
from .. import plant
from ..plant import commanded_cables
from ..robot import Robot
from . import plant_errors
from .montecarlo import QUANTILE_BOUND, MonteCarlo, hist_quantile, hole_error_sizes, monte_carlo
from .scenarios import PAPER_DH_TOL, PAPER_DL_TOL
from .sensitivity import linear_percentile, position_matrix
from .sampling import sample_configurations
from .workspace import joint_grid, paper_ik_seed

__all__ = ["HIST_RESOLUTION", "pooled_percentile", "Allocation", "allocate", "distribution",
           "region_cells", "parse_region", "hole_tolerances",
           "SPATIAL_REGION_DEFAULT", "error_tolerances",
           "read_tolerances", "default_configurations", "default_commands", "ELASTIC_COMMANDS"]

#: Relative bound of the Monte-Carlo quantiles the allocation reads
#: (:data:`cdsm.accuracy.montecarlo.QUANTILE_BOUND`, 0.498 %).
HIST_RESOLUTION = QUANTILE_BOUND


def pooled_percentile(mc: MonteCarlo, p: float, rows=None, interpolate: bool = False) -> float:
    """p-th percentile (m) of the position error pooled over the
    configurations ``rows`` (default all) of a Monte-Carlo study: the
    per-configuration histograms are summed; failed solves count as above
    every bin (inf if they reach the percentile). Within
    :data:`HIST_RESOLUTION` of the pooled sample quantile
    (:func:`~cdsm.accuracy.montecarlo.hist_quantile`); with ``interpolate``
    a log-linear interpolation inside the bin (an estimate, not a bound)."""
    sel = slice(None) if rows is None else rows
    hist = mc.pooled_hist(rows)
    failed = int(mc.failed[sel].sum())
    return float(hist_quantile(hist[None], p, np.array([failed]), interpolate=interpolate)[0])


# ---------------------------------------------------------------------------
# allocation
# ---------------------------------------------------------------------------
class Verdicts:
    """What an allocation answer says of itself (``achieved_m``,
    ``achieved_1p25_m`` and ``target_m`` in m)."""

    achieved_m: float
    achieved_1p25_m: float
    target_m: float

    @property
    def holds(self) -> bool:
        """The verified percentile is within the target."""
        return bool(self.achieved_m <= self.target_m)

    @property
    def not_loose(self) -> bool:
        """Every tolerance × 1.25 breaks the target: the answer is not loose."""
        return bool(self.achieved_1p25_m > self.target_m)


@dataclass
class Allocation(Verdicts):
    """Answer of :func:`allocate`, either kind (all lengths in m unless the
    key says mm).

    cable_length_tol_m: (m_pos,) ± tolerance per position-controlled cable
    (a planar arm's upper cables). hole_tol_m: ± tolerance per hole group
    (planar: (n,) per disk's hole height; spatial: (cables,) on every
    coordinate of each cable's holes), written to JSON under the kind's
    :attr:`~cdsm.kinds.Kind.hole_tolerance_key` (``hole_height_tol_m``,
    ``hole_tol_m``). achieved_m: the pooled percentile of the tip position
    error (|d(x, y)|, spatial |d(x, y, z)|) over the region verified by
    Monte Carlo at this answer (<= target). achieved_1p25_m: the same with
    every tolerance × 1.25 (> target: the answer is not loose). alpha:
    common scale of ``shape`` (m per unit). linear_m: the linear model's
    percentile at the answer; alpha_linear: its first guess. history:
    (alpha, achieved) of every Monte-Carlo evaluation. kind: the arm's kind.
    """

    cable_length_tol_m: np.ndarray
    hole_tol_m: np.ndarray
    achieved_m: float
    achieved_1p25_m: float
    target_m: float
    percentile: float
    alpha: float
    shape: np.ndarray
    linear_m: float
    alpha_linear: float
    failed: int
    kind: Kind
    history: List[tuple] = field(default_factory=list)
    params: dict = field(default_factory=dict)

    @property
    def hole_height_tol_m(self) -> np.ndarray:
        """The hole tolerances under a planar arm's name (per disk's hole
        height, m): :attr:`hole_tol_m`."""
        return self.hole_tol_m

    def to_json(self) -> dict:
        """``kind``, ``cable_length_tol_m``, the hole tolerances under the
        kind's key (``hole_height_tol_m``; spatial ``hole_tol_m``: what ``cdsm
        montecarlo --tolerances`` reads), ``achieved_mm`` and extras."""
        return {
            "kind": str(self.kind),
            "cable_length_tol_m": [float(v) for v in self.cable_length_tol_m],
            self.kind.hole_tolerance_key: [float(v) for v in self.hole_tol_m],
            "achieved_mm": self.achieved_m * 1e3,
            "achieved_interpolated_mm": self.params.get("achieved_interpolated_m", float("nan")) * 1e3,
            "target_mm": self.target_m * 1e3,
            "percentile": self.percentile,
            "holds": self.holds,
            "achieved_at_1p25_tol_mm": self.achieved_1p25_m * 1e3,
            "not_loose": self.not_loose,
            "linear_estimate_mm": self.linear_m * 1e3,
            "alpha": self.alpha,
            "alpha_linear": self.alpha_linear,
            "histogram_resolution": HIST_RESOLUTION,
            "failed_solves": self.failed,
            "monte_carlo_evaluations": [dict(alpha=a, achieved_mm=v * 1e3) for a, v in self.history],
            **self.params,
        }


def _shape(robot: Robot, em: np.ndarray, weights, base, shape: str, m: int, sizes: np.ndarray) -> np.ndarray:
    """(m + G,) the tolerance shape of :func:`allocate`, per error group:
    the m commanded cables, then the G hole groups (``sizes``:
    :func:`~cdsm.accuracy.montecarlo.hole_error_sizes`); ``em`` the linear
    map (N, d, m + sum(sizes)) of every error to the tip position."""
    groups = [m, len(sizes)]
    count = sum(groups)
    w = np.ones(count) if weights is None else np.asarray(weights, dtype=np.float64).reshape(-1)
    if w.size == 2:
        w = np.repeat(w, groups)
    if w.size != count or not np.isfinite(w).all() or (w <= 0).any():
        what = robot.kind.allocation["weights"].format(count=count, m=groups[0], groups=groups[1], finite="")
        raise CdsmInputError(f"`weights`: need 2 or {what}, got {weights}")
    if shape == "ratio":
        b = np.asarray(base, dtype=np.float64).reshape(-1)
        if b.size != 2 or not np.isfinite(b).all() or (b <= 0).any():
            raise CdsmInputError(f"`base`: need two positive lengths (cable, hole), m, got {base}")
        return w * np.repeat(b, groups)
    if shape == "equal-effect":
        ok = np.isfinite(em).all(axis=(1, 2))
        per_error = np.sqrt((em[ok] ** 2).sum(axis=1).mean(axis=0))  # RMS over the region of each error's effect
        return _EQUAL_EFFECT[robot.kind.allocation["equal_effect"]](w, per_error, groups[0], sizes)
    raise CdsmInputError(f"`shape`: expected 'ratio' or 'equal-effect', got {shape!r}")


def _equal_effect_per_error(w: np.ndarray, per_error: np.ndarray, m: int, sizes: np.ndarray) -> np.ndarray:
    """Planar rule: ``w`` over each error's RMS effect (every group one
    error), in mm (an effect below 1e-12 counts as 1e-12)."""
    return w / np.maximum(per_error, 1e-12) * 1e-3


def _equal_effect_per_group(w: np.ndarray, per_error: np.ndarray, m: int, sizes: np.ndarray) -> np.ndarray:
    """Spatial rule: ``w`` over each group's effect (a hole group: the root
    sum of squares over its coordinates); a group with no effect is not
    constrained: it gets the largest shape of the others."""
    holes = np.sqrt(np.add.reduceat(per_error[m:] ** 2, np.cumsum(np.concatenate([[0], sizes[:-1]]))))
    effect = np.concatenate([per_error[:m], holes])
    with np.errstate(divide="ignore"):
        shp = np.where(effect > 0, w / np.where(effect > 0, effect, 1.0), 0.0)
    if not (shp > 0).any():
        raise CdsmInputError("the linear model gives no tip error over this region (no sensitivity)")
    return np.where(shp > 0, shp, shp.max())


#: The equal-effect rules of the kinds (:attr:`cdsm.kinds.Kind.allocation`, ``"equal_effect"``).
_EQUAL_EFFECT = {"per_error": _equal_effect_per_error, "per_group": _equal_effect_per_group}


def _scale_search(simulate, shp: np.ndarray, target: float, percentile: float, a0: float, up: Tuple[float, float],
                  down: Tuple[float, float], rel_tol: float, max_evals: int, progress: bool, overshoot: float = 1.0):
    """The largest common scale ``alpha`` of the tolerance shape ``shp`` whose
    Monte Carlo ``simulate(alpha * shp)`` keeps the pooled ``percentile`` of
    the tip error within ``target`` (m): bracket from ``a0`` by steps
    ``target / achieved`` (× ``overshoot``, clipped to ``up`` when the target
    holds and to ``down`` when not), then bisect geometrically until ``hi /
    lo <= 1 + rel_tol``. Returns ``(lo, run, history)``: ``run(alpha)`` the
    cached Monte Carlo, ``history`` the (alpha, achieved) of every evaluation."""
    cache: Dict[float, MonteCarlo] = {}
    history: List[tuple] = []

    def run(alpha: float) -> MonteCarlo:
        if alpha not in cache:
            cache[alpha] = simulate(alpha * shp)
        return cache[alpha]

    def achieved(alpha: float) -> float:
        v = pooled_percentile(run(alpha), percentile)
        history.append((float(alpha), v))
        if progress:
            print(f"  alpha {alpha:.6g}: P{percentile:g} = {v * 1e3:.4f} mm", file=sys.stderr)
        return v

    lo, hi, a = None, None, a0
    for _ in range(max_evals):
        v = achieved(a)
        if v <= target:
            lo = a
            if hi is not None:
                break
            a = a * float(np.clip(target / v * overshoot, *up)) if v > 0 else a * up[1]
        else:
            hi = a
            if lo is not None:
                break
            a = a * float(np.clip(target / v * (2.0 - overshoot), *down))
    if lo is None or hi is None:
        raise CdsmInputError(f"tolerance allocation: could not bracket the target (history {history})")
    evals = len(history)
    while hi / lo > 1.0 + rel_tol and evals < max_evals:
        mid = float(np.sqrt(lo * hi))
        if achieved(mid) <= target:
            lo = mid
        else:
            hi = mid
        evals += 1
    return lo, run, history


class _Region:
    """The configurations an allocation or a distribution applies the errors
    at, and the arm's own Monte Carlo there: a rigid arm's joint angles
    ``theta`` (N, n) rad (the core's kernel, :func:`monte_carlo`), an elastic
    arm's commands ``dL`` (N, m_c) m (the plant's: every sample settled at its
    own equilibrium, :func:`cdsm.accuracy.plant_errors.monte_carlo_commands`;
    default :func:`default_commands`). ``m``: the cable-length tolerances
    (the commanded cables: position-controlled, and an elastic arm's
    displacement ones); ``sizes``: the errors of each hole group
    (:func:`~cdsm.accuracy.montecarlo.hole_error_sizes`)."""

    def __init__(self, robot: Robot, theta, commands):
        self.robot = robot
        self.m, self.sizes = len(commanded_cables(robot)), hole_error_sizes(robot)
        if robot.is_elastic:
            if theta is not None:
                raise CdsmInputError("`theta`: an elastic arm's configurations are the equilibria of its commands; "
                                     "give `commands` (N, m_c) m")
            self.commands = default_commands(robot) if commands is None else \
                plant_errors.nominal_commands(robot, commands)[1]
            self.theta = None
        else:
            if commands is not None:
                raise CdsmInputError("`commands`: for elastic arms (a rigid arm's configurations are its joint "
                                     "angles `theta`)")
            self.theta = as_batch("theta", default_configurations(robot) if theta is None else theta, robot.n)[0]
            self.commands = None

    def __len__(self) -> int:
        return len(self.theta if self.commands is None else self.commands)

    def position_matrix(self) -> np.ndarray:
        """(N, d, m + sum(sizes)) the linear map of every error to the tip position, m/m."""
        if self.commands is None:
            return position_matrix(self.robot, self.theta)
        return plant_errors.position_matrix_commands(self.robot, self.commands)

    def tips(self) -> np.ndarray:
        """(N, d) the nominal tip positions, m."""
        if self.commands is None:
            return self.robot.fk(self.theta)[:, :self.robot.kind.dim]
        t, d = plant_errors.nominal_commands(self.robot, self.commands)
        return plant.predict(self.robot, np.zeros(plant.size(self.robot)), t, d)[0][:, :self.robot.kind.dim]

    def monte_carlo(self, dl: np.ndarray, dh: np.ndarray, samples: int, seed: int) -> MonteCarlo:
        """The Monte Carlo at the tolerances ``dl`` (m,) and ``dh`` (one per hole error), m."""
        if self.commands is None:
            return monte_carlo(self.robot, self.theta, samples=samples, seed=seed, dl_tol=dl, dh_tol=dh,
                               progress=False)
        tol = {"cable_offset": dl, plant_errors.hole_block(self.robot): dh}
        return plant_errors.monte_carlo_commands(self.robot, self.commands, samples=samples, seed=seed,
                                                 tolerances=tol, progress=False)


def allocate(robot: Robot, target_m: float, theta=None, percentile: float = 95.0,
             weights=None, base=(PAPER_DL_TOL, PAPER_DH_TOL), shape: str = "ratio",
             samples: int = 1000, seed: int = 0, rel_tol: float = 0.01,
             max_evals: int = 30, progress: bool = False, commands=None):
    """Largest tolerances (common scale ``alpha`` of the cost shape, see the
    module doc) such that the pooled ``percentile`` of the tip position
    error (|d(x, y)|, spatial |d(x, y, z)|) over the configurations ``theta
    (N, n)`` rad (errors applied at these angles; default
    :func:`default_configurations`: the ±30°/5° joint grid, spatial 1000
    Sobol samples of the joint box) stays within ``target_m``.

    1. Sensitivities (Rust) -> linear model -> ``alpha_lin = T / P_lin(1)``
       (the linear percentile is proportional to alpha).
    2. Monte Carlo in the Rust core (``samples`` per configuration, common
       random numbers: the same seed at every alpha) brackets and bisects
       alpha until ``hi / lo <= 1 + rel_tol``; the answer is ``lo``, verified
       ``achieved(lo) <= T``, and ``achieved(1.25 lo) > T`` is evaluated.

    The tolerances are one per position-controlled cable and one per hole
    group (planar: a disk's hole height; spatial: every coordinate of a
    cable's holes); ``weights``: 2 or one per group. Returns an
    :class:`Allocation` (its JSON names the hole tolerances by the kind's
    :attr:`~cdsm.kinds.Kind.hole_tolerance_key`).

    An elastic arm (:attr:`Robot.is_elastic`) is allocated at its commands
    ``commands`` (N, m_c) m (default :func:`default_commands`; ``theta`` is
    refused) by the same search: the linear guess from the plant's
    sensitivities (:func:`cdsm.accuracy.plant_errors.position_matrix_commands`),
    the Monte Carlo the plant's, one tolerance per commanded cable (its rest
    length, ``cable_offset``) and per hole group.
    """
    kind = robot.kind
    region = _Region(robot, theta, commands)
    target = float(target_m)
    if not (np.isfinite(target) and target > 0):
        raise CdsmInputError(f"`target_m`: must be positive and finite, got {target_m}")
    if not 0.0 < float(percentile) < 100.0:
        raise CdsmInputError(f"`percentile`: must be within (0, 100), got {percentile}")
    m, sizes = region.m, region.sizes
    em = region.position_matrix()
    shp = _shape(robot, em, weights, base, shape, m, sizes)

    def per_error(tol: np.ndarray) -> np.ndarray:  # a hole group's tolerance on each of its errors
        return np.concatenate([tol[:m], np.repeat(tol[m:], sizes)])

    p_lin1 = linear_percentile(em, per_error(shp), percentile, seed=seed)
    if not (np.isfinite(p_lin1) and p_lin1 > 0):
        raise CdsmInputError("the linear model gives no tip error over this region (no sensitivity)")
    a_lin = target / p_lin1
    lo, run, history = _scale_search(
        lambda tol: region.monte_carlo(tol[:m], per_error(tol)[m:], samples, seed),
        shp, target, percentile, a_lin, (1.02, 1.3), (0.5, 0.98), rel_tol, max_evals, progress)
    mc = run(lo)
    ach = pooled_percentile(mc, percentile)
    ach_i = pooled_percentile(mc, percentile, interpolate=True)
    a125 = pooled_percentile(run(1.25 * lo), percentile)
    tol = lo * shp
    params = dict(achieved_interpolated_m=ach_i, samples=int(samples), seed=int(seed), configurations=int(len(region)),
                  shape=shape, weights=None if weights is None else np.asarray(weights, float).ravel().tolist(),
                  base_m=[float(v) for v in np.asarray(base, float).ravel()], robot=robot.name, n=robot.n)
    if kind.cable_numbers:  # the commanded cables by their numbers in the robot file
        params["position_cables"] = [c + 1 for c in commanded_cables(robot)]
    return Allocation(cable_length_tol_m=tol[:m], hole_tol_m=tol[m:], achieved_m=ach, achieved_1p25_m=a125,
                      target_m=target, percentile=float(percentile), alpha=float(lo), shape=shp,
                      linear_m=float(lo * p_lin1), alpha_linear=float(a_lin), failed=int(mc.failed.sum()), kind=kind,
                      history=history, params=params)


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


def default_configurations(robot: Robot) -> np.ndarray:
    """(N, n) rad: where an allocation or a distribution applies the errors
    by default — the paper's ±30°/5° joint grid where its grid protocols
    apply (planar arms: :attr:`cdsm.kinds.Kind.grid_protocols`), else 1000
    configurations sampled in the joint box (scrambled Sobol, seed 0)."""
    return joint_grid(robot.n) if robot.kind.grid_protocols else sample_configurations(robot, 1000)


#: Commands an elastic arm's allocation or distribution applies the errors at by default.
ELASTIC_COMMANDS = 200


def default_commands(robot: Robot, count: int = ELASTIC_COMMANDS, seed: int = 0) -> np.ndarray:
    """(N, m_c) m: an elastic arm's region by default — ``count`` commands
    sampled in the box ±:data:`~cdsm.accuracy.plant_errors.COMMAND_RANGE` on
    every commanded cable (scrambled Sobol, ``seed``;
    :func:`cdsm.accuracy.plant_errors.sample_commands`), those the nominal
    plant settles."""
    ws = plant_errors.sample_commands(robot, count, seed=seed)
    return ws.commands[ws.reachable]


def distribution(robot: Robot, dl_tol, dh_tol, theta=None, percentiles: Sequence[float] = (50, 95, 99),
                 samples: int = 1000, seed: int = 0, cells: int = 3, mc: Optional[MonteCarlo] = None,
                 commands=None) -> dict:
    """Tip-error distribution over a region for given tolerances (m, as
    :func:`error_tolerances` takes them: planar scalars or (n,)): Monte Carlo
    in the Rust core at every configuration ``theta (N, n)`` (default
    :func:`default_configurations`). Returns ``pooled`` {P: m} over the whole
    region, ``per_config`` (N, len(percentiles)) m, and ``regions``: one row
    per non-empty cell of a ``cells``×``cells`` grid over the nominal tips
    along the two position axes along which they spread most (``axes``; a
    planar arm's X, Y; row keys named after them) with its bounds (m),
    configuration count and pooled percentiles (m). Spatial arms:
    ``dl_tol`` per position-controlled cable, ``dh_tol`` per cable's holes
    or per hole coordinate. An elastic arm: at its ``commands`` (N, m_c) m
    (as :func:`allocate`), the tolerances per commanded cable.
    """
    region = _Region(robot, theta, commands)
    dl, dh = error_tolerances(robot, dl_tol, dh_tol)
    if mc is None:
        mc = region.monte_carlo(dl, dh, samples, seed)
    tips = region.tips()
    axes = sorted(np.argsort(-np.ptp(tips, axis=0), kind="stable")[:2])
    names = [robot.kind.position_axes[k] for k in axes]
    uv = tips[:, axes]
    cell = region_cells(uv, cells)
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    w = (hi - lo) / cells
    rows = []
    for c in range(cells * cells):
        sel = np.flatnonzero(cell == c)
        if len(sel) == 0:
            continue
        iu, iv = c % cells, c // cells
        rows.append({"cell": int(c),
                     f"{names[0]}_lo_m": float(lo[0] + iu * w[0]), f"{names[0]}_hi_m": float(lo[0] + (iu + 1) * w[0]),
                     f"{names[1]}_lo_m": float(lo[1] + iv * w[1]), f"{names[1]}_hi_m": float(lo[1] + (iv + 1) * w[1]),
                     "configurations": int(len(sel)),
                     **{f"p{p:g}_m": pooled_percentile(mc, p, sel) for p in percentiles}})
    per = np.stack([mc.percentile(p) for p in percentiles], axis=1)
    return dict(pooled={float(p): pooled_percentile(mc, p) for p in percentiles}, per_config=per, regions=rows,
                cell=cell, mc=mc, dl_tol_m=dl, dh_tol_m=dh, axes=names)


# ---------------------------------------------------------------------------
# tolerances
# ---------------------------------------------------------------------------
# ---------------------------------------------------------------------------
# regions
# ---------------------------------------------------------------------------
def _region_file(spec: str, path: str, columns: List[str], what: str) -> np.ndarray:
    """The ``columns`` of a region CSV file, (N, len(columns)): a header naming
    them, or no header (or a header of other names) and exactly those columns
    in that order."""
    try:
        table = read_table(path, f"--region {what}", headerless=columns)
    except CdsmInputError as exc:
        raise CdsmInputError(f"--region {spec!r}: {exc}") from None
    cols = table.columns
    missing = [c for c in columns if c not in cols]
    named = dict(zip(columns, columns))
    if missing and len(cols) == len(columns):  # positional columns under other names
        named, missing = dict(zip(columns, cols)), []
    if missing:
        raise CdsmInputError(f"--region {spec!r}: {path!r} has no column(s) {', '.join(missing)} "
                             f"(need {', '.join(columns)}, or no header and {len(columns)} values a row)")
    return np.stack([table.numbers(named[c]) for c in columns], axis=1)


def parse_region(spec: str, robot: Robot, seed: int = 0) -> Tuple[np.ndarray, str]:
    """Joint angles (N, n) rad of a region spec, and a description:
    ``grid:LO_DEG:HI_DEG:STEP_DEG[:N]`` (every joint; a grid of more than
    20000 points, or N given, is subsampled to N (default 2000) with ``seed``),
    ``joints:FILE.csv`` (columns ``theta_1..theta_n``, rad, or no header) or
    ``poses:FILE.csv`` (columns ``x, y, phi``, m, m, rad, or no header; pose IK
    from the paper's seed; planar robots) or ``sobol:N`` (N configurations
    sampled in the joint box, scrambled Sobol with ``seed``: the default
    region of spatial robots, :data:`SPATIAL_REGION_DEFAULT`). An elastic
    arm's region is its commands (N, m_c) m: ``sobol:N`` only
    (:func:`default_commands`)."""
    kind, _, rest = spec.partition(":")
    if robot.is_elastic:
        return _command_region(spec, kind, rest, robot, seed)
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
    if kind == "sobol":
        try:
            count = int(rest)
        except ValueError:
            count = 0
        if count < 1:
            raise CdsmInputError(f"--region {spec!r}: expected sobol:N with N >= 1 configurations")
        theta = sample_configurations(robot, count, "sobol", seed=seed)
        return theta, f"{count} configurations sampled in the joint box (scrambled Sobol, seed {seed})"
    if kind == "poses" and not robot.kind.pose_regions:
        raise CdsmInputError(f"--region {spec!r}: poses are planar (x, y, phi); for a spatial robot give "
                             "joints:FILE.csv or sobol:N")
    if kind == "poses":
        p = _region_file(spec, rest, ["x", "y", "phi"], "poses")
        sol = robot.ik(p, seed=paper_ik_seed(robot.n))
        bad = np.flatnonzero(~np.asarray(sol.converged, bool))
        if len(bad):
            raise CdsmInputError(f"--region {spec!r}: pose IK failed for row(s) {bad[:5].tolist()} (unreachable?)")
        return np.atleast_2d(sol.theta), f"{len(p)} poses from {rest} (pose IK, paper seed)"
    raise CdsmInputError(f"--region {spec!r}: expected grid:LO:HI:STEP[:N], joints:FILE.csv, poses:FILE.csv "
                         "or sobol:N")


def _command_region(spec: str, kind: str, rest: str, robot: Robot, seed: int) -> Tuple[np.ndarray, str]:
    """An elastic arm's region: ``sobol:N`` commands (N, m_c) m
    (:func:`default_commands`); a region of joint angles or poses is refused
    (its configurations are the equilibria of its commands)."""
    try:
        count = int(rest) if kind == "sobol" else 0
    except ValueError:
        count = 0
    if kind != "sobol" or count < 2:
        raise CdsmInputError(f"--region {spec!r}: an elastic arm's region is sobol:N (N >= 2 commands sampled in "
                             f"±{plant_errors.COMMAND_RANGE * 1e3:g} mm on every commanded cable); its "
                             "configurations are the equilibria of its commands, not joint angles or poses")
    d = default_commands(robot, count, seed)
    return d, (f"{len(d)} of {count} commands sampled in ±{plant_errors.COMMAND_RANGE * 1e3:g} mm on every "
               f"commanded cable (scrambled Sobol, seed {seed}; those the nominal plant settles)")


# ---------------------------------------------------------------------------
# spatial arms
# ---------------------------------------------------------------------------
#: The default region of a spatial robot's allocation (``--region``).
SPATIAL_REGION_DEFAULT = SPATIAL.allocation["region"]


def hole_tolerances(robot, per_cable) -> np.ndarray:
    """(3 H,) tolerance of every hole coordinate of a spatial arm, in the
    order of ``robot.flat_holes``, from one tolerance per cable's holes
    (cables,) m."""
    sizes = [3 * (2 * e + 1) for e in robot.cable_ends]
    return np.repeat(np.asarray(per_cable, dtype=np.float64), sizes)


def error_tolerances(robot, dl_tol, dh_tol, source: str = "",
                     names: Tuple[str, str] = ("dl_tol", "dh_tol")) -> Tuple[np.ndarray, np.ndarray]:
    """The tolerances, m, of the errors a Monte Carlo draws
    (:func:`~cdsm.accuracy.montecarlo.error_widths`), either kind:
    (m_c,) from ``dl_tol``, a scalar or one per commanded cable (the
    position-controlled ones; an elastic arm's displacement ones too);
    (h,) from ``dh_tol``, a scalar, one per hole group (planar: a disk's
    hole height; spatial: every coordinate of a cable's holes) or one per
    hole error (spatial: per hole coordinate). ``names``: the two inputs'
    names in error messages (after ``source``)."""
    pre = f"{source}: " if source else ""
    m, sizes = len(commanded_cables(robot)), hole_error_sizes(robot)
    groups, errors = len(sizes), int(sizes.sum())
    out = []
    for key, value, widths in ((names[0], dl_tol, (m,)), (names[1], dh_tol, (groups, errors))):
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            raise CdsmInputError(f"{pre}`{key}` is not a number or a list of numbers") from None
        if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] not in widths):
            want = (f"{m} values (one per commanded cable)" if key == names[0] else
                    f"{groups} values ({robot.kind.words['hole_group_each']})"
                    + (f" or {errors} (one per hole coordinate)" if errors != groups else ""))
            raise CdsmInputError(f"{pre}`{key}` needs {want} or a number, got shape {arr.shape}")
        if key == names[1] and arr.ndim == 1 and arr.shape[0] == groups and groups != errors:
            arr = np.repeat(arr, sizes)
        try:
            out.append(as_tolerances(key, arr, widths[-1]))
        except CdsmInputError as exc:
            raise CdsmInputError(f"{pre}{exc}") from None
    return out[0], out[1]


def _tolerance_json(path: str) -> dict:
    """The JSON object of a tolerance file (a clear error otherwise)."""
    text = read_text(path, "tolerance")
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise CdsmInputError(f"tolerance file {path!r}: not valid JSON ({exc})") from None
    if not isinstance(data, dict):
        raise CdsmInputError(f"tolerance file {path!r}: expected a JSON object")
    return data


def read_tolerances(path: str, robot) -> Tuple[np.ndarray, np.ndarray]:
    """Tolerances of an arm of either kind from a JSON file (as ``cdsm
    tolerance --json`` writes it): ``cable_length_tol_m`` — a number or one
    per position-controlled cable, m — and the kind's hole key
    (:attr:`~cdsm.kinds.Kind.hole_tolerance_key`: planar
    ``hole_height_tol_m``, a number or one per disk; spatial ``hole_tol_m``,
    a number, one per cable (every coordinate of its holes) or one per hole
    coordinate), m (other keys are ignored). Returns (dl_tol (m_pos,),
    dh_tol) as :func:`error_tolerances`, m."""
    data = _tolerance_json(path)
    hole_key = robot.kind.hole_tolerance_key
    for key in ("cable_length_tol_m", hole_key):
        if key not in data:
            extra = (" (`hole_height_tol_m` is the planar per-disk tolerance; a spatial robot takes `hole_tol_m` "
                     "per cable's holes or per hole coordinate)" if key == "hole_tol_m"
                     and "hole_height_tol_m" in data else "")
            raise CdsmInputError(f"tolerance file {path!r}: missing key {key!r}{extra}")
    return error_tolerances(robot, data["cable_length_tol_m"], data[hole_key], f"tolerance file {path!r}",
                            ("cable_length_tol_m", hole_key))
