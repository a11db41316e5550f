"""The optimism analysis: hand-made reevaluations against a hand computation, the bootstrap
interval, and the report's optimism files (on the fast stand-ins of ``experiment_fakes``)."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from experiment_fakes import fake_evaluate, small

from evolution.evaluation import LocalEvaluator
from evolution.experiments import preset, run
from evolution.experiments.app.reevaluate import reevaluate
from evolution.experiments.store.database import ReevaluationRecord
from evolution.reporting import report
from evolution.reporting.optimism import OPTIMISM_COLUMNS, bootstrap_ci, optimism_rows

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)
CONDITIONS = json.dumps({"heading": "random", "position_jitter": 0.0, "sensor_noise": 0.0,
                         "actuator_noise": 0.0}, sort_keys=True)

# run -> robot -> (stored fitness, reevaluated fitness of each repeat; None: a blow-up)
HAND: dict[int, dict[int, tuple[float, list[float | None]]]] = {
    0: {0: (3.0, [2.0, 3.0]), 1: (2.0, [0.5, 0.5]), 2: (1.0, [1.0, None])},
    1: {3: (1.0, [1.0, 1.0]), 4: (2.0, [3.0, 3.0]), 5: (4.0, [2.0, 2.0])},
}


def _records(hand: dict[int, dict[int, tuple[float, list[float | None]]]]
             ) -> list[ReevaluationRecord]:
    return [ReevaluationRecord(run_id, robot_id, "final", k, CONDITIONS, 3.0, 12.0, False,
                               100 * robot_id + k, "inborn", stored, value,
                               failure=None if value is not None else "blow-up: fast")
            for run_id, robots in hand.items()
            for robot_id, (stored, values) in robots.items()
            for k, value in enumerate(values)]


def test_numbers_equal_a_hand_computation() -> None:
    (row,) = optimism_rows([("hand", _records(HAND))])
    # Run 0: reevaluated means 2.5, 0.5, 1.0 (the blow-up left out); optimism 0.5, 1.5, 0.
    # Run 1: reevaluated means 1, 3, 2; optimism 0, -1, 2.
    run_optimism = [(0.5 + 1.5 + 0.0) / 3, (0.0 - 1.0 + 2.0) / 3]
    run_stored = [2.0, 7.0 / 3]
    run_again = [4.0 / 3, 2.0]
    assert (row.runs, row.robots, row.k, row.failures) == (2, 6, 2, 1)
    assert row.optimism == pytest.approx(np.mean(run_optimism))
    assert row.stored_mean == pytest.approx(np.mean(run_stored))
    assert row.reevaluated_mean == pytest.approx(np.mean(run_again))
    assert row.optimism_percent == pytest.approx(100 * np.mean(run_optimism) / np.mean(run_stored))
    # Ranks, run 0: stored (3, 2, 1) vs reevaluated (3, 1, 2): rho = 1 - 6 * 2 / 24 = 0.5.
    # Run 1: stored (1, 2, 3) vs reevaluated (1, 3, 2): rho = 0.5 too.
    assert row.spearman == pytest.approx(0.5)
    # Run 0's stored best (robot 0) is still the best; run 1's (robot 5) is not.
    assert row.best_stays_best == 0.5
    assert row.setting == "final, window 3-15 s, alone, heading random"
    assert row.optimism_low <= row.optimism <= row.optimism_high
    assert row.optimism_low == pytest.approx(min(run_optimism))
    assert row.optimism_high == pytest.approx(max(run_optimism))


def test_bootstrap_interval() -> None:
    rng = np.random.default_rng(1)
    values = rng.normal(2.0, 1.0, 30)
    low, high = bootstrap_ci(values)
    assert low < values.mean() < high
    assert high - low == pytest.approx(2 * 1.96 * values.std(ddof=1) / math.sqrt(30), rel=0.25)
    assert bootstrap_ci(values) == (low, high)  # seeded: the same data, the same interval
    assert all(math.isnan(v) for v in bootstrap_ci(np.array([1.0])))


def test_settings_are_rows_of_their_own() -> None:
    records = _records(HAND)
    later = [ReevaluationRecord(r.run_id, r.robot_id, r.kind, r.repeat, r.conditions, 6.0,
                                r.seconds, True, r.seed, r.controller, r.stored_fitness,
                                r.fitness, failure=r.failure) for r in records]
    rows = optimism_rows([("hand", records + later), ("none", [])])
    assert [r.setting for r in rows] == ["final, window 3-15 s, alone, heading random",
                                         "final, window 6-18 s, shared world, heading random"]
    assert rows[0].optimism == rows[1].optimism


def test_report_includes_the_optimism_table_and_figure(tmp_path: Path) -> None:
    config = small(preset("scenario1", births=24, runs=2, diversity_interval=8))
    run(config, tmp_path / "scenario1", evaluator=SERIAL)
    plain = report(tmp_path, tmp_path / "before", formats=("png",))
    assert not any("optimism" in p.name for p in (*plain.figures, *plain.tables))
    assert "Optimism" not in (tmp_path / "before" / "summary.md").read_text()

    reevaluate(tmp_path, k=3, evaluator=SERIAL)
    written = report(tmp_path, tmp_path / "after", formats=("png",))
    out = tmp_path / "after"
    assert out / "optimism.png" in written.figures and out / "optimism.csv" in written.tables
    with open(out / "optimism.csv", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert tuple(rows[0]) == OPTIMISM_COLUMNS and len(rows) == 1
    assert rows[0]["experiment"] == "Scenario 1 (15+15)" and rows[0]["runs"] == "2"
    assert rows[0]["k"] == "3"
    summary = (out / "summary.md").read_text()
    assert "## Optimism of a single evaluation" in summary
    assert "| Scenario 1 (15+15) | final, window 3-15 s, alone, heading random |" in summary
