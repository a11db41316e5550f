"""The records and interfaces of a run: what crosses between the loop, its worlds and observers.

A run is the evolution loop (:class:`~evolution.experiments.loop.evolve.Evolution`) stepped from its
start, or from a checkpoint, to its end. Each step ends at a *commit point*: the
:class:`Step` carries every record made since the previous one (a
:class:`~evolution.experiments.loop.records.Batch`) and the
:class:`~evolution.experiments.loop.records.Checkpoint` an exact continuation needs; the store
observer (:mod:`~evolution.experiments.store.observer`) writes both in one transaction. While a run
resumes by replay (:class:`Replay`), every robot it makes is checked against the stored one and
its steps are marked ``replayed`` (nothing new to write). The state and the steps both modes
share are :class:`~evolution.experiments.loop.state.RunState`'s.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from evolution.experiments.loop.config import ExperimentConfig
from evolution.experiments.loop.errors import StoreError
from evolution.experiments.loop.records import Batch, Checkpoint, LearningRecord, RobotRecord
from evolution.lifecycle import InfancyHook, Lifecycle
from revolve_env.body.robot import Robot
from revolve_env.body.serialize import from_json, to_json
from revolve_env.status import RobotStatus

__all__ = [
    "Birth",
    "Member",
    "OnlineWorld",
    "ProgressEvent",
    "Replay",
    "ReplayError",
    "RestorableWorld",
    "RobotStatus",
    "RunSummary",
    "Step",
    "StoredRun",
    "WorldFactory",
    "check_infancy",
    "decode",
    "genome",
    "json_norm",
    "run_seed",
    "world_seed",
]


class ReplayError(StoreError):
    """Replaying an online run did not reproduce the stored records (non-deterministic setup)."""


def run_seed(experiment_seed: int, run_id: int) -> int:
    """The seed of run ``run_id`` of an experiment.

    The loop's generator is ``default_rng(run_seed)``, i.e. ``SeedSequence(run_seed)``; the
    online world's is spawned from that same sequence (:func:`world_seed`), so the two streams
    are independent.
    """
    return int(np.random.SeedSequence([experiment_seed, run_id]).generate_state(1)[0])


def world_seed(run_seed: int) -> int:
    """The seed of a run's online world: the first child spawned from ``SeedSequence(run_seed)``.

    Before, the world was seeded with ``run_seed`` itself, so its generator drew the very numbers
    the loop's did.
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
    """What online evolution needs from a world holding the whole population."""

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


class StoredRun(Protocol):
    """What a resume reads of a run's stored results: the loop's one view of its store.

    The loop never writes: an observer does (the results store's
    :class:`~evolution.experiments.store.observer.StoreObserver` hands itself as this to
    :meth:`~evolution.experiments.loop.evolve.Evolution.resume_from`).
    """

    def robots(self, run_id: int, ids: Sequence[int] | None = None) -> list[RobotRecord]:
        """The robots of a run in birth order (only ``ids`` if given)."""

    def learning(self, run_id: int, ids: Sequence[int] | None = None) -> list[LearningRecord]:
        """Infancy learning records of a run (only of ``ids`` if given), in birth order."""

    def read_snapshot(self, run_id: int, ref: object, births: int) -> dict[str, Any]:
        """The data of a checkpoint's snapshot file.

        Raises:
            SnapshotError: missing, damaged, or not the checkpoint's.
        """

    def load_policy(self, run_id: int, robot: Robot, reference: str,
                    trust_pickled: bool = False) -> Any:
        """The SB3 policy a learning record references, checked against ``robot``.

        ``trust_pickled``: also load an older pickled policy (which can run code).

        Raises:
            StoreError: one line naming the file: outside the results folder, missing, damaged,
                of another body, not the one the store recorded, or pickled (not trusted).
        """


@dataclass(slots=True)
class Member:
    """A living robot known to the loop.

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


@dataclass(frozen=True, slots=True)
class Step:
    """One step of the evolution loop: a commit point and the records made since the last one.

    Offline a step is one generation (the first: the initial population); online it runs the
    conception ticks up to the next commit point (every ``checkpoint_interval`` births; the
    first: the initial population). Observers must not change the records.

    Attributes:
        records: Every record of the step: robots born, fitness samples, lifecycle transitions,
            deaths, failures, learning, the population's ``(robot_id, fitness)`` and, when due,
            its diversity.
        checkpoint: Where the run stands after the step: births, simulated time, generation,
            the generator's state and what else an exact continuation needs.
        replayed: The step repeated a commit point already stored (a resume by replay):
            nothing in it is new.
    """

    records: Batch
    checkpoint: Checkpoint
    replayed: bool = False

    @property
    def births(self) -> int:
        """Robots born so far."""
        return self.checkpoint.births

    @property
    def sim_time(self) -> float:
        """Simulated time. Seconds."""
        return self.checkpoint.sim_time

    @property
    def generation(self) -> int:
        """Offline: the generation just made (0: the initial population). Online: ticks so far."""
        return self.checkpoint.generation


@dataclass(frozen=True, slots=True)
class Replay:
    """A resume by deterministic replay: the run again from birth 0 up to a stored checkpoint.

    Attributes:
        until: The checkpoint to reach; its births and generator state are checked there.
        genomes: The stored genome (compact JSON) of every robot born, by robot id; every
            replayed robot is checked against its own.
        policies: ``policies(robot_id, robot)``: the stored learning record of a robot that
            lived driven by a saved policy and that policy, loaded (its Training Center is not
            run again); ``None`` for any other robot.
    """

    until: Checkpoint
    genomes: Mapping[int, str]
    policies: Callable[[int, Robot], tuple[LearningRecord, Any] | None]


# ---------------------------------------------------------------------------------------------


def check_infancy(hook: InfancyHook | None) -> None:
    """Refuse an infancy hook the loop cannot honour.

    Learners of a policy outside the genome (stable-baselines3) are accepted: the loop lets the
    policy drive the robot (offline evaluation, online life) and the store observer saves it.

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


def json_norm(value: object) -> object:
    """``value`` as JSON reads it back (tuples as lists, keys as text): for comparing states."""
    return json.loads(json.dumps(value, sort_keys=True))

