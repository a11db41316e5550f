"""Phototaxis: the light sensors' reading should grow.

The world has one point light (:attr:`revolve_env.world.WorldConfig.light_position`, 1 m ahead of
the origin along +x by default); a light sensor reads ``max(0, cos a) / (1 + (d / light_range)^2)``
(:func:`revolve_env.world.sensing.light_intensity`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from revolve_env.fitness import Window
from revolve_env.tasks.base import BaseTask

__all__ = ["LightFollowing"]


@dataclass(frozen=True)
class LightFollowing(BaseTask):
    """How much brighter the robot reads the light at the end of the window than at its start.

    ``f = light(end) - light(start)``, dimensionless in [-1, 1], from the ``"light"`` signal:
    the brightest of the robot's light sensors (noise-free), so a robot scores by coming closer
    to the light and turning its sensors to it. A robot without a light sensor is scored on the
    light at its core centre, as a sensor there facing the light would read it
    (``1 / (1 + (d / light_range)^2)``): on coming closer only. Either way a robot that stays
    put scores 0 and the reward of a step is the brightening over that step.
    """

    signal: ClassVar[str | None] = "light"
    registered: ClassVar[str | None] = "light-following"

    def fitness(self, window: Window) -> NDArray[np.float64]:
        """Every robot's gain in light intensity over its window (dimensionless)."""
        assert window.signal_start is not None and window.signal_end is not None
        gain: NDArray[np.float64] = window.signal_end - window.signal_start
        return gain
