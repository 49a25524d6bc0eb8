"""OpenCR-MuJoCo's tendon-driven continuum robots in (docs/interop.md,
"OpenCR"): a generation config (``configs/generation/*.json`` of
https://github.com/ContinuumRoboticsLab/opencr-mujoco) as a cdsm robot
file's data (:func:`robot_data`), and its system-identification recordings
(``tdcr_sysid_*.csv``) as commands and tip readings (:func:`read_sysid`).
SI units in everything returned (the recordings' mm become m).

What OpenCR's generator builds, and so what :func:`robot_data` writes
(docs/model.md, "Elastic arms"): a backbone rod of ``N`` uniform links
(length ``l = L/N``, half links at both ends) with ``joints_per_link``
bending hinges at each of the ``N`` stations ``(i - 1/2) l`` (axes ``x``
then ``-y`` of OpenCR's frame), each of stiffness ``N E I / L`` from the
rod (``material`` mode); tendons at ``distance_to_backbone`` and angle
``seg_offsets[s] + 2 pi n / T + tendon_angle_deltas[s][n]``, through one via
point per link at the uniform layout's link ends ``u = i l`` remapped
piecewise linearly so that segment ``s``'s tendons end at its cumulative
length; each tendon commanded in displacement through the actuator's
position gain ``kp`` (``tendon_kp_array``, or ``tendon_kp`` times the
``inverse_length`` multiplier linear in the segment index) with its
``tendon_pretension``, pull only, capped by ``tendon_forcerange``. OpenCR's
tendons do not stretch: the cable's E is set so large that ``k_s = kp``
to rounding. cdsm's backbone runs along ``x``: OpenCR's ``(x, y, z)`` is
cdsm's ``(y, z, x)``, so a tendon angle in OpenCR's ``xy`` plane is the
same angle here, measured from ``y`` towards ``z``.
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass
from typing import List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..display import ShortRepr
from ..files import read_table
from ..inputs import CdsmInputError

__all__ = ["robot_data", "load_config", "read_sysid", "is_sysid", "CONFIGS", "RECORDINGS", "Recording", "packaged",
           "PACKAGED", "INEXTENSIBLE_MODULUS", "MM"]

#: Young's modulus (Pa) written for OpenCR's tendons, which it models as
#: inextensible: E A / L is then about 1e21 N/m beside kp of 1e3-1e4 N/m.
INEXTENSIBLE_MODULUS = 1e30

#: The cable diameter written (m): any value; with :data:`INEXTENSIBLE_MODULUS`
#: it changes nothing.
TENDON_DIAMETER = 2e-4

#: One millimetre in metres (the recordings' unit).
MM = 1e-3


#: The packaged files of OpenCR's FTDCR v4 (``cdsm/data/ftdcr_v4/``, MIT
#: licence, its README says from where), by name: its generation configs and
#: its recordings. ``"ftdcr_v4"`` is the design (written by cdsm: the
#: ``ftdcr_v4_sysid`` config with the design tendon layout, segment offsets
#: 0, 30, 60 degrees, no per-tendon corrections and no pretension).
PACKAGED = {
    "ftdcr_v4": "ftdcr_v4_design.json",
    "ftdcr_v4_sysid": "ftdcr_v4_sysid.json",
    "ftdcr_v4_sysid_0326": "ftdcr_v4_sysid_0326.json",
    "ftdcr_v4_sysid_tension": "ftdcr_v4_sysid_tension.json",
    "ftdcr_v4_pipeline": "ftdcr_v4_pipeline.json",
    "ftdcr_v4_tendon_pull": "tdcr_sysid_20260511-183002_tendon_pull.csv",
    "ftdcr_v4_train": "tdcr_sysid_20260511-183002_train.csv",
    "ftdcr_v4_val": "tdcr_sysid_20260511-183002_val.csv",
}

#: The packaged generation configs (robots, :meth:`cdsm.Robot.load` by name;
#: ``ftdcr_v4_sysid_tension`` drives its tendons in force, which cdsm does not
#: read yet) and recordings (:func:`cdsm.calibration.measurements.read_for`).
CONFIGS = ("ftdcr_v4", "ftdcr_v4_sysid", "ftdcr_v4_sysid_0326", "ftdcr_v4_sysid_tension")
RECORDINGS = tuple(k for k, v in PACKAGED.items() if v.endswith(".csv"))


def packaged(name: str) -> str:
    """The path of a packaged OpenCR file by name (:data:`PACKAGED`)."""
    from importlib import resources

    from ..inputs import did_you_mean

    if name not in PACKAGED:
        raise CdsmInputError(f"`name`: no packaged OpenCR file {name!r}{did_you_mean(name, list(PACKAGED))} "
                             f"(packaged: {', '.join(PACKAGED)})")
    return str(resources.files("cdsm").joinpath("data", "ftdcr_v4", PACKAGED[name]))


def _field(config: Mapping, key: str, where: str = ""):
    if key not in config:
        raise CdsmInputError(f"OpenCR config: `{where}{key}` is missing")
    return config[key]


def _number(v, field: str, positive: bool = False, non_negative: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise CdsmInputError(f"OpenCR config: `{field}`: expected a finite number, got {v!r}")
    v = float(v)
    if positive and not v > 0:
        raise CdsmInputError(f"OpenCR config: `{field}`: must be > 0, got {v!r}")
    if non_negative and v < 0:
        raise CdsmInputError(f"OpenCR config: `{field}`: must be >= 0, got {v!r}")
    return v


def _numbers(text, field: str, count: int) -> List[float]:
    """OpenCR's space-separated vectors (``"0 0 -9.81"``)."""
    parts = str(text).split()
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise CdsmInputError(f"OpenCR config: `{field}`: expected {count} numbers separated by spaces, got {text!r}")
    return values


def _per_segment(config: Mapping, key: str, segments: int) -> List:
    table = _field(config, key)
    if not isinstance(table, Mapping) or sorted(table) != [str(s + 1) for s in range(segments)]:
        raise CdsmInputError(f"OpenCR config: `{key}`: expected one entry per segment keyed "
                             f"{', '.join(repr(str(s + 1)) for s in range(segments))}, got {table!r}")
    return [table[str(s + 1)] for s in range(segments)]


def load_config(path: "str | os.PathLike[str]") -> dict:
    """An OpenCR generation config (JSON) read from ``path``."""
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except OSError as e:
        raise CdsmInputError(f"OpenCR config {str(path)!r}: cannot be read ({e.strerror or e})") from None
    except (ValueError, UnicodeDecodeError) as e:
        raise CdsmInputError(f"OpenCR config {str(path)!r}: not JSON ({e})") from None
    if not isinstance(data, dict):
        raise CdsmInputError(f"OpenCR config {str(path)!r}: expected a JSON object")
    return data


def robot_data(config: Mapping, name: Optional[str] = None) -> dict:
    """The cdsm robot file's data (a dict for :meth:`cdsm.Robot.from_data`;
    SI units) of an OpenCR generation config (a parsed JSON object, see
    :func:`load_config`): a spatial arm of ``N`` linkages of
    ``joints_per_link`` elastic bending joints (stiffness from a
    ``[backbone]`` rod), one via plate per link, and one displacement cable
    per tendon in OpenCR's actuator order (segment-major: ``k0`` is segment
    1's tendon 0). The parts OpenCR's generator offers and its tendon arms
    do not use are refused naming the key (other actuation or joint modes,
    torsion joints, independent segments)."""
    if not isinstance(config, Mapping):
        raise CdsmInputError(f"OpenCR config: expected a JSON object, got {type(config).__name__}")
    if _field(config, "actuation_mode") != "parallel_tendons":
        raise CdsmInputError(f"OpenCR config: `actuation_mode`: only 'parallel_tendons' is read, "
                             f"got {config['actuation_mode']!r}")
    if _field(config, "joint_config_mode") != "material":
        raise CdsmInputError(f"OpenCR config: `joint_config_mode`: only 'material' (stiffness from the rod) is "
                             f"read, got {config['joint_config_mode']!r}")
    if "material_properties_per_segment" in config:
        raise CdsmInputError("OpenCR config: `material_properties_per_segment`: per-segment rods are not read")
    if config.get("independent_segments", False):
        raise CdsmInputError("OpenCR config: `independent_segments`: only coupled segments are read")
    if _field(config, "joints_per_link") != 2:
        raise CdsmInputError(f"OpenCR config: `joints_per_link`: only 2 (two bending hinges per link) is read, "
                             f"got {config['joints_per_link']!r}")
    S = _field(config, "num_segments")
    if isinstance(S, bool) or not isinstance(S, int) or S < 1:
        raise CdsmInputError(f"OpenCR config: `num_segments`: expected a positive integer, got {S!r}")
    links = _per_segment(config, "links_per_segment", S)
    for s, k in enumerate(links):
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            raise CdsmInputError(f"OpenCR config: `links_per_segment.{s + 1}`: expected a positive integer, got {k!r}")
    lengths = [_number(v, f"segment_lengths.{s + 1}", positive=True)
               for s, v in enumerate(_per_segment(config, "segment_lengths", S))]
    mat = _field(config, "material_properties")
    E = _number(_field(mat, "youngs_modulus", "material_properties."), "material_properties.youngs_modulus",
                positive=True)
    r_out = _number(_field(mat, "outer_radius", "material_properties."), "material_properties.outer_radius",
                    positive=True)
    r_in = _number(mat.get("inner_radius", 0.0), "material_properties.inner_radius", non_negative=True)
    if r_in != 0.0:
        raise CdsmInputError("OpenCR config: `material_properties.inner_radius`: only a solid rod (0) is read")
    rho = _number(_field(mat, "density", "material_properties."), "material_properties.density", positive=True)
    disk_radius = _number(_field(config, "radius"), "radius", positive=True)
    gx, gy, gz = _numbers(config.get("gravity", "0 0 -9.81"), "gravity", 3)

    N = sum(links)
    L = sum(lengths)
    ell = L / N
    # the via points: the uniform layout's link ends u = i l, remapped so that
    # segment s spans its own cumulative length
    first = np.concatenate([[0], np.cumsum(links)])
    start = np.concatenate([[0.0], np.cumsum(lengths)])
    plate = np.empty(N + 1)
    plate[0] = 0.0
    for i in range(1, N + 1):
        s = int(np.searchsorted(first, i, side="left")) - 1
        s = min(max(s, 0), S - 1)
        plate[i] = start[s] + (i - first[s]) * (lengths[s] / links[s])
    link_mass = rho * math.pi * r_out ** 2 * ell
    linkages = []
    for i in range(1, N + 1):
        station = (i - 0.5) * ell
        last = i == N
        linkages.append({
            "joints": [{"axis": [0.0, 1.0, 0.0], "offset": [station - plate[i - 1], 0.0, 0.0]},
                       {"axis": [0.0, 0.0, -1.0]}],
            "link_after": [plate[i] - station, 0.0, 0.0],
            "thickness": 0.0,
            "radius": disk_radius,
            "mass": link_mass / 2 if last else link_mass,
            "com": [station + (ell / 4 if last else ell / 2) - plate[i], 0.0, 0.0],
        })
    cables = _tendons(config, S, links)
    return {
        "kind": "spatial",
        "name": str(name if name is not None else config.get("description", "OpenCR continuum robot")),
        "gravity": [gz, gx, gy],
        "cable": {"youngs_modulus": INEXTENSIBLE_MODULUS, "diameter": TENDON_DIAMETER},
        "base": {"radius": disk_radius},
        "backbone": {"youngs_modulus": E, "radius": r_out, "segments": [{"length": L, "links": N}]},
        "linkage": linkages,
        "cables": cables,
    }


def _tendons(config: Mapping, S: int, links: Sequence[int]) -> List[dict]:
    details = _field(config, "actuation_details")
    segs = _field(details, "segments", "actuation_details.")
    if not isinstance(segs, list) or len(segs) != S:
        raise CdsmInputError(f"OpenCR config: `actuation_details.segments`: expected {S} entries, got {segs!r}")
    act = _field(config, "actuator_properties")
    if act.get("tendon_actuator_type", "position") != "position":
        raise CdsmInputError(f"OpenCR config: `actuator_properties.tendon_actuator_type`: only 'position' (a servo "
                             f"commanded in displacement) is read, got {act['tendon_actuator_type']!r}")
    counts = []
    for s, seg in enumerate(segs):
        T = _field(seg, "number_of_tendons", f"actuation_details.segments[{s}].")
        if isinstance(T, bool) or not isinstance(T, int) or T < 1:
            raise CdsmInputError(f"OpenCR config: `actuation_details.segments[{s}].number_of_tendons`: expected a "
                                 f"positive integer, got {T!r}")
        counts.append(T)
    total = sum(counts)
    offsets = config.get("seg_offsets", [0.0] * S)
    if not isinstance(offsets, list) or len(offsets) != S:
        raise CdsmInputError(f"OpenCR config: `seg_offsets`: expected {S} angles (rad), got {offsets!r}")
    deltas = config.get("tendon_angle_deltas", [[0.0] * T for T in counts])
    if not isinstance(deltas, list) or len(deltas) != S or any(
            not isinstance(d, list) or len(d) != T for d, T in zip(deltas, counts)):
        raise CdsmInputError(f"OpenCR config: `tendon_angle_deltas`: expected one list of {counts} angles (rad) per "
                             f"segment, got {deltas!r}")
    kp_array = act.get("tendon_kp_array")
    if kp_array is not None and (not isinstance(kp_array, list) or len(kp_array) != total):
        raise CdsmInputError(f"OpenCR config: `actuator_properties.tendon_kp_array`: expected {total} gains (N/m), "
                             f"got {kp_array!r}")
    kp0 = _number(_field(act, "tendon_kp", "actuator_properties.") if kp_array is None else act.get("tendon_kp", 1.0),
                  "actuator_properties.tendon_kp", positive=True)
    scaling = act.get("tendon_kp_scaling")
    f = _number(act.get("tendon_kp_scale_factor", 1.0), "actuator_properties.tendon_kp_scale_factor", positive=True)
    if scaling not in (None, "none", "inverse_length"):
        raise CdsmInputError(f"OpenCR config: `actuator_properties.tendon_kp_scaling`: 'inverse_length' or none, "
                             f"got {scaling!r}")
    pre = act.get("tendon_pretension", 0.0)
    if isinstance(pre, list):
        if len(pre) != total:
            raise CdsmInputError(f"OpenCR config: `actuator_properties.tendon_pretension`: expected {total} tensions "
                                 f"(N) or one, got {pre!r}")
    else:
        pre = [pre] * total
    cap = None
    if str(act.get("tendon_forcelimited", "false")).lower() == "true":
        lo, hi = _numbers(_field(act, "tendon_forcerange", "actuator_properties."),
                          "actuator_properties.tendon_forcerange", 2)
        cap = -lo
        if not cap > 0 or hi != 0.0:
            raise CdsmInputError(f"OpenCR config: `actuator_properties.tendon_forcerange`: expected '-F 0' with "
                                 f"F > 0 (a pull-only tendon), got {act['tendon_forcerange']!r}")
    ends = np.cumsum(links)
    out = []
    k = 0
    for s, T in enumerate(counts):
        r = _number(_field(segs[s], "distance_to_backbone", f"actuation_details.segments[{s}]."),
                    f"actuation_details.segments[{s}].distance_to_backbone", positive=True)
        m = 1.0 if scaling != "inverse_length" or S == 1 else 1.0 + (f - 1.0) * (S - 1 - s) / (S - 1)
        for n in range(T):
            kp = (_number(kp_array[k], f"actuator_properties.tendon_kp_array[{k}]", positive=True)
                  if kp_array is not None else kp0 * m)
            cable = {
                "end": int(ends[s]),
                "mode": "displacement",
                "radius": r,
                "angle": _number(offsets[s], f"seg_offsets[{s}]") + n * 2.0 * math.pi / T
                + _number(deltas[s][n], f"tendon_angle_deltas[{s}][{n}]"),
                "stiffness": kp,
                "pretension": _number(pre[k], f"actuator_properties.tendon_pretension[{k}]", non_negative=True),
            }
            if cap is not None:
                cable["max_tension"] = cap
            out.append(cable)
            k += 1
    return out


@dataclass(repr=False)
class Recording(ShortRepr):
    """An OpenCR system-identification recording, SI units: ``commands``
    (N, T) tendon displacements (m, positive = pull, OpenCR's actuator order
    ``k0..k{T-1}``), ``tip`` (N, 3) the motion-capture marker (m, the
    tracker's frame), ``time`` (N,) s, ``labels`` the rows' pattern labels
    as written, ``groups`` the labels without a ``_hold`` suffix (the
    pattern a row belongs to: hold out whole patterns, not rows), and
    ``hardware`` the servo id of each tendon (the CSV's column order)."""

    commands: np.ndarray
    tip: np.ndarray
    time: np.ndarray
    labels: Tuple[str, ...]
    groups: Tuple[str, ...]
    hardware: Tuple[int, ...]
    path: str


_SERVO = re.compile(r"servo_(\d+)_mm")


def is_sysid(path: "str | os.PathLike[str]") -> bool:
    """Whether the file at ``path`` reads as an OpenCR sysid recording: its
    header (the first line that is not a ``#`` comment) has a
    ``servo_<id>_mm`` column and ``tip_x``. A file that cannot be read as
    UTF-8 text is not one (its reader then says why)."""
    try:
        with open(path, encoding="utf-8-sig") as f:
            for line in f:
                if line.strip() and not line.lstrip().startswith("#"):
                    cols = [c.strip() for c in line.split(",")]
                    return "tip_x" in cols and any(_SERVO.fullmatch(c) for c in cols)
    except (OSError, UnicodeDecodeError):
        return False
    return False
_PULL = re.compile(r"tendon(\d+)_id(\d+)_pull")


def read_sysid(path: "str | os.PathLike[str]") -> Recording:
    """Read an OpenCR ``tdcr_sysid_*.csv`` recording (columns
    ``timestamp``, ``pattern_label``, ``servo_<id>_mm`` in the tendons'
    order ``k0, k1, ...``, ``tip_x``, ``tip_y``, ``tip_z`` in mm; numbers as
    :func:`cdsm.files.read_table` reads them): mm become m. Where a label
    names a tendon and its servo (``..._tendon<k>_id<hw>_pull``) it must
    agree with the column order."""
    table = read_table(path, "recording", read_as=lambda cols: {c: "text" if c == "pattern_label" else "number"
                                                                   for c in cols})
    where = table.source
    need = ["timestamp", "pattern_label", "tip_x", "tip_y", "tip_z"]
    servo = [(c, int(m.group(1))) for c in table.columns if (m := _SERVO.fullmatch(c))]
    missing = [c for c in need if c not in table.columns] + ([] if servo else ["servo_<id>_mm"])
    if missing:
        raise CdsmInputError(f"recording {where!r}: not an OpenCR sysid recording (missing columns "
                             f"{', '.join(missing)})")
    hw = tuple(h for _, h in servo)
    if len(set(hw)) != len(hw):
        raise CdsmInputError(f"recording {where!r}: a servo appears in two columns ({hw})")
    if len(table) == 0:
        raise CdsmInputError(f"recording {where!r}: no rows")
    commands = np.stack([table.numbers(c) for c, _ in servo], axis=1) * MM
    tip = np.stack([table.numbers(c) for c in ("tip_x", "tip_y", "tip_z")], axis=1) * MM
    time = table.numbers("timestamp").copy()
    labels = tuple(t.strip() for t in table.text("pattern_label"))
    for i, lab in enumerate(labels):
        m = _PULL.search(lab)
        if m:
            k, h = int(m.group(1)), int(m.group(2))
            if k >= len(hw) or hw[k] != h:
                col = f"servo_{hw[k]}_mm" if k < len(hw) else "absent"
                raise CdsmInputError(f"recording {where!r}, row {i + 1}: label {lab!r} pulls tendon {k} on servo "
                                     f"{h}, but column k{k} is {col}")
    groups = tuple(lab[:-len("_hold")] if lab.endswith("_hold") else lab for lab in labels)
    return Recording(commands, tip, time, labels, groups, hw, where)
