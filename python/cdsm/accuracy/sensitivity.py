"""First-order tip sensitivities and what they say: amplification maps,
the linear picture of a composite error, and where it departs from the
nonlinear solves. SI units: m, rad.

Sensitivities (Rust core, ``rust/sensitivity.rs``; implicit function theorem,
the cable solve keeps the upper-cable lengths)::

    dS/dl     =  J_pose (dL_upper/dtheta)^-1                      (N, 3, n)
    dS/dholes = -J_pose (dL_upper/dtheta)^-1 dL_upper/dholes      (N, 3, 3H) over Robot.flat_holes
    dS/ddh_i  =  dS/dholes summed over the holes of upper cable i (N, 3, n)

Linear amplification (per configuration, tolerances ``t``):

* worst case: ``worst_x = sum_j |S_xj| t_j``, ``worst_y = sum_j |S_yj| t_j``,
  ``worst_xy = hypot(worst_x, worst_y)`` (a bound on |d(x, y)|);
* RMS of |d(x, y)| for uniform errors: ``sqrt(sum_{i in x,y} sum_j S_ij^2 t_j^2 / 3)``.

Error budget (:func:`error_budget`, either kind): the share of each error
group (one cable's length; one disk's hole height, or on a spatial arm every
coordinate of one cable's holes) in the linear tip-position variance pooled
over a set of configurations, ``sum_{i, j in group} S_ij^2 t_j^2 / 3``, and
the linear first guess of tolerances for a target percentile: the linear
percentile is exactly proportional to a common scale of every tolerance.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Dict, Optional

import numpy as np

from .. import deprecated
from ..inputs import CdsmInputError, as_batch, as_count, as_tolerances
from ..plant import commanded_cables, join_columns
from ..robot import Robot
from .montecarlo import hole_error_sizes, monte_carlo, plate_hole_twins
from .scenarios import PAPER_DH_TOL, PAPER_DL_TOL, deviation
from .workspace import jump_points, singular_values, sweep
from ..display import ShortRepr

__all__ = ["Sensitivities", "sensitivities", "sensitivity", "error_matrix", "tolerance_vector", "amplification",
           "linear_percentile", "linear_vs_mc", "amplification_maps", "amplification_of", "position_matrix",
           "ErrorBudget", "error_budget"]


@dataclass(frozen=True, repr=False)
class Sensitivities(ShortRepr):
    """First-order sensitivities of the tip pose at ``theta (N, n)`` rad, the
    same fields for either kind (task rows: planar ``x, y, phi``; spatial
    ``x, y, z, wx, wy, wz``, the rotation as an angular velocity).

    cable: (N, task, m_pos) d(task)/d(position-cable length), m/m (rad/m for
    the rotation rows). groups: (N, task, G) d(task)/d(error of each
    coherent hole group of the core's ``CoreRobot.structure()``, in order):
    a planar arm's hole height of each disk (the paper's dh, G = n; also
    :attr:`pair`); G = 0 where every hole coordinate is its own error (a
    spatial arm). coords: (N, task, 3H) d(task)/d(every hole coordinate) in
    the order of :attr:`cdsm.Robot.flat_holes`, or None. ok: (N,) the cable
    Jacobian has full rank (NaN rows otherwise).
    """

    theta: np.ndarray
    cable: np.ndarray
    groups: np.ndarray
    coords: Optional[np.ndarray]
    ok: np.ndarray
    #: the planar layout (2n, n+1, 2, 2) of the deprecated :attr:`holes`: each slot's index in ``coords``, -1 where
    #: no hole (None: the layout is ``coords``'s)
    _slots: Optional[np.ndarray] = field(default=None, compare=False)

    @property
    def pair(self) -> Optional[np.ndarray]:
        """:attr:`groups` where the hole errors group coherently (a planar
        arm's per disk, (N, 3, n)), else None."""
        return self.groups if self.groups.shape[-1] else None

    @property
    def hole_errors(self) -> Optional[np.ndarray]:
        """The sensitivities to the hole errors a Monte Carlo draws
        (:func:`cdsm.accuracy.montecarlo.error_widths`): :attr:`groups` where
        they group coherently (planar, per disk's hole height), else
        :attr:`coords` (spatial, per hole coordinate); None if not computed."""
        return self.groups if self.groups.shape[-1] else self.coords

    @property
    def holes(self) -> Optional[np.ndarray]:
        """Deprecated (one release): :attr:`coords` in the shape of cdsm 0.2:
        a planar arm's (N, 3, 2n, n+1, 2, 2) planar layout (slots that are no
        hole 0, NaN on rows not ``ok``; ``z`` dropped), any other arm's
        :attr:`coords` as they are."""
        warnings.warn("Sensitivities.holes is deprecated and will be removed in the next release; use "
                      "Sensitivities.coords (N, task, 3H), over Robot.flat_holes for either kind",
                      DeprecationWarning, stacklevel=2)
        if self.coords is None or self._slots is None:
            return self.coords
        s = self._slots
        empty = np.where(self.ok, 0.0, np.nan).reshape((-1, 1) + (1,) * s.ndim)
        return np.where(s >= 0, self.coords[:, :, np.maximum(s, 0)], empty)


def _planar_slots(robot: Robot) -> np.ndarray:
    """(2n, n+1, 2, 2) int: each slot of the planar hole layout (cable, disk,
    face a/b, x/y) as an index into :attr:`Robot.flat_holes`, -1 where no
    cable has a hole."""
    n = robot.n
    slots = np.full((2 * n, n + 1, 2, 2), -1, dtype=np.int64)
    k = 0
    for c, e in enumerate(robot.cable_ends):
        for i in range(2 * e + 1):
            d, f = (0, 1) if i == 0 else ((i + 1) // 2, 1 - i % 2)
            slots[c, d, f] = (k + 3 * i, k + 3 * i + 1)
        k += 3 * (2 * e + 1)
    return slots


def sensitivities(robot: Robot, theta, holes: bool = False) -> Sensitivities:
    """Analytic tip sensitivities (Rust core) over ``theta (N, n)`` rad (or
    (n,)); ``holes``: also :attr:`Sensitivities.coords`."""
    t, _ = as_batch("theta", theta, robot.n)
    res = robot.core.sensitivity(t, bool(holes), robot.threads)
    ok = np.asarray(res.ok, bool)
    rows = (len(t), robot.kind.task)
    coherent = sum(g["coherent"] for g in robot.core.structure()["hole_groups"])
    coords = None if res.coords is None else res.coords.reshape(rows + (len(robot.flat_holes),))
    slots = _planar_slots(robot) if robot.kind.pair_holes else None
    return Sensitivities(t, res.cable.reshape(rows + (len(robot.position_cables),)),
                         res.groups.reshape(rows + (coherent,)), coords, ok, slots)


def sensitivity(robot: Robot, theta) -> np.ndarray:
    """First-order tip sensitivity to the upper-cable lengths: d[x, y, phi]/dL
    (N, 3, n) = J_pose · (dL_upper/dtheta)^-1 (m/m and rad/m), theta (N, n)
    rad. NaN where the cable Jacobian is singular (the ``cable`` part of
    :func:`sensitivities`)."""
    return sensitivities(robot, theta).cable


def error_matrix(sens: Sensitivities) -> np.ndarray:
    """(N, 2, 2n) d(x, y)/d[dl_1..dl_n, dh_1..dh_n], m/m: the linear map from
    the allocation's error vector to the tip position error."""
    return np.concatenate([sens.cable[:, :2, :], sens.pair[:, :2, :]], axis=2)


def tolerance_vector(robot: Robot, dl_tol, dh_tol) -> np.ndarray:
    """(2n,) tolerances, m: ``dl_tol`` per upper cable then ``dh_tol`` per disk
    (each a scalar or (n,), finite and >= 0)."""
    return np.concatenate([as_tolerances("dl_tol", dl_tol, robot.n), as_tolerances("dh_tol", dh_tol, robot.n)])


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
    """Pooled p-th percentile (m) of the tip position error |d(x, y)| (or
    |d(x, y, z)|) over all configurations under the linear model ``m (N, d,
    k)`` (d = 2 or 3) with independent uniform errors within ``±tol (k,)``
    (``samples`` common draws). Exactly proportional to ``tol``."""
    rng = np.random.default_rng([as_count("seed", seed), 7])
    v = rng.uniform(-1.0, 1.0, (as_count("samples", samples, 1), m.shape[2])) * tol
    ok = np.isfinite(m).all(axis=(1, 2))
    e = np.einsum("nik,sk->nsi", m[ok], v)
    return float(np.percentile(np.sqrt((e ** 2).sum(axis=-1)), p))


# ---------------------------------------------------------------------------
# where the linear picture holds
# ---------------------------------------------------------------------------
def linear_vs_mc(robot: Robot, protocol: str = "joint", dl_tol=PAPER_DL_TOL, dh_tol=PAPER_DH_TOL,
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
    if ws is None:
        ws = sweep(robot, protocol)
    ok = np.asarray(ws.reachable, bool) & np.isfinite(ws.theta0).all(axis=1)
    t = np.where(ok[:, None], ws.theta0, 0.0)
    n = robot.n
    sens = sensitivities(robot, t)
    amp = amplification(sens, dl_tol, dh_tol)
    tol = tolerance_vector(robot, dl_tol, dh_tol)
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
    paper's attitude-0 protocol on the ±30°/5° grid; spatial arms: give
    ``ws``, e.g. :func:`cdsm.accuracy.workspace.sample`): per configuration
    the nominal tip (``xy`` (N, 2), ``tip`` (N, 2 or 3), m) and the
    amplification per unit tolerance of the tip position: ``cable_worst``,
    ``cable_rms`` (mm of tip per mm on every position cable), ``hole_worst``,
    ``hole_rms`` (planar: per mm on every disk's hole height; spatial: per mm
    on every coordinate of every hole). Worst: the norm over the position
    axes of ``sum_j |S_ij|``; RMS: ``sqrt(sum_ij S_ij^2 / 3)``. NaN where the
    configuration is unreachable or the cable Jacobian singular."""
    if ws is None:
        ws = sweep(robot, protocol)
    ok = np.asarray(ws.reachable, bool) & np.isfinite(ws.theta0).all(axis=1)
    t = np.where(ok[:, None], ws.theta0, 0.0)
    cab, hol = _position_blocks(robot, t)
    return amplification_of(robot, ws, cab, hol, ok)


def amplification_of(robot: Robot, ws, cable: np.ndarray, hole: np.ndarray, ok: np.ndarray) -> dict:
    """The maps of :func:`amplification_maps` from the sensitivities of the
    tip position to the cable lengths ``cable`` (N, d, m) and to the hole
    errors ``hole`` (N, d, k), m/m, at the configurations of ``ws``, NaN where
    not ``ok`` (N,)."""
    out = {}
    for name, m in (("cable", cable), ("hole", hole)):
        out[f"{name}_worst"] = np.where(ok, np.linalg.norm(np.abs(m).sum(axis=2), axis=1), np.nan)
        out[f"{name}_rms"] = np.where(ok, np.sqrt((m ** 2).sum(axis=(1, 2)) / 3.0), np.nan)
    out["xy"] = ws.poses[:, :2]
    out["tip"] = ws.poses[:, :robot.kind.dim]
    out["ok"] = ok
    out["protocol"] = ws.protocol
    return out


def _position_blocks(robot: Robot, theta: np.ndarray):
    """(cable (N, d, m_pos), holes (N, d, k)) sensitivities of the tip
    position (d = 2 planar, 3 spatial) to the position-cable lengths and to
    the hole errors (planar: each disk's hole height; spatial: every hole
    coordinate), m/m; a zero-thickness disk's face-b hole takes its face-a
    twin's error (:func:`~cdsm.accuracy.montecarlo.plate_hole_twins`: its
    column joins the twin's and is 0), as the Monte Carlo draws them."""
    s = sensitivities(robot, theta, holes=robot.kind.hole_errors_per_coordinate)
    d = robot.kind.dim
    h = s.hole_errors[:, :d, :]
    twins = plate_hole_twins(robot)
    if twins[0].size:
        h = join_columns(h, twins)
    return s.cable[:, :d, :], h


def position_matrix(robot: Robot, theta) -> np.ndarray:
    """(N, d, m_pos + k) linear map from every error (the position-cable
    lengths, then the hole errors as in :func:`amplification_maps`) to the
    tip position (d = 2 planar, 3 spatial), m/m, at ``theta`` (N, n) rad.
    Planar arms: :func:`error_matrix`. NaN rows where the cable Jacobian is
    singular."""
    t, _ = as_batch("theta", theta, robot.n)
    return np.concatenate(_position_blocks(robot, t), axis=2)


@deprecated.renamed_fields(kinds="group_types")
@dataclass(frozen=True)
class ErrorBudget:
    """The linear tip-position error budget of a set of configurations
    (:func:`error_budget`).

    groups: (G,) labels (``"cable 3"``, ``"disk 2's holes"`` or ``"cable 3's
    holes"``). group_types: (G,) ``"length"`` or ``"holes"`` (``kinds``:
    its deprecated name, one release). tolerance: (G,) the
    tolerance of each group, m (a hole group: each coordinate's). share: (G,)
    share of the linear variance of the tip position, pooled over the
    configurations (sums to 1). rms: (G,) RMS over the configurations of the
    group's linear effect on the tip position per unit tolerance (m/m).
    matrix: (N', d, k) :func:`position_matrix` (the finite rows the linear
    percentile was taken over, see :func:`error_budget`); columns:
    (k,) the group of every column; tol: (k,) every column's tolerance, m.
    linear_m: the pooled ``percentile`` of |d position| under the linear
    model at these tolerances, m. configurations: rows used (finite
    sensitivities). seed, samples: the linear percentile's draws."""

    groups: tuple
    group_types: tuple
    tolerance: np.ndarray
    share: np.ndarray
    rms: np.ndarray
    matrix: np.ndarray
    columns: np.ndarray
    tol: np.ndarray
    percentile: float
    linear_m: float
    configurations: int
    seed: int = 0
    samples: int = 2000

    def for_target(self, target_m: float, shape: str = "ratio") -> np.ndarray:
        """(G,) linear first guess of the tolerances (m) that put the pooled
        percentile of |d position| at ``target_m``: ``"ratio"`` scales every
        tolerance alike; ``"equal-effect"`` makes every group add equally to
        the linear variance (tolerance ∝ 1 / rms; inf for a group with no
        effect). Monte Carlo verifies (``cdsm tolerance``)."""
        if shape == "ratio":
            return self.tolerance * (float(target_m) / self.linear_m)
        if shape != "equal-effect":
            raise CdsmInputError(f"`shape`: expected 'ratio' or 'equal-effect', got {shape!r}")
        with np.errstate(divide="ignore"):
            g = np.where(self.rms > 0, 1.0 / np.maximum(self.rms, 1e-300), 0.0)
        p1 = linear_percentile(self.matrix, g[self.columns], self.percentile, samples=self.samples, seed=self.seed)
        with np.errstate(divide="ignore"):
            return np.where(self.rms > 0, g * (float(target_m) / p1), np.inf)


def error_budget(robot: Robot, theta, dl_tol, dh_tol, percentile: float = 95.0, samples: int = 2000,
                 seed: int = 0, matrix: Optional[np.ndarray] = None) -> ErrorBudget:
    """The linear error budget (module doc) at ``theta`` (N, n) rad for
    tolerances ``dl_tol`` (per position cable: scalar or (m_pos,), m) and
    ``dh_tol`` (planar: per disk's hole height, scalar or (n,); spatial: per
    hole coordinate, scalar or (3 H,), m), with the pooled linear
    ``percentile`` over ``samples`` common draws (``seed``). The linear
    percentile costs ``N samples d k`` multiply-adds; past 1e8 it takes fewer
    draws (not below 64), then every j-th configuration (the shares use
    every one). ``matrix`` (N, d, k): the linear map to use instead of
    :func:`position_matrix` at ``theta`` (an elastic arm's, from its commands:
    :func:`cdsm.accuracy.plant_errors.position_matrix_commands`)."""
    t, _ = as_batch("theta", theta, robot.n)
    m = position_matrix(robot, t) if matrix is None else np.asarray(matrix, dtype=np.float64)
    m = m[np.isfinite(m).all(axis=(1, 2))]
    # the linear percentile costs N * samples * d * k multiply-adds: fewer draws, then fewer rows, past 1e8
    work = max(m.shape[1] * m.shape[2], 1)
    samples = min(int(samples), max(64, 100_000_000 // max(len(m) * work, 1)))
    lin_rows = m[::max(1, -(-len(m) * samples * work // 100_000_000))]
    pos = commanded_cables(robot)
    mp = len(pos)
    sizes = hole_error_sizes(robot)  # the hole errors of each group (the core's structure)
    hole_of_col = np.repeat(np.arange(len(sizes)), sizes)
    hole_groups = [robot.kind.hole_group.format(g + 1) for g in range(len(sizes))]
    dht = as_tolerances("dh_tol", dh_tol, int(sizes.sum()))
    dlt = as_tolerances("dl_tol", dl_tol, mp)
    groups = tuple([f"cable {c + 1}" for c in pos] + hole_groups)
    group_types = tuple(["length"] * mp + ["holes"] * len(hole_groups))
    columns = np.concatenate([np.arange(mp), mp + hole_of_col]).astype(np.int64)
    tol = np.concatenate([dlt, dht])
    G = len(groups)
    col_var = (m ** 2).sum(axis=1).mean(axis=0) if len(m) else np.zeros(len(tol))  # per unit tolerance
    var = np.bincount(columns, weights=col_var * tol ** 2 / 3.0, minlength=G)
    rms = np.sqrt(np.bincount(columns, weights=col_var, minlength=G))
    gtol = np.array([tol[columns == g].max() if (columns == g).any() else 0.0 for g in range(G)])
    share = var / var.sum() if var.sum() > 0 else np.zeros(G)
    lin = linear_percentile(lin_rows, tol, percentile, samples=samples, seed=seed) if len(m) else float("nan")
    return ErrorBudget(groups, group_types, gtol, share, rms, lin_rows, columns, tol, float(percentile), lin,
                       int(len(m)), int(seed), int(samples))
