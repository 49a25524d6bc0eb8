"""Manufacturing errors of an elastic arm as plant parameters
(:mod:`cdsm.accuracy.plant_errors`): the Monte Carlo against the independent NumPy
reference and against the linear picture of the sensitivities, the sensitivities against
central differences of the equilibrium.  SI units."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import cdsm
from cdsm import CdsmInputError
from cdsm.accuracy import plant_errors as pe
from cdsm.calibration import plant
from cdsm.calibration.measurements import commanded_cables
from cdsm.reference import elastic, read_robot
from test_elastic_plant import commands, two_segments


@pytest.fixture(scope="module")
def arm():
    text = two_segments()
    robot = cdsm.Robot.from_toml_str(text)
    _, dl = commands(robot, 6, 3, lo=0.0, hi=1.5e-3)
    return robot, read_robot(text), dl


def reference_tips(robot, ref, dl, p):
    """The reference plant's observations (N, 6) of the parameters ``p`` (P,): its
    cable offsets, joint stiffness and, on the reference arm itself, the holes moved by
    the ``hole_position`` block (commanded cable by cable, face by face, x y z). The
    commands stay the nominal arm's (``docs/model.md``: a cable's rest length is its
    nominal path at the rest angles minus the displacement), so the moved arm is
    commanded its own path plus the difference."""
    lay = plant.layout(robot)
    cmd = elastic.commanded_cables(ref)
    moved = [h.copy() for h in ref.holes]
    flat = p[lay["hole_position"]]
    start = 0
    for c in cmd:
        size = moved[c].size
        moved[c] = moved[c] + flat[start:start + size].reshape(moved[c].shape)
        start += size
    assert start == flat.size
    arm = dataclasses.replace(ref, holes=tuple(moved))
    t = np.tile(robot.rest_angles, (len(dl), 1))
    shift = (elastic.rest_lengths(ref) - elastic.rest_lengths(arm))[cmd]
    obs, ok = elastic.plant_predict(arm, t, dl + shift, ["absolute"] * len(dl),
                                    {"cable_offset": p[lay["cable_offset"]],
                                     "joint_stiffness": p[lay["joint_stiffness"]]})
    assert ok.all()
    return obs


def test_monte_carlo_statistics_are_the_reference_plants_on_the_same_draws(arm):
    """Three samples (offsets, every hole coordinate, joint stiffness): each drawn vector,
    settled by the NumPy reference's elastic plant, gives the same tip deviations as the
    core's study (sums, squares, extremes and counts per command row)."""
    robot, ref, dl = arm
    tol = {"cable_offset": 2e-4, "hole_position": 1e-4, "joint_stiffness": 0.05}
    mc = pe.monte_carlo_commands(robot, dl, samples=3, seed=7, tolerances=tol, chunk=2, progress=False)
    vec = pe.tolerance_vector(robot, tol)
    draws = np.concatenate([pe.sample_parameters(vec, 2, 7, 0), pe.sample_parameters(vec, 1, 7, 1)])
    nominal = reference_tips(robot, ref, dl, np.zeros(plant.size(robot)))
    q = np.stack([pe.deviation_quantities(robot, nominal, reference_tips(robot, ref, dl, p)) for p in draws])
    np.testing.assert_array_equal(mc.count, 3)
    np.testing.assert_array_equal(mc.failed, 0)
    np.testing.assert_allclose(mc.sum, q.sum(axis=0), rtol=0, atol=1e-10)
    np.testing.assert_allclose(mc.max, q.max(axis=0), rtol=0, atol=1e-10)
    np.testing.assert_allclose(mc.min, q.min(axis=0), rtol=0, atol=1e-10)
    assert np.all(mc.max_abs[:, 3] > 1e-4)  # the errors matter here: far above the agreement
    # the histogram counts every sample once, in the bin of its |d(X, Y, Z)|
    np.testing.assert_array_equal(mc.hist.sum(axis=1), 3)
    edges = mc.hist_edges()
    for j in range(len(dl)):
        bins = np.flatnonzero(mc.hist[j])
        assert all(edges[b - 1] <= q[:, j, 3].max() * 1.01 for b in bins)


def test_small_tolerances_spread_as_the_sensitivities_say(arm):
    """Tolerances small enough for the linear picture: the Monte Carlo's standard
    deviation of dX, dY, dZ per command row is sqrt(diag(J S J^T)), ``S`` the uniform
    errors' variances tol^2 / 3 and ``J`` the implicit-function sensitivities (2000
    samples: the standard deviation's sampling error ~2 %)."""
    robot, _, dl = arm
    tol = {"cable_offset": 2e-6, "hole_position": 1e-6, "joint_stiffness": 1e-3}
    mc = pe.monte_carlo_commands(robot, dl, samples=2000, seed=1, tolerances=tol, chunk=500, progress=False)
    sens = pe.sensitivities_commands(robot, dl)
    lay = plant.layout(robot)
    vec = pe.tolerance_vector(robot, tol)
    var = np.zeros((len(dl), 3))
    for b in tol:
        var += np.einsum("nik,k->ni", sens[b][:, :3, :] ** 2, vec[lay[b]] ** 2 / 3.0)
    np.testing.assert_allclose(mc.std[:, :3], np.sqrt(var), rtol=0.08)
    # and the mean is zero within its sampling error
    assert np.all(np.abs(mc.mean[:, :3]) < 4.0 * np.sqrt(var / 2000))


def test_sensitivities_are_central_differences_of_the_equilibrium(arm):
    """dtip/d(cable offset): an offset o of a displacement cable is a displacement -o
    (``Robot.equilibrium``); dtip/d(hole coordinate): the equilibrium of the arm with the
    hole moved (``Robot.with_holes``), its cables' rest lengths the nominal arm's (the
    displacement grows by the moved path's extra length at the rest angles: a hole moved
    along the backbone stretches its cable); dtip/d(segment stiffness): the reference's
    plant arm with the segment's springs scaled. Central differences, h = 1e-7 m / 1e-6."""
    robot, ref, dl = arm
    sens = pe.sensitivities_commands(robot, dl)
    assert sens["converged"].all()
    d = -dl

    def tip(rob, disp):
        eq = rob.equilibrium(displacements=disp, seed=robot.rest_angles)
        assert eq.converged.all()
        return rob.fk(eq.theta)[:, :3]

    h = 1e-7
    for i in (0, 4):
        e = np.zeros(d.shape[1])
        e[i] = h
        fd = (tip(robot, d - e) - tip(robot, d + e)) / (2 * h)
        np.testing.assert_allclose(sens["cable_offset"][:, :3, i], fd, rtol=0, atol=1e-6 * np.abs(fd).max())
    flat = robot.flat_holes
    assert flat.size == sens["hole_position"].shape[2]
    rest = robot.elastic_cables()["rest_length"]

    def moved_tip(holes):
        moved = robot.with_holes(holes, within_disks=False)
        return tip(moved, d + moved.elastic_cables()["rest_length"] - rest)

    for j in (3, 5, 40, flat.size - 3, flat.size - 2):  # x (along the backbone), z, y, x, y
        e = np.zeros(flat.size)
        e[j] = h
        fd = (moved_tip(flat + e) - moved_tip(flat - e)) / (2 * h)
        np.testing.assert_allclose(sens["hole_position"][:, :3, j], fd, rtol=0, atol=1e-6 * max(np.abs(fd).max(), 1e-3))
    hs = 1e-6
    t = np.tile(robot.rest_angles, (len(dl), 1))
    for s in range(2):
        e = np.zeros(2)
        e[s] = hs
        up, _ = elastic.plant_predict(ref, t, dl, ["absolute"] * len(dl), {"joint_stiffness": e})
        down, _ = elastic.plant_predict(ref, t, dl, ["absolute"] * len(dl), {"joint_stiffness": -e})
        fd = (up - down)[:, :3] / (2 * hs)
        np.testing.assert_allclose(sens["joint_stiffness"][:, :3, s], fd, rtol=0, atol=1e-6 * np.abs(fd).max())
        assert np.abs(fd).max() > 1e-4  # a segment's springs move the tip


def test_bad_tolerances_name_the_block(arm):
    robot, _, dl = arm
    with pytest.raises(CdsmInputError, match="no block 'hole_height'"):
        pe.tolerance_vector(robot, {"hole_height": 1e-4})
    with pytest.raises(CdsmInputError, match=r"tolerances\['cable_offset'\]"):
        pe.tolerance_vector(robot, {"cable_offset": -1e-4})
    with pytest.raises(CdsmInputError, match="theta_cmd"):
        pe.monte_carlo_commands(robot, dl, theta_cmd=np.zeros((2, robot.n)), samples=1, progress=False)
    with pytest.raises(CdsmInputError, match="no block 'hole_height'"):
        pe.sensitivities_commands(robot, dl, blocks=("hole_height",))


def test_the_joint_angle_monte_carlo_points_an_elastic_arm_to_its_commands():
    """accuracy.monte_carlo takes joint angles; an elastic arm's are not
    commanded: refused naming the input and the function that takes commands."""
    from cdsm.accuracy import monte_carlo

    robot = cdsm.Robot.load("ftdcr_v4")
    with pytest.raises(CdsmInputError, match=r"`theta0`.*monte_carlo_commands"):
        monte_carlo(robot, np.zeros((2, robot.n)), samples=2, progress=False)


# ---------------------------------------------------------------------------
# `cdsm montecarlo` on an elastic arm: the plant's Monte Carlo at sampled commands


def _cli_mc(tmp_path, robot_file, *extra):
    import json

    out = tmp_path / "mc.npz"
    assert cdsm.cli.main(["montecarlo", "--robot", str(robot_file), "--out", str(out), "--quiet", *extra]) == 0
    z = np.load(out)
    return z, json.loads(str(z["params"]))


@pytest.fixture()
def elastic_file(tmp_path):
    path = tmp_path / "two_segments.toml"
    path.write_text(two_segments())
    return path


def test_cli_montecarlo_elastic_arm_runs_the_plants_monte_carlo(tmp_path, elastic_file, arm):
    """An elastic arm's `cdsm montecarlo` samples commands (the nominal plant settles every
    one here), draws every sample's plant within the tolerances and reports the kind's
    quantities; without any tolerance every sample is the nominal plant: deviations 0."""
    robot = arm[0]
    z, params = _cli_mc(tmp_path, elastic_file, "--samples", "8", "--configurations", "12", "--chunk", "4")
    assert [str(q) for q in z["quantities"]] == list(robot.kind.quantities)
    assert params["protocol"] == "commanded" and params["configurations"] == 12 and params["unreachable"] == 0
    assert (z["count"] == 8).all() and z["poses"].shape == (12, 6)
    assert set(params["plant_tolerances_m"]) == {"cable_offset", "hole_position"}
    assert z["max_abs"][:, 3].max() > 1e-5  # ±1 mm on the tendons moves the tip
    tol = tmp_path / "zero.json"
    tol.write_text('{"cable_length_tol_m": 0, "hole_tol_m": 0}')
    z0, _ = _cli_mc(tmp_path, elastic_file, "--samples", "4", "--configurations", "8", "--tolerances", str(tol))
    assert (z0["count"] == 4).all() and np.array_equal(z0["max_abs"], np.zeros_like(z0["max_abs"]))


def test_cli_montecarlo_elastic_tolerance_file_per_cable(tmp_path, arm):
    """An elastic arm's tolerance file has a rigid arm's keys: `hole_tol_m` per commanded
    cable is every coordinate of that cable's holes (the plant's `hole_position` order); a
    wrong count names the file's key."""
    from cdsm.accuracy.tolerance import read_tolerances

    robot = arm[0]
    m = plant.commands(robot)
    path = tmp_path / "tol.json"
    per_cable = ", ".join(str(1e-4 * (c + 1)) for c in range(m))
    path.write_text('{"cable_length_tol_m": 0.002, "hole_tol_m": [%s]}' % per_cable)
    dl, dh = read_tolerances(str(path), robot)
    assert np.array_equal(dl, np.full(m, 0.002))
    sizes = [np.asarray(robot.holes[c]).size for c in commanded_cables(robot)]
    assert np.array_equal(dh, np.repeat(1e-4 * (np.arange(m) + 1), sizes))
    assert dh.size == plant.layout(robot)["hole_position"].stop - plant.layout(robot)["hole_position"].start
    path.write_text('{"cable_length_tol_m": [0.001, 0.001, 0.001, 0.001, 0.001, 0.001, 0.001], "hole_tol_m": 0}')
    with pytest.raises(CdsmInputError, match="cable_length_tol_m"):
        read_tolerances(str(path), robot)
    path.write_text('{"cable_length_tol_m": 0.001}')
    with pytest.raises(CdsmInputError, match="missing key 'hole_tol_m'"):
        read_tolerances(str(path), robot)


@pytest.mark.parametrize("extra, option", [(("--step", "5"), "--step"), (("--range", "10"), "--range"),
                                           (("--protocol", "joint"), "--protocol"),
                                           (("--scheduler", "tcp://x:1"), "--scheduler"),
                                           (("--reach-mm", "0"), "--reach-mm")])
def test_cli_montecarlo_elastic_refuses_rigid_options(tmp_path, elastic_file, extra, option, capsys):
    """The options of a rigid arm's configurations do not apply to an elastic arm: named, not ignored."""
    code = cdsm.cli.main(["montecarlo", "--robot", str(elastic_file), "--out", str(tmp_path / "x.npz"),
                          "--quiet", *extra])
    assert code != 0 and option in capsys.readouterr().err
    assert not (tmp_path / "x.npz").exists()


def test_cli_montecarlo_rigid_arm_refuses_reach(tmp_path, capsys):
    code = cdsm.cli.main(["montecarlo", "--out", str(tmp_path / "x.npz"), "--quiet", "--reach-mm", "2"])
    assert code != 0 and "--reach-mm" in capsys.readouterr().err


def test_tolerance_allocation_of_an_elastic_arm(arm):
    """The allocation of an elastic arm searches the plant's Monte Carlo at its commands:
    at the answer the pooled P95 is within the target and at 1.25x the tolerances above it,
    and at these small tolerances the linear estimate from the plant's implicit-function
    sensitivities (an independent path: no sampling, no settle per sample) agrees with the
    sampled percentile within 10 %."""
    from cdsm.accuracy import tolerance

    robot, _, dl = arm
    a = tolerance.allocate(robot, 2e-4, commands=dl, samples=300, seed=3)
    assert a.cable_length_tol_m.shape == (plant.commands(robot),)
    assert a.hole_tol_m.shape == (len(commanded_cables(robot)),)
    assert a.achieved_m <= 2e-4 < a.achieved_1p25_m
    assert a.linear_m == pytest.approx(a.achieved_m, rel=0.10)
    with pytest.raises(CdsmInputError, match="`theta`"):
        tolerance.allocate(robot, 2e-4, theta=np.zeros((2, robot.n)))
    with pytest.raises(CdsmInputError, match="`commands`"):
        tolerance.allocate(cdsm.Robot.paper(), 1e-3, commands=dl)


def test_cli_tolerance_of_an_elastic_arm(tmp_path, elastic_file, capsys):
    """`cdsm tolerance` on an elastic arm: commands sampled as its region, one tolerance
    per commanded cable and per cable's holes in the JSON, which `cdsm montecarlo
    --tolerances` reads back; a region of joint angles is refused naming `--region`."""
    import json

    out = tmp_path / "tol.json"
    code = cdsm.cli.main(["tolerance", "--robot", str(elastic_file), "--target-mm", "0.5", "--samples", "100",
                          "--region", "sobol:16", "--cells", "2", "--json", str(out), "--quiet"])
    assert code == 0
    data = json.loads(out.read_text())
    assert len(data["cable_length_tol_m"]) == 6 and len(data["hole_tol_m"]) == 6
    assert data["achieved_mm"] <= 0.5 and data["configurations"] <= 16
    z, params = _cli_mc(tmp_path, elastic_file, "--samples", "4", "--configurations", "8", "--tolerances", str(out))
    assert (z["count"] == 4).all()
    capsys.readouterr()
    code = cdsm.cli.main(["tolerance", "--robot", str(elastic_file), "--target-mm", "1", "--region",
                          "grid:-10:10:5"])
    assert code != 0 and "--region" in capsys.readouterr().err


def test_a_plate_hole_takes_one_error_for_both_faces():
    """FTDCR v4's via plates have zero thickness: a hole's two faces are one point, so a
    manufacturing error moves both alike (`hole_ties`). Drawn per face, the cable would
    zigzag through every plate (|δb − δa| ≥ 0: a lengthening the linear picture cannot
    see): at ±1 µm the tips were biased by 2–6× their spread and the spread was up to 22 %
    off the linear one. With the faces tied the errors are zero-mean (bias below a quarter
    of the spread: the mean of 400 samples) and the spread of every tip axis equals the
    linear √(Σ J² tol²/3) within 10 %, on commands the plant settles."""
    from cdsm.accuracy import tolerance

    robot = cdsm.Robot.load("ftdcr_v4")
    b, a = pe.hole_ties(robot)
    assert b.size == a.size > 0 and np.array_equal(b - a, np.full(b.size, 3))  # face b follows face a
    d = tolerance.default_commands(robot, 8)
    tol = 1e-6
    mc = pe.monte_carlo_commands(robot, d, samples=400, seed=5, tolerances={"hole_position": tol}, progress=False)
    em = pe.position_matrix_commands(robot, d)[:, :, plant.commands(robot):]
    linear = np.sqrt((em ** 2).sum(axis=2) * tol ** 2 / 3.0)  # (N, 3) per axis
    std = np.sqrt(mc.sum_sq[:, :3] / mc.count[:, None] - (mc.sum[:, :3] / mc.count[:, None]) ** 2)
    big = linear > 0.1 * linear.max()
    assert np.abs(std[big] / linear[big] - 1).max() < 0.10
    mean = mc.sum[:, :3] / mc.count[:, None]
    assert (np.linalg.norm(mean, axis=1) < 0.25 * np.linalg.norm(std, axis=1)).all()


def test_a_rigid_arm_with_plates_draws_one_error_per_plate_hole():
    """The same rule in the core's Monte Carlo of a rigid arm: `two_universal` with its disks
    made plates (thickness 0). Its sampled tips at ±1 µm on every hole coordinate are
    unbiased and spread as the linear map says (within 10 %), as they are for the arm as
    packaged; drawn per face, the plates' zigzags biased them."""
    import re

    from cdsm.accuracy.montecarlo import monte_carlo, plate_hole_twins
    from cdsm.accuracy.sensitivity import position_matrix

    text = re.sub(r"thickness = [0-9.e+-]+", "thickness = 0.0", cdsm.Robot.load("two_universal").to_toml())
    robot = cdsm.Robot.from_toml_str(text)
    b, a = plate_hole_twins(robot)
    assert b.size > 0
    theta = np.array([[0.2, -0.1, 0.15, 0.1], [-0.3, 0.2, 0.1, -0.2], [0.1, 0.3, -0.2, 0.25]])
    tol = 1e-6
    mc = monte_carlo(robot, theta, samples=2000, seed=2, dl_tol=0.0, dh_tol=tol, progress=False)
    em = position_matrix(robot, theta)[:, :, len(robot.position_cables):]
    linear = np.sqrt((em ** 2).sum(axis=2) * tol ** 2 / 3.0)
    mean = mc.sum[:, :3] / mc.count[:, None]
    std = np.sqrt(mc.sum_sq[:, :3] / mc.count[:, None] - mean ** 2)
    big = linear > 0.1 * linear.max()
    assert np.abs(std[big] / linear[big] - 1).max() < 0.10
    assert (np.linalg.norm(mean, axis=1) < 0.25 * np.linalg.norm(std, axis=1)).all()
