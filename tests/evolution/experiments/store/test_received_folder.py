"""A received results folder stays inert and bounded, for every command that opens one (issue 31).

Small experiments (fast physics stand-ins: an interrupted offline one, an interrupted online one,
and a study prepared but not run) are made once. Then, as someone who sends a results folder
could:

* the stored ``[task]`` names a *canary* module (on the Python path; importing it writes a
  marker file), and a pickled policy whose unpickling writes a marker is referenced by a learning
  record: ``report``, ``show --db``, ``export --db``, ``watch``, ``resume``, ``reevaluate`` and
  ``study --out`` (and the Python functions behind them) never fire a canary unless the trust
  flag is given, and the ones that would import say so in one line (with the flag, the module is
  imported: the test can fail);
* a FIFO, a symbolic link or a 20 GB sparse file takes the place of the database, of each file
  SQLite keeps beside it, of a study's ``study.json``: every command refuses in one line naming
  the file, and none hangs (they run in a subprocess with a timeout that holds on a loaded
  machine); the same in place of a snapshot and of a policy file, read by the store's functions.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import pickle
import shutil
import sqlite3
import stat
import subprocess
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import fake_evaluate, fake_world, small

from evolution import experiments
from evolution.cli import main
from evolution.evaluation import LocalEvaluator
from evolution.experiments import preset
from evolution.experiments.app import api
from evolution.experiments.app.reevaluate import reevaluate
from evolution.experiments.app.study import prepare_study, study
from evolution.experiments.loop import evolve as loop
from evolution.experiments.store import snapshot
from evolution.experiments.store.database import DB_NAME, Store, StoreError
from evolution.experiments.store.results_folder import (
    MAX_SNAPSHOT_BYTES,
    load_policy,
    read_file,
    read_settings,
)
from revolve_env.body.examples import EXAMPLES

ROOT = Path(__file__).resolve().parents[4]
SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)
CANARY = "revolve_received_canary"
"""The canary module's name: importing it appends a line to its marker file."""
SPARSE = 20 * 2**30
"""Size of the sparse file planted in place of a file of the folder (none of it is written)."""
TIMEOUT = 300.0
"""Seconds a subprocess of refusals may take on a loaded machine (each takes well under one)."""
STUDY = ["--runs", "1", "--births", "15", "--seed", "0", "--only", "scenario1", "--no-estimate"]


def _kill_after(births: int) -> experiments.ProgressCallback:
    def progress(event: experiments.ProgressEvent) -> None:
        if event.births >= births:
            raise KeyboardInterrupt
    return progress


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``offline/``, ``online/`` (interrupted) and ``study/`` (prepared) below one folder."""
    base = tmp_path_factory.mktemp("received")
    with pytest.raises(KeyboardInterrupt):
        experiments.run(small(preset("scenario1", births=30, runs=1, diversity_interval=5)),
                        base / "offline", _kill_after(20), evaluator=SERIAL)
    with pytest.raises(KeyboardInterrupt):
        experiments.run(small(preset("scenario3", births=30, runs=1, diversity_interval=5)),
                        base / "online", _kill_after(22), evaluator=SERIAL,
                        world_factory=fake_world)
    # Its settings (study.json and the database) name the canary's class, as a sender's could.
    prepare_study(base / "study", runs=1, births=15, experiments=["scenario1"])
    _with_canary_task(base / "study" / "scenario1" / DB_NAME)
    settings = json.loads((base / "study" / "study.json").read_text())
    settings["overrides"] = {"task": {"name": f"{CANARY}:Task"}}
    (base / "study" / "study.json").write_text(json.dumps(settings))
    return base


@pytest.fixture
def canary(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """The canary module on ``sys.path``; its marker file (absent until it fires)."""
    marker = tmp_path / "canary-fired"
    code = tmp_path / "canary-code"
    code.mkdir()
    (code / f"{CANARY}.py").write_text(
        f"with open({str(marker)!r}, 'a') as f:\n    f.write('imported\\n')\n")
    monkeypatch.syspath_prepend(str(code))
    sys.modules.pop(CANARY, None)
    yield marker
    sys.modules.pop(CANARY, None)


@pytest.fixture
def fake_physics(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(api, "make_evaluator", lambda *a, **k: SERIAL)
    monkeypatch.setattr(loop, "default_world", fake_world)


def _stored_config(db: Path, change: Callable[[dict[str, Any]], None]) -> None:
    """Edit the configuration stored in ``db`` as a sender could."""
    with contextlib.closing(sqlite3.connect(db)) as con:
        text = con.execute("SELECT value FROM meta WHERE key = 'config'").fetchone()[0]
        config = json.loads(text)
        change(config)
        con.execute("UPDATE meta SET value = ? WHERE key = 'config'",
                    (json.dumps(config, sort_keys=True),))
        con.commit()


def _with_canary_task(db: Path) -> None:
    _stored_config(db, lambda c: c.update(task={"name": f"{CANARY}:Task"}))


def _received(made: Path, tmp_path: Path) -> Path:
    """A copy of the made folders whose stored tasks name the canary module."""
    folder = tmp_path / "received"
    shutil.copytree(made, folder)
    for db in ("offline", "online"):
        _with_canary_task(folder / db / DB_NAME)
    return folder


def _digests(folder: Path) -> dict[str, str]:
    """SHA-256 of every database and SQLite file in ``folder`` (a planted one: its kind)."""
    digests = {}
    for path in sorted(folder.rglob(f"{DB_NAME}*")):
        st = path.lstat()
        digests[str(path.relative_to(folder))] = (
            hashlib.sha256(path.read_bytes()).hexdigest() if stat.S_ISREG(st.st_mode)
            and st.st_size < 2**30 else f"{stat.S_IFMT(st.st_mode)}:{st.st_size}")
    return digests


def _commands(folder: Path, scratch: Path, trust: bool = False) -> dict[str, list[str]]:
    """Every command that opens a results folder, on the folder it takes."""
    flag = ["--trust-task-code"] if trust else []
    return {
        "report": ["report", str(folder / "offline"), "--out", str(scratch / "report")],
        "show": ["show", "--db", str(folder / "offline"), "--best", "--out",
                 str(scratch / "best.gif"), "--seconds", "0.2", "--insertion", "0", "--fps", "2"],
        "export": ["export", "--db", str(folder / "offline"), "--best", "--format", "urdf",
                   "--out", str(scratch / "best.urdf")],
        "watch": ["watch", str(folder / "online"), "--record", str(scratch / "world.gif"),
                  "--seconds", "0.5", "--fps", "2", *flag],
        "resume": ["resume", str(folder / "offline"), *flag],
        "reevaluate": ["reevaluate", str(folder / "offline"), "--k", "1", *flag],
        "study": ["study", "--out", str(folder / "study"), *STUDY, "--set",
                  f"task.name={CANARY}:Task", *flag],
    }


IMPORTING = ("watch", "resume", "reevaluate", "study")
"""The commands that build the stored task (and so would import a class it names)."""


def _one_line(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str]:
    status = main(argv)
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    return status, err.strip()


# -- a stored name is never imported without the flag ---------------------------------------------

def test_no_command_imports_a_stored_task_module_without_the_flag(
        made: Path, tmp_path: Path, canary: Path, capsys: pytest.CaptureFixture[str],
        fake_physics: None) -> None:
    folder = _received(made, tmp_path)
    before = _digests(folder)
    for command, argv in _commands(folder, tmp_path).items():
        status, err = _one_line(capsys, argv)
        assert not canary.exists(), f"{command} imported the stored task's module"
        if command in IMPORTING:
            assert status == 2 and len(err.splitlines()) == 1, (command, err)
            assert "--trust-task-code" in err and CANARY in err, err
        else:  # reading or showing a folder needs no task
            assert status == 0, (command, err)
    assert _digests(folder) == before  # the refusals wrote nothing


@pytest.mark.parametrize("command", IMPORTING)
def test_the_flag_imports_it(made: Path, tmp_path: Path, canary: Path,
                             capsys: pytest.CaptureFixture[str], fake_physics: None,
                             command: str) -> None:
    """The user's word imports the module (the canary above could fire): here it holds no
    ``Task``, which is then said in one line."""
    folder = _received(made, tmp_path)
    status, err = _one_line(capsys, _commands(folder, tmp_path, trust=True)[command])
    assert canary.read_text() == "imported\n"
    assert status == 2 and f"module '{CANARY}' has no 'Task'" in err, err


def test_the_python_functions_import_nothing_without_trust(
        made: Path, tmp_path: Path, canary: Path, fake_physics: None) -> None:
    folder = _received(made, tmp_path)
    with pytest.raises(StoreError, match="trust_task_code=True"):
        experiments.resume(folder / "offline", evaluator=SERIAL)
    with pytest.raises(StoreError, match="trust_task_code=True"):
        experiments.resume(folder / "online", evaluator=SERIAL, world_factory=fake_world)
    with pytest.raises(StoreError, match="trust_task_code=True"):
        reevaluate(folder / "offline", k=1, workers=1)
    with pytest.raises(StoreError, match="trust_task_code=True"):
        study(folder / "study", runs=1, births=15, experiments=["scenario1"],
              overrides={"task": {"name": f"{CANARY}:Task"}}, evaluator=SERIAL)
    assert not canary.exists()
    with pytest.raises(experiments.ConfigError, match="has no 'Task'"):
        experiments.resume(folder / "offline", evaluator=SERIAL, trust_task_code=True)
    assert canary.exists()


def test_a_study_compares_the_stored_settings_before_importing_anything(
        made: Path, tmp_path: Path, canary: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A study whose ``study.json`` matches the command but whose database names another task
    class: other settings, refused, even with the flag (nothing is imported, neither the class
    the user named nor the stored one)."""
    folder = tmp_path / "study"
    shutil.copytree(made / "study", folder)
    _stored_config(folder / "scenario1" / DB_NAME,
                   lambda c: c.update(task={"name": f"{CANARY}:Other"}))
    status, err = _one_line(capsys, ["study", "--out", str(folder), *STUDY, "--set",
                                     f"task.name={CANARY}:Task", "--trust-task-code"])
    assert status == 2 and "other settings" in err and f"{CANARY}:Other" in err, err
    assert not canary.exists()


def test_a_pickled_policy_never_runs_without_the_flag(
        made: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A learning record references a pickle whose unpickling writes a marker (online: resume
    would reload it): resume refuses it in one line before reading it, as the store's loader
    does (reevaluate loads policies through the same loader)."""
    marker = tmp_path / "pickle-fired"
    folder = tmp_path / "online"
    shutil.copytree(made / "online", folder)
    (folder / "policies").mkdir()
    (folder / "policies" / "run0_robot1.pkl").write_bytes(pickle.dumps(_Evil(marker)))
    with contextlib.closing(sqlite3.connect(folder / DB_NAME)) as con:
        con.execute("INSERT INTO learning (run_id, robot_id, time, inheritance, failures, "
                    "policy) VALUES (0, 1, 0.0, 'darwinian', 0, ?)",
                    (json.dumps({"file": "policies/run0_robot1.pkl", "digest": "0" * 64}),))
        con.commit()
    status, err = _one_line(capsys, ["resume", str(folder)])
    assert status == 2 and len(err.splitlines()) == 1, err
    assert "--trust-pickled-policies" in err, err
    robot = EXAMPLES["spider"]()
    reference = json.dumps({"file": "policies/run0_robot1.pkl", "digest": "0" * 64})
    with pytest.raises(StoreError, match="trust-pickled-policies"):
        load_policy(folder, 0, robot, reference)
    assert not marker.exists()


class _Evil:
    """Unpickled, it creates ``marker``."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self) -> tuple[Any, ...]:
        return (open, (str(self.marker), "w"))


# -- FIFOs, symbolic links and huge files in place of the folder's files --------------------------

KINDS = {"fifo": "FIFO", "symlink": "symbolic link", "sparse": "larger than"}
"""What is planted, and what the refusal says."""
TARGETS = ("results.sqlite", "results.sqlite-wal", "results.sqlite-shm",
           "results.sqlite-journal")
"""The files SQLite would open in a results folder."""


def _plant(path: Path, kind: str, elsewhere: Path) -> None:
    """Put ``kind`` in ``path``'s place (the file it replaces is moved aside, not lost)."""
    if path.exists():
        path.rename(path.with_name(path.name + ".kept"))
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "symlink":
        path.symlink_to(elsewhere)
    else:
        with open(path, "wb") as f:
            f.truncate(SPARSE)


RUNNER = """
import contextlib, io, json, sys
from evolution.cli import main
for argv in json.loads(sys.argv[1]):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        status = main(argv)
    print(json.dumps([argv, status, err.getvalue()]), flush=True)
"""


def _run_all(commands: list[list[str]]) -> list[tuple[list[str], int, str]]:
    """Each command through ``revolve``'s ``main`` in one subprocess, which must end in time."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    try:
        done = subprocess.run([sys.executable, "-c", RUNNER, json.dumps(commands)], cwd=ROOT,
                              env=env, capture_output=True, text=True, timeout=TIMEOUT,
                              check=False)
    except subprocess.TimeoutExpired as error:
        out = error.stdout.decode() if isinstance(error.stdout, bytes) else error.stdout or ""
        hung = commands[len(out.splitlines())]
        pytest.fail(f"hung for {TIMEOUT:g} s: revolve {' '.join(hung)}")
    assert done.returncode == 0, done.stderr
    return [tuple(json.loads(line)) for line in done.stdout.splitlines()]  # type: ignore[misc]


# A FIFO (the hang) by default; the other kinds take the same check, in the slow suite (each is
# a subprocess of some 30 commands: about 8 s of CPU).
@pytest.mark.parametrize("kind", [
    "fifo", pytest.param("symlink", marks=pytest.mark.slow),
    pytest.param("sparse", marks=pytest.mark.slow)])
def test_every_command_refuses_a_strange_file_in_place_of_the_database(
        made: Path, tmp_path: Path, kind: str) -> None:
    """In place of the database or of SQLite's files beside it, or of a study's settings: one
    line naming the file and the problem; nothing hangs, nothing of the results is changed.
    One subprocess runs them all (a hang fails the test, naming the command)."""
    elsewhere = tmp_path / "elsewhere.sqlite"
    shutil.copy(made / "offline" / DB_NAME, elsewhere)
    commands: list[list[str]] = []
    expected: list[Path] = []
    for target in TARGETS:
        folder = tmp_path / target
        shutil.copytree(made, folder)
        for db in ("offline", "online", "study/scenario1"):
            _plant(folder / db / target, kind, elsewhere)
        scratch = tmp_path / f"{target}-out"
        for command, argv in _commands(folder, scratch).items():
            commands.append(argv)
            db = {"watch": "online", "study": "study/scenario1"}.get(command, "offline")
            expected.append(folder / db / target)
    # In place of a study's settings: the study and its report refuse it.
    folder = tmp_path / "study.json"
    shutil.copytree(made / "study", folder)
    (tmp_path / "elsewhere.json").write_text((folder / "study.json").read_text())
    _plant(folder / "study.json", kind, tmp_path / "elsewhere.json")
    for argv in (["study", "--out", str(folder), *STUDY, "--set", f"task.name={CANARY}:Task"],
                 ["report", str(folder), "--out", str(tmp_path / "study-report")]):
        commands.append(argv)
        expected.append(folder / "study.json")
    before = {t: _digests(tmp_path / t) for t in TARGETS}
    results = _run_all(commands)
    assert len(results) == len(commands)
    for (argv, status, err), path in zip(results, expected, strict=True):
        lines = err.strip().splitlines()
        assert status == 2 and len(lines) == 1, (argv, err)
        assert lines[0].startswith(f"revolve {argv[0]}: error: "), lines
        assert str(path) in lines[0] and KINDS[kind] in lines[0], lines[0]
    assert {t: _digests(tmp_path / t) for t in TARGETS} == before
    assert elsewhere.stat().st_size > 0 and not (tmp_path / "results.sqlite-out").exists()


@contextlib.contextmanager
def _unblocked(fifo: Path) -> Iterator[None]:
    """Fail, rather than hang, if the code in the block waits on ``fifo``: after the timeout a
    writer opens and closes it, which ends any read of it."""
    done = threading.Event()

    def release() -> None:
        if not done.wait(TIMEOUT):
            with contextlib.suppress(OSError):
                os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))

    guard = threading.Thread(target=release, daemon=True)
    guard.start()
    try:
        yield
    finally:
        done.set()
        guard.join()


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_snapshots_policies_and_settings_are_read_only_as_bounded_regular_files(
        made: Path, tmp_path: Path, kind: str) -> None:
    folder = tmp_path / "exp"
    shutil.copytree(made / "online", folder)
    (folder / "checkpoints").mkdir()
    (folder / "policies").mkdir()
    outside = tmp_path / "outside"
    outside.write_bytes(b"{}")
    snap = snapshot.snapshot_path(folder / DB_NAME, 0, 22)
    policy = folder / "policies" / "run0_robot1.safetensors"
    settings = folder / "study.json"
    for path in (snap, policy, settings):
        _plant(path, kind, outside)
    reference = json.dumps({"file": "policies/run0_robot1.safetensors", "digest": "0" * 64,
                            "sha256": "0" * 64})
    ref = {"file": snap.name, "sha256": "0" * 64, "births": 22, "format": snapshot.FORMAT}
    with _unblocked(snap), pytest.raises(snapshot.SnapshotError, match=KINDS[kind]):
        snapshot.read(folder / DB_NAME, 0, ref, 22)
    with _unblocked(policy), pytest.raises(StoreError, match=KINDS[kind]):
        load_policy(folder, 0, EXAMPLES["spider"](), reference)
    with _unblocked(settings), pytest.raises(StoreError, match=KINDS[kind]):
        read_settings(folder, "study.json")
    if kind == "sparse":
        assert snap.stat().st_size > MAX_SNAPSHOT_BYTES


def test_a_symbolic_link_inside_the_folder_is_refused_even_when_it_stays_inside(
        tmp_path: Path) -> None:
    (tmp_path / "real").mkdir()
    (tmp_path / "real" / "file").write_bytes(b"data")
    (tmp_path / "link").symlink_to(tmp_path / "real")
    (tmp_path / "real" / "alias").symlink_to(tmp_path / "real" / "file")
    assert read_file(tmp_path, "real/file", "file", 10) == b"data"
    with pytest.raises(StoreError, match="symbolic link"):
        read_file(tmp_path, "link/file", "file", 10)
    with pytest.raises(StoreError, match="symbolic link"):
        read_file(tmp_path, "real/alias", "file", 10)
    with pytest.raises(StoreError, match="larger than the 3 bytes"):
        read_file(tmp_path, "real/file", "file", 3)


def test_a_database_in_place_is_still_opened(made: Path) -> None:
    """The rule refuses only what is strange: the made databases open."""
    for db in ("offline", "online", "study/scenario1"):
        Store.open(made / db / DB_NAME).close()


# -- what a command writes into a received folder ----------------------------------------------

def test_a_report_never_writes_through_a_link_in_the_folder(
        made: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``report/summary.md`` linked to a file of the user's would be appended to."""
    folder = tmp_path / "exp"
    shutil.copytree(made / "offline", folder)
    victim = tmp_path / "victim.md"
    victim.write_text("mine\n")
    (folder / "report").mkdir()
    (folder / "report" / "summary.md").symlink_to(victim)
    status, err = _one_line(capsys, ["report", str(folder)])
    assert status == 2 and "holds the symbolic link" in err and len(err.splitlines()) == 1, err
    (folder / "report" / "summary.md").unlink()
    (folder / "report").rmdir()
    (folder / "report").symlink_to(tmp_path)
    status, err = _one_line(capsys, ["report", str(folder)])
    assert status == 2 and "goes through the symbolic link" in err, err
    assert victim.read_text() == "mine\n" and not (tmp_path / "index.html").exists()


def test_a_study_writes_its_settings_without_following_a_link(made: Path,
                                                              tmp_path: Path) -> None:
    folder = tmp_path / "study"
    folder.mkdir()
    victim = tmp_path / "victim"
    victim.write_text("mine\n")
    (folder / "study.json.tmp").symlink_to(victim)
    prepare_study(folder, runs=1, births=15, experiments=["scenario1"])
    assert victim.read_text() == "mine\n"
    assert read_settings(folder, "study.json")["births"] == 15
