"""Hashes of whole single-robot episodes, to the bit: what a change of the env's step must not move.

One home for the episode-hash loop of ``tests/envs/test_locomotion_compiled.py`` (the compiled
step against the general one) and ``benchmarks/locomotion_hashes.py`` (before against after a
change). Every observation, reward, flag and info value of every step goes into one SHA-256.

Usage::

    from episode_hashes import episodes, make, value
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

import revolve_env.envs  # noqa: F401  (registers the envs)
from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env.body.robot import Robot


def sensor_robot() -> Robot:
    """A random robot with a touch sensor and light sensors on its core and a moving link."""
    rng = np.random.default_rng(7)
    return [random_robot(rng, EvolutionConfig()) for _ in range(6)][4]


def value(x: object) -> str:
    """``x`` as its exact bits (floats in hex, arrays as their dtype, shape and bytes)."""
    if isinstance(x, float):
        return x.hex()
    if isinstance(x, np.ndarray):
        return x.dtype.str + str(x.shape) + x.tobytes().hex()
    return repr(x)


def make(env_id: str, kwargs: dict[str, Any], fast: bool = True) -> gym.Env[Any, Any]:
    """``gym.make(env_id, **kwargs)`` on the compiled step (``fast``) or the general one.

    ``"robot": "sensors"`` stands for :func:`sensor_robot`; a ``None`` value leaves that
    keyword at the env's default.
    """
    kwargs = {k: v for k, v in kwargs.items() if v is not None}
    if kwargs.get("robot") == "sensors":
        kwargs["robot"] = sensor_robot()
    env = gym.make(env_id, **kwargs)
    env.unwrapped._fast_step = fast  # type: ignore[attr-defined]
    return env


def episodes(env: gym.Env[Any, Any], seeds: tuple[int, ...] = (0, 1),
             after_reset: Callable[[], None] | None = None) -> tuple[str, int]:
    """The hash of ``env``'s episodes, one a seed (random actions drawn from the seed), and how
    many ended in a blow-up (terminated); ``after_reset`` is called after every reset."""
    digest = hashlib.sha256()
    blown = 0
    for seed in seeds:
        obs, info = env.reset(seed=seed)
        if after_reset is not None:
            after_reset()
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
    return digest.hexdigest(), blown
