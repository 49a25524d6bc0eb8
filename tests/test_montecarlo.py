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
    assert np.abs(auto.hist - newton.hist).sum() <= 2
