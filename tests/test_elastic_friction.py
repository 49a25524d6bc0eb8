"""Friction in the holes of an elastic arm (``docs/model.md``, "Elastic arms in the
plant", friction): the plant's ``cable_friction`` on an elastic arm against the NumPy
reference, the frictionless limit, the capstan ratio of one tendon over one turn, the
hysteresis of a pull and release, the Jacobian, and ``mu`` recovered by a fit."""

from __future__ import annotations

import numpy as np
import pytest

import cdsm
from cdsm.calibration import plant
from cdsm.reference import elastic, read_robot
from cdsm.reference.kinematics import cable_points
from elastic_cases import rod_toml
from test_elastic_plant import EFFECTS_TWO, commands, fit_tips, two_segments


def one_tendon(mu_links: int = 1) -> str:
    """A rod of ``mu_links`` stations bending about ``z`` (springs from the backbone), one
    displacement tendon 4 mm off the axis (``y``) ending at the last via plate, an
    actuator of 3000 N/m with 1 N of pretension; an inextensible cable (E A huge)."""
    cables = (f'[[cables]]\nend = {mu_links}\nmode = "displacement"\nradius = 0.004\nangle = 0.0\n'
              "stiffness = 3000.0\npretension = 1.0\n")
    return rod_toml(mu_links, 0.03 * mu_links, cables)


def via_plates() -> str:
    """The two-segment arm of :func:`test_elastic_plant.two_segments` with its via plates
    of no thickness (a cable turns once at each plate, from gap to gap)."""
    return two_segments().replace("thickness = 0.001\n", "thickness = 0.0\n")


def pulls(robot, d):
    """Displacement commands ``d (N,)`` m on every commanded cable at the rest angles."""
    m = plant.commands(robot)
    return np.tile(robot.rest_angles, (len(d), 1)), -np.repeat(np.asarray(d, float)[:, None], m, axis=1)


def with_mu(robot, mu, effects=None):
    e = dict(effects or {})
    e["cable_friction"] = [mu]
    return plant.params(robot, e)


# --------------------------------------------------------------------------
# Layout, the frictionless limit
# --------------------------------------------------------------------------
def test_cable_friction_is_the_last_block_of_an_elastic_arm_fitted_when_named():
    robot = cdsm.Robot.from_toml_str(two_segments())
    lay = plant.layout(robot)
    assert list(lay)[-1] == "cable_friction" and lay["cable_friction"].stop == plant.size(robot)
    assert "cable_friction" not in plant.effects_of(robot)
    assert plant.check_effects(robot, ["cable_friction"]) == ["cable_friction"]
    lo, hi = plant.bounds(robot)
    assert lo[lay["cable_friction"]][0] == 0.0 and hi[lay["cable_friction"]][0] == 1.0


def test_mu_zero_is_the_frictionless_equilibrium_bit_for_bit():
    """``cable_friction = 0`` with every other effect: the settled angles are exactly those
    of ``Robot.equilibrium`` of the realised commands (no effects: the frictionless core);
    a tiny ``mu`` moves them by about ``mu`` times friction's lever (continuity of the
    friction path at 0)."""
    robot = cdsm.Robot.from_toml_str(via_plates())
    t, dl = commands(robot, 10, 2, lo=-2e-3, hi=2e-3)
    p0 = with_mu(robot, 0.0)
    theta, ok = plant.settle(robot, p0, t, dl)
    eq = robot.equilibrium(displacements=-dl, sequence=True)
    assert ok.all() and eq.converged.all()
    np.testing.assert_array_equal(theta, eq.theta)
    th_small, ok_small = plant.settle(robot, with_mu(robot, 1e-9), t, dl)
    assert ok_small.all()
    assert 0.0 < np.abs(th_small - theta).max() < 1e-9
    th_big, _ = plant.settle(robot, with_mu(robot, 0.2), t, dl)
    assert np.abs(th_big - theta).max() > 1e-4


# --------------------------------------------------------------------------
# Facts: the capstan ratio, the hysteresis loop
# --------------------------------------------------------------------------
@pytest.mark.parametrize("mu", [0.1, 0.3])
def test_one_tendon_over_one_turn_has_the_capstan_ratio(mu):
    """One tendon, one joint: the cable turns only at the base hole (the via plate is its
    anchor), by ``beta`` = the angle of the gap from ``x``.  Pulled from straight the
    cable slides toward the actuator there and ``T_0 = T_gap e^{mu beta}``; released by
    half, it slides distally and ``T_0 = T_gap e^{-mu beta}``.  ``T_0 = k_s (L - l) + P``
    from the actuator, ``T_gap`` from the spring's balance ``k q = -T_gap dL/dq`` (central
    differences of the reference's lengths), ``beta`` from the reference's hole points."""
    text = one_tendon()
    robot = cdsm.Robot.from_toml_str(text)
    ref = read_robot(text)
    d = np.array([1e-3, 2e-3, 1e-3])
    t, dl = pulls(robot, d)
    theta, ok = plant.settle(robot, with_mu(robot, mu), t, dl)
    assert ok.all()
    ks, pre, k = 3000.0, 1.0, ref.joint_stiffness[0]
    L0 = elastic.rest_lengths(ref)[0]
    for q, dj, sign in zip(theta, d, (1.0, 1.0, -1.0)):
        h = 1e-6
        dLdq = (robot.cable_lengths(q[None] + h)[0, 0] - robot.cable_lengths(q[None] - h)[0, 0]) / (2 * h)
        L = robot.cable_lengths(q[None])[0, 0]
        t0 = ks * (L - (L0 - dj)) + pre
        t_gap = -k * q[0] / dLdq
        P = cable_points(ref, q[None])[0][0]
        gap = P[1] - P[0]
        beta = np.arctan2(np.hypot(gap[1], gap[2]), gap[0])
        assert beta > 0.01
        np.testing.assert_allclose(t0 / t_gap, np.exp(sign * mu * beta), rtol=1e-8)


def loop_width(robot, mu):
    """The largest difference of the tip's ``y`` (m) at equal command between a pull from
    0 to 3 mm and the release back, in 0.25 mm steps."""
    up = np.arange(0.0, 3.0001e-3, 0.25e-3)
    d = np.concatenate([up, up[::-1][1:]])
    t, dl = pulls(robot, d)
    obs, ok = plant.predict(robot, with_mu(robot, mu), t, dl)
    assert ok.all()
    y = obs[:, 1]
    out, back = y[:len(up)], y[len(up) - 1:][::-1]
    return np.abs(out - back).max()


def test_a_pull_and_release_make_a_loop_that_widens_with_mu():
    robot = cdsm.Robot.from_toml_str(one_tendon(4))
    widths = [loop_width(robot, mu) for mu in (0.0, 0.05, 0.1, 0.2)]
    assert widths[0] < 1e-12
    assert widths[1] > 1e-5 and widths[1] < widths[2] < widths[3]


# --------------------------------------------------------------------------
# The reference, the Jacobian, a fit
# --------------------------------------------------------------------------
@pytest.mark.parametrize("text", [two_segments(), via_plates()], ids=["plates", "via_plates"])
def test_predictions_with_friction_match_the_reference(text):
    """Every effect of the elastic plant and ``mu = 0.15``, absolute and displacement rows:
    the reference's observations (its Newton on central differences of its own residual;
    measured: 2e-15 m)."""
    robot = cdsm.Robot.from_toml_str(text)
    ref = read_robot(text)
    t, dl = commands(robot, 8, 1, lo=-1.5e-3, hi=2e-3)
    kind = ["absolute", "displacement", "absolute", "absolute", "unmeasured", "displacement", "absolute",
            "absolute"]
    eff = {k: EFFECTS_TWO[k] for k in ("actuation_scale", "cable_offset", "backlash", "joint_stiffness",
                                        "cable_angle", "frame_misalignment", "tip_offset")}
    eff["cable_friction"] = [0.15]
    obs, ok = plant.predict(robot, plant.params(robot, eff), t, dl, kind)
    want, want_ok = elastic.plant_predict(ref, t, dl, kind, eff)
    np.testing.assert_array_equal(ok, want_ok)
    assert ok.all()
    np.testing.assert_allclose(obs, want, rtol=0, atol=1e-12)
    frictionless, _ = plant.predict(robot, plant.params(robot, {**eff, "cable_friction": [0.0]}), t, dl, kind)
    assert np.nanmax(np.abs(frictionless - obs)) > 1e-5


@pytest.mark.parametrize("mu", [0.12, 0.0])
def test_jacobian_with_friction_is_differences_of_the_predictions(mu):
    """The implicit function theorem of the non-symmetric friction system against central
    differences (at ``mu = 0``: the ``mu`` column one-sided, forward differences)."""
    robot = cdsm.Robot.from_toml_str(via_plates())
    t, dl = commands(robot, 5, 3, lo=-1e-3, hi=2e-3)
    kind = ["absolute", "displacement", "absolute", "absolute", "absolute"]
    eff = {k: EFFECTS_TWO[k] for k in ("cable_offset", "backlash", "joint_stiffness", "tip_offset")}
    p = with_mu(robot, mu, eff)
    lay = plant.layout(robot)
    free = np.concatenate([np.arange(lay[b].start, lay[b].stop)
                           for b in ("cable_offset", "backlash", "joint_stiffness", "tip_offset", "cable_friction")])
    obs, ok, jac = plant.linearise(robot, p, free, t, dl, kind)
    assert ok.all() and np.isfinite(jac).all()
    scale = np.array([plant.TYPICAL[b] for b, _ in plant.parameter_blocks(robot, free)])
    fd = np.empty_like(jac)
    imu = lay["cable_friction"].start
    for col, i in enumerate(free):
        h = 1e-4 * scale[col]
        up, dn = p.copy(), p.copy()
        up[i] += h
        if i == imu and mu == 0.0:
            fd[:, :, col] = (plant.predict(robot, up, t, dl, kind)[0] - obs) / h
            continue
        dn[i] -= h
        fd[:, :, col] = (plant.predict(robot, up, t, dl, kind)[0] - plant.predict(robot, dn, t, dl, kind)[0]) / (2 * h)
    J, F = jac * scale, fd * scale
    assert np.abs(J[:, :, -1]).max() > 1e-5
    tol = (1e-3 if mu == 0.0 else 1e-7) * np.abs(J).max()
    np.testing.assert_allclose(J, F, rtol=0, atol=tol)


def test_a_fit_recovers_mu():
    """Noise-free tips of a pull-and-release sequence on the via-plate arm at ``mu =
    0.15`` with a marker offset, fitted back from zero by ``cdsm.calibration.fit``."""
    robot = cdsm.Robot.from_toml_str(via_plates())
    t, dl = commands(robot, 40, 5, lo=-1.5e-3, hi=2.5e-3)
    names = ["cable_friction", "tip_offset"]
    truth = plant.params(robot, {"cable_friction": [0.15], "tip_offset": EFFECTS_TWO["tip_offset"]})
    f, idx = fit_tips(robot, t, dl, truth, names)
    np.testing.assert_allclose(f.p[idx], truth[idx], rtol=1e-7, atol=0)
    assert f.rms < 1e-11
