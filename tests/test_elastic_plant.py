"""The plant of an elastic arm (``docs/model.md``, "The plant", "Elastic arms"): the
commands of its elastic cables, the effects (actuation, offsets, backlash, joint
stiffness per segment, cable angles, tip marker, frame) and the elastic settle warm-started
along the sequence, its Jacobian by the implicit function theorem, and fits of the
effects.  Checked against the independent NumPy reference (``cdsm.reference.elastic``),
central differences, ``Robot.equilibrium``, and a synthetic recovery.  SI units."""

from __future__ import annotations

import numpy as np
import pytest

import cdsm
from cdsm import CdsmInputError
from cdsm.calibration import plant
from cdsm.calibration.diagnosis import Prepared
from cdsm.calibration.fit import fit
from cdsm.calibration.measurements import commanded_cables
from cdsm.reference import elastic, read_robot
from cdsm.robot import kind_facts
from elastic_cases import mixed_text, planar_text, rod_toml


def two_segments() -> str:
    """2 segments x 4 links (two bending joints each, springs from the backbone), six
    displacement cables with pretension at 60 degree steps: three end at disk 4, three at
    disk 8; a cable of finite E A (the series stiffness depends on its rest length); plates
    1 mm thick (a hole of a plate of no thickness moved alone makes a traversal ``|dh|``,
    not differentiable at 0)."""
    cables = "".join(
        f'[[cables]]\nend = {end}\nmode = "displacement"\nradius = 0.004\nangle = {a!r}\nstiffness = 3000.0\n'
        "pretension = 1.0\n"
        for end, a in ((4, 0.0), (4, 2.0944), (4, 4.18879), (8, 1.0472), (8, 3.14159), (8, 5.23599)))
    return thick(rod_toml(8, 0.12, cables, joints="yz").replace("youngs_modulus = 1e30", "youngs_modulus = 2e9"))


def thick(text: str) -> str:
    """The arm of ``text`` with plates 1 mm thick."""
    assert "thickness = 0.0\n" in text
    return text.replace("thickness = 0.0\n", "thickness = 0.001\n")


def commands(robot, rows: int, seed: int, lo: float = 0.0, hi: float = 1.5e-3):
    """``rows`` displacement commands (pulls within ``[lo, hi]`` m) at the rest angles:
    ``theta_cmd`` = rest, ``dL`` = minus the displacements on the displacement cables,
    1 to 2 mm shorter than nominal on the position cables (taut)."""
    rng = np.random.default_rng(seed)
    cmd = commanded_cables(robot)
    pos = [robot.cable_modes[c] == "position" for c in cmd]
    d = rng.uniform(lo, hi, (rows, len(cmd)))
    d[:, pos] = rng.uniform(1e-3, 2e-3, (rows, sum(pos)))
    return np.tile(robot.rest_angles, (rows, 1)), -d


EFFECTS_TWO = {
    "actuation_scale": [0.03],
    "cable_offset": [2e-4, -1e-4, 1.5e-4, -2e-4, 1e-4, 0.5e-4],
    "backlash": [3e-5, 1e-5, 2e-5, 4e-5, 1e-5, 2e-5],
    "joint_stiffness": [0.15, -0.1],
    "cable_angle": [0.02, -0.01, 0.015, -0.02, 0.01, 0.03],
    "frame_misalignment": [0.004, -0.003, 0.005, 0.002, -0.001, 0.003],
    "tip_offset": [0.002, 0.001, -0.0015],
}


# --------------------------------------------------------------------------
# Layout, commands, bounds
# --------------------------------------------------------------------------
def test_an_elastic_arm_has_its_blocks_and_a_rigid_arm_its_kinds():
    """Elastic arms: the blocks of the elastic settle, ``joint_stiffness`` per segment
    (the joints between consecutive cable terminations), ``cable_angle`` per commanded
    cable and ``cable_friction`` last; no ``cable_elasticity``, ``hole_clearance``.  Every
    packaged rigid robot: its kind's layout, as before."""
    robot = cdsm.Robot.from_toml_str(two_segments())
    lay = plant.layout(robot)
    assert list(lay) == ["actuation_scale", "cable_offset", "hole_position", "link_length", "frame_misalignment",
                         "tip_offset", "backlash", "joint_axis", "joint_stiffness", "cable_angle", "cable_friction"]
    assert lay["joint_stiffness"].stop - lay["joint_stiffness"].start == 2
    assert lay["cable_angle"].stop - lay["cable_angle"].start == 6
    assert plant.commands(robot) == 6
    labels = [lab for b, lab, _ in plant.parameter_labels(robot) if b == "joint_stiffness"]
    assert labels == ["segment of joints 1–8 (springs 1 + s)", "segment of joints 9–16 (springs 1 + s)"]
    lo, hi = plant.bounds(robot)
    assert (lo[lay["joint_stiffness"]] == -0.9).all() and (hi[lay["cable_angle"]] == np.pi).all()
    # the default library: the per-hole, per-link and per-axis geometry and friction only when named
    assert plant.effects_of(robot) == ("actuation_scale", "cable_offset", "frame_misalignment", "tip_offset",
                                       "backlash", "joint_stiffness", "cable_angle")
    assert plant.check_effects(robot, ["hole_position", "joint_axis", "cable_friction"]) == [
        "hole_position", "joint_axis", "cable_friction"]
    with pytest.raises(CdsmInputError, match="hole_clearance"):
        plant.check_effects(robot, ["hole_clearance"])
    mixed = cdsm.Robot.from_toml_str(mixed_text())
    # the mixed arm commands its three displacement cables and its position cable
    assert commanded_cables(mixed) == [0, 1, 2, 4]
    assert len(elastic.segments(read_robot(mixed_text()))) == 3
    for name in ("paper", "paper_spatial", "serpentine8", "two_universal", "sjtu_snake"):
        r = cdsm.Robot.packaged(name)
        assert [b for b, _ in r.core.plant_effects()] == list(kind_facts(r.kind)["layout"]), name
        assert plant.effects_of(r) == (plant.EFFECTS if r.kind == "planar" else plant.SPATIAL_EFFECTS)


def test_bad_commands_are_refused_naming_the_field():
    robot = cdsm.Robot.from_toml_str(two_segments())
    t, dl = commands(robot, 3, 0)
    with pytest.raises(CdsmInputError, match="dL"):
        plant.predict(robot, np.zeros(plant.size(robot)), t, dl[:, :5])
    p = plant.params(robot, {"joint_stiffness": [-0.95, 0.0]})
    with pytest.raises(CdsmInputError, match="joint_stiffness"):
        plant.check_params(robot, p)
    obs, ok = plant.predict(robot, p, t, dl)  # outside the physical domain: no row predicted
    assert not ok.any() and np.isnan(obs).all()


# --------------------------------------------------------------------------
# Predictions: the reference, Robot.equilibrium
# --------------------------------------------------------------------------
@pytest.mark.parametrize("text", [two_segments(), mixed_text()], ids=["two_segments", "mixed"])
def test_predictions_match_the_reference(text):
    """Every effect of the elastic plant at once, absolute and displacement rows in one
    sequence (backlash and the warm start run over both): the reference's observations
    (measured: 1e-15 m)."""
    robot = cdsm.Robot.from_toml_str(text)
    ref = read_robot(text)
    t, dl = commands(robot, 8, 1)
    kind = ["absolute", "displacement", "absolute", "absolute", "unmeasured", "displacement", "absolute",
            "absolute"]
    m = plant.commands(robot)
    segs = len(elastic.segments(ref))
    eff = {"actuation_scale": [0.03], "cable_offset": np.linspace(-2e-4, 2e-4, m),
           "backlash": np.linspace(1e-5, 4e-5, m), "joint_stiffness": np.linspace(-0.1, 0.2, segs),
           "cable_angle": np.linspace(-0.02, 0.03, m), "frame_misalignment": EFFECTS_TWO["frame_misalignment"],
           "tip_offset": EFFECTS_TWO["tip_offset"]}
    obs, ok = plant.predict(robot, plant.params(robot, eff), t, dl, kind)
    want, want_ok = elastic.plant_predict(ref, t, dl, kind, eff)
    np.testing.assert_array_equal(ok, want_ok)
    assert ok.all()
    np.testing.assert_allclose(obs, want, rtol=0, atol=1e-12)
    # the effects matter here: far above the agreement
    nominal, _ = plant.predict(robot, np.zeros(plant.size(robot)), t, dl, kind)
    assert np.nanmax(np.abs(nominal - obs)) > 1e-4


def test_zero_parameters_are_the_equilibrium_of_the_same_commands():
    """All-zero parameters: each row's tip is the forward kinematics of
    ``Robot.equilibrium(displacements=-dL, sequence=True)`` (the warm start along the
    rows), and the settled angles are its angles."""
    robot = cdsm.Robot.from_toml_str(two_segments())
    t, dl = commands(robot, 12, 2, lo=-3e-3, hi=1e-3)
    obs, ok = plant.predict(robot, np.zeros(plant.size(robot)), t, dl)
    theta, _ = plant.settle(robot, np.zeros(plant.size(robot)), t, dl)
    eq = robot.equilibrium(displacements=-dl, sequence=True)
    assert ok.all() and eq.converged.all() and eq.slack.any()
    np.testing.assert_allclose(theta, eq.theta, rtol=0, atol=1e-13)
    np.testing.assert_allclose(obs, robot.fk(eq.theta), rtol=0, atol=1e-15)


# --------------------------------------------------------------------------
# The Jacobian
# --------------------------------------------------------------------------
@pytest.mark.parametrize("text", [two_segments(), thick(mixed_text())], ids=["two_segments", "mixed"])
def test_jacobian_is_central_differences_of_the_predictions(text):
    """Every parameter of the elastic plant but friction (the realised lengths, springs,
    cable angles, holes, links, joint axes, marker, frame): the exact Jacobian (implicit function
    theorem) against central differences of the predictions (measured: 1e-8 of the
    largest entry)."""
    robot = cdsm.Robot.from_toml_str(text)
    t, dl = commands(robot, 5, 3, lo=0.3e-3)
    kind = ["absolute", "displacement", "absolute", "absolute", "absolute"]
    lay = plant.layout(robot)
    eff = {k: v for k, v in EFFECTS_TWO.items() if k in ("actuation_scale", "frame_misalignment", "tip_offset")}
    eff.update(cable_offset=np.full(plant.commands(robot), 1e-4), backlash=np.full(plant.commands(robot), 2e-5),
               joint_stiffness=np.full(lay["joint_stiffness"].stop - lay["joint_stiffness"].start, 0.1),
               cable_angle=np.full(plant.commands(robot), 0.01))
    p = plant.params(robot, eff)
    # all but the last, friction (at mu = 0 one-sided: tests/test_elastic_friction.py)
    free = np.arange(lay["cable_friction"].start)
    obs, ok, jac = plant.linearise(robot, p, free, t, dl, kind)
    assert ok.all() and np.isfinite(jac).all()
    scale, fd = _central_differences(robot, p, free, t, dl, kind)
    cols = np.abs(jac).max(axis=(0, 1)) * scale
    assert (cols[lay["joint_stiffness"]] > 1e-4).all() and (cols[lay["cable_angle"]] > 1e-5).all()
    np.testing.assert_allclose(jac * scale, fd * scale, rtol=0, atol=1e-8 * np.abs(jac * scale).max())


def _central_differences(robot, p, free, t, dl, kind):
    """Each free parameter's typical size (:data:`plant.TYPICAL`, (k,)) and
    the predictions' central differences (N, w, k) with steps of 1e-3 of it."""
    scale = np.array([plant.TYPICAL[b] for b, _ in plant.parameter_blocks(robot, free)])
    fd = np.empty((len(t), plant.width(robot), len(free)))
    for j, i in enumerate(free):
        h = 1e-3 * scale[j]
        up, dn = p.copy(), p.copy()
        up[i] += h
        dn[i] -= h
        fd[:, :, j] = (plant.predict(robot, up, t, dl, kind)[0] - plant.predict(robot, dn, t, dl, kind)[0]) / (2 * h)
    return scale, fd


def test_planar_jacobian_is_central_differences_of_the_predictions():
    """A sprung planar arm under gravity (the paper's arm with springs and rest angles;
    position cables): every parameter's exact Jacobian (the adjoint of the implicit
    function theorem, the observation's derivative along a motion of the plane's base
    frame) against central differences of the predictions, attitude included."""
    robot = cdsm.Robot.from_toml_str(planar_text())
    t, dl = commands(robot, 4, 5)
    kind = ["absolute", "displacement", "absolute", "absolute"]
    lay = plant.layout(robot)
    p = np.zeros(plant.size(robot))
    rng = np.random.default_rng(2)
    for name, size in (("frame_misalignment", 0.02), ("tip_offset", 2e-3), ("cable_offset", 2e-4),
                       ("hole_height", 1e-4), ("link_length", 1e-4), ("joint_stiffness", 0.1),
                       ("actuation_scale", 0.01), ("backlash", 2e-5)):
        sl = lay[name]
        p[sl] = size * (rng.uniform(0.5, 1.0, sl.stop - sl.start) if name == "backlash"
                        else rng.uniform(-1.0, 1.0, sl.stop - sl.start))
    free = np.arange(lay["cable_friction"].start)  # frictionless: friction's derivative has its own test
    obs, ok, jac = plant.linearise(robot, p, free, t, dl, kind)
    assert ok.all() and np.isfinite(jac).all()
    scale, fd = _central_differences(robot, p, free, t, dl, kind)
    assert (np.abs(jac[:, 2, lay["frame_misalignment"]]) > 0.5).any()  # the attitude sees the frame
    np.testing.assert_allclose(jac * scale, fd * scale, rtol=0, atol=1e-8 * np.abs(jac * scale).max())


# --------------------------------------------------------------------------
# Fits
# --------------------------------------------------------------------------
@pytest.mark.parametrize("names", [["joint_stiffness", "cable_angle", "tip_offset", "frame_misalignment"],
                                   ["cable_offset", "tip_offset", "frame_misalignment"]], ids=["springs", "offsets"])
def test_a_fit_recovers_known_effects(names):
    """Noise-free tips of the two-segment arm (taut and slack cables) with known segment
    stiffnesses, cable angles, a marker offset and a frame — or known cable offsets —
    fitted back from zero by ``cdsm.calibration.fit`` (positions only, as a motion-capture
    marker measures; measured: 1e-10 relative).  Offsets and segment stiffnesses together
    are not separable: a common offset of a segment's three cables at 120 degrees bends
    nothing (singular values below 1e-6 of the largest)."""
    robot = cdsm.Robot.from_toml_str(two_segments())
    t, dl = commands(robot, 60, 4, lo=-1e-3, hi=3e-3)
    truth = plant.params(robot, {k: EFFECTS_TWO[k] for k in names})
    f, idx = fit_tips(robot, t, dl, truth, names)
    np.testing.assert_allclose(f.p[idx], truth[idx], rtol=1e-8, atol=0)
    assert f.rms < 1e-12 and np.isfinite(f.std).all()


def fit_tips(robot, t, dl, truth, names):
    """``names`` fitted from zero by ``cdsm.calibration.fit`` to the tip positions the
    plant at ``truth`` predicts for the absolute rows ``t``, ``dl`` (positions only, as a
    motion-capture marker measures): the fit and the fitted parameters' indices."""
    obs, ok = plant.predict(robot, truth, t, dl)
    assert ok.all()
    N = len(t)
    measured = np.full((N, 6), np.nan)
    measured[:, :3] = obs[:, :3]
    prep = Prepared(robot, None, t, dl, np.zeros(N, np.uint8), measured, np.ones(N, bool), {}, np.arange(N))
    return fit(prep, names), np.concatenate([plant.effect_indices(robot, e) for e in names])
