"""Issue 12: the paper's loads in four readings, and Table 3's execution order.

Facts stated: the paper's prototype read with 50/10/5 g or 5/10/50 g on disks
1..3, in a horizontal plane or with gravity along -Y, keeps every upper cable
taut over 97.6 %, 24.8 %, 100 % and 94.9 % of the ±30° grid (by the NumPy
reference's statics, written independently of the core); the robot files and
``load_readings`` give exactly those robots; a dead band of half-width b costs
a move that starts right after a reversal exactly 2b of cable; a row whose
nominal configuration needs a slack cable is flagged, not scored.
"""

from __future__ import annotations

import numpy as np
import pytest

G0 = 9.80665
READINGS = {  # packaged name: (weights g on disks 1..3, gravity m/s^2, taut % of the ±30° grid)
    "paper": ([50, 10, 5], [0.0, 0.0], 97.6),
    "paper_reversed_weights": ([5, 10, 50], [0.0, 0.0], 24.8),
    "paper_vertical": ([50, 10, 5], [0.0, -G0], 100.0),
    "paper_vertical_reversed_weights": ([5, 10, 50], [0.0, -G0], 94.9),
}


def grid30() -> np.ndarray:
    d = np.deg2rad(np.arange(-30.0, 30.1, 5.0))
    return np.array(np.meshgrid(d, d, d, indexing="ij")).reshape(3, -1).T


@pytest.mark.parametrize("name", list(READINGS))
def test_packaged_readings_keep_the_stated_share_of_the_grid_taut(cdsm, ref, name):
    weights, gravity, taut = READINGS[name]
    r = cdsm.Robot.packaged(name)
    np.testing.assert_allclose(r.lower_tension, np.array(weights) * 1e-3 * G0, rtol=1e-12)
    np.testing.assert_array_equal(r.gravity, gravity)
    th = grid30()
    T = ref.tensions(r, th, lower=r.lower_tension, gravity=np.array(gravity), mass=r.mass)
    share = 100.0 * (T > 0).all(axis=1).mean()
    assert share == pytest.approx(taut, abs=0.05)
    np.testing.assert_array_equal(r.feasible(th), (T > 0).all(axis=1))  # the robot's gravity is the default


def test_load_readings_of_the_paper_robot_are_the_packaged_files(cdsm):
    from cdsm.accuracy.statics import load_readings

    files = ["paper", "paper_reversed_weights", "paper_vertical", "paper_vertical_reversed_weights"]
    th = grid30()[::37]
    for (key, r), f in zip(load_readings(cdsm.Robot.paper()).items(), files):
        p = cdsm.Robot.packaged(f)
        np.testing.assert_array_equal(r.tensions(th), p.tensions(th), err_msg=key)
        np.testing.assert_array_equal(r.gravity, p.gravity)
    assert cdsm.Robot.paper().to_toml() == cdsm.Robot.packaged("paper").to_toml()


def test_unknown_packaged_robot_is_named(cdsm):
    with pytest.raises(cdsm.CdsmInputError, match="paper_vertical"):
        cdsm.Robot.packaged("no such robot")


def test_a_move_after_a_reversal_loses_the_whole_dead_band(cdsm):
    """Table 3 executed after reversals on a plant whose only effect is a dead
    band b on cable 1: the approach ends at L - 1 mm + b, the base is reached
    from below at L - b, and the -1 mm move ends at L - 1 mm + b: it realises
    -(1 mm - 2b), exactly the nominal arm's displacement between those two
    lengths."""
    from cdsm.calibration import diagnosis, measurements, plant

    robot = cdsm.Robot.paper()
    b = 30e-6
    t3 = measurements.packaged("table3")
    rev = measurements.after_reversals(t3)
    assert len(rev) == 2 * len(t3) and np.array_equal(rev.observed, np.tile([False, True], len(t3)))
    prep = diagnosis.prepare(robot, rev)
    p = plant.params(robot, {"backlash": [b, 0.0, 0.0]})
    got, ok = plant.predict(robot, p, prep.theta_cmd, prep.dL, prep.reading_codes)
    assert ok.all()
    th = prep.theta_cmd[1::2]
    base, end = np.zeros_like(th), prep.dL[1::2].copy()
    base[:, 0] -= b
    end[:, 0] += b
    nominal = np.zeros_like(p)
    want = plant.predict(robot, nominal, th, end)[0] - plant.predict(robot, nominal, th, base)[0]
    np.testing.assert_allclose(got[1::2, :2], want[:, :2], rtol=0, atol=1e-12)
    # in file order only some moves follow a reversal
    prep_f = diagnosis.prepare(robot, t3)
    file_order, _ = plant.predict(robot, p, prep_f.theta_cmd, prep_f.dL, prep_f.reading_codes)
    lost = np.abs(file_order[:, :2] - want[:, :2]).max(axis=1) < 1e-9
    assert 0 < lost.sum() < len(t3)
    with pytest.raises(cdsm.CdsmInputError, match="displacement"):
        measurements.after_reversals(plant.VirtualPrototype(robot).measure(prep.theta_cmd[:2]))


def test_rows_that_need_a_slack_cable_are_flagged(cdsm, ref):
    """With 5/10/50 g in a horizontal plane Table 3's points 7-9 cannot be held
    with taut cables (reference statics): the diagnosis flags them and scores
    the other six."""
    from cdsm.calibration import diagnosis, measurements

    r = cdsm.Robot.packaged("paper_reversed_weights")
    t3 = measurements.packaged("table3")
    prep = diagnosis.prepare(r, t3)
    T = ref.tensions(r, prep.theta_cmd, lower=r.lower_tension, mass=r.mass)
    slack = ~(T > 0).all(axis=1)
    assert list(np.flatnonzero(slack) + 1) == [7, 8, 9]
    assert set(prep.flags) == set(np.flatnonzero(slack)) and not prep.usable[slack].any()
    assert all("slack" in prep.flags[i] for i in prep.flags)
    d = diagnosis.diagnose(r, t3)
    assert d.to_json()["rows_used"] == 6 and set(d.to_json()["flagged_rows"]) == {"7", "8", "9"}


def test_after_reversals_keeps_what_the_data_say_about_themselves(cdsm):
    """The copy run after reversals is the same data set in another order: its
    fold groups and its sampling (fields of the measurements, not of the rows)
    are carried, not dropped; the approach rows are unmeasured."""
    import dataclasses

    from cdsm.calibration import measurements

    t3 = measurements.packaged("table3")
    t3 = dataclasses.replace(t3, labels={**t3.labels, "group": [str(i // 3) for i in range(len(t3))]},
                             fold_groups="group", sampled=True)
    rev = measurements.after_reversals(t3)
    assert rev.fold_groups == "group" and rev.sampled
    assert rev.labels["group"][1::2] == t3.labels["group"]
    assert not rev.observed[0::2].any()
