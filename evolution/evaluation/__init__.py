"""Isolated evaluations and where they run: tasks, outcomes, seeds, worker pools.

The layer between the pure evolutionary library and the experiments: the learners
(:mod:`evolution.learning`) evaluate candidate controllers with it, and the offline engine
evaluates whole generations with it.
"""

from __future__ import annotations

from evolution.evaluation.pool import Evaluator, LocalEvaluator, RayEvaluator, make_evaluator
from evolution.evaluation.tasks import (
    EvalOutcome,
    EvalTask,
    EvaluateFunction,
    InfancyReport,
    LearningSummary,
    episode_outcome,
    evaluate_after_infancy,
    evaluate_robot,
    evaluate_task,
    evaluation_seed,
    infancy_seed,
    run_infancy,
)

__all__ = [
    "EvalOutcome",
    "EvalTask",
    "EvaluateFunction",
    "Evaluator",
    "InfancyReport",
    "LearningSummary",
    "LocalEvaluator",
    "RayEvaluator",
    "episode_outcome",
    "evaluate_after_infancy",
    "evaluate_robot",
    "evaluate_task",
    "evaluation_seed",
    "infancy_seed",
    "make_evaluator",
    "run_infancy",
]
