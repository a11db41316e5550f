"""One setting record: :class:`revolve_env.setting.Setting`, taken by evaluate and the envs."""

from __future__ import annotations

import ast
import dataclasses
import inspect
from pathlib import Path

import numpy as np
import pytest

import revolve_env
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.envs.locomotion import LocomotionEnv
from revolve_env.envs.population import PopulationEnv, PopulationOptions
from revolve_env.setting import Setting
from revolve_env.tasks import DirectedLocomotion, Locomotion
from revolve_env.terrain import Flat, Rugged
from revolve_env.world import DEFAULT_ENGINE, ENGINES, WorldConfig

ROOT = Path(__file__).resolve().parents[1]


def test_the_default_setting_is_mujoco_and_the_papers_evaluation() -> None:
    setting = Setting()
    assert setting.engine == DEFAULT_ENGINE == WorldConfig().engine == "mujoco"
    assert setting.terrain == Flat() and setting.task == Locomotion()
    assert setting.conditions == IDEAL and (setting.insertion, setting.seconds) == (3.0, 12.0)


def test_keywords_change_the_parts_they_name() -> None:
    base = Setting.of(engine="pybullet", terrain="rugged", seconds=2.0)
    changed = Setting.of(base, task="directed-locomotion", insertion=0.5, timing="revolve2018")
    assert changed.engine == "pybullet" and isinstance(changed.terrain, Rugged)
    assert isinstance(changed.task, DirectedLocomotion)
    assert (changed.insertion, changed.seconds) == (0.5, 2.0)
    assert changed.world.brain_period == pytest.approx(1 / 8)
    noisy = Setting.of(sensor_noise=0.1)
    assert noisy.conditions == EvaluationConditions(sensor_noise=0.1)
    assert dataclasses.replace(base, seconds=3.0).seconds == 3.0  # frozen: replace, not assign


@pytest.mark.parametrize(("make", "error", "match"), [
    (lambda: Setting(insertion=-1.0), ValueError, "insertion must be a finite number >= 0"),
    (lambda: Setting(seconds=float("nan")), ValueError, "seconds must be"),
    (lambda: Setting(world="mujoco"), TypeError, "world must be a WorldConfig"),  # type: ignore[arg-type]
    (lambda: Setting(conditions={}), TypeError, "conditions must be"),  # type: ignore[arg-type]
    (lambda: Setting.of(engine="bullet"), ValueError, "unknown physics engine 'bullet'"),
    (lambda: Setting.of(timing="fast"), ValueError, "unknown timing 'fast'"),
    (lambda: Setting.of(conditions=IDEAL, sensor_noise=0.1), ValueError, "not both"),
    (lambda: Setting.of(task="no-such-task"), ValueError, "no-such-task"),
])
def test_bad_parts_are_refused_in_one_line(make: object, error: type[Exception],
                                           match: str) -> None:
    with pytest.raises(error, match=match):
        make()  # type: ignore[operator]


def test_evaluate_takes_a_setting_or_the_keywords_that_build_it() -> None:
    spider = revolve_env.example("spider")
    setting = Setting.of(engine="pybullet", seconds=1.0, insertion=0.5,
                         conditions=EvaluationConditions(heading="random", sensor_noise=0.05))
    by_record = revolve_env.evaluate(spider, setting, seed=3)
    by_keywords = revolve_env.evaluate(spider, seed=3, engine="pybullet", seconds=1.0,
                                       insertion=0.5, conditions=setting.conditions)
    assert by_record.fitness == by_keywords.fitness
    np.testing.assert_array_equal(by_record.trajectory, by_keywords.trajectory)
    # A keyword beside the setting changes that part of it: here the engine.
    other = revolve_env.evaluate(spider, setting, seed=3, engine="mujoco")
    assert other.fitness != by_record.fitness
    [many] = revolve_env.evaluate_many([spider], setting, seeds=[3])
    assert many.fitness == by_record.fitness
    with pytest.raises(TypeError, match="unexpected keyword argument 'bogus'"):
        revolve_env.evaluate(spider, bogus=1)  # type: ignore[call-arg]


@pytest.mark.parametrize("function", [revolve_env.evaluate, revolve_env.evaluate_many,
                                      PopulationEnv.__init__])
def test_evaluate_and_the_population_env_take_at_most_ten_parameters(function: object) -> None:
    """The setting (and the env's options) carry the rest (issue 29's done-when).

    ``**keywords`` counts as one; ``self`` does not.
    """
    parameters = [name for name in inspect.signature(function).parameters  # type: ignore[arg-type]
                  if name != "self"]
    assert len(parameters) <= 10, parameters


def test_the_single_robot_env_takes_a_setting() -> None:
    setting = Setting.of(engine="pybullet", terrain="rugged", insertion=0.5, seconds=1.0,
                         task="directed-locomotion")
    env = LocomotionEnv(setting=setting)
    try:
        assert env.config == setting.world and env.task == setting.task
        assert (env.insertion_time, env.evaluation_time) == (0.5, 1.0)
        # a setting's conditions are the caller's: their start noise (0), not the env's 0.1
        assert env.conditions == setting.conditions and env.reset_noise_scale == 0.0
    finally:
        env.close()
    env = LocomotionEnv(setting=setting, engine="mujoco", evaluation_time=2.0)
    try:
        assert env.config.engine == "mujoco" and isinstance(env.config.terrain, Rugged)
        assert env.evaluation_time == 2.0
    finally:
        env.close()
    default = LocomotionEnv()
    try:  # without a setting: the env's defaults as before
        assert default.config.engine == "mujoco" and default.reset_noise_scale == 0.1
        assert (default.insertion_time, default.evaluation_time) == (3.0, 12.0)
    finally:
        default.close()


def test_the_population_env_takes_a_setting() -> None:
    setting = Setting.of(engine="pybullet", insertion=1.0, seconds=6.0, task="directed-locomotion")
    env = PopulationEnv(max_births=4, initial_robots=(), setting=setting)
    try:
        assert env.config.engine == "pybullet" and env.task == setting.task
        assert (env.insertion_time, env.fitness_window) == (1.0, 6.0)
        assert env.conditions == setting.conditions
    finally:
        env.close()
    with pytest.raises(TypeError, match="setting must be a Setting"):
        PopulationEnv(setting="mujoco")  # type: ignore[arg-type]


def _engine_defaults(path: Path) -> list[str]:
    """Where ``path`` gives an engine's name as a default (a parameter's or a field's)."""
    tree = ast.parse(path.read_text(), str(path))
    found = []

    def named(node: ast.expr | None) -> bool:
        return isinstance(node, ast.Constant) and node.value in ENGINES

    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            defaults = [*node.args.defaults, *node.args.kw_defaults]
            found += [f"{path}:{node.lineno} {node.name}" for d in defaults if named(d)]
        elif isinstance(node, ast.ClassDef):
            found += [f"{path}:{s.lineno} {node.name}" for s in node.body
                      if isinstance(s, ast.AnnAssign) and named(s.value)]
    return found


def test_no_engine_name_is_a_default_but_the_one_home() -> None:
    """Every ``engine=`` default means :data:`DEFAULT_ENGINE` (the setting's world's)."""
    found = [hit for package in ("revolve_env", "evolution")
             for path in sorted((ROOT / package).rglob("*.py")) for hit in _engine_defaults(path)]
    assert found == []


def test_the_population_env_takes_its_options_as_a_record_or_as_keywords() -> None:
    options = PopulationOptions(max_births=6, birth_radius=1.5, trajectory_length=0,
                                space_mode="uniform", proprioception=True)
    by_record = PopulationEnv((), Setting.of(engine="pybullet"), options)
    by_keywords = PopulationEnv(initial_robots=(), engine="pybullet", max_births=6,
                                birth_radius=1.5, trajectory_length=0, space_mode="uniform",
                                proprioception=True)
    # a keyword beside the record changes that option only
    changed = PopulationEnv(initial_robots=(), options=options, max_births=9)
    try:
        for env in (by_record, by_keywords):
            assert env.options == options and env.config.engine == "pybullet"
            assert (env.max_births, env.birth_radius, env.trajectory_length) == (6, 1.5, 0)
            assert env.space_mode == "uniform" and env.proprioception
            assert len(env.possible_agents) == 6
        assert changed.options == dataclasses.replace(options, max_births=9)
        assert changed.max_births == 9 and changed.birth_radius == 1.5
    finally:
        for env in (by_record, by_keywords, changed):
            env.close()
    with pytest.raises(TypeError, match="PopulationEnv\\(\\) got an unexpected keyword argument "
                                        "'bogus'"):
        PopulationEnv(bogus=1)  # type: ignore[call-arg]
    with pytest.raises(TypeError, match="options must be a PopulationOptions"):
        PopulationEnv(options={"max_births": 3})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="max_births must be an integer >= 1"):
        PopulationOptions(max_births=0)
