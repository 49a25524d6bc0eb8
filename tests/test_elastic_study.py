"""The robot-neutral accuracy study (``cdsm paper``) on a small elastic arm: commands
sampled in a box, each error settled at its own equilibrium from the same commands, the
CSVs written, the sections that cannot apply saying so.  SI units."""

from __future__ import annotations

import csv

import numpy as np
import pytest

import cdsm
from cdsm import CdsmInputError, report, study
from test_elastic_plant import two_segments


@pytest.fixture(scope="module")
def elastic_study():
    robot = cdsm.Robot.from_toml_str(two_segments())
    return study.run(robot, samples=6, configurations=12, progress=False)


def test_the_study_of_an_elastic_arm_samples_commands(elastic_study):
    st = elastic_study
    assert st.protocols == ["commanded"]
    ws = st.workspaces["commanded"]
    assert ws.commands.shape == (12, 6) and np.abs(ws.commands).max() <= 3e-3
    assert ws.reachable.all()
    # every single error on every commanded cable: its length, its holes radially and along the normal, both signs
    assert len(st.scenarios) == 6 * 3 * 2
    mc = st.monte_carlo["commanded"]
    np.testing.assert_array_equal(mc.count + mc.failed, 6)
    assert st.budget is not None and len(st.budget.groups) == 12  # 6 cables' lengths, 6 cables' holes
    assert not st.friction  # frictionless statics: the section says it does not apply


def test_a_single_error_is_the_equilibrium_of_the_shifted_commands(elastic_study):
    """``cable2+`` (+1 mm on cable 2's length) at every configuration: the tip of
    ``Robot.equilibrium`` with cable 2 paid out 1 mm more (displacement ``d - 1 mm``), the
    rows in the same sequence, minus the nominal tip."""
    st = elastic_study
    robot, ws = st.robot, st.workspaces["commanded"]
    d = -ws.commands
    moved = d.copy()
    moved[:, 1] -= 1e-3
    nominal = robot.equilibrium(displacements=d, sequence=True)
    shifted = robot.equilibrium(displacements=moved, sequence=True)
    want = robot.fk(shifted.theta)[:, :3] - robot.fk(nominal.theta)[:, :3]
    got = st.result("cable2+").dS[:, :3]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert np.abs(want).max() > 1e-3


def test_the_study_writes_its_csvs_and_says_what_does_not_apply(elastic_study, tmp_path):
    paths = report.write(elastic_study, tmp_path / "out", progress=False, detail=False)
    for key in ("scenarios_csv", "montecarlo_csv", "configurations_csv", "jumps_csv", "friction_csv"):
        assert (tmp_path / "out" / paths[key].split("/")[-1]).exists(), key
    rows = list(csv.DictReader(line for line in open(paths["montecarlo_csv"]) if not line.startswith("#")))
    assert len(rows) == 12 and all(r["protocol"] == "commanded" for r in rows)
    assert all(int(r["samples"]) == 6 for r in rows)
    conf = list(csv.DictReader(line for line in open(paths["configurations_csv"]) if not line.startswith("#")))
    assert "tension_cable6_n" in conf[0]
    text = open(paths["report_md"]).read()
    assert "Does not apply: an elastic arm's statics is its frictionless equilibrium" in text
    assert "sampled command-space protocol" in text


def test_an_elastic_arms_study_takes_no_joint_angles():
    robot = cdsm.Robot.from_toml_str(two_segments())
    with pytest.raises(CdsmInputError, match="`theta`: an elastic arm's configurations are the equilibria"):
        study.run(robot, theta=np.zeros((10, robot.n)), progress=False)


def test_jump_points_are_the_commands_with_two_equilibria():
    """A heavy rod standing up (gravity along -x, 0.1 kg per station on four
    stations: past its buckling load) held by two tendons at 0 and 180 deg: a
    1 mm pull on the first leans it 62 mm that way; a slight pull on the other
    then leaves it leaning there when settled along the sequence, and takes it
    62 mm the other way from the rest angles — two equilibria of one command,
    the jump points; the pulls alone have one. The small arm of the study has
    one equilibrium at every sampled command: no jump point."""
    from cdsm.accuracy import plant_errors
    from cdsm.calibration import plant
    from elastic_cases import rod_toml

    cables = "".join(f'[[cables]]\nend = 4\nmode = "displacement"\nradius = 0.004\nangle = {a!r}\n'
                     "stiffness = 3000.0\npretension = 0.5\n" for a in (0.0, np.pi))
    robot = cdsm.Robot.from_toml_str(rod_toml(4, 0.1, cables, gravity="[-9.80665, 0.0, 0.0]", mass=0.1))
    dL = -np.array([[1e-3, 0.0], [0.0, 1e-4], [0.0, 1e-4], [1e-3, 0.0]])  # pulls (dL = -d)
    t = np.tile(robot.rest_angles, (4, 1))
    theta, ok = plant.settle(robot, np.zeros(plant.size(robot)), t, dL)
    assert ok.all()
    tip_y = robot.fk(theta)[:, 1]
    assert (tip_y > 0.05).all()  # leaning towards the first tendon all along
    np.testing.assert_array_equal(plant_errors.path_dependent(robot, dL, theta, ok), [False, True, True, False])
    small = cdsm.Robot.from_toml_str(two_segments())
    ws = plant_errors.sample_commands(small, 40)
    assert ws.reachable.all() and not ws.path_dependent.any()


def test_a_planar_elastic_arms_hole_errors_go_to_its_plants_hole_heights():
    """A planar elastic arm (springs on the paper arm's joints) has the plant
    block ``hole_height`` (per disk), not ``hole_position``: its Monte Carlo
    draws the paper's ±0.35 mm there by default (it drew none), its
    single hole errors and sensitivities use it, and its study completes (it
    failed on an index)."""
    from cdsm.accuracy import plant_errors
    from cdsm.calibration import plant
    from test_elastic import planar_text

    robot = cdsm.Robot.from_toml_str(planar_text())
    lay = plant.layout(robot)
    assert plant_errors.hole_block(robot) == "hole_height"
    tol = plant_errors.tolerance_vector(robot)
    np.testing.assert_array_equal(tol[lay["hole_height"]], 0.35e-3)
    dh = np.array([2e-4, -1e-4, 3e-4])
    np.testing.assert_array_equal(plant_errors.error_parameters(robot, None, dh)[lay["hole_height"]], dh)
    s = plant_errors.sensitivities_commands(robot, np.zeros((2, 3)))
    assert s["hole_height"].shape == (2, 3, 3) and np.isfinite(s["hole_height"]).all()
    st = study.run(robot, samples=4, configurations=12, progress=False)
    assert len(st.scenarios) == 3 * 2 * 2  # each position cable's length and each disk's hole height, both signs


def test_a_planar_hole_height_error_is_the_arm_with_its_holes_moved():
    """The plant's per-disk ``hole_height`` on a planar arm, rigid or sprung,
    settles where the same arm built with its holes moved
    (``Robot.hole_height_error``) settles for the same rest lengths: the
    plant's commands are the nominal arm's lengths at ``theta_cmd`` + dL, so
    the moved arm is commanded ``dL + L_nominal - L_moved``."""
    from cdsm.accuracy import plant_errors
    from cdsm.calibration import plant
    from elastic_cases import planar_text

    dh = np.array([2e-4, -1e-4, 3e-4])
    dL = np.array([[1e-4, -2e-4, 0.0], [0.0, 0.0, 0.0]])
    for robot, theta in ((cdsm.Robot.paper(), np.radians([[10.0, -5.0, 20.0], [0.0, 15.0, -10.0]])),
                         (cdsm.Robot.from_toml_str(planar_text()), None)):
        theta = np.tile(robot.rest_angles, (2, 1)) if theta is None else theta
        got, ok = plant.predict(robot, plant_errors.error_parameters(robot, None, dh), theta, dL)
        moved = robot.with_holes(robot.hole_height_error(dh))
        assert moved.is_elastic == robot.is_elastic
        same = dL + robot.position_lengths(theta) - moved.position_lengths(theta)
        want, ok2 = plant.predict(moved, np.zeros(plant.size(moved)), theta, same)
        assert ok.all() and ok2.all()
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
