"""Stored robots evaluated again: how optimistic was the single evaluation that selected them?

A run ranks each robot by one evaluation (offline) or one sliding window in a crowded world
(online). :func:`reevaluate` takes the robots a run kept and evaluates each of them ``k`` times
more under fresh conditions, writing every result into the experiment's own database (the
``reevaluations`` table, :class:`~evolution.experiments.store.schema.ReevaluationRecord`);
:mod:`evolution.reporting.optimism` turns them into the optimism table and figure.

Which robots (``which``)
    ``"final"``: the last committed population of every run; ``"best"``: the best robot of each
    commit point (an offline generation, an online birth), each robot once, with the highest
    fitness it was best with. Robots without a stored fitness are left out (nothing to compare),
    and so are online robots younger than ``fertile_age`` at the snapshot (their window was not
    full; selection did not see them either).

How (one *setting* per window offset)
    * conditions: the run's own (its config's ``evaluation`` table; a database from before
      conditions gets them in its schema upgrade) with a **random heading**, so each repeat
      starts facing another way and draws fresh noise; ``conditions=`` replaces them;
    * window: the robot is dropped, lives ``insertion + offset`` seconds, then its fitness
      ``f = v + 5 s`` is measured over ``evaluation_time`` seconds (later windows: offsets > 0);
    * alone at the origin (as offline runs evaluate), or with ``shared_world=True`` together
      with the run's other chosen robots in one population env world (placed by its placement
      rule), each robot's sliding-window fitness read at the end;
    * as it lived: a robot whose infancy learned a genome is evaluated with it (``"learned"``),
      one driven by a saved SB3 policy with that policy (``"policy"``, in the single-robot
      env) or, in a shared world, with its inborn network (``"inborn (policy not used)"``:
      the table's ``controller`` column says so).

Seeds: repeat ``r`` of robot ``i`` of run ``j`` uses :func:`reevaluation_seed` of (``seed``,
``j``, ``i``, ``r``), a stream apart from the run's evaluation seeds; the same repeat of every
window offset uses the same seed (a paired comparison). A shared world's seed depends on the run
and repeat only. So a reevaluation is a pure function of the database and its arguments: running
it again finds every row stored (the key holds no timestamp) and evaluates nothing, and a larger
``k`` adds only the missing repeats. Results are committed every few evaluations, so Ctrl-C
loses only the evaluations in flight.

Which databases: one set of experiments below ``path``, as a report takes them
(:func:`evolution.experiments.store.folders.select_results`: a study, or the experiments outside any
study; ``every_set=True`` takes them all); the summary names what was left out.

From the command line: ``revolve reevaluate RESULTS [--k 10] [--best] [--window-offset S ...]
[--shared-world] [--workers N] [--all]``, then ``revolve report RESULTS``.
"""

from __future__ import annotations

import json
import logging
import math
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

import revolve_env
from evolution.evaluation import EvalOutcome, EvalTask, Evaluator, make_evaluator
from evolution.experiments.app.api import check_task_code
from evolution.experiments.loop.config import MAX_SECONDS
from evolution.experiments.store import results_folder
from evolution.experiments.store.database import Store, StoreError
from evolution.experiments.store.folders import ResultSet, select_results
from evolution.experiments.store.integrity import check_writable, verify
from evolution.experiments.store.schema import ReevaluationRecord
from revolve_env.body.robot import Robot
from revolve_env.body.serialize import from_json
from revolve_env.conditions import RANDOM_HEADING, EvaluationConditions
from revolve_env.tasks import Locomotion, Task
from revolve_env.terrain import Flat, Terrain

__all__ = [
    "KINDS",
    "MAX_K",
    "Chosen",
    "ReevaluationSummary",
    "SharedWorldJob",
    "SkippedRun",
    "choose",
    "reevaluate",
    "reevaluation_conditions",
    "reevaluation_seed",
    "shared_world_seed",
]

_log = logging.getLogger(__name__)

KINDS = ("final", "best")
"""What ``which`` may be."""
MAX_K = 1000
"""Most repeats per robot and setting (a larger K only costs time: the CI is over runs)."""

_TAG = 0x2E7A1
"""Tags the reevaluation seeds apart from the runs' evaluation seeds (tag 0x0E7A1)."""
_SHARED_TAG = 0x5A4ED
"""Tags the seeds of shared reevaluation worlds."""
_CHUNK = 4
"""Evaluations per worker between two commits."""

ProgressFunction = Callable[[int, int], None]
"""``progress(done, total)``: evaluations done and planned, after every commit."""


def reevaluation_seed(seed: int, run_id: int, robot_id: int, repeat: int) -> int:
    """The seed of repeat ``repeat`` of robot ``robot_id`` of run ``run_id``."""
    return int(np.random.SeedSequence([seed, run_id, robot_id, repeat, _TAG])
               .generate_state(1)[0])


def shared_world_seed(seed: int, run_id: int, repeat: int) -> int:
    """The seed of repeat ``repeat`` of run ``run_id``'s shared world."""
    return int(np.random.SeedSequence([seed, run_id, repeat, _SHARED_TAG]).generate_state(1)[0])


def reevaluation_conditions(config: Mapping[str, Any],
                            conditions: EvaluationConditions | None = None
                            ) -> EvaluationConditions:
    """``conditions``, or the run's own (``config["evaluation"]``) with a random heading.

    A stored config without conditions (a database written by this version before the
    ``[evaluation]`` table existed) reevaluates with a random heading and no noise.

    Raises:
        StoreError: the stored conditions are not valid.
    """
    if conditions is not None:
        return conditions
    stored = config.get("evaluation")
    if stored is None:
        return EvaluationConditions(heading=RANDOM_HEADING)
    try:
        run_conditions = EvaluationConditions.from_dict(stored)
    except (TypeError, ValueError) as error:
        raise StoreError(f"the stored evaluation conditions are not valid: {error}") from None
    return replace(run_conditions, heading=RANDOM_HEADING)


@dataclass(frozen=True, slots=True)
class Chosen:
    """A robot chosen for reevaluation, as it lived.

    Attributes:
        run_id: Its run.
        robot_id: Its id.
        robot: The robot (with its learned controller when it learned one).
        controller: ``"inborn"``, ``"learned"`` or ``"policy"``.
        stored_fitness: What its run stored for it. Metres.
        policy: The policy reference (learning table JSON) when ``controller == "policy"``.
    """

    run_id: int
    robot_id: int
    robot: Robot
    controller: str
    stored_fitness: float
    policy: str | None = None


def choose(store: Store, run_id: int, which: str, mature_age: float = 0.0) -> list[Chosen]:
    """The robots of run ``run_id`` that ``which`` names (module docstring), by id.

    Args:
        store: The open database.
        run_id: The run.
        which: ``"final"`` or ``"best"``.
        mature_age: Only robots at least this old at a snapshot count in it (online runs:
            ``fertile_age``; an infant's window is not full yet). Seconds.

    Raises:
        ValueError: an unknown ``which``.
    """
    if which not in KINDS:
        raise ValueError(f"which must be one of {', '.join(map(repr, KINDS))}, got {which!r}")
    born = {r.robot_id: r.birth_time for r in store.robots(run_id) if r.birth_time is not None}
    snapshots = store.population_snapshots(run_id)
    if which == "final":
        snapshots = snapshots[-1:]
    stored: dict[int, float] = {}
    for _, sim_time, members in snapshots:
        finite = [(f, rid) for rid, f in members if f is not None and math.isfinite(f)
                  and rid in born and sim_time - born[rid] >= mature_age - 1e-9]
        if which == "final":
            stored.update((rid, f) for f, rid in finite)
        elif finite:
            fitness, rid = max(finite, key=lambda p: (p[0], -p[1]))
            stored[rid] = max(fitness, stored.get(rid, -math.inf))
    ids = sorted(stored)
    learned = {r.robot_id: r for r in store.learning(run_id, ids)}
    chosen = []
    for record in store.robots(run_id, ids):
        rid = record.robot_id
        learning = learned.get(rid)
        if learning is not None and learning.policy is not None:
            chosen.append(Chosen(run_id, rid, record.robot(), "policy", stored[rid],
                                 learning.policy))
        elif learning is not None and learning.learned_genome is not None:
            chosen.append(Chosen(run_id, rid, from_json(learning.learned_genome), "learned",
                                 stored[rid]))
        else:
            chosen.append(Chosen(run_id, rid, record.robot(), "inborn", stored[rid]))
    return chosen


@dataclass(frozen=True, slots=True)
class SkippedRun:
    """An unfinished run that :func:`reevaluate` left out.

    Attributes:
        database: Its experiment's database.
        run_id: The run.
        status: Its status (``pending``, ``running`` or ``interrupted``).
        births: Its births so far.
        target: The births it runs to.
    """

    database: Path
    run_id: int
    status: str
    births: int
    target: int


@dataclass(frozen=True, slots=True)
class ReevaluationSummary:
    """What :func:`reevaluate` did.

    Attributes:
        databases: The databases reevaluated.
        planned: Evaluations the arguments ask for (robots x repeats x settings).
        evaluated: Of those, evaluations run by this call (the others were stored already).
        added: Rows written by this call.
        skipped: Unfinished runs left out (``include_unfinished`` was false).
        left_out: The sets of experiments below the path that were not reevaluated
            (:func:`~evolution.experiments.store.folders.select_results`).
    """

    databases: tuple[Path, ...]
    planned: int
    evaluated: int
    added: int
    skipped: tuple[SkippedRun, ...] = ()
    left_out: tuple[ResultSet, ...] = ()


@dataclass(frozen=True, slots=True)
class _Setting:
    """What one reevaluation row is, apart from its robot and repeat."""

    kind: str
    conditions: EvaluationConditions
    insertion: float
    seconds: float
    shared_world: bool
    engine: str
    task: Task
    terrain: Terrain = Flat()

    @property
    def conditions_json(self) -> str:
        return json.dumps(self.conditions.to_dict(), sort_keys=True)


def reevaluate(
    path: str | os.PathLike[str],
    k: int = 10,
    which: Literal["final", "best"] = "final",
    window_offsets: Sequence[float] = (0.0,),
    shared_world: bool = False,
    conditions: EvaluationConditions | None = None,
    workers: int = 0,
    seed: int | None = None,
    *,
    evaluator: Evaluator | None = None,
    progress: ProgressFunction | None = None,
    include_unfinished: bool = False,
    trust_pickled_policies: bool = False,
    every_set: bool = False,
    trust_task_code: bool = False,
) -> ReevaluationSummary:
    """Reevaluate the chosen robots of every experiment at or below ``path`` (module docs).

    Args:
        path: A results directory, a folder of them, or a ``results.sqlite``.
        k: Repeats per robot and setting.
        which: ``"final"`` (final populations) or ``"best"`` (best robot of each commit point).
        window_offsets: Extra seconds lived before the fitness window, one setting each. Seconds.
        shared_world: Evaluate a run's chosen robots together in one world (one per repeat).
        conditions: The conditions of every reevaluation; default: each run's own with a random
            heading (:func:`reevaluation_conditions`).
        workers: Worker processes (0: all cores); with ``evaluator`` ignored.
        seed: Base of the reevaluation seeds; default: each experiment's seed.
        evaluator: Where the evaluations run (default: a local pool of ``workers``).
        progress: Called with (evaluations done, planned) after every commit.
        include_unfinished: Also reevaluate runs that have not finished (interrupted, or still
            running: their population is the last committed one); by default they are left
            out and listed in the summary's ``skipped``.
        trust_pickled_policies: Load SB3 policies that older versions saved as pickles (which
            can run code: only for a results folder whose author you trust).
        every_set: Every set of experiments below ``path`` (studies and lone experiments
            together), not only the one :func:`~evolution.experiments.store.folders.select_results`
            takes.
        trust_task_code: Import the module of a task class of the user's own that a stored
            ``[task]`` names (its code runs: only for a folder whose author you trust).

    Returns:
        What was planned and written.

    Raises:
        StoreError: no results database below ``path``, a damaged or read-only one, or a
            saved policy that cannot be used (checked, all of them, before anything is
            evaluated), or several studies and nothing else below ``path`` without
            ``every_set``, or a stored task class of the user's own not trusted.
        ValueError: a bad ``k`` (1 to :data:`MAX_K`), ``which`` or window offset (0 to
            :data:`~evolution.experiments.loop.config.MAX_SECONDS`).
        KeyboardInterrupt: Ctrl-C; everything committed stays, running again continues.
    """
    if isinstance(k, bool) or not isinstance(k, int) or not 1 <= k <= MAX_K:
        raise ValueError(f"k must be an integer from 1 to {MAX_K}, got {k!r}")
    if which not in KINDS:
        raise ValueError(f"which must be one of {', '.join(map(repr, KINDS))}, got {which!r}")
    offsets = tuple(float(o) for o in window_offsets)
    if not offsets or any(not (math.isfinite(o) and 0 <= o <= MAX_SECONDS) for o in offsets):
        raise ValueError(f"window offsets must be numbers of seconds from 0 to {MAX_SECONDS:g}, "
                         f"got {list(window_offsets)!r}")
    selection = select_results(path, every_set, "revolve reevaluate")
    plans = [_plan(db, k, which, offsets, shared_world, conditions, seed, include_unfinished,
                   trust_pickled_policies, trust_task_code)
             for db in selection.databases]
    total = sum(len(plan.todo) for plan in plans)
    used = evaluator or make_evaluator("local", workers)
    done = added = 0
    try:
        for plan in plans:
            with Store.open(plan.db) as store:
                for records in _evaluate(plan.todo, used, shared_world, plan.policies):
                    added += store.add_reevaluations(records)
                    done += len(records)
                    if progress is not None:
                        progress(done, total)
    finally:
        if evaluator is None:
            used.close()
    return ReevaluationSummary(tuple(plan.db for plan in plans),
                               sum(plan.asked for plan in plans), total, added,
                               tuple(run for plan in plans for run in plan.skipped),
                               selection.left_out)


_Todo = tuple[Chosen, _Setting, int, int]
"""One evaluation to run: the robot, the setting, the repeat and the seed."""


@dataclass(frozen=True, slots=True)
class _DatabasePlan:
    """What one database asks for: its evaluations and the policies they need."""

    db: Path
    asked: int
    todo: list[_Todo]
    policies: dict[tuple[int, int], Any]
    skipped: list[SkippedRun]


def _plan(db: Path, k: int, which: str, offsets: tuple[float, ...], shared_world: bool,
          conditions: EvaluationConditions | None, seed: int | None, include_unfinished: bool,
          trust_pickled: bool, trust_task_code: bool) -> _DatabasePlan:
    """The evaluations asked of a database and those not stored yet (checked first).

    The saved policies they need are loaded here, before anything is evaluated.
    """
    with Store.open(db) as store:
        config = verify(store)
        check_writable(store)
        check_task_code(db, config, trust_task_code)
        engine = config.world.engine
        if store.physics_revisions[engine] != revolve_env.PHYSICS_REVISIONS[engine]:
            _log.warning("%s: its fitness was measured with %s physics revision %d; it is "
                         "re-evaluated with revision %d, so the differences include the "
                         "engine's change", db, engine, store.physics_revisions[engine],
                         revolve_env.PHYSICS_REVISIONS[engine])
        base = store.seed if seed is None else seed
        used = reevaluation_conditions(store.config, conditions)
        settings = [_Setting(which, used, config.insertion + o, config.evaluation_time,
                             shared_world, config.world.engine, config.fitness_task(),
                             config.world.terrain_spec)
                    for o in offsets]
        mature_age = config.fertile_age if config.mode == "online" else 0.0
        stored = {r.key for r in store.reevaluations(which)}
        todo: list[_Todo] = []
        policies: dict[tuple[int, int], Any] = {}
        skipped: list[SkippedRun] = []
        asked = 0
        for run in store.runs():
            if run.status != "finished" and not include_unfinished:
                skipped.append(SkippedRun(db, run.run_id, run.status, run.births,
                                          config.births))
                continue
            chosen = choose(store, run.run_id, which, mature_age)
            asked += len(chosen) * k * len(settings)
            for setting in settings:
                for repeat in range(k):
                    items = [(c, setting, repeat,
                              shared_world_seed(base, c.run_id, repeat) if shared_world
                              else reevaluation_seed(base, c.run_id, c.robot_id, repeat))
                             for c in chosen]
                    missing = [item for item in items if _key(item) not in stored]
                    # A shared world is lived again whole: its robots meet the same neighbours.
                    todo += items if shared_world and missing else missing
        if not shared_world:  # a shared world drives every robot by its inborn network
            for c, _, _, _ in todo:
                if c.policy is not None and (c.run_id, c.robot_id) not in policies:
                    policies[c.run_id, c.robot_id] = results_folder.load_policy(
                        db.parent, c.run_id, c.robot, c.policy, trust_pickled)
    return _DatabasePlan(db, asked, todo, policies, skipped)


def _key(item: _Todo) -> tuple[int, str, int, str, float, bool, int, int]:
    """The store key of a planned evaluation (:attr:`ReevaluationRecord.key`)."""
    c, setting, repeat, seed = item
    return (c.run_id, setting.kind, c.robot_id, setting.conditions_json, setting.insertion,
            setting.shared_world, repeat, seed)


def _record(c: Chosen, setting: _Setting, repeat: int, seed: int, outcome: EvalOutcome,
            controller: str) -> ReevaluationRecord:
    return ReevaluationRecord(
        c.run_id, c.robot_id, setting.kind, repeat, setting.conditions_json, setting.insertion,
        setting.seconds, setting.shared_world, seed, controller, c.stored_fitness,
        outcome.fitness, outcome.v, outcome.s, outcome.failure)


def _evaluate(todo: list[_Todo], evaluator: Evaluator, shared_world: bool,
              policies: Mapping[tuple[int, int], Any]) -> Iterator[list[ReevaluationRecord]]:
    """Yield the records of ``todo`` chunk by chunk, each chunk ready to commit."""
    if shared_world:
        yield from _evaluate_shared(todo, evaluator)
        return
    chunk = max(1, evaluator.workers * _CHUNK)
    for start in range(0, len(todo), chunk):
        part = todo[start:start + chunk]
        tasks = [EvalTask(c.robot_id, c.robot, setting.insertion, setting.seconds, s,
                          engine=setting.engine, conditions=setting.conditions,
                          policy=policies.get((c.run_id, c.robot_id)), task=setting.task,
                          terrain=setting.terrain)
                 for c, setting, _, s in part]
        outcomes = evaluator.evaluate(tasks)
        yield [_record(c, setting, repeat, s, outcome, c.controller)
               for (c, setting, repeat, s), outcome in zip(part, outcomes, strict=True)]


@dataclass(frozen=True, slots=True)
class SharedWorldJob:
    """One shared reevaluation world: a run's chosen robots together for one repeat.

    Attributes:
        robots: The robots (their own networks drive them).
        seed: The world's seed (placement and headings, noise).
        conditions: The conditions of the world's robots.
        insertion: Seconds before the fitness window. Seconds.
        seconds: The fitness window. Seconds.
        engine: The physics engine.
        task: What the robots are scored on (the run's).
        terrain: The ground (the run's ``world.terrain``).
    """

    robots: tuple[Robot, ...]
    seed: int
    conditions: EvaluationConditions
    insertion: float
    seconds: float
    engine: str
    task: Task = Locomotion()
    terrain: Terrain = Flat()


def _evaluate_shared(todo: list[_Todo], evaluator: Evaluator
                     ) -> Iterator[list[ReevaluationRecord]]:
    """Yield the records of shared worlds: one world per (run, setting, repeat)."""
    groups: dict[tuple[int, float, int], list[_Todo]] = {}
    for item in todo:
        c, setting, repeat, _ = item
        groups.setdefault((c.run_id, setting.insertion, repeat), []).append(item)
    keys = list(groups)
    chunk = max(1, evaluator.workers)
    for start in range(0, len(keys), chunk):
        part = [groups[key] for key in keys[start:start + chunk]]
        jobs = [SharedWorldJob(tuple(c.robot for c, *_ in items), items[0][3],
                               items[0][1].conditions, items[0][1].insertion,
                               items[0][1].seconds, items[0][1].engine, items[0][1].task,
                               items[0][1].terrain)
                for items in part]
        results = evaluator.run_jobs(run_shared_world, jobs)
        records = []
        for items, outcomes in zip(part, results, strict=True):
            for (c, setting, repeat, s), outcome in zip(items, outcomes, strict=True):
                controller = ("inborn (policy not used)" if c.controller == "policy"
                              else c.controller)
                records.append(_record(c, setting, repeat, s, outcome, controller))
        yield records


def run_shared_world(job: SharedWorldJob, evaluator: Evaluator,
                     emit: Callable[[Any], None]) -> list[EvalOutcome]:
    """Live ``job.robots`` together in one population env world; one outcome per robot.

    The world runs ``insertion + seconds``; each robot's fitness is its sliding ``seconds``
    window at the end (a robot removed for a blow-up gets the failure). ``evaluator`` and
    ``emit`` are unused (the signature of :meth:`~evolution.evaluation.Evaluator.run_jobs`).
    """
    # Imported here: it loads the physics engine.
    from revolve_env.envs.population import PopulationEnv

    env = PopulationEnv(max_births=len(job.robots), initial_robots=list(job.robots),
                        insertion_time=job.insertion, maturity_age=job.insertion + job.seconds,
                        fitness_window=job.seconds, engine=job.engine, conditions=job.conditions,
                        task=job.task, terrain=job.terrain)
    try:
        env.reset(seed=job.seed)
        last = dict(env.statuses)  # every robot's status as the last step left it
        end = job.insertion + job.seconds
        while env.agents and float(env.time) < end - 0.5 * float(env.config.control_period):
            env.step({})
            last.update(env.statuses)
    finally:
        env.close()
    outcomes = []
    for status in last.values():
        failure = status.blow_up or status.death
        if failure:
            outcomes.append(EvalOutcome(None, failure=f"blow-up: {failure}"))
        else:
            outcomes.append(EvalOutcome(float(status.fitness), float(status.v), float(status.s)))
    return outcomes
