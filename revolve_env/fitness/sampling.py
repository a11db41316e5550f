"""When the core's pose is sampled for the fitness: the pose rate, and the shaking it hides.

The paper's system sent robot poses 5 times per simulated second (Revolve's
``--pose-update-frequency 5``) and computed the path ``v`` and the displacement ``s`` over the
window from those poses. Here the pose rate is a setting of the task
(:attr:`revolve_env.tasks.BaseTask.pose_rate`): a number of samples per second (default 5 Hz,
the paper's), or :data:`EVERY_PERIOD` (a sample every control period, 60 Hz with the default
timing: how the fitness was computed before the setting existed).

The rule, in one place for every driver (:func:`revolve_env.evaluate`, the envs, the online
world): a robot's pose is sampled every :func:`pose_stride` control periods, counted from the end
of its insertion (its first sample); :func:`pose_due` says which ages are due. Between two pose
samples the fitness windows hold the last sampled pose (and signal), so the fitness, and the
reward that is its change, move only at pose samples; a sliding window starts at the pose held
at its start (the last pose sample at or before it).

The shaking measure (:func:`shaking`) is the path of the core summed at every control period
over the path summed at the pose rate, over the same span: 1 for a robot that moves smoothly,
large for one whose core trembles or rocks in place between pose samples (what a path summed at
every control period pays it for).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["DEFAULT_POSE_RATE", "EVERY_PERIOD", "check_pose_rate", "pose_due", "pose_stride",
           "shaking"]

EVERY_PERIOD = "every-period"
"""The pose rate that samples the core every control period (the fitness before pose rates)."""

DEFAULT_POSE_RATE: float | str = 5.0
"""The pose rate of a task that does not say: the paper's 5 Hz (samples per second).

Results made before pose rates sampled every control period; their stored configs say so
(:data:`evolution.experiments.store.schema.POSE_RATE_OF_OLD_CONFIGS`)."""


def check_pose_rate(value: object) -> float | str:
    """``value`` as a pose rate: a positive number of Hz (made a float), or "every-period".

    Raises:
        ValueError: anything else (one line naming the value).
    """
    if value == EVERY_PERIOD:
        return EVERY_PERIOD
    if isinstance(value, bool) or not isinstance(value, (int, float)) or \
            not (math.isfinite(value) and value > 0):
        raise ValueError(f"pose_rate must be a positive number of samples per second (Hz) or "
                         f"{EVERY_PERIOD!r}, got {value!r}")
    return float(value)


def pose_stride(pose_rate: float | str, control_period: float) -> int:
    """Control periods between two pose samples (1 for :data:`EVERY_PERIOD`).

    Args:
        pose_rate: Samples per second (Hz), or :data:`EVERY_PERIOD`.
        control_period: The world's control period, itself a whole number of physics steps.
            Seconds.

    Raises:
        ValueError: the pose period (``1 / pose_rate``) is not a whole number of control
            periods (so not of physics steps either): one line naming both.
    """
    rate = check_pose_rate(pose_rate)
    if isinstance(rate, str):
        return 1
    ratio = 1.0 / (rate * control_period)
    stride = round(ratio)
    if stride < 1 or abs(ratio - stride) > 1e-6 * max(1.0, ratio):
        raise ValueError(
            f"pose_rate {rate:g} Hz does not fit the control period of {control_period:.6g} s "
            f"({1.0 / control_period:.6g} Hz): a pose period must be a whole number of control "
            f"periods (use {1.0 / control_period:.6g} Hz divided by a whole number, or "
            f"{EVERY_PERIOD!r})")
    return stride


def pose_due(ages: NDArray[np.int64], stride: int) -> NDArray[np.bool_]:
    """Which robots sample their pose now, from their ages counted from their first sample.

    Args:
        ages: Control periods since each robot's first pose sample (the end of its insertion);
            negative while it is still being inserted.
        stride: :func:`pose_stride`.
    """
    if stride == 1:
        due: NDArray[np.bool_] = ages >= 0
        return due
    due = (ages >= 0) & (ages % stride == 0)
    return due


def shaking(v_every_period: NDArray[np.float64] | float,
            v_pose: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """The shaking measure: path summed at every control period over path at the pose rate.

    Both paths over the same span (from the first to the last pose sample). 1 where the two are
    equal (a pose rate of every control period, or a robot that moves smoothly), more where the
    core's motion between pose samples adds path (tremor, rocking); 1 for a robot that has not
    moved, infinity for one whose pose samples all coincide while it moved between them.
    Dimensionless.
    """
    fine = np.asarray(v_every_period, dtype=np.float64)
    coarse = np.asarray(v_pose, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # a tiny coarse path
        ratio = np.where(fine <= 0.0, 1.0, fine / coarse)
    out: NDArray[np.float64] = np.where(coarse <= 0.0, np.where(fine <= 0.0, 1.0, np.inf),
                                        ratio)
    return out
