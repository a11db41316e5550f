"""The offline engine: generations of isolated evaluations, (mu + lambda) survivors.

Generation 0 is ``population_size`` random robots. Each later generation conceives
``offspring_size`` children (the last one fewer, to stop at exactly ``births``), evaluates them in
parallel (each alone, ``insertion`` + ``evaluation_time`` seconds, under the config's
``[evaluation]`` conditions: by default a random heading at the origin), and keeps
``population_size`` of parents + children (fitness: the fittest; random: uniformly). The simulated
clock advances by one evaluation per child, as if the robots were evaluated one after another as
in the paper. A commit point is one generation. Resume reloads the population from the store and
the generator's state from the checkpoint.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from evolution.evaluation import EvalOutcome, EvalTask, Evaluator, evaluation_seed
from evolution.experiments.remote_store import RunStore
from evolution.experiments.run import Member, ProgressEvent, RunJob, RunState, decode
from evolution.experiments.store import (
    Checkpoint,
    FailureRecord,
    FitnessSample,
    RobotRecord,
    StoreError,
)
from evolution.lifecycle import Lifecycle, Stage
from evolution.selection import mu_plus_lambda, random_survivors

__all__ = ["OfflineRun"]


class OfflineRun(RunState):
    """One offline run: generations evaluated by ``evaluator``, (mu + lambda) survivors."""

    def __init__(self, job: RunJob, store: RunStore, emit: Callable[[ProgressEvent], None],
                 evaluator: Evaluator) -> None:
        super().__init__(job, store, emit)
        self.evaluator = evaluator

    def restore(self, checkpoint: Checkpoint) -> None:
        """Continue from a checkpoint: clock, generator and population from the store."""
        self.restore_counters(checkpoint)
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
                robot = decode(genome)
            else:
                robot = record.robot()
            self.population.append(Member(robot_id, robot, life, fitness,
                                           learned=robot_id in learned_ids))

    def engine_state(self) -> dict[str, Any]:
        """What a checkpoint needs beyond the generator: the population and who learned."""
        state: dict[str, Any] = {"population": [[m.robot_id, m.fitness] for m in self.population]}
        learned = [m.robot_id for m in self.population if m.learned]
        if learned:
            state["learned"] = learned
        return state

    def make_generation(
        self, count: int, parents: Sequence[Member], random: bool = False
    ) -> list[Member]:
        """Conceive, deliver and evaluate ``count`` robots (all returned, some maybe dead)."""
        config = self.config
        span = config.seconds_per_evaluation
        members: list[Member] = []
        records: list[RobotRecord] = []
        for i in range(count):
            t0 = self.sim_time + i * span
            robot, pa, pb, origin = self.conceive(parents, t0, random)
            member, record = self.new_member(robot, (pa, pb), origin, t0, t0)
            members.append(member)
            records.append(record)
        self.batch.robots.extend(records)
        tasks = [
            EvalTask(m.robot_id, m.robot, config.insertion, config.evaluation_time,
                     evaluation_seed(self.seed, m.robot_id), self.job.infancy,
                     engine=config.world.engine, conditions=config.evaluation)
            for m in members
        ]
        outcomes = self.evaluator.evaluate(tasks)
        for record, member, outcome in zip(records, members, outcomes, strict=True):
            assert record.birth_time is not None
            self._record_outcome(member, outcome, record.birth_time)
        self.sim_time += count * span
        return members

    def _record_outcome(self, member: Member, outcome: EvalOutcome, born: float) -> None:
        config = self.config
        life = member.lifecycle
        end = born + config.seconds_per_evaluation
        if self.infancy is not None:
            self.record_infancy(member, born, outcome.learner_failure, outcome.learning,
                                outcome.learned)
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

    def select(self, pool: list[Member]) -> list[Member]:
        """Survivor selection over parents + children; the others die."""
        mu = self.config.population_size
        if len(pool) <= mu:
            return pool
        if self.config.survivor_selection == "fitness":
            keep = mu_plus_lambda(np.array([m.fitness for m in pool], dtype=float), mu)
        else:
            keep = random_survivors(len(pool), mu, self.rng)
        kept = {int(i) for i in keep}
        survivors = [m for i, m in enumerate(pool) if i in kept]
        for i, m in enumerate(pool):
            if i not in kept:
                self.kill(m, self.sim_time, "survivor selection")
        return survivors

    def run(self) -> None:
        """Run (or continue) to the end, committing every generation."""
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
