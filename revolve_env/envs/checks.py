"""Conformance checks of the envs, as library code (run by the tests, usable on your own robots).

``check_locomotion(robot)`` runs Gymnasium's ``check_env``, stable-baselines3's ``check_env`` (when
it is installed), a two-env determinism rollout and a pickle round trip of the spec-made env.
``registered_ids()`` lists this package's Gymnasium ids, so a check can cover every one of them.
"""

from __future__ import annotations

import pickle
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env

from revolve_env.body.robot import Robot

__all__ = ["check_determinism", "check_locomotion", "registered_ids"]

NAMESPACE = "revolve_env"


def registered_ids() -> list[str]:
    """Every Gymnasium id registered by this package (namespace ``revolve_env``)."""
    return sorted(i for i, spec in gym.registry.items() if spec.namespace == NAMESPACE)


def _rollout(env: gym.Env, seed: int, steps: int) -> tuple[np.ndarray, np.ndarray]:
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    observations, rewards = [obs], []
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        observations.append(obs)
        rewards.append(reward)
        if terminated or truncated:
            break
    return np.asarray(observations), np.asarray(rewards, dtype=np.float64)


def check_determinism(env_id: str, *, seed: int = 0, steps: int = 30, **kwargs: Any) -> None:
    """Two separately made envs given the same seed and actions must agree exactly.

    Raises:
        AssertionError: naming the first step where observations or rewards differ.
    """
    envs = [gym.make(env_id, **kwargs) for _ in range(2)]
    try:
        (obs_a, rew_a), (obs_b, rew_b) = (_rollout(e, seed, steps) for e in envs)
    finally:
        for e in envs:
            e.close()
    if obs_a.shape != obs_b.shape or not np.array_equal(obs_a, obs_b):
        raise AssertionError(f"{env_id}: observations differ between two envs seeded {seed}")
    if not np.array_equal(rew_a, rew_b):
        raise AssertionError(f"{env_id}: rewards differ between two envs seeded {seed}")


def check_locomotion(
    robot: Robot, env_id: str = "revolve_env/Locomotion-v0", *, steps: int = 30, **kwargs: Any
) -> None:
    """All conformance checks of the single-robot env on one robot.

    Args:
        robot: The robot (validated by the env).
        env_id: A registered id of this package.
        steps: Steps of the determinism rollout.
        **kwargs: More keyword arguments for the env (e.g. short ``evaluation_time`` for speed).

    Raises:
        AssertionError or the checkers' own errors, naming what failed.
    """
    kwargs = {"robot": robot, **kwargs}
    env = gym.make(env_id, **kwargs)
    try:
        with warnings.catch_warnings():
            # A headless machine has no window for render_mode="human"; the env warns and draws
            # off screen, which is what the checker's render pass then exercises.
            warnings.filterwarnings("ignore", message="render_mode='human' without a window")
            check_env(env.unwrapped)
            try:
                from stable_baselines3.common.env_checker import check_env as sb3_check_env
            except ImportError:
                pass
            else:
                sb3_check_env(env.unwrapped)
    finally:
        env.close()
    check_determinism(env_id, steps=steps, **kwargs)
    # Vector envs and process pools ship envs by pickling their constructor arguments.
    spec = gym.spec(env_id)
    clone = pickle.loads(pickle.dumps(kwargs))
    if clone["robot"] != robot:
        raise AssertionError(f"{env_id}: the robot does not survive a pickle round trip")
    pickle.loads(pickle.dumps(spec))
