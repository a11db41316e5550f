"""Brain-driven evaluation of one robot: ``revolve_env.evaluate(robot) -> EvaluationResult``.

The module is named ``evaluation`` so that the package attribute ``revolve_env.evaluate`` stays the
function (a submodule of the same name would replace it once imported).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.parts import sensor_bounds
from revolve_env.body.robot import Robot
from revolve_env.body.validate import Limits, validate
from revolve_env.brain import BatchController
from revolve_env.conditions import (
    IDEAL,
    EvaluationConditions,
    Start,
    add_sensor_noise,
    with_noise_shortcuts,
)
from revolve_env.fitness import DEFAULT_S_WEIGHT, fitness_terms
from revolve_env.world import World, WorldConfig

__all__ = ["EvaluationResult", "evaluate", "evaluation_mjcf", "start_generator"]

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
        fitness: ``v + 5 s`` over the evaluation (0 if the simulation blew up). Metres.
        v: Horizontal path length of the core over the evaluation. Metres.
        s: Horizontal distance between the core's first and last positions. Metres.
        trajectory: Core positions at every control period of the evaluation, first row at the
            end of insertion; shape (T, 3), read-only. Metres.
        blow_up: Why the simulation blew up, or None.
    """

    fitness: float
    v: float
    s: float
    trajectory: NDArray[np.float64] = field(repr=False, compare=False)
    blow_up: str | None = None


def evaluate(
    robot: Robot,
    *,
    seconds: float = 12.0,
    insertion: float = 3.0,
    seed: int = 0,
    sensor_noise: float = 0.0,
    actuator_noise: float = 0.0,
    config: WorldConfig | None = None,
    limits: Limits | None = None,
    engine: str | None = None,
    conditions: EvaluationConditions | None = None,
) -> EvaluationResult:
    """Run ``robot`` on its own controller in a fresh world and measure its fitness.

    The robot is validated, dropped at the origin (or where ``conditions`` draw its start), left
    ``insertion`` seconds to settle (its controller already runs) and then followed for
    ``seconds``; the fitness is ``v + 5 s`` over that span (:mod:`revolve_env.fitness`). The
    network is stepped by the compiled :class:`~revolve_env.brain.BatchController` once per
    control period.

    Args:
        robot: The robot, with its neural network.
        seconds: Evaluation time (the fitness window). Seconds.
        insertion: Settling time before the evaluation. Seconds.
        seed: Seeds the start (heading, jitter) and the noise that ``conditions`` ask for (the
            physics itself is deterministic): two generators, ``default_rng(seed)`` for the noise
            and :func:`start_generator` for the start.
        sensor_noise: Standard deviation of Gaussian noise on every sensor value (a shortcut for
            ``conditions=EvaluationConditions(sensor_noise=...)``; not with ``conditions``).
        actuator_noise: Standard deviation of Gaussian noise on every normalized hinge target
            (likewise).
        config: Physics settings; ``WorldConfig()`` by default.
        limits: Validation limits.
        engine: Physics engine (``"pybullet"`` or ``"mujoco"``); None keeps ``config.engine``
            (pybullet by default).
        conditions: Start heading and position jitter around the origin, sensor and actuator
            noise (:class:`~revolve_env.conditions.EvaluationConditions`); default
            :data:`~revolve_env.conditions.IDEAL` (heading 0 at the origin, no noise).

    Raises:
        RobotError: the robot is invalid (before any physics runs).
        ValueError: a bad timing or noise argument, noise given both ways, an unknown engine, or
            a network whose inputs do not match the body's sensors.
        EngineUnavailableError: the engine's package is not installed.
        TypeError: ``conditions`` is not an ``EvaluationConditions``.
    """
    validate(robot, limits)
    for name, value in (("seconds", seconds), ("insertion", insertion),
                        ("sensor_noise", sensor_noise), ("actuator_noise", actuator_noise)):
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value}")
    conditions = with_noise_shortcuts(conditions, sensor_noise, actuator_noise)
    cfg = (config if config is not None else WorldConfig()).with_engine(engine)
    dt = cfg.control_period
    insertion_ticks = round(insertion / dt)
    evaluation_ticks = round(seconds / dt)
    if evaluation_ticks < 1:
        raise ValueError(f"seconds ({seconds}) must cover at least one control period ({dt} s)")
    rng = np.random.default_rng(seed)
    start = conditions.start(start_generator(seed))
    with World(cfg) as world:
        path, reason = _rollout(world, robot, insertion_ticks, evaluation_ticks, rng,
                                conditions.sensor_noise, conditions.actuator_noise, start)
    if reason is not None:
        return EvaluationResult(0.0, 0.0, 0.0, path, reason)
    terms = fitness_terms(path, DEFAULT_S_WEIGHT)
    return EvaluationResult(terms.fitness, terms.v, terms.s, path, None)


def _rollout(
    world: World, robot: Robot, insertion_ticks: int, evaluation_ticks: int,
    rng: np.random.Generator, sensor_noise: float, actuator_noise: float, start: Start,
) -> tuple[NDArray[np.float64], str | None]:
    """Drop ``robot`` into ``world`` at ``start`` and let its own network drive it.

    Returns:
        The core's path over the evaluation ticks (read-only, metres) and the blow-up reason
        (``None`` if the simulation stayed sane).
    """
    brain = BatchController(world.config.control_period)
    brain.add(robot)
    inputs = np.zeros(brain.n_inputs)
    outputs = np.zeros(brain.n_outputs)
    trajectory = np.empty((evaluation_ticks + 1, 3))
    h = world.add_robot(robot, start.position, start.yaw)
    if world.n_inputs(h) != len(inputs) or world.n_outputs(h) != len(outputs):
        raise ValueError(
            f"the network has {len(inputs)} inputs / {len(outputs)} outputs but the body has "
            f"{world.n_inputs(h)} sensor values / {world.n_outputs(h)} active hinges"
        )
    low, high = sensor_bounds(robot)
    reason: str | None = None
    rows = 0
    for tick in range(insertion_ticks + evaluation_ticks):
        if tick == insertion_ticks:
            trajectory[0] = world.core_position(h)
            rows = 1
        inputs[:] = add_sensor_noise(world.read_sensors(h), sensor_noise, rng, low, high)
        brain.step(inputs, outputs)
        if actuator_noise > 0:
            world.set_targets(h, outputs + rng.normal(0.0, actuator_noise, outputs.shape))
        else:
            world.set_targets(h, outputs)
        world.step(1)
        reason = world.blow_up(h)
        if reason is not None:
            break
        if tick >= insertion_ticks:
            trajectory[rows] = world.core_position(h)
            rows += 1
    path = trajectory[:rows].copy()
    path.setflags(write=False)
    return path, reason


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
    with World((config if config is not None else WorldConfig()).with_engine("mujoco")) as world:
        world.add_robot(robot, start.position, start.yaw)
        return world.to_mjcf()
