"""Errors of the experiment layer that the CLI reports on one line (bad input, not bugs)."""

from __future__ import annotations

__all__ = ["ConfigError", "StoreError"]


class ConfigError(ValueError):
    """An experiment configuration that cannot be run (unknown key, value out of range, ...)."""


class StoreError(ValueError):
    """A results database that cannot be used: missing, corrupt, newer schema, other experiment."""
