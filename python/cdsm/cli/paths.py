"""The path options of the commands, declared by role — an input, an output
file, an output directory — with :func:`add_path`, and checked together
before a command runs (:func:`claimed`, called by :func:`cdsm.cli.main`):

- no path option is empty (an unset shell variable would name the current
  directory);
- no output names an input or another output of the same run: compared by
  real path (symbolic links resolved, ``./x`` and ``x`` alike) and, where
  both exist, as one file (hard links); an output directory by the files it
  writes (its report's names and its ``figures/``);
- an output file's directory exists and is writable, and it is no directory;
- an output directory is owned by this run until the command ends
  (:func:`cdsm.files.run_directory`: another run writing there, a file
  where it writes ``figures/``, or a user's files of its names are refused
  before anything is computed; ``--overwrite`` replaces the latter).
"""

from __future__ import annotations

import argparse
import contextlib
import os
from typing import Callable, Iterable, Iterator, List, Optional, Tuple

from ..files import RUN_MANIFEST, check_path, run_directory, same_file
from ..inputs import CdsmInputError

__all__ = ["ROLES", "PathOption", "add_path", "check", "claimed"]

#: the roles of a path option
ROLES = ("input", "output", "directory")


class PathOption:
    """A path option of a command: its ``dest`` on the parsed arguments,
    ``label`` in messages (the option, or a positional's metavar), ``role``
    (:data:`ROLES`); ``path_of`` maps its value to the path it names (None:
    none, e.g. a region that is not a file); outputs: ``suffix`` added when
    the value lacks it (as the writer does); directories: ``command`` (the
    run manifest's) and ``files()``, the names it writes there."""

    def __init__(self, dest: str, label: str, role: str, path_of: Optional[Callable[[str], Optional[str]]] = None,
                 suffix: str = "", command: str = "", files: Optional[Callable[[], Iterable[str]]] = None):
        if role not in ROLES:
            raise ValueError(f"role {role!r}: one of {', '.join(ROLES)}")
        self.dest, self.label, self.role, self.suffix, self.command = dest, label, role, suffix, command
        self.path_of = path_of or (lambda v: v)
        self.files = files or (lambda: ())


def add_path(p: argparse.ArgumentParser, *flags: str, role: str, path_of=None, suffix: str = "", command: str = "",
             files=None, **kw) -> argparse.Action:
    """``p.add_argument(*flags, **kw)`` for a path of ``role`` (see
    :class:`PathOption`); an output directory also adds ``--overwrite``.
    Returns the argparse action."""
    action = p.add_argument(*flags, **kw)
    label = flags[0] if flags[0].startswith("-") else str(action.metavar or action.dest).split("|")[0]
    spec = PathOption(action.dest, label, role, path_of, suffix, command, files)
    p.set_defaults(_paths=[*(p.get_default("_paths") or []), spec])
    if role == "directory":
        p.add_argument("--overwrite", action="store_true",
                       help=f"write into {action.metavar or 'DIR'} even when it holds files of the report's names "
                            "that no cdsm run wrote (default: refuse and name them)")
    return action


def _given(args) -> List[Tuple[PathOption, str, str]]:
    """(option, value, path) of every path option given; errors for empty ones."""
    out = []
    for spec in getattr(args, "_paths", None) or ():
        value = getattr(args, spec.dest, None)
        if value is None:
            continue
        check_path(value, spec.label)
        path = spec.path_of(value)
        if path is None:
            continue
        check_path(path, f"{spec.label} {value!r}")
        if spec.role == "output" and spec.suffix and not path.endswith(spec.suffix):
            path += spec.suffix
        out.append((spec, value, path))
    return out


def _inside(path: str, folder: str, names: Iterable[str], subdirs: Iterable[str]) -> Optional[str]:
    """The name under which an output directory ``folder`` writes ``path``
    (one of ``names``, or anything in ``subdirs``), or None."""
    for n in names:
        if same_file(path, os.path.join(folder, n)):
            return n
    rel = os.path.relpath(os.path.realpath(path), os.path.realpath(folder))
    parts = rel.split(os.sep)
    return rel.replace(os.sep, "/") if len(parts) > 1 and parts[0] in subdirs else None


def check(args, subdirs: Iterable[str] = ("figures",)) -> List[Tuple[PathOption, str, str]]:
    """Check the path options of ``args`` (module doc, everything but the
    ownership); returns the output directories as (option, value, path)."""
    given = _given(args)
    inputs = [g for g in given if g[0].role == "input" and os.path.isfile(g[2])]
    outputs = [g for g in given if g[0].role == "output"]
    dirs = [g for g in given if g[0].role == "directory"]
    for k, (o, ov, op) in enumerate(outputs):
        for i, iv, ip in inputs:
            if same_file(op, ip):
                raise CdsmInputError(f"{o.label} {ov!r} names the same file as {i.label} {iv!r}: writing it would "
                                     "replace the input; choose another output path")
        for o2, ov2, op2 in outputs[:k]:
            if same_file(op, op2):
                raise CdsmInputError(f"{o2.label} {ov2!r} and {o.label} {ov!r} both name one file: one output "
                                     "would replace the other")
    for k, (d, dv, dp) in enumerate(dirs):
        names = (*d.files(), RUN_MANIFEST)
        for o, ov, op in outputs + dirs[:k]:
            if same_file(op, dp):
                raise CdsmInputError(f"{o.label} {ov!r} and {d.label} {dv!r} both name one path: one output would "
                                     "replace the other")
            rel = _inside(op, dp, names, subdirs)
            if rel is not None:
                raise CdsmInputError(f"{o.label} {ov!r} is {rel!r} in {d.label} {dv!r}, which {d.label} writes: "
                                     "one output would replace the other; choose another path")
        for i, iv, ip in inputs:
            rel = _inside(ip, dp, names, subdirs)
            if rel is not None:
                raise CdsmInputError(f"{d.label} {dv!r} would write {rel!r} there, which is {i.label} {iv!r}: "
                                     "writing it would replace the input; choose another directory")
    for o, ov, op in outputs:
        if os.path.isdir(op):
            raise CdsmInputError(f"{o.label} {ov!r}: is a directory")
        parent = os.path.dirname(os.path.abspath(op))
        if not os.path.isdir(parent):
            raise CdsmInputError(f"{o.label} {ov!r}: directory {parent!r} does not exist")
        if not os.access(parent, os.W_OK):
            raise CdsmInputError(f"{o.label} {ov!r}: directory {parent!r} is not writable")
    return dirs


@contextlib.contextmanager
def claimed(args) -> Iterator[None]:
    """Check the path options of ``args`` (:func:`check`), then own its
    output directories (:func:`cdsm.files.run_directory`, their values made
    absolute on ``args``) until the ``with`` block ends."""
    dirs = check(args)
    with contextlib.ExitStack() as stack:
        for d, dv, dp in dirs:
            stack.enter_context(run_directory(dp, d.command, d.files(), overwrite=getattr(args, "overwrite", False),
                                              what=d.label, overwrite_hint="--overwrite"))
            setattr(args, d.dest, os.path.abspath(dp))
        yield
