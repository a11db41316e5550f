"""Errors of the experiment layer that the CLI reports on one line (bad input, not bugs)."""

from __future__ import annotations

__all__ = ["ConfigError", "SnapshotError", "StoreError"]


class ConfigError(ValueError):
    """An experiment configuration that cannot be run (unknown key, value out of range, ...)."""


class StoreError(ValueError):
    """A results database that cannot be used: missing, corrupt, newer schema, other experiment."""


class SnapshotError(Exception):
    """A snapshot file is missing, damaged, of another run or version, or cannot be read.

    Not bad input on its own: a resume that meets one replays from birth 0 instead
    (:mod:`~evolution.experiments.store.snapshot` reads the files).
    """
