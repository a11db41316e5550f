"""An experiment config's setting record: what its evaluations and worlds simulate."""

from __future__ import annotations

from evolution.experiments.loop.config import ExperimentConfig, load_config
from revolve_env.conditions import EvaluationConditions
from revolve_env.setting import Setting
from revolve_env.tasks import DirectedLocomotion
from revolve_env.terrain import Rugged


def test_the_setting_carries_the_configs_world_task_conditions_and_times() -> None:
    config = load_config("quick", {"world": {"engine": "pybullet", "terrain": "rugged"},
                                   "task": {"name": "directed-locomotion"},
                                   "evaluation": {"sensor_noise": 0.05},
                                   "insertion": 1.0, "evaluation_time": 6.0, "fertile_age": 7.0})
    setting = config.setting()
    assert setting.engine == "pybullet" and isinstance(setting.terrain, Rugged)
    assert isinstance(setting.task, DirectedLocomotion)
    assert setting.conditions == EvaluationConditions(heading="random", sensor_noise=0.05)
    assert (setting.insertion, setting.seconds) == (1.0, 6.0)


def test_a_shipped_config_runs_on_the_default_engine() -> None:
    """The shipped configs name MuJoCo, the default since 2026-11-27 (Setting's)."""
    assert load_config("scenario1").setting().engine == Setting().engine == "mujoco"
    assert ExperimentConfig().world.engine == "mujoco"
