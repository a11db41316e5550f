"""Damaged results databases: every command refuses them on one line and changes nothing.

One small interrupted offline experiment and one online experiment (fast physics stand-ins)
are made once; each case copies one,
damages one table (emptied, rows deleted, a wrong type, an inconsistent checkpoint, a duplicated
row, an extra column, a stored name that is a path, a policy reference leading out), and runs
``resume``, ``report`` and ``show --db`` through :func:`evolution.cli.main`: each must exit 2
with one line on stderr (no traceback), and the database's bytes must be unchanged.
A read-only database is refused by ``resume`` and still readable by ``report`` and ``show``.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib
import os
import shutil
import sqlite3
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from experiment_fakes import fake_evaluate, fake_world, small

from evolution import experiments
from evolution.cli import main
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ProgressEvent, preset
from evolution.experiments.app import api
from evolution.experiments.loop import evolve as loop
from evolution.experiments.store.database import DB_NAME, SCHEMA_VERSION, Store
from evolution.experiments.store.integrity import verify

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)
HALF = ("rowid IN (SELECT rowid FROM {t} ORDER BY rowid DESC "
        "LIMIT (SELECT COUNT(*) / 2 + 1 FROM {t}))")  # the latest half of a table

LEARNING_ROW = ("INSERT INTO learning (run_id, robot_id, time, inheritance, failures, policy) "
                "VALUES (0, 1, 0.0, 'darwinian', 0, '{policy}')")

# (case id, SQL that damages the database)
DAMAGES: list[tuple[str, str]] = [
    ("meta-empty", "DELETE FROM meta"),
    ("meta-config-not-an-object", "UPDATE meta SET value = '[1, 2]' WHERE key = 'config'"),
    ("meta-config-not-json", "UPDATE meta SET value = '{births: 3' WHERE key = 'config'"),
    ("meta-config-wrong-type", "UPDATE meta SET value = json_set(value, '$.births', 'many') "
                               "WHERE key = 'config'"),
    ("meta-config-fewer-births", "UPDATE meta SET value = json_set(value, '$.births', 20) "
                                 "WHERE key = 'config'"),
    ("runs-empty", "DELETE FROM runs"),
    ("runs-delete", "DELETE FROM runs WHERE run_id = 0"),
    ("runs-wrong-type", "UPDATE runs SET births = 'thirty' WHERE run_id = 0"),
    ("runs-births-beyond-config", "UPDATE runs SET births = 99 WHERE run_id = 0"),
    ("checkpoints-empty", "DELETE FROM checkpoints"),
    ("checkpoints-empty-state", "UPDATE checkpoints SET engine_state = '{}'"),
    ("checkpoints-state-not-object", "UPDATE checkpoints SET engine_state = '[1]'"),
    ("checkpoints-state-not-json", "UPDATE checkpoints SET engine_state = 'population'"),
    ("checkpoints-rng-empty", "UPDATE checkpoints SET rng_state = '{}'"),
    ("checkpoints-rng-wrong-type",
     "UPDATE checkpoints SET rng_state = json_set(rng_state, '$.state.state', 'x')"),
    ("checkpoints-wrong-type", "UPDATE checkpoints SET sim_time = 'late'"),
    ("checkpoints-births-beyond-config",
     "UPDATE checkpoints SET births = 99; UPDATE runs SET births = 99 WHERE run_id = 0"),
    ("robots-empty", "DELETE FROM robots"),
    ("robots-delete", "DELETE FROM robots WHERE " + HALF.format(t="robots")),
    ("robots-delete-one", "DELETE FROM robots WHERE robot_id = 3"),
    ("robots-fitness-text", "UPDATE robots SET fitness = 'fast' WHERE fitness IS NOT NULL"),
    ("robots-genome-not-json", "UPDATE robots SET genome = 'spider'"),
    ("robots-genome-not-a-robot", "UPDATE robots SET genome = '{\"core\": 1}'"),
    ("robots-id-text", "UPDATE robots SET robot_id = 'r' || robot_id WHERE robot_id = 0"),
    ("fitness-empty", "DELETE FROM fitness"),
    ("fitness-delete", "DELETE FROM fitness WHERE " + HALF.format(t="fitness")),
    ("fitness-wrong-type", "UPDATE fitness SET fitness = 'x'"),
    ("transitions-empty", "DELETE FROM transitions"),
    ("transitions-delete", "DELETE FROM transitions WHERE " + HALF.format(t="transitions")),
    ("transitions-unknown-stage", "UPDATE transitions SET target = 'limbo'"),
    ("transitions-wrong-type", "UPDATE transitions SET time = x'00'"),
    ("population-empty", "DELETE FROM population"),
    ("population-delete", "DELETE FROM population WHERE " + HALF.format(t="population")),
    ("population-wrong-type", "UPDATE population SET fitness = 'x'"),
    ("population-unborn", "UPDATE population SET robot_id = 999 WHERE rowid = 1"),
    ("diversity-empty", "DELETE FROM diversity"),
    ("diversity-wrong-type", "UPDATE diversity SET value = 'x'"),
    ("failures-wrong-type", "INSERT INTO failures (run_id, robot_id, time, kind) "
                            "VALUES (0, 1, 'noon', 'crossover')"),
    ("learning-wrong-type", "INSERT INTO learning (run_id, robot_id, time, inheritance) "
                            "VALUES (0, 1, 'x', 'darwinian')"),
    ("stray-run-robots", "INSERT INTO robots SELECT 7, robot_id, genome, parent_a, parent_b, "
                         "origin, generation, conceived_time, birth_time, death_time, "
                         "death_cause, fitness FROM robots WHERE run_id = 0"),
    # Issue 20: damages that `resume` used to continue (exit 0).
    ("population-duplicate-row", "INSERT INTO population SELECT * FROM population "
                                 "WHERE rowid = 1"),
    ("robots-extra-column", "ALTER TABLE robots ADD COLUMN extra TEXT; "
                            "UPDATE robots SET extra = 'x'"),
    ("meta-seed-not-an-integer", "UPDATE meta SET value = '1.5' WHERE key = 'seed'"),
    ("meta-config-name-a-path", "UPDATE meta SET value = json_set(value, '$.name', '../evil') "
                                "WHERE key = 'config'"),
    ("meta-config-name-control", "UPDATE meta SET value = json_set(value, '$.name', "
                                 "'a' || char(7)) WHERE key = 'config'"),
    ("learning-policy-absolute", LEARNING_ROW.format(policy='{"file": "/etc/passwd", '
                                                            '"digest": "x"}')),
    ("learning-policy-parent", LEARNING_ROW.format(policy='{"file": "../../x.safetensors", '
                                                          '"digest": "x"}')),
    ("learning-policy-malformed", LEARNING_ROW.format(policy="policies/x.pkl")),
]


OFFLINE_ONLY: list[tuple[str, str]] = [
    ("checkpoints-population-wrong-type",
     "UPDATE checkpoints SET engine_state = json_set(engine_state, '$.population[0][0]', 'x')"),
    ("checkpoints-population-unborn",
     "UPDATE checkpoints SET engine_state = json_set(engine_state, '$.population[0][0]', 999)"),
    ("checkpoints-learned-outside-population",
     "UPDATE checkpoints SET engine_state = json_set(engine_state, '$.learned', json('[999]'))"),
]
ONLINE_ONLY: list[tuple[str, str]] = [
    ("checkpoints-alive-missing",
     "UPDATE checkpoints SET engine_state = json_remove(engine_state, '$.alive')"),
    ("checkpoints-alive-wrong-type",
     "UPDATE checkpoints SET engine_state = json_set(engine_state, '$.alive[0]', 1.5)"),
    ("checkpoints-alive-unborn",
     "UPDATE checkpoints SET engine_state = json_set(engine_state, '$.alive[0]', 999)"),
]
CASES = ([pytest.param("offline", c, q, id=f"offline-{c}") for c, q in DAMAGES + OFFLINE_ONLY]
         + [pytest.param("online", c, q, id=f"online-{c}") for c, q in DAMAGES + ONLINE_ONLY])


def _kill_after(births: int) -> experiments.ProgressCallback:
    def progress(event: ProgressEvent) -> None:
        if event.births >= births:
            raise KeyboardInterrupt
    return progress


@pytest.fixture(scope="module")
def interrupted(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An offline experiment of 2 runs: run 0 interrupted at 30 births of 45, run 1 pending."""
    out = tmp_path_factory.mktemp("damaged") / "exp"
    config = small(preset("scenario1", births=45, runs=2, diversity_interval=5))
    with pytest.raises(KeyboardInterrupt):
        experiments.run(config, out, _kill_after(30), evaluator=SERIAL)
    return out


@pytest.fixture(scope="module")
def online(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An online experiment of 2 runs: run 0 interrupted at 22 births of 30, run 1 pending."""
    out = tmp_path_factory.mktemp("damaged") / "exp"
    config = small(preset("scenario3", births=30, runs=2, diversity_interval=5))
    with pytest.raises(KeyboardInterrupt):
        experiments.run(config, out, _kill_after(22), evaluator=SERIAL, world_factory=fake_world)
    return out


@pytest.fixture
def fake_physics(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(api, "make_evaluator", lambda *a, **k: SERIAL)
    monkeypatch.setattr(loop, "default_world", fake_world)


def _digest(folder: Path) -> str:
    return hashlib.sha256((folder / DB_NAME).read_bytes()).hexdigest()


def _damaged(source: Path, target: Path, sql: str) -> Path:
    shutil.copytree(source, target)
    con = sqlite3.connect(target / DB_NAME)
    try:
        before = con.total_changes
        con.executescript(sql)
        con.commit()
        assert con.total_changes > before, f"the damage {sql!r} changed nothing"
    finally:
        con.close()
    return target


def _commands(folder: Path, scratch: Path) -> dict[str, list[str]]:
    return {
        "resume": ["resume", str(folder)],
        "report": ["report", str(folder), "--out", str(scratch / "report")],
        "show": ["show", "--db", str(folder), "--best", "--out", str(scratch / "best.gif"),
                 "--seconds", "0.2", "--insertion", "0", "--fps", "2"],
    }


def _one_line_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    status = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    assert status == 2, f"{argv[0]} exited {status}: {err}"
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_the_undamaged_databases_are_usable(interrupted: Path, online: Path) -> None:
    with Store.open(interrupted / DB_NAME) as store:
        assert verify(store, resumable=True).births == 45
        assert [(r.status, r.births) for r in store.runs()] == [("interrupted", 30),
                                                                 ("pending", 0)]
    with Store.open(online / DB_NAME) as store:
        assert verify(store, resumable=True).mode == "online"
        assert [r.status for r in store.runs()] == ["interrupted", "pending"]


@pytest.mark.parametrize("engine_name, case, sql", CASES)
def test_a_damaged_database_is_refused_on_one_line_and_left_unchanged(
        request: pytest.FixtureRequest, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        fake_physics: None, engine_name: str, case: str, sql: str) -> None:
    source = request.getfixturevalue("interrupted" if engine_name == "offline" else "online")
    folder = _damaged(source, tmp_path / "exp", sql)
    digest = _digest(folder)
    for command, argv in _commands(folder, tmp_path).items():
        line = _one_line_error(capsys, argv)
        assert line.startswith(f"revolve {command}: error: "), line
        assert _digest(folder) == digest, f"{command} changed the database"
    assert not (tmp_path / "best.gif").exists()


def test_resume_refuses_a_checkpoint_beyond_the_config_before_printing_progress(
        interrupted: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        fake_physics: None) -> None:
    folder = _damaged(interrupted, tmp_path / "exp",
                      "UPDATE checkpoints SET births = 99; UPDATE runs SET births = 99")
    line = _one_line_error(capsys, ["resume", str(folder)])
    assert "99 births" in line and "45" in line
    assert "99/" not in capsys.readouterr().out


@contextlib.contextmanager
def _read_only(folder: Path) -> Iterator[None]:
    """``folder``'s database read-only (mode 0444) meanwhile."""
    db = folder / DB_NAME
    db.chmod(stat.S_IRUSR | stat.S_IRGRP | stat.S_IROTH)
    try:
        yield
    finally:
        db.chmod(stat.S_IRUSR | stat.S_IWUSR)


@contextlib.contextmanager
def _without_root() -> Iterator[None]:
    """Root writes read-only files: take an ordinary user's rights meanwhile (when root).

    Only around code that imports nothing new: the user cannot read root's site-packages.
    """
    as_root = hasattr(os, "geteuid") and os.geteuid() == 0
    if as_root:
        os.seteuid(65534)
    try:
        yield
    finally:
        if as_root:
            os.seteuid(0)


@pytest.mark.parametrize("version", [SCHEMA_VERSION, SCHEMA_VERSION - 1])
def test_a_read_only_database_is_refused_by_resume_and_read_by_the_others(
        interrupted: Path, capsys: pytest.CaptureFixture[str], fake_physics: None,
        version: int) -> None:
    """Also one of the previous schema: it cannot be upgraded in place, so it is upgraded in
    memory for the readers, and still refused by resume."""
    # Outside pytest's private temporary folder, so that another user can reach it.
    base = Path(tempfile.mkdtemp(prefix="revolve-readonly-"))
    try:
        folder = base / "exp"
        shutil.copytree(interrupted, folder)
        con = sqlite3.connect(folder / DB_NAME)
        if version < 7:
            con.execute("ALTER TABLE fitness DROP COLUMN shaking")  # added by schema 7
        con.execute("UPDATE meta SET value = ? WHERE key = 'schema_version'", (str(version),))
        con.commit()
        con.close()
        for path in (base, folder):
            path.chmod(0o777)
        digest = _digest(folder)
        commands = _commands(folder, base)
        # Once as root on a copy, so that the commands import all they need (the other user
        # cannot read root's site-packages).
        warm = _commands(shutil.copytree(folder, base / "warm"), base / "warm")
        assert main(warm["report"]) == 0 and main(warm["show"]) == 0
        # The command line imports each command's modules when the command runs: resume's too.
        for module in ("evolution.cli.progress", "evolution.experiments.app.api",
                       "evolution.experiments.app.callbacks"):
            importlib.import_module(module)
        with _read_only(folder), _without_root():
            line = _one_line_error(capsys, commands["resume"])
            assert "cannot be written" in line
            assert main(commands["report"]) == 0
            assert main(commands["show"]) == 0
        assert _digest(folder) == digest
        assert (base / "best.gif").stat().st_size > 0
    finally:
        shutil.rmtree(base, ignore_errors=True)


def test_verify_accepts_a_healthy_online_run(tmp_path: Path) -> None:
    config = small(preset("scenario3", births=30, runs=1, diversity_interval=5))
    with pytest.raises(KeyboardInterrupt):
        experiments.run(config, tmp_path / "online", _kill_after(22), evaluator=SERIAL,
                        world_factory=fake_world)
    with Store.open(tmp_path / "online" / DB_NAME) as store:
        verify(store, resumable=True)
    experiments.resume(tmp_path / "online", evaluator=SERIAL, world_factory=fake_world)
    with Store.open(tmp_path / "online" / DB_NAME) as store:
        assert verify(store).births == 30
        assert [r.status for r in store.runs()] == ["finished"]


def test_a_damaged_genome_outside_the_population_is_refused_when_asked_for(
        interrupted: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with Store.open(interrupted / DB_NAME) as store:
        members = {rid for rid, _ in store.final_population(0)}
    dead = min(set(range(30)) - members)
    folder = _damaged(interrupted, tmp_path / "exp",
                      f"UPDATE robots SET genome = '[' WHERE run_id = 0 AND robot_id = {dead}")
    digest = _digest(folder)
    for argv in (["show", "--db", str(folder), "--robot", str(dead)],
                 ["export", "--db", str(folder), "--robot", str(dead), "--format", "urdf"]):
        line = _one_line_error(capsys, argv)
        assert f"robot {dead} of run 0 does not decode" in line
    assert _digest(folder) == digest


def test_resume_of_a_folder_changes_nothing_when_one_experiment_is_damaged(
        interrupted: Path, online: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        fake_physics: None) -> None:
    shutil.copytree(interrupted, tmp_path / "a")  # healthy, would be continued
    _damaged(online, tmp_path / "b", "DELETE FROM checkpoints")
    digests = {name: _digest(tmp_path / name) for name in ("a", "b")}
    line = _one_line_error(capsys, ["resume", str(tmp_path)])
    assert "no checkpoint" in line
    assert {name: _digest(tmp_path / name) for name in ("a", "b")} == digests


@pytest.mark.parametrize("name", ["checkpoints", "policies"])
def test_a_folder_of_the_results_that_leads_outside_is_refused(
        online: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], fake_physics: None,
        name: str) -> None:
    """Resume would write snapshots or policies through it: refused before anything runs."""
    folder = tmp_path / "exp"
    shutil.copytree(online, folder)
    (tmp_path / "elsewhere").mkdir()
    (folder / name).symlink_to(tmp_path / "elsewhere")
    digest = _digest(folder)
    for command, argv in _commands(folder, tmp_path).items():
        line = _one_line_error(capsys, argv)
        assert line.startswith(f"revolve {command}: error: ") and "outside" in line, line
    assert _digest(folder) == digest and list((tmp_path / "elsewhere").iterdir()) == []
