"""Input validation of the public API.

Bad input raises ``cdsm.CdsmInputError`` (a ``ValueError``) whose message
names the offending argument or robot field; awkward but valid input
(integers, float32, non-contiguous views, 1-D single rows) works and gives the
same result as contiguous float64 input.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from conftest import LIM35, PAPER_LINKAGES, Linkage, random_theta, robot_toml


@pytest.fixture(scope="module")
def robot():
    import cdsm

    return cdsm.Robot.paper()


@pytest.fixture(scope="module")
def err():
    import cdsm

    assert issubclass(cdsm.CdsmInputError, ValueError)
    return cdsm.CdsmInputError


def good_theta(N=4):
    return random_theta(3, N=N, seed=99)


def good_pose(robot, N=4):
    return np.asarray(robot.fk(good_theta(N)))


def good_upper(robot, N=4):
    return np.asarray(robot.cable_lengths(good_theta(N)))[:, 0::2]


FORWARD = ["fk", "fk_jacobian", "cable_lengths", "cable_jacobian"]


# ==========================================================================
# Non-finite values
# ==========================================================================
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("fn", FORWARD)
def test_non_finite_theta(robot, err, fn, bad):
    theta = good_theta()
    theta[2, 1] = bad
    with pytest.raises(err, match="theta"):
        getattr(robot, fn)(theta)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_pose(robot, err, bad):
    pose = good_pose(robot)
    pose[1, 2] = bad
    with pytest.raises(err, match="pose.*non-finite.*row 1, column 2"):
        robot.ik(pose)


@pytest.mark.parametrize("bad", [np.nan, -np.inf])
def test_non_finite_ik_seed(robot, err, bad):
    seed = good_theta()
    seed[0, 0] = bad
    with pytest.raises(err, match="seed.*non-finite.*row 0, column 0"):
        robot.ik(good_pose(robot), seed=seed)


@pytest.mark.parametrize("method", ["auto", "newton", "closed_form"])
@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_upper(robot, err, bad, method):
    upper = good_upper(robot)
    upper[3, 0] = bad
    with pytest.raises(err, match="upper.*non-finite.*row 3, column 0"):
        robot.solve_cables(upper, method=method)


def test_non_finite_cable_seed(robot, err):
    seed = good_theta()
    seed[1, 2] = np.nan
    with pytest.raises(err, match="seed.*non-finite.*row 1, column 2"):
        robot.solve_cables(good_upper(robot), seed=seed)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_holes(robot, err, bad):
    holes = np.array(robot.holes)
    holes[0, 1, 0, 1] = bad
    with pytest.raises(err, match="holes"):
        robot.with_holes(holes)


# ==========================================================================
# Shapes
# ==========================================================================
# (3, 4) has 12 = 4 * 3 values: a wrapper that only flattens and counts would
# silently reinterpret it as 4 rows of 3; (2, 2, 3) likewise.
THETA_SHAPES = [(5, 4), (3, 4), (4, 2), (2, 2, 3), (4,), (2,), (0,), ()]


@pytest.mark.parametrize("shape", THETA_SHAPES)
@pytest.mark.parametrize("fn", FORWARD)
def test_wrong_theta_shape(robot, err, fn, shape):
    with pytest.raises(err, match="theta"):
        getattr(robot, fn)(np.zeros(shape))


@pytest.mark.parametrize("shape", [(4, 2), (4, 4), (2, 6), (2, 2, 3), (2,), (6,)])
def test_wrong_pose_shape(robot, err, shape):
    with pytest.raises(err, match="pose"):
        robot.ik(np.full(shape, 0.1))


@pytest.mark.parametrize("shape", [(4, 4), (4, 2), (3, 4), (2, 2, 3), (4,)])
def test_wrong_upper_shape(robot, err, shape):
    with pytest.raises(err, match="upper"):
        robot.solve_cables(np.full(shape, 0.07))


@pytest.mark.parametrize("shape", [(4, 4), (3, 3), (5, 3), (4, 3, 1), (2,)])
def test_wrong_seed_shape(robot, err, shape):
    """The seed must match the batch: (N, n) (a different N is an error too)."""
    with pytest.raises(err, match="seed"):
        robot.ik(good_pose(robot, N=4), seed=np.zeros(shape))
    with pytest.raises(err, match="seed"):
        robot.solve_cables(good_upper(robot, N=4), seed=np.zeros(shape))


@pytest.mark.parametrize("shape", [(6, 4, 2), (6, 3, 2, 2), (4, 4, 2, 2), (96,)])
def test_wrong_holes_shape(robot, err, shape):
    with pytest.raises(err, match="holes"):
        robot.with_holes(np.zeros(shape))


def test_shape_message_names_expected_width(robot, err):
    with pytest.raises(err) as info:
        robot.fk(np.zeros((5, 4)))
    assert "theta" in str(info.value)
    assert "3" in str(info.value)  # the expected width n = 3


def test_empty_batch(robot):
    assert np.asarray(robot.fk(np.zeros((0, 3)))).shape == (0, 3)
    assert np.asarray(robot.cable_lengths(np.zeros((0, 3)))).shape == (0, 6)
    assert np.asarray(robot.ik(np.zeros((0, 3))).theta).shape == (0, 3)


# ==========================================================================
# Awkward but valid arrays
# ==========================================================================
def test_single_row_1d(robot):
    theta = good_theta(1)
    assert np.asarray(robot.fk(theta[0])).shape == (3,)
    np.testing.assert_array_equal(robot.fk(theta[0]), robot.fk(theta)[0])
    np.testing.assert_array_equal(robot.cable_lengths(theta[0]), robot.cable_lengths(theta)[0])


def test_outputs_are_float64(robot):
    theta = good_theta()
    for fn, shape in zip(FORWARD, [(4, 3), (4, 3, 3), (4, 6), (4, 6, 3)]):
        out = np.asarray(getattr(robot, fn)(theta))
        assert out.shape == shape, fn
        assert out.dtype == np.float64, fn


@pytest.mark.parametrize("fn", FORWARD)
def test_integer_theta(robot, fn):
    theta_int = np.array([[0, 0, 0], [1, 0, -1], [0, -1, 1]], dtype=np.int64)
    np.testing.assert_array_equal(
        getattr(robot, fn)(theta_int), getattr(robot, fn)(theta_int.astype(float))
    )
    theta_list = [[0, 0, 0], [1, 0, -1]]
    np.testing.assert_array_equal(
        getattr(robot, fn)(theta_list), getattr(robot, fn)(np.array(theta_list, dtype=float))
    )


def test_float32_theta(robot):
    theta32 = good_theta().astype(np.float32)
    np.testing.assert_array_equal(robot.fk(theta32), robot.fk(theta32.astype(np.float64)))


def _views(a):
    """Non-contiguous views equal to ``a`` (2-D): strided, Fortran, reversed."""
    wide = np.zeros((a.shape[0], 2 * a.shape[1]))
    wide[:, ::2] = a
    tall = np.zeros((2 * a.shape[0], a.shape[1]))
    tall[::2] = a
    rev = a[::-1, ::-1].copy()[::-1, ::-1]
    return {
        "column_stride": wide[:, ::2],
        "row_stride": tall[::2],
        "fortran": np.asfortranarray(a),
        "transposed": np.ascontiguousarray(a.T).T,
        "negative_strides": rev,
    }


@pytest.mark.parametrize("view", ["column_stride", "row_stride", "fortran", "transposed", "negative_strides"])
def test_non_contiguous_inputs(robot, view):
    theta = good_theta()
    v = _views(theta)[view]
    assert np.array_equal(v, theta)
    for fn in FORWARD:
        np.testing.assert_array_equal(getattr(robot, fn)(v), getattr(robot, fn)(theta), err_msg=fn)

    pose = good_pose(robot)
    seed = theta + 0.01
    a = robot.ik(_views(pose)[view], seed=_views(seed)[view])
    b = robot.ik(pose, seed=seed)
    np.testing.assert_array_equal(a.theta, b.theta)
    np.testing.assert_array_equal(a.converged, b.converged)

    upper = good_upper(robot)
    for method in ("newton", "closed_form"):
        a = robot.solve_cables(_views(upper)[view], seed=_views(seed)[view], method=method)
        b = robot.solve_cables(upper, seed=seed, method=method)
        np.testing.assert_array_equal(a.theta, b.theta, err_msg=method)


def test_non_contiguous_holes(robot):
    holes = np.array(robot.holes)
    holes_f = np.asfortranarray(holes + 1e-4)
    a = robot.with_holes(holes_f)
    b = robot.with_holes(np.ascontiguousarray(holes + 1e-4))
    np.testing.assert_array_equal(a.holes, b.holes)
    theta = good_theta()
    np.testing.assert_array_equal(a.cable_lengths(theta), b.cable_lengths(theta))


def test_inputs_are_not_modified(robot):
    theta = good_theta()
    pose = good_pose(robot)
    seed = theta + 0.01
    copies = [theta.copy(), pose.copy(), seed.copy()]
    robot.fk(theta)
    robot.ik(pose, seed=seed)
    robot.solve_cables(good_upper(robot), seed=seed)
    for a, b in zip([theta, pose, seed], copies):
        np.testing.assert_array_equal(a, b)


# ==========================================================================
# Options
# ==========================================================================
def test_unknown_method(robot):
    with pytest.raises(ValueError, match="method"):
        robot.solve_cables(good_upper(robot), method="bogus")


@pytest.mark.parametrize("tol", [np.nan, np.inf])
def test_bad_tol(robot, err, tol):
    with pytest.raises(err, match="tol"):
        robot.ik(good_pose(robot), tol=tol)


def test_failed_solves_do_not_raise(robot):
    """Failed elements are flagged converged=False, never raised."""
    sol = robot.ik(np.array([[5.0, 0.0, 0.0]]))
    assert not np.asarray(sol.converged).any()
    sol = robot.solve_cables(np.array([[0.001, 0.001, 0.001]]), method="newton")
    assert not np.asarray(sol.converged).any()


# ==========================================================================
# Robot TOML
# ==========================================================================
def _toml(**changes):
    """Paper TOML with one line of the first linkage replaced: key -> value text."""
    text = robot_toml(PAPER_LINKAGES)
    for key, value in changes.items():
        text, count = re.subn(rf"^{key} = [^\n]*", f"{key} = {value}", text, count=1, flags=re.M)
        assert count == 1, key
    return text


def _raises_naming(err, text, field):
    import cdsm

    with pytest.raises(err) as info:
        cdsm.Robot.from_toml_str(text)
    assert field in str(info.value), str(info.value)
    return str(info.value)


def test_valid_toml_parses(cdsm):
    robot = cdsm.Robot.from_toml_str(robot_toml(PAPER_LINKAGES))
    np.testing.assert_array_equal(robot.joint_limits, np.tile([-LIM35, LIM35], (3, 1)))
    # the format of the brief: no `n`, comments, name
    robot = cdsm.Robot.from_toml_str(robot_toml(PAPER_LINKAGES, declare_n=False))
    assert robot.n == 3


def test_unknown_top_level_key(err):
    _raises_naming(err, "colour = 3\n" + robot_toml(PAPER_LINKAGES), "colour")


def test_unknown_linkage_key(err):
    text = robot_toml(PAPER_LINKAGES).replace("mass = 0.03", "mass = 0.03\nwheel_radius = 0.01", 1)
    _raises_naming(err, text, "wheel_radius")


@pytest.mark.parametrize(
    "field,value",
    [
        ("link_before", "-0.033"),
        ("link_before", "0.0"),
        ("link_after", "-1e-3"),
        ("link_after", "0"),
        ("thickness", "-0.01"),
        ("thickness", "0.0"),
        ("hole_height", "-0.03"),
    ],
)
def test_non_positive_length(err, field, value):
    _raises_naming(err, _toml(**{field: value}), field)


@pytest.mark.parametrize("field", ["link_before", "link_after", "thickness", "hole_height"])
@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_non_finite_length(err, field, value):
    _raises_naming(err, _toml(**{field: value}), field)


@pytest.mark.parametrize("value", ["[0.5, -0.5]", "[0.1, 0.1]", "[nan, 0.5]", "[-0.5, inf]", "[0.1]"])
def test_bad_joint_limits(err, value):
    _raises_naming(err, _toml(joint_limits=value), "joint_limits")


@pytest.mark.parametrize("field", ["mass", "lower_tension"])
@pytest.mark.parametrize("value", ["-1.0", "nan"])
def test_bad_mass_and_tension(err, field, value):
    _raises_naming(err, _toml(**{field: value}), field)


@pytest.mark.parametrize("line, shown", [("tension = 0.0\n", "got 0"), ("tension = -0.25\n", "got -0.25"),
                                         ("", "got none")])
def test_a_force_cable_without_a_positive_tension_shows_the_number(err, line, shown):
    """A spatial force cable's tension error prints the number as written
    (or that none was given), not Rust's ``Some(0.0)`` / ``None``."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "python" / "cdsm" / "robots" / "paper_spatial.toml").read_text()
    text = re.sub(r"tension = [0-9.]+\n", line, text, count=1)
    msg = _raises_naming(err, text, "cables[1].tension")
    assert msg.endswith(f"needs a positive tension (N), {shown}") and "Some" not in msg, msg


def test_wrong_type(err):
    _raises_naming(err, _toml(link_before='"long"'), "link_before")


def test_missing_required_field(err):
    text = re.sub(r"^thickness = [^\n]*\n", "", robot_toml(PAPER_LINKAGES), count=1, flags=re.M)
    _raises_naming(err, text, "thickness")


@pytest.mark.parametrize("declared", [2, 4])
def test_linkage_count_mismatch(err, declared):
    text = robot_toml(PAPER_LINKAGES).replace("n = 3", f"n = {declared}", 1)
    msg = _raises_naming(err, text, "linkage")
    assert re.search(r"\bn\b", msg), msg


def test_no_linkage(err):
    _raises_naming(err, 'name = "empty"\n', "linkage")


def test_malformed_toml(err):
    import cdsm

    with pytest.raises(err):
        cdsm.Robot.from_toml_str("[[linkage]\nlink_before = 0.033\n")


def test_missing_file():
    import cdsm

    with pytest.raises((OSError, ValueError)):
        cdsm.Robot.from_toml("/nonexistent/robot.toml")


def test_single_linkage_robot_parses(cdsm):
    text = robot_toml([Linkage(0.03, 0.04, 0.012, 0.02)])
    robot = cdsm.Robot.from_toml_str(text)
    assert robot.n == 1
    assert np.asarray(robot.holes).shape == (2, 2, 2, 2)


@pytest.mark.parametrize("value", [-1, 1.5, "two", None])
def test_threads_must_be_a_non_negative_integer(cdsm, value):
    robot = cdsm.Robot.paper()
    with pytest.raises(cdsm.CdsmInputError, match="threads"):
        robot.threads = value
    robot.threads = 1  # one worker gives the same answer as all cores
    one = robot.cable_lengths(np.full((50, 3), 0.2))
    robot.threads = 0
    np.testing.assert_array_equal(one, robot.cable_lengths(np.full((50, 3), 0.2)))
