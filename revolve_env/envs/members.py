"""A population env's living robots: their private, mutable bookkeeping and their info dicts.

One :class:`Member` per robot of :class:`revolve_env.envs.population.PopulationEnv`, from its
birth to its last report. Positions are in metres, ages and times in control periods (steps)
unless named in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.parts import sensor_bounds
from revolve_env.body.robot import Robot
from revolve_env.conditions import add_sensor_noise
from revolve_env.fitness import FitnessTerms, SlidingWindowFitness

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
    """A living robot (private, mutable bookkeeping)."""

    agent: str
    robot: Robot
    controlled_by: Controller
    handle: int  # world handle
    brain: int | None  # BatchController handle (brain-controlled robots)
    birth_step: int
    birth_position: tuple[float, float]
    born_inside: bool  # placed in the birth disc (False: the disc was crowded)
    yaw: float
    radius: float  # footprint radius, metres
    obs: NDArray[np.float64]
    position: NDArray[np.float64]  # core centre after the last step (last finite one), metres
    fitness: SlidingWindowFitness
    terms: FitnessTerms = NO_TERMS
    age_steps: int = 0
    trajectory: NDArray[np.float64] = field(default_factory=lambda: np.empty((64, 3)))
    n_trajectory: int = 0
    blow_up: str | None = None
    in_slice: slice = field(default_factory=lambda: slice(0, 0))
    out_slice: slice = field(default_factory=lambda: slice(0, 0))
    n_outputs: int = 0  # active hinges
    padded: bool = False  # observed and driven through the uniform spaces
    view: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))  # what the agent sees
    # Bounds that noisy sensor values are clipped to (sensor_bounds of the robot).
    sensor_low: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    sensor_high: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))

    def sense(self, values: NDArray[np.float64], noise: float,
              rng: np.random.Generator) -> None:
        """Take fresh sensor values as :attr:`obs`, noisy as ``add_sensor_noise`` makes them."""
        self.obs = add_sensor_noise(values, noise, rng, self.sensor_low, self.sensor_high)

    def record(self, position: NDArray[np.float64]) -> None:
        """Append a core position to the trajectory (grown by doubling)."""
        if self.n_trajectory == len(self.trajectory):
            grown = np.empty((2 * len(self.trajectory), 3))
            grown[: self.n_trajectory] = self.trajectory
            self.trajectory = grown
        self.trajectory[self.n_trajectory] = position
        self.n_trajectory += 1

    def blow(self) -> None:
        """The simulation blew up: zero observations, no fitness (the robot is to be dropped)."""
        self.obs = np.zeros_like(self.obs)
        self.view = np.zeros_like(self.view)
        self.terms = NO_TERMS

    def info(self, life: Lifetimes, death: str | None,
             masks: tuple[NDArray[np.bool_], NDArray[np.bool_]]) -> dict[str, Any]:
        """The info dict of this robot (see the env's class doc, Info)."""
        dt = life.dt
        trajectory = self.trajectory[: self.n_trajectory]
        trajectory.flags.writeable = False
        return {
            "age": self.age_steps * dt,
            "birth_time": self.birth_step * dt,
            "birth_position": self.birth_position,
            "born_inside_disc": self.born_inside,
            "inserting": self.age_steps < life.insertion_steps,
            "is_mature": self.age_steps >= life.maturity_steps,
            "fitness": self.terms.fitness,
            "fitness_v": self.terms.v,
            "fitness_s": self.terms.s,
            "position": self.position.copy(),
            "trajectory": trajectory,
            "controlled_by": self.controlled_by,
            "blow_up": self.blow_up,
            "death": death,
            "obs_mask": masks[0],
            "act_mask": masks[1],
        }


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
