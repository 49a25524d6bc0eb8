"""The arm's kind as data (issue 33, item 1): ``Robot.kind`` is a
:class:`cdsm.kinds.Kind`, a string with the facts that differ between the
kinds. Each fact is checked against a statement made elsewhere: the NumPy
reference's own ``reference.KINDS``, what the core returns, the physics (a
norm of the position error is at least the norm of its mean), or the literal
values of the names cdsm 0.2 published (which stay, one definition each)."""

from __future__ import annotations

import json
import pickle

import numpy as np
import pytest

PACKAGED = ("paper", "two_universal", "paper_spatial")


@pytest.mark.parametrize("name", PACKAGED)
def test_robot_kind_is_the_kind_object_and_still_the_string(cdsm, name):
    from cdsm.kinds import Kind, kind_of

    r = cdsm.Robot.from_toml(name)
    k = r.kind
    assert isinstance(k, Kind) and k is kind_of(str(k))
    assert k == r.core.kind and f"{k}" == r.core.kind and repr(k) == repr(r.core.kind)
    assert {"planar": 1, "spatial": 2}[k] in (1, 2) and json.dumps({"kind": k}) == json.dumps({"kind": str(k)})
    assert pickle.loads(pickle.dumps(k)) is k


@pytest.mark.parametrize("name", ("planar", "spatial"))
def test_kind_facts_agree_with_the_reference(cdsm, ref, name):
    from cdsm.kinds import kind_of

    ours, theirs = kind_of(name), ref.KINDS[name]
    assert ours.dim == theirs.dim and ours.rotation == theirs.rotation
    assert ours.task == len(theirs.task_rows)
    assert set(ours.masks) == set(theirs.masks)
    if ours.mask_weights:  # planar: weights on x, y, phi = the reference's position weights and rotation weight
        for m, (pos, _form, rot) in theirs.masks.items():
            assert ours.masks[m] == (*pos, rot)
    assert len(ours.position_axes) == ours.dim and len(ours.rotation_axes) == ours.task - ours.dim


@pytest.mark.parametrize("name", PACKAGED)
def test_kind_facts_agree_with_what_the_core_returns(cdsm, name):
    r = cdsm.Robot.from_toml(name)
    k = r.kind
    theta = np.full(r.n, 0.1)
    assert r.fk(theta).shape == (k.task,) and r.fk_jacobian(theta).shape == (k.task, r.n)
    assert r.gravity.shape == (k.dim,)
    # the default mask and every named one are taken by the core
    for m in k.masks:
        assert r.ik(r.fk(theta), mask=m).converged
    # a tip wrench of the task's width; a pure force along x is the same through the padding
    f = np.zeros(k.task)
    f[0] = 0.01
    t = r.tensions(theta, tip_wrench=f)
    assert t.shape == (len(r.position_cables),)


@pytest.mark.parametrize("name", ("paper", "two_universal"))
def test_monte_carlo_quantities_are_the_kinds_and_the_norm_is_the_position_norm(cdsm, name):
    from cdsm.accuracy.montecarlo import monte_carlo

    r = cdsm.Robot.from_toml(name)
    k = r.kind
    mc = monte_carlo(r, np.full((2, r.n), 0.05), samples=64, seed=3)
    assert mc.quantities == k.quantities and mc.sum.shape[1] == len(k.quantity_units)
    # mean |d position| >= |mean d position| (the norm's column is the norm of the position columns)
    mean = mc.mean
    assert np.all(mean[:, k.norm] >= np.linalg.norm(mean[:, :k.dim], axis=1) - 1e-15)
    assert np.all(mc.max[:, k.norm] >= 0)


def test_the_names_of_cdsm_0_2_keep_their_values(cdsm):
    import cdsm.spatial
    import cdsm.study
    from cdsm.accuracy import montecarlo
    from cdsm import robot

    assert robot.KINDS == ("planar", "spatial")
    assert robot.TASK_MASKS == {"pose": (1.0, 1.0, 1.0), "position": (1.0, 1.0, 0.0)}
    assert robot.SPATIAL_MASKS == ("position", "pointing", "pose")
    assert montecarlo.QUANTITY_NAMES == ("dX", "dY", "dphi", "dXY")
    assert montecarlo.QUANTITY_UNITS == ("m", "m", "rad", "m")
    assert montecarlo.SPATIAL_QUANTITY_NAMES == ("dX", "dY", "dZ", "dXYZ", "rot")
    assert montecarlo.SPATIAL_QUANTITY_UNITS == ("m", "m", "m", "m", "rad")
    assert cdsm.study.DEFAULT_SAMPLES == {"planar": 1000, "spatial": 200}
    assert cdsm.spatial.TASK == 6


def test_the_kinds_words(cdsm):
    from cdsm.kinds import PLANAR, SPATIAL

    assert (PLANAR.norm_label, PLANAR.norm_slug) == ("|d(X, Y)|", "dxy")
    assert (SPATIAL.norm_label, SPATIAL.norm_slug) == ("|d(X, Y, Z)|", "dxyz")
    assert PLANAR.pose_columns == ("x_m", "y_m", "phi_rad")
    assert SPATIAL.pose_columns == ("x_m", "y_m", "z_m", "rx_rad", "ry_rad", "rz_rad")
    assert SPATIAL.tip_columns == ("x_m", "y_m", "z_m")


def test_an_unknown_kind_or_mask_is_refused_by_name(cdsm):
    from cdsm.kinds import kind_of

    with pytest.raises(cdsm.CdsmInputError, match="`kind`: expected one of 'planar', 'spatial', got 'conical'"):
        kind_of("conical")
    with pytest.raises(cdsm.CdsmInputError, match=r"`mask`: expected one of 'pose', 'position' or 3 weights"):
        cdsm.Robot.paper().ik([0.2, 0.0, 0.0], mask="pointing")
    r = cdsm.Robot.from_toml("two_universal")
    with pytest.raises(cdsm.CdsmInputError, match=r"'position', 'pointing', 'pose' for a spatial arm, got \[1"):
        r.ik(r.fk(np.zeros(r.n)), mask=[1.0, 1.0, 1.0])
