"""Issue 23: a study and a report a researcher trusts on their own arm.

Facts stated: every report (the study of a planar or a spatial arm, the
diagnosis; the paper's in test_paper_pipeline.py) opens with its headline
— the first element of the HTML body is ``<section id="headline">`` — and
then a table of contents whose every link has its section; no report
prints ``nan``; the redundant 4-joint arm gets a robot-neutral report (no
paper prose, claims or Tables 2/3) that says which protocol it used and
why; failed Monte-Carlo solves are counted (the report's number is the
Monte Carlo's) and flagged; two runs with the same seed write
byte-identical files; every figure fits the page's text column unscaled;
a diverging map's zero is not the page's white and its negative end is
not the grey of the unreachable marks; the diagnosis draws no second
panel when no model is chosen and says "chosen" only when one is. Small
configuration counts keep it fast.
"""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _unrendered(st, report_text):
    """The report of ``st`` as (html, markdown) without drawing its figures
    (they are left out), checked by ``report_text``."""
    from cdsm import report

    doc = report.report_for(st).build({})
    html, md = doc.html({}, "t"), doc.markdown("figures", {})
    report_text(html, md)
    return html, md


@pytest.fixture(scope="module")
def redundant(cdsm):
    return cdsm.Robot.from_toml(ROOT / "examples" / "two_section_arm.toml")


@pytest.fixture(scope="module")
def redundant_runs(cdsm, redundant, tmp_path_factory):
    """The study of the 4-joint arm on a small grid, run twice with the same seed, each written."""
    from cdsm import report, study
    from cdsm.accuracy import workspace

    grid = workspace.joint_grid(4, step=np.radians(20.0))  # 4 values per joint: 256 configurations
    root = tmp_path_factory.mktemp("redundant")
    for k in range(2):
        st = study.run(redundant, grid=grid, samples=20, seed=3, progress=False)
        report.write(st, root / f"run{k}", detail=False)
    return st, [root / "run0", root / "run1"], root


def test_the_redundant_arm_gets_the_joint_space_protocol_and_says_why(cdsm, redundant, redundant_runs, report_page):
    from cdsm import paper, study

    protocols, reason = study.choose_protocols(redundant)
    assert protocols == ["joint"] and "redundant" in reason
    assert not paper.is_prototype(redundant)
    st, (out, _), _ = redundant_runs
    md = report_page(out)
    assert "joint-space protocol" in md and "redundant" in md and "null space" in md
    for word in ("Table 2", "Table 3", "claims", "the paper", "Fig. 5", "Fig. 7", "Fig. 12", "readings"):
        assert word not in md, word
    for name in ("claims.csv", "table2.csv", "table3.csv", "readings.csv"):
        assert not (out / name).exists()


def test_holes_against_lengths_divides_only_by_a_hole_error_that_moves_the_tip(redundant_runs):
    """The ratio |d(X, Y)|(length) / |d(X, Y)|(holes) divided by 1e-17 m where
    a hole error does not move the tip of the 4-joint arm (its 95th
    percentile read 4.7e13): it is taken where the hole error moves the tip
    by at least 1 µm, and the configurations left out are counted."""
    import re

    _, (out, _), _ = redundant_runs
    md = (out / "report.md").read_text(encoding="utf-8")
    para = next(p for p in md.split("\n\n") if p.startswith("**Holes against lengths.**"))
    lo, med, hi = (float(v) for v in re.search(
        r"5th percentile (\d+\.\d), median (\d+\.\d), 95th percentile (\d+\.\d)", para).groups())
    assert 1.0 < lo < med < hi < 100.0, para
    assert "where the hole error moves the tip by at least 1 µm" in para, para
    used, total = (int(v) for v in re.search(r"\((\d+) of (\d+)\)", para).groups())
    left = int(re.search(r"At (\d+) of \d+ the hole error moves the tip by less than 1 µm", para).group(1))
    assert used + left == total and left > 0, para


def test_the_paper_geometry_is_recognised_by_geometry_not_by_name(cdsm):
    from cdsm import paper

    for name in ("paper", "paper_reversed_weights", "paper_vertical", "paper_vertical_reversed_weights"):
        assert paper.is_prototype(cdsm.Robot.packaged(name))
    renamed = cdsm.Robot.from_toml_str(cdsm.Robot.paper().to_toml().replace("paper prototype", "my arm"))
    assert renamed.name != cdsm.Robot.paper().name and paper.is_prototype(renamed)
    holes = cdsm.Robot.paper().holes.copy()
    holes[0, 1, 0, 1] += 1e-4  # one hole 0.1 mm off: another arm
    assert not paper.is_prototype(cdsm.Robot.paper().with_holes(holes))
    assert not paper.is_prototype(cdsm.Robot.packaged("paper_spatial"))  # the planar layer's pose IK is planar


def test_failed_monte_carlo_solves_are_counted_and_flagged(cdsm, redundant, report_text):
    from cdsm import report, study

    th = np.random.default_rng(0).uniform(-0.6, 0.6, (30, 4))
    st = study.run(redundant, theta=th, samples=20, dl_tol=1e-2, progress=False)  # ±10 mm: some solves fail
    mc = st.monte_carlo["sampled"]
    failed = int(mc.failed.sum())
    assert failed > 0
    _, md = _unrendered(st, report_text)
    head = md[:md.index("## Contents")]
    assert f"{failed} of {int(mc.count.sum()) + failed} solves failed" in head
    assert f"at {int((mc.failed > 0).sum())} configurations — flagged" in head
    assert "Flag — failed solves" in md
    rows = report.report_for(st).tables()["configurations.csv"]
    assert sum(r["mc_failed"] for r in rows) == failed


def test_the_spatial_report_opens_with_its_headline(cdsm, report_text):
    from cdsm import report, study
    from cdsm.report import figures

    st = study.run(cdsm.Robot.packaged("two_universal"), configurations=30, samples=10, progress=False)
    _, md = _unrendered(st, report_text)
    assert "sampled joint-space protocol" in md
    assert "|d(X, Y, Z)|" in md[:md.index("## Contents")]
    for word in ("Table 3", "claims"):
        assert word not in md
    jobs = report.report_for(st).figure_jobs()
    assert {"overview_sampled", "rotation_sampled", "montecarlo_sampled", "feasibility", "scenario_cable1plus"} \
        <= {name for name, _ in jobs}
    for name, make in jobs[:7] + jobs[-1:]:  # the figures are made (not drawn) within the page's width
        for _, fig in make():
            assert fig.get_size_inches()[0] <= figures.MAX_WIDTH_IN


def _same_files(a: Path, b: Path, skip=()):
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    for f in files:
        if f.name not in skip:
            assert (a / f).read_bytes() == (b / f).read_bytes(), str(f)


def test_two_runs_with_the_same_seed_write_the_same_bytes(redundant_runs):
    _, outs, root = redundant_runs
    _same_files(*outs)
    text = (outs[0] / "report.html").read_text(encoding="utf-8")
    assert str(root) not in text and "run0" not in text


def test_two_diagnosis_reports_are_the_same_and_open_with_the_answer(cdsm, tmp_path, report_page):
    from cdsm.calibration import diagnosis, experiment, measurements
    from cdsm.report import diagnosis as diagnosis_report

    robot = cdsm.Robot.paper()
    meas = measurements.packaged("table3", 3)
    d = diagnosis.diagnose(robot, meas)
    sug = experiment.suggest(d, 3)
    for k in range(2):
        diagnosis_report.write(d, tmp_path / f"d{k}", suggestion=sug)
    _same_files(tmp_path / "d0", tmp_path / "d1")
    md = report_page(tmp_path / "d0")
    head = md[:md.index("## Contents")]
    assert f"**Verdict: {d.verdict}**" in head
    assert "Effect: none" in head and d.singles[0].name in head  # nothing chosen: the best candidate, named
    assert f"it does not — held-out RMS position error {d.baseline.heldout_rms * 1e6:.1f} µm" in head
    assert "Next measurements" in head and "suggested.csv" in head


def test_diagnosis_figures_say_chosen_only_when_a_model_is(cdsm):
    from cdsm.calibration import diagnosis, measurements, plant
    from cdsm.report import diagnosis as diagnosis_report

    robot = cdsm.Robot.paper()
    none = diagnosis.diagnose(robot, measurements.packaged("table3", 3))
    assert none.chosen is None
    fig = diagnosis_report.residual_map_figure(none)
    titles = [ax.get_title(loc="left") for ax in fig.axes]
    assert len(fig.axes) == 2 and titles[0].startswith("nominal model") and titles[1].startswith("zoom")
    assert not any("chosen" in t for t in titles)
    fig = diagnosis_report.candidates_figure(none)
    ax = fig.axes[0]
    assert "chosen" not in ax.get_title(loc="left").replace("no effect chosen", "")
    fig.canvas.draw()
    leg, box = ax.get_legend().get_window_extent(), ax.get_window_extent()
    assert leg.y1 < box.y0  # the legend is below the axes: it covers no bar

    vp = plant.VirtualPrototype(robot, {"hole_height": [2e-4, -1e-4, 2e-4]}, noise=10e-6, seed=2)
    theta, dL = vp.random_commands(15)
    some = diagnosis.diagnose(robot, vp.measure(theta.repeat(2, axis=0), dL.repeat(2, axis=0)))
    assert some.chosen is not None
    titles = [ax.get_title(loc="left") for ax in diagnosis_report.residual_map_figure(some).axes]
    assert titles[1].startswith(f"chosen model: {some.best}")
    assert "red: chosen" in diagnosis_report.candidates_figure(some).axes[0].get_title(loc="left")


def test_diverging_maps_keep_zero_and_negatives_visible(cdsm):
    import matplotlib.colors as mc

    from cdsm.report import figures

    for hue in figures.HUES:
        cmap = figures.hue_cmap(hue)
        zero, neg, pos = (np.array(cmap(v)[:3]) for v in (0.5, 0.0, 1.0))
        assert np.max(1.0 - zero) > 0.15  # not the page's white
        # the negative end has a hue of its own: not grey (the unreachable crosses), not the positive end
        assert mc.rgb_to_hsv(neg)[1] > 0.3 and np.abs(neg - pos).max() > 0.3
    magma = figures.seq_cmap("magma_r")
    assert np.max(1.0 - np.array(magma(0.0)[:3])) > 0.15


def test_cli_study_of_a_two_joint_arm(cdsm, tmp_path, capsys, report_page):
    """``cdsm paper`` on an arm of fewer joints than its pose: the joint-space
    protocol, said why, its CSV files, no paper layer; the terminal gives the
    failed solves' count."""
    from conftest import N12_LINKAGES, robot_toml

    from cdsm.cli import main

    f = tmp_path / "two.toml"
    f.write_text(robot_toml(N12_LINKAGES[:2], name="two links"))
    out = tmp_path / "out"
    assert main(["paper", "--robot", str(f), "--out-dir", str(out), "--samples", "10", "--no-scenario-figures",
                 "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "joint: worst single-error" in printed and "failed solves 0" in printed and "claims" not in printed
    md = report_page(out)
    assert "fewer than the 3 coordinates of its pose" in md and "joint-space protocol" in md
    assert sorted(p.name for p in out.glob("*.csv")) == ["configurations.csv", "friction.csv", "jumps.csv",
                                                          "montecarlo.csv", "scenarios.csv"]


def test_the_paper_keeps_its_1000_samples_and_large_grids_and_arms_get_fewer(cdsm, redundant):
    from cdsm import study

    paper = cdsm.Robot.paper()
    assert study.default_samples(paper, study.configuration_count(paper, study.choose_protocols(paper)[0])) == 1000
    n = study.configuration_count(redundant, study.choose_protocols(redundant)[0])
    assert n == 11 ** 4
    # the budget counts a solve by its size against the paper's 3 joints x 3 position cables:
    # the most samples that fit it
    size = redundant.n * len(redundant.position_cables) / 9.0
    s = study.default_samples(redundant, n)
    assert study.MIN_SAMPLES <= s < 1000
    assert s * n * size <= study.DEFAULT_SOLVES < (s + 1) * n * size
    assert study.default_samples(cdsm.Robot.packaged("two_universal"), 1000) == 200
    # the SJTU snake (24 joints, 36 position cables) takes the floor
    assert study.default_samples(cdsm.Robot.packaged("sjtu_snake"), 1000) == study.MIN_SAMPLES


def test_a_long_arm_draws_maps_for_its_worst_single_errors_only(cdsm):
    """Past 24 single errors a map each would bury the report: the 12 with
    the largest position error get one (every drawn error is at least as
    large as every one left to the overview), in the study's order."""
    from types import SimpleNamespace as NS

    from cdsm.report import study_figures as sf

    rng = np.random.default_rng(5)
    worst = rng.permutation(40) * 1e-4
    results = [NS(scenario=NS(key=f"s{i}"), position=np.array([np.nan, w, 0.5 * w])) for i, w in enumerate(worst)]
    keys = sf.detailed_scenarios(NS(scenarios=results))
    assert len(keys) == sf.DETAILED_SCENARIOS
    drawn = {int(k[1:]) for k in keys}
    assert min(worst[i] for i in drawn) > max(worst[i] for i in range(40) if i not in drawn)
    assert keys == sorted(keys, key=lambda k: int(k[1:]))
    few = results[:sf.MAX_SCENARIO_FIGURES]
    assert sf.detailed_scenarios(NS(scenarios=few)) == [r.scenario.key for r in few]


#: a robot name that is Markdown and matplotlib markup if taken as such (a heading, bold, a code span, a link, a
#: table cell break, HTML, a mathtext formula with a stray backslash)
HOSTILE_NAME = "arm **x**\n# h | `c` [l](#m) <b> $\\\\frac $1"


def test_outside_text_shows_as_written_and_changes_no_structure():
    """``document.literal``: the name keeps its characters in both renderers
    (its line break as a space) and adds no heading, table cell or link."""
    from cdsm.report.document import Document, literal

    doc = Document(f"Study of {literal(HOSTILE_NAME)}")
    doc.section("headline", "Headline")
    doc.p(f"Robot **{literal(HOSTILE_NAME)}**.")
    doc.table(["robot", "n"], [[literal(HOSTILE_NAME), "3"]])
    md = doc.markdown("figures")
    assert [line for line in md.splitlines() if line.startswith("#")] == [md.splitlines()[0]]
    row = next(line for line in md.splitlines() if line.startswith("| arm"))
    assert len(re.findall(r"(?<!\\)((?:\\\\)*)\|", row)) == 3  # two cells: three unescaped pipes
    page = doc.html({}, "t")
    shown = html.escape(HOSTILE_NAME.replace("\n", " "))
    assert f"<h1>Study of {shown}</h1>" in page and f"<b>{shown}</b>" in page and f"<td>{shown}</td>" in page
    assert "<a href" not in page and "<code>" not in page


def test_a_hostile_robot_name_in_the_reports(cdsm, tmp_path):
    """A study and a diagnosis of a robot whose name is markup: both reports
    keep their structure and the figures draw (a mathtext name raised at draw
    time)."""
    from conftest import N12_LINKAGES, robot_toml

    from cdsm.calibration import diagnosis, measurements
    from cdsm.cli import main
    from cdsm.report import diagnosis as diagnosis_report

    f = tmp_path / "two.toml"
    f.write_text(re.sub(r'^name = .*$', lambda _: "name = " + json.dumps(HOSTILE_NAME),
                        robot_toml(N12_LINKAGES[:2], name="x"), count=1, flags=re.M))
    out = tmp_path / "study"
    assert main(["paper", "--robot", str(f), "--out-dir", str(out), "--samples", "10", "--no-scenario-figures",
                 "--quiet"]) == 0
    paper = re.sub(r'^name = .*$', lambda _: "name = " + json.dumps(HOSTILE_NAME),
                   (Path(cdsm.__file__).parent / "robots" / "paper.toml").read_text(encoding="utf-8"),
                   count=1, flags=re.M)
    d = diagnosis.diagnose(cdsm.Robot.from_toml_str(paper), measurements.packaged("table3", 3))
    diagnosis_report.write(d, tmp_path / "diag")
    for folder in (out, tmp_path / "diag"):
        md = (folder / "report.md").read_text(encoding="utf-8")
        assert not re.search(r"^#+ h", md, re.M) and "arm \\*\\*x\\*\\* \\# h \\| \\`c\\`" in md
        assert html.escape(HOSTILE_NAME.replace("\n", " ")) in (folder / "report.html").read_text(encoding="utf-8")
        assert list((folder / "figures").glob("*.png"))
