"""The population env's five dicts: the compiled build against main's, and advance, per period.

Usage: ``python benchmarks/bench_population_dicts.py [--robots 30] [--repeats 8]``.

``--robots`` random robots in one MuJoCo world (``bench_population_windows.py``'s crowd),
restored from one snapshot before every timing; three sides on the same periods: ``step`` as it
is (the living agents' dicts made in one compiled call, ``_controller.step_reports``), ``step``
with the dicts built as main built them before the bulk build (``report_step`` as it was, kept in
``tests/population_dicts_reference.py`` as the reference the env's test compares against), and
``advance`` (no dicts), with raw ``mj_step`` of the same periods.

1. Whole loops, the sides alternating: the best CPU time per control period of each, its ratio
   to raw and its cost over ``advance``.
2. Period by period: three envs restored from the snapshot, stepped in turn (one period of each,
   then the next), so that a loaded machine's slow moments fall on every side alike: the median
   CPU time of a step, and of its part after the physics (``report_step`` / ``end_step``:
   sensing, scoring and the dicts), over ``--repeats`` x the periods.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the reference

from bench_engines import alternate, crowd_env, on_a_grid, random_robots, recorded
from population_dicts_reference import old_report

import revolve_env.envs.population as population_module


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=30)
    parser.add_argument("--repeats", type=int, default=8)
    parser.add_argument("--seconds", type=float, default=2.0)
    args = parser.parse_args()
    n = args.robots
    initial = on_a_grid(random_robots(n, seed=1))
    env = crowd_env(initial)
    start = env.snapshot()
    ticks = round(args.seconds / env.config.control_period)
    raw, check = recorded(env, ticks)

    bulk, end = population_module.report_step, population_module.end_step
    after: dict[str, list[float]] = {}

    def timed_part(name: str, part: Callable[..., Any]) -> Callable[..., Any]:
        def run(*args: Any) -> Any:
            cpu = time.process_time()
            out = part(*args)
            after[name].append(time.process_time() - cpu)
            return out
        return run

    def timed(name: str, how: str, report: Callable[..., Any]) -> Callable[[], float]:
        def run() -> float:
            population_module.report_step = timed_part(name, report)
            population_module.end_step = timed_part(name, end)
            try:
                env.restore(start)
                step = env.step if how == "step" else env.advance
                cpu = time.process_time()
                for _ in range(ticks):
                    step({})
                return time.process_time() - cpu
            finally:
                population_module.report_step, population_module.end_step = bulk, end
        return run

    sides: dict[str, Callable[[], float]] = {
        "step (compiled)": timed("step (compiled)", "step", bulk),
        "step (main's dicts)": timed("step (main's dicts)", "step", old_report),
        "advance": timed("advance", "advance", bulk),
        "raw mj_step": raw.run}
    after.update((name, []) for name in sides)  # (the whole loops' parts are not printed)
    best = alternate(sides, args.repeats)
    load = " ".join(Path("/proc/loadavg").read_text().split()[:3])
    print(f"{n} robots, {ticks} control periods (replay {check}); whole loops, best CPU of "
          f"{args.repeats} (load average {load}):")
    for name, cpu in best.items():
        over = "" if name == "raw mj_step" else \
            f"  {(cpu - best['advance']) / ticks * 1e6:+5.0f} us over advance"
        print(f"  {name:<20} {cpu / ticks * 1e6:7.0f} us per period  "
              f"{cpu / best['raw mj_step']:.3f}x raw{over}")

    envs = {name: crowd_env(initial, landing=0) for name in list(sides)[:3]}
    whole: dict[str, list[float]] = {name: [] for name in envs}
    after.update((name, []) for name in envs)
    reports = {"step (compiled)": bulk, "step (main's dicts)": old_report, "advance": bulk}
    for _ in range(args.repeats):
        for e in envs.values():
            e.restore(start)
        for _ in range(ticks):
            for name, e in envs.items():
                population_module.report_step = timed_part(name, reports[name])
                population_module.end_step = timed_part(name, end)
                step = e.advance if name == "advance" else e.step
                cpu = time.process_time()
                step({})
                whole[name].append(time.process_time() - cpu)
    population_module.report_step, population_module.end_step = bulk, end
    load = " ".join(Path("/proc/loadavg").read_text().split()[:3])
    print(f"period by period, median CPU of {args.repeats} x {ticks} periods (load average "
          f"{load}):")
    middle = {name: statistics.median(times) for name, times in whole.items()}
    for name in whole:
        print(f"  {name:<20} step {middle[name] * 1e6:6.0f} us "
              f"({(middle[name] - middle['advance']) * 1e6:+4.0f} over advance), after the "
              f"physics {statistics.median(after[name]) * 1e6:5.0f} us")
    for e in envs.values():
        e.close()
    env.close()


if __name__ == "__main__":
    main()
