"""Online resume from the last checkpoint's snapshot (MuJoCo, real physics, tiny runs): the
resumed database equals an uninterrupted run's, and resume does not replay from birth 0; a
missing or damaged snapshot falls back to replay, with the same result."""

from __future__ import annotations

import logging
import sqlite3
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import Kill, kill_after, small
from experiment_fakes import dump_results as dump

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ExperimentConfig, ProgressEvent, load_config
from evolution.experiments.store.database import Store

pytest.importorskip("mujoco", reason="the mujoco package is not installed")

SERIAL = LocalEvaluator(1)


def tiny(engine: str = "mujoco", **changes: Any) -> ExperimentConfig:
    values: dict[str, Any] = dict(
        runs=1, births=12, population_size=3, insertion=0.5, evaluation_time=1.0,
        fertile_age=1.5, min_alive=2, max_alive=5, conception_interval=1.0,
        checkpoint_interval=2, diversity_interval=3, workers=1)
    values.update(changes)
    return small(load_config("scenario3", {"world": {"engine": engine}, **values}))


@pytest.fixture(scope="module")
def reference(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[tuple[Any, ...]]]:
    out = tmp_path_factory.mktemp("ref")
    experiments.run(tiny(), out, evaluator=SERIAL)
    return dump(out / "results.sqlite")


def _killed(out: Path, births: int) -> int:
    with pytest.raises(Kill):
        experiments.run(tiny(), out, kill_after(births), evaluator=SERIAL)
    with Store.open(out / "results.sqlite") as store:
        checkpoint = store.checkpoint(0)
    assert checkpoint is not None and "snapshot" in checkpoint.engine_state
    assert (out / "checkpoints" / checkpoint.engine_state["snapshot"]["file"]).is_file()
    assert len(list((out / "checkpoints").iterdir())) == 1  # older snapshots were pruned
    return checkpoint.births


def test_a_killed_run_resumes_from_its_snapshot_to_the_uninterrupted_database(
        tmp_path: Path, reference: dict[str, list[tuple[Any, ...]]]) -> None:
    out = tmp_path / "killed"
    births = _killed(out, 7)
    events: list[ProgressEvent] = []
    experiments.resume(out, events.append, evaluator=SERIAL)
    assert dump(out / "results.sqlite") == reference
    # no replay: the resume's first event is the checkpoint itself, then it goes on from there
    assert not any(e.replaying for e in events)
    assert events[0].births == births and events[0].sim_time > 0
    assert all(e.births >= births for e in events)
    assert not list((out / "checkpoints").iterdir())  # a finished run keeps no snapshot


@pytest.mark.parametrize("damage", ["missing", "corrupt", "old-database"])
def test_without_a_usable_snapshot_resume_replays_to_the_same_database(
        tmp_path: Path, reference: dict[str, list[tuple[Any, ...]]], damage: str,
        caplog: pytest.LogCaptureFixture) -> None:
    out = tmp_path / "killed"
    _killed(out, 5)
    (path,) = (out / "checkpoints").iterdir()
    if damage == "missing":
        path.unlink()
    elif damage == "corrupt":
        blob = bytearray(path.read_bytes())
        blob[len(blob) // 2] ^= 0xFF
        path.write_bytes(bytes(blob))
    else:  # a database written before snapshots: no reference in the checkpoint
        con = sqlite3.connect(out / "results.sqlite")
        with con:
            con.execute("UPDATE checkpoints SET engine_state = json_remove(engine_state, "
                        "'$.snapshot')")
        con.close()
    events: list[ProgressEvent] = []
    with caplog.at_level(logging.WARNING, logger="evolution.experiments.loop.online"):
        experiments.resume(out, events.append, evaluator=SERIAL)
    assert "replaying from birth 0" in caplog.text
    assert any(e.replaying for e in events)
    assert dump(out / "results.sqlite") == reference


def test_an_unwritable_snapshot_folder_never_stops_a_run(
        tmp_path: Path, reference: dict[str, list[tuple[Any, ...]]],
        caplog: pytest.LogCaptureFixture) -> None:
    """The results matter more than a fast resume: without snapshots the run goes on (a file
    where the folder should be), and a resume replays."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "checkpoints").write_text("not a folder")
    with caplog.at_level(logging.WARNING, logger="evolution.experiments.loop.online"), \
            pytest.raises(Kill):
        experiments.run(tiny(), out, kill_after(5), evaluator=SERIAL)
    assert "cannot write the snapshot" in caplog.text
    events: list[ProgressEvent] = []
    experiments.resume(out, events.append, evaluator=SERIAL)
    assert any(e.replaying for e in events)
    assert dump(out / "results.sqlite") == reference


def test_pybullet_writes_no_snapshot_and_resumes_by_replay(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """pybullet cannot continue a saved state exactly: no snapshot files, replay with a note."""
    config = tiny("pybullet", births=8)
    experiments.run(config, tmp_path / "ref", evaluator=SERIAL)
    out = tmp_path / "killed"
    with pytest.raises(Kill):
        experiments.run(config, out, kill_after(5), evaluator=SERIAL)
    assert not (out / "checkpoints").exists()
    events: list[ProgressEvent] = []
    with caplog.at_level(logging.WARNING, logger="evolution.experiments.loop.online"):
        experiments.resume(out, events.append, evaluator=SERIAL)
    assert "cannot restore a saved state exactly" in caplog.text
    assert any(e.replaying for e in events)
    assert dump(out / "results.sqlite") == dump(tmp_path / "ref" / "results.sqlite")
