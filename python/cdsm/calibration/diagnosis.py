"""Sim-to-real gap diagnosis: which unmodelled effect explains the difference
between the nominal model and measurements, where the gap lies, and how far it
shrinks once the effect is added — judged on held-out rows. SI units (m, rad).

Pipeline (FIGAROH-like): prepare the commands (nominal pose IK for x_cmd rows),
fit each candidate effect of :mod:`cdsm.calibration.plant` by Levenberg–Marquardt (model
evaluations batched in the Rust core), rank by k-fold cross-validated held-out
RMS with AIC/BIC beside it, grow a combination by forward selection, and
report parameter uncertainty, identifiability, and the configuration features
that explain the residual size.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence

import numpy as np

from ..accuracy.sensitivity import sensitivity
from ..accuracy.workspace import paper_ik_seed, singular_values
from ..inputs import CdsmInputError
from ..progress import Progress
from ..robot import Robot
from . import plant
from .fit import Fit, fit, residual_matrix
from .measurements import Measurements

__all__ = ["prepare", "Prepared", "cross_validate", "diagnose", "Diagnosis", "Candidate", "better",
           "features", "spearman", "residuals", "DEFAULT_NOISE"]

# Measurement noise assumed when none is given: 10 µm per axis (laser tracker).
DEFAULT_NOISE = 10e-6


@dataclass
class Prepared:
    """Measurements with solved commands. theta_cmd (N, n) rad; usable (N,)
    bool; flags: {row: reason} for rows left out of the fit (never silently)."""

    robot: Robot
    meas: Measurements
    theta_cmd: np.ndarray
    usable: np.ndarray
    flags: Dict[int, str]

    @property
    def kind(self) -> str:
        return self.meas.kind

    @property
    def rows(self) -> np.ndarray:
        return np.flatnonzero(self.usable)


def prepare(robot: Robot, meas: Measurements) -> Prepared:
    """Solve each row's commanded configuration: theta_i given, or the nominal
    pose IK of (x_cmd, y_cmd, phi_cmd) from the paper's seed."""
    if meas.n != robot.n:
        raise CdsmInputError(f"measurements are for n = {meas.n} joints, the robot has {robot.n}")
    flags: Dict[int, str] = {}
    if meas.theta is not None:
        theta = np.array(meas.theta, dtype=float)
        ok = np.ones(len(meas), bool)
    else:
        sol = robot.ik(meas.pose_cmd, seed=paper_ik_seed(robot.n))
        theta = np.array(sol.theta, dtype=float)
        ok = np.asarray(sol.converged, bool)
        for i in np.flatnonzero(~ok):
            flags[int(i)] = f"commanded pose not reachable by the nominal model (IK residual {sol.residual[i]:.2e})"
        theta[~ok] = 0.0
    # the nominal commands must settle on the nominal model too
    obs, conv = plant.predict(robot, plant.params(robot), theta, meas.dL, meas.kind)
    for i in np.flatnonzero(ok & ~conv):
        flags[int(i)] = "the nominal model cannot realise the commanded cable lengths"
    ok &= conv
    return Prepared(robot, meas, theta, ok, flags)


def _folds(n_rows: int, k: int, seed: int = 0) -> List[np.ndarray]:
    order = np.random.default_rng(seed).permutation(n_rows)
    return [np.sort(order[i::k]) for i in range(k)]


def cross_validate(prep: Prepared, effects: Sequence[str], folds: int = 10) -> np.ndarray:
    """Held-out position error |e_xy| (m) of every usable row, by k-fold
    cross-validation (leave-one-out when there are fewer rows than folds)."""
    rows = prep.rows
    k = min(folds, len(rows))
    err = np.full(len(rows), np.nan)
    for test in _folds(len(rows), k):
        train = np.setdiff1d(np.arange(len(rows)), test)
        f = fit(prep, effects, rows[train]) if effects else None
        p = f.p if f is not None else np.zeros(plant.size(prep.robot))
        r = residual_matrix(prep, p[None], rows[test])[0].reshape(-1, 2)
        err[test] = np.hypot(r[:, 0], r[:, 1])
    return err


def _rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(e ** 2)))


def better(e_new: np.ndarray, e_old: np.ndarray, z: float = 2.0) -> bool:
    """Whether held-out errors ``e_new`` beat ``e_old`` beyond noise: a paired
    test on the per-row squared errors (mean gain > z standard errors)."""
    d = e_old ** 2 - e_new ** 2
    d = d[np.isfinite(d)]
    if len(d) < 2:
        return False
    se = d.std(ddof=1) / np.sqrt(len(d))
    return bool(d.mean() > z * se and d.mean() > 0)


@dataclass
class Candidate:
    """One effect or combination: its fit on all rows and its held-out errors."""

    name: str
    effects: List[str]
    fit: Fit
    heldout: np.ndarray

    @property
    def heldout_rms(self) -> float:
        return _rms(self.heldout)


@dataclass
class Diagnosis:
    """The answer: ``best`` (an effect, a '+'-joined combination, or 'none'),
    the baseline, every candidate (best first), the chosen model, the noise
    floor, per-row residuals and features, and identifiability notes."""

    best: str
    baseline: Candidate
    singles: List[Candidate]
    chosen: Optional[Candidate]
    steps: List[Candidate]
    noise: float
    prep: Prepared
    features: Dict[str, np.ndarray] = field(default_factory=dict)
    feature_correlation: Dict[str, float] = field(default_factory=dict)
    ties: List[str] = field(default_factory=list)
    correlated: List[str] = field(default_factory=list)
    folds: int = 10

    @property
    def noise_floor(self) -> float:
        """Expected held-out position RMS of a correct model: sqrt(2)·noise (m)."""
        return float(np.sqrt(2.0) * self.noise)

    @property
    def explained(self) -> bool:
        final = self.chosen.heldout_rms if self.chosen else self.baseline.heldout_rms
        return final <= 1.5 * self.noise_floor

    def final(self) -> Candidate:
        return self.chosen or self.baseline

    def to_json(self) -> dict:
        robot = self.prep.robot

        def cand(c: Candidate) -> dict:
            return dict(name=c.name, params=c.fit.params_by_effect(robot),
                        std=c.fit.std_by_effect(robot), heldout_rms_m=c.heldout_rms,
                        fit_rms_m=c.fit.rms, aic=c.fit.aic, bic=c.fit.bic,
                        converged=bool(c.fit.converged))

        return dict(
            best=self.best,
            baseline=dict(heldout_rms_m=self.baseline.heldout_rms, aic=self.baseline.fit.aic,
                          bic=self.baseline.fit.bic),
            effects=[cand(c) for c in self.singles],
            selection=[cand(c) for c in self.steps],
            chosen=cand(self.chosen) if self.chosen else None,
            noise_m=self.noise, noise_floor_m=self.noise_floor, explained=self.explained,
            kind=self.prep.kind, rows=int(len(self.prep.meas)), rows_used=int(self.prep.usable.sum()),
            flagged_rows={str(k): v for k, v in self.prep.flags.items()},
            ties=self.ties, correlated_parameters=self.correlated,
            feature_correlation=self.feature_correlation, folds=self.folds,
        )


def features(prep: Prepared) -> Dict[str, np.ndarray]:
    """Configuration features of every row (N,): closeness to a singular state
    (sigma_min/sigma_max of the pose Jacobian), the largest |joint angle| and
    |theta_2| (rad), the smallest upper tension (N), the tip sensitivity to the
    upper cables (m/m), the cable that carries dL, and X, Y (m)."""
    robot, th = prep.robot, prep.theta_cmd
    sv = singular_values(robot, th)
    sens = sensitivity(robot, th)
    pose = robot.fk(th)
    out = {
        "singularity (sigma_min/sigma_max)": sv[:, -1] / sv[:, 0],
        "max |joint angle| (rad)": np.abs(th).max(axis=1),
        "tip sensitivity to cables (m/m)": np.linalg.norm(sens[:, :2, :], axis=(1, 2)),
        "X (m)": pose[:, 0],
        "Y (m)": pose[:, 1],
        "cable with dL (index)": np.where(np.abs(prep.meas.dL).max(axis=1) > 0,
                                          np.abs(prep.meas.dL).argmax(axis=1) * 2 + 1, 0).astype(float),
    }
    if robot.n >= 2:
        out["|theta_2| (rad)"] = np.abs(th[:, 1])
    out["min upper tension (N)"] = robot.tensions(th).min(axis=1)
    return out


def _ranks(v: np.ndarray) -> np.ndarray:
    """Ranks of ``v`` (0-based), ties sharing their average rank."""
    order = np.argsort(v, kind="stable")
    r = np.empty(len(v))
    r[order] = np.arange(len(v), dtype=float)
    _, inv = np.unique(v, return_inverse=True)
    sums = np.bincount(inv, weights=r)
    return (sums / np.bincount(inv))[inv]


def spearman(a: np.ndarray, b: np.ndarray) -> float:
    m = np.isfinite(a) & np.isfinite(b)
    if m.sum() < 3:
        return float("nan")
    ra, rb = _ranks(a[m]), _ranks(b[m])
    if ra.std() == 0 or rb.std() == 0:
        return float("nan")
    return float(np.corrcoef(ra, rb)[0, 1])


def diagnose(robot: Robot, meas: Measurements, effects: Optional[Sequence[str]] = None,
             folds: int = 10, noise: float = DEFAULT_NOISE, max_combination: int = 3,
             progress: bool = False) -> Diagnosis:
    """Diagnose the gap between ``robot`` and ``meas`` (see the module doc).

    effects: the candidate library (default: every effect of :mod:`cdsm.calibration.plant`).
    noise: measurement noise per axis (m) for the noise floor. max_combination:
    the largest combination forward selection may build.
    """
    library = list(plant.EFFECTS if effects is None else effects)
    for e in library:
        if e not in plant.EFFECTS:
            raise CdsmInputError(f"`effects`: unknown effect {e!r}; known: {', '.join(plant.EFFECTS)}")
    if not (np.isfinite(noise) and noise > 0):
        raise CdsmInputError(f"`noise`: must be a positive number of m, got {noise}")
    prep = prepare(robot, meas)
    if prep.usable.sum() < 3:
        raise CdsmInputError(f"only {int(prep.usable.sum())} usable rows; the diagnosis needs at least 3")
    bar = Progress(len(library) + 1, "diagnose", progress)
    base = Candidate("none", [], fit(prep, []), cross_validate(prep, [], folds))
    bar.update(1)
    singles = []
    for e in library:
        singles.append(Candidate(e, [e], fit(prep, [e]), cross_validate(prep, [e], folds)))
        bar.update(1)
    singles.sort(key=lambda c: c.heldout_rms)
    chosen, steps = None, []
    top = singles[0] if singles else None
    if top is not None and better(top.heldout, base.heldout) and top.fit.bic < base.fit.bic:
        chosen = top
        steps.append(top)
        while len(chosen.effects) < max_combination:
            rest = [c.name for c in singles if c.name not in chosen.effects]
            trials = [Candidate("+".join(chosen.effects + [e]), chosen.effects + [e],
                                fit(prep, chosen.effects + [e]),
                                cross_validate(prep, chosen.effects + [e], folds)) for e in rest]
            if not trials:
                break
            trials.sort(key=lambda c: c.heldout_rms)
            nxt = trials[0]
            if better(nxt.heldout, chosen.heldout) and nxt.fit.bic < chosen.fit.bic:
                chosen = nxt
                steps.append(nxt)
            else:
                break
    d = Diagnosis(chosen.name if chosen else "none", base, singles, chosen, steps, float(noise), prep,
                  folds=int(min(folds, len(prep.rows))))
    # candidates the held-out errors cannot tell apart from the best single one
    if top is not None:
        d.ties = [c.name for c in singles[1:] if not better(top.heldout, c.heldout)
                  and c.heldout_rms < base.heldout_rms]
    final = d.final()
    if final.fit.corr.size:
        c = final.fit.corr
        names = final.fit.names
        for i in range(len(names)):
            for j in range(i + 1, len(names)):
                if abs(c[i, j]) > 0.95:
                    d.correlated.append(f"{names[i]} ~ {names[j]} (corr {c[i, j]:+.3f})")
    # where the gap lies: residual sizes against configuration features
    feats = features(prep)
    d.features = feats
    rows = prep.rows
    r_base = residual_matrix(prep, np.zeros(plant.size(robot))[None], rows)[0].reshape(-1, 2)
    size = np.hypot(r_base[:, 0], r_base[:, 1])
    d.feature_correlation = {k: spearman(v[rows], size) for k, v in feats.items()}
    return d


def residuals(d: Diagnosis, which: str = "final") -> np.ndarray:
    """Per-row residuals (N, 2) m (prediction − measurement) of the baseline or
    the final model, NaN for unusable rows."""
    prep = d.prep
    p = np.zeros(plant.size(prep.robot)) if which == "baseline" else d.final().fit.p
    out = np.full((len(prep.meas), 2), np.nan)
    out[prep.rows] = residual_matrix(prep, p[None], prep.rows)[0].reshape(-1, 2)
    return out
