"""Engine-neutral settings of a physics world (pure data)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from revolve_env.body.parts import SERVO
from revolve_env.terrain import Flat, Terrain, TerrainError, make_terrain

__all__ = ["DEFAULT_ENGINE", "TIMINGS", "TerrainError", "WorldConfig"]

#: The physics engine of everything that names none: MuJoCo (2.5-3.8x faster than pybullet,
#: exact snapshots). The one home of the default: every ``engine=`` keyword's None, and
#: :class:`revolve_env.Setting`, mean this one. ``engine="pybullet"`` is one keyword away.
#: (Before 2026-11-27 it was pybullet: results stored then name their engine, or are read as
#: pybullet by the store's upgrade.)
DEFAULT_ENGINE = "mujoco"

#: Named timings: preset -> (``timestep``, ``control_period``, ``brain_period``), seconds.
#: ``"default"`` (also ``"revolve-env-2025"``): physics at 1/240 s, servo law, sensors and
#: brains every 1/60 s. ``"revolve2018"``: the paper's system's published defaults (Revolve's
#: ``--controller-update-rate 8``, ``--sensor-update-rate 8``, ``--pose-update-frequency 5``,
#: ``--world-step-size 0.003``): brains (and the sensor values they read) at 8 Hz; physics at
#: 1/320 s, the step nearest 3 ms that whole control periods are made of; the servo law at
#: 1/40 s (Gazebo's servo ran every physics step; 40 Hz is the slowest rate of which both the
#: 8 Hz brain and the 5 Hz poses are whole multiples). Poses at 5 Hz are the task's setting
#: (:attr:`revolve_env.tasks.BaseTask.pose_rate`).
TIMINGS: dict[str, tuple[float, float, float]] = {
    "default": (1.0 / 240.0, 1.0 / 60.0, 1.0 / 60.0),
    "revolve-env-2025": (1.0 / 240.0, 1.0 / 60.0, 1.0 / 60.0),
    "revolve2018": (1.0 / 320.0, 1.0 / 40.0, 1.0 / 8.0),
}


@dataclass(frozen=True, slots=True)
class WorldConfig:
    """Settings of a :class:`~revolve_env.world.World`.

    Timing: physics advances in fixed steps of ``timestep`` (1/240 s, pybullet's default, small
    enough for the 10-60 g RoboGen parts with their 0.18 N m servos to stay stable) and the
    controllers act once per ``control_period`` (1/60 s, four physics steps). Servo commands,
    sensor readings and the blow-up check are refreshed once per control period.

    Attributes:
        engine: The physics engine, a name of :data:`~revolve_env.world.engines.ENGINES`:
            :data:`DEFAULT_ENGINE`, ``"mujoco"`` (faster, exact snapshots; see docs/engines.md
            for its integrator and contact settings), or ``"pybullet"`` (the first engine).
            Every rule above the engine (servo law, sensors, blow-up policy) is the same for
            both. The name is checked against the engine
            registry (:mod:`revolve_env.world.engines`) where a world or an env is made; this
            record is pure data and knows no engine.
        timestep: Physics step. Seconds.
        control_period: Control step (the servo law, sensor readings, blow-up checks); a whole
            multiple of ``timestep``. Seconds.
        brain_period: How often a robot's brain steps (reading its sensors then): a whole
            multiple of ``control_period``, whose servo targets hold in between; None: every
            control period. :data:`TIMINGS` names sets of the three. Seconds.
        gravity: Magnitude of gravity, pointing down (-z). Metres per second squared.
        friction: Coulomb friction coefficient between robots and the ground (and between robots).
        light_position: Position of the point light that light sensors see. Metres.
        light_range: Distance at which the light's intensity has fallen to one half. Metres.
        servo_gain: RoboGen's servo gain (``ServoMotor::DEFAULT_GAIN``): each control period the
            servo is commanded ``velocity = servo_gain * error / control_period``, clipped to
            ``SERVO.max_velocity``. Dimensionless.
        max_torque: Torque limit of an active hinge. Newton metres.
        max_velocity: Speed limit of an active hinge. Radians per second.
        range_deg: A normalized target of +-1 maps to +-``range_deg``. Degrees.
        drop_height: Gap between the robot's lowest point and the ground when it is inserted.
            Metres.
        max_linear_speed: A core faster than this means the simulation blew up. Metres per second.
        max_angular_speed: A core or joint spinning faster than this means the simulation blew up.
            Radians per second.
        solver_iterations: pybullet's constraint solver iterations per physics step (the MuJoCo
            backend's Newton solver stops on its own tolerance: 2-3 iterations per step in a
            30-robot world; CG, elliptic cones or a looser tolerance were slower). 20 rather than
            pybullet's 50: the example gaits keep their fitness (spider 10.2 vs 9.9, gecko 8.9
            vs 8.9, snake 10.0 vs 10.7 over 12 s) while a 30-robot world steps about 1.4x
            faster, which is what lets the online world run faster than real time on one core.
        terrain: The ground (:mod:`revolve_env.terrain`): :class:`Flat` (the plane, the
            default) or a heightfield spec (``Rugged``, ``Crater``, ``Bowl``); a name or a
            table ``{"name": ..., <parameters>}`` is read by
            :func:`~revolve_env.terrain.make_terrain`.
    """

    engine: str = DEFAULT_ENGINE
    timestep: float = 1.0 / 240.0
    control_period: float = 1.0 / 60.0
    gravity: float = 9.81
    friction: float = 1.0
    light_position: tuple[float, float, float] = (1.0, 0.0, 0.1)
    light_range: float = 1.0
    servo_gain: float = 0.5
    max_torque: float = SERVO.max_torque
    max_velocity: float = SERVO.max_velocity
    range_deg: float = SERVO.range_deg
    drop_height: float = 0.02
    max_linear_speed: float = 10.0
    max_angular_speed: float = 200.0
    solver_iterations: int = 20
    terrain: Terrain = field(default_factory=Flat)
    brain_period: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.terrain, Terrain):  # a name or a table: read it (or refuse it)
            object.__setattr__(self, "terrain", make_terrain(self.terrain))
        if not isinstance(self.engine, str):
            raise ValueError(f"engine must be an engine's name, got {self.engine!r}")
        if not (self.timestep > 0 and math.isfinite(self.timestep)):
            raise ValueError(f"timestep must be a positive number of seconds, got {self.timestep}")
        ratio = self.control_period / self.timestep
        if (not (self.control_period > 0 and math.isfinite(ratio))  # before round(): inf, NaN
                or abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1):
            raise ValueError(
                f"control_period ({self.control_period} s) must be a positive whole multiple of "
                f"timestep ({self.timestep} s)"
            )
        if self.brain_period is not None:
            ratio = self.brain_period / self.control_period
            if (not (self.brain_period > 0 and math.isfinite(ratio))
                    or abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1):
                raise ValueError(f"brain_period ({self.brain_period} s) must be a positive whole "
                                 f"multiple of control_period ({self.control_period} s)")
        for name in ("gravity", "friction", "light_range", "servo_gain", "max_torque",
                     "max_velocity", "range_deg", "max_linear_speed", "max_angular_speed"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite non-negative number, got {value}")
        if self.light_range <= 0:
            raise ValueError(f"light_range must be positive, got {self.light_range}")
        if not (math.isfinite(self.drop_height) and self.drop_height >= 0):
            raise ValueError(f"drop_height must be a finite number >= 0 m, got {self.drop_height}")
        if len(self.light_position) != 3 or not all(math.isfinite(v) for v in self.light_position):
            raise ValueError(f"light_position must be 3 finite numbers, got {self.light_position}")
        if self.solver_iterations < 1:
            raise ValueError(f"solver_iterations must be >= 1, got {self.solver_iterations}")

    def with_terrain(self, terrain: Terrain | str | Mapping[str, Any] | None) -> WorldConfig:
        """This config on ``terrain`` (None: its own): a spec, a name or a table.

        The one place where a ``terrain=`` keyword (of ``evaluate`` and the envs) meets a config.

        Raises:
            TerrainError: unknown terrain name or bad parameter.
        """
        if terrain is None:
            return self
        return dataclasses.replace(self, terrain=make_terrain(terrain))

    def with_timing(self, timing: str | None) -> WorldConfig:
        """This config with the physics step, control and brain periods of ``timing``.

        A name of :data:`TIMINGS`; None keeps this config's own.

        Raises:
            ValueError: an unknown name (one line listing the known ones).
        """
        if timing is None:
            return self
        if timing not in TIMINGS:
            raise ValueError(f"unknown timing {timing!r}: choose one of {', '.join(TIMINGS)}")
        timestep, control, brain = TIMINGS[timing]
        return dataclasses.replace(self, timestep=timestep, control_period=control,
                                   brain_period=None if brain == control else brain)

    @property
    def brain_dt(self) -> float:
        """The brain's period (``brain_period``, else ``control_period``). Seconds."""
        return self.control_period if self.brain_period is None else self.brain_period

    @property
    def brain_stride(self) -> int:
        """Control periods per brain step (1: every control period)."""
        return 1 if self.brain_period is None else round(self.brain_period / self.control_period)

    @property
    def substeps(self) -> int:
        """Physics steps per control period."""
        return round(self.control_period / self.timestep)
