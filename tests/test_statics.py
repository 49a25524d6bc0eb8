"""Statics, slack detection and cable elasticity (issue 4).

Physics stated by the tests: at the straight pose with symmetric holes the
upper tensions equal the hanging weights; the moment balance obeys virtual
work (sum_k tau_k dtheta_k = sum_c T_c dL_c, tau from the external loads)
against the independent cable Jacobian; stretch scales with 1/E; the paper's
steel cable stretches about 0.02 mm over 230 mm under 50 g; reversing the
paper's weight order (5, 10, 50 g) makes an upper cable go slack over most of
the +-30 deg grid. The Rust core matches the NumPy reference.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PAPER_LINKAGES, make_pair, random_theta, robot_toml

G0 = 9.80665
PAPER_WEIGHTS = np.array([50.0, 10.0, 5.0]) * 1e-3 * G0  # N, disks 1, 2, 3
REVERSED_WEIGHTS = PAPER_WEIGHTS[::-1].copy()


def grid30() -> np.ndarray:
    """The paper's workspace grid: every joint -30..30 deg, 5 deg step (13^3)."""
    d = np.deg2rad(np.arange(-30.0, 30.1, 5.0))
    return np.array(np.meshgrid(d, d, d, indexing="ij")).reshape(3, -1).T


def loads_for(pair, N, seed):
    rng = np.random.default_rng(seed)
    n = pair.rust.n
    lower = rng.uniform(0.05, 0.6, (N, n))
    wrench = rng.normal(0.0, [0.2, 0.2, 0.01], (N, 3))
    gravity = np.array([1.5, -9.81])
    return lower, wrench, gravity


# --------------------------------------------------------------------------
# Parity with the NumPy reference
# --------------------------------------------------------------------------
def test_tensions_match_reference(pair, ref):
    n = pair.rust.n
    theta = random_theta(n, N=400, seed=11)
    T = pair.rust.tensions(theta)
    Tr = ref.tensions(pair.ref, theta, pair.rust.lower_tension)
    scale = np.abs(Tr).max(axis=1, keepdims=True)
    assert np.all(np.abs(T - Tr) <= 1e-10 * scale)


def test_tensions_with_loads_match_reference(pair, ref):
    n = pair.rust.n
    theta = random_theta(n, N=300, seed=12)
    lower, wrench, gravity = loads_for(pair, 300, seed=3)
    T = pair.rust.tensions(theta, lower=lower, tip_wrench=wrench, gravity=gravity)
    Tr = ref.tensions(pair.ref, theta, lower, wrench, gravity, pair.rust.mass)
    scale = np.abs(Tr).max(axis=1, keepdims=True)
    assert np.all(np.abs(T - Tr) <= 1e-10 * scale)
    # shared (1-D) loads equal per-row copies
    T1 = pair.rust.tensions(theta, lower=lower[0], tip_wrench=wrench[0], gravity=gravity)
    T2 = pair.rust.tensions(theta, lower=np.tile(lower[0], (300, 1)),
                            tip_wrench=np.tile(wrench[0], (300, 1)), gravity=gravity)
    np.testing.assert_array_equal(T1, T2)


def test_elastic_solve_matches_reference(pair, ref):
    """Coupled solve with a compliant (3 GPa) cable and a routing length."""
    rob = pair.rust.with_cable(youngs_modulus=3e9, routing_length=0.1)
    n = rob.n
    theta0 = random_theta(n, N=60, seed=13, lim=0.4)
    feas = rob.feasible(theta0)
    theta0 = theta0[feas]
    L = rob.upper_lengths(theta0)
    sol = rob.solve_cables_elastic(L, seed=theta0)
    r = ref.solve_cables_elastic(pair.ref, L, 3e9, rob.cable_diameter, routing_length=0.1,
                                 lower=rob.lower_tension, seed=theta0)
    assert sol.converged.all() and r["converged"].all()
    np.testing.assert_allclose(sol.theta, r["theta"], rtol=0, atol=1e-9)
    scale = np.abs(r["tension"]).max(axis=1, keepdims=True)
    assert np.all(np.abs(sol.tension - r["tension"]) <= 1e-8 * scale)
    np.testing.assert_array_equal(sol.feasible, (sol.tension > 0).all(axis=1))


def test_elastic_solve_with_loads_matches_reference(cdsm, ref):
    rob = cdsm.Robot.paper().with_cable(youngs_modulus=5e9)
    theta0 = random_theta(3, N=50, seed=14, lim=0.3)
    wrench = np.array([0.0, -0.05, 0.0])
    gravity = np.array([0.0, -9.81])
    L = rob.upper_lengths(theta0)
    sol = rob.solve_cables_elastic(L, seed=theta0, tip_wrench=wrench, gravity=gravity)
    r = ref.solve_cables_elastic(ref.Robot.paper(), L, 5e9, rob.cable_diameter,
                                 lower=rob.lower_tension, tip_wrench=wrench, gravity=gravity,
                                 mass=rob.mass, seed=theta0)
    assert sol.converged.all() and r["converged"].all()
    np.testing.assert_allclose(sol.theta, r["theta"], rtol=0, atol=1e-9)


# --------------------------------------------------------------------------
# Physics
# --------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["paper", "n1", "n12"])
def test_straight_pose_tensions_equal_the_weights(cdsm, name):
    pair = make_pair(cdsm, name)  # symmetric holes
    n = pair.rust.n
    lower = np.random.default_rng(5).uniform(0.01, 1.0, (4, n))
    T = pair.rust.tensions(np.zeros((4, n)), lower=lower)
    np.testing.assert_allclose(T, lower, rtol=1e-13, atol=0)


def test_paper_straight_tensions_are_50_10_5_grams(cdsm):
    r = cdsm.Robot.paper()
    np.testing.assert_allclose(r.tensions(np.zeros(3)) / G0 * 1e3, [50.0, 10.0, 5.0], rtol=1e-13)


def test_tip_force_on_the_straight_arm_is_held_by_the_lever_rule(cdsm):
    """Straight arm, tip force F down: joint k sees F * (tip x - joint x), so the
    upper cable of pair k takes F * (joint_{k+1} x - joint_k x) / h_k more."""
    r = cdsm.Robot.paper()
    F = 0.3
    dT = r.tensions(np.zeros(3), tip_wrench=[0.0, -F, 0.0]) - r.tensions(np.zeros(3))
    h = np.array([0.030, 0.028, 0.026])
    pitch = np.array([0.076, 0.076, 0.043])  # joint k -> joint k+1 (last: joint 3 -> tip)
    np.testing.assert_allclose(dT, F * pitch / h, rtol=1e-12)


def _sub_robot_toml(linkages, j):
    """First j linkages, the last with half thickness: its tip is disk j's centre."""
    lk = [*linkages[:j]]
    last = lk[-1]
    lk[-1] = type(last)(last.link_before, last.link_after, last.thickness / 2, last.hole_height)
    return robot_toml(lk)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_virtual_work(cdsm, seed):
    """sum_k tau_k dtheta_k = sum_c T_c dL_c for random configurations with a
    tip wrench and gravity; tau from the pose Jacobians of the tip and of the
    disk centres, dL from the cable Jacobian (not the force balance)."""
    r = cdsm.Robot.paper()
    rng = np.random.default_rng(seed)
    N = 200
    theta = rng.uniform(-0.6, 0.6, (N, 3))
    wrench = rng.normal(0.0, [0.3, 0.3, 0.02], (N, 3))
    gravity = rng.normal(0.0, 5.0, 2)
    lower = rng.uniform(0.05, 0.5, (N, 3))
    T = r.tensions(theta, lower=lower, tip_wrench=wrench, gravity=gravity)
    tau = np.einsum("nik,ni->nk", r.fk_jacobian(theta), wrench)
    for j in range(1, 4):  # linkage j's mass at the centre of disk j
        sub = cdsm.Robot.from_toml_str(_sub_robot_toml(PAPER_LINKAGES, j))
        Jc = sub.fk_jacobian(theta[:, :j])[:, :2, :]  # (N, 2, j)
        tau[:, :j] += r.mass[j - 1] * np.einsum("nik,i->nk", Jc, gravity)
    Tall = np.empty((N, 6))
    Tall[:, 0::2], Tall[:, 1::2] = T, lower
    dtheta = rng.normal(0.0, 1e-3, (N, 3))
    dL = np.einsum("nck,nk->nc", r.cable_jacobian(theta), dtheta)
    work_loads = (tau * dtheta).sum(axis=1)
    work_cables = (Tall * dL).sum(axis=1)
    scale = np.abs(Tall * np.abs(dL)).sum(axis=1)
    assert np.all(np.abs(work_loads - work_cables) <= 1e-12 * scale + 1e-18)


def test_weight_order_decides_slack_over_the_grid(cdsm):
    """Paper's order (50, 10, 5 g): all cables taut over ~98% of the +-30 deg
    grid; reversed (5, 10, 50 g): an upper cable would have to push over ~75%."""
    r = cdsm.Robot.paper()
    th = grid30()
    slack_paper = 1.0 - r.feasible(th, lower=PAPER_WEIGHTS).mean()
    slack_rev = 1.0 - r.feasible(th, lower=REVERSED_WEIGHTS).mean()
    assert slack_paper < 0.05
    assert slack_rev > 0.5
    T = r.tensions(th, lower=REVERSED_WEIGHTS)
    assert (T <= 0).any(axis=1).mean() == pytest.approx(slack_rev)


def test_feasible_follows_min_tension(cdsm):
    r = cdsm.Robot.paper()
    th = grid30()
    T = r.tensions(th)
    for tmin in (0.0, 0.01, 0.05):
        np.testing.assert_array_equal(r.feasible(th, min_tension=tmin), (T > tmin).all(axis=1))
    assert bool(r.feasible(np.zeros(3)))


def test_paper_cable_stretch_order_of_magnitude(cdsm):
    """Paper: ~0.0234 mm for ~230 mm of steel (1.8e11 Pa, 0.18 mm) under 50 g.
    The model: upper cable 1 (76 mm in the arm) + 154 mm routing = 230 mm,
    under exactly 50 g at the straight pose."""
    r = cdsm.Robot.paper().with_cable(routing_length=0.154)
    s = r.stretch(np.zeros(3))[0]
    assert s == pytest.approx(0.230 * 0.05 * G0 / (r.axial_stiffness + 0.05 * G0), rel=1e-12)
    assert 0.0234e-3 / 2 < s < 0.0234e-3 * 2
    assert abs(s / 0.0234e-3 - 1.0) < 0.1  # 0.0246 mm vs the paper's 0.0234 mm


def test_stretch_scales_with_inverse_E(cdsm):
    base = cdsm.Robot.paper()
    th = random_theta(3, N=100, seed=21, lim=0.5)
    s1 = base.with_cable(youngs_modulus=1.8e11).stretch(th)
    s2 = base.with_cable(youngs_modulus=3.6e11).stretch(th)
    s3 = base.with_cable(youngs_modulus=1.8e10).stretch(th)
    # exactly (L + route) T / (E A + T): 1/E up to the strain (1e-4 for steel)
    np.testing.assert_allclose(s1 / s2, 2.0, rtol=2e-4)
    np.testing.assert_allclose(s3 / s1, 10.0, rtol=2e-3)
    # and linear in the routing length
    sr = base.with_cable(routing_length=0.2).stretch(th)
    L = base.upper_lengths(th)
    np.testing.assert_allclose(sr / s1, (L + 0.2) / L, rtol=1e-12)


def test_tip_deviation_of_elastic_cables_scales_with_inverse_E(cdsm):
    th = random_theta(3, N=40, seed=22, lim=0.4)
    base = cdsm.Robot.paper()
    th = th[base.feasible(th)]
    L = base.upper_lengths(th)
    d = []
    for E in (1.8e11, 3.6e11):
        rob = base.with_cable(youngs_modulus=E)
        sol = rob.solve_cables_elastic(L, seed=th)
        assert sol.converged.all()
        d.append(rob.fk(sol.theta) - rob.fk(th))
    assert np.abs(d[0][:, :2] - 2.0 * d[1][:, :2]).max() < 2e-3 * np.abs(d[0][:, :2]).max()


def test_steel_is_negligible_polymer_is_not(cdsm):
    """Same commanded lengths as the rigid model: steel moves the tip by well
    under 0.2 mm over the grid, a 3 GPa polymer cable by millimetres."""
    base = cdsm.Robot.paper()
    th = grid30()
    th = th[base.feasible(th)]
    L = base.upper_lengths(th)
    out = {}
    for name, E in (("steel", 1.8e11), ("polymer", 3e9)):
        rob = base.with_cable(youngs_modulus=E)
        sol = rob.solve_cables_elastic(L, seed=th)
        assert sol.converged.all()
        dS = rob.fk(sol.theta) - rob.fk(th)
        out[name] = np.hypot(dS[:, 0], dS[:, 1])
    assert out["steel"].max() < 0.2e-3
    assert np.median(out["polymer"]) > 1e-3


def test_stiff_cable_limit_is_the_rigid_solve(cdsm):
    rob = cdsm.Robot.paper().with_cable(youngs_modulus=1e30)
    th = random_theta(3, N=50, seed=23)
    sol = rob.solve_cables_elastic(rob.upper_lengths(th))
    rigid = rob.solve_cables(rob.upper_lengths(th))
    np.testing.assert_allclose(sol.theta, rigid.theta, atol=1e-12)


def test_elastic_solution_meets_hooke(cdsm):
    rob = cdsm.Robot.paper().with_cable(youngs_modulus=1e10, routing_length=0.2)
    th = random_theta(3, N=30, seed=24, lim=0.3)
    L = rob.upper_lengths(th)
    sol = rob.solve_cables_elastic(L, seed=th)
    assert sol.converged.all()
    eps = sol.tension / rob.axial_stiffness
    Lg = rob.upper_lengths(sol.theta)
    np.testing.assert_allclose(Lg, (L + 0.2) * (1 + eps) - 0.2, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sol.tension, rob.tensions(sol.theta), rtol=1e-12)
    np.testing.assert_allclose(rob.stretch(sol.theta), Lg - L, rtol=0, atol=2e-12)
    one = rob.solve_cables_elastic(L[0], seed=th[0])
    assert one.theta.shape == (3,) and one.tension.shape == (3,)


# --------------------------------------------------------------------------
# Bad input
# --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def robot():
    import cdsm

    return cdsm.Robot.paper()


@pytest.mark.parametrize(
    "call, name",
    [
        (lambda r: r.tensions([[0.0, np.nan, 0.0]]), "theta"),
        (lambda r: r.tensions(np.zeros((2, 4))), "theta"),
        (lambda r: r.tensions(np.zeros((2, 3)), lower=[0.1, 0.2]), "lower"),
        (lambda r: r.tensions(np.zeros((2, 3)), lower=np.zeros((3, 3))), "lower"),
        (lambda r: r.tensions(np.zeros((2, 3)), lower=[0.1, np.inf, 0.1]), "lower"),
        (lambda r: r.tensions(np.zeros(3), tip_wrench=[0.0, np.nan, 0.0]), "tip_wrench"),
        (lambda r: r.tensions(np.zeros(3), tip_wrench=[0.0, 1.0]), "tip_wrench"),
        (lambda r: r.tensions(np.zeros(3), gravity=[0.0, -9.81, 0.0]), "gravity"),
        (lambda r: r.tensions(np.zeros(3), gravity=[np.nan, -9.81]), "gravity"),
        (lambda r: r.feasible(np.zeros(3), min_tension=np.nan), "min_tension"),
        (lambda r: r.stretch([np.nan, 0.0, 0.0]), "theta"),
        (lambda r: r.solve_cables_elastic([0.07, np.nan, 0.2]), "upper"),
        (lambda r: r.solve_cables_elastic(np.full((2, 3), 0.1), seed=np.zeros((3, 3))), "seed"),
        (lambda r: r.solve_cables_elastic([0.07, 0.15, 0.2], max_iter=0), "max_iter"),
        (lambda r: r.solve_cables_elastic([0.07, 0.15, 0.2], tol=-1.0), "tol"),
        (lambda r: r.with_cable(youngs_modulus=-1.0), "cable.youngs_modulus"),
        (lambda r: r.with_cable(diameter=np.nan), "diameter"),
        (lambda r: r.with_cable(routing_length=-0.1), "cable.routing_length"),
    ],
)
def test_bad_input_names_the_argument(robot, call, name):
    import cdsm

    with pytest.raises(cdsm.CdsmInputError, match=f"`{name}`"):
        call(robot)


def test_routing_length_in_the_robot_file(cdsm):
    text = robot_toml(PAPER_LINKAGES)
    cable = "[cable]\nyoungs_modulus = 1.8e11\ndiameter = 0.18e-3\n"
    assert cdsm.Robot.from_toml_str(text).routing_length == 0.0  # back compatible
    r = cdsm.Robot.from_toml_str(text + cable + "routing_length = 0.25\n")
    assert r.routing_length == 0.25
    with pytest.raises(cdsm.CdsmInputError, match="cable.routing_length"):
        cdsm.Robot.from_toml_str(text + cable + "routing_length = -0.25\n")


def _taut(ref, robot, theta, **kw):
    """Every upper cable taut (tension > 0 N) by the NumPy reference's statics."""
    return (ref.tensions(robot, theta, **kw) > 0).all(axis=1)


def test_feasibility_map_helpers(cdsm, ref):
    from cdsm.accuracy import statics, workspace

    r = cdsm.Robot.paper()
    np.testing.assert_allclose(workspace.joint_grid(3), grid30(), rtol=0, atol=1e-15)
    fm = statics.feasibility_map(r, lower=REVERSED_WEIGHTS)
    np.testing.assert_array_equal(fm.feasible, _taut(ref, r, grid30(), lower=REVERSED_WEIGHTS))
    assert fm.slack_fraction > 0.5 and fm.pose.shape == (13**3, 3)
    d = statics.elastic_tip_deviation(r, grid30()[:20], youngs_modulus=3e9)
    assert d.shape == (20, 3) and np.nanmax(np.abs(d[:, :2])) > 1e-4


def test_solves_and_monte_carlo_flag_slack_cables(cdsm, ref):
    """Every solve reports whether its answer can be held with taut cables (as
    the NumPy reference's statics says)."""
    r = cdsm.Robot.paper()
    straight = r.solve_cables(r.upper_lengths(np.zeros(3)))
    assert straight.feasible  # the weights pull the straight arm taut
    grid = grid30()
    sol = r.ik(r.fk(grid))
    np.testing.assert_array_equal(sol.feasible, _taut(ref, r, sol.theta))
    assert 0 < (~sol.feasible).sum() < len(grid)  # some grid poses need a slack cable
    mc = cdsm.accuracy.monte_carlo(r, grid, samples=2, progress=False)
    np.testing.assert_array_equal(mc.feasible0, _taut(ref, r, grid))


def test_monte_carlo_counts_slack_samples(cdsm, ref):
    """check_slack counts, per configuration, the samples whose perturbed
    configuration needs a slack cable: with one sample it is exactly the slack
    flag of that sample's solved configuration."""
    from cdsm.accuracy.montecarlo import monte_carlo, sample_errors

    r = cdsm.Robot.paper()
    grid = grid30()[::7]
    mc = monte_carlo(r, grid, samples=1, seed=5, chunk=1, progress=False, check_slack=True)
    dl, dh = sample_errors(3, 1, 5, 0, np.full(3, 1e-3), np.full(3, 0.35e-3))
    d = cdsm.accuracy.deviation(r, grid, dL=dl[0], dh=dh[0])
    np.testing.assert_array_equal(mc.slack, (~_taut(ref, r, d.solution.theta)).astype(int))
    assert 0 < mc.slack.sum() < len(grid)
    plain = monte_carlo(r, grid, samples=1, seed=5, chunk=1, progress=False)
    assert plain.slack is None
    np.testing.assert_array_equal(plain.sum, mc.sum)  # checking does not change the study


def test_stretch_matches_reference(pair, ref):
    """Elongation T·L/(EA) of every upper cable, Rust vs the NumPy reference
    (which takes it as L_geom − L_rest: a difference of ~0.2 m lengths, so the
    agreement is judged in absolute terms, 1e-15 m)."""
    n = pair.rust.n
    theta = random_theta(n, N=200, seed=17)
    r = pair.rust
    got = r.stretch(theta)
    want = ref.cable_stretch(pair.ref, theta, r.tensions(theta), r.youngs_modulus, r.cable_diameter,
                             r.routing_length)
    assert np.abs(want).max() > 1e-7  # micrometre-scale stretches: the check is not empty
    assert np.all(np.abs(got - want) <= 1e-15)
