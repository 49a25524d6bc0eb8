"""Closed-form pose IK of 3-joint arms (``Robot.ik(..., method="closed_form")``).

The Rust core is checked against the independent NumPy reference
(``ref.ik_closed_form``, written from ``docs/model.md``) and against facts of
the planar 3R chain: every answer reproduces the target pose, the two
solutions are elbow flips of each other, the paper's branch is ``theta_2 <= 0``,
whole turns of a seed carry over to the answer.

Units: positions m, angles rad; the pose is ``[X m, Y m, phi rad]``.
Tolerances: angles from the same closed form agree to 1e-9 rad; poses are
reproduced to 1e-12 (m and rad).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import LIM35, PAPER_LINKAGES, Linkage, reference_robot, robot_toml

ANGLE_TOL = 1e-9  # rad, closed form vs closed form
POSE_TOL = 1e-12  # m and rad
LIM40 = math.radians(40.0)  # rad, sampling range (a little beyond the +-35 deg limits)

# A 3-joint arm with r1 != r2 and unequal links (m), so that swapped roles show.
ASYM_LINKAGES = [
    Linkage(0.030, 0.040, 0.012, 0.020),
    Linkage(0.020, 0.025, 0.008, 0.018),
    Linkage(0.035, 0.015, 0.010, 0.016),
]


def robot_pair(cdsm, name):
    """``(rust Robot, reference Robot)`` of the named 3-joint arm."""
    if name == "paper":
        return cdsm.Robot.paper(), reference_robot(PAPER_LINKAGES)
    return cdsm.Robot.from_toml_str(robot_toml(ASYM_LINKAGES)), reference_robot(ASYM_LINKAGES)


def arm_radii(robot):
    """``(r1, r2)`` m: joint 1 -> joint 2 and joint 2 -> joint 3 distances."""
    v = robot.planar  # the reference arm's planar layout
    lb, la, t = (np.asarray(a, dtype=float) for a in (v.link_before, v.link_after, v.thickness))
    return la[0] + t[0] + lb[1], la[1] + t[1] + lb[2]


def elbow_flip(robot, theta):
    """The other IK solution of the same pose, rad ``(N, 3)``: mirror of the arm
    about the line joint 1 -> joint 3 (``theta_2 -> -theta_2``; joint 1 turns by
    twice the angle ``gamma`` between link 1 and that line; ``phi`` is kept)."""
    r1, r2 = arm_radii(robot)
    t1, t2, t3 = theta.T
    gamma = np.arctan2(r2 * np.sin(t2), r1 + r2 * np.cos(t2))
    f1 = t1 + 2.0 * gamma
    f2 = -t2
    return np.stack([f1, f2, t1 + t2 + t3 - f1 - f2], axis=1)


def solve(robot, pose, seed, **kw):
    """Rust closed-form IK with tol 1e-12 and no limits unless given."""
    kw.setdefault("enforce_limits", False)
    kw.setdefault("tol", 1e-12)
    return robot.ik(pose, seed=seed, method="closed_form", **kw)


def max_abs(a):
    return float(np.max(np.abs(a), initial=0.0))


# ==========================================================================
# Input errors
# ==========================================================================
def test_reference_rejects_other_than_three_joints(ref):
    """The closed form exists only for n = 3: the reference raises ValueError."""
    two = reference_robot(PAPER_LINKAGES[:2])
    with pytest.raises(ValueError):
        ref.ik_closed_form(two, np.array([[0.1, 0.0, 0.0]]))


def test_rust_rejects_position_mask_other_n_and_unknown_method(cdsm):
    """closed_form needs the full pose of a 3-joint arm; unknown names are errors."""
    paper = cdsm.Robot.paper()
    pose = np.array([[0.2, 0.01, 0.05]])  # m, m, rad
    with pytest.raises(cdsm.CdsmInputError):
        paper.ik(pose, method="closed_form", mask="position")
    with pytest.raises(cdsm.CdsmInputError):
        paper.ik(pose, method="no_such_method")
    eight = cdsm.Robot.from_toml("python/cdsm/robots/serpentine8.toml")
    assert eight.n != 3
    with pytest.raises(cdsm.CdsmInputError):
        eight.ik(pose, method="closed_form")


# ==========================================================================
# (a) Parity with the independent reference
# ==========================================================================
@pytest.mark.parametrize("name", ["paper", "asym"])
@pytest.mark.parametrize("enforce", [False, True])
def test_parity_with_reference_random_batches(cdsm, ref, name, enforce):
    """Same branch (|dtheta| <= 1e-9 rad), same converged / reason / within_limits,
    residuals of the answers (m, rad) within 1e-14 of each other, iterations all 0.

    Poses: fk of uniform theta in +-40 deg, plus three out of reach; seeds:
    uniform in +-40 deg, the paper seed (0, -1e-3, 0) rad, uniform in +-10 rad."""
    from cdsm.accuracy.workspace import paper_ik_seed

    rust, rref = robot_pair(cdsm, name)
    rng = np.random.default_rng(11)
    pose = ref.fk(rref, rng.uniform(-LIM40, LIM40, (400, 3)))
    pose = np.vstack([pose, [[0.3, 0.0, 0.0], [0.0, 0.3, 1.0], [-0.2, -0.2, 2.0]]])
    seeds = [
        rng.uniform(-LIM40, LIM40, (pose.shape[0], 3)),
        np.asarray(paper_ik_seed(3), dtype=float),
        rng.uniform(-10.0, 10.0, (pose.shape[0], 3)),  # whole turns away: the wrapping
    ]
    for seed in seeds:
        got = solve(rust, pose, seed, enforce_limits=enforce)
        exp = ref.ik_closed_form(rref, pose, seed=seed, tol=1e-12, enforce_limits=enforce)
        assert got.theta.shape == (pose.shape[0], 3)
        assert max_abs(got.theta - exp["theta"]) <= ANGLE_TOL
        np.testing.assert_array_equal(got.converged, exp["converged"])
        np.testing.assert_array_equal(np.asarray(got.reason, dtype=str), exp["reason"].astype(str))
        np.testing.assert_array_equal(got.within_limits, exp["within_limits"])
        np.testing.assert_array_equal(got.iterations, 0)
        ok = exp["converged"]  # residuals of the answers: both at rounding level
        assert max_abs(got.residual[ok] - exp["residual"][ok]) <= 1e-14
        assert got.residual[ok].max() <= 1e-12
    assert not got.converged[-3:].any()  # the three far poses
    assert got.converged[:-3].sum() > 0


# ==========================================================================
# (b) Round trip: both branches reproduce the target
# ==========================================================================
@pytest.mark.parametrize("name", ["paper", "asym"])
def test_both_branches_reproduce_the_target(cdsm, ref, name):
    """fk of the answer (reference fk) is the target to 1e-12 m / rad; the elbow
    flip of the answer is the same pose, and a seed near the flip returns it."""
    rust, rref = robot_pair(cdsm, name)
    rng = np.random.default_rng(5)
    theta = rng.uniform(-LIM40, LIM40, (300, 3))
    theta = theta[np.abs(theta[:, 1]) > 0.05]  # keep the two branches apart (>= 0.1 rad)
    pose = ref.fk(rref, theta)
    near = solve(rust, pose, theta + rng.uniform(-0.01, 0.01, theta.shape))
    assert near.converged.all()
    assert max_abs(ref.fk(rref, near.theta) - pose) <= POSE_TOL
    assert max_abs(near.theta - theta) <= 1e-10  # the generating branch, not the flip
    assert near.residual.max() <= POSE_TOL

    flip = elbow_flip(rref, theta)
    assert max_abs(ref.fk(rref, flip) - pose) <= POSE_TOL  # the other solution of the same pose
    other = solve(rust, pose, flip + rng.uniform(-0.01, 0.01, flip.shape))
    assert other.converged.all()
    assert max_abs(other.theta - flip) <= 1e-10
    assert max_abs(ref.fk(rref, other.theta) - pose) <= POSE_TOL
    assert np.all(np.sign(other.theta[:, 1]) == -np.sign(near.theta[:, 1]))


# ==========================================================================
# (c) The paper's branch at Table 3
# ==========================================================================
def test_table3_paper_branch_and_lm_agree(cdsm, ref):
    """With the seed (0, -1e-3, 0) rad all nine commanded poses of Table 3 get
    theta_2 <= 0 (the paper's solutions) and the LM answer from that seed.

    The LM answer is exact only to its residual r <= 1e-12 (m, rad), so the two
    agree to 1e-9 rad plus r / sigma_min(J) (first order; sigma_min of the fk
    Jacobian, m/rad) — and at the stretched arm (point 1, J singular, the pose
    moves with the square of the bend) to 4 sqrt(r / min(r1, r2)) rad."""
    from cdsm.accuracy.workspace import paper_ik_seed

    robot = cdsm.Robot.paper()
    rref = reference_robot(PAPER_LINKAGES)
    pose = np.asarray(cdsm.calibration.measurements.packaged("table3").pose_cmd, dtype=float)
    seed = np.asarray(paper_ik_seed(3), dtype=float)
    np.testing.assert_array_equal(seed, [0.0, -1e-3, 0.0])
    cf = solve(robot, pose, seed)
    lm = robot.ik(pose, seed=seed)
    assert cf.converged.all() and lm.converged.all()
    assert np.all(cf.theta[:, 1] <= 0.0)
    assert max_abs(ref.fk(rref, cf.theta) - pose) <= POSE_TOL

    sigma_min = np.linalg.svd(ref.fk_jacobian(rref, cf.theta), compute_uv=False)[:, -1]
    r = np.maximum(lm.residual, 1e-16)
    bound = np.minimum(2.0 * r / sigma_min, 4.0 * np.sqrt(r / min(arm_radii(rref))))
    err = np.abs(cf.theta - lm.theta).max(axis=1)
    assert np.all(err <= ANGLE_TOL + bound), (err, bound)


# ==========================================================================
# (d) Tie rule
# ==========================================================================
def test_tie_goes_to_theta2_nonpositive(cdsm, ref):
    """A seed equally far (rad^2) from both branches gets theta_2 <= 0.

    1. Pose (x, 0, 0) with the wrist on the x axis and seed 0: the two branches
       are exact mirror images (theta and -theta), an exact tie.
    2. Tie band 1e-12 (1 + |seed|^2) rad^2: seed (0, d, 0) moves the squared
       distances apart by 4 |theta_2| d; d = 1e-14 rad stays a tie, d = 1e-9 rad
       picks the theta_2 > 0 branch.
    3. Random poses, seed = midpoint of the two branches (tie); pushed 1e-6 of
       the way towards the theta_2 > 0 branch it picks that one."""
    rust = cdsm.Robot.paper()
    rref = reference_robot(PAPER_LINKAGES)
    x = np.array([[0.15, 0.0, 0.0], [0.20, 0.0, 0.0], [0.225, 0.0, 0.0]])  # m, m, rad
    zero = np.zeros(3)
    tie = solve(rust, x, zero)
    assert tie.converged.all()
    assert np.all(tie.theta[:, 1] < 0.0)
    mirrored = solve(rust, x, zero + [0.0, 1e-9, 0.0])
    assert np.all(mirrored.theta[:, 1] > 0.0)
    assert max_abs(mirrored.theta + tie.theta) <= ANGLE_TOL
    in_band = solve(rust, x, zero + [0.0, 1e-14, 0.0])
    assert np.all(in_band.theta[:, 1] < 0.0)
    exp = ref.ik_closed_form(rref, x, seed=[0.0, 1e-14, 0.0])
    assert max_abs(in_band.theta - exp["theta"]) <= ANGLE_TOL

    rng = np.random.default_rng(3)
    theta = rng.uniform(-LIM40, LIM40, (200, 3))
    theta[:, 1] = np.abs(theta[:, 1]) + 0.05  # rad, the theta_2 > 0 branch
    pose = ref.fk(rref, theta)
    flip = elbow_flip(rref, theta)  # the theta_2 < 0 branch
    mid = 0.5 * (theta + flip)
    at_mid = solve(rust, pose, mid)
    assert max_abs(at_mid.theta - flip) <= 1e-10
    pushed = solve(rust, pose, mid + 1e-6 * (theta - flip))
    assert max_abs(pushed.theta - theta) <= 1e-10


# ==========================================================================
# (e) Out of reach
# ==========================================================================
def test_unreachable_keeps_the_seed(cdsm, ref):
    """A wrist beyond r1 + r2 from joint 1 has no solution: not converged, reason
    "unreachable", theta is the seed (rad) — nothing clamped onto the boundary,
    even 1 nm beyond the stretched arm."""
    rust = cdsm.Robot.paper()
    rref = reference_robot(PAPER_LINKAGES)
    reach = float(ref.fk(rref, np.zeros((1, 3)))[0, 0])  # m, the stretched arm
    pose = np.array([[0.3, 0.0, 0.0], [reach + 1e-9, 0.0, 0.0], [0.0, -0.25, -1.0]])
    seed = np.array([[0.1, -0.2, 0.3], [0.0, -1e-3, 0.0], [-0.4, 0.2, 0.1]])
    sol = solve(rust, pose, seed)
    assert not sol.converged.any()
    assert list(np.asarray(sol.reason, dtype=str)) == ["unreachable"] * 3
    np.testing.assert_array_equal(sol.theta, seed)
    np.testing.assert_array_equal(sol.iterations, 0)
    assert np.all(sol.residual > 0)  # the seed misses the target (its residual: the next test)
    with_limits = solve(rust, pose, seed, enforce_limits=True)
    assert list(np.asarray(with_limits.reason, dtype=str)) == ["unreachable"] * 3
    np.testing.assert_array_equal(with_limits.theta, seed)


def test_unreachable_residual_is_that_of_the_seed(cdsm, ref):
    """docs/model.md: residual = max |fk(theta) - target| (m, rad) with theta the
    returned angles, which for an unreachable pose are the seed: a finite number."""
    rust = cdsm.Robot.paper()
    rref = reference_robot(PAPER_LINKAGES)
    pose = np.array([[0.3, 0.0, 0.0], [0.0, -0.25, -1.0]])
    seed = np.array([[0.1, -0.2, 0.3], [-0.4, 0.2, 0.1]])
    sol = solve(rust, pose, seed)
    expected = np.abs(ref.fk(rref, seed) - pose).max(axis=1)
    np.testing.assert_allclose(sol.residual, expected, rtol=0, atol=1e-15)


# ==========================================================================
# (f) Joint limits
# ==========================================================================
def test_enforce_limits_drops_the_branch_outside(cdsm, ref):
    """Limits +-35 deg.  Row 0: the branch nearest the seed is outside
    (theta_1 = 0.7 rad), its elbow flip inside: enforce_limits returns the flip,
    converged.  Row 1: both branches outside: the nearest is returned, not
    converged, reason "outside limits".  Without enforce_limits the nearest is
    returned in both rows, converged, flagged by within_limits = False."""
    rust = cdsm.Robot.paper()
    rref = reference_robot(PAPER_LINKAGES)
    np.testing.assert_allclose(rust.joint_limits, [[-LIM35, LIM35]] * 3, rtol=0, atol=1e-15)
    inside = np.array([0.4, 0.3, 0.0])  # rad
    out1 = elbow_flip(rref, inside[None])[0]  # (0.7, -0.3, 0.3) for r1 = r2
    out2a = np.array([0.7, 0.3, -0.5])
    out2b = elbow_flip(rref, out2a[None])[0]
    assert np.all(np.abs(inside) <= LIM35) and np.abs(out1).max() > LIM35
    assert np.abs(out2a).max() > LIM35 and np.abs(out2b).max() > LIM35
    pose = ref.fk(rref, np.stack([inside, out2a]))
    seed = np.stack([out1, out2a])  # nearest branch: the one outside

    free = solve(rust, pose, seed)
    assert free.converged.all()
    assert list(np.asarray(free.reason, dtype=str)) == ["converged"] * 2
    assert max_abs(free.theta - seed) <= 1e-10
    np.testing.assert_array_equal(free.within_limits, [False, False])

    lim = solve(rust, pose, seed, enforce_limits=True)
    np.testing.assert_array_equal(lim.converged, [True, False])
    assert list(np.asarray(lim.reason, dtype=str)) == ["converged", "outside limits"]
    assert max_abs(lim.theta[0] - inside) <= 1e-10
    assert max_abs(lim.theta[1] - out2a) <= 1e-10  # nearest of the two, not clamped
    np.testing.assert_array_equal(lim.within_limits, [True, False])
    assert max_abs(ref.fk(rref, lim.theta) - pose) <= POSE_TOL  # both still reproduce the pose


# ==========================================================================
# (g) Whole turns
# ==========================================================================
def test_whole_turns_follow_the_seed(cdsm, ref):
    """Whole turns (2 pi rad) of the seed carry over to the answer.

    1. Seed + (2 pi k, 0, -2 pi k) or (0, 2 pi k, -2 pi k): the same arm, the
       same phi; the answer moves by the same turns (1e-12 rad per turn).
    2. Seed + 2 pi on joint 1 (or 2) only: theta_1 (theta_2) takes the turn,
       theta_3 = phi - theta_1 - theta_2 takes the opposite one, the sum is the
       target phi (not wrapped) to 1e-12 rad, and the answer is one of the two
       branches of the unshifted solve (the branch itself may change: the turn
       of theta_3 enters the squared distance to the seed) — as in the reference.
    3. Target phi + 2 pi: theta_3 takes the turn."""
    rust = cdsm.Robot.paper()
    rref = reference_robot(PAPER_LINKAGES)
    rng = np.random.default_rng(9)
    theta = rng.uniform(-LIM40, LIM40, (100, 3))
    theta = theta[np.abs(theta[:, 1]) > 0.02]  # two distinct branches
    pose = ref.fk(rref, theta)
    seed = theta + rng.uniform(-0.01, 0.01, theta.shape)
    base = solve(rust, pose, seed)
    assert base.converged.all()
    flip = elbow_flip(rref, base.theta)  # the other branch, same turns of theta_1, theta_2
    two_pi = 2.0 * np.pi
    for k, turns in [(0, 1), (0, -2), (1, 1), (1, -1)]:
        shift = np.zeros(3)
        shift[k] = turns * two_pi
        shift[2] = -turns * two_pi
        same_arm = solve(rust, pose, seed + shift)
        assert same_arm.converged.all()
        assert max_abs(same_arm.theta - (base.theta + shift)) <= 1e-12 * (1 + abs(turns))

        shift[2] = 0.0
        moved = solve(rust, pose, seed + shift)
        assert moved.converged.all()
        assert max_abs(moved.theta.sum(axis=1) - pose[:, 2]) <= 1e-12
        d = moved.theta[:, :2] - (seed + shift)[:, :2]
        assert np.all((d > -np.pi) & (d <= np.pi))
        unshifted = moved.theta - shift + [0.0, 0.0, shift[k]]
        same = np.sign(unshifted[:, 1]) == np.sign(base.theta[:, 1])
        branch = np.where(same[:, None], base.theta, flip)
        assert max_abs(unshifted - branch) <= 1e-10
        exp = ref.ik_closed_form(rref, pose, seed=seed + shift)
        assert max_abs(moved.theta - exp["theta"]) <= ANGLE_TOL

    spun = pose + [0.0, 0.0, two_pi]  # same physical pose, phi one turn more
    turned = solve(rust, spun, seed + [0.0, 0.0, two_pi])
    assert turned.converged.all()
    # cos/sin of phi + 2 pi differ from those of phi by rounding: 1e-10 rad
    assert max_abs(turned.theta - base.theta - [0.0, 0.0, two_pi]) <= 1e-10
    assert max_abs(turned.theta.sum(axis=1) - spun[:, 2]) <= 1e-12


# ==========================================================================
# The reference on its own (runs without the compiled extension)
# ==========================================================================
@pytest.mark.parametrize("linkages", [PAPER_LINKAGES, ASYM_LINKAGES])
def test_reference_reproduces_the_pose_and_is_exhaustive(ref, linkages):
    """The reference's answer reproduces the target (1e-12 m, rad) and is the
    generating theta or its elbow flip (1e-10 rad), whichever is nearer the seed."""
    rref = reference_robot(linkages)
    rng = np.random.default_rng(21)
    theta = rng.uniform(-LIM40, LIM40, (300, 3))
    theta = theta[np.abs(theta[:, 1]) > 0.02]
    pose = ref.fk(rref, theta)
    seed = rng.uniform(-LIM40, LIM40, theta.shape)
    sol = ref.ik_closed_form(rref, pose, seed=seed)
    assert sol["converged"].all()
    assert max_abs(ref.fk(rref, sol["theta"]) - pose) <= POSE_TOL
    flip = elbow_flip(rref, theta)
    nearer = np.where(
        (((theta - seed) ** 2).sum(axis=1) <= ((flip - seed) ** 2).sum(axis=1))[:, None], theta, flip
    )
    assert max_abs(sol["theta"] - nearer) <= 1e-10
