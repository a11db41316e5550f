"""Seeds that matter: the envs' start noise on the hinges (Gymnasium's ``reset_noise_scale``).

Locomotion-v1 and the population env perturb every active hinge's start by default, from the
reset seed; ``evaluate`` and the experiments keep the paper's start (their numbers do not move).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import revolve_env
from revolve_env import evaluate
from revolve_env.body.examples import gecko, spider
from revolve_env.conditions import (
    DEFAULT_RESET_NOISE_SCALE,
    IDEAL,
    EvaluationConditions,
)
from revolve_env.envs import LocomotionEnv
from revolve_env.envs.episode import run_episode
from revolve_env.envs.population import ONLINE_CONDITIONS, population_env
from revolve_env.evaluation import start_generator

SHORT = {"insertion_time": 0.25, "evaluation_time": 0.5}
N_SENSORS = 6  # the spider's: the core's IMU


def _episode(env: gym.Env[Any, Any], seed: int) -> tuple[np.ndarray, np.ndarray, float]:
    """First observation, the observations of 30 steps of a fixed action, and the return."""
    first, _ = env.reset(seed=seed)
    action = np.full(env.action_space.shape, 0.3, np.float32)
    rows, total = [], 0.0
    for _ in range(30):
        obs, reward, *_ = env.step(action)
        rows.append(obs)
        total += float(reward)
    return first, np.array(rows), total


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_seeds_change_locomotion_v1_episodes_and_a_seed_repeats_its_own(engine: str) -> None:
    env = gym.make("revolve_env/Locomotion-v1", engine=engine, **SHORT)
    a0, b0, c0 = _episode(env, 0)
    a1, b1, _ = _episode(env, 1)
    again = _episode(env, 0)
    env.close()
    assert not np.array_equal(a0, a1) and not np.array_equal(b0, b1)
    assert np.array_equal(a0, again[0]) and np.array_equal(b0, again[1]) and c0 == again[2]
    # The first observation shows the drawn start: angles, then speeds, of the 8 hinges.
    g = start_generator(0)
    IDEAL.start(g)  # heading 0, no jitter: draws nothing
    angles = g.uniform(-DEFAULT_RESET_NOISE_SCALE, DEFAULT_RESET_NOISE_SCALE, 8)
    speeds = g.uniform(-DEFAULT_RESET_NOISE_SCALE, DEFAULT_RESET_NOISE_SCALE, 8)
    assert np.allclose(a0[N_SENSORS:N_SENSORS + 8], angles, atol=1e-6)
    assert np.allclose(a0[N_SENSORS + 8:], speeds, atol=1e-6)


def test_reset_noise_scale_zero_gives_the_start_at_rest_whatever_the_seed() -> None:
    env = gym.make("revolve_env/Locomotion-v1", reset_noise_scale=0.0, **SHORT)
    (a0, b0, c0), (a1, b1, c1) = _episode(env, 0), _episode(env, 1)
    env.close()
    assert np.array_equal(a0, a1) and np.array_equal(b0, b1) and c0 == c1
    assert not a0[N_SENSORS:].any()  # every hinge at 0, at rest


def test_given_conditions_keep_their_own_start_noise_and_the_keyword_wins() -> None:
    assert LocomotionEnv(spider()).reset_noise_scale == DEFAULT_RESET_NOISE_SCALE
    assert LocomotionEnv(spider(), conditions=IDEAL).reset_noise_scale == 0.0
    assert LocomotionEnv(spider(), sensor_noise=0.1).reset_noise_scale == DEFAULT_RESET_NOISE_SCALE
    noisy = EvaluationConditions(reset_noise_scale=0.05)
    assert LocomotionEnv(spider(), conditions=noisy).reset_noise_scale == 0.05
    assert LocomotionEnv(spider(), conditions=noisy, reset_noise_scale=0.0).reset_noise_scale == 0
    with pytest.raises(ValueError, match="reset_noise_scale"):
        LocomotionEnv(spider(), reset_noise_scale=-0.1)
    with pytest.raises(ValueError, match="reset_noise_scale"):
        LocomotionEnv(spider(), reset_noise_scale=2.0)


def test_evaluate_is_unchanged_and_the_env_matches_it_under_the_same_conditions() -> None:
    """evaluate keeps the paper's start (no draw: the seed changes nothing without noise); the
    env driven by the brain gives its numbers bit for bit under the same conditions, noise on
    the hinges included."""
    robot = gecko()
    plain = [evaluate(robot, seconds=0.5, insertion=0.25, seed=s).fitness for s in (0, 1)]
    assert plain[0] == plain[1]
    env = LocomotionEnv(robot, controller="brain", conditions=IDEAL, **SHORT)
    assert run_episode(env, 0)["fitness"] == plain[0]
    noisy = EvaluationConditions(reset_noise_scale=DEFAULT_RESET_NOISE_SCALE)
    shaken = evaluate(robot, seconds=0.5, insertion=0.25, seed=0, conditions=noisy).fitness
    default_env = LocomotionEnv(robot, controller="brain", **SHORT)  # the env's default noise
    assert run_episode(default_env, 0)["fitness"] == shaken != plain[0]
    env.close()
    default_env.close()


def test_the_population_env_perturbs_newborns_by_default_and_not_under_given_conditions() -> None:
    def start(seed: int, **kwargs: Any) -> np.ndarray:
        env = population_env(space_mode="uniform", proprioception=True, max_births=4, **kwargs)
        obs, _ = env.reset(seed=seed, options={"robots": [{"robot": spider(),
                                                            "controlled_by": "agent"}]})
        env.close()
        return np.asarray(obs["robot_0"][10:18])  # 10 sensor entries, then the hinge angles

    s0, s1 = start(0), start(1)
    assert not np.array_equal(s0, s1) and np.array_equal(s0, start(0))
    assert 0 < np.abs(s0).max() <= DEFAULT_RESET_NOISE_SCALE
    for kwargs in ({"conditions": ONLINE_CONDITIONS}, {"reset_noise_scale": 0.0}):
        assert not start(0, **kwargs).any() and not start(1, **kwargs).any()


def test_stored_conditions_are_written_as_before() -> None:
    assert "reset_noise_scale" not in IDEAL.to_dict()
    noisy = EvaluationConditions(reset_noise_scale=0.1)
    assert EvaluationConditions.from_dict(noisy.to_dict()) == noisy
    assert revolve_env.population_env().conditions.reset_noise_scale == DEFAULT_RESET_NOISE_SCALE
