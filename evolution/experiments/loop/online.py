"""Online evolution: the whole population in one world, asynchronous births and deaths.

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
are conceived at once. A commit point is every ``checkpoint_interval`` births: a step of the loop
(:meth:`OnlineMode.step`) runs the conception ticks up to the next one (the first step: the
initial population at time 0).

Resume. On a world that restores its state exactly (:class:`~evolution.experiments.loop.run.
RestorableWorld` with ``exact_restore``: the population env on MuJoCo), every checkpoint but the
last also writes a snapshot file beside the database (:mod:`evolution.experiments.store.snapshot`;
:meth:`OnlineMode.snapshot` gives its data, the store observer writes it): the world's physics,
controllers, generator and bookkeeping and the loop's population and lifecycles. Resume
restores it and goes on from the checkpoint, bit-identical to an uninterrupted run, at a cost
proportional to the work since the checkpoint. Otherwise (pybullet,
a database from before snapshots, a missing or damaged file, a world that refuses the snapshot)
the run is replayed from its start, as before, with a logged note saying why.
"""

from __future__ import annotations

import logging
import math
import time
from typing import Any

import numpy as np

from evolution.evaluation import evaluation_seed, run_infancy
from evolution.experiments.loop.errors import SnapshotError
from evolution.experiments.loop.records import Checkpoint, FailureRecord, FitnessSample
from evolution.experiments.loop.run import (
    Member,
    OnlineWorld,
    Replay,
    RestorableWorld,
    Step,
    StoredRun,
    decode,
    genome,
    json_norm,
)
from evolution.experiments.loop.state import RunState
from evolution.lifecycle import LearningSummary, Lifecycle, Stage, stage_of
from evolution.selection import online_survivors
from revolve_env.body.robot import Robot

__all__ = ["OnlineMode"]

_log = logging.getLogger(__name__)


class OnlineMode:
    """Online evolution of one run: the whole population in ``world``.

    Args:
        state: The run's state.
        world: The world holding the population (the population env: :class:`~evolution.
            experiments.online_world.PopulationWorld`).
    """

    def __init__(self, state: RunState, world: OnlineWorld) -> None:
        self.state = state
        self.world = world
        self.dead: list[Member] = []

    # -- a step ------------------------------------------------------------------------------

    def step(self) -> Step:
        """To the next commit point: the initial population, or conception ticks."""
        state, config = self.state, self.state.config
        if not state.begun:
            for _ in range(config.population_size):
                self.give_birth(0.0, random=True)
            state.begun = True
            return self._close()
        while True:
            self._tick()
            if (state.done()
                    or state.births - state.last_commit_births >= config.checkpoint_interval):
                return self._close()

    def _tick(self) -> None:
        """One conception tick: live until it, bury, select, conceive."""
        state, config = self.state, self.state.config
        # Tick k falls at k * interval, not a running sum, so float drift never delays a
        # maturity or a birth by one tick (e.g. with a 0.1 s interval). Tick k follows
        # generation k - 1 (a resumed run picks up its count from the checkpoint).
        now = (state.generation + 1) * config.conception_interval
        self.update(now)
        self.select(now)
        while len(state.population) < config.min_alive and state.births < config.births:
            self.give_birth(now)
        if state.births < config.births:
            self.give_birth(now)
        state.generation += 1

    def _close(self) -> Step:
        members = self.state.population + self.dead
        self.dead = []
        return self.state.close_step(self.engine_state(), members)

    def give_birth(self, time_s: float, random: bool = False) -> None:
        """Conceive a robot (from two mature parents, or at random), train it, and deliver it."""
        state = self.state
        mature = [m for m in state.population if m.lifecycle.fertile]
        robot, pa, pb, origin = state.conceive(mature, time_s, random)
        member, record = state.new_member(robot, (pa, pb), origin, time_s, time_s)
        living = robot
        replay = state.replay
        stored = (replay.policies(member.robot_id, robot)
                  if replay is not None and member.robot_id in replay.genomes else None)
        if stored is not None:
            # Replaying: the policy saved with the run, not a second training.
            lesson, policy = stored
            member.policy_ref = lesson.policy
            state.infancy_over(member, time_s, None, LearningSummary(
                lesson.inborn_fitness, lesson.learned_fitness, lesson.evaluations,
                lesson.sim_seconds, lesson.failures, policy))
        elif state.infancy is not None:
            # The Training Center: a separate simulation before the robot enters the world.
            report = run_infancy(state.infancy, robot,
                                 evaluation_seed(state.seed, member.robot_id))
            living = report.robot
            state.infancy_over(member, time_s, report.failure, report.learning,
                               living if report.changed else None)
        else:
            state.infancy_over(member, time_s)
        state.batch.robots.append(record)
        try:
            # A robot with a policy is agent-controlled: the world asks the policy every step.
            birth = (self.world.add(living, member.robot_id) if member.policy is None
                     else self.world.add(living, member.robot_id, member.policy))
        except ValueError as error:
            # The physics engine cannot build this body (e.g. MuJoCo refuses its geometry): the
            # robot is born dead. Recorded, and the run goes on.
            cause = f"not built: {error}"
            state.batch.failures.append(FailureRecord(member.robot_id, time_s, "birth", cause))
            state.kill(member, time_s, cause)
            self.dead.append(member)
            return
        if not birth.inside:
            x, y = birth.position
            state.batch.failures.append(FailureRecord(
                member.robot_id, time_s, "crowded",
                f"the birth disc was full; born at the nearest free spot ({x:.3f}, {y:.3f}) m"))
        state.population.append(member)

    def update(self, now: float) -> None:
        """Advance the world to ``now``, then age, sample and bury."""
        state = self.state
        statuses = self.world.advance_to(now)
        state.sim_time = now
        for m in list(state.population):
            status = statuses.get(m.robot_id)
            if status is None:
                continue
            if status.death is not None:
                # Lost: stored with no fitness (the world reports 0 m after a blow-up, which is
                # no measurement). It leaves the population here, so selection never sees it.
                reason = status.blow_up or status.death
                cause = f"blow-up: {reason}"
                state.batch.failures.append(FailureRecord(m.robot_id, now, "blow-up", reason))
                m.fitness = None
                state.batch.fitness_updates.append((m.robot_id, None))
                self._bury(m, now, cause, remove=False)
                continue
            m.fitness = status.fitness
            # Insertion and maturity on the world's clock (the env counts control periods).
            m.lifecycle.advance_to(stage_of(status.inserting, status.mature))
            state.batch.fitness.append(FitnessSample(m.robot_id, now, status.fitness,
                                                     status.v, status.s))
            state.batch.fitness_updates.append((m.robot_id, status.fitness))

    def _bury(self, member: Member, now: float, cause: str, remove: bool = True) -> None:
        if remove:
            self.world.remove(member.robot_id)
        self.state.kill(member, now, cause)
        self.state.population.remove(member)
        self.dead.append(member)

    def select(self, now: float) -> None:
        """The online survivor rule over the mature robots."""
        state, config = self.state, self.state.config
        mature = [m for m in state.population
                  if m.lifecycle.fertile and m.fitness is not None and math.isfinite(m.fitness)]
        spared = len(state.population) - len(mature)
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
            doomed = [int(i) for i in state.rng.choice(len(mature), size=len(doomed),
                                                       replace=False)]
        for i in sorted(doomed):
            self._bury(mature[i], now, "survivor selection")

    def engine_state(self) -> dict[str, Any]:
        """What a checkpoint records beyond the generator: the living robots."""
        return {"alive": [m.robot_id for m in self.state.population]}

    # -- snapshots and resume ----------------------------------------------------------------

    def _restorable(self) -> RestorableWorld | None:
        world = self.world
        if isinstance(world, RestorableWorld) and world.exact_restore:
            return world
        return None

    def snapshot(self) -> dict[str, Any] | None:
        """The world's and the loop's whole state, for a snapshot file (see the module doc).

        Returns:
            Plain data (NumPy arrays allowed), or ``None`` when the world cannot restore
            exactly or the run is done (nothing left to resume).
        """
        world = self._restorable()
        state = self.state
        if world is None or state.done():
            return None
        # "engine": the loop's part of the file (the name the files have always used).
        loop = {
            "births": state.births, "sim_time": state.sim_time, "generation": state.generation,
            "rng": dict(state.rng.bit_generator.state),
            "population": [
                {"robot_id": m.robot_id, "genome": genome(m.robot),
                 "stage": None if m.lifecycle.stage is None else m.lifecycle.stage.value,
                 "birth_time": m.lifecycle.birth_time, "fitness": m.fitness,
                 "learned": m.learned, "policy": m.policy_ref,
                 "policy_state": None if m.policy is None else m.policy.get_state()}
                for m in state.population
            ],
        }
        return {"engine": loop, "world": world.snapshot()}

    def resume(self, checkpoint: Checkpoint, store: StoredRun,
               trust_pickled_policies: bool = False) -> None:
        """Continue from a checkpoint: from its snapshot, else by replay from birth 0.

        Replay: the run starts again from its seed; every robot is checked against the stored
        one, robots that lived driven by a saved policy get it back from its file, and the
        steps up to the checkpoint are ``replayed`` (nothing written).
        """
        state = self.state
        if self._restore(checkpoint, store, trust_pickled_policies):
            return

        def policies(robot_id: int, robot: Robot) -> tuple[Any, Any] | None:
            records = store.learning(state.run_id, [robot_id])
            if not records or records[0].policy is None:
                return None
            return records[0], store.load_policy(state.run_id, robot, records[0].policy,
                                                 trust_pickled_policies)

        genomes = {r.robot_id: r.genome for r in store.robots(state.run_id)}
        state.replay = Replay(checkpoint, genomes, policies)

    def _restore(self, checkpoint: Checkpoint, store: StoredRun, trust: bool) -> bool:
        """Continue from the checkpoint's snapshot; False (with a logged note) to replay."""
        state = self.state
        ref = checkpoint.engine_state.get("snapshot")
        world = self._restorable()
        if world is None:
            if isinstance(self.world, RestorableWorld):  # an engine that cannot (pybullet)
                _log.warning("run %d: this physics engine cannot restore a saved state exactly; "
                             "replaying from birth 0", state.run_id)
            return False
        if ref is None:
            _log.warning("run %d: its checkpoint at %d births has no snapshot (an older "
                         "database, or one written on another engine); replaying from birth 0",
                         state.run_id, checkpoint.births)
            return False
        try:
            data = store.read_snapshot(state.run_id, ref, checkpoint.births)
            loop = data["engine"]
            if (loop["births"] != checkpoint.births
                    or loop["generation"] != checkpoint.generation
                    or loop["sim_time"] != checkpoint.sim_time
                    or json_norm(loop["rng"]) != json_norm(checkpoint.rng_state)):
                raise SnapshotError("the snapshot's counters or generator differ from "
                                             "the checkpoint's")
            population = [
                Member(int(e["robot_id"]), decode(e["genome"]),
                       Lifecycle(int(e["robot_id"]), state.timing,
                                 None if e["stage"] is None else Stage(e["stage"]),
                                 e["birth_time"]),
                       e["fitness"], bool(e["learned"]))
                for e in loop["population"]
            ]
            for m, e in zip(population, loop["population"], strict=True):
                if e.get("policy") is not None:
                    m.policy_ref = str(e["policy"])
                    m.policy = store.load_policy(state.run_id, m.robot, m.policy_ref, trust)
                    m.policy.set_state(e["policy_state"])
            world.restore(data["world"])
            for m in population:
                if m.policy is not None:
                    world.drive(m.robot_id, m.policy)
        except (SnapshotError, KeyError, TypeError, ValueError, NotImplementedError,
                RecursionError) as e:
            _log.warning("run %d: cannot resume from the snapshot at %d births (%s); replaying "
                         "from birth 0", state.run_id, checkpoint.births, e)
            return False
        state.restore_counters(checkpoint)
        state.population = population
        self.dead = []
        state.started = time.perf_counter()
        return True
