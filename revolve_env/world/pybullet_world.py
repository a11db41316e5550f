"""The pybullet backend of :class:`World` (the only module of the package that imports pybullet).

One :class:`World` owns one pybullet client and passes ``physicsClientId`` on every call; it never
touches pybullet's implicit client 0. Each robot becomes one multibody built directly (no URDF)
from :func:`revolve_env.world.model.build_model`: one link per rigid body, compound box collision
shapes, exact masses, centres of mass and principal inertias, and revolute joints at the hinge
anchors.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass, field
from types import TracebackType
from typing import Self

import numpy as np
import pybullet as pb
from numpy.typing import ArrayLike, NDArray

from revolve_env.body.robot import Robot
from revolve_env.world._rotations import matrix_to_quat, quat_to_matrix
from revolve_env.world.config import WorldConfig
from revolve_env.world.model import LightSensorModel, RobotModel, TouchSensorModel, build_model

__all__ = ["World"]

_ROBOT_FRICTION = 1.0  # pybullet multiplies the two bodies' coefficients; the ground sets the value


def _all_finite(a: NDArray[np.float64]) -> bool:
    """Whether every entry is finite (fast path: one reduction; exact on overflow)."""
    return math.isfinite(float(np.add.reduce(a, axis=None))) or bool(np.isfinite(a).all())


@dataclass
class _RobotState:
    """Mutable per-robot bookkeeping (private)."""

    body: int
    model: RobotModel
    robot: Robot
    shapes: list[int]
    active_joints: list[int]
    all_joints: list[int]
    sensor_links: list[int]
    targets: NDArray[np.float64]
    forces: list[float]  # servo torque limit per active hinge
    # refreshed every control period
    core_pos: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    core_rot: NDArray[np.float64] = field(default_factory=lambda: np.eye(3))
    core_vel: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    core_angvel: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    prev_core_vel: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    joint_pos: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))  # by joint index
    joint_vel: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    blow_up: str | None = None


class World:
    """A flat world with gravity, friction, one point light and any number of robots.

    Units are SI throughout (metres, seconds, radians, kilograms). Time advances in control
    periods (``config.control_period``, 1/60 s by default), each made of ``config.substeps``
    physics steps (1/240 s by default). Each control period, every active hinge behaves like
    RoboGen's servo: it is commanded the velocity ``gain * (target - angle) / control_period``
    clipped to the servo's speed, with the servo's torque limit; passive hinges turn freely.

    Robots collide with the ground and with each other (not with themselves: the boxes of a
    RoboGen hinge interpenetrate by design).

    Use as a context manager, or call :meth:`close`::

        with World() as world:
            h = world.add_robot(robot)
            world.set_targets(h, np.zeros(world.n_outputs(h)))
            world.step(60)
            print(world.core_position(h))
    """

    def __init__(self, config: WorldConfig | None = None, *, gui: bool = False) -> None:
        """Connect a fresh physics client and build the ground.

        Args:
            config: Physics settings; defaults to ``WorldConfig()``.
            gui: Open pybullet's window (one per process) instead of a headless client.

        Raises:
            RuntimeError: no physics server could be started, or a GUI was asked for without a
                display or while another GUI is open.
        """
        self.config = config if config is not None else WorldConfig()
        self._gui = gui
        if gui and sys.platform.startswith("linux") and not (
            os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
        ):
            # pybullet's GUI would hang or abort the process without a display: refuse instead.
            raise RuntimeError("cannot open pybullet's GUI: no display (DISPLAY is not set)")
        self._cid = pb.connect(pb.GUI if gui else pb.DIRECT)
        if self._cid < 0:
            raise RuntimeError(
                "could not connect to a pybullet physics server"
                + (" (pybullet allows one GUI per process)" if gui else "")
            )
        self._closed = False
        self._robots: dict[int, _RobotState] = {}
        self._next_handle = 0
        self._time = 0.0
        self._setup()

    def _setup(self) -> None:
        """Physics settings and the ground (on a fresh or freshly reset client)."""
        cid = self._cid
        c = self.config
        pb.setPhysicsEngineParameter(
            fixedTimeStep=c.timestep, numSubSteps=0, numSolverIterations=c.solver_iterations,
            deterministicOverlappingPairs=1, physicsClientId=cid,
        )
        pb.setGravity(0.0, 0.0, -c.gravity, physicsClientId=cid)
        if self._gui:
            pb.configureDebugVisualizer(pb.COV_ENABLE_GUI, 0, physicsClientId=cid)
        plane = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=cid)
        self._ground = pb.createMultiBody(0.0, plane, physicsClientId=cid)
        pb.changeDynamics(self._ground, -1, lateralFriction=c.friction, restitution=0.0,
                          physicsClientId=cid)
        pb.changeVisualShape(self._ground, -1, rgbaColor=(0.85, 0.85, 0.8, 1.0), physicsClientId=cid)

    def reset(self) -> None:
        """Remove every robot and restart the simulation from time 0 on the same client.

        After a reset the world behaves exactly like a new one (same inputs, same trajectory).
        Handles are still never reused.
        """
        self._check_open()
        pb.resetSimulation(physicsClientId=self._cid)
        self._robots.clear()
        self._time = 0.0
        self._setup()

    # -- lifetime ---------------------------------------------------------------------------
    def close(self) -> None:
        """Disconnect the physics client (idempotent)."""
        if not self._closed:
            self._closed = True
            try:
                pb.disconnect(physicsClientId=self._cid)
            except pb.error:  # already gone (e.g. the GUI window was closed)
                pass

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def __del__(self) -> None:
        # Never raise from __del__: at interpreter shutdown pybullet may already be unloaded.
        try:
            self.close()
        except Exception:  # noqa: BLE001, S110
            pass

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("this World is closed")

    # -- properties ---------------------------------------------------------------------------
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
        state = self._state(handle)
        return float(sum(
            pb.getDynamicsInfo(state.body, link, physicsClientId=self._cid)[0]
            for link in range(-1, len(state.model.links) - 1)
        ))

    def body_count(self) -> int:
        """Number of bodies in the physics engine, the ground included (for leak checks)."""
        self._check_open()
        return int(pb.getNumBodies(physicsClientId=self._cid))

    def _state(self, handle: int) -> _RobotState:
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

        Args:
            robot: The robot.
            position: Horizontal position of the core. Metres.
            yaw: Heading about the vertical axis. Radians.
            drop_height: Gap under the robot. Metres; defaults to ``config.drop_height``.

        Returns:
            A handle, never reused within this world.
        """
        self._check_open()
        x, y = (float(v) for v in position)
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
            raise ValueError(f"position {position} and yaw {yaw} must be finite")
        gap = self.config.drop_height if drop_height is None else float(drop_height)
        if not (math.isfinite(gap) and gap >= 0):
            raise ValueError(f"drop_height must be >= 0 m, got {drop_height}")
        model = build_model(robot)
        cid = self._cid
        shapes: list[int] = []

        def collision(link: int) -> int:
            lk = model.links[link]
            s = pb.createCollisionShapeArray(
                shapeTypes=[pb.GEOM_BOX] * len(lk.box_centers),
                halfExtents=lk.box_half_extents.tolist(),
                collisionFramePositions=lk.box_centers.tolist(),
                collisionFrameOrientations=[matrix_to_quat(r) for r in lk.box_rotations],
                physicsClientId=cid,
            )
            shapes.append(s)
            return s

        def visual(link: int) -> int:
            lk = model.links[link]
            return pb.createVisualShapeArray(
                shapeTypes=[pb.GEOM_BOX] * len(lk.box_centers),
                halfExtents=lk.box_half_extents.tolist(),
                visualFramePositions=lk.box_centers.tolist(),
                visualFrameOrientations=[matrix_to_quat(r) for r in lk.box_rotations],
                physicsClientId=cid,
            )

        root = model.links[0]
        others = model.links[1:]
        base_rot = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0],
                             [0, 0, 1.0]])
        body = pb.createMultiBody(
            baseMass=root.mass,
            baseCollisionShapeIndex=collision(0),
            baseVisualShapeIndex=visual(0),
            basePosition=(x, y, gap - model.lowest_z),
            baseOrientation=matrix_to_quat(base_rot),
            baseInertialFramePosition=root.com.tolist(),
            baseInertialFrameOrientation=matrix_to_quat(root.inertia_axes),
            linkMasses=[lk.mass for lk in others],
            linkCollisionShapeIndices=[collision(i + 1) for i in range(len(others))],
            linkVisualShapeIndices=[visual(i + 1) for i in range(len(others))],
            linkPositions=[(lk.origin - model.links[lk.parent].origin).tolist() for lk in others],
            linkOrientations=[(0.0, 0.0, 0.0, 1.0)] * len(others),
            linkInertialFramePositions=[lk.com.tolist() for lk in others],
            linkInertialFrameOrientations=[matrix_to_quat(lk.inertia_axes) for lk in others],
            linkParentIndices=[lk.parent for lk in others],  # 0 = base, k = link k-1 = body k
            linkJointTypes=[pb.JOINT_FIXED if lk.fixed else pb.JOINT_REVOLUTE for lk in others],
            linkJointAxis=[lk.joint_axis.tolist() for lk in others],
            physicsClientId=cid,
        )
        for i, lk in enumerate(model.links):
            link = i - 1
            pb.changeDynamics(
                body, link, lateralFriction=_ROBOT_FRICTION, restitution=0.0,
                localInertiaDiagonal=lk.inertia_diagonal.tolist(), physicsClientId=cid,
            )
            for shape, color in enumerate(lk.box_colors):  # each box in its part's colour
                pb.changeVisualShape(body, link, shapeIndex=shape, rgbaColor=(*color, 1.0),
                                     physicsClientId=cid)
        # The hinges: joints 0..n-1 (the welded touch halves come after them), so a joint index
        # is also its position in joint_pos.
        all_joints = [i for i, lk in enumerate(others) if not lk.fixed]
        if all_joints:
            # Free every joint first (pybullet motorizes joints by default); servos are re-driven
            # every control period.
            pb.setJointMotorControlArray(
                body, all_joints, pb.VELOCITY_CONTROL, targetVelocities=[0.0] * len(all_joints),
                forces=[0.0] * len(all_joints), physicsClientId=cid,
            )
        sensor_links = sorted({
            s.link for _, s in model.sensors if isinstance(s, LightSensorModel) and s.link > 0
        })
        state = _RobotState(
            body=body, model=model, robot=robot, shapes=shapes,
            active_joints=[i - 1 for i in model.active_links], all_joints=all_joints,
            sensor_links=sensor_links, targets=np.zeros(model.n_outputs),
            forces=[self.config.max_torque] * model.n_outputs,
        )
        handle = self._next_handle
        self._next_handle += 1
        self._robots[handle] = state
        self._refresh(state)
        state.prev_core_vel = state.core_vel.copy()
        return handle

    def remove_robot(self, handle: int) -> None:
        """Take a robot out of the world; its body is deleted.

        Its collision and visual shapes stay allocated in the engine: pybullet 3.2 refuses to
        remove a shape once a body has used it ("Don't remove collision shape: it is used"), even
        after that body is gone, and has no call to remove visual shapes. The cost, measured with
        the 17-part spider, is about 150 KB of memory per robot ever added (some 0.45 GB over the
        paper's 3000 births in one online world).
        """
        state = self._state(handle)
        pb.removeBody(state.body, physicsClientId=self._cid)
        del self._robots[handle]

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
                f"robot {handle} has {state.model.n_outputs} active hinges, got {t.shape[0]} targets"
            )
        if not _all_finite(t):
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
        cid = self._cid
        k = c.servo_gain / c.control_period
        for _ in range(n):
            for state in self._robots.values():
                if state.active_joints:
                    q = state.joint_pos[state.active_joints]
                    vel = np.minimum(np.maximum(k * (state.targets - q), -c.max_velocity),
                                     c.max_velocity)
                    pb.setJointMotorControlArray(
                        state.body, state.active_joints, pb.VELOCITY_CONTROL,
                        targetVelocities=vel.tolist(), forces=state.forces, physicsClientId=cid,
                    )
            for _ in range(c.substeps):
                pb.stepSimulation(physicsClientId=cid)
            self._time += c.control_period
            for state in self._robots.values():
                state.prev_core_vel = state.core_vel
                self._refresh(state)

    # -- state --------------------------------------------------------------------------------
    def _refresh(self, state: _RobotState) -> None:
        """Read the core's pose and velocity and the joint states; check for a blow-up.

        Called for every robot every control period, so it keeps to three engine calls and a
        few small array operations.
        """
        cid = self._cid
        com, orn = pb.getBasePositionAndOrientation(state.body, physicsClientId=cid)
        v_com, w = pb.getBaseVelocity(state.body, physicsClientId=cid)
        root = state.model.links[0]
        rot = quat_to_matrix(orn) @ root.inertia_axes.T  # world <- root link frame = core frame
        ox, oy, oz = (-rot @ root.com).tolist()  # core centre minus centre of mass, world frame
        wx, wy, wz = w
        state.core_rot = rot
        state.core_pos = np.array((com[0] + ox, com[1] + oy, com[2] + oz))
        state.core_vel = np.array((
            v_com[0] + wy * oz - wz * oy, v_com[1] + wz * ox - wx * oz, v_com[2] + wx * oy - wy * ox
        ))
        state.core_angvel = np.array(w)
        joint_sum = 0.0
        if state.all_joints:
            js = np.array(
                [j[:2] for j in pb.getJointStates(state.body, state.all_joints, physicsClientId=cid)]
            )
            state.joint_pos = js[:, 0]
            state.joint_vel = js[:, 1]
            joint_sum = float(js.sum())
        if state.blow_up is None:
            finite = math.isfinite(sum(com) + sum(orn) + sum(v_com) + sum(w) + joint_sum)
            state.blow_up = self._check_blow_up(state, finite)

    def _check_blow_up(self, state: _RobotState, finite: bool) -> str | None:
        c = self.config
        if not finite:
            return f"non-finite state (NaN or infinity) at t={self._time:.3f} s"
        vx, vy, vz = state.core_vel
        speed = math.sqrt(vx * vx + vy * vy + vz * vz)
        if speed > c.max_linear_speed:
            return (f"core speed {speed:.1f} m/s exceeds {c.max_linear_speed} m/s "
                    f"at t={self._time:.3f} s")
        wx, wy, wz = state.core_angvel
        spin = math.sqrt(wx * wx + wy * wy + wz * wz)
        if spin > c.max_angular_speed:
            return (f"core spin {spin:.1f} rad/s exceeds {c.max_angular_speed} rad/s "
                    f"at t={self._time:.3f} s")
        if state.joint_vel.size:
            fastest = float(np.abs(state.joint_vel).max())
            if fastest > c.max_angular_speed:
                return (f"hinge speed {fastest:.1f} rad/s exceeds {c.max_angular_speed} rad/s "
                        f"at t={self._time:.3f} s")
        if state.core_pos[2] < -1.0:
            return f"core fell through the ground (z={state.core_pos[2]:.2f} m) at t={self._time:.3f} s"
        return None

    def blow_up(self, handle: int) -> str | None:
        """Why the robot's simulation blew up (NaN, or a part beyond a sane speed), else None.

        Once set, the reason stays; the robot keeps being simulated until removed.
        """
        return self._state(handle).blow_up

    def core_position(self, handle: int) -> NDArray[np.float64]:
        """Position of the core's centre. Metres, shape (3,)."""
        return self._state(handle).core_pos.copy()

    def core_positions(self, handles: tuple[int, ...] | list[int] | None = None) -> NDArray[np.float64]:
        """Core positions of several robots (all, in insertion order, by default). Shape (k, 3)."""
        hs = self.handles if handles is None else handles
        out = np.empty((len(hs), 3))
        for i, h in enumerate(hs):
            out[i] = self._state(h).core_pos
        return out

    def core_rotation(self, handle: int) -> NDArray[np.float64]:
        """Rotation from the core frame to the world frame, shape (3, 3)."""
        return self._state(handle).core_rot.copy()

    def core_velocity(self, handle: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Linear velocity of the core's centre (m/s) and angular velocity (rad/s), world frame."""
        state = self._state(handle)
        return state.core_vel.copy(), state.core_angvel.copy()

    def joint_angles(self, handle: int) -> NDArray[np.float64]:
        """Angles of the active hinges in controller output order. Radians."""
        state = self._state(handle)
        return state.joint_pos[state.active_joints].copy()

    def joint_velocities(self, handle: int) -> NDArray[np.float64]:
        """Angular velocities of the active hinges, in controller output order. Rad/s."""
        state = self._state(handle)
        return state.joint_vel[state.active_joints].copy()

    # -- sensors ------------------------------------------------------------------------------
    def read_sensors(self, handle: int) -> NDArray[np.float64]:
        """All sensor values of a robot, in controller input order (float64, shape (n_inputs,)).

        * Core IMU (6 values): accelerometer x, y, z (m/s^2, specific force in the core frame: a
          robot at rest reads +g along the up axis) and gyroscope x, y, z (rad/s, core frame).
          The acceleration is the change of the core's velocity over the last control period.
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
        cid = self._cid
        link_pose: dict[int, tuple[NDArray[np.float64], NDArray[np.float64]]] = {
            0: (state.core_pos, state.core_rot)
        }
        if state.sensor_links:
            ls = pb.getLinkStates(state.body, [i - 1 for i in state.sensor_links],
                                  computeForwardKinematics=1, physicsClientId=cid)
            for i, s in zip(state.sensor_links, ls):
                link_pose[i] = (np.asarray(s[4]), quat_to_matrix(s[5]))
        contacts: set[int] | None = None  # model link indices touching anything
        light = np.asarray(self.config.light_position)
        k = 0
        for kind, sensor in model.sensors:
            if kind == "imu":
                accel = (state.core_vel - state.prev_core_vel) * (1.0 / self.config.control_period)
                accel[2] += self.config.gravity
                out[k:k + 6] = (np.concatenate((accel, state.core_angvel)).reshape(2, 3)
                                @ state.core_rot).reshape(6)  # rows: R^T a, R^T w
                k += 6
            elif kind == "touch":
                assert isinstance(sensor, TouchSensorModel)
                if contacts is None:
                    contacts = {
                        c[3] + 1 for c in pb.getContactPoints(bodyA=state.body, physicsClientId=cid)
                    }
                out[k] = 1.0 if sensor.links[0] in contacts else 0.0
                out[k + 1] = 1.0 if sensor.links[1] in contacts else 0.0
                k += 2
            else:
                assert isinstance(sensor, LightSensorModel)
                pos, rot = link_pose[sensor.link]
                where = pos + rot @ sensor.position
                facing = rot @ sensor.direction
                to_light = light - where
                d = float(np.linalg.norm(to_light))
                cos_a = float(facing @ to_light) / d if d > 0 else 1.0
                out[k] = max(0.0, cos_a) / (1.0 + (d / self.config.light_range) ** 2)
                k += 1
        return out

    # -- rendering ----------------------------------------------------------------------------
    def render(
        self, width: int = 480, height: int = 360, target: ArrayLike | None = None,
        distance: float = 1.0, yaw_deg: float = 45.0, pitch_deg: float = -30.0,
    ) -> NDArray[np.uint8]:
        """An RGB picture of the world, shape (height, width, 3).

        Args:
            target: Point the camera looks at (metres); defaults to the first robot's core.
            distance: Camera distance from the target. Metres.
            yaw_deg: Camera heading. Degrees.
            pitch_deg: Camera elevation (negative looks down). Degrees.
        """
        self._check_open()
        if target is None:
            target = self.core_positions()[0] if self._robots else np.zeros(3)
        view = pb.computeViewMatrixFromYawPitchRoll(
            cameraTargetPosition=[float(v) for v in np.asarray(target)], distance=distance,
            yaw=yaw_deg, pitch=pitch_deg, roll=0.0, upAxisIndex=2, physicsClientId=self._cid,
        )
        proj = pb.computeProjectionMatrixFOV(fov=60.0, aspect=width / height, nearVal=0.01,
                                             farVal=100.0, physicsClientId=self._cid)
        renderer = pb.ER_BULLET_HARDWARE_OPENGL if self._gui else pb.ER_TINY_RENDERER
        _, _, rgba, _, _ = pb.getCameraImage(width, height, view, proj, renderer=renderer,
                                             physicsClientId=self._cid)
        return np.asarray(rgba, dtype=np.uint8).reshape(height, width, 4)[:, :, :3].copy()

    def look_at(self, target: ArrayLike, distance: float = 1.0) -> None:
        """Point the GUI window's camera at ``target`` (no effect without a GUI)."""
        if self._gui:
            pb.resetDebugVisualizerCamera(distance, 45.0, -30.0, np.asarray(target, float).tolist(),
                                          physicsClientId=self._cid)
