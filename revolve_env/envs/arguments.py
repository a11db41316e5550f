"""The population env's constructor arguments: its options record, checked, and the world settings.

:class:`PopulationOptions` is the env's own options (births, rendering, placement, trajectories,
spaces, lifecycle, episode length) as one frozen record, as :class:`~revolve_env.setting.Setting`
is where and how its robots are simulated; ``PopulationEnv(..., **keywords)`` builds both from
keywords (:class:`PopulationKeywords`, :func:`split_keywords`). Apart from
:mod:`revolve_env.envs.population` so that the env's module stays a readable size.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal, TypedDict

from revolve_env.body.validate import Limits
from revolve_env.conditions import EvaluationConditions
from revolve_env.envs.agent_spaces import SpaceMode
from revolve_env.tasks import Task
from revolve_env.terrain import Heightfield, Terrain
from revolve_env.world import WorldConfig, with_engine

__all__ = ["PopulationKeywords", "PopulationOptions", "check_arguments", "max_cycles_of",
           "split_keywords", "world_config_of"]


@dataclass(frozen=True, slots=True)
class PopulationOptions:
    """The population env's own options (not where robots are simulated: that is the setting).

    Checked when made (ValueError or TypeError naming the option). The module doc of
    :mod:`revolve_env.envs.population` has the table (Arguments).

    Attributes:
        max_births: Size of ``possible_agents``: the ids 0 .. max_births - 1.
        render_view: ``"top"`` (straight down) or ``"chase"`` (oblique), whole arena.
        render_size: Image width and height. Pixels.
        maturity_age: Age from which ``is_mature`` holds. Seconds.
        birth_radius: Random births lie within this distance of the origin. Metres.
        birth_clearance: Gap kept between footprints at birth. Metres.
        max_placement_tries: Random draws in the birth disc before placing outside it.
        trajectory_stride: Control periods between trajectory samples.
        trajectory_length: Samples of its trajectory kept per robot, its latest (0: none);
            None: its whole life.
        max_cycles: Truncate every robot after this many steps (None: never).
        limits: Validation limits and the sizes of the uniform spaces (None: Table 1).
        space_mode: ``"exact"`` or ``"uniform"``.
        proprioception: Observe hinge angles and velocities.
        lifecycle: ``lifecycle(env, k)``: births and deaths inside step ``k``.
        reset_noise_scale: Half-width of the uniform noise on newborns' hinge start angles
            (rad) and speeds (rad/s); None: the conditions' when given, else 0.1.
    """

    max_births: int = 1000
    render_view: Literal["top", "chase"] = "top"
    render_size: tuple[int, int] = (480, 360)
    maturity_age: float = 15.0
    birth_radius: float = 2.0
    birth_clearance: float = 0.02
    max_placement_tries: int = 200
    trajectory_stride: int = 1
    trajectory_length: int | None = None
    max_cycles: int | None = None
    limits: Limits | None = None
    space_mode: SpaceMode = "exact"
    proprioception: bool = False
    lifecycle: Callable[[Any, int], None] | None = None
    reset_noise_scale: float | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.max_births, int) and self.max_births >= 1):
            raise ValueError(f"max_births must be an integer >= 1, got {self.max_births!r}")
        if self.render_view not in ("top", "chase"):
            raise ValueError(f"render_view must be 'top' or 'chase', got {self.render_view!r}")
        if len(self.render_size) != 2 or min(self.render_size) < 1:
            raise ValueError(f"render_size must be (width, height) in pixels, got "
                             f"{self.render_size!r}")
        for name in ("maturity_age", "birth_radius", "birth_clearance"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value}")
        if self.max_placement_tries < 1:
            raise ValueError(f"max_placement_tries must be >= 1, got {self.max_placement_tries}")
        if self.trajectory_stride < 1:
            raise ValueError(f"trajectory_stride must be >= 1, got {self.trajectory_stride}")
        length = self.trajectory_length
        if length is not None and (isinstance(length, bool) or not (
                isinstance(length, int) and length >= 0)):
            raise ValueError(f"trajectory_length must be an integer >= 0 or None, got "
                             f"{length!r}")
        cycles = self.max_cycles
        if cycles is not None and not (isinstance(cycles, int) and cycles >= 1):
            raise ValueError(f"max_cycles must be an integer >= 1 or None, got {cycles!r}")
        if self.space_mode not in ("exact", "uniform"):
            raise ValueError(f"space_mode must be 'exact' or 'uniform', got {self.space_mode!r}")
        if self.lifecycle is not None and not callable(self.lifecycle):
            raise TypeError(f"lifecycle must be callable as lifecycle(env, step), got "
                            f"{type(self.lifecycle).__name__}")


class PopulationKeywords(TypedDict, total=False):
    """The keywords of ``PopulationEnv`` (and ``population_env``) beside its parameters.

    Those named as :class:`PopulationOptions`' fields change that option; the others change a
    part of the setting (insertion, fitness window, world, task, conditions); ``max_steps`` is
    the deprecated name of ``max_cycles``.
    """

    max_births: int
    render_view: Literal["top", "chase"]
    render_size: tuple[int, int]
    maturity_age: float
    birth_radius: float
    birth_clearance: float
    max_placement_tries: int
    trajectory_stride: int
    trajectory_length: int | None
    max_cycles: int | None
    limits: Limits | None
    space_mode: SpaceMode
    proprioception: bool
    lifecycle: Callable[[Any, int], None] | None
    reset_noise_scale: float | None
    max_steps: int | None
    insertion_time: float | None
    fitness_window: float | None
    control_period: float | None
    world_config: WorldConfig | None
    engine: str | None
    conditions: EvaluationConditions | None
    task: Task | str | Mapping[str, Any] | None
    terrain: Terrain | str | Mapping[str, Any] | None


_OPTIONS = frozenset(field.name for field in dataclasses.fields(PopulationOptions))


def split_keywords(keywords: Mapping[str, Any], what: str
                   ) -> tuple[dict[str, Any], dict[str, Any]]:
    """``keywords`` as (the options' among them, the rest); an unknown one is a TypeError."""
    known = PopulationKeywords.__annotations__
    for name in keywords:
        if name not in known:
            raise TypeError(f"{what}() got an unexpected keyword argument {name!r}")
    return ({k: v for k, v in keywords.items() if k in _OPTIONS},
            {k: v for k, v in keywords.items() if k not in _OPTIONS})


def check_arguments(render_mode: str | None, insertion_time: float, fitness_window: float,
                    conditions: object) -> None:
    """Refuse bad constructor arguments beside the options, by name."""
    if not isinstance(conditions, EvaluationConditions):
        raise TypeError(f"conditions must be an EvaluationConditions, got "
                        f"{type(conditions).__name__}")
    if render_mode is not None and render_mode != "rgb_array":
        raise ValueError(f"render_mode must be 'rgb_array' or None, got {render_mode!r}")
    if not (math.isfinite(insertion_time) and insertion_time >= 0):
        raise ValueError(f"insertion_time must be a finite number >= 0, got {insertion_time}")
    if not (math.isfinite(fitness_window) and fitness_window > 0):
        raise ValueError(f"fitness_window must be a positive number of seconds, got "
                         f"{fitness_window}")


def max_cycles_of(max_cycles: int | None, max_steps: int | None) -> int | None:
    """The episode length: ``max_cycles``, or ``max_steps`` (its deprecated old name)."""
    if max_steps is None:
        return max_cycles
    if max_cycles is not None and max_cycles != max_steps:
        raise ValueError(f"max_steps is the deprecated name of max_cycles: give one, got "
                         f"max_cycles={max_cycles} and max_steps={max_steps}")
    warnings.warn("population_env(max_steps=...) is deprecated: use max_cycles (PettingZoo's "
                  "name)", DeprecationWarning, stacklevel=3)
    return max_steps


def world_config_of(world_config: WorldConfig | None, control_period: float | None,
                  engine: str | None, terrain: Terrain | str | Mapping[str, Any] | None,
                  birth_radius: float) -> WorldConfig:
    """``world_config`` with the period, engine, terrain given (TerrainError: birth disc off it)."""
    config = world_config if world_config is not None else WorldConfig()
    if control_period is not None:  # replace() validates it against the timestep
        config = dataclasses.replace(config, control_period=control_period)
    config = with_engine(config, engine).with_terrain(terrain)
    if isinstance(config.terrain, Heightfield):
        config.terrain.check_disc(birth_radius, "the birth disc: birth_radius")
    return config
