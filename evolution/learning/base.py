"""The Training Center's contract: the :class:`Learner` protocol, its result, and the infancy hook.

A learner improves the controller of a newborn robot during infancy, within a *budget* of
**simulated seconds**: every second the learner simulates (a candidate's insertion and
evaluation, or the environment steps a reinforcement learner trains on) is charged to it, and
infancy ends when the budget is spent. Learners that count environment steps convert with
``steps = budget / control_period``.

:class:`TrainingCenter` turns a learner into the lifecycle's infancy hook
(:data:`evolution.lifecycle.InfancyHook`: ``hook(robot, rng) -> robot``) and carries the
inheritance option: **Darwinian** (children inherit the inborn genome) or **Lamarckian** (the
learned controller parameters are written back into the genome the robot passes to its
children).

Bad learners: a learner that raises, or returns non-finite or ill-shaped parameters, or a robot
with another body, makes the hook raise :class:`LearnerError`; the engine catches it, keeps the
inborn controller and records the failure in the store's failures table (kind ``"learner"``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from evolution.lifecycle import LearningSummary
from revolve_env.body.robot import Robot

__all__ = [
    "InfancyOutcome",
    "Inheritance",
    "Learner",
    "LearnerError",
    "LearningResult",
    "RobotPolicy",
    "TrainingCenter",
    "check_budget",
    "same_body",
]


class RobotPolicy(Protocol):
    """A controller learned outside the genome (e.g. :class:`~evolution.learning.PolicyAgent`)."""

    def reset(self) -> None:
        """Start a new episode."""

    def act(self, observation: NDArray[np.float64]) -> NDArray[np.float64]:
        """Normalised hinge targets in [-1, 1] for one observation of the robot's sensors."""


Inheritance = Literal["darwinian", "lamarckian"]
"""What a robot passes to its children: its inborn genome, or the genome with learned params."""


class LearnerError(RuntimeError):
    """A learner failed (raised, or gave unusable parameters); the inborn controller is kept."""


@dataclass(frozen=True, slots=True, eq=False)
class LearningResult:
    """What a learner gives back.

    Attributes:
        robot: The robot with the learned controller (same body as the infant). For learners
            that do not change the network (an SB3 policy), the inborn robot.
        params: The learned flat controller parameters of ``robot``
            (layout: :mod:`revolve_env.brain.spec`).
        fitness: Fitness ``v + 5 s`` of every evaluation (or every finished training episode),
            in the order they happened; the first is the inborn controller's when the learner
            evaluates it. Metres.
        inborn_fitness: Fitness of the inborn controller. Metres.
        best_fitness: Fitness of the returned controller (as measured by the learner). Metres.
        evaluations: Evaluations (or training episodes) the learner ran.
        sim_seconds: Simulated seconds the learner used (at most the budget). Seconds.
        failures: Evaluations that failed (blow-ups; scored 0).
        policy: The trained policy, for learners whose controller is not the network (SB3).
    """

    robot: Robot
    params: np.ndarray
    fitness: tuple[float, ...]
    inborn_fitness: float
    best_fitness: float
    evaluations: int
    sim_seconds: float
    failures: int = 0
    policy: RobotPolicy | None = None

    @property
    def best_so_far(self) -> np.ndarray:
        """Running maximum of :attr:`fitness` (the learning curve). Metres."""
        f = np.asarray(self.fitness, dtype=np.float64)
        return np.maximum.accumulate(f) if f.size else f

    @property
    def improvement(self) -> float:
        """``best_fitness - inborn_fitness``. Metres."""
        return self.best_fitness - self.inborn_fitness


@runtime_checkable
class Learner(Protocol):
    """Anything that improves a robot's controller within a budget of simulated seconds."""

    def learn(self, robot: Robot, budget: float, rng: np.random.Generator) -> LearningResult:
        """Learn a controller for ``robot``.

        Args:
            robot: The infant (a valid robot with a network).
            budget: Simulated seconds the learner may spend. Seconds.
            rng: The only source of randomness: the same generator state gives the same result.
        """
        ...


def check_budget(budget: float) -> float:
    """``budget`` as a float, or ValueError when it is not a positive finite number of seconds."""
    if isinstance(budget, bool) or not isinstance(budget, (int, float)) or not (
        math.isfinite(budget) and budget > 0
    ):
        raise ValueError(
            f"budget must be a positive finite number of simulated seconds, got {budget!r}"
        )
    return float(budget)


def same_body(a: Robot, b: Robot) -> bool:
    """True when ``a`` and ``b`` have the same body and network structure.

    The same parts in the same places, and the same neuron ids, activations and connections,
    whatever the parameter values.
    """

    def shape(robot: Robot) -> list[tuple[object, ...]]:
        return [
            (path, node.type, node.orientation, node.params,
             tuple((nr.id, nr.layer, nr.activation) for nr in node.neurons))
            for path, node in robot.walk()
        ] + [(c.src, c.dst) for c in robot.connections]

    return shape(a) == shape(b)


@dataclass(frozen=True, slots=True)
class InfancyOutcome:
    """One infancy in the Training Center.

    Attributes:
        robot: The robot that lives its maturity (learned controller, or the inborn one after a
            failure).
        genome: The robot the infant passes to its children: ``robot`` when Lamarckian, the
            inborn robot when Darwinian (or after a failure).
        result: The learner's result; ``None`` after a failure.
        failure: ``None``, or why learning failed (the inborn controller was kept).
    """

    robot: Robot
    genome: Robot
    result: LearningResult | None
    failure: str | None = None


@dataclass(frozen=True, slots=True)
class TrainingCenter:
    """A learner, its budget and the inheritance rule: the lifecycle's infancy hook.

    Call it as the hook (``center(robot, rng) -> robot``, raising :class:`LearnerError` on a
    failed learner so that the engine records it), or use :meth:`infancy` for the full outcome.

    Attributes:
        learner: The learner (picklable: the engine sends it to worker processes).
        budget: Simulated seconds of learning per infant. Seconds.
        inheritance: ``"darwinian"`` (default) or ``"lamarckian"``.
    """

    learner: Learner
    budget: float
    inheritance: Inheritance = "darwinian"

    def __post_init__(self) -> None:
        check_budget(self.budget)
        if self.inheritance not in ("darwinian", "lamarckian"):
            raise ValueError(
                f"inheritance must be 'darwinian' or 'lamarckian', got {self.inheritance!r}"
            )
        if not isinstance(self.learner, Learner):
            raise TypeError(
                f"learner must have a learn(robot, budget, rng) method, got {self.learner!r}"
            )
        minimum = getattr(self.learner, "min_budget", None)
        if isinstance(minimum, float) and self.budget < minimum - 1e-9:
            # Otherwise every infant would pay for evaluations and learn nothing, silently.
            raise ValueError(
                f"a budget of {self.budget:g} s is too small for one learning step of "
                f"{type(self.learner).__name__}: it needs at least {minimum:g} s"
            )
        if self.lamarckian and getattr(self.learner, "learns_policy", False):
            raise ValueError(
                f"{type(self.learner).__name__} learns a policy outside the genome: it has no "
                "parameters to write back, so it cannot be Lamarckian"
            )

    @property
    def lamarckian(self) -> bool:
        """True when learned parameters are written back into the genome children inherit."""
        return self.inheritance == "lamarckian"

    def run_learner(self, robot: Robot, rng: np.random.Generator) -> LearningResult:
        """Run the learner and check its result.

        Raises:
            LearnerError: the learner raised, or its result is unusable (non-finite or
                ill-shaped params, another body, params that do not match the robot).
        """
        from revolve_env.brain import get_params, set_params

        try:
            result = self.learner.learn(robot, self.budget, rng)
        except Exception as error:
            raise LearnerError(
                f"{type(self.learner).__name__} raised {type(error).__name__}: {error}"
            ) from error
        if not isinstance(result, LearningResult):
            raise LearnerError(f"{type(self.learner).__name__} returned {type(result).__name__}, "
                               "not a LearningResult")
        params = np.asarray(result.params, dtype=np.float64)
        n = get_params(robot).shape[0]
        if params.shape != (n,):
            raise LearnerError(f"learned params have shape {params.shape}, the robot has {n}")
        if not np.isfinite(params).all():
            k = int(np.argmax(~np.isfinite(params)))
            raise LearnerError(f"learned params[{k}] is {params[k]}")
        if not same_body(robot, result.robot):
            raise LearnerError(
                "the learner returned a robot with another body or network structure"
            )
        try:
            learned = set_params(robot, params)
        except ValueError as error:
            raise LearnerError(f"learned params are invalid: {error}") from error
        if not np.array_equal(get_params(result.robot), get_params(learned)):
            raise LearnerError("the learner's robot does not carry its learned params")
        return result

    def infancy(self, robot: Robot, rng: np.random.Generator) -> InfancyOutcome:
        """Learn, never raising for a bad learner: the failure is returned instead."""
        try:
            result = self.run_learner(robot, rng)
        except LearnerError as error:
            return InfancyOutcome(robot, robot, None, str(error))
        return InfancyOutcome(result.robot, self.genome_for_children(robot, result.robot), result)

    def learn_with_summary(self, robot: Robot,
                           rng: np.random.Generator) -> tuple[Robot, LearningSummary]:
        """The infancy hook with the learner's numbers, for the engine's learning records.

        Raises:
            LearnerError: learning failed; the caller keeps the inborn robot and records it.
        """
        result = self.run_learner(robot, rng)
        return result.robot, LearningSummary(
            _float_or_none(result.inborn_fitness), _float_or_none(result.best_fitness),
            int(result.evaluations), float(result.sim_seconds), int(result.failures),
            result.policy)

    def genome_for_children(self, inborn: Robot, learned: Robot) -> Robot:
        """The genome a robot passes on: ``learned`` (Lamarckian) or ``inborn`` (Darwinian)."""
        return learned if self.lamarckian else inborn

    def __call__(self, robot: Robot, rng: np.random.Generator) -> Robot:
        """The infancy hook: the robot with its learned controller.

        Raises:
            LearnerError: learning failed; the caller keeps the inborn robot and records it.
        """
        return self.run_learner(robot, rng).robot


def _float_or_none(value: float | None) -> float | None:
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None
