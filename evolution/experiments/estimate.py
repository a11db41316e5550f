"""How long a study will take, from a short measured calibration on this machine.

:func:`calibrate` measures the CPU time one birth of an experiment costs, in a few seconds:

* offline: :func:`~evolution.evaluation.evaluate_tasks` of a few random robots of the
  experiment's settings (engine, timing, conditions, Training Center), as a run evaluates its
  children; one birth is one evaluation;
* online: one world (:class:`~evolution.experiments.online_world.PopulationWorld`) of a
  typical number of random robots stepped for a few simulated seconds; one birth is one
  conception interval of that world.

:func:`estimate` turns the costs into a study's CPU time and its wall time on ``workers`` run
slots (a run is the unit of parallelism: one run on one worker, online runs first, as
:func:`~evolution.experiments.study.run_study` orders them). What the calibration cannot know
is stated by :data:`ASSUMPTIONS`: random robots are smaller than evolved ones grow, and the
online world's size is assumed. Nothing here writes a file.

Example::

    from evolution.experiments import load_config
    from evolution.experiments.estimate import calibrate, estimate, RunWork

    config = load_config("scenario1", {"world": {"engine": "mujoco"}})
    cost = calibrate(config)
    print(estimate([RunWork("scenario1", config, 3000)] * 30, {"scenario1": cost}, workers=2))
"""

from __future__ import annotations

import heapq
import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from evolution.evaluation import evaluate_tasks
from evolution.experiments.config import ExperimentConfig
from evolution.experiments.offline import evaluation_tasks
from evolution.random_robot import random_robot

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
    "run_cpu_seconds",
    "typical_world_size",
]

ASSUMPTIONS = ("assumes evolved robots cost what random ones do (they grow: expect more), an "
               "online world of the size shown throughout, one run per worker, nothing else "
               "on the cores")
"""What the estimate takes for granted, in one line."""

_OFFLINE_ROBOTS = 4
"""Random robots evaluated by an offline calibration (a few CPU seconds on pybullet)."""
_ONLINE_SECONDS = 3.0
"""Simulated seconds an online calibration steps its world. Seconds."""


@dataclass(frozen=True, slots=True)
class BirthCost:
    """What one birth of an experiment costs, as measured by :func:`calibrate`.

    Attributes:
        mode: ``"offline"`` or ``"online"``.
        engine: The physics engine.
        cpu_per_birth: CPU time of one birth. Seconds.
        sample: What was measured, in words (e.g. ``4 random robots x 15 s``).
        world_size: Online: robots in the calibration world (0 offline).
    """

    mode: str
    engine: str
    cpu_per_birth: float
    sample: str
    world_size: int = 0


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


@dataclass(frozen=True, slots=True)
class ExperimentEstimate:
    """One experiment's share of a study.

    Attributes:
        name: The experiment.
        cost: Its calibrated birth cost.
        runs: Runs left to do.
        births: Births left, all its runs together.
        cpu_seconds: CPU time left, all its runs together. Seconds.
    """

    name: str
    cost: BirthCost
    runs: int
    births: int
    cpu_seconds: float


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
        return {e.name: e.cost.cpu_per_birth for e in self.experiments}

    def lines(self) -> list[str]:
        """The estimate in words: one line per experiment, the total, the assumptions."""
        out = []
        for e in self.experiments:
            size = f", world of {e.cost.world_size} robots" if e.cost.mode == "online" else ""
            out.append(f"  {e.name}: {1e3 * e.cost.cpu_per_birth:.0f} ms CPU per birth "
                       f"({e.cost.mode}, {e.cost.engine}{size}; from {e.cost.sample}), "
                       f"{e.runs} run(s), {e.births} births: {e.cpu_seconds / 3600:.2f} CPU-h")
        out.append(f"  total {self.cpu_seconds / 3600:.2f} CPU-h: about "
                   f"{_hours(self.wall_seconds)} on {self.workers} worker(s) (calibration took "
                   f"{self.calibration_cpu:.1f} s CPU)")
        out.append(f"  (an estimate: it {ASSUMPTIONS})")
        return out


def typical_world_size(config: ExperimentConfig) -> int:
    """Robots an online world holds on average, as the calibration assumes.

    Halfway between ``min_alive`` (after a cull) and ``max_alive`` (when the cull comes): the
    world grows by one robot a conception interval between culls.
    """
    return max(1, round((config.min_alive + config.max_alive) / 2))


def calibration_key(config: ExperimentConfig) -> tuple[object, ...]:
    """What a birth's cost depends on: experiments equal here share one calibration."""
    online = ((config.conception_interval, typical_world_size(config), config.birth_radius)
              if config.mode == "online" else ())
    return (config.mode, config.world.engine, config.insertion, config.evaluation_time,
            config.evaluation, config.evolution, repr(config.learning), *online)


def calibrate(config: ExperimentConfig, *, seed: int = 0, robots: int | None = None,
              seconds: float = _ONLINE_SECONDS) -> BirthCost:
    """Measure the CPU time of one birth of ``config`` on this machine.

    Args:
        config: The experiment.
        seed: Seeds the random robots (and the online world). The cost hardly depends on it.
        robots: Offline: robots evaluated (default 4). Online: robots in the world (default
            :func:`typical_world_size`).
        seconds: Online: simulated time stepped. Seconds.

    Returns:
        The cost of one birth: offline, the CPU time of one evaluation; online, the CPU time of
        one conception interval of the world.
    """
    rng = np.random.default_rng(seed)
    if config.mode == "online":
        size = robots or typical_world_size(config)
        return _calibrate_online(config, rng, size, seconds)
    return _calibrate_offline(config, rng, robots or _OFFLINE_ROBOTS)


def _calibrate_offline(config: ExperimentConfig, rng: np.random.Generator,
                       count: int) -> BirthCost:
    tasks = evaluation_tasks(config, [(i, random_robot(rng, config.evolution),
                                       int(rng.integers(2**31))) for i in range(count + 1)],
                             config.training_center())
    # The first evaluation loads the engine and its caches: a cost a run pays once, not per birth.
    evaluate_tasks([replace(tasks[0], insertion=0.0, seconds=config.evaluation_time / 10,
                            infancy=None)])
    start = time.process_time()
    evaluate_tasks(tasks[1:])
    cpu = time.process_time() - start
    return BirthCost("offline", config.world.engine, cpu / count,
                     f"{count} random robots x {config.seconds_per_evaluation:g} s")


def _calibrate_online(config: ExperimentConfig, rng: np.random.Generator, size: int,
                      seconds: float) -> BirthCost:
    # Imported here: the online world loads the physics engine.
    from evolution.experiments.online_world import PopulationWorld

    world = PopulationWorld(config.replace(births=max(config.births, size)),
                            int(rng.integers(2**31)))
    for robot_id in range(size):
        world.add(random_robot(rng, config.evolution), robot_id)
    world.advance_to(world.time + 0.1)  # the first steps compile and cache: not per birth
    begin = world.time
    start = time.process_time()
    world.advance_to(begin + seconds)
    cpu = time.process_time() - start
    per_second = cpu / max(world.time - begin, 1e-9)
    return BirthCost("online", config.world.engine, per_second * config.conception_interval,
                     f"{size} random robots x {seconds:g} s, scaled to "
                     f"{config.conception_interval:g} s per birth", size)


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


def run_cpu_seconds(work: RunWork, cost: BirthCost) -> float:
    """CPU time left of one run. Seconds.

    Offline: one evaluation per birth left. Online: the initial robots are born together at
    time 0; every later birth takes one conception interval of the world.
    """
    left = max(0, work.config.births - work.done)
    if cost.mode == "online":
        first = max(work.done, work.config.population_size)
        left = max(0, work.config.births - first)
    return left * cost.cpu_per_birth


def estimate(work: Sequence[RunWork], costs: Mapping[str, BirthCost], workers: int,
             calibration_cpu: float = 0.0) -> StudyEstimate:
    """The CPU time and wall time of the runs in ``work`` on ``workers`` run slots.

    Runs are scheduled as :func:`~evolution.experiments.study.run_study` does: online runs
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
    for _, seconds in sorted(per_run, key=lambda p: p[0].config.mode != "online"):
        heapq.heapreplace(free, free[0] + seconds)
    experiments = tuple(
        ExperimentEstimate(
            name, costs[name], sum(w.experiment == name for w, _ in per_run),
            sum(max(0, w.config.births - w.done) for w, _ in per_run if w.experiment == name),
            sum(s for w, s in per_run if w.experiment == name))
        for name in names)
    return StudyEstimate(experiments, max(1, workers), max(free), calibration_cpu)


def _hours(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    minutes = round(seconds / 60)
    return f"{minutes // 60} h {minutes % 60:02d} min" if minutes >= 60 else f"{minutes} min"
