"""Results stored before the SB3 learner took revolve_env.rl's settings learn as they did.

Schema version 5 stored SB3 learning tables without ``normalize`` and ``settings``; until commit
dbfb7d7 such a table meant raw observations and rewards and SB3's own PPO defaults. Opened now, a
stored table gains ``normalize = false`` and ``settings = "sb3-defaults"``
(:data:`~evolution.experiments.store.schema.SB3_OF_OLD_RUNS`), and the learner built from it trains
to the numbers the old code gave (as floating point allows across machines), so a resumed run's
remaining infants learn as they would have in an uninterrupted run.
"""

from __future__ import annotations

import json
import sqlite3
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from evolution.experiments.store.database import Store
from evolution.learning import training_center_from_dict
from evolution.learning.policy_file import policy_digest
from revolve_env.body.examples import EXAMPLES
from revolve_env.tasks import make_task

pytest.importorskip("stable_baselines3")

IDEAL_TABLE = {"heading": 0.0, "position_jitter": 0.0, "sensor_noise": 0.0,
               "actuator_noise": 0.0}
# An SB3 table as a version-5 database stored it (before dbfb7d7): 4 PPO rollouts of 2 x 32
# steps of 1/30 s and the learner's two 1 s evaluations in a budget of 11 s.
OLD_TABLE: dict[str, Any] = {
    "learner": "sb3", "budget": 11.0, "n_envs": 2, "vec_env": "dummy", "insertion": 0.25,
    "seconds": 0.75, "control_period": 1 / 30, "conditions": IDEAL_TABLE,
    "algorithm_kwargs": {"n_steps": 32, "batch_size": 32}}

# What the code of dbfb7d7^ (the learner before the change) gave for OLD_TABLE with the action
# below: evolution.learning.config.training_center_from_dict(table).learner.learn(
# EXAMPLES["gecko"](), 11.0, np.random.default_rng(2018)), the policy's policy_digest, the
# training episodes' fitness, the inborn and learned fitness (metres); run in a worktree of
# dbfb7d7^ (torch 2.13 CPU, stable-baselines3 2.9). The same table trained with today's defaults
# (normalised, rl.ppo_settings) gives other numbers: digest 727a4db7..., learned 0.5865 m
# (modulate); f3056065..., 0.0008 m (targets).
OLD_CODE = {
    "modulate": {
        "digest": "c1d9a86d800528b6a3c9b15482ea44d392f9434854855f6598e480697f8c4dd1",
        "fitness": [0.41460312204684596, 0.5211720504558024, 0.33228183340108275,
                    0.3453515780141253, 0.5323373331835782, 0.21206527911556336,
                    0.4586374916218946, 0.21752181249675406],
        "inborn": 0.6311261484165301, "learned": 0.5414350543041007},
    "targets": {
        "digest": "8fbdb7dc648f785798f0b488500dfad63e7dcd386e6d879da930e82dc699256b",
        "fitness": [0.3916975617382236, 0.3371780790762319, 0.3203540146059628,
                    0.24554041652178968, 0.4388689445516558, 0.26969414301288075,
                    0.45535808796902866, 0.15008631355587426],
        "inborn": 0.6311261484165301, "learned": 0.00400099936345074},
}


def _version_5_store(path: Path, learning: dict[str, Any] | None) -> None:
    """A database as schema version 5 wrote it, its config holding ``learning``."""
    config: dict[str, Any] = {"name": "old", "births": 3, "mode": "offline",
                              "evaluation": IDEAL_TABLE}
    if learning is not None:
        config["learning"] = learning
    Store.create(path, config, 0).close()
    db = sqlite3.connect(path)
    db.execute("ALTER TABLE fitness DROP COLUMN shaking")  # added by schema 7
    db.execute("UPDATE meta SET value = '5' WHERE key = 'schema_version'")
    db.commit()
    db.close()


@pytest.fixture
def recorded_threads() -> Iterator[None]:
    """torch's intra-op threads as the numbers above were recorded (2), restored after.

    The sums of PPO's matrix products depend on them: with 1 thread the fitness differs from
    the second rollout on, by up to 4 % (index 2: 0.33228233 instead of 0.33228183 m), so the
    test must not take whatever a test before it in the same process left set."""
    torch = pytest.importorskip("torch")
    threads = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


@pytest.mark.parametrize("action", ["modulate", "targets"])
def test_a_stored_sb3_table_trains_to_the_old_codes_numbers(tmp_path: Path, action: str,
                                                            recorded_threads: None) -> None:
    path = tmp_path / "results.sqlite"
    _version_5_store(path, {**OLD_TABLE, "action": action})
    with Store.open(path) as store:
        table = store.config["learning"]
        task = store.config["task"]
        engine = store.config["world"]["engine"]
    # The engine it ran on (schema 8: pybullet, the default then), as the experiment hands it to
    # its learner (ExperimentConfig.training_center).
    assert engine == "pybullet"
    assert table == {**OLD_TABLE, "action": action, "normalize": False,
                     "settings": "sb3-defaults"}
    # The task an old run was scored with (schema 7): poses every control period, as the
    # experiment hands it to its learner (ExperimentConfig.fitness_task).
    assert task["pose_rate"] == "every-period"
    center = training_center_from_dict(table, engine=engine, task=make_task(task))
    result = center.learner.learn(EXAMPLES["gecko"](), table["budget"],
                                  np.random.default_rng(2018))
    old = OLD_CODE[action]
    assert result.policy is not None and result.policy.normalization is None
    # Recorded on another machine: the same numbers as floating point allows (another CPU or
    # BLAS build may round the last digits of a matrix product differently), so neither bit
    # for bit nor the parameters' digest, which any last-digit difference changes.
    assert list(result.fitness) == pytest.approx(old["fitness"], rel=1e-6)
    assert result.inborn_fitness == pytest.approx(old["inborn"], rel=1e-6)
    assert result.best_fitness == pytest.approx(old["learned"], rel=1e-6, abs=1e-9)
    if list(result.fitness) == old["fitness"]:  # this machine rounds as the recording one did
        assert policy_digest(result.policy) == old["digest"]


@pytest.mark.parametrize(("stored", "expected"), [
    ({"learner": "sb3", "budget": 90.0},
     {"learner": "sb3", "budget": 90.0, "normalize": False, "settings": "sb3-defaults"}),
    # Keys already there are kept (a table written by hand for the new learner).
    ({"learner": "sb3", "budget": 90.0, "normalize": True},
     {"learner": "sb3", "budget": 90.0, "normalize": True, "settings": "sb3-defaults"}),
    ({"learner": "sb3", "budget": 90.0, "settings": "benchmark"},
     {"learner": "sb3", "budget": 90.0, "normalize": False, "settings": "benchmark"}),
    # Other learners, and runs without learning, are not touched.
    ({"learner": "cma-es", "budget": 90.0}, {"learner": "cma-es", "budget": 90.0}),
    (None, None),
])
def test_version_5_upgrade_pins_only_old_sb3_tables(
        tmp_path: Path, stored: dict[str, Any] | None, expected: dict[str, Any] | None) -> None:
    path = tmp_path / "results.sqlite"
    _version_5_store(path, stored)
    with Store.open(path) as store:
        assert store.meta()["schema_version"] == "8"
        assert store.config.get("learning") == expected
        config = store.config
    with Store.open(path) as store:  # opening again changes nothing more
        assert store.config == config
    db = sqlite3.connect(path)
    try:
        (text,) = db.execute("SELECT value FROM meta WHERE key = 'config'").fetchone()
    finally:
        db.close()
    assert json.loads(text) == config  # upgraded in place


def test_sb3_defaults_skip_the_benchmark_settings() -> None:
    """SB3's PPO rollout is 2048 steps per env; the benchmark's, 128."""
    table = {"learner": "sb3", "budget": 90.0, "seconds": 4.0, "insertion": 0.5}
    old = training_center_from_dict({**table, "settings": "sb3-defaults"}).learner
    new = training_center_from_dict(table).learner
    assert old.min_budget == pytest.approx(2048 * 2 / 60 + 9.0)
    assert new.min_budget == pytest.approx(128 * 2 / 60 + 9.0)


def test_an_unknown_settings_name_is_refused() -> None:
    with pytest.raises(ValueError, match="settings must be 'benchmark' or 'sb3-defaults', got "
                                         "'fast'"):
        training_center_from_dict({"learner": "sb3", "budget": 90.0, "settings": "fast"})
