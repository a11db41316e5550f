"""One set of experiments at a time: a study, or the experiments outside any study.

``revolve run quick --out results`` beside ``revolve study --out results/study`` puts a lone
experiment and a study below ``results``; a report (and a reevaluation) of ``results`` takes the
lone one and names the study it left out, unless ``--all`` asks for every set. The runs use the
fast physics stand-ins of ``experiment_fakes``.
"""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import fake_evaluate, small

from evolution.cli.commands import main
from evolution.evaluation import LocalEvaluator
from evolution.experiments import StoreError, preset, run
from evolution.experiments.app.reevaluate import reevaluate
from evolution.experiments.app.study import study
from evolution.experiments.store.database import DB_NAME, Store
from evolution.experiments.store.folders import select_results
from evolution.reporting import report

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)
TINY: dict[str, Any] = {
    "population_size": 4, "offspring_size": 4, "insertion": 0.5, "evaluation_time": 1.0,
    "fertile_age": 1.5, "diversity_interval": 4,
    "evolution": {"initial_parts_mean": 5.0, "initial_parts_sd": 2.0, "max_parts": 12},
}


def _study(out: Path, seed: int = 1) -> None:
    study(out, runs=2, births=12, experiments=("scenario1", "baseline_b"), overrides=TINY,
          seed=seed, evaluator=SERIAL)


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``results/quick`` (a lone experiment of 30 births) beside ``results/study``."""
    root = tmp_path_factory.mktemp("sets") / "results"
    run(small(preset("quick", births=30, runs=2)), root / "quick", evaluator=SERIAL)
    _study(root / "study")
    return root


def test_a_folder_with_a_study_and_a_lone_experiment_takes_the_lone_one(results: Path) -> None:
    selection = select_results(results)
    assert selection.databases == (results / "quick" / DB_NAME,)
    (left,) = selection.left_out
    assert left.study == results / "study"
    assert left.describe() == f"the study {results / 'study'} (2 experiments)"
    every = select_results(results, every_set=True)
    assert len(every.databases) == 3 and every.left_out == ()
    assert every.study_of(results / "study" / "scenario1" / DB_NAME) == results / "study"
    assert every.study_of(results / "quick" / DB_NAME) is None


def test_a_study_folder_or_one_inside_it_is_the_study(results: Path) -> None:
    inside = select_results(results / "study")
    assert [db.parent.name for db in inside.databases] == ["baseline_b", "scenario1"]
    assert inside.left_out == () and {s.study for s in inside.chosen} == {results / "study"}
    one = select_results(results / "study" / "scenario1")
    assert one.databases == (results / "study" / "scenario1" / DB_NAME,)


def test_several_studies_and_nothing_else_are_refused_on_one_line(tmp_path: Path) -> None:
    _study(tmp_path / "a", seed=1)
    _study(tmp_path / "b", seed=2)
    with pytest.raises(StoreError, match=r"holds 2 studies .* --all$") as error:
        select_results(tmp_path)
    assert "\n" not in str(error.value) and str(tmp_path / "a") in str(error.value)
    assert len(select_results(tmp_path, every_set=True).databases) == 4
    with pytest.raises(StoreError, match="no results database"):
        select_results(tmp_path / "a" / "study.json")  # a file, not a database


def test_a_report_says_what_it_compares_and_what_it_left_out(results: Path,
                                                             tmp_path: Path) -> None:
    lone = report(results, tmp_path / "lone", formats=("png",))
    assert [e.label for e in lone.experiments] == ["quick"]
    assert [s.study for s in lone.left_out] == [results / "study"]
    text = (tmp_path / "lone" / "summary.md").read_text()
    assert "Left out (a report compares one set" in text
    assert f"the study {results / 'study'} (2 experiments)" in text
    assert f"`revolve report {results} --all`" in text
    everything = report(results, tmp_path / "all", formats=("png",), every_set=True)
    assert sorted(e.label for e in everything.experiments) == ["baseline_b", "quick",
                                                                "scenario1"]
    with open(tmp_path / "all" / "summary.csv", newline="") as f:
        budgets = {r["experiment"]: r["births_budget"] for r in csv.DictReader(f)}
    assert budgets == {"scenario1": "12", "baseline_b": "12", "quick": "30"}
    text = (tmp_path / "all" / "summary.md").read_text()
    assert "Budgets differ" in text and f"study {results / 'study'}" in text
    assert "outside any study" in text


def test_reevaluate_takes_the_same_set(results: Path, tmp_path: Path) -> None:
    import shutil

    copy = tmp_path / "results"
    shutil.copytree(results, copy)
    summary = reevaluate(copy, k=1, evaluator=SERIAL)
    assert summary.databases == (copy / "quick" / DB_NAME,)
    assert [s.study for s in summary.left_out] == [copy / "study"]
    with Store.open(copy / "study" / "scenario1" / DB_NAME) as store:
        assert store.reevaluations() == []  # the study was left alone
    summary = reevaluate(copy, k=1, evaluator=SERIAL, every_set=True)
    assert len(summary.databases) == 3


def test_the_cli_names_what_it_left_out(results: Path, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["report", str(results), "--out", str(tmp_path / "r"), "--formats", "png"]) == 0
    out = capsys.readouterr().out
    assert f"left out below {results}: the study {results / 'study'} (2 experiments): " \
           f"revolve report {results / 'study'}" in out
    assert f"open in a browser: {tmp_path / 'r' / 'index.html'}" in out
    assert main(["report", str(results), "--all", "--out", str(tmp_path / "a"),
                 "--formats", "png"]) == 0
    assert "3 experiment(s)" in capsys.readouterr().out
