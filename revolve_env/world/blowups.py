"""The blow-up policy: when a robot's simulation is not to be trusted any more.

A robot blows up when its state is not finite (NaN or infinity, or an engine that found it so and
put it at rest: ``diverged``), its core moves faster than ``max_linear_speed`` or spins faster
than ``max_angular_speed``, a hinge turns faster than ``max_angular_speed``, or its core falls
more than a metre through the ground. :func:`all_calm` screens every robot at once each control
period; only when it fails does :func:`reason` look at each robot.
"""

from __future__ import annotations

import math

import numpy as np

from revolve_env.world.backend import BodyStates
from revolve_env.world.config import WorldConfig
from revolve_env.world.robot_state import all_finite

__all__ = ["Screen", "all_calm", "reason"]

# |v|_max * sqrt(3) bounds the speed |v| from above; the margin keeps the screen strict.
_SCREEN = 0.999 / math.sqrt(3.0)
_max = np.maximum.reduce
_min = np.minimum.reduce


class Screen:
    """:func:`all_calm`'s per-entry limits for ``n`` robots with ``hinges`` hinges in all."""

    def __init__(self, n: int, hinges: int, c: WorldConfig) -> None:
        # |x| / limit <= 1 entry by entry: the core's velocity, spin and hinge speeds against
        # their screens; positions and hinge angles only against overflow (any finite value
        # passes, a NaN or infinity does not).
        self.inverse = np.concatenate((
            np.full(3 * n, 1.0 / (_SCREEN * c.max_linear_speed)),
            np.full(3 * n, 1.0 / (_SCREEN * c.max_angular_speed)),
            np.full(hinges, 1.0 / (0.999 * c.max_angular_speed)),
            np.full(3 * n + hinges, 1e-300)))


def all_calm(s: BodyStates, screen: Screen) -> bool:
    """True when no robot can have blown up (every robot's :func:`reason` is then None).

    A conservative screen of every robot at once: False may still find no blown robot. A NaN
    makes the maximum NaN and the comparison False; the screen's limits are 0.1 % inside the
    blow-up limits, so rounding near them cannot hide a blow-up. The core's orientation has no
    limit (a rotation's entries are in [-1, 1]) but must be finite, as :func:`reason` requires.
    Needs at least one robot.
    """
    x = np.concatenate((s.core_vel.reshape(-1), s.core_angvel.reshape(-1), s.joint_vel,
                        s.core_pos.reshape(-1), s.joint_pos))
    np.abs(x, out=x)
    x *= screen.inverse
    return bool(_max(x) <= 1.0 and _min(s.core_pos[:, 2]) >= -0.999
                and not np.count_nonzero(s.diverged) and all_finite(s.core_rot))


def reason(s: BodyStates, row: int, joints: slice, c: WorldConfig, time: float) -> str | None:
    """Why the robot in ``row`` (hinges ``joints`` of the joint arrays) blew up, else None.

    Args:
        s: Every robot's state.
        row: The robot's row.
        joints: Its hinges in ``s.joint_pos`` and ``s.joint_vel``.
        c: The limits.
        time: Simulated time, for the message. Seconds.
    """
    joint_vel = s.joint_vel[joints]
    finite = (not s.diverged[row]
              and all(all_finite(a[row]) for a in (s.core_pos, s.core_rot, s.core_vel,
                                                    s.core_angvel))
              and all_finite(s.joint_pos[joints]) and all_finite(joint_vel))
    if not finite:
        return f"non-finite state (NaN or infinity) at t={time:.3f} s"
    vx, vy, vz = s.core_vel[row]
    speed = math.sqrt(vx * vx + vy * vy + vz * vz)
    if speed > c.max_linear_speed:
        return f"core speed {speed:.1f} m/s exceeds {c.max_linear_speed} m/s at t={time:.3f} s"
    wx, wy, wz = s.core_angvel[row]
    spin = math.sqrt(wx * wx + wy * wy + wz * wz)
    if spin > c.max_angular_speed:
        return (f"core spin {spin:.1f} rad/s exceeds {c.max_angular_speed} rad/s "
                f"at t={time:.3f} s")
    if joint_vel.size:
        fastest = float(np.abs(joint_vel).max())
        if fastest > c.max_angular_speed:
            return (f"hinge speed {fastest:.1f} rad/s exceeds {c.max_angular_speed} rad/s "
                    f"at t={time:.3f} s")
    z = float(s.core_pos[row, 2])
    if z < -1.0:
        return f"core fell through the ground (z={z:.2f} m) at t={time:.3f} s"
    return None
