"""pybullet keeps every shape it made: links of the same geometry share theirs."""

from __future__ import annotations

from typing import Any

from world_robots import every_part, snake, spider

from revolve_env import example
from revolve_env.world import World, WorldConfig


def test_births_of_known_link_geometries_make_no_new_shapes() -> None:
    with World(WorldConfig(engine="pybullet")) as world:
        backend: Any = world.backend
        robots = [spider(), snake(), every_part(), example("gecko")]
        for i, robot in enumerate(robots):
            world.add_robot(robot, position=(1.5 * i, 0.0))
        world.step(5)
        made = len(backend._shape_cache)
        links = sum(len(backend._bodies[k].model.links) for k in backend._bodies)
        assert made < links  # a spider's four legs are one geometry
        for round_ in range(3):
            for i, robot in enumerate(robots):
                world.remove_robot(world.handles[0])
                world.add_robot(robot, position=(1.5 * i, 2.0 + round_))
            world.step(5)
        assert len(backend._shape_cache) == made
        assert world.body_count() == 1 + len(robots)
        for h in world.handles:
            assert world.blow_up(h) is None
        world.reset()
        assert backend._shape_cache == {}  # resetSimulation released them
