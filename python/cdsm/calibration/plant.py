"""The virtual prototype: the nominal robot with hidden effects
(:mod:`cdsm.plant`, the plant of the Rust core, and its effect library),
measured with noise — the data the diagnosis's tests and benchmarks run on.
SI units (m, rad, N). The plant's functions are re-exported here (their
module is :mod:`cdsm.plant`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import deprecated
from ..inputs import CdsmInputError, as_count, as_finite
from ..plant import (BLOCKS, EFFECT_BLOCKS, EFFECTS, ELASTIC_GEOMETRY, ELASTIC_ON_REQUEST, MAX_PARAMETER,
                     MEMORY_EFFECTS, READING_CODES, SPATIAL_EFFECTS, TYPICAL, bounds, check_commands, check_effects,
                     check_params, command_lengths, commanded_cables, commands, dims, effect_indices, effects_of,
                     layout, linearise, parameter_blocks, parameter_labels, parameter_names, params, predict,
                     reading_codes, settle, size, taut_commands, width)
from ..robot import Robot
from .measurements import Measurements

__all__ = ["EFFECTS", "BLOCKS", "MEMORY_EFFECTS", "EFFECT_BLOCKS", "TYPICAL", "EXAMPLES_N3", "layout", "size",
           "params", "check_params", "MAX_PARAMETER", "effect_indices", "parameter_blocks", "parameter_names",
           "parameter_labels", "bounds", "reading_codes", "predict", "linearise", "settle", "VirtualPrototype",
           "SPATIAL_EFFECTS", "ELASTIC_GEOMETRY", "ELASTIC_ON_REQUEST", "effects_of", "check_effects", "width",
           "dims", "commands", "command_lengths", "taut_commands", "commanded_cables", "check_commands",
           "READING_CODES"]

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
    "backlash": {"backlash": [6e-5, 4e-5, 3e-5]},
    "hole_height + actuation_scale": {"hole_height": [2e-4, -1e-4, 1.5e-4], "actuation_scale": [0.02]},
}


@dataclass
class VirtualPrototype:
    """A simulated prototype: the nominal robot with hidden effects, measured
    with Gaussian noise of ``noise`` m (per axis and reading), seeded. A
    displacement is the difference of two readings, so its noise is
    ``sqrt(2) * noise`` per axis."""

    robot: Robot
    effects: Dict[str, Sequence[float]] = field(default_factory=dict)
    noise: float = 10e-6
    seed: int = 0

    def measure(self, theta_cmd, dL=None, reading="absolute", observe=None, *, kind=None) -> Measurements:
        """Measure commands ``theta_cmd`` (N, n) rad with upper-cable extras
        ``dL`` (N, n) m (spatial: (N, m) on the position-controlled cables),
        run in the given order: a :class:`Measurements` of the given reading
        (``"absolute"``: x, y — spatial x, y, z —; ``"displacement"``: their
        moves; the attitude not measured). ``observe`` (N,) bool: rows to
        measure (the others run only and come out unmeasured). ``kind``: the
        deprecated name of ``reading`` (one release)."""
        reading = deprecated.old_keyword("VirtualPrototype.measure", "kind", "reading", kind, reading)
        t, d, _ = check_commands(self.robot, theta_cmd, dL, "absolute")
        seen = np.ones(len(t), bool) if observe is None else np.asarray(observe, bool)
        codes = np.where(seen, READING_CODES[reading], READING_CODES["unmeasured"])
        obs, conv = predict(self.robot, params(self.robot, self.effects), t, d, codes)
        if not conv[seen].all():
            raise CdsmInputError(f"virtual prototype: {int((~conv[seen]).sum())} commands do not settle")
        rng = np.random.default_rng(self.seed)
        sigma = self.noise * (np.sqrt(2.0) if reading == "displacement" else 1.0)
        k = dims(self.robot)
        meas = obs[:, :k] + rng.normal(0.0, sigma, (len(t), k))
        meas[~seen] = np.nan
        return Measurements(reading, self.robot.n, d, meas, theta=t, source="virtual prototype")

    def random_commands(self, rows: int, seed: Optional[int] = None, limit: Optional[float] = None,
                        dl: float = 1e-3, reading: str = "absolute", taut: bool = False, min_tension: float = 0.0,
                        max_draws: Optional[int] = None, *,
                        kind: Optional[str] = None) -> Tuple[np.ndarray, np.ndarray]:
        """``rows`` random commands: joint angles ``theta`` (rows, n), rad,
        uniform within ±``limit`` rad of the rest angles (default 30°; an
        elastic arm's default 0: its rows are commanded by their cables
        alone, ``theta`` the rest angles, as a recording's), and extras
        ``dL`` (rows, m), m, on the
        m position-controlled cables (a planar arm's upper cables), uniform
        within ±``dl`` m — for ``reading="displacement"`` one cable per row gets
        ±``dl`` exactly and the others 0. Seeded: ``seed``, default the
        prototype's ``seed + 1``; the same seed gives the same commands.

        ``taut=True`` (for planning an experiment the nominal model can use):
        only commands the nominal model keeps taut (:func:`taut_commands`:
        every position cable's tension above ``min_tension``, N, under the
        robot file's loads, at the commanded angles and where the command's
        lengths + dL take the nominal arm — the rows the diagnosis does not
        flag as needing a slack cable). Rejection sampling: candidates are
        drawn as above in batches of ``max(rows, 100)`` and the first ``rows``
        taut ones kept in draw order; after ``max_draws`` candidates (default
        ``max(1000, 100 * rows)``) without ``rows`` taut ones a
        :class:`CdsmInputError` says how many were tried and the acceptance
        rate (narrow ``limit``, lower ``min_tension`` or raise ``max_draws``).
        ``taut=False`` (default) draws exactly as before, without statics.
        ``kind``: the deprecated name of ``reading`` (one release)."""
        reading = deprecated.old_keyword("VirtualPrototype.random_commands", "kind", "reading", kind, reading)
        rows = as_count("rows", rows)
        if limit is None:
            limit = 0.0 if self.robot.is_elastic else np.radians(30.0)
        limit, dl = as_finite("limit", limit), as_finite("dl", dl)
        if limit < 0.0 or dl < 0.0:
            raise CdsmInputError(f"`{'limit' if limit < 0.0 else 'dl'}`: expected a half-width >= 0, got "
                                 f"{limit if limit < 0.0 else dl!r}")
        if reading not in ("absolute", "displacement"):
            raise CdsmInputError(f"`reading`: expected 'absolute' or 'displacement', got {reading!r}")
        if not isinstance(taut, (bool, np.bool_)):
            raise CdsmInputError(f"`taut`: expected True or False, got {taut!r}")
        min_tension = as_finite("min_tension", min_tension)
        if min_tension < 0.0:
            raise CdsmInputError(f"`min_tension`: expected a tension >= 0 N, got {min_tension!r}")
        if not taut and (min_tension != 0.0 or max_draws is not None):
            raise CdsmInputError(f"`{'min_tension' if min_tension != 0.0 else 'max_draws'}`: applies only "
                                 "with taut=True (commands drawn without statics otherwise)")
        draws = max(1000, 100 * rows) if max_draws is None else as_count("max_draws", max_draws, 1)
        rng = np.random.default_rng(self.seed + 1 if seed is None else seed)
        if not taut:
            return _draw_commands(self.robot, rng, rows, limit, dl, reading)
        kept, tried, found = [(np.zeros((0, self.robot.n)), np.zeros((0, commands(self.robot))))], 0, 0
        while found < rows and tried < draws:
            theta, d = _draw_commands(self.robot, rng, max(rows, 100), limit, dl, reading)
            use = min(len(theta), draws - tried)  # the last batch is drawn whole: the same stream whatever max_draws
            ok = taut_commands(self.robot, theta[:use], d[:use], reading, min_tension)
            kept.append((theta[:use][ok], d[:use][ok]))
            tried, found = tried + use, found + int(ok.sum())
        if found < rows:
            raise CdsmInputError(
                f"random_commands: {found} of {tried} commands drawn (acceptance rate {found / tried:.2%}) keep "
                f"every position cable above {min_tension:g} N by the nominal statics; {rows} asked for within "
                f"`max_draws` = {draws} (narrow `limit`, lower `min_tension` or raise `max_draws`)")
        return (np.concatenate([t for t, _ in kept])[:rows], np.concatenate([d for _, d in kept])[:rows])


def _draw_commands(robot: Robot, rng: np.random.Generator, rows: int, limit: float, dl: float,
                   reading: str) -> Tuple[np.ndarray, np.ndarray]:
    """``rows`` commands (theta (rows, n) rad, dL (rows, m) m) from ``rng``
    (:meth:`VirtualPrototype.random_commands`)."""
    n, w = robot.n, commands(robot)
    theta = robot.rest_angles + rng.uniform(-limit, limit, (rows, n))
    d = np.zeros((rows, w))
    if reading == "displacement":
        d[np.arange(rows), rng.integers(0, w, rows)] = rng.choice([-dl, dl], rows)
    else:
        d = rng.uniform(-dl, dl, (rows, w))
    return theta, d


#: ``KIND_CODES`` and ``kind_codes`` (cdsm 0.2's names) warn for one release.
__getattr__ = deprecated.module_getattr(__name__, {"KIND_CODES": "READING_CODES", "kind_codes": "reading_codes"},
                                        globals())
