"""Pictures of a population env's whole arena: a camera that frames every living robot."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from revolve_env.envs.members import Member
from revolve_env.world import World
from revolve_env.world.camera import FOV_DEG, project

__all__ = ["arena_camera", "arena_frame", "arena_pixels"]


def arena_camera(world: World, members: Sequence[Member], birth_radius: float,
                 size: tuple[int, int], view: Literal["top", "chase"]
                 ) -> tuple[tuple[float, float, float], float, float, float]:
    """The camera of :func:`arena_frame`: target (metres), distance (metres), yaw, pitch (degrees).

    Raises:
        ValueError: an unknown ``view``.
    """
    width, height = size
    if members:
        xy = world.core_positions([m.handle for m in members])[:, :2]
        reach = np.array([[m.radius] for m in members]) + 0.2  # footprint and a margin
        lo, hi = (xy - reach).min(axis=0), (xy + reach).max(axis=0)
    else:
        lo, hi = np.full(2, -birth_radius), np.full(2, birth_radius)
    centre = (lo + hi) / 2
    half = np.maximum((hi - lo) / 2, 0.5)
    # fov 60 deg vertically: fit the larger of the vertical and the aspect-corrected extents
    extent = max(half[1], half[0] * height / width)
    distance = extent / math.tan(math.radians(FOV_DEG / 2))
    target = (float(centre[0]), float(centre[1]), 0.0)
    if view == "top":
        return target, distance, 0.0, -89.9
    if view == "chase":
        return target, 1.3 * distance, 30.0, -40.0
    raise ValueError(f"view must be 'top' or 'chase', got {view!r}")


def arena_frame(world: World, members: Sequence[Member], birth_radius: float,
                size: tuple[int, int], view: Literal["top", "chase"]) -> NDArray[np.uint8]:
    """An RGB image ``(height, width, 3)`` framing every living robot (else the birth disc).

    ``view="top"`` looks straight down, ``"chase"`` obliquely; robots are drawn in their parts'
    colours. ``birth_radius`` in metres, ``size`` ``(width, height)`` in pixels.
    """
    target, distance, yaw, pitch = arena_camera(world, members, birth_radius, size, view)
    return world.render(size[0], size[1], target=target, distance=distance, yaw_deg=yaw,
                        pitch_deg=pitch)


def arena_pixels(world: World, members: Sequence[Member], birth_radius: float,
                 size: tuple[int, int], view: Literal["top", "chase"]) -> NDArray[np.float64]:
    """Where each member's core is in :func:`arena_frame`'s picture: pixels ``(n, 2)`` (x, y)."""
    if not members:
        return np.zeros((0, 2))
    camera = arena_camera(world, members, birth_radius, size, view)
    cores = world.core_positions([m.handle for m in members])
    return project(cores, size[0], size[1], *camera)
