"""Friction of the cables in the holes (``docs/model.md``, "Friction in the holes";
``rust/friction.rs`` through the plant and the statics): analytic facts
(Euler--Eytelwein at one hole, the frictionless limit, the hysteresis loop
widening with ``mu`` and the wrap angle, the sign of the dissipation) and
parity with the independent NumPy reference (``cdsm.reference.friction``,
``.plant``).  SI units: m, rad, N, 1/N."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import ROOT, reference

ROBOTS = ROOT / "python" / "cdsm" / "robots"

#: One joint of the paper's first linkage (link_before = link_after, so the
#: chord between the base hole and the disk's hole turns by theta / 2), no lower weight.
ONE_JOINT = """name = "one joint"
n = 1
[cable]
youngs_modulus = 1.8e11
diameter = 0.18e-3
[[linkage]]
link_before = 0.033
link_after = 0.033
thickness = 0.010
hole_height = 0.030
lower_tension = 0.0
"""


def _planar_params(plant, robot, **blocks):
    p = np.zeros(plant.size(robot))
    lay = plant.layout(robot)
    for name, v in blocks.items():
        p[lay[name]] = v
    return p


# --------------------------------------------------------------------------
# Statics: Euler--Eytelwein, the bounding states, the slack check
# --------------------------------------------------------------------------
@pytest.mark.parametrize("theta", [0.2, -0.45])
@pytest.mark.parametrize("mu", [0.1, 0.3])
def test_euler_eytelwein_at_one_hole(cdsm, theta, mu):
    """One joint, a tip couple, no lower weight: the upper cable turns through
    its base hole by |theta| / 2 (the chord of equal links), so the actuator's
    tension is the frictionless one times exp(+mu |theta| / 2) pulling and
    exp(-mu |theta| / 2) releasing (Euler--Eytelwein, T_in = T_out e^{mu beta})."""
    r = cdsm.Robot.from_toml_str(ONE_JOINT)
    th = np.array([[theta]])
    w = [0.0, 0.0, -0.02]  # a couple the upper cable holds
    t0 = r.tensions(th, tip_wrench=w)[0, 0]
    pull = r.tensions(th, tip_wrench=w, friction=mu, sliding="pull")[0, 0]
    rel = r.tensions(th, tip_wrench=w, friction=mu, sliding="release")[0, 0]
    assert t0 > 0.1
    beta = abs(theta) / 2
    assert pull == pytest.approx(t0 * np.exp(mu * beta), rel=1e-13)
    assert rel == pytest.approx(t0 * np.exp(-mu * beta), rel=1e-13)


def test_frictionless_statics_are_todays(cdsm):
    r = cdsm.Robot.paper().with_loads(gravity=[0.0, -9.80665])
    th = np.random.default_rng(1).uniform(-0.5, 0.5, (30, 3))
    t = r.tensions(th)
    for s in ("pull", "release"):
        assert np.array_equal(r.tensions(th, friction=0.0, sliding=s), t)


def test_statics_with_friction_match_the_reference(cdsm, ref):
    """The bounding states' tensions against the reference's balance with the
    capstan gap factors (``reference.friction_factors``)."""
    r = cdsm.Robot.paper().with_loads(gravity=[0.0, -9.80665])
    th = np.random.default_rng(2).uniform(-0.5, 0.5, (20, 3))
    H = sum(2 * (c // 2 + 1) for c in range(6))
    for sliding, (zp, zf) in (("pull", reference.friction.PULL), ("release", reference.friction.RELEASE)):
        z = np.concatenate([np.full(2 * (c // 2 + 1), zp if c % 2 == 0 else zf) for c in range(6)])
        assert z.size == H
        gap, _ = ref.friction_factors(r, th, np.tile(z, (20, 1)), 0.2)
        want = ref.tensions(r, th, lower=r.lower_tension, gravity=np.array([0.0, -9.80665]), mass=r.mass, gap=gap)
        got = r.tensions(th, friction=0.2, sliding=sliding)
        assert np.abs(got - want).max() < 1e-12, np.abs(got - want).max()


def test_dissipation_has_the_right_sign(cdsm):
    """Over a cycle an actuator hauls its cable in (pulling) and pays it out
    (releasing): the work it puts in, the integral of (T_pull - T_release) |dL|,
    is positive -- friction dissipates. The cable of the last disk (its joint's
    balance holds only its own pair) on random poses of the paper's vertical
    reading where it is taut: T_pull > T_release wherever it bends, equal at mu = 0;
    one joint with its lower weight: T_pull / T_release = exp(2 mu |theta| / 2),
    both cables turning by |theta| / 2 at their base holes."""
    r = cdsm.Robot.packaged("paper_vertical")
    th = np.random.default_rng(3).uniform(-0.6, 0.6, (200, 3))
    pull = r.tensions(th, friction=0.15, sliding="pull")[:, 2]
    rel = r.tensions(th, friction=0.15, sliding="release")[:, 2]
    taut = rel > 0
    assert taut.sum() > 100
    assert (pull[taut] > rel[taut]).all()
    assert np.array_equal(r.tensions(th, friction=0.0, sliding="pull"), r.tensions(th, friction=0.0, sliding="release"))
    one = cdsm.Robot.from_toml_str(ONE_JOINT.replace("lower_tension = 0.0", "lower_tension = 0.5"))
    for theta in (0.3, -0.2):
        ratio = one.tensions([theta], friction=0.2, sliding="pull") / one.tensions([theta], friction=0.2,
                                                                                  sliding="release")
        assert ratio[0] == pytest.approx(np.exp(0.2 * abs(theta) * 2), rel=1e-13)


def test_slack_check_with_friction(cdsm):
    """``feasible`` with friction is the sign of the tensions of the state named
    against the floor, and releasing drops a cable below the floor where the
    frictionless arm holds it above."""
    r = cdsm.Robot.paper()
    th = np.random.default_rng(4).uniform(-0.6, 0.6, (300, 3))
    floor = 0.05
    free = r.feasible(th, min_tension=floor)
    for s in ("pull", "release"):
        got = r.feasible(th, min_tension=floor, friction=0.3, sliding=s)
        assert np.array_equal(got, (r.tensions(th, friction=0.3, sliding=s) > floor).all(1))
    rel = r.feasible(th, min_tension=floor, friction=0.3, sliding="release")
    assert (free & ~rel).any()


def test_slack_comes_first_pulling_and_a_floor_is_crossed_first_releasing(cdsm):
    """The paper prototype at mu = 1 over the ±30° grid in 5° steps.
    Pulling, each position cable's tension grows toward its actuator and
    each force cable's toward its end, so at a joint the pairs ending beyond
    it pull harder on the position side than at their own joints and relieve
    the position cable ending there: it goes slack first pulling (taut
    releasing wherever taut pulling). The check reads the actuator's
    tension, and releasing the holes grip the paying-out cable: the actuator
    holds the gap tension over exp(mu sum beta), so a positive floor is
    crossed first releasing. ``feasible``'s docstring said releasing is
    where a cable goes slack first; it now says both, with these counts."""
    from cdsm.accuracy.workspace import joint_grid

    r = cdsm.Robot.paper()
    grid = joint_grid(3, step=np.radians(5.0))
    counts = {}
    for floor in (0.0, 0.05):
        pull = r.feasible(grid, min_tension=floor, friction=1.0, sliding="pull")
        release = r.feasible(grid, min_tension=floor, friction=1.0, sliding="release")
        counts[floor] = (int(pull.sum()), int(release.sum()))
        if floor == 0.0:
            assert not (pull & ~release).any()
    assert len(grid) == 2197 and counts == {0.0: (1576, 2197), 0.05: (1354, 6)}
    doc = " ".join(r.feasible.__doc__.split())
    assert "Slack comes first pulling" in doc and "A positive floor is crossed first releasing" in doc
    assert "1576 pulling and 2197 releasing" in doc and "1354 pulling and 6 releasing" in doc


def test_friction_input_errors(cdsm):
    r = cdsm.Robot.paper()
    with pytest.raises(cdsm.CdsmInputError, match="sliding"):
        r.tensions([0.1, 0.1, 0.1], friction=0.1, sliding="up")
    with pytest.raises(cdsm.CdsmInputError, match="friction"):
        r.tensions([0.1, 0.1, 0.1], friction=-0.1)
    with pytest.raises(cdsm.CdsmInputError, match="friction"):
        r.tensions([0.1, 0.1, 0.1], friction=float("nan"))


def test_the_friction_default_and_domain_are_the_cores(cdsm):
    """One default (0.15) and one domain ([0, 1]), both the core's
    (``rust/friction.rs``: MU_TYPICAL, MU_MAX, check_mu): the statics' default,
    the plant's typical size, and the errors of the statics and the friction
    map, each naming its own field."""
    from cdsm import _cdsm
    from cdsm.accuracy import statics
    from cdsm.calibration import plant

    assert _cdsm.FRICTION_TYPICAL == 0.15 and _cdsm.FRICTION_MAX == 1.0
    assert statics.FRICTION == _cdsm.FRICTION_TYPICAL == plant.TYPICAL["cable_friction"]
    r = cdsm.Robot.paper()
    for mu in (-0.1, 1.5):
        with pytest.raises(cdsm.CdsmInputError,
                           match=rf"^`friction`: the friction coefficient must be within \[0, 1\], got {mu}$"):
            r.tensions([0.1, 0.1, 0.1], friction=mu)
        with pytest.raises(cdsm.CdsmInputError,
                           match=rf"^`mu`: the friction coefficient must be within \[0, 1\], got {mu}$"):
            statics.friction_map(r, [[0.1, 0.1, 0.1]], mu=mu)
    assert _cdsm.check_friction("mu", 1.0) is None and _cdsm.check_friction("mu", 0.0) is None


# --------------------------------------------------------------------------
# The plant: parity, the frictionless limit, the hysteresis loop
# --------------------------------------------------------------------------
def _cycle(n, theta, steps=4, amplitude=1e-3):
    """A +-amplitude cycle of the first cable at the commanded ``theta``: 0 -> +a
    -> -a -> 0 in ``steps`` per quarter, absolute rows."""
    up = np.linspace(0.0, amplitude, steps + 1)
    path = np.concatenate([up, up[::-1][1:], -up[1:], -up[::-1][1:]])
    dl = np.zeros((path.size, n))
    dl[:, 0] = path
    return np.tile(theta, (path.size, 1)), dl, path


def _loop_width(obs, path):
    """The largest distance (m) between the tip positions at equal commands
    reached going up and going down."""
    k = path.size
    width = 0.0
    for i in range(k):
        for j in range(i + 1, k):
            if path[i] == path[j]:
                width = max(width, float(np.linalg.norm(obs[i, :2] - obs[j, :2])))
    return width


@pytest.mark.parametrize("blocks", [
    dict(cable_elasticity=0.02, cable_friction=0.15),
    dict(cable_elasticity=0.03, cable_friction=0.4, backlash=[3e-5, 2e-5, 1e-5], actuation_scale=0.02,
         hole_height=[1e-4, -2e-4, 1e-4], cable_offset=[-2e-4, 1e-4, 1e-4]),
    dict(cable_elasticity=0.02, cable_friction=0.2, hole_clearance=1.5e-4),
], ids=["kappa+mu", "mixture", "kappa+mu+clearance"])
def test_planar_plant_with_friction_matches_the_reference(cdsm, ref, blocks):
    from cdsm.calibration import plant

    r = cdsm.Robot.paper().with_loads(gravity=[0.0, -9.80665])
    rng = np.random.default_rng(len(blocks))
    theta = rng.uniform(-0.5, 0.5, (20, 3))
    dl = np.where(rng.random((20, 3)) < 0.6, rng.uniform(-1e-3, 1e-3, (20, 3)), 0.0)
    kind = rng.choice(["absolute", "displacement", "unmeasured"], 20, p=[0.5, 0.3, 0.2])
    p = _planar_params(plant, r, **blocks)
    obs, ok = plant.predict(r, p, theta, dl, kind)
    want, ok_ref = ref.plant_predict(r, p, theta, dl, kind)
    # kappa = 0.02-0.03 1/N under gravity loses its equilibrium on some rows with or
    # without friction (docs/model.md, "Statics"): both fail on the same rows
    assert (ok == ok_ref).all() and ok.sum() >= len(ok) // 2
    m = (kind != "unmeasured") & ok
    assert np.abs(obs[m] - want[m]).max() < 1e-10, np.abs(obs[m] - want[m]).max()
    # friction moved the arm: the test sees the effect
    p0 = p.copy()
    p0[plant.layout(r)["cable_friction"]] = 0.0
    assert np.nanmax(np.abs(plant.predict(r, p0, theta, dl, kind)[0][m] - obs[m])) > 1e-6


def test_spatial_plant_with_friction_matches_the_reference(cdsm):
    from cdsm.calibration import plant

    core, arm = cdsm.Robot.packaged("two_universal"), reference.load_robot(ROBOTS / "two_universal.toml")
    lay = reference.plant_layout(arm)
    p = np.zeros(reference.plant_size(arm))
    p[lay["cable_elasticity"]] = 0.02
    p[lay["cable_friction"]] = 0.2
    p[lay["backlash"]] = [2e-5, 1e-5, 3e-5, 1e-5]
    rng = np.random.default_rng(6)
    theta = rng.uniform(-0.4, 0.4, (14, 4))
    dL = rng.uniform(-1e-3, 1e-3, (14, 4))
    kind = rng.choice(["absolute", "displacement", "unmeasured"], 14, p=[0.5, 0.3, 0.2])
    obs, ok = plant.predict(core, p, theta, dL, kind)
    want, ok_ref = reference.plant_predict(arm, p, theta, dL, kind)
    assert (ok == ok_ref).all() and ok.all()
    m = kind != "unmeasured"
    assert np.abs(obs[m] - want[m]).max() < 1e-10, np.abs(obs[m] - want[m]).max()
    p[lay["cable_friction"]] = 0.0
    assert np.abs(plant.predict(core, p, theta, dL, kind)[0][m] - obs[m]).max() > 1e-6


def test_planar_and_spatial_friction_agree_on_the_paper_arm(cdsm):
    """Friction is written once: the paper arm as a planar and as a spatial file."""
    from cdsm.calibration import plant

    planar, spatial = cdsm.Robot.paper(), cdsm.Robot.packaged("paper_spatial")
    pp = _planar_params(plant, planar, cable_elasticity=0.02, cable_friction=0.25)
    ps = _planar_params(plant, spatial, cable_elasticity=0.02, cable_friction=0.25)
    rng = np.random.default_rng(7)
    theta, dl = rng.uniform(-0.5, 0.5, (12, 3)), rng.uniform(-1e-3, 1e-3, (12, 3))
    a, ok_a = plant.predict(planar, pp, theta, dl, "absolute")
    b, ok_b = plant.predict(spatial, ps, theta, dl, "absolute")
    assert ok_a.all() and ok_b.all()
    assert np.abs(a - b[:, [0, 1, 5]]).max() < 1e-10


@pytest.mark.parametrize("name", ["paper", "two_universal"])
def test_vanishing_friction_is_todays_elastic_plant(cdsm, name):
    """mu = 1e-300 runs the friction equations (capstan factors exp(-mu z beta) = 1
    in floating point, the balance with gap factors, the mean factor ebar, the
    frictionless balance for friction's change): they give the frictionless
    elastic plant to round-off. (mu = 0 itself takes the frictionless code path:
    bitwise today's plant.)"""
    from cdsm.calibration import plant

    r = cdsm.Robot.packaged(name)
    n, m = r.n, len(r.position_cables)
    rng = np.random.default_rng(8)
    theta, dl = rng.uniform(-0.4, 0.4, (16, n)), rng.uniform(-1e-3, 1e-3, (16, m))
    kind = rng.choice(["absolute", "displacement"], 16)
    p = _planar_params(plant, r, cable_elasticity=0.02)
    a, ok = plant.predict(r, p, theta, dl, kind)
    p[plant.layout(r)["cable_friction"]] = 1e-300
    b, ok_b = plant.predict(r, p, theta, dl, kind)
    assert ok.all() and ok_b.all()
    assert np.abs(a - b).max() <= 2e-15  # round-off (m and rad; the values are up to 0.5)


def test_redundant_arm_with_friction_matches_the_reference(cdsm):
    """Eight position cables for four joints (two_universal's force cables made
    position cables), pre-tensioned, kappa = 0.02 1/N with friction 0.15."""
    import re

    text = (ROBOTS / "two_universal.toml").read_text(encoding="utf-8")
    text = re.sub(r'mode = "force"\ntension = [0-9.eE+-]+\n', 'mode = "position"\n', text)
    core, arm = cdsm.Robot.from_toml_str(text), reference.read_robot(text)
    lay = reference.plant_layout(arm)
    p = np.zeros(reference.plant_size(arm))
    p[lay["cable_elasticity"]] = 0.02
    p[lay["cable_friction"]] = 0.15
    p[lay["cable_offset"]] = np.random.default_rng(5).uniform(-1e-3, -6e-4, 8)
    rng = np.random.default_rng(22)
    theta, dL = rng.uniform(-0.4, 0.4, (10, 4)), rng.uniform(-5e-4, 5e-4, (10, 8))
    kind = rng.choice(["absolute", "displacement"], 10)
    from cdsm.calibration import plant

    obs, ok = plant.predict(core, p, theta, dL, kind)
    want, ok_ref = reference.plant_predict(arm, p, theta, dL, kind)
    assert ok.all() and ok_ref.all()
    assert np.abs(obs - want).max() < 1e-9, np.abs(obs - want).max()


def test_hysteresis_widens_with_friction_and_wrap(cdsm):
    """A +-1 mm cycle of the first cable at a fixed commanded pose (kappa = 0.02
    1/N): no loop without friction; with it, a loop that widens with mu and
    with the bend (the wrap angles) of the pose."""
    from cdsm.calibration import plant

    r = cdsm.Robot.paper()

    def width(mu, bend):
        theta, dl, path = _cycle(3, np.full(3, bend))
        p = _planar_params(plant, r, cable_elasticity=0.02, cable_friction=mu)
        obs, ok = plant.predict(r, p, theta, dl, "absolute")
        assert ok.all()
        return _loop_width(obs, path)

    assert width(0.0, 0.3) == 0.0
    w = [width(mu, 0.3) for mu in (0.05, 0.1, 0.2)]
    assert 0.0 < w[0] < w[1] < w[2], w
    b = [width(0.15, bend) for bend in (0.1, 0.2, 0.4)]
    assert 0.0 < b[0] < b[1] < b[2], b


def test_hysteresis_matches_the_reference(cdsm, ref):
    from cdsm.calibration import plant

    r = cdsm.Robot.paper()
    theta, dl, path = _cycle(3, np.array([0.3, -0.2, 0.25]))
    p = _planar_params(plant, r, cable_elasticity=0.02, cable_friction=0.3)
    obs, ok = plant.predict(r, p, theta, dl, "absolute")
    want, ok_ref = ref.plant_predict(r, p, theta, dl, np.array(["absolute"] * len(path)))
    assert ok.all() and ok_ref.all()
    assert np.abs(obs - want).max() < 1e-10
    assert _loop_width(obs, path) > 1e-6


# --------------------------------------------------------------------------
# The study's friction map
# --------------------------------------------------------------------------
def test_friction_map_loops_match_the_reference(cdsm, ref):
    """The hysteresis map's loop widths (the robot file's steel cable, mu = 0.15)
    against the reference plant on the same cycles; none without friction."""
    from cdsm.accuracy import statics

    r = cdsm.Robot.packaged("paper_vertical")
    th = np.array([[0.3, -0.2, 0.25], [0.0, 0.0, 0.0], [-0.4, 0.3, 0.1]])
    fm = statics.friction_map(r, th)
    theta_cmd, dL = statics.hysteresis_cycles(3, 3, th)
    p = np.zeros(ref.plant_size(r))
    lay = ref.plant_layout(r)
    p[lay["cable_friction"]] = statics.FRICTION  # friction's stretch at the robot file's E A
    obs, ok = ref.plant_predict(r, p, theta_cmd, dL, np.array(["absolute"] * len(theta_cmd)))
    assert ok.all()
    xy = obs[:, :2].reshape(3, 3, 5, 2)
    want = np.linalg.norm(xy[:, :, 2] - xy[:, :, 4], axis=-1)
    assert np.abs(fm.loop - want).max() < 1e-12
    assert fm.width.max() > 1e-6 and fm.width.max() < 1e-4  # steel: micrometres
    assert np.array_equal(fm.width, fm.loop.max(axis=1))
    assert (statics.friction_map(r, th, mu=0.0).loop == 0.0).all()
    assert np.array_equal(fm.pull, r.tensions(th, friction=0.15, sliding="pull"))


def test_a_friction_map_over_a_cycle_budget_cycles_evenly_spread_configurations(cdsm):
    """With fewer cycles allowed than configurations, the cycled ones are
    evenly spread, their loops are those of the full map (each cycle is
    independent of the others), the rest NaN and flagged; the statics still
    cover every configuration."""
    from cdsm.accuracy import statics

    r = cdsm.Robot.packaged("paper_vertical")
    th = np.random.default_rng(4).uniform(-0.4, 0.4, (10, 3))
    full = statics.friction_map(r, th)
    part = statics.friction_map(r, th, cycle_work=4 * 3 * 3)  # four configurations' worth
    assert full.cycled.all() and part.cycled.sum() == 4
    assert np.flatnonzero(part.cycled).tolist() == [0, 3, 6, 9]
    np.testing.assert_array_equal(part.loop[part.cycled], full.loop[part.cycled])
    assert np.isnan(part.loop[~part.cycled]).all()
    np.testing.assert_array_equal(part.pull, full.pull)


# --------------------------------------------------------------------------
# The library effect cable_friction: the fit, compensation, --suggest
# --------------------------------------------------------------------------
#: A polymer-like cable (E A = 51 N) on the paper arm: friction moves the tip by
#: tens of micrometres, the effect the diagnosis can see at 10 µm noise (with
#: steel, E A = 4.6 kN, its loops are micrometres: docs/model.md).
COMPLIANT_E = 2e9


@pytest.fixture(scope="module")
def compliant(cdsm):
    return cdsm.Robot.paper().with_cable(youngs_modulus=COMPLIANT_E)


@pytest.fixture(scope="module")
def friction_data(compliant):
    from cdsm.calibration import plant

    rng = np.random.default_rng(3)
    theta, dl = rng.uniform(-0.5, 0.5, (60, 3)), rng.uniform(-1e-3, 1e-3, (60, 3))
    vp = plant.VirtualPrototype(compliant, {"cable_friction": [0.3]}, noise=10e-6, seed=1)
    return vp.measure(theta, dl, "displacement")


def test_library_has_cable_friction(cdsm):
    from cdsm.calibration import plant

    assert "cable_friction" in plant.EFFECTS and "cable_friction" in plant.SPATIAL_EFFECTS
    assert set(plant.MEMORY_EFFECTS) == {"backlash", "cable_friction"}


def test_the_diagnosis_names_and_fits_friction(compliant, friction_data):
    """Hidden mu = 0.3 on 60 displacement rows: named, explained, mu within 2 sigma
    of the truth (the jets' Jacobian through the sticking bands); the command
    line shows mu as the number it is (it showed 0.3 as "+300.000 ± ... mm")."""
    from cdsm.calibration import diagnosis, plant
    from cdsm.report import diagnosis as report

    d = diagnosis.diagnose(compliant, friction_data)
    assert d.best == "cable_friction" and d.verdict == "explained"
    fit = d.final().fit
    mu = fit.p[plant.layout(compliant)["cable_friction"]][0]
    assert abs(mu - 0.3) < 2 * fit.std[0] + 1e-3, (mu, fit.std)
    shown = f"μ (every cable, every hole) = {mu:+.4f} ± {fit.std[0]:.4f}"
    effect = next(ln for ln in report.summary(d) if ln.startswith("Effect: "))
    assert shown in effect and "mm" not in effect, effect


def test_friction_is_not_taken_for_backlash_or_elasticity(compliant):
    from cdsm.calibration import diagnosis, plant

    rng = np.random.default_rng(4)
    theta, dl = rng.uniform(-0.5, 0.5, (60, 3)), rng.uniform(-1e-3, 1e-3, (60, 3))
    for hidden in ({"backlash": [6e-5, 4e-5, 3e-5]}, {"cable_elasticity": [0.02]}):
        data = plant.VirtualPrototype(compliant, hidden, noise=10e-6, seed=2).measure(theta, dl, "displacement")
        d = diagnosis.diagnose(compliant, data)
        assert d.best == next(iter(hidden)), (hidden, d.best)


def test_compensation_with_friction_is_direction_aware(cdsm, compliant):
    """The fitted plant with friction puts the tip on target for targets run in
    order; the same target reached from the other side gets other commands."""
    from cdsm.calibration import plant

    p = plant.params(compliant, {"cable_friction": [0.3]})
    model = cdsm.FittedPlant(compliant, p, ["cable_friction"])
    a, b = compliant.fk([0.4, 0.35, 0.4]), compliant.fk([0.0, 0.05, 0.0])  # from further and less bent
    target = compliant.fk([0.25, 0.25, 0.25])
    one = model.compensate(np.array([a, target]))
    two = model.compensate(np.array([b, target]))
    assert one.converged.all() and two.converged.all()
    assert np.nanmax(one.predicted_error) < 1e-8 and np.nanmax(two.predicted_error) < 1e-8
    assert one.predicted_error_nominal[1] > 5e-5  # friction moves the uncompensated tip
    assert np.abs(one.commands[1] - two.commands[1]).max() > 3e-5


def test_suggest_offers_loading_and_unloading_with_friction(compliant, friction_data):
    """With a friction candidate every suggestion comes with an approach move
    from above or below (a loading or unloading cycle)."""
    from cdsm.calibration import diagnosis, experiment

    d = diagnosis.diagnose(compliant, friction_data, effects=["cable_friction", "backlash", "cable_elasticity"])
    sug = experiment.suggest(d, 4, pool=60)
    assert sug.approach is not None and len(sug.approach) == len(sug.theta)


def test_a_friction_map_runs_its_cycles_in_chunks_of_bounded_memory(cdsm, ref, monkeypatch):
    """Memory bounded by design (issue 32, item 11): the plant with friction
    keeps every hole's motion for every command, so the hysteresis map runs
    its cycles in chunks of :func:`cycle_chunk` (here two cycles: at most 10
    rows through the plant at once, where it used to run all 45 in one
    sequence); each chunk is a sequence of its own from the start state —
    its loops are the reference plant's on that chunk alone — and a chunk
    holding every cycle is the one sequence, as before."""
    from cdsm import plant
    from cdsm.accuracy import statics

    r = cdsm.Robot.packaged("paper_vertical")
    th = np.array([[0.3, -0.2, 0.25], [0.0, 0.0, 0.0], [-0.4, 0.3, 0.1]])
    whole = statics.friction_map(r, th)
    holes = 2 * sum(r.cable_ends)
    monkeypatch.setattr(statics, "CYCLE_MEMORY", 2 * 5 * holes * statics.BYTES_PER_HOLE_COMMAND)
    assert statics.cycle_chunk(r) == 2
    calls = []
    real = plant.predict

    def spy(robot, p, theta_cmd, *a, **k):
        calls.append(len(theta_cmd))
        return real(robot, p, theta_cmd, *a, **k)

    monkeypatch.setattr(plant, "predict", spy)
    fm = statics.friction_map(r, th)
    assert calls == [10, 10, 10, 10, 5]
    theta_cmd, dL = statics.hysteresis_cycles(3, 3, th)
    p = np.zeros(ref.plant_size(r))
    p[ref.plant_layout(r)["cable_friction"]] = statics.FRICTION
    want = np.empty(9)
    for first in range(0, 9, 2):
        rows = slice(5 * first, 5 * min(first + 2, 9))
        kinds = np.array(["absolute"] * (rows.stop - rows.start))
        obs, ok = ref.plant_predict(r, p, theta_cmd[rows], dL[rows], kinds)
        assert ok.all()
        xy = obs[:, :2].reshape(-1, 5, 2)
        want[first:first + len(xy)] = np.linalg.norm(xy[:, 2] - xy[:, 4], axis=-1)
    assert np.abs(fm.loop.reshape(-1) - want).max() < 1e-12
    # the first chunk starts where the whole sequence starts: same loops
    np.testing.assert_array_equal(fm.loop.reshape(-1)[:2], whole.loop.reshape(-1)[:2])
