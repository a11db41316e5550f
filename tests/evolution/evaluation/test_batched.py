"""Evaluations side by side: the same outcomes as one by one, whatever the workers and shares."""

from __future__ import annotations

import numpy as np
import pytest
from experiment_fakes import fake_evaluate

from evolution.config import EvolutionConfig
from evolution.evaluation import (
    EvalTask,
    LocalEvaluator,
    batched,
    evaluate_task,
    evaluate_tasks,
    evaluation_seed,
    shares,
)
from evolution.random_robot import random_robot
from revolve_env.body.robot import Robot
from revolve_env.conditions import EvaluationConditions

pytest.importorskip("mujoco", reason="the mujoco package is not installed")


def keep_inborn(robot: Robot, rng: np.random.Generator) -> Robot:
    """An infancy hook that learns nothing (its task goes one by one)."""
    return robot


def _tasks(n: int) -> list[EvalTask]:
    rng = np.random.default_rng(21)
    heading = EvaluationConditions(heading="random")
    tasks = [EvalTask(i, random_robot(rng, EvolutionConfig()), 0.25, 0.5, evaluation_seed(3, i),
                      engine="mujoco", conditions=heading) for i in range(n)]
    tasks[2] = EvalTask(2, tasks[2].robot, 0.25, 0.5, tasks[2].seed, keep_inborn,
                        engine="mujoco", conditions=heading)
    tasks[4] = EvalTask(4, tasks[4].robot, 0.5, 0.25, tasks[4].seed, engine="mujoco")  # timing
    return tasks


def test_a_generation_side_by_side_gives_each_robot_its_own_outcome() -> None:
    tasks = _tasks(9)
    one_by_one = [evaluate_task(t) for t in tasks]
    assert evaluate_tasks(tasks) == one_by_one
    assert batched(evaluate_task) is evaluate_tasks
    with LocalEvaluator(2) as two:
        assert two.evaluate(tasks) == one_by_one
    assert LocalEvaluator(1).evaluate(tasks[::-1]) == one_by_one[::-1]
    assert all(o.fitness is not None for o in one_by_one)


def test_shares_cover_every_task_once_with_about_the_same_parts_each() -> None:
    tasks = _tasks(9)
    for k in (1, 2, 3, 20):
        parts = shares(tasks, k)
        assert sorted(i for part in parts for i in part) == list(range(9))
        assert len(parts) == min(k, 9)
    loads = [sum(tasks[i].robot.num_parts() for i in part) for part in shares(tasks, 2)]
    biggest = max(t.robot.num_parts() for t in tasks)
    assert abs(loads[0] - loads[1]) <= biggest
    assert shares([], 2) == []


def test_any_other_function_is_called_task_by_task() -> None:
    tasks = _tasks(9)[:3]
    assert batched(fake_evaluate)(tasks) == [fake_evaluate(t) for t in tasks]
