"""The study's time estimate: runs scheduled as the study runs them (one run per worker, online
first), the CPU left of resumed runs, and a calibration that measures the real physics."""

from __future__ import annotations

import math

import pytest

from evolution.experiments import estimate as estimate_module
from evolution.experiments.config import ExperimentConfig, load_config
from evolution.experiments.estimate import (
    BirthCost,
    RunWork,
    calibrate,
    calibrate_all,
    estimate,
    run_cpu_seconds,
    typical_world_size,
)

OFFLINE = BirthCost("offline", "mujoco", 1.0, "given")
ONLINE = BirthCost("online", "mujoco", 8.0, "given", 19)


def _configs(births: int = 115) -> tuple[RunWork, RunWork]:
    online = load_config("scenario3", {"births": births})  # 15 initial robots
    offline = load_config("scenario1", {"births": births - 15})
    return RunWork("scenario3", online), RunWork("scenario1", offline)


def test_online_runs_pay_one_conception_interval_per_birth_after_the_initial_robots() -> None:
    online, offline = _configs()
    assert run_cpu_seconds(online, ONLINE) == 100 * 8.0
    assert run_cpu_seconds(RunWork("scenario3", online.config, done=50), ONLINE) == 65 * 8.0
    assert run_cpu_seconds(RunWork("scenario3", online.config, done=5), ONLINE) == 100 * 8.0
    assert run_cpu_seconds(offline, OFFLINE) == 100 * 1.0
    assert run_cpu_seconds(RunWork("scenario1", offline.config, done=100), OFFLINE) == 0.0


def test_runs_are_scheduled_one_per_worker_online_first() -> None:
    online, offline = _configs()
    work = [offline] * 8 + [online] * 2  # given offline first: the study starts online runs first
    costs = {"scenario3": ONLINE, "scenario1": OFFLINE}
    # 3 workers: two online runs of 800 s on two of them, the eight offline runs on the third.
    three = estimate(work, costs, workers=3)
    assert three.wall_seconds == 800.0 and three.cpu_seconds == 2 * 800 + 8 * 100
    # 2 workers: 800 s of online each, then four offline runs each.
    assert estimate(work, costs, workers=2).wall_seconds == 1200.0
    # Offline first would have been 1200 s on 3 workers: the order is the study's.
    assert estimate(work, costs, workers=64).wall_seconds == 800.0
    assert [(e.name, e.runs, e.births) for e in three.experiments] == [
        ("scenario1", 8, 800), ("scenario3", 2, 230)]
    assert three.weights() == {"scenario1": 1.0, "scenario3": 8.0}
    lines = three.lines()
    assert lines[0] == ("  scenario1: 1000 ms CPU per birth (offline, mujoco; from given), "
                        "8 run(s), 800 births: 0.22 CPU-h")
    assert "world of 19 robots" in lines[1]
    assert lines[2].startswith("  total 0.67 CPU-h: about 13 min on 3 worker(s)")
    assert lines[3].startswith("  (an estimate: it assumes evolved robots")


def test_experiments_of_equal_settings_share_one_calibration(
        monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[str] = []

    def fake(config: ExperimentConfig, *, seed: int = 0) -> BirthCost:
        calls.append(config.name)
        return OFFLINE

    monkeypatch.setattr(estimate_module, "calibrate", fake)
    configs = [load_config(n) for n in ("scenario1", "baseline_a", "baseline_b", "scenario3")]
    costs, cpu = calibrate_all(configs)
    assert calls == ["scenario1", "scenario3"]  # the baselines evaluate as scenario 1 does
    assert set(costs) == {"scenario1", "baseline_a", "baseline_b", "scenario3"} and cpu >= 0


def test_calibration_measures_the_physics() -> None:
    tiny = {"world": {"engine": "mujoco"}, "insertion": 0.5, "evaluation_time": 1.0,
            "fertile_age": 1.5,
            "evolution": {"max_parts": 8, "initial_parts_mean": 5.0, "initial_parts_sd": 1.0}}
    offline = calibrate(load_config("scenario1", tiny), robots=2)
    assert (offline.mode, offline.engine, offline.world_size) == ("offline", "mujoco", 0)
    assert offline.sample == "2 random robots x 1.5 s"
    assert math.isfinite(offline.cpu_per_birth) and offline.cpu_per_birth > 0
    config = load_config("scenario3", tiny)
    assert typical_world_size(config) == 19  # halfway between min_alive 8 and max_alive 30
    online = calibrate(config, robots=3, seconds=0.5)
    assert (online.mode, online.world_size) == ("online", 3)
    assert online.sample == "3 random robots x 0.5 s, scaled to 15 s per birth"
    assert math.isfinite(online.cpu_per_birth) and online.cpu_per_birth > 0
