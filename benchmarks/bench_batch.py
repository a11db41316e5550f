"""Many worlds of one body: robot-steps per second of the batched routes, and the batched infancy.

Rows, for ``N`` copies of the spider and of a 20-part random robot (MuJoCo, 1/60 s control
periods of 4 physics steps):

* ``raw mujoco.batch, T thr``: the floor. The robot's very model (``World.to_mjcf``) stepped by
  ``mujoco.batch.Batch`` on ``T`` threads, closed loop through its live views with RoboGen's
  servo law in NumPy toward the envs' own random targets (no sensors, rewards or Python per
  robot).
* ``native vector env, T thr``: :class:`revolve_env.envs.vector.LocomotionVectorEnv` (random
  actions), everything the env does: servo law, sensors, blow-up screen, fitness windows,
  rewards, infos; its N copies of one model step in one ``mujoco.batch`` on ``T`` threads
  (:mod:`revolve_env.world.mujoco_batch`), bit for bit the single env.
* ``native via SB3``: the same behind :class:`~revolve_env.envs.sb3_vector.NativeVecEnv`, what
  ``rl.make_vec_env`` gives PPO.
* ``SB3 DummyVecEnv``: today's route before this benchmark, ``DummyVecEnv`` of ``Monitor``-ed
  single envs (``rl.VecEnvConfig(batched=False)``).
* ``MuJoCo Warp``: the native vector env on ``engine="mujoco_warp"`` (its N copies the worlds of one
  Warp batch, float32, on the device Warp picks), printed only where ``mujoco_warp`` imports (the
  ``warp`` extra). One env steps alternately with each period one Warp graph (a CUDA graph on a GPU,
  replayed in C++ on the CPU) and with its kernels launched one by one from Python (two rows),
  beside ``raw MuJoCo Warp``, the floor there: the model's batch, each period's physics steps one
  Warp graph between the servo law in NumPy and the hinges' angles read back (no sensors, rewards or
  poses). Without a GPU Warp runs on the CPU, which the rows say ("no GPU: Warp on CPU"), and only
  for N <= 64 (launched from Python, a physics step costs ~0.1 s of launching ~900 kernels, plus ~1
  ms per world there). Its set-up includes compiling Warp's kernels the first time (minutes on a
  CPU; then Warp's cache, ``~/.cache/warp``).

Each figure is robot-steps (control periods of one robot) per second, of wall time and of this
process's CPU time; the set-up (model compiles, resets) is timed apart. Then CMA-ES infancy of
one spider (popsize 16; the inborn controller and whole generations while the budget pays) with
the candidates evaluated one by one (a function the evaluators cannot batch) vs one generation in
one ``evaluate_many`` call (the Training Center's route): CPU seconds and the same result.

Usage::

    python benchmarks/bench_batch.py --quick          # small N, short runs (a shared 2-core box)
    python benchmarks/bench_batch.py --device-check   # N = 1, 16, 256, 4096; one markdown table
    python benchmarks/bench_batch.py --quick --warp-only   # MuJoCo Warp's rows alone
    python benchmarks/bench_batch.py --warp-only --robots spider --sizes 1 64 1024 4096
    python benchmarks/bench_batch.py --setup 16 256 1024  # the vector env's set-up alone

``--setup``: wall and CPU seconds of ``LocomotionVectorEnv(N, robot=spider)`` and its first
``reset`` (every copy's model built and compiled, the world's arrays laid out), per N, and the CPU
per robot: flat in N when the set-up is linear.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import platform
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from evolution.config import EvolutionConfig
from evolution.evaluation import EvalOutcome, EvalTask, evaluate_task
from evolution.learning import CandidateEvaluation, CMAESLearner
from evolution.random_robot import random_robot
from revolve_env.body.examples import EXAMPLES
from revolve_env.body.robot import Layer, Robot
from revolve_env.world import World, WorldConfig


@dataclass(frozen=True, slots=True)
class Rate:
    """Robot-steps per second of wall and of CPU time, and the set-up's wall seconds."""

    wall: float
    cpu: float
    setup: float


@contextmanager
def _clock() -> Iterator[list[float]]:
    out: list[float] = []
    w, c = time.perf_counter(), time.process_time()
    yield out
    out += [time.perf_counter() - w, time.process_time() - c]


def spider() -> Robot:
    """The example spider (17 parts, 8 active hinges)."""
    return EXAMPLES["spider"]()


def twenty_part_robot(seed: int = 0) -> Robot:
    """The first random robot of exactly 20 parts with active hinges from ``seed`` on."""
    config = EvolutionConfig(initial_parts_mean=20, initial_parts_sd=0.0)
    rng = np.random.default_rng(seed)
    while True:
        robot = random_robot(rng, config)
        if robot.num_parts() == 20 and robot.neurons_of(Layer.OUTPUT):
            return robot


def _exported(robot: Robot, config: WorldConfig) -> Any:
    """The robot's very model as the project exports it (``World.to_mjcf``), compiled."""
    import mujoco

    with World(config) as world:
        world.add_robot(robot)
        return mujoco.MjModel.from_xml_string(world.to_mjcf())


def _servo_law(model: Any, n: int,
               config: WorldConfig) -> Callable[[int, NDArray[np.float64]], NDArray[np.float64]]:
    """RoboGen's servo law toward the envs' random targets (env_rate's actions), for ``n``
    copies: period ``t``'s controls from the copies' ``qpos`` (n, nq)."""
    hinges = model.jnt_qposadr[model.actuator_trnid[:, 0]].astype(np.intp)  # in actuator order
    k = config.servo_gain / config.control_period
    scale = math.radians(config.range_deg)
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, (n, model.nu)) * scale for _ in range(8)]

    def law(t: int, qpos: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.clip(k * (actions[t % 8] - qpos[:, hinges]), -config.max_velocity,
                       config.max_velocity)

    return law


def _raw_rate(period: Callable[[int], None], n: int, steps: int, setup: float,
              finish: Callable[[], object] = lambda: None) -> Rate:
    """``period`` timed over ``steps`` periods after five untimed ones (as the envs' first
    calls); ``finish`` waits for the last (a device's)."""
    for t in range(5):
        period(t)
    with _clock() as spent:
        for t in range(5, 5 + steps):
            period(t)
        finish()
    return Rate(n * steps / spent[0], n * steps / spent[1], setup)


def raw_batch(robot: Robot, n: int, steps: int, threads: int) -> Rate:
    """The floor: the robot's model in ``mujoco.batch`` with the servo law in NumPy."""
    from mujoco.batch import Batch

    config = WorldConfig(engine="mujoco")
    w0 = time.perf_counter()
    model = _exported(robot, config)
    batch = Batch(model, nsim=n, nthread=threads)
    batch.reset()
    setup = time.perf_counter() - w0
    qpos, ctrl = batch.bind("qpos"), batch.bind("ctrl")
    law = _servo_law(model, n, config)

    def period(t: int) -> None:
        ctrl[:] = law(t, qpos)
        batch.step(nstep=config.substeps)

    return _raw_rate(period, n, steps, setup)


def env_rate(make: Callable[[], object], n: int, steps: int, sb3: bool) -> Rate:
    """A vector env's rate over ``steps`` steps after its first reset (no episode ends)."""
    w0 = time.perf_counter()
    venv = make()
    rng = np.random.default_rng(0)
    if sb3:
        venv.seed(0)  # type: ignore[attr-defined]
        venv.reset()  # type: ignore[attr-defined]
        shape = (n, *venv.action_space.shape)  # type: ignore[attr-defined]
    else:
        venv.reset(seed=0)  # type: ignore[attr-defined]
        shape = venv.action_space.shape  # type: ignore[attr-defined]
    setup = time.perf_counter() - w0
    actions = [rng.uniform(-1, 1, shape).astype(np.float32) for _ in range(8)]
    for t in range(5):  # first calls' one-time costs (lazy imports, caches) are not timed
        venv.step(actions[t])  # type: ignore[attr-defined]
    with _clock() as spent:
        for t in range(steps):
            venv.step(actions[t % 8])  # type: ignore[attr-defined]
    venv.close()  # type: ignore[attr-defined]
    return Rate(n * steps / spent[0], n * steps / spent[1], setup)


def native(robot: Robot, n: int, steps: int, threads: int) -> Rate:
    from revolve_env.envs.vector import LocomotionVectorEnv

    return env_rate(lambda: LocomotionVectorEnv(n, robot=robot, engine="mujoco",
                                                proprioception=True, threads=threads),
                    n, steps, sb3=False)


def warp_device() -> str | None:
    """The device MuJoCo Warp would step on (``"cuda:0"``, ``"cpu"``); None: not installed."""
    if importlib.util.find_spec("mujoco_warp") is None:
        return None
    import warp

    return str(warp.get_preferred_device())


def on_warp(robot: Robot, n: int, steps: int) -> dict[str, Rate]:
    """The native vector env on MuJoCo Warp (its copies: the worlds of one Warp batch).

    One env steps alternately with each batch's period one Warp graph and with its kernels
    launched one by one from Python (``WarpScenes.graphs``), in four rounds after five untimed
    periods of each (Warp's compile, the graph's recording).
    """
    from revolve_env.envs.vector import LocomotionVectorEnv
    from revolve_env.world.warp_scenes import WarpScenes

    w0 = time.perf_counter()
    venv = LocomotionVectorEnv(n, robot=robot, engine="mujoco_warp", proprioception=True)
    venv.reset(seed=0)
    setup = time.perf_counter() - w0
    scenes = venv._world._backend  # type: ignore[union-attr]  # the isolated world's scenes
    assert isinstance(scenes, WarpScenes)
    sides = {"Warp graph": True, "kernels from Python": False}
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, venv.action_space.shape).astype(np.float32) for _ in range(8)]
    spent = {name: [0.0, 0.0] for name in sides}
    for flag in sides.values():
        scenes.graphs = flag
        for t in range(5):
            venv.step(actions[t])
    rounds = 4
    for r in range(rounds):
        for name, flag in sides.items():
            scenes.graphs = flag
            with _clock() as took:
                for t in range(r * steps // rounds, (r + 1) * steps // rounds):
                    venv.step(actions[t % 8])
            spent[name][0] += took[0]
            spent[name][1] += took[1]
    venv.close()
    return {name: Rate(n * steps / w, n * steps / c, setup) for name, (w, c) in spent.items()}


def raw_warp(robot: Robot, n: int, steps: int) -> Rate:
    """Warp's floor: the robot's model in one ``mujoco_warp`` batch, each period one Warp graph
    (its physics steps) between the servo law in NumPy and the hinges' angles read back."""
    import mujoco
    import mujoco_warp as mjw
    import warp as wp

    from revolve_env.world.warp_scenes import _FIRST_ROOM

    config = WorldConfig(engine="mujoco")
    w0 = time.perf_counter()
    model = _exported(robot, config)
    model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)  # as WarpScenes
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    m = mjw.put_model(model)
    d = mjw.put_data(model, data, nworld=n, nconmax=_FIRST_ROOM[0], njmax=_FIRST_ROOM[1])
    law = _servo_law(model, n, config)
    for _ in range(config.substeps):  # a first period loads the kernels (as WarpScenes)
        mjw.step(m, d)
    with wp.ScopedCapture(force_module_load=False) as capture:
        for _ in range(config.substeps):
            mjw.step(m, d)
    setup = time.perf_counter() - w0

    def period(t: int) -> None:
        d.ctrl.assign(law(t, d.qpos.numpy()).astype(np.float32))
        wp.capture_launch(capture.graph)

    rate = _raw_rate(period, n, steps, setup, finish=d.qpos.numpy)  # the last period done
    if d.overflow.numpy().any():
        print(f"(raw MuJoCo Warp, N = {n}: Warp's overflow flag is set; the row is not valid)")
    return rate


def via_sb3(robot: Robot, n: int, steps: int, batched: bool) -> Rate:
    from revolve_env import rl

    def make() -> object:
        config = rl.VecEnvConfig(n_envs=n, insertion_time=3.0, evaluation_time=12.0,
                                 normalize=False, batched=batched)
        return rl.make_vec_env(robot, config, engine="mujoco")

    return env_rate(make, n, steps, sb3=True)


def setup_time(n: int) -> tuple[float, float]:
    """Wall and CPU seconds of the native vector env of ``n`` spiders and its first reset."""
    from revolve_env.envs.vector import LocomotionVectorEnv

    with _clock() as spent:
        venv = LocomotionVectorEnv(n, robot=spider(), engine="mujoco", proprioception=True)
        venv.reset(seed=0)
    venv.close()
    return spent[0], spent[1]


def one_by_one(task: EvalTask) -> EvalOutcome:
    """evaluate_task, which the evaluators cannot batch (so each candidate goes alone)."""
    return evaluate_task(task)


def infancy(budget: float, insertion: float, seconds: float, repeats: int = 2) -> list[str]:
    """CMA-ES popsize 16 on the spider: one by one vs batched, CPU seconds and the results.

    The sides alternate ``repeats`` times after an untimed run of each (the process's one-time
    costs: imports, the compiled rollout's kernel check), each keeping its least CPU time.
    """
    lines = []
    results = {}
    best: dict[str, tuple[float, float]] = {}
    routes = (("one by one", one_by_one), ("batched", evaluate_task))
    for attempt in range(repeats + 1):
        for name, function in routes:
            evaluation = CandidateEvaluation(insertion=insertion, seconds=seconds,
                                             engine="mujoco", function=function)
            learner = CMAESLearner(popsize=16, evaluation=evaluation)
            with _clock() as spent:
                result = learner.learn(spider(), budget, np.random.default_rng(0))
            results[name] = result
            if attempt and spent[1] < best.get(name, (math.inf, math.inf))[1]:
                best[name] = (spent[0], spent[1])
    for name, _ in routes:
        result = results[name]
        wall, cpu = best[name]
        lines.append(f"| CMA-ES popsize 16, budget {budget:g} s ({insertion:g} + {seconds:g} s "
                     f"per candidate), {name} | {result.evaluations} | {cpu:.2f} | "
                     f"{wall:.2f} | {result.best_fitness:.6f} |")
    same = results["one by one"].fitness == results["batched"].fitness
    ratio = best["one by one"][1] / best["batched"][1]
    lines.append(f"(same fitness of every candidate on both routes: {same}; one by one / "
                 f"batched CPU {ratio:.2f}x, least of {repeats} after an untimed run each)")
    return lines


def _fmt(rate: Rate | None, note: str = "") -> str:
    if rate is None:
        return f"| {note} | | |"
    return f"| {rate.wall:,.0f} | {rate.cpu:,.0f} | {rate.setup:.2f} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="small N and short runs")
    parser.add_argument("--device-check", action="store_true",
                        help="N = 1, 16, 256, 4096 and one table to paste into the docs")
    parser.add_argument("--steps", type=int, default=None, help="control periods per row")
    parser.add_argument("--sizes", type=int, nargs="+", default=None, metavar="N",
                        help="the numbers of copies (default: 1 16 64 with --quick, else 1 16 "
                             "256 4096)")
    parser.add_argument("--robots", nargs="+", choices=("spider", "20-part random"),
                        default=["spider", "20-part random"], help="the robots of the rows")
    parser.add_argument("--warp-only", action="store_true",
                        help="only the MuJoCo Warp rows and the native vector env on 1 thread "
                             "beside them (no infancy)")
    parser.add_argument("--infancy-only", action="store_true",
                        help="only the CMA-ES infancy rows (budgets 119 s and 480 s)")
    parser.add_argument("--setup", type=int, nargs="+", default=None, metavar="N",
                        help="only the native vector env's set-up time for these N")
    args = parser.parse_args()
    if args.setup:
        setup_time(2)  # imports and first-call costs, untimed
        print(f"native vector env set-up, spider, load average {os.getloadavg()[0]:.1f}")
        for n in args.setup:
            wall, cpu = setup_time(n)
            print(f"N = {n:5d}: set-up {wall:8.2f} s wall, {cpu:8.2f} s CPU, "
                  f"{1e3 * cpu / n:6.1f} ms CPU per robot", flush=True)
        print(f"load average at the end {os.getloadavg()[0]:.1f}")
        return
    if args.quick:
        sizes, steps, env_limit = [1, 16, 64], args.steps or 60, 64
        budgets = [(119.0, 1.0, 6.0)]
    else:
        sizes, steps, env_limit = [1, 16, 256, 4096], args.steps or 200, 256
        budgets = [(119.0, 1.0, 6.0), (480.0, 3.0, 12.0)]
    if args.infancy_only:
        print(f"load average {os.getloadavg()[0]:.1f}")
        _infancy_table(budgets)
        print(f"load average at the end {os.getloadavg()[0]:.1f}")
        return
    sizes = args.sizes or sizes
    makers = {"spider": spider, "20-part random": twenty_part_robot}
    robots = {name: makers[name]() for name in args.robots}
    device = warp_device()
    gpu = device is not None and device != "cpu"
    warp_route = ("MuJoCo Warp: not installed (the warp extra)" if device is None else
                  f"MuJoCo Warp on {device}" if gpu else "MuJoCo Warp (no GPU: Warp on CPU)")
    print(f"# bench_batch: {platform.processor() or platform.machine()}, "
          f"{time.strftime('%Y-%m-%d')}, {steps} control periods per row")
    print("robot-steps per second (wall | CPU of this process), set-up wall seconds\n")
    print("| robot | N | route | steps/s wall | steps/s CPU | set-up s |")
    print("|---|---|---|---|---|---|")
    for name, robot in robots.items():
        for n in sizes:
            rows: list[tuple[str, str]] = []
            for threads in () if args.warp_only else (1, 2):
                rows.append((f"raw mujoco.batch, {threads} thr",
                             _fmt(raw_batch(robot, n, steps, threads))))
            if args.warp_only:
                if n <= env_limit:
                    rows.append(("native vector env, 1 thr", _fmt(native(robot, n, steps, 1))))
            elif n <= env_limit:
                for threads in (1, 2):
                    rows.append((f"native vector env, {threads} thr",
                                 _fmt(native(robot, n, steps, threads))))
                rows.append(("native via SB3 (rl.make_vec_env)",
                             _fmt(via_sb3(robot, n, steps, batched=True))))
                rows.append(("SB3 DummyVecEnv of single envs",
                             _fmt(via_sb3(robot, n, steps, batched=False))))
            else:
                for route in ("native vector env, 1 thr", "native vector env, 2 thr",
                              "native via SB3 (rl.make_vec_env)",
                              "SB3 DummyVecEnv of single envs"):
                    rows.append((route, _fmt(None, f"not run: N > {env_limit} (set-up "
                                                   "compiles a model per robot)")))
            if device is None:
                rows.append((warp_route, _fmt(None, "pip install '.[warp]'")))
            elif gpu or n <= 64:
                rows.append((f"raw MuJoCo Warp on {device}, Warp graph",
                             _fmt(raw_warp(robot, n, steps))))
                for side, rate in on_warp(robot, n, steps).items():
                    rows.append((f"{warp_route}, {side}", _fmt(rate)))
            else:
                rows.append((warp_route, _fmt(None, "not run: N > 64 on Warp's CPU")))
            for route, cells in rows:
                print(f"| {name} | {n} | {route} {cells}", flush=True)
    if args.warp_only:
        return
    _infancy_table(budgets)


def _infancy_table(budgets: list[tuple[float, float, float]]) -> None:
    print("\nInfancy (one spider): evaluations, CPU s, wall s, best fitness (m)\n")
    print("| learner | evaluations | CPU s | wall s | best fitness |")
    print("|---|---|---|---|---|")
    for budget, insertion, seconds in budgets:
        for line in infancy(budget, insertion, seconds):
            print(line, flush=True)


if __name__ == "__main__":
    main()
