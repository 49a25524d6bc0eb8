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

from ..robot import Robot
from .workspace import joint_grid
from ..display import ShortRepr

__all__ = ["FeasibilityMap", "feasibility_map", "elastic_tip_deviation", "load_readings", "Reading",
           "reading_maps", "STANDARD_GRAVITY"]

#: Standard gravity, m/s^2.
STANDARD_GRAVITY = 9.80665


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
    th = joint_grid(robot.n) if theta is None else np.atleast_2d(np.asarray(theta, dtype=float))
    T = robot.tensions(th, lower=lower, tip_wrench=tip_wrench, gravity=gravity, min_tension=min_tension)
    ok = np.asarray(robot.feasible(th, lower=lower, tip_wrench=tip_wrench, gravity=gravity,
                                   min_tension=min_tension), bool)
    return FeasibilityMap(th, robot.fk(th), T, ok, float(min_tension))


def elastic_tip_deviation(robot: Robot, theta, youngs_modulus: Optional[float] = None,
                          diameter: Optional[float] = None, lower=None) -> np.ndarray:
    """Tip deviation (N, 3) [dX m, dY m, dphi rad] when the rigid model's cable
    lengths at ``theta`` (N, n) rad are commanded to elastic cables (optionally of another
    material); NaN where the elastic solve did not converge."""
    th = np.atleast_2d(np.asarray(theta, dtype=float))
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
    th = joint_grid(robot.n) if theta is None else np.atleast_2d(np.asarray(theta, dtype=float))
    out = {}
    for name, r in load_readings(robot).items():
        fm = feasibility_map(r, th)
        el = elastic_tip_deviation(r, th)
        el[~fm.feasible] = np.nan
        out[name] = Reading(r, fm, el)
    return out
