"""The plant: nominal model plus unmodelled effects (``docs/model.md``, last section).

Independent NumPy reference, written from the document alone.  The plant is
the real arm as the nominal robot plus candidate effects with a flat parameter
vector ``p`` (SI units); **all-zero parameters give the nominal model exactly**.

Pipeline for one data set (:func:`plant_predict`)::

    theta_cmd, dL, kind  --(commands, in execution order)-->  c^1, c^2, ...
    c  --backlash_scan-->  r  --realised_lengths-->  L
    L  --settle (elasticity, clearance)-->  theta  --observe-->  seen

Robots are duck-typed as in :mod:`.kinematics` (``n``, ``link_before``,
``link_after``, ``thickness``, ``holes``, ``joint_limits``) plus, where the
statics are needed (``kappa > 0``), ``lower_tension (n,)`` N and ``mass (n,)``
kg; optional ``gravity (2,)`` m/s^2 (absent or None: ``[0, 0]``) and optional
``routing_length`` m (absent or None: 0).

Parameter layout (:data:`PLANT_EFFECTS`, :func:`plant_layout`), ``n`` joints:

=======================  ========  =====================================  ==========
effect                   size      symbols                                unit
=======================  ========  =====================================  ==========
``actuation_scale``      1         ``s``                                  1
``cable_offset``         n         ``o_1..o_n``                           m
``hole_height``          n         ``dh_1..dh_n``                         m
``link_length``          n+1       ``dl_0`` (base->joint 1), ``dl_1..n``  m
``cable_elasticity``     1         ``kappa >= 0`` (``1/(E A)``)           1/N
``hole_clearance``       1         ``cl >= 0``                            m
``frame_misalignment``   3         ``alpha, fx, fy``                      rad, m, m
``tip_offset``           2         ``tx, ty``                             m
``backlash``             n         ``b_1..b_n >= 0`` (half-widths)        m
``clearance_width``      1         ``dw`` (``w = 0.01 + dw > 0``)         rad
``cable_friction``       1         ``mu >= 0`` (every cable, every hole)  1
=======================  ========  =====================================  ==========

Friction (``mu > 0``, :mod:`.friction`): every hole's mobilisation ``z`` runs
over the command sequence from the straight pose (:func:`friction_motion`,
:func:`mobilisation`) and the settled state uses the capstan tension profile.
"""

from __future__ import annotations

import numpy as np

import dataclasses

from . import friction as fr
from . import sequence as sq
from .closed_form import solve_cables_closed_form
from .kinematics import cable_points, fk, position_lengths
from .robot import Robot, as_robot, hole_height_error
from .solve import levenberg_marquardt, solve_rows
from .statics import tensions


def batch_array(a, width: int, name: str) -> np.ndarray:
    """``a`` as a float64 ``(N, width)`` array (no 1-D convenience here)."""
    arr = np.asarray(a, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != width:
        raise ValueError(f"{name} must have shape (N, {width}), got {arr.shape}")
    return arr

__all__ = [
    "PLANT_EFFECTS",
    "CLEARANCE_WIDTH_0",
    "plant_size",
    "plant_layout",
    "plant_params",
    "plant_arm",
    "clearance_shifts",
    "arm_upper_lengths",
    "reference_lengths",
    "backlash_scan",
    "realised_lengths",
    "plant_tensions",
    "settling_residual",
    "settle",
    "observe",
    "plant_commands",
    "plant_predict",
    "friction_motion",
    "mobilisation",
    "friction_factors",
    "cable_compliance",
]

#: Base transition width of the hole clearance, rad (``w = 0.01 + dw``).
CLEARANCE_WIDTH_0 = 0.01

#: The effects of the flat parameter vector, in order: ``(name, size(n))``
#: with ``size`` a function of the number of joints ``n``.
PLANT_EFFECTS = [
    ("actuation_scale", lambda n: 1),
    ("cable_offset", lambda n: n),
    ("hole_height", lambda n: n),
    ("link_length", lambda n: n + 1),
    ("cable_elasticity", lambda n: 1),
    ("hole_clearance", lambda n: 1),
    ("frame_misalignment", lambda n: 3),
    ("tip_offset", lambda n: 2),
    ("backlash", lambda n: n),
    ("clearance_width", lambda n: 1),
    ("cable_friction", lambda n: 1),
]


def plant_size(n: int) -> int:
    """Length of the flat parameter vector for ``n`` joints (``4 n + 11``)."""
    return sum(size(n) for _, size in PLANT_EFFECTS)


def plant_layout(n: int) -> dict:
    """``{effect name: slice}`` into the flat parameter vector, in table order."""
    out, start = {}, 0
    for name, size in PLANT_EFFECTS:
        k = size(n)
        out[name] = slice(start, start + k)
        start += k
    return out


def plant_params(p, n: int) -> dict:
    """Split and check the flat vector ``p`` (``(4n+11,)``, SI) into named arrays.

    Keys: ``s`` (float), ``o (n,)`` m, ``dh (n,)`` m, ``dl (n+1,)`` m, ``kappa``
    1/N, ``cl`` m, ``alpha`` rad, ``f (2,)`` m, ``t (2,)`` m, ``b (n,)`` m,
    ``w`` rad (``0.01 + dw``), ``mu`` (1).  Raises ``ValueError`` on a wrong size
    or when ``kappa < 0``, ``cl < 0``, some ``b_i < 0``, ``w <= 0`` or ``mu < 0``.
    """
    p = np.asarray(p, dtype=float).reshape(-1)
    if p.size != plant_size(n):
        raise ValueError(f"plant parameters must have {plant_size(n)} entries for n = {n}, got {p.size}")
    lay = plant_layout(n)
    fm = p[lay["frame_misalignment"]]
    q = dict(
        s=float(p[lay["actuation_scale"]][0]),
        o=p[lay["cable_offset"]].copy(),
        dh=p[lay["hole_height"]].copy(),
        dl=p[lay["link_length"]].copy(),
        kappa=float(p[lay["cable_elasticity"]][0]),
        cl=float(p[lay["hole_clearance"]][0]),
        alpha=float(fm[0]),
        f=fm[1:3].copy(),
        t=p[lay["tip_offset"]].copy(),
        b=p[lay["backlash"]].copy(),
        w=CLEARANCE_WIDTH_0 + float(p[lay["clearance_width"]][0]),
        mu=float(p[lay["cable_friction"]][0]),
    )
    if not q["kappa"] >= 0.0:
        raise ValueError(f"cable_elasticity kappa must be >= 0, got {q['kappa']}")
    if not q["cl"] >= 0.0:
        raise ValueError(f"hole_clearance cl must be >= 0, got {q['cl']}")
    if not np.all(q["b"] >= 0.0):
        raise ValueError(f"backlash half-widths must be >= 0, got {q['b']}")
    if not q["w"] > 0.0:
        raise ValueError(f"clearance width w = 0.01 + dw must be > 0, got {q['w']}")
    if not q["mu"] >= 0.0:
        raise ValueError(f"cable_friction mu must be >= 0, got {q['mu']}")
    return q


# --------------------------------------------------------------------------
# The arm
# --------------------------------------------------------------------------
def _robot_routing(robot) -> float:
    r = getattr(robot, "routing_length", None)
    return 0.0 if r is None else float(r)


def cable_compliance(robot) -> float:
    """``kappa_c = 1 / (E A)``, ``A = pi d^2 / 4`` (1/N), of the robot's cable
    (``youngs_modulus`` Pa, ``cable_diameter`` m; default the paper's steel,
    1.8e11 Pa and 0.18 mm): friction's change of the tensions stretches the
    cables at ``kappa + kappa_c``."""
    E = float(getattr(robot, "youngs_modulus", 1.8e11))
    d = float(getattr(robot, "cable_diameter", getattr(robot, "diameter", 0.18e-3)))
    return 1.0 / (E * np.pi * d * d / 4.0)


def plant_arm(robot, p) -> Robot:
    """The plant's arm: ``robot`` with the hole-height and link-length errors.

    Every hole of pair ``i`` moves by ``dh_i`` (upper ``y += dh_i``, lower
    ``y -= dh_i``, on every face the pair crosses, the base disk's face ``b``
    included); ``link_before[1] += dl_0`` and ``link_after[i] += dl_i``.
    ``mass``, ``lower_tension``, ``gravity`` (default ``[0, 0]``) and
    ``routing_length`` (default 0) are carried over.  Returns a
    :class:`.robot.Robot`.
    """
    robot = as_robot(robot)
    q = plant_params(p, robot.n)
    arm = hole_height_error(robot, q["dh"])
    offsets, link_after = arm.offsets.copy(), arm.link_after.copy()
    offsets[0, 0] += q["dl"][0]
    link_after[:, 0] += q["dl"][1:]
    return dataclasses.replace(arm, offsets=offsets, link_after=link_after)


def clearance_shifts(theta, cl: float, w: float) -> np.ndarray:
    """Hole shifts ``d_k = cl tanh(theta_k / w)`` (m), ``(N, n)``; ``theta`` rad."""
    return cl * np.tanh(np.asarray(theta, dtype=float) / w)


def _arm_upper_lengths(arm, theta: np.ndarray, cl: float, w: float) -> np.ndarray:
    """Upper-cable lengths of ``arm`` (already perturbed) with hole clearance."""
    g = arm.planar
    n, N = g.n, theta.shape[0]
    H = g.holes[0::2]  # (n cables, n+1 disks, 2 faces, 2) upper holes
    d = clearance_shifts(theta, cl, w)  # (N, n): shift at joint k
    # index grid: cable ci (pair ci+1), segment kk (joint kk+1)
    ci = np.arange(n)[:, None]
    kk = np.arange(n)[None, :]
    mask = kk <= ci  # (n, n)
    # d_{k+1} of the cable, if it crosses joint k+1 (kk < ci), else 0
    d_pad = np.concatenate([d, np.zeros((N, 1))], axis=1)  # (N, n+1)
    d_k = np.broadcast_to(d[:, None, :], (N, n, n))
    d_next = np.where((kk < ci)[None], d_pad[:, None, 1:], 0.0)  # (N, n, n)

    p = H[:, :n, 1, :]  # (n, n, 2) face b of disk k-1
    q = H[:, 1:, 0, :]  # face a of disk k
    b = H[:, 1:, 1, :]  # face b of disk k
    px, py = p[None, ..., 0], p[None, ..., 1] + d_k
    qx, qy = q[None, ..., 0], q[None, ..., 1] + d_k
    bx, by = b[None, ..., 0], b[None, ..., 1] + d_next
    # A_k = (lb_k, 0) + Rot(theta_k) (q' + (la_k, 0)), frame O_{k-1,b}
    ux = qx + g.link_after[None, None, :]
    uy = qy
    c, s = np.cos(theta)[:, None, :], np.sin(theta)[:, None, :]
    ax = g.link_before[None, None, :] + c * ux - s * uy
    ay = s * ux + c * uy
    seg = np.hypot(ax - px, ay - py)
    # traversal of disk k, frame O_{k,a}
    tr = np.hypot(g.thickness[None, None, :] + bx - qx, by - qy)
    return np.where(mask[None], seg + tr, 0.0).sum(axis=2)


def arm_upper_lengths(robot, p, theta) -> np.ndarray:
    """Geometric upper-cable lengths of the plant's arm with hole clearance, m, ``(N, n)``.

    ``theta``: rad, ``(N, n)``.  Joint ``k`` shifts both holes beside it (face
    ``b`` of disk ``k-1``, face ``a`` of disk ``k``) by
    ``d_k = cl tanh(theta_k / w)`` along their local ``y``;
    ``L_arm,i = sum_{k<=i} |A_k - p'| + |t_k|`` with the traversal of disk ``k``
    ``t_k = (thickness_k + b_x - q'_x, b_y + d_{k+1} - q'_y)``, ``d_{k+1} = 0``
    for ``k = i`` (the anchor hole does not move).  With ``cl = 0`` these are
    the nominal (Eq. 4-5) upper lengths of :func:`plant_arm`.
    """
    arm = plant_arm(robot, p)
    q = plant_params(p, arm.n)
    theta = batch_array(theta, arm.n, "theta")
    return _arm_upper_lengths(arm, theta, q["cl"], q["w"])


# --------------------------------------------------------------------------
# Commands, backlash, actuation
# --------------------------------------------------------------------------
def reference_lengths(robot) -> np.ndarray:
    """``L_ref (n,)`` m: straight-pose upper lengths of the *nominal* robot."""
    return position_lengths(robot, np.zeros((1, int(robot.n))))[0]


def backlash_scan(robot, p, commands, start=None) -> np.ndarray:
    """Lost motion per upper cable over a command sequence.

    ``commands``: ``(R, n)`` m, in execution order.  The state ``r`` starts at
    ``start`` (default ``L_ref``, the nominal straight pose).  For each command
    ``c``, per cable: ``c - r > b`` -> ``r = c - b``; ``c - r < -b`` ->
    ``r = c + b``; otherwise unchanged.  Returns the delivered lengths
    ``r (R, n)`` m, one row per command (``b = 0``: ``r = c``).
    """
    n = int(robot.n)
    b = plant_params(p, n)["b"]
    commands = batch_array(commands, n, "commands")
    r = reference_lengths(robot).copy() if start is None else np.array(start, dtype=float).reshape(n)
    out = np.empty_like(commands)
    for j in range(commands.shape[0]):
        c = commands[j]
        r = np.where(c - r > b, c - b, np.where(c - r < -b, c + b, r))
        out[j] = r
    return out


def realised_lengths(robot, p, r) -> np.ndarray:
    """Realised (rest) upper lengths ``L = L_ref + (1 + s)(r - L_ref) + o``, m, ``(R, n)``.

    ``r``: delivered lengths ``(R, n)`` m (:func:`backlash_scan`).
    """
    n = int(robot.n)
    q = plant_params(p, n)
    r = batch_array(r, n, "r")
    L_ref = reference_lengths(robot)
    return L_ref + (1.0 + q["s"]) * (r - L_ref) + q["o"]


# --------------------------------------------------------------------------
# Settling
# --------------------------------------------------------------------------
def plant_tensions(robot, p, theta) -> np.ndarray:
    """Upper tensions ``(N, n)`` N of the statics of the plant's arm at ``theta``.

    Lower tensions ``robot.lower_tension``, gravity ``robot.gravity`` (default
    ``[0, 0]``) on ``robot.mass``, no tip wrench; the arm is
    :func:`plant_arm` *without* the clearance shifts.
    """
    arm = plant_arm(robot, p)
    return tensions(arm, batch_array(theta, arm.n, "theta"))


def friction_factors(arm, theta, z, mu: float):
    """The capstan profile of every cable of ``arm`` at ``theta (N, n)`` rad with
    the mobilisations ``z (N, H)`` (holes cable by cable, ``2 e`` each): the gap
    factors ``(N, n, m)`` (tension in the gap of joint ``j`` over the routing's, 1
    where the cable does not cross it) and ``ebar (N, m)`` (the length-weighted mean
    factor with the routing, ``docs/model.md``)."""
    arm = as_robot(arm)
    theta = batch_array(theta, arm.n, "theta")
    N = theta.shape[0]
    gap = np.ones((N, arm.n, arm.m))
    ebar = np.empty((N, arm.m))
    start = 0
    for c, P in enumerate(cable_points(arm, theta)):
        e = int(arm.cable_end[c])
        beta = fr.wrap_angles(P)
        g, _ = fr.segments(P)
        E = fr.profile(beta, z[:, start:start + 2 * e], mu)
        start += 2 * e
        for j in range(arm.n):
            k = int(arm.joint_disk[j])
            if k <= e:
                gap[:, j, c] = E[:, 2 * k - 1]
        ebar[:, c] = fr.mean_factor(g, E, float(arm.routing_length))
    return gap, ebar


def _hole_count(n: int) -> int:
    return sum(2 * (c // 2 + 1) for c in range(2 * n))


def _settling_F(robot, arm, q, L, theta, lower, z=None):
    """``F = L_arm(theta) - (L + L_route)(1 + kappa T(theta)) + L_route`` (m);
    with friction ``F = L_arm - L - (L + L_route) (kappa T_0 ebar + kappa_c (T_0 ebar
    - T*))`` (``T_0`` from the balance with the capstan gap factors of the
    mobilisations ``z (N, H)``, ``T*`` the frictionless balance's,
    ``kappa_c`` :func:`cable_compliance`)."""
    La = _arm_upper_lengths(arm, theta, q["cl"], q["w"])
    if q["kappa"] == 0.0 and q["mu"] == 0.0:
        return La - L
    Lr = arm.routing_length
    if q["mu"] == 0.0:
        T = tensions(arm, theta, lower=lower)
        return La - (L + Lr) * (1.0 + q["kappa"] * T) + Lr
    gap, ebar = friction_factors(arm, theta, z, q["mu"])
    T = tensions(arm, theta, lower=lower, gap=gap) * ebar[:, 0::2]
    T0 = tensions(arm, theta, lower=lower)
    return La - L - (L + Lr) * (q["kappa"] * T + cable_compliance(robot) * (T - T0))


def settling_residual(robot, p, realised, theta, z=None) -> np.ndarray:
    """``F(theta) = L_arm(theta) - (L + L_route)(1 + kappa T(theta)) + L_route``, m, ``(N, n)``.

    ``realised``: ``L (N, n)`` m; ``theta (N, n)`` rad; ``z (N, H)`` the
    mobilisations (friction; default every hole at +1).  Zero at the settled
    configuration.  With ``kappa = 0`` it is ``L_arm(theta) - L`` (the
    tensions are not evaluated).
    """
    arm = plant_arm(robot, p)
    q = plant_params(p, arm.n)
    L = batch_array(realised, arm.n, "realised")
    theta = batch_array(theta, arm.n, "theta")
    lower = None if q["kappa"] == 0.0 and q["mu"] == 0.0 else np.broadcast_to(
        np.asarray(arm.planar.lower_tension, dtype=float), L.shape)
    z = np.ones((L.shape[0], _hole_count(arm.n))) if z is None else np.asarray(z, float)
    return _settling_F(robot, arm, q, L, theta, lower, z)


def settle(robot, p, realised, theta_seed, tol=1e-12, max_iter=100, fd_step=1e-6, z=None):
    """Joint angles at which the plant's arm settles, per row.

    Solves ``L_arm,i(theta) = (L_i + L_route)(1 + kappa T_i(theta)) - L_route``
    (``realised`` = ``L (N, n)`` m, ``theta_seed (N, n)`` rad = ``theta_cmd``).
    First the rigid closed-form cable solve of the plant's arm (``L_arm = L``
    without clearance), branch nearest the seed; with ``kappa = 0`` and
    ``cl = 0`` that is the answer.  Otherwise damped Newton (the shared LM,
    ``delta = (J^T J + lambda I)^-1 J^T r``, ``r = -F``, tolerance ``tol`` m)
    from the rigid answer (from the seed where the rigid solve has no real
    branch), ``J = dF/dtheta`` by central differences of step ``fd_step`` rad.

    Returns ``(theta (N, n) rad, converged (N,) bool)``.
    """
    arm = plant_arm(robot, p)
    n = arm.n
    q = plant_params(p, n)
    L = batch_array(realised, n, "realised")
    seed = np.array(batch_array(theta_seed, n, "theta_seed"), dtype=float)
    if seed.shape != L.shape:
        raise ValueError(f"theta_seed must have shape {L.shape}, got {seed.shape}")

    rigid = solve_cables_closed_form(arm, L, seed=seed)
    if q["kappa"] == 0.0 and q["cl"] == 0.0 and q["mu"] == 0.0:
        return rigid["theta"], rigid["converged"]

    theta = np.where(rigid["converged"][:, None], rigid["theta"], seed)
    lower = None if q["kappa"] == 0.0 and q["mu"] == 0.0 else np.broadcast_to(
        np.asarray(arm.planar.lower_tension, dtype=float), L.shape)
    z = np.ones((L.shape[0], _hole_count(n))) if z is None else np.asarray(z, float)

    def F(th, idx):
        return _settling_F(robot, arm, q, L[idx], th, None if lower is None else lower[idx], z[idx])

    def residual(th, idx):
        return -F(th, idx)

    def step(th, r, lam, idx):
        J = np.empty((th.shape[0], n, n))
        for k in range(n):
            e = np.zeros(n)
            e[k] = fd_step
            J[:, :, k] = (F(th + e, idx) - F(th - e, idx)) / (2.0 * fd_step)
        Jt = np.swapaxes(J, 1, 2)
        A = Jt @ J + lam[:, None, None] * np.eye(n)
        return solve_rows(A, (Jt @ r[..., None])[..., 0])

    with np.errstate(all="ignore"):
        sol = levenberg_marquardt(residual, step, theta, tol, max_iter)
    return sol["theta"], sol["converged"]


# --------------------------------------------------------------------------
# Observation
# --------------------------------------------------------------------------
def observe(robot, p, theta) -> np.ndarray:
    """What the instrument sees at the settled ``theta (N, n)`` rad: ``(N, 3)``.

    ``(x, y, phi)`` = Eq. 1-3 on the plant's arm; ``tip = (x, y) + Rot(phi)(tx, ty)``;
    ``seen = Rot(alpha) tip + (fx, fy)`` (m) and ``phi_seen = phi + alpha`` (rad).
    """
    arm = plant_arm(robot, p)
    q = plant_params(p, arm.n)
    S = fk(arm, batch_array(theta, arm.n, "theta"))
    phi = S[:, 2]
    tx, ty = q["t"]
    tip_x = S[:, 0] + np.cos(phi) * tx - np.sin(phi) * ty
    tip_y = S[:, 1] + np.sin(phi) * tx + np.cos(phi) * ty
    ca, sa = np.cos(q["alpha"]), np.sin(q["alpha"])
    seen_x = ca * tip_x - sa * tip_y + q["f"][0]
    seen_y = sa * tip_x + ca * tip_y + q["f"][1]
    return np.stack([seen_x, seen_y, phi + q["alpha"]], axis=1)


# --------------------------------------------------------------------------
# Whole pipeline
# --------------------------------------------------------------------------
_KINDS = ("absolute", "displacement", "unmeasured")


def plant_commands(robot, theta_cmd, dL, kind):
    """The command sequence of a data set (rows already in execution order).

    ``C = L_upper,nom(theta_cmd)``; absolute and unmeasured rows give one
    command ``C + dL``, displacement rows two, ``C`` then ``C + dL``.  Returns
    ``commands (R, n)`` m, ``row (R,)`` (the data row of each command) and
    ``seeds (R, n)`` rad (that row's ``theta_cmd``).
    """
    n = int(robot.n)
    theta_cmd = batch_array(theta_cmd, n, "theta_cmd")
    dL = batch_array(dL, n, "dL")
    kind = list(kind)
    N = theta_cmd.shape[0]
    if dL.shape[0] != N or len(kind) != N:
        raise ValueError(f"theta_cmd, dL and kind must have the same number of rows, "
                         f"got {N}, {dL.shape[0]}, {len(kind)}")
    bad = [k for k in kind if k not in _KINDS]
    if bad:
        raise ValueError(f"kind must be one of {_KINDS}, got {bad[0]!r}")
    C = position_lengths(robot, theta_cmd)
    commands, rows = [], []
    for i, k in enumerate(kind):
        if k == "displacement":
            commands.append(C[i])
            rows.append(i)
        commands.append(C[i] + dL[i])
        rows.append(i)
    commands = np.array(commands).reshape(-1, n)
    rows = np.array(rows, dtype=np.int64)
    return commands, rows, theta_cmd[rows]


def friction_motion(robot, commands, seeds, first) -> tuple:
    """What the friction scan needs of the nominal motion (``docs/model.md``,
    "Sliding directions and the sticking band").

    ``commands (R, n)`` m, ``seeds (R, n)`` rad (each command's row
    ``theta_cmd``), ``first (R,)`` bool (a displacement row's first command:
    its configuration is the seed itself).  The nominal configuration of every
    other command is the closed-form cable solve of the nominal robot from the
    seed (the seed where it fails).  Returns ``d (R, H)`` m the distal lengths,
    ``beta (R, H)`` rad the wrap angles, ``tension (R, H)`` N the cable's
    frictionless tension ``T_hat`` at every hole (upper: the balance's, 0 where
    negative or undefined; lower: its set tension) and ``d0 (H,)`` the straight
    pose's distal lengths; holes cable by cable (``2 e`` each)."""
    robot = as_robot(robot)
    n = int(robot.n)
    commands = batch_array(commands, n, "commands")
    seeds = batch_array(seeds, n, "seeds")
    sol = solve_cables_closed_form(robot, commands, seed=seeds)
    theta = np.where(sol["converged"][:, None] & ~np.asarray(first, bool)[:, None], sol["theta"], seeds)
    T = tensions(robot, theta)
    T = np.where(np.isfinite(T) & (T > 0.0), T, 0.0)
    lower = np.asarray(robot.planar.lower_tension, dtype=float)

    def holes(th, Tup):
        d, beta, ten = [], [], []
        for c, P in enumerate(cable_points(robot, th)):
            gseg, _ = fr.segments(P)
            d.append(fr.distal_lengths(gseg))
            beta.append(fr.wrap_angles(P))
            tc = Tup[:, c // 2] if c % 2 == 0 else np.full(th.shape[0], lower[c // 2])
            ten.append(np.repeat(tc[:, None], gseg.shape[1], axis=1))
        return np.concatenate(d, 1), np.concatenate(beta, 1), np.concatenate(ten, 1)

    d, beta, ten = holes(theta, T)
    d0, _, _ = holes(np.zeros((1, n)), np.zeros((1, n)))
    return d, beta, ten, d0[0]


def mobilisation(robot, p, commands, seeds, first) -> np.ndarray:
    """``z (R, H)``: every hole's mobilisation after each command of the sequence
    (:func:`friction_motion`, :func:`.friction.mobilisation_scan` with the bands
    ``(kappa + kappa_c) T_hat d sinh(mu beta)`` of the plant ``p``, :func:`cable_compliance`)."""
    q = plant_params(p, int(robot.n))
    d, beta, ten, d0 = friction_motion(robot, commands, seeds, first)
    kf = q["kappa"] + cable_compliance(robot)
    return fr.mobilisation_scan(d, fr.band(kf, q["mu"], ten, d, beta), d0)


def plant_predict(robot, p, theta_cmd, dL, kind):
    """Observations of a data set under the plant ``p``.

    ``theta_cmd (N, n)`` rad, ``dL (N, n)`` m, ``kind``: length-``N`` sequence
    of ``"absolute" | "displacement" | "unmeasured"``, rows in execution order.
    All commands form one sequence (:func:`plant_commands`); backlash runs over
    the whole of it from the straight pose; each command settles from its
    row's ``theta_cmd``.  Returns ``(obs (N, 3), converged (N,))``: ``obs`` is
    ``seen`` (absolute), ``seen(C + dL) - seen(C)`` (displacement, both
    components and ``phi``), NaN (unmeasured, and rows that did not settle); ``converged`` is True when every
    command of the row settled (also for unmeasured rows).
    """
    robot = as_robot(robot)
    commands, rows, seeds = plant_commands(robot, theta_cmd, dL, kind)
    r = backlash_scan(robot, p, commands)
    L = realised_lengths(robot, p, r)
    first = sq.first_of_pairs(rows)
    z = mobilisation(robot, p, commands, seeds, first) if plant_params(p, int(robot.n))["mu"] > 0.0 else None
    theta, ok = settle(robot, p, L, seeds, z=z)
    return sq.observations(observe(robot, p, theta), rows, ok, kind)
