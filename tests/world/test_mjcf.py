"""World.to_mjcf: MuJoCo's MJCF of the scene compiles to the very model the world steps."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pytest
from world_robots import every_part, lone_core, snake, spider

from revolve_env import example
from revolve_env.world import World, WorldConfig, engines
from revolve_env.world.backend import EngineUnavailableError

mujoco = pytest.importorskip("mujoco", reason="the mujoco package is not installed")

MJ = WorldConfig(engine="mujoco")
FULL = mujoco.mjtState.mjSTATE_FULLPHYSICS


def _mjb(m: Any) -> bytes:
    buffer = np.zeros(mujoco.mj_sizeModel(m), dtype=np.uint8)
    mujoco.mj_saveModel(m, None, buffer)
    return buffer.tobytes()


def _busy(world: World) -> None:
    """Births, deaths (some pending), touching robots, a robot beyond the 30 collision bits."""
    robots = [every_part(), spider(), snake(), example("gecko"), lone_core()]
    handles = [world.add_robot(r, position=(0.25 * i, 0.1 * (i % 2)), yaw=0.7 * i)
               for i, r in enumerate(robots)]
    world.step(20)
    world.remove_robot(handles[1])
    world.add_robot(example("sensor_crawler"), position=(2.0, 0.0), yaw=1.0)
    world.step(5)
    world.remove_robot(handles[3])


def test_a_mujoco_worlds_mjcf_compiles_to_the_model_it_steps_and_steps_the_same() -> None:
    with World(MJ) as world:
        _busy(world)
        text = world.to_mjcf()
        world.step(1)  # compiles the pending death
        model = world.backend._model  # type: ignore[attr-defined]
        data = world.backend._data  # type: ignore[attr-defined]
        exported = mujoco.MjModel.from_xml_string(text)
        assert _mjb(exported) == _mjb(model)  # every array, name and option
        state = np.empty(mujoco.mj_stateSize(model, FULL))
        mujoco.mj_getState(model, data, state, FULL)
        twin = mujoco.MjData(exported)
        mujoco.mj_setState(exported, twin, state, FULL)
        mine = mujoco.MjData(model)
        mujoco.mj_setState(model, mine, state, FULL)
        for _ in range(60):
            mine.ctrl[:] = twin.ctrl[:] = np.sin(mine.time * 7 + np.arange(model.nu))
            mujoco.mj_step(model, mine, 4)
            mujoco.mj_step(exported, twin, 4)
        np.testing.assert_array_equal(twin.qpos, mine.qpos)
        np.testing.assert_array_equal(twin.qvel, mine.qvel)
        assert "<velocity" in text and "r0/b0" in text


def test_a_pybullet_worlds_mjcf_is_the_mujoco_world_of_its_robots() -> None:
    robots = [(spider(), (0.0, 0.0), 0.3), (snake(), (1.0, 0.5), -1.0),
              (every_part(), (-1.0, 0.2), 2.0)]
    texts = []
    for engine in ("pybullet", "mujoco"):
        with World(WorldConfig(engine=engine)) as world:
            for robot, xy, yaw in robots:
                world.add_robot(robot, position=xy, yaw=yaw)
            texts.append(world.to_mjcf())
    assert texts[0] == texts[1]
    with World(MJ) as world:
        for robot, xy, yaw in robots:
            world.add_robot(robot, position=xy, yaw=yaw)
        model = world.backend._model  # type: ignore[attr-defined]
        assert _mjb(mujoco.MjModel.from_xml_string(texts[0])) == _mjb(model)


def test_an_isolated_world_is_no_one_mjcf_scene() -> None:
    with World(MJ, isolated=True) as world:
        world.add_robot(spider())
        with pytest.raises(NotImplementedError, match="a scene per robot"):
            world.to_mjcf()


def test_without_mujoco_the_export_is_one_clear_error(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(engines, "TABLE", tuple(
        dataclasses.replace(e, package="no_such_mujoco", pip="no_such_mujoco")
        if e.name == "mujoco" else e for e in engines.TABLE))
    with World(WorldConfig(engine="pybullet")) as world:
        world.add_robot(spider())
        with pytest.raises(EngineUnavailableError, match="pip install no_such_mujoco"):
            world.to_mjcf()


def test_evaluation_mjcf_is_the_model_evaluate_steps(monkeypatch: pytest.MonkeyPatch) -> None:
    import revolve_env.evaluation as evaluation
    from revolve_env import EvaluationConditions, evaluate
    from revolve_env.evaluation import evaluation_mjcf

    stepped: list[bytes] = []

    class Recording(World):
        def add_robot(self, *args: Any, **kwargs: Any) -> int:
            handle = super().add_robot(*args, **kwargs)
            # evaluate's world is isolated: the robot's scene of its own, compiled as stepped (by
            # World.step or by the compiled rollout, which steps that scene's own model)
            (scene,) = self.backend._scenes.values()  # type: ignore[attr-defined]
            stepped.append(_mjb(scene._model))
            return handle

    monkeypatch.setattr(evaluation, "World", Recording)
    turned = EvaluationConditions(heading="random", position_jitter=0.3)
    evaluate(spider(), seed=7, seconds=0.1, insertion=0.0, engine="mujoco", conditions=turned)
    monkeypatch.undo()
    text = evaluation_mjcf(spider(), 7, conditions=turned)
    assert _mjb(mujoco.MjModel.from_xml_string(text)) == stepped[0]
    assert text != evaluation_mjcf(spider(), 8, conditions=turned)  # another start
