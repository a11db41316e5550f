"""Infancy learning: the Training Center of the Triangle of Life.

* :class:`Learner` / :class:`LearningResult`: the protocol every learner follows (budget in
  simulated seconds, explicit generator).
* :class:`CMAESLearner`, :class:`RandomSearchLearner`: learners over the flat controller
  parameters, candidates evaluated brain-driven in worker processes.
* :class:`SB3Learner`, :class:`PolicyAgent`: any stable-baselines3 algorithm on the infant's
  Gym env, and the adapter that lets the trained policy drive the robot in the population env.
* :class:`TrainingCenter`: a learner + budget + Darwinian/Lamarckian inheritance, usable as the
  lifecycle's infancy hook.

Engine integration (:mod:`evolution.experiments`). Pass ``infancy=center`` to :func:`evolution.run`
(and the same center to :func:`evolution.resume`); both engines use it. Offline, the evaluator
runs the infancy in the worker before the robot's evaluation; online, the engine runs it before
the robot enters the shared world. The Training Center is a separate simulation: it does not
advance the run's clock and a robot still matures ``fertile_age`` seconds after birth. Each
learning lands in the store's ``learning`` table (learned genome, the learner's inborn and learned
fitness, evaluations, simulated seconds); a :class:`LearnerError` (or any error of a hook) keeps
the inborn robot and lands in the failures table as kind ``"learner"``. With
``inheritance="lamarckian"`` the engine reproduces from the learned genome, otherwise from the
inborn one (the ``robots`` table always holds the inborn genome). :class:`SB3Learner` trains a
policy outside the genome (Darwinian only): the engine saves it with the results
(``<results>/policies/run<r>_robot<id>.safetensors``, :func:`save_policy`: numbers and plain
data that load without running code, :mod:`~evolution.learning.policy_file`; referenced from the
learning record's ``policy`` column) and lets it drive the robot: its offline evaluation (same
seed and window, the single-robot env with ``controller="agent"``) or its online life (an
agent-controlled robot of the population env, ``PolicyAgent.act`` on its observation every
control step). A resumed online run reloads the policies from their files (:func:`load_policy`).
A ``budget`` below the learner's ``min_budget`` (one learning step) is refused.

Importing this package loads neither pybullet nor torch; they load when a learner runs.
"""

from evolution.learning.base import (
    InfancyOutcome,
    Inheritance,
    Learner,
    LearnerError,
    LearningResult,
    RobotPolicy,
    TrainingCenter,
    same_body,
)
from evolution.learning.config import LEARNERS, training_center_from_dict
from evolution.learning.params import (
    CandidateEvaluation,
    CMAESLearner,
    RandomSearchLearner,
    evaluate_in_env,
    evaluate_params,
)
from evolution.learning.policy_file import PolicyFileError, load_policy, save_policy
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
    "PolicyFileError",
    "RandomSearchLearner",
    "RobotPolicy",
    "SB3Learner",
    "TrainingCenter",
    "evaluate_in_env",
    "evaluate_params",
    "load_policy",
    "rollout_fitness",
    "same_body",
    "save_policy",
    "training_center_from_dict",
]
