"""A progress line for long runs, on stderr.

It draws only when stderr is a terminal (or when forced), so logs and CI
output stay clean; the caller still decides whether progress is wanted at all.
"""

from __future__ import annotations

import sys
import time

__all__ = ["Progress"]


class Progress:
    """``Progress(total, label, enabled)``; call :meth:`update` with each
    finished amount. Draws only when ``enabled`` and stderr is a terminal
    (``force=True`` draws anyway)."""

    def __init__(self, total: int, label: str, enabled: bool = True, force: bool = False):
        self.total, self.label = total, label
        self.enabled = bool(enabled) and (force or sys.stderr.isatty())
        self.done, self.t0 = 0, time.perf_counter()

    def update(self, k: int) -> None:
        self.done += k
        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        frac = self.done / max(self.total, 1)
        bar = "#" * int(30 * min(frac, 1.0))
        # no estimate before the first step, nor once done (not "-0.0 s left")
        left = f", {el / frac - el:6.1f}s left" if 0 < frac < 1 else ""
        sys.stderr.write(f"\r{self.label} [{bar:<30}] {self.done}/{self.total} {el:6.1f}s elapsed{left}")
        if self.done >= self.total:
            sys.stderr.write("\n")
        sys.stderr.flush()
