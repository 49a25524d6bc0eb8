"""Measurement tables (CSV, SI units), shared by the paper pipeline and the
sim-to-real diagnosis.

A row is one measurement. Commanded configuration: ``theta_1..theta_n`` (rad)
or ``x_cmd, y_cmd, phi_cmd`` (m, m, rad; solved by the nominal pose IK). Optional
``dL_1..dL_n`` (m): extra length commanded on the upper cable of disk i.
Measured: ``x, y`` (m, absolute tip position) or ``dx, dy`` (m, displacement
caused by dL); optional ``phi`` / ``dphi`` (rad). Lines starting with ``#`` are
comments; other columns (e.g. ``point``) are kept as labels.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from importlib import resources
from typing import Dict, List, Optional

import numpy as np

from ..files import parse_table, read_text, table_column
from ..inputs import CdsmInputError

__all__ = ["Measurements", "parse_csv", "read_csv", "packaged"]


@dataclass
class Measurements:
    """A parsed measurement table; every array has one row per measurement.

    kind: ``"absolute"`` (x, y) or ``"displacement"`` (dx, dy). theta: (N, n)
    commanded angles or None; pose_cmd: (N, 3) commanded poses or None. dL:
    (N, n) m. measured: (N, 2) m. measured_phi: (N,) rad or None. labels:
    other columns as strings.
    """

    kind: str
    n: int
    dL: np.ndarray
    measured: np.ndarray
    theta: Optional[np.ndarray] = None
    pose_cmd: Optional[np.ndarray] = None
    measured_phi: Optional[np.ndarray] = None
    labels: Dict[str, List[str]] = field(default_factory=dict)
    source: str = ""

    def __len__(self) -> int:
        return len(self.measured)


def parse_csv(text: str, n: int, source: str = "<csv>") -> Measurements:
    """Parse a measurement table for a robot with ``n`` joints (format above)."""
    cols, rows = parse_table(text, source)
    has = set(cols)
    theta_cols = [f"theta_{i}" for i in range(1, n + 1)]
    pose_cols = ["x_cmd", "y_cmd", "phi_cmd"]
    if set(theta_cols) <= has:
        theta, pose = np.stack([table_column(rows, c, source) for c in theta_cols], 1), None
    elif set(pose_cols[:2]) <= has:
        theta = None
        phi = table_column(rows, "phi_cmd", source) if "phi_cmd" in has else np.zeros(len(rows))
        pose = np.stack([table_column(rows, "x_cmd", source), table_column(rows, "y_cmd", source), phi], 1)
    else:
        raise CdsmInputError(f"{source}: missing command columns: need {', '.join(theta_cols)} "
                             f"or x_cmd, y_cmd[, phi_cmd]; found {', '.join(cols)}")
    dl_cols = [f"dL_{i}" for i in range(1, n + 1)]
    extra = sorted(c for c in has if c.startswith("dL_") and c not in dl_cols)
    if extra:
        raise CdsmInputError(f"{source}: columns {extra} do not fit a robot with {n} joints")
    dL = np.stack([table_column(rows, c, source) if c in has else np.zeros(len(rows)) for c in dl_cols], 1)
    if {"x", "y"} <= has and {"dx", "dy"} & has:
        raise CdsmInputError(f"{source}: both absolute (x, y) and displacement (dx, dy) columns; give one kind")
    if {"x", "y"} <= has:
        kind, mcols, pcol = "absolute", ("x", "y"), "phi"
    elif {"dx", "dy"} <= has:
        kind, mcols, pcol = "displacement", ("dx", "dy"), "dphi"
    else:
        raise CdsmInputError(f"{source}: missing measured columns: need x, y (absolute) or dx, dy "
                             f"(displacement); found {', '.join(cols)}")
    measured = np.stack([table_column(rows, c, source) for c in mcols], 1)
    mphi = table_column(rows, pcol, source) if pcol in has else None
    used = set(theta_cols + pose_cols + dl_cols + list(mcols) + [pcol])
    labels = {c: [r[c] for r in rows] for c in cols if c not in used}
    return Measurements(kind, n, dL, measured, theta, pose, mphi, labels, source)


def read_csv(path: "str | os.PathLike[str]", n: int) -> Measurements:
    """Read a measurement CSV file (format in the module docstring)."""
    return parse_csv(read_text(path, "measurement"), n, str(path))


def packaged(name: str, n: int = 3) -> Measurements:
    """A table shipped with cdsm: ``"table3"`` (the paper's measurements) or
    ``"table3_theory"`` (the paper's simulated column)."""
    text = resources.files("cdsm").joinpath("data", f"{name}.csv").read_text(encoding="utf-8")
    return parse_csv(text, n, f"cdsm/data/{name}.csv")
