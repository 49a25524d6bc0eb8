"""Objects a person reads (issue 23, item 6): short reprs and notebook views
of results and robots, the drawing of an arm of either kind, and the face
frames it is drawn from (against the NumPy reference)."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

ROBOTS = Path(__file__).resolve().parents[1] / "python" / "cdsm" / "robots"


@pytest.mark.parametrize("name", ["two_universal", "sjtu_snake", "paper_spatial"])
def test_disk_frames_equal_the_reference(cdsm, ref, name):
    robot = cdsm.Robot.from_toml(name)
    nominal = ref.load_robot(ROBOTS / f"{name}.toml")
    lim = robot.joint_limits
    theta = np.random.default_rng(4).uniform(lim[:, 0], lim[:, 1], (50, robot.n))
    got = robot.disk_frames(theta)
    want = ref.disk_frames(nominal, theta)
    k = got.shape[1]
    np.testing.assert_allclose(got[:, :, 0, :3, :3], want["Ra"][:, 1:k + 1], atol=1e-14)
    np.testing.assert_allclose(got[:, :, 1, :3, 3], want["tb"][:, 1:k + 1], atol=1e-14)
    np.testing.assert_array_equal(got[:, :, :, 3], np.broadcast_to([0.0, 0.0, 0.0, 1.0], got[:, :, :, 3].shape))


def test_a_planar_arm_is_drawn_as_its_spatial_twin(cdsm):
    """The paper prototype and its spatial file are the same arm: the same
    face frames, in the plane z = 0."""
    theta = np.random.default_rng(5).uniform(-0.6, 0.6, (20, 3))
    planar, spatial = cdsm.Robot.paper(), cdsm.Robot.from_toml("paper_spatial")
    np.testing.assert_allclose(planar.disk_frames(theta), spatial.disk_frames(theta), atol=1e-15)
    assert np.abs(planar.disk_frames(theta)[..., 2, 3]).max() == 0.0


@pytest.mark.parametrize("name", ["paper", "two_universal"])
def test_drawn_cables_have_the_cable_lengths(cdsm, name):
    from cdsm.report.drawing import cable_paths

    robot = cdsm.Robot.from_toml(name)
    theta = np.random.default_rng(6).uniform(-0.5, 0.5, robot.n)
    drawn = [np.linalg.norm(np.diff(p, axis=0), axis=1).sum() for p in cable_paths(robot, theta)]
    np.testing.assert_allclose(drawn, robot.cable_lengths(theta), rtol=0, atol=1e-14)


@pytest.mark.parametrize("name,dims", [("paper", 2), ("two_universal", 3)])
def test_plot_draws_every_cable_in_the_arms_space(cdsm, name, dims):
    robot = cdsm.Robot.from_toml(name)
    ax = robot.plot(np.full(robot.n, 0.2))
    assert (ax.name == "3d") == (dims == 3)
    assert sum(1 for ln in ax.get_lines() if ln.get_color() in ("#c0392b", "#2471a3")) == robot.cables
    with pytest.raises(cdsm.CdsmInputError, match="`theta`"):
        robot.plot(np.zeros(robot.n + 1))
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.mark.parametrize("name, theta, title", [
    ("sjtu_snake", np.full(24, 0.1), "every joint at 5.7°"),
    ("sjtu_snake", np.linspace(-0.1, 0.2, 24), "24 joints, theta from -5.7° to 11.5°"),
    ("two_universal", [0.1, -0.2, 0.0, 0.35], "theta = (5.7, -11.5, 0.0, 20.1)°"),
    ("paper", None, "straight: every joint at 0.0°")])
def test_plot_titles_the_configuration_it_draws(cdsm, name, theta, title):
    """One angle for every joint is said once ("theta from 5.7 to 5.7 deg"
    said it as a range), a range only when the angles differ, in the
    degrees every print uses."""
    import matplotlib.pyplot as plt

    robot = cdsm.Robot.from_toml(name)
    ax = robot.plot(theta)
    assert ax.get_title() == f"{robot.name}\n{title}"
    plt.close("all")


def test_one_joint_limit_reads_the_same_in_print_report_and_figure(cdsm):
    """0.6 rad was 34.4° in ``print(robot)`` and 34° in the study report:
    every place that shows a joint limit uses :func:`cdsm.display.degrees`."""
    from cdsm import study
    from cdsm.display import degrees
    from cdsm.report import report_for, study_figures

    r = cdsm.Robot.from_toml("two_universal")
    assert degrees(0.6) == "34.4" and degrees(-1e-17) == "0.0" and degrees(np.radians(35.0)) == "35.0"
    assert "[-34.4, 34.4]" in str(r)
    st = study.run(r, theta=np.random.default_rng(0).uniform(-0.5, 0.5, (12, r.n)), samples=4, progress=False)
    md = report_for(st).build({}).markdown("figures", {})
    assert "[-34.4°, 34.4°]" in md and "[-34°" not in md
    from cdsm.accuracy.workspace import joint_grid

    paper = study.run(cdsm.Robot.paper(), grid=joint_grid(3, step=np.radians(15.0)), samples=2, progress=False)
    fig = study_figures.workspace_figure(paper)
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "phi = 0 within the joint limits (up to ±35.0°)" in labels, labels


def test_a_robot_prints_its_links_holes_cables_and_limits(cdsm):
    r = cdsm.Robot.from_toml("two_universal")
    text = str(r)
    assert "4 joints on 2 disks" in text and "limits (deg)" in text and "[-34.4, 34.4]" in text
    assert "force, 0.2 N" in text and "base hole (m)" in text
    html = r._repr_html_()
    assert html.count("<tr>") == 1 + 4 + 1 + 2 + 1 + 8 and "<table>" in html


def test_results_repr_is_short_and_names_the_shapes(cdsm):
    r = cdsm.Robot.paper()
    theta = np.zeros((50, 3))
    mc = cdsm.accuracy.monte_carlo(r, theta, samples=4, progress=False)
    assert len(repr(mc)) < 600 and "array(50, 4) float64" in repr(mc)
    sol = r.solve_cables(r.upper_lengths(theta))
    assert len(repr(sol)) < 400 and "theta=array(50, 3)" in repr(sol)
    assert "<table>" in mc._repr_html_()
    from cdsm.calibration import diagnosis, measurements

    d = diagnosis.diagnose(r, measurements.packaged("table3"))
    assert repr(d).startswith("Diagnosis(verdict='unexplained', best='none'") and len(repr(d)) < 300
