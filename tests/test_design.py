"""Issue 6: experiment design (cdsm.calibration.experiment.suggest) on Table-3-style data.

Setting: the virtual prototype has a 2 % actuation-scale error and is
measured like Table 3 — the nine commanded poses, upper cable 1 shortened by
1 mm, tip displacement with 30 µm noise per axis. On such data shortening
cable 1 by (1 + s) mm and moving the holes of pair 1 change the same
displacement almost identically. With 10 µm noise the 9 rows still separate
the two (held-out 13 vs 23 µm); with 30 µm (closer to what the laser-tracker
data of the real prototype show) they tie, and for noise seed 12 the
diagnosis even ranks hole_height first with actuation_scale tied (and, the
noise given, names it: the likelihood ratio supports it on nine rows).
"""

from __future__ import annotations

import numpy as np
import pytest

NOISE = 30e-6
TRUTH = {"actuation_scale": [0.02]}


@pytest.fixture(scope="module")
def setting(cdsm):
    from cdsm.calibration import diagnosis as diagnose, measurements, plant

    robot = cdsm.Robot.paper()
    t3 = measurements.packaged("table3")
    prep = diagnose.prepare(robot, t3)
    vp = plant.VirtualPrototype(robot, TRUTH, noise=NOISE, seed=12)
    data = vp.measure(prep.theta_cmd, t3.dL, reading="displacement")
    diag = diagnose.diagnose(robot, data, noise=NOISE)
    return robot, data, diag


def test_table3_style_data_tie_actuation_scale_and_hole_height(setting):
    """With the noise given, the likelihood ratio supports the first effect
    (the held-out signed-rank test supported neither on these nine rows: the
    answer was none): the wrong one is named, explained, and the truth is
    tied with it, which is what the suggested measurements resolve."""
    _, _, diag = setting
    assert diag.singles[0].name == "hole_height"   # the wrong one ranks first ...
    assert "actuation_scale" in diag.ties          # ... and the truth is tied with it
    assert diag.best == "hole_height" and diag.verdict == "explained"
    assert diag.support[0].test == "chi2" and diag.support[0].supported


def test_suggested_measurements_break_the_tie(setting, tmp_path):
    from cdsm.calibration import diagnosis as diagnose, experiment as design, measurements, plant

    robot, data, diag = setting
    sug = design.suggest(diag, 6)
    assert sug.criterion == "discrimination" and sug.reading == "displacement"
    assert sug.models[:2] == ["hole_height", "actuation_scale"]
    # within the joint limits, taut cables, one cable at ±1 mm per row (Table-3 style)
    assert robot.within_limits(sug.theta).all() and robot.feasible(sug.theta).all()
    assert np.allclose(np.sort(np.abs(sug.dL), axis=1), [0, 0, 1e-3])
    # expected separation grows; the summary says so
    assert sug.pairs_after["hole_height vs actuation_scale"] > 10
    assert "hole_height vs actuation_scale" in sug.summary()
    # measure the suggestions on the prototype (fresh noise) and diagnose again
    new = plant.VirtualPrototype(robot, TRUTH, noise=NOISE, seed=112).measure(sug.theta, sug.dL, "displacement")
    again = diagnose.diagnose(robot, design.combine(robot, data, new), noise=NOISE)
    assert again.best == "actuation_scale" and again.verdict == "explained"
    # the CSV is a measurement table once the measured columns are added
    path = tmp_path / "suggest.csv"
    sug.to_csv(path)
    text = path.read_text()
    lines = [ln for ln in text.splitlines() if not ln.startswith("#")]
    assert lines[0].split(",")[:7] == ["point", "theta_1", "theta_2", "theta_3", "dL_1", "dL_2", "dL_3"]
    filled = "\n".join([lines[0] + ",dx,dy"] + [ln + f",{a!r},{b!r}" for ln, (a, b)
                                                  in zip(lines[1:], new.measured.tolist())])
    back = measurements.parse_csv(filled, 3)
    assert back.reading == "displacement"
    assert np.array_equal(back.theta, sug.theta) and np.array_equal(back.dL, sug.dL)


def test_single_model_falls_back_to_d_optimal(cdsm):
    from cdsm.calibration import diagnosis as diagnose, experiment as design, plant

    robot = cdsm.Robot.paper()
    vp = plant.VirtualPrototype(robot, {"hole_height": [2e-4, -1e-4, 1.5e-4]}, seed=3)
    th, dl = vp.random_commands(30)
    diag = diagnose.diagnose(robot, vp.measure(th, dl), effects=["hole_height", "tip_offset"])
    assert diag.best == "hole_height" and not diag.ties
    sug = design.suggest(diag, 3, pool=100)
    assert sug.criterion == "d-optimal" and sug.reading == "absolute" and len(sug) == 3
    assert np.all(np.diff(sug.gain) > 0)
    assert np.abs(sug.dL).max() <= 1e-3


def test_bad_k(setting, cdsm):
    from cdsm.calibration import experiment as design

    with pytest.raises(cdsm.CdsmInputError, match="k"):
        design.suggest(setting[2], 0)


def test_backlash_tied_with_actuation_scale_gets_moves_in_both_directions(cdsm, tmp_path):
    """Issue 12: Table-3-style displacements, every move right after a reversal
    (it loses the whole dead band), 30 µm backlash on cable 1, 30 µm noise:
    backlash and a -6 % actuation scale tie. The suggestions approach their
    rows from both sides and move the cables both ways, where the two models
    predict differently; measured, they rank backlash first."""
    from cdsm.calibration import diagnosis, experiment, measurements, plant

    robot = cdsm.Robot.paper()
    t3 = measurements.packaged("table3")
    truth = {"backlash": [3e-5, 0.0, 0.0]}
    effects = ["backlash", "actuation_scale"]
    prep = diagnosis.prepare(robot, measurements.after_reversals(t3))
    vp = plant.VirtualPrototype(robot, truth, noise=30e-6, seed=9)
    data = vp.measure(prep.theta_cmd, prep.dL, "displacement", observe=prep.meas.observed)
    diag = diagnosis.diagnose(robot, data, noise=30e-6, effects=effects)
    assert diag.singles[0].name == "backlash" and diag.ties == ["actuation_scale"]  # nine rows cannot tell
    sug = experiment.suggest(diag, 6)
    assert sug.approach is not None and sorted(sug.models) == sorted(effects)
    side = np.sign(sug.approach.mean(axis=1))           # displacement rows: approach relative to the base
    move = np.sign(sug.dL.sum(axis=1))
    assert set(side) == {-1.0, 1.0}                      # approached from above and from below
    assert set(move) == {-1.0, 1.0}                      # moves in both directions
    # the approach commands every cable beyond the base by 1 mm, more than any dead band
    assert np.allclose(np.abs(sug.approach), 1e-3)
    th, dl, seen = sug.commands()
    assert np.array_equal(seen, np.tile([False, True], 6)) and np.array_equal(dl[1::2], sug.dL)
    pb, pa = sug.predictions["backlash"], sug.predictions["actuation_scale"]
    assert np.abs(pb - pa).max() > 2 * 30e-6
    new = plant.VirtualPrototype(robot, truth, noise=30e-6, seed=109).measure(th, dl, "displacement", observe=seen)
    again = diagnosis.diagnose(robot, experiment.combine(robot, data, new), noise=30e-6, effects=effects)
    assert again.singles[0].name == "backlash"
    assert again.singles[1].heldout_rms > 1.5 * again.singles[0].heldout_rms
    # the CSV keeps the approach rows, to run and not to measure
    path = tmp_path / "s.csv"
    sug.to_csv(path)
    rows = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")][1:]
    assert [r.split(",")[0] for r in rows[:2]] == ["s1 approach", "s1"] and len(rows) == 12
