"""What every ``revolve`` command prints with: its logging set-up and how it writes numbers.

Kept apart from :mod:`evolution.cli.progress` (the tqdm display over the experiments' events),
so that commands which run nothing start without loading the experiments.
"""

from __future__ import annotations

import contextlib
import logging
import math
import sys
from collections.abc import Iterator
from typing import TextIO

__all__ = ["OUR_LOGGERS", "cli_logging", "duration", "metres"]

OUR_LOGGERS = ("evolution", "revolve_env")
"""The loggers :func:`cli_logging` sets (others stay at ``WARNING``)."""

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


# --------------------------------------------------------------------------------------------
# Logging


class _Formatter(logging.Formatter):
    """``INFO`` as the bare message; other levels after their level (``DEBUG``: and logger)."""

    def format(self, record: logging.LogRecord) -> str:
        message = super().format(record)
        if record.levelno == logging.INFO:
            return message
        if record.levelno == logging.DEBUG:
            return f"debug: {record.name}: {message}"
        return f"{record.levelname.lower()}: {message}"


@contextlib.contextmanager
def cli_logging(verbosity: int = 0, stream: TextIO | None = None) -> Iterator[None]:
    """Python logging as the command line sets it, undone on exit.

    Our loggers (``evolution``, ``revolve_env``) log at ``INFO`` (``verbosity`` 1 or more:
    ``DEBUG``; -1 or less: ``WARNING``, which also turns the progress display off); every other
    library at ``WARNING``. Records go to ``stream`` (default: stderr as it is on entry).

    Args:
        verbosity: -1 (``--quiet``), 0 or 1 (``--verbose``).
        stream: Where the records are written.
    """
    level = logging.DEBUG if verbosity > 0 else logging.WARNING if verbosity < 0 else logging.INFO
    handler = logging.StreamHandler(stream if stream is not None else sys.stderr)
    handler.setFormatter(_Formatter())
    root = logging.getLogger()
    ours = [logging.getLogger(name) for name in OUR_LOGGERS]
    saved = root.level, [logger.level for logger in ours], list(root.handlers)
    root.addHandler(handler)
    root.setLevel(logging.WARNING)
    for logger in ours:
        logger.setLevel(level)
    try:
        yield
    finally:
        root.handlers = saved[2]  # also undoes a display's redirection left by an error
        root.setLevel(saved[0])
        for logger, old in zip(ours, saved[1], strict=True):
            logger.setLevel(old)
