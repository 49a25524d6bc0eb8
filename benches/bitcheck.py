#!/usr/bin/env python3
"""Bit-identity harness: every core entry point and the main Python pipelines,
dumped by one ``cdsm`` and compared bit for bit with another's dump.

    python benches/bitcheck.py dump OUT.npz [--quick] [--threads N] [--robots a,b] [--only GLOB]... [-v]
    python benches/bitcheck.py compare A.npz B.npz [--allow 'GLOB=REASON']... [--allow-file FILE]
    python benches/bitcheck.py run-both [--baseline DIR] [--tree DIR] [--out-dir DIR] [--quick] [dump/compare options]

``dump`` runs, with whatever ``cdsm`` is importable (``PYTHONPATH`` decides;
the dump records which), the table :data:`CASES` on the robots of
:func:`robot_table` (every packaged robot, ``examples/two_section_arm.toml``,
``benches/two_universal_nylon.toml``, an 8-joint spatial arm and the core's
built-in paper arm) with fixed, seeded inputs, and stores every result under a
stable key ``robot/case/variant`` (one array per field: ``KEY#field``) in an
``.npz``: floats as float64, integers as int64, booleans, strings as text. A
call that raises stores its exception (``KEY#!error``: type and message), so
error paths are compared too; one that raises ``AttributeError``,
``TypeError`` or ``ImportError`` (an entry point renamed or re-signed by a
refactor) is stored as *missing* (``KEY#!missing``); warnings other than
deprecations are stored too (``KEY#!warnings``). The full dump takes about
45 s and ``--quick`` (7 robots, fewer samples, a smaller diagnosis) 20 s on 2
busy cores (load 15); ``run-both`` about 2 min. Results do not depend on
``--threads`` (0, 1 and 3 give identical dumps).

``compare`` compares two dumps bit for bit: float64 through ``view(uint64)``
with every NaN equal to every NaN (any payload or sign) and ``-0.0`` against
``+0.0`` reported apart as ``signed zero``. It prints a table of the keys
that differ (count of differing elements, largest absolute and relative
difference), keys missing or absent on either side, and exits 1 if anything
differs that no ``--allow GLOB=REASON`` (fnmatch on the key; the reason is
printed with the accepted rows) accepts. ``--allow-file`` reads such lines
(``GLOB = reason``, ``#`` comments).

``run-both`` dumps with the baseline (``--baseline``, default
``/work/baseline/src/python``: the sources of 4e92c59 with their compiled
``_cdsm`` beside them) and with a tree (``--tree``, default the tree holding
this script: ``PYTHONPATH=<tree>/python``, so its compiled ``_cdsm`` must be
in ``<tree>/python/cdsm``), each in its own subprocess with only that
``PYTHONPATH``, checks that each imported the ``cdsm`` it was meant to, and
compares (``--out-dir`` keeps the two dumps). The same tree as baseline and
tree checks that the dump is deterministic.

Adding a check: write a function ``case_x(ctx, rec)`` that calls
``rec("variant", lambda: <call>)`` for each variant (``rec`` returns the
value, or None when the call raised) and list it in :data:`CASES` with the
kinds it applies to. ``ctx`` (:class:`Ctx`) holds the robot and its seeded
inputs; every input is drawn from a generator seeded by robot and purpose
(:meth:`Ctx.rng`), so selecting cases does not move the others' inputs.
"""

from __future__ import annotations

import argparse
import dataclasses
import fnmatch
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
import zlib
from pathlib import Path
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

TREE = Path(__file__).resolve().parents[1]
DEFAULT_BASELINE = "/work/baseline/src/python"

#: Exceptions that mean "this entry point is not there (or not with this
#: signature)" rather than "it refused the input".
MISSING = (AttributeError, TypeError, ImportError)

NONE = "\x00None"  # how a None result is stored
EMPTY_DICT = "\x00{}"

# Sizes of the plant's parameter blocks used to draw test effects (a copy of
# cdsm.calibration.plant.TYPICAL at 4e92c59, kept here so that the inputs do
# not move when the package's table does).
TYPICAL = {"actuation_scale": 0.02, "cable_offset": 2e-4, "hole_height": 2e-4, "hole_position": 2e-4,
           "link_length": 3e-4, "cable_elasticity": 0.02, "hole_clearance": 1.5e-4, "clearance_width": 0.01,
           "frame_misalignment": 5e-3, "tip_offset": 1e-3, "backlash": 3e-5, "joint_axis": 1e-2,
           "cable_friction": 0.15}

TOL, MAX_ITER = 1e-12, 100


# ---------------------------------------------------------------------------
# results as flat arrays
# ---------------------------------------------------------------------------
def _join(path: str, part: str) -> str:
    part = str(part).replace("#", "%23").replace("=", "%3D")
    return f"{path}.{part}" if path else part


def _array(a: np.ndarray) -> np.ndarray:
    """One stored array: float64, int64, bool or text."""
    k = a.dtype.kind
    if k == "f":
        return np.ascontiguousarray(a, np.float64)
    if k == "c":
        return np.ascontiguousarray(np.stack([a.real, a.imag], axis=-1), np.float64)
    if k in "iu":
        return np.ascontiguousarray(a, np.int64)
    if k == "b":
        return np.ascontiguousarray(a, bool)
    if k in "US":
        return np.ascontiguousarray(a.astype(str))
    raise TypeError(f"cannot store dtype {a.dtype}")


#: (class, field) -> the field's name in cdsm 0.3 (renamed in place, issue 33):
#: a tree before the rename stores its values under the new key, so both trees compare.
FIELD_RENAMES = {("Scenario", "kind"): "error", ("ErrorBudget", "kinds"): "group_types",
                 ("Measurements", "kind"): "reading", ("Suggestion", "kind"): "reading",
                 ("Prepared", "kinds"): "reading_codes"}


def flatten(v, path: str, out: Dict[str, np.ndarray], depth: int = 0) -> None:
    """Every number, flag and text of ``v`` into ``out`` under ``path`` (fields
    joined by ``.``, items by ``[i]``)."""
    if depth > 8:
        out[path] = np.array(f"<{type(v).__name__} nested too deep>")
    elif v is None:
        out[path] = np.array(NONE)
    elif isinstance(v, (bool, np.bool_)):
        out[path] = np.array(bool(v))
    elif isinstance(v, (int, np.integer)):
        out[path] = np.array(int(v), np.int64) if -2 ** 63 <= int(v) < 2 ** 63 else np.array(str(v))
    elif isinstance(v, (float, np.floating)):
        out[path] = np.array(float(v), np.float64)
    elif isinstance(v, (complex, np.complexfloating)):
        out[path] = np.array([v.real, v.imag], np.float64)
    elif isinstance(v, str):
        out[path] = np.array(v)
    elif isinstance(v, bytes):
        out[path] = np.frombuffer(v, np.uint8).astype(np.int64)
    elif isinstance(v, np.ndarray):
        if v.dtype.kind == "O":
            flatten(v.tolist(), path, out, depth + 1)
        else:
            out[path] = _array(v)
    elif isinstance(v, dict):
        if not v:
            out[path] = np.array(EMPTY_DICT)
        for k, x in v.items():
            flatten(x, _join(path, k), out, depth + 1)
    elif isinstance(v, (list, tuple)):
        scalar = (bool, int, float, np.bool_, np.integer, np.floating)
        if not v:
            out[path] = np.zeros(0)
        elif all(isinstance(x, scalar) for x in v) and len({isinstance(x, (bool, np.bool_)) for x in v}) == 1:
            out[path] = _array(np.asarray(v))
        elif all(isinstance(x, str) for x in v):
            out[path] = np.asarray(v, str)
        else:
            for i, x in enumerate(v):
                flatten(x, f"{path}[{i}]", out, depth + 1)
    elif hasattr(v, "core") and hasattr(v, "to_toml"):  # a cdsm.Robot
        flatten({"toml": v.to_toml()}, path, out, depth + 1)
    elif type(v).__name__ == "CoreRobot":
        flatten({"toml": v.to_toml()}, path, out, depth + 1)
    elif dataclasses.is_dataclass(v) and not isinstance(v, type):
        flatten({FIELD_RENAMES.get((type(v).__name__, f.name), f.name): getattr(v, f.name)
                 for f in dataclasses.fields(v) if not f.name.startswith("_")}, path, out, depth + 1)
    elif type(v).__module__.startswith("cdsm"):  # the core's result classes and the like
        attrs = {}
        for name in sorted(dir(v)):
            if name.startswith("_"):
                continue
            x = getattr(v, name)
            if not callable(x):
                attrs[name] = x
        flatten(attrs, path, out, depth + 1)
    else:
        out[path] = np.array(f"<{type(v).__module__}.{type(v).__name__}>")


def solution(s) -> dict:
    """A :class:`cdsm.Solution` with its derived fields (reason names, feasibility)."""
    out = {f.name: getattr(s, f.name) for f in dataclasses.fields(s) if not f.name.startswith("_")}
    out["reason"] = s.reason
    out["feasible"] = s.feasible
    return out


# ---------------------------------------------------------------------------
# recording
# ---------------------------------------------------------------------------
class Recorder:
    """Runs the calls of the cases and keeps their flattened results."""

    def __init__(self, only: Optional[Sequence[str]] = None):
        self.out: Dict[str, np.ndarray] = {}
        self.seconds: Dict[str, float] = {}
        self.only = list(only or [])
        self.prefix = ""
        self.keys: set = set()

    def wanted(self, key: str) -> bool:
        return not self.only or any(fnmatch.fnmatchcase(key, g) for g in self.only)

    def __call__(self, variant: str, thunk: Callable[[], object], needed: bool = False):
        """Run ``thunk`` and record its result (or exception) under
        ``prefix/variant``; the value, or None when it raised. A key that
        ``only`` leaves out is not run, unless ``needed`` (then only not kept)."""
        key = f"{self.prefix}/{variant}"
        if "#" in key or "=" in key:
            raise ValueError(f"bitcheck: key {key!r} must not hold '#' or '='")
        if not self.wanted(key):
            if not needed:
                return None
            try:
                return thunk()
            except Exception:
                return None
        if key in self.keys:
            raise ValueError(f"bitcheck: key {key!r} recorded twice")
        self.keys.add(key)
        t = time.perf_counter()
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                value = thunk()
        except MISSING as exc:
            self.out[f"{key}#!missing"] = np.array(f"{type(exc).__name__}: {exc}")
            return None
        except (KeyboardInterrupt, SystemExit):
            raise
        except BaseException as exc:  # CdsmInputError, a Rust panic, ...
            self.out[f"{key}#!error"] = np.array(f"{type(exc).__name__}: {exc}")
            return None
        finally:
            self.seconds[key] = time.perf_counter() - t
        leaves: Dict[str, np.ndarray] = {}
        flatten(value, "", leaves)
        seen = [f"{w.category.__name__}: {w.message}" for w in caught
                if not issubclass(w.category, (DeprecationWarning, PendingDeprecationWarning, FutureWarning))]
        if seen:
            leaves["!warnings"] = np.array(sorted(set(seen)))
        for f, a in leaves.items():
            self.out[f"{key}#{f}"] = a
        return value


# ---------------------------------------------------------------------------
# robots and their inputs
# ---------------------------------------------------------------------------
def robot_table() -> Dict[str, Callable[[], object]]:
    """Robot name -> builder (public API only). Every packaged robot, the
    example and benchmark files, an 8-joint spatial arm and the core's
    built-in paper arm."""
    import cdsm
    try:
        from cdsm.robot import packaged_robots
        names = packaged_robots()
    except MISSING:
        names = sorted(p.stem for p in (Path(cdsm.__file__).parent / "robots").glob("*.toml"))
    table: Dict[str, Callable[[], object]] = {}
    for name in names:
        table[name] = (lambda nm=name: cdsm.Robot.packaged(nm))
    table["two_section_arm"] = lambda: cdsm.Robot.from_toml(str(TREE / "examples" / "two_section_arm.toml"))
    table["two_universal_nylon"] = lambda: cdsm.Robot.from_toml(str(TREE / "benches" / "two_universal_nylon.toml"))

    def spatial8():
        sys.path.insert(0, str(TREE / "benches"))
        try:
            from bench_scale import spatial_toml
        finally:
            sys.path.pop(0)
        return cdsm.Robot.from_toml_str(spatial_toml(4))

    table["spatial8"] = spatial8
    table["paper_core"] = cdsm.Robot.paper
    return table


class Ctx:
    """One robot and its seeded inputs (rad, m, N)."""

    def __init__(self, name: str, robot, threads: int, quick: bool):
        self.name, self.robot, self.core = name, robot, robot.core
        robot.threads = threads
        self.threads, self.quick = threads, quick
        self.kind = robot.kind
        self.planar = self.kind == "planar"
        self.n = robot.n
        self.pos = list(robot.position_cables)
        self.m = len(self.pos)
        self.cables = robot.cables
        self.forces = self.cables - self.m
        self.task = 3 if self.planar else 6
        self.big = self.n > 12
        self.limits = np.array(robot.joint_limits, float)
        lo, hi = self.limits[:, 0], self.limits[:, 1]
        rows = 6 if self.big else (37 if self.planar else 13)  # odd counts: SIMD lanes and packs with a remainder
        alt = np.arange(self.n) % 2 == 0
        self.theta = np.vstack([np.zeros(self.n), self.rng("theta").uniform(0.9 * lo, 0.9 * hi, (rows - 3, self.n)),
                                np.where(alt, 0.999 * hi, 0.999 * lo), np.where(alt, 1.15 * hi, 1.15 * lo)])
        self.inside = self.theta[:-1]  # the last row lies outside the joint limits
        self.straight = float(robot.straight_length)
        #: hole coordinates: planar the (2n, n+1, 2, 2) layout, spatial every [x, y, z] (flat_holes)
        self.hole_width = 2 * self.n * (self.n + 1) * 4 if self.planar else len(robot.flat_holes)

    def rng(self, purpose: str) -> np.random.Generator:
        return np.random.default_rng(zlib.crc32(f"{self.name}/{purpose}".encode()))

    def lengths(self, theta) -> np.ndarray:
        """(N, m) position-cable lengths, m (public API)."""
        return np.asarray(self.robot.cable_lengths(theta))[:, self.pos]

    def gravity3(self) -> List[float]:
        return [0.0, -9.80665, 0.0] if self.planar else [0.0, 0.0, -9.80665]

    def core_wrench(self, rows: int = 0) -> np.ndarray:
        """A tip wrench the core takes: planar [Fx, Fy, Fz = 0, Mz], spatial [F, M]; N, N m."""
        r = self.rng(f"wrench{rows}")
        w = r.uniform(-0.3, 0.3, (max(rows, 1), 6))
        w[:, 3:] *= 0.02
        if self.planar:
            w = np.column_stack([w[:, 0], w[:, 1], np.zeros(len(w)), w[:, 5]])
        return flat(w if rows else w[0])

    def api_wrench(self, rows: int = 0) -> np.ndarray:
        """The same wrench in the task space: planar [Fx, Fy, Mz], spatial [F, M]."""
        w = self.core_wrench(rows).reshape(-1, 4 if self.planar else 6)
        if self.planar:
            w = w[:, [0, 1, 3]]
        return w if rows else w[0]


def flat(a) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, float).reshape(-1))


# ---------------------------------------------------------------------------
# the core (Robot.core / cdsm._cdsm.CoreRobot)
# ---------------------------------------------------------------------------
CORE_GETTERS = ("kind", "n", "name", "joint_limits", "axes", "gravity", "straight_length", "cables",
                "position_cables", "cable_ends", "cable_tensions", "flat_holes", "radii", "mass", "offsets",
                "joint_disks", "disk_link_after", "disk_thickness", "com", "youngs_modulus", "cable_diameter",
                "routing_length", "axial_stiffness", "holes")

#: The core's batch maps of theta (N, n).
THETA_MAPS = ("fk", "fk_matrix", "disk_frames", "fk_jacobian", "cable_lengths", "cable_jacobian", "within_limits")


def case_core_describe(ctx: Ctx, rec) -> None:
    c = ctx.core
    for g in CORE_GETTERS:
        rec(g, lambda: getattr(c, g))
    rec("to_toml", lambda: c.to_toml())
    rec("plant_effects", lambda: c.plant_effects())
    rec("plant_bounds", lambda: c.plant_bounds())
    rec("roundtrip", lambda: type(c).from_toml(c.to_toml()).to_toml())


def case_core_maps(ctx: Ctx, rec) -> None:
    c, th = ctx.core, ctx.theta
    bad = th.copy()
    bad[2, 0] = np.nan
    for f in THETA_MAPS:
        rec(f"{f}/rows", lambda: getattr(c, f)(flat(th), ctx.threads))
        rec(f"{f}/one", lambda: getattr(c, f)(flat(th[1]), ctx.threads))
        rec(f"{f}/empty", lambda: getattr(c, f)(np.zeros(0), ctx.threads))
        rec(f"{f}/ragged", lambda: getattr(c, f)(np.zeros(ctx.n + 1), ctx.threads))
        rec(f"{f}/nan", lambda: getattr(c, f)(flat(bad), ctx.threads))


def cable_targets(ctx: Ctx) -> np.ndarray:
    """(N, m) lengths: nominal, perturbed, two that no configuration realises."""
    L = ctx.lengths(ctx.theta)
    pert = L + ctx.rng("dlengths").uniform(-2e-4, 2e-4, L.shape)
    return np.vstack([L, pert, L[0] + 0.05, L[0] * 0.5])


def case_core_solve_cables(ctx: Ctx, rec) -> None:
    c = ctx.core
    L = cable_targets(ctx)
    seed = np.vstack([ctx.theta, ctx.theta, ctx.theta[:2]]) + ctx.rng("seed").normal(0.0, 0.05, (len(L), ctx.n))
    for method in ("auto", "newton", "closed_form"):
        for lim in (False, True):
            for s in (None, seed):
                v = f"{method}/{'limits' if lim else 'free'}/{'seeded' if s is not None else 'zero'}"
                rec(v, lambda: c.solve_cables(flat(L), None if s is None else flat(s), method, TOL, MAX_ITER, lim,
                                              ctx.threads))
    rec("newton/max_iter2", lambda: c.solve_cables(flat(L), None, "newton", TOL, 2, False, ctx.threads))
    rec("newton/tol1e-6", lambda: c.solve_cables(flat(L), None, "newton", 1e-6, MAX_ITER, False, ctx.threads))
    rec("error/method", lambda: c.solve_cables(flat(L), None, "bogus", TOL, MAX_ITER, False, ctx.threads))
    rec("error/tol", lambda: c.solve_cables(flat(L), None, "auto", -1.0, MAX_ITER, False, ctx.threads))
    rec("error/max_iter", lambda: c.solve_cables(flat(L), None, "auto", TOL, 0, False, ctx.threads))
    rec("error/width", lambda: c.solve_cables(np.zeros(ctx.m + 1), None, "auto", TOL, MAX_ITER, False, ctx.threads))
    rec("error/seed", lambda: c.solve_cables(flat(L), np.zeros(3), "auto", TOL, MAX_ITER, False, ctx.threads))
    nan = L.copy()
    nan[1, 0] = np.nan
    rec("error/nan", lambda: c.solve_cables(flat(nan), None, "auto", TOL, MAX_ITER, False, ctx.threads))


def ik_targets(ctx: Ctx) -> np.ndarray:
    """(N, task) tip poses of the configurations within the limits, and one 1 m away."""
    p = np.asarray(ctx.robot.fk(ctx.inside))
    far = p[0].copy()
    far[0] += 1.0
    return np.vstack([p, far])


def ik_masks(ctx: Ctx) -> Dict[str, object]:
    if ctx.planar:
        return {"pose": [1.0, 1.0, 1.0], "position": [1.0, 1.0, 0.0], "weighted": [1.0, 0.5, 2.0]}
    return {"position": "position", "pointing": "pointing", "pose": "pose"}


def case_core_ik(ctx: Ctx, rec) -> None:
    c = ctx.core
    P = ik_targets(ctx)
    seed = np.vstack([ctx.inside, np.zeros(ctx.n)]) + ctx.rng("ikseed").normal(0.0, 0.1, (len(P), ctx.n))
    for mname, mask in ik_masks(ctx).items():
        for method in ("lm", "closed_form"):
            for lim in (False, True):
                for s in (None, seed):
                    v = f"{mname}/{method}/{'limits' if lim else 'free'}/{'seeded' if s is not None else 'zero'}"
                    rec(v, lambda: c.ik(flat(P), None if s is None else flat(s), mask, method, TOL, MAX_ITER, lim,
                                        ctx.threads))
    first = next(iter(ik_masks(ctx).values()))
    rec("lm/max_iter3", lambda: c.ik(flat(P), None, first, "lm", TOL, 3, False, ctx.threads))
    other = "pose" if ctx.planar else [1.0, 1.0, 1.0]
    rec("error/other_kind_mask", lambda: c.ik(flat(P), None, other, "lm", TOL, MAX_ITER, False, ctx.threads))
    bad = [1.0, 1.0] if ctx.planar else "bogus"
    rec("error/mask", lambda: c.ik(flat(P), None, bad, "lm", TOL, MAX_ITER, False, ctx.threads))
    rec("error/method", lambda: c.ik(flat(P), None, first, "bogus", TOL, MAX_ITER, False, ctx.threads))
    rec("error/width", lambda: c.ik(np.zeros(ctx.task + 1), None, first, "lm", TOL, MAX_ITER, False, ctx.threads))
    nan = P.copy()
    nan[0, 0] = np.nan
    rec("error/nan", lambda: c.ik(flat(nan), None, first, "lm", TOL, MAX_ITER, False, ctx.threads))


def case_core_deviation(ctx: Ctx, rec) -> None:
    c = ctx.core
    t0 = ctx.inside[: 8 if not ctx.big else 3]
    r = ctx.rng("deviation")
    dl = r.uniform(-1e-3, 1e-3, ctx.m)
    dh = r.uniform(-3.5e-4, 3.5e-4, ctx.n)
    dholes = r.uniform(-3e-4, 3e-4, ctx.hole_width)
    holes = {"none": lambda: None}
    if ctx.planar:
        holes["dh"] = lambda: flat(c.hole_height_error(flat(dh)))
        holes["dholes"] = lambda: flat(c.holes + dholes)
    else:
        holes["dholes"] = lambda: flat(c.flat_holes + dholes)
    for hname, h in holes.items():
        for method in ("auto", "newton", "closed_form"):
            rec(f"{hname}/{method}", lambda: c.deviation(flat(t0), flat(dl), h(), method, TOL, MAX_ITER, ctx.threads))
    rec("error/holes", lambda: c.deviation(flat(t0), flat(dl), np.zeros(5), "auto", TOL, MAX_ITER, ctx.threads))
    rec("error/dl", lambda: c.deviation(flat(t0), np.zeros(ctx.m + 1), None, "auto", TOL, MAX_ITER, ctx.threads))
    rec("hole_height_error", lambda: c.hole_height_error(flat(dh)))
    rec("hole_height_error/error", lambda: c.hole_height_error(np.zeros(ctx.n + 1)))


def case_core_monte_carlo(ctx: Ctx, rec) -> None:
    c = ctx.core
    t0 = ctx.inside[:2] if ctx.big else ctx.theta[:7]  # row 6 ... the edge of the limits on small arms
    S = 8 if ctx.big else (16 if ctx.quick else 48)
    r = ctx.rng("mc")
    dl = r.uniform(-1e-3, 1e-3, (S, ctx.m))
    dh = r.uniform(-3.5e-4, 3.5e-4, (S, ctx.n))
    dholes = r.uniform(-3e-4, 3e-4, (S, ctx.hole_width))
    errors = {"none": (None, None), "dholes": (None, dholes)}
    if ctx.planar:
        errors["dh"] = (dh, None)
    for ename, (a, b) in errors.items():
        for method in ("auto", "newton"):
            for slack in (False, True):
                v = f"{ename}/{method}/{'slack' if slack else 'noslack'}"
                rec(v, lambda: c.monte_carlo(flat(t0), flat(dl), None if a is None else flat(a),
                                             None if b is None else flat(b), method, TOL, MAX_ITER, slack, ctx.threads))
    # errors large enough for failed samples and a spread histogram
    rec("large/dholes", lambda: c.monte_carlo(flat(t0), flat(dl * 12), None, flat(dholes * 12), "auto", TOL, MAX_ITER,
                                              True, ctx.threads))
    rec("error/both", lambda: c.monte_carlo(flat(t0), flat(dl), flat(dh), flat(dholes), "auto", TOL, MAX_ITER, False,
                                            ctx.threads))
    rec("error/dl", lambda: c.monte_carlo(flat(t0), np.zeros(ctx.m + 1), None, None, "auto", TOL, MAX_ITER, False,
                                          ctx.threads))
    rec("error/dh", lambda: c.monte_carlo(flat(t0), flat(dl), np.zeros(ctx.n * S + 1), None, "auto", TOL, MAX_ITER,
                                          False, ctx.threads))


def _flat_slots(robot) -> np.ndarray:
    """A planar arm's every coordinate of ``flat_holes`` (cable by cable:
    base face b, then faces a and b of disks 1..end; x, y, z) as its index in
    the planar hole layout ``(2n, n+1, 2, 2)`` flat, -1 for a ``z``."""
    n, out = robot.n, []
    for c, e in enumerate(robot.cable_ends):
        for i in range(2 * e + 1):
            d, f = (0, 1) if i == 0 else ((i + 1) // 2, 1 - i % 2)
            at = ((c * (n + 1) + d) * 2 + f) * 2
            out += [at, at + 1, -1]
    return np.array(out, np.int64)


def sensitivity_fields(ctx: Ctx, res, rows: int) -> dict:
    """The sensitivities of either version in the fields of the one output
    (issue 33, S12): ``cable``, ``groups`` (a planar arm's ``pair``),
    ``coords`` over ``flat_holes`` (a planar arm's planar-layout ``holes``
    picked slot by slot, ``z`` 0 or NaN on a singular row), ``ok``; ``res`` a
    core ``SensitivityResult`` or a :class:`Sensitivities`, of ``rows`` rows."""
    theta = dict(theta=res.theta) if hasattr(res, "theta") else {}
    if hasattr(res, "groups"):
        return dict(theta, cable=res.cable, groups=res.groups, coords=res.coords, ok=res.ok)
    groups = res.pair if res.pair is not None else np.zeros((rows, ctx.task, 0))
    coords = res.holes
    if coords is not None and ctx.planar:
        shape = (rows, ctx.task, -1) if np.ndim(res.cable) == 3 else (-1,)
        slots = _flat_slots(ctx.robot)
        old = np.asarray(coords, float).reshape(rows, ctx.task, -1)
        z = np.where(np.asarray(res.ok, bool), 0.0, np.nan)[:, None, None]
        coords = np.where(slots >= 0, old[:, :, np.maximum(slots, 0)], z).reshape(shape)
    return dict(theta, cable=res.cable, groups=groups, coords=coords, ok=res.ok)


def case_core_sensitivity(ctx: Ctx, rec) -> None:
    c = ctx.core
    th = ctx.theta[:8] if not ctx.big else ctx.theta[:3]
    for holes in (False, True):
        rec(f"sensitivity/{'holes' if holes else 'cables'}",
            lambda: sensitivity_fields(ctx, c.sensitivity(flat(th), holes, ctx.threads), len(th)))
    tol = np.concatenate([np.full(ctx.n, 1e-3), np.full(ctx.n, 3.5e-4)])
    rec("rms_amplification", lambda: c.rms_amplification(flat(th), flat(tol), 1e-6, ctx.threads))
    rec("rms_amplification/error", lambda: c.rms_amplification(flat(th), np.zeros(3), 1e-6, ctx.threads))


def case_core_tensions(ctx: Ctx, rec) -> None:
    c = ctx.core
    th = ctx.theta
    N = len(th)
    r = ctx.rng("tensions")
    force = r.uniform(0.05, 0.5, ctx.forces)
    force_rows = r.uniform(0.05, 0.5, (N, ctx.forces))
    g = ctx.gravity3()

    def t(force=None, wrench=None, gravity=None, min_tension=0.0, friction=None, pulling=True):
        return c.tensions(flat(th), None if force is None else flat(force), None if wrench is None else flat(wrench),
                          gravity, min_tension, ctx.threads, friction, pulling)

    rec("default", lambda: t())
    rec("gravity", lambda: t(gravity=g))
    rec("force", lambda: t(force=force))
    rec("force_rows", lambda: t(force=force_rows))
    rec("wrench", lambda: t(wrench=ctx.core_wrench()))
    rec("wrench_rows", lambda: t(wrench=ctx.core_wrench(N)))
    rec("min_tension", lambda: t(gravity=g, min_tension=0.05))
    rec("friction/pull", lambda: t(friction=0.15, pulling=True))
    rec("friction/release", lambda: t(friction=0.15, pulling=False))
    rec("friction/loads_release", lambda: t(force=force, wrench=ctx.core_wrench(), gravity=g, friction=0.3,
                                            pulling=False))
    rec("friction/zero", lambda: t(friction=0.0))
    rec("error/gravity", lambda: c.tensions(flat(th), None, None, [0.0, 1.0], 0.0, ctx.threads))
    rec("error/friction", lambda: t(friction=1.5))
    rec("error/friction_nan", lambda: t(friction=float("nan")))
    rec("error/wrench", lambda: t(wrench=np.zeros(5)))
    rec("error/force", lambda: t(force=np.zeros(ctx.forces + 1)))


def case_core_elastic(ctx: Ctx, rec) -> None:
    c = ctx.core
    th = ctx.inside[:3] if ctx.big else ctx.inside[:10]
    L = ctx.lengths(th) - 2e-5
    r = ctx.rng("elastic")
    force = r.uniform(0.05, 0.5, ctx.forces)

    def e(seed=None, force=None, wrench=None, gravity=None, min_tension=0.0):
        return c.solve_elastic(flat(L), None if seed is None else flat(seed), None if force is None else flat(force),
                               None if wrench is None else flat(wrench), gravity, min_tension, TOL, MAX_ITER,
                               ctx.threads)

    rec("default", lambda: e())
    rec("seeded", lambda: e(seed=th))
    rec("loads", lambda: e(force=force, wrench=ctx.core_wrench(), gravity=ctx.gravity3()))
    rec("min_tension", lambda: e(min_tension=0.05))
    rec("error/gravity", lambda: c.solve_elastic(flat(L), None, None, None, [1.0], 0.0, TOL, MAX_ITER, ctx.threads))


def case_core_variants(ctx: Ctx, rec) -> None:
    """with_holes, with_cable, with_loads: the derived arm's description and a few calls."""
    c = ctx.core
    r = ctx.rng("variants")
    th = ctx.inside[:5]

    def summary(v):
        out = {"toml": v.to_toml(), "flat_holes": v.flat_holes, "radii": v.radii,
               "lengths": v.cable_lengths(flat(th), 0)}
        for g in ("holes", "cable_tensions", "gravity", "axial_stiffness"):
            try:
                out[g] = getattr(v, g)
            except Exception as exc:  # the planar getters of a spatial arm
                out[g] = f"{type(exc).__name__}: {exc}"
        return out

    if ctx.planar:
        dholes, lower = r.uniform(-2e-4, 2e-4, ctx.hole_width), r.uniform(0.1, 1.0, ctx.n)
        holes = flat(c.holes + dholes)
        rec("with_holes", lambda: summary(c.with_holes(holes)))
        rec("with_loads", lambda: summary(c.with_loads(flat(lower), flat([0.0, -9.80665]))))
        rec("with_loads/error", lambda: c.with_loads(flat(np.ones(ctx.n)), flat([0.0, 0.0, 1.0])))
    else:
        holes = flat(c.flat_holes + r.uniform(-2e-4, 2e-4, ctx.hole_width))
        rec("with_holes", lambda: summary(c.with_holes(holes)))
        far = flat(c.flat_holes * 3.0)
        rec("with_holes/outside", lambda: summary(c.with_holes(far, False)))
        rec("with_holes/outside_refused", lambda: c.with_holes(far, True))
        rec("with_loads/error", lambda: c.with_loads(flat(np.ones(ctx.n)), flat([0.0, 0.0])))
    rec("with_holes/error_length", lambda: c.with_holes(np.zeros(7)))
    nan = holes.copy()
    nan[3] = np.nan
    rec("with_holes/error_nan", lambda: c.with_holes(nan))
    rec("with_cable", lambda: summary(c.with_cable(2.5e9, 3e-4, 0.3)))
    rec("with_cable/error", lambda: c.with_cable(2.5e9, -3e-4, 0.3))


# ---- the plant ---------------------------------------------------------
class PlantInputs:
    """The plant's layout, test effects and two data sets of one robot."""

    def __init__(self, ctx: Ctx):
        c = ctx.core
        self.blocks: List[Tuple[str, int]] = [(str(nm), int(sz)) for nm, sz in c.plant_effects()]
        self.size = sum(sz for _, sz in self.blocks)
        lo, hi = (np.asarray(b, float) for b in c.plant_bounds())
        self.index: Dict[str, np.ndarray] = {}
        off = 0
        for nm, sz in self.blocks:
            self.index[nm] = np.arange(off, off + sz)
            off += sz
        self.effect: Dict[str, np.ndarray] = {}
        for nm, sz in self.blocks:
            r = ctx.rng(f"effect/{nm}")
            v = TYPICAL.get(nm, 1e-4) * r.uniform(0.5, 1.5, sz) * r.choice([-1.0, 1.0], sz)
            idx = self.index[nm]
            v = np.where(lo[idx] >= 0.0, np.abs(v), v)
            p = np.zeros(self.size)
            p[idx] = np.clip(v, lo[idx], hi[idx])
            self.effect[nm] = p
        self.all = np.clip(sum(self.effect.values()), lo, hi)
        N = 6 if ctx.big else 12
        r = ctx.rng("plant/data")
        lo_t, hi_t = 0.6 * ctx.limits[:, 0], 0.6 * ctx.limits[:, 1]
        a, b = r.uniform(lo_t, hi_t, ctx.n), r.uniform(lo_t, hi_t, ctx.n)
        s = np.array([0.0, 0.25, 0.5, 0.75, 1.0, 0.75, 0.5, 0.25, 0.0, 0.5, 1.0, 0.5])[:N]  # reversals: memory
        self.theta = a + np.outer(s, b - a)
        self.dl = r.uniform(-2e-4, 2e-4, (N, ctx.m))
        self.kind = [0] * N
        for i in (3, 7):
            if i < N:
                self.kind[i] = 2  # unmeasured: runs, not scored
        self.dl_disp = np.zeros((N, ctx.m))
        self.dl_disp[np.arange(N), np.arange(N) % ctx.m] = np.where(np.arange(N) % 2 == 0, 5e-4, -5e-4)
        self.rows = N

    def free(self, block: str, most: int) -> List[int]:
        idx = self.index[block]
        if len(idx) > most:
            idx = idx[np.unique(np.linspace(0, len(idx) - 1, most).round().astype(int))]
        return [int(i) for i in idx]


def case_core_plant(ctx: Ctx, rec) -> None:
    c = ctx.core
    pi = PlantInputs(ctx)
    th, dl, kind = flat(pi.theta), flat(pi.dl), pi.kind

    def predict(p, theta=th, dl=dl, kind=kind):
        return c.plant_predict(flat(p), theta, dl, kind, TOL, MAX_ITER, ctx.threads)

    rec("predict/nominal", lambda: predict(np.zeros(pi.size)))
    rec("predict/all", lambda: predict(pi.all))
    rec("predict/batch", lambda: predict(np.vstack([np.zeros(pi.size), pi.all] + list(pi.effect.values()))))
    rec("predict/displacement", lambda: predict(pi.all, dl=flat(pi.dl_disp), kind=[1] * pi.rows))
    rec("linearise/all", lambda: c.plant_linearise(flat(pi.all), [i for b, _ in pi.blocks for i in pi.free(b, 2)],
                                                   th, dl, kind, TOL, MAX_ITER, ctx.threads))
    w = ctx.task
    fit_iter = 3 if ctx.quick else 6
    lite = ctx.quick and ctx.big  # --quick on a long arm: per effect only the prediction and the fit
    for b, _ in pi.blocks:
        p = pi.effect[b]
        rec(f"predict/{b}", lambda: predict(p))
        if not lite:
            rec(f"predict/{b}/displacement", lambda: predict(p, dl=flat(pi.dl_disp), kind=[1] * pi.rows))
            rec(f"linearise/{b}", lambda: c.plant_linearise(flat(p), pi.free(b, 24), th, dl, kind, TOL, MAX_ITER,
                                                            ctx.threads))
        obs = rec(f"fit/{b}/data", lambda: np.asarray(predict(p).observation, float).reshape(-1, w), needed=True)
        if obs is None:
            continue
        meas = obs + ctx.rng(f"noise/{b}").normal(0.0, 5e-6, obs.shape)
        meas[:, 2 if ctx.planar else 3:] = np.nan  # the attitude is not measured
        meas[np.asarray(kind) == 2] = np.nan
        free = pi.free(b, 8 if ctx.big else 12)
        scale = [TYPICAL.get(b, 1e-4)] * len(free)
        scored = [True] * pi.rows + [i % 2 == 0 for i in range(pi.rows)]
        rec(f"fit/{b}", lambda: c.plant_fit(th, dl, kind, flat(meas), scored, free, scale, np.zeros(pi.size), TOL,
                                            MAX_ITER, fit_iter, ctx.threads))
    out_of_domain = pi.all.copy()
    if "cable_friction" in pi.index:
        out_of_domain[pi.index["cable_friction"]] = 2.0
    rec("predict/out_of_domain", lambda: predict(out_of_domain))
    th1, dl1 = flat(pi.theta[:2]), flat(pi.dl[:2])  # refusals: two rows are enough
    rec("error/params", lambda: predict(np.zeros(pi.size + 1), th1, dl1, [0, 0]))
    rec("error/kind", lambda: predict(np.zeros(pi.size), th1, dl1, [9, 0]))
    rec("error/free", lambda: c.plant_linearise(flat(pi.all), [pi.size + 3], th1, dl1, [0, 0], TOL, MAX_ITER,
                                                ctx.threads))
    rec("error/scored", lambda: c.plant_fit(th1, dl1, [0, 0], np.zeros(2 * w), [True] * 3, [0], [0.02],
                                            np.zeros(pi.size), TOL, MAX_ITER, 3, ctx.threads))


def case_core_compensate(ctx: Ctx, rec) -> None:
    c = ctx.core
    pi = PlantInputs(ctx)
    p = sum(pi.effect[b] for b in ("actuation_scale", "cable_offset", "backlash") if b in pi.effect)
    th = ctx.inside[1:5]
    offset = [2e-4, -1e-4, 1e-3] if ctx.planar else [2e-4, -1e-4, 1e-4, 0.0, 0.0, 0.0]
    targets = np.asarray(ctx.robot.fk(th)) + offset
    L = ctx.straight
    weights = {"pose": [1.0, 1.0, L] if ctx.planar else [1.0, 1.0, 1.0, L, L, L],
               "position": [1.0, 1.0, 0.0] if ctx.planar else [1.0, 1.0, 1.0, 0.0, 0.0, 0.0]}
    start = flat(ctx.lengths(ctx.theta[:1]))
    for wname, wt in weights.items():
        for s in (None, start):
            v = f"{wname}/{'start' if s is not None else 'straight'}"
            rec(v, lambda: c.compensate(flat(p), flat(th), flat(targets), wt, s, 1e-9, TOL, 40, ctx.threads))
    rec("error/weights", lambda: c.compensate(flat(p), flat(th), flat(targets), [1.0], None, 1e-9, TOL, 40,
                                              ctx.threads))


# ---------------------------------------------------------------------------
# the public Robot (cdsm.Robot)
# ---------------------------------------------------------------------------
API_PROPERTIES = ("kind", "n", "name", "task", "joint_limits", "axes", "gravity", "straight_length", "cables",
                  "position_cables", "cable_ends", "cable_tensions", "flat_holes", "radii", "mass", "offsets",
                  "joint_disks", "disk_link_after", "disk_thickness", "com", "youngs_modulus", "cable_diameter",
                  "routing_length", "axial_stiffness", "holes", "link_before", "link_after", "thickness",
                  "lower_tension")

API_MAPS = ("fk", "fk_matrix", "disk_frames", "fk_jacobian", "cable_lengths", "position_lengths", "upper_lengths",
            "cable_jacobian", "within_limits", "feasible")


def case_api_describe(ctx: Ctx, rec) -> None:
    r = ctx.robot
    for p in API_PROPERTIES:
        rec(p, lambda: getattr(r, p))
    rec("holes_by_cable", lambda: r.holes_by_cable())
    rec("str", lambda: str(r))
    rec("repr", lambda: repr(r))
    rec("summary_tables", lambda: r.summary_tables())
    rec("to_urdf", lambda: r.to_urdf())
    rec("to_mjcf", lambda: r.to_mjcf())


def case_api_kinematics(ctx: Ctx, rec) -> None:
    r = ctx.robot
    for f in API_MAPS:
        rec(f"{f}/rows", lambda: getattr(r, f)(ctx.theta))
        rec(f"{f}/one", lambda: getattr(r, f)(ctx.theta[1]))
    rec("fk/list", lambda: r.fk([0] * ctx.n))
    rec("fk/error", lambda: r.fk(np.zeros(ctx.n + 1)))


def case_api_solves(ctx: Ctx, rec) -> None:
    r = ctx.robot
    L = cable_targets(ctx)
    for method in ("auto", "newton", "closed_form"):
        for lim in (False, True):
            rec(f"solve_cables/{method}/{'limits' if lim else 'free'}",
                lambda: solution(r.solve_cables(L, method=method, enforce_limits=lim)))
    rec("solve_cables/one", lambda: solution(r.solve_cables(L[1], seed=ctx.theta[1] + 0.01)))
    P = ik_targets(ctx)
    masks = {"pose": "pose", "position": "position", "weighted": (1.0, 0.5, 2.0)} if ctx.planar else \
        {m: m for m in ("position", "pointing", "pose")}
    for mname, mask in masks.items():
        for method in ("lm", "closed_form"):
            rec(f"ik/{mname}/{method}", lambda: solution(r.ik(P, mask=mask, method=method)))
        rec(f"ik/{mname}/limits", lambda: solution(r.ik(P, mask=mask, enforce_limits=True, seed=ctx.theta[0] + 0.01)))
    if ctx.planar:
        rec("ik/pose_keyword", lambda: solution(r.ik(pose=P[0])))
    rec("ik/error_mask", lambda: r.ik(P, mask="bogus"))


def case_api_statics(ctx: Ctx, rec) -> None:
    r = ctx.robot
    th = ctx.theta
    g = ctx.gravity3()[:2] if ctx.planar else ctx.gravity3()
    force = ctx.rng("api/force").uniform(0.05, 0.5, ctx.forces)
    rec("tensions", lambda: r.tensions(th))
    rec("tensions/one", lambda: r.tensions(th[1]))
    rec("tensions/wrench", lambda: r.tensions(th, tip_wrench=ctx.api_wrench()))
    rec("tensions/wrench_rows", lambda: r.tensions(th, tip_wrench=ctx.api_wrench(len(th))))
    rec("tensions/gravity", lambda: r.tensions(th, gravity=g))
    rec("tensions/force", lambda: r.tensions(th, force=force))
    rec("tensions/friction_pull", lambda: r.tensions(th, friction=0.15))
    rec("tensions/friction_release", lambda: r.tensions(th, friction=0.15, sliding="release"))
    rec("tensions/min_tension", lambda: r.tensions(th, gravity=g, min_tension=0.05))
    rec("tensions/error_friction", lambda: r.tensions(th, friction=1.5))
    rec("tensions/error_sliding", lambda: r.tensions(th, friction=0.1, sliding="bogus"))
    rec("feasible/loads", lambda: r.feasible(th, tip_wrench=ctx.api_wrench(), gravity=g, force=force))
    rec("feasible/friction_release", lambda: r.feasible(th, friction=0.2, sliding="release"))
    rec("stretch", lambda: r.stretch(th, gravity=g))
    thin = ctx.inside[:3] if ctx.big else ctx.inside[:8]
    Lc = ctx.lengths(thin) - 2e-5
    rec("solve_cables_elastic", lambda: solution(r.solve_cables_elastic(Lc)))
    rec("solve_cables_elastic/loads", lambda: solution(
        r.solve_cables_elastic(Lc, seed=thin, tip_wrench=ctx.api_wrench(), gravity=g, force=force)))
    if ctx.planar:
        rec("tensions/lower", lambda: r.tensions(th, lower=force))


def case_api_variants(ctx: Ctx, rec) -> None:
    r = ctx.robot
    rng = ctx.rng("api/variants")
    th = ctx.inside[:5]

    def summary(v):
        return {"toml": v.to_toml(), "fk": v.fk(th), "lengths": v.cable_lengths(th), "tensions": v.tensions(th)}

    if ctx.planar:
        dh, lower = rng.uniform(-3e-4, 3e-4, ctx.n), rng.uniform(0.1, 1.0, ctx.n)
        dholes = rng.uniform(-2e-4, 2e-4, ctx.hole_width)
        rec("hole_height_error", lambda: r.hole_height_error(dh))
        rec("with_holes", lambda: summary(r.with_holes(r.holes + dholes.reshape(r.holes.shape))))
        rec("with_loads", lambda: summary(r.with_loads(lower_tension=lower, gravity=[0.0, -9.80665])))
    else:
        rec("with_holes/list", lambda: summary(r.with_holes([h + 1e-4 for h in r.holes])))
        rec("with_holes/flat", lambda: summary(r.with_holes(r.flat_holes * 1.5, within_disks=False)))
    rec("with_cable", lambda: summary(r.with_cable(youngs_modulus=2.5e9, diameter=3e-4, routing_length=0.3)))


# ---------------------------------------------------------------------------
# the Python pipelines
# ---------------------------------------------------------------------------
def _mc_dict(mc) -> dict:
    from cdsm.accuracy import montecarlo

    out = {f.name: getattr(mc, f.name) for f in dataclasses.fields(mc) if not f.name.startswith("_")}
    out.update(mean=mc.mean, std=mc.std, max_abs=mc.max_abs, p95=mc.percentile(95.0),
               summary=montecarlo.summary(mc))
    return out


def case_py_deviation(ctx: Ctx, rec) -> None:
    from cdsm.accuracy import scenarios

    r = ctx.robot
    t0 = ctx.inside[: 3 if ctx.big else 8]
    g = ctx.rng("py/deviation")
    dL = g.uniform(-1e-3, 1e-3, ctx.m)
    rec("dL", lambda: scenarios.deviation(r, t0, dL=dL))
    dh, dholes = g.uniform(-3.5e-4, 3.5e-4, ctx.n), g.uniform(-3e-4, 3e-4, ctx.hole_width)
    if ctx.planar:
        rec("dh", lambda: scenarios.deviation(r, t0, dh=dh))
        rec("dholes", lambda: scenarios.deviation(r, t0, dL=dL, dholes=dholes.reshape(r.holes.shape)))
    else:
        rec("dholes", lambda: scenarios.deviation(r, t0, dL=dL, dholes=dholes))
        rec("error/dh", lambda: scenarios.deviation(r, t0, dh=np.zeros(ctx.n)))
    rec("poses", lambda: scenarios.deviation(r, poses=r.fk(t0[1:4]), dL=dL))
    rec("no_statics", lambda: scenarios.deviation(r, t0, dL=dL, statics=False))
    rec("rotation_vectors", lambda: scenarios.rotation_vectors(r.fk_matrix(t0)[:, :3, :3]))


def case_py_monte_carlo(ctx: Ctx, rec) -> None:
    from cdsm.accuracy import montecarlo

    r = ctx.robot
    t0 = ctx.inside[:2] if ctx.big else ctx.inside[:5]
    S = 6 if ctx.big else (24 if ctx.quick else 60)
    rec("default", lambda: _mc_dict(montecarlo.monte_carlo(r, t0, samples=S, seed=3, chunk=max(S // 3, 1),
                                                           progress=False, check_slack=True)))
    rec("newton", lambda: _mc_dict(montecarlo.monte_carlo(r, t0, samples=S, seed=4, progress=False, method="newton")))
    rec("no_holes", lambda: _mc_dict(montecarlo.monte_carlo(r, t0, samples=S, seed=5, dh_tol=0.0, progress=False)))


def case_py_sensitivity(ctx: Ctx, rec) -> None:
    from cdsm.accuracy import configurations, sampling, sensitivity, workspace

    r = ctx.robot
    th = ctx.inside[:3] if ctx.big else ctx.inside[:8]
    got = {}

    def sens_fields():
        got["sens"] = sensitivity.sensitivities(r, th, holes=True)
        return sensitivity_fields(ctx, got["sens"], len(th))

    rec("sensitivities", sens_fields, needed=True)
    sens = got.get("sens")
    if ctx.planar and sens is not None:
        # the planar layout of cdsm 0.2 (deprecated in 0.3): slots that are no hole hold +0.0 where 0.2 had -0.0
        rec("sensitivities/planar_layout", lambda: sens.holes)
    if ctx.planar and sens is not None:
        rec("amplification", lambda: sensitivity.amplification(sens, 1e-3, 3.5e-4))
    budget = rec("error_budget", lambda: sensitivity.error_budget(r, th, 1e-3, 3.5e-4, samples=200), needed=True)
    if budget is not None:
        for shape in ("ratio", "equal-effect"):
            rec(f"error_budget/for_target/{shape}", lambda: budget.for_target(1e-3, shape))
    rec("rms_and_gradient", lambda: configurations.rms_and_gradient(r, th))
    rec("singular_values", lambda: workspace.singular_values(r, th))
    rec("singular_measure", lambda: sampling.singular_measure(r, th))


def case_py_configurations(ctx: Ctx, rec) -> None:
    from cdsm.accuracy import configurations

    r = ctx.robot
    P = np.asarray(r.fk(ctx.inside[1:4]))
    iters = 20 if ctx.quick else 60
    rec("best", lambda: configurations.best_configurations(r, P, iters=iters))
    rec("path", lambda: configurations.path_configurations(r, P))
    if ctx.planar:
        rec("ik_branches", lambda: configurations.ik_branches(r, P))


def case_py_statics(ctx: Ctx, rec) -> None:
    from cdsm.accuracy import statics

    r = ctx.robot
    th = ctx.inside[:2] if ctx.big else ctx.inside[:6]
    rec("feasibility_map", lambda: statics.feasibility_map(r, th))
    rec("friction_map", lambda: statics.friction_map(r, th[:2] if not ctx.big else th[:1]))
    if ctx.planar:
        rec("elastic_tip_deviation", lambda: statics.elastic_tip_deviation(r, th, youngs_modulus=2.5e9))


def case_py_tolerance(ctx: Ctx, rec) -> None:
    from cdsm.accuracy import tolerance

    r = ctx.robot
    th = ctx.inside[1:4] if ctx.quick else ctx.inside[1:6]
    S = 16 if ctx.quick else 30
    rec("allocate", lambda: tolerance.allocate(r, 1e-3, th, samples=S, rel_tol=0.05, max_evals=12).to_json())
    rec("allocate/equal_effect", lambda: tolerance.allocate(r, 1e-3, th, shape="equal-effect", samples=S,
                                                            rel_tol=0.05, max_evals=12).to_json())
    rec("distribution", lambda: {k: v for k, v in tolerance.distribution(r, 1e-3, 3.5e-4, th, samples=S).items()
                                 if k != "mc"})


def _poses(ctx: Ctx, k: int) -> np.ndarray:
    p = np.asarray(ctx.robot.fk(ctx.inside[1:1 + k]))
    far = p[0].copy()
    far[0] += 1.0
    return np.vstack([p, far])


def _fitted_plant():
    """The fitted-plant class: ``cdsm.FittedPlant`` (cdsm 0.3), ``cdsm.Model``
    on a tree before the rename (no DeprecationWarning on either)."""
    import cdsm

    return cdsm.FittedPlant if "FittedPlant" in cdsm.__all__ else cdsm.Model


def case_py_compensate(ctx: Ctx, rec) -> None:
    r = ctx.robot
    effects = {"actuation_scale": [0.02], "cable_offset": list(ctx.rng("py/comp").uniform(-2e-4, 2e-4, ctx.m))}
    model = rec("model", lambda: _fitted_plant().from_effects(r, effects), needed=True)
    if model is None:
        return
    rec("model/to_dict", lambda: model.to_dict())
    rec("model/predict", lambda: model.predict(ctx.inside[:4]))
    P = _poses(ctx, 4)
    pos = P[:, :2] if ctx.planar else P[:, :3]
    rec("full", lambda: model.compensate(P))
    rec("position", lambda: model.compensate(pos))
    rec("limits", lambda: model.compensate(P, enforce_limits=True, min_tension=0.05))
    rec("error/poses", lambda: model.compensate(np.zeros((2, 5))))


def _measurements(ctx: Ctx, reading: str):
    from cdsm.calibration.plant import VirtualPrototype

    r = ctx.robot
    hidden = ({"hole_height": list(ctx.rng("py/hidden").uniform(-3e-4, 3e-4, ctx.n)), "actuation_scale": [0.02]}
              if ctx.planar else {"actuation_scale": [0.03], "cable_offset": [2e-4, -1e-4] + [0.0] * (ctx.m - 2)})
    vp = VirtualPrototype(r, hidden, noise=10e-6, seed=7)
    # positional: the keyword is ``kind`` before cdsm 0.3 and ``reading`` after
    th, dl = vp.random_commands(15, 11, None, 1e-3, reading)
    return vp.measure(th, dl, reading)


def case_py_diagnose(ctx: Ctx, rec) -> None:
    from cdsm.calibration import diagnosis, experiment, measurements

    r = ctx.robot

    def run(meas):
        if ctx.quick:
            lib = ["actuation_scale", "cable_offset", "hole_height" if ctx.planar else "hole_position"]
            d = diagnosis.diagnose(r, meas, effects=lib, folds=3)
        else:
            d = diagnosis.diagnose(r, meas, folds=5)
        return {"json": d.to_json(), "final_fit": d.final().fit, "suggest": experiment.suggest(d, 3, pool=60),
                "model": _fitted_plant().from_diagnosis(d).to_dict(),
                "residuals": {w: diagnosis.residuals(d, w) for w in ("baseline", "final")}}

    for reading in ("absolute", "displacement"):
        meas = rec(f"{reading}/data", lambda: _measurements(ctx, reading), needed=True)
        if meas is not None:
            rec(f"{reading}/diagnose", lambda: run(meas))
    if ctx.name == "paper":
        rec("table3/diagnose", lambda: run(measurements.packaged("table3")))


def _csv(columns: Dict[str, np.ndarray]) -> str:
    """A measurement table's text: every float in its shortest round-trip form, NaN as an empty cell."""
    names = list(columns)
    lines = [",".join(names)]
    for i in range(len(columns[names[0]])):
        cells = [float(columns[c][i]) for c in names]
        lines.append(",".join(repr(v) if np.isfinite(v) else "" for v in cells))
    return "\n".join(lines) + "\n"


def case_py_measurements(ctx: Ctx, rec) -> None:
    """The CSV reader on tables made from a virtual prototype's rows (and its refusals)."""
    from cdsm.calibration import measurements

    meas = _measurements(ctx, "absolute")
    k = 2 if ctx.planar else 3
    axes = ["x", "y", "z"][:k]
    cols = {f"theta_{i + 1}": meas.theta[:, i] for i in range(ctx.n)}
    cols.update({f"dL_{j + 1}": meas.dL[:, j] for j in range(ctx.m)})
    measured = np.array(meas.measured, float)
    measured[4] = np.nan  # a move that was not measured
    cols.update({a: measured[:, i] for i, a in enumerate(axes)})
    cables = None if ctx.planar else ctx.m

    def parse(c):
        return measurements.parse_csv(_csv(c), ctx.n, cables=cables)

    rec("absolute", lambda: parse(cols))
    rot = {"phi": np.linspace(-0.1, 0.1, len(measured))} if ctx.planar else \
        {f"r{a}": np.linspace(-0.1, 0.1, len(measured)) * (i + 1) for i, a in enumerate(axes)}
    rec("absolute_rotation", lambda: parse({**cols, **rot}))
    disp = {("d" + c if c in axes else c): v for c, v in cols.items()}
    rec("displacement", lambda: parse(disp))
    rec("sequence", lambda: parse({**cols, "sequence": np.arange(len(measured))[::-1] * 2.0}))
    if ctx.planar:
        pose = np.asarray(ctx.robot.fk(meas.theta))
        cmd = {"x_cmd": pose[:, 0], "y_cmd": pose[:, 1], "phi_cmd": pose[:, 2]}
        cmd.update({c: v for c, v in cols.items() if not c.startswith("theta_")})
        rec("pose_commands", lambda: parse(cmd))
    rec("error/both_kinds", lambda: parse({**cols, **{"d" + a: cols[a] for a in axes}}))
    half = dict(cols)
    half[axes[0]] = np.where(np.arange(len(measured)) == 2, np.nan, cols[axes[0]])
    rec("error/half_row", lambda: parse(half))
    rec("error/extra_cable", lambda: parse({**cols, f"dL_{ctx.m + 1}": cols["dL_1"]}))
    rec("error/duplicate_sequence", lambda: parse({**cols, "sequence": np.zeros(len(measured))}))


# ---------------------------------------------------------------------------
# module-level entry points
# ---------------------------------------------------------------------------
def case_module(rec) -> None:
    import cdsm
    from cdsm import _cdsm

    for name in ("PAPER_TOML", "HIST_LO", "HIST_PER_DECADE", "HIST_BINS", "QUANTITIES", "REASONS", "CLEARANCE_WIDTH"):
        rec(f"_cdsm.{name}", lambda: getattr(_cdsm, name))
    rec("_cdsm.hist_edges", lambda: _cdsm.hist_edges())
    rec("_cdsm.simd_instruction_set", lambda: _cdsm.simd_instruction_set())
    rec("_cdsm.paper", lambda: _cdsm.CoreRobot.paper().to_toml())
    texts = {p.stem: p.read_text() for p in sorted((TREE / "python" / "cdsm" / "robots").glob("*.toml"))}
    texts["two_section_arm"] = (TREE / "examples" / "two_section_arm.toml").read_text()
    for stem, text in texts.items():
        rec(f"robot_kind/{stem}", lambda: _cdsm.robot_kind(text))
    bad = {"syntax": "n = [", "no_n": 'name = "x"', "kind": 'kind = "tubular"',
           "negative_link": texts["paper"].replace("link_before = 0.033 ", "link_before = -0.033 ", 1),
           "spatial_no_cables": 'kind = "spatial"\n[base]\nradius = 0.03\n'}
    for label, text in bad.items():
        rec(f"from_toml_error/{label}", lambda: _cdsm.CoreRobot.from_toml(text).to_toml())
        rec(f"robot_kind_error/{label}", lambda: _cdsm.robot_kind(text))
    rec("py.REASONS", lambda: cdsm.robot.REASONS)
    rec("py.TASK_MASKS", lambda: cdsm.robot.TASK_MASKS)
    rec("py.packaged_robots", lambda: cdsm.robot.packaged_robots())
    rec("py.packaged_error", lambda: cdsm.Robot.packaged("no_such_robot"))
    from cdsm.calibration import measurements

    for name in ("table3", "table3_theory"):
        rec(f"py.measurements/{name}", lambda: measurements.packaged(name))


# ---------------------------------------------------------------------------
# the table
# ---------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Case:
    """A check: ``run(ctx, rec)`` on every robot of ``kinds`` (and, when
    given, only the robots ``robots``)."""

    name: str
    run: Callable[[Ctx, Callable], None]
    kinds: Tuple[str, ...] = ("planar", "spatial")
    robots: Optional[Tuple[str, ...]] = None


#: Robots the heavier Python pipelines run on.
PIPELINE_ROBOTS = ("paper", "paper_vertical", "serpentine8", "two_section_arm", "paper_spatial", "two_universal",
                   "two_universal_nylon", "spatial8", "sjtu_snake")
DIAGNOSIS_ROBOTS = ("paper", "two_universal")

CASES: Tuple[Case, ...] = (
    Case("core.describe", case_core_describe),
    Case("core.maps", case_core_maps),
    Case("core.solve_cables", case_core_solve_cables),
    Case("core.ik", case_core_ik),
    Case("core.deviation", case_core_deviation),
    Case("core.monte_carlo", case_core_monte_carlo),
    Case("core.sensitivity", case_core_sensitivity),
    Case("core.tensions", case_core_tensions),
    Case("core.solve_elastic", case_core_elastic),
    Case("core.variants", case_core_variants),
    Case("core.plant", case_core_plant),
    Case("core.compensate", case_core_compensate),
    Case("api.describe", case_api_describe),
    Case("api.kinematics", case_api_kinematics),
    Case("api.solves", case_api_solves),
    Case("api.statics", case_api_statics),
    Case("api.variants", case_api_variants),
    Case("py.deviation", case_py_deviation, robots=PIPELINE_ROBOTS),
    Case("py.monte_carlo", case_py_monte_carlo, robots=PIPELINE_ROBOTS),
    Case("py.sensitivity", case_py_sensitivity, robots=PIPELINE_ROBOTS),
    Case("py.configurations", case_py_configurations, robots=("paper", "serpentine8", "two_section_arm",
                                                               "two_universal")),
    Case("py.statics", case_py_statics, robots=PIPELINE_ROBOTS),
    Case("py.tolerance", case_py_tolerance, robots=("paper", "serpentine8", "two_universal")),
    Case("py.compensate", case_py_compensate, robots=PIPELINE_ROBOTS),
    Case("py.diagnose", case_py_diagnose, robots=DIAGNOSIS_ROBOTS),
    Case("py.measurements", case_py_measurements, robots=DIAGNOSIS_ROBOTS),
)

#: The robots of ``--quick`` (all cases, smaller samples).
QUICK_ROBOTS = ("paper", "paper_vertical", "serpentine8", "two_section_arm", "paper_spatial", "two_universal",
                "sjtu_snake")


# ---------------------------------------------------------------------------
# dump
# ---------------------------------------------------------------------------
def dump(path: "str | os.PathLike[str]", quick: bool = False, threads: int = 0, robots: Optional[Sequence[str]] = None,
         only: Optional[Sequence[str]] = None, verbose: bool = False) -> Dict[str, np.ndarray]:
    """Run the table with the importable ``cdsm`` and write every result to
    ``path`` (``.npz``); returns the arrays. ``robots``: names to run (default
    all, or :data:`QUICK_ROBOTS` with ``quick``); ``only``: globs on the keys."""
    import cdsm
    from cdsm import _cdsm

    start = time.perf_counter()
    rec = Recorder(only)
    table = robot_table()
    names = list(robots) if robots else [n for n in table if not quick or n in QUICK_ROBOTS]
    unknown = [n for n in names if n not in table]
    if unknown:
        raise SystemExit(f"bitcheck: unknown robot(s) {', '.join(unknown)}; known: {', '.join(table)}")
    def guarded(prefix: str, run: Callable[[], None]) -> None:
        """``run`` the calls of one case; a failure outside its calls (the
        inputs need an entry point that is not there, say) is recorded as
        ``prefix/!setup``."""
        rec.prefix = prefix
        try:
            run()
        except MISSING as exc:
            rec.out[f"{prefix}/!setup#!missing"] = np.array(f"{type(exc).__name__}: {exc}")
        except Exception as exc:
            rec.out[f"{prefix}/!setup#!error"] = np.array(f"{type(exc).__name__}: {exc}")

    guarded("_module", lambda: case_module(rec))
    for name in names:
        t = time.perf_counter()
        rec.prefix = name
        robot = rec("build", lambda: table[name](), needed=True)
        if robot is None:
            continue
        box: List[Ctx] = []
        guarded(name, lambda: box.append(Ctx(name, robot, threads, quick)))
        if not box:
            continue
        ctx = box[0]
        for case in CASES:
            if ctx.kind not in case.kinds or (case.robots is not None and name not in case.robots):
                continue
            guarded(f"{name}/{case.name}", lambda: case.run(ctx, rec))
        if verbose:
            print(f"  {name:32s} {time.perf_counter() - t:6.2f} s", file=sys.stderr)
    seconds = time.perf_counter() - start
    meta = dict(cdsm_file=cdsm.__file__, core_file=_cdsm.__file__, version=getattr(cdsm, "__version__", None),
                quick=bool(quick), threads=int(threads), robots=names, only=list(only or []),
                python=sys.version.split()[0], numpy=np.__version__, seconds=round(seconds, 2),
                slowest={k: round(v, 3) for k, v in sorted(rec.seconds.items(), key=lambda kv: -kv[1])[:10]})
    out = dict(rec.out)
    out["__meta__#json"] = np.array(json.dumps(meta))
    tmp = Path(str(path) + ".part.npz")
    np.savez(tmp, **out)
    os.replace(tmp, path)
    if verbose:
        print(f"bitcheck: {len(out)} arrays, {seconds:.1f} s -> {path}", file=sys.stderr)
    return out


# ---------------------------------------------------------------------------
# compare
# ---------------------------------------------------------------------------
@dataclasses.dataclass
class Difference:
    key: str
    what: str
    count: int = 0
    size: int = 0
    max_abs: float = float("nan")
    max_rel: float = float("nan")
    note: str = ""


def load(path: "str | os.PathLike[str]") -> Dict[str, np.ndarray]:
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def _family(a: np.ndarray) -> str:
    k = a.dtype.kind
    return {"f": "float", "i": "int", "u": "int", "b": "bool", "U": "text", "S": "text"}.get(k, k)


def _short(s: str, width: int = 70) -> str:
    s = s.replace("\n", "\\n")
    return s if len(s) <= width else s[: width - 3] + "..."


def compare_arrays(key: str, a: np.ndarray, b: np.ndarray) -> List[Difference]:
    """The differences of two stored arrays (empty: identical)."""
    fa, fb = _family(a), _family(b)
    if a.size == 0 and b.size == 0 and a.shape == b.shape:
        return []
    if fa != fb:
        return [Difference(key, "type", note=f"{a.dtype} vs {b.dtype}")]
    if a.shape != b.shape:
        return [Difference(key, "shape", note=f"{a.shape} vs {b.shape}")]
    size = int(a.size)
    if fa == "float":
        a64, b64 = np.ascontiguousarray(a, np.float64), np.ascontiguousarray(b, np.float64)
        same = a64.view(np.uint64) == b64.view(np.uint64)
        same |= np.isnan(a64) & np.isnan(b64)
        differ = ~same
        signed = differ & (a64 == b64)  # +0.0 vs -0.0: equal values, other bits
        value = differ & ~signed
        out = []
        if value.any():
            x, y = a64[value], b64[value]
            fin = np.isfinite(x) & np.isfinite(y)
            d = np.abs(x[fin] - y[fin])
            rel = d / np.maximum(np.maximum(np.abs(x[fin]), np.abs(y[fin])), 1e-300)
            mabs = float(d.max()) if d.size else 0.0
            mrel = float(rel.max()) if rel.size else 0.0
            note = ""
            if not fin.all():
                mabs = mrel = float("inf")
                i = int(np.flatnonzero(~fin)[0])
                note = f"non-finite mismatch, e.g. {x[i]!r} vs {y[i]!r}"
            out.append(Difference(key, "value", int(value.sum()), size, mabs, mrel, note))
        if signed.any():
            out.append(Difference(key, "signed zero", int(signed.sum()), size, 0.0, 0.0,
                                  f"{int((np.signbit(a64) & signed).sum())} negative in A, "
                                  f"{int((np.signbit(b64) & signed).sum())} in B"))
        return out
    if fa == "int":
        differ = a != b
        if differ.any():
            d = np.abs(a[differ].astype(np.float64) - b[differ].astype(np.float64))
            return [Difference(key, "value", int(differ.sum()), size, float(d.max()), float("nan"))]
        return []
    if fa == "bool":
        differ = a != b
        return [Difference(key, "value", int(differ.sum()), size)] if differ.any() else []
    differ = a != b
    if differ.any():
        i = np.flatnonzero(differ.reshape(-1))[0]
        return [Difference(key, "text", int(differ.sum()), size,
                           note=f"A {_short(str(a.reshape(-1)[i]), 60)!r} | B {_short(str(b.reshape(-1)[i]), 60)!r}")]
    return []


def _cases(arrays: Dict[str, np.ndarray]) -> Dict[str, Dict[str, np.ndarray]]:
    out: Dict[str, Dict[str, np.ndarray]] = {}
    for k, v in arrays.items():
        if k.startswith("__"):
            continue
        case, _, field = k.partition("#")
        out.setdefault(case, {})[field] = v
    return out


def differences(A: Dict[str, np.ndarray], B: Dict[str, np.ndarray]) -> Tuple[List[Difference], int, int]:
    """Every difference of two dumps, the number of keys compared and of
    elements compared."""
    ca, cb = _cases(A), _cases(B)
    out: List[Difference] = []
    keys = elements = 0
    for case in sorted(set(ca) | set(cb)):
        fa, fb = ca.get(case), cb.get(case)
        if fa is None or fb is None:
            out.append(Difference(case, f"absent in {'A' if fa is None else 'B'}",
                                  note="the other dump has it (another --quick/--robots/--only?)"))
            continue
        keys += 1
        ma, mb = "!missing" in fa, "!missing" in fb
        if ma or mb:
            side = "A and B" if ma and mb else ("A" if ma else "B")
            msg = str((fa if ma else fb)["!missing"])
            out.append(Difference(case, f"missing in {side}", note=_short(msg)))
            continue
        ea, eb = "!error" in fa, "!error" in fb
        if ea != eb:
            msg = str((fa if ea else fb)["!error"])
            out.append(Difference(case, "status", note=f"{'A' if ea else 'B'} raised: {_short(msg, 90)}"))
            continue
        for field in sorted(set(fa) | set(fb)):
            key = f"{case}#{field}"
            if field not in fa or field not in fb:
                out.append(Difference(key, f"field absent in {'A' if field not in fa else 'B'}"))
                continue
            elements += int(fa[field].size)
            out += compare_arrays(key, fa[field], fb[field])
    return out, keys, elements


def parse_allow(items: Sequence[str], files: Sequence[str] = ()) -> List[Tuple[str, str]]:
    """``GLOB=REASON`` items (and lines of files: ``GLOB = reason``, ``#`` comments) as (glob, reason)."""
    lines = list(items)
    for f in files:
        for line in Path(f).read_text().splitlines():
            line = line.strip()
            if line and not line.startswith("#"):
                lines.append(line)
    out = []
    for item in lines:
        glob, _, reason = item.partition("=")
        out.append((glob.strip(), reason.strip() or "(no reason given)"))
    return out


def _fmt(x: float) -> str:
    return "" if x != x else ("inf" if x == float("inf") else f"{x:.3g}")


def compare(a: "str | os.PathLike[str]", b: "str | os.PathLike[str]", allow: Sequence[Tuple[str, str]] = (),
            stream=None) -> int:
    """Print the differences of two dumps; 0 when none is left after ``allow``, else 1."""
    stream = stream or sys.stdout
    A, B = load(a), load(b)
    for label, arrays, path in (("A", A, a), ("B", B, b)):
        meta = json.loads(str(arrays["__meta__#json"])) if "__meta__#json" in arrays else {}
        print(f"{label}: {path}  cdsm {meta.get('cdsm_file')}  quick={meta.get('quick')} "
              f"threads={meta.get('threads')}  {meta.get('seconds')} s", file=stream)
    diffs, keys, elements = differences(A, B)
    accepted, left = [], []
    for d in diffs:
        case = d.key.partition("#")[0]
        hit = next(((g, r) for g, r in allow if fnmatch.fnmatchcase(d.key, g) or fnmatch.fnmatchcase(case, g)), None)
        (accepted if hit else left).append((d, hit))
    head = f"{'key':70s} {'difference':18s} {'count':>12s} {'max abs':>10s} {'max rel':>10s}  note"

    def row(d: Difference) -> str:
        count = f"{d.count}/{d.size}" if d.size else ""
        return (f"{_short(d.key):70s} {d.what:18s} {count:>12s} {_fmt(d.max_abs):>10s} {_fmt(d.max_rel):>10s}"
                f"  {d.note}")

    if left:
        print(f"\ndifferences ({len(left)}):", file=stream)
        print(head, file=stream)
        for d, _ in left:
            print(row(d), file=stream)
    if accepted:
        print(f"\naccepted by --allow ({len(accepted)}):", file=stream)
        for d, (g, reason) in accepted:
            print(f"{row(d)}\n    allowed by {g!r}: {reason}", file=stream)
    kinds: Dict[str, int] = {}
    for d, _ in left:
        kinds[d.what] = kinds.get(d.what, 0) + 1
    what = ", ".join(f"{v} {k}" for k, v in sorted(kinds.items())) or "none"
    print(f"\n{keys} keys ({elements} elements) compared; differences left: {len(left)} ({what}); "
          f"accepted: {len(accepted)}", file=stream)
    if keys == 0:
        print("NOTHING COMPARED (no key in both dumps)", file=stream)
        return 2
    print("IDENTICAL" if not diffs else ("DIFFERENT" if left else "IDENTICAL up to the accepted differences"),
          file=stream)
    return 1 if left else 0


# ---------------------------------------------------------------------------
# run-both
# ---------------------------------------------------------------------------
def _check_tree(pythonpath: Path) -> None:
    pkg = pythonpath / "cdsm"
    if not (pkg / "__init__.py").exists():
        raise SystemExit(f"bitcheck: no cdsm package in {pythonpath}")
    if not list(pkg.glob("_cdsm*.so")) and not list(pkg.glob("_cdsm*.pyd")):
        raise SystemExit(f"bitcheck: {pkg} holds no compiled _cdsm (copy or build it there first)")


def run_both(baseline: str, tree: str, out_dir: Optional[str], dump_args: List[str],
             allow: Sequence[Tuple[str, str]], parallel: bool = False) -> int:
    out = Path(out_dir) if out_dir else Path(tempfile.mkdtemp(prefix="bitcheck-"))
    out.mkdir(parents=True, exist_ok=True)
    sides = [("baseline", Path(baseline).resolve()), ("tree", (Path(tree) / "python").resolve())]
    procs = []
    for label, pp in sides:
        _check_tree(pp)
        env = dict(os.environ, PYTHONPATH=str(pp))
        cmd = [sys.executable, str(Path(__file__).resolve()), "dump", str(out / f"{label}.npz")] + dump_args
        print(f"bitcheck: dump with PYTHONPATH={pp}", file=sys.stderr)
        t = time.perf_counter()
        p = subprocess.Popen(cmd, env=env)
        if parallel:
            procs.append((label, p, t))
        else:
            if p.wait() != 0:
                raise SystemExit(f"bitcheck: the {label} dump failed (exit {p.returncode})")
            print(f"bitcheck: {label} dump {time.perf_counter() - t:.1f} s", file=sys.stderr)
    for label, p, t in procs:
        if p.wait() != 0:
            raise SystemExit(f"bitcheck: the {label} dump failed (exit {p.returncode})")
        print(f"bitcheck: {label} dump {time.perf_counter() - t:.1f} s", file=sys.stderr)
    for label, pp in sides:
        meta = json.loads(str(load(out / f"{label}.npz")["__meta__#json"]))
        if not Path(meta["cdsm_file"]).resolve().is_relative_to(pp):
            raise SystemExit(f"bitcheck: the {label} dump imported {meta['cdsm_file']}, not the cdsm in {pp}")
    print(f"bitcheck: dumps in {out}", file=sys.stderr)
    return compare(out / "baseline.npz", out / "tree.npz", allow)


# ---------------------------------------------------------------------------
# command line
# ---------------------------------------------------------------------------
def _dump_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--quick", action="store_true", help="fewer robots and samples (< 30 s)")
    p.add_argument("--threads", type=int, default=0, help="worker threads of every call (default 0: all cores)")
    p.add_argument("--robots", default=None, help="comma-separated robot names (default: all)")
    p.add_argument("--only", action="append", default=[], help="glob on the keys robot/case/variant (repeatable)")
    p.add_argument("-v", "--verbose", action="store_true")


def _allow_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--allow", action="append", default=[], metavar="GLOB=REASON",
                   help="accept differences of the keys matching GLOB, printing REASON (repeatable)")
    p.add_argument("--allow-file", action="append", default=[], metavar="FILE", help="lines 'GLOB = reason'")


def main(argv: Optional[Sequence[str]] = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = ap.add_subparsers(dest="command", required=True)
    d = sub.add_parser("dump", help="run every check with the importable cdsm")
    d.add_argument("out")
    _dump_options(d)
    c = sub.add_parser("compare", help="compare two dumps bit for bit")
    c.add_argument("a")
    c.add_argument("b")
    _allow_options(c)
    r = sub.add_parser("run-both", help="dump with the baseline and with a tree, then compare")
    r.add_argument("--baseline", default=DEFAULT_BASELINE,
                   help=f"PYTHONPATH of the baseline (default {DEFAULT_BASELINE})")
    r.add_argument("--tree", default=str(TREE), help="tree whose python/ to check (default: this script's)")
    r.add_argument("--out-dir", default=None, help="where the two dumps go (default: a new temporary directory)")
    r.add_argument("--parallel", action="store_true", help="run the two dumps at once")
    _dump_options(r)
    _allow_options(r)
    args = ap.parse_args(argv)
    if args.command == "dump":
        dump(args.out, args.quick, args.threads, args.robots.split(",") if args.robots else None, args.only,
             args.verbose)
        return 0
    allow = parse_allow(args.allow, args.allow_file)
    if args.command == "compare":
        return compare(args.a, args.b, allow)
    passthrough = (["--quick"] if args.quick else []) + ["--threads", str(args.threads)] + \
        (["--robots", args.robots] if args.robots else []) + [x for g in args.only for x in ("--only", g)] + \
        (["-v"] if args.verbose else [])
    return run_both(args.baseline, args.tree, args.out_dir, passthrough, allow, args.parallel)


if __name__ == "__main__":
    sys.exit(main())
