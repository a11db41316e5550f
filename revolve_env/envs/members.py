"""A population env's robots: what is fixed at a birth, and the env's one clock of their lives.

One :class:`Member` per living robot of :class:`revolve_env.envs.population.PopulationEnv`,
keyed by its robot id (:mod:`revolve_env.status`); its world handle and controller handle are
private to the env. :class:`LifeClock` counts every robot's age in control periods: the one
clock of insertion and maturity (the experiments' lifecycle reads it from the robots'
statuses). Positions are in metres, times in seconds unless named in steps.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.parts import sensor_bounds
from revolve_env.body.robot import Robot
from revolve_env.conditions import add_sensor_noise

__all__ = ["Controller", "Final", "LifeClock", "Member", "noise_generator", "sensor_bounds"]

Controller = Literal["brain", "agent"]

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
class LifeClock:
    """The env's clock of a robot's life, in control periods (seconds are derived).

    Attributes:
        dt: The control period. Seconds.
        insertion_steps: Not scored before this age (the insertion phase).
        maturity_steps: Mature from this age on.
    """

    dt: float
    insertion_steps: int
    maturity_steps: int

    @classmethod
    def of(cls, dt: float, insertion: float, maturity: float) -> LifeClock:
        """The clock of ``insertion`` and ``maturity`` seconds (rounded to whole periods)."""
        return cls(float(dt), round(insertion / dt), round(maturity / dt))  # ages x dt: floats


@dataclass
class Final:
    """What a robot that left the world last was (reported once more, and snapshot until then)."""

    obs: NDArray[np.float64]
    view: NDArray[np.float64]
    position: NDArray[np.float64]
    terms: tuple[float, float, float]
    age_steps: int
    trajectory: NDArray[np.float64]
    trajectory_room: int
    fitness: dict[str, Any]


@dataclass(eq=False)
class Member:
    """A living robot's bookkeeping that changes only at birth and death (private, mutable).

    What changes every step (sensor values, observation, position, trajectory, fitness) is in
    :class:`~revolve_env.envs.living.Living`, one row per robot.
    """

    robot_id: int
    agent: str  # its PettingZoo name, agent_name(robot_id), kept to key the five dicts
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
    final: Final | None = None  # its last state once it left the world

    def sense(self, values: NDArray[np.float64], noise: float,
              rng: np.random.Generator) -> NDArray[np.float64]:
        """Sensor values as this robot reads them: noisy as ``add_sensor_noise`` makes them."""
        return add_sensor_noise(values, noise, rng, self.sensor_low, self.sensor_high)
