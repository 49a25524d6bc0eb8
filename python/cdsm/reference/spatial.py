"""Independent, vectorised NumPy reference of the SPATIAL arm model (``docs/spatial.md``).

Written from ``docs/spatial.md`` (and the planar conventions of ``docs/model.md``
it must reproduce) alone, without looking at the Rust core; the tests use it to
cross-check ``cdsm.Robot`` for ``kind = "spatial"`` robot files.  It is meant to
be read: simple loops over joints, disks, cables and solver iterations, NumPy
vectorisation over the batch dimension ``N`` only.

Units: SI everywhere -- lengths m, angles rad, forces N, moments N m, masses
kg, gravity m/s^2.  Orientations are rotation vectors ``r = angle * axis``
(rad, principal logarithm, ``angle`` in ``[0, pi]``).

Contents

* :class:`SpatialRobot`, :func:`parse_spatial` (the TOML robot file, with the
  spec's validation rules; errors are ``ValueError`` naming the field) and
  :func:`load_spatial` (from a path).
* Rotations: :func:`rotation_matrix`, :func:`exp_so3`, :func:`log_so3`.
* Kinematics, batched over ``theta (N, n)``: :func:`fk_matrix`, :func:`fk`,
  :func:`disk_frames`, :func:`joint_positions_axes`, :func:`geometric_jacobian`,
  :func:`cable_points`, :func:`cable_lengths`, :func:`cable_jacobian`,
  :func:`position_cables`.
* Solves (own Levenberg--Marquardt loop, the rules of ``docs/model.md``):
  :func:`solve_cables`, :func:`ik`.
* Statics: :func:`moment_matrices`, :func:`external_moments`,
  :func:`min_norm_tensions` (the small QP) and :func:`tensions`.

Robot file: ``[[cables]]`` tables, one per cable, and the optional ``[cable]``
table of the material (``youngs_modulus`` Pa, ``diameter`` m, ``routing_length``
m; defaults steel, 0.18 mm, 0 m, as for planar arms).
"""

from __future__ import annotations

import itertools

import numpy as np

from .robot import Robot, load_robot, read_robot

__all__ = [
    "SpatialRobot",
    "parse_spatial",
    "load_spatial",
    "rotation_matrix",
    "exp_so3",
    "log_so3",
    "fk_matrix",
    "fk",
    "disk_frames",
    "joint_positions_axes",
    "geometric_jacobian",
    "cable_points",
    "cable_lengths",
    "cable_jacobian",
    "position_cables",
    "force_cables",
    "solve_cables",
    "ik",
    "moment_matrices",
    "external_moments",
    "min_norm_tensions",
    "tensions",
]

# Solver constants of docs/model.md ("Solves").
_LAMBDA_0 = 1e-3
_LAMBDA_MIN = 1e-12
_LAMBDA_MAX = 1e12
#: Least-squares cable solve (m > n): converged when an accepted step lowers
#: |r|^2 by less than this fraction of itself.
_STALL = 1e-12
#: Relative tolerance of the statics QP (feasibility of the floor, consistency).
_QP_RTOL = 1e-12

_MASKS = ("position", "pointing", "pose")


# --------------------------------------------------------------------------
# Robot description (:mod:`.robot`; the old names until the tests have moved)
# --------------------------------------------------------------------------
SpatialRobot = Robot
parse_spatial = read_robot
load_spatial = load_robot


def position_cables(robot: SpatialRobot) -> np.ndarray:
    """Indices (0-based, file order) of the position-controlled cables, ``(m_pos,)`` int."""
    return np.array([c for c, mode in enumerate(robot.cable_mode) if mode == "position"], dtype=np.int64)


def force_cables(robot: SpatialRobot) -> np.ndarray:
    """Indices (0-based, file order) of the force-controlled cables, ``(m - m_pos,)`` int."""
    return np.array([c for c, mode in enumerate(robot.cable_mode) if mode == "force"], dtype=np.int64)


# --------------------------------------------------------------------------
# Rotations
# --------------------------------------------------------------------------
def _skew(a: np.ndarray) -> np.ndarray:
    """``[a]x`` ``(..., 3, 3)`` of vectors ``a (..., 3)``."""
    z = np.zeros(a.shape[:-1])
    return np.stack(
        [
            np.stack([z, -a[..., 2], a[..., 1]], -1),
            np.stack([a[..., 2], z, -a[..., 0]], -1),
            np.stack([-a[..., 1], a[..., 0], z], -1),
        ],
        -2,
    )


def rotation_matrix(axis, angle) -> np.ndarray:
    """Rotation ``(..., 3, 3)`` by ``angle (...)`` rad about the unit ``axis (3,)`` or ``(..., 3)``
    (Rodrigues: ``I + sin t [a]x + (1 - cos t) [a]x^2``)."""
    axis = np.asarray(axis, dtype=float)
    angle = np.asarray(angle, dtype=float)
    shape = np.broadcast_shapes(axis.shape[:-1], angle.shape)
    axis = np.broadcast_to(axis, shape + (3,))
    angle = np.broadcast_to(angle, shape)
    K = _skew(axis)
    s, c = np.sin(angle)[..., None, None], np.cos(angle)[..., None, None]
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


def exp_so3(r) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` of rotation vectors ``r (..., 3)`` rad.

    ``R = I + A [r]x + B [r]x^2`` with ``A = sin t / t``, ``B = (1 - cos t) / t^2``,
    ``t = |r|``; Taylor series below ``t = 1e-4`` (exact to rounding at 0)."""
    r = np.asarray(r, dtype=float)
    t = np.linalg.norm(r, axis=-1)
    small = t < 1e-4
    ts = np.where(small, 1.0, t)
    A = np.where(small, 1.0 - t**2 / 6.0 + t**4 / 120.0, np.sin(ts) / ts)
    B = np.where(small, 0.5 - t**2 / 24.0 + t**4 / 720.0, (1.0 - np.cos(ts)) / ts**2)
    K = _skew(r)
    return np.eye(3) + A[..., None, None] * K + B[..., None, None] * (K @ K)


def log_so3(R) -> np.ndarray:
    """Principal rotation vectors ``(..., 3)`` rad of rotation matrices ``R (..., 3, 3)``.

    ``angle = atan2(|v|, (tr R - 1)/2)`` in ``[0, pi]`` with ``v = vee(R - R^T)/2
    = sin(angle) axis``.  For ``angle <= pi/2`` the vector is ``angle / sin(angle) v``
    (ratio 1 at ``v = 0``).  Beyond, the axis comes from the symmetric part
    ``(R + R^T)/2 - cos(angle) I = (1 - cos(angle)) axis axis^T`` (its largest
    column), with the sign of ``v``; exactly at ``pi`` (``v = 0``) the axis's
    largest component is made positive (both signs are principal logarithms).
    """
    R = np.asarray(R, dtype=float)
    v = 0.5 * np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    s = np.linalg.norm(v, axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    angle = np.arctan2(s, c)
    ratio = np.where(s > 0.0, angle / np.where(s > 0.0, s, 1.0), 1.0)
    out = ratio[..., None] * v
    near_pi = c < 0.0
    if np.any(near_pi):
        Rn, vn, cn, an = R[near_pi], v[near_pi], c[near_pi], angle[near_pi]
        B = (0.5 * (Rn + np.swapaxes(Rn, -1, -2)) - cn[:, None, None] * np.eye(3)) / (1.0 - cn)[:, None, None]
        i = np.argmax(np.diagonal(B, axis1=-2, axis2=-1), axis=-1)
        col = B[np.arange(B.shape[0]), :, i]
        axis = col / np.linalg.norm(col, axis=-1, keepdims=True)
        dot = (axis * vn).sum(-1)
        big = np.take_along_axis(axis, np.argmax(np.abs(axis), axis=-1)[:, None], -1)[:, 0]
        flip = (dot < 0.0) | ((dot == 0.0) & (big < 0.0))
        axis = np.where(flip[:, None], -axis, axis)
        out[near_pi] = an[:, None] * axis
    return out


# --------------------------------------------------------------------------
# Forward kinematics
# --------------------------------------------------------------------------
def as_theta(robot: SpatialRobot, theta) -> np.ndarray:
    """``theta`` as a float ``(N, n)`` array (rad); ValueError otherwise."""
    th = np.asarray(theta, dtype=float)
    if th.ndim != 2 or th.shape[1] != robot.n:
        raise ValueError(f"theta must have shape (N, {robot.n}), got {th.shape}")
    return th


def chain_frames(robot: SpatialRobot, theta: np.ndarray) -> dict:
    """The frames of the chain for ``theta (N, n)`` rad.

    Returns rotation ``Ra, Rb (N, K+1, 3, 3)`` and origins ``ta, tb (N, K+1, 3)``
    of the faces ``F_ka`` and ``F_kb`` (index 0: the base face, the identity;
    ``Ra[:, 0]`` is unused and set to it too), joint origins ``p (N, n, 3)`` m
    and world axes ``w (N, n, 3)``.
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


def fk_matrix(robot: SpatialRobot, theta) -> np.ndarray:
    """End frame ``F_Kb`` (distal face of the last disk) ``(N, 4, 4)``, translation in m."""
    ch = chain_frames(robot, as_theta(robot, theta))
    N = ch["tb"].shape[0]
    T = np.zeros((N, 4, 4))
    T[:, :3, :3] = ch["Rb"][:, -1]
    T[:, :3, 3] = ch["tb"][:, -1]
    T[:, 3, 3] = 1.0
    return T


def fk(robot: SpatialRobot, theta) -> np.ndarray:
    """Task vector ``(N, 6)``: ``[x, y, z]`` m of ``F_Kb`` and its rotation vector ``[rx, ry, rz]`` rad."""
    ch = chain_frames(robot, as_theta(robot, theta))
    return np.concatenate([ch["tb"][:, -1], log_so3(ch["Rb"][:, -1])], axis=1)


def disk_frames(robot: SpatialRobot, theta) -> dict:
    """Face frames of every disk: ``Ra, Rb (N, K+1, 3, 3)`` rotations and ``ta, tb (N, K+1, 3)``
    m origins of ``F_ka`` (proximal) and ``F_kb`` (distal); index 0 is the base face
    (the identity, also stored as ``Ra[:, 0]``, ``ta[:, 0]``)."""
    ch = chain_frames(robot, as_theta(robot, theta))
    return {key: ch[key] for key in ("Ra", "ta", "Rb", "tb")}


def joint_positions_axes(robot: SpatialRobot, theta):
    """Joint origins ``p (N, n, 3)`` m and unit world axes ``w (N, n, 3)``."""
    ch = chain_frames(robot, as_theta(robot, theta))
    return ch["p"], ch["w"]


def _point_jacobian(robot: SpatialRobot, ch: dict, q: np.ndarray, disk: int) -> np.ndarray:
    """``dq/dtheta (N, 3, n)`` m/rad of world points ``q (N, 3)`` fixed to disk ``disk`` (0 = base)."""
    J = np.cross(ch["w"], q[:, None, :] - ch["p"])  # (N, n, 3)
    J = np.where((robot.joint_disk <= disk)[None, :, None], J, 0.0)
    return np.swapaxes(J, 1, 2)


def geometric_jacobian(robot: SpatialRobot, theta) -> np.ndarray:
    """Geometric Jacobian ``(N, 6, n)`` of the end frame: rows 0-2 the linear velocity
    of its origin (m/rad), rows 3-5 the angular velocity (rad/rad), base frame."""
    ch = chain_frames(robot, as_theta(robot, theta))
    tip = ch["tb"][:, -1]
    lin = np.cross(ch["w"], tip[:, None, :] - ch["p"])  # (N, n, 3)
    return np.concatenate([np.swapaxes(lin, 1, 2), np.swapaxes(ch["w"], 1, 2)], axis=1)


# --------------------------------------------------------------------------
# Holes and cables
# --------------------------------------------------------------------------
def _cable_points(robot: SpatialRobot, ch: dict) -> list:
    pts = []
    N = ch["tb"].shape[0]
    for c in range(robot.m):
        e, h = int(robot.cable_end[c]), robot.holes[c]
        P = np.empty((N, 2 * e + 1, 3))
        P[:, 0] = h[0]  # B_0 = F_0b h_0, F_0b = I
        for k in range(1, e + 1):
            P[:, 2 * k - 1] = ch["Ra"][:, k] @ h[2 * k - 1] + ch["ta"][:, k]  # A_k
            P[:, 2 * k] = ch["Rb"][:, k] @ h[2 * k] + ch["tb"][:, k]  # B_k
        pts.append(P)
    return pts


def cable_points(robot: SpatialRobot, theta) -> list:
    """World points of every hole: a list (one per cable, file order) of ``(N, 2 e_c + 1, 3)``
    m arrays ``[B_0, A_1, B_1, ..., A_e, B_e]``."""
    return _cable_points(robot, chain_frames(robot, as_theta(robot, theta)))


def cable_lengths(robot: SpatialRobot, theta) -> np.ndarray:
    """Lengths ``(N, m)`` m of every cable (file order): ``sum_k |A_k - B_(k-1)| + |B_k - A_k|``."""
    pts = cable_points(robot, theta)
    out = np.empty((pts[0].shape[0] if pts else 0, robot.m))
    for c, P in enumerate(pts):
        seg = P[:, 1::2] - P[:, 0:-1:2]  # A_k - B_(k-1)
        trav = P[:, 2::2] - P[:, 1::2]  # B_k - A_k
        out[:, c] = np.linalg.norm(seg, axis=-1).sum(1) + np.linalg.norm(trav, axis=-1).sum(1)
    return out


def _unit(d: np.ndarray) -> np.ndarray:
    """``d / |d|`` along the last axis, 0 where ``|d| = 0``."""
    norm = np.linalg.norm(d, axis=-1, keepdims=True)
    return np.where(norm > 0.0, d / np.where(norm > 0.0, norm, 1.0), 0.0)


def cable_jacobian(robot: SpatialRobot, theta) -> np.ndarray:
    """Analytic ``dL/dtheta (N, m, n)`` m/rad of every cable (file order):
    ``sum_k u_k . (dA_k/dtheta_j - dB_(k-1)/dtheta_j)``, ``u_k`` the unit segment
    ``B_(k-1) -> A_k`` (a zero-length segment contributes 0)."""
    th = as_theta(robot, theta)
    ch = chain_frames(robot, th)
    pts = _cable_points(robot, ch)
    J = np.zeros((th.shape[0], robot.m, robot.n))
    for c, P in enumerate(pts):
        for k in range(1, int(robot.cable_end[c]) + 1):
            A, B = P[:, 2 * k - 1], P[:, 2 * k - 2]
            u = _unit(A - B)
            dA = _point_jacobian(robot, ch, A, k)
            dB = _point_jacobian(robot, ch, B, k - 1)
            J[:, c] += np.einsum("ni,nij->nj", u, dA - dB)
    return J


# --------------------------------------------------------------------------
# Solver (docs/model.md "Solves")
# --------------------------------------------------------------------------
def _levenberg_marquardt(residual, step, theta, tol, max_iter, lambda0, stall=None) -> dict:
    """Vectorised LM: each row has its own lambda and stops on its own.

    ``residual(theta, idx) -> (k, rows)``, ``step(theta, r, lam, idx) -> delta (k, n)``.
    A trial is accepted when it lowers ``|r|^2`` (``lambda <- max(lambda/10, 1e-12)``),
    otherwise ``lambda <- 10 lambda`` (from 0: ``1e-3``).  Converged when
    ``max|r| <= tol`` or, with ``stall``, when an accepted step lowers ``|r|^2`` by
    less than ``stall |r|^2``; failed after ``max_iter`` trials or ``lambda > 1e12``.
    """
    N = theta.shape[0]
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
            r_trial = residual(trial, idx)
        f_trial = (r_trial**2).sum(1)
        iterations[idx] += 1
        accept = f_trial < f[idx]  # NaN: rejected
        acc, rej = idx[accept], idx[~accept]
        if stall is not None:
            converged[acc] |= (f[acc] - f_trial[accept]) < stall * f[acc]
        theta[acc], r[acc], f[acc] = trial[accept], r_trial[accept], f_trial[accept]
        lam[acc] = np.maximum(lam[acc] / 10.0, _LAMBDA_MIN)
        lam[rej] = np.where(lam[rej] == 0.0, _LAMBDA_0, 10.0 * lam[rej])
        converged[idx] |= np.abs(r[idx]).max(1) <= tol
        active[idx] = ~converged[idx] & (iterations[idx] < max_iter) & (lam[idx] <= _LAMBDA_MAX)
    return dict(theta=theta, converged=converged, iterations=iterations, residual=np.abs(r).max(1, initial=0.0))


def _seed(robot: SpatialRobot, seed, N: int) -> np.ndarray:
    if seed is None:
        return np.zeros((N, robot.n))
    s = np.array(seed, dtype=float)
    if s.ndim == 1:
        s = np.tile(s, (N, 1))
    if s.shape != (N, robot.n):
        raise ValueError(f"seed must have shape ({N}, {robot.n}) or ({robot.n},), got {np.shape(seed)}")
    return s.copy()


def _within_limits(robot: SpatialRobot, theta: np.ndarray) -> np.ndarray:
    return np.all((theta >= robot.joint_limits[:, 0]) & (theta <= robot.joint_limits[:, 1]), axis=1)


def solve_cables(robot: SpatialRobot, lengths_pos, seed=None, tol=1e-12, max_iter=100) -> dict:
    """Commanded lengths of the position-controlled cables -> joint angles.

    ``lengths_pos (N, m_pos)`` m (in the order of :func:`position_cables`);
    ``seed (N, n)`` or ``(n,)`` rad, default 0.  LM on
    ``r = L_pos(theta) - L_cmd`` with the normal-equation step
    ``delta = -(J^T J + lambda I)^{-1} J^T r`` from ``lambda_0 = 0`` (Gauss--Newton /
    Newton).  Converged when ``max|r| <= tol``, or for ``m_pos > n`` (least squares)
    when an accepted step lowers ``|r|^2`` by less than ``1e-12`` of itself.

    Returns ``theta (N, n)`` rad, ``converged (N,)``, ``iterations (N,)`` (trials),
    ``residual (N,)`` m (``max|r|``: the misfit of inconsistent lengths), ``within_limits (N,)``.
    """
    pos = position_cables(robot)
    L = np.asarray(lengths_pos, dtype=float)
    if L.ndim != 2 or L.shape[1] != pos.size:
        raise ValueError(f"lengths_pos must have shape (N, {pos.size}), got {L.shape}")
    theta = _seed(robot, seed, L.shape[0])

    def residual(th, idx):
        return cable_lengths(robot, th)[:, pos] - L[idx]

    def step(th, r, lam, idx):
        J = cable_jacobian(robot, th)[:, pos, :]
        Jt = np.swapaxes(J, 1, 2)
        A = Jt @ J + lam[:, None, None] * np.eye(robot.n)
        return -solve_batched(A, (Jt @ r[..., None])[..., 0])

    stall = _STALL if pos.size > robot.n else None
    sol = _levenberg_marquardt(residual, step, theta, tol, max_iter, lambda0=0.0, stall=stall)
    sol["within_limits"] = _within_limits(robot, sol["theta"])
    return sol


def solve_batched(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise ``A x = b`` (``A (k, n, n)``); a singular row gives NaN (its trial is rejected)."""
    x = np.full(b.shape, np.nan)
    for i in range(A.shape[0]):
        try:
            x[i] = np.linalg.solve(A[i], b[i])
        except np.linalg.LinAlgError:
            pass
    return x


def _damped_min_norm_step(J: np.ndarray, r: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """``-J^T (J J^T + lambda I)^{-1} r`` row-wise, through the SVD of ``J (k, rows, n)``:
    ``-sum_i s_i / (s_i^2 + lambda) (u_i . r) v_i`` (stable when ``J`` is rank deficient)."""
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    coef = s / (s**2 + lam[:, None])
    coef = np.where(s > 0.0, coef, 0.0)
    y = coef * np.einsum("kri,kr->ki", U, r)
    return -np.einsum("kin,ki->kn", Vt, y)


def _ik_residual_jacobian(robot: SpatialRobot, theta, target_p, target_R, mask: str, jacobian: bool):
    ch = chain_frames(robot, theta)
    p, R = ch["tb"][:, -1], ch["Rb"][:, -1]
    rows = [p - target_p]
    if mask == "pointing":
        d, dt = R[:, :, 0], target_R[:, :, 0]
        rows.append(d - dt)
    elif mask == "pose":
        err = log_so3(np.swapaxes(target_R, 1, 2) @ R)  # in the target frame
        rows.append(np.einsum("nij,nj->ni", target_R, err))  # in the base frame
    r = np.concatenate(rows, axis=1)
    if not jacobian:
        return r, None
    w = ch["w"]  # (k, n, 3)
    blocks = [np.swapaxes(np.cross(w, p[:, None, :] - ch["p"]), 1, 2)]
    if mask == "pointing":
        blocks.append(np.swapaxes(np.cross(w, R[:, None, :, 0]), 1, 2))
    elif mask == "pose":
        blocks.append(np.swapaxes(w, 1, 2))
    return r, np.concatenate(blocks, axis=1)


def ik(robot: SpatialRobot, target, seed=None, mask="pose", tol=1e-12, max_iter=100) -> dict:
    """Pose IK by damped least squares (``docs/spatial.md`` "Solves").

    ``target (N, 6)``: ``[x, y, z]`` m and a rotation vector rad of the end frame
    ``F_Kb``; ``mask``: ``"position"`` (3 rows ``p - p_t``), ``"pointing"``
    (6 rows: ``p - p_t`` and ``d - d_t``, ``d = R e_x``) or ``"pose"`` (6 rows:
    ``p - p_t`` and ``R_t log(R_t^T R)``).  Geometric Jacobian, minimal-norm damped
    step ``-J^T (J J^T + lambda I)^{-1} r`` from ``lambda_0 = 1e-3``, default seed 0.
    Returns the dict of :func:`solve_cables` (``residual`` = max of the masked rows,
    m and rad mixed).
    """
    if mask not in _MASKS:
        raise ValueError(f"mask must be one of {_MASKS}, got {mask!r}")
    tg = np.asarray(target, dtype=float)
    if tg.ndim != 2 or tg.shape[1] != 6:
        raise ValueError(f"target must have shape (N, 6), got {tg.shape}")
    target_p, target_R = tg[:, :3], exp_so3(tg[:, 3:])
    theta = _seed(robot, seed, tg.shape[0])

    def residual(th, idx):
        return _ik_residual_jacobian(robot, th, target_p[idx], target_R[idx], mask, False)[0]

    def step(th, r, lam, idx):
        _, J = _ik_residual_jacobian(robot, th, target_p[idx], target_R[idx], mask, True)
        return _damped_min_norm_step(J, r, lam)

    sol = _levenberg_marquardt(residual, step, theta, tol, max_iter, lambda0=_LAMBDA_0)
    sol["within_limits"] = _within_limits(robot, sol["theta"])
    return sol


# --------------------------------------------------------------------------
# Statics
# --------------------------------------------------------------------------
def moment_matrices(robot: SpatialRobot, theta) -> np.ndarray:
    """Cable moment matrix ``M (N, n, m)`` N m per N: the moment about the axis of
    joint ``j`` (linkage ``k``) of a unit pull of cable ``c`` on the part distal of
    the joint, ``w_j . ((A_k - p_j) x unit(B_(k-1) - A_k))`` (0 when ``e_c < k``).

    Balance: ``M T + tau = 0`` with :func:`external_moments` ``tau``; virtual work
    makes ``M = -(dL/dtheta)^T``.
    """
    th = as_theta(robot, theta)
    ch = chain_frames(robot, th)
    pts = _cable_points(robot, ch)
    M = np.zeros((th.shape[0], robot.n, robot.m))
    for c, P in enumerate(pts):
        for j in range(robot.n):
            k = int(robot.joint_disk[j])
            if robot.cable_end[c] < k:
                continue
            A, B = P[:, 2 * k - 1], P[:, 2 * k - 2]
            e = _unit(B - A)
            M[:, j, c] = (ch["w"][:, j] * np.cross(A - ch["p"][:, j], e)).sum(-1)
    return M


def external_moments(robot: SpatialRobot, theta, tip_wrench=None) -> np.ndarray:
    """``tau (N, n)`` N m: moment about each joint axis of the loads on the part distal
    of it -- gravity ``mass_b g`` at every disk's centre of mass (disks ``b >= k``) and
    the tip wrench ``[F (N), M (N m)]`` ``(6,)`` or ``(N, 6)`` (base frame, at the origin
    of ``F_Kb``)."""
    th = as_theta(robot, theta)
    ch = chain_frames(robot, th)
    N = th.shape[0]
    tau = np.zeros((N, robot.n))
    g = np.asarray(robot.gravity, dtype=float)
    if np.any(g != 0.0):
        for b in range(1, robot.disks + 1):
            centre = ch["Ra"][:, b] @ robot.com[b - 1] + ch["ta"][:, b]
            weight = robot.mass[b - 1] * g
            arm = centre[:, None, :] - ch["p"]
            mom = (ch["w"] * np.cross(arm, weight)).sum(-1)  # (N, n)
            tau += np.where(robot.joint_disk[None, :] <= b, mom, 0.0)
    if tip_wrench is not None:
        W = np.broadcast_to(np.asarray(tip_wrench, dtype=float), (N, 6))
        tip = ch["tb"][:, -1]
        mom = np.cross(tip[:, None, :] - ch["p"], W[:, None, :3]) + W[:, None, 3:]
        tau += (ch["w"] * mom).sum(-1)
    return tau


def min_norm_tensions(A, b, floor=0.0):
    """Minimum-norm ``T`` with ``A T = b`` and ``T >= floor``, row-wise.

    ``A (N, n, m)``, ``b (N, n)``, ``floor`` scalar or ``(m,)``.  Active sets are
    enumerated (``m`` small: ``2^m`` working sets): for each set ``S`` of cables held
    at the floor the free tensions are the minimum-norm solution of
    ``A_F T_F = b - A_S floor_S`` (pseudo-inverse); a candidate counts when that
    system is consistent and ``T_F >= floor`` (both to ``1e-12`` relative).  The
    optimum is the candidate of least norm (the problem is strictly convex, so its
    own active set yields it).  Returns ``T (N, m)`` (NaN where no ``T >= floor``
    solves the balance) and ``feasible (N,)``.
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float)
    N, n, m = A.shape
    if m > 16:
        raise ValueError(f"min_norm_tensions enumerates 2^m active sets; m = {m} is too many")
    f = np.broadcast_to(np.asarray(floor, dtype=float), (m,))
    best = np.full((N, m), np.nan)
    best_norm = np.full(N, np.inf)
    scale_A = np.abs(A).max(axis=(1, 2), initial=0.0)
    scale_b = np.abs(b).max(1, initial=0.0)
    for at_floor in itertools.product((False, True), repeat=m):
        act = np.array(at_floor, dtype=bool)
        free = ~act
        T = np.empty((N, m))
        T[:, act] = f[act]
        rhs = b - A[:, :, act] @ f[act]
        if free.any():
            Af = A[:, :, free]
            T[:, free] = np.einsum("nij,nj->ni", np.linalg.pinv(Af), rhs)
            res = np.abs(np.einsum("nij,nj->ni", Af, T[:, free]) - rhs).max(1, initial=0.0)
        else:
            res = np.abs(rhs).max(1, initial=0.0)
        size = np.maximum(np.abs(T).max(1), np.abs(f).max(initial=0.0))
        consistent = res <= _QP_RTOL * 10.0 * (scale_A * size + scale_b) + 1e-300
        above = np.all(T >= f - _QP_RTOL * np.maximum(size, 1e-300)[:, None], axis=1)
        norm = (T**2).sum(1)
        better = consistent & above & (norm < best_norm)
        best[better] = T[better]
        best_norm[better] = norm[better]
    feasible = np.isfinite(best_norm)
    return best, feasible


def tensions(robot: SpatialRobot, theta, min_tension=0.0, tip_wrench=None):
    """Quasi-static tensions of the position-controlled cables.

    Moment balance about every joint axis (``n`` equations, :func:`moment_matrices`,
    :func:`external_moments` with the robot's gravity and the optional tip wrench
    ``(6,)`` or ``(N, 6)`` ``[F N, M N m]``); force cables at their file tension; of
    the position-cable tensions solving ``M_p T_p = -(tau + M_f T_f)`` with every
    ``T_p >= min_tension`` (N) the minimum-norm one.

    Returns ``T (N, m_pos)`` N (order of :func:`position_cables`; NaN where no
    such tension set exists) and ``feasible (N,)`` bool.
    """
    th = as_theta(robot, theta)
    M = moment_matrices(robot, th)
    tau = external_moments(robot, th, tip_wrench)
    pos, frc = position_cables(robot), force_cables(robot)
    b = -(tau + M[:, :, frc] @ robot.cable_tension[frc])
    return min_norm_tensions(M[:, :, pos], b, min_tension)
