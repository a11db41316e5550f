"""Isolated worlds: each robot in a scene of its own moves exactly as in a world of its own."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from world_robots import every_part, snake, spider

from revolve_env.body.examples import sensor_crawler
from revolve_env.world import World, WorldConfig

ENGINES = ["pybullet", "mujoco"]


def _config(engine: str) -> WorldConfig:
    if engine == "mujoco":
        pytest.importorskip("mujoco", reason="the mujoco package is not installed")
    return WorldConfig(engine=engine)


def _targets(i: int, n: int, phase: float) -> np.ndarray:
    return np.sin(2 * np.pi * i / 60 + phase + np.arange(n))


@pytest.mark.parametrize("engine", ENGINES)
def test_robots_side_by_side_move_as_each_alone_through_births_and_deaths(engine: str) -> None:
    """Every robot at the origin (they would overlap in one scene): positions, sensors (IMU,
    touch, light on the core and on moving links) and hinges equal a world of its own's."""
    config = _config(engine)
    robots = [every_part(), sensor_crawler(), spider(), snake(3)]

    def alone(k: int, periods: range) -> list[np.ndarray]:
        with World(config) as world:
            h = world.add_robot(robots[k], yaw=0.5 * k)
            out = []
            for i in range(periods.stop):
                world.set_targets(h, _targets(i, world.n_outputs(h), k))
                world.step()
                if i in periods:
                    out.append(np.concatenate([world.core_position(h), world.read_sensors(h),
                                               world.joint_angles(h)]))
            return out

    with World(config, isolated=True) as world:
        handles = {k: world.add_robot(robots[k], yaw=0.5 * k) for k in range(3)}
        seen: dict[int, list[np.ndarray]] = {k: [] for k in range(4)}
        for i in range(40):
            if i == 12:
                world.remove_robot(handles.pop(1))
            if i == 20:
                with pytest.raises(ValueError):  # tried and refused: the others go on
                    world.set_targets(handles[0], np.zeros(99))
            world.set_all_targets(np.concatenate([_targets(i, world.n_outputs(h), k)
                                                  for k, h in handles.items()]))
            world.step()
            for k, h in handles.items():
                seen[k].append(np.concatenate([world.core_position(h), world.read_sensors(h),
                                               world.joint_angles(h)]))
        assert world.body_count() == 3 and world.total_mass(handles[2]) > 0
        with pytest.raises(NotImplementedError):
            world.snapshot()
    for k, periods in ((0, range(40)), (2, range(40)), (1, range(12))):
        np.testing.assert_array_equal(np.array(seen[k]), np.array(alone(k, periods)))


def test_a_diverging_scene_is_replayed_as_alone_and_the_others_never_notice(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("mujoco", reason="the mujoco package is not installed")
    monkeypatch.chdir(tmp_path)  # MuJoCo logs its NaN warning to ./MUJOCO_LOG.TXT
    config = WorldConfig(engine="mujoco")

    def poison(world: World, k: int) -> None:
        """A force that makes the robot's dynamics NaN from its next physics step on."""
        backend = world.backend
        scene = list(backend._scenes.values())[k] if hasattr(backend, "_scenes") else backend
        scene._data.xfrc_applied[2, 0] = np.nan  # on a leg of that robot

    def run(isolated: bool, robots: list[int], poisoned: int | None) -> list[np.ndarray]:
        with World(config, isolated=isolated) as world:
            hs = [world.add_robot(spider(), position=(float(k), 0.0)) for k in robots]
            out = []
            for i in range(20):
                if i == 10 and poisoned is not None:
                    poison(world, poisoned)
                world.set_all_targets(np.concatenate([_targets(i, 8, k) for k in robots]))
                world.step()
                out.append(np.concatenate([world.core_position(h) for h in hs]
                                          + [[world.blow_up(h) is not None for h in hs]]))
            return out

    together = np.array(run(True, [0, 1], poisoned=1))
    calm = np.array(run(False, [0], poisoned=None))
    bad = np.array(run(False, [1], poisoned=0))
    np.testing.assert_array_equal(together[:, [0, 1, 2, 6]], calm)
    np.testing.assert_array_equal(together[:, [3, 4, 5, 7]], bad)
    assert together[-1, 7] == 1.0 and together[-1, 6] == 0.0
