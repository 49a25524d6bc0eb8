"""Measurement tables (CSV, SI units), shared by the paper pipeline and the
sim-to-real diagnosis.

A row is one measurement (or one commanded move). Commanded configuration:
``theta_1..theta_n`` (rad) or ``x_cmd, y_cmd[, phi_cmd]`` (m, m, rad; solved by
the nominal pose IK). Optional ``dL_1..dL_n`` (m): extra length commanded on
the upper cable of disk i. Measured: ``x, y`` (m, absolute tip position) or
``dx, dy`` (m, displacement caused by dL against the same command without
it); optional ``phi`` / ``dphi`` (rad). A row whose measured cells are empty is
a move that was commanded but not measured: it runs (it matters for
backlash) and is not scored. Rows run in file order, or in the order of an
optional integer ``sequence`` column (gaps allowed; equal values are an
error naming the rows). Lines starting with ``#`` are comments; other
columns (e.g. ``point``) are kept as labels. Numbers are ASCII decimal
(:data:`cdsm.files.NUMBER_CELL`: ``-1.5e-3``, ``.5``); ``1_0``, digits of other
scripts, ``nan`` and ``inf`` are refused with the file, row and column (an
empty measured cell is how a row says it was not measured).

Spatial arms (:func:`parse_csv` with ``cables``): ``theta_1..theta_n``,
``dL_1..dL_m`` on the m commanded cables (file order), measured
``x, y, z`` or ``dx, dy, dz`` (m) and optionally the rotation vector
``rx, ry, rz`` / ``drx, dry, drz`` (rad).

The commanded cables (:func:`commanded_cables`) are the position cables of
a rigid arm and the elastic cables (position and displacement cables, in
the robot's order) of an elastic one: a displacement ``d`` (m, positive =
pull) is the command ``theta`` = the rest angles, ``dL = -d``.

OpenCR-MuJoCo's system-identification recordings (``tdcr_sysid_*.csv``,
recognised by their ``servo_<id>_mm`` and ``tip_*`` columns;
:func:`cdsm.interop.opencr.read_sysid`) are read as such commands
(:func:`from_recording`): mm become m, the servo columns in their order are
the tendons ``k0..k{T-1}`` (checked against the ``tendon<k>_id<hw>`` labels),
``pattern_label`` is kept, and its pattern (the label without ``_hold``) is
the rows' default fold group.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass, field
from importlib import resources
from typing import Dict, List, Optional

import numpy as np

from .. import deprecated
from ..files import Table, parse_table, read_table
from ..inputs import CdsmInputError, did_you_mean
from ..display import ShortRepr
from ..plant import READING_CODES, commanded_cables

__all__ = ["Measurements", "parse_csv", "read_csv", "read_for", "packaged", "packaged_names", "after_reversals",
           "READING_CODES", "commanded_cables", "from_recording"]



@deprecated.renamed_fields(kind="reading")
@dataclass(repr=False)
class Measurements(ShortRepr):
    """A parsed measurement table; every array has one row per measurement.

    reading: what a measured row reads, ``"absolute"`` (x, y) or
    ``"displacement"`` (dx, dy); ``kind`` is its deprecated name (attribute
    and keyword, one release). theta: (N, n)
    commanded angles or None; pose_cmd: (N, 3) commanded poses or None. dL:
    (N, n) m (spatial: (N, m) on the position-controlled cables). measured:
    (N, 2) m (spatial: (N, 3)), NaN on rows that were commanded but not
    measured. measured_phi: (N,) rad or None (spatial: measured_rot (N, 3)
    rad or None). sequence: (N,) int execution order keys, or None (file
    order). labels: other columns as strings.
    """

    reading: str
    n: int
    dL: np.ndarray
    measured: np.ndarray
    theta: Optional[np.ndarray] = None
    pose_cmd: Optional[np.ndarray] = None
    measured_phi: Optional[np.ndarray] = None
    labels: Dict[str, List[str]] = field(default_factory=dict)
    source: str = ""
    sequence: Optional[np.ndarray] = None
    measured_rot: Optional[np.ndarray] = None
    #: the label column whose values group rows for cross-validation by
    #: default (rows of one value held out together), or None: row by row
    fold_groups: Optional[str] = None
    #: the rows sample continuous motions: in execution order, neighbouring
    #: rows of one fold group are neighbours in command and time (the
    #: diagnosis may then estimate the noise from neighbouring rows)
    sampled: bool = False

    def __len__(self) -> int:
        return len(self.measured)

    @property
    def observed(self) -> np.ndarray:
        """(N,) rows that carry a measurement (the others only run)."""
        return np.isfinite(self.measured).all(axis=1)

    @property
    def order(self) -> np.ndarray:
        """(N,) row indices in execution order."""
        if self.sequence is None:
            return np.arange(len(self))
        return np.argsort(self.sequence, kind="stable")

    def reading_codes(self) -> np.ndarray:
        """(N,) uint8 the rows' :data:`READING_CODES`: the data's reading,
        unmeasured rows as such."""
        return np.where(self.observed, READING_CODES[self.reading], READING_CODES["unmeasured"]).astype(np.uint8)

    def kind_codes(self) -> np.ndarray:
        """Deprecated name of :meth:`reading_codes` (one release)."""
        deprecated.warn_renamed("Measurements.kind_codes()", "Measurements.reading_codes()")
        return self.reading_codes()

    def copy_of(self) -> np.ndarray:
        """(N,) int: for each measured row that copies an earlier measured
        row bit for bit — the same command (``theta`` or ``pose_cmd``, and
        ``dL``) and the same reading (every measured column) — the index of
        the first such row (file order, 0-based); -1 elsewhere. Labels and
        ``sequence`` are not compared; -0.0 equals 0.0 and an empty cell an
        empty cell. A copy is one observation written twice, not a repeat:
        a repeat of a command has a reading of its own."""
        cmd = self.theta if self.theta is not None else self.pose_cmd
        cols = [a.reshape(len(self), -1) for a in (cmd, self.dL, self.measured, self.measured_phi,
                                                  self.measured_rot) if a is not None]
        key = np.concatenate(cols, axis=1).astype(np.float64) + 0.0  # -0.0 + 0.0 is 0.0
        key[np.isnan(key)] = np.nan  # one NaN pattern for every empty cell
        out = np.full(len(self), -1)
        seen = np.flatnonzero(self.observed)
        if not len(seen):
            return out
        rows = np.ascontiguousarray(key[seen]).view(np.dtype((np.void, key.itemsize * key.shape[1]))).ravel()
        _, first, inverse = np.unique(rows, return_index=True, return_inverse=True)
        orig = seen[first[inverse.reshape(-1)]]
        out[seen] = np.where(orig != seen, orig, -1)
        return out


def _sequence(table: Table) -> np.ndarray:
    vals = table.numbers("sequence")
    source = table.source
    if not np.all(vals == np.round(vals)):
        i = int(np.flatnonzero(vals != np.round(vals))[0])
        raise CdsmInputError(f"{source}: row {i + 1}, column 'sequence': must be an integer, got {vals[i]!r}")
    seq = vals.astype(np.int64)
    uniq, inv, counts = np.unique(seq, return_inverse=True, return_counts=True)
    if (counts > 1).any():
        dup = uniq[counts > 1][0]
        rows_dup = ", ".join(str(i + 1) for i in np.flatnonzero(seq == dup))
        raise CdsmInputError(f"{source}: column 'sequence': rows {rows_dup} share the value {dup}; "
                             "each row needs its own place in the execution order")
    return seq


def _read_as(n: int, cables: Optional[int]):
    """How a table's columns are kept (:func:`cdsm.files.parse_table`'s
    ``read_as``): the columns the format gives a meaning (commands,
    measurements, ``sequence``) as numbers, the others as text labels."""
    def read_as(cols: List[str]) -> Dict[str, str]:
        used = set(_used(set(cols), n, cables))
        return {c: "number" if c in used else "text" for c in cols}
    return read_as


def _used(has, n: int, cables: Optional[int]) -> List[str]:
    """The columns with a meaning in a table with columns ``has`` (the rest
    are labels)."""
    theta_cols = [f"theta_{i}" for i in range(1, n + 1)]
    if cables is None:
        meas = ("x", "y", "phi") if {"x", "y"} <= has else ("dx", "dy", "dphi")
        return theta_cols + ["x_cmd", "y_cmd", "phi_cmd"] + [f"dL_{i}" for i in range(1, n + 1)] + \
            list(meas) + ["sequence"]
    meas = ("x", "y", "z", "rx", "ry", "rz") if {"x", "y", "z"} <= has else ("dx", "dy", "dz", "drx", "dry", "drz")
    return theta_cols + [f"dL_{i}" for i in range(1, cables + 1)] + list(meas) + ["sequence"]


def parse_csv(text: str, n: int, source: str = "<csv>", cables: Optional[int] = None) -> Measurements:
    """Parse a measurement table for a robot with ``n`` joints (format above);
    ``cables``: the position-controlled cables of a spatial arm (spatial
    columns), None for a planar arm."""
    return _measurements(parse_table(text, source, read_as=_read_as(n, cables)), n, cables)


def _measurements(table: Table, n: int, cables: Optional[int]) -> Measurements:
    if cables is not None:
        return _parse_spatial(table, n, cables)
    cols, source, rows = table.columns, table.source, len(table)
    has = set(cols)
    theta_cols = [f"theta_{i}" for i in range(1, n + 1)]
    pose_cols = ["x_cmd", "y_cmd", "phi_cmd"]
    if set(theta_cols) <= has:
        theta, pose = np.stack([table.numbers(c) for c in theta_cols], 1), None
    elif set(pose_cols[:2]) <= has:
        theta = None
        phi = table.numbers("phi_cmd") if "phi_cmd" in has else np.zeros(rows)
        pose = np.stack([table.numbers("x_cmd"), table.numbers("y_cmd"), phi], 1)
    else:
        raise CdsmInputError(f"{source}: missing command columns: need {', '.join(theta_cols)} "
                             f"or x_cmd, y_cmd[, phi_cmd]; found {', '.join(cols)}")
    dl_cols = [f"dL_{i}" for i in range(1, n + 1)]
    extra = sorted(c for c in has if c.startswith("dL_") and c not in dl_cols)
    if extra:
        raise CdsmInputError(f"{source}: columns {extra} do not fit a robot with {n} joints")
    dL = np.stack([table.numbers(c) if c in has else np.zeros(rows) for c in dl_cols], 1)
    if {"x", "y"} <= has and {"dx", "dy"} & has:
        raise CdsmInputError(f"{source}: both absolute (x, y) and displacement (dx, dy) columns; "
                             "give one reading (absolute or displacement)")
    if {"x", "y"} <= has:
        reading, mcols, pcol = "absolute", ("x", "y"), "phi"
    elif {"dx", "dy"} <= has:
        reading, mcols, pcol = "displacement", ("dx", "dy"), "dphi"
    else:
        raise CdsmInputError(f"{source}: missing measured columns: need x, y (absolute) or dx, dy "
                             f"(displacement); found {', '.join(cols)}")
    measured = np.stack([table.numbers(c, allow_empty=True) for c in mcols], 1)
    half = np.isnan(measured).any(axis=1) & ~np.isnan(measured).all(axis=1)
    if half.any():
        i = int(np.flatnonzero(half)[0])
        raise CdsmInputError(f"{source}: row {i + 1}: {mcols[0]} and {mcols[1]} must both be given "
                             "(a measurement) or both be empty (a move that was not measured)")
    if np.isnan(measured).all():
        raise CdsmInputError(f"{source}: no row carries a measurement")
    mphi = table.numbers(pcol, allow_empty=True) if pcol in has else None
    seq = _sequence(table) if "sequence" in has else None
    labels = _labels(table, n, None)
    return Measurements(reading, n, dL, measured, theta, pose, mphi, labels, source, seq)


def _labels(table: Table, n: int, cables: Optional[int]) -> Dict[str, List[str]]:
    used = set(_used(set(table.columns), n, cables))
    return {c: table.text(c) for c in table.columns if c not in used}


def _parse_spatial(table: Table, n: int, m: int) -> Measurements:
    cols, source, rows = table.columns, table.source, len(table)
    has = set(cols)
    theta_cols = [f"theta_{i}" for i in range(1, n + 1)]
    if not set(theta_cols) <= has:
        raise CdsmInputError(f"{source}: missing command columns: a spatial arm needs {', '.join(theta_cols)}; "
                             f"found {', '.join(cols)}")
    theta = np.stack([table.numbers(c) for c in theta_cols], 1)
    dl_cols = [f"dL_{i}" for i in range(1, m + 1)]
    extra = sorted(c for c in has if c.startswith("dL_") and c not in dl_cols)
    if extra:
        raise CdsmInputError(f"{source}: columns {extra} do not fit a robot with {m} position-controlled cables")
    dL = np.stack([table.numbers(c) if c in has else np.zeros(rows) for c in dl_cols], 1)
    if {"x", "y", "z"} <= has:
        reading, mcols, rcols = "absolute", ("x", "y", "z"), ("rx", "ry", "rz")
    elif {"dx", "dy", "dz"} <= has:
        reading, mcols, rcols = "displacement", ("dx", "dy", "dz"), ("drx", "dry", "drz")
    else:
        raise CdsmInputError(f"{source}: missing measured columns: need x, y, z (absolute) or dx, dy, dz "
                             f"(displacement); found {', '.join(cols)}")
    measured = np.stack([table.numbers(c, allow_empty=True) for c in mcols], 1)
    half = np.isnan(measured).any(axis=1) & ~np.isnan(measured).all(axis=1)
    if half.any():
        i = int(np.flatnonzero(half)[0])
        raise CdsmInputError(f"{source}: row {i + 1}: {', '.join(mcols)} must all be given or all be empty")
    if np.isnan(measured).all():
        raise CdsmInputError(f"{source}: no row carries a measurement")
    rot = None
    if set(rcols) & has:
        if not set(rcols) <= has:
            raise CdsmInputError(f"{source}: give all of {', '.join(rcols)} (a rotation vector, rad) or none")
        rot = np.stack([table.numbers(c, allow_empty=True) for c in rcols], 1)
    seq = _sequence(table) if "sequence" in has else None
    return Measurements(reading, n, dL, measured, theta, None, None, _labels(table, n, m), source, seq, rot)


def read_csv(path: "str | os.PathLike[str]", n: int, cables: Optional[int] = None,
             progress: bool = False) -> Measurements:
    """Read a measurement CSV file (format in the module docstring),
    streamed: the file's text is not held, only the table's columns
    (:func:`cdsm.files.read_table`; ``progress``: a progress line on stderr)."""
    read_as = _read_as(n, cables)
    return _measurements(read_table(path, "measurement", read_as=read_as, progress=progress), n, cables)


def from_recording(robot, rec) -> Measurements:
    """Measurements of an OpenCR recording (:class:`cdsm.interop.opencr.Recording`,
    SI units) for ``robot``: each row commands the tendons' displacements
    ``d`` (m, positive = pull; the recording's tendons ``k0..`` are the
    robot's commanded cables in order) from the rest angles (``theta`` =
    :attr:`Robot.rest_angles`, ``dL = -d``); the tip (m, the tracker's frame)
    is an absolute reading; rows run in file order (the timestamps must not
    decrease); labels ``pattern_label``, ``pattern`` (the default fold group)
    and ``timestamp`` (s)."""
    cables = commanded_cables(robot)
    T = rec.commands.shape[1]
    if T != len(cables):
        raise CdsmInputError(f"recording {rec.path!r}: {T} servo columns (tendons k0..k{T - 1}), but the robot "
                             f"commands {len(cables)} cable(s); give the robot of the recording "
                             "(e.g. --robot ftdcr_v4 for FTDCR v4's files)")
    back = np.flatnonzero(np.diff(rec.time) < 0)
    if len(back):
        i = int(back[0]) + 1
        raise CdsmInputError(f"recording {rec.path!r}: row {i + 1}, column 'timestamp': {rec.time[i]!r} is "
                             f"earlier than the row before ({rec.time[i - 1]!r}); rows run in file order")
    N = len(rec.tip)
    theta = np.tile(np.asarray(robot.rest_angles, float), (N, 1))
    labels = {"pattern_label": list(rec.labels), "pattern": list(rec.groups),
              "timestamp": [repr(float(t)) for t in rec.time]}
    return Measurements("absolute", robot.n, -np.asarray(rec.commands, float), np.asarray(rec.tip, float),
                        theta=theta, labels=labels, source=rec.path, fold_groups="pattern", sampled=True)


def read_for(robot, path: "str | os.PathLike[str]", progress: bool = False) -> Measurements:
    """Read a measurement CSV file for ``robot`` (the columns of its kind,
    or an OpenCR recording: :func:`from_recording`); ``path`` may also name
    a packaged table (``"table3"``, ``"ftdcr_v4_train"``) when no such file
    exists — a file of that name wins. ``progress``: a progress line on
    stderr while a file is read."""
    from ..interop import opencr

    cables = len(commanded_cables(robot)) if robot.kind == "spatial" else None
    if not os.path.exists(path) and str(path) in packaged_names():
        if str(path) in opencr.RECORDINGS:
            return from_recording(robot, opencr.read_sysid(opencr.packaged(str(path))))
        text = resources.files("cdsm").joinpath("data", f"{path}.csv").read_text(encoding="utf-8")
        return parse_csv(text, robot.n, f"cdsm/data/{path}.csv", cables)
    if os.path.isfile(path) and opencr.is_sysid(path):
        return from_recording(robot, opencr.read_sysid(path))
    if not os.path.exists(path):
        raise CdsmInputError(f"measurement file {str(path)!r}: does not exist{did_you_mean(path, packaged_names())} "
                             f"(packaged tables, usable by name: {', '.join(packaged_names())})")
    return read_csv(path, robot.n, cables, progress)


def packaged_names() -> List[str]:
    """Names of the measurement tables shipped with cdsm (``cdsm/data/*.csv``)
    and of the packaged OpenCR recordings (``"ftdcr_v4_train"``, ...)."""
    from ..interop import opencr

    return sorted([p.name[:-4] for p in resources.files("cdsm").joinpath("data").iterdir()
                   if p.name.endswith(".csv")] + list(opencr.RECORDINGS))


def packaged(name: str, n: int = 3) -> Measurements:
    """A table shipped with cdsm: ``"table3"`` (the paper's measurements) or
    ``"table3_theory"`` (the paper's simulated column)."""
    if name not in packaged_names():
        raise CdsmInputError(f"`name`: no packaged measurement table {name!r}{did_you_mean(name, packaged_names())} "
                             f"(packaged: {', '.join(packaged_names())})")
    if not resources.files("cdsm").joinpath("data", f"{name}.csv").is_file():
        raise CdsmInputError(f"`name`: {name!r} is a recording of an OpenCR robot: read it for its robot, "
                             f"read_for(Robot.load('ftdcr_v4'), {name!r})")
    text = resources.files("cdsm").joinpath("data", f"{name}.csv").read_text(encoding="utf-8")
    return parse_csv(text, n, f"cdsm/data/{name}.csv")


def after_reversals(meas: Measurements) -> Measurements:
    """The same displacement measurements executed so that every measured
    move starts right after a reversal: before each measured row (execution
    order) an unmeasured row commands its base + dL, so the arm comes back to
    the base from the far side and the measured move loses the whole dead
    band of any backlash. With file order this bounds what an unknown
    execution order can do (SI units as the input)."""
    if meas.reading != "displacement":
        raise CdsmInputError("after_reversals: only displacement rows have a move to reverse "
                             f"(got {meas.reading} rows)")
    order = meas.order
    rows = np.repeat(order, 2)
    measured = meas.measured[rows].copy()
    measured[0::2] = np.nan

    def pick(a):
        return None if a is None else a[rows]

    phi = pick(meas.measured_phi)
    if phi is not None:
        phi = phi.copy()
        phi[0::2] = np.nan
    labels = {k: [f"{v[i]} (approach)" if j % 2 == 0 else v[i] for j, i in enumerate(rows)]
              for k, v in meas.labels.items()}
    rot = pick(meas.measured_rot)
    if rot is not None:
        rot = rot.copy()
        rot[0::2] = np.nan
    return dataclasses.replace(meas, dL=meas.dL[rows].copy(), measured=measured, theta=pick(meas.theta),
                               pose_cmd=pick(meas.pose_cmd), measured_phi=phi, labels=labels,
                               source=f"{meas.source} (after reversals)", sequence=None, measured_rot=rot)


#: ``KIND_CODES`` (cdsm 0.2's name of :data:`READING_CODES`) warns for one release.
__getattr__ = deprecated.module_getattr(__name__, {"KIND_CODES": "READING_CODES"}, globals())
