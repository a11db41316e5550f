"""What an isolated evaluation is: a task (robot, timing, seed), its outcome, and its seeds.

:func:`evaluate_task` is the evaluation of the experiments: the Training Center first (the task's
infancy hook, run by :func:`run_infancy`, which never fails the run), then the robot that lives
on, evaluated alone at the origin (:func:`evaluate_robot`). :func:`evaluate_tasks` is the same
for many tasks at once: the robots that need no hook or policy go side by side through
:func:`revolve_env.evaluate_many` (each in a scene of its own), which pays the per-step work
outside the physics engine once for all; :func:`batched` gives an evaluation function's batch
form, which the evaluators call with their share of the tasks.

Determinism: an evaluation is a pure function of the robot, the timing and its seed, and the seed
is derived from the run's seed and the robot's id (:func:`evaluation_seed`), so results do not
depend on the number of workers, on which worker ran what, or on which robots were evaluated
side by side (a robot's scene is its own: its outcome is bit for bit the one it gets alone).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from functools import partial
from typing import TYPE_CHECKING, Any, Protocol, cast

import numpy as np
from numpy.typing import NDArray

from evolution.lifecycle import InfancyHook, LearningSummary, SummarizingInfancyHook
from revolve_env.body.robot import Robot
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.setting import DEFAULT_ENGINE
from revolve_env.tasks import Locomotion, Task
from revolve_env.terrain import Flat, Terrain

if TYPE_CHECKING:
    from revolve_env.evaluation import EvaluationResult

__all__ = [
    "BatchFunction",
    "DrivingPolicy",
    "EvalOutcome",
    "EvalTask",
    "EvaluateFunction",
    "InfancyReport",
    "LearningSummary",
    "evaluate_after_infancy",
    "batched",
    "evaluate_robot",
    "episode_outcome",
    "evaluate_task",
    "evaluate_tasks",
    "evaluation_seed",
    "infancy_seed",
    "run_infancy",
]


class DrivingPolicy(Protocol):
    """A learned controller that drives a robot (:class:`evolution.learning.PolicyAgent`)."""

    control_period: float
    proprioception: bool  # it also observes hinge angles and velocities (Locomotion-v1's)

    def reset(self) -> None:
        """Start a new episode."""

    def act(self, observation: NDArray[np.float64]) -> NDArray[np.float64]:
        """Normalised hinge targets in [-1, 1] for one observation of the robot's sensors."""


@dataclass(frozen=True, slots=True)
class EvalTask:
    """One isolated evaluation.

    Attributes:
        robot_id: The robot's birth index (for messages).
        robot: The robot (its own network drives it).
        insertion: Settling time before the fitness window. Seconds.
        seconds: Fitness window. Seconds.
        seed: Seed of the evaluation (:func:`evaluation_seed`).
        infancy: Optional Training Center learner applied before the evaluation.
        engine: The physics engine (``"pybullet"`` or ``"mujoco"``).
        policy: A learned policy that drives the robot instead of its network (set by
            :func:`evaluate_after_infancy` after an SB3 infancy).
        conditions: Start heading and jitter, sensor and actuator noise, drawn from ``seed``
            (:class:`~revolve_env.conditions.EvaluationConditions`).
        task: What the robot is scored on (:mod:`revolve_env.tasks`; default the paper's
            :class:`~revolve_env.tasks.Locomotion`).
        terrain: The ground (:mod:`revolve_env.terrain`; default the plane).
    """

    robot_id: int
    robot: Robot
    insertion: float
    seconds: float
    seed: int
    infancy: InfancyHook | None = None
    engine: str = DEFAULT_ENGINE
    policy: DrivingPolicy | None = None
    conditions: EvaluationConditions = IDEAL
    task: Task = Locomotion()
    terrain: Terrain = Flat()


@dataclass(frozen=True, slots=True)
class EvalOutcome:
    """What an evaluation gave.

    Attributes:
        fitness: The task's fitness over the window (``v + 5 s`` by default, metres); ``None``
            when the evaluation failed.
        v: Path length over the window. Metres.
        s: Straight-line displacement over the window. Metres.
        shaking: The path at every control period over ``v``
            (:attr:`revolve_env.EvaluationResult.shaking`); ``None`` when not measured.
        failure: ``None``, or why the robot was lost (e.g. ``"blow-up: ..."``).
        learner_failure: ``None``, or why the infancy hook failed (the robot was then evaluated
            with its inherited brain).
        learned: The robot with the controller the infancy hook gave it, when that differs from
            the inborn one; ``None`` otherwise (no hook, a failed hook, or nothing learned). The
            evaluation measured this robot.
        learning: The learner's own record, when a hook ran and did not fail.
    """

    fitness: float | None
    v: float | None = None
    s: float | None = None
    failure: str | None = None
    learner_failure: str | None = None
    learned: Robot | None = None
    learning: LearningSummary | None = None
    shaking: float | None = None


EvaluateFunction = Callable[[EvalTask], EvalOutcome]
"""A picklable (module-level) function evaluating one task."""

BatchFunction = Callable[[Sequence[EvalTask]], list[EvalOutcome]]
"""A picklable function evaluating many tasks: outcomes in task order."""


def evaluation_seed(run_seed: int, robot_id: int) -> int:
    """The seed of a robot's evaluation: a function of the run's seed and the robot's id only."""
    return int(np.random.SeedSequence([run_seed, robot_id, 0x0E7A1]).generate_state(1)[0])


def infancy_seed(evaluation_seed: int) -> np.random.SeedSequence:
    """The seed of a robot's infancy learning, derived from its evaluation seed.

    Both engines use it, so an infant learns the same way offline and online, and the engine's
    own generator never depends on what a learner draws.
    """
    return np.random.SeedSequence([evaluation_seed, 1])


def evaluate_robot(task: EvalTask) -> EvalOutcome:
    """Evaluate ``task.robot`` alone at the origin with :func:`revolve_env.evaluate`.

    The robot's own network drives it, or ``task.policy`` when set (the same window, seed and
    engine, in the single-robot env with ``controller="agent"``). ``task.infancy`` is ignored
    here (:func:`evaluate_task` runs it first).
    """
    if task.policy is not None:
        return _evaluate_with_policy(task, task.policy)
    # Imported here: it loads the physics engine, which a process that only plans (the CLI, a
    # Ray driver) never needs.
    from revolve_env.evaluation import evaluate

    result = evaluate(task.robot, seconds=task.seconds, insertion=task.insertion, seed=task.seed,
                      engine=task.engine, conditions=task.conditions, task=task.task,
                      terrain=task.terrain)
    return _outcome(result)


def _outcome(result: EvaluationResult) -> EvalOutcome:
    if result.blow_up is not None:
        return EvalOutcome(None, failure=f"blow-up: {result.blow_up}")
    return EvalOutcome(float(result.fitness), float(result.v), float(result.s),
                       shaking=float(result.shaking))


def evaluate_robots(tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
    """:func:`evaluate_robot` of every task, the ones without a policy side by side.

    Tasks of the same engine, timing, conditions, task and terrain go through one
    :func:`revolve_env.evaluate_many`; every outcome is bit for bit the one
    :func:`evaluate_robot` gives the task alone. Outcomes in task order.
    """
    from revolve_env.evaluation import evaluate_many  # the physics: see evaluate_robot

    outcomes: list[EvalOutcome | None] = [None] * len(tasks)
    groups: dict[tuple[str, float, float, EvaluationConditions, Task, Terrain], list[int]] = {}
    for i, task in enumerate(tasks):
        if task.policy is not None:
            outcomes[i] = evaluate_robot(task)
        else:
            key = (task.engine, task.insertion, task.seconds, task.conditions, task.task,
                   task.terrain)
            groups.setdefault(key, []).append(i)
    for (engine, insertion, seconds, conditions, scored, terrain), members in groups.items():
        results = evaluate_many([tasks[i].robot for i in members], seconds=seconds,
                                insertion=insertion, seeds=[tasks[i].seed for i in members],
                                engine=engine, conditions=conditions, task=scored,
                                terrain=terrain)
        for i, result in zip(members, results, strict=True):
            outcomes[i] = _outcome(result)
    return [o for o in outcomes if o is not None]


def _evaluate_with_policy(task: EvalTask, policy: DrivingPolicy) -> EvalOutcome:
    from revolve_env.envs import LocomotionEnv
    from revolve_env.envs.episode import run_episode

    env = LocomotionEnv(task.robot, insertion_time=task.insertion, evaluation_time=task.seconds,
                        fitness_window=task.seconds, control_period=policy.control_period,
                        controller="agent", action="targets", engine=task.engine,
                        conditions=task.conditions, proprioception=policy.proprioception,
                        task=task.task, terrain=task.terrain)
    try:
        policy.reset()
        info = run_episode(env, task.seed, policy.act)
    finally:
        env.close()
    return episode_outcome(info)


def episode_outcome(info: Mapping[str, Any]) -> EvalOutcome:
    """The outcome of a finished env episode, from its last info: fitness, or the blow-up."""
    if info["blow_up"] is not None:
        return EvalOutcome(None, failure=f"blow-up: {info['blow_up']}")
    return EvalOutcome(float(info["fitness"]), float(info["fitness_v"]), float(info["fitness_s"]))


@dataclass(frozen=True, slots=True)
class InfancyReport:
    """One call of an infancy hook (:func:`run_infancy`).

    Attributes:
        robot: The robot that lives on: the learned one, or the inborn one after a failure.
        changed: True when ``robot``'s controller differs from the inborn one.
        failure: ``None``, or the hook's error in one line (the inborn robot was kept).
        learning: The learner's record (``None`` after a failure; without the numbers for a
            plain hook that is not a :class:`~evolution.learning.TrainingCenter`).
    """

    robot: Robot
    changed: bool
    failure: str | None = None
    learning: LearningSummary | None = None


def run_infancy(hook: InfancyHook, robot: Robot, seed: int) -> InfancyReport:
    """Call an infancy hook on a newborn, never raising for a failing learner.

    A hook with ``learn_with_summary`` (:class:`~evolution.lifecycle.SummarizingInfancyHook`,
    e.g. :class:`~evolution.learning.TrainingCenter`) also gives its learner's numbers (inborn
    and learned fitness, evaluations, simulated seconds). Any exception from the hook (a
    :class:`~evolution.learning.LearnerError` or a plain hook's own error) keeps the inborn
    robot and is returned as ``failure``, for the engine to record.

    Args:
        hook: The infancy hook.
        robot: The inborn robot.
        seed: The robot's evaluation seed (:func:`evaluation_seed`); the learner's generator is
            seeded with :func:`infancy_seed`.
    """
    rng = np.random.default_rng(infancy_seed(seed))
    try:
        if isinstance(hook, SummarizingInfancyHook):
            learned, summary = hook.learn_with_summary(robot, rng)
        else:
            learned = hook(robot, rng)
            summary = LearningSummary()
    except Exception as error:  # noqa: BLE001 - a failing learner must not kill the run; recorded
        return InfancyReport(robot, False, f"{type(error).__name__}: {error}")
    return InfancyReport(learned, learned != robot, None, summary)


def evaluate_after_infancy(task: EvalTask, evaluate: EvaluateFunction) -> EvalOutcome:
    """Apply ``task.infancy`` (if any), then ``evaluate`` the robot that lives on.

    ``evaluate`` receives the task with the learned robot and no hook; the outcome carries the
    learned robot (when it changed), the learner's record and any learner failure. This is how
    every evaluation function gets the Training Center: :func:`evaluate_task` is
    ``evaluate_after_infancy(task, evaluate_robot)``.
    """
    if task.infancy is None:
        return evaluate(task)
    report = run_infancy(task.infancy, task.robot, task.seed)
    learned = report.robot if report.changed else None
    policy = None if report.learning is None else report.learning.policy
    outcome = evaluate(replace(task, robot=report.robot, infancy=None,
                               policy=cast("DrivingPolicy | None", policy)))
    return replace(outcome, learner_failure=report.failure, learned=learned,
                   learning=report.learning)


def evaluate_task(task: EvalTask) -> EvalOutcome:
    """The default evaluation: the Training Center, then the robot alone at the origin.

    The Training Center is ``task.infancy`` (if any); the evaluation is
    :func:`revolve_env.evaluate`.
    """
    return evaluate_after_infancy(task, evaluate_robot)


def evaluate_tasks(tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
    """:func:`evaluate_task` of every task, in task order, the plain ones side by side.

    Tasks with an infancy hook go one by one (their learner evaluates its own candidates);
    the others through :func:`evaluate_robots`. Each outcome is the one :func:`evaluate_task`
    gives the task alone, bit for bit.
    """
    outcomes: list[EvalOutcome | None] = [None] * len(tasks)
    plain = [i for i, task in enumerate(tasks) if task.infancy is None]
    for i, task in enumerate(tasks):
        if task.infancy is not None:
            outcomes[i] = evaluate_task(task)
    for i, outcome in zip(plain, evaluate_robots([tasks[i] for i in plain]), strict=True):
        outcomes[i] = outcome
    return [o for o in outcomes if o is not None]


def _one_by_one(function: EvaluateFunction, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
    return [function(task) for task in tasks]


_BATCHED: dict[EvaluateFunction, BatchFunction] = {
    evaluate_task: evaluate_tasks,
    evaluate_robot: evaluate_robots,
}


def batched(function: EvaluateFunction) -> BatchFunction:
    """The batch form of an evaluation function (picklable): outcomes in task order.

    :func:`evaluate_task` and :func:`evaluate_robot` have their own
    (:func:`evaluate_tasks`, :func:`evaluate_robots`); any other function is called task by
    task.
    """
    batch = _BATCHED.get(function)
    return batch if batch is not None else partial(_one_by_one, function)
