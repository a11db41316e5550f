"""How long a study will take: the robot-seconds it simulates at this machine's measured rate.

A study's cost is the simulated time of its robots: *robot-seconds*, one robot simulated for
one second. Each experiment's are set by its config (:func:`run_robot_seconds`):

* offline: every birth is one evaluation of ``insertion + evaluation_time`` seconds;
* online: the world lives one ``conception_interval`` per birth after the initial robots, with
  the robots alive in it: measured at the run's start (below), then growing over the run as
  :mod:`~evolution.experiments.app.world_size` derives from the survivor rule and measured runs
  (a long run's world holds more robots than its start: scenario 3's 9 grew to 13.8 on average
  over 1,889 births).

:func:`calibrate` measures, in a few CPU seconds, how many robot-seconds this machine simulates
per CPU second for an experiment, everything a birth costs included (building, reproduction,
selection, the Training Center, the online world's per-period work), on the start of the
experiment's own run 0 (its seed, its settings, its reproduction and selection; nothing written):

* offline: its generation 0 is told a stand-in fitness (not simulated: a run pays it once), then
  its first generations of children (at least 30: two of scenario 1's) are conceived, evaluated
  in this process and selected as the run does, all of it timed: CPU per birth, of which
  reproduction and selection (the child's body checks: a fifth of a scenario 1 birth);
* online: its population world (its initial robots and survivor selection) for a few conception
  intervals after the first selection; the robots alive over those intervals are the world's
  measured size at its start.

:func:`estimate` divides the robot-seconds by the rate: each experiment's CPU time, and the
study's wall time on ``workers`` run slots (a run is the unit of parallelism: one run on one
worker, online runs first, as :func:`~evolution.experiments.app.study.run_study` orders them). What
the calibration cannot know is stated by :data:`ASSUMPTIONS` and printed with the estimate: the
robots it measures are those of a run's first generations. Measured, scenario 1's evolved robots
did not cost more per simulated second than random ones over 1000 births on MuJoCo (their sizes
stayed 11-18 parts; their cost 0.8-1.3x random robots', no trend: docs/performance.md,
2026-11-27); the calibration's former 4 random robots of a fixed seed, without reproduction, were
what read 0.5-0.76x of measured runs. Nothing here writes a file.

Example::

    from evolution.experiments import load_config
    from evolution.experiments.app.estimate import calibrate, estimate, RunWork

    config = load_config("scenario1", {"world": {"engine": "mujoco"}})
    cost = calibrate(config)
    study = estimate([RunWork("scenario1", config.replace(births=3000))] * 30,
                     {"scenario1": cost}, workers=2)
    for line in study.lines():
        print(line)
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from evolution.evaluation import EvalOutcome, Evaluator, LocalEvaluator
from evolution.experiments.app.world_size import WorldGrowth, world_growth
from evolution.experiments.loop.config import ExperimentConfig
from evolution.experiments.loop.run import ProgressEvent

__all__ = [
    "ASSUMPTIONS",
    "BirthCost",
    "ExperimentEstimate",
    "RunWork",
    "StudyEstimate",
    "calibrate",
    "calibrate_all",
    "calibration_key",
    "estimate",
    "online_rate",
    "run_cpu_seconds",
    "run_robot_seconds",
]

ASSUMPTIONS = ("assumes a run's later robots cost per simulated second what its first "
               "generations cost (measured: scenario 1's over 1000 births on MuJoCo, 0.8-1.3x "
               "random robots, no growth), an online world growing from the size measured at its "
               "start as a measured scenario 3 run's grew, one run per worker, nothing else on "
               "the cores, the results' storage free")
"""What the estimate takes for granted, in one line."""

_OFFLINE_ROBOTS = 30
"""Children an offline calibration evaluates, at least (whole generations: two of scenario 1's).

Random robots' CPU per robot-second spreads widely (what they do, not only their size): 4 of
them cost 66-117 ms per birth over five seeds (scenario 1, MuJoCo), and the 4 robots of the
former fixed seed were among the cheapest (0.5-0.76x of measured runs, 2026-11-27). About 4 CPU
seconds on MuJoCo, several times that on pybullet."""
_ONLINE_INTERVALS = 3
"""Conception intervals an online calibration measures, after the first survivor selection."""


@dataclass(frozen=True, slots=True)
class BirthCost:
    """What one birth of an experiment simulates, and this machine's measured rate.

    Attributes:
        mode: ``"offline"`` or ``"online"``.
        engine: The physics engine.
        rate: Robot-seconds simulated per CPU second, everything a birth costs included.
            Robot-seconds per second.
        robot_seconds: Robot-seconds one birth simulates: offline, one evaluation; online, the
            robots alive for one conception interval. Robot-seconds.
        sample: What was measured, in words (e.g. ``30 children of the run's first
            generations x 15 s``).
        alive: Online: the mean number of robots alive measured (0 offline). Robots.
        reproduction: Offline: the CPU time of a birth outside its evaluation (conceiving the
            child, the checks of its body, selection), included in ``rate``. Seconds.
        growth: Online: how the robots alive grow from ``alive`` over a run's births (``None``:
            they stay at ``alive``, e.g. a measured run's mean).
    """

    mode: str
    engine: str
    rate: float
    robot_seconds: float
    sample: str
    alive: float = 0.0
    reproduction: float = 0.0
    growth: WorldGrowth | None = None

    @property
    def cpu_per_birth(self) -> float:
        """CPU time of one birth (online: at ``alive`` robots, the run's start). Seconds."""
        return self.robot_seconds / self.rate if self.rate > 0 else math.inf

    def growth_factor(self, first: int, last: int) -> float:
        """Online: the mean robots alive over births ``[first, last)`` over ``alive`` (else 1)."""
        if self.growth is None or self.alive <= 0:
            return 1.0
        return self.growth.mean_alive(first, last) / self.alive


@dataclass(frozen=True, slots=True)
class RunWork:
    """One run still to do: its experiment and the births it has already committed.

    Attributes:
        experiment: The experiment's name.
        config: The experiment's configuration.
        done: Births already committed (a resumed run). Births.
    """

    experiment: str
    config: ExperimentConfig
    done: int = 0

    @property
    def births_left(self) -> int:
        """Births still to commit. Births."""
        return max(0, self.config.births - self.done)

    @property
    def first_interval(self) -> int:
        """Online: the birth its conception intervals left start at. Births.

        The initial robots are born together at time 0; every later birth takes one interval.
        """
        return max(self.done, self.config.population_size)

    @property
    def intervals_left(self) -> int:
        """Online: the conception intervals still to simulate, one per later birth left."""
        return max(0, self.config.births - self.first_interval)


@dataclass(frozen=True, slots=True)
class ExperimentEstimate:
    """One experiment's share of a study.

    Attributes:
        name: The experiment.
        cost: Its calibrated birth cost.
        runs: Runs left to do.
        births: Births left, all its runs together.
        robot_seconds: Robot-seconds left to simulate, all its runs together.
        cpu_seconds: CPU time left, all its runs together. Seconds.
        wall_seconds: When its last run ends, from the study's start, its runs scheduled with
            the others' as the study runs them (0 with no run left). Seconds.
        alive: Online: the mean robots alive over the conception intervals left, its world's
            growth included (0 offline, or with no interval left). Robots.
    """

    name: str
    cost: BirthCost
    runs: int
    births: int
    robot_seconds: float
    cpu_seconds: float
    wall_seconds: float = 0.0
    alive: float = 0.0

    @property
    def cpu_per_birth(self) -> float:
        """CPU time of a birth on average (online: at :attr:`alive` robots). Seconds."""
        if self.cost.mode == "online" and self.alive > 0 and self.cost.alive > 0:
            return self.cost.cpu_per_birth * self.alive / self.cost.alive
        return self.cost.cpu_per_birth


@dataclass(frozen=True, slots=True)
class StudyEstimate:
    """A study's estimated CPU time and wall time.

    Attributes:
        experiments: One estimate per experiment, in the order given.
        workers: Runs at once (worker processes, or the Ray cluster's CPUs).
        wall_seconds: Wall time on ``workers`` (runs scheduled as the study does). Seconds.
        calibration_cpu: CPU time the calibration itself took. Seconds.
    """

    experiments: tuple[ExperimentEstimate, ...]
    workers: int
    wall_seconds: float
    calibration_cpu: float = 0.0

    @property
    def cpu_seconds(self) -> float:
        """CPU time of the whole study. Seconds."""
        return sum(e.cpu_seconds for e in self.experiments)

    def weights(self) -> dict[str, float]:
        """CPU time of one birth of each experiment (the progress display weighs births so)."""
        return {e.name: e.cpu_per_birth for e in self.experiments}

    def lines(self) -> list[str]:
        """The estimate in words: one line per experiment, the total, the assumptions."""
        out = []
        for e in self.experiments:
            c = e.cost
            per_birth = f"{c.robot_seconds:g} s per birth"
            if c.mode == "online" and c.alive > 0:
                per_birth = f"{_alive(e)} x {c.robot_seconds / c.alive:g} s per birth"
            parts = (f", {1e3 * c.reproduction:.0f} ms of each birth its reproduction and "
                     "selection" if c.reproduction > 0 else "")
            out.append(f"  {e.name}: {e.runs} run(s), {e.births} births, "
                       f"{_robot_seconds(e.robot_seconds)} ({c.mode}, {c.engine}: {per_birth}) "
                       f"at {c.rate:.0f} robot-s per CPU-s (from {c.sample}{parts}), "
                       f"{1e3 * e.cpu_per_birth:.0f} ms CPU per birth: "
                       f"{e.cpu_seconds / 3600:.2f} CPU-h, its last run done after "
                       f"{_hours(e.wall_seconds)} ({e.wall_seconds / 3600:.2f} h)")
        out.append(f"  total {_robot_seconds(sum(e.robot_seconds for e in self.experiments))}, "
                   f"{self.cpu_seconds / 3600:.2f} CPU-h: about {_hours(self.wall_seconds)} on "
                   f"{self.workers} worker(s) (calibration took {self.calibration_cpu:.1f} s CPU)")
        out.append(f"  (an estimate: it {ASSUMPTIONS})")
        return out


def _alive(e: ExperimentEstimate) -> str:
    """The robots alive an online experiment's estimate assumes, and why, in words."""
    c, g = e.cost, e.cost.growth
    if g is None:  # e.g. a measured run's mean
        return f"{c.alive:.1f} robots alive"
    if e.alive >= c.alive + 0.05:
        return (f"{e.alive:.1f} robots alive on average ({c.alive:.1f} measured at its start, "
                f"growing after {g.onset:.0f} births toward the survivor rule's {g.ceiling:.1f} "
                "as a measured run's grew)")
    if e.alive <= 0:  # no interval left
        why = ""
    elif g.ceiling <= c.alive:
        why = f", at or above the survivor rule's ceiling of {g.ceiling:.1f}"
    else:
        why = f"; its world grows after {g.onset:.0f} births, past this study's"
    return f"{c.alive:.1f} robots alive (measured at its start{why})"


def calibration_key(config: ExperimentConfig) -> tuple[object, ...]:
    """What a birth's cost depends on: experiments equal here share one calibration.

    Both modes calibrate on the start of the experiment's own run, so its reproduction and
    selection settings and its seed count (offline: scenario 2's one child per generation and
    the baselines' random robots or random survivors are not scenario 1's births).
    """
    loop = (config.population_size, config.survivor_selection, config.new_robots,
            config.tournament_size, config.max_conception_attempts, config.diversity_interval,
            config.seed)
    online = ((config.conception_interval, config.min_alive, config.max_alive,
               config.death_threshold, config.cull_fraction, config.birth_radius,
               config.birth_clearance, config.fertile_age)
              if config.mode == "online" else (config.offspring_size,))
    return (config.mode, config.world, config.insertion, config.evaluation_time,
            config.evaluation, config.evolution, repr(config.learning), repr(config.task),
            *loop, *online)


def calibrate(config: ExperimentConfig, *, seed: int = 0, robots: int | None = None,
              intervals: int = _ONLINE_INTERVALS,
              evaluator: Evaluator | None = None,
              clock: Callable[[], float] = time.process_time) -> BirthCost:
    """Measure the robot-seconds ``config`` simulates per CPU second on this machine.

    Args:
        config: The experiment.
        seed: Offline: seeds the stand-in fitness of the run's generation 0 (not simulated).
            (Online the run's own seed is used.)
        robots: Offline: children evaluated, at least (default :data:`_OFFLINE_ROBOTS`; whole
            generations).
        intervals: Online: conception intervals measured after the first survivor selection.
        evaluator: Offline: evaluates the children (default: in this process, as a run with one
            worker does; the CPU it spends must show on ``clock``).
        clock: The CPU clock. Seconds.

    Returns:
        The measured rate and what one birth simulates (online: at the robots alive measured).
    """
    if config.mode == "online":
        return _calibrate_online(config, intervals, clock)
    rng = np.random.default_rng(seed)
    own = evaluator is None
    used = LocalEvaluator(1) if evaluator is None else evaluator
    try:
        return _calibrate_offline(config, rng, robots or _OFFLINE_ROBOTS, used, clock)
    finally:
        if own:
            used.close()


def _calibrate_offline(config: ExperimentConfig, rng: np.random.Generator, count: int,
                       evaluator: Evaluator, clock: Callable[[], float]) -> BirthCost:
    # Imported here: the loop's module loads the online world's (the physics engine's) too.
    from evolution.experiments.loop.evolve import Evolution

    # The start of the experiment's run 0, not written anywhere: its generation 0 (random
    # robots) told a stand-in fitness, not simulated (a run pays it once), then its first
    # generations of children, each conceived by the run's own reproduction, evaluated and
    # selected as the run does, timed whole: a birth's cost is all of it.
    short = config.replace(births=config.population_size + count + config.offspring_size,
                           max_sim_time=None)
    evaluation = other = 0.0
    children = 0
    with Evolution(short, evaluator=evaluator) as evolution:
        tasks = evolution.ask()
        # The first evaluation loads the engine and its caches: a cost a run pays once.
        evaluator.evaluate([replace(tasks[0], insertion=0.0, seconds=config.evaluation_time / 10,
                                    infancy=None)])
        while evolution.tell([EvalOutcome(float(rng.random()), 0.0, 0.0) for _ in tasks]) is None:
            tasks = evolution.ask()  # generation 0: until the population is full
        while children < count and not evolution.done:
            start = clock()
            tasks = evolution.ask()
            asked = clock()
            outcomes = evaluator.evaluate(tasks)
            evaluated = clock()
            evolution.tell(outcomes)
            other += asked - start + clock() - evaluated
            evaluation += evaluated - asked
            children += len(tasks)
    seconds = config.seconds_per_evaluation
    cpu = max(evaluation + other, 1e-9)
    return BirthCost("offline", config.world.engine, children * seconds / cpu, seconds,
                     f"{children} children of the run's first generations x {seconds:g} s",
                     reproduction=other / max(children, 1))


def online_rate(events: Sequence[ProgressEvent], cpu: Sequence[float], skip: int = 1
                ) -> tuple[float, float, float]:
    """Robots alive and robot-seconds per CPU second of an online run's commit points.

    Between two commit points the world lives from the first one's simulated time to the
    second's with the robots alive at the first (a blow-up in between is not counted).

    Args:
        events: The run's progress events, one per commit point, in order.
        cpu: The process's CPU time at each of them. Seconds.
        skip: Intervals left out at the start (the initial robots' first one: no survivor
            selection has happened yet).

    Returns:
        ``(alive, rate, robot_seconds)``: the time-weighted mean number of robots alive
        (robots), robot-seconds per CPU second, and the robot-seconds measured.

    Raises:
        ValueError: no simulated time or no CPU time past the skipped intervals.
    """
    robot_seconds = seconds = spent = 0.0
    for k in range(skip, len(events) - 1):
        dt = events[k + 1].sim_time - events[k].sim_time
        robot_seconds += events[k].population_size * dt
        seconds += dt
        spent += cpu[k + 1] - cpu[k]
    if seconds <= 0 or spent <= 0:
        raise ValueError(f"no simulated or CPU time measured in {len(events)} commit points "
                         f"after {skip} interval(s)")
    return robot_seconds / seconds, robot_seconds / spent, robot_seconds


def _calibrate_online(config: ExperimentConfig, intervals: int,
                      clock: Callable[[], float]) -> BirthCost:
    # Imported here: the online world loads the physics engine.
    from evolution.experiments.loop.evolve import Evolution, ProgressObserver
    from evolution.experiments.loop.online_world import PopulationWorld
    from evolution.experiments.loop.run import run_seed, world_seed

    # The start of the experiment's run 0, not written anywhere: its initial robots, the first
    # conception interval (skipped: no selection yet), then ``intervals`` more, a commit each.
    short = config.replace(checkpoint_interval=1, max_sim_time=None)
    events: list[ProgressEvent] = []
    cpu: list[float] = []

    def seen(event: ProgressEvent) -> None:
        if not event.finished:
            events.append(event)
            cpu.append(clock())

    world = PopulationWorld(short, world_seed(run_seed(short.seed, 0)))
    try:
        with Evolution(short, world=world, observers=[ProgressObserver(seen)]) as evolution:
            evolution.start()
            while not evolution.done and len(events) < intervals + 2:
                evolution.step()
    finally:
        world.close()
    if len(events) < 2:  # the initial robots are every birth: no interval to simulate
        return BirthCost("online", config.world.engine, math.inf, 0.0, "no conception interval",
                         float(config.population_size))
    skip = 1 if len(events) > 2 else 0
    alive, rate, measured = online_rate(events, cpu, skip)
    return BirthCost("online", config.world.engine, rate, alive * config.conception_interval,
                     f"{measured:.0f} robot-s of the run's start, {len(events) - 1 - skip} "
                     "conception interval(s) after its first", alive,
                     growth=world_growth(config, alive))


def calibrate_all(configs: Sequence[ExperimentConfig], *, seed: int = 0
                  ) -> tuple[dict[str, BirthCost], float]:
    """:func:`calibrate` each experiment, once per :func:`calibration_key`.

    Returns:
        The birth cost of each experiment by name, and the CPU time the calibration took
        (seconds).
    """
    start = time.process_time()
    measured: dict[tuple[object, ...], BirthCost] = {}
    costs = {}
    for config in configs:
        key = calibration_key(config)
        if key not in measured:
            measured[key] = calibrate(config, seed=seed)
        costs[config.name] = measured[key]
    return costs, time.process_time() - start


def run_robot_seconds(work: RunWork, cost: BirthCost) -> float:
    """Robot-seconds left to simulate in one run.

    Offline: one evaluation per birth left. Online: the initial robots are born together at
    time 0; every later birth takes one conception interval of the world, with ``cost.alive``
    robots in it, or as many as ``cost.growth`` gives at that birth.
    """
    if cost.mode == "online":
        return (work.intervals_left * cost.robot_seconds
                * cost.growth_factor(work.first_interval, work.config.births))
    return work.births_left * cost.robot_seconds


def run_cpu_seconds(work: RunWork, cost: BirthCost) -> float:
    """CPU time left of one run: its robot-seconds at the measured rate. Seconds."""
    return run_robot_seconds(work, cost) / cost.rate if cost.rate > 0 else math.inf


def estimate(work: Sequence[RunWork], costs: Mapping[str, BirthCost], workers: int,
             calibration_cpu: float = 0.0) -> StudyEstimate:
    """The CPU time and wall time of the runs in ``work`` on ``workers`` run slots.

    Runs are scheduled as :func:`~evolution.experiments.app.study.run_study` does: online runs
    first, each on the first worker that is free; the wall time is when the last one ends.

    Args:
        work: The runs left to do.
        costs: The calibrated birth cost of each experiment, by name.
        workers: Runs at once.
        calibration_cpu: CPU time the calibration took (reported). Seconds.
    """
    names = list(dict.fromkeys(w.experiment for w in work))
    per_run = [(w, run_cpu_seconds(w, costs[w.experiment])) for w in work]
    free = [0.0] * max(1, workers)
    ends = dict.fromkeys(names, 0.0)  # when each experiment's last run ends. Seconds
    for w, seconds in sorted(per_run, key=lambda p: p[0].config.mode != "online"):
        if seconds > 0:  # a finished run takes no worker
            end = free[0] + seconds
            heapq.heapreplace(free, end)
            ends[w.experiment] = max(ends[w.experiment], end)
    experiments = []
    for name in names:
        mine = [w for w, _ in per_run if w.experiment == name]
        cost = costs[name]
        robot_seconds = sum(run_robot_seconds(w, cost) for w in mine)
        alive = 0.0
        if cost.mode == "online" and cost.alive > 0:  # robot-seconds over the intervals'
            intervals = sum(w.intervals_left for w in mine)
            if intervals:
                alive = robot_seconds / (intervals * cost.robot_seconds / cost.alive)
        experiments.append(ExperimentEstimate(
            name, cost, len(mine), sum(w.births_left for w in mine),
            robot_seconds, sum(s for w, s in per_run if w.experiment == name), ends[name],
            alive))
    return StudyEstimate(tuple(experiments), max(1, workers), max(free), calibration_cpu)


def _hours(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    minutes = round(seconds / 60)
    return f"{minutes // 60} h {minutes % 60:02d} min" if minutes >= 60 else f"{minutes} min"


def _robot_seconds(value: float) -> str:
    """Robot-seconds in words: ``1.35e6 robot-s (375 robot-h)``."""
    return f"{value:.3g} robot-s ({value / 3600:.3g} robot-h)"
