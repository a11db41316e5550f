"""A robot's one id and its typed status, from the population env to the experiments.

A robot has ONE id, an int, from its birth in a world to its rows in a results store: the
population env keys its robots by it (an experiment gives it its own birth index,
``add_robot(..., robot_id=...)``), reports their :class:`RobotStatus` by it, and PettingZoo's
agent name is derived from it here and only here (:func:`agent_name`, :func:`robot_id`). The
world's handles, the backends' keys and the controller's handles stay inside their layers.

This module imports no physics: the experiments read statuses without loading an engine.
"""

from __future__ import annotations

from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["AGENT_PREFIX", "Death", "RobotStatus", "agent_name", "robot_id"]

AGENT_PREFIX = "robot_"
"""PettingZoo agent names are this prefix and the robot id: ``robot_17``."""

Death = Literal["removed", "blow_up"]
"""Why a robot left a world: taken out by its caller, or lost to a physics blow-up."""


def agent_name(robot: int) -> str:
    """The PettingZoo agent name of robot ``robot``: ``"robot_<id>"``."""
    return f"{AGENT_PREFIX}{robot}"


def robot_id(agent: str) -> int:
    """The robot id an agent name stands for (the inverse of :func:`agent_name`).

    Raises:
        KeyError: not an agent name (naming it).
    """
    if isinstance(agent, str) and agent.startswith(AGENT_PREFIX):
        digits = agent[len(AGENT_PREFIX):]
        if digits.isdigit() and digits.isascii() and (digits == "0" or digits[0] != "0"):
            return int(digits)
    raise KeyError(f"unknown agent {agent!r} (agent names are {AGENT_PREFIX}<id>)")


class RobotStatus(NamedTuple):
    """One robot of a population env as a step (or :meth:`PopulationEnv.status`) leaves it.

    Ages count control periods in the env's clock (the one clock of a robot's life: the
    experiments' lifecycle takes insertion and maturity from it); seconds are derived.

    Attributes:
        robot_id: Its id.
        fitness: The task's fitness over its window (0 while inserting and after a blow-up).
        v: Horizontal path length of its core over the window. Metres.
        s: Straight horizontal displacement of its core over the window. Metres.
        position: Core centre ``(x, y, z)`` (its last finite one). Metres.
        age_steps: Control periods since birth.
        age: Seconds since birth (``age_steps`` control periods).
        inserting: Still in the insertion phase (nothing scored yet).
        mature: Past the maturity age.
        death: None while alive; why it left, in the report of its death.
        blow_up: Why its simulation blew up, or None.
        birth_time: Simulated time of its birth. Seconds.
        birth_position: Core ``(x, y)`` where it was placed. Metres.
        born_inside: False when a crowded birth disc put it outside.
        controlled_by: ``"brain"`` (its own network) or ``"agent"`` (actions).
        trajectory: (T, 3) read-only core positions since birth, one per trajectory stride
            (birth position first). Metres.
    """

    robot_id: int
    fitness: float
    v: float
    s: float
    position: NDArray[np.float64]
    age_steps: int = 0
    age: float = 0.0
    inserting: bool = True
    mature: bool = False
    death: Death | None = None
    blow_up: str | None = None
    birth_time: float = 0.0
    birth_position: tuple[float, float] = (0.0, 0.0)
    born_inside: bool = True
    controlled_by: str = "brain"
    trajectory: NDArray[np.float64] = np.zeros((0, 3))
