"""bench_experiments' projection of the paper's study from measured runs: an online run's robots
alive grown on to the study's 3000 births as the study's estimate grows them, and the calibration
compared with a measured run over that run's births. The calibration is injected: nothing is
timed."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))

import bench_experiments  # noqa: E402

from evolution.experiments.app.estimate import BirthCost  # noqa: E402
from evolution.experiments.app.world_size import world_growth  # noqa: E402
from evolution.experiments.loop.config import ExperimentConfig  # noqa: E402


def _calibrate(config: ExperimentConfig, **_: Any) -> BirthCost:
    """9 robots at the start, 0.8 s per conception interval; offline 0.1 s per birth."""
    if config.mode == "online":
        return BirthCost("online", "mujoco", 135.0 / 0.8, 135.0, "given", 9.0,
                         growth=world_growth(config, 9.0))
    return BirthCost("offline", "mujoco", 150.0, 15.0, "given")


def test_a_measured_online_run_is_grown_to_the_studys_births(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setattr(bench_experiments, "calibrate", _calibrate)
    online = bench_experiments.preset("scenario3", births=1889, runs=1)
    offline = bench_experiments.preset("scenario1", births=1000, runs=1)
    # the 1,889-birth run: 1.778 s CPU per birth, 13.8 robots alive on average
    hours = bench_experiments.project({"scenario3": (online, 1.778 * 1889, 13.8),
                                       "scenario1": (offline, 100.0, 0.0)})
    growth = world_growth(online, 9.0)
    late = growth.mean_alive(15, 3000) / growth.mean_alive(15, 1889)  # 16.0 / 13.8
    out = capsys.readouterr().out
    assert (f"scenario3: the measured run's 13.8 robots alive grown to {13.8 * late:.1f} over "
            "3000 births, as the study's estimate grows its world") in out
    # the calibration over the measured run's births: 9 robots grown to the curve's 13.8
    row = next(line for line in out.splitlines() if line.startswith("scenario3 "))
    calibrated = 800 * growth.mean_alive(15, 1889) / 9.0
    assert row.split()[4:6] == [f"{calibrated:.0f}", "13.8"]
    # 2 cores: the 30 online runs first (15 each), 2985 conception intervals each at the
    # measured CPU per interval grown by 16.0 / 13.8; then the 120 offline runs, 0.1 s x 3000
    online_run = 2985 * 1.778 * 1889 / 1874 * late
    assert hours[2] * 3600 == pytest.approx(15 * online_run + 60 * 300.0)


def test_a_deadline_already_past_today_is_tomorrows() -> None:
    ahead = bench_experiments.time.gmtime(bench_experiments.time.time() + 3600)
    past = bench_experiments.time.gmtime(bench_experiments.time.time() - 3600)
    later = bench_experiments._next_utc(f"{ahead.tm_hour:02d}:{ahead.tm_min:02d}")
    earlier = bench_experiments._next_utc(f"{past.tm_hour:02d}:{past.tm_min:02d}")
    start = bench_experiments.time.time()
    assert 0 < later - start <= 3600  # within the hour ahead (today's, or tomorrow's after 23:00)
    assert 22 * 3600 < earlier - start <= 23 * 3600  # an hour ago today: tomorrow's
