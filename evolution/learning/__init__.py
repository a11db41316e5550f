"""Infancy learning: the Training Center of the Triangle of Life.

* :class:`Learner` / :class:`LearningResult`: the protocol every learner follows (budget in
  simulated seconds, explicit generator).
* :class:`CMAESLearner`, :class:`RandomSearchLearner`: learners over the flat controller
  parameters, candidates evaluated brain-driven in worker processes.
* :class:`SB3Learner`, :class:`PolicyAgent`: any stable-baselines3 algorithm on the infant's
  Gym env, and the adapter that lets the trained policy drive the robot in the population env.
* :class:`TrainingCenter`: a learner + budget + Darwinian/Lamarckian inheritance, usable as the
  lifecycle's infancy hook.

Engine integration. Offline engine: pass ``infancy=center`` to :func:`evolution.run`; the
evaluator calls ``center(robot, rng)`` before the evaluation (a :class:`LearnerError` keeps the
inborn robot and lands in the failures table as kind ``"learner"``). Lamarckian inheritance needs
the engine to take the learned robot back from the worker and give it to the member that
reproduces (``member.robot = center.genome_for_children(inborn, learned)``); the online engine
needs to call the hook at birth, before ``world.add``. :class:`SB3Learner` results drive the
robot through :class:`PolicyAgent` as an agent-controlled robot of the population env.

Importing this package loads neither pybullet nor torch; they load when a learner runs.
"""

from evolution.learning.base import (
    InfancyOutcome,
    Inheritance,
    Learner,
    LearnerError,
    LearningResult,
    TrainingCenter,
    same_body,
)
from evolution.learning.config import (
    LEARNERS,
    load_learning_experiment,
    training_center_from_dict,
)
from evolution.learning.params import (
    CandidateEvaluation,
    CMAESLearner,
    RandomSearchLearner,
    evaluate_in_env,
    evaluate_params,
)
from evolution.learning.sb3 import PolicyAgent, SB3Learner, rollout_fitness

__all__ = [
    "LEARNERS",
    "CMAESLearner",
    "CandidateEvaluation",
    "InfancyOutcome",
    "Inheritance",
    "Learner",
    "LearnerError",
    "LearningResult",
    "PolicyAgent",
    "RandomSearchLearner",
    "SB3Learner",
    "TrainingCenter",
    "evaluate_in_env",
    "evaluate_params",
    "load_learning_experiment",
    "rollout_fitness",
    "same_body",
    "training_center_from_dict",
]
