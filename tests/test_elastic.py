"""Elastic arms in the Rust core (``rust/elastic.rs``, ``Robot.equilibrium``;
``docs/model.md``, "Elastic arms"): the robot-file fields read by the one reader, the
frictionless equilibrium (the minimum of the potential) and its derivatives by the
implicit function theorem.  Checked against the independent NumPy reference
(``cdsm.reference.elastic``) on OpenCR's FTDCR v4 (60 joints, 9 tendons), a small mixed
spatial arm and a sprung planar arm, and against closed forms (constant curvature,
Euler-Bernoulli).  SI units."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import cdsm
from conftest import ROOT
from cdsm import CdsmInputError
from elastic_cases import BAD_FIELDS, EI, FTDCR_ROWS, OPENCR, TENDON, mixed_text, planar_text, rod_toml
from cdsm.reference import elastic, position_lengths, read_robot
from cdsm.robot import packaged_robots

FTDCR_TEXT = (OPENCR / "ftdcr_v4.toml").read_text(encoding="utf-8")
#: The recorded FTDCR rows of elastic_cases (slack tendons, far bends), ``(5, 9)`` m.
ROWS = np.array(list(FTDCR_ROWS.values()))


def zero_based(field: str) -> str:
    """A field as the core names it: array elements from 0 (the reference's from 1)."""
    return re.sub(r"\[(\d+)\]", lambda m: f"[{int(m.group(1)) - 1}]", field)


def both(text: str):
    return cdsm.Robot.from_toml_str(text), read_robot(text)


def assert_parity(core, ref, theta_atol=1e-12):
    """The core's :class:`Equilibrium` against the reference's answer dict (measured:
    angles to 3e-15 rad, tensions to 1e-14 of the largest)."""
    assert core.converged.all() and ref["converged"].all(), (core.reason, ref["reason"])
    np.testing.assert_allclose(core.theta, ref["theta"], rtol=0, atol=theta_atol)
    np.testing.assert_array_equal(core.slack, ref["slack"])
    np.testing.assert_array_equal(core.capped, ref["capped"])
    scale = np.abs(ref["tension"]).max()
    np.testing.assert_allclose(core.tension, ref["tension"], rtol=0, atol=1e-10 * scale)


# --------------------------------------------------------------------------
# Parity with the NumPy reference
# --------------------------------------------------------------------------
def test_ftdcr_equilibria_match_the_reference():
    """FTDCR v4 on five recorded rows (slack tendons, far bends): the same minimum, the
    same tensions and slack flags; warm-started along the rows, the same answers."""
    robot, ref = both(FTDCR_TEXT)
    assert robot.n == 60 and robot.displacement_cables == list(range(9))
    core = robot.equilibrium(displacements=ROWS)
    want = elastic.equilibrium(ref, displacements=ROWS)
    assert_parity(core, want)
    assert core.slack[0].sum() == 8 and core.tension[0, 2] > 1.0  # one tendon pulled, eight slack
    seq = robot.equilibrium(displacements=ROWS, sequence=True)
    assert_parity(seq, want)


def test_mixed_arm_equilibrium_matches_the_reference():
    """Every term of the potential (gravity, a tip force, position, force and displacement
    cables, a cap): the structure's dense fallback (gravity makes the loads' curvature
    dense)."""
    text = mixed_text()
    robot, ref = both(text)
    lengths = position_lengths(ref, np.full((2, ref.n), 0.02)) + np.array([[1e-4], [3e-4]])
    d = np.array([[0.003, -0.001, 0.002], [0.004, 0.002, -0.001]])
    w = [0.05, 0.1, -0.2, 0, 0, 0]
    core = robot.equilibrium(lengths=lengths, displacements=d, tip_wrench=w)
    want = elastic.equilibrium(ref, lengths=lengths, displacements=d, tip_wrench=w)
    assert_parity(core, want)
    assert not core.slack[0, 0] and 0.0 < core.tension[0, 0] < 4.0
    np.testing.assert_allclose(core.energy, want["U"], rtol=1e-12)


def test_planar_sprung_arm_matches_the_reference():
    """A planar arm through the same chain: springs with rest angles, gravity, lower
    force cables, a tip wrench with a moment."""
    robot, ref = both(planar_text())
    assert robot.kind == "planar"
    np.testing.assert_array_equal(robot.joint_stiffness, [0.05, 0.03, 0.02])
    lengths = position_lengths(ref, np.array([[0.1, -0.2, 0.3], [0.0, 0.1, 0.0]])) + 2e-5
    w = [0.02, -0.05, 0.001]
    core = robot.equilibrium(lengths=lengths, tip_wrench=w)
    want = elastic.equilibrium(ref, lengths=lengths, tip_wrench=w)
    assert_parity(core, want)


def test_derivatives_match_the_reference_and_differences():
    """``dq/dp = -H^-1 dg/dp`` for lengths, displacements and the wrench, the task's and
    tensions' derivatives: the reference's, and central differences of the core's own
    equilibria; one-sided (the slack side, zero) at rest with no pretension."""
    text = mixed_text()
    robot, ref = both(text)
    lengths = position_lengths(ref, np.full((1, ref.n), 0.02)) + 1e-4
    d = np.array([[0.003, 0.001, 0.002]])
    w = [0.05, 0.1, -0.2, 0, 0, 0]
    sol = robot.equilibrium(lengths=lengths, displacements=d, tip_wrench=w)
    der = robot.equilibrium_derivatives(sol.theta, lengths=lengths, displacements=d, tip_wrench=w)
    want = elastic.derivatives(ref, sol.theta, lengths, d, w)
    assert der.definite.all()
    for key in ("theta", "task", "tension"):
        for p in ("lengths", "displacements", "wrench"):
            got, ref_v = getattr(der, f"{key}_{p}"), want[f"{key}_{p}"]
            np.testing.assert_allclose(got, ref_v, rtol=0, atol=1e-11 * np.abs(ref_v).max(), err_msg=f"{key}_{p}")
    h = 1e-7
    for c in range(3):
        e = np.zeros((1, 3))
        e[0, c] = h
        up = robot.equilibrium(lengths=lengths, displacements=d + e, tip_wrench=w, seed=sol.theta).theta
        dn = robot.equilibrium(lengths=lengths, displacements=d - e, tip_wrench=w, seed=sol.theta).theta
        fd = (up - dn)[0] / (2 * h)
        np.testing.assert_allclose(der.theta_displacements[0, :, c], fd, atol=1e-6 * np.abs(fd).max())
    rest = cdsm.Robot.from_toml_str(re.sub(r"pretension = [0-9.e-]+", "pretension = 0.0", FTDCR_TEXT))
    at_rest = rest.equilibrium(displacements=np.zeros(9))
    assert at_rest.converged and at_rest.slack.all()
    np.testing.assert_array_equal(at_rest.theta, 0.0)
    one = rest.equilibrium_derivatives(at_rest.theta, displacements=np.zeros(9))
    np.testing.assert_array_equal(one.theta_displacements, 0.0)  # the slack side
    paid = rest.equilibrium(displacements=np.full(9, -1e-4))
    np.testing.assert_array_equal(paid.theta, 0.0)  # paying out confirms it


# --------------------------------------------------------------------------
# Closed forms, through the product
# --------------------------------------------------------------------------
def test_one_segment_one_tendon_is_constant_curvature_at_small_angles():
    """One segment of 20 stations pulled by one tendon at ``r`` through ``k_a``: ``phi =
    k_a d r L / (E I + k_a r^2 L)``, ``T = k_a (d - r phi)``, equal joint angles, the tip on
    the arc; relative errors second order in ``phi``."""
    r, ka, L, links = 0.0045, 7000.0, 0.1, 20
    cable = (f'[[cables]]\nend = {links}\nmode = "displacement"\nradius = {r!r}\nangle = 0.0\n'
             f"stiffness = {ka!r}\n")
    robot = cdsm.Robot.from_toml_str(rod_toml(links, L, cable))
    np.testing.assert_allclose(robot.joint_stiffness, EI / (L / links), rtol=1e-15)
    gain = ka * r * L / (EI + ka * r**2 * L)
    errors = []
    for phi_target in (2e-3, 1e-3):
        d = phi_target / gain
        sol = robot.equilibrium(displacements=[d])
        assert sol.converged and not sol.slack.any()
        phi = sol.theta.sum()
        kappa = phi_target / L
        tip = robot.fk(sol.theta)
        err = dict(phi=abs(phi / phi_target - 1.0), T=abs(sol.tension[0] / (ka * (d - r * phi_target)) - 1.0),
                   uniform=np.abs(sol.theta / sol.theta.mean() - 1.0).max(),
                   y=abs(tip[1] / ((1.0 - math.cos(phi_target)) / kappa) - 1.0))
        assert max(err.values()) < 0.05 * phi_target, err
        errors.append(err)
    for key in ("phi", "T"):
        assert 1.6 < errors[0][key] / errors[1][key] < 2.4, (key, errors)


def test_cantilever_converges_to_euler_bernoulli():
    """A cantilever of ``N`` links under a small tip force: ``F L^3 / (3 E I)`` times ``1 -
    1/(4 N^2)`` (second order in ``1/N``), for N = 4, 8, 16, 32."""
    L, F = 0.1, 1e-4
    delta = F * L**3 / (3.0 * EI)
    Ns = np.array([4, 8, 16, 32])
    rel = []
    for N in Ns:
        robot = cdsm.Robot.from_toml_str(rod_toml(int(N), L))
        sol = robot.equilibrium(displacements=[0.0], tip_wrench=[0, F, 0, 0, 0, 0])
        assert sol.converged and sol.slack.all()
        rel.append(robot.fk(sol.theta)[1] / delta - 1.0)
    rel = np.array(rel)
    order = -np.diff(np.log(np.abs(rel))) / np.diff(np.log(Ns))
    np.testing.assert_allclose(order, 2.0, atol=0.01)
    np.testing.assert_allclose(rel, -1.0 / (4.0 * Ns**2), rtol=0, atol=1e-7)


# --------------------------------------------------------------------------
# The robot file
# --------------------------------------------------------------------------
def test_ftdcr_reads_its_backbone_and_tendons():
    """``k = E I / l`` from the backbone (0.39480 N m/rad), nine displacement tendons with
    the actuator's stiffness, the fitted pretension and the cap; ``to_toml`` writes them
    (per joint) and reads back the same arm."""
    robot, ref = both(FTDCR_TEXT)
    np.testing.assert_allclose(robot.joint_stiffness, ref.joint_stiffness, rtol=1e-15)
    np.testing.assert_allclose(robot.joint_stiffness, 0.39480, rtol=1e-4)
    cab = robot.elastic_cables()
    np.testing.assert_array_equal(cab["stiffness"], ref.cable_stiffness)
    np.testing.assert_array_equal(cab["pretension"], ref.pretension)
    np.testing.assert_array_equal(cab["max_tension"], ref.max_tension)
    np.testing.assert_allclose(cab["rest_length"], elastic.rest_lengths(ref), rtol=1e-14)
    np.testing.assert_allclose(cab["series_stiffness"], elastic.series_stiffness(ref), rtol=1e-14)
    assert robot.cable_modes == ["displacement"] * 9 and robot.is_elastic
    again = cdsm.Robot.from_toml_str(robot.to_toml())
    np.testing.assert_array_equal(again.joint_stiffness, robot.joint_stiffness)
    assert again.to_toml() == robot.to_toml()
    planar = cdsm.Robot.from_toml_str(planar_text())
    back = cdsm.Robot.from_toml_str(planar.to_toml())
    np.testing.assert_array_equal(back.joint_stiffness, planar.joint_stiffness)
    np.testing.assert_array_equal(back.rest_angles, planar.rest_angles)


def test_an_arm_without_springs_is_unchanged():
    """Every packaged robot reads as a rigid arm (free joints, no displacement cables) and
    its rigid calls still run; an elastic arm refuses them, naming the call."""
    for name in packaged_robots():
        robot = cdsm.Robot.packaged(name)
        assert not robot.is_elastic and robot.displacement_cables == []
        np.testing.assert_array_equal(robot.joint_stiffness, 0.0)
        assert "stiffness" not in robot.to_toml() and "displacement" not in robot.to_toml()
    paper = cdsm.Robot.paper()
    assert paper.solve_cables(paper.upper_lengths(np.full(3, 0.1))).converged
    ftdcr = cdsm.Robot.from_toml_str(FTDCR_TEXT)
    with pytest.raises(CdsmInputError, match="tensions.*rigid arms only"):
        ftdcr.tensions(np.zeros(60))


@pytest.mark.parametrize("edit, field", BAD_FIELDS)
def test_bad_elastic_fields_are_refused_naming_the_field(edit, field):
    """Each bad value of the elastic fields is refused by the core's reader with an error
    naming the field (the reference refuses the same edits)."""
    text = rod_toml(3, 0.03, TENDON)
    cdsm.Robot.from_toml_str(text)  # the unedited file is good
    name, _, message = field.partition(": ")  # the reference's "field: problem"
    pattern = "field `" + re.escape(zero_based(name)) + ("`: " + re.escape(message) if message else "")
    with pytest.raises(CdsmInputError, match=pattern):
        cdsm.Robot.from_toml_str(edit(text))
    with pytest.raises(ValueError):
        read_robot(edit(text))


def test_planar_springs_are_read_and_refused():
    """The planar shorthand's ``stiffness`` and ``rest_angle`` per ``[[linkage]]``."""
    base = (ROOT / "python" / "cdsm" / "robots" / "paper.toml").read_text(encoding="utf-8")
    first = base.index("[[linkage]]") + len("[[linkage]]\n")
    good = base[:first] + "stiffness = 0.5\nrest_angle = 0.02\n" + base[first:]
    robot = cdsm.Robot.from_toml_str(good)
    assert robot.joint_stiffness[0] == 0.5 and robot.rest_angles[0] == 0.02
    np.testing.assert_array_equal(robot.joint_stiffness[1:], 0.0)
    for old, new, field in (("stiffness = 0.5", "stiffness = -0.5", "linkage[0].stiffness"),
                            ("rest_angle = 0.02", "rest_angle = nan", "linkage[0].rest_angle"),
                            ("rest_angle = 0.02", 'rest_angle = "x"', "linkage[0].rest_angle")):
        with pytest.raises(CdsmInputError, match=re.escape(field)):
            cdsm.Robot.from_toml_str(good.replace(old, new))


def test_bad_commands_are_refused_naming_the_argument():
    robot = cdsm.Robot.from_toml_str(mixed_text())
    L = np.array([0.05])
    with pytest.raises(CdsmInputError, match="displacements"):
        robot.equilibrium(lengths=L)
    with pytest.raises(CdsmInputError, match="displacements"):
        robot.equilibrium(lengths=L, displacements=[0.0, np.nan, 0.0])
    with pytest.raises(CdsmInputError, match="tip_wrench.*moment"):
        robot.equilibrium(lengths=L, displacements=np.zeros(3), tip_wrench=[0, 0, 0, 0, 0, 0.1])
    with pytest.raises(CdsmInputError, match="lengths.*> 0"):
        robot.equilibrium(lengths=[-1.0], displacements=np.zeros(3))
    with pytest.raises(CdsmInputError, match="seed"):
        robot.equilibrium(lengths=L, displacements=np.zeros(3), seed=np.zeros(5))


def test_a_sprung_planar_arm_keeps_its_springs_through_its_variants():
    """``with_cable``, ``with_holes`` and ``with_loads`` of a sprung planar arm
    change only what they name: the joint springs and rest angles stay (the
    binding rebuilt a planar arm from its planar description, which has no
    springs, and so returned a rigid arm)."""
    robot = cdsm.Robot.from_toml_str(planar_text())
    assert robot.is_elastic
    variants = {"with_cable": robot.with_cable(youngs_modulus=2.5e9),
                "with_holes": robot.with_holes(robot.holes * 1.01),
                "with_loads": robot.with_loads(lower_tension=robot.lower_tension * 2.0)}
    for name, other in variants.items():
        assert other.is_elastic, name
        np.testing.assert_array_equal(other.joint_stiffness, robot.joint_stiffness, err_msg=name)
        np.testing.assert_array_equal(other.rest_angles, robot.rest_angles, err_msg=name)
    assert variants["with_cable"].youngs_modulus == 2.5e9
    np.testing.assert_array_equal(variants["with_holes"].holes, robot.holes * 1.01)
    np.testing.assert_array_equal(variants["with_loads"].lower_tension, robot.lower_tension * 2.0)
