"""How many robots an online world holds over a run: what the study's estimate assumes.

An online birth costs about (robots alive) x (conception interval) robot-seconds, and the robots
alive change over a run. The online survivor rule (:func:`evolution.selection.online_survivors`,
applied by the loop at every conception tick) bounds them, whatever the robots do
(:func:`rule_bounds`, the rule itself run on two populations):

* **floor**: fitness spread so widely that every selection kills all it may (robots below
  ``death_threshold`` of the mean at every tick, as among random robots): ``min_alive`` mature
  robots plus the ticks' newborns (scenario 3: 9);
* **ceiling**: fitness so alike that nobody ever falls below the bar: one more robot every
  tick until ``max_alive``, where ``cull_fraction`` of them die, a sawtooth (scenario 3: 10 to
  30, mean 20).

Where a run lies between them is set by how far its population's fitness has converged, which
nothing before the run measures: a world starts at its floor (the calibration measures it over
its first conception intervals) and grows only at ticks where no mature robot is below the bar,
which become common as its fitness converges. :class:`WorldGrowth` is that trajectory in births:
the measured start until :data:`ONSET` births, then ``1 - exp(-(b - ONSET) / SCALE)`` of the way
to the rule's ceiling. ``ONSET`` and ``SCALE`` are fitted on the one long scenario 3 run measured
(MuJoCo, seed 0, 1,889 births; docs/performance.md, "The online world's growth in the study's
estimate", 2026-11-27): the figures of the estimate not derived from the config, with their error
stated there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from evolution.experiments.loop.config import ExperimentConfig
from evolution.selection import online_survivors

__all__ = ["ONSET", "SCALE", "WorldGrowth", "rule_bounds", "world_growth"]

ONSET = 600.0
"""Births an online world stays at its start. Births.

Scenario 3 on MuJoCo, seed 0: its world held 9-11 robots (9.3 on average) over its first 600
births."""
SCALE = 510.0
"""Births over which it then closes 63 % of the way to the rule's ceiling. Births.

Fitted: the same run averaged 13.8 robots alive over 1,889 births (the curve from 9.0 at its
start to scenario 3's ceiling of 20 gives 13.8 with 510)."""

_WARM, _TICKS = 100, 2000
"""Conception ticks the rule is run before its mean is taken (from the initial robots), and
ticks it is averaged over for :func:`rule_bounds` (about 95 of scenario 3's 21-tick sawtooths:
within 0.03 robots of its exact mean)."""


def _mean_alive(config: ExperimentConfig, alike: bool) -> float:
    """The loop's survivor rule and births, tick by tick: the mean robots alive after a birth.

    As :meth:`~evolution.experiments.loop.online.OnlineMode._tick`: select among the mature (a
    robot born ``k`` ticks ago is ``k`` conception intervals old), the immature counted in the
    bounds; conceive up to ``min_alive``; then one birth. ``alike``: equal fitness (nobody below
    the bar); else one robot far fitter than the rest (all others below it).
    """
    interval = config.conception_interval
    born: list[int] = [0] * config.population_size  # the tick each living robot was born at
    total = 0
    for tick in range(1, _WARM + _TICKS + 1):
        mature = [i for i, t in enumerate(born)
                  if (tick - t) * interval >= config.fertile_age - 1e-9]
        spared = len(born) - len(mature)
        if mature:
            fitness = np.ones(len(mature)) if alike else np.eye(1, len(mature))[0]
            floor = max(0, config.min_alive - spared)
            doomed = online_survivors(fitness, min_alive=floor,
                                      max_alive=max(floor, config.max_alive - spared),
                                      threshold=config.death_threshold,
                                      cull_fraction=config.cull_fraction)
            dead = {mature[int(i)] for i in doomed}
            born = [t for i, t in enumerate(born) if i not in dead]
        born += [tick] * max(0, config.min_alive - len(born))
        born.append(tick)
        if tick > _WARM:
            total += len(born)
    return total / _TICKS


def rule_bounds(config: ExperimentConfig) -> tuple[float, float]:
    """The mean robots alive an online run's survivor rule allows: ``(floor, ceiling)``.

    Derived from ``min_alive``, ``max_alive``, ``death_threshold``, ``cull_fraction``,
    ``conception_interval`` and ``fertile_age`` alone (see the module docs). Robots.
    """
    return _mean_alive(config, alike=False), _mean_alive(config, alike=True)


@dataclass(frozen=True, slots=True)
class WorldGrowth:
    """The robots alive in an online world at each of a run's births (see the module docs).

    Attributes:
        start: Robots alive at the run's start (measured by the calibration). Robots.
        ceiling: The survivor rule's ceiling (:func:`rule_bounds`). Robots.
        onset: Births before the world grows. Births.
        scale: Births over which it closes 63 % of the way to ``ceiling``. Births.
    """

    start: float
    ceiling: float
    onset: float = ONSET
    scale: float = SCALE

    def alive(self, birth: float) -> float:
        """Robots alive in the conception interval after ``birth`` births. Robots."""
        if birth <= self.onset or self.ceiling <= self.start:
            return self.start
        return self.start + (self.ceiling - self.start) * -math.expm1(
            -(birth - self.onset) / self.scale)

    def mean_alive(self, first: float, last: float) -> float:
        """The mean of :meth:`alive` over births ``[first, last)`` (``start`` if empty). Robots.

        The exact integral of the curve, in closed form (the mean of its values at a run's
        births, one conception interval each, differs from it by under 0.1 % at a scale of
        hundreds of births).
        """
        if last <= first:
            return self.start
        rise = max(0.0, self.ceiling - self.start)

        def grown(b: float) -> float:  # the integral of the rise's fraction from onset to b
            x = max(0.0, b - self.onset)
            return x + self.scale * math.expm1(-x / self.scale)

        return self.start + rise * (grown(last) - grown(first)) / (last - first)


def world_growth(config: ExperimentConfig, start: float) -> WorldGrowth:
    """The growth of ``config``'s online world from the ``start`` measured by the calibration."""
    return WorldGrowth(start, _mean_alive(config, alike=True))
