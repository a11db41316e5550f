"""What both engines share: a run's state, its records, commit points and replay checks.

A run is a loop of *commit points* (see :mod:`evolution.experiments.engine` for both engines).
Between two commit points the engine conceives robots (two tournament parents, or at random),
delivers them, lets them live, selects survivors, and collects every record in a
:class:`~evolution.experiments.store.Batch`; at the commit point the batch and a checkpoint are
written in one transaction. While an online run replays up to its last checkpoint
(:attr:`RunState.replay_until`), every robot it makes is checked against the stored one and
nothing is written.
"""

from __future__ import annotations

import json
import math
import time
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import Any, Protocol, runtime_checkable

import numpy as np

from evolution.diversity import diversity
from evolution.evaluation import LearningSummary
from evolution.experiments.config import ExperimentConfig
from evolution.experiments.remote_store import RunStore, host_store
from evolution.experiments.store import (
    Batch,
    Checkpoint,
    FailureRecord,
    LearningRecord,
    RobotRecord,
    StoreError,
)
from evolution.lifecycle import InfancyHook, Lifecycle, LifecycleTiming
from evolution.operators import reproduce
from evolution.random_robot import random_robot
from evolution.selection import select_parents
from revolve_env.body.robot import Robot
from revolve_env.body.serialize import from_json, to_json
from revolve_env.status import RobotStatus

__all__ = [
    "Birth",
    "OnlineWorld",
    "ProgressEvent",
    "ReplayError",
    "RestorableWorld",
    "RunJob",
    "RunSummary",
    "WorldFactory",
    "Member",
    "RobotStatus",
    "RunState",
    "StopRun",
    "check_infancy",
    "decode",
    "genome",
    "run_seed",
    "world_seed",
]


class ReplayError(StoreError):
    """Replaying an online run did not reproduce the stored records (non-deterministic setup)."""


def run_seed(experiment_seed: int, run_id: int) -> int:
    """The seed of run ``run_id`` of an experiment.

    The engine's generator is ``default_rng(run_seed)``, i.e. ``SeedSequence(run_seed)``; the
    online world's is spawned from that same sequence (:func:`world_seed`), so the two streams
    are independent.
    """
    return int(np.random.SeedSequence([experiment_seed, run_id]).generate_state(1)[0])


def world_seed(run_seed: int) -> int:
    """The seed of a run's online world: the first child spawned from ``SeedSequence(run_seed)``.

    Before, the world was seeded with ``run_seed`` itself, so its generator drew the very numbers
    the engine's did.
    """
    child = np.random.SeedSequence(run_seed).spawn(1)[0]
    return int(child.generate_state(1)[0])


@dataclass(frozen=True, slots=True)
class ProgressEvent:
    """Where a run stands, sent to the progress callback after every commit point.

    Attributes:
        run_id: The run.
        births: Robots born so far.
        target_births: Births at which the run stops.
        sim_time: Simulated time. Seconds.
        best: Highest fitness in the population (``nan`` if none). Metres.
        mean: Mean fitness of the population (``nan`` if none). Metres.
        population_size: Robots alive (offline: the population).
        sim_speed: Simulated seconds per wall-clock second since the run (re)started.
        wall_time: Wall-clock seconds since the run (re)started.
        replaying: True while an online run replays up to its last commit point.
        finished: True on the last event of a run.
        failures: Failures recorded since the run (re)started (blow-ups, learner failures,
            crossovers...), as sorted ``(kind, count)`` pairs.
    """

    run_id: int
    births: int
    target_births: int
    sim_time: float
    best: float
    mean: float
    population_size: int
    sim_speed: float
    wall_time: float
    replaying: bool = False
    finished: bool = False
    failures: tuple[tuple[str, int], ...] = ()


@dataclass(frozen=True, slots=True)
class RunSummary:
    """How a run ended."""

    run_id: int
    seed: int
    births: int
    sim_time: float
    best: float
    mean: float
    population_size: int
    wall_time: float
    status: str


@dataclass(frozen=True, slots=True)
class Birth:
    """Where the online world placed a newborn.

    Attributes:
        robot_id: The robot (the id the engine gave it: its birth index).
        position: Core ``(x, y)`` where it was placed. Metres.
        inside: False when the birth disc was crowded and it went outside.
    """

    robot_id: int
    position: tuple[float, float]
    inside: bool


class OnlineWorld(Protocol):
    """What the online engine needs from a world holding the whole population."""

    @property
    def time(self) -> float:
        """Simulated time. Seconds."""

    def add(self, robot: Robot, robot_id: int, policy: Any = None) -> Birth:
        """Place robot ``robot_id`` by the population env's rule and drop it in; where it went.

        ``policy`` (a :class:`~evolution.learning.PolicyAgent`): the robot is agent-controlled
        and the world sets its hinge targets to ``policy.act(observation)`` every control step;
        ``None``: its own network drives it.
        """

    def remove(self, robot_id: int) -> None:
        """Take a robot out of the world."""

    def advance_to(self, t: float) -> dict[int, RobotStatus]:
        """Simulate until time ``t``.

        Returns:
            The status of every robot alive before the call, by robot id (with its ``death``
            for those the world lost; insertion and maturity on the world's clock).
        """

    def close(self) -> None:
        """Release the physics."""


@runtime_checkable
class RestorableWorld(Protocol):
    """An online world that can also save and restore its whole state (for an exact resume)."""

    @property
    def exact_restore(self) -> bool:
        """Whether :meth:`restore` continues a :meth:`snapshot` bit for bit on this engine."""

    def snapshot(self) -> dict[str, Any]:
        """The world's whole state as plain data (NumPy arrays allowed)."""

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Continue from a :meth:`snapshot`; on failure the world is as new (time 0, empty).

        Raises:
            ValueError: the snapshot does not fit this world.
        """

    def drive(self, robot_id: int, policy: Any) -> None:
        """After :meth:`restore`: let ``policy`` drive the agent-controlled robot ``robot_id``."""


WorldFactory = Callable[[ExperimentConfig, int], OnlineWorld]
"""Makes the online world of a run from the config and a seed (:func:`world_seed`; picklable)."""


@dataclass(frozen=True, slots=True)
class RunJob:
    """Everything a worker needs to execute (or continue) one run.

    ``store``: where the run reads and writes its records; ``None``: it opens ``db_path``
    itself. A job sent to another machine carries a remote one (:meth:`for_remote_worker`).
    ``trust_pickled_policies``: a resumed run may load SB3 policies saved as pickles by older
    versions (unpickling can run code: only for a results folder whose author is trusted).
    """

    db_path: str
    run_id: int
    config: ExperimentConfig
    world_factory: WorldFactory | None = None
    infancy: InfancyHook | None = None
    stop_after_commits: int | None = None
    store: RunStore | None = None
    trust_pickled_policies: bool = False

    @contextmanager
    def for_remote_worker(self) -> Iterator[RunJob]:
        """This job for a Ray worker on any node: the database stays on this one.

        Call in the Ray driver; the copy's store is a
        :class:`~evolution.experiments.remote_store.RemoteStore` of this node's database,
        valid until the context exits.
        """
        with host_store(self.db_path) as store:
            yield replace(self, store=store)


@dataclass(slots=True)
class Member:
    """A living robot known to the engine.

    ``robot`` is the genome the member passes to its children: the inborn one, or the learned
    one (``learned``) under Lamarckian inheritance. ``policy`` is the SB3 policy that drives it
    (a :class:`~evolution.learning.PolicyAgent`; ``None``: its own network) and ``policy_ref``
    the store's reference to its file (JSON).
    """

    robot_id: int
    robot: Robot
    lifecycle: Lifecycle
    fitness: float | None = None
    learned: bool = False
    policy: Any = None
    policy_ref: str | None = None


class StopRun(Exception):
    """Internal: stop after a number of commit points (used by tests and benchmarks)."""


# ---------------------------------------------------------------------------------------------


def check_infancy(hook: InfancyHook | None) -> None:
    """Refuse an infancy hook the engine cannot honour.

    Learners of a policy outside the genome (stable-baselines3) are accepted: the engines save
    the policy with the results and let it drive the robot (offline evaluation, online life).

    Raises:
        TypeError: ``hook`` is not callable.
    """
    if hook is None:
        return
    if not callable(hook):
        raise TypeError(f"infancy must be a callable hook(robot, rng) -> robot, got {hook!r}")


def genome(robot: Robot) -> str:
    """A robot as the store keeps it (compact JSON)."""
    return to_json(robot, indent=None)


def decode(stored: str) -> Robot:
    """A robot from its stored JSON."""
    return from_json(stored)


def _finite(values: Sequence[float | None]) -> np.ndarray:
    return np.array([v for v in values if v is not None and math.isfinite(v)], dtype=float)


class RunState:
    """State and shared steps of one run (both engines)."""

    def __init__(self, job: RunJob, store: RunStore,
                 emit: Callable[[ProgressEvent], None]) -> None:
        self.job = job
        self.config = job.config
        self.run_id = job.run_id
        self.seed = run_seed(self.config.seed, self.run_id)
        self.store = store
        self.emit = emit
        self.timing = LifecycleTiming(self.config.insertion, self.config.fertile_age)
        self.rng = np.random.default_rng(self.seed)
        self.births = 0
        self.sim_time = 0.0
        self.generation = 0
        self.batch = Batch()
        self.population: list[Member] = []
        self.last_diversity_births: int | None = None
        self.last_commit_births = 0
        self.commits = 0
        self.started = time.perf_counter()
        self.sim_time_at_start = 0.0
        self.replay_until: Checkpoint | None = None
        self.stored_genomes: dict[int, str] = {}
        self.failure_counts: Counter[str] = Counter()
        check_infancy(job.infancy)
        self.infancy = job.infancy
        self.lamarckian = bool(getattr(job.infancy, "lamarckian", False))

    # -- conception --------------------------------------------------------------------------

    def choose_parents(self, candidates: Sequence[Member]) -> tuple[Member, Member]:
        """Two distinct parents by tournament on fitness (the second among the others)."""
        fitness = np.array([m.fitness for m in candidates], dtype=float)
        a, b = select_parents(fitness, self.rng, self.config.tournament_size)
        return candidates[a], candidates[b]

    def conceive(
        self, candidates: Sequence[Member], time_s: float, random: bool = False
    ) -> tuple[Robot, int | None, int | None, str]:
        """A new genome: random, or a child of two tournament parents among ``candidates``.

        Failed crossovers are recorded and retried with new parents, up to
        ``max_conception_attempts``; after that the robot is random (``"random-fallback"``).
        """
        config = self.config
        if random or config.new_robots == "random":
            return random_robot(self.rng, config.evolution), None, None, "random"
        candidates = [m for m in candidates if m.fitness is not None and math.isfinite(m.fitness)]
        if len(candidates) < 2:
            self.batch.failures.append(FailureRecord(
                self.births, time_s, "no-parents",
                f"{len(candidates)} mature robot(s); conceived a random robot"))
            return random_robot(self.rng, config.evolution), None, None, "random-fallback"
        for _ in range(config.max_conception_attempts):
            a, b = self.choose_parents(candidates)
            result = reproduce(a.robot, b.robot, self.rng, config.evolution)
            if result.child is not None:
                return result.child, a.robot_id, b.robot_id, "reproduction"
            self.batch.failures.append(FailureRecord(
                self.births, time_s, "crossover",
                f"parents {a.robot_id} and {b.robot_id}: {result.failure}"))
        self.batch.failures.append(FailureRecord(
            self.births, time_s, "conception",
            f"{config.max_conception_attempts} parent pairs gave no child; random robot"))
        return random_robot(self.rng, config.evolution), None, None, "random-fallback"

    def new_member(self, robot: Robot, parents: tuple[int | None, int | None], origin: str,
                   conceived: float, born: float) -> tuple[Member, RobotRecord]:
        """Register a conceived and delivered robot; checks it against the store on replay."""
        robot_id = self.births
        self.births += 1
        stored = genome(robot)
        replaying = self.replay_until is not None and robot_id in self.stored_genomes
        if replaying and self.stored_genomes[robot_id] != stored:
            raise ReplayError(
                f"run {self.run_id}: replay made a different robot {robot_id} than the stored "
                "one; the simulation is not deterministic on this machine, cannot resume"
            )
        life = Lifecycle(robot_id, self.timing)
        note = "random" if parents[0] is None else f"parents {parents[0]},{parents[1]}"
        life.conceive(conceived, note if origin != "random-fallback" else "random (fallback)")
        life.deliver(born)
        record = RobotRecord(self.run_id, robot_id, stored, parents[0], parents[1], origin,
                             self.generation, conceived, born)
        return Member(robot_id, robot, life), record

    # -- infancy -----------------------------------------------------------------------------

    def record_infancy(self, member: Member, time_s: float, failure: str | None,
                       learning: LearningSummary | None, learned: Robot | None) -> None:
        """Record what the Training Center did for ``member`` (born at ``time_s``).

        Under Lamarckian inheritance the learned robot (``None``: nothing learned) becomes the
        genome it passes on.
        """
        if failure is not None:
            self.batch.failures.append(FailureRecord(member.robot_id, time_s, "learner", failure))
            return
        if learning is None:
            return
        if learning.policy is not None:
            member.policy = learning.policy
            if member.policy_ref is None:  # a policy loaded on replay is already saved
                member.policy_ref = self.save_policy(member)
        self.batch.learning.append(LearningRecord(
            member.robot_id, time_s, "lamarckian" if self.lamarckian else "darwinian",
            genome(learned) if learned is not None else None, learning.inborn_fitness,
            learning.learned_fitness, learning.evaluations, learning.sim_seconds,
            learning.failures, member.policy_ref))
        if self.lamarckian and learned is not None:
            member.robot = learned
            member.learned = True

    def save_policy(self, member: Member) -> str:
        """Write ``member.policy`` beside the database (before the commit that references it).

        Returns:
            The learning record's reference: JSON ``{"file": ..., "digest": ..., "sha256": ...}``.
        """
        return self.store.save_policy(self.run_id, member.robot_id, member.policy)

    def load_policy(self, robot: Robot, reference: str) -> Any:
        """The policy a learning record references, checked against ``robot``.

        Raises:
            StoreError: one line naming the file: missing, damaged, of another body, or not the
                one the store recorded.
        """
        return self.store.load_policy(self.run_id, robot, reference,
                                      self.job.trust_pickled_policies)

    # -- deaths ------------------------------------------------------------------------------

    def kill(self, member: Member, time_s: float, cause: str) -> None:
        """Record a death (the member must be alive)."""
        member.lifecycle.die(time_s, cause)
        self.batch.deaths.append((member.robot_id, time_s, cause, member.fitness))

    def flush_transitions(self, members: Sequence[Member]) -> None:
        """Move the members' new lifecycle transitions into the batch."""
        for m in members:
            self.batch.transitions.extend(m.lifecycle.transitions)
            m.lifecycle.transitions.clear()

    # -- commit points -------------------------------------------------------------------------

    def restore_counters(self, checkpoint: Checkpoint) -> None:
        """Take the clock, counters and generator of a checkpoint (both engines' resume)."""
        self.births = checkpoint.births
        self.sim_time = checkpoint.sim_time
        self.sim_time_at_start = checkpoint.sim_time
        self.generation = checkpoint.generation
        self.rng.bit_generator.state = checkpoint.rng_state
        self.last_diversity_births = checkpoint.engine_state.get("last_diversity_births")

    def diversity_due(self) -> bool:
        """True when this commit point should measure the population's diversity."""
        interval = self.config.diversity_interval
        if interval == 0:
            return False
        if self.last_diversity_births is None:
            return True
        return self.births // interval > self.last_diversity_births // interval

    def commit(self, engine_state: dict[str, Any], flushed: Sequence[Member]) -> None:
        """Write the batch and the checkpoint (or, while replaying, check and drop them)."""
        self.last_commit_births = self.births
        self.flush_transitions(flushed)
        self.batch.population = [(m.robot_id, m.fitness) for m in self.population]
        if self.diversity_due():
            self.batch.diversity = float(diversity([m.robot for m in self.population]))
            self.last_diversity_births = self.births
        engine_state = {**engine_state, "last_diversity_births": self.last_diversity_births}
        checkpoint = Checkpoint(self.births, self.sim_time, self.generation,
                                dict(self.rng.bit_generator.state), engine_state)
        if self.replay_until is not None:
            target = self.replay_until
            if self.births < target.births:
                self.batch.clear()
                self._progress(replaying=True)
                return
            same_rng = _json_norm(checkpoint.rng_state) == _json_norm(target.rng_state)
            if self.births != target.births or not same_rng:
                raise ReplayError(
                    f"run {self.run_id}: replay reached {self.births} births with a different "
                    f"state than the checkpoint ({target.births} births); cannot resume exactly"
                )
            self.batch.clear()
            self.replay_until = None
            self.stored_genomes.clear()
            self.started = time.perf_counter()
            self.sim_time_at_start = self.sim_time
            self._progress()
            return
        self.failure_counts.update(f.kind for f in self.batch.failures)
        written = self.save_snapshot()
        if written is not None:
            checkpoint.engine_state["snapshot"] = written
        self.store.commit(self.run_id, self.batch, checkpoint)
        self.committed(written)
        self.commits += 1
        self._progress()
        if self.job.stop_after_commits is not None and self.commits >= self.job.stop_after_commits:
            raise StopRun

    def save_snapshot(self) -> dict[str, Any] | None:
        """Write what an exact continuation needs beside the database (before the commit).

        Returns:
            The reference the checkpoint keeps, or ``None`` (the default: nothing written, the
            engine resumes otherwise).
        """
        return None

    def committed(self, snapshot: dict[str, Any] | None) -> None:
        """Called once a checkpoint referencing ``snapshot`` (or none) is committed."""

    def _stats(self) -> tuple[float, float]:
        values = _finite([m.fitness for m in self.population])
        if values.size == 0:
            return math.nan, math.nan
        return float(values.max()), float(values.mean())

    def event(self, replaying: bool = False, finished: bool = False) -> ProgressEvent:
        """Where the run stands now."""
        wall = time.perf_counter() - self.started
        best, mean = self._stats()
        speed = (self.sim_time - self.sim_time_at_start) / wall if wall > 0 else math.nan
        return ProgressEvent(self.run_id, self.births, self.config.births, self.sim_time, best,
                             mean, len(self.population), speed, wall, replaying, finished,
                             tuple(sorted(self.failure_counts.items())))

    def _progress(self, replaying: bool = False) -> None:
        self.emit(self.event(replaying=replaying))

    def done(self) -> bool:
        """True once the run reached its births or its simulated-time limit."""
        limit = self.config.max_sim_time
        return self.births >= self.config.births or (limit is not None and self.sim_time >= limit)

    def summary(self, status: str) -> RunSummary:
        """How the run ended (``status``: ``finished`` or ``interrupted``)."""
        best, mean = self._stats()
        return RunSummary(self.run_id, self.seed, self.births, self.sim_time, best, mean,
                          len(self.population), time.perf_counter() - self.started, status)


def _json_norm(value: object) -> object:
    return json.loads(json.dumps(value, sort_keys=True))


