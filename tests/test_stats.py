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
