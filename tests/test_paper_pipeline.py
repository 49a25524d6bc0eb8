"""The ``cdsm paper`` pipeline end to end: command line, report files, the
workspace helpers it relies on, measurement parsing errors, and the claims of
a default-robot run."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    """One small CLI run (--samples 50) shared by the file checks."""
    from cdsm import cli

    out = tmp_path_factory.mktemp("paper")
    rc = cli.main(["paper", "--out-dir", str(out), "--samples", "50", "--seed", "3", "--quiet"])
    return rc, out


@pytest.fixture(scope="module")
def study():
    from cdsm import paper

    return paper.run(samples=20, progress=False)


# ---------------------------------------------------------------------------
# command line
# ---------------------------------------------------------------------------
def test_cli_writes_everything(paper_run):
    rc, out = paper_run
    assert rc == 0
    for name in ("report.md", "report.html", "table3.csv", "scenarios.csv", "jumps.csv", "claims.csv",
                 "montecarlo.csv", "table2.csv"):
        assert (out / name).is_file(), name
    pngs = sorted((out / "figures").glob("*.png"))
    names = {p.stem for p in pngs}
    assert {"overview_attitude0", "overview_joint", "montecarlo_attitude0", "montecarlo_joint",
            "singular", "workspace", "fig12_singular_state", "table3"} <= names
    assert sum(n.startswith("scenario_") for n in names) == 12  # both protocols in each
    assert any(n.startswith("table2_") for n in names)
    for p in pngs:
        assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_html_is_self_contained(paper_run):
    _, out = paper_run
    html = (out / "report.html").read_text(encoding="utf-8")
    n_img = html.count("<img")
    assert n_img >= 30
    assert html.count("src='data:image/png;base64,") == n_img
    assert not re.search(r"<img[^>]+src=['\"](?!data:)", html)
    assert not re.search(r"<(link|script)[^>]+(href|src)=", html)
    assert "<table>" in html


def test_the_paper_report_opens_with_its_answers(paper_run, report_page):
    """The headline (the body's first element) gives Table 3's agreement,
    the gap's verdict and the claims' verdicts as the CSV files have them."""
    import csv

    _, out = paper_run
    md = report_page(out)
    head = md[:md.index("## Contents")]
    t3 = list(csv.DictReader(open(out / "table3.csv")))
    err = max(abs(float(r[f"d{a}_ours_m"]) - float(r[f"d{a}_paper_m"])) for r in t3 for a in "xy") * 1e3
    mant, exp = f"{err:.1e}".split("e")
    assert f"Table 3 reproduced** to {mant}e{int(exp)} mm" in head and err < 2e-4
    verdict = next(r for r in csv.DictReader(open(out / "readings.csv")) if r["reading"] == "as given")
    assert f"the verdict is **{verdict['file_order_verdict']}**" in head
    claims = list(csv.DictReader(open(out / "claims.csv")))
    held = sum(c["holds"] == "True" for c in claims)
    assert f"{held} of {len(claims)} hold" in head
    for c in claims:
        if c["holds"] != "True":
            assert c["claim"].split(":")[0] in head
    for sid in ("table3", "claims", "single-errors", "montecarlo", "readings", "table2", "fig12"):
        assert f"](#{sid})" in md and f'<a id="{sid}"></a>' in md


def test_report_mentions_both_protocols(paper_run):
    _, out = paper_run
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "attitude-0 protocol" in md and "joint-space protocol" in md
    assert "unreachable" in md
    assert "50 samples, seed 3" in md
    header = (out / "table3.csv").read_text().splitlines()[0].split(",")
    for col in ("dx_ours_m", "dy_ours_m", "dx_paper_m", "dx_measured_m", "dy_measured_minus_ours_m"):
        assert col in header


def _cli_error(argv, capsys):
    from cdsm import cli

    try:
        rc = cli.main(argv)
    except SystemExit as exc:  # argparse
        rc = exc.code
    err = capsys.readouterr().err
    return rc, err


def test_bad_robot_file(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\nn = 3\n[[linkage]]\nlink_before = 0.03\n')
    rc, err = _cli_error(["paper", "--robot", str(bad), "--out-dir", str(tmp_path / "o"), "--quiet"], capsys)
    assert rc == 2
    assert err.startswith("cdsm: error:") and "link_after" in err and "bad.toml" in err
    assert "Traceback" not in err
    rc, err = _cli_error(["paper", "--robot", str(tmp_path / "missing.toml"), "--quiet"], capsys)
    assert rc == 2 and "missing.toml" in err


@pytest.mark.parametrize("argv, word", [
    (["paper", "--samples", "0"], "--samples"),
    (["paper", "--samples", "many"], "--samples"),
    (["paper", "--seed", "-1"], "--seed"),
    (["paper", "--bogus"], "--bogus"),
])
def test_bad_options(argv, word, capsys):
    rc, err = _cli_error(argv + ["--quiet"] if "--bogus" not in argv else argv, capsys)
    assert rc == 2
    assert word in err and "Traceback" not in err


def test_out_is_a_file(tmp_path, capsys):
    f = tmp_path / "f"
    f.write_text("x")
    rc, err = _cli_error(["paper", "--out-dir", str(f), "--quiet"], capsys)
    assert rc == 2 and "--out-dir" in err


def test_old_out_spelling_still_names_the_directory(tmp_path, capsys):
    """``--out DIR`` (0.1) still works for ``cdsm paper`` and says to use ``--out-dir``."""
    f = tmp_path / "f"
    f.write_text("x")
    rc, err = _cli_error(["paper", "--out", str(f), "--quiet"], capsys)
    assert rc == 2 and "deprecated" in err and "--out-dir" in err and "exists and is not a directory" in err


# ---------------------------------------------------------------------------
# workspace helpers
# ---------------------------------------------------------------------------
def test_joint_grid_and_neighbours():
    from cdsm.accuracy import workspace

    g = workspace.joint_grid(3)
    assert g.shape == (2197, 3)
    assert np.allclose(np.degrees(g[[0, -1]]), [[-30] * 3, [30] * 3])
    nb = workspace.grid_neighbours(13, 3)
    assert nb.shape == (3 * 13 * 13 * 12, 4)
    a, b = nb[:, 0], nb[:, 1]
    steps = np.abs(g[a] - g[b])
    assert np.allclose(np.sort(steps, axis=1)[:, :2], 0.0)
    assert np.allclose(steps.max(axis=1), np.radians(5.0))


def _synthetic_ws(robot, k=13):
    from cdsm.accuracy import workspace

    g = workspace.joint_grid(robot.n, step=np.radians(60.0 / (k - 1)))
    return workspace.Workspace("joint", g, robot.fk(g), g.copy(), np.ones(len(g), bool),
                               workspace.grid_neighbours(k, robot.n))


def test_jump_detection_synthetic():
    import cdsm
    from cdsm.accuracy import workspace

    robot = cdsm.Robot.paper()
    ws = _synthetic_ws(robot)
    g = ws.grid
    smooth = np.stack([1e-3 * g[:, 0] + 2e-4 * g[:, 1], -5e-4 * g[:, 2] + 1e-4, 0 * g[:, 0]], axis=1)
    j = workspace.jump_points(robot, ws, smooth)
    assert not j.edge_jump.any() and not j.point.any()

    planted = smooth.copy()
    step = g[:, 0] > np.radians(12.0)  # a discontinuity across theta_1 = 12.5 deg
    planted[step, 0] += 5e-3
    j = workspace.jump_points(robot, ws, planted)
    assert j.edge_jump.any()
    a, b = ws.neighbours[j.edge_jump, 0], ws.neighbours[j.edge_jump, 1]
    assert np.all(step[a] != step[b])  # every jump straddles the plant
    assert j.point[step].any() and j.point[~step].any()
    assert sum(j.counts().values()) == int(j.edge_jump.sum())


# ---------------------------------------------------------------------------
# measurement tables
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("text, column", [
    ("x_cmd,y_cmd,dL_1,dL_2,dL_3,dy\n0.2,0,-0.001,0,0,0.001\n", "dx"),          # missing column
    ("x_cmd,y_cmd,dL_1,dL_2,dL_3,dx,dy\n0.2,nan,-0.001,0,0,0,0.001\n", "y_cmd"),  # NaN cell
    ("x_cmd,y_cmd,dL_1,x,y,dx,dy\n0.2,0,-0.001,0.2,0,0,0.001\n", "dx"),          # both kinds
])
def test_parse_csv_errors_name_the_column(text, column):
    import cdsm
    from cdsm.calibration import measurements

    with pytest.raises(cdsm.CdsmInputError) as ei:
        measurements.parse_csv(text, 3, "t.csv")
    assert column in str(ei.value)


def test_packaged_measurements():
    from cdsm.calibration import measurements

    m = measurements.packaged("table3", 3)
    assert len(m) == 9 and m.reading == "displacement"
    assert np.allclose(m.dL[:, 0], -1e-3)


# ---------------------------------------------------------------------------
# the study itself
# ---------------------------------------------------------------------------
def _claim(study, prefix):
    return next(c for c in study.claims if c["claim"].startswith(prefix))


def test_claims_table3_and_conclusion4(study):
    t = study.table3
    assert np.abs(t["ours"] - t["paper"]).max() < 2e-7  # 2e-4 mm
    assert _claim(study, "Table 3")["holds"]
    assert _claim(study, "Conclusion 4")["holds"]


def test_jump_points_only_under_attitude0(study):
    a0 = sum(int(r.jumps.point.sum()) for r in study.scenarios if r.protocol == "attitude0")
    jt = sum(int(r.jumps.point.sum()) for r in study.scenarios if r.protocol == "joint")
    assert a0 > 0 and jt == 0


def test_table2_panels_share_one_range(study):
    """Every panel of a Table 2 figure shows the same X and Y window (the
    fourth panel of the first pose had a Y range of its own)."""
    from cdsm.report import paper_figures

    figs = paper_figures.table2_figures(study)
    assert len(figs) == 6
    for name, fig in figs:
        fig.canvas.draw()
        panels = [ax for ax in fig.axes if ax.get_visible()]
        assert len(panels) >= 2, name
        assert len({ax.get_xlim() for ax in panels}) == 1, name
        assert len({ax.get_ylim() for ax in panels}) == 1, name


def test_fig9_labels_stand_apart_and_every_set_of_tips_shows(study):
    """The workspace figure with the paper's marks (its Fig. 9 range): the
    labels of Table 3's nine points do not overlap (points 2-6 lie within
    15 mm), and the attitude-0 grid's tips (blue) are drawn over the joint
    grid's (grey) and the phi = 0 reach (green), which hid them."""
    from matplotlib.text import Text

    from cdsm.report import paper_figures, study_figures

    fig = study_figures.workspace_figure(study, paper_figures.workspace_overlay(study))
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    ax = fig.axes[0]
    points = {str(p) for p in study.table3["point"]}
    labels = [t for t in ax.texts if t.get_text() in points]
    assert len(labels) == 9
    boxes = [Text.get_window_extent(t, renderer) for t in labels]  # the words, not their leader lines
    crowded = [(labels[i].get_text(), labels[j].get_text()) for i in range(9) for j in range(i + 1, 9)
               if boxes[i].overlaps(boxes[j])]
    assert not crowded, crowded
    layer = {c.get_label().split(" ")[0]: c.get_zorder() for c in ax.collections}
    assert layer["grid"] > layer["phi"] > layer["joint"], layer


def test_chain_points_end_at_the_tip():
    import cdsm
    from cdsm.report import figures

    robot = cdsm.Robot.paper()
    th = np.radians([12.0, -25.0, 7.0])
    pts = figures.chain_points(robot, th)
    assert pts.shape == (3 * robot.n + 1, 2)
    assert np.allclose(pts[-1], robot.fk(th)[:2], atol=1e-12)


def test_redundant_robots_get_a_coarser_grid_and_no_jump_search():
    """n = 8: the ±30° grid is kept under 20000 points; with 3 values per joint
    there is no trend along a grid line, so jump points are not searched; the
    phi = 0 workspace is sampled instead of gridded (bounded memory)."""
    import cdsm
    from cdsm.accuracy import workspace
    from cdsm.report import study_figures

    r8 = cdsm.Robot.from_toml(Path(cdsm.__file__).parent / "robots" / "serpentine8.toml")
    assert np.degrees(workspace.default_step(3)) == pytest.approx(5.0)
    assert np.degrees(workspace.default_step(8)) == pytest.approx(30.0)
    ws = workspace.sweep(r8, "joint")
    assert len(ws.grid) == 3 ** 8 and len(ws.neighbours) == 0
    tips = study_figures.phi0_tips(r8, max_points=5000)
    assert 0 < len(tips) <= 5000 and np.isfinite(tips).all()
