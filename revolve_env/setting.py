"""Where and how robots are simulated: one frozen :class:`Setting`.

A setting is the physics world (engine, terrain, timings: a
:class:`~revolve_env.world.WorldConfig`), the task robots are scored on, the conditions they
start and live under, and the insertion and evaluation times. :func:`revolve_env.evaluate` and
:func:`~revolve_env.evaluate_many` take one (``setting=``); their keywords (``engine=``,
``terrain=``, ``task=``, ...) are a thin convenience that builds it (:meth:`Setting.of`)::

    setting = Setting.of(engine="pybullet", terrain="rugged", timing="revolve2018")
    evaluate(robot, setting, seed=3)         # the same as evaluate(robot, seed=3, engine=...)

The default engine has one home, :data:`DEFAULT_ENGINE` (MuJoCo; defined beside the world's
settings, :mod:`revolve_env.world.config`, whose ``WorldConfig().engine`` it is, and named here for
the layers that do not import the world, such as ``evolution``); every ``engine=None`` means it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, TypedDict

from revolve_env.conditions import IDEAL, EvaluationConditions, with_noise_shortcuts
from revolve_env.tasks import Task, make_task
from revolve_env.terrain import Terrain
from revolve_env.world.config import DEFAULT_ENGINE, WorldConfig
from revolve_env.world.engines import with_engine

__all__ = ["DEFAULT_ENGINE", "Setting", "SettingKeywords", "env_parts"]


class SettingKeywords(TypedDict, total=False):
    """The keywords that build a :class:`Setting` (:meth:`Setting.of`), as ``evaluate`` takes them.

    Each changes one part of the setting it is given (or of ``Setting()``).
    """

    seconds: float
    insertion: float
    config: WorldConfig | None
    engine: str | None
    timing: str | None
    terrain: Terrain | str | Mapping[str, Any] | None
    task: Task | str | Mapping[str, Any] | None
    conditions: EvaluationConditions | None
    sensor_noise: float
    actuator_noise: float


@dataclass(frozen=True, slots=True)
class Setting:
    """Where and how robots are simulated (module docstring); frozen.

    Attributes:
        world: The physics world: engine (``world.engine``, MuJoCo by default), terrain,
            physics step, control and brain periods, servo settings.
        task: What robots are scored on (:mod:`revolve_env.tasks`); the paper's
            :class:`~revolve_env.tasks.Locomotion` by default.
        conditions: Start heading and jitter, sensor and actuator noise, start noise
            (:class:`~revolve_env.conditions.EvaluationConditions`); default
            :data:`~revolve_env.conditions.IDEAL`.
        insertion: Settling time before the fitness window. Seconds.
        seconds: The fitness window (evaluation time after insertion). Seconds.
    """

    world: WorldConfig = field(default_factory=WorldConfig)
    task: Task = field(default_factory=make_task)
    conditions: EvaluationConditions = IDEAL
    insertion: float = 3.0
    seconds: float = 12.0

    def __post_init__(self) -> None:
        if not isinstance(self.world, WorldConfig):
            raise TypeError(f"world must be a WorldConfig, got {type(self.world).__name__}")
        if not isinstance(self.conditions, EvaluationConditions):
            raise TypeError(f"conditions must be an EvaluationConditions, got "
                            f"{type(self.conditions).__name__}")
        object.__setattr__(self, "task", make_task(self.task))
        for name in ("insertion", "seconds"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                    math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value}")
            object.__setattr__(self, name, float(value))

    @property
    def engine(self) -> str:
        """The physics engine's name (``world.engine``)."""
        return self.world.engine

    @property
    def terrain(self) -> Terrain:
        """The ground (``world.terrain``)."""
        return self.world.terrain

    @classmethod
    def of(cls, setting: Setting | None = None, *, seconds: float | None = None,
           insertion: float | None = None, config: WorldConfig | None = None,
           engine: str | None = None, timing: str | None = None,
           terrain: Terrain | str | Mapping[str, Any] | None = None,
           task: Task | str | Mapping[str, Any] | None = None,
           conditions: EvaluationConditions | None = None, sensor_noise: float = 0.0,
           actuator_noise: float = 0.0) -> Setting:
        """``setting`` (None: ``Setting()``) with the parts these keywords name changed.

        Args:
            setting: The setting to start from.
            seconds: The fitness window. Seconds.
            insertion: Settling time before it. Seconds.
            config: The physics world, in place of the setting's (engine, terrain and timing
                below apply on top of it).
            engine: The physics engine (``"mujoco"``, ``"pybullet"``); None keeps the world's.
            timing: A named timing (:data:`~revolve_env.world.config.TIMINGS`); None keeps the
                world's.
            terrain: The ground (:func:`~revolve_env.terrain.make_terrain`); None keeps the
                world's.
            task: What robots are scored on (:func:`~revolve_env.tasks.make_task`); None keeps
                the setting's.
            conditions: The evaluation conditions; None keeps the setting's (or, with a noise
                shortcut below, builds them from it).
            sensor_noise: Shortcut for ``conditions=EvaluationConditions(sensor_noise=...)``;
                not with ``conditions``.
            actuator_noise: Likewise, for the actuator noise.

        Raises:
            ValueError: a bad time or noise, noise given both ways, an unknown engine or timing,
                a bad task (``TaskError``) or terrain (``TerrainError``).
            EngineUnavailableError: the engine's package is not installed.
            TypeError: ``conditions`` or ``config`` of the wrong type.
        """
        base = setting if setting is not None else cls()
        if not isinstance(base, Setting):
            raise TypeError(f"setting must be a Setting, got {type(base).__name__}")
        for name, value in (("sensor_noise", sensor_noise), ("actuator_noise", actuator_noise)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value}")
        if conditions is None and (sensor_noise or actuator_noise):
            conditions = with_noise_shortcuts(None, sensor_noise, actuator_noise)
        elif conditions is not None:
            conditions = with_noise_shortcuts(conditions, sensor_noise, actuator_noise)
        world = config if config is not None else base.world
        if not isinstance(world, WorldConfig):
            raise TypeError(f"config must be a WorldConfig, got {type(world).__name__}")
        world = with_engine(world.with_timing(timing), engine).with_terrain(terrain)
        return dataclasses.replace(
            base, world=world, task=base.task if task is None else make_task(task),
            conditions=base.conditions if conditions is None else conditions,
            insertion=base.insertion if insertion is None else insertion,
            seconds=base.seconds if seconds is None else seconds)


def env_parts(setting: Setting | None, world_config: WorldConfig | None,
              task: Task | str | Mapping[str, Any] | None,
              conditions: EvaluationConditions | None
              ) -> tuple[WorldConfig | None, Task | str | Mapping[str, Any] | None,
                         EvaluationConditions | None]:
    """The world config, task and conditions an env takes: the keywords given, else ``setting``'s.

    The envs' ``setting=`` (``gym.make(..., setting=)``, ``population_env(setting=)``): a
    keyword given beside it changes that part of it, as :meth:`Setting.of` does for
    ``evaluate``; without a setting the keywords are returned as they are (the env's own
    defaults apply).

    Raises:
        TypeError: ``setting`` is not a :class:`Setting`.
    """
    if setting is None:
        return world_config, task, conditions
    if not isinstance(setting, Setting):
        raise TypeError(f"setting must be a Setting, got {type(setting).__name__}")
    return (setting.world if world_config is None else world_config,
            setting.task if task is None else task,
            setting.conditions if conditions is None else conditions)
