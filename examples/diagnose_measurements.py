"""Diagnose your own measurements: which unmodelled effect explains the gap
between the nominal model and the arm, how far it shrinks, and what to
measure next.

The measurement CSV has one row per measurement (SI units): the commanded
configuration (``theta_1..theta_n`` in rad, or ``x_cmd, y_cmd[, phi_cmd]``),
optional ``dL_1..dL_n`` (m), and the measured ``x, y`` (absolute, m) or
``dx, dy`` (displacements, m). Without a file this script makes one from a
virtual prototype with a hidden effect, so it runs anywhere.

    python examples/diagnose_measurements.py my_data.csv --robot my_arm.toml
"""

import argparse

import cdsm
from cdsm.calibration import diagnosis, experiment, measurements, plant


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    ap.add_argument("data", nargs="?", help="measurement CSV (default: made by a virtual prototype)")
    ap.add_argument("--robot", help="robot TOML (default: the paper's prototype)")
    ap.add_argument("--rows", type=int, default=40, help="rows of the virtual data set")
    ap.add_argument("--frame", default="register", choices=("register", "base"))
    args = ap.parse_args(argv)

    robot = cdsm.Robot.from_toml(args.robot) if args.robot else cdsm.Robot.paper()
    if args.data:
        meas = measurements.read_csv(args.data, robot.n)
    else:  # a prototype whose holes are 0.2 mm off, seen by a tracker with 20 µm noise; every
        # command measured twice in a row, so the diagnosis can tell the noise from the gap
        vp = plant.VirtualPrototype(robot, {"hole_height": [2e-4, -1e-4, 2e-4][:robot.n]}, noise=20e-6, seed=1)
        theta, dL = vp.random_commands(args.rows // 2)
        meas = vp.measure(theta.repeat(2, axis=0), dL.repeat(2, axis=0))

    d = diagnosis.diagnose(robot, meas, frame=args.frame)
    print(f"verdict: {d.verdict}; best model: {d.best}")
    print(f"held-out RMS position error: nominal {d.baseline.heldout_rms * 1e6:.1f} µm -> "
          f"{d.final().heldout_rms * 1e6:.1f} µm (noise floor {d.noise_floor * 1e6:.1f} µm, "
          f"noise {d.noise * 1e6:.3g} µm {d.noise_estimate.source})")
    for name, values in d.final().fit.params_by_effect(robot).items():
        print(f"  {name}: {[f'{v:.3g}' for v in values]} (SI)")
    if d.ties:
        print("tied with the best single effect:", ", ".join(d.ties))
    sug = experiment.suggest(d, 3)
    print(sug.summary())


if __name__ == "__main__":
    main()
