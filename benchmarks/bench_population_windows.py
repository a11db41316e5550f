"""The population env's step and advance with the compiled fitness windows and with NumPy's.

Usage: ``python benchmarks/bench_population_windows.py [--robots 30] [--repeats 8]``.

``--robots`` random robots in one MuJoCo world (``bench_engines.py``'s crowd: a grid 1.2 m apart,
landed for 30 control periods), restored from one snapshot before every timing; the env's
``step`` (every agent's five dicts) and ``advance`` (what the online world called per period),
each with the compiled window push (:func:`revolve_env.world.compiled.windows_kernel`) and with
NumPy's; ``advance_periods`` (what the online world calls now: all the periods in compiled calls,
on an env without trajectories, as the online world makes it); and the bare replay of the same
periods (raw ``mj_step``), the sides alternating in this process. Prints the best CPU time per
control period of each and its ratio to raw.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from bench_engines import alternate, crowd_env, on_a_grid, random_robots, recorded

from revolve_env.envs.population import PopulationEnv
from revolve_env.world import compiled


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=30)
    parser.add_argument("--repeats", type=int, default=8)
    parser.add_argument("--seconds", type=float, default=2.0)
    args = parser.parse_args()
    if compiled.windows_kernel() is None:
        sys.exit("the compiled rollout is not usable here: nothing to compare")
    n = args.robots
    initial = on_a_grid(random_robots(n, seed=1))
    fast = crowd_env(initial)
    real = compiled.windows_kernel
    compiled.windows_kernel = lambda: None  # the env made now keeps NumPy's windows
    try:
        slow = crowd_env(initial, landing=0)  # (restored from fast's snapshot before each run)
    finally:
        compiled.windows_kernel = real
    loop = crowd_env(initial, trajectory_length=0)  # the online world's env: no trajectories
    start, loop_start = fast.snapshot(), loop.snapshot()
    ticks = round(args.seconds / fast.config.control_period)
    raw, check = recorded(fast, ticks)

    def timed(env: PopulationEnv, how: str) -> float:
        env.restore(start)
        step = env.step if how == "step" else env.advance
        cpu = time.process_time()
        for _ in range(ticks):
            step({})
        return time.process_time() - cpu

    def periods() -> float:
        loop.restore(loop_start)
        cpu = time.process_time()
        ended = loop.advance_periods(ticks)
        cpu = time.process_time() - cpu
        assert not ended and loop.steps == 30 + ticks
        return cpu

    sides = {"step, compiled windows": lambda: timed(fast, "step"),
             "step, NumPy windows": lambda: timed(slow, "step"),
             "advance, compiled windows": lambda: timed(fast, "advance"),
             "advance, NumPy windows": lambda: timed(slow, "advance"),
             "advance_periods": periods,
             "raw mj_step": raw.run}
    best = alternate(sides, args.repeats)
    load = " ".join(Path("/proc/loadavg").read_text().split()[:3])
    print(f"{n} robots, {ticks} control periods, best CPU of {args.repeats} (replay {check}; "
          f"load average {load}):")
    for name, cpu in best.items():
        print(f"  {name:<27} {cpu / ticks * 1e6:7.0f} us per period  "
              f"{cpu / best['raw mj_step']:.3f}x raw")
    fast.close()
    slow.close()
    loop.close()


if __name__ == "__main__":
    main()
