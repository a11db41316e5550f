"""Births per minute of each experiment on this machine, and the wall time of the paper's study.

Usage::

    python benchmarks/bench_experiments.py [--births 45] [--workers 0] [--engine-only]
        [--physics pybullet|mujoco] [--only scenario1 scenario3] [--memory-after 300]
        [--floor-samples 12]

Runs each of the five experiments for ``--births`` births (fresh temporary results directory)
and prints births per minute; with ``--workers 1`` (everything in this process) also the CPU
time per birth, the figure the speed aims compare. ``--engine-only`` replaces the physics by a
constant-cost stand-in to measure the engine's own overhead (operators, selection, diversity,
SQLite). The estimate of the full study (5 experiments x 30 runs x 3000 births) assumes the
offline experiments keep all cores busy with evaluations and online runs go side by side, one
per core.

With ``--workers 1`` on MuJoCo it prints each run's CPU per birth next to its *floor* (issue 28):
the robot-seconds the run simulated (offline: births x 15 s; online: the robots alive between
commit points x the simulated time between them) divided by raw MuJoCo's robot-seconds per CPU
second, measured after the run in this process on the project's own exported models of the
run's robots (offline: ``--floor-samples`` of its robots spread over its births, each evaluation
recorded and replayed bare, as ``bench_engines.py`` does; online: worlds of the populations
alive at ``--floor-samples`` commit points spread over the run, 5 s each), and their ratio (aim
<= 1.25x). Every run also prints its resident memory's growth per birth from
``--memory-after`` births on (RSS at every commit point; aim online <= 20 KB per birth), and the
load average at the start and the end.

With ``--workers 1`` it also prints, per experiment, the calibration's estimate of the CPU per
birth (:func:`evolution.experiments.app.estimate.calibrate`, what ``revolve study`` prints before
it starts: robots alive and robot-seconds per CPU second) beside the measured one, and projects
the paper's study from the measured runs onto 2 cores and a 64-core Ray cluster
(:func:`evolution.experiments.app.estimate.estimate`: a run is the unit of parallelism, one run per
core, online runs first; an experiment not measured takes the cost of a measured one of its
mode; an online run's robots alive grow on to 3000 births as the study's estimate grows them).
The aim, <= 7 h on 2 cores, is judged from runs of >= 1000 births (scenario 1's
evolved robots were measured to cost per simulated second what random ones do over 1000 births,
but a short run's CPU per birth carries its start: generation 0, the engine's first load).

``--keep DIR`` keeps each run's results in ``DIR/<experiment>`` (a new folder).
"""

from __future__ import annotations

import argparse
import calendar
import contextlib
import dataclasses
import math
import os
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # run from a checkout

from bench_engines import crowd_env, numpy_rules, on_a_grid, record_evaluate, recorded
from bench_memory import per_birth_and_alive, rss_mb, slope

from evolution import experiments
from evolution.evaluation import EvalOutcome, EvalTask, LocalEvaluator, evaluate_task
from evolution.experiments import ExperimentConfig, preset
from evolution.experiments.app.estimate import (
    BirthCost,
    RunWork,
    calibrate,
    estimate,
    run_cpu_seconds,
)
from evolution.experiments.loop.registry import PAPER_SCENARIOS
from evolution.experiments.loop.run import ProgressEvent, decode
from evolution.experiments.store.database import Store
from revolve_env.body.serialize import to_json

STUDY_RUNS, STUDY_BIRTHS = 30, 3000


def constant_evaluate(task: EvalTask) -> EvalOutcome:
    """No physics: a fitness from the genome's length (measures engine overhead only)."""
    return EvalOutcome(float(len(to_json(task.robot, indent=None)) % 101) / 100.0, 0.0, 0.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--births", type=int, default=45)
    parser.add_argument("--workers", type=int, default=0, help="0: all cores")
    parser.add_argument("--engine-only", action="store_true")
    parser.add_argument("--only", nargs="*", default=list(PAPER_SCENARIOS))
    parser.add_argument("--physics", choices=("pybullet", "mujoco"), default=None,
                        help="the physics engine (default: each config's)")
    parser.add_argument("--memory-after", type=int, default=300,
                        help="RSS growth per birth from this many births on")
    parser.add_argument("--floor-samples", type=int, default=12,
                        help="robots (offline) or worlds (online) the floor is measured on")
    parser.add_argument("--deadline", default=None, metavar="HH:MM",
                        help="stop a run at its first commit point after this UTC time (the next "
                             "one: tomorrow's once today's has passed) and "
                             "report the births it committed")
    parser.add_argument("--given", nargs="*", default=[], metavar="NAME=MS@BIRTHS",
                        help="an experiment's CPU per birth measured by another run of this "
                             "benchmark (ms over that many births), for the study's projection")
    parser.add_argument("--given-alive", type=float, default=0.0,
                        help="online --given: the mean robots alive of that run")
    parser.add_argument("--trace", type=Path, default=None, metavar="FILE",
                        help="write births, robots alive, RSS (MB) and CPU (s) at every commit "
                             "point to FILE as CSV, as the run goes")
    parser.add_argument("--keep", type=Path, default=None, metavar="DIR",
                        help="keep each run's results in DIR/<experiment> (default: a "
                             "temporary folder, deleted)")
    args = parser.parse_args()
    deadline = None if args.deadline is None else _next_utc(args.deadline)
    cores = args.workers or os.cpu_count() or 1
    print(f"load average at the start {_load()}")
    if deadline is not None:
        print("stopping each run at its first commit point after "
              + time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(deadline)))
    print(f"{'experiment':<12} {'births':>6} {'wall s':>8} {'births/min':>11} {'sim s/wall s':>12}"
          f" {'study h (2 cores)':>18} {'CPU ms/birth':>13}")
    total_hours = 0.0
    # name -> (config, CPU seconds, mean robots alive at the commit points)
    measured: dict[str, tuple[ExperimentConfig, float, float]] = {}
    floors: list[str] = []
    memory: list[str] = []
    for name in args.only:
        try:
            run = measure_run(name, args.births, cores, physics=args.physics,
                              engine_only=args.engine_only, floor_samples=args.floor_samples,
                              memory_after=args.memory_after, deadline=deadline, keep=args.keep,
                              trace=args.trace)
        except ImportError as error:
            print(f"{name:<12} unavailable: {error}")
            continue
        if run.floor is not None:
            floors.append(run.floor_line())
            print(floors[-1], flush=True)
        memory.append(run.memory_line(args.memory_after))
        print(memory[-1], flush=True)
        rate = run.births / run.wall * 60
        speed = run.events[-1].sim_time / run.wall
        # On 2 cores: offline runs use every core for evaluations (scaled from `cores` here);
        # online worlds are one process each, two runs side by side.
        rate_2_cores = rate * 2 / cores if run.config.mode == "offline" else rate * 2
        hours = STUDY_RUNS * STUDY_BIRTHS / rate_2_cores / 60
        total_hours += hours
        per_birth = f"{run.cpu / run.births * 1e3:.0f}" if cores == 1 else "n/a"
        if cores == 1:
            measured[name] = (run.config, run.cpu, run.alive)
        stopped = f" (stopped at --deadline {args.deadline} UTC)" if run.stopped else ""
        print(f"{name:<12} {run.births:>6} {run.wall:>8.1f} {rate:>11.1f} {speed:>12.1f} "
              f"{hours:>18.1f} {per_birth:>13}{stopped}", flush=True)
    for given in args.given:
        name, _, figures = given.partition("=")
        ms, _, births_text = figures.partition("@")
        config = preset(name, births=int(births_text), runs=1)
        measured[name] = (config, float(ms) / 1e3 * config.births, float(args.given_alive))
        print(f"{name:<12} given: {float(ms):.0f} ms CPU per birth over {config.births} births "
              "(another run of this benchmark)")
    print(f"\nfull study ({len(args.only)} experiments x {STUDY_RUNS} runs x "
          f"{STUDY_BIRTHS} births, 2 cores): {total_hours:.0f} h = {total_hours / 24:.1f} days")
    if floors:
        print("\nCPU per birth against its floor (the robot-seconds the run simulated over raw "
              "MuJoCo's robot-seconds per CPU second on the run's own robots, this process; "
              "aim <= 1.25x):")
        print(*floors, sep="\n")
    print(f"\nresident memory (RSS) after {args.memory_after} births (aim online <= 20 KB per "
          "birth):")
    print(*memory, sep="\n")
    if measured:
        project(measured)
    print(f"\nload average at the end {_load()}")


@dataclass(frozen=True, slots=True)
class Floor:
    """A run's floor: the robot-seconds it simulated at raw MuJoCo's rate on its own robots.

    Attributes:
        simulated: Robot-seconds the run simulated.
        rate: Raw MuJoCo's robot-seconds per CPU second on the run's robots.
        what: What the rate was measured on, in words.
    """

    simulated: float
    rate: float
    what: str

    @property
    def cpu(self) -> float:
        """CPU time of the run at the floor. Seconds."""
        return self.simulated / self.rate


@dataclass(frozen=True, slots=True)
class RunMeasurement:
    """One measured run of an experiment (up to its last commit point).

    Attributes:
        name: The experiment.
        config: Its config, ``births`` the births it committed.
        wall: Wall time. Seconds.
        cpu: This process's CPU time (with ``--workers 1``: the whole run). Seconds.
        events: Its progress events, one per commit point.
        rss: Resident memory at each commit point. MB.
        stopped: Whether ``deadline`` stopped it before its births.
        floor: Its floor (``--workers 1`` on MuJoCo, physics on), else ``None``.
    """

    name: str
    config: ExperimentConfig
    wall: float
    cpu: float
    events: tuple[ProgressEvent, ...]
    rss: tuple[float, ...]
    stopped: bool
    floor: Floor | None

    @property
    def births(self) -> int:
        """Births committed."""
        return self.events[-1].births

    @property
    def alive(self) -> float:
        """The mean robots alive at its commit points. Robots."""
        return sum(e.population_size for e in self.events) / len(self.events)

    @property
    def cpu_per_birth(self) -> float:
        """CPU per birth. Seconds."""
        return self.cpu / self.births

    def memory_growth(self, after: int) -> tuple[float, float] | None:
        """RSS growth per birth from ``after`` births on: (least squares, end minus start). KB.

        ``None`` with fewer than two commit points from ``after`` births on.
        """
        points = [(e.births, r) for e, r in zip(self.events, self.rss, strict=True)
                  if e.births >= after]
        if len(points) < 2 or points[-1][0] == points[0][0]:
            return None
        (b0, r0), (b1, r1) = points[0], points[-1]
        fit = slope([b for b, _ in points], [r for _, r in points])
        return 1e3 * fit, 1e3 * (r1 - r0) / (b1 - b0)

    def memory_line(self, after: int) -> str:
        """:meth:`memory_growth` in one line."""
        growth = self.memory_growth(after)
        if growth is None:
            return f"  {self.name:<12} fewer than two commit points after {after} births"
        points = [(e.births, r) for e, r in zip(self.events, self.rss, strict=True)
                  if e.births >= after]
        (b0, r0), (b1, r1) = points[0], points[-1]
        line = (f"  {self.name:<12} {growth[0]:7.1f} KB per birth (least squares), "
                f"{growth[1]:7.1f} end minus start (births {b0} -> {b1}: "
                f"{r0:.1f} -> {r1:.1f} MB)")
        apart = self.memory_apart(after)
        if apart is None:
            return line
        return (f"{line}; robots alive apart: {apart[0]:.1f} KB per birth, "
                f"{apart[1]:.2f} MB per robot alive")

    def memory_apart(self, after: int) -> tuple[float, float] | None:
        """RSS growth from ``after`` births on per birth at constant robots alive (KB) and per
        robot alive at a constant birth count (MB): :func:`bench_memory.per_birth_and_alive`."""
        later = [(e, r) for e, r in zip(self.events, self.rss, strict=True) if e.births >= after]
        fit = per_birth_and_alive([e.births for e, _ in later],
                                  [e.population_size for e, _ in later], [r for _, r in later])
        return None if fit is None else (1e3 * fit[0], fit[1])

    def floor_line(self) -> str:
        """The run's CPU per birth, its floor and their ratio, in one line."""
        floor = self.floor
        if floor is None:
            return f"  {self.name:<12} no floor measured"
        births = self.births
        return (f"  {self.name:<12} {1e3 * self.cpu / births:7.0f} ms CPU per birth, floor "
                f"{1e3 * floor.cpu / births:7.0f} ms ({floor.simulated:.3g} robot-s at "
                f"{floor.rate:.0f} robot-s per CPU-s of raw MuJoCo, {floor.what}): "
                f"{self.cpu / floor.cpu:.2f}x")


def measure_run(name: str, births: int, cores: int, *, physics: str | None = None,
                engine_only: bool = False, floor_samples: int = 12, memory_after: int = 300,
                deadline: float | None = None, keep: Path | None = None,
                trace: Path | None = None) -> RunMeasurement:
    """Run experiment ``name`` once for ``births`` births on ``cores`` and measure it.

    One run: births per minute and CPU per birth count that run's births (the shipped configs'
    30 runs would run side by side, 30 times the births of the rate printed). With one core on
    MuJoCo (physics on), the floor is measured after the run on its own robots.

    Args:
        deadline: Stop at the first commit point after this Unix time (the work after it is
            lost, as a killed run's).
        keep: Keep the results in ``keep/<name>`` (default: a temporary folder, deleted).
        trace: Append ``name,births,alive,rss_mb,cpu_s`` at every commit point to this CSV
            file as the run goes (a long run's memory against births and robots alive).

    Raises:
        ImportError: the experiment's engine is not installed.
    """
    config = preset(name, births=births, workers=cores, runs=1)
    if physics is not None:
        config = config.replace(world=dataclasses.replace(config.world, engine=physics))
    function = constant_evaluate if engine_only else evaluate_task
    with contextlib.ExitStack() as stack:
        if keep is None:
            folder = Path(stack.enter_context(tempfile.TemporaryDirectory())) / "out"
        elif (keep / name).exists():
            raise FileExistsError(f"--keep: {keep / name} exists; give a new folder")
        else:
            folder = keep / name
        evaluator = stack.enter_context(LocalEvaluator(cores, function))
        events: list[ProgressEvent] = []
        rss: list[float] = []
        spent: list[float] = []  # the process's CPU at each commit point. Seconds

        def seen(event: ProgressEvent) -> None:
            if not event.replaying and not event.finished:
                events.append(event)
                rss.append(rss_mb())
                spent.append(time.process_time())
                if trace is not None:
                    new = not trace.exists()
                    with trace.open("a", encoding="utf-8") as out:
                        if new:
                            out.write("name,births,alive,rss_mb,cpu_s\n")
                        out.write(f"{name},{event.births},{event.population_size},"
                                  f"{rss[-1]:.2f},{spent[-1] - cpu:.2f}\n")
                if deadline is not None and time.time() >= deadline:
                    raise _Deadline

        start = time.perf_counter()
        cpu = time.process_time()
        stopped = False
        try:
            experiments.run(config, folder, seen, evaluator=evaluator)
        except _Deadline:
            stopped = True
        # Up to the last commit point.
        wall = time.perf_counter() - start
        cpu = spent[-1] - cpu
        config = config.replace(births=events[-1].births)
        floor = None
        if cores == 1 and not engine_only and config.world.engine == "mujoco":
            floor = measure_floor(config, folder / "results.sqlite", events, floor_samples)
    return RunMeasurement(name, config, wall, cpu, tuple(events), tuple(rss), stopped, floor)


class _Deadline(Exception):
    """A run reached --deadline (raised at a commit point: nothing after it is lost)."""


def _next_utc(hhmm: str) -> float:
    """The next ``HH:MM`` UTC as a Unix time (tomorrow's once today's has passed). Seconds."""
    now = time.gmtime()
    hours, minutes = (int(x) for x in hhmm.split(":"))
    today = calendar.timegm((now.tm_year, now.tm_mon, now.tm_mday, hours, minutes, 0, 0, 0, 0))
    return today if today > time.time() else today + 24 * 3600


def _load() -> str:
    """The 1, 5 and 15 minute load averages of this machine."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def run_robot_seconds_simulated(config: ExperimentConfig,
                                events: Sequence[ProgressEvent]) -> float:
    """Robot-seconds a measured run simulated. Robot-seconds.

    Offline: one evaluation per birth. Online: between two commit points the world lives from
    the first one's simulated time to the second's with the robots alive at the first (births
    and deaths fall on the commit points' conception ticks).
    """
    if config.mode == "offline":
        return events[-1].births * config.seconds_per_evaluation
    return sum(a.population_size * (b.sim_time - a.sim_time)
               for a, b in zip(events, events[1:], strict=False))


def measure_floor(config: ExperimentConfig, db: Path, events: Sequence[ProgressEvent],
                  samples: int) -> Floor | None:
    """The floor of a measured run stored in ``db`` (``None``: no simulated time committed)."""
    simulated = run_robot_seconds_simulated(config, events)
    if simulated <= 0:
        return None
    with Store.open(db) as store:
        robots = {r.robot_id: r.genome for r in store.robots(0)}
        snapshots = store.population_snapshots(0)
    if config.mode == "offline":
        rate, what = _raw_offline_rate(config, robots, samples)
    else:
        rate, what = _raw_online_rate(config, robots, snapshots, samples)
    return Floor(simulated, rate, what)


def _spread(count: int, items: int) -> list[int]:
    """``count`` indices spread evenly over ``items`` (each once)."""
    return sorted({int(i) for i in np.linspace(0, items - 1, min(count, items))})


def _raw_offline_rate(config: ExperimentConfig, robots: dict[int, str],
                      samples: int) -> tuple[float, str]:
    """Raw MuJoCo's robot-seconds per CPU second on robots of the run, evaluated as it did.

    Each sampled robot's evaluation (insertion + window, seed 0) is recorded on the NumPy path
    and replayed bare (:class:`bench_engines.Replay`: one ``mj_step`` call and the servo law per
    control period), best CPU of two.
    """
    ids = sorted(robots)
    chosen = [ids[i] for i in _spread(samples, len(ids))]
    seconds = raw = 0.0
    for robot_id in chosen:
        replay, check = record_evaluate(decode(robots[robot_id]), config.evaluation_time,
                                        config.insertion, seed=robot_id,
                                        conditions=config.evaluation)
        if check != "exact":
            raise RuntimeError(f"robot {robot_id}'s raw replay is {check}")
        seconds += config.seconds_per_evaluation
        raw += min(replay.run(), replay.run())
    return seconds / raw, f"{len(chosen)} of its robots x {config.seconds_per_evaluation:g} s"


_WORLD_SECONDS = 5.0
"""Simulated seconds of each online world the floor replays."""


def _raw_online_rate(config: ExperimentConfig, robots: dict[int, str],
                     snapshots: Sequence[tuple[int, float, list[tuple[int, float | None]]]],
                     samples: int) -> tuple[float, str]:
    """Raw MuJoCo's robot-seconds per CPU second on worlds of the run's own populations.

    At ``samples`` commit points spread over the run, the robots alive then are put in one
    population env (the run's settings, 1.2 m apart on a grid), left 0.5 s to land, then
    stepped :data:`_WORLD_SECONDS` with the world's targets recorded and replayed bare
    (best CPU of two).
    """
    robot_seconds = raw = 0.0
    chosen = [snapshots[i] for i in _spread(samples, len(snapshots))]
    for _, _, members in chosen:
        alive = [decode(robots[robot_id]) for robot_id, _ in members]
        env = crowd_env(on_a_grid(alive), landing=0, limits=config.evolution.limits,
                        conditions=config.evaluation, task=config.fitness_task(),
                        terrain=config.world.terrain_spec, trajectory_length=0)
        try:
            ticks = round(_WORLD_SECONDS / float(env.config.control_period))
            with numpy_rules():
                for _ in range(30):
                    env.advance({})
                replay, check = recorded(env, ticks, env.advance)
            if len(replay.targets) != ticks:
                raise RuntimeError(f"the world stepped {len(replay.targets)} recorded periods "
                                   f"of {ticks}: the env no longer steps through World.step")
            if check != "exact":
                raise RuntimeError(f"the raw replay of a world of {len(alive)} robots is {check}")
            robot_seconds += len(alive) * _WORLD_SECONDS
            raw += min(replay.run(), replay.run())
        finally:
            env.close()
    return robot_seconds / raw, (f"{len(chosen)} worlds of its populations x "
                                 f"{_WORLD_SECONDS:g} s")


def _measured_cost(config: ExperimentConfig, cpu: float, alive: float) -> BirthCost:
    """A whole measured run in the calibration's terms: robot-seconds per birth and per CPU-s.

    Online: per conception interval, at the run's mean robots alive (the initial robots are
    born together at time 0).
    """
    births = config.births
    per_birth = config.seconds_per_evaluation
    if config.mode == "online":
        births = max(1, config.births - config.population_size)
        per_birth = alive * config.conception_interval
    return BirthCost(config.mode, config.world.engine, births * per_birth / cpu, per_birth,
                     f"a measured run of {config.births} births",
                     alive if config.mode == "online" else 0.0)


def project(measured: dict[str, tuple[ExperimentConfig, float, float]]) -> dict[int, float]:
    """Calibration against measurement, and the paper's study projected from the measurement.

    The calibration's robots alive (online: measured at the run's start, grown over the run's
    births as the study's estimate grows them) and robot-seconds per CPU second beside the
    measured run's; their ratio of CPU per birth says how far off the study's estimate is. The
    study's online runs (3000 births) take the measured run's CPU per robot-second and its robots
    alive grown on by the estimate's curve (:mod:`evolution.experiments.app.world_size`) scaled
    through the measured run's mean.

    Args:
        measured: Experiment -> (its config, births its run committed; CPU seconds of the run;
            online: the mean robots alive at its commit points).

    Returns:
        The study's wall time on 2 and on 64 cores (hours), by cores; empty when an experiment
        had no measured run of its mode (the lines printed project the others).
    """
    print(f"\n{'experiment':<12} {'measured ms/birth':>18} {'alive':>6} {'robot-s/CPU-s':>14} "
          f"{'calibrated ms/birth':>20} {'alive':>6} {'robot-s/CPU-s':>14} "
          f"{'calibrated/measured':>20}")
    costs: dict[str, BirthCost] = {}
    for name, (config, cpu, alive) in measured.items():
        cost = _measured_cost(config, cpu, alive)
        guess = calibrate(config)
        grown = guess.growth_factor(config.population_size, config.births)  # online: the run's
        if guess.growth is not None and alive > 0:
            # The study's runs are longer: the measured world grows on as the estimate grows it
            # (its curve scaled to pass through the measured run's mean).
            g, k = guess.growth, alive / (guess.alive * grown)
            cost = dataclasses.replace(cost, growth=dataclasses.replace(
                g, start=g.start * k, ceiling=g.ceiling * k))
        costs[name] = cost
        alive_then = f"{cost.alive:.1f}" if cost.alive else "-"
        print(f"{name:<12} {1e3 * cost.cpu_per_birth:>18.0f} {alive_then:>6} "
              f"{cost.rate:>14.0f} {1e3 * guess.cpu_per_birth * grown:>20.0f} "
              f"{f'{guess.alive * grown:.1f}' if guess.alive else '-':>6} {guess.rate:>14.0f} "
              f"{guess.cpu_per_birth * grown / cost.cpu_per_birth:>20.2f}")
    by_mode = {cost.mode: cost for cost in costs.values()}
    work, study_costs = [], {}
    for name in PAPER_SCENARIOS:
        config = preset(name, births=STUDY_BIRTHS, runs=STUDY_RUNS)
        cost = costs.get(name, by_mode.get(config.mode))
        if cost is None:
            print(f"no measured {config.mode} run: {name} left out of the projection")
            continue
        study_costs[name] = cost
        work += [RunWork(name, config)] * STUDY_RUNS
    for name, cost in study_costs.items():
        if cost.growth is not None:
            study = preset(name, births=STUDY_BIRTHS)
            print(f"{name}: the measured run's {cost.alive:.1f} robots alive grown to "
                  f"{cost.growth.mean_alive(study.population_size, STUDY_BIRTHS):.1f} over "
                  f"{STUDY_BIRTHS} births, as the study's estimate grows its world")
    longest = max(run_cpu_seconds(w, study_costs[w.experiment]) for w in work)
    print(f"\nthe paper's study ({len(study_costs)} experiments x {STUDY_RUNS} runs x "
          f"{STUDY_BIRTHS} births) from the measured CPU per birth; longest run "
          f"{longest / 3600:.2f} h:")
    shortest = min(config.births for config, _, _ in measured.values())
    print(f"  (from runs of {shortest} births or more; the aim, <= 7 h on 2 cores, is judged on "
          "runs of >= 1000 births)")
    hours = {}
    for cores in (2, 64):
        result = estimate(work, study_costs, cores)
        hours[cores] = result.wall_seconds / 3600
        waves = math.ceil(len(work) / cores)
        print(f"  {cores:>2} cores: {result.cpu_seconds / 3600:.1f} CPU-h, wall "
              f"{result.wall_seconds / 3600:.2f} h scheduled as the study runs (online first, "
              f"one run per core); at most {waves} wave(s) x the longest run = "
              f"{waves * longest / 3600:.2f} h")
    return hours if len(study_costs) == len(PAPER_SCENARIOS) else {}


if __name__ == "__main__":
    main()
