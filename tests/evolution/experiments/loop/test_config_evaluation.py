"""The ``[evaluation]`` table of experiment configs, and runs under its conditions (real physics,
tiny runs): same seed and conditions, same database; today's conditions, today's numbers; noise
changes the numbers reproducibly, offline and online."""

from __future__ import annotations

import tomllib
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from experiment_fakes import dump_results as dump
from experiment_fakes import tiny_run

from evolution import experiments
from evolution.evaluation import EvalOutcome, EvalTask, LocalEvaluator, evaluate_task
from evolution.experiments import ConfigError, ExperimentConfig, load_config, preset
from evolution.experiments.loop.config import DEFAULT_EVALUATION
from evolution.experiments.loop.registry import shipped_config, shipped_configs
from revolve_env import IDEAL, EvaluationConditions

NOISE = {"sensor_noise": 0.1, "actuator_noise": 0.1}


# -- the table ---------------------------------------------------------------------------------

def test_the_default_is_a_random_heading_without_noise_offline_and_online() -> None:
    assert ExperimentConfig().evaluation == DEFAULT_EVALUATION == EvaluationConditions("random")
    assert ExperimentConfig.from_dict({}).evaluation == DEFAULT_EVALUATION
    assert ExperimentConfig.from_dict({"mode": "online"}).evaluation == DEFAULT_EVALUATION


@pytest.mark.parametrize("name", sorted(shipped_configs()))
def test_every_shipped_config_states_its_conditions(name: str) -> None:
    table = tomllib.loads(Path(shipped_config(name)).read_text(encoding="utf-8"))["evaluation"]
    assert table == {"heading": "random", "position_jitter": 0.0, "sensor_noise": 0.0,
                     "actuator_noise": 0.0}
    assert load_config(name).evaluation == DEFAULT_EVALUATION


def test_the_table_merges_over_presets_and_overrides(tmp_path: Path) -> None:
    path = tmp_path / "exp.toml"
    path.write_text('preset = "scenario1"\n[evaluation]\nheading = 1.5\nsensor_noise = 0.05\n')
    loaded = ExperimentConfig.from_toml(path)
    assert loaded.evaluation == EvaluationConditions(heading=1.5, sensor_noise=0.05)
    over = load_config(path, {"evaluation": {"heading": "random", "position_jitter": 0.2}})
    assert over.evaluation == EvaluationConditions("random", 0.2, 0.05, 0.0)
    assert load_config("scenario3", {"evaluation": {"heading": 0}}).evaluation == IDEAL
    assert ExperimentConfig.from_dict(over.to_dict()) == over
    assert over.to_dict()["evaluation"] == {"heading": "random", "position_jitter": 0.2,
                                            "sensor_noise": 0.05, "actuator_noise": 0.0}
    assert preset("quick", evaluation=IDEAL).evaluation == IDEAL


@pytest.mark.parametrize("table, message", [
    ({"heading": "north"}, "^evaluation.heading must be a number of radians or 'random'"),
    ({"heading": True}, "^evaluation.heading must be"),
    ({"position_jitter": -1.0}, "^evaluation.position_jitter must be a finite number >= 0"),
    ({"sensor_noise": "0.1"}, "^evaluation.sensor_noise must be a finite number >= 0"),
    ({"actuator_noise": float("inf")}, "^evaluation.actuator_noise must be"),
    ({"yaw": 1.0}, "^unknown evaluation config key\\(s\\): yaw; known keys: actuator_noise"),
])
def test_bad_conditions_name_the_key(table: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        ExperimentConfig.from_dict({"evaluation": table})


def test_a_bad_table_is_refused() -> None:
    with pytest.raises(ConfigError, match="evaluation must be a table"):
        ExperimentConfig.from_dict({"evaluation": "random"})
    with pytest.raises(ConfigError, match="evaluation must be an EvaluationConditions"):
        ExperimentConfig(evaluation={"heading": 0.0})  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="evaluation is a table: set its keys"):
        load_config("quick", {"evaluation": 0.0})


def test_the_training_center_learns_under_the_conditions() -> None:
    config = load_config("scenario1_learning", {"evaluation": {"heading": 0.5, **NOISE}})
    center = config.training_center()
    assert center is not None
    assert center.learner.evaluation.conditions == config.evaluation  # type: ignore[attr-defined]


# -- runs under conditions (real physics) -------------------------------------------------------

def tiny(mode: str, **evaluation: Any) -> ExperimentConfig:
    """A few seconds of real physics: 6 births, 1 s windows (robots of the shipped size: the
    small ones of the other tests barely move in 1 s, so neither heading nor noise shows)."""
    return tiny_run("scenario3" if mode == "online" else "scenario1", evaluation=evaluation)


def ideal_evaluate(task: EvalTask) -> EvalOutcome:
    """Today's offline evaluation before conditions: no conditions in the task."""
    return evaluate_task(replace(task, conditions=IDEAL))


def _run(config: ExperimentConfig, out: Path, function: Any = evaluate_task) -> dict[str, Any]:
    experiments.run(config, out, evaluator=LocalEvaluator(1, function))
    return dump(out / "results.sqlite")


def _fitness(results: dict[str, Any]) -> list[Any]:
    return results["fitness"]


@pytest.mark.parametrize("mode", ["offline", "online"])
def test_same_seed_and_conditions_give_the_same_database(tmp_path: Path, mode: str) -> None:
    config = tiny(mode, heading="random", position_jitter=0.1, **NOISE)
    assert _run(config, tmp_path / "a") == _run(config, tmp_path / "b")


def test_offline_heading_zero_is_todays_offline_evaluation(tmp_path: Path) -> None:
    """A config with heading 0 and no noise evaluates exactly as every offline run before the
    conditions existed; the random heading (the new default) moves the numbers."""
    fixed = _run(tiny("offline", heading=0.0), tmp_path / "fixed")
    assert fixed == _run(tiny("offline", heading="random"), tmp_path / "old", ideal_evaluate)
    assert _fitness(fixed) != _fitness(_run(tiny("offline", heading="random"),
                                            tmp_path / "random"))


@pytest.mark.parametrize("mode", ["offline", "online"])
def test_noise_moves_the_fitness_reproducibly(tmp_path: Path, mode: str) -> None:
    quiet = _run(tiny(mode, heading="random"), tmp_path / "quiet")
    noisy = _run(tiny(mode, heading="random", **NOISE), tmp_path / "noisy")
    assert _fitness(noisy) != _fitness(quiet)
    assert noisy == _run(tiny(mode, heading="random", **NOISE), tmp_path / "again")
    # Noise has its own generators: the same robots are born, at the same times.
    assert ([r[:3] for r in noisy["robots"]][:3] == [r[:3] for r in quiet["robots"]][:3])
