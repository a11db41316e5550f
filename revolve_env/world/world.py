"""The engine-neutral :class:`World`: RoboGen's rules over a batched physics backend.

Everything a physics engine should not decide lives here, once, for every engine: the target
clipping and the NaN guard on hinge targets, RoboGen's servo law, the IMU and light-sensor maths
and the blow-up policy. The engine itself is a :class:`~revolve_env.world.backend.PhysicsBackend`
chosen by ``WorldConfig.engine``, driven with one batched call per primitive and control period.
Their arithmetic has one compiled home (:mod:`~revolve_env.world.compiled`): a MuJoCo world of one
scene steps its whole period there, and a pybullet world, whose engine calls stay here, takes the
rules from it over the arrays below; the NumPy rules are the fallback, to the same bits.
"""

from __future__ import annotations

import math
from types import TracebackType
from typing import Any, Self

import numpy as np
from numpy.typing import ArrayLike, NDArray

from revolve_env.body.robot import Robot
from revolve_env.body.serialize import to_json
from revolve_env.world import compiled
from revolve_env.world.backend import BodyStates, PhysicsBackend, SnapshotMismatchError
from revolve_env.world.blowups import Screen, all_calm, reason
from revolve_env.world.config import WorldConfig
from revolve_env.world.engines import make_backend, require_engine
from revolve_env.world.model import PlacedModel, build_model
from revolve_env.world.robot_state import (
    Layout,
    RobotState,
    all_finite,
    empty_states,
    layout,
    restored_states,
    robot_state,
)
from revolve_env.world.sensing import IMU_HIGH, IMU_LOW, imu_readings, light_intensity

__all__ = ["World"]


class World:
    """A world with gravity, friction, one point light, a ground and any number of robots.

    The ground is ``config.terrain`` (:mod:`revolve_env.terrain`), the plane by default. Units
    are SI throughout (metres, seconds, radians, kilograms). Time advances in control periods
    (``config.control_period``, 1/60 s by default), each made of ``config.substeps`` physics
    steps (1/240 s by default). Each control period, every active hinge behaves like
    RoboGen's servo: it is commanded the velocity ``gain * (target - angle) / control_period``
    clipped to the servo's speed, with the servo's torque limit; passive hinges turn freely.

    Robots collide with the ground and with each other (not with themselves: the boxes of a
    RoboGen hinge interpenetrate by design), unless the world is ``isolated``: then each robot
    is in a scene of its own and moves exactly as it would alone, whichever robots are beside it
    (side-by-side evaluations). The physics engine is ``config.engine`` (``"pybullet"`` or
    ``"mujoco"``); the rules above are the same for all.

    Use as a context manager, or call :meth:`close`::

        with World(WorldConfig(engine="mujoco")) as world:
            h = world.add_robot(robot)
            world.set_targets(h, np.zeros(world.n_outputs(h)))
            world.step(60)
            print(world.core_position(h))
    """

    def __init__(self, config: WorldConfig | None = None, *, gui: bool = False,
                 isolated: bool = False, threads: int = 1) -> None:
        """Start a fresh engine of ``config.engine`` and build the ground.

        Args:
            config: Physics settings; defaults to ``WorldConfig()`` (MuJoCo).
            gui: Open the engine's window instead of running headless (pybullet only).
            isolated: Every robot in a scene of its own
                (:mod:`~revolve_env.world.isolated`): robots never meet, and each moves
                exactly as in a world of its own. No snapshots, no GUI.
            threads: Threads of an isolated world's batched stepping (MuJoCo: copies of one
                model in ``mujoco.batch``, bit for bit at any count); other engines and
                worlds step in this thread.

        Raises:
            ValueError: unknown engine name.
            EngineUnavailableError: the engine's package is not installed.
            RuntimeError: the engine could not start, or a GUI was asked for without a display,
                while another GUI is open, or of an engine that has none.
        """
        self.config = config if config is not None else WorldConfig()
        self._backend: PhysicsBackend = make_backend(self.config, gui=gui, isolated=isolated,
                                                     threads=threads)
        self._closed = False
        self._robots: dict[int, RobotState] = {}
        self._next_handle = 0
        self._time = 0.0
        self._now = empty_states()
        self._prev_vel = np.zeros((0, 3))
        self._layout = Layout()
        self._targets = np.zeros(0)  # every active hinge's target, robots in row order. Radians
        self._blown = np.zeros(0, dtype=bool)  # rows with a blow-up reason
        self._n_blown = 0
        self._screen = Screen(0, 0, self.config)
        self._target_scale = math.radians(self.config.range_deg)  # radians per normalized unit
        self._light = np.asarray(self.config.light_position, dtype=np.float64)
        # every robot's IMU and sensor values, computed on demand once per control period
        self._imu: NDArray[np.float64] | None = None
        self._sensors: NDArray[np.float64] | None = None
        # The compiled step of the robots now (None: not made yet), unless the NumPy path steps
        self._compiled: compiled.WorldStep | None = None
        self._numpy_path = False
        # pybullet: the NumPy path's rules in C++ (None: NumPy's; MuJoCo steps in WorldStep)
        self._rules = compiled.rules(self.config)

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
        self._targets = np.zeros(0)

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
    def target_scale(self) -> float:
        """A normalized target's hinge angle: targets in [-1, 1] times this. Radians."""
        return self._target_scale

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

    def plan(self, handle: int) -> tuple[RobotState, NDArray[np.float64]]:
        """A robot's record and its core's velocity one control period ago (metres per second).

        The record (its sensor plan and hinges) is the world's own: for compiled code that steps
        the robot, to read only.
        """
        state = self._state(handle)
        return state, self._prev_vel[state.row].copy()

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
        """Insert a robot, its lowest point ``drop_height`` above the highest ground under it.

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
            ValueError: a non-finite position, yaw or drop height, a robot the engine cannot
                build, or (``TerrainError``) a robot reaching past the terrain's edge (the world
                is unchanged then).
        """
        self._check_open()
        x, y = (float(v) for v in position)
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
            raise ValueError(f"position {position} and yaw {yaw} must be finite")
        gap = self.config.drop_height if drop_height is None else float(drop_height)
        if not (math.isfinite(gap) and gap >= 0):
            raise ValueError(f"drop_height must be >= 0 m, got {drop_height}")
        model = build_model(robot)
        # On the highest ground under its footprint (0 on the flat plane, as ever).
        ground = self.config.terrain.ground_under(x, y, model.footprint_radius)
        placed = (x, y, ground + gap - model.lowest_z)
        key = self._backend.add(model, placed, float(yaw))
        state = robot_state(key, model, robot, placed, float(yaw))
        handle = self._next_handle
        self._next_handle += 1
        previous = self._prev_vel
        targets = self._targets
        self._robots[handle] = state
        self._relayout()
        # Survivors keep the velocity of the last period for their IMU; the newborn is at rest.
        self._prev_vel = np.concatenate((previous, self._now.core_vel[state.row:state.row + 1]))
        self._targets = np.concatenate((targets, np.zeros(model.n_outputs)))
        self._flag(state, self._check_blow_up(state))
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
            NotImplementedError: an ``isolated`` world (each robot in a scene of its own).
        """
        self._check_open()
        require_engine("mujoco")  # the format is MuJoCo's: its model builder writes it
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
                 "placed": list(s.placed), "yaw": s.yaw, "targets": self._robot_targets(s).copy(),
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
        robots, targets, prev_vel = restored_states(snapshot)
        placed = [PlacedModel(r.key, r.model, r.placed, r.yaw) for r in robots.values()]
        self._robots.clear()
        self._time = 0.0
        try:
            self._backend.restore(placed, snapshot["backend"])
        except BaseException:
            self._relayout()
            self._targets = np.zeros(0)
            raise
        self._robots = robots
        self._next_handle = int(snapshot["next_handle"])
        self._time = float(snapshot["time"])
        self._relayout()
        self._prev_vel = prev_vel
        self._targets = targets

    def remove_robot(self, handle: int) -> None:
        """Take a robot out of the world; its bodies are deleted.

        The others keep their state exactly. See the backend's ``remove`` for what the engine
        keeps allocated.
        """
        state = self._state(handle)
        keep = np.ones(len(self._robots), dtype=bool)
        keep[state.row] = False
        targets = np.delete(self._targets, np.s_[self._output_slice(state)])
        self._backend.remove(state.key)
        del self._robots[handle]
        previous = self._prev_vel[keep]
        self._relayout()
        self._prev_vel = previous
        self._targets = targets

    def _relayout(self) -> None:
        """Rows, index arrays and a fresh read of every robot (after a birth, death or restore).

        The targets are the caller's to lay out (``_targets`` is left as it was).
        """
        states = list(self._robots.values())
        self._layout = layout(states, self._backend)
        self._screen = Screen(len(states), sum(s.n_joints for s in states), self.config)
        self._blown = np.array([s.blow_up is not None for s in states], dtype=bool)
        self._n_blown = int(np.count_nonzero(self._blown))
        self._now = self._backend.read() if self._robots else empty_states()
        self._prev_vel = self._now.core_vel.copy()
        self._imu = None
        self._sensors = None
        self._compiled = None  # made again for the robots now

    def _output_slice(self, state: RobotState) -> slice:
        offsets = self._layout.output_offsets
        return slice(int(offsets[state.row]), int(offsets[state.row + 1]))

    def _robot_targets(self, state: RobotState) -> NDArray[np.float64]:
        return self._targets[self._output_slice(state)]

    def _flag(self, state: RobotState, reason: str | None) -> None:
        """Record a robot's first blow-up reason (``None``: nothing to record)."""
        if reason is not None and state.blow_up is None:
            state.blow_up = reason
            self._blown[state.row] = True
            self._n_blown += 1

    def set_hinge_state(self, handle: int, angles: ArrayLike, velocities: ArrayLike) -> None:
        """Put a robot's active hinges at ``angles`` (radians) and speeds (radians per second).

        In controller output order, one value per active hinge; a start perturbation
        (:meth:`~revolve_env.conditions.EvaluationConditions.start_joints`), set before the robot
        is stepped. The servos' targets are unchanged.

        Raises:
            ValueError: a shape that is not one value per active hinge, or NaN or infinity.
        """
        state = self._state(handle)
        a = np.asarray(angles, dtype=np.float64).reshape(-1)
        v = np.asarray(velocities, dtype=np.float64).reshape(-1)
        n = state.model.n_outputs
        if a.shape != (n,) or v.shape != (n,):
            raise ValueError(f"robot {handle} has {n} active hinges, got {a.shape[0]} angles and "
                             f"{v.shape[0]} velocities")
        if not (np.isfinite(a).all() and np.isfinite(v).all()):
            raise ValueError("hinge angles and velocities must be finite")
        self._backend.set_hinges(state.key, state.active_local, a, v)
        self._now = self._backend.read()
        self._imu = None
        self._sensors = None

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
        self._write_targets(self._output_slice(state), t)

    def set_all_targets(self, targets: NDArray[np.float64]) -> None:
        """Set every robot's targets at once: :meth:`set_targets` for the flat array of all.

        Args:
            targets: ``(n_outputs,)`` float64, normalized; each robot's active hinges in output
                order, robots in insertion order (:attr:`output_offsets` delimits them).
        """
        self._check_open()
        if targets.shape != self._targets.shape:
            raise ValueError(f"expected {self._targets.shape[0]} targets (every active hinge), "
                             f"got shape {targets.shape}")
        self._write_targets(slice(None), targets)

    def set_target_entries(self, index: NDArray[np.intp], targets: NDArray[np.float64]) -> None:
        """Set some entries of the flat targets (:meth:`set_all_targets`'s layout) at once.

        The rules of :meth:`set_targets` apply robot by robot: a robot with a non-finite entry
        is blown up and all its hinges are held at 0.
        """
        self._check_open()
        if index.shape != targets.shape:
            raise ValueError(f"{index.shape} target entries but {targets.shape} values")
        self._write_targets(index, targets)

    def _write_targets(self, where: slice | NDArray[np.intp],
                       targets: NDArray[np.float64]) -> None:
        rules = self._rules
        if (rules is not None and isinstance(where, slice) and targets.dtype == np.float64
                and rules.clip_targets(targets, self._targets[where])):
            return  # else a non-finite target: the NumPy path below flags its robot
        if not all_finite(targets):
            rows = self._layout.output_rows[where]
            bad = np.unique(rows[~np.isfinite(targets)])
            for state in self._robots.values():
                if state.row in bad:
                    self._flag(state, f"non-finite hinge targets at t={self._time:.3f} s "
                                      "(the controller's outputs diverged)")
            keep = ~np.isin(rows, bad)
            index = np.arange(self._targets.shape[0])[where]
            self._write_targets(index[keep], targets[keep])
            for r in bad.tolist():
                offsets = self._layout.output_offsets
                self._targets[offsets[r]:offsets[r + 1]] = 0.0
            return
        # minimum/maximum: np.clip's Python wrapper costs more than the clipping (hot path)
        self._targets[where] = np.minimum(np.maximum(targets, -1.0), 1.0) * self._target_scale

    def step(self, n: int = 1) -> None:
        """Advance ``n`` control periods (each ``config.substeps`` physics steps)."""
        self._check_open()
        if n < 0:
            raise ValueError(f"cannot step a negative number of periods ({n})")
        c = self.config
        backend = self._backend
        k = c.servo_gain / c.control_period
        active = self._layout.active_index
        for _ in range(n):
            if not self._numpy_path and self._robots and self._compiled_period():
                continue
            if active.size:
                # RoboGen's servo law, for every active hinge of every robot at once.
                if self._rules is not None:
                    vel = self._rules.servo(self._targets, self._now.joint_pos, active)
                else:
                    q = self._now.joint_pos[active]
                    vel = np.minimum(np.maximum(k * (self._targets - q), -c.max_velocity),
                                     c.max_velocity)
                backend.set_joint_velocities(vel, c.max_torque)
            backend.step(c.substeps)
            self._time += c.control_period
            if self._robots:
                self._prev_vel = self._now.core_vel
                self._now = backend.read()
                self._imu = None
                self._sensors = None
                self._check_blow_ups()

    def _compiled_period(self) -> bool:
        """One control period in the compiled step (:class:`compiled.WorldStep`).

        The same numbers as the NumPy path of :meth:`step`; False where it does not apply
        (nothing done then).
        """
        run = self.compiled_step()
        if run is None:
            return False
        self.compiled_stepped(run, *run.period(self._targets))
        return True

    def compiled_step(self) -> compiled.WorldStep | None:
        """The compiled step of the robots now (made if need be), None where the NumPy path steps.

        For the envs' compiled steps (:class:`compiled.EnvStep`), which step the world through it
        and then call :meth:`compiled_stepped`.
        """
        if self._numpy_path or not self._robots:
            return None
        run = self._compiled
        if run is None or not run.current():
            run = compiled.world_step(self.config, self._backend, self._layout, self._screen)
            if run is None:
                self._numpy_path = True
                return None
            self._compiled = run
        return run

    def compiled_targets(self) -> NDArray[np.float64]:
        """Every active hinge's target, the world's own array. Radians.

        For a compiled step to write clipped targets into (:meth:`set_all_targets`' rules), not
        to keep.
        """
        return self._targets

    def compiled_stepped(self, run: compiled.WorldStep, outcome: str, now: BodyStates | None,
                         prev_vel: NDArray[np.float64] | None,
                         sensors: NDArray[np.float64] | None) -> None:
        """The world after one period of :meth:`compiled_step`, as :meth:`step` leaves it.

        The clock, the states, the sensors and the blow-up flags, from
        :meth:`compiled.WorldStep.period`'s result.
        """
        self._time += self.config.control_period
        self._imu = None
        if now is None or prev_vel is None:  # replayed by the backend: read as ever
            self._prev_vel = self._now.core_vel
            self._now = self._backend.read()
            self._sensors = None
            self._check_blow_ups()
            return
        self._prev_vel, self._now, self._sensors = prev_vel, now, sensors
        if outcome != "calm" or run.any_diverged:
            for state in self._robots.values():
                if state.blow_up is None:
                    self._flag(state, self._check_blow_up(state))

    def compiled_advanced(self, run: compiled.WorldStep, time: float,
                          views: compiled.Buffers) -> None:
        """The world after calm periods of :meth:`compiled_step` run elsewhere (last: ``views``).

        As :meth:`compiled_stepped` after each of them (calm, not diverged) leaves it: ``time``
        is the clock they reached (seconds; added to period by period, as there).
        """
        outcome, now, prev_vel, sensors = run.finished(0, views)
        assert outcome == "calm" and now is not None and prev_vel is not None
        assert not run.any_diverged
        self._time = time
        self._imu = None
        self._prev_vel, self._now, self._sensors = prev_vel, now, sensors

    # -- blow-ups -----------------------------------------------------------------------------
    def _check_blow_ups(self) -> None:
        """Flag every robot that blew up (:mod:`~revolve_env.world.blowups`).

        One screen of all robots at once, then robot by robot only when the screen fails.
        """
        rules = self._rules
        if (rules.calm(self._now, self._layout.joint_offsets, self._screen) if rules is not None
                else all_calm(self._now, self._screen)):
            return
        for state in self._robots.values():
            if state.blow_up is None:
                self._flag(state, self._check_blow_up(state))

    def _check_blow_up(self, state: RobotState) -> str | None:
        joints = slice(state.joint_start, state.joint_start + state.n_joints)
        return reason(self._now, state.row, joints, self.config, self._time)

    def blow_up(self, handle: int) -> str | None:
        """Why the robot's simulation blew up (NaN, or a part beyond a sane speed), else None.

        Once set, the reason stays; the robot keeps being simulated until removed.
        """
        return self._state(handle).blow_up

    @property
    def any_blown_up(self) -> bool:
        """Whether any robot has blown up (cheaper than ``blown_up.any()``)."""
        return self._n_blown > 0

    @property
    def blown_up(self) -> NDArray[np.bool_]:
        """Which robots have blown up (:meth:`blow_up` is not None), rows in insertion order.

        A read-only copy (later blow-ups do not change it).
        """
        self._check_open()
        flags = self._blown.copy()
        flags.flags.writeable = False
        return flags

    # -- state --------------------------------------------------------------------------------
    @property
    def targets(self) -> NDArray[np.float64]:
        """Position targets of every active hinge, robots in insertion order (a copy). Radians."""
        self._check_open()
        return self._targets.copy()

    @property
    def states(self) -> BodyStates:
        """Every robot's state after the last control period, rows in insertion order.

        Read-only arrays, replaced (not changed) by every step, birth and death.
        """
        self._check_open()
        return self._now

    def rows(self, handles: tuple[int, ...] | list[int]) -> NDArray[np.intp]:
        """The rows of some robots in the world's arrays (valid until the next birth or death)."""
        return np.array([self._state(h).row for h in handles], dtype=np.intp)

    @property
    def input_offsets(self) -> NDArray[np.intp]:
        """Where each robot's part of :meth:`sensor_values` starts, and the total (n + 1,)."""
        return self._layout.input_offsets

    @property
    def output_offsets(self) -> NDArray[np.intp]:
        """Where each robot's part of the flat targets starts, and the total (n + 1,)."""
        return self._layout.output_offsets

    def hinge_angles(self) -> NDArray[np.float64]:
        """Angles of every active hinge, robots in insertion order (flat targets' layout). Rad."""
        self._check_open()
        return self._now.joint_pos[self._layout.active_index]

    def hinge_velocities(self) -> NDArray[np.float64]:
        """Angular velocities of every active hinge, laid out like :meth:`hinge_angles`. Rad/s."""
        self._check_open()
        return self._now.joint_vel[self._layout.active_index]

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
            c, s = self.config, self._now
            self._imu = imu_readings(s.core_vel, self._prev_vel, s.core_angvel, s.core_rot,
                                     c.control_period, c.gravity)
        return self._imu

    def sensor_values(self) -> NDArray[np.float64]:
        """Every robot's sensor values, one flat read-only array (robots in insertion order).

        Each robot's values are those of :meth:`read_sensors`, in controller input order;
        :attr:`input_offsets` delimits them. Computed once per control period for all robots.
        """
        self._check_open()
        if self._sensors is None:
            self._sensors = self._sense()
        return self._sensors

    def _sense(self) -> NDArray[np.float64]:
        lay, s, c = self._layout, self._now, self.config
        out = np.empty(lay.n_inputs)
        if self._rules is not None and lay.n:  # the engine read in the NumPy path's order
            if lay.touch_ids.size:
                out[lay.touch_dest] = self._backend.touching(lay.touch_ids)
            poses = (self._backend.link_poses(lay.light_link_ids) if lay.light_link_ids.size
                     else None)
            self._rules.sense(out, lay, s, self._prev_vel, poses)
            out.flags.writeable = False
            return out
        if lay.n:
            # The real sensor saturates at full scale (NaN passes: a blow-up stays visible).
            out[lay.imu_dest] = np.minimum(np.maximum(self._imus(), IMU_LOW), IMU_HIGH)
        if lay.touch_ids.size:
            out[lay.touch_dest] = self._backend.touching(lay.touch_ids)
        if lay.light_dest.size:
            rows = lay.light_root_rows
            pos, rot = s.core_pos[rows], s.core_rot[rows]
            if lay.light_link_ids.size:
                link_pos, link_rot = self._backend.link_poses(lay.light_link_ids)
                pos, rot = np.concatenate((pos, link_pos)), np.concatenate((rot, link_rot))
            out[lay.light_dest] = light_intensity(pos, rot, lay.light_points, lay.light_facings,
                                                  self._light, c.light_range)
        out.flags.writeable = False
        return out

    def read_sensors(self, handle: int) -> NDArray[np.float64]:
        """All sensor values of a robot, in controller input order (float64, shape (n_inputs,)).

        A copy of its part of :meth:`sensor_values`:

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
        row = self._state(handle).row
        offsets = self._layout.input_offsets
        return self.sensor_values()[offsets[row]:offsets[row + 1]].copy()

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
