"""Inverse statics through the plant: the commands of an arm's commanded
cables that settle its tip on target positions (or poses), for an arm
whose joint angles are not commanded — an elastic arm, whose configuration
is the equilibrium of its tendons and springs. SI units (m, rad, N).

The unknowns are the commanded cables' extras ``dL`` (m_c,) m at the rest
angles (a displacement ``d = -dL``, positive = pull); the residual is the
plant's tip minus the target, weighted ``[1 per position coordinate, L
per rotation coordinate]`` (``L`` the straight arm length, m/rad; 0 for a
target without a rotation). Each row is solved by Gauss-Newton with the
**minimum-norm step** ``-pinv(J) r`` of the plant's exact Jacobian
(:func:`cdsm.calibration.plant.linearise` over ``cable_offset``, times the
actuators' gain ``1 + s``) and a backtracking line search on ``|r|``,
from a uniform preload of every cable (default :data:`PRELOAD`, a pull of
0.5 mm: the tendons taut, the arm about straight).

Why minimum-norm: FTDCR v4 has 9 tendons for a 3-D target, a 6-D null
space of co-contraction. The minimum-norm step changes the commands as
little as the residual allows and never moves them along the null space,
so the answer stays at the preload's co-contraction (no tension the target
does not need); a regularised least squares ``min |r|^2 + lambda |dL|^2``
would leave the tip ~lambda off the target, and the round trip must meet
it to rounding. A slack tendon (``sigma <= 0``, carrying nothing) has a
zero column: the steps do not move it (it stays slack) — a target that
needs it pulled is not reached from that side and is flagged. A row is
``converged`` when every weighted residual component is at most ``tol``;
otherwise flagged ``not reached`` with its error and slack tendons.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List

import numpy as np

from ..display import ShortRepr
from ..inputs import CdsmInputError, as_array, as_finite, as_iterations, as_vector
from ..robot import Robot
from . import plant

__all__ = ["PRELOAD", "RETRY", "InverseStatics", "inverse_statics", "target_array"]

#: The uniform pull (m) every commanded cable starts from.
PRELOAD = 0.5e-3

#: A row the iteration does not reach from the preload is tried once more from this many times it (more
#: co-contraction: the tendons the steps pay out stay taut longer).
RETRY = 4.0


@dataclass(repr=False)
class InverseStatics(ShortRepr):
    """Commands for N targets: ``dL`` (N, m_c) m at the rest angles
    (``displacements = -dL``, pull positive), the plant's tip ``seen`` (N, t)
    with them (run as one sequence, in order), ``error`` (N,) m its position's
    distance from the target, ``rotation_error`` (N,) rad (NaN without a
    rotation target), ``converged`` (N,), ``iterations`` (N,), ``slack`` (N,)
    the commanded cables at zero slope (slack) at the answer, ``flags`` one
    str per row ("" when fine)."""

    targets: np.ndarray
    dL: np.ndarray
    seen: np.ndarray
    error: np.ndarray
    rotation_error: np.ndarray
    converged: np.ndarray
    iterations: np.ndarray
    slack: np.ndarray
    flags: List[str]

    @property
    def displacements(self) -> np.ndarray:
        """(N, m_c) m: the cables' displacements (pull positive), ``-dL``."""
        return -self.dL


def target_array(robot: Robot, targets) -> np.ndarray:
    """``targets`` as (N, dim) positions or (N, task) poses (the kind's
    coordinates, m and rad), finite; :class:`CdsmInputError` otherwise."""
    kind = robot.kind
    arr = np.atleast_2d(as_array("targets", targets))
    if arr.ndim != 2 or arr.shape[1] not in (kind.dim, kind.task):
        raise CdsmInputError(f"`targets`: expected (N, {kind.dim}) positions or (N, {kind.task}) poses, "
                             f"got shape {np.shape(targets)}")
    if not np.isfinite(arr).all():
        i, j = np.argwhere(~np.isfinite(arr))[0]
        raise CdsmInputError(f"`targets`: non-finite value {arr[i, j]} at row {i}, column {j}")
    return arr


def _residual(robot, arr, seen, weights):
    """Weighted residual (t,) of one row (the target's missing rotation weighted 0)."""
    full = np.zeros(robot.kind.task)
    full[:arr.size] = arr
    return weights * (seen - full)


def _sequence(rest: np.ndarray, prev, x: np.ndarray):
    """The plant's rows of one candidate ``x`` (m_c,): after the previous row's
    answer ``prev`` (run, unmeasured) where there is one."""
    rows = np.array([x] if prev is None else [prev, x])
    readings = ["absolute"] * len(rows) if prev is None else ["unmeasured", "absolute"]
    return np.tile(rest, (len(rows), 1)), rows, readings


def _solve_row(robot, pp, target, weights, start, prev, offsets, gain, tol, max_iter):
    """Gauss-Newton with the minimum-norm step and a backtracking line search
    on one target from ``start``: (dL (m_c,), converged, iterations)."""
    rest = robot.rest_angles

    def predict(x):
        obs, ok = plant.predict(robot, pp, *_sequence(rest, prev, x))
        return obs[-1], bool(ok[-1])

    dl = np.array(start, dtype=float)
    seen, ok = predict(dl)
    r = _residual(robot, target, seen, weights) if ok else np.full(robot.kind.task, np.inf)
    k = 0
    while ok and np.max(np.abs(r)) > tol and k < max_iter:
        _, _, jac = plant.linearise(robot, pp, offsets, *_sequence(rest, prev, dl))
        step = -np.linalg.pinv(weights[:, None] * jac[-1] * gain, rcond=1e-12) @ r
        t, norm0 = 1.0, np.linalg.norm(r)
        while True:
            s2, ok2 = predict(dl + t * step)
            r2 = _residual(robot, target, s2, weights) if ok2 else None
            if r2 is not None and np.linalg.norm(r2) < norm0:
                dl, r = dl + t * step, r2
                break
            t *= 0.5
            if t < 1e-6:
                ok = False  # no step lowers the residual
                break
        k += 1
    return dl, bool(np.isfinite(r).all() and np.max(np.abs(r)) <= tol), k


def inverse_statics(robot: Robot, targets, p=None, start=None, preload: float = PRELOAD, tol: float = 1e-11,
                    max_iter: int = 60) -> InverseStatics:
    """Commands that settle the plant ``p`` (P,) (default the nominal arm) at
    ``targets`` (N, dim) m or (N, task) poses (module doc). ``start`` (m_c,)
    m: the ``dL`` each row starts from (default ``-preload`` on every
    commanded cable). Rows are solved in order, each from the answer before
    it run as a two-row sequence (the plant's memory of the previous command:
    exact without backlash); the returned ``seen`` runs the whole sequence.
    Without a ``start``, a row not reached from the preload is tried once
    more from :data:`RETRY` times it.
    ``tol`` (m) on the weighted residual."""
    arr = target_array(robot, targets)
    kind = robot.kind
    m = plant.commands(robot)
    pp = np.zeros(plant.size(robot)) if p is None else plant.check_params(robot, p, "p")
    preload = as_finite("preload", preload)
    if preload < 0.0:
        raise CdsmInputError(f"`preload`: expected a pull >= 0 m, got {preload!r}")
    d0 = np.full(m, -preload) if start is None else as_vector("start", start, m)
    tol, max_iter = as_finite("tol", tol), as_iterations("max_iter", max_iter)
    if tol <= 0.0:
        raise CdsmInputError(f"`tol`: expected a tolerance > 0 m, got {tol!r}")
    lay = plant.layout(robot)
    gain = 1.0 + float(pp[lay["actuation_scale"]][0]) if "actuation_scale" in lay else 1.0
    offsets = np.arange(lay["cable_offset"].start, lay["cable_offset"].stop)
    has_rot = arr.shape[1] == kind.task
    weights = np.array([1.0] * kind.dim + [robot.straight_length if has_rot else 0.0] * (kind.task - kind.dim))
    rest = robot.rest_angles
    N = len(arr)
    out_dl, iters = np.full((N, m), np.nan), np.zeros(N, np.int64)
    conv, slack = np.zeros(N, bool), np.zeros(N, np.int64)
    prev = None
    starts = [d0] if start is not None else [d0, RETRY * d0]
    for i in range(N):
        for s0 in starts:  # a row not reached from the preload: once more from a stronger one
            dl, conv[i], iters[i] = _solve_row(robot, pp, arr[i], weights, s0, prev, offsets, gain, tol, max_iter)
            if conv[i]:
                break
        th, rows, readings = _sequence(rest, prev, dl)
        _, _, jac = plant.linearise(robot, pp, offsets, th, rows, readings)
        slack[i] = int(np.sum(np.all(jac[-1] == 0.0, axis=0)))
        out_dl[i] = dl
        prev = dl
    seen, settled = plant.predict(robot, pp, np.tile(rest, (N, 1)), out_dl) if N else (np.zeros((0, kind.task)),
                                                                                        np.zeros(0, bool))
    dim = kind.dim
    err = np.linalg.norm(seen[:, :dim] - arr[:, :dim], axis=1)
    rot = np.linalg.norm(seen[:, dim:] - arr[:, dim:], axis=1) if has_rot else np.full(N, np.nan)
    conv &= settled
    flags = ["" if conv[i] else f"not reached: predicted tip error {err[i]:.2e} m ({slack[i]} of {m} commanded "
             "cables slack at the answer)" for i in range(N)]
    return InverseStatics(arr.copy(), out_dl, seen, err, rot, conv, iters, slack, flags)

