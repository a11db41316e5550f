"""Births per minute of each experiment on this machine, and the wall time of the paper's study.

Usage::

    python benchmarks/bench_experiments.py [--births 45] [--workers 0] [--engine-only]

Runs each of the five experiments for ``--births`` births (fresh temporary results directory)
and prints births per minute. ``--engine-only`` replaces the physics by a constant-cost stand-in
to measure the engine's own overhead (operators, selection, diversity, SQLite). The estimate of
the full study (5 experiments x 30 runs x 3000 births) assumes the offline experiments keep all
cores busy with evaluations and online runs go side by side, one per core.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from evolution import experiments
from evolution.evaluation import EvalOutcome, EvalTask, LocalEvaluator, evaluate_task
from evolution.experiments import preset

EXPERIMENTS = ("scenario1", "scenario2", "scenario3", "baseline_a", "baseline_b")
STUDY_RUNS, STUDY_BIRTHS = 30, 3000


def constant_evaluate(task: EvalTask) -> EvalOutcome:
    """No physics: a fitness from the genome's length (measures engine overhead only)."""
    return EvalOutcome(float(len(task.genome) % 101) / 100.0, 0.0, 0.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--births", type=int, default=45)
    parser.add_argument("--workers", type=int, default=0, help="0: all cores")
    parser.add_argument("--engine-only", action="store_true")
    parser.add_argument("--only", nargs="*", default=list(EXPERIMENTS))
    args = parser.parse_args()
    cores = args.workers or os.cpu_count() or 1
    function = constant_evaluate if args.engine_only else evaluate_task
    print(f"{'experiment':<12} {'births':>6} {'wall s':>8} {'births/min':>11} {'sim s/wall s':>12}"
          f" {'study h (2 cores)':>18}")
    total_hours = 0.0
    for name in args.only:
        config = preset(name, births=args.births, workers=cores)
        with tempfile.TemporaryDirectory() as tmp, LocalEvaluator(cores, function) as evaluator:
            events: list = []
            start = time.perf_counter()
            try:
                experiments.run(config, Path(tmp) / "out", events.append, evaluator=evaluator)
            except ImportError as error:
                print(f"{name:<12} unavailable: {error}")
                continue
            wall = time.perf_counter() - start
        rate = args.births / wall * 60
        speed = events[-1].sim_time / wall
        # On 2 cores: offline runs use every core for evaluations (scaled from `cores` here);
        # online worlds are one process each, two runs side by side.
        rate_2_cores = rate * 2 / cores if config.mode == "offline" else rate * 2
        hours = STUDY_RUNS * STUDY_BIRTHS / rate_2_cores / 60
        total_hours += hours
        print(f"{name:<12} {args.births:>6} {wall:>8.1f} {rate:>11.1f} {speed:>12.1f} "
              f"{hours:>18.1f}")
    print(f"\nfull study ({len(args.only)} experiments x {STUDY_RUNS} runs x "
          f"{STUDY_BIRTHS} births, 2 cores): {total_hours:.0f} h = {total_hours / 24:.1f} days")


if __name__ == "__main__":
    main()
