"""The NumPy reference of elastic arms (``cdsm.reference.elastic``; ``docs/model.md``,
"Elastic arms"): joint springs from a backbone rod, tendons commanded in
displacement through a series stiffness, unilateral, and the forward statics as the
minimum of the potential energy.  Checked against what does not come from the code:
constant curvature and Euler-Bernoulli in closed form, the potential's own finite
differences, and OpenCR-MuJoCo's model of the FTDCR v4 settled by MuJoCo.  SI units."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from conftest import ROOT
from cdsm.reference import elastic, fk, load_robot, position_lengths, read_robot
from elastic_cases import (BAD_FIELDS, EI, FTDCR_ROWS, OPENCR, TENDON, mixed_text,
                           rod_toml)


# --------------------------------------------------------------------------
# Closed forms
# --------------------------------------------------------------------------
def test_one_segment_one_tendon_is_constant_curvature_at_small_angles():
    """One segment (20 stations, one bending joint each) pulled by one tendon at ``r``
    through the actuator stiffness ``k_a``: the tendon's moment ``T r`` is the same at
    every station (small angles), so the segment bends at constant curvature ``kappa =
    T r / (E I)``, its tip angle ``phi = kappa L`` and ``T = k_a (d - r phi)`` (the tendon
    shortens by ``r phi``): ``phi = k_a d r L / (E I + k_a r^2 L)``; the tip lies on the arc,
    ``y = (1 - cos phi) / kappa``.  The model's departure is second order: relative
    errors that shrink in proportion to ``phi``."""
    r, ka, L, links = 0.0045, 7000.0, 0.1, 20
    cable = (f'[[cables]]\nend = {links}\nmode = "displacement"\nradius = {r!r}\nangle = 0.0\n'
             f"stiffness = {ka!r}\n")
    robot = read_robot(rod_toml(links, L, cable))
    np.testing.assert_allclose(robot.joint_stiffness, EI / (L / links), rtol=1e-15)
    gain = ka * r * L / (EI + ka * r**2 * L)  # rad per m of pull
    errors = []
    for phi_target in (2e-3, 1e-3):
        d = phi_target / gain
        sol = elastic.equilibrium(robot, displacements=[[d]])
        assert sol["converged"].all() and not sol["slack"].any()
        theta = sol["theta"][0]
        phi = theta.sum()
        T = ka * (d - r * phi_target)
        kappa = phi_target / L
        tip = fk(robot, sol["theta"])[0]
        err = dict(phi=abs(phi / phi_target - 1.0), T=abs(sol["tension"][0, 0] / T - 1.0),
                   uniform=np.abs(theta / theta.mean() - 1.0).max(),
                   y=abs(tip[1] / ((1.0 - math.cos(phi_target)) / kappa) - 1.0),
                   x=abs(tip[0] - math.sin(phi_target) / kappa) / L)
        assert max(err.values()) < 0.05 * phi_target, err  # measured: 0.018 phi (T)
        errors.append(err)
    # second order: halving the angle halves the relative error of phi and T
    for key in ("phi", "T"):
        assert 1.6 < errors[0][key] / errors[1][key] < 2.4, (key, errors)


def tip_deflection(links: int, F: float, L: float = 0.1) -> float:
    """The reference's tip deflection (m) of the rod of :func:`rod_toml` under the tip force
    ``F`` (N) along ``y``."""
    sol = elastic.equilibrium(read_robot(rod_toml(links, L)), displacements=[[0.0]], tip_wrench=[0, F, 0, 0, 0, 0])
    assert sol["converged"].all() and sol["slack"].all()  # the central cable carries nothing
    return float(fk(read_robot(rod_toml(links, L)), sol["theta"])[0, 1])


def test_cantilever_under_a_tip_load_converges_to_euler_bernoulli():
    """A cantilever of ``N`` links under a small tip force tends to Euler-Bernoulli's
    ``delta = F L^3 / (3 E I)`` as ``N`` grows, at the second order of OpenCR's layout
    (joints at ``(i - 1/2) l``): the lumped rod's ``sum_i (L - x_i)^2 l / (E I)`` is
    ``delta (1 - 1 / (4 N^2))``.  The order is measured from N = 4, 8, 16, 32."""
    L, F = 0.1, 1e-4
    delta = F * L**3 / (3.0 * EI)
    Ns = np.array([4, 8, 16, 32])
    rel = np.array([tip_deflection(int(N), F, L) / delta - 1.0 for N in Ns])
    assert np.all(rel < 0.0)  # a lumped rod is stiffer
    order = -np.diff(np.log(np.abs(rel))) / np.diff(np.log(Ns))
    np.testing.assert_allclose(order, 2.0, atol=0.01)
    # and the constant: the lumped sum's -1/(4 N^2), up to the load's own nonlinearity
    np.testing.assert_allclose(rel, -1.0 / (4.0 * Ns**2), rtol=0, atol=1e-7)  # measured: 1.9e-8


# --------------------------------------------------------------------------
# The energy minimum
# --------------------------------------------------------------------------
def mixed_arm():
    """The reference's robot of :func:`elastic_cases.mixed_text`: every term of the potential."""
    return read_robot(mixed_text())


def ftdcr():
    return load_robot(OPENCR / "ftdcr_v4.toml")


def finite_differences(f, x, h):
    """Central differences of ``f (n,) -> (k,)`` at ``x``: ``(k, n)``."""
    cols = []
    for j in range(x.size):
        e = np.zeros(x.size)
        e[j] = h
        cols.append((f(x + e) - f(x - e)) / (2.0 * h))
    return np.array(cols).T


@pytest.mark.parametrize("case", ["mixed", "ftdcr"])
def test_the_equilibrium_is_a_minimum_of_the_potential(case):
    """At the equilibrium the reference returns: the potential's gradient, by central
    differences of ``U`` alone, is zero (relative to the springs' moments), the Hessian
    by differences of the gradient is the analytic one and positive definite, and no
    nearby configuration has a lower ``U``."""
    if case == "mixed":
        robot = mixed_arm()
        cmd = dict(lengths=None, displacements=[[0.003, -0.001, 0.002]], tip_wrench=[0.05, 0.1, -0.2, 0, 0, 0])
        cmd["lengths"] = position_lengths(robot, np.full((1, robot.n), 0.02)) + 1e-4
    else:
        robot = ftdcr()
        cmd = dict(displacements=[FTDCR_ROWS[732]])
    sol = elastic.equilibrium(robot, **cmd)
    assert sol["converged"].all(), sol["reason"]
    q = sol["theta"][0]
    springs = elastic.tendon_springs(robot, cmd.get("lengths"), cmd["displacements"])
    wrench = cmd.get("tip_wrench")

    def ev(x, order):
        return elastic.evaluate(robot, springs, x[None], wrench, order=order)

    at = ev(q, 2)
    scale = np.abs(robot.joint_stiffness * (q - robot.rest_angle)).max()  # N m
    g_fd = finite_differences(lambda x: ev(x, 0)["U"], q, 1e-6)[0]
    assert np.abs(g_fd).max() < 1e-6 * scale, np.abs(g_fd).max() / scale
    assert np.abs(at["g"][0]).max() < 1e-10 * scale
    H_fd = finite_differences(lambda x: ev(x, 1)["g"][0], q, 1e-7)
    H = at["H"][0]
    np.testing.assert_allclose(H_fd, H, atol=1e-6 * np.abs(H).max())
    assert np.linalg.eigvalsh(H).min() > 0.0
    rng = np.random.default_rng(3)
    U0 = at["U"][0]
    for _ in range(20):
        assert ev(q + 1e-4 * rng.standard_normal(q.size), 0)["U"][0] > U0
    if case == "mixed":  # every part of the Hessian is present
        assert np.abs(at["Q"]).max() > 0.0 and (at["c"][0] > 0.0).sum() >= 2
        assert not sol["slack"][0, 0] and 0.0 < sol["tension"][0, 0] < 4.0


def test_a_slack_tendon_carries_nothing():
    """A pulled FTDCR tendon with the eight others paid out to -10 mm: those eight are
    slack (``sigma <= 0``, tension exactly 0), the pulled one taut; paying them out further
    does not move the arm at all; and an arm at rest (``d = 0``, no pretension) is straight
    with every tendon slack."""
    robot = ftdcr()
    d = np.array(FTDCR_ROWS[41])
    sol = elastic.equilibrium(robot, displacements=[d])
    assert sol["converged"].all()
    slack = d < -0.005
    np.testing.assert_array_equal(sol["slack"][0], slack)
    np.testing.assert_array_equal(sol["tension"][0, slack], 0.0)
    assert sol["tension"][0, 2] > 1.0
    further = elastic.equilibrium(robot, displacements=[np.where(slack, d - 0.02, d)], seed=sol["theta"])
    np.testing.assert_array_equal(further["slack"], sol["slack"])
    np.testing.assert_allclose(further["theta"], sol["theta"], rtol=0, atol=1e-14)
    text = (OPENCR / "ftdcr_v4.toml").read_text(encoding="utf-8")
    rest = read_robot(re.sub(r"pretension = [0-9.e-]+", "pretension = 0.0", text))
    at_rest = elastic.equilibrium(rest, displacements=np.zeros((1, 9)))
    assert at_rest["converged"].all() and at_rest["slack"].all()
    np.testing.assert_array_equal(at_rest["theta"], 0.0)
    np.testing.assert_array_equal(at_rest["tension"], 0.0)


def test_derivatives_by_the_implicit_function_theorem():
    """``dq/dd = -H^-1 dg/dd`` against central differences of the equilibrium (a taut
    configuration), and one-sided at a slack transition: at rest with no pretension every
    tendon is at ``sigma = 0``; the reported derivative is the slack side's (zero), which
    paying out confirms, while pulling moves the arm."""
    robot = mixed_arm()
    lengths = position_lengths(robot, np.full((1, robot.n), 0.02)) + 1e-4
    d = np.array([[0.003, 0.001, 0.002]])
    sol = elastic.equilibrium(robot, lengths=lengths, displacements=d)
    assert sol["converged"].all() and not sol["slack"][0, :3].any()
    der = elastic.derivatives(robot, sol["theta"], lengths, d)
    assert der["definite"].all()
    h = 1e-7
    for c in range(3):
        e = np.zeros((1, 3))
        e[0, c] = h
        up = elastic.equilibrium(robot, lengths=lengths, displacements=d + e, seed=sol["theta"])["theta"]
        dn = elastic.equilibrium(robot, lengths=lengths, displacements=d - e, seed=sol["theta"])["theta"]
        fd = (up - dn)[0] / (2 * h)
        np.testing.assert_allclose(der["theta_displacements"][0, :, c], fd, atol=1e-6 * np.abs(fd).max())

    text = (OPENCR / "ftdcr_v4.toml").read_text(encoding="utf-8")
    rest = read_robot(re.sub(r"pretension = [0-9.e-]+", "pretension = 0.0", text))
    zero = np.zeros((1, 9))
    der = elastic.derivatives(rest, np.zeros((1, 60)), displacements=zero)
    np.testing.assert_array_equal(der["theta_displacements"], 0.0)
    e = np.zeros((1, 9))
    e[0, 0] = 1e-5
    out = elastic.equilibrium(rest, displacements=zero - e)["theta"]
    pull = elastic.equilibrium(rest, displacements=zero + e)["theta"]
    np.testing.assert_array_equal(out, 0.0)
    assert np.abs(pull).max() > 1e-5


def test_the_structured_step_is_the_newton_step():
    """Woodbury over the 2 x 2 station blocks and the taut tendons (``structured_step``)
    solves the same system as the dense Hessian, on the FTDCR's configurations along a
    Newton descent (``Q = 0``: no gravity); with gravity it refuses (``Q`` is dense)."""
    robot = ftdcr()
    d = np.array([FTDCR_ROWS[732]])
    springs = elastic.tendon_springs(robot, displacements=d)
    sol = elastic.equilibrium(robot, displacements=d)
    for t in (0.3, 0.7, 0.95):
        parts = elastic.evaluate(robot, springs, t * sol["theta"])
        assert (parts["c"][0] > 0.0).sum() >= 3
        dense = np.linalg.solve(parts["H"][0], -parts["g"][0])
        np.testing.assert_allclose(elastic.structured_step(robot, parts), dense, rtol=0,
                                   atol=1e-10 * np.abs(dense).max())
    arm = mixed_arm()
    lengths = position_lengths(arm, np.full((1, arm.n), 0.02))
    parts = elastic.evaluate(arm, elastic.tendon_springs(arm, lengths, np.zeros((1, 3))), np.full((1, arm.n), 0.02))
    with pytest.raises(ValueError, match="^structured_step: the loads' curvature Q"):
        elastic.structured_step(arm, parts)


def test_a_rigid_arm_is_the_stiff_limit():
    """The paper's arm (no springs, as many position cables as joints, weights on the
    force cables): at the commanded lengths that hold ``theta0`` with the cables
    stretched under the balance's tensions (``statics.elastic_lengths``, today's elastic
    cable model), the potential's minimum is ``theta0``; the rigid cable solve of the same
    lengths is off by ``O(1 / (E A))``: ten times stiffer cables, ten times closer."""
    from cdsm.reference import Robot, solve_cables, tensions
    from cdsm.reference.statics import elastic_lengths
    import dataclasses
    robot = Robot.paper()
    theta0 = np.array([[0.1, -0.05, 0.08]])
    T = tensions(robot, theta0)
    assert np.all(T > 0.0)
    gaps = []
    for E in (1.0, 10.0, 100.0):
        arm = dataclasses.replace(robot, youngs_modulus=E * robot.youngs_modulus)
        lengths = elastic_lengths(arm, theta0, T, arm.youngs_modulus, arm.diameter, arm.routing_length)
        sol = elastic.equilibrium(arm, lengths=lengths)
        assert sol["converged"].all() and not sol["slack"][0, [0, 2, 4]].any()
        np.testing.assert_allclose(sol["theta"], theta0, rtol=0, atol=1e-14)
        np.testing.assert_allclose(sol["tension"][0, [0, 2, 4]], T[0], rtol=1e-9)  # T = k (L - l): eps / strain
        gaps.append(np.abs(solve_cables(arm, lengths)["theta"] - theta0).max())
    np.testing.assert_allclose(np.array(gaps[:-1]) / np.array(gaps[1:]), 10.0, rtol=1e-3)


def test_joint_friction_zero_is_the_frictionless_sequence():
    """Coulomb friction at the joints of 0 N m is the frictionless equilibrium warm-started
    along the sequence; with friction every joint that sticks is inside its band
    (``|dU/dq_j| <= tau_c``) and every joint that slips is at its edge."""
    robot = mixed_arm()
    lengths = np.tile(position_lengths(robot, np.full((1, robot.n), 0.02)), (4, 1))
    d = np.array([[0.002, 0.0, 0.0], [0.004, -0.001, 0.001], [0.001, 0.002, 0.0], [0.0, 0.0, 0.0]])
    free = elastic.equilibrium_sequence(robot, lengths=lengths, displacements=d)
    zero = elastic.friction_sequence(robot, 0.0, lengths=lengths, displacements=d)
    assert free["converged"].all() and zero["converged"].all()
    np.testing.assert_allclose(zero["theta"], free["theta"], rtol=0, atol=1e-12)
    tc = 2e-3
    fr = elastic.friction_sequence(robot, tc, lengths=lengths, displacements=d)
    assert fr["converged"].all() and fr["stuck"].any() and (~fr["stuck"]).any()
    springs = elastic.tendon_springs(robot, lengths, d)
    g = elastic.evaluate(robot, springs, fr["theta"], order=1)["g"]
    assert np.all(np.abs(g[fr["stuck"]]) <= tc * (1 + 1e-9))
    np.testing.assert_allclose(np.abs(g[~fr["stuck"]]), tc, rtol=1e-6)


# --------------------------------------------------------------------------
# OpenCR's MuJoCo model of the FTDCR v4
# --------------------------------------------------------------------------
def test_ftdcr_v4_against_opencr_mujoco_settled():
    """OpenCR-MuJoCo's own model of the FTDCR v4 (``tests/data/opencr``), settled by MuJoCo
    (its dynamics stepped until the tip moves less than 1e-12 m in 0.5 s) on five train
    rows, against the reference's equilibrium of ``ftdcr_v4.toml``: the tip site and the
    nine tendon tensions (MuJoCo's position actuators, ``T = clip(kp (len - L0 + d) + P,
    0, 100)``), the slack tendons among them."""
    mujoco = pytest.importorskip("mujoco")
    model = mujoco.MjModel.from_xml_path(str(OPENCR / "ftdcr_v4_sysid.xml"))
    data = mujoco.MjData(model)
    act = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, f"seg_{s}_ten_{t}") for s in range(3)
           for t in range(3)]
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "force_site_tip")
    cmd = np.array(list(FTDCR_ROWS.values()))
    tips, tensions = [], []
    for d in cmd:
        mujoco.mj_resetDataKeyframe(model, data, 0)  # the keyframe "pretension": straight, ctrl at d = 0
        data.ctrl[act] = model.key_ctrl[0][act] - d  # OpenCR's servo: ctrl = L0 - P/kp - d
        prev = np.full(3, np.inf)
        for _ in range(40):
            for _ in range(250):
                mujoco.mj_step(model, data)
            if np.abs(data.site_xpos[site] - prev).max() < 1e-12:
                break
            prev = data.site_xpos[site].copy()
        else:
            pytest.fail("MuJoCo did not settle in 20 s")
        assert data.ncon == 0
        tips.append(data.site_xpos[site].copy())
        tensions.append(-data.actuator_force[act])
    tips, tensions = np.array(tips), np.array(tensions)
    robot = ftdcr()
    sol = elastic.equilibrium(robot, displacements=cmd)
    assert sol["converged"].all()
    tip = fk(robot, sol["theta"])[:, [1, 2, 0]]  # cdsm (x, y, z) = MuJoCo (z, x, y)
    assert np.abs(tips[:, :2]).max(1).min() > 0.02  # the arm bends (tip >= 20 mm off the axis)
    np.testing.assert_allclose(tip, tips, rtol=0, atol=1e-11)  # m; measured: 4e-15
    np.testing.assert_allclose(sol["tension"], tensions, rtol=0, atol=1e-9)  # N; measured: 1e-12
    np.testing.assert_array_equal(sol["slack"], tensions == 0.0)


# --------------------------------------------------------------------------
# The robot file
# --------------------------------------------------------------------------
def test_the_backbone_derives_ftdcr_stiffness_and_the_tendons_series_stiffness():
    """The FTDCR file's joints get ``N E I / L`` (OpenCR's 0.39480 N m/rad for 30 links of
    the 186.5 mm rod), its tendons ``k_s = 1 / (1/kp + L0/(E A))`` = kp (the inextensible
    cable); a finite cable adds its compliance in series."""
    robot = ftdcr()
    np.testing.assert_allclose(robot.joint_stiffness, 30 * EI / 0.1865, rtol=1e-15)
    assert abs(robot.joint_stiffness[0] - 0.39480470680166646) < 1e-15
    np.testing.assert_allclose(elastic.series_stiffness(robot), 7000.0, rtol=1e-15)
    np.testing.assert_allclose(elastic.rest_lengths(robot), np.repeat([0.06, 0.1225, 0.1865], 3), rtol=1e-14)
    text = (OPENCR / "ftdcr_v4.toml").read_text(encoding="utf-8").replace("youngs_modulus = 1e30",
                                                                          "youngs_modulus = 200e9")
    steel = read_robot(text)
    EA = 200e9 * math.pi * 0.0002**2 / 4
    np.testing.assert_allclose(elastic.series_stiffness(steel),
                               1.0 / (1.0 / 7000.0 + np.repeat([0.06, 0.1225, 0.1865], 3) / EA), rtol=1e-13)


def test_an_arm_without_springs_reads_as_before():
    """Every packaged robot file (none has springs or displacement cables) reads with free
    joints, rigid actuators and no pretension or cap."""
    for path in sorted((ROOT / "python" / "cdsm" / "robots").glob("*.toml")):
        robot = load_robot(path)
        np.testing.assert_array_equal(robot.joint_stiffness, 0.0)
        np.testing.assert_array_equal(robot.rest_angle, 0.0)
        assert np.all(np.isinf(robot.cable_stiffness)) and np.all(np.isinf(robot.max_tension))
        np.testing.assert_array_equal(robot.pretension, 0.0)


@pytest.mark.parametrize("edit, field", BAD_FIELDS)
def test_bad_elastic_fields_are_refused_naming_the_field(edit, field):
    """Each bad value of the elastic fields raises an error that starts with the field."""
    text = rod_toml(3, 0.03, TENDON)
    read_robot(text)  # the unedited file is good
    with pytest.raises(ValueError, match="^" + re.escape(field)):
        read_robot(edit(text))


def test_planar_springs_are_read_and_refused():
    """The planar shorthand's ``stiffness`` and ``rest_angle`` per ``[[linkage]]``."""
    base = (ROOT / "python" / "cdsm" / "robots" / "paper.toml").read_text(encoding="utf-8")
    first = base.index("[[linkage]]") + len("[[linkage]]\n")
    good = base[:first] + "stiffness = 0.5\nrest_angle = 0.02\n" + base[first:]
    robot = read_robot(good)
    assert robot.joint_stiffness[0] == 0.5 and robot.rest_angle[0] == 0.02
    np.testing.assert_array_equal(robot.joint_stiffness[1:], 0.0)
    with pytest.raises(ValueError, match=r"^linkage\[1\]\.stiffness"):
        read_robot(good.replace("stiffness = 0.5", "stiffness = -0.5"))
    with pytest.raises(ValueError, match=r"^linkage\[1\]\.rest_angle"):
        read_robot(good.replace("rest_angle = 0.02", "rest_angle = nan"))


def test_bad_commands_are_refused_naming_the_argument():
    """Commands of the wrong shape, not finite, or a position cable's length <= 0 (its
    Hooke law divides by it); a spatial tip moment (no potential)."""
    arm = mixed_arm()
    lengths = position_lengths(arm, np.full((1, arm.n), 0.02))
    d = np.zeros((1, 3))
    for kwargs, field in ((dict(lengths=lengths, displacements=np.zeros((1, 2))), "displacements"),
                          (dict(lengths=lengths, displacements=d + np.nan), "displacements"),
                          (dict(lengths=-lengths, displacements=d), "lengths"),
                          (dict(displacements=d), "lengths"),
                          (dict(lengths=lengths, displacements=d, tip_wrench=[0, 0, 0, 0, 0, 0.1]), "tip_wrench")):
        with pytest.raises(ValueError, match="^" + field):
            elastic.equilibrium(arm, **kwargs)
