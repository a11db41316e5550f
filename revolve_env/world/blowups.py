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

__all__ = ["all_calm", "reason"]

# |v|_max * sqrt(3) bounds the speed |v| from above; the margin keeps the screen strict.
_SCREEN = 0.999 / math.sqrt(3.0)
_max = np.maximum.reduce
_min = np.minimum.reduce


def all_calm(s: BodyStates, c: WorldConfig) -> bool:
    """True when no robot can have blown up (every robot's :func:`reason` is then None).

    A conservative screen of every robot at once: False may still find no blown robot. A NaN
    makes its max or min NaN and the comparison False. Needs at least one robot.
    """
    lin = _SCREEN * c.max_linear_speed
    ang = _SCREEN * c.max_angular_speed
    hinge = 0.999 * c.max_angular_speed
    v, w, jv = s.core_vel, s.core_angvel, s.joint_vel
    return bool(
        _max(v, axis=None) <= lin and _min(v, axis=None) >= -lin
        and _max(w, axis=None) <= ang and _min(w, axis=None) >= -ang
        and (jv.size == 0 or (_max(jv) <= hinge and _min(jv) >= -hinge))
        and _min(s.core_pos[:, 2]) >= -0.999
        and all_finite(s.core_pos) and all_finite(s.joint_pos)
        and not s.diverged.any()
    )


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
