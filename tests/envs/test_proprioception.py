"""Proprioception: hinge angles and velocities from the world, in Locomotion-v1 and (opt-in) in
the population env; v0 and the robots' own networks are unchanged by it."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import revolve_env.envs  # noqa: F401  (registers the envs)
from revolve_env.body.examples import gecko, snake, spider
from revolve_env.body.robot import Layer
from revolve_env.envs import LOCOMOTION_ID, LOCOMOTION_V1_ID, LocomotionEnv
from revolve_env.envs.observations import HINGE_ANGLE_LIMIT, read_proprio
from revolve_env.envs.population import population_env

SHORT: dict[str, Any] = {"insertion_time": 0.25, "evaluation_time": 0.5}


def _rollout(env: gym.Env, steps: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    obs, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    observations, rewards = [obs], []
    for _ in range(steps):
        action = rng.uniform(-1, 1, env.action_space.shape).astype(np.float32)
        obs, reward, _, _, _ = env.step(action)
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
    space = v1.observation_space
    assert isinstance(space, gym.spaces.Box)
    np.testing.assert_array_equal(space.low[6:14], -math.pi)
    np.testing.assert_array_equal(space.high[14:], 200.0)
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


def test_population_proprioception_is_opt_in_and_leaves_brains_alone() -> None:
    robots = [gecko(), {"robot": snake(3), "controlled_by": "agent"}]

    def run(**kwargs: object) -> tuple[list[dict[str, np.ndarray]], list[dict[str, float]]]:
        env = population_env(initial_robots=robots, **kwargs)
        env.reset(seed=1)
        out_obs, out_rew = [], []
        for k in range(30):
            obs, rew, _, _, _ = env.step({"robot_1": np.full(3, math.sin(k / 5), np.float32)})
            out_obs.append(obs)
            out_rew.append(rew)
        env.close()
        return out_obs, out_rew

    plain_obs, plain_rew = run()
    prop_obs, prop_rew = run(proprioception=True)
    assert prop_rew == plain_rew  # same physics and brains, to the bit
    n_gecko = len(gecko().neurons_of(Layer.OUTPUT))
    for plain, prop in zip(plain_obs, prop_obs, strict=True):
        np.testing.assert_array_equal(prop["robot_0"][:6], plain["robot_0"])
        assert prop["robot_0"].shape == (6 + 2 * n_gecko,)
        assert prop["robot_1"].shape == (6 + 2 * 3,)
    assert np.abs(prop_obs[-1]["robot_1"][6:9]).max() > 0.1  # the driven snake's hinges moved


def test_population_uniform_layout_places_hinge_values_in_their_blocks() -> None:
    env = population_env(initial_robots=[{"robot": snake(3), "controlled_by": "agent"}],
                         space_mode="uniform", proprioception=True)
    env.reset(seed=0)
    for _ in range(30):
        obs, *_ = env.step({"robot_0": np.r_[np.ones(3), np.zeros(7)].astype(np.float32)})
    o = obs["robot_0"]
    assert o.shape == (10 + 10 + 10,)
    np.testing.assert_allclose(o[10:13], math.pi / 4, atol=math.radians(3))  # angles, radians
    assert not o[6:10].any() and not o[13:20].any() and not o[23:].any()  # padding
    mask = env.observation_mask("robot_0")
    np.testing.assert_array_equal(np.flatnonzero(mask), [0, 1, 2, 3, 4, 5, 10, 11, 12, 20, 21, 22])
    assert env.observation_space("robot_0").contains(o)
    assert env.observation_space("robot_0").high[10] == HINGE_ANGLE_LIMIT
    env.close()
