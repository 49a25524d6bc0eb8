"""Feasibility (slack-cable) maps and elastic-cable tip effects over a joint grid.

Thin helpers over :meth:`cdsm.Robot.tensions`, :meth:`~cdsm.Robot.feasible`
and :meth:`~cdsm.Robot.solve_cables_elastic` for reports (e.g. the paper's
workspace: every joint -30..30 deg in 5 deg steps). SI units: m, rad, N.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..robot import Robot
from .workspace import joint_grid

__all__ = ["FeasibilityMap", "feasibility_map", "elastic_tip_deviation"]


@dataclass(frozen=True)
class FeasibilityMap:
    """theta (N, n) rad; pose (N, 3) tip [x, y, phi]; tension (N, n) upper
    tensions, N; feasible (N,) all upper tensions > min_tension."""

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
    T = robot.tensions(th, lower=lower, tip_wrench=tip_wrench, gravity=gravity)
    with np.errstate(invalid="ignore"):
        ok = np.all(T > min_tension, axis=1)
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
