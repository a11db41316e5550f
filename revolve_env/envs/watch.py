"""Watching robots: a live window on one robot, and labelled pictures of a whole world.

* :func:`watch_robot`: the robot driven by its own brain in the engine's window (pybullet's, or
  MuJoCo's viewer), stepped in real time. It needs a display: without one (``$DISPLAY`` and
  ``$WAYLAND_DISPLAY`` unset on Linux) :class:`NoDisplayError` says so before anything opens.
* :func:`label_frame`: draws on a rendered picture of a world (e.g.
  :meth:`revolve_env.envs.population.PopulationEnv.render_frame`) each robot's id beside it, on
  a tag of a colour of its own (:data:`PALETTE`, :func:`pick_color`), a header line (time,
  births) and a legend listing every living robot, fittest first: a swatch of its colour, its
  id and its current fitness. ``revolve watch RESULTS --record`` writes such frames of a replayed
  online run.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.robot import Robot
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.terrain import Terrain
from revolve_env.world import opengl
from revolve_env.world.opengl import RenderUnavailableError, has_display

__all__ = ["PALETTE", "Label", "NoDisplayError", "RenderUnavailableError", "control_period",
           "has_display", "label_frame", "pick_color", "render_problem", "watch_robot"]


class NoDisplayError(RuntimeError):
    """A live window was asked for where there is no display."""


def render_problem(engine: str) -> str | None:
    """Why ``engine`` cannot draw frames here, in one line (None: it should), before it loads.

    MuJoCo: its OpenGL backend is chosen first (:func:`revolve_env.world.opengl.
    choose_mujoco_gl`, a no-op once MuJoCo is imported); pybullet always renders (its own
    software renderer).
    """
    if engine != "mujoco":
        return None
    opengl.choose_mujoco_gl()
    return opengl.render_problem()


PALETTE: tuple[tuple[float, float, float], ...] = (
    (0.902, 0.624, 0.0),  # orange
    (0.337, 0.706, 0.914),  # sky blue
    (0.0, 0.620, 0.451),  # bluish green
    (0.941, 0.894, 0.259),  # yellow
    (0.0, 0.447, 0.698),  # blue
    (0.835, 0.369, 0.0),  # vermillion
    (0.800, 0.475, 0.655),  # reddish purple
)
"""Okabe and Ito's colour-blind-safe qualitative palette (its black left for the text), RGB."""


def pick_color(taken: Sequence[int]) -> int:
    """The :data:`PALETTE` colour for a newcomer: the one fewest of ``taken`` hold, lowest first.

    ``taken``: the palette indices of the robots alive. Colours are distinct while no more
    robots than :data:`PALETTE` has colours are alive, then shared as evenly as they can be.
    """
    counts = np.bincount(np.asarray(taken, dtype=np.intp) % len(PALETTE),
                         minlength=len(PALETTE))
    return int(np.argmin(counts))


@dataclass(frozen=True, slots=True)
class Label:
    """One robot's line in the legend of :func:`label_frame`, and its tag on the picture.

    Attributes:
        text: What to write in the legend (e.g. ``"#12  3.104 m"``).
        color: RGB in [0, 1] of its swatch and tag.
        fitness: Orders the legend (fittest first).
        tag: What to write beside the robot on the picture (e.g. ``"#12"``); empty: no tag.
        at: Where the robot is on the picture (pixels, x right and y down); None: no tag.
    """

    text: str
    color: tuple[float, float, float]
    fitness: float = 0.0
    tag: str = ""
    at: tuple[float, float] | None = None


def control_period(engine: str) -> float:
    """The control period of the default world of ``engine``. Seconds."""
    from revolve_env.world import WorldConfig, with_engine

    return with_engine(WorldConfig(), engine).control_period


def _ink(rgb: tuple[int, ...]) -> tuple[int, int, int]:
    """Black or white, whichever reads better on ``rgb`` (by its luminance)."""
    luminance = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
    return (0, 0, 0) if luminance > 140 else (255, 255, 255)


def label_frame(frame: NDArray[np.uint8], header: str,
                labels: Sequence[Label]) -> NDArray[np.uint8]:
    """``frame`` with ``header`` on a white bar at the top, tags and a legend of ``labels``.

    Each label with a tag and a place on the picture gets a dot in its colour on the robot and
    its tag (its id) on a box of that colour beside it. The legend at the left lists the labels
    fittest first, one line of 12 pixels each, as many as fit; a last line says how many more
    there are.
    """
    from PIL import Image, ImageDraw, ImageFont

    image = Image.fromarray(np.asarray(frame, dtype=np.uint8))
    draw = ImageDraw.Draw(image)
    font = ImageFont.load_default(size=13)
    for lb in labels:
        if not lb.tag or lb.at is None or not all(np.isfinite(lb.at)):
            continue
        x, y = lb.at
        if not (0 <= x < image.width and 16 <= y < image.height):
            continue
        rgb = tuple(int(round(255 * c)) for c in lb.color)
        left, top, right, bottom = draw.textbbox((0, 0), lb.tag, font=font)
        w, h = right - left + 6, bottom - top + 4
        bx = min(max(x + 6, 0), image.width - w)  # above right of the robot, inside the frame
        by = min(max(y - 8 - h, 16), image.height - h)
        draw.line((x, y, bx, by + h), fill=(0, 0, 0), width=1)
        draw.ellipse((x - 3, y - 3, x + 3, y + 3), fill=rgb, outline=(0, 0, 0))
        draw.rectangle((bx, by, bx + w, by + h), fill=rgb, outline=(0, 0, 0))
        draw.text((bx + 3 - left, by + 2 - top), lb.tag, fill=_ink(rgb), font=font)
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
        engine: An engine with a GUI window (:attr:`~revolve_env.world.engines.Engine.gui`:
            pybullet's GUI or MuJoCo's own viewer; None means the default world's).
        seed: Seed of the episode.
        conditions: Start heading, jitter and noise (default: ideal); with the same ``seed``
            the robot starts as in ``evaluate(..., seed=seed, conditions=conditions)``.
        terrain: The ground (:func:`revolve_env.terrain.make_terrain`); None: flat.

    Returns:
        The fitness at the end. Metres.

    Raises:
        NoDisplayError: no display here.
        ValueError: ``engine`` has no GUI window, or the robot cannot be driven.
    """
    from revolve_env.world.engines import capable
    from revolve_env.world.engines import engine as engine_record

    if engine is not None and not engine_record(engine).gui:
        raise ValueError(f"a live window needs an engine with a GUI window "
                         f"({', '.join(capable('gui'))}), not {engine!r}")
    if not has_display():
        raise NoDisplayError("no display for a live window ($DISPLAY is unset)")
    from revolve_env.envs.episode import run_episode
    from revolve_env.envs.locomotion import LocomotionEnv

    env = LocomotionEnv(robot, render_mode="human", insertion_time=insertion,
                        evaluation_time=seconds, fitness_window=seconds, controller="brain",
                        conditions=conditions if conditions is not None else IDEAL,
                        terrain=terrain, engine=engine)  # evaluate's conditions: no start noise
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
