"""Isolated evaluations and where they run: tasks, outcomes, seeds, worker pools.

The layer between the pure evolutionary library and the experiments: the learners
(:mod:`evolution.learning`) evaluate candidate controllers with it, and the offline engine
evaluates whole generations with it.
"""

from __future__ import annotations

from evolution.evaluation.pool import (
    Evaluator,
    LocalEvaluator,
    RayEvaluator,
    make_evaluator,
    shares,
)
from evolution.evaluation.tasks import (
    BatchFunction,
    EvalOutcome,
    EvalTask,
    EvaluateFunction,
    InfancyReport,
    LearningSummary,
    batched,
    episode_outcome,
    evaluate_after_infancy,
    evaluate_robot,
    evaluate_robots,
    evaluate_task,
    evaluate_tasks,
    evaluation_seed,
    infancy_seed,
    run_infancy,
)

__all__ = [
    "BatchFunction",
    "EvalOutcome",
    "EvalTask",
    "EvaluateFunction",
    "Evaluator",
    "InfancyReport",
    "LearningSummary",
    "LocalEvaluator",
    "RayEvaluator",
    "batched",
    "episode_outcome",
    "evaluate_after_infancy",
    "evaluate_robot",
    "evaluate_robots",
    "evaluate_task",
    "evaluate_tasks",
    "evaluation_seed",
    "infancy_seed",
    "make_evaluator",
    "run_infancy",
    "shares",
]
