"""One rollout: the robots of a world advanced control period by control period.

The per-period rules above the physics world, in one place for every driver
(:func:`revolve_env.evaluate` / :func:`~revolve_env.evaluate_many`, the single-robot env and the
population env). It sits above ``world/``, ``brain/``, ``fitness/`` and ``tasks/`` and below
``evaluation.py`` and ``envs/``:

* :class:`Rollout` drives the robots of one :class:`~revolve_env.world.World`: the networks of
  brain-driven robots in one compiled :class:`~revolve_env.brain.BatchController` (stepped every
  ``brain_stride`` control periods, their targets held in between), the targets a learner gives
  for the others, the actuator noise (:func:`~revolve_env.conditions.add_actuator_noise`), the
  physics step and the blow-up screen.
* :class:`TaskWindows` is the task's sliding windows of those robots: their poses at the task's
  pose rate (held in between, :mod:`revolve_env.fitness.sampling`), one ring buffer
  (:class:`~revolve_env.fitness.FitnessWindows`) and the task's score of them.
* :class:`RobotWindow` is the same window of ONE robot (the single-robot env's) in Python floats:
  the numbers of a :class:`TaskWindows` of one column, bit for bit, without its arrays.
* :func:`rollout` is a whole evaluation of brain-driven robots, each in its own scene: the
  trajectory (and signal) of every robot over the evaluation, as :func:`revolve_env.evaluate`
  scores it.

The noise rule is :mod:`revolve_env.conditions`' (:func:`~revolve_env.conditions.add_sensor_noise`,
:func:`~revolve_env.conditions.add_actuator_noise`); the servo law, the sensors and the blow-up
rules are the world's.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.parts import sensor_bounds
from revolve_env.body.robot import Robot
from revolve_env.brain import BatchController
from revolve_env.brain.spec import NetworkSpec
from revolve_env.conditions import Start, add_actuator_noise, add_sensor_noise
from revolve_env.fitness import FitnessTerms, FitnessWindows, Window, trajectory_window
from revolve_env.fitness.sampling import pose_due, pose_stride
from revolve_env.fitness.terms import TIME_EPS
from revolve_env.tasks import (
    DirectedLocomotion,
    LightFollowing,
    Locomotion,
    Task,
    TaskError,
    own_reward,
    pose_rate,
    score,
)
from revolve_env.world import World, compiled
from revolve_env.world.signals import SignalReader, signal_reader

__all__ = ["RobotWindow", "Rollout", "TaskWindows", "rollout", "score_paths", "task_pose_stride",
           "task_rule"]


def task_pose_stride(task: Task, control_period: float) -> int:
    """Control periods between two pose samples of ``task``'s fitness.

    Raises:
        TaskError: the task's pose rate does not fit the control period (one line).
    """
    try:
        return pose_stride(pose_rate(task), control_period)
    except ValueError as error:
        raise TaskError(f"task {task.name!r}: {error}") from None


def task_rule(task: Task) -> compiled.TaskRule | None:
    """``task``'s fitness rule for the compiled env step (:class:`compiled.EnvStep`), or None.

    The shipped tasks rewarded by their fitness gain (:class:`~revolve_env.tasks.Locomotion`,
    :class:`~revolve_env.tasks.DirectedLocomotion`, :class:`~revolve_env.tasks.LightFollowing`,
    not a subclass: a user's class may score otherwise); their Python rules are the reference,
    and the compiled ones give their bits (tests).
    """
    if own_reward(task):
        return None
    kind = type(task)
    if kind is Locomotion:
        assert isinstance(task, Locomotion)
        limit = math.nan if task.limit is None else task.limit
        return 0, task.s_weight, limit, 1.0, 0.0
    if kind is DirectedLocomotion:
        assert isinstance(task, DirectedLocomotion)
        return 1, 0.0, math.nan, math.cos(task.heading), math.sin(task.heading)
    if kind is LightFollowing:
        return 2, 0.0, math.nan, 1.0, 0.0
    return None


def _entries(offsets: NDArray[np.intp], rows: list[int]) -> NDArray[np.intp]:
    """The flat entries of ``rows`` in a layout delimited by ``offsets``, row after row."""
    if not rows:
        return np.zeros(0, dtype=np.intp)
    return np.concatenate([np.arange(offsets[r], offsets[r + 1]) for r in rows]).astype(np.intp)


class Rollout:
    """The robots of one world, advanced by control periods (see the module doc).

    A robot is brain-driven (its network given at :meth:`add`, ``drives=True``), learner-driven
    (its targets given to :meth:`period`), or learner-driven with a network that assists
    (``drives=False``: :meth:`think` steps it; the caller mixes its outputs into the targets).
    Brains are laid out in the controller in world row order.

    Args:
        world: The world (owned by the caller).
        brain: The controller of the networks; default one of the world's brain period.
        brain_stride: Control periods per brain step; default the world's.
    """

    def __init__(self, world: World, brain: BatchController | None = None,
                 brain_stride: int | None = None) -> None:
        self.world = world
        self.brain = brain if brain is not None else BatchController(world.config.brain_dt)
        self.brain_stride = world.config.brain_stride if brain_stride is None else brain_stride
        self.periods = 0  # control periods stepped
        self.outputs = np.zeros(self.brain.n_outputs)  # brain order; held between brain steps
        self._nets: dict[int, int] = {}  # world handle -> controller handle
        self._drives: set[int] = set()  # world handles of brain-driven robots
        self._slices: dict[int, slice] = {}  # controller handle -> its outputs' slice
        self._inputs = np.zeros(0, dtype=np.intp)  # sensor entries the brains read, brain order
        self._targets = np.zeros(0, dtype=np.intp)  # target entries the driving brains write
        self._driving = np.zeros(0, dtype=np.intp)  # their outputs' entries (brain order)
        self._every = True  # every robot brain-driven: brain order is the world's layout
        self.relayout()

    # -- robots ------------------------------------------------------------------------------
    def add(self, robot: Robot, position: tuple[float, float], yaw: float, *,
            network: Robot | NetworkSpec | None = None, drives: bool = True,
            joints: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
            relayout: bool = True) -> int:
        """Drop ``robot`` into the world; its world handle.

        Args:
            robot: The body.
            position: Where its core goes, (x, y). Metres.
            yaw: Its heading. Radians.
            network: Its network (None: a learner's targets drive it).
            drives: Whether the network's outputs are the robot's targets (else it only assists).
            joints: Its active hinges' start angles and speeds (None: at rest at 0).
            relayout: Lay the brains out now (False: the caller calls :meth:`relayout`).

        Raises:
            ValueError: the network's inputs or outputs do not match the body.
        """
        handle = self.world.add_robot(robot, position, yaw)
        if joints is not None:
            self.world.set_hinge_state(handle, *joints)
        if network is not None:
            net = self.brain.add(network)
            self.adopt(handle, net, drives)
            ins, outs = self.brain.input_slice(net), self.brain.output_slice(net)
            n_in, n_out = ins.stop - ins.start, outs.stop - outs.start
            if self.world.n_inputs(handle) != n_in or self.world.n_outputs(handle) != n_out:
                raise ValueError(
                    f"the network has {n_in} inputs / {n_out} outputs but the body has "
                    f"{self.world.n_inputs(handle)} sensor values / "
                    f"{self.world.n_outputs(handle)} active hinges")
        if relayout:
            self.relayout()
        return handle

    def adopt(self, handle: int, net: int, drives: bool = True) -> None:
        """Take robot ``handle``'s network, already in the controller as ``net`` (a restore)."""
        self._nets[handle] = net
        if drives:
            self._drives.add(handle)

    def network(self, handle: int) -> int | None:
        """The controller handle of robot ``handle``'s network (None: it has none)."""
        return self._nets.get(handle)

    def remove(self, handles: Sequence[int]) -> None:
        """Take robots out of the world and their networks out of the controller.

        The others' held outputs stay theirs until their brains step again.
        """
        for handle in handles:
            self.world.remove_robot(handle)
            net = self._nets.pop(handle, None)
            self._drives.discard(handle)
            if net is not None:
                self.brain.remove(net)
        self.relayout()

    def relayout(self) -> None:
        """Where every brain reads its inputs and writes its targets (after births and deaths)."""
        world, brain = self.world, self.brain
        outputs = np.zeros(brain.n_outputs)
        slices = {}
        for net in self._nets.values():  # held outputs follow their network
            now = brain.output_slice(net)
            before = self._slices.get(net)
            if before is not None:
                outputs[now] = self.outputs[before]
            slices[net] = now
        self.outputs, self._slices = outputs, slices
        handles = list(self._nets)  # brain order: the order the networks were added in
        rows = world.rows(handles).tolist() if handles else []
        self._every = (len(self._drives) == len(handles) == len(world.handles)
                       and rows == list(range(len(rows))))
        if self._every:  # the brains' inputs and outputs are the world's, as they are
            return
        driving = [h in self._drives for h in handles]
        self._inputs = _entries(world.input_offsets, rows)
        self._targets = _entries(world.output_offsets,
                                 [r for r, d in zip(rows, driving, strict=True) if d])
        self._driving = _entries(
            np.array([0, *(s.stop for s in slices.values())], dtype=np.intp),
            [k for k, d in enumerate(driving) if d])

    # -- the period ---------------------------------------------------------------------------
    @property
    def all_brains(self) -> bool:
        """Whether every robot is brain-driven, stepped every period, in the world's order."""
        return self._every and bool(self._drives) and self.brain_stride == 1

    @property
    def thinking(self) -> bool:
        """Whether the brains step in the next period (else their targets hold)."""
        return self.periods % self.brain_stride == 0

    def think(self, values: NDArray[np.float64]) -> NDArray[np.float64]:
        """Step every network on the sensor ``values`` (the world's layout) if it is time to.

        Returns:
            Every network's outputs, brain order (held between brain steps; the rollout's own).
        """
        if self._nets and self.thinking:
            self.brain.step(values if self._every else values[self._inputs], self.outputs)
        return self.outputs

    def period(self, values: NDArray[np.float64] | None,
               learner: tuple[NDArray[np.intp] | None, NDArray[np.float64]] | None = None,
               actuator_noise: float = 0.0, rng: np.random.Generator | None = None,
               rngs: Sequence[np.random.Generator] | None = None,
               thought: bool = False) -> NDArray[np.bool_] | None:
        """One control period: targets, the physics, the blow-up screen.

        The learner's targets are set (with actuator noise), then the driving brains think on
        ``values`` (their sensor values as they read them, the world's layout; unused when the
        brains do not step) and their targets are set (with actuator noise); the world steps.

        Args:
            values: The sensor values the brains read (None: no brain steps now).
            learner: The learner-driven robots' targets: (entries of the flat targets, None:
                all of them; values), normalized.
            actuator_noise: Standard deviation of the noise on every target.
            rng: The noise's generator: the learner's targets, then the brains', each one draw.
            rngs: Instead, one generator per brain robot (brain order), drawn robot by robot.
            thought: The brains have stepped in this period already (their :attr:`outputs`
                are this period's: compiled periods that left the rest to Python).

        Returns:
            Which rows blew up (the world's :attr:`~revolve_env.world.World.blown_up`), None if
            none did.
        """
        world = self.world
        if learner is not None:
            entries, targets = learner
            if actuator_noise > 0:
                assert rng is not None
                targets = add_actuator_noise(targets, actuator_noise, rng)
            if entries is None:
                world.set_all_targets(targets)
            else:
                world.set_target_entries(entries, targets)
        if self._drives:
            if self.thinking and not thought:
                assert values is not None
                self.think(values)
            targets = self.outputs
            if actuator_noise > 0 and rngs is not None:  # robot by robot, its own generator
                targets = targets.copy()
                for net, gen in zip(self._nets.values(), rngs, strict=True):
                    part = self._slices[net]
                    targets[part] = add_actuator_noise(self.outputs[part], actuator_noise, gen)
            if not self._every:
                targets = targets[self._driving]
            if actuator_noise > 0 and rngs is None:
                assert rng is not None
                targets = add_actuator_noise(targets, actuator_noise, rng)
            if self._every:
                world.set_all_targets(targets)
            else:
                world.set_target_entries(self._targets, targets)
        world.step(1)
        self.periods += 1
        return self.blown()

    def blown(self) -> NDArray[np.bool_] | None:
        """The blow-up screen: which rows blew up (read-only), None if none."""
        return self.world.blown_up if self.world.any_blown_up else None


class TaskWindows:
    """The task's sliding windows of a world's robots: poses at its pose rate, then its score.

    One column per robot (:class:`~revolve_env.fitness.FitnessWindows`). A robot is sampled from
    the end of its insertion on, its pose every :func:`~revolve_env.fitness.sampling.pose_stride`
    control periods; in between it holds its last pose (and signal).

    Args:
        task: What the robots are scored on.
        window: The windows' length. Seconds.
        control_period: The world's control period. Seconds.
        insertion_steps: Control periods of a robot's life before it is scored.

    Raises:
        TaskError: the task's pose rate does not fit the control period.
    """

    def __init__(self, task: Task, window: float, control_period: float,
                 insertion_steps: int) -> None:
        self.task = task
        self.window = window
        self.insertion_steps = insertion_steps
        self.stride = task_pose_stride(task, control_period)
        self.ring = FitnessWindows(window, signal=task.signal is not None)

    def __len__(self) -> int:
        """Robots (columns)."""
        return len(self.ring)

    def clear(self) -> None:
        """No robots and no samples."""
        self.ring = FitnessWindows(self.window, signal=self.task.signal is not None)

    def add(self, count: int = 1) -> None:
        """Append ``count`` robots with no samples (newborns, last columns)."""
        self.ring.add(count)

    def remove(self, keep: NDArray[np.bool_]) -> None:
        """Keep only the robots where ``keep`` is True."""
        self.ring.remove(keep)

    def push(self, time: float, position: NDArray[np.float64], ages: NDArray[np.int64],
             sampling: NDArray[np.bool_] | None, signal: NDArray[np.float64] | None,
             kernel: Callable[..., tuple[bool, int, int, bool]] | None = None) -> Window:
        """Sample the robots in ``sampling`` (None: all) now; every robot's window after it.

        Args:
            time: Simulated time now. Seconds.
            position: (n, 3) every robot's core position now. Metres.
            ages: (n,) control periods since every robot's birth.
            sampling: Which robots are sampled (past their insertion, alive).
            signal: (n,) the task's signal of every robot now (None: the task has none).
            kernel: The compiled push (:func:`~revolve_env.world.compiled.windows_kernel`),
                used where it applies (:meth:`FitnessWindows.push_compiled`); the same numbers.
        """
        if kernel is not None and signal is None and sampling is not None:
            window = self.ring.push_compiled(kernel, time, position, ages, sampling, self.stride,
                                             self.insertion_steps)
            if window is not None:
                return window
        pose = position
        if self.stride > 1:  # between pose samples a robot holds its last one
            since = ages - self.insertion_steps
            posing = pose_due(since, self.stride)
            if not (posing.all() if sampling is None else posing[sampling].all()):
                held = ~posing & (since > 0)
                if sampling is not None:
                    held &= sampling
                last, last_signal = self.ring.last()
                if held.all():  # every robot holds (one robot between its samples)
                    pose = last
                    if signal is not None and last_signal is not None:
                        signal = last_signal
                else:
                    pose = position[:, :2].copy()
                    pose[held] = last[held]
                    if signal is not None and last_signal is not None:
                        signal = np.where(held, last_signal, signal)
        self.ring.push(time, pose, sampling, signal)
        return self.ring.current()

    def score(self, window: Window) -> NDArray[np.float64]:
        """The task's fitness of every robot's ``window``. Metres (the shipped tasks)."""
        return score(self.task, window)


class RobotWindow:
    """The task's sliding window of ONE robot, in Python floats (the single-robot env's).

    What a :class:`TaskWindows` of one column gives, bit for bit (the same floating-point
    operations in the same order, on floats instead of arrays of one): the robot is sampled from
    the end of its insertion on, its pose every :attr:`stride` control periods, holding its last
    pose (and signal) in between; samples older than ``window`` seconds leave; the path length is
    a running sum, rebased past 1 km. The task scores :meth:`current` (a :class:`Window` of one
    robot) by its own rule (:func:`~revolve_env.tasks.score`).

    Args:
        task: What the robot is scored on.
        window: The window's length. Seconds.
        control_period: The world's control period. Seconds.
        insertion_steps: Control periods of the robot's life before it is scored.

    Raises:
        TaskError: the task's pose rate does not fit the control period.
    """

    def __init__(self, task: Task, window: float, control_period: float,
                 insertion_steps: int) -> None:
        self.task = task
        self.window = float(window)
        self.insertion_steps = insertion_steps
        self.stride = task_pose_stride(task, control_period)
        self.signal = task.signal is not None
        # Samples in the window, oldest first: (time s, x m, y m, path m, signal).
        self._samples: deque[tuple[float, float, float, float, float]] = deque()

    def __len__(self) -> int:
        """Samples in the window."""
        return len(self._samples)

    def clear(self) -> None:
        """No samples."""
        self._samples.clear()

    def holds(self, age: int) -> bool:
        """Whether a robot ``age`` control periods old holds its last pose now (no new one)."""
        since = age - self.insertion_steps
        return self.stride > 1 and since > 0 and since % self.stride != 0

    def push(self, time: float, x: float, y: float, age: int, signal: float | None) -> None:
        """Sample the robot now (it holds its last pose and signal between pose samples).

        Args:
            time: Simulated time now (not before the previous sample). Seconds.
            x: The core's position now (ignored while the robot holds). Metres.
            y: Likewise. Metres.
            age: Control periods since the robot's birth.
            signal: The task's signal now (None: the task has none; ignored while it holds).

        Raises:
            ValueError: a time before the previous one, or a non-finite time or position.
        """
        samples = self._samples
        if self.holds(age):
            x, y, held = self.last()
            if signal is not None and self.signal:
                signal = held
        time = float(time)
        if not math.isfinite(time):
            raise ValueError(f"time must be finite, got {time}")
        if samples and time < samples[-1][0]:
            raise ValueError(f"time {time} s is before the previous sample")
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ValueError("positions of robots that sample must be finite")
        if self.signal and signal is None:
            raise ValueError("these windows keep a signal: push needs one")
        if samples:
            _, px, py, pp, _ = samples[-1]
            path = pp + math.hypot(x - px, y - py)
            horizon = time - self.window - TIME_EPS  # drop samples that left the window
            while samples and samples[0][0] < horizon:
                samples.popleft()
        else:
            path = 0.0
        samples.append((time, x, y, path, signal if self.signal and signal is not None else 0.0))
        if path > 1e3:  # keep the running sum small so that differences stay exact
            base = samples[0][3]
            self._samples = deque((t, sx, sy, p - base, sg) for t, sx, sy, p, sg in samples)

    def last(self) -> tuple[float, float, float]:
        """The latest sample's x, y (metres) and signal (zeros without a sample)."""
        if not self._samples:
            return 0.0, 0.0, 0.0
        _, x, y, _, signal = self._samples[-1]
        return x, y, signal

    def current(self) -> Window:
        """The window now as arrays of one robot (zeros but ``samples`` below two samples)."""
        samples = self._samples
        count = np.array([len(samples)], dtype=np.int64)
        count.flags.writeable = False
        first, last = (samples[0], samples[-1]) if len(samples) >= 2 else ((0.0,) * 5,) * 2
        t0, x0, y0, p0, g0 = first
        t1, x1, y1, p1, g1 = last
        return Window(np.array([[x0, y0]]), np.array([[x1, y1]]), np.array([p1 - p0]),
                      np.array([math.hypot(x1 - x0, y1 - y0)]),
                      count, np.array([g0]) if self.signal else None,
                      np.array([g1]) if self.signal else None, np.array([t1 - t0]))

    def terms(self) -> FitnessTerms:
        """The task's fitness of the window now, its path length ``v`` and displacement ``s``.

        Metres (the shipped tasks); all 0 below two samples.
        """
        samples = self._samples
        if len(samples) < 2:
            return FitnessTerms(0.0, 0.0, 0.0)
        window = self.current()  # scored by the task's own rule (its one home)
        return FitnessTerms(float(score(self.task, window)[0]), float(window.v[0]),
                            float(window.s[0]))


def _noisy_inputs(world: World, values: NDArray[np.float64], columns: list[int],
                  rngs: Sequence[np.random.Generator],
                  bounds: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]]],
                  noise: float) -> NDArray[np.float64]:
    """Every robot's sensor values with its own noise (robot by robot's own generator)."""
    noisy = np.empty_like(values)
    ins = world.input_offsets
    for row, i in enumerate(columns):
        low, high = bounds[i]
        noisy[ins[row]:ins[row + 1]] = add_sensor_noise(values[ins[row]:ins[row + 1]], noise,
                                                        rngs[i], low, high)
    return noisy


def rollout(
    world: World, robots: Sequence[Robot], starts: Sequence[Start], insertion_ticks: int,
    evaluation_ticks: int, rngs: Sequence[np.random.Generator], sensor_noise: float,
    actuator_noise: float, signal: str | None = None,
    joints: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]] | None] | None = None,
    threads: int = 1, compile_it: bool = True,
) -> list[tuple[NDArray[np.float64], NDArray[np.float64], str | None]]:
    """Drop ``robots`` into ``world`` at ``starts`` and let their own networks drive them.

    ``joints``: per robot, its active hinges' start angles and speeds (None: at rest at 0).
    Without noise, an isolated MuJoCo world runs in the compiled rollout to the same numbers
    (:func:`revolve_env.world.compiled.rollout`, over ``threads`` threads) unless ``compile_it``
    is False.

    One :meth:`Rollout.period` per control period over every robot: their sensor values as one
    array, one call of the compiled controller for all networks, every target set at once. A
    robot whose simulation blows up leaves the world and the controller at once (``world`` must
    keep the others' physics apart from it: a world of one robot, or an isolated one); the
    others go on. Noise draws from each robot's own generator in ``rngs``, robot by robot. A
    task's ``signal`` (:mod:`revolve_env.world.signals`) is sampled with every core position.

    Returns:
        Per robot: the core's path over the evaluation ticks (read-only, metres), the signal at
        the same ticks (empty without a signal) and the blow-up reason (``None`` if the
        simulation stayed sane).
    """
    if compile_it and sensor_noise <= 0 and actuator_noise <= 0:
        paths = compiled.rollout(world, robots, starts, insertion_ticks, evaluation_ticks, signal,
                                 joints, threads)
        if paths is not None:
            redo = [i for i, p in enumerate(paths) if p is None]
            if redo:  # the NumPy path replays and reports what turned non-finite
                with World(world.config, isolated=True) as again:
                    redone = rollout(again, [robots[i] for i in redo], [starts[i] for i in redo],
                                     insertion_ticks, evaluation_ticks,
                                     [np.random.default_rng(0) for _ in redo], 0.0, 0.0, signal,
                                     None if joints is None else [joints[i] for i in redo],
                                     compile_it=False)
                for i, result in zip(redo, redone, strict=True):
                    paths[i] = result
            return [p for p in paths if p is not None]
    n = len(robots)
    run = Rollout(world)
    handles = [run.add(robot, start.position, start.yaw, network=robot, relayout=False)
               for robot, start in zip(robots, starts, strict=True)]
    run.relayout()
    for h, hinges in zip(handles, joints or [None] * n, strict=True):
        if hinges is not None:
            world.set_hinge_state(h, *hinges)
    bounds = [sensor_bounds(robot) for robot in robots]
    noisy = sensor_noise > 0 or actuator_noise > 0
    trajectory = np.empty((evaluation_ticks + 1, n, 3))
    signals = np.empty((evaluation_ticks + 1, n) if signal is not None else (0, n))
    reader: SignalReader | None = signal_reader(signal, robots, world)
    columns = list(range(n))  # the robot (index into robots) of each world row
    rows = np.zeros(n, dtype=np.intp)  # trajectory rows of each robot that left
    recorded = 0  # trajectory rows of every robot still in the world
    reasons: list[str | None] = [None] * n
    every = True  # every robot still in the world: the world's rows are the columns
    own = list(rngs)  # the generator of each world row
    for tick in range(insertion_ticks + evaluation_ticks):
        if tick == insertion_ticks:
            trajectory[0, columns] = world.states.core_pos
            if reader is not None:
                signals[0, columns] = reader.read(world)
            recorded = 1
        values = world.sensor_values() if run.thinking else None
        if noisy and values is not None:
            values = _noisy_inputs(world, values, columns, rngs, bounds, sensor_noise)
        blown = run.period(values, actuator_noise=actuator_noise, rngs=own)
        if blown is not None:
            gone = [i for row, i in enumerate(columns) if blown[row]]
            for i in gone:
                reasons[i] = world.blow_up(handles[i])
            run.remove([handles[i] for i in gone])
            rows[gone] = recorded
            columns = [i for row, i in enumerate(columns) if not blown[row]]
            if not columns:
                break
            own = [rngs[i] for i in columns]
            every = False
            reader = signal_reader(signal, [robots[i] for i in columns], world)
        if tick >= insertion_ticks:
            if every:
                trajectory[recorded] = world.states.core_pos
            else:
                trajectory[recorded, columns] = world.states.core_pos
            if reader is not None:
                signals[recorded, columns] = reader.read(world)
            recorded += 1
    rows[columns] = recorded
    out = []
    for i in range(n):
        path = trajectory[:rows[i], i].copy()
        path.setflags(write=False)
        out.append((path, signals[:rows[i], i].copy() if signal is not None else signals[:0, i],
                    reasons[i]))
    return out


def score_paths(task: Task, paths: Sequence[tuple[NDArray[np.float64], NDArray[np.float64],
                                                   str | None]],
                stride: int, control_period: float) -> tuple[NDArray[np.float64], Window]:
    """The task's fitness of whole evaluations (:func:`rollout`'s paths), and their windows.

    Every pose sample of a path counts (:func:`~revolve_env.fitness.trajectory_window`); a
    path that ended in a blow-up is scored as it is (its caller zeroes it).

    Args:
        task: What the robots are scored on.
        paths: Per robot: its core's path (T, 3), its signal (T,) and its blow-up reason.
        stride: Control periods between two pose samples (:func:`task_pose_stride`).
        control_period: Time between two rows of a path. Seconds.
    """
    window = trajectory_window([p for p, _, _ in paths],
                               None if task.signal is None else [g for _, g, _ in paths],
                               stride, control_period)
    return score(task, window), window
