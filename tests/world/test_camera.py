"""Both engines film a camera alike, and :func:`project` says where things are in the picture."""

from __future__ import annotations

import numpy as np
import pytest

from revolve_env import example
from revolve_env.world import World, WorldConfig
from revolve_env.world.camera import project


def test_project_puts_the_target_in_the_middle_and_hides_what_is_behind() -> None:
    px = project([[1.0, 2.0, 0.0], [1.0, 2.0, 50.0]], 480, 360, (1.0, 2.0, 0.0), 2.0, 30.0,
                 -40.0)
    assert np.allclose(px[0], [240.0, 180.0])
    assert np.isnan(px[1]).all()  # 50 m up: behind a camera looking down


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
@pytest.mark.parametrize("camera", [(2.0, 30.0, -40.0), (3.0, 0.0, -89.9), (2.5, 120.0, -25.0)])
def test_a_robot_is_drawn_where_project_says(engine: str,
                                             camera: tuple[float, float, float]) -> None:
    if engine == "mujoco":
        pytest.importorskip("mujoco")
        from revolve_env.world.opengl import render_problem

        if render_problem() is not None:
            pytest.skip("MuJoCo cannot render here")
    distance, yaw, pitch = camera
    with World(WorldConfig(engine=engine)) as world:
        handle = world.add_robot(example("spider"), (0.5, 0.3), 0.0)
        world.step(30)
        frame = world.render(240, 180, (0.0, 0.0, 0.0), distance, yaw, pitch).astype(int)
        core = world.core_position(handle)
    ys, xs = np.nonzero(np.ptp(frame, axis=2) > 60)  # the robot: coloured, the ground grey
    at = project(core[None], 240, 180, (0.0, 0.0, 0.0), distance, yaw, pitch)[0]
    assert np.hypot(xs.mean() - at[0], ys.mean() - at[1]) < 4.0  # pixels
