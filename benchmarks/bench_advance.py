"""The population env's step with and without PettingZoo's dicts (issue 28 item 3).

Run: ``python benchmarks/bench_advance.py [--robots N] [--blocks B] [--periods P] [--engine E]``.

Two envs hold the same ``N`` random brain-driven robots (the evolution loop's online world); one
is stepped with :meth:`~revolve_env.envs.population.PopulationEnv.step` (observations, rewards,
terminations, truncations and infos of every agent, every robot's status), the other with
:meth:`~revolve_env.envs.population.PopulationEnv.advance` (the same step; statuses of the lives
that ended only), ``P`` control periods each in turn, ``B`` times (interleaved, so that other load
on the machine falls on both alike). Printed: CPU milliseconds per control period of each, the
share ``advance`` saves, and whether both envs ended with the same robots and fitnesses.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env.envs.population import PopulationEnv


def _env(robots: int, engine: str) -> PopulationEnv:
    rng = np.random.default_rng(1)
    env = PopulationEnv(max_births=robots, initial_robots=(), engine=engine, trajectory_length=0)
    env.reset(seed=0)
    for _ in range(robots):
        env.add_robot(random_robot(rng, EvolutionConfig()))
    return env


def main() -> None:
    """Print the figures for the command-line arguments."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robots", type=int, default=10)
    parser.add_argument("--blocks", type=int, default=10)
    parser.add_argument("--periods", type=int, default=120)
    parser.add_argument("--engine", default="mujoco")
    args = parser.parse_args()
    stepped, advanced = _env(args.robots, args.engine), _env(args.robots, args.engine)
    t_step = t_advance = 0.0
    for _ in range(args.blocks):
        t = time.process_time()
        for _ in range(args.periods):
            stepped.step({})
        t_step += time.process_time() - t
        t = time.process_time()
        for _ in range(args.periods):
            advanced.advance({})
        t_advance += time.process_time() - t
    n = args.blocks * args.periods
    same = stepped.robot_ids == advanced.robot_ids and all(
        stepped.status(r).fitness == advanced.status(r).fitness for r in stepped.robot_ids)
    print(f"{args.engine}, {len(stepped.robot_ids)} robots alive of {args.robots}: "
          f"step {1e3 * t_step / n:.3f} ms, advance {1e3 * t_advance / n:.3f} ms CPU per "
          f"control period; advance saves {100 * (1 - t_advance / t_step):.1f} %; "
          f"same robots and fitnesses: {same}")


if __name__ == "__main__":
    main()
