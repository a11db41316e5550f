"""How much the evaluation conditions move the fitness of a few robots.

Run: ``PYTHONPATH=. python benchmarks/bench_conditions.py [--robots N] [--seeds K] [--seed S]``.

Evaluates the example spider and gecko and ``N`` random robots (default
:class:`~evolution.config.EvolutionConfig`, one generator seeded with ``S``) with
:func:`revolve_env.evaluate` (3 s insertion, 12 s window, pybullet) under: the old fixed start
(:data:`~revolve_env.IDEAL`, heading 0), a random heading, and a random heading with sensor and
actuator noise of standard deviation 0.05 and 0.1. Conditions that draw are evaluated with the
evaluation seeds ``0 .. K-1`` and reported as mean +- standard deviation over them; the last rows
give the median over the robots of each condition's relative change from IDEAL (of the mean)
and of its spread (sd / mean). About 1 s per evaluation.
"""

from __future__ import annotations

import argparse
import statistics

import numpy as np

from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env import IDEAL, EvaluationConditions, evaluate
from revolve_env.body.examples import gecko, spider
from revolve_env.body.robot import Robot

CONDITIONS = {
    "IDEAL": IDEAL,
    "random heading": EvaluationConditions(heading="random"),
    "+ noise 0.05": EvaluationConditions(heading="random", sensor_noise=0.05,
                                         actuator_noise=0.05),
    "+ noise 0.1": EvaluationConditions(heading="random", sensor_noise=0.1, actuator_noise=0.1),
}


def _robots(n: int, seed: int) -> dict[str, Robot]:
    rng = np.random.default_rng(seed)
    robots = {"spider": spider(), "gecko": gecko()}
    robots.update({f"random {k}": random_robot(rng, EvolutionConfig()) for k in range(n)})
    return robots


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=10, help="random robots (default 10)")
    parser.add_argument("--seeds", type=int, default=5, help="evaluation seeds (default 5)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random robots")
    args = parser.parse_args()
    names = list(CONDITIONS)
    print("| robot | " + " | ".join(names) + " |")
    print("|---" * (len(names) + 1) + "|")
    change: dict[str, list[float]] = {n: [] for n in names}
    spread: dict[str, list[float]] = {n: [] for n in names}
    for label, robot in _robots(args.robots, args.seed).items():
        cells = []
        ideal = 0.0
        for name, conditions in CONDITIONS.items():
            seeds = [0] if conditions == IDEAL else list(range(args.seeds))
            f = [evaluate(robot, seed=s, conditions=conditions).fitness for s in seeds]
            mean = statistics.fmean(f)
            sd = statistics.pstdev(f)
            if name == "IDEAL":
                ideal = mean
                cells.append(f"{mean:.3f}")
                continue
            cells.append(f"{mean:.3f} +- {sd:.3f}")
            if ideal > 0.05:  # relative numbers of robots that move
                change[name].append(mean / ideal - 1)
                spread[name].append(sd / mean if mean > 0 else 0.0)
        print(f"| {label} | " + " | ".join(cells) + " |")
    print("| median change from IDEAL | - | " + " | ".join(
        f"{100 * statistics.median(change[n]):+.0f} %" for n in names[1:]) + " |")
    print("| median sd / mean | - | " + " | ".join(
        f"{100 * statistics.median(spread[n]):.0f} %" for n in names[1:]) + " |")


if __name__ == "__main__":
    main()
