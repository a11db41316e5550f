"""The command line's progress display (tqdm) and its logging set-up.

:class:`ProgressDisplay` takes the :class:`~evolution.experiments.ProgressEvent` of every run
(from the local workers and, once forwarded, from Ray) and shows it in one of three ways:

* On a terminal: one tqdm bar per run (its births, then its best and mean fitness, robots alive
  and simulation speed once a robot has been evaluated; ``no robot evaluated yet`` before) under a
  total bar (births of all runs, runs finished). A run keeps its line while it runs; finished
  bars stay in place. When there are more runs than lines, a starting run takes over the line of
  a finished (or not yet started) one. No ETA is shown before births have been counted. The
  total's ETA weighs each run's births by their cost (``add_runs(..., weight=)``: ``revolve
  study`` gives each experiment's calibrated CPU per birth, so an online birth counts as the
  offline births it costs), and is never shorter than the slowest running run's own ETA.
* Off a terminal (CI, a redirected stream): no bars; a plain ``INFO`` log line for a run each time
  it passes another ``step`` percent of its births, and for every run at most every ``interval``
  seconds otherwise.
* Nothing at all when the ``evolution`` logger is not enabled for ``INFO`` (``revolve --quiet``).

In every mode the display logs (logger ``evolution.cli.progress``) when a run is first heard of
(started, resumed, replaying), when a replay reaches its last commit point, when it finishes (with
its failures by kind), and at ``DEBUG`` (``revolve --verbose``) every event and every new failure.

Several experiments can share one display: register each one's runs under a label and feed its
events through :meth:`ProgressDisplay.feed` (or ``display(event, label=...)``)::

    display = ProgressDisplay()
    display.add_runs({0: 300, 1: 300}, label="scenario1")
    display.add_runs({0: 300, 1: 300}, label="baseline_a")
    evolution.run("scenario1", "results/scenario1", display.feed("scenario1"))
    display.close()

From Python, the display follows the logging configuration: call :func:`cli_logging` (or
``logging.basicConfig(level=logging.INFO)``) first, or it shows nothing.
"""

from __future__ import annotations

import contextlib
import logging
import math
import shutil
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import NoReturn, TextIO

from tqdm import tqdm
from tqdm.contrib.logging import logging_redirect_tqdm

from evolution.cli.logs import cli_logging, duration, metres
from evolution.experiments import EventObserver, ProgressEvent

__all__ = ["ProgressBar", "ProgressDisplay", "cli_logging", "duration", "metres"]

_log = logging.getLogger(__name__)

_BAR_FORMAT = "{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} births{postfix}"


# --------------------------------------------------------------------------------------------
# The display


@dataclass
class _Run:
    """What the display knows of one run (private)."""

    label: str
    run_id: int
    target: int
    births: int
    weight: float = 1.0  # cost of one of its births (any unit shared by all runs)
    event: ProgressEvent | None = None
    live_births: int | None = None  # births at the first live (not replayed) event
    live_since: float = math.nan  # clock then
    slot: int | None = None
    bucket: int = 0  # last ``step`` percent bucket logged (lines)
    failures: dict[str, int] = field(default_factory=dict)

    @property
    def name(self) -> str:
        return f"{self.label} run {self.run_id}" if self.label else f"run {self.run_id}"

    @property
    def finished(self) -> bool:
        return self.event is not None and self.event.finished

    def rate(self, now: float) -> float:
        """Births per wall-clock second since the first live event (``nan`` before two)."""
        if self.live_births is None or now <= self.live_since:
            return math.nan
        gained = self.births - self.live_births
        return gained / (now - self.live_since) if gained > 0 else math.nan

    def eta(self, now: float) -> float:
        """Wall-clock seconds until it finishes at its own rate (``nan`` before it has one)."""
        return (self.target - self.births) / self.rate(now)

    def status(self, now: float) -> str:
        """Its state in words: fitness, robots alive, speed and ETA once known."""
        e = self.event
        if e is None:
            return "waiting"
        if e.replaying:
            return "replaying to its last commit point"
        if not math.isfinite(e.best):
            text = "no robot evaluated yet"
        else:
            text = (f"best {metres(e.best)} m, mean {metres(e.mean)} m, "
                    f"{e.population_size} alive")
        if e.finished:
            return f"finished, {text}"
        if math.isfinite(e.sim_speed):
            text += f", sim {e.sim_speed:.1f}x"
        eta = self.eta(now)
        if math.isfinite(eta):
            text += f", ETA {duration(eta)}"
        return text


RunKey = tuple[str, int]
"""A run of the display: (label, run id)."""


class ProgressDisplay(EventObserver):
    """Progress of one or several experiments' runs (see the module doc).

    A progress callback of :func:`evolution.run` (or of a study, :meth:`feed`), and an
    observer of a loop stepped in Python (:class:`~evolution.experiments.loop.evolve.Evolution`).

    Args:
        targets: Births at which each run stops, by run id (more with :meth:`add_runs`).
        done: Births already committed by each run (resume), by run id.
        label: Label of these runs (an experiment's name; shown before ``run N``).
        stream: Where bars are drawn (default: stderr).
        tty: Draw bars (default: when ``stream`` is a terminal); else plain log lines.
        interval: Off a terminal, seconds between lines of a run that passes no ``step``. Seconds.
        step: Off a terminal, log a run each time it passes another ``step`` percent. Percent.
        max_bars: Run bars at most (default: the terminal's lines minus two).
        clock: Wall clock (tests). Seconds.
    """

    def __init__(
        self,
        targets: Mapping[int, int] | None = None,
        done: Mapping[int, int] | None = None,
        *,
        label: str = "",
        stream: TextIO | None = None,
        tty: bool | None = None,
        interval: float = 60.0,
        step: float = 10.0,
        max_bars: int | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.shown = _log.isEnabledFor(logging.INFO)
        tty = self.stream.isatty() if tty is None else tty
        self.bars_on = self.shown and tty
        self.interval = interval
        self.step = step
        self.clock = clock
        self.runs: dict[RunKey, _Run] = {}
        self.bars: dict[int, tqdm[NoReturn]] = {}  # slot -> bar; slot 0 is the total
        rows = shutil.get_terminal_size((100, 24)).lines
        self.slots: list[RunKey | None] = [None] * max(1, max_bars or rows - 2)
        self.live_since = math.nan
        self.last_line = -math.inf
        self.label = label
        self._redirect = contextlib.ExitStack()
        if targets:
            self.add_runs(targets, done, label=label)

    # -- runs ----------------------------------------------------------------------------------

    def add_runs(self, targets: Mapping[int, int], done: Mapping[int, int] | None = None,
                 label: str = "", weight: float = 1.0) -> None:
        """Register runs (their bars appear in this order, while there are lines for them).

        Args:
            targets: Births at which each run stops, by run id.
            done: Births already committed by each run, by run id.
            label: Label of these runs.
            weight: What one of their births costs, in any unit all runs share (e.g. CPU
                seconds per birth from :func:`evolution.experiments.app.estimate.calibrate`): the
                ETA weighs births by it.
        """
        if not (math.isfinite(weight) and weight > 0):
            raise ValueError(f"a birth's weight must be a positive number, not {weight!r}")
        for run_id, target in targets.items():
            run = _Run(label, run_id, target, (done or {}).get(run_id, 0), weight)
            self.runs[(label, run_id)] = run
            self._place(run, steal=False)
        self._draw_total()

    @property
    def total(self) -> int:
        """Births of all runs together at the end."""
        return sum(r.target for r in self.runs.values())

    @property
    def done(self) -> int:
        """Births committed so far, all runs together."""
        return sum(r.births for r in self.runs.values())

    def feed(self, label: str) -> Callable[[ProgressEvent], None]:
        """A progress callback for the runs registered under ``label``."""
        return lambda event: self(event, label=label)

    def __call__(self, event: ProgressEvent, label: str | None = None) -> None:
        """Take one progress event (called after every commit point of every run)."""
        key = (self.label if label is None else label, event.run_id)
        run = self.runs.get(key)
        if run is None:  # a run nobody registered: shown from its first event on
            self.add_runs({event.run_id: event.target_births}, label=key[0])
            run = self.runs[key]
        now = self.clock()
        self._note(run, event, now)
        run.births, run.event = event.births, event
        if self.bars_on and not self.bars:  # drawn from the first event on, below what the
            self._start_bars()  # command printed before the runs started
        if run.slot is None and not event.finished:
            self._place(run, steal=True)
        _log.debug("%s: %d/%d births, %s", run.name, run.births, run.target, run.status(now))
        if self.bars_on:
            self._draw(run, now)
        elif self.shown:
            self._line(run, now)

    def close(self) -> None:
        """Close the bars (in order, leaving them on screen) and give logging back."""
        for slot in sorted(self.bars):  # all drawn before any closes (a close moves the cursor)
            self._refresh(slot, self.clock())
        for slot in sorted(self.bars):
            self.bars[slot].close()
        self.bars.clear()
        self._redirect.close()

    def __enter__(self) -> ProgressDisplay:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- what is logged in every mode -------------------------------------------------------------

    def _note(self, run: _Run, event: ProgressEvent, now: float) -> None:
        """Log the start, replay, failures and end of a run; start its rate clocks."""
        before = run.event
        if before is None:
            if event.replaying:
                _log.info("%s: resuming, replaying to its last commit point", run.name)
            elif run.births > 0:
                _log.info("%s: resumed at %d births", run.name, run.births)
            else:
                _log.info("%s: running (first commit point at %d births)", run.name,
                          event.births)
        elif before.replaying and not event.replaying:
            _log.info("%s: replay reached its last commit point (%d births); continuing",
                      run.name, event.births)
        if not event.replaying and run.live_births is None:
            run.live_births, run.live_since = event.births, now
            if not math.isfinite(self.live_since):
                self.live_since = now
        counts = dict(event.failures)
        new = {k: n - run.failures.get(k, 0) for k, n in counts.items()
               if n > run.failures.get(k, 0)}
        if new:
            _log.debug("%s: new failures at %d births: %s", run.name, event.births, _kinds(new))
        run.failures = counts
        if event.finished:
            run.births, run.event = event.births, event
            _log.info("%s: finished, %d births, best %s m, mean %s m, %d alive, %s; %s", run.name,
                      event.births, metres(event.best), metres(event.mean),
                      event.population_size,
                      f"failures: {_kinds(counts)}" if counts else "no failures", self.summary())

    def eta(self) -> float:
        """Wall-clock seconds left for all runs (``inf`` before births were counted).

        Births are weighed by their cost (each run's ``weight``: an online birth simulates a
        whole world for a conception interval and costs several offline ones). The rate is the
        weighted births of all runs together since the first live event, counting each run's
        births from its own first live event (a replay or a resumed start is not a birth
        rate); the work left is the weighted births left. A run runs on one worker, so the
        ETA is never shorter than that of the slowest running run at its own rate.
        """
        runs = self.runs.values()
        gained = sum((r.births - r.live_births) * r.weight for r in runs
                     if r.live_births is not None)
        now = self.clock()
        elapsed = now - self.live_since
        if not math.isfinite(elapsed) or elapsed <= 0 or gained <= 0:
            return math.inf
        left = sum((r.target - r.births) * r.weight for r in runs)
        slowest = max((eta for r in runs if math.isfinite(eta := r.eta(now))), default=0.0)
        return max(left * elapsed / gained, slowest)

    def summary(self) -> str:
        """All runs in words: births, runs finished and, once known, the ETA."""
        total = max(1, self.total)
        text = (f"all runs: {self.done}/{self.total} births ({100 * self.done / total:.0f}%), "
                f"{sum(r.finished for r in self.runs.values())}/{len(self.runs)} runs finished")
        eta = self.eta()
        if math.isfinite(eta) and self.done < self.total:
            text += f", ETA {duration(eta)}"
        return text

    # -- off a terminal: lines -----------------------------------------------------------------

    def _line(self, run: _Run, now: float) -> None:
        bucket = int(100 * run.births / max(1, run.target) // self.step)
        if run.finished:  # its end is logged by _note
            return
        if bucket > run.bucket or now - self.last_line >= self.interval:
            run.bucket = bucket
            self.last_line = now
            _log.info("%s: %d/%d births (%.0f%%), %s; %s", run.name, run.births, run.target,
                      100 * run.births / max(1, run.target), run.status(now), self.summary())

    # -- on a terminal: bars -------------------------------------------------------------------

    def _start_bars(self) -> None:
        """Draw the total bar and a bar for each registered run (while there are lines)."""
        root = logging.getLogger()
        if any(isinstance(h, logging.StreamHandler) and h.stream in (sys.stdout, sys.stderr)
               for h in root.handlers):  # records to the terminal are written above the bars
            self._redirect.enter_context(logging_redirect_tqdm([root]))
        self.bars[0] = self._bar(0, "all runs", self.total, self.done)
        for run in self.runs.values():
            self._place(run, steal=False)

    def _place(self, run: _Run, steal: bool) -> None:
        """Give ``run`` a free line; with ``steal``, also a finished or idle run's line."""
        if not self.bars:
            return
        free = [i for i, key in enumerate(self.slots) if key is None]
        if not free and steal:
            for waiting in (False, True):  # finished runs' lines first, then unstarted ones'
                free = [i for i, key in enumerate(self.slots) if key is not None and (
                    self.runs[key].event is None if waiting else self.runs[key].finished)]
                if free:
                    break
        if not free:
            return
        slot = free[0]
        old = self.slots[slot]
        if old is not None:
            self.runs[old].slot = None
            bar = self.bars.pop(slot + 1)
            bar.leave = False  # cleared, not printed over the top line (its end was logged)
            bar.close()
        self.slots[slot], run.slot = (run.label, run.run_id), slot
        self.bars[slot + 1] = self._bar(slot + 1, run.name, run.target, run.births)
        self._refresh(slot + 1, self.clock())

    def _bar(self, position: int, desc: str, total: int, births: int) -> tqdm[NoReturn]:
        return tqdm(total=total, initial=births, desc=desc, position=position, leave=True,
                    file=self.stream, bar_format=_BAR_FORMAT, dynamic_ncols=True,
                    mininterval=0.0)

    def _refresh(self, slot: int, now: float) -> None:
        bar = self.bars[slot]
        if slot == 0:
            bar.total, bar.n = self.total, self.done
            eta = self.eta()
            finished = sum(r.finished for r in self.runs.values())
            text = f"{finished}/{len(self.runs)} runs finished"
            if math.isfinite(eta) and self.done < self.total:
                text += f", ETA {duration(eta)}"
        else:
            key = self.slots[slot - 1]
            assert key is not None
            run = self.runs[key]
            bar.n, text = run.births, run.status(now)
        bar.set_postfix_str(text, refresh=False)
        bar.refresh()

    def _draw(self, run: _Run, now: float) -> None:
        if run.slot is not None:
            self._refresh(run.slot + 1, now)
        self._draw_total()

    def _draw_total(self) -> None:
        if 0 in self.bars:
            self._refresh(0, self.clock())


def _kinds(counts: Mapping[str, int]) -> str:
    return ", ".join(f"{n} {kind}" for kind, n in sorted(counts.items()))


ProgressBar = ProgressDisplay
"""The display's former name (``ProgressBar(targets, done)`` still works)."""
