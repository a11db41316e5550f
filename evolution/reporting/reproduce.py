"""How to make a report again: the commands that wrote its results, read from the results.

Everything comes from what the results folder stores, not from memory: a study's settings file
(``study.json``: runs, births, seed, ``--set`` overrides, experiments), each lone experiment's
stored configuration (compared with the shipped config of its name, every difference a
``--set``), the stored reevaluations (their repeats, window offsets, kind and world), and the
report's own options. Paths are written as the report was given them, so the commands run from
the folder the report was made in. Options that change how runs execute but no number
(``workers``, ``evaluator``, ``ray_address``) are left out.
"""

from __future__ import annotations

import json
import math
import shlex
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from evolution.experiments.app.api import flat_keys
from evolution.experiments.app.reevaluate import reevaluation_conditions
from evolution.experiments.loop.config import ConfigError, load_config
from evolution.experiments.loop.registry import PAPER_SCENARIOS, shipped_configs
from evolution.experiments.store.database import DB_NAME, Store
from evolution.experiments.store.folders import STUDY_FILE
from evolution.experiments.store.results_folder import read_settings
from evolution.reporting.data import ExperimentData, Included

__all__ = ["EXECUTION_KEYS", "Command", "commands", "set_value"]

EXECUTION_KEYS = frozenset({"workers", "evaluator", "ray_address"})
"""Config keys that say how runs execute, not what they compute: never part of a command."""


@dataclass(frozen=True, slots=True)
class Command:
    """One command of the reproduction, with what it does.

    Attributes:
        line: The shell command.
        what: What it makes, in a few words.
    """

    line: str
    what: str


def set_value(value: Any) -> str:
    """A config value as ``--set KEY=VALUE`` reads it (TOML; a bare string when it stays one)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        try:
            tomllib.loads(f"v = {value}")
        except tomllib.TOMLDecodeError:
            return value
        return json.dumps(value)
    return json.dumps(value)


def _sets(changes: Mapping[str, Any]) -> list[str]:
    words: list[str] = []
    for key, value in sorted(changes.items()):
        if key.split(".")[0] not in EXECUTION_KEYS and value is not None:
            words += ["--set", f"{key}={set_value(value)}"]
    return words


def _study_command(folder: Path) -> Command:
    settings = read_settings(folder, STUDY_FILE)
    words = ["revolve", "study", "--out", str(folder), "--runs", str(settings["runs"]),
             "--births", str(settings["births"]), "--seed", str(settings["seed"])]
    words += _sets(flat_keys(settings.get("overrides", {})))
    names = list(settings.get("experiments", PAPER_SCENARIOS))
    if names != list(PAPER_SCENARIOS):
        words += ["--only", *names]
    return Command(shlex.join(words), f"the study in {folder} ({len(names)} experiments)")


def _run_command(e: ExperimentData, parent: Path) -> Command:
    """``revolve run`` of a lone experiment: its shipped config and every stored difference."""
    name, config = e.name, e.config
    words = ["revolve", "run"]
    basics: dict[str, Any] = {k: config[k] for k in ("runs", "births", "seed") if k in config}
    if name in shipped_configs():
        try:
            shipped = load_config(name, basics).to_dict()
        except ConfigError:
            shipped = {}
        stored, base = flat_keys(config), flat_keys(shipped)
        differ = {k: stored[k] for k in stored if base.get(k, object()) != stored[k]}
        words.append(name)
    else:  # not a shipped config: every key of it
        differ = {k: v for k, v in flat_keys(config).items() if k != "name"}
        words.append("quick")
        words += ["--name", name]
    for key in ("runs", "births", "seed"):
        differ.pop(key, None)
        if key in basics:
            words += [f"--{key}", str(basics[key])]
    differ.pop("name", None)
    words += ["--out", str(parent)]
    words += _sets(differ)
    return Command(shlex.join(words), f"{e.title} ({len(e.runs)} runs)")


def _reevaluation_settings(e: ExperimentData) -> set[tuple[str, bool, int, tuple[float, ...],
                                                            bool]]:
    """Each stored reevaluation call: kind, shared world, K, window offsets, own conditions."""
    with Store.open(e.path / DB_NAME) as store:
        records = store.reevaluations()
    insertion = float(e.config.get("insertion", 0.0))
    default = json.dumps(reevaluation_conditions(e.config).to_dict(), sort_keys=True)
    calls: dict[tuple[str, bool, bool], tuple[int, set[float]]] = {}
    for r in records:
        key = (r.kind, r.shared_world, json.loads(r.conditions) == json.loads(default))
        k, offsets = calls.get(key, (0, set()))
        offsets.add(round(r.insertion - insertion, 9))
        calls[key] = (max(k, r.repeat + 1), offsets)
    return {(kind, shared, k, tuple(sorted(offsets)), own)
            for (kind, shared, own), (k, offsets) in calls.items()}


def _reevaluate_commands(folder: Path, settings: set[tuple[str, bool, int, tuple[float, ...],
                                                           bool]]) -> list[Command]:
    out = []
    for kind, shared, k, offsets, own in sorted(settings):
        words = ["revolve", "reevaluate", str(folder), "--k", str(k)]
        if kind == "best":
            words.append("--best")
        if offsets != (0.0,):
            for o in offsets:
                words += ["--window-offset", f"{o:g}" if math.isfinite(o) else str(o)]
        if shared:
            words.append("--shared-world")
        what = "reevaluations of the " + ("best robots" if kind == "best" else "final populations")
        if not own:
            what += " (under other conditions than the run's own: given from Python)"
        out.append(Command(shlex.join(words), what))
    return out


def commands(included: Included, every_set: bool = False, brain_aware: bool = False,
             formats: Sequence[str] = ("png", "pdf"), out_dir: str | None = None
             ) -> list[Command]:
    """The commands that make these results and this report again, in order.

    ``every_set``, ``brain_aware``, ``formats`` and ``out_dir`` are the report's own options
    (``out_dir``: its folder when given, else the default).
    """
    out: list[Command] = []
    studies = sorted({e.study for e in included.experiments if e.study is not None}, key=str)
    for folder in studies:
        out.append(_study_command(folder))
        members = [e for e in included.experiments if e.study == folder]
        settings = [_reevaluation_settings(e) for e in members]
        if settings and all(s == settings[0] for s in settings):
            out += _reevaluate_commands(folder, settings[0])
        else:
            for e, s in zip(members, settings, strict=True):
                out += _reevaluate_commands(e.path, s)
    for e in included.experiments:
        if e.study is None:
            out.append(_run_command(e, e.path.parent))
            out += _reevaluate_commands(e.path, _reevaluation_settings(e))
    words = ["revolve", "report", str(included.root)]
    if every_set:
        words.append("--all")
    if brain_aware:
        words.append("--brain-aware")
    if tuple(formats) != ("png", "pdf"):
        words += ["--formats", ",".join(formats)]
    if out_dir is not None:
        words += ["--out", out_dir]
    out.append(Command(shlex.join(words), "this report"))
    return out
