"""Births and deaths in a crowded MuJoCo world: CPU per birth, per death, per cull.

Run: ``python benchmarks/bench_births.py [--robots 30] [--repeats 40] [--engine mujoco]``.

A world of ``--robots`` random robots (:func:`evolution.random_robot.random_robot`, seed 3,
spread 2 m apart) steps; then, ``--repeats`` times: one robot is born (a new random robot), the
world steps one control period, the oldest robot dies, the world steps again. Timed with
``time.process_time`` around each call, best and median over the repeats:

* ``World.add_robot`` (the robot's model, the engine's scene and the survivors' state);
* ``World.remove_robot``; on MuJoCo the scene without the dead robot is compiled when the world
  next needs it (deaths are batched), so the step after a death is timed too, less a plain
  step's time: ``death + its compile`` is what a lone death costs;
* a cull: ``--cull`` robots removed at once, then a step (less a plain step);
* the same at the population env level (``PopulationEnv.add_robot`` / ``remove_robot``, each
  followed by ``env.step``, less a plain env step).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env import population_env
from revolve_env.body.robot import Robot
from revolve_env.world import World, WorldConfig


def robots(n: int, seed: int = 3) -> list[Robot]:
    rng = np.random.default_rng(seed)
    config = EvolutionConfig()
    return [random_robot(rng, config) for _ in range(n)]


def timed(fn: Callable[[], object]) -> float:
    """CPU milliseconds of one call."""
    t = time.process_time()
    fn()
    return (time.process_time() - t) * 1e3


def spot(i: int) -> tuple[float, float]:
    return (2.0 * (i % 8), 2.0 * (i // 8))


def world_level(engine: str, n: int, repeats: int, cull: int) -> dict[str, list[float]]:
    pool = robots(n + repeats + cull)
    out: dict[str, list[float]] = {"birth": [], "death": [], "step": [], "step after death": [],
                                   "cull": []}
    with World(WorldConfig(engine=engine)) as world:
        alive = [world.add_robot(pool[i], position=spot(i)) for i in range(n)]
        world.step(2)
        for k in range(repeats):
            robot, where = pool[n + k], spot(n + k)
            t = time.process_time()
            alive.append(world.add_robot(robot, position=where))
            out["birth"].append((time.process_time() - t) * 1e3)
            out["step"].append(timed(world.step))
            out["death"].append(timed(lambda: world.remove_robot(alive.pop(0))))
            out["step after death"].append(timed(world.step))
        for i in range(cull):
            alive.append(world.add_robot(pool[n + repeats + i], position=spot(n + repeats + i)))
        world.step()
        t = time.process_time()
        for _ in range(cull):
            world.remove_robot(alive.pop(0))
        world.step()
        out["cull"].append((time.process_time() - t) * 1e3)
    return out


def env_level(engine: str, n: int, repeats: int) -> dict[str, list[float]]:
    pool = robots(n + repeats, seed=4)
    env = population_env(engine=engine, initial_robots=pool[:n], max_births=n + repeats,
                         birth_radius=6.0)
    env.reset(seed=0)
    out: dict[str, list[float]] = {"env step": [], "env birth + step": [],
                                   "env death + step": []}
    for k in range(repeats):
        out["env step"].append(timed(lambda: env.step({})))
        t = time.process_time()
        env.add_robot(pool[n + k])
        env.step({})
        out["env birth + step"].append((time.process_time() - t) * 1e3)
        out["env death + step"].append(timed(lambda: (env.remove_robot(env.agents[0]),
                                                      env.step({}))))
    env.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=30)
    ap.add_argument("--repeats", type=int, default=40)
    ap.add_argument("--cull", type=int, default=10, help="robots removed at once")
    ap.add_argument("--engine", default="mujoco")
    args = ap.parse_args()
    w = world_level(args.engine, args.robots, args.repeats, args.cull)
    e = env_level(args.engine, args.robots, args.repeats)
    step = statistics.median(w["step"])
    env_step = statistics.median(e["env step"])
    print(f"{args.engine}, {args.robots} random robots, {args.repeats} births and deaths; "
          "CPU ms (best / median):")

    def show(name: str, values: list[float], less: float = 0.0) -> None:
        v = [x - less for x in values]
        print(f"  {name:34s} {min(v):7.2f} / {statistics.median(v):7.2f}")

    show("World.add_robot", w["birth"])
    show("World.remove_robot", w["death"])
    show("  its compile (next step - a step)", w["step after death"], step)
    show("  death + its compile", [a + b for a, b in zip(w["death"], w["step after death"],
                                                          strict=True)], step)
    show(f"cull of {args.cull} (+ one step - a step)", w["cull"], step)
    show("a plain World.step", w["step"])
    show("env.add_robot + step - a step", e["env birth + step"], env_step)
    show("env.remove_robot + step - a step", e["env death + step"], env_step)
    show("a plain env.step", e["env step"])


if __name__ == "__main__":
    main()
