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

Resume. On a world that restores its state exactly (:class:`~evolution.experiments.run.
RestorableWorld` with ``exact_restore``: the population env on MuJoCo), every checkpoint but the
last also writes a snapshot file beside the database (:mod:`evolution.experiments.snapshot`):
the world's physics, controllers, generator and bookkeeping and the engine's population and
lifecycles. Resume restores it and goes on from the checkpoint, bit-identical to an
uninterrupted run, at a cost proportional to the work since the checkpoint. Otherwise (pybullet,
a database from before snapshots, a missing or damaged file, a world that refuses the snapshot)
the run is replayed from its start, as before, with a logged note saying why.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from evolution.evaluation import evaluation_seed, run_infancy
from evolution.experiments import snapshot
from evolution.experiments.remote_store import RunStore
from evolution.experiments.run import (
    Member,
    OnlineWorld,
    ProgressEvent,
    RestorableWorld,
    RunJob,
    RunState,
    _json_norm,
    decode,
    genome,
)
from evolution.experiments.store import (
    Checkpoint,
    FailureRecord,
    FitnessSample,
    LearningRecord,
)
from evolution.lifecycle import LearningSummary, Lifecycle, Stage, stage_of
from evolution.selection import online_survivors

__all__ = ["OnlineRun"]

_log = logging.getLogger(__name__)


class OnlineRun(RunState):
    """One online run: the whole population in ``world``, a birth every conception interval."""

    def __init__(self, job: RunJob, store: RunStore, emit: Callable[[ProgressEvent], None],
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
        stored = self._stored_learning(member.robot_id)
        if stored is not None:
            # Replaying: the policy saved with the run, not a second training.
            assert stored.policy is not None
            member.policy_ref = stored.policy
            self.record_infancy(member, time_s, None, LearningSummary(
                stored.inborn_fitness, stored.learned_fitness, stored.evaluations,
                stored.sim_seconds, stored.failures, self.load_policy(robot, stored.policy)),
                None)
        elif self.infancy is not None:
            # The Training Center: a separate simulation before the robot enters the world.
            report = run_infancy(self.infancy, robot, evaluation_seed(self.seed, member.robot_id))
            living = report.robot
            self.record_infancy(member, time_s, report.failure, report.learning,
                                living if report.changed else None)
        self.batch.robots.append(record)
        try:
            # A robot with a policy is agent-controlled: the world asks the policy every step.
            birth = (self.world.add(living, member.robot_id) if member.policy is None
                     else self.world.add(living, member.robot_id, member.policy))
        except ValueError as error:
            # The engine cannot build this body (e.g. MuJoCo refuses its geometry): the robot is
            # born dead. Recorded, and the run goes on.
            cause = f"not built: {error}"
            self.batch.failures.append(FailureRecord(member.robot_id, time_s, "birth", cause))
            self.kill(member, time_s, cause)
            self.dead.append(member)
            return
        if not birth.inside:
            x, y = birth.position
            self.batch.failures.append(FailureRecord(
                member.robot_id, time_s, "crowded",
                f"the birth disc was full; born at the nearest free spot ({x:.3f}, {y:.3f}) m"))
        self.population.append(member)

    def _stored_learning(self, robot_id: int) -> LearningRecord | None:
        """While replaying, the stored learning record of ``robot_id`` if it has a policy."""
        if self.replay_until is None or robot_id not in self.stored_genomes:
            return None
        records = self.store.learning(self.run_id, [robot_id])
        return records[0] if records and records[0].policy is not None else None

    def update(self, now: float) -> None:
        """Advance the world to ``now``, then age, sample and bury."""
        statuses = self.world.advance_to(now)
        self.sim_time = now
        for m in list(self.population):
            status = statuses.get(m.robot_id)
            if status is None:
                continue
            if status.death is not None:
                # Lost: stored with no fitness (the world reports 0 m after a blow-up, which is
                # no measurement). It leaves the population here, so selection never sees it.
                reason = status.blow_up or status.death
                cause = f"blow-up: {reason}"
                self.batch.failures.append(FailureRecord(m.robot_id, now, "blow-up", reason))
                m.fitness = None
                self.batch.fitness_updates.append((m.robot_id, None))
                self._bury(m, now, cause, remove=False)
                continue
            m.fitness = status.fitness
            # Insertion and maturity on the world's clock (the env counts control periods).
            m.lifecycle.advance_to(stage_of(status.inserting, status.mature))
            self.batch.fitness.append(FitnessSample(m.robot_id, now, status.fitness,
                                                    status.v, status.s))
            self.batch.fitness_updates.append((m.robot_id, status.fitness))

    def _bury(self, member: Member, now: float, cause: str, remove: bool = True) -> None:
        if remove:
            self.world.remove(member.robot_id)
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
        """Run to the end (from the last checkpoint's snapshot, or replaying up to it)."""
        config = self.config
        checkpoint = self.store.checkpoint(self.run_id)
        if checkpoint is not None and self._restore(checkpoint):
            self._live()
            return
        if checkpoint is not None:
            self.replay_until = checkpoint
            self.stored_genomes = {r.robot_id: r.genome for r in self.store.robots(self.run_id)}
        for _ in range(config.population_size):
            self.give_birth(0.0, random=True)
        self._commit_online(force=True)
        self._live()

    def _live(self) -> None:
        """The conception ticks until the run is done."""
        config = self.config
        # Tick k falls at k * interval, not a running sum, so float drift never delays a
        # maturity or a birth by one tick (e.g. with a 0.1 s interval). Tick k follows
        # generation k - 1 (a resumed run picks up its count from the checkpoint).
        tick = self.generation + 1
        next_tick = tick * config.conception_interval
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
        self.store.prune_snapshots(self.run_id, keep=None)

    # -- snapshots ---------------------------------------------------------------------------

    def _restorable(self) -> RestorableWorld | None:
        world = self.world
        if isinstance(world, RestorableWorld) and world.exact_restore:
            return world
        return None

    def save_snapshot(self) -> dict[str, Any] | None:
        """Write the world's and the engine's state beside the database (see the module doc).

        Returns:
            The file's reference for the checkpoint, or ``None`` when the world cannot restore
            exactly or the run is done.
        """
        world = self._restorable()
        if world is None or self.done():
            return None
        engine = {
            "births": self.births, "sim_time": self.sim_time, "generation": self.generation,
            "rng": dict(self.rng.bit_generator.state),
            "population": [
                {"robot_id": m.robot_id, "genome": genome(m.robot),
                 "stage": None if m.lifecycle.stage is None else m.lifecycle.stage.value,
                 "birth_time": m.lifecycle.birth_time, "fitness": m.fitness,
                 "learned": m.learned, "policy": m.policy_ref,
                 "policy_state": None if m.policy is None else m.policy.get_state()}
                for m in self.population
            ],
        }
        path = snapshot.snapshot_path(self.job.db_path, self.run_id, self.births)
        try:
            return self.store.write_snapshot(self.run_id, self.births,
                                             {"engine": engine, "world": world.snapshot()})
        except OSError as e:
            # The results matter more than a fast resume: commit without a snapshot.
            _log.warning("run %d: cannot write the snapshot %s (%s); a resume from this "
                         "checkpoint will replay", self.run_id, path, e.strerror or e)
            return None

    def committed(self, written: dict[str, Any] | None) -> None:
        """Delete the run's older snapshot files once a newer one is referenced."""
        if written is not None:
            self.store.prune_snapshots(self.run_id, keep=str(written["file"]))

    def _restore(self, checkpoint: Checkpoint) -> bool:
        """Continue from the checkpoint's snapshot; False (with a logged note) to replay."""
        ref = checkpoint.engine_state.get("snapshot")
        world = self._restorable()
        if world is None:
            if isinstance(self.world, RestorableWorld):  # an engine that cannot (pybullet)
                _log.warning("run %d: this physics engine cannot restore a saved state exactly; "
                             "replaying from birth 0", self.run_id)
            return False
        if ref is None:
            _log.warning("run %d: its checkpoint at %d births has no snapshot (an older "
                         "database, or one written on another engine); replaying from birth 0",
                         self.run_id, checkpoint.births)
            return False
        try:
            data = self.store.read_snapshot(self.run_id, ref, checkpoint.births)
            engine = data["engine"]
            if (engine["births"] != checkpoint.births
                    or engine["generation"] != checkpoint.generation
                    or engine["sim_time"] != checkpoint.sim_time
                    or _json_norm(engine["rng"]) != _json_norm(checkpoint.rng_state)):
                raise snapshot.SnapshotError("the snapshot's counters or generator differ from "
                                             "the checkpoint's")
            population = [
                Member(int(e["robot_id"]), decode(e["genome"]),
                       Lifecycle(int(e["robot_id"]), self.timing,
                                 None if e["stage"] is None else Stage(e["stage"]),
                                 e["birth_time"]),
                       e["fitness"], bool(e["learned"]))
                for e in engine["population"]
            ]
            for m, e in zip(population, engine["population"], strict=True):
                if e.get("policy") is not None:
                    m.policy_ref = str(e["policy"])
                    m.policy = self.load_policy(m.robot, m.policy_ref)
                    m.policy.set_state(e["policy_state"])
            world.restore(data["world"])
            for m in population:
                if m.policy is not None:
                    world.drive(m.robot_id, m.policy)
        except (snapshot.SnapshotError, KeyError, TypeError, ValueError, NotImplementedError,
                RecursionError) as e:
            _log.warning("run %d: cannot resume from the snapshot at %d births (%s); replaying "
                         "from birth 0", self.run_id, checkpoint.births, e)
            return False
        self.restore_counters(checkpoint)
        self.last_commit_births = checkpoint.births
        self.population = population
        self.dead = []
        self.started = time.perf_counter()
        self._progress()
        return True

    def _commit_online(self, force: bool) -> None:
        if force or self.births - self.last_commit_births >= self.config.checkpoint_interval:
            members = self.population + self.dead
            self.dead = []
            self.commit(self.engine_state(), members)

