"""How much the envs' default start noise on the hinges moves their numbers (issue 31).

Prints, for the spider and the gecko on their own brains in ``LocomotionEnv`` (pybullet, the full
3 s + 12 s episode), the fitness of seeds 0, 1, 2 with ``reset_noise_scale=0`` (the paper's start,
what ``evaluate`` and the experiments keep) and with the env's default (0.1 rad, 0.1 rad/s), and
the population env's summed fitness (one of each example robot, 10 s) for seeds 0 and 1.

Usage::

    python benchmarks/bench_reset_noise.py

Measured 2026-11-27 (pybullet; fitness in metres):

    spider reset_noise_scale=0 [10.1957, 10.1957, 10.1957]   default [10.4138, 9.9844, 10.0379]
    gecko  reset_noise_scale=0 [8.9094, 8.9094, 8.9094]      default [8.9155, 8.9396, 8.9016]
    population, 10 s, summed   reset_noise_scale=0 [18.2096, 18.4068]   default [19.2089, 18.1996]
"""

from __future__ import annotations

from typing import Any

from revolve_env.body.examples import example
from revolve_env.envs import LocomotionEnv
from revolve_env.envs.episode import run_episode
from revolve_env.envs.population import population_env

SETTINGS: tuple[dict[str, Any], ...] = ({"reset_noise_scale": 0.0}, {})


def main() -> None:
    for name in ("spider", "gecko"):
        for kwargs in SETTINGS:
            env = LocomotionEnv(example(name), controller="brain", engine="pybullet", **kwargs)
            fitness = [round(run_episode(env, seed)["fitness"], 4) for seed in (0, 1, 2)]
            env.close()
            print(name, kwargs or "default 0.1", fitness)
    for kwargs in SETTINGS:
        pop = population_env(max_cycles=600, engine="pybullet", **kwargs)
        totals = []
        for seed in (0, 1):
            pop.reset(seed=seed)
            for _ in range(600):
                pop.step({})
            totals.append(round(sum(s.fitness for s in pop.statuses.values()), 4))
        pop.close()
        print("population (5 examples, 10 s) summed fitness", kwargs or "default 0.1", totals)


if __name__ == "__main__":
    main()
