"""The ``revolve`` command line: a thin layer over the Python API.

The API is :mod:`evolution.experiments`, :mod:`evolution.reporting` and :mod:`revolve_env`.
"""

from __future__ import annotations

from evolution.cli.commands import CliError, build_parser, main
from evolution.cli.progress import ProgressBar, ProgressDisplay, cli_logging

__all__ = ["CliError", "ProgressBar", "ProgressDisplay", "build_parser", "cli_logging", "main"]
