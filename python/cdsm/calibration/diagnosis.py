"""Sim-to-real gap diagnosis: which unmodelled effect explains the difference
between the nominal model and measurements, where the gap lies, how far it
shrinks once the effect is added, and whether what is left is noise — judged
on held-out rows. SI units (m, rad).

Pipeline (FIGAROH-like):

1. **Prepare** the rows: commands in execution order (file order or the
   ``sequence`` column), the nominal pose IK for pose-commanded rows, rows the
   nominal model cannot realise flagged (never dropped silently), and so
   are rows that copy an earlier row bit for bit (command and reading): one
   observation, counted once — not as rows, folds or repeats
   (docs/model.md, "Rows, repeats and copies"); data about
   a thousand times off the robot's scale (mm given for m) are refused with a
   message that says so. Absolute data are **registered**: the measuring
   frame (rotation and translation) starts from a closed-form (Kabsch) fit of
   the nominal predictions to the measurements and is fitted with every
   candidate; ``frame="base"`` says the data are in the robot's base frame.
   By default (``frame="auto"``) registration is a hypothesis tested like any
   effect: absolute data whose RMS distance from the nominal predictions is
   within :data:`NEAR_FRACTION` of the arm's straight length are taken in the
   base frame, with ``frame_misalignment`` a candidate effect; data farther
   away (an instrument's own frame) are registered. No parameter of the
   library trades exactly with the frame: the base-to-first-joint link
   changes the cable routes and with them the joint angles, so it is not a
   translation (docs/model.md, "Registration"); an effect the frame makes
   redundant is dropped by the backward elimination of step 3.
2. **Candidates**: every effect of :mod:`cdsm.calibration.plant` is fitted in
   the Rust core (exact Jacobians, the physical domain as bounds; a fit that
   cannot stay physical fails for that candidate only) and scored by k-fold
   cross-validation (leave-one-out with fewer rows than folds), all folds in
   one call. A held-out row a candidate cannot predict counts with the
   nominal model's error for that row (counted in ``failures``).
3. **Selection**: the best single effect (by held-out RMS), then forward
   selection, each step taken only when the **support test** says it beats
   the previous model — **Bonferroni-corrected for the number of candidates
   compared at that step** (family ``alpha = 0.025``). The support test is
   what the noise allows (docs/model.md, "The support test"): where it is
   known (given, or estimated from repeats) a likelihood-ratio test of the
   nested models — chi-square of the drop in the position residuals' sum of
   squares over the noise variance, or F against the repeats' pure error,
   with the parameters the step adds (those at a bound not counted) as
   degrees of freedom — beside a held-out guard (the held-out RMS must
   improve); where it is only assumed, a one-sided Wilcoxon signed-rank
   test on the paired held-out gains in squared error, and BIC. Every
   decision is kept (:class:`SupportTest`). The held-out RMS of the chosen
   model comes from the same folds. BIC weights sit beside every candidate.
   **Backward elimination** then drops, one at a time, an effect of the
   chosen combination that it does not need (the combination is not
   supported over the one without it at the first step's level). Where selection
   ends with a model that is not adequate, with no model while the nominal
   one is not adequate, with a model whose first effect ties with other
   single effects, or with a model holding an effect that contains another
   library effect in the data (:func:`nested`: hole positions contain an
   actuation scale), a **search** goes beyond greedy: every pair of effects
   and every triple among the :data:`SEARCH_TOP` best single effects
   (only combinations no larger than an adequate greedy model). All are
   screened by the held-out RMS of the plant linearised at the start (same
   folds); the :data:`SEARCH_FULL` best are fitted in full, each required to
   beat the nominal model and each of its sub-combinations one effect
   smaller by the support test, Bonferroni-corrected for the whole family;
   where the greedy model holds a container, the :data:`SEARCH_TOP` best
   members built from what it contains are fitted in full too, whatever
   their screen (docs/model.md, "Nested effects").
   The adequate model with the fewest effects (then the lowest held-out
   RMS) is chosen, or the lowest held-out RMS when none is adequate;
   combinations of its size the held-out errors cannot tell from it are
   reported as ties.
4. **Verdict**: the noise comes from repeated commands approached from the
   same direction, each with a reading of its own (pure error, with a 95 %
   interval), from the user
   (``noise=``), or is assumed (10 µm per axis and reading; the diagnosis
   then says how that limits its verdict). A model is *adequate* when its
   held-out RMS is within its **adequacy bound** — the
   :data:`ADEQUACY_QUANTILE` quantile of the held-out RMS a correct model
   reaches on the same rows and folds, by a linearised parametric bootstrap
   around its fit (:class:`AdequacyBound`; docs/model.md, "The adequacy
   bound") — and a lack-of-fit test does not reject it at p = 0.01
   (chi-square against the given or assumed noise; F against pure error
   when the noise comes from repeats). ``explained`` when a chosen model beats the nominal one and is
   adequate, ``partly explained`` when it beats it but is not; otherwise
   ``no gap`` when the nominal model is adequate and ``unexplained`` when it
   is not. Rows whose residual stays beyond 5 sigma are flagged as outliers
   and the verdict is given with and without them.

A displacement row is the difference of two readings: its noise per axis is
``sqrt(2)`` times a reading's. The noise floor (the RMS |e_xy| of the noise
itself; a correct model's held-out RMS lies above it by what its fitted
parameters add, which its adequacy bound counts) is ``sqrt(2) * sigma`` for
absolute rows and ``2 sigma`` for displacement rows, ``sigma`` the noise of
one reading per axis.
"""

from __future__ import annotations

import copy
import itertools
import warnings
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import deprecated
from ..accuracy.scenarios import rotation_vectors
from ..accuracy.sensitivity import sensitivity
from ..accuracy.workspace import paper_ik_seed, singular_values
from ..inputs import CdsmDataWarning, CdsmInputError
from ..progress import Progress
from ..robot import Robot
from . import plant, stats
from .fit import Fit, fit_candidates, free_parameters
from .measurements import READING_CODES, Measurements, commanded_cables
from ..display import ShortRepr

__all__ = ["prepare", "Prepared", "diagnose", "Diagnosis", "Candidate", "NoiseEstimate", "Search", "features",
           "most_rows", "residuals", "repeat_groups", "kabsch_frame", "DEFAULT_NOISE", "FRAMES", "NEAR_FRACTION",
           "SEARCH_TOP", "SEARCH_FULL", "nested", "SupportTest", "AdequacyBound", "Verdict",
           "MAX_PARAMETER_SHARE", "ALPHA", "fold_split", "adequacy_bound", "LACK_OF_FIT_ALPHA",
           "ADEQUACY_QUANTILE", "BOOTSTRAP_DRAWS", "ESTIMATED", "neighbour_noise"]

#: Measurement noise assumed when none is given: 10 µm per axis and reading.
DEFAULT_NOISE = 10e-6
#: How absolute data relate to the robot's base frame: decided from the data
#: (``"auto"``), an instrument frame to register, or the base frame.
FRAMES = ("auto", "register", "base")
#: ``frame="auto"``: absolute data whose RMS distance from the nominal
#: predictions is at most this fraction of the arm's straight length are taken
#: in the base frame (5 %: 15 mm on the paper's arm, ten times the largest gap
#: the library's effects make at their typical size), farther ones registered.
NEAR_FRACTION = 0.05
#: The search beyond greedy tries triples among this many best single effects.
SEARCH_TOP = 5
#: The search fits in full the combinations with the lowest held-out RMS of
#: the plant linearised at the start (the same folds), this many of them.
SEARCH_FULL = 8
#: When the greedy model is adequate, only combinations whose linearised
#: held-out RMS is within this factor of their adequacy bound (that of the
#: plant linearised at the start) are fitted in full: no other could replace
#: it.
SCREEN_MARGIN = 1.25
#: The search fits in full only combinations with at most this many free
#: parameters per position component of the rows (more would interpolate
#: the data: the held-out test cannot support them).
MAX_PARAMETER_SHARE = 0.5
#: Outlier threshold, in noise standard deviations.
OUTLIER_SIGMA = 5.0
#: The most fitted rows (fits times the data set's rows) whose results a
#: diagnosis holds at once: the candidates fitted in one call of the core.
FIT_ROWS_AT_ONCE = 50_000


def most_rows(outliers: int, rows: int) -> bool:
    """Whether ``outliers`` of ``rows`` are too many to be outliers (at least
    3 and at least half the rows): the rows left are then not the data less
    a few bad readings, and the diagnosis is not rerun on them."""
    return outliers >= max(3, rows // 2)
#: Family-wise level of the one-sided selection test at each step.
ALPHA = 0.025
#: Level of the verdict's lack-of-fit test.
LACK_OF_FIT_ALPHA = 0.01
#: The adequacy bound of a model is this quantile of the held-out RMS a
#: correct model reaches on the same rows and folds (:class:`AdequacyBound`).
ADEQUACY_QUANTILE = 0.99
#: Simulated data sets of the linearised parametric bootstrap of the bound.
BOOTSTRAP_DRAWS = 400
#: Seed of the bootstrap's draws: the same draws for every model (common
#: random numbers), so a diagnosis is reproducible.
BOOTSTRAP_SEED = 20240601


@deprecated.renamed_fields(kinds="reading_codes", kind="reading")
@dataclass(repr=False)
class Prepared(ShortRepr):
    """Measurements ready for the plant, in file order.

    theta_cmd (N, n) rad: solved commands; dL (N, n) m; reading_codes (N,)
    the rows' :data:`~cdsm.plant.READING_CODES` (``kinds``: their deprecated
    name, one release); measured (N, 3) m, m, rad (NaN where not measured or not usable);
    usable (N,) rows scored; flags {row: reason} for rows left out (never
    silently); order (N,) execution order; registered: the measuring frame is
    fitted; start (P,) the parameters every fit starts from (the Kabsch
    frame when registered); frame, offset: the frame rule and the data's
    RMS distance from the nominal predictions (m)."""

    robot: Robot
    meas: Measurements
    theta_cmd: np.ndarray
    dL: np.ndarray
    reading_codes: np.ndarray
    measured: np.ndarray
    usable: np.ndarray
    flags: Dict[int, str]
    order: np.ndarray
    registered: bool = False
    start: Optional[np.ndarray] = None
    #: the frame rule asked for (one of :data:`FRAMES`)
    frame: str = "auto"
    #: RMS distance (m) of the measured positions from the nominal
    #: predictions, usable absolute rows (NaN for displacement data)
    offset: float = float("nan")
    #: the plant linearised at the fits' start (computed on first use)
    linear: Optional[tuple] = None
    #: {row: the earlier row it copies bit for bit} (file order, 0-based;
    #: :meth:`Measurements.copy_of`): counted once, never usable
    copies: Dict[int, int] = field(default_factory=dict)
    #: (N,) the rows' fold groups (rows of one label held out together), or
    #: None (rows dealt out one by one); ``group_column`` names their source
    groups: Optional[np.ndarray] = None
    group_column: Optional[str] = None

    @property
    def reading(self) -> str:
        """What the measured rows read: ``"absolute"`` or ``"displacement"``
        (:attr:`Measurements.reading`; ``kind``: its deprecated name)."""
        return self.meas.reading

    @property
    def rows(self) -> np.ndarray:
        """Indices of the usable rows (file order)."""
        return np.flatnonzero(self.usable)

    @property
    def group_count(self) -> Optional[int]:
        """The number of fold groups among the usable rows (None: rows are
        dealt out one by one)."""
        return None if self.groups is None else int(len(np.unique(self.groups[self.rows])))

    @property
    def readings(self) -> float:
        """Noise of a row per axis over the noise of one reading: 1 (absolute)
        or sqrt(2) (displacement: two readings)."""
        return float(np.sqrt(2.0)) if self.reading == "displacement" else 1.0


def kabsch_frame(predicted: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """The rigid frame that best maps ``predicted`` onto ``measured`` in
    least squares (Kabsch/Umeyama without scale): ``measured ≈ R predicted +
    t``. Planar (N, 2): ``[alpha (rad), tx, ty (m)]``; spatial (N, 3):
    ``[rotation vector (rad, 3), t (m, 3)]`` (the plants' frame blocks)."""
    p, q = np.asarray(predicted, float), np.asarray(measured, float)
    pc, qc = p - p.mean(axis=0), q - q.mean(axis=0)
    h = pc.T @ qc
    if p.shape[1] == 2:
        alpha = float(np.arctan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1]))
        c, s = np.cos(alpha), np.sin(alpha)
        t = q.mean(axis=0) - np.array([[c, -s], [s, c]]) @ p.mean(axis=0)
        return np.array([alpha, t[0], t[1]])
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    t = q.mean(axis=0) - r @ p.mean(axis=0)
    return np.concatenate([rotation_vectors(r), t])


def prepare(robot: Robot, meas: Measurements, frame: str = "auto") -> Prepared:
    """Solve each row's commanded configuration (theta_i given, or the nominal
    pose IK of (x_cmd, y_cmd, phi_cmd) from the paper's seed), check the rows
    against the nominal model and the data's scale, and set up the frame
    registration of absolute data (``frame``: one of :data:`FRAMES`; ``"auto"``
    registers data farther than :data:`NEAR_FRACTION` of the arm's straight
    length from the nominal predictions, RMS over the usable rows)."""
    if meas.n != robot.n:
        raise CdsmInputError(f"measurements are for n = {meas.n} joints, the robot has {robot.n}")
    if frame not in FRAMES:
        raise CdsmInputError(f"`frame`: expected one of {', '.join(FRAMES)}, got {frame!r}")
    flags: Dict[int, str] = {}
    N = len(meas)
    w, k = plant.width(robot), plant.dims(robot)
    if meas.theta is not None:
        theta = np.array(meas.theta, dtype=float)
        ok = np.ones(N, bool)
    else:
        sol = robot.ik(meas.pose_cmd, seed=paper_ik_seed(robot.n))
        theta = np.array(sol.theta, dtype=float)
        ok = np.asarray(sol.converged, bool)
        for i in np.flatnonzero(~ok):
            flags[int(i)] = f"commanded pose not reachable by the nominal model (IK residual {sol.residual[i]:.2e})"
        theta[~ok] = 0.0
    codes = meas.reading_codes()
    order = meas.order
    nominal = np.zeros(plant.size(robot))
    obs, conv = plant.predict(robot, nominal, theta[order], meas.dL[order], codes[order])
    settled, _ = plant.settle(robot, nominal, theta[order], meas.dL[order], codes[order])
    pred = np.empty_like(obs)
    pred[order] = obs
    settles = np.empty(N, bool)
    settles[order] = conv
    observed = meas.observed
    for i in np.flatnonzero(ok & ~settles):
        flags[int(i)] = "the nominal model cannot realise the commanded cable lengths"
    # the taut-cable model holds only where every upper cable stays taut under
    # the robot's loads (lower tensions, gravity), at the command and after dL
    reached = np.zeros_like(theta)
    reached[order] = np.where(np.isfinite(settled), settled, 0.0)
    # an elastic arm's statics carries slack cables (docs/model.md, "Elastic arms"): nothing to check
    taut = np.ones(N, bool) if robot.is_elastic else robot.feasible(theta) & robot.feasible(reached)
    for i in np.flatnonzero(ok & settles & observed & ~taut):
        flags[int(i)] = ("the nominal model needs a slack upper cable here under the robot's loads (lower "
                         "tensions, gravity): a taut-cable model cannot predict this row")
    usable = ok & settles & observed & taut
    # a row that copies an earlier one bit for bit is that one observation
    # again: counted once (not as a row, a held-out fold or a repeat)
    copy_of = meas.copy_of()
    copies = {int(i): int(copy_of[i]) for i in np.flatnonzero(copy_of >= 0)}
    for i, j in copies.items():
        if usable[i]:
            flags[i] = f"a copy of an earlier row, bit for bit (of row {j + 1}: the same command and reading)"
    usable &= copy_of < 0
    if copies:
        shown = sorted(copies)[:10]
        warnings.warn(f"{meas.source or 'measurements'}: {len(copies)} row(s) copy an earlier row bit for bit, the "
                      f"same command and the same reading (row(s) {', '.join(str(i + 1) for i in shown)}"
                      f"{', ...' if len(copies) > 10 else ''}, of row(s) "
                      f"{', '.join(str(j + 1) for j in sorted({copies[i] for i in shown}))}): one observation "
                      "written more than once, counted once — not as rows, held-out folds or repeats (a repeat "
                      "of a command has a reading of its own)", CdsmDataWarning, stacklevel=3)
    measured = np.full((N, w), np.nan)
    measured[:, :k] = meas.measured
    if meas.measured_phi is not None:
        measured[:, 2] = meas.measured_phi
    if meas.measured_rot is not None:
        measured[:, 3:6] = meas.measured_rot
    measured[~usable] = np.nan
    if usable.sum() >= 2:
        _check_scale(meas, pred[usable, :k], measured[usable, :k])
    offset = float("nan")
    if meas.reading == "absolute" and usable.any():
        offset = float(np.sqrt(np.mean(np.sum((pred[usable, :k] - measured[usable, :k]) ** 2, axis=1))))
    near = offset <= NEAR_FRACTION * robot.straight_length
    registered = meas.reading == "absolute" and (frame == "register" or (frame == "auto" and not near))
    start = nominal.copy()
    if registered and usable.sum() >= 2:
        start[plant.effect_indices(robot, "frame_misalignment")] = kabsch_frame(pred[usable, :k],
                                                                                measured[usable, :k])
    return Prepared(robot, meas, theta, np.asarray(meas.dL, float), codes, measured, usable, flags, order,
                    registered, start, frame, offset, copies=copies)


def _linearised(prep: Prepared) -> Tuple[np.ndarray, np.ndarray, np.ndarray, Dict[int, int]]:
    """The plant linearised at the fits' start on the usable rows (cached):
    the rows (file order) whose Jacobian is finite, their position
    Jacobian (R, d, P) with respect to every parameter of the library and
    the frame, their residuals measured - predicted (R, d), and each flat
    index's column."""
    if prep.linear is not None:
        return prep.linear
    robot = prep.robot
    free = np.concatenate([plant.effect_indices(robot, "frame_misalignment")]
                          + [plant.effect_indices(robot, e) for e in plant.effects_of(robot)
                             if e != "frame_misalignment"])
    start = prep.start if prep.registered else np.zeros(plant.size(robot))
    o, rows, k = prep.order, prep.rows, plant.dims(robot)
    obs, conv, jac = plant.linearise(robot, start, free, prep.theta_cmd[o], prep.dL[o], prep.reading_codes[o])
    J, y = np.empty_like(jac), np.empty_like(obs)
    J[o], y[o] = jac, obs
    ok = np.zeros(len(prep.theta_cmd), bool)
    ok[o] = conv
    r = rows[ok[rows]]
    J, res = J[r, :k, :], prep.measured[r, :k] - y[r, :k]
    good = np.isfinite(J).all(axis=(1, 2)) & np.isfinite(res).all(axis=1)
    prep.linear = (r[good], J[good], res[good], {int(i): j for j, i in enumerate(free)})
    return prep.linear


def _too_few_rows(robot: Robot, meas: Measurements, prep: Prepared) -> str:
    """Why a data set has fewer than 3 usable rows: the count of each reason,
    and a hint at the unit when the commanded poses lie far past the arm's
    reach (millimetres for metres)."""
    why: Dict[str, int] = {}
    for reason in prep.flags.values():
        cause = reason.split(" (", 1)[0]  # one count per cause, without the row's numbers
        why[cause] = why.get(cause, 0) + 1
    unmeasured = int((~meas.observed).sum())
    if unmeasured:
        why["a move that was not measured"] = unmeasured
    parts = [f"{count} row(s): {cause}" for cause, count in sorted(why.items(), key=lambda t: -t[1])]
    msg = (f"{meas.source or 'measurements'}: only {int(prep.usable.sum())} of {len(meas)} rows are usable; "
           f"the diagnosis needs at least 3" + (" (" + "; ".join(parts) + ")" if parts else ""))
    if meas.pose_cmd is not None:
        far = float(np.abs(meas.pose_cmd[:, :2]).max()) / robot.straight_length
        if far > 10.0:
            msg += (f". The commanded poses lie up to {far:.0f} times farther than the arm reaches: are they "
                    "in mm? cdsm reads SI units: metres (divide by 1000)")
    return msg


def _check_scale(meas: Measurements, predicted: np.ndarray, measured: np.ndarray) -> None:
    """Refuse data whose spread is about a thousand times the model's (mm for m)."""
    if meas.reading == "absolute":
        sp = np.sqrt(((predicted - predicted.mean(axis=0)) ** 2).sum(axis=1).mean())
        sm = np.sqrt(((measured - measured.mean(axis=0)) ** 2).sum(axis=1).mean())
    else:
        sp = np.sqrt((predicted ** 2).sum(axis=1).mean())
        sm = np.sqrt((measured ** 2).sum(axis=1).mean())
    if sp > 0 and sm > 30.0 * sp:
        raise CdsmInputError(f"{meas.source or 'measurements'}: the measured positions spread {sm / sp:.0f} times "
                             "wider than the robot's predictions for the same commands; are they in mm? cdsm "
                             "reads SI units: metres (divide by 1000)")
    if sm > 0 and sp > 30.0 * sm:
        raise CdsmInputError(f"{meas.source or 'measurements'}: the measured positions spread {sp / sm:.0f} times "
                             "narrower than the robot's predictions for the same commands; are they in km, or "
                             "is the robot file in mm? cdsm reads SI units: metres")


# ---------------------------------------------------------------------------
# noise from repeats
# ---------------------------------------------------------------------------
def repeat_groups(prep: Prepared, decimals: int = 9) -> List[np.ndarray]:
    """Groups (lists of usable rows, >= 2 each) that repeat the same command —
    same commanded angles and dL to ``decimals`` (rad, m) — approached from
    the same direction (the sign of each upper cable's last change of
    command before the row), so backlash cannot tell them apart."""
    robot = prep.robot
    order = prep.order
    base = plant.command_lengths(robot, prep.theta_cmd[order])
    cmd = base + prep.dL[order]
    state = plant.command_lengths(robot, np.zeros(robot.n))
    direction = np.zeros(state.shape[-1])
    keys: Dict[tuple, List[int]] = {}
    for j, i in enumerate(order):
        first = base[j] if prep.reading_codes[i] == READING_CODES["displacement"] else cmd[j]
        step = first - state
        direction = np.where(np.abs(step) > 1e-12, np.sign(step), direction)
        if prep.usable[i]:
            key = (tuple(np.round(prep.theta_cmd[i], decimals)), tuple(np.round(prep.dL[i], decimals)),
                   tuple(direction.astype(int)))
            keys.setdefault(key, []).append(int(i))
        state = cmd[j]
    return [np.array(v) for v in keys.values() if len(v) >= 2]


#: The noise sources that estimate the noise from the data, with degrees of
#: freedom: the support and lack-of-fit tests are F tests against them.
ESTIMATED = ("repeats", "neighbours")


@dataclass(repr=False)
class NoiseEstimate(ShortRepr):
    """The noise of one reading per axis (m), where it came from
    (``"repeats"``, ``"neighbours"``, ``"given"``, ``"assumed"``), its 95 %
    interval (estimated), and the pure error the estimate gives (sum of
    squares m², degrees of freedom; ``"neighbours"``: the variance of a row
    per axis times its effective degrees of freedom, see
    :func:`neighbour_noise`)."""

    sigma: float
    source: str
    ci: Optional[tuple] = None
    ss_pure: float = 0.0
    dof_pure: int = 0
    groups: int = 0
    #: rows (file order, 0-based) that copy an earlier row bit for bit
    #: (:attr:`Prepared.copies`): copies, not repeats
    duplicates: Tuple[int, ...] = ()


def neighbour_noise(prep: Prepared) -> Tuple[float, float, int]:
    """The noise of a row per axis estimated from neighbouring rows, for
    data that sample continuous motions (:attr:`Measurements.sampled`): the
    difference-based estimator of Gasser, Sroka and Jennen-Steinmetz
    (Biometrika 73, 1986) on the residuals ``e`` of the model the fits start
    from, over every three consecutive usable rows of one fold group in
    execution order: pseudo-residuals ``(e[i-1] - 2 e[i] + e[i+1]) / sqrt(6)``
    per position axis, whose mean square is the noise variance when the
    model's error changes smoothly from row to row. Returns the variance
    (m²), the pseudo-residuals' sum of squares (m²) and their effective
    degrees of freedom: ``18 t k / 35`` for Gaussian noise (``t`` triples,
    ``k`` axes: the pseudo-residuals of overlapping triples are correlated,
    ``Var = (35/18) 2 sigma^4 / t`` per axis), times ``2 / (kappa - 1)`` for
    their kurtosis ``kappa`` where it exceeds a Gaussian's 3 (a few jumps
    make the estimate that much less certain), never more than the Gaussian
    value; ``(nan, 0, 0)`` without triples. What changes between
    neighbouring rows faster than the motion (jitter, a jump at a reversal)
    counts as noise; what neighbours share (drift, the history of a
    pattern) does not: docs/model.md, "Rows, repeats and copies"."""
    robot = prep.robot
    k = plant.dims(robot)
    o = prep.order
    obs, _ = plant.predict(robot, prep.start, prep.theta_cmd[o], prep.dL[o], prep.reading_codes[o])
    e = obs[:, :k] - prep.measured[o, :k]
    group = (prep.groups if prep.groups is not None else
             np.asarray(prep.meas.labels[prep.meas.fold_groups], str) if prep.meas.fold_groups else
             np.zeros(len(o), str))[o]
    ok = prep.usable[o] & np.isfinite(e).all(axis=1)
    mid = np.flatnonzero(ok[1:-1] & ok[:-2] & ok[2:] & (group[1:-1] == group[:-2]) & (group[1:-1] == group[2:])) + 1
    if not len(mid):
        return float("nan"), 0.0, 0
    pseudo = (e[mid - 1] - 2.0 * e[mid] + e[mid + 1]) / np.sqrt(6.0)
    ss = float(np.sum(pseudo ** 2))
    var = ss / pseudo.size
    kurtosis = float(np.mean(pseudo ** 4)) / var ** 2 if var > 0 else 3.0
    nu = 18.0 * pseudo.size / 35.0 * min(1.0, 2.0 / max(kurtosis - 1.0, 1e-300))
    return var, ss, max(int(round(nu)), 1)


def _noise(prep: Prepared, given: Optional[float]) -> NoiseEstimate:
    k = plant.dims(prep.robot)
    # copies are not usable (prepare): every group holds readings of their own
    groups = repeat_groups(prep)
    ss, dof = 0.0, 0
    for g in groups:
        y = prep.measured[g, :k]
        ss += float(((y - y.mean(axis=0)) ** 2).sum())
        dof += k * (len(g) - 1)
    dup = tuple(sorted(prep.copies))
    if given is not None:
        return NoiseEstimate(float(given), "given", None, ss, dof, len(groups), dup)
    if dof >= 2 and ss > 0:
        r2 = prep.readings ** 2
        sigma = float(np.sqrt(ss / dof / r2))
        ci = (float(np.sqrt(ss / stats.chi2_ppf(0.975, dof) / r2)),
              float(np.sqrt(ss / stats.chi2_ppf(0.025, dof) / r2)))
        return NoiseEstimate(sigma, "repeats", ci, ss, dof, len(groups), dup)
    if prep.meas.sampled:
        var, _, nu = neighbour_noise(prep)
        if nu >= 2 and var > 0:
            r2 = prep.readings ** 2
            sigma = float(np.sqrt(var / r2))
            ci = (float(np.sqrt(var * nu / stats.chi2_ppf(0.975, nu) / r2)),
                  float(np.sqrt(var * nu / stats.chi2_ppf(0.025, nu) / r2)))
            return NoiseEstimate(sigma, "neighbours", ci, var * nu, nu, 0, dup)
    return NoiseEstimate(DEFAULT_NOISE, "assumed", None, ss, dof, len(groups), dup)


# ---------------------------------------------------------------------------
# candidates
# ---------------------------------------------------------------------------
@dataclass(repr=False)
class Candidate(ShortRepr):
    """One effect or combination: its fit on all usable rows, its held-out
    position errors |e_xy| (m, one per usable row; a row the candidate cannot
    predict counts with the nominal model's error), how many such failures
    there were, what the fit fitted and the folds."""

    name: str
    effects: List[str]
    fit: Fit
    heldout: np.ndarray
    failures: int = 0
    weight: float = float("nan")
    #: the effects the fit fitted (``effects``, and the frame when registered)
    fitted: List[str] = field(default_factory=list)
    #: the held-out rows of each fold (file order, 0-based)
    folds: List[np.ndarray] = field(default_factory=list)

    @property
    def heldout_rms(self) -> float:
        return float(np.sqrt(np.nanmean(self.heldout ** 2))) if len(self.heldout) else float("nan")


def fold_split(n_rows: int, k: int, seed: int = 0, groups: Optional[Sequence] = None) -> List[np.ndarray]:
    """The ``k`` held-out folds of ``n_rows`` rows the diagnosis scores on:
    indices into the rows, each sorted (a seeded permutation dealt out).
    With ``groups`` ((n_rows,) labels) whole groups are dealt out instead of
    rows — rows of one label are held out together (neighbouring keypoints
    of one motion pattern are not independent) — and ``k`` is at most the
    number of groups."""
    if groups is None:
        order = np.random.default_rng(seed).permutation(n_rows)
        return [np.sort(order[i::k]) for i in range(k)]
    labels = np.asarray(groups)
    if labels.shape != (n_rows,):
        raise CdsmInputError(f"`groups`: expected {n_rows} labels, got shape {labels.shape}")
    names, first, code = np.unique(labels, return_index=True, return_inverse=True)
    rank = np.argsort(np.argsort(first))  # groups in order of first appearance
    order = np.random.default_rng(seed).permutation(len(names))
    fold_of_group = np.empty(len(names), int)
    fold_of_group[order] = np.arange(len(names)) % min(k, len(names))
    fold = fold_of_group[rank[code]]
    return [np.flatnonzero(fold == i) for i in range(min(k, len(names)))]


def _fitted(prep: Prepared, effects: Sequence[str]) -> List[str]:
    """The effects a candidate fits: its own, and the frame when the data are registered."""
    return list(effects) + (["frame_misalignment"] if prep.registered and "frame_misalignment" not in effects
                            else [])


class _Scorer:
    """Fits and cross-validates candidates on one set of rows; ``bar``: a
    progress line counting fold fits. A candidate asked for again with its
    fitted effects in the same order (a forward-selection trial that
    backward elimination or the search asks for) is not fitted again: its
    fits would be the same bit for bit (a fit depends on nothing but its
    effects, rows and start); the answer is a copy of the first, where it
    was scored against the same base error (a held-out error a fold could
    not predict is the base model's)."""

    def __init__(self, prep: Prepared, rows: np.ndarray, folds: int, base_error: Optional[np.ndarray] = None,
                 bar: Optional[Progress] = None):
        self.prep = prep
        self.bar = bar
        self.rows = np.asarray(rows, int)
        groups = None if prep.groups is None else prep.groups[self.rows]
        self.tests = [self.rows[t] for t in fold_split(len(self.rows), min(folds, len(self.rows)), groups=groups)]
        k = self.k = len(self.tests)
        N = len(prep.theta_cmd)
        self.scored = np.zeros((k + 1, N), bool)
        self.scored[0, self.rows] = True
        for f, t in enumerate(self.tests):
            self.scored[f + 1, self.rows] = True
            self.scored[f + 1, t] = False
        self.base_error = base_error
        # fitted effects in order -> (the base error it was scored with, the
        # candidate fitted first): a hit needs the same base error object
        self.done: Dict[Tuple[str, ...], Tuple[Optional[np.ndarray], Candidate]] = {}

    def evaluate(self, name: str, effects: Sequence[str]) -> Candidate:
        """The candidate of ``effects`` (:meth:`evaluate_all` of one)."""
        return self.evaluate_all([(name, effects)])[0]

    def evaluate_all(self, named: Sequence[Tuple[str, Sequence[str]]]) -> List[Candidate]:
        """The candidates ``(name, effects)``: each one's fit on every row and
        one fit per fold, many candidates' fits in one call of the core (its
        worker threads take the fits one by one, so none waits for another
        candidate's slowest fold), at most :data:`FIT_ROWS_AT_ONCE` fitted
        rows' results held at once. Every fold starts from the same start
        as the fit on every row: a fold started from that fit would start at
        a point its held-out rows pulled on, and stop (an elastic fit stops
        within a tenth of a standard error) nearer to it than to its own
        minimum."""
        prep = self.prep
        fitted = [_fitted(prep, effects) for _, effects in named]
        key = [tuple(f) for f in fitted]
        hit = [key[c] in self.done and self.done[key[c]][0] is self.base_error for c in range(len(named))]
        todo = [c for c in range(len(named)) if not hit[c]]
        start = prep.start if prep.registered else np.zeros(plant.size(prep.robot))
        per = len(self.scored)
        # whole candidates per call, as many as the budget of rows allows (one at least)
        step = max(1, FIT_ROWS_AT_ONCE // max(per * len(prep.theta_cmd), 1))
        out: Dict[int, Candidate] = {c: self._again(named[c][0], named[c][1], self.done[key[c]][1])
                                     for c in range(len(named)) if hit[c]}
        for first in range(0, len(todo), step):
            part = todo[first:first + step]
            # the folds' fits serve their predictions only: no uncertainty
            fits = fit_candidates(prep, [fitted[c] for c in part], np.tile(self.scored, (len(part), 1)),
                                  np.repeat(np.arange(len(part)), per), start,
                                  uncertainty=np.tile(np.arange(per) == 0, len(part)))
            for j, c in enumerate(part):
                out[c] = self._candidate(named[c][0], list(named[c][1]), fitted[c], fits[j * per:(j + 1) * per])
                self.done[key[c]] = (self.base_error, out[c])
            if self.bar is not None:
                self.bar.update(len(fits))
        return [out[c] for c in range(len(named))]

    @staticmethod
    def _again(name: str, effects: Sequence[str], first: Candidate) -> Candidate:
        """The candidate ``name`` of ``effects`` from the same fits as
        ``first`` (a new candidate, as a fit again would give)."""
        fit_ = copy.deepcopy(first.fit)
        fit_.effects = list(effects)
        return Candidate(name, list(effects), fit_, first.heldout.copy(), first.failures,
                         fitted=list(first.fitted), folds=[t.copy() for t in first.folds])

    def _candidate(self, name: str, effects: List[str], fitted: List[str], fits: List[Fit]) -> Candidate:
        """The candidate from its fit on every row and its folds' fits."""
        prep = self.prep
        k = plant.dims(prep.robot)
        held = np.full(len(prep.theta_cmd), np.nan)
        full = fits[0]
        for t, fit_ in zip(self.tests, fits[1:]):
            if fit_.prediction is not None:
                held[t] = np.linalg.norm(fit_.prediction[t, :k] - prep.measured[t, :k], axis=1)
        held = held[self.rows]
        fail = ~np.isfinite(held)
        if self.base_error is not None:
            held[fail] = self.base_error[fail]
        full.effects = list(effects)
        return Candidate(name, list(effects), full, held, int(fail.sum()), fitted=list(fitted),
                         folds=[np.asarray(t, int) for t in self.tests])


@dataclass(repr=False)
class SupportTest(ShortRepr):
    """One support decision: whether the model ``big`` is supported over
    the nested smaller model ``small`` (``step``: where the diagnosis asked)
    at the level ``alpha`` (docs/model.md, "The support test"). A tie test
    is kept the same way (:attr:`nested` false): two models not nested,
    ``big`` beating ``small`` by the held-out signed-rank test whatever the
    noise, a tie where it does not.

    ``test``: ``"chi2"``, the likelihood ratio against the given noise,
    ``(RSS_small - RSS_big) / (r sigma)^2`` against chi-square(``dof``);
    ``"F"``, against the pure error of repeats, F(``dof``); both with the
    position residuals of the fits on all rows (RSS, m²) and ``dof`` the
    free parameters ``big`` adds (those at a bound not counted).
    ``"signed-rank"`` where the noise is only assumed: the one-sided
    Wilcoxon signed-rank test on the paired held-out gains in squared error
    (statistic W+, ``dof``: the pairs). ``guard``: what must agree besides
    the test — the held-out RMS improves (likelihood-ratio tests) or BIC
    is lower (signed-rank) — and ``guard_passed`` whether it does."""

    big: str
    small: str
    step: str
    test: str
    statistic: float
    dof: Tuple[int, ...]
    p_value: float
    alpha: float
    guard: str
    guard_passed: bool
    heldout_big: float
    heldout_small: float

    @property
    def supported(self) -> bool:
        """Nested: ``big`` is supported over ``small``; not nested: ``big``
        beats ``small`` (no tie)."""
        return bool(self.p_value < self.alpha and self.guard_passed)

    @property
    def nested(self) -> bool:
        """A support test of nested models (else a tie test of two models
        that are not nested: :meth:`_Judge.differs`)."""
        return self.guard != NOT_NESTED

    def to_json(self) -> dict:
        return dict(big=self.big, small=self.small, step=self.step, test=self.test, statistic=self.statistic,
                    dof=list(self.dof), p_value=self.p_value, alpha=self.alpha, guard=self.guard,
                    guard_passed=self.guard_passed, heldout_rms_big_m=self.heldout_big,
                    heldout_rms_small_m=self.heldout_small, supported=self.supported, nested=self.nested)


#: The guard of a :class:`SupportTest` of two models that are not nested (a tie test).
NOT_NESTED = "none (not nested: a tie test)"

#: How an :class:`AdequacyBound` is obtained (the JSON's words).
BOUND_METHOD = ("linearised parametric bootstrap: data sets simulated from the fitted model (its Jacobian at the "
                "fit) plus Gaussian noise of the noise estimate at the same rows, each refitted on the same "
                "folds (a Gaussian prior of one typical size per parameter, where the linearisation ends), "
                "the held-out RMS's upper quantile")


@dataclass(repr=False)
class AdequacyBound(ShortRepr):
    """The adequacy bound of one model on its rows and folds: ``bound`` (m),
    the ``quantile`` of the held-out RMS a correct model reaches there, and
    its ``median`` (m), by a linearised parametric bootstrap around the
    model's fit (:data:`BOUND_METHOD`; ``draws`` simulated data sets,
    ``parameters`` linearised — those at a bound held there); ``floor`` (m)
    the noise floor; ``noise`` the noise's source (from ``"repeats"`` the
    bootstrap also draws the noise estimate's own scatter)."""

    bound: float
    median: float
    floor: float
    parameters: int
    draws: int
    quantile: float
    noise: str

    @property
    def factor(self) -> float:
        """The bound over the noise floor."""
        return self.bound / self.floor if self.floor > 0 else float("nan")

    def to_json(self) -> dict:
        return dict(bound_m=self.bound, median_m=self.median, floor_m=self.floor, factor=self.factor,
                    quantile=self.quantile, draws=self.draws, parameters=self.parameters,
                    noise_source=self.noise, method=BOUND_METHOD)


@dataclass(repr=False)
class Verdict(ShortRepr):
    """The answer for one set of rows: the verdict, whether the nominal and
    the final model are adequate (held-out RMS within the model's
    :class:`AdequacyBound` and the lack-of-fit test not rejected at
    :data:`LACK_OF_FIT_ALPHA`), the lack-of-fit test of the final model
    (``test``: ``"chi2"`` or ``"F"``, statistic, degrees of freedom,
    p-value), the noise at which the final model would be adequate, and the
    two bounds used."""

    verdict: str
    nominal_adequate: bool
    final_adequate: bool
    test: str
    statistic: float
    dof: tuple
    p_value: float
    noise_needed: float
    bound: Optional[AdequacyBound] = None
    nominal_bound: Optional[AdequacyBound] = None


@dataclass(repr=False)
class Search(ShortRepr):
    """The search beyond greedy forward selection: why it ran, the family
    it searched (every pair, triples among the best single effects), the
    per-comparison level, the linearised held-out RMS (m) of every member of
    the family (the screen), the combinations fitted in full (``tried``)
    with whether each is supported
    (beats the nominal model and each sub-combination one effect smaller,
    by the corrected test and BIC) and adequate, the one picked, whether it
    replaced the greedy choice, and the combinations tied with it."""

    reason: str
    family: int
    alpha: float
    screened: Dict[str, float]
    tried: List[Candidate]
    supported: List[str]
    adequate: List[str]
    picked: Optional[str]
    replaced: bool
    ties: List[str]
    #: {name: adequacy bound (m)} of the members whose adequacy was judged
    bounds: Dict[str, float] = field(default_factory=dict)
    #: {name: adequacy bound (m) of the plant linearised at the start}: the
    #: screen's margin, where the greedy model is adequate (NaN elsewhere)
    screen_bounds: Dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict:
        return dict(reason=self.reason, family=self.family, alpha=self.alpha, picked=self.picked,
                    replaced_greedy=self.replaced, ties=self.ties, linearised_heldout_rms_m=self.screened,
                    linearised_adequacy_bound_m={k: (v if np.isfinite(v) else None)
                                                 for k, v in self.screen_bounds.items()},
                    tried=[dict(name=c.name, heldout_rms_m=c.heldout_rms, bic=c.fit.bic,
                                supported=c.name in self.supported, adequate=c.name in self.adequate,
                                adequacy_bound_m=self.bounds.get(c.name))
                           for c in self.tried])


@dataclass(repr=False)
class Diagnosis(ShortRepr):
    """The answer: ``best`` (an effect, a '+'-joined combination, or 'none'),
    the ``verdict``, the baseline, every candidate (best first), the chosen
    model, the noise, per-row residuals and features, and identifiability
    notes. ``baseline`` is the nominal model (in the registered frame when
    the data are registered); ``identity`` the chosen model (or the nominal
    one) in the identity frame (registered data only)."""

    best: str
    baseline: Candidate
    singles: List[Candidate]
    chosen: Optional[Candidate]
    steps: List[Candidate]
    noise_estimate: NoiseEstimate
    prep: Prepared
    verdict_detail: Optional[Verdict] = None
    identity: Optional[Candidate] = None
    registration_named: bool = False
    outliers: List[int] = field(default_factory=list)
    verdict_without_outliers: Optional[Verdict] = None
    #: why the verdict without the outliers was not given (None: it was, or
    #: there are none): the outliers are most of the rows (:func:`most_rows`)
    without_outliers_skipped: Optional[str] = None
    features: Dict[str, np.ndarray] = field(default_factory=dict)
    feature_correlation: Dict[str, float] = field(default_factory=dict)
    ties: List[str] = field(default_factory=list)
    correlated: List[str] = field(default_factory=list)
    unidentifiable: List[str] = field(default_factory=list)
    folds: int = 10
    alphas: List[float] = field(default_factory=list)
    search: Optional[Search] = None
    #: effects forward selection took and backward elimination dropped
    dropped: List[str] = field(default_factory=list)
    #: every support decision, in the order the diagnosis asked
    support: List[SupportTest] = field(default_factory=list)

    def __repr__(self) -> str:
        return (f"Diagnosis(verdict={self.verdict!r}, best={self.best!r}, held-out RMS "
                f"{self.baseline.heldout_rms * 1e6:.1f} -> {self.final().heldout_rms * 1e6:.1f} um, noise floor "
                f"{self.noise_floor * 1e6:.1f} um, {int(self.prep.usable.sum())} usable rows of {len(self.prep.meas)})")

    @property
    def noise(self) -> float:
        """The noise of one reading per axis (m)."""
        return self.noise_estimate.sigma

    @property
    def noise_floor(self) -> float:
        """The RMS position error of the noise alone (m): ``sqrt(2) * sigma``
        per row's reading count (see the module doc; spatial arms:
        ``sqrt(3)``, three position components). A correct model's held-out
        RMS lies above it: :class:`AdequacyBound`."""
        return float(np.sqrt(plant.dims(self.prep.robot)) * self.prep.readings * self.noise)

    @property
    def verdict(self) -> str:
        return self.verdict_detail.verdict if self.verdict_detail else "unexplained"

    @property
    def explained(self) -> bool:
        """The verdict is ``"no gap"`` or ``"explained"``."""
        return self.verdict in ("no gap", "explained")

    def final(self) -> Candidate:
        return self.chosen or self.baseline

    @property
    def support_rule(self) -> str:
        """The support test these data allow (docs/model.md, "The support test")."""
        return {"given": "likelihood ratio: chi-square against the given noise, beside a held-out guard (the "
                         "held-out RMS must improve)",
                "repeats": "likelihood ratio: F against the pure error of the repeats, beside a held-out guard "
                           "(the held-out RMS must improve)",
                "neighbours": "likelihood ratio: F against the noise of neighbouring rows, beside a held-out "
                              "guard (the held-out RMS must improve)"}.get(
            self.noise_estimate.source, "one-sided Wilcoxon signed-rank test on the paired held-out gains in "
                                        "squared error, and BIC (the noise is only assumed)")

    @property
    def support_limits(self) -> Optional[str]:
        """How an assumed noise, or one estimated from neighbouring rows,
        limits the verdict (None when the noise is given or estimated from
        repeats)."""
        if self.noise_estimate.source == "neighbours":
            return (f"The noise ({self.noise * 1e6:.1f} µm per axis and reading) is estimated from neighbouring "
                    "rows of each motion (the data hold no repeated command): it holds what changes from one "
                    "row to the next (the tracker's jitter, a jump at a reversal) and not what neighbours share "
                    "(drift over minutes, the history of a pattern). With one repetition the data cannot tell "
                    "such a shared error from a missing effect: 'not adequate' may be the robot not repeating "
                    "itself, and a support test against this noise counts a history or drift the model lacks "
                    "as signal. Repeats of the patterns (at the start and the end of a session) would "
                    "separate them.")
        if self.noise_estimate.source != "assumed":
            return None
        v = self.verdict_detail
        need = (f" The final model would be adequate at a noise of {v.noise_needed * 1e6:.1f} µm or more."
                if v is not None and not v.final_adequate else "")
        return (f"The noise is assumed ({self.noise * 1e6:.1f} µm per axis and reading), neither given nor "
                "estimated from repeated commands. The likelihood-ratio support test needs a known noise, so "
                "effects are supported by the held-out signed-rank test and BIC, which need none but have "
                "little power with few rows (at 15 rows an effect must gain on about 14 of them). Adequacy, "
                "and with it the verdicts 'explained' and 'no gap', is judged against the assumed noise: it "
                "holds if the real noise is at least that large, and a smaller real noise could make an "
                "adequate model inadequate." + need)

    def to_json(self) -> dict:
        robot = self.prep.robot

        def cand(c: Candidate) -> dict:
            return dict(name=c.name, params=c.fit.params_by_effect(robot),
                        std=c.fit.std_by_effect(robot), heldout_rms_m=c.heldout_rms,
                        fit_rms_m=c.fit.rms, aic=c.fit.aic, bic=c.fit.bic, bic_weight=c.weight,
                        failures=c.failures, converged=bool(c.fit.converged))

        def verdict(v: Optional[Verdict]):
            if v is None:
                return None
            return dict(verdict=v.verdict, nominal_adequate=v.nominal_adequate,
                        final_adequate=v.final_adequate,
                        lack_of_fit=dict(test=v.test, statistic=v.statistic, dof=list(v.dof), p_value=v.p_value,
                                         alpha=LACK_OF_FIT_ALPHA),
                        adequacy_bound_m=v.bound.bound if v.bound else None,
                        nominal_adequacy_bound_m=v.nominal_bound.bound if v.nominal_bound else None,
                        adequacy_bound=v.bound.to_json() if v.bound else None,
                        nominal_adequacy_bound=v.nominal_bound.to_json() if v.nominal_bound else None,
                        noise_needed_m=v.noise_needed)

        ne = self.noise_estimate
        prep = self.prep
        reg = None
        if prep.reading == "absolute":
            reg = dict(rule=prep.frame, fitted=bool(prep.registered), named=self.registration_named,
                       offset_m=prep.offset, near_m=NEAR_FRACTION * robot.straight_length)
        if prep.registered:
            ind = plant.effect_indices(robot, "frame_misalignment")
            reg.update(frame=self.final().fit.p[ind].tolist(), start=prep.start[ind].tolist(),
                       identity_heldout_rms_m=self.identity.heldout_rms if self.identity else None,
                       registered_heldout_rms_m=self.final().heldout_rms)
        out = dict(
            best=self.best, verdict=self.verdict, explained=self.explained,
            baseline=dict(heldout_rms_m=self.baseline.heldout_rms, aic=self.baseline.fit.aic,
                          bic=self.baseline.fit.bic, bic_weight=self.baseline.weight),
            effects=[cand(c) for c in self.singles],
            selection=[cand(c) for c in self.steps],
            chosen=cand(self.chosen) if self.chosen else None,
            noise_m=self.noise, noise_source=ne.source,
            noise_ci_m=list(ne.ci) if ne.ci else None,
            repeat_groups=ne.groups, duplicate_rows=[i + 1 for i in ne.duplicates],
            noise_floor_m=self.noise_floor,
            lack_of_fit=verdict(self.verdict_detail)["lack_of_fit"] if self.verdict_detail else None,
            verdict_detail=verdict(self.verdict_detail),
            outliers=[int(i) + 1 for i in self.outliers],
            verdict_without_outliers=verdict(self.verdict_without_outliers),
            registration=reg,
            search=self.search.to_json() if self.search else None, dropped=self.dropped,
            kind=self.prep.reading, rows=int(len(self.prep.meas)), rows_used=int(self.prep.usable.sum()),
            flagged_rows={str(k + 1): v for k, v in self.prep.flags.items()},
            failures={c.name: c.failures for c in [self.baseline] + self.singles + self.steps if c.failures},
            ties=self.ties, correlated_parameters=self.correlated,
            unidentifiable_parameters=self.unidentifiable,
            feature_correlation=self.feature_correlation, folds=self.folds,
            folds_by=(dict(column=prep.group_column, groups=prep.group_count) if prep.groups is not None else None),
            selection_test=dict(kind=self.support_rule + f", Bonferroni-corrected for the candidates compared "
                                                         f"at each step (family alpha {ALPHA})",
                                alpha=self.alphas),
            support=dict(rule=self.support_rule, noise_source=ne.source, limits=self.support_limits,
                         tests=[t.to_json() for t in self.support]),
            adequacy=dict(rule=f"held-out RMS within the model's adequacy bound (the {ADEQUACY_QUANTILE:g} "
                               "quantile of a correct model's held-out RMS on these rows and folds) and the "
                               f"lack-of-fit test not rejected at {LACK_OF_FIT_ALPHA:g}",
                          method=BOUND_METHOD, quantile=ADEQUACY_QUANTILE, draws=BOOTSTRAP_DRAWS,
                          lack_of_fit_alpha=LACK_OF_FIT_ALPHA,
                          final=(self.verdict_detail.bound.to_json() if self.verdict_detail
                                 and self.verdict_detail.bound else None),
                          nominal=(self.verdict_detail.nominal_bound.to_json() if self.verdict_detail
                                   and self.verdict_detail.nominal_bound else None)),
        )
        if self.without_outliers_skipped is not None:
            out["without_outliers_skipped"] = self.without_outliers_skipped
        return out


# ---------------------------------------------------------------------------
# features
# ---------------------------------------------------------------------------
def features(prep: Prepared) -> Dict[str, np.ndarray]:
    """Configuration features of every row (N,): closeness to a singular state
    (sigma_min/sigma_max of the pose Jacobian), the largest |joint angle| and
    |theta_2| (rad), the smallest upper tension (N), the tip sensitivity to the
    upper cables (m/m), the cable that carries dL, and X, Y (m)."""
    robot, th = prep.robot, prep.theta_cmd
    if robot.is_elastic:
        return _elastic_features(prep)
    if robot.kind == "spatial":
        return _spatial_features(robot, th, prep.dL)
    sv = singular_values(robot, th)
    sens = sensitivity(robot, th)
    pose = robot.fk(th)
    dl = np.abs(prep.dL)
    out = {
        "singularity (sigma_min/sigma_max)": sv[:, -1] / sv[:, 0],
        "max |joint angle| (rad)": np.abs(th).max(axis=1),
        "tip sensitivity to cables (m/m)": np.linalg.norm(sens[:, :2, :], axis=(1, 2)),
        "X (m)": pose[:, 0],
        "Y (m)": pose[:, 1],
        "cable with dL (index)": np.where(dl.max(axis=1) > 0, dl.argmax(axis=1) * 2 + 1, 0).astype(float),
    }
    if robot.n >= 2:
        out["|theta_2| (rad)"] = np.abs(th[:, 1])
    out["min upper tension (N)"] = robot.tensions(th).min(axis=1)
    return out


def _least_tension(tension: np.ndarray) -> np.ndarray:
    """(N,) the least tension of each row, N; NaN where the statics has no
    tension set (a slack configuration: the whole row is NaN)."""
    slack = np.isnan(tension).all(axis=1)
    least = np.where(np.isnan(tension), np.inf, tension).min(axis=1, initial=np.inf)
    least[slack] = np.nan
    return least


def _elastic_features(prep: Prepared) -> Dict[str, np.ndarray]:
    """An elastic arm's features at the nominal equilibrium of each row's
    commands (settled along the execution order): the largest |joint angle|
    and the tip's bend (the angle between the end frame's and the base's
    ``x``, the backbone; rad), X, Y, Z (m), the most pulled cable (1-based:
    the largest ``-dL``), the slack cables (count) and the largest tension
    (N)."""
    robot = prep.robot
    o = prep.order
    cables = commanded_cables(robot)
    lengths = robot.cable_lengths(prep.theta_cmd[o])[:, cables] + prep.dL[o]
    rest = robot.elastic_cables()["rest_length"]
    pos = [j for j, c in enumerate(cables) if c in set(robot.position_cables)]
    dis = [j for j, c in enumerate(cables) if c in set(robot.displacement_cables)]
    eq = robot.equilibrium(lengths=lengths[:, pos] if pos else None,
                           displacements=(rest[[cables[j] for j in dis]] - lengths[:, dis]) if dis else None,
                           sequence=True)
    th = np.empty_like(eq.theta)
    th[o] = eq.theta
    frame = robot.fk_matrix(th)
    pose = frame[:, :3, 3]
    tension, slack = np.empty_like(eq.tension), np.empty_like(eq.slack)
    tension[o], slack[o] = eq.tension, eq.slack
    pulled = -prep.dL
    return {
        "max |joint angle| (rad)": np.abs(th).max(axis=1),
        "tip bend (rad)": np.arccos(np.clip(frame[:, 0, 0], -1.0, 1.0)),
        "X (m)": pose[:, 0],
        "Y (m)": pose[:, 1],
        "Z (m)": pose[:, 2],
        "most pulled cable (index)": (pulled.argmax(axis=1) + 1).astype(float),
        "slack cables (count)": slack.sum(axis=1).astype(float),
        "max cable tension (N)": tension.max(axis=1),
    }


def _spatial_features(robot, th: np.ndarray, dl: np.ndarray) -> Dict[str, np.ndarray]:
    sv = np.linalg.svd(robot.fk_jacobian(th)[:, :3, :], compute_uv=False)
    pose = robot.fk(th)
    a = np.abs(dl)
    return {
        "singularity (sigma_min/sigma_max)": sv[:, -1] / sv[:, 0],
        "max |joint angle| (rad)": np.abs(th).max(axis=1),
        "X (m)": pose[:, 0],
        "Y (m)": pose[:, 1],
        "Z (m)": pose[:, 2],
        "cable with dL (index)": np.where(a.max(axis=1) > 0, a.argmax(axis=1) + 1, 0).astype(float),
        "min position-cable tension (N)": _least_tension(robot.tensions(th)),
    }


# ---------------------------------------------------------------------------
# the verdict
# ---------------------------------------------------------------------------
def _residual_xy(prep: Prepared, f: Fit, rows: np.ndarray) -> np.ndarray:
    k = plant.dims(prep.robot)
    return f.prediction[rows, :k] - prep.measured[rows, :k]


class _Judge:
    """The two questions the diagnosis asks of its models, on one set of
    rows with one noise estimate: is a model supported over a nested smaller
    one (:meth:`beats`; every decision kept in ``tests``), and is it adequate
    (:meth:`adequate`: its :class:`AdequacyBound`, computed once per model,
    and the lack-of-fit test). docs/model.md, "The support test" and "The
    adequacy bound"."""

    def __init__(self, prep: Prepared, noise: NoiseEstimate, rows: np.ndarray):
        self.prep = prep
        self.noise = noise
        self.rows = np.asarray(rows, int)
        self.tests: Dict[tuple, SupportTest] = {}
        self.bounds: Dict[int, AdequacyBound] = {}
        self.limits = plant.bounds(prep.robot)

    @property
    def row_noise(self) -> float:
        """The noise of a row per axis (m)."""
        return self.prep.readings * self.noise.sigma

    @property
    def floor(self) -> float:
        return float(np.sqrt(plant.dims(self.prep.robot)) * self.row_noise)

    def rss(self, c: Candidate) -> float:
        """The position residuals' sum of squares (m²) of ``c``'s fit on the rows."""
        return float(np.nansum(_residual_xy(self.prep, c.fit, self.rows) ** 2))

    def free(self, c: Candidate) -> np.ndarray:
        """Flat indices of the parameters ``c`` fitted that are not at a bound."""
        idx = free_parameters(self.prep.robot, c.fitted)[0]
        lo, hi = self.limits
        v = c.fit.p[idx]
        return idx[(v > lo[idx]) & (v < hi[idx])]

    def beats(self, big: Candidate, small: Candidate, alpha: float, step: str) -> bool:
        """Whether ``big`` is supported over the nested ``small`` at ``alpha``
        (:class:`SupportTest`): with a given or repeat-estimated noise, the
        likelihood-ratio test and the held-out RMS improving; with an
        assumed noise, the held-out signed-rank test and BIC."""
        key = ("nested", id(big), id(small), float(alpha))
        if key not in self.tests:
            ne = self.noise
            guard = big.heldout_rms < small.heldout_rms
            if ne.source == "assumed":
                w, pairs, p = stats.signed_rank(small.heldout ** 2 - big.heldout ** 2)
                t = SupportTest(big.name, small.name, step, "signed-rank", w, (pairs,), p, float(alpha),
                                "BIC lower", bool(big.fit.bic < small.fit.bic), big.heldout_rms, small.heldout_rms)
            else:
                dp = len(self.free(big)) - len(self.free(small))
                rs, rb = self.rss(small), self.rss(big)
                if ne.source in ESTIMATED:
                    stat, p = stats.f_difference(rs, rb, dp, ne.ss_pure, ne.dof_pure)
                    test, dof = "F", (max(dp, 0), ne.dof_pure)
                else:
                    stat, p = stats.chi2_difference(rs, rb, dp, self.row_noise ** 2)
                    test, dof = "chi2", (max(dp, 0),)
                t = SupportTest(big.name, small.name, step, test, float(stat), dof, float(p), float(alpha),
                                "held-out RMS improves", bool(guard), big.heldout_rms, small.heldout_rms)
            self.tests[key] = t
        return self.tests[key].supported

    def differs(self, a: Candidate, b: Candidate, alpha: float, step: str) -> bool:
        """Whether ``a``'s held-out errors beat ``b``'s beyond noise: models
        not nested (two single effects, two combinations of one size), so the
        held-out signed-rank test at ``alpha`` whatever the noise (a tie
        where it does not); kept in ``tests`` with the guard always met."""
        key = ("not nested", id(a), id(b), float(alpha))
        if key not in self.tests:
            w, pairs, p = stats.signed_rank(b.heldout ** 2 - a.heldout ** 2)
            self.tests[key] = SupportTest(a.name, b.name, step, "signed-rank", w, (pairs,), p, float(alpha),
                                          NOT_NESTED, True, a.heldout_rms, b.heldout_rms)
        return self.tests[key].supported

    def bound(self, c: Candidate) -> AdequacyBound:
        """``c``'s adequacy bound: the :data:`ADEQUACY_QUANTILE` of the
        held-out RMS of data simulated from ``c``'s fit linearised there
        (:func:`stats.heldout_rms_draws`) on ``c``'s folds."""
        if id(c) not in self.bounds:
            prep, robot = self.prep, self.prep.robot
            k = plant.dims(robot)
            rows = np.sort(np.concatenate(c.folds)) if c.folds else self.rows
            idx = self.free(c)
            scale = np.array([plant.TYPICAL[b] for b, _ in plant.parameter_blocks(robot, idx)], float)
            A = np.zeros((len(rows), k, len(idx)))
            if len(idx):
                o = prep.order
                _, _, jac = plant.linearise(robot, c.fit.p, idx, prep.theta_cmd[o], prep.dL[o], prep.reading_codes[o])
                J = np.empty_like(jac)
                J[o] = jac
                A = J[rows, :k, :] * scale
                # a row the linearisation cannot evaluate teaches the folds nothing
                A[~np.isfinite(A).all(axis=(1, 2))] = 0.0
            tests = [np.searchsorted(rows, t) for t in c.folds] if c.folds else [np.arange(len(rows))]
            draws = stats.heldout_rms_draws(A, tests, self.row_noise, BOOTSTRAP_DRAWS, BOOTSTRAP_SEED,
                                           self.noise.dof_pure if self.noise.source in ESTIMATED else 0)
            self.bounds[id(c)] = AdequacyBound(float(np.quantile(draws, ADEQUACY_QUANTILE)),
                                               float(np.median(draws)), self.floor, len(idx), BOOTSTRAP_DRAWS,
                                               ADEQUACY_QUANTILE, self.noise.source)
        return self.bounds[id(c)]

    def lack_of_fit(self, c: Candidate):
        """The lack-of-fit test of ``c`` on the rows: (test, statistic, dof,
        p-value, ssr, residual dof)."""
        prep, noise = self.prep, self.noise
        res = _residual_xy(prep, c.fit, self.rows)
        ssr = float(np.nansum(res ** 2))
        k = len(c.fit.names)
        dof = int(np.isfinite(res).sum()) - k
        if noise.source == "repeats" and noise.dof_pure >= 1 and dof - noise.dof_pure >= 1:
            ss_lof, df_lof = ssr - noise.ss_pure, dof - noise.dof_pure
            f = (max(ss_lof, 0.0) / df_lof) / (noise.ss_pure / noise.dof_pure)
            return "F", f, (df_lof, noise.dof_pure), stats.f_sf(f, df_lof, noise.dof_pure), ssr, dof
        if noise.source == "neighbours" and dof >= 1:
            # an independent estimate of the noise: F of the residual mean square over it
            f = (ssr / dof) / (noise.ss_pure / noise.dof_pure)
            return "F", f, (dof, noise.dof_pure), stats.f_sf(f, dof, noise.dof_pure), ssr, dof
        chi = ssr / self.row_noise ** 2
        return "chi2", chi, (max(dof, 1),), stats.chi2_sf(chi, max(dof, 1)), ssr, dof

    def adequate(self, c: Candidate) -> Tuple[bool, tuple]:
        """Whether ``c`` is adequate (held-out RMS within its bound, lack of
        fit not rejected at :data:`LACK_OF_FIT_ALPHA`), and its lack-of-fit test."""
        t = self.lack_of_fit(c)
        return bool(c.heldout_rms <= self.bound(c).bound and t[3] >= LACK_OF_FIT_ALPHA), t


def adequacy_bound(prep: Prepared, noise: NoiseEstimate, cand: Candidate) -> AdequacyBound:
    """The adequacy bound of ``cand`` — fitted on the usable rows of
    ``prep``, its held-out folds in ``cand.folds`` — with the noise
    ``noise`` (:class:`AdequacyBound`; docs/model.md, "The adequacy
    bound")."""
    return _Judge(prep, noise, prep.rows).bound(cand)


def _verdict(judge: _Judge, base: Candidate, final: Candidate, beats: bool) -> Verdict:
    """Adequacy of the nominal and the final model on the judge's rows and the verdict."""
    r = judge.prep.readings
    nom_ok, _ = judge.adequate(base)
    fin_ok, t = judge.adequate(final)
    if beats:
        verdict = "explained" if fin_ok else "partly explained"
    else:
        verdict = "no gap" if nom_ok else "unexplained"
    # the noise (per reading and axis) at which the final model would be
    # adequate: the bound grows in proportion to the noise
    ssr, dof = t[4], t[5]
    b = judge.bound(final)
    need = max(final.heldout_rms * judge.noise.sigma / b.bound if b.bound > 0 else 0.0,
               float(np.sqrt(ssr / (r ** 2 * stats.chi2_ppf(1.0 - LACK_OF_FIT_ALPHA, max(dof, 1)))))
               if dof > 0 else 0.0)
    return Verdict(verdict, bool(nom_ok), bool(fin_ok), t[0], float(t[1]), tuple(int(v) for v in t[2]),
                   float(t[3]), float(need), b, judge.bound(base))


def _evaluated(scorer: "_Scorer", known: Dict[frozenset, Candidate], effects: Sequence[str]) -> Candidate:
    """The candidate of ``effects`` (any order), evaluated once."""
    key = frozenset(effects)
    if key not in known:
        known[key] = scorer.evaluate("+".join(effects), list(effects))
    return known[key]


def _evaluated_all(scorer: "_Scorer", known: Dict[frozenset, Candidate],
                   combos: Sequence[Sequence[str]]) -> List[Candidate]:
    """:func:`_evaluated` of each of ``combos``, those not yet known fitted
    together (:meth:`_Scorer.evaluate_all`), added to ``known`` in order."""
    fresh: List[Sequence[str]] = []
    for c in combos:
        if frozenset(c) not in known and all(frozenset(c) != frozenset(f) for f in fresh):
            fresh.append(c)
    for c, cand in zip(fresh, scorer.evaluate_all([("+".join(c), list(c)) for c in fresh])):
        known[frozenset(c)] = cand
    return [known[frozenset(c)] for c in combos]


def _prune(judge: _Judge, scorer: "_Scorer", known: Dict[frozenset, Candidate], chosen: Optional[Candidate],
           alpha: float) -> Tuple[Optional[Candidate], List[str]]:
    """Backward elimination of the chosen combination: while one of its
    effects is not needed (the combination is not supported over the one
    without it at ``alpha``: :meth:`_Judge.beats`), drop the effect whose
    loss hurts least. Returns the model kept and the effects dropped."""
    dropped: List[str] = []
    while chosen is not None and len(chosen.effects) >= 2:
        subs = _evaluated_all(scorer, known, [[x for x in chosen.effects if x != e] for e in chosen.effects])
        weak = [(e, c) for e, c in zip(chosen.effects, subs)
                if not judge.beats(chosen, c, alpha, "backward elimination")]
        if not weak:
            break
        e, chosen = min(weak, key=lambda t: t[1].heldout_rms)
        dropped.append(e)
    return chosen, dropped


def _search(judge: _Judge, scorer: "_Scorer", known: Dict[frozenset, Candidate], base: Candidate,
            singles: List[Candidate], chosen: Optional[Candidate], ties: List[str],
            max_combination: int) -> Optional[Search]:
    """The search beyond greedy (module doc, step 3): runs where forward
    selection ends with a model that is not adequate, with none while the
    nominal model is not adequate, with a model whose first effect ties
    with other single effects, or with a model holding an effect that
    contains another library effect (:func:`nested`)."""
    if len(singles) < 2 or max_combination < 2:
        return None
    prep, rows = judge.prep, judge.rows
    chosen_ok = chosen is not None and judge.adequate(chosen)[0]
    nest = [] if chosen is None else nested(prep, chosen.effects, [c.name for c in singles], judge.row_noise)
    if chosen is not None and not chosen_ok:
        why = ["forward selection ended with a model that is not adequate"]
    elif chosen is None and not judge.adequate(base)[0]:
        why = ["forward selection chose no effect and the nominal model is not adequate"]
    elif chosen is not None and ties:
        why = [f"single effects tie with `{singles[0].name}`: {', '.join(ties)}"]
    else:
        why = []
    if nest:
        why.append("an effect of the chosen model contains another in the data (its change beside it stays "
                   "below the noise): " + ", ".join(f"`{big}` contains `{small}`" for big, small in nest))
    if not why:
        return None
    reason = "; ".join(why)
    order = [c.name for c in singles]
    combos = list(itertools.combinations(order, 2))
    # an adequate greedy model is replaced only by an adequate one no larger
    if max_combination >= 3 and not (chosen_ok and len(chosen.effects) < 3):
        combos += list(itertools.combinations(order[:SEARCH_TOP], 3))
    if nest and chosen_ok:  # the question is whether a model on the contained effect does instead of its container
        combos = [c for c in combos if any(small in c and big not in c for big, small in nest)]
    if not combos:
        return None
    # the members of the family built in place of a container from what it
    # contains: the SEARCH_TOP best by the screen are fitted in full whatever
    # their screen, which linearises the plant at the start and so misjudges
    # a gap of millimetres (where a container is adequate, the whole family;
    # where it is not, those built only from what it contains and the chosen
    # model's other effects, since a container the fit cannot bring to the
    # floor — 48 hole coordinates from a 1 mm gap — says nothing of the rest)
    if not nest:
        built = []
    elif chosen_ok:
        built = combos
    else:
        parts = {small for _, small in nest} | (set(chosen.effects) - {big for big, _ in nest})
        built = [c for c in combos if set(c) <= parts and any(small in c for _, small in nest)]
    a = ALPHA / len(combos)
    free = [free_parameters(prep.robot, _fitted(prep, c))[:2] for c in combos]
    screen, screen_bound = _screen(prep, scorer, free, judge.row_noise if chosen_ok else None)
    # a combination with more free parameters than half the position
    # components of the rows is not fitted in full: it would interpolate them
    observed = len(rows) * plant.dims(prep.robot)
    fittable = [i for i in np.argsort(screen, kind="stable") if len(free[i][0]) <= MAX_PARAMETER_SHARE * observed]
    ranked = [combos[i] for i in fittable if not chosen_ok or screen[i] <= SCREEN_MARGIN * screen_bound[i]]
    fresh = [c for c in ranked if frozenset(c) not in known][:SEARCH_FULL]
    fresh += [c for c in (combos[i] for i in fittable)
              if c in built and c not in fresh and frozenset(c) not in known][:SEARCH_TOP]
    tried = _evaluated_all(scorer, known, [c for c in ranked if frozenset(c) in known or c in fresh]
                           + [c for c in fresh if c not in ranked])

    def beats(c: Candidate, other: Candidate) -> bool:
        return judge.beats(c, other, a, "search")

    # every effect of a supported combination is needed: it beats the nominal
    # model and each combination one effect smaller, under the family's level
    def needed(c: Candidate) -> bool:
        return beats(c, base) and all(beats(c, _evaluated(scorer, known, sub))
                                      for sub in itertools.combinations(c.effects, len(c.effects) - 1))

    supported = [c for c in tried if needed(c)]
    # a member of the family those checks fitted in full (a pair under a
    # triple tried) is a candidate too: the linearised screen can rank it low
    # where the gap is large and the plant far from linear over it
    extra = [known[frozenset(c)] for c in ranked if frozenset(c) in known
             and all(known[frozenset(c)] is not t for t in tried)]
    tried = tried + extra
    supported += [c for c in extra if needed(c)]
    adequate = [c for c in supported if judge.adequate(c)[0]]
    if adequate or chosen_ok:
        # the adequate model with the fewest effects, then the lowest held-out
        # RMS; where an effect contains others the count of effects is no
        # measure of size (48 hole coordinates contain a scale and four
        # offsets): the lowest BIC, which counts the parameters
        pool = adequate + ([chosen] if chosen_ok else [])
        pick = min(pool, key=(lambda c: c.fit.bic) if nest else (lambda c: (len(c.effects), c.heldout_rms)))
        rivals = adequate
    else:
        pool = supported + ([chosen] if chosen is not None else [])
        pick = min(pool, key=lambda c: c.heldout_rms) if pool else None
        rivals = supported
    tie = [] if pick is None else [c.name for c in rivals if c is not pick and len(c.effects) == len(pick.effects)
                                   and not judge.differs(pick, c, ALPHA, "search: ties")]
    bounds = {c.name: judge.bounds[id(c)].bound for c in tried + ([chosen] if chosen is not None else [])
              if id(c) in judge.bounds}
    return Search(reason, len(combos), float(a), {"+".join(c): float(v) for c, v in zip(combos, screen)}, tried,
                  [c.name for c in supported], [c.name for c in adequate],
                  pick.name if pick is not None else None, pick is not None and pick is not chosen, tie, bounds,
                  {"+".join(c): float(v) for c, v in zip(combos, screen_bound)})


def nested(prep: Prepared, effects: Sequence[str], library: Sequence[str], sigma: float) -> List[Tuple[str, str]]:
    """Pairs ``(big, small)``: ``big`` one of ``effects``, ``small`` another
    effect of ``library`` that the rows cannot tell from ``big`` — with the
    plant linearised at the start, ``small`` changes the rows by more than
    ``sigma`` (m, the noise of a row per axis) at its typical size, but no
    such change leaves more than ``sigma`` beside ``big``: the largest
    singular value of ``small``'s Jacobian (columns at their typical sizes)
    is at least ``sigma``, with ``big``'s column space projected out below
    it. The effects with memory (:data:`plant.MEMORY_EFFECTS`: backlash's
    dead band, friction's sliding state) are not smooth at the start, so the
    linearisation does not speak for them: never ``small``. Such a ``big`` can stand in for
    ``small``, so forward selection may take it where ``small`` and a
    smaller effect would do (on ``two_universal``: ``hole_position``
    contains ``actuation_scale`` and ``cable_offset``)."""
    rows, J, _, col = _linearised(prep)
    if not len(rows):
        return []
    A = J.reshape(-1, J.shape[2])

    def columns(e: str) -> np.ndarray:
        idx, scale, _ = free_parameters(prep.robot, [e])
        return A[:, [col[int(i)] for i in idx]] * scale

    out = []
    for big in effects:
        u, s, _ = np.linalg.svd(columns(big), full_matrices=False)
        u = u[:, s > s[0] * 1e-10] if s.size and s[0] > 0 else u[:, :0]
        for small in library:
            if small in effects or small == big or small in plant.MEMORY_EFFECTS:
                continue
            c = columns(small)
            if not c.size or np.linalg.norm(c, 2) < sigma:
                continue
            if np.linalg.norm(c - u @ (u.T @ c), 2) < sigma:
                out.append((big, small))
    return out


def _screen(prep: Prepared, scorer: "_Scorer", free: Sequence[Tuple[np.ndarray, np.ndarray]],
            noise: Optional[float] = None) -> Tuple[np.ndarray, np.ndarray]:
    """Held-out RMS (m) of a linear least-squares fit of the plant linearised
    at the start, for each combination's free parameters ``free`` (indices,
    typical sizes: :func:`free_parameters` of what it fits), on the scorer's
    folds, and, given the noise of a row per axis ``noise`` (m), each
    combination's adequacy bound there (:func:`stats.heldout_rms_draws` on the same
    Jacobian and folds; NaN without ``noise``). Orders the search only."""
    rows, J, res, col = _linearised(prep)
    where = {int(i): j for j, i in enumerate(rows)}
    tests = [np.array([where[int(i)] for i in t if int(i) in where], int) for t in scorer.tests]
    out = np.full(len(free), np.inf)
    bound = np.full(len(free), np.nan)
    for n, (idx, scale) in enumerate(free):
        A = J[:, :, [col[int(i)] for i in idx]] * scale
        err = np.full(len(rows), np.nan)
        for t in tests:
            train = np.ones(len(rows), bool)
            train[t] = False
            x, *_ = np.linalg.lstsq(A[train].reshape(-1, len(idx)), res[train].reshape(-1), rcond=None)
            err[t] = np.linalg.norm(res[t] - A[t] @ x, axis=1)
        if np.isfinite(err).any():
            out[n] = float(np.sqrt(np.nanmean(err ** 2)))
        if noise is not None:
            bound[n] = float(np.quantile(stats.heldout_rms_draws(A, tests, noise, BOOTSTRAP_DRAWS, BOOTSTRAP_SEED),
                                          ADEQUACY_QUANTILE))
    return out, bound


def diagnose(robot: Robot, meas: Measurements, effects: Optional[Sequence[str]] = None,
             folds: int = 10, noise: Optional[float] = None, max_combination: int = 3,
             frame: str = "auto", progress: bool = False, folds_by: Optional[str] = None) -> Diagnosis:
    """Diagnose the gap between ``robot`` and ``meas`` (see the module doc).

    effects: the candidate library (default: every effect of
    :mod:`cdsm.calibration.plant`; with registered absolute data the frame is
    always fitted and named only when it beats the identity frame). noise:
    measurement noise per axis and reading (m); default: estimated from
    repeats, else from neighbouring rows where the rows sample continuous
    motions (:func:`neighbour_noise`), else assumed (:data:`DEFAULT_NOISE`). max_combination: the
    largest combination forward selection and the search may build. frame:
    ``"auto"`` (absolute data near the nominal predictions are taken in the
    base frame with ``frame_misalignment`` a candidate, farther ones
    registered; :data:`NEAR_FRACTION`), ``"register"`` (an instrument frame,
    fitted with every candidate) or ``"base"`` (the base frame). folds_by:
    a label column of ``meas`` whose rows of one value are held out together
    (:func:`fold_split`; e.g. a motion pattern: neighbouring keypoints of one
    pattern are not independent readings); default: the measurements' own
    grouping (:attr:`Measurements.fold_groups`: an OpenCR recording's
    pattern), else rows one by one.
    """
    library = plant.check_effects(robot, plant.effects_of(robot) if effects is None else effects)
    if noise is not None and not (np.isfinite(noise) and noise > 0):
        raise CdsmInputError(f"`noise`: must be a positive number of m, got {noise}")
    prep = prepare(robot, meas, frame)
    folds_by = meas.fold_groups if folds_by is None else folds_by
    if folds_by is not None:
        if folds_by not in meas.labels:
            raise CdsmInputError(f"`folds_by`: no label column {folds_by!r} in {meas.source or 'the measurements'} "
                                 f"(label columns: {', '.join(meas.labels) or 'none'})")
        prep.groups, prep.group_column = np.asarray(meas.labels[folds_by], dtype=str), folds_by
    if prep.usable.sum() < 3:
        raise CdsmInputError(_too_few_rows(robot, meas, prep))
    if prep.registered:
        library = [e for e in library if e != "frame_misalignment"]
    rows = prep.rows
    # progress in fold fits: the nominal model and every single effect, then
    # what selection, search and the checks fit (not known in advance)
    scorer = _Scorer(prep, rows, folds)
    bar = Progress((len(library) + 1) * (scorer.k + 1), "diagnose: the nominal model and each effect", progress,
                   unit="fold fits")
    scorer.bar = bar
    base = scorer.evaluate("none", [])
    scorer.base_error = base.heldout
    singles = scorer.evaluate_all([(e, [e]) for e in library])
    bar.finish()
    bar = Progress(None, "diagnose: selection, search and checks", progress, unit="fold fits")
    scorer.bar = bar
    singles.sort(key=lambda c: c.heldout_rms)
    # the noise decides the support test (docs/model.md, "The support test")
    ne = _noise(prep, noise)
    judge = _Judge(prep, ne, rows)
    chosen, steps, alphas = None, [], []
    top = singles[0] if singles else None
    if top is not None:
        a = ALPHA / len(singles)
        alphas.append(a)
        if judge.beats(top, base, a, "forward selection, step 1"):
            chosen = top
            steps.append(top)
    while chosen is not None and len(chosen.effects) < max_combination:
        rest = [c.name for c in singles if c.name not in chosen.effects]
        if not rest:
            break
        trials = sorted(scorer.evaluate_all([("+".join(chosen.effects + [e]), chosen.effects + [e]) for e in rest]),
                        key=lambda c: c.heldout_rms)
        nxt = trials[0]
        a = ALPHA / len(trials)
        alphas.append(a)
        if judge.beats(nxt, chosen, a, f"forward selection, step {len(steps) + 1}"):
            chosen = nxt
            steps.append(nxt)
        else:
            break
    known: Dict[frozenset, Candidate] = {frozenset(c.effects): c for c in singles + steps}
    chosen, dropped = _prune(judge, scorer, known, chosen, alphas[0]) if alphas else (chosen, [])
    # single effects the held-out errors cannot tell from the best one (not
    # nested: the paired signed-rank test, whatever the noise)
    ties = [c.name for c in singles[1:] if not judge.differs(top, c, ALPHA, "ties of the first single effect")
            and c.heldout_rms < base.heldout_rms] if top is not None else []
    search = _search(judge, scorer, known, base, singles, chosen, ties, max_combination)
    if search is not None and search.replaced:
        chosen = next(c for c in search.tried if c.name == search.picked)
    # the registration is named only when it beats the identity frame for the
    # chosen model, on held-out rows and by BIC, like any effect
    identity = None
    named = False
    if prep.registered:
        saved, prep.registered = prep.registered, False
        fin = chosen or base
        identity = _Scorer(prep, rows, folds, bar=bar).evaluate(
            "identity frame" + (f" ({fin.name})" if chosen else ""), list(fin.effects))
        prep.registered = saved
        named = judge.beats(fin, identity, ALPHA, "registration")
    names = list(chosen.effects) if chosen else []
    if named:
        names = ["frame_misalignment"] + names
    d = Diagnosis("+".join(names) or "none", base, singles, chosen, steps, ne, prep, identity=identity,
                  registration_named=named, folds=int(scorer.k), alphas=[float(a) for a in alphas],
                  search=search, dropped=dropped)
    d.support = list(judge.tests.values())
    pool = [base] + singles + [c for c in steps if len(c.effects) > 1]
    if chosen is not None and all(c is not chosen for c in pool):
        pool.append(chosen)
    for c, w in zip(pool, stats.model_weights([c.fit.bic for c in pool])):
        c.weight = float(w)
    # single effects the held-out errors cannot tell from the best one (pairwise, alpha 0.025)
    d.ties = ties
    final = d.final()
    if final.fit.corr.size:
        c = final.fit.corr
        nm = final.fit.names
        for i in range(len(nm)):
            for j in range(i + 1, len(nm)):
                if abs(c[i, j]) > 0.95:
                    d.correlated.append(f"{nm[i]} ~ {nm[j]} (corr {c[i, j]:+.3f})")
    d.unidentifiable = [n for n, s in zip(final.fit.names, final.fit.std) if not np.isfinite(s)]
    d.verdict_detail = _verdict(judge, base, final, chosen is not None)
    # outliers: rows whose residual stays beyond 5 sigma after the fit
    res = _residual_xy(prep, final.fit, rows)
    z = np.abs(res).max(axis=1) / (prep.readings * d.noise)
    d.outliers = [int(i) for i in rows[z > OUTLIER_SIGMA]]
    if d.outliers and most_rows(len(d.outliers), len(rows)):
        d.without_outliers_skipped = (
            f"{len(d.outliers)} of the {len(rows)} rows are beyond {OUTLIER_SIGMA:g} sigma: not a few bad readings "
            "but most of the data, and the rows left a different data set; the diagnosis is not rerun without them")
    elif d.outliers:
        keep = np.setdiff1d(rows, d.outliers)
        if len(keep) >= 3:
            sc = _Scorer(prep, keep, folds, bar=bar)
            b2 = sc.evaluate("none", [])
            sc.base_error = b2.heldout
            f2 = sc.evaluate(final.name, final.effects) if chosen else b2
            judge2 = _Judge(prep, ne, keep)
            beats2 = chosen is not None and judge2.beats(f2, b2, alphas[0], "without the outliers")
            d.verdict_without_outliers = _verdict(judge2, b2, f2, beats2)
            d.support += list(judge2.tests.values())
    # where the gap lies: residual sizes against configuration features
    feats = features(prep)
    d.features = feats
    r_base = _residual_xy(prep, base.fit, rows)
    size = np.linalg.norm(r_base, axis=1)
    d.feature_correlation = {k: stats.spearman(v[rows], size) for k, v in feats.items()}
    bar.finish()
    return d


def residuals(d: Diagnosis, which: str = "final") -> np.ndarray:
    """Per-row residuals (N, 2) m (prediction − measurement; spatial arms
    (N, 3)) of the baseline or the final model fitted on all usable rows, NaN
    for unusable rows (file order)."""
    prep = d.prep
    f = d.baseline.fit if which == "baseline" else d.final().fit
    out = np.full((len(prep.meas), plant.dims(prep.robot)), np.nan)
    out[prep.rows] = _residual_xy(prep, f, prep.rows)
    return out
