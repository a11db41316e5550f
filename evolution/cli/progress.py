"""The command line's progress display: one line per experiment, redrawn in place on a terminal."""

from __future__ import annotations

import math
import shutil
import sys
import time
from collections.abc import Callable
from typing import TextIO

from evolution.experiments import ProgressEvent

__all__ = ["ProgressBar", "duration", "metres"]


def duration(seconds: float) -> str:
    """A wall-clock duration as ``1h02m`` or ``3m05s`` (``?`` when not finite)."""
    if not math.isfinite(seconds):
        return "?"
    seconds = round(seconds)
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h}h{m:02d}m" if h else f"{m}m{s:02d}s"


def metres(value: float) -> str:
    """A distance in metres with three decimals (``-`` when not finite)."""
    return "-" if not math.isfinite(value) else f"{value:.3f}"


class ProgressBar:
    """Progress of an experiment's runs, fed with :class:`~evolution.experiments.ProgressEvent`.

    On a terminal one line is redrawn in place (at most every ``redraw`` seconds); otherwise a
    plain line is printed every ``interval`` seconds and when a run finishes.

    Args:
        targets: Births at which each run stops, by run id.
        done: Births already committed by each run (resume), by run id.
        stream: Where to draw (default stderr).
        tty: Force terminal mode on or off (default: ``stream.isatty()``).
        interval: Seconds between plain lines. Seconds.
        redraw: Minimum seconds between terminal redraws. Seconds.
        clock: Wall clock (tests). Seconds.
    """

    def __init__(
        self,
        targets: dict[int, int],
        done: dict[int, int] | None = None,
        stream: TextIO | None = None,
        tty: bool | None = None,
        interval: float = 10.0,
        redraw: float = 0.2,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.targets = dict(targets)
        self.births = {run: (done or {}).get(run, 0) for run in targets}
        self.stream = stream if stream is not None else sys.stderr
        self.tty = self.stream.isatty() if tty is None else tty
        self.interval = interval
        self.redraw = redraw
        self.clock = clock
        self.started = clock()
        self.births_at_start = sum(self.births.values())
        self.speeds: dict[int, float] = {}
        self.finished: set[int] = set()
        self.last_event: ProgressEvent | None = None
        self.last_draw = -math.inf
        self.drawn = False

    @property
    def total(self) -> int:
        """Births of all runs together at the end."""
        return sum(self.targets.values())

    @property
    def done(self) -> int:
        """Births committed so far, all runs together."""
        return sum(self.births.values())

    def eta(self) -> float:
        """Estimated wall-clock seconds left (from the birth rate since this bar started)."""
        elapsed = self.clock() - self.started
        gained = self.done - self.births_at_start
        if gained <= 0 or elapsed <= 0:
            return math.inf
        return (self.total - self.done) * elapsed / gained

    def line(self, width: int = 20) -> str:
        """The progress line (without line ending)."""
        total = max(1, self.total)
        fraction = min(1.0, self.done / total)
        filled = round(fraction * width)
        bar = "#" * filled + "-" * (width - filled)
        text = f"[{bar}] {100 * fraction:3.0f}% births {self.done}/{self.total}"
        if len(self.targets) > 1:
            text += f" | runs done {len(self.finished)}/{len(self.targets)}"
        event = self.last_event
        if event is not None:
            if event.replaying:
                text += f" | run {event.run_id} replaying to its last commit point"
            else:
                who = f"run {event.run_id} " if len(self.targets) > 1 else ""
                text += (f" | {who}best {metres(event.best)} m mean {metres(event.mean)} m"
                         f" pop {event.population_size}")
        speed = sum(v for v in self.speeds.values() if math.isfinite(v))
        if self.speeds:
            text += f" | sim {speed:.1f}x"
        text += f" | ETA {duration(self.eta())}"
        return text

    def __call__(self, event: ProgressEvent) -> None:
        """Take one progress event (called after every commit point of every run)."""
        if event.run_id in self.targets:
            self.births[event.run_id] = event.births
        self.last_event = event
        if not event.replaying and math.isfinite(event.sim_speed):
            self.speeds[event.run_id] = event.sim_speed
        if event.finished:
            self.finished.add(event.run_id)
            self.speeds.pop(event.run_id, None)
        now = self.clock()
        if self.tty:
            if now - self.last_draw >= self.redraw or event.finished:
                columns = shutil.get_terminal_size((100, 20)).columns
                self.stream.write("\r" + self.line()[: columns - 1].ljust(columns - 1))
                self.stream.flush()
                self.last_draw = now
                self.drawn = True
        elif now - self.last_draw >= self.interval or event.finished:
            self.stream.write(self.line() + "\n")
            self.stream.flush()
            self.last_draw = now

    def close(self) -> None:
        """End the terminal line (if one was drawn)."""
        if self.tty and self.drawn:
            self.stream.write("\n")
            self.stream.flush()
            self.drawn = False
