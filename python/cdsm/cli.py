"""Command line of cdsm: ``cdsm <command> [options]``.

Subcommands live in a registry (:data:`COMMANDS`): each is one function that
adds its options and one that runs it. To add one (diagnose, tolerance,
montecarlo, ...)::

    def _name_args(p: argparse.ArgumentParser) -> None:   # add options
        p.add_argument(...)

    @subcommand("name", help="one line")
    @options(_name_args)
    def _name_run(args) -> int:                            # exit status
        ...

User errors (bad options, bad robot or data files: :class:`CdsmInputError`)
exit with status 2 and one line ``cdsm: error: ...`` on stderr, no traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import Callable, Dict, List, Optional

__all__ = ["main", "subcommand", "COMMANDS"]

PROG = "cdsm"


class _Command:
    def __init__(self, name: str, help: str, add_args: Callable, run: Callable):
        self.name, self.help, self.add_args, self.run = name, help, add_args, run


#: name -> command; filled by :func:`subcommand`.
COMMANDS: Dict[str, _Command] = {}


def subcommand(name: str, help: str):
    """Register a subcommand: decorates ``run(args) -> int``; the options are
    added by ``run.add_args(parser)`` (set with :func:`options`)."""
    def deco(run: Callable) -> Callable:
        COMMANDS[name] = _Command(name, help, getattr(run, "add_args", lambda p: None), run)
        return run
    return deco


def options(add_args: Callable):
    """Attach the option builder ``add_args(parser)`` to a run function
    (use below :func:`subcommand`)."""
    def deco(run: Callable) -> Callable:
        run.add_args = add_args
        return run
    return deco


class UserError(Exception):
    """A user mistake reported as ``cdsm: error: <message>`` with exit status 2."""


# ---------------------------------------------------------------------------
# option types
# ---------------------------------------------------------------------------
def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return v


def _seed(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}")
    return v


def load_robot(path: Optional[str]):
    """The robot of ``--robot`` (TOML file), or the paper's prototype."""
    from .robot import CdsmInputError, Robot

    if path is None:
        return Robot.paper()
    if os.path.isdir(path):
        raise UserError(f"robot file {path!r}: is a directory")
    try:
        return Robot.from_toml(path)
    except CdsmInputError as exc:
        msg = str(exc)
        if path in msg:
            raise
        raise UserError(f"robot file {path!r}: {msg}") from None


def _prepare_out(path: str) -> str:
    out = os.path.abspath(path)
    if os.path.exists(out) and not os.path.isdir(out):
        raise UserError(f"--out {path!r}: exists and is not a directory")
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as exc:
        raise UserError(f"--out {path!r}: cannot create the directory ({exc.strerror})") from None
    if not os.access(out, os.W_OK):
        raise UserError(f"--out {path!r}: directory is not writable")
    return out


# ---------------------------------------------------------------------------
# cdsm paper
# ---------------------------------------------------------------------------
def _paper_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--robot", metavar="R.toml", help="robot description (TOML, SI units); "
                   "default: the paper's 3-joint prototype")
    p.add_argument("--out", metavar="DIR", default="cdsm-paper",
                   help="output directory (default: ./cdsm-paper)")
    p.add_argument("--samples", metavar="N", type=_positive_int, default=1000,
                   help="Monte-Carlo samples (default: 1000, as the paper)")
    p.add_argument("--seed", metavar="S", type=_seed, default=0, help="Monte-Carlo seed (default: 0)")
    p.add_argument("--quiet", action="store_true", help="no progress output")


@subcommand("paper", help="reproduce the seed paper's accuracy study: figures, CSV tables and a report")
@options(_paper_args)
def _paper_run(args) -> int:
    from . import paper, report

    t0 = time.perf_counter()
    robot = load_robot(args.robot)
    out = _prepare_out(args.out)
    show = not args.quiet

    def say(msg: str) -> None:
        if show:
            print(msg, file=sys.stderr, flush=True)

    say(f"cdsm paper: robot {robot.name!r} ({robot.n} joints), {args.samples} Monte-Carlo samples, "
        f"seed {args.seed} -> {out}")
    study = paper.run(robot, samples=args.samples, seed=args.seed, progress=show)
    paths = report.write(study, out, progress=show)
    h = report.headline(study)
    print(f"report: {paths['report_html']}")
    print(f"        {paths['report_md']}")
    for p in study.workspaces:
        line = (f"{p}: worst single-error |dXY| {h[f'worst_single_dxy_m_{p}'] * 1e3:.2f} mm, "
                f"jump points {h[f'jump_points_{p}']}, unreachable {h[f'unreachable_{p}']}")
        if f"mc_max_dxy_m_{p}" in h:
            line += (f", Monte Carlo max |dXY| {h[f'mc_max_dxy_m_{p}'] * 1e3:.2f} mm "
                     f"(95th pct up to {h[f'mc_max_p95_dxy_m_{p}'] * 1e3:.2f} mm)")
        print(line)
    if "table3_max_ours_minus_paper_m" in h:
        print(f"Table 3: max |ours - paper| {h['table3_max_ours_minus_paper_m'] * 1e3:.1e} mm, "
              f"RMS measured - ours {h['table3_rms_measured_minus_ours_m'] * 1e3:.3f} mm")
    print(f"claims holding: {h['claims_holding']} of {h['claims_total']}; "
          f"done in {time.perf_counter() - t0:.1f} s")
    return 0


# ---------------------------------------------------------------------------
# main
# ---------------------------------------------------------------------------
def build_parser() -> argparse.ArgumentParser:
    """The top-level parser with one subparser per registered command."""
    from . import __version__

    parser = argparse.ArgumentParser(
        prog=PROG, description="Kinematics and tip-positioning accuracy of cable-driven serpentine "
                               "manipulators (SI units).")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for cmd in COMMANDS.values():
        p = sub.add_parser(cmd.name, help=cmd.help, description=cmd.help)
        cmd.add_args(p)
        p.set_defaults(_run=cmd.run)
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of ``cdsm``; returns the exit status (0 ok, 2 user error)."""
    parser = build_parser()
    args = parser.parse_args(argv)  # exits 2 with a usage line on bad options
    if getattr(args, "_run", None) is None:
        parser.print_help(sys.stderr)
        return 2
    from .robot import CdsmInputError

    try:
        return int(args._run(args) or 0)
    except (CdsmInputError, UserError) as exc:
        msg = " ".join(str(exc).split())
        print(f"{PROG}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"\n{PROG}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
