"""The solves of an arm of either kind: one damped least-squares loop
(Levenberg--Marquardt), the cable solve, the pose IK, the tip deviation of
an error scenario and the tip sensitivities.

Written from ``docs/model.md`` ("Solves", "Sensitivities") and
``docs/spatial.md`` ("Solves"), independent of the Rust core.  Each function
is vectorised over the batch ``N``: every row has its own damping and stops
on its own.  Units: m, rad.
"""

from __future__ import annotations

import numpy as np

from .kinematics import (
    as_theta,
    cable_hole_gradient,
    cable_jacobian,
    chain_frames,
    cross,
    fk_jacobian,
    position_lengths,
    within_limits,
)
from .robot import Robot, as_robot, position_cables
from .rotations import exp_so3, log_so3

__all__ = [
    "levenberg_marquardt",
    "solve_rows",
    "seeds",
    "solve_cables",
    "ik",
    "deviation",
    "tip_sensitivity",
]

# The constants of docs/model.md ("Solves").
LAMBDA_0 = 1e-3
LAMBDA_MIN = 1e-12
LAMBDA_MAX = 1e12
#: Least-squares cable solve (more position cables than joints): converged when an
#: accepted step lowers ``|r|^2`` by less than this fraction of itself.
STALL = 1e-12



def levenberg_marquardt(residual, step, theta, tol, max_iter, lambda0=LAMBDA_0, project=None, stall=None) -> dict:
    """The damped least-squares loop of every solve, vectorised over the rows.

    ``residual(theta, idx) -> r (k, rows)`` for the batch rows ``idx``;
    ``step(theta, r, lam, idx) -> delta (k, n)``; ``project`` maps a trial onto the
    joint box (or None).  A trial is accepted when it lowers ``|r|^2`` (then
    ``lambda <- max(lambda/10, 1e-12)``), otherwise ``lambda <- 10 lambda`` (from an
    undamped start ``lambda = 0``: ``1e-3``).  A row has converged when ``max|r| <=
    tol`` or, with ``stall``, when an accepted step lowers ``|r|^2`` by less than
    ``stall |r|^2``; it has failed after ``max_iter`` trials or at ``lambda > 1e12``.
    ``theta (N, n)`` holds the seeds (updated in place).  Returns ``theta``,
    ``converged (N,)``, ``iterations (N,)`` (trials) and ``residual (N,)`` (``max|r|``).
    """
    N = theta.shape[0]
    with np.errstate(all="ignore"):
        r = residual(theta, np.arange(N))
    f = (r**2).sum(1)
    lam = np.full(N, float(lambda0))
    iterations = np.zeros(N, dtype=np.int64)
    converged = np.abs(r).max(1, initial=0.0) <= tol
    active = ~converged & (max_iter > 0)
    while active.any():
        idx = np.flatnonzero(active)
        with np.errstate(all="ignore"):
            trial = theta[idx] + step(theta[idx], r[idx], lam[idx], idx)
            if project is not None:
                trial = project(trial)
            r_trial = residual(trial, idx)
        f_trial = (r_trial**2).sum(1)
        iterations[idx] += 1
        accept = f_trial < f[idx]  # NaN: rejected
        acc, rej = idx[accept], idx[~accept]
        if stall is not None:
            converged[acc] |= (f[acc] - f_trial[accept]) < stall * f[acc]
        theta[acc], r[acc], f[acc] = trial[accept], r_trial[accept], f_trial[accept]
        lam[acc] = np.maximum(lam[acc] / 10.0, LAMBDA_MIN)
        lam[rej] = np.where(lam[rej] == 0.0, LAMBDA_0, 10.0 * lam[rej])
        converged[idx] |= np.abs(r[idx]).max(1) <= tol
        active[idx] = ~converged[idx] & (iterations[idx] < max_iter) & (lam[idx] <= LAMBDA_MAX)
    return dict(theta=theta, converged=converged, iterations=iterations, residual=np.abs(r).max(1, initial=0.0))


def solve_rows(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise ``A x = b`` (``A (k, n, n)``, ``b (k, n)``); a singular row gives NaN (its
    trial is then rejected) instead of failing the batch."""
    try:
        return np.linalg.solve(A, b[..., None])[..., 0]
    except np.linalg.LinAlgError:
        x = np.full(b.shape, np.nan)
        for i in range(A.shape[0]):
            try:
                x[i] = np.linalg.solve(A[i], b[i])
            except np.linalg.LinAlgError:
                pass
        return x


def seeds(robot: Robot, seed, N: int) -> np.ndarray:
    """The seeds ``(N, n)`` rad of a batch: ``seed (N, n)`` or ``(n,)``, default 0 (a copy)."""
    if seed is None:
        return np.zeros((N, robot.n))
    s = np.array(seed, dtype=float)
    if s.ndim == 1:
        s = np.tile(s, (N, 1))
    if s.shape != (N, robot.n):
        raise ValueError(f"seed must have shape ({N}, {robot.n}) or ({robot.n},), got {np.shape(seed)}")
    return s


def _box(robot: Robot, enforce_limits: bool):
    lo, hi = robot.joint_limits[:, 0], robot.joint_limits[:, 1]
    return (lambda th: np.clip(th, lo, hi)) if enforce_limits else None


# --------------------------------------------------------------------------
# The cable solve
# --------------------------------------------------------------------------
def solve_cables(robot: Robot, lengths, seed=None, tol=1e-12, max_iter=100, enforce_limits=False) -> dict:
    """Commanded lengths of the position-controlled cables -> joint angles.

    ``lengths (N, m_pos)`` m (the order of :func:`.robot.position_cables`; planar:
    the upper cables); ``seed (N, n)`` or ``(n,)`` rad, default 0.  Damped Newton on
    ``r = L_pos(theta) - L_cmd`` from ``lambda_0 = 0``: with as many position cables
    as joints the step is Newton's, ``J delta = -r``, while ``lambda <= 1e-12``, else
    ``delta = -(J^T J + lambda I)^-1 J^T r``, converged when ``max|r| <= tol``; with
    more (least squares) always the normal equations, converged also when an accepted
    step lowers ``|r|^2`` by less than ``1e-12`` of itself.  ``enforce_limits``: every
    trial projected onto the joint box.

    Returns ``theta (N, n)`` rad, ``converged (N,)``, ``iterations (N,)`` (trials),
    ``residual (N,)`` m (``max|r|``: the misfit of inconsistent lengths),
    ``within_limits (N,)``.
    """
    robot = as_robot(robot)
    pos = position_cables(robot)
    L = np.asarray(lengths, dtype=float)
    if L.ndim != 2 or L.shape[1] != pos.size:
        raise ValueError(f"lengths must have shape (N, {pos.size}), got {L.shape}")
    theta = seeds(robot, seed, L.shape[0])
    square = pos.size == robot.n

    def residual(th, idx):
        return position_lengths(robot, th) - L[idx]

    def step(th, r, lam, idx):
        J = cable_jacobian(robot, th)[:, pos, :]
        newton = (lam <= LAMBDA_MIN) if square else np.zeros(lam.shape, dtype=bool)
        delta = np.empty(th.shape)
        if newton.any():
            delta[newton] = -solve_rows(J[newton], r[newton])
        Jt = np.swapaxes(J[~newton], 1, 2)
        A = Jt @ J[~newton] + lam[~newton, None, None] * np.eye(robot.n)
        delta[~newton] = -solve_rows(A, (Jt @ r[~newton, :, None])[..., 0])
        return delta

    sol = levenberg_marquardt(residual, step, theta, tol, max_iter, lambda0=0.0, project=_box(robot, enforce_limits),
                              stall=None if square else STALL)
    sol["within_limits"] = within_limits(robot, sol["theta"])
    return sol


# --------------------------------------------------------------------------
# Pose IK
# --------------------------------------------------------------------------
def _damped_step(J: np.ndarray, r: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """The damped minimal-norm step of the pose IK, row-wise: ``-J^T (J J^T + lambda I)^-1 r``
    while the rows of ``J (k, rows, n)`` are no more than the joints, the same step in its
    ``n x n`` form ``-(J^T J + lambda I)^-1 J^T r`` beyond (``J J^T`` is singular there)."""
    Jt = np.swapaxes(J, 1, 2)
    if J.shape[1] <= J.shape[2]:
        y = solve_rows(J @ Jt + lam[:, None, None] * np.eye(J.shape[1]), r)
        return -(Jt @ y[..., None])[..., 0]
    return -solve_rows(Jt @ J + lam[:, None, None] * np.eye(J.shape[2]), (Jt @ r[..., None])[..., 0])


def _ik_mask(kind, mask) -> tuple:
    """``(position weights (dim,), rotation form, rotation weight)`` of an IK mask: a name of
    the kind's masks, or (an angle attitude) ``dim + 1`` weights on the task's coordinates."""
    if isinstance(mask, str):
        if mask not in kind.masks:
            raise ValueError(f"mask must be one of {tuple(kind.masks)}, got {mask!r}")
        return kind.masks[mask]
    w = np.asarray(mask, dtype=float).ravel()
    if kind.rotation != "angle" or w.size != kind.dim + 1:
        raise ValueError(f"mask must be one of {tuple(kind.masks)}"
                         + (f" or {kind.dim + 1} weights" if kind.rotation == "angle" else "") + f", got {mask!r}")
    return tuple(w[:kind.dim]), ("angle" if w[kind.dim] != 0.0 else "free"), float(w[kind.dim])


def _ik_rows(robot: Robot, target: np.ndarray, mask):
    """Residual and Jacobian of the pose IK (``docs/model.md``, ``docs/spatial.md``
    "Solves"), over the rows the mask keeps: the weighted position rows ``w_i (p_i -
    p_t,i)`` and, by the mask's rotation form, none (``"free"``), the angle's ``w (phi -
    phi_t)`` (``"angle"``, the unwrapped ``phi = sum(theta)``), the pointing direction's
    ``d - d_t`` (``d = R e_x``, ``"pointing"``) or the rotation error ``R_t log(R_t^T R)``
    (``"log"``); the geometric Jacobian (``w_j x (p - p_j)``, ``w_j x d``, ``w_j``)."""
    kind = robot.kind
    width = len(kind.task_rows)
    if target.ndim != 2 or target.shape[1] != width:
        raise ValueError(f"target must have shape (N, {width}), got {target.shape}")
    wp, form, wr = _ik_mask(kind, mask)
    wp = np.asarray(wp, dtype=float)
    on = wp != 0.0
    target_p = target[:, :kind.dim]
    target_R = exp_so3(target[:, kind.dim:]) if form in ("pointing", "log") else None

    def rows(th, idx, jacobian):
        ch = chain_frames(robot, th)
        p, R, w = ch["tb"][:, -1], ch["Rb"][:, -1], ch["w"]
        r = [(p[:, :kind.dim] - target_p[idx])[:, on] * wp[on]]
        J = [np.swapaxes(cross(w, p[:, None, :] - ch["p"]), 1, 2)[:, :kind.dim][:, on] * wp[on, None]]
        if form == "angle":
            r.append(wr * (th.sum(axis=1, keepdims=True) - target[idx, kind.dim:]))
            J.append(wr * w[:, None, :, 2])
        elif form == "pointing":
            r.append(wr * (R[:, :, 0] - target_R[idx, :, 0]))
            J.append(wr * np.swapaxes(cross(w, R[:, None, :, 0]), 1, 2))
        elif form == "log":
            tR = target_R[idx]
            r.append(wr * np.einsum("nij,nj->ni", tR, log_so3(np.swapaxes(tR, 1, 2) @ R)))
            J.append(wr * np.swapaxes(w, 1, 2))
        return np.concatenate(r, axis=1), (np.concatenate(J, axis=1) if jacobian else None)

    return rows


def ik(robot: Robot, target, seed=None, mask=None, tol=1e-12, max_iter=100, enforce_limits=False) -> dict:
    """Pose IK by damped least squares (``docs/model.md``, ``docs/spatial.md`` "Solves").

    ``target``: planar ``(N, 3)`` ``[x m, y m, phi rad]``, spatial ``(N, 6)``
    ``[x, y, z]`` m and a rotation vector rad of the end frame.  ``mask``: planar
    ``"pose"`` (default), ``"position"`` or three weights on the ``x, y, phi``
    residuals; spatial ``"position"``, ``"pointing"`` or ``"pose"`` (default).
    Minimal-norm damped step ``-J^T (J J^T + lambda I)^-1 r`` from ``lambda_0 =
    1e-3`` (the same step ``-(J^T J + lambda I)^-1 J^T r`` with more rows than
    joints, :func:`_damped_step`), default seed 0; ``enforce_limits``: every trial projected onto the
    joint box.  Returns the dict of :func:`solve_cables` (``residual``: max of the
    masked rows, m and rad mixed).
    """
    robot = as_robot(robot)
    tg = np.asarray(target, dtype=float)
    rows = _ik_rows(robot, tg, robot.kind.default_mask if mask is None else mask)
    theta = seeds(robot, seed, tg.shape[0])

    def residual(th, idx):
        return rows(th, idx, False)[0]

    def step(th, r, lam, idx):
        return _damped_step(rows(th, idx, True)[1], r, lam)

    sol = levenberg_marquardt(residual, step, theta, tol, max_iter, project=_box(robot, enforce_limits))
    sol["within_limits"] = within_limits(robot, sol["theta"])
    return sol


# --------------------------------------------------------------------------
# Error scenarios and sensitivities
# --------------------------------------------------------------------------
def deviation(robot: Robot, theta0, dL, arm=None, tol=1e-12, max_iter=100) -> dict:
    """Tip deviation caused by cable-length errors and an erroneous arm (paper Fig. 3).

    ``theta0 (N, n)`` rad: the nominal configurations; ``dL (m_pos,)`` or ``(N, m_pos)``
    m: errors of the position-cable lengths; ``arm``: the erroneous arm (default the
    nominal one), e.g. :func:`.robot.hole_height_error` of it.  The nominal lengths
    ``L0 = L_pos(theta0)`` plus ``dL`` are solved on ``arm`` (:func:`solve_cables`, seed
    ``theta0``).  Returns ``dS`` (planar ``(N, 3)``: the change of ``[x, y, phi]``;
    spatial ``(N, 6)``: ``[dp, R0 log(R0^T R)]``, m and rad), ``theta (N, n)`` rad and
    ``converged (N,)``.
    """
    robot = as_robot(robot)
    theta0 = as_theta(robot, theta0)
    target = position_lengths(robot, theta0) + np.asarray(dL, dtype=float)
    sol = solve_cables(robot if arm is None else as_robot(arm), target, seed=theta0, tol=tol, max_iter=max_iter)
    a, b = chain_frames(robot, theta0), chain_frames(robot, sol["theta"])
    dS = np.concatenate([(b["tb"][:, -1] - a["tb"][:, -1])[:, :robot.kind.dim],
                         robot.kind.attitude_change(a["Rb"][:, -1], b["Rb"][:, -1], theta0, sol["theta"])], axis=1)
    return dict(dS=dS, theta=sol["theta"], converged=sol["converged"])


def tip_sensitivity(robot: Robot, theta) -> dict:
    """First-order sensitivities of the task vector at ``theta (N, n)`` rad
    (``docs/model.md``, "Sensitivities"): the position cables hold their lengths, so
    ``dtheta = (J_p^T J_p)^-1 J_p^T dL`` (``J_p^-1`` when square).

    Returns ``cable (N, t, m_pos)``: dS/dL (m/m; rad/m for the rotation rows, the
    spatial ones as an angular velocity); ``holes (N, t, 3H)``: dS/d(every hole
    coordinate) in the layout of :func:`.kinematics.cable_hole_gradient` (0 for
    force cables' holes); ``pair (N, t, K)``: dS/d(hole height of disk k), the
    paper's ``dh`` (:func:`.robot.hole_height_error`: every hole of the cables
    ending at disk ``k`` along its ``y``, position cables ``+``, force cables ``-``).
    """
    robot = as_robot(robot)
    theta = as_theta(robot, theta)
    pos = position_cables(robot)
    Jp = cable_jacobian(robot, theta)[:, pos]  # (N, m_pos, n)
    if pos.size == robot.n:
        dtheta = np.linalg.solve(Jp, np.broadcast_to(np.eye(robot.n), Jp.shape))
    else:
        Jt = np.swapaxes(Jp, 1, 2)
        dtheta = np.linalg.solve(Jt @ Jp, Jt)
    cable = fk_jacobian(robot, theta) @ dtheta  # (N, t, m_pos)
    holes = -np.einsum("ntp,npH->ntH", cable, cable_hole_gradient(robot, theta)[:, pos])
    starts = np.cumsum([0] + [3 * h.shape[0] for h in robot.holes])
    pair = np.zeros(holes.shape[:2] + (robot.disks,))
    for c, h in enumerate(robot.holes):
        sign = 1.0 if robot.cable_mode[c] == "position" else -1.0
        y = holes[:, :, starts[c] + 1:starts[c + 1]:3]  # the y coordinates of cable c's holes
        pair[:, :, robot.cable_end[c] - 1] += sign * y.sum(axis=2)
    return dict(cable=cable, holes=holes, pair=pair)
