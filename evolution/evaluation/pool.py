"""Pluggable evaluators: where offline evaluations and whole runs execute.

An evaluator does two things:

* ``evaluate(tasks)``: evaluate robots in isolation (offline scenarios), results in task order:
  the tasks are shared out among the workers, and each worker evaluates its share side by side
  with the batch form of the evaluation function (:func:`~evolution.evaluation.batched`: for the
  default one, every robot in a scene of its own, each outcome the one it gets alone);
* ``run_jobs(fn, jobs, on_event)``: run whole experiment runs side by side, forwarding their
  progress events to ``on_event`` in this process.

:class:`LocalEvaluator` uses worker processes on this machine (``forkserver`` start method: a
clean interpreter per worker, no inherited physics state). :class:`RayEvaluator` runs the same
work as Ray tasks on a local Ray instance or an existing cluster (``pip install revolve-env[ray]``).
The local processes die with the process that made them, SIGKILL included
(:mod:`evolution.evaluation.lifeline`).
Both run any picklable evaluation function (default :func:`~evolution.evaluation.evaluate_task`:
the Training Center, then the robot alone at the origin).

A cluster without a shared filesystem. Under Ray the driver (the process that called
``run``/``resume``, e.g. ``revolve run``) alone touches the results folder: a run task
gets its job's :meth:`RemoteJob.for_remote_worker` copy, whose store is a Ray actor on the
driver's node owning the SQLite database, the online snapshots and the SB3 policies
(:mod:`evolution.experiments.store.remote`); the task sends its commit points there and reads
what a resume needs from there. Its progress events go to another actor on the driver's node,
from which :meth:`RayEvaluator.run_jobs` hands them to ``on_event`` as they come. Results are
the local ones, row for row (``tests/evolution/experiments/store/test_ray_cluster.py`` checks it on
a two-node cluster). To run on machines A (head, results) and B, C, ...::

    A$ ray start --head --port 6379
    B$ ray start --address A:6379          # and so on, on every other machine
    A$ revolve run scenario1 --set evaluator=ray --set ray_address=auto --out results

Every node needs revolve-env installed (same version; the workers import it), nothing else:
no shared folder. Start the driver on a node of the cluster (``auto``), not through Ray Client
(``ray://``), whose driver runs on the head node and would write the results there. Ctrl-C in
the driver cancels the runs; each stops after its last commit point, and ``revolve resume``
continues (under Ray or locally).
"""

from __future__ import annotations

import multiprocessing
import os
import queue
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from contextlib import AbstractContextManager, ExitStack
from multiprocessing.managers import SyncManager
from typing import Any, Protocol, Self, TypeVar, runtime_checkable

from evolution.evaluation.lifeline import guard_worker
from evolution.evaluation.tasks import (
    BatchFunction,
    EvalOutcome,
    EvalTask,
    EvaluateFunction,
    batched,
    evaluate_task,
)

__all__ = [
    "Evaluator", "JobFunction", "LocalEvaluator", "RayEvaluator", "RemoteJob", "make_evaluator",
    "shares",
]

_CANCEL_WAIT = 60.0
"""Seconds to wait for cancelled run tasks to record their status. Seconds."""

JobT = TypeVar("JobT")
"""What one job is (for the engine: a run to execute)."""
ResultT = TypeVar("ResultT")
"""What one job returns."""
EventT = TypeVar("EventT")
"""The progress events a job emits."""

JobFunction = Callable[[JobT, "Evaluator", Callable[[EventT], None]], ResultT]
"""``fn(job, evaluator, emit) -> result``: one job, evaluating with ``evaluator`` and sending
progress events through ``emit``."""


class Evaluator(Protocol):
    """Where evaluations and runs execute."""

    @property
    def workers(self) -> int:
        """Evaluations (or runs) that may execute at once."""

    def evaluate(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """Evaluate the tasks; results in task order."""

    def run_jobs(
        self,
        fn: JobFunction[JobT, EventT, ResultT],
        jobs: Sequence[JobT],
        on_event: Callable[[EventT], None] | None = None,
    ) -> list[ResultT]:
        """Call ``fn(job, evaluator, emit)`` for every job, side by side where possible.

        ``emit(event)`` forwards a progress event to ``on_event`` in this process. Results are
        returned in job order.
        """

    def close(self) -> None:
        """Release workers."""


def _run_job_in_worker(
    fn: JobFunction[JobT, EventT, ResultT],
    job: JobT,
    function: EvaluateFunction,
    events: queue.Queue[EventT] | None,
) -> ResultT:
    """Worker side of :meth:`LocalEvaluator.run_jobs`: one run with in-process evaluation."""
    inner = LocalEvaluator(workers=1, function=function)
    emit = (lambda event: events.put(event)) if events is not None else (lambda event: None)
    return fn(job, inner, emit)


class LocalEvaluator:
    """Worker processes on this machine.

    Args:
        workers: Processes; ``None`` or 0: all cores. 1 evaluates in this process.
        function: The evaluation function (picklable; default
            :func:`~evolution.evaluation.evaluate_task`).
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
            self._pool = ProcessPoolExecutor(self._workers, mp_context=self._context,
                                             initializer=guard_worker, initargs=(os.getpid(),))
        return self._pool

    def evaluate(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """Evaluate in worker processes (in this process when ``workers == 1``).

        Each worker gets one share of the tasks (:func:`shares`) and evaluates it side by side.
        """
        batch = batched(self.function)
        if self._workers == 1 or len(tasks) <= 1:
            return batch(tasks)
        parts = shares(tasks, self._workers)
        done = self._executor().map(batch, [[tasks[i] for i in part] for part in parts])
        return _in_task_order(len(tasks), parts, list(done))

    def run_jobs(
        self,
        fn: JobFunction[JobT, EventT, ResultT],
        jobs: Sequence[JobT],
        on_event: Callable[[EventT], None] | None = None,
    ) -> list[ResultT]:
        """Run jobs; one at a time here (evaluations in parallel) or side by side in processes.

        With a single job, or a single worker, the jobs run in this process one after the other,
        and their evaluations use this evaluator's workers. Otherwise up to ``workers`` jobs run
        side by side, each in its own process evaluating its robots in that process.
        """
        emit = on_event or (lambda event: None)
        if len(jobs) <= 1 or self._workers == 1:
            return [fn(job, self, emit) for job in jobs]
        manager = SyncManager(ctx=self._context)
        manager.start(guard_worker, (os.getpid(),))
        events: queue.Queue[EventT] | None = manager.Queue() if on_event is not None else None
        pool = ProcessPoolExecutor(min(self._workers, len(jobs)), mp_context=self._context,
                                   initializer=guard_worker, initargs=(os.getpid(),))
        try:
            futures = [pool.submit(_run_job_in_worker, fn, job, self.function, events)
                       for job in jobs]
            pending: set[Future[ResultT]] = set(futures)
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


def shares(tasks: Sequence[EvalTask], k: int) -> list[list[int]]:
    """The tasks (their indices) shared out among ``k`` workers, about the same work each.

    Largest robots first, each to the share with the fewest parts so far (the cost of a
    simulation grows with the robot). Outcomes do not depend on the sharing.
    """
    k = max(1, min(k, len(tasks)))
    # a task of a function that evaluates something else than EvalTasks weighs 1
    cost = [t.robot.num_parts() if isinstance(t, EvalTask) else 1 for t in tasks]
    parts: list[list[int]] = [[] for _ in range(k)]
    load = [0] * k
    for i in sorted(range(len(tasks)), key=lambda i: -cost[i]):
        j = load.index(min(load))
        parts[j].append(i)
        load[j] += cost[i]
    return [sorted(part) for part in parts if part]


def _in_task_order(n: int, parts: list[list[int]], done: list[list[EvalOutcome]]
                   ) -> list[EvalOutcome]:
    out: list[EvalOutcome | None] = [None] * n
    for part, outcomes in zip(parts, done, strict=True):
        for i, outcome in zip(part, outcomes, strict=True):
            out[i] = outcome
    return [o for o in out if o is not None]


def _drain(events: queue.Queue[EventT] | None, emit: Callable[[EventT], None]) -> None:
    if events is None:
        return
    while True:
        try:
            emit(events.get_nowait())
        except queue.Empty:
            return


def _ray_evaluate(batch: BatchFunction, tasks: list[EvalTask]) -> list[EvalOutcome]:
    return batch(tasks)


class _Inbox:
    """Ray actor on the driver's node: the progress events of remote jobs, in arrival order."""

    def __init__(self) -> None:
        self._events: list[Any] = []

    def put(self, event: Any) -> None:
        self._events.append(event)

    def take(self) -> list[Any]:
        events, self._events = self._events, []
        return events


def _ray_run_job(
    fn: JobFunction[JobT, EventT, ResultT], job: JobT, function: EvaluateFunction, inbox: Any
) -> ResultT:
    import ray

    def emit(event: EventT) -> None:
        # Waits for the inbox, so every event is there before the job's result.
        if inbox is not None:
            ray.get(inbox.put.remote(event))

    inner = LocalEvaluator(workers=1, function=function)
    return fn(job, inner, emit)


def _take(inbox: Any, on_event: Callable[[EventT], None] | None) -> None:
    """Hand the events waiting in ``inbox`` to ``on_event``."""
    if inbox is not None and on_event is not None:
        import ray

        for event in ray.get(inbox.take.remote()):
            on_event(event)


@runtime_checkable
class RemoteJob(Protocol):
    """A job that reads and writes files of the driver's machine (a run: its database).

    :class:`RayEvaluator` sends the job's :meth:`for_remote_worker` copy to the cluster
    (e.g. :meth:`evolution.experiments.RunJob.for_remote_worker`: the database stays on the
    driver's node and the worker calls it), so no node needs the driver's files.
    """

    def for_remote_worker(self) -> AbstractContextManager[Any]:
        """A copy of the job that any node can run, valid until the context exits."""


class RayEvaluator:
    """Ray tasks, on a local instance or an existing cluster.

    Offline evaluations become one task per share of them (one share per CPU, evaluated side by
    side in that task); whole runs become one task each (each run then
    evaluates its robots inside its task; tasks spread over the nodes). A run task never opens
    the database: a job that is a :class:`RemoteJob` (an experiment run) goes out as its
    :meth:`~RemoteJob.for_remote_worker` copy, whose store is an actor on the driver's node
    owning the SQLite file (:mod:`evolution.experiments.store.remote`), so a multi-node
    cluster needs nothing shared: no results folder on a shared filesystem. Progress events
    go to an actor on the driver's node too, and reach ``on_event`` while the runs go on.

    Run on a cluster: ``ray start --head`` on one machine, ``ray start --address HEAD:6379`` on
    the others, then on the head machine (where the results folder is written)
    ``revolve run scenario1 --evaluator ray --ray-address auto``. The driver must run on a
    node of the cluster (``ray://`` client mode would write the results on the head node).

    Args:
        address: ``ray.init(address=...)``: ``None`` starts (or joins) a local instance,
            ``"auto"`` or ``"ray://host:port"`` an existing cluster.
        function: The evaluation function (default :func:`~evolution.evaluation.evaluate_task`).
        num_cpus: CPUs of a new local instance started here (with ``address=None``; even when
            another Ray instance runs on this machine). ``None``: all, or join a running one.
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
                # A new instance of that size: joining one already running on this machine
                # (another job's) would refuse num_cpus.
                kwargs["num_cpus"] = num_cpus
                address = "local"
            ray.init(address=address, **kwargs)
            self._started_here = True
        self._evaluate = ray.remote(_ray_evaluate)
        # Any: a remote function of the generic _ray_run_job, whose types are fixed per call.
        self._run_job: Any = ray.remote(_ray_run_job).options(scheduling_strategy="SPREAD")

    @property
    def workers(self) -> int:
        """CPUs of the Ray cluster."""
        resources = self._ray.cluster_resources()  # type: ignore[no-untyped-call]
        return max(1, int(resources.get("CPU", 1)))

    def evaluate(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        """One Ray task per share of the tasks (one share per CPU); results in task order."""
        batch = batched(self.function)
        parts = shares(tasks, self.workers)
        refs = [self._evaluate.remote(batch, [tasks[i] for i in part]) for part in parts]
        return _in_task_order(len(tasks), parts, list(self._ray.get(refs)))

    def run_jobs(
        self,
        fn: JobFunction[JobT, EventT, ResultT],
        jobs: Sequence[JobT],
        on_event: Callable[[EventT], None] | None = None,
    ) -> list[ResultT]:
        """One Ray task per run; progress events reach ``on_event`` here while they run.

        On an error or Ctrl-C here (``on_event`` raising included) the tasks are cancelled
        (a KeyboardInterrupt in each run: it stops after its last commit point) and waited for,
        so each run records its status before the exception propagates.
        """
        ray = self._ray
        from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

        here = NodeAffinitySchedulingStrategy(ray.get_runtime_context().get_node_id(), soft=False)
        with ExitStack() as hosts:
            sent = [hosts.enter_context(job.for_remote_worker()) if isinstance(job, RemoteJob)
                    else job for job in jobs]
            inbox = None
            if on_event is not None:
                inbox = ray.remote(_Inbox).options(num_cpus=0, scheduling_strategy=here).remote()
                hosts.callback(ray.kill, inbox)
            refs = [self._run_job.remote(fn, job, self.function, inbox) for job in sent]
            try:
                pending = list(refs)
                while pending:
                    _, pending = ray.wait(pending, num_returns=len(pending), timeout=0.2)
                    _take(inbox, on_event)
                _take(inbox, on_event)
                return list(ray.get(refs))
            except BaseException:
                for ref in refs:
                    ray.cancel(ref)
                ray.wait(refs, num_returns=len(refs), timeout=_CANCEL_WAIT)
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
    """The evaluator an :class:`~evolution.experiments.loop.config.ExperimentConfig` asks for."""
    if kind == "local":
        return LocalEvaluator(workers or None, function=function)
    if kind == "ray":
        return RayEvaluator(address, function=function,
                            num_cpus=workers or None if address is None else None)
    raise ValueError(f"unknown evaluator {kind!r}; known: 'local', 'ray'")
