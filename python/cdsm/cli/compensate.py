"""``cdsm compensate``: cable commands that put the tip on target poses under a fitted model."""

from __future__ import annotations

import argparse
import os

from .paths import add_path
from .registry import (UserError, options, subcommand)


# ---------------------------------------------------------------------------
def _compensate_args(p: argparse.ArgumentParser) -> None:
    add_path(p, "targets", role="input", metavar="TARGETS.csv", help="target poses: columns x, y (m) and optional "
             "phi (rad); spatial arms x, y, z (m) and optional rx, ry, rz (rotation vector, rad); "
             "'#' comment lines")
    add_path(p, "--model", role="input", metavar="MODEL.json", required=True,
             help="fitted model (cdsm diagnose --save-model; format cdsm-model/2, also reads /1)")
    add_path(p, "--out", role="output", metavar="COMMANDS.csv", required=True,
             help="output: cable length commands L_i (m) per target (planar: the upper cables; spatial: the "
                  "position-controlled ones), converged, "
                  "predicted tip error (m), flags")
    p.add_argument("--tol", metavar="M", type=float, default=1e-9,
                   help="tip residual tolerance of the compensation solve, m (default 1e-9)")
    p.add_argument("--enforce-limits", action="store_true",
                   help="leave out targets whose nominal IK answer is outside the joint limits "
                        "(default: compensate them and flag the row)")


@subcommand("compensate", help="upper-cable commands that put the tip on target poses under a fitted model")
@options(_compensate_args)
def _compensate_run(args) -> int:
    from ..calibration.compensation import read_targets
    from ..calibration.model import FittedPlant

    if not (args.tol > 0 and args.tol < 1):
        raise UserError(f"--tol: expected a positive length in m, got {args.tol}")
    model = FittedPlant.load(args.model)
    poses = read_targets(args.targets, model.robot.kind)
    res = model.compensate(poses, tol=args.tol, enforce_limits=args.enforce_limits)
    res.to_csv(args.out)
    print(f"model {model.name!r} ({model.robot.name}, {model.robot.n} joints)")
    print(res.summary())
    for i, f in enumerate(res.flags):
        if f:
            print(f"  row {i + 1}: {f}")
    print(f"commands: {os.path.abspath(args.out)}")
    return 0


# ---------------------------------------------------------------------------
# main
# ---------------------------------------------------------------------------
