"""MuJoCo against pybullet, and the envs against raw MuJoCo, as ratios measured in one run.

Every ratio compares two sides timed in the same process, alternating (A, B, A, B, ...), and
keeps each side's best CPU time, so both see the same load of a shared machine:

1. ``spider``: the single-robot env (``Locomotion-v0``, the robot's own brain) over raw MuJoCo
   stepping of the very model the env compiled (a bare ``mj_step`` loop with the same servo law
   written to ``ctrl``: no env, no World), and MuJoCo over pybullet per CPU second (the env).
2. ``crowd``: the population env with ``--robots`` random robots in one world, the same two
   ratios (raw: a copy of the env's compiled model and state, stepped bare).
3. ``rank``: ``--rank-robots`` random robots (``evolution.random_robot``) evaluated on both
   engines (3 s insertion + 12 s): Spearman's rank correlation of their fitness, blow-ups and
   NaNs counted per engine.
4. ``memory``: resident memory of one world after 300 and after ``--births`` births (10 alive,
   each living 0.1 s, each newborn a new robot: the child of two living ones, as online), each
   engine in a fresh subprocess.
5. ``robust``: ``--robust-robots`` random robots evaluated in MuJoCo alone: crashes, NaN fitness
   and blow-ups counted. ``crowd-hour``: ``--crowd-minutes`` simulated minutes of ``--robots``
   robots (half walking examples, half random) packed in a 1 m disc with no clearance, each
   replaced after 60 s or when lost, on each of ``--crowd-engines``: blow-ups per 1,000
   robot-lives.
6. ``study``: the paper's full study (5 experiments x 30 runs x 3000 births) on 2 cores with
   MuJoCo: ``--pybullet-study-hours`` (what ``bench_experiments.py`` measured with pybullet)
   divided by the measured speed-ups, offline (``evaluate``, from ``rank``) and online (the
   crowd).

Usage: ``python benchmarks/bench_engines.py [--seconds 3] [--robots 30] [--rank-robots 40]
[--births 3000] [--repeats 2] [--robust-robots 2000] [--crowd-minutes 5]
[--only speed memory robust crowd-hour]``.
"""

from __future__ import annotations

import argparse
import math
import resource
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import mujoco
import numpy as np
from scipy.stats import spearmanr

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from evolution.config import EvolutionConfig
from evolution.operators import reproduce
from evolution.random_robot import random_robot
from revolve_env import LOCOMOTION_ID, evaluate, example, population_env
from revolve_env.body.robot import Robot
from revolve_env.envs.population import PopulationEnv
from revolve_env.world import World, WorldConfig

ENGINES = ("mujoco", "pybullet")


def alternate(sides: dict[str, Callable[[], float]], repeats: int) -> dict[str, float]:
    """Best (least) CPU seconds of each side, the sides run in turn ``repeats`` times."""
    best = {k: math.inf for k in sides}
    for _ in range(repeats):
        for name, run in sides.items():
            best[name] = min(best[name], run())
    return best


def random_robots(n: int, seed: int) -> list[Robot]:
    rng = np.random.default_rng(seed)
    config = EvolutionConfig()
    return [random_robot(rng, config) for _ in range(n)]


# -- 1. one robot ------------------------------------------------------------------------------
def env_cpu(robot: Robot, engine: str, seconds: float) -> float:
    env = gym.make(LOCOMOTION_ID, robot=robot, engine=engine, controller="brain",
                   insertion_time=0.0, evaluation_time=seconds)
    env.reset(seed=0)
    action = np.zeros(env.action_space.shape or (0,), dtype=np.float32)
    cpu = time.process_time()
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(action)
        done = terminated or truncated
    cpu = time.process_time() - cpu
    env.close()
    return cpu


def raw_cpu(world: World, seconds: float) -> float:
    """Bare MuJoCo on a copy of ``world``'s compiled model and state: per control period one
    gather of the hinge angles, RoboGen's servo law into ``ctrl`` and ``mj_step`` x substeps."""
    backend = world.backend
    m = backend._model  # type: ignore[attr-defined]
    d = mujoco.MjData(m)
    src = backend._data  # type: ignore[attr-defined]
    d.qpos[:], d.qvel[:] = src.qpos, src.qvel
    hinges = np.concatenate([backend._robots[world._robots[h].key]  # type: ignore[attr-defined]
                             .hinge_qpos[world._robots[h].active_local] for h in world.handles])
    c = world.config
    k = c.servo_gain / c.control_period
    ticks = round(seconds / c.control_period)
    phase = np.arange(hinges.size)
    cpu = time.process_time()
    for i in range(ticks):
        target = 0.7 * np.sin(2 * np.pi * i * c.control_period + phase)
        d.ctrl[:] = np.clip(k * (target - d.qpos[hinges]), -c.max_velocity, c.max_velocity)
        mujoco.mj_step(m, d, c.substeps)
    return time.process_time() - cpu


def single(seconds: float, repeats: int) -> None:
    robot = example("spider")
    world = World(WorldConfig(engine="mujoco"))
    world.add_robot(robot)
    best = alternate({
        "env mujoco": lambda: env_cpu(robot, "mujoco", seconds),
        "raw mujoco": lambda: raw_cpu(world, seconds),
        "env pybullet": lambda: env_cpu(robot, "pybullet", seconds),
    }, repeats)
    world.close()
    print(f"spider, {seconds:g} simulated s, best CPU of {repeats}: "
          + ", ".join(f"{k} {v:.3f} s" for k, v in best.items()))
    print(f"  env/raw MuJoCo {best['env mujoco'] / best['raw mujoco']:.2f}x; "
          f"MuJoCo env {best['env pybullet'] / best['env mujoco']:.2f}x faster than pybullet "
          f"per CPU second; raw MuJoCo {seconds / best['raw mujoco']:.0f} sim s per CPU s")


# -- 2. a crowd --------------------------------------------------------------------------------
def crowd(n: int, seconds: float, repeats: int) -> tuple[float, float]:
    """Returns the population env's CPU seconds per robot-simulated-second (MuJoCo, pybullet)."""
    robots = random_robots(n, seed=1)
    side = math.ceil(math.sqrt(n))
    initial = [{"robot": r, "position": (1.2 * (i % side), 1.2 * (i // side)), "yaw": 0.0}
               for i, r in enumerate(robots)]

    def make(engine: str) -> PopulationEnv:
        env: PopulationEnv = population_env(engine=engine, initial_robots=initial, max_births=n,
                             insertion_time=0.0)
        env.reset(seed=0)
        for _ in range(30):  # let them land
            env.step({})
        return env

    envs = {e: make(e) for e in ENGINES}
    ticks = round(seconds / envs["mujoco"].config.control_period)

    def run_env(engine: str) -> float:
        env = envs[engine]
        cpu = time.process_time()
        for _ in range(ticks):
            env.step({})
        return time.process_time() - cpu

    best = alternate({
        "env mujoco": lambda: run_env("mujoco"),
        "raw mujoco": lambda: raw_cpu(envs["mujoco"].world, seconds),
        "env pybullet": lambda: run_env("pybullet"),
    }, repeats)
    lost = n - len(envs["mujoco"].agents)
    for env in envs.values():
        env.close()
    print(f"{n} random robots in one world, {seconds:g} simulated s, best CPU of {repeats}: "
          + ", ".join(f"{k} {v:.3f} s" for k, v in best.items()))
    print(f"  population env/raw MuJoCo {best['env mujoco'] / best['raw mujoco']:.2f}x; MuJoCo "
          f"{best['env pybullet'] / best['env mujoco']:.2f}x faster than pybullet per CPU second; "
          f"MuJoCo {seconds / best['env mujoco']:.1f}x real time on one core; "
          f"{lost} robots lost to blow-ups in MuJoCo")
    return best["env mujoco"] / (n * seconds), best["env pybullet"] / (n * seconds)


# -- 3. same science ---------------------------------------------------------------------------
def rank(n: int) -> float:
    """Returns pybullet's evaluate() CPU time over MuJoCo's."""
    robots = random_robots(n, seed=2)
    fitness: dict[str, list[float]] = {e: [] for e in ENGINES}
    blow_ups = {e: 0 for e in ENGINES}
    cpu = {e: 0.0 for e in ENGINES}
    for robot in robots:
        for engine in ENGINES:  # alternating per robot
            t = time.process_time()
            r = evaluate(robot, engine=engine)
            cpu[engine] += time.process_time() - t
            fitness[engine].append(r.fitness)
            blow_ups[engine] += r.blow_up is not None
    a, b = np.array(fitness["mujoco"]), np.array(fitness["pybullet"])
    rho = spearmanr(a, b).statistic
    print(f"{n} random robots, 3 + 12 s each: Spearman rho(MuJoCo, pybullet) = {rho:.3f}; "
          f"mean fitness MuJoCo {a.mean():.2f} m, pybullet {b.mean():.2f} m; blow-ups MuJoCo "
          f"{blow_ups['mujoco']}, pybullet {blow_ups['pybullet']}; NaN fitness "
          f"{int(np.isnan(a).sum())} / {int(np.isnan(b).sum())}; evaluate() CPU MuJoCo "
          f"{cpu['mujoco']:.1f} s, pybullet {cpu['pybullet']:.1f} s "
          f"({cpu['pybullet'] / cpu['mujoco']:.2f}x)")
    return cpu["pybullet"] / cpu["mujoco"]


# -- 5. robustness ----------------------------------------------------------------------------
def robust(n: int) -> None:
    robots = random_robots(n, seed=4)
    crashes = nans = blown = 0
    cpu = time.process_time()
    reasons: dict[str, int] = {}
    for robot in robots:
        try:
            r = evaluate(robot, engine="mujoco")
        except Exception as e:  # noqa: BLE001 (counted: the point is that there are none)
            crashes += 1
            print(f"  crash: {type(e).__name__}: {e}")
            continue
        nans += not math.isfinite(r.fitness)
        if r.blow_up is not None:
            blown += 1
            kind = r.blow_up.split(" at t=")[0].split(" ")[0:2]
            reasons[" ".join(kind)] = reasons.get(" ".join(kind), 0) + 1
    print(f"{n} random robots in MuJoCo (3 + 12 s each, {time.process_time() - cpu:.0f} CPU s): "
          f"{crashes} crashes, {nans} NaN fitness, {blown} blow-ups flagged {reasons}")


def crowded_hour(engine: str, n: int, minutes: float, life: float = 60.0) -> None:
    """``n`` robots packed in a 1 m disc for ``minutes`` simulated minutes: lives and blow-ups.

    Half the robots walk (the spider, gecko and snake examples on their own brains), half are
    random; all are dropped with no clearance (they land on each other's footprints), and each
    is replaced by a new draw after ``life`` simulated seconds or when it is lost, so robots
    are born into the crowd all along.
    """
    rng = np.random.default_rng(5)
    config = EvolutionConfig()
    walkers = [example(name) for name in ("spider", "gecko", "snake")]

    def draw() -> Robot:
        if rng.random() < 0.5:
            return walkers[int(rng.integers(len(walkers)))]
        return random_robot(rng, config)

    env = population_env(engine=engine, initial_robots=[draw() for _ in range(n)],
                         max_births=1_000_000, birth_radius=1.0, birth_clearance=0.0,
                         max_placement_tries=50)
    env.reset(seed=0)
    born = dict.fromkeys(env.agents, 0.0)
    ticks = round(minutes * 60 / env.config.control_period)
    lives, blown = n, []
    cpu = time.process_time()
    for _ in range(ticks):
        _, _, terminations, _, infos = env.step({})
        blown += [f"{a}: {infos[a]['blow_up']}" for a, t in terminations.items()
                  if t and infos[a].get("blow_up")]
        for agent in [a for a in env.agents if env.time - born[a] > life]:
            env.remove_robot(agent)
        while len(env.agents) < n:
            born[env.add_robot(draw())] = env.time
            lives += 1
    cpu = time.process_time() - cpu
    env.close()
    print(f"{n} robots packed in a 1 m disc (half walking), {minutes:g} simulated min in "
          f"{engine} ({cpu:.0f} CPU s, {minutes * 60 / cpu:.1f}x real time): {lives} robot-lives "
          f"of up to {life:g} s, {len(blown)} blow-ups ({1000 * len(blown) / lives:.1f} per 1,000 "
          "robot-lives) " + "; ".join(blown[:3]))


# -- 4. memory ---------------------------------------------------------------------------------
def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize() / 2**20


def memory_child(engine: str, births: int) -> None:
    """Births of new robots, as in an online run: each the child of two living robots."""
    rng = np.random.default_rng(3)
    config = EvolutionConfig()
    marks = {}
    with World(WorldConfig(engine=engine)) as world:
        alive: list[tuple[int, Robot]] = []
        for b in range(births):
            if len(alive) < 2:
                robot = random_robot(rng, config)
            else:
                i, j = rng.choice(len(alive), 2, replace=False)
                child = reproduce(alive[i][1], alive[j][1], rng, config).child
                robot = child if child is not None else random_robot(rng, config)
            alive.append((world.add_robot(robot, position=(2.0 * (b % 10), 0.0)), robot))
            if len(alive) > 10:
                world.remove_robot(alive.pop(0)[0])
            world.step(6)
            if b + 1 in (300, births):
                marks[b + 1] = rss_mb()
    print(" ".join(f"{k}:{v:.1f}" for k, v in marks.items()))


def memory(births: int) -> None:
    out = {}
    for engine in ENGINES:
        t = time.perf_counter()
        res = subprocess.run([sys.executable, __file__, "--memory-child", engine, str(births)],
                             capture_output=True, text=True, check=True)
        marks = dict(kv.split(":") for kv in res.stdout.split())
        out[engine] = (float(marks["300"]), float(marks[str(births)]), time.perf_counter() - t)
    for engine, (a, b, wall) in out.items():
        print(f"memory {engine}: RSS {a:.0f} MB after 300 births, {b:.0f} MB after {births} "
              f"(+{b - a:.0f} MB, {(b - a) * 1024 / (births - 300):.0f} KB per birth; 10 alive, "
              f"0.1 s each, every newborn the child of two living robots; {wall:.0f} s wall)")


SECTIONS = ["speed", "memory", "robust", "crowd-hour"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated s per timing")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--robots", type=int, default=30)
    parser.add_argument("--rank-robots", type=int, default=40)
    parser.add_argument("--births", type=int, default=3000)
    parser.add_argument("--pybullet-study-hours", type=float, default=60.0,
                        help="the study's time with pybullet, from bench_experiments.py")
    parser.add_argument("--robust-robots", type=int, default=2000)
    parser.add_argument("--crowd-minutes", type=float, default=5.0)
    parser.add_argument("--crowd-engines", nargs="+", choices=ENGINES, default=["mujoco"])
    parser.add_argument("--only", nargs="+", choices=SECTIONS, default=SECTIONS,
                        help="run only these parts (speed: 1-3 and 6)")
    parser.add_argument("--memory-child", nargs=2, metavar=("ENGINE", "BIRTHS"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.memory_child:
        memory_child(args.memory_child[0], int(args.memory_child[1]))
        return
    print(f"physics 1/{round(1 / WorldConfig().timestep)} s, control "
          f"1/{round(1 / WorldConfig().control_period)} s")
    if "speed" in args.only:
        speed(args)
    if "memory" in args.only:
        memory(args.births)
    if "robust" in args.only:
        robust(args.robust_robots)
    if "crowd-hour" in args.only:
        for engine in args.crowd_engines:
            crowded_hour(engine, args.robots, args.crowd_minutes)



def speed(args: argparse.Namespace) -> None:
    single(args.seconds, args.repeats)
    per_mj, per_pb = crowd(args.robots, args.seconds, args.repeats)
    offline = rank(args.rank_robots)
    online = per_pb / per_mj
    hours = args.pybullet_study_hours
    print(f"paper's study on 2 cores: {hours:g} h with pybullet (bench_experiments.py) -> "
          f"{hours / max(offline, online):.0f}-{hours / min(offline, online):.0f} h with MuJoCo "
          f"(speed-ups {offline:.2f}x offline, {online:.2f}x online; the rest of a run, "
          f"reproduction and storage, assumed negligible)")


if __name__ == "__main__":
    main()
