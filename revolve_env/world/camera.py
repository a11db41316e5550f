"""The camera of :meth:`World.render <revolve_env.world.World.render>`, the same on every engine.

A camera looks at ``target`` from ``distance`` metres, turned ``yaw`` degrees about the vertical
(pybullet's convention: yaw 0 looks along +y, yaw 90 along -x; MuJoCo's azimuth is ``yaw + 90``)
and tilted ``pitch`` degrees (negative looks down), with a vertical field of view of
:data:`FOV_DEG`. :func:`project` gives where world points appear in its picture, for labels
drawn on a frame (checked against both engines' pictures to a pixel).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["FOV_DEG", "project"]

FOV_DEG = 60.0
"""Vertical field of view of every engine's frames. Degrees."""


def project(points: ArrayLike, width: int, height: int, target: ArrayLike, distance: float,
            yaw_deg: float, pitch_deg: float) -> NDArray[np.float64]:
    """Pixel positions ``(n, 2)`` (x right, y down) of world ``points`` ``(n, 3)`` (metres).

    Points behind the camera get NaN.
    """
    yaw, pitch = math.radians(yaw_deg + 90.0), math.radians(pitch_deg)
    forward = np.array([math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw),
                        math.sin(pitch)])
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    eye = np.asarray(target, dtype=np.float64).reshape(3) - distance * forward
    v = np.asarray(points, dtype=np.float64).reshape(-1, 3) - eye
    depth = v @ forward
    focal = (height / 2) / math.tan(math.radians(FOV_DEG) / 2)  # pixels
    with np.errstate(divide="ignore", invalid="ignore"):
        x = width / 2 + focal * (v @ right) / depth
        y = height / 2 - focal * (v @ up) / depth
    pixels = np.stack([x, y], axis=1)
    pixels[depth <= 0] = np.nan
    return pixels
