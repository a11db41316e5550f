"""Where the single-robot env's frames are taken from: named cameras, the same on both engines.

Plain data, no engine: :class:`~revolve_env.envs.LocomotionEnv`,
:func:`~revolve_env.envs.recording.record_robot` and ``revolve show --camera`` take a
:class:`Camera` or the name of one of :data:`CAMERAS`.
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass

__all__ = ["CAMERAS", "Camera", "check_size", "make_camera"]

MAX_SIZE = 4096
"""Largest frame width or height. Pixels."""


@dataclass(frozen=True, slots=True)
class Camera:
    """A camera of :class:`~revolve_env.envs.LocomotionEnv`'s frames and window.

    Attributes:
        distance: From the point looked at. Metres.
        yaw: Heading: 0 looks along +y, 90 along -x (:mod:`revolve_env.world.camera`). Degrees.
        pitch: Tilt; negative looks down, -90 straight down. Degrees.
        track: Look at the robot's core as it moves (True), or at the core's start (False).
    """

    distance: float = 1.0
    yaw: float = 45.0
    pitch: float = -30.0
    track: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.distance) and self.distance > 0):
            raise ValueError(f"camera distance must be a positive number of metres, got "
                             f"{self.distance}")
        if not (math.isfinite(self.yaw) and math.isfinite(self.pitch)
                and abs(self.pitch) <= 89.9):  # straight down: no heading to draw up from
            raise ValueError(f"camera yaw must be finite and pitch within [-89.9, 89.9] "
                             f"degrees, got yaw {self.yaw}, pitch {self.pitch}")


CAMERAS: dict[str, Camera] = {
    "track": Camera(),
    "far": Camera(distance=2.5, yaw=45.0, pitch=-35.0),
    "top": Camera(distance=2.0, yaw=0.0, pitch=-89.9),
    "fixed": Camera(distance=3.0, yaw=45.0, pitch=-35.0, track=False),
}
"""The named cameras: ``track`` (the default: 1 m from the core, following it), ``far`` (2.5 m,
following), ``top`` (2 m straight down, following) and ``fixed`` (3 m from where the core
started, not following: the robot walks across the picture)."""


def make_camera(camera: str | Camera) -> Camera:
    """The camera ``camera`` names (one of :data:`CAMERAS`), or ``camera`` itself.

    Raises:
        ValueError: an unknown name.
    """
    if isinstance(camera, Camera):
        return camera
    if camera not in CAMERAS:
        raise ValueError(f"camera must be a Camera or one of {', '.join(CAMERAS)}, got "
                         f"{camera!r}")
    return CAMERAS[camera]


def check_size(width: int, height: int) -> tuple[int, int]:
    """``(width, height)`` as ints, refused unless whole numbers in ``[1, MAX_SIZE]`` pixels.

    Raises:
        ValueError: a bad size, by name.
    """
    size = []
    for name, value in (("width", width), ("height", height)):
        try:
            pixels = operator.index(value)  # ints and NumPy integers, not 4.5 or "480"
        except TypeError:
            pixels = 0
        if isinstance(value, bool) or not 1 <= pixels <= MAX_SIZE:
            raise ValueError(f"{name} must be a whole number of pixels in [1, {MAX_SIZE}], "
                             f"got {value!r}")
        size.append(pixels)
    return size[0], size[1]
