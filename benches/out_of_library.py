"""Effects OUTSIDE the diagnosis library, for benchmarking its false-"explained"
rate (``benches/bench_error_rates.py``). SI units (m, rad).

None of these is (or should become) an effect of
:mod:`cdsm.calibration.plant`: a diagnosis that calls data made with one of
them "explained" has wrongly claimed that its library accounts for the gap.

Actuator-side effects map the *commanded* lengths ``c`` (N, w) of the
commanded cables (the n upper cables of a planar arm, every cable
of a spatial one's position set, an elastic arm's tendons too) of the rows, run in order, to the lengths
the screws *realise*; the nominal plant is then fed
``dL' = realised - L_pos,nom(theta_cmd)`` while the data keep the commanded
``dL`` (all the diagnosis sees). Every effect of :data:`EFFECTS` applies to
both kinds of arm. ``d = c - L_ref`` is the
commanded change from the length ``L_ref`` at the rest pose (straight for a
rigid arm; per cable). The
instrument-side effect (tracker drift) acts on the measured positions.

=====================  ======================================================
effect                 realised length / measurement
=====================  ======================================================
quadratic_actuator     L_ref + d + k2_i d²            (k2 ~ 0.3-0.6 1/m)
cubic_actuator         L_ref + d + k3_i d³            (k3 ~ 4-8 1/m²)
lead_screw             c + a_i sin(2π d / pitch)      (pitch 1 mm, a 20-40 µm)
thermal_drift          c (1 + j k)                    j the row (execution order), k ~ 1-2e-5
tracker_drift          measured p + (row index) v     v ~ 5 µm/row on each axis
=====================  ======================================================

A capstan-like friction loss in the holes was in this set until
``cable_friction`` joined the library (issue 25). The quadratic and cubic
actuators differ from ``actuation_scale`` (linear) and ``cable_offset`` (constant); the
lead screw's error is periodic in the commanded length; the drift is in time
(row order), not in the configuration.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from cdsm import Robot
from cdsm.calibration import measurements, plant

__all__ = ["OutOfLibrary", "QuadraticActuator", "CubicActuator", "LeadScrew", "ThermalDrift", "TrackerDrift",
           "EFFECTS", "to_frame", "measure", "commanded_lengths"]


def _signs(rng: np.random.Generator, n: int) -> np.ndarray:
    return rng.choice([-1.0, 1.0], n)


class OutOfLibrary:
    """An effect outside the library. ``realise`` maps commanded
    cable lengths (N, w) m (:func:`commanded_lengths`), rows in execution order, to realised ones; ``observe`` maps
    measured positions (N, k) m (instrument frame; k = 2 planar, 3 spatial)
    to what is read."""

    name = "out_of_library"

    @classmethod
    def sample(cls, rng: np.random.Generator, robot: Robot) -> "OutOfLibrary":  # pragma: no cover - abstract
        """Random parameters for ``robot`` (one per commanded cable, or per
        axis of the instrument)."""
        raise NotImplementedError

    def realise(self, robot: Robot, theta: np.ndarray, commanded: np.ndarray) -> np.ndarray:
        return commanded

    def observe(self, xy: np.ndarray) -> np.ndarray:
        """Read positions (N, k) m, k = 2 planar, 3 spatial."""
        return xy

    def describe(self) -> str:
        return self.name


def commanded_lengths(robot: Robot, theta: np.ndarray) -> np.ndarray:
    """(N, w) lengths (m) of the cables a row commands
    (:func:`measurements.commanded_cables`: the position cables, an elastic
    arm's tendons too) at the joint angles ``theta`` (N, n) rad."""
    return robot.cable_lengths(theta)[:, measurements.commanded_cables(robot)]


def _straight(robot: Robot) -> np.ndarray:
    """The commanded cables' lengths (m) at the rest pose (straight for a
    rigid arm), the reference of the actuator errors."""
    return commanded_lengths(robot, robot.rest_angles[None, :])[0]


@dataclass
class PowerActuator(OutOfLibrary):
    """Realised change ``d + k d^p`` per cable, ``d`` the commanded change
    (m) from the straight pose (k (w,) in m^(1-p)); subclasses set ``p``,
    the range of |k| and how it is written."""

    k: np.ndarray
    power = 2
    span = (0.0, 0.0)
    symbol, unit, precision = "k", "", 2

    @classmethod
    def sample(cls, rng, robot):
        w = plant.commands(robot)
        return cls(_signs(rng, w) * rng.uniform(*cls.span, w))

    def realise(self, robot, theta, commanded):
        ref = _straight(robot)
        d = commanded - ref
        return ref + d + self.k * d ** self.power

    def describe(self):
        sup = {2: "²", 3: "³"}[self.power]
        return (f"d + {self.symbol}·d{sup}, {self.symbol} = "
                f"{np.array2string(self.k, precision=self.precision)} {self.unit}")


class QuadraticActuator(PowerActuator):
    """Realised change ``d + k2 d²`` per cable (k2 (w,) 1/m, 0.3-0.6)."""

    name = "quadratic_actuator"
    power, span = 2, (0.3, 0.6)
    symbol, unit, precision = "k2", "1/m", 2


class CubicActuator(PowerActuator):
    """Realised change ``d + k3 d³`` per cable (k3 (w,) 1/m², 4-8)."""

    name = "cubic_actuator"
    power, span = 3, (4.0, 8.0)
    symbol, unit, precision = "k3", "1/m²", 1


@dataclass
class LeadScrew(OutOfLibrary):
    """Periodic lead-screw error: ``c + a sin(2π (c - L_ref) / pitch)``
    (a (n,) m, pitch m)."""

    a: np.ndarray
    pitch: float = 1e-3
    name = "lead_screw"

    @classmethod
    def sample(cls, rng, robot):
        return cls(rng.uniform(20e-6, 40e-6, plant.commands(robot)), 1e-3)

    def realise(self, robot, theta, commanded):
        ref = _straight(robot)
        return commanded + self.a * np.sin(2.0 * np.pi * (commanded - ref) / self.pitch)

    def describe(self):
        return f"a sin(2π d / {self.pitch * 1e3:g} mm), a = {np.array2string(self.a * 1e6, precision=0)} µm"


@dataclass
class ThermalDrift(OutOfLibrary):
    """The cables warm over the run: row ``j`` (execution order) realises
    every commanded length ``c`` as ``c (1 + j k)`` (k ~ 1-2e-5 per row: a
    polymer cable, ~1e-4 /K, warming about 10 K over 60 rows), a length error
    growing in time."""

    k: float = 1.5e-5
    name = "thermal_drift"

    @classmethod
    def sample(cls, rng, robot):
        return cls(float(rng.uniform(1e-5, 2e-5)))

    def realise(self, robot, theta, commanded):
        return commanded * (1.0 + self.k * np.arange(len(commanded))[:, None])

    def describe(self):
        return f"c (1 + j k), k = {self.k:.2g} per row"


@dataclass
class TrackerDrift(OutOfLibrary):
    """The instrument's reading drifts linearly in time: row ``j`` (execution
    order) is read ``j · v`` off (v (k,) m per row, instrument frame; about
    5 µm per row on each axis)."""

    v: np.ndarray = field(default_factory=lambda: np.array([5e-6, 5e-6]))
    name = "tracker_drift"

    @classmethod
    def sample(cls, rng, robot):
        k = plant.dims(robot)
        return cls(_signs(rng, k) * rng.uniform(4e-6, 6e-6, k))

    def observe(self, xy):
        return xy + np.arange(len(xy))[:, None] * self.v

    def describe(self):
        return f"drift {np.array2string(self.v * 1e6, precision=1)} µm/row"


#: The out-of-library effects, by name.
EFFECTS = {c.name: c for c in (QuadraticActuator, CubicActuator, LeadScrew, ThermalDrift, TrackerDrift)}


def to_frame(xy: np.ndarray, frame) -> np.ndarray:
    """Positions seen in an instrument frame: planar (N, 2) m with ``frame``
    ``(alpha, tx, ty)`` (rad, m, m): ``Rot(alpha) p + t``; spatial (N, 3) m
    with ``frame`` ``(R (3, 3), t (3,) m)``: ``R p + t``; ``None``:
    unchanged."""
    if frame is None:
        return xy
    if xy.shape[1] == 3:
        rot, t = frame
        return xy @ np.asarray(rot, float).T + np.asarray(t, float)
    a, tx, ty = frame
    c, s = np.cos(a), np.sin(a)
    return xy @ np.array([[c, s], [-s, c]]) + np.array([tx, ty])


def measure(robot: Robot, effect: Optional[OutOfLibrary], theta: np.ndarray, dL: np.ndarray,
            noise: float = 10e-6, seed: int = 0, frame=None) -> measurements.Measurements:
    """Absolute measurements (SI) of the rows ``theta`` (N, n) rad, ``dL``
    (N, w) m, run in order, on the nominal plant with ``effect`` (None:
    nominal), Gaussian noise ``noise`` m per axis and reading (seeded), read
    in the instrument frame ``frame`` (see :func:`to_frame`; None: the base
    frame). The table carries the *commanded* dL."""
    theta = np.asarray(theta, float)
    dL = np.asarray(dL, float)
    k = plant.dims(robot)
    nominal = commanded_lengths(robot, theta)
    commanded = nominal + dL
    realised = commanded if effect is None else effect.realise(robot, theta, commanded)
    obs, ok = plant.predict(robot, np.zeros(plant.size(robot)), theta, realised - nominal)
    if not np.all(ok):
        raise RuntimeError(f"{int((~ok).sum())} rows of {effect.name if effect else 'nominal'} do not settle")
    rng = np.random.default_rng(seed)
    xy = to_frame(obs[:, :k] + rng.normal(0.0, noise, (len(theta), k)), frame)
    if effect is not None:
        xy = effect.observe(xy)
    return measurements.Measurements("absolute", robot.n, dL, xy, theta=theta,
                                     source=f"out-of-library: {effect.name if effect else 'nominal'}")
