"""A fitted model of the real arm, :class:`FittedPlant` (nominal robot +
fitted effects: the plant with fitted parameters), that can be saved, loaded
and used to compensate cable commands. SI units (m, rad, N). ``Model`` is
its deprecated name (cdsm 0.2; one release, with a ``DeprecationWarning``).

The model is what the sim-to-real diagnosis (:mod:`cdsm.calibration.diagnosis`) chose: the
nominal :class:`~cdsm.robot.Robot` the controller believes in, plus the
unmodelled effects of :mod:`cdsm.calibration.plant` with their fitted parameters. With it,
:meth:`FittedPlant.compensate` finds the upper-cable length commands that put the
tip of the *fitted* plant on target poses.

Model file format ``cdsm-model/2`` (JSON, UTF-8)
------------------------------------------------
One JSON object; every number is a JSON float written by Python's ``repr``
(shortest round-trip form), so a model loads back bit-exactly::

    {
      "format": "cdsm-model/2",           # required; /1 files are read too (below)
      "cdsm_version": "0.1.0",            # the package that wrote it (informative)
      "name": "hole_height",              # the chosen model ('+'-joined, or 'none')
      "effects": ["hole_height"],         # fitted effects, in fit order
      "robot": {                          # the nominal robot
        "name": "...", "n": 3,
        "toml": "..."                     # a complete robot TOML (explicit holes),
      },                                  #   read by Robot.from_toml_str
      "params": {
        "layout": {"actuation_scale": [0, 1], ...},   # slice [start, stop) of each
                                                      #   effect in the flat vector
        "flat": [...],                    # (P,) the full plant parameter vector, SI
        "by_effect": {"hole_height": [...]},          # the fitted effects' values
        "std": {"hole_height": [...]}     # their 1-sigma uncertainty (SI, >= 0; null: not
      },                                  #   determined by the data), may be {}
      "data": {                           # provenance (null when built by hand)
        "source": "table3.csv", "kind": "displacement",
        "rows": 9, "rows_used": 9,
        "sha256": "...",                  # of the measurement arrays (see below)
        "file_sha256": "..." | null       # of the source file, if it was readable
      },
      "heldout": {                        # cross-validated figures (null by hand)
        "baseline_rms_m": ..., "final_rms_m": ..., "noise_m": ...,
        "noise_floor_m": ..., "explained": true, "best": "...", "ties": [...],
        "candidates": {"hole_height": <held-out RMS, m>, ...}
      }
    }

``data.kind`` is what the rows read (:attr:`Measurements.reading`; the key
keeps its name: file format). ``data.sha256`` is the SHA-256 of: the reading and n as ASCII (``"absolute 3\\n"``)
followed by the little-endian float64 bytes of the commanded ``theta`` (N, n)
or ``pose_cmd`` (N, 3), ``dL`` (N, n), ``measured`` (N, 2) and ``measured_phi``
(N,) when present, in that order. Non-finite figures are written as ``null``.
Every parameter is checked on reading (:func:`cdsm.calibration.plant.check_params`:
the physical domain, e.g. ``cable_friction`` within [0, 1], and at most 1000 in
size) and so is every 1-sigma list (one value per parameter of a fitted effect).
Readers must ignore unknown keys; a new major format bumps the version.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from typing import Dict, List, Mapping, Optional, Sequence

import numpy as np

from .. import deprecated
from ..files import read_text, sha256_of, write_text
from ..inputs import CdsmInputError, as_array, as_batch
from ..robot import Robot
from . import plant
from .compensation import Compensation, compensate
from .measurements import Measurements

__all__ = ["FittedPlant", "FORMAT"]

#: Version tag of the model file format (see the module docstring).
FORMAT = "cdsm-model/2"
#: Older formats this cdsm still reads (parameters remapped by block name).
READS = ("cdsm-model/1", FORMAT)


def _data_hash(meas: Measurements) -> str:
    hsh = hashlib.sha256(f"{meas.reading} {meas.n}\n".encode("ascii"))
    cmd = meas.theta if meas.theta is not None else meas.pose_cmd
    for arr in (cmd, meas.dL, meas.measured, meas.measured_phi):
        if arr is not None:
            hsh.update(np.ascontiguousarray(arr, dtype="<f8").tobytes())
    return hsh.hexdigest()


def _finite_or_none(v):
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


# ---------------------------------------------------------------------------
# the model
# ---------------------------------------------------------------------------
class FittedPlant:
    """The plant with fitted parameters: nominal robot + fitted effects (see the module docstring for the file).

    robot: the nominal :class:`Robot`. p: (P,) the full plant parameter vector
    (:func:`cdsm.calibration.plant.layout`), SI. effects: the fitted effects' names.
    name: the model name. std: {effect: 1-sigma list}. data, heldout: the
    provenance and cross-validated figures (dicts as in the file, or None).
    """

    def __init__(self, robot: Robot, p, effects: Sequence[str] = (), name: Optional[str] = None,
                 std: Optional[Mapping[str, Sequence[float]]] = None, data: Optional[dict] = None,
                 heldout: Optional[dict] = None, robot_toml_text: Optional[str] = None):
        self.robot = robot
        self.p = plant.check_params(robot, p, "p").copy()
        for e in effects:
            plant.effect_indices(robot, e)  # names the unknown ones
        self.effects = list(effects)
        self.name = name if name is not None else ("+".join(self.effects) or "none")
        self.std = _check_std(robot, self.effects, std)
        self.data = data
        self.heldout = heldout
        self._toml = robot_toml_text if robot_toml_text is not None else robot.to_toml()

    # ---- construction ---------------------------------------------------
    @classmethod
    def from_effects(cls, robot: Robot, effects: Mapping[str, Sequence[float]], **kw) -> "FittedPlant":
        """A model with given effect values ``{effect: values}`` (SI), e.g. a
        virtual prototype's truth. Every value within its physical domain
        (:func:`cdsm.calibration.plant.check_params`)."""
        return cls(robot, plant.check_params(robot, plant.params(robot, effects), "effects"), list(effects), **kw)

    @classmethod
    def from_diagnosis(cls, diag) -> "FittedPlant":
        """The chosen model of a :class:`cdsm.calibration.diagnosis.Diagnosis` (its final
        fit on all usable rows), with the data provenance and held-out figures."""
        robot = diag.prep.robot
        fin = diag.final()
        meas = diag.prep.meas
        src = meas.source or ""
        file_hash = sha256_of(src) if src and os.path.isfile(src) else None
        data = dict(source=src, kind=meas.reading, rows=int(len(meas)),
                    rows_used=int(diag.prep.usable.sum()), sha256=_data_hash(meas),
                    file_sha256=file_hash)
        heldout = dict(baseline_rms_m=_finite_or_none(diag.baseline.heldout_rms),
                       final_rms_m=_finite_or_none(fin.heldout_rms),
                       noise_m=_finite_or_none(diag.noise),
                       noise_floor_m=_finite_or_none(diag.noise_floor),
                       explained=bool(diag.explained), best=diag.best, ties=list(diag.ties),
                       candidates={c.name: _finite_or_none(c.heldout_rms) for c in diag.singles})
        # a parameter the data do not determine has a non-finite 1-sigma: NaN (null in the file)
        std = {e: [v if math.isfinite(v) else math.nan for v in vals]
               for e, vals in fin.fit.std_by_effect(robot).items()} if fin.effects else {}
        return cls(robot, fin.fit.p, fin.effects, name=diag.best, std=std, data=data, heldout=heldout)

    # ---- file -------------------------------------------------------------
    def params_by_effect(self) -> Dict[str, List[float]]:
        """{effect: values} of the fitted effects, SI."""
        return {e: self.p[plant.effect_indices(self.robot, e)].tolist() for e in self.effects}

    def to_dict(self) -> dict:
        """The file content as a dict (format ``cdsm-model/2``)."""
        from .. import __version__

        lay = plant.layout(self.robot)
        return {
            "format": FORMAT,
            "cdsm_version": __version__,
            "name": self.name,
            "effects": list(self.effects),
            "robot": {"name": self.robot.name, "n": int(self.robot.n), "toml": self._toml},
            "params": {
                "layout": {k: [s.start, s.stop] for k, s in lay.items()},
                "flat": [float(x) for x in self.p],
                "by_effect": self.params_by_effect(),
                "std": {k: [_finite_or_none(x) for x in v] for k, v in self.std.items()},
            },
            "data": self.data,
            "heldout": self.heldout,
        }

    def save(self, path: "str | os.PathLike[str]") -> None:
        """Write the model file (JSON, format ``cdsm-model/2``)."""
        write_text(path, json.dumps(self.to_dict(), indent=2, allow_nan=False) + "\n", "model")

    @classmethod
    def from_dict(cls, d: dict, source: str = "<model>") -> "FittedPlant":
        """Rebuild a model from :meth:`to_dict` output; checks the version and
        the parameter layout."""
        if not isinstance(d, dict):
            raise CdsmInputError(f"model file {source!r}: not a JSON object")
        fmt = d.get("format")
        if fmt not in READS:
            raise CdsmInputError(f"model file {source!r}: format {fmt!r} is not supported "
                                 f"(this cdsm reads {', '.join(map(repr, READS))})")
        try:
            rob = d["robot"]
            toml = rob["toml"]
            par = d["params"]
            flat = par["flat"]
            effects = list(d["effects"])
        except (KeyError, TypeError) as exc:
            raise CdsmInputError(f"model file {source!r}: missing field {exc}") from None
        try:
            robot = Robot.from_toml_str(toml)
        except CdsmInputError as exc:
            raise CdsmInputError(f"model file {source!r}: bad robot: {exc}") from None
        lay = plant.layout(robot)
        try:
            flat = as_array("params.flat", flat)
        except CdsmInputError as exc:
            raise CdsmInputError(f"model file {source!r}: {exc}") from None
        p = _remap(flat, par.get("layout"), lay, source)
        std = par.get("std", {})
        if not isinstance(std, dict):
            raise CdsmInputError(f"model file {source!r}: `params.std`: expected an object {{effect: [1-sigma "
                                 f"values]}}, got {json.dumps(std)}")
        try:
            p = plant.check_params(robot, p, "params.flat")
            return cls(robot, p, effects, name=d.get("name"), std=std,
                       data=d.get("data"), heldout=d.get("heldout"), robot_toml_text=toml)
        except CdsmInputError as exc:
            raise CdsmInputError(f"model file {source!r}: {exc}") from None

    @classmethod
    def load(cls, path: "str | os.PathLike[str]") -> "FittedPlant":
        """Read a model file written by :meth:`save` (exact round trip)."""
        src = str(path)
        text = read_text(path, "model")
        try:
            d = json.loads(text)
        except json.JSONDecodeError as exc:
            raise CdsmInputError(f"model file {src!r}: not JSON ({exc.msg} at line {exc.lineno})") from None
        return cls.from_dict(d, src)

    def __eq__(self, other) -> bool:
        if not isinstance(other, FittedPlant):
            return NotImplemented
        return json.dumps(self.to_dict(), sort_keys=True) == json.dumps(other.to_dict(), sort_keys=True)

    def __repr__(self) -> str:
        return f"FittedPlant({self.name!r}, robot={self.robot.name!r}, n={self.robot.n})"

    # ---- use --------------------------------------------------------------
    def predict(self, theta_cmd, dL=None, reading: str = "absolute", *, kind: Optional[str] = None):
        """The fitted plant's observations for commands ``theta_cmd`` (N, n) rad
        + ``dL`` (N, n) m of rows that read ``reading`` (``kind``: its
        deprecated name, one release): ((N, 3), converged (N,)), see
        :func:`cdsm.calibration.plant.predict`."""
        reading = deprecated.old_keyword("FittedPlant.predict", "kind", "reading", kind, reading)
        t, _ = as_batch("theta_cmd", theta_cmd, self.robot.n)
        d = np.zeros_like(t) if dL is None else dL
        return plant.predict(self.robot, self.p, t, d, reading)

    def compensate(self, poses, tol: float = 1e-9, max_iter: int = 40, min_tension: float = 0.0,
                   enforce_limits: bool = False, start=None) -> Compensation:
        """Upper-cable length commands that put the fitted plant's tip on
        ``poses`` (run in order): :func:`cdsm.calibration.compensation.compensate`
        (the options and flags are documented there)."""
        return compensate(self, poses, tol=tol, max_iter=max_iter, min_tension=min_tension,
                          enforce_limits=enforce_limits, start=start)


def _check_std(robot: Robot, effects: Sequence[str], std) -> Dict[str, List[float]]:
    """``std`` ({effect: 1-sigma values}, SI) checked: only fitted effects,
    each with one value >= 0 per parameter of the effect; ``None`` or NaN
    for a parameter the data do not determine (NaN in memory, ``null`` in
    the file). Refusals name ``std[effect]``."""
    if std is None:
        return {}
    if not isinstance(std, Mapping):
        raise CdsmInputError(f"`std`: expected {{effect: [1-sigma values]}}, got {type(std).__name__}")
    out: Dict[str, List[float]] = {}
    for k, v in std.items():
        field = f"std[{k!r}]"
        if k not in effects:
            raise CdsmInputError(f"`{field}`: {k!r} is not a fitted effect of this model "
                                 f"(effects: {', '.join(effects) or 'none'})")
        want = len(plant.effect_indices(robot, k))
        if not isinstance(v, (list, tuple, np.ndarray)):
            raise CdsmInputError(f"`{field}`: expected a list of {want} 1-sigma values (SI), got {v!r}")
        cells = [math.nan if x is None else x for x in np.asarray(v, dtype=object).ravel()]
        arr = as_array(field, cells)
        if np.ndim(v) != 1 or arr.size != want:
            raise CdsmInputError(f"`{field}`: expected a list of {want} 1-sigma values (SI; one per parameter of "
                                 f"{k}), got shape {np.shape(v)}")
        if np.isinf(arr).any() or (arr < 0).any():
            raise CdsmInputError(f"`{field}`: a 1-sigma value is finite and >= 0 (null: not determined), "
                                 f"got {arr.tolist()}")
        out[str(k)] = [float(x) for x in arr]
    return out


def _remap(flat: np.ndarray, file_layout, lay, source: str) -> np.ndarray:
    """The flat parameters of a model file in this cdsm's layout ``lay``,
    block by block by name (a file of an older format lacks the newer blocks:
    they are zero, the nominal value)."""
    if file_layout is None:
        if flat.ndim != 1 or flat.size != sum(sl.stop - sl.start for sl in lay.values()):
            raise CdsmInputError(f"model file {source!r}: params.flat needs "
                                 f"{sum(sl.stop - sl.start for sl in lay.values())} numbers, got {flat.size}")
        return flat
    p = np.zeros(sum(sl.stop - sl.start for sl in lay.values()))
    for name, span in file_layout.items():
        if name not in lay:
            raise CdsmInputError(f"model file {source!r}: unknown parameter block {name!r}")
        a, b = int(span[0]), int(span[1])
        sl = lay[name]
        if b - a != sl.stop - sl.start:
            raise CdsmInputError(f"model file {source!r}: block {name!r} has {b - a} values, "
                                 f"this robot needs {sl.stop - sl.start}")
        if a < 0 or b > flat.size:
            raise CdsmInputError(f"model file {source!r}: params.flat has {flat.size} numbers, but block "
                                 f"{name!r} needs entries {a}..{b - 1}")
        p[sl] = flat[a:b]
    return p


#: ``Model`` (cdsm 0.2's name of :class:`FittedPlant`) warns for one release.
__getattr__ = deprecated.module_getattr(__name__, {"Model": "FittedPlant"}, globals())
