"""Named cameras and frame sizes of the single-robot env (issue 31), checked before any physics."""

from __future__ import annotations

import numpy as np
import pytest

from revolve_env.cameras import CAMERAS, Camera, check_size, make_camera
from revolve_env.envs import LocomotionEnv


def test_names_and_cameras() -> None:
    assert make_camera("track") == Camera() == CAMERAS["track"]
    custom = Camera(distance=2.0, yaw=90.0, pitch=-10.0, track=False)
    assert make_camera(custom) is custom
    with pytest.raises(ValueError, match="camera must be a Camera or one of track, far"):
        make_camera("nowhere")
    for bad in ({"distance": 0.0}, {"distance": float("nan")}, {"pitch": -90.0},
                {"yaw": float("inf")}):
        with pytest.raises(ValueError, match="camera"):
            Camera(**bad)  # type: ignore[arg-type]


def test_sizes() -> None:
    assert check_size(480, 360) == (480, 360)
    assert check_size(np.int64(64), 48) == (64, 48)
    for width, height in ((0, 360), (480, -1), (4.5, 360), ("480", 360), (True, 360),
                          (480, 100_000)):
        with pytest.raises(ValueError, match="must be a whole number of pixels"):
            check_size(width, height)  # type: ignore[arg-type]


def test_the_env_refuses_a_bad_size_or_camera_by_name() -> None:
    with pytest.raises(ValueError, match="height must be"):
        LocomotionEnv(render_mode="rgb_array", height=0)
    with pytest.raises(ValueError, match="camera must be"):
        LocomotionEnv(render_mode="rgb_array", camera="nowhere")


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_frames_have_the_size_and_camera_asked(engine: str) -> None:
    if engine == "mujoco":
        pytest.importorskip("mujoco")
        from revolve_env.world.opengl import render_problem

        if render_problem() is not None:
            pytest.skip("MuJoCo cannot render here")
    frames = {}
    for camera in ("track", "top", "fixed"):
        env = LocomotionEnv(render_mode="rgb_array", engine=engine, width=96, height=64,
                            camera=camera, controller="brain", insertion_time=0.0,
                            evaluation_time=1.0)
        env.reset(seed=0)
        for _ in range(30):
            env.step(env.action_space.sample())
        frame = env.render()
        env.close()
        assert frame is not None and frame.shape == (64, 96, 3)
        frames[camera] = frame
    assert not np.array_equal(frames["track"], frames["top"])
    assert not np.array_equal(frames["track"], frames["fixed"])
