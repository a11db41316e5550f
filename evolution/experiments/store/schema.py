"""The layout of the results store: its SQL tables, their upgrades, and what is read back.

:class:`~evolution.experiments.store.database.Store` writes and reads them (its module docstring
describes each table); the records a run writes are the loop's
(:mod:`~evolution.experiments.loop.records`). The records here are read back from a database or
made after a run: a run's row, a population snapshot and its fitness series, a re-evaluation.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "CONDITIONS_OF_OLD_RUNS",
    "ENGINE_OF_OLD_CONFIGS",
    "LEARNING_TABLE",
    "MIGRATIONS",
    "MODE_OF_OLD_CONFIGS",
    "POSE_RATE_OF_OLD_CONFIGS",
    "REEVALUATIONS_TABLE",
    "SB3_OF_OLD_RUNS",
    "SCHEMA",
    "SCHEMA_V1",
    "SCHEMA_VERSION",
    "SHAKING_COLUMN",
    "TABLES",
    "FitnessSeries",
    "PopulationSnapshot",
    "ReevaluationRecord",
    "RunRecord",
]

SCHEMA_VERSION = 8
"""Version of the database layout; a database with a newer one is refused, an older one is
upgraded when opened (see the module docstring)."""

SCHEMA_V1 = """
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE runs (
    run_id INTEGER PRIMARY KEY,
    seed INTEGER NOT NULL,
    status TEXT NOT NULL CHECK (status IN ('pending', 'running', 'interrupted', 'finished')),
    births INTEGER NOT NULL DEFAULT 0,
    sim_time REAL NOT NULL DEFAULT 0,
    generation INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE checkpoints (
    run_id INTEGER PRIMARY KEY REFERENCES runs(run_id),
    births INTEGER NOT NULL,
    sim_time REAL NOT NULL,
    generation INTEGER NOT NULL,
    rng_state TEXT NOT NULL,
    engine_state TEXT NOT NULL
);
CREATE TABLE robots (
    run_id INTEGER NOT NULL REFERENCES runs(run_id),
    robot_id INTEGER NOT NULL,
    genome TEXT NOT NULL,
    parent_a INTEGER,
    parent_b INTEGER,
    origin TEXT NOT NULL,
    generation INTEGER NOT NULL,
    conceived_time REAL NOT NULL,
    birth_time REAL,
    death_time REAL,
    death_cause TEXT,
    fitness REAL,
    PRIMARY KEY (run_id, robot_id)
);
CREATE TABLE fitness (
    run_id INTEGER NOT NULL,
    robot_id INTEGER NOT NULL,
    time REAL NOT NULL,
    fitness REAL NOT NULL,
    v REAL,
    s REAL
);
CREATE INDEX fitness_by_robot ON fitness (run_id, robot_id);
CREATE TABLE transitions (
    run_id INTEGER NOT NULL,
    robot_id INTEGER NOT NULL,
    source TEXT,
    target TEXT NOT NULL,
    time REAL NOT NULL,
    note TEXT NOT NULL DEFAULT ''
);
CREATE INDEX transitions_by_robot ON transitions (run_id, robot_id);
CREATE TABLE population (
    run_id INTEGER NOT NULL,
    births INTEGER NOT NULL,
    sim_time REAL NOT NULL,
    robot_id INTEGER NOT NULL,
    fitness REAL
);
CREATE INDEX population_by_births ON population (run_id, births);
CREATE TABLE diversity (
    run_id INTEGER NOT NULL,
    births INTEGER NOT NULL,
    sim_time REAL NOT NULL,
    value REAL NOT NULL,
    PRIMARY KEY (run_id, births)
);
CREATE TABLE failures (
    run_id INTEGER NOT NULL,
    robot_id INTEGER,
    time REAL NOT NULL,
    kind TEXT NOT NULL,
    detail TEXT NOT NULL DEFAULT ''
);
"""
"""The tables of schema version 1."""

LEARNING_TABLE = """
CREATE TABLE learning (
    run_id INTEGER NOT NULL,
    robot_id INTEGER NOT NULL,
    time REAL NOT NULL,
    inheritance TEXT NOT NULL,
    learned_genome TEXT,
    inborn_fitness REAL,
    learned_fitness REAL,
    evaluations INTEGER,
    sim_seconds REAL,
    failures INTEGER NOT NULL DEFAULT 0,
    PRIMARY KEY (run_id, robot_id)
);
"""
"""The ``learning`` table, added by schema version 2."""

POLICY_COLUMN = """
ALTER TABLE learning ADD COLUMN policy TEXT;
"""
"""Schema version 3: the learning record's reference to a saved policy (JSON), for learners
whose controller is a policy outside the genome (SB3)."""

REEVALUATIONS_TABLE = """
CREATE TABLE reevaluations (
    run_id INTEGER NOT NULL,
    robot_id INTEGER NOT NULL,
    kind TEXT NOT NULL,
    repeat INTEGER NOT NULL,
    conditions TEXT NOT NULL,
    insertion REAL NOT NULL,
    seconds REAL NOT NULL,
    shared_world INTEGER NOT NULL,
    seed INTEGER NOT NULL,
    controller TEXT NOT NULL,
    stored_fitness REAL,
    fitness REAL,
    v REAL,
    s REAL,
    failure TEXT,
    PRIMARY KEY (run_id, kind, robot_id, conditions, insertion, shared_world, repeat, seed)
);
"""
"""Schema version 4: robots evaluated again after their run
(:mod:`evolution.experiments.app.reevaluate`).

The primary key holds no timestamp (the seed is derived from the experiment, run, robot and
repeat), so repeating a reevaluation finds its rows and adds none."""

CONDITIONS_OF_OLD_RUNS = """
UPDATE meta SET value = json_set(value, '$.evaluation', json(
    CASE WHEN json_extract(value, '$.engine') = 'online'
    THEN '{"heading": "random", "position_jitter": 0.0, "sensor_noise": 0.0, "actuator_noise": 0.0}'
    ELSE '{"heading": 0.0, "position_jitter": 0.0, "sensor_noise": 0.0, "actuator_noise": 0.0}'
    END))
WHERE key = 'config' AND json_valid(value) AND json_type(value) = 'object'
    AND json_type(value, '$.evaluation') IS NULL;
UPDATE meta SET value = json_set(value, '$.learning.conditions', json(
    '{"heading": 0.0, "position_jitter": 0.0, "sensor_noise": 0.0, "actuator_noise": 0.0}'))
WHERE key = 'config' AND json_valid(value) AND json_type(value) = 'object'
    AND json_type(value, '$.learning') = 'object'
    AND json_type(value, '$.learning.conditions') IS NULL;
"""
"""Schema version 4, for a stored config without an ``evaluation`` table: the conditions its runs
actually lived under, before conditions were configurable. Offline evaluations started at
heading 0 at the origin; online newborns at a random heading (the population env's draw); nothing
was noisy; infants of the Training Center learned at heading 0 in both (the second statement
pins that in the learning table). Written out literally on purpose: a migration must not change
when the code's defaults do, and this statement is the one home of that rule."""

MODE_OF_OLD_CONFIGS = """
UPDATE meta SET value = json_remove(json_set(value, '$.mode', json_extract(value, '$.engine')),
                                    '$.engine')
WHERE key = 'config' AND json_valid(value) AND json_type(value) = 'object'
    AND json_type(value, '$.engine') IS NOT NULL AND json_type(value, '$.mode') IS NULL;
"""
"""Schema version 5: the stored config's switch between offline and online evolution is called
``mode``; it was ``engine``, a word that now names only the physics engine (``world.engine``).
Nothing else changes: the runs continue and report as before. (A config with neither key is
offline, the default of both names.)"""

SB3_OF_OLD_RUNS = """
UPDATE meta SET value = json_set(value, '$.learning.normalize', json('false'))
WHERE key = 'config' AND json_valid(value) AND json_type(value) = 'object'
    AND json_extract(value, '$.learning.learner') = 'sb3'
    AND json_type(value, '$.learning.normalize') IS NULL;
UPDATE meta SET value = json_set(value, '$.learning.settings', 'sb3-defaults')
WHERE key = 'config' AND json_valid(value) AND json_type(value) = 'object'
    AND json_extract(value, '$.learning.learner') = 'sb3'
    AND json_type(value, '$.learning.settings') IS NULL;
"""
"""Schema version 6, for a stored config whose infants learn with SB3 (``learning.learner =
"sb3"``): how its learner trained before it took revolve_env.rl's normalised env and PPO settings
(:class:`~evolution.learning.SB3Learner`'s ``normalize`` and ``settings``). It trained on raw
observations and rewards (``normalize = false``) with SB3's own defaults under
``algorithm_kwargs`` (``settings = "sb3-defaults"``: ``n_steps`` 2048, exploration std 1, ...);
with both the learner trains exactly as it did (the same env, seeds and keyword arguments), so a
resumed run's remaining infants learn to the numbers of an uninterrupted run. A key already there
is kept. Written out literally on purpose: a migration must not change when the code's defaults
do, and this statement is the one home of that rule."""

SHAKING_COLUMN = """
ALTER TABLE fitness ADD COLUMN shaking REAL;
"""
"""Schema version 7: each fitness sample's shaking measure (:attr:`FitnessSample.shaking`);
NULL in samples stored before it."""

POSE_RATE_OF_OLD_CONFIGS = """
UPDATE meta SET value = json_set(value, '$.task', json(
    '{"name": "locomotion", "pose_rate": "every-period"}'))
WHERE key = 'config' AND json_valid(value) AND json_type(value) = 'object'
    AND (json_type(value, '$.task') IS NULL OR json_type(value, '$.task') = 'null');
UPDATE meta SET value = json_set(value, '$.task.pose_rate', 'every-period')
WHERE key = 'config' AND json_valid(value) AND json_type(value) = 'object'
    AND json_type(value, '$.task') = 'object' AND json_type(value, '$.task.pose_rate') IS NULL;
"""
"""Schema version 7: the pose rate the fitness of a stored run was computed at. Before pose rates
(:mod:`revolve_env.fitness.sampling`) the core was sampled every control period, so a stored
config without one gets ``pose_rate = "every-period"`` in its task table (a config without a
task table gets the paper's ``locomotion`` task, its default then, with it): a resumed run
scores its remaining births as it scored the first ones. A pose rate already there is kept.
Written out literally on purpose: a migration must not change when the code's defaults do, and
this statement is the one home of that rule."""

ENGINE_OF_OLD_CONFIGS = """
UPDATE meta SET value = json_set(value, '$.world.engine', 'pybullet')
WHERE key = 'config' AND json_valid(value) AND json_type(value) = 'object'
    AND (json_type(value, '$.world') IS NULL OR json_type(value, '$.world') = 'object')
    AND json_type(value, '$.world.engine') IS NULL;
"""
"""Schema version 8: the physics engine of a stored config that names none. Until MuJoCo became
the default engine (2026-11-27) a config without ``world.engine`` (every one stored before the
``[world]`` table, 2026-11-23) ran on pybullet, so it gets ``world.engine = "pybullet"``: a
resumed run steps its remaining births on the engine of its first ones. An engine already there
is kept. Written out literally on purpose: a migration must not change when the code's defaults
do, and this statement is the one home of that rule (the store says so in one line when it
applies it: :func:`evolution.experiments.store.engine_of_old_config`)."""

SCHEMA = SCHEMA_V1 + LEARNING_TABLE + POLICY_COLUMN + REEVALUATIONS_TABLE + SHAKING_COLUMN
"""The current layout (version :data:`SCHEMA_VERSION`)."""

TABLES = frozenset(re.findall(r"CREATE TABLE (\w+)", SCHEMA))
"""The tables of the current layout (an opened database must have them all)."""

MIGRATIONS: dict[int, str] = {1: LEARNING_TABLE, 2: POLICY_COLUMN,
                               3: REEVALUATIONS_TABLE + CONDITIONS_OF_OLD_RUNS,
                               4: MODE_OF_OLD_CONFIGS, 5: SB3_OF_OLD_RUNS,
                               6: SHAKING_COLUMN + POSE_RATE_OF_OLD_CONFIGS,
                               7: ENGINE_OF_OLD_CONFIGS}
"""For each old version, the statements that bring it to the next one."""


PopulationSnapshot = tuple[int, float, list[tuple[int, float | None]]]
"""One population snapshot: ``(births, sim_time, [(robot_id, fitness), ...])``."""


@dataclass(frozen=True, slots=True)
class ReevaluationRecord:
    """One evaluation of a stored robot after its run (:mod:`evolution.experiments.app.reevaluate`).

    Attributes:
        run_id: Run (repeat index).
        robot_id: The robot.
        kind: Which robots were chosen: ``"final"`` (the final population) or ``"best"`` (the
            best robot of each commit point: an offline generation, an online birth).
        repeat: Index of the repeat, ``0 .. K - 1``.
        conditions: The evaluation conditions as JSON
            (:meth:`~revolve_env.conditions.EvaluationConditions.to_dict`, sorted keys).
        insertion: Start of the fitness window after the robot's drop. Seconds.
        seconds: Length of the fitness window. Seconds.
        shared_world: True when the robot lived with its run's other chosen robots in one world.
        seed: Seed of the evaluation (or of the shared world).
        controller: ``"inborn"``, ``"learned"`` (a learned genome), ``"policy"`` (a saved SB3
            policy drove it) or ``"inborn (policy not used)"``.
        stored_fitness: The fitness the run stored for it (what selection saw). Metres.
        fitness: ``v + 5 s`` over the window; ``None`` when the evaluation failed. Metres.
        v: Path length over the window. Metres.
        s: Straight-line displacement over the window. Metres.
        failure: ``None``, or why the evaluation failed (a blow-up).
    """

    run_id: int
    robot_id: int
    kind: str
    repeat: int
    conditions: str
    insertion: float
    seconds: float
    shared_world: bool
    seed: int
    controller: str
    stored_fitness: float | None
    fitness: float | None
    v: float | None = None
    s: float | None = None
    failure: str | None = None

    @property
    def key(self) -> tuple[int, str, int, str, float, bool, int, int]:
        """The primary key: what makes two reevaluations the same one."""
        return (self.run_id, self.kind, self.robot_id, self.conditions, float(self.insertion),
                bool(self.shared_world), self.repeat, self.seed)


@dataclass(frozen=True, slots=True)
class RunRecord:
    """One run of an experiment."""

    run_id: int
    seed: int
    status: str
    births: int
    sim_time: float
    generation: int


@dataclass(frozen=True, slots=True)
class FitnessSeries:
    """Population fitness after each commit point of a run (arrays of equal length).

    Attributes:
        births: Births so far.
        sim_time: Simulated time. Seconds.
        mean: Mean fitness of the population (robots with a fitness).
        best: Highest fitness.
        worst: Lowest fitness.
        median: Median fitness.
        size: Population size (all members, with or without fitness).
    """

    births: np.ndarray
    sim_time: np.ndarray
    mean: np.ndarray
    best: np.ndarray
    worst: np.ndarray
    median: np.ndarray
    size: np.ndarray

    @classmethod
    def from_snapshots(cls, snapshots: Sequence[PopulationSnapshot]) -> FitnessSeries:
        """The statistics of each snapshot (finite fitness values only; ``nan`` without any)."""
        births, times, means, bests, worsts, medians, sizes = [], [], [], [], [], [], []
        for b, t, members in snapshots:
            values = np.array([f for _, f in members if f is not None and math.isfinite(f)])
            births.append(b)
            times.append(t)
            sizes.append(len(members))
            if values.size:
                means.append(values.mean())
                bests.append(values.max())
                worsts.append(values.min())
                medians.append(float(np.median(values)))
            else:
                means.append(math.nan)
                bests.append(math.nan)
                worsts.append(math.nan)
                medians.append(math.nan)
        return cls(
            np.array(births, dtype=np.int64), np.array(times, dtype=float),
            np.array(means, dtype=float), np.array(bests, dtype=float),
            np.array(worsts, dtype=float), np.array(medians, dtype=float),
            np.array(sizes, dtype=np.int64),
        )
