"""The report's statistics against hand computations and SciPy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import mannwhitneyu

from evolution.reporting.stats import (
    ALPHA,
    EXACT_LIMIT,
    a12,
    a12_interval,
    a12_variance,
    compare,
    curve_summary,
    holm,
    smallest_p,
)


def test_a12_by_hand() -> None:
    # pairs (x, y): 3 > 1, 3 > 2, 3 = 3 (half), 1 < 2, 1 < 3, 1 = 1 (half): (2 + 0.5 + 0.5) / 6
    assert a12(np.array([3.0, 1.0]), np.array([1.0, 2.0, 3.0])) == pytest.approx(3 / 6)
    assert a12(np.array([5.0, 6.0]), np.array([1.0, 2.0])) == 1.0
    assert a12(np.array([1.0]), np.array([1.0])) == 0.5
    assert math.isnan(a12(np.zeros(0), np.array([1.0])))


def test_a12_is_u_over_the_pairs() -> None:
    rng = np.random.default_rng(3)
    x, y = rng.normal(size=7), rng.normal(0.5, size=5)
    assert a12(x, y) == pytest.approx(mannwhitneyu(x, y).statistic / 35)


def test_the_interval_shows_uncertainty_at_the_extremes() -> None:
    """Every run of A above every run of B: a bootstrap said [1, 1]; the interval says how far
    from 1 so few runs leave A12, and contains 0.5 exactly when the test cannot reject."""
    low, high = a12_interval(np.arange(8) + 10.0, np.arange(8.0))
    assert high == 1.0 and low == pytest.approx(0.807, abs=0.002)
    low, high = a12_interval(np.array([4.0, 5.0, 6.0]), np.array([1.0, 2.0, 3.0]))
    assert high == 1.0 and low == pytest.approx(0.413, abs=0.002) and low < 0.5  # p = 0.1
    low, high = a12_interval(np.ones(3), np.ones(4))  # all tied: no information
    assert (low, high) == (0.0, 1.0)
    assert all(math.isnan(v) for v in a12_interval(np.zeros(0), np.ones(2)))


def test_the_interval_excludes_one_half_exactly_when_the_exact_test_rejects() -> None:
    rng = np.random.default_rng(11)
    seen = set()
    for _ in range(150):
        n_a, n_b = rng.integers(2, 7, size=2)
        # Rounded: ties between and within the samples happen.
        x = np.round(rng.normal(rng.uniform(0, 2), 1, n_a), 1)
        y = np.round(rng.normal(0, 1, n_b), 1)
        c = compare(x, y)
        if abs(c.p - ALPHA) < 1e-9:
            continue
        assert c.a12_low <= c.a12 <= c.a12_high
        assert (c.a12_low > 0.5 or c.a12_high < 0.5) == (c.p < ALPHA), (x, y, c)
        seen.add(c.p < ALPHA)
    assert seen == {True, False}


def test_the_interval_is_symmetric() -> None:
    x, y = np.array([1.0, 4.0, 5.0, 2.0]), np.array([0.5, 2.0, 3.0])
    low, high = a12_interval(x, y)
    back = a12_interval(y, x)
    assert (low, high) == pytest.approx((1 - back[1], 1 - back[0]), abs=1e-7)
    big_x, big_y = np.linspace(0, 3, 20), np.linspace(-1, 2, 25)  # the score interval
    low, high = a12_interval(big_x, big_y)
    back = a12_interval(big_y, big_x)
    assert (low, high) == pytest.approx((1 - back[1], 1 - back[0]), abs=1e-7)


def test_the_score_interval_is_the_exact_one_for_larger_samples() -> None:
    rng = np.random.default_rng(2)
    x, y = rng.normal(0.8, 1, 8), rng.normal(0, 1, 8)
    exact = a12_interval(x, y)
    theta = a12(x, y)
    # The same family's normal approximation (what samples beyond EXACT_LIMIT get).
    grid = np.linspace(0.0, 1.0, 10_001)
    inside = grid[(theta - grid) ** 2 <= 1.959964 ** 2 * a12_variance(grid, 8, 8)]
    assert exact == pytest.approx((inside.min(), inside.max()), abs=0.05)


@pytest.mark.parametrize(("n_a", "n_b"), [(4, 5), (20, 20)])
def test_the_interval_covers_the_true_a12(n_a: int, n_b: int) -> None:
    """Coverage under a Lehmann alternative, A = B^(1/3) on uniforms: A12 = 3/4. Exact for
    4 against 5 runs, the score interval for 20 against 20."""
    assert (math.comb(n_a + n_b, n_a) <= EXACT_LIMIT) == (n_a < 20)
    rng = np.random.default_rng(5)
    covered = 0
    trials = 300
    for _ in range(trials):
        x, y = rng.uniform(size=n_a) ** (1 / 3), rng.uniform(size=n_b)
        low, high = a12_interval(x, y)
        covered += low <= 0.75 <= high
    assert covered / trials >= 0.93


def test_smallest_p_of_mann_whitney() -> None:
    assert smallest_p(3, 3) == pytest.approx(0.1)  # 2 / C(6, 3)
    assert smallest_p(2, 2) == pytest.approx(1 / 3)
    assert smallest_p(30, 30) < 1e-15
    exact = mannwhitneyu([4.0, 5.0, 6.0], [1.0, 2.0, 3.0], method="exact").pvalue
    assert exact == pytest.approx(smallest_p(3, 3))


def test_holm_on_known_p_values() -> None:
    # sorted 0.01 (x4), 0.02 (x3), 0.03 (x2), 0.5 (x1) -> 0.04, 0.06, 0.06, 0.5
    assert holm([0.03, 0.5, 0.01, 0.02]) == pytest.approx([0.06, 0.5, 0.04, 0.06])
    assert holm([]) == []


def test_compare_is_scipy_with_the_effect_size() -> None:
    x, y = np.array([1.0, 4.0, 5.0]), np.array([0.5, 2.0, 3.0])
    c = compare(x, y)
    reference = mannwhitneyu(x, y, alternative="two-sided")
    assert (c.u, c.p) == (pytest.approx(reference.statistic), pytest.approx(reference.pvalue))
    assert (c.n_a, c.n_b, c.median_a, c.median_b) == (3, 3, 4.0, 2.0)
    assert c.a12 == pytest.approx(7 / 9) and c.p_floor == pytest.approx(0.1)
    tied = compare(np.ones(3), np.ones(2))
    assert (tied.p, tied.a12) == (1.0, 0.5)


def test_curve_summary_counts_significant_points_by_side() -> None:
    above, below = curve_summary([0.9, 0.8, 0.1, 0.95], [0.01, 0.2, 0.03, 0.04])
    assert (above, below) == (0.5, 0.25)
    assert all(math.isnan(v) for v in curve_summary([], []))


def test_tied_small_samples_get_the_exact_permutation_p() -> None:
    """With ties scipy's default falls back to the normal approximation (p = 0.047 for these
    3 against 3), below the exact floor of 0.1: the exact permutation test never is."""
    result = compare(np.array([1.0, 1.0, 1.0]), np.array([3.0, 3.0, 3.0]))
    assert result.p == pytest.approx(0.1) and result.p >= result.p_floor
    untied = compare(np.array([1.0, 2.0, 3.0]), np.array([4.0, 5.0, 6.0]))
    assert untied.p == pytest.approx(0.1)
