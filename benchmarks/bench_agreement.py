"""Do the two engines agree on small motions? The rocking robot and 200 random robots on both.

Prints, for pybullet and MuJoCo (``evaluate``: 3 s insertion + 12 s, fitness ``v + 5 s`` in
metres):

1. The rocking robot (``--case``, default ``shared/cases/rocking_robot.json`` beside the checkout;
   evaluate seed 1) and the examples spider, gecko and snake (seed 0): fitness, the core's path
   from poses at every control period (60 Hz) and at 5 Hz (every 12th pose, the paper's pose
   rate), its displacement, and the fitness the 5 Hz path gives.
2. ``--robots`` random robots (``evolution.random_robot`` from ``default_rng(--seed)``, the robots
   of ``bench_engines.py --only rank`` with the same count): Spearman's rank correlation of their
   fitness between the engines, from 60 Hz and from 5 Hz poses; the mean fitness on each engine;
   how many robots differ by more than 1 m; how many hardly move on either engine (fitness
   < 1 cm on both: their order is tremor) and the rank correlation with those counted as tied.
3. With ``--ceiling``: each engine against itself with every robot dropped 0.1 mm higher (a
   change no experiment could control), the rank correlation that chaos alone leaves.

Usage: ``python benchmarks/bench_agreement.py [--robots 200] [--seed 2] [--case FILE]
[--ceiling]``. 200 robots take about 3 CPU minutes (MuJoCo 35 s, pybullet 130 s on this
project's 2-core machine).
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
from revolve_env import EvaluationResult, evaluate, evaluate_many, example
from revolve_env.body.robot import Robot
from revolve_env.body.serialize import from_json
from revolve_env.world import WorldConfig

ENGINES = ("mujoco", "pybullet")
STILL = 0.01
"""Fitness below which a robot hardly moves (metres over 12 s)."""
EVERY = 12
"""Poses kept for the 5 Hz figures: every 12th control period of 1/60 s."""
# The project's shared cases beside the checkout (a checkout, or a worktree one level deeper).
_CASES = [p / "shared" / "cases" / "rocking_robot.json" for p in Path(__file__).resolve().parents]
_CASE = next((case for case in _CASES if case.exists()), None)


def figures(r: EvaluationResult) -> dict[str, float]:
    """Fitness, the 60 Hz and 5 Hz paths, the displacement and the 5 Hz fitness. Metres."""
    xy = r.trajectory[:, :2]
    few = xy[::EVERY]
    v5 = float(np.linalg.norm(np.diff(few, axis=0), axis=1).sum())
    s = float(np.linalg.norm(xy[-1] - xy[0]))
    return {"f": r.fitness, "v60": r.v, "v5": v5, "s": s, "f5": 0.0 if r.blow_up else v5 + 5 * s}


def walkers(case: Path | None) -> None:
    named: list[tuple[str, Robot, int]] = []
    if case is not None:
        named.append(("rocking robot", from_json(case.read_text()), 1))
    named += [(name, example(name), 0) for name in ("spider", "gecko", "snake")]
    print("robot          engine    fitness  path60  path5   displ  f(5 Hz)")
    for name, robot, seed in named:
        for engine in ENGINES:
            d = figures(evaluate(robot, seed=seed, engine=engine))
            print(f"{name:14s} {engine:8s} {d['f']:8.3f} {d['v60']:7.3f} {d['v5']:6.3f} "
                  f"{d['s']:7.3f} {d['f5']:8.3f}")


def _rho(a: NDArray[np.float64], b: NDArray[np.float64]) -> float:
    return float(spearmanr(a, b).statistic)


def agreement(label: str, a: list[dict[str, float]], b: list[dict[str, float]]) -> None:
    for key, what in (("f", "60 Hz"), ("f5", "5 Hz")):
        x = np.array([d[key] for d in a])
        y = np.array([d[key] for d in b])
        still = (x < STILL) & (y < STILL)
        xt, yt = np.where(still, 0.0, x), np.where(still, 0.0, y)
        print(f"  {label}, fitness from {what} poses: Spearman rho {_rho(x, y):.3f}; mean "
              f"{x.mean():.3f} / {y.mean():.3f} m; {int((np.abs(x - y) > 1.0).sum())} differ by "
              f"> 1 m; {int(still.sum())} move < {STILL * 100:g} cm on both (rho with them tied: "
              f"{_rho(xt, yt):.3f})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=200)
    parser.add_argument("--seed", type=int, default=2)
    parser.add_argument("--case", type=Path, default=_CASE)
    parser.add_argument("--ceiling", action="store_true",
                        help="also each engine against itself, dropped 0.1 mm higher")
    args = parser.parse_args()
    walkers(args.case)
    if args.robots < 2:
        return
    rng = np.random.default_rng(args.seed)
    config = EvolutionConfig()
    robots = [random_robot(rng, config) for _ in range(args.robots)]
    runs: dict[str, list[dict[str, float]]] = {}
    for engine in ENGINES:
        cpu = time.process_time()
        runs[engine] = [figures(r) for r in evaluate_many(robots, engine=engine)]
        print(f"{args.robots} random robots on {engine}: {time.process_time() - cpu:.0f} CPU s")
    agreement("MuJoCo / pybullet", runs["mujoco"], runs["pybullet"])
    if args.ceiling:
        for engine in ENGINES:
            higher = WorldConfig(drop_height=WorldConfig().drop_height + 1e-4)
            again = [figures(r) for r in evaluate_many(robots, engine=engine, config=higher)]
            agreement(f"{engine} / itself 0.1 mm higher", runs[engine], again)


if __name__ == "__main__":
    main()
