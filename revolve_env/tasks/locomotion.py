"""Walking tasks: the paper's ``f = v + 5 s`` and displacement along a heading.

Both score the core's horizontal path over the window (:class:`~revolve_env.fitness.Window`);
every value is in metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from revolve_env.fitness import DEFAULT_S_WEIGHT, Window
from revolve_env.fitness.terms import speed_fitness
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

    The instability guard (``limit``) is the paper's ``--fitness-limit``: "minimum fitness value
    that is considered unrealistic and should probably be attributed to a simulator
    instability. A fitness of zero is returned in this case." The paper's fitness is in speeds
    (``v`` and ``s`` divided by the window's ``T`` seconds), ours in metres, so a robot scores 0
    where ``f / T >= limit``: over the 12 s window, ``limit = 1.0`` m/s (the paper's default
    value) zeroes ``f >= 12 m``, i.e. ``v + 5 s >= 12 m`` (the example spider scores about 10 m).
    ``T`` is the window's :attr:`~revolve_env.fitness.Window.duration` (the time from its first
    to its last pose sample; shorter while an online window fills).

    Attributes:
        s_weight: Weight of the displacement ``s`` (the paper: 5).
        limit: The paper's fitness limit, ``(v + s_weight s) / T`` in metres per second at and
            above which the fitness is 0; None (the default): no limit.
    """

    registered: ClassVar[str | None] = "locomotion"
    s_weight: float = DEFAULT_S_WEIGHT
    limit: float | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "s_weight", _number(self.s_weight, "s_weight"))
        if self.limit is not None:
            limit = _number(self.limit, "limit (metres per second)")
            if limit <= 0:
                raise ValueError(f"limit must be a positive speed (metres per second; the "
                                 f"paper's fitness limit is 1.0), got {self.limit!r}")
            object.__setattr__(self, "limit", limit)

    def fitness(self, window: Window) -> NDArray[np.float64]:
        """``v + s_weight * s`` of every robot, 0 at or above the limit. Metres."""
        f = speed_fitness(window.v, window.s, self.s_weight)
        if self.limit is not None:
            if window.duration is None:
                raise ValueError("a fitness limit needs the window's duration (Window.duration)")
            f = np.where(f >= self.limit * window.duration, 0.0, f)
            f[window.duration <= 0.0] = 0.0
        return f

    def to_dict(self) -> dict[str, Any]:
        """``{"name": "locomotion", "s_weight": ..., "pose_rate": ...}``, with ``limit`` if set."""
        data = BaseTask.to_dict(self)
        if self.limit is None:
            del data["limit"]
        return data


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
        super().__post_init__()
        object.__setattr__(self, "heading", _number(self.heading, "heading (radians)"))

    def fitness(self, window: Window) -> NDArray[np.float64]:
        """Every robot's displacement along ``heading``. Metres."""
        d = window.end - window.start
        along: NDArray[np.float64] = (d[:, 0] * math.cos(self.heading)
                                      + d[:, 1] * math.sin(self.heading))
        return along
