"""Reports: figures and tables from results databases, checked against the stores' own numbers.

The experiments are run on the fast physics stand-ins of ``experiment_fakes`` (the report reads
databases; what made the numbers does not matter here).
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
import sqlite3
from itertools import combinations
from pathlib import Path

import numpy as np
import pytest
from experiment_fakes import (
    fake_evaluate,
    fake_evaluate_after_infancy,
    fake_world,
    param_distance_fitness,
    small,
)
from scipy.stats import mannwhitneyu

from evolution.evaluation import LocalEvaluator
from evolution.experiments import ProgressEvent, preset, run
from evolution.experiments.store.database import DB_NAME, Store, StoreError
from evolution.learning import CandidateEvaluation, RandomSearchLearner, TrainingCenter
from evolution.reporting import find_experiments, report, step_on_grid
from evolution.reporting.stats import holm as _holm
from evolution.reporting.tables import (
    MANN_WHITNEY_COLUMNS,
    SUMMARY_COLUMNS,
    TESTED_SAMPLES,
)

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)
CANDIDATES = CandidateEvaluation(insertion=0.0, seconds=1.0, function=param_distance_fitness)
NAMES = ("baseline_b", "scenario3", "scenario1")  # deliberately not in report order
FIGURE_STEMS = ("fitness_over_births", "final_fitness", "diversity_over_births", "final_diversity",
                "lost_robots", "curve_tests")


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Two runs of three experiments (offline, online, baseline) side by side in one folder."""
    root = tmp_path_factory.mktemp("results")
    for name in NAMES:
        config = small(preset(name, births=30, runs=2, diversity_interval=10))
        run(config, root / name, evaluator=SERIAL, world_factory=fake_world)
    return root


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def written(results: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, str]]:
    before = {name: _digest(results / name / DB_NAME) for name in NAMES}
    result = report(results)
    assert result.out_dir == results / "report"
    return result.out_dir, before


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_every_figure_is_written_as_png_and_pdf(written: tuple[Path, dict[str, str]]) -> None:
    out, _ = written
    for stem in FIGURE_STEMS:
        png, pdf = out / f"{stem}.png", out / f"{stem}.pdf"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", stem
        assert pdf.read_bytes()[:5] == b"%PDF-", stem
        assert png.stat().st_size > 5000  # a drawn figure, not an empty canvas


def test_without_learning_there_are_no_learning_columns_or_figure(
        written: tuple[Path, dict[str, str]]) -> None:
    out, _ = written
    with open(out / "summary.csv", newline="") as f:
        assert tuple(next(csv.reader(f))) == SUMMARY_COLUMNS
    assert not (out / "learning_gain.png").exists()


def test_learning_columns_are_the_stored_learning_records(results: Path, tmp_path: Path) -> None:
    """A learning experiment next to one without: the learning columns summarise the learning
    table of the results store (records written here through the store's own commit)."""
    import shutil

    from evolution.reporting import LEARNING_COLUMNS, summary_rows

    root = tmp_path / "mixed"
    shutil.copytree(results / "scenario1", root / "scenario1")
    config = small(preset("scenario1", births=30, runs=1, diversity_interval=10)).replace(
        name="scenario1_learning",
        learning={"learner": "random-search", "budget": 14.0, "inheritance": "darwinian"})
    learning_evaluator = LocalEvaluator(workers=1, function=fake_evaluate_after_infancy)
    center = TrainingCenter(RandomSearchLearner(batch_size=1, evaluation=CANDIDATES), 2.0)
    # The stored table says random search; the stand-in candidate fitness keeps this fast.
    run(config.replace(learning=None), root / "learning", evaluator=learning_evaluator,
        infancy=center)
    db = root / "learning" / DB_NAME
    with sqlite3.connect(db) as con:  # the table the CLI would have stored
        stored = json.loads(con.execute("SELECT value FROM meta WHERE key='config'").fetchone()[0])
        stored = {**stored, "name": "scenario1_learning", "learning": config.learning}
        con.execute("UPDATE meta SET value=? WHERE key='config'", (json.dumps(stored),))
    with Store.open(db) as store:
        records = store.learning(0)
        failures = store.failures(0, "learner")
    assert records
    experiments = find_experiments(root)
    rows = {r["experiment"]: r for r in summary_rows(experiments)}
    learned = rows["scenario1_learning"]
    assert learned["learning"] == "random-search darwinian"
    assert learned["infants_learned"] == len(records)
    assert learned["learner_failures"] == len(failures)
    assert learned["inborn_fitness_mean"] == pytest.approx(
        np.mean([r.inborn_fitness for r in records]))
    assert learned["learning_gain_mean"] == pytest.approx(
        np.mean([r.learned_fitness - r.inborn_fitness for r in records]))
    plain = rows["scenario1"]
    assert ((plain["learning"], plain["infants_learned"], plain["learner_failures"])
            == ("none", 0, 0))
    assert math.isnan(plain["inborn_fitness_mean"])
    result = report(root, formats=("png",))
    assert root / "report" / "learning_gain.png" in result.figures
    with open(root / "report" / "summary.csv", newline="") as f:
        assert tuple(next(csv.reader(f))) == SUMMARY_COLUMNS + LEARNING_COLUMNS


def test_report_only_reads_the_databases(
        results: Path, written: tuple[Path, dict[str, str]]) -> None:
    _, before = written
    assert {name: _digest(results / name / DB_NAME) for name in NAMES} == before


def test_summary_rows_match_the_stored_final_populations(
        results: Path, written: tuple[Path, dict[str, str]]) -> None:
    out, _ = written
    rows = _rows(out / "summary.csv")
    assert list(rows[0]) == list(SUMMARY_COLUMNS)
    assert [r["experiment"] for r in rows] == ["scenario1", "scenario3", "baseline_b"]
    for row in rows:
        with Store.open(results / row["experiment"] / DB_NAME) as store:
            finals = [store.final_population(r.run_id) for r in store.runs()]
        pooled = np.array([f for final in finals for _, f in final if f is not None])
        assert int(row["runs"]) == 2 and int(row["finished_runs"]) == 2
        assert float(row["births_mean"]) == 30
        assert float(row["final_fitness_mean"]) == pytest.approx(pooled.mean(), rel=1e-5)
        assert float(row["final_fitness_max"]) == pytest.approx(pooled.max(), rel=1e-5)
        assert float(row["final_population_size_mean"]) == np.mean([len(f) for f in finals])
        assert float(row["final_diversity_mean"]) > 0  # random bodies differ
    assert rows[0]["mode"] == "offline" and rows[1]["mode"] == "online"
    # (15+15) keeps exactly 15 robots.
    assert float(rows[0]["final_population_size_mean"]) == 15


def test_per_run_tests_are_the_scipy_tests_of_one_value_per_run(
        results: Path, written: tuple[Path, dict[str, str]]) -> None:
    out, _ = written
    rows = _rows(out / "tests_per_run.csv")
    assert list(rows[0]) == list(MANN_WHITNEY_COLUMNS)
    labels = ["scenario1", "scenario3", "baseline_b"]
    samples = [s for s in TESTED_SAMPLES if s != "run_brain_diversity"]  # not asked for
    expected_pairs = [(s, a, b) for s in samples for a, b in combinations(labels, 2)]
    assert [(r["sample"], r["experiment_a"], r["experiment_b"]) for r in rows] == expected_pairs
    for r in rows:
        p, holm = float(r["p_value"]), float(r["p_holm"])
        assert 0.0 <= p <= 1.0 and p <= holm <= 1.0
        assert (r["n_a"], r["n_b"], float(r["p_min"])) == ("2", "2", pytest.approx(1 / 3))
        assert float(r["a12_ci_low"]) <= float(r["a12"]) <= float(r["a12_ci_high"])
    means = {}
    for name in ("scenario1", "baseline_b"):
        with Store.open(results / name / DB_NAME) as store:
            means[name] = [np.mean([f for _, f in store.final_population(r.run_id)
                                    if f is not None]) for r in store.runs()]
    reference = mannwhitneyu(means["scenario1"], means["baseline_b"], alternative="two-sided")
    row = next(r for r in rows if r["sample"] == "run_mean_fitness"
               and (r["experiment_a"], r["experiment_b"]) == ("scenario1", "baseline_b"))
    assert float(row["p_value"]) == pytest.approx(reference.pvalue, rel=1e-5)
    assert float(row["a12"]) == pytest.approx(reference.statistic / 4)  # A12 = U / (n_a n_b)


def test_pooled_tests_are_kept_as_descriptive(
        results: Path, written: tuple[Path, dict[str, str]]) -> None:
    out, _ = written
    rows = _rows(out / "tests_pooled_descriptive.csv")
    assert {r["sample"] for r in rows} == {"pooled_fitness"}
    pooled = {}
    for name in ("scenario1", "baseline_b"):
        with Store.open(results / name / DB_NAME) as store:
            pooled[name] = [f for r in store.runs() for _, f in store.final_population(r.run_id)
                            if f is not None]
    reference = mannwhitneyu(pooled["scenario1"], pooled["baseline_b"], alternative="two-sided")
    row = next(r for r in rows
               if (r["experiment_a"], r["experiment_b"]) == ("scenario1", "baseline_b"))
    assert float(row["p_value"]) == pytest.approx(reference.pvalue, rel=1e-5)
    assert float(row["u_statistic"]) == pytest.approx(reference.statistic)
    assert int(row["n_a"]) == 30 and int(row["n_b"]) == 30
    text = (out / "summary.md").read_text()
    assert "Descriptive only: pooled populations" in text
    assert "Holm-Bonferroni" in text


def test_curve_tests_compare_runs_at_equal_births(
        written: tuple[Path, dict[str, str]]) -> None:
    out, _ = written
    rows = _rows(out / "curve_tests.csv")
    pair = [r for r in rows if (r["experiment_a"], r["experiment_b"]) == ("scenario1",
                                                                           "baseline_b")]
    # Both reached 30 births; offline commit points at 15 and 30: the points from 50 % on.
    assert [int(r["births"]) for r in pair] == [15, 18, 21, 24, 27, 30]
    assert [int(r["point"]) for r in pair] == [4, 5, 6, 7, 8, 9]
    assert [float(r["p_holm"]) for r in pair] == pytest.approx(
        _holm([float(r["p_value"]) for r in pair]))


def test_curve_tests_pair_like_with_like(written: tuple[Path, dict[str, str]]) -> None:
    """Offline experiments with offline ones only: online scenario 3 is in no pair."""
    out, _ = written
    pairs = {(r["experiment_a"], r["experiment_b"]) for r in _rows(out / "curve_tests.csv")}
    assert pairs == {("scenario1", "baseline_b")}


def test_pooled_p_values_are_only_in_their_csv(written: tuple[Path, dict[str, str]]) -> None:
    out, _ = written
    text = (out / "summary.md").read_text()
    per_run, pooled = text.index("## Primary tests"), text.index("## Descriptive only")
    assert per_run < pooled  # the real tests lead
    header = next(line for line in text[pooled:].splitlines() if line.startswith("| sample"))
    assert "p_value" not in header and "p_holm" not in header and "a12" in header
    assert "p-values are left out of this page and of summary.md" in text[pooled:]
    assert "p_value" in _rows(out / "tests_pooled_descriptive.csv")[0]


def test_markdown_summary_holds_both_tables(written: tuple[Path, dict[str, str]]) -> None:
    out, _ = written
    text = (out / "summary.md").read_text()
    assert "| experiment | label | mode |" in text and "| sample | experiment_a |" in text
    assert text.count("\n| pooled_fitness |") == 3


def test_step_on_grid_holds_the_last_value_and_is_undefined_outside() -> None:
    x = np.array([15, 30, 45])
    y = np.array([1.0, 2.0, 4.0])
    got = step_on_grid(x, y, np.array([10, 15, 20, 30, 44, 45, 50]))
    np.testing.assert_array_equal(got, [np.nan, 1.0, 1.0, 2.0, 2.0, 4.0, np.nan])


def test_holm_correction_by_hand() -> None:
    # sorted p: 0.01 (x3), 0.02 (x2), 0.04 (x1) -> 0.03, 0.04, 0.04 (monotone)
    assert _holm([0.04, 0.01, 0.02]) == pytest.approx([0.04, 0.03, 0.04])
    assert _holm([0.9, 0.8]) == pytest.approx([1.0, 1.0])


def test_same_named_experiments_are_told_apart_by_path(results: Path, tmp_path: Path) -> None:
    import shutil

    for folder in ("a", "b"):
        shutil.copytree(results / "scenario1", tmp_path / folder / "scenario1")
    labels = [e.label for e in find_experiments(tmp_path)]
    assert labels == ["a/scenario1", "b/scenario1"]


def test_an_interrupted_run_is_reported_as_unfinished(tmp_path: Path) -> None:
    class Stop(Exception):
        pass

    def stop_at_30(event: ProgressEvent) -> None:
        if event.births >= 30:
            raise Stop

    config = small(preset("scenario1", births=60, runs=2))  # run 1 never starts
    with pytest.raises(Stop):
        run(config, tmp_path / "scenario1", stop_at_30, evaluator=SERIAL)
    (experiment,) = find_experiments(tmp_path)
    assert [(r.status, r.births) for r in experiment.runs] == [("interrupted", 30)]
    result = report(tmp_path, tmp_path / "out", formats=("png",))
    row = _rows(result.tables[0])[0]
    assert (row["runs"], row["runs_in_database"], row["finished_runs"], row["births_mean"]) == (
        "1", "2", "0", "30")
    assert len(result.figures) == len(FIGURE_STEMS)
    # One experiment: no pair to test, the table has only its header.
    assert _rows(result.tables[1]) == []


def test_missing_empty_corrupt_and_newer_results_are_refused(results: Path, tmp_path: Path) -> None:
    with pytest.raises(StoreError, match="no such results directory"):
        report(tmp_path / "nowhere")
    with pytest.raises(StoreError, match="no results database"):
        report(tmp_path)
    bad = tmp_path / "corrupt" / DB_NAME
    bad.parent.mkdir()
    bad.write_bytes(b"not a database" * 100)
    with pytest.raises(StoreError, match="corrupt"):
        report(bad.parent)
    import shutil

    newer = tmp_path / "newer"
    shutil.copytree(results / "scenario1", newer)
    con = sqlite3.connect(newer / DB_NAME)
    con.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    con.commit()
    con.close()
    with pytest.raises(StoreError, match="schema version 99"):
        report(newer)
    with pytest.raises(ValueError, match="unknown figure format"):
        report(results, tmp_path / "x", formats=("bmp",))


def test_final_diversity_is_the_mean_pairwise_distance_of_the_final_bodies(results: Path) -> None:
    from evolution.diversity import pairwise_distances

    (experiment,) = [e for e in find_experiments(results) if e.name == "scenario1"]
    with Store.open(results / "scenario1" / DB_NAME) as store:
        for r in experiment.runs:
            members = [rid for rid, _ in store.final_population(r.run_id)]
            robots = [rec.robot() for rec in store.robots(r.run_id, members)]
            d = pairwise_distances(robots)
            n = len(robots)
            assert r.final_diversity == pytest.approx(d[np.triu_indices(n, 1)].mean())
            assert math.isfinite(r.final_diversity)
