"""The progress display and the command line's logging, with fake events (no physics): bars keep
their lines, the total is the sum, nothing is guessed before there is data, plain lines off a
terminal, ``--quiet`` and ``--verbose``."""

from __future__ import annotations

import io
import logging
import math
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from experiment_fakes import fake_evaluate

from evolution.cli import main
from evolution.cli.progress import ProgressDisplay, cli_logging
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ProgressEvent
from evolution.experiments.app import api

NAN = math.nan


def _event(run_id: int, births: int, *, best: float = 2.5, target: int = 100,
           finished: bool = False, replaying: bool = False,
           failures: tuple[tuple[str, int], ...] = ()) -> ProgressEvent:
    mean = NAN if math.isnan(best) else best / 2
    return ProgressEvent(run_id, births, target, births * 15.0, best, mean, 15, 40.0, 1.0,
                         replaying=replaying, finished=finished, failures=failures)


class Clock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def log() -> Iterator[io.StringIO]:
    """The CLI's logging at its default level, into a string."""
    stream = io.StringIO()
    with cli_logging(0, stream):
        yield stream


def _bar_text(display: ProgressDisplay, run_id: int, label: str = "") -> str:
    slot = display.runs[(label, run_id)].slot
    assert slot is not None
    return str(display.bars[slot + 1])


def test_bars_keep_their_lines_and_the_total_is_the_sum(log: io.StringIO) -> None:
    clock = Clock()
    display = ProgressDisplay({0: 100, 1: 100, 2: 100}, stream=io.StringIO(), tty=True,
                              max_bars=2, clock=clock)
    assert not display.bars  # nothing drawn before the first event
    for births in (10, 20, 30):
        for run_id in (1, 0):  # interleaved, in another order than the lines
            clock.now += 1.0
            display(_event(run_id, births))
            assert [display.runs[("", r)].slot for r in (0, 1, 2)] == [0, 1, None]  # 2 lines
            assert display.bars[0].n == display.done == sum(display.bars[s].n for s in (1, 2))
    assert "30/100 births" in _bar_text(display, 0) and "best 2.500 m" in _bar_text(display, 0)
    display(_event(0, 100, finished=True))
    display(_event(2, 10))  # a third run takes the finished run's line
    assert display.runs[("", 2)].slot == 0 and display.runs[("", 0)].slot is None
    assert display.runs[("", 1)].slot == 1
    assert display.bars[0].n == 100 + 30 + 10 and display.bars[0].total == 300
    assert "1/3 runs finished" in str(display.bars[0])
    display.close()
    assert "run 0: finished, 100 births, best 2.500 m" in log.getvalue()


def test_no_eta_or_fitness_before_there_is_data(log: io.StringIO) -> None:
    clock = Clock()
    display = ProgressDisplay({0: 100, 1: 100}, stream=io.StringIO(), tty=True, clock=clock)
    display(_event(1, 10, best=NAN))
    assert "waiting" in _bar_text(display, 0) and "ETA" not in str(display.bars[0])
    display(_event(0, 10, best=NAN))
    text = _bar_text(display, 0)
    assert "no robot evaluated yet" in text
    assert "ETA" not in text and "best" not in text and " - " not in text
    clock.now = 10.0
    display(_event(0, 30))
    # 20 births in 10 s: 70 left take 35 s; all runs: 20 births in 10 s, 160 left take 80 s
    assert "ETA 0m35s" in _bar_text(display, 0) and "ETA 1m20s" in str(display.bars[0])
    display.close()


def test_a_replay_shows_as_such_and_does_not_count_for_the_eta(log: io.StringIO) -> None:
    clock = Clock()
    display = ProgressDisplay({0: 100}, {0: 0}, label="s3", stream=io.StringIO(), tty=True,
                              clock=clock)
    for births in (10, 20, 40):
        clock.now += 0.1
        display(_event(0, births, replaying=True))
    assert "replaying to its last commit point" in _bar_text(display, 0, "s3")
    clock.now = 1.0
    display(_event(0, 40))
    clock.now = 11.0
    display(_event(0, 60))  # 20 live births in 10 s: 40 left take 20 s
    assert "ETA 0m20s" in _bar_text(display, 0, "s3")
    display.close()
    text = log.getvalue()
    assert "s3 run 0: resuming, replaying to its last commit point" in text
    assert "s3 run 0: replay reached its last commit point (40 births); continuing" in text


def test_labels_keep_several_experiments_apart(log: io.StringIO) -> None:
    display = ProgressDisplay(stream=io.StringIO(), tty=True)
    display.add_runs({0: 50}, label="scenario1")
    display.add_runs({0: 50}, label="baseline_a")
    display.feed("baseline_a")(_event(0, 20, target=50))
    display(_event(0, 10, target=50), label="scenario1")
    assert "10/50" in _bar_text(display, 0, "scenario1")
    assert "20/50" in _bar_text(display, 0, "baseline_a")
    assert str(display.bars[2]).startswith("baseline_a run 0")
    display.close()


def test_off_a_terminal_plain_lines_every_step_or_interval(log: io.StringIO) -> None:
    clock = Clock()
    display = ProgressDisplay({0: 100, 1: 100}, tty=False, interval=30.0, step=25.0, clock=clock)
    assert not display.bars
    for births, now in ((5, 1.0), (10, 2.0), (30, 3.0), (35, 40.0), (40, 41.0)):
        clock.now = now
        display(_event(0, births, best=NAN if births == 5 else 2.5))
    clock.now = 50.0
    display(_event(0, 100, finished=True, failures=(("blow-up", 2), ("learner", 1))))
    display.close()
    lines = log.getvalue().splitlines()
    progress = [line for line in lines if "/100 births (" in line]
    # 5: first line; 10: same 25 % and within 30 s; 30: a new quarter; 35: 30 s passed; 40: no.
    assert [line.split(":")[1].split()[0] for line in progress] == ["5/100", "30/100", "35/100"]
    assert "no robot evaluated yet" in progress[0] and "ETA" not in progress[0]
    assert "all runs: 5/200 births (2%), 0/2 runs finished" in progress[0]
    assert "best 2.500 m, mean 1.250 m, 15 alive, sim 40.0x, ETA" in progress[1]
    assert lines[0] == "run 0: running (first commit point at 5 births)"
    assert lines[-1].startswith("run 0: finished, 100 births, best 2.500 m, mean 1.250 m")
    assert "failures: 2 blow-up, 1 learner; all runs: 100/200 births" in lines[-1]
    assert "\r" not in log.getvalue()


def test_quiet_shows_nothing_but_warnings_and_errors() -> None:
    stream, bars = io.StringIO(), io.StringIO()
    with cli_logging(-1, stream):
        display = ProgressDisplay({0: 100}, stream=bars, tty=True)
        display(_event(0, 50))
        display(_event(0, 100, finished=True))
        display.close()
        logging.getLogger("evolution.experiments.loop.online").warning("cannot write the snapshot")
        logging.getLogger("evolution.cli.progress").info("not shown")
    assert bars.getvalue() == "" and not display.bars
    assert stream.getvalue() == "warning: cannot write the snapshot\n"


def test_verbose_shows_every_event_and_new_failures_at_debug() -> None:
    stream = io.StringIO()
    with cli_logging(1, stream):
        display = ProgressDisplay({0: 100}, tty=False)
        display(_event(0, 10))
        display(_event(0, 20, failures=(("blow-up", 1),)))
        display.close()
    text = stream.getvalue()
    assert "debug: evolution.cli.progress: run 0: 10/100 births, best 2.500 m" in text
    assert "debug: evolution.cli.progress: run 0: new failures at 20 births: 1 blow-up" in text


def test_logging_is_given_back_after_the_command() -> None:
    root, ours = logging.getLogger(), logging.getLogger("evolution")
    before = (list(root.handlers), root.level, ours.level)
    with cli_logging(1):
        display = ProgressDisplay({0: 10}, stream=io.StringIO(), tty=True)
        display(_event(0, 5, target=10))
        assert ours.level == logging.DEBUG and root.level == logging.WARNING
        # an error leaves the display open: its redirection of the handlers is undone too
    assert (list(root.handlers), root.level, ours.level) == before
    display.bars.clear()


@pytest.fixture
def fake_physics(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(api, "make_evaluator",
                        lambda *a, **k: LocalEvaluator(workers=1, function=fake_evaluate))


SMALL = ["--runs", "1", "--births", "18", "--set", "population_size=6", "--set", "offspring_size=6",
         "--set", "evolution.initial_parts_mean=5", "--set", "evolution.initial_parts_sd=2",
         "--set", "evolution.max_parts=12"]


@pytest.mark.parametrize("flag, shown", [("--quiet", False), ("-v", True)])
def test_the_cli_flags(flag: str, shown: bool, fake_physics: None, tmp_path: Path,
                       capsys: pytest.CaptureFixture[str]) -> None:
    assert main([flag, "run", "scenario1", "--out", str(tmp_path), *SMALL]) == 0
    captured = capsys.readouterr()
    assert "run 0: finished, 18 births" in captured.out  # the command's own result
    if shown:
        assert "debug: evolution.cli.progress: scenario1 run 0: 6/18 births" in captured.err
        assert "scenario1 run 0: finished, 18 births" in captured.err
    else:
        assert captured.err == ""


def test_run_then_resume_write_tensorboard_scalars(fake_physics: None, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("tensorboard")
    pytest.importorskip("torch")
    tb = tmp_path / "tb"
    assert main(["-q", "run", "scenario1", "--out", str(tmp_path / "out"), "--tensorboard",
                 str(tb), *SMALL]) == 0
    assert main(["resume", str(tmp_path / "out"), "--tensorboard", str(tb)]) == 0
    assert list((tb / "scenario1" / "run0").glob("events.out.tfevents.*"))
    assert "nothing to resume" in capsys.readouterr().out


def test_a_missing_tensorboard_is_one_line_before_anything_runs(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "torch.utils.tensorboard", None)
    out = tmp_path / "out"
    assert main(["run", "quick", "--out", str(out), "--tensorboard", str(tmp_path / "tb")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].endswith('pip install "revolve-env[tensorboard]"')
    assert not out.exists()


def test_the_eta_weighs_births_by_their_cost(log: io.StringIO) -> None:
    """Two workers: an online run (a birth costs 8 offline ones) beside an offline run, a second
    online run waiting. In 10 s the online run makes 10 births, the offline one 80 and ends."""
    clock = Clock()
    display = ProgressDisplay(stream=io.StringIO(), tty=False, clock=clock)
    display.add_runs({0: 100, 1: 100}, label="scenario3", weight=8.0)
    display.add_runs({0: 80}, label="scenario1", weight=1.0)
    display(_event(0, 0), label="scenario3")
    display(_event(0, 0, target=80), label="scenario1")
    clock.now = 10.0
    display(_event(0, 10), label="scenario3")
    display(_event(0, 80, target=80, finished=True), label="scenario1")
    # Work done: 10 x 8 + 80 = 160 in 10 s; left: (90 + 100) x 8 = 1520, 95 s at 16 per second.
    # (Births alike: 90 in 10 s, 190 left, 21 s: the runs left are online.)
    assert display.eta() == pytest.approx(95.0)
    assert "ETA 1m35s" in display.summary()
    with pytest.raises(ValueError, match="weight must be a positive number"):
        display.add_runs({2: 10}, label="scenario2", weight=0.0)
    display.close()


def test_the_eta_is_never_shorter_than_the_slowest_running_run(log: io.StringIO) -> None:
    """One online run beside one offline run: the offline run's worker cannot help the online
    run, which needs 90 s at its own rate (the pooled rate would say 2.5 s)."""
    clock = Clock()
    display = ProgressDisplay(stream=io.StringIO(), tty=False, clock=clock)
    display.add_runs({0: 100}, label="scenario3", weight=8.0)
    display.add_runs({0: 100}, label="scenario1")
    display(_event(0, 0), label="scenario3")
    display(_event(0, 0), label="scenario1")
    clock.now = 10.0
    display(_event(0, 10), label="scenario3")
    display(_event(0, 80), label="scenario1")
    assert display.eta() == pytest.approx(90.0)
    display.close()
