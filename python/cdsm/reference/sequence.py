"""The sequence semantics of a data set, for the reference plant (:mod:`.plant`,
both kinds of arm; ``docs/model.md``, "The virtual prototype"): a displacement row runs two commands, an absolute or
unmeasured row one, in row order; what a row reports from the poses ``seen``
after each command."""

from __future__ import annotations

import numpy as np

__all__ = ["commands", "first_of_pairs", "observations"]


def commands(C: np.ndarray, dL: np.ndarray, kind) -> tuple:
    """The command sequence of ``N`` rows: ``C (N, m)`` m the lengths each
    row's command starts from, ``dL (N, m)`` m its extra; an absolute or
    unmeasured row one command ``C + dL``, a displacement row two, ``C`` then
    ``C + dL``. Returns ``commands (R, m)`` m and ``rows (R,)`` (each
    command's row)."""
    out, rows = [], []
    for i, k in enumerate(kind):
        if k == "displacement":
            out.append(C[i])
            rows.append(i)
        out.append(C[i] + dL[i])
        rows.append(i)
    return np.array(out).reshape(-1, C.shape[1]), np.array(rows, dtype=np.int64)


def first_of_pairs(rows: np.ndarray) -> np.ndarray:
    """``(R,)`` bool: the commands that are the earlier of a displacement row's
    two (``rows (R,)``: each command's row)."""
    first = np.zeros(len(rows), bool)
    first[:-1] = rows[1:] == rows[:-1]
    return first


def observations(seen: np.ndarray, rows: np.ndarray, ok: np.ndarray, kind) -> tuple:
    """``(obs (N, w), converged (N,))`` of the ``N`` rows named by ``kind``
    from ``seen (R, w)``, the observed pose after each command (SI units), and
    ``ok (R,)``, whether it settled: a displacement row the second pose minus
    the first, an absolute row its pose, an unmeasured row NaN; a row whose
    commands did not all settle NaN and not converged."""
    kind = list(kind)
    obs = np.full((len(kind), seen.shape[1]), np.nan)
    converged = np.ones(len(kind), dtype=bool)
    np.logical_and.at(converged, rows, ok)
    j = 0
    for i, k in enumerate(kind):
        if k == "displacement":
            obs[i] = seen[j + 1] - seen[j]
            j += 2
        else:
            if k == "absolute":
                obs[i] = seen[j]
            j += 1
    obs[~converged] = np.nan
    return obs, converged
