"""The compiled rollout: a whole evaluation on MuJoCo in C++, to the bit of the NumPy rules.

:func:`rollout` runs the insertion and the fitness window of robots in an isolated MuJoCo world
(each robot in a scene of its own) in the extension ``revolve_env._rollout``: per control period
RoboGen's servo law, ``mj_step``, the body states, the IMU, touch and light sensors, the blow-up
screen, the brain and the core's path, with the GIL released and no Python, the robots spread over
``threads`` threads (a robot's result does not depend on the split). The rules stay where they
are (:mod:`~revolve_env.world.world`, :mod:`~revolve_env.world.sensing`,
:mod:`~revolve_env.world.blowups`); the extension does their arithmetic in the same order, and
Python decides what they decide rarely: a robot whose screen fails waits until
:func:`~revolve_env.world.blowups.reason` has judged it, and a robot whose physics or brain turns
non-finite is evaluated again on the NumPy path (which replays and reports it as ever).

:class:`WorldStep` (made by :func:`world_step`) is one control period of every robot of a MuJoCo
:class:`~revolve_env.world.World` of one scene, as the envs step it period by period: the servo
law on the world's targets, the substeps, the body states, every sensor value and the blow-up
screen's calm test in one call (the same rules' code in C++ as the rollout's). Python keeps the
rest: the targets, the brains (one call of the batch controller), a period that needs a replay
(:meth:`~revolve_env.world.mujoco_backend.MujocoBackend.stepped`) and the judgement of a failed
screen.

:class:`EnvStep` (made by :func:`env_step`) is one step of the single-robot env
(:class:`~revolve_env.envs.LocomotionEnv`) on such a world in one call: the action (or the
robot's brain), the period above, the task's window of the robot and the shipped task's fitness,
the reward and the observation. Python finishes a step only at events (a bad action, a brain
that diverges, a period that is not calm, an observation that is not finite).

:class:`PopulationPeriods` (made by :func:`population_periods`) is many control periods of the
population env (:class:`~revolve_env.envs.population.PopulationEnv`) whose robots are all
brain-driven, in one call: per period the brains, the targets, the period above, the ages, the
fitness windows' push and the task's fitness of every robot. Python takes a period over only where
it has a part in it (a brain that diverges, a period that is not calm, a push the compiled one
declines).

:class:`Rules` (made by :func:`rules`) is the same rules for a pybullet world, whose engine calls
stay in Python: the target clipping, the servo law, the blow-up screen, the IMU and the light
sensors over the arrays its NumPy path would hand to NumPy, by the same C++ functions.

The only module that imports the extension. It is used only where it gives the NumPy path's
numbers: the extension must be built against the very ``mujoco`` that is imported, and its
kernels must round as NumPy's do here (checked once per process on random data: NumPy's matrix
products are OpenBLAS's, which fuse or not by CPU). Otherwise, or when it was not built (no
compiler or no ``mujoco`` wheel at install time), :func:`rollout`, :func:`world_step` and
:func:`rules` return None and the caller takes the NumPy path; the reason is logged once.
"""

from __future__ import annotations

import ctypes
import functools
import importlib
import importlib.metadata
import importlib.util
import logging
import math
import pathlib
import sys
from collections.abc import Callable, Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.robot import Robot
from revolve_env.brain._registry import as_spec
from revolve_env.world.backend import BodyStates, PhysicsBackend
from revolve_env.world.blowups import Screen, reason
from revolve_env.world.config import WorldConfig
from revolve_env.world.robot_state import Layout, RobotState
from revolve_env.world.sensing import IMU_HIGH, imu_readings, light_falloff, light_intensity

if TYPE_CHECKING:
    from revolve_env.brain.controller import BatchController
    from revolve_env.world.mujoco_backend import RawScene

__all__ = ["SIGNALS", "EnvStep", "Path", "PopulationPeriods", "Rules", "TaskRule",
           "WindowsPush", "WorldStep", "available", "env_step", "hypot_exact", "population_periods",
           "rollout", "rules", "windows_kernel", "world_step"]

_log = logging.getLogger(__name__)

Path = tuple[NDArray[np.float64], NDArray[np.float64], str | None]
"""Per robot: the core's path (read-only, metres), the task signal at the same rows (empty
without one) and the blow-up reason."""

SIGNALS = ("light",)
"""The task signals the compiled rollout records (:mod:`revolve_env.world.signals`)."""



class Evaluating(Protocol):
    """What :func:`rollout` needs of a :class:`~revolve_env.world.World`.

    (World imports this module, so it is named here by what it does.)
    """

    config: WorldConfig

    @property
    def engine(self) -> str: ...
    @property
    def handles(self) -> tuple[int, ...]: ...
    @property
    def backend(self) -> PhysicsBackend: ...
    def add_robot(self, robot: Robot, position: tuple[float, float] = ...,
                  yaw: float = ...) -> int: ...
    def n_inputs(self, handle: int) -> int: ...
    def n_outputs(self, handle: int) -> int: ...
    def set_hinge_state(self, handle: int, angles: NDArray[np.float64],
                        velocities: NDArray[np.float64]) -> None: ...
    def blow_up(self, handle: int) -> str | None: ...
    def plan(self, handle: int) -> tuple[RobotState, NDArray[np.float64]]: ...


@functools.cache
def _extension() -> ModuleType | None:
    """The extension if it gives the NumPy rules' numbers here, else None (logged once)."""
    # mujoco first: its libmujoco, loaded, is the one the extension links to (by its soname),
    # wherever the mujoco package is installed.
    from revolve_env.world.mujoco_gl import mujoco  # noqa: PLC0415 (only on MuJoCo's path)

    try:
        ext = importlib.import_module("revolve_env._rollout")
    except ImportError as e:
        _log.warning("revolve-env: the compiled rollout is not built (%s); evaluations on MuJoCo "
                     "use the NumPy rules", " ".join(str(e).split()))
        return None
    if mujoco.__version__ != ext.MUJOCO_VERSION or ext.mujoco_version() != ext.MUJOCO_HEADER:
        _log.warning("revolve-env: the compiled rollout was built for mujoco %s, not the "
                     "installed %s; evaluations on MuJoCo use the NumPy rules (reinstall "
                     "revolve-env to rebuild it)", ext.MUJOCO_VERSION, mujoco.__version__)
        return None
    odd = _kernels_differ(ext)
    if odd:
        _log.warning("revolve-env: the compiled rollout's %s does not round as NumPy's does on "
                     "this machine; evaluations on MuJoCo use the NumPy rules", odd)
        return None
    return ext


def _kernels_differ(ext: ModuleType) -> str | None:
    """The first kernel whose bits differ from NumPy's on random data, else None.

    The rules' kernels (:func:`_rule_kernels_differ`), then the angular velocity's product and
    the light's fall-off, which only MuJoCo's paths use.
    """
    from revolve_env.world.mujoco_backend import _c_einsum  # noqa: PLC0415 (imports mujoco)

    odd = _rule_kernels_differ(ext)
    if odd:
        return odd
    rng = np.random.default_rng(2026)
    n = 256
    rot, spin = rng.normal(size=(n, 3, 3)), rng.normal(size=(n, 3)) * 10
    if not np.array_equal(ext.einsum_products(rot, spin), _c_einsum("nij,nj->ni", rot, spin)):
        return "angular velocity product"
    pos = rng.normal(size=(n, 3))
    if not np.array_equal(ext.falloff_values(pos, np.array([1.0, 0.0, 0.1]), 0.7),
                          light_falloff(pos, np.array([1.0, 0.0, 0.1]), 0.7)):
        return "light fall-off"
    return None


def available() -> bool:
    """Whether the compiled rollout is built and gives the NumPy rules' numbers here."""
    return _extension() is not None


def windows_kernel() -> WindowsPush | None:
    """The compiled push of fitness windows (``FitnessWindows.push_compiled``), None if not usable.

    Not usable where the compiled rollout is not (:func:`available`; also without ``mujoco``).
    """
    try:
        ext = _extension()
    except ImportError:
        return None
    if ext is None or not hypot_exact():
        return None
    return WindowsPush(ext.windows_push)


class WindowsPush:
    """The extension's ``windows_push``, as an env can keep it.

    Pickled (an env sent to another process, as SuperSuit's vector envs do), it is looked up
    again there (:func:`windows_kernel`: None where it is not usable).
    """

    def __init__(self, push: Callable[..., tuple[bool, int, int, bool]]) -> None:
        self._push = push

    def __call__(self, *args: Any) -> tuple[bool, int, int, bool]:
        """``windows_push(*args)``: (pushed, seq, start, all_started)."""
        return self._push(*args)

    def __reduce__(self) -> tuple[Callable[[], WindowsPush | None], tuple[()]]:
        return windows_kernel, ()


def rollout(world: Evaluating, robots: Sequence[Robot], starts: Sequence[Any],
            insertion_ticks: int, evaluation_ticks: int, signal: str | None,
            joints: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]] | None] | None,
            threads: int) -> list[Path | None] | None:
    """``evaluation._rollout`` without noise, compiled; None where it does not apply.

    It applies to an empty isolated MuJoCo ``world`` and a task without a signal or with one of
    :data:`SIGNALS`, when the extension is usable (:func:`available`); then it adds the robots
    to ``world`` (spent afterwards: close it) and returns what the NumPy path would, bit for bit,
    but None for each robot that the NumPy path must evaluate again (its physics or its brain's
    outputs turned non-finite: that path replays and reports it).

    Args:
        world: An empty ``World(config, isolated=True)``.
        robots: The robots, with their networks.
        starts: Their starts (``position``, ``yaw``).
        insertion_ticks: Control periods before the fitness window.
        evaluation_ticks: Control periods of the window.
        signal: The task's signal, None or one of :data:`SIGNALS`.
        joints: Per robot, its active hinges' start angles and speeds (None: at rest).
        threads: Threads to spread the robots over (>= 1); the numbers do not depend on it.

    Raises:
        ValueError: a network whose inputs or outputs do not match its body.
    """
    scenes = getattr(world.backend, "scenes", None)
    if ((signal is not None and signal not in SIGNALS) or world.engine != "mujoco" or world.handles
            or scenes is None):
        return None
    ext = _extension()
    if ext is None:
        return None
    c = world.config
    n = len(robots)
    handles = [world.add_robot(robot, start.position, start.yaw)
               for robot, start in zip(robots, starts, strict=True)]
    specs = [as_spec(robot) for robot in robots]
    for spec, h in zip(specs, handles, strict=True):
        if world.n_inputs(h) != spec.n_inputs or world.n_outputs(h) != spec.n_outputs:
            raise ValueError(
                f"the network has {spec.n_inputs} inputs / {spec.n_outputs} outputs but the body "
                f"has {world.n_inputs(h)} sensor values / {world.n_outputs(h)} active hinges")
    for h, hinges in zip(handles, joints or [None] * n, strict=True):
        if hinges is not None:
            world.set_hinge_state(h, *hinges)
    run = ext.Rollout(insertion_ticks, evaluation_ticks, c.brain_stride, c.substeps,
                      c.control_period, c.servo_gain / c.control_period, c.max_velocity,
                      math.radians(c.range_deg), c.gravity, IMU_HIGH,
                      np.asarray(c.light_position, dtype=np.float64), float(c.light_range),
                      signal == "light")
    redo = [i for i, h in enumerate(handles) if world.blow_up(h) is not None]  # blown at birth
    for h, scene, spec in zip(handles, scenes(), specs, strict=True):
        s, prev_vel = world.plan(h)
        _add(run, s, scene, spec, Screen(1, s.n_joints, c).inverse, prev_vel, c.brain_dt)
    reasons: list[str | None] = [None] * n
    while True:
        run.run(max(1, int(threads)))
        waiting = [i for i in range(n) if run.status(i) == ext.SCREEN]
        if not waiting:
            break
        for i in waiting:
            pos, rot, vel, spin, angles, speeds = run.state(i)
            now = BodyStates(pos, rot, vel, spin, angles, speeds, np.zeros(1, dtype=bool))
            reasons[i] = reason(now, 0, slice(0, angles.shape[0]), c, run.time(i))
            run.resume(i, reasons[i] is not None)
    redo += [i for i in range(n) if run.status(i) == ext.FALLBACK and i not in redo]
    out: list[Path | None] = []
    for i in range(n):
        path = run.path(i)
        path.setflags(write=False)
        out.append(None if i in redo else (path, run.signal(i), reasons[i]))
    return out


def _add(run: Any, s: RobotState, scene: Any, spec: Any, screen: NDArray[np.float64],
         prev_vel: NDArray[np.float64], brain_dt: float) -> None:
    """Hand one robot (its world bookkeeping ``s``, its MuJoCo scene, its network) to ``run``."""
    def ints(a: Any) -> NDArray[np.int64]:
        return np.ascontiguousarray(np.asarray(a).reshape(-1), dtype=np.int64)

    raw: RawScene = scene.raw_scene()
    root = s.light_links == 0
    bodies = np.full(s.light_links.shape[0], -1, dtype=np.int64)  # -1: the core's pose
    if (~root).any():
        bodies[~root] = scene.link_index(0, s.light_links[~root])
    touch = scene.link_index(0, s.touch_links) if s.touch_links.size else np.zeros(0)
    run.add(raw.model, raw.data, int(raw.root_bodies[0]), int(raw.root_qpos[0]),
            int(raw.root_dofs[0]), ints(raw.hinge_qpos), ints(raw.hinge_dofs), ints(s.active_local),
            int(s.n_inputs), ints(touch), ints(s.touch_local), bodies, ints(s.light_local),
            np.ascontiguousarray(s.light_position, dtype=np.float64).reshape(-1, 3),
            np.ascontiguousarray(s.light_direction, dtype=np.float64).reshape(-1, 3),
            np.ascontiguousarray(screen), np.ascontiguousarray(prev_vel, dtype=np.float64),
            spec.kinds, spec.neuron_params, spec.src, spec.dst, spec.weight,
            int(spec.n_inputs), int(spec.n_outputs), float(brain_dt))


class WorldStep:
    """One control period of every robot of a MuJoCo world in C++ (:meth:`World.step`).

    RoboGen's servo law on the world's targets, the substeps, the body states, every robot's
    sensor values and the blow-up screen's calm test, by the rules of the NumPy path (the same
    bits). Made by :func:`world_step` for one scene and one layout of the robots: good while
    :meth:`current` and no robot was born or died.
    """

    def __init__(self, ext: ModuleType, backend: object, raw: RawScene, layout: Layout,
                 screen: Screen, c: WorldConfig) -> None:
        def ints(a: Any) -> NDArray[np.int64]:
            return np.ascontiguousarray(np.asarray(a).reshape(-1), dtype=np.int64)

        n, joints = layout.n, int(raw.hinge_qpos.shape[0])
        roots = layout.light_root_rows.shape[0]
        links = layout.light_link_ids.shape[0]
        self._run = ext.WorldStep(
            raw.model, raw.data, c.substeps, c.control_period, c.servo_gain / c.control_period,
            c.max_velocity, c.gravity, IMU_HIGH, np.asarray(c.light_position, dtype=np.float64),
            float(c.light_range), ints(raw.root_bodies), ints(raw.root_qpos),
            ints(raw.root_dofs), ints(raw.hinge_qpos), ints(raw.hinge_dofs),
            ints(layout.joint_offsets), ints(layout.input_offsets[:-1]), layout.n_inputs,
            ints(raw.hinge_qpos[layout.active_index]), ints(layout.touch_ids),
            ints(layout.touch_dest),
            np.concatenate((np.full(roots, -1, dtype=np.int64), ints(layout.light_link_ids))),
            np.concatenate((ints(layout.light_root_rows), np.zeros(links, dtype=np.int64))),
            ints(layout.light_dest),
            np.ascontiguousarray(layout.light_points.reshape(-1, 3)),
            np.ascontiguousarray(layout.light_facings.reshape(-1, 3)),
            np.ascontiguousarray(screen.inverse, dtype=np.float64))
        self._backend: Any = backend
        self._version = raw.version
        self._outcomes = ("calm", "unsettled", "replay", "restart")
        self._start = raw.start
        self._diverged = raw.diverged
        self.any_diverged = bool(raw.diverged.any())
        self._size = int(self._run.states_size)
        self._inputs = layout.n_inputs
        k = 3 * n
        self._cuts = (k, 4 * k, 5 * k, 6 * k, 6 * k + joints, 6 * k + 2 * joints)
        self._n = n
        self._substeps = c.substeps
        self.size = self._size
        self._queue: list[Buffers] = []

    @property
    def extension_step(self) -> Any:
        """The extension's own world step (for :class:`EnvStep`)."""
        return self._run

    @property
    def start(self) -> NDArray[np.float64]:
        """The backend's buffer of the period's start state (a replay starts from it)."""
        return self._start

    def current(self) -> bool:
        """Whether the backend still steps the scene this was made for (deaths compiled first)."""
        return bool(self._backend.scene_version() == self._version)

    def period(self, targets: NDArray[np.float64]) -> tuple[str, BodyStates | None,
                                                              NDArray[np.float64] | None,
                                                              NDArray[np.float64] | None]:
        """Step the world one control period towards ``targets`` (radians, flat layout).

        Returns:
            The outcome ("calm"; "unsettled": a robot may have blown up; "replay" or "restart":
            the backend has replayed the period, :meth:`MujocoBackend.stepped`), then for "calm"
            and "unsettled" every robot's state now, the cores' velocities before the period
            (n, 3) and every robot's sensor values (read-only), else None three times.
        """
        views = self.buffers()
        return self.finished(self._run.step(targets, self._start, views[0], views[1]), views)

    def buffers(self) -> Buffers:
        """Fresh arrays for one period and the views of them that :meth:`finished` hands out.

        The states and sensors the extension writes, made :data:`BATCH` periods at a time: one
        allocation and one slicing for all, so that a period pays neither (each period's arrays
        are still its own: the world's states are replaced, never changed).
        """
        queue = self._queue
        if not queue:
            k, n = BATCH, self._n
            a, b, c, d, e, f = self._cuts
            states, sensors = np.empty((k, self._size)), np.empty((k, self._inputs))
            read = sensors.view()
            read.flags.writeable = False
            queue.extend(zip(states, sensors, states[:, :a].reshape(k, n, 3),
                             states[:, a:b].reshape(k, n, 3, 3), states[:, b:c].reshape(k, n, 3),
                             states[:, c:d].reshape(k, n, 3), states[:, d:e], states[:, e:f],
                             states[:, f:].reshape(k, n, 3), read, strict=True))
            queue.reverse()
        return queue.pop()

    def finished(self, code: int, views: Buffers
                 ) -> tuple[str, BodyStates | None, NDArray[np.float64] | None,
                            NDArray[np.float64] | None]:
        """:meth:`period`'s result from the extension's outcome ``code``.

        ``views``: the :meth:`buffers` it filled. (The env's step, :class:`EnvStep`, runs the
        period inside its own call and ends here too.)
        """
        outcome = self._outcomes[code]
        # the backend replays what needs a replay; an unsettled state is a stepped one to it
        self._backend.stepped("calm" if outcome == "unsettled" else outcome, self._substeps)
        if outcome in ("replay", "restart"):
            return outcome, None, None, None
        _, _, pos, rot, vel, spin, joints, speeds, prev_vel, sensors = views
        return outcome, BodyStates(pos, rot, vel, spin, joints, speeds, self._diverged), \
            prev_vel, sensors


BATCH = 64
"""Periods whose arrays :meth:`WorldStep.buffers` makes at once."""

Buffers = tuple[NDArray[np.float64], ...]
""":meth:`WorldStep.buffers`: the states and sensors to write, then the views of them:
core_pos, core_rot, core_vel, core_angvel, joint_pos, joint_vel, the velocities before the
period and the sensor values (read-only)."""


def world_step(c: WorldConfig, backend: object, layout: Layout, screen: Screen) -> WorldStep | None:
    """The compiled step of a world's robots (:class:`WorldStep`), None where it does not apply.

    It applies to a MuJoCo world of one scene (not an isolated one) with robots, when the
    extension is usable (:func:`available`).

    Args:
        c: The world's settings.
        backend: The world's physics backend.
        layout: The world's index arrays over its robots.
        screen: The world's blow-up screen of them.
    """
    raw_scene = getattr(backend, "raw_scene", None)
    if c.engine != "mujoco" or raw_scene is None or not layout.n:
        return None
    ext = _extension()
    if ext is None:
        return None
    raw: RawScene = raw_scene()
    return WorldStep(ext, backend, raw, layout, screen, c)


TaskRule = tuple[int, float, float, float, float]
"""A shipped task's fitness rule for :class:`EnvStep`: (kind: 0 ``Locomotion``, 1
``DirectedLocomotion``, 2 ``LightFollowing``; ``s_weight``; ``limit``, NaN for none; the cosine
and sine of the heading), as :func:`revolve_env.rollout.task_rule` makes it."""


class Windowing(Protocol):
    """The window :class:`EnvStep` keeps, as :class:`revolve_env.rollout.RobotWindow` offers it."""

    def window_holds(self, age: int) -> bool: ...
    def window_push(self, time: float, x: float, y: float, age: int,
                    signal: float | None) -> int: ...
    def window_terms(self) -> tuple[float, float, float]: ...
    def window_last(self) -> tuple[float, float, float]: ...
    def window_len(self) -> int: ...
    def window_clear(self) -> None: ...


class CompiledWindow:
    """The compiled step's window of its robot, with :class:`~revolve_env.rollout.RobotWindow`'s.

    For the steps that Python finishes: the same samples, the same numbers.
    """

    def __init__(self, ext: Windowing) -> None:
        self._ext = ext

    def __len__(self) -> int:
        """Samples in the window."""
        return int(self._ext.window_len())

    def clear(self) -> None:
        """No samples."""
        self._ext.window_clear()

    def holds(self, age: int) -> bool:
        """Whether a robot ``age`` control periods old holds its last pose now (no new one)."""
        return bool(self._ext.window_holds(age))

    def push(self, time: float, x: float, y: float, age: int, signal: float | None) -> None:
        """:meth:`RobotWindow.push <revolve_env.rollout.RobotWindow.push>`: the same errors."""
        why = self._ext.window_push(time, x, y, age, signal)
        if why == 1:
            raise ValueError(f"time must be finite, got {time}")
        if why == 2:
            raise ValueError(f"time {time} s is before the previous sample")
        if why == 3:
            raise ValueError("positions of robots that sample must be finite")
        if why == 4:
            raise ValueError("these windows keep a signal: push needs one")

    def last(self) -> tuple[float, float, float]:
        """The latest sample's x, y (metres) and signal (zeros without a sample)."""
        x, y, signal = self._ext.window_last()
        return x, y, signal

    def terms(self) -> tuple[float, float, float]:
        """The task's fitness, v and s of the window now (metres; zeros below two samples)."""
        f, v, s = self._ext.window_terms()
        return f, v, s


class Stepping(Protocol):
    """What :class:`EnvStep` needs of a :class:`~revolve_env.world.World` (it imports this)."""

    config: WorldConfig

    @property
    def time(self) -> float: ...
    def compiled_targets(self) -> NDArray[np.float64]: ...
    def compiled_stepped(self, run: WorldStep, outcome: str, now: BodyStates | None,
                         prev_vel: NDArray[np.float64] | None,
                         sensors: NDArray[np.float64] | None) -> None: ...


class EnvStep:
    """One step of the single-robot env (:class:`~revolve_env.envs.LocomotionEnv`) in C++.

    In one call: the action's check and clip to the world's targets (or the robot's brain, stepped
    every ``brain_stride`` periods on the observation's sensor values), the world's period
    (:class:`WorldStep`), the task's window of the robot (:attr:`window`, the rules of
    :class:`~revolve_env.rollout.RobotWindow`), the shipped task's fitness and the reward (its
    gain), and the observation, written into the env's own array. :meth:`step` says when it
    stopped early for Python (see there). Made by :func:`env_step`.

    The brain has one owner per episode. Where the env steps on this (chosen at reset, for the
    whole episode), this steps the robot's network in its own controller, made from the network
    at reset as the env's :class:`~revolve_env.rollout.Rollout` makes its own; the two start
    alike, and only this one is stepped: the Rollout's controller stays as reset (its
    ``state``/``time`` are not the episode's) and the general step, which would step it, is never
    taken in such an episode. What the env reads of the brain is shared, not copied: the held
    outputs are the Rollout's own array (``outputs``, written here in place; the env's targets
    and a diverged brain's report come from it), and the Rollout's ``periods`` count every step.
    """

    def __init__(self, ext: ModuleType, world: Stepping, run: WorldStep, n_act: int,
                 n_inputs: int, active: NDArray[np.intp], proprioception: bool,
                 low: NDArray[np.float64], high: NDArray[np.float64], rule: TaskRule,
                 window: float, insertion: int, stride: int, signal_inputs: NDArray[np.intp],
                 network: Robot | None, outputs: NDArray[np.float64] | None) -> None:
        c = world.config
        spec = None
        if network is not None:
            s = as_spec(network)
            spec = (s.kinds, s.neuron_params, s.src, s.dst, s.weight, int(s.n_inputs),
                    int(s.n_outputs))
        kind, s_weight, limit, cos_h, sin_h = rule
        self.out = np.zeros(6)
        """After a step done here: its reward, the task's fitness, v, s (metres) and the core's
        x, y (metres)."""
        self._ext = ext.EnvStep(
            run.extension_step, world.compiled_targets(),
            np.zeros(0) if outputs is None else outputs, run.start, self.out, n_act, n_inputs,
            np.asarray(active, dtype=np.int64),
            proprioception, np.ascontiguousarray(low, dtype=np.float64),
            np.ascontiguousarray(high, dtype=np.float64), math.radians(c.range_deg), kind,
            s_weight, limit, cos_h, sin_h, window, insertion, stride,
            np.asarray(signal_inputs, dtype=np.int64), spec, c.brain_dt, c.brain_stride)
        self.window = CompiledWindow(self._ext)
        self._world = world
        self._run = run
        self._dt = c.control_period
        self._step = self._ext.step
        self.done = ext.ENV_DONE
        self.bad_action = ext.ENV_BAD_ACTION
        self.brain_diverged = ext.ENV_BRAIN_DIVERGED

    @property
    def terms(self) -> tuple[float, float, float]:
        """The task's fitness, v and s the last step left (metres)."""
        f, v, s = self._ext.terms
        return f, v, s

    @terms.setter
    def terms(self, value: tuple[float, float, float]) -> None:
        self._ext.terms = value

    def current(self) -> bool:
        """Whether the world's compiled step is still the one this steps."""
        return self._run.current()

    def adopt(self, run: WorldStep) -> None:
        """Step the world's new compiled step (its scene remade by a replay) from now on."""
        self._ext.set_world(run.extension_step, run.start)
        self._run = run

    def step(self, action: Any, obs: NDArray[np.float64], periods: int, age: int) -> int:
        """One env step towards ``action``; ``obs`` (the previous observation) becomes the new one.

        Args:
            action: The env's action (a 1-D C-contiguous float32 or float64 array; TypeError
                for anything else: the caller's general path takes it).
            obs: The env's observation array (float64): the brain reads its sensor part.
            periods: Control periods stepped in the episode before this one.
            age: The env's step count after this step.

        Returns:
            :attr:`done` (all done: :attr:`out`, ``obs`` and the world are the step's),
            :attr:`bad_action` (nothing done: the action has the wrong shape or is not finite),
            :attr:`brain_diverged` (the brain stepped and wrote its outputs; nothing else), or
            the world's period outcome, 0-3 (the world has stepped, the env's part is left).
        """
        world, run = self._world, self._run
        views = run.buffers()
        code: int = self._step(action, obs, views[0], views[1], periods, age,
                               world.time + self._dt)
        if code >= 0:
            world.compiled_stepped(run, *run.finished(code % 10, views))
        return code


def env_step(world: Stepping, n_act: int, n_inputs: int, active: NDArray[np.intp],
             proprioception: bool, low: NDArray[np.float64], high: NDArray[np.float64],
             rule: TaskRule, window: float, insertion: int, stride: int,
             signal_inputs: NDArray[np.intp], network: Robot | None,
             outputs: NDArray[np.float64] | None, run: WorldStep | None) -> EnvStep | None:
    """The compiled step of the single-robot env (:class:`EnvStep`), None where it does not apply.

    It applies to a world of one robot stepped by a compiled ``run`` (:class:`WorldStep`, of the
    world now, not diverged) when :func:`hypot_exact` holds here.

    Args:
        world: The env's world, its robot added.
        n_act: The action's length.
        n_inputs: The robot's sensor values.
        active: Its active hinges' entries in the world's joint arrays (output order).
        proprioception: Whether the hinges' angles and speeds follow the sensors.
        low: The observation's lower bounds.
        high: Its upper bounds.
        rule: The task's fitness rule (:data:`TaskRule`).
        window: The window's length. Seconds.
        insertion: Control periods before the window samples.
        stride: Control periods between two pose samples.
        signal_inputs: The robot's light sensors' entries in its sensor values (the task
            signal "light"; empty: the light at the core).
        network: The robot whose network drives it (None: the action drives).
        outputs: The brain's outputs, which the step keeps (held between its steps; None
            without a brain).
        run: The world's compiled step (None: the NumPy path steps it).
    """
    ext = _extension()
    if ext is None or run is None or run.any_diverged or run._n != 1 or not hypot_exact():
        return None
    return EnvStep(ext, world, run, n_act, n_inputs, active, proprioception, low, high, rule,
                   window, insertion, stride, signal_inputs, network, outputs)


@functools.cache
def hypot_exact() -> bool:
    """Whether the extension's ``math.hypot`` gives CPython's bits here (random data, once).

    The port is CPython 3.10-3.11's algorithm (later versions accumulate its rounding terms
    otherwise): on another Python the envs keep Python's and NumPy's windows.
    """
    ext = _extension()
    if ext is None:
        return False
    if sys.version_info[:2] not in ((3, 10), (3, 11)):
        _log.warning("revolve-env: the compiled math.hypot is CPython 3.11's; on Python %d.%d the "
                  "envs' fitness windows use Python's and NumPy's", *sys.version_info[:2])
        return False
    rng = np.random.default_rng(28)
    scale = 10.0 ** rng.integers(-310, 300, size=20000)
    a, b = rng.normal(size=20000) * scale, rng.normal(size=20000) * np.roll(scale, 7)
    a[:5000], b[:5000] = rng.normal(size=5000) * 1e-3, rng.normal(size=5000) * 1e-3
    # zeros, the smallest subnormal, infinities and NaN
    a = np.concatenate((a, [0.0, 5e-324, np.inf, -np.inf, np.nan, 0.0, 2.0]))
    b = np.concatenate((b, [0.0, 1.0, 0.0, 1.0, 1.0, 5e-324, np.nan]))
    want = np.array([math.hypot(x, y) for x, y in zip(a.tolist(), b.tolist(), strict=True)])
    if np.array_equal(ext.py_hypots(a, b), want, equal_nan=True):
        return True
    _log.warning("revolve-env: the compiled math.hypot does not give CPython's bits here; the "
                 "envs' fitness windows use Python's and NumPy's")
    return False


# -- The population env's periods ----------------------------------------------------------------

class PopulationPeriods:
    """Many control periods of a population env whose robots are all brain-driven, in C++.

    What :meth:`PopulationEnv.advance({}) <revolve_env.envs.population.PopulationEnv.advance>`
    does period after period when nothing in between needs Python: the brains (a copy of the
    env's controller, its networks' states and times handed over at :meth:`__init__` and back by
    :meth:`give_back`), the targets (:meth:`World.set_all_targets`' clip), the world's period
    (:class:`WorldStep`), the robots' ages, the fitness windows' push and the task's fitness
    (:data:`TaskRule`, kinds 0 and 1). The same bits as that path (tests). Made by
    :func:`population_periods` for one world step and one population: good for one call of
    :meth:`run`.
    """

    def __init__(self, ext: ModuleType, run: WorldStep, brain: BatchController,
                 target_scale: float, control_period: float, rule: TaskRule, window: float,
                 eps: float, stride: int, insertion: int, sample_from: int) -> None:
        kind, s_weight, limit, cos_h, sin_h = rule
        self._ext = ext.PopulationPeriods(run.extension_step, brain.dt, target_scale,
                                          control_period, kind, s_weight, limit, cos_h, sin_h,
                                          window, eps, stride, insertion, sample_from)
        # the env controller's handle -> the copy's
        self._handles: list[tuple[int, int]] = []
        for h in brain.handles:
            spec = brain.spec(h)
            mine = self._ext.add_network(spec.kinds, spec.neuron_params, spec.src, spec.dst,
                                         spec.weight, spec.n_inputs, spec.n_outputs,
                                         brain.get_state(h), brain.time(h))
            self._handles.append((h, mine))
        self._brain = brain
        self.stops = (ext.PERIODS_ALL, ext.PERIODS_BRAIN, ext.PERIODS_WORLD)
        """The numbers of :attr:`run`'s stops: all done, a brain's outputs not finite (it stepped,
        nothing else), the world's period not calm or a push declined (the world stepped)."""
        self.run = self._ext.run
        """The extension's ``run``: up to ``n`` periods, GIL released; (periods done whole, the
        stop, the world's outcome of the period it stopped in, the ring's ``seq`` and ``start``,
        whether every column has started, whether it pushed, the world's clock after the whole
        periods)."""

    def give_back(self) -> None:
        """Every network's state and time to the env's controller (after :meth:`run`)."""
        for h, mine in self._handles:
            self._brain.set_state(h, self._ext.state(mine), self._ext.time(mine))

    def raise_pending(self) -> None:
        """Raise what a signal handler raised during :meth:`run` (Ctrl-C: ``KeyboardInterrupt``).

        :meth:`run` looks at Python's signals every 30 periods and after its last; one that
        raised stops it at a period's start (stop "all done", the periods before it whole). The
        caller takes those periods back first, then calls this: the env stays whole.
        """
        self._ext.raise_pending()


def population_periods(run: WorldStep, brain: BatchController, target_scale: float,
                       control_period: float, rule: TaskRule | None, window: float, eps: float,
                       stride: int, insertion: int, sample_from: int) -> PopulationPeriods | None:
    """A population's compiled periods (:class:`PopulationPeriods`), None where they do not apply.

    They apply to a world stepped by a compiled ``run`` (not diverged) with a shipped task of
    kind 0 or 1 (no signal), when :func:`hypot_exact` holds here.

    Args:
        run: The world's compiled step.
        brain: The env's :class:`~revolve_env.brain.BatchController`, every robot's network in the
            world's order.
        target_scale: Radians per normalized target.
        control_period: Seconds.
        rule: The task's rule (:func:`revolve_env.rollout.task_rule`).
        window: The fitness windows' length. Seconds.
        eps: The windows' tolerance on sample times (``fitness.terms.TIME_EPS``). Seconds.
        stride: Control periods between two pose samples.
        insertion: The windows' insertion (control periods) for held poses.
        sample_from: The age (control periods) from which a robot samples.
    """
    ext = _extension()
    if (ext is None or run.any_diverged or rule is None or rule[0] not in (0, 1)
            or not hypot_exact()):
        return None
    return PopulationPeriods(ext, run, brain, target_scale, control_period, rule, window, eps,
                             stride, insertion, sample_from)


# -- The rules over a World's arrays (pybullet) ------------------------------------------------

_NO_POSES = (np.zeros((0, 3)), np.zeros((0, 3, 3)))


class Rules:
    """The per-period rules of a :class:`~revolve_env.world.World`'s NumPy path, in C++.

    pybullet's worlds keep their engine calls in Python (the motors, ``stepSimulation``, the body
    reads, the contacts and the link poses) and take the rules from the extension, over the very
    arrays the NumPy path hands to NumPy: the target clipping, RoboGen's servo law, the blow-up
    screen, the IMU and the light sensors. The same C++ functions as :func:`rollout`'s and
    :class:`WorldStep`'s, so the rules have one home, and the same bits as the NumPy rules
    (which stay the fallback and the tests' reference). Made by :func:`rules`.
    """

    def __init__(self, ext: ModuleType, c: WorldConfig) -> None:
        self._ext = ext
        self._scale = math.radians(c.range_deg)
        self._servo_k = c.servo_gain / c.control_period
        self._max_velocity = float(c.max_velocity)
        self._period = float(c.control_period)
        self._gravity = float(c.gravity)
        self._light = np.asarray(c.light_position, dtype=np.float64)
        self._range = float(c.light_range)

    def clip_targets(self, targets: NDArray[np.float64], out: NDArray[np.float64]) -> bool:
        """``out[:] = clip(targets, -1, 1) * scale`` (radians), unless a target is not finite.

        Returns False then, ``out`` untouched (the NumPy path flags the robot).

        Args:
            targets: Normalized targets, float64.
            out: Where they go (a contiguous slice of the world's targets).
        """
        return bool(self._ext.clip_targets(targets, self._scale, out))

    def servo(self, targets: NDArray[np.float64], joint_pos: NDArray[np.float64],
              active: NDArray[np.intp]) -> NDArray[np.float64]:
        """RoboGen's servo law: every active hinge's commanded velocity. Radians per second.

        Args:
            targets: Every active hinge's target. Radians.
            joint_pos: Every hinge's angle (``BodyStates.joint_pos``). Radians.
            active: The active hinges in ``joint_pos``, in the targets' order.
        """
        out: NDArray[np.float64] = self._ext.servo_velocities(targets, joint_pos, active,
                                                              self._servo_k, self._max_velocity)
        return out

    def calm(self, s: BodyStates, joint_offsets: NDArray[np.intp], screen: Screen) -> bool:
        """:func:`~revolve_env.world.blowups.all_calm` of every robot (at least one)."""
        return bool(self._ext.all_calm_rows(s.core_pos, s.core_rot, s.core_vel, s.core_angvel,
                                            s.joint_pos, s.joint_vel, s.diverged, joint_offsets,
                                            screen.inverse))

    def sense(self, out: NDArray[np.float64], lay: Layout, s: BodyStates,
              prev_vel: NDArray[np.float64],
              link_poses: tuple[NDArray[np.float64], NDArray[np.float64]] | None) -> None:
        """Write every robot's IMU and light sensor values into ``out`` (the world's layout).

        Args:
            out: Every robot's sensor values (the touch sensors are the caller's).
            lay: The world's index arrays.
            s: Every robot's state now.
            prev_vel: (n, 3) the cores' velocities one control period ago. Metres per second.
            link_poses: The poses of ``lay.light_link_ids`` (None: there are none).
        """
        link_pos, link_rot = _NO_POSES if link_poses is None else link_poses
        self._ext.sense_rows(out, lay.input_offsets, s.core_pos, s.core_rot, s.core_vel,
                             prev_vel, s.core_angvel, self._period, self._gravity, IMU_HIGH,
                             lay.light_dest, lay.light_root_rows, link_pos, link_rot,
                             lay.light_points, lay.light_facings, self._light, self._range)


def rules(c: WorldConfig) -> Rules | None:
    """The compiled rules of a world's control period (:class:`Rules`), None where not used.

    Used by pybullet's worlds when the extension is usable (:func:`_rules_extension`); MuJoCo's
    worlds step in :class:`WorldStep` or, where it does not apply, keep the NumPy rules.
    """
    if c.engine != "pybullet":
        return None
    ext = _rules_extension()
    return None if ext is None else Rules(ext, c)


@functools.cache
def _rules_extension() -> ModuleType | None:
    """The extension for pybullet's rules if it gives the NumPy rules' bits here, else None.

    :func:`_extension`'s gate, without importing the ``mujoco`` package (a world loads only the
    engine it uses): the extension links MuJoCo's library, which is loaded from the installed
    package's folder (found, not imported); it must be the version the extension was built for,
    and the kernels the rules use must round as NumPy's (checked once per process). Where
    ``mujoco`` is imported already, :func:`_extension` decides. None without the ``mujoco``
    package (the reason logged once).
    """
    if "mujoco" in sys.modules:
        return _extension()
    spec = importlib.util.find_spec("mujoco")
    if spec is None or not spec.submodule_search_locations:
        return None
    libs = [lib for folder in spec.submodule_search_locations
            for pattern in ("libmujoco.so.*", "libmujoco.*.dylib")
            for lib in sorted(pathlib.Path(folder).glob(pattern))]
    try:
        version = importlib.metadata.version("mujoco")
        for lib in libs[:1]:  # the extension finds it loaded, by its soname
            ctypes.CDLL(str(lib))
        ext = importlib.import_module("revolve_env._rollout")
    except (ImportError, OSError) as e:
        _log.warning("revolve-env: the compiled rules are not usable (%s); pybullet's worlds use "
                     "the NumPy rules", " ".join(str(e).split()))
        return None
    if version != ext.MUJOCO_VERSION or ext.mujoco_version() != ext.MUJOCO_HEADER:
        _log.warning("revolve-env: the compiled rules were built for mujoco %s, not the "
                     "installed %s; pybullet's worlds use the NumPy rules", ext.MUJOCO_VERSION,
                     version)
        return None
    odd = _rule_kernels_differ(ext)
    if odd:
        _log.warning("revolve-env: the compiled rules' %s does not round as NumPy's does on this "
                     "machine; pybullet's worlds use the NumPy rules", odd)
        return None
    return ext


def _rule_kernels_differ(ext: ModuleType) -> str | None:
    """The first kernel of the rules whose bits differ from NumPy's on random data, else None.

    The IMU's and the light sensors' products (pybullet's rules and MuJoCo's paths use both).
    """
    rng = np.random.default_rng(2027)
    n = 256
    rot = rng.normal(size=(n, 3, 3))
    vel, prev, spin = (rng.normal(size=(n, 3)) * 10 for _ in range(3))
    raw = np.concatenate(((vel - prev) * (1.0 / (1 / 60)), spin), axis=1)
    raw[:, 2] += 9.81
    if not np.array_equal(ext.imu_products(raw.reshape(n, 2, 3), rot).reshape(n, 6),
                          imu_readings(vel, prev, spin, rot, 1 / 60, 9.81)):
        return "IMU product"
    pos, point = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 0.1
    facing = rng.normal(size=(n, 3))
    facing /= np.linalg.norm(facing, axis=1, keepdims=True)
    light = np.array([1.0, 0.0, 0.1])
    want = light_intensity(pos, rot, np.ascontiguousarray(point[:, :, None]),
                           np.ascontiguousarray(facing[:, :, None]), light, 1.0)
    if not np.array_equal(ext.light_values(pos, rot, point, facing, light, 1.0), want):
        return "light sensor"
    return None
