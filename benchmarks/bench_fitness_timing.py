"""The fitness under each pose rate and timing, on both engines: the evidence for the defaults.

For the example walkers, ``--robots`` random robots (``evolution.random_robot``, seeded) and
the rocking robot of issue 27 (``--rocking``, evaluated with seed 1), under each timing
(:data:`revolve_env.world.config.TIMINGS`: ``default`` and ``revolve2018``), on pybullet and
MuJoCo, prints for each pose rate (every control period, and 5 Hz):

* each walker's and the rocking robot's fitness ``v + 5 s`` (metres) and shaking measure (the
  path summed at every control period over the path at the pose rate);
* over the random robots: mean fitness, median and 90th percentile of the shaking measure (of
  robots that moved at all: path > 1 cm), and Spearman's rank correlation of fitness between
  the engines; blow-ups per engine.

Each robot is evaluated once per engine and timing (3 s insertion + 12 s, heading 0); the pose
rates are computed from the same trajectory (a pose every ``stride`` rows), exactly as
``evaluate(task=Locomotion(pose_rate=...))`` computes them.

Usage: ``python benchmarks/bench_fitness_timing.py [--robots 200] [--seed 2]
[--timings default revolve2018] [--rocking ../shared/cases/rocking_robot.json]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.stats import spearmanr

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env import evaluate_many
from revolve_env.body.examples import EXAMPLES
from revolve_env.body.robot import Robot
from revolve_env.body.serialize import from_json
from revolve_env.fitness import fitness_terms
from revolve_env.fitness.sampling import EVERY_PERIOD, pose_stride, shaking
from revolve_env.tasks import Locomotion
from revolve_env.world import WorldConfig
from revolve_env.world.config import TIMINGS

ENGINES = ("pybullet", "mujoco")
WALKERS = ("spider", "gecko", "snake")
RATES: tuple[float | str, ...] = (EVERY_PERIOD, 5.0)


def _terms(path: NDArray[np.float64], stride: int) -> tuple[float, float]:
    """Fitness ``v + 5 s`` at a pose every ``stride`` rows, and its shaking measure."""
    k = (len(path) - 1) // stride * stride + 1
    poses = path[:k:stride]
    terms = fitness_terms(poses)
    fine = fitness_terms(path[:k]).v
    return terms.fitness, float(shaking(fine, terms.v))


def measure(robots: list[Robot], seeds: list[int], engine: str, config: WorldConfig
            ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_],
                       NDArray[np.float64]]:
    """Fitness and shaking (robots x rates), blow-ups, and every-period path (metres)."""
    results = evaluate_many(robots, seeds=seeds, engine=engine, config=config,
                            task=Locomotion(pose_rate=EVERY_PERIOD))
    f = np.zeros((len(robots), len(RATES)))
    sh = np.ones((len(robots), len(RATES)))
    blown = np.array([r.blow_up is not None for r in results])
    moved = np.zeros(len(robots))
    for i, r in enumerate(results):
        moved[i] = fitness_terms(r.trajectory).v
        if r.blow_up is not None:
            continue
        for j, rate in enumerate(RATES):
            f[i, j], sh[i, j] = _terms(r.trajectory, pose_stride(rate, config.control_period))
    return f, sh, blown, moved


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--robots", type=int, default=200)
    parser.add_argument("--seed", type=int, default=2)
    parser.add_argument("--timings", nargs="+", default=["default", "revolve2018"],
                        choices=list(TIMINGS))
    parser.add_argument("--rocking", default=str(Path(__file__).resolve().parents[2] / "shared"
                                                 / "cases" / "rocking_robot.json"))
    parser.add_argument("--batch", type=int, default=20, help="robots per evaluate_many call")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    randoms = [random_robot(rng, EvolutionConfig()) for _ in range(args.robots)]
    named = [EXAMPLES[w]() for w in WALKERS]
    names = list(WALKERS)
    rocking = Path(args.rocking)
    if rocking.is_file():
        named.append(from_json(rocking.read_text()))
        names.append("rocking")
    seeds = [0] * len(WALKERS) + [1] * (len(named) - len(WALKERS))
    print(f"# bench_fitness_timing: {len(randoms)} random robots (seed {args.seed}), "
          f"3 s + 12 s, heading 0; walkers seed 0, rocking robot seed 1")
    for timing in args.timings:
        config = WorldConfig().with_timing(timing)
        data = {}
        for engine in ENGINES:
            t = time.process_time()
            walk = measure(named, seeds, engine, config)
            parts = [measure(randoms[a:a + args.batch], [0] * len(randoms[a:a + args.batch]),
                             engine, config) for a in range(0, len(randoms), args.batch)]
            rand = tuple(np.concatenate([p[k] for p in parts]) for k in range(4))
            data[engine] = (walk, rand)
            print(f"({timing}, {engine}: {time.process_time() - t:.0f} s CPU)", file=sys.stderr)
        print(f"\n## timing {timing}: physics {config.timestep * 1e3:.3f} ms, control "
              f"{1 / config.control_period:g} Hz, brain {1 / config.brain_dt:g} Hz")
        print("| pose rate | " + " | ".join(f"{n} pyb / mjc (shaking)" for n in names)
              + " | random: mean f pyb / mjc | median shaking pyb / mjc (p90) "
              "| Spearman rho | blow-ups pyb / mjc |")
        print("|" + "---|" * (len(names) + 5))
        for j, rate in enumerate(RATES):
            label = ("every period" if rate == EVERY_PERIOD
                     else f"{rate:g} Hz")
            if rate == EVERY_PERIOD:
                label += f" ({1 / config.control_period:g} Hz)"
            cells = []
            for i in range(len(names)):
                (fp, sp, _, _), (fm, sm, _, _) = data["pybullet"][0], data["mujoco"][0]
                cells.append(f"{fp[i, j]:.2f} / {fm[i, j]:.2f} ({sp[i, j]:.2f} / {sm[i, j]:.2f})")
            (fp, sp, bp, mp), (fm, sm, bm, mm) = data["pybullet"][1], data["mujoco"][1]
            rho = spearmanr(fp[:, j], fm[:, j]).statistic if len(fp) > 2 else float("nan")
            mid = []
            for s, moved in ((sp[:, j], mp), (sm[:, j], mm)):
                s = s[moved > 0.01]
                mid.append(f"{np.median(s):.2f} ({np.percentile(s, 90):.2f})" if s.size else "-")
            print(f"| {label} | " + " | ".join(cells)
                  + f" | {fp[:, j].mean():.3f} / {fm[:, j].mean():.3f} | {mid[0]} / {mid[1]} "
                  f"| {rho:.3f} | {int(bp.sum())} / {int(bm.sum())} |")


if __name__ == "__main__":
    main()
