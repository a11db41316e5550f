"""The records a run makes: robots, fitness samples, failures, learning, commit points.

The loop (:mod:`~evolution.experiments.loop.state`) makes them; the results store
(:class:`~evolution.experiments.store.database.Store`, whose tables
:mod:`~evolution.experiments.store.schema` lays out) writes and reads them. They are plain data:
a :class:`Batch` collects one commit point's records (a new one for each), the others are frozen.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from evolution.lifecycle import Transition

if TYPE_CHECKING:
    from revolve_env.body.robot import Robot

__all__ = [
    "Batch",
    "Checkpoint",
    "DiversityPoint",
    "FailureRecord",
    "FitnessSample",
    "LearningRecord",
    "RobotRecord",
]


@dataclass(frozen=True, slots=True)
class RobotRecord:
    """One robot of a run as stored.

    Attributes:
        run_id: Run (repeat index).
        robot_id: Birth index within the run.
        genome: The robot as JSON (``revolve_env.body.serialize``).
        parent_a: First parent's id, ``None`` for a random robot.
        parent_b: Second parent's id, ``None`` for a random robot.
        origin: ``"random"``, ``"reproduction"`` or ``"random-fallback"`` (reproduction failed
            too often).
        generation: Offline generation (online: 0).
        conceived_time: Simulated time of conception. Seconds.
        birth_time: Simulated time of delivery; ``None`` if never delivered. Seconds.
        death_time: Simulated time of death; ``None`` while alive. Seconds.
        death_cause: Why it died (``"survivor selection"``, ``"blow-up: ..."``); ``None`` alive.
        fitness: Last known fitness (offline: the evaluation; online: the last sample);
            ``None`` for a robot lost to a failure (a blow-up, a failed evaluation, a body the
            engine could not build: its ``death_cause`` says which). Databases written before
            this rule hold 0.0 for robots lost in the shared world; reports read loss from
            the ``failures`` table, so both report alike.
    """

    run_id: int
    robot_id: int
    genome: str
    parent_a: int | None
    parent_b: int | None
    origin: str
    generation: int
    conceived_time: float
    birth_time: float | None
    death_time: float | None = None
    death_cause: str | None = None
    fitness: float | None = None

    def robot(self) -> Robot:
        """The genome decoded into a :class:`~revolve_env.body.robot.Robot`."""
        from revolve_env.body.serialize import from_json

        return from_json(self.genome)


@dataclass(frozen=True, slots=True)
class FitnessSample:
    """A robot's fitness at one simulated time.

    Attributes:
        robot_id: The robot.
        time: Simulated time. Seconds.
        fitness: ``v + 5 s`` over the preceding window. Metres.
        v: Path length over the window (at the task's pose rate). Metres. ``None`` when
            unknown.
        s: Straight-line displacement over the window. Metres. ``None`` when unknown.
        shaking: The path at every control period over ``v``, over the same span
            (:func:`revolve_env.fitness.sampling.shaking`; 1 at a pose rate of every control
            period). Dimensionless. ``None`` when unknown (online samples, samples stored
            before schema 7).
    """

    robot_id: int
    time: float
    fitness: float
    v: float | None = None
    s: float | None = None
    shaking: float | None = None


@dataclass(frozen=True, slots=True)
class FailureRecord:
    """Something that went wrong and was handled (``kind``: e.g. ``"crossover"``, ``"blow-up"``).

    Attributes:
        robot_id: Robot concerned, if any.
        time: Simulated time. Seconds.
        kind: Short machine-readable kind.
        detail: Human-readable detail.
    """

    robot_id: int | None
    time: float
    kind: str
    detail: str = ""


@dataclass(frozen=True, slots=True)
class LearningRecord:
    """One infancy in the Training Center (a learner that ran without failing).

    Attributes:
        robot_id: The infant.
        time: Simulated time of its birth, when it went to the Training Center. Seconds.
        inheritance: ``"darwinian"`` or ``"lamarckian"``: which genome it passes to children.
        learned_genome: The robot as JSON with its learned controller; ``None`` when the learner
            kept the inborn controller.
        inborn_fitness: Fitness of the inborn controller as the learner measured it. Metres.
        learned_fitness: Fitness of the learned controller as the learner measured it. Metres.
        evaluations: Evaluations (or training episodes) the learner ran.
        sim_seconds: Simulated seconds spent in the Training Center. Seconds.
        failures: Learner evaluations that failed (blow-ups).
        policy: ``None``, or the saved policy that drives the robot (an SB3 learner), as JSON:
            ``{"file": path relative to the results folder, "digest": SHA-256 of its
            parameters, "sha256": SHA-256 of the file}``
            (:class:`~evolution.experiments.store.results_folder.PolicyReference`; older databases
            have no ``sha256`` and a pickled ``.pkl`` file).
    """

    robot_id: int
    time: float
    inheritance: str
    learned_genome: str | None
    inborn_fitness: float | None
    learned_fitness: float | None
    evaluations: int | None
    sim_seconds: float | None
    failures: int = 0
    policy: str | None = None

    @property
    def improvement(self) -> float | None:
        """``learned_fitness - inborn_fitness`` (``None`` when either is unknown). Metres."""
        if self.inborn_fitness is None or self.learned_fitness is None:
            return None
        return self.learned_fitness - self.inborn_fitness


@dataclass(frozen=True, slots=True)
class DiversityPoint:
    """Population diversity after ``births`` births (mean pairwise tree edit distance)."""

    births: int
    sim_time: float
    value: float


@dataclass(frozen=True, slots=True)
class Checkpoint:
    """Where a run stands at a commit point: enough to continue it exactly.

    Attributes:
        births: Robots born so far.
        sim_time: Simulated time. Seconds.
        generation: Offline generation counter (online: number of conception ticks).
        rng_state: ``numpy.random.Generator.bit_generator.state``.
        engine_state: Whatever else the engine needs (JSON-compatible).
    """

    births: int
    sim_time: float
    generation: int
    rng_state: dict[str, Any]
    engine_state: dict[str, Any]


@dataclass(slots=True)
class Batch:
    """The records of one commit point, written in one transaction."""

    robots: list[RobotRecord] = field(default_factory=list)
    deaths: list[tuple[int, float, str, float | None]] = field(default_factory=list)
    """(robot_id, time, cause, final fitness) of robots stored earlier that died now."""
    fitness_updates: list[tuple[int, float | None]] = field(default_factory=list)
    """(robot_id, fitness): latest fitness of robots stored earlier; ``None`` for a robot lost
    to a blow-up in the shared world (stored as NULL: lost, not 0 m)."""
    fitness: list[FitnessSample] = field(default_factory=list)
    transitions: list[Transition] = field(default_factory=list)
    population: list[tuple[int, float | None]] | None = None
    """Snapshot (robot_id, fitness) of the population at this commit point, if any."""
    diversity: float | None = None
    failures: list[FailureRecord] = field(default_factory=list)
    learning: list[LearningRecord] = field(default_factory=list)
