"""``revolve reevaluate RESULTS``: stored robots evaluated again, and the optimism table.

A thin layer over :func:`evolution.experiments.app.reevaluate.reevaluate` (what is evaluated, with
which seeds and conditions, how rows are keyed) and :mod:`evolution.reporting.optimism` (what the
table means). Progress is a count of evaluations on stderr (a tqdm bar on a terminal, log lines
otherwise, nothing with ``--quiet``); at the end the optimism table of
every experiment below RESULTS is printed, and ``revolve report RESULTS`` adds it to the report.
Running the same command again evaluates only what is missing (nothing, or the repeats a larger
``--k`` adds); after Ctrl-C it continues where the last commit left off.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time
from typing import Any, Literal, NoReturn

from tqdm import tqdm

from evolution.cli.robots import (
    EXIT_INTERRUPTED,
    non_negative_seconds,
    number,
    trust_argument,
    workers,
)
from evolution.experiments.app.reevaluate import MAX_K, reevaluate
from evolution.experiments.store.folders import left_out_note
from evolution.reporting import find_experiments
from evolution.reporting.optimism import EXPLANATION, markdown, optimism_rows, read_reevaluations

__all__ = ["add_reevaluate"]

_log = logging.getLogger(__name__)


class _Count:
    """Evaluations done out of planned, on stderr.

    A tqdm bar on a terminal, else an ``INFO`` log line at most every ``interval`` seconds;
    nothing with ``revolve --quiet`` (as the runs' progress display).
    """

    def __init__(self, interval: float = 10.0) -> None:
        self.interval = interval
        self.last = -math.inf
        self.bar: tqdm[NoReturn] | None = None

    def __call__(self, done: int, total: int) -> None:
        if not _log.isEnabledFor(logging.INFO):
            return
        if sys.stderr.isatty():
            if self.bar is None:
                self.bar = tqdm(total=total, desc="reevaluated", unit=" evaluations",
                                file=sys.stderr, leave=True)
            self.bar.update(done - self.bar.n)
            return
        now = time.monotonic()
        if now - self.last >= self.interval or done == total:
            _log.info("reevaluated %d/%d", done, total)
            self.last = now

    def close(self) -> None:
        """End the bar (if one was drawn)."""
        if self.bar is not None:
            self.bar.close()


def _cmd_reevaluate(args: argparse.Namespace) -> int:
    offsets = tuple(args.window_offset) if args.window_offset else (0.0,)
    which: Literal["final", "best"] = "best" if args.best else "final"
    chosen = "best robot of each commit point" if args.best else "final populations"
    print(f"reevaluating the {chosen} below {args.results}: K = {args.k}, window offsets "
          f"{', '.join(f'{o:g}' for o in offsets)} s"
          f"{', in one shared world per run' if args.shared_world else ''}", flush=True)
    count = _Count()
    try:
        summary = reevaluate(args.results, k=args.k, which=which, window_offsets=offsets,
                             shared_world=args.shared_world, workers=args.workers,
                             progress=count, include_unfinished=args.include_unfinished,
                             trust_pickled_policies=args.trust_pickled_policies,
                             every_set=args.all, trust_task_code=args.trust_task_code)
    except KeyboardInterrupt:
        print("revolve reevaluate: interrupted; finished reevaluations are saved; run the same "
              "command again to continue", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        count.close()
    for run in summary.skipped:
        print(f"skipped run {run.run_id} of {run.database.parent}: {run.status} at "
              f"{run.births} of {run.target} births (--include-unfinished reevaluates its last "
              "committed population)", flush=True)
    print(f"{summary.planned} reevaluation(s) asked for in {len(summary.databases)} "
          f"database(s): {summary.added} new, {summary.planned - summary.evaluated} stored "
          "already", flush=True)
    note = left_out_note(args.results, summary.left_out, "revolve reevaluate")
    if note:
        print(note, flush=True)
    rows = optimism_rows(read_reevaluations(find_experiments(args.results, every_set=args.all)))
    more = " --all" if args.all else ""
    print("\n".join(["", *markdown(rows), "", EXPLANATION, "",
                     f"next: revolve report {args.results}{more}"]), flush=True)
    return 0


def add_reevaluate(sub: Any) -> None:
    """Register the ``reevaluate`` subcommand on ``revolve``'s subparsers."""
    p = sub.add_parser(
        "reevaluate",
        description="Evaluate the final population of every run of one set of experiments "
                    "below RESULTS (a study, or the experiments outside any study; --all: "
                    "every set) (or, with "
                    "--best, the best robot of each generation / online birth) K more times "
                    "under fresh conditions (the run's own with a random heading: new headings "
                    "and noise draws, seeded), store the results in each experiment's database, "
                    "and print per experiment the optimism of a single evaluation (stored minus "
                    "mean reevaluated fitness, 95 % bootstrap CI over runs) and the rank "
                    "stability (Spearman, best stays best). Running it again adds only missing "
                    "rows; `revolve report RESULTS` then includes optimism.csv and "
                    "optimism.png/pdf.",
    )
    p.add_argument("results", metavar="RESULTS",
                   help="results folder (as given to `revolve run --out`), or one experiment's")
    p.add_argument("--k", type=number(int, 1, strict=False, high=MAX_K), default=10,
                   help="reevaluations per robot")
    p.add_argument("--best", action="store_true",
                   help="the best robot of each commit point instead of the final population")
    p.add_argument("--window-offset", type=non_negative_seconds, action="append",
                   metavar="S",
                   help="seconds lived before the fitness window, one setting each (repeatable; "
                        "default: 0, the run's own window)")
    p.add_argument("--shared-world", action="store_true",
                   help="evaluate a run's robots together in one world per repeat")
    p.add_argument("--workers", type=workers, default=0,
                   help="worker processes, 0: all cores")
    p.add_argument("--include-unfinished", action="store_true",
                   help="also runs that have not finished (interrupted or still running: their "
                        "last committed population); by default they are skipped, and listed")
    trust_argument(p)
    p.add_argument("--all", action="store_true",
                   help="every set of experiments below RESULTS (by default one: a study, or "
                        "the experiments outside any study, as revolve report takes them)")
    p.set_defaults(handler=_cmd_reevaluate)
