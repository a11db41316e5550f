"""The report's statistics against hand computations and SciPy."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import mannwhitneyu

from evolution.reporting.stats import (
    a12,
    a12_interval,
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


def test_bootstrap_interval_is_seeded_and_brackets_the_effect() -> None:
    x, y = np.array([1.0, 2.0, 3.0, 4.0]), np.array([2.5, 3.5, 0.5])
    first = a12_interval(x, y, np.random.default_rng(7))
    assert first == a12_interval(x, y, np.random.default_rng(7))
    assert 0.0 <= first[0] <= a12(x, y) <= first[1] <= 1.0
    # Every value of x above every value of y: every resample says 1.
    assert a12_interval(x + 10, y, np.random.default_rng(0)) == (1.0, 1.0)


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
    c = compare(x, y, np.random.default_rng(0))
    reference = mannwhitneyu(x, y, alternative="two-sided")
    assert (c.u, c.p) == (pytest.approx(reference.statistic), pytest.approx(reference.pvalue))
    assert (c.n_a, c.n_b, c.median_a, c.median_b) == (3, 3, 4.0, 2.0)
    assert c.a12 == pytest.approx(7 / 9) and c.p_floor == pytest.approx(0.1)
    tied = compare(np.ones(3), np.ones(2), np.random.default_rng(0))
    assert (tied.p, tied.a12) == (1.0, 0.5)


def test_curve_summary_counts_significant_points_by_side() -> None:
    above, below = curve_summary([0.9, 0.8, 0.1, 0.95], [0.01, 0.2, 0.03, 0.04])
    assert (above, below) == (0.5, 0.25)
    assert all(math.isnan(v) for v in curve_summary([], []))


def test_tied_small_samples_get_the_exact_permutation_p() -> None:
    """With ties scipy's default falls back to the normal approximation (p = 0.047 for these
    3 against 3), below the exact floor of 0.1: the exact permutation test never is."""
    rng = np.random.default_rng(0)
    result = compare(np.array([1.0, 1.0, 1.0]), np.array([3.0, 3.0, 3.0]), rng)
    assert result.p == pytest.approx(0.1) and result.p >= result.p_floor
    untied = compare(np.array([1.0, 2.0, 3.0]), np.array([4.0, 5.0, 6.0]), rng)
    assert untied.p == pytest.approx(0.1)
