"""The statistics the diagnosis judges with: the normal, chi-square and F
tails (``scipy.special``), the likelihood-ratio tests of nested least-squares
models (:func:`chi2_difference` against a known noise, :func:`f_difference`
against pure error), the held-out RMS of a correct linear model
(:func:`heldout_rms_draws`), the paired signed-rank test on held-out errors
(ranks from SciPy, its exact distribution counted here: see
:func:`signed_rank_p`), rank correlation (``scipy.stats.spearmanr``) and
model weights. SciPy is imported on first use: ``scipy.stats`` takes 0.5-0.8 s
to import, once per process (``import cdsm`` stays at about 0.2 s).
"""

from __future__ import annotations

from typing import Sequence, Tuple

import numpy as np

__all__ = ["normal_sf", "normal_isf", "chi2_sf", "chi2_ppf", "f_sf", "chi2_difference", "f_difference",
           "heldout_rms_draws", "signed_rank", "signed_rank_p", "better", "spearman", "model_weights"]

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


def chi2_difference(rss_small: float, rss_big: float, dof: int, variance: float) -> Tuple[float, float]:
    """Likelihood-ratio test of a least-squares model against a nested
    smaller one when the noise variance is known: ``(statistic, p-value)``,
    the statistic ``(rss_small - rss_big) / variance`` (sums of squared
    residuals, m², over the same residual components; ``variance`` the noise
    variance of one component, m²) and its chi-square tail with ``dof``
    degrees of freedom (the parameters the bigger model adds). Under
    Gaussian noise, a model linear in its parameters and the smaller model
    correct, the statistic is chi-square(``dof``) exactly (docs/model.md,
    "The support test"). A negative difference (the bigger fit worse) counts
    as 0; ``dof`` < 1 gives p = 1: nothing was added."""
    if not (variance > 0 and np.isfinite(variance)):
        raise ValueError(f"variance must be positive and finite, got {variance}")
    stat = max(float(rss_small) - float(rss_big), 0.0) / float(variance)
    if not np.isfinite(stat):
        return float("nan"), 1.0
    return stat, (chi2_sf(stat, dof) if dof >= 1 else 1.0)


def f_difference(rss_small: float, rss_big: float, dof: int, ss_pure: float, dof_pure: int
                 ) -> Tuple[float, float]:
    """Likelihood-ratio test of a nested least-squares model against pure
    error (repeated measurements estimate the noise): ``(statistic,
    p-value)``, ``F = ((rss_small - rss_big) / dof) / (ss_pure / dof_pure)``
    and its F(``dof``, ``dof_pure``) tail. The repeats' scatter about their
    means is orthogonal to every model's columns (a model predicts the same
    for a repeated command), so the two sums are independent and F is exact
    under the assumptions of :func:`chi2_difference`, whatever the noise's
    size. A negative difference counts as 0; ``dof`` < 1 gives p = 1."""
    if not (ss_pure > 0 and np.isfinite(ss_pure) and dof_pure >= 1):
        raise ValueError(f"pure error needs a positive sum of squares and dof >= 1, got {ss_pure}, {dof_pure}")
    diff = max(float(rss_small) - float(rss_big), 0.0)
    if not np.isfinite(diff):
        return float("nan"), 1.0
    if dof < 1:
        return 0.0, 1.0
    stat = (diff / dof) / (float(ss_pure) / dof_pure)
    return stat, f_sf(stat, dof, dof_pure)


def heldout_rms_draws(A: np.ndarray, tests: Sequence[np.ndarray], noise: float, draws: int, seed: int,
                      dof_pure: int = 0) -> np.ndarray:
    """(``draws``,) draws of the held-out RMS error (m) of a correct model
    linear in its parameters, cross-validated on the folds ``tests``: a
    linearised parametric bootstrap. ``A`` (n, d, k): the Jacobian of the n
    rows' d components with respect to the k parameters, each scaled to its
    typical size (m per typical size); ``tests``: the held-out rows of each
    fold (indices into the n rows); ``noise`` (m): the noise of one
    component. Each draw is a data set of Gaussian noise about the model
    (the model's own part cancels: it is linear); each fold fits the rows it
    trains on by least squares with a Gaussian prior of one typical size per
    parameter (the ridge ``noise**2 |x|**2``, which leaves a direction the
    rows see well alone and holds one they barely see near the fit, where a
    nonlinear model would no longer be linear) and predicts its held-out
    rows; a draw is the RMS over all n rows of their held-out |e| (norm over
    the d components), so the folds' correlation — they share the rows they
    train on — is kept, which a chi-square of n components would not. With
    ``dof_pure`` > 0 (the noise estimated from repeats with that many degrees
    of freedom) each draw is divided by an independent draw of the
    estimate's own scatter, sqrt(chi2(dof_pure) / dof_pure): the draws are
    then of the held-out RMS over the estimated noise times the true one.
    Seeded by ``seed``: the same draws for the same inputs."""
    A = np.asarray(A, float)
    n, d, k = A.shape
    rng = np.random.default_rng(seed)
    E = rng.standard_normal((n * d, draws)) * noise
    M = A.reshape(n * d, k)
    # each fold's normal equations from the whole set's less its held-out rows'
    G, b = M.T @ M, M.T @ E
    ss = np.zeros(draws)
    for t in tests:
        t = np.asarray(t, int)
        if not len(t):
            continue
        comp = (t[:, None] * d + np.arange(d)).ravel()
        Et = E[comp]
        if k and len(t) < n:
            At = M[comp]
            x = np.linalg.solve(G - At.T @ At + noise ** 2 * np.eye(k), b - At.T @ Et)
            Et = Et - At @ x
        ss += (Et ** 2).sum(axis=0)
    rms = np.sqrt(ss / n)
    if dof_pure > 0:
        rms = rms / np.sqrt(rng.chisquare(dof_pure, draws) / dof_pure)
    return rms


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
    """The p-value of :func:`signed_rank`."""
    return signed_rank(d)[2]


def signed_rank(d: np.ndarray) -> Tuple[float, int, float]:
    """``(W+, n, p)``: the sum of the ranks of the positive differences, the
    number of pairs used and the one-sided p-value of the Wilcoxon
    signed-rank test that the paired differences ``d`` are positive (zeros and NaN dropped; ties share ranks,
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
        return 0.0, 0, 1.0
    ranks = rankdata(np.abs(d))
    w = float(ranks[d > 0].sum())
    if n > EXACT_PAIRS:
        return w, n, normal_sf((w - 0.5 - n * (n + 1) / 4.0) / np.sqrt(float((ranks ** 2).sum()) / 4.0))
    # distribution of the sum of a random subset of the ranks, on half-ranks (ties share .5)
    r2 = np.round(2 * ranks).astype(int)
    dist = np.zeros(int(r2.sum()) + 1)
    dist[0] = 1.0
    for r in r2:
        dist[r:] = dist[r:] + dist[:-r]
    dist /= dist.sum()
    return w, n, float(dist[int(round(2 * w)):].sum())


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
