"""Checks that a results database is whole before anything reads or continues it.

A damaged database (a table emptied or edited by hand, rows deleted, text where numbers belong,
a checkpoint that does not match its run) used to surface deep inside ``resume`` or ``report``
as a KeyError, TypeError or IntegrityError, sometimes after ``resume`` had already written to
it. :func:`verify` runs a fixed set of cheap read-only checks (SQL aggregates, and for the runs
that ``resume`` would continue, the checkpoint's state and the genomes it restores) and raises
one :class:`~evolution.experiments.loop.errors.StoreError` naming the first problem, so the
commands refuse a damaged database on one line and change nothing. :func:`check_writable` tells
``resume`` before its first write whether it could write at all.

What is checked (``runs`` as the config's ``runs``, ``births`` a run's births):

* meta: the stored config is an object and a valid :class:`ExperimentConfig` (its name
  printable and path-free), the seed a whole number;
* every table has exactly this package's columns; every column holds its type (``typeof``),
  lifecycle stages are known ones;
* no population snapshot lists a robot twice;
* files: the ``checkpoints`` and ``policies`` folders and every policy file the learning table
  refers to lie inside the results folder
  (:func:`~evolution.experiments.store.results_folder.inside`: no absolute path, no ``..``, no
  symbolic link leading out), each reference well formed;
* runs: ids within the config's runs, ``0 <= births <=`` the config's births;
* checkpoints: one per run that has births, matching its run row; the generator state is one a
  ``PCG64`` accepts; the engine state is an object with the engine's keys, naming robots born;
* robots: a run's robot ids are exactly ``0 .. births - 1``; no robots of unknown runs; every
  robot has its lifecycle transitions; every robot with a fitness that did not blow up has a
  fitness sample;
* population: the snapshot at each checkpoint exists (offline: it lists the checkpoint's
  population) and names stored robots;
* diversity: present once a run has committed, when the config computes it;
* the genomes of each checkpoint's population (and learned genomes it names) decode; fully
  validated (:func:`~revolve_env.body.serialize.from_json` with its checks) for the runs that
  ``resume`` would continue.
"""

from __future__ import annotations

import functools
import json
import math
import re
import sqlite3
from collections.abc import Mapping
from typing import Any

import numpy as np

from evolution.experiments.loop.config import ExperimentConfig
from evolution.experiments.loop.errors import ConfigError
from evolution.experiments.store.database import Store, StoreError
from evolution.experiments.store.results_folder import PolicyReference, inside
from evolution.experiments.store.schema import SCHEMA, TABLES
from evolution.lifecycle import Stage

__all__ = ["check_writable", "verify"]

_NUM = ("integer", "real")
_INT = ("integer",)
_TEXT = ("text",)
_NULL = ("null",)

_COLUMN_TYPES: dict[str, dict[str, tuple[str, ...]]] = {
    "runs": {"run_id": _INT, "seed": _INT, "status": _TEXT, "births": _INT, "sim_time": _NUM,
             "generation": _INT},
    "checkpoints": {"run_id": _INT, "births": _INT, "sim_time": _NUM, "generation": _INT,
                    "rng_state": _TEXT, "engine_state": _TEXT},
    "robots": {"run_id": _INT, "robot_id": _INT, "genome": _TEXT, "parent_a": _INT + _NULL,
               "parent_b": _INT + _NULL, "origin": _TEXT, "generation": _INT,
               "conceived_time": _NUM, "birth_time": _NUM + _NULL, "death_time": _NUM + _NULL,
               "death_cause": _TEXT + _NULL, "fitness": _NUM + _NULL},
    "fitness": {"run_id": _INT, "robot_id": _INT, "time": _NUM, "fitness": _NUM,
                "v": _NUM + _NULL, "s": _NUM + _NULL},
    "transitions": {"run_id": _INT, "robot_id": _INT, "source": _TEXT + _NULL,
                    "target": _TEXT, "time": _NUM, "note": _TEXT},
    "population": {"run_id": _INT, "births": _INT, "sim_time": _NUM, "robot_id": _INT,
                   "fitness": _NUM + _NULL},
    "diversity": {"run_id": _INT, "births": _INT, "sim_time": _NUM, "value": _NUM},
    "failures": {"run_id": _INT, "robot_id": _INT + _NULL, "time": _NUM, "kind": _TEXT,
                 "detail": _TEXT},
    "learning": {"run_id": _INT, "robot_id": _INT, "time": _NUM, "inheritance": _TEXT,
                 "learned_genome": _TEXT + _NULL, "inborn_fitness": _NUM + _NULL,
                 "learned_fitness": _NUM + _NULL, "evaluations": _INT + _NULL,
                 "sim_seconds": _NUM + _NULL, "failures": _INT, "policy": _TEXT + _NULL},
}
"""The ``typeof`` each column may hold (SQLite keeps whatever it is given)."""


def verify(store: Store, resumable: bool = False) -> ExperimentConfig:
    """Check a results database; return its configuration.

    Args:
        store: The open database.
        resumable: Validate the genomes that continuing the unfinished runs restores fully
            (slower: the part-overlap check), not only that they decode.

    Returns:
        The stored experiment configuration.

    Raises:
        StoreError: the database is damaged (the message names the table, run or robot).
    """
    config = stored_config(store)
    try:
        _check_meta(store)
        _check_columns(store)
        _check_types(store)
        _check_duplicates(store)
        _check_files(store)
        for run_id, status, births in store.query("SELECT run_id, status, births FROM runs"):
            _check_run(store, config, run_id, births, resumable and status != "finished")
        stray = store.query(
            "SELECT 'robots', run_id FROM robots WHERE run_id NOT IN (SELECT run_id FROM runs) "
            "UNION SELECT 'checkpoints', run_id FROM checkpoints "
            "WHERE run_id NOT IN (SELECT run_id FROM runs) LIMIT 1")
        if stray:
            raise StoreError(f"the {stray[0][0]} table has rows of run {stray[0][1]}, which the "
                             "runs table does not list")
    except StoreError as error:
        raise StoreError(f"{store.path} is damaged: {error}") from None
    return config


def stored_config(store: Store) -> ExperimentConfig:
    """The stored experiment configuration, validated.

    Raises:
        StoreError: it is not an object, or not a valid configuration for this package.
    """
    data = store.config
    try:
        return ExperimentConfig.from_dict(data)
    except ConfigError as error:
        raise StoreError(f"{store.path}: the stored configuration is not valid: {error}") from None


def check_writable(store: Store) -> None:
    """Raise unless ``store`` can be written (it is opened read-write and not locked for good).

    Raises:
        StoreError: the file (or its folder, which SQLite's journal needs) is read-only.
    """
    try:
        store.query("BEGIN IMMEDIATE")
        try:
            # A write that changes nothing, rolled back: a read-only connection refuses it
            # (BEGIN alone does not tell).
            store.query("UPDATE meta SET value = value WHERE key = 'schema_version'")
        finally:
            store.query("ROLLBACK")
    except sqlite3.OperationalError as error:
        raise StoreError(f"{store.path} cannot be written ({error}); resume needs write access "
                         "to the database and its folder") from None


def _check_meta(store: Store) -> None:
    text = store.meta().get("seed")
    if not isinstance(text, str) or not re.fullmatch(r"[0-9]{1,19}", text):
        raise StoreError(f"table meta: the seed {text!r} is not a whole number")


@functools.cache
def _schema_columns() -> dict[str, frozenset[str]]:
    """The columns of each table of a database this package creates."""
    db = sqlite3.connect(":memory:")
    try:
        db.executescript(SCHEMA)
        return {table: frozenset(row[1] for row in db.execute(f"PRAGMA table_info({table})"))
                for table in TABLES}
    finally:
        db.close()


def _check_columns(store: Store) -> None:
    for table, expected in sorted(_schema_columns().items()):
        found = {row[1] for row in store.query(f"PRAGMA table_info({table})")}
        if found != expected:
            extra, missing = sorted(found - expected), sorted(expected - found)
            what = (f"column(s) {', '.join(extra)} it should not have" if extra
                    else f"no column(s) {', '.join(missing)}")
            raise StoreError(f"table {table} has {what}")


def _check_duplicates(store: Store) -> None:
    rows = store.query("SELECT run_id, births, robot_id FROM population GROUP BY run_id, births, "
                       "robot_id HAVING COUNT(*) > 1 LIMIT 1")
    if rows:
        run_id, births, robot_id = rows[0]
        raise StoreError(f"run {run_id}: the population snapshot at births {births} lists "
                         f"robot {robot_id} more than once")


def _check_files(store: Store) -> None:
    """The folders and policy files the database refers to lie inside the results folder."""
    folder = store.path.parent
    for name in ("checkpoints", "policies"):
        if (folder / name).exists() or (folder / name).is_symlink():
            inside(folder, name, "folder")
    for run_id, robot_id, text in store.query(
            "SELECT run_id, robot_id, policy FROM learning WHERE policy IS NOT NULL"):
        try:
            PolicyReference.parse(text).check(folder)
        except StoreError as error:
            raise StoreError(f"run {run_id}: robot {robot_id}'s policy: {error}") from None


def _check_types(store: Store) -> None:
    for table, columns in _COLUMN_TYPES.items():
        wrong = " OR ".join(
            f"typeof({column}) NOT IN ({', '.join(repr(t) for t in kinds)})"
            for column, kinds in columns.items())
        rows = store.query(f"SELECT {', '.join(columns)} FROM {table} WHERE {wrong} LIMIT 1")
        if rows:
            column, value = next((c, v) for c, v in zip(columns, rows[0], strict=True)
                                 if _sql_type(v) not in columns[c])
            raise StoreError(f"table {table}: column {column} holds {value!r}, not "
                             f"{' or '.join(columns[column])}")
    stages = tuple(s.value for s in Stage)
    marks = ", ".join("?" * len(stages))
    rows = store.query(
        f"SELECT source, target FROM transitions WHERE target NOT IN ({marks}) "
        f"OR (source IS NOT NULL AND source NOT IN ({marks})) LIMIT 1", stages + stages)
    if rows:
        raise StoreError(f"table transitions: unknown lifecycle stage in {rows[0]!r}")


def _sql_type(value: object) -> str:
    if value is None:
        return "null"
    if isinstance(value, int):
        return "integer"
    if isinstance(value, float):
        return "real"
    if isinstance(value, str):
        return "text"
    return "blob"


def _check_run(store: Store, config: ExperimentConfig, run_id: int, births: int,
               resumable: bool) -> None:
    """The checks of one run (see the module docstring)."""
    where = f"run {run_id}"
    if not 0 <= run_id < config.runs:
        raise StoreError(f"{where} is not one of the experiment's {config.runs} run(s)")
    if not 0 <= births <= config.births:
        raise StoreError(f"{where} has {births} births, outside 0..{config.births} (the "
                         "config's births)")
    rows = store.query("SELECT births, sim_time, generation, rng_state, engine_state FROM "
                       "checkpoints WHERE run_id = ?", (run_id,))
    count, low, high = store.query(
        "SELECT COUNT(*), MIN(robot_id), MAX(robot_id) FROM robots WHERE run_id = ?",
        (run_id,))[0]
    if (count, low, high) != ((births, 0, births - 1) if births else (0, None, None)):
        raise StoreError(f"{where} has {births} births but {count} robot rows "
                         f"(ids {low}..{high})")
    if not rows:
        if births:
            raise StoreError(f"{where} has {births} births but no checkpoint")
        return
    c_births, c_time, c_generation, rng_text, engine_text = rows[0]
    run_row = store.query("SELECT births, sim_time, generation FROM runs WHERE run_id = ?",
                          (run_id,))[0]
    if (c_births, c_time, c_generation) != tuple(run_row):
        raise StoreError(f"{where}: its checkpoint (births {c_births}) does not match its runs "
                         f"row (births {run_row[0]})")
    _check_rng(where, rng_text)
    state = _json_object(f"{where}: checkpoint engine_state", engine_text)
    members = _check_engine_state(where, config, state, births)
    missing = store.query(
        "SELECT robot_id FROM robots r WHERE run_id = ? AND NOT EXISTS (SELECT 1 FROM "
        "transitions t WHERE t.run_id = r.run_id AND t.robot_id = r.robot_id) LIMIT 1",
        (run_id,))
    if missing:
        raise StoreError(f"{where}: robot {missing[0][0]} has no lifecycle transitions")
    missing = store.query(
        "SELECT robot_id FROM robots r WHERE run_id = ? AND fitness IS NOT NULL AND "
        "(death_cause IS NULL OR death_cause NOT LIKE 'blow-up%') AND NOT EXISTS (SELECT 1 "
        "FROM fitness f WHERE f.run_id = r.run_id AND f.robot_id = r.robot_id) LIMIT 1",
        (run_id,))
    if missing:
        raise StoreError(f"{where}: robot {missing[0][0]} has a fitness but no fitness sample")
    snapshot = [rid for (rid,) in store.query(
        "SELECT robot_id FROM population WHERE run_id = ? AND births = ? ORDER BY rowid",
        (run_id, c_births))]
    if snapshot != members:
        raise StoreError(f"{where}: the population snapshot at births {c_births} is missing "
                         "or differs from its checkpoint's population")
    unknown = store.query(
        "SELECT births, robot_id FROM population WHERE run_id = ? AND (births > ? OR "
        "robot_id < 0 OR robot_id >= ?) LIMIT 1", (run_id, c_births, births))
    if unknown:
        raise StoreError(f"{where}: the population snapshot at births {unknown[0][0]} names "
                         f"robot {unknown[0][1]}, which was not born before the checkpoint")
    if config.diversity_interval and not store.query(
            "SELECT 1 FROM diversity WHERE run_id = ? LIMIT 1", (run_id,)):
        raise StoreError(f"{where}: the diversity table has no value although the config "
                         f"computes it every {config.diversity_interval} births")
    _check_restorable(store, run_id, members, state, resumable)


def _check_rng(where: str, text: str) -> None:
    state = _json_object(f"{where}: checkpoint rng_state", text)
    try:
        np.random.default_rng(0).bit_generator.state = state
    except (TypeError, ValueError, KeyError, OverflowError) as error:
        raise StoreError(f"{where}: checkpoint rng_state is not a generator state "
                         f"({type(error).__name__}: {error})") from None


def _json_object(what: str, text: str) -> dict[str, Any]:
    try:
        value = json.loads(text)
    except (ValueError, RecursionError):
        raise StoreError(f"{what} is not JSON") from None
    if not isinstance(value, dict):
        raise StoreError(f"{what} is not a JSON object")
    return value


def _is_id(value: object, births: int) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < births


def _check_engine_state(where: str, config: ExperimentConfig, state: Mapping[str, Any],
                        births: int) -> list[int]:
    """Check a checkpoint's engine state; the ids of the population it holds."""
    what = f"{where}: checkpoint engine_state"
    last = state.get("last_diversity_births")
    if last is not None and not _is_id(last, births + 1):
        raise StoreError(f"{what} has last_diversity_births {last!r}")
    if config.mode == "online":
        alive = state.get("alive")
        if not isinstance(alive, list) or not all(_is_id(a, births) for a in alive):
            raise StoreError(f"{what} has no list of living robot ids ('alive')")
        return list(alive)
    population = state.get("population")
    if not isinstance(population, list) or not all(
            isinstance(m, list) and len(m) == 2 and _is_id(m[0], births)
            and (m[1] is None or (isinstance(m[1], (int, float)) and not isinstance(m[1], bool)
                                  and not math.isnan(m[1])))
            for m in population):
        raise StoreError(f"{what} has no population of [robot id, fitness] pairs")
    ids = [m[0] for m in population]
    learned = state.get("learned", [])
    if not isinstance(learned, list) or not set(learned) <= set(ids):
        raise StoreError(f"{what} lists learned robots outside its population")
    return ids


def _check_restorable(store: Store, run_id: int, members: list[int],
                      state: Mapping[str, Any], validate: bool) -> None:
    """The genomes of a checkpoint's population decode (and pass validation if ``validate``)."""
    from revolve_env.body.serialize import from_json

    learned = set(state.get("learned", []))
    genomes = dict(store.query(
        f"SELECT robot_id, genome FROM robots WHERE run_id = ? AND robot_id IN "
        f"({', '.join('?' * len(members))})", (run_id, *members)))
    if learned:
        rows = dict(store.query(
            f"SELECT robot_id, learned_genome FROM learning WHERE run_id = ? AND robot_id IN "
            f"({', '.join('?' * len(learned))})", (run_id, *sorted(learned))))
        for robot_id in learned:
            if rows.get(robot_id) is None:
                raise StoreError(f"run {run_id}: robot {robot_id} reproduces with its learned "
                                 "genome but the learning table has none")
            genomes[robot_id] = rows[robot_id]
    for robot_id in members:
        try:
            from_json(genomes[robot_id], check=validate)
        except ValueError as error:  # RobotError and malformed JSON are ValueErrors
            raise StoreError(f"run {run_id}: the genome of robot {robot_id} does not decode "
                             f"({error})") from None
