"""Watching robots: a live window on one robot, and labelled pictures of a whole world.

* :func:`watch_robot`: the robot driven by its own brain in the engine's GUI window (pybullet),
  stepped in real time. It needs a display: without one (``$DISPLAY`` and ``$WAYLAND_DISPLAY``
  unset on Linux) :class:`NoDisplayError` says so before anything opens.
* :func:`label_frame`: draws on a rendered picture of a world (e.g.
  :meth:`revolve_env.envs.population.PopulationEnv.render_frame`) a header line (time, births)
  and a legend listing every living robot, fittest first: a swatch of its colour, its id and
  its current fitness. ``revolve watch RESULTS --record`` writes such frames of a replayed
  online run.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.robot import Robot
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.terrain import Terrain

__all__ = ["Label", "NoDisplayError", "control_period", "has_display", "label_frame", "watch_robot"]


class NoDisplayError(RuntimeError):
    """A live window was asked for where there is no display."""


@dataclass(frozen=True, slots=True)
class Label:
    """One robot's line in the legend of :func:`label_frame`.

    Attributes:
        text: What to write (e.g. ``"#12  3.104 m"``).
        color: RGB in [0, 1] of its swatch (the robot's colour).
        fitness: Orders the legend (fittest first).
    """

    text: str
    color: tuple[float, float, float]
    fitness: float = 0.0


def control_period(engine: str) -> float:
    """The control period of the default world of ``engine``. Seconds."""
    from revolve_env.world import WorldConfig

    return WorldConfig().with_engine(engine).control_period


def has_display() -> bool:
    """Whether a window can open here (on Linux: ``$DISPLAY`` or ``$WAYLAND_DISPLAY`` set)."""
    if not sys.platform.startswith("linux"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def label_frame(frame: NDArray[np.uint8], header: str,
                labels: Sequence[Label]) -> NDArray[np.uint8]:
    """``frame`` with ``header`` on a white bar at the top and a legend of ``labels`` at the left.

    The legend lists the labels fittest first, one line of 12 pixels each, as many as fit; a
    last line says how many more there are.
    """
    from PIL import Image, ImageDraw

    image = Image.fromarray(np.asarray(frame, dtype=np.uint8))
    draw = ImageDraw.Draw(image)
    draw.rectangle((0, 0, image.width, 15), fill=(255, 255, 255))
    draw.text((4, 2), header, fill=(0, 0, 0))
    line = 12
    rows = max(0, (image.height - 24) // line)
    ordered = sorted(labels, key=lambda lb: -lb.fitness)
    shown = ordered if len(ordered) <= rows else ordered[:max(0, rows - 1)]
    width = 8 + max((int(draw.textlength(lb.text)) for lb in shown), default=0) + 16
    lines = len(shown) + (len(shown) < len(ordered))
    if lines:
        draw.rectangle((0, 18, width, 20 + line * lines), fill=(255, 255, 255))
    for k, lb in enumerate(shown):
        y = 20 + line * k
        rgb = tuple(int(round(255 * c)) for c in lb.color)
        draw.rectangle((3, y + 2, 11, y + 10), fill=rgb, outline=(0, 0, 0))
        draw.text((15, y), lb.text, fill=(0, 0, 0))
    if len(shown) < len(ordered):
        draw.text((15, 20 + line * len(shown)), f"+{len(ordered) - len(shown)} more",
                  fill=(0, 0, 0))
    return np.asarray(image)


def watch_robot(robot: Robot, seconds: float = 12.0, insertion: float = 3.0, *,
                engine: str | None = None, seed: int = 0,
                conditions: EvaluationConditions | None = None,
                terrain: Terrain | str | Mapping[str, Any] | None = None) -> float:
    """Show ``robot``, driven by its own brain, in the engine's window in real time.

    Args:
        robot: A valid robot with at least one active hinge.
        seconds: Evaluation time after insertion. Seconds.
        insertion: Settling time first. Seconds.
        engine: ``"pybullet"`` (None means it); MuJoCo has no window in this package.
        seed: Seed of the episode.
        conditions: Start heading, jitter and noise (default: ideal); with the same ``seed``
            the robot starts as in ``evaluate(..., seed=seed, conditions=conditions)``.
        terrain: The ground (:func:`revolve_env.terrain.make_terrain`); None: flat.

    Returns:
        The fitness at the end. Metres.

    Raises:
        NoDisplayError: no display here.
        ValueError: ``engine`` is not pybullet, or the robot cannot be driven.
    """
    if engine not in (None, "pybullet"):
        raise ValueError(f"a live window needs the pybullet engine, not {engine!r}")
    if not has_display():
        raise NoDisplayError("no display for a live window ($DISPLAY is unset)")
    from revolve_env.envs.episode import run_episode
    from revolve_env.envs.locomotion import LocomotionEnv

    env = LocomotionEnv(robot, render_mode="human", insertion_time=insertion,
                        evaluation_time=seconds, fitness_window=seconds, controller="brain",
                        conditions=conditions if conditions is not None else IDEAL,
                        terrain=terrain)  # evaluate's conditions: no env default start noise
    dt = env.config.control_period
    started = time.perf_counter()

    def pace(step: int, info: object) -> None:
        ahead = started + step * dt - time.perf_counter()
        if ahead > 0:
            time.sleep(ahead)

    try:
        info = run_episode(env, seed, on_step=pace)
    finally:
        env.close()
    return float(info["fitness"])
