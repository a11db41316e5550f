"""pybullet's control period on the compiled rules against the NumPy rules, in one process.

Run: ``python benchmarks/bench_pybullet_rules.py [--repeats R] [--robots N]``.

A pybullet :class:`~revolve_env.world.World` keeps its engine calls in Python and takes the rules
of a control period (target clipping, servo law, blow-up screen, IMU and light sensors) from the
compiled extension when it is usable (:class:`revolve_env.world.compiled.Rules`); the NumPy rules
are the fallback. Each row times the same work both ways, the sides alternating in one process
(so under the same load; which goes first alternates), and prints the best CPU time of
``repeats`` per side and their ratio:

* ``evaluate`` of the example spider (3 s insertion + 12 s window);
* ``evaluate_many`` of ``N`` random robots (1 + 4 s each, isolated worlds);
* a world of ``N`` random robots with their brains, 120 control periods, sensors read every
  period (the population env's world without its reports);
* one period's rules alone (target clipping, servo law, screen, IMU and light sensors; no engine
  call), for the spider and for the ``N`` random robots in one world, best of 300-call loops.

Both sides give the same numbers to the bit (tests/world/test_pybullet_rules.py); here the first
three rows also check that their two results are equal.
"""

from __future__ import annotations

import argparse
import math
import time
import timeit
from collections.abc import Callable
from typing import Any
from unittest import mock

import numpy as np

from evolution.config import EvolutionConfig
from evolution.random_robot import random_robot
from revolve_env import evaluate, evaluate_many
from revolve_env.body.examples import spider
from revolve_env.body.robot import Robot
from revolve_env.rollout import Rollout
from revolve_env.world import World, WorldConfig, compiled
from revolve_env.world.blowups import all_calm
from revolve_env.world.sensing import IMU_HIGH, IMU_LOW, imu_readings, light_intensity

PYBULLET = WorldConfig(engine="pybullet")


def _robots(n: int) -> list[Robot]:
    rng = np.random.default_rng(28)
    return [random_robot(rng, EvolutionConfig()) for _ in range(n)]


def _world_with_brains(robots: list[Robot], periods: int) -> bytes:
    with World(PYBULLET) as world:
        run = Rollout(world)
        for i, r in enumerate(robots):
            run.add(r, (1.5 * (i % 6), 1.5 * (i // 6)), 0.0, network=r, relayout=False)
        run.relayout()
        for _ in range(periods):
            run.period(world.sensor_values())
        return world.states.core_pos.tobytes() + world.sensor_values().tobytes()


def _rules_alone(robots: list[Robot], repeats: int) -> tuple[float, float]:
    """Microseconds of one period's rules (targets, servo law, screen, sensors), best of
    ``repeats`` x 300, compiled and NumPy; the engine calls a period also makes (the body read,
    the contacts and link poses the sensors need) are in neither."""
    with World(PYBULLET) as world:
        for i, r in enumerate(robots):
            world.add_robot(r, (1.5 * (i % 6), 1.5 * (i // 6)))
        world.step(10)
        rules = world._rules  # the world's own (private: this bench times its parts)
        assert rules is not None
        lay, s, screen = world._layout, world.states, world._screen
        targets = np.sin(np.arange(lay.n_outputs, dtype=np.float64))
        out = np.empty(lay.n_inputs)
        poses = (world.backend.link_poses(lay.light_link_ids) if lay.light_link_ids.size
                 else None)
        prev = s.core_vel.copy()
        k = world.config.servo_gain / world.config.control_period
        vmax = world.config.max_velocity

        def compiled_rules() -> None:
            rules.clip_targets(targets, world._targets)
            rules.servo(world._targets, s.joint_pos, lay.active_index)
            rules.calm(s, lay.joint_offsets, screen)
            rules.sense(out, lay, s, prev, poses)

        def numpy_rules() -> None:
            world._targets[:] = np.minimum(np.maximum(targets, -1.0), 1.0) * math.radians(
                world.config.range_deg)
            q = s.joint_pos[lay.active_index]
            np.minimum(np.maximum(k * (world._targets - q), -vmax), vmax)
            all_calm(s, screen)
            imu = imu_readings(s.core_vel, prev, s.core_angvel, s.core_rot,
                               world.config.control_period, world.config.gravity)
            out[lay.imu_dest] = np.minimum(np.maximum(imu, IMU_LOW), IMU_HIGH)
            if lay.light_dest.size:
                rows = lay.light_root_rows
                pos, rot = s.core_pos[rows], s.core_rot[rows]
                if poses is not None:
                    pos, rot = np.concatenate((pos, poses[0])), np.concatenate((rot, poses[1]))
                out[lay.light_dest] = light_intensity(
                    pos, rot, lay.light_points, lay.light_facings,
                    np.asarray(world.config.light_position), world.config.light_range)

        best = [float("inf"), float("inf")]
        for _ in range(repeats):
            for side, run in enumerate((compiled_rules, numpy_rules)):
                best[side] = min(best[side], min(timeit.repeat(run, number=300, repeat=3)) / 300)
        return best[0] * 1e6, best[1] * 1e6


def _cpu(run: Callable[[], Any]) -> tuple[float, Any]:
    start = time.process_time()
    out = run()
    return time.process_time() - start, out


def _row(name: str, run: Callable[[], Any], repeats: int) -> None:
    best = {"compiled": float("inf"), "numpy": float("inf")}
    results: dict[str, Any] = {}
    for i in range(repeats):  # which side goes first alternates (it measured slower here)
        for side in ("compiled", "numpy") if i % 2 else ("numpy", "compiled"):
            if side == "numpy":
                with mock.patch.object(compiled, "rules", lambda c: None):
                    cpu, out = _cpu(run)
            else:
                cpu, out = _cpu(run)
            best[side] = min(best[side], cpu)
            results[side] = out
    same = repr(results["compiled"]) == repr(results["numpy"])
    print(f"{name:<58} compiled {best['compiled'] * 1e3:9.1f} ms   NumPy rules "
          f"{best['numpy'] * 1e3:9.1f} ms   NumPy/compiled {best['numpy'] / best['compiled']:.3f}x"
          f"   {'same numbers' if same else 'NUMBERS DIFFER'}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--robots", type=int, default=10)
    args = parser.parse_args()
    if compiled.rules(PYBULLET) is None:
        raise SystemExit("the compiled rules are not usable here (see the log line)")
    robots = _robots(args.robots)
    body = spider()

    def fitness(r: Any) -> Any:
        return (r.fitness.hex(), r.trajectory.tobytes(), r.blow_up)

    _row("spider, evaluate (3 + 12 s)",
         lambda: fitness(evaluate(body, engine="pybullet")), args.repeats)
    _row(f"{args.robots} random robots, evaluate_many (1 + 4 s)",
         lambda: [fitness(r) for r in evaluate_many(robots, engine="pybullet", seconds=4.0,
                                                      insertion=1.0)], args.repeats)
    _row(f"a world of {args.robots} random robots with brains, 120 periods",
         lambda: _world_with_brains(robots, 120), args.repeats)
    for name, bodies in (("the spider", [body]), (f"{args.robots} random robots", robots)):
        fast, slow = _rules_alone(bodies, args.repeats)
        print(f"{'one period of the rules alone, ' + name:<58} compiled {fast:9.1f} us   "
              f"NumPy rules {slow:9.1f} us   NumPy/compiled {slow / fast:.3f}x", flush=True)


if __name__ == "__main__":
    main()
