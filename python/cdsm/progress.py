"""Progress of long runs, on stderr, in two forms.

On a terminal: one line redrawn in place (a bar, the count, the time spent
and an estimate of the time left), at most :data:`TERMINAL_EVERY` seconds
apart, ended with a newline when the work is done.

Off a terminal (a log file, CI, a pipe): plain lines, never a carriage
return, so a log stays readable — one line when the work has run
:data:`LOG_EVERY` seconds since the last one (percent, count, time spent,
estimate left) and one line when it is done. A run of a few seconds leaves
one line per stage; an hour-long one a line every half minute.

The caller decides whether progress is wanted at all (``enabled``; the
commands' ``--quiet``).
"""

from __future__ import annotations

import sys
import time
from typing import Optional

__all__ = ["Progress", "TERMINAL_EVERY", "LOG_EVERY"]

#: Seconds between redraws of the terminal line (the last one is always drawn).
TERMINAL_EVERY = 0.1
#: Seconds between two lines of the log form (off a terminal).
LOG_EVERY = 30.0


def _clock(seconds: float) -> str:
    """``12.3 s``, ``4 min 05 s``, ``1 h 02 min``."""
    if seconds < 60:
        return f"{seconds:.1f} s"
    if seconds < 3600:
        return f"{int(seconds // 60)} min {int(seconds % 60):02d} s"
    return f"{int(seconds // 3600)} h {int(seconds % 3600 // 60):02d} min"


def _amount(v: float, unit: str) -> str:
    if unit == "bytes":
        return f"{v / 1e6:.1f} MB" if v >= 1e6 else f"{v / 1e3:.1f} kB"
    return f"{int(v)}" + (f" {unit}" if unit else "")


class Progress:
    """``Progress(total, label, enabled)``; call :meth:`update` with each
    finished amount (``total`` None: the amount of work is not known in
    advance — counts and time, no bar or estimate; :meth:`finish` ends it).
    Nothing is written unless ``enabled``; ``force=True`` takes stderr for a
    terminal whatever it is. ``unit``: what is counted (``"bytes"`` shows
    kB or MB), for the lines' counts."""

    def __init__(self, total: Optional[int], label: str, enabled: bool = True, force: bool = False,
                 unit: str = ""):
        self.total, self.label, self.unit = total, label, unit
        self.known = total is not None  # a total given in advance (a bar, an estimate)
        self.enabled = bool(enabled)
        self.terminal = bool(force) or sys.stderr.isatty()
        self.done, self.t0 = 0, time.perf_counter()
        self.last = self.t0  # when the last line was written (or the start)
        self.closed = False

    def update(self, k: int) -> None:
        """``k`` more finished; the line or log line when it is due."""
        self.done += k
        if not self.enabled or self.closed:
            return
        now = time.perf_counter()
        end = self.total is not None and self.done >= self.total
        if end:
            self._write(now, True)
        elif now - self.last >= (TERMINAL_EVERY if self.terminal else LOG_EVERY):
            self._write(now, False)

    def finish(self) -> None:
        """The work is done (a bar of unknown total, or one left short):
        the last line."""
        if self.total is None or self.done < self.total:
            self.total = self.done
            if self.enabled and not self.closed:
                self._write(time.perf_counter(), True)

    def _count(self) -> str:
        if not self.known:
            return _amount(self.done, self.unit)
        if self.unit == "bytes":
            return f"{_amount(self.done, self.unit)} of {_amount(self.total, self.unit)}"
        return f"{self.done}/{self.total}" + (f" {self.unit}" if self.unit else "")

    def _write(self, now: float, end: bool) -> None:
        self.last = now
        el = now - self.t0
        frac = min(self.done / max(self.total, 1), 1.0) if self.known else None
        # no estimate before the first step, nor once done (not "-0.0 s left")
        left = f", about {_clock(el / frac - el)} left" if frac is not None and 0 < frac < 1 else ""
        if self.terminal:
            bar = "" if frac is None else f" [{'#' * int(30 * frac):<30}]"
            sys.stderr.write(f"\r{self.label}{bar} {self._count()} {_clock(el)} elapsed{left}\033[K")
            if end:
                sys.stderr.write("\n")
        elif end:
            sys.stderr.write(f"{self.label}: done, {self._count()} in {_clock(el)}\n")
        else:
            pct = "" if frac is None else f"{100 * frac:.0f} %, "
            sys.stderr.write(f"{self.label}: {pct}{self._count()}, {_clock(el)} elapsed{left}\n")
        sys.stderr.flush()
        if end:
            self.closed = True
