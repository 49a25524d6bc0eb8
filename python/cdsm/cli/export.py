"""``cdsm export``: the robot for other tools, MuJoCo's MJCF and URDF (``docs/interop.md``)."""

from __future__ import annotations

import argparse
import os

from .registry import (UserError, add_robot_option, check_out_file, load_robot, options, subcommand)


def _export_args(p: argparse.ArgumentParser) -> None:
    add_robot_option(p)
    p.add_argument("--mjcf", metavar="OUT.xml", help="write MuJoCo's MJCF: a body per disk, a hinge per "
                   "joint in cdsm's order, a site per hole, a spatial tendon per cable, actuators")
    p.add_argument("--urdf", metavar="OUT.urdf", help="write the URDF: revolute joints in cdsm's order, "
                   "inertials, a link 'tip' at the end frame")


@subcommand("export", help="write the robot as MuJoCo MJCF and/or URDF")
@options(_export_args)
def _export_run(args) -> int:
    from ..files import write_text

    if args.mjcf is None and args.urdf is None:
        raise UserError("export: give --mjcf OUT.xml and/or --urdf OUT.urdf")
    if args.mjcf is not None and args.urdf is not None \
            and os.path.abspath(args.mjcf) == os.path.abspath(args.urdf):
        raise UserError(f"--mjcf, --urdf: both name {args.mjcf!r}")
    check_out_file(args.mjcf, "--mjcf")
    check_out_file(args.urdf, "--urdf")
    robot = load_robot(args.robot)
    # build both texts before writing either: a robot MuJoCo cannot take leaves no file behind
    texts = []
    if args.mjcf is not None:
        texts.append(("MJCF", args.mjcf, robot.to_mjcf()))
    if args.urdf is not None:
        texts.append(("URDF", args.urdf, robot.to_urdf()))
    print(f"robot {robot.name!r} ({robot.kind}, {robot.n} joints, {robot.cables} cables)")
    for what, path, text in texts:
        write_text(path, text, what)
        print(f"{what}: {os.path.abspath(path)}")
    return 0
