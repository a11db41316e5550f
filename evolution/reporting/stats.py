"""Statistics of a report: per-run tests, effect sizes with bootstrap intervals, Holm's correction.

The primary comparison takes one value per run (runs are the independent units; robots of one
run are not): two-sided Mann-Whitney U between every pair of experiments, the Vargha-Delaney
A12 effect size (the probability that a run of A beats a run of B, ties counting half; 0.5: no
effect) with a 95 % percentile bootstrap interval (each group resampled with replacement, from
a seeded generator, so a report is reproducible), and Holm-Bonferroni's step-down correction
over the pairs of one sample. Small samples (at most :data:`EXACT_LIMIT` ways to split them)
get the exact permutation distribution of U, ties included (the normal approximation scipy
falls back to with ties could go below the exact floor); larger ones (and a single run against
others) scipy's default. The exact two-sided p cannot go below ``2 / C(n_a + n_b, n_a)`` (0.1
with 3 runs against 3): :func:`smallest_p` gives that floor and the tables show it in every
row, so a small study's lack of power is visible.

Experiments of one study share their run seeds (run ``i`` of every experiment starts from the
same initial robots: common random numbers), so their samples are paired by run; the tests here
ignore the pairing, which makes them conservative, never more significant than the data.

Whole curves are compared at equal births: on a grid of fractions of the births both
experiments reached (:data:`CURVE_FRACTIONS`), each run's population mean fitness at those
births (the value after the last commit point at or before them), the same test at each point,
Holm-corrected over the points of one pair; :func:`curve_summary` gives the fraction of the
points where one experiment is significantly above the other.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.stats import PermutationMethod, mannwhitneyu

__all__ = [
    "ALPHA",
    "BOOTSTRAP_RESAMPLES",
    "CURVE_FRACTIONS",
    "EXACT_LIMIT",
    "Comparison",
    "a12",
    "a12_interval",
    "compare",
    "curve_summary",
    "holm",
    "smallest_p",
]

ALPHA = 0.05
"""Significance level of the corrected p-values."""

BOOTSTRAP_RESAMPLES = 2000
"""Bootstrap resamples of an effect size's confidence interval."""

EXACT_LIMIT = 20_000
"""Largest number of splits ``C(n_a + n_b, n_a)`` tested by exact permutation (0.1 s at most)."""

CURVE_FRACTIONS = tuple(k / 10 for k in range(1, 11))
"""Points of the whole-curve comparison: these fractions of the births both experiments reached."""


def a12(x: NDArray[np.float64], y: NDArray[np.float64]) -> float:
    """Vargha-Delaney A12: P(X > Y) + P(X = Y) / 2 over all pairs; ``nan`` when one is empty."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.size == 0 or y.size == 0:
        return math.nan
    greater = np.sum(x[:, None] > y[None, :])
    equal = np.sum(x[:, None] == y[None, :])
    return float((greater + 0.5 * equal) / (x.size * y.size))


def a12_interval(
    x: NDArray[np.float64], y: NDArray[np.float64], rng: np.random.Generator,
    resamples: int = BOOTSTRAP_RESAMPLES, level: float = 0.95,
) -> tuple[float, float]:
    """Percentile bootstrap interval of :func:`a12` (each group resampled with replacement)."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.size == 0 or y.size == 0:
        return math.nan, math.nan
    xs = x[rng.integers(0, x.size, size=(resamples, x.size))]
    ys = y[rng.integers(0, y.size, size=(resamples, y.size))]
    greater = (xs[:, :, None] > ys[:, None, :]).sum(axis=(1, 2))
    equal = (xs[:, :, None] == ys[:, None, :]).sum(axis=(1, 2))
    values = (greater + 0.5 * equal) / (x.size * y.size)
    tail = (1.0 - level) / 2.0
    low, high = np.quantile(values, [tail, 1.0 - tail])
    return float(low), float(high)


def smallest_p(n_a: int, n_b: int) -> float:
    """The smallest two-sided exact Mann-Whitney p-value with these group sizes."""
    if n_a == 0 or n_b == 0:
        return math.nan
    return min(1.0, 2.0 / math.comb(n_a + n_b, n_a))


def holm(p: Sequence[float]) -> list[float]:
    """Holm-Bonferroni adjusted p-values (step-down, monotone, capped at 1)."""
    order = np.argsort(p)
    m = len(p)
    adjusted = np.empty(m)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        adjusted[i] = running
    return adjusted.tolist()


@dataclass(frozen=True, slots=True)
class Comparison:
    """One two-sided Mann-Whitney U test with its effect size.

    Attributes:
        n_a: Values of A.
        n_b: Values of B.
        median_a: Median of A.
        median_b: Median of B.
        u: U statistic of A.
        p: Two-sided p-value (uncorrected; 1 when every value is tied).
        a12: Vargha-Delaney A12 of A over B.
        a12_low: Lower end of its 95 % bootstrap interval.
        a12_high: Upper end.
        p_floor: The smallest p these sizes allow (:func:`smallest_p`).
    """

    n_a: int
    n_b: int
    median_a: float
    median_b: float
    u: float
    p: float
    a12: float
    a12_low: float
    a12_high: float
    p_floor: float


def compare(x: NDArray[np.float64], y: NDArray[np.float64], rng: np.random.Generator
            ) -> Comparison:
    """Mann-Whitney U (two-sided), A12 and its bootstrap interval of two non-empty samples."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if np.ptp(np.concatenate([x, y])) == 0:
        u, p = x.size * y.size / 2.0, 1.0  # all tied: no evidence of a difference
    else:
        # scipy's permutation needs two values a side; one run against n is tested as before.
        exact = min(x.size, y.size) >= 2 and math.comb(x.size + y.size, x.size) <= EXACT_LIMIT
        method: str | PermutationMethod = (PermutationMethod(n_resamples=math.inf) if exact
                                           else "auto")
        result = mannwhitneyu(x, y, alternative="two-sided", method=method)
        u, p = float(result.statistic), float(result.pvalue)
    low, high = a12_interval(x, y, rng)
    return Comparison(int(x.size), int(y.size), float(np.median(x)), float(np.median(y)), u,
                      min(1.0, max(0.0, p)), a12(x, y), low, high, smallest_p(x.size, y.size))


def curve_summary(a12s: Sequence[float], p_holm: Sequence[float], alpha: float = ALPHA
                  ) -> tuple[float, float]:
    """Fractions of the curve's points where A is significantly above B, and B above A."""
    if not a12s:
        return math.nan, math.nan
    above = sum(p < alpha and e > 0.5 for e, p in zip(a12s, p_holm, strict=True))
    below = sum(p < alpha and e < 0.5 for e, p in zip(a12s, p_holm, strict=True))
    return above / len(a12s), below / len(a12s)
