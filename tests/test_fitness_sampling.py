"""The fitness's pose rate, the shaking measure and the paper's fitness limit."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from revolve_env import evaluate, population_env
from revolve_env.body.examples import gecko, spider
from revolve_env.fitness import Window, fitness_terms, trajectory_window
from revolve_env.fitness.sampling import (
    EVERY_PERIOD,
    check_pose_rate,
    pose_due,
    pose_stride,
    shaking,
)
from revolve_env.fitness.terms import pose_path_lengths
from revolve_env.tasks import Locomotion, TaskError, make_task

SHORT = {"insertion": 0.5, "seconds": 2.0}

coordinates = st.floats(-5.0, 5.0, allow_nan=False)
paths = st.integers(0, 40).flatmap(
    lambda t: arrays(np.float64, (t, 3), elements=coordinates))


@settings(max_examples=200, deadline=None)
@given(paths)
def test_a_pose_every_control_period_is_the_fitness_before_pose_rates_bit_for_bit(
        path: np.ndarray) -> None:
    before = fitness_terms(path)  # how every sample counted before pose rates
    for rate in (EVERY_PERIOD, 60, 60.0):
        stride = pose_stride(rate, 1.0 / 60.0)
        assert stride == 1
        w = trajectory_window([path], stride=stride)
        assert (w.v[0], w.s[0]) == (before.v, before.s)
        assert w.samples[0] == len(path)


@settings(max_examples=200, deadline=None)
@given(paths, st.integers(1, 13))
def test_the_window_of_a_pose_rate_is_the_path_at_its_pose_samples(
        path: np.ndarray, stride: int) -> None:
    w = trajectory_window([path], stride=stride, period=0.1)
    poses = path[::stride]
    terms = fitness_terms(poses)
    assert (w.v[0], w.s[0]) == (terms.v, terms.s)
    assert w.samples[0] == len(poses)
    assert w.duration is not None
    assert w.duration[0] == (pytest.approx((len(poses) - 1) * stride * 0.1) if len(poses) > 1
                             else 0.0)
    fine, coarse = pose_path_lengths([path], stride)
    assert coarse[0] == terms.v
    # the path at every row over the same span is never shorter (the triangle inequality)
    assert fine[0] >= coarse[0] - 1e-12
    assert shaking(fine, coarse)[0] >= 1.0 - 1e-12


def test_pose_strides_and_the_rates_that_do_not_fit() -> None:
    assert pose_stride(5, 1 / 60) == 12
    assert pose_stride(5.0, 1 / 40) == 8
    assert pose_stride(EVERY_PERIOD, 1 / 8) == 1
    for rate, period in ((7, 1 / 60), (120, 1 / 60), (5, 1 / 8)):
        with pytest.raises(ValueError, match=r"^pose_rate .* does not fit the control period"):
            pose_stride(rate, period)
    for bad in (0, -5, float("nan"), float("inf"), True, "often", None):
        with pytest.raises(ValueError, match="^pose_rate must be a positive number"):
            check_pose_rate(bad)
    assert pose_due(np.array([-3, 0, 1, 12, 13, 24]), 12).tolist() == [
        False, True, False, True, False, True]
    assert pose_due(np.array([-1, 0, 5]), 1).tolist() == [False, True, True]


def test_bad_pose_rates_are_one_line_errors_everywhere() -> None:
    with pytest.raises(TaskError, match="pose_rate must be a positive number"):
        make_task({"name": "locomotion", "pose_rate": 0})
    with pytest.raises(TaskError, match="pose_rate 7 Hz does not fit"):
        evaluate(spider(), task=Locomotion(pose_rate=7), **SHORT)
    with pytest.raises(TaskError, match="pose_rate 7 Hz does not fit"):
        gym.make("revolve_env/Locomotion-v1", robot=spider(), task=Locomotion(pose_rate=7))
    with pytest.raises(TaskError, match="pose_rate 7 Hz does not fit"):
        population_env(initial_robots=[], task=Locomotion(pose_rate=7)).reset(seed=0)


def test_shaking_of_still_smooth_and_trembling_paths() -> None:
    assert shaking(np.array([0.0, 2.0, 3.0]), np.array([0.0, 2.0, 1.5])).tolist() == [
        1.0, 1.0, 2.0]
    assert shaking(1.0, 0.0).tolist() == np.inf
    # a core that goes back and forth between two points every period, sampled every 2 periods
    t = np.arange(25)
    trembling = np.stack([0.01 * (t % 2), np.zeros(25), np.zeros(25)], axis=1)
    fine, coarse = pose_path_lengths([trembling], 2)
    assert fine[0] == pytest.approx(0.24) and coarse[0] == 0.0
    assert shaking(fine, coarse)[0] == np.inf


def test_evaluate_at_a_pose_rate() -> None:
    every = evaluate(spider(), task=Locomotion(pose_rate=EVERY_PERIOD), **SHORT)
    same = evaluate(spider(), task=Locomotion(pose_rate=60), **SHORT)
    assert (same.fitness, same.v, same.s, same.shaking) == (every.fitness, every.v, every.s, 1.0)
    slow = evaluate(spider(), task=Locomotion(pose_rate=5), **SHORT)
    poses = every.trajectory[::12]
    assert len(poses) == 11  # 2 s at 5 Hz, both ends
    terms = fitness_terms(poses)
    assert (slow.fitness, slow.v, slow.s) == (terms.fitness, terms.v, terms.s)
    assert slow.shaking == pytest.approx(fitness_terms(every.trajectory).v / terms.v)
    assert slow.shaking > 1.0


def test_the_env_rewards_only_at_pose_samples_and_sums_to_evaluate() -> None:
    task = Locomotion(pose_rate=10)
    env = gym.make("revolve_env/Locomotion-v1", robot=gecko(), controller="brain", task=task,
                   insertion_time=0.5, evaluation_time=2.0, reset_noise_scale=0.0)
    env.reset(seed=0)
    rewards = []
    done = False
    while not done:
        _, reward, terminated, truncated, info = env.step(np.zeros(env.action_space.shape))
        rewards.append(float(reward))
        done = terminated or truncated
    env.close()
    steps = np.arange(1, len(rewards) + 1)
    off_pose = (steps < 30) | ((steps - 30) % 6 != 0)
    assert not np.any(np.asarray(rewards)[off_pose])
    assert sum(rewards) == pytest.approx(info["fitness"], abs=1e-12)
    expected = evaluate(gecko(), task=task, **SHORT)
    assert info["fitness"] == pytest.approx(expected.fitness, rel=1e-12, abs=1e-12)


def test_the_population_env_holds_the_pose_between_samples() -> None:
    env = population_env(initial_robots=[], insertion_time=0.5, fitness_window=1.0,
                         task=Locomotion(pose_rate=10))
    env.reset(seed=0)
    a = env.add_robot(gecko(), (0.0, 0.0))
    total = 0.0
    for step in range(1, 121):
        _, rewards, _, _, infos = env.step({})
        total += rewards[a]
        if step < 30 or (step - 30) % 6:
            assert rewards[a] == 0.0
    info = infos[a]
    assert total == pytest.approx(info["fitness"])
    # the window: the last 1 s of pose samples (every 6th row from the end of insertion)
    poses = info["trajectory"][30::6]
    assert len(poses) == 16
    terms = fitness_terms(poses[-11:])
    assert info["fitness"] == pytest.approx(terms.fitness, rel=1e-12)


def _window(f_v: list[float], duration: list[float]) -> Window:
    n = len(f_v)
    return Window(np.zeros((n, 2)), np.zeros((n, 2)), np.asarray(f_v), np.zeros(n),
                  np.full(n, 61, dtype=np.int64), duration=np.asarray(duration))


def test_the_fitness_limit_is_the_papers_speed() -> None:
    # 1 m/s over 12 s: 12 m and more are an instability
    task = Locomotion(limit=1.0)
    f = task.fitness(_window([11.9, 12.0, 30.0, 3.0], [12.0, 12.0, 12.0, 2.0]))
    assert f.tolist() == [11.9, 0.0, 0.0, 0.0]
    assert Locomotion().fitness(_window([30.0], [12.0])).tolist() == [30.0]
    assert task.to_dict()["limit"] == 1.0 and "limit" not in Locomotion().to_dict()
    assert make_task(task.to_dict()) == task
    for bad in (0, -1.0, float("inf"), "1"):
        with pytest.raises(TaskError, match="^task 'locomotion': limit .*must be"):
            make_task({"name": "locomotion", "limit": bad})
    spider_f = evaluate(spider(), **SHORT).fitness  # about 1.5 m in 2 s: 0.76 m/s
    assert evaluate(spider(), task=Locomotion(limit=1.0), **SHORT).fitness == spider_f
    assert evaluate(spider(), task=Locomotion(limit=0.5), **SHORT).fitness == 0.0
