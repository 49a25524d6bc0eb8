"""The command registry and what the commands share: option types, the
robot option and the user-error type (path options: :mod:`cdsm.cli.paths`).

A command is a module of :mod:`cdsm.cli` with one function that adds its
options and one that runs it::

    def _args(p: argparse.ArgumentParser) -> None:        # add options
        p.add_argument(...)

    @subcommand("name", help="one line")
    @options(_args)
    def _run(args) -> int:                                 # exit status
        ...

and one line in :data:`cdsm.cli.COMMAND_MODULES`. User errors (bad options,
bad robot or data files: :class:`CdsmInputError`) exit with status 2 and one
line ``cdsm: error: ...`` on stderr, no traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Callable, Dict, Optional

from .paths import add_path

__all__ = ["PROG", "COMMANDS", "Command", "subcommand", "options", "UserError", "DeprecatedOption", "int_at_least",
           "positive_int", "seed_int", "load_robot", "ROBOT_HELP", "add_robot_option"]

PROG = "cdsm"


class Command:
    """A registered subcommand: name, help line, option builder, run function."""

    def __init__(self, name: str, help: str, add_args: Callable, run: Callable):
        self.name, self.help, self.add_args, self.run = name, help, add_args, run


#: name -> command; filled by :func:`subcommand`.
COMMANDS: Dict[str, Command] = {}


def subcommand(name: str, help: str):
    """Register a subcommand: decorates ``run(args) -> int``; the options are
    added by ``run.add_args(parser)`` (set with :func:`options`)."""
    def deco(run: Callable) -> Callable:
        COMMANDS[name] = Command(name, help, getattr(run, "add_args", lambda p: None), run)
        return run
    return deco


def options(add_args: Callable):
    """Attach the option builder ``add_args(parser)`` to a run function
    (use below :func:`subcommand`)."""
    def deco(run: Callable) -> Callable:
        run.add_args = add_args
        return run
    return deco


class DeprecatedOption(argparse.Action):
    """An old option spelling that still works and says what replaces it
    (``replacement=``, on stderr)."""

    def __init__(self, option_strings, dest, replacement: str = "", **kw):
        self.replacement = replacement
        super().__init__(option_strings, dest, **kw)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"{PROG}: warning: {option_string} is deprecated here; use {self.replacement}", file=sys.stderr)
        setattr(namespace, self.dest, values)


class UserError(Exception):
    """A user mistake reported as ``cdsm: error: <message>`` with exit status 2."""


# ---------------------------------------------------------------------------
# option types
# ---------------------------------------------------------------------------
def int_at_least(text: str, lo: int, what: str) -> int:
    """argparse type: an integer >= ``lo``."""
    try:
        v = int(text)
    except ValueError:
        v = lo - 1
    if v < lo:
        raise argparse.ArgumentTypeError(f"expected a {what} integer, got {text!r}")
    return v


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    return int_at_least(text, 1, "positive")


def seed_int(text: str) -> int:
    """argparse type: an integer >= 0 (random seeds)."""
    return int_at_least(text, 0, "non-negative")


#: The help of every command's ``--robot``.
ROBOT_HELP = ("robot description: a TOML file (SI units), an OpenCR generation config (.json), or the name of a "
              "packaged robot (`cdsm list` shows them: e.g. two_universal, ftdcr_v4); default: the paper's 3-joint "
              "prototype")


def add_robot_option(p: argparse.ArgumentParser) -> None:
    """The ``--robot`` option every command shares (an input path, :mod:`cdsm.cli.paths`)."""
    add_path(p, "--robot", role="input", metavar="R.toml|NAME", help=ROBOT_HELP)


def load_robot(path: Optional[str]):
    """The robot of ``--robot`` (:meth:`cdsm.Robot.load`: a TOML file, an
    OpenCR config, or the name of a packaged robot such as ``two_universal``
    or ``ftdcr_v4``), or the paper's prototype."""
    from ..inputs import CdsmInputError
    from ..robot import Robot

    if path is None:
        return Robot.paper()
    if os.path.isdir(path):
        raise UserError(f"robot file {path!r}: is a directory")
    try:
        return Robot.load(path)
    except CdsmInputError as exc:
        msg = str(exc)
        if path in msg:
            raise
        raise UserError(f"robot file {path!r}: {msg}") from None


# ---------------------------------------------------------------------------
# cdsm paper
# ---------------------------------------------------------------------------
