"""Brain-driven evaluation of one robot: ``revolve_env.evaluate(robot) -> EvaluationResult``.

The module is named ``evaluation`` so that the package attribute ``revolve_env.evaluate`` stays the
function (a submodule of the same name would replace it once imported).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Unpack

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.parts import sensor_bounds
from revolve_env.body.robot import Layer, Robot
from revolve_env.body.validate import Limits, validate
from revolve_env.brain import BatchController
from revolve_env.conditions import IDEAL, EvaluationConditions, Start, add_sensor_noise
from revolve_env.fitness import trajectory_window
from revolve_env.fitness.sampling import pose_stride, shaking
from revolve_env.fitness.terms import pose_path_lengths
from revolve_env.setting import Setting, SettingKeywords
from revolve_env.tasks import TaskError, pose_rate, score
from revolve_env.world import World, WorldConfig, with_engine
from revolve_env.world.signals import SignalReader, signal_reader

__all__ = ["EvaluationResult", "evaluate", "evaluate_many", "evaluation_mjcf", "start_generator"]

_START_STREAM = 0x57A27
"""Tags the generator of a start, apart from the noise generator of the same seed."""


def start_generator(seed: int) -> np.random.Generator:
    """The generator an evaluation of ``seed`` draws its start (heading, jitter) from.

    Apart from ``default_rng(seed)``, which draws the noise: turning the random heading on or off
    changes no noise draw.
    """
    return np.random.default_rng(np.random.SeedSequence([seed, _START_STREAM]))


@dataclass(frozen=True)
class EvaluationResult:
    """Outcome of :func:`evaluate`.

    Attributes:
        fitness: The task's fitness over the evaluation (0 if the simulation blew up); the
            default task's ``v + 5 s`` in metres.
        v: Horizontal path length of the core over the evaluation, from its poses at the
            task's pose rate (:mod:`revolve_env.fitness.sampling`). Metres.
        s: Horizontal distance between the core's first and last poses. Metres.
        trajectory: Core positions at every control period of the evaluation, first row at the
            end of insertion; shape (T, 3), read-only. Metres.
        blow_up: Why the simulation blew up, or None.
        shaking: The path summed at every control period over ``v``, over the same span
            (:func:`~revolve_env.fitness.sampling.shaking`): 1 at a pose rate of every control
            period or for a smooth walker, more for a core that trembles or rocks between pose
            samples (after a blow-up: over the path before it). Dimensionless.
    """

    fitness: float
    v: float
    s: float
    trajectory: NDArray[np.float64] = field(repr=False, compare=False)
    blow_up: str | None = None
    shaking: float = 1.0


def evaluate(
    robot: Robot,
    setting: Setting | None = None,
    *,
    seed: int = 0,
    limits: Limits | None = None,
    **keywords: Unpack[SettingKeywords],
) -> EvaluationResult:
    """Run ``robot`` on its own controller in a fresh world and measure its fitness.

    (:func:`evaluate_many` evaluates many robots at once, to the same results.)

    The robot is validated, dropped at the origin (or where the setting's conditions draw its
    start), left ``insertion`` seconds to settle (its controller already runs) and then followed
    for ``seconds``; the fitness is the setting's task's over that span, by default the paper's
    ``v + 5 s`` (:class:`revolve_env.tasks.Locomotion`). The network is stepped by the compiled
    :class:`~revolve_env.brain.BatchController` once per control period.

    Args:
        robot: The robot, with its neural network.
        setting: Where and how it is simulated (:class:`~revolve_env.setting.Setting`: engine,
            terrain, timings, task, conditions, insertion and evaluation times); ``Setting()``
            by default: MuJoCo, flat ground, 3 s insertion, 12 s window, the paper's task and
            :data:`~revolve_env.conditions.IDEAL` conditions.
        seed: Seeds the start (heading, jitter) and the noise that the conditions ask for (the
            physics itself is deterministic): two generators, ``default_rng(seed)`` for the noise
            and :func:`start_generator` for the start.
        limits: Validation limits.
        **keywords: Parts of the setting, changed (:meth:`Setting.of
            <revolve_env.setting.Setting.of>`): ``seconds`` (the fitness window) and
            ``insertion`` (settling time), seconds; ``config`` (a
            :class:`~revolve_env.world.WorldConfig`); ``engine`` (``"mujoco"``, the default, or
            ``"pybullet"``); ``timing`` (a named timing); ``terrain`` (``"flat"``,
            ``"rugged"``, ``"crater"``, ``"bowl"``, a table or a spec: the robot is dropped onto
            the highest ground under its footprint); ``task`` (a task, a name or a table);
            ``conditions``; ``sensor_noise`` and ``actuator_noise`` (standard deviations of
            Gaussian noise on every sensor value and normalized hinge target: shortcuts for
            ``conditions``, not with it).

    Raises:
        RobotError: the robot is invalid (before any physics runs).
        ValueError: a bad timing or noise argument, noise given both ways, an unknown engine, a
            network whose inputs do not match the body's sensors, a bad task (``TaskError``), or
            a bad terrain or a start off it (``TerrainError``).
        EngineUnavailableError: the engine's package is not installed.
        TypeError: ``conditions`` is not an ``EvaluationConditions``, or an unknown keyword.
    """
    setting = Setting.of(setting, **keywords)
    [result] = evaluate_many([robot], setting, seeds=[seed], limits=limits)
    return result


def evaluate_many(
    robots: Sequence[Robot],
    setting: Setting | None = None,
    *,
    seeds: Sequence[int] | None = None,
    limits: Limits | None = None,
    **keywords: Unpack[SettingKeywords],
) -> list[EvaluationResult]:
    """:func:`evaluate` many robots side by side: the same results, for less work per robot.

    Every robot is in a scene of its own (``World(config, isolated=True)``), so it moves exactly
    as :func:`evaluate` alone moves it, bit for bit, whichever robots are beside it and however
    many; one control period steps them all, with their sensors, controllers (one call of the
    compiled controller for all networks) and hinge targets as arrays over every robot, so the
    per-period work outside the physics engine is paid once for the batch. A robot that blows
    up leaves the batch at once, as its own evaluation would stop.

    Args:
        robots: The robots, with their networks.
        setting: Where and how every robot is simulated (as :func:`evaluate`'s); the
            conditions of each are drawn from its own seed.
        seeds: One seed per robot (as :func:`evaluate`'s ``seed``); default 0 for each.
        limits: Validation limits.
        **keywords: Parts of the setting, changed (as :func:`evaluate`'s).

    Returns:
        One :class:`EvaluationResult` per robot, in order.

    Raises:
        RobotError: a robot is invalid (before any physics runs).
        ValueError: a bad timing, a seed count that does not match, an unknown engine, a network
            whose inputs do not match its body's sensors, a robot the engine cannot build, a
            bad task (``TaskError``), or a bad terrain or a start off it (``TerrainError``).
        EngineUnavailableError: the engine's package is not installed.
        TypeError: ``conditions`` is not an ``EvaluationConditions``, or an unknown keyword.
    """
    for robot in robots:
        validate(robot, limits)
    setting = Setting.of(setting, **keywords)
    seeds = [0] * len(robots) if seeds is None else [int(s) for s in seeds]
    if len(seeds) != len(robots):
        raise ValueError(f"{len(seeds)} seeds for {len(robots)} robots")
    conditions, scored, cfg = setting.conditions, setting.task, setting.world
    dt = cfg.control_period
    insertion_ticks = round(setting.insertion / dt)
    evaluation_ticks = round(setting.seconds / dt)
    if evaluation_ticks < 1:
        raise ValueError(f"seconds ({setting.seconds}) must cover at least one control period "
                         f"({dt} s)")
    try:
        stride = pose_stride(pose_rate(scored), dt)
    except ValueError as error:
        raise TaskError(f"task {scored.name!r}: {error}") from None
    if not robots:
        return []
    rngs = [np.random.default_rng(seed) for seed in seeds]
    gens = [start_generator(seed) for seed in seeds]
    starts = [conditions.start(g) for g in gens]
    # The hinges' start noise (none under the paper's conditions: nothing drawn), after the start.
    joints = [conditions.start_joints(g, len(robot.neurons_of(Layer.OUTPUT)))
              for g, robot in zip(gens, robots, strict=True)]
    with World(cfg, isolated=True) as world:
        paths = _rollout(world, robots, starts, insertion_ticks, evaluation_ticks, rngs,
                         conditions.sensor_noise, conditions.actuator_noise, scored.signal,
                         joints)
    trajectories = [p for p, _, _ in paths]
    window = trajectory_window(trajectories,
                               None if scored.signal is None else [g for _, g, _ in paths],
                               stride, dt)
    fitness = score(scored, window).tolist()
    shakes = shaking(*pose_path_lengths(trajectories, stride)).tolist()
    results = []
    for i, (path, _, reason) in enumerate(paths):
        if reason is not None:
            results.append(EvaluationResult(0.0, 0.0, 0.0, path, reason, shakes[i]))
        else:
            results.append(EvaluationResult(fitness[i], float(window.v[i]), float(window.s[i]),
                                            path, None, shakes[i]))
    return results


def _rollout(
    world: World, robots: Sequence[Robot], starts: Sequence[Start], insertion_ticks: int,
    evaluation_ticks: int, rngs: Sequence[np.random.Generator], sensor_noise: float,
    actuator_noise: float, signal: str | None = None,
    joints: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]] | None] | None = None,
) -> list[tuple[NDArray[np.float64], NDArray[np.float64], str | None]]:
    """Drop ``robots`` into ``world`` at ``starts`` and let their own networks drive them.

    ``joints``: per robot, its active hinges' start angles and speeds (None: at rest at 0).

    One pass per control period over every robot: their sensor values as one array, one call of
    the compiled controller for all networks, every target set at once. A robot whose
    simulation blows up leaves the world and the controller at once (``world`` must keep the
    others' physics apart from it: a world of one robot, or an isolated one); the others go on.
    Noise draws from each robot's own generator in ``rngs``, robot by robot. A task's
    ``signal`` (:mod:`revolve_env.world.signals`) is sampled with every core position.

    Returns:
        Per robot: the core's path over the evaluation ticks (read-only, metres), the signal at
        the same ticks (empty without a signal) and the blow-up reason (``None`` if the
        simulation stayed sane).
    """
    n = len(robots)
    brain = BatchController(world.config.brain_dt)
    think_every = world.config.brain_stride  # control periods per brain step
    nets = [brain.add(robot) for robot in robots]
    handles = [world.add_robot(robot, start.position, start.yaw)
               for robot, start in zip(robots, starts, strict=True)]
    for net, h in zip(nets, handles, strict=True):
        ins, outs = brain.input_slice(net), brain.output_slice(net)
        n_in, n_out = ins.stop - ins.start, outs.stop - outs.start
        if world.n_inputs(h) != n_in or world.n_outputs(h) != n_out:
            raise ValueError(
                f"the network has {n_in} inputs / {n_out} outputs but the body has "
                f"{world.n_inputs(h)} sensor values / {world.n_outputs(h)} active hinges")
    for h, hinges in zip(handles, joints or [None] * n, strict=True):
        if hinges is not None:
            world.set_hinge_state(h, *hinges)
    bounds = [sensor_bounds(robot) for robot in robots]
    noisy = sensor_noise > 0 or actuator_noise > 0
    outputs = np.zeros(brain.n_outputs)
    trajectory = np.empty((evaluation_ticks + 1, n, 3))
    signals = np.empty((evaluation_ticks + 1, n) if signal is not None else (0, n))
    reader: SignalReader | None = signal_reader(signal, robots, world)
    columns = np.arange(n)  # the robot (index into robots) of each world row
    rows = np.zeros(n, dtype=np.intp)  # trajectory rows of each robot that left
    recorded = 0  # trajectory rows of every robot still in the world
    reasons: list[str | None] = [None] * n
    every = True  # every robot still in the world: the world's rows are the columns
    for tick in range(insertion_ticks + evaluation_ticks):
        if tick == insertion_ticks:
            trajectory[0, columns] = world.states.core_pos
            if reader is not None:
                signals[0, columns] = reader.read(world)
            recorded = 1
        think = tick % think_every == 0  # the brain steps; its targets hold in between
        if noisy:
            inputs, targets = _noisy_step(world, brain, world.sensor_values(), outputs, columns,
                                          rngs, bounds, sensor_noise, actuator_noise, think)
        else:
            if think:
                brain.step(world.sensor_values(), outputs)
            targets = outputs
        world.set_all_targets(targets)
        world.step(1)
        if world.any_blown_up:
            left = columns
            held = {i: outputs[brain.output_slice(nets[i])].copy() for i in left.tolist()}
            columns = _drop_blown(world, brain, handles, nets, columns, reasons)
            rows[np.setdiff1d(left, columns)] = recorded
            if not columns.size:
                break
            outputs = np.zeros(brain.n_outputs)
            for i in columns.tolist():  # the others' targets hold until their brains step
                outputs[brain.output_slice(nets[i])] = held[i]
            every = False
            reader = signal_reader(signal, [robots[i] for i in columns.tolist()], world)
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


def _noisy_step(
    world: World, brain: BatchController, inputs: NDArray[np.float64],
    outputs: NDArray[np.float64], columns: NDArray[np.intp],
    rngs: Sequence[np.random.Generator],
    bounds: Sequence[tuple[NDArray[np.float64], NDArray[np.float64]]], sensor_noise: float,
    actuator_noise: float, think: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Sensor noise, the controller and actuator noise, robot by robot's own generator.

    Without ``think`` (a control period between two brain steps) no sensor is read: only the
    actuator noise is drawn, on the held outputs.
    """
    noisy_in = np.empty_like(inputs)
    ins, outs = world.input_offsets, world.output_offsets
    if think:
        for row, i in enumerate(columns.tolist()):
            low, high = bounds[i]
            noisy_in[ins[row]:ins[row + 1]] = add_sensor_noise(inputs[ins[row]:ins[row + 1]],
                                                               sensor_noise, rngs[i], low, high)
        brain.step(noisy_in, outputs)
    if actuator_noise <= 0:
        return noisy_in, outputs
    targets = outputs.copy()
    for row, i in enumerate(columns.tolist()):
        part = slice(outs[row], outs[row + 1])
        targets[part] = outputs[part] + rngs[i].normal(0.0, actuator_noise,
                                                        outs[row + 1] - outs[row])
    return noisy_in, targets


def _drop_blown(world: World, brain: BatchController, handles: list[int], nets: list[int],
                columns: NDArray[np.intp], reasons: list[str | None]) -> NDArray[np.intp]:
    """Take the robots that blew up out of the world and the controller; the columns left."""
    keep = []
    for row, i in enumerate(columns.tolist()):
        if world.blown_up[row]:
            reasons[i] = world.blow_up(handles[i])
        else:
            keep.append(i)
    for i in columns.tolist():
        if reasons[i] is not None and i not in keep:
            world.remove_robot(handles[i])
            brain.remove(nets[i])
    return np.array(keep, dtype=np.intp)


def evaluation_mjcf(robot: Robot, seed: int = 0, *, config: WorldConfig | None = None,
                    limits: Limits | None = None,
                    conditions: EvaluationConditions = IDEAL) -> str:
    """MuJoCo's MJCF of the world :func:`evaluate` steps for ``robot`` with these arguments.

    The robot at its start (the conditions' heading and jitter drawn for ``seed``), dropped as an
    evaluation drops it, in MuJoCo's scene (:meth:`revolve_env.world.World.to_mjcf`).

    Raises:
        RobotError: the robot is invalid.
        EngineUnavailableError: the ``mujoco`` package is not installed.
    """
    validate(robot, limits)
    start = conditions.start(start_generator(seed))
    with World(with_engine(config if config is not None else WorldConfig(), "mujoco")) as world:
        world.add_robot(robot, start.position, start.yaw)
        return world.to_mjcf()
