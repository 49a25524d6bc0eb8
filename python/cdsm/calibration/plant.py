"""The real arm as the nominal model plus unmodelled effects, and a virtual
prototype that makes measurement data from it. SI units (m, rad, N).

Effects (all-zero parameters give the nominal model exactly; the equations are
in ``docs/model.md``):

=====================  =====  ====================================================
name                   size   parameters
=====================  =====  ====================================================
actuation_scale        1      s: actuators realise L_ref + (1 + s)(L_cmd - L_ref)
cable_offset           n      constant length offset of each upper cable, m
hole_height            n      hole-height error of each cable pair, m
link_length            n + 1  base->joint 1, then joint i -> disk i length errors, m
cable_elasticity       1      compliance 1/(E A), 1/N (stretch T L / (E A))
hole_clearance         1      c >= 0, m: holes shift c·tanh(theta/0.01) to the concave side
frame_misalignment     3      instrument frame: rotation (rad), x, y (m)
tip_offset             2      measured point offset in the end frame, x, y (m)
=====================  =====  ====================================================
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..inputs import CdsmInputError, as_batch
from ..robot import Robot
from .measurements import Measurements

__all__ = ["EFFECTS", "TYPICAL", "NON_NEGATIVE", "EXAMPLES_N3", "layout", "size", "params", "predict",
           "settle", "VirtualPrototype"]

EFFECTS: Tuple[str, ...] = (
    "actuation_scale", "cable_offset", "hole_height", "link_length",
    "cable_elasticity", "hole_clearance", "frame_misalignment", "tip_offset",
)

# A magnitude a real prototype could have, per effect (for scaling the fit and
# for generating test data): 2 % actuation error, 0.2 mm offsets, 0.2 mm holes,
# 0.3 mm links, a polymer-like compliance (E A ~ 50 N), 0.15 mm clearance,
# 5 mrad / 1 mm frame, 1 mm tip offset.
TYPICAL: Dict[str, float] = {
    "actuation_scale": 0.02, "cable_offset": 2e-4, "hole_height": 2e-4, "link_length": 3e-4,
    "cable_elasticity": 0.02, "hole_clearance": 1.5e-4, "frame_misalignment": 5e-3,
    "tip_offset": 1e-3,
}
# Hidden effects for 3-joint robots, ~1-2x TYPICAL with mixed signs: every
# effect of the library and a two-effect mixture (SI). The virtual-prototype
# checks of compensation use them (tests and benches/bench_compensate.py).
EXAMPLES_N3: Dict[str, Dict[str, List[float]]] = {
    "actuation_scale": {"actuation_scale": [0.03]},
    "cable_offset": {"cable_offset": [3e-4, -2e-4, 1e-4]},
    "hole_height": {"hole_height": [3e-4, -2e-4, 2e-4]},
    "link_length": {"link_length": [4e-4, -3e-4, 2e-4, -2e-4]},
    "cable_elasticity": {"cable_elasticity": [0.02]},
    "hole_clearance": {"hole_clearance": [1.5e-4]},
    "frame_misalignment": {"frame_misalignment": [5e-3, 1e-3, -1e-3]},
    "tip_offset": {"tip_offset": [1e-3, -5e-4]},
    "hole_height + actuation_scale": {"hole_height": [2e-4, -1e-4, 1.5e-4], "actuation_scale": [0.02]},
}
# Parameters that must stay >= 0.
NON_NEGATIVE = ("cable_elasticity", "hole_clearance")


def layout(robot: Robot) -> Dict[str, slice]:
    """Slice of each effect in the flat parameter vector."""
    out, off = {}, 0
    for name, size in robot.core.plant_effects():
        out[name] = slice(off, off + size)
        off += size
    return out


def size(robot: Robot) -> int:
    """Length of the flat parameter vector."""
    return sum(s for _, s in robot.core.plant_effects())


def params(robot: Robot, effects: Optional[Mapping[str, Sequence[float]]] = None) -> np.ndarray:
    """Flat parameter vector from ``{effect: values}`` (others zero); SI units."""
    lay = layout(robot)
    p = np.zeros(size(robot))
    for name, val in (effects or {}).items():
        if name not in lay:
            raise CdsmInputError(f"`effects`: unknown effect {name!r}; known: {', '.join(EFFECTS)}")
        v = np.atleast_1d(np.asarray(val, dtype=np.float64))
        sl = lay[name]
        if v.size != sl.stop - sl.start:
            raise CdsmInputError(f"`effects[{name!r}]`: needs {sl.stop - sl.start} values, got {v.size}")
        p[sl] = v
    return p


def _predict_all(robot: Robot, p, theta_cmd, dL, kind: str, tol: float, max_iter: int):
    pp, single = as_batch("params", p, size(robot))
    t, _ = as_batch("theta_cmd", theta_cmd, robot.n)
    d, _ = as_batch("dL", dL, robot.n)
    if kind not in ("absolute", "displacement"):
        raise CdsmInputError(f"`kind`: expected 'absolute' or 'displacement', got {kind!r}")
    obs, conv, theta = robot.core.plant_predict(pp, t, d, kind == "displacement", float(tol),
                                                 int(max_iter), robot.threads)
    shape = (len(pp), len(t))
    out = obs.reshape(shape + (3,)), conv.reshape(shape), theta.reshape(shape + (robot.n,))
    return tuple(a[0] for a in out) if single else out


def predict(robot: Robot, p, theta_cmd, dL, kind: str = "absolute",
            tol: float = 1e-12, max_iter: int = 100) -> Tuple[np.ndarray, np.ndarray]:
    """Observations of the plant(s) ``p`` ((P,) or (K, P)) for the commands
    ``theta_cmd`` (N, n) rad and ``dL`` (N, n) m: (N, 3) or (K, N, 3) —
    [x, y, phi] (absolute, instrument frame) or [dx, dy, dphi] (displacement)
    — and the converged flags (N,) or (K, N)."""
    obs, conv, _ = _predict_all(robot, p, theta_cmd, dL, kind, tol, max_iter)
    return obs, conv


def settle(robot: Robot, p, theta_cmd, dL, tol: float = 1e-12,
           max_iter: int = 100) -> Tuple[np.ndarray, np.ndarray]:
    """Joint angles (N, n) rad the plant ``p`` (P,) settles at for the nominal
    commands at ``theta_cmd`` (N, n) rad plus ``dL`` (N, n) m — every effect of
    the plant included — and the converged flags (N,); NaN rows where not."""
    _, conv, theta = _predict_all(robot, p, theta_cmd, dL, "absolute", tol, max_iter)
    return theta, conv


@dataclass
class VirtualPrototype:
    """A simulated prototype: the nominal robot with hidden effects, measured
    with Gaussian noise of ``noise`` m (per axis), seeded."""

    robot: Robot
    effects: Dict[str, Sequence[float]] = field(default_factory=dict)
    noise: float = 10e-6
    seed: int = 0

    def measure(self, theta_cmd, dL=None, kind: str = "absolute") -> Measurements:
        """Measure commands ``theta_cmd`` (N, n) rad with upper-cable extras ``dL``
        (N, n) m: a :class:`Measurements` of the given kind (phi not measured)."""
        t, _ = as_batch("theta_cmd", theta_cmd, self.robot.n)
        d = np.zeros_like(t) if dL is None else as_batch("dL", dL, self.robot.n)[0]
        obs, conv = predict(self.robot, params(self.robot, self.effects), t, d, kind)
        if not conv.all():
            raise CdsmInputError(f"virtual prototype: {int((~conv).sum())} commands do not settle")
        rng = np.random.default_rng(self.seed)
        meas = obs[:, :2] + rng.normal(0.0, self.noise, (len(t), 2))
        return Measurements(kind, self.robot.n, d, meas, theta=t, source="virtual prototype")

    def random_commands(self, rows: int, seed: Optional[int] = None, limit: float = np.radians(30.0),
                        dl: float = 1e-3, kind: str = "absolute") -> Tuple[np.ndarray, np.ndarray]:
        """Random commands within ±limit (rad) with upper-cable extras within ±dl
        (m; for displacement data one cable per row gets ±dl exactly)."""
        rng = np.random.default_rng(self.seed + 1 if seed is None else seed)
        n = self.robot.n
        theta = rng.uniform(-limit, limit, (rows, n))
        d = np.zeros((rows, n))
        if kind == "displacement":
            d[np.arange(rows), rng.integers(0, n, rows)] = rng.choice([-dl, dl], rows)
        else:
            d = rng.uniform(-dl, dl, (rows, n))
        return theta, d
