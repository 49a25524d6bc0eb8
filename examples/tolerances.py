"""Allocate manufacturing tolerances: the largest ± tolerances on the
upper-cable lengths and hole heights that keep the 95th percentile of the
tip position error within a budget over the workspace, checked by Monte
Carlo in the Rust core. SI units (m).

    python examples/tolerances.py --target-mm 1
"""

import argparse

import cdsm
from cdsm.accuracy import tolerance, workspace


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("--target-mm", type=float, default=1.0, help="tip error budget, mm")
    ap.add_argument("--samples", type=int, default=1000, help="Monte-Carlo samples per configuration")
    ap.add_argument("--step", type=float, default=5.0, help="joint grid step, degrees")
    args = ap.parse_args(argv)

    robot = cdsm.Robot.paper()
    import numpy as np

    region = workspace.joint_grid(robot.n, step=np.radians(args.step))
    a = tolerance.allocate(robot, args.target_mm * 1e-3, region, samples=args.samples)
    print("cable length tolerance (mm):", ", ".join(f"{v * 1e3:.4f}" for v in a.cable_length_tol_m))
    print("hole height tolerance (mm):  ", ", ".join(f"{v * 1e3:.4f}" for v in a.hole_height_tol_m))
    print(f"P95 |d(x, y)| = {a.achieved_m * 1e3:.4f} mm (target {args.target_mm} mm); "
          f"every tolerance x1.25 gives {a.achieved_1p25_m * 1e3:.4f} mm")


if __name__ == "__main__":
    main()
