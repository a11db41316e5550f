"""Evolution as a loop you can step: :class:`Evolution`, with observers.

One run of an experiment is an :class:`Evolution` stepped from its start (or a checkpoint) to its
end. A step ends at a *commit point* and returns a :class:`~evolution.experiments.loop.run.Step`
holding every record made since the previous one::

    from evolution.experiments import Evolution, preset

    with Evolution(preset("quick", births=45, workers=1)) as evolution:
        while not evolution.done:
            step = evolution.step()        # offline: one generation (the first: generation 0)
            print(step.births, evolution.fitness.max())

Nothing is written anywhere unless an observer writes it. Observers (:class:`Observer`) are told
when the loop starts, when a robot is born, after every step and when it stops; the results
store (:class:`~evolution.experiments.store.observer.StoreObserver`), the progress display and
TensorBoard (:class:`EventObserver`: ``revolve``'s display,
:class:`~evolution.experiments.app.callbacks.TensorBoardLogger`) are observers.
:func:`evolution.run` and ``revolve run`` are this loop plus the store observer, for every run of
an experiment (:func:`~evolution.experiments.store.observer.execute_run`).

The two modes (``config.mode``) are :class:`~evolution.experiments.loop.offline.OfflineMode`
(a step: one generation of isolated evaluations, (mu + lambda) survivors; :meth:`Evolution.ask` and
:meth:`Evolution.tell` split it around your own evaluation) and
:class:`~evolution.experiments.loop.online.OnlineMode` (a step: the conception ticks up to the next
commit point, every ``checkpoint_interval`` births, in one world holding the whole population:
by default the population env, :func:`default_world`, imported only when an online loop is
made). Evaluation seeds are :func:`~evolution.evaluation.evaluation_seed` (run seed, robot id), so
offline results do not depend on the number of workers.

Resume. The store observer continues a run from its last checkpoint: offline, the population
from the store and the generator from the checkpoint; online, from a snapshot file of the world
and the loop (``checkpoints/run<id>.b<births>.snapshot``, referenced with its SHA-256 from the
checkpoint's ``engine_state``) where the physics engine restores its state exactly (MuJoCo),
else by **deterministic replay**: the loop runs again from its seed, checking every replayed
robot against the stored one and the generator's state against the checkpoint; its steps up to
the checkpoint are ``replayed`` and nothing of them is written. Either way the stored results
are never touched and the resumed run is bit-identical to an uninterrupted one.

Infancy learning (the Training Center: ``config.learning``, or ``infancy=``)
    Every newborn goes to the Training Center right after delivery, before it enters a world:
    offline, the evaluator calls the hook in the worker before the robot's evaluation (so the
    fitness is that of the learned controller); online, the loop calls it before
    ``world.add``, and the learned controller drives the robot in the shared world. The Training
    Center is a *separate* simulation: the learner's simulated seconds are recorded
    (``learning.sim_seconds``) but do not advance the run's clock, and a robot still matures
    ``fertile_age`` seconds after its birth, as without learning. So learning changes what a
    robot does during its life, not how long the life stages last, and runs with and without
    learning compare at equal simulated time and births.

    The learner's generator is seeded from the robot's evaluation seed
    (:func:`~evolution.evaluation.pool.infancy_seed`), never from the run's generator, so a learner
    cannot change the run's other random choices. A hook that raises (a
    :class:`~evolution.learning.LearnerError`, or any error of a plain hook) keeps the inborn
    controller; the failure is recorded (kind ``"learner"``) and the run goes on.

    Inheritance: the ``robots`` table holds the inborn genome as conceived; a successful
    learning is recorded in the ``learning`` table (learned genome, the learner's inborn and
    learned fitness, evaluations, simulated seconds). With a Lamarckian
    :class:`~evolution.learning.TrainingCenter` (``center.lamarckian``) the genome the robot
    passes to its children is the learned one; otherwise (Darwinian, or a plain hook) it is
    the inborn one.

    A learner that trains a policy outside the genome (stable-baselines3; Darwinian only) gives
    the robot a policy instead of a network, and the policy drives the robot: its offline
    evaluation (same seed and window), or its online life as an agent-controlled robot of the
    shared world. The store observer writes it to
    ``<results>/policies/run<r>_robot<id>.safetensors`` when the robot is born, before the
    commit that references it (the learning record's ``policy`` column: file, its SHA-256 and
    the parameters' digest; the file loads without running code,
    :mod:`evolution.learning.policy_file`). An online run resumed by replay reloads the
    policies from their files (a missing, damaged or foreign file is a one-line
    :class:`~evolution.experiments.loop.errors.StoreError` naming it, before anything is written);
    a MuJoCo snapshot keeps the policies' references and network states.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from evolution.evaluation import EvalOutcome, EvalTask, Evaluator, make_evaluator
from evolution.experiments.loop.config import ConfigError, ExperimentConfig, as_config
from evolution.experiments.loop.heap import release_freed_memory
from evolution.experiments.loop.offline import OfflineMode
from evolution.experiments.loop.online import OnlineMode
from evolution.experiments.loop.online_world import PopulationWorld
from evolution.experiments.loop.records import Checkpoint
from evolution.experiments.loop.run import (
    Member,
    OnlineWorld,
    ProgressEvent,
    RunSummary,
    Step,
    StoredRun,
    world_seed,
)
from evolution.experiments.loop.state import RunState
from evolution.lifecycle import InfancyHook

__all__ = ["Evolution", "EventObserver", "Observer", "ProgressObserver", "default_world",
           "infancy_for"]

Status = Literal["finished", "interrupted"]
"""How a loop stopped: it reached its births or time (``finished``), or it was closed before, or
an error escaped a step (``interrupted``: a store observer's run can be resumed)."""


class Observer:
    """Something told what the loop does; override the hooks you need (each does nothing).

    Observers are told in the order they were attached. An exception raised by one stops the
    loop: every observer is then told it stopped (``interrupted``) and the exception propagates.
    """

    def started(self, evolution: Evolution) -> None:
        """Before the first step (a store observer resumes the run from its checkpoint here)."""

    def born(self, evolution: Evolution, member: Member) -> None:
        """A robot was born and its infancy is over (a learned policy in ``member.policy``).

        Online it has not entered the world yet; offline it has been evaluated.
        """

    def stepped(self, evolution: Evolution, step: Step) -> None:
        """A step reached its commit point (``step.replayed``: it repeated a stored one)."""

    def stopped(self, evolution: Evolution, status: Status) -> None:
        """The loop stopped, ``finished`` or ``interrupted``; told once."""


class EventObserver(Observer):
    """An observer of :class:`~evolution.experiments.loop.run.ProgressEvent` s: where a run stands.

    It is given an event when a resumed loop starts (where it continues from; not while it
    replays), after every step (``replaying`` while a replay has not reached its checkpoint)
    and when the loop finishes (``finished``). Subclasses implement :meth:`__call__`, so they
    also serve as progress callbacks of :func:`evolution.run` (whose runs may execute in other
    processes and send their events to the caller's).
    """

    def __call__(self, event: ProgressEvent) -> None:
        """Receive one event."""
        raise NotImplementedError

    def started(self, evolution: Evolution) -> None:
        """A resumed loop: the event of where it continues from."""
        if evolution.births > 0 and not evolution.replaying:
            self(evolution.event())

    def stepped(self, evolution: Evolution, step: Step) -> None:
        """The event of the step."""
        self(evolution.event(replaying=evolution.replaying))

    def stopped(self, evolution: Evolution, status: Status) -> None:
        """The last event, ``finished``, if it finished."""
        if status == "finished":
            self(evolution.event(finished=True))


class ProgressObserver(EventObserver):
    """An :class:`EventObserver` passing every event to ``callback``.

    Args:
        callback: Any progress callback (``print``, a list's ``append``, a forwarder to
            another process).
    """

    def __init__(self, callback: Callable[[ProgressEvent], Any]) -> None:
        self.callback = callback

    def __call__(self, event: ProgressEvent) -> None:
        """Pass ``event`` on."""
        self.callback(event)


def default_world(config: ExperimentConfig, seed: int) -> OnlineWorld:
    """The population environment of :mod:`revolve_env.envs.population` as an online world."""
    return PopulationWorld(config, seed)


def infancy_for(config: ExperimentConfig, infancy: InfancyHook | None) -> InfancyHook | None:
    """The infancy hook of a run: ``config.learning``'s Training Center, or ``infancy``.

    Raises:
        ConfigError: both are given and differ (which one would the stored results describe?).
    """
    center = config.training_center()
    if center is None:
        return infancy
    if infancy is not None and infancy != center:
        raise ConfigError(
            "the config has a learning table and infancy= gives another Training Center; give "
            "one of them (the learning table is stored with the results, infancy= is not)"
        )
    return center


class Evolution:
    """One run of an experiment as a loop: :meth:`step` it, read its population.

    Args:
        config: An :class:`~evolution.experiments.loop.config.ExperimentConfig`, a shipped config
            name, a TOML path or a dict; ``config.mode`` picks offline or online evolution.
        run_id: Which run of the experiment (its seed:
            :func:`~evolution.experiments.loop.run.run_seed` of ``config.seed`` and ``run_id``).
        evaluator: Offline: evaluates each generation (default: one made from
            ``config.evaluator`` and ``config.workers``, closed by :meth:`close`). Unused online.
        world: Online: the world holding the population (default: :func:`default_world` of the
            run's :func:`~evolution.experiments.loop.run.world_seed`, closed by :meth:`close`).
            Unused offline.
        infancy: The Training Center (default: the one ``config.learning`` describes; to
            store results, give it in ``config.learning``, see :func:`infancy_for`).
        observers: Told what the loop does (:class:`Observer`); more with :meth:`attach`.

    Raises:
        ConfigError: an invalid config.
        TypeError: an infancy hook that is not callable.
    """

    def __init__(
        self,
        config: ExperimentConfig | str | os.PathLike[str] | Mapping[str, Any],
        *,
        run_id: int = 0,
        evaluator: Evaluator | None = None,
        world: OnlineWorld | None = None,
        infancy: InfancyHook | None = None,
        observers: Sequence[Observer] = (),
    ) -> None:
        self.config = as_config(config)
        if infancy is None:
            infancy = self.config.training_center()
        self._state = RunState(self.config, run_id, infancy)
        self._state.on_born = self._born
        self._observers: list[Observer] = list(observers)
        self._phase: Literal["new", "running", "stopped"] = "new"
        self._closers: list[Callable[[], None]] = []
        self._mode: OfflineMode | OnlineMode
        if self.config.mode == "offline":
            if evaluator is None:
                evaluator = make_evaluator(self.config.evaluator, self.config.workers,
                                           self.config.ray_address)
                self._closers.append(evaluator.close)
            self._mode = OfflineMode(self._state, evaluator)
        else:
            if world is None:
                world = default_world(self.config, world_seed(self._state.seed))
                self._closers.append(world.close)
            self._mode = OnlineMode(self._state, world)

    # -- where the run stands ----------------------------------------------------------------

    @property
    def run_id(self) -> int:
        """The run."""
        return self._state.run_id

    @property
    def seed(self) -> int:
        """The run's seed."""
        return self._state.seed

    @property
    def mode(self) -> str:
        """``"offline"`` or ``"online"``."""
        return self.config.mode

    @property
    def births(self) -> int:
        """Robots born so far."""
        return self._state.births

    @property
    def sim_time(self) -> float:
        """Simulated time. Seconds."""
        return self._state.sim_time

    @property
    def generation(self) -> int:
        """Offline: the last generation made (0: the initial population). Online: ticks so far."""
        return self._state.generation

    @property
    def population(self) -> tuple[Member, ...]:
        """The living robots (offline: the population kept by the last selection).

        The members are the loop's own: read them, do not change them.
        """
        return tuple(self._state.population)

    @property
    def fitness(self) -> NDArray[np.float64]:
        """The population's fitness, in :attr:`population` order (``nan``: none yet). Metres."""
        return np.array([np.nan if m.fitness is None else m.fitness
                         for m in self._state.population], dtype=float)

    @property
    def done(self) -> bool:
        """Whether the run reached its births or its simulated-time limit."""
        return self._state.done()

    @property
    def replaying(self) -> bool:
        """Whether the loop is replaying a stored run up to its checkpoint (a resume)."""
        return self._state.replay is not None

    @property
    def world(self) -> OnlineWorld | None:
        """Online: the world holding the population; offline: ``None``."""
        return self._mode.world if isinstance(self._mode, OnlineMode) else None

    def event(self, replaying: bool = False, finished: bool = False) -> ProgressEvent:
        """Where the run stands now, as a progress event."""
        return self._state.event(replaying, finished)

    def summary(self, status: str) -> RunSummary:
        """How the run ended (``status``: ``finished`` or ``interrupted``)."""
        return self._state.summary(status)

    # -- observers -----------------------------------------------------------------------------

    def attach(self, observer: Observer) -> Observer:
        """Tell ``observer`` what the loop does from now on (before :meth:`start`: all of it)."""
        self._observers.append(observer)
        return observer

    def _born(self, member: Member) -> None:
        for observer in self._observers:
            observer.born(self, member)

    # -- stepping ------------------------------------------------------------------------------

    def start(self) -> None:
        """Tell the observers the loop starts (a store observer resumes it here); once.

        :meth:`step` starts the loop if need be. A loop that is done once started (a resumed
        run that had reached its end) stops ``finished`` at once.
        """
        if self._phase != "new":
            return
        self._phase = "running"
        with self._stopping_on_error():
            for observer in self._observers:
                observer.started(self)
        if self.done:
            self._stop("finished")

    def step(self) -> Step:
        """Run to the next commit point; the step's records.

        Raises:
            RuntimeError: the loop has stopped (done, closed, or after an error).
        """
        self._check_running("step")
        with self._stopping_on_error():
            step = self._mode.step()
        return self._stepped(step)

    def run(self, steps: int | None = None) -> None:
        """Step until the run is done (or ``steps`` steps were taken)."""
        self.start()
        taken = 0
        while not self.done and self._phase == "running" and (steps is None or taken < steps):
            self.step()
            taken += 1

    def ask(self) -> list[EvalTask]:
        """Offline: conceive the next robots to evaluate; their evaluation tasks.

        Evaluate them as you like (:func:`~evolution.evaluation.evaluate_task` does what the
        evaluator would) and give the outcomes to :meth:`tell`, in task order.

        Raises:
            TypeError: an online loop (its world evaluates robots as they live: :meth:`step`).
            RuntimeError: the loop has stopped, or the last tasks were not told.
        """
        mode = self._offline("ask")
        self._check_running("ask")
        with self._stopping_on_error():
            return mode.ask()

    def tell(self, outcomes: Sequence[EvalOutcome]) -> Step | None:
        """Offline: the outcomes of the tasks :meth:`ask` gave, in order; the step they close.

        Returns:
            The step, or ``None`` while generation 0 still lacks robots (one was lost in its
            evaluation): :meth:`ask` again.

        Raises:
            TypeError: an online loop.
            RuntimeError: nothing was asked.
            ValueError: not one outcome per task.
        """
        mode = self._offline("tell")
        with self._stopping_on_error():
            step = mode.tell(outcomes)
        return None if step is None else self._stepped(step)

    def _offline(self, what: str) -> OfflineMode:
        if not isinstance(self._mode, OfflineMode):
            raise TypeError(f"{what}() is for offline evolution; an online loop's world "
                            "evaluates its robots as they live: use step()")
        return self._mode

    def _check_running(self, what: str) -> None:
        self.start()
        if self._phase == "stopped":
            reason = "is done" if self.done else "has stopped"
            raise RuntimeError(f"cannot {what}(): run {self.run_id} {reason}")

    def _stepped(self, step: Step) -> Step:
        with self._stopping_on_error():
            for observer in self._observers:
                observer.stepped(self, step)
        # The step's models, snapshot and records are freed now: their pages go back to the
        # system, so a long run's memory stays flat (see heap's module doc).
        release_freed_memory()
        if self.done:
            self._stop("finished")
        return step

    @contextlib.contextmanager
    def _stopping_on_error(self) -> Iterator[None]:
        try:
            yield
        except BaseException:
            if self._phase == "running":
                self._phase = "stopped"
                for observer in self._observers:
                    # The original error matters more than a failure while stopping.
                    with contextlib.suppress(Exception):
                        observer.stopped(self, "interrupted")
            raise

    def _stop(self, status: Status) -> None:
        self._phase = "stopped"
        for observer in self._observers:
            observer.stopped(self, status)

    # -- for the store observer ----------------------------------------------------------------

    def resume_from(self, checkpoint: Checkpoint, store: StoredRun,
                    trust_pickled_policies: bool = False) -> None:
        """Continue from a stored checkpoint (call from an observer's :meth:`Observer.started`).

        Offline: the population from the store. Online: from the checkpoint's snapshot, else
        by replay from birth 0 (:attr:`replaying` until the checkpoint is reached).
        ``trust_pickled_policies``: load SB3 policies saved as pickles by older versions.

        Raises:
            RuntimeError: the loop has already stepped.
            StoreError: what the checkpoint needs is missing or damaged in the store.
        """
        if self._state.begun or self._state.births:
            raise RuntimeError("resume_from() before the first step only")
        self._mode.resume(checkpoint, store, trust_pickled_policies)

    def snapshot(self) -> dict[str, Any] | None:
        """What an exact continuation needs beyond the checkpoint (online on MuJoCo), or None."""
        return self._mode.snapshot()

    # -- the end -------------------------------------------------------------------------------

    def close(self) -> None:
        """Stop the loop (``interrupted`` if it was running) and close what it made."""
        try:
            if self._phase == "running":
                self._stop("interrupted")
        finally:
            self._phase = "stopped"
            closers, self._closers = self._closers, []
            for close in closers:
                close()

    def __enter__(self) -> Evolution:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
