"""Reading and writing the text files of cdsm (robot TOML, measurement and
command CSV, model JSON) with errors that name the file and what it is for."""

from __future__ import annotations

import os

from ._cdsm import CdsmInputError

__all__ = ["read_text", "write_text"]


def read_text(path: "str | os.PathLike[str]", what: str) -> str:
    """The UTF-8 text of ``path``; :class:`CdsmInputError` ("<what> file
    '<path>': <reason>") when it cannot be read."""
    try:
        with open(path, encoding="utf-8") as fh:
            return fh.read()
    except OSError as exc:
        raise CdsmInputError(f"{what} file {str(path)!r}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise CdsmInputError(f"{what} file {str(path)!r}: not UTF-8 text") from None


def write_text(path: "str | os.PathLike[str]", text: str, what: str) -> None:
    """Write ``text`` (UTF-8, line endings as given) to ``path``;
    :class:`CdsmInputError` naming the file when it cannot be written."""
    try:
        with open(path, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
    except OSError as exc:
        raise CdsmInputError(f"{what} file {str(path)!r}: {exc.strerror}") from None
