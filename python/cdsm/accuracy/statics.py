"""Feasibility (slack-cable) maps and elastic-cable tip effects over a joint
grid, and the load readings of a robot (weight order x plane).

Thin helpers over :meth:`cdsm.Robot.tensions`, :meth:`~cdsm.Robot.feasible`
and :meth:`~cdsm.Robot.solve_cables_elastic` for reports (e.g. the paper's
workspace: every joint -30..30 deg in 5 deg steps). SI units: m, rad, N.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional

import numpy as np

from .. import _cdsm
from ..inputs import CdsmInputError, as_batch, as_count, as_finite
from ..progress import Progress
from ..robot import Robot
from .workspace import joint_grid
from ..display import ShortRepr

__all__ = ["FeasibilityMap", "feasibility_map", "elastic_tip_deviation", "load_readings", "Reading",
           "reading_maps", "STANDARD_GRAVITY", "FrictionMap", "friction_map", "hysteresis_cycles", "FRICTION",
           "CYCLE_AMPLITUDE", "CYCLE_WORK", "CYCLE_MEMORY", "BYTES_PER_HOLE_COMMAND", "cycle_chunk"]

#: Standard gravity, m/s^2.
STANDARD_GRAVITY = 9.80665
#: The typical friction coefficient of a cable in a hole (oiled or greased steel
#: on metal; ``docs/model.md``, "Friction in the holes"): the core's.
FRICTION: float = _cdsm.FRICTION_TYPICAL
#: The amplitude of the cable cycle of the hysteresis map, m.
CYCLE_AMPLITUDE = 1e-3
#: The hysteresis cycles of a friction map run at evenly spread
#: configurations, at most this many (configurations x position cables x
#: joints) in all: every configuration of the paper's arm and of
#: ``two_universal``, 57 of the SJTU snake's 1000 (each cycle settles a
#: 24-joint arm five times per cable).
CYCLE_WORK = 50_000
#: Bytes the plant with friction keeps per hole and command of a sequence
#: (the motion's distal length, wrap angle and tension, and the
#: mobilisation: four float64).
BYTES_PER_HOLE_COMMAND = 32
#: At most this many bytes of it in one chunk of the hysteresis map
#: (:func:`cycle_chunk`).
CYCLE_MEMORY = 256 * 2 ** 20


@dataclass(frozen=True, repr=False)
class FeasibilityMap(ShortRepr):
    """theta (N, n) rad; pose (N, task) tip pose (planar [x, y, phi];
    spatial [x, y, z, rx, ry, rz]); tension (N, m_pos) tensions of the
    position-controlled cables (planar: the upper cables), N; feasible (N,)
    the core's verdict (:meth:`cdsm.Robot.feasible`): every position cable
    held above min_tension — with more position cables than joints a cable
    of the minimum-norm set may sit exactly at the floor."""

    theta: np.ndarray
    pose: np.ndarray
    tension: np.ndarray
    feasible: np.ndarray
    min_tension: float

    @property
    def slack_fraction(self) -> float:
        """Fraction of configurations that need a slack upper cable."""
        return float(1.0 - self.feasible.mean())


def feasibility_map(robot: Robot, theta=None, lower=None, tip_wrench=None, gravity=None,
                    min_tension: float = 0.0) -> FeasibilityMap:
    """Tensions (N) and the feasibility flag over ``theta`` (N, n) rad (default
    the paper's +-30 deg, 5 deg grid); ``min_tension`` in N; loads as in
    :meth:`cdsm.Robot.tensions`. Plot ``pose[:, :2]`` coloured by ``feasible``."""
    th = joint_grid(robot.n) if theta is None else as_batch("theta", theta, robot.n)[0]
    T = robot.tensions(th, lower=lower, tip_wrench=tip_wrench, gravity=gravity, min_tension=min_tension)
    ok = np.asarray(robot.feasible(th, lower=lower, tip_wrench=tip_wrench, gravity=gravity,
                                   min_tension=min_tension), bool)
    return FeasibilityMap(th, robot.fk(th), T, ok, float(min_tension))


def elastic_tip_deviation(robot: Robot, theta, youngs_modulus: Optional[float] = None,
                          diameter: Optional[float] = None, lower=None) -> np.ndarray:
    """Tip deviation (N, 3) [dX m, dY m, dphi rad] when the rigid model's cable
    lengths at ``theta`` (N, n) rad are commanded to elastic cables (optionally of another
    material); NaN where the elastic solve did not converge."""
    th = as_batch("theta", theta, robot.n)[0]
    rob = robot.with_cable(youngs_modulus=youngs_modulus, diameter=diameter)
    sol = rob.solve_cables_elastic(rob.upper_lengths(th), seed=th, lower=lower)
    d = rob.fk(sol.theta) - rob.fk(th)
    d[~np.asarray(sol.converged)] = np.nan
    return d


def load_readings(robot: Robot) -> Dict[str, Robot]:
    """The four readings of a robot's loads when its description is ambiguous
    (the seed paper's is): the lower tensions as given or in reverse order
    (disk 1 <-> disk n), in the robot's plane or the other one (no gravity
    <-> gravity along -Y, :data:`STANDARD_GRAVITY`). Keys ``"as given"``,
    ``"weights reversed"``, ``"other plane"``, ``"other plane, weights
    reversed"``. For :meth:`Robot.paper` these are the packaged ``paper``,
    ``paper_reversed_weights``, ``paper_vertical`` and
    ``paper_vertical_reversed_weights`` robots."""
    flat = not np.any(robot.gravity)
    other = np.array([0.0, -STANDARD_GRAVITY]) if flat else np.zeros(2)
    rev = robot.lower_tension[::-1].copy()
    return {"as given": robot,
            "weights reversed": robot.with_loads(lower_tension=rev),
            "other plane": robot.with_loads(gravity=other),
            "other plane, weights reversed": robot.with_loads(lower_tension=rev, gravity=other)}


@dataclass(frozen=True, repr=False)
class Reading(ShortRepr):
    """One load reading over a joint grid: the robot, its feasibility map and
    the tip deviation (N, 3) [dX m, dY m, dphi rad] its elastic cables cause
    when the rigid model's lengths are commanded (NaN where slack or not
    converged)."""

    robot: Robot
    feasibility: FeasibilityMap
    elastic: np.ndarray

    @property
    def plane(self) -> str:
        g = self.robot.gravity
        return "horizontal" if not np.any(g) else f"gravity ({g[0]:g}, {g[1]:g}) m/s²"

    @property
    def weights_g(self) -> np.ndarray:
        """Lower-cable weights, g (tension / standard gravity)."""
        return self.robot.lower_tension / STANDARD_GRAVITY * 1e3


def reading_maps(robot: Robot, theta=None) -> Dict[str, Reading]:
    """:func:`feasibility_map` and :func:`elastic_tip_deviation` of every
    reading of :func:`load_readings` over ``theta`` (N, n) rad (default the
    paper's +-30 deg grid)."""
    th = joint_grid(robot.n) if theta is None else as_batch("theta", theta, robot.n)[0]
    out = {}
    for name, r in load_readings(robot).items():
        fm = feasibility_map(r, th)
        el = elastic_tip_deviation(r, th)
        el[~fm.feasible] = np.nan
        out[name] = Reading(r, fm, el)
    return out


@dataclass(frozen=True, repr=False)
class FrictionMap(ShortRepr):
    """Friction in the holes over configurations ``theta`` (N, n) rad
    (``docs/model.md``, "Friction in the holes"), coefficient ``mu``:

    * ``pull`` / ``release`` (N, m_pos): the position cables' tensions at the
      actuators, N, in the two bounding sliding states (the actuators hauling
      the arm against the force cables, or paying out);
      ``feasible_pull`` / ``feasible_release`` (N,): every one above ``min_tension``;
    * ``loop`` (N, m_pos): the hysteresis of each position cable, m — the
      distance between the tip positions at the commanded configuration reached
      after ``+amplitude`` and after ``-amplitude`` on that cable (a
      ``0, +a, 0, -a, 0`` cycle), through the plant with friction ``mu`` and
      no other effect (friction's change of the tensions stretches the cables
      at the robot file's ``1 / (E A)``, over the routing length too); NaN
      where a command did not settle or the configuration was not cycled.
      ``width`` (N,): the largest over the cables; ``cycled`` (N,): the
      configurations whose cycles were run (:data:`CYCLE_WORK`)."""

    theta: np.ndarray
    pose: np.ndarray
    pull: np.ndarray
    release: np.ndarray
    feasible_pull: np.ndarray
    feasible_release: np.ndarray
    loop: np.ndarray
    mu: float
    amplitude: float
    min_tension: float
    cycled: np.ndarray

    @property
    def width(self) -> np.ndarray:
        """(N,) the largest loop width over the position cables, m (NaN where any is NaN)."""
        return self.loop.max(axis=1) if self.loop.shape[1] else np.full(len(self.loop), np.nan)


def _amplitude(value) -> float:
    """A cycle amplitude (m): finite and positive."""
    a = as_finite("amplitude", value)
    if not a > 0.0:
        raise CdsmInputError(f"`amplitude`: the cycle's amplitude must be a positive length (m), got {a}")
    return a


def hysteresis_cycles(n: int, m: int, theta, amplitude: float = CYCLE_AMPLITUDE):
    """The commands of the hysteresis map: for every configuration ``theta``
    (N, n) rad and position cable ``c < m``, ``0, +a, 0, -a, 0`` on that cable
    (m), absolute rows in this order. Returns ``theta_cmd (5 N m, n)``, ``dL (5
    N m, m)``; the rows of configuration ``i`` and cable ``c`` start at ``5 (i m + c)``."""
    n, m = as_count("n", n, 1), as_count("m", m, 0)
    th, _ = as_batch("theta", theta, n, finite=False)
    amplitude = _amplitude(amplitude)
    return _cycles(th, m, 0, th.shape[0] * m, amplitude)


def _cycles(th: np.ndarray, m: int, first: int, stop: int, amplitude: float):
    """The rows of :func:`hysteresis_cycles` of cycles ``first .. stop`` (cycle
    ``i m + c``: configuration ``i``, cable ``c``)."""
    g = np.arange(first, stop)
    theta_cmd = np.repeat(th[g // max(m, 1)], 5, axis=0)
    dL = np.zeros((5 * len(g), m))
    dL[np.arange(5 * len(g)), np.repeat(g % max(m, 1), 5)] = np.tile([0.0, amplitude, 0.0, -amplitude, 0.0], len(g))
    return theta_cmd, dL


def cycle_chunk(robot: Robot) -> int:
    """How many hysteresis cycles of :func:`friction_map` run through the
    plant in one sequence: the plant with friction keeps every hole's motion
    for every command (:data:`BYTES_PER_HOLE_COMMAND`), so the cycles run in
    chunks that hold at most :data:`CYCLE_MEMORY` bytes of it (each chunk
    from the plant's start state). Every configuration of the paper's arm
    fits in one; a 200-joint planar arm's 80 400 holes take 20 cycles a chunk."""
    holes = 2 * sum(robot.cable_ends)
    return max(1, CYCLE_MEMORY // (BYTES_PER_HOLE_COMMAND * 5 * max(holes, 1)))


def friction_map(robot: Robot, theta, mu: float = FRICTION, amplitude: float = CYCLE_AMPLITUDE,
                 min_tension: float = 0.0, cycle_work: int = CYCLE_WORK, progress: bool = False,
                 label: str = "friction map") -> FrictionMap:
    """:class:`FrictionMap` of ``robot`` over ``theta`` (N, n) rad (rows with NaN
    are left NaN): statics with friction ``mu`` (1) pulling and releasing, and
    the hysteresis of a ``+-amplitude`` (m) cycle of every position cable
    through the plant with friction ``mu`` and the robot file's cable (its
    stretch fed forward, or, with rigid commands, its compliance ``1 / (E A)``
    as ``cable_elasticity``: ``docs/model.md``, "Commands and their order")
    (:func:`hysteresis_cycles`; :mod:`cdsm.calibration.plant`) at evenly
    spread configurations, at most ``cycle_work`` configurations x position
    cables x joints, run in chunks of :func:`cycle_chunk` cycles (memory
    bounded by :data:`CYCLE_MEMORY`). ``progress``: a progress line on
    stderr (``label``) over the cycles."""
    from .. import plant

    th, _ = as_batch("theta", theta, robot.n, finite=False)  # rows with NaN are left NaN
    mu = as_finite("mu", mu)
    _cdsm.check_friction("mu", mu)
    amplitude = _amplitude(amplitude)
    min_tension = as_finite("min_tension", min_tension)
    cycle_work = as_count("cycle_work", cycle_work, 1)
    N, m = th.shape[0], len(robot.position_cables)
    ok = np.isfinite(th).all(axis=1)
    nan = np.full((N, m), np.nan)
    pull, release, loop = nan.copy(), nan.copy(), nan.copy()
    fp, fr, cycled = np.zeros(N, bool), np.zeros(N, bool), np.zeros(N, bool)
    if ok.any():
        t = th[ok]
        pull[ok] = robot.tensions(t, friction=mu, sliding="pull", min_tension=min_tension)
        release[ok] = robot.tensions(t, friction=mu, sliding="release", min_tension=min_tension)
        fp[ok] = robot.feasible(t, friction=mu, sliding="pull", min_tension=min_tension)
        fr[ok] = robot.feasible(t, friction=mu, sliding="release", min_tension=min_tension)
        effects = {"cable_friction": [mu]}
        if not robot.stretch_feed_forward:
            effects["cable_elasticity"] = [1.0 / robot.axial_stiffness]
        p = plant.params(robot, effects)
        rows = np.flatnonzero(ok)
        most = max(1, int(cycle_work) // max(m * robot.n, 1))
        if len(rows) > most:
            rows = rows[np.unique(np.linspace(0, len(rows) - 1, most).round().astype(int))]
        d = plant.dims(robot)
        k = len(rows) * m
        width = np.full(k, np.nan)
        step = cycle_chunk(robot)
        bar = Progress(k, label, progress, unit="cycles")
        for first in range(0, k, step):
            stop = min(first + step, k)
            theta_cmd, dL = _cycles(th[rows], m, first, stop, amplitude)
            obs, conv = plant.predict(robot, p, theta_cmd, dL, "absolute")
            pos = obs[:, :d].reshape(stop - first, 5, d)
            good = conv.reshape(stop - first, 5).all(axis=1)
            width[first:stop] = np.where(good, np.linalg.norm(pos[:, 2] - pos[:, 4], axis=1), np.nan)
            bar.update(stop - first)
        loop[rows] = width.reshape(len(rows), m)
        cycled[rows] = True
    return FrictionMap(th, robot.fk(np.where(ok[:, None], th, 0.0)), pull, release, fp, fr, loop, float(mu),
                       float(amplitude), float(min_tension), cycled)
