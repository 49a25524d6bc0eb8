"""Both arm kinds through the same doors (issue 22): a robot is named the
same way everywhere, the command line checks effects against the robot's own
library before it reads any data, nothing refused is refused late, and no
RuntimeWarning reaches the user. Each test reproduces a reported bug."""

from __future__ import annotations

import dataclasses
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

ROBOTS = Path(__file__).resolve().parents[1] / "python" / "cdsm" / "robots"


def _all_position_two_universal(cdsm):
    """``two_universal`` with every force cable made position-controlled (8
    position cables on 4 joints)."""
    text = (ROBOTS / "two_universal.toml").read_text()
    text, count = re.subn(r'mode = "force"\ntension = [0-9.]+\n', 'mode = "position"\n', text)
    assert count == 4
    return cdsm.Robot.from_toml_str(text)


# ---------------------------------------------------------------------------
# one rule for naming a robot
# ---------------------------------------------------------------------------
def test_a_packaged_name_is_a_robot_everywhere(cdsm, tmp_path):
    r = cdsm.Robot.from_toml("two_universal")
    assert r.kind == "spatial" and r.n == 4
    assert cdsm.Robot.from_toml(ROBOTS / "paper.toml").n == 3
    with pytest.raises(cdsm.CdsmInputError) as exc:
        cdsm.Robot.from_toml("two_universall")
    msg = str(exc.value)
    assert "two_universall" in msg and "two_universal" in msg.split("packaged:")[1] and "paper" in msg
    # a file of that name in the working directory wins over the packaged robot
    (tmp_path / "two_universal").write_text((ROBOTS / "paper.toml").read_text())
    assert cdsm.Robot.from_toml(tmp_path / "two_universal").kind == "planar"


# ---------------------------------------------------------------------------
# the command line checks what it can before reading the data
# ---------------------------------------------------------------------------
def _cli(capsys, argv):
    from cdsm import cli

    rc = cli.main(argv)
    return rc, capsys.readouterr().err


def test_cli_effects_follow_the_robots_kind(cdsm, tmp_path, capsys):
    """``hole_position`` is a spatial effect, ``hole_height`` a planar one:
    each refused for the other kind, named, before the data file is read."""
    absent = str(tmp_path / "no-such-data.csv")
    rc, err = _cli(capsys, ["diagnose", absent, "--robot", "two_universal", "--effects", "hole_height"])
    assert rc == 2 and "hole_height" in err and "spatial" in err and "no-such-data" not in err
    rc, err = _cli(capsys, ["diagnose", absent, "--effects", "hole_position"])
    assert rc == 2 and "hole_position" in err and "planar" in err and "no-such-data" not in err
    # accepted for its own kind: the next complaint is the missing file
    rc, err = _cli(capsys, ["diagnose", absent, "--robot", "two_universal", "--effects", "hole_position"])
    assert rc == 2 and "no-such-data" in err


def test_suggest_designs_measurements_for_a_spatial_arm(cdsm, tmp_path, capsys):
    """Experiment design on a spatial arm: proposals in its own columns
    (theta_1..4, dL on its 4 position cables, x, y, z), predicted in 3-D,
    approached from both sides when a candidate has backlash, and the file
    reads back as a spatial measurement table."""
    from cdsm.calibration import diagnosis, experiment, measurements, plant

    robot = cdsm.Robot.packaged("two_universal")
    vp = plant.VirtualPrototype(robot, {"backlash": [4e-5, 3e-5, 2e-5, 3e-5]}, noise=1e-5, seed=0)
    th, dl = vp.random_commands(12)
    d = diagnosis.diagnose(robot, vp.measure(th, dl), effects=["backlash", "cable_offset"], folds=3,
                           noise=1e-5, frame="base")
    s = experiment.suggest(d, 3, pool=60)
    assert len(s) == 3 and s.theta.shape == (3, 4) and s.dL.shape == (3, 4)
    assert all(p.shape == (3, 3) for p in s.predictions.values())
    assert s.approach is not None  # a candidate with backlash: approach moves
    path = s.to_csv(tmp_path / "s.csv")
    header = [ln for ln in open(path).read().splitlines() if not ln.startswith("#")][0].split(",")
    assert header[:9] == ["point"] + [f"theta_{i}" for i in range(1, 5)] + [f"dL_{i}" for i in range(1, 5)]
    assert "z_nom" in header and "rz_nom" in header
    # measured as proposed: x, y, z added, empty on the approach rows
    lines = open(path).read().splitlines()
    body = [ln for ln in lines if not ln.startswith("#")]
    pred = next(iter(s.predictions.values()))
    rows = [body[0] + ",x,y,z"]
    for k, ln in enumerate(body[1:]):
        rows.append(ln + (",,," if k % 2 == 0 else "," + ",".join(repr(float(v)) for v in pred[k // 2])))
    (tmp_path / "m.csv").write_text("\n".join(rows) + "\n")
    back = measurements.read_for(robot, str(tmp_path / "m.csv"))
    assert len(back) == 6 and back.observed.tolist() == [False, True] * 3


# ---------------------------------------------------------------------------
# no RuntimeWarning reaches the user
# ---------------------------------------------------------------------------
def test_a_spatial_diagnosis_with_undetermined_fits_warns_nothing(cdsm):
    """The all-position arm: elasticity fits that cannot be evaluated (the
    review saw an overflow in the correlation, an SVD that did not converge
    and an All-NaN slice in the features) end as failed candidates, quietly."""
    from cdsm.calibration import diagnosis, plant

    robot = _all_position_two_universal(cdsm)
    vp = plant.VirtualPrototype(robot, {"tip_offset": [1e-3, 0.0, -1e-3]}, noise=1e-5, seed=2)
    th, dl = vp.random_commands(20)
    m = vp.measure(th, dl)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        d = diagnosis.diagnose(robot, m, effects=["cable_elasticity", "tip_offset"], folds=3, noise=1e-5)
    assert d.best is not None and "tip_offset" in d.best



# ---------------------------------------------------------------------------
# linear sensitivities and the equal-effect tolerance shape, spatial arms
# ---------------------------------------------------------------------------
def test_spatial_sensitivities_are_the_reference_solves_differentiated(cdsm, ref):
    """d(tip)/d(cable length) and d(tip)/d(hole) of two_universal against
    central differences of the NumPy reference's own cable solves."""
    from cdsm.accuracy.sensitivity import sensitivities

    robot = cdsm.Robot.packaged("two_universal")
    mirror = ref.load_robot(ROBOTS / "two_universal.toml")
    theta = np.random.default_rng(3).uniform(-0.4, 0.4, (4, 4))
    s = sensitivities(robot, theta, holes=True)
    assert s.ok.all() and s.cable.shape == (4, 6, 4) and s.coords.shape == (4, 6, len(robot.flat_holes))
    pos = ref.position_cables(mirror)
    L0 = ref.cable_lengths(mirror, theta)[:, pos]
    h = 1e-6

    def tips(m, lengths):
        sol = ref.solve_cables(m, lengths, seed=theta)
        assert sol["converged"].all()
        return ref.fk_matrix(m, sol["theta"])[:, :3, 3]

    for k in range(4):
        d = np.zeros(4)
        d[k] = h
        fd = (tips(mirror, L0 + d) - tips(mirror, L0 - d)) / (2 * h)
        np.testing.assert_allclose(s.cable[:, :3, k], fd, atol=1e-7)
    flat = robot.flat_holes
    for j in (3, 13, 25, 40):  # a few hole coordinates of position cables
        e = np.zeros_like(flat)
        e[j] = h

        def moved(sign):
            holes, k = [], 0
            for hh in mirror.holes:
                holes.append((flat + sign * e)[k:k + hh.size].reshape(hh.shape))
                k += hh.size
            return dataclasses.replace(mirror, holes=tuple(holes))

        fd = (tips(moved(1.0), L0) - tips(moved(-1.0), L0)) / (2 * h)
        np.testing.assert_allclose(s.coords[:, :3, j], fd, atol=1e-7)


def test_a_spatial_allocation_starts_from_its_linear_guess_and_meets_the_target(cdsm):
    from cdsm.accuracy import tolerance
    from cdsm.accuracy.sampling import sample_configurations
    from cdsm.accuracy.sensitivity import sensitivities

    robot = cdsm.Robot.packaged("two_universal")
    theta = sample_configurations(robot, 40)
    for shape in ("ratio", "equal-effect"):
        a = tolerance.allocate(robot, 0.5e-3, theta, percentile=95, shape=shape, samples=200, seed=1)
        assert a.holds and np.isfinite(a.alpha_linear) and a.achieved_m <= 0.5e-3
        assert 0.5 < a.alpha / a.alpha_linear < 2.0  # the linear guess is near the answer
    # equal-effect: every group adds the same linear variance over the region
    sens = sensitivities(robot, theta, holes=True)
    em = np.concatenate([sens.cable[:, :3], sens.coords[:, :3]], axis=2)
    full = np.concatenate([a.cable_length_tol_m, tolerance.hole_tolerances(robot, a.hole_tol_m)])
    var = ((em ** 2).sum(axis=1).mean(axis=0)) * full ** 2
    m = len(robot.position_cables)
    groups = [var[:m][i] for i in range(m)]
    starts = np.cumsum([0] + [3 * (2 * e + 1) for e in robot.cable_ends])
    groups += [var[m + starts[c]:m + starts[c + 1]].sum() for c in range(robot.cables)
               if c in robot.position_cables]
    assert np.ptp(groups) <= 1e-9 * max(groups)


def test_configuration_choice_in_the_null_space_of_a_redundant_spatial_arm(cdsm):
    """two_universal on tip positions (4 joints, 3 matched rows: one null
    direction): the chosen configurations keep the tip where it is, are
    never more sensitive than the default, and the Monte Carlo agrees."""
    from cdsm.accuracy import configurations as cf

    robot = cdsm.Robot.packaged("two_universal")
    th = np.random.default_rng(1).uniform(-0.4, 0.4, (6, 4))
    targets = robot.fk(th)
    res = cf.best_configurations(robot, targets, iters=20, starts=2)
    assert res["ok"].all()
    np.testing.assert_allclose(robot.fk(res["theta_best"])[:, :3], targets[:, :3], atol=1e-9)
    assert (res["rms_best"] <= res["rms_default"]).all() and (res["rms_best"] < res["rms_default"]).any()
    path = cf.path_configurations(robot, targets[:3], iters=10)
    np.testing.assert_allclose(robot.fk(path["theta"])[:, :3], targets[:3, :3], atol=1e-9)
    c = cf.compare_with_default(robot, targets, best=res, samples=200)
    assert c["median_ratio"] <= 1.0


# ---------------------------------------------------------------------------
# the Monte-Carlo quantities of both kinds
# ---------------------------------------------------------------------------
def _weakly_held_two_universal(redundant: bool) -> str:
    """``two_universal`` with 0.01 N force cables (slack on about half of the
    joint box); ``redundant``: its 180-degree cables position-controlled too
    (6 position cables on 4 joints) and gravity along +y."""
    text = re.sub(r"tension = [0-9.]+\n", "tension = 0.01\n", (ROBOTS / "two_universal.toml").read_text())
    if redundant:
        text, count = re.subn(r'mode = "force"\ntension = [0-9.]+\n(radius = [0-9.]+\nangle = 3.14)',
                              r'mode = "position"\n\1', text)
        assert count == 2
        text = text.replace("gravity = [0.0, 0.0, -9.80665]", "gravity = [0.0, 9.80665, 0.0]")
    return text


@pytest.mark.parametrize("redundant", [False, True])
def test_spatial_monte_carlo_counts_slack_samples_as_the_reference_statics(cdsm, ref, redundant):
    """With one sample per configuration, ``slack`` is exactly the NumPy
    reference's verdict on that sample's solved configuration, with the
    sample's holes for the moment arms: no taut set of position tensions
    (the square balance, or the minimum-norm set above 0 with 6 position
    cables on 4 joints)."""
    from cdsm.accuracy.montecarlo import monte_carlo, sample_errors

    text = _weakly_held_two_universal(redundant)
    r, nominal = cdsm.Robot.from_toml_str(text), ref.read_robot(text)
    assert len(r.position_cables) == (6 if redundant else 4)
    theta = np.random.default_rng(3).uniform(-0.6, 0.6, (60, r.n))
    mc = monte_carlo(r, theta, samples=1, seed=11, chunk=1, progress=False, check_slack=True)
    m, h = len(r.position_cables), len(r.flat_holes)
    dl, dh = sample_errors(r.n, 1, 11, 0, np.full(m, 1e-3), np.full(h, 0.35e-3))
    d = cdsm.accuracy.deviation(r, theta, dL=dl[0], dholes=dh[0])
    assert d.ok.all()
    sizes = [x.size for x in nominal.holes]
    parts = np.split(np.concatenate([x.ravel() for x in nominal.holes]) + dh[0], np.cumsum(sizes)[:-1])
    moved = dataclasses.replace(nominal, holes=tuple(p.reshape(x.shape) for p, x in zip(parts, nominal.holes)))
    _, taut = ref.feasible_tensions(moved, d.solution.theta)
    np.testing.assert_array_equal(mc.slack, (~taut).astype(int))
    assert 0 < mc.slack.sum() < len(theta)
    plain = monte_carlo(r, theta, samples=1, seed=11, chunk=1, progress=False)
    assert plain.slack is None
    np.testing.assert_array_equal(plain.sum, mc.sum)


# ---------------------------------------------------------------------------
# the rotation vector of fk() (issue 32, item 12)
# ---------------------------------------------------------------------------
def _rotation_vector_mp(R, mp):
    """The rotation vector of the 3 x 3 matrix ``R`` in 40-digit arithmetic:
    its unit quaternion (the largest of 2w, 2x, 2y, 2z from the diagonal,
    the rest from the off-diagonal sums and differences), then the angle
    2 atan2(|q|, w) along q/|q|."""
    m = [[mp.mpf(float(R[i][j])) for j in range(3)] for i in range(3)]
    d = [m[0][0], m[1][1], m[2][2]]
    tr = d[0] + d[1] + d[2]
    sk = (m[2][1] - m[1][2], m[0][2] - m[2][0], m[1][0] - m[0][1])
    sy = (m[1][2] + m[2][1], m[0][2] + m[2][0], m[0][1] + m[1][0])
    if tr >= max(d):
        w = mp.sqrt(1 + tr) / 2
        q = [w] + [s / (4 * w) for s in sk]
    else:
        k = max(range(3), key=lambda i: d[i])
        v = mp.sqrt(1 + 2 * d[k] - tr) / 2
        q = [sk[k] / (4 * v), None, None, None]
        q[1 + k] = v
        for i in range(3):
            if i != k:
                q[1 + i] = sy[3 - i - k] / (4 * v)
    if q[0] < 0:
        q = [-v for v in q]
    s = mp.sqrt(q[1] ** 2 + q[2] ** 2 + q[3] ** 2)
    f = 2 * mp.atan2(s, q[0]) / s if s else 2 / q[0]
    return [float(v * f) for v in q[1:]]


def test_fk_rotation_vector_is_exact_to_rounding_at_every_angle(cdsm):
    """fk()'s rotation vector against the logarithm of the same rotation
    matrix (``fk_matrix``) in 40-digit arithmetic (mpmath), about a joint
    axis and about two tilted axes, from 1e-9 rad to just below pi, densely
    between 0.1 and 0.2 rad: ``log_so3``'s series (used below 0.2 rad) was
    cut off after its u^10 term, 1.5e-14 rad off at 0.2 rad. Within 4e-16
    rad below 1 rad and four units in the last place of the angle above."""
    import mpmath

    mpmath.mp.dps = 40
    r = cdsm.Robot.packaged("two_universal")
    t = np.concatenate([np.geomspace(1e-9, 0.1, 100), np.linspace(0.1, 0.2, 501),
                        np.linspace(0.2, np.pi - 1e-6, 200)])
    theta = np.zeros((3 * len(t), r.n))
    theta[:len(t), 0] = t  # pitch alone: the angle is t
    theta[len(t):2 * len(t), :2] = np.outer(t, [0.6, 0.8])
    theta[2 * len(t):, :2] = np.outer(t, [-0.28, 0.96])
    got = r.fk(theta)[:, 3:]
    want = np.array([_rotation_vector_mp(R, mpmath) for R in r.fk_matrix(theta)[:, :3, :3]])
    angle = np.linalg.norm(want, axis=1)
    np.testing.assert_allclose(angle[:len(t)], t, rtol=0, atol=1e-15)
    assert ((angle > 0.1) & (angle < 0.2)).sum() > 1000 and angle.max() > 3.1
    err = np.abs(got - want).max(axis=1)
    allowed = np.maximum(4e-16, 4 * np.spacing(angle))
    worst = np.argmax(err / allowed)
    assert (err <= allowed).all(), f"off by {err[worst]:.3g} rad at {angle[worst]:.6f} rad"
