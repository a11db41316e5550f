"""A population env's living robots: their private bookkeeping, kept from birth to last report.

One :class:`Member` per robot of :class:`revolve_env.envs.population.PopulationEnv`. Positions
are in metres, ages and times in control periods (steps) unless named in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.parts import sensor_bounds
from revolve_env.body.robot import Robot
from revolve_env.conditions import add_sensor_noise
from revolve_env.fitness import FitnessTerms

__all__ = ["NO_TERMS", "Controller", "Dicts", "Lifetimes", "Member", "Report", "noise_generator",
           "sensor_bounds"]

Controller = Literal["brain", "agent"]
NO_TERMS = FitnessTerms(0.0, 0.0, 0.0)
Dicts = tuple[dict[str, NDArray[np.float64]], dict[str, float], dict[str, bool],
              dict[str, bool], dict[str, dict[str, Any]]]
"""The five dicts of a step: observations, rewards, terminations, truncations, infos."""

_NOISE_STREAM = 0x4E015E
"""Tags the noise generator apart from the env's generator of the same reset seed."""


def noise_generator(seed: int | None) -> np.random.Generator:
    """The generator of a population episode's sensor and actuator noise, from its reset seed.

    Apart from the env's own generator (births, headings): turning noise on draws nothing from
    that one, so births and headings stay where they were.
    """
    if seed is None:
        return np.random.default_rng()
    return np.random.default_rng(np.random.SeedSequence([seed, _NOISE_STREAM]))


@dataclass(frozen=True)
class Lifetimes:
    """The env's clock and life phases, in control periods (``dt`` in seconds)."""

    dt: float  # control period. Seconds
    insertion_steps: int  # not scored before this age
    maturity_steps: int  # mature from this age on


@dataclass(eq=False)
class Member:
    """A living robot's bookkeeping that changes only at birth and death (private, mutable).

    What changes every step (sensor values, observation, position, trajectory, fitness) is in
    :class:`~revolve_env.envs.living.Living`, one row per robot.
    """

    agent: str
    robot: Robot
    controlled_by: Controller
    handle: int  # world handle
    brain: int | None  # BatchController handle (brain-controlled robots)
    birth_step: int
    birth_time: float  # birth_step control periods. Seconds
    birth_position: tuple[float, float]
    born_inside: bool  # placed in the birth disc (False: the disc was crowded)
    yaw: float
    radius: float  # footprint radius, metres
    blow_up: str | None = None
    n_outputs: int = 0  # active hinges
    padded: bool = False  # observed and driven through the uniform spaces
    # Bounds that noisy sensor values are clipped to (sensor_bounds of the robot).
    sensor_low: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    sensor_high: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    final: Any = None  # Living's Final record once the robot left the world

    def sense(self, values: NDArray[np.float64], noise: float,
              rng: np.random.Generator) -> NDArray[np.float64]:
        """Sensor values as this robot reads them: noisy as ``add_sensor_noise`` makes them."""
        return add_sensor_noise(values, noise, rng, self.sensor_low, self.sensor_high)


class Report:
    """The five dicts of a step, filled agent by agent."""

    def __init__(self) -> None:
        self.obs: dict[str, NDArray[np.float64]] = {}
        self.rewards: dict[str, float] = {}
        self.terminations: dict[str, bool] = {}
        self.truncations: dict[str, bool] = {}
        self.infos: dict[str, dict[str, Any]] = {}

    def add(self, agent: str, obs: NDArray[np.float64], reward: float, terminated: bool,
            truncated: bool, info: dict[str, Any]) -> None:
        """Report one agent in all five dicts."""
        self.obs[agent] = obs
        self.rewards[agent] = reward
        self.terminations[agent] = terminated
        self.truncations[agent] = truncated
        self.infos[agent] = info

    def dicts(self) -> Dicts:
        """The five dicts, as ``step`` returns them."""
        return self.obs, self.rewards, self.terminations, self.truncations, self.infos
