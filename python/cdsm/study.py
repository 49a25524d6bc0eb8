"""The accuracy study of a robot of either kind (``cdsm paper``): the seed
paper's methods over any arm. SI units in every array (m, rad, N); the
report (:mod:`cdsm.report`) converts to mm and degrees.

:func:`run` computes, per protocol (:func:`choose_protocols`):

* the initial configurations (:class:`cdsm.accuracy.workspace.Workspace`);
* every single-error scenario (:func:`scenario_set`) with its tip deviation
  and jump points;
* a Monte-Carlo study of composite errors, failed solves counted (they are
  flagged in the report, never dropped) and perturbed samples checked for a
  slack cable;
* the singular measure, the statics (position-cable tensions, slack), the
  first-order amplification maps;
* friction in the holes (:func:`cdsm.accuracy.statics.friction_map`,
  ``mu`` = :data:`cdsm.accuracy.statics.FRICTION`): the tensions pulling and
  releasing, the slack check in both states, and the hysteresis of a ±1 mm
  cycle of every position cable through the plant with the robot file's
  cable stiffness;

and, on the main protocol, the linear error budget and tolerance guesses
(:func:`cdsm.accuracy.sensitivity.error_budget`). Where the errors are
largest: :func:`worst_configurations`. The seed paper's own layer (its
claims, Tables 2 and 3, its load readings) is :mod:`cdsm.paper`, built on
this study for the paper's geometry only.

Protocols (the report says which one it used and why):

* a planar arm without redundancy (3 joints for the pose ``[x, y, phi]``):
  the paper's two grid protocols, ``attitude0`` (grid tip, phi = 0, pose IK,
  then the error) and ``joint`` (the error at the grid angles);
* a planar arm with redundancy (more than 3 joints) or too few joints: the
  ``joint`` protocol only — its pose IK has a continuum of answers (or none
  at phi = 0), so an attitude-0 study would measure the IK's choices, not
  the arm (the null-space configuration choice of
  :mod:`cdsm.accuracy.configurations` picks the least sensitive answer for
  a given target);
* planar arms whose ±30° grid would have fewer than
  :data:`cdsm.accuracy.workspace.MIN_LINE` values per joint, and spatial
  arms: ``sampled`` configurations in the joint box (scrambled Sobol), jumps
  between nearest neighbours in joint space.

Single errors: planar arms ±1 mm on each upper cable (``cable1±``,
``cable3±``, ...) and ±0.35 mm on each disk's hole height (``disk1±``, ...);
spatial arms ±1 mm on each position-controlled cable's length
(``cable{c}±``, file order from 1), ±0.35 mm on all its holes along the
radius in each face plane (``radial{c}±``) and along the disk normal
(``normal{c}±``). The Monte Carlo draws uniform errors within the same
bounds on every cable and hole error at once (spatial: every hole
coordinate, independent).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np

from .accuracy import montecarlo, sampling, scenarios, sensitivity, statics, workspace
from .inputs import CdsmInputError
from .progress import Progress
from .robot import Robot
from .display import ShortRepr

__all__ = ["Scenario", "ScenarioResult", "Study", "run", "choose_protocols", "scenario_set", "planar_scenarios",
           "spatial_scenarios", "hole_direction", "worst_configurations", "finite_rms", "PROTOCOL_NAMES",
           "KINDS", "DEFAULT_CONFIGURATIONS", "DEFAULT_SAMPLES", "DEFAULT_DL_TOL", "DEFAULT_DH_TOL",
           "DEFAULT_TARGET", "NEAR_SINGULAR", "DEFAULT_SOLVES", "MIN_SAMPLES", "default_samples",
           "configuration_count"]

#: Readable names of the protocols.
PROTOCOL_NAMES = {"attitude0": "attitude-0 protocol", "joint": "joint-space protocol",
                  "sampled": "sampled joint-space protocol"}
#: Spatial single-error kinds: the cable's length, its holes along the radius, its holes along the disk normal.
KINDS = ("cable", "radial", "normal")
#: Sampled configurations of the ``sampled`` protocol (default).
DEFAULT_CONFIGURATIONS = 1000
#: Monte-Carlo samples per configuration (default, at most), by kind: the paper's 1000; 200 over sampled 3-D arms.
DEFAULT_SAMPLES = {"planar": 1000, "spatial": 200}
#: Monte-Carlo solves of a study by default, at most, counted as solves of the paper's arm (fewer samples per
#: configuration over large grids or large arms, not fewer than :data:`MIN_SAMPLES`): the paper's 1000 samples over
#: its two grids stay.
DEFAULT_SOLVES = 5_000_000
MIN_SAMPLES = 100
#: Error bounds: per position cable's length and per hole error (m).
DEFAULT_DL_TOL = scenarios.PAPER_DL_TOL
DEFAULT_DH_TOL = scenarios.PAPER_DH_TOL
#: The tip-error percentile target (m) of the tolerance guesses (95th percentile of |d position|).
DEFAULT_TARGET = 1e-3
#: Singular measure below which a configuration counts as near-singular.
NEAR_SINGULAR = 0.02


def default_samples(robot: Robot, configurations: int = 0) -> int:
    """Monte-Carlo samples per configuration by default: the kind's
    :data:`DEFAULT_SAMPLES`, fewer where ``configurations`` (over every
    protocol) would need more than :data:`DEFAULT_SOLVES` solves of the
    paper's arm — a solve counted by its size, joints x position cables,
    against the paper's 3 x 3 (the SJTU snake's 24 x 36 costs 96 of them) —
    but not fewer than :data:`MIN_SAMPLES`."""
    size = robot.n * len(robot.position_cables) / 9.0
    cap = int(DEFAULT_SOLVES / max(size, 1.0)) // max(int(configurations), 1)
    return int(min(DEFAULT_SAMPLES[robot.kind], max(MIN_SAMPLES, cap)))


def configuration_count(robot: Robot, protocols: List[str], configurations: int = 1000, grid=None) -> int:
    """How many configurations the study of ``protocols`` has (before the
    attitude-0 protocol drops the unreachable tips)."""
    total = 0
    for p in protocols:
        if p == "sampled":
            total += int(configurations)
        else:
            total += len(grid) if grid is not None else workspace.grid_values(robot.n) ** robot.n
    return total


# ---------------------------------------------------------------------------
# scenarios
# ---------------------------------------------------------------------------
@dataclass(frozen=True, repr=False)
class Scenario(ShortRepr):
    """One single error. key: ``cable3+``, ``disk2-``, ``radial3-``, ...
    dL: error on the position cables' lengths (planar (n,) upper cables;
    spatial (m_pos,)), m. dh: planar (n,) error on each disk's hole height,
    m (None for spatial arms). figure: the paper's figure it reproduces (set
    by :mod:`cdsm.paper`), or "". kind: ``"cable"``, ``"hole"`` (planar),
    ``"radial"`` or ``"normal"`` (spatial). cable: the cable's file index
    (0-based; planar hole scenarios: the upper cable of the pair). sign: ±1.
    size: the error's magnitude, m. dholes: spatial (3 H,) error on every
    hole coordinate (the order of ``robot.flat_holes``), m, or None."""

    key: str
    label: str
    dL: np.ndarray
    dh: Optional[np.ndarray] = None
    figure: str = ""
    kind: str = "cable"
    cable: int = 0
    sign: float = 1.0
    size: float = 0.0
    dholes: Optional[np.ndarray] = None


def planar_scenarios(n: int, cable_error: float = DEFAULT_DL_TOL,
                     hole_error: float = DEFAULT_DH_TOL) -> List[Scenario]:
    """The planar single errors: ±``cable_error`` on each upper cable (cables
    1, 3, 5, ...) and ±``hole_error`` on each disk's holes (m)."""
    out = []
    for i in range(n):
        for sign in (-1.0, 1.0):
            dl = np.zeros(n)
            dl[i] = sign * cable_error
            out.append(Scenario(f"cable{2 * i + 1}{'+' if sign > 0 else '-'}",
                                f"{sign * cable_error * 1e3:+g} mm on cable {2 * i + 1}", dl, np.zeros(n),
                                kind="cable", cable=2 * i, sign=sign, size=float(cable_error)))
    for i in range(n):
        for sign in (-1.0, 1.0):
            dh = np.zeros(n)
            dh[i] = sign * hole_error
            out.append(Scenario(f"disk{i + 1}{'+' if sign > 0 else '-'}",
                                f"{sign * hole_error * 1e3:+g} mm on disk {i + 1}'s holes", np.zeros(n), dh,
                                kind="hole", cable=2 * i, sign=sign, size=float(hole_error)))
    return out


def hole_direction(robot: Robot, cable: int, kind: str) -> np.ndarray:
    """(3 H,) unit moves of a spatial arm's cable ``cable``'s holes (zero
    elsewhere), in the order of ``robot.flat_holes``: ``"radial"`` outward in
    each face plane (``(0, y, z) / |(y, z)|``; a hole on the axis does not
    move), ``"normal"`` along the face's x axis."""
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


def spatial_scenarios(robot: Robot, cable_error: float = DEFAULT_DL_TOL,
                      hole_error: float = DEFAULT_DH_TOL) -> List[Scenario]:
    """The single errors of a spatial arm: for each position-controlled cable
    ±``cable_error`` on its length, then ±``hole_error`` radially and along
    the normal on its holes (m). Holes of force-controlled cables do not move
    the tip of the rigid model (their lengths are not commanded): no scenario
    (the Monte Carlo perturbs them all the same)."""
    pos = robot.position_cables
    out = []
    for i, c in enumerate(pos):
        for sign in (-1.0, 1.0):
            dl = np.zeros(len(pos))
            dl[i] = sign * cable_error
            out.append(Scenario(f"cable{c + 1}{'+' if sign > 0 else '-'}",
                                f"{sign * cable_error * 1e3:+g} mm on cable {c + 1}'s length", dl,
                                kind="cable", cable=c, sign=sign, size=float(cable_error)))
    for kind, what in (("radial", "radially"), ("normal", "along the disk normal")):
        for c in pos:
            unit = hole_direction(robot, c, kind)
            for sign in (-1.0, 1.0):
                out.append(Scenario(f"{kind}{c + 1}{'+' if sign > 0 else '-'}",
                                    f"{sign * hole_error * 1e3:+g} mm {what} on cable {c + 1}'s holes",
                                    np.zeros(len(pos)), kind=kind, cable=c, sign=sign, size=float(hole_error),
                                    dholes=sign * hole_error * unit))
    return out


def scenario_set(robot: Robot, cable_error: float = DEFAULT_DL_TOL,
                 hole_error: float = DEFAULT_DH_TOL) -> List[Scenario]:
    """The single errors of ``robot``'s kind (module doc)."""
    if robot.kind == "spatial":
        return spatial_scenarios(robot, cable_error, hole_error)
    return planar_scenarios(robot.n, cable_error, hole_error)


@dataclass(repr=False)
class ScenarioResult(ShortRepr):
    """A scenario over one protocol's configurations: dS (N, task) tip
    deviation (planar [dX, dY (m), dphi (rad)]; spatial [dX, dY, dZ (m),
    rotation vector (rad, base frame)]), NaN where unreachable or unsolved;
    ok (N,); jumps of the position deviation (grid protocols
    :class:`cdsm.accuracy.workspace.Jumps`, with reasons; ``sampled``
    :class:`cdsm.accuracy.sampling.SampledJumps`)."""

    scenario: Scenario
    protocol: str
    dS: np.ndarray
    ok: np.ndarray
    jumps: object

    @property
    def position(self) -> np.ndarray:
        """(N,) |d position| (planar |d(X, Y)|, spatial |d(X, Y, Z)|), m."""
        d = 2 if self.dS.shape[1] == 3 else 3
        return np.linalg.norm(self.dS[:, :d], axis=1)

    @property
    def position_mm(self) -> np.ndarray:
        """(N,) |d position| in mm."""
        return self.position * 1e3

    @property
    def rotation(self) -> np.ndarray:
        """(N,) rotation of the end frame, rad (planar |dphi|)."""
        if self.dS.shape[1] == 3:
            return np.abs(self.dS[:, 2])
        return np.linalg.norm(self.dS[:, 3:], axis=1)

    @property
    def jump_count(self) -> int:
        """Configurations on a jump."""
        return int(np.asarray(self.jumps.point).sum())


# ---------------------------------------------------------------------------
# protocols
# ---------------------------------------------------------------------------
def choose_protocols(robot: Robot, grid=None, theta=None) -> Tuple[List[str], str]:
    """The protocols of ``robot``'s study and the reason, in words (module
    doc): a given ``theta`` is sampled; a given ``grid`` (planar) is gridded."""
    if theta is not None:
        return ["sampled"], "the errors are applied at the configurations given"
    if robot.kind == "spatial":
        return ["sampled"], ("a spatial arm has no single attitude to hold over its workspace, and a joint grid is "
                             "impossible past a few joints: the errors are applied at configurations sampled in "
                             "the joint box (scrambled Sobol sequence); jump points are judged between nearest "
                             "neighbours in joint space")
    n = robot.n
    if grid is None and workspace.grid_values(n) < workspace.MIN_LINE:
        return ["sampled"], (f"the ±30° joint grid of {n} joints has only {workspace.grid_values(n)} values per "
                             f"joint, too few to judge a jump against its neighbours: the errors are applied at "
                             "configurations sampled in the joint box (scrambled Sobol sequence); jump points are "
                             "judged between nearest neighbours in joint space")
    if n == 3:
        return ["attitude0", "joint"], ("the arm has as many joints as its pose [x, y, phi] has coordinates (no "
                                        "redundancy): the paper's two grid protocols")
    if n > 3:
        return ["joint"], (f"the arm has {n} joints for the 3 coordinates of its pose [x, y, phi]: it is "
                           "redundant, so the pose IK of a grid tip has a continuum of answers and an attitude-0 "
                           "study would measure the solver's choices (its jumps and failed solves), not the arm. "
                           "The errors are applied at the grid angles themselves (joint-space protocol); for a "
                           "given target, `cdsm.accuracy.configurations.best_configurations` picks the least "
                           "sensitive configuration in the null space")
    return ["joint"], (f"the arm has {n} joint{'s' if n > 1 else ''}, fewer than the 3 coordinates of its pose "
                       "[x, y, phi]: a grid tip cannot in general be held at phi = 0, so the errors are applied at "
                       "the grid angles themselves (joint-space protocol)")


def _workspace(robot: Robot, protocol: str, grid, theta, configurations: int, method: str, seed: int,
               k: int) -> workspace.Workspace:
    if protocol == "sampled":
        return workspace.sample(robot, configurations, method=method, seed=seed, k=k, theta=theta)
    return workspace.sweep(robot, protocol, grid=grid)


def _jumps(robot: Robot, ws: workspace.Workspace, ds: np.ndarray):
    if ws.protocol == "sampled":
        d = 3 if robot.kind == "spatial" else 2
        return sampling.jump_points(ws.theta0, ds[:, :d], neighbours=ws.neighbours)
    return workspace.jump_points(robot, ws, ds)


def _initial(ws: workspace.Workspace) -> np.ndarray:
    """(N, n) initial angles with unreachable rows at 0 (for batch calls)."""
    return np.where(ws.reachable[:, None], ws.theta0, 0.0)


def _scenario(robot: Robot, ws: workspace.Workspace, sc: Scenario) -> ScenarioResult:
    ok0 = ws.reachable
    theta0 = _initial(ws)
    if robot.kind == "spatial":
        dev = scenarios.deviation(robot, theta0, dL=sc.dL, dholes=sc.dholes, statics=False)
    else:
        dev = scenarios.deviation(robot, theta0, dL=sc.dL, dh=sc.dh if sc.dh is not None and np.any(sc.dh) else None,
                                  statics=False)
    ok = ok0 & np.asarray(dev.ok, bool)
    ds = np.where(ok[:, None], dev.dS, np.nan)
    return ScenarioResult(sc, ws.protocol, ds, ok, _jumps(robot, ws, ds))


def _singular(robot: Robot, ws: workspace.Workspace) -> np.ndarray:
    """(N,) singular measure: planar sigma_min / sigma_max of the pose
    Jacobian (attitude row scaled to m); spatial of the position Jacobian
    (:func:`cdsm.accuracy.sampling.singular_measure`); NaN where unreachable."""
    th = _initial(ws)
    if robot.kind == "spatial":
        r = sampling.singular_measure(robot, th)
    else:
        sv = workspace.singular_values(robot, th)
        r = sv[:, -1] / np.maximum(sv[:, 0], 1e-300)
    return np.where(ws.reachable, r, np.nan)


# ---------------------------------------------------------------------------
# the study
# ---------------------------------------------------------------------------
def finite_rms(v: np.ndarray) -> float:
    """RMS of the finite entries of ``v`` (NaN when there are none)."""
    v = np.asarray(v, dtype=float)
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v ** 2))) if len(v) else float("nan")


@dataclass(repr=False)
class Study(ShortRepr):
    """Everything the study of one robot computes; the report reads it.

    workspaces: {protocol: initial configurations}. scenarios: every single
    error under every protocol. monte_carlo: {protocol: statistics over the
    reachable configurations}. singular: {protocol: (N,) singular measure}.
    feasibility: {protocol: statics at the initial configurations}.
    amplification: {protocol: amplification maps}. budget: the linear error
    budget on the main protocol (the first). protocol_reason: why these
    protocols (words). params: samples, seed, configurations, tolerances...
    friction: {protocol: friction in the holes at the initial configurations}.
    """

    robot: Robot
    workspaces: Dict[str, workspace.Workspace]
    scenarios: List[ScenarioResult]
    monte_carlo: Dict[str, montecarlo.MonteCarlo]
    singular: Dict[str, np.ndarray]
    params: dict = field(default_factory=dict)
    feasibility: Dict[str, statics.FeasibilityMap] = field(default_factory=dict)
    amplification: Dict[str, dict] = field(default_factory=dict)
    budget: Optional[sensitivity.ErrorBudget] = None
    protocol_reason: str = ""
    friction: Dict[str, statics.FrictionMap] = field(default_factory=dict)

    @property
    def kind(self) -> str:
        return self.robot.kind

    @property
    def protocols(self) -> List[str]:
        return list(self.workspaces)

    @property
    def main(self) -> str:
        """The main protocol (the first): the claims and the budget use it."""
        return next(iter(self.workspaces))

    def result(self, key: str, protocol: Optional[str] = None) -> ScenarioResult:
        """The result of scenario ``key`` under ``protocol`` (default the main one)."""
        protocol = self.main if protocol is None else protocol
        for r in self.scenarios:
            if r.scenario.key == key and r.protocol == protocol:
                return r
        raise KeyError((key, protocol))

    def results(self, protocol: Optional[str] = None) -> List[ScenarioResult]:
        protocol = self.main if protocol is None else protocol
        return [r for r in self.scenarios if r.protocol == protocol]

    # the main protocol's arrays, by the names of the sampled study of cdsm 0.2
    @property
    def theta(self) -> np.ndarray:
        """(N, n) initial angles of the main protocol, rad (NaN where unreachable)."""
        return self.workspaces[self.main].theta0

    @property
    def pose(self) -> np.ndarray:
        """(N, task) initial poses of the main protocol."""
        return self.workspaces[self.main].poses

    @property
    def tensions(self) -> np.ndarray:
        """(N, m_pos) position-cable tensions at the main protocol's configurations, N."""
        return self.feasibility[self.main].tension

    @property
    def feasible(self) -> np.ndarray:
        """(N,) held with every position cable taut (main protocol; unreachable rows False)."""
        return self.feasibility[self.main].feasible & self.workspaces[self.main].reachable

    @property
    def feasible_share(self) -> float:
        """Share of the main protocol's reachable configurations held with every position cable taut."""
        ws = self.workspaces[self.main]
        r = ws.reachable
        return float(np.mean(self.feasibility[self.main].feasible[r])) if r.any() else float("nan")


def run(robot: Optional[Robot] = None, samples: Optional[int] = None, seed: int = 0, progress: bool = True,
        grid=None, configurations: int = DEFAULT_CONFIGURATIONS, method: str = "sobol", dl_tol=DEFAULT_DL_TOL,
        dh_tol=DEFAULT_DH_TOL, k: int = 6, theta=None, target: float = DEFAULT_TARGET) -> Study:
    """The accuracy study of ``robot`` (default the paper's prototype; module
    doc). ``samples``: Monte-Carlo samples per configuration (default
    :func:`default_samples` of the study's size), ``seed`` for them and for the sampled
    configurations. ``grid`` (N, n) rad: the grid of the planar protocols.
    ``configurations``, ``method``, ``k``: the sampled protocol (count,
    ``"sobol"`` or ``"random"``, neighbours for jumps); ``theta`` (N, n) rad:
    sample these configurations instead. ``dl_tol``, ``dh_tol``: the Monte
    Carlo's bounds (m; spatial ``dh_tol`` per hole coordinate). ``target``:
    the tip-error 95th percentile (m) the tolerance guesses aim at."""
    robot = robot or Robot.paper()
    protocols, reason = choose_protocols(robot, grid=grid, theta=theta)
    spaces = {p: _workspace(robot, p, grid, theta, configurations, method, seed, k) for p in protocols}
    given_samples = samples
    samples = (default_samples(robot, sum(len(ws.grid) for ws in spaces.values())) if samples is None
               else int(samples))
    scen = scenario_set(robot)
    bar = Progress(len(scen) * len(spaces), "error scenarios", progress)
    results = []
    for ws in spaces.values():
        for sc in scen:
            results.append(_scenario(robot, ws, sc))
            bar.update(1)
    mcs = {p: montecarlo.monte_carlo(robot, ws.theta0[ws.reachable], samples=samples, seed=seed, dl_tol=dl_tol,
                                     dh_tol=dh_tol, progress=progress, check_slack=True, label=f"monte carlo ({p})")
           for p, ws in spaces.items()}
    singular = {p: _singular(robot, ws) for p, ws in spaces.items()}
    mc0 = next(iter(mcs.values()))
    params = dict(samples=int(samples), samples_default=given_samples is None, seed=int(seed),
                  dl_tol_m=mc0.params["dl_tol_m"],
                  dh_tol_m=mc0.params["dh_tol_m"], target_m=float(target))
    main = spaces[protocols[0]]
    if main.protocol == "sampled":
        params.update(configurations=int(len(main.grid)), method=main.params["method"], k=int(main.params["k"]))
    study = Study(robot, spaces, results, mcs, singular, params, protocol_reason=reason)
    for p, ws in spaces.items():
        study.feasibility[p] = statics.feasibility_map(robot, _initial(ws))
        study.amplification[p] = sensitivity.amplification_maps(robot, p, ws)
        study.friction[p] = statics.friction_map(robot, np.where(ws.reachable[:, None], ws.theta0, np.nan),
                                                 progress=progress, label=f"friction map ({p})")
    th = main.theta0[main.reachable]
    if len(th):
        study.budget = sensitivity.error_budget(robot, th, mc0.params["dl_tol_m"], mc0.params["dh_tol_m"],
                                                seed=seed)
    return study


def worst_configurations(study: Study, protocol: Optional[str] = None, count: int = 5) -> List[dict]:
    """The ``count`` configurations of ``protocol`` (default the main one)
    with the largest Monte-Carlo 95th percentile of |d position|: index,
    theta (n,) rad, pose, p95_m, max_m, failed (solves), the largest single
    error there (m) and its scenario, singular measure, taut (statics) and
    whether any scenario has a jump there."""
    p = study.main if protocol is None else protocol
    ws, mc = study.workspaces[p], study.monte_carlo[p]
    idx = np.flatnonzero(ws.reachable)
    p95 = mc.percentile(95.0)
    res = study.results(p)
    pos = np.stack([r.position for r in res], axis=1) if res else np.zeros((len(ws.grid), 0))
    jump = np.any([r.jumps.point for r in res], axis=0) if res else np.zeros(len(ws.grid), bool)
    order = np.argsort(-np.where(np.isfinite(p95), p95, -np.inf), kind="stable")[:int(count)]
    out = []
    for j in order:
        i = int(idx[j])
        row = pos[i]
        fin = np.isfinite(row)
        w = int(np.argmax(np.where(fin, row, -np.inf))) if fin.any() else -1
        out.append(dict(index=i, theta=ws.theta0[i], pose=ws.poses[i], p95_m=float(p95[j]),
                        max_m=float(mc.max_abs[j, 3]), failed=int(mc.failed[j]),
                        single_m=float(row[w]) if w >= 0 else float("nan"),
                        single=res[w].scenario.key if w >= 0 else "",
                        singular=float(study.singular[p][i]), taut=bool(study.feasibility[p].feasible[i]),
                        jump=bool(jump[i])))
    return out
