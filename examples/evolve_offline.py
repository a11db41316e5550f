"""Evolve robots offline (scenario 1's rules) into a temporary folder, then report on them.

Run from the repository root: ``python examples/evolve_offline.py``.
"""

import tempfile
from pathlib import Path

import evolution

# Scenario 1 (offline mu + lambda = 15 + 15, evaluations of 3 s + 12 s, 3000 births, 30 runs)
# shrunk to a few seconds of work. For real use take `evolution.preset("scenario1")` as it is,
# or raise births, population_size, offspring_size, runs and the times below.
config = evolution.preset(
    "scenario1",
    population_size=4,
    offspring_size=4,
    births=12,              # the initial population counts: 4 initial robots + 2 generations
    insertion=0.5,          # seconds of settling before each evaluation
    evaluation_time=2.0,    # seconds of the fitness window f = v + 5 s
    fertile_age=2.5,        # offline robots are mature once evaluated: <= insertion + evaluation
    diversity_interval=4,   # population diversity every this many births
    runs=1,
    seed=1,
    workers=1,              # worker processes; 0 uses every core
).replace(name="scenario1_small")  # preset's first argument is the shipped name, so rename here

with tempfile.TemporaryDirectory() as tmp:
    out = Path(tmp) / config.name
    # Writes out/results.sqlite as it goes; after a crash evolution.resume(out) continues.
    summary = evolution.run(config, out)
    for run in summary.runs:
        print(f"run {run.run_id}: {run.births} births, best fitness {run.best:.3f} m, "
              f"mean {run.mean:.3f} m, {run.wall_time:.1f} s wall time ({run.status})")

    # Figures and tables (the same as `revolve report OUT`); png only to keep it quick.
    report = evolution.report(out, formats=("png",))
    print(f"report: {len(report.figures)} figures, {len(report.tables)} tables in {report.out_dir}")
    for table in report.tables:
        print("  ", table.name)
