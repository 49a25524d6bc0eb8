"""Python stops re-deciding the arm kind (issue 33, item 1): the studies,
the command line and the report ask the kind object (``Robot.kind``) or the
core's hole structure (``CoreRobot.structure()``) instead of comparing the
kind with its name. Each answer is checked against a statement made
independently of the code under test: the robot's own cable ends and joint
count, the tolerance file the allocation reads, the numbers of the two
paths the kinds took before."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "python" / "cdsm"
PACKAGED = ("paper", "serpentine8", "paper_spatial", "two_universal", "sjtu_snake")

#: The comparisons of an arm kind with a name still allowed in the studies,
#: command line, report and compensation: each dispatches to two different
#: paths that a later step of issue 33 makes one (module: the functions).
ALLOWED: dict = {}
KIND_BY_NAME = re.compile(r"""\.kind\s*(==|!=)\s*["'](planar|spatial)["']""")


def test_studies_cli_report_ask_the_kind_instead_of_its_name():
    found = {}
    for folder in ("accuracy", "cli", "report"):
        for path in (PACKAGE / folder).glob("*.py"):
            found[f"{folder}/{path.name}"] = path
    found["paper.py"] = PACKAGE / "paper.py"
    found["calibration/compensation.py"] = PACKAGE / "calibration" / "compensation.py"
    counts = {}
    for key, path in found.items():
        lines = [s for s in path.read_text().splitlines() if not s.strip().startswith("#")]
        n = sum(1 for s in lines if KIND_BY_NAME.search(s))
        if n:
            counts[key] = n
    assert counts == ALLOWED


@pytest.mark.parametrize("name", PACKAGED)
def test_the_errors_a_sample_draws_follow_the_cores_hole_groups(cdsm, name):
    from cdsm.accuracy.montecarlo import error_widths, hole_error_sizes

    r = cdsm.Robot.packaged(name)
    sizes = hole_error_sizes(r)
    if r.kind.hole_errors_per_coordinate:  # every coordinate (x, y, z) of every hole of each cable
        assert sizes.tolist() == [3 * (2 * e + 1) for e in r.cable_ends]
        assert error_widths(r) == (len(r.position_cables), 3 * sum(2 * e + 1 for e in r.cable_ends))
    else:  # one height error per disk
        assert sizes.tolist() == [1] * r.n
        assert error_widths(r) == (r.n, r.n)


@pytest.mark.parametrize("name", ("paper", "two_universal"))
def test_error_budget_groups_are_the_kinds_hole_groups(cdsm, name):
    from cdsm.accuracy.sensitivity import error_budget, position_matrix

    r = cdsm.Robot.packaged(name)
    theta = np.radians([[10.0] * r.n, [-20.0] + [15.0] * (r.n - 1)])
    b = error_budget(r, theta, 1e-3, 0.35e-3, samples=64)
    mp = len(r.position_cables)
    if r.kind.hole_errors_per_coordinate:
        holes = [f"cable {c + 1}'s holes" for c in range(r.cables)]
        width = [3 * (2 * e + 1) for e in r.cable_ends]
    else:
        holes = [f"disk {i + 1}'s holes" for i in range(r.n)]
        width = [1] * r.n
    assert b.groups == tuple([f"cable {c + 1}" for c in r.position_cables] + holes)
    assert b.columns.tolist() == list(range(mp)) + [mp + g for g, w in enumerate(width) for _ in range(w)]
    m = position_matrix(r, theta)
    assert m.shape == (2, r.kind.dim, mp + sum(width))


def test_sensitivities_name_the_block_of_the_hole_errors(cdsm):
    from cdsm.accuracy.sensitivity import sensitivities

    p, s = cdsm.Robot.paper(), cdsm.Robot.packaged("two_universal")
    sp = sensitivities(p, np.zeros((2, 3)))
    assert sp.hole_errors is sp.pair and sp.pair is sp.groups and sp.pair.shape == (2, 3, 3)
    ss = sensitivities(s, np.zeros((2, s.n)), holes=True)
    assert ss.pair is None and ss.groups.shape == (2, 6, 0)  # a spatial arm's hole coordinates are each an error
    assert ss.hole_errors is ss.coords and ss.coords.shape == (2, 6, 96)
    assert ss.cable.shape == (2, 6, len(s.position_cables))


def test_one_tolerance_reader_for_both_kinds(cdsm, tmp_path):
    from cdsm.accuracy import tolerance

    p, s = cdsm.Robot.paper(), cdsm.Robot.packaged("two_universal")
    f = tmp_path / "planar.json"
    f.write_text(json.dumps({"cable_length_tol_m": [1e-4, 2e-4, 3e-4], "hole_height_tol_m": 5e-5}))
    dl, dh = tolerance.read_tolerances(str(f), p)
    assert dl.tolist() == [1e-4, 2e-4, 3e-4] and dh.tolist() == [5e-5] * 3
    g = tmp_path / "spatial.json"
    per_cable = [1e-5 * (c + 1) for c in range(s.cables)]
    g.write_text(json.dumps({"cable_length_tol_m": 1e-4, "hole_tol_m": per_cable}))
    dl, dh = tolerance.read_tolerances(str(g), s)
    assert dl.tolist() == [1e-4] * 4
    assert dh.tolist() == [v for c, v in enumerate(per_cable) for _ in range(3 * (2 * s.cable_ends[c] + 1))]
    with pytest.raises(cdsm.CdsmInputError, match="missing key 'hole_height_tol_m'"):
        tolerance.read_tolerances(str(g), p)
    with pytest.raises(cdsm.CdsmInputError, match=r"`dh_tol` needs 3 values \(one per disk's holes\) or a number"):
        tolerance.error_tolerances(p, 1e-3, [1e-4, 1e-4])
    with pytest.raises(cdsm.CdsmInputError, match=r"8 values \(one per cable's holes\) or 96"):
        tolerance.error_tolerances(s, 1e-3, [1e-4, 1e-4])


def test_monte_carlo_without_hole_errors_is_the_same_for_both_kinds(cdsm):
    """Zero hole tolerances pass no hole errors to the core, either kind (the
    planar path passed zero heights): the same statistics, bit for bit."""
    from cdsm.accuracy.montecarlo import monte_carlo, sample_errors

    r = cdsm.Robot.paper()
    theta = np.radians([[10.0, -5.0, 20.0], [-25.0, 15.0, 5.0], [0.0, 0.0, 0.0]])
    mc = monte_carlo(r, theta, samples=40, chunk=40, dh_tol=0.0, progress=False)
    dl, dh = sample_errors(3, 40, 0, 0, np.full(3, 1e-3), np.zeros(3))
    old = r.core.monte_carlo(np.ascontiguousarray(theta), dl, dh, None, "auto", 1e-12, 100, False, r.threads)
    assert np.array_equal(mc.sum.view(np.uint64), old.sum.reshape(-1, 4).view(np.uint64))
    assert np.array_equal(mc.max.view(np.uint64), old.max.reshape(-1, 4).view(np.uint64))
    assert mc.hist.sum() == old.hist.sum()


def test_the_kinds_answer_the_studies_questions(cdsm):
    from cdsm.kinds import PLANAR, SPATIAL

    assert (PLANAR.default_mask, SPATIAL.default_mask) == ("pose", "position")
    assert (PLANAR.norm_short, SPATIAL.norm_short) == ("|dXY|", "|dXYZ|")
    assert (PLANAR.hole_grouping, SPATIAL.hole_grouping) == ("per_end_disk", "per_cable")
    assert (PLANAR.pose_regions, SPATIAL.pose_regions) == (True, False)
    assert (PLANAR.hole_tolerance_key, SPATIAL.hole_tolerance_key) == ("hole_height_tol_m", "hole_tol_m")
    assert PLANAR.report_tables["mc_mean"] and not SPATIAL.report_tables["mc_mean"]


def test_configuration_masks_default_to_the_kinds(cdsm):
    from cdsm.accuracy import configurations as cf

    p = cdsm.Robot.paper()
    poses = p.fk(np.radians([[10.0, 20.0, -15.0]]))
    th, valid = cf.ik_branches(p, poses)
    th_pose, valid_pose = cf.ik_branches(p, poses, mask="pose")
    assert valid.any() and np.array_equal(th, th_pose, equal_nan=True) and np.array_equal(valid, valid_pose)


def test_is_prototype_compares_the_arm_with_the_papers(cdsm):
    from cdsm import paper

    assert paper.is_prototype(cdsm.Robot.paper())
    assert not paper.is_prototype(cdsm.Robot.packaged("paper_spatial"))
    assert not paper.is_prototype(cdsm.Robot.packaged("serpentine8"))


@pytest.mark.parametrize("name, width", [("paper", 2), ("paper", 3), ("two_universal", 3), ("two_universal", 6)])
def test_compensating_no_targets_gives_an_empty_table_for_either_kind(cdsm, name, width, tmp_path):
    """One compensation for both kinds: no targets give an empty table (a
    spatial arm's used to fail with an error about ``seed``)."""
    r = cdsm.Robot.packaged(name)
    m = len(r.position_cables)
    c = cdsm.FittedPlant.from_effects(r, {"actuation_scale": [0.02]}).compensate(np.zeros((0, width)))
    assert c.commands.shape == (0, m) and c.theta_cmd.shape == (0, r.n) and c.flags == [] and c.kind == r.kind
    c.to_csv(tmp_path / "c.csv")
    head = [line for line in (tmp_path / "c.csv").read_text().splitlines() if not line.startswith("#")]
    axes = r.kind.task_axes if width == r.kind.task else r.kind.position_axes
    assert head[0].split(",")[:len(axes) + 1] == list(axes) + ["L_1"] and len(head) == 1


def test_one_allocation_for_both_kinds_keeps_each_kinds_result(cdsm):
    """One allocate and one result type: its hole field, and its JSON's key,
    by the kind's tolerance key, the tolerances one per position cable and per
    hole group, the default region the kind's (joint grid / Sobol sample)."""
    from cdsm.accuracy import tolerance
    from cdsm.accuracy.workspace import joint_grid

    p, s = cdsm.Robot.paper(), cdsm.Robot.packaged("two_universal")
    assert np.array_equal(tolerance.default_configurations(p), joint_grid(3))
    assert tolerance.default_configurations(s).shape == (1000, s.n)
    for r in (p, s):
        th = np.radians([[10.0] * r.n, [-15.0] * r.n, [20.0] + [-5.0] * (r.n - 1)])
        a = tolerance.allocate(r, 1e-3, th, samples=12, rel_tol=0.2, max_evals=12)
        assert type(a) is tolerance.Allocation and a.kind == r.kind
        holes = getattr(a, r.kind.hole_tolerance_key)
        js = a.to_json()
        assert js["kind"] == r.kind and js[r.kind.hole_tolerance_key] == holes.tolist()
        assert a.cable_length_tol_m.shape == (len(r.position_cables),)
        assert holes.shape == (len(r.core.structure()["hole_groups"]),)
        with pytest.raises(cdsm.CdsmInputError, match=r"`weights`: need 2 or"):
            tolerance.allocate(r, 1e-3, th, weights=[1.0, 2.0, 3.0], samples=4)


def test_cli_tolerance_json_names_the_region_axes_for_either_kind(cdsm, tmp_path, capsys):
    from cdsm.cli import main

    out = tmp_path / "p.json"
    assert main(["tolerance", "--robot", "paper", "--target-mm", "2", "--samples", "10",
                 "--region", "grid:-20:20:20", "--json", str(out), "--quiet"]) == 0
    data = json.loads(out.read_text())
    assert data["region_axes"] == ["x", "y"] and len(data["hole_height_tol_m"]) == 3
    assert "per upper cable" in capsys.readouterr().out
