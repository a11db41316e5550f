"""The Training Center's generations in one batch: the numbers of one by one, one call each."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import revolve_env.evaluation
from evolution.evaluation import EvalOutcome, EvalTask, evaluate_task
from evolution.learning import CandidateEvaluation, CMAESLearner, RandomSearchLearner
from revolve_env.body.examples import EXAMPLES


def one_by_one(task: EvalTask) -> EvalOutcome:
    """evaluate_task, which the evaluators cannot batch (not the same function)."""
    return evaluate_task(task)


def _learners(function: Any, engine: str) -> tuple[CMAESLearner, RandomSearchLearner]:
    evaluation = CandidateEvaluation(insertion=0.1, seconds=0.25, engine=engine,
                                     function=function)
    return (CMAESLearner(popsize=4, evaluation=evaluation),
            RandomSearchLearner(batch_size=4, evaluation=evaluation))


@pytest.mark.parametrize("engine", ["mujoco", pytest.param("pybullet", marks=pytest.mark.slow)])
def test_a_batched_generation_gives_the_numbers_of_one_by_one(
        engine: str, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip(engine)
    calls: list[int] = []
    many = revolve_env.evaluation.evaluate_many

    def counted(robots: Any, *args: Any, **kwargs: Any) -> Any:
        calls.append(len(robots))
        return many(robots, *args, **kwargs)

    monkeypatch.setattr(revolve_env.evaluation, "evaluate_many", counted)
    robot = EXAMPLES["spider"]()
    budget = 9 * 0.35  # the inborn controller and two generations of four
    for batched, single in zip(_learners(evaluate_task, engine),
                               _learners(one_by_one, engine), strict=True):
        calls.clear()
        a = batched.learn(robot, budget, np.random.default_rng(4))
        generations = list(calls)
        b = single.learn(robot, budget, np.random.default_rng(4))
        assert a.fitness == b.fitness and len(a.fitness) == 9
        assert np.array_equal(a.params, b.params) and a.best_fitness == b.best_fitness
        assert generations[0] == 1 and sum(generations) == 9  # the inborn, then batches
        assert max(generations) > 1
        assert calls[len(generations):] == [1] * 9  # one by one: a robot per call
