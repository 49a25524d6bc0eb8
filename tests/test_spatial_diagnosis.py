"""Issue 14: the spatial plant, its measurement files and the diagnosis.

Facts stated: all-zero parameters are the nominal model; each effect moves
the predictions as its definition says, computed independently with the NumPy
spatial reference (actuators and backlash on the commanded lengths, moved
holes and links through the reference's own cable solve, the tip offset and
the instrument frame through its forward kinematics); on virtual-prototype
data the diagnosis names the hidden effect and explains the gap. SI units.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

ROBOTS = Path(__file__).resolve().parents[1] / "python" / "cdsm" / "robots"


@pytest.fixture(scope="module")
def arm(cdsm, ref):
    robot = cdsm.Robot.packaged("two_universal")
    mirror = ref.load_robot(ROBOTS / "two_universal.toml")
    return robot, mirror


def _commands(robot, rows=12, seed=0):
    rng = np.random.default_rng(seed)
    th = rng.uniform(-0.4, 0.4, (rows, robot.n))
    dl = rng.uniform(-1e-3, 1e-3, (rows, len(robot.position_cables)))
    return th, dl


def _ref_tips(mirror, lengths, seed, tip=None, frame=None):
    """Positions (N, 3) m of the reference arm settled at the position-cable
    ``lengths`` from ``seed``, seen through a tip offset and a frame."""
    from conftest import reference as ref

    sol = ref.solve_cables(mirror, lengths, seed=seed)
    assert sol["converged"].all()
    f = ref.fk_matrix(mirror, sol["theta"])
    p = f[:, :3, 3] + (0 if tip is None else np.einsum("nij,j->ni", f[:, :3, :3], tip))
    if frame is not None:
        p = p @ ref.exp_so3(frame[:3]).T + frame[3:]
    return p


def test_zero_parameters_are_the_nominal_arm(cdsm, arm):
    from cdsm.calibration import plant

    robot, _ = arm
    th, _ = _commands(robot)
    obs, ok = plant.predict(robot, np.zeros(plant.size(robot)), th)
    assert ok.all()
    np.testing.assert_allclose(obs, robot.fk(th), rtol=0, atol=1e-12)


@pytest.mark.parametrize("effect", ["actuation_scale", "cable_offset", "hole_position", "link_length",
                                    "tip_offset", "frame_misalignment"])
def test_each_effect_matches_the_reference(cdsm, ref, arm, effect):
    from cdsm.calibration import plant

    robot, mirror = arm
    th, dl = _commands(robot)
    pos = ref.position_cables(mirror)
    lay = plant.layout(robot)
    p = np.zeros(plant.size(robot))
    l_ref = ref.cable_lengths(mirror, np.zeros((1, robot.n)))[0, pos]
    cmd = ref.cable_lengths(mirror, th)[:, pos] + dl
    real, tip, frame, moved = cmd, None, None, mirror
    rng = np.random.default_rng(4)
    if effect == "actuation_scale":
        p[lay[effect]] = 0.03
        real = l_ref + 1.03 * (cmd - l_ref)
    elif effect == "cable_offset":
        o = rng.uniform(-3e-4, 3e-4, len(pos))
        p[lay[effect]] = o
        real = cmd + o
    elif effect == "hole_position":
        d = rng.uniform(-2e-4, 2e-4, lay[effect].stop - lay[effect].start)
        p[lay[effect]] = d
        holes, k = list(mirror.holes), 0
        for c in pos:  # the holes of the position-controlled cables, in order
            h = np.array(holes[c], dtype=float)
            holes[c] = h + d[k:k + h.size].reshape(h.shape)
            k += h.size
        moved = dataclasses.replace(mirror, holes=tuple(holes))
    elif effect == "link_length":
        d = rng.uniform(-3e-4, 3e-4, lay[effect].stop - lay[effect].start)
        p[lay[effect]] = d
        nj = robot.n
        moved = dataclasses.replace(mirror, offsets=mirror.offsets + d[:3 * nj].reshape(nj, 3),
                                    link_after=mirror.link_after + d[3 * nj:].reshape(-1, 3))
    elif effect == "tip_offset":
        tip = np.array([1e-3, -5e-4, 2e-4])
        p[lay[effect]] = tip
    else:
        frame = np.array([0.2, -0.1, 0.3, 1.2, -0.4, 0.5])
        p[lay[effect]] = frame
    obs, ok = plant.predict(robot, p, th, dl)
    assert ok.all()
    want = _ref_tips(moved, real, th, tip, frame)
    np.testing.assert_allclose(obs[:, :3], want, rtol=0, atol=1e-9)
    assert np.abs(obs[:, :3] - robot.fk(th)[:, :3]).max() > 1e-5  # the effect is visible


def test_backlash_loses_the_dead_band_on_a_reversal(cdsm, ref, arm):
    """Two rows on the same command, the second after going 1 mm beyond: the
    realised lengths differ by the whole dead band 2b of each cable."""
    from cdsm.calibration import plant

    robot, mirror = arm
    pos = ref.position_cables(mirror)
    b = np.array([4e-5, 3e-5, 2e-5, 5e-5])
    p = plant.params(robot, {"backlash": b})
    th = np.tile(np.array([0.1, -0.2, 0.15, 0.05]), (3, 1))
    dl = np.zeros((3, len(pos)))
    dl[1] = 1e-3  # go beyond, then come back to the same command
    obs, ok = plant.predict(robot, p, th, dl)
    assert ok.all()
    cmd = ref.cable_lengths(mirror, th[:1])[:, pos]
    l_ref = ref.cable_lengths(mirror, np.zeros((1, robot.n)))[0, pos]
    first = np.where(cmd > l_ref, cmd - b, cmd + b)  # approached from the straight pose
    back = cmd + 1e-3 - b + 0.0  # state after going beyond ...
    back = np.where(cmd - back < -b, cmd + b, back)  # ... then down by 1 mm: reversal
    np.testing.assert_allclose(obs[0, :3], _ref_tips(mirror, first, th[:1])[0], atol=1e-9)
    np.testing.assert_allclose(obs[2, :3], _ref_tips(mirror, back, th[:1])[0], atol=1e-9)


def test_spatial_measurement_csv(cdsm, tmp_path):
    from cdsm.calibration import measurements

    robot = cdsm.Robot.packaged("two_universal")
    text = ("theta_1,theta_2,theta_3,theta_4,dL_1,dL_3,x,y,z,rx,ry,rz,point\n"
            "0.1,0,0,0,1e-3,0,0.06,0.001,0,0,0,0.1,a\n0,0.1,0,0,0,0,,,,,,,b\n")
    m = measurements.parse_csv(text, robot.n, "t.csv", cables=len(robot.position_cables))
    assert m.reading == "absolute" and m.measured.shape == (2, 3) and m.measured_rot.shape == (2, 3)
    assert m.dL.shape == (2, 4) and m.dL[0, 0] == 1e-3 and np.isnan(m.measured[1]).all()
    with pytest.raises(cdsm.CdsmInputError, match="dL_5"):
        measurements.parse_csv("theta_1,theta_2,theta_3,theta_4,dL_5,x,y,z\n0,0,0,0,0,0,0,0\n", 4, "t", 4)
    with pytest.raises(cdsm.CdsmInputError, match="rx, ry, rz"):
        measurements.parse_csv("theta_1,theta_2,theta_3,theta_4,x,y,z,rx\n0,0,0,0,0,0,0,0\n", 4, "t", 4)
    with pytest.raises(cdsm.CdsmInputError, match="theta_1"):
        measurements.parse_csv("x_cmd,y_cmd,x,y,z\n0,0,0,0,0\n", 4, "t", 4)


@pytest.mark.parametrize("effect, values", [("actuation_scale", [0.03]),
                                            ("tip_offset", [1e-3, -5e-4, 2e-4]),
                                            ("backlash", [4e-5, 3e-5, 2e-5, 5e-5])])
def test_the_diagnosis_names_each_effect(cdsm, arm, effect, values):
    from cdsm.calibration import diagnosis, plant

    robot, _ = arm
    vp = plant.VirtualPrototype(robot, {effect: values}, noise=10e-6, seed=3)
    th, dl = vp.random_commands(40, limit=0.4)
    d = diagnosis.diagnose(robot, vp.measure(th, dl), frame="base", noise=10e-6,
                           effects=["actuation_scale", "cable_offset", "tip_offset", "backlash"])
    assert d.best == effect and d.verdict == "explained"
    assert d.baseline.heldout_rms > 3 * d.noise_floor
    assert d.noise_floor == pytest.approx(np.sqrt(3) * 10e-6)  # three position components


def test_a_tracker_frame_is_registered_in_3d(cdsm, arm):
    from cdsm.calibration import diagnosis, plant

    robot, _ = arm
    frame = [0.3, -0.2, 0.5, 1.2, -0.4, 0.3]
    vp = plant.VirtualPrototype(robot, {"frame_misalignment": frame, "tip_offset": [1e-3, -5e-4, 2e-4]},
                                noise=10e-6, seed=5)
    th, dl = vp.random_commands(40, limit=0.4)
    d = diagnosis.diagnose(robot, vp.measure(th, dl), noise=10e-6, effects=["tip_offset", "cable_offset"])
    assert d.prep.registered and d.registration_named
    assert d.best == "frame_misalignment+tip_offset" and d.verdict == "explained"
    got = d.final().fit.p[plant.effect_indices(robot, "frame_misalignment")]
    # 10 µm of noise over a workspace a few cm wide: the rotation to ~1e-3 rad,
    # the translation (metres away) to a few tens of µm
    np.testing.assert_allclose(got[:3], frame[:3], atol=1e-3)
    np.testing.assert_allclose(got[3:], frame[3:], atol=5e-5)
    # the report and the command line show the tip offset's three parameters (a
    # zip over the planar labels showed two), as the JSON has them
    from cdsm.report import diagnosis as report

    rows = report.param_rows(d, d.chosen)
    assert [lab for _, lab, *_ in rows] == [f"tip offset {a} (end frame)" for a in "xyz"]
    assert [v for *_, v, _ in rows] == d.to_json()["chosen"]["params"]["tip_offset"]
    effect_line = next(ln for ln in report.summary(d) if ln.startswith("Effect: "))
    assert all(f"{lab} = {txt}" in effect_line for _, lab, txt, _, _ in rows)


def test_a_spatial_frame_is_reported_in_six_labelled_parameters(cdsm, arm, parameter_table):
    """A spatial frame has a rotation vector (rad) and a translation (m):
    six rows, each in its unit (a zip over the planar labels showed three,
    the rotation in mm), and the command line lists them all."""
    robot, _ = arm
    frame = [0.3, -0.2, 0.05, 1.2, -0.4, 3e-4]
    rows, notes = parameter_table(robot, {"frame_misalignment": frame}, {"frame_misalignment": [1e-3] * 3 + [2e-5] * 3})
    assert rows == {("frame_misalignment", "instrument frame rotation vector, x"): "+17.19 ± 0.06°",
                    ("frame_misalignment", "instrument frame rotation vector, y"): "-11.46 ± 0.06°",
                    ("frame_misalignment", "instrument frame rotation vector, z"): "+50.00 ± 1.00 mrad",
                    ("frame_misalignment", "instrument frame x"): "+1200.000 ± 0.020 mm",
                    ("frame_misalignment", "instrument frame y"): "-400.000 ± 0.020 mm",
                    ("frame_misalignment", "instrument frame z"): "+300.0 ± 20.0 µm"}
    assert notes == []


def test_every_spatial_parameter_is_listed_under_its_own_label(cdsm, parameter_table):
    """``sjtu_snake``'s 36 cable offsets (24 were listed, under the planar
    labels "upper cable 2i+1 (pair i+1)"), ``two_universal``'s 18 link
    parameters (5 were), its joint axes in mrad (they were in mm) and its
    holes by cable, disk face and axis."""
    snake = cdsm.Robot.packaged("sjtu_snake")
    off = np.linspace(-2e-4, 2e-4, 36)
    rows, _ = parameter_table(snake, {"cable_offset": off}, {"cable_offset": np.full(36, 1e-5)})
    assert list(rows) == [("cable_offset", f"cable {c} (to disk {(c - 1) % 12 + 1})") for c in range(1, 37)]
    assert rows[("cable_offset", "cable 36 (to disk 12)")] == "+200.0 ± 10.0 µm"
    two = cdsm.Robot.packaged("two_universal")
    rows, _ = parameter_table(two, {"link_length": np.full(18, 1e-4), "joint_axis": np.full(8, 4e-3)},
                              {"link_length": np.full(18, 1e-5), "joint_axis": np.full(8, 1e-4)})
    labels = [lab for _, lab in rows]
    assert labels[:4] == ["joint 1 offset, x", "joint 1 offset, y", "joint 1 offset, z", "joint 2 offset, x"]
    assert labels[12:18] == [f"disk {d} link after, {a}" for d in (1, 2) for a in "xyz"]
    assert labels[18:20] == ["joint 1 tilt d1 (toward e1)", "joint 1 tilt d2 (toward e2)"] and len(labels) == 26
    assert rows[("joint_axis", "joint 4 tilt d2 (toward e2)")] == "+4.00 ± 0.10 mrad"
    holes = 3 * sum(2 * two.cable_ends[c] + 1 for c in two.position_cables)
    rows, _ = parameter_table(two, {"hole_position": np.full(holes, 5e-5)}, {"hole_position": np.full(holes, 1e-5)})
    assert len(rows) == holes == 3 * (3 + 3 + 5 + 5)
    assert ("hole_position", "cable 5, disk 2 face b, z") in rows  # the 0° cable to disk 2 (cables 1, 2, 5, 6)


def test_compensated_commands_put_the_reference_arm_on_target(cdsm, ref, arm, tmp_path):
    """Commands from a fitted spatial model, played on the NumPy reference arm
    with the same actuator gain and offsets computed independently, land on
    the targets; the nominal commands miss by about the offsets' effect."""
    from cdsm.calibration.model import FittedPlant

    robot, mirror = arm
    pos = ref.position_cables(mirror)
    off = np.array([1e-4, -2e-4, 5e-5, 0.0])
    model = FittedPlant.from_effects(robot, {"actuation_scale": [0.03], "cable_offset": off})
    path = tmp_path / "m.json"
    model.save(path)
    model = FittedPlant.load(path)
    th = np.random.default_rng(1).uniform(-0.3, 0.3, (6, robot.n))
    targets = robot.fk(th)[:, :3]
    c = model.compensate(targets)
    assert c.converged.all() and c.commands.shape == (6, len(pos)) and not any(c.flags)
    l_ref = ref.cable_lengths(mirror, np.zeros((1, robot.n)))[0, pos]

    def played(cmd):
        return _ref_tips(mirror, l_ref + 1.03 * (cmd - l_ref) + off, seed=c.theta_cmd)

    np.testing.assert_allclose(played(c.commands), targets, rtol=0, atol=1e-9)
    miss = np.linalg.norm(played(c.nominal_commands) - targets, axis=1)
    assert (miss > 1e-4).all()
    np.testing.assert_allclose(c.predicted_error_nominal, miss, rtol=1e-6)


def test_cli_compensate_spatial_targets(cdsm, arm, tmp_path, capsys):
    from cdsm.calibration.model import FittedPlant
    from cdsm.cli import main

    robot, _ = arm
    FittedPlant.from_effects(robot, {"actuation_scale": [0.03]}).save(tmp_path / "m.json")
    tips = robot.fk(np.random.default_rng(2).uniform(-0.3, 0.3, (3, robot.n)))
    t = tmp_path / "t.csv"
    t.write_text("x,y,z,rx,ry,rz\n" + "".join(",".join(repr(float(v)) for v in r) + "\n" for r in tips))
    out = tmp_path / "o.csv"
    assert main(["compensate", str(t), "--model", str(tmp_path / "m.json"), "--out", str(out)]) == 0
    lines = [ln for ln in out.read_text().splitlines() if not ln.startswith("#")]
    head = lines[0].split(",")
    cab = [f"L_{i + 1}" for i in range(len(robot.position_cables))]  # numbered as dL_i of measurement files
    assert head[:6 + len(cab)] == ["x", "y", "z", "rx", "ry", "rz"] + cab and "predicted_rotation_error" in head
    assert all(r.split(",")[head.index("converged")] == "1" for r in lines[1:])
    t.write_text("x,y,z,rx\n0,0,0.3,0\n")
    assert main(["compensate", str(t), "--model", str(tmp_path / "m.json"), "--out", str(out)]) == 2
    assert "rx" in capsys.readouterr().err


def test_a_rank_deficient_fit_gives_correlations_not_overflow_warnings(cdsm):
    """hole_position of two_universal (every hole coordinate) fitted on 8
    rows: far more parameters than the rows determine. No RuntimeWarning
    reaches the user; every correlation is within [-1, 1] or undetermined
    (NaN), and the undetermined parameters say so (NaN standard deviation)."""
    import warnings

    from cdsm.calibration import diagnosis, plant
    from cdsm.calibration.fit import fit

    robot = cdsm.Robot.from_toml("two_universal")
    vp = plant.VirtualPrototype(robot, {"actuation_scale": [0.02]}, noise=10e-6, seed=3)
    th, dl = vp.random_commands(8, limit=0.3)
    prep = diagnosis.prepare(robot, vp.measure(th, dl), frame="base")
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        f = fit(prep, ["hole_position", "actuation_scale"])
    c = f.corr[np.isfinite(f.corr)]
    assert c.size and np.abs(c).max() <= 1.0
    assert np.isnan(f.std).any()


@pytest.fixture(scope="module")
def two_trackers(cdsm, arm):
    """The diagnoses of one arm (a tip offset) read without noise by trackers in
    two frames, registered: the same gaps seen in two measuring frames."""
    from cdsm.calibration import diagnosis, plant

    robot, _ = arm
    out = []
    for frame in ([0.3, -0.2, 0.5, 1.2, -0.4, 0.3], [-1.1, 0.4, 2.0, -0.5, 0.8, 0.2]):
        vp = plant.VirtualPrototype(robot, {"frame_misalignment": frame, "tip_offset": [1e-3, -5e-4, 2e-4]},
                                    noise=0.0, seed=5)
        th, dl = vp.random_commands(30, limit=0.4)
        d = diagnosis.diagnose(robot, vp.measure(th, dl), noise=10e-6, effects=["tip_offset"])
        assert d.prep.registered
        out.append(d)
    return out


def test_the_residual_map_draws_the_same_gaps_whatever_frame_the_tracker_reads_in(two_trackers):
    """The gap arrows stand at the tips in the robot's base frame, so they point in the base frame: the
    same arm read without noise by trackers in two frames gives the same arrows; drawn as the trackers'
    own components they turned with each tracker."""
    from cdsm.report import diagnosis as report

    arrows = []
    for d in two_trackers:
        fig = report.residual_map_figure(d)
        q = fig.axes[0].collections[-1]  # the nominal model's arrows
        arrows.append(np.stack([np.asarray(q.U), np.asarray(q.V)], 1))
    np.testing.assert_allclose(arrows[0], arrows[1], rtol=0, atol=1e-6 * np.abs(arrows[0]).max())


def test_residuals_csv_holds_every_axis_in_the_base_frame(two_trackers, tmp_path):
    """A spatial arm's gaps have three components: `residuals.csv` writes
    x, y and z (it wrote two), in the robot's base frame whatever frame the
    tracker reads in: two trackers reading the same noiseless arm give the
    same gaps and commanded tips, each gap as long as the diagnosis's
    frame-free residual (measured − model)."""
    import csv

    from cdsm.calibration import diagnosis
    from cdsm.report import diagnosis as report

    tables = []
    for d in two_trackers:
        paths = report.write(d, tmp_path / f"rep{len(tables)}")
        with open(paths["csv"], encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
        cols = [f"gap_nominal_d{a}_m" for a in "xyz"] + ["x_cmd_m", "y_cmd_m", "z_cmd_m"]
        tables.append(np.array([[float(r[c]) for c in cols] for r in rows]))
        # the nominal gap's length is the frame-free distance measured − model
        gap = np.array([[float(r[f"gap_nominal_d{a}_m"]) for a in "xyz"] for r in rows])
        np.testing.assert_allclose(np.linalg.norm(gap, axis=1),
                                   np.linalg.norm(diagnosis.residuals(d, "baseline"), axis=1), rtol=1e-12)
    np.testing.assert_allclose(tables[0], tables[1], rtol=0, atol=1e-6 * np.abs(tables[0]).max())
