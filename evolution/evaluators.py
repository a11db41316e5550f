"""Pluggable evaluators: where offline evaluations and whole runs execute.

An evaluator does two things:

* ``evaluate(tasks)``: evaluate robots in isolation (offline scenarios), results in task order;
* ``run_jobs(fn, jobs, on_event)``: run whole experiment runs side by side.

:class:`LocalEvaluator` uses worker processes on this machine (``forkserver`` start method: a
clean interpreter per worker, no inherited pybullet state). :class:`RayEvaluator` runs the same
work as Ray tasks on a local Ray instance or an existing cluster (``pip install revolve-env[ray]``).

Determinism: an evaluation is a pure function of the robot, the timing and its seed, and the seed
is derived from the run's seed and the robot's id (:func:`evaluation_seed`), so results do not
depend on the number of workers or on which worker ran what.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import queue
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, replace
from typing import Any, Protocol, Self

import numpy as np

from evolution.lifecycle import InfancyHook

__all__ = [
    "EvalOutcome",
    "EvalTask",
    "EvaluateFunction",
    "Evaluator",
    "InfancyReport",
    "LearningSummary",
    "LocalEvaluator",
    "RayEvaluator",
    "evaluate_after_infancy",
    "evaluate_robot",
    "evaluate_task",
    "evaluation_seed",
    "infancy_seed",
    "make_evaluator",
    "run_infancy",
]


@dataclass(frozen=True, slots=True)
class EvalTask:
    """One isolated evaluation.

    Attributes:
        robot_id: The robot's birth index (for messages).
        genome: The robot as JSON.
        insertion: Settling time before the fitness window. Seconds.
        seconds: Fitness window. Seconds.
        seed: Seed of the evaluation (:func:`evaluation_seed`).
        infancy: Optional Training Center learner applied before the evaluation.
    """

    robot_id: int
    genome: str
    insertion: float
    seconds: float
    seed: int
    infancy: InfancyHook | None = None


@dataclass(frozen=True, slots=True)
class LearningSummary:
    """What the Training Center's learner reported for one infant.

    Attributes:
        inborn_fitness: Fitness of the inborn controller as the learner measured it (its own
            candidate evaluation, not the experiment's); ``None`` when unknown (a plain hook).
            Metres.
        learned_fitness: Fitness of the learned controller as the learner measured it; ``None``
            when unknown. Metres.
        evaluations: Evaluations (or training episodes) the learner ran; ``None`` when unknown.
        sim_seconds: Simulated seconds the learner used in its own Training Center simulations;
            ``None`` when unknown. Seconds.
        failures: Learner evaluations that failed (blow-ups).
    """

    inborn_fitness: float | None = None
    learned_fitness: float | None = None
    evaluations: int | None = None
    sim_seconds: float | None = None
    failures: int = 0


@dataclass(frozen=True, slots=True)
class EvalOutcome:
    """What an evaluation gave.

    Attributes:
        fitness: ``v + 5 s`` over the window; ``None`` when the evaluation failed. Metres.
        v: Path length over the window. Metres.
        s: Straight-line displacement over the window. Metres.
        failure: ``None``, or why the robot was lost (e.g. ``"blow-up: ..."``).
        learner_failure: ``None``, or why the infancy hook failed (the robot was then evaluated
            with its inherited brain).
        learned_genome: The robot as JSON with the controller the infancy hook gave it, when
            that differs from the inborn one; ``None`` otherwise (no hook, a failed hook, or
            nothing learned). The evaluation measured this robot.
        learning: The learner's own record, when a hook ran and did not fail.
    """

    fitness: float | None
    v: float | None = None
    s: float | None = None
    failure: str | None = None
    learner_failure: str | None = None
    learned_genome: str | None = None
    learning: LearningSummary | None = None


EvaluateFunction = Callable[[EvalTask], EvalOutcome]
"""A picklable (module-level) function evaluating one task."""


def evaluation_seed(run_seed: int, robot_id: int) -> int:
    """The seed of a robot's evaluation: a function of the run's seed and the robot's id only."""
    return int(np.random.SeedSequence([run_seed, robot_id, 0x0E7A1]).generate_state(1)[0])


def infancy_seed(evaluation_seed: int) -> np.random.SeedSequence:
    """The seed of a robot's infancy learning, derived from its evaluation seed.

    Both engines use it, so an infant learns the same way offline and online, and the engine's
    own generator never depends on what a learner draws.
    """
    return np.random.SeedSequence([evaluation_seed, 1])


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

    robot: Any
    changed: bool
    failure: str | None = None
    learning: LearningSummary | None = None


def run_infancy(hook: InfancyHook, robot: Any, seed: int) -> InfancyReport:
    """Call an infancy hook on a newborn, never raising for a failing learner.

    A :class:`~evolution.learning.TrainingCenter` hook also gives its learner's numbers (inborn
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
    from evolution.learning.base import TrainingCenter

    try:
        if isinstance(hook, TrainingCenter):
            result = hook.run_learner(robot, rng)
            learned = result.robot
            summary = LearningSummary(
                _float_or_none(result.inborn_fitness), _float_or_none(result.best_fitness),
                int(result.evaluations), float(result.sim_seconds), int(result.failures))
        else:
            learned = hook(robot, rng)
            summary = LearningSummary()
    except Exception as error:  # noqa: BLE001 - a failing learner must not kill the run; recorded
        return InfancyReport(robot, False, f"{type(error).__name__}: {error}")
    return InfancyReport(learned, learned != robot, None, summary)


def evaluate_after_infancy(task: EvalTask, evaluate: EvaluateFunction) -> EvalOutcome:
    """Apply ``task.infancy`` (if any), then ``evaluate`` the robot that lives on.

    ``evaluate`` receives the task with the learned genome and no hook; the outcome carries the
    learned genome (when it changed), the learner's record and any learner failure. This is how
    every evaluation function gets the Training Center: :func:`evaluate_task` is
    ``evaluate_after_infancy(task, evaluate_robot)``.
    """
    if task.infancy is None:
        return evaluate(task)
    from revolve_env.body.serialize import from_json, to_json

    report = run_infancy(task.infancy, from_json(task.genome), task.seed)
    learned = to_json(report.robot, indent=None) if report.changed else None
    outcome = evaluate(replace(task, genome=learned or task.genome, infancy=None))
    return replace(outcome, learner_failure=report.failure, learned_genome=learned,
                   learning=report.learning)


def evaluate_robot(task: EvalTask) -> EvalOutcome:
    """Evaluate ``task.genome`` alone at the origin with :func:`revolve_env.evaluate`
    (its own network driving it; ``task.infancy`` is ignored here)."""
    from revolve_env.body.serialize import from_json
    from revolve_env.evaluation import evaluate

    result = evaluate(from_json(task.genome), seconds=task.seconds, insertion=task.insertion,
                      seed=task.seed)
    if result.blow_up is not None:
        return EvalOutcome(None, failure=f"blow-up: {result.blow_up}")
    return EvalOutcome(float(result.fitness), float(result.v), float(result.s))


def evaluate_task(task: EvalTask) -> EvalOutcome:
    """The default evaluation: the Training Center (``task.infancy``, if any), then the robot
    evaluated alone at the origin with :func:`revolve_env.evaluate`."""
    return evaluate_after_infancy(task, evaluate_robot)


def _float_or_none(value: Any) -> float | None:
    if value is None:
        return None
    value = float(value)
    return value if math.isfinite(value) else None


# --------------------------------------------------------------------------------------------


class Evaluator(Protocol):
    """Where evaluations and runs execute."""

    @property
    def workers(self) -> int:
        """Evaluations (or runs) that may execute at once."""

    def evaluate(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """Evaluate the tasks; results in task order."""

    def run_jobs(
        self,
        fn: Callable[..., Any],
        jobs: Sequence[Any],
        on_event: Callable[[Any], None] | None = None,
    ) -> list[Any]:
        """Call ``fn(job, evaluator, emit)`` for every job, side by side where possible.

        ``emit(event)`` forwards a progress event to ``on_event`` in this process. Results are
        returned in job order.
        """

    def close(self) -> None:
        """Release workers."""


def _run_job_in_worker(fn: Callable[..., Any], job: Any, function: EvaluateFunction,
                       events: Any) -> Any:
    """Worker side of :meth:`LocalEvaluator.run_jobs`: one run with in-process evaluation."""
    inner = LocalEvaluator(workers=1, function=function)
    emit = (lambda event: events.put(event)) if events is not None else (lambda event: None)
    return fn(job, inner, emit)


class LocalEvaluator:
    """Worker processes on this machine.

    Args:
        workers: Processes; ``None`` or 0: all cores. 1 evaluates in this process.
        function: The evaluation function (picklable; default :func:`evaluate_task`).
        start_method: ``"forkserver"`` (default where available) or ``"spawn"``.
    """

    def __init__(
        self,
        workers: int | None = None,
        function: EvaluateFunction = evaluate_task,
        start_method: str | None = None,
    ) -> None:
        if workers is not None and workers < 0:
            raise ValueError(f"workers must be >= 0 (0: all cores), got {workers}")
        self._workers = workers or (os.cpu_count() or 1)
        self.function = function
        if start_method is None:
            methods = multiprocessing.get_all_start_methods()
            start_method = "forkserver" if "forkserver" in methods else "spawn"
        if start_method not in ("forkserver", "spawn"):
            raise ValueError(f"start_method must be 'forkserver' or 'spawn', got {start_method!r}")
        self._context = multiprocessing.get_context(start_method)
        self._pool: ProcessPoolExecutor | None = None

    @property
    def workers(self) -> int:
        """Processes used."""
        return self._workers

    def _executor(self) -> ProcessPoolExecutor:
        if self._pool is None:
            self._pool = ProcessPoolExecutor(self._workers, mp_context=self._context)
        return self._pool

    def evaluate(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """Evaluate in worker processes (in this process when ``workers == 1``)."""
        if self._workers == 1 or len(tasks) <= 1:
            return [self.function(task) for task in tasks]
        return list(self._executor().map(self.function, tasks))

    def run_jobs(
        self,
        fn: Callable[..., Any],
        jobs: Sequence[Any],
        on_event: Callable[[Any], None] | None = None,
    ) -> list[Any]:
        """Run jobs; one at a time here (evaluations in parallel) or side by side in processes.

        With a single job, or a single worker, the jobs run in this process one after the other,
        and their evaluations use this evaluator's workers. Otherwise up to ``workers`` jobs run
        side by side, each in its own process evaluating its robots in that process.
        """
        emit = on_event or (lambda event: None)
        if len(jobs) <= 1 or self._workers == 1:
            return [fn(job, self, emit) for job in jobs]
        manager = self._context.Manager()
        events = manager.Queue() if on_event is not None else None
        pool = ProcessPoolExecutor(min(self._workers, len(jobs)), mp_context=self._context)
        try:
            futures = [pool.submit(_run_job_in_worker, fn, job, self.function, events)
                       for job in jobs]
            pending: set[Future[Any]] = set(futures)
            while pending:
                _, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
                _drain(events, emit)
            _drain(events, emit)
            return [f.result() for f in futures]
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)
            raise
        finally:
            pool.shutdown(wait=True)
            manager.shutdown()

    def close(self) -> None:
        """Shut the worker processes down."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __getstate__(self) -> dict[str, Any]:
        raise TypeError("a LocalEvaluator owns processes and cannot be pickled")


def _drain(events: Any, emit: Callable[[Any], None]) -> None:
    if events is None:
        return
    while True:
        try:
            emit(events.get_nowait())
        except queue.Empty:
            return


def _ray_evaluate(function: EvaluateFunction, task: EvalTask) -> EvalOutcome:
    return function(task)


def _ray_run_job(fn: Callable[..., Any], job: Any, function: EvaluateFunction) -> Any:
    inner = LocalEvaluator(workers=1, function=function)
    return fn(job, inner, lambda event: None)


class RayEvaluator:
    """Ray tasks, on a local instance or an existing cluster.

    Offline evaluations become one task each; whole runs become one task each (each run then
    evaluates its robots inside its task). Runs write to the experiment's SQLite database, so
    on a multi-node cluster the results directory must be on a filesystem all nodes share.

    Args:
        address: ``ray.init(address=...)``: ``None`` starts (or joins) a local instance,
            ``"auto"`` or ``"ray://host:port"`` an existing cluster.
        function: The evaluation function (default :func:`evaluate_task`).
        num_cpus: CPUs of a local instance started here (``None``: all).
        init_kwargs: Further keyword arguments for ``ray.init``.

    Raises:
        ImportError: Ray is not installed (with the extra to install).
    """

    def __init__(
        self,
        address: str | None = None,
        function: EvaluateFunction = evaluate_task,
        num_cpus: int | None = None,
        **init_kwargs: Any,
    ) -> None:
        try:
            import ray
        except ImportError as error:
            raise ImportError(
                "the Ray evaluator needs Ray: pip install 'revolve-env[ray]'"
            ) from error
        self._ray = ray
        self.function = function
        self._started_here = False
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False}
            kwargs.update(init_kwargs)
            if address is None and num_cpus is not None:
                kwargs["num_cpus"] = num_cpus
            ray.init(address=address, **kwargs)
            self._started_here = True
        self._evaluate = ray.remote(_ray_evaluate)
        self._run_job = ray.remote(_ray_run_job)

    @property
    def workers(self) -> int:
        """CPUs of the Ray cluster."""
        return max(1, int(self._ray.cluster_resources().get("CPU", 1)))

    def evaluate(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """One Ray task per evaluation; results in task order."""
        refs = [self._evaluate.remote(self.function, task) for task in tasks]
        return list(self._ray.get(refs))

    def run_jobs(
        self,
        fn: Callable[..., Any],
        jobs: Sequence[Any],
        on_event: Callable[[Any], None] | None = None,
    ) -> list[Any]:
        """One Ray task per run (progress events are not forwarded from Ray tasks)."""
        refs = [self._run_job.remote(fn, job, self.function) for job in jobs]
        try:
            return list(self._ray.get(refs))
        except BaseException:
            for ref in refs:
                self._ray.cancel(ref)
            raise

    def close(self) -> None:
        """Shut down the Ray instance if this evaluator started it."""
        if self._started_here:
            self._ray.shutdown()
            self._started_here = False

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def make_evaluator(kind: str, workers: int = 0, address: str | None = None,
                   function: EvaluateFunction = evaluate_task) -> LocalEvaluator | RayEvaluator:
    """The evaluator an :class:`~evolution.experiment.ExperimentConfig` asks for."""
    if kind == "local":
        return LocalEvaluator(workers or None, function=function)
    if kind == "ray":
        return RayEvaluator(address, function=function,
                            num_cpus=workers or None if address is None else None)
    raise ValueError(f"unknown evaluator {kind!r}; known: 'local', 'ray'")
