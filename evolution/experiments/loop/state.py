"""The state of one run and the steps both modes share: conception, birth, infancy, death.

:class:`RunState` holds what a run is at any moment (its generator, counters, population and
the records of the step under way) and the rules both modes apply: two tournament parents or a
random robot, birth, the Training Center's outcome, death, and the close of a step (population
snapshot, diversity, checkpoint). It knows no store and no display: the loop
(:class:`~evolution.experiments.loop.evolve.Evolution`) hands each closed
:class:`~evolution.experiments.loop.run.Step` to its observers, one of which may write it.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable, Sequence

import numpy as np

from evolution.diversity import diversity
from evolution.evaluation import LearningSummary
from evolution.experiments.loop.config import ExperimentConfig
from evolution.experiments.loop.records import (
    Batch,
    Checkpoint,
    FailureRecord,
    LearningRecord,
    RobotRecord,
)
from evolution.experiments.loop.run import (
    Member,
    ProgressEvent,
    Replay,
    ReplayError,
    RunSummary,
    Step,
    check_infancy,
    genome,
    json_norm,
    run_seed,
)
from evolution.lifecycle import InfancyHook, Lifecycle, LifecycleTiming
from evolution.operators import reproduce
from evolution.random_robot import random_robot
from evolution.selection import select_parents
from revolve_env.body.robot import Robot

__all__ = ["RunState"]


class RunState:
    """State and shared steps of one run (both modes).

    Args:
        config: The experiment.
        run_id: The run (its seed is :func:`~evolution.experiments.loop.run.run_seed`).
        infancy: The Training Center's hook, or ``None``.

    Attributes:
        on_born: Called with every newborn once its infancy is over, before its learning record
            is made (the loop tells its observers; the store observer saves a learned policy).
        begun: Whether the initial population is made (or restored from a checkpoint).
        replay: Set while the run resumes by replay
            (:class:`~evolution.experiments.loop.run.Replay`).
    """

    def __init__(self, config: ExperimentConfig, run_id: int,
                 infancy: InfancyHook | None) -> None:
        check_infancy(infancy)
        self.config = config
        self.run_id = run_id
        self.seed = run_seed(config.seed, run_id)
        self.timing = LifecycleTiming(config.insertion, config.fertile_age)
        self.rng = np.random.default_rng(self.seed)
        self.births = 0
        self.sim_time = 0.0
        self.generation = 0
        self.begun = False
        self.batch = Batch()
        self.population: list[Member] = []
        self.last_diversity_births: int | None = None
        self.last_commit_births = 0
        self.started = time.perf_counter()
        self.sim_time_at_start = 0.0
        self.replay: Replay | None = None
        self.failure_counts: Counter[str] = Counter()
        self.infancy = infancy
        self.lamarckian = bool(getattr(infancy, "lamarckian", False))
        self.on_born: Callable[[Member], None] = lambda member: None

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
        if self.replay is not None and self.replay.genomes.get(robot_id, stored) != stored:
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

    def infancy_over(self, member: Member, time_s: float, failure: str | None = None,
                     learning: LearningSummary | None = None,
                     learned: Robot | None = None) -> None:
        """Record what the Training Center did for ``member`` (born at ``time_s``).

        The member gets the learned policy, if any; then :attr:`on_born` is told of it; then
        its learning record is made (with the policy's reference, if one was kept). Under
        Lamarckian inheritance the learned robot (``None``: nothing learned) becomes the genome
        it passes on.
        """
        if failure is not None:
            self.batch.failures.append(FailureRecord(member.robot_id, time_s, "learner", failure))
            learning = None
        if learning is not None and learning.policy is not None:
            member.policy = learning.policy
        self.on_born(member)
        if learning is None:
            return
        self.batch.learning.append(LearningRecord(
            member.robot_id, time_s, "lamarckian" if self.lamarckian else "darwinian",
            genome(learned) if learned is not None else None, learning.inborn_fitness,
            learning.learned_fitness, learning.evaluations, learning.sim_seconds,
            learning.failures, member.policy_ref))
        if self.lamarckian and learned is not None:
            member.robot = learned
            member.learned = True

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
        """Take the clock, counters and generator of a checkpoint (both modes' resume)."""
        self.births = checkpoint.births
        self.sim_time = checkpoint.sim_time
        self.sim_time_at_start = checkpoint.sim_time
        self.generation = checkpoint.generation
        self.rng.bit_generator.state = checkpoint.rng_state
        self.last_diversity_births = checkpoint.engine_state.get("last_diversity_births")
        self.last_commit_births = checkpoint.births
        self.begun = True

    def diversity_due(self) -> bool:
        """True when this commit point should measure the population's diversity."""
        interval = self.config.diversity_interval
        if interval == 0:
            return False
        if self.last_diversity_births is None:
            return True
        return self.births // interval > self.last_diversity_births // interval

    def close_step(self, engine_state: dict[str, object], flushed: Sequence[Member]) -> Step:
        """End the step at a commit point: its records, population, diversity and checkpoint.

        While replaying, a step before the stored checkpoint is ``replayed``; the one that
        reaches it is checked against it (births and generator) and ends the replay.

        Raises:
            ReplayError: the replay reached the checkpoint's births in another state.
        """
        self.last_commit_births = self.births
        self.flush_transitions(flushed)
        batch, self.batch = self.batch, Batch()
        batch.population = [(m.robot_id, m.fitness) for m in self.population]
        if self.diversity_due():
            batch.diversity = float(diversity([m.robot for m in self.population]))
            self.last_diversity_births = self.births
        engine_state = {**engine_state, "last_diversity_births": self.last_diversity_births}
        checkpoint = Checkpoint(self.births, self.sim_time, self.generation,
                                dict(self.rng.bit_generator.state), engine_state)
        replay = self.replay
        if replay is None:
            self.failure_counts.update(f.kind for f in batch.failures)
            return Step(batch, checkpoint)
        target = replay.until
        if self.births >= target.births:
            same_rng = json_norm(checkpoint.rng_state) == json_norm(target.rng_state)
            if self.births != target.births or not same_rng:
                raise ReplayError(
                    f"run {self.run_id}: replay reached {self.births} births with a different "
                    f"state than the checkpoint ({target.births} births); cannot resume exactly"
                )
            self.replay = None
            self.started = time.perf_counter()
            self.sim_time_at_start = self.sim_time
        return Step(batch, checkpoint, replayed=True)

    # -- where the run stands ----------------------------------------------------------------

    def _stats(self) -> tuple[float, float]:
        values = np.array([m.fitness for m in self.population
                           if m.fitness is not None and math.isfinite(m.fitness)], dtype=float)
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

    def done(self) -> bool:
        """True once the run reached its births or its simulated-time limit."""
        limit = self.config.max_sim_time
        return self.births >= self.config.births or (limit is not None and self.sim_time >= limit)

    def summary(self, status: str) -> RunSummary:
        """How the run ended (``status``: ``finished`` or ``interrupted``)."""
        best, mean = self._stats()
        return RunSummary(self.run_id, self.seed, self.births, self.sim_time, best, mean,
                          len(self.population), time.perf_counter() - self.started, status)
