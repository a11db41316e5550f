"""Task signals: what a task (:mod:`revolve_env.tasks`) may ask a world to measure per robot.

A reader is made for the robots of a world as laid out now (rebuilt at every birth and death,
like the world's own index arrays) and gives every robot's value with array operations, one
per robot in the world's row order. Readers read the world, never change it, and see no noise
(a task scores the physics, not a robot's perception of it). :data:`READERS` has one reader
per name of :data:`revolve_env.tasks.SIGNALS`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from revolve_env.body.parts import light_inputs
from revolve_env.body.robot import Robot
from revolve_env.tasks import SIGNALS
from revolve_env.world.config import WorldConfig
from revolve_env.world.sensing import light_falloff
from revolve_env.world.world import World

__all__ = ["READERS", "LightSignal", "SignalReader", "signal_reader"]


class SignalReader(Protocol):
    """Reads one signal of every robot of a world (rows: the world's)."""

    def read(self, world: World) -> NDArray[np.float64]:
        """The signal of every robot now, shape (n,)."""


class LightSignal:
    """``"light"``: each robot's brightest light-sensor reading, else the light at its core.

    Args:
        robots: The world's robots, in its row order.
        input_offsets: Where each robot's sensor values start in the world's flat array
            (:attr:`World.input_offsets`).
        config: The world's settings (the light's position and range).
    """

    def __init__(self, robots: Sequence[Robot], input_offsets: NDArray[np.intp],
                 config: WorldConfig) -> None:
        entries: list[NDArray[np.intp]] = []
        starts: list[int] = []
        rows: list[int] = []
        k = 0
        for row, robot in enumerate(robots):
            local = light_inputs(robot)
            if local.size:
                rows.append(row)
                starts.append(k)
                entries.append(int(input_offsets[row]) + local)
                k += local.size
        self._entries = (np.concatenate(entries) if entries else np.zeros(0, dtype=np.intp))
        self._starts = np.array(starts, dtype=np.intp)
        self._rows = np.array(rows, dtype=np.intp)
        self._light = np.asarray(config.light_position, dtype=np.float64)
        self._range = float(config.light_range)

    def read(self, world: World) -> NDArray[np.float64]:
        """Every robot's reading: dimensionless, in [0, 1]."""
        out = light_falloff(world.states.core_pos, self._light, self._range)
        if self._rows.size:
            values = world.sensor_values()[self._entries]
            out[self._rows] = np.maximum.reduceat(values, self._starts)
        return out


READERS = {"light": LightSignal}
"""Signal name -> its reader class (made from the robots, their input offsets and the config)."""
assert set(READERS) == set(SIGNALS), "every task signal needs a reader here"


def signal_reader(name: str | None, robots: Sequence[Robot], world: World
                  ) -> SignalReader | None:
    """The reader of signal ``name`` for ``world``'s robots as laid out now (None: no signal)."""
    if name is None:
        return None
    return READERS[name](robots, world.input_offsets, world.config)
