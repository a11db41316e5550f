"""Like with like: every pair of experiments is compared at the most births both reached.

The experiments run on the fast physics stand-ins of ``experiment_fakes``; the expected values
are read from the stores directly (the population snapshot at those births), so the report's
own reading is checked against them.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from experiment_fakes import (
    Kill,
    fake_evaluate,
    fake_evaluate_with_losses,
    fake_world,
    kill_after,
    small,
)
from scipy.stats import mannwhitneyu

from evolution.evaluation import LocalEvaluator
from evolution.experiments import preset, run
from evolution.experiments.store.database import DB_NAME, Store
from evolution.reporting import Report, find_experiments, load_included, report
from evolution.reporting.figures import fitness_over_births
from evolution.reporting.stats import CURVE_FRACTIONS
from evolution.reporting.tables import mann_whitney_rows, write_tables

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)
LOSSY = LocalEvaluator(workers=1, function=fake_evaluate_with_losses)


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def _stored_means(db: Path, births: int) -> list[float]:
    """Each run's population mean fitness at the last snapshot at or before ``births``."""
    means = []
    with Store.open(db) as store:
        for r in store.runs():
            snapshots = [s for s in store.population_snapshots(r.run_id) if s[0] <= births]
            means.append(float(np.mean([f for _, f in snapshots[-1][2] if f is not None])))
    return means


@pytest.fixture(scope="module")
def mixed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Scenario 1 for 60 births, baseline B for 30, scenario 3 for 45: three budgets."""
    root = tmp_path_factory.mktemp("mixed")
    run(small(preset("scenario1", births=60, runs=3, diversity_interval=15)),
        root / "scenario1", evaluator=SERIAL)
    run(small(preset("baseline_b", births=30, runs=3, diversity_interval=15)),
        root / "baseline_b", evaluator=SERIAL)
    run(small(preset("scenario3", births=45, runs=3, diversity_interval=15)),
        root / "scenario3", evaluator=SERIAL, world_factory=fake_world)
    return root


@pytest.fixture(scope="module")
def mixed_report(mixed: Path) -> Report:
    return report(mixed, formats=("png",))


def test_per_run_tests_compare_each_pair_at_the_births_both_reached(
        mixed: Path, mixed_report: Report) -> None:
    result = mixed_report
    rows = _rows(result.tables[1])
    births = {(r["experiment_a"], r["experiment_b"]): int(r["births"]) for r in rows}
    assert births == {("scenario1", "scenario3"): 45, ("scenario1", "baseline_b"): 30,
                      ("scenario3", "baseline_b"): 30}
    row = next(r for r in rows if r["sample"] == "run_mean_fitness"
               and (r["experiment_a"], r["experiment_b"]) == ("scenario1", "baseline_b"))
    # Scenario 1 at 30 births: its population after the generation ending at 30, not its final.
    at_30 = _stored_means(mixed / "scenario1" / DB_NAME, 30)
    final = _stored_means(mixed / "scenario1" / DB_NAME, 60)
    assert at_30 != final
    baseline = _stored_means(mixed / "baseline_b" / DB_NAME, 30)
    reference = mannwhitneyu(at_30, baseline, alternative="two-sided", method="exact")
    assert float(row["median_a"]) == pytest.approx(np.median(at_30), rel=1e-5)
    assert float(row["median_b"]) == pytest.approx(np.median(baseline), rel=1e-5)
    assert float(row["p_value"]) == pytest.approx(reference.pvalue, rel=1e-5)
    assert float(row["a12"]) == pytest.approx(reference.statistic / 9)
    # Scenario 1 against scenario 3 at 45 births: scenario 3's final population.
    row = next(r for r in rows if r["sample"] == "run_mean_fitness"
               and (r["experiment_a"], r["experiment_b"]) == ("scenario1", "scenario3"))
    assert float(row["median_b"]) == pytest.approx(
        np.median(_stored_means(mixed / "scenario3" / DB_NAME, 45)), rel=1e-5)
    assert float(row["median_a"]) == pytest.approx(
        np.median(_stored_means(mixed / "scenario1" / DB_NAME, 45)), rel=1e-5)


def test_curves_are_compared_over_the_common_range_only(mixed_report: Report) -> None:
    rows = _rows(mixed_report.tables[3])
    # Like with like (issue 31): offline curves with offline ones; scenario 3 (online) has no
    # online partner here, so it is in no curve test.
    assert {(r["experiment_a"], r["experiment_b"]) for r in rows} == {("scenario1", "baseline_b")}
    pair = [int(r["births"]) for r in rows]
    assert pair and max(pair) == 30
    assert set(pair) <= {round(f * 30) for f in CURVE_FRACTIONS}


def test_the_summary_says_budgets_differ_and_what_it_compares(
        mixed: Path, mixed_report: Report) -> None:
    result = mixed_report
    text = (result.out_dir / "summary.md").read_text()
    assert "Budgets differ" in text and "30 births, the most every run reached" in text
    summary = {r["experiment"]: r for r in _rows(result.tables[0])}
    assert {k: (r["births_budget"], r["births_reached_min"]) for k, r in summary.items()} == {
        "scenario1": ("60", "60"), "scenario3": ("45", "45"), "baseline_b": ("30", "30")}
    # Without losses the births axis is the engines' count: the figures mark the common point.
    figure = fitness_over_births(find_experiments(mixed))
    marks = [line for line in figure.axes[0].lines if line.get_linestyle() == ":"]
    assert [tuple(line.get_xdata()) for line in marks] == [(30, 30)]


def test_equal_budgets_compare_the_final_populations(tmp_path: Path) -> None:
    """A run that lost robots still reached its budget: the births the engine counts."""
    for name, evaluator in (("scenario1", LOSSY), ("baseline_b", SERIAL)):
        run(small(preset(name, births=30, runs=3)), tmp_path / name, evaluator=evaluator)
    experiments = find_experiments(tmp_path)
    assert any(r.failed_births.size for r in experiments[0].runs)
    assert {r.births for r in experiments[0].runs} != {30}  # fewer on the report's axis
    (tmp_path / "tables").mkdir()
    paths, _ = write_tables(load_included(tmp_path), tmp_path / "tables")
    rows = _rows(paths[1])
    assert {r["births"] for r in rows} == {"30"}
    row = next(r for r in rows if r["sample"] == "run_mean_fitness")
    assert float(row["median_a"]) == pytest.approx(
        np.median(_stored_means(tmp_path / "scenario1" / DB_NAME, 30)), rel=1e-5)
    lost = sum(r.lost_robots for r in experiments[0].runs)
    assert (row["lost_a"], row["lost_b"]) == (str(lost), "0") and lost > 0
    assert "Budgets differ" not in (tmp_path / "tables" / "summary.md").read_text()


def test_an_interrupted_run_moves_its_pairs_to_where_it_stopped(tmp_path: Path) -> None:
    run(small(preset("baseline_b", births=60, runs=2)), tmp_path / "baseline_b",
        evaluator=SERIAL)
    with pytest.raises(Kill):
        run(small(preset("scenario1", births=60, runs=2)), tmp_path / "scenario1",
            kill_after(45), evaluator=SERIAL)
    (scenario1, baseline) = find_experiments(tmp_path)
    assert [r.engine_births for r in scenario1.runs] == [45]
    rows = mann_whitney_rows([scenario1, baseline])
    assert {r["births"] for r in rows} == {45}
    row = next(r for r in rows if r["sample"] == "run_best_fitness")
    with Store.open(tmp_path / "baseline_b" / DB_NAME) as store:
        best = [max(f for _, f in [s for s in store.population_snapshots(r.run_id)
                                   if s[0] <= 45][-1][2]) for r in store.runs()]
    assert row["median_b"] == pytest.approx(np.median(best), rel=1e-5)
    assert [p.births for p in baseline.populations_at(45)] == [45, 45]
