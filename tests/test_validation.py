"""A diagnosed model judged on a second file (issue 35, item 5: ``cdsm
diagnose TRAIN --validate VAL``): the figures against the NumPy reference
plant run with the parameters the diagnosis fitted, the physics of a right
model (down to the noise on new rows), and nothing refitted."""

from __future__ import annotations

import json

import numpy as np
import pytest

NOISE = 10e-6


def _pair(plant, robot, effects, rows, seed, kind="absolute"):
    """Two data sets of one virtual prototype (the same hidden effects),
    commands and noise drawn independently."""
    vp = plant.VirtualPrototype(robot, effects, noise=NOISE, seed=seed)
    out = []
    for _ in range(2):
        th, dl = vp.random_commands(rows, reading=kind)
        out.append(vp.measure(th, dl, reading=kind))
    return out


def _write(path, m) -> str:
    """A planar measurement table as a user writes it (theta_i, dL_i, x, y
    or dx, dy; SI units)."""
    n = m.n
    meas = ("x", "y") if m.reading == "absolute" else ("dx", "dy")
    head = [f"theta_{i + 1}" for i in range(n)] + [f"dL_{i + 1}" for i in range(n)] + list(meas)
    rows = np.hstack([m.theta, m.dL, m.measured[:, :2]])
    path.write_text(",".join(head) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in rows) + "\n")
    return str(path)


@pytest.mark.parametrize("robot_name, effects, frame", [
    ("paper_vertical", {"link_length": [4e-4, -3e-4, 2e-4, 1e-4]}, "base"),
    ("two_universal", {"cable_offset": [1e-3, -6e-4, 4e-4, -8e-4]}, "register"),
])
def test_the_second_files_errors_are_the_reference_plants_with_the_fitted_parameters(cdsm, ref, robot_name,
                                                                                      effects, frame):
    from cdsm.calibration import diagnosis, plant
    from cdsm.calibration.validation import validate

    robot = cdsm.Robot.packaged(robot_name)
    train, val = _pair(plant, robot, effects, 40, seed=11)
    if frame == "register":
        # the tracker's frame: both files rotated and moved alike
        c, s = np.cos(0.4), np.sin(0.4)
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        for m in (train, val):
            m.measured[:] = m.measured @ R.T + np.array([1.3, -0.2, 0.4])
    d = diagnosis.diagnose(robot, train, noise=NOISE, frame=frame)
    v = validate(d, val)
    prep = diagnosis.prepare(robot, val, frame="base")
    rows = np.flatnonzero(prep.usable)
    assert v.rows == len(rows) > 30 and v.rows_in_file == 40
    # every other model the diagnosis fitted, judged the same way (which effects carry over)
    fitted = {c.name: c.fit.p for c in list(d.singles) + list(d.steps)}
    assert v.candidates and set(v.candidates) <= set(fitted) and d.final().name not in v.candidates
    judged = [(fitted[name], r, ra) for name, (r, ra, lost) in v.candidates.items() if not lost]
    assert judged
    for p, rms, aligned in [(d.baseline.fit.p, v.nominal_rms, v.nominal_rms_mean_aligned),
                            (d.final().fit.p, v.model_rms, v.model_rms_mean_aligned)] + judged:
        k = plant.dims(robot)
        obs, ok = ref.plant_predict(ref.read_robot(robot.to_toml()), p, prep.theta_cmd[prep.order],
                                    prep.dL[prep.order], np.array(["absolute"] * len(val))[prep.order])
        assert ok.all()
        full = np.empty_like(obs)
        full[prep.order] = obs
        err = full[rows, :k] - prep.measured[rows, :k]
        assert rms == pytest.approx(np.sqrt(np.mean(np.sum(err ** 2, axis=1))), rel=1e-9)
        e0 = err - err.mean(axis=0)
        assert aligned == pytest.approx(np.sqrt(np.mean(np.sum(e0 ** 2, axis=1))), rel=1e-9)
    # the right model, fitted on the first file, predicts new rows down to
    # the noise (floor sqrt(k) * 10 um); the nominal one does not
    assert d.best.endswith(next(iter(effects)))
    floor = np.sqrt(plant.dims(robot)) * NOISE
    assert v.model_rms < 1.6 * floor < v.nominal_rms / 5


def test_the_command_line_adds_the_validation_and_refuses_another_reading_kind(cdsm, tmp_path, capsys):
    from cdsm import cli
    from cdsm.calibration import plant

    robot = cdsm.Robot.packaged("paper_vertical")
    train, val = _pair(plant, robot, {"cable_offset": [3e-4, -2e-4, 1e-4]}, 30, seed=5)
    _, disp = _pair(plant, robot, {"cable_offset": [3e-4, -2e-4, 1e-4]}, 30, seed=6, kind="displacement")
    paths = {name: _write(tmp_path / f"{name}.csv", m) for name, m in (("train", train), ("val", val),
                                                                        ("disp", disp))}
    out = tmp_path / "d.json"
    assert cli.main(["diagnose", paths["train"], "--robot", "paper_vertical", "--noise", "1e-5", "--validate",
                     paths["val"], "--json", str(out), "--quiet"]) == 0
    js = json.loads(out.read_text())["validation"]
    assert {"rows", "nominal_rms_m", "model_rms_m", "nominal_rms_mean_aligned_m", "model_rms_mean_aligned_m"} <= set(js)
    assert js["rows"] >= 25 and js["model_rms_m"] < js["nominal_rms_m"]
    assert "validation on" in capsys.readouterr().out
    assert cli.main(["diagnose", paths["train"], "--robot", "paper_vertical", "--validate", paths["disp"],
                     "--quiet"]) == 2
    assert "validation data: displacement readings, the diagnosed data are absolute" in capsys.readouterr().err


def test_the_report_says_it_in_its_headline_and_a_section(cdsm, tmp_path):
    """The paper's Table 3 judged on itself: the nominal and the fitted model
    predict its nine rows as on the first file (the same rows, the same
    parameters: the in-sample figures), in the report's headline, a section
    and diagnosis.json."""
    from cdsm.calibration import diagnosis, measurements
    from cdsm.calibration.validation import validate
    from cdsm.report import diagnosis as report

    robot = cdsm.Robot.packaged("paper_vertical")
    meas = measurements.read_for(robot, "table3")
    d = diagnosis.diagnose(robot, meas)
    v = validate(d, meas)
    assert v.rows == int(d.prep.usable.sum())
    fin = d.final().fit
    rows = d.prep.rows
    err = fin.prediction[rows, :2] - d.prep.measured[rows, :2]
    assert v.model_rms == pytest.approx(np.sqrt(np.mean(np.sum(err ** 2, axis=1))), rel=1e-12)
    paths = report.write(d, tmp_path / "r", validation=v)
    md = open(paths["report_md"], encoding="utf-8").read()
    head = md[:md.index("## Answer")] if "## Answer" in md else md
    assert "On a second file" in head and f"{v.rows} of {v.rows_in_file} rows" in head
    js = json.load(open(paths["json"], encoding="utf-8"))
    assert js["validation"]["model_rms_m"] == v.model_rms


def test_grouped_folds_hold_out_whole_groups(cdsm):
    """Folds by a label column (issue 35 item 5: hold out whole patterns,
    not rows): every fold is a union of whole groups, the folds partition
    the rows, their number is at most the groups'; without groups the folds
    are today's (the same seeded permutation)."""
    from cdsm.calibration.diagnosis import fold_split

    rng = np.random.default_rng(3)
    labels = np.array([f"p{g}" for g in rng.integers(0, 13, 200)])
    folds = fold_split(200, 10, groups=labels)
    assert len(folds) == 10
    assert sorted(np.concatenate(folds).tolist()) == list(range(200))
    for f in folds:
        inside = set(labels[f])
        assert all(set(labels[g]).isdisjoint(inside) for g in folds if g is not f)
    assert len(fold_split(200, 50, groups=labels)) == len(set(labels))
    order = np.random.default_rng(0).permutation(60)
    assert all((a == np.sort(order[i::10])).all() for i, a in enumerate(fold_split(60, 10)))


def test_the_diagnosis_holds_out_a_label_columns_groups(cdsm, tmp_path):
    from cdsm import cli
    from cdsm.calibration import diagnosis, plant

    robot = cdsm.Robot.packaged("paper_vertical")
    train, _ = _pair(plant, robot, {"cable_offset": [3e-4, -2e-4, 1e-4]}, 30, seed=8)
    train.labels["pattern"] = [f"pattern {i // 3}" for i in range(30)]
    d = diagnosis.diagnose(robot, train, noise=NOISE, folds_by="pattern")
    groups = np.asarray(train.labels["pattern"])
    for c in [d.baseline] + d.singles:
        for f in c.folds:
            assert set(groups[f]).isdisjoint(set(groups[np.setdiff1d(d.prep.rows, f)]))
    assert d.to_json()["folds_by"] == {"column": "pattern", "groups": 10}
    path = _write(tmp_path / "t.csv", train)
    with pytest.raises(cdsm.CdsmInputError, match="`folds_by`: no label column 'pattern'"):
        diagnosis.diagnose(robot, train.__class__(**{**train.__dict__, "labels": {}}), folds_by="pattern")
    assert cli.main(["diagnose", path, "--robot", "paper_vertical", "--folds-by", "pattern", "--quiet"]) == 2
