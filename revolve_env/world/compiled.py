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

The only module that imports the extension. It is used only where it gives the NumPy path's
numbers: the extension must be built against the very ``mujoco`` that is imported, and its
kernels must round as NumPy's do here (checked once per process on random data: NumPy's matrix
products are OpenBLAS's, which fuse or not by CPU). Otherwise, or when it was not built (no
compiler or no ``mujoco`` wheel at install time), :func:`rollout` and :func:`world_step` return
None and the caller takes the NumPy path; the reason is logged once.
"""

from __future__ import annotations

import functools
import importlib
import logging
import math
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
    from revolve_env.world.mujoco_backend import RawScene

__all__ = ["SIGNALS", "Path", "WorldStep", "available", "rollout", "windows_kernel",
           "world_step"]

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
    """The first kernel whose bits differ from NumPy's on random data, else None."""
    from revolve_env.world.mujoco_backend import _c_einsum  # noqa: PLC0415 (imports mujoco)

    rng = np.random.default_rng(2026)
    n = 256
    rot = rng.normal(size=(n, 3, 3))
    vel, prev, spin = (rng.normal(size=(n, 3)) * 10 for _ in range(3))
    imu = imu_readings(vel, prev, spin, rot, 1 / 60, 9.81)
    raw = np.concatenate(((vel - prev) * (1.0 / (1 / 60)), spin), axis=1)
    raw[:, 2] += 9.81
    if not np.array_equal(ext.imu_products(raw.reshape(n, 2, 3), rot).reshape(n, 6), imu):
        return "IMU product"
    if not np.array_equal(ext.einsum_products(rot, spin), _c_einsum("nij,nj->ni", rot, spin)):
        return "angular velocity product"
    pos, point = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)) * 0.1
    facing = rng.normal(size=(n, 3))
    facing /= np.linalg.norm(facing, axis=1, keepdims=True)
    light = np.array([1.0, 0.0, 0.1])
    want = light_intensity(pos, rot, np.ascontiguousarray(point[:, :, None]),
                           np.ascontiguousarray(facing[:, :, None]), light, 1.0)
    if not np.array_equal(ext.light_values(pos, rot, point, facing, light, 1.0), want):
        return "light sensor"
    if not np.array_equal(ext.falloff_values(pos, light, 0.7), light_falloff(pos, light, 0.7)):
        return "light fall-off"
    return None


def available() -> bool:
    """Whether the compiled rollout is built and gives the NumPy rules' numbers here."""
    return _extension() is not None


def windows_kernel() -> Callable[..., tuple[bool, int, int, bool]] | None:
    """The compiled push of fitness windows (``FitnessWindows.push_compiled``), None if not usable.

    Not usable where the compiled rollout is not (:func:`available`; also without ``mujoco``).
    """
    try:
        ext = _extension()
    except ImportError:
        return None
    if ext is None or not _hypot_agrees(ext):
        return None
    return ext.windows_push  # type: ignore[no-any-return]


@functools.cache
def _hypot_agrees(ext: ModuleType) -> bool:
    """Whether the extension's ``math.hypot`` gives CPython's bits on random data (else logs)."""
    rng = np.random.default_rng(2026)
    n = 256
    # ordinary, tiny, huge and mixed magnitudes, zeros, subnormals, infinities and NaN
    x = np.concatenate((rng.normal(size=n), rng.normal(size=n) * 1e-160, rng.normal(size=n) * 1e160,
                        rng.normal(size=n), np.zeros(4), [5e-324, np.inf, -np.inf, np.nan]))
    y = np.concatenate((rng.normal(size=n), rng.normal(size=n), rng.normal(size=n) * 1e-200,
                        rng.normal(size=n) * 1e-9, [0.0, 1.0, -3.0, 5e-324], [2.0, 1.0, 0.0, 1.0]))
    want = np.array([math.hypot(a, b) for a, b in zip(x.tolist(), y.tolist(), strict=True)])
    if np.array_equal(ext.hypots(x, y), want, equal_nan=True):
        return True
    _log.warning("revolve-env: the compiled math.hypot does not give CPython's bits here; the "
                 "population env's fitness windows use NumPy")
    return False


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
        states = np.empty(self._size)
        sensors = np.empty(self._inputs)
        outcome = self._outcomes[self._run.step(targets, self._start, states, sensors)]
        # the backend replays what needs a replay; an unsettled state is a stepped one to it
        self._backend.stepped("calm" if outcome == "unsettled" else outcome, self._substeps)
        if outcome in ("replay", "restart"):
            return outcome, None, None, None
        n = self._n
        a, b, c, d, e, f = self._cuts
        now = BodyStates(states[:a].reshape(n, 3), states[a:b].reshape(n, 3, 3),
                         states[b:c].reshape(n, 3), states[c:d].reshape(n, 3), states[d:e],
                         states[e:f], self._diverged)
        sensors.flags.writeable = False
        return outcome, now, states[f:].reshape(n, 3), sensors


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
