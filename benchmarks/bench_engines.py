"""MuJoCo against pybullet, and the envs against raw MuJoCo, as ratios measured in one run.

Every ratio compares two sides timed in the same process, alternating (A, B, A, B, ...), and
keeps each side's best CPU time, so both see the same load of a shared machine.

"Raw MuJoCo" is a bare ``mj_step`` loop on a copy of the very model the env or ``evaluate``
compiled, started from the same state and driven by the same hinge targets (recorded from an
untimed run of the env, then replayed through RoboGen's servo law written to ``ctrl``): no env, no
World, no sensors, no brain, and the same physics work, since it retraces the same trajectory.
Each comparison prints whether the replay ended bit for bit where the env did (it should: the
same model, state and controls).

1. ``single``: the spider in the single-robot env (``Locomotion-v1``, the aim's env, driven by
   the robot's own brain, one compiled call per step) over raw MuJoCo (and the same env on its
   general Python step, with its world stepped by the NumPy rules instead of the compiled world
   step, and ``Locomotion-v0``: the same robot and physics without proprioception), and MuJoCo
   over pybullet per CPU second (the env).
2. ``evaluate``: ``revolve_env.evaluate`` of the spider (3 s insertion + 12 s) over raw MuJoCo,
   and MuJoCo over pybullet.
   ``offline``: ``--offline-robots`` random robots (a generation) through ``evaluate_many``,
   ``evaluate`` one by one, the NumPy rules and 2 threads, over raw MuJoCo replaying each alone
   per robot-second. The raw side starts from the compiled model at its first control period;
   two more sides say what a call pays that it does not: ``evaluate_many`` of one control
   period (validation, the models' assembly and compiles, the rollout's set-up) and MuJoCo's own
   compile of the exported models (``MjModel.from_xml_string`` of each scene's MJCF), timed
   alone and added to the raw side for a like-for-like ratio.
3. ``crowd``: the population env with ``--robots`` random robots in one world (restored from one
   snapshot before every timing, so each timing steps the same ``--seconds``), the same ratios.
4. ``rank``: ``--rank-robots`` random robots (``evolution.random_robot``) evaluated on both
   engines (3 s insertion + 12 s): Spearman's rank correlation of their fitness, blow-ups and
   NaNs counted per engine.
5. ``study``: the paper's full study (5 experiments x 30 runs x 3000 births) on 2 cores with
   MuJoCo: ``--pybullet-study-hours`` (what ``bench_experiments.py`` measured with pybullet)
   divided by the measured speed-ups, offline (``evaluate``, from ``rank``) and online (the
   crowd); printed with ``rank``.
6. ``memory``: resident memory of one world after 300 and after ``--births`` births (10 alive,
   each living 0.1 s, each newborn a new robot: the child of two living ones, as online), each
   engine in a fresh subprocess.
7. ``robust``: ``--robust-robots`` random robots evaluated in MuJoCo alone: crashes, NaN fitness
   and blow-ups counted. ``crowd-hour``: ``--crowd-minutes`` simulated minutes of ``--robots``
   robots (half walking examples, half random) packed in a 1 m disc with no clearance, each
   replaced after 60 s or when lost, on each of ``--crowd-engines``: blow-ups per 1,000
   robot-lives (``--mujoco-integrator before``: MuJoCo with the integrator it used before,
   ``implicitfast`` with islands, as ``integrator_move.py`` sets it).
8. ``--whole-runs BIRTHS`` (not a section: minutes of CPU): scenario 1 and scenario 3 run
   ``BIRTHS`` births each in this process on MuJoCo by ``bench_experiments.py``'s own
   ``measure_run`` (CPU per birth beside its floor, memory per birth after 300 births), then the
   paper's study projected from them onto 2 cores; ``--given-run NAME=CPU_MS@BIRTHS,floor=MS,
   memory=KB`` takes a run measured by ``bench_experiments.py`` in another process instead.

Last, every aim of issue 28 with its figure beside the aim, "met" or "missed by 1.23x" (the
figure over the aim, or the aim over the figure for an aim of at least), and "not measured in
this run" (with what measures it) for the aims of sections not run (``benchmarks/aims.py``).

Usage: ``python benchmarks/bench_engines.py [--only single evaluate crowd ...] [--seconds 3]
[--robots 30] [--rank-robots 40] [--births 3000] [--repeats 2] [--robust-robots 2000]
[--crowd-minutes 5] [--crowd-engines mujoco pybullet] [--whole-runs 1000]
[--given-run scenario3=1315@609,floor=627,memory=5.9]``.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import resource
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from numpy.typing import NDArray
from scipy.stats import spearmanr

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from aims import ISSUE_28, Aim, Figure, GivenRun, parse_given_run, summary
from integrator_move import integrator_before

from evolution.config import EvolutionConfig
from evolution.operators import reproduce
from evolution.random_robot import random_robot
from revolve_env import (
    LOCOMOTION_ID,
    LOCOMOTION_V1_ID,
    EvaluationConditions,
    evaluate,
    evaluate_many,
    example,
    population_env,
)
from revolve_env.body.robot import Robot
from revolve_env.envs.population import PopulationEnv
from revolve_env.world import World, WorldConfig, compiled

ENGINES = ("mujoco", "pybullet")
SECTIONS = ("single", "evaluate", "offline", "crowd", "rank", "memory", "robust", "crowd-hour")
_STATE = int(mujoco.mjtState.mjSTATE_INTEGRATION)
FIGURES: dict[str, Figure] = {}
"""Issue 28's aims' figures measured in this run, by :attr:`aims.Aim.key`; printed last."""
EXTRA: dict[str, tuple[Figure, Aim]] = {}
"""Further rows of the aims' summary: a figure and the aim it is held to, by name."""
_AIM = {aim.key: aim for aim in ISSUE_28}


@contextlib.contextmanager
def numpy_rules() -> Iterator[None]:
    """Evaluations inside take the NumPy path (the compiled rollout declines), and so do the
    worlds that first step inside (the compiled world step declines; a world keeps its path) and
    the population envs made inside (their fitness windows' push stays NumPy's)."""
    original, step, windows = compiled.rollout, compiled.world_step, compiled.windows_kernel
    compiled.rollout = lambda *a, **k: None  # type: ignore[assignment]
    compiled.world_step = lambda *a, **k: None
    compiled.windows_kernel = lambda: None
    try:
        yield
    finally:
        compiled.rollout = original  # type: ignore[assignment]
        compiled.world_step = step
        compiled.windows_kernel = windows


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


# -- raw MuJoCo: the same model, state and targets, replayed bare -------------------------------
def scene(world: World) -> Any:
    """The MuJoCo backend holding ``world``'s model (an isolated world's: its one robot's)."""
    backend: Any = world.backend
    if hasattr(backend, "_scenes"):
        (only,) = backend._scenes.values()
        return only
    return backend


class Replay:
    """A world's compiled MuJoCo model and state now, and the hinge targets of the periods after.

    :meth:`record` logs the world's targets before each control period it steps; :meth:`run`
    replays them on a fresh ``MjData`` of the same model: per period one gather of the hinge
    angles, RoboGen's servo law into ``ctrl`` and ``mj_step`` x substeps.
    """

    def __init__(self, world: World) -> None:
        backend = self.scene = scene(world)
        self.model = backend._model
        self.state = np.empty(mujoco.mj_stateSize(self.model, _STATE))
        mujoco.mj_getState(self.model, backend._data, self.state, _STATE)
        self.hinges = self.model.jnt_qposadr[self.model.actuator_trnid[:, 0]].astype(np.intp)
        self.config = world.config
        self.targets: list[NDArray[np.float64]] = []
        self.final = np.zeros(0)
        self.xml = backend.mjcf()  # the project's exported model: what a raw user compiles

    def compile(self) -> float:
        """CPU seconds of compiling the exported model (MJCF text) and making its data."""
        cpu = time.process_time()
        m = mujoco.MjModel.from_xml_string(self.xml)
        mujoco.MjData(m)
        return time.process_time() - cpu

    def record(self, world: World) -> None:
        """Log ``world``'s targets before each of its control periods until :meth:`stop`."""
        step = world.step

        def logged(n: int = 1) -> None:
            for _ in range(n):
                self.targets.append(world.targets.copy())
                step(1)

        world.step = logged  # type: ignore[method-assign]

    @staticmethod
    def stop(world: World) -> None:
        """Stop logging ``world``'s targets: the periods recorded so far are the replay's.

        Left logging, the timed runs of the env would pay for the log and grow the replay (each
        run of the env adding its periods to the raw side's).
        """
        del world.step

    def run(self) -> float:
        """CPU seconds of the bare replay (its end state in :attr:`final`)."""
        m, c = self.model, self.config
        d = mujoco.MjData(m)
        mujoco.mj_setState(m, d, self.state, _STATE)
        hinges, targets = self.hinges, self.targets
        k = c.servo_gain / c.control_period
        vmax, substeps = c.max_velocity, c.substeps
        cpu = time.process_time()
        for t in targets:
            d.ctrl[:] = np.minimum(np.maximum(k * (t - d.qpos[hinges]), -vmax), vmax)
            mujoco.mj_step(m, d, substeps)
        cpu = time.process_time() - cpu
        self.final = d.qpos.copy()
        return cpu

    def same_as(self, world: World) -> str:
        """"exact" when the replay ended where ``world`` is now, else how far off (metres)."""
        now: Any = world.backend
        backend = self.scene if not getattr(now, "_scenes", True) else scene(world)  # closed
        here = np.asarray(backend._data.qpos)
        if here.shape == self.final.shape and np.array_equal(here, self.final):
            return "exact"
        return "off" if here.shape != self.final.shape else \
            f"off by {float(np.abs(here - self.final).max()):.1e}"


def on_a_grid(robots: list[Robot], spacing: float = 1.2) -> list[dict[str, Any]]:
    """``robots`` as a population env's initial robots on a square grid ``spacing`` metres
    apart, all facing +x."""
    side = math.ceil(math.sqrt(len(robots)))
    return [{"robot": r, "position": (spacing * (i % side), spacing * (i // side)), "yaw": 0.0}
            for i, r in enumerate(robots)]


def crowd_env(initial: list[dict[str, Any]], engine: str = "mujoco", landing: int = 30,
              **kwargs: Any) -> PopulationEnv:
    """The population env of the crowd ``initial``: no births (``max_births`` its size), fitness
    from birth, reset (seed 0) and stepped ``landing`` control periods for its robots to land."""
    env: PopulationEnv = population_env(engine=engine, initial_robots=initial,
                                        max_births=len(initial), insertion_time=0.0, **kwargs)
    try:
        env.reset(seed=0)
        for _ in range(landing):
            env.step({})
    except BaseException:
        env.close()
        raise
    return env


def recorded(env: PopulationEnv, ticks: int,
             step: Callable[[dict[str, Any]], object] | None = None) -> tuple[Replay, str]:
    """The bare replay of the next ``ticks`` control periods of ``env`` (stepped by ``step``,
    ``env.step`` unless given), run once, and :meth:`Replay.same_as` of its end."""
    raw = Replay(env.world)
    raw.record(env.world)
    for _ in range(ticks):
        (step or env.step)({})
    raw.stop(env.world)
    raw.run()
    return raw, raw.same_as(env.world)


# -- 1. one robot in the env -------------------------------------------------------------------
def make_single(robot: Robot, engine: str, seconds: float,
                env_id: str = LOCOMOTION_V1_ID) -> gym.Env[Any, Any]:
    """The single-robot env ``env_id`` of ``robot`` driven by its brain, all ``seconds`` scored."""
    return gym.make(env_id, robot=robot, engine=engine, controller="brain",
                    insertion_time=0.0, evaluation_time=seconds)


def env_cpu(env: gym.Env[Any, Any]) -> float:
    env.reset(seed=0)
    action = np.zeros(env.action_space.shape or (0,), dtype=np.float32)
    cpu = time.process_time()
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(action)
        done = terminated or truncated
    return time.process_time() - cpu


def numpy_cpu(env: gym.Env[Any, Any]) -> float:
    """:func:`env_cpu` with the world stepped by the NumPy rules."""
    with numpy_rules():
        return env_cpu(env)


def single(seconds: float, repeats: int) -> None:
    robot = example("spider")
    envs = {e: make_single(robot, e, seconds) for e in ENGINES}
    slow = make_single(robot, "mujoco", seconds)
    v0 = make_single(robot, "mujoco", seconds, LOCOMOTION_ID)  # same physics, no proprioception
    general = make_single(robot, "mujoco", seconds)  # the env's general Python step
    general.unwrapped._fast_step = False  # type: ignore[attr-defined]
    mj = envs["mujoco"]
    mj.reset(seed=0)
    world: World = mj.unwrapped._world  # type: ignore[attr-defined]
    raw = Replay(world)
    raw.record(world)
    # The recording run (untimed; env_cpu's own reset restarts the world) on the general step,
    # whose world.step the replay logs (the compiled env step runs the period in its own call,
    # to the same targets and states).
    mj.unwrapped._fast_step = False  # type: ignore[attr-defined]
    env_cpu(mj)
    mj.unwrapped._fast_step = True  # type: ignore[attr-defined]
    raw.stop(world)
    raw.run()
    check = raw.same_as(world)
    best = alternate({
        "env mujoco": lambda: env_cpu(mj),
        "raw mujoco": raw.run,
        "env mujoco general step": lambda: env_cpu(general),
        "env mujoco NumPy rules": lambda: numpy_cpu(slow),
        "env mujoco v0": lambda: env_cpu(v0),
        "env pybullet": lambda: env_cpu(envs["pybullet"]),
    }, repeats)
    slow.close()
    v0.close()
    general.close()
    for env in envs.values():
        env.close()
    print(f"spider, Locomotion-v1 (brain), {seconds:g} simulated s, best CPU of {repeats}: "
          + ", ".join(f"{k} {v:.3f} s" for k, v in best.items()) + f" (replay {check})")
    FIGURES["single"] = Figure(best["env mujoco"] / best["raw mujoco"])
    print(f"  env/raw MuJoCo {best['env mujoco'] / best['raw mujoco']:.2f}x (the general step "
          f"{best['env mujoco general step'] / best['raw mujoco']:.2f}x, NumPy rules "
          f"{best['env mujoco NumPy rules'] / best['raw mujoco']:.2f}x, Locomotion-v0 "
          f"{best['env mujoco v0'] / best['raw mujoco']:.2f}x); "
          f"MuJoCo env {best['env pybullet'] / best['env mujoco']:.2f}x faster than pybullet "
          f"per CPU second; raw MuJoCo {seconds / best['raw mujoco']:.0f} sim s per CPU s")


# -- 2. one evaluate() -------------------------------------------------------------------------
def record_evaluate(robot: Robot, seconds: float, insertion: float, seed: int = 0,
                    conditions: EvaluationConditions | None = None) -> tuple[Replay, str]:
    """The replay of one ``evaluate`` on MuJoCo, and whether it ends where the evaluation did."""
    original = World.step
    seen: dict[str, Any] = {}

    def step(self: World, n: int = 1) -> None:
        if "replay" not in seen:
            seen["replay"] = Replay(self)
            seen["world"] = self
        for _ in range(n):
            seen["replay"].targets.append(self.targets.copy())
            original(self, 1)

    World.step = step  # type: ignore[method-assign]
    try:
        with numpy_rules():  # the compiled rollout steps no World: record the NumPy path's
            evaluate(robot, seconds=seconds, insertion=insertion, engine="mujoco", seed=seed,
                     conditions=conditions)
    finally:
        World.step = original  # type: ignore[method-assign]
    raw: Replay = seen["replay"]
    raw.run()
    return raw, raw.same_as(seen["world"])


def evaluate_one(repeats: int) -> None:
    robot = example("spider")
    seconds, insertion = 12.0, 3.0
    raw, check = record_evaluate(robot, seconds, insertion)

    def run(engine: str) -> float:
        cpu = time.process_time()
        evaluate(robot, seconds=seconds, insertion=insertion, engine=engine)
        return time.process_time() - cpu

    def run_numpy() -> float:
        with numpy_rules():
            return run("mujoco")

    path = "compiled" if compiled.available() else "NumPy rules: the compiled rollout is not usable"
    best = alternate({"evaluate mujoco": lambda: run("mujoco"), "raw mujoco": raw.run,
                      "evaluate mujoco NumPy rules": run_numpy,
                      "evaluate pybullet": lambda: run("pybullet")}, repeats)
    print(f"spider, evaluate() {insertion:g} + {seconds:g} s, best CPU of {repeats}: "
          + ", ".join(f"{k} {v:.3f} s" for k, v in best.items()) + f" (replay {check}; {path})")
    ratio = best["evaluate mujoco"] / best["raw mujoco"]
    print(f"  evaluate/raw MuJoCo {ratio:.2f}x (NumPy rules "
          f"{best['evaluate mujoco NumPy rules'] / best['raw mujoco']:.2f}x); MuJoCo "
          f"{best['evaluate pybullet'] / best['evaluate mujoco']:.2f}x faster than pybullet")
    FIGURES["evaluate"] = Figure(ratio)
    FIGURES["pybullet"] = Figure(best["evaluate pybullet"] / best["evaluate mujoco"])


# -- 3. offline: a generation evaluated side by side ------------------------------------------
def side_by_side(n: int, repeats: int) -> None:
    """``n`` random robots (a generation's children), 3 + 12 s each under the shipped configs'
    conditions (random heading): ``evaluate`` one by one, ``evaluate_many`` all at once, and raw
    MuJoCo replaying each alone; CPU per simulated robot-second."""
    robots = random_robots(n, seed=6)
    seeds = list(range(n))
    conditions = EvaluationConditions(heading="random")
    seconds, insertion = 12.0, 3.0
    replays = [record_evaluate(r, seconds, insertion, s, conditions) for r, s in zip(robots, seeds,
                                                                                      strict=True)]
    checks = {check for _, check in replays}

    def alone() -> float:
        cpu = time.process_time()
        for robot, seed in zip(robots, seeds, strict=True):
            evaluate(robot, seconds=seconds, insertion=insertion, seed=seed, engine="mujoco",
                     conditions=conditions)
        return time.process_time() - cpu

    def together(threads: int = 1) -> float:
        cpu = time.process_time()
        evaluate_many(robots, seconds=seconds, insertion=insertion, seeds=seeds, engine="mujoco",
                      conditions=conditions, threads=threads)
        return time.process_time() - cpu

    def together_numpy() -> float:
        with numpy_rules():
            return together()

    walls: dict[int, float] = {}

    def wall(threads: int) -> Callable[[], float]:
        def timed() -> float:
            start = time.perf_counter()
            cpu = together(threads)
            walls[threads] = min(walls.get(threads, math.inf), time.perf_counter() - start)
            return cpu
        return timed

    def raw() -> float:
        return sum(replay.run() for replay, _ in replays)

    def raw_compile() -> float:  # what a raw user adds: the exported models compiled
        return sum(replay.compile() for replay, _ in replays)

    def build_only() -> float:  # evaluate_many's per-call work: validation, models, compiles
        cpu = time.process_time()
        evaluate_many(robots, seconds=WorldConfig().control_period, insertion=0.0, seeds=seeds,
                      engine="mujoco", conditions=conditions)
        return time.process_time() - cpu

    one = [evaluate(r, seconds=seconds, insertion=insertion, seed=s, engine="mujoco",
                    conditions=conditions) for r, s in zip(robots, seeds, strict=True)]
    many = evaluate_many(robots, seconds=seconds, insertion=insertion, seeds=seeds,
                         engine="mujoco", conditions=conditions)
    same = all(a.fitness == b.fitness and np.array_equal(a.trajectory, b.trajectory)
               for a, b in zip(one, many, strict=True))
    best = alternate({"evaluate_many": wall(1), "evaluate one by one": alone, "raw mujoco": raw,
                      "evaluate_many NumPy rules": together_numpy,
                      "evaluate_many 2 threads": wall(2), "raw mujoco compile alone": raw_compile,
                      "evaluate_many of one period": build_only}, repeats)
    robot_seconds = sum(len(r.trajectory) for r in one) / 60.0 + n * insertion
    print(f"{n} random robots, {insertion:g} + {seconds:g} s each, best CPU of {repeats}: "
          + ", ".join(f"{k} {v:.3f} s" for k, v in best.items())
          + f" (evaluate_many == evaluate: {'bit for bit' if same else 'NO'}; replays "
          + "/".join(sorted(checks)) + ")")
    per = {k: v / robot_seconds * 1e3 for k, v in best.items()}
    print("  CPU ms per simulated robot-second: " + ", ".join(f"{k} {v:.2f}"
                                                             for k, v in per.items())
          + f"; evaluate_many/raw {best['evaluate_many'] / best['raw mujoco']:.2f}x (NumPy rules "
          f"{best['evaluate_many NumPy rules'] / best['raw mujoco']:.2f}x), "
          f"one by one/raw {best['evaluate one by one'] / best['raw mujoco']:.2f}x")
    built = best["raw mujoco"] + best["raw mujoco compile alone"]
    print(f"  like for like: evaluate_many/raw with the exported models' compile "
          f"{best['evaluate_many'] / built:.2f}x (raw's compile "
          f"{best['raw mujoco compile alone']:.3f} s CPU); evaluate_many of one control "
          f"period (validation, models, compiles, set-up: "
          f"what every call pays) {best['evaluate_many of one period']:.3f} s CPU, "
          f"{best['evaluate_many of one period'] / best['evaluate_many']:.0%} of evaluate_many; "
          f"load average {' '.join(f'{v:.1f}' for v in os.getloadavg())}")
    speed_up = walls[1] / walls[2]
    print(f"  threads (compiled rollout): wall {walls[1]:.3f} s with 1, {walls[2]:.3f} s with 2 "
          f"-> {speed_up:.2f}x; CPU per robot-second with 2 threads / with 1 "
          f"{best['evaluate_many 2 threads'] / best['evaluate_many']:.2f}x (a loaded machine "
          "gives the second thread less than a core)")
    FIGURES["evaluate_many"] = Figure(best["evaluate_many"] / best["raw mujoco"],
                                      f"{n} random robots")
    EXTRA["evaluate_many / raw mj_step with the exported models' compile (like for like)"] = (
        Figure(best["evaluate_many"] / built, f"{n} random robots"), _AIM["evaluate_many"])
    FIGURES["threads"] = Figure(speed_up, f"{n} random robots")
    FIGURES["threads_cpu"] = Figure(best["evaluate_many 2 threads"] / best["evaluate_many"])


# -- 3. a crowd --------------------------------------------------------------------------------
def crowd(n: int, seconds: float, repeats: int) -> tuple[float, float]:
    """Returns the population env's CPU seconds per robot-simulated-second (MuJoCo, pybullet)."""
    initial = on_a_grid(random_robots(n, seed=1))
    envs = {e: crowd_env(initial, e) for e in ENGINES}
    with numpy_rules():  # its world keeps the NumPy rules
        slow = envs["mujoco NumPy rules"] = crowd_env(initial)
    mj = envs["mujoco"]
    ticks = round(seconds / mj.config.control_period)
    start = mj.snapshot()

    def run_env(engine: str) -> float:
        env = envs[engine]
        if env is mj or env is slow:
            env.restore(start)
        cpu = time.process_time()
        for _ in range(ticks):
            env.step({})
        return time.process_time() - cpu

    mj.restore(start)
    raw, check = recorded(mj, ticks)
    best = alternate({
        "env mujoco": lambda: run_env("mujoco"),
        "raw mujoco": raw.run,
        "env mujoco NumPy rules": lambda: run_env("mujoco NumPy rules"),
        "env pybullet": lambda: run_env("pybullet"),
    }, repeats)
    lost = n - len(mj.agents)
    for env in envs.values():
        env.close()
    print(f"{n} random robots in one world, {seconds:g} simulated s, best CPU of {repeats}: "
          + ", ".join(f"{k} {v:.3f} s" for k, v in best.items()) + f" (replay {check})")
    print(f"  population env/raw MuJoCo {best['env mujoco'] / best['raw mujoco']:.2f}x "
          f"(NumPy rules {best['env mujoco NumPy rules'] / best['raw mujoco']:.2f}x); MuJoCo "
          f"{best['env pybullet'] / best['env mujoco']:.2f}x faster than pybullet per CPU second; "
          f"MuJoCo {seconds / best['env mujoco']:.1f}x real time on one core; "
          f"{lost} robots lost to blow-ups in MuJoCo")
    FIGURES["crowd"] = Figure(best["env mujoco"] / best["raw mujoco"], f"{n} robots")
    return best["env mujoco"] / (n * seconds), best["env pybullet"] / (n * seconds)


# -- 4. same science ---------------------------------------------------------------------------
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


# -- 7. robustness ----------------------------------------------------------------------------
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


# -- 6. memory ---------------------------------------------------------------------------------
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


# -- 8. whole runs: bench_experiments.py's measurements, for the aims' summary ---------------
WHOLE_RUNS = ("scenario1", "scenario3")
"""The experiments whose whole runs issue 28 holds to their floor."""


def whole_runs(births: int, floor_samples: int, given: list[GivenRun]) -> None:
    """Issue 28's whole-run aims: each of :data:`WHOLE_RUNS` run ``births`` births (0: none)
    by ``bench_experiments.py``'s own functions (one process, MuJoCo: CPU per birth, its floor,
    memory per birth after 300 births) unless given, then the paper's study projected from
    them (and any other given run) onto 2 cores."""
    import bench_experiments  # here, not above: it imports this module (Replay, ...)

    measured: dict[str, tuple[Any, float, float]] = {}
    shortest = math.inf
    for run in given:
        config = bench_experiments.preset(run.name, births=run.births, runs=1)
        measured[run.name] = (config, run.cpu_ms / 1e3 * run.births, run.alive)
        shortest = min(shortest, run.births)
        note = f"given: another process's run of {run.births} births"
        if run.name in WHOLE_RUNS and run.floor_ms is not None:
            FIGURES[run.name] = Figure(run.cpu_ms / run.floor_ms,
                                       f"{note}, {run.cpu_ms:.0f} ms CPU per birth, floor "
                                       f"{run.floor_ms:.0f} ms")
        if run.name == "scenario3" and run.memory_kb is not None:
            FIGURES["memory"] = Figure(run.memory_kb, note)
    for name in WHOLE_RUNS if births > 0 else ():
        if name in measured:
            continue
        print(f"whole run: {name}, {births} births, one process, MuJoCo "
              f"(bench_experiments.measure_run)...", flush=True)
        one = bench_experiments.measure_run(name, births, 1, physics="mujoco",
                                            floor_samples=floor_samples, memory_after=300)
        print(one.floor_line())
        print(one.memory_line(300), flush=True)
        measured[name] = (one.config, one.cpu, one.alive)
        shortest = min(shortest, one.births)
        if one.floor is not None:
            FIGURES[name] = Figure(one.cpu / one.floor.cpu,
                                   f"this run: {one.births} births, "
                                   f"{1e3 * one.cpu_per_birth:.0f} ms CPU per birth, floor "
                                   f"{1e3 * one.floor.cpu / one.births:.0f} ms")
        growth = one.memory_growth(300)
        if name == "scenario3" and growth is not None:
            FIGURES["memory"] = Figure(growth[0], f"this run: births 300-{one.births}, "
                                                  "least squares")
    if not measured:
        return
    hours = bench_experiments.project(measured)
    if 2 in hours:
        short = ("; the aim is judged on runs of >= 1000 births"
                 if shortest < 1000 else "")
        FIGURES["study"] = Figure(hours[2], f"projected from runs of {shortest:.0f} births or "
                                            f"more{short}")


def _given_run(text: str) -> GivenRun:
    try:
        return parse_given_run(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", choices=SECTIONS, default=list(SECTIONS),
                        help="sections to run (default: all)")
    parser.add_argument("--seconds", type=float, default=3.0, help="simulated s per timing")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--robots", type=int, default=30)
    parser.add_argument("--rank-robots", type=int, default=40)
    parser.add_argument("--offline-robots", type=int, default=15,
                        help="robots evaluated side by side (a scenario 1 generation: 15)")
    parser.add_argument("--births", type=int, default=3000)
    parser.add_argument("--pybullet-study-hours", type=float, default=60.0,
                        help="the study's time with pybullet, from bench_experiments.py")
    parser.add_argument("--robust-robots", type=int, default=2000)
    parser.add_argument("--crowd-minutes", type=float, default=5.0)
    parser.add_argument("--crowd-engines", nargs="+", choices=ENGINES, default=["mujoco"])
    parser.add_argument("--mujoco-integrator", choices=("now", "before"), default="now",
                        help="crowd-hour: MuJoCo's integrator as now (discrete) or as before")
    parser.add_argument("--whole-runs", type=int, default=0, metavar="BIRTHS",
                        help="also run scenario 1 and scenario 3 for BIRTHS births each (one "
                             "process, MuJoCo, bench_experiments.py's measure_run: minutes) for "
                             "the whole-run aims; default 0: not run")
    parser.add_argument("--given-run", nargs="*", type=_given_run, default=[],
                        metavar="NAME=CPU_MS@BIRTHS[,floor=MS][,memory=KB][,alive=N]",
                        help="a whole run measured by bench_experiments.py --workers 1 in "
                             "another process, for the whole-run aims (instead of measuring it)")
    parser.add_argument("--floor-samples", type=int, default=12,
                        help="--whole-runs: robots or worlds each run's floor is measured on")
    parser.add_argument("--memory-child", nargs=2, metavar=("ENGINE", "BIRTHS"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.memory_child:
        memory_child(args.memory_child[0], int(args.memory_child[1]))
        return
    only = set(args.only)
    print(f"physics 1/{round(1 / WorldConfig().timestep)} s, control "
          f"1/{round(1 / WorldConfig().control_period)} s")
    if "single" in only:
        single(args.seconds, args.repeats)
    if "evaluate" in only:
        evaluate_one(args.repeats)
    if "offline" in only:
        side_by_side(args.offline_robots, args.repeats)
    per_mj = per_pb = math.nan
    if "crowd" in only:
        per_mj, per_pb = crowd(args.robots, args.seconds, args.repeats)
    if "rank" in only:
        offline = rank(args.rank_robots)
        online = per_pb / per_mj
        hours = args.pybullet_study_hours
        if math.isfinite(online):
            print(f"paper's study on 2 cores: {hours:g} h with pybullet (bench_experiments.py) "
                  f"-> {hours / max(offline, online):.0f}-{hours / min(offline, online):.0f} h "
                  f"with MuJoCo (speed-ups {offline:.2f}x offline, {online:.2f}x online; the "
                  "rest of a run, reproduction and storage, assumed negligible)")
    if "memory" in only:
        memory(args.births)
    if "robust" in only:
        robust(args.robust_robots)
    if "crowd-hour" in only:
        for engine in args.crowd_engines:
            if engine == "mujoco" and args.mujoco_integrator == "before":
                with integrator_before():  # implicitfast, islands on (integrator_move.py)
                    print("MuJoCo as before: implicitfast, constraint islands on")
                    crowded_hour(engine, args.robots, args.crowd_minutes)
            else:
                crowded_hour(engine, args.robots, args.crowd_minutes)
    if args.whole_runs > 0 or args.given_run:
        whole_runs(args.whole_runs, args.floor_samples, args.given_run)
    print(*summary(FIGURES, EXTRA), sep="\n")


if __name__ == "__main__":
    main()
