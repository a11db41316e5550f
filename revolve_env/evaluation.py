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

from revolve_env.body.robot import Layer, Robot
from revolve_env.body.validate import Limits, validate
from revolve_env.conditions import IDEAL, EvaluationConditions
from revolve_env.fitness.sampling import shaking
from revolve_env.fitness.terms import pose_path_lengths
from revolve_env.rollout import rollout, score_paths, task_pose_stride
from revolve_env.setting import Setting, SettingKeywords
from revolve_env.world import World, WorldConfig, with_engine

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
    threads: int = 1,
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
        threads: Threads of this process that step the robots (MuJoCo's compiled rollout,
            :mod:`revolve_env.world.compiled`; elsewhere one). The results do not depend on it.
            One by default, as processes (``--workers``) already share the cores.
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
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
        raise ValueError(f"threads must be a whole number >= 1, got {threads!r}")
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
    stride = task_pose_stride(scored, dt)
    if not robots:
        return []
    rngs = [np.random.default_rng(seed) for seed in seeds]
    gens = [start_generator(seed) for seed in seeds]
    starts = [conditions.start(g) for g in gens]
    # The hinges' start noise (none under the paper's conditions: nothing drawn), after the start.
    joints = [conditions.start_joints(g, len(robot.neurons_of(Layer.OUTPUT)))
              for g, robot in zip(gens, robots, strict=True)]
    with World(cfg, isolated=True) as world:
        paths = rollout(world, robots, starts, insertion_ticks, evaluation_ticks, rngs,
                        conditions.sensor_noise, conditions.actuator_noise, scored.signal, joints,
                        threads)
    trajectories = [p for p, _, _ in paths]
    scores, window = score_paths(scored, paths, stride, dt)
    fitness = scores.tolist()
    shakes = shaking(*pose_path_lengths(trajectories, stride)).tolist()
    results = []
    for i, (path, _, reason) in enumerate(paths):
        if reason is not None:
            results.append(EvaluationResult(0.0, 0.0, 0.0, path, reason, shakes[i]))
        else:
            results.append(EvaluationResult(fitness[i], float(window.v[i]), float(window.s[i]),
                                            path, None, shakes[i]))
    return results


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
