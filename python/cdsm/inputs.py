"""Validation of array and number inputs shared by the whole package.

Every public function of cdsm checks its inputs with these helpers, so bad
input raises :class:`CdsmInputError` (a ``ValueError``) naming the argument
and the problem, and the Rust core receives C-contiguous float64 arrays.
"""

from __future__ import annotations

import difflib
from typing import Iterable, Optional, Tuple

import numpy as np

from ._cdsm import CdsmInputError

__all__ = ["CdsmInputError", "CdsmDataWarning", "as_array", "as_batch", "as_vector", "as_finite", "as_count",
           "as_iterations", "as_tolerances", "did_you_mean"]

class CdsmDataWarning(UserWarning):
    """Data cdsm takes but a person should look at (copied rows, say): the
    message names the rows and what was done with them."""


def did_you_mean(name: str, choices: Iterable[str]) -> str:
    """``"; did you mean 'x'?"`` naming the ``choices`` closest to a misspelt
    ``name`` (:func:`difflib.get_close_matches`, at most three), or ``""``
    when none is close: for the errors that refuse an unknown name."""
    close = difflib.get_close_matches(str(name), list(choices), n=3)
    return f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""


#: The largest iteration count the core takes (an unsigned 32-bit integer).
MAX_ITERATIONS = 2**32 - 1


def _cells(value):
    """The scalars of nested lists and tuples (NumPy turns ``[0.1, True]``
    into ``[0.1, 1.0]`` before its dtype could tell)."""
    for v in value:
        if isinstance(v, (list, tuple)):
            yield from _cells(v)
        else:
            yield v


def as_array(name: str, value) -> np.ndarray:
    """``value`` as a float64 array of any shape, taken whole: complex
    values (NumPy would drop the imaginary part), booleans (``True`` is no
    1.0), ``None`` (no NaN), text and other non-numbers are refused naming
    ``name``."""
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as exc:
        raise CdsmInputError(f"`{name}`: not a numeric array ({exc})") from None
    cells = raw.ravel() if raw.dtype == object else tuple(_cells(value)) if isinstance(value, (list, tuple)) else ()
    if np.iscomplexobj(raw) or any(isinstance(v, (complex, np.complexfloating)) for v in cells):
        raise CdsmInputError(f"`{name}`: complex values are not accepted (the imaginary part would be lost); "
                             "give real numbers")
    if raw.dtype.kind == "b" or any(isinstance(v, (bool, np.bool_)) for v in cells):
        raise CdsmInputError(f"`{name}`: expected numbers, got booleans (True is not 1.0)")
    if any(v is None for v in cells):
        raise CdsmInputError(f"`{name}`: expected numbers, got None")
    if raw.dtype.kind in "USV":
        raise CdsmInputError(f"`{name}`: expected numbers, got {raw.dtype.kind == 'V' and 'records' or 'text'}")
    try:
        return raw.astype(np.float64, copy=False)
    except (TypeError, ValueError) as exc:
        raise CdsmInputError(f"`{name}`: not a numeric array ({exc})") from None


def as_batch(name: str, value, width: int, finite: bool = True) -> Tuple[np.ndarray, bool]:
    """``value`` as a C-contiguous float64 ``(N, width)`` array, and whether it was 1-D.

    ``finite``: reject NaN and infinities here (naming the row and column);
    False where the core checks the batch itself, naming the row and column
    too (a second pass over a large batch is not free)."""
    arr = as_array(name, value)
    single = arr.ndim == 1
    if single:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != width:
        raise CdsmInputError(
            f"`{name}`: expected shape (N, {width}) or ({width},), got {np.shape(value)}"
        )
    if finite and not np.isfinite(arr).all():
        row, col = np.argwhere(~np.isfinite(arr))[0]
        raise CdsmInputError(f"`{name}`: non-finite value {arr[row, col]} at row {row}, column {col}")
    return np.ascontiguousarray(arr), single


def as_vector(name: str, value, width: int) -> np.ndarray:
    """``value`` as a finite float64 ``(width,)`` array."""
    arr, single = as_batch(name, value, width)
    if not single:
        raise CdsmInputError(f"`{name}`: expected shape ({width},), got {np.shape(value)}")
    return arr[0]


def as_finite(name: str, value) -> float:
    """``value`` as a finite float (a complex number, text and a boolean —
    ``True`` is no 1.0 — are refused)."""
    if (isinstance(value, (complex, np.complexfloating, str, bytes, bool, np.bool_))
            or (isinstance(value, np.ndarray) and value.dtype.kind in "bcUS")):
        raise CdsmInputError(f"`{name}`: expected a real number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise CdsmInputError(f"`{name}`: expected a number, got {value!r}") from None
    if not np.isfinite(v):
        raise CdsmInputError(f"`{name}`: must be finite, got {v}")
    return v


def as_count(name: str, value, minimum: int = 0, maximum: Optional[int] = None) -> int:
    """``value`` as a whole count within ``[minimum, maximum]``: an integer,
    or a float with no fractional part (``1e3``); ``1.7`` is refused, not
    truncated, and so are booleans and counts past ``maximum``."""
    if isinstance(value, (bool, np.bool_)):
        raise CdsmInputError(f"`{name}`: expected an integer, got {value!r}")
    if isinstance(value, (int, np.integer)):
        v = int(value)
    elif (isinstance(value, (float, np.floating)) and np.isfinite(value) and float(value).is_integer()
          and abs(value) <= 2**53):
        v = int(value)  # past 2**53 a float is not an exact count
    else:
        raise CdsmInputError(f"`{name}`: expected a whole number, got {value!r}")
    if v < minimum:
        raise CdsmInputError(f"`{name}`: must be at least {minimum}, got {v}")
    if maximum is not None and v > maximum:
        raise CdsmInputError(f"`{name}`: must be at most {maximum}, got {v}")
    return v


def as_iterations(name: str, value) -> int:
    """``value`` as an iteration count in ``[1, 2**32 - 1]`` (:func:`as_count`)."""
    return as_count(name, value, 1, MAX_ITERATIONS)


def as_tolerances(name: str, value, n: int) -> np.ndarray:
    """``value`` (scalar or ``(n,)``) as ``(n,)`` finite tolerances >= 0 (m)."""
    arr = as_array(name, value)
    try:
        arr = np.broadcast_to(arr, (n,)).copy()
    except ValueError:
        raise CdsmInputError(f"`{name}`: expected a scalar or ({n},) tolerances (m), got shape {arr.shape}") from None
    if not np.isfinite(arr).all() or (arr < 0).any():
        raise CdsmInputError(f"`{name}`: tolerances must be finite and >= 0 (m), got {value}")
    return arr
