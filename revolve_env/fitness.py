"""Locomotion fitness ``f = v + 5 s`` over a sliding time window (pure NumPy).

The one implementation used by the single-robot env, :func:`revolve_env.evaluate`, the population
env and evolution (Revolve paper, section 4): over the last ``window`` seconds (12 s by default),

* ``v`` is the length of the path travelled by the core in the horizontal plane (metres),
* ``s`` is the straight horizontal distance between the core's positions at the start and the end
  of the window (metres),
* ``f = v + s_weight * s`` with ``s_weight = 5``.

:func:`fitness_terms` works on a whole trajectory, :func:`window_fitness` on the last ``window``
seconds of a time-stamped one. Online, :class:`FitnessWindows` keeps the windows of many robots
in one ring buffer (times, core positions and path lengths, one column per robot) and gives
every robot's terms at once with array operations; :class:`SlidingWindowFitness` is one
robot's window in plain floats (cheaper for one robot, and the reference that
``FitnessWindows`` equals bit for bit: ``tests/test_fitness.py``). All share the same
arithmetic.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DEFAULT_S_WEIGHT",
    "DEFAULT_WINDOW",
    "FitnessTerms",
    "FitnessWindows",
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


def _hypot(dx: NDArray[np.float64], dy: NDArray[np.float64]) -> NDArray[np.float64]:
    """``math.hypot`` element by element (CPython's own; the windows have always used it).

    Not the C library's ``np.hypot``: the two differ in the last bit now and then.
    """
    return np.fromiter(map(math.hypot, dx.tolist(), dy.tolist()), np.float64, dx.shape[0])


class FitnessWindows:
    """The sliding fitness windows of many robots, in one ring buffer (online, array-wise).

    A column per robot, a row per sample time: the robots that sample are sampled together
    (every control period of a world), each from its first sample on. :meth:`push` appends the
    core positions of the robots that sample now; :meth:`terms` gives every robot's ``v``,
    ``s`` and ``f = v + s_weight * s`` over its samples with ``t >= t_last - window``, bit for
    bit as :func:`window_fitness` on that robot's samples would (to rounding: the path length is
    a running sum, so each query costs O(1)). Samples older than the window are dropped, so
    memory stays bounded however long the robots live. Columns follow births and deaths
    (:meth:`add`, :meth:`remove`).

    What a task needs per robot is here as arrays: :meth:`ends` (first and last horizontal
    positions in the window, path length between them, samples in the window).
    """

    def __init__(self, window: float = DEFAULT_WINDOW, s_weight: float = DEFAULT_S_WEIGHT,
                 capacity: int = 1024) -> None:
        """Windows of ``window`` seconds; ``f = v + s_weight * s``; no robots yet.

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
        self._xy = np.empty((capacity, 0, 2))
        self._path = np.empty((capacity, 0))  # path length from each robot's first sample
        self._seq = 0  # sequence number of the next sample time (its ring row: seq % capacity)
        self._start = 0  # sequence number of the oldest sample time in the windows
        self._first = np.zeros(0, dtype=np.int64)  # each robot's first sample (_NONE: none)
        self._last = np.zeros(0, dtype=np.int64)  # and last one
        self._cols = np.zeros(0, dtype=np.intp)  # every column

    _NONE: ClassVar[int] = int(np.iinfo(np.int64).max)  # no sample yet

    def __len__(self) -> int:
        """Robots (columns)."""
        return int(self._first.shape[0])

    @property
    def capacity(self) -> int:
        """Sample times the ring holds before it grows."""
        return int(self._t.shape[0])

    # -- robots -------------------------------------------------------------------------------
    def add(self, count: int = 1) -> None:
        """Append ``count`` robots with no samples (they start at their first :meth:`push`)."""
        cap = self.capacity
        self._xy = np.concatenate((self._xy, np.zeros((cap, count, 2))), axis=1)
        self._path = np.concatenate((self._path, np.zeros((cap, count))), axis=1)
        self._first = np.concatenate((self._first, np.full(count, self._NONE, dtype=np.int64)))
        self._last = np.concatenate((self._last, np.full(count, -1, dtype=np.int64)))
        self._cols = np.arange(len(self))

    def remove(self, keep: NDArray[np.bool_]) -> None:
        """Keep only the robots where ``keep`` is True (the others' columns go)."""
        self._xy = self._xy[:, keep]
        self._path = self._path[:, keep]
        self._first = self._first[keep]
        self._last = self._last[keep]
        self._cols = np.arange(len(self))

    def reset(self) -> None:
        """Forget every sample of every robot (the robots stay, as if just added)."""
        self._seq = self._start = 0
        self._first[:] = self._NONE
        self._last[:] = -1

    # -- samples ------------------------------------------------------------------------------
    def push(self, t: float, xy: NDArray[np.float64], sampling: NDArray[np.bool_] | None = None
             ) -> None:
        """Sample the robots at time ``t`` (seconds; not before the previous sample time).

        Args:
            t: Sample time. Seconds.
            xy: (n, 2) or (n, 3) core positions of every robot (only x and y are used; the rows
                of robots that do not sample now are ignored). Metres.
            sampling: Which robots sample now (default: all). A robot that sampled before must
                sample at every push until it is removed; one left out stays as it was (its
                window only loses its oldest samples). At the latest sample time again, robots
                not sampled then join that time (a robot born between two steps).

        Raises:
            ValueError: a time before the previous one, a non-finite time or position of a
                robot that samples, or a wrong shape.
        """
        t = float(t)
        n = len(self)
        if not math.isfinite(t):
            raise ValueError(f"time must be finite, got {t}")
        if xy.ndim != 2 or xy.shape[0] != n or xy.shape[1] not in (2, 3):
            raise ValueError(f"positions must have shape ({n}, 2) or ({n}, 3), got {xy.shape}")
        seq, cap = self._seq, self.capacity
        if seq > self._start and t < self._t[(seq - 1) % cap]:
            raise ValueError(f"time {t} s is before the previous sample")
        cols = self._cols if sampling is None else np.flatnonzero(sampling)
        x, y = xy[cols, 0], xy[cols, 1]
        if not (math.isfinite(float(np.add.reduce(x)) + float(np.add.reduce(y)))
                or (np.isfinite(x).all() and np.isfinite(y).all())):
            raise ValueError("positions of robots that sample must be finite")
        started = self._first[cols] != self._NONE
        path = np.zeros(cols.shape[0])
        if started.any():
            on = cols[started]
            prev = self._last[on] % cap
            path[started] = self._path[prev, on] + _hypot(x[started] - self._xy[prev, on, 0],
                                                          y[started] - self._xy[prev, on, 1])
        if seq > self._start and t == self._t[(seq - 1) % cap] and \
                not (self._last[cols] == seq - 1).any():
            # The latest sample time again, for robots not sampled then (a birth between two
            # steps): they join that time's row.
            seq -= 1
            row = seq % cap
        else:
            # Drop sample times that left the window (the newest one always stays).
            horizon = t - self.window - _TIME_EPS
            while self._start < seq and self._t[self._start % cap] < horizon:
                self._start += 1
            if seq - self._start == cap:
                self._grow()
                cap = self.capacity
            row = seq % cap
            self._t[row] = t
        self._xy[row, cols, 0] = x
        self._xy[row, cols, 1] = y
        self._path[row, cols] = path
        self._first[cols[~started]] = seq
        self._last[cols] = seq
        self._seq = seq + 1
        if path.shape[0] and float(np.maximum.reduce(path)) > 1e3:
            self._rebase(cols[path > 1e3])

    def _rebase(self, cols: NDArray[np.intp]) -> None:
        """Keep the running sums small so that differences stay exact to ~1e-13 m."""
        cap = self.capacity
        for c in cols.tolist():
            lo = max(int(self._first[c]), self._start)
            self._path[:, c] -= self._path[lo % cap, c]

    def _grow(self) -> None:
        cap = self.capacity
        order = (self._start + np.arange(self._seq - self._start)) % cap
        k = order.shape[0]
        t, xy, path = np.empty(2 * cap), np.empty((2 * cap,) + self._xy.shape[1:]), \
            np.empty((2 * cap, self._path.shape[1]))
        # sequence numbers keep their meaning: row = seq % new capacity
        rows = (self._start + np.arange(k)) % (2 * cap)
        t[rows], xy[rows], path[rows] = self._t[order], self._xy[order], self._path[order]
        self._t, self._xy, self._path = t, xy, path

    # -- windows ------------------------------------------------------------------------------
    def ends(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                            NDArray[np.int64]]:
        """Every robot's window: first and last (x, y) (n, 2), path length ``v`` (n,), samples.

        A robot with no sample in its window has zeros and 0 samples.
        """
        cap = self.capacity
        lo = np.maximum(self._first, self._start)
        count = np.maximum(self._last - lo + 1, 0)
        cols = np.arange(len(self))
        some = count > 0
        fc, lc = np.where(some, lo, 0) % cap, np.where(some, self._last, 0) % cap
        first, last = self._xy[fc, cols], self._xy[lc, cols]
        v = self._path[lc, cols] - self._path[fc, cols]
        if not some.all():
            first[~some] = 0.0
            last[~some] = 0.0
            v[~some] = 0.0
        return first, last, v, count

    def terms(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Every robot's ``(f, v, s)`` over its window (zeros below two samples). Metres."""
        first, last, v, count = self.ends()
        s = _hypot(last[:, 0] - first[:, 0], last[:, 1] - first[:, 1])
        few = count < 2
        if few.any():
            v[few] = 0.0
            s[few] = 0.0
        return v + self.s_weight * s, v, s

    # -- one robot's window as plain data ------------------------------------------------------
    def samples(self, col: int) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                         NDArray[np.float64]]:
        """One robot's samples in its window, oldest first: times, (x, y), path (copies)."""
        cap = self.capacity
        lo = max(int(self._first[col]), self._start)
        rows = np.arange(lo, int(self._last[col]) + 1) % cap
        return self._t[rows], self._xy[rows, col], self._path[rows, col]

    def snapshot(self, col: int) -> dict[str, Any]:
        """One robot's window as :meth:`SlidingWindowFitness.snapshot` gives it."""
        t, xy, path = self.samples(col)
        return {"window": self.window, "s_weight": self.s_weight, "capacity": self.capacity,
                "t": t, "xy": xy, "path": path}

    def restore(self, snapshots: Sequence[dict[str, Any]]) -> None:
        """Replace every robot's window by one :meth:`snapshot` each (columns in order).

        Robots sample together, so each window's times are the latest ones of the longest.

        Raises:
            ValueError: a snapshot per robot is missing, or one is inconsistent or does not end
                with the others' sample times.
        """
        if len(snapshots) != len(self):
            raise ValueError(f"{len(snapshots)} fitness window snapshots for {len(self)} robots")
        windows = []
        for snapshot in snapshots:
            t = np.asarray(snapshot["t"], dtype=np.float64).reshape(-1)
            xy = np.asarray(snapshot["xy"], dtype=np.float64).reshape(-1, 2)
            path = np.asarray(snapshot["path"], dtype=np.float64).reshape(-1)
            if xy.shape[0] != t.shape[0] or path.shape[0] != t.shape[0]:
                raise ValueError("a fitness window snapshot needs as many positions and path "
                                 "lengths as times")
            windows.append((t, xy, path))
        times = max((w[0] for w in windows), key=len, default=np.zeros(0))
        k_all = times.shape[0]
        cap = max([self.capacity, k_all, 2]
                  + [int(snapshot.get("capacity", 0)) for snapshot in snapshots])
        n = len(self)
        self._t, self._xy, self._path = np.empty(cap), np.zeros((cap, n, 2)), np.zeros((cap, n))
        self._t[:k_all] = times
        self._start, self._seq = 0, k_all
        for col, (t, xy, path) in enumerate(windows):
            k = t.shape[0]
            if not np.array_equal(times[k_all - k:], t):
                raise ValueError("fitness windows of robots sampled together must end with the "
                                 "same sample times")
            self._xy[k_all - k:k_all, col] = xy
            self._path[k_all - k:k_all, col] = path
            self._first[col], self._last[col] = (k_all - k, k_all - 1) if k else (self._NONE, -1)


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
