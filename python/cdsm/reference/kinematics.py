"""Independent, vectorised NumPy reference implementation of ``docs/model.md``.

This module is written from ``docs/model.md`` alone and is used to cross-check
the Rust core (``cdsm.Robot``) in the test-suite.  It is deliberately simple
and readable rather than fast; every batch function is vectorised over the
batch dimension ``N`` (Python loops run only over the ``n`` joints or over
solver iterations).

Robots are duck-typed: every function reads only these attributes of
``robot`` (all SI; anything array-like is accepted):

=================  ===================  ==========================================
attribute          shape                meaning
=================  ===================  ==========================================
``n``              int                  number of joints / disks
``link_before``    ``(n,)``             m, link from disk ``i-1`` to joint ``i``
``link_after``     ``(n,)``             m, link from joint ``i`` to disk ``i``
``thickness``      ``(n,)``             m, thickness of disk ``i`` (``B``)
``holes``          ``(2n, n+1, 2, 2)``  m, ``holes[c, d, f] = (x, y)``
``joint_limits``   ``(n, 2)``           rad, ``[lo, hi]`` per joint
=================  ===================  ==========================================

so both :class:`.robot.Robot` (through its planar view) and ``cdsm.Robot`` can be passed.

Conventions (see ``docs/model.md``): cables ``c = 0 .. 2n-1``; cable ``c``
belongs to pair ``i = c // 2 + 1`` (1-based disk index), even ``c`` is the
upper cable (hole at ``+h_i``), odd ``c`` the lower one.  Pair ``i`` crosses
the base disk (face ``b`` only) and disks ``1..i`` (both faces).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .robot import Robot, as_robot, used_hole_mask

__all__ = [
    "wrap_angle",
    "fk",
    "fk_jacobian",
    "cable_lengths",
    "upper_cable_lengths",
    "cable_jacobian",
    "upper_cable_jacobian",
    "segment_coefficients",
    "segment_lengths",
    "ik",
    "ik_closed_form",
    "solve_cables",
    "solve_cables_closed_form",
    "deviation",
    "hole_height_error",
    "hole_points",
]

# LM constants of docs/model.md.
_LAMBDA_0 = 1e-3
_LAMBDA_MIN = 1e-12
_LAMBDA_MAX = 1e12


# --------------------------------------------------------------------------
# Robot description
# --------------------------------------------------------------------------
def planar_attributes(robot):
    """The planar attributes of ``robot``: its :class:`.robot.PlanarView` when it is a
    :class:`.robot.Robot`, else the object itself (duck-typed, e.g. ``cdsm.Robot``)."""
    return robot.planar if isinstance(robot, Robot) else robot


@dataclass
class _Geometry:
    n: int
    lb: np.ndarray
    la: np.ndarray
    t: np.ndarray
    holes: np.ndarray
    limits: np.ndarray


def read_geometry(robot) -> _Geometry:
    """Read the duck-typed robot attributes once, as float arrays."""
    robot = planar_attributes(robot)
    n = int(robot.n)
    if n < 1:
        raise ValueError(f"robot.n must be >= 1, got {n}")
    return _Geometry(
        n=n,
        lb=np.asarray(robot.link_before, dtype=float).reshape(n),
        la=np.asarray(robot.link_after, dtype=float).reshape(n),
        t=np.asarray(robot.thickness, dtype=float).reshape(n),
        holes=np.asarray(robot.holes, dtype=float).reshape(2 * n, n + 1, 2, 2),
        limits=np.asarray(robot.joint_limits, dtype=float).reshape(n, 2),
    )


def batch_array(a, width: int, name: str) -> np.ndarray:
    """``a`` as a float64 ``(N, width)`` array (no 1-D convenience here)."""
    arr = np.asarray(a, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name} must have shape (N, {width}), got {arr.shape}")
    return arr


def wrap_angle(x):
    """Wrap angles (rad) to the interval ``(-pi, pi]``."""
    x = np.asarray(x, dtype=float)
    return np.pi - np.mod(np.pi - x, 2.0 * np.pi)


# --------------------------------------------------------------------------
# Forward kinematics (Eq. 1-3)
# --------------------------------------------------------------------------
def _chain(g: _Geometry, theta: np.ndarray):
    """Per-linkage position increments of the chain.

    Returns ``inc_b`` and ``inc_a``, both ``(N, n, 2)`` m: the vector of
    ``link_before[k]`` (direction ``alpha_{k-1}``) and of
    ``link_after[k] + thickness[k]`` (direction ``alpha_k``), where
    ``alpha_k = theta_1 + ... + theta_k``.
    """
    alpha = np.cumsum(theta, axis=1)
    alpha_prev = np.concatenate([np.zeros_like(alpha[:, :1]), alpha[:, :-1]], axis=1)
    inc_b = g.lb[None, :, None] * np.stack([np.cos(alpha_prev), np.sin(alpha_prev)], -1)
    inc_a = (g.la + g.t)[None, :, None] * np.stack([np.cos(alpha), np.sin(alpha)], -1)
    return inc_b, inc_a


def fk(robot, theta) -> np.ndarray:
    """End pose ``S = [X, Y, phi]`` (m, m, rad), shape ``(N, 3)``.

    ``theta``: joint angles, rad, shape ``(N, n)``.
    """
    g = read_geometry(robot)
    theta = batch_array(theta, g.n, "theta")
    inc_b, inc_a = _chain(g, theta)
    pos = (inc_b + inc_a).sum(axis=1)
    return np.concatenate([pos, theta.sum(axis=1, keepdims=True)], axis=1)


def fk_jacobian(robot, theta) -> np.ndarray:
    """Analytic ``dS/dtheta``, shape ``(N, 3, n)`` (rows m/rad, m/rad, 1).

    Column ``j`` is ``[-(Y - Jy_j), X - Jx_j, 1]`` with ``J_j`` the position of
    joint ``j``; ``P - J_j`` is accumulated distally (no cancellation).
    """
    g = read_geometry(robot)
    theta = batch_array(theta, g.n, "theta")
    inc_b, inc_a = _chain(g, theta)
    inc = inc_b + inc_a
    # rev[:, j] = sum_{k >= j} inc[:, k]; tail_j = inc_a_j + rev_{j+1} = P - J_j.
    rev = np.flip(np.cumsum(np.flip(inc, axis=1), axis=1), axis=1)
    rev_next = np.concatenate([rev[:, 1:], np.zeros_like(rev[:, :1])], axis=1)
    tail = inc_a + rev_next
    jac = np.empty((theta.shape[0], 3, g.n))
    jac[:, 0, :] = -tail[..., 1]
    jac[:, 1, :] = tail[..., 0]
    jac[:, 2, :] = 1.0
    return jac


# --------------------------------------------------------------------------
# Cable lengths (Eq. 4-5)
# --------------------------------------------------------------------------
def _segment_vectors(g: _Geometry):
    """``u``, ``w`` ``(2n, n, 2)`` m and the segment mask ``(2n, n)``.

    Segment ``k`` (0-based ``k`` here, the model's ``k+1``) of cable ``c`` runs
    from ``p = holes[c, k, 1]`` to ``A = w + Rot(theta_k) u`` + p, with
    ``u = holes[c, k+1, 0] + (link_after[k], 0)`` and
    ``w = (link_before[k], 0) - p``.
    """
    n = g.n
    p = g.holes[:, :n, 1, :]  # (2n, n, 2): distal face of disk k-1
    q = g.holes[:, 1:, 0, :]  # (2n, n, 2): proximal face of disk k
    u = q.copy()
    u[..., 0] += g.la[None, :]
    w = -p
    w[..., 0] += g.lb[None, :]
    pair = np.arange(2 * n) // 2 + 1
    mask = np.arange(1, n + 1)[None, :] <= pair[:, None]
    return u, w, mask


def _segment_pqr(g: _Geometry):
    """``P, Q, R`` ``(2n, n)`` with ``s^2 = P + Q cos(theta_k) + R sin(theta_k)``."""
    u, w, mask = _segment_vectors(g)
    P = (w**2).sum(-1) + (u**2).sum(-1)
    Q = 2.0 * (w * u).sum(-1)
    R = 2.0 * (w[..., 1] * u[..., 0] - w[..., 0] * u[..., 1])
    return P, Q, R, mask


def _traversals(g: _Geometry) -> np.ndarray:
    """Constant part of each cable length, ``(2n,)`` m: sum of disk traversals."""
    a = g.holes[:, 1:, 0, :]  # (2n, n, 2) proximal face of disk k
    b = g.holes[:, 1:, 1, :]  # distal face, in its own frame
    d = b.copy()
    d[..., 0] += g.t[None, :]
    trav = np.hypot(d[..., 0] - a[..., 0], d[..., 1] - a[..., 1])  # (2n, n)
    _, _, mask = _segment_vectors(g)
    return np.where(mask, trav, 0.0).sum(axis=1)


def _segments(g: _Geometry, theta: np.ndarray):
    """Segment lengths ``s`` and ``ds/dtheta_k``, both ``(N, 2n, n)``, masked."""
    u, w, mask = _segment_vectors(g)
    c = np.cos(theta)[:, None, :]
    s_ = np.sin(theta)[:, None, :]
    vx = u[None, ..., 0] * c - u[None, ..., 1] * s_  # Rot(theta) u
    vy = u[None, ..., 0] * s_ + u[None, ..., 1] * c
    ax = w[None, ..., 0] + vx  # A - p
    ay = w[None, ..., 1] + vy
    s = np.hypot(ax, ay)
    ds = (-ax * vy + ay * vx) / s
    s = np.where(mask[None], s, 0.0)
    ds = np.where(mask[None], ds, 0.0)
    return s, ds


def segment_coefficients(robot):
    """``P, Q, R`` ``(2n, n)`` (m^2) with ``s^2 = P + Q cos(theta_k) + R sin(theta_k)``
    for segment ``k`` of cable ``c``, and the mask ``(2n, n)`` of the segments a
    cable has."""
    return _segment_pqr(read_geometry(robot))


def segment_lengths(robot, theta):
    """Segment lengths ``s`` (m) and ``ds/dtheta_k`` (m/rad), both ``(N, 2n, n)``,
    zero where a cable has no segment; ``theta (N, n)`` rad."""
    g = read_geometry(robot)
    return _segments(g, batch_array(theta, g.n, "theta"))


def cable_lengths(robot, theta) -> np.ndarray:
    """All cable lengths, m, shape ``(N, 2n)`` (upper 1, lower 1, upper 2, ...).

    ``theta``: rad, ``(N, n)``.
    """
    g = read_geometry(robot)
    theta = batch_array(theta, g.n, "theta")
    s, _ = _segments(g, theta)
    return s.sum(axis=2) + _traversals(g)[None, :]


def cable_jacobian(robot, theta) -> np.ndarray:
    """Analytic ``dL/dtheta``, m/rad, shape ``(N, 2n, n)``.

    ``d s_k / d theta_k = (A - p) x d(Rot u)/d theta / s_k``; cable ``c`` of
    pair ``i`` depends on ``theta_1..theta_i`` only.
    """
    g = read_geometry(robot)
    theta = batch_array(theta, g.n, "theta")
    _, ds = _segments(g, theta)
    return ds


def upper_cable_lengths(robot, theta) -> np.ndarray:
    """Upper (position-controlled) cable lengths, m, ``(N, n)``."""
    return cable_lengths(robot, theta)[:, 0::2]


def upper_cable_jacobian(robot, theta) -> np.ndarray:
    """``dL_upper/dtheta``, m/rad, ``(N, n, n)``, lower triangular."""
    return cable_jacobian(robot, theta)[:, 0::2, :]


# --------------------------------------------------------------------------
# Levenberg-Marquardt (docs/model.md, "Solves")
# --------------------------------------------------------------------------
def levenberg_marquardt(residual, step, theta, tol, max_iter, project=None, lambda0=_LAMBDA_0):
    """Vectorised LM loop shared by the pose IK and the cable solve.

    ``residual(theta, idx) -> r (k, m)`` for the batch rows ``idx``;
    ``step(theta, r, lam, idx) -> delta (k, n)``; ``project`` maps a trial onto
    the joint box (or None).  Each batch element has its own lambda (starting
    at ``lambda0``; a rejected step at lambda 0 goes on at 1e-3) and stops
    independently: converged when ``max|r| <= tol``, failed after ``max_iter``
    trials or when ``lambda > 1e12``.  Returns the solution dict.
    """
    N = theta.shape[0]
    all_idx = np.arange(N)
    r = residual(theta, all_idx)
    f = (r**2).sum(axis=1)
    lam = np.full(N, float(lambda0))
    iterations = np.zeros(N, dtype=np.int64)
    converged = np.abs(r).max(axis=1, initial=0.0) <= tol
    active = ~converged & (iterations < max_iter)
    while active.any():
        idx = np.flatnonzero(active)
        trial = theta[idx] + step(theta[idx], r[idx], lam[idx], idx)
        if project is not None:
            trial = project(trial)
        r_trial = residual(trial, idx)
        f_trial = (r_trial**2).sum(axis=1)
        iterations[idx] += 1
        accept = f_trial < f[idx]  # NaN compares False: rejected
        acc, rej = idx[accept], idx[~accept]
        theta[acc] = trial[accept]
        r[acc] = r_trial[accept]
        f[acc] = f_trial[accept]
        lam[acc] = np.maximum(lam[acc] / 10.0, _LAMBDA_MIN)
        lam[rej] = np.where(lam[rej] == 0.0, _LAMBDA_0, lam[rej] * 10.0)
        converged[idx] = np.abs(r[idx]).max(axis=1) <= tol
        active[idx] = ~converged[idx] & (iterations[idx] < max_iter) & (lam[idx] <= _LAMBDA_MAX)
    return dict(
        theta=theta,
        converged=converged,
        iterations=iterations,
        residual=np.abs(r).max(axis=1, initial=0.0),
    )


def batched_solve(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve ``A x = b`` for a stack ``A (k, m, m)``, ``b (k, m)``.

    A singular matrix gives a NaN row (the trial is then rejected and lambda
    raised) instead of failing the whole batch.
    """
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


def _seed(seed, N: int, n: int) -> np.ndarray:
    if seed is None:
        return np.zeros((N, n))
    seed = np.array(seed, dtype=float)  # copy: the solver updates it in place
    if seed.ndim == 1:
        seed = np.tile(seed, (N, 1))
    seed = batch_array(seed, n, "seed")
    if seed.shape[0] != N:
        raise ValueError(f"seed must have shape ({N}, {n}), got {seed.shape}")
    return seed.copy()


def _within_limits(g: _Geometry, theta: np.ndarray) -> np.ndarray:
    lo, hi = g.limits[:, 0], g.limits[:, 1]
    return np.all((theta >= lo) & (theta <= hi), axis=1)


def ik(robot, pose, seed=None, tol=1e-12, max_iter=100, enforce_limits=False) -> dict:
    """Pose IK by LM on ``r = pose - fk(theta)`` (docs/model.md).

    ``pose``: ``(N, 3)`` ``[X m, Y m, phi rad]``; ``seed``: ``(N, n)`` or
    ``(n,)`` rad, default zeros.  Step
    ``delta = J^T (J J^T + lambda I_3)^{-1} r``, or the same step as
    ``(J^T J + lambda I_n)^{-1} J^T r`` for an arm of fewer than 3 joints.  Returns a dict with
    ``theta (N, n)`` rad, ``converged (N,)`` bool, ``iterations (N,)`` int
    (number of trials), ``residual (N,)`` = ``max|r|`` of the final iterate,
    ``within_limits (N,)`` bool.
    """
    g = read_geometry(robot)
    pose = batch_array(pose, 3, "pose")
    theta = _seed(seed, pose.shape[0], g.n)

    def residual(th, idx):
        return pose[idx] - fk(robot, th)

    def step(th, r, lam, idx):
        J = fk_jacobian(robot, th)  # (k, 3, n)
        Jt = np.swapaxes(J, 1, 2)
        if g.n < 3:
            # more pose coordinates than joints: J J^T is singular, so the
            # same step in its n x n form, (J^T J + lambda I_n)^{-1} J^T r
            A = Jt @ J + lam[:, None, None] * np.eye(g.n)
            return batched_solve(A, (Jt @ r[..., None])[..., 0])
        A = J @ Jt + lam[:, None, None] * np.eye(3)
        y = batched_solve(A, r)
        return (Jt @ y[..., None])[..., 0]

    lo, hi = g.limits[:, 0], g.limits[:, 1]
    project = (lambda th: np.clip(th, lo, hi)) if enforce_limits else None

    sol = levenberg_marquardt(residual, step, theta, tol, max_iter, project)
    sol["within_limits"] = _within_limits(g, sol["theta"])
    return sol


def _whole_turns_near(angle: np.ndarray, seed: np.ndarray) -> np.ndarray:
    """``angle`` moved by whole turns (rad) so that ``angle - seed`` lies in ``(-pi, pi]``.

    The shift is ``2 pi k`` with an integer ``k`` (the smallest ``k`` with
    ``angle - seed - 2 pi k <= pi``), applied to ``angle`` itself.
    """
    d = angle - seed
    k = np.ceil((d - np.pi) / (2.0 * np.pi))
    out = angle - 2.0 * np.pi * k
    # Guard the rounding at the interval ends (keeps (-pi, pi] exact in float).
    out = np.where(out - seed > np.pi, out - 2.0 * np.pi, out)
    out = np.where(out - seed <= -np.pi, out + 2.0 * np.pi, out)
    return out


def ik_closed_form(robot, pose, seed=None, tol=1e-12, enforce_limits=False) -> dict:
    """Closed-form full-pose IK of a 3-joint arm (docs/model.md, "Closed-form pose IK").

    ``pose``: ``(N, 3)`` ``[X m, Y m, phi rad]``; ``seed``: ``(N, 3)`` or
    ``(3,)`` rad, default zeros.  With ``r1 = link_after[1] + thickness[1] +
    link_before[2]``, ``r2 = link_after[2] + thickness[2] + link_before[3]``,
    ``a3 = link_after[3] + thickness[3]`` (m), the wrist (joint 3) is
    ``W = (X - a3 cos phi, Y - a3 sin phi)`` and, from joint 1 at
    ``(link_before[1], 0)``, ``c2 = (|W - J1|^2 - r1^2 - r2^2) / (2 r1 r2)``.
    Branches ``s = +1, -1``: ``theta_2 = s acos(c2)``, ``theta_1 =
    atan2(dy, dx) - atan2(r2 sin theta_2, r1 + r2 cos theta_2)``, both moved by
    whole turns to within pi of the seed, then ``theta_3 = phi - theta_1 -
    theta_2``.  The branch nearest the seed (sum of squared differences) wins;
    a tie (within ``1e-12 (1 + |seed|^2)``) goes to the ``s = -1`` branch
    (``theta_2 = -acos(c2) <= 0`` before the turn shift).  With
    ``enforce_limits`` a branch outside the joint box is dropped first; if
    both are, the nearest is returned with reason ``"outside limits"``.
    ``|c2| > 1``: reason ``"unreachable"``, ``theta`` = seed.

    Returns a dict with ``theta (N, 3)`` rad, ``converged (N,)`` bool,
    ``iterations (N,)`` int (all 0), ``residual (N,)`` = ``max|fk(theta) -
    pose|`` over X, Y (m) and phi (rad), ``within_limits (N,)`` bool and
    ``reason (N,)`` str (``"converged"``, ``"unreachable"``, ``"outside
    limits"``, and ``"singular"`` for a reachable answer whose residual
    exceeds ``tol``).
    """
    g = read_geometry(robot)
    if g.n != 3:
        raise ValueError(f"ik_closed_form needs a 3-joint robot, got n = {g.n}")
    pose = batch_array(pose, 3, "pose")
    N = pose.shape[0]
    seed = _seed(seed, N, 3)
    x, y, phi = pose[:, 0], pose[:, 1], pose[:, 2]

    r1 = g.la[0] + g.t[0] + g.lb[1]
    r2 = g.la[1] + g.t[1] + g.lb[2]
    a3 = g.la[2] + g.t[2]
    dx = x - a3 * np.cos(phi) - g.lb[0]
    dy = y - a3 * np.sin(phi)
    c2 = (dx**2 + dy**2 - r1**2 - r2**2) / (2.0 * r1 * r2)
    reachable = np.abs(c2) <= 1.0  # NaN: not reachable

    acos = np.arccos(np.where(reachable, c2, 0.0))
    # Branch axis: index 0 is s = -1 (theta_2 <= 0, the paper's), index 1 is s = +1.
    s = np.array([-1.0, 1.0])
    th2 = s[None, :] * acos[:, None]  # (N, 2)
    th1 = np.arctan2(dy, dx)[:, None] - np.arctan2(r2 * np.sin(th2), r1 + r2 * np.cos(th2))
    th1 = _whole_turns_near(th1, seed[:, :1])
    th2 = _whole_turns_near(th2, seed[:, 1:2])
    th3 = phi[:, None] - th1 - th2
    branches = np.stack([th1, th2, th3], axis=-1)  # (N, 2, 3)

    dist = ((branches - seed[:, None, :]) ** 2).sum(axis=-1)  # (N, 2) rad^2
    inside = np.stack([_within_limits(g, branches[:, b]) for b in range(2)], axis=1)
    allowed = inside if enforce_limits else np.ones_like(inside)
    none_allowed = ~allowed.any(axis=1)
    allowed = np.where(none_allowed[:, None], True, allowed)  # both dropped: nearest of both
    band = 1e-12 * (1.0 + (seed**2).sum(axis=1))
    tie = np.abs(dist[:, 0] - dist[:, 1]) <= band
    plus_nearer = dist[:, 1] < dist[:, 0]
    pick_plus = np.where(
        allowed[:, 0] & allowed[:, 1], plus_nearer & ~tie, allowed[:, 1]
    )  # one allowed: that one
    chosen = branches[np.arange(N), pick_plus.astype(int)]

    theta = np.where(reachable[:, None], chosen, seed)
    residual = np.abs(fk(robot, theta) - pose).max(axis=1)
    outside = reachable & enforce_limits & none_allowed
    converged = reachable & ~outside & (residual <= tol)
    reason = np.where(converged, "converged",
                      np.where(outside, "outside limits",
                               np.where(reachable, "singular", "unreachable"))).astype(object)
    return dict(
        theta=theta,
        converged=converged,
        iterations=np.zeros(N, dtype=np.int64),
        residual=residual,
        within_limits=_within_limits(g, theta),
        reason=reason,
    )


def solve_cables(robot, upper, seed=None, tol=1e-12, max_iter=100) -> dict:
    """Upper cable lengths -> joint angles by damped Newton (docs/model.md).

    ``upper``: target upper-cable lengths ``(N, n)`` m; ``seed``: ``(N, n)`` or
    ``(n,)`` rad, default zeros.  ``r = L_target - L_upper(theta)``, starting
    undamped: the Newton step ``J delta = r`` while ``lambda <= 1e-12``,
    otherwise ``delta = (J^T J + lambda I_n)^{-1} J^T r``.  Returns the same
    dict as :func:`ik`.
    """
    g = read_geometry(robot)
    upper = batch_array(upper, g.n, "upper")
    theta = _seed(seed, upper.shape[0], g.n)

    def residual(th, idx):
        return upper[idx] - upper_cable_lengths(robot, th)

    def step(th, r, lam, idx):
        J = upper_cable_jacobian(robot, th)  # (k, n, n)
        Jt = np.swapaxes(J, 1, 2)
        A = Jt @ J + lam[:, None, None] * np.eye(g.n)
        damped = batched_solve(A, (Jt @ r[..., None])[..., 0])
        newton = batched_solve(J, r)
        return np.where((lam <= _LAMBDA_MIN)[:, None], newton, damped)

    sol = levenberg_marquardt(residual, step, theta, tol, max_iter, lambda0=0.0)
    sol["within_limits"] = _within_limits(g, sol["theta"])
    return sol


def solve_cables_closed_form(robot, upper, seed=None) -> dict:
    """Closed-form cable solve, joint by joint (k = 1..n).

    With ``theta_1..theta_{k-1}`` known, the remaining length of upper cable
    ``k`` fixes ``s_k``; ``P + Q cos + R sin = s_k^2`` gives
    ``theta_k = atan2(R, Q) +- acos((s_k^2 - P) / hypot(Q, R))``.  Of the real
    branches the one nearest the seed (difference wrapped to ``(-pi, pi]``) is
    taken and returned as ``seed + wrapped difference``.

    ``upper``: ``(N, n)`` m; ``seed``: ``(N, n)``/``(n,)`` rad, default zeros.
    Returns ``theta (N, n)`` rad (NaN from the first joint without a real
    branch on), ``converged (N,)`` (every joint had a real branch),
    ``residual (N,)`` ``max|L_target - L_upper(theta)|`` m (inf when not
    converged), ``n_branches (N, n)`` int (0, 1 or 2 distinct real branches;
    0 for joints after a failed one).
    """
    g = read_geometry(robot)
    upper = batch_array(upper, g.n, "upper")
    N = upper.shape[0]
    seed = _seed(seed, N, g.n)
    P, Q, R, _ = _segment_pqr(g)
    trav = _traversals(g)[0::2]  # (n,) upper cables
    Pu, Qu, Ru = P[0::2], Q[0::2], R[0::2]  # (n cables, n segments)
    u, w, _ = _segment_vectors(g)

    theta = np.full((N, g.n), np.nan)
    n_branches = np.zeros((N, g.n), dtype=np.int64)
    ok = np.ones(N, dtype=bool)
    for k in range(g.n):
        # Length already used by segments 1..k-1 of upper cable k (0-based k).
        used = np.zeros(N) + trav[k]
        for j in range(k):
            th = theta[:, j]
            used = used + np.sqrt(
                np.maximum(Pu[k, j] + Qu[k, j] * np.cos(th) + Ru[k, j] * np.sin(th), 0.0)
            )
        s = upper[:, k] - used
        rho = np.hypot(Qu[k, k], Ru[k, k])
        with np.errstate(invalid="ignore", divide="ignore"):
            arg = (s**2 - Pu[k, k]) / rho
        real = ok & (s >= 0.0) & (np.abs(arg) <= 1.0)
        base = np.arctan2(Ru[k, k], Qu[k, k])
        acos = np.arccos(np.clip(arg, -1.0, 1.0))
        cand = np.stack([base + acos, base - acos], axis=1)  # (N, 2)
        diff = wrap_angle(cand - seed[:, k : k + 1])
        pick = np.argmin(np.abs(diff), axis=1)
        chosen = seed[:, k] + diff[np.arange(N), pick]
        theta[:, k] = np.where(real, chosen, np.nan)
        n_branches[:, k] = np.where(real, np.where(acos > 0.0, 2, 1), 0)
        ok = real
    residual = np.full(N, np.inf)
    if ok.any():
        r = upper[ok] - upper_cable_lengths(robot, theta[ok])
        residual[ok] = np.abs(r).max(axis=1)
    return dict(theta=theta, converged=ok, residual=residual, n_branches=n_branches)


# --------------------------------------------------------------------------
# Error analysis (paper Fig. 3)
# --------------------------------------------------------------------------
def deviation(robot, theta0, dL, holes_perturbed=None, tol=1e-12, max_iter=100) -> dict:
    """Tip deviation caused by cable-length and/or hole errors (paper Fig. 3).

    ``theta0``: nominal joint angles ``(N, n)`` rad; ``dL``: upper-cable length
    errors ``(n,)`` (or ``(N, n)``) m; ``holes_perturbed``: hole positions of
    the erroneous robot ``(2n, n+1, 2, 2)`` m (default: nominal holes).

    ``L0 = L_upper(theta0)`` on the nominal robot; ``L0 + dL`` is solved by
    LM (:func:`solve_cables`, seed ``theta0``) on the perturbed robot.
    Returns ``dS = fk(theta) - fk(theta0)`` ``(N, 3)`` (m, m, rad),
    ``theta (N, n)`` rad and ``converged (N,)``.
    """
    g = read_geometry(robot)
    theta0 = batch_array(theta0, g.n, "theta0")
    target = upper_cable_lengths(robot, theta0) + np.asarray(dL, dtype=float)
    perturbed = robot if holes_perturbed is None else as_robot(robot).with_planar_holes(holes_perturbed)
    sol = solve_cables(perturbed, target, seed=theta0, tol=tol, max_iter=max_iter)
    dS = fk(robot, sol["theta"]) - fk(robot, theta0)
    return dict(dS=dS, theta=sol["theta"], converged=sol["converged"])


def hole_height_error(robot, dh) -> np.ndarray:
    """Holes ``(2n, n+1, 2, 2)`` m with the paper's "error on disk i's holes".

    The hole height of pair ``i`` is increased by ``dh[i]`` m (``(n,)``): upper
    ``y += dh[i]``, lower ``y -= dh[i]``, on every face that pair crosses.
    """
    g = read_geometry(robot)
    dh = np.asarray(dh, dtype=float).reshape(g.n)
    holes = g.holes.copy()
    mask = used_hole_mask(g.n)
    for c in range(2 * g.n):
        sign = 1.0 if c % 2 == 0 else -1.0
        holes[c, mask[c], 1] += sign * dh[c // 2]
    return holes


# --------------------------------------------------------------------------
# Statics and cable elasticity (issue 4)
# --------------------------------------------------------------------------
# Written from the physics: a cable is a straight, massless string between
# holes; the joints are frictionless pins.  Cut the arm just distal of joint k
# (across segment k of every cable that reaches disk k or beyond).  The cut-off
# part (linkages k..n with the cable pieces inside them) is held by the pin
# force at joint k (no moment), the cut cables, and the external loads.  Each
# cut cable pulls the part at its hole A_k (proximal face of disk k) with
# force T * unit(B_{k-1} - A_k).  The moment of all of these about joint k
# vanishes: a lower-triangular linear system in the upper tensions.
#
# Mass model: linkage i's whole mass sits at the centre of disk i, the point
# (thickness_i / 2, 0) of frame O_{i,a}.

__all__ += ["tensions", "elastic_upper_lengths", "solve_cables_elastic", "cable_stretch"]

#: Standard gravity (m/s^2), used for hanging weights given in kg.
STANDARD_GRAVITY = 9.80665


def _rot(angle, v):
    """Rotate 2-vectors ``v (..., 2)`` by ``angle (...)`` rad."""
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], -1)


def _cross(a, b):
    """z component of ``a x b`` for 2-vectors."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _frames(g: _Geometry, theta: np.ndarray):
    """Base-frame points of the chain for ``theta (N, n)``.

    Returns dict with ``joint (N, n, 2)``, ``face_b_prev (N, n, 2)`` (origin of
    O_{k-1,b}), ``face_a (N, n, 2)`` (O_{k,a}), ``centre (N, n, 2)`` (disk k
    centre), ``tip (N, 2)``, ``alpha_prev (N, n)`` and ``alpha (N, n)`` (axis
    angles of O_{k-1,b} and O_{k,a}), all in m and rad.
    """
    N = theta.shape[0]
    alpha = np.cumsum(theta, axis=1)
    alpha_prev = np.concatenate([np.zeros((N, 1)), alpha[:, :-1]], axis=1)
    ex_prev = np.stack([np.cos(alpha_prev), np.sin(alpha_prev)], -1)
    ex = np.stack([np.cos(alpha), np.sin(alpha)], -1)
    # increments: face b of k-1 -> joint k -> face a of k -> face b of k
    steps = g.lb[None, :, None] * ex_prev + (g.la + g.t)[None, :, None] * ex
    face_b = np.cumsum(steps, axis=1)  # origin of O_{k,b}
    face_b_prev = np.concatenate([np.zeros((N, 1, 2)), face_b[:, :-1]], axis=1)
    joint = face_b_prev + g.lb[None, :, None] * ex_prev
    face_a = joint + g.la[None, :, None] * ex
    centre = face_a + 0.5 * g.t[None, :, None] * ex
    return dict(joint=joint, face_b_prev=face_b_prev, face_a=face_a, centre=centre,
                tip=face_b[:, -1], alpha_prev=alpha_prev, alpha=alpha)


def _cable_moments(g: _Geometry, fr) -> np.ndarray:
    """``M (N, 2n, n)``: moment about joint k (N m per N of tension) of the pull
    of cable c on the part distal of joint k (zero where c does not cross k)."""
    n = g.n
    p = g.holes[:, :n, 1, :]  # (2n, n, 2) hole in face b of disk k-1
    q = g.holes[:, 1:, 0, :]  # (2n, n, 2) hole in face a of disk k
    B = fr["face_b_prev"][:, None] + _rot(fr["alpha_prev"][:, None], p[None])
    A = fr["face_a"][:, None] + _rot(fr["alpha"][:, None], q[None])
    d = B - A
    e = d / np.linalg.norm(d, axis=-1, keepdims=True)
    M = _cross(A - fr["joint"][:, None], e)
    _, _, mask = _segment_vectors(g)
    return np.where(mask[None], M, 0.0)


def _external_moments(g: _Geometry, fr, mass, gravity, tip_wrench) -> np.ndarray:
    """Moment about each joint of the loads on the part distal of it, ``(N, n)`` N m."""
    N = fr["tip"].shape[0]
    tau = np.zeros((N, g.n))
    if gravity is not None:
        w = np.asarray(mass, dtype=float).reshape(g.n)[:, None] * np.asarray(gravity, float)  # (n, 2)
        # cross((C_j - J_k), w_j) summed over j >= k
        r = fr["centre"][:, None, :, :] - fr["joint"][:, :, None, :]  # (N, k, j, 2)
        tj = _cross(r, w[None, None])
        upper = np.triu(np.ones((g.n, g.n), dtype=bool))  # j >= k
        tau += np.where(upper[None], tj, 0.0).sum(axis=2)
    if tip_wrench is not None:
        f = np.broadcast_to(np.asarray(tip_wrench, dtype=float), (N, 3))
        tau += _cross(fr["tip"][:, None] - fr["joint"], f[:, None, :2]) + f[:, 2:3]
    return tau


def hole_points(robot, theta) -> list:
    """Base-frame points of every cable's holes at ``theta (N, n)`` rad: a list
    (cable ``c = 0..2n-1``) of ``(N, 2e + 1, 2)`` m arrays ``[B_0, A_1, B_1, ...,
    A_e, B_e]`` (``e`` the cable's pair; ``B_k`` on face b of disk ``k``, ``A_k`` on
    face a)."""
    g = read_geometry(robot)
    theta = batch_array(theta, g.n, "theta")
    fr = _frames(g, theta)
    ex = np.stack([np.cos(fr["alpha"]), np.sin(fr["alpha"])], -1)
    face_b = fr["face_a"] + g.t[None, :, None] * ex
    out = []
    for c in range(2 * g.n):
        e = c // 2 + 1
        P = np.empty((theta.shape[0], 2 * e + 1, 2))
        P[:, 0] = g.holes[c, 0, 1]
        for k in range(1, e + 1):
            P[:, 2 * k - 1] = fr["face_a"][:, k - 1] + _rot(fr["alpha"][:, k - 1], g.holes[c, k, 0])
            P[:, 2 * k] = face_b[:, k - 1] + _rot(fr["alpha"][:, k - 1], g.holes[c, k, 1])
        out.append(P)
    return out


def tensions(robot, theta, lower=None, tip_wrench=None, gravity=None, mass=None, gap=None) -> np.ndarray:
    """Upper-cable tensions (N) ``(N, n)`` from the moment balance at every joint.

    ``lower``: lower-cable tensions ``(n,)`` or ``(N, n)`` N (default
    ``robot.lower_tension``); ``tip_wrench``: ``[Fx N, Fy N, Mz N m]`` at the
    tip, base frame, ``(3,)`` or ``(N, 3)``; ``gravity``: ``(2,)`` m/s^2 in the
    base frame (default none); ``mass``: ``(n,)`` kg (default ``robot.mass``).
    ``gap``: optional ``(N, 2n, n)`` factors of each cable's tension in the gap
    of each joint over its routing tension (friction in the holes; the upper
    tensions returned are then the routing's, the lower ones given are too).
    Positive = taut.  NaN where an upper cable has no moment about its joint.
    """
    g = read_geometry(robot)
    theta = batch_array(theta, g.n, "theta")
    N = theta.shape[0]
    if lower is None:
        lower = planar_attributes(robot).lower_tension
    lower = np.broadcast_to(np.asarray(lower, dtype=float), (N, g.n))
    if gravity is not None and mass is None:
        mass = planar_attributes(robot).mass
    fr = _frames(g, theta)
    M = _cable_moments(g, fr)  # (N, 2n, n)
    if gap is not None:
        M = M * np.asarray(gap, dtype=float)
    tau = _external_moments(g, fr, mass, gravity, tip_wrench)
    # sum_c T_c M[c, k] + tau_k = 0  ->  Mu^T T_up = -(tau + Ml^T T_low)
    Mu, Ml = M[:, 0::2, :], M[:, 1::2, :]  # (N, pair, joint)
    rhs = -(tau + np.einsum("npk,np->nk", Ml, lower))
    A = np.swapaxes(Mu, 1, 2)  # (N, joint, pair), upper triangular
    with np.errstate(all="ignore"):
        return batched_solve(A, rhs)


def elastic_upper_lengths(robot, theta, T, E, diameter, routing_length=0.0) -> np.ndarray:
    """Unstretched (commanded) upper-cable lengths that hold the arm at ``theta``.

    Hooke: a cable piece of rest length l under tension T has length
    ``l (1 + T/(E A))``, ``A = pi d^2 / 4``.  The actuator fixes the rest
    length ``L_cmd + routing_length`` between the screw and the anchor; the
    path behind the base disk is geometrically ``routing_length`` long, so the
    arm sees ``L_geom = (L_cmd + routing) (1 + eps) - routing``.
    """
    eps = np.asarray(T, float) / (E * np.pi * diameter**2 / 4.0)
    Lg = upper_cable_lengths(robot, theta)
    return (Lg + routing_length) / (1.0 + eps) - routing_length


def cable_stretch(robot, theta, T, E, diameter, routing_length=0.0) -> np.ndarray:
    """Elongation (m) of every upper cable at ``theta`` under tensions ``T``."""
    Lg = upper_cable_lengths(robot, batch_array(theta, robot.n, "theta"))
    return Lg - elastic_upper_lengths(robot, theta, T, E, diameter, routing_length)


def solve_cables_elastic(robot, upper, E, diameter, routing_length=0.0, lower=None,
                         tip_wrench=None, gravity=None, mass=None, seed=None,
                         tol=1e-12, max_iter=100) -> dict:
    """Commanded (unstretched) upper lengths ``(N, n)`` m -> joint angles with
    stretched cables, the tensions depending on theta (coupled solve).

    First the rigid LM solve from ``seed``; then LM on
    ``r = upper - L_cmd(theta)`` where ``L_cmd(theta)`` is
    :func:`elastic_upper_lengths` with the statics tensions at theta, and the
    Jacobian by central differences.  Returns the dict of :func:`solve_cables`
    plus ``tension (N, n)`` N.
    """
    g = read_geometry(robot)
    upper = batch_array(upper, g.n, "upper")
    rigid = solve_cables(robot, upper, seed=seed, tol=tol, max_iter=max_iter)
    theta = rigid["theta"].copy()

    lower_b = None if lower is None else np.broadcast_to(np.asarray(lower, float), upper.shape)
    wrench_b = None if tip_wrench is None else np.broadcast_to(np.asarray(tip_wrench, float),
                                                               (upper.shape[0], 3))

    def _T(th, idx):
        return tensions(robot, th, None if lower_b is None else lower_b[idx],
                        None if wrench_b is None else wrench_b[idx], gravity, mass)

    def model(th, idx):
        return elastic_upper_lengths(robot, th, _T(th, idx), E, diameter, routing_length)

    def residual(th, idx):
        return upper[idx] - model(th, idx)

    def step(th, r, lam, idx):
        h = 1e-6
        J = np.empty((th.shape[0], g.n, g.n))
        for k in range(g.n):
            d = np.zeros(g.n)
            d[k] = h
            J[:, :, k] = (model(th + d, idx) - model(th - d, idx)) / (2 * h)
        Jt = np.swapaxes(J, 1, 2)
        A = Jt @ J + lam[:, None, None] * np.eye(g.n)
        return batched_solve(A, (Jt @ r[..., None])[..., 0])

    sol = levenberg_marquardt(residual, step, theta, tol, max_iter)
    sol["within_limits"] = _within_limits(g, sol["theta"])
    sol["tension"] = _T(sol["theta"], np.arange(upper.shape[0]))
    return sol


# --------------------------------------------------------------------------
# Tip sensitivities (issue 7)
# --------------------------------------------------------------------------
# The cable solve holds the upper-cable lengths: L_upper(theta; holes) = L0 + dl.
# Differentiating, Jc dtheta + (dL_upper/dholes) dholes = dl, so
#   dS/dl     =  Jp Jc^-1,
#   dS/dholes = -Jp Jc^-1 dL_upper/dholes,
# with Jp = dS/dtheta and Jc = dL_upper/dtheta.  dL/dholes by the chain rule on
# the segment and traversal vectors of docs/model.md (no finite differences).

__all__ += ["cable_hole_gradient", "tip_sensitivity"]


def cable_hole_gradient(robot, theta) -> np.ndarray:
    """``dL_c / d holes``, shape ``(N, 2n, 2n, n+1, 2, 2)`` m/m: cable ``c`` (axis 1)
    against every hole coordinate (axes 2-5, the ``holes`` layout).

    Segment ``k`` of cable ``c``: ``v = w + Rot(theta_k) u`` with
    ``w = (link_before[k], 0) - p``, ``u = q + (link_after[k], 0)``; for
    ``e = v / |v|``: ``d|v|/dp = -e``, ``d|v|/dq = Rot(theta_k)^T e``.  Traversal
    of disk ``k+1``: ``t = (thickness[k] + b_x - a_x, b_y - a_y)``;
    ``d|t|/db = t/|t|``, ``d|t|/da = -t/|t|``.  Entries a cable does not use are 0.
    """
    g = read_geometry(robot)
    theta = batch_array(theta, g.n, "theta")
    n, N = g.n, theta.shape[0]
    u, w, mask = _segment_vectors(g)  # (2n, n, 2), (2n, n, 2), (2n, n)
    c = np.cos(theta)[:, None, :]
    s = np.sin(theta)[:, None, :]
    vx = w[None, ..., 0] + u[None, ..., 0] * c - u[None, ..., 1] * s
    vy = w[None, ..., 1] + u[None, ..., 0] * s + u[None, ..., 1] * c
    ln = np.hypot(vx, vy)
    ex, ey = vx / ln, vy / ln  # (N, 2n, n)
    m = mask[None].astype(float)
    grad_p = np.stack([-ex, -ey], -1) * m[..., None]  # d/d holes[c, k, 1]
    grad_q = np.stack([c * ex + s * ey, -s * ex + c * ey], -1) * m[..., None]  # d/d holes[c, k+1, 0]
    a = g.holes[:, 1:, 0, :]
    b = g.holes[:, 1:, 1, :]
    tx = g.t[None, :] + b[..., 0] - a[..., 0]
    ty = b[..., 1] - a[..., 1]
    tl = np.hypot(tx, ty)
    dt = np.stack([tx / tl, ty / tl], -1) * mask[..., None]  # (2n, n, 2) d/d b
    grad = np.zeros((N, 2 * n, 2 * n, n + 1, 2, 2))
    for cab in range(2 * n):
        grad[:, cab, cab, :n, 1, :] += grad_p[:, cab]
        grad[:, cab, cab, 1:, 0, :] += grad_q[:, cab] - dt[None, cab]
        grad[:, cab, cab, 1:, 1, :] += dt[None, cab]
    return grad


def tip_sensitivity(robot, theta) -> dict:
    """First-order sensitivities of the tip pose at ``theta (N, n)`` rad.

    Returns ``cable (N, 3, n)``: dS/dl_upper (m/m; rad/m for phi);
    ``holes (N, 3, 2n, n+1, 2, 2)``: dS/d(every hole coordinate), zero for the
    lower (force-controlled) cables and unused entries; ``pair (N, 3, n)``:
    dS/d(hole height of disk i), the paper's dh (upper holes +dh, lower -dh).
    """
    g = read_geometry(robot)
    theta = batch_array(theta, g.n, "theta")
    n = g.n
    jp = fk_jacobian(robot, theta)  # (N, 3, n)
    jc = upper_cable_jacobian(robot, theta)  # (N, n, n)
    # S Jc = Jp  <=>  Jc^T S^T = Jp^T
    S = np.swapaxes(np.linalg.solve(np.swapaxes(jc, 1, 2), np.swapaxes(jp, 1, 2)), 1, 2)
    grad = cable_hole_gradient(robot, theta)[:, 0::2]  # (N, n, 2n, n+1, 2, 2) upper cables
    holes = -np.einsum("nri,nicdfx->nrcdfx", S, grad)
    # dh_i: +y on every used hole of cable 2i (lower cables do not move the tip)
    mask = used_hole_mask(n)  # (2n, n+1, 2)
    dy = np.array([(grad[:, i, 2 * i, ..., 1] * mask[2 * i][None]).sum(axis=(1, 2)) for i in range(n)]).T
    pair = -S * dy[:, None, :]
    return dict(cable=S, holes=holes, pair=pair)
