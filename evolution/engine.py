"""One evolution engine; the scenarios are configurations of it.

A run is a loop of *commit points*. Between two commit points the engine conceives robots
(two tournament parents, or at random), delivers them, lets them live (evaluated alone, offline,
or together in one world, online), selects survivors, and collects every record in a
:class:`~evolution.store.Batch`; at the commit point the batch and a checkpoint are written in
one transaction.

Offline (``engine = "offline"``)
    Generation 0 is ``population_size`` random robots. Each later generation conceives
    ``offspring_size`` children (the last one fewer, to stop at exactly ``births``), evaluates
    them in parallel (each alone at the origin, ``insertion`` + ``evaluation_time`` seconds), and
    keeps ``population_size`` of parents + children (fitness: the fittest; random: uniformly).
    The simulated clock advances by one evaluation per child, as if the robots were evaluated
    one after another as in the paper. A commit point is one generation. Resume reloads the
    population from the store and the generator's state from the checkpoint.

Online (``engine = "online"``)
    ``population_size`` random robots are born at time 0 at random free positions. Every
    ``conception_interval`` seconds of simulated time: robots that died in the world (blow-ups)
    are recorded; survivor selection applies the online rule to the *mature* robots (infants
    have no full fitness window yet; the population never drops below ``min_alive`` through
    selection and is culled when it reaches ``max_alive``); then one robot is conceived from two
    mature parents chosen by tournament on their current sliding-window fitness and born at a
    random free position within ``birth_radius`` of the origin. If blow-ups leave fewer than
    ``min_alive`` robots, extra robots are conceived at once. A commit point is every
    ``checkpoint_interval`` births.

    Resume of an online run is by **deterministic replay**: a physics world cannot be
    serialised portably (pybullet's saveState lives in memory, and controller states live in
    the compiled controllers), so the engine re-runs the run from its start with the same seed,
    checking every replayed robot against the stored one and the generator's state against the
    checkpoint, and writes nothing until it has passed the last commit point. The stored results
    are never touched; the price is re-simulating the time before the interruption.

Evaluation seeds are :func:`~evolution.evaluators.evaluation_seed` (run seed, robot id), so
offline results do not depend on the number of workers.

Infancy learning (the Training Center, ``RunJob.infancy``)
    Every newborn goes to the Training Center right after delivery, before it enters a world:
    offline, the evaluator calls the hook in the worker before the robot's evaluation (so the
    fitness is that of the learned controller); online, the engine calls it before
    ``world.add``, and the learned controller drives the robot in the shared world. The Training
    Center is a *separate* simulation: the learner's simulated seconds are recorded
    (``learning.sim_seconds``) but do not advance the run's clock, and a robot still matures
    ``fertile_age`` seconds after its birth, as without learning. So learning changes what a
    robot does during its life, not how long the life stages last, and runs with and without
    learning compare at equal simulated time and births.

    The learner's generator is seeded from the robot's evaluation seed
    (:func:`~evolution.evaluators.infancy_seed`), never from the run's generator, so a learner
    cannot change the run's other random choices. A hook that raises (a
    :class:`~evolution.learning.LearnerError`, or any error of a plain hook) keeps the inborn
    controller; the failure is recorded (kind ``"learner"``) and the run goes on.

    Inheritance: the ``robots`` table holds the inborn genome as conceived; a successful
    learning is recorded in the ``learning`` table (learned genome, the learner's inborn and
    learned fitness, evaluations, simulated seconds). With a Lamarckian
    :class:`~evolution.learning.TrainingCenter` (``center.lamarckian``) the genome the robot
    passes to its children is the learned one; otherwise (Darwinian, or a plain hook) it is
    the inborn one. A learner that trains a policy outside the genome (stable-baselines3) is
    refused: the engine's evaluators and world run robots on their own networks.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from evolution.evaluators import (
    EvalOutcome,
    EvalTask,
    Evaluator,
    LearningSummary,
    evaluation_seed,
    run_infancy,
)
from evolution.experiment import ExperimentConfig
from evolution.lifecycle import InfancyHook, Lifecycle, LifecycleTiming, Stage
from evolution.store import (
    Batch,
    Checkpoint,
    FailureRecord,
    FitnessSample,
    LearningRecord,
    RobotRecord,
    Store,
    StoreError,
)
from revolve_env.body.robot import Robot

__all__ = [
    "AgentStatus",
    "OnlineWorld",
    "ProgressEvent",
    "ReplayError",
    "RunJob",
    "RunSummary",
    "WorldFactory",
    "check_infancy",
    "execute_run",
    "run_seed",
]


class ReplayError(StoreError):
    """Replaying an online run did not reproduce the stored records (non-deterministic setup)."""


def run_seed(experiment_seed: int, run_id: int) -> int:
    """The seed of run ``run_id`` of an experiment."""
    return int(np.random.SeedSequence([experiment_seed, run_id]).generate_state(1)[0])


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
class AgentStatus:
    """One robot in the online world after the world advanced.

    Attributes:
        fitness: Sliding-window fitness ``v + 5 s``. Metres.
        v: Path length over the window. Metres.
        s: Straight displacement over the window. Metres.
        position: Core position on the ground plane ``(x, y)``. Metres.
        removed: ``None``, or why the world removed the robot (blow-up).
    """

    fitness: float
    v: float | None
    s: float | None
    position: tuple[float, float]
    removed: str | None = None


class OnlineWorld(Protocol):
    """What the online engine needs from a world holding the whole population."""

    @property
    def time(self) -> float:
        """Simulated time. Seconds."""

    def add(self, robot: Robot, position: tuple[float, float]) -> str:
        """Drop a robot at ``position`` (metres); returns its agent id."""

    def remove(self, agent: str) -> None:
        """Take a robot out of the world."""

    def advance_to(self, t: float) -> dict[str, AgentStatus]:
        """Simulate until time ``t``; the status of every robot alive before the call
        (``removed`` set for those the world removed)."""

    def positions(self) -> dict[str, tuple[float, float]]:
        """Ground-plane positions of the living robots. Metres."""

    def close(self) -> None:
        """Release the physics."""


WorldFactory = Callable[[ExperimentConfig, int], OnlineWorld]
"""Makes the online world of a run from the config and the run's seed (picklable)."""


@dataclass(frozen=True, slots=True)
class RunJob:
    """Everything a worker needs to execute (or continue) one run."""

    db_path: str
    run_id: int
    config: ExperimentConfig
    world_factory: WorldFactory | None = None
    infancy: InfancyHook | None = None
    stop_after_commits: int | None = None


@dataclass(slots=True)
class _Member:
    """A living robot known to the engine.

    ``robot`` is the genome the member passes to its children: the inborn one, or the learned
    one (``learned``) under Lamarckian inheritance.
    """

    robot_id: int
    robot: Robot
    lifecycle: Lifecycle
    fitness: float | None = None
    agent: str | None = None
    learned: bool = False


class _StopRun(Exception):
    """Internal: stop after a number of commit points (used by tests and benchmarks)."""


# ---------------------------------------------------------------------------------------------


def check_infancy(hook: InfancyHook | None) -> None:
    """Refuse an infancy hook the engine cannot honour.

    Raises:
        TypeError: ``hook`` is not callable.
        ValueError: its learner trains a policy outside the genome (stable-baselines3): the
            engine's evaluators and world drive robots with their own networks, so the policy
            would be silently ignored.
    """
    if hook is None:
        return
    if not callable(hook):
        raise TypeError(f"infancy must be a callable hook(robot, rng) -> robot, got {hook!r}")
    learner = getattr(hook, "learner", None)
    if getattr(learner, "learns_policy", False):
        raise ValueError(
            f"{type(learner).__name__} trains a policy outside the genome, but the engine "
            "evaluates robots on their own networks; use a controller-parameter learner "
            "(CMA-ES, random search) in experiments"
        )


def _genome(robot: Robot) -> str:
    from revolve_env.body.serialize import to_json

    return to_json(robot, indent=None)


def _decode(genome: str) -> Robot:
    from revolve_env.body.serialize import from_json

    return from_json(genome)


def _finite(values: Sequence[float | None]) -> np.ndarray:
    return np.array([v for v in values if v is not None and math.isfinite(v)], dtype=float)


class _Run:
    """State and shared steps of one run (both engines)."""

    def __init__(self, job: RunJob, store: Store, emit: Callable[[ProgressEvent], None]) -> None:
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
        self.population: list[_Member] = []
        self.last_diversity_births: int | None = None
        self.last_commit_births = 0
        self.commits = 0
        self.started = time.perf_counter()
        self.sim_time_at_start = 0.0
        self.replay_until: Checkpoint | None = None
        self.stored_genomes: dict[int, str] = {}
        check_infancy(job.infancy)
        self.infancy = job.infancy
        self.lamarckian = bool(getattr(job.infancy, "lamarckian", False))

    # -- conception --------------------------------------------------------------------------

    def choose_parents(self, candidates: Sequence[_Member]) -> tuple[_Member, _Member]:
        """Two distinct parents by tournament on fitness (the second among the others)."""
        from evolution.selection import select_parents

        fitness = np.array([m.fitness for m in candidates], dtype=float)
        a, b = select_parents(fitness, self.rng, self.config.tournament_size)
        return candidates[a], candidates[b]

    def conceive(
        self, candidates: Sequence[_Member], time_s: float, random: bool = False
    ) -> tuple[Robot, int | None, int | None, str]:
        """A new genome: random, or a child of two tournament parents among ``candidates``.

        Failed crossovers are recorded and retried with new parents, up to
        ``max_conception_attempts``; after that the robot is random (``"random-fallback"``).
        """
        from evolution.operators import reproduce
        from evolution.random_robot import random_robot

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
                   conceived: float, born: float) -> tuple[_Member, RobotRecord]:
        """Register a conceived and delivered robot; checks it against the store on replay."""
        robot_id = self.births
        self.births += 1
        genome = _genome(robot)
        replaying = self.replay_until is not None and robot_id in self.stored_genomes
        if replaying and self.stored_genomes[robot_id] != genome:
            raise ReplayError(
                f"run {self.run_id}: replay made a different robot {robot_id} than the stored "
                "one; the simulation is not deterministic on this machine, cannot resume"
            )
        life = Lifecycle(robot_id, self.timing)
        note = "random" if parents[0] is None else f"parents {parents[0]},{parents[1]}"
        life.conceive(conceived, note if origin != "random-fallback" else "random (fallback)")
        life.deliver(born)
        record = RobotRecord(self.run_id, robot_id, genome, parents[0], parents[1], origin,
                             self.generation, conceived, born)
        return _Member(robot_id, robot, life), record

    # -- infancy -----------------------------------------------------------------------------

    def record_infancy(self, member: _Member, time_s: float, failure: str | None,
                       learning: LearningSummary | None, learned_genome: str | None,
                       learned: Robot | None = None) -> None:
        """Record what the Training Center did for ``member`` (born at ``time_s``); under
        Lamarckian inheritance the learned genome becomes the one it passes on."""
        if failure is not None:
            self.batch.failures.append(FailureRecord(member.robot_id, time_s, "learner", failure))
            return
        if learning is None:
            return
        self.batch.learning.append(LearningRecord(
            member.robot_id, time_s, "lamarckian" if self.lamarckian else "darwinian",
            learned_genome, learning.inborn_fitness, learning.learned_fitness,
            learning.evaluations, learning.sim_seconds, learning.failures))
        if self.lamarckian and learned_genome is not None:
            member.robot = learned if learned is not None else _decode(learned_genome)
            member.learned = True

    # -- deaths ------------------------------------------------------------------------------

    def kill(self, member: _Member, time_s: float, cause: str) -> None:
        """Record a death (the member must be alive)."""
        member.lifecycle.die(time_s, cause)
        self.batch.deaths.append((member.robot_id, time_s, cause, member.fitness))

    def flush_transitions(self, members: Sequence[_Member]) -> None:
        """Move the members' new lifecycle transitions into the batch."""
        for m in members:
            self.batch.transitions.extend(m.lifecycle.transitions)
            m.lifecycle.transitions.clear()

    # -- commit points -------------------------------------------------------------------------

    def diversity_due(self) -> bool:
        interval = self.config.diversity_interval
        if interval == 0:
            return False
        if self.last_diversity_births is None:
            return True
        return self.births // interval > self.last_diversity_births // interval

    def commit(self, engine_state: dict[str, Any], flushed: Sequence[_Member]) -> None:
        """Write the batch and the checkpoint (or, while replaying, check and drop them)."""
        self.last_commit_births = self.births
        self.flush_transitions(flushed)
        self.batch.population = [(m.robot_id, m.fitness) for m in self.population]
        if self.diversity_due():
            from evolution.diversity import diversity

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
            if self.births != target.births or _json_norm(checkpoint.rng_state) != _json_norm(target.rng_state):
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
        self.store.commit(self.run_id, self.batch, checkpoint)
        self.commits += 1
        self._progress()
        if self.job.stop_after_commits is not None and self.commits >= self.job.stop_after_commits:
            raise _StopRun

    def _stats(self) -> tuple[float, float]:
        values = _finite([m.fitness for m in self.population])
        if values.size == 0:
            return math.nan, math.nan
        return float(values.max()), float(values.mean())

    def event(self, replaying: bool = False, finished: bool = False) -> ProgressEvent:
        wall = time.perf_counter() - self.started
        best, mean = self._stats()
        speed = (self.sim_time - self.sim_time_at_start) / wall if wall > 0 else math.nan
        return ProgressEvent(self.run_id, self.births, self.config.births, self.sim_time, best,
                             mean, len(self.population), speed, wall, replaying, finished)

    def _progress(self, replaying: bool = False) -> None:
        self.emit(self.event(replaying=replaying))

    def done(self) -> bool:
        limit = self.config.max_sim_time
        return self.births >= self.config.births or (limit is not None and self.sim_time >= limit)

    def summary(self, status: str) -> RunSummary:
        best, mean = self._stats()
        return RunSummary(self.run_id, self.seed, self.births, self.sim_time, best, mean,
                          len(self.population), time.perf_counter() - self.started, status)


def _json_norm(value: Any) -> Any:
    import json

    return json.loads(json.dumps(value, sort_keys=True))


# ---------------------------------------------------------------------------------------------
# Offline


class _OfflineRun(_Run):
    def __init__(self, job: RunJob, store: Store, emit: Callable[[ProgressEvent], None],
                 evaluator: Evaluator) -> None:
        super().__init__(job, store, emit)
        self.evaluator = evaluator

    def restore(self, checkpoint: Checkpoint) -> None:
        self.births = checkpoint.births
        self.sim_time = checkpoint.sim_time
        self.sim_time_at_start = checkpoint.sim_time
        self.generation = checkpoint.generation
        self.rng.bit_generator.state = checkpoint.rng_state
        self.last_diversity_births = checkpoint.engine_state.get("last_diversity_births")
        members = checkpoint.engine_state["population"]
        ids = [m[0] for m in members]
        records = {r.robot_id: r for r in self.store.robots(self.run_id, ids)}
        learned_ids = set(checkpoint.engine_state.get("learned", []))
        learned = {r.robot_id: r.learned_genome
                   for r in self.store.learning(self.run_id, sorted(learned_ids))}
        self.population = []
        for robot_id, fitness in members:
            record = records[robot_id]
            life = Lifecycle(robot_id, self.timing, Stage.MATURITY, record.birth_time)
            if robot_id in learned_ids:
                genome = learned.get(robot_id)
                if genome is None:
                    raise StoreError(
                        f"run {self.run_id}: robot {robot_id} reproduces with its learned genome "
                        "but the learning table has none; the database is incomplete"
                    )
                robot = _decode(genome)
            else:
                robot = record.robot()
            self.population.append(_Member(robot_id, robot, life, fitness,
                                           learned=robot_id in learned_ids))

    def engine_state(self) -> dict[str, Any]:
        state: dict[str, Any] = {"population": [[m.robot_id, m.fitness] for m in self.population]}
        learned = [m.robot_id for m in self.population if m.learned]
        if learned:
            state["learned"] = learned
        return state

    def make_generation(
        self, count: int, parents: Sequence[_Member], random: bool = False
    ) -> list[_Member]:
        """Conceive, deliver and evaluate ``count`` robots (all returned, some maybe dead)."""
        config = self.config
        span = config.seconds_per_evaluation
        members: list[_Member] = []
        records: list[RobotRecord] = []
        for i in range(count):
            t0 = self.sim_time + i * span
            robot, pa, pb, origin = self.conceive(parents, t0, random)
            member, record = self.new_member(robot, (pa, pb), origin, t0, t0)
            members.append(member)
            records.append(record)
        self.batch.robots.extend(records)
        tasks = [
            EvalTask(m.robot_id, rec.genome, config.insertion, config.evaluation_time,
                     evaluation_seed(self.seed, m.robot_id), self.job.infancy)
            for m, rec in zip(members, records)
        ]
        outcomes = self.evaluator.evaluate(tasks)
        for record, member, outcome in zip(records, members, outcomes, strict=True):
            assert record.birth_time is not None
            self._record_outcome(member, outcome, record.birth_time)
        self.sim_time += count * span
        return members

    def _record_outcome(self, member: _Member, outcome: EvalOutcome, born: float) -> None:
        config = self.config
        life = member.lifecycle
        end = born + config.seconds_per_evaluation
        if self.infancy is not None:
            self.record_infancy(member, born, outcome.learner_failure, outcome.learning,
                                outcome.learned_genome)
        if (outcome.failure is not None or outcome.fitness is None
                or not math.isfinite(outcome.fitness)):
            # A non-finite fitness cannot be ranked (selection needs finite values) nor stored.
            cause = outcome.failure or f"evaluation gave no finite fitness ({outcome.fitness})"
            self.batch.failures.append(FailureRecord(member.robot_id, end, "evaluation", cause))
            life.die(end, cause)
            self.batch.deaths.append((member.robot_id, end, cause, None))
            return
        life.advance_to_age(config.fertile_age)
        member.fitness = float(outcome.fitness)
        self.batch.fitness.append(FitnessSample(member.robot_id, end, member.fitness,
                                                outcome.v, outcome.s))
        self.batch.fitness_updates.append((member.robot_id, member.fitness))

    def select(self, pool: list[_Member]) -> list[_Member]:
        mu = self.config.population_size
        if len(pool) <= mu:
            return pool
        if self.config.survivor_selection == "fitness":
            from evolution.selection import mu_plus_lambda

            keep = mu_plus_lambda(np.array([m.fitness for m in pool], dtype=float), mu)
        else:
            from evolution.selection import random_survivors

            keep = random_survivors(len(pool), mu, self.rng)
        kept = {int(i) for i in keep}
        survivors = [m for i, m in enumerate(pool) if i in kept]
        for i, m in enumerate(pool):
            if i not in kept:
                self.kill(m, self.sim_time, "survivor selection")
        return survivors

    def run(self) -> None:
        config = self.config
        checkpoint = self.store.checkpoint(self.run_id)
        if checkpoint is not None:
            self.restore(checkpoint)
        else:
            # Generation 0: random robots until the population is full (a robot lost in its
            # evaluation is replaced; it still counts as a birth).
            while len(self.population) < config.population_size and not self.done():
                need = min(config.population_size - len(self.population),
                           config.births - self.births)
                born = self.make_generation(need, [], random=True)
                self.flush_transitions(born)
                self.population.extend(m for m in born if m.lifecycle.alive)
            self.commit(self.engine_state(), [])
        while not self.done():
            self.generation += 1
            count = min(config.offspring_size, config.births - self.births)
            parents = list(self.population)
            children = self.make_generation(count, parents)
            pool = parents + [c for c in children if c.lifecycle.alive]
            self.population = self.select(pool)
            self.flush_transitions(parents + children)
            self.commit(self.engine_state(), [])


# ---------------------------------------------------------------------------------------------
# Online


class _OnlineRun(_Run):
    def __init__(self, job: RunJob, store: Store, emit: Callable[[ProgressEvent], None],
                 world: OnlineWorld) -> None:
        super().__init__(job, store, emit)
        self.world = world
        self.dead: list[_Member] = []

    def position(self, time_s: float) -> tuple[float, float]:
        """A random point within ``birth_radius`` of the origin, away from other robots."""
        config = self.config
        occupied = np.array(list(self.world.positions().values()), dtype=float).reshape(-1, 2)
        best, best_gap = (0.0, 0.0), -math.inf
        for _ in range(100):
            r = config.birth_radius * math.sqrt(self.rng.random())
            a = 2 * math.pi * self.rng.random()
            point = (r * math.cos(a), r * math.sin(a))
            gap = (float(np.min(np.hypot(occupied[:, 0] - point[0], occupied[:, 1] - point[1])))
                   if len(occupied) else math.inf)
            if gap >= config.birth_clearance:
                return point
            if gap > best_gap:
                best, best_gap = point, gap
        self.batch.failures.append(FailureRecord(
            self.births, time_s, "crowded",
            f"no position {config.birth_clearance} m from the others; best gap {best_gap:.3f} m"))
        return best

    def give_birth(self, time_s: float, random: bool = False) -> None:
        mature = [m for m in self.population if m.lifecycle.fertile]
        robot, pa, pb, origin = self.conceive(mature, time_s, random)
        position = self.position(time_s)
        member, record = self.new_member(robot, (pa, pb), origin, time_s, time_s)
        living = robot
        if self.infancy is not None:
            # The Training Center: a separate simulation before the robot enters the world.
            report = run_infancy(self.infancy, robot, evaluation_seed(self.seed, member.robot_id))
            living = report.robot
            genome = _genome(living) if report.changed else None
            self.record_infancy(member, time_s, report.failure, report.learning, genome,
                                living if report.changed else None)
        member.agent = self.world.add(living, position)
        self.batch.robots.append(record)
        self.population.append(member)

    def update(self, now: float) -> None:
        """Advance the world to ``now``, then age, sample and bury."""
        statuses = self.world.advance_to(now)
        self.sim_time = now
        for m in list(self.population):
            status = statuses.get(m.agent or "")
            if status is None:
                continue
            m.fitness = status.fitness
            if status.removed is not None:
                cause = f"blow-up: {status.removed}"
                self.batch.failures.append(FailureRecord(m.robot_id, now, "blow-up", status.removed))
                self._bury(m, now, cause, remove=False)
                continue
            assert m.lifecycle.birth_time is not None
            m.lifecycle.advance_to_age(now - m.lifecycle.birth_time)
            self.batch.fitness.append(FitnessSample(m.robot_id, now, status.fitness,
                                                    status.v, status.s))
            self.batch.fitness_updates.append((m.robot_id, status.fitness))

    def _bury(self, member: _Member, now: float, cause: str, remove: bool = True) -> None:
        if remove and member.agent is not None:
            self.world.remove(member.agent)
        self.kill(member, now, cause)
        self.population.remove(member)
        self.dead.append(member)

    def select(self, now: float) -> None:
        """The online survivor rule over the mature robots."""
        from evolution.selection import online_survivors

        config = self.config
        mature = [m for m in self.population
                  if m.lifecycle.fertile and m.fitness is not None and math.isfinite(m.fitness)]
        spared = len(self.population) - len(mature)
        if not mature:
            return
        fitness = np.array([m.fitness for m in mature], dtype=float)
        # The bounds count every living robot; only the mature ones can be selected.
        min_alive = max(0, config.min_alive - spared)
        doomed_indices = online_survivors(
            fitness,
            min_alive=min_alive,
            max_alive=max(min_alive, config.max_alive - spared),
            threshold=config.death_threshold,
            cull_fraction=config.cull_fraction,
        )
        doomed = [int(i) for i in doomed_indices]
        if config.survivor_selection == "random" and doomed:
            doomed = [int(i) for i in self.rng.choice(len(mature), size=len(doomed), replace=False)]
        for i in sorted(doomed):
            self._bury(mature[i], now, "survivor selection")

    def engine_state(self) -> dict[str, Any]:
        return {"alive": [m.robot_id for m in self.population]}

    def run(self) -> None:
        config = self.config
        checkpoint = self.store.checkpoint(self.run_id)
        if checkpoint is not None:
            self.replay_until = checkpoint
            self.stored_genomes = {r.robot_id: r.genome for r in self.store.robots(self.run_id)}
        for _ in range(config.population_size):
            self.give_birth(0.0, random=True)
        self._commit_online(force=True)
        # Tick k falls at k * interval, not a running sum, so float drift never delays a
        # maturity or a birth by one tick (e.g. with a 0.1 s interval).
        tick = 1
        next_tick = config.conception_interval
        while not self.done():
            self.update(next_tick)
            self.select(next_tick)
            while len(self.population) < config.min_alive and self.births < config.births:
                self.give_birth(next_tick)
            if self.births < config.births:
                self.give_birth(next_tick)
            self.generation += 1
            tick += 1
            next_tick = tick * config.conception_interval
            self._commit_online(force=self.done())

    def _commit_online(self, force: bool) -> None:
        if force or self.births - self.last_commit_births >= self.config.checkpoint_interval:
            members = self.population + self.dead
            self.dead = []
            self.commit(self.engine_state(), members)


# ---------------------------------------------------------------------------------------------


def execute_run(job: RunJob, evaluator: Evaluator, emit: Callable[[Any], None]) -> RunSummary:
    """Execute (or continue) one run to its end, writing to ``job.db_path``.

    A KeyboardInterrupt (or any error) stops the run after the last commit point; the run's
    status becomes ``interrupted`` and the exception propagates.
    """
    store = Store.open(job.db_path)
    run: _Run | None = None
    world: OnlineWorld | None = None
    try:
        store.set_status(job.run_id, "running")
        if job.config.engine == "offline":
            run = _OfflineRun(job, store, emit, evaluator)
        else:
            factory = job.world_factory or default_world
            world = factory(job.config, run_seed(job.config.seed, job.run_id))
            run = _OnlineRun(job, store, emit, world)
        try:
            run.run()
        except _StopRun:
            store.set_status(job.run_id, "interrupted")
            return run.summary("interrupted")
        store.set_status(job.run_id, "finished")
        emit(run.event(finished=True))
        return run.summary("finished")
    except BaseException:
        # Best effort: the original error, re-raised below, matters more than a failed status
        # update (whatever its type: a closed or broken database).
        try:
            store.set_status(job.run_id, "interrupted")
        except Exception:  # noqa: BLE001, S110
            pass
        raise
    finally:
        if world is not None:
            world.close()
        store.close()


def default_world(config: ExperimentConfig, seed: int) -> OnlineWorld:
    """The population environment of :mod:`revolve_env.envs.population` as an online world."""
    from evolution._online_world import PopulationWorld

    return PopulationWorld(config, seed)
