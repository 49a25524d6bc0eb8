"""The reference's one description of an arm (``cdsm.reference.robot``): both
robot-file forms read into it, the planar shorthand desugared as
``docs/model.md`` ("The arm model") defines it, and its planar view.  SI units."""

from __future__ import annotations

import re

import numpy as np
import pytest

from conftest import ROOT, PAPER_LINKAGES, reference_robot, robot_toml

ROBOTS = ROOT / "python" / "cdsm" / "robots"
PLANAR_FILES = ["paper", "paper_reversed_weights", "paper_vertical", "paper_vertical_reversed_weights",
                "serpentine8"]
G0 = 9.80665


def test_the_paper_robot_is_its_packaged_file(ref):
    """``Robot.paper()`` (Table 1 with the paper's loads) is ``robots/paper.toml``."""
    a, b = ref.Robot.paper(), ref.load_robot(ROBOTS / "paper.toml")
    for field in ("axes", "offsets", "joint_limits", "joint_disk", "link_after", "thickness", "radius", "mass",
                  "com", "gravity", "cable_end", "cable_tension"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=field)
    assert a.cable_mode == b.cable_mode and a.kind == b.kind == "planar"
    for h, g in zip(a.holes, b.holes):
        np.testing.assert_array_equal(h, g)
    np.testing.assert_allclose(a.cable_tension[1::2], np.array([50.0, 10.0, 5.0]) * 1e-3 * G0, rtol=1e-15)


def test_the_planar_shorthand_is_the_general_form_of_docs(ref):
    """The paper's planar file and its general-form twin (``paper_spatial.toml``,
    written by hand from ``docs/spatial.md``) describe the same joints, disks,
    cables and loads; only the kind (the task space), the name and the disks'
    radii (the largest hole distance vs the twin's 35 mm) differ."""
    planar, general = ref.load_robot(ROBOTS / "paper.toml"), ref.load_robot(ROBOTS / "paper_spatial.toml")
    assert (planar.kind, general.kind) == ("planar", "spatial")
    for field in ("axes", "offsets", "joint_limits", "joint_disk", "link_after", "thickness", "mass", "com",
                  "gravity", "cable_end", "cable_tension", "youngs_modulus", "diameter", "routing_length"):
        np.testing.assert_allclose(getattr(planar, field), getattr(general, field), rtol=0, atol=1e-17,
                                   err_msg=field)
    assert planar.cable_mode == general.cable_mode
    for h, g in zip(planar.holes, general.holes):
        np.testing.assert_allclose(h, g, rtol=0, atol=1e-17)  # (0, r cos a, r sin a) with a = pi: 3.7e-18
    np.testing.assert_array_equal(planar.radius, [0.030, 0.028, 0.026])
    np.testing.assert_array_equal(general.radius, [0.035] * 3)


@pytest.mark.parametrize("name", PLANAR_FILES)
def test_planar_files_read_as_the_core_reads_them(cdsm, ref, name):
    """Every packaged planar file: the reference's planar view of its reading is the
    core's robot, number for number (the used hole entries; the core leaves the
    others 0 as well)."""
    core = cdsm.Robot.packaged(name)
    view = ref.load_robot(ROBOTS / f"{name}.toml").planar
    for field in ("link_before", "link_after", "thickness", "joint_limits", "lower_tension", "mass", "gravity",
                  "holes"):
        np.testing.assert_array_equal(np.asarray(getattr(core, field)), getattr(view, field), err_msg=field)
    robot = ref.load_robot(ROBOTS / f"{name}.toml")
    assert (robot.youngs_modulus, robot.diameter, robot.routing_length) == (
        core.youngs_modulus, core.cable_diameter, core.routing_length)


def test_explicit_planar_holes_equal_hole_height(ref):
    """``upper_holes`` / ``lower_holes`` at ``(0, +-h)`` are the ``hole_height`` arm;
    an explicit hole off its line reads through to the planar view."""
    text = robot_toml(PAPER_LINKAGES[:2])
    a = ref.read_robot(text)
    lines = []
    for i, lk in enumerate(PAPER_LINKAGES[:2]):
        pts = [[0.0, lk.hole_height]] * (2 * i + 3)
        low = [[0.0, -lk.hole_height]] * (2 * i + 3)
        if i == 1:
            pts[3] = [1e-3, 0.02]  # face a of disk 2
        lines.append((f"hole_height = {lk.hole_height!r}", f"upper_holes = {pts!r}\nlower_holes = {low!r}"))
    for old, new in lines:
        text = text.replace(old, new, 1)
    b = ref.read_robot(text)
    holes = a.planar.holes.copy()
    holes[2, 2, 0] = [1e-3, 0.02]
    np.testing.assert_array_equal(b.planar.holes, holes)
    assert b.holes[2][3].tolist() == [1e-3, 0.02, 0.0]


def test_the_planar_view_round_trips(ref):
    """``with_planar_holes`` of a planar view's holes is the arm itself; a spatial
    arm has no planar view and says why."""
    r = reference_robot(PAPER_LINKAGES, gravity=[0.0, -G0])
    holes = r.planar.holes
    back = r.with_planar_holes(holes)
    for h, g in zip(back.holes, r.holes):
        np.testing.assert_array_equal(h, g)
    np.testing.assert_array_equal(r.planar.gravity, [0.0, -G0])
    with pytest.raises(ValueError, match="not a planar arm: one joint per disk"):
        ref.load_robot(ROBOTS / "two_universal.toml").planar


BASE = robot_toml(PAPER_LINKAGES[:2])


def _edit(old, new):
    assert old in BASE, old
    return BASE.replace(old, new, 1)


@pytest.mark.parametrize("text, field", [
    (_edit("link_before = 0.033", "link_before = -0.033"), "linkage[1].link_before"),
    (_edit("thickness = 0.01", "thickness = nan"), "linkage[1].thickness"),
    (_edit("hole_height = 0.028", "hole_height = 0.0"), "linkage[2].hole_height"),
    (_edit("hole_height = 0.028", "upper_holes = [[0.0, 0.028]]"), "linkage[2].hole_height"),
    (_edit("mass = 0.03", "mass = -0.03"), "linkage[1].mass"),
    (_edit("lower_tension = 0.1", "lower_tension = -0.1"), "linkage[1].lower_tension"),
    (_edit("joint_limits = [", "joint_limits = [0.7, "), "linkage[1].joint_limits"),
    (_edit("n = 2", "n = 3"), "n"),
    (_edit("n = 2", "n = 2\ngravity = [0.0, -9.8, 0.0]"), "gravity"),
    (_edit("mass = 0.03", "mass = 0.03\nradius = 0.03"), "linkage[1].radius"),
    (_edit("n = 2", "n = 2\n[base]\nradius = 0.03\n"), "kind"),
    (_edit("n = 2", 'kind = "planer"\nn = 2'), "kind"),
])
def test_planar_file_errors_name_the_field(ref, text, field):
    with pytest.raises(ValueError, match="^" + re.escape(field)):
        ref.read_robot(text)
