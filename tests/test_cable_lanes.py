"""The general cable solve on lanes (issue 22, speed): a batch of cable
solves of a spatial arm, and its Monte Carlo, run the Newton phase of the
damped solver several rows at a time (``docs/model.md``, "Solves"), and the
rows that leave it (a rejected step, a singular Jacobian, the iteration
limit) through the damped solver from their seeds. Parity with the
independent NumPy reference (``cdsm.reference``, written from
``docs/spatial.md``) on random rows of an 8-joint arm — near and far seeds,
cables too long to reach, rows that end at the iteration limit, enforced
joint limits — and of the 24-joint SJTU snake (more cables than joints:
least squares). SI units: m, rad."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import ROOT, reference



def _eight_joint_toml(sections: int = 4) -> str:
    """Four universal-joint sections (pitch about y, yaw about z), two
    position and two force cables ending at each disk (the ``two_universal``
    pattern continued; the 8-joint arm of ``benches/bench_scale.py``)."""
    lines = ['kind = "spatial"', 'name = "eight joints"', "gravity = [0.0, 0.0, -9.80665]", "",
             "[base]", "radius = 0.03", ""]
    for _ in range(sections):
        lines += ["[[linkage]]", "joints = [",
                  "  { axis = [0.0, 1.0, 0.0], offset = [0.015, 0.0, 0.0], limits = [-0.6, 0.6] },",
                  "  { axis = [0.0, 0.0, 1.0], offset = [0.0, 0.0, 0.0], limits = [-0.6, 0.6] },",
                  "]", "link_after = [0.015, 0.0, 0.0]", "thickness = 0.005", "radius = 0.03",
                  "mass = 0.015", "com = [0.0025, 0.0, 0.0]", ""]
    for s in range(sections):
        for k in range(4):
            mode = 'mode = "position"' if k < 2 else 'mode = "force"\ntension = 1.0'
            lines += ["[[cables]]", f"end = {s + 1}", mode, f"radius = {0.028 - 0.002 * s:.4f}",
                      f"angle = {k * np.pi / 2!r}", ""]
    return "\n".join(lines)


@pytest.fixture(scope="module")
def eight(cdsm, ref):
    text = _eight_joint_toml()
    return cdsm.Robot.from_toml_str(text), ref.read_robot(text)


def _position_lengths(nominal, theta):
    return reference.cable_lengths(nominal, theta)[:, reference.position_cables(nominal)]


def _rows(nominal, count, seed):
    """Targets of ``count`` random configurations in +-0.55 rad and their
    seeds: most near the answer (0.05 rad), every fifth anywhere in the
    joint box; some rows with a cable 2 cm too long, or every cable 50 %
    too long (out of reach)."""
    rng = np.random.default_rng(seed)
    n = nominal.n
    th = rng.uniform(-0.55, 0.55, (count, n))
    lengths = _position_lengths(nominal, th)
    seed_ = th + rng.normal(0.0, 0.05, th.shape)
    seed_[::5] = rng.uniform(-0.6, 0.6, (len(seed_[::5]), n))
    lengths[3::17, 2] += 0.02
    lengths[7::29] *= 1.5
    return th, lengths, seed_


def test_batch_solves_are_the_references(eight):
    """203 rows (packs of four and a short one): the same rows converge as
    in the reference, to the same angles (1e-9 rad) after the same number
    of trial steps; the others are rows whose lengths were made up, and end
    with their misfit."""
    robot, nominal = eight
    _, lengths, seed = _rows(nominal, 203, 5)
    sol = robot.solve_cables(lengths, seed=seed)
    mine = reference.solve_cables(nominal, lengths, seed=seed)
    conv = np.asarray(sol.converged)
    np.testing.assert_array_equal(conv, mine["converged"])
    assert 150 < conv.sum() < 203
    np.testing.assert_allclose(np.asarray(sol.theta)[conv], mine["theta"][conv], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(np.asarray(sol.iterations)[conv], mine["iterations"][conv])
    res = np.asarray(sol.residual)
    assert np.all(res[conv] <= 1e-12) and np.all(res[~conv] > 1e-6)
    # only rows whose lengths were made up fail (every other row has an answer)
    altered = {i for i in range(203) if i % 17 == 3 or i % 29 == 7}
    assert set(np.flatnonzero(~conv)) <= altered
    assert "converged" not in set(np.asarray(sol.reason)[~conv])


def test_a_row_does_not_depend_on_its_pack_or_thread(eight):
    """A row solved alone (its pack padded), or in a batch split over two
    threads, gives the bits of the whole batch on one thread."""
    robot, nominal = eight
    _, lengths, seed = _rows(nominal, 23, 6)
    robot.threads = 1
    one = robot.solve_cables(lengths, seed=seed)
    robot.threads = 2
    two = robot.solve_cables(lengths, seed=seed)
    robot.threads = 1
    for field in ("theta", "converged", "iterations", "residual", "reason"):
        np.testing.assert_array_equal(np.asarray(getattr(one, field)), np.asarray(getattr(two, field)))
    for i in (0, 3, 7, 22):
        alone = robot.solve_cables(lengths[i:i + 1], seed=seed[i:i + 1])
        np.testing.assert_array_equal(np.asarray(alone.theta)[0], np.asarray(one.theta)[i])
        assert alone.iterations[0] == one.iterations[i] and alone.reason[0] == one.reason[i]


def test_enforced_limits_keep_the_answers_in_the_box(eight):
    """With the limits enforced, lengths of configurations inside the box
    are solved (as the reference solves them, 1e-9 rad); lengths that need a
    joint 0.1 rad past its limit are not, the answer stays in the box."""
    robot, nominal = eight
    rng = np.random.default_rng(7)
    th = rng.uniform(-0.5, 0.5, (40, robot.n))
    th[1::3, 2] = 0.7
    lengths = _position_lengths(nominal, th)
    seed = np.clip(th + 0.03, -0.6, 0.6)
    sol = robot.solve_cables(lengths, seed=seed, enforce_limits=True)
    inside = np.all(np.abs(th) <= 0.6, axis=1)
    conv = np.asarray(sol.converged)
    np.testing.assert_array_equal(conv, inside)
    np.testing.assert_allclose(np.asarray(sol.theta)[inside], th[inside], rtol=0, atol=1e-9)
    assert np.all(np.abs(np.asarray(sol.theta)) <= 0.6)
    assert np.asarray(sol.within_limits).all()
    assert set(np.asarray(sol.reason)[~conv]) <= {"outside limits", "iteration limit", "unreachable"}


def test_least_squares_lanes_on_the_sjtu_snake_are_the_references(cdsm):
    """36 position cables on 24 joints with inconsistent lengths (+-1 mm):
    least squares from the nominal configuration, the same minimum as the
    reference's: the squared misfit to 1e-10 of itself, max |r| to 1e-11 m,
    the angles to 1e-7 rad (both stop when a step lowers the squared misfit
    by less than 1e-12 of itself, a test at the level of its rounding: one
    side may take one step more along the misfit's flat valley)."""
    robot = cdsm.Robot.from_toml("sjtu_snake")
    nominal = reference.load_robot(ROOT / "python" / "cdsm" / "robots" / "sjtu_snake.toml")
    rng = np.random.default_rng(8)
    th = rng.uniform(-0.3, 0.3, (9, robot.n))
    lengths = _position_lengths(nominal, th) + rng.uniform(-1e-3, 1e-3, (9, len(robot.position_cables)))
    sol = robot.solve_cables(lengths, seed=th)
    mine = reference.solve_cables(nominal, lengths, seed=th)
    assert np.asarray(sol.converged).all() and mine["converged"].all()
    cost = [((_position_lengths(nominal, t) - lengths) ** 2).sum(1) for t in (np.asarray(sol.theta), mine["theta"])]
    np.testing.assert_allclose(cost[0], cost[1], rtol=1e-10, atol=0)
    np.testing.assert_allclose(np.asarray(sol.residual), mine["residual"], rtol=0, atol=1e-11)
    np.testing.assert_allclose(np.asarray(sol.theta), mine["theta"], rtol=0, atol=1e-7)
    assert np.all(np.asarray(sol.residual) > 1e-5)


def test_spatial_monte_carlo_is_the_references(eight):
    """Every sample of the Monte Carlo (cable errors +-1 cm so that some
    samples do not converge, hole errors +-0.35 mm on every coordinate) is
    the reference's solve of that sample's arm from the nominal
    configuration: the same counts of solved and failed samples, the same
    sums, minima and maxima of dX, dY, dZ, |dXYZ| (m) and the rotation
    angle (rad) per configuration."""
    from cdsm.accuracy.montecarlo import monte_carlo, sample_errors

    robot, nominal = eight
    theta = np.random.default_rng(9).uniform(-0.55, 0.55, (7, robot.n))
    samples, m, h = 9, len(robot.position_cables), len(robot.flat_holes)
    mc = monte_carlo(robot, theta, samples=samples, seed=4, chunk=samples, dl_tol=1e-2, progress=False)
    dl, dh = sample_errors(robot.n, samples, 4, 0, np.full(m, 1e-2), np.full(h, 0.35e-3))
    l0 = _position_lengths(nominal, theta)
    f0 = reference.fk_matrix(nominal, theta)
    sizes = [x.size for x in nominal.holes]
    values = np.full((samples, len(theta), 5), np.nan)
    for s in range(samples):
        flat = np.concatenate([x.ravel() for x in nominal.holes]) + dh[s]
        parts = np.split(flat, np.cumsum(sizes)[:-1])
        arm = dataclasses.replace(nominal, holes=tuple(p.reshape(x.shape) for p, x in zip(parts, nominal.holes)))
        sol = reference.solve_cables(arm, l0 + dl[s], seed=theta)
        f = reference.fk_matrix(arm, sol["theta"])
        d = f[:, :3, 3] - f0[:, :3, 3]
        angle = np.array([np.linalg.norm(reference.log_so3(a[:3, :3].T @ b[:3, :3])) for a, b in zip(f0, f)])
        ok = sol["converged"]
        values[s, ok] = np.column_stack([d, np.linalg.norm(d, axis=1), angle])[ok]
    solved = ~np.isnan(values[..., 0])
    np.testing.assert_array_equal(mc.count, solved.sum(0))
    np.testing.assert_array_equal(mc.failed, (~solved).sum(0))
    assert 0 < mc.failed.sum() < samples * len(theta)
    np.testing.assert_allclose(mc.sum, np.nansum(values, 0), rtol=0, atol=1e-11)
    np.testing.assert_allclose(mc.min, np.nanmin(values, 0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(mc.max, np.nanmax(values, 0), rtol=0, atol=1e-12)
