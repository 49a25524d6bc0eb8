"""Command line of cdsm: ``cdsm <command> [options]``, one module per command
(:data:`COMMAND_MODULES`); the registry and shared option types are in
:mod:`cdsm.cli.registry`."""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from typing import List, Optional

from ..inputs import CdsmInputError
from .paths import claimed
from .registry import COMMANDS, PROG, UserError

__all__ = ["main", "build_parser", "COMMANDS", "COMMAND_MODULES"]

#: the modules that register the commands, in help order
COMMAND_MODULES = ("paper", "diagnose", "compensate", "tolerance", "montecarlo", "export", "listing")


def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with one subparser per registered command."""
    from .. import __version__

    for name in COMMAND_MODULES:
        importlib.import_module(f"{__name__}.{name}")
    # allow_abbrev=False on every parser: an option is taken only as spelt
    # (`--sample 5` is refused, not read as `--samples 5`)
    parser = argparse.ArgumentParser(
        prog=PROG, description="Kinematics and tip-positioning accuracy of cable-driven serpentine "
                               "manipulators (SI units).", allow_abbrev=False)
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for cmd in COMMANDS.values():
        p = sub.add_parser(cmd.name, help=cmd.help, description=cmd.help, allow_abbrev=False)
        cmd.add_args(p)
        p.set_defaults(_run=cmd.run, _parser=p)
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``cdsm``; returns the exit status (0 ok, 2 user error)."""
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)  # exits 2 with a usage line on bad options
    if extra:
        # an option the command does not know: the command's usage, not the top level's
        (getattr(args, "_parser", None) or parser).error(f"unrecognized arguments: {' '.join(extra)}")
    if getattr(args, "_run", None) is None:
        parser.print_help(sys.stderr)
        return 2

    try:
        with claimed(args):  # path options checked, output directories owned, before the command computes
            return int(args._run(args) or 0)
    except (CdsmInputError, UserError) as exc:
        msg = " ".join(str(exc).split())
        print(f"{PROG}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\n{PROG}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into e.g. `head`, which closed early
        sys.stdout = open(os.devnull, "w")
        return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
