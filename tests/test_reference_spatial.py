"""Self-checks of the NumPy reference (``cdsm.reference``) on spatial arms: the
facts of ``docs/spatial.md`` and the planar model it must reproduce, using the
reference only (no compiled extension).  SI units: m, rad, N, kg."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from conftest import LIM35, PAPER_LINKAGES, ROOT, random_theta, reference_robot

ROBOTS = ROOT / "python" / "cdsm" / "robots"
G0 = 9.80665
PAPER_LOWER = np.array([0.4903325, 0.0980665, 0.04903325])  # N: 50, 10, 5 g
PAPER_MASS = np.array([0.0322, 0.0334, 0.0210])  # kg


@pytest.fixture(scope="module")
def paper(ref):
    return ref.load_robot(ROBOTS / "paper_spatial.toml")


@pytest.fixture(scope="module")
def uni(ref):
    return ref.load_robot(ROBOTS / "two_universal.toml")


@pytest.fixture(scope="module")
def uni_all_position(uni):
    """two_universal with all 8 cables position-controlled (m_pos = 8 > n = 4)."""
    return dataclasses.replace(uni, cable_mode=("position",) * uni.m, cable_tension=np.full(uni.m, np.nan))


@pytest.fixture(scope="module")
def uni_skewed(uni):
    """two_universal with every hole moved by up to 2 mm in x, y, z (general geometry)."""
    rng = np.random.default_rng(11)
    holes = tuple(h + rng.uniform(-2e-3, 2e-3, h.shape) for h in uni.holes)
    return dataclasses.replace(uni, holes=holes)


def _box(robot, N, seed, scale=1.0):
    """Joint angles ``(N, n)`` rad uniform in ``scale`` times the joint box."""
    lo, hi = robot.joint_limits[:, 0] * scale, robot.joint_limits[:, 1] * scale
    return np.random.default_rng(seed).uniform(lo, hi, (N, robot.n))


# --------------------------------------------------------------------------
# Robot files
# --------------------------------------------------------------------------
def test_packaged_files(paper, uni, ref):
    assert (paper.n, paper.disks, paper.m) == (3, 3, 6)
    assert paper.kind == "spatial"
    np.testing.assert_array_equal(ref.position_cables(paper), [0, 2, 4])
    np.testing.assert_allclose(paper.cable_tension[1::2], PAPER_LOWER, rtol=0, atol=0)
    np.testing.assert_allclose(paper.joint_limits, np.tile([-LIM35, LIM35], (3, 1)), rtol=1e-15)
    for c, h in enumerate(paper.holes):
        assert h.shape == (2 * (c // 2 + 1) + 1, 3)
    assert (uni.n, uni.disks, uni.m) == (4, 2, 8)
    np.testing.assert_array_equal(uni.joint_disk, [1, 1, 2, 2])
    np.testing.assert_array_equal(ref.position_cables(uni), [0, 1, 4, 5])
    np.testing.assert_array_equal(ref.force_cables(uni), [2, 3, 6, 7])
    np.testing.assert_allclose(np.linalg.norm(uni.axes, axis=1), 1.0, atol=1e-15)
    np.testing.assert_array_equal(uni.gravity, [0.0, 0.0, -G0])


def test_explicit_holes_equal_radius_angle(ref, uni):
    """``holes = [...]`` with the points of ``radius`` + ``angle`` is the same cable."""
    text = (ROBOTS / "two_universal.toml").read_text()
    pts = ", ".join(["[0.0, 0.0, 0.025]"] * 5)
    old = "end = 2\nmode = \"position\"\nradius = 0.025\nangle = 1.5707963267948966\n"
    assert old in text
    explicit = ref.read_robot(text.replace(old, f"end = 2\nmode = \"position\"\nholes = [{pts}]\n"))
    th = _box(uni, 50, 3)
    np.testing.assert_allclose(ref.cable_lengths(explicit, th), ref.cable_lengths(uni, th), rtol=0, atol=1e-15)


# --------------------------------------------------------------------------
# The planar arm as a spatial file
# --------------------------------------------------------------------------
def _eq_1_3(linkages, theta):
    """The planar chain of the seed paper's Eq. 1-3, written out: joint positions
    ``(N, n, 2)``, disk centres ``(N, n, 2)``, the tip ``(N, 2)`` (m) and ``phi (N,)``."""
    lb, la, t = (np.array([getattr(lk, a) for lk in linkages]) for a in ("link_before", "link_after", "thickness"))
    alpha = np.cumsum(theta, axis=1)
    before = np.concatenate([np.zeros((len(theta), 1)), alpha[:, :-1]], axis=1)
    e, e_prev = np.stack([np.cos(alpha), np.sin(alpha)], -1), np.stack([np.cos(before), np.sin(before)], -1)
    face_b = np.cumsum(lb[:, None] * e_prev + (la + t)[:, None] * e, axis=1)
    prev = np.concatenate([np.zeros((len(theta), 1, 2)), face_b[:, :-1]], axis=1)
    joints = prev + lb[:, None] * e_prev
    centres = joints + (la + t / 2)[:, None] * e
    return joints, centres, face_b[:, -1], alpha[:, -1]


def _eq_4_5(ref, robot, theta):
    """Cable lengths ``(N, 2n)`` and ``dL/dtheta (N, 2n, n)`` of a planar arm from the
    closed form of Eq. 4-5: ``s_k^2 = P + Q cos(theta_k) + R sin(theta_k)`` plus the
    disks' traversals (``reference.closed_form``)."""
    P, Q, R, mask = ref.segment_coefficients(robot)
    c, s = np.cos(theta)[:, None, :], np.sin(theta)[:, None, :]
    seg = np.where(mask, np.sqrt(P + Q * c + R * s), 0.0)
    dseg = np.where(mask, (R * c - Q * s) / (2.0 * np.where(mask, seg, 1.0)), 0.0)
    return seg.sum(axis=2) + ref.traversals(robot), dseg


def test_paper_spatial_reproduces_the_planar_equations(ref, paper):
    """The paper's arm, as its general-form file and as the planar shorthand, through
    the one chain: Eq. 1-3 and the closed form of Eq. 4-5 (written out here and in
    ``reference.closed_form``), z = 0 and rotations about z only; the spatial task's
    rotation is the planar attitude wrapped."""
    planar = reference_robot(PAPER_LINKAGES)
    th = random_theta(3, N=500, seed=1)
    joints, _, tip, phi = _eq_1_3(PAPER_LINKAGES, th)
    pose, planar_pose = ref.fk(paper, th), ref.fk(planar, th)
    np.testing.assert_allclose(pose[:, :2], tip, rtol=0, atol=1e-12)
    np.testing.assert_allclose(planar_pose, np.column_stack([tip, phi]), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(pose[:, 2], 0.0)  # z = 0
    np.testing.assert_array_equal(pose[:, 3:5], 0.0)  # rotation about z only
    np.testing.assert_allclose(pose[:, 5], ref.wrap_angle(phi), rtol=0, atol=1e-12)
    L, dL = _eq_4_5(ref, planar, th)
    for robot in (paper, planar):
        np.testing.assert_allclose(ref.cable_lengths(robot, th), L, rtol=0, atol=1e-12)
        np.testing.assert_allclose(ref.cable_jacobian(robot, th), dL, rtol=0, atol=1e-12)
    # the task Jacobian: column j is [-(Y - Jy_j), X - Jx_j, 1] (Eq. 1-3 differentiated)
    want = np.stack([-(tip[:, None, 1] - joints[..., 1]), tip[:, None, 0] - joints[..., 0], np.ones((500, 3))], 1)
    np.testing.assert_allclose(ref.fk_jacobian(planar, th), want, rtol=0, atol=1e-12)
    J = ref.geometric_jacobian(paper, th)
    np.testing.assert_allclose(J[:, [0, 1, 5]], want, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(J[:, 2:5], 0.0)


def test_paper_spatial_statics_equal_planar(ref, paper):
    """Same upper tensions as the planar statics, with in-plane gravity and a tip
    wrench: the minimum-norm set above 0 of the general-form file (feasible rows) and
    the square balance of the planar shorthand; both balance the loads by virtual
    work, ``sum_c T_c dL_c/dtheta_j = tau_j``, with ``dL/dtheta`` from the closed form
    of Eq. 4-5 and ``tau`` the loads' generalised forces, central differences of
    their work on the chain of Eq. 1-3 (independent of the moment matrices)."""
    planar = reference_robot(PAPER_LINKAGES)
    th = random_theta(3, N=200, seed=2)
    wrench = np.array([0.3, -0.2, 0.004])  # Fx N, Fy N, Mz N m
    vertical = dataclasses.replace(paper, gravity=np.array([0.0, -G0, 0.0]))
    T, feasible = ref.feasible_tensions(vertical, th, tip_wrench=[wrench[0], wrench[1], 0.0, 0.0, 0.0, wrench[2]])
    T_planar = ref.tensions(planar, th, lower=PAPER_LOWER, tip_wrench=wrench, gravity=[0.0, -G0], mass=PAPER_MASS)
    np.testing.assert_array_equal(feasible, np.all(T_planar >= 0.0, axis=1))
    assert 0 < feasible.sum() < len(th)  # both cases occur
    np.testing.assert_allclose(T[feasible], T_planar[feasible], rtol=1e-10, atol=1e-12)
    assert np.isnan(T[~feasible]).all()

    def work(t):
        _, centres, tip, phi = _eq_1_3(PAPER_LINKAGES, t)
        return (PAPER_MASS[None, :, None] * centres * [0.0, -G0]).sum((1, 2)) + tip @ wrench[:2] + wrench[2] * phi

    h = 1e-6
    tau = np.stack([(work(th + h * e) - work(th - h * e)) / (2 * h) for e in np.eye(3)], axis=1)
    _, dL = _eq_4_5(ref, planar, th)
    everyone = np.empty((200, 6))
    everyone[:, 0::2], everyone[:, 1::2] = T_planar, PAPER_LOWER
    np.testing.assert_allclose(np.einsum("nc,ncj->nj", everyone, dL), tau, rtol=0, atol=1e-9)


def test_principal_rotation_vector_beyond_half_turn(ref, paper):
    """fk's rotation vector is the principal log: phi = 3.6 rad comes out as 3.6 - 2 pi."""
    th = np.array([[1.2, 1.2, 1.2], [-1.2, -1.2, -1.2], [np.pi / 3] * 3])
    r = ref.fk(paper, th)[:, 3:]
    np.testing.assert_allclose(r[:2, 2], ref.wrap_angle(th[:2].sum(1)), rtol=0, atol=1e-12)
    assert np.all(np.linalg.norm(r, axis=1) <= np.pi)
    assert abs(abs(r[2, 2]) - np.pi) < 1e-12


# --------------------------------------------------------------------------
# Rotations and frames
# --------------------------------------------------------------------------
@pytest.mark.parametrize(
    "angle", [0.0, 1e-300, 1e-12, 1e-8, 1e-4, 0.3, math.pi / 2, 2.5, math.pi - 1e-4, math.pi - 1e-8, math.pi - 1e-12]
)
def test_rotation_vector_round_trip(ref, angle):
    rng = np.random.default_rng(4)
    axis = rng.normal(size=(200, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    r = angle * axis
    R = ref.exp_so3(r)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=4e-15)
    np.testing.assert_allclose(ref.log_so3(R), r, rtol=0, atol=2e-15)
    np.testing.assert_allclose(ref.rotation_matrix(axis, angle), R, rtol=0, atol=2e-15)


def test_rotation_vector_at_half_turn(ref):
    """At exactly pi both signs are principal logarithms: the same rotation, |r| = pi."""
    rng = np.random.default_rng(5)
    axis = rng.normal(size=(200, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    axis = np.vstack([axis, np.eye(3), -np.eye(3)])
    R = ref.exp_so3(np.pi * axis)
    r = ref.log_so3(R)
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), np.pi, rtol=0, atol=2e-15)
    np.testing.assert_allclose(ref.exp_so3(r), R, rtol=0, atol=2e-15)
    np.testing.assert_allclose(np.abs((r * axis).sum(1)), np.pi, rtol=0, atol=2e-15)  # same axis up to sign


def test_log_of_random_rotations(ref):
    Q, _ = np.linalg.qr(np.random.default_rng(6).normal(size=(500, 3, 3)))
    Q *= np.sign(np.linalg.det(Q))[:, None, None]  # proper rotations
    r = ref.log_so3(Q)
    assert np.all(np.linalg.norm(r, axis=1) <= np.pi)
    np.testing.assert_allclose(ref.exp_so3(r), Q, rtol=0, atol=4e-15)


def test_fk_matrix_and_fk_agree(ref, uni):
    th = _box(uni, 300, 7)
    F, pose = ref.fk_matrix(uni, th), ref.fk(uni, th)
    np.testing.assert_array_equal(F[:, :3, 3], pose[:, :3])
    np.testing.assert_allclose(ref.exp_so3(pose[:, 3:]), F[:, :3, :3], rtol=0, atol=2e-15)
    np.testing.assert_array_equal(F[:, 3], np.broadcast_to([0.0, 0.0, 0.0, 1.0], (300, 4)))
    frames = ref.disk_frames(uni, th)
    np.testing.assert_array_equal(frames["tb"][:, -1], pose[:, :3])
    # straight arm: along x, 2 * (0.015 + 0.015 + 0.005) m
    np.testing.assert_allclose(ref.fk(uni, np.zeros((1, 4))), [[0.07, 0, 0, 0, 0, 0]], rtol=0, atol=1e-17)


# --------------------------------------------------------------------------
# Jacobians against central differences
# --------------------------------------------------------------------------
def _central(f, th, h=1e-6):
    cols = []
    for j in range(th.shape[1]):
        e = np.zeros(th.shape[1])
        e[j] = h
        cols.append((f(th + e) - f(th - e)) / (2 * h))
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("name", ["paper", "uni", "uni_skewed"])
def test_geometric_jacobian_central_differences(ref, name, request):
    robot = request.getfixturevalue(name)
    th = _box(robot, 40, 8)
    J = ref.geometric_jacobian(robot, th)
    np.testing.assert_allclose(J[:, :3], _central(lambda t: ref.fk(robot, t)[:, :3], th), rtol=0, atol=1e-10)
    # angular velocity: vee of dR/dtheta_j R^T
    dR = _central(lambda t: ref.fk_matrix(robot, t)[:, :3, :3], th)  # (N, 3, 3, n)
    R = ref.fk_matrix(robot, th)[:, :3, :3]
    W = np.einsum("nikj,nlk->njil", dR, R)  # (N, n, 3, 3) skew matrices
    omega = np.stack([W[..., 2, 1], W[..., 0, 2], W[..., 1, 0]], axis=1)  # (N, 3, n)
    np.testing.assert_allclose(J[:, 3:], omega, rtol=0, atol=1e-9)
    p, w = ref.joint_positions_axes(robot, th)
    np.testing.assert_allclose(np.linalg.norm(w, axis=-1), 1.0, atol=1e-15)


@pytest.mark.parametrize("name", ["paper", "uni", "uni_skewed"])
def test_cable_jacobian_central_differences(ref, name, request):
    robot = request.getfixturevalue(name)
    th = _box(robot, 40, 9)
    J = ref.cable_jacobian(robot, th)
    np.testing.assert_allclose(J, _central(lambda t: ref.cable_lengths(robot, t), th), rtol=0, atol=1e-10)
    # a cable depends only on the joints proximal of its end disk
    for c in range(robot.m):
        distal = robot.joint_disk > robot.cable_end[c]
        assert np.all(J[:, c, distal] == 0.0)


def test_disk_traversals_do_not_depend_on_theta(ref, uni_skewed):
    th = _box(uni_skewed, 30, 10)
    for P in ref.cable_points(uni_skewed, th):
        trav = np.linalg.norm(P[:, 2::2] - P[:, 1::2], axis=-1)
        np.testing.assert_allclose(trav, np.broadcast_to(trav[0], trav.shape), rtol=0, atol=1e-15)


# --------------------------------------------------------------------------
# Solves
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["paper", "uni", "uni_skewed"])
def test_cable_solve_recovers_theta(ref, name, request):
    robot = request.getfixturevalue(name)
    th = _box(robot, 200, 12)
    lengths = ref.cable_lengths(robot, th)[:, ref.position_cables(robot)]
    sol = ref.solve_cables(robot, lengths)
    assert sol["converged"].all()
    assert np.all(sol["residual"] <= 1e-12)
    np.testing.assert_allclose(sol["theta"], th, rtol=0, atol=1e-9)
    assert sol["within_limits"].all()


def test_cable_solve_least_squares(ref, uni_all_position):
    """m_pos = 8 > n = 4: consistent lengths give theta back; inconsistent ones stop
    at a stationary point and report the misfit."""
    robot = uni_all_position
    th = _box(robot, 40, 13)
    lengths = ref.cable_lengths(robot, th)
    sol = ref.solve_cables(robot, lengths)
    assert sol["converged"].all()
    np.testing.assert_allclose(sol["theta"], th, rtol=0, atol=1e-9)
    # Inconsistent lengths: Gauss-Newton converges linearly at a rate of about 1e-5 here, so
    # whether an accepted step lands in the window "decrease < 1e-12 |r|^2" above the
    # rounding of |r|^2 (about 1e-13 of it) is a matter of rounding: the spec's rule flags a
    # few rows as not converged although they sit at the minimum.  Every row is checked.
    noisy = lengths + np.random.default_rng(14).normal(0.0, 1e-4, lengths.shape)
    sol = ref.solve_cables(robot, noisy, seed=th)
    assert sol["converged"].mean() > 0.8
    r = ref.cable_lengths(robot, sol["theta"]) - noisy
    np.testing.assert_allclose(sol["residual"], np.abs(r).max(1), rtol=0, atol=0)
    assert np.all(sol["residual"] > 1e-6)
    J = ref.cable_jacobian(robot, sol["theta"])
    grad = np.einsum("nmj,nm->nj", J, r)  # stationary: J^T r = 0
    assert np.all(np.linalg.norm(grad, axis=1) <= 1e-6 * np.linalg.norm(J, axis=(1, 2)) * np.linalg.norm(r, axis=1))


@pytest.mark.parametrize("name, scale", [("paper", 1.0), ("uni", 0.5)])
@pytest.mark.parametrize("mask", ["position", "pointing", "pose"])
def test_ik_reaches_fk_targets(ref, name, scale, mask, request):
    robot = request.getfixturevalue(name)
    th = _box(robot, 60, 15, scale)
    target = ref.fk(robot, th)
    sol = ref.ik(robot, target, mask=mask)
    assert sol["converged"].all()
    reached = ref.fk_matrix(robot, sol["theta"])
    np.testing.assert_allclose(reached[:, :3, 3], target[:, :3], rtol=0, atol=1e-12)
    R_target = ref.exp_so3(target[:, 3:])
    if mask == "pointing":
        np.testing.assert_allclose(reached[:, :3, 0], R_target[:, :, 0], rtol=0, atol=1e-12)
    if mask == "pose":
        np.testing.assert_allclose(reached[:, :3, :3], R_target, rtol=0, atol=1e-12)


def test_pose_ik_from_a_nearby_seed_over_the_box(ref, uni):
    """Full box, seeds 0.05 rad off: pose (and pointing, 5 DOF for 4 joints) pin theta."""
    th = _box(uni, 60, 16)
    seed = th + np.random.default_rng(17).uniform(-0.05, 0.05, th.shape)
    for mask in ("pose", "pointing"):
        sol = ref.ik(uni, ref.fk(uni, th), seed=seed, mask=mask)
        assert sol["converged"].all()
        np.testing.assert_allclose(sol["theta"], th, rtol=0, atol=1e-9)


# --------------------------------------------------------------------------
# Statics
# --------------------------------------------------------------------------
def _all_tensions(ref, robot, T_pos):
    T = np.broadcast_to(robot.cable_tension, (T_pos.shape[0], robot.m)).copy()
    T[:, ref.position_cables(robot)] = T_pos
    return T


def test_moments_are_minus_the_cable_jacobian(ref, uni_skewed, paper):
    for robot in (uni_skewed, paper):
        th = _box(robot, 50, 18)
        np.testing.assert_allclose(
            ref.moment_matrices(robot, th), -np.swapaxes(ref.cable_jacobian(robot, th), 1, 2), rtol=0, atol=1e-15
        )


def test_external_moments_are_generalised_forces(ref, uni):
    """tau = sum_b mass_b g . d(com_b)/dtheta + J^T [F; M] (independent: central differences)."""
    th = _box(uni, 30, 19)
    wrench = np.array([0.2, -0.1, 0.3, 0.002, -0.001, 0.003])

    def coms(t):
        fr = ref.disk_frames(uni, t)
        return np.stack(
            [fr["Ra"][:, b] @ uni.com[b - 1] + fr["ta"][:, b] for b in range(1, uni.disks + 1)], axis=1
        )  # (N, K, 3)

    dcom = _central(coms, th)  # (N, K, 3, n)
    gravity = np.einsum("k,i,nkij->nj", uni.mass, uni.gravity, dcom)
    tip = np.einsum("nrj,r->nj", ref.geometric_jacobian(uni, th), wrench)
    np.testing.assert_allclose(ref.external_moments(uni, th, wrench), gravity + tip, rtol=0, atol=1e-11)


@pytest.mark.parametrize("name", ["paper_loaded", "uni", "uni_all_position"])
def test_statics_virtual_work(ref, name, request, paper, uni, uni_all_position):
    """sum_c T_c dL_c/dtheta_j = tau_j: the cable tensions balance the load moments."""
    robot = {
        "paper_loaded": dataclasses.replace(paper, gravity=np.array([0.0, -G0, 0.0])),
        "uni": uni,
        "uni_all_position": uni_all_position,
    }[name]
    th = _box(robot, 60, 20, 0.8)
    wrench = np.array([0.05, 0.02, -0.03, 0.0, 0.001, 0.0])
    T_pos, feasible = ref.feasible_tensions(robot, th, tip_wrench=wrench)
    assert feasible.mean() > 0.8
    T = _all_tensions(ref, robot, T_pos[feasible])
    J = ref.cable_jacobian(robot, th[feasible])
    np.testing.assert_allclose(
        np.einsum("nmj,nm->nj", J, T), ref.external_moments(robot, th[feasible], wrench), rtol=0, atol=1e-12
    )
    assert np.all(T_pos[feasible] >= 0.0)


def test_two_universal_taut_over_the_box(ref, uni):
    """Gravity along -z: every position cable stays taut over the joint box; at the straight
    pose the yaw cables carry exactly their antagonist's tension (no yaw moment)."""
    corners = np.array(np.meshgrid(*[[-0.6, 0.0, 0.6]] * 4)).reshape(4, -1).T
    th = np.vstack([corners, _box(uni, 200, 21)])
    T, feasible = ref.feasible_tensions(uni, th)
    assert feasible.all() and np.all(T > 0.01)
    T0, ok = ref.feasible_tensions(uni, np.zeros((1, 4)))
    assert ok.all()
    np.testing.assert_allclose(T0[0, [0, 2]], [1.0, 0.2], rtol=0, atol=1e-12)
    assert T0[0, 1] > 1.0 and T0[0, 3] > 0.2  # the top cables also hold the weight


def _dykstra(A, b, floor, iterations=3000):
    """Projection of 0 onto {A T = b} and {T >= floor} (Dykstra's alternating projections)."""
    P = np.linalg.pinv(A)
    x = np.zeros(A.shape[1])
    p = np.zeros_like(x)
    q = np.zeros_like(x)
    for _ in range(iterations):
        y = x + p
        y = y - P @ (A @ y - b)
        p = x + p - y
        x = np.maximum(y + q, floor)
        q = y + q - x
    return x


@pytest.mark.parametrize("floor", [0.0, 0.3])
def test_minimum_norm_tensions(ref, uni_all_position, floor):
    """m_pos = 8 > n = 4: the tensions solve the balance above the floor and no other
    feasible set (along the null space of the moment matrix) has a smaller norm; an
    independent QP (Dykstra's projections) gives the same point."""
    robot = uni_all_position
    th = _box(robot, 30, 22)
    T, feasible = ref.feasible_tensions(robot, th, min_tension=floor)
    assert feasible.all()
    A = ref.moment_matrices(robot, th)
    b = -ref.external_moments(robot, th)
    np.testing.assert_allclose(np.einsum("njm,nm->nj", A, T), b, rtol=0, atol=1e-13)
    assert np.all(T >= floor - 1e-13)
    rng = np.random.default_rng(23)
    norm = np.linalg.norm(T, axis=1)
    for i in range(len(th)):
        Z = np.linalg.svd(A[i])[2][robot.n :].T  # (8, 4) null space basis
        for eps in (1e-6, 1e-3, 1e-1):
            trial = T[i] + eps * (Z @ rng.normal(size=(Z.shape[1], 200))).T
            ok = np.all(trial >= floor, axis=1)
            assert np.all(np.linalg.norm(trial[ok], axis=1) >= norm[i] * (1 - 1e-14))
    for i in range(3):
        np.testing.assert_allclose(_dykstra(A[i], b[i], floor), T[i], rtol=0, atol=1e-10)


def test_slack_configuration_is_flagged(ref, uni, paper):
    """No tension set above the floor: feasible False and NaN tensions."""
    th = np.zeros((2, 4))
    T, feasible = ref.feasible_tensions(uni, th, tip_wrench=[[0, 0, 0, 0, 0, 0], [0, 0, 0, 0, 0, 0.05]])
    np.testing.assert_array_equal(feasible, [True, False])  # a yaw moment one 0-deg cable cannot pull against
    assert np.isfinite(T[0]).all() and np.isnan(T[1]).all()
    T, feasible = ref.feasible_tensions(uni, th[:1], min_tension=0.5)  # section 2 yaw cable holds 0.2 N only
    assert not feasible[0] and np.isnan(T).all()
    T, feasible = ref.feasible_tensions(paper, np.array([[0.0, 0.0, 0.0]]), tip_wrench=[0, 0, 0, 0, 0, 0.1])
    assert not feasible[0]


def test_min_norm_tensions_small_cases(ref):
    """Hand cases: one equation, two cables."""
    A = np.array([[[1.0, 1.0]], [[1.0, -1.0]], [[1.0, -1.0]], [[1.0, 1.0]]])
    b = np.array([[2.0], [1.0], [-3.0], [-1.0]])
    T, feasible = ref.min_norm_tensions(A, b, floor=0.0)
    np.testing.assert_array_equal(feasible, [True, True, True, False])
    np.testing.assert_allclose(T[:3], [[1.0, 1.0], [1.0, 0.0], [0.0, 3.0]], rtol=0, atol=1e-15)
    T, feasible = ref.min_norm_tensions(A[:1], b[:1], floor=1.5)
    assert not feasible[0]


# --------------------------------------------------------------------------
# Validation
# --------------------------------------------------------------------------
BASE_TEXT = """
kind = "spatial"
name = "validation base"
gravity = [0.0, 0.0, -9.80665]

[base]
radius = 0.03

[[linkage]]
joints = [ { axis = [0.0, 1.0, 0.0], offset = [0.02, 0.0, 0.0], limits = [-0.6, 0.6] } ]
link_after = [0.02, 0.0, 0.0]
thickness = 0.005
radius = 0.03
mass = 0.02

[[cables]]
end = 1
mode = "position"
radius = 0.025
angle = 1.5707963267948966

[[cables]]
end = 1
mode = "force"
tension = 0.3
holes = [[0.0, 0.0, -0.025], [0.0, 0.0, -0.025], [0.0, 0.0, -0.025]]
"""


def test_validation_base_parses(ref):
    robot = ref.read_robot(BASE_TEXT)
    assert (robot.n, robot.disks, robot.m) == (1, 1, 2)
    np.testing.assert_array_equal(robot.com, [[0.0025, 0.0, 0.0]])  # default: the disk centre
    assert (robot.youngs_modulus, robot.diameter, robot.routing_length) == (1.8e11, 0.18e-3, 0.0)
    robot = ref.read_robot(BASE_TEXT + "\n[cable]\nyoungs_modulus = 2e11\ndiameter = 3e-4\nrouting_length = 0.5\n")
    assert (robot.youngs_modulus, robot.diameter, robot.routing_length) == (2e11, 3e-4, 0.5)


def _edit(old, new, count=1):
    assert BASE_TEXT.count(old) >= count, old
    return BASE_TEXT.replace(old, new, count)


@pytest.mark.parametrize(
    "text, field",
    [
        (_edit("axis = [0.0, 1.0, 0.0]", "axis = [0.0, 0.0, 0.0]"), "linkage[1].joints[1].axis"),
        (_edit("radius = 0.025", "radius = 0.031"), "cables[1].radius"),
        (_edit("[0.0, 0.0, -0.025]]", "[0.0, 0.02, -0.025]]"), "cables[2].holes[2]"),
        (_edit("[[0.0, 0.0, -0.025], ", "["), "cables[2].holes"),
        (_edit("end = 1", "end = 2"), "cables[1].end"),
        (_edit("end = 1", "end = 0"), "cables[1].end"),
        (_edit("end = 1", "end = 1.0"), "cables[1].end"),
        (_edit('mode = "position"', 'mode = "length"'), "cables[1].mode"),
        (_edit("tension = 0.3\n", ""), "cables[2].tension"),
        (_edit("tension = 0.3", "tension = 0.0"), "cables[2].tension"),
        (_edit('mode = "position"', 'mode = "position"\ntension = 0.3'), "cables[1].tension"),
        (_edit('mode = "position"', 'mode = "force"\ntension = 0.3'), "cables: "),
        (_edit("offset = [0.02, 0.0, 0.0]", "offset = [nan, 0.0, 0.0]"), "linkage[1].joints[1].offset[0]"),
        (_edit("gravity = [0.0, 0.0, -9.80665]", "gravity = [0.0, 0.0, -inf]"), "gravity[2]"),
        (_edit("thickness = 0.005", "thickness = -0.005"), "linkage[1].thickness"),  # 0 is a via plate
        (_edit("radius = 0.03\nmass", "radius = -0.03\nmass"), "linkage[1].radius"),
        (_edit("[base]\nradius = 0.03", "[base]\nradius = 0.0"), "base.radius"),
        (_edit("mass = 0.02", "mass = -0.02"), "linkage[1].mass"),
        (_edit("limits = [-0.6, 0.6]", "limits = [0.6, 0.6]"), "linkage[1].joints[1].limits"),
        (_edit("limits = [-0.6, 0.6]", "limits = [0.6, -0.6]"), "linkage[1].joints[1].limits"),
        (_edit('kind = "spatial"', 'kind = "spherical"'), "kind"),
        (_edit('kind = "spatial"', 'kind = "planar"'), "kind"),
        (_edit("joints = [ { axis = [0.0, 1.0, 0.0], offset = [0.02, 0.0, 0.0], limits = [-0.6, 0.6] } ]",
               "joints = []"), "linkage[1].joints"),
        (_edit("radius = 0.025\nangle", "radius = 0.025\nholes = [[0, 0, 0]] \nangle"), "cables[1].holes"),
        (_edit("thickness = 0.005", "thickness = 0.005\nlength = 0.1"), "linkage[1].length"),
        (BASE_TEXT + "\n[cable]\nyoungs_modulus = -1.8e11\n", "cable.youngs_modulus"),
        (BASE_TEXT + "\n[cable]\nyoung = 1.8e11\n", "cable.young"),
        (BASE_TEXT.split("[[cables]]")[0], "cables"),
    ],
)
def test_validation_names_the_field(ref, text, field):
    with pytest.raises(ValueError, match=re.escape(field)):
        ref.read_robot(text)


def test_validation_no_linkage(ref):
    text = 'kind = "spatial"\nlinkage = []\n\n[base]\nradius = 0.03\n'
    with pytest.raises(ValueError, match=r"^linkage"):
        ref.read_robot(text)


def test_axis_is_normalised(ref):
    robot = ref.read_robot(_edit("axis = [0.0, 1.0, 0.0]", "axis = [0.0, 3.0, 4.0]"))
    np.testing.assert_allclose(robot.axes, [[0.0, 0.6, 0.8]], rtol=0, atol=1e-16)
