"""Proprioception: hinge angles and velocities from the world, in Locomotion-v1 and (opt-in) in
the population env; v0 and the robots' own networks are unchanged by it."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import revolve_env.envs  # noqa: F401  (registers the envs)
from revolve_env.body.examples import spider
from revolve_env.envs import LOCOMOTION_ID, LOCOMOTION_V1_ID, LocomotionEnv
from revolve_env.envs.observations import read_proprio

SHORT = {"insertion_time": 0.25, "evaluation_time": 0.5}


def _rollout(env: gym.Env, steps: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    observations, rewards = [obs], []
    for _ in range(steps):
        obs, reward, _, _, _ = env.step(rng.uniform(-1, 1, env.action_space.shape).astype(np.float32))
        observations.append(obs)
        rewards.append(reward)
    env.close()
    return np.array(observations), np.array(rewards)


@pytest.mark.parametrize("controller", ["agent", "brain"])
def test_v1_is_v0_plus_hinge_angles_and_velocities(controller: str) -> None:
    """Same physics, same rewards to the bit; the extra values are the world's hinge state."""
    v0 = gym.make(LOCOMOTION_ID, robot=spider(), controller=controller, **SHORT)
    v1 = gym.make(LOCOMOTION_V1_ID, robot=spider(), controller=controller, **SHORT)
    assert v0.observation_space.shape == (6,)
    assert v1.observation_space.shape == (6 + 2 * 8,)
    np.testing.assert_array_equal(v1.observation_space.low[6:14], -math.pi)
    np.testing.assert_array_equal(v1.observation_space.high[14:], 200.0)
    obs0, rew0 = _rollout(v0, 40)
    obs1, rew1 = _rollout(v1, 40)
    np.testing.assert_array_equal(obs1[:, :6], obs0)
    np.testing.assert_array_equal(rew1, rew0)  # the brain reads RoboGen's sensors only
    assert np.abs(obs1[1:, 6:14]).max() > 0.1  # the hinges moved
    assert np.abs(obs1[1:, 14:]).max() > 0.5


def test_hinge_angles_are_radians_and_velocities_their_rate() -> None:
    env = LocomotionEnv(spider(), proprioception=True, insertion_time=0.0, evaluation_time=3.0)
    env.reset(seed=0)
    # Hold every hinge at the full target (+1 = 45 degrees): the angles settle at pi/4 radians.
    for _ in range(60):
        obs, *_ = env.step(np.ones(8, dtype=np.float32))
    np.testing.assert_allclose(obs[6:14], math.pi / 4, atol=math.radians(2))
    assert np.abs(obs[14:]).max() < 0.2  # at rest. Rad/s
    world, handle = env._world, env._handle  # the values are the world's own
    assert world is not None
    np.testing.assert_array_equal(obs[6:], read_proprio(world, handle))
    # A sinusoidal drive: the reported velocity is the rate of change of the reported angle.
    angles, speeds = [], []
    dt = env.config.control_period
    for k in range(90):
        target = np.full(8, math.sin(2 * math.pi * k * dt), dtype=np.float32)
        obs, *_ = env.step(target)
        angles.append(obs[6:14])
        speeds.append(obs[14:])
    rate = np.diff(np.array(angles), axis=0) / dt
    mid = (np.array(speeds)[1:] + np.array(speeds)[:-1]) / 2
    assert np.corrcoef(rate.ravel(), mid.ravel())[0, 1] > 0.95
    env.close()


def test_a_blown_up_robot_observes_zeros_within_bounds() -> None:
    from revolve_env.world import WorldConfig

    env = LocomotionEnv(spider(), proprioception=True, insertion_time=0.0, evaluation_time=2.0,
                        controller="brain", world_config=WorldConfig(max_linear_speed=0.05))
    env.reset(seed=0)
    for _ in range(120):
        obs, _, terminated, _, _ = env.step(np.zeros(8, dtype=np.float32))
        if terminated:
            break
    assert terminated
    assert obs.shape == (22,) and not obs.any() and env.observation_space.contains(obs)
    env.close()
