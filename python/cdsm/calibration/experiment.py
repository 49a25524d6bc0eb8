"""Experiment design from a diagnosis: which measurements to take next so
that tied candidate models separate (or, for one model, so that its
parameters become precise). SI units (m, rad).

Criterion (model discrimination, Box–Hill / Buzzi-Ferraris style, linearised).
The candidates are the diagnosis' chosen model, its best single effect and
every effect tied with it (``diag.ties``), each with its fitted parameters.
Each model's parameters keep the uncertainty the data so far leave them:
posterior covariance ``C_m = (J_m^T J_m / sigma^2 + I / prior^2)^-1`` in
parameters scaled by their typical size (:data:`cdsm.calibration.plant.TYPICAL`; prior:
``prior`` typical sizes). For a set S of new rows the expected chi-square by
which the measurements would separate models a and b is

    D_ab(S) = d^T (2 sigma^2 I + J_a C_a J_a^T + J_b C_b J_b^T)^-1 d,   d = y_a(S) - y_b(S)

(y: predicted observed positions — [x, y] or [dx, dy] planar, [x, y, z] or
[dx, dy, dz] spatial — m; J: Jacobians on S; sigma:
noise per axis, m). A difference a model could absorb by moving a poorly
determined parameter counts little, and rows that tell the same thing share
one covariance, so they add little together. The score of S is the sum of D_ab
over the pairs (> ~10 per pair is decisive); K rows are picked greedily from a
candidate pool, each maximising the score of the set so far. With a single
candidate the fallback is greedy D-optimality (log det of the posterior
information of its parameters).

Candidate pool: commanded configurations uniform within the joint limits
(shrunk by ``margin``), with dL as in the data: displacement data gets one
upper cable at ±``dl`` (Table-3 style), absolute data dL uniform in ±``dl``;
kept only when every position cable stays taut (:meth:`Robot.feasible`) at the
commanded configuration and at the nominal one with dL, and when every
candidate model predicts the row.

Backlash and friction. When a candidate model has backlash or
``cable_friction`` (memory), what a row shows depends on the direction each
cable last moved (a dead band; the holes' sliding state). Each candidate then comes
as two *units*, one per approach side: an unmeasured approach row that
commands every upper cable ``approach`` (m, default ``dl``) beyond the row's
command — above (+) or below (−) — then the measured row. The approach
leaves every cable on a known side of its dead band whatever ran before, so
a unit's prediction does not depend on the order of the suggestions; moves
in both directions (with and against the approach) are then on offer, and
the criterion picks the ones that separate backlash from the effects it
ties with (a dead band costs a fixed length per reversal, an actuation
scale error a fixed fraction of every move) and friction from both (a
loading/unloading cycle: friction's lost motion grows with the tension and
the wrap angles of the pose, elasticity's has no direction).

Suggestion CSV (:meth:`Suggestion.to_csv`): a measurement table
(:mod:`cdsm.calibration.measurements`) without measured columns: ``point``
(s1, s2, ...; ``s1 approach`` for an approach row), ``theta_1..theta_n``
(rad), ``dL_1..dL_n`` (m), and for orientation the nominal tip pose
``x_nom, y_nom`` (m), ``phi_nom`` (rad) (read back as labels). Run the rows
in file order, measure each row that is not an approach row, add
``x, y`` (absolute) or ``dx, dy`` (displacement, the tip motion caused by dL)
in m — empty on approach rows — and feed it to ``cdsm diagnose`` after the
earlier data.
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np

from .. import deprecated
from ..files import write_text
from ..inputs import CdsmInputError, as_count
from ..robot import Robot
from . import plant
from .diagnosis import Diagnosis, Prepared, prepare
from .fit import free_parameters
from .measurements import READING_CODES, Measurements
from ..display import ShortRepr

__all__ = ["suggest", "Suggestion", "candidate_pool", "combine", "discrimination"]


@deprecated.renamed_fields(kind="reading")
@dataclass(repr=False)
class Suggestion(ShortRepr):
    """K proposed measurements.

    theta: (K, n) commanded angles, rad. dL: (K, m) extras on the
    position-controlled cables (a planar arm's upper cables), m. reading:
    "absolute" or "displacement" (as the data; ``kind``: its deprecated
    name, attribute and keyword, one release). criterion: "discrimination"
    or "d-optimal". models: candidate names compared. predictions: {model:
    (K, d) predicted observed position, m; d = 2 planar, 3 spatial}. gain:
    (K,) score after each greedy pick (chi-square units for discrimination,
    log det for d-optimal). score_before: the score of the data already
    taken. pairs_before / pairs_after: {"a vs b": D_ab + D_ba} (chi-square).
    noise: per-axis noise, m. pose: (K, task) nominal tip poses (planar m, m,
    rad; spatial x, y, z m, rotation vector rad). approach: (K, m) dL (m) of
    the unmeasured approach row run before each measured row (backlash
    candidates; see the module doc), or None.
    """

    theta: np.ndarray
    dL: np.ndarray
    reading: str
    criterion: str
    models: List[str]
    predictions: Dict[str, np.ndarray]
    gain: np.ndarray
    score_before: float
    pairs_before: Dict[str, float] = field(default_factory=dict)
    pairs_after: Dict[str, float] = field(default_factory=dict)
    noise: float = 10e-6
    pose: Optional[np.ndarray] = None
    pool_size: int = 0
    #: held-out RMS of the best model over the noise floor (sqrt(2)·noise);
    #: far above 1 the chi-square figures overstate the separation
    misfit: float = float("nan")
    approach: Optional[np.ndarray] = None

    def __len__(self) -> int:
        return len(self.theta)

    def commands(self) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The rows to run, in order: theta (R, n) rad, dL (R, m) m, and
        which to measure (R,) bool (approach rows are run, not measured)."""
        if self.approach is None:
            return self.theta, self.dL, np.ones(len(self), bool)
        k = len(self.theta)
        th = np.repeat(self.theta, 2, axis=0)
        dl = np.empty((2 * k, self.dL.shape[1]))
        dl[0::2], dl[1::2] = self.approach, self.dL
        return th, dl, np.tile([False, True], k)

    def to_csv(self, path: "str | os.PathLike[str]") -> str:
        """Write :meth:`csv_text` to ``path``. Returns the path."""
        return write_text(path, self.csv_text(), "suggestion")

    def csv_text(self) -> str:
        """The proposed commands as a measurement CSV without measured
        columns (format in the module docstring)."""
        n, m = self.theta.shape[1], self.dL.shape[1]
        d = next(iter(self.predictions.values())).shape[1] if self.predictions else 2
        axes = "xyz"[:d]
        mcols = ", ".join(axes) if self.reading == "absolute" else ", ".join(f"d{a}" for a in axes)
        names = ["x_nom", "y_nom", "phi_nom"] if d == 2 else ["x_nom", "y_nom", "z_nom", "rx_nom", "ry_nom",
                                                              "rz_nom"]
        buf = io.StringIO()
        buf.write(f"# cdsm diagnose --suggest: {len(self)} proposed measurements ({self.criterion}; "
                  f"models: {', '.join(self.models)})\n")
        buf.write(f"# SI units: theta_i and angles in rad; dL_i and positions in m. {', '.join(names)}: "
                  "nominal tip pose (labels only)\n")
        buf.write(f"# reading: {self.reading}; run the rows in this order; after measuring add columns "
                  f"{mcols} (m), empty on 'approach' rows (run, not measured), and run cdsm diagnose on it "
                  "after the earlier data\n")
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["point"] + [f"theta_{i}" for i in range(1, n + 1)] + [f"dL_{i}" for i in range(1, m + 1)]
                   + names)
        pose = self.pose if self.pose is not None else np.full((len(self), len(names)), np.nan)
        th, dl, seen = self.commands()
        for j in range(len(th)):
            i = j // 2 if self.approach is not None else j
            w.writerow([f"s{i + 1}" if seen[j] else f"s{i + 1} approach"] + [repr(float(v)) for v in th[j]]
                       + [repr(float(v)) for v in dl[j]] + [repr(float(v)) for v in pose[i]])
        return buf.getvalue()

    def summary(self) -> str:
        """A short human-readable account (units in the text)."""
        lines = []
        if np.isfinite(self.misfit) and self.misfit > 3.0:
            lines.append(f"warning: the best model still misses the data by {self.misfit:.1f}x the noise floor; "
                         "the separation figures below assume the stated noise and overstate how decisive "
                         "the suggestions are — they still say where the candidates differ most")
        if self.criterion == "discrimination":
            lines.append(f"{len(self)} suggested {self.reading} measurements to tell apart: {', '.join(self.models)}")
            lines.append(f"chi-square separation (>~10 is decisive; noise {self.noise * 1e6:.3g} µm per axis): "
                         f"{self.score_before:.3g} in the data so far (difference of the fits' chi-square), "
                         f"{self.gain[-1]:.3g} expected from the suggestions")
            for k in self.pairs_before:
                lines.append(f"  {k}: so far {self.pairs_before[k]:.3g}, expected from the suggestions "
                             f"{self.pairs_after.get(k, float('nan')):.3g}")
        else:
            lines.append(f"{len(self)} suggested {self.reading} measurements (D-optimal for the parameters of "
                         f"{', '.join(self.models) or 'the model'}); "
                         f"log det gain {self.gain[-1] - self.score_before:.3g}")
        lines.append(f"picked from {self.pool_size} feasible candidates (taut cables, within joint limits)")
        if self.approach is not None:
            lines.append("each row is approached from the side given (an unmeasured move of every upper cable "
                         "beyond the command, run first): with backlash the direction of a move matters")
        for i in range(len(self)):
            th = ", ".join(f"{np.degrees(v):+.1f}" for v in self.theta[i])
            dl = ", ".join(f"{v * 1e3:+.2f}" for v in self.dL[i])
            side = ""
            if self.approach is not None:
                first = self.dL[i] if self.reading == "absolute" else 0.0
                side = ", approached from " + ("above" if (self.approach[i] - first).mean() > 0 else "below")
            pr = "; ".join(f"{m}: (" + ", ".join(f"{v * 1e3:+.3f}" for v in p[i]) + ")"
                           for m, p in self.predictions.items())
            lines.append(f"  s{i + 1}: theta = ({th}) deg, dL = ({dl}) mm{side}; predicted [mm] {pr}")
        return "\n".join(lines)


# ---------------------------------------------------------------------------
def candidate_pool(robot: Robot, reading: Optional[str] = None, size: int = 400, seed: int = 0, dl: float = 1e-3,
                   margin: float = 0.9, *, kind: Optional[str] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Random candidate commands (theta (C, n) rad, dL (C, m) m on the
    position-controlled cables) within ``margin`` x the joint limits around
    their midpoints, each half-width at most 40° (0.698 rad), with taut
    cables (see module doc), for rows that read ``reading`` (``"absolute"``
    or ``"displacement"``: one cable's dL per row; ``kind``: its deprecated
    name, one release). ``size`` draws before the feasibility filter
    (C <= size); ``dl`` in m."""
    reading = deprecated.old_keyword("candidate_pool", "kind", "reading", kind, reading)
    if reading is None:
        raise TypeError("candidate_pool() missing the argument 'reading'")
    rng = np.random.default_rng(seed)
    n, m = robot.n, plant.commands(robot)
    lim = robot.joint_limits
    mid, half = lim.mean(axis=1), 0.5 * (lim[:, 1] - lim[:, 0]) * margin
    half = np.minimum(half, np.radians(40.0))
    theta = mid + rng.uniform(-1.0, 1.0, (size, n)) * half
    d = np.zeros((size, m))
    if reading == "displacement":
        d[np.arange(size), rng.integers(0, m, size)] = rng.choice([-dl, dl], size)
    else:
        d = rng.uniform(-dl, dl, (size, m))
    return _feasible(robot, theta, d)


def _feasible(robot: Robot, theta: np.ndarray, d: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    ok = _feasible_mask(robot, theta, d)
    return theta[ok], d[ok]


def _feasible_mask(robot: Robot, theta: np.ndarray, d: np.ndarray) -> np.ndarray:
    """(C,) commands within the joint limits with taut cables at theta and at
    the nominal configuration that theta's lengths + d reach."""
    ok = robot.within_limits(theta) & robot.feasible(theta)
    sol = robot.solve_cables(plant.command_lengths(robot, theta) + d, seed=theta)
    th2 = np.array(sol.theta, dtype=float)
    conv = np.asarray(sol.converged, bool)
    ok &= conv
    if conv.any():
        ok[conv] &= robot.within_limits(th2[conv]) & robot.feasible(th2[conv])
    return ok


def combine(robot: Robot, *tables: "Measurements | Prepared") -> Measurements:
    """One measurement table (commands as theta) from several of the same
    reading run one after the other, e.g. Table 3 (x_cmd rows) plus measured
    suggestions (theta rows). Pose-commanded rows are solved by the nominal
    IK (paper seed); rows that were run but not measured stay (backlash);
    flagged rows are dropped."""
    th, dl, ms, reading = [], [], [], None
    for t in tables:
        prep = t if isinstance(t, Prepared) else prepare(robot, t)
        if reading is None:
            reading = prep.reading
        elif prep.reading != reading:
            raise CdsmInputError(f"combine: tables of different readings ({reading}, {prep.reading})")
        flagged = np.zeros(len(prep.theta_cmd), bool)
        flagged[list(prep.flags)] = True
        runs = prep.usable | (~prep.meas.observed & ~flagged)
        rows = prep.order[runs[prep.order]]  # execution order
        th.append(prep.theta_cmd[rows])
        dl.append(prep.dL[rows])
        ms.append(prep.measured[rows, :plant.dims(robot)])
    if reading is None:
        raise CdsmInputError("combine: no tables")
    return Measurements(reading, robot.n, np.concatenate(dl), np.concatenate(ms), theta=np.concatenate(th),
                        source="combined")


# ---------------------------------------------------------------------------
def _model_set(diag: Diagnosis):
    """[(name, effects, p)] of the candidates to tell apart, best first."""
    out, seen = [], set()

    def add(c):
        if c is not None and c.name not in seen and c.effects:
            out.append((c.name, list(c.effects), np.array(c.fit.p)))
            seen.add(c.name)

    add(diag.chosen)
    if diag.singles:
        add(diag.singles[0])
    by = {c.name: c for c in diag.singles}
    for t in diag.ties:
        add(by.get(t))
    return out


def _pred_and_jac(robot: Robot, effects, p, theta, dl, codes):
    """Predictions (R, d) of the observed position (d = 2 planar, 3 spatial)
    and their exact Jacobian (R, d, k) in scaled parameters (the Rust core's
    linearised plant); NaN rows where the plant does not settle."""
    idx, scale, _ = free_parameters(robot, effects)
    obs, conv, J = plant.linearise(robot, p, idx, theta, dl, codes)
    d = plant.dims(robot)
    y = obs[:, :d].copy()
    J = J[:, :d, :] * scale
    y[~conv] = np.nan
    J[~conv] = np.nan
    return y, J


def _posterior_cov(J_old: np.ndarray, noise: float, prior: float) -> np.ndarray:
    """Parameter covariance (k, k) in scaled units from the rows already
    measured (J_old (R, d, k)) and a Gaussian prior of ``prior`` typical sizes."""
    J = J_old.reshape(-1, J_old.shape[-1]) / noise
    return np.linalg.inv(J.T @ J + np.eye(J.shape[1]) / prior ** 2)


def discrimination(y: Dict[str, np.ndarray], J: Dict[str, np.ndarray], C: Dict[str, np.ndarray],
                   noise: float) -> Dict[Tuple[str, str], float]:
    """Expected chi-square separation of every pair of models on a set of
    new rows: ``d^T (2 sigma^2 I + J_a C_a J_a^T + J_b C_b J_b^T)^-1 d`` with
    ``d = y_a - y_b`` over the rows. y[m]: (S, d) m; J[m]: (S, d, k) per
    scaled parameter; C[m]: (k, k) posterior covariance (see module doc)."""
    out = {}
    names = list(y)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            d = (y[a] - y[b]).reshape(-1)
            Ja = J[a].reshape(len(d), -1)
            Jb = J[b].reshape(len(d), -1)
            S = 2 * noise ** 2 * np.eye(len(d)) + Ja @ C[a] @ Ja.T + Jb @ C[b] @ Jb.T
            out[(a, b)] = float(d @ np.linalg.solve(S, d)) if len(d) else 0.0
    return out


def suggest(diag: Diagnosis, k: int, candidates: Optional[Tuple[np.ndarray, np.ndarray]] = None,
            seed: int = 0, pool: int = 400, dl: float = 1e-3, prior: float = 10.0,
            approach: Optional[float] = None) -> Suggestion:
    """The ``k`` next measurements that best separate the diagnosis' tied
    candidates (or, with one candidate, D-optimal ones for its parameters).

    candidates: optional pool (theta (C, n) rad, dL (C, m) m), filtered for
    joint limits and taut cables; default a random pool of ``pool`` commands
    (seed ``seed``) with dL as in the data (±``dl`` m). The rows read
    what the data read (:attr:`Prepared.reading`). approach: the approach move (m, default ``dl``) when a
    candidate has backlash. See the module docstring for the criterion.
    """
    k = as_count("k", k, 1)
    prep = diag.prep
    robot, reading, noise = prep.robot, prep.reading, float(diag.noise * prep.readings)
    if candidates is None:
        cth, cdl = candidate_pool(robot, reading, pool, seed, dl)
    else:
        cth = np.atleast_2d(np.asarray(candidates[0], float))
        cdl = np.atleast_2d(np.asarray(candidates[1], float))
        if len(cth) != len(cdl) or cth.shape[1] != robot.n or cdl.shape[1] != plant.commands(robot):
            raise CdsmInputError(f"`candidates`: need theta (C, {robot.n}) and dL (C, {plant.commands(robot)})")
        cth, cdl = _feasible(robot, cth, cdl)
    models = _model_set(diag)
    if not models:
        c = diag.singles[0] if diag.singles else None
        if c is None:
            raise CdsmInputError("the diagnosis has no candidate effects to design for")
        models = [(c.name, list(c.effects), np.array(c.fit.p))]
    criterion = "discrimination" if len(models) >= 2 else "d-optimal"
    app = None
    if any(e in eff for _, eff, _ in models for e in plant.MEMORY_EFFECTS):
        # one unit per approach side: (approach row, measured row)
        a = float(dl if approach is None else approach)
        if not (np.isfinite(a) and a > 0):
            raise CdsmInputError(f"`approach`: must be a positive length in m, got {approach}")
        first = cdl if reading == "absolute" else np.zeros_like(cdl)
        units = [(cth, cdl, first + side * a) for side in (1.0, -1.0)]
        keep = [_feasible_mask(robot, t, d) for t, _, d in units]
        cth = np.concatenate([u[0][m] for u, m in zip(units, keep)])
        cdl = np.concatenate([u[1][m] for u, m in zip(units, keep)])
        app = np.concatenate([u[2][m] for u, m in zip(units, keep)])
    if len(cth) == 0:
        raise CdsmInputError("no feasible candidate measurements (joint limits / slack cables)")
    # the data as run (usable and unmeasured rows, execution order), then the candidates
    flagged = np.zeros(len(prep.theta_cmd), bool)
    flagged[list(prep.flags)] = True
    run = prep.order[(prep.usable | (~prep.meas.observed & ~flagged))[prep.order]]
    codes = [prep.reading_codes[run]]
    th_all, dl_all = [prep.theta_cmd[run]], [prep.dL[run]]
    data_rows = np.flatnonzero(prep.usable[run])
    nD = len(run)
    if app is None:
        th_all.append(cth)
        dl_all.append(cdl)
        codes.append(np.full(len(cth), READING_CODES[reading], np.uint8))
        cand_rows = nD + np.arange(len(cth))
    else:
        th_all.append(np.repeat(cth, 2, axis=0))
        d = np.empty((2 * len(cth), cdl.shape[1]))
        d[0::2], d[1::2] = app, cdl
        dl_all.append(d)
        codes.append(np.tile(np.array([READING_CODES["unmeasured"], READING_CODES[reading]], np.uint8), len(cth)))
        cand_rows = nD + 1 + 2 * np.arange(len(cth))
    th_all, dl_all, codes = np.concatenate(th_all), np.concatenate(dl_all), np.concatenate(codes)
    Y, JJ = {}, {}
    for name, eff, p in models:
        Y[name], JJ[name] = _pred_and_jac(robot, eff, p, th_all, dl_all, codes)
    okc = np.ones(len(cth), bool)
    keepU = np.ones(len(data_rows), bool)
    for name in Y:
        good = np.isfinite(Y[name]).all(axis=1) & np.isfinite(JJ[name]).all(axis=(1, 2))
        okc &= good[cand_rows]
        keepU &= good[data_rows]
    cand = np.flatnonzero(okc)
    if len(cand) < k:
        raise CdsmInputError(f"only {len(cand)} feasible candidate measurements for k = {k}")
    base = list(data_rows[keepU])
    names = list(Y)
    chosen: List[int] = []
    gains = []
    Cr = cand_rows[cand]

    dm = plant.dims(robot)

    def pair_terms(sel):
        """Separation of the new rows sel (indices into all rows) plus each candidate."""
        idx = np.array(sel, dtype=int)
        M, s = len(Cr), dm * len(idx)
        tot = np.zeros(M)
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                d = np.concatenate([np.broadcast_to((Y[a][idx] - Y[b][idx]).reshape(-1), (M, s)),
                                    Y[a][Cr] - Y[b][Cr]], axis=1)                      # (M, s+d)
                S = 2 * noise ** 2 * np.eye(s + dm)[None].repeat(M, 0)
                for m in (a, b):
                    kk = JJ[m].shape[-1]
                    Jm = np.concatenate([np.broadcast_to(JJ[m][idx].reshape(s, kk), (M, s, kk)),
                                         JJ[m][Cr]], axis=1)                         # (M, s+d, k)
                    S = S + Jm @ Cov[m] @ np.transpose(Jm, (0, 2, 1))
                tot += np.einsum("mi,mi->m", d, np.linalg.solve(S, d[..., None])[..., 0])
        return tot

    def logdet_terms(sel):
        idx = np.array(sel, dtype=int)
        name = names[0]
        J0 = (JJ[name][idx] / noise).reshape(dm * len(idx), -1)
        kk = J0.shape[1]
        G0 = J0.T @ J0
        G0 = G0 + np.eye(kk) / prior ** 2  # Gaussian prior of `prior` typical sizes
        Jc = JJ[name][Cr] / noise
        G = G0[None] + np.einsum("mik,mil->mkl", Jc, Jc)
        return np.linalg.slogdet(G)[1], float(np.linalg.slogdet(G0)[1])

    Cov = {m: _posterior_cov(JJ[m][base], noise, prior) for m in names}
    if criterion == "discrimination":
        # evidence so far: the difference of the fits' chi-square on the data taken
        ssr = {name: c.fit.ssr for c in list(diag.singles) + list(diag.steps) for name in [c.name]}
        before = {(a, b): abs(ssr.get(a, np.nan) - ssr.get(b, np.nan)) / noise ** 2
                  for i, a in enumerate(names) for b in names[i + 1:]}
        score0 = float(sum(before.values()))
    else:
        score0 = logdet_terms(base)[1]
        before = {}
    avail = np.ones(len(cand), bool)
    for _ in range(k):
        newrows = list(Cr[chosen]) if chosen else []
        sc = pair_terms(newrows) if criterion == "discrimination" else logdet_terms(base + newrows)[0]
        sc = np.where(avail, sc, -np.inf)
        j = int(np.argmax(sc))
        chosen.append(j)
        avail[j] = False
        gains.append(float(sc[j]))
    pick = cand[np.array(chosen)]
    new = list(cand_rows[pick])
    after = discrimination({m: Y[m][new] for m in names}, {m: JJ[m][new] for m in names}, Cov, noise) \
        if criterion == "discrimination" else {}

    def sym(dd):
        return {f"{a} vs {b}": v for (a, b), v in dd.items()}

    theta, dL = cth[pick], cdl[pick]
    best = diag.final()
    misfit = best.heldout_rms / diag.noise_floor if diag.noise_floor > 0 else float("nan")
    return Suggestion(theta, dL, reading, criterion, names, {m: Y[m][new] for m in names},
                      np.array(gains), score0, sym(before), sym(after), noise, robot.fk(theta), len(cand),
                      float(misfit), None if app is None else app[pick])
