"""Statistics of a report: per-run tests, effect sizes with exact intervals, Holm's correction.

The primary comparison takes one value per run (runs are the independent units; robots of one
run are not): two-sided Mann-Whitney U between every pair of experiments, the Vargha-Delaney
A12 effect size (the probability that a run of A beats a run of B, ties counting half; 0.5: no
effect) with a 95 % confidence interval (:func:`a12_interval`), and Holm-Bonferroni's step-down
correction over the pairs of one sample. Small samples (at most :data:`EXACT_LIMIT` ways to
split them) get the exact permutation distribution of U, ties included (the normal
approximation scipy falls back to with ties could go below the exact floor); larger ones (and
a single run against others) scipy's default. The exact two-sided p cannot go below
``2 / C(n_a + n_b, n_a)`` (0.1 with 3 runs against 3): :func:`smallest_p` gives that floor and
the tables show it in every row, so a small study's lack of power is visible.

The interval of A12. A percentile bootstrap collapses at the extremes: with every run of A
above every run of B each resample says A12 = 1, so 8 runs against 8 gave [1.00, 1.00], as
if 16 runs proved a certainty. :func:`a12_interval` instead inverts a test, so its width
follows the sample sizes: it holds every A12 that a two-sided test at 5 % does not reject,
under the family of *Lehmann alternatives* (A's distribution a power of B's, ``F_A = F_B^k``,
so ``A12 = k / (k + 1)``; Lehmann 1953). Under that family the probability of each way the
runs of A and B can interleave is known exactly, so for small samples the test is exact:
at A12 = 0.5 it is the exact permutation test whose p the tables show, and the interval
excludes 0.5 exactly when that p is below 0.05 (3 runs against 3 with A12 = 1: p = 0.1 and
[0.41, 1]; 8 against 8: [0.80, 1]). Beyond :data:`EXACT_LIMIT` splits it is the score
(Wilson-type) interval with the variance of A12 under the same family (Hanley and McNeil
1982's; Newcombe 2006's method 5 uses it with the two sizes averaged). The family is
symmetric: the interval of B over A is one minus that of A over B. Ties count half in A12 and
are kept by the exact test (tied values are treated as adjacent in an unknown order).

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
from itertools import combinations

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import brentq
from scipy.special import expit, logsumexp
from scipy.stats import PermutationMethod, mannwhitneyu, norm, rankdata

__all__ = [
    "ALPHA",
    "CURVE_FRACTIONS",
    "EXACT_LIMIT",
    "Comparison",
    "a12",
    "a12_interval",
    "a12_variance",
    "compare",
    "curve_summary",
    "holm",
    "smallest_p",
]

ALPHA = 0.05
"""Significance level of the corrected p-values."""

EXACT_LIMIT = 20_000
"""Largest number of splits ``C(n_a + n_b, n_a)`` tested by exact permutation, and given the
exact interval of A12 (8 runs against 8: 12,870 splits; about 0.1 s each)."""

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


def a12_interval(x: NDArray[np.float64], y: NDArray[np.float64], level: float = 0.95
                 ) -> tuple[float, float]:
    """Confidence interval of :func:`a12` (A = ``x`` over B = ``y``), exact for small samples.

    The A12 values a two-sided test at ``1 - level`` does not reject under the Lehmann
    alternatives (module docstring): exact up to :data:`EXACT_LIMIT` splits, the score interval
    beyond. ``(nan, nan)`` when a sample is empty.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.size == 0 or y.size == 0:
        return math.nan, math.nan
    alpha = 1.0 - level
    if math.comb(x.size + y.size, x.size) <= EXACT_LIMIT:
        return _exact_interval(x, y, alpha)
    return _score_interval(a12(x, y), x.size, y.size, alpha)


_LOG_K = 40.0
"""Search range of ``log k`` (A12 from 4e-18 to 1 - 4e-18): beyond it a bound is 0 or 1."""


def _exact_interval(x: NDArray[np.float64], y: NDArray[np.float64], alpha: float
                    ) -> tuple[float, float]:
    """Invert the exact two-sided test of ``A12 = k / (k + 1)`` under ``F_A = F_B^k``.

    Every split of the pooled, sorted values into A's positions is enumerated; under the
    alternative ``k`` a split with ``a_i`` of A's values among the lowest ``i`` has probability
    ``n_a! n_b! k^n_a / prod_i (i + (k - 1) a_i)`` (integrating the ordered uniforms), which is
    ``1 / C(N, n_a)`` at ``k = 1``. U of a split is from mid-ranks, as the observed U.
    """
    n_a, n = x.size, x.size + y.size
    pooled = np.sort(np.concatenate([x, y]))
    midranks = rankdata(pooled)
    splits = np.array(list(combinations(range(n), n_a)), dtype=np.int64)
    members = np.zeros((splits.shape[0], n), dtype=np.float64)
    np.put_along_axis(members, splits, 1.0, axis=1)
    u = members @ midranks - n_a * (n_a + 1) / 2.0
    observed = float(rankdata(np.concatenate([x, y]))[:n_a].sum() - n_a * (n_a + 1) / 2.0)
    at_least = u >= observed - 1e-9
    at_most = u <= observed + 1e-9
    a_below = np.cumsum(members, axis=1)  # a_i: A's values among the lowest i
    b_below = np.arange(1, n + 1, dtype=np.float64) - a_below  # B's values among them
    const = math.lgamma(n_a + 1) + math.lgamma(n - n_a + 1)
    log_half_alpha = math.log(alpha / 2.0)

    def log_tail(log_k: float, tail: NDArray[np.bool_]) -> float:
        k = math.exp(log_k)
        # (i - a_i) + k a_i: i + (k - 1) a_i without losing k a_i to rounding when k is tiny
        log_p = const + n_a * log_k - np.log(b_below + k * a_below).sum(axis=1)
        return float(logsumexp(log_p[tail]))

    # P(U >= observed) grows with k and P(U <= observed) falls: each bound is one root.
    def lower(log_k: float) -> float:
        return log_tail(log_k, at_least) - log_half_alpha

    def upper(log_k: float) -> float:
        return log_tail(log_k, at_most) - log_half_alpha

    low = 0.0 if lower(-_LOG_K) >= 0 else float(expit(brentq(lower, -_LOG_K, _LOG_K,
                                                               xtol=1e-8)))
    high = 1.0 if upper(_LOG_K) >= 0 else float(expit(brentq(upper, -_LOG_K, _LOG_K,
                                                               xtol=1e-8)))
    return low, high


def a12_variance(theta: float, n_a: int, n_b: int) -> float:
    """Variance of :func:`a12` at ``A12 = theta`` under the Lehmann alternatives.

    Hanley and McNeil's (1982) ``[theta (1 - theta) + (n_a - 1)(Q_A - theta^2) + (n_b - 1)(Q_B
    - theta^2)] / (n_a n_b)`` with ``Q_A = 2 theta^2 / (1 + theta)`` (two runs of A above one
    of B) and ``Q_B = theta / (2 - theta)`` (one run of A above two of B).
    """
    return theta * (1.0 - theta) / (n_a * n_b) * (
        1.0 + (n_a - 1) * theta / (1.0 + theta) + (n_b - 1) * (1.0 - theta) / (2.0 - theta))


def _score_interval(estimate: float, n_a: int, n_b: int, alpha: float) -> tuple[float, float]:
    """The A12 values ``theta`` with ``(estimate - theta)^2 <= z^2 Var_theta``.

    A Wilson-type interval: never degenerate at an estimate of 0 or 1.
    """
    z2 = float(norm.ppf(1.0 - alpha / 2.0)) ** 2

    def outside(theta: float) -> float:
        return (estimate - theta) ** 2 - z2 * a12_variance(theta, n_a, n_b)

    # Just off the estimate the condition holds (the variance is positive there, even at an
    # estimate of 0 or 1): one root on each side.
    step = 1e-9
    low = 0.0 if estimate <= step else float(brentq(outside, 0.0, estimate - step, xtol=1e-10))
    high = 1.0 if estimate >= 1.0 - step else float(brentq(outside, estimate + step, 1.0,
                                                           xtol=1e-10))
    return low, high


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
        a12_low: Lower end of its 95 % interval (:func:`a12_interval`; ``nan`` when not asked).
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


def compare(x: NDArray[np.float64], y: NDArray[np.float64], interval: bool = True
            ) -> Comparison:
    """Mann-Whitney U (two-sided), A12 and (when ``interval``) its interval of two samples.

    Both samples must be non-empty.
    """
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
    low, high = a12_interval(x, y) if interval else (math.nan, math.nan)
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
