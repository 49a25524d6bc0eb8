"""Kinematics of an arm of either kind: the chain's frames, the task vector,
Jacobians, cable points, lengths and their derivatives.

Written from ``docs/spatial.md`` ("Frames and forward kinematics", "Holes and
cables") and ``docs/model.md`` (Eq. 1-5; "The arm model"), independent of the
Rust core.  One chain for both kinds: a planar arm is the case with every
axis ``z``.  The task vector is the kind's projection of the end frame
``F_Kb``: planar ``[x, y, phi]`` with ``phi = theta_1 + ... + theta_n`` (the
unwrapped sum, Eq. 3), spatial ``[x, y, z, rx, ry, rz]`` (the principal
rotation vector).

Every function takes a :class:`.robot.Robot` (or anything
:func:`.robot.as_robot` reads) and joint angles ``theta (N, n)`` rad, and is
vectorised over the batch ``N``; Python loops run over joints, disks and
cables only.  Units: m, rad.
"""

from __future__ import annotations

import numpy as np

from .robot import Robot, as_robot, position_cables
from .rotations import rotation_matrix

__all__ = [
    "as_theta",
    "within_limits",
    "chain_frames",
    "fk_matrix",
    "fk",
    "task_vector",
    "disk_frames",
    "joint_positions_axes",
    "geometric_jacobian",
    "fk_jacobian",
    "point_jacobian",
    "cable_points",
    "cable_lengths",
    "position_lengths",
    "segment_lengths",
    "cable_jacobian",
    "cable_hole_gradient",
    "unit_vectors",
    "cross",
]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` along the last axis of broadcasting ``(..., 3)`` arrays."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def as_theta(robot: Robot, theta) -> np.ndarray:
    """``theta`` as a float ``(N, n)`` array (rad); ValueError otherwise."""
    th = np.asarray(theta, dtype=float)
    if th.ndim != 2 or th.shape[1] != robot.n:
        raise ValueError(f"theta must have shape (N, {robot.n}), got {th.shape}")
    return th


def within_limits(robot: Robot, theta: np.ndarray) -> np.ndarray:
    """``(N,)`` bool: every joint angle within its limits (inclusive)."""
    lim = as_robot(robot).joint_limits
    return np.all((theta >= lim[:, 0]) & (theta <= lim[:, 1]), axis=1)


# --------------------------------------------------------------------------
# The chain
# --------------------------------------------------------------------------
def chain_frames(robot: Robot, theta: np.ndarray) -> dict:
    """The frames of the chain for ``theta (N, n)`` rad (``docs/spatial.md``)::

        F = F_(k-1)b;  for each joint j of disk k:  F = F Trans(offset_j) Rot(axis_j, theta_j)
        F_ka = F Trans(link_after_k);  F_kb = F_ka Trans(thickness_k, 0, 0)

    Returns rotations ``Ra, Rb (N, K+1, 3, 3)`` and origins ``ta, tb (N, K+1, 3)``
    of the faces ``F_ka`` and ``F_kb`` (index 0: the base face, the identity;
    ``Ra[:, 0]`` is set to it too), joint origins ``p (N, n, 3)`` m and world
    axes ``w (N, n, 3)``.
    """
    N, n, K = theta.shape[0], robot.n, robot.disks
    R = np.broadcast_to(np.eye(3), (N, 3, 3)).copy()
    t = np.zeros((N, 3))
    Ra = np.empty((N, K + 1, 3, 3))
    Rb = np.empty((N, K + 1, 3, 3))
    ta = np.empty((N, K + 1, 3))
    tb = np.empty((N, K + 1, 3))
    Ra[:, 0] = Rb[:, 0] = np.eye(3)
    ta[:, 0] = tb[:, 0] = 0.0
    p = np.empty((N, n, 3))
    w = np.empty((N, n, 3))
    for k in range(1, K + 1):
        for j in np.flatnonzero(robot.joint_disk == k):
            t = t + R @ robot.offsets[j]  # G_j = F Trans(offset_j)
            p[:, j] = t
            w[:, j] = R @ robot.axes[j]
            R = R @ rotation_matrix(robot.axes[j], theta[:, j])  # F = G_j Rot(axis_j, theta_j)
        t = t + R @ robot.link_after[k - 1]  # F_ka
        Ra[:, k], ta[:, k] = R, t
        t = t + R[:, :, 0] * robot.thickness[k - 1]  # F_kb = F_ka Trans(thickness, 0, 0)
        Rb[:, k], tb[:, k] = R, t
    return dict(Ra=Ra, ta=ta, Rb=Rb, tb=tb, p=p, w=w)


def _frames(robot, theta):
    robot = as_robot(robot)
    return robot, chain_frames(robot, as_theta(robot, theta))


def fk_matrix(robot: Robot, theta) -> np.ndarray:
    """End frame ``F_Kb`` (distal face of the last disk) ``(N, 4, 4)``, translation in m."""
    robot, ch = _frames(robot, theta)
    N = ch["tb"].shape[0]
    T = np.zeros((N, 4, 4))
    T[:, :3, :3] = ch["Rb"][:, -1]
    T[:, :3, 3] = ch["tb"][:, -1]
    T[:, 3, 3] = 1.0
    return T


def task_vector(robot: Robot, position: np.ndarray, R: np.ndarray, theta: np.ndarray,
                turn: float = 0.0) -> np.ndarray:
    """The kind's task vector of a frame ``(position (N, 3) m, R (N, 3, 3))`` of the arm
    at ``theta (N, n)`` rad: its position coordinates and its attitude
    (:meth:`.robot.Kind.attitude`): planar ``[x, y, phi]`` with ``phi = sum(theta) + turn``
    (unwrapped; ``turn`` rad a rotation about ``z`` applied to the frame), spatial
    ``[x, y, z]`` and the principal rotation vector of ``R`` (rad)."""
    return np.concatenate([position[:, :robot.kind.dim], robot.kind.attitude(R, theta, turn)], axis=1)


def fk(robot: Robot, theta) -> np.ndarray:
    """The task vector of the end frame ``F_Kb``, ``(N, 3)`` planar ``[x, y, phi]``
    (m, m, rad) or ``(N, 6)`` spatial ``[x, y, z, rx, ry, rz]`` (m, rad)."""
    robot, ch = _frames(robot, theta)
    return task_vector(robot, ch["tb"][:, -1], ch["Rb"][:, -1], np.asarray(theta, dtype=float))


def disk_frames(robot: Robot, theta) -> dict:
    """Face frames of every disk: ``Ra, Rb (N, K+1, 3, 3)`` rotations and ``ta, tb (N, K+1, 3)``
    m origins of ``F_ka`` (proximal) and ``F_kb`` (distal); index 0 is the base face
    (the identity, also stored as ``Ra[:, 0]``, ``ta[:, 0]``)."""
    _, ch = _frames(robot, theta)
    return {key: ch[key] for key in ("Ra", "ta", "Rb", "tb")}


def joint_positions_axes(robot: Robot, theta):
    """Joint origins ``p (N, n, 3)`` m and unit world axes ``w (N, n, 3)``."""
    _, ch = _frames(robot, theta)
    return ch["p"], ch["w"]


def point_jacobian(robot: Robot, ch: dict, q: np.ndarray, disk: int) -> np.ndarray:
    """``dq/dtheta (N, 3, n)`` m/rad of world points ``q (N, 3)`` fixed to disk ``disk``
    (0 = base): ``w_j x (q - p_j)`` for the joints proximal of it, else 0."""
    J = cross(ch["w"], q[:, None, :] - ch["p"])  # (N, n, 3)
    J = np.where((robot.joint_disk <= disk)[None, :, None], J, 0.0)
    return np.swapaxes(J, 1, 2)


def geometric_jacobian(robot: Robot, theta) -> np.ndarray:
    """Geometric Jacobian ``(N, 6, n)`` of the end frame: rows 0-2 the linear velocity
    of its origin (m/rad), rows 3-5 the angular velocity (rad/rad), base frame."""
    robot, ch = _frames(robot, theta)
    tip = ch["tb"][:, -1]
    lin = cross(ch["w"], tip[:, None, :] - ch["p"])  # (N, n, 3)
    return np.concatenate([np.swapaxes(lin, 1, 2), np.swapaxes(ch["w"], 1, 2)], axis=1)


def fk_jacobian(robot: Robot, theta) -> np.ndarray:
    """``d(task vector)/dtheta``: planar ``(N, 3, n)`` (rows ``x``, ``y`` m/rad and
    ``phi`` 1: the geometric Jacobian's rows 0, 1, 5), spatial the geometric Jacobian
    ``(N, 6, n)`` (the rotation as an angular velocity)."""
    robot = as_robot(robot)
    return geometric_jacobian(robot, theta)[:, list(robot.kind.task_rows)]


# --------------------------------------------------------------------------
# Holes and cables
# --------------------------------------------------------------------------
def cable_points(robot: Robot, theta, frames: dict | None = None) -> list:
    """World points of every hole: a list (one per cable, file order) of ``(N, 2 e_c + 1, 3)``
    m arrays ``[B_0, A_1, B_1, ..., A_e, B_e]`` (``B_0 = F_0b h_0``, ``A_k = F_ka h_(2k-1)``,
    ``B_k = F_kb h_(2k)``); ``frames``: :func:`chain_frames` at ``theta`` when at hand."""
    robot = as_robot(robot)
    ch = chain_frames(robot, as_theta(robot, theta)) if frames is None else frames
    pts = []
    N = ch["tb"].shape[0]
    for c in range(robot.m):
        e, h = int(robot.cable_end[c]), robot.holes[c]
        P = np.empty((N, 2 * e + 1, 3))
        P[:, 0] = h[0]
        for k in range(1, e + 1):
            P[:, 2 * k - 1] = ch["Ra"][:, k] @ h[2 * k - 1] + ch["ta"][:, k]
            P[:, 2 * k] = ch["Rb"][:, k] @ h[2 * k] + ch["tb"][:, k]
        pts.append(P)
    return pts


def cable_lengths(robot: Robot, theta) -> np.ndarray:
    """Lengths ``(N, m)`` m of every cable (file order): ``sum_k |A_k - B_(k-1)| + |B_k - A_k|``."""
    robot, ch = _frames(robot, theta)
    out = np.empty((ch["tb"].shape[0], robot.m))
    for c, P in enumerate(cable_points(robot, theta, ch)):
        seg = P[:, 1::2] - P[:, 0:-1:2]  # A_k - B_(k-1)
        trav = P[:, 2::2] - P[:, 1::2]  # B_k - A_k
        out[:, c] = np.linalg.norm(seg, axis=-1).sum(1) + np.linalg.norm(trav, axis=-1).sum(1)
    return out


def position_lengths(robot: Robot, theta) -> np.ndarray:
    """Lengths ``(N, m_pos)`` m of the position-controlled cables (the commanded ones;
    planar: the upper cables)."""
    robot = as_robot(robot)
    return cable_lengths(robot, theta)[:, position_cables(robot)]


def segment_lengths(robot: Robot, theta) -> np.ndarray:
    """Gap lengths ``|A_k - B_(k-1)|`` ``(N, m, K)`` m of every cable (0 where cable ``c``
    does not reach disk ``k``)."""
    robot, ch = _frames(robot, theta)
    out = np.zeros((ch["tb"].shape[0], robot.m, robot.disks))
    for c, P in enumerate(cable_points(robot, theta, ch)):
        e = int(robot.cable_end[c])
        out[:, c, :e] = np.linalg.norm(P[:, 1::2] - P[:, 0:-1:2], axis=-1)
    return out


def unit_vectors(d: np.ndarray) -> np.ndarray:
    """``d / |d|`` along the last axis, 0 where ``|d| = 0``."""
    norm = np.linalg.norm(d, axis=-1, keepdims=True)
    return np.where(norm > 0.0, d / np.where(norm > 0.0, norm, 1.0), 0.0)


def cable_jacobian(robot: Robot, theta) -> np.ndarray:
    """Analytic ``dL/dtheta (N, m, n)`` m/rad of every cable (file order):
    ``sum_k u_k . (dA_k/dtheta_j - dB_(k-1)/dtheta_j)``, ``u_k`` the unit segment
    ``B_(k-1) -> A_k`` (a zero-length segment contributes 0)."""
    robot, ch = _frames(robot, theta)
    J = np.zeros((ch["tb"].shape[0], robot.m, robot.n))
    for c, P in enumerate(cable_points(robot, theta, ch)):
        for k in range(1, int(robot.cable_end[c]) + 1):
            A, B = P[:, 2 * k - 1], P[:, 2 * k - 2]
            u = unit_vectors(A - B)
            dA = point_jacobian(robot, ch, A, k)
            dB = point_jacobian(robot, ch, B, k - 1)
            J[:, c] += np.einsum("ni,nij->nj", u, dA - dB)
    return J


def cable_hole_gradient(robot: Robot, theta) -> np.ndarray:
    """``dL_c / d(hole coordinates)`` ``(N, m, 3H)`` m/m: every cable against every hole
    coordinate of the arm, the holes flat (cable by cable in file order, each cable's
    points in order, ``x, y, z`` in their face frames; ``H`` the number of points).

    Gap ``k``: ``v = A_k - B_(k-1)``, ``u = v / |v|``: ``d|v|/da = R_ka^T u`` on face a of
    disk ``k``, ``d|v|/db = -R_(k-1)b^T u`` on face b of disk ``k - 1``.  Traversal of
    disk ``k``: ``t = B_k - A_k``: ``d|t|/db = R_kb^T t/|t|``, ``d|t|/da = -R_ka^T t/|t|``
    (``docs/model.md``, "Sensitivities").  A cable's entries of other cables' holes are 0.
    """
    robot, ch = _frames(robot, theta)
    N = ch["tb"].shape[0]
    starts = np.cumsum([0] + [3 * h.shape[0] for h in robot.holes])
    grad = np.zeros((N, robot.m, int(starts[-1])))

    def add(c, i, R, v):
        grad[:, c, starts[c] + 3 * i:starts[c] + 3 * i + 3] += np.einsum("nji,nj->ni", R, v)

    for c, P in enumerate(cable_points(robot, theta, ch)):
        for k in range(1, int(robot.cable_end[c]) + 1):
            u = unit_vectors(P[:, 2 * k - 1] - P[:, 2 * k - 2])
            add(c, 2 * k - 1, ch["Ra"][:, k], u)
            add(c, 2 * k - 2, ch["Rb"][:, k - 1], -u)
            t = unit_vectors(P[:, 2 * k] - P[:, 2 * k - 1])
            add(c, 2 * k, ch["Rb"][:, k], t)
            add(c, 2 * k - 1, ch["Ra"][:, k], -t)
    return grad
