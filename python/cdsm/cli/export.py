"""``cdsm export``: the robot for other tools, MuJoCo's MJCF and URDF (``docs/interop.md``)."""

from __future__ import annotations

import argparse
import os

from .paths import add_path
from .registry import (UserError, add_robot_option, load_robot, options, subcommand)


def _export_args(p: argparse.ArgumentParser) -> None:
    add_robot_option(p)
    add_path(p, "--mjcf", role="output", metavar="OUT.xml", help="write MuJoCo's MJCF: a body per disk, a hinge per "
             "joint in cdsm's order, a site per hole, a spatial tendon per cable, actuators")
    add_path(p, "--urdf", role="output", metavar="OUT.urdf", help="write the URDF: revolute joints in cdsm's order, "
             "inertials, a link 'tip' at the end frame")


@subcommand("export", help="write the robot as MuJoCo MJCF and/or URDF")
@options(_export_args)
def _export_run(args) -> int:
    from ..files import write_text

    if args.mjcf is None and args.urdf is None:
        raise UserError("export: give --mjcf OUT.xml and/or --urdf OUT.urdf")
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
