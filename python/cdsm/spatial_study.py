"""The seed paper's accuracy methods on a spatial arm (``kind = "spatial"``,
``docs/spatial.md``): the role of :mod:`cdsm.paper` for 3-D arms.

Over configurations sampled in the joint box (a scrambled Sobol sequence —
a full grid is impossible past a few joints), :func:`run` computes the
workspace (end-frame poses), single-error scenarios, a Monte-Carlo study,
the singular measure of the position Jacobian and the statics (tensions of
the position-controlled cables, slack configurations). Jump points are
judged against each configuration's nearest neighbours in joint space
(:func:`cdsm.accuracy.sampling.jump_points`).

Single errors (the paper's Fig. 5 and 6 in 3-D), on each position-controlled
cable ``c`` (numbered 1.. in file order, as the robot file's ``[[cables]]``):

* ``cable{c}±``  — ±1 mm on its commanded length;
* ``radial{c}±`` — ±0.35 mm on all its holes, along the radius in the face
  plane (outward: ``(0, y, z) / |(y, z)|`` in each face frame; a hole on the
  axis does not move) — the planar "error on disk i's holes" of the upper
  cable;
* ``normal{c}±`` — ±0.35 mm on all its holes along the disk normal (face
  ``x``).

Holes of force-controlled cables do not move the tip of the rigid model
(their lengths are not commanded), so they get no scenario; the Monte Carlo
perturbs them all the same.

Monte Carlo: uniform errors within ±1 mm on every position-controlled cable
and ±0.35 mm on every hole coordinate (x, y, z of every hole, independent):
the paper's bound applied per coordinate, as a drawing tolerance is. Every
array is SI (m, rad, N); the report converts to mm and degrees.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

from .accuracy import montecarlo, sampling, scenarios
from .inputs import CdsmInputError
from .progress import Progress

__all__ = ["SpatialScenario", "SpatialScenarioResult", "SpatialStudy", "spatial_scenarios", "hole_direction",
           "run", "KINDS", "DEFAULT_CONFIGURATIONS", "DEFAULT_SAMPLES", "DEFAULT_DL_TOL", "DEFAULT_DH_TOL"]

#: Scenario kinds: the cable's length, its holes along the radius, its holes along the disk normal.
KINDS = ("cable", "radial", "normal")
#: Defaults of :func:`run`.
DEFAULT_CONFIGURATIONS = 1000
DEFAULT_SAMPLES = 200
#: Monte-Carlo bounds: per position-controlled cable (m) and per hole coordinate (m).
DEFAULT_DL_TOL = scenarios.PAPER_DL_TOL
DEFAULT_DH_TOL = scenarios.PAPER_DH_TOL


@dataclass(frozen=True)
class SpatialScenario:
    """One single error. key: ``cable3+``, ``radial3-``, ``normal3+`` (cable
    number 1.. in file order). kind: one of :data:`KINDS`. cable: the cable's
    file index (0-based). sign: ±1. size: the error's magnitude, m. dL:
    (m_pos,) error on the position-controlled cables' lengths, m. dholes:
    (3 H,) error on every hole coordinate (the order of ``robot.flat_holes``),
    m, or None."""

    key: str
    label: str
    kind: str
    cable: int
    sign: float
    size: float
    dL: np.ndarray
    dholes: Optional[np.ndarray]


def hole_direction(robot, cable: int, kind: str) -> np.ndarray:
    """(3 H,) unit moves of cable ``cable``'s holes (zero elsewhere), in the
    order of ``robot.flat_holes``: ``"radial"`` outward in each face plane,
    ``"normal"`` along the face's x axis."""
    if kind not in ("radial", "normal"):
        raise CdsmInputError(f"`kind`: expected 'radial' or 'normal', got {kind!r}")
    parts = []
    for c, h in enumerate(robot.holes):
        d = np.zeros_like(h)
        if c == cable:
            if kind == "normal":
                d[:, 0] = 1.0
            else:
                r = np.linalg.norm(h[:, 1:], axis=1)
                with np.errstate(invalid="ignore", divide="ignore"):
                    d[:, 1:] = np.where(r[:, None] > 0, h[:, 1:] / r[:, None], 0.0)
        parts.append(d.ravel())
    return np.concatenate(parts)


def spatial_scenarios(robot, cable_error: float = scenarios.PAPER_DL_TOL,
                      hole_error: float = scenarios.PAPER_DH_TOL) -> List[SpatialScenario]:
    """The single-error scenarios of a spatial arm (module doc): for each
    position-controlled cable ±``cable_error`` on its length, then
    ±``hole_error`` radially and along the normal on its holes (m)."""
    pos = robot.position_cables
    out = []
    for i, c in enumerate(pos):
        for sign in (-1.0, 1.0):
            dl = np.zeros(len(pos))
            dl[i] = sign * cable_error
            out.append(SpatialScenario(f"cable{c + 1}{'+' if sign > 0 else '-'}",
                                       f"{sign * cable_error * 1e3:+g} mm on cable {c + 1}'s length",
                                       "cable", c, sign, float(cable_error), dl, None))
    for kind, what in (("radial", "radially"), ("normal", "along the disk normal")):
        for c in pos:
            unit = hole_direction(robot, c, kind)
            for sign in (-1.0, 1.0):
                out.append(SpatialScenario(f"{kind}{c + 1}{'+' if sign > 0 else '-'}",
                                           f"{sign * hole_error * 1e3:+g} mm {what} on cable {c + 1}'s holes",
                                           kind, c, sign, float(hole_error), np.zeros(len(pos)),
                                           sign * hole_error * unit))
    return out


@dataclass
class SpatialScenarioResult:
    """A scenario over the sampled configurations: dS (N, 6) [dX, dY, dZ (m),
    rotation vector (rad, base frame)], NaN where the perturbed solve failed;
    ok (N,); jumps of the position deviation."""

    scenario: SpatialScenario
    dS: np.ndarray
    ok: np.ndarray
    jumps: sampling.SampledJumps

    @property
    def position(self) -> np.ndarray:
        """(N,) |d(X, Y, Z)|, m."""
        return np.linalg.norm(self.dS[:, :3], axis=1)

    @property
    def rotation(self) -> np.ndarray:
        """(N,) rotation angle of the end frame's change, rad."""
        return np.linalg.norm(self.dS[:, 3:], axis=1)


@dataclass
class SpatialStudy:
    """Everything the spatial study computes; the report reads it.

    theta: (N, n) sampled configurations, rad. pose: (N, 6) their end poses
    [x, y, z (m), rotation vector (rad)]. scenarios: the single errors.
    monte_carlo: per-configuration statistics (quantities dX, dY, dZ, dXYZ,
    rot). singular: (N,) sigma_min / sigma_max of the position Jacobian.
    tensions: (N, m_pos) N, NaN where slack. feasible: (N,) no slack cable.
    neighbours: (N, k) nearest neighbours in joint space (jumps).
    """

    robot: object
    theta: np.ndarray
    pose: np.ndarray
    scenarios: List[SpatialScenarioResult]
    monte_carlo: montecarlo.MonteCarlo
    singular: np.ndarray
    tensions: np.ndarray
    feasible: np.ndarray
    neighbours: np.ndarray
    params: dict = field(default_factory=dict)

    def result(self, key: str) -> SpatialScenarioResult:
        for r in self.scenarios:
            if r.scenario.key == key:
                return r
        raise KeyError(key)

    @property
    def feasible_share(self) -> float:
        """Share of the configurations held with every position cable taut."""
        return float(np.mean(self.feasible)) if len(self.feasible) else float("nan")


def run(robot, configurations: int = DEFAULT_CONFIGURATIONS, samples: int = DEFAULT_SAMPLES, seed: int = 0,
        progress: bool = True, method: str = "sobol", dl_tol=DEFAULT_DL_TOL, dh_tol=DEFAULT_DH_TOL,
        k: int = 6, theta=None) -> SpatialStudy:
    """The spatial study of ``robot`` (module doc): ``configurations`` joint
    angles sampled in its joint box (``method`` ``"sobol"``, scrambled with
    ``seed``, or ``"random"``) — or the given ``theta`` (N, n) rad —, every
    single-error scenario with its jump points (``k`` neighbours), a Monte
    Carlo of ``samples`` composite errors (``dl_tol`` per position cable,
    ``dh_tol`` per hole coordinate, m; ``seed``), the singular measure and
    the statics. About 2 s for ``two_universal`` with the defaults."""
    if getattr(robot, "kind", "") != "spatial":
        raise CdsmInputError(f"`robot`: the spatial study needs a spatial robot, got kind "
                             f"{getattr(robot, 'kind', '?')!r} (planar arms: cdsm.paper.run)")
    given = theta is not None
    if not given:
        theta = sampling.sample_configurations(robot, configurations, method=method, seed=seed)
    else:
        theta = np.ascontiguousarray(np.asarray(theta, dtype=np.float64))
        if theta.ndim != 2 or theta.shape[1] != robot.n or not np.isfinite(theta).all():
            raise CdsmInputError(f"`theta`: expected finite (N, {robot.n}) joint angles, got shape {theta.shape}")
    if len(theta) <= k:
        raise CdsmInputError(f"`configurations`: need more than k = {k} configurations, got {len(theta)}")
    nb = sampling.nearest_neighbours(theta, k)
    scen = spatial_scenarios(robot)
    bar = Progress(len(scen), "error scenarios", progress)
    results = []
    for sc in scen:
        dev = scenarios.deviation(robot, theta, dL=sc.dL, dholes=sc.dholes)
        ok = np.asarray(dev.ok, bool)
        ds = np.where(ok[:, None], dev.dS, np.nan)
        results.append(SpatialScenarioResult(sc, ds, ok, sampling.jump_points(theta, ds[:, :3], neighbours=nb)))
        bar.update(1)
    mc = montecarlo.monte_carlo(robot, theta, samples=samples, seed=seed, dl_tol=dl_tol, dh_tol=dh_tol,
                                progress=progress)
    tens = robot.tensions(theta)
    return SpatialStudy(robot, theta, robot.fk(theta), results, mc, sampling.singular_measure(robot, theta),
                        tens, np.asarray(robot.feasible(theta), bool), nb,
                        dict(configurations=int(len(theta)), samples=int(samples), seed=int(seed),
                             method="given" if given else method, k=int(k),
                             dl_tol_m=mc.params["dl_tol_m"], dh_tol_m=mc.params["dh_tol_m"]))
