"""RL infancy inside evolution runs: SB3 policies saved with the run, driving the robots,
killed and resumed to the same database, budgets checked at config time."""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path
from typing import Any

import pytest
from evolution import experiments
from evolution.evaluation import LocalEvaluator, evaluate_task
from evolution.experiments import ConfigError, ExperimentConfig, ProgressEvent, preset
from evolution.experiments.store import Store, StoreError

pytest.importorskip("stable_baselines3")

TABLES = ("runs", "checkpoints", "robots", "fitness", "transitions", "population", "diversity",
          "failures", "learning")
SERIAL = LocalEvaluator(workers=1, function=evaluate_task)
# One PPO rollout of 16 steps (1/60 s each) and the learner's two 1.5 s evaluations: 3.27 s.
LEARNING = {"learner": "sb3", "algorithm": "PPO", "n_envs": 1, "vec_env": "dummy",
            "insertion": 0.5, "seconds": 1.0, "budget": 3.3,
            "algorithm_kwargs": {"n_steps": 16, "batch_size": 16, "n_epochs": 1}}


def dump(db: Path) -> dict[str, list[tuple[Any, ...]]]:
    con = sqlite3.connect(db)
    try:
        return {t: sorted(con.execute(f"SELECT * FROM {t}").fetchall(), key=repr) for t in TABLES}
    finally:
        con.close()


class Kill(Exception):
    pass


def killer(after_births: int) -> Any:
    def progress(event: ProgressEvent) -> None:
        if event.births >= after_births and not event.replaying:
            raise Kill(f"killed at {event.births} births")
    return progress


def offline_config() -> ExperimentConfig:
    return (preset("scenario1", runs=1, births=6, population_size=4, offspring_size=2,
                        insertion=0.5, evaluation_time=1.0, fertile_age=1.0,
                        learning=LEARNING))


def online_config() -> ExperimentConfig:
    return (preset("scenario3", runs=1, births=6, population_size=4, min_alive=2, max_alive=8,
                        insertion=0.5, evaluation_time=1.0, fertile_age=1.0,
                        conception_interval=0.5, checkpoint_interval=1, learning=LEARNING))


def _check_policies(out: Path) -> None:
    with Store.open(out / "results.sqlite") as store:
        records = store.learning(0)
        failures = store.failures(0)
    # Every infant learned, except robots without a hinge (nothing to control: a learner failure).
    assert len(records) >= 3
    assert sorted([r.robot_id for r in records]
                  + [f.robot_id for f in failures if f.kind == "learner"]) == list(range(6))
    assert all("no active hinge" in f.detail for f in failures if f.kind == "learner")
    for r in records:
        assert r.policy is not None and r.learned_genome is None
        assert r.inborn_fitness is not None and r.learned_fitness is not None
        assert r.sim_seconds is not None and r.sim_seconds <= LEARNING["budget"]
        assert (out / json.loads(r.policy)["file"]).is_file()


def test_offline_ppo_infancy_killed_and_resumed(tmp_path: Path) -> None:
    config = offline_config()
    experiments.run(config, tmp_path / "ref", evaluator=SERIAL)
    _check_policies(tmp_path / "ref")
    out = tmp_path / "killed"
    with pytest.raises(Kill):
        experiments.run(config, out, killer(4), evaluator=SERIAL)
    experiments.resume(out, evaluator=SERIAL)
    assert dump(out / "results.sqlite") == dump(tmp_path / "ref" / "results.sqlite")


def test_online_ppo_infancy_killed_and_resumed(tmp_path: Path) -> None:
    config = online_config()
    experiments.run(config, tmp_path / "ref", evaluator=SERIAL)
    _check_policies(tmp_path / "ref")
    out = tmp_path / "killed"
    with pytest.raises(Kill):
        experiments.run(config, out, killer(5), evaluator=SERIAL)
    experiments.resume(out, evaluator=SERIAL)
    assert dump(out / "results.sqlite") == dump(tmp_path / "ref" / "results.sqlite")
