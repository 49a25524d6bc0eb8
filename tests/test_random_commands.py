"""Random commands of the virtual prototype
(``cdsm.calibration.plant.VirtualPrototype.random_commands``) and its taut
option (issue 34, item 4): with ``taut=True`` only commands the nominal
model keeps taut, checked here by the NumPy reference's statics and cable
solve, written independently of the Rust core. ``serpentine8`` (planar, 8
joints) keeps about 1 in 5 random commands within ±30° taut, so the option
has something to reject; ``paper_spatial`` checks the spatial statics.
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import ROOT

ROBOTS = ROOT / "python" / "cdsm" / "robots"


@pytest.fixture(scope="module", params=["serpentine8", "paper_spatial"])
def arm(request, cdsm, ref):
    """(name, cdsm robot, reference robot) of a packaged robot file."""
    text = (ROBOTS / f"{request.param}.toml").read_text(encoding="utf-8")
    return request.param, cdsm.Robot.from_toml_str(text), ref.read_robot(text)


def _reference_taut(ref, nominal, theta, d, floor=0.0):
    """(N,) every position cable's tension above ``floor`` N by the reference
    statics at ``theta`` (N, n) rad and at the angles the nominal arm takes
    for the lengths of ``theta`` + ``d`` (N, m) m (square arms: the balance's
    one solution)."""
    pos = ref.position_cables(nominal)
    assert pos.size == nominal.n
    lengths = ref.cable_lengths(nominal, theta)[:, pos] + d
    sol = ref.solve_cables(nominal, lengths, seed=theta)
    reached = np.where(np.asarray(sol["converged"], bool)[:, None], sol["theta"], np.nan)
    out = np.asarray(sol["converged"], bool)
    for th in (theta, reached):
        with np.errstate(invalid="ignore"):
            out &= (ref.tensions(nominal, np.nan_to_num(th)) > floor).all(axis=1)
    return out


def _vp(cdsm, robot, seed=4):
    from cdsm.calibration import plant

    return plant.VirtualPrototype(robot, {}, seed=seed)


@pytest.mark.parametrize("floor", [0.0, 0.02])
def test_taut_commands_are_taut_by_the_reference_statics(cdsm, ref, arm, floor):
    name, robot, nominal = arm
    vp = _vp(cdsm, robot)
    theta, d = vp.random_commands(60, taut=True, min_tension=floor)
    assert theta.shape == (60, robot.n) and d.shape == (60, len(robot.position_cables))
    assert np.abs(theta).max() <= np.radians(30.0) and np.abs(d).max() <= 1e-3
    assert _reference_taut(ref, nominal, theta, d, floor).all()
    # the same seed without the option draws commands that are not all taut:
    # the option has rejected something
    plain = vp.random_commands(200)
    assert not _reference_taut(ref, nominal, *plain, floor).all()


def test_taut_displacement_commands(cdsm, ref, arm):
    _, robot, nominal = arm
    theta, d = _vp(cdsm, robot).random_commands(40, taut=True, reading="displacement", dl=2e-3)
    assert ((d != 0).sum(axis=1) == 1).all() and set(np.abs(d[d != 0])) == {2e-3}
    assert _reference_taut(ref, nominal, theta, d).all()


def test_taut_rows_are_all_usable_by_the_diagnosis(cdsm):
    from cdsm.calibration import diagnosis

    robot = cdsm.Robot.from_toml("serpentine8")
    vp = _vp(cdsm, robot)
    for taut, usable in ((False, lambda u: u.sum() < 30), (True, lambda u: u.all())):
        prep = diagnosis.prepare(robot, vp.measure(*vp.random_commands(60, taut=taut)))
        assert usable(prep.usable), int(prep.usable.sum())


def test_taut_draws_are_reproducible(cdsm):
    robot = cdsm.Robot.from_toml("serpentine8")
    a = _vp(cdsm, robot).random_commands(30, taut=True)
    b = _vp(cdsm, robot).random_commands(30, taut=True)
    c = _vp(cdsm, robot).random_commands(30, taut=True, seed=99)
    for x, y in zip(a, b):
        np.testing.assert_array_equal(x, y)
    assert not np.array_equal(a[0], c[0])
    # max_draws bounds the search, it does not change what is found
    e = _vp(cdsm, robot).random_commands(30, taut=True, max_draws=10**6)
    np.testing.assert_array_equal(a[0], e[0])


@pytest.mark.parametrize("kind", ["absolute", "displacement"])
def test_default_draws_are_unchanged(cdsm, kind):
    """Without the option the draw is the one before it, bit for bit: angles
    then extras from numpy's generator seeded with the prototype's seed + 1."""
    robot = cdsm.Robot.from_toml("serpentine8")
    theta, d = _vp(cdsm, robot, seed=7).random_commands(25, reading=kind, limit=0.4, dl=2e-3)
    rng = np.random.default_rng(8)
    want = rng.uniform(-0.4, 0.4, (25, 8))
    if kind == "displacement":
        dw = np.zeros((25, 8))
        dw[np.arange(25), rng.integers(0, 8, 25)] = rng.choice([-2e-3, 2e-3], 25)
    else:
        dw = rng.uniform(-2e-3, 2e-3, (25, 8))
    np.testing.assert_array_equal(theta, want)
    np.testing.assert_array_equal(d, dw)


def test_an_impossible_request_says_what_was_tried(cdsm, ref):
    robot = cdsm.Robot.from_toml("serpentine8")
    nominal = ref.read_robot((ROBOTS / "serpentine8.toml").read_text(encoding="utf-8"))
    vp = _vp(cdsm, robot)
    # the first 100 candidates are the plain draw of 100: count its taut ones independently
    found = int(_reference_taut(ref, nominal, *vp.random_commands(100)).sum())
    assert 0 < found < 60
    with pytest.raises(cdsm.CdsmInputError,
                       match=rf"{found} of 100 commands drawn \(acceptance rate {found:d}\.00%\).*60 asked for"):
        vp.random_commands(60, taut=True, max_draws=100)
    with pytest.raises(cdsm.CdsmInputError, match=r"0 of 6000 commands drawn \(acceptance rate 0\.00%\)"):
        vp.random_commands(60, taut=True, min_tension=1e3)


@pytest.mark.parametrize("kw, field", [
    (dict(taut="yes"), "taut"), (dict(taut=1), "taut"),
    (dict(taut=True, min_tension=-0.1), "min_tension"), (dict(taut=True, min_tension=np.nan), "min_tension"),
    (dict(min_tension=0.1), "min_tension"), (dict(max_draws=1000), "max_draws"),
    (dict(taut=True, max_draws=0), "max_draws"), (dict(taut=True, max_draws=1.5), "max_draws"),
    (dict(reading="absolut"), "reading"), (dict(limit=-0.1), "limit"), (dict(dl=np.inf), "dl"),
    (dict(rows=-1), "rows"), (dict(rows=2.5), "rows"),
])
def test_bad_options_are_refused_by_name(cdsm, kw, field):
    vp = _vp(cdsm, cdsm.Robot.paper())
    kw = dict(kw)
    rows = kw.pop("rows", 10)
    with pytest.raises(cdsm.CdsmInputError, match=f"`{field}`"):
        vp.random_commands(rows, **kw)


def test_an_elastic_arm_is_commanded_by_its_cables_alone(cdsm):
    """An elastic arm's random rows command only its tendons, as a recording's
    rows do: theta is the rest angles (±30° on each of FTDCR v4's 60 joints
    commanded tendon pulls of centimetres, tips a metre apart), and the
    prototype reads the arm's frictionless equilibrium at the tendons' pull
    -dL (m; docs/model.md: a displacement d is dL = -d at the rest angles)."""
    from cdsm.calibration import plant

    robot = cdsm.Robot.load("ftdcr_v4")
    vp = plant.VirtualPrototype(robot, noise=0.0, seed=4)
    theta, d = vp.random_commands(6)
    np.testing.assert_array_equal(theta, np.tile(robot.rest_angles, (6, 1)))
    assert d.shape == (6, len(robot.displacement_cables)) and np.abs(d).max() <= 1e-3
    got = vp.measure(theta, d).measured
    eq = robot.equilibrium(displacements=-d)
    assert eq.converged.all()
    np.testing.assert_allclose(got, robot.fk(eq.theta)[:, :3], rtol=0, atol=1e-9)
    # a shape can still be asked for: angles around the rest within ±limit
    th2, _ = vp.random_commands(6, limit=0.01)
    assert 0 < np.abs(th2 - robot.rest_angles).max() <= 0.01
