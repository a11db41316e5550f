"""The engine-neutral :class:`World`: RoboGen's rules over a batched physics backend.

Everything a physics engine should not decide lives here, once, for every engine: the target
clipping and the NaN guard on hinge targets, RoboGen's servo law, the IMU and light-sensor maths
and the blow-up policy. The engine itself is a :class:`~revolve_env.world.backend.PhysicsBackend`
chosen by ``WorldConfig.engine``, driven with one batched call per primitive and control period.
"""

from __future__ import annotations

import math
from types import TracebackType
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from revolve_env.body.parts import IMU_ACCEL_RANGE, IMU_GYRO_RANGE
from revolve_env.body.robot import Robot
from revolve_env.body.serialize import from_json, to_json
from revolve_env.world.backend import (
    PhysicsBackend,
    PlacedModel,
    SnapshotMismatchError,
    make_backend,
)
from revolve_env.world.config import WorldConfig
from revolve_env.world.model import LightSensorModel, TouchSensorModel, build_model
from revolve_env.world.robot_state import RobotState, all_finite, empty_states, robot_state

__all__ = ["World"]


class World:
    """A flat world with gravity, friction, one point light and any number of robots.

    Units are SI throughout (metres, seconds, radians, kilograms). Time advances in control
    periods (``config.control_period``, 1/60 s by default), each made of ``config.substeps``
    physics steps (1/240 s by default). Each control period, every active hinge behaves like
    RoboGen's servo: it is commanded the velocity ``gain * (target - angle) / control_period``
    clipped to the servo's speed, with the servo's torque limit; passive hinges turn freely.

    Robots collide with the ground and with each other (not with themselves: the boxes of a
    RoboGen hinge interpenetrate by design). The physics engine is ``config.engine``
    (``"pybullet"`` or ``"mujoco"``); the rules above are the same for all.

    Use as a context manager, or call :meth:`close`::

        with World(WorldConfig(engine="mujoco")) as world:
            h = world.add_robot(robot)
            world.set_targets(h, np.zeros(world.n_outputs(h)))
            world.step(60)
            print(world.core_position(h))
    """

    def __init__(self, config: WorldConfig | None = None, *, gui: bool = False) -> None:
        """Start a fresh engine of ``config.engine`` and build the ground.

        Args:
            config: Physics settings; defaults to ``WorldConfig()`` (pybullet).
            gui: Open the engine's window instead of running headless (pybullet only).

        Raises:
            EngineUnavailableError: the engine's package is not installed.
            RuntimeError: the engine could not start, or a GUI was asked for without a display,
                while another GUI is open, or of an engine that has none.
        """
        self.config = config if config is not None else WorldConfig()
        self._backend: PhysicsBackend = make_backend(self.config, gui=gui)
        self._closed = False
        self._robots: dict[int, RobotState] = {}
        self._next_handle = 0
        self._time = 0.0
        self._now = empty_states()
        self._prev_vel = np.zeros((0, 3))
        self._active_index = np.zeros(0, dtype=np.intp)
        self._imu: NDArray[np.float64] | None = None  # every robot's IMU, computed on demand

    def reset(self) -> None:
        """Remove every robot and restart the simulation from time 0 with the same engine.

        After a reset the world behaves exactly like a new one (same inputs, same trajectory).
        Handles are still never reused.
        """
        self._check_open()
        self._backend.reset()
        self._robots.clear()
        self._time = 0.0
        self._relayout()

    # -- lifetime ---------------------------------------------------------------------------
    def close(self) -> None:
        """Release the physics engine (idempotent)."""
        if not self._closed:
            self._closed = True
            self._backend.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("this World is closed")

    # -- properties ---------------------------------------------------------------------------
    @property
    def engine(self) -> str:
        """Name of the physics engine (``config.engine``)."""
        return self.config.engine

    @property
    def backend(self) -> PhysicsBackend:
        """The engine backend (owned by this world: for benchmarks and diagnostics only)."""
        return self._backend

    @property
    def time(self) -> float:
        """Simulated time since the world was made. Seconds."""
        return self._time

    @property
    def handles(self) -> tuple[int, ...]:
        """Handles of the robots in the world, in insertion order."""
        return tuple(self._robots)

    def robot(self, handle: int) -> Robot:
        """The robot description behind ``handle``."""
        return self._state(handle).robot

    def n_inputs(self, handle: int) -> int:
        """Number of sensor values of a robot."""
        return self._state(handle).model.n_inputs

    def n_outputs(self, handle: int) -> int:
        """Number of active hinges of a robot."""
        return self._state(handle).model.n_outputs

    def total_mass(self, handle: int) -> float:
        """Mass of a robot as the physics engine holds it (all links). Kilograms."""
        return self._backend.total_mass(self._state(handle).key)

    def body_count(self) -> int:
        """Number of robots in the physics engine plus the ground (for leak checks)."""
        self._check_open()
        return self._backend.body_count()

    def _state(self, handle: int) -> RobotState:
        self._check_open()
        try:
            return self._robots[handle]
        except KeyError:
            raise KeyError(f"no robot with handle {handle} in this world") from None

    # -- robots -------------------------------------------------------------------------------
    def add_robot(
        self, robot: Robot, position: tuple[float, float] = (0.0, 0.0), yaw: float = 0.0,
        drop_height: float | None = None,
    ) -> int:
        """Insert a robot, dropped so that its lowest point is ``drop_height`` above the ground.

        The robot must be valid (``revolve_env.body.validate``); this method only builds it.
        Every other robot's state is kept exactly.

        Args:
            robot: The robot.
            position: Horizontal position of the core. Metres.
            yaw: Heading about the vertical axis. Radians.
            drop_height: Gap under the robot. Metres; defaults to ``config.drop_height``.

        Returns:
            A handle, never reused within this world.

        Raises:
            ValueError: a non-finite position, yaw or drop height, or a robot the engine cannot
                build (the world is unchanged then).
        """
        self._check_open()
        x, y = (float(v) for v in position)
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
            raise ValueError(f"position {position} and yaw {yaw} must be finite")
        gap = self.config.drop_height if drop_height is None else float(drop_height)
        if not (math.isfinite(gap) and gap >= 0):
            raise ValueError(f"drop_height must be >= 0 m, got {drop_height}")
        model = build_model(robot)
        placed = (x, y, gap - model.lowest_z)
        key = self._backend.add(model, placed, float(yaw))
        state = robot_state(key, model, robot, placed, float(yaw))
        handle = self._next_handle
        self._next_handle += 1
        previous = self._prev_vel
        self._robots[handle] = state
        self._relayout()
        # Survivors keep the velocity of the last period for their IMU; the newborn is at rest.
        self._prev_vel = np.concatenate((previous, self._now.core_vel[state.row:state.row + 1]))
        self._imu = None
        state.blow_up = self._check_blow_up(state)
        return handle

    # -- export -------------------------------------------------------------------------------
    def to_mjcf(self) -> str:
        """The whole scene as placed, as MuJoCo's MJCF text (any engine's world).

        The ground, the light, the physics options and every robot where it was added (its root
        link at its insertion pose, hinges at zero), with the servos and contact settings of the
        MuJoCo backend. ``mujoco.MjModel.from_xml_string(world.to_mjcf())`` compiles, for a MuJoCo
        world, to the very model the world steps (the same MJB bytes), so it can be stepped and
        timed bare; a pybullet world's robots come out as a MuJoCo world holding them would.

        Raises:
            EngineUnavailableError: the ``mujoco`` package is not installed.
        """
        self._check_open()
        return self._backend.mjcf()

    # -- snapshots ----------------------------------------------------------------------------
    @property
    def exact_restore(self) -> bool:
        """Whether :meth:`restore` continues a :meth:`snapshot` bit for bit on this engine.

        MuJoCo: yes; pybullet: no (see its backend).
        """
        return self._backend.exact_restore

    def snapshot(self) -> dict[str, Any]:
        """Everything an exact continuation of this world needs, as plain data.

        The robots (JSON, in insertion order, with their handles and the poses they were added
        at), their targets and blow-ups, the clock, the IMU's previous velocities and the
        engine's state (:meth:`PhysicsBackend.snapshot`). :meth:`restore` on a fresh world of the
        same config makes a world that steps on exactly as this one.

        Raises:
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        self._check_open()
        backend = self._backend.snapshot()
        return {
            "engine": self.engine, "time": self._time, "next_handle": self._next_handle,
            "prev_vel": self._prev_vel.copy(), "backend": backend,
            "robots": [
                {"handle": h, "key": s.key, "robot": to_json(s.robot, indent=None),
                 "placed": list(s.placed), "yaw": s.yaw, "targets": s.targets.copy(),
                 "blow_up": s.blow_up}
                for h, s in self._robots.items()
            ],
        }

    def restore(self, snapshot: dict[str, Any]) -> None:
        """Replace this world's robots and state by those of a :meth:`snapshot`.

        Raises:
            SnapshotMismatchError: the snapshot is of another engine, or its scene cannot be
                rebuilt exactly (the world is empty then, at time 0).
            NotImplementedError: the engine cannot restore its state exactly (pybullet).
        """
        self._check_open()
        if snapshot.get("engine") != self.engine:
            raise SnapshotMismatchError(f"the snapshot is of engine {snapshot.get('engine')!r}, "
                                        f"this world runs {self.engine!r}")
        robots: dict[int, RobotState] = {}
        placed: list[PlacedModel] = []
        try:
            for entry in snapshot["robots"]:
                robot = from_json(entry["robot"])
                model = build_model(robot)
                x, y, z = (float(v) for v in entry["placed"])
                state = robot_state(int(entry["key"]), model, robot, (x, y, z),
                                     float(entry["yaw"]))
                targets = np.array(entry["targets"], dtype=np.float64)
                if targets.shape != state.targets.shape:
                    raise SnapshotMismatchError(f"robot {entry['handle']}: {targets.shape[0]} "
                                                f"targets for {model.n_outputs} active hinges")
                state.targets = targets
                state.blow_up = entry["blow_up"]
                robots[int(entry["handle"])] = state
                placed.append((state.key, model, state.placed, state.yaw))
            prev_vel = np.array(snapshot["prev_vel"], dtype=np.float64).reshape(-1, 3)
            if prev_vel.shape[0] != len(robots):
                raise SnapshotMismatchError("the snapshot's IMU state does not fit its robots")
        except (KeyError, TypeError, ValueError) as e:
            if isinstance(e, SnapshotMismatchError):
                raise
            raise SnapshotMismatchError(f"damaged world snapshot: {e}") from e
        self._robots.clear()
        self._time = 0.0
        try:
            self._backend.restore(placed, snapshot["backend"])
        except BaseException:
            self._relayout()
            raise
        self._robots = robots
        self._next_handle = int(snapshot["next_handle"])
        self._time = float(snapshot["time"])
        self._relayout()
        self._prev_vel = prev_vel

    def remove_robot(self, handle: int) -> None:
        """Take a robot out of the world; its bodies are deleted.

        The others keep their state exactly. See the backend's ``remove`` for what the engine
        keeps allocated.
        """
        state = self._state(handle)
        keep = np.ones(len(self._robots), dtype=bool)
        keep[state.row] = False
        self._backend.remove(state.key)
        del self._robots[handle]
        previous = self._prev_vel[keep]
        self._relayout()
        self._prev_vel = previous
        self._imu = None

    def _relayout(self) -> None:
        """Rows and hinge offsets of every robot, and a fresh read (after a birth or death)."""
        start = 0
        active: list[NDArray[np.intp]] = []
        for row, state in enumerate(self._robots.values()):
            state.row = row
            state.joint_start = start
            active.append(start + state.active_local)
            start += state.n_joints
        self._active_index = np.concatenate(active) if active else np.zeros(0, dtype=np.intp)
        self._now = self._backend.read() if self._robots else empty_states()
        self._prev_vel = self._now.core_vel.copy()
        self._imu = None

    # -- control ------------------------------------------------------------------------------
    def set_targets(self, handle: int, targets: ArrayLike) -> None:
        """Set the active hinges' position targets, normalized to [-1, 1] (= +-45 degrees).

        Values outside [-1, 1] are clipped. Targets hold until changed. NaN or infinity (a
        controller whose network diverged) marks the robot as blown up (see :meth:`blow_up`) and
        holds its hinges at 0: the caller sees the reason and nothing crashes.
        """
        state = self._state(handle)
        t = np.asarray(targets, dtype=np.float64).reshape(-1)
        if t.shape[0] != state.model.n_outputs:
            raise ValueError(
                f"robot {handle} has {state.model.n_outputs} active hinges, "
                f"got {t.shape[0]} targets"
            )
        if not all_finite(t):
            if state.blow_up is None:
                state.blow_up = (f"non-finite hinge targets at t={self._time:.3f} s "
                                 "(the controller's outputs diverged)")
            state.targets = np.zeros_like(state.targets)
            return
        # minimum/maximum: np.clip's Python wrapper costs more than the clipping (hot path)
        state.targets = np.minimum(np.maximum(t, -1.0), 1.0) * math.radians(self.config.range_deg)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` control periods (each ``config.substeps`` physics steps)."""
        self._check_open()
        if n < 0:
            raise ValueError(f"cannot step a negative number of periods ({n})")
        c = self.config
        backend = self._backend
        k = c.servo_gain / c.control_period
        for _ in range(n):
            if self._active_index.size:
                # RoboGen's servo law, for every active hinge of every robot at once.
                targets = np.concatenate([s.targets for s in self._robots.values()])
                q = self._now.joint_pos[self._active_index]
                vel = np.minimum(np.maximum(k * (targets - q), -c.max_velocity), c.max_velocity)
                backend.set_joint_velocities(vel, c.max_torque)
            backend.step(c.substeps)
            self._time += c.control_period
            if self._robots:
                self._prev_vel = self._now.core_vel
                self._now = backend.read()
                self._imu = None
                self._check_blow_ups()

    # -- blow-ups -----------------------------------------------------------------------------
    def _check_blow_ups(self) -> None:
        """Flag every robot whose state is non-finite or beyond a sane speed.

        One batched test for the common case where none is, then the exact per-robot test.
        """
        c = self.config
        s = self._now
        # A NaN anywhere makes its max/min NaN and the comparison False; |v|_max * sqrt(3)
        # bounds the speed |v| from above.
        screen = 0.999 / math.sqrt(3.0)
        calm = (
            float(np.abs(s.core_vel).max()) <= screen * c.max_linear_speed
            and float(np.abs(s.core_angvel).max()) <= screen * c.max_angular_speed
            and (s.joint_vel.size == 0
                 or float(np.abs(s.joint_vel).max()) <= 0.999 * c.max_angular_speed)
            and float(s.core_pos[:, 2].min()) >= -0.999
            and all_finite(s.core_pos) and all_finite(s.joint_pos)
            and not s.diverged.any()
        )
        if calm:
            return
        for state in self._robots.values():
            if state.blow_up is None:
                state.blow_up = self._check_blow_up(state)

    def _check_blow_up(self, state: RobotState) -> str | None:
        c = self.config
        s = self._now
        r = state.row
        joints = slice(state.joint_start, state.joint_start + state.n_joints)
        joint_vel = s.joint_vel[joints]
        finite = (not s.diverged[r]
                  and all(all_finite(a[r]) for a in (s.core_pos, s.core_rot, s.core_vel,
                                                      s.core_angvel))
                  and all_finite(s.joint_pos[joints]) and all_finite(joint_vel))
        if not finite:
            return f"non-finite state (NaN or infinity) at t={self._time:.3f} s"
        vx, vy, vz = s.core_vel[r]
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        if speed > c.max_linear_speed:
            return (f"core speed {speed:.1f} m/s exceeds {c.max_linear_speed} m/s "
                    f"at t={self._time:.3f} s")
        wx, wy, wz = s.core_angvel[r]
        spin = math.sqrt(wx * wx + wy * wy + wz * wz)
        if spin > c.max_angular_speed:
            return (f"core spin {spin:.1f} rad/s exceeds {c.max_angular_speed} rad/s "
                    f"at t={self._time:.3f} s")
        if joint_vel.size:
            fastest = float(np.abs(joint_vel).max())
            if fastest > c.max_angular_speed:
                return (f"hinge speed {fastest:.1f} rad/s exceeds {c.max_angular_speed} rad/s "
                        f"at t={self._time:.3f} s")
        z = float(s.core_pos[r, 2])
        if z < -1.0:
            return f"core fell through the ground (z={z:.2f} m) at t={self._time:.3f} s"
        return None

    def blow_up(self, handle: int) -> str | None:
        """Why the robot's simulation blew up (NaN, or a part beyond a sane speed), else None.

        Once set, the reason stays; the robot keeps being simulated until removed.
        """
        return self._state(handle).blow_up

    # -- state --------------------------------------------------------------------------------
    def core_position(self, handle: int) -> NDArray[np.float64]:
        """Position of the core's centre. Metres, shape (3,)."""
        pos: NDArray[np.float64] = self._now.core_pos[self._state(handle).row].copy()
        return pos

    def core_positions(self, handles: tuple[int, ...] | list[int] | None = None
                       ) -> NDArray[np.float64]:
        """Core positions of several robots (all, in insertion order, by default). Shape (k, 3)."""
        if handles is None:
            self._check_open()
            return self._now.core_pos.copy()
        rows = [self._state(h).row for h in handles]
        return self._now.core_pos[rows] if rows else np.empty((0, 3))

    def core_rotation(self, handle: int) -> NDArray[np.float64]:
        """Rotation from the core frame to the world frame, shape (3, 3)."""
        rot: NDArray[np.float64] = self._now.core_rot[self._state(handle).row].copy()
        return rot

    def core_velocity(self, handle: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Linear velocity of the core's centre (m/s) and angular velocity (rad/s), world frame."""
        r = self._state(handle).row
        return self._now.core_vel[r].copy(), self._now.core_angvel[r].copy()

    def joint_angles(self, handle: int) -> NDArray[np.float64]:
        """Angles of the active hinges in controller output order. Radians."""
        state = self._state(handle)
        return self._now.joint_pos[state.joint_start + state.active_local]

    def joint_velocities(self, handle: int) -> NDArray[np.float64]:
        """Angular velocities of the active hinges, in controller output order. Rad/s."""
        state = self._state(handle)
        return self._now.joint_vel[state.joint_start + state.active_local]

    # -- sensors ------------------------------------------------------------------------------
    def _imus(self) -> NDArray[np.float64]:
        """The core IMU of every robot, (n, 6): accelerometer then gyroscope, core frame."""
        if self._imu is None:
            c = self.config
            s = self._now
            accel = (s.core_vel - self._prev_vel) * (1.0 / c.control_period)
            accel[:, 2] += c.gravity
            # rows: R^T a, R^T w (a stacked matmul: the same bits as one robot's)
            self._imu = (np.concatenate((accel, s.core_angvel), axis=1).reshape(-1, 2, 3)
                         @ s.core_rot).reshape(-1, 6)
        return self._imu

    def read_sensors(self, handle: int) -> NDArray[np.float64]:
        """All sensor values of a robot, in controller input order (float64, shape (n_inputs,)).

        * Core IMU (6 values): accelerometer x, y, z (m/s^2, specific force in the core frame: a
          robot at rest reads +g along the up axis) and gyroscope x, y, z (rad/s, core frame).
          The acceleration is the change of the core's velocity over the last control period.
          Readings saturate at the sensor's full scale, +-16 g and +-2000 deg/s
          (:data:`~revolve_env.body.parts.IMU_ACCEL_RANGE`, ``IMU_GYRO_RANGE``).
        * Touch sensor (2 values): 1.0 if the left/right half touches anything, else 0.0.
        * Light sensor (1 value): ``max(0, cos a) / (1 + (d / light_range)^2)`` in [0, 1], with
          ``d`` the distance to the light and ``a`` the angle between the sensor's facing and the
          direction to the light (no occlusion).
        """
        state = self._state(handle)
        model = state.model
        out = np.empty(model.n_inputs)
        if model.n_inputs == 0:
            return out
        s = self._now
        r = state.row
        core_rot = s.core_rot[r]
        link_pose: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {
            0: (s.core_pos[r], core_rot)
        }
        if state.sensor_links:
            poses = self._backend.link_poses(state.key, state.sensor_links)
            link_pose.update(zip(state.sensor_links, poses, strict=True))
        contacts: frozenset[int] | None = None  # model link indices touching anything
        c = self.config
        light = np.asarray(c.light_position)
        k = 0
        for kind, sensor in model.sensors:
            if kind == "imu":
                # The real sensor saturates at full scale (NaN passes: a blow-up stays visible).
                imu = self._imus()[r]
                out[k:k + 3] = np.minimum(np.maximum(imu[:3], -IMU_ACCEL_RANGE), IMU_ACCEL_RANGE)
                out[k + 3:k + 6] = np.minimum(np.maximum(imu[3:], -IMU_GYRO_RANGE), IMU_GYRO_RANGE)
                k += 6
            elif kind == "touch":
                assert isinstance(sensor, TouchSensorModel)
                if contacts is None:
                    contacts = self._backend.contacts(state.key)
                out[k] = 1.0 if sensor.links[0] in contacts else 0.0
                out[k + 1] = 1.0 if sensor.links[1] in contacts else 0.0
                k += 2
            else:
                assert isinstance(sensor, LightSensorModel)
                pos, rot = link_pose[sensor.link]
                where = pos + rot @ sensor.position
                facing = rot @ sensor.direction
                to_light = light - where
                d = math.sqrt(float(to_light.dot(to_light)))  # np.linalg.norm's own formula
                cos_a = float(facing @ to_light) / d if d > 0 else 1.0
                out[k] = max(0.0, cos_a) / (1.0 + (d / c.light_range) ** 2)
                k += 1
        return out

    # -- rendering ----------------------------------------------------------------------------
    def render(
        self, width: int = 480, height: int = 360, target: ArrayLike | None = None,
        distance: float = 1.0, yaw_deg: float = 45.0, pitch_deg: float = -30.0,
    ) -> NDArray[np.uint8]:
        """An RGB picture of the world, shape (height, width, 3).

        Args:
            width: Picture width. Pixels.
            height: Picture height. Pixels.
            target: Point the camera looks at (metres); defaults to the first robot's core.
            distance: Camera distance from the target. Metres.
            yaw_deg: Camera heading. Degrees.
            pitch_deg: Camera elevation (negative looks down). Degrees.

        Raises:
            RuntimeError: the engine cannot render here (MuJoCo without an OpenGL context).
        """
        self._check_open()
        if target is None:
            target = self._now.core_pos[0] if self._robots else np.zeros(3)
        x, y, z = (float(v) for v in np.asarray(target, dtype=np.float64).reshape(3))
        return self._backend.render(width, height, (x, y, z), distance, yaw_deg, pitch_deg)

    def look_at(self, target: ArrayLike, distance: float = 1.0) -> None:
        """Point the GUI window's camera at ``target`` (no effect without a GUI)."""
        x, y, z = (float(v) for v in np.asarray(target, dtype=np.float64).reshape(3))
        self._backend.look_at((x, y, z), distance)
