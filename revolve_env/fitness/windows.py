"""Sliding fitness windows: the ring buffer of many robots, and a one-robot view of it.

See :mod:`revolve_env.fitness` for the rule. :class:`FitnessWindows` is the one ring buffer;
:class:`SlidingWindowFitness` is one robot's window in it, with float-valued methods. Both give
the :class:`~revolve_env.fitness.Window` a task scores.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, ClassVar, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from revolve_env.fitness.terms import (
    DEFAULT_S_WEIGHT,
    DEFAULT_WINDOW,
    TIME_EPS,
    FitnessTerms,
    Window,
    hypot,
    speed_fitness,
)

__all__ = ["FitnessWindows", "Ring", "SlidingWindowFitness"]


class Ring(NamedTuple):
    """A :class:`FitnessWindows`' own arrays and counters (:meth:`FitnessWindows.ring`).

    A row per sample time (row ``seq % capacity``), a column per robot; the arrays are the
    windows' own, written in place by a compiled caller, which hands the counters it leaves to
    :meth:`FitnessWindows.pushed`.
    """

    t: NDArray[np.float64]
    """(capacity,) every row's sample time. Seconds."""
    xy: NDArray[np.float64]
    """(capacity, n, 2) every robot's core position at each sample time. Metres."""
    path: NDArray[np.float64]
    """(capacity, n) every robot's path length from its first sample. Metres."""
    first: NDArray[np.int64]
    """(n,) every robot's first sample (sequence number; ``FitnessWindows._NONE``: none yet)."""
    last: NDArray[np.int64]
    """(n,) every robot's last sample (sequence number; -1: none yet)."""
    seq: int
    """The sequence number of the next sample time."""
    start: int
    """The sequence number of the oldest sample time in the windows."""


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

    What a task scores is :meth:`current`: every robot's window as a :class:`Window` of arrays
    (with ``signal=True``, a task's signal is kept with each sample and given at both ends).
    """

    def __init__(self, window: float = DEFAULT_WINDOW, s_weight: float = DEFAULT_S_WEIGHT,
                 capacity: int = 1024, signal: bool = False) -> None:
        """Windows of ``window`` seconds; ``f = v + s_weight * s``; no robots yet.

        Args:
            window: Window length. Seconds.
            s_weight: Weight of ``s``.
            capacity: Initial ring size (samples); it doubles when a window holds more.
            signal: Keep a signal value with every sample (:meth:`push`'s ``signal``).
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
        self._sig: NDArray[np.float64] | None = np.empty((capacity, 0)) if signal else None
        self._seq = 0  # sequence number of the next sample time (its ring row: seq % capacity)
        self._start = 0  # sequence number of the oldest sample time in the windows
        self._first = np.zeros(0, dtype=np.int64)  # each robot's first sample (_NONE: none)
        self._last = np.zeros(0, dtype=np.int64)  # and last one
        self._cols = np.zeros(0, dtype=np.intp)  # every column
        self._all_started = True  # every robot has a sample (push's common case)
        self._rows_now: tuple[Any, ...] | None = None  # _rows() until the next change

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
        if self._sig is not None:
            self._sig = np.concatenate((self._sig, np.zeros((cap, count))), axis=1)
        self._first = np.concatenate((self._first, np.full(count, self._NONE, dtype=np.int64)))
        self._last = np.concatenate((self._last, np.full(count, -1, dtype=np.int64)))
        self._cols = np.arange(len(self))
        self._all_started = count == 0 and self._all_started
        self._rows_now = None

    def remove(self, keep: NDArray[np.bool_]) -> None:
        """Keep only the robots where ``keep`` is True (the others' columns go)."""
        self._xy = self._xy[:, keep]
        self._path = self._path[:, keep]
        if self._sig is not None:
            self._sig = self._sig[:, keep]
        self._first = self._first[keep]
        self._last = self._last[keep]
        self._cols = np.arange(len(self))
        self._all_started = bool((self._first != self._NONE).all())
        self._rows_now = None

    def reset(self) -> None:
        """Forget every sample of every robot (the robots stay, as if just added)."""
        self._seq = self._start = 0
        self._first[:] = self._NONE
        self._last[:] = -1
        self._all_started = len(self) == 0
        self._rows_now = None

    # -- samples ------------------------------------------------------------------------------
    def push(self, t: float, xy: NDArray[np.float64], sampling: NDArray[np.bool_] | None = None,
             signal: NDArray[np.float64] | None = None) -> None:
        """Sample the robots at time ``t`` (seconds; not before the previous sample time).

        Args:
            t: Sample time. Seconds.
            xy: (n, 2) or (n, 3) core positions of every robot (only x and y are used; the rows
                of robots that do not sample now are ignored). Metres.
            sampling: Which robots sample now (default: all). A robot that sampled before must
                sample at every push until it is removed; one left out stays as it was (its
                window only loses its oldest samples). At the latest sample time again, robots
                not sampled then join that time (a robot born between two steps).
            signal: (n,) every robot's signal now (windows made with ``signal=True`` only; the
                entries of robots that do not sample are ignored).

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
        if sampling is not None and sampling.all():
            sampling = None  # every robot: the same columns, without the masks
        cols = self._cols if sampling is None else np.flatnonzero(sampling)
        x, y = xy[cols, 0], xy[cols, 1]
        if not (math.isfinite(float(np.add.reduce(x)) + float(np.add.reduce(y)))
                or (np.isfinite(x).all() and np.isfinite(y).all())):
            raise ValueError("positions of robots that sample must be finite")
        every = sampling is None and self._all_started  # the common case, without masks
        if every:
            prev = self._last % cap
            path = self._path[prev, cols] + hypot(x - self._xy[prev, cols, 0],
                                                  y - self._xy[prev, cols, 1])
        else:
            started = self._first[cols] != self._NONE
            path = np.zeros(cols.shape[0])
            if started.any():
                on = cols[started]
                prev = self._last[on] % cap
                path[started] = self._path[prev, on] + hypot(x[started] - self._xy[prev, on, 0],
                                                              y[started] - self._xy[prev, on, 1])
        if seq > self._start and t == self._t[(seq - 1) % cap] and \
                not (self._last[cols] == seq - 1).any():
            # The latest sample time again, for robots not sampled then (a birth between two
            # steps): they join that time's row.
            seq -= 1
            row = seq % cap
        else:
            # Drop sample times that left the window (the newest one always stays).
            horizon = t - self.window - TIME_EPS
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
        if self._sig is not None:
            if signal is None:
                raise ValueError("these windows keep a signal: push needs one")
            self._sig[row, cols] = signal[cols]
        if not every:
            self._first[cols[~started]] = seq
            self._all_started = bool((self._first != self._NONE).all())
        self._last[cols] = seq
        self._seq = seq + 1
        self._rows_now = None
        if path.shape[0] and float(np.maximum.reduce(path)) > 1e3:
            self._rebase(cols[path > 1e3])

    def push_compiled(self, kernel: Callable[..., tuple[bool, int, int, bool]], t: float,
                      position: NDArray[np.float64], ages: NDArray[np.int64],
                      sampling: NDArray[np.bool_], stride: int, insertion_steps: int
                      ) -> Window | None:
        """:meth:`push` then :meth:`current` in one compiled call, or None (nothing done).

        For windows without a signal, a robot holding its last pose between its pose samples
        as :class:`~revolve_env.rollout.TaskWindows` has it (``stride``: control periods between
        them, counted from ``insertion_steps`` of age on). ``kernel`` is the compiled rollout's
        ``windows_push`` (:func:`revolve_env.world.compiled.windows_kernel`): the same numbers as
        :meth:`push`; it declines (None) what :meth:`push` does rarely (a robot joining the latest
        sample time, a ring that grows, a path rebased past 1 km) and bad input (errors there).

        Args:
            kernel: The compiled push.
            t: Sample time. Seconds.
            position: (n, 3) every robot's core position (C order). Metres.
            ages: (n,) control periods since every robot's birth.
            sampling: (n,) which robots sample now.
            stride: Control periods between pose samples.
            insertion_steps: Age of a robot's first sample. Control periods.
        """
        n = len(self)
        if (self._sig is not None or position.shape != (n, 3) or not position.flags.c_contiguous
                or ages.shape != (n,) or ages.dtype != np.int64 or not ages.flags.c_contiguous
                or sampling.shape != (n,) or sampling.dtype != np.bool_):
            return None
        if not (self._xy.flags.c_contiguous and self._path.flags.c_contiguous):  # after remove
            self._xy, self._path = np.ascontiguousarray(self._xy), np.ascontiguousarray(self._path)
        first, last, v, s = np.empty((n, 2)), np.empty((n, 2)), np.empty(n), np.empty(n)
        count, duration = np.empty(n, dtype=np.int64), np.empty(n)
        pushed, seq, start, all_started = kernel(
            float(t), self.window, TIME_EPS, int(stride), int(insertion_steps),
            position.reshape(-1), ages, sampling, self._t, self._xy, self._path, self._first,
            self._last, self._seq, self._start, first.reshape(-1), last.reshape(-1), v, s, count,
            duration)
        if not pushed:
            return None
        self._seq, self._start, self._all_started = seq, start, all_started
        self._rows_now = None
        count.flags.writeable = False
        return Window(first, last, v, s, count, None, None, duration)

    def ring(self) -> Ring | None:
        """The ring's own arrays, for a compiled caller that pushes as :meth:`push_compiled` does.

        Written in place by the caller, which then calls :meth:`pushed`; None for windows with a
        signal.
        """
        if self._sig is not None:
            return None
        if not (self._xy.flags.c_contiguous and self._path.flags.c_contiguous):  # after remove
            self._xy, self._path = np.ascontiguousarray(self._xy), np.ascontiguousarray(self._path)
        return Ring(self._t, self._xy, self._path, self._first, self._last, self._seq,
                    self._start)

    def pushed(self, seq: int, start: int, all_started: bool) -> None:
        """After pushes into :meth:`ring`'s arrays: the ring's counters they left."""
        self._seq, self._start, self._all_started = int(seq), int(start), bool(all_started)
        self._rows_now = None

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
        if self._sig is not None:
            sig = np.empty((2 * cap, self._sig.shape[1]))
            sig[rows] = self._sig[order]
            self._sig = sig

    # -- windows ------------------------------------------------------------------------------
    def _rows(self) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp],
                             NDArray[np.int64], NDArray[np.bool_]]:
        """Ring rows of every robot's first and last sample, its column, samples, any sample.

        Kept until the windows change (between a step's :meth:`current` and the next step's
        :meth:`last`); the sample counts (given out in :class:`Window`) read-only.
        """
        if self._rows_now is None:
            cap = self.capacity
            lo = np.maximum(self._first, self._start)
            count = np.maximum(self._last - lo + 1, 0)
            count.flags.writeable = False
            some = count > 0
            self._rows_now = (np.where(some, lo, 0) % cap, np.where(some, self._last, 0) % cap,
                              self._cols, count, some)
        return self._rows_now

    def ends(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64],
                            NDArray[np.int64]]:
        """Every robot's window: first and last (x, y) (n, 2), path length ``v`` (n,), samples.

        A robot with no sample in its window has zeros and 0 samples.
        """
        fc, lc, cols, count, some = self._rows()
        first, last = self._xy[fc, cols], self._xy[lc, cols]
        v = self._path[lc, cols] - self._path[fc, cols]
        if not some.all():
            first[~some] = 0.0
            last[~some] = 0.0
            v[~some] = 0.0
        return first, last, v, count

    def last(self) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """Every robot's latest sample: (x, y) (n, 2) and its signal (n,) (None without one).

        What a robot holds between two pose samples (:mod:`revolve_env.fitness.sampling`);
        rows of robots with no sample are zeros.
        """
        _, lc, cols, _, some = self._rows()
        xy = np.where(some[:, None], self._xy[lc, cols], 0.0)
        sig = None if self._sig is None else np.where(some, self._sig[lc, cols], 0.0)
        return xy, sig

    def current(self) -> Window:
        """Every robot's window now, as arrays (zeros but ``samples`` below two samples)."""
        fc, lc, cols, count, some = self._rows()
        first, last = self._xy[fc, cols], self._xy[lc, cols]
        v = self._path[lc, cols] - self._path[fc, cols]
        s = hypot(last[:, 0] - first[:, 0], last[:, 1] - first[:, 1])
        sig_first = sig_last = None
        if self._sig is not None:
            sig_first, sig_last = self._sig[fc, cols], self._sig[lc, cols]
        duration = self._t[lc] - self._t[fc]
        few = count < 2
        if few.any():
            for a in (first, last, v, s, sig_first, sig_last, duration):
                if a is not None:
                    a[few] = 0.0
        return Window(first, last, v, s, count, sig_first, sig_last, duration)

    def terms(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Every robot's ``(f, v, s)`` over its window (zeros below two samples). Metres."""
        w = self.current()
        return speed_fitness(w.v, w.s, self.s_weight), w.v, w.s

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
        out = {"window": self.window, "s_weight": self.s_weight, "capacity": self.capacity,
               "t": t, "xy": xy, "path": path}
        if self._sig is not None:
            lo = max(int(self._first[col]), self._start)
            out["signal"] = self._sig[np.arange(lo, int(self._last[col]) + 1) % self.capacity,
                                      col]
        return out

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
            sig = np.zeros(t.shape[0])
            if self._sig is not None:
                if "signal" not in snapshot:
                    raise ValueError("these fitness windows keep a signal; the snapshot has none")
                sig = np.asarray(snapshot["signal"], dtype=np.float64).reshape(-1)
            if xy.shape[0] != t.shape[0] or path.shape[0] != t.shape[0] or \
                    sig.shape[0] != t.shape[0]:
                raise ValueError("a fitness window snapshot needs as many positions, path "
                                 "lengths and signal values as times")
            windows.append((t, xy, path, sig))
        times = max((w[0] for w in windows), key=len, default=np.zeros(0))
        k_all = times.shape[0]
        cap = max([self.capacity, k_all, 2]
                  + [int(snapshot.get("capacity", 0)) for snapshot in snapshots])
        n = len(self)
        self._t, self._xy, self._path = np.empty(cap), np.zeros((cap, n, 2)), np.zeros((cap, n))
        if self._sig is not None:
            self._sig = np.zeros((cap, n))
        self._t[:k_all] = times
        self._start, self._seq = 0, k_all
        self._rows_now, self._all_started = None, False  # the masked push until all are read
        for col, (t, xy, path, sig) in enumerate(windows):
            k = t.shape[0]
            if not np.array_equal(times[k_all - k:], t):
                raise ValueError("fitness windows of robots sampled together must end with the "
                                 "same sample times")
            self._xy[k_all - k:k_all, col] = xy
            self._path[k_all - k:k_all, col] = path
            if self._sig is not None:
                self._sig[k_all - k:k_all, col] = sig
            self._first[col], self._last[col] = (k_all - k, k_all - 1) if k else (self._NONE, -1)
        self._all_started = bool((self._first != self._NONE).all())


class SlidingWindowFitness:
    """One robot's sliding fitness window: a :class:`FitnessWindows` of one column.

    ``add(t, position)`` appends a sample; ``terms()`` gives the fitness over the samples with
    ``t >= t_last - window``, as :func:`window_fitness` on the same samples (to rounding: the path
    length is kept as a running sum, so each query costs O(1)). Samples older than the window are
    dropped, so memory stays bounded however long the robot lives. :meth:`current` gives the
    window as a task scores it (a :class:`Window` of one robot).
    """

    def __init__(
        self, window: float = DEFAULT_WINDOW, s_weight: float = DEFAULT_S_WEIGHT,
        capacity: int = 1024, signal: bool = False,
    ) -> None:
        """A window of ``window`` seconds; ``f = v + s_weight * s``.

        Args:
            window: Window length. Seconds.
            s_weight: Weight of ``s``.
            capacity: Initial ring size (samples); it doubles when a window holds more.
            signal: Keep a signal value with every sample (:meth:`add`'s ``signal``).
        """
        self._ring = FitnessWindows(window, s_weight, capacity, signal)
        self._ring.add(1)
        self._signal = signal

    @property
    def window(self) -> float:
        """Window length. Seconds."""
        return self._ring.window

    @property
    def s_weight(self) -> float:
        """Weight of ``s``."""
        return self._ring.s_weight

    def __len__(self) -> int:
        """Samples currently in the window."""
        return int(self._ring.ends()[3][0])

    def reset(self) -> None:
        """Forget every sample."""
        self._ring.reset()

    def add(self, t: float, position: ArrayLike, signal: float | None = None) -> None:
        """Append the core's position at time ``t`` (seconds; not before the previous sample).

        ``signal``: the task's signal now (required when the window keeps one).
        """
        p = np.asarray(position, dtype=np.float64).reshape(-1)
        if p.shape[0] not in (2, 3) or not (math.isfinite(float(p[0]))
                                            and math.isfinite(float(p[1]))):
            raise ValueError(f"position must be 2 or 3 finite numbers, got {position!r}")
        if self._signal and signal is None:
            raise ValueError("this window keeps a signal: add needs one")
        self._ring.push(t, p.reshape(1, -1), None,
                        None if signal is None or not self._signal else np.array([signal]))

    def snapshot(self) -> dict[str, Any]:
        """The window's samples and settings as plain data (see :meth:`from_snapshot`)."""
        return self._ring.snapshot(0)

    @classmethod
    def from_snapshot(cls, snapshot: dict[str, Any]) -> SlidingWindowFitness:
        """A window that goes on exactly as the one :meth:`snapshot` was taken of.

        Raises:
            ValueError: inconsistent sample arrays.
        """
        n = np.asarray(snapshot["t"]).reshape(-1).shape[0]
        window = cls(float(snapshot["window"]), float(snapshot["s_weight"]),
                     max(int(snapshot["capacity"]), n, 2), signal="signal" in snapshot)
        window._ring.restore([snapshot])
        return window

    def last(self) -> tuple[NDArray[np.float64], float | None]:
        """The latest sample's (x, y) (a copy) and signal (None without one).

        What the robot holds between two pose samples (:mod:`revolve_env.fitness.sampling`).

        Raises:
            ValueError: the window has no sample.
        """
        if not len(self):
            raise ValueError("the window has no sample yet")
        xy, sig = self._ring.last()
        return xy[0].copy(), None if sig is None else float(sig[0])

    def samples(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Times (T,) and horizontal positions (T, 2) in the window, oldest first (copies)."""
        t, xy, _ = self._ring.samples(0)
        return t, xy

    def current(self) -> Window:
        """The window now as arrays of one robot (zeros but ``samples`` below two samples)."""
        return self._ring.current()

    def terms(self) -> FitnessTerms:
        """Fitness and its terms over the current window."""
        f, v, s = self._ring.terms()
        return FitnessTerms(float(f[0]), float(v[0]), float(s[0]))

    @property
    def fitness(self) -> float:
        """``v + s_weight * s`` over the current window. Metres."""
        return self.terms().fitness
