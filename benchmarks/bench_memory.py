"""Memory of a long online run: KB per birth over its births (issue 28, item 4).

Run: ``python benchmarks/bench_memory.py [--births 400] [--after 100] [--engine mujoco]
[--set KEY=VALUE ...] [--tracemalloc]``.

One run of ``scenario3`` (seed 3, the engine given, ``--set`` overrides as ``revolve run``'s, e.g.
``--set conception_interval=3.0`` for a quicker world) is written to a temporary results folder
as ``revolve run`` writes it (one commit and one snapshot file per birth). After every commit
point the process's resident memory (RSS, ``/proc/self/statm``; Linux only) is read, and with
``--tracemalloc`` the memory Python allocated (``tracemalloc``, started at birth ``--after``: it
slows the run about 2x; NumPy's arrays count, the engine's C allocations do not).

Printed: RSS (and on glibc the bytes ``malloc`` holds in use, ``mallinfo2``: RSS growing while they
stay flat is the heap's resident pages, not an allocation) at every ``--every`` births; the growth
per birth after ``--after`` births (a least-squares line through every commit point from there on,
and end minus start), in KB per birth, and the same growth apart from the robots alive (a plane
through births and robots alive: KB per birth at a constant number alive, MB per robot alive; a
world that grows needs more); with ``--tracemalloc``, the traced growth per birth and the ``--top``
allocation sites that grew most between birth ``--after`` and the end. The aim (issue 28): flat
after the first 300 births of a 3000-birth run, <= 20 KB per birth.
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import os
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from evolution import experiments
from evolution.cli.options import parse_set
from evolution.evaluation import LocalEvaluator
from evolution.experiments import ProgressEvent, load_config


def rss_mb() -> float:
    """Resident memory of this process. Megabytes."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6


class _Mallinfo2(ctypes.Structure):
    _fields_ = [(name, ctypes.c_size_t) for name in (
        "arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks", "uordblks",
        "fordblks", "keepcost")]


def malloc_in_use_mb() -> float | None:
    """The bytes glibc's ``malloc`` holds allocated (heap and ``mmap``), ``None`` elsewhere. MB.

    Beside RSS it tells what a run holds from what the heap keeps resident around it
    (fragmentation): RSS growing with this flat is the heap, not an allocation.
    """
    try:
        info = ctypes.CDLL("libc.so.6").mallinfo2  # glibc >= 2.33
    except (OSError, AttributeError):
        return None
    info.restype = _Mallinfo2
    held = info()
    return (held.uordblks + held.hblkhd) / 1e6


def slope(births: list[int], values: list[float]) -> float:
    """Least-squares growth of ``values`` per birth (0 with fewer than two points)."""
    if len(births) < 2:
        return 0.0
    return float(np.polyfit(np.asarray(births, float), np.asarray(values, float), 1)[0])


def per_birth_and_alive(births: list[int], alive: list[int],
                        values: list[float]) -> tuple[float, float] | None:
    """Growth of ``values`` per birth and per robot alive, apart (issue 28, item 4).

    A least-squares plane ``values = a + b * births + c * alive``: ``b`` is the growth per birth
    at a constant number of robots alive, ``c`` the growth per robot alive at a constant birth
    count (a world that grows legitimately needs more memory; a run that keeps something per
    birth shows in ``b``). ``None`` when the robots alive never changed or fewer than three
    points are given (the plane is not determined).
    """
    if len(births) < 3 or len(set(alive)) < 2:
        return None
    x = np.column_stack((np.ones(len(births)), np.asarray(births, float),
                         np.asarray(alive, float)))
    if np.linalg.matrix_rank(x) < 3:
        return None
    coefficients = np.linalg.lstsq(x, np.asarray(values, float), rcond=None)[0]
    return float(coefficients[1]), float(coefficients[2])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--births", type=int, default=400)
    parser.add_argument("--after", type=int, default=100,
                        help="measure the growth from this many births on")
    parser.add_argument("--engine", choices=("pybullet", "mujoco"), default="mujoco")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--every", type=int, default=25, help="print RSS every this many births")
    parser.add_argument("--tracemalloc", action="store_true")
    parser.add_argument("--top", type=int, default=8)
    args = parser.parse_args()
    overrides = {"runs": 1, "seed": 3, "births": args.births, "workers": 1,
                 **parse_set(args.set)}
    overrides["world"] = {**overrides.get("world", {}), "engine": args.engine}
    config = load_config("scenario3", overrides)
    points: list[tuple[int, float, float, int]] = []  # births, RSS MB, traced MB, alive
    first: list[tracemalloc.Snapshot] = []
    held: list[float] = []  # malloc's bytes in use at each commit point (glibc), MB

    def progress(event: ProgressEvent) -> None:
        if event.replaying:
            return
        if event.births >= args.after and args.tracemalloc and not tracemalloc.is_tracing():
            gc.collect()
            tracemalloc.start(6)
            first.append(tracemalloc.take_snapshot())
        traced = tracemalloc.get_traced_memory()[0] / 1e6 if tracemalloc.is_tracing() else 0.0
        points.append((event.births, rss_mb(), traced, event.population_size))
        in_use = malloc_in_use_mb()
        if in_use is not None:
            held.append(in_use)
        if event.births % args.every == 0:
            print(f"  births {event.births:>5}  RSS {points[-1][1]:7.1f} MB  alive "
                  f"{event.population_size:>3}"
                  + (f"  malloc in use {in_use:6.1f} MB" if in_use is not None else "")
                  + (f"  traced {traced:6.1f} MB" if traced else ""), flush=True)

    print(f"scenario3, {args.engine}, {args.births} births ({' '.join(args.set) or 'as shipped'})")
    start = time.process_time()
    with tempfile.TemporaryDirectory() as tmp, LocalEvaluator(1) as evaluator:
        experiments.run(config, Path(tmp) / "run", progress, evaluator=evaluator)
        gc.collect()
        last = tracemalloc.take_snapshot() if tracemalloc.is_tracing() else None
    cpu = time.process_time() - start
    later = [p for p in points if p[0] >= args.after]
    births = [p[0] for p in later]
    print(f"CPU {cpu:.0f} s ({cpu / max(1, args.births):.2f} s per birth); "
          f"mean alive {np.mean([p[3] for p in later]) if later else float('nan'):.1f}")
    if len(later) < 2:
        print(f"fewer than two commit points after {args.after} births: raise --births")
        return
    span = births[-1] - births[0]
    rss = [p[1] for p in later]
    print(f"RSS after {births[0]} births: {1e3 * slope(births, rss):.1f} KB per birth "
          f"(least squares), {1e3 * (rss[-1] - rss[0]) / span:.1f} KB per birth (births "
          f"{births[0]} -> {births[-1]}: {rss[0]:.1f} -> {rss[-1]:.1f} MB)")
    if len(held) == len(points):
        in_use = held[len(points) - len(later):]
        print(f"malloc in use after {births[0]} births: {1e3 * slope(births, in_use):.1f} KB per "
              f"birth (least squares; RSS growing faster is the heap's resident pages)")
    apart = per_birth_and_alive(births, [p[3] for p in later], rss)
    if apart is not None:
        print(f"RSS after {births[0]} births, robots alive apart: {1e3 * apart[0]:.1f} KB per "
              f"birth at constant robots alive, {apart[1]:.2f} MB per robot alive")
    if last is not None and first:
        traced = [p[2] for p in later]
        print(f"traced by Python after {births[0]} births: "
              f"{1e3 * slope(births, traced):.1f} KB per birth (least squares)")
        print(f"allocation sites that grew most, births {births[0]} -> {births[-1]}:")
        for stat in last.compare_to(first[0], "lineno")[:args.top]:
            frame = stat.traceback[0]
            print(f"  {stat.size_diff / 1e3:+10.1f} KB {stat.count_diff:+7d} blocks  "
                  f"{frame.filename}:{frame.lineno}")


if __name__ == "__main__":
    main()
