"""The population env's constructor arguments checked, and the world settings they give.

Apart from :mod:`revolve_env.envs.population` so that the env's module stays a readable size; the
env is their only user.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Mapping
from typing import Any

from revolve_env.conditions import EvaluationConditions
from revolve_env.terrain import Heightfield, Terrain
from revolve_env.world import WorldConfig, with_engine

__all__ = ["check_arguments", "max_cycles_of", "world_config_of"]


def check_arguments(max_births: int, render_mode: str | None, render_view: str,
                    render_size: tuple[int, int], times: dict[str, float],
                    fitness_window: float, max_placement_tries: int, trajectory_stride: int,
                    max_cycles: int | None, space_mode: str, lifecycle: object,
                    conditions: object) -> None:
    """Refuse bad constructor arguments (``times``: the ones that must be >= 0) by name."""
    if not isinstance(conditions, EvaluationConditions):
        raise TypeError(f"conditions must be an EvaluationConditions, got "
                        f"{type(conditions).__name__}")
    if not (isinstance(max_births, int) and max_births >= 1):
        raise ValueError(f"max_births must be an integer >= 1, got {max_births!r}")
    if render_mode is not None and render_mode != "rgb_array":
        raise ValueError(f"render_mode must be 'rgb_array' or None, got {render_mode!r}")
    if render_view not in ("top", "chase"):
        raise ValueError(f"render_view must be 'top' or 'chase', got {render_view!r}")
    if len(render_size) != 2 or min(render_size) < 1:
        raise ValueError(f"render_size must be (width, height) in pixels, got {render_size!r}")
    for name, value in times.items():
        if not (math.isfinite(value) and value >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {value}")
    if not (math.isfinite(fitness_window) and fitness_window > 0):
        raise ValueError(f"fitness_window must be a positive number of seconds, got "
                         f"{fitness_window}")
    if max_placement_tries < 1:
        raise ValueError(f"max_placement_tries must be >= 1, got {max_placement_tries}")
    if trajectory_stride < 1:
        raise ValueError(f"trajectory_stride must be >= 1, got {trajectory_stride}")
    if max_cycles is not None and not (isinstance(max_cycles, int) and max_cycles >= 1):
        raise ValueError(f"max_cycles must be an integer >= 1 or None, got {max_cycles!r}")
    if space_mode not in ("exact", "uniform"):
        raise ValueError(f"space_mode must be 'exact' or 'uniform', got {space_mode!r}")
    if lifecycle is not None and not callable(lifecycle):
        raise TypeError(f"lifecycle must be callable as lifecycle(env, step), got "
                        f"{type(lifecycle).__name__}")


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
