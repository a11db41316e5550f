"""Named timings: the current one, and the paper's system's (8 Hz brains, 1/320 s physics)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from revolve_env import evaluate, evaluate_many, population_env
from revolve_env.body.examples import gecko, spider
from revolve_env.tasks import Locomotion
from revolve_env.world import WorldConfig
from revolve_env.world.config import TIMINGS

PAPER = WorldConfig().with_timing("revolve2018")


def test_the_presets() -> None:
    assert WorldConfig().with_timing("default") == WorldConfig()
    assert WorldConfig().with_timing("revolve-env-2025") == WorldConfig()
    assert WorldConfig().with_timing(None) == WorldConfig()
    assert (PAPER.timestep, PAPER.control_period, PAPER.brain_period) == (1 / 320, 1 / 40, 1 / 8)
    assert (PAPER.substeps, PAPER.brain_stride, PAPER.brain_dt) == (8, 5, 1 / 8)
    assert WorldConfig().brain_stride == 1 and WorldConfig().brain_dt == 1 / 60
    assert set(TIMINGS) == {"default", "revolve-env-2025", "revolve2018"}
    with pytest.raises(ValueError, match="^unknown timing 'gazebo': choose one of default, "):
        WorldConfig().with_timing("gazebo")
    for bad in (1 / 50, 0.0, -1 / 8, float("nan")):
        with pytest.raises(ValueError, match=r"^brain_period .* must be a positive whole multiple"):
            WorldConfig(brain_period=bad)


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_the_spider_walks_with_the_papers_timing(engine: str) -> None:
    result = evaluate(spider(), engine=engine, config=PAPER, task=Locomotion(pose_rate=5))
    assert result.blow_up is None
    assert result.s > 1.0  # metres in 12 s (about 1.6 m with the default timing)
    assert len(result.trajectory) == 12 * 40 + 1  # a row per control period of 1/40 s


def test_brains_step_every_brain_period_and_their_targets_hold() -> None:
    # the hinge targets the brain writes change only at brain steps: every 5th control period
    env = gym.make("revolve_env/Locomotion-v1", robot=gecko(), controller="brain",
                   world_config=PAPER, insertion_time=0.0, evaluation_time=1.0,
                   reset_noise_scale=0.0)  # evaluate's start: hinges at rest
    env.reset(seed=0)
    unwrapped = env.unwrapped
    targets = []
    for _ in range(20):
        env.step(np.zeros(env.action_space.shape))
        targets.append(unwrapped._brain_out.copy())  # type: ignore[attr-defined]
    env.close()
    changed = [k for k in range(1, 20) if not np.array_equal(targets[k], targets[k - 1])]
    assert changed == [5, 10, 15]
    # the env and evaluate drive the robot alike
    single = evaluate(gecko(), config=PAPER, insertion=0.0, seconds=1.0)
    env = gym.make("revolve_env/Locomotion-v1", robot=gecko(), controller="brain",
                   world_config=PAPER, insertion_time=0.0, evaluation_time=1.0,
                   reset_noise_scale=0.0)  # evaluate's start: hinges at rest
    env.reset(seed=0)
    done = False
    while not done:
        _, _, terminated, truncated, info = env.step(np.zeros(env.action_space.shape))
        done = terminated or truncated
    env.close()
    assert info["fitness"] == pytest.approx(single.fitness, rel=1e-12)


def test_evaluate_many_is_evaluate_with_the_papers_timing() -> None:
    robots = [spider(), gecko()]
    many = evaluate_many(robots, config=PAPER, seeds=[0, 1], insertion=0.5, seconds=2.0)
    alone = [evaluate(r, config=PAPER, seed=s, insertion=0.5, seconds=2.0)
             for r, s in zip(robots, [0, 1], strict=True)]
    assert many == alone


def test_the_population_env_refuses_a_brain_period() -> None:
    with pytest.raises(ValueError, match="^brain_period .* is not supported in the population"):
        population_env(initial_robots=[], world_config=PAPER)
