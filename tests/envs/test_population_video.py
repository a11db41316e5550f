"""PopulationEnv rendering and the video helper."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from revolve_env.body.examples import gecko, snake
from revolve_env.body.robot import Node, Robot
from revolve_env.envs.population import PopulationEnv, population_env
from revolve_env.envs.video import mp4_available, record_video, write_video


def _painted(robot: Robot, color: tuple[float, float, float]) -> Robot:
    def paint(node: Node) -> Node:
        return replace(node, color=color,
                       children=tuple((slot, paint(child)) for slot, child in node.children))

    return replace(robot, body=paint(robot.body))


def _share(img: np.ndarray, channel: int) -> float:
    """Fraction of pixels strongly of one primary colour's hue (parts are drawn lighter or
    darker by type, :func:`revolve_env.world.model.drawn_colors`)."""
    c = img.astype(int)
    main = c[..., channel]
    others = [k for k in range(3) if k != channel]
    return float(np.mean((main > 120) & (c[..., others[0]] < 0.6 * main)
                         & (c[..., others[1]] < 0.6 * main)))


@pytest.mark.parametrize("view", ["top", "chase"])
def test_render_shows_each_robot_in_its_colour(view: str) -> None:
    env = population_env(render_mode="rgb_array", render_view=view, render_size=(160, 120),
                         initial_robots=[])
    env.reset(seed=0)
    empty = env.render()
    assert empty is not None and empty.shape == (120, 160, 3) and empty.dtype == np.uint8
    assert _share(empty, 1) == 0.0 and _share(empty, 0) == 0.0
    green = env.add_robot(_painted(gecko(), (0.0, 1.0, 0.0)), (-0.5, 0.0))
    env.add_robot(_painted(snake(3), (1.0, 0.0, 0.0)), (0.5, 0.0))
    img = env.render()
    assert _share(img, 1) > 0.002 and _share(img, 0) > 0.001
    env.remove_robot(green)
    img = env.render()
    assert _share(img, 1) == 0.0 and _share(img, 0) > 0.001


def test_no_render_mode_renders_nothing() -> None:
    env = population_env(initial_robots=[snake(2)])
    env.reset(seed=0)
    assert env.render() is None


def test_write_gif_round_trip(tmp_path: Path) -> None:
    frames = [np.full((8, 10, 3), k * 40, np.uint8) for k in range(4)]
    out = write_video(frames, tmp_path / "v.gif", fps=10)
    with Image.open(out) as im:
        assert im.n_frames == 4 and im.size == (10, 8)
        im.seek(3)
        assert np.asarray(im.convert("RGB"))[0, 0, 0] == 120


def test_mp4_without_ffmpeg_falls_back_to_gif(tmp_path: Path) -> None:
    frames = [np.zeros((8, 8, 3), np.uint8)] * 2
    if mp4_available():
        assert write_video(frames, tmp_path / "v.mp4") == tmp_path / "v.mp4"
    else:
        with pytest.warns(UserWarning, match="writing a GIF instead"):
            assert write_video(frames, tmp_path / "v.mp4") == tmp_path / "v.gif"
        assert (tmp_path / "v.gif").exists()


def test_write_video_rejects_bad_frames(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no frames"):
        write_video([], tmp_path / "v.gif")
    with pytest.raises(ValueError, match="frame 1"):
        write_video([np.zeros((4, 4, 3), np.uint8), np.zeros((5, 4, 3), np.uint8)],
                    tmp_path / "v.gif")
    with pytest.raises(ValueError, match=".gif or .mp4"):
        write_video([np.zeros((4, 4, 3), np.uint8)], tmp_path / "v.avi")


def test_record_video_of_a_run_with_a_birth(tmp_path: Path) -> None:
    env = population_env(render_size=(64, 48), initial_robots=[snake(2)])
    env.reset(seed=0)

    def policy(e: PopulationEnv) -> dict:
        if e.time > 0.1 and len(e.agents) == 1:
            e.add_robot(snake(2))
        return {}

    out = record_video(env, tmp_path / "run.gif", steps=12, every=4, policy=policy)
    with Image.open(out) as im:
        assert im.n_frames == 4 and im.size == (64, 48)
    assert env.agents == ["robot_0", "robot_1"]


def test_float_frames_are_refused_rather_than_written_black(tmp_path: Path) -> None:
    frames = [np.full((8, 8, 3), 0.5)] * 2
    with pytest.raises(ValueError, match="uint8"):
        write_video(frames, tmp_path / "v.gif", fps=10)
