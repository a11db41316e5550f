"""Walking tasks: the paper's ``f = v + 5 s`` and displacement along a heading.

Both score the core's horizontal path over the window (:class:`~revolve_env.fitness.Window`);
every value is in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from revolve_env.fitness import DEFAULT_S_WEIGHT, Window
from revolve_env.tasks.base import BaseTask

__all__ = ["DirectedLocomotion", "Locomotion"]


def _number(value: object, name: str) -> float:
    """``value`` as a float (a table may give an int), or ValueError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class Locomotion(BaseTask):
    """The paper's fitness (section 4): ``f = v + s_weight * s`` over the window. Metres.

    ``v`` is the core's horizontal path length, ``s`` its straight horizontal displacement: a
    robot is rewarded for moving and more for moving straight. The default task everywhere.

    Attributes:
        s_weight: Weight of the displacement ``s`` (the paper: 5).
    """

    registered: ClassVar[str | None] = "locomotion"
    s_weight: float = DEFAULT_S_WEIGHT

    def __post_init__(self) -> None:
        object.__setattr__(self, "s_weight", _number(self.s_weight, "s_weight"))

    def fitness(self, window: Window) -> NDArray[np.float64]:
        """``v + s_weight * s`` of every robot. Metres."""
        f: NDArray[np.float64] = window.v + self.s_weight * window.s
        return f


@dataclass(frozen=True)
class DirectedLocomotion(BaseTask):
    """Displacement along a fixed direction over the window: ``(end - start) . (cos h, sin h)``.

    Metres; negative when the robot went the other way. The direction is in the world frame
    (0: +x, pi/2: +y), whatever heading a robot starts with, so a robot started with a random
    heading must turn to score.

    Attributes:
        heading: The rewarded direction. Radians.
    """

    registered: ClassVar[str | None] = "directed-locomotion"
    heading: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "heading", _number(self.heading, "heading (radians)"))

    def fitness(self, window: Window) -> NDArray[np.float64]:
        """Every robot's displacement along ``heading``. Metres."""
        d = window.end - window.start
        along: NDArray[np.float64] = (d[:, 0] * math.cos(self.heading)
                                      + d[:, 1] * math.sin(self.heading))
        return along
