"""Locomotion's float window of its one robot against the general TaskWindows: the same episodes.

The env scores its robot with :class:`~revolve_env.rollout.RobotWindow` (floats, no arrays per
step); ``_fast_windows = False`` puts it back on the one-column
:class:`~revolve_env.rollout.TaskWindows`. Every observation, reward, flag and info value of an
episode must be the same bytes on both paths, for every shipped task and a user's.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from numpy.typing import NDArray

import revolve_env.envs  # noqa: F401  (registers the env)
from revolve_env.fitness import Window
from revolve_env.tasks import Locomotion


@dataclass(frozen=True)
class _Doubled(Locomotion):
    """A user's task: not a shipped type, and its own reward (not the gain)."""

    def reward(self, window: Window, fitness: NDArray[np.float64],
               previous: NDArray[np.float64]) -> NDArray[np.float64]:
        return 2.0 * (fitness - previous) + window.s


SHORT = {"insertion_time": 0.25, "evaluation_time": 1.5}
CASES: dict[str, dict[str, Any]] = {
    "locomotion": {},
    "limit": {"task": {"name": "locomotion", "limit": 0.05}},
    "directed": {"task": {"name": "directed-locomotion", "heading": 1.0}},
    "light": {"task": "light-following", "fitness_window": 0.5},
    "every-period": {"task": {"name": "locomotion", "pose_rate": "every-period"},
                     "fitness_window": 0.3},
    "user-task": {"task": _Doubled()},
    "no-insertion-noisy": {"insertion_time": 0.0, "sensor_noise": 0.1, "actuator_noise": 0.1},
    "modulated-brain": {"action": "modulate", "task": "light-following"},
}


def _value(x: object) -> str:
    if isinstance(x, float):
        return x.hex()
    if isinstance(x, np.ndarray):
        return x.tobytes().hex()
    return repr(x)


def _episode(case: str, seed: int, fast: bool) -> str:
    """A hash of the episode's every observation, reward, flags and info, random actions."""
    env = gym.make("revolve_env/Locomotion-v1", **{**SHORT, **CASES[case]})
    env.unwrapped._fast_windows = fast  # type: ignore[attr-defined]
    digest = hashlib.sha256()
    obs, info = env.reset(seed=seed)
    digest.update((_value(obs) + repr(sorted((k, _value(v)) for k, v in info.items()))).encode())
    rng = np.random.default_rng(seed)
    done = False
    while not done:
        action = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        digest.update("".join(_value(x) for x in (obs, reward, terminated, truncated)).encode())
        digest.update(repr(sorted((k, _value(v)) for k, v in info.items())).encode())
        done = terminated or truncated
    env.close()
    return digest.hexdigest()


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_float_window_gives_the_general_paths_episodes(case: str) -> None:
    for seed in (0, 1):
        assert _episode(case, seed, fast=True) == _episode(case, seed, fast=False)


def test_the_float_window_is_the_default_and_a_limit_case_zeroes_some_steps() -> None:
    env = gym.make("revolve_env/Locomotion-v1", **{**SHORT, **CASES["limit"]})
    assert env.unwrapped._fast_windows  # type: ignore[attr-defined]
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    fitness, done = [], False
    while not done:
        _, _, terminated, truncated, info = env.step(
            rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32))
        fitness.append(info["fitness"] == 0.0 and info["fitness_v"] > 0.0)
        done = terminated or truncated
    env.close()
    assert any(fitness) and not all(fitness)  # the limit's branch is taken, and not always


def test_an_infinite_hinge_speed_is_saturated_as_before_not_zeroed() -> None:
    """The one-clip observation falls back to the hinge values' own saturation when a hinge
    value is not finite (the old rule: saturate the hinges, then zero only a non-finite obs)."""
    env = gym.make("revolve_env/Locomotion-v1", **SHORT)
    env.reset(seed=0)
    inner: Any = env.unwrapped
    world = inner._world
    speeds = world.hinge_velocities().copy()
    speeds[0] = np.inf
    world.hinge_velocities = lambda: speeds
    obs = inner._get_obs()
    n, limit = len(speeds), world.config.max_angular_speed
    assert obs[-n] == limit
    assert np.array_equal(obs[-n + 1:], np.clip(speeds[1:], -limit, limit))
    env.close()
