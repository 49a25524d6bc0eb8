"""Model files (cdsm-model/2; /1 still read) and compensation on the virtual prototype."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cdsm.calibration import plant

NOISE = 10e-6
FLOOR = np.sqrt(2.0) * NOISE  # expected RMS |e_xy| of a perfect model, m

# Withheld effects (SI): every effect of the library and a two-effect mixture.
SCENARIOS = plant.EXAMPLES_N3


@pytest.fixture(scope="module")
def robot(cdsm):
    return cdsm.Robot.paper()


def _targets(robot, rows=20, seed=1234):
    th = np.random.default_rng(seed).uniform(-np.radians(30), np.radians(30), (rows, robot.n))
    return robot.fk(th)


def _diagnosed(robot, effects, rows=40, seed=0):
    from cdsm.calibration import diagnosis as diagnose, plant

    vp = plant.VirtualPrototype(robot, effects, noise=NOISE, seed=seed)
    th, dl = vp.random_commands(rows)
    return diagnose.diagnose(robot, vp.measure(th, dl), noise=NOISE)


@pytest.fixture(scope="module")
def hole_model(robot):
    from cdsm.calibration.model import FittedPlant

    return FittedPlant.from_diagnosis(_diagnosed(robot, SCENARIOS["hole_height"]))


# ---------------------------------------------------------------------------
# file format
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("perturbed", [False, True])
def test_robot_toml_rebuilds_the_robot_exactly(cdsm, ref, robot, perturbed):

    r = robot.with_holes(robot.hole_height_error([1e-4, -3e-5, 2e-6])) if perturbed else robot
    r2 = cdsm.Robot.from_toml_str(r.to_toml())
    for a in ("link_before", "link_after", "thickness", "mass", "lower_tension", "joint_limits",
              "youngs_modulus", "cable_diameter", "routing_length", "name"):
        assert np.array_equal(getattr(r, a), getattr(r2, a)), a
    used = ref.used_hole_mask(r.n)  # unused entries (base face a, ...) are not part of the model
    assert np.array_equal(r.holes[used], r2.holes[used])
    assert not r2.holes[~used].any()


def test_save_load_round_trip_is_exact(cdsm, hole_model, tmp_path):
    from cdsm.calibration import plant

    path = tmp_path / "m.json"
    hole_model.save(path)
    m2 = cdsm.FittedPlant.load(path)
    assert m2 == hole_model
    assert np.array_equal(m2.p, hole_model.p) and m2.p.tobytes() == hole_model.p.tobytes()
    assert m2.effects == ["hole_height"] and m2.name == hole_model.name
    assert np.array_equal(m2.robot.holes, hole_model.robot.holes)
    d = json.loads(path.read_text())
    assert d["format"] == "cdsm-model/2"
    assert d["data"]["kind"] == "absolute" and d["data"]["rows"] == 40 and len(d["data"]["sha256"]) == 64
    assert d["heldout"]["final_rms_m"] < d["heldout"]["baseline_rms_m"]
    lay = plant.layout(hole_model.robot)
    assert d["params"]["by_effect"]["hole_height"] == hole_model.p[lay["hole_height"]].tolist()
    assert d["params"]["layout"] == {k: [v.start, v.stop] for k, v in lay.items()}
    # saving the loaded model writes the same bytes
    m2.save(tmp_path / "m2.json")
    assert (tmp_path / "m2.json").read_text() == path.read_text()
    # same predictions
    th = np.random.default_rng(2).uniform(-0.4, 0.4, (5, 3))
    assert np.array_equal(m2.predict(th)[0], hole_model.predict(th)[0])


@pytest.mark.parametrize("text, msg", [
    ("not json", "not JSON"),
    ('{"format": "cdsm-model/999"}', "not supported"),
    ('{"format": "cdsm-model/1", "robot": {}}', "missing field"),
])
def test_bad_model_files(cdsm, tmp_path, text, msg):
    p = tmp_path / "bad.json"
    p.write_text(text)
    with pytest.raises(cdsm.CdsmInputError, match=msg):
        cdsm.FittedPlant.load(p)


def test_a_version_1_model_file_still_loads(cdsm, robot, tmp_path):
    """cdsm-model/1 files (eight parameter blocks, no backlash, no clearance
    width) load with their values remapped by block name; the new blocks are
    zero (nominal)."""
    old_layout = {"actuation_scale": [0, 1], "cable_offset": [1, 4], "hole_height": [4, 7],
                  "link_length": [7, 11], "cable_elasticity": [11, 12], "hole_clearance": [12, 13],
                  "frame_misalignment": [13, 16], "tip_offset": [16, 18]}
    flat = [0.01] + [0.0] * 3 + [1e-4, -1e-4, 2e-4] + [0.0] * 5 + [1.5e-4] + [0.0] * 5
    d = {"format": "cdsm-model/1", "name": "hole_height+hole_clearance",
         "effects": ["hole_height", "hole_clearance"], "robot": {"name": robot.name, "n": 3, "toml": robot.to_toml()},
         "params": {"layout": old_layout, "flat": flat}}
    p = tmp_path / "v1.json"
    p.write_text(json.dumps(d))
    m = cdsm.FittedPlant.load(p)
    lay = plant.layout(m.robot)
    assert m.p[lay["actuation_scale"]].tolist() == [0.01]
    assert m.p[lay["hole_height"]].tolist() == [1e-4, -1e-4, 2e-4]
    assert m.p[lay["hole_clearance"]].tolist() == [1.5e-4]
    assert not m.p[lay["backlash"]].any() and not m.p[lay["clearance_width"]].any()


def test_wrong_parameter_count_is_refused(cdsm, hole_model, tmp_path):
    d = hole_model.to_dict()
    d["params"]["flat"] = d["params"]["flat"][:-1]
    p = tmp_path / "short.json"
    p.write_text(json.dumps(d))
    with pytest.raises(cdsm.CdsmInputError, match="params.flat"):
        cdsm.FittedPlant.load(p)


# ---------------------------------------------------------------------------
# compensation on the virtual prototype
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(SCENARIOS))
def test_compensation_reaches_the_noise_floor(cdsm, robot, name):
    """Fit on 40 measurements, compensate 20 disjoint targets, measure them."""
    from cdsm.calibration import plant

    effects = SCENARIOS[name]
    model = cdsm.FittedPlant.from_diagnosis(_diagnosed(robot, effects))
    poses = _targets(robot)
    comp = model.compensate(poses)
    assert comp.converged.all(), comp.flags
    assert np.nanmax(comp.predicted_error) < 1e-8
    probe = plant.VirtualPrototype(robot, effects, noise=NOISE, seed=99)
    after = np.hypot(*(probe.measure(comp.theta_cmd, comp.dL).measured - poses[:, :2]).T)
    before = np.hypot(*(probe.measure(comp.theta_cmd).measured - poses[:, :2]).T)
    rms_a, rms_b = np.sqrt(np.mean(after ** 2)), np.sqrt(np.mean(before ** 2))
    assert rms_a <= 2 * FLOOR, (name, rms_a)
    assert rms_b >= 5 * rms_a, (name, rms_b, rms_a)


def test_position_only_targets_and_unreachable_flags(cdsm, robot, hole_model):
    poses = _targets(robot, 6)
    comp = hole_model.compensate(poses[:, :2])
    assert comp.converged.all() and np.nanmax(comp.predicted_error) < 1e-8
    assert np.isnan(comp.predicted_phi_error).all()
    # beyond reach: flagged and no commands
    bad = hole_model.compensate([[0.5, 0.0, 0.0]])
    assert not bad.converged.any()
    assert all(f.startswith("unreachable") for f in bad.flags)
    assert np.isnan(bad.commands).all()
    # a folded pose needs joint angles beyond the limits: flagged; compensated
    # only when limits are not enforced (limits are flags unless asked)
    folded = [[0.05, 0.0, 0.0]]
    flagged = hole_model.compensate(folded)
    assert "outside the joint limits" in flagged.flags[0]
    enforced = hole_model.compensate(folded, enforce_limits=True)
    assert not enforced.converged.any() and np.isnan(enforced.commands).all()
    assert "outside the joint limits" in enforced.flags[0]
    # the nominal commands of the nominal model need no correction
    nominal = cdsm.FittedPlant(robot, np.zeros_like(hole_model.p))
    c0 = nominal.compensate(poses)
    assert np.abs(c0.dL).max() < 1e-9 and np.allclose(c0.commands, c0.nominal_commands, atol=1e-9)


def test_slack_cables_are_flagged(cdsm, robot):
    """Targets whose configuration needs an upper cable to push (slack under
    the 50/10/5 g weights: found on the ±30° grid) are flagged; taut ones
    are not."""
    from cdsm.accuracy.workspace import joint_grid, paper_ik_seed

    grid = joint_grid(3)
    poses = robot.fk(grid)
    sol = robot.ik(poses, seed=paper_ik_seed(3))  # the configuration compensation will use
    reached = np.asarray(sol.converged) & (np.abs(sol.theta - grid).max(axis=1) < 1e-9)
    slack = np.flatnonzero(reached & ~robot.feasible(sol.theta))[:3]
    taut = np.flatnonzero(reached & robot.feasible(sol.theta))[:3]
    assert len(slack) == 3 and len(taut) == 3  # the slack path really runs
    comp = cdsm.FittedPlant(robot, np.zeros(plant.size(robot))).compensate(poses[np.r_[slack, taut]])
    assert all("slack cable" in f for f in comp.flags[:3])
    assert not any("slack cable" in f for f in comp.flags[3:])


# ---------------------------------------------------------------------------
# CLI
# ---------------------------------------------------------------------------
def _run(argv, capsys):
    from cdsm.cli import main

    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_compensate_round_trip(robot, hole_model, tmp_path, capsys):
    mpath = tmp_path / "model.json"
    hole_model.save(mpath)
    poses = _targets(robot, 5)
    t = tmp_path / "targets.csv"
    t.write_text("# targets, m and rad\nx,y,phi\n" + "".join(f"{a!r},{b!r},{c!r}\n" for a, b, c in poses.tolist())
                 + "0.5,0,0\n")
    out = tmp_path / "cmd.csv"
    code, so, se = _run(["compensate", str(t), "--model", str(mpath), "--out", str(out)], capsys)
    assert code == 0, se
    assert "6 targets: 5 converged, 1 flagged" in so
    lines = [ln for ln in out.read_text().splitlines() if not ln.startswith("#")]
    head = lines[0].split(",")
    assert head[:6] == ["x", "y", "phi", "L_1", "L_2", "L_3"] and "flags" in head
    rows = [dict(zip(head, ln.split(",", len(head) - 1))) for ln in lines[1:]]
    comp = hole_model.compensate(poses)
    for i in range(5):
        assert rows[i]["converged"] == "1"
        assert [float(rows[i][f"L_{j}"]) for j in (1, 2, 3)] == comp.commands[i].tolist()
    assert rows[5]["converged"] == "0" and "unreachable" in rows[5]["flags"]


@pytest.mark.parametrize("content, msg", [
    ("x,phi\n0.2,0\n", "missing target columns y"),
    ("x,y\n0.2,nan\n", "non-finite"),
    ("x,y\n0.2,abc\n", "not a number"),
])
def test_cli_compensate_bad_targets(hole_model, tmp_path, capsys, content, msg):
    mpath = tmp_path / "model.json"
    hole_model.save(mpath)
    t = tmp_path / "t.csv"
    t.write_text(content)
    code, _, se = _run(["compensate", str(t), "--model", str(mpath), "--out", str(tmp_path / "o.csv")], capsys)
    assert code == 2 and msg in se and "Traceback" not in se


def test_cli_compensate_bad_model(tmp_path, capsys):
    t = tmp_path / "t.csv"
    t.write_text("x,y\n0.2,0\n")
    m = tmp_path / "m.json"
    m.write_text('{"format": "cdsm-model/0"}')
    code, _, se = _run(["compensate", str(t), "--model", str(m), "--out", str(tmp_path / "o.csv")], capsys)
    assert code == 2 and "not supported" in se
    code, _, se = _run(["compensate", str(t), "--model", str(tmp_path / "nope.json"), "--out",
                        str(tmp_path / "o.csv")], capsys)
    assert code == 2 and "nope.json" in se


def test_model_from_known_effects(robot):
    """A model can be built from effects known by other means (e.g. a CMM)."""
    from cdsm.calibration.model import FittedPlant

    dh = [1e-4, 0.0, -1e-4]
    m = FittedPlant.from_effects(robot, {"hole_height": dh})
    th = np.radians([[10.0, -5.0, 20.0], [-15.0, 25.0, 5.0]])
    obs, ok = m.predict(th)
    # the same arm built another way: the robot with its holes moved, driven by the nominal lengths
    moved = robot.with_holes(robot.hole_height_error(dh))
    want = moved.fk(moved.solve_cables(robot.upper_lengths(th), seed=th).theta)
    assert ok.all() and np.abs(obs - want).max() < 1e-12
    assert np.abs(obs[:, :2] - robot.fk(th)[:, :2]).max() > 1e-6  # the holes matter
