"""Progress callbacks and observers: TensorBoard scalars, and several callbacks as one.

Any run takes a progress callback (``evolution.run(config, out, progress)``,
``evolution.resume(out, progress)``, ``revolve run ... --tensorboard DIR``)::

    from evolution.experiments.app.callbacks import TensorBoardLogger, combine

    with TensorBoardLogger("tb/scenario1") as tensorboard:
        evolution.run("scenario1", "results/scenario1", combine(tensorboard, print))

Both are also observers (:class:`~evolution.experiments.loop.evolve.EventObserver`) of a loop
stepped in Python, with or without a database::

    with TensorBoardLogger("tb/quick") as tensorboard:
        Evolution("quick", observers=[tensorboard]).run()

:class:`TensorBoardLogger` writes one TensorBoard run per experiment run (``LOG_DIR/run0``,
``LOG_DIR/run1``, ...) with these scalars, against births (the step):

=====================  ==================================================================
tag                    value
=====================  ==================================================================
``fitness/best``       highest fitness in the population (once one is known). Metres.
``fitness/mean``       mean fitness of the population (once one is known). Metres.
``population/size``    robots alive (offline: the population).
``speed/sim_speed``    simulated seconds per wall-clock second since the run (re)started.
``failures/total``     failures recorded since the run (re)started (blow-ups, learners...).
=====================  ==================================================================

Events of an online run replaying to its last commit point (on resume) are not written again;
the commit point a resumed run continues from is (the same values at the same step). A run's
``finished`` event repeats its last commit point: it closes the run's file without writing that
point a second time.
View them with ``tensorboard --logdir LOG_DIR``. It needs ``pip install "revolve-env[tensorboard]"``
(the ``tensorboard`` package and PyTorch, whose ``SummaryWriter`` writes the files); without them
making a logger raises :class:`TensorBoardUnavailableError` (an ``ImportError``) saying so.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

from evolution.experiments.loop.evolve import EventObserver
from evolution.experiments.loop.run import ProgressEvent

__all__ = ["Combined", "TensorBoardLogger", "TensorBoardUnavailableError", "combine"]

PIP_COMMAND = 'pip install "revolve-env[tensorboard]"'
"""How to install what :class:`TensorBoardLogger` needs."""


class TensorBoardUnavailableError(ImportError):
    """The packages that write TensorBoard files (``tensorboard``, ``torch``) are missing."""


class Combined(EventObserver):
    """Several progress callbacks called in turn with every event (see :func:`combine`).

    Args:
        callbacks: The callbacks, called in this order.
    """

    def __init__(self, *callbacks: Callable[[ProgressEvent], Any]) -> None:
        self.callbacks = callbacks

    def __call__(self, event: ProgressEvent) -> None:
        """Pass ``event`` to every callback."""
        for callback in self.callbacks:
            callback(event)

    def close(self) -> None:
        """Close every callback that has a ``close`` method (all of them, even if one fails)."""
        errors = []
        for callback in self.callbacks:
            close = getattr(callback, "close", None)
            if close is not None:
                try:
                    close()
                except Exception as error:  # noqa: BLE001 - closed the others, then re-raised
                    errors.append(error)
        if errors:
            raise errors[0]


def combine(*callbacks: Callable[[ProgressEvent], Any]) -> Combined:
    """One progress callback calling each of ``callbacks`` in turn.

    For example the CLI's display and a :class:`TensorBoardLogger`; its ``close()`` closes those
    that can be closed.
    """
    return Combined(*callbacks)


class TensorBoardLogger(EventObserver):
    """A progress callback writing each run's scalars to TensorBoard (see the module doc).

    Args:
        log_dir: Folder of the experiment's TensorBoard runs (created when the first is written).
        flush_secs: Seconds between writes to disk (also written when a run finishes and on
            :meth:`close`). Seconds.

    Raises:
        TensorBoardUnavailableError: ``tensorboard`` or ``torch`` is not installed.
    """

    def __init__(self, log_dir: str | os.PathLike[str], flush_secs: float = 30.0) -> None:
        try:
            from torch.utils.tensorboard import SummaryWriter
        except ImportError as error:
            raise TensorBoardUnavailableError(
                f"TensorBoard logging needs the tensorboard and torch packages ({error}); "
                f"install them with: {PIP_COMMAND}") from None
        self.log_dir = Path(log_dir)
        self.flush_secs = flush_secs
        self._writer_class = SummaryWriter
        self.writers: dict[int, Any] = {}
        self._steps: dict[int, int] = {}  # run -> the last step written

    def __call__(self, event: ProgressEvent) -> None:
        """Write the scalars of one event (not those of a replay)."""
        if event.replaying:
            return
        writer = self.writers.get(event.run_id)
        if writer is None:
            writer = self._writer_class(log_dir=str(self.log_dir / f"run{event.run_id}"),
                                        flush_secs=self.flush_secs)
            self.writers[event.run_id] = writer
        step = event.births
        if event.finished and self._steps.get(event.run_id) == step:
            self.writers.pop(event.run_id).close()  # its last commit point, written already
            return
        self._steps[event.run_id] = step
        for tag, value in (("fitness/best", event.best), ("fitness/mean", event.mean),
                           ("population/size", event.population_size),
                           ("speed/sim_speed", event.sim_speed),
                           ("failures/total", sum(n for _, n in event.failures))):
            if math.isfinite(value):
                writer.add_scalar(tag, value, step)
        if event.finished:
            self.writers.pop(event.run_id).close()

    def close(self) -> None:
        """Write everything and close the files (of runs still open, e.g. after Ctrl-C)."""
        for writer in self.writers.values():
            writer.close()
        self.writers.clear()

    def __enter__(self) -> TensorBoardLogger:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
