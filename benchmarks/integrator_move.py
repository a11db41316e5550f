"""How far MuJoCo's fitness moved when the backend changed integrator: a before/after table.

Run: ``python benchmarks/integrator_move.py [--random 40] [--seed 11] [--seconds 12]``.

The MuJoCo backend stepped with ``implicitfast`` and constraint islands on; it now steps with
the ``discrete`` integrator and islands off (see :mod:`revolve_env.world.mujoco_backend` for
why: touching robots were flung apart and lost). This script evaluates the five example robots
and ``--random`` random robots (:func:`evolution.random_robot.random_robot`, seed ``--seed``) on
their own brains (``revolve_env.evaluate_many``: 3 s insertion, then ``--seconds``, seed 0 each)
with the scene as built now ("after") and with the scene's two options set back ("before"),
and prints each robot's fitness both ways, then the summary: mean and largest change, the rank
correlation of before and after, and blow-ups on each side. Nothing else differs between the
two sides, so the table is the move of that one change.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import mujoco
import numpy as np
from scipy.stats import spearmanr

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env import evaluate_many
from revolve_env.body.examples import EXAMPLES
from revolve_env.body.robot import Robot
from revolve_env.world import mujoco_scene


@contextmanager
def integrator_before() -> Iterator[None]:
    """Scenes built with the options of before: ``implicitfast``, constraint islands on."""
    built = mujoco_scene.scene_spec

    def before(config: object) -> mujoco.MjSpec:
        spec = built(config)  # type: ignore[arg-type]
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_ISLAND)
        return spec

    mujoco_scene.scene_spec = before  # type: ignore[assignment]
    try:
        yield
    finally:
        mujoco_scene.scene_spec = built  # type: ignore[assignment]


def fitness(robots: list[Robot], seconds: float) -> tuple[np.ndarray, list[str | None]]:
    results = evaluate_many(robots, seconds=seconds, engine="mujoco")
    return np.array([r.fitness for r in results]), [r.blow_up for r in results]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--random", type=int, default=40, help="random robots")
    parser.add_argument("--seed", type=int, default=11, help="seed of the random robots")
    parser.add_argument("--seconds", type=float, default=12.0, help="fitness window, s")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    config = EvolutionConfig()
    names = [*EXAMPLES, *(f"random {i}" for i in range(args.random))]
    robots = [make() for make in EXAMPLES.values()]
    robots += [random_robot(rng, config) for _ in range(args.random)]
    with integrator_before():
        before, blown_before = fitness(robots, args.seconds)
    after, blown_after = fitness(robots, args.seconds)
    print(f"MuJoCo fitness (v + 5 s, m; 3 s + {args.seconds:g} s, seed 0): implicitfast + islands"
          " (before) -> discrete, islands off (after)")
    print(f"{'robot':<16}{'before':>10}{'after':>10}{'change':>10}")
    for name, b, a, xb, xa in zip(names, before, after, blown_before, blown_after, strict=True):
        flags = "".join((" blown up before" if xb else "", " blown up after" if xa else ""))
        print(f"{name:<16}{b:>10.3f}{a:>10.3f}{a - b:>+10.3f}{flags}")
    change = after - before
    k = len(EXAMPLES)
    rho = float(spearmanr(before, after).statistic)
    rho_random = float(spearmanr(before[k:], after[k:]).statistic) if args.random > 2 else np.nan
    print(f"examples: mean |change| {np.abs(change[:k]).mean():.3f} m, largest "
          f"{change[:k][np.abs(change[:k]).argmax()]:+.3f} m")
    if args.random:
        r = change[k:]
        print(f"{args.random} random robots: mean fitness {before[k:].mean():.3f} -> "
              f"{after[k:].mean():.3f} m, mean |change| {np.abs(r).mean():.3f} m, median "
              f"{np.median(np.abs(r)):.3f} m, largest {r[np.abs(r).argmax()]:+.3f} m, "
              f"unchanged (< 1 mm) {int((np.abs(r) < 1e-3).sum())}, Spearman rho before/after "
              f"{rho_random:.3f}")
    print(f"all {len(robots)}: Spearman rho before/after {rho:.3f}; blow-ups before "
          f"{sum(x is not None for x in blown_before)}, after "
          f"{sum(x is not None for x in blown_after)}")


if __name__ == "__main__":
    main()
