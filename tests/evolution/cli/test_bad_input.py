"""Bad command lines of every ``revolve`` command: one line, exit status 2, before anything runs.

Every value is checked when it is given (issue 20): numbers that would hang the machine (frames,
repeats, births, workers, seconds, radii), names that are not printable or are paths, files in
the way, flags that need another flag. Each case below must exit 2 with exactly one line on
stderr, write nothing, and never reach a simulation (those entry points raise if called). A
fuzz of the numeric options checks the same of any text. Also here: ``--version``, and the dead
ends of a killed ``run`` (runs never registered, a database without tables).
"""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import dump_results, fake_evaluate, fake_world, small
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from evolution import experiments
from evolution.cli import main
from evolution.evaluation import LocalEvaluator
from evolution.experiments import preset
from evolution.experiments.app import api
from evolution.experiments.loop import evolve as loop
from evolution.experiments.store.database import DB_NAME, Store

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)


class Ran(BaseException):
    """A command got past its checks and started to simulate."""


def _ran(*args: object, **kwargs: object) -> Any:
    raise Ran


@pytest.fixture
def nothing_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every way a command starts to simulate raises :class:`Ran`."""
    import evolution.experiments.app.reevaluate as reevaluate_module
    import revolve_env.envs.recording

    monkeypatch.setattr(api, "_execute", _ran)
    monkeypatch.setattr("evolution.evaluation.evaluate_robot", _ran)  # revolve demo
    monkeypatch.setattr(revolve_env.envs.recording, "record_robot", _ran)
    monkeypatch.setattr(reevaluate_module, "make_evaluator", _ran)
    monkeypatch.setattr("evolution.cli.viewer.replay_online", _ran)
    monkeypatch.setattr("evolution.cli.study.run_study", _ran)
    # revolve study's time estimate simulates each experiment for a few seconds of CPU first
    # (20 s for the five): it was most of the numeric options' fuzz (2026-11-27).
    monkeypatch.setattr("evolution.cli.study.calibrate_all", _ran)


@pytest.fixture(scope="module")
def online(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished online experiment (fast stand-ins): 30 births, about 225 s simulated."""
    out = tmp_path_factory.mktemp("online") / "exp"
    experiments.run(small(preset("scenario3", births=30, runs=1)), out, evaluator=SERIAL,
                    world_factory=fake_world)
    return out


def _one_line(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    try:
        status = main(argv)
    except SystemExit as exit_:  # argparse (one line too: see commands._Parser)
        status = exit_.code if isinstance(exit_.code, int) else 1
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    assert status == 2, f"{argv} exited {status}: {err}"
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


# (argv with {tmp}, {file}, {online} filled in, what the line must say)
BAD: list[tuple[list[str], str]] = [
    (["run", "quick", "--set", "evaluation_time=1e-9", "--set", "fertile_age=0",
      "--set", "insertion=0"], "evaluation_time must cover one control period"),
    (["run", "scenario3", "--set", "evaluation_time=1e-9", "--set", "fertile_age=0.5",
      "--set", "insertion=0"], "evaluation_time must cover one control period"),
    (["run", "scenario3", "--set", "world.engine=mujoco", "--set", "birth_radius=1e30"],
     "birth_radius must be <= 100 m"),
    (["run", "scenario3", "--set", "birth_clearance=1e9"], "birth_clearance must be <= 100 m"),
    (["run", "scenario3", "--set", "world.engine=mujoco_warp"],
     "'mujoco_warp' steps isolated worlds only (its capability shared_world is False)"),
    (["show", "spider", "--engine", "mujoco_warp"], "invalid choice: 'mujoco_warp'"),
    (["run", "quick", "--set", "evaluation.position_jitter=1e30"],
     "position_jitter must be <= 100 m"),
    (["run", "quick", "--set", "evaluation_time=1e9"], "evaluation_time must be <= 3600 s"),
    (["run", "quick", "--set", "insertion=1e7"], "insertion must be <= 3600 s"),
    (["run", "scenario3", "--set", "conception_interval=1e12"],
     "conception_interval must be <= 3600 s"),
    (["run", "quick", "--births", "100000000000000000000"], "births must be <= 10000000"),
    (["run", "quick", "--set", "births=1e20"], "births must be an integer"),
    (["run", "quick", "--runs", "1000000"], "runs must be <= 10000"),
    (["run", "quick", "--set", "population_size=100000000"], "population_size must be <="),
    (["run", "scenario3", "--set", "max_alive=100000000"], "max_alive must be <= 1000"),
    (["run", "quick", "--seed", "100000000000000000000"], "seed must be <="),
    (["run", "quick", "--workers", "1000000"], "--workers: must be <= 1024"),
    (["run", "quick", "--set", "workers=1000000"], "workers must be <= 1024"),
    (["run", "quick", "--name", "a\x01b"], "cannot name a folder"),
    (["run", "quick", "--name", "a\\b"], "cannot name a folder"),
    (["run", "quick", "--name", "../x"], "cannot name a folder"),
    (["run", "quick", "--name", ".."], "cannot name a folder"),
    (["run", "quick", "--name", "x" * 101], "cannot name a folder"),
    (["run", "quick", "--tensorboard", "{file}"], "is a file, not a folder"),
    (["run", "quick", "--tensorboard", "{file}/tb"], "is a file, not a folder"),
    (["resume", "{online}", "--tensorboard", "{file}"], "is a file, not a folder"),
    (["show", "spider", "--fps", "1e9"], "--fps: must be <= 60"),
    (["show", "spider", "--seconds", "1e9"], "--seconds: must be <= 3600"),
    (["show", "spider", "--insertion", "1e9"], "--insertion: must be <= 3600"),
    (["show", "spider", "--seconds", "3000", "--out", "{tmp}/x.gif"], "frames"),
    (["show", "spider", "--fps", "60", "--out", "{tmp}/x.gif"], "a GIF cannot play 60"),
    (["show", "spider", "--out", "{tmp}/missing/x.gif"], "is not a folder"),
    (["show", "spider", "--out", "{tmp}/x.avi"], "must end in .gif or .mp4"),
    (["show", "spider", "--best"], "--best names a robot of a results database"),
    (["show", "spider", "--robot", "3"], "--robot names a robot of a results database"),
    (["show", "spider", "--run", "1", "--best"], "--best and --run name a robot"),
    (["export", "spider", "--format", "urdf", "--best"], "--best names a robot"),
    (["watch", "{online}", "--record", "{tmp}/w.gif", "--fps", "30"], "frames"),
    (["watch", "{online}", "--record", "{tmp}/w.avi", "--seconds", "5"], ".gif or .mp4"),
    (["watch", "{online}", "--record", "{tmp}/missing/w.gif", "--seconds", "5"],
     "is not a folder"),
    (["watch", "spider", "--fps", "1e9"], "--fps: must be <= 60"),
    (["reevaluate", "{online}", "--k", "1000000000"], "--k: must be <= 1000"),
    (["reevaluate", "{online}", "--window-offset", "1e9"], "--window-offset: must be <= 3600"),
    (["reevaluate", "{online}", "--workers", "100000"], "--workers: must be <= 1024"),
    (["demo", "--seconds", "1e9"], "--seconds: must be <= 3600"),
    (["demo", "--births", "100000000000"], "births must be <= 10000000"),
    (["demo", "--population", "100000000"], "population_size must be <="),
    (["study", "--workers", "100000", "--out", "{tmp}/study"], "--workers: must be <= 1024"),
    (["study", "--births", "100000000000", "--out", "{tmp}/study"], "births must be <="),
    (["study", "--set", "name=x", "--out", "{tmp}/study"], "name"),
    (["report", "{online}", "--formats", "exe"], "--formats"),
    (["run"], "required"),
    ([], "required"),
    (["fly"], "invalid choice"),
]


@pytest.mark.parametrize("argv, says", BAD, ids=[" ".join(a)[:60] for a, _ in BAD])
def test_a_bad_command_line_is_one_line_before_anything_runs(
        tmp_path: Path, online: Path, capsys: pytest.CaptureFixture[str],
        nothing_runs: None, argv: list[str], says: str) -> None:
    (tmp_path / "file").write_text("in the way")
    filled = [a.format(tmp=tmp_path, file=tmp_path / "file", online=online) for a in argv]
    if filled and filled[0] == "run":
        filled += ["--out", str(tmp_path / "out")]
    before = sorted(p.name for p in tmp_path.iterdir())
    line = _one_line(capsys, filled)
    assert says in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written


OPTIONS = [(["show", "spider", "--out", "{tmp}/x.gif"], "--fps"),
           (["show", "spider", "--out", "{tmp}/x.gif"], "--seconds"),
           (["show", "spider", "--out", "{tmp}/x.gif"], "--insertion"),
           (["reevaluate", "{tmp}"], "--k"), (["reevaluate", "{tmp}"], "--window-offset"),
           (["reevaluate", "{tmp}"], "--workers"), (["run", "quick"], "--births"),
           (["run", "quick"], "--runs"), (["run", "quick"], "--workers"),
           (["run", "quick"], "--seed"), (["demo"], "--seconds"), (["demo"], "--births"),
           (["demo"], "--population"), (["study", "--out", "{tmp}/s"], "--workers")]
texts = st.one_of(st.sampled_from(["0", "-1", "1e9", "1e309", "nan", "inf", "-inf", "1e-320",
                                   "60", "60.0001", "3600", "3600.5", "1000", "1001", "1024",
                                   "1025", "10000001", "99999999999999999999", "0x10", "",
                                   " ", "1_000", "\x00"]),
                  st.text(max_size=8), st.floats().map(repr), st.integers().map(str))


@settings(max_examples=int(os.environ.get("REVOLVE_FUZZ_EXAMPLES", "150")), deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(option=st.sampled_from(OPTIONS), value=texts)
def test_numeric_options_give_one_line_or_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], nothing_runs: None,
        option: tuple[list[str], str], value: str) -> None:
    """Whatever text a numeric option gets: refused on one line, or the command runs."""
    argv, flag = option
    filled = [a.format(tmp=tmp_path) for a in argv] + [f"{flag}={value}"]
    if filled[0] == "run":
        filled += ["--out", str(tmp_path / "out")]
    try:
        status = main(filled)
    except SystemExit as exit_:
        status = exit_.code if isinstance(exit_.code, int) else 1
    except Ran:
        capsys.readouterr()
        return
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err, (filled, err)
    assert len(err.strip().splitlines()) == 1, err


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    import revolve_env

    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    assert capsys.readouterr().out.strip() == f"revolve {revolve_env.__version__}"


# -- dead ends of a killed run ---------------------------------------------------------------------


@pytest.fixture
def fake_physics(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(api, "make_evaluator", lambda *a, **k: SERIAL)
    monkeypatch.setattr(loop, "default_world", fake_world)


@pytest.mark.parametrize("name", ["scenario1", "scenario3"])
def test_runs_never_registered_are_registered_and_run_by_resume(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], fake_physics: None,
        name: str) -> None:
    """Killed between creating the database and registering the runs: resume runs them all,
    to the results of an uninterrupted run (before, it said every run had finished)."""
    config = small(preset(name, births=30, runs=2))
    experiments.run(config, tmp_path / "whole", evaluator=SERIAL, world_factory=fake_world)
    folder = tmp_path / "killed"
    Store.create(folder / DB_NAME, config.to_dict(), config.seed).close()  # the state a kill left
    assert main(["resume", str(folder)]) == 0
    assert "resuming 2 run(s)" in capsys.readouterr().out
    assert dump_results(folder / DB_NAME) == dump_results(tmp_path / "whole" / DB_NAME)
    assert main(["resume", str(folder)]) == 0
    assert "nothing to resume" in capsys.readouterr().out


def _empty_database(folder: Path, wal: bool) -> Path:
    """What a kill while the database was being created leaves: a file with no table."""
    folder.mkdir(parents=True)
    db = folder / DB_NAME
    if wal:
        con = sqlite3.connect(db)
        con.execute("PRAGMA journal_mode = WAL")
        con.close()
    else:
        db.write_bytes(b"")
    return db


@pytest.mark.parametrize("wal", [False, True])
def test_a_database_without_tables_names_the_command_that_fixes_it(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], fake_physics: None,
        wal: bool) -> None:
    folder = tmp_path / "results" / "quick"
    _empty_database(folder, wal)
    for argv in (["resume", str(folder)], ["report", str(folder)],
                 ["show", "--db", str(folder), "--best"],
                 ["reevaluate", str(folder)]):
        line = _one_line(capsys, argv)
        assert "is empty" in line and "revolve run" in line, line
    # ... and that command replaces it.
    assert main(["run", "quick", "--runs", "1", "--births", "15",
                 "--out", str(tmp_path / "results")]) == 0
    with Store.open(folder / DB_NAME) as store:
        assert [(r.status, r.births) for r in store.runs()] == [("finished", 15)]


def test_a_study_replaces_a_database_without_tables(tmp_path: Path,
                                                   fake_physics: None) -> None:
    from evolution.experiments.app.study import study

    _empty_database(tmp_path / "study" / "baseline_a", wal=False)
    study(tmp_path / "study", runs=1, births=15, experiments=("baseline_a",),
          evaluator=SERIAL)
    with Store.open(tmp_path / "study" / "baseline_a" / DB_NAME) as store:
        assert [r.status for r in store.runs()] == ["finished"]
