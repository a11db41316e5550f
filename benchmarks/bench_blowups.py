"""Blow-up rate of random robots, split by cause (controller vs physics).

Run: ``python benchmarks/bench_blowups.py [--robots N] [--seconds S] [--insertion S] [--seed K]
[--engines pybullet mujoco]``.

Draws ``N`` random robots with :func:`evolution.random_robot.random_robot` (default
:class:`~evolution.config.EvolutionConfig`, one ``numpy`` generator seeded with ``K``), evaluates
each with :func:`revolve_env.evaluate` on each engine and counts the robots whose evaluation blew
up: blow-ups per 1,000 robot-lives of an offline evaluation. (Robots living together in one world
are counted by ``bench_engines.py --only crowd-hour`` and by the runs' ``failures`` table.) A
blow-up whose reason names the controller ("the controller's outputs diverged": non-finite hinge
targets) counts as a controller blow-up; any other reason is a physics blow-up.

The default times are ``evaluate``'s own (3 s of insertion, 12 s of evaluation; about 3 minutes
for 1,000 robots on one core). Shorter runs undercount: a diverging network grows geometrically
from a small value and needs seconds of robot time to overflow (with 1 s + 3 s, 1,000 robots showed
no blow-up at all before linear neurons were clamped). Run from the repository root with
``PYTHONPATH=.`` when the project is not installed.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

import numpy as np

from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env import ENGINES, evaluate

_CONTROLLER_MARK = "controller's outputs diverged"


def blow_up_counts(robots: int, seconds: float, insertion: float, seed: int,
                   engine: str = "pybullet") -> Counter[str]:
    """Evaluate ``robots`` random robots and count the outcomes.

    Args:
        robots: How many random robots to draw and evaluate.
        seconds: Evaluation time per robot. Seconds.
        insertion: Settling time per robot before the evaluation. Seconds.
        seed: Seed of the generator that draws the robots.
        engine: The physics engine.

    Returns:
        Counts under the keys ``"ok"``, ``"controller"`` and ``"physics"``.
    """
    rng = np.random.default_rng(seed)
    config = EvolutionConfig()
    counts: Counter[str] = Counter()
    for _ in range(robots):
        result = evaluate(random_robot(rng, config), seconds=seconds, insertion=insertion,
                          engine=engine)
        if result.blow_up is None:
            counts["ok"] += 1
        elif _CONTROLLER_MARK in result.blow_up:
            counts["controller"] += 1
        else:
            counts["physics"] += 1
    return counts


def main() -> None:
    """Print the blow-up rates for the command-line arguments."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=1000)
    ap.add_argument("--seconds", type=float, default=12.0, help="evaluation time, seconds")
    ap.add_argument("--insertion", type=float, default=3.0, help="settling time, seconds")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--engines", nargs="+", default=["pybullet"], choices=ENGINES)
    args = ap.parse_args()
    n = args.robots
    for engine in args.engines:
        t0 = time.perf_counter()
        c = blow_up_counts(args.robots, args.seconds, args.insertion, args.seed, engine)
        wall = time.perf_counter() - t0
        print(f"{engine}: {n} random robots, seed {args.seed}, {args.insertion:g} s insertion + "
              f"{args.seconds:g} s evaluation, {wall:.0f} s wall")
        for key in ("controller", "physics"):
            print(f"  {key:10s} blow-ups: {c[key]:5d}  ({1000.0 * c[key] / n:.1f} per 1,000)")
        total = c["controller"] + c["physics"]
        print(f"  {'all':10s} blow-ups: {total:5d}  ({1000.0 * total / n:.1f} per 1,000)")


if __name__ == "__main__":
    main()
