"""Parent and survivor selection as pure functions over fitness arrays (paper, Sect. 6).

Every function takes fitness as a 1-D array-like of finite floats, indexed like the population,
and returns indices. Random choices draw from the ``numpy.random.Generator`` passed in. Ties are
broken by index (the lower index counts as fitter), so results never depend on sort stability.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "mu_plus_lambda",
    "online_survivors",
    "random_survivors",
    "select_parents",
    "tournament",
]


def _fitness(fitness: ArrayLike, at_least: int = 1) -> NDArray[np.float64]:
    f = np.asarray(fitness, dtype=np.float64)
    if f.ndim != 1:
        raise ValueError(f"fitness must be a 1-D array, got shape {f.shape}")
    if len(f) < at_least:
        raise ValueError(f"need at least {at_least} fitness value(s), got {len(f)}")
    if not np.all(np.isfinite(f)):
        raise ValueError("fitness values must be finite (no NaN or infinity)")
    return f


def _worst_first(f: NDArray[np.float64]) -> NDArray[np.intp]:
    # Ascending fitness; among equals the higher index is "worse" (lower index wins ties).
    return np.lexsort((-np.arange(len(f)), f))


def tournament(fitness: ArrayLike, rng: np.random.Generator, k: int = 4,
               exclude: int | None = None) -> int:
    """Index of the fittest of ``k`` distinct robots drawn at random (all of them if fewer).

    Ties go to the lower index.

    Args:
        fitness: Fitness of each robot.
        rng: The generator drawing the entrants.
        k: Tournament size.
        exclude: An index that may not take part (used to draw a second, different parent).
    """
    f = _fitness(fitness)
    if k < 1:
        raise ValueError(f"tournament size k must be >= 1, got {k}")
    pool = np.arange(len(f))
    if exclude is not None:
        pool = pool[pool != exclude]
        if len(pool) == 0:
            raise ValueError("no robot left to draw after the exclusion")
    entrants = rng.choice(pool, size=min(k, len(pool)), replace=False)
    best = max(entrants.tolist(), key=lambda i: (f[i], -i))
    return int(best)


def select_parents(fitness: ArrayLike, rng: np.random.Generator, k: int = 4) -> tuple[int, int]:
    """Two distinct parents, each the winner of a ``k``-tournament.

    The second tournament is drawn without the first winner.
    """
    _fitness(fitness, at_least=2)
    a = tournament(fitness, rng, k)
    b = tournament(fitness, rng, k, exclude=a)
    return a, b


def mu_plus_lambda(fitness: ArrayLike, mu: int) -> NDArray[np.intp]:
    """Indices of the ``mu`` fittest of parents and offspring together, fittest first.

    Truncation selection; among equal fitness the lower index wins.
    """
    f = _fitness(fitness)
    if not 1 <= mu <= len(f):
        raise ValueError(f"mu must be in [1, {len(f)}], got {mu}")
    return _worst_first(f)[::-1][:mu].copy()


def random_survivors(n: int, mu: int, rng: np.random.Generator) -> NDArray[np.intp]:
    """``mu`` distinct indices out of ``n`` drawn uniformly, sorted.

    The random-selection baseline.
    """
    if not 1 <= mu <= n:
        raise ValueError(f"mu must be in [1, n={n}], got {mu}")
    return np.sort(rng.choice(n, size=mu, replace=False))


def online_survivors(
    fitness: ArrayLike, min_alive: int = 8, max_alive: int = 30, threshold: float = 0.7,
    cull_fraction: float = 0.7,
) -> NDArray[np.intp]:
    """Indices of the robots that die under the paper's online rule, sorted.

    Robots whose fitness is below ``threshold`` of the population mean die, least fit first, but
    never so many that fewer than ``min_alive`` remain. If nobody is below the threshold and the
    population has reached ``max_alive``, the ``cull_fraction`` least fit die (again never going
    below ``min_alive``).

    The threshold is ``mean - (1 - threshold) * |mean|``: 70 % of the mean when the mean is
    positive, and 30 % of its magnitude below the mean when it is negative (taking 70 % of a
    negative mean literally would put the bar above the mean and kill above-average robots). With
    a zero mean the bar is 0: robots with negative fitness die.
    """
    f = _fitness(fitness, at_least=0)
    if min_alive < 0 or max_alive < min_alive:
        raise ValueError(f"need 0 <= min_alive <= max_alive, got {min_alive}, {max_alive}")
    if not 0.0 <= threshold <= 1.0 or not 0.0 <= cull_fraction <= 1.0:
        raise ValueError("threshold and cull_fraction must be in [0, 1]")
    n = len(f)
    spare = n - min_alive
    if n == 0 or spare <= 0:
        return np.zeros(0, dtype=np.intp)
    mean = float(f.mean())
    bar = mean - (1.0 - threshold) * abs(mean)
    order = _worst_first(f)
    below = order[f[order] < bar]
    if len(below):
        dead = below[:spare]
    elif n >= max_alive:
        dead = order[: min(math.floor(cull_fraction * n + 1e-9), spare)]
    else:
        dead = order[:0]
    return np.sort(dead)
