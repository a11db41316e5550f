"""Command-line input shared by the subcommands: ``--set KEY=VALUE`` and checked numbers.

Bad input raises :class:`CliError` (or argparse's own error for a bad number), which ``revolve``
reports on one line with exit status 2.
"""

from __future__ import annotations

import argparse
import math
import tomllib
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["CliError", "non_negative_int", "number", "parse_set", "positive_float",
           "positive_int"]


class CliError(ValueError):
    """Bad command-line input (reported on one line, exit status 2)."""


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


def number(kind: type[int | float], low: float, strict: bool) -> Callable[[str], Any]:
    """An argparse type: ``kind`` parsed from text, finite, above ``low``.

    With ``strict`` false, ``low`` itself is allowed.
    """
    noun = "an integer" if kind is int else "a number"

    def parse(text: str) -> int | float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not {noun}: {text!r}") from None
        if not math.isfinite(value) or (value <= low if strict else value < low):
            bound = f"> {low:g}" if strict else f">= {low:g}"
            raise argparse.ArgumentTypeError(f"must be {bound}, got {text}")
        return value

    return parse


positive_int = number(int, 1, strict=False)
non_negative_int = number(int, 0, strict=False)
positive_float = number(float, 0.0, strict=True)
