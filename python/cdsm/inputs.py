"""Validation of array and number inputs shared by the whole package.

Every public function of cdsm checks its inputs with these helpers, so bad
input raises :class:`CdsmInputError` (a ``ValueError``) naming the argument
and the problem, and the Rust core receives C-contiguous float64 arrays.
"""

from __future__ import annotations

from typing import Tuple

import numpy as np

from ._cdsm import CdsmInputError

__all__ = ["CdsmInputError", "as_batch", "as_vector", "as_finite", "as_iterations", "as_tolerances"]


def as_batch(name: str, value, width: int, finite: bool = True) -> Tuple[np.ndarray, bool]:
    """``value`` as a C-contiguous float64 ``(N, width)`` array, and whether it was 1-D.

    ``finite``: reject NaN and infinities here (naming the row and column);
    False where the core checks the batch itself, naming the row and column
    too (a second pass over a large batch is not free)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise CdsmInputError(f"`{name}`: not a numeric array ({exc})") from None
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
    """``value`` as a finite float."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise CdsmInputError(f"`{name}`: expected a number, got {value!r}") from None
    if not np.isfinite(v):
        raise CdsmInputError(f"`{name}`: must be finite, got {v}")
    return v


def as_iterations(name: str, value) -> int:
    """``value`` as an iteration count >= 1."""
    try:
        v = int(value)
    except (TypeError, ValueError):
        raise CdsmInputError(f"`{name}`: expected an integer, got {value!r}") from None
    if v < 1:
        raise CdsmInputError(f"`{name}`: must be at least 1, got {value}")
    return v


def as_tolerances(name: str, value, n: int) -> np.ndarray:
    """``value`` (scalar or ``(n,)``) as ``(n,)`` finite tolerances >= 0 (m)."""
    arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (n,)).copy()
    if not np.isfinite(arr).all() or (arr < 0).any():
        raise CdsmInputError(f"`{name}`: tolerances must be finite and >= 0 (m), got {value}")
    return arr
