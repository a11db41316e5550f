"""The world's one pass over all robots: flat sensors and targets, equal to the per-robot calls."""

from __future__ import annotations

import math

import numpy as np
import pytest
from world_robots import every_part, snake, spider
from world_views import hinge_targets

from revolve_env.body.examples import sensor_crawler
from revolve_env.world import World, WorldConfig

ENGINES = ["pybullet", "mujoco"]


def _world(engine: str) -> World:
    if engine == "mujoco":
        pytest.importorskip("mujoco", reason="the mujoco package is not installed")
    return World(WorldConfig(engine=engine))


@pytest.mark.parametrize("engine", ENGINES)
def test_flat_sensors_and_hinges_are_every_robots_own_one_after_the_other(engine: str) -> None:
    """Robots touching the ground, each other and facing the light; a death and a birth."""
    with _world(engine) as world:
        hs = [world.add_robot(r, position=(0.25 * i, 0.0), yaw=0.7 * i)
              for i, r in enumerate([every_part(), sensor_crawler(), spider(), every_part()])]
        rng = np.random.default_rng(0)
        for k in range(40):
            if k == 15:
                world.remove_robot(hs.pop(1))
            if k == 25:
                hs.append(world.add_robot(sensor_crawler(), position=(-0.4, 0.3)))
            world.set_all_targets(rng.uniform(-1, 1, world.output_offsets[-1]))
            world.step(1)
            flat = world.sensor_values()
            assert not flat.flags.writeable
            np.testing.assert_array_equal(flat, np.concatenate([world.read_sensors(h)
                                                                for h in hs]))
            offsets = world.input_offsets
            assert [int(b - a) for a, b in zip(offsets[:-1], offsets[1:], strict=True)] == \
                [world.n_inputs(h) for h in hs]
            np.testing.assert_array_equal(world.hinge_angles(),
                                          np.concatenate([world.joint_angles(h) for h in hs]))
            np.testing.assert_array_equal(world.hinge_velocities(), np.concatenate(
                [world.joint_velocities(h) for h in hs]))
        touch = flat[world.input_offsets[0] + 7:world.input_offsets[0] + 9]
        assert set(touch.tolist()) <= {0.0, 1.0}


@pytest.mark.parametrize("engine", ENGINES)
def test_setting_all_targets_at_once_is_setting_each_robots(engine: str) -> None:
    with _world(engine) as a, _world(engine) as b:
        ha = [a.add_robot(r, position=(i, 0.0)) for i, r in enumerate([spider(), snake(3)])]
        hb = [b.add_robot(r, position=(i, 0.0)) for i, r in enumerate([spider(), snake(3)])]
        values = np.linspace(-1.5, 1.5, a.output_offsets[-1])
        a.set_all_targets(values)
        b.set_targets(hb[0], values[:8])
        b.set_targets(hb[1], values[8:])
        np.testing.assert_array_equal(a.targets, b.targets)
        np.testing.assert_array_equal(hinge_targets(a, ha[1]), hinge_targets(b, hb[1]))
        assert np.abs(a.targets).max() == pytest.approx(math.radians(45.0))
        a.step(20)
        b.step(20)
        np.testing.assert_array_equal(a.states.core_pos, b.states.core_pos)
        with pytest.raises(ValueError, match="every active hinge"):
            a.set_all_targets(values[:3])


@pytest.mark.parametrize("engine", ENGINES)
def test_a_non_finite_entry_blows_up_its_robot_only_and_holds_its_hinges(engine: str) -> None:
    with _world(engine) as world:
        first, second = world.add_robot(spider()), world.add_robot(snake(3), position=(1.0, 0))
        index = np.arange(world.output_offsets[-1])
        values = np.full(index.shape, 0.5)
        values[9] = np.nan  # the snake's second hinge
        world.set_target_entries(index, values)
        assert world.blow_up(first) is None
        reason = world.blow_up(second)
        assert reason is not None and "non-finite hinge targets" in reason
        assert world.blown_up.tolist() == [False, True]
        assert not world.blown_up.flags.writeable
        np.testing.assert_array_equal(hinge_targets(world, first),
                                      np.full(8, 0.5 * math.radians(45.0)))
        assert not hinge_targets(world, second).any()
        world.set_target_entries(index[:2], np.array([1.0, -1.0]))  # a part of the first
        assert hinge_targets(world, first)[:2].tolist() == [math.radians(45.0),
                                                            -math.radians(45.0)]
