"""Independent NumPy reference of the SPATIAL plant: the real arm as the nominal
spatial model plus unmodelled effects.

Written from ``docs/model.md`` ("The arm model", "The plant" and its
subsections) and ``docs/spatial.md`` alone, on top of the reference spatial
kinematics (:mod:`.kinematics`); the tests check the Rust core's one plant
(``cdsm.calibration.plant`` on a ``kind = "spatial"`` robot) against it.
**All-zero parameters give the nominal model exactly.**

Units: SI everywhere -- lengths m, angles rad, forces N, compliance 1/N.
Orientations are rotation vectors (rad, principal logarithm).

Pipeline for one data set (:func:`predict`), rows in execution order::

    theta_cmd, dL, kind  --commands-->  c^1, c^2, ...        (m_pos lengths each)
    c  --backlash_scan-->  r  --realised_lengths-->  L
    L  --settle (rigid solve, then elasticity / clearance)-->  theta
    theta  --observe-->  [x, y, z, rx, ry, rz]

Notation: ``n`` joints, ``K`` disks, ``m`` position-controlled cables (the
commanded ones, file order, :func:`.robot.position_cables`), ``H`` the holes
of those cables (``2 e_c + 1`` each, cable by cable in file order, each cable's
holes in file order: base face b, then faces a, b of disks ``1..e_c``).

Parameter layout (:data:`BLOCKS`, :func:`layout`), in this order:

======================  ==========  ==========================================  =========
block                   size        meaning                                     unit
======================  ==========  ==========================================  =========
``actuation_scale``     1           ``s``: ``L = L_ref + (1 + s)(r - L_ref) + o``  1
``cable_offset``        m           ``o`` per position cable                    m
``hole_position``       3H          every hole of the position cables moved     m
                                    by ``[dx, dy, dz]`` in its face frame
``link_length``         3(n + K)    every joint ``offset``, then every disk's   m
                                    ``link_after``, moved by a 3-vector
``cable_elasticity``    1           ``kappa >= 0``                              1/N
``frame_misalignment``  6           rotation vector ``rho``, translation ``t``  rad, m
``tip_offset``          3           measured point in the end frame             m
``backlash``            m           dead-band half-width ``b >= 0``             m
``hole_clearance``      1           ``cl >= 0``                                 m
``clearance_width``     1           ``dw`` (``w = 0.01 + dw``)                  rad
``joint_axis``          2n          ``(d1, d2)`` tilt of each joint's axis      rad
``cable_friction``      1           ``mu >= 0``: friction in every hole         1
======================  ==========  ==========================================  =========

Friction (``mu > 0``, :mod:`.friction`, ``docs/model.md`` "Friction in the
holes"): every hole of every cable has a mobilisation ``z`` scanned over the
command sequence on the nominal motion (:func:`friction_motion`,
:func:`mobilisation`); the balance takes each cable's tension in the gap of
each joint and the stretch the length-weighted profile.

Readings where the docs leave a choice (each checked against the core by the
parity tests):

* ``hole_position``: cable by cable (position cables in file order), each
  cable's holes in file order, ``[dx, dy, dz]`` per hole.
* ``joint_axis``: "within about 25 deg of x" is ``|a . e_x| > 0.9`` (25.8 deg;
  :data:`AXIS_NEAR_X`), either direction of x.
* ``m = n`` statics: the square solve of the moment balance, no floor (a
  negative tension is kept).
* ``m > n``: ``dL_i/dtheta_j`` of the equilibrium (rigid and elastic) is that
  of the unshifted holes ``J0`` also in the elastic case.
* The settled configuration is found by this module's own solver (rigid cable
  solve, an energy descent for the elastic ``m > n`` arm, then a semismooth
  damped Newton), not by imitating the core's path; where the core fails to
  settle a command whose equilibrium exists, the two differ in ``converged``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from . import friction as fr
from . import sequence as sq
from . import kinematics as kin
from . import robot as rb
from . import rotations as rot
from . import solve as sv
from . import statics as st

__all__ = [
    "BLOCKS",
    "CLEARANCE_WIDTH_0",
    "AXIS_NEAR_X",
    "block_sizes",
    "layout",
    "size",
    "plant_params",
    "axis_basis",
    "tilted_axes",
    "plant_arm",
    "bend_shifts",
    "arm_lengths",
    "reference_lengths",
    "plant_commands",
    "backlash_scan",
    "realised_lengths",
    "plant_tensions",
    "settling_residual",
    "settle",
    "observe",
    "predict",
    "friction_factors",
    "friction_motion",
    "mobilisation",
]

#: The parameter blocks of a spatial arm's plant, in the order of the flat vector.
BLOCKS = ("actuation_scale", "cable_offset", "hole_position", "link_length", "cable_elasticity",
          "frame_misalignment", "tip_offset", "backlash", "hole_clearance", "clearance_width", "joint_axis",
          "cable_friction")

#: Base transition width of the hole clearance, rad (``w = 0.01 + dw``).
CLEARANCE_WIDTH_0 = 0.01

#: ``|a . e_x|`` above which a joint axis ``a`` counts as "within about 25 deg of
#: x" and its tilt basis starts from ``y`` instead (cos 25 deg = 0.906; the docs
#: give no exact threshold, this reading takes 0.9, i.e. 25.8 deg).
AXIS_NEAR_X = 0.9

_KINDS = ("absolute", "displacement", "unmeasured")


# --------------------------------------------------------------------------
# Parameter layout
# --------------------------------------------------------------------------
def _pos(robot) -> np.ndarray:
    return rb.position_cables(robot)


def _hole_count(robot) -> int:
    return int(sum(2 * int(robot.cable_end[c]) + 1 for c in _pos(robot)))


def block_sizes(robot) -> list:
    """``[(block, size), ...]`` of the flat vector of ``robot`` (a :class:`.robot.Robot`)."""
    n, K, m, H = robot.n, robot.disks, int(_pos(robot).size), _hole_count(robot)
    sizes = dict(actuation_scale=1, cable_offset=m, hole_position=3 * H, link_length=3 * (n + K),
                 cable_elasticity=1, frame_misalignment=6, tip_offset=3, backlash=m, hole_clearance=1,
                 clearance_width=1, joint_axis=2 * n, cable_friction=1)
    return [(b, sizes[b]) for b in BLOCKS]


def layout(robot) -> dict:
    """``{block: slice}`` into the flat parameter vector, in :data:`BLOCKS` order."""
    out, start = {}, 0
    for name, k in block_sizes(robot):
        out[name] = slice(start, start + k)
        start += k
    return out


def size(robot) -> int:
    """Length of the flat parameter vector, ``2m + 3H + 3(n + K) + 2n + 14``."""
    return sum(k for _, k in block_sizes(robot))


def plant_params(robot, p) -> dict:
    """Split and check the flat vector ``p (size(robot),)`` (SI) into named arrays.

    Keys: ``s`` (float), ``o (m,)`` m, ``dholes`` (tuple, one ``(2 e_c + 1, 3)`` m
    array per position cable), ``doffset (n, 3)`` m, ``dlink_after (K, 3)`` m,
    ``kappa`` 1/N, ``rho (3,)`` rad, ``t (3,)`` m, ``tip (3,)`` m, ``b (m,)`` m,
    ``cl`` m, ``w`` rad (``0.01 + dw``), ``tilt (n, 2)`` rad, ``mu`` (1).  ``ValueError`` on a
    wrong size or outside the physical domain of ``docs/model.md`` (``kappa < 0``, ``mu < 0``,
    ``cl < 0``, some ``b < 0``, ``w`` outside ``[1e-4, 1]``, ``1 + s <= 0.1``; the
    upper bound of ``cl``, "the least hole radius", is not checked).
    """
    p = np.asarray(p, dtype=float).reshape(-1)
    if p.size != size(robot):
        raise ValueError(f"plant parameters must have {size(robot)} entries for this robot, got {p.size}")
    lay = layout(robot)
    n, K = robot.n, robot.disks
    dh = p[lay["hole_position"]].reshape(-1, 3)
    dholes, start = [], 0
    for c in _pos(robot):
        cnt = 2 * int(robot.cable_end[c]) + 1
        dholes.append(dh[start:start + cnt].copy())
        start += cnt
    ll = p[lay["link_length"]].reshape(n + K, 3)
    fm = p[lay["frame_misalignment"]]
    q = dict(
        s=float(p[lay["actuation_scale"]][0]),
        o=p[lay["cable_offset"]].copy(),
        dholes=tuple(dholes),
        doffset=ll[:n].copy(),
        dlink_after=ll[n:].copy(),
        kappa=float(p[lay["cable_elasticity"]][0]),
        rho=fm[:3].copy(),
        t=fm[3:].copy(),
        tip=p[lay["tip_offset"]].copy(),
        b=p[lay["backlash"]].copy(),
        cl=float(p[lay["hole_clearance"]][0]),
        w=CLEARANCE_WIDTH_0 + float(p[lay["clearance_width"]][0]),
        tilt=p[lay["joint_axis"]].reshape(n, 2).copy(),
        mu=float(p[lay["cable_friction"]][0]),
    )
    if not q["kappa"] >= 0.0:
        raise ValueError(f"cable_elasticity kappa must be >= 0, got {q['kappa']}")
    if not q["cl"] >= 0.0:
        raise ValueError(f"hole_clearance cl must be >= 0, got {q['cl']}")
    if not np.all(q["b"] >= 0.0):
        raise ValueError(f"backlash half-widths must be >= 0, got {q['b']}")
    if not 1e-4 <= q["w"] <= 1.0:
        raise ValueError(f"clearance width w = 0.01 + dw must be within [1e-4, 1] rad, got {q['w']}")
    if not q["mu"] >= 0.0:
        raise ValueError(f"cable_friction mu must be >= 0, got {q['mu']}")
    if not 1.0 + q["s"] > 0.1:
        raise ValueError(f"actuator gain 1 + s must be above 0.1, got {1.0 + q['s']}")
    return q


# --------------------------------------------------------------------------
# The plant's arm
# --------------------------------------------------------------------------
def axis_basis(axis) -> tuple:
    """The tilt basis ``(e1, e2)`` (each ``(3,)``) of a unit joint axis ``a (3,)``.

    ``e1``: ``e_x`` made perpendicular to ``a`` and normalised (``e_y`` instead
    when ``|a . e_x| > AXIS_NEAR_X``, ``a`` within about 25 deg of ``x``);
    ``e2 = a x e1``.
    """
    a = np.asarray(axis, dtype=float)
    ref = np.array([1.0, 0.0, 0.0]) if abs(a[0]) <= AXIS_NEAR_X else np.array([0.0, 1.0, 0.0])
    e1 = ref - (ref @ a) * a
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def tilted_axes(axes, tilt) -> np.ndarray:
    """Joint axes ``(n, 3)`` tilted by ``tilt (n, 2)`` rad: ``(a + d1 e1 + d2 e2) / |...|``."""
    axes = np.asarray(axes, dtype=float)
    out = np.empty_like(axes)
    for j, a in enumerate(axes):
        e1, e2 = axis_basis(a)
        v = a + tilt[j, 0] * e1 + tilt[j, 1] * e2
        out[j] = v / np.linalg.norm(v)
    return out


def plant_arm(robot, p):
    """The plant's arm: ``robot`` (:class:`.robot.Robot`) with every hole of the
    position cables moved by its ``hole_position`` 3-vector (face frame), every joint
    offset and disk ``link_after`` moved by its ``link_length`` 3-vector and every
    joint axis tilted by ``joint_axis``.  Force-cable holes, masses, centres of mass,
    thicknesses, gravity and the cable material are unchanged.  Returns a new
    :class:`.robot.Robot`.
    """
    q = plant_params(robot, p)
    holes = list(robot.holes)
    for i, c in enumerate(_pos(robot)):
        holes[c] = robot.holes[c] + q["dholes"][i]
    return dataclasses.replace(
        robot,
        axes=tilted_axes(robot.axes, q["tilt"]),
        offsets=robot.offsets + q["doffset"],
        link_after=robot.link_after + q["dlink_after"],
        holes=tuple(holes),
    )


def _bend(ch: dict, K: int, cl: float, w: float) -> tuple:
    """Clearance shifts of the bend of every disk: ``sb, sa (N, K+1, 3)`` m, index ``k = 1..K``.

    ``sb[:, k]``: on face b of disk ``k - 1`` (its own frame), ``cl g (0, n_y, n_z)``;
    ``sa[:, k]``: on face a of disk ``k``, ``-cl g (0, m_y, m_z)``; ``n = R_k e_x``,
    ``m = R_k^T e_x``, ``R_k = R(F_(k-1)b)^T R(F_ka)`` the rotation of the motion
    ``T_k``, ``phi = atan2(|(n_y, n_z)|, n_x)``, ``g = tanh(phi / w) / sin(phi)``
    (``1/w`` at ``phi = 0``).
    """
    N = ch["tb"].shape[0]
    sb = np.zeros((N, K + 1, 3))
    sa = np.zeros((N, K + 1, 3))
    if cl == 0.0:
        return sb, sa
    for k in range(1, K + 1):
        Rk = np.swapaxes(ch["Rb"][:, k - 1], 1, 2) @ ch["Ra"][:, k]
        nv, mv = Rk[:, :, 0], Rk[:, 0, :]
        phi = np.arctan2(np.hypot(nv[:, 1], nv[:, 2]), nv[:, 0])
        sphi = np.sin(phi)
        g = np.where(sphi > 0.0, np.tanh(phi / w) / np.where(sphi > 0.0, sphi, 1.0), 1.0 / w)
        sb[:, k, 1:] = (cl * g)[:, None] * nv[:, 1:]
        sa[:, k, 1:] = -(cl * g)[:, None] * mv[:, 1:]
    return sb, sa


def bend_shifts(robot, p, theta) -> tuple:
    """Hole-clearance shifts of the plant's arm at ``theta (N, n)`` rad (:func:`_bend`):
    ``sb, sa (N, K+1, 3)`` m (index 0 unused, zero)."""
    arm = plant_arm(robot, p)
    q = plant_params(robot, p)
    return _bend(kin.chain_frames(arm, kin.as_theta(arm, theta)), arm.disks, q["cl"], q["w"])


def _arm_lengths(arm, ch: dict, cl: float, w: float) -> np.ndarray:
    """Position-cable lengths ``(N, m)`` m of ``arm`` (already moved) with hole clearance."""
    sb, sa = _bend(ch, arm.disks, cl, w)
    pos = _pos(arm)
    N = ch["tb"].shape[0]
    out = np.zeros((N, pos.size))
    for i, c in enumerate(pos):
        e, h = int(arm.cable_end[c]), arm.holes[c]
        prev = h[0] + sb[:, 1]  # B'_0 (base face b, the identity frame), shifted by the bend of disk 1
        for k in range(1, e + 1):
            A = np.einsum("nij,nj->ni", ch["Ra"][:, k], h[2 * k - 1] + sa[:, k]) + ch["ta"][:, k]
            hb = h[2 * k] + (sb[:, k + 1] if k < e else np.zeros((N, 3)))  # the anchor hole does not move
            B = np.einsum("nij,nj->ni", ch["Rb"][:, k], hb) + ch["tb"][:, k]
            out[:, i] += np.linalg.norm(A - prev, axis=-1) + np.linalg.norm(B - A, axis=-1)
            prev = B
    return out


def arm_lengths(robot, p, theta) -> np.ndarray:
    """Geometric position-cable lengths ``L_arm (N, m)`` m of the plant's arm at
    ``theta (N, n)`` rad, with the hole-clearance shifts of every bend
    (``docs/model.md``, "The arm"); with ``cl = 0`` the nominal lengths of :func:`plant_arm`."""
    arm = plant_arm(robot, p)
    q = plant_params(robot, p)
    return _arm_lengths(arm, kin.chain_frames(arm, kin.as_theta(arm, theta)), q["cl"], q["w"])


# --------------------------------------------------------------------------
# Commands, backlash, actuation
# --------------------------------------------------------------------------
def reference_lengths(robot) -> np.ndarray:
    """``L_ref (m,)`` m: straight-pose position-cable lengths of the *nominal* robot."""
    return kin.cable_lengths(robot, np.zeros((1, robot.n)))[0, _pos(robot)]


def plant_commands(robot, theta_cmd, dL, kind) -> tuple:
    """The command sequence of a data set (rows in execution order).

    ``theta_cmd (N, n)`` rad, ``dL (N, m)`` m, ``kind`` ``N`` names.  ``C =
    L_pos,nom(theta_cmd)``; absolute and unmeasured rows give one command
    ``C + dL``, displacement rows two, ``C`` then ``C + dL``.  Returns
    ``commands (R, m)`` m, ``rows (R,)`` (the data row of each command) and
    ``seeds (R, n)`` rad (that row's ``theta_cmd``).
    """
    pos = _pos(robot)
    theta_cmd = np.asarray(theta_cmd, dtype=float).reshape(-1, robot.n)
    N = theta_cmd.shape[0]
    dL = np.asarray(dL, dtype=float).reshape(N, pos.size)
    kind = list(kind)
    if len(kind) != N:
        raise ValueError(f"kind must have {N} entries, got {len(kind)}")
    bad = [k for k in kind if k not in _KINDS]
    if bad:
        raise ValueError(f"kind must be one of {_KINDS}, got {bad[0]!r}")
    C = kin.cable_lengths(robot, theta_cmd)[:, pos]
    commands, rows = [], []
    for i, k in enumerate(kind):
        if k == "displacement":
            commands.append(C[i])
            rows.append(i)
        commands.append(C[i] + dL[i])
        rows.append(i)
    rows = np.array(rows, dtype=np.int64)
    return np.array(commands).reshape(-1, pos.size), rows, theta_cmd[rows]


def backlash_scan(robot, p, commands) -> np.ndarray:
    """Lost motion per position cable over a command sequence ``commands (R, m)`` m.

    The state ``r`` starts at ``L_ref`` (the straight pose); per command ``c``:
    ``c - r > b`` -> ``r = c - b``; ``c - r < -b`` -> ``r = c + b``; otherwise
    unchanged.  Returns the delivered lengths ``r (R, m)`` m.
    """
    b = plant_params(robot, p)["b"]
    commands = np.asarray(commands, dtype=float)
    r = reference_lengths(robot).copy()
    out = np.empty_like(commands)
    for j, c in enumerate(commands):
        r = np.where(c - r > b, c - b, np.where(c - r < -b, c + b, r))
        out[j] = r
    return out


def realised_lengths(robot, p, r) -> np.ndarray:
    """Realised rest lengths ``L = L_ref + (1 + s)(r - L_ref) + o``, ``(R, m)`` m."""
    q = plant_params(robot, p)
    L_ref = reference_lengths(robot)
    return L_ref + (1.0 + q["s"]) * (np.asarray(r, dtype=float) - L_ref) + q["o"]


# --------------------------------------------------------------------------
# Settling
# --------------------------------------------------------------------------
def _square_tensions(arm, theta) -> np.ndarray:
    """Position-cable tensions ``(N, m)`` N of the statics of ``arm`` (``m = n``): the square
    solve of ``M_p T_p = -(tau + M_f T_f)`` (force cables at their tension, the file's
    gravity, no tip wrench, moment arms of the unshifted holes)."""
    pos, frc = _pos(arm), rb.force_cables(arm)
    M = st.moment_matrices(arm, theta)
    tau = st.external_moments(arm, theta)
    rhs = -(tau + M[:, :, frc] @ arm.cable_tension[frc])
    return np.linalg.solve(M[:, :, pos], rhs[..., None])[..., 0]


def plant_tensions(robot, p, theta) -> np.ndarray:
    """Position-cable tensions ``(N, m)`` N of the plant's arm at ``theta (N, n)`` rad
    (:func:`plant_arm`, no clearance shift); the square statics, ``m = n`` only."""
    arm = plant_arm(robot, p)
    if _pos(arm).size != arm.n:
        raise ValueError("plant_tensions: the statics fix the tensions only with as many position cables as joints")
    return _square_tensions(arm, kin.as_theta(arm, theta))


def friction_factors(arm, theta, z, mu: float):
    """The capstan profile of every cable of ``arm`` at ``theta (N, n)`` rad with the
    mobilisations ``z (N, H)`` (every cable's holes, file order, ``2 e_c`` each): the
    factor of each cable's tension in the gap of each joint over its routing
    tension ``(N, n, m_all)`` (1 where the cable does not cross the joint: its
    moment there is 0 anyway) and ``ebar (N, m_all)``, the length-weighted mean
    factor with the routing (``docs/model.md``)."""
    th = kin.as_theta(arm, theta)
    N = th.shape[0]
    gap = np.ones((N, arm.n, arm.m))
    ebar = np.empty((N, arm.m))
    start = 0
    for c, P in enumerate(kin.cable_points(arm, th)):
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


def _friction_holes(robot) -> int:
    """Every cable's turning holes, ``2 e_c`` each (friction's mobilisations)."""
    return int(sum(2 * int(e) for e in robot.cable_end))


def _residual_function(robot, arm, q, L, z=None):
    """``F(theta, idx, taut=None) -> (k, n)`` of the settled state for the rows ``idx`` of ``L (R, m)``.

    * ``m = n``: ``L_arm(theta) - (L + L_r)(1 + kappa T(theta)) + L_r`` (m);
    * ``m > n``, ``kappa = 0``: ``J0^T (L_arm - L) / |J0(0)|_F`` (m; ``J0`` the
      Jacobian of the unshifted lengths, the constant scale that of the straight pose);
    * ``m > n``, ``kappa > 0``: ``J0^T max(0, s) - kappa (tau - J0_f^T T_f)`` (m),
      ``s = (L_arm + L_r)/(L + L_r) - 1``.

    ``F.taut(theta, idx) -> (k, m)`` bool: the cables counted taut at ``theta``
    (``s >= -1e-12``).  Given ``taut``, ``max(0, s)`` is replaced by ``s`` on the
    taut cables and 0 on the others: the smooth piece of ``F`` whose derivative
    the Newton step uses (a semismooth Newton; central differences across the kink
    of ``max`` would blend the two pieces).  Without ``taut`` (the residual), ``F``
    itself.

    ``F.energy(theta, idx) -> (k,)`` (elastic arm with ``m > n`` and ``cl = 0``
    only, else None): the potential whose gradient is ``F``,
    ``sum_i (L_i + L_r)/2 max(0, s_i)^2 + kappa (V(theta) + sum_f T_f L_f(theta))``,
    ``V = -sum_b mass_b g . c_b`` the gravity potential (J), ``L_f`` the force-cable
    lengths (m): the equilibrium is its stationary point, a minimum for a stable arm.
    """
    pos, frc = _pos(arm), rb.force_cables(arm)
    Lr = float(arm.routing_length)
    kappa, cl, w, mu = q["kappa"], q["cl"], q["w"], q["mu"]
    square = pos.size == arm.n
    scale = np.linalg.norm(kin.cable_jacobian(arm, np.zeros((1, arm.n)))[0, pos])
    friction = mu > 0.0 and (square or kappa > 0.0)  # a rigid redundant arm: no stretch to change
    kc = 1.0 / (float(arm.youngs_modulus) * np.pi * float(arm.diameter) ** 2 / 4.0)
    if friction:
        z = np.ones((L.shape[0], _friction_holes(arm))) if z is None else np.asarray(z, float)

    def factors(th, idx):
        """Gap factors (k, n, m_all) and ebar (k, m_all); ones without friction."""
        if not friction:
            return np.ones((th.shape[0], arm.n, arm.m)), np.ones((th.shape[0], arm.m))
        return friction_factors(arm, th, z[idx], mu)

    def strain(th, idx):
        La = _arm_lengths(arm, kin.chain_frames(arm, th), cl, w)
        return (La + Lr) / (L[idx] + Lr) - 1.0

    def F(th, idx, taut=None):
        ch = kin.chain_frames(arm, th)
        La = _arm_lengths(arm, ch, cl, w)
        Li = L[idx]
        if square:
            if kappa == 0.0 and not friction:
                return La - Li
            if not friction:
                T = _square_tensions(arm, th)
                return La - (Li + Lr) * (1.0 + kappa * T) + Lr
            gap, ebar = factors(th, idx)
            M = st.moment_matrices(arm, th) * gap
            rhs = -(st.external_moments(arm, th) + M[:, :, frc] @ arm.cable_tension[frc])
            T = np.linalg.solve(M[:, :, pos], rhs[..., None])[..., 0] * ebar[:, pos]
            T0 = _square_tensions(arm, th)
            return La - Li - (Li + Lr) * (kappa * T + kc * (T - T0))
        J = kin.cable_jacobian(arm, th)  # (k, m_all, n), unshifted holes
        if kappa == 0.0:
            return np.einsum("kij,ki->kj", J[:, pos, :], La - Li) / scale
        gap, ebar = factors(th, idx)
        J = J * np.swapaxes(gap, 1, 2)  # each cable's entry of joint j scaled by its gap's factor
        Jp = J[:, pos, :]
        s = (La + Lr) / (Li + Lr) - 1.0
        pull = np.maximum(0.0, s) if taut is None else np.where(taut, s, 0.0)
        tau = st.external_moments(arm, th)
        force = np.einsum("kij,i->kj", J[:, frc, :], arm.cable_tension[frc])
        return np.einsum("kij,ki->kj", Jp, pull / ebar[:, pos]) - kappa * (tau - force)

    def taut(th, idx):
        if square or kappa == 0.0:
            return None
        return strain(th, idx) >= -1e-12

    def energy(th, idx):
        La = kin.cable_lengths(arm, th)  # unshifted holes: only used with cl = 0
        Li = L[idx]
        s = (La[:, pos] + Lr) / (Li + Lr) - 1.0
        ch = kin.chain_frames(arm, th)
        V = np.zeros(th.shape[0])
        for b in range(1, arm.disks + 1):
            centre = np.einsum("nij,j->ni", ch["Ra"][:, b], arm.com[b - 1]) + ch["ta"][:, b]
            V -= arm.mass[b - 1] * (centre @ arm.gravity)
        work = La[:, frc] @ arm.cable_tension[frc]
        return 0.5 * ((Li + Lr) * np.maximum(0.0, s) ** 2).sum(1) + kappa * (V + work)

    F.taut = taut
    F.energy = energy if (not square and kappa > 0.0 and cl == 0.0 and not friction) else None
    return F


def settling_residual(robot, p, realised, theta, z=None) -> np.ndarray:
    """The equations ``F (R, n)`` (m) of the settled state at ``theta (R, n)`` rad for the
    realised lengths ``realised (R, m)`` m (:func:`_residual_function`; ``z (R, H)`` the
    mobilisations with friction, default +1); zero when settled."""
    arm = plant_arm(robot, p)
    q = plant_params(robot, p)
    L = np.asarray(realised, dtype=float)
    th = kin.as_theta(arm, theta)
    return _residual_function(robot, arm, q, L, z)(th, np.arange(th.shape[0]))


def _damped_newton(F, theta, target, max_iter, h):
    """Batched damped Newton / LM on ``F(theta, idx) = 0`` (``n`` equations, ``n`` unknowns).

    Central-difference Jacobian (step ``h`` rad) of a smooth piece of ``F``
    (``F.taut``, see :func:`_residual_function`): that of the current point, kept
    while a row's trials are rejected, except that a rejected trial where other
    cables are taut brings the piece of the trial's cables (the Newton step of a
    piecewise-smooth system: the step that crosses a kink is retried on the piece
    beyond it).  Step ``-(J^T J + lambda I)^-1 J^T F``; a trial is accepted when it
    lowers ``|F|^2`` (``lambda <- max(lambda/10, 1e-12)``), else ``lambda <- 10
    lambda`` (from 0: ``1e-3``).  A row stops at ``max|F| <= target``, after
    ``max_iter`` trials or at ``lambda > 1e12``.  Returns ``theta``, ``max|F|``.
    """
    N, n = theta.shape
    idx_all = np.arange(N)
    with np.errstate(all="ignore"):
        r = F(theta, idx_all)
    f = (r**2).sum(1)
    lam = np.zeros(N)
    J = np.zeros((N, n, n))
    piece = F.taut(theta, idx_all)  # (N, m) bool or None: the piece of each row's J
    stale = np.ones(N, dtype=bool)
    trials = np.zeros(N, dtype=np.int64)
    active = np.isfinite(f) & ~(np.abs(r).max(1) <= target)
    while active.any():
        idx = np.flatnonzero(active & stale)
        if idx.size:
            taut = None if piece is None else piece[idx]
            for k in range(n):
                e = np.zeros(n)
                e[k] = h
                with np.errstate(all="ignore"):
                    J[idx, :, k] = (F(theta[idx] + e, idx, taut) - F(theta[idx] - e, idx, taut)) / (2.0 * h)
            stale[idx] = False
        idx = np.flatnonzero(active)
        Jt = np.swapaxes(J[idx], 1, 2)
        A = Jt @ J[idx] + lam[idx, None, None] * np.eye(n)
        delta = -sv.solve_rows(A, (Jt @ r[idx, :, None])[..., 0])
        trial = theta[idx] + delta
        with np.errstate(all="ignore"):
            r_trial = F(trial, idx)
        f_trial = (r_trial**2).sum(1)
        trials[idx] += 1
        accept = f_trial < f[idx]
        acc, rej = idx[accept], idx[~accept]
        theta[acc], r[acc], f[acc] = trial[accept], r_trial[accept], f_trial[accept]
        stale[acc] = True
        if piece is not None:
            if acc.size:
                piece[acc] = F.taut(theta[acc], acc)
            if rej.size:
                with np.errstate(all="ignore"):
                    beyond = F.taut(trial[~accept], rej)
                other = np.any(beyond != piece[rej], axis=1)
                piece[rej[other]] = beyond[other]
                stale[rej[other]] = True
        lam[acc] = np.maximum(lam[acc] / 10.0, 1e-12)
        lam[rej] = np.where(lam[rej] == 0.0, 1e-3, 10.0 * lam[rej])
        active[idx] = ~(np.abs(r[idx]).max(1) <= target) & (trials[idx] < max_iter) & (lam[idx] <= 1e12)
    return theta, np.abs(r).max(1)


def _energy_descent(F, theta, switch, max_iter, h):
    """Batched damped Newton *minimisation* of ``F.energy`` (``F`` its gradient), down
    to ``max|F| <= switch``: step ``-(H + lambda mu I)^-1 F`` with ``H`` the symmetric
    part of the central-difference Jacobian of ``F``'s smooth piece (``F.taut``),
    ``mu = tr(H)/n``; a trial is accepted when it lowers the energy (``lambda <-
    lambda/10``, 0 below ``1e-12``), else ``lambda <- 10 lambda`` (from 0: ``1e-3``);
    ``lambda`` also grows while ``H + lambda mu I`` is not positive definite.

    Descent on the energy, unlike least squares on ``F``, cannot stall where a cable
    is at the kink of ``max(0, s)`` (``|F|^2`` has non-zero local minima there).
    Returns ``theta``.
    """
    N, n = theta.shape
    E = F.energy
    with np.errstate(all="ignore"):
        g = F(theta, np.arange(N))
        e = E(theta, np.arange(N))
    lam = np.zeros(N)
    H = np.zeros((N, n, n))
    stale = np.ones(N, dtype=bool)
    trials = np.zeros(N, dtype=np.int64)
    active = np.isfinite(e) & ~(np.abs(g).max(1) <= switch)
    while active.any():
        idx = np.flatnonzero(active & stale)
        if idx.size:
            taut = F.taut(theta[idx], idx)
            for k in range(n):
                d = np.zeros(n)
                d[k] = h
                with np.errstate(all="ignore"):
                    H[idx, :, k] = (F(theta[idx] + d, idx, taut) - F(theta[idx] - d, idx, taut)) / (2.0 * h)
            H[idx] = 0.5 * (H[idx] + np.swapaxes(H[idx], 1, 2))
            stale[idx] = False
        idx = np.flatnonzero(active)
        mu = np.abs(np.trace(H[idx], axis1=1, axis2=2)) / n
        A = H[idx] + (lam[idx] * mu)[:, None, None] * np.eye(n)
        with np.errstate(all="ignore"):
            pd = np.linalg.eigvalsh(A).min(1) > 0.0
            delta = -sv.solve_rows(A, g[idx])
            trial = theta[idx] + delta
            e_trial = E(trial, idx)
        trials[idx] += 1
        accept = pd & (e_trial < e[idx])
        acc, rej = idx[accept], idx[~accept]
        theta[acc], e[acc] = trial[accept], e_trial[accept]
        with np.errstate(all="ignore"):
            g[acc] = F(theta[acc], acc)
        stale[acc] = True
        lam[acc] = np.where(lam[acc] / 10.0 < 1e-12, 0.0, lam[acc] / 10.0)
        lam[rej] = np.where(lam[rej] == 0.0, 1e-3, 10.0 * lam[rej])
        active[idx] = ~(np.abs(g[idx]).max(1) <= switch) & (trials[idx] < max_iter) & (lam[idx] <= 1e12)
    return theta


def settle(robot, p, realised, theta_seed, tol=1e-12, target=1e-15, max_iter=200, fd_step=1e-6, z=None):
    """Joint angles at which the plant's arm settles, per command.

    ``realised``: ``L (R, m)`` m; ``theta_seed (R, n)`` rad (the row's ``theta_cmd``).
    First the rigid cable solve of the plant's arm (:func:`.solve.solve_cables`,
    no clearance; least squares when ``m > n``) from the seed; for an elastic arm with
    ``m > n`` a descent on its energy without clearance (:func:`_energy_descent`);
    then damped Newton
    (:func:`_damped_newton`) on the settled-state equations
    (:func:`settling_residual`: elasticity, clearance, the redundant arm's least
    squares or elastic equilibrium) from the rigid answer (from the seed where the
    rigid solve failed), iterated down to ``max|F| <= target`` m where round-off
    allows.  A command has settled when ``max|F| <= tol`` m.  ``z (R, H)``: every
    hole's mobilisation (friction).

    Returns ``theta (R, n)`` rad and ``converged (R,)`` bool.
    """
    arm = plant_arm(robot, p)
    q = plant_params(robot, p)
    L = np.asarray(realised, dtype=float)
    seed = np.array(theta_seed, dtype=float).reshape(L.shape[0], arm.n)
    rigid = sv.solve_cables(arm, L, seed=seed)
    theta = np.where(np.isfinite(rigid["theta"]).all(1, keepdims=True), rigid["theta"], seed)
    F = _residual_function(robot, arm, q, L, z)
    if arm.n < _pos(arm).size and q["kappa"] > 0.0:
        # the redundant elastic arm: minimise its energy (without clearance and
        # friction, which has none) first
        F0 = _residual_function(robot, arm, dict(q, cl=0.0, mu=0.0), L)
        theta = _energy_descent(F0, theta, 1e-13, max_iter, fd_step)
    theta, res = _damped_newton(F, theta, target, max_iter, fd_step)
    return theta, res <= tol


# --------------------------------------------------------------------------
# Observation and the whole pipeline
# --------------------------------------------------------------------------
def observe(robot, p, theta) -> np.ndarray:
    """What the instrument sees at the settled ``theta (N, n)`` rad: ``(N, 6)``.

    ``q = Rot(rho) (p_end + R_end tip) + t`` (m) and the attitude
    ``log(Rot(rho) R_end)`` (rotation vector, rad), ``(p_end, R_end)`` the end
    frame ``F_Kb`` of the plant's arm.
    """
    arm = plant_arm(robot, p)
    q = plant_params(robot, p)
    ch = kin.chain_frames(arm, kin.as_theta(arm, theta))
    p_end, R_end = ch["tb"][:, -1], ch["Rb"][:, -1]
    E = rot.exp_so3(q["rho"])
    point = p_end + R_end @ q["tip"]
    seen = point @ E.T + q["t"]
    return np.concatenate([seen, rot.log_so3(E @ R_end)], axis=1)


def friction_motion(robot, commands, seeds, first) -> tuple:
    """What the friction scan needs of the nominal motion (``docs/model.md``, "Sliding
    directions and the sticking band"): the nominal configuration of each command
    ``commands (R, m)`` m -- ``seeds (R, n)`` rad itself for a displacement row's first
    command (``first (R,)``), else the rigid cable solve of the nominal robot from the
    seed (the seed where it fails) -- and there, per hole of every cable (file order,
    ``2 e_c`` each): ``d (R, H)`` m the distal lengths, ``beta (R, H)`` rad the wrap
    angles, ``tension (R, H)`` N the cable's frictionless tension ``T_hat`` (force
    cables their set tension; position cables the square balance's, or with more
    position cables than joints the minimum-norm set at or above 0; 0 where negative
    or undefined); and ``d0 (H,)`` the straight pose's distal lengths."""
    seeds = np.asarray(seeds, dtype=float).reshape(-1, robot.n)
    sol = sv.solve_cables(robot, np.asarray(commands, dtype=float), seed=seeds)
    good = np.isfinite(sol["theta"]).all(1) & np.asarray(sol["converged"], bool) & ~np.asarray(first, bool)
    theta = np.where(good[:, None], sol["theta"], seeds)
    pos, frc = _pos(robot), rb.force_cables(robot)

    def holes(th):
        if pos.size == robot.n:
            Tp = _square_tensions(robot, th)
        else:
            M = st.moment_matrices(robot, th)
            b = -(st.external_moments(robot, th) + M[:, :, frc] @ robot.cable_tension[frc])
            Tp, _ = st.min_norm_tensions(M[:, :, pos], b, 0.0)
        T = np.tile(np.asarray(robot.cable_tension, float), (th.shape[0], 1))
        T[:, pos] = np.where(np.isfinite(Tp) & (Tp > 0.0), Tp, 0.0)
        d, beta, ten = [], [], []
        for c, P in enumerate(kin.cable_points(robot, th)):
            g, _ = fr.segments(P)
            d.append(fr.distal_lengths(g))
            beta.append(fr.wrap_angles(P))
            ten.append(np.repeat(T[:, c:c + 1], g.shape[1], axis=1))
        return np.concatenate(d, 1), np.concatenate(beta, 1), np.concatenate(ten, 1)

    d, beta, ten = holes(theta)
    d0, _, _ = holes(np.zeros((1, robot.n)))
    return d, beta, ten, d0[0]


def mobilisation(robot, p, commands, seeds, first) -> np.ndarray:
    """``z (R, H)``: every hole's mobilisation after each command (:func:`friction_motion`,
    :func:`.friction.mobilisation_scan`, bands ``(kappa + kappa_c) T_hat d sinh(mu beta)`` of
    ``p``, ``kappa_c = 1 / (E A)`` of the robot file's cable)."""
    q = plant_params(robot, p)
    d, beta, ten, d0 = friction_motion(robot, commands, seeds, first)
    kf = q["kappa"] + 1.0 / (float(robot.youngs_modulus) * np.pi * float(robot.diameter) ** 2 / 4.0)
    return fr.mobilisation_scan(d, fr.band(kf, q["mu"], ten, d, beta), d0)


def predict(robot, p, theta_cmd, dL, kind, tol=1e-12):
    """Observations of a data set under the plant ``p`` (``(size(robot),)``, SI).

    ``theta_cmd (N, n)`` rad, ``dL (N, m)`` m (on the position cables), ``kind``:
    ``N`` names ``"absolute" | "displacement" | "unmeasured"``, rows in execution
    order.  All commands form one sequence (:func:`plant_commands`); backlash runs
    over the whole of it from the straight pose; each command settles from its
    row's ``theta_cmd``.  Returns ``(obs (N, 6), converged (N,))``: ``obs`` is
    ``[x, y, z, rx, ry, rz]`` (m, rad; absolute), the difference second minus first
    (displacement), NaN (unmeasured, and rows that did not settle); ``converged``
    is True when every command of the row settled.
    """
    commands, rows, seeds = plant_commands(robot, theta_cmd, dL, kind)
    r = backlash_scan(robot, p, commands)
    L = realised_lengths(robot, p, r)
    first = sq.first_of_pairs(rows)
    z = mobilisation(robot, p, commands, seeds, first) if plant_params(robot, p)["mu"] > 0.0 else None
    theta, ok = settle(robot, p, L, seeds, tol=tol, z=z)
    return sq.observations(observe(robot, p, theta), rows, ok, kind)
