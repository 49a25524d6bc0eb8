"""A rigid arm with more position cables than joints whose robot states its cable settles
on its cables as springs (``docs/model.md``, "Settling"): at the minimum of the potential
of its position cables, each commanded to its realised length and stretched at ``kappa +
1/(E A)`` (the robot file's cable; nothing fed forward), gravity and force cables in the
balance, a slack cable carrying nothing -- not at the unweighted least squares on the
lengths (the settle before issue 35, which put every consistent command exactly where
it was commanded).  One whose cable is not stated (cdsm's default cable, a placeholder:
the packaged SJTU snake, a CASPR import) keeps the least squares; ``Robot.redundant_settle``
says which.

The arm: two_universal with its force cables made position cables (8 cables, 4
joints, gravity), its cable stated; the SJTU snake (36 cables, 24 joints) on a stated
1 mm cable for parity.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from cdsm import reference
from cdsm.reference import elastic

ROBOTS = Path(__file__).resolve().parents[1] / "python" / "cdsm" / "robots"


# cdsm's default cable (steel, 0.18 mm), stated
_STATED = "\n[cable]\nyoungs_modulus = 1.8e11\ndiameter = 0.18e-3\n"


def _eight_text(stated: bool = True) -> str:
    """two_universal with its force cables made position cables, its cable stated or not."""
    text = (ROBOTS / "two_universal.toml").read_text(encoding="utf-8")
    out = re.sub(r'mode = "force"\ntension = [0-9.eE+-]+\n', 'mode = "position"\n', text)
    assert out.count('mode = "position"') == 8
    return out + _STATED if stated else out


@pytest.fixture(scope="module")
def cdsm_core():
    return pytest.importorskip("cdsm")


def _commands(ref, rows, seed):
    theta = np.random.default_rng(seed).uniform(-0.4, 0.4, (rows, ref.n))
    L = reference.cable_lengths(ref, theta)[:, reference.position_cables(ref)]
    return theta, L


def _settle(cdsm, robot, theta, dL=None, p=None):
    """The core plant's settled tips (N, 6) and flags, absolute rows."""
    from cdsm.calibration import plant

    p = np.zeros(plant.size(robot)) if p is None else p
    dL = np.zeros((theta.shape[0], 8)) if dL is None else dL
    return plant.predict(robot, p, theta, dL, "absolute")


def test_nominal_redundant_arm_sags_on_its_cables(cdsm_core):
    """All-zero plant, consistent commands: the arm settles where the reference's
    elastic statics (:func:`cdsm.reference.elastic.equilibrium`, an independent Newton on
    ``U``, its position cables at ``E A / (L + L_r)``) puts it, not at ``theta_cmd``
    (the least-squares settle's answer, which this test rejects: the sag under gravity
    is tens of microradians on the file's nylon-free steel cable)."""
    text = _eight_text()
    robot, ref = cdsm_core.Robot.from_toml_str(text), reference.read_robot(text)
    theta, L = _commands(ref, 6, 11)
    obs, ok = _settle(cdsm_core, robot, theta)
    assert ok.all()
    want = elastic.equilibrium(ref, lengths=L, seed=theta)
    assert want["converged"].all()
    np.testing.assert_allclose(obs, reference.fk(ref, want["theta"]), rtol=0, atol=1e-10)
    sag = np.abs(obs[:, :3] - reference.fk(ref, theta)[:, :3]).max()
    assert sag > 1e-6  # the least squares put the tip at fk(theta_cmd) to 1e-12 m


def test_stiff_limit_is_the_exact_length_solution(cdsm_core):
    """As ``E A -> inf`` with consistent commands the settle tends to the configuration
    that realises every commanded length (``theta_cmd``), the difference ``O(1/(E A))``:
    a hundred times stiffer, a hundred times closer."""
    ref = reference.read_robot(_eight_text())
    theta, _ = _commands(ref, 5, 12)
    gaps = []
    for e in (2e9, 2e11):
        robot = cdsm_core.Robot.from_toml_str(_eight_text()).with_cable(youngs_modulus=e)
        obs, ok = _settle(cdsm_core, robot, theta)
        assert ok.all()
        gaps.append(np.abs(obs[:, :3] - reference.fk(ref, theta)[:, :3]).max())
    assert gaps[0] > 1e-5
    assert 80 < gaps[0] / gaps[1] < 120


def test_slack_cables_carry_nothing(cdsm_core):
    """Commands 2 mm longer on one antagonist set than its path: those cables go slack
    and the arm settles on the others, as the reference's elastic statics has it (the
    balance's damped Newton of the elastic redundant arm failed on such rows)."""
    text = _eight_text()
    robot, ref = cdsm_core.Robot.from_toml_str(text), reference.read_robot(text)
    theta, L = _commands(ref, 4, 13)
    dL = np.zeros_like(L)
    dL[:, 4:] = 2e-3
    obs, ok = _settle(cdsm_core, robot, theta, dL)
    want = elastic.equilibrium(ref, lengths=L + dL, seed=theta)
    assert ok.all() and want["converged"].all()
    assert want["slack"][:, 4:].any(axis=1).all()
    np.testing.assert_allclose(obs, reference.fk(ref, want["theta"]), rtol=0, atol=1e-9)


def test_sjtu_snake_plant_parity(cdsm_core):
    """The SJTU snake (24 joints, 36 cables) under an offset and a compliance:
    core and NumPy reference plant settle the same (its predictions change with issue 35:
    before, the least squares on the lengths)."""
    from cdsm.calibration import plant

    # 1 mm steel cables (the comparison): the packaged 0.18 mm cable lets the
    # snake sag by centimetres under its weight, where the descents from the
    # least-squares seed can reach different minima
    robot = cdsm_core.Robot.packaged("sjtu_snake").with_cable(diameter=1e-3)
    text = (ROBOTS / "sjtu_snake.toml").read_text(encoding="utf-8")
    ref = reference.read_robot(text + "\n[cable]\ndiameter = 1e-3\nyoungs_modulus = 180e9\n")
    rng = np.random.default_rng(14)
    theta = rng.uniform(-0.1, 0.1, (3, ref.n))
    dL = rng.uniform(-2e-4, 2e-4, (3, 36))
    lay = reference.plant_layout(ref)
    p = np.zeros(reference.plant_size(ref))
    p[lay["cable_offset"]] = rng.uniform(-3e-4, 3e-4, 36)
    p[lay["cable_elasticity"]] = 1e-6
    obs, ok = plant.predict(robot, p, theta, dL, "absolute")
    want, ok_ref = reference.plant_predict(ref, p, theta, dL, ["absolute"] * 3)
    assert ok.all() and ok_ref.all()
    np.testing.assert_allclose(obs, want, rtol=0, atol=1e-9)


def test_unstated_cable_keeps_the_least_squares_settle(cdsm_core):
    """The same arm without a ``[cable]`` table (cdsm's default cable, not stated) settles
    as before issue 35, at the unweighted least squares on the lengths: inconsistent
    commands (+-1 mm) land where the reference's rigid least-squares cable solve puts
    them, not where the stated cable's potential does (the same default numbers)."""
    text = _eight_text(stated=False)
    robot, ref = cdsm_core.Robot.from_toml_str(text), reference.read_robot(text)
    theta, L = _commands(ref, 5, 15)
    dL = np.random.default_rng(15).uniform(-1e-3, 1e-3, L.shape)
    obs, ok = _settle(cdsm_core, robot, theta, dL)
    lsq = reference.solve_cables(ref, L + dL, seed=theta)
    assert ok.all() and np.isfinite(lsq["theta"]).all()
    np.testing.assert_allclose(obs, reference.fk(ref, lsq["theta"]), rtol=0, atol=1e-8)
    stated, ok = _settle(cdsm_core, cdsm_core.Robot.from_toml_str(_eight_text()), theta, dL)
    assert ok.all() and np.abs(stated - obs).max() > 1e-4


def test_the_robot_says_how_it_settles(cdsm_core):
    """``Robot.redundant_settle``: "potential" where a redundant rigid arm's cable is
    stated (a ``[cable]`` table or ``with_cable``), "least_squares" where it is not (the
    packaged SJTU snake, a CASPR import); None for other arms.  The file ``to_toml``
    writes keeps it (no ``[cable]`` table for a cable not stated)."""
    R = cdsm_core.Robot
    snake = R.packaged("sjtu_snake")
    assert not snake.cable_stated and snake.redundant_settle == "least_squares"
    steel = snake.with_cable(diameter=1e-3)
    assert steel.cable_stated and steel.redundant_settle == "potential"
    assert R.from_toml_str(snake.to_toml()).redundant_settle == "least_squares"
    assert "\n[cable]\n" not in snake.to_toml()
    assert R.from_toml_str(steel.to_toml()).redundant_settle == "potential"
    assert R.from_toml_str(_eight_text()).redundant_settle == "potential"
    assert R.from_toml_str(_eight_text(stated=False)).redundant_settle == "least_squares"
    assert R.from_toml_str(_hinge_text()).redundant_settle == "potential"
    assert R.packaged("two_universal").redundant_settle is None  # 4 position cables, 4 joints
    assert R.packaged("paper").redundant_settle is None
    assert reference.read_robot(_eight_text()).cable_stated
    assert not reference.read_robot(_eight_text(stated=False)).cable_stated


# One joint about z, two antagonistic position cables: A's base hole 0.3 m behind the
# base face (a long cable, E A / L small), B's at the base face (short, stiff).
_HINGE = """
kind = "spatial"
name = "hinge, two antagonists"
gravity = [0.0, 0.0, 0.0]

[cable]
youngs_modulus = {E}
diameter = 0.5e-3

[base]
radius = 0.02

[[linkage]]
joints = [{{ axis = [0.0, 0.0, 1.0], offset = [0.015, 0.0, 0.0], limits = [-0.6, 0.6] }}]
link_after = [0.015, 0.0, 0.0]
thickness = 0.005
radius = 0.02

[[cables]]
end = 1
mode = "position"
holes = [[-0.3, 0.01, 0.0], [0.0, 0.01, 0.0], [0.0, 0.01, 0.0]]
{PA}
[[cables]]
end = 1
mode = "position"
holes = [[0.0, -0.01, 0.0], [0.0, -0.01, 0.0], [0.0, -0.01, 0.0]]
{PB}
"""

_E = 1.8e11
_EA = _E * np.pi * 0.5e-3**2 / 4.0


def _hinge_text(pa=None, pb=None, e=_E) -> str:
    line = lambda p: "" if p is None else f"pretension = {p!r}\n"  # noqa: E731
    return _HINGE.format(E=repr(e), PA=line(pa), PB=line(pb))


def _hinge_lengths(q):
    """Path lengths (m) of cables A and B at the hinge angle ``q`` rad, by hand: the
    joint at (0.015, 0, 0), face a of the disk 0.015 m beyond it, each hole 0.01 m off
    the axis, the 5 mm disk traversal added."""
    c, s = np.cos(q), np.sin(q)
    out = []
    for base, y in (((-0.3, 0.01), 0.01), ((0.0, -0.01), -0.01)):
        hole = np.array([0.015 + 0.015 * c - y * s, 0.015 * s + y * c])
        out.append(np.hypot(*(hole - np.array(base))) + 0.005)
    return np.array(out)


def _hinge_root(f, lo=-0.3, hi=0.3):
    """The root of the scalar ``f`` on ``[lo, hi]`` by bisection (``f(lo) f(hi) < 0``)."""
    flo = f(lo)
    assert flo * f(hi) < 0.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if f(mid) * flo > 0.0:
            lo, flo = mid, f(mid)
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _hinge_equilibrium(cmd, pre):
    """The hinge angle (rad) at which cables A, B commanded to ``cmd`` (m) with the
    pretensions ``pre`` (N) balance: ``sum_i dL_i/dq T_i = 0``, ``T_i = max(0, P_i + E A
    (L_i(q) - l_i) / l_i)`` (routing length 0), ``dL/dq`` by central differences."""

    def moment(q):
        h = 1e-7
        dl = (_hinge_lengths(q + h) - _hinge_lengths(q - h)) / (2 * h)
        t = np.maximum(0.0, pre + _EA * (_hinge_lengths(q) - cmd) / cmd)
        return float(dl @ t)

    return _hinge_root(moment)


def _hinge_settle(cdsm, text, cmd):
    """The core plant's settled hinge angle (rad) for the realised lengths ``cmd`` (m)."""
    from cdsm import plant

    robot = cdsm.Robot.from_toml_str(text)
    ref = reference.read_robot(text)
    dl = cmd - reference.cable_lengths(ref, np.zeros((1, 1)))[0]
    obs, ok = plant.predict(robot, np.zeros(plant.size(robot)), np.zeros((1, 1)), dl[None, :], "absolute")
    assert ok.all()
    return float(obs[0, 5])  # the rotation vector's z: the hinge angle


def test_hinge_settles_at_the_stiffness_weighted_equilibrium(cdsm_core):
    """Cable A commanded 1 mm short: the stiff short cable B barely gives, the long
    cable A takes most of the mismatch -- the angle the hand-computed balance gives (the
    unweighted least squares on the lengths, the settle before issue 35, splits the
    mismatch evenly: about five times the angle)."""
    cmd = _hinge_lengths(0.0) - np.array([1e-3, 0.0])
    want = _hinge_equilibrium(cmd, np.zeros(2))
    even = _hinge_root(lambda q: float(((_hinge_lengths(q + 1e-7) - _hinge_lengths(q - 1e-7)) / 2e-7)
                                       @ (_hinge_lengths(q) - cmd)))
    got = _hinge_settle(cdsm_core, _hinge_text(), cmd)
    assert abs(got - want) < 1e-9
    assert abs(even) > 4 * abs(want) > 0.0


def test_position_pretension_shortens_the_commands(cdsm_core):
    """Consistent commands at 0, 10 N on cable A and 2 N on B: each is taken in by ``P L
    / (E A)``, and the hinge turns to the balance of the two pretensioned springs
    (hand-computed); without a pretension it stays at 0, and with equal ones too (equal
    moment arms at 0: each cable carries its pretension there)."""
    cmd = _hinge_lengths(0.0)
    assert abs(_hinge_settle(cdsm_core, _hinge_text(), cmd)) < 1e-12
    assert abs(_hinge_settle(cdsm_core, _hinge_text(10.0, 10.0), cmd)) < 1e-12
    want = _hinge_equilibrium(cmd, np.array([10.0, 2.0]))
    got = _hinge_settle(cdsm_core, _hinge_text(10.0, 2.0), cmd)
    assert abs(want) > 1e-4
    assert abs(got - want) < 1e-9
    ref = reference.read_robot(_hinge_text(10.0, 2.0))
    ref_eq = elastic.equilibrium(ref, lengths=cmd[None, :], seed=np.zeros((1, 1)))
    assert abs(ref_eq["theta"][0, 0] - want) < 1e-9


@pytest.mark.parametrize("value, problem", [(-1.0, ">= 0"), (float("inf"), ">= 0"), (float("nan"), ">= 0")])
def test_position_pretension_refused_when_bad(cdsm_core, value, problem):
    """A position cable's pretension is N, finite and >= 0 (both readers name the field;
    the reference counts cables from 1)."""
    text = _hinge_text(pa=value)
    with pytest.raises(ValueError, match=r"cables\[0\]\.pretension.*" + problem):
        cdsm_core.Robot.from_toml_str(text)
    with pytest.raises(ValueError, match=r"cables\[1\]\.pretension"):
        reference.read_robot(text)


def test_position_pretension_refused_where_the_statics_fix_the_tensions(cdsm_core):
    """As many position cables as joints (cable B made a force cable): a position
    cable's pretension would change nothing, so the file is refused naming the field;
    on a force cable the key is refused too."""
    square = _hinge_text(pa=5.0).replace('mode = "position"\nholes = [[0.0, -0.01',
                                         'mode = "force"\ntension = 1.0\nholes = [[0.0, -0.01')
    with pytest.raises(ValueError, match=r"cables\[0\]\.pretension`?: a position cable's pretension needs more"):
        cdsm_core.Robot.from_toml_str(square)
    with pytest.raises(ValueError, match=r"cables\[1\]\.pretension: a position cable's pretension needs more"):
        reference.read_robot(square)
    force = _hinge_text(pb=5.0).replace('mode = "position"\nholes = [[0.0, -0.01',
                                        'mode = "force"\ntension = 1.0\nholes = [[0.0, -0.01')
    with pytest.raises(ValueError, match=r"cables\[1\]\.pretension`?: only position and displacement"):
        cdsm_core.Robot.from_toml_str(force)


def test_position_pretension_refused_without_a_stated_cable(cdsm_core):
    """The hinge without its ``[cable]`` table: it settles in least squares on the
    lengths, where a pretension would change nothing, so the file is refused naming the
    field (both readers)."""
    text = re.sub(r"\[cable\]\nyoungs_modulus = .*\ndiameter = .*\n", "", _hinge_text(pb=5.0))
    assert "[cable]" not in text
    with pytest.raises(ValueError, match=r"cables\[1\]\.pretension`?: a position cable's pretension needs the "
                       r"arm's cable stated"):
        cdsm_core.Robot.from_toml_str(text)
    with pytest.raises(ValueError, match=r"cables\[2\]\.pretension: a position cable's pretension needs the "
                       r"arm's cable stated"):
        reference.read_robot(text)


def test_position_pretension_round_trips_through_the_file(cdsm_core):
    robot = cdsm_core.Robot.from_toml_str(_hinge_text(pa=2.5))
    again = cdsm_core.Robot.from_toml_str(robot.to_toml())
    assert again.to_toml() == robot.to_toml()
    assert "pretension = 2.5" in robot.to_toml()
