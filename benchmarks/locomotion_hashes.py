"""Hashes of whole Locomotion-v0/-v1 episodes: what a change of the env's step must not move.

Every observation, reward, flag and info value of every step of two episodes (seeds 0 and 1, in
one env: the second starts from a reset world) goes into one SHA-256 per configuration. Run it
before and after a change and compare the lines: a refactor of the step leaves every one as it
was. The configurations are the env's kinds of steps: the agent's targets and the robot's brain,
every shipped task (with a fitness limit, a heading, the light), a pose every period, a short
window, a user's task with its own reward, noise, modulation, Locomotion-v0, a robot with touch
and light sensors, and blow-ups (a low speed limit).

Usage: ``python benchmarks/locomotion_hashes.py [--only NAME ...] [--path general]`` (``general``:
the env's general Python step, ``LocomotionEnv._fast_step = False``; default: as shipped).
"""

from __future__ import annotations

import argparse
import hashlib
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

import revolve_env.envs  # noqa: F401  (registers the envs)
from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env import LOCOMOTION_ID, LOCOMOTION_V1_ID
from revolve_env.body.robot import Robot
from revolve_env.fitness import Window
from revolve_env.tasks import Locomotion
from revolve_env.world import WorldConfig


@dataclass(frozen=True)
class Doubled(Locomotion):
    """A user's task: not a shipped type, and its own reward (not the gain)."""

    def reward(self, window: Window, fitness: NDArray[np.float64],
               previous: NDArray[np.float64]) -> NDArray[np.float64]:
        return 2.0 * (fitness - previous) + window.s


def sensor_robot() -> Robot:
    """A random robot with a touch sensor and light sensors on its core and a moving link."""
    rng = np.random.default_rng(7)
    return [random_robot(rng, EvolutionConfig()) for _ in range(6)][4]


SHORT = {"insertion_time": 0.25, "evaluation_time": 1.5}
BLOWS = {"world_config": WorldConfig(max_linear_speed=0.4)}
CASES: dict[str, tuple[str, dict[str, Any]]] = {
    "default": (LOCOMOTION_V1_ID, {}),
    "brain": (LOCOMOTION_V1_ID, {"controller": "brain"}),
    "limit": (LOCOMOTION_V1_ID, {"task": {"name": "locomotion", "limit": 0.05}}),
    "directed": (LOCOMOTION_V1_ID, {"task": {"name": "directed-locomotion", "heading": 1.0}}),
    "light": (LOCOMOTION_V1_ID, {"task": "light-following", "fitness_window": 0.5}),
    "every-period": (LOCOMOTION_V1_ID, {"task": {"name": "locomotion",
                                                 "pose_rate": "every-period"},
                                        "fitness_window": 0.3}),
    "window-1s": (LOCOMOTION_V1_ID, {"fitness_window": 1.0}),
    "user-task": (LOCOMOTION_V1_ID, {"task": Doubled()}),
    "no-insertion-noisy": (LOCOMOTION_V1_ID, {"insertion_time": 0.0, "sensor_noise": 0.1,
                                              "actuator_noise": 0.1}),
    "no-insertion": (LOCOMOTION_V1_ID, {"insertion_time": 0.0, "controller": "brain"}),
    "v0-brain": (LOCOMOTION_ID, {"controller": "brain"}),
    "v0-agent": (LOCOMOTION_ID, {}),
    "modulated-brain": (LOCOMOTION_V1_ID, {"action": "modulate", "task": "light-following"}),
    "sensors-light-brain": (LOCOMOTION_V1_ID, {"robot": "sensors", "controller": "brain",
                                               "task": "light-following"}),
    "sensors-agent": (LOCOMOTION_V1_ID, {"robot": "sensors"}),
    "blow-up-brain": (LOCOMOTION_V1_ID, {"robot": "sensors", "controller": "brain", **BLOWS}),
    "blow-up-agent": (LOCOMOTION_V1_ID, {"robot": "sensors", **BLOWS}),
    "full-brain": (LOCOMOTION_V1_ID, {"controller": "brain", "insertion_time": None,
                                      "evaluation_time": None}),
}


def value(x: object) -> str:
    """``x`` as its exact bits (floats in hex, arrays as their bytes)."""
    if isinstance(x, float):
        return x.hex()
    if isinstance(x, np.ndarray):
        return x.dtype.str + str(x.shape) + x.tobytes().hex()
    return repr(x)


def make(case: str) -> gym.Env[Any, Any]:
    env_id, kwargs = CASES[case]
    kwargs = {**SHORT, **kwargs}
    kwargs = {k: v for k, v in kwargs.items() if v is not None}
    if kwargs.get("robot") == "sensors":
        kwargs["robot"] = sensor_robot()
    return gym.make(env_id, **kwargs)


def episodes(case: str, fast: bool = True, seeds: tuple[int, ...] = (0, 1)) -> tuple[str, int]:
    """The hash of ``case``'s episodes (random actions) and how many ended in a blow-up."""
    env = make(case)
    env.unwrapped._fast_step = fast  # type: ignore[attr-defined]
    digest = hashlib.sha256()
    blown = 0
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        digest.update((value(obs) + repr(sorted((k, value(v)) for k, v in info.items())))
                      .encode())
        rng = np.random.default_rng(seed)
        done = False
        while not done:
            action = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
            obs, reward, terminated, truncated, info = env.step(action)
            digest.update("".join(value(x) for x in (obs, reward, terminated, truncated))
                          .encode())
            digest.update(repr(sorted((k, value(v)) for k, v in info.items())).encode())
            done = terminated or truncated
        blown += bool(terminated)
    env.close()
    return digest.hexdigest(), blown


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", nargs="*", default=sorted(CASES))
    parser.add_argument("--path", choices=("shipped", "general"), default="shipped")
    args = parser.parse_args()
    for case in args.only:
        digest, blown = episodes(case, fast=args.path == "shipped")
        print(f"{case:22s} {digest} blow-ups {blown}", flush=True)


if __name__ == "__main__":
    main()
