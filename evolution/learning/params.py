"""Learners over the flat controller parameter vector: CMA-ES and a random-search baseline.

Both search in *normalised* coordinates, ``x = (p - low) / (high - low)`` in ``[0, 1]`` per
parameter (bounds from :func:`revolve_env.brain.param_bounds`), so one step size fits weights
(-2..2), periods (0.25..4 s) and phases (0..1) alike. Candidates are evaluated with the robot's
own network driving it (:func:`evolution.evaluation.evaluate_task`, i.e.
:func:`revolve_env.evaluate`), in worker processes when ``workers > 1``.

Determinism: every candidate of one learning run is evaluated with the same seed (drawn once from
the learner's generator: common random numbers, so candidates are compared under the same
conditions), the candidates depend only on the generator, and results come back in candidate
order, so the result does not depend on the number of workers.

Budget: each evaluation costs ``insertion + seconds`` simulated seconds; the inborn controller is
evaluated first and is charged too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from evolution.evaluation import (
    EvalOutcome,
    EvalTask,
    EvaluateFunction,
    LocalEvaluator,
    episode_outcome,
    evaluate_task,
)
from evolution.learning.base import LearningResult, check_budget
from revolve_env.body.robot import Robot
from revolve_env.brain import get_params, param_bounds, set_params
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.setting import DEFAULT_ENGINE
from revolve_env.tasks import Locomotion, Task
from revolve_env.terrain import Flat, Terrain

__all__ = [
    "CMAESLearner",
    "CandidateEvaluation",
    "RandomSearchLearner",
    "evaluate_in_env",
    "evaluate_params",
]


def evaluate_in_env(task: EvalTask) -> EvalOutcome:
    """Brain-driven evaluation through ``revolve_env/Locomotion-v0`` (``controller="brain"``).

    Same task and outcome types as :func:`~evolution.evaluation.evaluate_task`; an alternative
    evaluation function for :class:`CandidateEvaluation` that goes through the Gym env (one
    episode: ``task.insertion`` then a ``task.seconds`` fitness window).
    """
    # Imported here: they load the physics engine, which a process that only plans never needs.
    from revolve_env.envs import LocomotionEnv
    from revolve_env.envs.episode import run_episode

    env = LocomotionEnv(task.robot, controller="brain", insertion_time=task.insertion,
                        evaluation_time=task.seconds, fitness_window=task.seconds,
                        engine=task.engine, conditions=task.conditions, task=task.task,
                        terrain=task.terrain)
    try:
        return episode_outcome(run_episode(env, task.seed))
    finally:
        env.close()


@dataclass(frozen=True, slots=True)
class CandidateEvaluation:
    """How a learner scores one candidate controller.

    Attributes:
        insertion: Settling time before the fitness window. Seconds.
        seconds: Fitness window. Seconds.
        workers: Processes evaluating candidates at once (1: in this process).
        function: Picklable ``EvalTask -> EvalOutcome`` (default: brain-driven
            :func:`~evolution.evaluation.evaluate_task`).
        engine: The physics engine of the candidates' evaluations (``"pybullet"``,
            ``"mujoco"``).
        conditions: Start heading and jitter, sensor and actuator noise of every candidate
            evaluation (an experiment's ``[evaluation]`` table). All candidates of one learning
            run share one seed, so they start alike and meet the same noise draws.
        task: What candidates are scored on (:mod:`revolve_env.tasks`; an experiment's task:
            infants learn what they will be selected for).
        terrain: The ground of the candidates' evaluations (:mod:`revolve_env.terrain`; an
            experiment's ``world.terrain``).
    """

    insertion: float = 1.0
    seconds: float = 6.0
    workers: int = 1
    function: EvaluateFunction = field(default=evaluate_task)
    engine: str = DEFAULT_ENGINE
    conditions: EvaluationConditions = IDEAL
    task: Task = Locomotion()
    terrain: Terrain = Flat()

    def __post_init__(self) -> None:
        if not (math.isfinite(self.insertion) and self.insertion >= 0):
            raise ValueError(
                f"insertion must be a finite number of seconds >= 0, got {self.insertion}"
            )
        if not (math.isfinite(self.seconds) and self.seconds > 0):
            raise ValueError(f"seconds must be a positive number of seconds, got {self.seconds}")
        if isinstance(self.workers, bool) or not isinstance(self.workers, int) or self.workers < 1:
            raise ValueError(f"workers must be an integer >= 1, got {self.workers!r}")

    @property
    def cost(self) -> float:
        """Simulated seconds of one evaluation."""
        return self.insertion + self.seconds


def evaluate_params(
    robot: Robot,
    candidates: Sequence[np.ndarray],
    seed: int,
    evaluation: CandidateEvaluation,
    evaluator: LocalEvaluator | None = None,
) -> tuple[np.ndarray, int]:
    """Fitness of ``robot`` with each parameter vector of ``candidates`` (in order).

    A failed evaluation (blow-up) scores 0, the fitness of a robot that does not move.

    Returns:
        The fitness of each candidate (metres) and the number of failed evaluations.
    """
    tasks = [
        EvalTask(i, set_params(robot, p), evaluation.insertion,
                 evaluation.seconds, seed, engine=evaluation.engine,
                 conditions=evaluation.conditions, task=evaluation.task,
                 terrain=evaluation.terrain)
        for i, p in enumerate(candidates)
    ]
    own = evaluator is None
    if evaluator is None:
        evaluator = LocalEvaluator(min(evaluation.workers, max(1, len(tasks))), evaluation.function)
    try:
        outcomes = evaluator.evaluate(tasks)
    finally:
        if own:
            evaluator.close()
    fitness = np.array(
        [o.fitness if o.fitness is not None and math.isfinite(o.fitness) else 0.0
         for o in outcomes],
        dtype=np.float64,
    )
    failures = sum(1 for o in outcomes if o.fitness is None or not math.isfinite(o.fitness))
    return fitness, failures


class _Search:
    """Bookkeeping shared by the learners: normalisation, budget, best-so-far, the record."""

    def __init__(self, robot: Robot, budget: float, rng: np.random.Generator,
                 evaluation: CandidateEvaluation) -> None:
        self.robot = robot
        self.evaluation = evaluation
        self.inborn = get_params(robot)
        bounds = param_bounds(robot)
        self.low, self.high = bounds[:, 0], bounds[:, 1]
        self.span = np.where(self.high > self.low, self.high - self.low, 1.0)
        self.max_evaluations = math.floor(check_budget(budget) / evaluation.cost + 1e-9)
        self.seed = int(rng.integers(0, 2**63 - 1))
        self.fitness: list[float] = []
        self.failures = 0
        self.best_params = self.inborn
        self.best_fitness = -math.inf
        self.evaluator = (LocalEvaluator(evaluation.workers, evaluation.function)
                          if evaluation.workers > 1 else None)

    @property
    def left(self) -> int:
        """Evaluations the budget still pays for."""
        return self.max_evaluations - len(self.fitness)

    def to_unit(self, params: np.ndarray) -> NDArray[np.float64]:
        """Parameters mapped to the unit cube of their ranges (clipped to it)."""
        unit: NDArray[np.float64] = np.clip((params - self.low) / self.span, 0.0, 1.0)
        return unit

    def from_unit(self, x: np.ndarray) -> NDArray[np.float64]:
        """Unit-cube coordinates (clipped to it) mapped back to parameters."""
        params: NDArray[np.float64] = self.low + np.clip(x, 0.0, 1.0) * self.span
        return params

    def evaluate(self, params: Sequence[np.ndarray]) -> np.ndarray:
        """Evaluate candidates (no more than the budget allows), update the best."""
        params = list(params)[: self.left]
        if not params:
            return np.empty(0)
        fitness, failed = evaluate_params(self.robot, params, self.seed, self.evaluation,
                                          self.evaluator)
        self.failures += failed
        for p, f in zip(params, fitness, strict=True):
            self.fitness.append(float(f))
            if f > self.best_fitness:  # strict: ties keep the earlier (the inborn first)
                self.best_fitness, self.best_params = float(f), np.array(p, dtype=np.float64)
        return fitness

    def result(self) -> LearningResult:
        inborn = self.fitness[0] if self.fitness else math.nan
        best = self.best_fitness if self.fitness else math.nan
        return LearningResult(
            robot=set_params(self.robot, self.best_params) if self.fitness else self.robot,
            params=np.array(self.best_params),
            fitness=tuple(self.fitness),
            inborn_fitness=inborn,
            best_fitness=best,
            evaluations=len(self.fitness),
            sim_seconds=len(self.fitness) * self.evaluation.cost,
            failures=self.failures,
        )

    def close(self) -> None:
        if self.evaluator is not None:
            self.evaluator.close()


@dataclass(frozen=True, slots=True)
class CMAESLearner:
    """CMA-ES (the ``cma`` package) on the normalised controller parameters.

    Starts at the inborn parameters; evaluates the inborn controller, then whole generations of
    ``popsize`` candidates while the budget pays for one (the rest of the budget is left unused);
    returns the best controller evaluated, which is the inborn one if nothing beat it.

    Attributes:
        sigma0: Initial step size, as a fraction of each parameter's range.
        popsize: Candidates per generation (``None``: CMA-ES's default ``4 + 3 ln n``).
        evaluation: How candidates are evaluated (timing, workers).
    """

    sigma0: float = 0.15
    popsize: int | None = 8
    evaluation: CandidateEvaluation = field(default_factory=CandidateEvaluation)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.sigma0) and 0 < self.sigma0 <= 1):
            raise ValueError(
                f"sigma0 must be in (0, 1] (a fraction of each range), got {self.sigma0}"
            )
        if self.popsize is not None and (not isinstance(self.popsize, int) or self.popsize < 2):
            raise ValueError(f"popsize must be an integer >= 2 or None, got {self.popsize!r}")

    @property
    def min_budget(self) -> float:
        """Seconds: the inborn evaluation and one generation (``None``: CMA-ES's least, 6).

        Less buys no learning step, so the Training Center refuses it.
        """
        return (1 + (self.popsize or 6)) * self.evaluation.cost

    def learn(self, robot: Robot, budget: float, rng: np.random.Generator) -> LearningResult:
        """Run CMA-ES for ``budget`` simulated seconds (see the class docstring).

        Raises:
            ValueError: a non-positive budget, or a robot without learnable parameters.
        """
        import cma

        search = _Search(robot, budget, rng, self.evaluation)
        try:
            n = search.inborn.shape[0]
            if n == 0:
                raise ValueError("the robot's network has no learnable parameters")
            search.evaluate([search.inborn])
            x0 = search.to_unit(search.inborn)
            # By default cma reseeds NumPy's global generator and samples from it, so anything
            # else drawing from ``np.random`` in this process would change the candidates (and
            # cma would reseed the caller's generator). Give it a private generator instead, the
            # one its ``seed`` option would have made (same candidates); seed NaN: cma then
            # touches no global state.
            private = np.random.RandomState(int(rng.integers(1, 2**31 - 1)))
            options = {
                "bounds": [0.0, 1.0],
                "seed": math.nan,
                "randn": private.randn,
                "verbose": -9,
                "verb_log": 0,
                "verb_disp": 0,
            }
            if self.popsize is not None:
                options["popsize"] = self.popsize
            if n == 1:  # cma refuses one dimension; a second, ignored coordinate makes it work
                x0 = np.append(x0, 0.5)
            es = cma.CMAEvolutionStrategy(x0.tolist(), self.sigma0, options)
            while search.left >= es.popsize and not es.stop():
                solutions = es.ask()  # feasible points (cma's bound handling repairs them)
                fitness = search.evaluate([search.from_unit(np.asarray(x)[:n]) for x in solutions])
                es.tell(solutions, (-fitness).tolist())  # cma minimises
            return search.result()
        finally:
            search.close()


@dataclass(frozen=True, slots=True)
class RandomSearchLearner:
    """Random search around the inborn controller: the baseline for the other learners.

    Evaluates the inborn controller, then independent candidates ``inborn + N(0, sigma^2)`` in
    normalised coordinates (clipped to the bounds), ``batch_size`` at a time, until the budget is
    spent; returns the best (the inborn one if nothing beat it).

    Attributes:
        sigma: Perturbation size, as a fraction of each parameter's range.
        batch_size: Candidates evaluated together (the parallel unit).
        evaluation: How candidates are evaluated (timing, workers).
    """

    sigma: float = 0.15
    batch_size: int = 8
    evaluation: CandidateEvaluation = field(default_factory=CandidateEvaluation)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.sigma) and self.sigma > 0):
            raise ValueError(f"sigma must be a positive fraction of each range, got {self.sigma}")
        if not isinstance(self.batch_size, int) or self.batch_size < 1:
            raise ValueError(f"batch_size must be an integer >= 1, got {self.batch_size!r}")

    @property
    def min_budget(self) -> float:
        """Seconds: the inborn evaluation and one candidate (less buys no learning step)."""
        return 2 * self.evaluation.cost

    def learn(self, robot: Robot, budget: float, rng: np.random.Generator) -> LearningResult:
        """Run random search for ``budget`` simulated seconds (see the class docstring)."""
        search = _Search(robot, budget, rng, self.evaluation)
        try:
            if search.inborn.shape[0] == 0:
                raise ValueError("the robot's network has no learnable parameters")
            search.evaluate([search.inborn])
            x0 = search.to_unit(search.inborn)
            while search.left > 0:
                k = min(self.batch_size, search.left)
                xs = x0 + self.sigma * rng.standard_normal((k, x0.shape[0]))
                search.evaluate([search.from_unit(x) for x in xs])
            return search.result()
        finally:
            search.close()
