"""Every living robot's core trajectory, appended for all robots in one array write per step.

:class:`TrajectoryStore` keeps each robot's samples contiguous (a segment of one arena) so that a
robot's trajectory is a read-only view, handed out without a copy; the segments grow by
doubling. A step appends to every robot that records with one fancy-index write. An arena is
never written again where a view handed out may look: a full segment moves to fresh space, and
when the arena runs out a new one is made (the old array lives on in the views that use it).

A store made with ``length`` keeps each robot's latest ``length`` samples only (0: none), so its
memory stays bounded however long the robots live: a full segment then moves to fresh space with
its latest samples, as it would to grow. A robot living 1000 s at 60 samples a second otherwise
holds 1.4 MB (its segment, up to twice that while it grows).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["TrajectoryStore"]

_FIRST = 64  # samples a new robot's segment holds before it moves


class TrajectoryStore:
    """Core positions (metres) of many robots over their lives; rows follow births and deaths."""

    def __init__(self, capacity: int = 4096, length: int | None = None) -> None:
        """An empty store.

        Args:
            capacity: Samples of the first arena.
            length: Samples kept per robot, its latest (0: none); None: every sample.
        """
        if length is not None and length < 0:
            raise ValueError(f"length must be >= 0 or None, got {length}")
        self.length = length
        self._arena = np.empty((capacity, 3))
        self._read = self._read_only(self._arena)
        self._used = 0  # rows of the arena handed to segments
        self._start = np.zeros(0, dtype=np.intp)  # each robot's segment
        self._length = np.zeros(0, dtype=np.intp)
        self._room = np.zeros(0, dtype=np.intp)

    @staticmethod
    def _read_only(arena: NDArray[np.float64]) -> NDArray[np.float64]:
        view = arena.view()
        view.flags.writeable = False
        return view

    def __len__(self) -> int:
        """Robots."""
        return int(self._start.shape[0])

    def add(self, samples: NDArray[np.float64] | None = None, room: int = _FIRST) -> None:
        """A new robot (last row), with ``samples`` (T, 3) already recorded (default none)."""
        if samples is not None and self.length is not None:
            samples = samples[samples.shape[0] - min(samples.shape[0], self.length):]
        k = 0 if samples is None else samples.shape[0]
        room = max(room if self.length is None else min(room, self._trim_room()), k, 1)
        start = self._allocate(room)
        if k:
            assert samples is not None
            self._arena[start:start + k] = samples
        self._start = np.append(self._start, start)
        self._length = np.append(self._length, k)
        self._room = np.append(self._room, room)

    def remove(self, keep: NDArray[np.bool_]) -> None:
        """Keep the robots where ``keep`` is True (the others' segments become free space)."""
        self._start, self._length, self._room = (self._start[keep], self._length[keep],
                                                 self._room[keep])

    def clear(self) -> None:
        """No robots."""
        self.remove(np.zeros(len(self), dtype=bool))

    def append(self, rows: NDArray[np.intp] | slice, positions: NDArray[np.float64]) -> None:
        """Record ``positions`` (k, 3) for the robots in ``rows``, one sample each."""
        if self.length == 0:
            return
        length = self._length[rows]
        if (length == self._room[rows]).any():
            for row in np.arange(len(self))[rows][length == self._room[rows]].tolist():
                if self.length is not None and int(self._length[row]) >= self.length:
                    # Its latest samples to fresh space (a view handed out keeps the old ones).
                    self._move(row, self._trim_room(), self.length - 1)
                else:
                    self._move(row, 2 * int(self._room[row]))
        self._arena[self._start[rows] + self._length[rows]] = positions
        self._length[rows] += 1

    def _trim_room(self) -> int:
        """Room of a segment that keeps ``length`` samples: one copy per ``length`` appends."""
        assert self.length is not None
        return max(2 * self.length, 1)

    def _move(self, row: int, room: int, keep: int | None = None) -> None:
        """Give a robot a segment of ``room`` samples with its samples so far (its latest keep)."""
        start, k = int(self._start[row]), int(self._length[row])
        if keep is not None and keep < k:
            start, k = start + k - keep, keep
        old = self._arena
        new = self._allocate(room)  # may replace the arena: copy from the old one
        self._arena[new:new + k] = old[start:start + k]
        self._start[row] = new
        self._length[row] = k
        self._room[row] = room

    def _allocate(self, room: int) -> int:
        """Rows for a segment at the end of the arena, in a new arena when it is full."""
        if self._used + room > self._arena.shape[0]:
            live = int(self._room.sum())
            arena = np.empty((max(2 * (live + room), 4096), 3))
            used = 0
            for row in range(len(self)):  # compact the live segments into the new arena
                s, k, r = int(self._start[row]), int(self._length[row]), int(self._room[row])
                arena[used:used + k] = self._arena[s:s + k]
                self._start[row] = used
                used += r
            self._arena, self._read, self._used = arena, self._read_only(arena), used
        start = self._used
        self._used += room
        return start

    def view(self, row: int) -> NDArray[np.float64]:
        """A robot's trajectory so far, (T, 3), read-only (it does not see later samples)."""
        s, k = int(self._start[row]), int(self._length[row])
        if self.length is not None and k > self.length:
            s, k = s + k - self.length, self.length
        return self._read[s:s + k]

    def views(self) -> list[NDArray[np.float64]]:
        """Every robot's :meth:`view`, in row order."""
        read, start, stop = self.spans()
        return [read[s:e] for s, e in zip(start.tolist(), stop.tolist(), strict=True)]

    def spans(self) -> tuple[NDArray[np.float64], NDArray[np.intp], NDArray[np.intp]]:
        """What :meth:`views` slices: the read-only arena and every robot's start and stop in it."""
        stop = self._start + self._length
        start = (self._start if self.length is None
                 else np.maximum(self._start, stop - self.length))
        return self._read, start, stop

    def room(self, row: int) -> int:
        """Samples a robot's segment holds before it moves."""
        return int(self._room[row])
