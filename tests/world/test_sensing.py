"""The array sensor maths give, sensor by sensor, the bits of the one-robot formulas."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from revolve_env.body.parts import IMU_ACCEL_RANGE, IMU_GYRO_RANGE
from revolve_env.world.sensing import IMU_HIGH, IMU_LOW, imu_readings, light_intensity


def _rotations(rng: np.random.Generator, n: int) -> np.ndarray:
    q, _ = np.linalg.qr(rng.normal(size=(n, 3, 3)))
    return np.ascontiguousarray(q)


def _one_light(pos: np.ndarray, rot: np.ndarray, point: np.ndarray, facing: np.ndarray,
               light: np.ndarray, light_range: float) -> float:
    """The light sensor as the world computed it for one sensor (before the array pass)."""
    where = pos + rot @ point
    face = rot @ facing
    to_light = light - where
    d = math.sqrt(float(to_light.dot(to_light)))
    cos_a = float(face @ to_light) / d if d > 0 else 1.0
    return max(0.0, cos_a) / (1.0 + (d / light_range) ** 2)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 40))
def test_light_sensors_of_many_robots_read_what_each_alone_reads(seed: int, n: int) -> None:
    rng = np.random.default_rng(seed)
    pos = rng.normal(size=(n, 3)) * rng.choice([0.01, 1.0, 30.0])
    rot = _rotations(rng, n)
    point = rng.normal(size=(n, 3)) * 0.05
    facing = rng.normal(size=(n, 3))
    facing /= np.linalg.norm(facing, axis=1, keepdims=True)
    light = rng.normal(size=3)
    pos[0] = light - rot[0] @ point[0]  # a sensor right at the light: d = 0
    got = light_intensity(pos, rot, point[:, :, None], facing[:, :, None], light, 1.0)
    want = [_one_light(pos[i], rot[i].copy(), point[i], facing[i], light, 1.0) for i in range(n)]
    assert got.tolist() == want
    assert np.all((got >= 0) & (got <= 1))


def test_a_light_sensor_facing_away_reads_plus_zero_and_a_lost_one_nan_as_alone() -> None:
    rot = np.eye(3)[None]
    light = np.array([1.0, 0, 0])
    away = light_intensity(np.zeros((1, 3)), rot, np.zeros((1, 3, 1)),
                           np.array([[-1.0, 0, 0]])[:, :, None], light, 1.0)
    assert away.tolist() == [0.0] and math.copysign(1.0, away[0]) == 1.0  # max(0.0, -0.9)
    lost = light_intensity(np.full((1, 3), np.nan), rot, np.zeros((1, 3, 1)),
                           np.array([[1.0, 0, 0]])[:, :, None], light, 1.0)
    alone = _one_light(np.full(3, np.nan), np.eye(3), np.zeros(3), np.array([1.0, 0, 0]), light,
                       1.0)
    assert math.isnan(lost[0]) and math.isnan(alone)  # a blow-up stays visible


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 40))
def test_imu_of_many_robots_reads_what_each_alone_reads(seed: int, n: int) -> None:
    rng = np.random.default_rng(seed)
    vel, prev, spin = (rng.normal(size=(n, 3)) for _ in range(3))
    rot = _rotations(rng, n)
    got = imu_readings(vel, prev, spin, rot, 1 / 60, 9.81)
    for i in range(n):  # one robot: the same formula on arrays of one row
        one = imu_readings(vel[i:i + 1], prev[i:i + 1], spin[i:i + 1], rot[i:i + 1].copy(),
                           1 / 60, 9.81)
        assert got[i].tolist() == one[0].tolist()
    assert IMU_HIGH.tolist() == [IMU_ACCEL_RANGE] * 3 + [IMU_GYRO_RANGE] * 3
    assert IMU_LOW.tolist() == (-IMU_HIGH).tolist()
