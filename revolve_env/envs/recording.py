"""Videos of a robot walking: frames from the locomotion environment, written as GIF (or MP4).

The camera of :class:`revolve_env.envs.LocomotionEnv` follows the robot (by default) over a
ground with a grid, and every frame is annotated with the simulated time, the fitness so far and
a small map of the path the core has travelled (north up, 1 m scale bar).
Written by :func:`revolve_env.envs.video.write_video`: GIF with Pillow (a dependency), MP4 needs
``imageio-ffmpeg`` too (without it a GIF is written instead). The video plays in real time: a
frame every ``round(1 / (fps * control_period))`` control periods, written at exactly that frame
rate (GIF delays in centiseconds that add up to the simulated time).

The fitness window is the whole evaluation (``seconds``), as in :func:`revolve_env.evaluate`, so
the fitness a video reports is the one an isolated evaluation of the same robot, timing, engine
and seed gives.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.robot import Robot
from revolve_env.cameras import Camera
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.envs.episode import run_episode
from revolve_env.envs.locomotion import LocomotionEnv
from revolve_env.envs.video import VideoError, check_video, write_video
from revolve_env.terrain import Terrain

__all__ = ["BlowUpError", "Video", "record_robot"]


class BlowUpError(ValueError):
    """The recorded simulation blew up (the robot, not the code, is at fault)."""


@dataclass(frozen=True, slots=True)
class Video:
    """A written video.

    Attributes:
        path: The video file written.
        frames: Number of frames.
        seconds: Simulated time shown (insertion included). Seconds.
        fitness: Fitness ``v + 5 s`` at the end of the evaluation. Metres.
        distance: Straight distance of the core from its start. Metres.
    """

    path: Path
    frames: int
    seconds: float
    fitness: float
    distance: float


def _annotate(
    frame: NDArray[np.uint8], text: str, path: list[tuple[float, float]]
) -> NDArray[np.uint8]:
    from PIL import Image, ImageDraw

    image = Image.fromarray(frame)
    draw = ImageDraw.Draw(image)
    draw.rectangle((0, 0, image.width, 16), fill=(255, 255, 255))
    draw.text((4, 2), text, fill=(0, 0, 0))
    size, margin = 90, 6
    box = (image.width - size - margin, 20, image.width - margin, 20 + size)
    draw.rectangle(box, fill=(255, 255, 255), outline=(80, 80, 80))
    xs = np.array([p[0] for p in path])
    ys = np.array([p[1] for p in path])
    cx, cy = xs[0], ys[0]
    span = max(1.0, 2.2 * float(np.max(np.hypot(xs - cx, ys - cy))))  # metres across the map
    scale = (size - 10) / span
    mid = ((box[0] + box[2]) / 2, (box[1] + box[3]) / 2)
    points = [(mid[0] + (x - cx) * scale, mid[1] - (y - cy) * scale) for x, y in path]
    if len(points) > 1:
        draw.line(points, fill=(200, 40, 40), width=2)
    draw.ellipse((mid[0] - 2, mid[1] - 2, mid[0] + 2, mid[1] + 2), fill=(0, 0, 0))
    draw.line((box[0] + 4, box[3] - 4, box[0] + 4 + scale, box[3] - 4), fill=(0, 0, 0), width=2)
    draw.text((box[0] + 6, box[3] - 16), "1 m", fill=(0, 0, 0))
    return np.asarray(image)


def record_robot(
    robot: Robot,
    path: str | os.PathLike[str],
    seconds: float = 12.0,
    insertion: float = 3.0,
    fps: float = 15.0,
    *,
    engine: str | None = None,
    seed: int = 0,
    conditions: EvaluationConditions | None = None,
    terrain: Terrain | str | Mapping[str, Any] | None = None,
    width: int = 480,
    height: int = 360,
    camera: str | Camera = "track",
) -> Video:
    """Simulate ``robot`` driven by its own brain and write a video of it.

    Args:
        robot: A valid robot with at least one active hinge.
        path: Where to write the video (``.gif`` or ``.mp4``).
        seconds: Evaluation time after insertion. Seconds.
        insertion: Settling time shown first. Seconds.
        fps: Frames per simulated second (the GIF plays in real time). The frame period is a
            whole number of control periods, the nearest to ``1 / fps``.
        engine: Physics engine (``"mujoco"`` or ``"pybullet"``); None: MuJoCo.
        seed: Seed of the episode (:func:`revolve_env.evaluate`'s ``seed``).
        conditions: Start heading, jitter and noise (default
            :data:`~revolve_env.conditions.IDEAL`); with the same ``seed`` the robot starts and
            moves exactly as in ``evaluate(..., seed=seed, conditions=conditions)``.
        terrain: The ground (:func:`revolve_env.terrain.make_terrain`); None: flat.
        width: Frame width. Pixels.
        height: Frame height. Pixels.
        camera: A :class:`~revolve_env.cameras.Camera` or its name (default: following the
            core at 1 m).

    Raises:
        ValueError: bad timing, size or camera, or a robot the environment cannot drive (no hinge).
        VideoError: a video that could not be written (:func:`check_video`), before anything
            is simulated.
    """
    if not (math.isfinite(fps) and fps > 0):
        raise VideoError(f"fps must be a positive number, got {fps}")
    env = LocomotionEnv(robot, render_mode="rgb_array", insertion_time=insertion,
                        evaluation_time=seconds, fitness_window=seconds, controller="brain",
                        engine=engine, conditions=conditions if conditions is not None else IDEAL,
                        terrain=terrain, width=width, height=height,
                        camera=camera)  # evaluate's conditions: no env default start noise
    try:
        dt = env.config.control_period
        every = max(1, round(1.0 / (fps * dt)))
        check_video(path, 1.0 / (every * dt))  # before the simulation, not after it
        frames: list[NDArray[np.uint8]] = []
        trail: list[tuple[float, float]] = []
        steps = [0]

        def frame(step: int, info: dict[str, Any]) -> None:
            label = (f"t = {step * dt:5.1f} s   fitness = {float(info['fitness']):.3f} m"
                     + ("   (settling)" if not info.get("evaluating") else ""))
            picture = env.render()
            assert picture is not None
            frames.append(_annotate(picture, label, trail))

        def record(step: int, info: dict[str, Any]) -> None:
            steps[0] = step
            trail.append((float(info["x_position"]), float(info["y_position"])))
            if step % every == 0:
                frame(step, info)

        info = run_episode(env, seed, on_step=record)
        if steps[0] % every != 0:  # the last frame shows the end of the episode
            frame(steps[0], info)
        if info.get("blow_up"):
            raise BlowUpError(f"the simulation blew up: {info['blow_up']}")
    finally:
        env.close()
    distance = math.hypot(trail[-1][0] - trail[0][0], trail[-1][1] - trail[0][1])
    written = write_video(frames, path, fps=1.0 / (every * dt))
    return Video(written, len(frames), steps[0] * dt, float(info["fitness"]), distance)

