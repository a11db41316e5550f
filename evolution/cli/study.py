"""``revolve study``: the paper's five experiments in one folder, then their figures and tables.

``revolve study --runs 3 --births 60`` runs scenario1, scenario2, scenario3, baseline_a and
baseline_b (:func:`evolution.experiments.app.study.study`: all their runs as jobs of one evaluator,
two at once on two cores) into ``--out`` (``OUT/<name>/results.sqlite`` each, the settings in
``OUT/study.json``), then writes the report (``OUT/report/``: the paper's figures and the
tables) and prints where it is. The same command again continues an interrupted study (Ctrl-C,
a crash, a kill) and leaves finished experiments alone; other settings into the same folder are
refused on one line naming the setting.

Time, measured once each on this project's shared 2-core machine: ``revolve study --runs 3
--births 60`` took 1 min 54 s on MuJoCo, the default engine (load average about 2.4), and 16 min
50 s with ``--set world.engine=pybullet`` (load average 4.5 to 6.8: other jobs shared the
cores); scenario 3's
online runs (one world of 8 to 30 robots simulated for 15 s per birth) took about 8 min each with
pybullet and 45 s with MuJoCo, an offline run 0.5 to 1 min and 5 to 10 s.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Mapping
from contextlib import closing
from pathlib import Path
from typing import Any

from evolution.cli.options import parse_set, tensorboard_argument
from evolution.cli.progress import ProgressDisplay, duration, metres
from evolution.cli.robots import (
    EXIT_INTERRUPTED,
    CliError,
    non_negative_int,
    positive_int,
    trust_argument,
    workers,
    writable_folder,
)
from evolution.evaluation import Evaluator
from evolution.experiments import ProgressEvent
from evolution.experiments.app.callbacks import TensorBoardLogger
from evolution.experiments.app.estimate import RunWork, StudyEstimate, calibrate_all, estimate
from evolution.experiments.app.study import (
    StudyPlan,
    prepare_study,
    run_study,
    study_configs,
    study_evaluator,
)
from evolution.experiments.loop.registry import PAPER_SCENARIOS
from evolution.reporting import report
from revolve_env.tasks import TASKS

__all__ = ["StudyDisplay", "add_study"]

class StudyDisplay:
    """The progress of every run of a study on one display, each run labelled by its experiment.

    Args:
        plan: The prepared study (its unfinished runs are registered, experiment by experiment).
        stream: Where to draw (default stderr).
        weights: Cost of one birth of each experiment, by name (the ETA weighs births by it;
            :meth:`StudyEstimate.weights`); default: all alike.
        tensorboard: Also write each run's scalars for TensorBoard, in
            ``tensorboard/<experiment>/run<N>`` (:class:`TensorBoardLogger`); ``None``: not.

    Raises:
        TensorBoardUnavailableError: ``tensorboard`` is given, but its packages are missing.
    """

    def __init__(self, plan: StudyPlan, stream: Any = None,
                 weights: Mapping[str, float] | None = None,
                 tensorboard: Path | None = None) -> None:
        self.loggers = {} if tensorboard is None else {
            e.name: TensorBoardLogger(tensorboard / e.name) for e in plan.experiments if e.jobs}
        self.display = ProgressDisplay(stream=stream)
        for experiment in plan.experiments:
            if experiment.jobs:
                self.display.add_runs({job.run_id: experiment.config.births
                                       for job in experiment.jobs},
                                      experiment.done, label=experiment.name,
                                      weight=(weights or {}).get(experiment.name, 1.0))

    def __call__(self, experiment: str, event: ProgressEvent) -> None:
        """Take one event of run ``event.run_id`` of ``experiment``."""
        self.display(event, label=experiment)
        if experiment in self.loggers:
            self.loggers[experiment](event)

    def close(self) -> None:
        """End the display and write the TensorBoard files."""
        self.display.close()
        for logger in self.loggers.values():
            logger.close()


def _say(text: str) -> None:
    print(text, flush=True)


def _again(args: argparse.Namespace, plan: StudyPlan) -> str:
    """The command that continues this study (same settings, same way of running).

    With ``--trust-task-code`` when an experiment is scored by a task class of the user's own:
    continuing imports it from the stored settings, which needs the user's word.
    """
    words = ["revolve", "study", "--out", args.out, "--runs", str(args.runs), "--births",
             str(args.births), "--seed", str(args.seed)]
    for item in args.set or []:
        words += ["--set", item]
    if args.only:
        words += ["--only", *args.only]
    if args.workers:
        words += ["--workers", str(args.workers)]
    if args.evaluator != "local":
        words += ["--evaluator", args.evaluator]
    if args.ray_address:
        words += ["--ray-address", args.ray_address]
    if args.no_estimate:
        words += ["--no-estimate"]
    if args.tensorboard:
        words += ["--tensorboard", args.tensorboard]
    if args.trust_task_code or any(e.config.task is not None
                                   and e.config.task.get("name") not in TASKS
                                   for e in plan.experiments):
        words += ["--trust-task-code"]
    return shlex.join(words)


def _describe(plan: StudyPlan) -> None:
    for e in plan.experiments:
        c = e.config
        left = (f"{len(e.jobs)} run(s) to do" if e.jobs else "finished")
        if e.jobs and any(e.done.values()):
            left += f" ({sum(e.done.values())} births already committed)"
        _say(f"  {e.name}: {c.runs} run(s) x {c.births} births ({c.mode}, "
             f"{c.world.engine}): {left} -> {e.out_dir}")


def _estimate(work: list[RunWork], workers: int) -> StudyEstimate:
    """Calibrate every experiment of ``work`` and print the study's estimated time."""
    configs = list({w.experiment: w.config for w in work}.values())
    _say(f"calibrating {len(configs)} experiment(s) on this machine (robot-seconds per CPU "
         "second, on the start of each one's own run: a few seconds of CPU each; --no-estimate "
         "skips it)...")
    costs, cpu = calibrate_all(configs)
    result = estimate(work, costs, workers, cpu)
    _say("estimated time:")
    for line in result.lines():
        _say(line)
    return result


def _cmd_study(args: argparse.Namespace) -> int:
    if args.ray_address and args.evaluator != "ray":
        raise CliError("--ray-address needs --evaluator ray")
    overrides = parse_set(args.set or [])
    experiments = tuple(args.only) if args.only else PAPER_SCENARIOS
    settings: dict[str, Any] = {
        "runs": args.runs, "births": args.births, "experiments": experiments,
        "overrides": overrides, "seed": args.seed, "evaluator": args.evaluator,
        "workers": args.workers, "ray_address": args.ray_address}
    if args.estimate_only:  # nothing is written: the whole study, as if none of it were done
        configs = study_configs(**settings)
        with closing(study_evaluator(args.evaluator, args.workers, args.ray_address)) as used:
            _estimate([RunWork(c.name, c) for c in configs for _ in range(c.runs)], used.workers)
        return 0
    if args.tensorboard:  # a missing extra or a file in the way, refused before any work
        writable_folder(Path(args.tensorboard), "--tensorboard")
        TensorBoardLogger(args.tensorboard).close()
    plan = prepare_study(args.out, **settings, trust_task_code=args.trust_task_code)
    if args.tensorboard:
        for experiment in plan.experiments:
            writable_folder(Path(args.tensorboard) / experiment.name, "--tensorboard")
    where = "Ray" if args.evaluator == "ray" else f"{args.workers or 'all'} core(s)"
    _say(f"study in {plan.out_dir}: {len(plan.experiments)} experiment(s), {plan.pending} "
         f"unfinished run(s) on {where}")
    _describe(plan)
    if not plan.pending:
        return _run(args, plan, None, None)
    # Made here: the estimate needs its workers (a Ray cluster's CPUs) before the runs start.
    with closing(study_evaluator(args.evaluator, args.workers, args.ray_address)) as used:
        weights = None
        if not args.no_estimate:
            weights = _estimate([RunWork(e.name, e.config, e.done[job.run_id])
                                 for e in plan.experiments for job in e.jobs],
                                used.workers).weights()
        return _run(args, plan, used, weights)


def _run(args: argparse.Namespace, plan: StudyPlan, evaluator: Evaluator | None,
         weights: Mapping[str, float] | None) -> int:
    tensorboard = Path(args.tensorboard) if args.tensorboard else None
    display = StudyDisplay(plan, weights=weights, tensorboard=tensorboard)
    try:
        summary = run_study(plan, display, evaluator)
    except KeyboardInterrupt:
        display.close()
        print(f"revolve study: interrupted; finished work is saved in {plan.out_dir}; continue "
              f"with: {_again(args, plan)}", file=sys.stderr)
        return EXIT_INTERRUPTED
    display.close()
    for experiment in summary.experiments:
        for r in experiment.runs:
            _say(f"{experiment.out_dir.name} run {r.run_id}: {r.status}, {r.births} births, "
                 f"best {metres(r.best)} m, mean {metres(r.mean)} m, {duration(r.wall_time)}")
    if plan.pending:
        _say(f"runs done in {duration(summary.wall_time)}")
    else:
        _say("every run had finished already")
    result = report(plan.out_dir)
    if not args.quiet:  # --quiet: where the page is, no list of files
        _say(f"report of {len(result.experiments)} experiment(s) in {result.out_dir}:")
        for path in (*result.figures, *result.tables):
            _say(f"  {path}")
    _say(f"open in a browser: {result.page}")
    return 0


def add_study(sub: argparse._SubParsersAction[Any]) -> None:
    """Register ``revolve study`` (its options' defaults shown in ``--help``)."""
    p = sub.add_parser(
        "study",
        description="Run the paper's study: scenario1, scenario2, scenario3, baseline_a and "
                    "baseline_b, --runs runs of --births births each, all runs side by side on "
                    "one pool of workers (or Ray), into OUT/<name>/results.sqlite; then write "
                    "the figures and tables into OUT/report/. The settings are kept in "
                    "OUT/study.json: the same command continues an interrupted study, leaving "
                    "finished experiments alone, and other settings into OUT are refused.",
        epilog="births 60 with population 15 is 4 offline generations (15 + 3 x 15) for "
               "scenario 1 and the baselines, 45 generations of one child for scenario 2, and "
               "45 births after the first 15 in scenario 3's world. Measured on two shared cores: "
               "2 min on MuJoCo (the default), 17 min with --set world.engine=pybullet. "
               "Example: revolve study --runs 3 --births 60",
    )
    p.add_argument("--out", default="results/study", metavar="DIR", help="the study's folder")
    p.add_argument("--runs", type=positive_int, default=3, help="runs per experiment")
    p.add_argument("--births", type=positive_int, default=60,
                   help="births per run (the initial robots count)")
    p.add_argument("--seed", type=non_negative_int, default=0,
                   help="experiment seed of every experiment")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="change a config key in every experiment, e.g. --set "
                        "world.engine=pybullet or --set evaluation_time=6 (repeatable)")
    p.add_argument("--only", nargs="+", metavar="NAME",
                   help="run only these experiments (shipped names or TOML paths; default: "
                        f"{' '.join(PAPER_SCENARIOS)}); a later call may add the others")
    p.add_argument("--workers", type=workers, default=0,
                   help="runs at once: worker processes, 0: all cores (Ray: CPUs of a local "
                        "instance)")
    p.add_argument("--evaluator", choices=("local", "ray"), default="local",
                   help="local processes, or Ray tasks (pip install '.[ray]')")
    tensorboard_argument(p)
    p.add_argument("--ray-address", metavar="ADDRESS",
                   help="an existing Ray cluster, e.g. auto or HOST:PORT (default: start a "
                        "local instance)")
    trust_argument(p, pickled=False)
    when = p.add_mutually_exclusive_group()
    when.add_argument("--estimate-only", action="store_true",
                      help="calibrate, print the study's estimated time and exit, writing "
                           "nothing")
    when.add_argument("--no-estimate", action="store_true",
                      help="start at once, without the calibration (a few seconds of CPU) "
                           "that estimates the time and weighs the ETA")
    p.set_defaults(handler=_cmd_study)

