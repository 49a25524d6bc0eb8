"""Parity of the Rust core (``cdsm.Robot``) with the NumPy reference.

Tolerances: forward maps (pose, cable lengths, Jacobians) <= 1e-12 in SI
units (m, rad, m/rad); solved joint angles <= 1e-10 rad.  Both
implementations run the same algorithms of ``docs/model.md``, so the solves
are compared element by element, and both must flag the same elements as
converged.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import (
    LIM35,
    N12_LINKAGES,
    N1_LINKAGES,
    PAPER_LINKAGES,
    TABLE3_DL,
    TABLE3_POINTS,
    TABLE3_SEED,
    TABLE3_THEORETICAL_MM,
    hole_perturbation,
    make_pair,
    random_theta,
    reference_robot,
    robot_toml,
)

FWD_TOL = 1e-12  # m, rad, m/rad
ANGLE_TOL = 1e-10  # rad


def assert_close(actual, expected, tol, what=""):
    actual = np.asarray(actual, dtype=float)
    expected = np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    err = np.max(np.abs(actual - expected), initial=0.0)
    assert err <= tol, f"{what}: max abs error {err:.3e} > {tol:.1e}"


def straight_cable_lengths(linkages):
    """Cable lengths (2n,) m at theta = 0 for straight holes: the sum of
    link_before + link_after + thickness over the linkages each pair crosses."""
    per = np.array([lk.link_before + lk.link_after + lk.thickness for lk in linkages])
    cum = np.cumsum(per)
    return np.repeat(cum, 2)


# ==========================================================================
# The reference on its own (runs without the compiled extension)
# ==========================================================================
class TestReferenceAlone:
    @pytest.mark.parametrize("linkages", [PAPER_LINKAGES, N1_LINKAGES, N12_LINKAGES])
    def test_jacobians_match_central_differences(self, ref, linkages):
        robot = reference_robot(linkages)
        robot = robot.with_planar_holes(robot.planar.holes + hole_perturbation(robot.n, 3e-4, seed=3))
        theta = random_theta(robot.n, N=50, seed=1)
        h = 1e-6
        fd_fk = np.empty((50, 3, robot.n))
        fd_l = np.empty((50, 2 * robot.n, robot.n))
        for j in range(robot.n):
            e = np.zeros(robot.n)
            e[j] = h
            fd_fk[:, :, j] = (ref.fk(robot, theta + e) - ref.fk(robot, theta - e)) / (2 * h)
            fd_l[:, :, j] = (
                ref.cable_lengths(robot, theta + e) - ref.cable_lengths(robot, theta - e)
            ) / (2 * h)
        assert_close(ref.fk_jacobian(robot, theta), fd_fk, 1e-8, "fk jacobian vs FD")
        assert_close(ref.cable_jacobian(robot, theta), fd_l, 1e-8, "cable jacobian vs FD")

    def test_pqr_form_equals_direct_lengths(self, ref):
        """The closed-form coefficients P, Q, R reproduce the segment lengths."""
        robot = reference_robot(PAPER_LINKAGES)
        robot = robot.with_planar_holes(robot.planar.holes + hole_perturbation(3, 3e-4, seed=4))
        theta = random_theta(3, N=20, seed=2)
        P, Q, R, mask = ref.segment_coefficients(robot)
        s2 = P + Q * np.cos(theta)[:, None, :] + R * np.sin(theta)[:, None, :]
        s = ref.segment_lengths(robot, theta)  # the chain's gaps |A_k - B_(k-1)|
        assert_close(np.where(mask, np.sqrt(s2), 0.0), s, 1e-15, "sqrt(P+Qc+Rs)")

    def test_straight_invariants(self, ref):
        for linkages in (PAPER_LINKAGES, N1_LINKAGES, N12_LINKAGES):
            robot = reference_robot(linkages)
            zero = np.zeros((1, robot.n))
            total = sum(lk.link_before + lk.link_after + lk.thickness for lk in linkages)
            assert_close(ref.fk(robot, zero)[0], [total, 0.0, 0.0], 1e-15, "fk(0)")
            assert_close(
                ref.cable_lengths(robot, zero)[0], straight_cable_lengths(linkages), 1e-15, "L(0)"
            )

    def test_table3_theoretical_column(self, ref):
        robot = ref.Robot.paper()
        seed = np.tile(TABLE3_SEED, (9, 1))
        sol = ref.ik(robot, TABLE3_POINTS, seed=seed)
        assert sol["converged"].all()
        dev = ref.deviation(robot, sol["theta"], TABLE3_DL)
        assert dev["converged"].all()
        assert_close(dev["dS"][:, :2] * 1e3, TABLE3_THEORETICAL_MM, 2e-4, "Table 3 (mm)")
        cf = ref.solve_cables_closed_form(
            robot, ref.position_lengths(robot, sol["theta"]) + TABLE3_DL, seed=sol["theta"]
        )
        assert cf["converged"].all()
        assert (cf["n_branches"] == 2).all()
        assert_close(cf["theta"], dev["theta"], ANGLE_TOL, "closed form vs LM")

    def test_table3_zero_seed_takes_mirror_branch_at_points_8_9(self, ref):
        robot = ref.Robot.paper()
        sol = ref.ik(robot, TABLE3_POINTS)
        assert sol["converged"].all()
        dS = ref.deviation(robot, sol["theta"], TABLE3_DL)["dS"][:, :2] * 1e3
        err = np.abs(dS - TABLE3_THEORETICAL_MM).max(axis=1)
        assert (err[:7] <= 2e-4).all(), err
        assert (err[7:] > 0.01).all(), err
        assert (sol["theta"][7:, 1] > 0).all()  # the mirror image theta_2 >= 0

    def test_hole_height_error(self, ref):
        robot = ref.Robot.paper()
        holes = ref.hole_height_error(robot, [3.5e-4, 0.0, -1e-4]).planar.holes
        mask = ref.used_hole_mask(3)
        d = holes - robot.planar.holes
        assert (d[..., 0] == 0).all()
        assert (d[~mask] == 0).all()
        np.testing.assert_allclose(d[0][mask[0], 1], 3.5e-4, atol=1e-18)
        np.testing.assert_allclose(d[1][mask[1], 1], -3.5e-4, atol=1e-18)
        assert (d[2:4] == 0).all()
        np.testing.assert_allclose(d[5][mask[5], 1], 1e-4, atol=1e-18)


# ==========================================================================
# Robot description
# ==========================================================================
def test_paper_robot_is_table_1(cdsm, ref):
    robot = cdsm.Robot.paper()
    expected = ref.Robot.paper().planar
    assert robot.n == 3
    for attr in ("link_before", "link_after", "thickness", "joint_limits", "lower_tension", "mass"):
        assert_close(getattr(robot, attr), getattr(expected, attr), 0.0, attr)
    mask = ref.used_hole_mask(3)
    holes = np.asarray(robot.holes)
    assert holes.shape == (6, 4, 2, 2)
    assert_close(holes[mask], expected.holes[mask], 0.0, "holes (used entries)")


@pytest.mark.parametrize("linkages", [N1_LINKAGES, N12_LINKAGES], ids=["n1", "n12"])
def test_toml_robot_attributes(cdsm, ref, linkages):
    robot = cdsm.Robot.from_toml_str(robot_toml(linkages))
    expected = reference_robot(linkages).planar
    n = len(linkages)
    assert robot.n == n
    for attr, shape in [
        ("link_before", (n,)),
        ("link_after", (n,)),
        ("thickness", (n,)),
        ("joint_limits", (n, 2)),
        ("holes", (2 * n, n + 1, 2, 2)),
    ]:
        value = np.asarray(getattr(robot, attr))
        assert value.shape == shape, attr
        assert value.dtype == np.float64, attr
    for attr in ("link_before", "link_after", "thickness", "joint_limits"):
        assert_close(getattr(robot, attr), getattr(expected, attr), 0.0, attr)
    mask = ref.used_hole_mask(n)
    assert_close(np.asarray(robot.holes)[mask], expected.holes[mask], 0.0, "holes")


def test_from_toml_path_equals_from_toml_str(cdsm, tmp_path):
    text = robot_toml(PAPER_LINKAGES)
    path = tmp_path / "robot.toml"
    path.write_text(text)
    a = cdsm.Robot.from_toml(str(path))
    b = cdsm.Robot.from_toml_str(text)
    for attr in ("link_before", "link_after", "thickness", "holes", "joint_limits"):
        assert_close(getattr(a, attr), getattr(b, attr), 0.0, attr)


def test_with_holes_round_trip(cdsm):
    robot = cdsm.Robot.paper()
    holes = np.asarray(robot.holes) + hole_perturbation(3, 3e-4, seed=11)
    other = robot.with_holes(holes)
    assert_close(other.holes, holes, 0.0, "with_holes(holes).holes")
    # the original is untouched
    assert_close(robot.holes, cdsm.Robot.paper().holes, 0.0, "original holes")
    assert_close(other.link_before, robot.link_before, 0.0, "link_before")


# ==========================================================================
# Forward maps
# ==========================================================================
def test_fk_parity(pair, ref):
    theta = random_theta(pair.ref.n, seed=21)
    assert_close(pair.rust.fk(theta), ref.fk(pair.ref, theta), FWD_TOL, f"{pair.name} fk")


def test_cable_lengths_parity(pair, ref):
    theta = random_theta(pair.ref.n, seed=22)
    assert_close(
        pair.rust.cable_lengths(theta),
        ref.cable_lengths(pair.ref, theta),
        FWD_TOL,
        f"{pair.name} cable lengths",
    )


def test_fk_jacobian_parity(pair, ref):
    theta = random_theta(pair.ref.n, seed=23)
    assert_close(
        pair.rust.fk_jacobian(theta),
        ref.fk_jacobian(pair.ref, theta),
        FWD_TOL,
        f"{pair.name} fk jacobian",
    )


def test_cable_jacobian_parity(pair, ref):
    theta = random_theta(pair.ref.n, seed=24)
    jac = np.asarray(pair.rust.cable_jacobian(theta))
    assert_close(jac, ref.cable_jacobian(pair.ref, theta), FWD_TOL, f"{pair.name} cable jac")
    # cable c of pair i depends on theta_1..theta_i only
    n = pair.ref.n
    pair_of = np.arange(2 * n) // 2
    upper_tri = np.arange(n)[None, :] > pair_of[:, None]
    assert (jac[:, upper_tri] == 0.0).all()


@pytest.mark.parametrize(
    "kind", ["zero", "lower_limits", "upper_limits", "alternating_limits", "tiny", "tiny_negative"]
)
def test_forward_edge_cases(pair, ref, kind):
    n = pair.ref.n
    lo, hi = pair.ref.joint_limits[:, 0], pair.ref.joint_limits[:, 1]
    theta = {
        "zero": np.zeros(n),
        "lower_limits": lo,
        "upper_limits": hi,
        "alternating_limits": np.where(np.arange(n) % 2 == 0, lo, hi),
        "tiny": np.full(n, 1e-9),
        "tiny_negative": np.where(np.arange(n) % 2 == 0, -1e-9, 1e-9),
    }[kind][None, :]
    for fn in ("fk", "cable_lengths", "fk_jacobian", "cable_jacobian"):
        assert_close(
            getattr(pair.rust, fn)(theta),
            getattr(ref, fn)(pair.ref, theta),
            FWD_TOL,
            f"{pair.name} {fn} at {kind}",
        )


# ==========================================================================
# Physical invariants
# ==========================================================================
@pytest.mark.parametrize(
    "name,linkages", [("paper", PAPER_LINKAGES), ("n1", N1_LINKAGES), ("n12", N12_LINKAGES)]
)
def test_straight_pose_invariants(cdsm, name, linkages):
    robot = make_pair(cdsm, name).rust
    n = len(linkages)
    zero = np.zeros((1, n))
    total = sum(lk.link_before + lk.link_after + lk.thickness for lk in linkages)
    assert_close(robot.fk(zero)[0], [total, 0.0, 0.0], 1e-15, "fk(0) = (sum of lengths, 0, 0)")
    assert_close(
        robot.cable_lengths(zero)[0], straight_cable_lengths(linkages), 1e-15, "L(0) = sums"
    )
    # at theta = 0 the upper and lower cable of a pair change in opposite
    # directions by the same first-order amount
    jac = np.asarray(robot.cable_jacobian(zero))[0]
    assert_close(jac[0::2], -jac[1::2], 1e-15, "dL_upper = -dL_lower at theta = 0")


def test_upper_and_lower_change_oppositely(cdsm):
    robot = cdsm.Robot.paper()
    rng = np.random.default_rng(5)
    dtheta = rng.uniform(-1e-4, 1e-4, (200, 3))
    L0 = robot.cable_lengths(np.zeros((1, 3)))
    dL = robot.cable_lengths(dtheta) - L0
    up, low = dL[:, 0::2], dL[:, 1::2]
    scale = np.abs(up).max()
    # first order cancels: the sum is second order in |dtheta| (~1e-8 rad^2 * m)
    assert np.abs(up + low).max() <= 1e-3 * scale
    big = np.abs(up) > 1e-2 * scale
    assert (np.sign(up[big]) == -np.sign(low[big])).all()
    # and within +-35 deg the upper cables shorten, the lower lengthen, as a
    # joint they cross bends positively (straight holes)
    jac = np.asarray(robot.cable_jacobian(random_theta(3, seed=6)))
    crossed = np.arange(3)[None, :] <= (np.arange(6) // 2)[:, None]
    assert (jac[:, 0::2][:, crossed[0::2]] < 0).all()
    assert (jac[:, 1::2][:, crossed[1::2]] > 0).all()


# ==========================================================================
# Pose IK
# ==========================================================================
def _rounding_spread(pair, pose, seed, rows, kw, tries=4):
    """``(N,)`` rad: for the ``rows``, the largest change of the core's IK answer when
    every seed angle moves by one ulp up or down (at random, ``tries`` times); 0 elsewhere."""
    spread = np.zeros(len(pose))
    if rows.size == 0:
        return spread
    base = np.zeros((len(pose), pair.ref.n)) if seed is None else np.asarray(seed, dtype=float)
    theta0 = np.asarray(pair.rust.ik(pose[rows], seed=base[rows], **kw).theta)
    rng = np.random.default_rng(0)
    for _ in range(tries):
        up = rng.random(base[rows].shape) < 0.5
        nudged = np.where(up, np.nextafter(base[rows], np.inf), np.nextafter(base[rows], -np.inf))
        moved = np.asarray(pair.rust.ik(pose[rows], seed=nudged, **kw).theta)
        spread[rows] = np.maximum(spread[rows], np.abs(moved - theta0).max(axis=1))
    return spread


def _ik_parity(pair, ref, pose, seed, what, **kw):
    sol = pair.rust.ik(pose, seed=seed, **kw)
    expected = ref.ik(pair.ref, pose, seed=seed, **kw)
    conv = np.asarray(sol.converged)
    assert conv.dtype == np.bool_
    np.testing.assert_array_equal(conv, expected["converged"], err_msg=f"{what}: converged")
    theta = np.asarray(sol.theta)
    # a converged row of a redundant arm stops somewhere on its pose's set of
    # configurations, and where depends on rounding along its path: on the
    # 12-joint arm from far seeds the core itself moves such a row's answer by
    # up to 5e-10 rad when its seed moves by one ulp (31 steps along a singular
    # value of 0.04). A row the core does not reproduce to ANGLE_TOL under one-ulp
    # changes of its seed is compared to twice that spread (two paths, each within
    # it of a third); every other row to the full tolerance
    err = np.abs(theta - expected["theta"]).max(axis=1)
    spread = _rounding_spread(pair, pose, seed, np.flatnonzero(conv & (err > ANGLE_TOL)), kw)
    undetermined = spread > ANGLE_TOL
    assert_close(theta[conv & ~undetermined], expected["theta"][conv & ~undetermined], ANGLE_TOL, f"{what}: theta")
    assert (err[undetermined] <= 2.0 * spread[undetermined]).all(), (f"{what}: theta beyond twice the core's own "
                                                                     f"rounding spread", err[undetermined],
                                                                     spread[undetermined])
    # a row both leave unconverged at max_iter with an angle held on the joint
    # box (limits enforced) is a search that crept along the bound, and
    # where it stopped depends on rounding (poses out of reach within the box:
    # the 2-joint arm's such rows end up to 3.3e-5 rad apart): 1e-3 rad;
    # every other row to the full tolerance
    lo, hi = pair.ref.joint_limits.T
    max_iter = kw.get("max_iter", 100)
    crept = (~conv & bool(kw.get("enforce_limits"))
             & np.any((theta == lo) | (theta == hi), axis=1)
             & np.any((expected["theta"] == lo) | (expected["theta"] == hi), axis=1)
             & (np.asarray(sol.iterations) == max_iter) & (expected["iterations"] == max_iter))
    assert_close(theta[crept], expected["theta"][crept], 1e-3, f"{what}: theta crept along the box")
    rest = ~conv & ~crept
    assert_close(theta[rest], expected["theta"][rest], ANGLE_TOL, f"{what}: unconverged theta")
    np.testing.assert_array_equal(
        np.asarray(sol.within_limits), expected["within_limits"], err_msg=f"{what}: limits"
    )
    it = np.asarray(sol.iterations)
    assert (it >= 0).all() and (it <= kw.get("max_iter", 100)).all()
    res = np.asarray(sol.residual)
    tol = kw.get("tol", 1e-12)
    assert (res[conv] <= tol).all()
    return sol, expected


@pytest.mark.parametrize("seed_kind", ["near", "far", "default"])
def test_ik_parity(pair, ref, seed_kind):
    n = pair.ref.n
    rng = np.random.default_rng(31)
    theta_true = random_theta(n, seed=32)
    pose = ref.fk(pair.ref, theta_true)
    seed = {
        "near": theta_true + rng.normal(0.0, 0.02, theta_true.shape),
        "far": rng.uniform(-LIM35, LIM35, theta_true.shape),
        "default": None,
    }[seed_kind]
    sol, expected = _ik_parity(pair, ref, pose, seed, f"{pair.name} ik {seed_kind}")
    assert expected["converged"].mean() >= 0.95
    # every converged answer really reaches the pose
    conv = expected["converged"]
    assert_close(pair.rust.fk(sol.theta)[conv], pose[conv], 1e-12, "fk(ik(pose))")


@pytest.mark.parametrize("mask", ["position", [1.0, 0.5, 2.0], [0.0, 1.0, 1.0]], ids=["position", "weights", "y-phi"])
def test_ik_mask_parity(pair, ref, mask):
    """The task masks of a planar arm: a name or weights on the x, y, phi residuals
    (0: the coordinate is free), seeded near the answer."""
    n = pair.ref.n
    theta_true = random_theta(n, N=200, seed=37)
    pose = ref.fk(pair.ref, theta_true)
    seed = theta_true + np.random.default_rng(38).normal(0.0, 0.02, theta_true.shape)
    sol, expected = _ik_parity(pair, ref, pose, seed, f"{pair.name} ik mask {mask}", mask=mask)
    assert expected["converged"].mean() >= 0.95
    w = np.array([1.0, 1.0, 0.0]) if mask == "position" else np.asarray(mask)
    conv = expected["converged"]
    reached = np.abs(ref.fk(pair.ref, expected["theta"]) - pose)[conv][:, w != 0]
    assert reached.max() <= 1e-12 / w[w != 0].min()


def test_ik_iteration_counts_match(pair, ref):
    """Same LM, same lambda schedule: the trial counts should agree."""
    theta_true = random_theta(pair.ref.n, N=200, seed=33)
    pose = ref.fk(pair.ref, theta_true)
    sol = pair.rust.ik(pose)
    expected = ref.ik(pair.ref, pose)
    it, it_ref = np.asarray(sol.iterations), expected["iterations"]
    agree = np.mean(it == it_ref)
    assert agree >= 0.99, (f"iterations agree on {agree:.1%}; first diffs {it[it != it_ref][:5]} "
                           f"vs {it_ref[it != it_ref][:5]}")


def test_ik_enforce_limits_parity(pair, ref):
    n = pair.ref.n
    rng = np.random.default_rng(34)
    theta_true = random_theta(n, N=200, seed=35)
    pose = ref.fk(pair.ref, theta_true)
    seed = np.clip(theta_true + rng.normal(0, 0.02, theta_true.shape), *pair.ref.joint_limits.T)
    sol, _ = _ik_parity(pair, ref, pose, seed, f"{pair.name} ik enforce", enforce_limits=True)
    assert np.asarray(sol.within_limits).all()


def test_ik_at_joint_limits(pair, ref):
    """Poses reached exactly at the joint limits: projected LM lands on the box."""
    n = pair.ref.n
    lo, hi = pair.ref.joint_limits[:, 0], pair.ref.joint_limits[:, 1]
    theta = np.stack([lo, hi, np.where(np.arange(n) % 2 == 0, lo, hi)])
    pose = ref.fk(pair.ref, theta)
    seed = 0.9 * theta
    sol, _ = _ik_parity(pair, ref, pose, seed, f"{pair.name} ik at limits", enforce_limits=True)
    if n <= 3:  # not redundant: the answer is the limit configuration itself
        assert np.asarray(sol.converged).all()
        assert np.asarray(sol.within_limits).all()
        assert_close(sol.theta, theta, 1e-9, "theta at limits")


def test_ik_near_singular(pair, ref):
    """Tiny angles: near the straight (singular) pose both still converge."""
    n = pair.ref.n
    theta = np.array([np.full(n, 1e-9), np.where(np.arange(n) % 2 == 0, -1e-9, 1e-9), np.zeros(n)])
    pose = ref.fk(pair.ref, theta)
    for seed in (None, theta + 1e-3):
        sol = pair.rust.ik(pose, seed=seed)
        expected = ref.ik(pair.ref, pose, seed=seed)
        assert np.asarray(sol.converged).all() and expected["converged"].all()
        # the X row of the Jacobian vanishes here: angles are only fixed to
        # ~sqrt(tol / length), so compare the poses, and the angles loosely
        assert_close(pair.rust.fk(sol.theta), pose, 1e-12, "fk(ik) near singular")
        assert_close(sol.theta, expected["theta"], 1e-5, "theta near singular")


def test_ik_single_pose_1d(cdsm, ref):
    robot = cdsm.Robot.paper()
    theta = np.array([0.1, -0.2, 0.3])
    pose = ref.fk(ref.Robot.paper(), theta[None])[0]
    sol = robot.ik(pose, seed=theta + 0.01)
    assert np.asarray(sol.theta).shape == (3,)
    assert bool(np.asarray(sol.converged))
    assert_close(sol.theta, theta, 1e-9, "1-D ik")


def test_failed_ik_is_flagged_not_raised(pair, ref):
    n = pair.ref.n
    unreachable = np.array([[2.0, 0.0, 0.0], [0.0, -2.0, 0.5]])  # beyond the arm's reach
    sol = pair.rust.ik(unreachable)
    expected = ref.ik(pair.ref, unreachable)
    assert not np.asarray(sol.converged).any()
    assert not expected["converged"].any()
    assert np.isfinite(np.asarray(sol.theta)).all()
    assert np.asarray(sol.theta).shape == (2, n)
    # a budget too small to finish is also just a flag
    theta_true = random_theta(n, N=20, seed=36)
    pose = ref.fk(pair.ref, theta_true)
    sol = pair.rust.ik(pose, max_iter=1)
    assert (np.asarray(sol.iterations) <= 1).all()
    np.testing.assert_array_equal(
        np.asarray(sol.converged), ref.ik(pair.ref, pose, max_iter=1)["converged"]
    )


# ==========================================================================
# Cable solve
# ==========================================================================
@pytest.mark.parametrize("method", ["newton", "closed_form", "auto"])
@pytest.mark.parametrize("seed_kind", ["default", "near"])
def test_solve_cables_parity(pair, ref, method, seed_kind):
    n = pair.ref.n
    theta_true = random_theta(n, seed=41)
    upper = ref.position_lengths(pair.ref, theta_true)
    seed = None
    if seed_kind == "near":
        seed = theta_true + np.random.default_rng(42).normal(0.0, 0.02, theta_true.shape)
    sol = pair.rust.solve_cables(upper, seed=seed, method=method)
    if method in ("closed_form", "auto"):  # auto = verified closed form, LM fallback
        expected = ref.solve_cables_closed_form(pair.ref, upper, seed=seed)
    else:
        expected = ref.solve_cables(pair.ref, upper, seed=seed)
    what = f"{pair.name} solve_cables {method} {seed_kind}"
    assert np.asarray(sol.converged).all(), what
    assert expected["converged"].all(), what
    assert_close(sol.theta, expected["theta"], ANGLE_TOL, what)
    # cable lengths determine the angles uniquely within +-35 deg here
    assert_close(sol.theta, theta_true, 1e-9, what + " vs truth")
    assert (np.asarray(sol.residual) <= 1e-12).all()


@pytest.mark.parametrize("kind", ["zero", "limits", "tiny"])
@pytest.mark.parametrize("method", ["newton", "closed_form"])
def test_solve_cables_edge_cases(pair, ref, kind, method):
    n = pair.ref.n
    lo, hi = pair.ref.joint_limits[:, 0], pair.ref.joint_limits[:, 1]
    theta = {
        "zero": np.zeros((1, n)),
        "limits": np.stack([lo, hi, np.where(np.arange(n) % 2 == 0, lo, hi)]),
        "tiny": np.stack([np.full(n, 1e-9), np.full(n, -1e-9)]),
    }[kind]
    upper = ref.position_lengths(pair.ref, theta)
    sol = pair.rust.solve_cables(upper, method=method)
    assert np.asarray(sol.converged).all()
    assert_close(sol.theta, theta, 1e-9, f"{pair.name} {method} {kind}")
    if method == "newton":
        assert_close(sol.theta, ref.solve_cables(pair.ref, upper)["theta"], ANGLE_TOL, "parity")
    else:
        assert_close(
            sol.theta, ref.solve_cables_closed_form(pair.ref, upper)["theta"], ANGLE_TOL, "parity"
        )


@pytest.mark.parametrize("method", ["newton", "closed_form"])
def test_failed_cable_solve_is_flagged(pair, ref, method):
    n = pair.ref.n
    straight = ref.position_lengths(pair.ref, np.zeros((1, n)))
    upper = np.vstack([0.05 * straight, straight + 0.05])  # shorter than a disk / too long
    sol = pair.rust.solve_cables(upper, method=method)
    assert not np.asarray(sol.converged).any()
    expected = (
        ref.solve_cables(pair.ref, upper)
        if method == "newton"
        else ref.solve_cables_closed_form(pair.ref, upper)
    )
    assert not expected["converged"].any()


# ==========================================================================
# The seed paper's Table 3 through the Rust path
# ==========================================================================
def _table3_rust(robot, seed, method):
    seed = None if seed is None else np.tile(seed, (9, 1))
    sol0 = robot.ik(TABLE3_POINTS, seed=seed)
    assert np.asarray(sol0.converged).all()
    theta0 = np.asarray(sol0.theta)
    upper = np.asarray(robot.cable_lengths(theta0))[:, 0::2] + TABLE3_DL
    sol = robot.solve_cables(upper, seed=theta0, method=method)
    assert np.asarray(sol.converged).all()
    dS = np.asarray(robot.fk(sol.theta)) - np.asarray(robot.fk(theta0))
    return dS[:, :2] * 1e3, sol0


@pytest.mark.parametrize("method", ["newton", "closed_form", "auto"])
def test_table3_theoretical_column(cdsm, method):
    dS_mm, _ = _table3_rust(cdsm.Robot.paper(), TABLE3_SEED, method)
    assert_close(dS_mm, TABLE3_THEORETICAL_MM, 2e-4, f"Table 3 (mm) via {method}")


def test_table3_zero_seed_misses_points_8_and_9(cdsm):
    """Documented fact (docs/model.md): the mirror-symmetric solve from theta = 0
    takes the theta_2 >= 0 branch for Y > 0 and misses points 8 and 9."""
    dS_mm, sol0 = _table3_rust(cdsm.Robot.paper(), None, "newton")
    err = np.abs(dS_mm - TABLE3_THEORETICAL_MM).max(axis=1)
    assert (err[:7] <= 2e-4).all(), err
    assert (err[7:] > 0.01).all(), err
    assert (np.asarray(sol0.theta)[7:, 1] > 0).all()


def test_table3_joint_limit_flags(cdsm, ref):
    """Points 2, 3, 4, 5, 8 and 9 need up to 40.6 deg > 35 deg; 1, 6, 7 do not."""
    robot = cdsm.Robot.paper()
    sol = robot.ik(TABLE3_POINTS, seed=np.tile(TABLE3_SEED, (9, 1)))
    assert np.asarray(sol.converged).all()
    expected = np.array([True, False, False, False, False, True, True, False, False])
    np.testing.assert_array_equal(np.asarray(sol.within_limits), expected)
    worst = np.degrees(np.abs(np.asarray(sol.theta)).max(axis=1))
    assert worst.max() == pytest.approx(40.58, abs=0.01)
    assert (worst[~expected] > 35).all() and (worst[expected] <= 35).all()
    # enforcing the limits, those six poses cannot be reached; the rest can
    sol = robot.ik(TABLE3_POINTS, seed=np.tile(TABLE3_SEED, (9, 1)), enforce_limits=True)
    np.testing.assert_array_equal(np.asarray(sol.converged), expected)
    assert np.asarray(sol.within_limits).all()
