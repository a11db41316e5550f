"""Checkpoint cost and online resume time: snapshot resume against replay from birth 0.

Usage::

    PYTHONPATH=. python benchmarks/bench_checkpoint.py [--births 45] [--kill 0.9] [--seed 0]

Runs the ``scenario3`` experiment (online, one run, its own timings: a birth every 15 s of
simulated time, a checkpoint at every birth) on MuJoCo for ``--births`` births, three times
from the same seed:

1. uninterrupted, timing every snapshot the checkpoints write (world and engine state to
   ``checkpoints/run0.b<births>.snapshot``) and every checkpoint transaction, as a share of the
   run's wall time;
2. killed (a progress callback that raises) at the first checkpoint at or after ``--kill`` x
   ``--births`` births; the killed results directory is copied;
3. resumed twice: from the snapshot, and with the snapshot file deleted (replay from birth 0,
   the behaviour before snapshots). Both resumed databases are checked against the
   uninterrupted one, table by table.

Prints the figures; wall times depend on the machine (and on other work on it). Measured with
``--births 300`` (seed 0, one core of a 2-core machine shared with other work, 2026-11-23):

* uninterrupted run 174.8 s; 285 snapshots took 3.9 s in all, 2.2 % of the run (53 ms at most;
  4.5 MB per file at 270 births); the checkpoint transactions 0.2 s (0.1 %);
* killed at 270 births: resume by replay 157.5 s, from the snapshot 16.6 s (9.5x faster; the
  30 births left are the work); both databases identical to the uninterrupted run's.
"""

from __future__ import annotations

import argparse
import contextlib
import shutil
import sqlite3
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from evolution import experiments
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ExperimentConfig, ProgressEvent, load_config
from evolution.experiments.store.database import Store
from evolution.experiments.store.observer import StoreObserver

TABLES = ("runs", "checkpoints", "robots", "fitness", "transitions", "population", "diversity",
          "failures", "learning")


class _Kill(Exception):
    """Stops a run from its progress callback."""


def _dump(db: Path) -> dict[str, list[tuple[Any, ...]]]:
    con = sqlite3.connect(db)
    try:
        return {t: sorted(con.execute(f"SELECT * FROM {t}").fetchall(), key=repr) for t in TABLES}
    finally:
        con.close()


@contextmanager
def _timed(cls: type, name: str, spent: list[float]) -> Iterator[None]:
    """Add the wall time of every call of ``cls.name`` to ``spent`` (seconds) while active."""
    original: Callable[..., Any] = getattr(cls, name)

    def wrapper(*args: Any, **kwargs: Any) -> Any:
        start = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            spent.append(time.perf_counter() - start)

    setattr(cls, name, wrapper)
    try:
        yield
    finally:
        setattr(cls, name, original)


def _config(births: int, seed: int) -> ExperimentConfig:
    return load_config("scenario3", {"world": {"engine": "mujoco"}, "births": births, "runs": 1,
                                     "seed": seed, "workers": 1})


def main() -> None:
    """Run the three runs and print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--births", type=int, default=45, help="births of the run")
    parser.add_argument("--kill", type=float, default=0.9, help="kill at this share of births")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    config = _config(args.births, args.seed)
    serial = LocalEvaluator(1)
    root = Path(tempfile.mkdtemp(prefix="bench_checkpoint_"))
    try:
        snapshots: list[float] = []
        commits: list[float] = []
        start = time.perf_counter()
        with _timed(StoreObserver, "write_snapshot", snapshots), _timed(Store, "commit", commits):
            experiments.run(config, root / "ref", evaluator=serial)
        run_s = time.perf_counter() - start
        reference = _dump(root / "ref" / "results.sqlite")

        kill_at = max(1, round(args.kill * args.births))

        def killer(event: ProgressEvent) -> None:
            if event.births >= kill_at and not event.replaying:
                raise _Kill

        start = time.perf_counter()
        with contextlib.suppress(_Kill):
            experiments.run(config, root / "killed", killer, evaluator=serial)
        killed_s = time.perf_counter() - start
        (snapshot,) = (root / "killed" / "checkpoints").glob("*.snapshot")
        size = snapshot.stat().st_size
        shutil.copytree(root / "killed", root / "replay")
        for path in (root / "replay" / "checkpoints").glob("*.snapshot"):
            path.unlink()

        timings = {}
        for name in ("killed", "replay"):
            events: list[ProgressEvent] = []
            start = time.perf_counter()
            experiments.resume(root / name, events.append, evaluator=serial)
            timings[name] = time.perf_counter() - start
            replayed = any(e.replaying for e in events)
            same = _dump(root / name / "results.sqlite") == reference
            print(f"resume via {'replay' if replayed else 'snapshot'}: {timings[name]:.2f} s, "
                  f"database {'identical to' if same else 'DIFFERENT from'} the uninterrupted run")
        print(f"scenario3 on MuJoCo, {args.births} births, seed {args.seed}, killed at "
              f"{kill_at} births ({killed_s:.1f} s into the run)")
        print(f"uninterrupted run: {run_s:.2f} s wall; {len(snapshots)} snapshots took "
              f"{sum(snapshots):.3f} s ({100 * sum(snapshots) / run_s:.2f} % of the run, "
              f"{1000 * max(snapshots, default=0.0):.1f} ms at most); the checkpoint "
              f"transactions {sum(commits):.3f} s ({100 * sum(commits) / run_s:.2f} %); "
              f"snapshot file at the kill: {size / 1e6:.2f} MB")
        print(f"resume after the kill: {timings['replay']:.2f} s by replay, "
              f"{timings['killed']:.2f} s from the snapshot "
              f"({timings['replay'] / timings['killed']:.1f}x faster)")
    finally:
        shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
