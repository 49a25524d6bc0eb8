"""``cdsm list``: the robots and measurement tables shipped with cdsm, by
the names every command accepts (``--robot two_universal``, ``cdsm diagnose
table3``)."""

from __future__ import annotations

import argparse

from .registry import options, subcommand


def _list_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("what", nargs="?", choices=("robots", "data"), help="list only the robots or only the data")


@subcommand("list", help="the packaged robots and measurement tables, by the names the commands accept")
@options(_list_args)
def _list_run(args) -> int:
    from ..calibration import measurements
    from ..inputs import CdsmInputError
    from ..interop import opencr
    from ..robot import Robot, packaged_robots

    configs = list(opencr.CONFIGS)
    if args.what in (None, "robots"):
        print("robots (--robot NAME):")
        for name in list(packaged_robots()) + configs:
            try:
                r = Robot.load(name)
            except CdsmInputError as exc:  # an OpenCR config of a kind cdsm does not read
                print(f"  {name:<36s} not readable: {exc}")
                continue
            print(f"  {name:<36s} {r.kind:<8s} {r.n:2d} joints, {r.cables:2d} cables  {r.name}")
    if args.what in (None, "data"):
        print("measurement tables (cdsm diagnose NAME):")
        for name in measurements.packaged_names():
            # a recording is read for its robot (OpenCR's files: FTDCR v4)
            m = measurements.read_for(Robot.load("ftdcr_v4") if name in opencr.RECORDINGS else Robot.paper(), name)
            print(f"  {name:<36s} {m.reading:<12s} {len(m):4d} rows, {m.n} joints  {m.source}")
    return 0
