"""The ``[task]`` table of experiment configs: what robots are scored on, stored with the results
(tiny runs with real physics): offline and online runs score with it, resume and reevaluate use
the stored one, no table is the paper's fitness exactly as before, and a stored class of a
user's own is imported only when a run or re-evaluation needs it."""

from __future__ import annotations

import json
import sqlite3
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import dump_results as dump
from experiment_fakes import tiny_run

from evolution import experiments
from evolution.cli.commands import main
from evolution.evaluation import EvalTask, LocalEvaluator, evaluate_task, evaluation_seed
from evolution.experiments import ConfigError, ExperimentConfig, load_config
from evolution.experiments.app.reevaluate import reevaluate
from evolution.experiments.loop.config import DEFAULT_EVALUATION
from evolution.experiments.loop.run import decode, run_seed
from evolution.experiments.store.database import Store, StoreError
from revolve_env.conditions import EvaluationConditions
from revolve_env.tasks import DirectedLocomotion, Locomotion

DIRECTED = {"name": "directed-locomotion", "heading": 0.0}


def tiny(mode: str, task: dict[str, Any] | None = None) -> ExperimentConfig:
    """6 births, 1 s windows, ``task`` as the ``[task]`` table (none: no table)."""
    name = "scenario3" if mode == "online" else "scenario1"
    return tiny_run(name) if task is None else tiny_run(name, task=task)


def _run(config: ExperimentConfig, out: Path) -> dict[str, Any]:
    experiments.run(config, out, evaluator=LocalEvaluator(1, evaluate_task))
    return dump(out / "results.sqlite")


# -- the table ---------------------------------------------------------------------------------

def test_no_table_is_the_papers_fitness_and_is_not_stored() -> None:
    config = ExperimentConfig()
    assert config.task is None and config.fitness_task() == Locomotion()
    assert "task" not in config.to_dict()  # stored configs of before are unchanged


def test_the_table_round_trips_and_merges_as_a_table(tmp_path: Path) -> None:
    path = tmp_path / "exp.toml"
    path.write_text('preset = "quick"\n[task]\nname = "directed-locomotion"\nheading = 1\n')
    config = ExperimentConfig.from_toml(path)
    assert config.fitness_task() == DirectedLocomotion(1.0)
    assert ExperimentConfig.from_dict(config.to_dict()) == config
    assert config.to_dict()["task"] == {"name": "directed-locomotion", "heading": 1}
    over = load_config(path, {"task": {"heading": 0.5}})  # --set task.heading=0.5
    assert over.fitness_task() == DirectedLocomotion(0.5)
    assert over.evaluation == DEFAULT_EVALUATION


def test_the_pose_rate_and_limit_from_the_command_line() -> None:
    over = load_config("quick", {"task": {"name": "locomotion", "pose_rate": 10, "limit": 1.0}})
    assert over.fitness_task() == Locomotion(pose_rate=10.0, limit=1.0)
    every = load_config("quick", {"task": {"name": "locomotion", "pose_rate": "every-period"}})
    assert every.fitness_task().to_dict()["pose_rate"] == "every-period"
    assert load_config("quick").fitness_task() == Locomotion(pose_rate=5.0)


@pytest.mark.parametrize("table, message", [
    ({"name": "swimming"}, "^task: unknown task 'swimming': use one of locomotion"),
    ({"heading": 1.0}, "^task: a task table needs a 'name'"),
    ({"name": "directed-locomotion", "speed": 1}, "^task: task 'directed-locomotion': bad "
                                                  "parameters"),
    ({"name": "locomotion", "s_weight": "5"}, "^task: task 'locomotion': s_weight must be a "
                                              "finite number"),
    ({"name": 3}, "^task: a task name must be a string"),
    ("locomotion", "^task must be a table with a name"),
    ({"name": "no such module:Task"}, "^task: unknown task 'no such module:Task'"),
    ({"name": "locomotion", "pose_rate": 7}, "^task: pose_rate 7 Hz does not fit the control "
                                             "period"),
    ({"name": "locomotion", "pose_rate": 0}, "^task: task 'locomotion': pose_rate must be a "
                                             "positive number"),
    ({"name": "locomotion", "limit": 0}, "^task: task 'locomotion': limit must be a positive "
                                         "speed"),
])
def test_a_bad_table_is_refused_in_one_line(table: Any, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        ExperimentConfig.from_dict({"task": table})


def test_a_class_of_ones_own_is_refused_before_anything_is_written(tmp_path: Path) -> None:
    config = tiny("offline", {"name": "no_such_module_here:Task"})  # the form is fine
    with pytest.raises(ConfigError, match="cannot import module 'no_such_module_here'"):
        experiments.run(config, tmp_path / "out")
    assert not (tmp_path / "out" / "results.sqlite").exists()


def test_reading_a_stored_class_of_ones_own_imports_nothing() -> None:
    sys.modules.pop("experiment_tasks", None)
    config = ExperimentConfig.from_dict({"task": {"name": "experiment_tasks:Forward"}})
    assert "experiment_tasks" not in sys.modules  # a report or show would not run its code
    with pytest.raises(ConfigError, match="is a class of your own"):
        config.fitness_task(allow_import=False)
    assert config.fitness_task().to_dict() == {"name": "experiment_tasks:Forward", "scale": 1.0,
                                               "pose_rate": 5.0}


# -- runs --------------------------------------------------------------------------------------

@pytest.mark.parametrize("mode", ["offline", "online"])
def test_a_run_scores_with_its_task_and_stores_it(tmp_path: Path, mode: str) -> None:
    paper = _run(tiny(mode), tmp_path / "paper")
    explicit = _run(tiny(mode, {"name": "locomotion"}), tmp_path / "explicit")
    directed = _run(tiny(mode, DIRECTED), tmp_path / "directed")
    assert explicit["fitness"] == paper["fitness"]  # the table names the default exactly
    assert directed["fitness"] != paper["fitness"]
    with Store.open(tmp_path / "directed" / "results.sqlite") as store:
        assert store.config["task"] == DIRECTED
    if mode == "offline":
        # Each stored fitness is the robot's evaluation under the task, with its seed.
        seed = run_seed(0, 0)
        with sqlite3.connect(tmp_path / "directed" / "results.sqlite") as db:
            rows = db.execute("SELECT robot_id, genome, fitness FROM robots").fetchall()
        config = tiny(mode, DIRECTED)
        for robot_id, genome, fitness in rows[:2]:
            outcome = evaluate_task(EvalTask(
                robot_id, decode(genome), config.insertion, config.evaluation_time,
                evaluation_seed(seed, robot_id), conditions=config.evaluation,
                task=DirectedLocomotion(0.0)))
            assert outcome.fitness == fitness


def test_a_class_of_ones_own_scores_a_run_and_its_resume(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = tiny("offline", {"name": "experiment_tasks:Forward", "scale": 2.0})
    whole = _run(config, tmp_path / "whole")

    def stop(event: Any) -> None:
        if event.births >= 3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        experiments.run(config, tmp_path / "cut", stop,
                        evaluator=LocalEvaluator(1, evaluate_task))
    before = dump(tmp_path / "cut" / "results.sqlite")
    # Resuming someone's folder must not run the code its task names unless trusted.
    with pytest.raises(StoreError, match="pass --trust-task-code"):
        experiments.resume(tmp_path / "cut", evaluator=LocalEvaluator(1, evaluate_task))
    assert main(["resume", str(tmp_path / "cut")]) == 2  # the command line says it in one line
    assert "--trust-task-code" in capsys.readouterr().err
    assert dump(tmp_path / "cut" / "results.sqlite") == before
    experiments.resume(tmp_path / "cut", evaluator=LocalEvaluator(1, evaluate_task),
                       trust_task_code=True)
    assert dump(tmp_path / "cut" / "results.sqlite")["fitness"] == whole["fitness"]
    with pytest.raises(StoreError, match="pass --trust-task-code"):
        reevaluate(tmp_path / "cut", k=1, workers=1)
    assert reevaluate(tmp_path / "cut", k=1, workers=1, trust_task_code=True).added > 0


def test_reevaluation_scores_with_the_stored_task(tmp_path: Path) -> None:
    _run(tiny("offline", DIRECTED), tmp_path / "directed")
    summary = reevaluate(tmp_path / "directed", k=2, workers=1)
    assert summary.added > 0
    with sqlite3.connect(tmp_path / "directed" / "results.sqlite") as db:
        rows = db.execute("SELECT robot_id, seed, conditions, insertion, seconds, fitness "
                          "FROM reevaluations").fetchall()
        genomes = dict(db.execute("SELECT robot_id, genome FROM robots").fetchall())
    assert rows
    for robot_id, seed, conditions, insertion, seconds, fitness in rows:
        base = EvalTask(robot_id, decode(genomes[robot_id]), insertion, seconds, seed,
                        conditions=EvaluationConditions.from_dict(json.loads(conditions)))
        directed = evaluate_task(replace(base, task=DirectedLocomotion(0.0))).fitness
        assert fitness == directed != evaluate_task(base).fitness
