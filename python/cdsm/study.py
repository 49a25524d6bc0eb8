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

from . import deprecated
from .accuracy import montecarlo, plant_errors, sampling, scenarios, sensitivity, statics, workspace
from .calibration import plant
from .calibration.measurements import commanded_cables
from .inputs import CdsmInputError
from .kinds import KINDS as ARM_KINDS, PLANAR, Kind
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
                  "sampled": "sampled joint-space protocol", "commanded": "sampled command-space protocol"}
#: Spatial single-error kinds: the cable's length, its holes along the radius, its holes along the disk normal.
KINDS = ("cable", "radial", "normal")
#: Sampled configurations of the ``sampled`` protocol (default).
DEFAULT_CONFIGURATIONS = 1000
#: Monte-Carlo samples per configuration (default, at most), by kind: the paper's 1000; 200 over sampled 3-D arms
#: (each kind's :attr:`cdsm.kinds.Kind.default_samples`).
DEFAULT_SAMPLES = {str(k): k.default_samples for k in ARM_KINDS.values()}
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
    size = robot.n * len(commanded_cables(robot)) / 9.0
    cap = int(DEFAULT_SOLVES / max(size, 1.0)) // max(int(configurations), 1)
    return int(min(robot.kind.default_samples, max(MIN_SAMPLES, cap)))


def configuration_count(robot: Robot, protocols: List[str], configurations: int = 1000, grid=None) -> int:
    """How many configurations the study of ``protocols`` has (before the
    attitude-0 protocol drops the unreachable tips)."""
    total = 0
    for p in protocols:
        if p in ("sampled", "commanded"):
            total += int(configurations)
        else:
            total += len(grid) if grid is not None else workspace.grid_values(robot.n) ** robot.n
    return total


# ---------------------------------------------------------------------------
# scenarios
# ---------------------------------------------------------------------------
@deprecated.renamed_fields(kind="error")
@dataclass(frozen=True, repr=False)
class Scenario(ShortRepr):
    """One single error. key: ``cable3+``, ``disk2-``, ``radial3-``, ...
    dL: error on the position cables' lengths (planar (n,) upper cables;
    spatial (m_pos,)), m. dh: planar (n,) error on each disk's hole height,
    m (None for a cable error and for spatial arms). figure: the paper's figure it reproduces (set
    by :mod:`cdsm.paper`), or "". error: ``"cable"``, ``"hole"`` (planar),
    ``"radial"`` or ``"normal"`` (spatial). cable: the cable's file index
    (0-based; planar hole scenarios: the upper cable of the pair). sign: ±1.
    size: the error's magnitude, m. dholes: spatial (3 H,) error on every
    hole coordinate (the order of ``robot.flat_holes``), m, or None (a
    cable error, planar arms). The arm's kind says which of the two a hole
    error is given by (:attr:`cdsm.kinds.Kind.hole_error_arg`). ``kind`` is
    the deprecated name of ``error`` (cdsm 0.2; one release)."""

    key: str
    label: str
    dL: np.ndarray
    dh: Optional[np.ndarray] = None
    figure: str = ""
    error: str = "cable"
    cable: int = 0
    sign: float = 1.0
    size: float = 0.0
    dholes: Optional[np.ndarray] = None


@dataclass(frozen=True)
class _PlanarPairs:
    """What :func:`scenario_set` reads of a planar arm of ``n`` joints: its
    cables in pairs (upper cable ``2i`` and lower ``2i + 1`` end at disk
    ``i + 1``; the upper ones are position-controlled)."""

    n: int
    kind: Kind = PLANAR

    @property
    def position_cables(self) -> List[int]:
        return list(range(0, 2 * self.n, 2))

    @property
    def displacement_cables(self) -> List[int]:
        return []

    @property
    def cable_ends(self) -> List[int]:
        return [c // 2 + 1 for c in range(2 * self.n)]


def planar_scenarios(n: int, cable_error: float = DEFAULT_DL_TOL,
                     hole_error: float = DEFAULT_DH_TOL) -> List[Scenario]:
    """The planar single errors of an arm of ``n`` joints: ±``cable_error``
    on each upper cable (cables 1, 3, 5, ...) and ±``hole_error`` on each
    disk's holes (m) — :func:`scenario_set` of a planar arm."""
    return scenario_set(_PlanarPairs(int(n)), cable_error, hole_error)


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
    the normal on its holes (m) — :func:`scenario_set` of a spatial arm.
    Holes of force-controlled cables do not move the tip of the rigid model
    (their lengths are not commanded): no scenario (the Monte Carlo perturbs
    them all the same)."""
    return scenario_set(robot, cable_error, hole_error)


def _hole_move(robot: Robot, error: str, i: int, cable: int) -> np.ndarray:
    """The unit hole error ``error`` of position cable ``cable`` (the
    ``i``-th): a planar disk's hole height (``"hole"``, (n,), the disk cable
    ``cable`` ends at) or a move of every hole of the cable (3 H,)."""
    if error == "hole":
        unit = np.zeros(robot.n)
        unit[robot.cable_ends[cable] - 1] = 1.0
        return unit
    return hole_direction(robot, cable, error)


def scenario_set(robot: Robot, cable_error: float = DEFAULT_DL_TOL,
                 hole_error: float = DEFAULT_DH_TOL) -> List[Scenario]:
    """The single errors of ``robot`` (module doc): ±``cable_error`` on each
    position cable's length, then ±``hole_error`` on the holes, each of the
    kind's hole errors (:attr:`cdsm.kinds.Kind.hole_scenarios`: planar each
    disk's hole height, spatial each position cable's holes radially and
    along the normal), m."""
    kind, pos = robot.kind, commanded_cables(robot)
    out = []
    for i, c in enumerate(pos):
        for sign in (-1.0, 1.0):
            dl = np.zeros(len(pos))
            dl[i] = sign * cable_error
            out.append(Scenario(f"cable{c + 1}{'+' if sign > 0 else '-'}",
                                kind.cable_scenario_label.format(size=sign * cable_error * 1e3, cable=c + 1), dl,
                                error="cable", cable=c, sign=sign, size=float(cable_error)))
    for error, key, label in kind.hole_scenarios:
        for i, c in enumerate(pos):
            unit = _hole_move(robot, error, i, c)
            words = dict(cable=c + 1, disk=robot.cable_ends[c])
            for sign in (-1.0, 1.0):
                out.append(Scenario(key.format(**words) + ("+" if sign > 0 else "-"),
                                    label.format(size=sign * hole_error * 1e3, **words), np.zeros(len(pos)),
                                    error=error, cable=c, sign=sign, size=float(hole_error),
                                    **{kind.hole_error_arg: sign * hole_error * unit}))
    return out


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
    if robot.is_elastic:  # its angles are the equilibrium of its commands: none can be given or gridded
        if theta is not None or grid is not None:
            raise CdsmInputError(f"`{'theta' if theta is not None else 'grid'}`: an elastic arm's configurations "
                                 "are the equilibria of its commands; its study samples the commands")
        return ["commanded"], (f"the arm is elastic (joint springs, tendons commanded in displacement): its "
                               f"configuration is the equilibrium of its {len(commanded_cables(robot))} commands, "
                               "not a joint-angle set, so the errors are applied at the equilibria of commands "
                               f"sampled in the box ±{plant_errors.COMMAND_RANGE * 1e3:g} mm on every commanded "
                               "cable (scrambled Sobol sequence), each error settled at its own equilibrium from "
                               "the same commands; jump points are the commands with two equilibria (settled "
                               "from the rest angles and along the sequence, tips more than "
                               f"{plant_errors.PATH_TOLERANCE * 1e3:g} mm apart): elsewhere the equilibrium is the "
                               "one minimiser of the potential, continuous in the commands (slack transitions make "
                               "kinks, not jumps), and a neighbour test in a box of "
                               f"{len(commanded_cables(robot))} dimensions would only flag those kinks")
    if theta is not None:
        return ["sampled"], "the errors are applied at the configurations given"
    if not robot.kind.grid_protocols:
        return ["sampled"], robot.kind.no_grid_reason
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
    if protocol == "commanded":
        return plant_errors.sample_commands(robot, configurations, method=method, seed=seed, k=k)
    if protocol == "sampled":
        return workspace.sample(robot, configurations, method=method, seed=seed, k=k, theta=theta)
    return workspace.sweep(robot, protocol, grid=grid)


def _jumps(robot: Robot, ws: workspace.Workspace, ds: np.ndarray):
    if ws.path_dependent is not None:  # a jump is a snap between two equilibria of one command
        size = len(ds)
        mag = np.linalg.norm(ds[:, :robot.kind.dim], axis=1)
        fin = np.isfinite(mag)
        return sampling.SampledJumps(ws.neighbours, np.zeros((0, 2), np.int64), np.zeros(0), np.zeros(0),
                                     np.full(size, np.nan), np.zeros(0, bool), ws.path_dependent & fin,
                                     float(np.percentile(mag[fin], 95)) if fin.any() else 0.0)
    if ws.protocol == "sampled":
        return sampling.jump_points(ws.theta0, ds[:, :robot.kind.dim], neighbours=ws.neighbours)
    return workspace.jump_points(robot, ws, ds)


def _initial(ws: workspace.Workspace) -> np.ndarray:
    """(N, n) initial angles with unreachable rows at 0 (for batch calls)."""
    return np.where(ws.reachable[:, None], ws.theta0, 0.0)


def _scenario(robot: Robot, ws: workspace.Workspace, sc: Scenario) -> ScenarioResult:
    ok0 = ws.reachable
    arg = robot.kind.hole_error_arg
    hole = getattr(sc, arg)
    if ws.commands is not None:  # settled at the commands by the plant with the error's parameters
        dS, solved = plant_errors.deviation_commands(robot, plant_errors.error_parameters(robot, sc.dL, hole),
                                                     ws.commands)
    else:
        dev = scenarios.deviation(robot, _initial(ws), dL=sc.dL, statics=False,
                                  **{arg: hole if hole is not None and np.any(hole) else None})
        dS, solved = dev.dS, dev.ok
    ok = ok0 & np.asarray(solved, bool)
    ds = np.where(ok[:, None], dS, np.nan)
    return ScenarioResult(sc, ws.protocol, ds, ok, _jumps(robot, ws, ds))


def _singular(robot: Robot, ws: workspace.Workspace) -> np.ndarray:
    """(N,) singular measure: planar sigma_min / sigma_max of the pose
    Jacobian (attitude row scaled to m); spatial of the position Jacobian
    (:func:`cdsm.accuracy.sampling.singular_measure`); NaN where unreachable."""
    if ws.commands is not None:
        return _command_singular(robot, ws)
    r = _SINGULAR[robot.kind.singular](robot, _initial(ws))
    return np.where(ws.reachable, r, np.nan)


def _command_singular(robot: Robot, ws: workspace.Workspace) -> np.ndarray:
    """(N,) sigma_min / sigma_max of the tip position's Jacobian by the commands
    (an elastic arm's: the plant's implicit-function sensitivities to the
    commanded cables' lengths; a slack tendon's column is zero, so fewer taut
    tendons than position axes make it 0); NaN where unreachable."""
    out = np.full(len(ws.grid), np.nan)
    ok = ws.reachable
    if ok.any():
        s = plant_errors.sensitivities_commands(robot, ws.commands[ok], blocks=("cable_offset",))
        sv = np.linalg.svd(np.nan_to_num(s["cable_offset"][:, :robot.kind.dim, :]), compute_uv=False)
        out[ok] = np.where(s["converged"], sv[:, -1] / np.maximum(sv[:, 0], 1e-300), np.nan)
    return out


def _pose_singular(robot: Robot, theta: np.ndarray) -> np.ndarray:
    """(N,) sigma_min / sigma_max of the pose Jacobian, the attitude row scaled to m."""
    sv = workspace.singular_values(robot, theta)
    return sv[:, -1] / np.maximum(sv[:, 0], 1e-300)


#: The singular measure by the Jacobian rows it takes (:attr:`cdsm.kinds.Kind.singular`).
_SINGULAR = {"pose": _pose_singular, "position": sampling.singular_measure}


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
    def kind(self) -> Kind:
        """The robot's :class:`cdsm.kinds.Kind`."""
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
    mcs = {p: _monte_carlo(robot, ws, samples, seed, dl_tol, dh_tol, progress) for p, ws in spaces.items()}
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
        if ws.commands is not None:  # the elastic statics: tensions of the equilibria, no friction (frictionless)
            study.feasibility[p] = _equilibrium_map(robot, ws)
            study.amplification[p] = plant_errors.amplification_commands(robot, ws)
            continue
        study.feasibility[p] = statics.feasibility_map(robot, _initial(ws))
        study.amplification[p] = sensitivity.amplification_maps(robot, p, ws)
        study.friction[p] = statics.friction_map(robot, np.where(ws.reachable[:, None], ws.theta0, np.nan),
                                                 progress=progress, label=f"friction map ({p})")
    th = main.theta0[main.reachable]
    if len(th):
        matrix = (None if main.commands is None else
                  plant_errors.position_matrix_commands(robot, main.commands[main.reachable]))
        study.budget = sensitivity.error_budget(robot, th, mc0.params["dl_tol_m"], mc0.params["dh_tol_m"],
                                                seed=seed, matrix=matrix)
    return study


def _monte_carlo(robot: Robot, ws: workspace.Workspace, samples: int, seed: int, dl_tol, dh_tol,
                 progress: bool) -> montecarlo.MonteCarlo:
    """The Monte Carlo of one protocol: the core's at the configurations, or
    the plant's at the commands (an elastic arm: every sample settled at its
    own equilibrium), with the same tolerances."""
    label = f"monte carlo ({ws.protocol})"
    if ws.commands is None:
        return montecarlo.monte_carlo(robot, ws.theta0[ws.reachable], samples=samples, seed=seed, dl_tol=dl_tol,
                                      dh_tol=dh_tol, progress=progress, check_slack=True, label=label)
    holes = plant_errors.hole_block(robot)
    tol = {"cable_offset": dl_tol, holes: dh_tol}
    mc = plant_errors.monte_carlo_commands(robot, ws.commands[ws.reachable], samples=samples, seed=seed,
                                           tolerances=tol, progress=progress, label=label)
    vec = plant_errors.tolerance_vector(robot, tol)
    lay = plant.layout(robot)
    mc.params.update(dl_tol_m=vec[lay["cable_offset"]].tolist(), dh_tol_m=vec[lay[holes]].tolist())
    return mc


def _equilibrium_map(robot: Robot, ws: workspace.Workspace) -> statics.FeasibilityMap:
    """The statics of an elastic arm's configurations: the commanded cables'
    tensions at the equilibria of the commands (N), held (``feasible``)
    where the equilibrium converged — a slack tendon is part of it."""
    eq = plant_errors.equilibria(robot, ws.commands)
    cmd = commanded_cables(robot)
    ok = np.asarray(eq.converged, bool) & ws.reachable
    return statics.FeasibilityMap(ws.theta0, ws.poses, np.where(ok[:, None], eq.tension[:, cmd], np.nan), ok, 0.0)


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
