"""Recorded runs: small experiments on both physics engines; their databases compared by table.

A refactor must move no stored number. This script records a fixed set of small runs (offline
and online, pybullet and MuJoCo, with and without infancy learning) into a folder, and compares
two such folders table by table: every row of every table of each database.

Usage::

    PYTHONPATH=. python benchmarks/recorded_runs.py record OUT [--cases NAME ...] [--kill K]
    PYTHONPATH=. python benchmarks/recorded_runs.py resume OUT
    PYTHONPATH=. python benchmarks/recorded_runs.py compare A B

``record`` writes ``OUT/<case>/results.sqlite`` for every case; with ``--kill K`` each run is
stopped (a progress callback that raises, as a kill) at its first commit point at or past
``K`` x its births, leaving an interrupted results folder that ``resume`` continues (with the
code checked out now: a folder recorded by an older version is upgraded as a user's would be).
``compare`` copies both folders' databases aside, opens each copy once with the store (which
upgrades an older schema in place, as ``revolve resume`` would) and compares every table, row
by row in insertion order; the stored configuration (``meta.config``) is compared as JSON data
and ``package_version`` is not compared. It prints one line per case and table and exits 1 if
anything differs.

The recorded cases name no offline/online switch of their own: each starts from a shipped
config (``quick``, ``scenario3``, ``scenario1_learning``, ``scenario3_learning``), so the same
command records with code from before and after a rename of that switch.

Measured for issue 21 (the stepping loop, the ``engine`` -> ``mode`` rename, schema 5), seed 3,
2-core machine shared with other work: ``record BASE/full`` and ``record BASE/killed --kill 0.6``
with the code before (schema 4), ``record NEW`` with the code after, then ``resume`` of a copy of
``BASE/killed`` with the code after. ``compare BASE/full NEW`` and ``compare BASE/full
RESUMED``: both "ALL IDENTICAL", 66 tables of 6 databases each (offline 90 births and online 50
births on pybullet and MuJoCo, offline learning 18 births on pybullet, online learning 14 births
on MuJoCo; the online MuJoCo runs resumed from their snapshot, the online pybullet one by
replay). A change of 1e-12 m in one fitness sample is reported as DIFFERENT (exit status 1).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sqlite3
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ExperimentConfig, ProgressEvent, load_config
from evolution.experiments.store.database import DB_NAME, Store


@dataclass(frozen=True)
class Case:
    """One recorded experiment: a shipped config and the keys changed to make it small."""

    name: str
    config: str
    overrides: dict[str, Any] = field(default_factory=dict)

    def load(self) -> ExperimentConfig:
        """The experiment config of this case."""
        return load_config(self.config, {"runs": 1, "seed": 3, **self.overrides})


_LEARN = {"budget": 35.0, "workers": 1}  # the inborn controller, then one CMA-ES generation
CASES = (
    Case("offline-pybullet", "quick", {"births": 90, "world": {"engine": "pybullet"}}),
    Case("offline-mujoco", "quick", {"births": 90, "world": {"engine": "mujoco"}}),
    Case("online-pybullet", "scenario3", {"births": 50, "world": {"engine": "pybullet"}}),
    Case("online-mujoco", "scenario3", {"births": 50, "world": {"engine": "mujoco"}}),
    Case("offline-learning-pybullet", "scenario1_learning",
         {"births": 18, "population_size": 6, "offspring_size": 6, "learning": _LEARN,
          "world": {"engine": "pybullet"}}),
    Case("online-learning-mujoco", "scenario3_learning",
         {"births": 14, "population_size": 8, "learning": _LEARN,
          "world": {"engine": "mujoco"}}),
)


class _Kill(Exception):
    """Stands for a kill of the process: raised from a progress callback."""


def record(out: Path, cases: list[Case], kill: float | None, workers: int) -> None:
    """Record every case into ``out/<case>`` (stopped at ``kill`` x births if given)."""
    for case in cases:
        config = case.load()
        target = out / case.name
        if target.exists():
            shutil.rmtree(target)
        stop_at = None if kill is None else max(1, round(kill * config.births))

        def progress(event: ProgressEvent, stop_at: int | None = stop_at) -> None:
            if stop_at is not None and event.births >= stop_at and not event.replaying:
                raise _Kill

        start = time.perf_counter()
        with LocalEvaluator(workers) as evaluator:
            try:
                experiments.run(config, target, progress, evaluator=evaluator)
                status = "finished"
            except _Kill:
                status = f"killed at >= {stop_at} births"
        print(f"{case.name:<26} {config.births:>4} births  {time.perf_counter() - start:7.1f} s"
              f"  {status}", flush=True)


def resume(out: Path, workers: int) -> None:
    """Resume every results folder under ``out`` with the code checked out now."""
    for folder in sorted(p.parent for p in out.glob(f"*/{DB_NAME}")):
        start = time.perf_counter()
        with LocalEvaluator(workers) as evaluator:
            experiments.resume(folder, evaluator=evaluator)
        print(f"{folder.name:<26} resumed  {time.perf_counter() - start:7.1f} s", flush=True)


def dump(db: Path) -> dict[str, list[tuple[Any, ...]]]:
    """Every table of a database (upgraded to this version's schema), rows in insertion order.

    ``meta``'s ``config`` is parsed JSON (an upgrade may write its keys in another order) and its
    ``package_version`` row is left out.
    """
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / DB_NAME
        with sqlite3.connect(db) as source, sqlite3.connect(copy) as target:
            source.backup(target)  # the WAL's committed pages included
        Store.open(copy).close()  # upgrades an older schema in place, as resume would
        con = sqlite3.connect(copy)
        try:
            names = [r[0] for r in con.execute(
                "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")]
            tables = {t: con.execute(f"SELECT * FROM {t} ORDER BY rowid").fetchall()
                      for t in names}
        finally:
            con.close()
    tables["meta"] = sorted(
        (key, json.loads(value) if key == "config" else value)
        for key, value in tables["meta"] if key != "package_version")
    return tables


def compare(a: Path, b: Path) -> bool:
    """Print the table-by-table comparison of two recorded folders; True if all are identical."""
    names = sorted({p.parent.name for p in a.glob(f"*/{DB_NAME}")}
                   | {p.parent.name for p in b.glob(f"*/{DB_NAME}")})
    same = True
    for name in names:
        if not (a / name / DB_NAME).is_file() or not (b / name / DB_NAME).is_file():
            print(f"{name:<26} missing in {a if not (a / name / DB_NAME).is_file() else b}")
            same = False
            continue
        left, right = dump(a / name / DB_NAME), dump(b / name / DB_NAME)
        for table in sorted(set(left) | set(right)):
            x, y = left.get(table), right.get(table)
            if x == y:
                verdict = "identical"
            elif x is not None and y is not None and sorted(map(repr, x)) == sorted(map(repr, y)):
                verdict = "SAME ROWS, OTHER ORDER"
                same = False
            else:
                verdict = "DIFFERENT"
                same = False
            rows = "-" if x is None else len(x)
            print(f"{name:<26} {table:<14} {rows:>6} rows  {verdict}")
            if verdict == "DIFFERENT" and x is not None and y is not None:
                for i, (p, q) in enumerate(zip(x, y, strict=False)):
                    if p != q:
                        print(f"    first difference at row {i}:\n      {p!r:.300}\n"
                              f"      {q!r:.300}")
                        break
    print("ALL IDENTICAL" if same else "DIFFERENCES FOUND")
    return same


def main() -> None:
    """Parse the command line and run it."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    rec = commands.add_parser("record", help="record the cases into OUT/<case>")
    rec.add_argument("out", type=Path)
    rec.add_argument("--cases", nargs="*", default=[c.name for c in CASES],
                     choices=[c.name for c in CASES])
    rec.add_argument("--kill", type=float, default=None,
                     help="stop each run at this share of its births (an interrupted folder)")
    rec.add_argument("--workers", type=int, default=2, help="evaluation worker processes")
    res = commands.add_parser("resume", help="resume every folder under OUT")
    res.add_argument("out", type=Path)
    res.add_argument("--workers", type=int, default=2, help="evaluation worker processes")
    cmp = commands.add_parser("compare", help="compare two recorded folders table by table")
    cmp.add_argument("a", type=Path)
    cmp.add_argument("b", type=Path)
    args = parser.parse_args()
    if args.command == "record":
        record(args.out, [c for c in CASES if c.name in args.cases], args.kill, args.workers)
    elif args.command == "resume":
        resume(args.out, args.workers)
    elif not compare(args.a, args.b):
        sys.exit(1)


if __name__ == "__main__":
    main()
