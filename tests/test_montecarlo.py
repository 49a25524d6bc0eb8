"""The Monte-Carlo kernel's two paths agree: the closed form across SIMD lanes
(``method="auto"``: a block's deviations and statistics computed lane by lane)
and the damped Newton one row at a time (``method="newton"``: every sample
through the per-row path), on the paper's errors."""

from __future__ import annotations

import numpy as np


def test_closed_form_lanes_and_newton_rows_give_the_same_statistics(cdsm):
    from cdsm.accuracy import montecarlo, workspace

    robot = cdsm.Robot.paper()
    # 314 configurations: 19 full blocks of 16 lanes and a partial one
    grid = workspace.joint_grid(robot.n)[::7]
    auto = montecarlo.monte_carlo(robot, grid, samples=40, seed=3, progress=False, method="auto")
    newton = montecarlo.monte_carlo(robot, grid, samples=40, seed=3, progress=False, method="newton")
    assert auto.count.sum() == 40 * len(grid) and auto.failed.sum() == 0
    np.testing.assert_array_equal(auto.count, newton.count)
    np.testing.assert_array_equal(auto.failed, newton.failed)
    # both solve to 1e-12 m on the cables: the deviations agree to about
    # 1e-11 (m, rad) per sample
    for name in ("min", "max"):
        np.testing.assert_allclose(getattr(auto, name), getattr(newton, name), rtol=0, atol=1e-9)
    np.testing.assert_allclose(auto.sum, newton.sum, rtol=0, atol=40 * 1e-9)
    np.testing.assert_allclose(auto.sum_sq, newton.sum_sq, rtol=0, atol=40 * 1e-10)
    # the histogram of |dXY| may move a sample only across a bin edge
    assert np.abs(auto.dense_hist() - newton.dense_hist()).sum() <= 2


def test_merged_chunks_count_every_bin_of_their_parts(cdsm):
    """Each chunk's histogram holds only the window of bins its samples
    reach (uint32); a merged study holds the union (int64): the same counts
    in every bin as the chunks' full histograms added up."""
    from cdsm.accuracy import montecarlo

    r = cdsm.Robot.paper()
    # near straight (small errors) and bent: the chunks' windows differ
    theta = np.ascontiguousarray([[0.0, 0.0, 0.01], [0.5, -0.5, 0.5], [-0.2, 0.3, 0.0]])
    tol = (np.full(3, 1e-3), np.full(3, 0.35e-3))
    for chunk in (60, 7, 1):
        mc = montecarlo.monte_carlo(r, theta, samples=60, seed=5, chunk=chunk, progress=False)
        parts = [montecarlo.monte_carlo_chunk(r, theta, 5, c, m, *tol)
                 for c, m in enumerate(montecarlo.chunk_sizes(60, chunk))]
        assert all(p.hist.dtype == np.uint32 and 0 < p.hist.shape[1] < cdsm._cdsm.HIST_BINS for p in parts)
        full = np.zeros((3, cdsm._cdsm.HIST_BINS), np.int64)
        for p in parts:
            full[:, p.hist_lo:p.hist_lo + p.hist.shape[1]] += p.hist
        assert full.sum() == 180
        np.testing.assert_array_equal(mc.dense_hist(), full)
        assert mc.hist.dtype == (np.uint32 if chunk == 60 else np.int64)


def test_percentiles_are_the_sample_quantiles_within_their_bound(cdsm):
    """Issue 23: a Monte-Carlo percentile is within QUANTILE_BOUND (0.498 %)
    of the sample quantile (the smallest sample with at least p % at or
    below it) of the stored samples: here every sample's deviation is
    recomputed by a separate batch solve of its cable lengths."""
    from cdsm.accuracy import montecarlo

    r = cdsm.Robot.paper()
    theta = np.array([[0.3, -0.2, 0.1], [-0.5, 0.4, 0.3], [0.55, -0.55, 0.2]])
    S = 4000
    mc = montecarlo.monte_carlo(r, theta, samples=S, seed=3, chunk=1000, dh_tol=0.0, progress=False)
    assert (mc.count == S).all()
    dl = np.concatenate([montecarlo.sample_errors(3, 1000, 3, c, np.full(3, 1e-3), np.zeros(3))[0]
                         for c in range(4)])
    for j, t in enumerate(theta):
        sol = r.solve_cables(r.upper_lengths(t) + dl, seed=np.tile(t, (S, 1)))
        d = np.sort(np.hypot(*(r.fk(sol.theta)[:, :2] - r.fk(t)[:2]).T))
        for p in (5.0, 50.0, 90.0, 95.0, 99.0, 99.9, 100.0):
            exact = d[int(np.ceil(p / 100 * S)) - 1]
            assert abs(mc.percentile(p)[j] / exact - 1) <= montecarlo.QUANTILE_BOUND, (j, p)
    # the pooled percentile of one configuration is its own
    from cdsm.accuracy.tolerance import pooled_percentile

    assert pooled_percentile(mc, 95.0, rows=[1]) == mc.percentile(95.0)[1]
