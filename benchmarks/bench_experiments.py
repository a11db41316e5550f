"""Births per minute of each experiment on this machine, and the wall time of the paper's study.

Usage::

    python benchmarks/bench_experiments.py [--births 45] [--workers 0] [--engine-only]
        [--physics pybullet|mujoco] [--only scenario1 scenario3]

Runs each of the five experiments for ``--births`` births (fresh temporary results directory)
and prints births per minute; with ``--workers 1`` (everything in this process) also the CPU
time per birth, the figure the speed aims compare. ``--engine-only`` replaces the physics by a
constant-cost stand-in to measure the engine's own overhead (operators, selection, diversity,
SQLite). The estimate of the full study (5 experiments x 30 runs x 3000 births) assumes the
offline experiments keep all cores busy with evaluations and online runs go side by side, one
per core.

With ``--workers 1`` it also prints, per experiment, the calibration's estimate of the CPU per
birth (:func:`evolution.experiments.app.estimate.calibrate`, what ``revolve study`` prints before
it starts: robots alive and robot-seconds per CPU second) beside the measured one, and projects
the paper's study from the measured runs onto 2 cores and a 64-core Ray cluster
(:func:`evolution.experiments.app.estimate.estimate`: a run is the unit of parallelism, one run per
core, online runs first; an experiment not measured takes the cost of a measured one of its
mode). The measured run's own length matters: evolved robots grow,
so a run of 300 births is cheaper per birth than one of 3000.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from evolution import experiments
from evolution.evaluation import EvalOutcome, EvalTask, LocalEvaluator, evaluate_task
from evolution.experiments import ExperimentConfig, preset
from evolution.experiments.app.estimate import (
    BirthCost,
    RunWork,
    calibrate,
    estimate,
    run_cpu_seconds,
)
from evolution.experiments.loop.registry import PAPER_SCENARIOS
from revolve_env.body.serialize import to_json

STUDY_RUNS, STUDY_BIRTHS = 30, 3000


def constant_evaluate(task: EvalTask) -> EvalOutcome:
    """No physics: a fitness from the genome's length (measures engine overhead only)."""
    return EvalOutcome(float(len(to_json(task.robot, indent=None)) % 101) / 100.0, 0.0, 0.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--births", type=int, default=45)
    parser.add_argument("--workers", type=int, default=0, help="0: all cores")
    parser.add_argument("--engine-only", action="store_true")
    parser.add_argument("--only", nargs="*", default=list(PAPER_SCENARIOS))
    parser.add_argument("--physics", choices=("pybullet", "mujoco"), default=None,
                        help="the physics engine (default: each config's)")
    args = parser.parse_args()
    cores = args.workers or os.cpu_count() or 1
    function = constant_evaluate if args.engine_only else evaluate_task
    print(f"{'experiment':<12} {'births':>6} {'wall s':>8} {'births/min':>11} {'sim s/wall s':>12}"
          f" {'study h (2 cores)':>18} {'CPU ms/birth':>13}")
    total_hours = 0.0
    # name -> (config, CPU seconds, mean robots alive at the commit points)
    measured: dict[str, tuple[ExperimentConfig, float, float]] = {}
    for name in args.only:
        # One run: births per minute and CPU per birth count that run's births (the shipped
        # configs' 30 runs would run side by side, 30 times the births of the rate printed).
        config = preset(name, births=args.births, workers=cores, runs=1)
        if args.physics is not None:
            config = config.replace(world=dataclasses.replace(config.world,
                                                              engine=args.physics))
        with tempfile.TemporaryDirectory() as tmp, LocalEvaluator(cores, function) as evaluator:
            events: list[Any] = []
            start = time.perf_counter()
            cpu = time.process_time()
            try:
                experiments.run(config, Path(tmp) / "out", events.append, evaluator=evaluator)
            except ImportError as error:
                print(f"{name:<12} unavailable: {error}")
                continue
            wall = time.perf_counter() - start
            cpu = time.process_time() - cpu
        rate = args.births / wall * 60
        speed = events[-1].sim_time / wall
        # On 2 cores: offline runs use every core for evaluations (scaled from `cores` here);
        # online worlds are one process each, two runs side by side.
        rate_2_cores = rate * 2 / cores if config.mode == "offline" else rate * 2
        hours = STUDY_RUNS * STUDY_BIRTHS / rate_2_cores / 60
        total_hours += hours
        per_birth = f"{cpu / args.births * 1e3:.0f}" if cores == 1 else "n/a"
        if cores == 1:
            alive = [e.population_size for e in events if not e.replaying]
            measured[name] = (config, cpu, sum(alive) / max(1, len(alive)))
        print(f"{name:<12} {args.births:>6} {wall:>8.1f} {rate:>11.1f} {speed:>12.1f} "
              f"{hours:>18.1f} {per_birth:>13}")
    print(f"\nfull study ({len(args.only)} experiments x {STUDY_RUNS} runs x "
          f"{STUDY_BIRTHS} births, 2 cores): {total_hours:.0f} h = {total_hours / 24:.1f} days")
    if measured:
        _project(measured)


def _measured_cost(config: ExperimentConfig, cpu: float, alive: float) -> BirthCost:
    """A whole measured run in the calibration's terms: robot-seconds per birth and per CPU-s.

    Online: per conception interval, at the run's mean robots alive (the initial robots are
    born together at time 0).
    """
    births = config.births
    per_birth = config.seconds_per_evaluation
    if config.mode == "online":
        births = max(1, config.births - config.population_size)
        per_birth = alive * config.conception_interval
    return BirthCost(config.mode, config.world.engine, births * per_birth / cpu, per_birth,
                     f"a measured run of {config.births} births",
                     alive if config.mode == "online" else 0.0)


def _project(measured: dict[str, tuple[ExperimentConfig, float, float]]) -> None:
    """Calibration against measurement, and the paper's study projected from the measurement.

    The calibration's robots alive (online: measured at the run's start) and robot-seconds per
    CPU second beside the measured run's; their ratio of CPU per birth says how far off the
    study's estimate is.
    """
    print(f"\n{'experiment':<12} {'measured ms/birth':>18} {'alive':>6} {'robot-s/CPU-s':>14} "
          f"{'calibrated ms/birth':>20} {'alive':>6} {'robot-s/CPU-s':>14} "
          f"{'calibrated/measured':>20}")
    costs: dict[str, BirthCost] = {}
    for name, (config, cpu, alive) in measured.items():
        costs[name] = cost = _measured_cost(config, cpu, alive)
        guess = calibrate(config)
        alive_then = f"{cost.alive:.1f}" if cost.alive else "-"
        print(f"{name:<12} {1e3 * cost.cpu_per_birth:>18.0f} {alive_then:>6} "
              f"{cost.rate:>14.0f} {1e3 * guess.cpu_per_birth:>20.0f} "
              f"{f'{guess.alive:.1f}' if guess.alive else '-':>6} {guess.rate:>14.0f} "
              f"{guess.cpu_per_birth / cost.cpu_per_birth:>20.2f}")
    by_mode = {cost.mode: cost for cost in costs.values()}
    work, study_costs = [], {}
    for name in PAPER_SCENARIOS:
        config = preset(name, births=STUDY_BIRTHS, runs=STUDY_RUNS)
        cost = costs.get(name, by_mode.get(config.mode))
        if cost is None:
            print(f"no measured {config.mode} run: {name} left out of the projection")
            continue
        study_costs[name] = cost
        work += [RunWork(name, config)] * STUDY_RUNS
    longest = max(run_cpu_seconds(w, study_costs[w.experiment]) for w in work)
    print(f"\nthe paper's study ({len(study_costs)} experiments x {STUDY_RUNS} runs x "
          f"{STUDY_BIRTHS} births) from the measured CPU per birth; longest run "
          f"{longest / 3600:.2f} h:")
    for cores in (2, 64):
        result = estimate(work, study_costs, cores)
        waves = math.ceil(len(work) / cores)
        print(f"  {cores:>2} cores: {result.cpu_seconds / 3600:.1f} CPU-h, wall "
              f"{result.wall_seconds / 3600:.2f} h scheduled as the study runs (online first, "
              f"one run per core); at most {waves} wave(s) x the longest run = "
              f"{waves * longest / 3600:.2f} h")


if __name__ == "__main__":
    main()
