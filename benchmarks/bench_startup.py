"""How long ``revolve`` takes to start: CPU of ``--version``, ``--help`` and the imports.

Run: ``python benchmarks/bench_startup.py [--repeats 5]``.

Each line is a fresh interpreter (``sys.executable``, the checkout on ``PYTHONPATH``) timed by
its children's CPU (user + system, :func:`os.wait4`), best and median over ``--repeats``:

* ``python -c pass``: the interpreter alone (site packages and their ``.pth`` files included),
  the floor under every other line;
* ``import evolution``: the evolutionary library (numpy, the robot description, Gymnasium's
  registration of the envs);
* ``import evolution.cli``: the command line, which loads no command's module;
* ``revolve --version`` and ``revolve --help``, as ``python -m evolution.cli``;
* ``import evolution.experiments`` and ``import evolution.reporting``: what a command that runs
  or reports loads on top (scipy, matplotlib).

CPU, not wall time: on a shared machine the wall time says more about the other jobs.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CASES = {
    "python -c pass": ["-c", "pass"],
    "import evolution": ["-c", "import evolution"],
    "import evolution.cli": ["-c", "import evolution.cli"],
    "revolve --version": ["-m", "evolution.cli", "--version"],
    "revolve --help": ["-m", "evolution.cli", "--help"],
    "import evolution.experiments": ["-c", "import evolution.experiments"],
    "import evolution.reporting": ["-c", "import evolution.reporting"],
}


def cpu_seconds(args: list[str]) -> float:
    """User + system CPU of one run of ``python ARGS``, seconds."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    process = subprocess.Popen([sys.executable, *args], env=env, stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(process.pid, 0)
    process.returncode = os.waitstatus_to_exitcode(status)
    if process.returncode != 0:
        raise SystemExit(f"python {' '.join(args)} exited with {process.returncode}")
    return usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="runs of each case")
    args = parser.parse_args()
    print(f"{'case':<30} {'best':>8} {'median':>8}  (CPU seconds, {args.repeats} runs)")
    for name, case in CASES.items():
        times = [cpu_seconds(case) for _ in range(args.repeats)]
        print(f"{name:<30} {min(times):8.3f} {statistics.median(times):8.3f}", flush=True)


if __name__ == "__main__":
    main()
