"""Training Center benchmark: learner evaluations per second, and learning vs no learning.

Prints:

1. CMA-ES candidate evaluations per second (brain-driven,
   ``evolution.evaluation.pool.evaluate_task``) with 1 and 2 worker processes, and the simulated
   seconds per wall-clock second.
2. Inborn vs learned fitness of a few random robots (CMA-ES and the random-search baseline, the
   same budget).
3. A small offline evolution (scenario 1 shape, scaled down) with and without infancy learning:
   best and mean fitness of the population after every generation.

and writes ``learning_comparison.png`` (panels 2 and 3) next to ``--out``.

Usage: ``python benchmarks/bench_learning.py [--quick] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from evolution.config import EvolutionConfig
from evolution.evaluation import EvalTask, LocalEvaluator, evaluate_task
from evolution.experiments import ExperimentConfig, run
from evolution.learning import (
    CandidateEvaluation,
    CMAESLearner,
    RandomSearchLearner,
    TrainingCenter,
)
from evolution.random_robot import random_robot
from revolve_env.body.examples import EXAMPLES
from revolve_env.body.serialize import to_json
from revolve_env.brain import get_params


def evaluations_per_second(workers: int, evaluations: int, seconds: float) -> tuple[float, float]:
    """CMA-ES on the gecko: (evaluations per wall second, simulated seconds per wall second)."""
    evaluation = CandidateEvaluation(insertion=0.5, seconds=seconds, workers=workers)
    learner = CMAESLearner(popsize=8, evaluation=evaluation)
    budget = evaluations * evaluation.cost
    start = time.perf_counter()
    result = learner.learn(EXAMPLES["gecko"](), budget, np.random.default_rng(0))
    wall = time.perf_counter() - start
    return result.evaluations / wall, result.sim_seconds / wall


def random_robots(n: int, seed: int) -> list:
    rng = np.random.default_rng(seed)
    robots = []
    config = EvolutionConfig(initial_parts_mean=8.0)
    while len(robots) < n:
        robot = random_robot(rng, config)
        if get_params(robot).size:
            robots.append(robot)
    return robots


def learned_vs_inborn(robots: list, budget: float, evaluation: CandidateEvaluation) -> dict:
    """Inborn and learned fitness per robot, for CMA-ES and random search on one budget."""
    rows: dict[str, list[tuple[float, float]]] = {"CMA-ES": [], "random search": []}
    for i, robot in enumerate(robots):
        for name, learner in (("CMA-ES", CMAESLearner(popsize=4, evaluation=evaluation)),
                              ("random search", RandomSearchLearner(batch_size=4,
                                                                   evaluation=evaluation))):
            result = learner.learn(robot, budget, np.random.default_rng(i))
            # Re-evaluate the learned robot with a seed the learner never saw.
            task = EvalTask(i, to_json(result.robot), evaluation.insertion, evaluation.seconds, 99)
            learned = evaluate_task(task).fitness or 0.0
            rows[name].append((result.inborn_fitness, learned))
    return rows


def evolution_curves(config: ExperimentConfig, center: TrainingCenter | None, workers: int) -> list:
    events: list = []
    with tempfile.TemporaryDirectory() as tmp, LocalEvaluator(workers) as evaluator:
        run(config, Path(tmp) / "out", events.append, evaluator=evaluator, infancy=center)
    return [(e.births, e.best, e.mean) for e in events if not e.finished]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller sizes (about a minute)")
    parser.add_argument("--out", type=Path, default=Path("."), help="folder of the PNG")
    args = parser.parse_args()
    quick = args.quick

    print("== 1. learner evaluations per second (CMA-ES, gecko, 0.5 s + 3 s per evaluation)")
    n = 9 if quick else 17
    for workers in (1, 2):
        eps, speed = evaluations_per_second(workers, n, 3.0)
        print(f"workers={workers}: {eps:6.2f} evaluations/s, {speed:6.1f} simulated s per wall s")

    print("\n== 2. inborn vs learned fitness of random robots "
          "(budget: 13 evaluations of 0.5 s + 4 s)")
    evaluation = CandidateEvaluation(insertion=0.5, seconds=4.0)
    budget = 13 * evaluation.cost
    robots = random_robots(3 if quick else 6, seed=1)
    rows = learned_vs_inborn(robots, budget, evaluation)
    for name, pairs in rows.items():
        inborn = np.array([p[0] for p in pairs])
        learned = np.array([p[1] for p in pairs])
        print(f"{name:14s} inborn mean {inborn.mean():.3f} m, learned mean {learned.mean():.3f} m, "
              f"gain {np.mean(learned - inborn):+.3f} m; per robot: "
              + ", ".join(f"{a:.2f}->{b:.2f}" for a, b in pairs))

    print("\n== 3. offline evolution with and without learning (scaled-down scenario 1)")
    births = 12 if quick else 20
    config = ExperimentConfig(name="learning-comparison", population_size=4, offspring_size=4,
                              births=births, insertion=0.5, evaluation_time=4.0, fertile_age=4.5,
                              diversity_interval=0, seed=3,
                              evolution=EvolutionConfig(initial_parts_mean=8.0))
    center = TrainingCenter(CMAESLearner(popsize=4, evaluation=evaluation), 9 * evaluation.cost)
    curves = {}
    for label, hook in (("no learning", None), ("CMA-ES infancy", center)):
        start = time.perf_counter()
        curves[label] = evolution_curves(config, hook, workers=2)
        wall = time.perf_counter() - start
        final = curves[label][-1]
        print(f"{label:15s} after {final[0]} births: best {final[1]:.3f} m, mean {final[2]:.3f} m "
              f"({wall:.0f} s wall)")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4))
    width = 0.27
    x = np.arange(len(robots))
    ax1.bar(x - width, [p[0] for p in rows["CMA-ES"]], width, label="inborn")
    ax1.bar(x, [p[1] for p in rows["random search"]], width, label="random search")
    ax1.bar(x + width, [p[1] for p in rows["CMA-ES"]], width, label="CMA-ES")
    ax1.set_xlabel("random robot")
    ax1.set_ylabel("fitness v + 5 s over 4 s (m)")
    ax1.set_title(f"infancy learning, budget {budget:.0f} simulated s")
    ax1.legend()
    for label, points in curves.items():
        b = [p[0] for p in points]
        line = ax2.plot(b, [p[1] for p in points], label=f"{label}: best")[0]
        ax2.plot(b, [p[2] for p in points], "--", color=line.get_color(), label=f"{label}: mean")
    ax2.set_xlabel("births")
    ax2.set_ylabel("population fitness (m)")
    ax2.set_title("offline evolution (4+4), with and without learning")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "learning_comparison.png"
    fig.savefig(path, dpi=100)
    print(f"\nwrote {path}")
    if not all(math.isfinite(p[1]) for c in curves.values() for p in c):
        print("note: a run had no finite fitness at some commit point")


if __name__ == "__main__":
    main()
