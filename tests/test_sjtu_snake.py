"""The packaged SJTU snake (``python/cdsm/robots/sjtu_snake.toml``) is CASPR's model of it.

CASPR's own files (``tests/data/caspr/SJTUSnake/``, verbatim from
https://github.com/darwinlau/CASPR, BSD-3-Clause) are read here with
``xml.etree.ElementTree`` and evaluated independently in NumPy, the way CASPR's
``src/Model`` code does:

* bodies (``SystemModelBodies.update``, ``BodyModelRigid``, ``UniversalXZ``):
  ``R_0k = R_0p R_pe(q)`` with ``R_pe = R_x(q1) R_z(q2)`` for ``U_XZ``, and the
  joint of link k at ``p_k = p_p + R_0p r_Parent`` (CASPR stores ``r_OP`` in the
  link frame, ``R_pe^T (r_OP_p + r_Parent)``: the same point); ``q`` is the
  links' joint variables in link order;
* cables (``CableAttachmentPoint`` with ``attachment_reference = "joint"``,
  ``CableSegmentModel``, ``CableModelBase.length``): a point ``r_A`` on link k
  is ``p_k + R_0k r_A`` (on link 0 ``r_A`` itself), and a cable's length is the
  sum of the straight segments between its consecutive attachment points; the
  set is the file's ``default_cable_set``

(``tests/caspr_reference.py``, shared with ``tests/test_caspr_import.py``).

The NumPy reference (``cdsm.reference``, loaded from its
files by ``conftest``; no compiled extension) reads the packaged robot file; its
cable lengths must equal CASPR's at 200 random configurations within the joint
limits to 1e-12 m. SI units: m, rad, kg.

How it was checked that this test can fail: in a copy of ``sjtu_snake.toml``,
one number was moved by a millimetre (cable 20, CASPR's "cable 2 (link 8)", its
face-a hole on disk 5: y 0.014555 -> 0.015555) and this test run on the copy:
``test_cable_lengths_equal_caspr`` failed (max |L_cdsm - L_CASPR| = 1.6e-4 m),
as did the hole-radius and hole-point checks. ``test_one_millimetre_is_seen``
keeps such a check in the suite. On the packaged file the largest difference is
about 1e-15 m.
"""

from __future__ import annotations

import dataclasses
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import caspr_reference
from conftest import ROOT

CASPR = ROOT / "tests" / "data" / "caspr" / "SJTUSnake"
TOML = ROOT / "python" / "cdsm" / "robots" / "sjtu_snake.toml"
SET_ID = "base to link cable connection"

#: CASPR -> cdsm: (x, y, z) -> (y, -x, z), the rotation by -90 deg about z
#: (CASPR's links lie along y, cdsm's arm along x; z is kept).
Q = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])

N_CONFIG = 200
TOL = 1e-12  # m


# --------------------------------------------------------------------------
# CASPR's model, from its XML files (tests/caspr_reference.py)
# --------------------------------------------------------------------------
def caspr_bodies():
    """The links of ``SJTUSnake_bodies.xml`` as dicts (SI units), in file order."""
    return caspr_reference.bodies(CASPR / "SJTUSnake_bodies.xml")


def caspr_cables():
    """``(default set id, [(name, [(link, r_A), ...]), ...])`` of the default set, in
    file order; attachment points as CASPR lists them (end link first)."""
    root = ET.parse(CASPR / "SJTUSnake_cables.xml").getroot()
    for c in root.iter("cable_ideal"):
        assert c.get("attachment_reference") == "joint", c.attrib
    return caspr_reference.cables(CASPR / "SJTUSnake_cables.xml")


caspr_frames = caspr_reference.frames
caspr_points = caspr_reference.points
caspr_lengths = caspr_reference.lengths


# --------------------------------------------------------------------------
# Fixtures
# --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def caspr():
    default, cables = caspr_cables()
    return dict(links=caspr_bodies(), default=default, cables=cables)


@pytest.fixture(scope="module")
def snake(ref):
    return ref.load_robot(TOML)


@pytest.fixture(scope="module")
def theta(snake):
    """200 configurations uniform in the joint box (rad), seeded."""
    lo, hi = snake.joint_limits[:, 0], snake.joint_limits[:, 1]
    return np.random.default_rng(2024).uniform(lo, hi, (N_CONFIG, snake.n))


# --------------------------------------------------------------------------
# CASPR's model as the brief describes it
# --------------------------------------------------------------------------
def test_caspr_model_facts(caspr):
    links, cables = caspr["links"], caspr["cables"]
    assert caspr["default"] == SET_ID
    assert [lk["num"] for lk in links] == list(range(1, 13))
    assert [lk["parent"] for lk in links] == list(range(12))
    for lk in links:
        assert lk["type"] == "U_XZ"
        assert lk["q_min"] == [-0.35, -0.35] and lk["q_max"] == [0.35, 0.35]
        assert lk["mass"] == pytest.approx(0.062, abs=5e-5)
        np.testing.assert_array_equal(lk["end"], [0.0, 0.09921, 0.0])
    np.testing.assert_array_equal(links[0]["location"], [0.0, 0.0, 0.0])
    for lk in links[1:]:
        np.testing.assert_array_equal(lk["location"], [0.0, 0.09921, 0.0])
    assert len(cables) == 36
    ends = [att[0][0] for _, att in cables]
    assert sorted(ends) == sorted(list(range(1, 13)) * 3)
    for _, att in cables:
        assert att[-1][0] == 0  # every cable starts at the base
        for _, r in att:  # holes at 19 mm from the link axis (y)
            assert np.hypot(r[0], r[2]) == pytest.approx(0.019, abs=1e-6)


# --------------------------------------------------------------------------
# The packaged file
# --------------------------------------------------------------------------
def test_packaged_file_facts(snake, caspr, ref):
    links = caspr["links"]
    assert snake.kind == "spatial"
    assert (snake.n, snake.disks, snake.m) == (24, 12, 36)
    assert snake.cable_mode == ("position",) * 36
    np.testing.assert_array_equal(ref.position_cables(snake), np.arange(36))
    counts = np.bincount(snake.cable_end, minlength=13)[1:]
    np.testing.assert_array_equal(counts, np.full(12, 3))  # three cables end at each link
    # the ends in CASPR's order: cable i (link k) for i = 1, 2, 3 and k = 1..12
    np.testing.assert_array_equal(snake.cable_end, [att[0][0] for _, att in caspr["cables"]])
    # limits, joint by joint in CASPR's order
    lo = np.concatenate([lk["q_min"] for lk in links])
    hi = np.concatenate([lk["q_max"] for lk in links])
    np.testing.assert_array_equal(snake.joint_limits, np.stack([lo, hi], axis=1))
    np.testing.assert_array_equal(snake.joint_limits, np.tile([-0.35, 0.35], (24, 1)))
    np.testing.assert_array_equal(snake.joint_disk, np.repeat(np.arange(1, 13), 2))
    # U_XZ under Q: Q e_x then Q e_z
    np.testing.assert_array_equal(snake.axes, np.tile([Q @ [1.0, 0, 0], Q @ [0, 0, 1.0]], (12, 1)))
    # masses and centres of mass (face-a frame = CASPR's link frame)
    np.testing.assert_array_equal(snake.mass, [lk["mass"] for lk in links])
    np.testing.assert_allclose(snake.com, [Q @ lk["com"] for lk in links], rtol=0, atol=1e-15)
    # gravity: CASPR's -z, perpendicular to the straight arm (+x), standard magnitude
    np.testing.assert_array_equal(snake.gravity, [0.0, 0.0, -9.80665])
    assert snake.gravity @ ref.fk_matrix(snake, np.zeros((1, 24)))[0, :3, 0] == 0.0
    # the straight arm points along +x: twelve links of 0.09921 m
    np.testing.assert_allclose(ref.fk(snake, np.zeros((1, 24)))[0], [12 * 0.09921, 0, 0, 0, 0, 0], atol=1e-15)
    # holes within the radii (the reader checks it too), at 19 mm
    for h in snake.holes:
        assert np.all(np.hypot(h[:, 1], h[:, 2]) <= 0.02)
        np.testing.assert_allclose(np.hypot(h[:, 1], h[:, 2]), 0.019, atol=1e-6)


def test_cable_lengths_equal_caspr(snake, caspr, theta, ref):
    """The packaged file's cable lengths (NumPy reference) equal CASPR's model's, 1e-12 m."""
    mine = ref.cable_lengths(snake, theta)
    theirs = caspr_lengths(caspr["links"], caspr["cables"], theta)
    assert mine.shape == theirs.shape == (N_CONFIG, 36)
    err = np.max(np.abs(mine - theirs))
    assert err <= TOL, f"max |L_cdsm - L_CASPR| = {err:.3e} m"
    # the configurations do bend the arm: lengths change by centimetres
    assert np.ptp(theirs, axis=0).min() > 1e-3


def test_points_and_tip_equal_caspr(snake, caspr, theta, ref):
    """Every hole point is CASPR's attachment point (under Q) and the end frame is
    CASPR's tip operational point (link 12, offset end_location): 1e-12 m."""
    R, p = caspr_frames(caspr["links"], theta)
    pts = ref.cable_points(snake, theta)
    for c, (name, att) in enumerate(caspr["cables"]):
        P = caspr_points(R, p, att[::-1]) @ Q.T  # base to end, cdsm axes
        e = att[0][0]
        # cdsm: B_0, A_1, B_1, ..., A_e, B_e; CASPR: base, (link k: 2 points) for k < e, link e: 1 point
        np.testing.assert_allclose(pts[c][:, :-1], P, rtol=0, atol=TOL, err_msg=name)
        np.testing.assert_allclose(pts[c][:, -1], P[:, -1], rtol=0, atol=TOL, err_msg=name)  # zero traversal
        assert pts[c].shape[1] == 2 * e + 1
    T = ref.fk_matrix(snake, theta)
    tip = p[:, 12] + R[:, 12] @ caspr["links"][-1]["end"]
    np.testing.assert_allclose(T[:, :3, 3], tip @ Q.T, rtol=0, atol=TOL)
    np.testing.assert_allclose(T[:, :3, :3], Q @ R[:, 12] @ Q.T, rtol=0, atol=1e-13)


def test_one_millimetre_is_seen(snake, caspr, theta, ref):
    """A hole off by 1 mm (in y) breaks the equality by far more than the tolerance."""
    holes = list(snake.holes)
    h = holes[19].copy()
    h[9, 1] -= 1e-3  # cable 20, face a of disk 5
    holes[19] = h
    moved = dataclasses.replace(snake, holes=tuple(holes))
    err = np.abs(ref.cable_lengths(moved, theta) - caspr_lengths(caspr["links"], caspr["cables"], theta))
    assert err[:, 19].max() > 1e-5
    assert np.delete(err, 19, axis=1).max() <= TOL


# --------------------------------------------------------------------------
# The Rust core, when the extension is importable (in CI it is built)
# --------------------------------------------------------------------------
def test_rust_core_reads_the_packaged_file(snake, theta, ref):
    cdsm = pytest.importorskip("cdsm")
    if "sjtu_snake" not in cdsm.robot.packaged_robots():
        pytest.skip(f"the importable cdsm ({cdsm.__file__}) is built from another tree: no sjtu_snake")
    robot = cdsm.Robot.packaged("sjtu_snake")
    assert robot.kind == "spatial"
    assert robot.n == 24 and robot.cables == 36
    assert list(robot.position_cables) == list(range(36))
    th = theta[:8]
    err = np.max(np.abs(robot.cable_lengths(th) - ref.cable_lengths(snake, th)))
    assert err <= TOL, f"max |L_rust - L_reference| = {err:.3e} m"
