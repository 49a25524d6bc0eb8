"""Describe a new robot in TOML and ask the first questions about it: its
reach, its cable lengths, whether its cables stay taut, and how sensitive its
tip is to cable-length errors. SI units (m, rad, N).

    python examples/describe_robot.py examples/two_section_arm.toml
"""

import argparse
import os

import numpy as np

import cdsm
from cdsm.accuracy import sensitivity, workspace

HERE = os.path.dirname(os.path.abspath(__file__))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("robot", nargs="?", default=os.path.join(HERE, "two_section_arm.toml"))
    ap.add_argument("--step", type=float, default=15.0, help="joint grid step, degrees")
    args = ap.parse_args(argv)

    robot = cdsm.Robot.from_toml(args.robot)  # a bad file names the field and the problem
    print(robot)
    theta = np.radians([20.0, -10.0, 15.0, 5.0][:robot.n] + [0.0] * max(0, robot.n - 4))
    print("tip pose [x m, y m, phi rad]:", robot.fk(theta).round(5))
    print("cable lengths (m):", robot.cable_lengths(theta).round(5))
    sol = robot.solve_cables(robot.upper_lengths(theta) + 1e-3 * np.eye(robot.n)[0], seed=theta)
    moved = np.linalg.norm(robot.fk(sol.theta)[:2] - robot.fk(theta)[:2])
    print(f"1 mm more on cable 1 moves the tip by {moved * 1e3:.3f} mm ({sol.reason})")
    grid = workspace.joint_grid(robot.n, -0.5, 0.5, np.radians(args.step))
    taut = robot.feasible(grid)
    print(f"{100 * taut.mean():.1f} % of {len(grid)} grid configurations hold every upper cable taut")
    s = sensitivity.sensitivities(robot, grid)
    gain = np.linalg.norm(s.cable[:, :2, :], axis=(1, 2))
    print(f"tip sensitivity to cable lengths: median {np.nanmedian(gain):.2f}, max {np.nanmax(gain):.2f} m/m")


if __name__ == "__main__":
    main()
