"""The SQLite results store: schema, transactional commits, clear errors, queries."""

from __future__ import annotations

import contextlib
import json
import math
import sqlite3
from pathlib import Path

import numpy as np
import pytest

from evolution.experiments.loop.config import ExperimentConfig
from evolution.experiments.store.database import (
    SCHEMA_VERSION,
    Batch,
    Checkpoint,
    FailureRecord,
    FitnessSample,
    LearningRecord,
    ReevaluationRecord,
    RobotRecord,
    Store,
    StoreError,
)
from evolution.lifecycle import Stage, Transition
from revolve_env.conditions import IDEAL

TABLES = {"meta", "runs", "checkpoints", "robots", "fitness", "transitions", "population",
          "diversity", "failures", "learning", "reevaluations"}


def _checkpoint(births: int, t: float) -> Checkpoint:
    rng = np.random.default_rng(births)
    return Checkpoint(births, t, births, rng.bit_generator.state, {"population": [[0, 1.5]]})


def _robot(robot_id: int, t: float,
           parents: tuple[int | None, int | None] = (None, None)) -> RobotRecord:
    return RobotRecord(0, robot_id, f'{{"id": {robot_id}}}', parents[0], parents[1],
                       "random" if parents[0] is None else "reproduction", 0, t, t)


@pytest.fixture()
def store(tmp_path: Path) -> Store:
    s = Store.create(tmp_path / "results.sqlite", {"name": "test", "births": 3}, seed=5)
    s.add_run(0, 1234)
    yield s
    s.close()


def test_schema_and_meta(store: Store) -> None:
    assert set(store.table_counts()) == TABLES
    meta = store.meta()
    assert meta["schema_version"] == str(SCHEMA_VERSION)
    assert meta["package_version"]
    assert store.config == {"name": "test", "births": 3}
    assert store.seed == 5
    with contextlib.closing(sqlite3.connect(store.path)) as con:
        mode = con.execute("PRAGMA journal_mode").fetchone()[0]
    assert mode == "wal"


def test_commit_writes_everything_and_queries_read_it(store: Store) -> None:
    batch = Batch()
    batch.robots += [_robot(0, 0.0), _robot(1, 15.0), _robot(2, 30.0, (0, 1))]
    batch.fitness += [FitnessSample(0, 15.0, 1.0, 0.5, 0.1), FitnessSample(1, 30.0, 3.0)]
    batch.fitness_updates += [(0, 1.0), (1, 3.0)]
    batch.transitions += [Transition(0, None, Stage.CONCEPTION, 0.0, "random"),
                          Transition(0, Stage.CONCEPTION, Stage.DELIVERY, 0.0)]
    batch.deaths.append((2, 45.0, "blow-up: too fast", None))
    batch.failures.append(FailureRecord(2, 45.0, "blow-up", "too fast"))
    batch.population = [(0, 1.0), (1, 3.0)]
    batch.diversity = 4.5
    store.commit(0, batch, _checkpoint(3, 45.0))
    assert len(batch.robots) == 3  # left as it was: the loop's observers may read it after

    assert store.robot(0, 2).parent_a == 0 and store.robot(0, 2).parent_b == 1
    assert store.robot(0, 2).death_cause == "blow-up: too fast"
    assert store.robot(0, 1).fitness == 3.0
    assert [r.robot_id for r in store.robots(0)] == [0, 1, 2]
    assert [s.fitness for s in store.fitness_samples(0, robot_id=0)] == [1.0]
    assert ([t.target for t in store.transitions(0, robot_id=0)]
            == [Stage.CONCEPTION, Stage.DELIVERY])
    assert store.failures(0, kind="blow-up")[0].detail == "too fast"
    series = store.fitness_over_births(0)
    assert series.births.tolist() == [3] and series.mean.tolist() == [2.0]
    assert series.best.tolist() == [3.0] and series.size.tolist() == [2]
    assert store.final_population(0) == [(0, 1.0), (1, 3.0)]
    assert [(d.births, d.value) for d in store.diversity_over_births(0)] == [(3, 4.5)]
    cp = store.checkpoint(0)
    assert cp is not None and cp.births == 3 and cp.engine_state == {"population": [[0, 1.5]]}
    assert cp.rng_state == np.random.default_rng(3).bit_generator.state
    assert store.runs()[0].births == 3 and store.runs()[0].seed == 1234
    with pytest.raises(KeyError, match="no robot 9 in run 0"):
        store.robot(0, 9)


def test_failed_commit_leaves_no_trace(store: Store) -> None:
    store.commit(0, Batch(robots=[_robot(0, 0.0)]), _checkpoint(1, 15.0))
    before = store.table_counts()
    bad = Batch(robots=[_robot(1, 15.0), _robot(0, 15.0)])  # robot 0 again: primary key clash
    with pytest.raises(sqlite3.IntegrityError):
        store.commit(0, bad, _checkpoint(2, 30.0))
    assert store.table_counts() == before
    assert store.checkpoint(0).births == 1


def test_create_never_overwrites(tmp_path: Path, store: Store) -> None:
    with pytest.raises(StoreError, match="refusing to overwrite"):
        Store.create(store.path, {}, 0)


def test_open_errors_name_the_problem(tmp_path: Path) -> None:
    with pytest.raises(StoreError, match="no results database"):
        Store.open(tmp_path / "missing.sqlite")
    garbage = tmp_path / "garbage.sqlite"
    garbage.write_bytes(b"this is not a database at all" * 200)
    with pytest.raises(StoreError, match="not a readable SQLite database"):
        Store.open(garbage)
    other = tmp_path / "other.sqlite"
    with contextlib.closing(sqlite3.connect(other)) as con:
        con.execute("CREATE TABLE t (x)").connection.commit()
    with pytest.raises(StoreError, match="not a revolve-env results database"):
        Store.open(other)
    broken = tmp_path / "broken.sqlite"
    Store.create(broken, {}, 0).close()
    db = sqlite3.connect(broken)
    db.execute("DROP TABLE runs")
    db.commit()
    db.close()
    with pytest.raises(StoreError, match="incomplete: table\\(s\\) runs missing"):
        Store.open(broken)
    db = sqlite3.connect(broken)
    db.execute("UPDATE meta SET value = 'two' WHERE key = 'schema_version'")
    db.commit()
    db.close()
    with pytest.raises(StoreError, match="unreadable schema version 'two'"):
        Store.open(broken)


def test_newer_schema_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "results.sqlite"
    Store.create(path, {}, 0).close()
    db = sqlite3.connect(path)
    db.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'", (str(SCHEMA_VERSION + 1),))
    db.commit()
    db.close()
    with pytest.raises(StoreError, match=f"schema version {SCHEMA_VERSION + 1}, newer"):
        Store.open(path)


def test_learning_records_round_trip(store: Store) -> None:
    learned = LearningRecord(1, 15.0, "lamarckian", '{"id": 1, "learned": true}', 0.25, 0.75, 17,
                             119.0, 2)
    unchanged = LearningRecord(0, 0.0, "darwinian", None, 0.5, 0.5, 5, 35.0)
    store.commit(0, Batch(robots=[_robot(0, 0.0), _robot(1, 15.0)],
                          learning=[learned, unchanged]), _checkpoint(2, 30.0))
    assert store.learning(0) == [unchanged, learned]  # birth order
    assert store.learning(0, [1]) == [learned]
    assert learned.improvement == 0.5 and LearningRecord(2, 0.0, "darwinian", None, None, 1.0,
                                                         None, None).improvement is None


def _make_old(path: Path, version: int, *, drop: tuple[str, ...] = (),
              config: dict[str, object] | None = None, sql: tuple[str, ...] = ()) -> None:
    """Turn a fresh database into one written by schema ``version``: the tables it did not have
    dropped, the fitness table without schema 7's ``shaking``, then ``sql`` run and its config
    stored as ``config`` (if given) as that version stored it."""
    db = sqlite3.connect(path)
    for table in drop:
        db.execute(f"DROP TABLE {table}")
    db.execute("ALTER TABLE fitness DROP COLUMN shaking")  # added by schema 7
    for statement in sql:
        db.execute(statement)
    db.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'", (str(version),))
    if config is not None:
        db.execute("UPDATE meta SET value = ? WHERE key = 'config'", (json.dumps(config),))
    db.commit()
    db.close()


def test_version_1_database_is_upgraded_in_place(tmp_path: Path) -> None:
    """A database written before the learning table existed opens, gains an empty learning
    table (with its policy column) and the current version, and keeps every record."""
    path = tmp_path / "results.sqlite"
    with Store.create(path, {"name": "old"}, 0) as s:
        s.add_run(0, 7)
        s.commit(0, Batch(robots=[_robot(0, 0.0)]), _checkpoint(1, 15.0))
    _make_old(path, 1, drop=("learning", "reevaluations"))
    with Store.open(path) as s:
        assert s.meta()["schema_version"] == str(SCHEMA_VERSION) == "8"
        assert s.learning(0) == [] and [r.robot_id for r in s.robots(0)] == [0]
        assert set(s.table_counts()) == TABLES


def test_version_2_database_gains_the_policy_column(tmp_path: Path) -> None:
    """A version-2 database (learning table without ``policy``) is upgraded in place: its
    learning records keep their values and read back with no policy."""
    path = tmp_path / "results.sqlite"
    with Store.create(path, {"name": "old"}, 0) as s:
        s.add_run(0, 7)
    _make_old(path, 2, drop=("learning", "reevaluations"), sql=(
        "CREATE TABLE learning (run_id INTEGER NOT NULL, robot_id INTEGER NOT NULL, "
        "time REAL NOT NULL, inheritance TEXT NOT NULL, learned_genome TEXT, "
        "inborn_fitness REAL, learned_fitness REAL, evaluations INTEGER, sim_seconds REAL, "
        "failures INTEGER NOT NULL DEFAULT 0, PRIMARY KEY (run_id, robot_id))",
        "INSERT INTO learning VALUES (0, 0, 0.0, 'darwinian', NULL, 0.5, 0.75, 3, 21.0, 0)"))
    with Store.open(path) as s:
        assert s.meta()["schema_version"] == "8"
        assert s.learning(0) == [LearningRecord(0, 0.0, "darwinian", None, 0.5, 0.75, 3, 21.0)]


def test_infinite_and_missing_fitness(store: Store) -> None:
    batch = Batch(robots=[_robot(0, 0.0)], population=[(0, None)])
    store.commit(0, batch, _checkpoint(1, 15.0))
    series = store.fitness_over_births(0)
    assert math.isnan(series.mean[0]) and series.size[0] == 1


def test_run_seed_conflict(store: Store) -> None:
    store.add_run(0, 1234)  # idempotent
    with pytest.raises(StoreError, match="exists with seed"):
        store.add_run(0, 99)


OLD_TASK = {"name": "locomotion", "pose_rate": "every-period"}
"""The task a config stored before schema 7 without one gains: the fitness it was scored with."""

OLD_WORLD = {"engine": "pybullet"}
"""The world table a config stored before schema 8 without an engine gains: the engine it ran on."""


def _dump(path: Path, tables: list[str]) -> dict[str, list[tuple[object, ...]]]:
    """Every row of ``tables``, without the columns that upgrades add (NULL in old rows)."""
    db = sqlite3.connect(path)
    try:
        out = {}
        for t in tables:
            columns = [c[1] for c in db.execute(f"PRAGMA table_info({t})")]
            if "shaking" in columns:  # schema 7's
                assert db.execute(f"SELECT count(*) FROM {t} WHERE shaking IS NOT NULL"
                                  ).fetchone() == (0,)
            keep = ", ".join(c for c in columns if c != "shaking")
            out[t] = db.execute(f"SELECT {keep} FROM {t} ORDER BY rowid").fetchall()
        return out
    finally:
        db.close()


@pytest.mark.parametrize(("engine", "heading"), [("offline", 0.0), ("online", "random"),
                                                 (None, 0.0)])
def test_version_3_database_is_upgraded_in_place(
        tmp_path: Path, engine: str | None, heading: object) -> None:
    """A version-3 database gains the empty reevaluations table, and its stored config the
    conditions its runs lived under (offline, the default engine: heading 0; online: random);
    every old row stays as it was."""
    path = tmp_path / "results.sqlite"
    config: dict[str, object] = {"name": "old", "births": 3}
    if engine is not None:
        config["engine"] = engine
    with Store.create(path, config, 0) as s:
        s.add_run(0, 7)
        s.commit(0, Batch(robots=[_robot(0, 0.0)], population=[(0, 1.0)],
                          fitness=[FitnessSample(0, 15.0, 1.0, 0.5, 0.1)]), _checkpoint(1, 15.0))
    _make_old(path, 3, drop=("reevaluations",), config=config)
    old_tables = sorted(TABLES - {"meta", "reevaluations"})
    before = _dump(path, old_tables)
    renamed = {("mode" if k == "engine" else k): v for k, v in config.items()}
    with Store.open(path) as s:
        assert s.meta()["schema_version"] == "8"
        assert s.config == {**renamed, "evaluation": {
            "heading": heading, "position_jitter": 0.0, "sensor_noise": 0.0,
            "actuator_noise": 0.0}, "task": OLD_TASK, "world": OLD_WORLD}
        assert s.reevaluations() == [] and set(s.table_counts()) == TABLES
    assert _dump(path, old_tables) == before
    with Store.open(path) as s:  # opening again changes nothing more
        assert s.config["evaluation"]["heading"] == heading


@pytest.mark.parametrize("mode", ["offline", "online", None])
def test_version_4_database_names_its_mode(tmp_path: Path, mode: str | None) -> None:
    """A version-4 database stored the switch between offline and online evolution as
    ``engine``: opened, its stored config calls it ``mode`` with the same value (none stored:
    offline, the default of both names), and every other row stays as it was."""
    path = tmp_path / "results.sqlite"
    config: dict[str, object] = {"name": "old", "births": 3, "world": {"engine": "mujoco"}}
    if mode is not None:
        config["engine"] = mode
    with Store.create(path, config, 0) as s:
        s.add_run(0, 7)
        s.commit(0, Batch(robots=[_robot(0, 0.0)], population=[(0, 1.0)]), _checkpoint(1, 15.0))
    _make_old(path, 4)
    tables = sorted(TABLES - {"meta"})
    before = _dump(path, tables)
    expected = {k: v for k, v in config.items() if k != "engine"} | {"task": OLD_TASK}
    if mode is not None:
        expected["mode"] = mode
    with Store.open(path) as s:
        assert s.meta()["schema_version"] == "8" and s.config == expected
        assert ExperimentConfig.from_dict({**s.config, "births": 15}).mode == (mode or "offline")
    assert _dump(path, tables) == before
    with Store.open(path) as s:  # opening again changes nothing more
        assert s.config == expected


def test_upgrade_keeps_stored_conditions(tmp_path: Path) -> None:
    """A stored config that already names its conditions keeps them."""
    path = tmp_path / "results.sqlite"
    conditions = {"heading": 1.5, "position_jitter": 0.1, "sensor_noise": 0.0,
                  "actuator_noise": 0.05}
    config = {"name": "old", "engine": "online", "evaluation": conditions}
    Store.create(path, config, 0).close()
    _make_old(path, 3, drop=("reevaluations",), config=config)
    with Store.open(path) as s:
        assert s.config["evaluation"] == conditions


def test_reevaluations_are_written_once(store: Store) -> None:
    """The key has no timestamp: writing the same reevaluation again adds nothing and keeps the
    first values; another repeat or window is a new row."""
    row = ReevaluationRecord(0, 2, "final", 0, '{"heading": "random"}', 3.0, 12.0, False, 99,
                             "inborn", 4.0, 3.5, 1.0, 0.5, None)
    assert store.add_reevaluations([row]) == 1
    assert store.add_reevaluations([row, ReevaluationRecord(
        *row.key[:1], 2, "final", 0, row.conditions, 3.0, 12.0, False, 99, "inborn", 4.0, 9.9)]
    ) == 0
    later = ReevaluationRecord(0, 2, "final", 0, row.conditions, 6.0, 12.0, False, 99, "inborn",
                               4.0, None, failure="blow-up: too fast")
    again = ReevaluationRecord(0, 2, "final", 1, row.conditions, 3.0, 12.0, True, 98, "learned",
                               4.0, math.inf)
    assert store.add_reevaluations([later, again]) == 2
    assert store.reevaluations() == [row, again, later]
    assert store.reevaluations("best") == []


def test_upgrade_pins_the_learning_conditions_of_old_runs(tmp_path: Path) -> None:
    """Before conditions existed infants learned at heading 0 in both engines: an old online
    learning run keeps learning so after the upgrade, though its own newborns face random
    headings, so a resumed run trains its infants as the stored ones were trained."""
    path = tmp_path / "results.sqlite"
    learning = {"learner": "cma-es", "budget": 60.0, "insertion": 0.5, "seconds": 1.0}
    config: dict[str, object] = {"name": "old", "engine": "online", "learning": learning}
    Store.create(path, config, 0).close()
    _make_old(path, 3, drop=("reevaluations",), config=config)
    with Store.open(path) as s:
        stored = s.config
    assert stored["evaluation"]["heading"] == "random"
    assert stored["learning"]["conditions"]["heading"] == 0.0
    center = ExperimentConfig.from_dict(
        {**stored, "population_size": 8, "births": 10}).training_center()
    assert center is not None
    assert center.learner.evaluation.conditions == IDEAL  # type: ignore[attr-defined]
    fresh = ExperimentConfig.from_dict({"mode": "online", "learning": learning,
                                        "population_size": 8, "births": 10})
    center = fresh.training_center()
    learner = center.learner if center is not None else None
    assert learner.evaluation.conditions.random_heading  # type: ignore[union-attr]


@pytest.mark.parametrize(("task", "expected"), [
    (None, OLD_TASK),
    ({"name": "directed-locomotion", "heading": 1.0},
     {"name": "directed-locomotion", "heading": 1.0, "pose_rate": "every-period"}),
    # a pose rate already there is kept (a table written by hand for the new code)
    ({"name": "locomotion", "pose_rate": 5}, {"name": "locomotion", "pose_rate": 5}),
])
def test_version_6_database_keeps_the_pose_rate_it_was_scored_at(
        tmp_path: Path, task: dict[str, object] | None, expected: dict[str, object]) -> None:
    """Before schema 7 the fitness sampled the core every control period: an old stored config
    says so after the upgrade, so its runs resume to their own numbers, and its old fitness
    samples read back with no shaking measure."""
    path = tmp_path / "results.sqlite"
    config: dict[str, object] = {"name": "old", "births": 3}
    if task is not None:
        config["task"] = task
    with Store.create(path, config, 0) as s:
        s.add_run(0, 7)
        s.commit(0, Batch(robots=[_robot(0, 0.0)],
                          fitness=[FitnessSample(0, 15.0, 1.0, 0.5, 0.1, 1.25)]),
                 _checkpoint(1, 15.0))
    _make_old(path, 6)
    with Store.open(path) as s:
        assert s.meta()["schema_version"] == "8" and s.config["task"] == expected
        assert s.fitness_samples(0) == [FitnessSample(0, 15.0, 1.0, 0.5, 0.1, None)]
        fitness_task = ExperimentConfig.from_dict({**s.config, "births": 15}).fitness_task()
        assert fitness_task.to_dict()["pose_rate"] == expected["pose_rate"]
        s.commit(0, Batch(fitness=[FitnessSample(1, 30.0, 2.0, 1.0, 0.2, 1.5)]),
                 _checkpoint(2, 30.0))
        assert s.fitness_samples(0, 1) == [FitnessSample(1, 30.0, 2.0, 1.0, 0.2, 1.5)]
    with Store.open(path) as s:  # opening again changes nothing more
        assert s.config["task"] == expected


@pytest.mark.parametrize(("world", "expected", "said"), [
    (None, {"engine": "pybullet"}, True),
    ({"terrain": "rugged"}, {"terrain": "rugged", "engine": "pybullet"}, True),
    # an engine already named is kept, whichever it is
    ({"engine": "mujoco"}, {"engine": "mujoco"}, False),
    ({"engine": "pybullet"}, {"engine": "pybullet"}, False),
])
def test_version_7_database_keeps_the_engine_it_ran_on(
        tmp_path: Path, caplog: pytest.LogCaptureFixture, world: dict[str, object] | None,
        expected: dict[str, object], said: bool) -> None:
    """Before schema 8 a config without ``world.engine`` ran on pybullet, the default then: it
    reads as pybullet after the upgrade (MuJoCo is the default now), with one line saying so,
    and a resumed run steps its remaining births on the engine of its first ones."""
    path = tmp_path / "results.sqlite"
    config: dict[str, object] = {"name": "old", "births": 15}
    if world is not None:
        config["world"] = world
    Store.create(path, config, 0).close()
    db = sqlite3.connect(path)
    db.execute("UPDATE meta SET value = '7' WHERE key = 'schema_version'")
    db.commit()
    db.close()
    with caplog.at_level("WARNING", logger="evolution.experiments.store"), Store.open(path) as s:
        assert s.meta()["schema_version"] == "8" and s.config["world"] == expected
        assert ExperimentConfig.from_dict(s.config).world.engine == expected["engine"]
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == int(said)
    if said:
        assert "names no physics engine" in lines[0] and "read as pybullet" in lines[0]
    caplog.clear()
    with Store.open(path) as s:  # opening again changes nothing more, and says nothing
        assert s.config["world"] == expected
    assert caplog.records == []


def test_new_config_without_an_engine_runs_on_mujoco() -> None:
    """A config written today without ``world.engine`` runs on the default engine, MuJoCo."""
    assert ExperimentConfig.from_dict({"name": "new"}).world.engine == "mujoco"
