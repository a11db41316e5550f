"""Issue 28's aims summary (benchmarks/aims.py, bench_engines.whole_runs): every aim printed with
its figure, the aim and the verdict, or "not measured in this run"; the whole-run figures taken
from bench_experiments' measured runs or from given ones. Figures are injected: nothing is timed.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

import aims  # noqa: E402
import bench_engines  # noqa: E402
import bench_experiments  # noqa: E402
from aims import ISSUE_28, Aim, Figure, parse_given_run, summary, verdict  # noqa: E402

from evolution.experiments.loop.run import ProgressEvent  # noqa: E402

AT_MOST = Aim("a", "a ratio", 1.25, True, "x", "somewhere")
AT_LEAST = Aim("b", "a speed-up", 4.0, False, "x", "somewhere")


def test_the_verdict_says_met_or_by_how_much_the_aim_is_missed() -> None:
    assert verdict(AT_MOST, 1.25) == "met" and verdict(AT_MOST, 0.5) == "met"
    assert verdict(AT_MOST, 2.5) == "missed by 2.00x"
    assert verdict(AT_LEAST, 4.0) == "met" and verdict(AT_LEAST, 2.0) == "missed by 2.00x"
    assert verdict(AT_LEAST, 0.0) == "missed by infx"
    assert verdict(AT_MOST, math.nan) == "no figure (NaN)"
    memory = next(a for a in ISSUE_28 if a.key == "memory")
    assert verdict(memory, -2.4) == "met" and verdict(memory, 34.0) == "missed by 1.70x"


def test_every_aim_of_the_issue_is_printed_measured_or_not() -> None:
    lines = summary({"evaluate": Figure(1.07), "pybullet": Figure(5.05, "spider"),
                     "study": Figure(22.6, "projected from runs of 609 births")},
                    {"like for like": (Figure(0.98), AT_MOST)})
    assert lines[0].startswith("issue 28's aims")
    assert len(lines) == 1 + len(ISSUE_28) + 1
    assert lines[1] == ("  evaluate() of one spider / raw mj_step: 1.07x (aim <= 1.15x): met")
    assert "  MuJoCo over pybullet, evaluate() of one spider: 5.05x (aim >= 4.00x): met; spider" \
        in lines
    study = next(line for line in lines if "the paper's study" in line)
    assert study.endswith("22.6 h (aim <= 7.0 h): missed by 3.23x; projected from runs of 609 "
                          "births")
    scenario1 = next(line for line in lines if "scenario 1" in line)
    assert scenario1.endswith("not measured in this run (aim <= 1.25x; bench_engines "
                              "--whole-runs BIRTHS or --given-run (bench_experiments.py))")
    assert sum("not measured in this run" in line for line in lines) == len(ISSUE_28) - 3
    assert lines[-1] == "  like for like: 0.98x (aim <= 1.25x): met"
    with pytest.raises(KeyError, match="no aim of issue 28: nonsense"):
        summary({"nonsense": Figure(1.0)})


def test_a_given_run_is_read_from_one_argument() -> None:
    run = parse_given_run("scenario3=1315@609,floor=627,memory=5.9,alive=9.3")
    assert (run.name, run.cpu_ms, run.births, run.floor_ms, run.memory_kb, run.alive) == (
        "scenario3", 1315.0, 609, 627.0, 5.9, 9.3)
    assert parse_given_run("scenario1=116@1000") == aims.GivenRun("scenario1", 116.0, 1000)
    for bad in ("scenario1", "scenario1=116", "=116@10", "scenario1=x@10", "scenario1=116@10,",
                "scenario1=116@10,speed=3", "scenario1=116@10,floor=1,floor=2",
                "scenario1=-1@10", "scenario1=116@0", "scenario1=116@10,floor=0"):
        with pytest.raises(ValueError, match="--given-run"):
            parse_given_run(bad)


def _event(births: int, sim_time: float, alive: int) -> ProgressEvent:
    return ProgressEvent(0, births, 1000, sim_time, 1.0, 0.5, alive, 1.0, 1.0)


def _measured(name: str, births: int, *args: Any, **kwargs: Any
              ) -> bench_experiments.RunMeasurement:
    config = bench_experiments.preset(name, births=births, runs=1)
    # commit points every 100 births; RSS 100 MB, then 10 KB more per birth from birth 300
    events = tuple(_event(b, 15.0 * b, 10) for b in range(100, births + 1, 100))
    rss = tuple(100.0 + 0.01 * max(0, e.births - 300) for e in events)
    floor = bench_experiments.Floor(15.0 * births, 150.0, "given")  # 0.1 s per birth
    return bench_experiments.RunMeasurement(name, config, 60.0, 0.125 * births, events, rss,
                                            False, floor)


def test_whole_runs_fill_the_aims_from_measured_and_given_runs(
        monkeypatch: pytest.MonkeyPatch) -> None:
    figures: dict[str, Figure] = {}
    monkeypatch.setattr(bench_engines, "FIGURES", figures)
    measured: list[str] = []
    projected: list[dict[str, tuple[Any, float, float]]] = []

    def measure(name: str, births: int, *args: Any, **kwargs: Any
                ) -> bench_experiments.RunMeasurement:
        measured.append(name)
        return _measured(name, births)

    def project(runs: dict[str, tuple[Any, float, float]]) -> dict[int, float]:
        projected.append(runs)
        return {2: 10.5, 64: 1.0}

    monkeypatch.setattr(bench_experiments, "measure_run", measure)
    monkeypatch.setattr(bench_experiments, "project", project)
    given = [parse_given_run("scenario1=116@1000,floor=108")]
    bench_engines.whole_runs(600, 12, given)
    assert measured == ["scenario3"]  # scenario 1 was given
    assert figures["scenario1"] == Figure(
        116 / 108, "given: another process's run of 1000 births, 116 ms CPU per birth, floor "
        "108 ms")
    assert figures["scenario3"].value == pytest.approx(1.25)
    assert figures["scenario3"].note == ("this run: 600 births, 125 ms CPU per birth, floor "
                                         "100 ms")
    assert figures["memory"].value == pytest.approx(10.0)
    assert figures["study"] == Figure(10.5, "projected from runs of 600 births or more; the aim "
                                            "is judged on runs of >= 1000 births")
    (runs,) = projected
    assert runs["scenario1"][1] == pytest.approx(116.0) and runs["scenario3"][2] == 10.0


def test_whole_runs_leave_unmeasured_what_nothing_measured(
        monkeypatch: pytest.MonkeyPatch) -> None:
    figures: dict[str, Figure] = {}
    monkeypatch.setattr(bench_engines, "FIGURES", figures)
    monkeypatch.setattr(bench_experiments, "project", lambda runs: {})  # a mode missing
    bench_engines.whole_runs(0, 12, [parse_given_run("scenario1=116@1000")])
    assert figures == {}  # no floor given, no online run: no figure
    lines = summary(figures)
    assert sum("not measured in this run" in line for line in lines) == len(ISSUE_28)


def test_a_short_run_has_no_memory_figure_after_300_births() -> None:
    run = _measured("scenario3", 300)
    assert run.memory_growth(300) is None
    assert run.memory_line(300).endswith("fewer than two commit points after 300 births")
    longer = _measured("scenario3", 1000)
    slope, end = longer.memory_growth(300) or (math.nan, math.nan)
    assert slope == pytest.approx(10.0) and end == pytest.approx(10.0)
    assert longer.alive == 10.0 and longer.cpu_per_birth == 0.125
    assert longer.floor_line().endswith(": 1.25x")


def test_memory_growth_is_told_apart_per_birth_and_per_robot_alive() -> None:
    # RSS that follows the robots alive only (0.5 MB each), in a world that grows from 9 to 15
    events = tuple(_event(b, 15.0 * b, 9 + (b - 300) // 100) for b in range(300, 1000, 10))
    rss = tuple(100.0 + 0.5 * e.population_size for e in events)
    config = bench_experiments.preset("scenario3", births=1000, runs=1)
    run = bench_experiments.RunMeasurement("scenario3", config, 60.0, 100.0, events, rss, False,
                                           None)
    slope, _ = run.memory_growth(300) or (math.nan, math.nan)
    assert slope > 4.0  # a line through births alone sees the growing world as growth per birth
    per_birth, per_alive = run.memory_apart(300) or (math.nan, math.nan)
    assert per_birth == pytest.approx(0.0, abs=1e-6) and per_alive == pytest.approx(0.5)
    assert run.memory_line(300).endswith("robots alive apart: 0.0 KB per birth, 0.50 MB per "
                                         "robot alive")
    # a world of constant size: nothing to tell apart
    assert _measured("scenario3", 1000).memory_apart(300) is None
