"""Tasks a user would write (importable by dotted path: ``user_tasks:Sideways``)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from revolve_env.fitness import Window
from revolve_env.tasks import BaseTask, Locomotion


@dataclass(frozen=True)
class Sideways(BaseTask):
    """Distance covered across the x axis (either way), scaled. Metres."""

    scale: float = 1.0

    def fitness(self, window: Window) -> NDArray[np.float64]:
        out: NDArray[np.float64] = self.scale * np.abs(window.end[:, 1] - window.start[:, 1])
        return out


@dataclass(frozen=True)
class Straighter(Locomotion):
    """A shipped task subclassed: stored under its own dotted path, not the shipped name."""

    s_weight: float = 10.0


@dataclass(frozen=True)
class AliveBonus(BaseTask):
    """The paper's fitness, but every control step earns a reward of 1 (a custom reward)."""

    def fitness(self, window: Window) -> NDArray[np.float64]:
        out: NDArray[np.float64] = window.v + 5.0 * window.s
        return out

    def reward(self, window: Window, fitness: NDArray[np.float64],
               previous: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.ones_like(fitness)


class NoFitness:
    """Not a task: it has a name and nothing else."""

    name = "no-fitness"


@dataclass
class Mutable:
    """A task that follows the protocol but is not hashable (a plain dataclass): refused."""

    name = "user_tasks:Mutable"
    signal = None

    def fitness(self, window: Window) -> NDArray[np.float64]:
        return window.v

    def reward(self, window: Window, fitness: NDArray[np.float64],
               previous: NDArray[np.float64]) -> NDArray[np.float64]:
        return fitness - previous

    def to_dict(self) -> dict[str, str]:
        return {"name": self.name}


@dataclass(frozen=True)
class Smell(BaseTask):
    """Asks for a signal the world does not have."""

    signal = "smell"

    def fitness(self, window: Window) -> NDArray[np.float64]:
        return window.v
