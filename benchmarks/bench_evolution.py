"""Evolution benchmarks: children per second, and population diversity with zss vs compiled TED.

Run: ``python benchmarks/bench_evolution.py``. Prints figures; asserts nothing about speed.
"""

from __future__ import annotations

import time

import numpy as np

from evolution.config import EvolutionConfig
from evolution.diversity import diversity, pairwise_distances, tree_edit_distance_zss
from evolution.operators import reproduce
from evolution.random_robot import random_robot


def children_per_second(n_children: int = 200, seed: int = 0) -> tuple[float, int]:
    """Reproduce from random pairs of a population of 15 random robots (default config)."""
    config = EvolutionConfig()
    rng = np.random.default_rng(seed)
    pop = [random_robot(rng, config) for _ in range(15)]
    start = time.perf_counter()
    made = failed = 0
    while made + failed < n_children:
        i, j = rng.choice(len(pop), size=2, replace=False)
        result = reproduce(pop[i], pop[j], rng, config)
        if result.child is None:
            failed += 1
        else:
            made += 1
            pop[int(rng.integers(len(pop)))] = result.child
    return made / (time.perf_counter() - start), failed


def diversity_timing(n_robots: int = 30, parts: int = 30, seed: int = 0) -> None:
    config = EvolutionConfig(initial_parts_mean=parts, initial_parts_sd=0.0)
    rng = np.random.default_rng(seed)
    robots = [random_robot(rng, config) for _ in range(n_robots)]
    t0 = time.perf_counter()
    fast = diversity(robots)
    repeats = 20
    for _ in range(repeats - 1):
        diversity(robots)
    t_fast = (time.perf_counter() - t0) / repeats

    t0 = time.perf_counter()
    pairs = [(i, j) for i in range(n_robots) for j in range(i + 1, n_robots)]
    ref = [tree_edit_distance_zss(robots[i], robots[j]) for i, j in pairs]
    t_zss = time.perf_counter() - t0
    d = pairwise_distances(robots)
    assert [d[i, j] for i, j in pairs] == ref, "fast path disagrees with zss"
    print(f"diversity of {n_robots} robots x {parts} parts ({len(pairs)} pairs): {fast:.2f}")
    print(f"  zss (pure Python): {t_zss * 1e3:9.1f} ms  ({t_zss / len(pairs) * 1e3:.2f} ms/pair)")
    print(f"  compiled fast path:{t_fast * 1e3:9.2f} ms  (incl. tree conversion)")
    print(f"  speed-up: {t_zss / t_fast:.0f}x")


def main() -> None:
    rate, failed = children_per_second()
    print(f"reproduction: {rate:.1f} children/s (default config, 15 random parents; "
          f"{failed} crossover failures in 200 attempts)")
    diversity_timing()


if __name__ == "__main__":
    main()
