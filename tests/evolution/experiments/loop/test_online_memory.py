"""A long online run holds the records of its living robots only (issue 28, item 4).

After many births and deaths in a small world, at every commit point the loop, the store and the
world together hold one loop member and one lifecycle per living robot, and no per-birth record
(fitness samples, failures, robot records, statuses) of earlier commit points: what a run keeps
grows with the robots alive, never with the births.
"""

from __future__ import annotations

import gc
from collections import Counter
from pathlib import Path

from evolution import experiments
from evolution.experiments import ProgressEvent, preset
from evolution.experiments.loop.records import FailureRecord, FitnessSample, RobotRecord
from evolution.experiments.loop.run import Member
from evolution.lifecycle import Lifecycle
from revolve_env.status import RobotStatus

_KINDS = (Member, Lifecycle, FitnessSample, FailureRecord, RobotRecord, RobotStatus)


def _held() -> Counter[str]:
    """Live objects of the per-robot and per-birth kinds, by kind."""
    gc.collect()
    return Counter(type(o).__name__ for o in gc.get_objects() if type(o) in _KINDS)


def test_after_many_births_and_deaths_a_run_holds_only_its_living_robots(
        tmp_path: Path) -> None:
    # A conception every 0.5 s of 2-4 robots: 40 births, most of them dead by the end.
    config = preset("scenario3", births=40, population_size=3, min_alive=2, max_alive=4,
                    conception_interval=0.5, insertion=0.25, evaluation_time=0.25,
                    fertile_age=0.5, diversity_interval=0, workers=1, runs=1, seed=1)
    seen: list[tuple[int, int, Counter[str]]] = []

    def progress(event: ProgressEvent) -> None:
        if event.births >= 10 and not event.finished:
            seen.append((event.births, event.population_size, _held()))

    experiments.run(config, tmp_path / "run", progress)
    assert seen and seen[-1][0] >= 35 and seen[-1][0] - seen[-1][1] >= 30  # most died
    for births, alive, held in seen:
        # one member and one lifecycle per living robot (the loop's and the world's statuses
        # of the living: at most two each); no record of a closed commit point
        assert held["Member"] == alive and held["Lifecycle"] == alive, (births, alive, held)
        assert held["RobotStatus"] <= 2 * alive, (births, alive, held)
        for kind in ("FitnessSample", "FailureRecord", "RobotRecord"):
            assert held[kind] <= alive + 2, (births, alive, held)
