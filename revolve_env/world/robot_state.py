"""The world's per-robot bookkeeping (private to :mod:`revolve_env.world.world`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.robot import Robot
from revolve_env.world.backend import BodyStates
from revolve_env.world.model import LightSensorModel, RobotModel

__all__ = ["RobotState", "all_finite", "empty_states", "robot_state"]


def all_finite(a: NDArray[np.float64]) -> bool:
    """Whether every entry is finite (fast path: one reduction; exact on overflow)."""
    return math.isfinite(float(np.add.reduce(a, axis=None))) or bool(np.isfinite(a).all())


def empty_states() -> BodyStates:
    """No robots' states (the world's state before the first step)."""
    return BodyStates(np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros((0, 3)),
                      np.zeros(0), np.zeros(0), np.zeros(0, dtype=bool))


@dataclass
class RobotState:
    """Per-robot bookkeeping of the world (private, mutable)."""

    key: int  # the backend's key
    model: RobotModel
    robot: Robot
    targets: NDArray[np.float64]  # active hinge targets. Radians
    active_local: NDArray[np.intp]  # active hinges among the robot's hinges, output order
    n_joints: int  # hinges, active and passive
    sensor_links: list[int]  # non-root links carrying a light sensor
    placed: tuple[float, float, float] = (0.0, 0.0, 0.0)  # root position given to the backend, m
    yaw: float = 0.0  # heading given to the backend. Radians
    row: int = 0  # row in the backend's BodyStates
    joint_start: int = 0  # first hinge in BodyStates.joint_pos
    blow_up: str | None = None


def robot_state(key: int, model: RobotModel, robot: Robot, placed: tuple[float, float, float],
                 yaw: float) -> RobotState:
    """The world's bookkeeping of a robot the backend built under ``key``."""
    hinges = [i for i in range(1, len(model.links)) if not model.links[i].fixed]
    assert hinges == list(range(1, len(hinges) + 1)), "hinge links come before welded ones"
    return RobotState(
        key=key, model=model, robot=robot, targets=np.zeros(model.n_outputs),
        active_local=np.array([i - 1 for i in model.active_links], dtype=np.intp),
        n_joints=len(hinges),
        sensor_links=sorted({
            s.link for _, s in model.sensors if isinstance(s, LightSensorModel) and s.link > 0
        }),
        placed=placed, yaw=yaw,
    )
