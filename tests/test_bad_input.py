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


# ==========================================================================
# issue 32, item 9: validation gaps
# ==========================================================================
def _model_file(cdsm, tmp_path):
    from cdsm.calibration.model import FittedPlant

    m = FittedPlant.from_effects(cdsm.Robot.paper(), {"cable_friction": [0.2], "backlash": [1e-5, 2e-5, 3e-5]},
                           std={"cable_friction": [0.01], "backlash": [1e-6, 1e-6, 1e-6]})
    path = tmp_path / "m.json"
    m.save(path)
    import json

    return FittedPlant, json.loads(path.read_text(encoding="utf-8")), path


@pytest.mark.parametrize("mu", [1.5, -0.1])
def test_a_model_refuses_friction_outside_zero_to_one_on_input(cdsm, err, tmp_path, mu):
    import json

    FittedPlant, d, path = _model_file(cdsm, tmp_path)
    with pytest.raises(err, match=r"`effects`: cable_friction must be within \[0, 1\]"):
        FittedPlant.from_effects(cdsm.Robot.paper(), {"cable_friction": [mu]})
    lay = d["params"]["layout"]["cable_friction"]
    d["params"]["flat"][lay[0]] = mu
    path.write_text(json.dumps(d), encoding="utf-8")
    with pytest.raises(err, match=r"m\.json.*`params\.flat`: cable_friction must be within \[0, 1\]"):
        FittedPlant.load(path)


@pytest.mark.parametrize("where, value, match", [
    ("std", {"backlash": None}, r"`std\['backlash'\]`: expected a list of 3"),
    ("std", {"backlash": [-1e-6, 1e-6, 1e-6]}, r"`std\['backlash'\]`: .*>= 0"),
    ("std", {"backlash": [1e-6, 1e-6, 1e-6, 1e-6]}, r"`std\['backlash'\]`: expected a list of 3"),
    ("std", {"backlash": [1e-6, 1e-6, 1e-6], "hole_height": [1e-6, 1e-6, 1e-6]},
     r"`std\['hole_height'\]`: 'hole_height' is not a fitted effect"),
    ("std", {"cable_friction": [True]}, r"`std\['cable_friction'\]`: .*booleans"),
    ("std", None, r"`params\.std`: expected an object"),
    ("flat0", 1e308, r"`params\.flat`: actuation_scale must be within \[-0\.9, 1000\]"),
    ("flat0", True, r"`params\.flat`: .*booleans"),
    ("flat0", None, r"`params\.flat`: .*None"),
])
def test_a_model_file_is_refused_naming_the_field(cdsm, err, tmp_path, where, value, match):
    import json

    FittedPlant, d, path = _model_file(cdsm, tmp_path)
    if where == "std":
        d["params"]["std"] = value
    else:
        d["params"]["flat"][0] = value
    path.write_text(json.dumps(d), encoding="utf-8")
    with pytest.raises(err, match=match):
        FittedPlant.load(path)


def test_a_model_with_an_undetermined_parameter_saves_and_loads(cdsm, tmp_path):
    """A fit's 1-sigma is NaN where the data do not determine a parameter:
    the file says null and reads it back as NaN (saving used to raise
    json's ValueError)."""
    from cdsm.calibration.model import FittedPlant

    m = FittedPlant.from_effects(cdsm.Robot.paper(), {"backlash": [1e-5, 2e-5, 3e-5]},
                           std={"backlash": [float("nan"), 1e-6, 2e-6]})
    m.save(tmp_path / "m.json")
    assert '"backlash": [\n        null,' in (tmp_path / "m.json").read_text(encoding="utf-8")
    back = FittedPlant.load(tmp_path / "m.json")
    assert back == m and np.isnan(back.std["backlash"][0]) and back.std["backlash"][1:] == [1e-6, 2e-6]


def test_booleans_are_not_numbers(robot, err):
    theta = np.zeros((2, 3))
    with pytest.raises(err, match="`friction`"):
        robot.tensions(theta, friction=True)
    with pytest.raises(err, match="`min_tension`"):
        robot.feasible(theta, min_tension=np.True_)
    with pytest.raises(err, match="`theta`.*booleans"):
        robot.fk([[True, False, False]])
    with pytest.raises(err, match="`theta`.*booleans"):
        robot.fk([0.1, True, 0.0])  # NumPy alone would read [0.1, 1.0, 0.0]


@pytest.mark.parametrize("sliding", [np.array(["pull", "release"]), np.array(["pull"]), ["pull"], 1])
def test_sliding_is_one_state_named_clearly(robot, err, sliding):
    with pytest.raises(err, match="`sliding`: expected 'pull' or 'release'"):
        robot.tensions(np.zeros((2, 3)), friction=0.2, sliding=sliding)


@pytest.mark.parametrize("kw, match", [
    (dict(theta=np.zeros((2, 3), complex)), "`theta`: complex"),
    (dict(theta=np.zeros((2, 2))), r"`theta`: expected shape \(N, 3\)"),
    (dict(theta=np.zeros(4)), r"`theta`: expected shape \(N, 3\)"),
    (dict(theta=np.zeros((2, 3, 1))), r"`theta`: expected shape \(N, 3\)"),
    (dict(amplitude=-1e-3), "`amplitude`: .*positive"),
    (dict(amplitude=0.0), "`amplitude`: .*positive"),
    (dict(mu=True), "`mu`"),
    (dict(mu=1.5), r"`mu`: .*\[0, 1\]"),
    (dict(cycle_work=0), "`cycle_work`"),
])
def test_friction_map_checks_its_inputs(robot, err, kw, match):
    import warnings

    from cdsm.accuracy import statics

    args = dict(theta=np.zeros((2, 3)))
    args.update(kw)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning: a refusal
        with pytest.raises(err, match=match):
            statics.friction_map(robot, **args)


def test_friction_map_leaves_rows_with_nan_nan(robot):
    from cdsm.accuracy import statics

    fm = statics.friction_map(robot, [[0.1, 0.0, 0.0], [np.nan, 0.0, 0.0]])
    assert np.isfinite(fm.pull[0]).all() and np.isnan(fm.pull[1]).all() and fm.cycled.tolist() == [True, False]


@pytest.mark.parametrize("args, match", [
    ((3, -1e308, 1e308, 1.0), "too large"),
    ((3, 0.0, 1.0, 1e-300), "too large"),
    ((0, 0.0, 1.0, 0.1), "`n`"),
    ((2.5, 0.0, 1.0, 0.1), "`n`"),
    ((3, 0.0, np.inf, 0.1), "`hi`"),
])
def test_joint_grid_refuses_clearly(err, args, match):
    from cdsm.accuracy.workspace import joint_grid

    with pytest.raises(err, match=match):
        joint_grid(*args)


def test_percentiles_get_distinct_exact_keys(cdsm, err, tmp_path, capsys):
    import cdsm.cli
    from cdsm.accuracy import montecarlo

    out = tmp_path / "mc.npz"
    assert cdsm.cli.main(["montecarlo", "--out", str(out), "--samples", "20", "--step", "15",
                          "--percentiles", "99.99999,100,50,99.9", "--quiet"]) == 0
    z = np.load(out)
    keys = sorted(k for k in z.files if re.fullmatch(r"p[0-9_e+-]+", k))
    assert keys == ["p100", "p50", "p99_9", "p99_99999"]  # the ordinary keys as before
    assert z["percentiles"].tolist() == [99.99999, 100.0, 50.0, 99.9]
    assert "worst p99.99999" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        cdsm.cli.main(["montecarlo", "--out", str(tmp_path / "b.npz"), "--percentiles", "95,95.0", "--quiet"])
    assert "more than once" in capsys.readouterr().err
    mc = cdsm.accuracy.monte_carlo(cdsm.Robot.paper(), np.zeros((1, 3)), samples=5, progress=False)
    with pytest.raises(err, match="`percentiles`: 95 is given more than once"):
        montecarlo.summary(mc, [95, 95.0])
    assert montecarlo.percentile_key(1e-5) == "p1e-05" and montecarlo.percentile_key(-0.0) == "p0"


@pytest.mark.parametrize("fn", FORWARD + ["tensions"])
def test_planar_angles_whose_sum_overflows_are_refused(robot, err, fn):
    """A planar disk's angle is the running sum of the joint angles: 1e308 +
    1e308 rad overflows (fk returned NaN and inf for finite input; found by
    the property tests once they drew new examples)."""
    with pytest.raises(err, match="`theta`: row 1: the joint angles add up past the largest float"):
        getattr(robot, fn)(np.array([[0.1, 0.2, 0.3], [1e308, 1e308, 0.0]]))
    assert np.isfinite(robot.fk([1e300, 1e10, 3.0])).all()  # large but summable: taken


# ==========================================================================
# Robot names (MJCF and URDF carry them in an XML attribute) and robots
# built from data
# ==========================================================================
#: A one-disk spatial arm, written with inline tables (the shape of its data below).
SPATIAL_TOML = ('kind = "spatial"\nname = "data arm"\nbase = { radius = 0.03 }\n'
                "linkage = [{ joints = [{ axis = [0.0, 0.0, 1.0], offset = [0.02, 0.0, 0.0], limits = [-0.5, 0.5] }], "
                "link_after = [0.01, 0.0, 0.0], thickness = 0.005, radius = 0.03, mass = 0.02 }]\n"
                'cables = [{ end = 1, mode = "position", radius = 0.025, angle = 0.0 }, '
                '{ end = 1, mode = "force", tension = 1.0, radius = 0.025, angle = 3.0 }]\n')


def _spatial_data(**top):
    """The data of :data:`SPATIAL_TOML` (a dict of the file's structure), top-level keys replaced."""
    data = {"kind": "spatial", "name": "data arm", "base": {"radius": 0.03},
            "linkage": [{"joints": [{"axis": [0.0, 0.0, 1.0], "offset": [0.02, 0.0, 0.0], "limits": [-0.5, 0.5]}],
                         "link_after": [0.01, 0.0, 0.0], "thickness": 0.005, "radius": 0.03, "mass": 0.02}],
            "cables": [{"end": 1, "mode": "position", "radius": 0.025, "angle": 0.0},
                       {"end": 1, "mode": "force", "tension": 1.0, "radius": 0.025, "angle": 3.0}]}
    data.update(top)
    return data


def _named(kind, value):
    """A robot file of ``kind`` whose name is the TOML string ``value``."""
    text = robot_toml(PAPER_LINKAGES) if kind == "planar" else SPATIAL_TOML
    text, count = re.subn(r'^name = "[^"\n]*"$', lambda _: f"name = {value}", text, count=1, flags=re.M)
    assert count == 1
    return text


#: characters XML 1.0 forbids (its Char production), as TOML escapes
FORBIDDEN = ["\\u0000", "\\u0001", "\\u0008", "\\u000B", "\\u000C", "\\u001B", "\\u001F", "\\uFFFE", "\\uFFFF"]


@pytest.mark.parametrize("kind", ["planar", "spatial"])
@pytest.mark.parametrize("escape", FORBIDDEN)
def test_a_name_xml_forbids_is_refused(cdsm, err, kind, escape):
    """No MJCF or URDF could carry such a name: every reader refuses it,
    naming the field and the character (it once reached `cdsm export`,
    which wrote two files no XML reader takes)."""
    msg = _raises_naming(err, _named(kind, f'"arm {escape}"'), "`name`")
    assert f"U+{escape[2:]}" in msg, msg
    char = chr(int(escape[2:], 16))
    with pytest.raises(err, match=rf"`name`.*U\+{escape[2:]}"):
        cdsm.Robot.from_data(_spatial_data(name=f"arm {char}"))


@pytest.mark.parametrize("kind", ["planar", "spatial"])
def test_names_xml_allows_are_kept(cdsm, kind):
    """Any other Unicode is a name, read and written back as it is."""
    name = 'a\t"b"\\ c\nd\r\x7f\x85 \ud7ff\ue000\ufffd \U0001F4AA\U0010FFFF'
    robot = cdsm.Robot.from_toml_str(_named(kind, '"x"'))
    robot = cdsm.Robot.from_toml_str(robot.to_toml().replace('name = "x"', "name = " + _toml_str(name), 1))
    assert robot.name == name
    assert cdsm.Robot.from_toml_str(robot.to_toml()).name == name


def _toml_str(text):
    """``text`` as a TOML basic string, every character escaped."""
    return '"' + "".join(f"\\U{ord(ch):08X}" for ch in text) + '"'


def test_robot_from_data(cdsm, err):
    """Robot.from_data: the file's data, no text in between; the same checks
    and the same field paths as the file."""
    assert cdsm.Robot.from_data(_spatial_data()).to_toml() == cdsm.Robot.from_toml_str(SPATIAL_TOML).to_toml()
    planar = cdsm.Robot.from_data({"name": "p", "linkage": [
        {"link_before": 0.03, "link_after": 0.03, "thickness": 0.01, "hole_height": 0.02, "mass": 0.01}]})
    assert planar.kind == "planar" and planar.n == 1
    bad_mass = _spatial_data()
    bad_mass["linkage"][0]["mass"] = -1.0
    cases = [
        (bad_mass, r"`linkage\[0\]\.mass`.*>= 0"),
        (_spatial_data(colour=3), r"colour"),
        (_spatial_data(name=b"arm"), r"`name`: a bytes is not a robot file's value"),
        (_spatial_data(name="arm \ud800"), r"`name`.*lone surrogate"),
        (_spatial_data(gravity=[0.0, 0.0, None]), r"`gravity\[2\]`: a NoneType"),
        (_spatial_data(base={1: 0.03}), r"`base`: key 1 is not a string"),
        (_spatial_data(cables=[{"end": 2**70}]), r"`cables\[0\]\.end`: integer .* out of range"),
        (_spatial_data(name=1.5), r"`name`"),
    ]
    for data, pattern in cases:
        with pytest.raises(err, match=pattern):
            cdsm.Robot.from_data(data)
    with pytest.raises(err, match=r"`data`: expected a dict"):
        cdsm.Robot.from_data(SPATIAL_TOML)


def test_negative_lower_tension_is_refused(robot, err):
    """A planar file refuses a negative ``lower_tension``; so does ``with_loads``."""
    with pytest.raises(err, match=r"lower_tension\[1\]"):
        robot.with_loads(lower_tension=[0.1, -0.2, 0.3])
