"""The report's shaking table: each evaluated robot's shaking measure, read back from the store."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from experiment_fakes import fake_evaluate, fake_world, small

from evolution.cli.commands import main
from evolution.evaluation import LocalEvaluator
from evolution.evaluation.tasks import EvalOutcome, EvalTask
from evolution.experiments import preset, run
from evolution.experiments.store.database import DB_NAME, Store
from evolution.reporting import report
from evolution.reporting.data import load_experiment
from evolution.reporting.tables import SHAKING_COLUMNS, shaking_line, shaking_rows


def shaking_evaluate(task: EvalTask) -> EvalOutcome:
    """:func:`fake_evaluate` with a shaking measure that grows with the fitness."""
    outcome = fake_evaluate(task)
    assert outcome.fitness is not None
    return dataclasses.replace(outcome, shaking=1.0 + outcome.fitness)


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("shaking")
    config = small(preset("scenario1", births=20, runs=2, diversity_interval=0)).replace(
        task={"name": "locomotion", "pose_rate": 5})
    run(config, root / "scenario1", evaluator=LocalEvaluator(workers=1, function=shaking_evaluate),
        world_factory=fake_world)
    return root


def test_the_shaking_table_is_the_stored_measure(results: Path) -> None:
    experiment = load_experiment(results / "scenario1")
    with Store.open(results / "scenario1" / DB_NAME) as store:
        samples = [s for run_id in (0, 1) for s in store.fitness_samples(run_id)]
    assert samples and all(s.shaking == pytest.approx(1.0 + s.fitness) for s in samples)
    [row] = shaking_rows([experiment])
    assert tuple(row) == SHAKING_COLUMNS
    shaking = np.array([s.shaking for s in samples])
    fitness = np.array([s.fitness for s in samples])
    assert row["pose_rate"] == "5" and row["robots_measured"] == len(samples) == 40
    assert row["shaking_median"] == pytest.approx(np.median(shaking))
    assert row["fittest_robots"] == 4
    assert row["fittest_shaking_median"] == pytest.approx(np.median(np.sort(fitness)[-4:]) + 1)
    assert row["share_shaking_over_2"] == pytest.approx(np.mean(shaking > 2))
    assert "median" in shaking_line(row) and "4 fittest" in shaking_line(row)


@pytest.mark.slow
def test_the_report_shows_it_in_the_summary_the_page_and_the_cli(
        results: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    result = report(results, tmp_path / "report", formats=("png",))
    summary = (result.out_dir / "summary.md").read_text()
    page = result.page.read_text()
    assert "## Shaking: is evolution paid for vibration?" in summary
    assert "fittest_shaking_median" in summary and "fittest_shaking_median" in page
    assert main(["report", str(results), "--out", str(tmp_path / "cli"), "--formats", "png"]) == 0
    out = capsys.readouterr().out
    assert "shaking (path every control period / at pose rate 5) median" in out


@pytest.mark.slow
def test_experiments_without_a_measure_have_no_row(tmp_path: Path) -> None:
    root = tmp_path / "plain"
    run(small(preset("scenario1", births=15, runs=1, diversity_interval=0)), root,
        evaluator=LocalEvaluator(workers=1, function=fake_evaluate), world_factory=fake_world)
    assert shaking_rows([load_experiment(root)]) == []
    summary = (report(root, tmp_path / "report", formats=("png",)).out_dir / "summary.md")
    assert "(no robot with a shaking measure)" in summary.read_text()
