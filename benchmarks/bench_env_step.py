"""Locomotion-v1's step in one process: the compiled step, the general step and raw MuJoCo, in turn.

The spider driven by its brain (``Locomotion-v1``, insertion 0, ``--seconds`` scored), episodes
timed whole (CPU time, microseconds per step), the sides alternating so that they share the
machine's load: the env as ``gym.make`` gives it (the compiled step, one C++ call per step),
the same env's inner step without Gymnasium's layers (``env.unwrapped.step``: what the layers
cost) and through every one of them (no shortcut past them, ``TimeLimitFits``), the env on its
general Python step (``_fast_step = False``: the step before the compiled one) and raw MuJoCo
replaying the same targets on the same model (``bench_engines.Replay``). Prints the best and
the median of each side and their ratios to raw.

Usage: ``python benchmarks/bench_env_step.py [--episodes 9] [--seconds 15]``.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
from bench_engines import Replay

import revolve_env.envs  # noqa: F401  (registers the envs)
from revolve_env import LOCOMOTION_V1_ID
from revolve_env.body.examples import example


def make(seconds: float, fast: bool) -> gym.Env[Any, Any]:
    env = gym.make(LOCOMOTION_V1_ID, robot=example("spider"), controller="brain",
                   insertion_time=0.0, evaluation_time=seconds)
    env.unwrapped._fast_step = fast  # type: ignore[attr-defined]
    return env


def episode(env: gym.Env[Any, Any], step: Callable[[Any], Any] | None = None) -> float:
    """Microseconds of CPU per step of one whole episode (``step``: instead of ``env.step``)."""
    env.reset(seed=0)
    step = env.step if step is None else step
    action = np.zeros(env.action_space.shape or (0,), dtype=np.float32)
    n, done = 0, False
    cpu = time.process_time()
    while not done:
        _, _, terminated, truncated, _ = step(action)
        n += 1
        done = terminated or truncated
    return (time.process_time() - cpu) / n * 1e6


def full_layers(env: gym.Env[Any, Any]) -> float:
    """:func:`episode` through all of ``gym.make``'s layers (no shortcut past them)."""
    layers = env._layers  # type: ignore[attr-defined]
    env._layers = None  # type: ignore[attr-defined]
    try:
        return episode(env)
    finally:
        env._layers = layers  # type: ignore[attr-defined]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--episodes", type=int, default=9)
    parser.add_argument("--seconds", type=float, default=15.0)
    args = parser.parse_args()
    fast, general = make(args.seconds, True), make(args.seconds, False)
    general.reset(seed=0)
    raw = Replay(general.unwrapped._world)  # type: ignore[attr-defined]
    raw.record(general.unwrapped._world)  # type: ignore[attr-defined]
    episode(general)  # the recording run (untimed): the general step calls world.step
    raw.stop(general.unwrapped._world)  # type: ignore[attr-defined]
    periods = len(raw.targets)
    sides: dict[str, Callable[[], float]] = {
        "compiled step (gym.make)": lambda: episode(fast),
        "compiled step, no wrappers": lambda: episode(fast, fast.unwrapped.step),
        "compiled step, every layer": lambda: full_layers(fast),
        "general step (gym.make)": lambda: episode(general),
        "raw mj_step": lambda: raw.run() / periods * 1e6,
    }
    times: dict[str, list[float]] = {k: [] for k in sides}
    for _ in range(args.episodes):
        for name, run in sides.items():
            times[name].append(run())
    raw_best, raw_median = min(times["raw mj_step"]), statistics.median(times["raw mj_step"])
    print(f"Locomotion-v1, the spider's brain, {periods} steps per episode, "
          f"{args.episodes} episodes per side, CPU us per step (replay {raw.same_as(fast.unwrapped._world)}):")  # type: ignore[attr-defined]  # noqa: E501
    for name, values in times.items():
        best, median = min(values), statistics.median(values)
        print(f"  {name:28s} best {best:7.1f}  median {median:7.1f}  "
              f"/ raw {best / raw_best:.2f}x (median {median / raw_median:.2f}x)")
    general_best = min(times["general step (gym.make)"])
    print(f"  the compiled step is {general_best / min(times['compiled step (gym.make)']):.2f}x "
          "faster per step than the general one (best)")
    fast.close()
    general.close()


if __name__ == "__main__":
    main()
