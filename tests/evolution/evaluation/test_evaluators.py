"""Evaluators: results do not depend on where or in how many processes evaluations run."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import dump_results, fake_evaluate, small

from evolution import experiments
from evolution.evaluation import EvalTask, LocalEvaluator, evaluation_seed
from evolution.experiments import preset
from revolve_env.body.examples import EXAMPLES, example
from revolve_env.body.robot import Robot

TABLES = ("robots", "fitness", "transitions", "population", "diversity", "failures", "checkpoints")


def dump(db: Path) -> dict[str, list[tuple[Any, ...]]]:
    return dump_results(db, TABLES)


def _robot(i: int) -> Robot:
    """One of the example robots, by index (the fakes hash its JSON)."""
    return example(sorted(EXAMPLES)[i % len(EXAMPLES)])


def test_evaluation_seed_depends_on_run_seed_and_robot_only() -> None:
    assert evaluation_seed(5, 3) == evaluation_seed(5, 3)
    assert len({evaluation_seed(s, r) for s in range(10) for r in range(10)}) == 100


def test_worker_count_does_not_change_results(tmp_path: Path) -> None:
    config = small(preset("scenario1", births=45, runs=1))
    experiments.run(config, tmp_path / "one", evaluator=LocalEvaluator(1, fake_evaluate))
    with LocalEvaluator(2, fake_evaluate) as two:
        experiments.run(config, tmp_path / "two", evaluator=two)
    assert dump(tmp_path / "one" / "results.sqlite") == dump(tmp_path / "two" / "results.sqlite")


def test_runs_side_by_side_in_processes_equal_runs_one_by_one(tmp_path: Path) -> None:
    config = small(preset("scenario2", births=25, runs=3))
    experiments.run(config, tmp_path / "serial", evaluator=LocalEvaluator(1, fake_evaluate))
    events: list[Any] = []
    with LocalEvaluator(2, fake_evaluate) as pool:
        summary = experiments.run(config, tmp_path / "pool", events.append, evaluator=pool)
    assert [s.run_id for s in summary.runs] == [0, 1, 2]
    assert {e.run_id for e in events} == {0, 1, 2}  # progress forwarded from the workers
    assert (dump(tmp_path / "serial" / "results.sqlite")
            == dump(tmp_path / "pool" / "results.sqlite"))


def test_local_evaluator_keeps_task_order() -> None:
    tasks = [EvalTask(i, _robot(i), 0.0, 1.0, i) for i in range(6)]
    with LocalEvaluator(2, fake_evaluate) as pool:
        assert pool.evaluate(tasks) == [fake_evaluate(t) for t in tasks]
    with pytest.raises(ValueError, match="workers must be >= 0"):
        LocalEvaluator(-1)


def test_ray_evaluator_on_a_local_instance(tmp_path: Path) -> None:
    ray = pytest.importorskip("ray")
    from evolution.evaluation import RayEvaluator

    config = small(preset("scenario1", births=30, runs=2))
    experiments.run(config, tmp_path / "local", evaluator=LocalEvaluator(1, fake_evaluate))
    evaluator = RayEvaluator(function=fake_evaluate, num_cpus=2,
                             runtime_env={"env_vars": {"PYTHONPATH": os.pathsep.join(filter(
                                 None, [*(str(p) for p in Path(__file__).parents[2:4]),
                                        os.environ.get("PYTHONPATH")]))}})
    try:
        tasks = [EvalTask(i, _robot(i), 0.0, 1.0, i) for i in range(4)]
        assert evaluator.evaluate(tasks) == [fake_evaluate(t) for t in tasks]  # evaluations
        experiments.run(config, tmp_path / "ray", evaluator=evaluator)  # whole runs as tasks
    finally:
        evaluator.close()
    assert not ray.is_initialized()
    assert dump(tmp_path / "local" / "results.sqlite") == dump(tmp_path / "ray" / "results.sqlite")


def test_real_physics_offline_run_is_reproducible(tmp_path: Path) -> None:
    """Two short offline runs with the real evaluation give identical numbers."""
    config = small(preset("scenario1", population_size=3, offspring_size=3, births=6,
                          insertion=0.5, evaluation_time=1.0, fertile_age=1.5, runs=1))
    with LocalEvaluator(2) as pool:
        experiments.run(config, tmp_path / "a", evaluator=pool)
    experiments.run(config, tmp_path / "b", evaluator=LocalEvaluator(1))
    a, b = dump(tmp_path / "a" / "results.sqlite"), dump(tmp_path / "b" / "results.sqlite")
    assert a == b
    assert len(a["fitness"]) + sum(1 for f in a["failures"] if f[3] == "evaluation") == 6
