"""From a robot file to a diagnosis, in one script: describe and draw the
arm, study its accuracy, take measurements (here from a virtual prototype
with a hidden effect, written to and read back from a CSV file as a real
data set would be), find the effect, plan the next measurements and
compensate the commands. Every number is SI (m, rad, N); prints in mm.

    python examples/walkthrough.py [my_arm.toml] [--out DIR]
"""

import argparse
import os
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402

import cdsm  # noqa: E402
from cdsm.accuracy import montecarlo, sampling  # noqa: E402
from cdsm.calibration import diagnosis, experiment, measurements, plant  # noqa: E402

HERE = Path(__file__).resolve().parent


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("robot", nargs="?", default=str(HERE / "two_section_arm.toml"), help="robot TOML")
    ap.add_argument("--out", default=None, help="directory for the drawing and the data (default: a temporary one)")
    ap.add_argument("--rows", type=int, default=40, help="measured rows")
    ap.add_argument("--samples", type=int, default=200, help="Monte-Carlo samples per configuration")
    args = ap.parse_args(argv)
    out = Path(args.out or tempfile.mkdtemp(prefix="cdsm-walkthrough-"))
    os.makedirs(out, exist_ok=True)

    # 1. the arm
    robot = cdsm.Robot.from_toml(args.robot)
    print(robot)
    ax = robot.plot(np.linspace(0.3, -0.3, robot.n))
    ax.figure.savefig(out / "arm.png", dpi=100)
    print(f"drawing: {out / 'arm.png'}")

    # 2. its accuracy under the seed paper's errors (1 mm on the cables, 0.35 mm on the holes)
    theta = sampling.sample_configurations(robot, 64, seed=1)
    mc = montecarlo.monte_carlo(robot, theta, samples=args.samples, seed=1, progress=False)
    worst = np.nanmax(mc.max[:, -1]) * 1e3
    print(f"Monte Carlo over 64 configurations: {mc}")
    print(f"largest tip error {worst:.2f} mm; failed solves {int(mc.failed.sum())}")

    # 3. measurements: a prototype whose holes are off (hidden), 10 um noise,
    #    written as a CSV file and read back as a measured data set would be
    hidden = {"hole_height": list(np.linspace(2e-4, -1e-4, robot.n))}
    vp = plant.VirtualPrototype(robot, hidden, noise=10e-6, seed=3)
    th, dl = vp.random_commands(args.rows)
    meas = vp.measure(th, dl)
    rows = ["theta_" + str(i + 1) for i in range(robot.n)] + ["dL_" + str(i + 1) for i in range(robot.n)] + ["x", "y"]
    table = np.hstack([meas.theta, meas.dL, meas.measured])
    csv = out / "measurements.csv"
    csv.write_text(",".join(rows) + "\n" + "\n".join(",".join(repr(float(v)) for v in r) for r in table) + "\n")
    data = measurements.read_for(robot, csv)
    print(f"measurements: {csv} ({len(data)} rows)")

    # 4. the diagnosis, and what to measure next
    d = diagnosis.diagnose(robot, data)
    print(d)
    print(f"verdict: {d.verdict}; best: {d.best}")
    s = experiment.suggest(d, 4)
    print(f"next measurements: {len(s.theta)} commands (theta in deg):")
    for t in s.theta:
        print("   ", ", ".join(f"{v:+.1f}" for v in np.degrees(t)))

    # 5. compensation: the commands that put the real arm's tip where the nominal one would go
    model = cdsm.FittedPlant.from_diagnosis(d)
    targets = robot.fk(theta[:5])[:, :2]
    comp = model.compensate(targets)
    print(f"compensated {int(comp.converged.sum())} of {len(targets)} targets: predicted tip error "
          f"{np.nanmax(comp.predicted_error_nominal) * 1e6:.1f} um with the nominal commands, "
          f"{np.nanmax(comp.predicted_error) * 1e6:.3f} um with the compensated ones")


if __name__ == "__main__":
    main()
