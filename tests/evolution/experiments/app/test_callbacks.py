"""Progress callbacks: TensorBoard scalars read back, combine(), and the failure counts the
events carry (on the fast physics stand-ins of ``experiment_fakes``)."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest
from experiment_fakes import Kill, fake_evaluate, fake_world, fake_world_with_blow_ups, small
from experiment_fakes import kill_after as killer

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import Evolution, ProgressEvent, preset
from evolution.experiments.app.callbacks import (
    TensorBoardLogger,
    TensorBoardUnavailableError,
    combine,
)
from evolution.experiments.store.database import Store

pytest.importorskip("tensorboard", reason="TensorBoard logging needs the tensorboard package")
pytest.importorskip("torch", reason="TensorBoard logging writes with torch's SummaryWriter")

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)


def _scalars(folder: Path) -> dict[str, list[tuple[int, float]]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    acc = EventAccumulator(str(folder))
    acc.Reload()
    return {tag: [(e.step, e.value) for e in acc.Scalars(tag)] for tag in acc.Tags()["scalars"]}


def test_a_run_writes_its_scalars_against_births(tmp_path: Path) -> None:
    events: list[ProgressEvent] = []
    config = small(preset("scenario1", runs=2, births=45))
    with TensorBoardLogger(tmp_path / "tb") as tensorboard:
        experiments.run(config, tmp_path / "out", combine(tensorboard, events.append),
                        evaluator=SERIAL)
    assert sorted(p.name for p in (tmp_path / "tb").iterdir()) == ["run0", "run1"]
    scalars = _scalars(tmp_path / "tb" / "run1")
    assert set(scalars) == {"fitness/best", "fitness/mean", "population/size", "speed/sim_speed",
                            "failures/total"}
    # One point per commit point (15, 30, 45 births); the finished event repeats the last one and
    # is not written again.
    assert [step for step, _ in scalars["fitness/best"]] == [15, 30, 45]
    last = [e for e in events if e.run_id == 1][-1]
    assert scalars["fitness/best"][-1][1] == pytest.approx(last.best)
    assert scalars["fitness/mean"][-1][1] == pytest.approx(last.mean)
    assert [v for _, v in scalars["population/size"]] == [15.0] * 3


def test_the_logger_observes_a_loop_stepped_in_python(tmp_path: Path) -> None:
    """Attached to the loop itself (no database, no progress callback), the logger writes the
    scalars ``evolution.run`` makes it write."""
    config = small(preset("scenario1", runs=1, births=45))
    with TensorBoardLogger(tmp_path / "run") as tensorboard:
        experiments.run(config, tmp_path / "out", tensorboard, evaluator=SERIAL)
    with TensorBoardLogger(tmp_path / "loop") as tensorboard:
        Evolution(config, evaluator=SERIAL, observers=[tensorboard]).run()
    looped, stored = _scalars(tmp_path / "loop" / "run0"), _scalars(tmp_path / "run" / "run0")
    assert [step for step, _ in looped["fitness/best"]] == [15, 30, 45]
    for tag in ("fitness/best", "fitness/mean", "population/size", "failures/total"):
        assert looped[tag] == stored[tag], tag


def test_unknown_fitness_and_replays_are_not_written(tmp_path: Path) -> None:
    nan = float("nan")
    with TensorBoardLogger(tmp_path) as tensorboard:
        tensorboard(ProgressEvent(0, 5, 10, 1.0, nan, nan, 5, 2.0, 1.0))
        tensorboard(ProgressEvent(0, 8, 10, 2.0, 1.0, 0.5, 5, 2.0, 1.0, replaying=True))
        tensorboard(ProgressEvent(0, 10, 10, 3.0, 1.5, 0.75, 5, 2.0, 1.0, finished=True))
    scalars = _scalars(tmp_path / "run0")
    assert scalars["fitness/best"] == [(10, 1.5)]
    assert [step for step, _ in scalars["population/size"]] == [5, 10]


def test_a_missing_tensorboard_is_one_line_naming_the_pip_command(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "torch.utils.tensorboard", None)
    pip = r'pip install "revolve-env\[tensorboard\]"'
    with pytest.raises(TensorBoardUnavailableError, match=pip):
        TensorBoardLogger("unused")


def test_combine_calls_each_and_closes_those_that_close() -> None:
    seen: list[str] = []

    class Closing:
        def __call__(self, event: ProgressEvent) -> None:
            seen.append(f"closing {event.births}")

        def close(self) -> None:
            seen.append("closed")

    both = combine(Closing(), lambda e: seen.append(f"plain {e.births}"))
    both(ProgressEvent(0, 3, 10, 1.0, 1.0, 1.0, 3, 1.0, 1.0))
    both.close()
    assert seen == ["closing 3", "plain 3", "closed"]


def test_events_count_the_failures_of_the_run(tmp_path: Path) -> None:
    events: list[ProgressEvent] = []
    config = small(preset("scenario3", runs=1, births=80))
    experiments.run(config, tmp_path / "out", events.append, evaluator=SERIAL,
                    world_factory=fake_world_with_blow_ups)
    with Store.open(tmp_path / "out" / "results.sqlite") as store:
        stored = store.failures(0)
    counts = dict(events[-1].failures)
    assert counts["blow-up"] > 0
    assert sum(counts.values()) == len(stored)
    totals = [sum(n for _, n in e.failures) for e in events]
    assert totals == sorted(totals) and totals[0] < totals[-1]


def test_a_resumed_online_run_continues_its_curves_without_the_replay(tmp_path: Path) -> None:
    config = small(preset("scenario3", runs=1, births=60, checkpoint_interval=5))
    out, tb = tmp_path / "out", tmp_path / "tb"
    with TensorBoardLogger(tb) as tensorboard, pytest.raises(Kill):
        experiments.run(config, out, combine(tensorboard, killer(33)), evaluator=SERIAL,
                        world_factory=fake_world)
    first = [step for step, _ in _scalars(tb / "run0")["population/size"]]
    # TensorBoard reads a run's event files in the order of their names: the second they were
    # opened, then a process-wide counter compared as text ("10" < "9"). A resume in the same
    # second as the kill (only a test is that fast) could be read first and the killed run's
    # points dropped as orphans, so the resumed file opens a second later, as a user's would.
    time.sleep(1.1)
    events: list[ProgressEvent] = []
    with TensorBoardLogger(tb) as tensorboard:
        experiments.resume(out, combine(tensorboard, events.append), evaluator=SERIAL,
                           world_factory=fake_world)
    assert any(e.replaying for e in events)
    scalars = _scalars(tb / "run0")
    steps = [step for step, _ in scalars["population/size"]]
    assert steps[:len(first)] == first and first[-1] == 35  # the kill came at its commit point
    resumed = steps[len(first):]
    # The replayed births are not written again; the commit point the run continues from is,
    # with the same values.
    assert resumed[0] == 35 and resumed[1] > 35 and resumed == sorted(resumed)
    assert resumed[-1] == 60
    at_35 = [value for step, value in scalars["fitness/best"] if step == 35]
    assert len(at_35) == 2 and at_35[0] == at_35[1]
