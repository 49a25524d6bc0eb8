"""Inverse statics and compensation of an elastic arm (FTDCR v4: 60 joints, 9 tendons):
tendon displacements that settle the modelled tip on a target, checked through
``Robot.equilibrium`` (not the plant that solved them).  SI units."""

from __future__ import annotations

import numpy as np
import pytest

import cdsm
from cdsm import CdsmInputError
from cdsm.calibration import plant
from cdsm.calibration.compensation import compensate
from cdsm.calibration.inverse_statics import inverse_statics
from cdsm.calibration.model import FittedPlant


@pytest.fixture(scope="module")
def ftdcr():
    robot = cdsm.Robot.load("ftdcr_v4")
    d = np.random.default_rng(5).uniform(-2e-3, 4e-3, (8, 9))  # pulls up to 4 mm, pay-outs up to 2 mm
    eq = robot.equilibrium(displacements=d)
    assert eq.converged.all() and eq.slack.any()  # some tendons hang slack at these commands
    return robot, d, robot.fk(eq.theta)


def tips(robot, displacements):
    eq = robot.equilibrium(displacements=displacements)
    assert eq.converged.all()
    return robot.fk(eq.theta)


def test_round_trip_commands_tip_commands_meets_the_target(ftdcr):
    """Commands -> tips -> inverse statics -> the equilibrium of its displacements puts
    the tip on the target within 1e-9 m (9 tendons for 3 coordinates: other commands than
    the ones that made the tips)."""
    robot, d, tip = ftdcr
    res = inverse_statics(robot, tip[:, :3])
    assert res.converged.all() and not any(res.flags)
    reached = tips(robot, res.displacements)
    np.testing.assert_allclose(reached[:, :3], tip[:, :3], rtol=0, atol=1e-9)
    assert np.abs(res.displacements - d).max() > 1e-4  # a different answer on the null space
    np.testing.assert_allclose(res.seen[:, :3], reached[:, :3], rtol=0, atol=1e-12)
    assert (res.slack > 0).any()  # slack tendons at some answers: left alone, the target met


def test_a_pose_target_meets_position_and_rotation(ftdcr):
    """A full pose (position and rotation vector) the arm took with every tendon pulled
    (taut): 9 tendons reach its 6 coordinates."""
    robot, _, _ = ftdcr
    d = np.random.default_rng(6).uniform(0.5e-3, 3e-3, (3, 9))
    pose = tips(robot, d)
    res = inverse_statics(robot, pose)
    assert res.converged.all() and res.targets.shape == (3, 6)
    np.testing.assert_allclose(tips(robot, res.displacements), pose, rtol=0, atol=1e-9)


def test_a_pose_the_preload_pays_slack_is_reached_from_the_retry(ftdcr):
    """A pose the arm took with tendons slack: from the preload alone the steps pay four
    tendons out until they hang slack (their columns zero) and the pose is not reached —
    flagged with them; the retry from a stronger preload keeps them taut and reaches it."""
    robot, _, tip = ftdcr
    once = inverse_statics(robot, tip[3:4], start=np.full(9, -0.5e-3))
    assert not once.converged[0] and once.slack[0] == 4
    assert once.flags[0].startswith("not reached") and "(4 of 9 commanded cables slack at the answer)" in once.flags[0]
    res = inverse_statics(robot, tip[3:4])
    assert res.converged[0] and res.slack[0] == 0
    np.testing.assert_allclose(tips(robot, res.displacements), tip[3:4], rtol=0, atol=1e-9)


def test_a_target_out_of_reach_is_flagged(ftdcr):
    robot, _, tip = ftdcr
    far = tip[:2, :3] + np.array([0.0, 0.0, 0.5])  # half a metre off a 0.19 m arm
    res = inverse_statics(robot, far, max_iter=15)
    assert not res.converged.any()
    assert all(f.startswith("not reached: predicted tip error") for f in res.flags)
    assert (res.error > 0.1).all()


def test_compensation_of_a_fitted_error_model_meets_the_targets(ftdcr):
    """A synthetic error model (tendon offsets of 0.2 mm): the nominal inverse statics'
    commands leave the modelled tip off by millimetres; the compensated commands put it
    on the target (checked by the equilibrium of the displacements the offsets leave:
    ``-dL - offset``)."""
    robot, _, tip = ftdcr
    offsets = np.linspace(-2e-4, 2e-4, 9)
    model = FittedPlant.from_effects(robot, {"cable_offset": offsets})
    comp = compensate(model, tip[:, :3])
    assert comp.converged.all() and not any(comp.flags)
    assert np.all(comp.predicted_error_nominal > 1e-4)
    assert np.all(comp.predicted_error < 1e-9)
    dl = comp.dL  # the commands are the commanded cables' paths at theta_cmd (the rest angles) + dL
    np.testing.assert_allclose(comp.commands, plant.command_lengths(robot, comp.theta_cmd) + dl, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(comp.theta_cmd, np.tile(robot.rest_angles, (len(tip), 1)))
    np.testing.assert_allclose(tips(robot, -dl - offsets)[:, :3], tip[:, :3], rtol=0, atol=1e-9)
    with pytest.raises(CdsmInputError, match="`start`: applies to an arm commanded by its joint angles"):
        compensate(model, tip[:, :3], start=np.zeros(9))


def test_the_commands_file_of_an_elastic_arm_says_what_its_columns_are(ftdcr, tmp_path):
    """The CSV of an elastic arm's compensation names its commanded tendons and says that
    L_i is a rest length from the rest angles and the tendon's pull is -dL_i (it said
    "upper-cable length commands" and "position-controlled cable" for every robot)."""
    robot, _, tip = ftdcr
    model = FittedPlant.from_effects(robot, {"cable_offset": np.linspace(-2e-4, 2e-4, 9)})
    compensate(model, tip[:2, :3]).to_csv(tmp_path / "c.csv")
    head = [line for line in (tmp_path / "c.csv").read_text().splitlines() if line.startswith("#")]
    assert not any("upper" in line or "position-controlled" in line for line in head)
    assert any("rest length" in line and "pulled by -dL_i" in line and "cables 1, 2, 3, 4, 5, 6, 7, 8, 9" in line
               for line in head)


def test_bad_targets_name_the_field(ftdcr):
    robot, _, _ = ftdcr
    with pytest.raises(CdsmInputError, match="`targets`: expected"):
        inverse_statics(robot, np.zeros((2, 4)))
    with pytest.raises(CdsmInputError, match="`targets`: non-finite"):
        inverse_statics(robot, [[np.nan, 0.0, 0.0]])
    with pytest.raises(CdsmInputError, match="`preload`: expected a pull >= 0 m"):
        inverse_statics(robot, [[0.18, 0.0, 0.0]], preload=-1e-3)
