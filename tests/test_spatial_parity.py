"""Parity of the Rust core on spatial robot files (``cdsm.Robot`` with
``kind == "spatial"``) with the independent NumPy reference
(``cdsm.reference``, written from ``docs/spatial.md``) on random
batches.  SI units: m, rad, N.  Tolerances: lengths and poses 1e-12, Jacobians
1e-10, solves 1e-9 rad.

The whole module is skipped while the compiled core cannot load a spatial
robot file (``cdsm.Robot.from_toml(path).kind`` missing or not ``"spatial"``).
"""

from __future__ import annotations

import numpy as np
import pytest

from conftest import ROOT, reference

ROBOTS = ROOT / "python" / "cdsm" / "robots"
NAMES = ["paper_spatial", "two_universal"]


def _rust_robot(name):
    import cdsm

    return cdsm.Robot.from_toml(str(ROBOTS / f"{name}.toml"))


try:
    _probe = _rust_robot("two_universal")
    _kind = getattr(_probe, "kind", None)
except Exception as exc:  # the extension is missing, older, or cannot read spatial files yet
    pytest.skip(f"cdsm cannot load spatial robot files yet: {exc!r}", allow_module_level=True)
if _kind != "spatial":
    pytest.skip(f"cdsm.Robot.from_toml(...).kind is {_kind!r}, not 'spatial'", allow_module_level=True)


@pytest.fixture(params=NAMES, scope="module")
def pair(request):
    """``(rust robot, reference robot)`` of one packaged spatial file."""
    return _rust_robot(request.param), reference.load_robot(ROBOTS / f"{request.param}.toml")


def _box(robot, N, seed, scale=1.0):
    lo, hi = robot.joint_limits[:, 0] * scale, robot.joint_limits[:, 1] * scale
    return np.random.default_rng(seed).uniform(lo, hi, (N, robot.n))


def test_shapes_and_kind(pair):
    rust, ref = pair
    assert rust.kind == "spatial"
    assert rust.n == ref.n
    th = _box(ref, 7, 0)
    assert np.asarray(rust.fk(th)).shape == (7, 6)
    assert np.asarray(rust.fk_matrix(th)).shape == (7, 4, 4)
    assert np.asarray(rust.cable_lengths(th)).shape == (7, ref.m)
    assert np.asarray(rust.cable_jacobian(th)).shape == (7, ref.m, ref.n)
    assert np.asarray(rust.fk_jacobian(th)).shape == (7, 6, ref.n)


def test_forward_kinematics(pair):
    rust, ref = pair
    th = _box(ref, 500, 1)
    np.testing.assert_allclose(np.asarray(rust.fk_matrix(th)), reference.fk_matrix(ref, th), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(rust.fk(th)), reference.fk(ref, th), rtol=0, atol=1e-12)


def test_rotation_vector_beyond_half_turn(pair):
    """Outside the joint box (FK does not clamp): principal rotation vectors, |r| <= pi."""
    rust, ref = pair
    th = np.random.default_rng(2).uniform(-2.0, 2.0, (300, ref.n))
    a, b = np.asarray(rust.fk(th)), reference.fk(ref, th)
    np.testing.assert_allclose(a[:, :3], b[:, :3], rtol=0, atol=1e-12)
    ok = np.linalg.norm(b[:, 3:], axis=1) < np.pi - 1e-6  # at pi both signs are principal
    np.testing.assert_allclose(a[ok, 3:], b[ok, 3:], rtol=0, atol=1e-11)
    np.testing.assert_allclose(reference.exp_so3(a[:, 3:]), reference.exp_so3(b[:, 3:]), rtol=0, atol=1e-11)


def test_cable_lengths_and_jacobians(pair):
    rust, ref = pair
    th = _box(ref, 500, 3)
    np.testing.assert_allclose(np.asarray(rust.cable_lengths(th)), reference.cable_lengths(ref, th), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(rust.cable_jacobian(th)), reference.cable_jacobian(ref, th),
                               rtol=0, atol=1e-10)
    np.testing.assert_allclose(np.asarray(rust.fk_jacobian(th)), reference.geometric_jacobian(ref, th),
                               rtol=0, atol=1e-10)


def test_cable_solve(pair):
    rust, ref = pair
    th = _box(ref, 200, 4)
    lengths = reference.cable_lengths(ref, th)[:, reference.position_cables(ref)]
    seed = np.zeros_like(th)
    sol = rust.solve_cables(lengths, seed=seed)
    mine = reference.solve_cables(ref, lengths, seed=seed)
    assert np.asarray(sol.converged).all() and mine["converged"].all()
    np.testing.assert_allclose(np.asarray(sol.theta), th, rtol=0, atol=1e-9)
    np.testing.assert_allclose(np.asarray(sol.theta), mine["theta"], rtol=0, atol=1e-9)
    assert np.all(np.asarray(sol.residual) <= 1e-12)


@pytest.mark.parametrize("mask", ["position", "pointing", "pose"])
def test_ik(pair, mask):
    """From seed 0 both reach the target (a planar arm has two elbow branches
    there, and the solvers' paths may pick different ones); seeded near the
    answer they agree on the joint angles (rad) — the same answer, to 1e-9."""
    rust, ref = pair
    th = _box(ref, 100, 5, scale=0.5)
    target = reference.fk(ref, th)
    seed = np.zeros_like(th)
    sol = rust.ik(target, seed=seed, mask=mask)
    mine = reference.ik(ref, target, seed=seed, mask=mask)
    conv = np.asarray(sol.converged)
    np.testing.assert_array_equal(conv, mine["converged"])
    assert conv.all()
    theta = np.asarray(sol.theta)
    np.testing.assert_allclose(reference.fk(ref, theta)[:, :3], target[:, :3], rtol=0, atol=1e-12)
    # seeded 1 mrad from the answer both reach the same joint angles, to 1e-9
    # rad plus what a 1e-12 residual allows where the Jacobian is nearly
    # singular (1e-12 over its smallest non-zero singular value)
    sv = np.linalg.svd(reference.geometric_jacobian(ref, th), compute_uv=False)
    sv_min = np.where(sv > 1e-9, sv, np.inf).min(axis=1)
    tol = 1e-9 + 1e-12 / sv_min
    near = th + np.random.default_rng(7).uniform(-1e-3, 1e-3, th.shape)
    sol = rust.ik(target, seed=near, mask=mask)
    mine = reference.ik(ref, target, seed=near, mask=mask)
    assert np.asarray(sol.converged).all() and mine["converged"].all()
    assert np.all(np.abs(np.asarray(sol.theta) - mine["theta"]).max(axis=1) <= tol)
    if mask in ("pose", "pointing"):  # unique near the answer: the joint angles themselves
        assert np.all(np.abs(np.asarray(sol.theta) - th).max(axis=1) <= tol)


def test_tensions(pair):
    """Feasibility and the tensions where feasible equal the reference's
    minimum-norm set; where not, an arm with as many position cables as
    joints still has its balance's one solution, and some cable of it would
    have to push (the reference has no set above the floor: NaN)."""
    rust, ref = pair
    th = _box(ref, 300, 6)
    T, feasible = reference.feasible_tensions(ref, th)
    T_rust = np.asarray(rust.tensions(th))
    np.testing.assert_array_equal(np.asarray(rust.feasible(th)), feasible)
    np.testing.assert_allclose(T_rust[feasible], T[feasible], rtol=1e-9, atol=1e-12)
    assert np.isnan(T[~feasible]).all()
    if len(rust.position_cables) == rust.n and (~feasible).any():
        assert (np.nanmin(T_rust[~feasible], axis=1) < 0).all()
        M = reference.moment_matrices(ref, th[~feasible])
        tau = reference.external_moments(ref, th[~feasible])
        pos, frc = reference.position_cables(ref), reference.force_cables(ref)
        resid = (np.einsum("nij,nj->ni", M[:, :, pos], T_rust[~feasible]) + tau
                 + M[:, :, frc] @ ref.cable_tension[frc])
        assert np.abs(resid).max() < 1e-12
    elif len(rust.position_cables) > rust.n:
        assert np.isnan(T_rust[~feasible]).all()


def test_planar_end_frame_equals_the_paper_arm_built_in_3d(cdsm):
    """Robot.fk_matrix of the planar prototype is the frame the spatial core
    computes for paper_spatial (all axes along z): equal to 1e-12 m, z = 0."""
    planar, spatial = cdsm.Robot.paper(), cdsm.Robot.packaged("paper_spatial")
    th = np.random.default_rng(5).uniform(-0.6, 0.6, (50, 3))
    f = planar.fk_matrix(th)
    np.testing.assert_allclose(f, spatial.fk_matrix(th), rtol=0, atol=1e-12)
    assert f.shape == (50, 4, 4) and planar.fk_matrix(th[0]).shape == (4, 4)
    np.testing.assert_allclose(f[:, 2, 3], 0.0, atol=0)
