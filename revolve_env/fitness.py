"""Locomotion fitness ``f = v + 5 s`` over a sliding time window (pure NumPy).

The one implementation used by the single-robot env, :func:`revolve_env.evaluate`, the population
env and evolution (Revolve paper, section 4): over the last ``window`` seconds (12 s by default),

* ``v`` is the length of the path travelled by the core in the horizontal plane (metres),
* ``s`` is the straight horizontal distance between the core's positions at the start and the end
  of the window (metres),
* ``f = v + s_weight * s`` with ``s_weight = 5``.

:func:`fitness_terms` works on a whole trajectory, :func:`window_fitness` on the last ``window``
seconds of a time-stamped one, and :class:`SlidingWindowFitness` keeps a ring buffer of
time-stamped samples for online use; all three share the same arithmetic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DEFAULT_S_WEIGHT",
    "DEFAULT_WINDOW",
    "FitnessTerms",
    "SlidingWindowFitness",
    "fitness_terms",
    "window_fitness",
]

DEFAULT_WINDOW = 12.0
"""Length of the fitness window. Seconds."""

DEFAULT_S_WEIGHT = 5.0
"""Weight of the straight-line displacement ``s`` in ``f = v + 5 s``."""

_TIME_EPS = 1e-9  # seconds: samples this close to the window's start still belong to it


@dataclass(frozen=True, slots=True)
class FitnessTerms:
    """Fitness and its terms.

    Attributes:
        fitness: ``v + s_weight * s``. Metres.
        v: Horizontal path length of the core over the window. Metres.
        s: Horizontal distance between the core's first and last positions in the window. Metres.
    """

    fitness: float
    v: float
    s: float


def _horizontal(positions: ArrayLike) -> NDArray[np.float64]:
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise ValueError(f"positions must have shape (T, 2) or (T, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError("positions contain NaN or infinity")
    return p[:, :2]


def fitness_terms(positions: ArrayLike, s_weight: float = DEFAULT_S_WEIGHT) -> FitnessTerms:
    """Fitness of a whole trajectory of core positions.

    Args:
        positions: Shape (T, 3) or (T, 2), metres; only x and y are used. T may be 0 or 1
            (fitness 0).
        s_weight: Weight of ``s``.
    """
    xy = _horizontal(positions)
    if len(xy) < 2:
        return FitnessTerms(0.0, 0.0, 0.0)
    steps = np.diff(xy, axis=0)
    v = float(np.sum(np.hypot(steps[:, 0], steps[:, 1])))
    s = float(math.hypot(*(xy[-1] - xy[0])))
    return FitnessTerms(v + s_weight * s, v, s)


def window_fitness(
    times: ArrayLike, positions: ArrayLike, window: float = DEFAULT_WINDOW,
    s_weight: float = DEFAULT_S_WEIGHT,
) -> FitnessTerms:
    """Fitness over the samples of the last ``window`` seconds (``t >= t_last - window``).

    Args:
        times: Non-decreasing sample times, shape (T,). Seconds.
        positions: Core positions, shape (T, 3) or (T, 2). Metres.
        window: Window length. Seconds.
        s_weight: Weight of ``s``.
    """
    t = np.asarray(times, dtype=np.float64).reshape(-1)
    xy = _horizontal(positions)
    if len(t) != len(xy):
        raise ValueError(f"{len(t)} times but {len(xy)} positions")
    if not window > 0:
        raise ValueError(f"window must be positive, got {window} s")
    if len(t) == 0:
        return FitnessTerms(0.0, 0.0, 0.0)
    if np.any(np.diff(t) < 0):
        raise ValueError("times must be non-decreasing")
    first = int(np.searchsorted(t, t[-1] - window - _TIME_EPS, side="left"))
    return fitness_terms(xy[first:], s_weight)


class SlidingWindowFitness:
    """Fitness over a sliding window of time-stamped core positions (online, ring buffer).

    ``add(t, position)`` appends a sample; ``terms()`` gives the fitness over the samples with
    ``t >= t_last - window``, as :func:`window_fitness` on the same samples (to rounding: the path
    length is kept as a running sum, so each query costs O(1)). Samples older than the window are
    dropped, so memory stays bounded however long the robot lives.
    """

    def __init__(
        self, window: float = DEFAULT_WINDOW, s_weight: float = DEFAULT_S_WEIGHT,
        capacity: int = 1024,
    ) -> None:
        """A window of ``window`` seconds; ``f = v + s_weight * s``.

        Args:
            window: Window length. Seconds.
            s_weight: Weight of ``s``.
            capacity: Initial ring size (samples); it doubles when a window holds more.
        """
        if not (window > 0 and math.isfinite(window)):
            raise ValueError(f"window must be a positive number of seconds, got {window}")
        if capacity < 2:
            raise ValueError(f"capacity must be >= 2, got {capacity}")
        self.window = float(window)
        self.s_weight = float(s_weight)
        self._t = np.empty(capacity)
        self._xy = np.empty((capacity, 2))
        self._path = np.empty(capacity)  # path length from an arbitrary origin up to each sample
        self._start = 0  # ring index of the oldest kept sample
        self._n = 0

    def __len__(self) -> int:
        """Samples currently in the window."""
        return self._n

    def reset(self) -> None:
        """Forget every sample."""
        self._start = 0
        self._n = 0

    def add(self, t: float, position: ArrayLike) -> None:
        """Append the core's position at time ``t`` (seconds; not before the previous sample)."""
        p = np.asarray(position, dtype=np.float64).reshape(-1)
        if p.shape[0] not in (2, 3) or not (math.isfinite(float(p[0]))
                                            and math.isfinite(float(p[1]))):
            raise ValueError(f"position must be 2 or 3 finite numbers, got {position!r}")
        t = float(t)
        if not math.isfinite(t):
            raise ValueError(f"time must be finite, got {t}")
        x, y = float(p[0]), float(p[1])
        cap = len(self._t)
        path = 0.0
        if self._n:
            last = (self._start + self._n - 1) % cap
            if t < self._t[last]:
                raise ValueError(f"time {t} s is before the previous sample")
            step = math.hypot(x - self._xy[last, 0], y - self._xy[last, 1])
            path = float(self._path[last]) + step
        # Drop samples that left the window (the newest one always stays).
        while self._n and self._t[self._start] < t - self.window - _TIME_EPS:
            self._start = (self._start + 1) % cap
            self._n -= 1
        if self._n == cap:
            self._grow()
            cap = len(self._t)
        i = (self._start + self._n) % cap
        self._t[i] = t
        self._xy[i, 0] = x
        self._xy[i, 1] = y
        self._path[i] = path
        self._n += 1
        if path > 1e3:  # keep the running sum small so that differences stay exact to ~1e-13 m
            self._path -= self._path[self._start]

    def _grow(self) -> None:
        idx = (self._start + np.arange(self._n)) % len(self._t)
        t, xy, path = self._t[idx], self._xy[idx], self._path[idx]
        cap = 2 * len(self._t)
        self._t, self._xy, self._path = np.empty(cap), np.empty((cap, 2)), np.empty(cap)
        self._t[: len(t)] = t
        self._xy[: len(t)] = xy
        self._path[: len(t)] = path
        self._start = 0

    def snapshot(self) -> dict[str, Any]:
        """The window's samples and settings as plain data (see :meth:`from_snapshot`)."""
        idx = (self._start + np.arange(self._n)) % len(self._t)
        return {"window": self.window, "s_weight": self.s_weight, "capacity": len(self._t),
                "t": self._t[idx], "xy": self._xy[idx], "path": self._path[idx]}

    @classmethod
    def from_snapshot(cls, snapshot: dict[str, Any]) -> SlidingWindowFitness:
        """A window that goes on exactly as the one :meth:`snapshot` was taken of.

        Raises:
            ValueError: inconsistent sample arrays.
        """
        t = np.asarray(snapshot["t"], dtype=np.float64).reshape(-1)
        xy = np.asarray(snapshot["xy"], dtype=np.float64).reshape(-1, 2)
        path = np.asarray(snapshot["path"], dtype=np.float64).reshape(-1)
        n = len(t)
        if len(xy) != n or len(path) != n:
            raise ValueError("a fitness window snapshot needs as many positions and path lengths "
                             "as times")
        window = cls(float(snapshot["window"]), float(snapshot["s_weight"]),
                     max(int(snapshot["capacity"]), n, 2))
        window._t[:n], window._xy[:n], window._path[:n] = t, xy, path
        window._n = n
        return window

    def samples(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Times (T,) and horizontal positions (T, 2) in the window, oldest first (copies)."""
        idx = (self._start + np.arange(self._n)) % len(self._t)
        return self._t[idx], self._xy[idx]

    def terms(self) -> FitnessTerms:
        """Fitness and its terms over the current window."""
        if self._n < 2:
            return FitnessTerms(0.0, 0.0, 0.0)
        first = self._start
        last = (self._start + self._n - 1) % len(self._t)
        v = float(self._path[last] - self._path[first])
        s = math.hypot(self._xy[last, 0] - self._xy[first, 0],
                       self._xy[last, 1] - self._xy[first, 1])
        return FitnessTerms(v + self.s_weight * s, v, s)

    @property
    def fitness(self) -> float:
        """``v + s_weight * s`` over the current window. Metres."""
        return self.terms().fitness
