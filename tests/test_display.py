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
