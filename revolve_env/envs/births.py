"""What a population env checks before a birth, and how ``reset``'s robots are given.

A birth is refused (``ValueError``, or ``TypeError`` for a non-robot) before anything changes,
naming the agent it would have been; positions are ``(x, y)`` in metres, headings in radians.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator, Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.robot import Robot
from revolve_env.body.validate import Limits, validate
from revolve_env.brain.spec import NetworkSpec
from revolve_env.conditions import EvaluationConditions
from revolve_env.envs.members import sensor_bounds

__all__ = ["check_birth", "initial_births", "jittered"]

INITIAL_KEYS = frozenset({"robot", "position", "controlled_by", "yaw"})
"""The keys of a mapping among ``reset``'s robots (``robot`` required)."""


def check_birth(
    agent: str, robot: Robot, position: tuple[float, float] | None, controlled_by: str,
    yaw: float | None, limits: Limits | None,
) -> tuple[NetworkSpec | None, NDArray[np.float64], NDArray[np.float64]]:
    """Refuse a bad birth, naming the agent; its network (brain-controlled) and sensor bounds."""
    if controlled_by not in ("brain", "agent"):
        raise ValueError(f"add_robot ({agent}): controlled_by must be 'brain' or 'agent', "
                         f"got {controlled_by!r}")
    if not isinstance(robot, Robot):
        raise TypeError(f"add_robot ({agent}): expected a Robot, got {type(robot).__name__}")
    try:
        validate(robot, limits)
    except ValueError as e:
        raise ValueError(f"add_robot ({agent}): invalid robot: {e}") from e
    if yaw is not None and not math.isfinite(float(yaw)):
        raise ValueError(f"add_robot ({agent}): yaw must be finite, got {yaw!r}")
    if position is not None and len(position) != 2:
        raise ValueError(f"add_robot ({agent}): position must be (x, y), got {position!r}")
    low, high = sensor_bounds(robot)
    spec: NetworkSpec | None = None
    if controlled_by == "brain":
        try:
            spec = NetworkSpec.from_robot(robot)
        except ValueError as e:
            raise ValueError(f"add_robot ({agent}): invalid network: {e}") from e
        if spec.n_inputs != len(low):
            raise ValueError(f"add_robot ({agent}): the network has {spec.n_inputs} input "
                             f"neurons but the body has {len(low)} sensor values")
    return spec, low, high


def jittered(xy: tuple[float, float], jitter: float,
             rng: np.random.Generator) -> tuple[float, float]:
    """``xy`` moved to a point drawn uniformly from the disc of radius ``jitter`` around it.

    The draw of :meth:`EvaluationConditions.start` (metres), so that a requested birth position
    is jittered as an offline start is; nothing is drawn for ``jitter == 0``.
    """
    return EvaluationConditions(position_jitter=jitter).start(rng, xy).position


def initial_births(entries: Iterable[Robot | Mapping[str, Any]]) -> Iterator[dict[str, Any]]:
    """The keyword arguments of ``add_robot`` for each of ``reset``'s robots, checked lazily.

    Each entry is a ``Robot`` or a mapping with keys ``robot`` and optional ``position``,
    ``controlled_by``, ``yaw``; a bad one raises when it is reached (earlier ones were added).
    """
    for k, entry in enumerate(entries):
        if isinstance(entry, Robot):
            yield {"robot": entry}
        elif isinstance(entry, Mapping):
            unknown = set(entry) - INITIAL_KEYS
            if unknown or "robot" not in entry:
                raise ValueError(f"initial robot {k}: expected a Robot or a mapping with keys "
                                 f"'robot' and optional 'position', 'controlled_by', 'yaw'; "
                                 f"got keys {sorted(entry)}")
            yield {"robot": entry["robot"], "position": entry.get("position"),
                   "controlled_by": entry.get("controlled_by", "brain"), "yaw": entry.get("yaw")}
        else:
            raise TypeError(f"initial robot {k}: expected a Robot or a mapping, got "
                            f"{type(entry).__name__}")
