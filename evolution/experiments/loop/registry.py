"""The one scenario registry: the experiment configs shipped as TOML files.

``configs/*.toml`` holds the paper's five experiments and ``quick``; ``configs/learning/*.toml``
the scenarios with infancy learning (``scenario1_learning``, ...). The command line
(``revolve run scenario1``) and the Python API (``evolution.run("scenario1")``,
:func:`~evolution.experiments.preset`) read these same files, so a name means the same runs
everywhere. This module only finds and reads them; :mod:`evolution.experiments.loop.config`
turns the data into an :class:`~evolution.experiments.ExperimentConfig`.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

from evolution.experiments.loop.errors import ConfigError

__all__ = ["PAPER_SCENARIOS", "learning_names", "read_toml", "shipped_config", "shipped_configs"]

PAPER_SCENARIOS = ("scenario1", "scenario2", "scenario3", "baseline_a", "baseline_b")
"""The paper's five experiments, in its order: what ``revolve study`` runs by default, and the
order reports list experiments in (others after them, by name)."""


def shipped_configs() -> dict[str, Path]:
    """The shipped experiment configs by name (file stem), learning variants included."""
    # The files beside this module (naming its package, "evolution.experiments", would be an
    # import of the package that imports this module: a circle for tests/test_import_graph.py).
    folder = Path(__file__).with_name("configs")
    found: dict[str, Path] = {}
    for sub in (folder, folder / "learning"):
        if sub.is_dir():
            found.update({p.stem: p for p in sub.iterdir() if p.name.endswith(".toml")})
    return found


def learning_names() -> list[str]:
    """Shipped configs with a ``[learning]`` table (infancy learning)."""
    return sorted(name for name, path in shipped_configs().items()
                  if path.parent.name == "learning")


def shipped_config(name: str) -> Path:
    """The file of a shipped config.

    Raises:
        ConfigError: no shipped config has that name (the known ones are listed).
    """
    shipped = shipped_configs()
    if name not in shipped:
        raise ConfigError(f"unknown scenario {name!r}; known: {', '.join(sorted(shipped))}")
    return shipped[name]


def read_toml(path: str | os.PathLike[str]) -> dict[str, Any]:
    """The plain data of a TOML config file.

    Raises:
        ConfigError: the file cannot be read or is not valid TOML (naming the file).
    """
    path = Path(path)
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as error:
        raise ConfigError(f"cannot read experiment config {path}: {error}") from error
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as error:
        raise ConfigError(f"{path} is not valid TOML: {error}") from error
