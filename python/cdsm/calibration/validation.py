"""A diagnosed model judged on a second file (``cdsm diagnose TRAIN.csv
--validate VAL.csv``; docs/model.md, "Validation on a second file").

The nominal model and the chosen model are taken as the diagnosis fitted
them on the first file — every parameter, the registered frame included —
and predict the second file's rows; nothing is refitted on the second file.
The figures are the tip position error (prediction − measurement), RMS over
the rows both models predict: as it is, and after removing its mean over
those rows (the mean offset: three translations, the metric of OpenCR and
of many calibration papers). Every other model the diagnosis fitted on
the first file (each effect alone, each step of the selection) is judged
the same way on the same rows: which effects carry over to the second
file, not only the chosen model. A row a model cannot predict (its plant does
not settle there) is counted and said, not scored for either model; a row
the nominal model cannot use (the reasons :func:`diagnosis.prepare` gives)
is flagged with its reason. SI units (m)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict

import numpy as np

from ..display import ShortRepr
from ..inputs import CdsmInputError
from . import plant
from .diagnosis import Diagnosis, prepare
from .measurements import Measurements

__all__ = ["Validation", "validate"]


@dataclass(repr=False)
class Validation(ShortRepr):
    """The nominal and the chosen model of a diagnosis on a second file.
    ``rows``: rows scored (both models predict them); ``rows_in_file``;
    ``nominal_rms``, ``model_rms`` (m): tip position error, RMS over those
    rows; ``*_mean_aligned`` (m): the same after removing the error's mean
    over the rows; ``unpredicted``: {"nominal", "model"} the rows each model
    cannot predict (0-based, file order); ``flagged``: {row: reason} the rows
    the nominal model cannot use (0-based); ``model``: the chosen model's
    name; ``source``: the second file."""

    rows: int
    rows_in_file: int
    nominal_rms: float
    model_rms: float
    nominal_rms_mean_aligned: float
    model_rms_mean_aligned: float
    unpredicted: Dict[str, list] = field(default_factory=dict)
    flagged: Dict[int, str] = field(default_factory=dict)
    model: str = "none"
    source: str = ""
    #: every other model the diagnosis fitted on the first file (each single
    #: effect, each step of the selection), judged the same way on the rows
    #: scored above: {name: (rms, rms_mean_aligned, rows it cannot predict)}
    candidates: Dict[str, tuple] = field(default_factory=dict)

    def to_json(self) -> dict:
        return dict(source=self.source, model=self.model, rows=self.rows, rows_in_file=self.rows_in_file,
                    nominal_rms_m=self.nominal_rms, model_rms_m=self.model_rms,
                    nominal_rms_mean_aligned_m=self.nominal_rms_mean_aligned,
                    model_rms_mean_aligned_m=self.model_rms_mean_aligned,
                    unpredicted={k: [i + 1 for i in v] for k, v in self.unpredicted.items()},
                    flagged_rows={str(k + 1): v for k, v in self.flagged.items()},
                    candidates=[dict(model=name, model_rms_m=r, model_rms_mean_aligned_m=ra, unpredicted=lost)
                                for name, (r, ra, lost) in self.candidates.items()],
                    refitted="nothing: every parameter and the frame as fitted on the first file")

    def summary(self) -> str:
        """One line for the command line."""
        lost = {k: len(v) for k, v in self.unpredicted.items() if v}
        said = ("; not predicted: " + ", ".join(f"{k} {n} row(s)" for k, n in lost.items())) if lost else ""
        return (f"validation on {self.source or 'the second file'}: {self.rows} of {self.rows_in_file} rows, tip "
                f"error RMS nominal {self.nominal_rms * 1e3:.3f} mm -> {self.model} {self.model_rms * 1e3:.3f} mm "
                f"(mean offset removed: {self.nominal_rms_mean_aligned * 1e3:.3f} -> "
                f"{self.model_rms_mean_aligned * 1e3:.3f} mm){said}")


def _rms(err: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(err ** 2, axis=1)))) if len(err) else float("nan")


def validate(d: Diagnosis, meas: Measurements) -> Validation:
    """Judge the nominal and the chosen model of ``d`` on the measurements
    ``meas`` of the same robot (another file: same columns, same
    :attr:`~Measurements.reading`), nothing refitted (module doc). The rows run in the second file's
    execution order from the plant's start state, as a new sequence."""
    robot = d.prep.robot
    if meas.n != robot.n:
        raise CdsmInputError(f"validation data: measurements for n = {meas.n} joints, the robot has {robot.n}")
    if meas.reading != d.prep.reading:
        raise CdsmInputError(f"validation data: {meas.reading} readings, the diagnosed data are {d.prep.reading}: "
                             "a model is judged on data of the same reading")
    # the frame rule "base": prepare() fits no frame here; the frame comes
    # with each model's parameters from the first file
    prep = prepare(robot, meas, frame="base")
    k = plant.dims(robot)
    order = prep.order
    fits = {"nominal": d.baseline.fit.p, "model": d.final().fit.p}
    others = {}
    for c in list(d.singles) + list(d.steps):
        if c.name not in others and c.name != d.final().name and c is not d.baseline:
            others[c.name] = c.fit.p
    pred, ok = plant.predict(robot, np.stack([fits["nominal"], fits["model"]] + list(others.values())),
                             prep.theta_cmd[order], prep.dL[order], prep.reading_codes[order])
    obs = np.empty_like(pred)
    obs[:, order] = pred
    conv = np.empty_like(ok)
    conv[:, order] = ok
    usable = prep.usable.copy()
    unpredicted = {}
    for j, name in enumerate(fits):
        good = conv[j] & np.isfinite(obs[j, :, :k]).all(axis=1)
        unpredicted[name] = [int(i) for i in np.flatnonzero(usable & ~good)]
        usable &= good
    rows = np.flatnonzero(usable)
    err = [obs[j, rows, :k] - prep.measured[rows, :k] for j in range(2)]
    judged = {}
    for j, name in enumerate(others, start=2):
        e = obs[j, rows, :k] - prep.measured[rows, :k]
        good = conv[j, rows] & np.isfinite(e).all(axis=1)
        e = e[good]
        judged[name] = (_rms(e), _rms(e - e.mean(axis=0)) if len(e) else float("nan"),
                        [int(i) for i in rows[~good]])
    return Validation(
        rows=int(len(rows)), rows_in_file=int(len(meas)),
        nominal_rms=_rms(err[0]), model_rms=_rms(err[1]),
        nominal_rms_mean_aligned=_rms(err[0] - err[0].mean(axis=0)) if len(rows) else float("nan"),
        model_rms_mean_aligned=_rms(err[1] - err[1].mean(axis=0)) if len(rows) else float("nan"),
        unpredicted=unpredicted, flagged=dict(prep.flags), model=d.best, source=meas.source or "",
        candidates=judged)
