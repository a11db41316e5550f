"""The results store: one SQLite database per experiment.

Standard library ``sqlite3``, write-ahead log, versioned schema. Runs write their records in
batches, one transaction per *commit point* (an offline generation, an online birth): a batch
holds the robots, fitness samples, lifecycle transitions, population snapshot, diversity values
and failures since the previous commit point, together with the run's *checkpoint* (births,
simulated time, the random generator's state and the loop's state). A killed run therefore
loses at most the work since its last commit, and a resumed run starts exactly from the
checkpoint.

Tables (``run_id`` is the repeat index within the experiment, ``robot_id`` the birth index of the
robot within its run, so ``(run_id, robot_id)`` names a robot):

========== ===================================================================================
meta        key/value: ``schema_version``, ``package_version``, ``config`` (JSON), ``seed``
runs        one row per run: seed, status, births, simulated time, generation
checkpoints the latest commit point of each run: rng state and engine state (JSON)
robots      genome (robot JSON), parents, origin, conception/birth/death time, cause, fitness
fitness     fitness samples over simulated time (offline: one per evaluation), with ``v``,
            ``s`` and the shaking measure (offline; NULL online and before schema 7)
transitions every lifecycle transition with its simulated time
population  population snapshots: the members and their fitness after each commit point
diversity   population diversity over births
failures    crossover failures, blow-ups, learner failures, ... with their time
learning    infancy learning in the Training Center: the learned genome, the learner's inborn
            and learned fitness, its evaluations and simulated seconds (one row per infant
            whose learner ran without failing; failed learners are in ``failures``)
reevaluations robots evaluated again after their run (``revolve reevaluate``): kind (``final``
            or ``best``), repeat, conditions (JSON), window, shared world or not, seed, the
            stored and the new fitness; keyed without a timestamp, so a repeated reevaluation
            adds no rows (:mod:`evolution.experiments.app.reevaluate`)
========== ===================================================================================

The ``robots`` table always holds the genome *as conceived* (the inborn one). With Lamarckian
inheritance the genome a robot passes to its children is its learned genome
(``learning.learned_genome``); the checkpoint's engine state lists the members that reproduce
with it (``"learned"``), so a resumed run continues with the same genomes.

Schema versions: 1 had no ``learning`` table; 2 had no ``learning.policy`` column (the reference
to a saved SB3 policy in ``<results>/policies/``); 3 had no ``reevaluations`` table, and its
stored configs no ``evaluation`` table; 4 named the stored config's offline/online switch
``engine``; 5 stored SB3 learning tables without ``normalize`` and ``settings``; 6 had no
``fitness.shaking`` column and computed the fitness from the core's position at every control
period without saying so in its config. An older database
is upgraded in place when opened, in one transaction (the empty ``learning`` and
``reevaluations`` tables and the ``policy`` column, NULL in old rows, are added; a stored config
without ``evaluation`` gains the conditions its runs lived under,
:data:`~evolution.experiments.store.schema.CONDITIONS_OF_OLD_RUNS`: heading 0 offline, a random
heading online, no noise; its ``engine`` key becomes ``mode``,
:data:`~evolution.experiments.store.schema.MODE_OF_OLD_CONFIGS`; an SB3 learning table gains
``normalize = false`` and ``settings = "sb3-defaults"``, how its learner trained then,
:data:`~evolution.experiments.store.schema.SB3_OF_OLD_RUNS`; the ``shaking`` column is added,
NULL in old rows, and the stored task gains ``pose_rate = "every-period"``, the sampling its fitness
was computed at, :data:`~evolution.experiments.store.schema.POSE_RATE_OF_OLD_CONFIGS`; the version
is set to 7; nothing else changes); a database newer than this package is refused. An old database
that cannot be written is upgraded in a read-only copy in memory instead: readers (``report``,
``show``) read it,
``resume`` refuses it as it refuses any read-only database.

The query functions at the bottom (``fitness_over_births``, ``final_population``, ...) are what
reports and plots read.
"""

from __future__ import annotations

import json
import logging
import math
import os
import sqlite3
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Self

import revolve_env
from evolution.experiments.loop.errors import StoreError
from evolution.experiments.loop.records import (
    Batch,
    Checkpoint,
    DiversityPoint,
    FailureRecord,
    FitnessSample,
    LearningRecord,
    RobotRecord,
)
from evolution.experiments.store.results_folder import check_database
from evolution.experiments.store.schema import (
    MIGRATIONS,
    SCHEMA,
    SCHEMA_VERSION,
    TABLES,
    FitnessSeries,
    PopulationSnapshot,
    ReevaluationRecord,
    RunRecord,
)
from evolution.lifecycle import Stage, Transition

__all__ = [
    "DB_NAME", "SCHEMA_VERSION", "Batch", "Checkpoint", "DiversityPoint", "FailureRecord",
    "FitnessSample", "FitnessSeries", "LearningRecord", "ReevaluationRecord", "RobotRecord",
    "RunRecord", "Store", "StoreError", "engine_of_old_config", "package_version",
]

_log = logging.getLogger(__name__)

DB_NAME = "results.sqlite"
"""File name of the database inside a results directory."""


def package_version() -> str:
    """The installed version of ``revolve-env``; not installed: the package's own version."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("revolve-env")
    except PackageNotFoundError:  # run from a checkout (PYTHONPATH)
        import revolve_env

        return revolve_env.__version__


def _nullable(value: float | None) -> float | None:
    """SQLite has no NaN; store a non-finite fitness as NULL... except infinities, kept."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return None
    return float(value)


# --------------------------------------------------------------------------------------------
# The store


class Store:
    """An open results database. Use :meth:`create` for a new one, :meth:`open` otherwise."""

    def __init__(self, connection: sqlite3.Connection, path: Path) -> None:
        self._db = connection
        self.path = path

    # -- opening ---------------------------------------------------------------------------

    @staticmethod
    def _connect(path: Path) -> sqlite3.Connection:
        db = sqlite3.connect(path, timeout=60.0, isolation_level=None, check_same_thread=False)
        try:
            db.execute("PRAGMA busy_timeout = 60000")
            # WAL + NORMAL: a commit survives a killed process (not necessarily a power cut),
            # and commits do not wait for a disk flush.
            db.execute("PRAGMA synchronous = NORMAL")
        except BaseException:
            db.close()  # never left to the garbage collector (Python 3.13 warns)
            raise
        return db

    @classmethod
    def create(cls, path: str | Path, config: dict[str, Any], seed: int) -> Store:
        """Create a new database at ``path`` (which must not exist) for an experiment.

        An empty database (no tables: a run killed while it created its database) holds no
        results and is replaced.

        Raises:
            StoreError: ``path`` already exists (existing results are never overwritten).
        """
        path = Path(path)
        if path.exists() and cls.is_empty(path):
            for leftover in (path, Path(f"{path}-wal"), Path(f"{path}-shm")):
                leftover.unlink(missing_ok=True)
        if path.exists():
            raise StoreError(f"{path} already exists; refusing to overwrite existing results")
        path.parent.mkdir(parents=True, exist_ok=True)
        db = cls._connect(path)
        try:
            db.execute("PRAGMA journal_mode = WAL")
            # Schema and meta in one transaction: a database without meta is never left behind.
            with _transaction(db):
                for statement in SCHEMA.split(";"):
                    if statement.strip():
                        db.execute(statement)
                db.executemany(
                    "INSERT INTO meta (key, value) VALUES (?, ?)",
                    [
                        ("schema_version", str(SCHEMA_VERSION)),
                        ("package_version", package_version()),
                        ("config", json.dumps(config, sort_keys=True)),
                        ("seed", str(int(seed))),
                        ("physics", json.dumps(revolve_env.PHYSICS_REVISIONS, sort_keys=True)),
                    ],
                )
        except BaseException:
            db.close()
            path.unlink(missing_ok=True)
            raise
        return cls(db, path)

    @staticmethod
    def is_empty(path: str | Path) -> bool:
        """Whether ``path`` is a SQLite database without any table (or an empty file).

        A run killed before its database's first transaction leaves one: it holds nothing.
        A file that is not a regular, bounded one
        (:func:`~evolution.experiments.store.results_folder.check_database`) is not empty: it is not
        opened (a FIFO would hang SQLite).
        """
        try:
            check_database(Path(path))
        except StoreError:
            return False
        try:
            db = sqlite3.connect(path, timeout=60.0)
            try:
                return not db.execute("SELECT 1 FROM sqlite_master LIMIT 1").fetchall()
            finally:
                db.close()
        except sqlite3.DatabaseError:  # not a database at all: not ours to replace
            return False

    @classmethod
    def open(cls, path: str | Path) -> Store:
        """Open an existing database, checking that it is one of ours and not newer.

        The file and SQLite's files beside it are checked first: regular files (not symbolic
        links, FIFOs or devices) of a bounded size
        (:func:`~evolution.experiments.store.results_folder.check_database`).

        Raises:
            StoreError: missing file, not a regular file or too large, not a SQLite database,
                corrupt, not a results database, or a schema newer than this package
                understands.
        """
        path = Path(path)
        if not os.path.lexists(path):
            raise StoreError(f"no results database at {path}")
        check_database(path)
        # Every way out but success closes the connection: one left to the garbage collector
        # is an unclosed database (a ResourceWarning from Python 3.13).
        try:
            db = cls._connect(path)
        except sqlite3.DatabaseError as error:
            raise StoreError(
                f"{path} is not a readable SQLite database ({error}); corrupt?"
            ) from error
        try:
            check = db.execute("PRAGMA quick_check").fetchone()
            _check_database(db, path, check)
        except _ReadOnly:
            db = _upgraded_copy(db, path)
        except sqlite3.DatabaseError as error:
            db.close()
            raise StoreError(
                f"{path} is not a readable SQLite database ({error}); corrupt?"
            ) from error
        except BaseException:
            db.close()
            raise
        return cls(db, path)

    def close(self) -> None:
        """Close the connection."""
        self._db.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- meta ------------------------------------------------------------------------------

    def meta(self) -> dict[str, str]:
        """All key/value pairs of the meta table."""
        return dict(self._db.execute("SELECT key, value FROM meta").fetchall())

    @property
    def config(self) -> dict[str, Any]:
        """The experiment configuration the database was created for.

        Raises:
            StoreError: the stored configuration is not a JSON object (a damaged database).
        """
        try:
            config = json.loads(self.meta()["config"])
        except (ValueError, RecursionError):
            config = None
        if not isinstance(config, dict):
            raise StoreError(f"{self.path} is damaged: its stored configuration is not a JSON "
                             "object")
        return config

    @property
    def seed(self) -> int:
        """The experiment's seed."""
        return int(self.meta()["seed"])

    @property
    def physics_revisions(self) -> dict[str, int]:
        """Engine -> the revision of its stepping the results were made with.

        :data:`revolve_env.PHYSICS_REVISIONS` at creation; 1 for a database made before they
        were recorded (or a damaged record).
        """
        try:
            stored = json.loads(self.meta().get("physics", "{}"))
        except (ValueError, RecursionError):
            stored = {}
        if not isinstance(stored, dict):
            stored = {}
        return {engine: stored[engine] if isinstance(stored.get(engine), int) else 1
                for engine in revolve_env.PHYSICS_REVISIONS}

    # -- writing ---------------------------------------------------------------------------

    def add_run(self, run_id: int, seed: int) -> None:
        """Register a run (status ``pending``); a no-op if it exists with the same seed."""
        with _transaction(self._db):
            row = self._db.execute("SELECT seed FROM runs WHERE run_id = ?", (run_id,)).fetchone()
            if row is None:
                self._db.execute(
                    "INSERT INTO runs (run_id, seed, status) VALUES (?, ?, 'pending')",
                    (run_id, int(seed)),
                )
            elif row[0] != int(seed):
                raise StoreError(f"run {run_id} exists with seed {row[0]}, not {seed}")

    def set_status(self, run_id: int, status: str) -> None:
        """Set a run's status (``pending``, ``running``, ``interrupted``, ``finished``)."""
        with _transaction(self._db):
            self._db.execute("UPDATE runs SET status = ? WHERE run_id = ?", (status, run_id))

    def commit(self, run_id: int, batch: Batch, checkpoint: Checkpoint) -> None:
        """Write one commit point atomically: the batch's records and the run's checkpoint."""
        db = self._db
        with _transaction(db):
            db.executemany(
                "INSERT INTO robots (run_id, robot_id, genome, parent_a, parent_b, origin, "
                "generation, conceived_time, birth_time, death_time, death_cause, fitness) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                [
                    (run_id, r.robot_id, r.genome, r.parent_a, r.parent_b, r.origin, r.generation,
                     r.conceived_time, r.birth_time, r.death_time, r.death_cause,
                     _nullable(r.fitness))
                    for r in batch.robots
                ],
            )
            db.executemany(
                "UPDATE robots SET fitness = ? WHERE run_id = ? AND robot_id = ?",
                [(_nullable(f), run_id, rid) for rid, f in batch.fitness_updates],
            )
            db.executemany(
                "UPDATE robots SET death_time = ?, death_cause = ?, "
                "fitness = COALESCE(?, fitness) WHERE run_id = ? AND robot_id = ?",
                [(t, cause, _nullable(f), run_id, rid) for rid, t, cause, f in batch.deaths],
            )
            db.executemany(
                "INSERT INTO fitness (run_id, robot_id, time, fitness, v, s, shaking) "
                "VALUES (?, ?, ?, ?, ?, ?, ?)",
                [(run_id, s.robot_id, s.time, s.fitness, s.v, s.s, s.shaking)
                 for s in batch.fitness],
            )
            db.executemany(
                "INSERT INTO transitions (run_id, robot_id, source, target, time, note) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                [
                    (run_id, t.robot_id, None if t.source is None else t.source.value,
                     t.target.value, t.time, t.note)
                    for t in batch.transitions
                ],
            )
            if batch.population is not None:
                db.executemany(
                    "INSERT INTO population (run_id, births, sim_time, robot_id, fitness) "
                    "VALUES (?, ?, ?, ?, ?)",
                    [
                        (run_id, checkpoint.births, checkpoint.sim_time, rid, _nullable(f))
                        for rid, f in batch.population
                    ],
                )
            if batch.diversity is not None:
                db.execute(
                    "INSERT OR REPLACE INTO diversity (run_id, births, sim_time, value) "
                    "VALUES (?, ?, ?, ?)",
                    (run_id, checkpoint.births, checkpoint.sim_time, float(batch.diversity)),
                )
            db.executemany(
                "INSERT INTO failures (run_id, robot_id, time, kind, detail) "
                "VALUES (?, ?, ?, ?, ?)",
                [(run_id, f.robot_id, f.time, f.kind, f.detail) for f in batch.failures],
            )
            db.executemany(
                "INSERT INTO learning (run_id, robot_id, time, inheritance, learned_genome, "
                "inborn_fitness, learned_fitness, evaluations, sim_seconds, failures, policy) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                [(run_id, r.robot_id, r.time, r.inheritance, r.learned_genome,
                  _nullable(r.inborn_fitness), _nullable(r.learned_fitness), r.evaluations,
                  r.sim_seconds, r.failures, r.policy) for r in batch.learning],
            )
            db.execute(
                "INSERT OR REPLACE INTO checkpoints "
                "(run_id, births, sim_time, generation, rng_state, engine_state) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (run_id, checkpoint.births, checkpoint.sim_time, checkpoint.generation,
                 json.dumps(checkpoint.rng_state, sort_keys=True),
                 json.dumps(checkpoint.engine_state, sort_keys=True)),
            )
            db.execute(
                "UPDATE runs SET births = ?, sim_time = ?, generation = ? WHERE run_id = ?",
                (checkpoint.births, checkpoint.sim_time, checkpoint.generation, run_id),
            )

    def add_reevaluations(self, records: Sequence[ReevaluationRecord]) -> int:
        """Write reevaluations in one transaction; rows whose key is stored already are kept.

        Returns:
            How many rows were new.
        """
        with _transaction(self._db):
            before = self._db.total_changes
            self._db.executemany(
                f"INSERT OR IGNORE INTO reevaluations ({_REEVALUATION_COLUMNS}) "
                "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                [(r.run_id, r.robot_id, r.kind, r.repeat, r.conditions, float(r.insertion),
                  float(r.seconds), int(r.shared_world), r.seed, r.controller,
                  _nullable(r.stored_fitness), _nullable(r.fitness), _nullable(r.v),
                  _nullable(r.s), r.failure) for r in records])
            return self._db.total_changes - before

    # -- reading ---------------------------------------------------------------------------

    def reevaluations(self, kind: str | None = None) -> list[ReevaluationRecord]:
        """Stored reevaluations (of one kind if given), by run, kind, robot, setting, repeat."""
        query = f"SELECT {_REEVALUATION_COLUMNS} FROM reevaluations"
        args: tuple[str, ...] = ()
        if kind is not None:
            query += " WHERE kind = ?"
            args = (kind,)
        rows = self._db.execute(
            query + " ORDER BY run_id, kind, robot_id, conditions, insertion, shared_world, "
            "repeat, seed", args).fetchall()
        return [ReevaluationRecord(r[0], r[1], r[2], r[3], r[4], r[5], r[6], bool(r[7]), r[8],
                                   r[9], r[10], r[11], r[12], r[13], r[14]) for r in rows]

    def checkpoint(self, run_id: int) -> Checkpoint | None:
        """The latest commit point of a run, ``None`` before the first."""
        row = self._db.execute(
            "SELECT births, sim_time, generation, rng_state, engine_state FROM checkpoints "
            "WHERE run_id = ?",
            (run_id,),
        ).fetchone()
        if row is None:
            return None
        return Checkpoint(row[0], row[1], row[2], json.loads(row[3]), json.loads(row[4]))

    def runs(self) -> list[RunRecord]:
        """All runs, by id."""
        rows = self._db.execute(
            "SELECT run_id, seed, status, births, sim_time, generation FROM runs ORDER BY run_id"
        ).fetchall()
        return [RunRecord(*row) for row in rows]

    def robot(self, run_id: int, robot_id: int) -> RobotRecord:
        """One robot.

        Raises:
            KeyError: no such robot.
        """
        row = self._db.execute(
            f"SELECT {_ROBOT_COLUMNS} FROM robots WHERE run_id = ? AND robot_id = ?",
            (run_id, robot_id),
        ).fetchone()
        if row is None:
            raise KeyError(f"no robot {robot_id} in run {run_id} of {self.path}")
        return RobotRecord(*row)

    def robots(self, run_id: int, ids: Sequence[int] | None = None) -> list[RobotRecord]:
        """The robots of a run in birth order (only ``ids`` if given)."""
        rows = self._db.execute(
            f"SELECT {_ROBOT_COLUMNS} FROM robots WHERE run_id = ? ORDER BY robot_id", (run_id,)
        ).fetchall()
        records = [RobotRecord(*row) for row in rows]
        if ids is not None:
            wanted = set(ids)
            records = [r for r in records if r.robot_id in wanted]
        return records

    def fitness_samples(self, run_id: int, robot_id: int | None = None) -> list[FitnessSample]:
        """Fitness samples of a run (of one robot if given), in time order."""
        query = "SELECT robot_id, time, fitness, v, s, shaking FROM fitness WHERE run_id = ?"
        args: tuple[int, ...] = (run_id,)
        if robot_id is not None:
            query += " AND robot_id = ?"
            args += (robot_id,)
        rows = self._db.execute(query + " ORDER BY time, robot_id", args).fetchall()
        return [FitnessSample(*row) for row in rows]

    def transitions(self, run_id: int, robot_id: int | None = None) -> list[Transition]:
        """Lifecycle transitions of a run (of one robot if given), in recorded order."""
        query = "SELECT robot_id, source, target, time, note FROM transitions WHERE run_id = ?"
        args: tuple[int, ...] = (run_id,)
        if robot_id is not None:
            query += " AND robot_id = ?"
            args += (robot_id,)
        rows = self._db.execute(query + " ORDER BY rowid", args).fetchall()
        return [
            Transition(rid, None if src is None else Stage(src), Stage(dst), time, note)
            for rid, src, dst, time, note in rows
        ]

    def failures(self, run_id: int, kind: str | None = None) -> list[FailureRecord]:
        """Handled failures of a run (of one kind if given), in recorded order."""
        query = "SELECT robot_id, time, kind, detail FROM failures WHERE run_id = ?"
        args: tuple[int | str, ...] = (run_id,)
        if kind is not None:
            query += " AND kind = ?"
            args += (kind,)
        return [FailureRecord(*row) for row in self._db.execute(query + " ORDER BY rowid", args)]

    def learning(self, run_id: int, ids: Sequence[int] | None = None) -> list[LearningRecord]:
        """Infancy learning records of a run (only of ``ids`` if given), in birth order."""
        rows = self._db.execute(
            "SELECT robot_id, time, inheritance, learned_genome, inborn_fitness, learned_fitness, "
            "evaluations, sim_seconds, failures, policy FROM learning WHERE run_id = ? "
            "ORDER BY robot_id",
            (run_id,),
        ).fetchall()
        records = [LearningRecord(*row) for row in rows]
        if ids is not None:
            wanted = set(ids)
            records = [r for r in records if r.robot_id in wanted]
        return records

    def population_snapshots(self, run_id: int) -> list[PopulationSnapshot]:
        """Every population snapshot: ``(births, sim_time, [(robot_id, fitness), ...])``."""
        rows = self._db.execute(
            "SELECT births, sim_time, robot_id, fitness FROM population WHERE run_id = ? "
            "ORDER BY births, rowid",
            (run_id,),
        ).fetchall()
        snapshots: list[PopulationSnapshot] = []
        for births, sim_time, robot_id, fitness in rows:
            if not snapshots or snapshots[-1][0] != births:
                snapshots.append((births, sim_time, []))
            snapshots[-1][2].append((robot_id, fitness))
        return snapshots

    def fitness_over_births(self, run_id: int) -> FitnessSeries:
        """Population fitness statistics after each commit point of a run (for plots)."""
        return FitnessSeries.from_snapshots(self.population_snapshots(run_id))

    def final_population(self, run_id: int) -> list[tuple[int, float | None]]:
        """The last population snapshot of a run: ``[(robot_id, fitness), ...]``."""
        snapshots = self.population_snapshots(run_id)
        return snapshots[-1][2] if snapshots else []

    def diversity_over_births(self, run_id: int) -> list[DiversityPoint]:
        """Population diversity over births, in birth order."""
        rows = self._db.execute(
            "SELECT births, sim_time, value FROM diversity WHERE run_id = ? ORDER BY births",
            (run_id,),
        ).fetchall()
        return [DiversityPoint(*row) for row in rows]

    def query(self, sql: str, params: Sequence[Any] = ()) -> list[tuple[Any, ...]]:
        """Run one SQL statement and return its rows.

        For read-only checks such as :func:`evolution.experiments.store.integrity.verify`.
        """
        return self._db.execute(sql, tuple(params)).fetchall()

    def table_counts(self) -> dict[str, int]:
        """Number of rows of each table (for summaries and tests)."""
        names = [r[0] for r in self._db.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")]
        return {n: self._db.execute(f"SELECT COUNT(*) FROM {n}").fetchone()[0] for n in names}


_ROBOT_COLUMNS = (
    "run_id, robot_id, genome, parent_a, parent_b, origin, generation, conceived_time, "
    "birth_time, death_time, death_cause, fitness"
)


_REEVALUATION_COLUMNS = (
    "run_id, robot_id, kind, repeat, conditions, insertion, seconds, shared_world, seed, "
    "controller, stored_fitness, fitness, v, s, failure"
)


def _check_database(db: sqlite3.Connection, path: Path, check: tuple[str] | None) -> None:
    """Raise :class:`StoreError` unless ``db`` is an intact results database of this package.

    ``check`` is the row of ``PRAGMA quick_check``. A database of an older schema is upgraded
    in place.
    """
    if check is None or check[0] != "ok":
        raise StoreError(f"{path} is corrupt: integrity check says {check!r}")
    if not db.execute("SELECT 1 FROM sqlite_master LIMIT 1").fetchall():
        raise StoreError(
            f"{path} is empty: the experiment was stopped while it created its database, "
            "before storing anything; start it again with the same `revolve run` (or `revolve "
            "study`) command, which replaces an empty database")
    try:
        rows = dict(db.execute("SELECT key, value FROM meta").fetchall())
    except sqlite3.DatabaseError as error:
        raise StoreError(f"{path} is not a revolve-env results database ({error})") from error
    if "schema_version" not in rows or "config" not in rows:
        raise StoreError(
            f"{path} is not a revolve-env results database (meta table incomplete)"
        )
    try:
        version = int(rows["schema_version"])
    except ValueError:
        raise StoreError(
            f"{path} has an unreadable schema version {rows['schema_version']!r}; corrupt?"
        ) from None
    if version > SCHEMA_VERSION:
        raise StoreError(
            f"{path} has schema version {version}, newer than this package's "
            f"{SCHEMA_VERSION}; upgrade revolve-env to read it"
        )
    if version < SCHEMA_VERSION:
        if version < 8:
            engine_of_old_config(db, path)
        try:
            _migrate(db, version)
        except sqlite3.Error as error:
            if _is_read_only(error):
                raise _ReadOnly(path) from error
            raise StoreError(
                f"{path} has schema version {version}, older than this package's "
                f"{SCHEMA_VERSION}, and could not be upgraded in place ({error}); open it "
                "once with write access, or with the revolve-env version that wrote it"
            ) from error
    rows_of_tables = db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")
    tables = {row[0] for row in rows_of_tables}
    missing = sorted(TABLES - tables)
    if missing:
        raise StoreError(
            f"{path} is incomplete: table(s) {', '.join(missing)} missing; corrupt?"
        )


def engine_of_old_config(db: sqlite3.Connection, path: Path) -> bool:
    """Say in one line (logged) that ``db``'s stored config names no engine and is read as pybullet.

    The rule itself is the schema 8 upgrade (:data:`~evolution.experiments.records.
    ENGINE_OF_OLD_CONFIGS`); this is its one line, said before it is applied (on every open of a
    read-only database, whose upgrade is a copy in memory).

    Returns:
        Whether the config names no engine.
    """
    unnamed = db.execute(
        "SELECT 1 FROM meta WHERE key = 'config' AND json_valid(value) "
        "AND json_type(value) = 'object' AND json_type(value, '$.world.engine') IS NULL "
        "AND (json_type(value, '$.world') IS NULL OR json_type(value, '$.world') = 'object')"
    ).fetchall()
    if unnamed:
        _log.warning("%s: its config names no physics engine (stored before MuJoCo became the "
                     "default): read as pybullet, the engine it ran on", path)
    return bool(unnamed)


class _ReadOnly(StoreError):
    """An old database that cannot be upgraded in place because it cannot be written."""


def _is_read_only(error: sqlite3.Error) -> bool:
    """Whether SQLite refused a write because the file (or its folder) is read-only."""
    code = getattr(error, "sqlite_errorcode", None)
    return code is not None and code & 0xFF == sqlite3.SQLITE_READONLY


def _upgraded_copy(db: sqlite3.Connection, path: Path) -> sqlite3.Connection:
    """A read-only database of an older schema, upgraded in a copy in memory; ``db`` is closed.

    ``revolve report``, ``show`` and the other readers read it as they read one upgraded in
    place; the copy refuses writes (``query_only``), so ``resume`` still finds it read-only
    (:func:`~evolution.experiments.store.integrity.check_writable`) and nothing is written anywhere.
    """
    copy = sqlite3.connect(":memory:", isolation_level=None, check_same_thread=False)
    try:
        db.backup(copy)
    except BaseException:
        copy.close()
        raise
    finally:
        db.close()
    try:
        _check_database(copy, path, ("ok",))
    except BaseException:
        copy.close()
        raise
    copy.execute("PRAGMA query_only = ON")
    return copy


def _migrate(db: sqlite3.Connection, version: int) -> None:
    """Bring a database of an older schema ``version`` to :data:`SCHEMA_VERSION`.

    One transaction: either fully upgraded or untouched.
    """
    with _transaction(db):
        for old in range(version, SCHEMA_VERSION):
            for statement in MIGRATIONS[old].split(";"):
                if statement.strip():
                    db.execute(statement)
        db.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'",
                   (str(SCHEMA_VERSION),))


@contextmanager
def _transaction(db: sqlite3.Connection) -> Iterator[None]:
    db.execute("BEGIN IMMEDIATE")
    try:
        yield
    except BaseException:
        db.execute("ROLLBACK")
        raise
    db.execute("COMMIT")
