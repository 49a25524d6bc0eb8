"""Sim-to-real gap diagnosis (``cdsm.calibration.diagnosis``, its report and
``cdsm diagnose``), checked on withheld effects: data come from a seeded
virtual prototype with 10 µm measurement noise, and the diagnosis is never
told which effect is in them. Row counts and folds are kept small (30 rows,
5 folds); the 60-row, 10-fold case and the measured error rates are the
benchmarks ``benches/bench_diagnose.py`` and ``benches/bench_error_rates.py``.
"""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

ROWS, FOLDS = 30, 5
NOISE = 10e-6
LIBRARY = ["actuation_scale", "cable_offset", "hole_height", "link_length", "cable_elasticity",
           "hole_clearance", "frame_misalignment", "tip_offset", "backlash"]


@pytest.fixture(scope="module")
def mods(cdsm):
    from cdsm import cli
    from cdsm.calibration import diagnosis, measurements, plant
    from cdsm.report import diagnosis as report

    return dict(cli=cli, diagnose=diagnosis, report=report, measurements=measurements, plant=plant)


@pytest.fixture(scope="module")
def robot(cdsm):
    return cdsm.Robot.paper()


def _typical(plant, robot, effect, seed):
    """Parameters of ``effect``'s first block at the library's typical
    magnitude, signs mixed (seeded); parameters bounded below by 0 positive."""
    lay = plant.layout(robot)[effect]
    w = lay.stop - lay.start
    lo, _ = plant.bounds(robot)
    positive = lo[lay.start] == 0.0
    sign = np.ones(w) if positive else np.random.default_rng(seed).choice([-1.0, 1.0], w)
    if w > 1 and not positive:
        sign[0], sign[1] = 1.0, -1.0  # both signs present
    return plant.TYPICAL[effect] * sign


def _data(plant, robot, effects, seed, rows=ROWS, kind="absolute", noise=NOISE):
    vp = plant.VirtualPrototype(robot, effects, noise=noise, seed=seed)
    th, dl = vp.random_commands(rows, reading=kind)
    return vp.measure(th, dl, reading=kind)


def _write_csv(path, header, rows):
    path.write_text(",".join(header) + "\n" + "\n".join(",".join(repr(float(v)) if not isinstance(v, str) else v
                                                                  for v in r) for r in rows) + "\n")
    return str(path)


# ---------------------------------------------------------------------------
# withheld effects
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("effect", LIBRARY)
def test_every_effect_is_named_first_and_explained(mods, robot, effect):
    """Each library effect at a magnitude a real prototype could have is named
    first, and its held-out RMS falls to within 1.5x the noise floor
    (absolute data in the robot's base frame)."""
    plant, diagnose = mods["plant"], mods["diagnose"]
    seed = 11 + LIBRARY.index(effect)
    meas = _data(plant, robot, {effect: _typical(plant, robot, effect, seed)}, seed)
    d = diagnose.diagnose(robot, meas, folds=FOLDS, noise=NOISE, frame="base")
    assert d.singles[0].name == effect
    assert d.best.split("+")[0] == effect
    assert d.final().heldout_rms <= 1.5 * d.noise_floor
    assert d.baseline.heldout_rms > 2 * d.noise_floor  # the effect was visible at all
    assert d.verdict == "explained" and d.explained


def test_library_is_covered(mods):
    """The parametrised list above is the whole library but ``cable_friction``:
    at the paper's steel cable (E A = 4.6 kN) its typical mu moves the tip by
    micrometres, below this noise; it is named and fitted on a compliant cable
    in ``tests/test_friction.py``."""
    assert set(mods["plant"].EFFECTS) == set(LIBRARY) | {"cable_friction"}


def test_no_effect_answers_no_gap(mods, robot):
    d = mods["diagnose"].diagnose(robot, _data(mods["plant"], robot, {}, 3), folds=FOLDS, noise=NOISE)
    assert d.best == "none" and d.chosen is None
    assert d.verdict == "no gap" and d.explained
    assert d.baseline.heldout_rms <= 1.5 * d.noise_floor
    assert "No gap beyond measurement noise" in " ".join(mods["report"].findings(d)["answer"])


def test_two_effects_forward_selection_finds_both(mods, robot):
    plant = mods["plant"]
    eff = {"hole_height": _typical(plant, robot, "hole_height", 5),
           "frame_misalignment": _typical(plant, robot, "frame_misalignment", 6)}
    d = mods["diagnose"].diagnose(robot, _data(plant, robot, eff, 21, rows=40), folds=FOLDS, noise=NOISE,
                                  frame="base")
    assert set(d.best.split("+")) == set(eff)
    assert d.final().heldout_rms <= 1.5 * d.noise_floor
    assert [len(c.effects) for c in d.steps] == [1, 2]


def test_effect_outside_the_library_is_not_explained(mods, robot, tmp_path):
    """Outside effect: a quadratic actuator nonlinearity, which no library
    effect can express. The actuators realise L_cmd + k (L_cmd - L_ref)^2
    (L_ref: straight-pose lengths; k = 0.3 /m gives up to ~0.3 mm of length
    error, even in the joint angles, where actuation_scale is linear and the
    hole effects are odd or constant). Generated by feeding the nominal plant
    the realised extra length while the table records the commanded dL. The
    verdict must not be "explained", and the report says where the gap is."""
    plant, diagnose, report = mods["plant"], mods["diagnose"], mods["report"]
    vp = plant.VirtualPrototype(robot, {}, noise=NOISE, seed=4)
    th, dl = vp.random_commands(ROWS)
    l_ref = robot.upper_lengths(np.zeros(robot.n))
    l_cmd = robot.upper_lengths(th) + dl
    k = 0.3  # 1/m
    real = vp.measure(th, dl + k * (l_cmd - l_ref) ** 2)
    meas = mods["measurements"].Measurements("absolute", robot.n, dl, real.measured, theta=th, source="quadratic")
    d = diagnose.diagnose(robot, meas, folds=FOLDS, noise=NOISE, frame="base")
    assert d.verdict in ("unexplained", "partly explained") and not d.explained
    assert d.final().heldout_rms > 1.5 * d.noise_floor or d.verdict_detail.p_value < 0.01
    f = report.findings(d)
    assert "unexplained" in " ".join(f["answer"]) or "part of the gap" in " ".join(f["answer"])
    where = " ".join(f["where"])
    assert "Largest gaps" in where and "Spearman" in where
    if d.chosen is not None:  # a partial fit must say what it leaves, and where
        assert "leaves unexplained" in where
    paths = report.write(d, tmp_path / "rep")
    md = open(paths["report_md"], encoding="utf-8").read()
    assert d.verdict in md and "Where the gap lies" in md


def test_displacement_data(mods, robot):
    """Displacement data (one cable moved ±1 mm per row): actuation_scale is
    visible in displacements and diagnosed; the floor counts two readings."""
    plant = mods["plant"]
    meas = _data(plant, robot, {"actuation_scale": [0.03]}, 8, rows=40, kind="displacement")
    assert meas.reading == "displacement"
    d = mods["diagnose"].diagnose(robot, meas, folds=FOLDS, noise=NOISE)
    assert d.best == "actuation_scale"
    assert d.noise_floor == pytest.approx(2.0 * NOISE)
    assert d.final().heldout_rms <= 1.5 * d.noise_floor
    v = d.chosen.fit.params_by_effect(robot)["actuation_scale"][0]
    assert abs(v - 0.03) < 4 * d.chosen.fit.std[0] + 2e-3


# ---------------------------------------------------------------------------
# real instrument frames, scale, noise, sequences
# ---------------------------------------------------------------------------
def _tracker(meas, angle, shift):
    """The same absolute data seen in a tracker frame rotated by ``angle`` and
    moved by ``shift`` (m)."""
    c, s = np.cos(angle), np.sin(angle)
    out = meas.measured @ np.array([[c, s], [-s, c]]) + np.asarray(shift)
    return type(meas)("absolute", meas.n, meas.dL, out, theta=meas.theta, source="tracker")


def test_a_tracker_frame_metres_away_is_registered(mods, robot):
    """40 rows 1.4 m and 30 deg off: the diagnosis registers the frame (starts
    from Kabsch), names it because it beats the identity frame, still finds
    the arm's own effect, and no candidate aborts the run."""
    plant = mods["plant"]
    meas = _data(plant, robot, {"hole_height": [3e-4, -2e-4, 2e-4]}, 31, rows=40)
    far = _tracker(meas, np.radians(30.0), [1.2, -0.7])
    d = mods["diagnose"].diagnose(robot, far, folds=FOLDS, noise=NOISE)
    assert d.prep.registered and d.registration_named
    assert d.best == "frame_misalignment+hole_height"
    assert d.verdict == "explained"
    frame = d.final().fit.params_by_effect(robot)["frame_misalignment"] if "frame_misalignment" in \
        d.final().effects else d.final().fit.p[mods["plant"].layout(robot)["frame_misalignment"]]
    assert abs(frame[0] - np.radians(30.0)) < 1e-4
    j = d.to_json()
    assert j["registration"]["named"] and abs(j["registration"]["frame"][1] - 1.2) < 1e-3


def test_registered_data_already_in_the_base_frame_do_not_name_the_frame(mods, robot):
    plant = mods["plant"]
    meas = _data(plant, robot, {"actuation_scale": [0.02]}, 32, rows=40)
    d = mods["diagnose"].diagnose(robot, meas, folds=FOLDS, noise=NOISE, frame="register")
    assert d.prep.registered and not d.registration_named
    assert d.best == "actuation_scale"


def test_positions_in_mm_are_refused_with_a_hint(mods, robot, cdsm):
    meas = _data(mods["plant"], robot, {}, 33, rows=12)
    mm = type(meas)("absolute", meas.n, meas.dL, meas.measured * 1e3, theta=meas.theta, source="mm.csv")
    with pytest.raises(cdsm.CdsmInputError, match="in mm"):
        mods["diagnose"].diagnose(robot, mm)


def test_noise_is_estimated_from_repeated_commands(mods, robot):
    """30 µm tracker noise, not told: every command measured twice in a row
    (approached from the same direction). The estimate comes from the repeats
    and its 95 % interval holds 30 µm; the right model is explained."""
    plant = mods["plant"]
    vp = plant.VirtualPrototype(robot, {"hole_height": [3e-4, -2e-4, 2e-4]}, noise=30e-6, seed=34)
    th, dl = vp.random_commands(25)
    meas = vp.measure(np.repeat(th, 2, axis=0), np.repeat(dl, 2, axis=0))
    d = mods["diagnose"].diagnose(robot, meas, folds=FOLDS, frame="base")
    ne = d.noise_estimate
    assert ne.source == "repeats" and ne.groups == 25
    assert ne.ci[0] < 30e-6 < ne.ci[1]
    assert d.best == "hole_height" and d.verdict == "explained"
    assert d.verdict_detail.test == "F"


def test_the_default_noise_is_called_assumed_and_says_what_would_do(mods, robot):
    meas = _data(mods["plant"], robot, {"hole_height": [3e-4, -2e-4, 2e-4]}, 35, noise=30e-6)
    d = mods["diagnose"].diagnose(robot, meas, folds=FOLDS, frame="base")
    assert d.noise_estimate.source == "assumed" and d.noise == mods["diagnose"].DEFAULT_NOISE
    assert d.verdict == "partly explained"
    assert 20e-6 < d.verdict_detail.noise_needed < 60e-6
    assert "would be adequate at a noise of" in " ".join(mods["report"].findings(d)["answer"])


def test_backlash_is_found_in_a_sequence_with_unmeasured_moves(mods, robot):
    """Backlash of 60/40/30 µm; half of the commanded moves are not measured
    (they still move the screws). The diagnosis names backlash."""
    plant = mods["plant"]
    vp = plant.VirtualPrototype(robot, {"backlash": [6e-5, 4e-5, 3e-5]}, noise=NOISE, seed=36)
    th, dl = vp.random_commands(60)
    seen = np.arange(60) % 2 == 0
    meas = vp.measure(th, dl, observe=seen)
    assert (meas.observed == seen).all()
    d = mods["diagnose"].diagnose(robot, meas, folds=FOLDS, noise=NOISE, frame="base")
    assert d.best == "backlash" and d.verdict == "explained"
    b = d.chosen.fit.params_by_effect(robot)["backlash"]
    assert np.allclose(b, [6e-5, 4e-5, 3e-5], atol=1e-5)


def test_a_sequence_column_orders_the_rows(mods, robot, tmp_path):
    """The same backlash data written in reverse file order with a
    ``sequence`` column give the same fit; a repeated value is refused."""
    plant = mods["plant"]
    vp = plant.VirtualPrototype(robot, {"backlash": [6e-5, 4e-5, 3e-5]}, noise=NOISE, seed=37)
    th, dl = vp.random_commands(24)
    meas = vp.measure(th, dl)
    rows = [[i + 1, *th[i], *dl[i], *meas.measured[i]] for i in range(24)][::-1]
    csv = _write_csv(tmp_path / "s.csv", ["sequence", "theta_1", "theta_2", "theta_3", "dL_1", "dL_2", "dL_3",
                                          "x", "y"], rows)
    back = mods["measurements"].read_csv(csv, 3)
    assert (back.order == np.arange(23, -1, -1)).all()
    a = mods["diagnose"].diagnose(robot, meas, effects=["backlash"], folds=FOLDS, noise=NOISE, frame="base")
    b = mods["diagnose"].diagnose(robot, back, effects=["backlash"], folds=FOLDS, noise=NOISE, frame="base")
    assert np.allclose(a.chosen.fit.p, b.chosen.fit.p, atol=1e-12)
    rows[3][0] = rows[5][0]
    bad = _write_csv(tmp_path / "t.csv", ["sequence", "theta_1", "theta_2", "theta_3", "dL_1", "dL_2", "dL_3",
                                          "x", "y"], rows)
    with pytest.raises(ValueError, match=r"rows 4, 6 share the value"):
        mods["measurements"].read_csv(bad, 3)


def test_an_outlier_is_flagged_and_the_verdict_given_without_it(mods, robot):
    plant = mods["plant"]
    meas = _data(plant, robot, {"actuation_scale": [0.02]}, 38, rows=40)
    meas.measured[7] += [4e-4, -3e-4]  # a bad reading
    d = mods["diagnose"].diagnose(robot, meas, folds=FOLDS, noise=NOISE, frame="base")
    assert 7 in d.outliers
    assert d.verdict_without_outliers is not None and d.verdict_without_outliers.verdict == "explained"
    assert d.to_json()["outliers"] == [o + 1 for o in d.outliers]


def test_outliers_that_are_most_rows_are_not_diagnosed_again(mods, robot):
    """Rows beyond 5 sigma of a noise given 6 times too small are most of them (28 of
    40): the rows left would be another data set, so the diagnosis is not rerun without
    them, and the JSON and the report say why."""
    plant = mods["plant"]
    meas = _data(plant, robot, {"actuation_scale": [0.02]}, 38, rows=40)
    d = mods["diagnose"].diagnose(robot, meas, folds=FOLDS, noise=NOISE / 6, frame="base")
    assert 20 <= len(d.outliers) <= 37
    assert d.verdict_without_outliers is None
    out = d.to_json()
    assert out["verdict_without_outliers"] is None and "most of the data" in out["without_outliers_skipped"]
    names = [str(i + 1) for i in range(40)]
    assert "not rerun without them" in mods["report"].outlier_note(d, names)


def test_report_files(mods, robot, tmp_path):
    plant = mods["plant"]
    meas = _data(plant, robot, {"tip_offset": [1e-3, -1e-3]}, 9, rows=20)
    d = mods["diagnose"].diagnose(robot, meas, effects=["tip_offset", "actuation_scale"], folds=4, noise=NOISE,
                                  frame="base")
    paths = mods["report"].write(d, tmp_path / "r")
    html = open(paths["report_html"], encoding="utf-8").read()
    md = open(paths["report_md"], encoding="utf-8").read()
    assert html.count("data:image/png;base64,") == 4 and "src='figures" not in html
    for head in ("Answer", "Where the gap lies", "Which effect explains it", "How far it shrinks",
                 "Identifiability", "Flagged rows"):
        assert f"## {head}" in md
    assert "tip offset x" in md and "µm" in md
    j = json.load(open(paths["json"]))
    assert j["best"] == "tip_offset" and j["verdict"] == "explained"


# ---------------------------------------------------------------------------
# the parameter table (issue 32, item 12)
# ---------------------------------------------------------------------------
def test_each_parameter_is_shown_in_its_own_unit(robot, parameter_table):
    """μ = 1.0 ± 1.29 was "+1000.000 ± 1287.997 mm" (every parameter scaled
    and labelled as a length), and ``hole_clearance``'s second parameter
    (the transition width, rad) was cut off by a zip over planar labels."""
    rows, notes = parameter_table(
        robot, {"cable_friction": [1.0], "hole_clearance": [1e-4, 0.02], "actuation_scale": [0.03],
                "cable_elasticity": [0.02], "frame_misalignment": [0.3, 2e-3, -5e-6]},
        {"cable_friction": [1.288], "hole_clearance": [2e-5, 0.004], "actuation_scale": [0.001],
         "cable_elasticity": [0.002], "frame_misalignment": [0.01, 1e-5, 2e-6]})
    assert rows == {
        ("cable_friction", "μ (every cable, every hole)"): "+1.0000 ± 1.2880",
        ("hole_clearance", "clearance c"): "+100.0 ± 20.0 µm",
        ("hole_clearance", "transition width w − 0.01 rad"): "+20.00 ± 4.00 mrad",
        ("actuation_scale", "s (actuator gain 1 + s)"): "+0.0300 ± 0.0010",
        ("cable_elasticity", "compliance 1/(E A)"): "+0.0200 ± 0.0020 1/N (E·A ≈ 50 N)",
        ("frame_misalignment", "instrument frame rotation"): "+17.19 ± 0.57°",
        ("frame_misalignment", "instrument frame x"): "+2.000 ± 0.010 mm",
        ("frame_misalignment", "instrument frame y"): "-5.0 ± 2.0 µm"}
    # μ at its upper bound with a standard error larger than itself: said in words
    (note,) = notes
    assert note.startswith("`cable_friction` μ (every cable, every hole) = +1.0000 ± 1.2880 sits at its upper "
                           "bound (1)") and "not a measurement" in note
    # at the bound with a small error, or inside with a large one: nothing to say
    assert parameter_table(robot, {"cable_friction": [1.0]}, {"cable_friction": [0.1]})[1] == []
    assert parameter_table(robot, {"cable_friction": [0.5]}, {"cable_friction": [0.9]})[1] == []


def test_the_planar_labels_name_the_robots_own_cables_and_disks(robot, parameter_table):
    rows, _ = parameter_table(robot, {"cable_offset": [2e-4, -1e-4, 3e-5], "link_length": [1e-4, 2e-4, 3e-4, 4e-4]},
                              {"cable_offset": [1e-5] * 3, "link_length": [1e-5] * 4})
    assert list(rows) == [("cable_offset", "cable 1 (to disk 1)"), ("cable_offset", "cable 3 (to disk 2)"),
                          ("cable_offset", "cable 5 (to disk 3)"), ("link_length", "base → joint 1"),
                          ("link_length", "joint 1 → disk 1"), ("link_length", "joint 2 → disk 2"),
                          ("link_length", "joint 3 → disk 3")]
    assert rows[("cable_offset", "cable 3 (to disk 2)")] == "-100.0 ± 10.0 µm"


def test_one_row_carrying_half_the_gap_is_said_in_words(mods, robot):
    """"1 of 12 rows carryes half of the squared gap": the verb agrees."""
    meas = _data(mods["plant"], robot, {}, 5, rows=12)
    meas.measured[4] += [8e-4, 0.0]
    d = mods["diagnose"].diagnose(robot, meas, effects=["tip_offset"], folds=4, noise=NOISE, frame="base")
    where = " ".join(mods["report"].findings(d)["where"])
    assert "1 of 12 rows carries half of the squared gap" in where and "carryes" not in where


# ---------------------------------------------------------------------------
# the command line
# ---------------------------------------------------------------------------
def _absolute_rows(robot, plant, rows, seed):
    vp = plant.VirtualPrototype(robot, {"actuation_scale": [0.02]}, noise=NOISE, seed=seed)
    th, dl = vp.random_commands(rows)
    m = vp.measure(th, dl)
    return [[*th[i], *dl[i], *m.measured[i]] for i in range(rows)]


HEADER = ["theta_1", "theta_2", "theta_3", "dL_1", "dL_2", "dL_3", "x", "y"]


def test_cli_json_keys_and_flagged_unreachable_row(mods, robot, tmp_path, capsys):
    """JSON keys as the issues fix them; a row whose commanded pose cannot be
    solved is flagged (JSON, report), not dropped."""
    from cdsm.accuracy.workspace import paper_ik_seed

    plant = mods["plant"]
    vp = plant.VirtualPrototype(robot, {"actuation_scale": [0.02]}, noise=NOISE, seed=2)
    th, dl = vp.random_commands(16)
    pose = robot.fk(th)
    th = robot.ik(pose, seed=paper_ik_seed(3)).theta  # the configuration a pose command reaches
    m = vp.measure(th, dl)
    rows = [[str(i + 1), *pose[i], *dl[i], *m.measured[i]] for i in range(16)]
    rows.insert(5, ["6", 0.5, 0.02, 0.0, 0.0, 0.0, 0.0, 0.5, 0.02])  # 0.5 m: beyond the arm's reach
    csv = _write_csv(tmp_path / "d.csv", ["point", "x_cmd", "y_cmd", "phi_cmd", "dL_1", "dL_2", "dL_3", "x", "y"],
                     rows)
    out, rep = tmp_path / "d.json", tmp_path / "rep"
    rc = mods["cli"].main(["diagnose", csv, "--effects", "actuation_scale,tip_offset", "--folds", "4",
                           "--frame", "base", "--noise", "1e-5", "--json", str(out), "--report", str(rep),
                           "--quiet"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "Effect: actuation_scale" in text and "noise floor" in text and "flagged rows: 6" in text
    j = json.load(open(out))
    assert j["best"] == "actuation_scale" and j["verdict"] == "explained" and j["explained"] is True
    assert j["noise_source"] == "given" and j["noise_m"] == 1e-5
    assert 0.01 <= j["lack_of_fit"]["p_value"] <= 1
    assert isinstance(j["baseline"]["heldout_rms_m"], float)
    hr = [e["heldout_rms_m"] for e in j["effects"]]
    assert hr == sorted(hr) and j["effects"][0]["name"] == "actuation_scale"
    for e in j["effects"]:
        assert {"name", "params", "heldout_rms_m", "bic_weight", "failures"} <= set(e)
    assert abs(sum(e["bic_weight"] for e in j["effects"]) + j["baseline"]["bic_weight"] - 1) < 1e-9
    assert j["rows"] == 17 and j["rows_used"] == 16
    assert list(j["flagged_rows"]) == ["6"] and "not reachable" in j["flagged_rows"]["6"]
    md = (rep / "report.md").read_text(encoding="utf-8")
    assert "row 6 (point 6): commanded pose not reachable" in md
    assert "not reachable" in (rep / "residuals.csv").read_text(encoding="utf-8")


def _cli_error(mods, capsys, argv):
    try:
        rc = mods["cli"].main(argv)
    except SystemExit as exc:  # argparse option errors
        rc = exc.code
    return rc, capsys.readouterr().err


def test_cli_missing_column(mods, robot, tmp_path, capsys):
    rows = _absolute_rows(robot, mods["plant"], 6, 1)
    csv = _write_csv(tmp_path / "m.csv", HEADER[:-1], [r[:-1] for r in rows])
    rc, err = _cli_error(mods, capsys, ["diagnose", csv, "--quiet"])
    assert rc == 2 and "missing measured columns" in err and "Traceback" not in err


def test_cli_nan_cell(mods, robot, tmp_path, capsys):
    rows = _absolute_rows(robot, mods["plant"], 6, 1)
    rows[3][6] = "nan"
    csv = _write_csv(tmp_path / "n.csv", HEADER, rows)
    rc, err = _cli_error(mods, capsys, ["diagnose", csv, "--quiet"])
    assert rc == 2 and "row 4" in err and "'x'" in err and "non-finite" in err


def test_cli_half_a_measurement(mods, robot, tmp_path, capsys):
    rows = _absolute_rows(robot, mods["plant"], 6, 1)
    rows[2][7] = ""
    csv = _write_csv(tmp_path / "h.csv", HEADER, rows)
    rc, err = _cli_error(mods, capsys, ["diagnose", csv, "--quiet"])
    assert rc == 2 and "row 3" in err and "both" in err


def test_cli_mixed_kinds(mods, robot, tmp_path, capsys):
    rows = _absolute_rows(robot, mods["plant"], 6, 1)
    csv = _write_csv(tmp_path / "k.csv", HEADER[:-1] + ["dy"], rows)
    rc, err = _cli_error(mods, capsys, ["diagnose", csv, "--quiet"])
    assert rc == 2 and "missing measured columns" in err


def test_cli_unknown_effect_and_bad_options(mods, robot, tmp_path, capsys):
    csv = _write_csv(tmp_path / "ok.csv", HEADER, _absolute_rows(robot, mods["plant"], 6, 1))
    rc, err = _cli_error(mods, capsys, ["diagnose", csv, "--effects", "actuation_scale,friction"])
    assert rc == 2 and "unknown effect" in err and "'friction'" in err and "known:" in err
    for bad in ("-1e-5", "0", "nan", "ten", "5"):
        rc, err = _cli_error(mods, capsys, ["diagnose", csv, f"--noise={bad}"])
        assert rc == 2 and "--noise" in err, bad
    rc, err = _cli_error(mods, capsys, ["diagnose", csv, "--folds", "1"])
    assert rc == 2 and "--folds" in err
    rc, err = _cli_error(mods, capsys, ["diagnose", csv, "--frame", "tracker"])
    assert rc == 2 and "--frame" in err
    rc, err = _cli_error(mods, capsys, ["diagnose", str(tmp_path / "absent.csv")])
    assert rc == 2 and "absent.csv" in err


def test_cli_saves_a_model_that_loads_and_suggests_measurements(mods, robot, tmp_path, capsys):
    """--save-model writes the chosen model (it loads back with the fitted
    values) and --suggest writes the proposed measurements into the report."""
    from cdsm.calibration.model import FittedPlant

    csv = _write_csv(tmp_path / "ok.csv", HEADER, _absolute_rows(robot, mods["plant"], 16, 1))
    mfile, rep = tmp_path / "m.json", tmp_path / "rep"
    rc, err = _cli_error(mods, capsys, ["diagnose", csv, "--effects", "actuation_scale,tip_offset", "--folds",
                                        "3", "--frame", "base", "--quiet", "--save-model", str(mfile),
                                        "--suggest", "3", "--report", str(rep)])
    assert rc == 0, err
    m = FittedPlant.load(mfile)
    assert m.effects == ["actuation_scale"] and abs(m.params_by_effect()["actuation_scale"][0] - 0.02) < 2e-3
    lines = [ln for ln in (rep / "suggested.csv").read_text().splitlines() if not ln.startswith("#")]
    assert len(lines) == 4 and lines[0].startswith("point,theta_1")


# ---------------------------------------------------------------------------
# copies of one reading are one observation (issue 32, item 5)
# ---------------------------------------------------------------------------
def _table3_lines(cdsm):
    import os

    with open(os.path.join(os.path.dirname(cdsm.__file__), "data", "table3.csv"), encoding="utf-8") as fh:
        return [ln for ln in fh.read().splitlines() if ln and not ln.startswith("#")]


def test_copies_of_one_table3_row_are_refused_like_the_row_alone(mods, robot, cdsm):
    """Nine bit-identical copies of one Table 3 row are one observation: the
    diagnosis refuses them as it refuses the row alone (it used to answer
    `explained` from 9 "rows" and 9 folds, held-out RMS 0)."""
    src = _table3_lines(cdsm)
    with pytest.raises(cdsm.CdsmInputError, match="only 1 of 1 rows are usable"):
        mods["diagnose"].diagnose(robot, mods["measurements"].parse_csv("\n".join(src[:2]), 3))
    copies = mods["measurements"].parse_csv("\n".join([src[0]] + [src[1]] * 9), 3)
    with pytest.warns(cdsm.CdsmDataWarning, match="bit for bit.*counted once"):
        with pytest.raises(cdsm.CdsmInputError, match=r"only 1 of 9 rows are usable.*8 row\(s\): a copy"):
            mods["diagnose"].diagnose(robot, copies)


def test_sixty_copies_of_a_synthetic_row_are_refused(mods, robot, cdsm):
    m = _data(mods["plant"], robot, {"tip_offset": [1e-3, -5e-4]}, 40, rows=1)
    sixty = mods["measurements"].Measurements("absolute", 3, np.repeat(m.dL, 60, 0), np.repeat(m.measured, 60, 0),
                                              theta=np.repeat(m.theta, 60, 0), source="sixty copies")
    with pytest.warns(cdsm.CdsmDataWarning, match="59 row"):
        with pytest.raises(cdsm.CdsmInputError, match="only 1 of 60 rows are usable"):
            mods["diagnose"].diagnose(robot, sixty, folds=FOLDS, frame="base")
    assert m.copy_of().tolist() == [-1] and sixty.copy_of().tolist() == [-1] + [0] * 59


def test_copies_change_nothing_but_the_flags(mods, robot, cdsm):
    """30 rows and a copy of each after them: the copies are flagged, not
    rows nor folds nor repeats; every held-out figure is that of the 30 rows
    alone (the copies run after them, so nothing they run changes them)."""
    meas = _data(mods["plant"], robot, {"hole_height": [3e-4, -2e-4, 2e-4]}, 41)
    twice = mods["measurements"].Measurements("absolute", 3, np.tile(meas.dL, (2, 1)),
                                              np.tile(meas.measured, (2, 1)), theta=np.tile(meas.theta, (2, 1)))
    alone = mods["diagnose"].diagnose(robot, meas, folds=FOLDS, frame="base")
    with pytest.warns(cdsm.CdsmDataWarning, match="30 row"):
        d = mods["diagnose"].diagnose(robot, twice, folds=FOLDS, frame="base")
    j = d.to_json()
    assert j["rows"] == 60 and j["rows_used"] == 30 and j["duplicate_rows"] == list(range(31, 61))
    assert j["flagged_rows"]["31"].startswith("a copy of an earlier row") and "of row 1:" in j["flagged_rows"]["31"]
    assert d.noise_estimate.source == "assumed" and d.noise_estimate.groups == 0
    assert len(d.baseline.heldout) == 30 and d.folds == FOLDS
    assert (d.best, d.verdict) == (alone.best, alone.verdict)
    assert [c.heldout_rms for c in d.singles] == [c.heldout_rms for c in alone.singles]


def test_repeats_with_readings_of_their_own_still_estimate_the_noise(mods, robot, cdsm):
    """What is a copy: the whole row (command and reading) bit for bit, not
    a label; a repeat with a reading of its own, or the same reading of
    another command, is no copy."""
    head = "point,theta_1,theta_2,theta_3,dL_1,dL_2,dL_3,x,y,phi\n"
    m = mods["measurements"].parse_csv(head + "a,0.1,0,0,0,0,0,0.2,0.01,\n"
                                       "b,0.1,-0.0,0,0,0,0,0.2,0.01,\n"  # a copy (another label, -0.0)
                                       "c,0.1,0,0,0,0,0,0.2,0.01000001,\n"  # a repeat
                                       "d,0.1,0,0,0.001,0,0,0.2,0.01,\n"  # another command
                                       "e,0.1,0,0,0,0,0,0.2,0.01,0.001\n"  # another reading (phi)
                                       "f,0.1,0,0,0,0,0,0.2,0.01,\n", 3)  # a copy of row a
    assert m.copy_of().tolist() == [-1, 0, -1, -1, -1, 0]
    plant = mods["plant"]
    vp = plant.VirtualPrototype(robot, {"hole_height": [3e-4, -2e-4, 2e-4]}, noise=30e-6, seed=34)
    th, dl = vp.random_commands(25)
    meas = vp.measure(np.repeat(th, 2, axis=0), np.repeat(dl, 2, axis=0))
    with warnings.catch_warnings():
        warnings.simplefilter("error", cdsm.CdsmDataWarning)  # no copies here
        d = mods["diagnose"].diagnose(robot, meas, folds=FOLDS, frame="base")
    assert d.prep.copies == {} and int(d.prep.usable.sum()) == 50
    assert d.noise_estimate.source == "repeats" and d.noise_estimate.groups == 25


def test_candidates_are_fitted_together_within_a_budget_with_the_same_answer(mods, robot, monkeypatch):
    """Memory bounded by design (issue 32, item 11) and threads kept busy
    (issue 34, item 4): the candidates' fits (the fit on all rows and every
    fold's) go to the core many candidates at a time, at most
    ``FIT_ROWS_AT_ONCE`` fitted rows per call (one candidate at least), and
    the answer is the one of one candidate per call — each fit is
    independent, whichever thread takes it."""
    plant, diagnose = mods["plant"], mods["diagnose"]
    meas = _data(plant, robot, {"hole_height": _typical(plant, robot, "hole_height", 3)}, 3)
    calls = []
    real = diagnose.fit_candidates

    def spy(prep, candidates, scored, *a, **k):
        calls.append((len(candidates), len(scored)))
        return real(prep, candidates, scored, *a, **k)

    monkeypatch.setattr(diagnose, "fit_candidates", spy)
    monkeypatch.setattr(diagnose, "FIT_ROWS_AT_ONCE", 1)
    r2 = robot.with_loads()  # a copy with its own thread count
    r2.threads = 2
    d2 = diagnose.diagnose(r2, meas, folds=FOLDS, noise=NOISE, frame="base")
    assert calls and set(calls) == {(1, FOLDS + 1)}
    calls.clear()
    monkeypatch.setattr(diagnose, "FIT_ROWS_AT_ONCE", 3 * (FOLDS + 1) * len(meas))
    d1 = diagnose.diagnose(r2, meas, folds=FOLDS, noise=NOISE, frame="base")
    # the single effects three at a time, then the candidates of each step together
    assert calls[1] == (3, 3 * (FOLDS + 1)) and max(c for c, _ in calls) == 3
    assert all(f == c * (FOLDS + 1) for c, f in calls)
    assert d1.best == d2.best == "hole_height"
    for a, b in zip([d1.baseline] + d1.singles, [d2.baseline] + d2.singles):
        assert a.name == b.name
        np.testing.assert_array_equal(a.heldout, b.heldout)
        np.testing.assert_array_equal(a.fit.p, b.fit.p)


def _two_folds(mods, robot):
    """Prepared hole-height data (base frame) and two folds' flags: every
    usable row, every other one."""
    meas = _data(mods["plant"], robot, {"hole_height": _typical(mods["plant"], robot, "hole_height", 3)}, 3)
    prep = mods["diagnose"].prepare(robot, meas, "base")
    scored = np.zeros((2, len(meas)), bool)
    scored[0, prep.rows] = True
    scored[1, prep.rows[::2]] = True
    return prep, scored


def test_fit_candidates_fits_each_candidate_as_alone_and_refuses_bad_indices(mods, robot, cdsm):
    """Several candidates in one call of the core (issue 34, item 4): each
    fit equals the candidate's fit alone; an index beyond the candidates,
    or one index short, is refused naming `candidate`."""
    from cdsm.calibration.fit import fit_candidates, fit_folds

    prep, scored = _two_folds(mods, robot)
    cands = [["hole_height"], ["actuation_scale", "link_length"]]
    both = fit_candidates(prep, cands, np.vstack([scored, scored]), [1, 0, 0, 1])
    for f, c in zip(both, [(1, 0), (0, 1), (0, 0), (1, 1)]):
        alone = fit_folds(prep, cands[c[0]], scored[c[1]:c[1] + 1])[0]
        assert f.effects == cands[c[0]]
        np.testing.assert_array_equal(f.p, alone.p)
        np.testing.assert_array_equal(f.prediction, alone.prediction)
        np.testing.assert_array_equal(f.std, alone.std)
    for bad in ([0, 2], [0]):
        with pytest.raises(cdsm.CdsmInputError, match="candidate"):
            fit_candidates(prep, cands, scored, bad)


def test_fold_fits_carry_no_uncertainty_and_the_same_fit(mods, robot):
    """The cross-validation folds need only their predictions (issue 34,
    item 4): a fit asked without uncertainty has no standard deviations,
    correlation or singular values, and the same parameters, statistics and
    predictions as one with them."""
    from cdsm.calibration.fit import fit_folds

    prep, scored = _two_folds(mods, robot)
    some = fit_folds(prep, ["hole_height"], scored, uncertainty=[True, False])
    every = fit_folds(prep, ["hole_height"], scored)
    assert some[1].std is None and some[1].corr is None and some[1].singular is None
    assert np.isfinite(every[1].std).all() and every[1].corr.shape == (3, 3)
    for a, b in zip(some, every):
        np.testing.assert_array_equal(a.p, b.p)
        np.testing.assert_array_equal(a.prediction, b.prediction)
        assert (a.ssr, a.bic, a.iterations) == (b.ssr, b.bic, b.iterations)
    np.testing.assert_array_equal(some[0].std, every[0].std)
    np.testing.assert_array_equal(some[0].corr, every[0].corr)


def test_a_candidate_asked_again_is_not_fitted_again(mods, robot, monkeypatch):
    """Issue 35, item 5: a candidate asked for again with its effects in the
    same order (a forward-selection trial that backward elimination or the
    search asks for) is not fitted again: a new candidate, equal bit for bit
    to the first and to a fit afresh; the same effects in another order are
    fitted (their fit differs in rounding)."""
    plant, diagnose = mods["plant"], mods["diagnose"]
    meas = _data(plant, robot, {"hole_height": _typical(plant, robot, "hole_height", 3)}, 3)
    prep = diagnose.prepare(robot, meas, "base")
    calls = []
    real = diagnose.fit_candidates

    def spy(prep, candidates, *a, **k):
        calls.append([list(c) for c in candidates])
        return real(prep, candidates, *a, **k)

    monkeypatch.setattr(diagnose, "fit_candidates", spy)
    scorer = diagnose._Scorer(prep, prep.rows, FOLDS)
    scorer.base_error = scorer.evaluate("none", []).heldout
    first = scorer.evaluate("hole_height+link_length", ["hole_height", "link_length"])
    again = scorer.evaluate_all([("actuation_scale", ["actuation_scale"]),
                                 ("hole_height+link_length", ["hole_height", "link_length"])])[1]
    assert calls[1:] == [[["hole_height", "link_length"]], [["actuation_scale"]]]
    fresh = diagnose._Scorer(prep, prep.rows, FOLDS, base_error=scorer.base_error).evaluate(
        "hole_height+link_length", ["hole_height", "link_length"])
    assert again is not first and again.fit is not first.fit and again.fit.p is not first.fit.p
    for c in (again, fresh):
        assert (c.name, c.effects, c.failures, c.fitted) == (first.name, first.effects, first.failures, first.fitted)
        np.testing.assert_array_equal(c.heldout, first.heldout)
        np.testing.assert_array_equal(c.fit.p, first.fit.p)
        np.testing.assert_array_equal(c.fit.std, first.fit.std)
        np.testing.assert_array_equal(c.fit.prediction, first.fit.prediction)
    scorer.evaluate("link_length+hole_height", ["link_length", "hole_height"])
    assert calls[-1] == [["link_length", "hole_height"]]
    # another base error (the rows a fold cannot predict take it): fitted again
    scorer.base_error = scorer.base_error.copy()
    scorer.evaluate("hole_height+link_length", ["hole_height", "link_length"])
    assert calls[-1] == [["hole_height", "link_length"]]
