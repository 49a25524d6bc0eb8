"""How results show themselves: a short ``repr`` (array fields as their
shape and dtype, never their contents) and a notebook table
(``_repr_html_``) for every result dataclass that mixes in
:class:`ShortRepr`."""

from __future__ import annotations

import dataclasses
import html

import numpy as np

__all__ = ["ShortRepr", "describe", "degrees"]

#: Fields shown before "..." in a repr.
MAX_FIELDS = 12


def degrees(rad: float) -> str:
    """An angle given in rad as degrees with one decimal (no unit sign): the
    one way every print, report and figure shows a joint angle or limit
    (0.6 rad is ``"34.4"`` everywhere)."""
    return f"{round(float(np.degrees(rad)), 1) + 0.0:.1f}"  # + 0.0: no "-0.0"


def describe(value) -> str:
    """A value in a few characters: arrays as ``(shape) dtype``, long
    sequences and mappings by their length, nested results by their class."""
    if isinstance(value, np.ndarray):
        return f"array{value.shape} {value.dtype}"
    if isinstance(value, (bool, np.bool_, int, np.integer)):
        return str(value)
    if isinstance(value, (float, np.floating)):
        return f"{value:.6g}"
    if isinstance(value, str):
        return repr(value) if len(value) <= 40 else repr(value[:37] + "...")
    if value is None:
        return "None"
    if isinstance(value, (list, tuple)):
        if len(value) <= 4 and all(isinstance(v, (int, float, str, np.integer, np.floating)) for v in value):
            return repr(type(value)(value))
        return f"{type(value).__name__} of {len(value)}"
    if isinstance(value, dict):
        return f"dict of {len(value)}"
    return type(value).__name__


class ShortRepr:
    """Mixin of result dataclasses (declare them ``@dataclass(repr=False)``):
    ``repr`` names each field with :func:`describe`; ``_repr_html_`` is the
    same as a table."""

    def _fields(self):
        return [(f.name, describe(getattr(self, f.name))) for f in dataclasses.fields(self)
                if f.repr and not f.name.startswith("_")]

    def __repr__(self) -> str:
        items = self._fields()
        shown = ", ".join(f"{k}={v}" for k, v in items[:MAX_FIELDS])
        return f"{type(self).__name__}({shown}{', ...' if len(items) > MAX_FIELDS else ''})"

    def _repr_html_(self) -> str:
        rows = "".join(f"<tr><td>{html.escape(k)}</td><td>{html.escape(v)}</td></tr>" for k, v in self._fields())
        return f"<b>{html.escape(type(self).__name__)}</b><table>{rows}</table>"
