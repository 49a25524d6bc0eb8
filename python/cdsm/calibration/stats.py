"""The statistics the diagnosis judges with, in NumPy and the standard
library (no SciPy): the normal, chi-square and F distributions, the paired
test on held-out errors, rank correlation and model weights.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

__all__ = ["normal_sf", "chi2_sf", "chi2_ppf", "f_sf", "signed_rank_p", "better",
           "spearman", "model_weights"]


def _gamma_p(a: float, x: float) -> float:
    """Regularised lower incomplete gamma P(a, x) (series / continued fraction)."""
    if x <= 0:
        return 0.0
    lg = math.lgamma(a)
    if x < a + 1:
        term = total = 1.0 / a
        ap = a
        for _ in range(10000):
            ap += 1
            term *= x / ap
            total += term
            if abs(term) < abs(total) * 1e-16:
                break
        return total * math.exp(-x + a * math.log(x) - lg)
    # Lentz's continued fraction for Q(a, x)
    tiny = 1e-300
    b = x + 1 - a
    c = 1 / tiny
    d = 1 / b
    h = d
    for i in range(1, 10000):
        an = -i * (i - a)
        b += 2
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1 / d
        delta = d * c
        h *= delta
        if abs(delta - 1) < 1e-16:
            break
    return 1.0 - math.exp(-x + a * math.log(x) - lg) * h


def chi2_sf(x: float, dof: float) -> float:
    """P(X > x) for X ~ chi-square with ``dof`` degrees of freedom."""
    if dof <= 0:
        raise ValueError(f"dof must be positive, got {dof}")
    return 1.0 - _gamma_p(dof / 2.0, max(x, 0.0) / 2.0)


def chi2_ppf(q: float, dof: float) -> float:
    """The ``q`` quantile of chi-square with ``dof`` degrees of freedom (bisection)."""
    if not 0.0 < q < 1.0:
        raise ValueError(f"q must be in (0, 1), got {q}")
    lo, hi = 0.0, max(1.0, dof)
    while 1.0 - chi2_sf(hi, dof) < q:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if 1.0 - chi2_sf(mid, dof) < q:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def _beta_i(a: float, b: float, x: float) -> float:
    """Regularised incomplete beta I_x(a, b) (continued fraction)."""
    if x <= 0:
        return 0.0
    if x >= 1:
        return 1.0
    if x > (a + 1) / (a + b + 2):
        return 1.0 - _beta_i(b, a, 1 - x)
    lbeta = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
    front = math.exp(lbeta + a * math.log(x) + b * math.log(1 - x)) / a
    tiny = 1e-300
    c, d = 1.0, 1.0 - (a + b) * x / (a + 1)
    d = 1 / (tiny if abs(d) < tiny else d)
    h = d
    for m in range(1, 10000):
        for num in (m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m)),
                    -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1))):
            d = 1 + num * d
            d = 1 / (tiny if abs(d) < tiny else d)
            c = 1 + num / c
            c = tiny if abs(c) < tiny else c
            h *= d * c
        if abs(d * c - 1) < 1e-16:
            break
    return front * h


def f_sf(x: float, d1: float, d2: float) -> float:
    """P(X > x) for X ~ F(d1, d2)."""
    if d1 <= 0 or d2 <= 0:
        raise ValueError(f"degrees of freedom must be positive, got {d1}, {d2}")
    if x <= 0:
        return 1.0
    return _beta_i(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * x))


def normal_sf(x: float) -> float:
    """P(Z > x) for a standard normal Z."""
    return 0.5 * math.erfc(x / math.sqrt(2.0))


def signed_rank_p(d: np.ndarray) -> float:
    """One-sided p-value of the Wilcoxon signed-rank test that the paired
    differences ``d`` are positive (zeros and NaN dropped; ties share ranks):
    exact by enumerating the rank sums for up to 60 pairs, the normal
    approximation with continuity correction beyond. 1 with no pairs."""
    d = np.asarray(d, float)
    d = d[np.isfinite(d) & (d != 0.0)]
    n = len(d)
    if n == 0:
        return 1.0
    ranks = _ranks(np.abs(d)) + 1.0
    w = float(ranks[d > 0].sum())
    if n <= 60:
        # distribution of the sum of a random subset of the ranks (halves for ties)
        r2 = np.round(2 * ranks).astype(int)
        total = int(r2.sum())
        dist = np.zeros(total + 1)
        dist[0] = 1.0
        for r in r2:
            dist[r:] = dist[r:] + dist[:-r]
        dist /= dist.sum()
        return float(dist[int(round(2 * w)):].sum())
    mean = n * (n + 1) / 4.0
    var = float((ranks ** 2).sum()) / 4.0
    return normal_sf((w - 0.5 - mean) / math.sqrt(var))


def better(e_new: np.ndarray, e_old: np.ndarray, alpha: float) -> bool:
    """Whether held-out errors ``e_new`` beat ``e_old`` beyond noise: the
    one-sided signed-rank test on the paired gains in squared error
    ``e_old^2 - e_new^2`` rejects "no gain" at ``alpha``."""
    d = np.asarray(e_old, float) ** 2 - np.asarray(e_new, float) ** 2
    return signed_rank_p(d) < alpha


def _ranks(v: np.ndarray) -> np.ndarray:
    """Ranks of ``v`` (0-based), ties sharing their average rank."""
    order = np.argsort(v, kind="stable")
    r = np.empty(len(v))
    r[order] = np.arange(len(v), dtype=float)
    _, inv = np.unique(v, return_inverse=True)
    sums = np.bincount(inv, weights=r)
    return (sums / np.bincount(inv))[inv]


def spearman(a: np.ndarray, b: np.ndarray) -> float:
    """Spearman rank correlation of the finite pairs (NaN with fewer than 3 or
    a constant side)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    m = np.isfinite(a) & np.isfinite(b)
    if m.sum() < 3:
        return float("nan")
    ra, rb = _ranks(a[m]), _ranks(b[m])
    if ra.std() == 0 or rb.std() == 0:
        return float("nan")
    return float(np.corrcoef(ra, rb)[0, 1])


def model_weights(criterion: Sequence[float]) -> np.ndarray:
    """Akaike/Schwarz weights ``exp(-delta/2) / sum`` of information criteria
    (AIC or BIC) of competing models."""
    c = np.asarray(criterion, float)
    w = np.exp(-0.5 * (c - np.nanmin(c)))
    w[~np.isfinite(w)] = 0.0
    return w / w.sum()
