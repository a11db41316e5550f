"""Robot videos: exact timing, and evolved robots drawn with their parts apart."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from revolve_env.body.examples import sensor_crawler, spider
from revolve_env.body.geometry import assemble
from revolve_env.body.robot import Node, PartType, Robot
from revolve_env.envs.locomotion import LocomotionEnv
from revolve_env.envs.recording import record_robot
from revolve_env.envs.video import gif_delays, write_video
from revolve_env.world.model import build_model, drawn_colors, part_color


def _painted(robot: Robot, color: tuple[float, float, float]) -> Robot:
    """Every part in one colour, as evolution leaves a lineage."""
    def paint(node: Node) -> Node:
        return replace(node, color=color,
                       children=tuple((slot, paint(child)) for slot, child in node.children))

    return replace(robot, body=paint(robot.body))


def _gif_durations(path: Path) -> list[int]:
    with Image.open(path) as gif:
        out = []
        for k in range(gif.n_frames):
            gif.seek(k)
            out.append(int(gif.info["duration"]))
        return out


@pytest.mark.parametrize("fps", [15.0, 30.0, 1 / 0.07, 7.0, 50.0])
def test_gif_delays_add_up_to_the_clock(fps: float) -> None:
    for frames in (1, 2, 29, 300):
        delays = gif_delays(frames, fps)
        assert all(d % 10 == 0 and d >= 20 for d in delays)
        assert abs(sum(delays) / 1000 - frames / fps) <= 0.005


def test_written_gif_lasts_as_long_as_the_frames(tmp_path: Path) -> None:
    frames = [np.full((6, 8, 3), 3 * k, np.uint8) for k in range(45)]
    out = write_video(frames, tmp_path / "v.gif", fps=30.0)
    durations = _gif_durations(out)
    assert len(durations) == 45
    # 1.5 s: 3.33 cs a frame; one rounded delay for every frame (3 cs) would play 10 % fast.
    assert sum(durations) == 1500


def test_a_gif_faster_than_50_fps_is_refused(tmp_path: Path) -> None:
    frames = [np.zeros((4, 4, 3), np.uint8)] * 3
    with pytest.raises(ValueError, match="at most 50"):
        write_video(frames, tmp_path / "v.gif", fps=60.0)


def test_robot_video_plays_for_the_simulated_time(tmp_path: Path) -> None:
    video = record_robot(spider(), tmp_path / "s.gif", seconds=1.0, insertion=0.5, fps=15.0)
    durations = _gif_durations(video.path)
    assert len(durations) == video.frames
    assert video.seconds == pytest.approx(1.5)
    # Frames every 4 control periods of 1/60 s (1/15 s); the last one shows the end.
    assert abs(sum(durations) / 1000 - video.seconds) <= 1 / 15


def test_the_video_fitness_is_the_isolated_evaluation(tmp_path: Path) -> None:
    from revolve_env import evaluate

    video = record_robot(spider(), tmp_path / "s.gif", seconds=1.0, insertion=0.5, fps=5.0,
                         seed=7)
    assert video.fitness == evaluate(spider(), seconds=1.0, insertion=0.5, seed=7).fitness


def test_one_colour_robot_is_drawn_with_its_parts_apart() -> None:
    red = (1.0, 0.0, 0.0)
    robot = _painted(sensor_crawler(), red)
    asm = assemble(robot)
    colors = drawn_colors(asm)
    types = {p.node.type for p in asm.parts}
    assert len(types) >= 4
    assert len(set(colors)) == len(types)  # one shade per part type, the core as it is
    assert colors[0] == red
    for part, color in zip(asm.parts, colors, strict=True):
        assert color == part_color(part.node.type, red)
    model = build_model(robot)
    drawn = {tuple(c) for link in model.links for c in link.box_colors}
    assert drawn == set(colors)  # what both engines draw


def test_designed_colours_are_kept() -> None:
    robot = spider()
    asm = assemble(robot)
    assert drawn_colors(asm) == [p.node.color for p in asm.parts]


def _saturations(robot: Robot, engine: str) -> np.ndarray:
    env = LocomotionEnv(robot, render_mode="rgb_array", controller="brain", engine=engine)
    try:
        env.reset(seed=0)
        try:
            img = env.render()
        except RuntimeError as error:  # MuJoCo without an OpenGL context (MUJOCO_GL unset)
            pytest.skip(str(error))
    finally:
        env.close()
    assert img is not None
    c = img.reshape(-1, 3).astype(float)
    red = (c[:, 0] > 90) & (c[:, 0] > 1.3 * c[:, 2])  # the robot; the ground is grey or blue
    top = c[red].max(axis=1)
    return np.asarray((top - c[red].min(axis=1)) / top)


@pytest.mark.parametrize("engine", ["pybullet", "mujoco"])
def test_a_rendered_one_colour_robot_shows_several_colours(engine: str) -> None:
    robot = _painted(sensor_crawler(), (1.0, 0.0, 0.0))
    sat = _saturations(robot, engine)
    assert len(sat) > 50
    # the core and the hinges: pure red (lit darker or lighter), the bricks: lighter
    # (whitened) red, the light sensor: orange; several colours, not one.
    assert np.mean(sat > 0.9) > 0.05
    assert np.mean((sat > 0.3) & (sat < 0.75)) > 0.05
    assert PartType.BRICK in {n.type for _, n in robot.walk()}
