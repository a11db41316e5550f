"""The ``[learning]`` table of an experiment config: kept by ExperimentConfig, stored with the
results, turned into the Training Center by ``run`` and ``resume``; conflicts and bad tables are
refused before anything is written.

Runs use the physics stand-in :func:`experiment_fakes.fake_evaluate` (it ignores the Training
Center), so these tests check the bookkeeping, fast; tests/evolution/test_cli.py runs a learning
experiment on the real physics.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from experiment_fakes import fake_evaluate

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ConfigError, ExperimentConfig, preset
from evolution.experiments.store.database import DB_NAME, Store
from evolution.learning import (
    CMAESLearner,
    RandomSearchLearner,
    TrainingCenter,
    training_center_from_dict,
)

SERIAL = LocalEvaluator(workers=1, function=fake_evaluate)
TABLE = {"learner": "random-search", "budget": 6.0, "inheritance": "lamarckian", "popsize": 3,
         "insertion": 0.5, "seconds": 1.0}


def tiny(**kw: object) -> ExperimentConfig:
    base = preset("scenario1", population_size=2, offspring_size=2, births=4, insertion=0.0,
                  evaluation_time=1.0, fertile_age=1.0, diversity_interval=2, runs=1)
    return base.replace(**kw)


def test_the_table_round_trips_and_builds_its_training_center() -> None:
    config = tiny(learning=TABLE)
    assert config.to_dict()["learning"] == TABLE
    assert "learning" not in tiny().to_dict()  # configs without learning are stored as before
    again = ExperimentConfig.from_dict(json.loads(json.dumps(config.to_dict())))
    assert again == config and again.learning == TABLE
    center = config.training_center()
    # The infants learn under the experiment's evaluation conditions.
    assert center == training_center_from_dict(TABLE, conditions=config.evaluation)
    assert center != training_center_from_dict(TABLE)  # IDEAL: the fixed heading
    assert isinstance(center.learner, RandomSearchLearner) and center.learner.batch_size == 3
    assert center.lamarckian and center.budget == 6.0
    assert tiny().training_center() is None
    hash(config)  # still hashable: the table is left out of the hash


def test_the_table_is_a_detached_copy() -> None:
    table = dict(TABLE)
    config = tiny(learning=table)
    table["budget"] = 1e9
    assert config.learning is not None and config.learning["budget"] == 6.0


@pytest.mark.parametrize("table, message", [
    ({**TABLE, "popsiz": 3}, "unknown learning key.*popsiz"),
    ({**TABLE, "learner": "hill-climb"}, "learner must be one of"),
    ({"learner": "cma-es"}, "budget.*required"),
    ({**TABLE, "budget": -1.0}, "budget"),
    ({**TABLE, "inheritance": "baldwinian"}, "inheritance"),
    ("cma-es", "learning must be a table"),
])
def test_bad_tables_are_config_errors_naming_the_problem(table: object, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        tiny(learning=table)


def test_toml_files_keep_the_table(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text('preset = "scenario1"\nname = "mine"\n[learning]\nlearner = "cma-es"\n'
                    'budget = 35.0\npopsize = 4\n')
    config = ExperimentConfig.from_toml(path)
    assert config.learning == {"learner": "cma-es", "budget": 35.0, "popsize": 4}
    center = config.training_center()
    assert center is not None and center == ExperimentConfig.from_toml(path).training_center()
    assert isinstance(center.learner, CMAESLearner)


def test_run_stores_the_table_and_resume_reads_it(tmp_path: Path) -> None:
    config = tiny(learning=TABLE)
    experiments.run(config, tmp_path / "a", evaluator=SERIAL)
    with Store.open(tmp_path / "a" / DB_NAME) as store:
        assert store.config["learning"] == TABLE
    # The center of the table itself may also be given (config.training_center()).
    experiments.run(config, tmp_path / "b", evaluator=SERIAL, infancy=config.training_center())
    experiments.resume(tmp_path / "b", evaluator=SERIAL, infancy=config.training_center())


def test_another_training_center_next_to_a_table_is_refused(tmp_path: Path) -> None:
    config = tiny(learning=TABLE)
    other = TrainingCenter(RandomSearchLearner(batch_size=2), 14.0, "lamarckian")
    with pytest.raises(ConfigError, match="learning table and infancy="):
        experiments.run(config, tmp_path / "x", evaluator=SERIAL, infancy=other)
    assert not (tmp_path / "x").exists()
    experiments.run(config.replace(births=2), tmp_path / "y", evaluator=SERIAL)
    with pytest.raises(ConfigError, match="learning table and infancy="):
        experiments.resume(tmp_path / "y", evaluator=SERIAL, infancy=other)
