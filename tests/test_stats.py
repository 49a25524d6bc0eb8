"""The statistics the diagnosis judges with (``cdsm.calibration.stats``,
SciPy-backed) against independent facts: closed forms of the chi-square, F
and normal tails, published quantiles, the signed-rank test's p-value by
explicit enumeration of every sign assignment, by exact integer
arithmetic of its generating function (ties included) and by SciPy's exact
distribution (no ties), and Spearman's
correlation of a published example and a hand-ranked one.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from cdsm.calibration import stats


def chi2_sf_closed(x: float, dof: int) -> float:
    """Chi-square tail for integer dof: the Poisson sum (even dof) or erfc
    plus the half-integer terms (odd dof)."""
    h = x / 2.0
    if dof % 2 == 0:
        return math.exp(-h) * sum(h ** k / math.factorial(k) for k in range(dof // 2))
    return math.erfc(math.sqrt(h)) + math.exp(-h) * sum(h ** (k - 0.5) / math.gamma(k + 0.5)
                                                       for k in range(1, dof // 2 + 1))


@pytest.mark.parametrize("dof", [1, 2, 3, 4, 7, 10, 31, 60])
@pytest.mark.parametrize("x", [0.01, 0.5, 1.0, 3.0, 9.5, 30.0, 120.0])
def test_chi2_sf_equals_its_closed_form(dof, x):
    # relative, down to tails of 1e-26 (a 1 - P(a, x) form loses them)
    assert stats.chi2_sf(x, dof) == pytest.approx(chi2_sf_closed(x, dof), rel=1e-12, abs=1e-300)


def test_chi2_sf_at_and_below_zero_is_one():
    assert stats.chi2_sf(0.0, 3) == 1.0 and stats.chi2_sf(-2.0, 3) == 1.0
    with pytest.raises(ValueError):
        stats.chi2_sf(1.0, 0)


def test_chi2_ppf_published_quantiles_and_closed_form():
    # z_0.975^2 (1 dof); NIST/SEMATECH e-Handbook 1.3.6.7.4 (3 decimals): 10 dof, 0.975 and 0.025
    assert stats.chi2_ppf(0.95, 1) == pytest.approx(1.959963984540054 ** 2, rel=1e-13)
    assert stats.chi2_ppf(0.975, 10) == pytest.approx(20.483, abs=5e-4)
    assert stats.chi2_ppf(0.025, 10) == pytest.approx(3.247, abs=5e-4)
    assert stats.chi2_ppf(0.99, 30) == pytest.approx(50.892, abs=5e-4)
    for q in (1e-9, 0.025, 0.5, 0.975, 0.999999):  # 2 dof: the exponential, ppf = -2 ln(1 - q)
        assert stats.chi2_ppf(q, 2) == pytest.approx(-2.0 * math.log1p(-q), rel=1e-13)
    for dof in (1, 5, 40):  # the inverse of the closed-form tail
        for q in (1e-6, 0.3, 0.99):
            assert 1.0 - chi2_sf_closed(stats.chi2_ppf(q, dof), dof) == pytest.approx(q, rel=1e-9)
    for bad in (0.0, 1.0, -0.1):
        with pytest.raises(ValueError):
            stats.chi2_ppf(bad, 3)


def f_sf_closed(x: float, d1: int, d2: int) -> float:
    """F tail for even d1, d2: I_y(d2/2, d1/2), y = d2 / (d2 + d1 x), as the
    binomial sum of the regularised incomplete beta with integer parameters."""
    a, b = d2 // 2, d1 // 2
    y = d2 / (d2 + d1 * x)
    m = a + b - 1
    return sum(math.comb(m, j) * y ** j * (1 - y) ** (m - j) for j in range(a, m + 1))


@pytest.mark.parametrize("d1, d2", [(2, 2), (2, 10), (4, 6), (6, 30), (10, 4), (20, 40)])
@pytest.mark.parametrize("x", [0.05, 0.7, 1.0, 2.5, 8.0, 60.0])
def test_f_sf_equals_its_closed_form(d1, d2, x):
    assert stats.f_sf(x, d1, d2) == pytest.approx(f_sf_closed(x, d1, d2), rel=1e-11, abs=1e-300)


def test_f_sf_published_quantile_and_bounds():
    # NIST/SEMATECH e-Handbook 1.3.6.7.3: F_0.95(3, 10) = 3.708 (3 decimals)
    assert stats.f_sf(3.708, 3, 10) == pytest.approx(0.05, abs=2e-5)
    assert stats.f_sf(0.0, 3, 10) == 1.0 and stats.f_sf(-1.0, 3, 10) == 1.0
    with pytest.raises(ValueError):
        stats.f_sf(1.0, 0, 10)


def test_normal_sf_published_values():
    assert stats.normal_sf(1.959963984540054) == pytest.approx(0.025, rel=1e-14)
    assert stats.normal_sf(1.6448536269514722) == pytest.approx(0.05, rel=1e-14)
    assert stats.normal_sf(0.0) == 0.5
    # Abramowitz & Stegun 26.2: Q(10) = 7.6198530241605e-24, far below 1 - Phi's rounding
    assert stats.normal_sf(10.0) == pytest.approx(7.6198530241605e-24, rel=1e-12)
    assert stats.normal_sf(-10.0) == pytest.approx(1.0, rel=1e-15)


def test_normal_isf_published_quantiles():
    # z_0.975, z_0.95 and z_0.995 (NIST/SEMATECH e-Handbook 1.3.6.7.1, here to 16 digits)
    assert stats.normal_isf(0.025) == pytest.approx(1.959963984540054, rel=1e-14)
    assert stats.normal_isf(0.05) == pytest.approx(1.6448536269514722, rel=1e-14)
    assert stats.normal_isf(0.005) == pytest.approx(2.5758293035489004, rel=1e-14)
    assert stats.normal_isf(0.5) == 0.0
    # Abramowitz & Stegun 26.2: Q(10) = 7.6198530241605e-24
    assert stats.normal_isf(7.6198530241605e-24) == pytest.approx(10.0, rel=1e-12)
    for bad in (0.0, 1.0, -0.1):
        with pytest.raises(ValueError):
            stats.normal_isf(bad)


def mid_ranks(v) -> np.ndarray:
    """1-based ranks, ties sharing their average (counted pairwise)."""
    v = np.asarray(v, float)
    below = (v[None, :] < v[:, None]).sum(axis=1)
    equal = (v[None, :] == v[:, None]).sum(axis=1)
    return below + (equal + 1) / 2.0


def signed_rank_enumerated(d) -> float:
    """P(W+ >= w) over every one of the 2**n sign assignments of |d|, each
    listed explicitly (n <= ~22)."""
    d = np.asarray(d, float)
    d = d[np.isfinite(d) & (d != 0)]
    r = mid_ranks(np.abs(d))
    w = r[d > 0].sum()
    sums = np.zeros(1)
    for ri in r:
        sums = np.concatenate([sums, sums + ri])
    return float(np.mean(sums >= w - 1e-9))


def signed_rank_generating(d) -> float:
    """The same p-value in exact integers: the generating function
    prod (1 + x**(2 r_i)) over the doubled ranks, multiplied as one big
    integer (Kronecker substitution, 64 bits per coefficient)."""
    d = np.asarray(d, float)
    d = d[np.isfinite(d) & (d != 0)]
    r2 = [int(round(2 * x)) for x in mid_ranks(np.abs(d))]
    w2 = int(round(sum(x for x, s in zip(r2, d) if s > 0)))
    poly = 1
    for x in r2:
        poly *= 1 + (1 << (64 * x))
    mask = (1 << 64) - 1
    counts = [(poly >> (64 * k)) & mask for k in range(sum(r2) + 1)]
    return sum(counts[w2:]) / 2 ** len(r2)


def test_signed_rank_exact_equals_enumeration_of_every_sign_assignment():
    rng = np.random.default_rng(4)
    cases = [
        [1.0, 2.0, 3.0, 4.0, 5.0],                          # all positive: 1/32
        [-1.0, 2.0, -3.0, 4.0, 5.0, 6.0, -7.0],
        [0.5, -0.5, 1.0, 1.0, -2.0, 3.0, 3.0, 3.0, -4.0],   # ties across signs
        [0.0, 0.0, 1.5, -1.5, 2.0, np.nan, 2.0, 2.5],       # zeros and NaN dropped
    ]
    cases += [np.round(rng.normal(0.3, 1.0, n), 1) for n in (12, 16, 20)]  # many ties
    cases += [rng.normal(0.2, 1.0, n) for n in (11, 18)]                    # none
    for d in cases:
        assert stats.signed_rank_p(np.asarray(d)) == pytest.approx(signed_rank_enumerated(d), rel=1e-12)
    assert stats.signed_rank_p(np.array([1.0, 2.0, 3.0, 4.0, 5.0])) == 1 / 32


def test_signed_rank_exact_up_to_60_pairs_with_ties():
    rng = np.random.default_rng(7)
    for n, decimals in ((60, 1), (45, 1), (60, None), (33, None)):
        d = rng.normal(0.25, 1.0, n)
        d = np.round(d, decimals) if decimals is not None else d
        want = signed_rank_generating(d)
        assert stats.signed_rank_p(d) == pytest.approx(want, rel=1e-10, abs=1e-15)


def test_signed_rank_without_ties_equals_scipy_exact():
    from scipy.stats import wilcoxon

    rng = np.random.default_rng(11)
    for n in (1, 2, 5, 13, 14, 30, 59, 60):
        d = rng.normal(0.3, 1.0, n)
        want = wilcoxon(d, alternative="greater", method="exact").pvalue
        assert stats.signed_rank_p(d) == pytest.approx(want, rel=1e-12, abs=1e-15)


def test_signed_rank_normal_approximation_beyond_60_pairs():
    rng = np.random.default_rng(9)
    tied = np.round(rng.normal(0.2, 1.0, 80), 1)
    tied = tied[tied != 0]
    assert len(tied) > 60 and len(np.unique(np.abs(tied))) < len(tied)
    for d in (tied, rng.normal(0.1, 1.0, 200)):
        r = mid_ranks(np.abs(d))
        w = r[d > 0].sum()
        n = len(d)
        # tie-corrected variance sum(r^2) / 4, continuity correction 1/2
        z = (w - 0.5 - n * (n + 1) / 4) / math.sqrt((r ** 2).sum() / 4)
        assert stats.signed_rank_p(d) == pytest.approx(0.5 * math.erfc(z / math.sqrt(2)), rel=1e-12)


def test_signed_rank_without_pairs_and_better():
    assert stats.signed_rank_p(np.array([0.0, np.nan])) == 1.0
    old = np.full(12, 2.0)
    assert stats.better(np.full(12, 1.0), old, 0.05)        # p = 2**-12
    assert not stats.better(old, np.full(12, 1.0), 0.05)


def test_spearman_published_and_hand_ranked_examples():
    # Wikipedia, "Spearman's rank correlation coefficient": IQ against hours of TV per week, rho = -29/165
    iq = [106, 100, 86, 101, 99, 103, 97, 113, 112, 110]
    tv = [7, 27, 2, 50, 28, 29, 20, 12, 6, 17]
    assert stats.spearman(iq, tv) == pytest.approx(-29 / 165, rel=1e-14)
    # ties: ranks [1, 2.5, 2.5, 4] and [1, 3, 2, 4] correlate sqrt(4.5^2 / (4.5 * 5))
    assert stats.spearman([1, 2, 2, 3], [1, 3, 2, 4]) == pytest.approx(math.sqrt(0.9), rel=1e-14)
    # non-finite pairs dropped; NaN below 3 pairs or with a constant side
    assert stats.spearman([1, 2, 2, 3, np.nan], [1, 3, 2, 4, 5]) == pytest.approx(math.sqrt(0.9), rel=1e-14)
    assert math.isnan(stats.spearman([1, 2, np.nan], [1, 2, 3]))
    assert math.isnan(stats.spearman([1, 1, 1, 1], [1, 2, 3, 4]))


# ---------------------------------------------------------------------------
# likelihood-ratio tests of nested models and the held-out RMS of a correct
# model (issue 34): against scipy.stats and numpy least squares on linear
# Gaussian models, where the answers are exact
# ---------------------------------------------------------------------------
def _rss(X: np.ndarray, y: np.ndarray, cols) -> float:
    """Residual sum of squares of the least-squares fit of y on X's columns ``cols`` (numpy)."""
    beta = np.linalg.lstsq(X[:, cols], y, rcond=None)[0]
    return float(np.sum((y - X[:, cols] @ beta) ** 2))


def test_chi2_difference_is_the_likelihood_ratio_of_nested_linear_models():
    from scipy import stats as sst

    rng = np.random.default_rng(3)
    sigma = 0.5
    X = rng.normal(size=(40, 5))
    y = X[:, :2] @ np.array([1.0, -2.0]) + 0.3 * X[:, 2] + rng.normal(0.0, sigma, 40)
    small, big = _rss(X, y, [0, 1]), _rss(X, y, [0, 1, 2, 3])
    stat, p = stats.chi2_difference(small, big, 2, sigma ** 2)
    assert stat == pytest.approx((small - big) / sigma ** 2, rel=1e-12)
    assert p == pytest.approx(sst.chi2.sf((small - big) / sigma ** 2, 2), rel=1e-10)
    # the bigger fit worse (not nested, or not at its minimum) is no evidence; nothing added: p = 1
    assert stats.chi2_difference(big, small, 2, sigma ** 2) == (0.0, 1.0)
    assert stats.chi2_difference(small, big, 0, sigma ** 2)[1] == 1.0
    with pytest.raises(ValueError):
        stats.chi2_difference(small, big, 2, 0.0)


def test_chi2_difference_under_the_null_is_chi_square_of_the_added_parameters():
    """The smaller model true: the statistic is chi-square(dof) exactly
    (Kolmogorov-Smirnov against scipy's distribution, 2000 data sets)."""
    from scipy import stats as sst

    rng = np.random.default_rng(11)
    sigma = 2.0
    X = rng.normal(size=(30, 6))
    draws = []
    for _ in range(2000):
        y = X[:, :2] @ np.array([3.0, 1.0]) + rng.normal(0.0, sigma, 30)
        draws.append(stats.chi2_difference(_rss(X, y, [0, 1]), _rss(X, y, [0, 1, 2, 3, 4]), 3, sigma ** 2)[0])
    assert sst.kstest(draws, sst.chi2(3).cdf).pvalue > 0.01


def test_f_difference_against_pure_error_of_repeats():
    """Repeated rows (the same design row, their own noise) estimate the
    noise; F = (drop in RSS / dof) / (pure SS / pure dof) is F(dof, pure
    dof) under the smaller model whatever sigma (scipy.stats.f)."""
    from scipy import stats as sst

    rng = np.random.default_rng(5)
    base = rng.normal(size=(12, 4))
    X = np.repeat(base, 3, axis=0)  # 12 commands, 3 repeats each
    groups = np.repeat(np.arange(12), 3)

    def pure(y):
        ss = sum(float(np.sum((y[groups == g] - y[groups == g].mean()) ** 2)) for g in range(12))
        return ss, 12 * 2

    y = X[:, 0] * 2.0 + 0.8 * X[:, 1] + rng.normal(0.0, 0.1, len(X))
    small, big = _rss(X, y, [0]), _rss(X, y, [0, 1, 2])
    ss, dof = pure(y)
    stat, p = stats.f_difference(small, big, 2, ss, dof)
    assert stat == pytest.approx(((small - big) / 2) / (ss / dof), rel=1e-12)
    assert p == pytest.approx(sst.f.sf(stat, 2, dof), rel=1e-10)
    draws = []
    for sigma in (1e-3, 1.0, 50.0) * 500:  # the noise's size does not matter
        y = X[:, 0] * 2.0 + rng.normal(0.0, sigma, len(X))
        draws.append(stats.f_difference(_rss(X, y, [0]), _rss(X, y, [0, 1, 2]), 2, *pure(y))[0])
    assert sst.kstest(draws, sst.f(2, 24).cdf).pvalue > 0.01
    with pytest.raises(ValueError):
        stats.f_difference(small, big, 2, 0.0, 3)


def _cv_rms(A: np.ndarray, y: np.ndarray, tests) -> float:
    """Held-out RMS of |e| per row of ordinary least squares on the folds
    (numpy lstsq; A (n, d, k), y (n, d))."""
    n, d, k = A.shape
    err = np.zeros(n)
    for t in tests:
        train = np.ones(n, bool)
        train[t] = False
        x = np.linalg.lstsq(A[train].reshape(-1, k), y[train].reshape(-1), rcond=None)[0]
        err[t] = np.linalg.norm(y[t] - A[t] @ x, axis=1)
    return float(np.sqrt(np.mean(err ** 2)))


@pytest.mark.parametrize("n, k, many", [(15, 6, True), (60, 12, True), (20, 1, False)])
def test_heldout_rms_draws_match_an_independent_cross_validation(n, k, many):
    """A linear Gaussian toy model: the held-out RMS of data simulated
    independently (true parameters, noise, numpy least squares on 10
    folds) has the quantiles of the draws, and the 0.99 quantile is
    exceeded by 1 % of the independent data sets (the bound is calibrated;
    sqrt(1 + k/n) alone, or a chi-square of n components, would not be)."""
    rng = np.random.default_rng(100 + n + k)
    d, sigma = 2, 1e-5
    A = rng.normal(size=(n, d, k)) * 1e-3   # m per typical size: every direction seen far above the noise
    A[:3] *= 8.0                              # three high-leverage rows: the folds' errors are uneven
    order = rng.permutation(n)
    tests = [np.sort(order[i::10]) for i in range(min(10, n))]
    draws = stats.heldout_rms_draws(A, tests, sigma, 4000, 7)
    truth = rng.normal(size=k)
    sims = np.array([_cv_rms(A, A @ truth + rng.normal(0.0, sigma, (n, d)), tests) for _ in range(3000)])
    for q in (0.1, 0.5, 0.9):
        assert np.quantile(draws, q) == pytest.approx(np.quantile(sims, q), rel=0.02)
    bound = np.quantile(draws, 0.99)
    assert 12 <= np.sum(sims > bound) <= 50    # 1 % of 3000 = 30, binomial 99.9 % range
    # the naive bound, the chi-square of n d components, misses many parameters' share
    naive = sigma * np.sqrt(stats.chi2_ppf(0.99, n * d) / n)
    assert (np.mean(sims > naive) > 0.05) == many


def test_heldout_rms_draws_with_repeats_draw_the_noise_estimate_too():
    """Compared with an estimated noise (dof_pure degrees of freedom), the
    held-out RMS over sigma-hat: an independent simulation of both."""
    rng = np.random.default_rng(8)
    n, d, k, sigma, dof = 20, 2, 3, 1.0, 6
    A = rng.normal(size=(n, d, k)) * 100.0
    tests = [np.arange(i, n, 5) for i in range(5)]
    draws = stats.heldout_rms_draws(A, tests, sigma, 4000, 3, dof_pure=dof)
    sims = np.array([_cv_rms(A, rng.normal(0.0, sigma, (n, d)), tests)
                     / np.sqrt(rng.chisquare(dof) / dof) for _ in range(3000)])
    for q in (0.5, 0.9, 0.99):
        assert np.quantile(draws, q) == pytest.approx(np.quantile(sims, q), rel=0.05)
    # without the estimate's scatter the 0.99 quantile is far lower
    assert np.quantile(stats.heldout_rms_draws(A, tests, sigma, 4000, 3), 0.99) < 0.8 * np.quantile(draws, 0.99)


def test_signed_rank_statistic_and_pairs():
    d = np.array([3.0, -1.0, 2.0, 0.0, np.nan, 4.0])
    w, n, p = stats.signed_rank(d)
    assert (w, n) == (2.0 + 3.0 + 4.0, 4)     # ranks of |d| = 1, 2, 3, 4; positive: 3, 2, 4 -> ranks 3, 2, 4
    assert p == stats.signed_rank_p(d) == pytest.approx(2 / 16)  # W+ >= 9 of 16 sign assignments: 9, 10
