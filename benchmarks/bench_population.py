"""Population env speed: 1, 10 and 30 robots in one world, spread out and crowded.

Run: ``python benchmarks/bench_population.py [--seconds S] [--sizes 1 10 30]``.

Each world holds the five example robots in turn (spider, gecko, snake, sensor crawler, bar
walker), brain-controlled. Three ways of stepping the same world for ``S`` simulated seconds:

* ``raw``: bare pybullet on the bodies the World built: per control period one
  ``setJointMotorControlArray`` per robot (a sine gait) and the physics substeps; no state is read.
  This is the physics floor.
* ``world``: :class:`revolve_env.world.World` stepping (servo law, core/joint state refresh,
  blow-up check) with sine targets; no sensors, brains or fitness.
* ``env``: :class:`revolve_env.envs.PopulationEnv.step` (brains in one batched call, sensors,
  fitness, trajectories, infos); ``insertion_time=0`` so the fitness is computed every step (the
  costliest case).

Printed per case: simulated seconds per wall second (>= 1 is faster than real time), robot-seconds
per CPU-second (process time, so other load on the machine matters less), and the env's CPU time
over raw's. "spread": robots 1.5 m apart on a grid (no contacts between robots); "crowded": random
free places within a disc just large enough to hold them (robots collide).
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

import numpy as np
import pybullet as pb

from revolve_env.body.examples import EXAMPLES
from revolve_env.envs.population import PopulationEnv, footprint_radius


def make_env(n: int, layout: str, seed: int = 0) -> PopulationEnv:
    robots = [make() for make in EXAMPLES.values()]
    robots = [robots[k % len(robots)] for k in range(n)]
    if layout == "spread":
        side = math.ceil(math.sqrt(n))
        env = PopulationEnv(insertion_time=0.0, initial_robots=[
            {"robot": r, "position": (1.5 * (k % side), 1.5 * (k // side))}
            for k, r in enumerate(robots)])
    else:
        area = sum(math.pi * (footprint_radius(r) + 0.02) ** 2 for r in robots)
        radius = math.sqrt(area / math.pi / 0.45)  # about 45 % of the disc covered
        env = PopulationEnv(insertion_time=0.0, initial_robots=robots, birth_radius=radius,
                            birth_clearance=0.0, max_placement_tries=5000)
    env.reset(seed=seed)
    return env


def timed(run: Callable[[], None]) -> tuple[float, float]:
    """Wall and CPU seconds of ``run()``."""
    w, c = time.perf_counter(), time.process_time()
    run()
    return time.perf_counter() - w, time.process_time() - c


def bench_env(env: PopulationEnv, steps: int) -> tuple[float, float]:
    def run() -> None:
        for _ in range(steps):
            env.step({})

    return timed(run)


def bench_world(env: PopulationEnv, steps: int) -> tuple[float, float]:
    world = env.world
    handles = [env._roster.member(a, "bench").handle for a in env.agents]
    dt = env.config.control_period

    def run() -> None:
        for k in range(steps):
            phase = math.sin(2 * math.pi * k * dt)
            for h in handles:
                world.set_targets(h, np.full(world.n_outputs(h), phase))
            world.step(1)

    return timed(run)


def bench_raw(env: PopulationEnv, steps: int) -> tuple[float, float]:
    world = env.world
    cid = world.backend.client_id  # type: ignore[attr-defined]  # drive pybullet directly
    states = [world.backend._bodies[world._robots[env._roster.member(a, "bench").handle].key]  # type: ignore[attr-defined]
              for a in env.agents]
    c = env.config
    dt = c.control_period

    def run() -> None:
        for k in range(steps):
            vel = 5.0 * math.cos(2 * math.pi * k * dt)
            for s in states:
                if s.active_joints:
                    pb.setJointMotorControlArray(
                        s.body, s.active_joints, pb.VELOCITY_CONTROL,
                        targetVelocities=[vel] * len(s.active_joints),
                        forces=[c.max_torque] * len(s.active_joints), physicsClientId=cid)
            for _ in range(c.substeps):
                pb.stepSimulation(physicsClientId=cid)

    return timed(run)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated seconds per case")
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 10, 30])
    args = parser.parse_args()
    print(f"{'robots':>6} {'layout':>8} {'mode':>6} {'sim s/wall s':>13} {'robot-s/CPU-s':>14} "
          f"{'CPU / raw':>10}")
    for n in args.sizes:
        for layout in ("spread", "crowded"):
            raw_cpu = None
            for mode, bench in (("raw", bench_raw), ("world", bench_world), ("env", bench_env)):
                env = make_env(n, layout)
                dt = env.config.control_period
                steps = max(1, round(args.seconds / dt))
                bench_env(env, round(0.5 / dt))  # let the robots land before timing
                wall, cpu = bench(env, steps)
                sim = steps * dt
                raw_cpu = cpu if mode == "raw" else raw_cpu
                assert raw_cpu is not None
                print(f"{n:>6} {layout:>8} {mode:>6} {sim / wall:>13.2f} {n * sim / cpu:>14.1f} "
                      f"{cpu / raw_cpu:>10.2f}", flush=True)
                env.close()


if __name__ == "__main__":
    main()
