"""The online engine: the whole population in one world, asynchronous births and deaths.

``population_size`` random robots are born at time 0 at random free positions. Every
``conception_interval`` seconds of simulated time: robots that died in the world (blow-ups) are
recorded; survivor selection applies the online rule to the *mature* robots (infants have no full
fitness window yet; the population never drops below ``min_alive`` through selection and is culled
when it reaches ``max_alive``); then one robot is conceived from two mature parents chosen by
tournament on their current sliding-window fitness and born at a random free position within
``birth_radius`` of the origin (the population env's placement rule,
:func:`revolve_env.envs.placement.place`: when the disc is crowded the newborn goes to the
nearest free spot outside it, recorded as a ``crowded`` event; a birth never stops a run). If
blow-ups leave fewer than ``min_alive`` robots, extra robots
are conceived at once. A commit point is every ``checkpoint_interval`` births.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from evolution.evaluation import evaluation_seed, run_infancy
from evolution.experiments.run import Member, OnlineWorld, ProgressEvent, RunJob, RunState
from evolution.experiments.store import FailureRecord, FitnessSample, Store
from evolution.selection import online_survivors

__all__ = ["OnlineRun"]


class OnlineRun(RunState):
    """One online run: the whole population in ``world``, a birth every conception interval."""

    def __init__(self, job: RunJob, store: Store, emit: Callable[[ProgressEvent], None],
                 world: OnlineWorld) -> None:
        super().__init__(job, store, emit)
        self.world = world
        self.dead: list[Member] = []

    def give_birth(self, time_s: float, random: bool = False) -> None:
        """Conceive a robot (from two mature parents, or at random), train it, and deliver it."""
        mature = [m for m in self.population if m.lifecycle.fertile]
        robot, pa, pb, origin = self.conceive(mature, time_s, random)
        member, record = self.new_member(robot, (pa, pb), origin, time_s, time_s)
        living = robot
        if self.infancy is not None:
            # The Training Center: a separate simulation before the robot enters the world.
            report = run_infancy(self.infancy, robot, evaluation_seed(self.seed, member.robot_id))
            living = report.robot
            self.record_infancy(member, time_s, report.failure, report.learning,
                                living if report.changed else None)
        self.batch.robots.append(record)
        try:
            birth = self.world.add(living)
        except ValueError as error:
            # The engine cannot build this body (e.g. MuJoCo refuses its geometry): the robot is
            # born dead. Recorded, and the run goes on.
            cause = f"not built: {error}"
            self.batch.failures.append(FailureRecord(member.robot_id, time_s, "birth", cause))
            self.kill(member, time_s, cause)
            self.dead.append(member)
            return
        member.agent = birth.agent
        if not birth.inside:
            x, y = birth.position
            self.batch.failures.append(FailureRecord(
                member.robot_id, time_s, "crowded",
                f"the birth disc was full; born at the nearest free spot ({x:.3f}, {y:.3f}) m"))
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
                self.batch.failures.append(
                    FailureRecord(m.robot_id, now, "blow-up", status.removed))
                self._bury(m, now, cause, remove=False)
                continue
            assert m.lifecycle.birth_time is not None
            m.lifecycle.advance_to_age(now - m.lifecycle.birth_time)
            self.batch.fitness.append(FitnessSample(m.robot_id, now, status.fitness,
                                                    status.v, status.s))
            self.batch.fitness_updates.append((m.robot_id, status.fitness))

    def _bury(self, member: Member, now: float, cause: str, remove: bool = True) -> None:
        if remove and member.agent is not None:
            self.world.remove(member.agent)
        self.kill(member, now, cause)
        self.population.remove(member)
        self.dead.append(member)

    def select(self, now: float) -> None:
        """The online survivor rule over the mature robots."""
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
        """What a checkpoint records beyond the generator: the living robots."""
        return {"alive": [m.robot_id for m in self.population]}

    def run(self) -> None:
        """Run to the end (replaying up to the last checkpoint on resume)."""
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
