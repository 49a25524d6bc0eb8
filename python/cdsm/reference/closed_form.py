"""The planar arm in closed form: the segment coefficients of Eq. 4-5, the
closed-form cable solve and the closed-form pose IK of a 3-joint arm.

The specification of the planar case (``docs/model.md``, "Holes and cables",
"Solves", "Closed-form pose IK"), written from the document and independent of
the Rust core; they read the arm in the planar layout
(:class:`.robot.PlanarView`).  Conventions: cables ``c = 0 .. 2n-1``, cable
``c`` of pair ``i = c // 2 + 1`` (1-based disk), even ``c`` the upper
(position-controlled) cable.  Units: m, rad.
"""

from __future__ import annotations

import numpy as np

from .kinematics import fk, position_lengths, within_limits
from .robot import Robot, as_robot
from .rotations import wrap_angle
from .solve import seeds

__all__ = ["segment_coefficients", "traversals", "solve_cables_closed_form", "ik_closed_form"]


def _segment_vectors(v):
    """``u``, ``w`` ``(2n, n, 2)`` m and the segment mask ``(2n, n)`` of a planar view.

    Segment ``k`` (0-based ``k`` here, the model's ``k+1``) of cable ``c`` runs
    from ``p = holes[c, k, 1]`` to ``A = w + Rot(theta_k) u + p``, with
    ``u = holes[c, k+1, 0] + (link_after[k], 0)`` and ``w = (link_before[k], 0) - p``.
    """
    n = v.n
    p = v.holes[:, :n, 1, :]  # (2n, n, 2): distal face of disk k-1
    u = v.holes[:, 1:, 0, :].copy()  # (2n, n, 2): proximal face of disk k
    u[..., 0] += v.link_after[None, :]
    w = -p
    w[..., 0] += v.link_before[None, :]
    mask = np.arange(1, n + 1)[None, :] <= (np.arange(2 * n) // 2 + 1)[:, None]
    return u, w, mask


def segment_coefficients(robot: Robot):
    """``P, Q, R`` ``(2n, n)`` (m^2) with ``s^2 = P + Q cos(theta_k) + R sin(theta_k)``
    for segment ``k`` of cable ``c`` (Eq. 4-5: ``P = |w|^2 + |u|^2``, ``Q = 2 w.u``,
    ``R = 2 (w_y u_x - w_x u_y)``), and the mask ``(2n, n)`` of the segments a cable has."""
    u, w, mask = _segment_vectors(as_robot(robot).planar)
    P = (w**2).sum(-1) + (u**2).sum(-1)
    Q = 2.0 * (w * u).sum(-1)
    R = 2.0 * (w[..., 1] * u[..., 0] - w[..., 0] * u[..., 1])
    return P, Q, R, mask


def traversals(robot: Robot) -> np.ndarray:
    """The constant part of every cable's length ``(2n,)`` m: its disks' traversals
    ``|(thickness[k] + b_x, b_y) - a|`` (``a``, ``b`` its holes on faces a, b of disk k)."""
    v = as_robot(robot).planar
    a, b = v.holes[:, 1:, 0, :], v.holes[:, 1:, 1, :]
    trav = np.hypot(v.thickness[None, :] + b[..., 0] - a[..., 0], b[..., 1] - a[..., 1])  # (2n, n)
    _, _, mask = _segment_vectors(v)
    return np.where(mask, trav, 0.0).sum(axis=1)


def solve_cables_closed_form(robot: Robot, upper, seed=None) -> dict:
    """Closed-form cable solve, joint by joint (k = 1..n).

    With ``theta_1..theta_{k-1}`` known, the remaining length of upper cable ``k``
    fixes ``s_k``; ``P + Q cos + R sin = s_k^2`` gives ``theta_k = atan2(R, Q) +-
    acos((s_k^2 - P) / hypot(Q, R))``.  Of the real branches the one nearest the seed
    (difference wrapped to ``(-pi, pi]``) is taken and returned as ``seed + wrapped
    difference``.

    ``upper``: ``(N, n)`` m; ``seed``: ``(N, n)``/``(n,)`` rad, default zeros.
    Returns ``theta (N, n)`` rad (NaN from the first joint without a real branch on),
    ``converged (N,)`` (every joint had a real branch), ``residual (N,)``
    ``max|L_target - L_upper(theta)|`` m (inf when not converged), ``n_branches (N,
    n)`` int (0, 1 or 2 distinct real branches; 0 for joints after a failed one).
    """
    robot = as_robot(robot)
    n = robot.planar.n
    upper = np.asarray(upper, dtype=float)
    if upper.ndim != 2 or upper.shape[1] != n:
        raise ValueError(f"upper must have shape (N, {n}), got {upper.shape}")
    N = upper.shape[0]
    seed = seeds(robot, seed, N)
    P, Q, R, _ = segment_coefficients(robot)
    trav = traversals(robot)[0::2]  # (n,) upper cables
    Pu, Qu, Ru = P[0::2], Q[0::2], R[0::2]  # (n cables, n segments)

    theta = np.full((N, n), np.nan)
    n_branches = np.zeros((N, n), dtype=np.int64)
    ok = np.ones(N, dtype=bool)
    for k in range(n):
        # Length already used by segments 1..k-1 of upper cable k (0-based k).
        used = np.zeros(N) + trav[k]
        for j in range(k):
            th = theta[:, j]
            used = used + np.sqrt(np.maximum(Pu[k, j] + Qu[k, j] * np.cos(th) + Ru[k, j] * np.sin(th), 0.0))
        s = upper[:, k] - used
        rho = np.hypot(Qu[k, k], Ru[k, k])
        with np.errstate(invalid="ignore", divide="ignore"):
            arg = (s**2 - Pu[k, k]) / rho
        real = ok & (s >= 0.0) & (np.abs(arg) <= 1.0)
        base = np.arctan2(Ru[k, k], Qu[k, k])
        acos = np.arccos(np.clip(arg, -1.0, 1.0))
        cand = np.stack([base + acos, base - acos], axis=1)  # (N, 2)
        diff = wrap_angle(cand - seed[:, k:k + 1])
        pick = np.argmin(np.abs(diff), axis=1)
        chosen = seed[:, k] + diff[np.arange(N), pick]
        theta[:, k] = np.where(real, chosen, np.nan)
        n_branches[:, k] = np.where(real, np.where(acos > 0.0, 2, 1), 0)
        ok = real
    residual = np.full(N, np.inf)
    if ok.any():
        residual[ok] = np.abs(upper[ok] - position_lengths(robot, theta[ok])).max(axis=1)
    return dict(theta=theta, converged=ok, residual=residual, n_branches=n_branches)


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


def ik_closed_form(robot: Robot, pose, seed=None, tol=1e-12, enforce_limits=False) -> dict:
    """Closed-form full-pose IK of a 3-joint planar arm (docs/model.md, "Closed-form pose IK").

    ``pose``: ``(N, 3)`` ``[X m, Y m, phi rad]``; ``seed``: ``(N, 3)`` or ``(3,)`` rad,
    default zeros.  With ``r1 = link_after[1] + thickness[1] + link_before[2]``,
    ``r2 = link_after[2] + thickness[2] + link_before[3]``, ``a3 = link_after[3] +
    thickness[3]`` (m), the wrist (joint 3) is ``W = (X - a3 cos phi, Y - a3 sin phi)``
    and, from joint 1 at ``(link_before[1], 0)``, ``c2 = (|W - J1|^2 - r1^2 - r2^2) /
    (2 r1 r2)``.  Branches ``s = +1, -1``: ``theta_2 = s acos(c2)``, ``theta_1 =
    atan2(dy, dx) - atan2(r2 sin theta_2, r1 + r2 cos theta_2)``, both moved by whole
    turns to within pi of the seed, then ``theta_3 = phi - theta_1 - theta_2``.  The
    branch nearest the seed (sum of squared differences) wins; a tie (within
    ``1e-12 (1 + |seed|^2)``) goes to the ``s = -1`` branch (``theta_2 = -acos(c2) <=
    0`` before the turn shift).  With ``enforce_limits`` a branch outside the joint
    box is dropped first; if both are, the nearest is returned with reason ``"outside
    limits"``.  ``|c2| > 1``: reason ``"unreachable"``, ``theta`` = seed.

    Returns a dict with ``theta (N, 3)`` rad, ``converged (N,)`` bool, ``iterations
    (N,)`` int (all 0), ``residual (N,)`` = ``max|fk(theta) - pose|`` over X, Y (m) and
    phi (rad), ``within_limits (N,)`` bool and ``reason (N,)`` str (``"converged"``,
    ``"unreachable"``, ``"outside limits"``, and ``"singular"`` for a reachable answer
    whose residual exceeds ``tol``).
    """
    robot = as_robot(robot)
    v = robot.planar
    if v.n != 3:
        raise ValueError(f"ik_closed_form needs a 3-joint robot, got n = {v.n}")
    pose = np.asarray(pose, dtype=float)
    if pose.ndim != 2 or pose.shape[1] != 3:
        raise ValueError(f"pose must have shape (N, 3), got {pose.shape}")
    N = pose.shape[0]
    seed = seeds(robot, seed, N)
    x, y, phi = pose[:, 0], pose[:, 1], pose[:, 2]
    lb, la, t = v.link_before, v.link_after, v.thickness

    r1 = la[0] + t[0] + lb[1]
    r2 = la[1] + t[1] + lb[2]
    a3 = la[2] + t[2]
    dx = x - a3 * np.cos(phi) - lb[0]
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
    inside = np.stack([within_limits(robot, branches[:, b]) for b in range(2)], axis=1)
    allowed = inside if enforce_limits else np.ones_like(inside)
    none_allowed = ~allowed.any(axis=1)
    allowed = np.where(none_allowed[:, None], True, allowed)  # both dropped: nearest of both
    band = 1e-12 * (1.0 + (seed**2).sum(axis=1))
    tie = np.abs(dist[:, 0] - dist[:, 1]) <= band
    plus_nearer = dist[:, 1] < dist[:, 0]
    pick_plus = np.where(allowed[:, 0] & allowed[:, 1], plus_nearer & ~tie, allowed[:, 1])  # one allowed: that one
    chosen = branches[np.arange(N), pick_plus.astype(int)]

    theta = np.where(reachable[:, None], chosen, seed)
    residual = np.abs(fk(robot, theta) - pose).max(axis=1)
    outside = reachable & enforce_limits & none_allowed
    converged = reachable & ~outside & (residual <= tol)
    reason = np.where(converged, "converged",
                      np.where(outside, "outside limits",
                               np.where(reachable, "singular", "unreachable"))).astype(object)
    return dict(theta=theta, converged=converged, iterations=np.zeros(N, dtype=np.int64), residual=residual,
                within_limits=within_limits(robot, theta), reason=reason)
