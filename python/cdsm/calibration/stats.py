"""The statistics the diagnosis judges with: the normal, chi-square and F
tails (``scipy.special``), the paired signed-rank test on held-out errors
(ranks from SciPy, its exact distribution counted here: see
:func:`signed_rank_p`), rank correlation (``scipy.stats.spearmanr``) and
model weights. SciPy is imported on first use: ``scipy.stats`` takes 0.5-0.8 s
to import, once per process (``import cdsm`` stays at about 0.2 s).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

__all__ = ["normal_sf", "normal_isf", "chi2_sf", "chi2_ppf", "f_sf", "signed_rank_p", "better",
           "spearman", "model_weights"]

#: Largest number of pairs whose signed-rank p-value is exact (beyond: the
#: normal approximation with continuity correction).
EXACT_PAIRS = 60


def chi2_sf(x: float, dof: float) -> float:
    """P(X > x) for X ~ chi-square with ``dof`` degrees of freedom: the
    regularised upper incomplete gamma Q(dof/2, x/2) (``scipy.special.chdtrc``)."""
    from scipy import special

    if dof <= 0:
        raise ValueError(f"dof must be positive, got {dof}")
    return float(special.chdtrc(dof, max(x, 0.0)))


def chi2_ppf(q: float, dof: float) -> float:
    """The ``q`` quantile of chi-square with ``dof`` degrees of freedom:
    2 P^-1(dof/2, q), the inverse of the regularised lower incomplete gamma
    (``scipy.special.gammaincinv``; exact in ``q`` near 0, where 1 - q rounds)."""
    from scipy import special

    if not 0.0 < q < 1.0:
        raise ValueError(f"q must be in (0, 1), got {q}")
    if dof <= 0:
        raise ValueError(f"dof must be positive, got {dof}")
    return 2.0 * float(special.gammaincinv(dof / 2.0, q))


def f_sf(x: float, d1: float, d2: float) -> float:
    """P(X > x) for X ~ F(d1, d2) (``scipy.special.fdtrc``: the regularised
    incomplete beta I_{d2/(d2 + d1 x)}(d2/2, d1/2))."""
    from scipy import special

    if d1 <= 0 or d2 <= 0:
        raise ValueError(f"degrees of freedom must be positive, got {d1}, {d2}")
    if x <= 0:
        return 1.0
    return float(special.fdtrc(d1, d2, x))


def normal_sf(x: float) -> float:
    """P(Z > x) for a standard normal Z (``scipy.special.ndtr(-x)``)."""
    from scipy import special

    return float(special.ndtr(-x))


def normal_isf(p: float) -> float:
    """The x with P(Z > x) = ``p`` for a standard normal Z
    (``-scipy.special.ndtri(p)``), e.g. 1.95996 for p = 0.025."""
    from scipy import special

    if not 0.0 < p < 1.0:
        raise ValueError(f"p must be in (0, 1), got {p}")
    return -float(special.ndtri(p))


def signed_rank_p(d: np.ndarray) -> float:
    """One-sided p-value of the Wilcoxon signed-rank test that the paired
    differences ``d`` are positive (zeros and NaN dropped; ties share ranks,
    ``scipy.stats.rankdata``): exact for up to 60 pairs, ties included, the
    normal approximation with continuity correction and the tie-corrected
    variance beyond — the tail of ``(W+ - 1/2 - n (n + 1)/4) / sqrt(sum r**2 / 4)``
    (``scipy.special.ndtr``). 1 with no pairs.

    The exact p-value is counted here, not taken from ``scipy.stats.wilcoxon``:
    with tied |d| SciPy has no exact distribution (its ``method="exact"``
    uses the distribution without ties, rounding the statistic; its
    permutation method enumerates all 2**n sign assignments, 2**60 at 60
    pairs; its default ``"auto"`` switches to the normal approximation past
    13 pairs), so this count is needed anyway; without ties it gives
    SciPy's ``method="exact"`` p-value (a test), and calling SciPy for that
    case costs 3.5-10x the count here (0.3-2 ms a call at 15-60 pairs, a few
    % of a 60-row diagnosis, which runs the test about 11 times)."""
    from scipy.stats import rankdata

    d = np.asarray(d, float)
    d = d[np.isfinite(d) & (d != 0.0)]
    n = len(d)
    if n == 0:
        return 1.0
    ranks = rankdata(np.abs(d))
    w = float(ranks[d > 0].sum())
    if n > EXACT_PAIRS:
        return normal_sf((w - 0.5 - n * (n + 1) / 4.0) / np.sqrt(float((ranks ** 2).sum()) / 4.0))
    # distribution of the sum of a random subset of the ranks, on half-ranks (ties share .5)
    r2 = np.round(2 * ranks).astype(int)
    dist = np.zeros(int(r2.sum()) + 1)
    dist[0] = 1.0
    for r in r2:
        dist[r:] = dist[r:] + dist[:-r]
    dist /= dist.sum()
    return float(dist[int(round(2 * w)):].sum())


def better(e_new: np.ndarray, e_old: np.ndarray, alpha: float) -> bool:
    """Whether held-out errors ``e_new`` beat ``e_old`` beyond noise: the
    one-sided signed-rank test on the paired gains in squared error
    ``e_old^2 - e_new^2`` rejects "no gain" at ``alpha``."""
    d = np.asarray(e_old, float) ** 2 - np.asarray(e_new, float) ** 2
    return signed_rank_p(d) < alpha


def spearman(a: np.ndarray, b: np.ndarray) -> float:
    """Spearman rank correlation of the finite pairs (ties share their
    average rank; ``scipy.stats.spearmanr``); NaN with fewer than 3 pairs or
    a constant side."""
    from scipy.stats import spearmanr

    a, b = np.asarray(a, float), np.asarray(b, float)
    m = np.isfinite(a) & np.isfinite(b)
    if m.sum() < 3:
        return float("nan")
    a, b = a[m], b[m]
    if (a == a[0]).all() or (b == b[0]).all():
        return float("nan")
    return float(spearmanr(a, b)[0])


def model_weights(criterion: Sequence[float]) -> np.ndarray:
    """Akaike/Schwarz weights ``exp(-delta/2) / sum`` of information criteria
    (AIC or BIC) of competing models."""
    c = np.asarray(criterion, float)
    w = np.exp(-0.5 * (c - np.nanmin(c)))
    w[~np.isfinite(w)] = 0.0
    return w / w.sum()
