"""The example walkers on every terrain and engine: fitness, and what a terrain costs.

1. ``fitness``: each example robot (its own brain, seed 0, heading 0 at the origin) evaluated
   by ``revolve_env.evaluate`` (3 s insertion + 12 s window) on every shipped terrain (defaults)
   and both engines: the fitness ``v + 5 s`` and the straight displacement ``s`` (metres).
2. ``cost``: the CPU time of that evaluation of the spider on each terrain over the flat plane,
   per engine, best of ``--repeats`` alternating runs (flat, terrain, flat, terrain, ...).

Usage: ``python benchmarks/bench_terrains.py [--only fitness cost] [--repeats 3]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from revolve_env import ENGINES, EXAMPLES, TERRAINS, evaluate, example

SECONDS, INSERTION = 12.0, 3.0


def fitness() -> None:
    """Print the fitness table (one row per engine and robot, one column per terrain)."""
    names = list(TERRAINS)
    print(f"fitness v + 5 s (straight displacement s), metres; {INSERTION:g} s insertion + "
          f"{SECONDS:g} s, seed 0")
    print(f"{'engine':9} {'robot':15} " + " ".join(f"{n:>14}" for n in names))
    for engine in ENGINES:
        for robot in EXAMPLES:
            cells = []
            for terrain in names:
                r = evaluate(example(robot), seconds=SECONDS, insertion=INSERTION,
                             engine=engine, terrain=terrain)
                cell = "blow-up" if r.blow_up else f"{r.fitness:.2f} ({r.s:.2f})"
                cells.append(f"{cell:>14}")
            print(f"{engine:9} {robot:15} " + " ".join(cells), flush=True)


def _cpu(engine: str, terrain: str) -> float:
    start = time.process_time()
    evaluate(example("spider"), seconds=SECONDS, insertion=INSERTION, engine=engine,
             terrain=terrain)
    return time.process_time() - start


def cost(repeats: int) -> None:
    """Print each terrain's evaluation CPU time over the flat plane's, per engine."""
    print(f"CPU time of one evaluation of the spider, best of {repeats}, alternating with flat")
    for engine in ENGINES:
        for terrain in TERRAINS:
            if terrain == "flat":
                continue
            _cpu(engine, terrain)  # the terrain's grid is built once per process: not timed
            flat, other = float("inf"), float("inf")
            for _ in range(repeats):
                flat = min(flat, _cpu(engine, "flat"))
                other = min(other, _cpu(engine, terrain))
            print(f"{engine:9} {terrain:7} {other:6.3f} s vs flat {flat:6.3f} s: "
                  f"x{other / flat:.2f}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="+", choices=["fitness", "cost"],
                        default=["fitness", "cost"])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    if "fitness" in args.only:
        fitness()
    if "cost" in args.only:
        cost(args.repeats)


if __name__ == "__main__":
    main()
