"""Sensor maths over arrays of robots: the core IMU and the light sensors (pure NumPy).

Each function works on every robot (or sensor) of a world at once and gives, row by row, the
very bits the same formula gives one robot alone: products of a 3x3 matrix and a vector are
stacked ``matmul`` (what ``rot @ v`` is for one), dot products ``np.vecdot`` (what ``a @ b``
is), squares ``np.float_power`` (what Python's ``x ** 2`` is). ``tests/world/test_sensing.py``
checks them against the per-sensor formulas bit for bit.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.parts import IMU_ACCEL_RANGE, IMU_GYRO_RANGE

__all__ = ["IMU_HIGH", "IMU_LOW", "imu_readings", "light_falloff", "light_intensity"]

IMU_HIGH = np.array([IMU_ACCEL_RANGE] * 3 + [IMU_GYRO_RANGE] * 3)
"""Full scale of the IMU's six values (accelerometer m/s^2, gyroscope rad/s)."""
IMU_LOW = -IMU_HIGH
_TWO = np.float64(2.0)


def imu_readings(
    core_vel: NDArray[np.float64], prev_vel: NDArray[np.float64],
    core_angvel: NDArray[np.float64], core_rot: NDArray[np.float64], control_period: float,
    gravity: float,
) -> NDArray[np.float64]:
    """The core IMU of every robot, (n, 6): accelerometer then gyroscope in the core frame.

    The accelerometer reads the specific force (m/s^2): the change of the core's velocity over
    the last control period plus the reaction to gravity (+g along the world's up axis); the
    gyroscope the angular velocity (rad/s). Not saturated (see :data:`IMU_LOW`, :data:`IMU_HIGH`).

    Args:
        core_vel: (n, 3) core velocities now, world frame. Metres per second.
        prev_vel: (n, 3) core velocities one control period ago.
        core_angvel: (n, 3) core angular velocities, world frame. Radians per second.
        core_rot: (n, 3, 3) rotations from the core frame to the world frame.
        control_period: Seconds.
        gravity: Metres per second squared.
    """
    accel = (core_vel - prev_vel) * (1.0 / control_period)
    accel[:, 2] += gravity
    # rows: R^T a, R^T w (a stacked matmul: the same bits as one robot's)
    both: NDArray[np.float64] = (np.concatenate((accel, core_angvel), axis=1).reshape(-1, 2, 3)
                                 @ core_rot).reshape(-1, 6)
    return both


def light_intensity(
    positions: NDArray[np.float64], rotations: NDArray[np.float64],
    points: NDArray[np.float64], facings: NDArray[np.float64],
    light: NDArray[np.float64], light_range: float,
) -> NDArray[np.float64]:
    """What each light sensor reads: ``max(0, cos a) / (1 + (d / light_range)^2)`` in [0, 1].

    ``d`` is the distance from the sensing point to the light and ``a`` the angle between the
    sensor's facing and the direction to the light (no occlusion); a sensor at the light reads
    ``1 / (1 + 0)`` with ``cos a = 1``.

    Args:
        positions: (k, 3) world positions of the sensors' link frames. Metres.
        rotations: (k, 3, 3) rotations from those frames to the world frame.
        points: (k, 3, 1) sensing points in their link frames (columns). Metres.
        facings: (k, 3, 1) unit facings in their link frames (columns).
        light: (3,) the light's position. Metres.
        light_range: Distance at which the intensity halves. Metres.
    """
    where = positions + (rotations @ points)[:, :, 0]
    facing = (rotations @ facings)[:, :, 0]
    to_light = light - where
    d = np.sqrt(np.vecdot(to_light, to_light))
    cos_a = np.divide(np.vecdot(facing, to_light), d, out=np.ones_like(d), where=d > 0)
    # Python's max(0.0, c) keeps 0.0 unless c > 0 (also for NaN and -0.0): so does this
    bright: NDArray[np.float64] = np.where(cos_a > 0, cos_a, 0.0) / _spread(d, light_range)
    return bright


def _spread(d: NDArray[np.float64], light_range: float) -> NDArray[np.float64]:
    """``1 + (d / light_range)^2``: the light's fall-off with distance ``d`` (metres)."""
    out: NDArray[np.float64] = 1.0 + np.float_power(d / light_range, _TWO)
    return out


def light_falloff(positions: NDArray[np.float64], light: NDArray[np.float64],
                  light_range: float) -> NDArray[np.float64]:
    """What a light sensor at each point facing the light reads: ``1 / (1 + (d / light_range)^2)``.

    :func:`light_intensity` with ``cos a = 1``. Args: ``positions`` (k, 3), ``light`` (3,) in
    metres; ``light_range`` in metres.
    """
    to_light = light - positions
    d = np.sqrt(np.vecdot(to_light, to_light))
    out: NDArray[np.float64] = 1.0 / _spread(d, light_range)
    return out
