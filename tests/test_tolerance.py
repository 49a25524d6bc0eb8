"""Issue 7: sensitivities (Rust vs NumPy reference vs finite differences),
tolerance allocation, the ``cdsm tolerance`` CLI and sensitivity-aware
configurations."""

import json

import numpy as np
import pytest

from cdsm import reference as ref
from cdsm.accuracy import configurations as design_config, sensitivity, tolerance
from cdsm.cli import main
from cdsm.accuracy.scenarios import deviation
from cdsm.robot import Robot
from cdsm.accuracy.workspace import joint_grid

ROBOT8 = "python/cdsm/robots/serpentine8.toml"


@pytest.fixture(scope="module")
def paper():
    return Robot.paper()


@pytest.fixture(scope="module")
def r8():
    import os
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    return Robot.from_toml(os.path.join(here, ROBOT8))


def _tilted(robot, seed=3):
    rng = np.random.default_rng(seed)
    return robot.with_holes(robot.holes + rng.uniform(-1e-3, 1e-3, robot.holes.shape))


def _rel(a, b):
    return np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300)


@pytest.mark.parametrize("which", ["paper", "tilted", "r8"])
def test_rust_matches_reference(which, paper, r8):
    robot = {"paper": paper, "tilted": _tilted(paper), "r8": r8}[which]
    rng = np.random.default_rng(7)
    lim = robot.joint_limits
    th = rng.uniform(lim[:, 0], lim[:, 1], (40, robot.n))
    s = sensitivity.sensitivities(robot, th, holes=True)
    r = ref.tip_sensitivity(ref.Robot.like(robot), th)
    assert s.ok.all()
    assert s.pair is s.groups
    for key, want in (("cable", r["cable"]), ("groups", r["pair"]), ("coords", r["holes"])):
        got = getattr(s, key)
        assert got.shape == want.shape
        # 1e-9 relative to each array's scale (entries are O(0.01..10))
        assert _rel(got, want) < 1e-9, key


def _flat_index(c, d, f):
    """Where hole (cable c, disk d, face f) of the planar layout starts in
    ``Robot.flat_holes``: the cable's holes are base face b, then faces a
    and b of disks 1..end."""
    start = sum(3 * (2 * (k // 2 + 1) + 1) for k in range(c))
    return start + 3 * (0 if d == 0 else 2 * d - 1 + f)


def test_the_planar_holes_shape_is_deprecated_and_equals_the_flat_coordinates(paper):
    th = np.array([[0.2, -0.3, 0.1], [-0.4, 0.25, 0.35]])
    s = sensitivity.sensitivities(paper, th, holes=True)
    with pytest.warns(DeprecationWarning, match="Sensitivities.coords"):
        h = s.holes
    assert h.shape == (2, 3, 6, 4, 2, 2)
    mask = ref.used_hole_mask(paper.n)
    want = np.zeros(h.shape)
    for c in range(2 * paper.n):
        for d in range(paper.n + 1):
            for f in range(2):
                if mask[c, d, f]:
                    at = _flat_index(c, d, f)
                    want[:, :, c, d, f] = s.coords[:, :, at:at + 2]
    np.testing.assert_array_equal(h, want)
    # the reference's planar layout of the same numbers
    r = ref.tip_sensitivity(ref.Robot.like(paper), th)
    np.testing.assert_allclose(h, ref.to_planar_layout(ref.Robot.like(paper), r["holes"]), rtol=0, atol=1e-9)
    # a spatial arm's: its flat coordinates, warned too
    sp = Robot.packaged("two_universal")
    ss = sensitivity.sensitivities(sp, np.zeros((1, sp.n)), holes=True)
    with pytest.warns(DeprecationWarning):
        assert ss.holes is ss.coords


def test_lower_cable_and_z_do_not_move_the_tip(paper):
    s = sensitivity.sensitivities(paper, [0.2, -0.3, 0.1], holes=True)
    h = s.coords[0]  # (3, 3H)
    assert np.all(h[:, 2::3] == 0.0)  # a planar arm's z
    for c in range(1, 2 * paper.n, 2):  # lower cables are force controlled
        start = _flat_index(c, 0, 1)
        assert np.all(h[:, start:start + 3 * (2 * (c // 2 + 1) + 1)] == 0.0)
    assert np.all(h[:, :2] != 0.0)  # cable 1's base hole does


def test_sensitivities_match_finite_differences_of_the_deviation(paper):
    th = np.array([[0.3, -0.2, 0.45], [-0.5, 0.1, -0.05]])
    s = sensitivity.sensitivities(paper, th, holes=True)
    h = 1e-5
    for j in range(paper.n):
        d = np.zeros(paper.n)
        d[j] = h
        fd = (deviation(paper, th, dL=d, tol=1e-15, max_iter=400).dS
              - deviation(paper, th, dL=-d, tol=1e-15, max_iter=400).dS) / (2 * h)
        assert np.allclose(fd, s.cable[:, :, j], rtol=1e-5, atol=1e-8)
        fd = (deviation(paper, th, dh=d, tol=1e-15, max_iter=400).dS
              - deviation(paper, th, dh=-d, tol=1e-15, max_iter=400).dS) / (2 * h)
        assert np.allclose(fd, s.groups[:, :, j], rtol=1e-5, atol=1e-8)
    rng = np.random.default_rng(0)
    mask = ref.used_hole_mask(paper.n)
    for _ in range(6):
        c = 2 * rng.integers(0, paper.n)
        d_idx = rng.choice(np.flatnonzero(mask[c].ravel()))
        dd, f = divmod(int(d_idx), 2)
        x = int(rng.integers(0, 2))
        dh = np.zeros(paper.holes.shape)
        dh[c, dd, f, x] = h
        fd = (deviation(paper, th, dholes=dh, tol=1e-15, max_iter=400).dS
              - deviation(paper, th, dholes=-dh, tol=1e-15, max_iter=400).dS) / (2 * h)
        assert np.allclose(fd, s.coords[:, :, _flat_index(int(c), dd, f) + x], rtol=1e-4, atol=1e-8)


def test_amplification_formulas(paper):
    s = sensitivity.sensitivities(paper, [[0.1, -0.2, 0.3]])
    m = sensitivity.error_matrix(s)[0]
    amp = sensitivity.amplification(s, 1e-3, 0.35e-3)
    t = np.r_[np.full(3, 1e-3), np.full(3, 0.35e-3)]
    assert np.isclose(amp["worst_x"][0], np.abs(m[0]) @ t)
    assert np.isclose(amp["rms_xy"][0], np.sqrt(((m ** 2).sum(0) @ t ** 2) / 3))
    # RMS of the linear model by sampling
    v = np.random.default_rng(0).uniform(-1, 1, (200000, 6)) * t
    e = v @ m.T
    assert np.isclose(np.sqrt((e ** 2).sum(1).mean()), amp["rms_xy"][0], rtol=5e-3)


def test_pooled_percentile_merges_histograms(paper):
    from cdsm.accuracy.montecarlo import monte_carlo
    mc = monte_carlo(paper, joint_grid(3, np.radians(-10), np.radians(10), np.radians(10)),
                     samples=200, progress=False)
    p = tolerance.pooled_percentile(mc, 95)
    per = mc.percentile(95)
    assert per.min() <= p <= per.max()
    # the interpolated estimate lies in the same bin as the bin's middle
    assert abs(tolerance.pooled_percentile(mc, 95, interpolate=True) / p - 1) <= 2.01 * tolerance.HIST_RESOLUTION


def test_allocation_holds_and_is_not_loose(paper):
    theta = joint_grid(3, np.radians(-30), np.radians(30), np.radians(15))
    a = tolerance.allocate(paper, 1e-3, theta, samples=200, seed=1)
    assert a.holds and a.achieved_m <= 1e-3
    assert a.not_loose
    # independent re-check of the two claims with the public Monte Carlo
    from cdsm.accuracy.montecarlo import monte_carlo
    mc = monte_carlo(paper, theta, samples=200, seed=1, dl_tol=a.cable_length_tol_m,
                     dh_tol=a.hole_height_tol_m, progress=False)
    assert tolerance.pooled_percentile(mc, 95) <= 1e-3
    mc = monte_carlo(paper, theta, samples=200, seed=1, dl_tol=1.25 * a.cable_length_tol_m,
                     dh_tol=1.25 * a.hole_height_tol_m, progress=False)
    assert tolerance.pooled_percentile(mc, 95) > 1e-3
    # equal relative cost: the paper's 1 : 0.35 ratio
    assert np.allclose(a.hole_height_tol_m / a.cable_length_tol_m, 0.35)
    # weights shift the shape
    w = tolerance.allocate(paper, 1e-3, theta, weights=[2, 1], samples=100, seed=1)
    assert np.allclose(w.hole_height_tol_m / w.cable_length_tol_m, 0.175)
    assert w.holds and w.not_loose


def test_distribution_per_region(paper):
    theta = joint_grid(3, np.radians(-30), np.radians(30), np.radians(15))
    d = tolerance.distribution(paper, 1e-3, 0.35e-3, theta, samples=100, cells=2)
    assert sum(r["configurations"] for r in d["regions"]) == len(theta)
    assert all(r["p95_m"] >= r["p50_m"] for r in d["regions"])
    assert d["per_config"].shape == (len(theta), 3)


def test_cli_json_keys(tmp_path, paper):
    out = tmp_path / "tol.json"
    rc = main(["tolerance", "--target-mm", "2", "--region", "grid:-30:30:15", "--samples", "100",
               "--json", str(out), "--quiet"])
    assert rc == 0
    d = json.loads(out.read_text())
    assert len(d["cable_length_tol_m"]) == 3 and len(d["hole_height_tol_m"]) == 3
    assert d["achieved_mm"] <= 2.0
    assert d["achieved_at_1p25_tol_mm"] > 2.0
    assert isinstance(d["regions"], list)


def test_cli_regions_from_files(tmp_path, paper):
    jf = tmp_path / "j.csv"
    jf.write_text("t1,t2,t3\n0.1,0.2,-0.1\n-0.2,0.1,0.3\n0,0.3,0.2\n")
    out = tmp_path / "o.json"
    assert main(["tolerance", "--target-mm", "1", "--region", f"joints:{jf}", "--samples", "50",
                 "--json", str(out), "--quiet"]) == 0
    pf = tmp_path / "p.csv"
    pf.write_text("# x, y, phi\n0.2,-0.05,0\n0.21,0.03,0\n")
    assert main(["tolerance", "--target-mm", "1", "--region", f"poses:{pf}", "--samples", "50",
                 "--quiet"]) == 0


@pytest.mark.parametrize("argv,needle", [
    (["--target-mm", "0"], "--target-mm"),
    (["--target-mm", "1", "--percentile", "100"], "--percentile"),
    (["--target-mm", "1", "--region", "grid:1:2"], "--region"),
    (["--target-mm", "1", "--region", "cube:1"], "--region"),
    (["--target-mm", "1", "--region", "joints:/nonexistent.csv"], "does not exist"),
    (["--target-mm", "1", "--weights", "1,2,3"], "weights"),
    (["--target-mm", "1", "--weights", "a,b"], "--weights"),
    (["--target-mm", "1", "--base-mm", "1"], "--base-mm"),
    (["--target-mm", "1", "--robot", "/nonexistent.toml"], "robot file"),
    (["--target-mm", "1", "--json", "/nonexistent/dir/x.json"], "--json"),
])
def test_cli_errors(argv, needle, capsys):
    assert main(["tolerance"] + argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("cdsm: error:") and needle in err


def test_cli_missing_target_is_usage_error():
    with pytest.raises(SystemExit) as e:
        main(["tolerance"])
    assert e.value.code == 2


def test_branch_choice_improves_or_equals_the_default(paper):
    g = joint_grid(3, np.radians(-30), np.radians(30), np.radians(10))
    poses = paper.fk(g)
    poses[:, 2] = 0.0
    b = design_config.best_configurations(paper, poses)
    ok = b["ok"]
    assert ok.sum() > 20
    assert np.all(b["rms_best"][ok] <= b["rms_default"][ok] + 1e-15)
    assert np.allclose(paper.fk(b["theta_best"][ok]), poses[ok], atol=1e-9)
    assert paper.within_limits(b["theta_best"][ok]).all()
    assert (b["rms_best"][ok] < 0.99 * b["rms_default"][ok]).any()
    c = design_config.compare_with_default(paper, poses, samples=200, best=b)
    assert c["pooled_best_m"] <= c["pooled_default_m"] * 1.04  # one histogram bin


def test_null_space_descent_keeps_the_pose_and_improves(r8):
    rng = np.random.default_rng(0)
    poses = r8.fk(rng.uniform(-0.4, 0.4, (8, 8)))
    b = design_config.best_configurations(r8, poses, iters=30, starts=2)
    ok = b["ok"]
    assert ok.any()
    assert np.allclose(r8.fk(b["theta_best"][ok]), poses[ok], atol=1e-9)
    assert r8.within_limits(b["theta_best"][ok]).all()
    assert np.all(b["rms_best"][ok] <= b["rms_default"][ok] + 1e-15)
    assert (b["rms_best"][ok] < b["rms_default"][ok]).any()


def test_path_is_continuous(paper, r8):
    th = np.linspace([-0.3, 0.25, 0.0], [0.3, -0.25, 0.1], 21)
    poses = paper.fk(th)
    p = design_config.path_configurations(paper, poses)
    assert np.allclose(paper.fk(p["theta"]), poses, atol=1e-9)
    assert p["max_joint_step"] <= 0.05
    # the theta = 0 seeded default switches branch along this path; the DP does not
    d = paper.ik(poses)
    assert np.abs(np.diff(d.theta, axis=0)).max() > 0.15
    assert p["rms"].sum() <= design_config.rms_amplification(paper, d.theta).sum()
    ys8 = np.linspace(-0.05, 0.05, 6)
    poses8 = np.stack([np.full_like(ys8, 0.36), ys8, np.zeros_like(ys8)], axis=1)
    p8 = design_config.path_configurations(r8, poses8, iters=15)
    assert np.allclose(r8.fk(p8["theta"]), poses8, atol=1e-9)
    assert p8["max_joint_step"] < 0.3


def test_linear_vs_mc_summary(paper):
    from cdsm.accuracy.workspace import grid_neighbours, sweep
    g = joint_grid(3, np.radians(-30), np.radians(30), np.radians(10))
    ws = sweep(paper, "joint", grid=g, neighbours=grid_neighbours(7, 3))
    res = sensitivity.linear_vs_mc(paper, ws=ws, samples=100)
    other = res["summary"]["other"]
    assert other["count"] > 0
    assert other["rms_ratio_dev_median"] < 0.1
    assert np.isfinite(res["ratio_rms"]).all()
