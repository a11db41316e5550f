"""The ``revolve`` command line: a thin layer over the Python API.

The API is :mod:`evolution.experiments`, :mod:`evolution.reporting` and :mod:`revolve_env`.
Importing this package loads none of them (nor scipy, matplotlib or a physics engine): each
command imports what it uses, so ``revolve --help`` and ``revolve --version`` answer at once.
:class:`ProgressBar` and :class:`ProgressDisplay` (which load the experiments) are served lazily.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from evolution.cli.commands import CliError, build_parser, main
from evolution.cli.logs import cli_logging

if TYPE_CHECKING:
    from evolution.cli.progress import ProgressBar, ProgressDisplay

__all__ = ["CliError", "ProgressBar", "ProgressDisplay", "build_parser", "cli_logging", "main"]

_LAZY = {"ProgressBar": "evolution.cli.progress", "ProgressDisplay": "evolution.cli.progress"}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'evolution.cli' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(list(globals()) + list(_LAZY))
