"""Compensation: the upper-cable commands that put the tip of a fitted plant
on target poses, and the table they are written to. SI units (m, rad, N).
"""

from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass
from typing import List

import numpy as np

from ..accuracy.workspace import paper_ik_seed
from ..files import read_table, write_text
from ..inputs import CdsmInputError, as_array, as_finite, as_iterations, as_vector
from ..display import ShortRepr
from ..kinds import KINDS, kind_of
from . import plant
from .inverse_statics import PRELOAD, inverse_statics
from .measurements import commanded_cables

__all__ = ["Compensation", "compensate", "compensate_commands", "read_targets", "TARGET_COLUMNS"]


# ---------------------------------------------------------------------------
# targets
# ---------------------------------------------------------------------------
def read_targets(path: "str | os.PathLike[str]", kind: str = "planar") -> np.ndarray:
    """Target poses from a CSV file; lines starting with ``#`` are comments,
    other columns are ignored. Planar arms (``kind="planar"``): columns ``x,
    y`` (m) and optional ``phi`` (rad), returns (N, 2) or (N, 3). Spatial arms
    (``kind="spatial"``): ``x, y, z`` (m) and optional ``rx, ry, rz`` (the
    rotation vector of the tip frame, rad), returns (N, 3) or (N, 6). Raises
    :class:`CdsmInputError` on a missing column, a non-number or a non-finite
    value."""
    src = str(path)
    if kind not in TARGET_COLUMNS:
        raise CdsmInputError(f"`kind`: expected one of {', '.join(TARGET_COLUMNS)}, got {kind!r}")
    need, extra = TARGET_COLUMNS[kind]
    table = read_table(path, "targets", read_as=lambda cols: {c: "number" for c in need + extra if c in cols})
    cols = table.columns
    missing = [c for c in need if c not in cols]
    if missing:
        raise CdsmInputError(f"{src}: missing target columns {', '.join(missing)} (need {', '.join(need)} [m] "
                             f"and optional {', '.join(extra)} [rad]); found {', '.join(cols)}")
    partial = [c for c in extra if c in cols]
    if partial and len(partial) != len(extra):
        raise CdsmInputError(f"{src}: orientation columns {', '.join(partial)} given without "
                             f"{', '.join(c for c in extra if c not in cols)}: give all of {', '.join(extra)} or none")
    use = list(need) + (list(extra) if partial else [])
    return np.stack([table.numbers(c) for c in use], axis=1)


#: The nominal IK's seed of a compensation, by the kind's policy (:attr:`cdsm.kinds.Kind.compensation`).
_IK_SEEDS = {"paper": paper_ik_seed, "zeros": np.zeros}

#: Target columns per robot kind: (required position columns, optional
#: orientation columns) — the kind's position and rotation axes.
TARGET_COLUMNS = {name: (k.position_axes, k.rotation_axes) for name, k in KINDS.items()}


# ---------------------------------------------------------------------------
# compensation result
# ---------------------------------------------------------------------------
@dataclass(repr=False)
class Compensation(ShortRepr):
    """Compensated commands for N target poses (robot with n joints).

    targets: (N, 2) or (N, 3) the targets [x, y(, phi)] (m, m, rad).
    commands: (N, n) upper-cable length commands L_1..L_n, m (what the
    controller sends; NaN where the target is unreachable). theta_cmd: (N, n)
    rad, the nominal IK of the target (the uncompensated configuration) and dL:
    (N, n) m the correction, so ``commands = upper_lengths(theta_cmd) + dL``.
    nominal_commands: (N, n) m, the uncompensated commands
    ``upper_lengths(theta_cmd)``. converged: (N,) bool. predicted_error: (N,) m,
    the model's predicted tip position error |xy - target| with the commands;
    predicted_error_nominal: (N,) m, the same with the nominal commands;
    predicted_phi_error: (N,) rad (NaN when phi was not given). theta_pred:
    (N, n) rad, the configuration the fitted arm is predicted to settle at.
    elastic: the arm is elastic (:func:`compensate_commands`: ``theta_cmd``
    its rest angles, ``commands`` the commanded cables' rest lengths).
    flags: one str per row, "" when fine, else '; '-joined reasons
    (``unreachable: ...``, ``slack cable``, ``joint limits``, ``not converged``).
    kind: the robot kind. For a spatial arm (m position cables) targets are
    (N, 3) [x, y, z] m or (N, 6) with the rotation vector (rad), commands,
    dL and nominal_commands are (N, m), predicted_error is the 3-D distance
    and predicted_phi_error the norm of the rotation-vector difference (rad).
    """

    targets: np.ndarray
    commands: np.ndarray
    theta_cmd: np.ndarray
    dL: np.ndarray
    nominal_commands: np.ndarray
    converged: np.ndarray
    predicted_error: np.ndarray
    predicted_error_nominal: np.ndarray
    predicted_phi_error: np.ndarray
    theta_pred: np.ndarray
    flags: List[str]
    model_name: str = ""
    kind: str = "planar"
    cable_ids: "List[int] | None" = None
    elastic: bool = False

    def __len__(self) -> int:
        return len(self.targets)

    @property
    def ok(self) -> np.ndarray:
        """(N,) converged and not flagged."""
        return self.converged & np.array([not f for f in self.flags], bool)

    def to_csv(self, path: "str | os.PathLike[str]") -> None:
        """Write the commands table: target columns (x, y[, phi]), L_1..L_n (m),
        converged (0/1), predicted_error and predicted_error_nominal (m),
        predicted_phi_error (rad, empty without phi), theta_1..theta_n (rad,
        the nominal configuration) and dL_1..dL_n (m, the correction), flags.
        Undefined numbers are written as ``nan``; floats by ``repr`` (exact)."""
        n = self.theta_cmd.shape[1]
        kind = kind_of(self.kind)
        pos, rot, rot_err = kind.position_axes, kind.rotation_axes, kind.words["rotation_error"]
        has_phi = self.targets.shape[1] > len(pos)
        cab = list(range(1, self.commands.shape[1] + 1))
        head = list(pos) + (list(rot) if has_phi else []) + [f"L_{i}" for i in cab] + \
            ["converged", "predicted_error", "predicted_error_nominal"] + \
            ([rot_err] if has_phi else []) + \
            [f"theta_{i}" for i in range(1, n + 1)] + [f"dL_{i}" for i in cab] + ["flags"]
        buf = io.StringIO()
        buf.write(f"# cdsm compensate: cable length commands from model {self.model_name!r}\n")
        buf.write(f"# SI units: {', '.join(pos)}, L_i, dL_i, predicted_error* in m; {', '.join(rot)}, theta_i, "
                  f"{rot_err} in rad\n")
        cables = ", ".join(str(c + 1) for c in self.cable_indices)
        if self.elastic:  # its cables' rest lengths, from the rest angles; a tendon's pull is -dL
            buf.write(f"# elastic arm: L_i, dL_i: the i-th commanded cable (robot-file cables {cables}); L_i = its "
                      "rest length = its path at the rest angles theta_i + dL_i (a displacement-commanded tendon "
                      "is pulled by -dL_i); converged 1/0; flags empty when fine\n")
        else:
            buf.write(f"# {kind.words['commands_note'].format(cables=cables)}\n")
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(head)
        for i in range(len(self)):
            row = [repr(float(v)) for v in self.targets[i]]
            row += [repr(float(v)) for v in self.commands[i]]
            row += [str(int(self.converged[i])), repr(float(self.predicted_error[i])),
                    repr(float(self.predicted_error_nominal[i]))]
            if has_phi:
                row.append(repr(float(self.predicted_phi_error[i])))
            row += [repr(float(v)) for v in self.theta_cmd[i]] + [repr(float(v)) for v in self.dL[i]]
            row.append(self.flags[i])
            w.writerow(row)
        write_text(path, buf.getvalue(), "commands")

    @property
    def cable_indices(self) -> List[int]:
        """0-based indices of the commanded cables (planar: the n upper
        cables; spatial: the position-controlled cables)."""
        return list(self.cable_ids) if self.cable_ids is not None else list(range(self.commands.shape[1]))

    def summary(self) -> str:
        """A few lines: counts and the predicted errors before/after (µm)."""
        ok = self.converged
        fl = sum(1 for f in self.flags if f)
        lines = [f"{len(self)} targets: {int(ok.sum())} converged, {fl} flagged"]
        if ok.any():
            lines.append(f"predicted tip error with nominal commands: max "
                         f"{np.nanmax(self.predicted_error_nominal[ok]) * 1e6:.1f} µm; compensated: max "
                         f"{np.nanmax(self.predicted_error[ok]) * 1e6:.3g} µm")
        return "\n".join(lines)




def compensate(model, poses, tol: float = 1e-9, max_iter: int = 40, min_tension: float = 0.0,
               enforce_limits: bool = False, start=None) -> Compensation:
    """Commands of the position-controlled cables (planar: the upper
    cables) that put the fitted plant's tip on ``poses``, either kind.

    poses: (N, task) the full targets or (N, dim) their positions alone
    (planar: [x, y, phi] (m, m, rad) or [x, y]; spatial: [x, y, z] (m) and
    optionally the rotation vector (rad)), run in this order (backlash has
    memory; ``start`` (m_pos,) m: the lengths the screws hold before the
    first target, default the straight pose). Each row: the nominal
    configuration ``theta_cmd`` is the nominal IK of the target from the
    kind's seed — planar the paper's seed
    (:func:`cdsm.accuracy.workspace.paper_ik_seed`; without phi, the IK of
    (x, y, 0) — for n = 3 the paper's branch — or of the position alone
    (task mask ``"position"``) when that fails or leaves the joint limits);
    spatial theta = 0 (mask ``"pose"``, or ``"position"`` without a
    rotation). The Rust core then finds, by the shared damped least squares
    with the plant's exact Jacobian, the lengths the screws must deliver so
    that the fitted plant's tip meets the target — residual [position(,
    rotation·L)], L the straight arm length (m/rad), converged when its
    largest component is <= ``tol`` (m) — and commands them through the
    backlash in order. The commands are the nominal lengths at
    ``theta_cmd`` + ``dL``.

    Flags: ``unreachable`` (nominal IK fails), ``outside the joint limits``
    (the nominal IK answer leaves them: flagged, and left out only with
    ``enforce_limits``), ``slack cable`` (planar: an upper tension <=
    ``min_tension`` N at the predicted configuration of the fitted arm;
    spatial: no tension set >= ``min_tension`` N holds it), ``joint
    limits`` (that configuration leaves the limits), ``not converged``.

    An elastic arm (:attr:`Robot.is_elastic`: its joint angles are the
    equilibrium of its tendons and springs, not commanded) goes by its
    inverse statics instead: :func:`compensate_commands`.
    """
    r = model.robot
    if r.is_elastic:  # its joint angles are not commanded: no nominal IK, the inverse statics
        if start is not None or enforce_limits:
            raise CdsmInputError(f"`{'start' if start is not None else 'enforce_limits'}`: applies to an arm "
                                 "commanded by its joint angles; an elastic arm's commands start from a preload "
                                 "(cdsm.calibration.compensation.compensate_commands)")
        return compensate_commands(model, poses, tol=tol, max_iter=max_iter)
    kind = r.kind
    policy = kind.compensation
    n, m, dim = r.n, len(r.position_cables), kind.dim
    arr = np.atleast_2d(as_array("poses", poses))
    if arr.ndim != 2 or arr.shape[1] not in (dim, kind.task):
        raise CdsmInputError(f"`poses`: expected shape {policy['shapes']}, got {np.shape(poses)}")
    if not np.isfinite(arr).all():
        i, j = np.argwhere(~np.isfinite(arr))[0]
        raise CdsmInputError(f"`poses`: non-finite value {arr[i, j]} at row {i}, column {j}")
    N = len(arr)
    has_rot = arr.shape[1] == kind.task
    full = arr if has_rot else np.column_stack([arr, np.zeros((N, kind.task - dim))])
    flags: List[List[str]] = [[] for _ in range(N)]
    seed = _IK_SEEDS[policy["ik_seed"]](n)
    # without a rotation: the pose at rotation 0 first (planar), or the position alone at once (spatial)
    first = "pose" if has_rot or policy["zero_rotation_first"] else "position"
    theta = np.zeros((N, n))
    reach = np.zeros(N, bool)
    if N:
        sol = r.ik(full, seed=seed, mask=first)
        theta = np.array(sol.theta, dtype=float).reshape(N, n)
        reach = np.asarray(sol.converged, bool).reshape(N)
    if first == "pose" and not has_rot and N:
        # the pose at rotation 0 unreachable or outside the limits: position-only IK
        idx = np.flatnonzero(~(reach & r.within_limits(theta)))
        if len(idx):
            s2 = r.ik(full[idx], seed=seed, mask="position")
            th2 = np.atleast_2d(s2.theta)
            ok2 = np.atleast_1d(s2.converged) & (r.within_limits(th2) | ~reach[idx])
            theta[idx[ok2]] = th2[ok2]
            reach[idx[ok2]] = True
    for i in np.flatnonzero(~reach):
        flags[i].append(policy["unreachable"])
    lim = r.within_limits(theta) if N else np.zeros(0, bool)
    for i in np.flatnonzero(reach & ~lim):
        flags[i].append("outside the joint limits: the nominal IK answer leaves them"
                        + (" (not compensated: enforce_limits)" if enforce_limits else ""))
    if enforce_limits:
        reach &= lim
    L = r.straight_length
    weights = [1.0] * dim + [L if has_rot else 0.0] * (kind.task - dim)
    commands, nominal, th_pred, conv, seen, seen0 = _solve_rows(model, theta, full, reach, weights, m, start,
                                                                tol, max_iter)
    rows = np.flatnonzero(reach)
    err = policy["position_error"](seen[:, :dim] - full[:, :dim])
    err0 = policy["position_error"](seen0[:, :dim] - full[:, :dim])
    rerr = policy["rotation_error"](seen[:, dim:] - full[:, dim:]) if has_rot else np.full(N, np.nan)
    slack = policy["slack"].format(min_tension=min_tension)
    _flag_outcome(r, flags, rows, conv, seen, th_pred, err, min_tension, slack)
    return Compensation(arr.copy(), commands, theta, commands - nominal, nominal, conv, err, err0, rerr, th_pred,
                        ["; ".join(f) for f in flags], model.name, str(kind),
                        list(r.position_cables) if kind.cable_numbers else None)


def _solve_rows(model, theta, full, reach, weights, m: int, start, tol, max_iter):
    """The core's compensation of the rows ``reach`` (the others stay NaN):
    commands, nominal commands (N, m) m, predicted configurations (N, n) rad,
    converged (N,), observations with the commands and with the nominal ones
    (N, width)."""
    r = model.robot
    N, n, width = len(full), r.n, full.shape[1]
    commands, nominal = np.full((N, m), np.nan), np.full((N, m), np.nan)
    th_pred, conv = np.full((N, n), np.nan), np.zeros(N, bool)
    seen, seen0 = np.full((N, width), np.nan), np.full((N, width), np.nan)
    rows = np.flatnonzero(reach)
    if len(rows):
        st = None if start is None else np.ascontiguousarray(as_vector("start", start, m))
        res = r.core.compensate(np.ascontiguousarray(model.p, float), np.ascontiguousarray(theta[rows]),
                                np.ascontiguousarray(full[rows]), weights, st, as_finite("tol", tol), 1e-12,
                                as_iterations("max_iter", max_iter), r.threads)
        commands[rows] = res.command.reshape(-1, m)
        nominal[rows] = res.nominal.reshape(-1, m)
        th_pred[rows] = res.theta.reshape(-1, n)
        conv[rows] = res.converged
        seen[rows] = res.seen.reshape(-1, width)
        seen0[rows] = res.seen_nominal.reshape(-1, width)
    return commands, nominal, th_pred, conv, seen, seen0


def _flag_outcome(r, flags, rows, conv, seen, th_pred, err, min_tension, slack_text: str) -> None:
    """Flags of the compensated rows: not converged (or not realisable), a
    slack cable or the joint limits at the predicted configuration."""
    for i in rows[~conv[rows]]:
        if not np.isfinite(seen[i]).all():
            flags[i].append("the fitted model cannot realise the commands")
        else:
            flags[i].append(f"not converged (predicted tip error {err[i]:.2e} m)")
    fin = rows[np.isfinite(th_pred[rows]).all(axis=1)]
    if len(fin):
        feas = r.feasible(th_pred[fin], min_tension=min_tension)
        inlim = r.within_limits(th_pred[fin])
        for i, f_, li in zip(fin, np.atleast_1d(feas), np.atleast_1d(inlim)):
            if not f_:
                flags[i].append(slack_text)
            if not li:
                flags[i].append("joint limits: the predicted configuration leaves them")


def compensate_commands(model, poses, tol: float = 1e-11, max_iter: int = 60, preload: float = PRELOAD,
                        start=None):
    """:func:`cdsm.calibration.compensate` of an arm commanded by its cables
    (an elastic arm): the commands that settle the fitted plant ``model.p``
    at ``poses``, and as the uncompensated commands those the nominal
    model's inverse statics finds
    (:func:`cdsm.calibration.inverse_statics.inverse_statics`, minimum-norm
    Gauss-Newton from ``preload``; ``start`` its first ``dL``). Returns
    a :class:`~cdsm.calibration.compensation.Compensation`: ``theta_cmd``
    the rest angles, ``commands`` the commanded cables' rest lengths (their
    paths at the rest angles + dL), ``dL`` the plant's extras (minus the
    tendons' displacements, m), ``nominal_commands`` the nominal inverse
    statics' commands, ``predicted_error`` and ``predicted_error_nominal`` the fitted
    plant's tip error with either, ``theta_pred`` where the fitted plant
    settles; flags those of the fitted inverse statics and a target the
    nominal one does not reach."""
    r = model.robot
    nominal = inverse_statics(r, poses, None, start, preload, tol, max_iter)
    fitted = inverse_statics(r, poses, model.p, start, preload, tol, max_iter)
    N, dim = len(nominal.targets), r.kind.dim
    rest = np.tile(r.rest_angles, (N, 1))
    base = plant.command_lengths(r, rest) if N else np.zeros((0, plant.commands(r)))
    seen0, _ = plant.predict(r, model.p, rest, nominal.dL) if N else (np.zeros((0, r.kind.task)), None)
    theta_pred, _ = plant.settle(r, model.p, rest, fitted.dL) if N else (np.zeros((0, r.n)), None)
    err0 = np.linalg.norm(seen0[:, :dim] - nominal.targets[:, :dim], axis=1)
    flags = ["; ".join(f for f in (fitted.flags[i], "" if nominal.converged[i] else
                                   "the nominal model's inverse statics does not reach the target") if f)
             for i in range(N)]
    return Compensation(fitted.targets, base + fitted.dL, rest, fitted.dL, base + nominal.dL,
                        fitted.converged, fitted.error, err0, fitted.rotation_error, theta_pred,
                        flags, model.name, str(r.kind), list(commanded_cables(r)), elastic=True)
