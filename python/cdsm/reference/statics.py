"""Statics and cable elasticity of an arm of either kind: the moment balance
about every joint axis, its tensions (the square solve, and the minimum-norm
set above a floor), and the elastic cable solve.

Written from ``docs/model.md`` ("Statics, slack cables and cable
elasticity") and ``docs/spatial.md`` ("Statics"), independent of the Rust
core.  Quasi-static, frictionless pins, massless straight cables.  Cut the arm
just distal of joint ``j`` (a joint of disk ``k``): the cut-off part is held by
the cables crossing the cut, each pulling at its hole ``A_k`` along
``unit(B_(k-1) - A_k)`` with its tension, by gravity on the disks ``b >= k`` at
their centres of mass, and by the tip wrench; the moments about the joint's
axis balance.  Friction in the holes enters as the factors of each cable's
tension in the gap of each joint (``gap``, :func:`.plant.friction_factors`).

Units: m, rad, N, N m, kg, m/s^2, Pa.
"""

from __future__ import annotations

import itertools

import numpy as np

from .kinematics import as_theta, cable_points, chain_frames, cross, position_lengths, unit_vectors, within_limits
from .robot import Robot, as_robot, force_cables, position_cables
from .solve import levenberg_marquardt, solve_cables, solve_rows

__all__ = [
    "moment_matrices",
    "external_moments",
    "tensions",
    "min_norm_tensions",
    "feasible_tensions",
    "elastic_lengths",
    "cable_stretch",
    "solve_cables_elastic",
]

#: Relative tolerance of the minimum-norm QP (feasibility of the floor, consistency).
QP_RTOL = 1e-12


def moment_matrices(robot: Robot, theta, frames: dict | None = None) -> np.ndarray:
    """Cable moment matrix ``M (N, n, m)`` N m per N: the moment about the axis of
    joint ``j`` (of disk ``k``) of a unit pull of cable ``c`` on the part distal of
    the joint, ``w_j . ((A_k - p_j) x unit(B_(k-1) - A_k))`` (0 when ``e_c < k``).

    Balance: ``M T + tau = 0`` with :func:`external_moments` ``tau``; virtual work
    makes ``M = -(dL/dtheta)^T``.  ``frames``: :func:`.kinematics.chain_frames` at ``theta``
    when at hand.
    """
    robot = as_robot(robot)
    th = as_theta(robot, theta)
    ch = chain_frames(robot, th) if frames is None else frames
    M = np.zeros((th.shape[0], robot.n, robot.m))
    k = robot.joint_disk  # (n,): the disk of each joint
    for c, P in enumerate(cable_points(robot, th, ch)):
        crosses = k <= robot.cable_end[c]  # the joints whose cut cable c crosses
        A, B = P[:, 2 * k[crosses] - 1], P[:, 2 * k[crosses] - 2]  # (N, j, 3): A_k, B_(k-1) of each
        M[:, crosses, c] = (ch["w"][:, crosses] * cross(A - ch["p"][:, crosses], unit_vectors(B - A))).sum(-1)
    return M


def _gravity(gravity) -> np.ndarray:
    """``(3,)`` m/s^2 of an in-plane ``(2,)`` or a ``(3,)`` gravity."""
    g = np.asarray(gravity, dtype=float).ravel()
    if g.size not in (2, 3):
        raise ValueError(f"gravity must have 2 (in-plane) or 3 entries, got {g.size}")
    return np.concatenate([g, np.zeros(3 - g.size)])


def _wrench(robot: Robot, tip_wrench, N: int) -> np.ndarray:
    """The tip wrench as ``(N, 6)`` ``[F, M]`` from the task's entries (the kind's
    ``task_rows``: planar ``[Fx, Fy, Mz]`` N, N, N m; spatial ``[Fx, Fy, Fz, Mx, My, Mz]``)."""
    rows = list(robot.kind.task_rows)
    W = np.zeros((N, 6))
    W[:, rows] = np.broadcast_to(np.asarray(tip_wrench, dtype=float), (N, len(rows)))
    return W


def external_moments(robot: Robot, theta, tip_wrench=None, gravity=None, mass=None,
                     frames: dict | None = None) -> np.ndarray:
    """``tau (N, n)`` N m: moment about each joint axis of the loads on the part distal
    of it -- gravity ``mass_b g`` at every disk's centre of mass (disks ``b >= k``) and
    the tip wrench (base frame, at the origin of ``F_Kb``; planar ``[Fx, Fy, Mz]``,
    spatial ``[F, M]``; ``(t,)`` or ``(N, t)``).  ``gravity``: the robot's (default)
    or ``(2,)`` in-plane / ``(3,)`` m/s^2; ``mass``: ``(K,)`` kg (default the robot's);
    ``frames``: :func:`.kinematics.chain_frames` at ``theta`` when at hand."""
    robot = as_robot(robot)
    th = as_theta(robot, theta)
    ch = chain_frames(robot, th) if frames is None else frames
    N = th.shape[0]
    tau = np.zeros((N, robot.n))
    g = robot.gravity if gravity is None else _gravity(gravity)
    mass = robot.mass if mass is None else np.asarray(mass, dtype=float).reshape(robot.disks)
    if np.any(g != 0.0):
        for b in range(1, robot.disks + 1):
            centre = ch["Ra"][:, b] @ robot.com[b - 1] + ch["ta"][:, b]
            arm = centre[:, None, :] - ch["p"]
            mom = (ch["w"] * cross(arm, mass[b - 1] * g)).sum(-1)  # (N, n)
            tau += np.where(robot.joint_disk[None, :] <= b, mom, 0.0)
    if tip_wrench is not None:
        W = _wrench(robot, tip_wrench, N)
        tip = ch["tb"][:, -1]
        mom = cross(tip[:, None, :] - ch["p"], W[:, None, :3]) + W[:, None, 3:]
        tau += (ch["w"] * mom).sum(-1)
    return tau


def tensions(robot: Robot, theta, lower=None, tip_wrench=None, gravity=None, mass=None, gap=None,
             frames: dict | None = None) -> np.ndarray:
    """Position-cable tensions ``(N, m_pos)`` N from the moment balance, for an arm with
    as many position cables as joints (the square solve, from the tip joint down for a
    planar arm: a negative tension is kept -- a cable that would have to push).

    ``lower``: the force cables' tensions ``(m_f,)`` or ``(N, m_f)`` N (default the
    robot's; planar: the lower cables'); ``tip_wrench``, ``gravity``, ``mass``: as
    :func:`external_moments`; ``gap``: ``(N, n, m)`` factors of each cable's tension in
    the gap of each joint over its routing tension (friction in the holes; the
    tensions returned, and ``lower``, are then the routings'); ``frames``:
    :func:`.kinematics.chain_frames` at ``theta`` when at hand.  NaN where the balance has
    no unique solution.
    """
    robot = as_robot(robot)
    th = as_theta(robot, theta)
    pos, frc = position_cables(robot), force_cables(robot)
    if pos.size != robot.n:
        raise ValueError(f"tensions: {pos.size} position cables for {robot.n} joints; the balance fixes their "
                         f"tensions only when the numbers are equal (see feasible_tensions())")
    N = th.shape[0]
    ch = chain_frames(robot, th) if frames is None else frames
    M = moment_matrices(robot, th, ch)
    if gap is not None:
        M = M * np.asarray(gap, dtype=float)
    tau = external_moments(robot, th, tip_wrench, gravity, mass, ch)
    Tf = robot.cable_tension[frc] if lower is None else lower
    Tf = np.broadcast_to(np.asarray(Tf, dtype=float), (N, frc.size))
    rhs = -(tau + np.einsum("njf,nf->nj", M[:, :, frc], Tf))
    with np.errstate(all="ignore"):
        return solve_rows(M[:, :, pos], rhs)


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
        consistent = res <= QP_RTOL * 10.0 * (scale_A * size + scale_b) + 1e-300
        above = np.all(T >= f - QP_RTOL * np.maximum(size, 1e-300)[:, None], axis=1)
        norm = (T**2).sum(1)
        better = consistent & above & (norm < best_norm)
        best[better] = T[better]
        best_norm[better] = norm[better]
    return best, np.isfinite(best_norm)


def feasible_tensions(robot: Robot, theta, min_tension=0.0, tip_wrench=None):
    """Quasi-static tensions of the position-controlled cables, any number of them
    (``docs/spatial.md``, "Statics").

    Moment balance about every joint axis (:func:`moment_matrices`,
    :func:`external_moments` with the robot's gravity and the optional tip wrench);
    force cables at their set tension; of the position-cable tensions solving
    ``M_p T_p = -(tau + M_f T_f)`` with every ``T_p >= min_tension`` (N) the
    minimum-norm one (:func:`min_norm_tensions`).

    Returns ``T (N, m_pos)`` N (order of :func:`.robot.position_cables`; NaN where no
    such tension set exists) and ``feasible (N,)`` bool.
    """
    robot = as_robot(robot)
    th = as_theta(robot, theta)
    ch = chain_frames(robot, th)
    M = moment_matrices(robot, th, ch)
    tau = external_moments(robot, th, tip_wrench, frames=ch)
    pos, frc = position_cables(robot), force_cables(robot)
    b = -(tau + M[:, :, frc] @ robot.cable_tension[frc])
    return min_norm_tensions(M[:, :, pos], b, min_tension)


# --------------------------------------------------------------------------
# Cable elasticity
# --------------------------------------------------------------------------
def elastic_lengths(robot: Robot, theta, T, E, diameter, routing_length=0.0) -> np.ndarray:
    """Unstretched (commanded) position-cable lengths ``(N, m_pos)`` m that hold the arm
    at ``theta`` under tensions ``T (N, m_pos)`` N.

    Hooke: a cable piece of rest length ``l`` under ``T`` is ``l (1 + T/(E A))`` long,
    ``A = pi d^2 / 4`` (``E`` Pa, ``diameter`` m).  The actuator fixes the rest length
    ``L_cmd + L_r`` between the screw and the anchor; the path behind the base disk is
    geometrically ``L_r = routing_length`` m long, so the arm sees ``L_geom = (L_cmd +
    L_r)(1 + eps) - L_r``.
    """
    eps = np.asarray(T, float) / (E * np.pi * diameter**2 / 4.0)
    return (position_lengths(robot, theta) + routing_length) / (1.0 + eps) - routing_length


def cable_stretch(robot: Robot, theta, T, E, diameter, routing_length=0.0) -> np.ndarray:
    """Elongation (m) ``(N, m_pos)`` of every position cable at ``theta`` under ``T``."""
    return position_lengths(robot, theta) - elastic_lengths(robot, theta, T, E, diameter, routing_length)


def solve_cables_elastic(robot: Robot, lengths, E, diameter, routing_length=0.0, lower=None, tip_wrench=None,
                         gravity=None, mass=None, seed=None, tol=1e-12, max_iter=100) -> dict:
    """Commanded (unstretched) position-cable lengths ``(N, m_pos)`` m -> joint angles
    with stretched cables, the tensions (:func:`tensions`, square arms) depending on
    theta: the coupled solve of ``docs/model.md``.

    First the rigid solve from ``seed`` (:func:`.solve.solve_cables`); then the damped
    least squares on ``r = L_cmd - elastic_lengths(theta)`` (the loads of
    :func:`tensions`), the Jacobian by central differences.  Returns the dict of
    :func:`.solve.solve_cables` plus ``tension (N, m_pos)`` N.
    """
    robot = as_robot(robot)
    L = np.asarray(lengths, dtype=float)
    rigid = solve_cables(robot, L, seed=seed, tol=tol, max_iter=max_iter)
    theta = rigid["theta"].copy()
    N, n = L.shape[0], robot.n
    lower_b = None if lower is None else np.broadcast_to(np.asarray(lower, float), (N, force_cables(robot).size))
    wrench = None if tip_wrench is None else np.broadcast_to(np.asarray(tip_wrench, float),
                                                              (N, len(robot.kind.task_rows)))

    def T(th, idx):
        return tensions(robot, th, None if lower_b is None else lower_b[idx],
                        None if wrench is None else wrench[idx], gravity, mass)

    def model(th, idx):
        return elastic_lengths(robot, th, T(th, idx), E, diameter, routing_length)

    def residual(th, idx):
        return L[idx] - model(th, idx)

    def step(th, r, lam, idx):
        h = 1e-6
        J = np.empty((th.shape[0], L.shape[1], n))
        for k in range(n):
            d = np.zeros(n)
            d[k] = h
            J[:, :, k] = (model(th + d, idx) - model(th - d, idx)) / (2 * h)
        Jt = np.swapaxes(J, 1, 2)
        return solve_rows(Jt @ J + lam[:, None, None] * np.eye(n), (Jt @ r[..., None])[..., 0])

    sol = levenberg_marquardt(residual, step, theta, tol, max_iter)
    sol["within_limits"] = within_limits(robot, sol["theta"])
    sol["tension"] = T(sol["theta"], np.arange(N))
    return sol
