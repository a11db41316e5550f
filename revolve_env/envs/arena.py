"""Pictures of a population env's whole arena: a camera that frames every living robot."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from revolve_env.envs.members import Member
from revolve_env.world import World

__all__ = ["arena_frame"]


def arena_frame(world: World, members: Sequence[Member], birth_radius: float,
                size: tuple[int, int], view: Literal["top", "chase"]) -> NDArray[np.uint8]:
    """An RGB image ``(height, width, 3)`` framing every living robot (else the birth disc).

    ``view="top"`` looks straight down, ``"chase"`` obliquely; robots are drawn in their parts'
    colours. ``birth_radius`` in metres, ``size`` ``(width, height)`` in pixels.
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
    distance = extent / math.tan(math.radians(30.0))
    target = (float(centre[0]), float(centre[1]), 0.0)
    if view == "top":
        return world.render(width, height, target=target, distance=distance, yaw_deg=0.0,
                            pitch_deg=-89.9)
    if view == "chase":
        return world.render(width, height, target=target, distance=1.3 * distance,
                            yaw_deg=30.0, pitch_deg=-40.0)
    raise ValueError(f"view must be 'top' or 'chase', got {view!r}")
