"""Command-line input shared by the experiment subcommands: ``--set KEY=VALUE``, ``--tensorboard``.

Bad input raises :class:`~evolution.cli.robots.CliError`, which ``revolve`` reports on one line
with exit status 2.
"""

from __future__ import annotations

import argparse
import tomllib
from collections.abc import Sequence
from typing import Any

from evolution.cli.robots import CliError

__all__ = ["parse_set", "tensorboard_argument"]


def tensorboard_argument(parser: argparse.ArgumentParser) -> None:
    """``--tensorboard DIR``: each run's scalars for TensorBoard in ``DIR/<experiment>/run<N>``."""
    parser.add_argument("--tensorboard", metavar="DIR",
                        help="also write each run's fitness, population size and speed against "
                             "births for TensorBoard to DIR/<experiment>/run<N> (needs "
                             'pip install "revolve-env[tensorboard]")')


def parse_set(items: Sequence[str]) -> dict[str, Any]:
    """``KEY=VALUE`` overrides as nested config data.

    VALUE is read as TOML, else as a string; ``evolution.KEY``, ``learning.KEY`` and
    ``world.KEY`` nest.
    """
    data: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise CliError(f"--set expects KEY=VALUE, got {item!r}")
        parts = key.split(".")
        if any(not p.replace("_", "").isalnum() for p in parts):
            raise CliError(f"--set: {key!r} is not a config key")
        try:
            parsed = tomllib.loads(f"v = {value.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            parsed = value.strip()
        target = data
        for p in parts[:-1]:
            target = target.setdefault(p, {})
            if not isinstance(target, dict):
                raise CliError(f"--set: {key!r} conflicts with another --set")
        target[parts[-1]] = parsed
    return data
