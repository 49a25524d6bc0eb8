"""Parity of the plant (``rust/plant.rs`` through ``cdsm.calibration.plant``)
with the independent NumPy reference written from ``docs/model.md``
(``cdsm.reference.plant``): every effect alone and a mixture, on random
command sequences mixing absolute, displacement and unmeasured rows, and the
exact Jacobian against central differences of the reference."""

from __future__ import annotations

import numpy as np
import pytest

BLOCK_SCALE = {  # a magnitude per parameter block (SI), signs drawn at random
    "actuation_scale": 0.03, "cable_offset": 3e-4, "hole_height": 3e-4, "link_length": 4e-4,
    "cable_elasticity": 0.03, "hole_clearance": 2e-4, "frame_misalignment": 5e-3, "tip_offset": 1e-3,
    "backlash": 6e-5, "clearance_width": 0.006, "cable_friction": 0.3,
}
NON_NEGATIVE = ("cable_elasticity", "hole_clearance", "backlash", "cable_friction")


@pytest.fixture(scope="module")
def robot(cdsm):
    r = cdsm.Robot.paper()
    return r.with_loads(gravity=[0.0, -9.80665])  # the statics carry gravity too


def _params(cdsm_plant, robot, blocks, seed):
    rng = np.random.default_rng(seed)
    lay = cdsm_plant.layout(robot)
    p = np.zeros(cdsm_plant.size(robot))
    for b in blocks:
        sl = lay[b]
        v = rng.uniform(0.3, 1.0, sl.stop - sl.start) * BLOCK_SCALE[b]
        if b not in NON_NEGATIVE:
            v *= rng.choice([-1.0, 1.0], len(v))
        p[sl] = v
    if "clearance_width" in blocks and "hole_clearance" not in blocks:
        p[lay["hole_clearance"]] = 1.5e-4  # the width shows only with a clearance
    return p


def _rows(n, rows, seed):
    rng = np.random.default_rng(seed)
    theta = rng.uniform(-0.5, 0.5, (rows, n))
    dl = np.where(rng.random((rows, n)) < 0.5, rng.uniform(-1e-3, 1e-3, (rows, n)), 0.0)
    kind = rng.choice(["absolute", "displacement", "unmeasured"], rows, p=[0.5, 0.3, 0.2])
    return theta, dl, kind


ALL = ["actuation_scale", "cable_offset", "hole_height", "link_length", "cable_elasticity", "hole_clearance",
       "frame_misalignment", "tip_offset", "backlash", "clearance_width", "cable_friction"]


@pytest.mark.parametrize("blocks", [[b] for b in ALL] + [ALL], ids=ALL + ["all"])
def test_predictions_match_the_reference(cdsm, ref, robot, blocks):
    from cdsm.calibration import plant

    assert set(plant.BLOCKS) == set(ALL)
    p = _params(plant, robot, blocks, seed=len(blocks) * 7 + ALL.index(blocks[0]))
    theta, dl, kind = _rows(robot.n, 24, seed=ALL.index(blocks[0]))
    obs, ok = plant.predict(robot, p, theta, dl, kind)
    want, ok_ref = ref.plant_predict(robot, p, theta, dl, kind)
    assert (ok == ok_ref).all() and ok.sum() >= len(ok) - 2  # both fail on the same rows, if any
    measured = (kind != "unmeasured") & ok
    assert np.isnan(obs[kind == "unmeasured"]).all() and np.isnan(want[kind == "unmeasured"]).all()
    err = np.abs(obs[measured] - want[measured]).max()
    assert err < 1e-10, err


def test_all_zero_parameters_are_the_nominal_model(cdsm, ref, robot):
    from cdsm.calibration import plant

    theta, dl, _ = _rows(robot.n, 12, seed=5)
    obs, ok = plant.predict(robot, np.zeros(plant.size(robot)), theta, dl, "absolute")
    nominal = robot.fk(robot.solve_cables(robot.upper_lengths(theta) + dl, seed=theta).theta)
    assert ok.all() and np.abs(obs - nominal).max() < 1e-12


# Friction's reference settles displacement rows through the sticking band
# slowly (~0.4 s a prediction under gravity): every effect but friction on 10
# rows of every kind, and every effect with friction on 4 absolute rows. The
# friction column is checked where mu > 0: at mu = 0 (its bound) a forward
# difference of 1e-7 falls inside the onset of the sticking band, whose width
# grows with mu (there the jets agree with a step of 1e-5 to 4 digits).
@pytest.mark.parametrize("blocks, rows, least", [([b for b in ALL if b != "cable_friction"], 10, 5), (ALL, 4, 3)],
                         ids=["without friction", "with friction"])
def test_exact_jacobian_matches_central_differences_of_the_reference(cdsm, ref, robot, blocks, rows, least):
    from cdsm.calibration import plant

    p = _params(plant, robot, blocks, seed=3)
    theta, dl, kind = _rows(robot.n, rows, seed=9)
    free = np.arange(plant.size(robot))
    if "cable_friction" not in blocks:
        free = np.setdiff1d(free, plant.effect_indices(robot, "cable_friction"))
    obs, ok, J = plant.linearise(robot, p, free, theta, dl, kind)
    lo, _ = plant.bounds(robot)
    measured = (kind != "unmeasured") & ok
    assert measured.sum() >= least
    for col, j in enumerate(free):
        h = 1e-7 * max(1.0, abs(p[j]) * 1e3)
        a, b = p.copy(), p.copy()
        a[j] += h
        central = p[j] - h >= lo[j]
        if central:
            b[j] -= h
        ya, _ = ref.plant_predict(robot, a, theta, dl, kind)
        yb, _ = ref.plant_predict(robot, b, theta, dl, kind)
        fd = (ya - yb) / (2 * h if central else h)
        err = np.abs(fd[measured] - J[measured, :, col]).max()
        assert err < 1e-5 * (1 + np.abs(J[measured, :, col]).max()), (j, err)
