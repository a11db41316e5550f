"""Where a newborn robot goes: the one birth-placement rule of the population env and the engine.

A robot occupies a disc of radius :func:`footprint_radius` about its core (whatever its
heading). A newborn's disc must keep ``clearance`` metres from every living robot's disc. It is
placed at a uniformly random point of the birth disc (radius ``birth_radius`` about the origin)
that is free; after ``tries`` random points without a free one, the birth disc is crowded, and
the robot goes to the **nearest free position outside it**: the first free point on rings of
growing radius (``birth_radius`` + k * the robot's radius), scanned from a random angle. A birth
therefore never fails for lack of room; a :class:`Placement` says whether it landed inside the
birth disc, so callers can record the event.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.robot import Robot
from revolve_env.body.validate import assembly_of

__all__ = ["Disc", "Placement", "clash", "footprint_radius", "place"]

_RING_LIMIT = 10_000
"""Rings scanned outside the birth disc before giving up (unreachable with finite robots)."""


def footprint_radius(robot: Robot) -> float:
    """Radius of the smallest vertical cylinder about the core holding the assembled robot.

    Whatever the robot's heading, its horizontal footprint at assembly lies within this distance
    of its core centre. Metres. (The assembly validation made of this robot object, if it is
    remembered: :func:`~revolve_env.body.validate.assembly_of`.)
    """
    return assembly_of(robot).footprint_radius()


@dataclass(frozen=True, slots=True)
class Disc:
    """A living robot's footprint on the ground.

    Attributes:
        x: Core position. Metres.
        y: Core position. Metres.
        radius: Footprint radius (:func:`footprint_radius`). Metres.
    """

    x: float
    y: float
    radius: float


@dataclass(frozen=True, slots=True)
class Placement:
    """Where a newborn was placed.

    Attributes:
        position: Core ``(x, y)``. Metres.
        inside: True when the position lies in the birth disc; False when the disc was crowded
            and the robot went to the nearest free position outside it.
    """

    position: tuple[float, float]
    inside: bool


def clash(occupied: Sequence[Disc], xy: tuple[float, float], radius: float,
          clearance: float) -> int | None:
    """Index of the first disc of ``occupied`` too close to a disc of ``radius`` at ``xy``.

    Args:
        occupied: The living robots' footprints.
        xy: Candidate core position. Metres.
        radius: The newborn's footprint radius. Metres.
        clearance: Gap to keep between footprints. Metres.

    Returns:
        The index of the closest offending disc, or None when the position is free.
    """
    if not occupied:
        return None
    centres: NDArray[np.float64] = np.array([(d.x, d.y) for d in occupied], dtype=np.float64)
    reach = np.array([d.radius for d in occupied]) + radius + clearance
    gaps = np.hypot(centres[:, 0] - xy[0], centres[:, 1] - xy[1]) - reach
    k = int(np.argmin(gaps))
    return k if gaps[k] < 0 else None


def place(occupied: Sequence[Disc], radius: float, birth_radius: float, clearance: float,
          rng: np.random.Generator, tries: int = 200) -> Placement:
    """A free position for a newborn of footprint ``radius`` (the module's rule).

    Args:
        occupied: The living robots' footprints.
        radius: The newborn's footprint radius. Metres.
        birth_radius: Radius of the birth disc about the origin. Metres.
        clearance: Gap to keep between footprints. Metres.
        rng: Draws the random points (and the scan's starting angle outside the disc).
        tries: Random points tried inside the birth disc first.

    Raises:
        ValueError: a non-finite or negative size (the caller's bug, not a crowded world).
    """
    for name, value in (("radius", radius), ("birth_radius", birth_radius),
                        ("clearance", clearance)):
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0 m, got {value}")
    for _ in range(tries):
        r = birth_radius * math.sqrt(float(rng.random()))
        angle = float(rng.uniform(0.0, 2.0 * math.pi))
        xy = (r * math.cos(angle), r * math.sin(angle))
        if clash(occupied, xy, radius, clearance) is None:
            return Placement(xy, True)
    start = float(rng.uniform(0.0, 2.0 * math.pi))
    step = max(radius, 0.05)
    for ring in range(1, _RING_LIMIT + 1):
        r = birth_radius + ring * step
        n = max(8, math.ceil(2.0 * math.pi * r / step))
        for k in range(n):
            angle = start + 2.0 * math.pi * k / n
            xy = (r * math.cos(angle), r * math.sin(angle))
            if clash(occupied, xy, radius, clearance) is None:
                return Placement(xy, False)
    raise AssertionError(f"no free position within {_RING_LIMIT} rings of the birth disc")
