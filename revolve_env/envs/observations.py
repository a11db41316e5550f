"""Observation pieces both envs share: the IMU's full-scale ranges and proprioception.

Proprioception is what a learner may see besides RoboGen's sensors: the angle and the angular
velocity of every active hinge, read from the world. The robots' own networks never see it (their
input neurons are RoboGen's sensors only).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.parts import IMU_ACCEL_RANGE, IMU_GYRO_RANGE, PART_SPECS
from revolve_env.body.robot import PartType, Robot
from revolve_env.world import World, WorldConfig

__all__ = [
    "ACCEL_RANGE", "GYRO_RANGE", "HINGE_ANGLE_LIMIT", "IMU_VALUES", "hinge_values",
    "proprio_bounds", "read_proprio", "saturated_sensor_bounds", "uniform_sensor_bounds",
]

# The IMU's full-scale ranges; the world saturates its readings there (one home: body/parts.py).
ACCEL_RANGE = IMU_ACCEL_RANGE
"""Accelerometer full scale. Metres per second squared."""
GYRO_RANGE = IMU_GYRO_RANGE
"""Gyroscope full scale. Radians per second."""
IMU_VALUES = PART_SPECS[PartType.CORE].n_inputs
"""Sensor values of the core (accelerometer x, y, z, gyroscope x, y, z): always the first ones."""
HINGE_ANGLE_LIMIT = math.pi
"""Hinge angles saturate at +-pi in observations (the servo keeps them within +-45 degrees unless
overpowered; the hinge itself has no stop). Radians."""


def saturated_sensor_bounds(robot: Robot) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bounds of a robot's sensor values in controller input order, the IMU at full scale.

    Core: accelerometer ``+-ACCEL_RANGE``, gyroscope ``+-GYRO_RANGE``; touch (binary) and light
    (intensity) sensors read in [0, 1].
    """
    low: list[float] = []
    high: list[float] = []
    for _, node in robot.walk():
        n = PART_SPECS[node.type].n_inputs
        if node.type == PartType.CORE:  # accelerometer, then gyroscope
            low += [-ACCEL_RANGE] * 3 + [-GYRO_RANGE] * 3
            high += [ACCEL_RANGE] * 3 + [GYRO_RANGE] * 3
        else:  # touch (binary) and light (intensity) sensors read in [0, 1]
            low += [0.0] * n
            high += [1.0] * n
    return np.array(low), np.array(high)


def uniform_sensor_bounds(n_inputs: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bounds that fit the sensor values of every robot with at most ``n_inputs`` of them.

    The core comes first in traversal order, so the first six values are always its IMU (at full
    scale); any later value is a touch or light reading in [0, 1] (or padding, 0).

    Raises:
        ValueError: ``n_inputs`` is smaller than the core's six IMU values.
    """
    if n_inputs < IMU_VALUES:
        raise ValueError(f"limits of {n_inputs} inputs leave no room for the core's "
                         f"{IMU_VALUES} IMU values: no robot can be valid")
    rest = n_inputs - IMU_VALUES
    low = np.array([-ACCEL_RANGE] * 3 + [-GYRO_RANGE] * 3 + [0.0] * rest)
    high = np.array([ACCEL_RANGE] * 3 + [GYRO_RANGE] * 3 + [1.0] * rest)
    return low, high


def proprio_bounds(
    n_hinges: int, config: WorldConfig
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Bounds of :func:`read_proprio`'s values for ``n_hinges`` active hinges.

    Angles within ``+-HINGE_ANGLE_LIMIT`` (radians), then angular velocities within
    ``+-config.max_angular_speed`` (rad/s; a faster hinge is a blow-up, so a live robot never
    reads beyond it).
    """
    low = np.concatenate((np.full(n_hinges, -HINGE_ANGLE_LIMIT),
                          np.full(n_hinges, -config.max_angular_speed)))
    return low, -low


def hinge_values(world: World) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Angles (radians) and angular velocities (rad/s) of every robot's active hinges.

    Flat, robots in the world's order, each in controller output order (the order of the
    action entries), saturated at the bounds of :func:`proprio_bounds`.
    """
    limit = world.config.max_angular_speed
    angles = np.minimum(np.maximum(world.hinge_angles(), -HINGE_ANGLE_LIMIT), HINGE_ANGLE_LIMIT)
    speeds = np.minimum(np.maximum(world.hinge_velocities(), -limit), limit)
    return angles, speeds


def read_proprio(world: World, handle: int) -> NDArray[np.float64]:
    """Angles (radians) then angular velocities (rad/s) of one robot's active hinges.

    Its part of :func:`hinge_values`: shape ``(2 n,)`` for ``n`` active hinges.
    """
    limit = world.config.max_angular_speed
    angles = np.minimum(np.maximum(world.joint_angles(handle), -HINGE_ANGLE_LIMIT),
                        HINGE_ANGLE_LIMIT)
    speeds = np.minimum(np.maximum(world.joint_velocities(handle), -limit), limit)
    return np.concatenate((angles, speeds))
