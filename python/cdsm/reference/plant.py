"""The plant: the real arm as the nominal model plus unmodelled effects, one for
both kinds of arm (``docs/model.md``, "The plant: nominal model plus unmodelled
effects"; ``docs/spatial.md``, "The plant").

Independent NumPy reference, written from the documents alone on top of the
reference's kinematics and statics.  **All-zero parameters give the nominal model
exactly.**  Units: SI everywhere -- m, rad, N, compliance 1/N; orientations as
rotation vectors (rad, principal logarithm).

Pipeline for one data set (:func:`plant_predict`), rows in execution order::

    theta_cmd, dL, kind  --commands-->  c^1, c^2, ...        (m_pos lengths each)
    c  --backlash_scan-->  r  --realised_lengths-->  L
    L  --settle (rigid solve, then elasticity / clearance / friction)-->  theta
    theta  --observe-->  seen (the kind's task vector)

Notation: ``n`` joints, ``K`` disks, ``m_pos`` position-controlled cables (the
commanded ones, file order, :func:`.robot.position_cables`; planar: the upper
cables), ``H`` the holes of those cables (``2 e_c + 1`` each).

The parameter layout of each kind is the table of ``docs/model.md``
(:attr:`.robot.Kind.layout`, :func:`plant_blocks`); every effect is a move of the arm's
numbers (:func:`plant_params`, :func:`plant_arm`) or of the pipeline's
(actuation, backlash, elasticity, clearance, friction, observation), written
once.  The planar ``hole_height`` is one grouping of hole coordinates (every hole
of the cables ending at a disk along its ``y``: :func:`.robot.hole_height_error`),
the spatial ``hole_position`` every coordinate of the position cables' holes.

Readings where the docs leave a choice (each checked against the core by the
parity tests):

* ``hole_position``: cable by cable (position cables in file order), each
  cable's holes in file order, ``[dx, dy, dz]`` per hole.
* ``joint_axis``: "within about 25 deg of x" is ``|a . e_x| >= 0.9`` (25.8 deg;
  :data:`AXIS_NEAR_X`), either direction of x.
* ``m = n`` statics: the square solve of the moment balance, no floor (a
  negative tension is kept).
* ``m > n``: ``dL_i/dtheta_j`` of the equilibrium (rigid and elastic) is that
  of the unshifted holes ``J0`` also in the elastic case.
* The settled configuration is found by this module's own solver (rigid cable
  solve, an energy descent for the elastic ``m > n`` arm, then a semismooth
  damped Newton), not by imitating the core's path; where the core fails to
  settle a command whose equilibrium exists, the two differ in ``converged``.
* The parameters' physical domain (``docs/model.md``) is checked: a vector
  outside it raises ``ValueError`` (the core predicts no row there).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from . import friction as fr
from . import sequence as sq
from .kinematics import (
    as_theta,
    cross,
    cable_jacobian,
    cable_lengths,
    cable_points,
    chain_frames,
    position_lengths,
    task_vector,
)
from .robot import Robot, as_robot, force_cables, hole_height_moves, position_cables
from .rotations import exp_so3
from .solve import solve_cables, solve_rows
from .statics import external_moments, min_norm_tensions, moment_matrices, tensions

__all__ = [
    "CLEARANCE_WIDTH_0",
    "AXIS_NEAR_X",
    "plant_blocks",
    "plant_layout",
    "plant_size",
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
    "fed_forward_compliance",
    "redundant_compliance",
    "friction_factors",
    "settling_equations",
    "settling_residual",
    "settle",
    "observe",
    "friction_motion",
    "mobilisation",
    "plant_predict",
]

#: Base transition width of the hole clearance, rad (``w = 0.01 + dw``).
CLEARANCE_WIDTH_0 = 0.01

#: ``|a . e_x|`` at and above which a joint axis ``a`` counts as "within about 25 deg
#: of x" and its tilt basis starts from ``y`` instead (``docs/model.md``: 0.9, 25.8 deg).
AXIS_NEAR_X = 0.9

_KINDS = ("absolute", "displacement", "unmeasured")


# --------------------------------------------------------------------------
# Parameter layout and the moves of the arm's numbers
# --------------------------------------------------------------------------
def _hole_heights(robot: Robot, x: np.ndarray, q: dict) -> None:
    q["dholes"] = list(hole_height_moves(robot, x))


def _hole_points(robot: Robot, x: np.ndarray, q: dict) -> None:
    moves, start = x.reshape(-1, 3), 0
    for c in position_cables(robot):
        count = robot.holes[c].shape[0]
        q["dholes"][c] = moves[start:start + count].copy()
        start += count


def _links_along_x(robot: Robot, x: np.ndarray, q: dict) -> None:
    q["doffset"][0, 0] = x[0]
    q["dlink_after"][:, 0] = x[1:]
    links = np.concatenate([robot.offsets[:1, 0], robot.link_after[:, 0]])
    if not np.all(links + x > 0.1 * links):
        raise ValueError(f"link_length: the links must stay above a tenth of nominal, got {links + x} m "
                         f"for {links} m")


def _offsets_and_links(robot: Robot, x: np.ndarray, q: dict) -> None:
    moves = x.reshape(robot.n + robot.disks, 3)
    q["doffset"], q["dlink_after"] = moves[:robot.n].copy(), moves[robot.n:].copy()


def _turn_and_origin(robot: Robot, x: np.ndarray, q: dict) -> None:
    q["rho"], q["t"] = np.array([0.0, 0.0, x[0]]), np.array([x[1], x[2], 0.0])


def _rotation_and_origin(robot: Robot, x: np.ndarray, q: dict) -> None:
    q["rho"], q["t"] = x[:3].copy(), x[3:].copy()


def _point_in_plane(robot: Robot, x: np.ndarray, q: dict) -> None:
    q["tip"][:2] = x


def _point_in_space(robot: Robot, x: np.ndarray, q: dict) -> None:
    q["tip"] = x.copy()


def _joint_tilts(robot: Robot, x: np.ndarray, q: dict) -> None:
    q["tilt"] = x.reshape(robot.n, 2).copy()


#: The size rules of the kinds' layouts (:attr:`.robot.Kind.layout`): the size of a block
#: from the arm's numbers, and the move of the plant's numbers its values make (None: the
#: values are read as they are, :func:`plant_params`).
_RULES = {
    "one": (lambda r: 1, None),
    "position cables": (lambda r: position_cables(r).size, None),
    "disk hole heights": (lambda r: r.disks, _hole_heights),
    "position cables' hole points": (lambda r: 3 * sum(r.holes[c].shape[0] for c in position_cables(r)),
                                     _hole_points),
    "first offset and links along x": (lambda r: 1 + r.disks, _links_along_x),
    "offsets and links": (lambda r: 3 * (r.n + r.disks), _offsets_and_links),
    "turn about z and origin in the plane": (lambda r: 3, _turn_and_origin),
    "rotation vector and origin": (lambda r: 6, _rotation_and_origin),
    "point in the plane": (lambda r: 2, _point_in_plane),
    "point in space": (lambda r: 3, _point_in_space),
    "joint tilts": (lambda r: 2 * r.n, _joint_tilts),
}


def plant_blocks(robot) -> list:
    """``[(block, size), ...]`` of the flat parameter vector of ``robot``'s kind
    (:attr:`.robot.Kind.layout`, the table of ``docs/model.md``)."""
    robot = as_robot(robot)
    return [(name, _RULES[rule][0](robot)) for name, rule in robot.kind.layout]


def plant_layout(robot) -> dict:
    """``{block: slice}`` into the flat parameter vector, in the layout's order."""
    out, start = {}, 0
    for name, k in plant_blocks(robot):
        out[name] = slice(start, start + k)
        start += k
    return out


def plant_size(robot) -> int:
    """Length of the flat parameter vector (planar ``4n + 11``, spatial
    ``2 m_pos + 3H + 3(n + K) + 2n + 14``)."""
    return sum(k for _, k in plant_blocks(robot))


def plant_params(robot, p) -> dict:
    """Split and check the flat vector ``p (plant_size(robot),)`` (SI) into the
    plant's numbers, each block as a move of the arm's or the pipeline's numbers.

    Keys: ``s`` (float), ``o (m_pos,)`` m, ``b (m_pos,)`` m, ``kappa`` 1/N, ``cl`` m,
    ``w`` rad (``0.01 + dw``), ``mu`` (1); ``dholes`` (one ``(2 e_c + 1, 3)`` m move per
    cable: planar ``hole_height`` along ``y``, position ``+dh``, force ``-dh``, of the
    cables ending at each disk; spatial ``hole_position`` of the position cables'),
    ``doffset (n, 3)`` and ``dlink_after (K, 3)`` m (planar ``link_length``: ``dl_0``
    on the first offset's ``x``, ``dl_i`` on disk ``i``'s ``link_after``), ``tilt (n,
    2)`` rad (0 for planar arms), the instrument frame ``rho (3,)`` rad and ``t (3,)``
    m (planar ``alpha`` about ``z``, ``fx, fy``) and the ``tip (3,)`` m.

    ``ValueError`` on a wrong size or outside the physical domain of
    ``docs/model.md``: ``kappa < 0``, ``cl < 0`` (its upper bound, "the least hole
    radius", is not checked), some ``b < 0``, ``w`` outside ``[1e-4, 1]``, ``mu``
    outside ``[0, 1]``, ``1 + s <= 0.1``, a planar link at or below a tenth of nominal.
    """
    robot = as_robot(robot)
    p = np.asarray(p, dtype=float).reshape(-1)
    if p.size != plant_size(robot):
        raise ValueError(f"plant parameters must have {plant_size(robot)} entries for this robot, got {p.size}")
    v = {name: p[sl] for name, sl in plant_layout(robot).items()}
    q = dict(s=float(v["actuation_scale"][0]), o=v["cable_offset"].copy(), b=v["backlash"].copy(),
             kappa=float(v["cable_elasticity"][0]), cl=float(v["hole_clearance"][0]),
             w=CLEARANCE_WIDTH_0 + float(v["clearance_width"][0]), mu=float(v["cable_friction"][0]),
             dholes=[np.zeros_like(h) for h in robot.holes], doffset=np.zeros((robot.n, 3)),
             dlink_after=np.zeros((robot.disks, 3)), tilt=np.zeros((robot.n, 2)), rho=np.zeros(3), t=np.zeros(3),
             tip=np.zeros(3))
    for name, rule in robot.kind.layout:
        move = _RULES[rule][1]
        if move is not None:
            move(robot, v[name], q)
    if not q["kappa"] >= 0.0:
        raise ValueError(f"cable_elasticity kappa must be >= 0, got {q['kappa']}")
    if not q["cl"] >= 0.0:
        raise ValueError(f"hole_clearance cl must be >= 0, got {q['cl']}")
    if not np.all(q["b"] >= 0.0):
        raise ValueError(f"backlash half-widths must be >= 0, got {q['b']}")
    if not 1e-4 <= q["w"] <= 1.0:
        raise ValueError(f"clearance width w = 0.01 + dw must be within [1e-4, 1] rad, got {q['w']}")
    if not 0.0 <= q["mu"] <= 1.0:
        raise ValueError(f"cable_friction mu must be within [0, 1], got {q['mu']}")
    if not 1.0 + q["s"] > 0.1:
        raise ValueError(f"actuator gain 1 + s must be above 0.1, got {1.0 + q['s']}")
    return q


def axis_basis(axis) -> tuple:
    """The tilt basis ``(e1, e2)`` (each ``(3,)``) of a unit joint axis ``a (3,)``.

    ``e1``: ``e_x`` made perpendicular to ``a`` and normalised (``e_y`` instead
    when ``|a . e_x| >= AXIS_NEAR_X``, ``a`` within about 25 deg of ``x``);
    ``e2 = a x e1``.
    """
    a = np.asarray(axis, dtype=float)
    ref = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < AXIS_NEAR_X else np.array([0.0, 1.0, 0.0])
    e1 = ref - (ref @ a) * a
    e1 /= np.linalg.norm(e1)
    return e1, cross(a, e1)


def tilted_axes(axes, tilt) -> np.ndarray:
    """Joint axes ``(n, 3)`` tilted by ``tilt (n, 2)`` rad: ``(a + d1 e1 + d2 e2) / |...|``."""
    axes = np.asarray(axes, dtype=float)
    out = np.empty_like(axes)
    for j, a in enumerate(axes):
        e1, e2 = axis_basis(a)
        v = a + tilt[j, 0] * e1 + tilt[j, 1] * e2
        out[j] = v / np.linalg.norm(v)
    return out


def plant_arm(robot, p) -> Robot:
    """The plant's arm: ``robot`` with its numbers moved by the parameters (``docs/model.md``,
    "The arm"): every hole by its ``dholes`` move (in its face frame), every joint offset
    and disk ``link_after`` by its move and, where the kind has ``joint_axis``, every
    joint axis tilted.  Masses, centres of mass, thicknesses, force tensions, gravity and
    the cable material are unchanged.  Returns a new :class:`.robot.Robot`.
    """
    robot = as_robot(robot)
    q = plant_params(robot, p)
    moved = dataclasses.replace(
        robot,
        holes=tuple(h + d for h, d in zip(robot.holes, q["dholes"])),
        offsets=robot.offsets + q["doffset"],
        link_after=robot.link_after + q["dlink_after"],
    )
    if "joint_axis" in plant_layout(robot):
        moved = dataclasses.replace(moved, axes=tilted_axes(robot.axes, q["tilt"]))
    return moved


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
    ``sb, sa (N, K+1, 3)`` m (index 0 unused, zero).  For a bend about ``z`` by ``theta``
    both are ``(0, cl tanh(theta / w), 0)``: the planar shifts."""
    robot = as_robot(robot)
    arm = plant_arm(robot, p)
    q = plant_params(robot, p)
    return _bend(chain_frames(arm, as_theta(arm, theta)), arm.disks, q["cl"], q["w"])


def _arm_lengths(arm, ch: dict, cl: float, w: float) -> np.ndarray:
    """Position-cable lengths ``(N, m)`` m of ``arm`` (already moved) with hole clearance."""
    sb, sa = _bend(ch, arm.disks, cl, w)
    pos = position_cables(arm)
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
    robot = as_robot(robot)
    arm = plant_arm(robot, p)
    q = plant_params(robot, p)
    return _arm_lengths(arm, chain_frames(arm, as_theta(arm, theta)), q["cl"], q["w"])


# --------------------------------------------------------------------------
# Commands, backlash, actuation
# --------------------------------------------------------------------------
def reference_lengths(robot) -> np.ndarray:
    """``L_ref (m_pos,)`` m: straight-pose position-cable lengths of the *nominal* robot."""
    robot = as_robot(robot)
    return position_lengths(robot, np.zeros((1, robot.n)))[0]


def plant_commands(robot, theta_cmd, dL, kind) -> tuple:
    """The command sequence of a data set (rows in execution order).

    ``theta_cmd (N, n)`` rad, ``dL (N, m)`` m, ``kind`` ``N`` names.  ``C =
    L_pos,nom(theta_cmd)``; absolute and unmeasured rows give one command
    ``C + dL``, displacement rows two, ``C`` then ``C + dL``.  Returns
    ``commands (R, m)`` m, ``rows (R,)`` (the data row of each command) and
    ``seeds (R, n)`` rad (that row's ``theta_cmd``).
    """
    robot = as_robot(robot)
    pos = position_cables(robot)
    theta_cmd = np.asarray(theta_cmd, dtype=float).reshape(-1, robot.n)
    N = theta_cmd.shape[0]
    dL = np.asarray(dL, dtype=float).reshape(N, pos.size)
    kind = list(kind)
    if len(kind) != N:
        raise ValueError(f"kind must have {N} entries, got {len(kind)}")
    bad = [k for k in kind if k not in _KINDS]
    if bad:
        raise ValueError(f"kind must be one of {_KINDS}, got {bad[0]!r}")
    commands, rows = sq.commands(position_lengths(robot, theta_cmd).reshape(N, pos.size), dL, kind)
    return commands, rows, theta_cmd[rows]


def backlash_scan(robot, p, commands, start=None) -> np.ndarray:
    """Lost motion per position cable over a command sequence ``commands (R, m_pos)`` m.

    The state ``r`` starts at ``start`` (default ``L_ref``, the straight pose); per
    command ``c``: ``c - r > b`` -> ``r = c - b``; ``c - r < -b`` -> ``r = c + b``;
    otherwise unchanged.  Returns the delivered lengths ``r (R, m_pos)`` m (``b = 0``:
    ``r = c``).
    """
    b = plant_params(robot, p)["b"]
    commands = np.asarray(commands, dtype=float)
    r = reference_lengths(robot).copy() if start is None else np.array(start, dtype=float).reshape(b.shape)
    out = np.empty_like(commands)
    for j, c in enumerate(commands):
        r = np.where(c - r > b, c - b, np.where(c - r < -b, c + b, r))
        out[j] = r
    return out


def realised_lengths(robot, p, r) -> np.ndarray:
    """Realised rest lengths ``L = L_ref + (1 + s)(r - L_ref) + o``, ``(R, m_pos)`` m, of the
    delivered lengths ``r (R, m_pos)`` m (:func:`backlash_scan`)."""
    q = plant_params(robot, p)
    L_ref = reference_lengths(robot)
    return L_ref + (1.0 + q["s"]) * (np.asarray(r, dtype=float) - L_ref) + q["o"]


# --------------------------------------------------------------------------
# Settling
# --------------------------------------------------------------------------
def plant_tensions(robot, p, theta) -> np.ndarray:
    """Position-cable tensions ``(N, m)`` N of the plant's arm at ``theta (N, n)`` rad
    (:func:`plant_arm`, no clearance shift): the square statics of :func:`.statics.tensions`
    (force cables at their tension, the robot's gravity, no tip wrench), ``m_pos = n`` only."""
    return tensions(plant_arm(robot, p), theta)


def fed_forward_compliance(robot) -> float:
    """``kappa_ff`` (1/N): the compliance whose frictionless stretch the controller feeds
    forward (``docs/model.md``, "Commands and their order"): ``1 / (E A)``, ``A = pi d^2 /
    4``, of the robot file's cable when the file says ``stretch_feed_forward`` (the
    default) and the arm has as many position cables as joints, else 0.  The cable's one
    compliance is ``kappa + kappa_ff``."""
    robot = as_robot(robot)
    if not robot.stretch_feed_forward or position_cables(robot).size != robot.n:
        return 0.0
    return 1.0 / (float(robot.youngs_modulus) * np.pi * float(robot.diameter) ** 2 / 4.0)


def redundant_compliance(robot) -> float:
    """The compliance (1/N) a settle adds to the plant's ``kappa``: ``1 / (E A)``, ``A = pi
    d^2 / 4``, of the robot file's cable when the arm is rigid with more position cables
    than joints and its file states the cable (``docs/model.md``, "Settling": nothing is fed
    forward there, so the arm settles on the file's cables stretched under their tensions,
    at ``k = kappa + 1/(E A)``), else 0 (the default cable is a placeholder: the arm
    settles in least squares on the lengths)."""
    robot = as_robot(robot)
    elastic = (np.any(robot.joint_stiffness != 0.0) or np.any(robot.rest_angle != 0.0)
               or "displacement" in robot.cable_mode)
    if position_cables(robot).size <= robot.n or elastic or not robot.cable_stated:
        return 0.0
    return 1.0 / (float(robot.youngs_modulus) * np.pi * float(robot.diameter) ** 2 / 4.0)


def _settle_numbers(robot, p) -> dict:
    """:func:`plant_params` with ``kappa`` the compliance the settle stretches the cables at
    (:func:`redundant_compliance` added)."""
    q = plant_params(robot, p)
    return dict(q, kappa=q["kappa"] + redundant_compliance(robot))


def friction_factors(arm, theta, z, mu: float):
    """The capstan profile of every cable of ``arm`` at ``theta (N, n)`` rad with the
    mobilisations ``z (N, H)`` (every cable's holes, file order, ``2 e_c`` each): the
    factor of each cable's tension in the gap of each joint over its routing
    tension ``(N, n, m_all)`` (1 where the cable does not cross the joint: its
    moment there is 0 anyway) and ``ebar (N, m_all)``, the length-weighted mean
    factor with the routing (``docs/model.md``)."""
    arm = as_robot(arm)
    th = as_theta(arm, theta)
    N = th.shape[0]
    gap = np.ones((N, arm.n, arm.m))
    ebar = np.empty((N, arm.m))
    start = 0
    for c, P in enumerate(cable_points(arm, th)):
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


def settling_equations(robot, arm, q, L, z=None):
    """``F(theta, idx, taut=None) -> (k, n)`` of the settled state for the rows ``idx`` of the
    realised lengths ``L (R, m)`` m on the plant's arm ``arm`` (:func:`plant_arm` of ``robot``)
    with the numbers ``q`` (:func:`plant_params`) and the mobilisations ``z (R, H)``
    (friction; default every hole at +1).  With friction (``docs/model.md``, "Stretch")
    the tensions take the capstan gap factors and the cable stretches at its one
    compliance ``kappa + kappa_ff`` under them, less the frictionless stretch
    ``kappa_ff T*`` fed forward (:func:`fed_forward_compliance`).

    * ``m = n``: ``L_arm(theta) - (L + L_r)(1 + kappa T(theta)) + L_r`` (m);
    * ``m > n``, ``kappa = 0``: ``J0^T (L_arm - L) / |J0(0)|_F`` (m; ``J0`` the
      Jacobian of the unshifted lengths, the constant scale that of the straight pose);
    * ``m > n``, ``kappa > 0``: ``J0^T max(0, s + kappa P) - kappa (tau - J0_f^T T_f)`` (m),
      ``s = (L_arm + L_r)/(L + L_r) - 1``, ``P`` the position cables' pretension (N:
      the tension ``P + s / kappa``, "Settling").

    ``F.taut(theta, idx) -> (k, m)`` bool: the cables counted taut at ``theta``
    (``s >= -1e-12``).  Given ``taut``, ``max(0, s)`` is replaced by ``s`` on the
    taut cables and 0 on the others: the smooth piece of ``F`` whose derivative
    the Newton step uses (a semismooth Newton; central differences across the kink
    of ``max`` would blend the two pieces).  Without ``taut`` (the residual), ``F``
    itself.

    ``F.energy(theta, idx) -> (k,)`` (elastic arm with ``m > n`` and ``cl = 0``
    only, else None): the potential whose gradient is ``F``,
    ``sum_i (L_i + L_r)/2 max(0, s_i + kappa P_i)^2 + kappa (V(theta) + sum_f T_f L_f(theta))``,
    ``V = -sum_b mass_b g . c_b`` the gravity potential (J), ``L_f`` the force-cable
    lengths (m): the equilibrium is its stationary point, a minimum for a stable arm.
    """
    pos, frc = position_cables(arm), force_cables(arm)
    Lr = float(arm.routing_length)
    kappa, cl, w, mu = q["kappa"], q["cl"], q["w"], q["mu"]
    square = pos.size == arm.n
    scale = np.linalg.norm(cable_jacobian(arm, np.zeros((1, arm.n)))[0, pos])
    friction = mu > 0.0 and (square or kappa > 0.0)  # a rigid redundant arm: no stretch to change
    kff = fed_forward_compliance(arm)
    pre = kappa * np.asarray(arm.pretension, dtype=float)[pos]  # the strain P kappa of the pretension
    if friction:
        z = np.ones((L.shape[0], _friction_holes(arm))) if z is None else np.asarray(z, float)

    def factors(th, idx):
        """Gap factors (k, n, m_all) and ebar (k, m_all); ones without friction."""
        if not friction:
            return np.ones((th.shape[0], arm.n, arm.m)), np.ones((th.shape[0], arm.m))
        return friction_factors(arm, th, z[idx], mu)

    def strain(th, idx):
        La = _arm_lengths(arm, chain_frames(arm, th), cl, w)
        return (La + Lr) / (L[idx] + Lr) - 1.0 + pre

    def F(th, idx, taut=None):
        ch = chain_frames(arm, th)
        La = _arm_lengths(arm, ch, cl, w)
        Li = L[idx]
        if square:
            if kappa == 0.0 and not friction:
                return La - Li
            if not friction:
                T = tensions(arm, th, frames=ch)
                return La - (Li + Lr) * (1.0 + kappa * T) + Lr
            gap, ebar = factors(th, idx)
            T = tensions(arm, th, gap=gap, frames=ch) * ebar[:, pos]
            if kff == 0.0:
                return La - Li - (Li + Lr) * kappa * T
            T0 = tensions(arm, th, frames=ch)
            return La - Li - (Li + Lr) * ((kappa + kff) * T - kff * T0)
        J = cable_jacobian(arm, th)  # (k, m_all, n), unshifted holes
        if kappa == 0.0:
            return np.einsum("kij,ki->kj", J[:, pos, :], La - Li) / scale
        gap, ebar = factors(th, idx)
        J = J * np.swapaxes(gap, 1, 2)  # each cable's entry of joint j scaled by its gap's factor
        Jp = J[:, pos, :]
        s = (La + Lr) / (Li + Lr) - 1.0 + pre
        pull = np.maximum(0.0, s) if taut is None else np.where(taut, s, 0.0)
        tau = external_moments(arm, th, frames=ch)
        force = np.einsum("kij,i->kj", J[:, frc, :], arm.cable_tension[frc])
        return np.einsum("kij,ki->kj", Jp, pull / ebar[:, pos]) - kappa * (tau - force)

    def taut(th, idx):
        if square or kappa == 0.0:
            return None
        return strain(th, idx) >= -1e-12

    def energy(th, idx):
        La = cable_lengths(arm, th)  # unshifted holes: only used with cl = 0
        Li = L[idx]
        s = (La[:, pos] + Lr) / (Li + Lr) - 1.0 + pre
        ch = chain_frames(arm, th)
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
    realised lengths ``realised (R, m)`` m (:func:`settling_equations`; ``z (R, H)`` the
    mobilisations with friction, default +1); zero when settled."""
    robot = as_robot(robot)
    arm = plant_arm(robot, p)
    q = _settle_numbers(robot, p)
    L = np.asarray(realised, dtype=float)
    th = as_theta(arm, theta)
    return settling_equations(robot, arm, q, L, z)(th, np.arange(th.shape[0]))


def _damped_newton(F, theta, tol, max_iter, h):
    """Batched damped Newton / LM on ``F(theta, idx) = 0`` (``n`` equations, ``n`` unknowns).

    Central-difference Jacobian (step ``h`` rad) of a smooth piece of ``F``
    (``F.taut``, see :func:`settling_equations`): that of the current point, kept
    while a row's trials are rejected, except that a rejected trial where other
    cables are taut brings the piece of the trial's cables (the Newton step of a
    piecewise-smooth system: the step that crosses a kink is retried on the piece
    beyond it).  Step ``-(J^T J + lambda I)^-1 J^T F``; a trial is accepted when it
    lowers ``|F|^2`` (``lambda <- max(lambda/10, 1e-12)``), else ``lambda <- 10
    lambda`` (from 0: ``1e-3``).  A row stops at its first rejected trial once ``max|F| <=
    tol`` (it has settled, and the step no longer gains: round-off), after
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
    active = np.isfinite(f)
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
        delta = -solve_rows(A, (Jt @ r[idx, :, None])[..., 0])
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
        settled = np.abs(r[idx]).max(1) <= tol
        active[idx] = ~(settled & ~accept) & (r[idx] != 0.0).any(1) & (trials[idx] < max_iter) & (lam[idx] <= 1e12)
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
            delta = -solve_rows(A, g[idx])
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


def settle(robot, p, realised, theta_seed, tol=1e-12, max_iter=200, fd_step=1e-6, z=None):
    """Joint angles at which the plant's arm settles, per command.

    ``realised``: ``L (R, m)`` m; ``theta_seed (R, n)`` rad (the row's ``theta_cmd``).
    First the rigid cable solve of the plant's arm (:func:`.solve.solve_cables`,
    no clearance; least squares when ``m > n``) from the seed; for an elastic arm with
    ``m > n`` (``kappa > 0``, or the file's cable stated: stretched at ``kappa + 1/(E A)``,
    :func:`redundant_compliance`) a descent on its energy without clearance
    (:func:`_energy_descent`);
    then damped Newton
    (:func:`_damped_newton`) on the settled-state equations
    (:func:`settling_residual`: elasticity, clearance, the redundant arm's least
    squares or elastic equilibrium) from the rigid answer (from the seed where the
    rigid solve failed), iterated down to round-off (a row within ``max|F| <= tol`` m
    stops at its first trial that does not lower ``|F|^2``).  A command has settled when
    ``max|F| <= tol`` m.  ``z (R, H)``: every
    hole's mobilisation (friction).

    Returns ``theta (R, n)`` rad and ``converged (R,)`` bool.
    """
    robot = as_robot(robot)
    arm = plant_arm(robot, p)
    q = _settle_numbers(robot, p)
    L = np.asarray(realised, dtype=float)
    seed = np.array(theta_seed, dtype=float).reshape(L.shape[0], arm.n)
    rigid = solve_cables(arm, L, seed=seed)
    theta = np.where(np.isfinite(rigid["theta"]).all(1, keepdims=True), rigid["theta"], seed)
    F = settling_equations(robot, arm, q, L, z)
    if arm.n < position_cables(arm).size and q["kappa"] > 0.0:
        # the redundant elastic arm: minimise its energy (without clearance and
        # friction, which has none) first
        F0 = settling_equations(robot, arm, dict(q, cl=0.0, mu=0.0), L)
        theta = _energy_descent(F0, theta, 1e-13, max_iter, fd_step)
    theta, res = _damped_newton(F, theta, tol, max_iter, fd_step)
    return theta, res <= tol


# --------------------------------------------------------------------------
# Observation and the whole pipeline
# --------------------------------------------------------------------------
def observe(robot, p, theta) -> np.ndarray:
    """What the instrument sees at the settled ``theta (N, n)`` rad: the kind's task vector
    of the frame ``E F_end Trans(tip)`` (``docs/model.md``, "Observation"), ``F_end`` the end
    frame of the plant's arm, ``E = (Rot(rho), t)`` the instrument frame.

    Seen ``q = Rot(rho) (p_end + R_end tip) + t`` (m); planar ``(N, 3)`` ``[q_x, q_y, phi +
    alpha]`` (``phi`` the unwrapped sum of ``theta``, ``alpha`` the frame's turn about
    ``z``), spatial ``(N, 6)`` ``[q, log(Rot(rho) R_end)]`` (rotation vector, rad).
    """
    robot = as_robot(robot)
    arm = plant_arm(robot, p)
    q = plant_params(robot, p)
    th = as_theta(arm, theta)
    ch = chain_frames(arm, th)
    p_end, R_end = ch["tb"][:, -1], ch["Rb"][:, -1]
    E = exp_so3(q["rho"])
    seen = (p_end + R_end @ q["tip"]) @ E.T + q["t"]
    return task_vector(arm, seen, E @ R_end, th, turn=q["rho"][2])


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
    robot = as_robot(robot)
    seeds = np.asarray(seeds, dtype=float).reshape(-1, robot.n)
    sol = solve_cables(robot, np.asarray(commands, dtype=float), seed=seeds)
    good = np.isfinite(sol["theta"]).all(1) & np.asarray(sol["converged"], bool) & ~np.asarray(first, bool)
    theta = np.where(good[:, None], sol["theta"], seeds)
    pos, frc = position_cables(robot), force_cables(robot)

    def holes(th):
        if pos.size == robot.n:
            Tp = tensions(robot, th)
        else:
            M = moment_matrices(robot, th)
            b = -(external_moments(robot, th) + M[:, :, frc] @ robot.cable_tension[frc])
            Tp, _ = min_norm_tensions(M[:, :, pos], b, 0.0)
        T = np.tile(np.asarray(robot.cable_tension, float), (th.shape[0], 1))
        T[:, pos] = np.where(np.isfinite(Tp) & (Tp > 0.0), Tp, 0.0)
        d, beta, ten = [], [], []
        for c, P in enumerate(cable_points(robot, th)):
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
    :func:`.friction.mobilisation_scan`, bands ``(kappa + kappa_ff) T_hat d sinh(mu beta)`` of
    ``p``: the cable's one compliance, :func:`fed_forward_compliance`, with ``kappa +
    1/(E A)`` for ``kappa`` where the arm has more position cables than joints,
    :func:`redundant_compliance`)."""
    q = _settle_numbers(robot, p)
    d, beta, ten, d0 = friction_motion(robot, commands, seeds, first)
    kf = q["kappa"] + fed_forward_compliance(robot)
    return fr.mobilisation_scan(d, fr.band(kf, q["mu"], ten, d, beta), d0)


def plant_predict(robot, p, theta_cmd, dL, kind, tol=1e-12):
    """Observations of a data set under the plant ``p`` (``(plant_size(robot),)``, SI).

    ``theta_cmd (N, n)`` rad, ``dL (N, m)`` m (on the position cables), ``kind``:
    ``N`` names ``"absolute" | "displacement" | "unmeasured"``, rows in execution
    order.  All commands form one sequence (:func:`plant_commands`); backlash runs
    over the whole of it from the straight pose; each command settles from its
    row's ``theta_cmd``.  Returns ``(obs (N, t), converged (N,))``: ``obs`` is
    :func:`observe` (absolute: planar ``[x, y, phi]``, spatial ``[x, y, z, rx, ry, rz]``,
    m and rad), the difference second minus first (displacement, every component),
    NaN (unmeasured, and rows that did not settle); ``converged``
    is True when every command of the row settled (also for unmeasured rows).
    """
    robot = as_robot(robot)
    commands, rows, seeds = plant_commands(robot, theta_cmd, dL, kind)
    r = backlash_scan(robot, p, commands)
    L = realised_lengths(robot, p, r)
    first = sq.first_of_pairs(rows)
    z = mobilisation(robot, p, commands, seeds, first) if plant_params(robot, p)["mu"] > 0.0 else None
    theta, ok = settle(robot, p, L, seeds, tol=tol, z=z)
    return sq.observations(observe(robot, p, theta), rows, ok, kind)
