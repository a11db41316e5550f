"""Random robots of the evolution's own generator for the compiled-rules tests, shared.

Usage::

    from random_robots import has_sensors, random_robots
"""

from __future__ import annotations

import numpy as np

from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env.body.robot import Robot
from revolve_env.world import build_model
from revolve_env.world.model import LightSensorModel


def random_robots(n: int, seed: int) -> list[Robot]:
    """``n`` random robots (default :class:`EvolutionConfig`) drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    return [random_robot(rng, EvolutionConfig()) for _ in range(n)]


def has_sensors(robots: list[Robot]) -> None:
    """Assert touch sensors and light sensors on the core and on moving links, among ``robots``."""
    models = [build_model(r) for r in robots]
    lights = [s for m in models for _, s in m.sensors if isinstance(s, LightSensorModel)]
    assert any(s.link > 0 for s in lights) and any(s.link == 0 for s in lights)
    assert any(kind == "touch" for m in models for kind, _ in m.sensors)
