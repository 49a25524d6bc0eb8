"""Every file cdsm reads or writes goes through here: text (robot TOML, model
JSON), CSV tables (measurements, targets, regions, report tables), JSON,
``.npz`` arrays and PNG figures, with errors that name the file and what it
is for (:class:`CdsmInputError`).

Files are written whole or not at all: into a temporary file beside the
target, then renamed into place (:func:`atomic_file`), so a killed run never
leaves a truncated file at a final path. An output directory written by one
run (a report) carries a manifest, ``cdsm-run.json``: it says
``"complete": false`` from the moment the run starts writing there and
``"complete": true`` with every file of the run and its SHA-256 only once
the last one is in place (:func:`begin_run`, :func:`finish_run`,
:func:`run_complete`).
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import math
import os
import tempfile
import zipfile
from typing import Dict, Iterable, Iterator, List, Optional, Sequence, Tuple

import numpy as np

from ._cdsm import CdsmInputError

__all__ = ["read_text", "write_text", "read_bytes", "sha256_of", "parse_table", "read_table", "table_column",
           "write_csv", "write_json", "json_safe", "csv_cell", "write_npz", "read_npz", "atomic_file",
           "RUN_MANIFEST", "begin_run", "finish_run", "run_complete"]

#: The manifest of an output directory written by one run (see the module doc).
RUN_MANIFEST = "cdsm-run.json"
_RUN_FORMAT = "cdsm-run/1"


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


@contextlib.contextmanager
def atomic_file(path: "str | os.PathLike[str]", what: str) -> Iterator[io.BufferedWriter]:
    """A binary file object whose bytes land at ``path`` whole or not at all:
    written to a temporary file in the same directory, flushed to disk and
    renamed over ``path`` when the ``with`` block ends without an error
    (removed otherwise). :class:`CdsmInputError` naming the file when it
    cannot be written."""
    target = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(target))
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{os.path.basename(target)}.", suffix=".part", dir=folder)
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


def write_text(path: "str | os.PathLike[str]", text: str, what: str) -> str:
    """Write ``text`` (UTF-8, line endings as given) to ``path``, whole or
    not at all (:func:`atomic_file`); :class:`CdsmInputError` naming the file
    when it cannot be written. Returns the path."""
    try:
        data = text.encode("utf-8")
    except UnicodeEncodeError as exc:
        raise CdsmInputError(f"{what} file {str(path)!r}: text is not valid Unicode ({exc.reason})") from None
    with atomic_file(path, what) as fh:
        fh.write(data)
    return str(path)


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
    p = os.fspath(path)
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


def _numeric(cells: Sequence[str]) -> bool:
    try:
        [float(c) for c in cells]
    except ValueError:
        return False
    return True


def parse_table(text: str, source: str, headerless: Optional[Sequence[str]] = None
                ) -> Tuple[List[str], List[Dict[str, str]]]:
    """Header (column names) and rows (dicts of strings) of a CSV text whose
    ``#`` lines (and trailing ``# ...`` remarks) are comments; an error naming
    ``source`` if either is empty. With ``headerless`` (column names), a text
    whose first line is all numbers has no header and takes those names."""
    text = text[1:] if text.startswith("\ufeff") else text  # a byte-order mark is not part of the header
    lines = [ln.split("#", 1)[0] if headerless is not None else ln for ln in text.splitlines()]
    lines = [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise CdsmInputError(f"{source}: no header and no rows")
    first = next(csv.reader([lines[0]]))
    if headerless is not None and _numeric(first):
        if len(first) != len(headerless):
            raise CdsmInputError(f"{source}: line 1: expected {len(headerless)} values "
                                 f"({', '.join(headerless)}), got {len(first)}")
        lines.insert(0, ",".join(headerless))
    reader = csv.DictReader(io.StringIO("\n".join(lines)))
    cols = [c.strip() for c in (reader.fieldnames or [])]
    twice = sorted({c for c in cols if cols.count(c) > 1})
    if twice:
        raise CdsmInputError(f"{source}: column(s) {', '.join(map(repr, twice))} appear more than once in the "
                             "header; each column must be named once")
    reader.fieldnames = cols
    rows = list(reader)
    for i, r in enumerate(rows):
        if None in r:
            raise CdsmInputError(f"{source}: row {i + 1}: more values than the {len(cols)} columns "
                                 f"({', '.join(cols)})")
        for k, v in r.items():
            if v is None:
                r[k] = ""  # a short row: the missing cells are empty
    if not rows:
        raise CdsmInputError(f"{source}: header but no rows")
    return cols, rows


def read_table(path: "str | os.PathLike[str]", what: str, headerless: Optional[Sequence[str]] = None
               ) -> Tuple[List[str], List[Dict[str, str]]]:
    """:func:`parse_table` of a CSV file (``what`` names it in errors)."""
    return parse_table(read_text(path, what), str(path), headerless)


def table_column(rows: Sequence[Dict[str, str]], name: str, source: str,
                 allow_empty: bool = False) -> np.ndarray:
    """Column ``name`` of parsed rows as floats; an error naming the row and
    column for a non-number or a non-finite value. With ``allow_empty`` an
    empty cell gives NaN (a value that was not measured)."""
    out = np.empty(len(rows))
    for i, r in enumerate(rows):
        cell = (r.get(name) or "").strip()
        if allow_empty and cell == "":
            out[i] = np.nan
            continue
        try:
            out[i] = float(cell)
        except ValueError:
            raise CdsmInputError(f"{source}: row {i + 1}, column {name!r}: not a number: {cell!r}") from None
        if not np.isfinite(out[i]):
            raise CdsmInputError(f"{source}: row {i + 1}, column {name!r}: non-finite value {cell!r}")
    return out


def csv_cell(v):
    """A CSV cell: floats by ``repr`` (exact round trip), everything else as is."""
    return repr(float(v)) if isinstance(v, (float, np.floating)) else v


def write_csv(path: "str | os.PathLike[str]", rows: List[dict], what: str = "CSV",
              comments: Sequence[str] = ()) -> str:
    """Write dict rows (one header from the first row's keys; floats by
    ``repr``) with optional ``# `` comment lines first. Returns the path."""
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
    return write_text(path, buf.getvalue(), what)


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
    """Write :func:`json_safe` of ``obj`` as strict JSON. Returns the path."""
    return write_text(path, json.dumps(json_safe(obj), indent=indent, allow_nan=False) + "\n", what)


# ---------------------------------------------------------------------------
# output directories of one run
# ---------------------------------------------------------------------------
def begin_run(out: "str | os.PathLike[str]", command: str) -> None:
    """Mark the output directory ``out`` as being written by ``command``:
    its manifest says ``"complete": false`` until :func:`finish_run`. Call it
    before the first file of the run is written there."""
    write_text(os.path.join(out, RUN_MANIFEST),
               json.dumps({"format": _RUN_FORMAT, "command": command, "complete": False}, indent=1) + "\n",
               "run manifest")


def finish_run(out: "str | os.PathLike[str]", command: str, files: Iterable["str | os.PathLike[str]"]) -> str:
    """Mark ``out`` complete: the manifest lists every file of the run (paths
    relative to ``out``, sorted) with its SHA-256. Returns the manifest's path."""
    root = os.path.abspath(out)
    listed = {}
    for f in files:
        rel = os.path.relpath(os.path.abspath(f), root).replace(os.sep, "/")
        digest = sha256_of(f)
        if digest is None:
            raise CdsmInputError(f"run manifest: {str(f)!r} was not written")
        listed[rel] = digest
    body = {"format": _RUN_FORMAT, "command": command, "complete": True,
            "files": {k: listed[k] for k in sorted(listed)}}
    return write_text(os.path.join(out, RUN_MANIFEST), json.dumps(body, indent=1) + "\n", "run manifest")


def run_complete(out: "str | os.PathLike[str]", verify: bool = True) -> bool:
    """Whether ``out`` holds a finished run: its manifest says complete and
    (``verify``) every file it lists is there with the listed SHA-256. Files
    beside them that the manifest does not list are not part of the run."""
    try:
        man = json.loads(read_text(os.path.join(out, RUN_MANIFEST), "run manifest"))
    except (CdsmInputError, ValueError):
        return False
    if not (isinstance(man, dict) and man.get("format") == _RUN_FORMAT and man.get("complete") is True):
        return False
    files = man.get("files")
    if not isinstance(files, dict):
        return False
    return not verify or all(sha256_of(os.path.join(out, k)) == v for k, v in files.items())
