"""Offline evolution: generations of isolated evaluations, (mu + lambda) survivors.

Generation 0 is ``population_size`` random robots. Each later generation conceives
``offspring_size`` children (the last one fewer, to stop at exactly ``births``), evaluates them in
parallel (each alone, ``insertion`` + ``evaluation_time`` seconds, under the config's
``[evaluation]`` conditions: by default a random heading at the origin), and keeps
``population_size`` of parents + children (fitness: the fittest; random: uniformly). The simulated
clock advances by one evaluation per child, as if the robots were evaluated one after another as
in the paper. A step (commit point) is one generation. Resume reloads the population from the
store and the generator's state from the checkpoint.

:meth:`OfflineMode.ask` conceives the robots to evaluate and returns their tasks;
:meth:`OfflineMode.tell` takes their outcomes and closes the generation; :meth:`OfflineMode.step`
is both, evaluating with the mode's evaluator. Generation 0 replaces robots lost in their
evaluation, so it may take more than one ask/tell.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from evolution.evaluation import EvalOutcome, EvalTask, Evaluator, evaluation_seed
from evolution.experiments.loop.config import ExperimentConfig
from evolution.experiments.loop.errors import StoreError
from evolution.experiments.loop.records import (
    Checkpoint,
    FailureRecord,
    FitnessSample,
    RobotRecord,
)
from evolution.experiments.loop.run import Member, Step, StoredRun, decode
from evolution.experiments.loop.state import RunState
from evolution.lifecycle import InfancyHook, Lifecycle, Stage
from evolution.selection import mu_plus_lambda, random_survivors
from revolve_env.body.robot import Robot

__all__ = ["OfflineMode", "evaluation_tasks"]


def evaluation_tasks(config: ExperimentConfig, robots: Sequence[tuple[int, Robot, int]],
                     infancy: InfancyHook | None) -> list[EvalTask]:
    """How an offline run of ``config`` evaluates robots: one task per ``(id, robot, seed)``.

    Its timing, engine, terrain, conditions and task are the config's; ``infancy`` is the run's
    Training Center (``None``: none). The study's time estimate calibrates with the same tasks.
    """
    task = config.fitness_task()
    return [EvalTask(robot_id, robot, config.insertion, config.evaluation_time, seed, infancy,
                     engine=config.world.engine, conditions=config.evaluation, task=task,
                     terrain=config.world.terrain_spec)
            for robot_id, robot, seed in robots]


class OfflineMode:
    """Offline evolution of one run: generations evaluated by ``evaluator``.

    Args:
        state: The run's state.
        evaluator: Evaluates each generation's robots (:meth:`step`).
    """

    def __init__(self, state: RunState, evaluator: Evaluator) -> None:
        self.state = state
        self.evaluator = evaluator
        self._asked: list[tuple[Member, RobotRecord]] | None = None
        self._parents: list[Member] = []

    # -- resume --------------------------------------------------------------------------------

    def resume(self, checkpoint: Checkpoint, store: StoredRun,
               trust_pickled_policies: bool = False) -> None:
        """Continue from a checkpoint: clock, generator and population from the store.

        Raises:
            StoreError: a member reproduces with a learned genome the store does not hold.
        """
        state = self.state
        state.restore_counters(checkpoint)
        members = checkpoint.engine_state["population"]
        ids = [m[0] for m in members]
        records = {r.robot_id: r for r in store.robots(state.run_id, ids)}
        learned_ids = set(checkpoint.engine_state.get("learned", []))
        learned = {r.robot_id: r.learned_genome
                   for r in store.learning(state.run_id, sorted(learned_ids))}
        state.population = []
        for robot_id, fitness in members:
            record = records[robot_id]
            life = Lifecycle(robot_id, state.timing, Stage.MATURITY, record.birth_time)
            if robot_id in learned_ids:
                genome = learned.get(robot_id)
                if genome is None:
                    raise StoreError(
                        f"run {state.run_id}: robot {robot_id} reproduces with its learned "
                        "genome but the learning table has none; the database is incomplete"
                    )
                robot = decode(genome)
            else:
                robot = record.robot()
            state.population.append(Member(robot_id, robot, life, fitness,
                                           learned=robot_id in learned_ids))

    def engine_state(self) -> dict[str, Any]:
        """What a checkpoint needs beyond the generator: the population and who learned."""
        population = self.state.population
        state: dict[str, Any] = {"population": [[m.robot_id, m.fitness] for m in population]}
        learned = [m.robot_id for m in population if m.learned]
        if learned:
            state["learned"] = learned
        return state

    def snapshot(self) -> None:
        """Nothing beyond the checkpoint: an offline run resumes from its store alone."""

    # -- a generation ----------------------------------------------------------------------

    def ask(self) -> list[EvalTask]:
        """Conceive and deliver the next robots to evaluate; their evaluation tasks.

        Generation 0 (random robots) until the population is full, then ``offspring_size``
        children of tournament parents (fewer to stop at exactly ``births``).

        Raises:
            RuntimeError: the last tasks were not told yet.
        """
        if self._asked is not None:
            raise RuntimeError("ask() again before tell(): give the outcomes of the robots "
                               "asked for first")
        state, config = self.state, self.state.config
        if state.begun:
            state.generation += 1
            count = min(config.offspring_size, config.births - state.births)
            self._parents = list(state.population)
        else:
            count = min(config.population_size - len(state.population),
                        config.births - state.births)
            self._parents = []
        span = config.seconds_per_evaluation
        asked: list[tuple[Member, RobotRecord]] = []
        for i in range(count):
            t0 = state.sim_time + i * span
            robot, pa, pb, origin = state.conceive(self._parents, t0, random=not state.begun)
            asked.append(state.new_member(robot, (pa, pb), origin, t0, t0))
        state.batch.robots.extend(record for _, record in asked)
        self._asked = asked
        return evaluation_tasks(config, [(m.robot_id, m.robot, evaluation_seed(state.seed,
                                                                               m.robot_id))
                                         for m, _ in asked], state.infancy)

    def tell(self, outcomes: Sequence[EvalOutcome]) -> Step | None:
        """Record the outcomes of the robots asked for (in task order); close the generation.

        Returns:
            The step, or ``None`` while generation 0 still needs robots (one was lost in its
            evaluation): :meth:`ask` again.

        Raises:
            RuntimeError: nothing was asked.
            ValueError: not one outcome per task.
        """
        asked, self._asked = self._asked, None
        if asked is None:
            raise RuntimeError("tell() without ask(): ask for the robots to evaluate first")
        if len(outcomes) != len(asked):
            raise ValueError(f"tell() takes one outcome per task asked ({len(asked)}), "
                             f"got {len(outcomes)}")
        state, config = self.state, self.state.config
        for (member, record), outcome in zip(asked, outcomes, strict=True):
            assert record.birth_time is not None
            self._record_outcome(member, outcome, record.birth_time)
        state.sim_time += len(asked) * config.seconds_per_evaluation
        born = [member for member, _ in asked]
        if not state.begun:
            # Generation 0: a robot lost in its evaluation is replaced (it still counts as a
            # birth) until the population is full.
            state.flush_transitions(born)
            state.population.extend(m for m in born if m.lifecycle.alive)
            if len(state.population) < config.population_size and not state.done():
                return None
            state.begun = True
            return state.close_step(self.engine_state(), [])
        parents = self._parents
        state.population = self.select(parents + [c for c in born if c.lifecycle.alive])
        state.flush_transitions(parents + born)
        return state.close_step(self.engine_state(), [])

    def step(self) -> Step:
        """One generation, evaluated by the mode's evaluator (generation 0 first)."""
        while True:
            step = self.tell(self.evaluator.evaluate(self.ask()))
            if step is not None:
                return step

    def _record_outcome(self, member: Member, outcome: EvalOutcome, born: float) -> None:
        state, config = self.state, self.state.config
        life = member.lifecycle
        end = born + config.seconds_per_evaluation
        if state.infancy is not None:
            state.infancy_over(member, born, outcome.learner_failure, outcome.learning,
                               outcome.learned)
        else:
            state.infancy_over(member, born)
        if (outcome.failure is not None or outcome.fitness is None
                or not math.isfinite(outcome.fitness)):
            # A non-finite fitness cannot be ranked (selection needs finite values) nor stored.
            cause = outcome.failure or f"evaluation gave no finite fitness ({outcome.fitness})"
            state.batch.failures.append(FailureRecord(member.robot_id, end, "evaluation", cause))
            life.die(end, cause)
            state.batch.deaths.append((member.robot_id, end, cause, None))
            return
        life.advance_to_age(config.fertile_age)
        member.fitness = float(outcome.fitness)
        state.batch.fitness.append(FitnessSample(member.robot_id, end, member.fitness,
                                                 outcome.v, outcome.s, outcome.shaking))
        state.batch.fitness_updates.append((member.robot_id, member.fitness))

    def select(self, pool: list[Member]) -> list[Member]:
        """Survivor selection over parents + children; the others die."""
        state = self.state
        mu = state.config.population_size
        if len(pool) <= mu:
            return pool
        if state.config.survivor_selection == "fitness":
            keep = mu_plus_lambda(np.array([m.fitness for m in pool], dtype=float), mu)
        else:
            keep = random_survivors(len(pool), mu, state.rng)
        kept = {int(i) for i in keep}
        survivors = [m for i, m in enumerate(pool) if i in kept]
        for i, m in enumerate(pool):
            if i not in kept:
                state.kill(m, state.sim_time, "survivor selection")
        return survivors
