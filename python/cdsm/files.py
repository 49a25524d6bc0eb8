"""Every file cdsm reads or writes goes through here: text (robot TOML, model
JSON), CSV tables (measurements, targets, regions, report tables), JSON,
``.npz`` arrays and PNG figures, with errors that name the file and what it
is for (:class:`CdsmInputError`).

Files are written whole or not at all: into a temporary file beside the
target (``.<name>.<pid>.<random>.part``), then renamed into place
(:func:`atomic_file`), so a killed run never leaves a truncated file at a
final path. An empty path (an unset shell variable) is refused, never taken
for the current directory (:func:`check_path`).

An output directory written by one run (a report) is owned by that run while
it writes (:func:`run_directory`): a second run into it is refused while the
first holds it; a directory holding files of the run's names that no cdsm
run wrote is refused unless asked to overwrite; a killed run's ``.part``
files are removed. It carries a manifest, ``cdsm-run.json``: it says
``"complete": false`` from the moment the run starts writing there and
``"complete": true`` with every file the run wrote and the SHA-256 of the
bytes it wrote only once the last one is in place (:class:`Run`,
:func:`run_complete`).
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import itertools
import json
import math
import os
import re
import tempfile
import threading
import zipfile
from typing import AbstractSet, Callable, Dict, Iterable, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from ._cdsm import CdsmInputError

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows: no advisory locks, runs into one directory are not kept apart
    fcntl = None  # type: ignore[assignment]

__all__ = ["read_text", "write_text", "write_bytes", "read_bytes", "sha256_of", "parse_table", "read_table",
           "Table", "NUMBER_CELL", "write_csv", "csv_text", "write_json", "json_text", "json_safe", "csv_cell",
           "write_npz", "read_npz", "atomic_file", "check_path", "same_file", "RUN_MANIFEST", "Run", "run_directory",
           "run_complete"]

#: The manifest of an output directory written by one run (see the module doc).
RUN_MANIFEST = "cdsm-run.json"
_RUN_FORMAT = "cdsm-run/1"

# a temporary file of atomic_file: the target's name, the writing process's id, random letters
_PART = re.compile(r"^\.(?P<name>.+)\.(?P<pid>[0-9]+)\.[^.]+\.part$")


def read_text(path: "str | os.PathLike[str]", what: str) -> str:
    """The UTF-8 text of ``path`` (a byte-order mark, as some spreadsheet
    programs write, is dropped); :class:`CdsmInputError` ("<what> file
    '<path>': <reason>") when it cannot be read."""
    if os.path.isdir(path):
        raise CdsmInputError(f"{what} file {str(path)!r}: is a directory")
    try:
        with open(path, encoding="utf-8-sig") as fh:
            return fh.read()
    except FileNotFoundError:
        raise CdsmInputError(f"{what} file {str(path)!r}: does not exist") from None
    except OSError as exc:
        raise CdsmInputError(f"{what} file {str(path)!r}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise CdsmInputError(f"{what} file {str(path)!r}: not UTF-8 text") from None


def check_path(path: "str | os.PathLike[str]", what: str) -> str:
    """``path`` as a string; :class:`CdsmInputError` naming ``what`` when it
    is empty (an unset shell variable), which would otherwise name the
    current directory."""
    p = os.fspath(path)
    if p in ("", b""):
        raise CdsmInputError(f"{what}: empty path (an unset shell variable?); give a file or directory name")
    return os.fsdecode(p)


def same_file(a: "str | os.PathLike[str]", b: "str | os.PathLike[str]") -> bool:
    """Whether paths ``a`` and ``b`` name one file: the same real path
    (symbolic links resolved, ``./x`` and ``x`` alike, whether or not it
    exists) or, both existing, the same file (hard links)."""
    if os.path.realpath(a) == os.path.realpath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


@contextlib.contextmanager
def atomic_file(path: "str | os.PathLike[str]", what: str) -> Iterator[io.BufferedWriter]:
    """A binary file object whose bytes land at ``path`` whole or not at all:
    written to a temporary file in the same directory
    (``.<name>.<pid>.<random>.part``), flushed to disk and renamed over
    ``path`` when the ``with`` block ends without an error (removed
    otherwise). :class:`CdsmInputError` naming the file when it cannot be
    written or ``path`` is empty. Temporaries of ``path`` that a process no
    longer running left (a killed write) are removed first."""
    target = check_path(path, f"{what} file")
    folder = os.path.dirname(os.path.abspath(target))
    _remove_stale_parts(folder, {os.path.basename(target)})
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(target)}.{os.getpid()}.", suffix=".part", dir=folder)
    except OSError as exc:
        raise CdsmInputError(f"{what} file {target!r}: {exc.strerror}") from None
    try:
        with os.fdopen(fd, "wb") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o666 & ~_UMASK)
        os.replace(tmp, target)
    except OSError as exc:
        _remove_quietly(tmp)
        raise CdsmInputError(f"{what} file {target!r}: {exc.strerror}") from None
    except BaseException:
        _remove_quietly(tmp)
        raise


def _read_umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


# read once, at import (reading it means setting it, for a moment)
_UMASK = _read_umask()


def _remove_quietly(path: str) -> None:
    try:
        os.remove(path)
    except OSError:
        pass


def _utf8(text: str, path: "str | os.PathLike[str]", what: str) -> bytes:
    try:
        return text.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise CdsmInputError(f"{what} file {str(path)!r}: text is not valid Unicode ({exc.reason})") from None


def write_bytes(path: "str | os.PathLike[str]", data: bytes, what: str) -> str:
    """Write ``data`` to ``path``, whole or not at all (:func:`atomic_file`);
    :class:`CdsmInputError` naming the file when it cannot be written.
    Returns the path."""
    with atomic_file(path, what) as fh:
        fh.write(data)
    return str(path)


def write_text(path: "str | os.PathLike[str]", text: str, what: str) -> str:
    """Write ``text`` (UTF-8, line endings as given) to ``path``, whole or
    not at all (:func:`atomic_file`); :class:`CdsmInputError` naming the file
    when it cannot be written. Returns the path."""
    return write_bytes(path, _utf8(text, path, what), what)


def read_bytes(path: "str | os.PathLike[str]", what: str) -> bytes:
    """The bytes of ``path`` (figures, hashes); an error naming the file."""
    try:
        with open(path, "rb") as fh:
            return fh.read()
    except FileNotFoundError:
        raise CdsmInputError(f"{what} file {str(path)!r}: does not exist") from None
    except OSError as exc:
        raise CdsmInputError(f"{what} file {str(path)!r}: {exc.strerror}") from None


def sha256_of(path: "str | os.PathLike[str]") -> Optional[str]:
    """SHA-256 of a file's bytes, or None when it cannot be read."""
    try:
        return hashlib.sha256(read_bytes(path, "data")).hexdigest()
    except CdsmInputError:
        return None


def write_npz(path: "str | os.PathLike[str]", arrays: Dict[str, np.ndarray], what: str) -> str:
    """Write arrays to a compressed ``.npz`` (the suffix added when missing,
    as NumPy does), whole or not at all; returns the path written."""
    p = check_path(path, f"{what} file")
    p = p if p.endswith(".npz") else p + ".npz"
    with atomic_file(p, what) as fh:
        np.savez_compressed(fh, **arrays)
    return p


def read_npz(path: "str | os.PathLike[str]", what: str) -> Dict[str, np.ndarray]:
    """The arrays of a ``.npz`` file (no pickles); :class:`CdsmInputError`
    naming the file when it is missing, truncated or not an ``.npz``."""
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except FileNotFoundError:
        raise CdsmInputError(f"{what} file {str(path)!r}: does not exist") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise CdsmInputError(f"{what} file {str(path)!r}: not a readable .npz, truncated or damaged "
                             f"({type(exc).__name__}: {exc})") from None


# ---------------------------------------------------------------------------
# CSV tables
# ---------------------------------------------------------------------------
#: What a number cell of a CSV table is: ASCII decimal — an optional sign,
#: digits with an optional decimal point (``12``, ``1.5``, ``.5``, ``5.``),
#: an optional exponent (``e-3``, ``E+05``) — with spaces or tabs around it.
#: Nothing else is read as a number: no digit-group underscores (``1_0``),
#: no digits of other scripts (``١``), no ``nan``, ``inf`` or ``infinity``,
#: no hexadecimal. A number beyond the float range (``1e999``) is refused.
NUMBER_CELL = re.compile(r"[ \t]*[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?[ \t]*")
# characters no number cell holds: a quick test of a chunk of a column at
# once, its cells joined by commas (a cell holding a comma is no number for
# float() either); made of these characters only, a cell is a number cell
# exactly when Python's float() reads it
_NOT_IN_NUMBERS = re.compile(r"[^0-9+\-.eE \t,]")
_NON_FINITE = re.compile(r"[ \t]*[+-]?(?:nan|inf|infinity)[ \t]*", re.IGNORECASE)
#: Rows parsed at a time: the strings of one chunk are all the reader
#: holds beyond the table's columns (number columns as float64 arrays).
CHUNK_ROWS = 4096
_RULE = "a number is ASCII decimal: an optional sign, digits, an optional decimal point and exponent, e.g. -1.5e-3"


def _number_problem(cell: str) -> str:
    """Why ``cell`` (not empty) is not a number cell, for an error message."""
    if _NON_FINITE.fullmatch(cell):
        return f"non-finite value {cell!r}; a number cell must be finite ({_RULE})"
    if NUMBER_CELL.fullmatch(cell):
        return f"{cell!r} is beyond the range of a float (about ±1.8e308)"
    return f"not a number: {cell!r} ({_RULE})"


class _NumberColumn:
    """One column read as numbers, chunk by chunk: float64 values (NaN for
    an empty cell), the first empty row and the first row that is not a
    number (with its reason); once a row is not a number the values are
    dropped (the column cannot be used)."""

    __slots__ = ("parts", "values", "empty", "bad")

    def __init__(self):
        self.parts: List[np.ndarray] = []
        self.values: Optional[np.ndarray] = None
        self.empty: Optional[int] = None
        self.bad: Optional[Tuple[int, str]] = None

    def add(self, cells: Sequence[str], first: int) -> None:
        """Append ``cells``, the rows ``first, first + 1, ...`` (0-based)."""
        if self.bad is not None:
            return
        if not _NOT_IN_NUMBERS.search(",".join(cells)):
            try:
                vals = np.fromiter(map(float, cells), np.float64, len(cells))
            except ValueError:
                vals = None  # an empty cell or a misplaced sign, point or exponent
            if vals is not None and np.isfinite(vals).all():
                self.parts.append(vals)
                return
        vals = np.empty(len(cells))
        for j, c in enumerate(cells):
            if NUMBER_CELL.fullmatch(c):
                vals[j] = float(c)
                if math.isfinite(vals[j]):
                    continue
            elif not c.strip():  # blank (any white space): no value
                vals[j] = np.nan
                if self.empty is None:
                    self.empty = first + j
                continue
            self.bad, self.parts = (first + j, _number_problem(c)), []
            return
        self.parts.append(vals)

    def finish(self) -> None:
        self.values = np.concatenate(self.parts) if self.parts else np.zeros(0)
        self.parts = []


class Table:
    """A CSV table as :func:`parse_table` / :func:`read_table` read it: the
    column names in file order (:attr:`columns`), its rows (``len``), and per
    column the cells as numbers (:meth:`numbers`, float64) or as text
    (:meth:`text`, the cells as written). Errors name :attr:`source`, the
    row (1 = the first row under the header) and the column."""

    def __init__(self, source: str, columns: List[str], rows: int, numbers: Dict[str, "_NumberColumn"],
                 text: Dict[str, List[str]]):
        self.source, self.columns, self._rows = source, columns, rows
        self._numbers, self._text = numbers, text

    def __len__(self) -> int:
        return self._rows

    def numbers(self, name: str, allow_empty: bool = False) -> np.ndarray:
        """Column ``name`` as float64 (N,); :class:`CdsmInputError` naming the
        row and column for a cell that is not a number (:data:`NUMBER_CELL`:
        ASCII decimal; ``nan``, ``inf`` and numbers beyond the float range
        are refused). With ``allow_empty`` an empty cell gives NaN (a value
        that was not measured); otherwise it is an error too. The array is
        the table's own: copy it before changing it."""
        if name not in self._numbers:
            if name not in self._text:
                raise CdsmInputError(f"{self.source}: no column {name!r}; columns: {', '.join(self.columns)}")
            col = _NumberColumn()
            col.add(self._text[name], 0)
            col.finish()
            self._numbers[name] = col
        col = self._numbers[name]
        problems = ([col.bad] if col.bad is not None else []) + \
            ([(col.empty, "empty; a number is needed here")] if col.empty is not None and not allow_empty else [])
        if problems:
            row, why = min(problems)
            raise CdsmInputError(f"{self.source}: row {row + 1}, column {name!r}: {why}")
        return col.values

    def text(self, name: str) -> List[str]:
        """Column ``name`` as the cells written (a column the reader was
        told to keep as text; :func:`parse_table`'s ``read_as``)."""
        if name not in self._text:
            raise KeyError(f"{self.source}: column {name!r} was not kept as text")
        return list(self._text[name])


def _float_like(cell: str) -> bool:
    """Whether Python's float() reads ``cell`` (which a number cell need not be)."""
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _is_number_row(cells: Sequence[str]) -> bool:
    return bool(cells) and all(NUMBER_CELL.fullmatch(c) for c in cells)


# a line that is blank or a comment, in a block of lines (each ending in "\n")
_SKIPPED_LINE = re.compile(r"^[^\S\n]*(?:#|\n)", re.MULTILINE)


def _content(lines: Iterable[str], remarks: bool) -> Iterator[List[str]]:
    """Blocks of the lines of a table that are not blank and not ``#``
    comments; with ``remarks``, trailing ``# ...`` remarks cut off too.
    (Blocks: a whole block is checked at once, and passed on as it is when
    it holds no such line.)"""
    it = iter(lines)
    while True:
        block = list(itertools.islice(it, 4096))
        if not block:
            return
        text = "".join(block)
        if (remarks and "#" in text) or _SKIPPED_LINE.search(text) or not block[-1].strip():
            out = []
            for ln in block:
                if remarks and "#" in ln:
                    ln = ln.split("#", 1)[0] + "\n"
                s = ln.strip()
                if s and s[0] != "#":
                    out.append(ln)
            block = out
        yield block


def _parse_lines(lines: Iterable[str], source: str, headerless: Optional[Sequence[str]],
                 read_as: Optional[Callable[[List[str]], Dict[str, str]]],
                 tick: Optional[Callable[[], None]] = None) -> Table:
    reader = csv.reader(itertools.chain.from_iterable(_content(lines, headerless is not None)))
    first = next(reader, None)
    if first is None:
        raise CdsmInputError(f"{source}: no header and no rows")
    pending: List[List[str]] = []
    if headerless is not None and _is_number_row(first):
        if len(first) != len(headerless):
            raise CdsmInputError(f"{source}: line 1: expected {len(headerless)} values "
                                 f"({', '.join(headerless)}), got {len(first)}")
        pending, first = [first], list(headerless)
    elif headerless is not None:
        # not a header of names, and not a row of numbers either: say so
        # rather than take a row in another notation (1_0, ١) for a header
        odd = [c for c in first if not NUMBER_CELL.fullmatch(c) and _float_like(c)]
        if odd:
            raise CdsmInputError(f"{source}: line 1: {_number_problem(odd[0])}; give a header of column names "
                                 f"({', '.join(headerless)}) or a first row of numbers")
    cols = [c.strip() for c in first]
    twice = sorted({c for c in cols if cols.count(c) > 1})
    if twice:
        raise CdsmInputError(f"{source}: column(s) {', '.join(map(repr, twice))} appear more than once in the "
                             "header; each column must be named once")
    kinds = {c: "number" for c in cols} if read_as is None else read_as(list(cols))
    numbers = {c: _NumberColumn() for c in cols if kinds.get(c) == "number"}
    text: Dict[str, List[str]] = {c: [] for c in cols if kinds.get(c) == "text"}
    width, done = len(cols), 0
    while True:
        chunk = pending + list(itertools.islice(reader, CHUNK_ROWS - len(pending)))
        pending = []
        if not chunk:
            break
        if set(map(len, chunk)) != {width}:
            for j, r in enumerate(chunk):
                if len(r) > width:
                    raise CdsmInputError(f"{source}: row {done + j + 1}: more values than the {width} columns "
                                         f"({', '.join(cols)})")
                r.extend([""] * (width - len(r)))  # a short row: the missing cells are empty
        for c, cells in zip(cols, zip(*chunk)):
            if c in numbers:
                numbers[c].add(cells, done)
            elif c in text:
                text[c].extend(cells)
        done += len(chunk)
        if tick is not None:
            tick()
    if not done:
        raise CdsmInputError(f"{source}: header but no rows")
    for col in numbers.values():
        col.finish()
    return Table(source, cols, done, numbers, text)


def parse_table(text: str, source: str, headerless: Optional[Sequence[str]] = None,
                read_as: Optional[Callable[[List[str]], Dict[str, str]]] = None) -> Table:
    """The :class:`Table` of a CSV text whose ``#`` lines are comments
    (blank lines skipped); an error naming ``source`` if it has no header or
    no rows, a header naming a column twice, or a row longer than the
    header (a shorter row's missing cells are empty). With ``headerless``
    (column names), a text whose first line is all numbers has no header and
    takes those names, and trailing ``# ...`` remarks are cut off every line.
    ``read_as(columns)`` says how each column is kept: ``"number"`` or
    ``"text"``; a column it does not name is not kept (default: every
    column a number). Number cells follow :data:`NUMBER_CELL`; a cell that
    is not a number is an error only when its column is asked for
    (:meth:`Table.numbers`). The rows are parsed :data:`CHUNK_ROWS` at a
    time: no per-row objects are kept."""
    text = text[1:] if text.startswith("\ufeff") else text  # a byte-order mark is not part of the header
    return _parse_lines(io.StringIO(text, newline=None), source, headerless, read_as)


def read_table(path: "str | os.PathLike[str]", what: str, headerless: Optional[Sequence[str]] = None,
               read_as: Optional[Callable[[List[str]], Dict[str, str]]] = None, progress: bool = False) -> Table:
    """:func:`parse_table` of a CSV file (``what`` names it in errors),
    streamed from disk: what it holds is the table's columns, not the file's
    text. ``progress``: a progress line over the file's bytes on stderr
    (:class:`cdsm.progress.Progress`)."""
    from .progress import Progress

    name = str(path)
    if os.path.isdir(path):
        raise CdsmInputError(f"{what} file {name!r}: is a directory")
    try:
        with open(path, encoding="utf-8-sig", newline=None) as fh:
            size = os.fstat(fh.fileno()).st_size
            bar = Progress(size, f"reading {os.path.basename(name)}", progress and size > 0, unit="bytes")
            seen = [0]

            def tick():
                at = min(fh.buffer.tell(), size)
                bar.update(at - seen[0])
                seen[0] = at

            table = _parse_lines(fh, name, headerless, read_as, tick)
            bar.update(size - seen[0])
            return table
    except FileNotFoundError:
        raise CdsmInputError(f"{what} file {name!r}: does not exist") from None
    except UnicodeDecodeError:
        raise CdsmInputError(f"{what} file {name!r}: not UTF-8 text") from None
    except OSError as exc:
        raise CdsmInputError(f"{what} file {name!r}: {exc.strerror}") from None


def csv_cell(v):
    """A CSV cell: floats by ``repr`` (exact round trip), everything else as is."""
    return repr(float(v)) if isinstance(v, (float, np.floating)) else v


def write_csv(path: "str | os.PathLike[str]", rows: List[dict], what: str = "CSV",
              comments: Sequence[str] = ()) -> str:
    """Write :func:`csv_text` of ``rows`` and ``comments``. Returns the path."""
    return write_text(path, csv_text(rows, comments), what)


def csv_text(rows: List[dict], comments: Sequence[str] = ()) -> str:
    """CSV text of dict rows (one header from the first row's keys; floats
    by ``repr``) with optional ``# `` comment lines first."""
    buf = io.StringIO()
    for c in comments:
        buf.write(f"# {c}\n")
    if not rows:
        buf.write("\n")
    else:
        w = csv.DictWriter(buf, fieldnames=list(rows[0].keys()), lineterminator="\r\n")
        w.writeheader()
        for r in rows:
            w.writerow({k: csv_cell(v) for k, v in r.items()})
    return buf.getvalue()


def json_safe(obj):
    """``obj`` with NumPy scalars and arrays turned into Python numbers and
    lists, and non-finite floats into ``None`` (strict JSON)."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if math.isfinite(v) else None
    return obj


def write_json(path: "str | os.PathLike[str]", obj, what: str = "JSON", indent: int = 1) -> str:
    """Write :func:`json_text` of ``obj``. Returns the path."""
    return write_text(path, json_text(obj, indent), what)


def json_text(obj, indent: int = 1) -> str:
    """:func:`json_safe` of ``obj`` as strict JSON text (a final newline)."""
    return json.dumps(json_safe(obj), indent=indent, allow_nan=False) + "\n"


# ---------------------------------------------------------------------------
# output directories of one run
# ---------------------------------------------------------------------------
# the output directories this process owns, by (device, inode): [owning thread, depth]
_OWNED: Dict[Tuple[int, int], List[int]] = {}
_OWNED_LOCK = threading.Lock()


class Run:
    """The files one run writes into its output directory ``out`` (made by
    :func:`run_directory`). :meth:`write` (and :meth:`write_text`,
    :meth:`write_csv`, :meth:`write_json`) puts a file in place whole and
    records the SHA-256 of the bytes it wrote; ``name`` is one of the run's
    ``names`` or ``<subdir>/<file>`` in one of its ``subdirs``. The first
    write marks the directory incomplete; :meth:`finish` marks it complete,
    listing exactly the files this run wrote."""

    def __init__(self, out: str, command: str, names: Iterable[str], subdirs: Iterable[str]):
        self.out, self.command = out, command
        self.names, self.subdirs = frozenset(names), tuple(subdirs)
        self._written: Dict[str, str] = {}
        self._begun = False

    def _target(self, name: str) -> str:
        parts = name.split("/")
        if not (name in self.names
                or (len(parts) == 2 and parts[0] in self.subdirs and parts[1] not in ("", ".", ".."))):
            raise ValueError(f"{name!r} is not a file of this run (its files: {', '.join(sorted(self.names))}, "
                             f"{', '.join(d + '/*' for d in self.subdirs)})")
        return os.path.join(self.out, *parts)

    def write(self, name: str, data: bytes, what: str) -> str:
        """Write ``data`` as ``out/name``; returns its path."""
        target = self._target(name)
        if not self._begun:
            self._manifest({"complete": False})
            self._begun = True
        folder = os.path.dirname(target)
        try:
            os.makedirs(folder, exist_ok=True)
        except OSError as exc:
            raise CdsmInputError(f"{what} file {target!r}: cannot create {folder!r} ({exc.strerror})") from None
        write_bytes(target, data, what)
        self._written[name] = hashlib.sha256(data).hexdigest()
        return target

    def write_text(self, name: str, text: str, what: str) -> str:
        """Write ``text`` (UTF-8) as ``out/name``; returns its path."""
        return self.write(name, _utf8(text, os.path.join(self.out, name), what), what)

    def write_csv(self, name: str, rows: List[dict], what: str = "CSV", comments: Sequence[str] = ()) -> str:
        """Write :func:`csv_text` of ``rows`` as ``out/name``; returns its path."""
        return self.write_text(name, csv_text(rows, comments), what)

    def write_json(self, name: str, obj, what: str = "JSON", indent: int = 1) -> str:
        """Write :func:`json_text` of ``obj`` as ``out/name``; returns its path."""
        return self.write_text(name, json_text(obj, indent), what)

    def finish(self) -> str:
        """Mark the directory complete: its manifest lists every file this run
        wrote (paths relative to ``out``, sorted) with the SHA-256 of the
        bytes written. Returns the manifest's path."""
        return self._manifest({"complete": True, "files": {k: self._written[k] for k in sorted(self._written)}})

    def _manifest(self, body: dict) -> str:
        text = json.dumps({"format": _RUN_FORMAT, "command": self.command, **body}, indent=1) + "\n"
        return write_text(os.path.join(self.out, RUN_MANIFEST), text, "run manifest")


@contextlib.contextmanager
def run_directory(out: "str | os.PathLike[str]", command: str, names: Iterable[str],
                  subdirs: Sequence[str] = ("figures",), overwrite: bool = False, what: str = "output directory",
                  overwrite_hint: str = "overwrite=True") -> Iterator[Run]:
    """Own the output directory ``out`` (created, with its parents, when
    missing) for one run of ``command`` that writes the files ``names`` and
    files in the directories ``subdirs`` there; yields the :class:`Run` that
    writes them. Before anything is written, :class:`CdsmInputError` naming
    ``what`` and ``out`` when

    - ``out`` is empty, exists and is not a directory, or cannot be created or written;
    - another run owns it: another process (an exclusive lock on the
      directory, held until the ``with`` block ends and released by the
      system however the process ends) or another thread of this one;
    - one of ``names`` there is a directory, or one of ``subdirs`` exists and is not a directory;
    - no cdsm run wrote there (no manifest) and it holds files of ``names`` (or the
      manifest's name) or a non-empty subdirectory, unless ``overwrite``
      (``overwrite_hint`` tells how to ask for it).

    Then the ``.part`` files of ``names`` and in ``subdirs`` that processes no
    longer running left there (a killed run) are removed, also those of
    files this run will not write again. In the thread that
    owns ``out`` already (a command that claimed it before computing, then
    its report) the lock is shared and the checks were made. The owner
    removes the directories this call created at its end when nothing was
    written into them."""
    path = check_path(out, what)
    label = f"{what} {path!r}"
    names = frozenset(names)
    if os.path.exists(path) and not os.path.isdir(path):
        raise CdsmInputError(f"{label}: exists and is not a directory")
    created = _missing_dirs(path)
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as exc:
        raise CdsmInputError(f"{label}: cannot create the directory ({exc.strerror})") from None
    with _owned(path, label) as first:
        try:
            if first:
                if not os.access(path, os.W_OK):
                    raise CdsmInputError(f"{label}: directory is not writable")
                _check_layout(path, label, names, subdirs, overwrite, overwrite_hint)
                _remove_stale_parts(path, names | {RUN_MANIFEST})
                for d in subdirs:
                    _remove_stale_parts(os.path.join(path, d), None)
            yield Run(path, command, names, subdirs)
        finally:
            # by the owner only, still holding it: a run refused beside the owner removes nothing
            for d in reversed(created if first else []):
                try:
                    os.rmdir(d)  # only when empty: the run wrote nothing
                except OSError:
                    break


def _missing_dirs(path: str) -> List[str]:
    """The directories ``os.makedirs(path)`` would create, outermost first."""
    out = []
    p = os.path.abspath(path)
    while not os.path.exists(p):
        out.append(p)
        parent = os.path.dirname(p)
        if parent == p:
            break
        p = parent
    return out[::-1]


@contextlib.contextmanager
def _owned(path: str, label: str) -> Iterator[bool]:
    """Hold ``path`` for this thread: yields True for the first hold (the
    lock taken), False for a nested one in the same thread."""
    st = os.stat(path)
    key, me = (st.st_dev, st.st_ino), threading.get_ident()
    busy = (f"{label}: another cdsm run is writing into this directory now; wait for it to end or choose "
            "another directory")
    with _OWNED_LOCK:
        held = _OWNED.get(key)
        if held is not None and held[0] != me:
            raise CdsmInputError(busy)
        if held is not None:
            held[1] += 1
    if held is not None:
        try:
            yield False
        finally:
            with _OWNED_LOCK:
                held[1] -= 1
        return
    fd = _lock(path, busy)
    with _OWNED_LOCK:
        _OWNED[key] = [me, 1]
    try:
        yield True
    finally:
        with _OWNED_LOCK:
            del _OWNED[key]
        if fd is not None:
            os.close(fd)  # releases the lock


def _lock(path: str, busy: str) -> Optional[int]:
    """An exclusive lock on the directory ``path`` (``flock``, released when
    its descriptor closes or the process ends); where the file system does
    not lock directories, on a file ``.cdsm-run.lock`` in it. None where
    the platform has no such locks."""
    if fcntl is None:  # pragma: no cover - Windows
        return None
    for target, flags in ((path, os.O_RDONLY), (os.path.join(path, ".cdsm-run.lock"), os.O_RDWR | os.O_CREAT)):
        try:
            fd = os.open(target, flags, 0o666)
        except OSError:
            continue
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise CdsmInputError(busy) from None
        except OSError:  # this file system does not lock directories (NFS): try the lock file
            os.close(fd)
            continue
        return fd
    return None


def _check_layout(path: str, label: str, names: frozenset, subdirs: Sequence[str], overwrite: bool,
                  hint: str) -> None:
    for n in sorted(names):
        if os.path.isdir(os.path.join(path, n)):
            raise CdsmInputError(f"{label}: {n!r} in it is a directory, where this run writes a file; move it or "
                                 "choose another directory")
    for d in subdirs:
        p = os.path.join(path, d)
        if os.path.lexists(p) and not os.path.isdir(p):
            raise CdsmInputError(f"{label}: {d!r} in it is a file, where this run writes its {d}/ directory; move "
                                 "it or choose another directory")
    if overwrite or _manifest_of(path) is not None:
        return
    found = [n for n in sorted(names | {RUN_MANIFEST}) if os.path.lexists(os.path.join(path, n))]
    for d in subdirs:
        try:
            k = len([e for e in os.listdir(os.path.join(path, d)) if not _PART.match(e)])
        except OSError:  # none there
            k = 0
        if k:
            found.append(f"{d}/ ({k} file{'s' if k > 1 else ''})")
    if found:
        raise CdsmInputError(f"{label}: holds {', '.join(found)}, not written by a cdsm run (no {RUN_MANIFEST}), "
                             f"which this run would replace; choose a new or empty directory, or pass {hint} to "
                             "replace them")


def _remove_stale_parts(folder: str, names: Optional[AbstractSet[str]]) -> None:
    """Remove the temporaries (:func:`atomic_file`) in ``folder`` of the
    files ``names`` (None: of any file) whose writing process no longer runs."""
    try:
        entries = os.listdir(folder)
    except OSError:
        return
    for e in entries:
        m = _PART.match(e)
        if m and (names is None or m["name"] in names) and not _running(int(m["pid"])):
            _remove_quietly(os.path.join(folder, e))


def _running(pid: int) -> bool:
    """Whether process ``pid`` runs (on this machine); True when unsure."""
    if os.name != "posix" or pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process
        return True
    return True


def _manifest_of(out: str) -> Optional[dict]:
    """The manifest of ``out`` when a cdsm run wrote one, else None."""
    try:
        man = json.loads(read_text(os.path.join(out, RUN_MANIFEST), "run manifest"))
    except (CdsmInputError, ValueError):
        return None
    return man if isinstance(man, dict) and man.get("format") == _RUN_FORMAT else None


def run_complete(out: "str | os.PathLike[str]", verify: bool = True) -> bool:
    """Whether ``out`` holds a finished run: its manifest says complete and
    (``verify``) every file it lists is there with the listed SHA-256. Files
    beside them that the manifest does not list are not part of the run."""
    man = _manifest_of(os.fspath(out))
    if man is None or man.get("complete") is not True:
        return False
    files = man.get("files")
    if not isinstance(files, dict):
        return False
    return not verify or all(sha256_of(os.path.join(out, k)) == v for k, v in files.items())
