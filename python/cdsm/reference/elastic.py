"""Elastic arms: joint springs, tendons commanded in displacement through a series
stiffness, unilateral tendons, and the forward statics as the minimum of the potential
energy; joint Coulomb friction as a quasi-static incremental problem.

Written from ``docs/model.md`` ("Elastic arms"), independent of the Rust core; one
statics for both kinds (a planar arm is the case with every axis ``z``).  It is a
specification: every formula is written out once, in the order of the document.

Notation: ``n`` joints, ``m`` cables (file order), ``q = theta (N, n)`` rad.  Every cable
``c`` that is position- or displacement-controlled (*elastic*) pulls with

    sigma_c(q) = P_c + k_c (L_c(q) - l_c),   T_c = clip(sigma_c, 0, Tmax_c)

``L_c(q)`` its path length (m), ``l_c`` its rest length (m), ``k_c`` its series stiffness
(N/m), ``P_c`` its pretension and ``Tmax_c`` its cap (N):

* displacement cable: ``l_c = L0_c - d_c`` (``L0_c`` the path length at the rest angles,
  ``d_c`` the command, m, positive = pull), ``k_c = 1 / (1/k_a + (L0_c + L_r)/(E A))``;
* position cable: ``l_c = L_cmd,c`` (the commanded length), ``k_c = E A / (L_cmd,c +
  L_r)``, ``P_c = 0``, no cap (the cable's own Hooke law: today's elastic cable);

a force cable pulls with its set tension ``T_f`` whatever ``q``.  The potential

    U(q) = 1/2 sum_j k_j (q_j - rest_j)^2 + sum_elastic W_c(sigma_c) + sum_force T_f L_f(q)
           - sum_disks mass_b g . c_b(q) - F . p_tip(q) - Mz phi(q)   (Mz: planar arms only)

with ``W(sigma) = 0`` (``sigma <= 0``), ``sigma^2 / (2k)`` (``0 <= sigma <= Tmax``),
``Tmax sigma / k - Tmax^2 / (2k)`` (above), so that ``dW/dL = T``; its gradient

    g(q) = K (q - rest) + G T - tau(q),   G = dL/dq^T (n, m),  tau = the loads' moments

and its Hessian ``H = K + B + G_E diag(c) G_E^T + Q``: ``B`` the cables' curvature ``sum_c
T_c d^2 L_c`` (block diagonal: a gap's length depends only on its disk's joints), ``c``
the taut cables' stiffness (``k_c`` where ``0 < sigma_c < Tmax_c``, else 0), ``Q =
-dtau/dq`` the loads' curvature (dense).

Units: m, rad, N, N m, N/m, N m/rad, Pa, kg, m/s^2, J.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from . import friction as fr
from . import sequence as sq
from .kinematics import as_theta, cable_lengths, cable_points, chain_frames, cross, fk_jacobian, task_vector
from .robot import Robot, as_robot, displacement_cables, force_cables, position_cables
from .rotations import exp_so3
from .solve import solve_cables

__all__ = [
    "rest_lengths",
    "series_stiffness",
    "Springs",
    "tendon_springs",
    "tendon_energy",
    "evaluate",
    "equilibrium",
    "equilibrium_sequence",
    "derivatives",
    "friction_sequence",
    "segments",
    "commanded_cables",
    "plant_arm",
    "plant_predict",
    "capstan_wraps",
    "capstan_motion",
    "capstan_residual",
    "capstan_settle",
    "newton_step",
    "structured_step",
    "ARMIJO",
    "XTOL",
    "SHIFT",
]

#: Armijo's sufficient-decrease constant of the line search.
ARMIJO = 1e-4
#: Converged when the (unshifted) Newton step's largest component is at most this (rad).
XTOL = 1e-12
#: The first shift of an indefinite Hessian, relative to the mean |diagonal|.
SHIFT = 1e-3
#: Halvings of the line search before a row is declared stuck.
HALVINGS = 50
#: The line search accepts a full step whose predicted decrease ``-g.s`` is below this many
#: ulps of ``sum |terms of U|`` (``U`` cannot resolve it: Newton's local convergence).
ROUNDING_ULPS = 64.0


# --------------------------------------------------------------------------
# Tendons
# --------------------------------------------------------------------------
def rest_lengths(robot: Robot) -> np.ndarray:
    """``L0 (m,)`` m: every cable's path length at the rest angles, holes as given (the
    gaps and the disk traversals; no routing behind the base)."""
    robot = as_robot(robot)
    return cable_lengths(robot, robot.rest_angle[None, :])[0]


def series_stiffness(robot: Robot) -> np.ndarray:
    """``k_s (m,)`` N/m of the displacement cables: the actuator ``k_a`` (the file's
    ``stiffness``, inf when absent) in series with the cable, ``E A / (L0 + L_r)``
    (``A = pi d^2 / 4``, ``L_r`` the routing length): ``1 / (1/k_a + (L0 + L_r)/(E A))``;
    NaN for the other cables."""
    robot = as_robot(robot)
    EA = robot.youngs_modulus * np.pi * robot.diameter**2 / 4.0
    out = np.full(robot.m, np.nan)
    d = displacement_cables(robot)
    L0 = rest_lengths(robot)[d]
    out[d] = 1.0 / (1.0 / robot.cable_stiffness[d] + (L0 + robot.routing_length) / EA)
    return out


@dataclasses.dataclass
class Springs:
    """The cables' laws for a batch of ``N`` commands (``docs/model.md``, "Elastic arms").

    ``elastic (m,)`` bool: position or displacement cables; ``rest (N, m)`` m: ``l_c``
    (NaN for force cables); ``k (N, m)`` N/m (0 for force cables); ``pretension (m,)`` N;
    ``cap (m,)`` N (inf: none); ``force (m,)`` N: a force cable's set tension (0 for the
    others); ``lengths (N, m_pos)``, ``displacements (N, m_d)``: the commands.
    """

    elastic: np.ndarray
    rest: np.ndarray
    k: np.ndarray
    pretension: np.ndarray
    cap: np.ndarray
    force: np.ndarray
    lengths: np.ndarray
    displacements: np.ndarray

    @property
    def rows(self) -> int:
        return int(self.rest.shape[0])

    def take(self, idx) -> "Springs":
        """The rows ``idx`` of the batch."""
        return dataclasses.replace(self, rest=self.rest[idx], k=self.k[idx], lengths=self.lengths[idx],
                                   displacements=self.displacements[idx])


def _commands(values, size: int, name: str, rows: int | None) -> np.ndarray | None:
    if values is None:
        if size:
            raise ValueError(f"{name}: the arm has {size} such cables; give {name} (N, {size}) m")
        return None
    v = np.asarray(values, dtype=float)
    v = v.reshape(1, -1) if v.ndim == 1 else v
    if v.ndim != 2 or v.shape[1] != size or (rows is not None and v.shape[0] != rows):
        raise ValueError(f"{name}: must have shape (N, {size}), got {np.shape(values)}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: must be finite")
    return v


def tendon_springs(robot: Robot, lengths=None, displacements=None, rows: int | None = None) -> Springs:
    """The cables' laws for commanded ``lengths (N, m_pos)`` m of the position cables (order
    of :func:`.robot.position_cables`) and ``displacements (N, m_d)`` m of the displacement
    cables (order of :func:`.robot.displacement_cables`, positive = pull); each is needed
    when the arm has such cables.  ``rows``: ``N`` when neither is given (default 1)."""
    robot = as_robot(robot)
    pos, dis, frc = position_cables(robot), displacement_cables(robot), force_cables(robot)
    L = _commands(lengths, pos.size, "lengths", None)
    d = _commands(displacements, dis.size, "displacements", None if L is None else L.shape[0])
    N = L.shape[0] if L is not None else d.shape[0] if d is not None else (1 if rows is None else int(rows))
    L = np.zeros((N, 0)) if L is None else L
    d = np.zeros((N, 0)) if d is None else d
    if L.shape[0] != N or d.shape[0] != N:
        raise ValueError(f"lengths and displacements: {L.shape[0]} and {d.shape[0]} rows differ")
    EA = robot.youngs_modulus * np.pi * robot.diameter**2 / 4.0
    Lr = robot.routing_length
    if np.any(L + Lr <= 0.0):
        raise ValueError(f"lengths: a commanded cable length plus the routing length ({Lr!r} m) must be > 0 m, "
                         f"got {L[L + Lr <= 0.0][0]!r}")
    rest = np.full((N, robot.m), np.nan)
    k = np.zeros((N, robot.m))
    rest[:, pos] = L
    k[:, pos] = EA / (L + Lr)
    rest[:, dis] = rest_lengths(robot)[dis] - d
    k[:, dis] = series_stiffness(robot)[dis]
    elastic = np.zeros(robot.m, dtype=bool)
    elastic[pos] = elastic[dis] = True
    force = np.zeros(robot.m)
    force[frc] = robot.cable_tension[frc]
    return Springs(elastic=elastic, rest=rest, k=k, pretension=np.where(elastic, robot.pretension, 0.0),
                   cap=np.where(elastic, robot.max_tension, np.inf), force=force, lengths=L, displacements=d)


def tendon_energy(sigma, k, cap):
    """``W(sigma)`` J of a cable at ``sigma = P + k (L - l)`` N: 0 below 0, ``sigma^2 / (2k)``
    up to the cap, ``Tmax sigma / k - Tmax^2 / (2k)`` above it (``dW/dL = clip(sigma, 0,
    Tmax)``); ``k > 0``."""
    sigma, k, cap = np.broadcast_arrays(np.asarray(sigma, float), np.asarray(k, float), np.asarray(cap, float))
    s = np.maximum(sigma, 0.0)
    capped = s > cap
    safe = np.where(capped, cap, 0.0)
    return np.where(capped, (safe * s - 0.5 * safe**2) / k, 0.5 * s**2 / k)


# --------------------------------------------------------------------------
# The potential, its gradient and Hessian
# --------------------------------------------------------------------------
def _wrench(robot: Robot, tip_wrench, N: int) -> np.ndarray:
    """``(N, 6)`` ``[F, M]`` (base frame) of the kind's wrench rows (planar ``[Fx, Fy, Mz]``,
    spatial ``[F, M]``); a spatial moment is refused: a constant moment in space does work
    ``M . omega`` that is no differential, so the arm would have no potential."""
    W = np.zeros((N, 6))
    if tip_wrench is None:
        return W
    rows = list(robot.kind.task_rows)
    w = np.asarray(tip_wrench, dtype=float)
    if w.shape[-1] != len(rows) or w.ndim > 2 or (w.ndim == 2 and w.shape[0] not in (1, N)):
        raise ValueError(f"tip_wrench: must have shape ({len(rows)},) or (N, {len(rows)}), got {w.shape}")
    W[:, rows] = np.broadcast_to(w, (N, len(rows)))
    if robot.kind.rotation != "angle" and np.any(W[:, 3:] != 0.0):
        raise ValueError("tip_wrench: a spatial tip moment is not conservative (no potential); "
                         "apply forces instead (a couple as two forces at two points of the end disk)")
    return W


def _pairs(robot: Robot) -> tuple:
    """The joint pairs ``(a, b)`` with ``a <= b`` (chain order) on the same disk."""
    a, b = [], []
    for j in range(robot.n):
        for i in range(j + 1):
            if robot.joint_disk[i] == robot.joint_disk[j]:
                a.append(i)
                b.append(j)
    return np.array(a, dtype=np.int64), np.array(b, dtype=np.int64)


def _point_terms(F, P, p, w, proximal, order):
    """``f = F . P`` of a point ``P (N, 3)`` fixed to a disk, pulled by ``F (N, 3)``: its
    gradient ``F . (w_j x (P - p_j))`` ``(N, n)`` over the joints ``proximal (n,)`` of it and,
    with ``order >= 2``, its Hessian ``F . (w_a x (w_b x (P - p_b)))`` for ``a <= b``
    (mirrored) ``(N, n, n)``."""
    X = np.where(proximal[None, :, None], cross(w, P[:, None, :] - p), 0.0)  # w_b x (P - p_b)
    grad = np.einsum("ni,nji->nj", F, X)
    if order < 2:
        return grad, None
    Y = np.where(proximal[None, :, None], cross(F[:, None, :], w), 0.0)  # F x w_a
    M = np.einsum("nai,nbi->nab", Y, X)  # F . (w_a x X_b) = X_b . (F x w_a)
    upper = np.triu(M)
    return grad, upper + np.swapaxes(np.triu(M, 1), 1, 2)


def evaluate(robot: Robot, springs: Springs, theta, tip_wrench=None, order: int = 2) -> dict:
    """The potential ``U (N,)`` J at ``theta (N, n)`` rad and, with ``order >= 1``, its gradient
    ``g (N, n)`` N m and, with ``order >= 2``, its Hessian ``H (N, n, n)`` N m/rad with its
    parts: ``K (n,)`` the joint stiffnesses, ``B (N, n, n)`` the cables' curvature
    (block diagonal by disk), ``G (N, n, m)`` ``= dL/dq^T``, ``c (N, m)`` the taut cables'
    stiffness, ``Q (N, n, n)`` the loads' curvature.  Also ``L (N, m)`` m, ``sigma (N, m)`` N,
    ``tension (N, m)`` N (force cables: their set tension), ``tau (N, n)`` N m (the loads'
    moments about the joint axes), ``scale (N,)`` J (``sum |terms of U|``: its rounding
    level).  ``springs`` from :func:`tendon_springs`; ``tip_wrench`` the kind's rows."""
    robot = as_robot(robot)
    th = as_theta(robot, theta)
    N, n, m = th.shape[0], robot.n, robot.m
    if springs.rows != N:
        raise ValueError(f"springs: {springs.rows} rows for {N} configurations")
    W = _wrench(robot, tip_wrench, N)
    ch = chain_frames(robot, th)
    p, w = ch["p"], ch["w"]
    pts = cable_points(robot, th, ch)
    kj, rest = robot.joint_stiffness, robot.rest_angle
    disk = robot.joint_disk

    # the cables: lengths, dL/dq (per joint: the gap of its disk only) and curvature
    L = np.empty((N, m))
    G = np.zeros((N, n, m))
    for c, P in enumerate(pts):
        L[:, c] = (np.linalg.norm(P[:, 1::2] - P[:, 0:-1:2], axis=-1).sum(1)
                   + np.linalg.norm(P[:, 2::2] - P[:, 1::2], axis=-1).sum(1))
    sigma = springs.pretension + springs.k * (L - springs.rest)
    T = np.where(springs.elastic, np.clip(np.nan_to_num(sigma, nan=0.0), 0.0, springs.cap), springs.force)
    sigma = np.where(springs.elastic, sigma, springs.force)
    energy = np.where(springs.elastic, tendon_energy(np.nan_to_num(sigma), np.where(springs.k > 0, springs.k, 1.0),
                                                     springs.cap), springs.force * L)
    dq = th - rest
    U = 0.5 * (kj * dq**2).sum(1) + energy.sum(1)
    # the rounding level of U: its terms, and the work a relative error eps in a length or
    # a position would make (T L of every cable, |F| |P| of every load)
    scale = 0.5 * (kj * dq**2).sum(1) + np.abs(energy).sum(1) + (np.abs(T) * L).sum(1)

    # the loads: gravity on every disk's centre of mass, the tip force, a planar moment
    loads = []  # (F (N, 3), P (N, 3), proximal (n,))
    g_acc = np.broadcast_to(robot.gravity, (N, 3))
    if np.any(robot.gravity != 0.0):
        for b in range(1, robot.disks + 1):
            if robot.mass[b - 1] > 0.0:
                centre = np.einsum("nij,j->ni", ch["Ra"][:, b], robot.com[b - 1]) + ch["ta"][:, b]
                loads.append((robot.mass[b - 1] * g_acc, centre, disk <= b))
    if np.any(W[:, :3] != 0.0):
        loads.append((W[:, :3], ch["tb"][:, -1], np.ones(n, dtype=bool)))
    for F, P, _ in loads:
        U -= (F * P).sum(1)
        scale += np.linalg.norm(F, axis=1) * np.linalg.norm(P, axis=1)
    Mz = W[:, 5]  # planar arms only (a spatial moment is refused)
    U -= Mz * th.sum(1)
    scale += np.abs(Mz * th.sum(1))
    out = dict(U=U, L=L, sigma=sigma, tension=T, scale=scale)
    if order < 1:
        return out

    for c, P in enumerate(pts):
        on = disk <= robot.cable_end[c]  # the joints whose disk cable c reaches
        k = disk[on]
        A, B = P[:, 2 * k - 1], P[:, 2 * k - 2]  # (N, j, 3): A_k, B_(k-1) of each joint's gap
        v = A - B
        dist = np.linalg.norm(v, axis=-1)
        u = np.where(dist[..., None] > 0.0, v / np.where(dist > 0.0, dist, 1.0)[..., None], 0.0)
        G[:, on, c] = (u * cross(w[:, on], A - p[:, on])).sum(-1)
    tau = np.zeros((N, n))
    Q = np.zeros((N, n, n)) if order >= 2 else None
    for F, P, proximal in loads:
        grad, hess = _point_terms(F, P, p, w, proximal, order)
        tau += grad
        if order >= 2:
            Q -= hess
    tau += Mz[:, None] * w[:, :, 2]
    g = kj * dq + np.einsum("njc,nc->nj", G, T) - tau
    out.update(g=g, G=G, tau=tau)
    if order < 2:
        return out

    Bc = np.zeros((N, n, n))
    pa, pb = _pairs(robot)
    for c, P in enumerate(pts):
        sel = disk[pa] <= robot.cable_end[c]
        a, b = pa[sel], pb[sel]
        k = disk[a]
        A, Bp = P[:, 2 * k - 1], P[:, 2 * k - 2]
        v = A - Bp
        dist = np.linalg.norm(v, axis=-1)
        va = cross(w[:, a], A - p[:, a])
        vb = cross(w[:, b], A - p[:, b])
        vab = cross(w[:, a], cross(w[:, b], A - p[:, b]))
        with np.errstate(all="ignore"):
            h = (((va * vb).sum(-1) + (v * vab).sum(-1)) / dist
                 - (v * va).sum(-1) * (v * vb).sum(-1) / dist**3)
        h = np.where(dist > 0.0, h, 0.0) * T[:, c:c + 1]
        np.add.at(Bc, (slice(None), a, b), h)
        off = a != b
        np.add.at(Bc, (slice(None), b[off], a[off]), h[:, off])
    taut = springs.elastic & (sigma > 0.0) & (sigma < springs.cap)
    cstiff = np.where(taut, springs.k, 0.0)
    H = Bc + np.einsum("njc,nc,nkc->njk", G, cstiff, G) + Q
    H[:, np.arange(n), np.arange(n)] += kj
    out.update(H=H, K=kj.copy(), B=Bc, c=cstiff, Q=Q)
    return out


# --------------------------------------------------------------------------
# The solver
# --------------------------------------------------------------------------
def _cho_solve(L: np.ndarray, b: np.ndarray) -> np.ndarray:
    y = np.linalg.solve(L, b)
    return np.linalg.solve(L.T, y)


def newton_step(H: np.ndarray, g: np.ndarray) -> tuple:
    """The step ``s`` of ``(H + tau I) s = -g`` for one row (``H (n, n)``, ``g (n,)``):
    ``tau = 0`` when ``H`` is positive definite (its Cholesky succeeds), else the first of
    ``beta, 2 beta, 4 beta, ...`` that makes it so, ``beta = SHIFT`` times the mean
    ``|H_jj|`` (1 N m/rad when that is 0).  Returns ``(s, tau)``; ``s`` NaN when no shift
    of up to ``2^60 beta`` helps (a non-finite ``H``)."""
    n = H.shape[0]
    if not (np.all(np.isfinite(H)) and np.all(np.isfinite(g))):
        return np.full(n, np.nan), np.inf
    tau = 0.0
    beta = SHIFT * np.abs(np.diag(H)).mean() if n else 1.0
    beta = beta if beta > 0.0 else 1.0
    for _ in range(61):
        try:
            L = np.linalg.cholesky(H + tau * np.eye(n))
            return -_cho_solve(L, g), tau
        except np.linalg.LinAlgError:
            tau = beta if tau == 0.0 else 2.0 * tau
    return np.full(n, np.nan), np.inf


def structured_step(robot: Robot, parts: dict, row: int = 0) -> np.ndarray:
    """The Newton step ``s`` of ``H s = -g`` by the structure of ``docs/model.md`` ("The
    solver"), for one row of :func:`evaluate`'s ``parts`` (``order=2``): ``H = D + G_t C
    G_t^T`` with ``D = K + B`` block diagonal (one block per disk: its joints) and ``C =
    diag(c)`` over the ``m_t`` taut cables, so by Woodbury

        s = -(D^-1 g - D^-1 G_t (C^-1 + G_t^T D^-1 G_t)^-1 G_t^T D^-1 g)

    a solve per block and one ``m_t x m_t`` solve.  Needs ``Q = 0`` (no gravity, no tip
    force: ``Q`` is dense) and every block of ``D`` invertible; ``(n,)`` rad."""
    robot = as_robot(robot)
    Q = parts["Q"][row]
    if np.any(Q != 0.0):
        raise ValueError("structured_step: the loads' curvature Q is not 0 (gravity or a tip force): "
                         "H has no block-plus-low-rank form")
    g, B, G, c = parts["g"][row], parts["B"][row], parts["G"][row], parts["c"][row]
    taut = c > 0.0
    Gt = G[:, taut]
    rhs = np.column_stack([g, Gt])  # D^-1 [g, G_t] block by block
    sol = np.empty_like(rhs)
    for k in np.unique(robot.joint_disk):
        j = np.flatnonzero(robot.joint_disk == k)
        Dk = B[np.ix_(j, j)] + np.diag(parts["K"][j])
        sol[j] = np.linalg.solve(Dk, rhs[j])
    Dg, DG = sol[:, 0], sol[:, 1:]
    small = np.diag(1.0 / c[taut]) + Gt.T @ DG
    return -(Dg - DG @ np.linalg.solve(small, Gt.T @ Dg))


def equilibrium(robot: Robot, lengths=None, displacements=None, tip_wrench=None, seed=None, xtol: float = XTOL,
                max_iter: int = 100) -> dict:
    """The frictionless forward statics of an elastic arm (``docs/model.md``, "Elastic
    arms"): for every row of commands, the configuration that minimises the potential
    ``U`` (:func:`evaluate`), by Newton's method on ``U``.

    Commands: ``lengths (N, m_pos)`` m, ``displacements (N, m_d)`` m (:func:`tendon_springs`);
    ``tip_wrench`` the kind's rows (planar ``[Fx, Fy, Mz]`` N, N, N m; spatial ``[Fx, Fy,
    Fz, 0, 0, 0]``), ``(t,)`` or ``(N, t)``; ``seed (N, n)`` or ``(n,)`` rad (default: for an
    arm without springs and with at least as many position cables as joints the rigid
    cable solve of the commanded lengths from the rest angles, which picks the branch as
    today's solves do; else the rest angles).

    Per row: the step ``s`` of :func:`newton_step` (the Hessian, shifted while not positive
    definite); converged when it is unshifted and ``max |s| <= xtol`` rad (the step is then
    taken); otherwise a backtracking line search, ``t = 1, 1/2, ...`` (at most ``HALVINGS``),
    takes the first ``t`` with ``U(q + t s) <= U(q) + ARMIJO t g.s`` (a full unshifted step
    whose predicted decrease ``-g.s`` is below the rounding level of ``U`` is taken as is).
    A row fails after ``max_iter`` steps (``"iteration limit"``), when no ``t`` decreases
    ``U`` (``"line search"``), when a value is not finite (``"not finite"``), or at a
    stationary point where the Hessian is not positive definite (``"not a minimum"``: an
    unstable or undetermined equilibrium).

    Returns ``theta (N, n)`` rad, ``tension (N, m)`` N (every cable; force cables their set
    tension), ``slack (N, m)`` (elastic cables with ``sigma <= 0``: carrying nothing),
    ``capped (N, m)`` (``sigma >= Tmax``), ``converged (N,)``, ``reason`` (list of str),
    ``iterations (N,)``, ``gradient (N,)`` N m (``max |g|`` at the answer), ``U (N,)`` J.
    """
    robot = as_robot(robot)
    rows = None if seed is None or np.ndim(seed) < 2 else np.shape(seed)[0]
    if rows is None and tip_wrench is not None and np.ndim(tip_wrench) == 2:
        rows = np.shape(tip_wrench)[0]
    springs = tendon_springs(robot, lengths, displacements, rows)
    N = springs.rows
    theta = _seed(robot, seed, N, springs)
    wrench = _wrench(robot, tip_wrench, N)
    task = wrench[:, list(robot.kind.task_rows)]
    theta, converged, reason, iterations = _newton(robot, springs, task, theta, xtol, max_iter)
    return _result(robot, springs, task, theta, converged, reason, iterations)


def _seed(robot: Robot, seed, N: int, springs: Springs | None = None) -> np.ndarray:
    """``seed`` as ``(N, n)`` rad, or the default seed: for an arm without joint springs and
    with at least as many position cables as joints the rigid cable solve of the commanded
    lengths from the rest angles (least squares beyond ``n``; the rest angles where it
    fails), else the rest angles."""
    if seed is None:
        rest = np.tile(robot.rest_angle, (N, 1))
        if springs is None or position_cables(robot).size < robot.n or np.any(robot.joint_stiffness > 0.0):
            return rest
        rigid = solve_cables(robot, springs.lengths, seed=rest)["theta"]
        return np.where(np.all(np.isfinite(rigid), axis=1, keepdims=True), rigid, rest)
    s = np.array(seed, dtype=float)
    s = np.tile(s, (N, 1)) if s.ndim == 1 else s
    if s.shape != (N, robot.n):
        raise ValueError(f"seed: must have shape ({N}, {robot.n}) or ({robot.n},), got {np.shape(seed)}")
    return s


def _result(robot, springs, task, theta, converged, reason, iterations) -> dict:
    ev = evaluate(robot, springs, theta, task, order=1)
    slack = springs.elastic & ~(ev["sigma"] > 0.0)
    capped = springs.elastic & (ev["sigma"] >= springs.cap)
    return dict(theta=theta, tension=ev["tension"], slack=slack, capped=capped, converged=converged,
                reason=list(reason), iterations=iterations, gradient=np.abs(ev["g"]).max(1, initial=0.0), U=ev["U"])


def _newton(robot, springs, task, theta, xtol, max_iter) -> tuple:
    """Newton with the Armijo line search on ``U``, every row of the batch on its own:
    ``(theta, converged, reason, iterations)``."""
    q = np.array(theta, dtype=float)
    N = q.shape[0]
    converged = np.zeros(N, dtype=bool)
    reason = ["iteration limit"] * N
    iterations = np.zeros(N, dtype=np.int64)
    active = np.ones(N, dtype=bool)
    eps = np.finfo(float).eps
    for _ in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        ev = evaluate(robot, springs.take(idx), q[idx], task[idx])
        search, steps, slopes = [], [], []
        for r, i in enumerate(idx):
            s, shift = newton_step(ev["H"][r], ev["g"][r])
            if not (np.all(np.isfinite(s)) and np.isfinite(ev["U"][r])):
                active[i], reason[i] = False, "not finite"
                continue
            if np.abs(s).max(initial=0.0) <= xtol:
                active[i] = False
                if shift == 0.0:
                    q[i] += s
                    converged[i], reason[i], iterations[i] = True, "converged", iterations[i] + 1
                else:
                    reason[i] = "not a minimum"
                continue
            iterations[i] += 1
            slope = float(ev["g"][r] @ s)
            if shift == 0.0 and -slope <= ROUNDING_ULPS * eps * ev["scale"][r]:
                q[i] += s  # below the rounding level of U: Newton's full step
                continue
            search.append((r, i))
            steps.append(s)
            slopes.append(slope)
        if not search:
            continue
        rows = np.array([i for _, i in search])
        U0 = ev["U"][[r for r, _ in search]]
        steps, slopes = np.array(steps), np.array(slopes)
        t = np.ones(rows.size)
        pending = np.ones(rows.size, dtype=bool)
        for _ in range(HALVINGS):
            k = np.flatnonzero(pending)
            trial = q[rows[k]] + t[k, None] * steps[k]
            Ut = evaluate(robot, springs.take(rows[k]), trial, task[rows[k]], order=0)["U"]
            ok = Ut <= U0[k] + ARMIJO * t[k] * slopes[k]
            q[rows[k[ok]]] = trial[ok]
            pending[k[ok]] = False
            t[k[~ok]] *= 0.5
            if not pending.any():
                break
        for i in rows[pending]:
            active[i], reason[i] = False, "line search"
    return q, converged, reason, iterations


def _sequence(robot: Robot, lengths, displacements, tip_wrench, start) -> tuple:
    """A sequence's cable laws, its task wrench rows ``(N, t)`` and its start ``(n,)`` rad."""
    springs = tendon_springs(robot, lengths, displacements,
                             None if tip_wrench is None or np.ndim(tip_wrench) < 2 else np.shape(tip_wrench)[0])
    task = _wrench(robot, tip_wrench, springs.rows)[:, list(robot.kind.task_rows)]
    return springs, task, _seed(robot, start, 1)[0]


def equilibrium_sequence(robot: Robot, lengths=None, displacements=None, tip_wrench=None, start=None,
                         xtol: float = XTOL, max_iter: int = 100) -> dict:
    """:func:`equilibrium` along a sequence of commands, each row seeded with the previous
    row's answer (the first with ``start (n,)`` rad, default the rest angles): the warm
    start of ``docs/model.md``.  Without friction the answer of a row does not depend on
    the history except through which minimum a row reaches."""
    robot = as_robot(robot)
    springs, task, q = _sequence(robot, lengths, displacements, tip_wrench, start)
    N = springs.rows
    theta = np.empty((N, robot.n))
    converged = np.zeros(N, dtype=bool)
    reason, iterations = [], np.zeros(N, dtype=np.int64)
    for i in range(N):
        sol = _newton(robot, springs.take([i]), task[i:i + 1], q[None], xtol, max_iter)
        q, converged[i], iterations[i] = sol[0][0], sol[1][0], sol[3][0]
        theta[i] = q
        reason.append(sol[2][0])
    return _result(robot, springs, task, theta, converged, reason, iterations)


# --------------------------------------------------------------------------
# Derivatives by the implicit function theorem
# --------------------------------------------------------------------------
def derivatives(robot: Robot, theta, lengths=None, displacements=None, tip_wrench=None) -> dict:
    """Derivatives of an equilibrium ``theta (N, n)`` rad (:func:`equilibrium`) by the
    implicit function theorem, ``dq/dp = -H^-1 dg/dp``, on the smooth piece the arm is on:
    a cable at ``sigma <= 0`` counts as slack (no stiffness, ``dT = 0``), one at ``sigma >=
    Tmax`` as capped (constant tension), so at a transition the derivative is the one-sided
    one of that side.

    ``dg/dp``: a displacement ``d_c``: ``G_c k_c`` (taut); a commanded length ``L_c``:
    ``G_c dsigma/dL_c``, ``dsigma/dL_c = -k_c (L_c(q) + L_r)/(L_c + L_r)`` (taut); the tip
    wrench (the kind's rows ``t``): ``-J_t^T`` (the geometric Jacobian's rows).

    Returns ``theta_lengths (N, n, m_pos)`` rad/m, ``theta_displacements (N, n, m_d)``
    rad/m, ``theta_wrench (N, n, t)`` rad per N (or N m); ``task_*`` the same for the task
    vector (:func:`.kinematics.fk_jacobian` times the above: m/m, m/N, ...; rad rows as
    angular velocities for spatial arms); ``tension_*`` ``(N, m, .)`` N per unit;
    ``definite (N,)``: the Hessian is positive definite (else the entries are NaN).
    """
    robot = as_robot(robot)
    th = as_theta(robot, theta)
    springs = tendon_springs(robot, lengths, displacements, th.shape[0])
    N, n = th.shape
    task_w = _wrench(robot, tip_wrench, N)[:, list(robot.kind.task_rows)]
    ev = evaluate(robot, springs, th, task_w)
    G, c, L = ev["G"], ev["c"], ev["L"]
    pos, dis = position_cables(robot), displacement_cables(robot)
    Lr = robot.routing_length
    # dsigma/dp directly (at fixed q), per command column; zero where slack or capped
    dsig_L = np.where(c[:, pos] > 0.0, -springs.k[:, pos] * (L[:, pos] + Lr) / (springs.lengths + Lr), 0.0)
    dsig_d = np.where(c[:, dis] > 0.0, springs.k[:, dis], 0.0)
    dg = {
        "lengths": G[:, :, pos] * dsig_L[:, None, :],
        "displacements": G[:, :, dis] * dsig_d[:, None, :],
        "wrench": -np.swapaxes(fk_jacobian(robot, th), 1, 2),  # d(-tau)/dw
    }
    direct = {"lengths": (pos, dsig_L), "displacements": (dis, dsig_d)}
    J = fk_jacobian(robot, th)
    out = {"definite": np.zeros(N, dtype=bool)}
    for key, rhs in dg.items():
        dq = np.full(rhs.shape, np.nan)
        for i in range(N):
            try:
                Lc = np.linalg.cholesky(ev["H"][i])
            except np.linalg.LinAlgError:
                continue
            out["definite"][i] = True
            dq[i] = -_cho_solve(Lc, rhs[i])
        out[f"theta_{key}"] = dq
        out[f"task_{key}"] = J @ dq
        dT = np.einsum("nc,njc,njp->ncp", c, G, dq)  # k_c G_c^T dq on the taut cables
        if key in direct:
            cols, dsig = direct[key]
            dT[:, cols, np.arange(cols.size)] += dsig
        out[f"tension_{key}"] = dT
    return out


# --------------------------------------------------------------------------
# Joint Coulomb friction: the quasi-static incremental problem
# --------------------------------------------------------------------------
def friction_sequence(robot: Robot, joint_friction, lengths=None, displacements=None, tip_wrench=None,
                      start=None, xtol: float = XTOL, max_iter: int = 200) -> dict:
    """Coulomb friction at the joints along a sequence of commands (``docs/model.md``,
    "Elastic arms", history): row ``i`` minimises

        Phi_i(q) = U_i(q) + sum_j tau_c,j |q_j - q_(i-1),j|

    (``U_i`` the potential of row ``i``'s commands, ``q_(i-1)`` the previous row's answer,
    ``q_0 = start``, default the rest angles; ``joint_friction`` ``tau_c`` N m, scalar or
    ``(n,)``, ``>= 0``).  At the answer a joint either sticks, ``q_j = q_(i-1),j`` with
    ``|dU_i/dq_j| <= tau_c,j``, or slips, ``dU_i/dq_j = -tau_c,j sign(q_j - q_(i-1),j)``.

    Solved by an orthant-wise Newton method: with ``x = q - q_(i-1)`` the pseudo-gradient
    (``g_j + tau sign x_j`` where ``x_j != 0``; at ``x_j = 0`` the part of ``g_j`` beyond
    ``+-tau``, 0 inside the band); the Newton step on the joints that move or would move
    (the others held), its components that leave their orthant at ``x_j = 0`` dropped, the
    trial projected onto the orthant (a joint whose ``x_j`` would change sign stops at 0),
    Armijo on ``Phi`` (an unshifted step whose predicted decrease is below ``Phi``'s rounding
    level is taken whole, as in :func:`equilibrium`).  A joint with ``tau_c = 0`` has no kink and is never held.
    Converged when every held joint is inside its band and the unshifted step is at most
    ``xtol`` rad.  With ``tau_c = 0`` this is :func:`equilibrium_sequence`'s Newton.

    Returns the dict of :func:`equilibrium` plus ``stuck (N, n)``: the joints held at the
    previous angle.
    """
    robot = as_robot(robot)
    tc = np.broadcast_to(np.asarray(joint_friction, dtype=float), (robot.n,)).copy()
    if not np.all(np.isfinite(tc)) or np.any(tc < 0.0):
        raise ValueError(f"joint_friction: must be finite and >= 0 N m, got {joint_friction!r}")
    springs, task, prev = _sequence(robot, lengths, displacements, tip_wrench, start)
    N = springs.rows
    theta = np.empty((N, robot.n))
    stuck = np.zeros((N, robot.n), dtype=bool)
    converged = np.zeros(N, dtype=bool)
    reason, iterations = [], np.zeros(N, dtype=np.int64)
    for i in range(N):
        q, converged[i], why, iterations[i] = _minimise_friction(
            robot, springs.take([i]), task[i:i + 1], prev, tc, xtol, max_iter)
        theta[i] = q
        stuck[i] = (q == prev) & (tc > 0.0)
        reason.append(why)
        prev = q
    out = _result(robot, springs, task, theta, converged, reason, iterations)
    out["stuck"] = stuck
    return out


def _pseudo_gradient(g, x, tc):
    """The minimum-norm subgradient of ``Phi`` at ``x = q - q_prev``."""
    pg = g + tc * np.sign(x)
    at0 = (x == 0.0) & (tc > 0.0)
    band = np.where(g + tc < 0.0, g + tc, np.where(g - tc > 0.0, g - tc, 0.0))
    return np.where(at0, band, pg)


def _minimise_friction(robot, springs, task, prev, tc, xtol, max_iter) -> tuple:
    """Orthant-wise Newton on ``Phi`` for one row: ``(q, converged, reason, iterations)``."""
    q = np.array(prev, dtype=float)
    kinked = tc > 0.0

    def phi(qq):
        U = float(evaluate(robot, springs, qq[None], task, order=0)["U"][0])
        return U + float(np.sum(tc * np.abs(qq - prev)))

    for it in range(max_iter):
        ev = evaluate(robot, springs, q[None], task)
        g, H = ev["g"][0], ev["H"][0]
        x = q - prev
        pg = _pseudo_gradient(g, x, tc)
        orthant = np.where(x != 0.0, np.sign(x), -np.sign(pg))
        free = ~kinked | (x != 0.0) | (pg != 0.0)
        if not free.any():
            return q, True, "converged", it
        s = np.zeros(robot.n)
        sF, shift = newton_step(H[np.ix_(free, free)], pg[free])
        if not np.all(np.isfinite(sF)):
            return q, False, "not finite", it
        s[free] = sF
        leave = kinked & (x == 0.0) & (s * orthant <= 0.0)
        s[leave] = 0.0
        if np.abs(s).max(initial=0.0) <= xtol:
            if shift == 0.0 and not np.any(leave & (pg != 0.0)):
                return _project(prev, x + s, orthant, kinked), True, "converged", it + 1
            return q, False, "not a minimum", it
        if shift == 0.0 and -float(pg @ s) <= ROUNDING_ULPS * np.finfo(float).eps * float(ev["scale"][0]):
            q = _project(prev, x + s, orthant, kinked)  # below the rounding level of Phi: the full step
            continue
        P0 = phi(q)
        t = 1.0
        for _ in range(HALVINGS):
            trial = _project(prev, x + t * s, orthant, kinked)
            if phi(trial) <= P0 + ARMIJO * float(pg @ (trial - q)):
                break
            t *= 0.5
        else:
            return q, False, "line search", it + 1
        q = trial
    return q, False, "iteration limit", max_iter


def _project(prev, x, orthant, kinked):
    """``prev + x`` with every kinked joint's ``x_j`` that left its orthant set to 0."""
    out = np.where(kinked & (orthant != 0.0) & (np.sign(x) != orthant), 0.0, x)
    return prev + out


# --------------------------------------------------------------------------
# The plant of an elastic arm (docs/model.md, "The plant", "Elastic arms")
# --------------------------------------------------------------------------
def commanded_cables(robot: Robot) -> np.ndarray:
    """The cables an elastic arm's plant commands: its position and displacement cables
    in file order, ``(m_c,)`` int (force cables keep their set tension)."""
    robot = as_robot(robot)
    return np.array([c for c, mode in enumerate(robot.cable_mode) if mode != "force"], dtype=np.int64)


def segments(robot: Robot) -> list:
    """The segments of an arm: the joints between consecutive cable terminations (the
    disks where some cable ends), base to tip, each a list of 0-based joint indices; the
    joints beyond the last termination are a segment of their own."""
    robot = as_robot(robot)
    ends = sorted(set(int(e) for e in robot.cable_end) | {robot.disks})
    out, start = [], 0
    for e in ends:
        joints = [j for j in range(robot.n) if start < robot.joint_disk[j] <= e]
        if joints:
            out.append(joints)
        start = e
    return out


def plant_arm(robot: Robot, joint_stiffness=None, cable_angle=None) -> Robot:
    """The plant's arm of an elastic ``robot``: every joint spring of segment ``s``
    (:func:`segments`) scaled by ``1 + joint_stiffness[s]``; every hole of commanded
    cable ``i`` (:func:`commanded_cables`) turned by ``cable_angle[i]`` rad about its
    face frame's ``x`` (the backbone axis): ``(x, y, z) -> (x, y cos a - z sin a, y sin a
    + z cos a)``."""
    robot = as_robot(robot)
    k = robot.joint_stiffness.copy()
    if joint_stiffness is not None:
        for s, joints in zip(np.asarray(joint_stiffness, float), segments(robot)):
            k[joints] *= 1.0 + s
    holes = [h.copy() for h in robot.holes]
    if cable_angle is not None:
        for a, c in zip(np.asarray(cable_angle, float), commanded_cables(robot)):
            ca, sa = np.cos(a), np.sin(a)
            h = robot.holes[c]
            holes[c] = np.stack([h[:, 0], h[:, 1] * ca - h[:, 2] * sa, h[:, 1] * sa + h[:, 2] * ca], axis=1)
    return dataclasses.replace(robot, joint_stiffness=k, holes=tuple(holes))


def plant_predict(robot: Robot, theta_cmd, dL, kind, effects=None, xtol: float = XTOL, max_iter: int = 100):
    """Observations of a data set by the plant of an elastic arm, rows in execution order.

    ``theta_cmd (N, n)`` rad, ``dL (N, m_c)`` m on the commanded cables, ``kind`` ``N``
    names (``"absolute"``, ``"displacement"``, ``"unmeasured"``).  ``effects``: a dict of
    ``actuation_scale`` ``s``, ``cable_offset`` ``o (m_c,)`` m, ``backlash`` ``b (m_c,)``
    m, ``joint_stiffness`` ``(segments,)``, ``cable_angle (m_c,)`` rad,
    ``frame_misalignment`` (spatial ``[rho (3) rad, t (3) m]``) and ``tip_offset`` (3,) m.

    The commands ``c = L_c,nom(theta_cmd) + dL`` (a displacement row two, without and
    with ``dL``) run through the dead band from the straight pose's lengths ``L_ref``
    (``c - r > b``: ``r = c - b``; ``< -b``: ``r = c + b``) and the actuators, ``l = L_ref
    + (1 + s)(r - L_ref) + o``: each commanded cable's rest length.  The plant's arm
    (:func:`plant_arm`) settles at the minimum of its potential, each command from the
    previous command's answer (:func:`equilibrium_sequence`: a position cable's commanded
    length ``l``, a displacement cable's displacement ``L0 - l`` with ``L0`` the plant
    arm's rest length, so that its rest length is ``l``); the instrument sees ``Rot(rho)
    (p_end + R_end tip) + t`` and the attitude ``Rot(rho) R_end``.

    Returns ``obs (N, t)``, ``converged (N,)`` (:func:`.sequence.observations`).
    """
    robot = as_robot(robot)
    e = dict(effects or {})
    cmd = commanded_cables(robot)
    theta_cmd = np.asarray(theta_cmd, float).reshape(-1, robot.n)
    dL = np.asarray(dL, float).reshape(len(theta_cmd), cmd.size)
    kind = list(kind)
    commands, rows = sq.commands(cable_lengths(robot, theta_cmd)[:, cmd], dL, kind)
    L_ref = cable_lengths(robot, np.zeros((1, robot.n)))[0, cmd]
    b = np.asarray(e.get("backlash", np.zeros(cmd.size)), float)
    r, delivered = L_ref.copy(), np.empty_like(commands)
    for j, c in enumerate(commands):
        r = np.where(c - r > b, c - b, np.where(c - r < -b, c + b, r))
        delivered[j] = r
    s = float(np.atleast_1d(e.get("actuation_scale", 0.0))[0])
    rest = L_ref + (1.0 + s) * (delivered - L_ref) + np.asarray(e.get("cable_offset", np.zeros(cmd.size)), float)
    arm = plant_arm(robot, e.get("joint_stiffness"), e.get("cable_angle"))
    modes = np.array([robot.cable_mode[c] for c in cmd])
    pos, dis = modes == "position", modes == "displacement"
    L0 = rest_lengths(arm)[cmd]
    sol = equilibrium_sequence(arm, lengths=rest[:, pos] if pos.any() else None,
                               displacements=(L0[dis] - rest[:, dis]) if dis.any() else None,
                               xtol=xtol, max_iter=max_iter)
    theta, ok = sol["theta"], np.asarray(sol["converged"], bool)
    mu = float(np.atleast_1d(e.get("cable_friction", 0.0))[0])
    if mu != 0.0:
        z = capstan_motion(robot, commands, theta_cmd[rows], mu)
        theta = theta.copy()
        for j in np.flatnonzero(ok):
            theta[j], ok[j] = capstan_settle(arm, rest[j], z[j], mu, theta[j], xtol=xtol, max_iter=max_iter)
    frame = np.asarray(e.get("frame_misalignment", np.zeros(6)), float)
    tip = np.asarray(e.get("tip_offset", np.zeros(3)), float)
    ch = chain_frames(arm, as_theta(arm, theta))
    p_end, R_end = ch["tb"][:, -1], ch["Rb"][:, -1]
    E = exp_so3(frame[:3])
    seen = (p_end + R_end @ tip) @ E.T + frame[3:]
    return sq.observations(task_vector(arm, seen, E @ R_end, theta), rows, ok, kind)


# --------------------------------------------------------------------------
# Friction in the holes (docs/model.md, "Elastic arms in the plant", friction)
# --------------------------------------------------------------------------
def capstan_wraps(robot: Robot, P: np.ndarray, c: int) -> tuple:
    """Segment lengths ``g (N, 2e)`` m and wrap angles ``beta (N, 2e)`` rad of cable ``c``
    with hole points ``P (N, 2e + 1, 3)``: those of :mod:`.friction`, except at a via
    plate (its disk's thickness 0 and the same hole on both faces: the traversal is a
    point), where the cable turns once, from its gap into the next gap (the point's
    direction is the gap's)."""
    e = int(robot.cable_end[c])
    h = robot.holes[c]
    g, u = fr.segments(P)
    for k in range(1, e + 1):
        if robot.thickness[k - 1] == 0.0 and np.array_equal(h[2 * k - 1], h[2 * k]):
            g[:, 2 * k - 1] = 0.0
            u[:, 2 * k - 1] = u[:, 2 * k - 2]
    N = P.shape[0]
    ex = np.zeros((N, 1, 3))
    ex[..., 0] = 1.0
    dirs = np.concatenate([ex, u], axis=1)
    a, b = dirs[:, :-1], dirs[:, 1:]
    beta = np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), (a * b).sum(-1))
    return g, beta


def _split_rest(robot: Robot, rest: np.ndarray) -> tuple:
    """The commanded cables' rest lengths ``rest (N, m_c)`` m as the statics' commands: the
    position cables' lengths and the displacement cables' displacements ``L0 - l`` (``None``
    where the arm has no such cable)."""
    cmd = commanded_cables(robot)
    modes = np.array([robot.cable_mode[c] for c in cmd])
    pos, dis = modes == "position", modes == "displacement"
    L0 = rest_lengths(robot)[cmd]
    return (rest[:, pos] if pos.any() else None), ((L0[dis] - rest[:, dis]) if dis.any() else None)


def _ea(robot: Robot) -> float:
    return robot.youngs_modulus * np.pi * robot.diameter**2 / 4.0


def _actuator_tensions(robot: Robot, springs: Springs, L: np.ndarray, ebar: np.ndarray) -> np.ndarray:
    """``T_0 (N, m)`` N: every cable's actuator tension from its compatibility with the
    mean capstan factors ``ebar (N, m)`` at its path lengths ``L (N, m)`` m: displacement
    ``(L - l + P/k_s) / (1/k_s + (L0 + L_r)(ebar - 1)/(E A))``, position ``E A (L - l) /
    ((l + L_r) ebar)``, 0 where not positive, the cap above it; a force cable's set tension."""
    EA, Lr = _ea(robot), robot.routing_length
    dis = np.zeros(robot.m, dtype=bool)
    dis[displacement_cables(robot)] = True
    pos = np.zeros(robot.m, dtype=bool)
    pos[position_cables(robot)] = True
    rest = springs.rest
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / springs.k
        share = (rest_lengths(robot) + Lr) / EA
        t_dis = (L - rest + inv * springs.pretension) / (inv + share * (ebar - 1.0))
        t_pos = EA * (L - rest) / ((rest + Lr) * ebar)
    t = np.where(dis, t_dis, np.where(pos, t_pos, 0.0))
    t = np.where(t > 0.0, np.minimum(t, springs.cap), 0.0)
    return np.where(springs.elastic, t, springs.force)


def capstan_residual(robot: Robot, rest, z, mu: float, theta) -> np.ndarray:
    """The friction residual ``r (n,)`` N m of one command at ``theta (n,)`` rad: ``k_j (q_j -
    rest_j) + sum_c T_(c,0) E_(c,2k-1) dL_c/dq_j - tau_j`` (joint ``j`` of disk ``k``).
    ``rest (m_c,)`` m the commanded cables' rest lengths, ``z`` every hole's mobilisation
    (cables in file order, ``2 e_c`` each), ``mu`` the friction coefficient."""
    robot = as_robot(robot)
    springs = tendon_springs(robot, *_split_rest(robot, np.asarray(rest, float)[None]))
    th = as_theta(robot, np.asarray(theta, float).reshape(1, -1))
    ev = evaluate(robot, springs, th, order=1)
    pts = cable_points(robot, th, chain_frames(robot, th))
    n, m = robot.n, robot.m
    ebar = np.ones((1, m))
    gapfac = np.ones((n, m))
    o = 0
    for c, P in enumerate(pts):
        e = int(robot.cable_end[c])
        g, beta = capstan_wraps(robot, P, c)
        E = fr.profile(beta, np.asarray(z, float)[None, o:o + 2 * e], mu)
        ebar[0, c] = fr.mean_factor(g, E, robot.routing_length)[0]
        on = robot.joint_disk <= e
        gapfac[on, c] = E[0, 2 * robot.joint_disk[on] - 1]
        o += 2 * e
    T0 = _actuator_tensions(robot, springs, ev["L"], ebar)[0]
    return (robot.joint_stiffness * (th[0] - robot.rest_angle)
            + (ev["G"][0] * gapfac) @ T0 - ev["tau"][0])


def capstan_motion(robot: Robot, commands, theta_cmd, mu: float) -> np.ndarray:
    """Every hole's mobilisation after each command, ``z (R, H)`` (cables in file order):
    the scan of :func:`.friction.mobilisation_scan` along the nominal motion, every
    command's nominal frictionless equilibrium (``commands (R, m_c)`` the commanded
    cables' nominal rest lengths, warm-started along the sequence; ``theta_cmd (R, n)``
    where it does not converge), the band ``T_hat d sinh(mu beta) / (E A)`` with ``T_hat``
    the frictionless tension there."""
    robot = as_robot(robot)
    lengths, displacements = _split_rest(robot, np.asarray(commands, float))
    sol = equilibrium_sequence(robot, lengths=lengths, displacements=displacements)
    ok = np.asarray(sol["converged"], bool)
    q = np.where(ok[:, None], sol["theta"], np.asarray(theta_cmd, float))
    springs = tendon_springs(robot, lengths=lengths, displacements=displacements)
    T = evaluate(robot, springs, q, order=0)["tension"]
    pts = cable_points(robot, q)
    pts0 = cable_points(robot, np.zeros((1, robot.n)))
    EA = _ea(robot)
    out = []
    for c in range(robot.m):
        g, beta = capstan_wraps(robot, pts[c], c)
        g0, _ = capstan_wraps(robot, pts0[c], c)
        d, d0 = fr.distal_lengths(g), fr.distal_lengths(g0)[0]
        t = np.where(np.isfinite(T[:, c:c + 1]) & (T[:, c:c + 1] > 0.0), T[:, c:c + 1], 0.0)
        w = fr.band(1.0 / EA, mu, t, d, beta)
        out.append(fr.mobilisation_scan(d, w, d0))
    return np.concatenate(out, axis=1)


def capstan_settle(robot: Robot, rest, z, mu: float, seed, xtol: float = XTOL, max_iter: int = 100,
                   step: float = 1e-7) -> tuple:
    """One command settled with friction in the holes: the root of :func:`capstan_residual`
    by Newton from ``seed (n,)`` rad (its frictionless equilibrium), the Jacobian by central
    differences of ``step`` rad, halving the step until ``|r|`` decreases; converged when
    the step is at most ``xtol`` rad (a step of at most ``1e-8`` rad taken whole: ``|r|``
    at its rounding level).  Returns ``(theta (n,), converged)``."""
    q = np.asarray(seed, float).copy()
    n = q.size

    def res(x):
        return capstan_residual(robot, rest, z, mu, x)

    for _ in range(max_iter):
        r = res(q)
        A = np.empty((n, n))
        for j in range(n):
            dq = np.zeros(n)
            dq[j] = step
            A[:, j] = (res(q + dq) - res(q - dq)) / (2.0 * step)
        s = np.linalg.solve(A, -r)
        if np.max(np.abs(s)) <= xtol:
            return q + s, True
        r0, t = np.linalg.norm(r), 1.0
        for _ in range(40):
            if np.linalg.norm(res(q + t * s)) <= (1.0 - 1e-4 * t) * r0:
                break
            t *= 0.5
        else:
            if np.max(np.abs(s)) > 1e-8:
                return np.full(n, np.nan), False
            t = 1.0
        q = q + t * s
    return np.full(n, np.nan), False
