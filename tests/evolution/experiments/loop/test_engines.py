"""Experiments on either physics engine: ``world.engine`` selects it, is stored with the results,
and a killed MuJoCo run resumes to the uninterrupted run's numbers (real physics, tiny runs)."""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import Kill, kill_after, small, tiny_run
from experiment_fakes import dump_results as dump

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ConfigError, ExperimentConfig, load_config
from evolution.experiments.store.database import Store
from evolution.reporting import report

pytest.importorskip("mujoco", reason="the mujoco package is not installed")


def tiny(name: str, **changes: Any) -> ExperimentConfig:
    return small(tiny_run(name, births=8, world={"engine": "mujoco"}, **changes))


def test_world_engine_is_one_config_key_stored_with_the_results(tmp_path: Path) -> None:
    config = load_config("quick", {"world": {"engine": "pybullet"}})
    assert config.world.engine == "pybullet" and config.to_dict()["world"] == {"engine": "pybullet"}
    assert ExperimentConfig.from_dict(config.to_dict()) == config
    assert load_config("quick").world.engine == "mujoco"  # the default since 2026-11-27
    with pytest.raises(ConfigError, match="world.engine must be one of"):
        load_config("quick", {"world": {"engine": "ode"}})
    with pytest.raises(ConfigError, match="unknown world config key"):
        load_config("quick", {"world": {"gravity": 1.0}})


@pytest.mark.parametrize("name", ["scenario1", "scenario3"])
def test_a_killed_mujoco_run_resumes_to_the_same_numbers(tmp_path: Path, name: str) -> None:
    config = tiny(name)
    serial = LocalEvaluator(1)
    experiments.run(config, tmp_path / "ref", evaluator=serial)
    with Store.open(tmp_path / "ref" / "results.sqlite") as store:
        assert store.config["world"] == {"engine": "mujoco"}
    with pytest.raises(Kill):
        experiments.run(config, tmp_path / "killed", kill_after(3), evaluator=serial)
    experiments.resume(tmp_path / "killed", evaluator=serial)
    assert dump(tmp_path / "killed" / "results.sqlite") == dump(tmp_path / "ref" / "results.sqlite")
    written = report(tmp_path, formats=("png",))
    assert len(written.experiments) == 2 and all(p.is_file() for p in written.figures)


def test_a_killed_noisy_mujoco_online_run_resumes_to_the_same_numbers(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """The population env's noise generator is part of its snapshot: with sensor and actuator
    noise on, a resumed run continues from the snapshot (no replay) bit for bit."""
    config = tiny("scenario3", evaluation={"sensor_noise": 0.1, "actuator_noise": 0.1})
    serial = LocalEvaluator(1)
    experiments.run(config, tmp_path / "ref", evaluator=serial)
    with pytest.raises(Kill):
        experiments.run(config, tmp_path / "killed", kill_after(3), evaluator=serial)
    with caplog.at_level(logging.WARNING):
        experiments.resume(tmp_path / "killed", evaluator=serial)
    assert "replaying" not in caplog.text
    assert dump(tmp_path / "killed" / "results.sqlite") == dump(tmp_path / "ref" / "results.sqlite")


def test_the_engines_give_different_but_valid_runs(tmp_path: Path) -> None:
    """The same seed on both engines: both runs finish with finite fitness; the numbers differ
    (different physics), so the engine really is the one the config names."""
    mujoco = tiny("scenario1")
    pybullet = small(mujoco.replace(world=type(mujoco.world)(engine="pybullet")))
    experiments.run(mujoco, tmp_path / "mujoco", evaluator=LocalEvaluator(1))
    experiments.run(pybullet, tmp_path / "pybullet", evaluator=LocalEvaluator(1))
    a = dump(tmp_path / "mujoco" / "results.sqlite")["fitness"]
    b = dump(tmp_path / "pybullet" / "results.sqlite")["fitness"]
    assert a and b and a != b
