"""The study's time estimate: the robot-seconds each experiment simulates (offline: births x
evaluated seconds; online: robots alive measured x simulated time) over the measured robot-seconds
per CPU second; runs scheduled as the study runs them (one run per worker, online first); the
CPU left of resumed runs; and a calibration that measures the real physics."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import pytest

from evolution.evaluation import EvalOutcome, EvalTask
from evolution.experiments.app import estimate as estimate_module
from evolution.experiments.app.estimate import (
    BirthCost,
    RunWork,
    calibrate,
    calibrate_all,
    estimate,
    online_rate,
    run_cpu_seconds,
    run_robot_seconds,
)
from evolution.experiments.app.world_size import WorldGrowth, rule_bounds
from evolution.experiments.loop.config import ExperimentConfig, load_config
from evolution.experiments.loop.run import ProgressEvent

# 15 robot-s per birth at 15 robot-s per CPU-s: 1 s per birth; online 10 robots alive x 15 s,
# 150 robot-s per birth at 18.75 robot-s per CPU-s: 8 s per birth.
OFFLINE = BirthCost("offline", "mujoco", 15.0, 15.0, "given")
ONLINE = BirthCost("online", "mujoco", 18.75, 150.0, "given", 10.0)


def _configs(births: int = 115) -> tuple[RunWork, RunWork]:
    online = load_config("scenario3", {"births": births})  # 15 initial robots
    offline = load_config("scenario1", {"births": births - 15})
    return RunWork("scenario3", online), RunWork("scenario1", offline)


def test_offline_runs_simulate_one_evaluation_per_birth() -> None:
    _, offline = _configs()
    assert run_robot_seconds(offline, OFFLINE) == 100 * 15.0
    assert run_cpu_seconds(offline, OFFLINE) == 100 * 15.0 / 15.0
    assert run_robot_seconds(RunWork("scenario1", offline.config, done=60), OFFLINE) == 40 * 15.0
    assert run_cpu_seconds(RunWork("scenario1", offline.config, done=100), OFFLINE) == 0.0


def test_online_runs_simulate_the_robots_alive_for_a_conception_interval_per_birth() -> None:
    online, _ = _configs()
    # after the 15 initial robots, born together at time 0: 100 intervals of 10 robots x 15 s
    assert run_robot_seconds(online, ONLINE) == 100 * 10 * 15.0
    assert run_cpu_seconds(online, ONLINE) == 100 * 8.0
    assert run_cpu_seconds(RunWork("scenario3", online.config, done=50), ONLINE) == 65 * 8.0
    assert run_cpu_seconds(RunWork("scenario3", online.config, done=5), ONLINE) == 100 * 8.0
    assert ONLINE.cpu_per_birth == 8.0 and OFFLINE.cpu_per_birth == 1.0


def test_an_online_world_that_grows_simulates_its_mean_robots_alive() -> None:
    online, _ = _configs(births=315)  # 300 conception intervals after the 15 initial robots
    growth = WorldGrowth(10.0, 20.0, onset=115.0, scale=50.0)
    cost = replace(ONLINE, growth=growth)
    mean = growth.mean_alive(15, 315)
    assert 10.0 < mean < 20.0
    assert run_robot_seconds(online, cost) == pytest.approx(300 * 15.0 * mean)
    assert run_cpu_seconds(online, cost) == pytest.approx(300 * 15.0 * mean / 18.75)
    # resumed at 215 births: its last 100 intervals, in the grown world
    resumed = RunWork("scenario3", online.config, done=215)
    assert run_robot_seconds(resumed, cost) == pytest.approx(
        100 * 15.0 * growth.mean_alive(215, 315))
    # a run that ends before the onset: the world measured at the start throughout
    assert run_robot_seconds(_configs(births=115)[0], cost) == 100 * 10 * 15.0
    study = estimate([online] * 2, {"scenario3": cost}, workers=1)
    (experiment,) = study.experiments
    assert experiment.alive == pytest.approx(mean)
    assert experiment.cpu_per_birth == pytest.approx(8.0 * mean / 10.0)
    assert study.weights() == {"scenario3": experiment.cpu_per_birth}
    line = study.lines()[0]
    assert (f"(online, mujoco: {mean:.1f} robots alive on average (10.0 measured at its start, "
            "growing after 115 births toward the survivor rule's 20.0 as a measured run's grew) x "
            f"15 s per birth) at 19 robot-s per CPU-s (from given), "
            f"{1e3 * experiment.cpu_per_birth:.0f} ms CPU per birth: ") in line
    # a study of short runs: its worlds never grow, and the line says so
    short = estimate([_configs(births=100)[0]], {"scenario3": cost}, workers=1).lines()[0]
    assert ("(online, mujoco: 10.0 robots alive (measured at its start; its world grows after "
            "115 births, past this study's) x 15 s per birth)") in short
    assert "8000 ms CPU per birth" in short
    # a world measured at the rule's ceiling cannot grow; a finished run has no interval left
    full = replace(ONLINE, growth=WorldGrowth(10.0, 9.5, onset=0.0, scale=50.0))
    assert ("(online, mujoco: 10.0 robots alive (measured at its start, at or above the survivor "
            "rule's ceiling of 9.5) x 15 s per birth)") in estimate(
                [online], {"scenario3": full}, workers=1).lines()[0]
    done = RunWork("scenario3", online.config, done=315)
    assert ("(online, mujoco: 10.0 robots alive (measured at its start) x 15 s per birth)"
            in estimate([done], {"scenario3": cost}, workers=1).lines()[0])


def _event(births: int, sim_time: float, alive: int) -> ProgressEvent:
    return ProgressEvent(0, births, 100, sim_time, 1.0, 0.5, alive, 1.0, 1.0)


def test_the_online_rate_weighs_each_interval_by_its_robots_alive() -> None:
    # Commit points: 15 initial robots at 0 s; then intervals of 15 s with 9, 9 and 12 alive
    # (the first, 15 robots, is skipped: no selection yet), CPU 2, 2 and 4 s.
    events = [_event(15, 0.0, 15), _event(16, 15.0, 9), _event(17, 30.0, 9),
              _event(18, 45.0, 12), _event(19, 60.0, 10)]
    cpu = [0.0, 10.0, 12.0, 14.0, 18.0]
    alive, rate, robot_seconds = online_rate(events, cpu)
    assert robot_seconds == (9 + 9 + 12) * 15.0
    assert alive == pytest.approx(10.0) and rate == pytest.approx(450.0 / 8.0)
    assert online_rate(events, cpu, skip=0)[0] == pytest.approx((15 + 9 + 9 + 12) / 4)
    with pytest.raises(ValueError, match="no simulated or CPU time"):
        online_rate(events[:2], cpu[:2])


def test_runs_are_scheduled_one_per_worker_online_first() -> None:
    online, offline = _configs()
    work = [offline] * 8 + [online] * 2  # given offline first: the study starts online runs first
    costs = {"scenario3": ONLINE, "scenario1": OFFLINE}
    # 3 workers: two online runs of 800 s on two of them, the eight offline runs on the third.
    three = estimate(work, costs, workers=3)
    assert three.wall_seconds == 800.0 and three.cpu_seconds == 2 * 800 + 8 * 100
    # 2 workers: 800 s of online each, then four offline runs each.
    two = estimate(work, costs, workers=2)
    assert two.wall_seconds == 1200.0
    # Each experiment's projected hours: when its last run ends (the online runs first).
    assert [(e.name, e.wall_seconds) for e in two.experiments] == [
        ("scenario1", 1200.0), ("scenario3", 800.0)]
    assert [e.wall_seconds for e in three.experiments] == [800.0, 800.0]
    # A finished run takes no worker: the others start at once.
    done = RunWork("scenario3", online.config, done=online.config.births)
    late = estimate([done, done, offline], costs, workers=1)
    assert [(e.name, e.wall_seconds) for e in late.experiments] == [
        ("scenario3", 0.0), ("scenario1", 100.0)]
    # Offline first would have been 1200 s on 3 workers: the order is the study's.
    assert estimate(work, costs, workers=64).wall_seconds == 800.0
    assert [(e.name, e.runs, e.births, e.robot_seconds) for e in three.experiments] == [
        ("scenario1", 8, 800, 8 * 100 * 15.0), ("scenario3", 2, 230, 2 * 100 * 150.0)]
    assert three.weights() == {"scenario1": 1.0, "scenario3": 8.0}
    lines = three.lines()
    assert lines[0] == ("  scenario1: 8 run(s), 800 births, 1.2e+04 robot-s (3.33 robot-h) "
                        "(offline, mujoco: 15 s per birth) at 15 robot-s per CPU-s (from given), "
                        "1000 ms CPU per birth: 0.22 CPU-h, its last run done after 13 min "
                        "(0.22 h)")
    assert lines[1] == ("  scenario3: 2 run(s), 230 births, 3e+04 robot-s (8.33 robot-h) "
                        "(online, mujoco: 10.0 robots alive x 15 s per birth) at 19 robot-s per "
                        "CPU-s (from given), 8000 ms CPU per birth: 0.44 CPU-h, its last run "
                        "done after 13 min (0.22 h)")
    assert lines[2].startswith("  total 4.2e+04 robot-s (11.7 robot-h), 0.67 CPU-h: about "
                               "13 min on 3 worker(s)")
    assert lines[3].startswith("  (an estimate: it assumes a run's later robots cost per "
                               "simulated second what its first generations cost")


def test_experiments_of_equal_settings_share_one_calibration(
        monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[str] = []

    def fake(config: ExperimentConfig, *, seed: int = 0) -> BirthCost:
        calls.append(config.name)
        return OFFLINE

    monkeypatch.setattr(estimate_module, "calibrate", fake)
    copy = load_config("scenario1", {"name": "copy"})
    configs = [load_config(n) for n in ("scenario1", "scenario2", "baseline_a", "baseline_b",
                                        "scenario3")] + [copy]
    costs, cpu = calibrate_all(configs)
    # The calibration runs each experiment's own start: its reproduction (scenario 2's one
    # child per generation, the baselines' random robots or survivors) is its own; a copy
    # under another name is not.
    assert calls == ["scenario1", "scenario2", "baseline_a", "baseline_b", "scenario3"]
    assert costs["copy"] is costs["scenario1"] and cpu >= 0


class _Evaluations:
    """An evaluator with no physics on a clock of its own: 0.1 s per task, 0.002 s per read."""

    def __init__(self) -> None:
        self.now = 0.0
        self.robots: list[int] = []

    @property
    def workers(self) -> int:
        return 1

    def clock(self) -> float:
        self.now += 0.002
        return self.now

    def evaluate(self, tasks: Sequence[EvalTask]) -> list[EvalOutcome]:
        self.now += 0.1 * len(tasks)
        self.robots += [t.robot_id for t in tasks]
        return [EvalOutcome(float(t.robot_id % 7) / 7, 0.0, 0.0) for t in tasks]

    def run_jobs(self, *args: Any, **kwargs: Any) -> list[Any]:
        raise AssertionError("the calibration runs no jobs")

    def close(self) -> None:
        pass


@pytest.mark.parametrize("offspring", [4, 3, 1])
def test_the_offline_calibration_times_the_runs_own_births_reproduction_included(
        offspring: int) -> None:
    config = load_config("scenario1", {**TINY, "offspring_size": offspring})
    fake = _Evaluations()
    cost = calibrate(config, robots=8, evaluator=fake, clock=fake.clock)
    generations = -(-8 // offspring)  # whole generations, at least 8 children
    children = generations * offspring
    # Generation 0 (robots 0-3) is not simulated: only the warm-up evaluates its first robot;
    # then the children the run's reproduction conceived, in order.
    assert fake.robots == [0, *range(4, 4 + children)]
    assert cost.sample == f"{children} children of the run's first generations x 1.5 s"
    # Per generation: 0.1 s per child evaluated, and 4 clock reads around ask, evaluate, tell.
    evaluation = children * 0.1 + generations * 0.002
    other = generations * 0.004
    assert cost.reproduction == pytest.approx(other / children)
    assert cost.rate == pytest.approx(children * 1.5 / (evaluation + other))
    assert cost.cpu_per_birth == pytest.approx((evaluation + other) / children)
    assert (cost.mode, cost.robot_seconds, cost.alive) == ("offline", 1.5, 0.0)


def test_the_offline_calibration_ignores_the_runs_own_limits() -> None:
    # A run that would stop after its generation 0 (its births or its simulated time) still
    # has its children measured: the calibration is of a birth, not of the run.
    config = load_config("scenario1", {**TINY, "births": 4, "max_sim_time": 1.0})
    fake = _Evaluations()
    cost = calibrate(config, robots=4, evaluator=fake, clock=fake.clock)
    assert cost.sample.startswith("4 children") and math.isfinite(cost.cpu_per_birth)


def test_the_estimate_says_what_a_birth_spends_outside_its_evaluation() -> None:
    online, offline = _configs()
    cost = BirthCost("offline", "mujoco", 15.0, 15.0, "30 children", reproduction=0.25)
    (line, *_) = estimate([offline], {"scenario1": cost}, workers=1).lines()
    assert "(from 30 children, 250 ms of each birth its reproduction and selection)" in line


TINY = {"world": {"engine": "mujoco"}, "insertion": 0.5, "evaluation_time": 1.0,
        "fertile_age": 1.0, "conception_interval": 1.0, "population_size": 4, "min_alive": 2,
        "offspring_size": 2,
        "evolution": {"max_parts": 8, "initial_parts_mean": 5.0, "initial_parts_sd": 1.0}}


def test_calibration_measures_the_physics() -> None:
    offline = calibrate(load_config("scenario1", TINY), robots=2)
    assert (offline.mode, offline.engine, offline.alive) == ("offline", "mujoco", 0.0)
    assert offline.sample == "2 children of the run's first generations x 1.5 s"
    assert offline.robot_seconds == 1.5 and offline.reproduction > 0
    assert math.isfinite(offline.rate) and offline.rate > 0
    online = calibrate(load_config("scenario3", TINY), intervals=2)
    # the run's own start: its robots alive after its first selection, not an assumed number
    assert online.mode == "online" and 2 <= online.alive <= 30
    assert online.robot_seconds == pytest.approx(online.alive * 1.0)
    assert online.sample.endswith("2 conception interval(s) after its first")
    # the world grows from the robots measured toward the ceiling of the survivor rule
    assert online.growth is not None and online.growth.start == online.alive
    assert online.growth.ceiling == rule_bounds(load_config("scenario3", TINY))[1]
    assert math.isfinite(online.rate) and online.rate > 0
