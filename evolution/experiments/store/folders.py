"""Which results databases a command takes from a folder: one set of experiments at a time.

A *set* is what one report compares: the experiments of one study (the folder holding
``study.json``, written by :mod:`evolution.experiments.app.study`: its experiments share their runs,
births, seed and settings), or the experiments outside any study (``revolve run`` writes each to
``OUT/<name>/``, with whatever budget it was given). A folder may hold several sets: ``revolve
run quick --out results`` beside ``revolve study`` (``results/study``) puts a lone experiment
and a study below ``results``. Mixing them would compare experiments that never shared a
design, so :func:`select_results` takes one set:

1. the study the folder is, or lies in (``results/study``, ``results/study/scenario1``);
2. else the experiments outside any study, when there are some (``results``: ``quick``);
3. else the one study below it.

The sets it leaves out are named (the report says so, with the command that reports each), and
with several studies below the folder and nothing else it refuses, naming them. ``every_set``
(``--all`` on the command line) takes every set at once: a report then compares all of them,
each pair at the births both reached (:mod:`evolution.reporting.tables`).

``revolve report`` and ``revolve reevaluate`` follow this rule; ``revolve resume`` continues
every unfinished run below its folder, whatever its set (continuing compares nothing).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from evolution.experiments.loop.errors import StoreError
from evolution.experiments.store.database import DB_NAME

__all__ = ["STUDY_FILE", "ResultSet", "Selection", "left_out_note", "select_results"]

STUDY_FILE = "study.json"
"""The study's settings, in its results folder (:mod:`evolution.experiments.app.study`)."""


@dataclass(frozen=True, slots=True)
class ResultSet:
    """Experiments compared together: one study's, or those outside any study.

    Attributes:
        study: The study's folder (holding ``study.json``); ``None`` for the experiments
            outside any study.
        databases: Their results databases, sorted by path.
    """

    study: Path | None
    databases: tuple[Path, ...]

    def describe(self) -> str:
        """What the set is, e.g. ``the study results/study (5 experiments)``."""
        count = len(self.databases)
        plural = "s" * (count != 1)
        if self.study is not None:
            return f"the study {self.study} ({count} experiment{plural})"
        shown = ", ".join(str(db.parent) for db in self.databases[:3])
        more = ", ..." if count > 3 else ""
        return f"{count} experiment{plural} outside any study ({shown}{more})"


@dataclass(frozen=True, slots=True)
class Selection:
    """What :func:`select_results` took from a folder.

    Attributes:
        root: The folder (or database) given.
        chosen: The sets taken (one, or every set with ``every_set``).
        left_out: The sets below ``root`` not taken.
    """

    root: Path
    chosen: tuple[ResultSet, ...]
    left_out: tuple[ResultSet, ...]

    @property
    def databases(self) -> tuple[Path, ...]:
        """Every database of the chosen sets, sorted by path."""
        return tuple(sorted(db for s in self.chosen for db in s.databases))

    def study_of(self, db: Path) -> Path | None:
        """The study folder ``db`` belongs to (``None``: outside any study)."""
        for s in self.chosen:
            if db in s.databases:
                return s.study
        raise KeyError(f"{db} is not among the chosen databases")



def left_out_note(root: str | os.PathLike[str], left_out: Sequence[ResultSet],
                  command: str) -> str | None:
    """One line naming the sets ``command`` left out below ``root`` and how to take them.

    ``None`` when nothing was left out.
    """
    if not left_out:
        return None
    hints = [f"{s.describe()}: {command} {s.study}" if s.study is not None
             else s.describe() for s in left_out]
    return (f"left out below {root}: {'; '.join(hints)} (or all together: {command} {root} "
            "--all)")


def _study_folder(folder: Path) -> Path | None:
    """The nearest folder at or above ``folder`` holding a study's settings file."""
    for candidate in (folder, *folder.parents):
        # Whatever its kind: a study's settings file that is not a regular file is refused when
        # read (results_folder.read_settings), never passed over.
        if os.path.lexists(candidate / STUDY_FILE):
            return candidate
    return None


def _display(path: Path, root: Path, shown_root: Path) -> Path:
    """``path`` as the user would write it: below the folder they gave, as they gave it."""
    try:
        return shown_root / path.relative_to(root)
    except ValueError:
        return path


def result_sets(root: Path) -> list[ResultSet]:
    """Every set of experiments at or below ``root`` (see the module docstring).

    Raises:
        StoreError: ``root`` is missing or holds no results database.
    """
    if not root.exists():
        raise StoreError(f"no such results directory: {root}")
    if root.is_file():
        paths = [root] if root.name == DB_NAME else []
    else:
        paths = sorted(root.rglob(DB_NAME))
    if not paths:
        raise StoreError(f"no results database ({DB_NAME}) at or below {root}")
    absolute = root.resolve()
    shown = root
    sets: dict[Path | None, list[Path]] = {}
    for db in paths:
        study = _study_folder(db.resolve().parent.parent)
        key = None if study is None else _display(study, absolute, shown)
        sets.setdefault(key, []).append(db)
    return [ResultSet(study, tuple(dbs)) for study, dbs in sorted(
        sets.items(), key=lambda item: (item[0] is not None, str(item[0])))]


def select_results(root: str | os.PathLike[str], every_set: bool = False,
                   command: str = "revolve report") -> Selection:
    """The set of experiments a command takes from ``root`` (module docstring).

    Args:
        root: A results folder, a folder of them, or a ``results.sqlite``.
        every_set: Take every set below ``root`` (``--all``).
        command: The command named in messages (``revolve report``, ``revolve reevaluate``).

    Raises:
        StoreError: ``root`` is missing or holds no database, or it holds several studies and
            nothing else and ``every_set`` is not given (one line naming them).
    """
    path = Path(root)
    sets = result_sets(path)
    if every_set or len(sets) == 1:
        return Selection(path, tuple(sets), ())
    chosen = _one_set(path, sets, command)
    return Selection(path, (chosen,), tuple(s for s in sets if s is not chosen))


def _one_set(root: Path, sets: Sequence[ResultSet], command: str) -> ResultSet:
    loose = [s for s in sets if s.study is None]
    if loose:
        return loose[0]
    named = "; ".join(s.describe() for s in sets)
    raise StoreError(f"{root} holds {len(sets)} studies ({named}); one {command.split()[-1]} "
                     f"takes one: {command} {sets[0].study}, or all together with {command} "
                     f"{root} --all")
