"""Kill and resume gives the same results as an uninterrupted run; results are never overwritten."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import CtrlCEvaluator, Kill, fake_evaluate, fake_world, small
from experiment_fakes import dump_results as dump
from experiment_fakes import kill_after as killer

import revolve_env
from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ExperimentConfig, ProgressEvent, preset
from evolution.experiments.app.api import check_resumable
from evolution.experiments.loop.config import WorldSettings
from evolution.experiments.store.database import Store, StoreError


def small_preset(name: str, **kw: object) -> ExperimentConfig:
    """A shipped config with small robots and, unless told otherwise, one run."""
    kw.setdefault("runs", 1)
    return small(preset(name, **kw))


SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)


def _uninterrupted(config: ExperimentConfig, out: Path, **kw: Any) -> dict[str, list]:
    experiments.run(config, out, evaluator=SERIAL, **kw)
    return dump(out / "results.sqlite")


@pytest.mark.parametrize("name, births, kills", [
    ("scenario1", 75, [30, 50]),
    ("scenario2", 40, [20]),
    ("baseline_b", 60, [30]),
])
def test_offline_kill_and_resume_equals_uninterrupted(
        tmp_path: Path, name: str, births: int, kills: list[int]) -> None:
    config = small_preset(name, births=births, diversity_interval=5, runs=2)
    reference = _uninterrupted(config, tmp_path / "ref")
    out = tmp_path / "killed"
    with pytest.raises(Kill):
        experiments.run(config, out, killer(kills[0]), evaluator=SERIAL)
    assert ({r.status for r in Store.open(out / "results.sqlite").runs()}
            == {"interrupted", "pending"})
    for k in kills[1:]:
        with pytest.raises(Kill):
            experiments.resume(out, killer(k), evaluator=SERIAL)
    experiments.resume(out, evaluator=SERIAL)
    assert dump(out / "results.sqlite") == {**reference}


def test_ctrl_c_mid_generation_keeps_finished_generations(tmp_path: Path) -> None:
    config = small_preset("scenario1", births=75)
    reference = _uninterrupted(config, tmp_path / "ref")
    out = tmp_path / "killed"
    with pytest.raises(KeyboardInterrupt):
        experiments.run(config, out, evaluator=CtrlCEvaluator(15 + 15 + 7))
    with Store.open(out / "results.sqlite") as store:
        assert store.runs()[0].status == "interrupted"
        assert store.checkpoint(0).births == 30  # the half-done third generation is not stored
        assert len(store.robots(0)) == 30
    experiments.resume(out, evaluator=SERIAL)
    assert dump(out / "results.sqlite") == reference


def test_online_kill_and_resume_replays_to_the_same_result(tmp_path: Path) -> None:
    config = small_preset("scenario3", births=60, checkpoint_interval=5, diversity_interval=7)
    reference = _uninterrupted(config, tmp_path / "ref", world_factory=fake_world)
    out = tmp_path / "killed"
    with pytest.raises(Kill):
        experiments.run(config, out, killer(33), evaluator=SERIAL, world_factory=fake_world)
    with Store.open(out / "results.sqlite") as store:
        assert store.checkpoint(0).births == 35
    events: list[ProgressEvent] = []
    experiments.resume(out, events.append, evaluator=SERIAL, world_factory=fake_world)
    assert any(e.replaying for e in events) and events[-1].finished
    assert dump(out / "results.sqlite") == reference


def _as_version_4(db: Path) -> None:
    """What the version before ``mode`` wrote: the stored config's switch named ``engine``."""
    con = sqlite3.connect(db)
    config = json.loads(con.execute("SELECT value FROM meta WHERE key = 'config'").fetchone()[0])
    config["engine"] = config.pop("mode")
    con.execute("UPDATE meta SET value = ? WHERE key = 'config'",
                (json.dumps(config, sort_keys=True),))
    con.execute("ALTER TABLE fitness DROP COLUMN shaking")  # added by schema 7
    con.execute("UPDATE meta SET value = '4' WHERE key = 'schema_version'")
    con.commit()
    con.close()


@pytest.mark.parametrize("name, kill", [("scenario1", 30), ("scenario3", 33)])
def test_a_version_4_run_resumes_to_the_same_numbers(tmp_path: Path, name: str,
                                                     kill: int) -> None:
    """A run interrupted under schema 4 (its config says ``engine = "offline" | "online"``) is
    upgraded when resumed, continues to the results of an uninterrupted run, and keeps its
    mode."""
    config = small_preset(name, births=60, checkpoint_interval=5, diversity_interval=7)
    reference = _uninterrupted(config, tmp_path / "ref", world_factory=fake_world)
    out = tmp_path / "old"
    with pytest.raises(Kill):
        experiments.run(config, out, killer(kill), evaluator=SERIAL, world_factory=fake_world)
    _as_version_4(out / "results.sqlite")
    experiments.resume(out, evaluator=SERIAL, world_factory=fake_world)
    assert dump(out / "results.sqlite") == reference
    with Store.open(out / "results.sqlite") as store:
        assert store.config["mode"] == config.mode and "engine" not in store.config


def test_resume_refuses_a_tampered_online_run(tmp_path: Path) -> None:
    config = small_preset("scenario3", births=40, checkpoint_interval=5)
    out = tmp_path / "out"
    with pytest.raises(Kill):
        experiments.run(config, out, killer(25), evaluator=SERIAL, world_factory=fake_world)
    con = sqlite3.connect(out / "results.sqlite")
    con.execute("UPDATE robots SET genome = '{}' WHERE robot_id = 17")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match="replay made a different robot 17"):
        experiments.resume(out, evaluator=SERIAL, world_factory=fake_world)


def test_results_are_never_overwritten(tmp_path: Path) -> None:
    out = tmp_path / "out"
    experiments.run(small_preset("scenario1", births=15), out, evaluator=SERIAL)
    before = dump(out / "results.sqlite")
    with pytest.raises(StoreError,
                       match="already holds results of this experiment .*revolve resume"):
        experiments.run(small_preset("scenario1", births=15), out, evaluator=SERIAL)
    with pytest.raises(StoreError,
                       match=r"experiment 'scenario1' with other settings \(births: 15 stored"):
        experiments.run(small_preset("scenario1", births=30), out, evaluator=SERIAL)
    assert dump(out / "results.sqlite") == before


def test_resume_errors(tmp_path: Path) -> None:
    with pytest.raises(StoreError, match="no results database"):
        experiments.resume(tmp_path / "nothing-here")
    bad = tmp_path / "corrupt"
    bad.mkdir()
    (bad / "results.sqlite").write_bytes(b"\x00garbage" * 1000)
    with pytest.raises(StoreError, match="corrupt"):
        experiments.resume(bad)
    with pytest.raises(StoreError, match="cannot be used"):
        experiments.run(small_preset("scenario1", births=15), bad, evaluator=SERIAL)


def test_resuming_a_finished_experiment_changes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "out"
    experiments.run(small_preset("scenario2", births=20), out, evaluator=SERIAL)
    before = dump(out / "results.sqlite")
    summary = experiments.resume(out, evaluator=SERIAL)
    assert summary.runs == ()
    assert dump(out / "results.sqlite") == before


def test_a_kill_before_all_runs_were_registered_resumes_every_run(tmp_path: Path) -> None:
    """The database may exist with fewer runs than configured (killed right after creation)."""
    config = small_preset("scenario2", births=20, runs=2)
    out = tmp_path / "out"
    out.mkdir()
    Store.create(out / "results.sqlite", config.to_dict(), config.seed).close()  # then killed
    summary = experiments.resume(out, evaluator=SERIAL)
    assert sorted(r.run_id for r in summary.runs) == [0, 1]
    assert dump(out / "results.sqlite") == _uninterrupted(config, tmp_path / "reference")


def test_results_of_another_physics_revision_are_not_continued(tmp_path: Path) -> None:
    """A run made before MuJoCo's stepping changed (no recorded revision: revision 1) is refused
    in one line instead of living its remaining births in other physics; finished results are
    still read and reported."""
    config = ExperimentConfig(population_size=2, offspring_size=2, births=4, runs=1)
    config = config.replace(world=WorldSettings(engine="mujoco"))
    db_path = tmp_path / "results.sqlite"
    Store.create(db_path, config.to_dict(), 0).close()
    with Store.open(db_path) as store:
        assert store.physics_revisions == revolve_env.PHYSICS_REVISIONS
    check_resumable(db_path)  # this version's own results continue
    with sqlite3.connect(db_path) as db:
        db.execute("DELETE FROM meta WHERE key = 'physics'")
    with Store.open(db_path) as store:
        assert store.physics_revisions == dict.fromkeys(revolve_env.PHYSICS_REVISIONS, 1)
    with pytest.raises(StoreError, match="made with mujoco physics revision 1, and this "
                                         "version of revolve-env steps mujoco as revision 2"):
        check_resumable(db_path)
    with sqlite3.connect(db_path) as db:
        db.execute("INSERT INTO meta VALUES ('physics', ?)", (json.dumps({"mujoco": "x"}),))
    with Store.open(db_path) as store:  # damaged: read as the oldest revision
        assert store.physics_revisions["mujoco"] == 1
