"""Self-checks of the reference plant (``cdsm.reference.plant``) on planar arms: facts of
``docs/model.md`` ("The plant: nominal model plus unmodelled effects"), using
the NumPy reference only (no compiled extension)."""

from __future__ import annotations

import dataclasses
import math
import types

import numpy as np
import pytest

from conftest import N1_LINKAGES, N12_LINKAGES, PAPER_LINKAGES, random_theta, reference_robot

G0 = 9.80665


def _robot(ref, name, mass=None, gravity=None, routing_length=0.0):
    lk = {"paper": PAPER_LINKAGES, "n1": N1_LINKAGES, "n12": N12_LINKAGES}[name]
    r = reference_robot(lk, gravity=gravity, routing_length=routing_length)
    return r if mass is None else dataclasses.replace(r, mass=np.asarray(mass, float))


def _planar(n):
    """A planar reference arm of ``n`` joints (the planar layout depends on ``n`` only)."""
    return reference_robot(N12_LINKAGES[:n])


def _p(ref, n, **effects):
    """Flat parameter vector of an ``n``-joint planar arm with the named effects set."""
    p = np.zeros(ref.plant_size(_planar(n)))
    lay = ref.plant_layout(_planar(n))
    for k, v in effects.items():
        p[lay[k]] = v
    return p


def _rot(a, v):
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], -1)


NAMES = ["paper", "n1", "n12"]


# --------------------------------------------------------------------------
# Parameter layout
# --------------------------------------------------------------------------
@pytest.mark.parametrize("n", [1, 3, 12])
def test_layout(ref, n):
    names = [name for name, _ in ref.plant_blocks(_planar(n))]
    assert names == ["actuation_scale", "cable_offset", "hole_height", "link_length",
                     "cable_elasticity", "hole_clearance", "frame_misalignment",
                     "tip_offset", "backlash", "clearance_width", "cable_friction"]
    lay = ref.plant_layout(_planar(n))
    sizes = [1, n, n, n + 1, 1, 1, 3, 2, n, 1, 1]
    assert [lay[k].stop - lay[k].start for k in names] == sizes
    assert lay["actuation_scale"].start == 0
    for a, b in zip(names, names[1:]):
        assert lay[a].stop == lay[b].start
    assert ref.plant_size(_planar(n)) == 4 * n + 11 == lay["cable_friction"].stop


def test_parameter_checks(ref):
    """Outside the physical domain of docs/model.md ("Parameters") the reference refuses."""
    n = 3
    robot = _planar(n)
    la = robot.link_after[1, 0]  # m, link_after[2]: its link_length entry is dl_2
    for bad, field in [(dict(cable_elasticity=-1e-6), "cable_elasticity"),
                       (dict(hole_clearance=-1e-4), "hole_clearance"),
                       (dict(backlash=[0, -1e-5, 0]), "backlash"), (dict(clearance_width=-0.01), "clearance width"),
                       (dict(clearance_width=1.0), "clearance width"), (dict(cable_friction=-0.1), "cable_friction"),
                       (dict(cable_friction=1.01), "cable_friction"), (dict(actuation_scale=-0.9), "actuator gain"),
                       (dict(link_length=[0.0, 0.0, -0.91 * la, 0.0]), "link_length")]:
        with pytest.raises(ValueError, match=field):
            ref.plant_params(robot, _p(ref, n, **bad))
    ref.plant_params(robot, _p(ref, n, link_length=[0.0, 0.0, -0.89 * la, 0.0], clearance_width=0.99,
                               cable_friction=1.0, actuation_scale=-0.89))  # inside, at the edges
    with pytest.raises(ValueError):
        ref.plant_params(robot, np.zeros(4 * n + 10))


# --------------------------------------------------------------------------
# All-zero parameters: the nominal model
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_zero_parameters_are_nominal(ref, name):
    robot = _robot(ref, name)
    n = robot.n
    p = np.zeros(ref.plant_size(robot))
    arm = ref.plant_arm(robot, p)
    for a in ["axes", "offsets", "joint_limits", "link_after", "thickness", "mass", "com", "gravity",
              "cable_tension"]:
        np.testing.assert_array_equal(getattr(arm, a), getattr(robot, a), err_msg=a)
    for h, g in zip(arm.holes, robot.holes):
        assert np.array_equal(h, g)

    N = 60
    theta = random_theta(n, N, seed=3, lim=0.4)
    dL = np.random.default_rng(4).normal(0.0, 5e-4, (N, n))
    kind = ["absolute", "displacement", "unmeasured"] * (N // 3)
    obs, ok = ref.plant_predict(robot, p, theta, dL, kind)
    assert ok.all()

    # the plant's settle (a damped Newton on the cables to round-off) and two
    # independent rigid solves; the closed form to 1e-14 per coordinate: x, y (m)
    # and each joint angle, so phi, the sum of n angles, to n 1e-14 rad
    C = ref.position_lengths(robot, theta)
    for solver, atol in [(ref.solve_cables_closed_form, [1e-14, 1e-14, n * 1e-14]), (ref.solve_cables, 1e-10)]:
        s1 = solver(robot, C + dL, seed=theta)
        s0 = solver(robot, C, seed=theta)
        assert s1["converged"].all() and s0["converged"].all()
        S1, S0 = ref.fk(robot, s1["theta"]), ref.fk(robot, s0["theta"])
        k = np.array(kind)
        assert (np.abs(obs[k == "absolute"] - S1[k == "absolute"]) <= atol).all()
        assert (np.abs(obs[k == "displacement"] - (S1 - S0)[k == "displacement"]) <= atol).all()
        assert np.isnan(obs[k == "unmeasured"]).all()
    # with dL = 0 an absolute row sees the commanded pose
    obs0, ok0 = ref.plant_predict(robot, p, theta, np.zeros_like(dL), ["absolute"] * N)
    assert ok0.all()
    np.testing.assert_allclose(obs0, ref.fk(robot, theta), rtol=0, atol=1e-13)


# --------------------------------------------------------------------------
# The arm and hole clearance
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_arm_perturbations(ref, name):
    robot = _robot(ref, name)
    n = robot.n
    rng = np.random.default_rng(5)
    dh, dl = rng.normal(0, 1e-4, n), rng.normal(0, 1e-4, n + 1)
    arm = ref.plant_arm(robot, _p(ref, n, hole_height=dh, link_length=dl)).planar
    robot = robot.planar
    assert arm.link_before[0] == robot.link_before[0] + dl[0]
    np.testing.assert_array_equal(arm.link_before[1:], robot.link_before[1:])
    np.testing.assert_array_equal(arm.link_after, robot.link_after + dl[1:])
    np.testing.assert_array_equal(arm.thickness, robot.thickness)
    mask = ref.used_hole_mask(n)
    for c in range(2 * n):
        sign = 1.0 if c % 2 == 0 else -1.0
        d = arm.holes[c, ..., 1] - robot.holes[c, ..., 1]
        np.testing.assert_allclose(d[mask[c]], sign * dh[c // 2], rtol=0, atol=1e-17)
        assert np.all(d[~mask[c]] == 0.0)
        np.testing.assert_array_equal(arm.holes[c, ..., 0], robot.holes[c, ..., 0])
    # carried over
    np.testing.assert_array_equal(arm.mass, robot.mass)
    np.testing.assert_array_equal(arm.lower_tension, robot.lower_tension)
    np.testing.assert_array_equal(arm.gravity, [0.0, 0.0])


@pytest.mark.parametrize("name", NAMES)
def test_clearance_zero_is_nominal_length(ref, name):
    robot = _robot(ref, name)
    n = robot.n
    rng = np.random.default_rng(6)
    p = _p(ref, n, hole_height=rng.normal(0, 1e-4, n), link_length=rng.normal(0, 1e-4, n + 1),
           clearance_width=0.02)
    theta = random_theta(n, 200, seed=7)
    La = ref.arm_lengths(robot, p, theta)
    np.testing.assert_allclose(La, ref.position_lengths(ref.plant_arm(robot, p), theta),
                               rtol=0, atol=1e-15)


@pytest.mark.parametrize("name", NAMES)
def test_clearance_vanishes_at_straight_pose(ref, name):
    robot = _robot(ref, name)
    n = robot.n
    p = _p(ref, n, hole_clearance=3e-4, hole_height=np.full(n, 2e-5))
    assert all(np.all(shift == 0.0) for shift in ref.bend_shifts(robot, p, np.zeros((1, n))))
    z = np.zeros((1, n))
    np.testing.assert_allclose(ref.arm_lengths(robot, p, z),
                               ref.position_lengths(ref.plant_arm(robot, p), z), rtol=0, atol=1e-15)
    # away from the straight pose it does change the lengths
    theta = random_theta(n, 20, seed=8)
    assert np.abs(ref.arm_lengths(robot, p, theta)
                  - ref.position_lengths(ref.plant_arm(robot, p), theta)).max() > 1e-6


def test_clearance_by_hand_n1(ref):
    """n = 1, straight holes at height h: both holes of the joint move by d, the
    anchor (face b of disk 1) stays."""
    robot = _robot(ref, "n1")
    v = robot.planar
    lb, la, t = v.link_before[0], v.link_after[0], v.thickness[0]
    h = v.holes[0, 0, 1, 1]
    cl, dw = 4e-4, 0.005
    w = 0.01 + dw
    theta = np.linspace(-0.6, 0.6, 13)[:, None]
    d = cl * np.tanh(theta[:, 0] / w)
    Ax = lb + np.cos(theta[:, 0]) * la - np.sin(theta[:, 0]) * (h + d)
    Ay = np.sin(theta[:, 0]) * la + np.cos(theta[:, 0]) * (h + d)
    expect = np.hypot(Ax - 0.0, Ay - (h + d)) + np.hypot(t, -d)
    got = ref.arm_lengths(robot, _p(ref, 1, hole_clearance=cl, clearance_width=dw), theta)
    np.testing.assert_allclose(got[:, 0], expect, rtol=0, atol=1e-15)


def test_clearance_by_hand_n2_inner_disk(ref):
    """n = 2, upper cable 2: disk 1's traversal sees d_1 at face a and d_2 at face b."""
    lk = PAPER_LINKAGES[:2]
    robot = reference_robot(lk)
    h = lk[1].hole_height
    cl = 2e-4
    theta = np.array([[0.3, -0.2]])
    d1, d2 = cl * np.tanh(theta[0] / 0.01)
    t1, t2 = theta[0]

    def seg(lb, la, th, d):
        A = np.array([lb + np.cos(th) * la - np.sin(th) * (h + d), np.sin(th) * la + np.cos(th) * (h + d)])
        return np.hypot(A[0], A[1] - (h + d))

    expect = (seg(lk[0].link_before, lk[0].link_after, t1, d1) + math.hypot(lk[0].thickness, d2 - d1)
              + seg(lk[1].link_before, lk[1].link_after, t2, d2) + math.hypot(lk[1].thickness, -d2))
    got = ref.arm_lengths(robot, _p(ref, 2, hole_clearance=cl), theta)
    assert abs(got[0, 1] - expect) < 1e-15


# --------------------------------------------------------------------------
# Backlash and actuation
# --------------------------------------------------------------------------
def test_backlash_zero_is_identity(ref):
    robot = _robot(ref, "paper")
    c = ref.reference_lengths(robot) + np.random.default_rng(9).normal(0, 2e-3, (50, 3))
    assert np.array_equal(ref.backlash_scan(robot, _p(ref, 3), c), c)


def test_backlash_reversal_and_monotone(ref):
    robot = _robot(ref, "paper")
    L0 = ref.reference_lengths(robot)
    np.testing.assert_array_equal(L0, ref.position_lengths(robot, np.zeros((1, 3)))[0])
    b = np.array([1e-4, 2e-4, 5e-5])
    p = _p(ref, 3, backlash=b)
    D = 1e-3
    # monotone: up, up, up -> b lost once
    c = L0 + np.array([[D], [2 * D], [3 * D]]) * np.ones(3)
    r = ref.backlash_scan(robot, p, c)
    np.testing.assert_allclose(r[0] - L0, D - b, rtol=0, atol=1e-15)
    np.testing.assert_allclose(np.diff(r, axis=0), D, rtol=0, atol=1e-15)
    # reversal: up by D then down by D -> the down move delivers D - 2b
    c = L0 + np.array([[D], [0.0]]) * np.ones(3)
    r = ref.backlash_scan(robot, p, c)
    np.testing.assert_allclose(r[0] - r[1], D - 2 * b, rtol=0, atol=1e-15)
    np.testing.assert_allclose(r[1], L0 + b, rtol=0, atol=1e-15)
    # inside the dead band nothing moves
    c = L0 + np.array([[0.5], [-0.9], [0.99]]) * b
    r = ref.backlash_scan(robot, p, c)
    assert np.array_equal(r, np.tile(L0, (3, 1)))


def test_realised_lengths(ref):
    robot = _robot(ref, "paper")
    L0 = ref.reference_lengths(robot)
    o = np.array([1e-4, -2e-4, 3e-5])
    s = 0.02
    r = L0 + np.array([[0.0, 0.0, 0.0], [1e-3, -2e-3, 5e-4]])
    L = ref.realised_lengths(robot, _p(ref, 3, actuation_scale=s, cable_offset=o), r)
    np.testing.assert_allclose(L[0], L0 + o, rtol=0, atol=1e-15)  # scale pivots on L_ref
    np.testing.assert_allclose(L[1] - L[0], 1.02 * (r[1] - r[0]), rtol=0, atol=1e-15)
    assert np.array_equal(ref.realised_lengths(robot, _p(ref, 3), r), r)


def test_backlash_in_the_pipeline(ref):
    """One absolute row commanded longer than the straight pose by more than b
    on every cable: the arm sees C + dL - b."""
    robot = _robot(ref, "paper")
    b = np.array([1e-4, 2e-4, 1.5e-4])
    theta = np.array([[-0.2, -0.1, -0.15]])  # all upper cables longer than straight
    C = ref.position_lengths(robot, theta)
    assert np.all(C[0] - ref.reference_lengths(robot) > b)
    obs, ok = ref.plant_predict(robot, _p(ref, 3, backlash=b), theta, np.zeros((1, 3)), ["absolute"])
    sol = ref.solve_cables(robot, C - b, seed=theta)
    np.testing.assert_allclose(obs, ref.fk(robot, sol["theta"]), rtol=0, atol=1e-10)
    # the same row measured as a displacement: C then C (+0): second command within the band
    obs_d, _ = ref.plant_predict(robot, _p(ref, 3, backlash=b), theta, np.zeros((1, 3)), ["displacement"])
    np.testing.assert_allclose(obs_d, 0.0, rtol=0, atol=1e-15)


def test_commands_order(ref):
    robot = _robot(ref, "paper")
    theta = random_theta(3, 4, seed=10, lim=0.3)
    dL = np.full((4, 3), 1e-4)
    cmds, rows, seeds = ref.plant_commands(robot, theta, dL, ["displacement", "absolute", "unmeasured",
                                                              "displacement"])
    C = ref.position_lengths(robot, theta)
    assert rows.tolist() == [0, 0, 1, 2, 3, 3]
    np.testing.assert_array_equal(cmds, [C[0], C[0] + dL[0], C[1] + dL[1], C[2] + dL[2], C[3], C[3] + dL[3]])
    np.testing.assert_array_equal(seeds, theta[rows])
    with pytest.raises(ValueError):
        ref.plant_commands(robot, theta, dL, ["absolute", "absolute", "absolute", "relative"])


# --------------------------------------------------------------------------
# Observation
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_tip_offset_rotates_with_phi(ref, name):
    robot = _robot(ref, name)
    n = robot.n
    theta = random_theta(n, 100, seed=11)
    tip = np.array([3e-3, -2e-3])
    base = ref.observe(robot, _p(ref, n), theta)
    np.testing.assert_allclose(base, ref.fk(robot, theta), rtol=0, atol=0)
    got = ref.observe(robot, _p(ref, n, tip_offset=tip), theta)
    phi = theta.sum(axis=1)
    np.testing.assert_allclose(got[:, :2] - base[:, :2], _rot(phi, np.tile(tip, (100, 1))), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(got[:, 2], base[:, 2])
    # in a rotated, shifted frame
    a, f = 0.05, np.array([1e-2, -3e-3])
    fm = ref.observe(robot, _p(ref, n, tip_offset=tip, frame_misalignment=[a, *f]), theta)
    np.testing.assert_allclose(fm[:, :2], _rot(a, got[:, :2]) + f, rtol=0, atol=1e-15)
    np.testing.assert_allclose(fm[:, 2], phi + a, rtol=0, atol=1e-15)


@pytest.mark.parametrize("name", NAMES)
def test_frame_translation_cancels_in_displacements(ref, name):
    robot = _robot(ref, name)
    n = robot.n
    N = 30
    theta = random_theta(n, N, seed=12, lim=0.4)
    dL = np.random.default_rng(13).normal(0, 5e-4, (N, n))
    kind = ["displacement", "absolute"] * (N // 2)
    k = np.array(kind)
    base = _p(ref, n, tip_offset=[2e-3, 1e-3], backlash=np.full(n, 5e-5))
    o0, ok0 = ref.plant_predict(robot, base, theta, dL, kind)
    lay = ref.plant_layout(robot)
    moved = base.copy()
    moved[lay["frame_misalignment"]] = [0.0, 0.02, -0.01]
    o1, ok1 = ref.plant_predict(robot, moved, theta, dL, kind)
    assert ok0.all() and ok1.all()
    np.testing.assert_allclose(o1[k == "displacement"], o0[k == "displacement"], rtol=0, atol=1e-15)
    np.testing.assert_allclose(o1[k == "absolute"] - o0[k == "absolute"], [[0.02, -0.01, 0.0]] * (N // 2),
                               rtol=0, atol=1e-15)
    # the frame rotation stays: displacements rotate, their phi does not change
    rot = base.copy()
    rot[lay["frame_misalignment"]] = [0.1, 0.02, -0.01]
    o2, _ = ref.plant_predict(robot, rot, theta, dL, kind)
    dd = o0[k == "displacement"]
    np.testing.assert_allclose(o2[k == "displacement"][:, :2], _rot(0.1, dd[:, :2]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(o2[k == "displacement"][:, 2], dd[:, 2], rtol=0, atol=1e-15)


# --------------------------------------------------------------------------
# Statics and settling
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", NAMES)
def test_gravity_changes_tensions_only_with_mass(ref, name):
    n = _robot(ref, name).n
    theta = random_theta(n, 50, seed=14)
    g = [3.0, -9.81]
    p = _p(ref, n, hole_height=np.full(n, 1e-4))
    flat = ref.plant_tensions(_robot(ref, name), p, theta)
    v = _robot(ref, name).planar  # a duck-typed arm without a gravity attribute: [0, 0]
    no_attr = types.SimpleNamespace(n=v.n, **{a: getattr(v, a) for a in ("link_before", "link_after", "thickness",
                                                                           "holes", "joint_limits", "mass",
                                                                           "lower_tension")})
    np.testing.assert_array_equal(ref.plant_tensions(no_attr, p, theta), flat)
    massless = ref.plant_tensions(_robot(ref, name, mass=np.zeros(n), gravity=g), p, theta)
    np.testing.assert_allclose(massless, flat, rtol=0, atol=1e-14)
    heavy = ref.plant_tensions(_robot(ref, name, gravity=g), p, theta)
    assert np.abs(heavy - flat).max() > 1e-3


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("gravity,routing", [(None, 0.0), ([0.0, -G0], 0.4)])
def test_elastic_settling(ref, name, gravity, routing):
    robot = _robot(ref, name, gravity=gravity, routing_length=routing)
    n = robot.n
    N = 40
    theta_cmd = random_theta(n, N, seed=15, lim=0.35)
    kappa = 2e-5  # 1/N: about 1/(E A) of a 0.45 mm steel cable
    rng = np.random.default_rng(16)
    p = _p(ref, n, cable_elasticity=kappa, hole_height=rng.normal(0, 5e-5, n),
           link_length=rng.normal(0, 5e-5, n + 1))
    L = ref.position_lengths(robot, theta_cmd)
    theta, ok = ref.settle(robot, p, L, theta_cmd)
    assert ok.all()
    arm = ref.plant_arm(robot, p)
    T = ref.tensions(arm, theta, lower=robot.planar.lower_tension,
                     gravity=None if gravity is None else gravity, mass=robot.mass)
    stretch = ref.position_lengths(arm, theta) - L
    # the settling equation: L_arm - L = (L + L_route) kappa T
    np.testing.assert_allclose(stretch, (L + routing) * kappa * T, rtol=0, atol=1e-10)
    # taut cables lengthen (and the random configurations do pull on them)
    assert (T > 1e-3).any() and (stretch[T > 1e-3] > 0.0).all()
    # and the rigid answer is a different configuration
    lay = ref.plant_layout(robot)
    rigid, _ = ref.settle(robot, _p(ref, n, hole_height=p[lay["hole_height"]], link_length=p[lay["link_length"]]),
                          L, theta_cmd)
    assert np.abs(theta - rigid).max() > 1e-6
    # the same physics through the kinematics module's elastic cable solve
    d = 1e-3
    E = 1.0 / (kappa * math.pi * d**2 / 4.0)
    el = ref.solve_cables_elastic(arm, L, E, d, routing_length=routing, gravity=gravity,
                                  mass=robot.mass, seed=theta_cmd)
    assert el["converged"].all()
    np.testing.assert_allclose(theta, el["theta"], rtol=0, atol=1e-9)


def test_settling_with_clearance(ref):
    robot = _robot(ref, "paper")
    theta_cmd = random_theta(3, 30, seed=17, lim=0.4)
    L = ref.position_lengths(robot, theta_cmd)
    p = _p(ref, 3, hole_clearance=2e-4, clearance_width=0.01, cable_elasticity=1e-5)
    theta, ok = ref.settle(robot, p, L, theta_cmd)
    assert ok.all()
    F = ref.settling_residual(robot, p, L, theta)
    assert np.abs(F).max() <= 1e-12
    # F written out: clearance lengths against the stretched rest lengths
    T = ref.tensions(ref.plant_arm(robot, p), theta, lower=robot.planar.lower_tension)
    np.testing.assert_allclose(ref.arm_lengths(robot, p, theta), L * (1 + 1e-5 * T), rtol=0, atol=1e-12)


def test_unreachable_command_fails(ref):
    robot = _robot(ref, "paper")
    theta = np.zeros((3, 3))
    dL = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [1e-4, 0.0, 0.0]])  # 0.5 m: no configuration
    kind = ["absolute", "absolute", "displacement"]
    for p in [_p(ref, 3), _p(ref, 3, cable_elasticity=1e-5)]:
        obs, ok = ref.plant_predict(robot, p, theta, dL, kind)
        assert ok.tolist() == [True, False, True]
        assert np.isnan(obs[1]).all() and np.isfinite(obs[[0, 2]]).all()
