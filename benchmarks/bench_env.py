"""Cost of the single-robot env against raw pybullet stepping, and of a 30-robot world's tick.

Run: ``python benchmarks/bench_env.py [--seconds S] [--repeats R]``.

For the example spider (17 parts) and a 20-part robot (the spider with bricks on three feet):

* env: ``gymnasium.make("revolve_env/Locomotion-v0")`` stepped with a fixed sinusoidal action,
  episodes reset when they end;
* raw: the very same multibody in a bare pybullet client loop with no env and no World around it:
  per control period one ``getJointStates``, one ``setJointMotorControlArray`` (the same servo
  law) and ``substeps`` calls of ``stepSimulation`` (1/240 s physics, 1/60 s control);
* ratio env / raw wall time per simulated second (the env's overhead; the aim is <= 1.2).

:func:`world_tick_breakdown` times a 30-robot world's control tick (sensors, controller, targets,
physics) so the controller's share can be read off. Figures are the best of ``repeats`` runs,
which filters out other processes on a shared machine; the env/raw ratio is also given in
process CPU time, which other processes disturb less than wall time.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import pybullet as pb

import revolve_env.envs  # noqa: F401  (registers the env)
from revolve_env.body.examples import EXAMPLES, spider
from revolve_env.body.robot import Node, PartType, Robot
from revolve_env.body.validate import validate
from revolve_env.brain import BatchController
from revolve_env.envs import LOCOMOTION_ID
from revolve_env.world import World, WorldConfig

PYBULLET = WorldConfig(engine="pybullet")  # what this script measures (MuJoCo is the default)


def twenty_part_robot() -> Robot:
    """The example spider with a brick added under three of its feet (20 parts, 8 servos)."""
    robot = spider()
    for slot in (0, 1, 3):
        foot = (slot, 1, 1, 1)
        robot = robot.replace_node((*foot, 1), Node(PartType.BRICK, color=(0.2, 0.45, 0.85)))
    robot = Robot(robot.body, robot.connections, "spider20")
    validate(robot)
    assert robot.num_parts() == 20
    return robot


def _actions(n: int, ticks: int, dt: float) -> np.ndarray:
    t = np.arange(ticks)[:, None] * dt
    return np.sin(2 * math.pi * t + np.arange(n)[None, :]).astype(np.float32)


@dataclass(frozen=True)
class Rate:
    """Simulated seconds per second of wall-clock time and of this process's CPU time."""

    wall: float
    cpu: float


def _rate(simulated: float, wall: float, cpu: float) -> Rate:
    return Rate(simulated / wall, simulated / cpu)


def env_rate(robot: Robot, seconds: float) -> Rate:
    """Simulated seconds per second of the env driven by a fixed action sequence."""
    env = gym.make(LOCOMOTION_ID, robot=robot, engine="pybullet")
    dt = env.unwrapped.config.control_period
    ticks = int(round(seconds / dt))
    actions = _actions(env.action_space.shape[0], ticks, dt)
    env.reset(seed=0)
    start, cpu = time.perf_counter(), time.process_time()
    for a in actions:
        _, _, terminated, truncated, _ = env.step(a)
        if terminated or truncated:
            env.reset()
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    env.close()
    return _rate(ticks * dt, wall, cpu)


def raw_rate(robot: Robot, seconds: float, physics_only: bool = False) -> Rate:
    """Simulated seconds per second of the same multibody in a bare pybullet loop."""
    config = PYBULLET
    dt = config.control_period
    ticks = int(round(seconds / dt))
    with World(config) as world:  # only to build the identical multibody and ground
        h = world.add_robot(robot)
        # the bare client and body below: no World code in the loop
        backend = world.backend
        state = backend._bodies[world._robots[h].key]  # type: ignore[attr-defined]
        cid, body, joints = backend.client_id, state.body, state.active_joints  # type: ignore[attr-defined]
        actions = _actions(len(joints), ticks, dt) * math.radians(config.range_deg)
        k = config.servo_gain / dt
        forces = [config.max_torque] * len(joints)
        substeps = config.substeps
        start, cpu = time.perf_counter(), time.process_time()
        for target in actions:
            if not physics_only:
                q = np.array([s[0] for s in pb.getJointStates(body, joints, physicsClientId=cid)])
                vel = np.clip(k * (target - q), -config.max_velocity, config.max_velocity)
                pb.setJointMotorControlArray(body, joints, pb.VELOCITY_CONTROL,
                                             targetVelocities=vel.tolist(), forces=forces,
                                             physicsClientId=cid)
            for _ in range(substeps):
                pb.stepSimulation(physicsClientId=cid)
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    return _rate(ticks * dt, wall, cpu)


@dataclass(frozen=True)
class TickBreakdown:
    """Wall time of one control tick of a many-robot world, by phase. Seconds."""

    robots: int
    sensors: float
    controller: float
    targets: float
    physics: float

    @property
    def total(self) -> float:
        return self.sensors + self.controller + self.targets + self.physics

    @property
    def controller_share(self) -> float:
        return self.controller / self.total


def world_tick_breakdown(n_robots: int = 30, ticks: int = 120) -> TickBreakdown:
    """Time each phase of a control tick of a world with ``n_robots`` example robots.

    The robots (the example robots in turn) stand on a grid 0.6 m apart and run their own brains
    through one :class:`~revolve_env.brain.BatchController`.
    """
    names = sorted(EXAMPLES)
    config = PYBULLET
    side = math.ceil(math.sqrt(n_robots))
    with World(config) as world:
        brain = BatchController(config.control_period)
        handles = []
        for i in range(n_robots):
            robot = EXAMPLES[names[i % len(names)]]()
            handles.append(world.add_robot(robot, position=(0.6 * (i % side), 0.6 * (i // side))))
            brain.add(robot)
        inputs = np.zeros(brain.n_inputs)
        outputs = np.zeros(brain.n_outputs)
        in_slices = [brain.input_slice(b) for b in brain.handles]
        out_slices = [brain.output_slice(b) for b in brain.handles]
        world.step(10)
        spent = np.zeros(4)
        for _ in range(ticks):
            t0 = time.perf_counter()
            for h, sl in zip(handles, in_slices, strict=True):
                inputs[sl] = world.read_sensors(h)
            t1 = time.perf_counter()
            brain.step(inputs, outputs)
            t2 = time.perf_counter()
            for h, sl in zip(handles, out_slices, strict=True):
                world.set_targets(h, outputs[sl])
            t3 = time.perf_counter()
            world.step(1)
            t4 = time.perf_counter()
            spent += (t1 - t0, t2 - t1, t3 - t2, t4 - t3)
    s = spent / ticks
    return TickBreakdown(n_robots, *map(float, s))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="simulated seconds per run")
    parser.add_argument("--repeats", type=int, default=3, help="runs per figure (best is kept)")
    parser.add_argument("--robots", type=int, default=30, help="robots in the world-tick test")
    args = parser.parse_args()

    dt = WorldConfig().control_period
    print(f"physics 1/{round(1 / WorldConfig().timestep)} s, control 1/{round(1 / dt)} s; "
          f"{args.seconds:g} simulated s per run, best of {args.repeats}")
    print(f"{'robot':<10}{'parts':>6}{'env steps/s':>13}{'env sim s/s':>13}"
          f"{'raw sim s/s':>13}{'physics-only':>14}{'env/raw wall':>14}{'env/raw cpu':>13}")
    for robot in (spider(), twenty_part_robot()):
        runs: dict[str, list[Rate]] = {"env": [], "raw": [], "phys": []}
        for _ in range(args.repeats):  # interleaved, so that all three see the same load
            runs["env"].append(env_rate(robot, args.seconds))
            runs["raw"].append(raw_rate(robot, args.seconds))
            runs["phys"].append(raw_rate(robot, args.seconds, physics_only=True))
        best = {k: Rate(max(r.wall for r in v), max(r.cpu for r in v)) for k, v in runs.items()}
        env, raw, phys = best["env"], best["raw"], best["phys"]
        print(f"{robot.name:<10}{robot.num_parts():>6}{env.wall / dt:>13.0f}{env.wall:>13.2f}"
              f"{raw.wall:>13.2f}{phys.wall:>14.2f}{raw.wall / env.wall:>14.3f}"
              f"{raw.cpu / env.cpu:>13.3f}")

    best = min((world_tick_breakdown(args.robots) for _ in range(args.repeats)),
               key=lambda b: b.total)
    print(f"\n{best.robots}-robot world, one control tick (ms): sensors {1e3 * best.sensors:.3f}, "
          f"controller {1e3 * best.controller:.3f}, targets {1e3 * best.targets:.3f}, "
          f"physics {1e3 * best.physics:.3f}, total {1e3 * best.total:.3f}; "
          f"controller share {100 * best.controller_share:.2f} %")


if __name__ == "__main__":
    main()
