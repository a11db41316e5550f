"""Write videos of a run: GIF through Pillow, MP4 through imageio's ffmpeg plugin when present.

Timing is exact: a GIF stores each frame's delay in whole centiseconds, so a frame period that is
not a whole number of them (1/15 s = 6.67 cs) is written as a mix of delays whose running sum
follows the true clock (:func:`gif_delays`: 7, 7, 6, 7, 7, 6, ... cs at 15 fps): the whole GIF
lasts the simulated time within one centisecond. (Writing every frame with the rounded delay of
6 cs, as Pillow would, plays 11 % fast.) GIF players do not show frames faster than 50 per
second (2 cs), so a faster GIF is refused. MP4 is written at the exact frame rate.
"""

from __future__ import annotations

import importlib.util
import math
import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from revolve_env.envs.population import PopulationEnv

__all__ = ["GIF_MAX_FPS", "VideoError", "check_video", "gif_delays", "mp4_available",
           "record_video", "write_video"]


class VideoError(ValueError):
    """A video that cannot be written as asked (frame rate, file type): the caller's input."""

GIF_MAX_FPS = 50.0
"""The fastest frame rate a GIF can play (2 cs per frame; players slow shorter delays)."""


def mp4_available() -> bool:
    """Whether MP4 can be written here (imageio with its ffmpeg plugin installed)."""
    return (importlib.util.find_spec("imageio") is not None
            and importlib.util.find_spec("imageio_ffmpeg") is not None)


def gif_delays(frames: int, fps: float) -> list[int]:
    """Per-frame GIF delays, whole centiseconds, whose running sum follows ``k / fps`` seconds.

    Frame ``k`` is shown from ``round(100 k / fps)`` to ``round(100 (k + 1) / fps)`` cs, so the
    total is ``round(100 frames / fps)`` cs: exact within half a centisecond.

    Returns:
        The delays in milliseconds (multiples of 10, as Pillow takes them).
    """
    edges = [round(100.0 * k / fps) for k in range(frames + 1)]
    return [10 * (b - a) for a, b in zip(edges, edges[1:], strict=False)]


def check_video(path: str | os.PathLike[str], fps: float) -> None:
    """Refuse, before any frame is made, a video :func:`write_video` could not write.

    Args:
        path: The video file to write.
        fps: Its frames per second.

    Raises:
        VideoError: a non-positive frame rate, a suffix other than ``.gif`` or ``.mp4``, a GIF
            faster than :data:`GIF_MAX_FPS`, or a folder that does not exist.
    """
    out = Path(path)
    if not (math.isfinite(fps) and fps > 0):
        raise VideoError(f"fps must be a positive number, got {fps}")
    suffix = out.suffix.lower()
    if suffix not in (".gif", ".mp4"):
        raise VideoError(f"video path must end in .gif or .mp4, got {out.name!r}")
    if suffix == ".gif" or not mp4_available():
        _check_gif_fps(fps)
    folder = out.parent
    if not folder.is_dir():
        raise VideoError(f"cannot write {out}: {folder} is not a folder")


def _check_gif_fps(fps: float) -> None:
    if fps > GIF_MAX_FPS:
        raise VideoError(f"a GIF cannot play {fps:g} frames per second (at most "
                         f"{GIF_MAX_FPS:g}): take fewer frames, or write an MP4")


def write_video(
    frames: Sequence[NDArray[np.uint8]], path: str | os.PathLike[str], fps: float = 30.0
) -> Path:
    """Write RGB frames ``(height, width, 3)`` uint8 as a ``.gif`` or ``.mp4`` file.

    MP4 needs ffmpeg (the ``imageio-ffmpeg`` package); without it a GIF is written next to the
    requested path (same name, ``.gif``) and a ``UserWarning`` says so.

    Args:
        frames: At least one frame; all of the same shape.
        path: Output file; its suffix (``.gif`` or ``.mp4``) picks the format.
        fps: Frames per second of the video.

    Returns:
        The path actually written.
    """
    out = Path(path)
    if not frames:
        raise ValueError("no frames to write")
    shape = np.asarray(frames[0]).shape
    if len(shape) != 3 or shape[2] != 3:
        raise ValueError(f"frames must be RGB images (height, width, 3), got shape {shape}")
    for k, f in enumerate(frames):
        a = np.asarray(f)
        if a.shape != shape:
            raise ValueError(f"frame {k} has shape {a.shape}, frame 0 has {shape}")
        if a.dtype != np.uint8:
            # A float image in [0, 1] cast to uint8 would come out black: refuse, do not guess.
            raise ValueError(f"frame {k} must be uint8 RGB (0-255), got dtype {a.dtype}")
    check_video(out, fps)
    if out.suffix.lower() == ".mp4":
        if mp4_available():
            import imageio.v2 as imageio

            with imageio.get_writer(out, fps=fps, macro_block_size=1) as writer:
                for f in frames:
                    writer.append_data(np.asarray(f, dtype=np.uint8))  # type: ignore[attr-defined,unused-ignore]
            return out
        out = out.with_suffix(".gif")
        warnings.warn(f"MP4 needs ffmpeg (pip install imageio-ffmpeg), which is not installed: "
                      f"writing a GIF instead, to {out}", UserWarning, stacklevel=2)
    _check_gif_fps(fps)
    from PIL import Image

    images = [Image.fromarray(np.asarray(f, dtype=np.uint8)) for f in frames]
    # A list of delays, not one: Pillow truncates a single delay to whole centiseconds.
    images[0].save(out, save_all=True, append_images=images[1:],
                   duration=gif_delays(len(images), fps), loop=0)
    return out


def record_video(
    env: PopulationEnv,
    path: str | os.PathLike[str],
    steps: int,
    *,
    policy: Callable[[PopulationEnv], dict[str, Any]] | None = None,
    every: int = 6,
    view: Literal["top", "chase"] | None = None,
) -> Path:
    """Step ``env`` (already reset) ``steps`` times and write a video of the arena.

    One frame is taken before the first step and then every ``every`` steps; the video plays in
    real time (``fps = 1 / (every * control_period)``).

    Args:
        env: A reset :class:`PopulationEnv` (any ``render_mode``).
        path: Output ``.gif`` or ``.mp4`` (see :func:`write_video`).
        steps: Control periods to simulate.
        policy: Called before each step with the env; returns the actions dict (default: none,
            so agent-controlled robots hold their targets). It may add or remove robots.
        every: Steps between frames.
        view: ``"top"`` or ``"chase"``; defaults to ``env.render_view``.

    Returns:
        The path written.
    """
    if steps < 1 or every < 1:
        raise ValueError(f"steps and every must be >= 1, got {steps} and {every}")
    camera = view if view is not None else env.render_view
    frames = [env.render_frame(camera)]
    for k in range(1, steps + 1):
        env.step(policy(env) if policy is not None else {})
        if k % every == 0:
            frames.append(env.render_frame(camera))
    return write_video(frames, path, fps=1.0 / (every * env.config.control_period))
